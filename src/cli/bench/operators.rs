//! `codimfx bench operators`: time per stage of the MLS operators (neighbour
//! search, frames, fits, Laplacian rows, CSR assembly) on sphere sheets of
//! 30k / 120k / 480k particles with ~72 neighbours each (h = 4.88 Δ, as the
//! paper's 30k case), and the run time against error of sphere diffusion
//! (resolution × operator × scheme). `--plot FILE.png` draws error against
//! run time, log–log.
use anyhow::{Context, Result};
use clap::Args;
use codimfx::mls::laplacian::{csr_from_rows, laplacian_rows, row_entries};
use codimfx::mls::operators::{fit_particle, par_fit_map, par_frames};
use codimfx::mls::{MlsParams, Neighborhoods};
use codimfx::validate::sampling::{sphere_latitude, sphere_spacing_for};
use codimfx::validate::sphere_diffusion::{EigenMethod, Scheme, SphereDiffusion};
use codimfx::Real;
use rayon::prelude::*;
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `codimfx bench operators`.
#[derive(Args, Debug)]
pub struct OperatorsArgs {
    /// Sheet particle counts for the stage timings (comma separated).
    #[arg(long, value_delimiter = ',', default_values_t = vec![30_000usize, 120_000, 480_000])]
    sizes: Vec<usize>,
    /// Fit order for the stage timings (default: the default operator's 4).
    #[arg(long, default_value_t = 4)]
    order: usize,
    /// Repetitions per stage; the fastest is reported.
    #[arg(long, default_value_t = 3)]
    reps: usize,
    /// Particle counts of the sphere-diffusion error/time table (h scaled
    /// with the spacing as in the default 30k, h = 0.1 case).
    #[arg(long, value_delimiter = ',', default_values_t = vec![7_500usize, 30_000, 120_000])]
    diffusion_sizes: Vec<usize>,
    /// Skip the sphere-diffusion error/time table.
    #[arg(long)]
    no_diffusion: bool,
    /// Write a log–log plot of error against run time to this PNG file.
    #[arg(long)]
    plot: Option<PathBuf>,
}

/// CPU seconds (user + system, all threads) of this process so far, from
/// /proc/self/stat (clock ticks of 1/100 s); `None` where unavailable.
fn cpu_seconds() -> Option<Real> {
    let s = std::fs::read_to_string("/proc/self/stat").ok()?;
    let rest = &s[s.rfind(')')? + 2..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    // fields 14 and 15 of stat(5) are utime and stime; `rest` starts at field 3
    let ut: Real = f.get(11)?.parse().ok()?;
    let st: Real = f.get(12)?.parse().ok()?;
    Some((ut + st) / 100.0)
}

/// Fastest wall time over `reps` runs, and the mean CPU time per run.
fn best_of<T>(reps: usize, mut f: impl FnMut() -> T) -> (Real, T) {
    let mut best = Real::INFINITY;
    let mut out = None;
    for _ in 0..reps.max(1) {
        let t = Instant::now();
        let r = f();
        best = best.min(t.elapsed().as_secs_f64());
        out = Some(r);
    }
    (best, out.expect("at least one repetition"))
}

/// Mean CPU seconds per run of `f` over `reps` runs (None without /proc).
fn cpu_of(reps: usize, mut f: impl FnMut()) -> Option<Real> {
    let c0 = cpu_seconds()?;
    for _ in 0..reps.max(1) {
        f();
    }
    Some((cpu_seconds()? - c0) / reps.max(1) as Real)
}

/// One point of the error/time table.
pub(super) struct Point {
    pub(super) series: usize,
    pub(super) seconds: Real,
    pub(super) error: Real,
}

/// Runs the benchmark and prints markdown tables.
pub fn run(a: OperatorsArgs) -> Result<()> {
    println!("threads: {}\n", rayon::current_num_threads());
    println!(
        "## MLS operator stages (sheet particles on the unit sphere, h = 4.88 Δ, order {})\n",
        a.order
    );
    println!("Wall times are the fastest of --reps runs; CPU time (all threads, from /proc) is load-independent,");
    println!("and 2 cores / CPU time is the throughput two unshared cores would give.\n");
    println!("| particles | nbrs | neighbours ns/p | frames ns/p | fits ns/p | fits+rows ns/p | assembly ns/p | frames+fits+rows particles/s (wall) | frames+fits+rows CPU ns/p | particles/s on 2 free cores |");
    println!("|---|---|---|---|---|---|---|---|---|---|");
    for &n in &a.sizes {
        let sp = sphere_spacing_for(n, 1.0);
        let h = 4.88 * sp;
        let x = sphere_latitude(1.0, sp, 0.0, 1);
        let mut params = MlsParams::new(h);
        params.order = a.order;
        params.validate()?;
        let np = x.len() as Real;
        let (t_nb, nb) = best_of(a.reps, || Neighborhoods::sheet(&x, h));
        let nb = nb?;
        let (t_fr, frames) = best_of(a.reps, || par_frames(&nb, &params));
        let (t_fit, ok) = best_of(a.reps, || {
            (0..nb.len())
                .into_par_iter()
                .filter(|&p| fit_particle(&nb, p, &frames[p], &params).fit().is_some())
                .count()
        });
        anyhow::ensure!(ok == nb.len(), "only {ok} of {} fits succeeded", nb.len());
        let (t_rows, rows) = best_of(a.reps, || {
            par_fit_map(&nb, &frames, &params, |_, f| {
                f.map_or_else(Vec::new, |f| row_entries(f, params.christoffel))
            })
            .0
        });
        let (t_asm, m) = best_of(a.reps, || csr_from_rows(nb.len(), nb.len(), rows.clone()));
        m?;
        // cross-check: the library's one-call path gives the same rows
        let (lib_rows, _) = laplacian_rows(&nb, &params)?;
        anyhow::ensure!(
            lib_rows == rows,
            "stage-by-stage rows differ from laplacian_rows"
        );
        let ops = t_fr + t_rows;
        // CPU time of frames + fits + rows, repeated to ≥ ~1 s for the 10 ms clock
        let creps = ((1.0 / ops.max(1e-3)).ceil() as usize).clamp(a.reps.max(1), 50);
        let cpu = cpu_of(creps, || {
            let fr = par_frames(&nb, &params);
            let r = par_fit_map(&nb, &fr, &params, |_, f| {
                f.map_or_else(Vec::new, |f| row_entries(f, params.christoffel))
            });
            std::hint::black_box(r);
        });
        println!(
            "| {} | {:.1} | {:.0} | {:.0} | {:.0} | {:.0} | {:.0} | {:.0} | {} | {} |",
            x.len(),
            nb.lists.mean_count(),
            t_nb * 1e9 / np,
            t_fr * 1e9 / np,
            t_fit * 1e9 / np,
            t_rows * 1e9 / np,
            t_asm * 1e9 / np,
            np / ops,
            cpu.map_or("-".into(), |c| format!("{:.0}", c * 1e9 / np)),
            cpu.map_or("-".into(), |c| format!("{:.0}", 2.0 * np / c)),
        );
    }
    if a.no_diffusion || a.diffusion_sizes.is_empty() {
        return Ok(());
    }
    let h_over = 0.1 / sphere_spacing_for(30_000, 1.0);
    let series: [(&str, bool, Scheme, [u8; 3]); 4] = [
        (
            "default (order 4) + exact",
            false,
            Scheme::Exact,
            [200, 30, 30],
        ),
        (
            "default (order 4) + forward Euler dt=1e-3",
            false,
            Scheme::ForwardEuler,
            [240, 150, 20],
        ),
        (
            "paper (order 2) + exact",
            true,
            Scheme::Exact,
            [30, 60, 200],
        ),
        (
            "paper (order 2) + forward Euler dt=1e-3",
            true,
            Scheme::ForwardEuler,
            [30, 170, 60],
        ),
    ];
    println!("\n## Sphere diffusion to t = 0.5: run time against error (h = {h_over:.3} Δ; seconds end to end, no eigenvalue)\n");
    println!("| particles | h | operator + scheme | spatial max error | total max error | L1 error | seconds |");
    println!("|---|---|---|---|---|---|---|");
    let mut points = Vec::new();
    for &n in &a.diffusion_sizes {
        let h = h_over * sphere_spacing_for(n, 1.0);
        for (si, (name, paper, scheme, _)) in series.iter().enumerate() {
            let case = SphereDiffusion {
                particles: n,
                scheme: *scheme,
                dt: 1e-3,
                mls: if *paper {
                    MlsParams::paper(h)
                } else {
                    MlsParams::new(h)
                },
                eigen: EigenMethod::None,
                ..SphereDiffusion::default()
            };
            let r = case
                .run()
                .with_context(|| format!("sphere diffusion {n} {name}"))?;
            println!(
                "| {} | {:.4} | {name} | {:.3e} | {:.3e} | {:.3e} | {:.2} |",
                r.particles, h, r.spatial_max_error, r.total_max_error, r.l1_error, r.seconds
            );
            points.push(Point {
                series: si,
                seconds: r.seconds,
                error: r.total_max_error,
            });
        }
    }
    if let Some(path) = &a.plot {
        let colors: Vec<[u8; 3]> = series.iter().map(|s| s.3).collect();
        plot(path, &points, &colors)?;
        println!(
            "\nplot: {} (x: seconds, y: total max error, log–log, grid at decades; unstable runs (error ≥ 1) left out)",
            path.display()
        );
        for (name, _, _, c) in &series {
            println!("  rgb{c:?}: {name}");
        }
    }
    Ok(())
}

/// Draws a log–log scatter with lines joining each series, grid lines at
/// every decade, to a PNG.
pub(super) fn plot(path: &PathBuf, pts: &[Point], colors: &[[u8; 3]]) -> Result<()> {
    use image::{Rgb, RgbImage};
    let (w, h, m) = (900u32, 600u32, 50i64);
    let mut img = RgbImage::from_pixel(w, h, Rgb([255, 255, 255]));
    // unstable runs (error ≥ 1 or infinite) are left out of the plot; the table lists them
    let shown = |p: &Point| p.seconds > 0.0 && p.error > 0.0 && p.error < 1.0;
    let good: Vec<&Point> = pts.iter().filter(|p| shown(p)).collect();
    anyhow::ensure!(!good.is_empty(), "nothing to plot");
    let lx: Vec<Real> = good.iter().map(|p| p.seconds.log10()).collect();
    let ly: Vec<Real> = good.iter().map(|p| p.error.log10()).collect();
    let (x0, x1) = (
        lx.iter().cloned().fold(Real::INFINITY, Real::min).floor(),
        lx.iter()
            .cloned()
            .fold(Real::NEG_INFINITY, Real::max)
            .ceil(),
    );
    let (y0, y1) = (
        ly.iter().cloned().fold(Real::INFINITY, Real::min).floor(),
        ly.iter()
            .cloned()
            .fold(Real::NEG_INFINITY, Real::max)
            .ceil(),
    );
    let (x1, y1) = (x1.max(x0 + 1.0), y1.max(y0 + 1.0));
    let px = |v: Real| m + ((v - x0) / (x1 - x0) * (w as i64 - 2 * m) as Real) as i64;
    let py = |v: Real| h as i64 - m - ((v - y0) / (y1 - y0) * (h as i64 - 2 * m) as Real) as i64;
    let put = |img: &mut RgbImage, x: i64, y: i64, c: [u8; 3]| {
        if x >= 0 && y >= 0 && x < w as i64 && y < h as i64 {
            img.put_pixel(x as u32, y as u32, Rgb(c));
        }
    };
    // decade grid and axes
    for d in (x0 as i64)..=(x1 as i64) {
        let x = px(d as Real);
        for y in m..=(h as i64 - m) {
            put(
                &mut img,
                x,
                y,
                if d == x0 as i64 {
                    [0, 0, 0]
                } else {
                    [215, 215, 215]
                },
            );
        }
    }
    for d in (y0 as i64)..=(y1 as i64) {
        let y = py(d as Real);
        for x in m..=(w as i64 - m) {
            put(
                &mut img,
                x,
                y,
                if d == y0 as i64 {
                    [0, 0, 0]
                } else {
                    [215, 215, 215]
                },
            );
        }
    }
    // lines joining consecutive points of a series (in resolution order)
    for (s, &color) in colors.iter().enumerate() {
        let ser: Vec<(i64, i64)> = pts
            .iter()
            .filter(|p| p.series == s && shown(p))
            .map(|p| (px(p.seconds.log10()), py(p.error.log10())))
            .collect();
        for wnd in ser.windows(2) {
            let (a, b) = (wnd[0], wnd[1]);
            let steps = (b.0 - a.0).abs().max((b.1 - a.1).abs()).max(1);
            for k in 0..=steps {
                let x = a.0 + (b.0 - a.0) * k / steps;
                let y = a.1 + (b.1 - a.1) * k / steps;
                put(&mut img, x, y, color);
            }
        }
        for (x, y) in ser {
            for dx in -4..=4 {
                for dy in -4..=4 {
                    put(&mut img, x + dx, y + dy, color);
                }
            }
        }
    }
    img.save(path)
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}
