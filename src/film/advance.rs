//! Driving the film step (Algorithm 1 without a grid) through a span of
//! time: the motion limit's speed, the retry with halved substeps after a
//! failed solve, and the substep loop the validation cases use. Split from
//! [`super::step`] to keep the files short; [`super::step`] re-exports them.

use super::step::step;
use super::{FilmError, FilmParams, FilmState, FilmStepInfo};
use crate::math::Real;
use crate::neighbors::CellGrid;
use crate::particles::{Codim, Particles};
use rayon::prelude::*;

/// Largest particle speed, the motion limit's input. Points (C = 3) count
/// too although they move ballistically: leaving them out lengthened the
/// bursting bubble's substeps once droplets formed and changed its rim speed
/// in the sixth frame (s = 4 mm) from 1.14 to 1.40 m/s (Taylor–Culick 1.0),
/// so the rim needs those shorter steps (`docs/decisions.md`). Scenes may
/// let points move further ([`motion_speed`], `film.point_cfl`).
pub fn film_speed(p: &Particles) -> Real {
    motion_speed(p, 1.0, 1.0)
}

/// The speed the substep's motion limit divides `cfl` × spacing by: the
/// largest speed of the sheet and filament particles, and of the points
/// (C = 3) scaled by `cfl / point_cfl`, so that a point moves at most
/// `point_cfl` spacings per substep. With `point_cfl == cfl` it is the
/// largest speed of all, [`film_speed`].
pub fn motion_speed(p: &Particles, cfl: Real, point_cfl: Real) -> Real {
    let ratio = cfl / point_cfl;
    (0..p.len())
        .map(|i| {
            let s = p.v[i].norm();
            if p.codim[i] == Codim::Point {
                s * ratio
            } else {
                s
            }
        })
        .fold(0.0, Real::max)
}

/// The motion limit's speed when sheets and filaments may drift
/// `drift_cfl` spacings per substep with their neighbours: for each sheet
/// or filament particle the larger of its largest speed relative to the
/// particles within `h + 2 drift_cfl spacing` (anything that can enter its
/// h-neighbourhood during the substep) and its own speed × `cfl /
/// drift_cfl`; points as in [`motion_speed`]. So a film's deformation moves
/// at most `cfl` spacings per substep, its rigid drift `drift_cfl`, and two
/// pieces that approach each other are limited by their closing speed
/// before they can meet. A particle with no neighbour but itself has
/// relative speed 0. The largest value is exact whatever the thread count.
pub fn drift_motion_speed(
    p: &Particles,
    h: Real,
    spacing: Real,
    cfl: Real,
    point_cfl: Real,
    drift_cfl: Real,
) -> Real {
    if p.is_empty() {
        return 0.0;
    }
    let r = h + 2.0 * drift_cfl * spacing;
    let grid = CellGrid::build(&p.x, r);
    let (to_point, to_drift) = (cfl / point_cfl, cfl / drift_cfl);
    (0..p.len())
        .into_par_iter()
        .map(|i| {
            let s = p.v[i].norm();
            if p.codim[i] == Codim::Point {
                return s * to_point;
            }
            let mut rel: Real = 0.0;
            grid.for_each_within(&p.x, &p.x[i], r, |j, _| {
                rel = rel.max((p.v[i] - p.v[j]).norm());
            });
            rel.max(s * to_drift)
        })
        .reduce(|| 0.0, Real::max)
}

/// Runs [`step`], halving the step (up to `max_halvings` times) when a
/// solve fails or a value turns non-finite; the state is restored before
/// each retry. Returns the info of the last sub-step and the number of
/// halvings used.
pub fn step_with_retry(
    parts: &mut Particles,
    state: &mut FilmState,
    prm: &FilmParams,
    dt: Real,
    max_halvings: u32,
) -> Result<(FilmStepInfo, u32), FilmError> {
    let mut halvings = 0;
    loop {
        let saved = (parts.clone(), state.clone());
        let n = 1u32 << halvings;
        let sub = dt / n as Real;
        let mut last = Ok(FilmStepInfo::default());
        for _ in 0..n {
            last = step(parts, state, prm, sub);
            if last.is_err() {
                break;
            }
        }
        match last {
            Ok(i) => return Ok((i, halvings)),
            Err(e) if halvings >= max_halvings => {
                *parts = saved.0;
                *state = saved.1;
                return Err(e);
            }
            Err(_) => {
                *parts = saved.0;
                *state = saved.1;
                halvings += 1;
            }
        }
    }
}

/// Advances the films by `duration` in substeps whose motion stays below
/// `cfl` × `spacing` (the last substeps split so none is tiny); returns the
/// number of substeps. Used by the validation cases; scenes go through
/// [`crate::step::step`] in the frame loop of [`crate::sim`], which also
/// keeps the frame record.
pub fn advance_by(
    parts: &mut Particles,
    state: &mut FilmState,
    prm: &FilmParams,
    duration: Real,
    spacing: Real,
    cfl: Real,
) -> Result<usize, FilmError> {
    let mut left = duration;
    let mut n = 0;
    while left > 1e-12 * duration {
        let vmax = film_speed(parts);
        let mut dt = if vmax > 0.0 {
            left.min(cfl * spacing / vmax)
        } else {
            left
        };
        if dt < left && left - dt < 0.2 * dt {
            dt = 0.5 * left;
        }
        step_with_retry(parts, state, prm, dt, 4)?;
        left -= dt;
        n += 1;
    }
    Ok(n)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;

    #[test]
    fn a_drifting_film_is_limited_by_its_neighbours_speeds_and_a_closing_one() {
        // a 5 x 5 patch of sheet (spacing 1, h = 3) drifting at 2 m/s with
        // one particle 0.1 m/s faster
        let mut p = Particles::new();
        for a in 0..5 {
            for b in 0..5 {
                let x = Vec3::new(a as Real, b as Real, 0.0);
                p.push(x, Vec3::new(2.0, 0.0, 0.0), 1.0, 1.0, Codim::Sheet);
            }
        }
        p.v[12].x += 0.1;
        let speed = |p: &Particles| drift_motion_speed(p, 3.0, 1.0, 0.5, 6.0, 2.0);
        // the drift counts at cfl / drift_cfl = 1/4 (0.525 m/s for the
        // fastest), the deformation at 0.1 m/s in full
        assert!((speed(&p) - 2.1 / 4.0).abs() < 1e-12, "{}", speed(&p));
        // a slow drift: the relative 0.1 m/s sets the step
        for v in p.v.iter_mut() {
            v.x -= 1.9;
        }
        assert!((speed(&p) - 0.1).abs() < 1e-12, "{}", speed(&p));
        // a filament fragment flying at the patch from 6 spacings away (beyond h, but
        // within h + 2 drift_cfl spacings) at 3 m/s: its closing speed, 3.1
        // m/s against the fastest sheet particle (0.2 m/s) counts in full
        let d = p.push(
            Vec3::new(10.0, 2.0, 0.0),
            Vec3::new(-3.0, 0.0, 0.0),
            1.0,
            1.0,
            Codim::Filament,
        );
        assert!((speed(&p) - 3.1).abs() < 1e-12, "{}", speed(&p));
        // further away it only drifts: 3 m/s at 1/4
        p.x[d].x = 20.0;
        assert!((speed(&p) - 0.75).abs() < 1e-12, "{}", speed(&p));
        // with drift_cfl = cfl nothing moves faster than in motion_speed's limit
        assert!(drift_motion_speed(&p, 3.0, 1.0, 0.5, 6.0, 0.5) >= motion_speed(&p, 0.5, 6.0));
    }

    #[test]
    fn points_enter_the_motion_limit_at_their_own_cfl() {
        let mut p = Particles::new();
        let o = Vec3::zeros();
        p.push(o, Vec3::new(0.0, 0.3, 0.4), 1.0, 1.0, Codim::Sheet);
        p.push(o, Vec3::new(1.0, 0.0, 0.0), 1.0, 1.0, Codim::Filament);
        p.push(o, Vec3::new(0.0, 0.0, -4.0), 1.0, 1.0, Codim::Point);
        // the same cfl for all: the largest speed, a point's
        assert_eq!(motion_speed(&p, 0.5, 0.5), film_speed(&p));
        assert_eq!(motion_speed(&p, 0.5, 0.5), 4.0);
        // a point may move 4x further: 4 m/s counts as 1 m/s, the filament's
        assert_eq!(motion_speed(&p, 0.5, 2.0), 1.0);
        // 8x: the filament's 1 m/s sets the step, the point's 0.5 does not
        assert_eq!(motion_speed(&p, 0.5, 4.0), 1.0);
        // the filament at rest: the sheet's 0.5 m/s, the point's 0.125 not
        p.v[1] = Vec3::zeros();
        assert_eq!(motion_speed(&p, 0.5, 16.0), 0.5);
        assert_eq!(motion_speed(&p, 0.5, 2.0), 1.0);
    }
}
