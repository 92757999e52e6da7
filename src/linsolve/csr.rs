//! A borrowed compressed-row view of a faer sparse matrix, with a parallel
//! matrix–vector product.

use super::SolveError;
use faer::sparse::SparseRowMatRef;
use rayon::prelude::*;

/// Compressed sparse rows: columns of row i are `col[row_ptr[i]..row_ptr[i+1]]`.
#[derive(Clone, Copy, Debug)]
pub struct Csr<'a> {
    /// Rows.
    pub nrows: usize,
    /// Columns.
    pub ncols: usize,
    /// Row pointers (len nrows + 1).
    pub row_ptr: &'a [usize],
    /// Column indices.
    pub col: &'a [usize],
    /// Values.
    pub val: &'a [f64],
}

impl<'a> Csr<'a> {
    /// Views a compressed faer row-major matrix (one built from triplets is).
    pub fn from_faer(m: SparseRowMatRef<'a, usize, f64>) -> Result<Csr<'a>, SolveError> {
        let (nrows, ncols, row_ptr, row_nnz, col) = m.symbolic().parts();
        if row_nnz.is_some() {
            return Err(SolveError::Dimension(
                "matrix rows are not compressed".into(),
            ));
        }
        Ok(Csr {
            nrows,
            ncols,
            row_ptr,
            col,
            val: m.val(),
        })
    }

    /// y = A x (parallel over rows, deterministic).
    pub fn matvec(&self, x: &[f64], y: &mut [f64]) {
        y.par_iter_mut()
            .enumerate()
            .with_min_len(256)
            .for_each(|(i, yi)| {
                let (s, e) = (self.row_ptr[i], self.row_ptr[i + 1]);
                let mut acc = 0.0;
                for k in s..e {
                    acc += self.val[k] * x[self.col[k]];
                }
                *yi = acc;
            });
    }

    /// True when every stored value is finite.
    pub fn all_finite(&self) -> bool {
        self.val.iter().all(|v| v.is_finite())
    }
}
