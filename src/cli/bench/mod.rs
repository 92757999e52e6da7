//! `codimfx bench …`: one file per benchmark target.
use clap::{Args, Subcommand};

mod neighbors;

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
}

/// Runs the chosen benchmark.
pub fn run(a: BenchArgs) -> anyhow::Result<()> {
    match a.target {
        BenchTarget::Neighbors(x) => neighbors::run(x),
    }
}
