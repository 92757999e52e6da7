//! Curvature-vector validation: κn = Δx (the Laplace–Beltrami operator of
//! the position, paper §6 uses it for surface tension) against analytic
//! values on sampled shapes, at several resolutions with h = c·Δ.
//!
//! | shape | codim | analytic Δx |
//! |---|---|---|
//! | unit sphere | sheet | −2 x |
//! | torus (C = 1.5, a = 0.6) | sheet | −(1/a + cos v/(C + a cos v)) n |
//! | cylinder (R = 0.6) | sheet | −(1/R) n (ends excluded by 2h) |
//! | circle (R = 1) | filament | −x/R² |
//! | helix (r = 1, c = 0.3) | filament | −r/(r² + c²) (cos u, sin u, 0) (ends excluded) |
//!
//! n is the outward unit normal. Error: |Δx − κn| / |κn| per particle,
//! max and mean over the evaluated particles.

use super::sampling::{circle, cylinder, helix, sphere_latitude, torus};
use super::{observed_orders, ValidateError};
use crate::math::{Real, Vec3};
use crate::mls::{FitStats, JointLaplacian, MlsParams, Neighborhoods};
use crate::particles::Codim;
use serde::Serialize;

/// The shapes of the study.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum CurvatureShape {
    /// Unit sphere (sheet).
    Sphere,
    /// Torus C = 1.5, a = 0.6 (sheet).
    Torus,
    /// Cylinder R = 0.6, length 3 (sheet).
    Cylinder,
    /// Unit circle (filament).
    Circle,
    /// Helix r = 1, pitch c = 0.3, 2 turns (filament).
    Helix,
}

impl CurvatureShape {
    /// All shapes.
    pub const ALL: [CurvatureShape; 5] = [
        CurvatureShape::Sphere,
        CurvatureShape::Torus,
        CurvatureShape::Cylinder,
        CurvatureShape::Circle,
        CurvatureShape::Helix,
    ];

    fn sample(self, spacing: Real) -> (Vec<Vec3>, Codim) {
        match self {
            CurvatureShape::Sphere => (sphere_latitude(1.0, spacing, 0.0, 1), Codim::Sheet),
            CurvatureShape::Torus => (torus(1.5, 0.6, spacing), Codim::Sheet),
            CurvatureShape::Cylinder => (cylinder(0.6, 3.0, spacing), Codim::Sheet),
            CurvatureShape::Circle => (circle(1.0, spacing), Codim::Filament),
            CurvatureShape::Helix => (helix(1.0, 0.3, 2.0, spacing), Codim::Filament),
        }
    }

    /// Analytic curvature vector at `x`, or `None` where the point is not
    /// evaluated (near an open end, within `margin`).
    fn exact(self, x: &Vec3, margin: Real) -> Option<Vec3> {
        match self {
            CurvatureShape::Sphere => Some(-2.0 * x),
            CurvatureShape::Torus => {
                let rad = (x.x * x.x + x.y * x.y).sqrt();
                let v = x.z.atan2(rad - 1.5);
                let u = x.y.atan2(x.x);
                let n = Vec3::new(v.cos() * u.cos(), v.cos() * u.sin(), v.sin());
                Some(-(1.0 / 0.6 + v.cos() / (1.5 + 0.6 * v.cos())) * n)
            }
            CurvatureShape::Cylinder => (x.z.abs() < 1.5 - margin)
                .then(|| -(1.0 / 0.6) * Vec3::new(x.x, x.y, 0.0).normalize()),
            CurvatureShape::Circle => Some(-x),
            CurvatureShape::Helix => {
                let u = x.z / 0.3;
                let umax = 2.0 * 2.0 * std::f64::consts::PI;
                let m = margin / (1.0f64 + 0.09).sqrt();
                (u > m && u < umax - m).then(|| -(1.0 / 1.09) * Vec3::new(u.cos(), u.sin(), 0.0))
            }
        }
    }
}

/// One resolution.
#[derive(Clone, Debug, Serialize)]
pub struct CurvatureRun {
    /// Particle count.
    pub particles: usize,
    /// Spacing Δ (m).
    pub spacing: Real,
    /// Support radius h (m).
    pub h: Real,
    /// Particles evaluated (open ends excluded).
    pub evaluated: usize,
    /// max |Δx − κn| / |κn|.
    pub max_rel_error: Real,
    /// mean |Δx − κn| / |κn|.
    pub mean_rel_error: Real,
    /// Fit fallbacks.
    pub fit_stats: FitStats,
}

/// A shape at several resolutions.
#[derive(Clone, Debug, Serialize)]
pub struct CurvatureStudy {
    /// The shape.
    pub shape: CurvatureShape,
    /// Coarse to fine.
    pub runs: Vec<CurvatureRun>,
    /// Observed order of the max error between consecutive runs.
    pub observed_order_max: Vec<Real>,
    /// Observed order of the mean error.
    pub observed_order_mean: Vec<Real>,
}

/// Curvature error of `shape` at one spacing with h = `h_over_spacing`·Δ;
/// `base` gives the other operator parameters.
pub fn curvature_run(
    shape: CurvatureShape,
    spacing: Real,
    h_over_spacing: Real,
    base: &MlsParams,
) -> Result<CurvatureRun, ValidateError> {
    if !(spacing > 0.0 && spacing.is_finite()) {
        return Err(ValidateError::Param {
            what: "spacing",
            value: spacing,
            reason: "must be positive and finite",
        });
    }
    let params = MlsParams {
        h: h_over_spacing * spacing,
        ..*base
    };
    params.validate()?;
    let (x, codim) = shape.sample(spacing);
    let nb = Neighborhoods::build(&x, &vec![codim; x.len()], params.h)?;
    let l = JointLaplacian::assemble(&nb, &params)?;
    let kn = l.apply_vec3(&nb.x);
    let errs: Vec<Real> =
        nb.x.iter()
            .zip(&kn)
            .filter_map(|(p, k)| {
                shape
                    .exact(p, 2.0 * params.h)
                    .map(|e| (k - e).norm() / e.norm())
            })
            .collect();
    if errs.is_empty() {
        return Err(ValidateError::Param {
            what: "spacing",
            value: spacing,
            reason: "too coarse: h leaves no particle away from the open ends",
        });
    }
    let max = errs.iter().fold(0.0 as Real, |a, &b| {
        if b.is_finite() {
            a.max(b)
        } else {
            Real::INFINITY
        }
    });
    let mean = errs.iter().sum::<Real>() / errs.len().max(1) as Real;
    Ok(CurvatureRun {
        particles: x.len(),
        spacing,
        h: params.h,
        evaluated: errs.len(),
        max_rel_error: max,
        mean_rel_error: mean,
        fit_stats: l.stats,
    })
}

/// [`curvature_run`] at each spacing (coarse to fine) with observed orders.
pub fn curvature_study(
    shape: CurvatureShape,
    spacings: &[Real],
    h_over_spacing: Real,
    base: &MlsParams,
) -> Result<CurvatureStudy, ValidateError> {
    let runs = spacings
        .iter()
        .map(|&s| curvature_run(shape, s, h_over_spacing, base))
        .collect::<Result<Vec<_>, _>>()?;
    let sp: Vec<Real> = runs.iter().map(|r| r.spacing).collect();
    let emax: Vec<Real> = runs.iter().map(|r| r.max_rel_error).collect();
    let emean: Vec<Real> = runs.iter().map(|r| r.mean_rel_error).collect();
    Ok(CurvatureStudy {
        shape,
        observed_order_max: observed_orders(&sp, &emax),
        observed_order_mean: observed_orders(&sp, &emean),
        runs,
    })
}
