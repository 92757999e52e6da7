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

/// One matrix row: diagonal, +x/+y/+z neighbours and coefficients, −x/−y/−z neighbours.
type Row = (Real, [u32; 3], [Real; 3], [u32; 3]);

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
    for (ax, info) in infos.iter_mut().enumerate() {
        let g: &MacGrid = grid;
        let ns = g.slots();
        let liquid = |s: Option<usize>| s.is_some_and(|s| g.phi[s] < 0.0);
        let faces: Vec<usize> = (0..ns)
            .filter(|&s| {
                !is_wall_face(g, s, ax)
                    && g.weight[ax][s] > 0.0
                    && (liquid(Some(s)) || liquid(g.neighbor(s, unit(ax, -1))))
            })
            .collect();
        let mut index = vec![NONE; ns];
        for (i, &s) in faces.iter().enumerate() {
            index[s] = i as u32;
        }
        let rows: Vec<Row> = faces
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
        *info = pcg(&a, &b, &mut x, prm)?;
        for (i, &s) in faces.iter().enumerate() {
            grid.u[ax][s] = x[i];
        }
    }
    Ok(infos)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;
    use crate::solids::SolidSet;

    /// A liquid ball away from the walls (all boundaries free, Neumann) with
    /// a rough velocity field: the implicit solve conserves Σu exactly per
    /// component, damps the roughness, and for μ → ∞ leaves the uniform mean
    /// (a rigid translation) — the properties of eq. (13) with L's null space.
    #[test]
    fn free_blob_keeps_momentum_and_tends_to_rigid_motion() {
        for (mu, dev_max) in [(1e-3, 1.0), (1e9, 1e-6)] {
            let mut g = MacGrid::new(Vec3::zeros(), Vec3::repeat(1.0), 0.1);
            g.activate(&[Vec3::repeat(0.5)], 4);
            g.compute_weights(&SolidSet::default());
            for s in 0..g.slots() {
                let r = (g.cell_pos(s) - Vec3::repeat(0.5)).norm();
                g.phi[s] = if r < 0.25 { -0.1 } else { 0.1 };
                for a in 0..3 {
                    g.u[a][s] = ((s * 7919 + a * 104729) % 1000) as Real / 1000.0 - 0.5;
                }
            }
            let liquid_face = |g: &MacGrid, s: usize, a: usize| {
                !is_wall_face(g, s, a)
                    && (g.phi[s] < 0.0
                        || g.neighbor(s, unit(a, -1)).is_some_and(|t| g.phi[t] < 0.0))
            };
            let before: Vec<Vec<Real>> = (0..3)
                .map(|a| {
                    (0..g.slots())
                        .filter(|&s| liquid_face(&g, s, a))
                        .map(|s| g.u[a][s])
                        .collect()
                })
                .collect();
            let prm = PcgParams {
                tolerance: 1e-13,
                max_iterations: 2000,
            };
            let info = viscosity(&mut g, mu, 1000.0, 1.0, prm).unwrap();
            for a in 0..3 {
                assert!(info[a].converged, "{:?}", info[a]);
                let after: Vec<Real> = (0..g.slots())
                    .filter(|&s| liquid_face(&g, s, a))
                    .map(|s| g.u[a][s])
                    .collect();
                let n = after.len() as Real;
                let (sb, sa): (Real, Real) = (before[a].iter().sum(), after.iter().sum());
                assert!((sb - sa).abs() < 1e-9 * n, "component {a}: Σu {sb} -> {sa}");
                let mean = sa / n;
                let dev = |v: &[Real]| v.iter().map(|u| (u - mean).abs()).fold(0.0, Real::max);
                assert!(
                    dev(&after) <= dev(&before[a]) * dev_max + 1e-12,
                    "component {a}: no damping"
                );
                if mu > 1.0 {
                    assert!(
                        dev(&after) < 1e-6,
                        "component {a}: deviation {} from rigid motion",
                        dev(&after)
                    );
                }
            }
        }
    }
}
