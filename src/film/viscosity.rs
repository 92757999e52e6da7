//! Film viscosity (§5, eq. 13): one implicit solve per axis on the joint
//! MLS Laplacian of the sheet and filament particles, run by the film step
//! only when μ > 0.

use super::{FilmError, FilmParams};
use crate::linsolve::{bicgstab, Csr, Ilu0, SolveInfo};
use crate::math::{Real, Vec3};
use crate::particles::Particles;
use faer::sparse::{SparseRowMat, Triplet};

/// Implicit viscosity on the film particles: (M − μΔt V L) u = M u*.
pub(super) fn viscosity(
    l: &SparseRowMat<usize, Real>,
    film: &Particles,
    u: &mut [Vec3],
    prm: &FilmParams,
    dt: Real,
) -> Result<[SolveInfo; 3], FilmError> {
    let err = |e| FilmError::Solve {
        stage: "viscosity",
        source: e,
    };
    let lc = Csr::from_faer(l.as_ref()).map_err(err)?;
    let n = lc.nrows;
    let mut t = Vec::with_capacity(lc.val.len() + n);
    for i in 0..n {
        t.push(Triplet::new(i, i, film.mass[i]));
        if film.fixed[i] {
            continue;
        }
        let c = prm.viscosity * dt * film.mass[i] / prm.density;
        for k in lc.row_ptr[i]..lc.row_ptr[i + 1] {
            t.push(Triplet::new(i, lc.col[k], -c * lc.val[k]));
        }
    }
    let a = SparseRowMat::try_new_from_triplets(n, n, &t)
        .map_err(|e| err(crate::linsolve::SolveError::Dimension(format!("{e:?}"))))?;
    let ac = Csr::from_faer(a.as_ref()).map_err(err)?;
    let ilu = Ilu0::new(&ac).map_err(err)?;
    let mut info = [SolveInfo::default(); 3];
    for d in 0..3 {
        let b: Vec<Real> = (0..n).map(|i| film.mass[i] * u[i][d]).collect();
        let mut x: Vec<Real> = u.iter().map(|v| v[d]).collect();
        info[d] = bicgstab(&ac, &b, &mut x, &ilu, &prm.solver).map_err(err)?;
        for i in 0..n {
            u[i][d] = x[i];
        }
    }
    Ok(info)
}
