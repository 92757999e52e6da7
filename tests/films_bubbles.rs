//! A gust of air through a ring blows the ring's film into a finger whose
//! neck closes once the gust stops: a separate bubble (the paper's Fig. 2),
//! held up by its air (`film.bag_air`, src/film/air/).
use codimfx::io::manifest::Manifest;
use codimfx::io::ply;
use codimfx::particles::Codim;
use codimfx::sim::{RunOptions, Sim};
use std::path::Path;
use std::sync::atomic::AtomicBool;

/// The blowing-bubble set-up (ring radius 19.2 mm, σ = 0.01 N/m, a 1 µm
/// film) at dx = 2.4 mm (1,887 particles), blown upwards by one 30 ms gust
/// of a 3 m/s jet of radius 8 mm, 10 ms per frame.
const SCENE: &str = "\
version: 1
domain:
  min: [-0.06, -0.06, -0.06]
  max: [0.06, 0.18, 0.06]
  dx: 0.0024
time:
  fps: 100
  frames: 5
  max_dt: 0.005
physics:
  density: 1000
  surface_tension: 0.01
  viscosity: 0
  gravity: [0, -9.81, 0]
films:
  - kind: disk
    center: [0, 0, 0]
    normal: [0, 1, 0]
    radius: 0.0192
    spacing: 0.3333
film:
  thickness: 1.0e-6
  wind:
    velocity: [0, 3.0, 0]
    radius: 0.008
    gust: { duration: 0.03 }
  bag_air: true
  max_speed: 5.0
  point_cfl: 6
";

fn run(scene: &Path, out: &Path, frames: u32, resume: bool) -> Sim {
    run_scaled(scene, out, frames, resume, None)
}

fn run_scaled(scene: &Path, out: &Path, frames: u32, resume: bool, scale: Option<f64>) -> Sim {
    let mut sim = Sim::open(
        scene,
        &RunOptions {
            out_root: Some(out.to_path_buf()),
            frames: Some(frames),
            resume,
            scale,
            verbose: false,
        },
    )
    .unwrap();
    sim.run(&AtomicBool::new(false), |_, _| {}).unwrap();
    sim
}

/// Checks that bubble `b`'s air is within 5 % of the Laplace pressure 4σ/R
/// of a soap bubble with two faces (σ = 0.01 N/m, R the radius of a sphere
/// of volume V_0); returns R.
fn at_laplace(b: &codimfx::film::air::Bubble) -> f64 {
    let r_eq = (3.0 * b.v0 / (4.0 * std::f64::consts::PI)).cbrt();
    let laplace = 4.0 * 0.01 / r_eq;
    eprintln!(
        "bubble: V0 = {:.3} cm³, R = {:.2} mm, p = {:.3} Pa against 4σ/R = {laplace:.3} Pa",
        b.v0 * 1e6,
        r_eq * 1e3,
        b.pressure
    );
    assert!(
        (b.pressure / laplace - 1.0).abs() < 0.05,
        "{} vs {laplace}",
        b.pressure
    );
    r_eq
}

#[test]
fn a_gust_blows_a_bubble_that_keeps_its_air_at_the_laplace_pressure() {
    let tmp = tempfile::tempdir().unwrap();
    let scene = tmp.path().join("gust.yaml");
    std::fs::write(&scene, SCENE).unwrap();
    let sim = run(&scene, tmp.path(), 5, false);
    let m = Manifest::read(&sim.dir.join("manifest.json")).unwrap();
    let m0 = m.frames[0].total_mass;
    for f in &m.frames {
        assert!((f.total_mass - m0).abs() <= 1e-12 * m0, "frame {}", f.frame);
    }
    let air: Vec<_> = m.frames[1..]
        .iter()
        .map(|f| f.air.clone().unwrap())
        .collect();
    for (f, a) in air.iter().enumerate() {
        eprintln!("frame {}: {a:?}", f + 1);
    }
    // while the jet blows (frames 1–3) the finger grows and nothing closes
    for a in &air[..3] {
        assert!(a.bubbles.is_empty() && a.new_bubbles == 0, "{a:?}");
    }
    // then its neck closes: one bubble, exactly once
    let closed: u32 = air.iter().map(|a| a.new_bubbles).sum();
    assert_eq!(closed, 1);
    let last = air.last().unwrap();
    assert_eq!(last.bubbles.len(), 1);
    // its air keeps its volume and holds the film at the Laplace pressure
    let r_eq = at_laplace(&last.bubbles[0]);
    assert!(r_eq > 0.008 && r_eq < 0.02, "R = {r_eq}");
    assert!(last.bubble_volume_error < 0.01, "{last:?}");
    // the bubble is round and holds V0; the ring's film is back near its plane
    let p = ply::read(&sim.dir.join("particles.0005.ply"))
        .unwrap()
        .particles;
    let free: Vec<usize> = (0..p.len())
        .filter(|&i| p.codim[i] == Codim::Sheet && !p.fixed[i])
        .collect();
    let (bubble, ring): (Vec<usize>, Vec<usize>) = free.iter().partition(|&&i| p.x[i].y > 0.02);
    let c = bubble.iter().map(|&i| p.x[i]).sum::<codimfx::math::Vec3>() / bubble.len() as f64;
    let radii: Vec<f64> = bubble.iter().map(|&i| (p.x[i] - c).norm()).collect();
    let mean = radii.iter().sum::<f64>() / radii.len() as f64;
    let (lo, hi) = radii
        .iter()
        .fold((f64::MAX, 0.0f64), |(a, b), &r| (a.min(r), b.max(r)));
    eprintln!(
        "bubble particles {}, radius {mean:.5} in [{lo:.5}, {hi:.5}]",
        bubble.len()
    );
    // 16 ms after the pinch it still rings in its l = 2 mode (measured:
    // radii 10.2–12.4 mm about 11.3); the finger it was spans 7–30 mm
    assert!((hi - lo) / mean < 0.25, "not round: {lo} .. {hi}");
    assert!((mean / r_eq - 1.0).abs() < 0.03, "{mean} vs {r_eq}");
    let sag = ring.iter().map(|&i| p.x[i].y.abs()).fold(0.0, f64::max);
    assert!(sag < 0.005, "the ring's film is {sag} m out of its plane");

    // a run resumed after the bubble closed finds it again from the manifest
    // and writes the same bytes
    assert!(air[3].bubbles.len() == 1, "closed by frame 4: {:?}", air[3]);
    let dir_b = tmp.path().join("resumed");
    std::fs::create_dir_all(dir_b.join("gust")).unwrap();
    for f in 0..=4 {
        let name = ply::frame_name(f);
        std::fs::copy(sim.dir.join(&name), dir_b.join("gust").join(&name)).unwrap();
    }
    let mut mb = m.clone();
    mb.frames.retain(|r| r.frame <= 4);
    mb.frames_written = 4;
    mb.write(&dir_b.join("gust").join("manifest.json")).unwrap();
    let resumed = run(&scene, &dir_b, 5, true);
    let a5 = std::fs::read(sim.dir.join("particles.0005.ply")).unwrap();
    let b5 = std::fs::read(resumed.dir.join("particles.0005.ply")).unwrap();
    assert!(a5 == b5, "the resumed frame 5 differs");
    let mr = Manifest::read(&resumed.dir.join("manifest.json")).unwrap();
    assert_eq!(mr.frames[5].air, m.frames[5].air);
}

#[test]
fn the_preset_blows_its_first_bubble_at_the_laplace_pressure() {
    // presets/blowing_bubble.yaml at --scale 2 (dx = 2.4 mm, 1,887
    // particles), frames 1–2 (67 ms): the first gust's bubble closes in
    // frame 1 and keeps its air; measured 4.007 Pa against 4σ/R = 3.965 Pa
    // (V₀ = 4.300 cm³; with the preset's `film.marangoni`, session 28).
    let tmp = tempfile::tempdir().unwrap();
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("presets/blowing_bubble.yaml");
    let sim = run_scaled(&scene, tmp.path(), 2, false, Some(2.0));
    let m = Manifest::read(&sim.dir.join("manifest.json")).unwrap();
    let m0 = m.frames[0].total_mass;
    for f in &m.frames {
        assert!((f.total_mass - m0).abs() <= 1e-12 * m0, "frame {}", f.frame);
    }
    // one bubble, closed in frame 1, at the Laplace pressure 4σ/R
    let a1 = m.frames[1].air.clone().unwrap();
    let a2 = m.frames[2].air.clone().unwrap();
    assert_eq!((a1.new_bubbles, a2.new_bubbles, a2.burst), (1, 0, 0));
    let r_eq = at_laplace(&a2.bubbles[0]);
    assert!(r_eq > 0.008 && r_eq < 0.02, "R = {r_eq}");
    assert!(a2.bubble_volume_error < 0.01, "{a2:?}");
}
