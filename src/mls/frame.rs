//! Local frames by weighted PCA (paper Appendix A, eqs. 25–29).
//!
//! For particle p with neighbours q, |x_q − x_p| < h:
//!
//! * weights Φ_pq = 1 − (|x_p − x_q| / h)³ (eq. 27), Φ_pp = 1;
//! * weighted centroid x̄ = Σ Φ x_q / Σ Φ (eq. 26);
//! * covariance C = Σ Φ (x_q − x̄)(x_q − x̄)ᵀ / Σ Φ (eq. 25);
//! * C = R Σ Rᵀ (eqs. 28–29), eigenvectors sorted by descending eigenvalue.
//!
//! On a sheet b¹, b² span the tangent plane and b³ is the normal; on a
//! filament b¹ is the tangent and b², b³ the normal and binormal. The frame
//! is made right-handed (b³ = b¹ × b²) so local coordinates
//! ξ = Bᵀ (x_q − x_p) are a rotation of world coordinates.

use crate::math::{Mat3, Real, Vec3};

/// An orthonormal local frame: the columns of `axes` are b¹, b², b³.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    /// Columns b¹, b², b³ (right-handed, orthonormal).
    pub axes: Mat3,
    /// Eigenvalues of the weighted covariance, descending (m²).
    pub eigenvalues: [Real; 3],
}

impl Frame {
    /// Local coordinates ξ = Bᵀ d of a world-space offset `d`.
    #[inline]
    pub fn to_local(&self, d: &Vec3) -> Vec3 {
        self.axes.tr_mul(d)
    }

    /// World-space vector B ξ of local components `xi`.
    #[inline]
    pub fn to_world(&self, xi: &Vec3) -> Vec3 {
        self.axes * xi
    }

    /// Axis k (0-based): b¹, b², b³.
    #[inline]
    pub fn axis(&self, k: usize) -> Vec3 {
        self.axes.column(k).into_owned()
    }
}

/// PCA weight Φ(d) = 1 − (d/h)³ for d < h, else 0 (eq. 27).
#[inline]
pub fn pca_weight(d: Real, h: Real) -> Real {
    if d < h {
        let r = d / h;
        1.0 - r * r * r
    } else {
        0.0
    }
}

/// The weighted-PCA frame at `center` from the points `others` (the point
/// at `center` itself is included with Φ = 1). Never fails: with no other
/// point the covariance is zero and the frame is the world axes (a caller
/// detects that case by the eigenvalues, all zero).
pub fn pca_frame(center: &Vec3, others: impl Iterator<Item = Vec3>, h: Real) -> Frame {
    // Accumulate relative to the centre for accuracy: y = x_q − x_p.
    let mut wsum = 1.0; // Φ_pp = 1, y_p = 0
    let mut m1 = Vec3::zeros();
    let mut m2 = Mat3::zeros();
    for x in others {
        let y = x - center;
        let w = pca_weight(y.norm(), h);
        if w > 0.0 {
            wsum += w;
            m1 += w * y;
            m2 += w * y * y.transpose();
        }
    }
    let mean = m1 / wsum; // x̄ − x_p, eq. (26)
    let cov = m2 / wsum - mean * mean.transpose(); // eq. (25)
    frame_from_covariance(cov)
}

/// Eigen-decomposition of a symmetric covariance with eigenvectors sorted
/// by descending eigenvalue and made right-handed (eqs. 28–29).
pub fn frame_from_covariance(cov: Mat3) -> Frame {
    let cov = 0.5 * (cov + cov.transpose());
    if !cov.iter().all(|v| v.is_finite()) {
        return Frame {
            axes: Mat3::identity(),
            eigenvalues: [0.0; 3],
        };
    }
    let eig = nalgebra::SymmetricEigen::new(cov);
    let mut idx = [0usize, 1, 2];
    // descending; ties broken by index so the result is deterministic
    idx.sort_by(|&a, &b| {
        eig.eigenvalues[b]
            .total_cmp(&eig.eigenvalues[a])
            .then(a.cmp(&b))
    });
    let b1: Vec3 = eig.eigenvectors.column(idx[0]).into_owned();
    let b2: Vec3 = eig.eigenvectors.column(idx[1]).into_owned();
    let b3 = b1.cross(&b2);
    let axes = Mat3::from_columns(&[b1, b2, b3]);
    let ev = [
        eig.eigenvalues[idx[0]].max(0.0),
        eig.eigenvalues[idx[1]].max(0.0),
        eig.eigenvalues[idx[2]].max(0.0),
    ];
    Frame {
        axes,
        eigenvalues: ev,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plane_frame_has_normal_along_plane_normal() {
        let n = Vec3::new(1.0, 2.0, 2.0).normalize();
        let t1 = Vec3::new(2.0, -1.0, 0.0).normalize();
        let t2 = n.cross(&t1);
        let c = Vec3::new(0.3, -0.2, 0.7);
        let pts: Vec<Vec3> = (-3..=3)
            .flat_map(|i| (-3..=3).map(move |j| (i as Real, j as Real)))
            .filter(|&(i, j)| i != 0.0 || j != 0.0)
            .map(|(i, j)| c + 0.02 * (i * t1 + j * t2))
            .collect();
        let f = pca_frame(&c, pts.into_iter(), 0.1);
        assert!((f.axis(2).dot(&n).abs() - 1.0).abs() < 1e-12);
        assert!(f.eigenvalues[2] < 1e-15 * f.eigenvalues[0].max(1e-30) + 1e-20);
        assert!((f.axes.determinant() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn line_frame_has_tangent_first() {
        let t = Vec3::new(0.0, 3.0, 4.0).normalize();
        let c = Vec3::new(1.0, 1.0, 1.0);
        let pts = (-4..=4)
            .filter(|&i| i != 0)
            .map(|i| c + 0.02 * i as Real * t);
        let f = pca_frame(&c, pts, 0.1);
        assert!((f.axis(0).dot(&t).abs() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn isolated_point_gives_identity_frame_without_nan() {
        let f = pca_frame(&Vec3::new(1.0, 2.0, 3.0), std::iter::empty(), 0.1);
        assert!(f.axes.iter().all(|v| v.is_finite()));
        assert_eq!(f.eigenvalues, [0.0; 3]);
    }
}
