//! `codimfx bench films`: wall time per stage of the grid-free film step on
//! the paper's film scenes at the paper's particle counts (Table 1): the
//! bursting bubble (~70k sheet particles, Δt = 0.002 s) and the catenoid
//! (~63k, Δt = 0.005 s). The first `--substeps` steps from the initial state
//! are timed at the paper's Δt; "s per paper step" is their mean.
use anyhow::{Context, Result};
use clap::{Args, ValueEnum};
use codimfx::film::catenoid::CatenoidSetup;
use codimfx::film::deformation::latitude_sphere;
use codimfx::film::step::step_with_retry;
use codimfx::film::{FilmParams, FilmState, FilmTimings};
use codimfx::gas::GasPocket;
use codimfx::math::{Real, Vec3};
use codimfx::particles::{Codim, Particles};

/// Which film scene to time.
#[derive(Clone, Copy, Debug, ValueEnum)]
enum Scene {
    /// Bursting bubble (Fig. 9): R = 0.0576 m, σ = 5e-4, hole half-angle 0.45 rad.
    Bubble,
    /// Film catenoid (Fig. 6): R = 0.0512 m, d = 0.0384 m, σ = 0.015.
    Catenoid,
}

/// Arguments of `codimfx bench films`.
#[derive(Args, Debug)]
pub struct FilmsArgs {
    /// Scenes to time (comma separated).
    #[arg(long, value_delimiter = ',', default_values_t = vec![Scene::Bubble, Scene::Catenoid])]
    scenes: Vec<Scene>,
    /// Particle spacing relative to the paper's (2 = a quarter of the particles).
    #[arg(long, default_value_t = 1.0)]
    coarsen: Real,
    /// Steps to time.
    #[arg(long, default_value_t = 5)]
    substeps: usize,
}

impl std::fmt::Display for Scene {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Scene::Bubble => "bubble",
            Scene::Catenoid => "catenoid",
        })
    }
}

fn bubble(s: Real) -> (Particles, FilmParams, FilmState, Real) {
    let r = 0.0576;
    let tau = 1e-6;
    let pts = latitude_sphere(Vec3::zeros(), r, s);
    let a = 4.0 * std::f64::consts::PI * r * r / pts.len() as Real;
    let mut p = Particles::new();
    let up = Vec3::y();
    for x in pts {
        if x.normalize().dot(&up) < 0.45f64.cos() {
            p.push(x, Vec3::zeros(), 1000.0 * tau * a, 0.5 * tau, Codim::Sheet);
        }
    }
    let mut prm = FilmParams::new(3.0 * s, 5e-4);
    prm.gravity = Vec3::zeros();
    let st = FilmState {
        gas: Some(GasPocket {
            v0: 0.0,
            ..GasPocket::balanced_sphere(r, 5e-4, 0.0)
        }),
    };
    (p, prm, st, 0.002)
}

fn catenoid(s: Real) -> (Particles, FilmParams, FilmState, Real) {
    let p = CatenoidSetup::paper(s).particles();
    let mut prm = FilmParams::new(3.0 * s, 0.015);
    prm.gravity = Vec3::zeros();
    prm.damping = 5.0;
    (p, prm, FilmState::default(), 0.005)
}

/// Runs the benchmark and prints a markdown table.
pub fn run(a: FilmsArgs) -> Result<()> {
    println!("threads: {}\n", rayon::current_num_threads());
    println!("| scene | particles | Δt (s) | advect | transition | reseed | forces | operators | tension | BiCGSTAB its | s per paper step |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    for sc in &a.scenes {
        // paper counts: ~70k (bubble, spacing 7.7e-4 m), ~63k (catenoid, 4.4e-4 m)
        let (mut p, prm, mut st, dt) = match sc {
            Scene::Bubble => bubble(7.7e-4 * a.coarsen),
            Scene::Catenoid => catenoid(4.43e-4 * a.coarsen),
        };
        let n = p.len();
        let mut sum = FilmTimings::default();
        let mut its = 0usize;
        let t0 = std::time::Instant::now();
        for k in 0..a.substeps {
            let (info, _) = step_with_retry(&mut p, &mut st, &prm, dt, 2)
                .with_context(|| format!("{sc} step {}", k + 1))?;
            let t = info.timings;
            sum.advect += t.advect;
            sum.transition += t.transition;
            sum.reseed += t.reseed;
            sum.forces += t.forces;
            sum.operators += t.operators;
            sum.tension += t.tension;
            its += info
                .tension_solve
                .iter()
                .map(|s| s.iterations)
                .sum::<usize>();
        }
        let k = a.substeps.max(1) as Real;
        println!(
            "| {sc} | {n} | {dt} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.1} | {:.2} |",
            sum.advect / k,
            sum.transition / k,
            sum.reseed / k,
            sum.forces / k,
            sum.operators / k,
            sum.tension / k,
            its as Real / (3.0 * k),
            t0.elapsed().as_secs_f64() / k
        );
    }
    println!("\n(stage columns in s per step; BiCGSTAB iterations per velocity component)");
    Ok(())
}
