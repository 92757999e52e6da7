//! `codimfx validate slab`: the coupled solver's thick sheet edge against
//! the momentum balance of Taylor–Culick retraction (2σ per unit length).
//! `codimfx validate wedge`: a box's edges against Keller & Miksis's
//! self-similar recoil.
use super::bench::accuracy::LayerArg;
use anyhow::{Context, Result};
use clap::Args;
use codimfx::math::Real;
use codimfx::validate::slab::{retract, SlabCase};
use codimfx::validate::wedge::{recoil, WedgeCase};

/// Flags of `validate slab`.
#[derive(Args, Debug)]
pub struct SlabArgs {
    /// Thickness in cells (Δx = 1/480 m).
    #[arg(long, default_value_t = 3.0)]
    cells: Real,
    /// Where the lower face sits in its cell (fraction of a cell, 0–1).
    #[arg(long, default_value_t = 0.0)]
    offset: Real,
    /// Level-set radius of the liquid, relative to Δx (`solver.surface_radius`).
    #[arg(long, default_value_t = 1.0)]
    surface_radius: Real,
    /// How the surface layer carries its tension (`coupling.layer`).
    #[arg(long, value_enum, default_value_t = LayerArg::Coupled)]
    layer: LayerArg,
    /// Substep (s).
    #[arg(long, default_value_t = 0.0025)]
    dt: Real,
    /// End time (s).
    #[arg(long, default_value_t = 0.05)]
    time: Real,
    /// Print a sample every this many substeps.
    #[arg(long, default_value_t = 4)]
    every: usize,
    /// Print JSON instead of a table.
    #[arg(long)]
    json: bool,
}

/// Runs the slab case.
pub fn slab(a: SlabArgs) -> Result<()> {
    if !(a.cells >= 0.25 && (0.0..=1.0).contains(&a.offset)) {
        anyhow::bail!(
            "validate slab: --cells must be ≥ 0.25 and --offset in [0, 1] (got {} and {})",
            a.cells,
            a.offset
        );
    }
    let case = SlabCase {
        cells: a.cells,
        offset: a.offset,
        surface_radius: a.surface_radius,
        layer: a.layer.into(),
        ..SlabCase::chain()
    };
    let (samples, wall) = retract(&case, a.dt, a.time, a.every).context("running the slab")?;
    if a.json {
        let v = serde_json::json!({
            "thickness_m": case.thickness(),
            "edge_length_m": case.length,
            "pull_n": case.pull(),
            "taylor_culick_m_s": case.taylor_culick(),
            "capillary_time_s": case.capillary_time(),
            "samples": samples,
            "wall_s": wall,
        });
        println!("{}", serde_json::to_string_pretty(&v)?);
        return Ok(());
    }
    println!(
        "free slab, zero gravity: h = {:.2} mm ({} cells, offset {}), edge L = {:.0} mm, σ = {} N/m, surface_radius {}",
        1e3 * case.thickness(),
        case.cells,
        case.offset,
        1e3 * case.length,
        case.sigma,
        case.surface_radius
    );
    println!(
        "expected: half-slab momentum 2σL t = {:.3e} N × t; Taylor–Culick v = {:.3} m/s, t_c = {:.3} s",
        case.pull(),
        case.taylor_culick(),
        case.capillary_time()
    );
    println!("| t (s) | momentum (kg m/s) | / 2σL t | edge retraction (mm) | v_TC t (mm) |");
    println!("|---|---|---|---|---|");
    for s in &samples {
        println!(
            "| {:.4} | {:.3e} | {:.2} | {:.2} | {:.2} |",
            s.t,
            s.momentum,
            s.pull_ratio,
            1e3 * s.retraction,
            1e3 * s.taylor_culick
        );
    }
    println!("wall {wall:.1} s");
    Ok(())
}

/// Flags of `validate wedge`.
#[derive(Args, Debug)]
pub struct WedgeArgs {
    /// How the surface layer carries its tension (`coupling.layer`).
    #[arg(long, value_enum, default_value_t = LayerArg::Jump)]
    layer: LayerArg,
    /// Frames of 5 ms to run (the recoil stays a wedge's to about 16).
    #[arg(long, default_value_t = 16)]
    frames: usize,
    /// Print JSON instead of a table.
    #[arg(long)]
    json: bool,
}

/// Runs the wedge case.
pub fn wedge(a: WedgeArgs) -> Result<()> {
    let case = WedgeCase::collision(a.layer.into());
    let (samples, dt, wall) = recoil(&case, a.frames).context("running the wedge")?;
    if a.json {
        let v = serde_json::json!({
            "sigma_n_m": case.sigma,
            "substep_s": dt,
            "samples": samples,
            "wall_s": wall,
        });
        println!("{}", serde_json::to_string_pretty(&v)?);
        return Ok(());
    }
    println!(
        "a 48 × 24 × 24 mm box at rest, σ = {} N/m, Δx = 1/480 m, substep {:.2} ms: its long edges' recoil d against Keller & Miksis's d = C (σt²/ρ)^(1/3)",
        case.sigma,
        1e3 * dt
    );
    println!("| t (s) | recoil (mm) | (σt²/ρ)^(1/3) (mm) | ratio |");
    println!("|---|---|---|---|");
    for s in &samples {
        println!(
            "| {:.3} | {:.3} | {:.3} | {:.3} |",
            s.t,
            1e3 * s.recoil,
            1e3 * case.scale(s.t),
            s.ratio
        );
    }
    println!("a constant ratio means the self-similar recoil; wall {wall:.1} s");
    Ok(())
}
