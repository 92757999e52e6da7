//! A borrowed compressed-row view of a faer sparse matrix, with a parallel
//! matrix–vector product.

use super::SolveError;
use faer::sparse::{SparseRowMat, SparseRowMatRef, SymbolicSparseRowMat, Triplet};
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

impl super::Operator for Csr<'_> {
    fn dims(&self) -> (usize, usize) {
        (self.nrows, self.ncols)
    }
    fn matvec(&self, x: &[f64], y: &mut [f64]) {
        Csr::matvec(self, x, y)
    }
    fn all_finite(&self) -> bool {
        Csr::all_finite(self)
    }
}

/// The compressed-row matrix of `t` (entries at the same position summed,
/// in the order they appear in `t`). The entries are bucketed by row with a
/// counting sort and each row's (column, value) pairs are sorted in place,
/// so the cost does not depend on the order of `t` beyond each row's own
/// entries (faer's builder sorts indices into `t`, which costs cache misses
/// when `t` is not in row order).
pub fn rows_from_triplets(
    nrows: usize,
    ncols: usize,
    t: &[Triplet<usize, usize, f64>],
) -> Result<SparseRowMat<usize, f64>, SolveError> {
    let mut start = vec![0usize; nrows + 1];
    for e in t {
        if e.row >= nrows || e.col >= ncols {
            return Err(SolveError::Dimension(format!(
                "entry ({}, {}) of a {nrows}×{ncols} matrix",
                e.row, e.col
            )));
        }
        start[e.row + 1] += 1;
    }
    for i in 0..nrows {
        start[i + 1] += start[i];
    }
    let mut fill = start.clone();
    let mut buf = vec![(0usize, 0.0f64); t.len()];
    for e in t {
        buf[fill[e.row]] = (e.col, e.val);
        fill[e.row] += 1;
    }
    // each row sorted by column (in parallel; stable: duplicates keep their
    // order in `t`)
    {
        let mut rows: Vec<&mut [(usize, f64)]> = Vec::with_capacity(nrows);
        let mut left = &mut buf[..];
        for i in 0..nrows {
            let (row, rest) = std::mem::take(&mut left).split_at_mut(start[i + 1] - start[i]);
            rows.push(row);
            left = rest;
        }
        rows.par_iter_mut()
            .with_min_len(256)
            .for_each(|row| row.sort_by_key(|e| e.0));
    }
    let mut row_ptr = Vec::with_capacity(nrows + 1);
    let mut col = Vec::with_capacity(t.len());
    let mut val = Vec::with_capacity(t.len());
    row_ptr.push(0);
    for i in 0..nrows {
        let row = &buf[start[i]..start[i + 1]];
        let first = col.len();
        for &(c, v) in row.iter() {
            if col.len() > first && col[col.len() - 1] == c {
                *val.last_mut().expect("a value per column") += v;
            } else {
                col.push(c);
                val.push(v);
            }
        }
        row_ptr.push(col.len());
    }
    let sym = SymbolicSparseRowMat::new_checked(nrows, ncols, row_ptr, None, col);
    Ok(SparseRowMat::new(sym, val))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_from_triplets_matches_faer() {
        // a scrambled pattern with duplicates
        let n = 50;
        let mut t = Vec::new();
        for k in 0..2000usize {
            let (i, j) = ((k * 31 + 7) % n, (k * 17 + 3) % n);
            t.push(Triplet::new(i, j, (k as f64 * 0.37).sin()));
        }
        let ours = rows_from_triplets(n, n, &t).unwrap();
        let theirs = SparseRowMat::try_new_from_triplets(n, n, &t).unwrap();
        let (a, b) = (
            Csr::from_faer(ours.as_ref()).unwrap(),
            Csr::from_faer(theirs.as_ref()).unwrap(),
        );
        assert_eq!(a.row_ptr, b.row_ptr);
        assert_eq!(a.col, b.col);
        for (x, y) in a.val.iter().zip(b.val) {
            assert!((x - y).abs() <= 1e-12 * (1.0 + y.abs()), "{x} {y}");
        }
        assert!(rows_from_triplets(n, n, &[Triplet::new(n, 0, 1.0)]).is_err());
    }
}
