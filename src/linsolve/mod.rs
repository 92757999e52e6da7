//! Iterative solvers for the non-symmetric sparse systems of the MLS
//! operators: BiCGSTAB (van der Vorst 1992) with a Jacobi or ILU(0)
//! preconditioner, on faer CSR matrices.
//!
//! The MLS Laplacian is not symmetric (paper §11), so the implicit systems
//! (I − Δt L) x = b (diffusion, viscosity eq. 12) and M − σΔt² S L (surface
//! tension, eqs. 16/24) need a non-symmetric Krylov method; the paper uses
//! BiCGSTAB. Shaped like faer's solvers: parameters in, [`SolveInfo`] out,
//! a typed error carrying the iterations and the residual reached.
//! Deterministic: every reduction is summed in a fixed order.

pub mod bicgstab;
pub mod ilu0;

pub use bicgstab::{bicgstab, BicgstabParams};
pub use ilu0::Ilu0;

use crate::math::Real;
use faer::sparse::SparseRowMat;
use rayon::prelude::*;
use thiserror::Error;

/// What an iterative solve did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SolveInfo {
    /// Iterations taken.
    pub iterations: usize,
    /// Final ‖b − A x‖ / ‖b‖.
    pub rel_residual: Real,
}

/// Errors of the iterative solvers.
#[derive(Debug, Error, PartialEq)]
pub enum LinsolveError {
    /// The tolerance was not reached.
    #[error("BiCGSTAB did not converge: {iters} iterations, relative residual {rel_residual:e}")]
    NoConvergence {
        /// Iterations taken.
        iters: usize,
        /// Relative residual reached.
        rel_residual: Real,
    },
    /// A breakdown (ρ or ω zero) before convergence.
    #[error("BiCGSTAB breakdown after {iters} iterations (relative residual {rel_residual:e})")]
    Breakdown {
        /// Iterations taken.
        iters: usize,
        /// Relative residual reached.
        rel_residual: Real,
    },
    /// ILU(0) met a zero or non-finite pivot.
    #[error("ILU(0): pivot {value:e} in row {row}")]
    Pivot {
        /// Row of the pivot.
        row: usize,
        /// Its value.
        value: Real,
    },
    /// Sizes do not match.
    #[error("linear system size mismatch: matrix {n}, vector {got}")]
    Size {
        /// Matrix dimension.
        n: usize,
        /// Vector length.
        got: usize,
    },
}

/// A preconditioner z = P⁻¹ r.
pub trait Preconditioner: Sync {
    /// Applies P⁻¹ to `r`, writing `z`.
    fn apply(&self, r: &[Real], z: &mut [Real]);
}

/// Jacobi (diagonal) preconditioner; a zero diagonal entry acts as 1.
pub struct Jacobi {
    inv_diag: Vec<Real>,
}

impl Jacobi {
    /// From the diagonal of a CSR matrix.
    pub fn new(a: &SparseRowMat<usize, Real>) -> Jacobi {
        let inv_diag = diagonal(a)
            .into_iter()
            .map(|d| {
                if d != 0.0 && d.is_finite() {
                    1.0 / d
                } else {
                    1.0
                }
            })
            .collect();
        Jacobi { inv_diag }
    }
}

impl Preconditioner for Jacobi {
    fn apply(&self, r: &[Real], z: &mut [Real]) {
        z.par_iter_mut()
            .zip(r)
            .zip(&self.inv_diag)
            .for_each(|((z, r), d)| *z = r * d);
    }
}

/// No preconditioning.
pub struct Identity;

impl Preconditioner for Identity {
    fn apply(&self, r: &[Real], z: &mut [Real]) {
        z.copy_from_slice(r);
    }
}

/// Diagonal of a CSR matrix (0 where not stored).
pub fn diagonal(a: &SparseRowMat<usize, Real>) -> Vec<Real> {
    let rp = a.symbolic().row_ptr();
    let ci = a.symbolic().col_idx();
    let v = a.val();
    (0..a.nrows())
        .map(|i| {
            (rp[i]..rp[i + 1])
                .find(|&k| ci[k] == i)
                .map_or(0.0, |k| v[k])
        })
        .collect()
}

/// y = A x for a CSR matrix, rows in parallel (deterministic).
pub fn csr_matvec(a: &SparseRowMat<usize, Real>, x: &[Real], y: &mut [Real]) {
    let rp = a.symbolic().row_ptr();
    let ci = a.symbolic().col_idx();
    let v = a.val();
    y.par_iter_mut().enumerate().for_each(|(i, yi)| {
        let mut s = 0.0;
        for k in rp[i]..rp[i + 1] {
            s += v[k] * x[ci[k]];
        }
        *yi = s;
    });
}

/// The CSR matrix α I + β A (A square, columns sorted per row); the
/// diagonal is inserted where A does not store it.
pub fn identity_plus(
    a: &SparseRowMat<usize, Real>,
    alpha: Real,
    beta: Real,
) -> SparseRowMat<usize, Real> {
    let n = a.nrows();
    let rp = a.symbolic().row_ptr();
    let ci = a.symbolic().col_idx();
    let v = a.val();
    let mut row_ptr = Vec::with_capacity(n + 1);
    let mut col = Vec::with_capacity(v.len() + n);
    let mut val = Vec::with_capacity(v.len() + n);
    row_ptr.push(0);
    for i in 0..n {
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
    SparseRowMat::new(sym, val)
}
