//! `codimfx sim [SCENE.yaml] [-o DIR] [--frames N] [--resume] [--threads N] [--scale S] [-v]`:
//! runs a scene, writing `DIR/<scene-name>/particles.NNNN.ply` and
//! `manifest.json`, with a progress bar and a per-stage time summary.
//! Without a scene it runs the dripping-water preset built into the binary.
//! Ctrl-C stops after the current frame (no partial file is left).
use anyhow::{Context, Result};
use clap::Args;
use codimfx::sim::{RunOptions, Sim};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// Arguments of `codimfx sim`.
#[derive(Args, Debug)]
pub struct SimArgs {
    /// Scene file (YAML, see docs/scene-format.md). Default: the dripping-water
    /// preset built into the binary (presets/dripping.yaml).
    scene: Option<PathBuf>,
    /// Parent folder of the cache (default: the scene's output.dir, else `cache`).
    #[arg(short = 'o', long = "out")]
    out: Option<PathBuf>,
    /// Simulate up to this frame (default: the scene's time.frames).
    #[arg(long)]
    frames: Option<u32>,
    /// Continue after the last complete frame of the existing cache.
    #[arg(long)]
    resume: bool,
    /// Worker threads (default: all cores). Same input and thread count give identical caches.
    #[arg(long)]
    threads: Option<usize>,
    /// Resolution scale for quick runs: cell size dx × S, particle spacings
    /// follow (they are relative to dx), so S = 2 halves the resolution and
    /// has ~8× fewer particles. Recorded in the manifest; --resume reuses it.
    #[arg(long, value_parser = positive_scale)]
    scale: Option<f64>,
    /// Print every substep of a liquid scene (time, Δt, solver iterations
    /// and residual, wall time, fastest particle) to stderr: for following a
    /// slow frame.
    #[arg(short = 'v', long)]
    verbose: bool,
}

/// The dripping-water preset, built into the binary for `codimfx sim` without a scene.
const BUILTIN_SCENE: &str = include_str!("../../presets/dripping.yaml");
/// Name under which the built-in scene appears in messages and the manifest.
const BUILTIN_NAME: &str = "built-in:presets/dripping.yaml";

fn positive_scale(s: &str) -> Result<f64, String> {
    let v: f64 = s.parse().map_err(|e| format!("{e}"))?;
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(format!("must be a positive number, got {s}"))
    }
}

/// Runs `codimfx sim`.
pub fn run(a: SimArgs) -> Result<()> {
    if let Some(n) = a.threads {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
            .context("setting the thread count")?;
    }
    let stop = Arc::new(AtomicBool::new(false));
    {
        let stop = stop.clone();
        ctrlc::set_handler(move || {
            if stop.swap(true, Ordering::SeqCst) {
                std::process::exit(130);
            }
            eprintln!("\nstopping after the current frame (Ctrl-C again to abort)");
        })
        .context("installing the Ctrl-C handler")?;
    }
    let opt = RunOptions {
        out_root: a.out,
        frames: a.frames,
        resume: a.resume,
        scale: a.scale,
        verbose: a.verbose,
    };
    let (mut sim, label) = match &a.scene {
        Some(p) => (Sim::open(p, &opt)?, p.display().to_string()),
        None => {
            let sim = Sim::open_text(BUILTIN_SCENE, Path::new(BUILTIN_NAME), &opt)?;
            eprintln!(
                "no scene given: running the dripping-water preset built into the binary \
                 (presets/dripping.yaml); cache -> {}",
                sim.dir.display()
            );
            (sim, BUILTIN_NAME.to_string())
        }
    };
    if sim.manifest.scale != 1.0 {
        eprintln!(
            "--scale {}: dx = {} m (particle spacings follow)",
            sim.manifest.scale, sim.scene.domain.dx
        );
    }
    eprintln!(
        "{}: {} particles, dx = {} m, frames {}..={} -> {}",
        label,
        sim.state.particles.len(),
        sim.scene.domain.dx,
        sim.frame + 1,
        sim.last_frame,
        sim.dir.display()
    );
    if sim.dropped_in_solid > 0 {
        eprintln!(
            "note: {} seed samples inside solids were dropped",
            sim.dropped_in_solid
        );
    }
    let pb = ProgressBar::new(sim.last_frame as u64);
    pb.set_style(
        ProgressStyle::with_template(
            "frame {pos}/{len} {bar:30} {msg} [{elapsed_precise}, ETA {eta}]",
        )
        .expect("valid template"),
    );
    pb.set_position(sim.frame as u64);
    let mut substeps = 0u64;
    let start = std::time::Instant::now();
    sim.run(&stop, |s, r| {
        substeps += r.substeps as u64;
        pb.set_position(r.frame as u64);
        pb.set_message(format!(
            "t = {:.3} s, {} particles, {} substeps, max speed {:.3} m/s",
            r.time,
            s.state.particles.len(),
            r.substeps,
            r.speed.max
        ));
    })?;
    pb.finish();
    let wall = start.elapsed().as_secs_f64();
    if stop.load(Ordering::SeqCst) {
        eprintln!("stopped by Ctrl-C after frame {}", sim.frame);
    }
    eprintln!(
        "\n{} frames, {substeps} substeps, {:.2} s wall; time per stage:",
        sim.frame, wall
    );
    eprintln!("| stage | total (s) | ms/substep | share |");
    eprintln!("|---|---|---|---|");
    let total = sim.totals.total().max(1e-12);
    for (k, v) in &sim.totals.0 {
        eprintln!(
            "| {k} | {v:.3} | {:.2} | {:.1} % |",
            1e3 * v / substeps.max(1) as f64,
            100.0 * v / total
        );
    }
    Ok(())
}
