//! Preconditioned BiCGSTAB (van der Vorst 1992, right preconditioning):
//! solves A x = b for a general non-singular sparse A.
//!
//! r₀ = b − A x₀, r̂ = r₀; each iteration: p ← r + β(p − ω v), v = A P⁻¹p,
//! α = ρ/(r̂·v), s = r − α v, t = A P⁻¹s, ω = (t·s)/(t·t),
//! x ← x + α P⁻¹p + ω P⁻¹s, r = s − ω t. Stops when ‖r‖ ≤ tol ‖b‖.

use super::{csr_matvec, LinsolveError, Preconditioner, SolveInfo};
use crate::math::Real;
use faer::sparse::SparseRowMat;

/// Parameters of [`bicgstab`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BicgstabParams {
    /// Relative residual tolerance ‖b − A x‖ / ‖b‖ (dimensionless).
    pub tol: Real,
    /// Iteration limit.
    pub max_iters: usize,
}

impl Default for BicgstabParams {
    fn default() -> Self {
        BicgstabParams {
            tol: 1e-10,
            max_iters: 500,
        }
    }
}

fn dot(a: &[Real], b: &[Real]) -> Real {
    // fixed-order chunked sum: deterministic, independent of thread count
    a.chunks(4096)
        .zip(b.chunks(4096))
        .map(|(x, y)| x.iter().zip(y).map(|(p, q)| p * q).sum::<Real>())
        .sum()
}

/// Solves A x = b; `x` holds the initial guess on entry and the solution on exit.
pub fn bicgstab(
    a: &SparseRowMat<usize, Real>,
    b: &[Real],
    x: &mut [Real],
    pre: &impl Preconditioner,
    params: &BicgstabParams,
) -> Result<SolveInfo, LinsolveError> {
    let n = a.nrows();
    if b.len() != n || x.len() != n {
        return Err(LinsolveError::Size {
            n,
            got: if b.len() != n { b.len() } else { x.len() },
        });
    }
    let bnorm = dot(b, b).sqrt();
    if bnorm == 0.0 {
        x.iter_mut().for_each(|v| *v = 0.0);
        return Ok(SolveInfo {
            iterations: 0,
            rel_residual: 0.0,
        });
    }
    let mut r = vec![0.0; n];
    csr_matvec(a, x, &mut r);
    r.iter_mut().zip(b).for_each(|(r, b)| *r = b - *r);
    let rhat = r.clone();
    let (mut p, mut v) = (vec![0.0; n], vec![0.0; n]);
    let (mut ph, mut sh, mut t) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    let (mut rho, mut alpha, mut omega) = (1.0, 1.0, 1.0);
    let mut res = dot(&r, &r).sqrt() / bnorm;
    if res <= params.tol {
        return Ok(SolveInfo {
            iterations: 0,
            rel_residual: res,
        });
    }
    for it in 1..=params.max_iters {
        let rho_new = dot(&rhat, &r);
        if rho_new == 0.0 || !rho_new.is_finite() {
            return Err(LinsolveError::Breakdown {
                iters: it,
                rel_residual: res,
            });
        }
        let beta = (rho_new / rho) * (alpha / omega);
        rho = rho_new;
        p.iter_mut()
            .zip(&r)
            .zip(&v)
            .for_each(|((p, r), v)| *p = r + beta * (*p - omega * v));
        pre.apply(&p, &mut ph);
        csr_matvec(a, &ph, &mut v);
        let rv = dot(&rhat, &v);
        if rv == 0.0 || !rv.is_finite() {
            return Err(LinsolveError::Breakdown {
                iters: it,
                rel_residual: res,
            });
        }
        alpha = rho / rv;
        // s overwrites r
        r.iter_mut().zip(&v).for_each(|(r, v)| *r -= alpha * v);
        let snorm = dot(&r, &r).sqrt() / bnorm;
        if snorm <= params.tol {
            x.iter_mut().zip(&ph).for_each(|(x, p)| *x += alpha * p);
            return Ok(SolveInfo {
                iterations: it,
                rel_residual: snorm,
            });
        }
        pre.apply(&r, &mut sh);
        csr_matvec(a, &sh, &mut t);
        let tt = dot(&t, &t);
        if tt == 0.0 || !tt.is_finite() {
            return Err(LinsolveError::Breakdown {
                iters: it,
                rel_residual: snorm,
            });
        }
        omega = dot(&t, &r) / tt;
        x.iter_mut()
            .zip(&ph)
            .zip(&sh)
            .for_each(|((x, p), s)| *x += alpha * p + omega * s);
        r.iter_mut().zip(&t).for_each(|(r, t)| *r -= omega * t);
        res = dot(&r, &r).sqrt() / bnorm;
        if !res.is_finite() {
            return Err(LinsolveError::Breakdown {
                iters: it,
                rel_residual: res,
            });
        }
        if res <= params.tol {
            return Ok(SolveInfo {
                iterations: it,
                rel_residual: res,
            });
        }
        if omega == 0.0 {
            return Err(LinsolveError::Breakdown {
                iters: it,
                rel_residual: res,
            });
        }
    }
    Err(LinsolveError::NoConvergence {
        iters: params.max_iters,
        rel_residual: res,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::linsolve::{Ilu0, Jacobi};
    use crate::mls::laplacian::csr_from_rows;

    /// Non-symmetric convection–diffusion matrix on a 1-D grid.
    fn matrix(n: usize) -> SparseRowMat<usize, Real> {
        let rows = (0..n)
            .map(|i| {
                let mut r = Vec::new();
                if i > 0 {
                    r.push((i - 1, -1.3));
                }
                r.push((i, 2.5));
                if i + 1 < n {
                    r.push((i + 1, -0.7));
                }
                r
            })
            .collect();
        csr_from_rows(n, n, rows).unwrap()
    }

    #[test]
    fn solves_a_nonsymmetric_system_with_both_preconditioners() {
        let n = 400;
        let a = matrix(n);
        let xs: Vec<Real> = (0..n).map(|i| (i as Real * 0.1).sin()).collect();
        let mut b = vec![0.0; n];
        csr_matvec(&a, &xs, &mut b);
        let p = BicgstabParams {
            tol: 1e-12,
            max_iters: 400,
        };
        let mut x = vec![0.0; n];
        let info = bicgstab(&a, &b, &mut x, &Jacobi::new(&a), &p).unwrap();
        assert!(info.rel_residual <= 1e-12);
        assert!(x.iter().zip(&xs).all(|(a, b)| (a - b).abs() < 1e-9));
        let mut y = vec![0.0; n];
        let info2 = bicgstab(&a, &b, &mut y, &Ilu0::new(&a).unwrap(), &p).unwrap();
        // ILU(0) of a tridiagonal matrix is its exact LU: one iteration
        assert!(info2.iterations <= 2, "{info2:?}");
        assert!(y.iter().zip(&xs).all(|(a, b)| (a - b).abs() < 1e-9));
    }

    #[test]
    fn reports_non_convergence_with_numbers() {
        let a = matrix(400);
        let b = vec![1.0; 400];
        let mut x = vec![0.0; 400];
        let e = bicgstab(
            &a,
            &b,
            &mut x,
            &crate::linsolve::Identity,
            &BicgstabParams {
                tol: 1e-14,
                max_iters: 2,
            },
        );
        assert!(
            matches!(e, Err(LinsolveError::NoConvergence { iters: 2, .. })),
            "{e:?}"
        );
    }
}
