//! Film-only scenes through `codimfx sim`'s library entry point: no grid
//! stage runs, mass is conserved, ring particles stay fixed across a resume,
//! and a resumed run writes the same bytes as a straight one.
use codimfx::io::manifest::Manifest;
use codimfx::sim::{RunOptions, Sim};
use std::path::Path;
use std::sync::atomic::AtomicBool;

/// The shipped catenoid preset at a coarse resolution (dx × 2.5, ~4k particles).
fn coarse_catenoid(dir: &Path) -> std::path::PathBuf {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/presets/catenoid.yaml"
    ))
    .unwrap();
    let text = text.replace("dx: 0.00133 ", "dx: 0.003325");
    assert!(text.contains("dx: 0.003325"), "preset dx line changed");
    let p = dir.join("catenoid.yaml");
    std::fs::write(&p, text).unwrap();
    p
}

fn run(scene: &Path, out: &Path, frames: u32, resume: bool) -> Sim {
    let mut sim = Sim::open(
        scene,
        &RunOptions {
            out_root: Some(out.to_path_buf()),
            frames: Some(frames),
            resume,
            scale: None,
        },
    )
    .unwrap();
    sim.run(&AtomicBool::new(false), |_, _| {}).unwrap();
    sim
}

#[test]
fn catenoid_preset_runs_without_grid_and_conserves_mass() {
    let tmp = tempfile::tempdir().unwrap();
    let scene = coarse_catenoid(tmp.path());
    let sim = run(&scene, tmp.path(), 3, false);
    let m = Manifest::read(&tmp.path().join("catenoid/manifest.json")).unwrap();
    assert_eq!(m.frames_written, 3);
    let m0 = m.frames[0].total_mass;
    for r in &m.frames[1..] {
        for grid_stage in ["p2g", "projection", "g2p", "viscosity", "body_force"] {
            assert_eq!(
                r.stage_s[grid_stage], 0.0,
                "grid stage {grid_stage} ran in a film-only scene"
            );
        }
        assert!(r.stage_s["tension"] > 0.0 && r.tension.solves > 0);
        assert_eq!(r.tension.unconverged, 0);
        assert!(
            (r.total_mass - m0).abs() <= 1e-12 * m0,
            "mass {} vs {m0}",
            r.total_mass
        );
        assert_eq!(r.counts["volume"], 0);
    }
    // the rings are still there and still fixed
    let fixed = sim.state.particles.fixed.iter().filter(|f| **f).count();
    assert!(fixed > 100, "{fixed} fixed particles");
    // the film moved inwards (catenoid neck) but stayed between the rings
    let p = &sim.state.particles;
    let r_min = (0..p.len())
        .filter(|&i| !p.fixed[i])
        .map(|i| p.x[i].x.hypot(p.x[i].y))
        .fold(1.0, f64::min);
    assert!(r_min < 0.0512 - 1e-4 && r_min > 0.04, "{r_min}");
}

#[test]
fn film_resume_is_byte_identical() {
    let tmp = tempfile::tempdir().unwrap();
    let scene = coarse_catenoid(tmp.path());
    let a = tmp.path().join("a");
    let b = tmp.path().join("b");
    run(&scene, &a, 4, false);
    run(&scene, &b, 2, false);
    let resumed = run(&scene, &b, 4, true);
    assert!(
        resumed.state.particles.fixed.iter().any(|f| *f),
        "fixed flags lost on resume"
    );
    for f in 1..=4 {
        let name = format!("catenoid/particles.{f:04}.ply");
        let x = std::fs::read(a.join(&name)).unwrap();
        let y = std::fs::read(b.join(&name)).unwrap();
        assert!(x == y, "frame {f} differs after resume");
    }
}
