//! `codimfx bench …`: one file per benchmark target.
use clap::{Args, Subcommand};

mod neighbors;
mod surface;

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
    /// Surfacer on a ~860k-particle blob: time, peak memory, triangles (and splashsurf if on PATH).
    Surface(surface::SurfaceBenchArgs),
}

/// Runs the chosen benchmark.
pub fn run(a: BenchArgs) -> anyhow::Result<()> {
    match a.target {
        BenchTarget::Neighbors(x) => neighbors::run(x),
        BenchTarget::Surface(x) => surface::run(x),
    }
}
