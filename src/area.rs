//! Control areas of sheet and filament particles (paper Appendix D) and the
//! thickness/radius they imply.
//!
//! - Sheet particle: the area of its cell in a *local Voronoi* diagram
//!   (after Lai et al. 2013, simplified): the sheet neighbours are projected
//!   onto the tangent plane (b¹, b²) and the cell of the origin is the square
//!   [−h, h]² clipped by the perpendicular bisector of every projected
//!   neighbour. A free film (not the surface of a volume) has two faces, so
//!   its surface-tension area is doubled ([`surface_tension_area`]).
//! - Filament particle: a tube of radius r and length l, where l is half the
//!   distance between its two closest filament neighbours (on a uniform
//!   filament of spacing s this is s; the paper's "distance between the two
//!   closest particles" read so that the lengths of all particles add up to
//!   the filament's length). Lateral area 2π r l.
//! - Rim particle (a filament particle bounding a sheet, Bush & Hasha 2004):
//!   S_r = 2 r l for the rim tension and S_f = 2(π − 1) r l for the
//!   filament tension. Bud particle (a filament end): S_b = π r².
//! - Volume conservation: a sheet particle of mass m and one-face area A has
//!   thickness τ = m / (ρ A) and radius (half thickness) τ/2; a filament
//!   particle has radius r = √(m / (ρ π l)).

use crate::math::{Mat3, Real, Vec3};

/// Area (m²) of the local Voronoi cell of a sheet particle at `xp` with
/// frame `frame` (columns b¹, b², b³) among the neighbour positions `nbrs`
/// (all within `h`), bounded to a square of half-width 0.75 × the mean
/// distance of the six nearest neighbours (open edges). Without neighbours the cell is the whole [−h, h]²
/// square clipped to the disk area π h²/4 (a lone particle gets the area of
/// a disk of radius h/2).
pub fn voronoi_area(xp: &Vec3, frame: &Mat3, nbrs: impl Iterator<Item = Vec3>, h: Real) -> Real {
    let b1: Vec3 = frame.column(0).into();
    let b2: Vec3 = frame.column(1).into();
    let nbrs: Vec<Vec3> = nbrs.collect();
    // bound the cell by 0.75 × the mean distance of the 6 nearest neighbours:
    // inside a sheet the bisectors cut much closer (≤ 0.58 × on a hexagonal,
    // 0.5 × on a square lattice), but at an open edge the cell would extend
    // to the search square and give the particle up to 4 h² of area
    let mut near = [0.0 as Real; 6];
    let mut k = 0;
    for q in &nbrs {
        let d = (q - xp).norm();
        if d > 0.0 && (k < 6 || d < near[5]) {
            // insert into the ascending list of the (up to) 6 smallest
            let mut i = k.min(5);
            while i > 0 && near[i - 1] > d {
                near[i] = near[i - 1];
                i -= 1;
            }
            near[i] = d;
            k = (k + 1).min(6);
        }
    }
    let half = if k > 0 {
        (0.75 * near[..k].iter().sum::<Real>() / k as Real).min(h)
    } else {
        h
    };
    // the cell, clipped by each bisector in turn (two buffers, no copy when
    // a bisector misses the cell)
    let mut poly: Vec<[Real; 2]> = Vec::with_capacity(16);
    poly.extend([[-half, -half], [half, -half], [half, half], [-half, half]]);
    let mut next: Vec<[Real; 2]> = Vec::with_capacity(16);
    let mut clipped = false;
    for q in nbrs {
        let d = q - xp;
        let n = [d.dot(&b1), d.dot(&b2)];
        let nn = n[0] * n[0] + n[1] * n[1];
        if nn <= 1e-24 * h * h {
            continue;
        }
        // keep points y with y·n ≤ |n|²/2
        clipped = true;
        if clip_into(&poly, n, 0.5 * nn, &mut next) {
            std::mem::swap(&mut poly, &mut next);
        }
        if poly.len() < 3 {
            return 0.0;
        }
    }
    if !clipped {
        return std::f64::consts::PI * h * h / 4.0;
    }
    polygon_area(&poly)
}

/// The part of `poly` where y·n ≤ c, written into `out`; returns false (and
/// leaves `out` alone) when the whole polygon is kept, which is what the
/// clip would return then.
fn clip_into(poly: &[[Real; 2]], n: [Real; 2], c: Real, out: &mut Vec<[Real; 2]>) -> bool {
    let f = |p: &[Real; 2]| p[0] * n[0] + p[1] * n[1] - c;
    if poly.iter().all(|p| f(p) <= 0.0) {
        return false;
    }
    out.clear();
    for i in 0..poly.len() {
        let a = poly[i];
        let b = poly[(i + 1) % poly.len()];
        let (fa, fb) = (f(&a), f(&b));
        if fa <= 0.0 {
            out.push(a);
        }
        if (fa < 0.0 && fb > 0.0) || (fa > 0.0 && fb < 0.0) {
            let t = fa / (fa - fb);
            out.push([a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]);
        }
    }
    true
}

fn polygon_area(p: &[[Real; 2]]) -> Real {
    let mut a = 0.0;
    for i in 0..p.len() {
        let (u, v) = (p[i], p[(i + 1) % p.len()]);
        a += u[0] * v[1] - v[0] * u[1];
    }
    0.5 * a.abs()
}

/// Surface-tension area of a sheet particle: its Voronoi area, doubled for a
/// free film (two faces), single for the surface layer of a volume.
pub fn surface_tension_area(voronoi: Real, free_film: bool) -> Real {
    if free_film {
        2.0 * voronoi
    } else {
        voronoi
    }
}

/// Length l (m) of a filament particle at `xp`: half the distance between
/// its two closest filament neighbours; with one neighbour, the distance to
/// it; with none, `fallback`.
pub fn filament_length(xp: &Vec3, nbrs: impl Iterator<Item = Vec3>, fallback: Real) -> Real {
    let (mut d1, mut d2) = (Real::INFINITY, Real::INFINITY);
    for q in nbrs {
        let d = (q - xp).norm();
        if d <= 0.0 {
            continue;
        }
        if d < d1 {
            d2 = d1;
            d1 = d;
        } else if d < d2 {
            d2 = d;
        }
    }
    if d2.is_finite() {
        0.5 * (d1 + d2)
    } else if d1.is_finite() {
        d1
    } else {
        fallback
    }
}

/// Rim length (m) carried by rim particle `xp` with rim tangent `t` (unit):
/// the inverse of the rim's line density at `xp`, estimated with the
/// normalised 1-D kernel W(d) = 35/(32 w) (1 − (d/w)²)³ of the tangential
/// offsets d = t·(x_j − x_p) of the filament neighbours `nbrs` (without
/// `xp` itself), capped by `cap`.
///
/// A sheet that retracts faster than its edge particles merge leaves a rim
/// one to two particles thick. With the nearest-neighbour length of
/// [`filament_length`] every particle of such a band carries a full
/// spacing, so the band's rim force σ S_r / r = 2σ l summed ~1.7 times
/// 2σ per metre of rim in the bursting bubble, and the rim outran
/// Taylor–Culick by 12–32 % (`docs/decisions.md`). The line density counts
/// a band of k rows as k particles per spacing, so the rim's force per
/// length stays 2σ. On a regular single row of spacing s the kernel sum is
/// 1/s within 0.8 % for w ≥ 2s (0.2 % for w ≥ 3s).
pub fn rim_length(
    xp: &Vec3,
    t: &Vec3,
    nbrs: impl Iterator<Item = Vec3>,
    w: Real,
    cap: Real,
) -> Real {
    let k = 35.0 / (32.0 * w);
    let mut density = k;
    for q in nbrs {
        let u = t.dot(&(q - xp)) / w;
        if u.abs() < 1.0 {
            let a = 1.0 - u * u;
            density += k * a * a * a;
        }
    }
    (1.0 / density).min(cap)
}

/// Areas used by the filament, rim and bud tension terms (paper Appendix D).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FilamentAreas {
    /// Lateral tube area 2π r l (plain filament particle).
    pub lateral: Real,
    /// Rim component S_r = 2 r l.
    pub rim: Real,
    /// Filament component of a rim particle S_f = 2(π − 1) r l.
    pub rim_filament: Real,
    /// Bud area S_b = π r².
    pub bud: Real,
}

/// Filament areas for radius `r` and length `l`.
pub fn filament_areas(r: Real, l: Real) -> FilamentAreas {
    use std::f64::consts::PI;
    FilamentAreas {
        lateral: 2.0 * PI * r * l,
        rim: 2.0 * r * l,
        rim_filament: 2.0 * (PI - 1.0) * r * l,
        bud: PI * r * r,
    }
}

/// Half thickness (m) of a sheet particle of mass `m` (kg), one-face area `a`
/// (m²) and density `rho` (kg/m³): τ/2 with τ = m/(ρ a).
pub fn sheet_half_thickness(m: Real, a: Real, rho: Real) -> Real {
    0.5 * m / (rho * a)
}

/// Radius (m) of the sphere of mass `m` (kg) at density `rho`: the largest
/// half thickness of a sheet particle and the largest tube radius of a
/// filament particle. A particle whose control area or length is so small
/// that its thickness would exceed it is no longer thin (a crowded,
/// degenerate neighbourhood); callers clamp to it and count the clamp.
pub fn sphere_radius(m: Real, rho: Real) -> Real {
    (3.0 * m / (4.0 * std::f64::consts::PI * rho)).cbrt()
}

/// Tube radius (m) of a filament particle of mass `m`, length `l`, density `rho`.
pub fn filament_radius(m: Real, l: Real, rho: Real) -> Real {
    (m / (rho * std::f64::consts::PI * l)).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rim_length_counts_rows() {
        let s = 1e-3;
        let t = Vec3::x();
        for (rows, phase) in [(1usize, 0.0), (1, 0.37), (2, 0.0), (2, 0.5), (3, 0.25)] {
            // rows of spacing s along x, offset s across, row k shifted by k·phase·s
            let mut nb = Vec::new();
            for k in 0..rows {
                for i in -20i32..=20 {
                    let x = Vec3::new((i as Real + k as Real * phase) * s, k as Real * s, 0.0);
                    if x.norm() > 0.0 && x.norm() < 3.0 * s {
                        nb.push(x);
                    }
                }
            }
            let l = rim_length(&Vec3::zeros(), &t, nb.into_iter(), 3.0 * s, 10.0 * s);
            let want = s / rows as Real;
            assert!(
                (l - want).abs() < 0.02 * want,
                "rows {rows} phase {phase}: {l} vs {want}"
            );
        }
    }

    fn lattice_nbrs(s: Real, h: Real, hex: bool) -> Vec<Vec3> {
        let mut v = Vec::new();
        for i in -10i32..=10 {
            for j in -10i32..=10 {
                let (x, y) = if hex {
                    (
                        s * (i as Real + 0.5 * (j.rem_euclid(2)) as Real),
                        s * j as Real * (3.0 as Real).sqrt() / 2.0,
                    )
                } else {
                    (s * i as Real, s * j as Real)
                };
                let p = Vec3::new(x, y, 0.0);
                if p.norm() > 0.0 && p.norm() < h {
                    v.push(p);
                }
            }
        }
        v
    }

    #[test]
    fn square_and_hexagonal_lattices_give_the_cell_area() {
        let (s, h) = (0.01, 0.035);
        let a = voronoi_area(
            &Vec3::zeros(),
            &Mat3::identity(),
            lattice_nbrs(s, h, false).into_iter(),
            h,
        );
        assert!((a - s * s).abs() < 1e-12 * s * s, "square {a}");
        let a = voronoi_area(
            &Vec3::zeros(),
            &Mat3::identity(),
            lattice_nbrs(s, h, true).into_iter(),
            h,
        );
        let hex = s * s * (3.0 as Real).sqrt() / 2.0;
        assert!((a - hex).abs() < 1e-12 * hex, "hex {a} vs {hex}");
    }

    #[test]
    fn tilted_frame_and_curved_neighbours() {
        // the same square lattice rotated into an arbitrary plane and lifted
        // slightly off it: the projected cell is unchanged
        let (s, h) = (0.01, 0.035);
        let r = nalgebra::Rotation3::from_euler_angles(0.3, -0.7, 1.1);
        let frame: Mat3 = *r.matrix();
        let nb: Vec<Vec3> = lattice_nbrs(s, h, false)
            .into_iter()
            .map(|p| r * (p + Vec3::new(0.0, 0.0, 2.0 * p.norm_squared())))
            .collect();
        let a = voronoi_area(&Vec3::zeros(), &frame, nb.into_iter(), h);
        assert!((a - s * s).abs() < 1e-10, "{a}");
    }

    #[test]
    fn filament_measures() {
        let xs = [
            Vec3::new(-0.01, 0.0, 0.0),
            Vec3::new(0.01, 0.0, 0.0),
            Vec3::new(0.02, 0.0, 0.0),
        ];
        assert!((filament_length(&Vec3::zeros(), xs.into_iter(), 1.0) - 0.01).abs() < 1e-15);
        assert_eq!(
            filament_length(&Vec3::zeros(), std::iter::empty(), 0.5),
            0.5
        );
        let a = filament_areas(0.001, 0.01);
        assert!(
            (a.rim + a.rim_filament - a.lateral).abs() < 1e-18,
            "rim split adds up to the lateral area"
        );
        // volume round trip: mass of a tube of radius r, length l
        let (r, l, rho) = (0.002, 0.01, 1000.0);
        let m = rho * std::f64::consts::PI * r * r * l;
        assert!((filament_radius(m, l, rho) - r).abs() < 1e-15);
        assert!((sheet_half_thickness(rho * 1e-4 * 2e-6, 1e-4, rho) - 1e-6).abs() < 1e-18);
        let r = 4.3e-4;
        let m = rho * 4.0 / 3.0 * std::f64::consts::PI * r * r * r;
        assert!((sphere_radius(m, rho) - r).abs() < 1e-15);
        assert_eq!(surface_tension_area(1.0, true), 2.0);
    }
}
