//! `codimfx bench neighbors`: the measurement behind the choice of the
//! neighbour search (docs/decisions.md). Sheet-like point sets (a jittered
//! sphere surface sampled at spacing Δ) and volume-like ones (a jittered
//! lattice block) at several sizes, with the radius chosen for a target
//! neighbour count; both structures must return identical lists.
use anyhow::{ensure, Result};
use clap::Args;
use codimfx::neighbors::{neighbor_lists, neighbor_lists_kiddo};
use codimfx::{Real, Vec3};
use std::time::Instant;

/// Arguments of `codimfx bench neighbors`.
#[derive(Args, Debug)]
pub struct NeighborsArgs {
    /// Particle counts to measure (comma separated).
    #[arg(long, value_delimiter = ',', default_values_t = vec![30_000usize, 120_000, 480_000])]
    sizes: Vec<usize>,
    /// Target mean neighbour counts (comma separated).
    #[arg(long, value_delimiter = ',', default_values_t = vec![40usize, 80])]
    neighbors: Vec<usize>,
    /// Repetitions per measurement; the fastest is reported.
    #[arg(long, default_value_t = 3)]
    reps: usize,
}

/// Deterministic pseudo-random numbers in [0, 1) (SplitMix64).
fn rand01(state: &mut u64) -> Real {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    ((z ^ (z >> 31)) >> 11) as Real / (1u64 << 53) as Real
}

/// A jittered volume block of `n` points, unit spacing.
fn block(n: usize) -> Vec<Vec3> {
    let side = (n as Real).cbrt().ceil() as usize;
    let mut s = 7u64;
    let mut v = Vec::with_capacity(n);
    'outer: for i in 0..side {
        for j in 0..side {
            for k in 0..side {
                if v.len() == n {
                    break 'outer;
                }
                let mut jit = || 0.3 * (rand01(&mut s) - 0.5);
                v.push(Vec3::new(
                    i as Real + jit(),
                    j as Real + jit(),
                    k as Real + jit(),
                ));
            }
        }
    }
    v
}

/// `n` points on a sphere (golden spiral), mean spacing 1.
fn sphere(n: usize) -> Vec<Vec3> {
    let r = (n as Real / (4.0 * std::f64::consts::PI)).sqrt();
    let ga = std::f64::consts::PI * (3.0 - (5.0 as Real).sqrt());
    (0..n)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as Real + 0.5) / n as Real;
            let rho = (1.0 - z * z).sqrt();
            let t = ga * i as Real;
            Vec3::new(r * rho * t.cos(), r * rho * t.sin(), r * z)
        })
        .collect()
}

fn best_of<T>(reps: usize, mut f: impl FnMut() -> T) -> (Real, T) {
    let mut best = Real::INFINITY;
    let mut out = None;
    for _ in 0..reps.max(1) {
        let t = Instant::now();
        let r = f();
        best = best.min(t.elapsed().as_secs_f64());
        out = Some(r);
    }
    (best, out.unwrap())
}

/// Runs the benchmark and prints a markdown table.
pub fn run(a: NeighborsArgs) -> Result<()> {
    println!(
        "threads: {}\n\n| set | particles | mean nbrs | cell grid (ms) | kiddo (ms) | grid ns/particle | kiddo ns/particle |",
        rayon::current_num_threads()
    );
    println!("|---|---|---|---|---|---|---|");
    for &n in &a.sizes {
        for (name, pts, dim) in [("sheet", sphere(n), 2.0), ("volume", block(n), 3.0)] {
            for &k in &a.neighbors {
                // radius giving ~k neighbours at unit density in `dim` dimensions
                let r: Real = if dim == 2.0 {
                    (k as Real / std::f64::consts::PI).sqrt()
                } else {
                    (3.0 * k as Real / (4.0 * std::f64::consts::PI)).cbrt()
                };
                let (tg, g) = best_of(a.reps, || neighbor_lists(&pts, r));
                let (tk, kd) = best_of(a.reps, || neighbor_lists_kiddo(&pts, r));
                ensure!(
                    g == kd,
                    "cell grid and kiddo disagree on {name} n={n} k={k}"
                );
                println!(
                    "| {name} | {n} | {:.1} | {:.1} | {:.1} | {:.0} | {:.0} |",
                    g.mean_count(),
                    tg * 1e3,
                    tk * 1e3,
                    tg * 1e9 / n as Real,
                    tk * 1e9 / n as Real
                );
            }
        }
    }
    Ok(())
}
