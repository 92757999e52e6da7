//! Software splat renderer for quick looks at particle caches.
//!
//! Each particle is drawn as a shaded disc (a sphere impostor) of its cached
//! radius times a splat factor, with a z-buffer, coloured by codimension
//! (volume blue, sheet green, filament orange, point red). The camera is
//! perspective or orthographic; [`Camera::auto`] frames a bounding box from a
//! fixed three-quarter view.

use crate::math::{Real, Vec3};
use crate::particles::Codim;
use crate::scene::Solid;
use image::{Rgb, RgbImage};

/// A pinhole or orthographic camera.
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    /// Eye position (m).
    pub eye: Vec3,
    /// Look-at point (m).
    pub target: Vec3,
    /// Up direction.
    pub up: Vec3,
    /// Vertical field of view (degrees) for perspective.
    pub fov_deg: Real,
    /// Orthographic projection (half height of the view = distance · tan(fov/2)).
    pub ortho: bool,
}

impl Camera {
    /// Frames the box `[lo, hi]` from azimuth 35°, elevation 25°, y up.
    pub fn auto(lo: Vec3, hi: Vec3, ortho: bool) -> Camera {
        let c = (lo + hi) * 0.5;
        let r = ((hi - lo).norm() * 0.5).max(1e-6);
        let (az, el) = (35f64.to_radians(), 25f64.to_radians());
        let dir = Vec3::new(az.sin() * el.cos(), el.sin(), az.cos() * el.cos());
        let fov: Real = 35.0;
        let dist = 1.08 * r / (0.5 * fov.to_radians()).sin();
        Camera {
            eye: c + dir * dist,
            target: c,
            up: Vec3::new(0.0, 1.0, 0.0),
            fov_deg: fov,
            ortho,
        }
    }
}

/// Display colour of a codimension.
pub fn codim_color(c: Codim) -> [Real; 3] {
    match c {
        Codim::Volume => [0.25, 0.5, 1.0],
        Codim::Sheet => [0.3, 0.85, 0.35],
        Codim::Filament => [1.0, 0.6, 0.15],
        Codim::Point => [0.95, 0.2, 0.2],
    }
}

/// Image size and disc scale of a render.
#[derive(Clone, Copy, Debug)]
pub struct ImageSize {
    /// Width (pixels).
    pub width: u32,
    /// Height (pixels).
    pub height: u32,
    /// Disc radius relative to the particle radius.
    pub splat: Real,
}

/// Display colour of static solids.
pub const SOLID_COLOR: [Real; 3] = [0.55, 0.55, 0.52];

/// Points on the surfaces of the scene's solids, about `h` apart, clipped to
/// the domain box `[lo, hi]`, drawn grey by [`render`] so the liquid can be
/// judged against what it hits.
pub fn solid_points(solids: &[Solid], lo: Vec3, hi: Vec3, h: Real) -> Vec<Vec3> {
    let v = |a: &[f64; 3]| Vec3::new(a[0], a[1], a[2]);
    let inside = |p: &Vec3| (0..3).all(|d| p[d] >= lo[d] - 1e-9 && p[d] <= hi[d] + 1e-9);
    let basis = |n: Vec3| {
        let t = if n.x.abs() < 0.9 {
            Vec3::x()
        } else {
            Vec3::y()
        };
        let a = n.cross(&t).normalize();
        (a, n.cross(&a))
    };
    let mut out = Vec::new();
    let patch = |c: Vec3, a: Vec3, b: Vec3, ra: Real, rb: Real, out: &mut Vec<Vec3>| {
        let (na, nb) = ((2.0 * ra / h).ceil() as i64, (2.0 * rb / h).ceil() as i64);
        for i in 0..=na {
            for j in 0..=nb {
                let p = c
                    + a * (-ra + 2.0 * ra * i as Real / na.max(1) as Real)
                    + b * (-rb + 2.0 * rb * j as Real / nb.max(1) as Real);
                if inside(&p) {
                    out.push(p);
                }
            }
        }
    };
    let diag = (hi - lo).norm();
    for s in solids {
        match s {
            Solid::Plane { point, normal } => {
                let n = v(normal).normalize();
                let (a, b) = basis(n);
                // the plane point closest to the box centre, then a patch covering the box
                let c = (lo + hi) * 0.5;
                let c = c - n * (c - v(point)).dot(&n);
                patch(c, a, b, diag, diag, &mut out);
            }
            Solid::Box { min, max } => {
                let (bl, bh) = (v(min), v(max));
                let c = (bl + bh) * 0.5;
                let e = (bh - bl) * 0.5;
                for d in 0..3 {
                    let (d1, d2) = ((d + 1) % 3, (d + 2) % 3);
                    for sgn in [-1.0, 1.0] {
                        let mut fc = c;
                        fc[d] += sgn * e[d];
                        let mut a = Vec3::zeros();
                        a[d1] = 1.0;
                        let mut b = Vec3::zeros();
                        b[d2] = 1.0;
                        patch(fc, a, b, e[d1], e[d2], &mut out);
                    }
                }
            }
            Solid::Sphere { center, radius } => {
                let n = ((4.0 * std::f64::consts::PI * radius * radius / (h * h)).ceil() as usize)
                    .max(12);
                let ga = std::f64::consts::PI * (3.0 - (5.0 as Real).sqrt());
                for i in 0..n {
                    let z = 1.0 - 2.0 * (i as Real + 0.5) / n as Real;
                    let rho = (1.0 - z * z).sqrt();
                    let t = ga * i as Real;
                    let p = v(center) + Vec3::new(rho * t.cos(), z, rho * t.sin()) * *radius;
                    if inside(&p) {
                        out.push(p);
                    }
                }
            }
            Solid::Cylinder {
                center,
                axis,
                radius,
                height,
            } => {
                let ax = v(axis).normalize();
                let (a, b) = basis(ax);
                let c = v(center);
                let nr = ((2.0 * std::f64::consts::PI * radius / h).ceil() as usize).max(12);
                let nh = ((height / h).ceil() as usize).max(1);
                for i in 0..nr {
                    let t = 2.0 * std::f64::consts::PI * i as Real / nr as Real;
                    let dir = a * t.cos() + b * t.sin();
                    for j in 0..=nh {
                        let p = c + ax * (height * (j as Real / nh as Real - 0.5)) + dir * *radius;
                        if inside(&p) {
                            out.push(p);
                        }
                    }
                    // caps
                    let nc = ((radius / h).ceil() as usize).max(1);
                    for k in 0..nc {
                        for sgn in [-0.5, 0.5] {
                            let p =
                                c + ax * (height * sgn) + dir * (*radius * k as Real / nc as Real);
                            if inside(&p) {
                                out.push(p);
                            }
                        }
                    }
                }
            }
            Solid::Pipe {
                center,
                axis,
                inner_radius,
                outer_radius,
                height,
            } => {
                let ax = v(axis).normalize();
                let (a, b) = basis(ax);
                let c = v(center);
                let nr = ((2.0 * std::f64::consts::PI * outer_radius / h).ceil() as usize).max(12);
                let nh = ((height / h).ceil() as usize).max(1);
                let nw = (((outer_radius - inner_radius) / h).ceil() as usize).max(1);
                for i in 0..nr {
                    let t = 2.0 * std::f64::consts::PI * i as Real / nr as Real;
                    let dir = a * t.cos() + b * t.sin();
                    // inner and outer walls
                    for r in [*inner_radius, *outer_radius] {
                        for j in 0..=nh {
                            let p = c + ax * (height * (j as Real / nh as Real - 0.5)) + dir * r;
                            if inside(&p) {
                                out.push(p);
                            }
                        }
                    }
                    // annular end faces
                    for k in 0..=nw {
                        let r =
                            inner_radius + (outer_radius - inner_radius) * k as Real / nw as Real;
                        for sgn in [-0.5, 0.5] {
                            let p = c + ax * (height * sgn) + dir * r;
                            if inside(&p) {
                                out.push(p);
                            }
                        }
                    }
                }
            }
        }
    }
    out
}

/// Renders particles (and grey solid surface points) into a `width × height` image.
pub fn render(
    x: &[Vec3],
    radius: &[Real],
    codim: &[Codim],
    cam: &Camera,
    size: &ImageSize,
    solid_points: &[Vec3],
    solid_radius: Real,
) -> RgbImage {
    let (width, height, splat) = (size.width, size.height, size.splat);
    let (w, h) = (width as usize, height as usize);
    let f = (cam.target - cam.eye).normalize();
    let mut r = f.cross(&cam.up);
    if r.norm() < 1e-9 {
        r = f.cross(&Vec3::new(1.0, 0.0, 0.0));
    }
    let r = r.normalize();
    let u = r.cross(&f);
    let tan = (0.5 * cam.fov_deg.to_radians()).tan();
    let focal = 0.5 * h as Real / tan;
    let ortho_scale = focal / (cam.target - cam.eye).norm();
    let mut zbuf = vec![Real::INFINITY; w * h];
    let mut col = vec![[0.0f32; 3]; w * h];
    let light = (u * 0.6 - f + r * 0.3).normalize();
    let mut draw = |pos: &Vec3, rw: Real, base: [Real; 3]| {
        let rel = pos - cam.eye;
        let z = rel.dot(&f);
        if !cam.ortho && z <= 1e-6 {
            return;
        }
        let scale = if cam.ortho { ortho_scale } else { focal / z };
        let sx = 0.5 * w as Real + rel.dot(&r) * scale;
        let sy = 0.5 * h as Real - rel.dot(&u) * scale;
        let pr = (rw * scale).max(0.7);
        if sx + pr < 0.0 || sy + pr < 0.0 || sx - pr > w as Real || sy - pr > h as Real {
            return;
        }
        let (x0, x1) = (
            (sx - pr).floor().max(0.0) as usize,
            ((sx + pr).ceil() as usize).min(w),
        );
        let (y0, y1) = (
            (sy - pr).floor().max(0.0) as usize,
            ((sy + pr).ceil() as usize).min(h),
        );
        for py in y0..y1 {
            for px in x0..x1 {
                let dx = (px as Real + 0.5 - sx) / pr;
                let dy = (py as Real + 0.5 - sy) / pr;
                let d2 = dx * dx + dy * dy;
                if d2 > 1.0 {
                    continue;
                }
                let nz = (1.0 - d2).sqrt();
                let depth = z - nz * rw;
                let k = py * w + px;
                if depth < zbuf[k] {
                    zbuf[k] = depth;
                    let n = r * dx - u * dy - f * nz;
                    let shade = 0.3 + 0.7 * n.dot(&light).max(0.0);
                    col[k] = base.map(|c| (c * shade) as f32);
                }
            }
        }
    };
    for i in 0..x.len() {
        draw(&x[i], radius[i] * splat, codim_color(codim[i]));
    }
    for p in solid_points {
        draw(p, solid_radius, SOLID_COLOR);
    }
    RgbImage::from_fn(width, height, |px, py| {
        let k = py as usize * w + px as usize;
        if zbuf[k].is_finite() {
            Rgb(col[k].map(|c| (c.clamp(0.0, 1.0) * 255.0) as u8))
        } else {
            let t = py as f32 / h as f32;
            let g = (28.0 + 24.0 * t) as u8;
            Rgb([g, g, g + 6])
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_particle_in_front_of_the_camera_is_drawn_in_its_colour() {
        let cam = Camera::auto(Vec3::new(-1.0, -1.0, -1.0), Vec3::new(1.0, 1.0, 1.0), false);
        let img = render(
            &[Vec3::zeros()],
            &[0.2],
            &[Codim::Filament],
            &cam,
            &ImageSize {
                width: 64,
                height: 48,
                splat: 1.0,
            },
            &[],
            0.0,
        );
        let c = img.get_pixel(32, 24);
        assert!(c[0] > c[2] && c[0] > 60, "centre pixel {c:?}");
        // corners stay background
        assert_eq!(img.get_pixel(0, 0)[0], img.get_pixel(63, 0)[0]);
    }

    #[test]
    fn solid_points_lie_on_the_solids_and_inside_the_box() {
        let solids = [
            Solid::Sphere {
                center: [0.5, 0.0, 0.5],
                radius: 0.2,
            },
            Solid::Cylinder {
                center: [0.2, 0.5, 0.2],
                axis: [0.0, 1.0, 0.0],
                radius: 0.1,
                height: 0.4,
            },
            Solid::Plane {
                point: [0.0, 0.1, 0.0],
                normal: [0.0, 1.0, 0.0],
            },
            Solid::Pipe {
                center: [0.7, 0.6, 0.7],
                axis: [0.0, 1.0, 0.0],
                inner_radius: 0.05,
                outer_radius: 0.08,
                height: 0.2,
            },
        ];
        let (lo, hi) = (Vec3::zeros(), Vec3::repeat(1.0));
        let pts = solid_points(&solids, lo, hi, 0.02);
        let set = crate::solids::SolidSet::from_scene(&solids);
        assert!(pts.len() > 1000);
        for p in &pts {
            assert!(
                (0..3).all(|d| p[d] >= -1e-9 && p[d] <= 1.0 + 1e-9),
                "{p:?} outside the box"
            );
            // on the union's surface or inside it (caps and overlaps), never outside
            assert!(
                set.phi(p) < 1e-9,
                "{p:?} off the solids: phi = {}",
                set.phi(p)
            );
        }
    }
}
