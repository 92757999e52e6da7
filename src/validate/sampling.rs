//! Point samplings of analytic shapes for the validation cases.
//!
//! The sphere follows the paper's Appendix F: particles placed evenly on
//! circles of latitude, circles spaced Δ apart along the meridian and
//! particles Δ apart along each circle (the poles are single particles).
//! Optional jitter moves each point tangentially by up to `jitter · Δ` in
//! each tangent direction (uniform, deterministic seed) and projects it back
//! onto the shape.

use crate::math::{Real, Vec3};
use std::f64::consts::PI;

/// Deterministic pseudo-random numbers in [0, 1) (SplitMix64).
pub fn rand01(state: &mut u64) -> Real {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    ((z ^ (z >> 31)) >> 11) as Real / (1u64 << 53) as Real
}

/// Spacing Δ that gives about `n` particles on a sphere of radius `r`.
pub fn sphere_spacing_for(n: usize, r: Real) -> Real {
    (4.0 * PI * r * r / n.max(1) as Real).sqrt()
}

/// Appendix F sphere: radius `r`, spacing `spacing`, tangential jitter as a
/// fraction of the spacing, deterministic `seed`.
pub fn sphere_latitude(r: Real, spacing: Real, jitter: Real, seed: u64) -> Vec<Vec3> {
    let n_lat = ((PI * r / spacing).round() as usize).max(1);
    let mut pts = Vec::new();
    for i in 0..=n_lat {
        let theta = PI * i as Real / n_lat as Real;
        let ring = ((2.0 * PI * r * theta.sin() / spacing).round() as usize).max(1);
        let phase = if i % 2 == 0 { 0.0 } else { 0.5 };
        for j in 0..ring {
            let phi = 2.0 * PI * (j as Real + phase) / ring as Real;
            pts.push(
                r * Vec3::new(
                    theta.sin() * phi.cos(),
                    theta.sin() * phi.sin(),
                    theta.cos(),
                ),
            );
        }
    }
    if jitter > 0.0 {
        let mut s = seed;
        for p in pts.iter_mut() {
            let n = p.normalize();
            let a = if n.x.abs() < 0.9 {
                Vec3::x()
            } else {
                Vec3::y()
            };
            let t1 = n.cross(&a).normalize();
            let t2 = n.cross(&t1);
            let d = jitter
                * spacing
                * ((2.0 * rand01(&mut s) - 1.0) * t1 + (2.0 * rand01(&mut s) - 1.0) * t2);
            *p = r * (*p + d).normalize();
        }
    }
    pts
}

/// Torus with tube radius `a` around a centre circle of radius `c` in the
/// xy-plane, spacing about Δ on both circle families.
pub fn torus(c: Real, a: Real, spacing: Real) -> Vec<Vec3> {
    let nv = ((2.0 * PI * a / spacing).round() as usize).max(3);
    let mut pts = Vec::new();
    for i in 0..nv {
        let v = 2.0 * PI * i as Real / nv as Real;
        let rad = c + a * v.cos();
        let nu = ((2.0 * PI * rad / spacing).round() as usize).max(3);
        let phase = if i % 2 == 0 { 0.0 } else { 0.5 };
        for j in 0..nu {
            let u = 2.0 * PI * (j as Real + phase) / nu as Real;
            pts.push(Vec3::new(rad * u.cos(), rad * u.sin(), a * v.sin()));
        }
    }
    pts
}

/// Cylinder of radius `r` along z, z ∈ [−len/2, len/2], spacing Δ.
pub fn cylinder(r: Real, len: Real, spacing: Real) -> Vec<Vec3> {
    let nu = ((2.0 * PI * r / spacing).round() as usize).max(3);
    let nz = ((len / spacing).round() as usize).max(1);
    let mut pts = Vec::new();
    for k in 0..=nz {
        let z = -0.5 * len + len * k as Real / nz as Real;
        let phase = if k % 2 == 0 { 0.0 } else { 0.5 };
        for j in 0..nu {
            let u = 2.0 * PI * (j as Real + phase) / nu as Real;
            pts.push(Vec3::new(r * u.cos(), r * u.sin(), z));
        }
    }
    pts
}

/// Circle of radius `r` in the xy-plane, spacing Δ.
pub fn circle(r: Real, spacing: Real) -> Vec<Vec3> {
    let n = ((2.0 * PI * r / spacing).round() as usize).max(3);
    (0..n)
        .map(|j| {
            let u = 2.0 * PI * j as Real / n as Real;
            Vec3::new(r * u.cos(), r * u.sin(), 0.0)
        })
        .collect()
}

/// Helix (r cos u, r sin u, c u), u ∈ [0, turns·2π], spacing Δ in arc length.
/// Its curvature is r / (r² + c²).
pub fn helix(r: Real, c: Real, turns: Real, spacing: Real) -> Vec<Vec3> {
    let speed = (r * r + c * c).sqrt();
    let umax = turns * 2.0 * PI;
    let n = ((umax * speed / spacing).round() as usize).max(2);
    (0..=n)
        .map(|j| {
            let u = umax * j as Real / n as Real;
            Vec3::new(r * u.cos(), r * u.sin(), c * u)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn appendix_f_sphere_has_expected_count_and_radius() {
        let p = sphere_latitude(1.0, 0.0205, 0.0, 1);
        // 4π/Δ² ≈ 29,900
        assert!(
            (p.len() as Real - 4.0 * PI / 0.0205f64.powi(2)).abs() < 300.0,
            "{}",
            p.len()
        );
        assert!(p.iter().all(|x| (x.norm() - 1.0).abs() < 1e-14));
        let j = sphere_latitude(1.0, 0.05, 0.2, 3);
        assert!(j.iter().all(|x| (x.norm() - 1.0).abs() < 1e-14));
    }
}
