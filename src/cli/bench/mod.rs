//! `codimfx bench …`: one file per benchmark target.
use clap::{Args, Subcommand};

pub mod accuracy;
mod coupling;
mod films;
mod neighbors;
mod operators;
mod scenes;
mod surface;
mod volume;

/// Arguments of `codimfx bench`.
#[derive(Args, Debug)]
pub struct BenchArgs {
    #[command(subcommand)]
    target: BenchTarget,
}

#[derive(Subcommand, Debug)]
enum BenchTarget {
    /// Fixed-radius neighbour search: uniform cell grid against kiddo's k-d tree.
    Neighbors(neighbors::NeighborsArgs),
    /// MLS operators: time per stage, and sphere-diffusion error against run time.
    Operators(operators::OperatorsArgs),
    /// PIC/FLIP volume solver: ms per substep per stage on a 250k-particle dam break.
    Volume(volume::VolumeArgs),
    /// Film step on the paper's bursting bubble and catenoid: s per step per stage.
    Films(films::FilmsArgs),
    /// Coupled solve, eq. (24): monolithic against Schur complement on resting droplets.
    Coupling(coupling::CouplingArgs),
    /// Run time against error: l = 2 droplet oscillation period against Rayleigh's.
    Accuracy(accuracy::AccuracyArgs),
    /// Liquid presets at the paper's resolution: s/frame per stage against issue 5's targets.
    Scenes(scenes::ScenesArgs),
    /// Surfacer on a ~860k-particle blob: time, peak memory, triangles (and splashsurf if on PATH).
    Surface(surface::SurfaceBenchArgs),
}

/// Runs the chosen benchmark.
pub fn run(a: BenchArgs) -> anyhow::Result<()> {
    match a.target {
        BenchTarget::Neighbors(x) => neighbors::run(x),
        BenchTarget::Operators(x) => operators::run(x),
        BenchTarget::Volume(x) => volume::run(x),
        BenchTarget::Surface(x) => surface::run(x),
        BenchTarget::Films(x) => films::run(x),
        BenchTarget::Coupling(x) => coupling::run(x),
        BenchTarget::Accuracy(x) => accuracy::run(x),
        BenchTarget::Scenes(x) => scenes::run(x),
    }
}
