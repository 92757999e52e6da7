//! Sparse assembly of the joint Laplace–Beltrami matrix (paper §3.2.4, §4):
//!
//! ```text
//!     L = [ L(1)     L(1)(2) ]   rows/cols 0..n_sheet: sheet particles
//!         [ L(2)(1)  L(2)    ]   rows/cols n_sheet..n: filament particles
//! ```
//!
//! Row p holds the Laplace–Beltrami weights of p's fit (eq. 7c/8c/35):
//! (L s)_p = Δs(x_p). One matrix serves all three velocity components (no
//! 3× copies). Rows are built in parallel, one small solve per particle,
//! and stored in CSR (faer `SparseRowMat`) with columns sorted, so the
//! result does not depend on the thread count. Every row sums to zero up to
//! round-off, because the fits reproduce constants.

use super::operators::{par_fit_map, par_frames, Neighborhoods};
use super::{FitStats, MlsError, MlsParams};
use crate::math::{Real, Vec3};
use faer::sparse::{SparseRowMat, SymbolicSparseRowMat};
use rayon::prelude::*;

/// One of the four blocks of the joint Laplacian.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Block {
    /// L(1): sheet rows, sheet columns.
    SheetSheet,
    /// L(1)(2): sheet rows, filament columns.
    SheetFilament,
    /// L(2)(1): filament rows, sheet columns.
    FilamentSheet,
    /// L(2): filament rows, filament columns.
    FilamentFilament,
}

/// The assembled joint Laplacian on a [`Neighborhoods`] index.
#[derive(Clone, Debug)]
pub struct JointLaplacian {
    /// Number of sheet rows (the first ones).
    pub n_sheet: usize,
    /// CSR matrix, n × n, in 1/m².
    pub matrix: SparseRowMat<usize, Real>,
    /// What the fits did.
    pub stats: FitStats,
}

/// Per-particle Laplacian rows (columns sorted, self included), in parallel.
pub fn laplacian_rows(
    nb: &Neighborhoods,
    params: &MlsParams,
) -> Result<(Vec<Vec<(usize, Real)>>, FitStats), MlsError> {
    params.validate()?;
    let frames = par_frames(nb, params);
    let christoffel = params.christoffel;
    Ok(par_fit_map(nb, &frames, params, |_, f| {
        let Some(f) = f else { return Vec::new() };
        let r = f.laplacian_row(christoffel);
        let mut row: Vec<(usize, Real)> = f.members.iter().map(|&q| q as usize).zip(r).collect();
        row.sort_unstable_by_key(|e| e.0);
        row
    }))
}

impl JointLaplacian {
    /// Builds the joint Laplacian of the neighbourhoods with `params`.
    pub fn assemble(nb: &Neighborhoods, params: &MlsParams) -> Result<JointLaplacian, MlsError> {
        let (rows, stats) = laplacian_rows(nb, params)?;
        let matrix = csr_from_rows(nb.len(), nb.len(), rows)?;
        Ok(JointLaplacian {
            n_sheet: nb.n_sheet,
            matrix,
            stats,
        })
    }

    /// Number of rows (= columns).
    pub fn n(&self) -> usize {
        self.matrix.nrows()
    }

    /// y = L x, rows in parallel (deterministic: each row summed in order).
    pub fn apply(&self, x: &[Real], y: &mut [Real]) {
        let rp = self.matrix.symbolic().row_ptr();
        let ci = self.matrix.symbolic().col_idx();
        let v = self.matrix.val();
        y.par_iter_mut().enumerate().for_each(|(i, yi)| {
            let mut s = 0.0;
            for k in rp[i]..rp[i + 1] {
                s += v[k] * x[ci[k]];
            }
            *yi = s;
        });
    }

    /// L applied to a vector field componentwise, using differences to the
    /// row's own value (exact for constants): (L x)_p = Σ_q L_pq (x_q − x_p).
    pub fn apply_vec3(&self, x: &[Vec3]) -> Vec<Vec3> {
        let rp = self.matrix.symbolic().row_ptr();
        let ci = self.matrix.symbolic().col_idx();
        let v = self.matrix.val();
        (0..self.n())
            .into_par_iter()
            .map(|i| {
                let mut s = Vec3::zeros();
                for k in rp[i]..rp[i + 1] {
                    s += v[k] * (x[ci[k]] - x[i]);
                }
                s
            })
            .collect()
    }

    /// Row and column ranges of a block.
    pub fn block_ranges(&self, b: Block) -> (std::ops::Range<usize>, std::ops::Range<usize>) {
        let (s, n) = (0..self.n_sheet, self.n_sheet..self.n());
        match b {
            Block::SheetSheet => (s.clone(), s),
            Block::SheetFilament => (s, n),
            Block::FilamentSheet => (n, s),
            Block::FilamentFilament => (n.clone(), n),
        }
    }

    /// A copy of one block as its own CSR matrix (indices local to the block).
    pub fn block(&self, b: Block) -> Result<SparseRowMat<usize, Real>, MlsError> {
        let (rr, cr) = self.block_ranges(b);
        let rp = self.matrix.symbolic().row_ptr();
        let ci = self.matrix.symbolic().col_idx();
        let v = self.matrix.val();
        let rows = rr
            .clone()
            .map(|i| {
                (rp[i]..rp[i + 1])
                    .filter(|&k| cr.contains(&ci[k]))
                    .map(|k| (ci[k] - cr.start, v[k]))
                    .collect()
            })
            .collect();
        csr_from_rows(rr.len(), cr.len(), rows)
    }

    /// Largest |row sum| relative to the row's largest |entry| (a check that
    /// constants are in the kernel).
    pub fn max_relative_row_sum(&self) -> Real {
        let rp = self.matrix.symbolic().row_ptr();
        let v = self.matrix.val();
        (0..self.n())
            .map(|i| {
                let r = &v[rp[i]..rp[i + 1]];
                let m = r.iter().fold(0.0 as Real, |a, b| a.max(b.abs()));
                if m == 0.0 {
                    0.0
                } else {
                    r.iter().sum::<Real>().abs() / m
                }
            })
            .fold(0.0, Real::max)
    }
}

/// CSR matrix from rows of (column, value) with sorted, distinct columns.
pub fn csr_from_rows(
    nrows: usize,
    ncols: usize,
    rows: Vec<Vec<(usize, Real)>>,
) -> Result<SparseRowMat<usize, Real>, MlsError> {
    if rows.len() != nrows {
        return Err(MlsError::Length {
            what: "rows",
            got: rows.len(),
            expected: nrows,
        });
    }
    let nnz: usize = rows.iter().map(|r| r.len()).sum();
    let mut row_ptr = Vec::with_capacity(nrows + 1);
    let mut col_idx = Vec::with_capacity(nnz);
    let mut val = Vec::with_capacity(nnz);
    row_ptr.push(0);
    for (i, r) in rows.into_iter().enumerate() {
        for (c, x) in r {
            if c >= ncols || col_idx.len() > row_ptr[i] && *col_idx.last().unwrap() >= c {
                return Err(MlsError::Sparse(format!(
                    "row {i}: column {c} out of order or out of range"
                )));
            }
            col_idx.push(c);
            val.push(x);
        }
        row_ptr.push(col_idx.len());
    }
    let sym = SymbolicSparseRowMat::new_checked(nrows, ncols, row_ptr, None, col_idx);
    Ok(SparseRowMat::new(sym, val))
}
