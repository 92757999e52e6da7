//! The band velocity (`coupling.band: extrapolated`): how much the liquid's
//! velocity changes between a surface layer's
//! particles and the constraint faces J holds to them (§7, eq. 18; see
//! `docs/decisions.md`, "Band velocity").

use super::faces::Constraints;
use super::surface::Surface;
use crate::grid::MacGrid;
use crate::math::{Real, Vec3};

/// c_f = Σ_i J_fi (∇u_a)_i · (x_f − x_i) for each constraint face f of axis
/// a: how much the liquid's velocity changes between the sheet particles
/// and the face ([`super::BandVelocity::Extrapolated`]).
///
/// (∇u)_i is the gradient of v** (the grid velocity before the solve: u^n
/// carried by the particles, so the correction lags one substep) at the
/// point [`BAND_PROBE`] Δx inside the liquid along the particle's normal,
/// past the band of constraint faces: inside the band the grid's velocity
/// is the constraint's own, so the gradient must be read from the free
/// liquid below. All of it counts, not only the normal derivative: J
/// averages particles that sit beside the face along the sheet as well as
/// across it, and on a curved layer the tangential offsets do not cancel.
/// With the normal derivative alone the grid velocity at the layer
/// particles after the solve was 0.977 of their own in an l = 2 flow at
/// R = 4Δx, and the layer, which takes the grid's velocity, lost 2 % of the
/// droplet's kinetic energy every substep; with the whole gradient, 0.999
/// (`docs/decisions.md`, "The band correction takes the whole gradient").
/// The normal is oriented by the liquid level set. A particle whose probe
/// point is not at least Δx/2 inside the liquid (a body thinner than the
/// probe depth), and every free sheet, keeps c = 0 (the sheet's own
/// velocity).
pub fn band_correction(grid: &MacGrid, surf: &Surface, k: &Constraints) -> Vec<Real> {
    use rayon::prelude::*;
    let d = BAND_PROBE * grid.dx;
    let phi_at = |y: &Vec3| {
        let c = grid.cell_of(y);
        grid.slot(c[0], c[1], c[2])
            .map_or(Real::MAX, |s| grid.phi[s])
    };
    let grads: Vec<Option<[Vec3; 3]>> = (0..surf.n_sheet())
        .into_par_iter()
        .map(|i| {
            if !surf.attached[i] {
                return None;
            }
            let x = surf.nb.x[i];
            let n: Vec3 = surf.axes[i].column(2).into();
            let (lo, hi) = (phi_at(&(x - d * n)), phi_at(&(x + d * n)));
            let (n, inner) = if lo <= hi { (n, lo) } else { (-n, hi) };
            (inner < -0.5 * grid.dx).then(|| grid.velocity_gradient(&(x - d * n)).1)
        })
        .collect();
    (0..k.len())
        .into_par_iter()
        .map(|f| {
            let (a, s) = k.faces[f];
            let xf = grid.face_pos(s, a);
            k.row(f)
                .map(|(i, j)| match &grads[i] {
                    Some(g) => j * g[a].dot(&(xf - surf.nb.x[i])),
                    None => 0.0,
                })
                .sum()
        })
        .collect()
}

/// Depth (× Δx) below a sheet particle at which [`band_correction`] reads
/// the liquid's velocity: past the band of constraint faces, which reaches
/// about Δx inside the sheet. 1.5, 2 and 3 gave the same period within
/// 0.5 points (`docs/decisions.md`).
pub const BAND_PROBE: Real = 2.0;
