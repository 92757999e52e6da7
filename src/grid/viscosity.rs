//! Implicit, component-decoupled viscosity on the grid: the codimension-0
//! part of Algorithm 1 step 6, paper §5 eq. (13) with i = 0:
//!
//! `(M − μ Δt V L) u** = M u*`, i.e. per face `(1 − μΔt/ρ L) u** = u*`
//!
//! with `L` the 7-point Laplacian of one velocity component over the faces
//! next to liquid (Rasmussen et al. 2004). Boundary conditions: faces closed by
//! a solid or a domain wall hold u = 0 (Dirichlet, no slip); faces in the air
//! are left out of the stencil (zero normal derivative, a traction-free
//! approximation — the decoupled scheme's known inaccuracy at free surfaces,
//! which the paper notes citing Batty & Bridson 2008). The stage is skipped
//! entirely when μ = 0.

use super::extrapolate::is_wall_face;
use super::pcg::{pcg, NotFinite, PcgParams, SolveInfo, Stencil7};
use super::projection::unit;
use super::{MacGrid, NONE};
use crate::math::Real;
use rayon::prelude::*;

/// Solves eq. (13) for the three components; returns one solve record per component.
pub fn viscosity(
    grid: &mut MacGrid,
    mu: Real,
    density: Real,
    dt: Real,
    prm: PcgParams,
) -> Result<[SolveInfo; 3], NotFinite> {
    let c = mu * dt / (density * grid.dx * grid.dx);
    let mut infos = [SolveInfo::default(); 3];
    for ax in 0..3 {
        let g: &MacGrid = grid;
        let ns = g.slots();
        let liquid = |s: Option<usize>| s.is_some_and(|s| g.phi[s] < 0.0);
        let mut index = vec![NONE; ns];
        let mut faces = Vec::new();
        for s in 0..ns {
            if !is_wall_face(g, s, ax)
                && g.weight[ax][s] > 0.0
                && (liquid(Some(s)) || liquid(g.neighbor(s, unit(ax, -1))))
            {
                index[s] = faces.len() as u32;
                faces.push(s);
            }
        }
        let rows: Vec<(Real, [u32; 3], [Real; 3], [u32; 3])> = faces
            .par_iter()
            .map(|&s| {
                let mut diag = 1.0;
                let mut up = [NONE; 3];
                let mut lo = [NONE; 3];
                let mut off = [0.0; 3];
                for d in 0..3 {
                    for k in [-1isize, 1] {
                        let t = g.neighbor(s, unit(d, k));
                        match t {
                            Some(t) if index[t] != NONE => {
                                diag += c;
                                if k > 0 {
                                    up[d] = index[t];
                                    off[d] = -c;
                                } else {
                                    lo[d] = index[t];
                                }
                            }
                            Some(t) if !is_wall_face(g, t, ax) && g.weight[ax][t] > 0.0 => {}
                            _ => diag += c,
                        }
                    }
                }
                (diag, up, off, lo)
            })
            .collect();
        let mut a = Stencil7::default();
        for (d, up, off, lo) in rows {
            a.diag.push(d);
            a.up.push(up);
            a.off.push(off);
            a.lo.push(lo);
        }
        let b: Vec<Real> = faces.iter().map(|&s| g.u[ax][s]).collect();
        let mut x = b.clone();
        infos[ax] = pcg(&a, &b, &mut x, prm)?;
        for (i, &s) in faces.iter().enumerate() {
            grid.u[ax][s] = x[i];
        }
    }
    Ok(infos)
}
