//! Outputs read by real clients: the cache round trip, the sequence driver (`--frames`,
//! `name.####.ext`), OpenVDB's own `vdb_print` and Python module (Debian `libopenvdb-tools`,
//! `python3-openvdb`; `.ci/run` installs them), vdb-rs, and ply-rs-bw for the PLY meshes.
mod common;
use common::*;
use std::path::Path;
use std::process::Command;
use surfacer::cache::{frame_path, read_frame, write_frame};
use surfacer::pipeline::output_path;
use surfacer::{surface_cache, ParticleFrame, Real, SurfaceOptions, Vec3};

const R_BALL: Real = 0.6;

fn sphere_cache(dir: &Path, frames: u32) -> Real {
    let mut r = 0.0;
    for n in 1..=frames {
        let mut f = ParticleFrame::default();
        r = shell_ball(
            &mut f,
            Vec3::zeros(),
            R_BALL,
            0.05,
            0.2,
            Vec3::new(0.5, 0.0, 0.0),
        );
        if n > 1 {
            // later frames move the ball, so frames differ
            for p in f.pos.iter_mut() {
                p.x += 0.1 * (n - 1) as Real;
            }
        }
        write_frame(&frame_path(dir, n), &f, n, n as Real / 24.0).unwrap();
    }
    r
}

fn tool(name: &str) -> String {
    for d in ["/usr/bin", "/usr/local/bin"] {
        let p = format!("{d}/{name}");
        if Path::new(&p).exists() {
            return p;
        }
    }
    panic!("{name} not found in /usr/bin or /usr/local/bin: install Debian's libopenvdb-tools and python3-openvdb (.ci/run does)");
}

#[test]
fn cache_round_trip_is_exact_and_bad_values_are_named() {
    let d = tempfile::tempdir().unwrap();
    let mut f = ParticleFrame::default();
    ball(
        &mut f,
        Vec3::zeros(),
        0.2,
        0.05,
        0.3,
        Vec3::new(0.1, 0.2, 0.3),
    );
    helix(&mut f, 0.1, 0.05, 1.0, 0.01, 0.003);
    let p = frame_path(d.path(), 7);
    write_frame(&p, &f, 7, 0.29).unwrap();
    let g = read_frame(&p).unwrap();
    assert_eq!(g.pos, f.pos);
    assert_eq!(g.vel, f.vel);
    assert_eq!(g.codim, f.codim);
    assert_eq!(g.id, f.id);
    assert_eq!(g.frame, f.frame);
    // a NaN is reported with file, index and property
    f.mass[3] = Real::NAN;
    write_frame(&p, &f, 7, 0.29).unwrap();
    let e = read_frame(&p).unwrap_err().to_string();
    assert!(e.contains("particle 3") && e.contains("mass"), "{e}");
}

#[test]
fn sequence_outputs_open_in_openvdb_and_match_the_sphere() {
    let cache = tempfile::tempdir().unwrap();
    let out = tempfile::tempdir().unwrap();
    let r = sphere_cache(cache.path(), 3);
    let done = surface_cache(
        cache.path(),
        out.path(),
        Some((2, 3)),
        &SurfaceOptions::default(),
        &|_, _| {},
    )
    .unwrap();
    assert_eq!(done, vec![2, 3]);
    for name in ["surface.0001.vdb", "mesh.0001.ply"] {
        assert!(!out.path().join(name).exists(), "{name} outside --frames");
    }
    let mut names: Vec<String> = std::fs::read_dir(out.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    names.sort();
    assert_eq!(
        names,
        [
            "filaments.0002.ply",
            "filaments.0003.ply",
            "mesh.0002.ply",
            "mesh.0003.ply",
            "sheets.0002.ply",
            "sheets.0003.ply",
            "surface.0002.vdb",
            "surface.0003.vdb"
        ]
    );
    let vdb = output_path(out.path(), "surface", 2, "vdb");

    // vdb_print lists both grids
    let o = Command::new(tool("vdb_print"))
        .args(["-l", "-m"])
        .arg(&vdb)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&o.stdout).to_string() + &String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "vdb_print failed: {text}");
    assert!(text.contains("surface") && text.contains("float"), "{text}");
    assert!(text.contains("level set"), "{text}");
    assert!(text.contains("contravariant relative"), "{text}");
    assert!(
        text.lines()
            .any(|l| l.starts_with("Name: v") || l.contains(" v "))
            || text.contains("vec3s"),
        "{text}"
    );

    // pyopenvdb: voxel values against the analytic SDF, inside/outside, its own mesher
    let script = r#"
import sys, math, pyopenvdb as vdb
path, r, cx = sys.argv[1], float(sys.argv[2]), float(sys.argv[3])
g = vdb.read(path, 'surface')
v = vdb.read(path, 'v')
h = g.transform.voxelSize()[0]
acc = g.getConstAccessor()
n = 0; s = 0.0; s2 = 0.0; mx = 0.0
for item in g.citerOnValues():
    if item.count != 1: continue
    i, j, k = item.min
    x, y, z = i * h - cx, j * h, k * h
    exact = math.sqrt(x*x + y*y + z*z) - r
    if abs(exact) < h:
        e = item.value - exact
        n += 1; s += e; s2 += e*e; mx = max(mx, abs(e))
ci = int(round(cx / h))
inside = acc.getValue((ci, 0, 0))
far = acc.getValue((ci + int(3 * r / h), 0, 0))
pts, quads = g.convertToQuads(0.0)
rad = [math.sqrt((p[0]-cx)**2 + p[1]**2 + p[2]**2) - r for p in pts]
mm = sum(rad) / len(rad)
rms = math.sqrt(sum(e*e for e in rad) / len(rad))
vx = v.getConstAccessor().getValue((ci + int(round(r / h)), 0, 0))[0]
print(g.gridClass.replace(' ', '_'), g.background, n, s/n/h, math.sqrt(s2/n)/h, mx/h, inside, far, len(quads), mm/h, rms/h, vx)
"#;
    let o = Command::new(tool("python3"))
        .arg("-c")
        .arg(script)
        .arg(&vdb)
        .arg(r.to_string())
        .arg("0.1")
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&o.stdout).to_string();
    assert!(
        o.status.success(),
        "pyopenvdb failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    eprintln!("pyopenvdb: {text}");
    let w: Vec<&str> = text.split_whitespace().collect();
    assert_eq!(w[0], "level_set");
    let num = |i: usize| w[i].parse::<Real>().unwrap();
    let bg = num(1);
    assert!(num(2) > 1000.0, "near-surface voxels read: {}", w[2]);
    assert!(
        num(3).abs() < 0.25 && num(4) < 0.5,
        "voxel values vs SDF: mean {} rms {} voxels",
        w[3],
        w[4]
    );
    assert!(num(5) < 0.5, "max {} voxels", w[5]);
    assert_eq!(num(6), -bg, "centre must read as inside (−background)");
    assert_eq!(num(7), bg, "far voxel must read as outside");
    assert!(num(8) > 1000.0);
    assert!(
        num(9).abs() < 0.25 && num(10) < 0.5,
        "OpenVDB mesher vs sphere: mean {} rms {} voxels",
        w[9],
        w[10]
    );
    assert!(
        (num(11) - 0.5).abs() < 1e-3,
        "velocity grid v.x = {}",
        w[11]
    );

    // vdb-rs reads the same grid
    let f = std::io::BufReader::new(std::fs::File::open(&vdb).unwrap());
    let mut rd = vdb_rs::VdbReader::new(f).unwrap();
    let mut grids = rd.available_grids();
    grids.sort();
    assert_eq!(grids, ["surface", "v"]);
    let grid = rd.read_grid::<f32>("surface").unwrap();
    let active = grid.iter().count();
    assert!(active > 1000, "vdb-rs reads {active} active voxels");

    // the PLY mesh reads back with its properties
    let mesh_path = output_path(out.path(), "mesh", 2, "ply");
    let mut f = std::fs::File::open(&mesh_path).unwrap();
    let ply = ply_rs_bw::parser::Parser::<ply_rs_bw::ply::DefaultElement>::new()
        .read_ply(&mut f)
        .unwrap();
    let v = &ply.payload["vertex"];
    let faces = &ply.payload["face"];
    assert!(v.len() > 1000 && faces.len() > 2000);
    for key in ["x", "y", "z", "nx", "ny", "nz", "vx", "vy", "vz"] {
        assert!(v[0].contains_key(key), "mesh PLY lacks {key}");
    }
}
