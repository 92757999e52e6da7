//! Heat diffusion on the unit sphere (paper §10.1, Fig. 17).
//!
//! ∂s/∂t = Δs with s(θ, φ, 0) = cos φ, φ the polar angle, i.e. s₀ = z; it is a
//! degree-1 spherical harmonic, so s(t) = e^{−2t} cos φ exactly. The
//! semi-discrete system ds/dt = L s is integrated
//!
//! * accurately (shift-and-invert Krylov exponential, [`super::time`]),
//!   which gives the **spatial error** e_h = exp(tL)s₀ − s(t);
//! * with the chosen scheme (forward Euler — the paper's Δt = 1e-3 —,
//!   backward Euler, Crank–Nicolson, or the exact exponential), which gives
//!   the **total error**.
//!
//! Errors: max-abs and L1 (mean |e| over particles; the sampling is nearly
//! uniform in area). The rightmost eigenvalue of L is estimated by Arnoldi
//! on (I − τL)⁻¹; a stable operator has Re λ ≤ 0 (the constant mode gives 0).

use super::sampling::{sphere_latitude, sphere_spacing_for};
use super::time::{
    backward_euler, crank_nicolson, forward_euler, krylov_exp_poly, rightmost_ritz,
    rightmost_shift_invert, LinearSolver, ShiftedSolver,
};
use super::{max_abs, observed_orders, ValidateError};
use crate::math::Real;
use crate::mls::{FitStats, JointLaplacian, MlsParams, Neighborhoods};
use serde::Serialize;
use std::time::Instant;

/// Time integration scheme.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Scheme {
    /// s ← s + Δt L s (the paper's choice).
    ForwardEuler,
    /// (I − Δt L) s⁺ = s.
    BackwardEuler,
    /// (I − Δt/2 L) s⁺ = (I + Δt/2 L) s.
    CrankNicolson,
    /// exp(tL) s₀ by Krylov (time error ≪ spatial error).
    Exact,
}

/// How the rightmost eigenvalue of L is estimated.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum EigenMethod {
    /// Not estimated.
    None,
    /// Converged Ritz values of 120 Arnoldi steps on L (no solves). Fast but
    /// not trustworthy: it can miss an unstable mode entirely (measured on the
    /// butterfly without boundary rows: −1.0e4 reported, +30 true); kept for
    /// the spectral-radius estimate.
    Ritz,
    /// 45 Arnoldi steps on (I − 0.002 L)⁻¹, each solve by the case's
    /// [`LinearSolver`] to a relative residual of 1e-8 (default BiCGSTAB;
    /// `SparseLu` is exact but its factorisation takes ~9 s for 30k
    /// particles). Measured on the unstable butterfly variant it finds the
    /// true rightmost eigenvalue (+15.6, +30.2 at Δ = 0.04, 0.02).
    ShiftInvert,
}

/// The case's parameters.
#[derive(Clone, Debug, Serialize)]
pub struct SphereDiffusion {
    /// Target particle count (Appendix F sampling; the actual count differs slightly).
    pub particles: usize,
    /// Tangential jitter, fraction of the spacing.
    pub jitter: Real,
    /// Jitter seed.
    pub seed: u64,
    /// End time (s).
    pub t_end: Real,
    /// Time step of the chosen scheme (s).
    pub dt: Real,
    /// Time scheme for the total error.
    pub scheme: Scheme,
    /// MLS operator parameters (h, order, …).
    pub mls: MlsParams,
    /// How to estimate the rightmost eigenvalue.
    pub eigen: EigenMethod,
    /// Linear solver of the implicit schemes.
    pub solver: LinearSolver,
}

impl Default for SphereDiffusion {
    /// The default case: ~30k particles, h = 0.1, t = 0.5, default operator.
    fn default() -> Self {
        SphereDiffusion {
            particles: 30_000,
            jitter: 0.0,
            seed: 1,
            t_end: 0.5,
            dt: 1e-3,
            scheme: Scheme::Exact,
            mls: MlsParams::new(0.1),
            eigen: EigenMethod::ShiftInvert,
            solver: LinearSolver::Bicgstab,
        }
    }
}

/// Figures of one run.
#[derive(Clone, Debug, Serialize)]
pub struct SphereDiffusionReport {
    /// Actual particle count.
    pub particles: usize,
    /// Sampling spacing Δ (m).
    pub spacing: Real,
    /// Support radius h (m).
    pub h: Real,
    /// Fit order.
    pub order: usize,
    /// Mean neighbour count.
    pub mean_neighbors: Real,
    /// Scheme used for the total error.
    pub scheme: Scheme,
    /// Its time step (s); 0 for the exact exponential.
    pub dt: Real,
    /// max |exp(tL)s₀ − s(t)|: the spatial error.
    pub spatial_max_error: Real,
    /// mean |exp(tL)s₀ − s(t)|.
    pub spatial_l1_error: Real,
    /// max |s_scheme − s(t)|: spatial plus time error.
    pub total_max_error: Real,
    /// mean |s_scheme − s(t)|.
    pub l1_error: Real,
    /// max |s_scheme − exp(tL)s₀|: the time error of the scheme.
    pub time_max_error: Real,
    /// Re of the rightmost eigenvalue estimate of L (NaN-free; null if not computed).
    pub rightmost_eigenvalue: Option<Real>,
    /// Im of that eigenvalue.
    pub rightmost_eigenvalue_im: Option<Real>,
    /// Largest |Ritz value| of L (Ritz method only): ≈ spectral radius ρ;
    /// forward Euler is stable only for Δt < 2/ρ.
    pub spectral_radius: Option<Real>,
    /// Matrix–vector products of the accurate exponential.
    pub krylov_matvecs: usize,
    /// Largest |row sum| / max |entry| of L.
    pub max_relative_row_sum: Real,
    /// Fit fallbacks.
    pub fit_stats: FitStats,
    /// Seconds to build neighbours + L.
    pub seconds_operator: Real,
    /// Seconds end to end (sampling to errors).
    pub seconds: Real,
}

impl SphereDiffusion {
    /// Runs the case.
    pub fn run(&self) -> Result<SphereDiffusionReport, ValidateError> {
        let start = Instant::now();
        if self.particles < 20 {
            return Err(ValidateError::Param {
                what: "particles",
                value: self.particles as Real,
                reason: "need at least 20",
            });
        }
        if !(0.0..=0.5).contains(&self.jitter) {
            return Err(ValidateError::Param {
                what: "jitter",
                value: self.jitter,
                reason: "must lie in [0, 0.5]",
            });
        }
        self.mls.validate()?;
        let spacing = sphere_spacing_for(self.particles, 1.0);
        let x = sphere_latitude(1.0, spacing, self.jitter, self.seed);
        let nb = Neighborhoods::sheet(&x, self.mls.h)?;
        let l = JointLaplacian::assemble(&nb, &self.mls)?;
        let seconds_operator = start.elapsed().as_secs_f64();
        let t = self.t_end;
        let s0: Vec<Real> = nb.x.iter().map(|p| p.z).collect();
        let decay = (-2.0 * t).exp();
        let exact: Vec<Real> = s0.iter().map(|z| decay * z).collect();
        let (accurate, krylov_matvecs) = krylov_exp_poly(&l, &s0, t, 1e-10, 30)?;
        let (scheme_sol, dt) = match self.scheme {
            Scheme::Exact => (accurate.clone(), 0.0),
            Scheme::ForwardEuler => (forward_euler(&l, &s0, t, self.dt)?, self.dt),
            Scheme::BackwardEuler => (backward_euler(&l, &s0, t, self.dt, self.solver)?, self.dt),
            Scheme::CrankNicolson => (crank_nicolson(&l, &s0, t, self.dt, self.solver)?, self.dt),
        };
        let n = s0.len() as Real;
        // a blown-up (non-finite) solution reports infinite errors, never NaN
        let err = |a: &[Real], b: &[Real]| -> (Real, Real) {
            if a.iter().chain(b).any(|v| !v.is_finite()) {
                return (Real::INFINITY, Real::INFINITY);
            }
            let m = max_abs(a.iter().zip(b).map(|(x, y)| x - y));
            let l1 = a.iter().zip(b).map(|(x, y)| (x - y).abs()).sum::<Real>() / n;
            (m, l1)
        };
        let (spatial_max_error, spatial_l1_error) = err(&accurate, &exact);
        let (total_max_error, l1_error) = err(&scheme_sol, &exact);
        let (time_max_error, _) = err(&scheme_sol, &accurate);
        let mut spectral_radius = None;
        let (re, im) = match self.eigen {
            EigenMethod::None => (None, None),
            EigenMethod::Ritz => {
                let (re, im, _, rho) = rightmost_ritz(&l, 120, 7, 1e-6);
                spectral_radius = Some(rho);
                (Some(re), Some(im))
            }
            EigenMethod::ShiftInvert => {
                let sv = ShiftedSolver::with_tol(&l, 0.002, self.solver, 1e-8)?;
                let (re, im) = rightmost_shift_invert(l.n(), 0.002, 45, 7, |w| sv.solve(w))?;
                (Some(re), Some(im))
            }
        };
        Ok(SphereDiffusionReport {
            particles: x.len(),
            spacing,
            h: self.mls.h,
            order: self.mls.order,
            mean_neighbors: nb.lists.mean_count(),
            scheme: self.scheme,
            dt,
            spatial_max_error,
            spatial_l1_error,
            total_max_error,
            l1_error,
            time_max_error,
            rightmost_eigenvalue: re,
            rightmost_eigenvalue_im: im,
            spectral_radius,
            krylov_matvecs,
            max_relative_row_sum: l.max_relative_row_sum(),
            fit_stats: l.stats,
            seconds_operator,
            seconds: start.elapsed().as_secs_f64(),
        })
    }
}

/// A convergence study: the case at several particle counts with h scaled
/// with the spacing (fixed neighbour count), and the observed orders.
#[derive(Clone, Debug, Serialize)]
pub struct Convergence {
    /// One report per resolution, coarse to fine.
    pub runs: Vec<SphereDiffusionReport>,
    /// Observed order of the spatial max error between consecutive runs (in Δ).
    pub observed_order_max: Vec<Real>,
    /// Observed order of the spatial L1 error.
    pub observed_order_l1: Vec<Real>,
}

/// Runs `base` at each particle count in `counts`, with h = `h_over_spacing` · Δ.
pub fn convergence(
    base: &SphereDiffusion,
    counts: &[usize],
    h_over_spacing: Real,
) -> Result<Convergence, ValidateError> {
    let mut runs = Vec::new();
    for &n in counts {
        let mut c = base.clone();
        c.particles = n;
        c.mls.h = h_over_spacing * sphere_spacing_for(n, 1.0);
        runs.push(c.run()?);
    }
    let sp: Vec<Real> = runs.iter().map(|r| r.spacing).collect();
    let emax: Vec<Real> = runs.iter().map(|r| r.spatial_max_error).collect();
    let el1: Vec<Real> = runs.iter().map(|r| r.spatial_l1_error).collect();
    Ok(Convergence {
        observed_order_max: observed_orders(&sp, &emax),
        observed_order_l1: observed_orders(&sp, &el1),
        runs,
    })
}
