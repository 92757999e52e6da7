//! Semi-implicit codimensional surface tension (paper §6, eqs. 14–17) and
//! the explicit rim and bud tension.
//!
//! On sheet and filament particles the tension force is
//! f = σ κn S = σ (∇²x) S (eq. 14), with ∇² the joint MLS Laplace–Beltrami
//! operator L (§3.2.4) and S the control area (Appendix D, [`crate::area`]).
//! Taking x^{n+1} = x^n + Δt u^{n+1} inside the Laplacian (Zheng et al. 2006)
//! gives, per velocity component,
//!
//! (M − σΔt² S L) u^{n+1} = σΔt S L x^n + M u** + Δt f_explicit   (eq. 16/17)
//!
//! — one matrix for the three components, non-symmetric because L is;
//! solved with BiCGSTAB + ILU(0) ([`crate::linsolve`]).
//! With `film.implicit: diffusive` only the diffusive part of L is
//! implicit and the rest acts on u^n ([`split`]): an M-matrix at any Δt.
//!
//! Rim particles (filament particles on a sheet's edge) get the explicit rim
//! force σ n S_r / r (Bush & Hasha 2004) with n = ±b² oriented into the sheet
//! (the rim curvature is 1/r), optionally multiplied by a user modulation of
//! the yaw angle (the fluid-polygon saw-tooth, §10.2). Bud particles
//! (filament ends) get σ (2/r) S_b along their tangent into the filament:
//! the bud is a hemisphere of radius r whose mean-curvature vector has
//! magnitude 2/r.
//!
//! Fixed particles (Appendix C rings) keep their prescribed velocity: their
//! rows are replaced by the identity.

use crate::linsolve::{
    bicgstab, diag_plus_scaled_rows, BicgstabParams, Csr, Ilu0, SolveError, SolveInfo,
};
use crate::math::{Mat3, Real, Vec3};
use crate::particles::Codim;
use crate::transition::cone_census;
use faer::sparse::{SparseRowMat, SparseRowMatRef};
use rayon::prelude::*;

#[path = "tension_split.rs"]
pub mod split;

/// Role of a filament particle for the explicit tension terms.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FilamentRole {
    /// Not a filament particle.
    None,
    /// Interior of a free filament.
    Plain,
    /// Bounds a sheet (has sheet neighbours within h).
    Rim,
    /// End of a filament (filament neighbours on one side only along b¹).
    Bud,
}

/// Classifies filament particle `p`: rim if a sheet particle is within h,
/// else bud if only one of the two cones of half-aperture `bud_angle` along
/// ±b¹ holds filament particles, else plain.
pub fn filament_role(
    p: usize,
    frame: &Mat3,
    x: &[Vec3],
    codim: &[Codim],
    nbrs: &[u32],
    h: Real,
    bud_angle: Real,
) -> FilamentRole {
    if codim[p] != Codim::Filament {
        return FilamentRole::None;
    }
    if nbrs
        .iter()
        .any(|&q| codim[q as usize] == Codim::Sheet && (x[q as usize] - x[p]).norm() < h)
    {
        return FilamentRole::Rim;
    }
    let b1: Vec3 = frame.column(0).into();
    let c = cone_census(p, &b1, bud_angle, h, x, codim, nbrs);
    if c.one_sided(&[Codim::Filament]) {
        FilamentRole::Bud
    } else {
        FilamentRole::Plain
    }
}

/// Explicit rim force on rim particle `p`: σ S_r / r times `modulation`
/// (1 for a plain rim), along the rim's in-plane normal pointing into the
/// sheet. The paper takes b² of F_p, the frame of the rim particle's
/// neighbourhood *including* its sheet neighbours; here that direction is
/// formed directly as the offset to the sheet neighbours' centroid with its
/// component along the rim tangent (b¹ of the filament frame, `frame`
/// column 0) removed — the same vector, without depending on how PCA orders
/// two nearly equal eigenvalues.
pub fn rim_force(
    p: usize,
    frame: &Mat3,
    x: &[Vec3],
    codim: &[Codim],
    nbrs: &[u32],
    sigma: Real,
    s_rim: Real,
    r: Real,
    modulation: Real,
) -> Vec3 {
    let mut c = Vec3::zeros();
    let mut n = 0;
    for &q in nbrs {
        if codim[q as usize] == Codim::Sheet {
            c += x[q as usize];
            n += 1;
        }
    }
    if n == 0 || r <= 0.0 {
        return Vec3::zeros();
    }
    let t: Vec3 = frame.column(0).into();
    let mut d = c / n as Real - x[p];
    d -= t * d.dot(&t);
    let len = d.norm();
    if len == 0.0 || !len.is_finite() {
        return Vec3::zeros();
    }
    d * (sigma * s_rim / r * modulation / len)
}

/// Explicit bud force on bud particle `p`: σ (2/r) S_b along ±b¹ oriented
/// towards its filament neighbours.
pub fn bud_force(
    p: usize,
    frame: &Mat3,
    x: &[Vec3],
    codim: &[Codim],
    nbrs: &[u32],
    sigma: Real,
    s_bud: Real,
    r: Real,
) -> Vec3 {
    let b1: Vec3 = frame.column(0).into();
    let mut side = 0.0;
    for &q in nbrs {
        if codim[q as usize] == Codim::Filament && q as usize != p {
            side += (x[q as usize] - x[p]).dot(&b1);
        }
    }
    if side == 0.0 || r <= 0.0 {
        return Vec3::zeros();
    }
    b1 * (side.signum() * sigma * 2.0 / r * s_bud)
}

/// Saw-tooth modulation of the rim tension for the fluid polygon (§10.2):
/// 1 + a·(2·frac(k·(φ − φ₀)/2π) − 1) for the yaw angle φ of a particle
/// around the vertical axis through `centre`, with k teeth, amplitude a and
/// the teeth turned by φ₀ (their drops at φ₀ + 2πj/k).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sawtooth {
    /// Number of teeth k.
    pub corners: u32,
    /// Amplitude a, in [0, 1).
    pub amplitude: Real,
    /// A point of the vertical axis (m).
    pub centre: Vec3,
    /// Turn φ₀ of the teeth about the axis (rad).
    pub phase: Real,
}

impl Sawtooth {
    /// The factor on the rim tension at `x`.
    pub fn at(&self, x: &Vec3) -> Real {
        let d = x - self.centre;
        let phi = d.z.atan2(d.x) - self.phase; // yaw about the y (vertical) axis
        let t = (self.corners as Real * phi / (2.0 * std::f64::consts::PI)).rem_euclid(1.0);
        1.0 + self.amplitude * (2.0 * t - 1.0)
    }
}

/// Inputs of the semi-implicit solve, all indexed on the joint sheet+filament
/// index of L.
pub struct TensionSystem<'a> {
    /// Joint Laplacian L (n×n), rows are ∇² at each particle.
    pub laplacian: SparseRowMatRef<'a, usize, Real>,
    /// Particle masses (kg).
    pub mass: &'a [Real],
    /// Surface-tension areas S (m²).
    pub area: &'a [Real],
    /// Positions x^n (m).
    pub x: &'a [Vec3],
    /// Velocities u** after viscosity (m/s).
    pub u: &'a [Vec3],
    /// Explicit forces (rim, bud, wind, …) (N).
    pub f_explicit: &'a [Vec3],
    /// Fixed particles keep `u`.
    pub fixed: &'a [bool],
    /// Implicit drag coefficients d (kg/s) per particle, or empty for none:
    /// the force −d u^{n+1} joins the system's diagonal (its target velocity
    /// goes into `f_explicit` as d u_target, see `gas::wind_drag`).
    pub drag: &'a [Real],
    /// Kinematic viscosity ν = μ/ρ (m²/s) of an implicit MLS viscosity
    /// (eq. 13, m u = m u* + μΔt V L u with V = m/ρ) solved together with the
    /// tension; 0 when the caller solves viscosity separately or μ = 0.
    pub nu: Real,
    /// Surface tension σ (N/m).
    pub sigma: Real,
    /// Time step Δt (s).
    pub dt: Real,
    /// Which part of ∇²x^n enters the right-hand side.
    pub curvature: CurvaturePart<'a>,
    /// Take only the diffusive part of L implicitly and the rest on u^n
    /// ([`split`], `film.implicit: diffusive`).
    pub diffusive: bool,
    /// Implicit weight θ of the tension: σS L(xⁿ + θΔt uⁿ⁺¹); 1 is eq. (16)'s
    /// backward Euler, 1/2 the least that stays unconditionally stable.
    pub theta: Real,
}

/// Which part of the curvature vector ∇²x^n = (L x^n)_i drives the
/// explicit side of eq. (16).
#[derive(Clone, Copy, Debug)]
pub enum CurvaturePart<'a> {
    /// All of it.
    Full,
    /// Its normal part only ([`normal_part`]): frame axes per joint
    /// particle; the first `n_sheet` are sheets.
    Normal {
        /// Frame axes (b¹, b², b³) per particle.
        axes: &'a [Mat3],
        /// Number of sheet particles (the first joint indices).
        n_sheet: usize,
    },
}

/// The normal part of a curvature vector ∇²x: a sheet keeps its b³
/// component, a filament loses its b¹ component. Analytically κn is normal;
/// on an irregular sampling, or next to a boundary ring where the
/// neighbourhood is one-sided, the MLS row has an O(h^k) tangential error
/// which, left in the explicit tension, drives the particles along the
/// surface and feeds on the irregularity it creates (resting droplet:
/// tangential sheet speed doubling every ~30 ms; full-resolution catenoid:
/// the rows next to the rings pulled away from them until the film tore,
/// `docs/decisions.md`).
pub fn normal_part(axes: &Mat3, sheet: bool, lx: &Vec3) -> Vec3 {
    if sheet {
        let n: Vec3 = axes.column(2).into();
        n * n.dot(lx)
    } else {
        let t: Vec3 = axes.column(0).into();
        lx - t * t.dot(lx)
    }
}

/// Result of the semi-implicit tension solve.
#[derive(Clone, Debug)]
pub struct TensionSolution {
    /// u^{n+1} per particle.
    pub u: Vec<Vec3>,
    /// Solver figures per component (x, y, z).
    pub info: [SolveInfo; 3],
}

/// Assembles A = I + Δt M⁻¹ D − (σΔt² M⁻¹ S + νΔt) L: eq. (16) with every
/// row divided by the particle's mass, so rows of light and heavy particles
/// are on one scale (identity rows for fixed particles); D is the implicit
/// drag (zero unless `drag` is given), ν the implicit viscosity (eq. 13).
pub fn assemble(sys: &TensionSystem) -> Result<SparseRowMat<usize, Real>, SolveError> {
    let n = sys.laplacian.nrows();
    if sys.laplacian.ncols() != n || [sys.mass.len(), sys.area.len(), sys.fixed.len()] != [n; 3] {
        return Err(SolveError::Dimension(format!(
            "tension system: Laplacian {}×{}, {} masses, {} areas, {} fixed flags",
            n,
            sys.laplacian.ncols(),
            sys.mass.len(),
            sys.area.len(),
            sys.fixed.len()
        )));
    }
    // a fixed row keeps only its diagonal 1 (its Laplacian entries scaled to 0)
    Ok(diag_plus_scaled_rows(
        sys.laplacian,
        |i| {
            if sys.fixed[i] {
                1.0
            } else {
                1.0 + sys.drag.get(i).map_or(0.0, |d| sys.dt * d / sys.mass[i])
            }
        },
        |i| {
            if sys.fixed[i] {
                0.0
            } else {
                -implicit_scale(sys, i)
            }
        },
    ))
}

/// The factor σΔt² S_i/m_i + νΔt of L's row i in the implicit term of the
/// mass-scaled eq. (16) (non-fixed rows).
fn implicit_scale(sys: &TensionSystem, i: usize) -> Real {
    sys.theta * sys.sigma * sys.dt * sys.dt * sys.area[i] / sys.mass[i] + sys.nu * sys.dt
}

/// Solves eq. (16)/(17) for u^{n+1}, component by component with one
/// ILU(0) factorisation. The previous velocity is the initial guess.
pub fn solve(sys: &TensionSystem, prm: &BicgstabParams) -> Result<TensionSolution, SolveError> {
    let n = sys.mass.len();
    let l = Csr::from_faer(sys.laplacian)?;
    let split = if sys.diffusive {
        Some(split::split(&l, sys.fixed)?)
    } else {
        None
    };
    let a_mat = match &split {
        Some(s) => assemble(&TensionSystem {
            laplacian: s.implicit.as_ref(),
            ..*sys
        })?,
        None => assemble(sys)?,
    };
    let a = Csr::from_faer(a_mat.as_ref())?;
    let ilu = Ilu0::new(&a)?;
    // ∇²x^n per particle (three products), then its normal part if asked
    let lx_c: Vec<Vec<Real>> = (0..3)
        .into_par_iter()
        .map(|d| {
            let xc: Vec<Real> = sys.x.iter().map(|x| x[d]).collect();
            let mut lx = vec![0.0; n];
            l.matvec(&xc, &mut lx);
            lx
        })
        .collect();
    let lx: Vec<Vec3> = (0..n)
        .map(|i| {
            let v = Vec3::new(lx_c[0][i], lx_c[1][i], lx_c[2][i]);
            match sys.curvature {
                CurvaturePart::Full => v,
                CurvaturePart::Normal { axes, n_sheet } => normal_part(&axes[i], i < n_sheet, &v),
            }
        })
        .collect();
    // the three components share the matrix and its factors and are solved
    // side by side (each solve is sequential, so the result does not
    // depend on the thread count)
    let comps: Vec<(Vec<Real>, SolveInfo)> = (0..3)
        .into_par_iter()
        .map(|d| {
            let b: Vec<Real> = (0..n)
                .map(|i| {
                    if sys.fixed[i] {
                        sys.u[i][d]
                    } else {
                        // the split's remainder on u^n, on the implicit
                        // term's row scale (see `assemble`)
                        let late = split.as_ref().map_or(0.0, |s| {
                            implicit_scale(sys, i) * s.remainder(i, |j| sys.u[j][d])
                        });
                        (sys.sigma * sys.dt * sys.area[i] * lx[i][d]
                            + sys.dt * sys.f_explicit[i][d])
                            / sys.mass[i]
                            + sys.u[i][d]
                            + late
                    }
                })
                .collect();
            let mut sol: Vec<Real> = sys.u.iter().map(|v| v[d]).collect();
            let info = bicgstab(&a, &b, &mut sol, &ilu, prm)?;
            Ok((sol, info))
        })
        .collect::<Result<_, SolveError>>()?;
    let mut u = vec![Vec3::zeros(); n];
    let mut info = [SolveInfo::default(); 3];
    for (d, (sol, si)) in comps.into_iter().enumerate() {
        info[d] = si;
        for i in 0..n {
            u[i][d] = sol[i];
        }
    }
    Ok(TensionSolution { u, info })
}

#[cfg(test)]
#[path = "tension_tests.rs"]
mod tests;
