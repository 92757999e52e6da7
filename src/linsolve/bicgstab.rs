//! Right-preconditioned BiCGSTAB (van der Vorst 1992), the solver the paper
//! uses for eq. (24).

use super::{dot, norm, Operator, Preconditioner, SolveError, SolveInfo};
use rayon::prelude::*;

/// Restarts allowed after a ρ breakdown (the shadow residual is reset to the current residual).
const MAX_RESTARTS: usize = 5;

/// Parameters of a BiCGSTAB solve.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct BicgstabParams {
    /// Relative residual tolerance ‖b − Ax‖/‖b‖ (paper: 1e-9).
    pub tol: f64,
    /// Iteration budget.
    pub max_iter: usize,
}

impl Default for BicgstabParams {
    fn default() -> Self {
        BicgstabParams {
            tol: 1e-9,
            max_iter: 1000,
        }
    }
}

fn axpy_into(out: &mut [f64], a: &[f64], s: f64, b: &[f64]) {
    out.par_iter_mut()
        .zip(a.par_iter().zip(b.par_iter()))
        .with_min_len(1024)
        .for_each(|(o, (x, y))| *o = x + s * y);
}

/// r = b − A x (with `tmp` as scratch); returns ‖r‖. The recursive residual
/// of BiCGSTAB drifts, so convergence is always confirmed with this one.
pub(super) fn true_residual(
    a: &dyn Operator,
    b: &[f64],
    x: &[f64],
    tmp: &mut [f64],
    r: &mut [f64],
) -> f64 {
    a.matvec(x, tmp);
    axpy_into(r, b, -1.0, tmp);
    norm(r)
}

/// Solves A x = b starting from the given `x`. Returns the iterations and
/// the true relative residual, or why it failed. Never leaves a non-finite
/// value in `x`: on failure `x` holds the best finite iterate reached.
pub fn bicgstab(
    a: &dyn Operator,
    b: &[f64],
    x: &mut [f64],
    m: &dyn Preconditioner,
    prm: &BicgstabParams,
) -> Result<SolveInfo, SolveError> {
    let n = b.len();
    let Some(bn) = super::prepare(a, b, x)? else {
        return Ok(SolveInfo {
            iterations: 0,
            rel_residual: 0.0,
        });
    };
    let mut r = vec![0.0; n];
    let mut tmp = vec![0.0; n];
    // ‖r‖ of the current residual and ‖r0‖ of the shadow one, kept for the
    // breakdown test (each is the norm of the vector as it stands)
    let mut r_norm = true_residual(a, b, x, &mut tmp, &mut r);
    let mut r0 = r.clone();
    let mut r0_norm = r_norm;
    let mut restarts = 0;
    let (mut rho, mut alpha, mut omega) = (1.0f64, 1.0f64, 1.0f64);
    let mut v = vec![0.0; n];
    let mut p = vec![0.0; n];
    let mut ph = vec![0.0; n];
    let mut s = vec![0.0; n];
    let mut sh = vec![0.0; n];
    let mut t = vec![0.0; n];
    let mut best = x.to_vec();
    let mut best_res = r_norm / bn;
    if best_res <= prm.tol {
        return Ok(SolveInfo {
            iterations: 0,
            rel_residual: best_res,
        });
    }
    for it in 1..=prm.max_iter {
        let mut rho_new = dot(&r0, &r);
        if rho_new.abs() <= 1e-30 * r0_norm * r_norm || !rho_new.is_finite() {
            // (near-)orthogonal shadow residual: restart from the current residual
            if restarts >= MAX_RESTARTS || !rho_new.is_finite() {
                x.copy_from_slice(&best);
                return Err(SolveError::Breakdown {
                    iteration: it,
                    what: "rho",
                    value: rho_new,
                });
            }
            restarts += 1;
            r0.copy_from_slice(&r);
            r0_norm = r_norm;
            p.iter_mut().for_each(|e| *e = 0.0);
            v.iter_mut().for_each(|e| *e = 0.0);
            rho = 1.0;
            alpha = 1.0;
            omega = 1.0;
            rho_new = dot(&r0, &r);
        }
        let beta = (rho_new / rho) * (alpha / omega);
        rho = rho_new;
        // p = r + beta (p − omega v)
        p.par_iter_mut()
            .zip(r.par_iter().zip(v.par_iter()))
            .with_min_len(1024)
            .for_each(|(pi, (ri, vi))| *pi = ri + beta * (*pi - omega * vi));
        m.apply(&p, &mut ph);
        a.matvec(&ph, &mut v);
        let r0v = dot(&r0, &v);
        if r0v == 0.0 || !r0v.is_finite() {
            x.copy_from_slice(&best);
            return Err(SolveError::Breakdown {
                iteration: it,
                what: "r0·v",
                value: r0v,
            });
        }
        alpha = rho / r0v;
        axpy_into(&mut s, &r, -alpha, &v);
        // x += alpha ph (tentatively; s may already be small)
        x.par_iter_mut()
            .zip(ph.par_iter())
            .with_min_len(1024)
            .for_each(|(xi, pi)| *xi += alpha * pi);
        let s_norm = norm(&s);
        let sn = s_norm / bn;
        if sn <= prm.tol {
            let res = true_residual(a, b, x, &mut tmp, &mut r) / bn;
            if res <= prm.tol * 10.0 {
                return Ok(SolveInfo {
                    iterations: it,
                    rel_residual: res,
                });
            }
            r.copy_from_slice(&s);
            r_norm = s_norm;
            continue;
        }
        m.apply(&s, &mut sh);
        a.matvec(&sh, &mut t);
        let tt = dot(&t, &t);
        if tt == 0.0 || !tt.is_finite() {
            x.copy_from_slice(&best);
            return Err(SolveError::Breakdown {
                iteration: it,
                what: "t·t",
                value: tt,
            });
        }
        omega = dot(&t, &s) / tt;
        if omega == 0.0 || !omega.is_finite() {
            x.copy_from_slice(&best);
            return Err(SolveError::Breakdown {
                iteration: it,
                what: "omega",
                value: omega,
            });
        }
        x.par_iter_mut()
            .zip(sh.par_iter())
            .with_min_len(1024)
            .for_each(|(xi, si)| *xi += omega * si);
        axpy_into(&mut r, &s, -omega, &t);
        r_norm = norm(&r);
        let rn = r_norm / bn;
        if !rn.is_finite() {
            x.copy_from_slice(&best);
            return Err(SolveError::NonFinite("iterate"));
        }
        if rn < best_res {
            best_res = rn;
            best.copy_from_slice(x);
        }
        if rn <= prm.tol {
            // confirm with the true residual (the recursive one drifts),
            // which goes on as r if it is not small enough
            r_norm = true_residual(a, b, x, &mut tmp, &mut r);
            let res = r_norm / bn;
            if res <= prm.tol * 10.0 {
                return Ok(SolveInfo {
                    iterations: it,
                    rel_residual: res,
                });
            }
        }
    }
    let res = true_residual(a, b, &best, &mut tmp, &mut r) / bn;
    x.copy_from_slice(&best);
    Err(SolveError::NoConvergence {
        iterations: prm.max_iter,
        rel_residual: res,
        tol: prm.tol,
    })
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::linsolve::{Csr, Identity, Ilu0, Jacobi};
    use faer::sparse::{SparseRowMat, Triplet};

    /// 2-D convection–diffusion on an m×m grid (non-symmetric), Dirichlet.
    pub(in crate::linsolve) fn convdiff(m: usize, peclet: f64) -> SparseRowMat<usize, f64> {
        let idx = |i: usize, j: usize| i * m + j;
        let mut t = Vec::new();
        for i in 0..m {
            for j in 0..m {
                let k = idx(i, j);
                t.push(Triplet::new(k, k, 4.0));
                if i > 0 {
                    t.push(Triplet::new(k, idx(i - 1, j), -1.0 - peclet));
                }
                if i + 1 < m {
                    t.push(Triplet::new(k, idx(i + 1, j), -1.0 + peclet));
                }
                if j > 0 {
                    t.push(Triplet::new(k, idx(i, j - 1), -1.0));
                }
                if j + 1 < m {
                    t.push(Triplet::new(k, idx(i, j + 1), -1.0));
                }
            }
        }
        SparseRowMat::try_new_from_triplets(m * m, m * m, &t).unwrap()
    }

    /// ‖b − A x‖/‖b‖.
    pub(in crate::linsolve) fn residual(a: &Csr, b: &[f64], x: &[f64]) -> f64 {
        let mut ax = vec![0.0; b.len()];
        a.matvec(x, &mut ax);
        let r: Vec<f64> = b.iter().zip(&ax).map(|(p, q)| p - q).collect();
        norm(&r) / norm(b)
    }

    #[test]
    fn solves_nonsymmetric_system_to_tolerance_and_ilu_helps() {
        let mat = convdiff(40, 0.4);
        let a = Csr::from_faer(mat.as_ref()).unwrap();
        let b: Vec<f64> = (0..a.nrows)
            .map(|i| ((i * 37 % 101) as f64 / 50.0) - 1.0)
            .collect();
        let prm = BicgstabParams {
            tol: 1e-10,
            max_iter: 2000,
        };
        let mut x_ilu = vec![0.0; a.nrows];
        let ilu = bicgstab(&a, &b, &mut x_ilu, &Ilu0::new(&a).unwrap(), &prm).unwrap();
        let mut x_id = vec![0.0; a.nrows];
        let plain = bicgstab(&a, &b, &mut x_id, &Identity, &prm).unwrap();
        let mut x_j = vec![0.0; a.nrows];
        bicgstab(&a, &b, &mut x_j, &Jacobi::new(&a).unwrap(), &prm).unwrap();
        for x in [&x_ilu, &x_id, &x_j] {
            assert!(residual(&a, &b, x) < 1e-9);
        }
        assert!(
            ilu.iterations * 2 < plain.iterations,
            "ILU {} vs none {}",
            ilu.iterations,
            plain.iterations
        );
        // agrees with a direct solve
        let lu = mat.as_ref().sp_lu().unwrap();
        let rhs = faer::Mat::from_fn(a.nrows, 1, |i, _| b[i]);
        use faer::linalg::solvers::Solve;
        let xd = lu.solve(&rhs);
        let err = (0..a.nrows)
            .map(|i| (xd[(i, 0)] - x_ilu[i]).abs())
            .fold(0.0, f64::max);
        assert!(err < 1e-8, "{err}");
    }

    #[test]
    fn ilu0_is_exact_for_tridiagonal() {
        // no fill-in: ILU(0) = LU, so one preconditioned step solves it
        let n = 50;
        let mut t = Vec::new();
        for i in 0..n {
            t.push(Triplet::new(i, i, 3.0));
            if i > 0 {
                t.push(Triplet::new(i, i - 1, -1.2));
            }
            if i + 1 < n {
                t.push(Triplet::new(i, i + 1, -0.7));
            }
        }
        let m = SparseRowMat::try_new_from_triplets(n, n, &t).unwrap();
        let a = Csr::from_faer(m.as_ref()).unwrap();
        let b: Vec<f64> = (0..n).map(|i| i as f64).collect();
        let mut x = vec![0.0; n];
        let info = bicgstab(
            &a,
            &b,
            &mut x,
            &Ilu0::new(&a).unwrap(),
            &BicgstabParams::default(),
        )
        .unwrap();
        assert!(info.iterations <= 1, "{info:?}");
        assert!(residual(&a, &b, &x) < 1e-12);
    }

    #[test]
    fn failures_are_reported_not_nan() {
        let mat = convdiff(20, 0.2);
        let a = Csr::from_faer(mat.as_ref()).unwrap();
        let b = vec![1.0; a.nrows];
        let mut x = vec![0.0; a.nrows];
        let e = bicgstab(
            &a,
            &b,
            &mut x,
            &Identity,
            &BicgstabParams {
                tol: 1e-14,
                max_iter: 3,
            },
        )
        .unwrap_err();
        assert!(
            matches!(e, SolveError::NoConvergence { iterations: 3, .. }),
            "{e}"
        );
        assert!(x.iter().all(|v| v.is_finite()));
        let mut bad = b.clone();
        bad[3] = f64::NAN;
        assert_eq!(
            bicgstab(&a, &bad, &mut x, &Identity, &BicgstabParams::default()).unwrap_err(),
            SolveError::NonFinite("right-hand side")
        );
        // zero pivot: a row without a diagonal entry
        let m = SparseRowMat::try_new_from_triplets(
            2,
            2,
            &[Triplet::new(0, 1, 1.0), Triplet::new(1, 0, 1.0)],
        )
        .unwrap();
        let a = Csr::from_faer(m.as_ref()).unwrap();
        assert_eq!(Ilu0::new(&a).err(), Some(SolveError::ZeroPivot { row: 0 }));
    }

    #[test]
    fn same_bits_for_any_thread_count() {
        let mat = convdiff(70, 0.3);
        let a = Csr::from_faer(mat.as_ref()).unwrap();
        let b: Vec<f64> = (0..a.nrows).map(|i| (i as f64 * 0.37).sin()).collect();
        let run = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| {
                let mut x = vec![0.0; a.nrows];
                bicgstab(
                    &a,
                    &b,
                    &mut x,
                    &Ilu0::new(&a).unwrap(),
                    &BicgstabParams::default(),
                )
                .unwrap();
                x
            })
        };
        assert_eq!(run(1), run(3));
    }
}
