//! The `codimfx` command line: argument parsing and file handling only; the
//! numerics live in the `codimfx` library and the `surfacer` crate.
use clap::{Parser, Subcommand};

mod cli;

/// codimfx: codimensional surface-tension liquids — volumes, thin sheets,
/// filaments and droplets in one simulation (Wang et al., SIGGRAPH 2020).
#[derive(Parser, Debug)]
#[command(version, about, long_about = None, propagate_version = true)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Measure run time (and error, where there is one) of a part of the solver.
    Bench(cli::bench::BenchArgs),
    /// Check the MLS operators against analytic solutions (sphere diffusion, curvature, butterfly).
    Validate(cli::validate::ValidateArgs),
    /// Simulate a scene file into a particle cache (PLY per frame + manifest.json).
    Sim(cli::sim::SimArgs),
    /// Render PNG previews and a contact sheet of a particle cache.
    Preview(cli::preview::PreviewArgs),
    /// Turn a particle cache into OpenVDB level sets and PLY meshes (surface.####.vdb, mesh.####.ply, …).
    Surface(cli::surface::SurfaceArgs),
    /// Measure a sheet's outline seen from above in a particle cache: mean radius and Fourier modes in the yaw angle (a fluid polygon's corners).
    Outline(cli::outline::OutlineArgs),
}

fn main() -> anyhow::Result<()> {
    let cli = Cli::parse();
    match cli.command {
        Command::Bench(a) => cli::bench::run(a),
        Command::Validate(a) => cli::validate::run(a),
        Command::Sim(a) => cli::sim::run(a),
        Command::Preview(a) => cli::preview::run(a),
        Command::Surface(a) => cli::surface::run(a),
        Command::Outline(a) => cli::outline::run(a),
    }
}
