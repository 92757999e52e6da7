//! Weighted least-squares polynomial fits in a local frame (paper §3.2.2,
//! §3.2.3, Appendix B, eqs. 3–5 and 30–34).
//!
//! In the frame of particle p the members q (p itself first, then its
//! neighbours) have scaled local coordinates η_q = ξ_q / h. A field s is
//! fitted by a polynomial ŝ(β, η) = Σ_j β_j P_j(η) minimising
//! Σ_q Ψ_q (ŝ(β, η_q) − s_q)² (eq. 4/31), i.e.
//!
//! (Bᵀ W B) β = Bᵀ W s   (eq. 5),   β = H s,   H = (Bᵀ W B)⁻¹ Bᵀ W   (eq. 34)
//!
//! with the weights of eq. 32: Ψ = 1 for p itself and 1/n for its n
//! neighbours (neighbours of another codimension are scaled by the joint
//! weight of §3.2.4, see [`super::MlsParams`]).
//!
//! Monomials are ordered by total degree, so the first six of a bivariate
//! basis are 1, η¹, η², (η¹)², η¹η², (η²)² whatever the order — exactly the
//! paper's quadratic basis (eq. 3) — and the first three of a univariate
//! basis are 1, η, η² (§3.2.3). Orders above 2 are a departure from the
//! paper (see `docs/decisions.md`: the quartic fit is the default because it
//! is ~300× more accurate on the sphere-diffusion case and stays stable).
//!
//! H is never formed: the normal matrix is equilibrated (unit diagonal) and
//! factorised once by Cholesky; every field fitted at the particle reuses
//! the factor. A pivot below `pivot_tol` marks the fit rank deficient (too
//! few points, collinear points on a sheet); the caller then lowers the order.

use crate::math::Real;

/// Number of monomials of total degree ≤ `order` in `vars` (1 or 2) variables.
#[inline]
pub fn n_terms(vars: usize, order: usize) -> usize {
    if vars == 1 {
        order + 1
    } else {
        (order + 1) * (order + 2) / 2
    }
}

/// Writes the monomials of total degree ≤ `order` at `eta` into `out`
/// (length [`n_terms`]); bivariate order: for degree d, (η¹)^(d−i) (η²)^i,
/// i = 0..=d.
#[inline]
pub fn monomials(vars: usize, order: usize, eta: [Real; 2], out: &mut [Real]) {
    if vars == 1 {
        let mut p = 1.0;
        for o in out.iter_mut().take(order + 1) {
            *o = p;
            p *= eta[0];
        }
        return;
    }
    let (u, v) = (eta[0], eta[1]);
    let mut k = 0;
    let mut upow = [1.0; 9];
    let mut vpow = [1.0; 9];
    for d in 1..=order.min(8) {
        upow[d] = upow[d - 1] * u;
        vpow[d] = vpow[d - 1] * v;
    }
    for d in 0..=order {
        for i in 0..=d {
            out[k] = upow[d - i] * vpow[i];
            k += 1;
        }
    }
}

/// A factorised weighted least-squares problem over the members of one
/// particle's neighbourhood.
#[derive(Clone, Debug)]
pub struct LsqFit {
    /// Number of local variables: 2 on sheets, 1 on filaments.
    pub vars: usize,
    /// Polynomial order actually used.
    pub order: usize,
    /// Number of basis terms.
    pub k: usize,
    /// Number of members m.
    m: usize,
    /// Weighted basis, transposed and row-major: row i holds Ψ_q P_i(η_q),
    /// q = 0..m (contiguous, so every product below is a dot or an axpy).
    wbt: Vec<Real>,
    /// Member weights Ψ_q (length m).
    weights: Vec<Real>,
    /// Equilibration D = diag(A)^{-1/2}.
    scale: Vec<Real>,
    /// Lower Cholesky factor of D A D, row-major k × k.
    chol: Vec<Real>,
}

#[inline]
fn dot(a: &[Real], b: &[Real]) -> Real {
    // four partial sums: lets the compiler vectorise, fixed order (deterministic)
    let mut acc = [0.0; 4];
    let n4 = a.len() / 4 * 4;
    for (ca, cb) in a[..n4].chunks_exact(4).zip(b[..n4].chunks_exact(4)) {
        for l in 0..4 {
            acc[l] += ca[l] * cb[l];
        }
    }
    let mut s = (acc[0] + acc[1]) + (acc[2] + acc[3]);
    for i in n4..a.len() {
        s += a[i] * b[i];
    }
    s
}

impl LsqFit {
    /// Builds and factorises the fit of order `order` over members with
    /// scaled local coordinates `eta` and weights `weights` (zero weights
    /// allowed). Returns `None` when the system is rank deficient: fewer
    /// weighted members than basis terms, or a relative pivot below
    /// `pivot_tol`.
    pub fn new(
        vars: usize,
        order: usize,
        eta: &[[Real; 2]],
        weights: &[Real],
        pivot_tol: Real,
    ) -> Option<LsqFit> {
        let k = n_terms(vars, order);
        let m = eta.len();
        let active = weights.iter().filter(|&&w| w > 0.0).count();
        if active < k {
            return None;
        }
        // unweighted basis Bᵀ (k × m), row by row: each monomial of degree d is
        // a monomial of degree d − 1 times η¹ (or η² for the last one), so
        // every row is one contiguous elementwise product (vectorises)
        let mut bt = vec![0.0; k * m];
        bt[..m].iter_mut().for_each(|v| *v = 1.0);
        for (q, e) in eta.iter().enumerate() {
            bt[m + q] = e[0];
            if vars == 2 {
                bt[2 * m + q] = e[1];
            }
        }
        let row_of = |d: usize, i: usize| if vars == 1 { d } else { d * (d + 1) / 2 + i };
        for d in 2..=order {
            let top = if vars == 1 { 0 } else { d };
            for i in 0..=top {
                let (src, var) = if i < d {
                    (row_of(d - 1, i), 1)
                } else {
                    (row_of(d - 1, d - 1), 2)
                };
                let dst = row_of(d, i);
                let (lo, hi) = bt.split_at_mut(dst * m);
                let (s, x) = (&lo[src * m..(src + 1) * m], &lo[var * m..(var + 1) * m]);
                for ((o, a), b) in hi[..m].iter_mut().zip(s).zip(x) {
                    *o = a * b;
                }
            }
        }
        let mut wbt = bt.clone();
        for i in 0..k {
            for (v, w) in wbt[i * m..(i + 1) * m].iter_mut().zip(weights) {
                *v *= w;
            }
        }
        // A = Bᵀ W B (lower triangle). A_ij = Σ_q Ψ_q η_q^(α_i + α_j) depends only on
        // the summed exponents, so each distinct moment is one dot product
        // (45 instead of 120 for the quartic) and is copied to its other entries.
        let mut ex = [(0usize, 0usize); 28];
        let mut t = 0;
        for d in 0..=order {
            if vars == 1 {
                ex[t] = (d, 0);
                t += 1;
            } else {
                for i in 0..=d {
                    ex[t] = (d - i, i);
                    t += 1;
                }
            }
        }
        let mut memo = [[Real::NAN; 13]; 13];
        let mut a = vec![0.0; k * k];
        for i in 0..k {
            let wi = &wbt[i * m..(i + 1) * m];
            for j in 0..=i {
                let (p, r) = (ex[i].0 + ex[j].0, ex[i].1 + ex[j].1);
                let mut v = memo[p][r];
                if v.is_nan() {
                    v = dot(wi, &bt[j * m..(j + 1) * m]);
                    memo[p][r] = v;
                }
                a[i * k + j] = v;
            }
        }
        let mut scale = vec![0.0; k];
        for i in 0..k {
            let d = a[i * k + i];
            if !(d > 0.0 && d.is_finite()) {
                return None;
            }
            scale[i] = 1.0 / d.sqrt();
        }
        for i in 0..k {
            for j in 0..=i {
                a[i * k + j] *= scale[i] * scale[j];
            }
        }
        // in-place Cholesky of the equilibrated matrix (unit diagonal)
        for j in 0..k {
            let mut d = a[j * k + j];
            for p in 0..j {
                d -= a[j * k + p] * a[j * k + p];
            }
            if d.is_nan() || d <= pivot_tol {
                return None;
            }
            let d = d.sqrt();
            a[j * k + j] = d;
            for i in j + 1..k {
                let mut s = a[i * k + j];
                for p in 0..j {
                    s -= a[i * k + p] * a[j * k + p];
                }
                a[i * k + j] = s / d;
            }
        }
        Some(LsqFit {
            vars,
            order,
            k,
            m,
            wbt,
            weights: weights.to_vec(),
            scale,
            chol: a,
        })
    }

    /// Basis value P_i(η_q) of member q (i = 1, 2 give η¹, η²). Members with
    /// zero weight return 0.
    pub fn basis(&self, q: usize, i: usize) -> Real {
        let w = self.weights[q];
        if w == 0.0 {
            0.0
        } else {
            self.wbt[i * self.m + q] / w
        }
    }

    /// Weight Ψ_q of member q.
    pub fn weight(&self, q: usize) -> Real {
        self.weights[q]
    }

    /// Number of members m.
    pub fn members(&self) -> usize {
        self.m
    }

    /// Solves (Bᵀ W B) y = `rhs` in place.
    #[allow(clippy::needless_range_loop)] // triangular sweeps read best with indices
    pub fn solve_normal(&self, rhs: &mut [Real]) {
        let k = self.k;
        for i in 0..k {
            rhs[i] *= self.scale[i];
        }
        for i in 0..k {
            let mut s = rhs[i];
            for p in 0..i {
                s -= self.chol[i * k + p] * rhs[p];
            }
            rhs[i] = s / self.chol[i * k + i];
        }
        for i in (0..k).rev() {
            let mut s = rhs[i];
            for p in i + 1..k {
                s -= self.chol[p * k + i] * rhs[p];
            }
            rhs[i] = s / self.chol[i * k + i];
        }
        for i in 0..k {
            rhs[i] *= self.scale[i];
        }
    }

    /// Coefficients β = H s of one field given its member values (eq. 34).
    pub fn coefficients(&self, values: &[Real]) -> Vec<Real> {
        let m = self.m;
        let mut rhs: Vec<Real> = (0..self.k)
            .map(|i| dot(&self.wbt[i * m..(i + 1) * m], values))
            .collect();
        self.solve_normal(&mut rhs);
        rhs
    }

    /// The member weights r_q = dᵀ H e_q of a linear functional β ↦ dᵀ β:
    /// one small solve (Bᵀ W B) y = d, then r_q = Σ_i y_i Ψ_q P_i(η_q).
    pub fn functional_row(&self, d: &[Real]) -> Vec<Real> {
        let (k, m) = (self.k, self.m);
        let mut y = d[..k].to_vec();
        self.solve_normal(&mut y);
        let mut r = vec![0.0; m];
        for (i, yi) in y.iter().enumerate() {
            if *yi != 0.0 {
                for (rq, b) in r.iter_mut().zip(&self.wbt[i * m..(i + 1) * m]) {
                    *rq += yi * b;
                }
            }
        }
        r
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid_eta(n: i32, s: Real) -> Vec<[Real; 2]> {
        let mut v = vec![[0.0, 0.0]];
        for i in -n..=n {
            for j in -n..=n {
                if (i, j) != (0, 0) && ((i * i + j * j) as Real) * s * s < 1.0 {
                    v.push([i as Real * s + 0.01 * j as Real * s, j as Real * s]);
                }
            }
        }
        v
    }

    #[test]
    fn quartic_fit_reproduces_quartic_polynomial() {
        let eta = grid_eta(6, 0.2);
        let n = eta.len() - 1;
        let w: Vec<Real> = (0..eta.len())
            .map(|q| if q == 0 { 1.0 } else { 1.0 / n as Real })
            .collect();
        let fit = LsqFit::new(2, 4, &eta, &w, 1e-13).expect("full rank");
        let f = |e: [Real; 2]| {
            0.3 - e[0] + 2.0 * e[1] * e[1] + 0.5 * e[0] * e[0] * e[0] * e[1] - e[1].powi(4)
        };
        let vals: Vec<Real> = eta.iter().map(|&e| f(e)).collect();
        let c = fit.coefficients(&vals);
        let expect = [
            0.3, -1.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.0, 0.0, -1.0,
        ];
        for (a, b) in c.iter().zip(expect) {
            assert!((a - b).abs() < 1e-10, "{c:?}");
        }
    }

    #[test]
    fn collinear_points_are_rank_deficient_for_bivariate_fit() {
        let eta: Vec<[Real; 2]> = (0..20).map(|i| [i as Real * 0.05, 0.0]).collect();
        let w = vec![1.0; 20];
        assert!(LsqFit::new(2, 2, &eta, &w, 1e-13).is_none());
        assert!(LsqFit::new(1, 2, &eta, &w, 1e-13).is_some());
    }

    #[test]
    fn too_few_points_is_rank_deficient() {
        let eta = vec![[0.0, 0.0], [0.1, 0.0], [0.0, 0.1]];
        assert!(LsqFit::new(2, 2, &eta, &[1.0; 3], 1e-13).is_none());
    }
}
