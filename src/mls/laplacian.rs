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

use super::frame::Frame;
use super::operators::{par_fit_map, par_frames, LocalFit, Neighborhoods};
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

/// Sparse rows as (column, value) lists, one per matrix row.
pub type Rows = Vec<Vec<(usize, Real)>>;

/// Per-particle Laplacian rows (columns sorted, self included), in parallel.
pub fn laplacian_rows(
    nb: &Neighborhoods,
    params: &MlsParams,
) -> Result<(Rows, FitStats), MlsError> {
    params.validate()?;
    let frames = par_frames(nb, params);
    laplacian_rows_with_frames(nb, &frames, params)
}

/// [`laplacian_rows`] with the frames already computed (`par_frames(nb, p)`
/// for any `p` with the same `h` and `filament_weight_in_sheet`: the frames
/// do not depend on the other fit settings).
pub fn laplacian_rows_with_frames(
    nb: &Neighborhoods,
    frames: &[Frame],
    params: &MlsParams,
) -> Result<(Rows, FitStats), MlsError> {
    params.validate()?;
    if frames.len() != nb.len() {
        return Err(MlsError::Length {
            what: "frames",
            got: frames.len(),
            expected: nb.len(),
        });
    }
    let christoffel = params.christoffel;
    Ok(par_fit_map(nb, frames, params, |_, f| {
        f.map_or_else(Vec::new, |f| row_entries(f, christoffel))
    }))
}

/// The Laplacian row of one fit as (column, value), columns ascending: the
/// neighbours are already sorted, so the particle's own entry is merged in.
pub fn row_entries(f: &LocalFit, christoffel: bool) -> Vec<(usize, Real)> {
    let r = f.laplacian_row(christoffel);
    let p = f.members[0] as usize;
    let mut row = Vec::with_capacity(r.len());
    let mut own = Some((p, r[0]));
    for (&q, &v) in f.members[1..].iter().zip(&r[1..]) {
        let q = q as usize;
        if let Some(o) = own {
            if o.0 < q {
                row.push(o);
                own = None;
            }
        }
        row.push((q, v));
    }
    if let Some(o) = own {
        row.push(o);
    }
    row
}

impl JointLaplacian {
    /// Builds the joint Laplacian of the neighbourhoods with `params`.
    pub fn assemble(nb: &Neighborhoods, params: &MlsParams) -> Result<JointLaplacian, MlsError> {
        let (rows, stats) = laplacian_rows(nb, params)?;
        JointLaplacian::from_rows(nb, rows, stats)
    }

    /// [`JointLaplacian::assemble`] with the frames already computed (see
    /// [`laplacian_rows_with_frames`]); the film step passes the frames it
    /// built for the transitions instead of recomputing them.
    pub fn assemble_with_frames(
        nb: &Neighborhoods,
        frames: &[Frame],
        params: &MlsParams,
    ) -> Result<JointLaplacian, MlsError> {
        let (rows, stats) = laplacian_rows_with_frames(nb, frames, params)?;
        JointLaplacian::from_rows(nb, rows, stats)
    }

    /// The matrix of rows already computed on `nb` (e.g. by [`row_entries`]
    /// inside another pass over the same fits).
    pub fn from_rows(
        nb: &Neighborhoods,
        rows: Rows,
        stats: FitStats,
    ) -> Result<JointLaplacian, MlsError> {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::particles::Codim;
    use crate::validate::sampling::{rand01, sphere_latitude};

    /// A jittered flat square sheet z = 0 of side 1, spacing 0.05.
    fn flat_sheet() -> Vec<Vec3> {
        let mut s = 5u64;
        let mut v = Vec::new();
        for i in 0..21 {
            for j in 0..21 {
                let jx = 0.01 * (rand01(&mut s) - 0.5);
                let jy = 0.01 * (rand01(&mut s) - 0.5);
                v.push(Vec3::new(i as Real * 0.05 + jx, j as Real * 0.05 + jy, 0.0));
            }
        }
        v
    }

    #[test]
    fn constants_are_in_the_kernel_and_linear_functions_on_a_plane_too() {
        let x = flat_sheet();
        let nb = Neighborhoods::sheet(&x, 0.16).unwrap();
        for params in [MlsParams::new(0.16), MlsParams::paper(0.16)] {
            let l = JointLaplacian::assemble(&nb, &params).unwrap();
            assert!(
                l.max_relative_row_sum() < 1e-12,
                "{}",
                l.max_relative_row_sum()
            );
            let s: Vec<Real> = nb.x.iter().map(|p| 0.3 + 2.0 * p.x - 1.5 * p.y).collect();
            let mut ls = vec![0.0; s.len()];
            l.apply(&s, &mut ls);
            // interior particles (not boundary rows): the fit reproduces linear functions exactly
            let mut checked = 0;
            for (i, p) in nb.x.iter().enumerate() {
                if p.x > 0.2 && p.x < 0.8 && p.y > 0.2 && p.y < 0.8 {
                    assert!(ls[i].abs() < 1e-9, "row {i}: {}", ls[i]);
                    checked += 1;
                }
            }
            assert!(checked > 100);
            // and a quadratic: Δ(x² + y²) = 4
            let q: Vec<Real> = nb.x.iter().map(|p| p.x * p.x + p.y * p.y).collect();
            l.apply(&q, &mut ls);
            for (i, p) in nb.x.iter().enumerate() {
                if p.x > 0.2 && p.x < 0.8 && p.y > 0.2 && p.y < 0.8 {
                    assert!((ls[i] - 4.0).abs() < 1e-8, "row {i}: {}", ls[i]);
                }
            }
        }
    }

    #[test]
    fn assembling_with_given_frames_gives_the_same_matrix() {
        let x = flat_sheet();
        let nb = Neighborhoods::sheet(&x, 0.16).unwrap();
        let params = MlsParams::new(0.16);
        let a = JointLaplacian::assemble(&nb, &params).unwrap();
        // frames computed with other fit settings are the same frames
        let frames = par_frames(
            &nb,
            &MlsParams {
                order: 2,
                sheet_weight_in_filament: 0.0,
                ..params
            },
        );
        let b = JointLaplacian::assemble_with_frames(&nb, &frames, &params).unwrap();
        assert_eq!(a.matrix.val(), b.matrix.val());
        assert_eq!(a.matrix.symbolic().col_idx(), b.matrix.symbolic().col_idx());
        assert_eq!(a.stats, b.stats);
        assert!(JointLaplacian::assemble_with_frames(&nb, &frames[1..], &params).is_err());
    }

    #[test]
    fn result_does_not_depend_on_particle_order() {
        let x = sphere_latitude(1.0, 0.08, 0.1, 3);
        let n = x.len();
        let perm: Vec<usize> = (0..n).map(|i| (i * 7919) % n).collect();
        assert_eq!(
            {
                let mut p = perm.clone();
                p.sort();
                p
            },
            (0..n).collect::<Vec<_>>()
        );
        let y: Vec<Vec3> = perm.iter().map(|&i| x[i]).collect();
        let params = MlsParams::new(0.4);
        let la =
            JointLaplacian::assemble(&Neighborhoods::sheet(&x, 0.4).unwrap(), &params).unwrap();
        let lb =
            JointLaplacian::assemble(&Neighborhoods::sheet(&y, 0.4).unwrap(), &params).unwrap();
        // (L_b)[a][b] = (L_a)[perm a][perm b]
        let s: Vec<Real> = x.iter().map(|p| (3.0 * p.x).sin() + p.y * p.z).collect();
        let sy: Vec<Real> = perm.iter().map(|&i| s[i]).collect();
        let (mut ra, mut rb) = (vec![0.0; n], vec![0.0; n]);
        la.apply(&s, &mut ra);
        lb.apply(&sy, &mut rb);
        for k in 0..n {
            assert!(
                (rb[k] - ra[perm[k]]).abs() < 1e-9 * (1.0 + ra[perm[k]].abs()),
                "{k}"
            );
        }
    }

    #[test]
    fn degenerate_neighbourhoods_fall_back_without_nan() {
        // a line of points declared as sheet (collinear), an isolated point, and a proper patch
        let mut x: Vec<Vec3> = (0..12)
            .map(|i| Vec3::new(i as Real * 0.02, 5.0, 0.0))
            .collect();
        x.push(Vec3::new(-9.0, -9.0, -9.0));
        x.extend(flat_sheet());
        let nb = Neighborhoods::build(&x, &vec![Codim::Sheet; x.len()], 0.16).unwrap();
        let l = JointLaplacian::assemble(&nb, &MlsParams::new(0.16)).unwrap();
        assert!(l.matrix.val().iter().all(|v| v.is_finite()));
        assert_eq!(l.stats.particles, x.len());
        assert_eq!(l.stats.isolated, 1);
        assert!(l.stats.no_row >= 13, "{:?}", l.stats); // collinear line + isolated
        assert_eq!(
            l.stats.full_order + l.stats.lowered_order + l.stats.no_row,
            x.len()
        );
        // a NaN position is an error naming the particle
        let mut bad = x.clone();
        bad[4].y = Real::NAN;
        assert_eq!(
            Neighborhoods::sheet(&bad, 0.16).unwrap_err(),
            MlsError::NonFinite { index: 4 }
        );
        assert!(matches!(
            MlsParams {
                order: 9,
                ..MlsParams::new(0.1)
            }
            .validate(),
            Err(MlsError::InvalidParam { field: "order", .. })
        ));
    }

    #[test]
    fn joint_blocks_partition_the_matrix() {
        use crate::validate::butterfly::butterfly_particles;
        let (x, c) = butterfly_particles(0.08);
        let nb = Neighborhoods::build(&x, &c, 0.28).unwrap();
        let l = JointLaplacian::assemble(&nb, &MlsParams::new(0.28)).unwrap();
        let nnz: usize = [
            Block::SheetSheet,
            Block::SheetFilament,
            Block::FilamentSheet,
            Block::FilamentFilament,
        ]
        .iter()
        .map(|&b| l.block(b).unwrap().compute_nnz())
        .sum();
        assert_eq!(nnz, l.matrix.compute_nnz());
        let b = l.block(Block::FilamentSheet).unwrap();
        assert_eq!((b.nrows(), b.ncols()), (nb.len() - nb.n_sheet, nb.n_sheet));
        assert!(l.block(Block::SheetFilament).unwrap().compute_nnz() > 0);
        // faer's own product agrees with `apply`
        let s: Vec<Real> = nb.x.iter().map(|p| p.x * p.y).collect();
        let mut y = vec![0.0; s.len()];
        l.apply(&s, &mut y);
        let sc = faer::Col::<Real>::from_fn(s.len(), |i| s[i]);
        let yf = &l.matrix * &sc;
        for i in 0..s.len() {
            assert!((yf[i] - y[i]).abs() <= 1e-9 * (1.0 + y[i].abs()));
        }
    }
}
