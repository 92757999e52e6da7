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
            let (pushed, clamped) = solids.push_out_in_box(&mut p, &lo, &hi, eps, 1e-3 * grid.dx);
            *x = p;
            (pushed as u8, clamped as u8)
        })
        .unzip();
    AdvectInfo {
        solid_pushouts: pushes.iter().map(|&b| b as usize).sum(),
        wall_clamps: clamps.iter().map(|&b| b as usize).sum(),
    }
}
