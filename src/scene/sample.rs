//! Sampling liquid bodies into codimension-0 particles (paper Appendix F).
//!
//! Boxes, ellipsoids and cylinders: a regular lattice at spacing `spacing·Δx`
//! (a box's lattice is stretched by at most half a spacing so that it fills the
//! box exactly). Spheres: equidistributed concentric shells at equidistant
//! radii, each shell sampled on circles of latitude whose spacing, and the
//! spacing of particles along each circle, equal the particle spacing
//! (Appendix F). Masses are uniform per body, m = ρV/N with V the body's exact
//! volume; the radius is the sphere-equivalent r = (3m / 4πρ)^{1/3}.
//!
//! Surface layer (Appendix F: "the outermost layer composed of codimension-1
//! particles"): when [`FluidBody::surface_layer`] holds, the outermost layer
//! becomes sheet particles of the same mass — for lattices the points with a
//! missing lattice neighbour (outside the shape), for spheres the outermost
//! shell. A sheet particle's radius is half its thickness, m / (2ρs²), the
//! particle standing for a patch of area s².

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
    /// Of those, surface-layer (sheet) particles per body.
    pub sheet_per_body: Vec<usize>,
    /// Samples dropped because they fell inside a solid.
    pub dropped_in_solid: usize,
}

/// Lattice points at spacing ≈ `s` in the box [lo, hi] for which `inside`
/// holds, each with a flag: true when one of its six lattice neighbours is
/// missing (outside the shape or the box), i.e. the point is in the
/// outermost layer.
fn lattice(lo: Vec3, hi: Vec3, s: Real, inside: impl Fn(&Vec3) -> bool) -> Vec<(Vec3, bool)> {
    let n: Vec<usize> = (0..3)
        .map(|d| (((hi[d] - lo[d]) / s).round() as usize).max(1))
        .collect();
    let step = Vec3::new(
        (hi[0] - lo[0]) / n[0] as Real,
        (hi[1] - lo[1]) / n[1] as Real,
        (hi[2] - lo[2]) / n[2] as Real,
    );
    let at = |i: usize, j: usize, k: usize| {
        lo + Vec3::new(
            (i as Real + 0.5) * step.x,
            (j as Real + 0.5) * step.y,
            (k as Real + 0.5) * step.z,
        )
    };
    let mut flag = vec![false; n[0] * n[1] * n[2]];
    for k in 0..n[2] {
        for j in 0..n[1] {
            for i in 0..n[0] {
                flag[i + n[0] * (j + n[1] * k)] = inside(&at(i, j, k));
            }
        }
    }
    let has = |i: isize, j: isize, k: isize| {
        i >= 0
            && j >= 0
            && k >= 0
            && (i as usize) < n[0]
            && (j as usize) < n[1]
            && (k as usize) < n[2]
            && flag[i as usize + n[0] * (j as usize + n[1] * k as usize)]
    };
    let mut out = Vec::new();
    for k in 0..n[2] {
        for j in 0..n[1] {
            for i in 0..n[0] {
                if !flag[i + n[0] * (j + n[1] * k)] {
                    continue;
                }
                let (a, b, c) = (i as isize, j as isize, k as isize);
                let outer = !(has(a - 1, b, c)
                    && has(a + 1, b, c)
                    && has(a, b - 1, c)
                    && has(a, b + 1, c)
                    && has(a, b, c - 1)
                    && has(a, b, c + 1));
                out.push((at(i, j, k), outer));
            }
        }
    }
    out
}

/// Concentric shells at equidistant radii, each on circles of latitude; the
/// flag marks the outermost shell.
fn sphere_shells(c: Vec3, r: Real, s: Real) -> Vec<(Vec3, bool)> {
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
                out.push((
                    c + Vec3::new(rho * phi.cos(), rk * theta.cos(), rho * phi.sin()),
                    k + 1 == shells,
                ));
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
        // a surface-layer particle stands for a patch of area s²: half its thickness
        let sheet_radius = 0.5 * mass / (rho * s * s);
        let layer = b.surface_layer(scene.physics.surface_tension);
        let vel = v(&b.velocity());
        let (mut kept, mut sheet) = (0, 0);
        for (p, outer) in pts {
            if solids.phi(&p) < 0.0 {
                rep.dropped_in_solid += 1;
                continue;
            }
            if layer && outer {
                parts.push(p, vel, mass, sheet_radius, Codim::Sheet);
                sheet += 1;
            } else {
                parts.push(p, vel, mass, radius, Codim::Volume);
            }
            kept += 1;
        }
        rep.per_body.push(kept);
        rep.sheet_per_body.push(sheet);
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
        assert!(pts.iter().all(|(p, _)| p.norm() < r));
        // centroid at the centre
        let c: Vec3 = pts.iter().map(|(p, _)| p).sum::<Vec3>() / n;
        assert!(c.norm() < 1e-3, "centroid {c:?}");
        // the outer flag marks exactly the outermost shell (radius r − s/2),
        // about 4π(r − s/2)²/s² particles
        let outer: Vec<_> = pts.iter().filter(|(_, o)| *o).collect();
        assert!(outer
            .iter()
            .all(|(p, _)| (p.norm() - (r - 0.5 * s)).abs() < 1e-12));
        let expect = 4.0 * PI * (r - 0.5 * s).powi(2) / (s * s);
        let m = outer.len() as Real;
        assert!((m / expect - 1.0).abs() < 0.03, "{m} vs {expect}");
    }

    #[test]
    fn box_lattice_is_exact_and_flags_its_faces() {
        let pts = lattice(Vec3::zeros(), Vec3::new(1.0, 0.5, 0.25), 0.125, |_| true);
        assert_eq!(pts.len(), 8 * 4 * 2);
        // 6×5×4 lattice: the 4×3×2 interior is not outer
        let pts = lattice(Vec3::zeros(), Vec3::new(0.6, 0.5, 0.4), 0.1, |_| true);
        assert_eq!(pts.len(), 120);
        assert_eq!(pts.iter().filter(|(_, o)| *o).count(), 120 - 24);
        for (p, o) in &pts {
            let on_face = (0..3).any(|d| p[d] < 0.1 || p[d] > [0.6, 0.5, 0.4][d] - 0.1);
            assert_eq!(*o, on_face, "{p:?}");
        }
    }

    fn scene(sigma: f64, bodies: &str) -> Scene {
        let text = format!(
            "version: 1\ndomain: {{min: [0, 0, 0], max: [1, 1, 1], dx: 0.1}}\n\
             time: {{fps: 30, frames: 1}}\nphysics: {{surface_tension: {sigma}}}\n\
             bodies:\n{bodies}"
        );
        crate::scene::load_str(&text, std::path::Path::new("t.yaml")).unwrap()
    }

    #[test]
    fn surface_layer_follows_sigma_unless_set() {
        let bodies = concat!(
            "  - {kind: box, min: [0.1, 0.1, 0.1], max: [0.7, 0.6, 0.5], spacing: 1.0}\n",
            "  - {kind: box, min: [0.1, 0.1, 0.1], max: [0.7, 0.6, 0.5], spacing: 1.0, surface_layer: false}\n",
            "  - {kind: sphere, center: [0.5, 0.5, 0.5], radius: 0.3, spacing: 0.5}\n",
            "  - {kind: ellipsoid, center: [0.5, 0.5, 0.5], radii: [0.3, 0.2, 0.25], spacing: 0.25}\n",
            "  - {kind: cylinder, center: [0.5, 0.5, 0.5], axis: [0, 1, 0], radius: 0.2, height: 0.4, spacing: 0.25}\n",
        );
        let with = scene(0.03, bodies);
        assert!(with.bodies[0].surface_layer(0.03) && !with.bodies[1].surface_layer(0.03));
        let (p, rep) = sample_bodies(&with, &SolidSet::default());
        // box 6×5×4: 96 outer particles; the second box keeps all volume
        assert_eq!(rep.per_body[0], 120);
        assert_eq!(rep.sheet_per_body[0], 96);
        assert_eq!(rep.sheet_per_body[1], 0);
        // the sphere's outer shell: radius 0.3 − 0.025 at spacing 0.05
        let sphere = 4.0 * PI * 0.275f64.powi(2) / 0.0025;
        assert!((rep.sheet_per_body[2] as f64 / sphere - 1.0).abs() < 0.05);
        // ellipsoid and cylinder: a one-particle layer. A lattice point lies in
        // it when it is closer to the surface than s·max|n_d|, so the layer
        // holds between 1/√3 and 1 particle per s² of area (Thomsen's formula
        // for the ellipsoid's area, error < 1.1 %)
        let e = 1.6075;
        let (a, b, c) = (0.3f64, 0.2f64, 0.25f64);
        let sum = (a * b).powf(e) + (a * c).powf(e) + (b * c).powf(e);
        let ell = 4.0 * PI * (sum / 3.0).powf(1.0 / e) / (0.025 * 0.025);
        let r = rep.sheet_per_body[3] as f64 / ell;
        assert!(
            r > 0.6 && r < 1.0,
            "ellipsoid layer {} vs area/s² {ell}",
            rep.sheet_per_body[3]
        );
        let cyl = (2.0 * PI * 0.2 * 0.4 + 2.0 * PI * 0.04) / (0.025 * 0.025);
        let r = rep.sheet_per_body[4] as f64 / cyl;
        assert!(
            r > 0.6 && r < 1.0,
            "cylinder layer {} vs area/s² {cyl}",
            rep.sheet_per_body[4]
        );
        // same mass as the volume particles of the body; sheet radius = half thickness
        let first = 0..120;
        let m0 = p.mass[0];
        assert!(first.clone().all(|i| p.mass[i] == m0));
        let sheet: Vec<usize> = first.filter(|&i| p.codim[i] == Codim::Sheet).collect();
        assert_eq!(sheet.len(), 96);
        assert!((p.radius[sheet[0]] - 0.5 * m0 / (1000.0 * 0.01)).abs() < 1e-15);
        // without tension no body has a surface layer by default
        let without = scene(0.0, bodies);
        let (p, _) = sample_bodies(&without, &SolidSet::default());
        assert!(p.codim.iter().all(|c| *c == Codim::Volume));
    }
}
