//! `codimfx bench volume`: the PIC/FLIP volume solver on a dam break of about
//! 250k particles at Δx = 1/128 of a unit domain (Appendix F sampling, 27
//! particles per cell): milliseconds per substep for each stage of `step()`
//! and particles per second. Target on the 2-core reference machine:
//! ≤ 0.5 s per substep for P2G + projection + G2P + advection together.
use anyhow::Result;
use clap::Args;
use codimfx::grid::MacGrid;
use codimfx::scene::{
    sample_bodies, Domain, FluidBody, Output, Physics, Scene, SolverSettings, TimeSettings,
};
use codimfx::solids::SolidSet;
use codimfx::step::{cfl_dt, step, SimState, StageTimes, StepParams};
use codimfx::{Real, Vec3};
use std::time::Instant;

/// Arguments of `codimfx bench volume`.
#[derive(Args, Debug)]
pub struct VolumeArgs {
    /// Cells across the unit domain (Δx = 1/N).
    #[arg(long, default_value_t = 128)]
    cells: usize,
    /// Timed substeps.
    #[arg(long, default_value_t = 10)]
    substeps: usize,
    /// Use the APIC transfer instead of PIC/FLIP.
    #[arg(long)]
    apic: bool,
    /// Simulated time (s) before the timed substeps, so the column has started to collapse.
    #[arg(long, default_value_t = 0.25)]
    settle: Real,
}

/// The benchmark scene: a 16 × 36 × 16-cell water column in the corner of a unit box.
pub fn dam_scene(cells: usize) -> Scene {
    let dx = 1.0 / cells as Real;
    Scene {
        version: 1,
        domain: Domain {
            min: [0.0; 3],
            max: [1.0; 3],
            dx,
        },
        time: TimeSettings {
            fps: 30.0,
            frames: 1,
            max_dt: 0.01,
            cfl: 1.0,
        },
        physics: Physics::default(),
        solver: SolverSettings::default(),
        bodies: vec![FluidBody::Box {
            min: [0.0; 3],
            max: [16.0 * dx, 36.0 * dx, 16.0 * dx],
            velocity: [0.0; 3],
            spacing: 1.0 / 3.0,
            surface_layer: None,
        }],
        solids: vec![],
        jets: vec![],
        coupling: Default::default(),
        films: vec![],
        film: Default::default(),
        output: Output::default(),
    }
}

/// Runs the benchmark and prints a markdown table.
pub fn run(a: VolumeArgs) -> Result<()> {
    let mut scene = dam_scene(a.cells);
    if a.apic {
        scene.solver.transfer = codimfx::scene::Transfer::Apic;
    }
    let solids = SolidSet::from_scene(&scene.solids);
    let (particles, _) = sample_bodies(&scene, &solids);
    let n = particles.len();
    let params = StepParams::from_scene(&scene);
    let d = &scene.domain;
    let grid = MacGrid::new(Vec3::from(d.min), Vec3::from(d.max), d.dx);
    let mut st = SimState::new(particles, grid, solids);
    let dtf = |st: &SimState| {
        cfl_dt(
            &st.particles,
            d.dx,
            params.accel,
            scene.time.cfl,
            scene.time.max_dt,
        )
    };
    let mut scratch = StageTimes::default();
    let (mut t, mut warm) = (0.0, 0);
    while t < a.settle {
        let dt = dtf(&st);
        step(&mut st, &params, dt, &mut scratch)?;
        t += dt;
        warm += 1;
    }
    let mut times = StageTimes::default();
    let (mut iters, mut cells, mut blocks) = (0u64, 0usize, 0usize);
    let t0 = Instant::now();
    for _ in 0..a.substeps {
        let dt = dtf(&st);
        let info = step(&mut st, &params, dt, &mut times)?;
        iters += info.pressure.solve.iterations as u64;
        cells = cells.max(info.pressure.cells);
        blocks = blocks.max(info.blocks);
    }
    let wall = t0.elapsed().as_secs_f64();
    let k = a.substeps.max(1) as Real;
    println!(
        "threads: {}, transfer: {:?}, particles: {n}, dx = 1/{}, timed after {warm} substeps (t = {t:.3} s), liquid cells: {cells}, blocks: {blocks} ({} cells allocated of {}), mean pressure PCG iterations: {:.1}\n",
        rayon::current_num_threads(),
        scene.solver.transfer,
        a.cells,
        blocks * 512,
        a.cells.pow(3),
        iters as Real / k
    );
    println!("| stage | ms/substep |");
    println!("|---|---|");
    for (s, v) in &times.0 {
        println!("| {s} | {:.1} |", 1e3 * v / k);
    }
    let core: Real = ["p2g", "projection", "g2p", "advect"]
        .iter()
        .map(|s| times.0[*s])
        .sum::<Real>()
        / k;
    println!("| **total** | {:.1} |", 1e3 * wall / k);
    println!(
        "\nP2G + projection + G2P + advection: {:.3} s/substep (target ≤ 0.5); {:.2e} particle-substeps/s",
        core,
        n as Real * k / wall
    );
    Ok(())
}
