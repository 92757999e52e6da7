//! Sampling liquid bodies into codimension-0 particles (paper Appendix F).
//!
//! Boxes, ellipsoids and cylinders: a regular lattice at spacing `spacing·Δx`
//! (a box's lattice is stretched by at most half a spacing so that it fills the
//! box exactly). Spheres: equidistributed concentric shells at equidistant
//! radii, each shell sampled on circles of latitude whose spacing, and the
//! spacing of particles along each circle, equal the particle spacing
//! (Appendix F). Masses are uniform per body, m = ρV/N with V the body's exact
//! volume; the radius is the sphere-equivalent r = (3m / 4πρ)^{1/3}.

use super::{FluidBody, Scene};
use crate::math::{Real, Vec3};
use crate::particles::{Codim, Particles};
use crate::solids::SolidSet;
use std::f64::consts::PI;

/// What sampling produced.
#[derive(Clone, Debug, Default)]
pub struct SampleReport {
    /// Particles kept per body.
    pub per_body: Vec<usize>,
    /// Samples dropped because they fell inside a solid.
    pub dropped_in_solid: usize,
}

fn lattice(lo: Vec3, hi: Vec3, s: Real, inside: impl Fn(&Vec3) -> bool) -> Vec<Vec3> {
    let n: Vec<usize> = (0..3)
        .map(|d| (((hi[d] - lo[d]) / s).round() as usize).max(1))
        .collect();
    let step = Vec3::new(
        (hi[0] - lo[0]) / n[0] as Real,
        (hi[1] - lo[1]) / n[1] as Real,
        (hi[2] - lo[2]) / n[2] as Real,
    );
    let mut out = Vec::new();
    for k in 0..n[2] {
        for j in 0..n[1] {
            for i in 0..n[0] {
                let p = lo
                    + Vec3::new(
                        (i as Real + 0.5) * step.x,
                        (j as Real + 0.5) * step.y,
                        (k as Real + 0.5) * step.z,
                    );
                if inside(&p) {
                    out.push(p);
                }
            }
        }
    }
    out
}

fn sphere_shells(c: Vec3, r: Real, s: Real) -> Vec<Vec3> {
    let shells = ((r / s).round() as usize).max(1);
    let dr = r / shells as Real;
    let mut out = Vec::new();
    for k in 0..shells {
        let rk = (k as Real + 0.5) * dr;
        let n_lat = ((PI * rk / s).round() as usize).max(1);
        for j in 0..n_lat {
            let theta = (j as Real + 0.5) * PI / n_lat as Real;
            let rho = rk * theta.sin();
            let n_lon = ((2.0 * PI * rho / s).round() as usize).max(1);
            // offset every other circle by half a step to avoid aligned meridians
            let off = if j % 2 == 0 { 0.0 } else { 0.5 };
            for l in 0..n_lon {
                let phi = 2.0 * PI * (l as Real + off) / n_lon as Real;
                out.push(c + Vec3::new(rho * phi.cos(), rk * theta.cos(), rho * phi.sin()));
            }
        }
    }
    out
}

fn v(a: &[f64; 3]) -> Vec3 {
    Vec3::new(a[0], a[1], a[2])
}

/// Samples every body of a (validated) scene; samples inside solids are dropped and counted.
pub fn sample_bodies(scene: &Scene, solids: &SolidSet) -> (Particles, SampleReport) {
    let rho = scene.physics.density;
    let dx = scene.domain.dx;
    let mut parts = Particles::new();
    let mut rep = SampleReport::default();
    for b in &scene.bodies {
        let s = b.spacing() * dx;
        let (pts, volume) = match b {
            FluidBody::Box { min, max, .. } => {
                let (lo, hi) = (v(min), v(max));
                let e = hi - lo;
                (lattice(lo, hi, s, |_| true), e.x * e.y * e.z)
            }
            FluidBody::Sphere { center, radius, .. } => (
                sphere_shells(v(center), *radius, s),
                4.0 / 3.0 * PI * radius.powi(3),
            ),
            FluidBody::Ellipsoid { center, radii, .. } => {
                let (c, r) = (v(center), v(radii));
                let pts = lattice(c - r, c + r, s, |p| {
                    let q = (p - c).component_div(&r);
                    q.norm_squared() <= 1.0
                });
                (pts, 4.0 / 3.0 * PI * r.x * r.y * r.z)
            }
            FluidBody::Cylinder {
                center,
                axis,
                radius,
                height,
                ..
            } => {
                let (c, a) = (v(center), v(axis).normalize());
                let e = Vec3::from_fn(|d, _| {
                    0.5 * height * a[d].abs() + radius * (1.0 - a[d] * a[d]).max(0.0).sqrt()
                });
                let pts = lattice(c - e, c + e, s, |p| {
                    let rel = p - c;
                    let t = rel.dot(&a);
                    t.abs() <= 0.5 * height && (rel - a * t).norm() <= *radius
                });
                (pts, PI * radius * radius * height)
            }
        };
        let mass = if pts.is_empty() {
            0.0
        } else {
            rho * volume / pts.len() as Real
        };
        let radius = (3.0 * mass / (4.0 * PI * rho)).cbrt();
        let vel = v(&b.velocity());
        let mut kept = 0;
        for p in pts {
            if solids.phi(&p) < 0.0 {
                rep.dropped_in_solid += 1;
                continue;
            }
            parts.push(p, vel, mass, radius, Codim::Volume);
            kept += 1;
        }
        rep.per_body.push(kept);
    }
    (parts, rep)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sphere_shells_fill_the_ball_uniformly() {
        let (r, s) = (1.0, 0.05);
        let pts = sphere_shells(Vec3::zeros(), r, s);
        // count matches the volume at one particle per s³ within 5 %
        let expect = 4.0 / 3.0 * PI / (s * s * s);
        let n = pts.len() as Real;
        assert!(
            (n / expect - 1.0).abs() < 0.05,
            "n = {n}, expected ≈ {expect}"
        );
        assert!(pts.iter().all(|p| p.norm() < r));
        // centroid at the centre
        let c: Vec3 = pts.iter().sum::<Vec3>() / n;
        assert!(c.norm() < 1e-3, "centroid {c:?}");
    }

    #[test]
    fn box_lattice_is_exact() {
        let pts = lattice(Vec3::zeros(), Vec3::new(1.0, 0.5, 0.25), 0.125, |_| true);
        assert_eq!(pts.len(), 8 * 4 * 2);
    }
}
