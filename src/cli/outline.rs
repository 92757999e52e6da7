//! `codimfx outline DIR [--frames a-b] [--centre x,y,z] [--bins N] [--modes K]`:
//! the outline of a horizontal sheet in a particle cache, seen from above,
//! and its Fourier modes in the yaw angle (how many corners a fluid polygon
//! has and where its corners point; [`codimfx::outline`]). One line per
//! frame; the yaw is measured about the vertical from +x towards +z.
use anyhow::{ensure, Context, Result};
use clap::Args;
use codimfx::io::manifest::Manifest;
use codimfx::io::ply;
use codimfx::math::Vec3;
use codimfx::outline::outline_modes;
use std::path::PathBuf;

/// Arguments of `codimfx outline`.
#[derive(Args, Debug)]
pub struct OutlineArgs {
    /// Cache folder (the one holding particles.NNNN.ply and manifest.json).
    dir: PathBuf,
    /// Frame range `a-b` (inclusive) or a single frame; default all written frames.
    #[arg(long)]
    frames: Option<String>,
    /// Point on the vertical axis of the yaw angle, `x,y,z` (m); default the domain's centre.
    #[arg(long)]
    centre: Option<String>,
    /// Yaw bins of the outline (at least 2 × modes + 1).
    #[arg(long, default_value_t = 72)]
    bins: usize,
    /// Highest Fourier mode reported.
    #[arg(long, default_value_t = 12)]
    modes: usize,
}

/// Runs `codimfx outline`.
pub fn run(a: OutlineArgs) -> Result<()> {
    ensure!(a.modes >= 2, "--modes {}: at least 2", a.modes);
    ensure!(
        a.bins > 2 * a.modes,
        "--bins {}: need more than 2 × --modes = {}",
        a.bins,
        2 * a.modes
    );
    let m = Manifest::read(&a.dir.join("manifest.json"))
        .with_context(|| format!("reading the cache {}", a.dir.display()))?;
    let centre = match &a.centre {
        Some(s) => {
            let v = crate::cli::preview::parse_reals(s, "--centre")?;
            ensure!(v.len() == 3, "--centre {s:?}: expected x,y,z");
            Vec3::new(v[0], v[1], v[2])
        }
        None => (Vec3::from(m.domain_min) + Vec3::from(m.domain_max)) * 0.5,
    };
    let (lo, hi) = match &a.frames {
        Some(s) => crate::cli::preview::parse_range(s)?,
        None => (0, m.frames_written),
    };
    println!(
        "# outline of the sheet and filament particles about the vertical through ({:.4}, {:.4}, {:.4}) m, {} yaw bins",
        centre.x, centre.y, centre.z, a.bins
    );
    println!("| frame | particles | mean radius (mm) | k = 6 (mm) | strongest three (k: mm at the yaw of a crest) |");
    println!("|---|---|---|---|---|");
    for f in lo..=hi.min(m.frames_written) {
        let path = a.dir.join(ply::frame_name(f));
        let frame = ply::read(&path).with_context(|| format!("reading {}", path.display()))?;
        match outline_modes(&frame.particles, &centre, a.bins, a.modes) {
            Some(o) => {
                let top: Vec<String> = o
                    .strongest()
                    .iter()
                    .take(3)
                    .map(|(k, v)| format!("{k}: {:.2} at {:.0}°", v * 1e3, o.crest[*k]))
                    .collect();
                let k6 = o
                    .amplitude
                    .get(6)
                    .map_or("–".into(), |v| format!("{:.2}", v * 1e3));
                println!(
                    "| {f} | {} | {:.1} | {k6} | {} |",
                    o.particles,
                    o.mean_radius * 1e3,
                    top.join(", ")
                );
            }
            None => println!("| {f} | 0 | – | – | no sheet or filament particles |"),
        }
    }
    Ok(())
}
