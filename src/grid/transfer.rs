//! Particle ↔ grid transfers of PIC/FLIP (Zhu & Bridson 2005), Algorithm 1 steps 5 and 8.
//!
//! P2G (step 5): each face value is the mass-weighted trilinear average of the
//! codimension-0 particle velocities around it,
//! `u_f = Σ_p w_fp m_p u_p · e_a / Σ_p w_fp m_p`,
//! computed as a *gather* over the particles of the neighbouring cells (the
//! particles are counting-sorted by cell first), so every face is written by
//! one thread in a fixed order: the result does not depend on the thread count.
//! The same pass builds the liquid level set at cell centres,
//! `φ_c = min_p |x_c − x_p| − k Δx` (k = `surface_radius`, 0.75 by default:
//! larger than the widest gap of a Δx/2 lattice, so no spurious air cells open
//! inside the liquid, where they would let it collapse), whose zero
//! crossing the ghost-fluid projection uses.
//!
//! APIC (Jiang et al. 2015) is the alternative transfer (`solver.transfer`).
//!
//! G2P (step 8): `u_p ← α (u_p + Δu_grid(x_p)) + (1 − α) u_grid(x_p)` with α the
//! FLIP fraction and `Δu_grid = u^{n+1} − u^{P2G}` on the faces; the
//! increment is sampled with the wall faces replaced by their interior
//! neighbours ([`MacGrid::stencil_clamped`]), otherwise a particle resting
//! next to a wall keeps a growing normal velocity that the grid never sees.

use super::extrapolate::extrapolate_p2g;
use super::{MacGrid, VelocityFit, FACE_OFFSETS, NONE};
use crate::math::{Real, Vec3};
use crate::particles::{Codim, Particles};
use crate::solids::SolidSet;
use rayon::prelude::*;

/// Codimension-0 particles sorted by the slot of the cell that contains them.
#[derive(Clone, Debug, Default)]
pub struct CellSort {
    /// `order[start[s]..start[s+1]]` are the particles in slot `s`.
    pub start: Vec<u32>,
    /// Particle indices, grouped by slot, ascending inside a slot.
    pub order: Vec<u32>,
}

impl CellSort {
    /// Particles in slot `s`.
    #[inline]
    pub fn in_slot(&self, s: usize) -> &[u32] {
        &self.order[self.start[s] as usize..self.start[s + 1] as usize]
    }
}

/// Counting sort of the codimension-0 particles by cell slot (grid must be activated around them).
pub fn sort_particles(grid: &MacGrid, parts: &Particles) -> CellSort {
    let slot_of: Vec<u32> = parts
        .x
        .par_iter()
        .zip(parts.codim.par_iter())
        .map(|(x, c)| {
            if *c != Codim::Volume {
                return NONE;
            }
            let c = grid.cell_of(x);
            grid.slot(c[0], c[1], c[2]).map_or(NONE, |s| s as u32)
        })
        .collect();
    let ns = grid.slots();
    let mut start = vec![0u32; ns + 1];
    for &s in &slot_of {
        if s != NONE {
            start[s as usize + 1] += 1;
        }
    }
    for s in 0..ns {
        start[s + 1] += start[s];
    }
    let mut fill = start.clone();
    let mut order = vec![0u32; start[ns] as usize];
    for (p, &s) in slot_of.iter().enumerate() {
        if s != NONE {
            order[fill[s as usize] as usize] = p as u32;
            fill[s as usize] += 1;
        }
    }
    CellSort { start, order }
}

/// Ridge ε (cells²) added to the offsets' covariance in P2G's linear fit
/// ([`super::VelocityFit::Linear`]), so that directions the particles do
/// not span (a thin sheet, a lone particle) keep the mean. The covariance
/// along the normal of a flat surface through the face is about 1/18
/// cells², 1/6 inside the liquid: ε shortens the gradient there by 2 % and
/// 0.6 %. In the pure-inertia l = 2 droplet (R = 4Δx, 12 substeps) the
/// kinetic energy kept was 0.976 with ε = 0.01, 0.990 with 0.003, 0.996
/// with 0.001 and 0.999 with 0.0003.
pub const LINEAR_RIDGE: Real = 0.001;

/// A face takes its value from P2G's linear fit only if one particle
/// weighs at least this much there (the product of its three hat weights);
/// the faces that see particles only at the edge of their support are
/// extrapolated instead (linearly, from the faces behind them). On a ball
/// in a linear flow this took the faces' RMS error from 1.2 % to 0.25 % of
/// the largest speed (`the_linear_fit_reads_a_linear_flow_at_the_free_surface`).
pub const LINEAR_MIN_WEIGHT: Real = 0.1;

/// Weighted moments of one face's particles for P2G's linear fit.
#[derive(Clone, Copy, Default)]
struct LinearMoments {
    /// Σ w m d, Σ w m d dᵀ, Σ w m u d (d the particle's offset from the
    /// face in cells, u its velocity component).
    s1: Vec3,
    s2: nalgebra::Matrix3<Real>,
    t1: Vec3,
    /// Largest single weight, and the range of the velocities.
    wmax: Real,
    lo: Real,
    hi: Real,
    n: usize,
}

impl LinearMoments {
    fn add(&mut self, d: Vec3, w: Real, wm: Real, u: Real) {
        self.s1 += d * wm;
        self.s2 += d * d.transpose() * wm;
        self.t1 += d * (wm * u);
        self.wmax = self.wmax.max(w);
        if self.n == 0 {
            (self.lo, self.hi) = (u, u);
        }
        self.lo = self.lo.min(u);
        self.hi = self.hi.max(u);
        self.n += 1;
    }

    /// The fit's value at the face, from the weighted mean `mean` and the
    /// total weight `den`. The step from the mean is limited to twice the
    /// range of the particles' velocities, so that two close particles with
    /// different velocities cannot throw the face's value far past them
    /// (the ridge alone would let their difference grow up to
    /// 1/(2√ε) ≈ 16-fold a cell away); on a ball in a linear flow the
    /// limit never binds (with once the range it bound, and the faces' RMS
    /// error rose from 0.25 % to 0.7 %).
    fn value(&self, den: Real, mean: Real) -> Real {
        let db = self.s1 / den;
        let cov =
            self.s2 / den - db * db.transpose() + nalgebra::Matrix3::identity() * LINEAR_RIDGE;
        let cv = self.t1 / den - db * mean;
        match cov.cholesky() {
            Some(ch) => {
                let step = -ch.solve(&cv).dot(&db);
                let range = self.hi - self.lo;
                mean + step.clamp(-2.0 * range, 2.0 * range)
            }
            None => mean,
        }
    }
}

/// Which faces received particle weight in P2G (1) and which did not (0).
pub type Valid = [Vec<u8>; 3];

/// How P2G builds the grid (Algorithm 1 step 5), from the scene's `solver:`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct P2gSettings {
    /// Blocks are allocated within this many cells of the particles, and
    /// the velocities extended one layer further.
    pub margin: usize,
    /// Radius of each volume particle's sphere in the level set, relative
    /// to Δx (`solver.surface_radius`).
    pub surface_radius: Real,
    /// `solver.separate_bodies` ([`super::bodies`]).
    pub separate_bodies: bool,
    /// `solver.open_gaps` ([`gap_cells`]).
    pub open_gaps: bool,
    /// `solver.velocity_fit`.
    pub fit: VelocityFit,
}

impl P2gSettings {
    /// Margin 2, level-set radius `surface_radius`, neither separation rule,
    /// the weighted mean.
    pub fn plain(surface_radius: Real) -> Self {
        P2gSettings {
            margin: 2,
            surface_radius,
            separate_bodies: false,
            open_gaps: false,
            fit: VelocityFit::Mean,
        }
    }
}

/// What the gather of one slot finds: its three lower faces' velocities and
/// whether they hold one, φ at its centre, the offset of its nearest
/// particle, and the faces' masses.
type SlotGather = ([Real; 3], [u8; 3], Real, Vec3, [Real; 3]);

/// Algorithm 1 step 5: particle velocities to the faces, and the liquid level
/// set. With `affine` (APIC), particle p contributes `u_p,a + c_p,a · (x_f − x_p)`
/// to face f of component a instead of `u_p,a`.
///
/// Without `affine`, `set.fit` chooses how the contributions
/// combine: [`super::VelocityFit::Mean`] takes their weighted mean ū;
/// [`super::VelocityFit::Linear`] fits u(x) = ū + g · (x − x̄) by weighted
/// least squares (x̄ the weighted mean offset of the particles from the
/// face, in cells; g solves (C + εI) g = Σ w m (x_p − x̄)(u_p − ū) / Σ w m
/// with C the offsets' weighted covariance and ε = [`LINEAR_RIDGE`]) and
/// takes u(x_f) = ū − g · x̄. Where the particles surround the face, x̄ ≈ 0
/// and the two agree; where they lie on one side (the free surface), the
/// mean reads the velocity at their centroid, up to a cell inside the
/// liquid, and the fit carries it to the face. The ridge keeps the fit to
/// the mean along directions the particles do not span (a thin sheet, a
/// lone particle).
pub fn particles_to_grid(
    grid: &mut MacGrid,
    parts: &Particles,
    sort: &CellSort,
    set: &P2gSettings,
    affine: Option<&[[Vec3; 3]]>,
) -> Valid {
    let ns = grid.slots();
    let g: &MacGrid = grid;
    let inv_dx = 1.0 / g.dx;
    let r_ls = set.surface_radius * g.dx;
    // APIC's particles carry their own gradient to the face
    let linear = affine.is_none() && set.fit == VelocityFit::Linear;
    #[inline]
    fn hat(t: Real) -> Real {
        (1.0 - t.abs()).max(0.0)
    }
    // one gather over the 27 cells around each slot gives its three lower
    // faces (weights relative to the slot's lower corner) and φ at its centre
    let per_slot: Vec<SlotGather> = (0..ns)
        .into_par_iter()
        .map(|s| {
            if !g.in_domain(s) {
                return (
                    [0.0; 3],
                    [0; 3],
                    g.dx,
                    Vec3::repeat(Real::INFINITY),
                    [0.0; 3],
                );
            }
            let c = g.cell(s);
            let corner = Vec3::new(c[0] as Real, c[1] as Real, c[2] as Real);
            let mut num = [0.0; 3];
            let mut den = [0.0; 3];
            // the linear fit's moments per face (`VelocityFit::Linear`)
            let mut fit = [LinearMoments::default(); 3];
            let mut d2min = Real::INFINITY;
            // offset of the nearest particle from the centre (cells)
            let mut near = Vec3::repeat(Real::INFINITY);
            for dz in -1..=1isize {
                for dy in -1..=1isize {
                    for dxi in -1..=1isize {
                        let Some(t) = g.slot(c[0] + dxi, c[1] + dy, c[2] + dz) else {
                            continue;
                        };
                        for &p in sort.in_slot(t) {
                            let p = p as usize;
                            let r = (parts.x[p] - g.origin) * inv_dx - corner;
                            let h0 = [hat(r.x), hat(r.y), hat(r.z)];
                            let h5 = [hat(r.x - 0.5), hat(r.y - 0.5), hat(r.z - 0.5)];
                            let m = parts.mass[p];
                            let w = [
                                h0[0] * h5[1] * h5[2],
                                h5[0] * h0[1] * h5[2],
                                h5[0] * h5[1] * h0[2],
                            ];
                            for a in 0..3 {
                                if w[a] > 0.0 {
                                    let mut va = parts.v[p][a];
                                    if let Some(c) = affine {
                                        // face a of this slot sits at the corner + ½ on the other axes
                                        let mut df = Vec3::repeat(0.5) - r;
                                        df[a] = -r[a];
                                        va += c[p][a].dot(&df) * g.dx;
                                    }
                                    num[a] += w[a] * m * va;
                                    den[a] += w[a] * m;
                                    if linear {
                                        // offset of the particle from the face (cells)
                                        let mut d = r - Vec3::repeat(0.5);
                                        d[a] = r[a];
                                        fit[a].add(d, w[a], w[a] * m, va);
                                    }
                                }
                            }
                            let e = r - Vec3::repeat(0.5);
                            let d2 = e.norm_squared();
                            if d2 < d2min {
                                d2min = d2;
                                near = e;
                            }
                        }
                    }
                }
            }
            let mut u = [0.0; 3];
            let mut f = [0u8; 3];
            for a in 0..3 {
                if den[a] > 0.0
                    && g.weight[a][s] > 0.0
                    && (!linear || fit[a].wmax >= LINEAR_MIN_WEIGHT)
                {
                    u[a] = if linear {
                        fit[a].value(den[a], num[a] / den[a])
                    } else {
                        num[a] / den[a]
                    };
                    f[a] = 1;
                }
            }
            (u, f, (d2min.sqrt() * g.dx - r_ls).min(g.dx), near, den)
        })
        .collect();
    let mut valid: Valid = Default::default();
    let mut u: [Vec<Real>; 3] = Default::default();
    let mut mass: [Vec<Real>; 3] = Default::default();
    for a in 0..3 {
        u[a] = per_slot.iter().map(|x| x.0[a]).collect();
        mass[a] = per_slot.iter().map(|x| x.4[a]).collect();
        valid[a] = per_slot.iter().map(|x| x.1[a]).collect();
    }
    let mut phi: Vec<Real> = per_slot.iter().map(|x| x.2).collect();
    // the cells flagged by a separation rule become air, just outside the surface
    let make_air = |phi: &mut [Real], gap: &[bool]| {
        for (p, _) in phi.iter_mut().zip(gap).filter(|(_, &is_gap)| is_gap) {
            *p = 0.01 * g.dx;
        }
    };
    // each slot's nearest volume particle, for the separation rules
    let near: Vec<Vec3> = if set.separate_bodies || set.open_gaps {
        per_slot.iter().map(|x| x.3).collect()
    } else {
        Vec::new()
    };
    if set.separate_bodies {
        // liquid cells that the volume particles do not join stay apart
        let gap = super::bodies::separated_cells(g, parts, &phi, &near);
        make_air(&mut phi, &gap);
    }
    if set.open_gaps {
        let gap = gap_cells(g, sort, parts, &phi, &near);
        make_air(&mut phi, &gap);
    }
    // The distance to the nearest particle is not a distance to the surface
    // deep inside the liquid; one Jacobi pass of the Lipschitz bound
    // φ_c ← min(φ_c, max_n φ_n − Δx) over cells whose six neighbours are all
    // liquid makes interior cells at least a cell deep, leaving the zero
    // crossing (and so the free surface) unchanged.
    let phi: Vec<Real> = (0..ns)
        .into_par_iter()
        .map(|s| {
            let p = phi[s];
            if p >= 0.0 {
                return p;
            }
            let mut mx = Real::NEG_INFINITY;
            for o in FACE_OFFSETS {
                match g.neighbor(s, o) {
                    Some(t) if phi[t] < 0.0 => mx = mx.max(phi[t]),
                    Some(_) => return p,
                    // the domain wall: liquid continues to the wall
                    None => {}
                }
            }
            if mx.is_finite() {
                p.min(mx - g.dx)
            } else {
                p
            }
        })
        .collect();
    grid.u = u;
    grid.mass = mass;
    grid.phi = phi;
    valid
}

/// The liquid cells whose centres lie in a gap between two liquid surfaces
/// (`solver.open_gaps`). The level set reaches `surface_radius` Δx past the
/// outermost particles, so two surfaces closer than about 2 Δx share liquid
/// cells; the projection then keeps the particle-free liquid between them
/// incompressible, and the surfaces stop before they touch (docs/decisions.md,
/// "Open gaps").
///
/// A liquid cell is a gap cell when, with c its centre, p its nearest volume
/// particle (`near`: offset from c in cells, ∞ when none is in the 27 cells
/// around) and r = |p − c|:
/// - c is clear of the particles: r > 0.35 Δx (inside the liquid, particles
///   spaced Δx/3 or closer leave no such hole);
/// - a particle q lies on the other side: the segment pq passes within r/2
///   of c (the nearest such q within two cells is taken; searched only when
///   the nearest particle of one of the 26 cells around lies across c);
/// - the gap is a slab, not a hole: no particle within 1.5 Δx of c lies
///   within r/2 of the plane through c normal to pq.
///
/// Only cells clear of particles are opened, so a lone body's grid does not
/// change (a cell outside one convex or flat surface has particles on one
/// side only) and no liquid that holds particles is taken from the pressure
/// solve. A gap narrower than about 1.7 Δx may have every cell centre within
/// 0.35 Δx of a particle and stays joined; `separate_bodies`
/// ([`super::bodies`]) opens such gaps too, by asking whether the particles
/// join the two sides near the face.
pub fn gap_cells(
    g: &MacGrid,
    sort: &CellSort,
    parts: &Particles,
    phi: &[Real],
    near: &[Vec3],
) -> Vec<bool> {
    let inv_dx = 1.0 / g.dx;
    (0..g.slots())
        .into_par_iter()
        .map(|s| {
            let p = near[s];
            let d2 = p.norm_squared();
            if !g.in_domain(s) || phi[s] >= 0.0 || d2 <= 0.35 * 0.35 {
                return false;
            }
            let r = d2.sqrt();
            let c = g.cell(s);
            let across = (0..27isize).any(|d| {
                let o = [d / 9 - 1, d / 3 % 3 - 1, d % 3 - 1];
                g.slot(c[0] + o[0], c[1] + o[1], c[2] + o[2])
                    .is_some_and(|t| {
                        let pt = near[t] + Vec3::new(o[0] as Real, o[1] as Real, o[2] as Real);
                        pt.iter().all(|v| v.is_finite()) && pt.dot(&p) < 0.0
                    })
            });
            if !across {
                return false;
            }
            let centre = Vec3::new(c[0] as Real, c[1] as Real, c[2] as Real) + Vec3::repeat(0.5);
            let around = || {
                (0..125isize)
                    .filter_map(move |d| {
                        g.slot(c[0] + d / 25 - 2, c[1] + d / 5 % 5 - 2, c[2] + d % 5 - 2)
                    })
                    .flat_map(|u| sort.in_slot(u).iter())
                    .map(move |&i| (parts.x[i as usize] - g.origin) * inv_dx - centre)
            };
            // the nearest particle across c from p
            let mut best: Option<(Real, Vec3)> = None;
            for q in around() {
                let dq = q.norm_squared();
                if q.dot(&p) >= 0.0 || best.is_some_and(|(b, _)| b <= dq) {
                    continue;
                }
                let pq = q - p;
                let l = (-p).dot(&pq) / pq.norm_squared();
                if (p + pq * l.clamp(0.0, 1.0)).norm_squared() < 0.25 * d2 {
                    best = Some((dq, q));
                }
            }
            let Some((_, q)) = best else {
                return false;
            };
            let n = (q - p).normalize();
            !around().any(|x| x.norm_squared() < 2.25 && x.dot(&n).abs() < 0.5 * r)
        })
        .collect()
}

/// Algorithm 1 step 5 as one stage: allocate the blocks within `margin`
/// cells of the particles, compute the cut-cell face weights, sort the
/// particles by cell, gather the face velocities and the level set, extend the
/// velocities `margin + 1` layers, and keep a copy for the FLIP update.
pub fn transfer_to_grid(
    grid: &mut MacGrid,
    parts: &Particles,
    solids: &SolidSet,
    set: &P2gSettings,
    affine: Option<&[[Vec3; 3]]>,
) {
    grid.activate(&parts.x, set.margin);
    grid.compute_weights(solids);
    let sort = sort_particles(grid, parts);
    let mut valid = particles_to_grid(grid, parts, &sort, set, affine);
    extrapolate_p2g(grid, &mut valid, set.margin + 1, set.fit);
    grid.u_old = grid.u.clone();
}

/// Algorithm 1 step 8: PIC/FLIP update of the codimension-0 particle velocities.
pub fn grid_to_particles(grid: &MacGrid, parts: &mut Particles, flip: Real) {
    let delta: [Vec<Real>; 3] = [0, 1, 2].map(|a| {
        grid.u[a]
            .par_iter()
            .zip(grid.u_old[a].par_iter())
            .map(|(n, o)| n - o)
            .collect()
    });
    parts
        .v
        .par_iter_mut()
        .zip(parts.x.par_iter())
        .zip(parts.codim.par_iter())
        .for_each(|((v, x), c)| {
            if *c != Codim::Volume {
                return;
            }
            let mut pic = Vec3::zeros();
            let mut dv = Vec3::zeros();
            for a in 0..3 {
                let (idx, w) = grid.stencil(a, x);
                for k in 0..8 {
                    if idx[k] != NONE {
                        pic[a] += w[k] * grid.u[a][idx[k] as usize];
                    }
                }
                // the two stencils differ only within a cell of a wall
                let qa = (x[a] - grid.origin[a]) / grid.dx;
                let (idx, w) = if qa < 1.0 || qa > grid.n[a] as Real - 1.0 {
                    grid.stencil_clamped(a, x, true)
                } else {
                    (idx, w)
                };
                for k in 0..8 {
                    if idx[k] != NONE {
                        dv[a] += w[k] * delta[a][idx[k] as usize];
                    }
                }
            }
            *v = (*v + dv) * flip + pic * (1.0 - flip);
        });
}

/// Algorithm 1 step 8 with APIC (Jiang, Schroeder, Selle, Teran, Stomakhin
/// 2015): `u_p,a = Σ_f w_fp u_f` and `c_p,a = Σ_f ∇w_fp u_f`, the affine
/// velocity that the next P2G carries back to the grid.
pub fn grid_to_particles_apic(grid: &MacGrid, parts: &mut Particles, affine: &mut [[Vec3; 3]]) {
    parts
        .v
        .par_iter_mut()
        .zip(affine.par_iter_mut())
        .zip(parts.x.par_iter().zip(parts.codim.par_iter()))
        .for_each(|((v, c), (x, cd))| {
            if *cd != Codim::Volume {
                return;
            }
            (*v, *c) = grid.velocity_gradient(x);
        });
}

#[cfg(test)]
#[path = "transfer_tests.rs"]
mod tests;
