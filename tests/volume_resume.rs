//! Caches: 10 frames straight and 5 frames + `--resume` to 10 give
//! byte-identical PLY files (and the two runs agree on frames 1–5, so the
//! same input gives the same bytes); a frame is complete or absent; the
//! `codimfx sim` and `codimfx preview` commands work end to end.
use codimfx::io::manifest::Manifest;
use codimfx::io::ply;
use codimfx::sim::{RunOptions, Sim};
use std::path::Path;
use std::process::Command;
use std::sync::atomic::AtomicBool;

const SCENE: &str = "\
version: 1
domain: {min: [0, 0, 0], max: [0.3, 0.2, 0.05], dx: 0.0125}
time: {fps: 30, frames: 10, max_dt: 0.01}
physics: {viscosity: 1.0e-3}
bodies:
  - kind: box
    min: [0, 0, 0]
    max: [0.1, 0.12, 0.05]
    spacing: 0.5
  - kind: sphere
    center: [0.2, 0.12, 0.025]
    radius: 0.02
    velocity: [0, -0.5, 0]
solids:
  - kind: box
    min: [0.14, 0.0, 0.0]
    max: [0.18, 0.03, 0.05]
";

fn run(scene: &Path, out: &Path, frames: u32, resume: bool) {
    let opt = RunOptions {
        out_root: Some(out.to_path_buf()),
        frames: Some(frames),
        resume,
        scale: None,
        verbose: false,
    };
    let mut sim = Sim::open(scene, &opt).unwrap();
    sim.run(&AtomicBool::new(false), |_, _| {}).unwrap();
    assert_eq!(sim.frame, frames);
}

#[test]
fn resumed_runs_are_byte_identical_to_straight_runs() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("resume.yaml");
    std::fs::write(&scene, SCENE).unwrap();
    let (a, b) = (dir.path().join("a"), dir.path().join("b"));
    run(&scene, &a, 10, false);
    run(&scene, &b, 5, false);
    run(&scene, &b, 10, true);
    for f in 0..=10 {
        let name = ply::frame_name(f);
        let x = std::fs::read(a.join("resume").join(&name)).unwrap();
        let y = std::fs::read(b.join("resume").join(&name)).unwrap();
        assert!(
            x == y,
            "frame {f} differs between the straight and the resumed run"
        );
    }
    let m = Manifest::read(&b.join("resume/manifest.json")).unwrap();
    assert_eq!(m.frames_written, 10);
    assert_eq!(
        m.frames.iter().map(|r| r.frame).collect::<Vec<_>>(),
        (0..=10).collect::<Vec<_>>()
    );
    let last = &m.frames[10];
    assert!(last.viscosity.solves > 0 && last.stage_s["viscosity"] > 0.0);
    assert!(last.pressure.solves == last.substeps && last.pressure.iterations_max > 0);
    assert_eq!(last.substep_log.len() as u32, last.substeps);
    let dt_sum: f64 = last.substep_log.iter().map(|s| s.dt).sum();
    assert!(
        (dt_sum - 1.0 / 30.0).abs() < 1e-12,
        "substeps cover the frame: {dt_sum}"
    );
    assert!(last
        .substep_log
        .iter()
        .all(|s| s.residual <= 1e-8 && s.iterations > 0));
    // the cache is complete and readable: no temporary files, the same
    // particles (ids; each frame reorders the store in space)
    for e in std::fs::read_dir(b.join("resume")).unwrap() {
        let n = e.unwrap().file_name().to_string_lossy().into_owned();
        assert!(!n.ends_with(".tmp"), "leftover {n}");
    }
    let f0 = ply::read(&a.join("resume").join(ply::frame_name(0))).unwrap();
    let f10 = ply::read(&a.join("resume").join(ply::frame_name(10))).unwrap();
    let sorted = |mut v: Vec<u64>| {
        v.sort_unstable();
        v
    };
    assert_eq!(
        sorted(f0.particles.id.clone()),
        sorted(f10.particles.id.clone())
    );
    assert_eq!(f0.particles.total_mass(), f10.particles.total_mass());
}

#[test]
fn resume_refuses_a_changed_scene() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("resume.yaml");
    std::fs::write(&scene, SCENE).unwrap();
    run(&scene, dir.path(), 1, false);
    std::fs::write(&scene, SCENE.replace("fps: 30", "fps: 24")).unwrap();
    let opt = RunOptions {
        out_root: Some(dir.path().to_path_buf()),
        frames: Some(2),
        resume: true,
        scale: None,
        verbose: false,
    };
    let e = Sim::open(&scene, &opt).err().expect("must refuse");
    assert!(e.to_string().contains("scene file changed"), "{e}");
}

#[test]
fn sim_and_preview_commands_work_end_to_end() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("cli.yaml");
    std::fs::write(&scene, SCENE).unwrap();
    let exe = env!("CARGO_BIN_EXE_codimfx");
    let out = dir.path().join("cache");
    let st = Command::new(exe)
        .args([
            "sim",
            scene.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--frames",
            "3",
            "--threads",
            "2",
        ])
        .output()
        .unwrap();
    assert!(
        st.status.success(),
        "{}",
        String::from_utf8_lossy(&st.stderr)
    );
    let err = String::from_utf8_lossy(&st.stderr);
    assert!(err.contains("| projection |"), "no stage summary in: {err}");
    let cache = out.join("cli");
    assert!(cache.join("particles.0003.ply").exists());
    let st = Command::new(exe)
        .args([
            "preview",
            cache.to_str().unwrap(),
            "--frames",
            "1-3",
            "--width",
            "160",
            "--height",
            "90",
        ])
        .output()
        .unwrap();
    assert!(
        st.status.success(),
        "{}",
        String::from_utf8_lossy(&st.stderr)
    );
    for f in ["frame.0001.png", "frame.0003.png", "contact_sheet.png"] {
        let img = image::open(cache.join("preview").join(f))
            .unwrap()
            .to_rgb8();
        assert!(img.width() >= 160);
        // some pixels show liquid (blue dominant)
        let blue = img
            .pixels()
            .filter(|p| p[2] > 120 && p[2] > p[0] + 40)
            .count();
        assert!(blue > 50, "{f}: {blue} liquid pixels");
    }
    // a bad scene fails with the file and field in the message, before any work
    std::fs::write(&scene, SCENE.replace("dx: 0.0125", "dx: -1")).unwrap();
    let st = Command::new(exe)
        .args([
            "sim",
            scene.to_str().unwrap(),
            "-o",
            dir.path().join("bad").to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(!st.status.success());
    let err = String::from_utf8_lossy(&st.stderr);
    assert!(
        err.contains("cli.yaml:2:") && err.contains("domain.dx"),
        "{err}"
    );
    assert!(!dir.path().join("bad").exists());
}

#[test]
fn results_do_not_depend_on_the_thread_count() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("resume.yaml");
    std::fs::write(&scene, SCENE).unwrap();
    for threads in [1, 3] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let out = dir.path().join(format!("t{threads}"));
        pool.install(|| run(&scene, &out, 3, false));
    }
    for f in 1..=3 {
        let name = ply::frame_name(f);
        let x = std::fs::read(dir.path().join("t1/resume").join(&name)).unwrap();
        let y = std::fs::read(dir.path().join("t3/resume").join(&name)).unwrap();
        assert!(x == y, "frame {f} differs between 1 and 3 threads");
    }
}
