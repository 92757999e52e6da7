//! Pressure projection, Algorithm 1 step 7 (the volumetric part; the
//! monolithic surface-tension coupling of §7 will add its particle and
//! impulse blocks to this system).
//!
//! With the scaled pressure `q = p Δt / (ρ Δx)` (m/s) the update is
//! `u_f ← u_f − (q_{c+} − q_{c−})` and incompressibility of every liquid cell,
//! weighted by the open face fractions `w_f` of the cut-cell method (Batty,
//! Bertails & Bridson 2007), gives the SPD system
//!
//! `Σ_f w_f (q_c − q_n) / θ_f = −Σ_f w_f u_f·n_f`,
//!
//! where `θ_f = 1` between liquid cells and, across the free surface, `θ_f =
//! φ_c / (φ_c − φ_n)` is the ghost-fluid interface fraction (Enright, Nguyen,
//! Gibou & Fedkiw 2003) so that the pressure vanishes at the level set's zero
//! crossing (p = 0 at the surface, σ = 0). θ is clamped to ≥ 0.01 and the
//! clamps are counted. Solved by PCG with MIC(0) ([`super::pcg`]).

use super::extrapolate::{constrain_solids, extrapolate, is_wall_face};
use super::pcg::{pcg, NotFinite, PcgParams, SolveInfo, Stencil7};
use super::transfer::Valid;
use super::{MacGrid, NONE};
use crate::math::Real;
use crate::solids::SolidSet;
use rayon::prelude::*;

/// Smallest ghost-fluid fraction used (a counted clamp below it).
pub const THETA_MIN: Real = 0.01;

/// One matrix row: diagonal, +x/+y/+z neighbours and coefficients, −x/−y/−z neighbours, rhs, θ clamps.
pub(crate) type Row = (Real, [u32; 3], [Real; 3], [u32; 3], Real, usize);

/// How one open, unprescribed face of a liquid cell enters the cell's row
/// ([`rows`]).
pub(crate) enum FaceTerm {
    /// To the neighbouring unknown: the face's velocity weighs `flux` in
    /// the divergence, and the pressure difference `coef` in the operator.
    Liquid { flux: Real, coef: Real },
    /// To air, at the ghost-fluid fraction θ (and whether it was clamped):
    /// the face's weight in the divergence, weight/θ on the diagonal.
    Air { theta: Real, clamps: usize },
    /// Not in the row (closed, its flux someone else's).
    Closed,
}

/// The rows of the liquid `cells` (unknown `index` per slot): prescribed
/// faces go to the right-hand side, faces with `skip(axis, slot)` are left
/// out, and every other open face enters as
/// `term(axis, face slot, cell slot, slot across the face, weight)` says.
pub(crate) fn rows(
    g: &MacGrid,
    index: &[u32],
    cells: &[usize],
    skip: impl Fn(usize, usize) -> bool + Sync,
    term: impl Fn(usize, usize, usize, Option<usize>, Real) -> FaceTerm + Sync,
) -> Vec<Row> {
    cells
        .par_iter()
        .map(|&s| {
            let mut diag = 0.0;
            let mut up = [NONE; 3];
            let mut lo = [NONE; 3];
            let mut off = [0.0; 3];
            let mut rhs = 0.0;
            let mut clamps = 0;
            for a in 0..3 {
                let w = g.weight[a][s];
                if w > 0.0 && g.is_prescribed(a, s) {
                    rhs += w * g.u[a][s];
                } else if w > 0.0 && !skip(a, s) {
                    let n = g.neighbor(s, unit(a, -1));
                    match term(a, s, s, n, w) {
                        FaceTerm::Liquid { flux, coef } => {
                            rhs += flux * g.u[a][s];
                            diag += coef;
                            lo[a] = n.map_or(NONE, |n| index[n]);
                        }
                        FaceTerm::Air { theta, clamps: c } => {
                            rhs += w * g.u[a][s];
                            diag += w / theta;
                            clamps += c;
                        }
                        FaceTerm::Closed => {}
                    }
                }
                let t = g.neighbor(s, unit(a, 1));
                let w = t.map_or(0.0, |t| g.weight[a][t]);
                if w > 0.0 {
                    let t = t.unwrap_or(0);
                    if g.is_prescribed(a, t) {
                        rhs -= w * g.u[a][t];
                    } else if !skip(a, t) {
                        match term(a, t, s, Some(t), w) {
                            FaceTerm::Liquid { flux, coef } => {
                                rhs -= flux * g.u[a][t];
                                diag += coef;
                                up[a] = index[t];
                                off[a] = -coef;
                            }
                            FaceTerm::Air { theta, clamps: c } => {
                                rhs -= w * g.u[a][t];
                                diag += w / theta;
                                clamps += c;
                            }
                            FaceTerm::Closed => {}
                        }
                    }
                }
            }
            (diag, up, off, lo, rhs, clamps)
        })
        .collect()
}

/// What the projection did.
#[derive(Clone, Copy, Debug, Default)]
pub struct ProjectionInfo {
    /// The PCG solve.
    pub solve: SolveInfo,
    /// Pressure unknowns (liquid cells).
    pub cells: usize,
    /// Free-surface faces whose θ was clamped to [`THETA_MIN`].
    pub theta_clamps: usize,
}

/// The ghost-fluid fraction θ of a face from the level set on its liquid
/// and air sides, clamped to [`THETA_MIN`] (and whether it was).
#[inline]
pub(crate) fn theta(phi_in: Real, phi_out: Real) -> (Real, bool) {
    let t = phi_in / (phi_in - phi_out);
    if t < THETA_MIN {
        (THETA_MIN, true)
    } else {
        (t.min(1.0), false)
    }
}

/// The pressure system of the liquid: unknowns, 7-point matrix and
/// right-hand side, built once and shared by the plain projection and the
/// coupled solve of §7 ([`crate::coupling`]).
#[derive(Clone, Debug, Default)]
pub struct Poisson {
    /// Liquid level set, extended half a cell into solids.
    pub phi: Vec<Real>,
    /// Unknown index of each slot's cell, or [`NONE`].
    pub index: Vec<u32>,
    /// Slot of each unknown.
    pub cells: Vec<usize>,
    /// The SPD matrix.
    pub a: Stencil7,
    /// Right-hand side: −(weighted divergence) of `grid.u`.
    pub b: Vec<Real>,
    /// Free-surface faces whose θ was clamped to [`THETA_MIN`].
    pub theta_clamps: usize,
    /// Scaled pressure q at the interface of free-surface faces that carry
    /// a surface-tension jump ([`Poisson::set_air`]); elsewhere q = 0 there.
    pub air: FaceValues,
}

/// Values on MAC faces `(axis, slot)`, sorted by face: a sparse table for
/// the few faces of the free surface.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FaceValues(Vec<(u64, Real)>);

impl FaceValues {
    /// The table from `(axis, slot, value)` entries (any order; a face
    /// given twice keeps its last value).
    pub fn new(mut entries: Vec<(usize, usize, Real)>) -> FaceValues {
        entries.sort_by_key(|e| (e.0, e.1));
        entries.dedup_by(|b, a| {
            let same = (a.0, a.1) == (b.0, b.1);
            if same {
                a.2 = b.2;
            }
            same
        });
        FaceValues(
            entries
                .into_iter()
                .map(|(a, s, v)| (Self::key(a, s), v))
                .collect(),
        )
    }

    #[inline]
    fn key(a: usize, s: usize) -> u64 {
        ((a as u64) << 60) | s as u64
    }

    /// Value of face `(a, s)`, 0 where the table has none.
    #[inline]
    pub fn get(&self, a: usize, s: usize) -> Real {
        if self.0.is_empty() {
            return 0.0;
        }
        let k = Self::key(a, s);
        self.0
            .binary_search_by_key(&k, |e| e.0)
            .map_or(0.0, |i| self.0[i].1)
    }

    /// Number of faces in the table.
    pub fn len(&self) -> usize {
        self.0.len()
    }

    /// True without faces.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// The entries `(axis, slot, value)` in face order.
    pub fn iter(&self) -> impl Iterator<Item = (usize, usize, Real)> + '_ {
        self.0
            .iter()
            .map(|&(k, v)| ((k >> 60) as usize, (k & ((1 << 60) - 1)) as usize, v))
    }
}

/// The two sides of face `(a, s)` (axis `a`, the lower face of slot `s`):
/// unknown indices of the lower and upper cells (if liquid) and the
/// ghost-fluid fraction θ of the face (1 between two liquid cells).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FaceSides {
    /// Unknown below the face.
    pub lo: Option<u32>,
    /// Unknown above the face.
    pub hi: Option<u32>,
    /// Ghost-fluid fraction.
    pub theta: Real,
}

impl Poisson {
    /// Builds the system. Faces for which `skip(axis, slot)` is true are left
    /// out of the operator and of the divergence (their velocity is set by
    /// something else: the constraint faces of the eliminated coupled system).
    pub fn build(
        g: &MacGrid,
        solids: &SolidSet,
        skip: impl Fn(usize, usize) -> bool + Sync,
    ) -> Poisson {
        let ns = g.slots();
        let dx = g.dx;
        // Liquid level set extended half a cell into solids (Batty et al. 2007), so
        // liquid resting on a cut-cell solid has no spurious free surface there.
        let phi: Vec<Real> = (0..ns)
            .into_par_iter()
            .map(|s| {
                let p = g.phi[s];
                if !solids.is_empty() && p < 0.5 * dx && solids.phi(&g.cell_pos(s)) < 0.0 {
                    p.min(-0.5 * dx)
                } else {
                    p
                }
            })
            .collect();
        let open = |s: usize, a: usize| -> Real {
            match g.neighbor(s, unit(a, 1)) {
                Some(t) => g.weight[a][s] + g.weight[a][t],
                None => g.weight[a][s],
            }
        };
        let mut index = vec![NONE; ns];
        let mut cells = Vec::new();
        for s in 0..ns {
            if g.in_domain(s) && phi[s] < 0.0 && (0..3).map(|a| open(s, a)).sum::<Real>() > 0.0 {
                index[s] = cells.len() as u32;
                cells.push(s);
            }
        }
        let phi_at = |t: Option<usize>| t.map_or(dx, |t| phi[t]);
        let rows = rows(g, &index, &cells, skip, |_, _, s, across, w| {
            match across.filter(|&t| index[t] != NONE) {
                Some(_) => FaceTerm::Liquid { flux: w, coef: w },
                None => {
                    let (theta, c) = theta(phi[s], phi_at(across));
                    FaceTerm::Air {
                        theta,
                        clamps: c as usize,
                    }
                }
            }
        });
        Poisson::from_rows(phi, index, cells, rows)
    }

    /// The system from its rows (one per unknown, in `cells` order).
    pub(crate) fn from_rows(
        phi: Vec<Real>,
        index: Vec<u32>,
        cells: Vec<usize>,
        rows: Vec<Row>,
    ) -> Poisson {
        let mut a = Stencil7::default();
        let mut b = Vec::with_capacity(rows.len());
        let mut theta_clamps = 0;
        for (d, up, off, lo, r, c) in rows {
            a.diag.push(d);
            a.up.push(up);
            a.off.push(off);
            a.lo.push(lo);
            b.push(r);
            theta_clamps += c;
        }
        Poisson {
            phi,
            index,
            cells,
            a,
            b,
            theta_clamps,
            air: FaceValues::default(),
        }
    }

    /// Puts the scaled pressure `air` on the air side of free-surface faces
    /// (a ghost-fluid Dirichlet value at the interface, Kang, Fedkiw & Liu
    /// 2000: the liquid's pressure at the surface is σκ there instead of 0).
    /// Each face must be one the system was built with (open, not
    /// prescribed, not skipped) between a liquid cell and a non-liquid one;
    /// other entries are ignored. The row of the liquid cell c gains
    /// w_f q_Γ/θ_f on its right-hand side, and [`Self::apply`] uses q_Γ as
    /// the air side's pressure.
    pub fn set_air(&mut self, g: &MacGrid, air: FaceValues) {
        let mut kept = Vec::with_capacity(air.len());
        for (a, s, q) in air.iter() {
            if let Some(sd) = self.face(g, a, s) {
                if let (Some(c), None) | (None, Some(c)) = (sd.lo, sd.hi) {
                    self.b[c as usize] += g.weight[a][s] * q / sd.theta;
                    kept.push((a, s, q));
                }
            }
        }
        self.air = FaceValues::new(kept);
    }

    /// Changes the right-hand side as if face `(a, s)`'s velocity in
    /// `grid.u` had been larger by `du` when the system was built (the
    /// face must be open and not prescribed).
    pub fn shift_face_velocity(&mut self, g: &MacGrid, a: usize, s: usize, du: Real) {
        if let Some(sd) = self.face(g, a, s) {
            let w = g.weight[a][s];
            if let Some(c) = sd.hi {
                self.b[c as usize] += w * du;
            }
            if let Some(c) = sd.lo {
                self.b[c as usize] -= w * du;
            }
        }
    }

    /// Unknown of slot `s`, if its cell is liquid.
    #[inline]
    pub fn unknown(&self, s: usize) -> Option<u32> {
        let i = self.index[s];
        (i != NONE).then_some(i)
    }

    /// The sides of face `(a, s)`; `None` when neither side is liquid.
    pub fn face(&self, g: &MacGrid, a: usize, s: usize) -> Option<FaceSides> {
        let l = g.neighbor(s, unit(a, -1));
        let lo = l.and_then(|l| self.unknown(l));
        let hi = self.unknown(s);
        let phi_at = |t: Option<usize>| t.map_or(g.dx, |t| self.phi[t]);
        let theta = match (lo, hi) {
            (Some(_), Some(_)) => 1.0,
            (Some(_), None) => theta(phi_at(l), self.phi[s]).0,
            (None, Some(_)) => theta(self.phi[s], phi_at(l)).0,
            (None, None) => return None,
        };
        Some(FaceSides { lo, hi, theta })
    }

    /// Pressure update of every open face next to liquid:
    /// `u_f ← u_f − (q_hi − q_lo)/θ_f + extra(a, s)` (the coupling adds its
    /// impulses through `extra`); returns the faces that hold a projected value.
    pub fn apply(
        &self,
        grid: &mut MacGrid,
        q: &[Real],
        extra: impl Fn(usize, usize) -> Real + Sync,
    ) -> Valid {
        self.update_faces(grid, |_, ax, s, u, f| {
            let ql = f.lo.map_or_else(|| self.air.get(ax, s), |i| q[i as usize]);
            let qh = f.hi.map_or_else(|| self.air.get(ax, s), |i| q[i as usize]);
            (u - (qh - ql) / f.theta + extra(ax, s), 1)
        })
    }

    /// Sets every face of `grid.u` and returns which hold a projected value:
    /// walls and closed faces 0 (invalid), prescribed faces kept (valid),
    /// faces with no liquid side kept (invalid), and each face next to
    /// liquid as `rule(grid, axis, slot, u, sides)` says (new value, valid).
    pub(crate) fn update_faces(
        &self,
        grid: &mut MacGrid,
        rule: impl Fn(&MacGrid, usize, usize, Real, FaceSides) -> (Real, u8) + Sync,
    ) -> Valid {
        let g: &MacGrid = grid;
        let ns = g.slots();
        let mut valid: Valid = Default::default();
        let mut newu: [Vec<Real>; 3] = Default::default();
        for ax in 0..3 {
            let (nu, vf): (Vec<Real>, Vec<u8>) = (0..ns)
                .into_par_iter()
                .map(|s| {
                    let u = g.u[ax][s];
                    if is_wall_face(g, s, ax) || g.weight[ax][s] == 0.0 {
                        return (0.0, 0);
                    }
                    if g.is_prescribed(ax, s) {
                        return (u, 1);
                    }
                    match self.face(g, ax, s) {
                        Some(f) => rule(g, ax, s, u, f),
                        None => (u, 0),
                    }
                })
                .unzip();
            newu[ax] = nu;
            valid[ax] = vf;
        }
        grid.u = newu;
        valid
    }
}

/// Projects `grid.u` to be divergence free in the liquid; returns the faces that hold a projected value.
pub fn project(
    grid: &mut MacGrid,
    solids: &SolidSet,
    prm: PcgParams,
) -> Result<(ProjectionInfo, Valid), NotFinite> {
    let sys = Poisson::build(grid, solids, |_, _| false);
    let mut q = vec![0.0; sys.a.len()];
    let solve = pcg(&sys.a, &sys.b, &mut q, prm)?;
    let valid = sys.apply(grid, &q, |_, _| 0.0);
    Ok((
        ProjectionInfo {
            solve,
            cells: sys.cells.len(),
            theta_clamps: sys.theta_clamps,
        },
        valid,
    ))
}

/// Algorithm 1 step 7 as one stage: [`project`], then extend the projected
/// velocities `layers` layers and apply free slip inside solids.
pub fn project_liquid(
    grid: &mut MacGrid,
    solids: &SolidSet,
    prm: PcgParams,
    layers: usize,
) -> Result<ProjectionInfo, NotFinite> {
    let (info, mut valid) = project(grid, solids, prm)?;
    extrapolate(grid, &mut valid, layers);
    constrain_solids(grid, solids);
    Ok(info)
}

/// Offset of `k` cells along axis `a`.
#[inline]
pub fn unit(a: usize, k: isize) -> [isize; 3] {
    let mut o = [0; 3];
    o[a] = k;
    o
}

/// Largest |divergence|·Δx over liquid cells (m/s): the discrete
/// incompressibility residual, for tests.
pub fn max_divergence(g: &MacGrid) -> Real {
    (0..g.slots())
        .into_par_iter()
        .filter(|&s| g.in_domain(s) && g.phi[s] < 0.0)
        .map(|s| {
            let mut d = 0.0;
            for a in 0..3 {
                let hi = g
                    .neighbor(s, unit(a, 1))
                    .map_or(0.0, |t| g.weight[a][t] * g.u[a][t]);
                d += hi - g.weight[a][s] * g.u[a][s];
            }
            d.abs()
        })
        .reduce(|| 0.0, Real::max)
}
