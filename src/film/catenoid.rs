//! The film catenoid (paper Fig. 6, Appendix E): a cylindrical membrane
//! spanning two coaxial rings of radius R. With the rings at separation
//! d < 1.3255 R the film settles to the minimal surface r(z) = a cosh(z/a),
//! R = a cosh(d/2a) (the larger root, the stable branch); pulled beyond the
//! critical separation the neck pinches.
//!
//! Sampling (Appendix F, "sampled in a similar way" to the circle patterns):
//! circles along the axis at spacing s, each with round(2πR/s) particles;
//! the first and last circles are the rings: static boundary particles
//! (Appendix C) that take part in the sheet fits but move only with their
//! prescribed velocity.

use crate::math::{Real, Vec3};
use crate::particles::{Codim, Particles};

/// Geometry of a catenoid film.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CatenoidSetup {
    /// Ring radius R (m).
    pub radius: Real,
    /// Initial ring separation d (m).
    pub length: Real,
    /// Particle spacing s (m).
    pub spacing: Real,
    /// Film thickness τ (m).
    pub thickness: Real,
    /// Density ρ (kg/m³).
    pub density: Real,
    /// Speed at which each ring moves away from the middle along the axis (m/s).
    pub ring_speed: Real,
}

impl CatenoidSetup {
    /// The paper's catenoid (R = 0.0512 m, length 0.0384 m) at spacing `s`, 1 µm thick, static rings.
    pub fn paper(spacing: Real) -> CatenoidSetup {
        CatenoidSetup {
            radius: 0.0512,
            length: 0.0384,
            spacing,
            thickness: 1e-6,
            density: 1000.0,
            ring_speed: 0.0,
        }
    }

    /// Samples the membrane and its rings; the axis is z, the middle at z = 0.
    pub fn particles(&self) -> Particles {
        let s = self.spacing;
        let nz = (self.length / s).round().max(2.0) as usize;
        let dz = self.length / nz as Real;
        let nt = (2.0 * std::f64::consts::PI * self.radius / s).round() as usize;
        let area = 2.0 * std::f64::consts::PI * self.radius / nt as Real * dz;
        let mass = self.density * self.thickness * area;
        let mut p = Particles::new();
        for k in 0..=nz {
            let z = -0.5 * self.length + k as Real * dz;
            let ring = k == 0 || k == nz;
            let phase = if k % 2 == 0 { 0.0 } else { 0.5 };
            for i in 0..nt {
                let t = 2.0 * std::f64::consts::PI * (i as Real + phase) / nt as Real;
                let x = Vec3::new(self.radius * t.cos(), self.radius * t.sin(), z);
                let v = if ring {
                    Vec3::new(0.0, 0.0, z.signum() * self.ring_speed)
                } else {
                    Vec3::zeros()
                };
                let j = p.push(x, v, mass, 0.5 * self.thickness, Codim::Sheet);
                p.fixed[j] = ring;
            }
        }
        p
    }
}

/// Neck parameter a of the stable catenoid through rings of radius `r` at
/// separation `d`, or `None` beyond the critical separation (d > 1.3255 R).
pub fn catenoid_neck(r: Real, d: Real) -> Option<Real> {
    // a cosh(d/2a) has its minimum where u tanh u = 1, u = d/2a
    let mut u: Real = 1.2;
    for _ in 0..50 {
        u -= (u * u.tanh() - 1.0) / (u.tanh() + u / u.cosh().powi(2));
    }
    let a_min = 0.5 * d / u;
    let g = |a: Real| a * (0.5 * d / a).cosh() - r;
    if g(a_min) > 0.0 {
        return None;
    }
    let (mut lo, mut hi) = (a_min, r);
    for _ in 0..200 {
        let m = 0.5 * (lo + hi);
        if g(m) > 0.0 {
            hi = m
        } else {
            lo = m
        }
    }
    Some(0.5 * (lo + hi))
}

/// Radius of the film at its middle: mean distance to the axis of the
/// non-fixed sheet particles with |z| below `band`.
pub fn neck_radius(p: &Particles, band: Real) -> Option<Real> {
    let (mut s, mut n) = (0.0, 0);
    for i in 0..p.len() {
        if !p.fixed[i] && p.codim[i] == Codim::Sheet && p.x[i].z.abs() < band {
            s += p.x[i].x.hypot(p.x[i].y);
            n += 1;
        }
    }
    (n > 0).then(|| s / n as Real)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn analytic_neck() {
        // critical separation d/R = 1.3255
        assert!(catenoid_neck(1.0, 1.32).is_some());
        assert!(catenoid_neck(1.0, 1.34).is_none());
        let a = catenoid_neck(0.0512, 0.0384).unwrap();
        assert!((a * (0.0192 / a).cosh() - 0.0512).abs() < 1e-12);
        assert!(a > 0.047 && a < 0.048, "{a}");
    }

    #[test]
    fn sampling_has_rings_and_uniform_mass() {
        let p = CatenoidSetup::paper(0.002).particles();
        let rings = p.fixed.iter().filter(|f| **f).count();
        assert_eq!(
            rings,
            2 * (2.0 * std::f64::consts::PI * 0.0512 / 0.002).round() as usize
        );
        let area: Real = p.mass.iter().sum::<Real>() / (1000.0 * 1e-6);
        let exact = 2.0 * std::f64::consts::PI * 0.0512 * (0.0384 + 0.0384 / 19.0);
        assert!((area / exact - 1.0).abs() < 1e-9, "{area} {exact}");
    }
}
