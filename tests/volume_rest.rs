//! A liquid at rest in a closed box stays at rest: after 1 s of simulated
//! time the largest particle speed is below 1e-3 m/s and no particle has
//! crossed or been clamped at a wall.
use codimfx::sim::{RunOptions, Sim};
use std::sync::atomic::AtomicBool;

const SCENE: &str = "\
version: 1
domain: {min: [0, 0, 0], max: [0.4, 0.4, 0.4], dx: 0.05}
time: {fps: 10, frames: 10, max_dt: 0.02}
bodies:
  - kind: box
    min: [0, 0, 0]
    max: [0.4, 0.2, 0.4]
    spacing: 0.5
";

/// The same tank with its floor raised to a cut-cell plane at y = 0.0737 m,
/// between grid faces: side faces of the bottom liquid cells are part open.
const ON_PLANE: &str = "\
version: 1
domain: {min: [0, 0, 0], max: [0.4, 0.4, 0.4], dx: 0.05}
time: {fps: 10, frames: 10, max_dt: 0.02}
bodies:
  - kind: box
    min: [0, 0.0737, 0]
    max: [0.4, 0.2, 0.4]
    spacing: 0.5
solids:
  - kind: plane
    point: [0, 0.0737, 0]
    normal: [0, 1, 0]
";

#[test]
fn liquid_at_rest_stays_at_rest_for_one_second() {
    check_rest(SCENE, 8 * 4 * 8 * 8);
}

#[test]
fn liquid_at_rest_on_a_cut_cell_plane_stays_at_rest() {
    check_rest(ON_PLANE, 16 * 5 * 16);
}

fn check_rest(text: &str, count: usize) {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("rest.yaml");
    std::fs::write(&scene, text).unwrap();
    let opt = RunOptions {
        out_root: Some(dir.path().join("out")),
        frames: None,
        resume: false,
        scale: None,
        verbose: false,
    };
    let mut sim = Sim::open(&scene, &opt).unwrap();
    let n0 = sim.state.particles.len();
    assert_eq!(n0, count);
    let mut clamps = 0;
    sim.run(&AtomicBool::new(false), |_, r| {
        clamps += r.fallbacks.wall_clamps
    })
    .unwrap();
    assert!((sim.time - 1.0).abs() < 1e-12, "t = {}", sim.time);
    let p = &sim.state.particles;
    let vmax = p.v.iter().map(|v| v.norm()).fold(0.0, f64::max);
    assert!(vmax < 1e-3, "max speed after 1 s: {vmax:e} m/s");
    assert_eq!(clamps, 0, "particles were clamped at the walls");
    let eps = 1e-9;
    for x in &p.x {
        assert!(
            x.iter().all(|c| *c > eps && *c < 0.4 - eps),
            "particle at {x:?} left the box"
        );
        assert!(
            x.y < 0.2,
            "particle at {x:?} rose above the initial surface"
        );
    }
    let last = sim.manifest.frames.last().unwrap();
    // every stage is in the time map; viscosity is skipped (μ = 0) and,
    // with σ = 0, so are the coupled solve and the codimension update
    assert_eq!(last.stage_s.len(), codimfx::step::STAGES.len());
    assert_eq!(last.stage_s["viscosity"], 0.0);
    for s in [
        "mls_operators",
        "coupled_assembly",
        "coupled_factor",
        "coupled_solve",
        "transition",
    ] {
        assert_eq!(last.stage_s[s], 0.0, "{s}");
    }
    assert!(last.stage_s["projection"] > 0.0);
    assert_eq!(last.viscosity.solves, 0);
    assert_eq!(last.pressure.unconverged, 0);
    eprintln!("rest: max speed after 1 s = {vmax:e} m/s");
}
