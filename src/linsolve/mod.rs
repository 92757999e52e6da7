//! Sparse iterative solvers for the non-symmetric systems of the method:
//! implicit MLS diffusion/viscosity (eq. 13), semi-implicit surface tension
//! (eq. 16/17) and the monolithic coupled system (eq. 24), which the paper
//! solves with BiCGSTAB (van der Vorst 1992) and an incomplete-LU
//! preconditioner at tolerance 1e-9.
//!
//! faer supplies the sparse matrix type (`SparseRowMat<usize, f64>`) but no
//! incomplete factorisation, so ILU(0) is written here ([`ilu0`]); the
//! Krylov loops are [`bicgstab()`] and, for the coupled system, [`gmres()`]. Matrix–vector products are parallel over
//! rows; dot products are summed over fixed-size chunks in a fixed order, so
//! results are bit-identical for any thread count.

pub mod bicgstab;
pub mod csr;
mod fill;
pub mod gmres;
pub mod ilu0;
pub mod order;
pub mod tripled;
pub mod tripled_ilu;

pub use bicgstab::{bicgstab, BicgstabParams};
pub use csr::Csr;
pub use gmres::{gmres, GmresParams};
pub use ilu0::{Identity, Ilu0, Jacobi, Preconditioner};
pub use order::{reverse_cuthill_mckee, split_halves};
pub use tripled::Tripled;
pub use tripled_ilu::TripledIlu;

/// A square or rectangular linear map that BiCGSTAB can apply.
pub trait Operator: Sync {
    /// (rows, columns).
    fn dims(&self) -> (usize, usize);
    /// y = A x.
    fn matvec(&self, x: &[f64], y: &mut [f64]);
    /// True when every stored value is finite.
    fn all_finite(&self) -> bool;
}

/// What a solve reached.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SolveInfo {
    /// Iterations performed.
    pub iterations: usize,
    /// Final relative residual ‖b − Ax‖ / ‖b‖ (recomputed, not the recursive estimate).
    pub rel_residual: f64,
}

/// Why a solve failed. Each variant carries the numbers needed to report it.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SolveError {
    /// The tolerance was not reached in the iteration budget.
    #[error("linear solver did not converge: relative residual {rel_residual:.3e} after {iterations} iterations (tolerance {tol:.1e})")]
    NoConvergence {
        /// Iterations performed.
        iterations: usize,
        /// Relative residual reached.
        rel_residual: f64,
        /// Requested tolerance.
        tol: f64,
    },
    /// The residual stopped falling: less than halved over the last
    /// `window` iterations (GMRES, whose residual never grows).
    #[error("linear solver stagnated: relative residual {rel_residual:.3e} after {iterations} iterations, less than halved over the last {window} (tolerance {tol:.1e})")]
    Stagnation {
        /// Iterations performed.
        iterations: usize,
        /// Relative residual reached.
        rel_residual: f64,
        /// The window.
        window: usize,
        /// Requested tolerance.
        tol: f64,
    },
    /// A BiCGSTAB scalar vanished (ρ or ω); the method cannot continue.
    #[error("BiCGSTAB breakdown at iteration {iteration}: {what} = {value:.3e}")]
    Breakdown {
        /// Iteration at which it happened.
        iteration: usize,
        /// Which scalar vanished.
        what: &'static str,
        /// Its value.
        value: f64,
    },
    /// A non-finite value appeared in the matrix, right-hand side or iterate.
    #[error("non-finite value in the linear system ({0})")]
    NonFinite(&'static str),
    /// ILU(0) met a zero (or missing) pivot.
    #[error("ILU(0) zero pivot in row {row}")]
    ZeroPivot {
        /// Row of the pivot.
        row: usize,
    },
    /// The matrix is not square or does not match the vectors.
    #[error("dimension mismatch: {0}")]
    Dimension(String),
}

/// The checks both Krylov solvers start with: A square and matching b and
/// x, A and b finite (`Err` otherwise); a non-finite start is replaced by 0.
/// Returns ‖b‖, or `None` when b = 0 (then x = 0 is the solution, written).
fn prepare(a: &dyn Operator, b: &[f64], x: &mut [f64]) -> Result<Option<f64>, SolveError> {
    let (n, ncols) = a.dims();
    if ncols != n || b.len() != n || x.len() != n {
        return Err(SolveError::Dimension(format!(
            "A {}×{}, b {}, x {}",
            n,
            ncols,
            b.len(),
            x.len()
        )));
    }
    if !a.all_finite() {
        return Err(SolveError::NonFinite("matrix"));
    }
    if !b.iter().all(|v| v.is_finite()) {
        return Err(SolveError::NonFinite("right-hand side"));
    }
    if !x.iter().all(|v| v.is_finite()) {
        x.iter_mut().for_each(|v| *v = 0.0);
    }
    let bn = norm(b);
    if bn == 0.0 {
        x.iter_mut().for_each(|v| *v = 0.0);
        return Ok(None);
    }
    Ok(Some(bn))
}

/// Chunk length of the deterministic reductions.
const CHUNK: usize = 4096;

/// Deterministic parallel dot product: fixed chunks, summed in order.
pub fn dot(a: &[f64], b: &[f64]) -> f64 {
    use rayon::prelude::*;
    debug_assert_eq!(a.len(), b.len());
    let partial: Vec<f64> = a
        .par_chunks(CHUNK)
        .zip(b.par_chunks(CHUNK))
        .map(|(x, y)| x.iter().zip(y).map(|(p, q)| p * q).sum::<f64>())
        .collect();
    partial.iter().sum()
}

/// Euclidean norm with [`dot`].
pub fn norm(a: &[f64]) -> f64 {
    dot(a, a).sqrt()
}

/// The CSR matrix α I + β A (A square, columns sorted per row); the
/// diagonal is inserted where A does not store it.
pub fn identity_plus(
    a: &faer::sparse::SparseRowMat<usize, f64>,
    alpha: f64,
    beta: f64,
) -> faer::sparse::SparseRowMat<usize, f64> {
    diag_plus_scaled_rows(a.as_ref(), |_| alpha, |_| beta)
}

/// The CSR matrix whose row i is α_i e_iᵀ + β_i (row i of A) (A square,
/// columns sorted per row); the diagonal is inserted where A does not
/// store it.
pub fn diag_plus_scaled_rows(
    a: faer::sparse::SparseRowMatRef<'_, usize, f64>,
    alpha: impl Fn(usize) -> f64,
    beta: impl Fn(usize) -> f64,
) -> faer::sparse::SparseRowMat<usize, f64> {
    let n = a.nrows();
    let rp = a.symbolic().row_ptr();
    let ci = a.symbolic().col_idx();
    let v = a.val();
    let mut row_ptr = Vec::with_capacity(n + 1);
    let mut col = Vec::with_capacity(v.len() + n);
    let mut val = Vec::with_capacity(v.len() + n);
    row_ptr.push(0);
    for i in 0..n {
        let (alpha, beta) = (alpha(i), beta(i));
        let mut diag_done = false;
        for k in rp[i]..rp[i + 1] {
            if !diag_done && ci[k] > i {
                col.push(i);
                val.push(alpha);
                diag_done = true;
            }
            if ci[k] == i {
                col.push(i);
                val.push(alpha + beta * v[k]);
                diag_done = true;
            } else {
                col.push(ci[k]);
                val.push(beta * v[k]);
            }
        }
        if !diag_done {
            col.push(i);
            val.push(alpha);
        }
        row_ptr.push(col.len());
    }
    let sym = faer::sparse::SymbolicSparseRowMat::new_checked(n, n, row_ptr, None, col);
    faer::sparse::SparseRowMat::new(sym, val)
}
