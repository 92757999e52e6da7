//! Static solids as signed distance functions (negative inside).
//!
//! Appendix C of the paper treats solids with the standard cut-cell method in
//! the projection; the projection (`grid::projection`) needs the fraction of
//! each MAC face that is open to liquid, which is computed from these SDFs
//! sampled at the face corners (Batty, Bertails, Bridson 2007). The domain box
//! is a closed container handled by the grid's index range, not here.
//! Particles that an advection step carries into a solid are projected back to
//! its surface along the SDF gradient ([`SolidSet::push_out`]), and counted.

use crate::math::{Real, Vec3};
use crate::scene::Solid;

#[derive(Clone, Debug)]
enum Shape {
    Plane {
        p: Vec3,
        n: Vec3,
    },
    Box {
        c: Vec3,
        half: Vec3,
    },
    Sphere {
        c: Vec3,
        r: Real,
    },
    Cylinder {
        c: Vec3,
        a: Vec3,
        r: Real,
        half: Real,
    },
    Pipe {
        c: Vec3,
        a: Vec3,
        r_in: Real,
        r_out: Real,
        half: Real,
    },
}

/// Signed distance to the rectangle |q.0| ≤ 0, |q.1| ≤ 0 given the signed
/// slab distances q (exact for a solid of revolution in its meridian plane).
fn rect(q0: Real, q1: Real) -> Real {
    let (o0, o1) = (q0.max(0.0), q1.max(0.0));
    (o0 * o0 + o1 * o1).sqrt() + q0.max(q1).min(0.0)
}

/// The union of the scene's static solids.
#[derive(Clone, Debug, Default)]
pub struct SolidSet {
    shapes: Vec<Shape>,
}

/// Distance value used when there is no solid at all (m).
pub const FAR: Real = 1e30;

fn v(a: &[f64; 3]) -> Vec3 {
    Vec3::new(a[0], a[1], a[2])
}

impl SolidSet {
    /// Builds the set from the scene's solids (validated: non-zero axes and normals).
    pub fn from_scene(solids: &[Solid]) -> SolidSet {
        let shapes = solids
            .iter()
            .map(|s| match s {
                Solid::Plane { point, normal } => Shape::Plane {
                    p: v(point),
                    n: v(normal).normalize(),
                },
                Solid::Box { min, max } => Shape::Box {
                    c: (v(min) + v(max)) * 0.5,
                    half: (v(max) - v(min)) * 0.5,
                },
                Solid::Sphere { center, radius } => Shape::Sphere {
                    c: v(center),
                    r: *radius,
                },
                Solid::Cylinder {
                    center,
                    axis,
                    radius,
                    height,
                } => Shape::Cylinder {
                    c: v(center),
                    a: v(axis).normalize(),
                    r: *radius,
                    half: 0.5 * height,
                },
                Solid::Pipe {
                    center,
                    axis,
                    inner_radius,
                    outer_radius,
                    height,
                } => Shape::Pipe {
                    c: v(center),
                    a: v(axis).normalize(),
                    r_in: *inner_radius,
                    r_out: *outer_radius,
                    half: 0.5 * height,
                },
            })
            .collect();
        SolidSet { shapes }
    }

    /// True when the scene has no solid besides the domain walls.
    pub fn is_empty(&self) -> bool {
        self.shapes.is_empty()
    }

    /// Signed distance to the union of solids (m), negative inside; [`FAR`] if none.
    pub fn phi(&self, x: &Vec3) -> Real {
        let mut d = FAR;
        for s in &self.shapes {
            let e = match s {
                Shape::Plane { p, n } => (x - p).dot(n),
                Shape::Box { c, half } => {
                    let q = (x - c).abs() - half;
                    let out = q.map(|t| t.max(0.0)).norm();
                    out + q.max().min(0.0)
                }
                Shape::Sphere { c, r } => (x - c).norm() - r,
                Shape::Cylinder { c, a, r, half } => {
                    let rel = x - c;
                    let t = rel.dot(a);
                    rect((rel - a * t).norm() - r, t.abs() - half)
                }
                Shape::Pipe {
                    c,
                    a,
                    r_in,
                    r_out,
                    half,
                } => {
                    // the wall is the rectangle r_in ≤ ρ ≤ r_out, |t| ≤ half
                    // in the meridian plane (ρ, t)
                    let rel = x - c;
                    let t = rel.dot(a);
                    let rho = (rel - a * t).norm();
                    let radial = (rho - 0.5 * (r_in + r_out)).abs() - 0.5 * (r_out - r_in);
                    rect(radial, t.abs() - half)
                }
            };
            d = d.min(e);
        }
        d
    }

    /// Unit outward normal of the solid union at `x` (central differences of [`Self::phi`]).
    pub fn normal(&self, x: &Vec3, h: Real) -> Vec3 {
        let mut g = Vec3::zeros();
        for d in 0..3 {
            let mut e = Vec3::zeros();
            e[d] = h;
            g[d] = self.phi(&(x + e)) - self.phi(&(x - e));
        }
        let n = g.norm();
        if n > 0.0 {
            g / n
        } else {
            Vec3::new(0.0, 1.0, 0.0)
        }
    }

    /// Moves `x` out of the solids to signed distance at least `margin`
    /// ([`Self::push_out_in_box`] with no box). Returns true when the point
    /// was inside (a counted correction).
    pub fn push_out(&self, x: &mut Vec3, margin: Real, h: Real) -> bool {
        let far = Vec3::repeat(Real::INFINITY);
        self.push_out_in_box(x, &-far, &far, margin, h).0
    }

    /// Moves `x` out of the solids to signed distance at least `margin`
    /// while keeping it in the box `[lo + margin, hi − margin]`: the point
    /// is clamped to the box, and the push along the solid's normal drops
    /// the components that point out through a wall the point lies on, so a
    /// point where a solid meets a wall slides along the wall instead of
    /// bouncing between the two.
    /// Returns (pushed out of a solid, clamped to the box).
    pub fn push_out_in_box(
        &self,
        x: &mut Vec3,
        lo: &Vec3,
        hi: &Vec3,
        margin: Real,
        h: Real,
    ) -> (bool, bool) {
        let (mut pushed, mut clamped) = (false, false);
        for _ in 0..16 {
            for d in 0..3 {
                let q = x[d].clamp(lo[d] + margin, hi[d] - margin);
                if q != x[d] {
                    clamped = true;
                    x[d] = q;
                }
            }
            if self.shapes.is_empty() {
                break;
            }
            let p = self.phi(x);
            if p >= margin {
                break;
            }
            let mut n = self.normal(x, h);
            for d in 0..3 {
                if (x[d] <= lo[d] + margin && n[d] < 0.0) || (x[d] >= hi[d] - margin && n[d] > 0.0)
                {
                    n[d] = 0.0;
                }
            }
            let nn = n.norm_squared();
            if nn < 1e-12 {
                break;
            }
            // φ(x + t n') ≈ φ + t n·n' = φ + t |n'|²
            *x += n * ((margin - p) / nn);
            pushed = true;
        }
        (pushed, clamped)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_point_where_a_solid_meets_a_wall_ends_outside_both() {
        // the dam-break bump: a sphere centred 0.05 inside the box crossing
        // the wall z = 0; points just inside it, at and beside the wall
        let s = SolidSet::from_scene(&[Solid::Sphere {
            center: [0.25, 0.0, 0.05],
            radius: 0.06,
        }]);
        let (lo, hi) = (Vec3::zeros(), Vec3::new(0.4, 0.3, 0.1));
        let m = 1.25e-5;
        for start in [
            Vec3::new(0.259, 0.0317, -8.5e-5),
            Vec3::new(0.259, 0.0317, 0.0),
            Vec3::new(0.25, 0.01, 1e-3),
            Vec3::new(0.27, 0.01, 0.099),
        ] {
            let mut x = start;
            let (pushed, _) = s.push_out_in_box(&mut x, &lo, &hi, m, 1e-6);
            assert!(pushed, "{start:?} starts inside the sphere");
            assert!(
                s.phi(&x) >= m * (1.0 - 1e-6),
                "{start:?} → {x:?}: φ = {}",
                s.phi(&x)
            );
            for d in 0..3 {
                assert!(
                    x[d] >= lo[d] + m && x[d] <= hi[d] - m,
                    "{start:?} → {x:?} leaves the box"
                );
            }
        }
    }

    #[test]
    fn distances_of_each_shape() {
        let s = SolidSet::from_scene(&[
            Solid::Sphere {
                center: [0.0; 3],
                radius: 1.0,
            },
            Solid::Box {
                min: [2.0, 0.0, 0.0],
                max: [3.0, 1.0, 1.0],
            },
            Solid::Cylinder {
                center: [0.0, 5.0, 0.0],
                axis: [0.0, 0.0, 2.0],
                radius: 0.5,
                height: 2.0,
            },
        ]);
        assert!((s.phi(&Vec3::new(0.0, 2.0, 0.0)) - 1.0).abs() < 1e-12);
        assert!((s.phi(&Vec3::new(2.5, 0.5, 0.5)) + 0.5).abs() < 1e-12);
        assert!((s.phi(&Vec3::new(0.0, 5.0, 0.0)) + 0.5).abs() < 1e-12);
        assert!((s.phi(&Vec3::new(0.0, 5.0, 3.0)) - 2.0).abs() < 1e-12);
        let mut x = Vec3::new(0.1, 0.2, 0.0);
        assert!(s.push_out(&mut x, 1e-3, 1e-6));
        assert!(s.phi(&x) >= 1e-3 - 1e-9);
    }

    #[test]
    fn pipe_distance_is_exact_around_the_wall() {
        // nozzle along y: bore radius 1, wall to radius 1.5, from y = 1 to y = 3
        let s = SolidSet::from_scene(&[Solid::Pipe {
            center: [0.0, 2.0, 0.0],
            axis: [0.0, -3.0, 0.0],
            inner_radius: 1.0,
            outer_radius: 1.5,
            height: 2.0,
        }]);
        let phi = |x: Real, y: Real, z: Real| s.phi(&Vec3::new(x, y, z));
        // on the axis (in the bore): distance to the inner wall
        assert!((phi(0.0, 2.0, 0.0) - 1.0).abs() < 1e-12);
        // inside the wall, middle of its thickness: −0.25
        assert!((phi(1.25, 2.0, 0.0) + 0.25).abs() < 1e-12);
        assert!((phi(0.0, 2.0, -1.25) + 0.25).abs() < 1e-12);
        // near an end: closer to the rim face than to the sides
        assert!((phi(1.25, 2.9, 0.0) + 0.1).abs() < 1e-12);
        // outside, radially
        assert!((phi(0.0, 2.0, 2.0) - 0.5).abs() < 1e-12);
        // below the nozzle, in line with the wall: distance to the rim face
        assert!((phi(1.2, 0.5, 0.0) - 0.5).abs() < 1e-12);
        // below the nozzle on the axis: distance to the inner rim corner (ρ = 1, y = 1)
        assert!((phi(0.0, 0.0, 0.0) - 2.0f64.sqrt()).abs() < 1e-12);
        // liquid in the bore is not pushed out; a point in the wall is, to the nearer face
        let mut x = Vec3::new(0.0, 2.0, 0.5);
        assert!(!s.push_out(&mut x, 1e-3, 1e-6));
        let mut x = Vec3::new(1.1, 2.0, 0.0);
        assert!(s.push_out(&mut x, 1e-3, 1e-6));
        assert!((x.x - (1.0 - 1e-3)).abs() < 1e-6, "{x:?}");
        // gradient of a distance function has unit length away from the medial surfaces
        for p in [
            Vec3::new(0.3, 2.2, 0.1),
            Vec3::new(1.7, 2.4, 0.2),
            Vec3::new(1.3, 0.4, 0.1),
        ] {
            let g = Vec3::from_fn(|d, _| {
                let mut e = Vec3::zeros();
                e[d] = 1e-6;
                (s.phi(&(p + e)) - s.phi(&(p - e))) / 2e-6
            });
            assert!(
                (g.norm() - 1.0).abs() < 1e-6,
                "{p:?}: |grad| = {}",
                g.norm()
            );
        }
    }
}
