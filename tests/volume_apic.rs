//! APIC transfer (solver.transfer: apic): a spinning liquid ball in zero
//! gravity keeps its angular momentum, which PIC dissipates; APIC runs resume
//! bit for bit (the affine matrices travel in the cache).
use codimfx::grid::MacGrid;
use codimfx::io::ply;
use codimfx::scene::{load_str, sample_bodies, Transfer};
use codimfx::sim::{RunOptions, Sim};
use codimfx::solids::SolidSet;
use codimfx::step::{cfl_dt, step, SimState, StageTimes, StepParams};
use codimfx::Vec3;
use std::path::Path;
use std::sync::atomic::AtomicBool;

const BALL: &str = "\
version: 1
domain: {min: [0, 0, 0], max: [0.4, 0.4, 0.4], dx: 0.02}
time: {fps: 10, frames: 5, max_dt: 0.01}
physics: {gravity: [0, 0, 0]}
bodies:
  - kind: sphere
    center: [0.2, 0.2, 0.2]
    radius: 0.1
    spacing: 0.5
";

/// Angular momentum about z through the centre of mass after `t` seconds, relative to the initial one.
fn spin_ratio(transfer: Transfer, flip: f64, t_end: f64) -> f64 {
    let mut scene = load_str(BALL, Path::new("ball.yaml")).unwrap();
    scene.solver.transfer = transfer;
    scene.solver.flip = flip;
    let solids = SolidSet::from_scene(&scene.solids);
    let (mut particles, _) = sample_bodies(&scene, &solids);
    let c = Vec3::new(0.2, 0.2, 0.2);
    let omega = Vec3::new(0.0, 0.0, 4.0); // rad/s: rim speed 0.4 m/s
    for (x, v) in particles.x.iter().zip(particles.v.iter_mut()) {
        *v = omega.cross(&(x - c));
    }
    let lz = |p: &codimfx::Particles| -> f64 {
        let m: f64 = p.total_mass();
        let com: Vec3 = p.x.iter().zip(&p.mass).map(|(x, mi)| x * *mi).sum::<Vec3>() / m;
        p.x.iter()
            .zip(&p.v)
            .zip(&p.mass)
            .map(|((x, v), mi)| mi * (x - com).cross(v).z)
            .sum()
    };
    let l0 = lz(&particles);
    let d = &scene.domain;
    let params = StepParams::from_scene(&scene);
    let grid = MacGrid::new(Vec3::from(d.min), Vec3::from(d.max), d.dx);
    let mut st = SimState::new(particles, grid, solids);
    let mut times = StageTimes::default();
    let mut t = 0.0;
    while t < t_end {
        let dt = cfl_dt(&st.particles, d.dx, params.accel, 1.0, 0.01).min(t_end - t);
        step(&mut st, &params, dt, &mut times).unwrap();
        t += dt;
    }
    lz(&st.particles) / l0
}

#[test]
fn apic_keeps_the_angular_momentum_that_pic_dissipates() {
    let apic = spin_ratio(Transfer::Apic, 0.0, 0.5);
    let pic = spin_ratio(Transfer::Flip, 0.0, 0.5);
    eprintln!(
        "angular momentum kept after 0.5 s: APIC {:.4}, PIC {:.4}",
        apic, pic
    );
    // measured: APIC 0.949, PIC 0.274 (the free surface and the projection
    // cost APIC a few per cent; PIC's averaging loses most of the spin)
    assert!(apic > 0.9, "APIC kept {apic}");
    assert!(pic < 0.5, "PIC kept {pic}");
}

#[test]
fn apic_runs_resume_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("ball.yaml");
    let text =
        BALL.replace("gravity: [0, 0, 0]", "gravity: [0, -9.81, 0]") + "solver: {transfer: apic}\n";
    std::fs::write(&scene, text).unwrap();
    let run = |out: &Path, frames: u32, resume: bool| {
        let opt = RunOptions {
            out_root: Some(out.to_path_buf()),
            frames: Some(frames),
            resume,
            scale: None,
            verbose: false,
        };
        let mut sim = Sim::open(&scene, &opt).unwrap();
        sim.run(&AtomicBool::new(false), |_, _| {}).unwrap();
    };
    let (a, b) = (dir.path().join("a"), dir.path().join("b"));
    run(&a, 4, false);
    run(&b, 2, false);
    run(&b, 4, true);
    for f in 0..=4 {
        let x = std::fs::read(a.join("ball").join(ply::frame_name(f))).unwrap();
        let y = std::fs::read(b.join("ball").join(ply::frame_name(f))).unwrap();
        assert!(x == y, "frame {f} differs");
    }
    let fr = ply::read(&a.join("ball").join(ply::frame_name(4))).unwrap();
    let c = fr.affine.expect("APIC cache carries c00…c22");
    assert!(c.iter().any(|m| m.iter().any(|r| r.norm() > 0.0)));
}
