//! `codimfx preview DIR [--frames a-b] [--camera …]`: PNG quick looks of a
//! particle cache (`DIR` holds `particles.NNNN.ply`), one image per frame in
//! `DIR/preview/` plus `contact_sheet.png` of evenly spaced frames.
use anyhow::{bail, ensure, Context, Result};
use clap::Args;
use codimfx::io::manifest::Manifest;
use codimfx::io::ply;
use codimfx::preview::{render, solid_points, Camera, ImageSize};
use codimfx::scene::load_str;
use codimfx::{Real, Vec3};
use image::{imageops, RgbImage};
use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// Arguments of `codimfx preview`.
#[derive(Args, Debug)]
pub struct PreviewArgs {
    /// Cache folder (the one holding particles.NNNN.ply).
    dir: PathBuf,
    /// Frame range `a-b` (inclusive) or a single frame; default all.
    #[arg(long)]
    frames: Option<String>,
    /// Explicit camera `ex,ey,ez,tx,ty,tz[,fov_deg]` (eye, target; y up); default: framed from the cache bounds.
    #[arg(long)]
    camera: Option<String>,
    /// Orthographic projection instead of perspective.
    #[arg(long)]
    ortho: bool,
    /// Image width (pixels).
    #[arg(long, default_value_t = 960)]
    width: u32,
    /// Image height (pixels).
    #[arg(long, default_value_t = 540)]
    height: u32,
    /// Disc radius relative to the cached particle radius.
    #[arg(long, default_value_t = 1.6)]
    splat: Real,
    /// Do not draw the scene's static solids (grey).
    #[arg(long)]
    no_solids: bool,
    /// Output folder (default DIR/preview).
    #[arg(short = 'o', long = "out")]
    out: Option<PathBuf>,
}

fn frames_on_disk(dir: &Path) -> Result<Vec<u32>> {
    let mut v = Vec::new();
    for e in std::fs::read_dir(dir).with_context(|| format!("reading {}", dir.display()))? {
        let n = e?.file_name().to_string_lossy().into_owned();
        if let Some(num) = n
            .strip_prefix("particles.")
            .and_then(|s| s.strip_suffix(".ply"))
        {
            if let Ok(f) = num.parse::<u32>() {
                v.push(f);
            }
        }
    }
    v.sort_unstable();
    Ok(v)
}

pub(crate) fn parse_range(s: &str) -> Result<(u32, u32)> {
    let r = match s.split_once('-') {
        Some((a, b)) => (a.trim().parse()?, b.trim().parse()?),
        None => {
            let a = s.trim().parse()?;
            (a, a)
        }
    };
    ensure!(r.0 <= r.1, "--frames {s}: start after end");
    Ok(r)
}

/// Parses the comma-separated finite numbers of option `flag`.
pub(crate) fn parse_reals(s: &str, flag: &str) -> Result<Vec<Real>> {
    let v: Vec<Real> = s
        .split(',')
        .map(|t| t.trim().parse::<Real>())
        .collect::<std::result::Result<_, _>>()
        .with_context(|| format!("{flag} {s:?}: expected numbers"))?;
    ensure!(
        v.iter().all(|c| c.is_finite()),
        "{flag} {s:?}: non-finite value"
    );
    Ok(v)
}

fn parse_camera(s: &str, ortho: bool) -> Result<Camera> {
    let v = parse_reals(s, "--camera")?;
    ensure!(
        v.len() == 6 || v.len() == 7,
        "--camera {s:?}: expected ex,ey,ez,tx,ty,tz[,fov]"
    );
    let cam = Camera {
        eye: Vec3::new(v[0], v[1], v[2]),
        target: Vec3::new(v[3], v[4], v[5]),
        up: Vec3::new(0.0, 1.0, 0.0),
        fov_deg: v.get(6).copied().unwrap_or(35.0),
        ortho,
    };
    ensure!(
        (cam.eye - cam.target).norm() > 0.0,
        "--camera {s:?}: eye equals target"
    );
    ensure!(
        cam.fov_deg > 0.0 && cam.fov_deg < 179.0,
        "--camera {s:?}: fov must be in (0, 179)"
    );
    Ok(cam)
}

/// Runs `codimfx preview`.
pub fn run(a: PreviewArgs) -> Result<()> {
    let t0 = std::time::Instant::now();
    let mut frames = frames_on_disk(&a.dir)?;
    if let Some(r) = &a.frames {
        let (lo, hi) = parse_range(r)?;
        frames.retain(|f| (lo..=hi).contains(f));
    }
    if frames.is_empty() {
        bail!(
            "{}: no particles.NNNN.ply frames (in the requested range)",
            a.dir.display()
        );
    }
    ensure!(
        a.width >= 16 && a.height >= 16,
        "image must be at least 16×16"
    );
    let out = a.out.clone().unwrap_or_else(|| a.dir.join("preview"));
    std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
    let cam = match &a.camera {
        Some(s) => parse_camera(s, a.ortho)?,
        None => {
            // bounds of up to 5 evenly spaced frames
            let (m, k5) = (frames.len(), frames.len().min(5));
            let picks: Vec<u32> = (0..k5)
                .map(|k| frames[k * (m - 1) / (k5 - 1).max(1)])
                .collect();
            let mut lo = Vec3::repeat(Real::INFINITY);
            let mut hi = Vec3::repeat(Real::NEG_INFINITY);
            for f in picks {
                let fr = ply::read(&a.dir.join(ply::frame_name(f)))?;
                for x in &fr.particles.x {
                    lo = lo.inf(x);
                    hi = hi.sup(x);
                }
            }
            ensure!(lo.x.is_finite(), "frames hold no particles");
            Camera::auto(lo, hi, a.ortho)
        }
    };
    // static solids from the scene copy in the manifest, when there is one
    let mpath = a.dir.join("manifest.json");
    let manifest = if a.no_solids || !mpath.exists() {
        None
    } else {
        match Manifest::read(&mpath) {
            Ok(m) => Some(m),
            Err(e) => {
                eprintln!("note: solids not drawn: {e}");
                None
            }
        }
    };
    let (solid_pts, solid_r) = match manifest {
        Some(m) => {
            let scene = load_str(&m.scene_yaml, Path::new(&m.scene_file))
                .with_context(|| format!("scene copy in {}/manifest.json", a.dir.display()))?;
            let (lo, hi) = (Vec3::from(scene.domain.min), Vec3::from(scene.domain.max));
            let h = scene.domain.dx * 0.5;
            (solid_points(&scene.solids, lo, hi, h), 0.6 * h)
        }
        _ => (Vec::new(), 0.0),
    };
    let count: usize = frames
        .par_iter()
        .map(|&f| -> Result<usize> {
            let fr = ply::read(&a.dir.join(ply::frame_name(f)))?;
            let p = &fr.particles;
            let size = ImageSize {
                width: a.width,
                height: a.height,
                splat: a.splat,
            };
            let img = render(&p.x, &p.radius, &p.codim, &cam, &size, &solid_pts, solid_r);
            let path = out.join(format!("frame.{f:04}.png"));
            img.save(&path)
                .with_context(|| format!("writing {}", path.display()))?;
            Ok(p.len())
        })
        .collect::<Result<Vec<_>>>()?
        .into_iter()
        .max()
        .unwrap_or(0);
    // contact sheet: up to 12 evenly spaced frames, 4 per row, half size
    let n = frames.len().min(12);
    let picks: Vec<u32> = (0..n)
        .map(|k| frames[k * (frames.len() - 1) / (n - 1).max(1)])
        .collect();
    let (tw, th) = (a.width / 2, a.height / 2);
    let cols = n.min(4) as u32;
    let rows = (n as u32).div_ceil(cols);
    let mut sheet = RgbImage::from_pixel(
        cols * (tw + 4) + 4,
        rows * (th + 4) + 4,
        image::Rgb([10, 10, 12]),
    );
    for (k, f) in picks.iter().enumerate() {
        let img = image::open(out.join(format!("frame.{f:04}.png")))?.to_rgb8();
        let small = imageops::resize(&img, tw, th, imageops::FilterType::Triangle);
        let (cx, cy) = (k as u32 % cols, k as u32 / cols);
        imageops::overlay(
            &mut sheet,
            &small,
            (4 + cx * (tw + 4)) as i64,
            (4 + cy * (th + 4)) as i64,
        );
    }
    let sp = out.join("contact_sheet.png");
    sheet
        .save(&sp)
        .with_context(|| format!("writing {}", sp.display()))?;
    eprintln!(
        "{} frames (up to {count} particles each) -> {} in {:.2} s; contact sheet of frames {:?}",
        frames.len(),
        out.display(),
        t0.elapsed().as_secs_f64(),
        picks
    );
    Ok(())
}
