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
                    let radial = (rel - a * t).norm() - r;
                    let axial = t.abs() - half;
                    let ox = radial.max(0.0);
                    let oy = axial.max(0.0);
                    (ox * ox + oy * oy).sqrt() + radial.max(axial).min(0.0)
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

    /// Moves `x` out of the solids to signed distance at least `margin`.
    /// Returns true when the point was inside (a counted correction).
    pub fn push_out(&self, x: &mut Vec3, margin: Real, h: Real) -> bool {
        if self.shapes.is_empty() {
            return false;
        }
        let mut moved = false;
        for _ in 0..8 {
            let p = self.phi(x);
            if p >= margin {
                break;
            }
            let n = self.normal(x, h);
            *x += n * (margin - p);
            moved = true;
        }
        moved
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
