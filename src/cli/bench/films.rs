//! `codimfx bench films`: wall time per stage of the grid-free film step on
//! the paper's film scenes at the paper's particle counts (Table 1): the
//! bursting bubble (~70k sheet particles, Δt = 0.002 s, 1/60 s frames) and
//! the catenoid (~63k, Δt = 0.005 s, 1/30 s frames). `--frames` frames from
//! the initial state are simulated with the substepping of `codimfx sim`
//! (Δt = min(paper Δt, `--cfl` spacings / max speed), see
//! [`codimfx::film::driver::substep`]); the table gives seconds per frame,
//! per stage and in all, the substeps per frame and the seconds per substep.
use anyhow::{Context, Result};
use clap::{Args, ValueEnum};
use codimfx::film::catenoid::CatenoidSetup;
use codimfx::film::deformation::latitude_sphere;
use codimfx::film::driver::substep;
use codimfx::film::step::{film_speed, step_with_retry};
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
    /// Frames to simulate (1/60 s bubble, 1/30 s catenoid).
    #[arg(long, default_value_t = 1)]
    frames: usize,
    /// Motion limit per substep, in particle spacings (`film.cfl`); default:
    /// the shipped preset's (bubble 2, catenoid 0.5).
    #[arg(long)]
    cfl: Option<Real>,
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
        ..FilmState::default()
    };
    (p, prm, st, 0.002)
}

fn catenoid(s: Real) -> (Particles, FilmParams, FilmState, Real) {
    // the inertial thickness of presets/catenoid.yaml (film plus the air it
    // moves, docs/decisions.md)
    let p = CatenoidSetup {
        thickness: 3e-5,
        ..CatenoidSetup::paper(s)
    }
    .particles();
    let mut prm = FilmParams::new(3.0 * s, 0.015);
    prm.gravity = Vec3::zeros();
    prm.damping = 5.0;
    (p, prm, FilmState::default(), 0.005)
}

/// Bubble rim position: arc length (on the sphere of radius 0.0576 m) from
/// the hole axis (+y) to the 2nd percentile of the sheet particles' polar
/// angles, as in `tests/films_sim.rs` (Taylor–Culick speed 1.0 m/s).
fn rim_arc(p: &Particles) -> Real {
    let mut th: Vec<Real> = (0..p.len())
        .filter(|&i| p.codim[i] == Codim::Sheet)
        .map(|i| (p.x[i].y / p.x[i].norm()).clamp(-1.0, 1.0).acos())
        .collect();
    if th.is_empty() {
        return Real::NAN;
    }
    th.sort_by(|a, b| a.total_cmp(b));
    th[th.len() / 50] * 0.0576
}

/// Runs the benchmark and prints a markdown table.
pub fn run(a: FilmsArgs) -> Result<()> {
    println!("threads: {}\n", rayon::current_num_threads());
    println!("| scene | particles | cfl | frame (s) | substeps/frame | advect | transition | reseed | forces | operators | tension | BiCGSTAB its | s/substep | s/frame | rim speed (m/s) |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for sc in &a.scenes {
        // paper counts: ~70k (bubble, spacing 7.7e-4 m), ~63k (catenoid, 4.43e-4 m)
        let spacing = match sc {
            Scene::Bubble => 7.7e-4 * a.coarsen,
            Scene::Catenoid => 4.43e-4 * a.coarsen,
        };
        let (mut p, prm, mut st, max_dt) = match sc {
            Scene::Bubble => bubble(spacing),
            Scene::Catenoid => catenoid(spacing),
        };
        let frame = match sc {
            Scene::Bubble => 1.0 / 60.0,
            Scene::Catenoid => 1.0 / 30.0,
        };
        // presets/bursting_bubble.yaml and presets/catenoid.yaml
        let cfl = a.cfl.unwrap_or(match sc {
            Scene::Bubble => 2.0,
            Scene::Catenoid => 0.5,
        });
        let n = p.len();
        let mut sum = FilmTimings::default();
        let (mut its, mut substeps) = (0usize, 0usize);
        let t0 = std::time::Instant::now();
        let mut arcs = vec![rim_arc(&p)];
        for f in 0..a.frames {
            // the substepping of `codimfx sim` (`film::driver::substep`)
            let mut left = frame;
            while left > 1e-12 * frame {
                let (dt, _) = substep(max_dt, cfl, spacing, film_speed(&p), left);
                let (info, _) = step_with_retry(&mut p, &mut st, &prm, dt, 2)
                    .with_context(|| format!("{sc} frame {} substep {}", f + 1, substeps + 1))?;
                left -= dt;
                substeps += 1;
                sum.add(&info.timings);
                its += info
                    .tension_solve
                    .iter()
                    .map(|s| s.iterations)
                    .sum::<usize>();
            }
            arcs.push(rim_arc(&p));
        }
        // mean rim speed after the first frame (which forms the rim); bubble only
        let rim_speed = match sc {
            Scene::Bubble if a.frames >= 2 => format!(
                "{:.3}",
                (arcs[a.frames] - arcs[1]) / ((a.frames - 1) as Real * frame)
            ),
            _ => "—".into(),
        };
        let wall = t0.elapsed().as_secs_f64();
        let k = a.frames.max(1) as Real;
        println!(
            "| {sc} | {n} | {cfl} | {frame:.4} | {:.1} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.1} | {:.3} | {:.2} | {rim_speed} |",
            substeps as Real / k,
            sum.advect / k,
            sum.transition / k,
            sum.reseed / k,
            sum.forces / k,
            sum.operators / k,
            sum.tension / k,
            its as Real / (3.0 * substeps.max(1) as Real),
            wall / substeps.max(1) as Real,
            wall / k
        );
    }
    println!(
        "\n(stage columns in s per frame; BiCGSTAB iterations per velocity component and substep)"
    );
    Ok(())
}
