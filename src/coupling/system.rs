//! Assembly of the coupled system, eq. (24), and of its reduced form with
//! the impulses eliminated (the Schur-complement variant).
//!
//! Scaled unknowns: q = Δt p / (ρ Δx) per liquid cell (m/s, the grid's
//! pressure scaling), u per sheet/filament particle (m/s, three rows each,
//! interleaved), and μ_f = λ_f / (ρ Δx³ w_f) per constraint face (m/s: the
//! impulse per unit face mass). With m̂ = m/(ρΔx³), ĉ = θσΔt²S/(ρΔx³) (θ the
//! tension's implicit weight, 1 in the paper) and
//! s_{c,f} = +1 when c is the cell below face f, −1 above it:
//!
//! - cell c (eq. 20):    A q + Σ_f s_{c,f} (w_f/θ_f) μ_f = b_c
//! - particle (i, d) (eqs. 21/22, negated as in eq. 24):
//!   −m̂_i u_{i,d} + ĉ_i Σ_j L_ij u_{j,d} − Σ_{f: axis d} J_{f,i} w_f μ_f
//!   (ĉ_i also holds μΔt m_i/(ρ ρΔx³), the implicit MLS viscosity of eq. 13,
//!   on particles that are not a volume's surface layer)
//!   = −[m u** + Δt (σ S L x + f_explicit)]_{i,d} / (ρΔx³)
//! - face f (eq. 23, times w_f):
//!   Σ_c s_{c,f} (w_f/θ_f) q_c + (w_f/θ_f) μ_f − w_f (J u)_f = −w_f v**_f
//!
//! so that the face velocity after the solve is v_f = v**_f − (Gq)_f + μ_f/θ_f
//! = (J u)_f: a constraint face carries the liquid fraction θ_f of its mass
//! (M₍₀₎ of eq. 19). θ_f is [`Constraints::mass`]: the ghost-fluid fraction
//! of the pressure's level set, or the fraction inside the sheet
//! ([`Constraints::set_mass`]), bounded below by [`Constraints::floor`]; in the
//! monolithic form the constraint faces' entries of A use the same
//! θ_f (A is corrected from the pressure solve's ghost-fluid θ). At rest
//! μ_f = −(Gq)_f whatever θ_f is, so θ_f changes the inertia, never the
//! Young–Laplace jump. The q–μ and u–μ blocks are each other's transposes,
//! as in eq. (24); only the MLS Laplacian is non-symmetric. Fixed particles
//! get identity rows.
//!
//! Eliminating μ with the face rows (μ_f/θ_f = (Ju)_f − v**_f + (Gq)_f)
//! leaves [q, u] with A' (A without the constraint faces: they become
//! Neumann faces whose flux is the particles'), the coupling s_{c,f} w_f J
//! in both off-diagonal blocks, and the particle block
//! −m̂ + ĉ L − Jᵀ W Θ J (the sheet drags the face masses it drives).

use super::faces::Constraints;
use super::surface::Surface;
use super::{solve_err, CouplingError};
use crate::grid::projection::Poisson;
use crate::grid::NONE;
use crate::linsolve::{
    csr::rows_from_triplets, reverse_cuthill_mckee, split_halves, Csr, SolveError, Tripled,
};
use crate::math::{Real, Vec3};
use faer::sparse::{SparseRowMat, Triplet};
use rayon::prelude::*;

/// Default smallest face-mass fraction (`coupling.mass_floor`). The
/// monolithic form's face rows divide by it: a massless face outside the
/// sheet would make entries of size w/θ → ∞ in A and in the μ block. The
/// reduced form uses the same bound so that both forms solve the same
/// equations. The floor is inertia the faces outside the sheet add to it,
/// which the balanced face mass pays for with the other faces
/// ([`super::FaceMass::Balanced`]; `docs/decisions.md`, "The mass floor").
pub const MASS_FLOOR: Real = 0.05;

/// Default implicit weight θ of the sheet and filament tension
/// (`coupling.tension_theta`): the force is σS L(xⁿ + θΔt uⁿ⁺¹). 1/2 is the
/// smallest θ that stays stable at any Δt, and damps a capillary
/// oscillation half as much as the paper's backward Euler (θ = 1;
/// `docs/decisions.md`, "The tension's implicit weight").
pub const TENSION_THETA: Real = 0.5;

/// θ_f of constraint face `f`, at least [`Constraints::floor`] (both forms
/// use the same, so that they solve the same equations).
#[inline]
pub fn mono_theta(k: &Constraints, f: usize) -> Real {
    k.mass[f].max(k.floor)
}

/// Physical scalars of the solve.
#[derive(Clone, Copy, Debug)]
pub struct Scalars {
    /// Substep Δt (s).
    pub dt: Real,
    /// Surface tension σ (N/m).
    pub sigma: Real,
    /// Dynamic viscosity μ (Pa·s) of the free sheets and filaments (eq. 13).
    pub viscosity: Real,
    /// Density ρ (kg/m³).
    pub density: Real,
    /// Cell size Δx (m).
    pub dx: Real,
    /// Implicit weight θ of the tension ([`super::surface::SurfaceParams::tension_theta`]).
    pub theta: Real,
}

/// Which system to build.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Form {
    /// eq. (24): [q, u, μ].
    Monolithic,
    /// μ eliminated: [q, u].
    Reduced,
}

/// Order of the unknowns of the monolithic system, which is what ILU(0)
/// eliminates in (`docs/decisions.md`, Coupling).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum IluOrder {
    /// [q, u, μ] as eq. (24) writes it, particles in joint-index order.
    Equation,
    /// [u, μ, q]: the particles first, numbered by reverse Cuthill–McKee of
    /// the Laplacian's pattern (three interleaved rows each), then the
    /// constraint faces, then the liquid cells.
    #[default]
    ParticlesFirst,
}

/// The matrix of an assembled system.
pub enum SystemMatrix {
    /// General compressed rows.
    General(SparseRowMat<usize, Real>),
    /// The monolithic form ordered particles first, its particle block
    /// `I₃ ⊗ P` stored once ([`Tripled`]).
    Shared(Tripled),
}

/// A sparse system and its right-hand side.
pub struct Assembled {
    /// The matrix.
    pub matrix: SystemMatrix,
    /// Right-hand side.
    pub rhs: Vec<Real>,
    /// Offset of the q block.
    pub qo: usize,
    /// Offset of the u block (three rows per particle, interleaved).
    pub uo: usize,
    /// Offset of the μ block.
    pub mo: usize,
    /// Liquid cells.
    pub nq: usize,
    /// Particles.
    pub np: usize,
    /// Constraint faces (0 in the reduced form).
    pub nk: usize,
    /// Slot of each particle in the u block (`None`: joint-index order).
    slot: Option<Vec<usize>>,
}

impl Assembled {
    /// Row (and column) of component `d` of particle `i`'s velocity.
    #[inline]
    pub fn u_row(&self, i: usize, d: usize) -> usize {
        self.uo + 3 * self.slot.as_ref().map_or(i, |s| s[i]) + d
    }
}

/// Entries of the pressure block (symmetric 7-point stencil).
/// The diagonal is always stored (it may be 0 in the reduced form).
fn pressure_block(sys: &Poisson, qo: usize, t: &mut Vec<Triplet<usize, usize, Real>>) {
    let a = &sys.a;
    for i in 0..a.len() {
        t.push(Triplet::new(qo + i, qo + i, a.diag[i]));
        for d in 0..3 {
            let u = a.up[i][d];
            if u != NONE {
                let u = qo + u as usize;
                t.push(Triplet::new(qo + i, u, a.off[i][d]));
                t.push(Triplet::new(u, qo + i, a.off[i][d]));
            }
        }
    }
}

/// The particles' slots in the particles-first order of eq. (24): reverse
/// Cuthill–McKee of the MLS Laplacian's pattern, then its two halves apart
/// and their separator last ([`split_halves`]), so that the shared format's
/// triangular solves work the halves in parallel. It depends only on the
/// pattern (the same in both formats and for any thread count), so
/// [`crate::coupling::solve`] computes it once per substep, beside the grid
/// work that does not need it.
#[derive(Clone, Debug)]
pub struct ParticleOrder {
    /// Slot of each particle (joint index → slot).
    pub slot: Vec<usize>,
    /// Slots `..halves[0]` and `halves[0]..halves[1]` share no entry of P.
    pub halves: [usize; 2],
}

/// [`ParticleOrder`] of the sheet and filament particles of `surf`.
pub fn particle_order(surf: &Surface) -> Result<ParticleOrder, SolveError> {
    let np = surf.len();
    let l = Csr::from_faer(surf.laplacian.as_ref())?;
    let rcm = reverse_cuthill_mckee(np, l.row_ptr, l.col);
    let (order, a, b) = split_halves(np, l.row_ptr, l.col, &rcm);
    let mut slot = vec![0; np];
    for (s, &i) in order.iter().enumerate() {
        slot[i] = s;
    }
    Ok(ParticleOrder {
        slot,
        halves: [a, b],
    })
}

/// (cell, s_{c,f}) of the liquid cells next to constraint face f.
fn face_cells(k: &Constraints, f: usize) -> impl Iterator<Item = (usize, Real)> + '_ {
    let s = k.sides[f];
    s.lo.map(|c| (c as usize, 1.0))
        .into_iter()
        .chain(s.hi.map(|c| (c as usize, -1.0)))
}

/// Assembles the chosen form. `sys` is the pressure system built without
/// (monolithic) or with (reduced) the constraint faces skipped; `vstar`
/// holds v**_f − c_f of each constraint face, where the face is held to
/// (J u)_f + c_f, and `band` holds c_f: the reduced form's cell rows carry
/// the constraint faces' flux w_f((J u)_f + c_f), so c enters their
/// right-hand side (the monolithic form needs only v** − c).
///
/// Unknown order: monolithic [q, u, μ] as eq. (24) writes it
/// ([`IluOrder::Equation`]) or [u, μ, q] with the particles in reverse
/// Cuthill–McKee order ([`IluOrder::ParticlesFirst`]); reduced [u, q], so
/// that ILU(0) meets the particle pivots first and the cells whose every
/// face is a constraint face (a zero diagonal in A') receive their pivot
/// from the eliminated particle block. With `face_fill` the monolithic
/// matrix also stores explicit zeros between the constraint faces of one
/// axis that share a free particle: the λ–λ fill that eliminating the
/// particle rows creates, which ILU(0) then keeps (ILU with one level of
/// fill in the λ block). Neither changes the system, only the incomplete
/// factorisation ILU(0) computes.
///
/// With `shared`, the monolithic form ordered particles first is built as
/// [`SystemMatrix::Shared`]: its particle block is `I₃ ⊗ P`, assembled
/// once (the values and their summation order are those of the general
/// rows; tested). Otherwise, and for the other forms,
/// [`SystemMatrix::General`].
#[allow(clippy::needless_range_loop, clippy::too_many_arguments)]
pub fn assemble(
    form: Form,
    sys: &Poisson,
    surf: &Surface,
    k: &Constraints,
    vstar: &[Real],
    band: &[Real],
    sc: Scalars,
    order: IluOrder,
    face_fill: bool,
    shared: bool,
    given: Option<&ParticleOrder>,
    cut: &[(usize, usize, Vec3)],
) -> Result<Assembled, SolveError> {
    if form == Form::Monolithic && !cut.is_empty() {
        return Err(SolveError::Dimension(
            "the cut layer's rows are built for the reduced form only".into(),
        ));
    }
    let nq = sys.a.len();
    let np = surf.len();
    let nk = if form == Form::Monolithic { k.len() } else { 0 };
    let n = nq + 3 * np + nk;
    let reorder = form == Form::Monolithic && order == IluOrder::ParticlesFirst;
    let (qo, uo, mo) = match form {
        Form::Monolithic if reorder => (3 * np + nk, 0, 3 * np),
        Form::Monolithic => (0, nq, nq + 3 * np),
        Form::Reduced => (3 * np, 0, n),
    };
    let l = Csr::from_faer(surf.laplacian.as_ref())?;
    let (slot, halves) = match (reorder, given) {
        (false, _) => (None, [np, np]),
        (true, Some(o)) if o.slot.len() == np => (Some(o.slot.clone()), o.halves),
        (true, Some(_)) => {
            return Err(SolveError::Dimension(
                "the particle order was computed for another particle set".into(),
            ))
        }
        (true, None) => {
            let o = particle_order(surf)?;
            (Some(o.slot), o.halves)
        }
    };
    let ur = |i: usize, d: usize| uo + 3 * slot.as_ref().map_or(i, |s| s[i]) + d;
    let vol = sc.density * sc.dx.powi(3);
    let shared_p = shared && reorder;
    // ĉ_i of particle i's tension/viscosity row (eq. 21/22, eq. 13)
    let ch = |i: usize| {
        // the implicit MLS viscosity μΔt V L u of eq. (13), V = m/ρ, on
        // particles that are not the surface layer of a volume (whose
        // velocity the grid's viscosity sets)
        let visc = if surf.attached[i] {
            0.0
        } else {
            sc.viscosity * sc.dt * surf.mass[i] / sc.density
        };
        (sc.theta * sc.sigma * sc.dt * sc.dt * surf.area[i] + visc) / vol
    };
    let mut t: Vec<Triplet<usize, usize, Real>> = Vec::with_capacity(
        7 * nq + 3 * l.val.len() * (!shared_p) as usize + 4 * k.col.len() + 4 * k.len(),
    );
    let mut rhs = vec![0.0; n];
    pressure_block(sys, qo, &mut t);
    rhs[qo..qo + nq].copy_from_slice(&sys.b);
    // (L x)_i projected on the normal space: the explicit part of the tension
    let mut lx = vec![Vec3::zeros(); np];
    for (i, out) in lx.iter_mut().enumerate() {
        let mut v = Vec3::zeros();
        for kk in l.row_ptr[i]..l.row_ptr[i + 1] {
            v += surf.nb.x[l.col[kk]] * l.val[kk];
        }
        *out = surf.normal_curvature(i, &v);
    }
    // particle rows
    for i in 0..np {
        let mh = surf.mass[i] / vol;
        for d in 0..3 {
            let r = ur(i, d);
            if !shared_p {
                t.push(Triplet::new(r, r, -mh));
            }
            if surf.fixed[i] {
                rhs[r] = -mh * surf.u[i][d];
                continue;
            }
            // implicit tension and viscosity
            if !shared_p {
                let ch = ch(i);
                for kk in l.row_ptr[i]..l.row_ptr[i + 1] {
                    t.push(Triplet::new(r, ur(l.col[kk], d), ch * l.val[kk]));
                }
            }
            rhs[r] = -(surf.mass[i] * surf.u[i][d]
                + sc.dt * (sc.sigma * surf.area[i] * lx[i][d] + surf.force[i][d]))
                / vol;
        }
    }
    // the cut layer (super::cut): the cells' rows carry the particles'
    // normal flux, the particles' rows the cells' pressure
    for &(c, i, v) in cut {
        for d in 0..3 {
            if v[d] != 0.0 {
                let r = ur(i, d);
                t.push(Triplet::new(qo + c, r, v[d]));
                if !surf.fixed[i] {
                    t.push(Triplet::new(r, qo + c, v[d]));
                }
            }
        }
    }
    // coupling through the constraint faces
    for f in 0..k.len() {
        let a = k.faces[f].0;
        let w = k.weight[f];
        match form {
            Form::Monolithic => {
                let th = mono_theta(k, f);
                // A was built with the ghost-fluid θ on this face
                let delta = w / th - w / k.sides[f].theta;
                if delta != 0.0 {
                    for (c1, s1) in face_cells(k, f) {
                        for (c2, s2) in face_cells(k, f) {
                            t.push(Triplet::new(qo + c1, qo + c2, s1 * s2 * delta));
                        }
                    }
                }
                let m = mo + f;
                t.push(Triplet::new(m, m, w / th));
                rhs[m] = -w * vstar[f];
                for (c, s) in face_cells(k, f) {
                    t.push(Triplet::new(qo + c, m, s * w / th));
                    t.push(Triplet::new(m, qo + c, s * w / th));
                }
                for (i, j) in k.row(f) {
                    let r = ur(i, a);
                    t.push(Triplet::new(m, r, -w * j));
                    if !surf.fixed[i] {
                        t.push(Triplet::new(r, m, -w * j));
                    }
                }
            }
            Form::Reduced => {
                let th = mono_theta(k, f);
                for (c, s) in face_cells(k, f) {
                    rhs[qo + c] -= s * w * band[f];
                    for (i, j) in k.row(f) {
                        let r = ur(i, a);
                        t.push(Triplet::new(qo + c, r, s * w * j));
                        if !surf.fixed[i] {
                            t.push(Triplet::new(r, qo + c, s * w * j));
                        }
                    }
                }
                for (i, ji) in k.row(f) {
                    if surf.fixed[i] {
                        continue;
                    }
                    let r = ur(i, a);
                    rhs[r] -= ji * w * th * vstar[f];
                    for (jdx, jj) in k.row(f) {
                        t.push(Triplet::new(r, ur(jdx, a), -ji * w * th * jj));
                    }
                }
            }
        }
    }
    if form == Form::Monolithic && face_fill {
        // explicit zeros where eliminating a particle row fills the λ block:
        // faces of one axis that share a (free) particle
        // the faces of each (free particle, axis), ascending, in compressed rows
        let mut start = vec![0usize; 3 * np + 1];
        for f in 0..k.len() {
            let a = k.faces[f].0;
            for (i, _) in k.row(f) {
                if !surf.fixed[i] {
                    start[3 * i + a + 1] += 1;
                }
            }
        }
        for b in 0..3 * np {
            start[b + 1] += start[b];
        }
        let mut at = start.clone();
        let mut faces_of = vec![0u32; start[3 * np]];
        for f in 0..k.len() {
            let a = k.faces[f].0;
            for (i, _) in k.row(f) {
                if !surf.fixed[i] {
                    faces_of[at[3 * i + a]] = f as u32;
                    at[3 * i + a] += 1;
                }
            }
        }
        // each face's row of explicit zeros, in parallel (a marker per task)
        let zeros: Vec<Vec<u32>> = (0..k.len())
            .into_par_iter()
            .with_min_len(1024)
            .map_init(
                || vec![usize::MAX; k.len()],
                |seen, f| {
                    let a = k.faces[f].0;
                    seen[f] = f;
                    let mut row = Vec::new();
                    for (i, _) in k.row(f) {
                        for &g in &faces_of[start[3 * i + a]..start[3 * i + a + 1]] {
                            if seen[g as usize] != f {
                                seen[g as usize] = f;
                                row.push(g);
                            }
                        }
                    }
                    row
                },
            )
            .collect();
        for (f, row) in zeros.iter().enumerate() {
            t.extend(
                row.iter()
                    .map(|&g| Triplet::new(mo + f, mo + g as usize, 0.0)),
            );
        }
    }
    let matrix = if let (true, Some(slot)) = (shared_p, slot.as_ref()) {
        // P by slot: −m̂ on the diagonal, then ĉ L (fixed: −m̂ alone),
        // summed in the general rows' order
        let mut at = vec![0; np];
        for (i, &s) in slot.iter().enumerate() {
            at[s] = i;
        }
        let rows: Vec<Vec<(u32, Real)>> = at
            .par_iter()
            .map(|&i| {
                let mut row = vec![(slot[i] as u32, -surf.mass[i] / vol)];
                if !surf.fixed[i] {
                    let ch = ch(i);
                    for kk in l.row_ptr[i]..l.row_ptr[i + 1] {
                        row.push((slot[l.col[kk]] as u32, ch * l.val[kk]));
                    }
                }
                // stable: duplicates keep their order
                row.sort_by_key(|e| e.0);
                row.dedup_by(|b, a| {
                    let same = a.0 == b.0;
                    if same {
                        a.1 += b.1;
                    }
                    same
                });
                row
            })
            .collect();
        let rest = rows_from_triplets(n, n, &t)?;
        let rest = Csr::from_faer(rest.as_ref())?;
        // the impulse rows split by face axis (faces are sorted by axis, and
        // a face row couples only to its own axis's particle components and
        // faces); the pressure rows after them couple to all
        SystemMatrix::Shared(
            Tripled::from_parts(np, halves, &rows, &rest)?.with_sequential_tail(qo),
        )
    } else if reorder {
        // the triplets are out of row order: bucket them by row first
        SystemMatrix::General(rows_from_triplets(n, n, &t)?)
    } else {
        SystemMatrix::General(
            SparseRowMat::try_new_from_triplets(n, n, &t)
                .map_err(|e| SolveError::Dimension(format!("{e:?}")))?,
        )
    };
    Ok(Assembled {
        matrix,
        rhs,
        qo,
        uo,
        mo,
        nq,
        np,
        nk,
        slot,
    })
}

/// ‖b − A x‖/‖b‖ of eq. (24) in the monolithic form for a solution given as
/// (q, u, μ).
#[allow(clippy::too_many_arguments)]
pub(super) fn eq24_residual(
    full: &Poisson,
    surf: &Surface,
    k: &Constraints,
    vstar: &[Real],
    sc: Scalars,
    q: &[Real],
    u: &[Vec3],
    mu: &[Real],
) -> Result<Real, CouplingError> {
    let sys = assemble(
        Form::Monolithic,
        full,
        surf,
        k,
        vstar,
        &vec![0.0; k.len()],
        sc,
        IluOrder::Equation,
        false,
        false,
        None,
        &[],
    )
    .map_err(solve_err("eq. (24) residual"))?;
    let SystemMatrix::General(m) = &sys.matrix else {
        return Err(solve_err("eq. (24) residual")(SolveError::Dimension(
            "the equation order came out in the shared format".into(),
        )));
    };
    let a = Csr::from_faer(m.as_ref()).map_err(solve_err("eq. (24) residual"))?;
    let mut x = vec![0.0; a.nrows];
    x[sys.qo..sys.qo + sys.nq].copy_from_slice(q);
    for (i, v) in u.iter().enumerate() {
        for d in 0..3 {
            x[sys.u_row(i, d)] = v[d];
        }
    }
    for f in 0..k.len() {
        x[sys.mo + f] = mu[f];
    }
    let mut ax = vec![0.0; a.nrows];
    a.matvec(&x, &mut ax);
    let r: Vec<Real> = sys.rhs.iter().zip(&ax).map(|(b, y)| b - y).collect();
    let bn = crate::linsolve::norm(&sys.rhs);
    Ok(if bn > 0.0 {
        crate::linsolve::norm(&r) / bn
    } else {
        crate::linsolve::norm(&r)
    })
}
