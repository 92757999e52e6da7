//! The diffusive split of the implicit tension (`film.implicit: diffusive`).
//!
//! Eq. (16) takes the whole MLS Laplacian L implicitly:
//! (I − c_i L) u^{n+1} = rhs, with c_i = σΔt² S_i/m_i (+ νΔt). An MLS row is
//! not a diffusion stencil: its off-diagonal weights have both signs, and
//! next to a moving ring (the first film row left 1.5 spacings behind it) or
//! across a thin, stretched neck the diagonal itself turns positive
//! (σΔt²(S/m)L_ii = +3.7 at the paper's spacing and Δt = 0.5 ms), so the
//! implicit row's diagonal 1 − c_i L_ii goes negative and BiCGSTAB stagnates
//! (docs/decisions.md, "Moving rings: the pinch").
//!
//! The split writes each non-fixed row as L = L⁺ + L⁻ with
//! L⁺_ij = max(L_ij, 0) for j ≠ i and L⁺_ii = −Σ_{j≠i} L⁺_ij (a diffusion
//! row, zero row sum), L⁻ = L − L⁺, and takes L⁺ implicitly and L⁻ on u^n:
//!
//! (I − c_i L⁺) u^{n+1} = rhs + c_i (L⁻ u^n)_i.
//!
//! I − c L⁺ has a positive diagonal 1 + c_i Σ_{j≠i} L⁺_ij and non-positive
//! off-diagonals summing to less than it: a strictly row-diagonally dominant
//! M-matrix whatever Δt, so ILU(0) exists and BiCGSTAB converges in a few
//! iterations. Both parts keep L's action on constants (L⁺ by construction,
//! L⁻ because L's rows sum to zero), and a steady state (u^{n+1} = u^n) is
//! the same as with the full implicit form, so equilibria do not change.
//! What changes is the transient: the remainder acts one step late.

use crate::linsolve::{Csr, SolveError};
use crate::math::Real;
use faer::sparse::{SparseRowMat, Triplet};

/// L split into its implicit diffusive part and the explicit remainder.
pub struct Split {
    /// L⁺ (fixed rows copied from L: their rows are identity rows anyway).
    pub implicit: SparseRowMat<usize, Real>,
    /// L⁻ in compressed rows: row i's (column, weight) pairs are
    /// `explicit[explicit_ptr[i]..explicit_ptr[i + 1]]`; empty for fixed rows.
    pub explicit: Vec<(usize, Real)>,
    /// Row starts of `explicit` (n + 1).
    pub explicit_ptr: Vec<usize>,
}

impl Split {
    /// (L⁻ v)_i.
    pub fn remainder(&self, i: usize, v: impl Fn(usize) -> Real) -> Real {
        self.explicit[self.explicit_ptr[i]..self.explicit_ptr[i + 1]]
            .iter()
            .map(|&(j, w)| w * v(j))
            .sum()
    }
}

/// Splits the rows of `l` that are not `fixed` (see the module doc).
pub fn split(l: &Csr, fixed: &[bool]) -> Result<Split, SolveError> {
    let n = l.nrows;
    if fixed.len() != n {
        return Err(SolveError::Dimension(format!(
            "diffusive split: {n} rows, {} fixed flags",
            fixed.len()
        )));
    }
    let mut t = Vec::with_capacity(l.val.len());
    let mut explicit = Vec::with_capacity(l.val.len());
    let mut explicit_ptr = Vec::with_capacity(n + 1);
    explicit_ptr.push(0);
    for (i, &fx) in fixed.iter().enumerate().take(n) {
        let rg = l.row_ptr[i]..l.row_ptr[i + 1];
        if fx {
            t.extend(rg.map(|k| Triplet::new(i, l.col[k], l.val[k])));
            explicit_ptr.push(explicit.len());
            continue;
        }
        let (mut diag, mut pos) = (0.0, 0.0);
        for k in rg {
            let (j, v) = (l.col[k], l.val[k]);
            if j == i {
                diag += v;
            } else if v > 0.0 {
                t.push(Triplet::new(i, j, v));
                pos += v;
            } else if v < 0.0 {
                explicit.push((j, v));
            }
        }
        t.push(Triplet::new(i, i, -pos));
        explicit.push((i, diag + pos));
        explicit_ptr.push(explicit.len());
    }
    let implicit = SparseRowMat::try_new_from_triplets(n, l.ncols, &t)
        .map_err(|e| SolveError::Dimension(format!("diffusive split: {e:?}")))?;
    Ok(Split {
        implicit,
        explicit,
        explicit_ptr,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_split_keeps_l_and_its_implicit_part_is_a_diffusion() {
        // rows of mixed sign, one with a positive diagonal (anti-diffusive)
        let rows: Vec<Vec<(usize, Real)>> = vec![
            vec![(0, -4.0), (1, 3.0), (2, -1.0), (3, 2.0)],
            vec![(0, 1.0), (1, 2.5), (2, -4.0), (3, 0.5)],
            vec![(1, 2.0), (2, -2.0)],
            vec![(0, 7.0), (3, -7.0)],
        ];
        let t: Vec<Triplet<usize, usize, Real>> = rows
            .iter()
            .enumerate()
            .flat_map(|(i, r)| r.iter().map(move |&(j, v)| Triplet::new(i, j, v)))
            .collect();
        let lm = SparseRowMat::try_new_from_triplets(4, 4, &t).unwrap();
        let l = Csr::from_faer(lm.as_ref()).unwrap();
        let fixed = [false, false, false, true];
        let s = split(&l, &fixed).unwrap();
        let imp = Csr::from_faer(s.implicit.as_ref()).unwrap();
        for (i, &fx) in fixed.iter().enumerate() {
            let dense = |c: &Csr, j: usize| -> Real {
                (c.row_ptr[i]..c.row_ptr[i + 1])
                    .filter(|&k| c.col[k] == j)
                    .map(|k| c.val[k])
                    .sum()
            };
            let row = &s.explicit[s.explicit_ptr[i]..s.explicit_ptr[i + 1]];
            for j in 0..4 {
                let ex: Real = row.iter().filter(|e| e.0 == j).map(|e| e.1).sum();
                // L⁺ + L⁻ = L entry by entry
                assert!(
                    (dense(&imp, j) + ex - dense(&l, j)).abs() < 1e-14,
                    "({i}, {j})"
                );
                if !fx && j != i {
                    assert!(dense(&imp, j) >= 0.0);
                }
            }
            if !fx {
                let sum: Real = (0..4).map(|j| dense(&imp, j)).sum();
                assert!(sum.abs() < 1e-14, "row {i} of L⁺ sums to {sum}");
            } else {
                assert!(row.is_empty());
            }
        }
        // row 1's diagonal was +2.5: in L⁺ it is −1.5 (its positive
        // off-diagonals), the +4.0 left explicit
        let d1: Real = (imp.row_ptr[1]..imp.row_ptr[2])
            .filter(|&k| imp.col[k] == 1)
            .map(|k| imp.val[k])
            .sum();
        assert_eq!(d1, -1.5);
        assert_eq!(s.remainder(1, |_| 1.0), 4.0 - 4.0);
        assert_eq!(s.remainder(1, |j| j as Real), 2.0 * -4.0 + 4.0);
    }
}
