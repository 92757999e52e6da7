//! `codimfx bench surface`: the surfacer on a ~860k-particle volume blob (a sphere above a slab,
//! jittered lattice of spacing 0.0125 m) at voxel size = particle radius (spacing/2): wall time
//! per stage, peak memory, triangles. When a `splashsurf` binary is on PATH the same particles
//! run through it (isotropic kernels, same radius and cube size) and the ratios are printed.
use anyhow::{Context, Result};
use clap::Args;
use std::io::Write;
use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};
use surfacer::{ParticleFrame, SurfaceOptions, Vec3};

/// Arguments of `codimfx bench surface`.
#[derive(Args, Debug)]
pub struct SurfaceBenchArgs {
    /// Particle spacing (m).
    #[arg(long, default_value_t = 0.0125)]
    spacing: f64,
    /// Sphere radius (m).
    #[arg(long, default_value_t = 0.55)]
    sphere_radius: f64,
    /// Slab side (m), square in x and y.
    #[arg(long, default_value_t = 2.0)]
    slab_side: f64,
    /// Slab thickness (m).
    #[arg(long, default_value_t = 0.25)]
    slab_thickness: f64,
    /// Also run with isotropic kernels.
    #[arg(long)]
    isotropic_too: bool,
    /// Add a sheet (disk of sheet particles), a helix filament and a few point particles around
    /// the blob, to exercise every codimension (used by .ci/dcc.sh).
    #[arg(long)]
    extras: bool,
    /// Write the outputs (VDB and PLY) to this folder and time that as well.
    #[arg(long)]
    write: Option<std::path::PathBuf>,
    /// Run the comparison this many times, codimfx and splashsurf alternating (the blob is
    /// regenerated for each run), and print every ratio with their median: single runs on a
    /// shared machine scatter by ±5 %.
    #[arg(long, default_value_t = 1)]
    repeat: usize,
}

fn rand01(s: &mut u64) -> f64 {
    *s = s.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *s;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
}

/// The blob: a slab z ∈ [0, t], |x|,|y| ≤ side/2, and a sphere resting 0.05 m above it;
/// lattice jittered by ±0.1 spacing.
fn blob(a: &SurfaceBenchArgs) -> ParticleFrame {
    let dx = a.spacing;
    let mut f = ParticleFrame::default();
    let mut s = 1u64;
    let ps = dx * (3.0 / (4.0 * std::f64::consts::PI)).cbrt();
    let c = Vec3::new(0.0, 0.0, a.slab_thickness + 0.05 + a.sphere_radius);
    let half = a.slab_side / 2.0;
    let n = ((half.max(c.z + a.sphere_radius)) / dx).ceil() as i64 + 1;
    for i in -n..=n {
        for j in -n..=n {
            for k in 0..=(2 * n) {
                let p = Vec3::new(i as f64, j as f64, k as f64) * dx;
                let in_slab = p.x.abs() <= half && p.y.abs() <= half && p.z <= a.slab_thickness;
                let in_ball = (p - c).norm() <= a.sphere_radius;
                if in_slab || in_ball {
                    let mut jit = || (rand01(&mut s) - 0.5) * 0.2 * dx;
                    let q = p + Vec3::new(jit(), jit(), jit());
                    let v = if in_ball {
                        Vec3::new(0.0, 0.0, -1.0)
                    } else {
                        Vec3::zeros()
                    };
                    let id = f.len() as u32;
                    f.push(q, v, id, 0, ps, 1000.0 * dx * dx * dx, Vec3::zeros());
                }
            }
        }
    }
    if a.extras {
        add_extras(&mut f, a);
    }
    f
}

/// A horizontal sheet beside the slab, a helix above it, and three droplets.
fn add_extras(f: &mut ParticleFrame, a: &SurfaceBenchArgs) {
    let ds = a.spacing;
    let th = 0.2 * ds;
    let x0 = a.slab_side / 2.0 + 4.0 * ds + 0.25 * a.slab_side;
    let n = (0.25 * a.slab_side / ds) as i64;
    for i in -n..=n {
        for j in -n..=n {
            let p = Vec3::new(x0 + i as f64 * ds, j as f64 * ds, 0.5 * a.slab_thickness);
            let id = f.len() as u32;
            f.push(
                p,
                Vec3::new(0.0, 0.0, 0.5),
                id,
                1,
                0.5 * th,
                1000.0 * ds * ds * th,
                Vec3::z(),
            );
        }
    }
    let (r, pitch, rt) = (0.2 * a.slab_side, 0.1 * a.slab_side, 0.4 * ds);
    let c = pitch / (2.0 * std::f64::consts::PI);
    let speed = (r * r + c * c).sqrt();
    let steps = (3.0 * 2.0 * std::f64::consts::PI * speed / (0.5 * ds)) as i64;
    for i in 0..=steps {
        let t = i as f64 * 0.5 * ds / speed;
        let p = Vec3::new(
            -x0 + r * t.cos(),
            r * t.sin(),
            a.slab_thickness + 2.0 * ds + c * t,
        );
        let tan = Vec3::new(-r * t.sin(), r * t.cos(), c) / speed;
        let id = f.len() as u32;
        let m = 1000.0 * std::f64::consts::PI * rt * rt * 0.5 * ds;
        f.push(p, tan, id, 2, rt, m, tan);
    }
    for k in 0..3 {
        let p = Vec3::new(
            0.3 * a.slab_side,
            (k as f64 - 1.0) * 0.1 * a.slab_side,
            a.slab_thickness + 0.2 * a.slab_side,
        );
        let id = f.len() as u32;
        f.push(
            p,
            Vec3::new(0.0, 0.0, -2.0),
            id,
            3,
            0.6 * ds,
            1000.0 * ds.powi(3),
            Vec3::zeros(),
        );
    }
}

/// CPU seconds (user + system) of this process and of its waited-for children, from
/// /proc/self/stat (clock ticks of 1/100 s, Linux's USER_HZ).
fn cpu_times() -> (f64, f64) {
    let s = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    // fields after the command name in parentheses: utime stime cutime cstime are 14–17
    let rest = s.rsplit_once(')').map_or("", |r| r.1);
    let f: Vec<f64> = rest
        .split_whitespace()
        .map(|x| x.parse::<f64>().unwrap_or(0.0))
        .collect();
    let at = |i: usize| f.get(i - 3).copied().unwrap_or(0.0) / 100.0;
    (at(14) + at(15), at(16) + at(17))
}

/// Peak resident memory of a process (VmHWM, bytes), from /proc.
fn peak_rss(pid: &str) -> Option<u64> {
    let s = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    let l = s.lines().find(|l| l.starts_with("VmHWM:"))?;
    l.split_whitespace()
        .nth(1)?
        .parse::<u64>()
        .ok()
        .map(|k| k * 1024)
}

fn which(name: &str) -> Option<std::path::PathBuf> {
    std::env::var_os("PATH").and_then(|p| {
        std::env::split_paths(&p)
            .map(|d| d.join(name))
            .find(|p| p.is_file())
    })
}

/// Writes the particles' positions as splashsurf's `.xyz` (f32 triples).
fn write_xyz(f: &ParticleFrame, input: &Path) -> Result<()> {
    let mut w = std::io::BufWriter::new(std::fs::File::create(input)?);
    for p in &f.pos {
        for c in [p.x, p.y, p.z] {
            w.write_all(&(c as f32).to_le_bytes())?;
        }
    }
    w.flush()?;
    Ok(())
}

/// Runs splashsurf on the particles in `input` (`.xyz`); returns (wall s, peak bytes).
fn run_splashsurf(bin: &Path, input: &Path, radius: f64, dir: &Path) -> Result<(f64, u64)> {
    let t = Instant::now();
    let mut child = Command::new(bin)
        .arg("reconstruct")
        .arg(input)
        .arg("-o")
        .arg(dir.join("blob.ply"))
        .arg(format!("--particle-radius={radius}"))
        .arg("--smoothing-length=2.0")
        .arg("--cube-size=1.0")
        .arg("--surface-threshold=0.6")
        .stdout(std::process::Stdio::null())
        .spawn()
        .context("starting splashsurf")?;
    let pid = child.id().to_string();
    let mut peak = 0;
    loop {
        if let Some(st) = child.try_wait()? {
            anyhow::ensure!(st.success(), "splashsurf failed: {st}");
            break;
        }
        peak = peak.max(peak_rss(&pid).unwrap_or(0));
        std::thread::sleep(Duration::from_millis(5));
    }
    // polling can miss the last milliseconds: the kernel's record of the waited-for children's
    // largest resident set is exact (splashsurf is this process's only child)
    Ok((t.elapsed().as_secs_f64(), peak.max(children_max_rss())))
}

/// Largest peak RSS (bytes) of this process's waited-for children (`getrusage(RUSAGE_CHILDREN)`),
/// 0 where unavailable.
fn children_max_rss() -> u64 {
    #[cfg(all(target_os = "linux", target_arch = "x86_64"))]
    {
        extern "C" {
            fn getrusage(who: i32, usage: *mut i64) -> i32;
        }
        // struct rusage on x86-64 Linux: two timevals (4 × i64), then 14 longs, ru_maxrss (KiB)
        // first among them
        let mut r = [0i64; 18];
        // SAFETY: r is as large as struct rusage and suitably aligned
        if unsafe { getrusage(-1, r.as_mut_ptr()) } == 0 {
            return r[4].max(0) as u64 * 1024;
        }
    }
    0
}

/// Surfaces `frame` once (and writes it when asked); prints the table row (and the stage counts
/// when `report`); returns (total s, peak RSS bytes of this process, CPU s).
fn surface_once(
    frame: ParticleFrame,
    aniso: bool,
    radius: f64,
    n_volume: usize,
    a: &SurfaceBenchArgs,
    report: bool,
) -> Result<(f64, u64, f64)> {
    let mut o = SurfaceOptions {
        voxel_size: Some(radius),
        ..Default::default()
    };
    o.aniso.anisotropic = aniso;
    let t = Instant::now();
    let cpu0 = cpu_times().0;
    let g = surfacer::surface_frame(frame, &o)?;
    let mut total = t.elapsed().as_secs_f64();
    let mut wt = 0.0;
    if let Some(dir) = &a.write {
        std::fs::create_dir_all(dir)?;
        let t = Instant::now();
        surfacer::pipeline::write_outputs(dir, 1, &g)?;
        wt = t.elapsed().as_secs_f64();
        total += wt;
    }
    let cpu = cpu_times().0 - cpu0;
    let peak = peak_rss("self").unwrap_or(0);
    let st = &g.stats;
    let pvol = n_volume as f64 * a.spacing.powi(3);
    println!(
        "| {} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.0} | {} | {} | {} | {:+.2} % |",
        if aniso { "anisotropic" } else { "isotropic" },
        total,
        st.seconds[0],
        st.seconds[1],
        st.seconds[2],
        st.seconds[3],
        st.seconds[4],
        wt,
        peak as f64 / 1e6,
        st.leaves,
        st.active_voxels,
        st.triangles,
        100.0 * (g.mesh.volume() / pvol - 1.0)
    );
    if report {
        eprintln!(
            "  {}: deep kernels {}, band blocks {}, interior blocks {}, grid bytes {:.0} MB, isotropic kernels {}, redistance {:?}, volume shift {:.2e} m",
            if aniso { "anisotropic" } else { "isotropic" },
            st.deep_kernels,
            st.density_blocks,
            st.interior_blocks,
            st.grid_bytes as f64 / 1e6,
            st.isotropic_kernels,
            st.redistance,
            st.volume_shift
        );
    }
    Ok((total, peak, cpu))
}

/// Runs the benchmark and prints a markdown table.
pub fn run(a: SurfaceBenchArgs) -> Result<()> {
    // large stage buffers go back to the system when freed (surfacer::alloc), as in
    // `codimfx surface`
    surfacer::alloc::return_freed_memory();
    let t = Instant::now();
    let f = blob(&a);
    let gen = t.elapsed().as_secs_f64();
    let radius = a.spacing / 2.0;
    let before = peak_rss("self").unwrap_or(0);
    println!(
        "particles: {} (sphere r = {} m on a {}×{}×{} m slab, spacing {} m, jitter ±0.1), voxel {} m, threads {}, generated in {:.2} s, RSS before surfacing {:.0} MB\n",
        f.len(),
        a.sphere_radius,
        a.slab_side,
        a.slab_side,
        a.slab_thickness,
        a.spacing,
        radius,
        rayon::current_num_threads(),
        gen,
        before as f64 / 1e6
    );
    println!("| kernels | total (s) | kernels | density | band | union | mesh | write | peak RSS (MB) | leaves | active voxels | triangles | volume err |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    let modes: &[bool] = if a.isotropic_too {
        &[true, false]
    } else {
        &[true]
    };
    // splashsurf's input is written now: the frame is handed over to the surfacer (as
    // `codimfx surface` does with each frame it reads), which frees it after taking the volume
    // particles' data
    let splash = which("splashsurf");
    let dir = tempfile_dir()?;
    let xyz = dir.join("blob.xyz");
    if splash.is_some() {
        write_xyz(&f, &xyz)?;
    }
    let n_volume = f.codim.iter().filter(|&&c| c == 0).count();
    let mut f = Some(f);
    // (codimfx wall, codimfx CPU, splashsurf wall, splashsurf CPU) per run; peak memory from the
    // first run only: this process's high-water mark never falls, and a child's recorded peak
    // includes its parent's at the spawn (exec keeps the larger of the two)
    let mut runs: Vec<(f64, f64, f64, f64)> = Vec::new();
    let mut peaks = (0u64, 0u64);
    for rep in 0..a.repeat.max(1) {
        let mut ours = (0.0, 0.0);
        for (m, &aniso) in modes.iter().enumerate() {
            let frame = match f.take() {
                Some(fr) if m + 1 < modes.len() => {
                    let c = fr.clone();
                    f = Some(fr);
                    c
                }
                Some(fr) => fr,
                None => blob(&a),
            };
            let (total, peak, cpu) = surface_once(frame, aniso, radius, n_volume, &a, rep == 0)?;
            if aniso {
                ours = (total, cpu);
                if rep == 0 {
                    peaks.0 = peak;
                }
            }
        }
        if let Some(bin) = &splash {
            let c0 = cpu_times().1;
            let (ts, ps) = run_splashsurf(bin, &xyz, radius, &dir)?;
            let cs = cpu_times().1 - c0;
            if rep == 0 {
                peaks.1 = ps;
            }
            runs.push((ours.0, ours.1, ts, cs));
        } else {
            runs.push((ours.0, ours.1, 0.0, 0.0));
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    if splash.is_none() {
        println!("\nsplashsurf: not on PATH, comparison skipped (cargo install splashsurf)");
        return Ok(());
    }
    for (k, r) in runs.iter().enumerate() {
        println!(
            "\nrun {}: splashsurf (isotropic) {:.2} s, CPU {:.2} s; codimfx anisotropic {:.2} s, CPU {:.2} s (user + system, surfacing and writing): time × {:.2}, CPU × {:.2}",
            k + 1,
            r.2,
            r.3,
            r.0,
            r.1,
            r.0 / r.2,
            r.1 / r.3.max(0.01)
        );
    }
    let median = |mut v: Vec<f64>| {
        v.sort_by(|x, y| x.total_cmp(y));
        let n = v.len();
        if n % 2 == 1 {
            v[n / 2]
        } else {
            0.5 * (v[n / 2 - 1] + v[n / 2])
        }
    };
    let t: Vec<f64> = runs.iter().map(|r| r.0 / r.2).collect();
    let c: Vec<f64> = runs.iter().map(|r| r.1 / r.3.max(0.01)).collect();
    let (tmin, tmax) = t
        .iter()
        .fold((f64::MAX, 0.0f64), |m, &x| (m.0.min(x), m.1.max(x)));
    println!(
        "\npeak RSS (first run): splashsurf {:.0} MB, codimfx {:.0} MB",
        peaks.1 as f64 / 1e6,
        peaks.0 as f64 / 1e6
    );
    println!(
        "codimfx anisotropic / splashsurf over {} run(s): time × {:.2} (median; {:.2}–{:.2}), CPU × {:.2} (median), memory × {:.2}",
        runs.len(),
        median(t),
        tmin,
        tmax,
        median(c),
        peaks.0 as f64 / peaks.1 as f64
    );
    Ok(())
}

fn tempfile_dir() -> Result<std::path::PathBuf> {
    let d = std::env::temp_dir().join(format!("codimfx-bench-surface-{}", std::process::id()));
    std::fs::create_dir_all(&d)?;
    Ok(d)
}
