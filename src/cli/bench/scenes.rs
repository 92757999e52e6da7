//! `codimfx bench scenes`: seconds per frame, per stage, of the paper's
//! liquid presets at their shipped (paper) resolution, against the
//! per-frame targets of issue 5 (the paper's 8-core + GPU times). Each
//! preset runs `--frames` frames into a temporary folder, optionally after
//! `--skip` frames so that a jet has left its nozzle; the table lists the
//! mean over the timed frames.
use anyhow::{Context, Result};
use clap::Args;
use codimfx::sim::{RunOptions, Sim};
use codimfx::Real;
use std::path::PathBuf;
use std::sync::atomic::AtomicBool;

/// Arguments of `codimfx bench scenes`.
#[derive(Args, Debug)]
pub struct ScenesArgs {
    /// Presets to run (names in presets/, without .yaml).
    #[arg(long, value_delimiter = ',', default_values_t = [
        "dripping", "droplet_collision", "droplet_on_plane", "fluid_chain", "polygon", "waterbell",
    ].map(String::from).to_vec())]
    presets: Vec<String>,
    /// Frames timed per preset.
    #[arg(long, default_value_t = 2)]
    frames: u32,
    /// Frames run before the timed ones.
    #[arg(long, default_value_t = 0)]
    skip: u32,
    /// Folder holding the presets.
    #[arg(long, default_value = "presets")]
    dir: PathBuf,
}

/// Issue 5's per-frame targets on this machine (s).
fn target(name: &str) -> Option<Real> {
    Some(match name {
        n if n.starts_with("dripping") => 15.0,
        "droplet_collision" => 7.0,
        n if n.starts_with("droplet_on_plane") => 6.5,
        "fluid_chain" => 60.0,
        n if n.starts_with("polygon") => 80.0,
        "waterbell" => 110.0,
        _ => return None,
    })
}

/// Runs the benchmark and prints a markdown table.
pub fn run(a: ScenesArgs) -> Result<()> {
    println!("threads: {}\n", rayon::current_num_threads());
    println!(
        "## Liquid presets at the paper's resolution: s/frame (mean of {} frames after {})\n",
        a.frames, a.skip
    );
    println!("| preset | particles | substeps/frame | s/frame | target | MLS ops | assembly | factor | Krylov solve | P2G | transitions | other |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|");
    for name in &a.presets {
        let tmp = tempfile::tempdir()?;
        let scene = a.dir.join(format!("{name}.yaml"));
        let opt = RunOptions {
            out_root: Some(tmp.path().to_path_buf()),
            frames: Some(a.skip + a.frames),
            ..Default::default()
        };
        let mut sim =
            Sim::open(&scene, &opt).with_context(|| format!("opening {}", scene.display()))?;
        sim.run(&AtomicBool::new(false), |_, _| {})
            .with_context(|| format!("running {name}"))?;
        let fr: Vec<_> = sim
            .manifest
            .frames
            .iter()
            .skip(1 + a.skip as usize)
            .collect();
        let n = fr.len().max(1) as Real;
        let mean = |f: &dyn Fn(&codimfx::io::manifest::FrameRecord) -> Real| {
            fr.iter().map(|r| f(r)).sum::<Real>() / n
        };
        let stage = |s: &str| mean(&|r| r.stage_s.get(s).copied().unwrap_or(0.0));
        let wall = mean(&|r| r.wall_s);
        let named = [
            "mls_operators",
            "coupled_assembly",
            "coupled_factor",
            "coupled_solve",
            "p2g",
            "transition",
        ];
        let other = wall - named.iter().map(|s| stage(s)).sum::<Real>();
        println!(
            "| {name} | {} | {:.1} | {:.2} | {} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} |",
            sim.state.particles.len(),
            mean(&|r| r.substeps as Real),
            wall,
            target(name).map_or("–".into(), |t| format!("≤ {t}")),
            stage("mls_operators"),
            stage("coupled_assembly"),
            stage("coupled_factor"),
            stage("coupled_solve"),
            stage("p2g"),
            stage("transition"),
            other
        );
    }
    Ok(())
}
