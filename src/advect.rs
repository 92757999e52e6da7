//! Particle advection, Algorithm 1 step 1.
//!
//! Codimension-0 particles move through the divergence-free grid velocity
//! with the explicit midpoint rule (second order):
//! `x* = x + ½Δt u(x)`, `x ← x + Δt u(x*)`. Particles of other codimensions
//! (added by later stages) move with their own velocity. A particle that ends
//! inside a static solid is projected to the solid surface along the SDF
//! gradient, and one that leaves the domain box is clamped back; both
//! corrections are counted and reported per frame.

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
        .zip(parts.v.par_iter())
        .zip(parts.codim.par_iter().zip(parts.fixed.par_iter()))
        .map(|((x, v), (c, fixed))| {
            if *fixed {
                return (0, 0);
            }
            let mut p = if *c == Codim::Volume {
                let mid = *x + grid.velocity(x) * (0.5 * dt);
                *x + grid.velocity(&mid) * dt
            } else {
                *x + v * dt
            };
            let mut clamped = 0;
            let mut pushed = 0;
            // a push out of a solid may cross a wall and a clamp may re-enter
            // the solid (a solid touching a wall): alternate a few times
            for _ in 0..4 {
                for d in 0..3 {
                    let q = p[d].clamp(lo[d] + eps, hi[d] - eps);
                    if q != p[d] {
                        clamped = 1;
                        p[d] = q;
                    }
                }
                if !solids.push_out(&mut p, eps, 1e-3 * grid.dx) {
                    break;
                }
                pushed = 1;
            }
            *x = p;
            (pushed, clamped)
        })
        .unzip();
    AdvectInfo {
        solid_pushouts: pushes.iter().map(|&b| b as usize).sum(),
        wall_clamps: clamps.iter().map(|&b| b as usize).sum(),
    }
}
