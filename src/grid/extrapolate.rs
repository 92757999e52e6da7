//! Velocity extrapolation and the solid boundary condition on faces.
//!
//! After P2G and after the projection only faces next to liquid hold
//! meaningful velocities. Particle advection and G2P sample a few cells past
//! the liquid, so the values are extended layer by layer: a face without a
//! value takes the average of its valid 6-neighbours of the same component
//! (Jacobi sweeps, so the result does not depend on the visiting order).
//! After P2G with `solver.velocity_fit: linear` ([`extrapolate_p2g`]) the
//! first two layers instead continue the velocity linearly, 2u_t − u_t'
//! from the two valid faces t, t' behind each face along an axis (averaged
//! over the axes that have both), so that the faces just outside the
//! liquid, which the free-surface cells' divergence reads, carry the flow's
//! gradient (on the droplets measured the second layer changed nothing);
//! further layers stay constant, where a linear continuation would grow
//! without bound. After the projection the extension is constant: the
//! linear one there fed G2P's FLIP update with twice the difference of two
//! faces' changes, and a dam break around a solid splashed at 5.3 m/s
//! instead of 3.2 (`docs/decisions.md`, "A linear velocity at the free
//! surface").
//! Faces inside static solids are then set to the extrapolated velocity minus
//! its normal component (free slip, solid velocity 0; Bridson 2015 §4.3).

use super::transfer::Valid;
use super::{MacGrid, FACE_OFFSETS};
use crate::math::{Real, Vec3};
use crate::solids::SolidSet;
use rayon::prelude::*;

/// True for faces on or past the domain walls (always 0, never extrapolated).
#[inline]
pub fn is_wall_face(g: &MacGrid, s: usize, a: usize) -> bool {
    !g.in_domain(s) || g.cell(s)[a] == 0
}

/// Extends `field` (component `a`) from its valid faces by `layers` layers
/// (the first two linearly if `linear`).
pub fn extrapolate_component(
    g: &MacGrid,
    field: &mut [Real],
    valid: &mut [u8],
    a: usize,
    layers: usize,
    linear: bool,
) {
    for layer in 0..layers {
        let upd: Vec<Option<Real>> = (0..field.len())
            .into_par_iter()
            .map(|s| {
                if valid[s] != 0 || is_wall_face(g, s, a) {
                    return None;
                }
                if linear && layer < LINEAR_LAYERS {
                    // 2u_t − u_t' along each axis where the two faces
                    // behind s hold values
                    let (mut sum, mut cnt) = (0.0, 0);
                    for o in FACE_OFFSETS {
                        let Some(t) = g.neighbor(s, o).filter(|&t| valid[t] != 0) else {
                            continue;
                        };
                        if let Some(t2) = g.neighbor(t, o).filter(|&t2| valid[t2] != 0) {
                            sum += 2.0 * field[t] - field[t2];
                            cnt += 1;
                        }
                    }
                    if cnt > 0 {
                        return Some(sum / cnt as Real);
                    }
                }
                let (mut sum, mut cnt) = (0.0, 0);
                for o in FACE_OFFSETS {
                    if let Some(t) = g.neighbor(s, o) {
                        if valid[t] != 0 {
                            sum += field[t];
                            cnt += 1;
                        }
                    }
                }
                (cnt > 0).then(|| sum / cnt as Real)
            })
            .collect();
        let mut any = false;
        for (s, v) in upd.into_iter().enumerate() {
            if let Some(v) = v {
                field[s] = v;
                valid[s] = 1;
                any = true;
            }
        }
        if !any {
            break;
        }
    }
}

/// Extrapolates all three components of `grid.u` (constant layers).
pub fn extrapolate(g: &mut MacGrid, valid: &mut Valid, layers: usize) {
    extend(g, valid, layers, false);
}

/// Layers [`extrapolate_p2g`] continues linearly with
/// [`super::VelocityFit::Linear`].
pub const LINEAR_LAYERS: usize = 2;

/// Extrapolates the velocities P2G gathered: [`LINEAR_LAYERS`] layers linearly with
/// [`super::VelocityFit::Linear`], then constant layers.
pub fn extrapolate_p2g(g: &mut MacGrid, valid: &mut Valid, layers: usize, fit: super::VelocityFit) {
    extend(g, valid, layers, fit == super::VelocityFit::Linear);
}

fn extend(g: &mut MacGrid, valid: &mut Valid, layers: usize, linear: bool) {
    for (a, va) in valid.iter_mut().enumerate() {
        let mut f = std::mem::take(&mut g.u[a]);
        extrapolate_component(g, &mut f, va, a, layers, linear);
        g.u[a] = f;
    }
}

/// Free-slip condition on faces closed by an interior solid: removes the
/// normal component of the (extrapolated) velocity there.
pub fn constrain_solids(g: &mut MacGrid, solids: &SolidSet) {
    if solids.is_empty() {
        return;
    }
    let h = 1e-3 * g.dx;
    let grid: &MacGrid = g;
    let newu: [Vec<Real>; 3] = [0, 1, 2].map(|a| {
        (0..grid.slots())
            .into_par_iter()
            .map(|s| {
                if is_wall_face(grid, s, a) || grid.weight[a][s] > 0.0 {
                    return grid.u[a][s];
                }
                let x = grid.face_pos(s, a);
                let v: Vec3 = grid.velocity(&x);
                let n = solids.normal(&x, h);
                v[a] - v.dot(&n) * n[a]
            })
            .collect()
    });
    g.u = newu;
}
