//! Time integrators for ds/dt = L s and a rightmost-eigenvalue estimate.
//!
//! * forward Euler (the paper's §10.1 scheme): s ← s + Δt L s;
//! * backward Euler: (I − Δt L) s⁺ = s;
//! * Crank–Nicolson: (I − Δt/2 L) s⁺ = (I + Δt/2 L) s;
//!
//!   both with either one sparse LU reused every step or BiCGSTAB + ILU(0)
//!   ([`crate::linsolve`]), see [`LinearSolver`];
//! * "exact": s(t) = exp(tL) s₀ by shift-and-invert (rational) Krylov:
//!   Arnoldi on A = (I − γL)⁻¹ gives A V_m ≈ V_m H_m, hence
//!   L ≈ V_m (I − H_m⁻¹)/γ V_mᵀ and exp(tL) s₀ ≈ ‖s₀‖ V_m exp(t(I − H_m⁻¹)/γ) e₁,
//!   iterated until two successive approximations agree to `tol`. Its time
//!   error is far below any spatial error, so it separates the two.
//!
//! * "exact" without factorisation: exp(tL) s₀ by polynomial Krylov
//!   (Arnoldi on L, [`krylov_exp_poly`]) in sub-steps, each accepted when two
//!   Krylov dimensions agree to `tol`; cheap because a sparse LU of the
//!   30k-particle MLS matrix costs ~9 s while a matvec costs ~1 ms.
//!
//! Rightmost eigenvalue, two estimates: [`rightmost_ritz`] runs Arnoldi on
//! L itself and keeps the Ritz values whose residual ‖L y − θ y‖ is small
//! (no factorisation; an isolated unstable mode converges fast);
//! [`rightmost_eigenvalue`] runs Arnoldi on the backward-Euler propagator
//! (I − τL)⁻¹ from a random start; its dominant eigenvalues μ are those of
//! L with the largest real part near the axis, λ = (1 − 1/μ)/τ. An unstable
//! mode (Re λ > 0) gives |μ| > 1 and dominates quickly.

use crate::math::Real;
use crate::mls::JointLaplacian;
use faer::linalg::solvers::Solve;
use faer::sparse::linalg::solvers::Lu;
use faer::sparse::{SparseColMat, Triplet};
use faer::MatMut;
use nalgebra::DMatrix;
use rayon::prelude::*;
use thiserror::Error;

/// Errors of the validation integrators.
#[derive(Debug, Error)]
pub enum TimeError {
    /// The sparse LU factorisation failed.
    #[error("sparse LU of I − {gamma}·L failed: {reason}")]
    Lu {
        /// Shift γ (s).
        gamma: Real,
        /// faer's reason.
        reason: String,
    },
    /// A step size or end time is not positive and finite.
    #[error("time parameter `{what}` = {value} must be positive and finite")]
    BadTime {
        /// Which parameter.
        what: &'static str,
        /// Its value.
        value: Real,
    },
    /// An iterative solve failed.
    #[error(transparent)]
    Linsolve(#[from] crate::linsolve::SolveError),
    /// The Krylov exponential did not reach its tolerance.
    #[error("Krylov exponential: no convergence after {iters} vectors (change {change:e})")]
    NoConvergence {
        /// Krylov dimension reached.
        iters: usize,
        /// Last relative change.
        change: Real,
    },
}

/// A sparse LU of I − γL, reused for every solve.
pub struct ShiftedLu {
    lu: Lu<usize, Real>,
    /// The shift γ (s).
    pub gamma: Real,
}

impl ShiftedLu {
    /// Factorises I − γL.
    pub fn new(l: &JointLaplacian, gamma: Real) -> Result<ShiftedLu, TimeError> {
        let n = l.n();
        let rp = l.matrix.symbolic().row_ptr();
        let ci = l.matrix.symbolic().col_idx();
        let v = l.matrix.val();
        let mut t = Vec::with_capacity(v.len() + n);
        for i in 0..n {
            let mut diag = false;
            for k in rp[i]..rp[i + 1] {
                let d = if ci[k] == i { 1.0 } else { 0.0 };
                diag |= ci[k] == i;
                t.push(Triplet::new(i, ci[k], d - gamma * v[k]));
            }
            if !diag {
                t.push(Triplet::new(i, i, 1.0));
            }
        }
        let err = |e: String| TimeError::Lu { gamma, reason: e };
        let a = SparseColMat::<usize, Real>::try_new_from_triplets(n, n, &t)
            .map_err(|e| err(format!("{e:?}")))?;
        let lu = a.sp_lu().map_err(|e| err(format!("{e:?}")))?;
        Ok(ShiftedLu { lu, gamma })
    }

    /// Solves (I − γL) x = b in place.
    pub fn solve(&self, b: &mut [Real]) {
        let n = b.len();
        self.lu
            .solve_in_place(MatMut::from_column_major_slice_mut(b, n, 1));
    }
}

/// How the implicit schemes solve (I − γL) x = b.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum LinearSolver {
    /// faer sparse LU, factorised once (slow to factorise for MLS stencils).
    SparseLu,
    /// BiCGSTAB with a Jacobi preconditioner, tolerance 1e-12, warm-started
    /// from the right-hand side (ILU(0) measured slower: its sequential
    /// sweeps cost more than the iterations they save at these Δt).
    Bicgstab,
}

/// A reusable solver for (I − γL) x = b.
pub enum ShiftedSolver {
    /// Direct.
    Lu(Box<ShiftedLu>),
    /// Iterative: the matrix I − γL and its Jacobi preconditioner.
    Iterative {
        /// I − γL in CSR.
        a: faer::sparse::SparseRowMat<usize, Real>,
        /// Its Jacobi preconditioner.
        pre: crate::linsolve::Jacobi,
        /// Total BiCGSTAB iterations so far.
        iterations: std::cell::Cell<usize>,
        /// Relative residual tolerance.
        tol: Real,
    },
}

impl ShiftedSolver {
    /// Prepares the solver for shift γ (iterative tolerance 1e-12).
    pub fn new(
        l: &JointLaplacian,
        gamma: Real,
        kind: LinearSolver,
    ) -> Result<ShiftedSolver, TimeError> {
        ShiftedSolver::with_tol(l, gamma, kind, 1e-12)
    }

    /// Prepares the solver for shift γ with relative residual tolerance `tol`
    /// for the iterative solver.
    pub fn with_tol(
        l: &JointLaplacian,
        gamma: Real,
        kind: LinearSolver,
        tol: Real,
    ) -> Result<ShiftedSolver, TimeError> {
        Ok(match kind {
            LinearSolver::SparseLu => ShiftedSolver::Lu(Box::new(ShiftedLu::new(l, gamma)?)),
            LinearSolver::Bicgstab => {
                let a = crate::linsolve::identity_plus(&l.matrix, 1.0, -gamma);
                let pre =
                    crate::linsolve::Jacobi::new(&crate::linsolve::Csr::from_faer(a.as_ref())?)?;
                ShiftedSolver::Iterative {
                    a,
                    pre,
                    iterations: std::cell::Cell::new(0),
                    tol,
                }
            }
        })
    }

    /// Solves (I − γL) x = b in place.
    pub fn solve(&self, b: &mut [Real]) -> Result<(), TimeError> {
        match self {
            ShiftedSolver::Lu(lu) => lu.solve(b),
            ShiftedSolver::Iterative {
                a,
                pre,
                iterations,
                tol,
            } => {
                let rhs = b.to_vec();
                let p = crate::linsolve::BicgstabParams {
                    tol: *tol,
                    max_iter: 1000,
                };
                let csr = crate::linsolve::Csr::from_faer(a.as_ref())?;
                let info = crate::linsolve::bicgstab(&csr, &rhs, b, pre, &p)?;
                iterations.set(iterations.get() + info.iterations);
            }
        }
        Ok(())
    }

    /// Total iterations of the iterative solver (0 for the LU).
    pub fn iterations(&self) -> usize {
        match self {
            ShiftedSolver::Lu(_) => 0,
            ShiftedSolver::Iterative { iterations, .. } => iterations.get(),
        }
    }
}

fn check(what: &'static str, value: Real) -> Result<(), TimeError> {
    if value > 0.0 && value.is_finite() {
        Ok(())
    } else {
        Err(TimeError::BadTime { what, value })
    }
}

fn steps(t: Real, dt: Real) -> usize {
    ((t / dt).round() as usize).max(1)
}

/// Forward Euler to time `t` with step ≈ `dt` (the step is adjusted so an
/// integer number of steps reaches `t`).
pub fn forward_euler(
    l: &JointLaplacian,
    s0: &[Real],
    t: Real,
    dt: Real,
) -> Result<Vec<Real>, TimeError> {
    check("t", t)?;
    check("dt", dt)?;
    let n = steps(t, dt);
    let dt = t / n as Real;
    let mut s = s0.to_vec();
    let mut ls = vec![0.0; s.len()];
    for _ in 0..n {
        l.apply(&s, &mut ls);
        s.iter_mut().zip(&ls).for_each(|(a, b)| *a += dt * b);
    }
    Ok(s)
}

/// Backward Euler to time `t` with step ≈ `dt`.
pub fn backward_euler(
    l: &JointLaplacian,
    s0: &[Real],
    t: Real,
    dt: Real,
    kind: LinearSolver,
) -> Result<Vec<Real>, TimeError> {
    check("t", t)?;
    check("dt", dt)?;
    let n = steps(t, dt);
    let solver = ShiftedSolver::new(l, t / n as Real, kind)?;
    let mut s = s0.to_vec();
    for _ in 0..n {
        solver.solve(&mut s)?;
    }
    Ok(s)
}

/// Crank–Nicolson to time `t` with step ≈ `dt`.
pub fn crank_nicolson(
    l: &JointLaplacian,
    s0: &[Real],
    t: Real,
    dt: Real,
    kind: LinearSolver,
) -> Result<Vec<Real>, TimeError> {
    check("t", t)?;
    check("dt", dt)?;
    let n = steps(t, dt);
    let dt = t / n as Real;
    let solver = ShiftedSolver::new(l, 0.5 * dt, kind)?;
    let mut s = s0.to_vec();
    let mut ls = vec![0.0; s.len()];
    for _ in 0..n {
        l.apply(&s, &mut ls);
        s.iter_mut().zip(&ls).for_each(|(a, b)| *a += 0.5 * dt * b);
        solver.solve(&mut s)?;
    }
    Ok(s)
}

fn dot(a: &[Real], b: &[Real]) -> Real {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Arnoldi with re-orthogonalised modified Gram–Schmidt on v ↦ A v given by
/// `apply` (in place). Returns the basis and the (m+1) × m Hessenberg matrix;
/// stops early on breakdown.
fn arnoldi(
    v0: &[Real],
    m: usize,
    mut apply: impl FnMut(&mut [Real]),
) -> (Vec<Vec<Real>>, DMatrix<Real>) {
    let beta = dot(v0, v0).sqrt();
    let mut v = vec![v0.iter().map(|x| x / beta).collect::<Vec<_>>()];
    let mut h = DMatrix::zeros(m + 1, m);
    for j in 0..m {
        let mut w = v[j].clone();
        apply(&mut w);
        // classical Gram–Schmidt, twice (CGS2): the projections are independent
        // dot products (parallel over basis vectors), the update a fixed-order
        // sum per entry (parallel over entries) — deterministic
        for _pass in 0..2 {
            let c: Vec<Real> = v.par_iter().map(|vi| dot(&w, vi)).collect();
            for (i, ci) in c.iter().enumerate() {
                h[(i, j)] += ci;
            }
            w.par_chunks_mut(2048).enumerate().for_each(|(b, chunk)| {
                let off = b * 2048;
                let len = chunk.len();
                for (i, vi) in v.iter().enumerate() {
                    let ci = c[i];
                    for (a, x) in chunk.iter_mut().zip(&vi[off..off + len]) {
                        *a -= ci * x;
                    }
                }
            });
        }
        let nw = dot(&w, &w).sqrt();
        h[(j + 1, j)] = nw;
        if nw < 1e-14 {
            return (v, h.view((0, 0), (j + 2, j + 1)).into_owned());
        }
        v.push(w.into_iter().map(|x| x / nw).collect());
    }
    (v, h)
}

/// exp(tL) s₀ by shift-and-invert Krylov with shift γ (module docs).
/// Returns the result and the Krylov dimension used.
pub fn krylov_exp(
    lu: &ShiftedLu,
    s0: &[Real],
    t: Real,
    tol: Real,
    max_dim: usize,
) -> Result<(Vec<Real>, usize), TimeError> {
    check("t", t)?;
    let beta = dot(s0, s0).sqrt();
    if beta == 0.0 {
        return Ok((s0.to_vec(), 0));
    }
    let (v, h) = arnoldi(s0, max_dim, |w| lu.solve(w));
    let mmax = h.ncols();
    let coeffs = |m: usize| -> Option<nalgebra::DVector<Real>> {
        let hm = h.view((0, 0), (m, m)).into_owned();
        let inv = hm.try_inverse()?;
        let a = (DMatrix::identity(m, m) - inv) * (t / lu.gamma);
        let e = a.exp();
        let c = e.column(0).into_owned() * beta;
        c.iter().all(|x| x.is_finite()).then_some(c)
    };
    let mut prev: Option<nalgebra::DVector<Real>> = None;
    let mut change = Real::INFINITY;
    let mut m = 4.min(mmax);
    loop {
        if let Some(c) = coeffs(m) {
            if let Some(p) = &prev {
                let mut d = c.clone();
                for i in 0..p.len() {
                    d[i] -= p[i];
                }
                change = d.norm() / c.norm().max(1e-300);
                if change < tol || m == mmax {
                    let n = s0.len();
                    let mut s = vec![0.0; n];
                    for (k, ck) in c.iter().enumerate() {
                        s.iter_mut().zip(&v[k]).for_each(|(a, b)| *a += ck * b);
                    }
                    if change < tol || mmax < max_dim {
                        return Ok((s, m));
                    }
                    return Err(TimeError::NoConvergence { iters: m, change });
                }
            }
            prev = Some(c);
        }
        if m == mmax {
            return Err(TimeError::NoConvergence { iters: m, change });
        }
        m = (m + 4).min(mmax);
    }
}

/// Estimate of the rightmost eigenvalue (re, im) of L: `m` Arnoldi steps on
/// (I − τL)⁻¹ (applied by the LU) from a deterministic random start; the
/// Ritz value with the largest real part of λ = (1 − 1/μ)/τ among the
/// dominant half by |μ|.
pub fn rightmost_eigenvalue(lu: &ShiftedLu, n: usize, m: usize, seed: u64) -> (Real, Real) {
    rightmost_shift_invert(n, lu.gamma, m, seed, |w| {
        lu.solve(w);
        Ok(())
    })
    .expect("a direct solve cannot fail")
}

/// As [`rightmost_eigenvalue`] with any solver of (I − τL) x = b
/// (e.g. [`ShiftedSolver`] with BiCGSTAB).
pub fn rightmost_shift_invert(
    n: usize,
    tau: Real,
    m: usize,
    seed: u64,
    mut solve: impl FnMut(&mut [Real]) -> Result<(), TimeError>,
) -> Result<(Real, Real), TimeError> {
    let mut s = seed;
    let v0: Vec<Real> = (0..n)
        .map(|_| super::sampling::rand01(&mut s) - 0.5)
        .collect();
    let mut err = None;
    let (_, h) = arnoldi(&v0, m, |w| {
        if err.is_none() {
            if let Err(e) = solve(w) {
                err = Some(e);
            }
        }
    });
    if let Some(e) = err {
        return Err(e);
    }
    let k = h.ncols();
    let hm = h.view((0, 0), (k, k)).into_owned();
    let mut mus: Vec<nalgebra::Complex<Real>> = hm.complex_eigenvalues().iter().copied().collect();
    mus.sort_by(|a, b| b.norm().total_cmp(&a.norm()));
    let keep = (mus.len() / 2).max(1);
    Ok(mus
        .iter()
        .take(keep)
        .filter(|mu| mu.norm() > 1e-12)
        .map(|mu| {
            let lam = (nalgebra::Complex::new(1.0, 0.0) - mu.inv()) / tau;
            (lam.re, lam.im)
        })
        .fold(
            (Real::NEG_INFINITY, 0.0),
            |a, b| if b.0 > a.0 { b } else { a },
        ))
}

/// exp(tL) s₀ by polynomial Krylov with sub-steps (module docs). Returns the
/// result and the total number of matrix–vector products.
pub fn krylov_exp_poly(
    l: &JointLaplacian,
    s0: &[Real],
    t: Real,
    tol: Real,
    m_max: usize,
) -> Result<(Vec<Real>, usize), TimeError> {
    check("t", t)?;
    let mut s = s0.to_vec();
    let mut done = 0.0;
    let mut tau = t;
    let mut matvecs = 0;
    let mut ls = vec![0.0; s.len()];
    let mut halvings = 0;
    while done < t * (1.0 - 1e-14) {
        tau = tau.min(t - done);
        let beta = dot(&s, &s).sqrt();
        if beta == 0.0 {
            break;
        }
        let (v, h) = arnoldi(&s, m_max, |w| {
            l.apply(w, &mut ls);
            w.copy_from_slice(&ls);
        });
        matvecs += h.ncols();
        let mmax = h.ncols();
        let approx = |m: usize| -> nalgebra::DVector<Real> {
            let hm = h.view((0, 0), (m, m)).into_owned() * tau;
            hm.exp().column(0).into_owned() * beta
        };
        let breakdown = mmax < m_max;
        let full = approx(mmax);
        let coarse = approx((mmax * 3 / 4).max(1));
        let mut d = full.clone();
        for i in 0..coarse.len() {
            d[i] -= coarse[i];
        }
        let change = d.norm() / full.norm().max(1e-300);
        if (change < tol || breakdown) && full.iter().all(|x| x.is_finite()) {
            s.iter_mut().for_each(|x| *x = 0.0);
            for (k, ck) in full.iter().enumerate() {
                s.iter_mut().zip(&v[k]).for_each(|(a, b)| *a += ck * b);
            }
            done += tau;
            tau *= 1.5;
        } else {
            halvings += 1;
            if halvings > 60 {
                return Err(TimeError::NoConvergence {
                    iters: matvecs,
                    change,
                });
            }
            tau *= 0.5;
        }
    }
    Ok((s, matvecs))
}

/// Rightmost converged Ritz value of L: `m` Arnoldi steps on L from a
/// deterministic random start; a Ritz pair (θ, y) counts as converged when
/// its residual |h_{m+1,m} y_m| / ‖y‖ ≤ `rel_tol` · max |θ|. Returns
/// (re, im, residual) of the one with the largest real part (of all Ritz
/// values when none converged), and the
/// largest |θ| (a lower estimate of the spectral radius ρ, which bounds the
/// forward-Euler step: Δt < 2/ρ for a real negative spectrum).
pub fn rightmost_ritz(
    l: &JointLaplacian,
    m: usize,
    seed: u64,
    rel_tol: Real,
) -> (Real, Real, Real, Real) {
    use nalgebra::Complex;
    let n = l.n();
    let mut st = seed;
    let v0: Vec<Real> = (0..n)
        .map(|_| super::sampling::rand01(&mut st) - 0.5)
        .collect();
    let mut ls = vec![0.0; n];
    let (_, h) = arnoldi(&v0, m, |w| {
        l.apply(w, &mut ls);
        w.copy_from_slice(&ls);
    });
    let k = h.ncols();
    let hk = h.view((0, 0), (k, k)).into_owned();
    let beta = if h.nrows() > k { h[(k, k - 1)] } else { 0.0 };
    let thetas: Vec<Complex<Real>> = hk.clone().complex_eigenvalues().iter().copied().collect();
    let scale = thetas
        .iter()
        .fold(0.0 as Real, |a, t| a.max(t.norm()))
        .max(1e-300);
    let hc: DMatrix<Complex<Real>> = hk.map(|x| Complex::new(x, 0.0));
    let mut best = (Real::NEG_INFINITY, 0.0, Real::INFINITY);
    // fallback when no Ritz pair converged: the rightmost Ritz value of all
    // (Ritz values lie in the field of values, so this errs towards "unstable")
    let mut any = (Real::NEG_INFINITY, 0.0, Real::INFINITY);
    for th in &thetas {
        // inverse iteration on the small matrix for the Ritz vector
        let shift = *th + Complex::new(1e-10 * scale, 0.0);
        let a = &hc - DMatrix::<Complex<Real>>::identity(k, k) * shift;
        let lu = a.lu();
        let mut y = nalgebra::DVector::<Complex<Real>>::from_fn(k, |i, _| {
            Complex::new(1.0 + 0.1 * i as Real, 0.0)
        });
        for _ in 0..3 {
            match lu.solve(&y) {
                Some(z) => {
                    let nz = z.norm();
                    if !(nz > 0.0 && nz.is_finite()) {
                        break;
                    }
                    y = z / Complex::new(nz, 0.0);
                }
                None => break,
            }
        }
        let res = beta * y[k - 1].norm() / y.norm().max(1e-300);
        if res <= rel_tol * scale && th.re > best.0 {
            best = (th.re, th.im, res);
        }
        if th.re > any.0 {
            any = (th.re, th.im, res);
        }
    }
    if !best.0.is_finite() {
        best = any;
    }
    (best.0, best.1, best.2, scale)
}
