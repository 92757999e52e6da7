//! Film-only scenes (no liquid, no grid): the film step's parameters and
//! initial state from the scene, the substep length (motion per substep
//! limited to `film.cfl` particle spacings, [`film_substep`]), droplets stopped at the domain
//! box, and the cache's frame vectors. The frame loop is [`crate::sim`]'s and
//! the substep [`crate::step::step`]'s, as for every scene.

use super::advance::{drift_motion_speed, motion_speed};
use super::air::AirParams;
use super::{FilmParams, FilmState, Gust, Wind};
use crate::gas::GasPocket;
use crate::linsolve::BicgstabParams;
use crate::math::{Real, Vec3};
use crate::mls::MlsParams;
use crate::particles::{Codim, Particles};
use crate::scene::{FilmBody, Scene};

/// Film solver parameters of a validated scene (h = Δx).
pub fn params_from_scene(s: &Scene) -> FilmParams {
    let h = s.domain.dx;
    let f = &s.film;
    let mut prm = FilmParams::new(h, s.physics.surface_tension);
    prm.mls = MlsParams {
        order: f.order,
        ..prm.mls
    };
    prm.density = s.physics.density;
    prm.viscosity = s.physics.viscosity;
    let a = s.acceleration();
    prm.gravity = Vec3::new(a[0], a[1], a[2]);
    prm.damping = f.damping;
    prm.marangoni = f.marangoni;
    prm.wind = f.wind.as_ref().map(|w| Wind {
        velocity: Vec3::from(w.velocity),
        air_density: w.air_density,
        drag: w.drag,
        gust: w.gust.as_ref().map(|g| Gust {
            start: g.start,
            duration: g.duration,
            period: g.period,
            between: g.between,
        }),
        radius: w.radius,
        origin: Vec3::from(w.origin),
    });
    // the bag hangs from the first disk's ring, its axis along the wind
    if let (true, Some(w)) = (f.bag_air, &prm.wind) {
        if let Some(FilmBody::Disk {
            center,
            normal,
            radius,
            ..
        }) = s.films.iter().find(|b| matches!(b, FilmBody::Disk { .. }))
        {
            let mut axis = Vec3::from(*normal).normalize();
            if axis.dot(&w.velocity) < 0.0 {
                axis = -axis;
            }
            prm.air = Some(AirParams::new(
                Vec3::from(*center),
                axis,
                *radius,
                w.air_density,
                h,
            ));
        }
    }
    if !f.transitions {
        prm.transitions = None;
    }
    if !f.reseed {
        prm.reseed = None;
    }
    // rings pulled apart stretch the film along one direction only: fill the
    // empty lines of the reseeding grid too (`ReseedParams::gap_lines`)
    let moving_rings = s
        .films
        .iter()
        .any(|b| matches!(b, FilmBody::Cylinder { ring_speed, .. } if *ring_speed != 0.0));
    if let Some(r) = prm.reseed.as_mut() {
        r.gap_lines = moving_rings;
        if moving_rings {
            r.heavy_fraction = crate::reseed::HEAVY_FRACTION;
        }
    }
    prm.solver = BicgstabParams {
        tol: f.solver_tolerance,
        max_iter: f.solver_max_iterations,
    };
    prm.max_speed = f.max_speed;
    prm.diffusive = f.diffusive();
    prm.rim_modulation = f.rim_modulation.as_ref().map(|m| m.sawtooth());
    prm
}

/// Initial film state: a soft gas pocket balanced for the first spherical
/// film when `film.gas` is set (rest volume measured on the first step).
pub fn initial_state(s: &Scene) -> FilmState {
    let gas = s.film.gas.then(|| {
        let r = s
            .films
            .iter()
            .find_map(|b| match b {
                FilmBody::Sphere { radius, .. } => Some(*radius),
                _ => None,
            })
            .unwrap_or(s.domain.dx);
        GasPocket {
            v0: 0.0,
            ..GasPocket::balanced_sphere(r, s.physics.surface_tension, 0.0)
        }
    });
    FilmState {
        gas,
        ..FilmState::default()
    }
}

/// Smallest film particle spacing of the scene (m).
pub fn spacing(s: &Scene) -> Real {
    s.films
        .iter()
        .map(|b| match b {
            FilmBody::Sphere { spacing, .. }
            | FilmBody::Cylinder { spacing, .. }
            | FilmBody::Disk { spacing, .. } => *spacing,
        })
        .fold(1.0, Real::min)
        * s.domain.dx
}

/// Length of the next substep with `rem` seconds of the frame left: at
/// most `max_dt`, motion at most `cfl` × `spacing` at speed `vmax`, and the
/// rest of the frame split in two rather than leaving a sliver. Returns the
/// substep and whether it ends the frame.
pub fn substep(max_dt: Real, cfl: Real, spacing: Real, vmax: Real, rem: Real) -> (Real, bool) {
    let mut dt = max_dt;
    if vmax > 0.0 {
        dt = dt.min(cfl * spacing / vmax);
    }
    fit_to_frame(dt, rem)
}

/// The next substep of a film-only scene at time `t` with `rem` seconds of
/// the frame left, and whether it ends the frame: motion per substep at most
/// `film.cfl` particle spacings, droplets `film.point_cfl`, and with
/// `film.drift_cfl` a film's drift with its neighbours that many
/// ([`super::advance::drift_motion_speed`]). The drift limit is not used
/// while a jet blows: the film it blows into a bag then moves as a whole at
/// up to the jet's speed, and the longer steps burst it (docs/decisions.md,
/// "Motion limit and drift").
pub fn film_substep(
    s: &Scene,
    wind: Option<&Wind>,
    p: &Particles,
    t: Real,
    rem: Real,
) -> (Real, bool) {
    let film = &s.film;
    let spacing = spacing(s);
    let point_cfl = film.point_cfl.unwrap_or(film.cfl);
    let jet = wind.is_some_and(|w| w.jet_blowing(t));
    let speed = match film.drift_cfl {
        Some(drift) if !jet => {
            drift_motion_speed(p, s.domain.dx, spacing, film.cfl, point_cfl, drift)
        }
        _ => motion_speed(p, film.cfl, point_cfl),
    };
    substep(s.time.max_dt, film.cfl, spacing, speed, rem)
}

/// A substep of at most `dt` with `rem` seconds of the frame left: the rest
/// of the frame when it fits, half of it when `dt` would leave a sliver
/// shorter than `dt`; returns it and whether it ends the frame. Every scene's
/// frame loop uses it ([`crate::sim`]).
pub fn fit_to_frame(dt: Real, rem: Real) -> (Real, bool) {
    if dt >= rem {
        (rem, true)
    } else if dt > 0.5 * rem {
        (0.5 * rem, false)
    } else {
        (dt, false)
    }
}

/// Droplets (points) stop at the domain box: a droplet shot from a
/// pinching neck at 10–30 m/s would otherwise fly metres away, set the
/// substep through the motion limit and the preview's framing. It is put
/// back on the wall and loses its outward velocity. Sheets and filaments
/// are left alone (a bubble's retracting rim may pass the box). Returns
/// the number of clamped coordinates (the manifest's `fallbacks.wall_clamps`).
pub fn close_walls(p: &mut Particles, lo: Vec3, hi: Vec3) -> usize {
    let mut n = 0;
    for i in 0..p.len() {
        if p.fixed[i] || p.codim[i] != Codim::Point {
            continue;
        }
        for a in 0..3 {
            if p.x[i][a] < lo[a] {
                p.x[i][a] = lo[a];
                p.v[i][a] = p.v[i][a].max(0.0);
                n += 1;
            } else if p.x[i][a] > hi[a] {
                p.x[i][a] = hi[a];
                p.v[i][a] = p.v[i][a].min(0.0);
                n += 1;
            }
        }
    }
    n
}
