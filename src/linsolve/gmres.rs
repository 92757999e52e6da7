//! Restarted, right-preconditioned GMRES(m) (Saad and Schultz 1986; Saad,
//! *Iterative Methods for Sparse Linear Systems*, Alg. 9.5), the default
//! Krylov method of the coupled system (eq. 24).
//!
//! BiCGSTAB, the paper's solver, takes two products with A and two
//! preconditioner applications per iteration and its residual is not
//! monotone: on the droplet on a plane after the impact it sat on plateaus
//! for hundreds of iterations (`docs/decisions.md`, "Two passes of fill,
//! and GMRES"). GMRES takes one product and one application per iteration
//! and minimises the residual over the Krylov space of each cycle, at the
//! cost of up to m + 1 stored vectors and the orthogonalisation (modified
//! Gram–Schmidt). Every reduction is [`super::dot`], so results are
//! bit-identical for any thread count.

use super::{dot, norm, Operator, Preconditioner, SolveError, SolveInfo};
use rayon::prelude::*;

/// Iterations over which the residual must at least halve. A healthy solve
/// of the coupled system falls by far more (the droplet on a plane: 1e-9
/// in at most ~150 iterations); one whose right-hand side a null mode does
/// not reach sits at ~1e-2 for its whole budget (the droplet on a plane at
/// frame 70, where the counted switch to the other form and the release of
/// the enclosed cells' faces then solve it).
pub const STAGNATION_WINDOW: usize = 100;

/// Parameters of a GMRES(m) solve.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GmresParams {
    /// Relative residual tolerance ‖b − Ax‖/‖b‖.
    pub tol: f64,
    /// Budget of iterations (products with A), over all cycles.
    pub max_iter: usize,
    /// Krylov vectors per cycle (m).
    pub restart: usize,
}

/// y += s x.
fn axpy(y: &mut [f64], s: f64, x: &[f64]) {
    y.par_iter_mut()
        .zip(x.par_iter())
        .with_min_len(1024)
        .for_each(|(y, x)| *y += s * x);
}

/// Solves A x = b starting from the given `x` with GMRES(m), right
/// preconditioned by `m` (so the residual it minimises is A's own).
/// Returns the iterations and the true relative residual, or why it
/// failed; on failure `x` holds the last finite iterate (GMRES's residual
/// never grows from one cycle to the next). A residual that does not halve
/// over [`STAGNATION_WINDOW`] iterations ends the solve
/// ([`SolveError::Stagnation`]).
pub fn gmres(
    a: &dyn Operator,
    b: &[f64],
    x: &mut [f64],
    m: &dyn Preconditioner,
    prm: &GmresParams,
) -> Result<SolveInfo, SolveError> {
    let n = b.len();
    let Some(bn) = super::prepare(a, b, x)? else {
        return Ok(SolveInfo {
            iterations: 0,
            rel_residual: 0.0,
        });
    };
    let mk = prm.restart.max(1);
    let mut tmp = vec![0.0; n];
    let mut r = vec![0.0; n];
    let mut z = vec![0.0; n];
    let mut v: Vec<Vec<f64>> = Vec::with_capacity(mk + 1);
    // Hessenberg columns (rotated into R), rotations, rotated β e₁
    let mut h = vec![vec![0.0; mk + 1]; mk];
    let (mut cs, mut sn) = (vec![0.0; mk], vec![0.0; mk]);
    let mut g = vec![0.0; mk + 1];
    let mut it = 0;
    // the relative residual after each iteration, over all cycles
    let mut history: Vec<f64> = Vec::new();
    let mut stalled = false;
    loop {
        let beta = super::bicgstab::true_residual(a, b, x, &mut tmp, &mut r);
        let res = beta / bn;
        if !res.is_finite() {
            return Err(SolveError::NonFinite("iterate"));
        }
        if res <= prm.tol {
            return Ok(SolveInfo {
                iterations: it,
                rel_residual: res,
            });
        }
        if stalled {
            return Err(SolveError::Stagnation {
                iterations: it,
                rel_residual: res,
                window: STAGNATION_WINDOW,
                tol: prm.tol,
            });
        }
        if it >= prm.max_iter {
            return Err(SolveError::NoConvergence {
                iterations: it,
                rel_residual: res,
                tol: prm.tol,
            });
        }
        if v.is_empty() {
            v.push(vec![0.0; n]);
        }
        v[0].par_iter_mut()
            .zip(r.par_iter())
            .with_min_len(1024)
            .for_each(|(v, r)| *v = r / beta);
        g.iter_mut().for_each(|e| *e = 0.0);
        g[0] = beta;
        let mut k = 0;
        while k < mk && it < prm.max_iter {
            m.apply(&v[k], &mut z);
            if v.len() == k + 1 {
                v.push(vec![0.0; n]);
            }
            let (head, tail) = v.split_at_mut(k + 1);
            let w = &mut tail[0];
            a.matvec(&z, w);
            let col = &mut h[k];
            // modified Gram–Schmidt
            for (i, vi) in head.iter().enumerate() {
                let hij = dot(w, vi);
                col[i] = hij;
                axpy(w, -hij, vi);
            }
            let hn = norm(w);
            col[k + 1] = hn;
            if !hn.is_finite() {
                return Err(SolveError::NonFinite("Krylov vector"));
            }
            if hn > 0.0 {
                w.par_iter_mut().with_min_len(1024).for_each(|e| *e /= hn);
            }
            // the previous rotations on the new column, then its own
            for i in 0..k {
                let t = cs[i] * col[i] + sn[i] * col[i + 1];
                col[i + 1] = -sn[i] * col[i] + cs[i] * col[i + 1];
                col[i] = t;
            }
            let d = col[k].hypot(col[k + 1]);
            if d == 0.0 {
                return Err(SolveError::Breakdown {
                    iteration: it + 1,
                    what: "Hessenberg column",
                    value: d,
                });
            }
            cs[k] = col[k] / d;
            sn[k] = col[k + 1] / d;
            col[k] = d;
            col[k + 1] = 0.0;
            g[k + 1] = -sn[k] * g[k];
            g[k] *= cs[k];
            k += 1;
            it += 1;
            let res = g[k].abs() / bn;
            history.push(res);
            if res <= prm.tol || hn == 0.0 {
                break;
            }
            if it > STAGNATION_WINDOW && res > 0.5 * history[it - 1 - STAGNATION_WINDOW] {
                stalled = true;
                break;
            }
        }
        // y = R⁻¹ g, then x += M⁻¹ (V y)
        let mut y = vec![0.0; k];
        for i in (0..k).rev() {
            let mut s = g[i];
            for j in i + 1..k {
                s -= h[j][i] * y[j];
            }
            y[i] = s / h[i][i];
        }
        tmp.iter_mut().for_each(|e| *e = 0.0);
        for (j, yj) in y.iter().enumerate() {
            axpy(&mut tmp, *yj, &v[j]);
        }
        m.apply(&tmp, &mut z);
        let before = x.to_vec();
        axpy(x, 1.0, &z);
        if !x.iter().all(|e| e.is_finite()) {
            x.copy_from_slice(&before);
            return Err(SolveError::NonFinite("iterate"));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::linsolve::bicgstab::tests::{convdiff, residual as rel_residual};
    use crate::linsolve::{bicgstab, BicgstabParams, Csr, Identity, Ilu0};
    use faer::sparse::{SparseRowMat, Triplet};

    #[test]
    fn reaches_the_tolerance_and_agrees_with_bicgstab() {
        let m = convdiff(30, 2.0);
        let a = Csr::from_faer(m.as_ref()).unwrap();
        let b: Vec<f64> = (0..900).map(|i| ((i * 37) % 11) as f64 - 5.0).collect();
        let ilu = Ilu0::new(&a).unwrap();
        let mut x = vec![0.0; 900];
        let prm = GmresParams {
            tol: 1e-10,
            max_iter: 500,
            restart: 20,
        };
        let s = gmres(&a, &b, &mut x, &ilu, &prm).unwrap();
        assert!(s.rel_residual <= 1e-10, "{s:?}");
        assert!(rel_residual(&a, &b, &x) <= 1e-10);
        let mut xb = vec![0.0; 900];
        let bp = BicgstabParams {
            tol: 1e-10,
            max_iter: 500,
        };
        bicgstab(&a, &b, &mut xb, &ilu, &bp).unwrap();
        let diff = x
            .iter()
            .zip(&xb)
            .map(|(p, q)| (p - q).abs())
            .fold(0.0, f64::max);
        let scale = x.iter().map(|p| p.abs()).fold(0.0, f64::max);
        // both within 1e-10 of b: the solutions agree to A⁻¹'s amplification
        assert!(diff <= 1e-7 * scale, "{diff} vs {scale}");
        // the preconditioner pays: unpreconditioned GMRES(20) needs more
        let mut xi = vec![0.0; 900];
        let si = gmres(&a, &b, &mut xi, &Identity, &prm).unwrap();
        assert!(si.iterations > s.iterations, "{si:?} vs {s:?}");
    }

    #[test]
    fn full_gmres_is_exact_in_n_steps() {
        // without restarts GMRES ends in at most n iterations (exact
        // arithmetic); on a 5×5 system to round-off
        let m = convdiff(5, 1.0);
        let a = Csr::from_faer(m.as_ref()).unwrap();
        let b: Vec<f64> = (0..25).map(|i| (i as f64).sin()).collect();
        let mut x = vec![0.0; 25];
        let prm = GmresParams {
            tol: 1e-13,
            max_iter: 25,
            restart: 25,
        };
        let s = gmres(&a, &b, &mut x, &Identity, &prm).unwrap();
        assert!(s.iterations <= 25, "{s:?}");
        assert!(rel_residual(&a, &b, &x) <= 1e-13);
    }

    #[test]
    fn failures_are_reported_not_nan() {
        let m = convdiff(20, 2.0);
        let a = Csr::from_faer(m.as_ref()).unwrap();
        let b = vec![1.0; 400];
        let mut x = vec![0.0; 400];
        let prm = GmresParams {
            tol: 1e-14,
            max_iter: 3,
            restart: 2,
        };
        match gmres(&a, &b, &mut x, &Identity, &prm) {
            Err(SolveError::NoConvergence {
                iterations,
                rel_residual,
                ..
            }) => {
                assert_eq!(iterations, 3);
                assert!(rel_residual < 1.0 && rel_residual.is_finite());
            }
            other => panic!("{other:?}"),
        }
        assert!(x.iter().all(|v| v.is_finite()));
        let mut bad = b.clone();
        bad[7] = f64::NAN;
        assert_eq!(
            gmres(&a, &bad, &mut x, &Identity, &prm),
            Err(SolveError::NonFinite("right-hand side"))
        );
    }

    /// A singular system whose right-hand side lies partly outside the
    /// range: the residual cannot fall below that part, and the solve stops
    /// once it has not halved over the window, reporting where it stood.
    #[test]
    fn a_stalled_residual_ends_the_solve() {
        // the 1-D Neumann Laplacian (constant null space) and a b with a
        // constant part
        let n = 400;
        let mut t = Vec::new();
        for i in 0..n {
            let d = if i == 0 || i == n - 1 { 1.0 } else { 2.0 };
            t.push(Triplet::new(i, i, d));
            if i > 0 {
                t.push(Triplet::new(i, i - 1, -1.0));
            }
            if i + 1 < n {
                t.push(Triplet::new(i, i + 1, -1.0));
            }
        }
        let m = SparseRowMat::try_new_from_triplets(n, n, &t).unwrap();
        let a = Csr::from_faer(m.as_ref()).unwrap();
        let b: Vec<f64> = (0..n).map(|i| 1.0 + (i as f64 * 0.1).sin()).collect();
        let mut x = vec![0.0; n];
        let prm = GmresParams {
            tol: 1e-9,
            max_iter: 5000,
            restart: 50,
        };
        match gmres(&a, &b, &mut x, &Identity, &prm) {
            Err(SolveError::Stagnation {
                iterations,
                rel_residual,
                window,
                ..
            }) => {
                assert_eq!(window, STAGNATION_WINDOW);
                assert!(iterations > window && iterations < 5000, "{iterations}");
                // the constant part of b: mean 1 + O(1/n) against ‖b‖/√n
                let mean = b.iter().sum::<f64>() / n as f64;
                let floor = mean * (n as f64).sqrt() / norm(&b);
                assert!(
                    rel_residual >= floor * (1.0 - 1e-9),
                    "{rel_residual} vs {floor}"
                );
                assert!(rel_residual < 2.0 * floor, "{rel_residual} vs {floor}");
            }
            other => panic!("{other:?}"),
        }
        assert!(x.iter().all(|v| v.is_finite()));
    }

    #[test]
    fn same_bits_for_any_thread_count() {
        let m = convdiff(40, 3.0);
        let a = Csr::from_faer(m.as_ref()).unwrap();
        let b: Vec<f64> = (0..1600).map(|i| ((i * 13) % 7) as f64).collect();
        let ilu = Ilu0::new(&a).unwrap();
        let prm = GmresParams {
            tol: 1e-9,
            max_iter: 300,
            restart: 30,
        };
        let run = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| {
                let mut x = vec![0.0; 1600];
                gmres(&a, &b, &mut x, &ilu, &prm).unwrap();
                x
            })
        };
        let (x1, x3) = (run(1), run(3));
        assert!(x1.iter().zip(&x3).all(|(p, q)| p.to_bits() == q.to_bits()));
    }
}
