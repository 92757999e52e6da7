//! Preconditioners: ILU(0) (incomplete LU with the sparsity of A, Saad,
//! *Iterative Methods for Sparse Linear Systems*, Alg. 10.4), Jacobi and
//! the identity.

use super::{Csr, SolveError};

/// z ≈ A⁻¹ r.
pub trait Preconditioner: Sync {
    /// Applies the preconditioner.
    fn apply(&self, r: &[f64], z: &mut [f64]);
}

/// No preconditioning.
pub struct Identity;

impl Preconditioner for Identity {
    fn apply(&self, r: &[f64], z: &mut [f64]) {
        z.copy_from_slice(r);
    }
}

/// Diagonal scaling.
pub struct Jacobi {
    inv_diag: Vec<f64>,
}

impl Jacobi {
    /// Builds from the diagonal of `a`; a zero diagonal entry is an error.
    pub fn new(a: &Csr) -> Result<Jacobi, SolveError> {
        let mut inv_diag = vec![0.0; a.nrows];
        for (i, d) in inv_diag.iter_mut().enumerate() {
            let v = (a.row_ptr[i]..a.row_ptr[i + 1])
                .find(|&k| a.col[k] == i)
                .map(|k| a.val[k])
                .unwrap_or(0.0);
            if v == 0.0 || !v.is_finite() {
                return Err(SolveError::ZeroPivot { row: i });
            }
            *d = 1.0 / v;
        }
        Ok(Jacobi { inv_diag })
    }
}

impl Preconditioner for Jacobi {
    fn apply(&self, r: &[f64], z: &mut [f64]) {
        for ((zi, ri), di) in z.iter_mut().zip(r).zip(&self.inv_diag) {
            *zi = ri * di;
        }
    }
}

/// ILU(0) factors: L (unit diagonal implied) and U without its diagonal,
/// each in its own compressed rows, and U's diagonal apart. The triangular
/// solves stream the factors from memory, so each reads only its own factor,
/// contiguously, with u32 column indices (12 instead of 16 bytes per entry;
/// `docs/benchmarks.md`). Column indices in each row of A must be sorted
/// (faer's are).
pub struct Ilu0 {
    l: Triangle,
    u: Triangle,
    diag: Vec<f64>,
}

/// Strictly triangular rows: row i is `col[ptr[i]..ptr[i + 1]]`, `val[..]`.
#[derive(Debug, PartialEq)]
pub(super) struct Triangle {
    pub(super) ptr: Vec<usize>,
    pub(super) col: Vec<u32>,
    pub(super) val: Vec<f64>,
}

impl Triangle {
    /// The entries `rows(i)` (index ranges into `col`/`val`) of every row.
    pub(super) fn gather(
        n: usize,
        col: &[usize],
        val: &[f64],
        rows: impl Fn(usize) -> std::ops::Range<usize>,
    ) -> Triangle {
        let mut ptr = Vec::with_capacity(n + 1);
        ptr.push(0);
        let (mut c, mut v) = (Vec::new(), Vec::new());
        for i in 0..n {
            for k in rows(i) {
                c.push(col[k] as u32);
                v.push(val[k]);
            }
            ptr.push(c.len());
        }
        Triangle {
            ptr,
            col: c,
            val: v,
        }
    }
}

/// The ILU(0) factors of `a` in `a`'s own pattern: the values (L's below
/// the diagonal, U's on and above it) and the position of each row's
/// diagonal. A zero or missing pivot is reported with its row.
fn factor(a: &Csr) -> Result<(Vec<f64>, Vec<usize>), SolveError> {
    let n = a.nrows;
    if a.ncols != n {
        return Err(SolveError::Dimension(format!(
            "ILU(0) of a {}×{} matrix",
            a.nrows, a.ncols
        )));
    }
    if n > u32::MAX as usize {
        return Err(SolveError::Dimension(format!(
            "ILU(0) of {n} rows: more than u32 indices hold"
        )));
    }
    let (row_ptr, col) = (a.row_ptr, a.col);
    let mut val = a.val.to_vec();
    let mut diag = vec![usize::MAX; n];
    for i in 0..n {
        for k in row_ptr[i]..row_ptr[i + 1] {
            if col[k] == i {
                diag[i] = k;
            }
        }
        if diag[i] == usize::MAX {
            return Err(SolveError::ZeroPivot { row: i });
        }
    }
    // position of column j in the current row i, via a dense marker
    let mut pos = vec![usize::MAX; n];
    for i in 0..n {
        let (s, e) = (row_ptr[i], row_ptr[i + 1]);
        for k in s..e {
            pos[col[k]] = k;
        }
        for k in s..e {
            let j = col[k];
            if j >= i {
                break;
            }
            let piv = val[diag[j]];
            let lij = val[k] / piv;
            val[k] = lij;
            for kk in diag[j] + 1..row_ptr[j + 1] {
                let p = pos[col[kk]];
                if p != usize::MAX {
                    val[p] -= lij * val[kk];
                }
            }
        }
        for k in s..e {
            pos[col[k]] = usize::MAX;
        }
        let d = val[diag[i]];
        if d == 0.0 || !d.is_finite() {
            return Err(SolveError::ZeroPivot { row: i });
        }
    }
    Ok((val, diag))
}

impl Ilu0 {
    /// Factorises `a`. A zero or missing pivot is reported with its row.
    pub fn new(a: &Csr) -> Result<Ilu0, SolveError> {
        let (val, diag) = factor(a)?;
        let (n, row_ptr) = (a.nrows, a.row_ptr);
        Ok(Ilu0 {
            l: Triangle::gather(n, a.col, &val, |i| row_ptr[i]..diag[i]),
            u: Triangle::gather(n, a.col, &val, |i| diag[i] + 1..row_ptr[i + 1]),
            diag: diag.iter().map(|&k| val[k]).collect(),
        })
    }

    /// ILU(0) of `a` on its pattern extended by `passes` passes of level-1
    /// fill in the rows and columns from `from` on ([`super::fill`]): the
    /// coupled system's impulse and pressure rows. `from ≥ n` or no pass is
    /// [`Ilu0::new`].
    pub fn with_tail_fill(a: &Csr, from: usize, passes: usize) -> Result<Ilu0, SolveError> {
        if a.ncols != a.nrows || from >= a.nrows || passes == 0 {
            return Ilu0::new(a);
        }
        let (row_ptr, col, val) =
            super::fill::with_tail_fill_passes(a.row_ptr, a.col, a.val, from, passes, |c| c, |c| c);
        Ilu0::new(&Csr {
            nrows: a.nrows,
            ncols: a.ncols,
            row_ptr: &row_ptr,
            col: &col,
            val: &val,
        })
    }
}

impl Preconditioner for Ilu0 {
    fn apply(&self, r: &[f64], z: &mut [f64]) {
        let n = r.len();
        let (l, u) = (&self.l, &self.u);
        // L y = r (unit lower)
        for i in 0..n {
            let mut acc = r[i];
            for k in l.ptr[i]..l.ptr[i + 1] {
                acc -= l.val[k] * z[l.col[k] as usize];
            }
            z[i] = acc;
        }
        // U z = y
        for i in (0..n).rev() {
            let mut acc = z[i];
            for k in u.ptr[i]..u.ptr[i + 1] {
                acc -= u.val[k] * z[u.col[k] as usize];
            }
            z[i] = acc / self.diag[i];
        }
    }
}
