//! Sheet particles (codimension 1) as oriented disks.
//!
//! Disk i lies in the tangent plane of particle i (normal = the cache's frame vector b³). Its
//! radius is `overlap` × the distance to its `k_spacing`-th nearest sheet neighbour, so that
//! neighbouring disks overlap without holes (a square lattice of spacing s needs r > s/√2, a
//! hexagonal one r > s/√3; the 4th neighbour of either is at s). Its thickness is
//! mass / (ρ · s²) — the particle's own share s² of the sheet's area, not the overlapping disk's —
//! clamped below by `min_thickness_voxels` · Δx so the grid resolves it.
//! A sheet particle without neighbours gets the disk of its own volume at thickness 2·pscale.
//! The disks are rounded (a disk of radius r − t/2 swept by a ball of radius t/2), whose signed
//! distance is exact (see [`Prim::Disk`]).
use crate::cache::ParticleFrame;
use crate::hash::CellGrid;
use crate::levelset::Prim;
use crate::mesh::TriMesh;
use crate::{Real, Vec3};
use rayon::prelude::*;

/// Parameters of the sheet disks.
#[derive(Debug, Clone)]
pub struct SheetParams {
    /// liquid density ρ (kg/m³) used for thickness = mass / (ρ · area)
    pub density: Real,
    /// which nearest neighbour's distance sets the disk radius
    pub k_spacing: usize,
    /// disk radius relative to that distance
    pub overlap: Real,
    /// minimal thickness relative to the voxel size
    pub min_thickness_voxels: Real,
    /// segments of the explicit disk mesh
    pub segments: usize,
}

impl Default for SheetParams {
    fn default() -> Self {
        SheetParams {
            density: 1000.0,
            k_spacing: 4,
            overlap: 1.1,
            min_thickness_voxels: 1.5,
            segments: 12,
        }
    }
}

/// Builds one disk per sheet particle (with its velocity).
pub fn sheet_disks(frame: &ParticleFrame, voxel: Real, p: &SheetParams) -> Vec<(Prim, Vec3)> {
    let idx = frame.indices_of(1);
    if idx.is_empty() {
        return Vec::new();
    }
    let pts: Vec<Vec3> = idx.iter().map(|&i| frame.pos[i]).collect();
    // spacing estimate from each particle's own area: mass/(ρ·2·pscale)
    let mut own: Vec<Real> = idx
        .iter()
        .map(|&i| {
            (frame.mass[i] / (p.density * 2.0 * frame.pscale[i]))
                .max(0.0)
                .sqrt()
        })
        .collect();
    own.sort_by(|a, b| a.total_cmp(b));
    let median = own[own.len() / 2].max(voxel);
    let search = 3.0 * median;
    let grid = CellGrid::build(&pts, search);
    idx.par_iter()
        .enumerate()
        .map(|(a, &i)| {
            let mut d: Vec<Real> = Vec::new();
            grid.for_each_within(&pts, &pts[a], search, |j, d2| {
                if j != a {
                    d.push(d2.sqrt());
                }
            });
            d.sort_by(|x, y| x.total_cmp(y));
            let n = frame.frame[i];
            let n = if n.norm() > 0.0 {
                n.normalize()
            } else {
                Vec3::z()
            };
            // local spacing s and the particle's share of the sheet's area, s²
            let (r, area) = if d.is_empty() {
                let a = frame.mass[i] / (p.density * 2.0 * frame.pscale[i]);
                ((a / std::f64::consts::PI).sqrt(), a)
            } else {
                let s = d[(p.k_spacing.max(1) - 1).min(d.len() - 1)];
                (p.overlap * s, s * s)
            };
            let r = r.max(0.5 * voxel);
            let thick = frame.mass[i] / (p.density * area);
            let t = 0.5 * thick.max(p.min_thickness_voxels * voxel);
            (
                Prim::Disk {
                    c: frame.pos[i],
                    n,
                    r: r.max(t),
                    t,
                },
                frame.vel[i],
            )
        })
        .collect()
}

/// Explicit mesh of the disks: each a closed prism of `segments` sides.
pub fn disks_mesh(disks: &[(Prim, Vec3)], segments: usize) -> TriMesh {
    let mut m = TriMesh::default();
    let s = segments.max(3);
    for (prim, v) in disks {
        let Prim::Disk { c, n, r, t } = *prim else {
            continue;
        };
        let u = any_perp(&n);
        let w = n.cross(&u);
        let base = m.pos.len() as u32;
        for side in [1.0, -1.0] {
            m.pos.push(c + side * t * n);
            m.normal.push(side * n);
            m.vel.push(*v);
            for k in 0..s {
                let a = 2.0 * std::f64::consts::PI * k as Real / s as Real;
                let dir = a.cos() * u + a.sin() * w;
                m.pos.push(c + r * dir + side * t * n);
                m.normal.push((dir + side * n).normalize());
                m.vel.push(*v);
            }
        }
        let top = base;
        let bot = base + s as u32 + 1;
        for k in 0..s as u32 {
            let k1 = (k + 1) % s as u32;
            m.tris.push([top, top + 1 + k, top + 1 + k1]);
            m.tris.push([bot, bot + 1 + k1, bot + 1 + k]);
            m.tris.push([top + 1 + k, bot + 1 + k, bot + 1 + k1]);
            m.tris.push([top + 1 + k, bot + 1 + k1, top + 1 + k1]);
        }
    }
    m
}

/// A unit vector perpendicular to `n`.
pub fn any_perp(n: &Vec3) -> Vec3 {
    let a = if n.x.abs() < 0.9 {
        Vec3::x()
    } else {
        Vec3::y()
    };
    n.cross(&a).normalize()
}
