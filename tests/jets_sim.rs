//! Jets in the frame loop: emission per substep with exact layer times (the
//! particle count after a frame is the number of layers emitted by then times
//! the circle pattern, plus what reseeding inserted and removed), the per-frame `emitted` count in the manifest, resume
//! byte-identical across emission, `--scale`, and `codimfx sim` without a
//! scene running the built-in dripping preset.
use codimfx::emitter::circle_pattern;
use codimfx::io::manifest::Manifest;
use codimfx::io::ply;
use codimfx::particles::Codim;
use codimfx::sim::{RunOptions, Sim};
use std::path::Path;
use std::process::Command;
use std::sync::atomic::AtomicBool;

/// A nozzle (pipe) pointing down with a jet starting at 10 ms and stopping at 90 ms.
const SCENE: &str = "\
version: 1
domain: {min: [0, 0, 0], max: [0.064, 0.1, 0.064], dx: 0.004}
time: {fps: 50, frames: 6, max_dt: 0.005}
physics: {surface_tension: 0.03}
jets:
  - origin: [0.032, 0.085, 0.032]
    direction: [0, -1, 0]
    radius: 0.008
    speed: 0.2
    start: 0.01
    stop: 0.09
solids:
  - kind: pipe
    center: [0.032, 0.088, 0.032]
    axis: [0, 1, 0]
    inner_radius: 0.009
    outer_radius: 0.014
    height: 0.016
";

fn run(scene: &Path, out: &Path, frames: u32, resume: bool, scale: Option<f64>) -> Sim {
    let opt = RunOptions {
        out_root: Some(out.to_path_buf()),
        frames: Some(frames),
        resume,
        scale,
        verbose: false,
    };
    let mut sim = Sim::open(scene, &opt).unwrap_or_else(|e| panic!("{e}"));
    sim.run(&AtomicBool::new(false), |_, _| {})
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(sim.frame, frames);
    sim
}

#[test]
fn jets_emit_exact_layers_and_resume_byte_identically() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("jet.yaml");
    std::fs::write(&scene, SCENE).unwrap();
    let (a, b) = (dir.path().join("a"), dir.path().join("b"));
    let sim = run(&scene, &a, 6, false, None);
    run(&scene, &b, 3, false, None);
    run(&scene, &b, 6, true, None);
    for f in 0..=6 {
        let name = ply::frame_name(f);
        let x = std::fs::read(a.join("jet").join(&name)).unwrap();
        let y = std::fs::read(b.join("jet").join(&name)).unwrap();
        assert!(
            x == y,
            "frame {f} differs between the straight and the resumed run"
        );
    }
    // resuming from an empty frame 0 (the jet has not started yet)
    let c = dir.path().join("c");
    run(&scene, &c, 0, false, None);
    run(&scene, &c, 2, true, None);
    for f in 0..=2 {
        let name = ply::frame_name(f);
        let x = std::fs::read(a.join("jet").join(&name)).unwrap();
        let y = std::fs::read(c.join("jet").join(&name)).unwrap();
        assert!(x == y, "frame {f} differs after resuming from frame 0");
    }
    let m = Manifest::read(&a.join("jet/manifest.json")).unwrap();
    let (mb, jet) = (
        Manifest::read(&b.join("jet/manifest.json")).unwrap(),
        &sim.jets[0],
    );
    assert_eq!(m.scale, 1.0);
    let per_layer = circle_pattern(jet.radius, jet.spacing, 0.0).len() as u64;
    assert_eq!(
        per_layer,
        circle_pattern(jet.radius, jet.spacing, 0.5).len() as u64
    );
    // frame 0 is empty (the jet starts at 10 ms); afterwards the count is
    // exactly the layers emitted by t = f / fps, and nothing after the stop
    assert_eq!(m.frames[0].counts.values().sum::<usize>(), 0);
    let (mut total, mut reseeded) = (0, 0i64);
    for (r, rb) in m.frames.iter().zip(&mb.frames) {
        total += r.emitted;
        reseeded += r.reseed.inserted() as i64 - r.reseed.removed() as i64;
        assert_eq!(r.emitted, rb.emitted, "frame {}", r.frame);
        // every particle was emitted, or inserted by reseeding (§9)
        let n: usize = r.counts.values().sum();
        assert_eq!(n as i64, total as i64 + reseeded, "frame {}", r.frame);
        assert_eq!(
            total,
            jet.layers_by(r.time) * per_layer,
            "frame {}",
            r.frame
        );
        assert!(r.counts["sheet"] > 0 || r.frame == 0);
    }
    // 80 ms of emission at one layer per s/v: ⌈0.08 / (s/v)⌉ layers
    assert_eq!(total, (0.08 / jet.period()).ceil() as u64 * per_layer);
    assert_eq!(m.frames[6].emitted, 0);
    assert!(m.frames[1].emitted > 0 && m.frames[5].emitted > 0);
    // emitted with mass ρ s³ per particle; reseeding redistributes it
    // exactly; the liquid left the nozzle and fell
    let last = ply::read(&a.join("jet").join(ply::frame_name(6))).unwrap();
    let p = &last.particles;
    let m0 = 1000.0 * jet.spacing.powi(3);
    let mass: f64 = p.mass.iter().sum();
    assert!((mass - m0 * total as f64).abs() < 1e-12 * mass, "{mass}");
    assert!(p.mass.iter().all(|&m| m > 0.0));
    assert!(p.x.iter().all(|x| x.iter().all(|c| c.is_finite())));
    let ymean = p.x.iter().map(|x| x.y).sum::<f64>() / p.len() as f64;
    assert!(ymean < 0.07, "mean height {ymean}");
    assert!(p.codim.contains(&Codim::Sheet));
}

#[test]
fn scale_coarsens_the_run_and_is_kept_on_resume() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("jet.yaml");
    std::fs::write(&scene, SCENE).unwrap();
    let full = run(&scene, &dir.path().join("s1"), 2, false, None);
    let out = dir.path().join("s2");
    let half = run(&scene, &out, 1, false, Some(2.0));
    assert_eq!(half.scene.domain.dx, 0.008);
    assert_eq!(half.jets[0].spacing, 2.0 * full.jets[0].spacing);
    // resuming without --scale keeps the cache's scale; another scale is refused
    let half = run(&scene, &out, 2, true, None);
    assert_eq!(half.scene.domain.dx, 0.008);
    let m = Manifest::read(&out.join("jet/manifest.json")).unwrap();
    assert_eq!((m.scale, m.dx, m.frames_written), (2.0, 0.008, 2));
    let opt = RunOptions {
        out_root: Some(out.clone()),
        frames: Some(3),
        resume: true,
        scale: Some(1.0),
        verbose: false,
    };
    let e = Sim::open(&scene, &opt).err().expect("must refuse");
    assert!(e.to_string().contains("--scale 2"), "{e}");
    // half the resolution: per layer ~1/4 of the particles, half the layers
    let (n1, n2) = (full.state.particles.len(), half.state.particles.len());
    let r = n1 as f64 / n2 as f64;
    assert!(r > 5.0 && r < 12.0, "{n1} vs {n2} particles");
}

#[test]
fn sim_without_a_scene_runs_the_built_in_dripping_preset() {
    let dir = tempfile::tempdir().unwrap();
    let exe = env!("CARGO_BIN_EXE_codimfx");
    let st = Command::new(exe)
        .current_dir(dir.path())
        .args(["sim", "--frames", "1", "--scale", "2", "--threads", "2"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&st.stderr);
    assert!(st.status.success(), "{err}");
    assert!(
        err.contains("no scene given") && err.contains("built into the binary"),
        "{err}"
    );
    assert!(err.contains("cache/dripping"), "{err}");
    let cache = dir.path().join("cache/dripping");
    let m = Manifest::read(&cache.join("manifest.json")).unwrap();
    assert_eq!(m.scale, 2.0);
    assert_eq!(m.scene_yaml, include_str!("../presets/dripping.yaml"));
    assert!(m.scene_file.contains("presets/dripping.yaml"));
    assert!(m.frames[1].emitted > 0);
    assert!(cache.join("particles.0001.ply").exists());
    // a bad --scale is refused by the argument parser
    let st = Command::new(exe)
        .current_dir(dir.path())
        .args(["sim", "--scale", "0"])
        .output()
        .unwrap();
    assert!(!st.status.success());
    assert!(String::from_utf8_lossy(&st.stderr).contains("positive"));
}
