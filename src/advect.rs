//! Particle advection, Algorithm 1 step 1.
//!
//! Codimension-0 particles move through the divergence-free grid velocity
//! with the explicit midpoint rule (second order):
//! `x* = x + ½Δt u(x)`, `x ← x + Δt u(x*)`. Particles of other codimensions
//! (added by later stages) move with their own velocity. A particle that ends
//! inside a static solid is projected to the solid surface along the SDF
//! gradient, and one that leaves the domain box is clamped back; both
//! corrections are counted and reported per frame. A sheet, filament or
//! point particle stopped that way also loses its velocity into the wall or
//! solid.

use crate::grid::MacGrid;
use crate::math::{Real, Vec3};
use crate::particles::{Codim, Particles};
use crate::solids::SolidSet;
use rayon::prelude::*;

/// Corrections made while advecting.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AdvectInfo {
    /// Particles moved out of a solid.
    pub solid_pushouts: usize,
    /// Particles clamped back into the domain box.
    pub wall_clamps: usize,
}

/// Moves every non-fixed particle by one substep `dt` (s).
pub fn advect(
    parts: &mut Particles,
    grid: &MacGrid,
    solids: &SolidSet,
    lo: Vec3,
    hi: Vec3,
    dt: Real,
) -> AdvectInfo {
    let eps = 1e-3 * grid.dx;
    let (pushes, clamps): (Vec<u8>, Vec<u8>) = parts
        .x
        .par_iter_mut()
        .zip(parts.v.par_iter_mut())
        .zip(parts.codim.par_iter().zip(parts.fixed.par_iter()))
        .map(|((x, v), (c, fixed))| {
            if *fixed {
                return (0, 0);
            }
            let own = *c != Codim::Volume;
            let mut p = if own {
                *x + *v * dt
            } else {
                let mid = *x + grid.velocity(x) * (0.5 * dt);
                *x + grid.velocity(&mid) * dt
            };
            let (pushed, clamped) = solids.push_out_in_box(&mut p, &lo, &hi, eps, 1e-3 * grid.dx);
            *x = p;
            if own && (pushed || clamped) {
                stop_at_walls(&p, v, solids, &lo, &hi, eps, grid.dx);
            }
            (pushed as u8, clamped as u8)
        })
        .unzip();
    AdvectInfo {
        solid_pushouts: pushes.iter().map(|&b| b as usize).sum(),
        wall_clamps: clamps.iter().map(|&b| b as usize).sum(),
    }
}

/// A sheet, filament or point particle that a wall or a solid stopped loses
/// the part of its velocity that points into it (an inelastic stop): its
/// velocity is its own, and kept it would push into the wall every
/// substep, and a stray droplet flying at a wall corner would set the CFL
/// substep of the whole scene (the grid's free-slip condition does the
/// same for the volume particles).
fn stop_at_walls(
    x: &Vec3,
    v: &mut Vec3,
    solids: &SolidSet,
    lo: &Vec3,
    hi: &Vec3,
    eps: Real,
    dx: Real,
) {
    for d in 0..3 {
        let at_lo = x[d] <= lo[d] + 2.0 * eps && v[d] < 0.0;
        let at_hi = x[d] >= hi[d] - 2.0 * eps && v[d] > 0.0;
        if at_lo || at_hi {
            v[d] = 0.0;
        }
    }
    if !solids.is_empty() && solids.phi(x) < 2.0 * eps {
        let n = solids.normal(x, 1e-3 * dx);
        let vn = v.dot(&n);
        if vn < 0.0 {
            *v -= n * vn;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_droplet_stopped_by_a_wall_keeps_only_its_tangential_velocity() {
        let (lo, hi) = (Vec3::zeros(), Vec3::repeat(1.0));
        let g = MacGrid::new(lo, hi, 0.1);
        let mut p = Particles::default();
        // a point 1 cm from the x = 1 wall flying at it (and along y);
        // a filament particle in the open; a point at the corner x = z = 0
        let start = [
            (
                Vec3::new(0.99, 0.5, 0.5),
                Vec3::new(5.0, 2.0, 0.0),
                Codim::Point,
            ),
            (
                Vec3::new(0.5, 0.5, 0.5),
                Vec3::new(5.0, 2.0, 0.0),
                Codim::Filament,
            ),
            (
                Vec3::new(0.01, 0.5, 0.01),
                Vec3::new(-3.0, 1.0, -4.0),
                Codim::Point,
            ),
        ];
        let [a, b, c] = start.map(|(x, v, k)| p.push(x, v, 1.0, 0.01, k));
        let info = advect(&mut p, &g, &SolidSet::default(), lo, hi, 0.01);
        assert_eq!(info.wall_clamps, 2);
        assert!(p.x[a][0] < 1.0 && p.x[c][0] > 0.0 && p.x[c][2] > 0.0);
        assert_eq!(p.v[a], Vec3::new(0.0, 2.0, 0.0));
        assert_eq!(p.v[b], Vec3::new(5.0, 2.0, 0.0));
        assert_eq!(p.v[c], Vec3::new(0.0, 1.0, 0.0));
        assert!((p.x[b] - Vec3::new(0.55, 0.52, 0.5)).norm() < 1e-12);
    }
}
