//! Scalar and small fixed-size vector types used throughout the solver.
//!
//! The solver works in `f64` (`Real`) everywhere; nalgebra supplies the small
//! fixed-size algebra (3-vectors, 3×3 matrices, eigen-decompositions).

/// Floating-point type of the solver.
pub type Real = f64;
/// A 3-vector in world space (metres, metres per second, …).
pub type Vec3 = nalgebra::Vector3<Real>;
/// A 3×3 matrix (covariances, frames).
pub type Mat3 = nalgebra::Matrix3<Real>;

/// Squared Euclidean distance between two points.
#[inline]
pub fn dist2(a: &Vec3, b: &Vec3) -> Real {
    (a - b).norm_squared()
}
