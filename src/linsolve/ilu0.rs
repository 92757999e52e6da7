//! ILU(0): incomplete LU factorisation with the sparsity pattern of A
//! (Saad, *Iterative Methods for Sparse Linear Systems*, Alg. 10.4), used as
//! a preconditioner for [`super::bicgstab`]. L is unit lower triangular and
//! U upper triangular, both stored in one CSR copy of A's pattern.

use super::{LinsolveError, Preconditioner};
use crate::math::Real;
use faer::sparse::SparseRowMat;

/// The ILU(0) factors of a square CSR matrix (columns sorted per row, the
/// diagonal stored in every row).
pub struct Ilu0 {
    row_ptr: Vec<usize>,
    col: Vec<usize>,
    val: Vec<Real>,
    diag: Vec<usize>,
}

impl Ilu0 {
    /// Factorises A; fails on a missing, zero or non-finite pivot.
    pub fn new(a: &SparseRowMat<usize, Real>) -> Result<Ilu0, LinsolveError> {
        let n = a.nrows();
        let row_ptr = a.symbolic().row_ptr().to_vec();
        let col = a.symbolic().col_idx().to_vec();
        let mut val = a.val().to_vec();
        let mut diag = vec![usize::MAX; n];
        for (i, d) in diag.iter_mut().enumerate() {
            if let Some(k) = (row_ptr[i]..row_ptr[i + 1]).find(|&k| col[k] == i) {
                *d = k;
            }
            if *d == usize::MAX {
                return Err(LinsolveError::Pivot { row: i, value: 0.0 });
            }
        }
        // position of column j within row i, via a scatter array
        let mut pos = vec![usize::MAX; n];
        for i in 0..n {
            for k in row_ptr[i]..row_ptr[i + 1] {
                pos[col[k]] = k;
            }
            for k in row_ptr[i]..diag[i] {
                let j = col[k];
                let piv = val[diag[j]];
                if piv == 0.0 || !piv.is_finite() {
                    return Err(LinsolveError::Pivot { row: j, value: piv });
                }
                let l = val[k] / piv;
                val[k] = l;
                for kk in diag[j] + 1..row_ptr[j + 1] {
                    let p = pos[col[kk]];
                    if p != usize::MAX {
                        val[p] -= l * val[kk];
                    }
                }
            }
            for k in row_ptr[i]..row_ptr[i + 1] {
                pos[col[k]] = usize::MAX;
            }
            let d = val[diag[i]];
            if d == 0.0 || !d.is_finite() {
                return Err(LinsolveError::Pivot { row: i, value: d });
            }
        }
        Ok(Ilu0 {
            row_ptr,
            col,
            val,
            diag,
        })
    }
}

impl Preconditioner for Ilu0 {
    /// z = U⁻¹ L⁻¹ r (two sequential triangular sweeps).
    fn apply(&self, r: &[Real], z: &mut [Real]) {
        let n = r.len();
        for i in 0..n {
            let mut s = r[i];
            for k in self.row_ptr[i]..self.diag[i] {
                s -= self.val[k] * z[self.col[k]];
            }
            z[i] = s;
        }
        for i in (0..n).rev() {
            let mut s = z[i];
            for k in self.diag[i] + 1..self.row_ptr[i + 1] {
                s -= self.val[k] * z[self.col[k]];
            }
            z[i] = s / self.val[self.diag[i]];
        }
    }
}
