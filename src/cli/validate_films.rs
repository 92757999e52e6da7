//! `codimfx validate sphere-deformation` and `codimfx validate catenoid`:
//! the film solver against the paper's reseeding test (Fig. 15) and the
//! analytic minimal surface (Fig. 6).
use anyhow::{Context, Result};
use clap::Args;
use codimfx::film::catenoid::{catenoid_neck, neck_radius, CatenoidSetup};
use codimfx::film::deformation::{run as run_deformation, DeformationSetup};
use codimfx::film::step::advance_by;
use codimfx::film::{FilmParams, FilmState};
use codimfx::math::{Real, Vec3};

/// Flags of `validate sphere-deformation`.
#[derive(Args, Debug)]
pub struct DeformationArgs {
    /// Initial particle spacing on the sphere of radius 0.15 (paper: ≈ 0.00238 for ~50k particles).
    #[arg(long, default_value_t = 0.00238)]
    spacing: Real,
    /// Support radius h relative to the spacing.
    #[arg(long, default_value_t = 3.0)]
    h_over_spacing: Real,
    /// Time step of the midpoint advection (s).
    #[arg(long, default_value_t = 0.01)]
    dt: Real,
    /// Removal threshold relative to h (paper: 0.1–0.2).
    #[arg(long, default_value_t = 0.15)]
    remove_distance: Real,
    /// Print JSON instead of a table.
    #[arg(long)]
    json: bool,
}

/// Flags of `validate catenoid`.
#[derive(Args, Debug)]
pub struct CatenoidArgs {
    /// Particle spacing (m); h = 3 × spacing.
    #[arg(long, default_value_t = 0.002)]
    spacing: Real,
    /// Ring separation relative to the paper's 0.0384 m (critical: 1.3255 R / 0.0384 = 1.767).
    #[arg(long, default_value_t = 1.0)]
    length_scale: Real,
    /// Frames of 5 ms to run.
    #[arg(long, default_value_t = 25)]
    frames: usize,
    /// Air drag (1/s) that lets the film settle.
    #[arg(long, default_value_t = 30.0)]
    damping: Real,
    /// MLS fit order of the tension operator.
    #[arg(long, default_value_t = 3)]
    order: usize,
    /// Print JSON instead of a table.
    #[arg(long)]
    json: bool,
}

/// Runs the sphere-deformation case.
pub fn deformation(a: DeformationArgs) -> Result<()> {
    let set = DeformationSetup {
        spacing: a.spacing,
        h_over_spacing: a.h_over_spacing,
        dt: a.dt,
        remove_distance: a.remove_distance,
        ..DeformationSetup::paper(a.spacing)
    };
    let r = run_deformation(&set, |_, _| {}).context("sphere deformation")?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&r)?);
        return Ok(());
    }
    println!(
        "sphere deformation (LeVeque flow, forward to {:.2} s, back to {:.2} s)",
        set.t_reverse,
        2.0 * set.t_reverse
    );
    println!("| figure | value | paper |\n|---|---|---|");
    println!("| particles at t = 0 | {} | ~50k |", r.particles_start);
    println!(
        "| particles at maximal stretch | {} | ~170k |",
        r.particles_max_stretch
    );
    println!("| particles at the end | {} | ~100k |", r.particles_end);
    println!(
        "| max distance to the sphere / R | {:.3e} | |",
        r.max_distance_rel
    );
    println!(
        "| mean distance to the sphere / R | {:.3e} | |",
        r.mean_distance_rel
    );
    println!(
        "| hole-free particles at maximal stretch | {:.1} % | |",
        100.0 * r.coverage_max_stretch
    );
    println!(
        "| largest gap at maximal stretch / h | {:.3} | |",
        r.max_gap_max_stretch
    );
    println!("| inserted / removed | {} / {} | |", r.inserted, r.removed);
    println!("| seconds | {:.2} | |", r.seconds);
    Ok(())
}

/// Runs the catenoid case.
pub fn catenoid(a: CatenoidArgs) -> Result<()> {
    let t0 = std::time::Instant::now();
    let mut set = CatenoidSetup::paper(a.spacing);
    set.length *= a.length_scale;
    let mut p = set.particles();
    let n0 = p.len();
    let mut prm = FilmParams::new(3.0 * a.spacing, 0.015);
    prm.mls.order = a.order;
    prm.gravity = Vec3::zeros();
    prm.damping = a.damping;
    let mut st = FilmState::default();
    let mut substeps = 0;
    for f in 0..a.frames {
        substeps += advance_by(&mut p, &mut st, &prm, 0.005, a.spacing, 0.5)
            .with_context(|| format!("catenoid frame {}", f + 1))?;
    }
    let exact = catenoid_neck(set.radius, set.length);
    let neck = neck_radius(&p, 0.6 * a.spacing);
    let err = match (exact, neck) {
        (Some(e), Some(n)) => Some(n / e - 1.0),
        _ => None,
    };
    let vmax = p.v.iter().map(|v| v.norm()).fold(0.0, Real::max);
    if a.json {
        let j = serde_json::json!({
            "particles": n0, "substeps": substeps, "neck_radius": neck, "catenoid_neck": exact,
            "neck_relative_error": err, "max_speed": vmax, "seconds": t0.elapsed().as_secs_f64()
        });
        println!("{}", serde_json::to_string_pretty(&j)?);
        return Ok(());
    }
    println!(
        "film catenoid: R = {} m, d = {} m, {} particles, {} substeps",
        set.radius, set.length, n0, substeps
    );
    match exact {
        Some(e) => println!("| analytic neck a | {e:.6} m |"),
        None => println!("| analytic neck | none: d exceeds 1.3255 R, the film must pinch |"),
    }
    match neck {
        Some(n) => println!("| simulated neck | {n:.6} m |"),
        None => println!("| simulated neck | no film particle left at the middle |"),
    }
    if let Some(e) = err {
        println!("| relative error | {:+.3} % |", 100.0 * e);
    }
    println!(
        "| max speed | {vmax:.3e} m/s |\n| seconds | {:.2} |",
        t0.elapsed().as_secs_f64()
    );
    Ok(())
}
