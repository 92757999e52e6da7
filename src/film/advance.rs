//! Driving the film step (Algorithm 1 without a grid) through a span of
//! time: the motion limit's speed, the retry with halved substeps after a
//! failed solve, and the substep loop the validation cases use. Split from
//! [`super::step`] to keep the files short; [`super::step`] re-exports them.

use super::step::step;
use super::{FilmError, FilmParams, FilmState, FilmStepInfo};
use crate::math::Real;
use crate::particles::{Codim, Particles};

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
