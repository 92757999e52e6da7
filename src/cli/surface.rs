//! `codimfx surface CACHE_DIR [-o OUT] [--frames a-b] [--voxel-size …]`: turns a particle cache
//! into `surface.####.vdb`, `mesh.####.ply`, `sheets.####.ply`, `filaments.####.ply` with the
//! `surfacer` crate (docs/surfacer.md).
use anyhow::{bail, Context, Result};
use clap::Args;
use std::path::PathBuf;
use std::time::Instant;
use surfacer::SurfaceOptions;

/// Arguments of `codimfx surface`.
#[derive(Args, Debug)]
pub struct SurfaceArgs {
    /// Cache folder holding particles.####.ply (written by `codimfx sim`).
    cache_dir: PathBuf,
    /// Output folder (default: CACHE_DIR/surface).
    #[arg(short, long)]
    out: Option<PathBuf>,
    /// Frames to surface, `a-b` inclusive or a single frame `a` (default: all).
    #[arg(long)]
    frames: Option<String>,
    /// Voxel size in metres (default: half the volume particles' spacing).
    #[arg(long)]
    voxel_size: Option<f64>,
    /// Narrow-band half width in voxels.
    #[arg(long, default_value_t = 3.0)]
    band: f64,
    /// Use isotropic kernels for the volume particles (no Yu & Turk anisotropy).
    #[arg(long)]
    isotropic: bool,
    /// Centre smoothing λ of the anisotropic kernels.
    #[arg(long, default_value_t = 0.9)]
    lambda: f64,
    /// Frames surfaced at the same time.
    #[arg(long, default_value_t = 2)]
    parallel_frames: usize,
    /// Liquid density (kg/m³) for sheet thickness and filament length.
    #[arg(long, default_value_t = 1000.0)]
    density: f64,
}

fn parse_frames(s: &str) -> Result<(u32, u32)> {
    let (a, b) = match s.split_once('-') {
        Some((a, b)) => (a, b),
        None => (s, s),
    };
    let a: u32 = a
        .trim()
        .parse()
        .with_context(|| format!("--frames {s}: `{a}` is not a frame number"))?;
    let b: u32 = b
        .trim()
        .parse()
        .with_context(|| format!("--frames {s}: `{b}` is not a frame number"))?;
    if a > b {
        bail!("--frames {s}: first frame {a} is after last frame {b}");
    }
    Ok((a, b))
}

/// Runs `codimfx surface`.
pub fn run(a: SurfaceArgs) -> Result<()> {
    // large stage buffers go back to the system when freed (surfacer::alloc)
    surfacer::alloc::return_freed_memory();
    let range = a.frames.as_deref().map(parse_frames).transpose()?;
    let mut o = SurfaceOptions {
        voxel_size: a.voxel_size,
        band_voxels: a.band,
        parallel_frames: a.parallel_frames.max(1),
        ..Default::default()
    };
    o.aniso.anisotropic = !a.isotropic;
    o.aniso.lambda = a.lambda;
    o.sheets.density = a.density;
    o.filaments.density = a.density;
    let out = a.out.clone().unwrap_or_else(|| a.cache_dir.join("surface"));
    let t = Instant::now();
    let done = surfacer::surface_cache(&a.cache_dir, &out, range, &o, &|f, st| {
        println!(
            "frame {f:04}: {} volume / {} sheet / {} filament / {} point particles, Δx = {:.4} m, {} leaves, {} active voxels, {} triangles, {:.2} s",
            st.particles[0],
            st.particles[1],
            st.particles[2],
            st.particles[3],
            st.voxel,
            st.leaves,
            st.active_voxels,
            st.triangles,
            st.seconds.iter().sum::<f64>()
        );
    })
    .with_context(|| format!("surfacing {}", a.cache_dir.display()))?;
    println!(
        "{} frames surfaced into {} in {:.2} s",
        done.len(),
        out.display(),
        t.elapsed().as_secs_f64()
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn surface_command_writes_the_requested_frames() {
        let dir = tempfile::tempdir().unwrap();
        let dx = 0.05;
        let ps = dx * (3.0 / (4.0 * std::f64::consts::PI)).cbrt();
        for n in 1..=3u32 {
            let mut f = surfacer::ParticleFrame::default();
            for i in -4..=4 {
                for j in -4..=4 {
                    for k in -4..=4 {
                        let p = surfacer::Vec3::new(i as f64, j as f64, k as f64) * dx;
                        if p.norm() <= 0.2 {
                            let id = f.len() as u32;
                            f.push(
                                p,
                                surfacer::Vec3::zeros(),
                                id,
                                0,
                                ps,
                                0.125,
                                surfacer::Vec3::zeros(),
                            );
                        }
                    }
                }
            }
            surfacer::cache::write_frame(&surfacer::cache::frame_path(dir.path(), n), &f, n, 0.0)
                .unwrap();
        }
        let out = dir.path().join("geo");
        run(SurfaceArgs {
            cache_dir: dir.path().into(),
            out: Some(out.clone()),
            frames: Some("2-3".into()),
            voxel_size: Some(0.02),
            band: 3.0,
            isotropic: false,
            lambda: 0.9,
            parallel_frames: 2,
            density: 1000.0,
        })
        .unwrap();
        for n in [2, 3] {
            for name in ["surface", "mesh", "sheets", "filaments"] {
                let ext = if name == "surface" { "vdb" } else { "ply" };
                assert!(out.join(format!("{name}.{n:04}.{ext}")).exists());
            }
        }
        assert!(!out.join("surface.0001.vdb").exists());
        // a bad range names itself
        let e = run(SurfaceArgs {
            cache_dir: dir.path().into(),
            out: Some(out),
            frames: Some("8-9".into()),
            voxel_size: None,
            band: 3.0,
            isotropic: false,
            lambda: 0.9,
            parallel_frames: 1,
            density: 1000.0,
        })
        .unwrap_err();
        assert!(format!("{e:#}").contains("8-9"), "{e:#}");
    }

    #[test]
    fn frame_ranges_parse_and_bad_ones_are_named() {
        assert_eq!(parse_frames("10-20").unwrap(), (10, 20));
        assert_eq!(parse_frames("7").unwrap(), (7, 7));
        assert!(parse_frames("20-10")
            .unwrap_err()
            .to_string()
            .contains("after"));
        assert!(parse_frames("x-3").unwrap_err().to_string().contains("`x`"));
    }
}
