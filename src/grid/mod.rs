//! Sparse staggered MAC grid (Harlow & Welch 1965) for the codimension-0 liquid.
//!
//! The domain is divided into blocks of 8³ cells; only blocks within a few
//! cells of a particle are allocated, so memory and time scale with the
//! liquid, not with the domain. A small dense table (one `u32` per block, i.e.
//! 1/512 of the cell count) maps block coordinates to storage; each allocated
//! block stores its 512 cells contiguously. Every cell owns its *lower* faces:
//! `u[a][s]` is the velocity component along axis `a` on the face at
//! `x_a = i_a Δx` of the cell in slot `s` (staggered MAC layout).
//!
//! Slots are ordered by block (z, y, x) and within a block by (z, y, x), so a
//! cell's −x, −y, −z neighbours always come before it: the ordering that the
//! MIC(0) preconditioner in [`pcg`] needs.
//!
//! The domain box is a closed container: faces on its boundary are closed
//! (weight 0) by index range; other solids are cut cells ([`SolidSet`]).

pub mod bodies;
pub mod extrapolate;
pub mod pcg;
pub mod projection;
pub mod transfer;
pub mod viscosity;

use crate::math::{Real, Vec3};
use crate::solids::SolidSet;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};

/// Block edge in cells.
pub const B: usize = 8;
/// Cells per block.
pub const BV: usize = B * B * B;
/// "No entry" in index tables.
pub const NONE: u32 = u32::MAX;

/// Offsets of a cell's six face neighbours (−x, +x, −y, +y, −z, +z).
pub const FACE_OFFSETS: [[isize; 3]; 6] = [
    [-1, 0, 0],
    [1, 0, 0],
    [0, -1, 0],
    [0, 1, 0],
    [0, 0, -1],
    [0, 0, 1],
];

/// A jet's inflow disk: the liquid enters through it at a fixed velocity.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Inflow {
    /// Centre of the emission plane (m).
    pub origin: Vec3,
    /// Unit direction of the jet.
    pub direction: Vec3,
    /// Radius (m).
    pub radius: Real,
    /// Speed (m/s).
    pub speed: Real,
}

/// The sparse MAC grid and its per-slot fields.
#[derive(Clone, Debug, Default)]
pub struct MacGrid {
    /// World position of the domain's lower corner (m).
    pub origin: Vec3,
    /// Cell size Δx (m).
    pub dx: Real,
    /// Cells per axis in the domain.
    pub n: [usize; 3],
    /// Blocks per axis.
    pub nb: [usize; 3],
    /// Block table: storage index of each block, or [`NONE`].
    pub block_of: Vec<u32>,
    /// Block coordinates of each allocated block, in storage order.
    pub blocks: Vec<[usize; 3]>,
    /// Face velocities per axis (m/s), one per slot.
    pub u: [Vec<Real>; 3],
    /// Face velocities after the particle-to-grid transfer (for the FLIP update).
    pub u_old: [Vec<Real>; 3],
    /// Mass of each face at the last particle-to-grid transfer (kg):
    /// Σ_p m_p w_fp over the volume particles, the weight with which the
    /// grid-to-particle transfer hands the face's velocity change back to
    /// them.
    pub mass: [Vec<Real>; 3],
    /// Fraction of each face open to liquid (1 open, 0 closed by a solid or wall).
    pub weight: [Vec<Real>; 3],
    /// Liquid level set at cell centres (m), negative inside the liquid.
    pub phi: Vec<Real>,
    /// Face-neighbour slots (−x, +x, −y, +y, −z, +z) of every slot, or [`NONE`].
    pub nbr: Vec<[u32; 6]>,
    /// Faces whose velocity is prescribed for this substep (jet inflow),
    /// per axis; empty when there are none. The projection keeps their
    /// velocity and counts their flux.
    pub prescribed: [Vec<bool>; 3],
}

/// How the face velocities are formed where the particles around a face do
/// not surround it (`solver.velocity_fit`; `docs/decisions.md`, "A linear
/// velocity at the free surface").
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum VelocityFit {
    /// P2G fits a linear function of position to the particles' velocities
    /// around each face (weighted least squares, the P2G weights) and takes
    /// its value at the face; the first two layers of extrapolated faces
    /// continue the velocity linearly from the two faces behind each. A
    /// linear flow is then read exactly at a face whose particles all lie
    /// on one side of it.
    Linear,
    /// The weighted mean of the particles' velocities (Zhu & Bridson 2005)
    /// and a constant extension: near the surface each face reads the
    /// velocity at its particles' centroid, inside the liquid (default:
    /// with `linear` as the default the polygon's grid mode grew at its rim
    /// and a dam break kept more of its splash; `docs/decisions.md`, "A
    /// linear velocity at the free surface", session 35).
    #[default]
    Mean,
}

impl MacGrid {
    /// An empty grid over the box `[lo, hi]` with cell size `dx`.
    pub fn new(lo: Vec3, hi: Vec3, dx: Real) -> MacGrid {
        let n = [0, 1, 2].map(|d| (((hi[d] - lo[d]) / dx) - 1e-9).ceil().max(1.0) as usize);
        let nb = n.map(|c| c.div_ceil(B));
        MacGrid {
            origin: lo,
            dx,
            n,
            nb,
            block_of: vec![NONE; nb[0] * nb[1] * nb[2]],
            ..Default::default()
        }
    }

    /// True when face `(a, s)` has a prescribed velocity.
    #[inline]
    pub fn is_prescribed(&self, a: usize, s: usize) -> bool {
        self.prescribed[a].get(s).copied().unwrap_or(false)
    }

    /// Prescribes the velocity of the faces crossing each inflow disk (jet
    /// nozzles): the faces of axis a with a non-zero direction component
    /// whose centre lies within the jet radius of the axis and less than one
    /// cell upstream of the emission plane get u_a = speed · d_a.
    pub fn set_inflow(&mut self, inflow: &[Inflow]) {
        if inflow.is_empty() {
            self.prescribed = Default::default();
            return;
        }
        let ns = self.slots();
        for a in 0..3 {
            let mut flags = vec![false; ns];
            for (s, f) in flags.iter_mut().enumerate() {
                if !self.in_domain(s) || self.weight[a][s] == 0.0 {
                    continue;
                }
                let mut c = self.cell_pos(s);
                c[a] -= 0.5 * self.dx;
                for j in inflow {
                    if j.direction[a].abs() < 1e-3 {
                        continue;
                    }
                    let d = c - j.origin;
                    let xi = d.dot(&j.direction);
                    if xi <= 0.0 && xi > -self.dx && (d - j.direction * xi).norm() < j.radius {
                        *f = true;
                        self.u[a][s] = j.speed * j.direction[a];
                    }
                }
            }
            self.prescribed[a] = flags;
        }
    }

    /// Number of storage slots (allocated cells, including padding past the domain).
    pub fn slots(&self) -> usize {
        self.blocks.len() * BV
    }

    /// Slot of cell `(i, j, k)`, or `None` outside the domain or the allocated blocks.
    #[inline]
    pub fn slot(&self, i: isize, j: isize, k: isize) -> Option<usize> {
        if i < 0 || j < 0 || k < 0 {
            return None;
        }
        let (i, j, k) = (i as usize, j as usize, k as usize);
        if i >= self.n[0] || j >= self.n[1] || k >= self.n[2] {
            return None;
        }
        let b = self.block_of[(k / B * self.nb[1] + j / B) * self.nb[0] + i / B];
        if b == NONE {
            return None;
        }
        Some(b as usize * BV + ((k % B) * B + (j % B)) * B + (i % B))
    }

    /// Cell coordinates of a slot.
    #[inline]
    pub fn cell(&self, s: usize) -> [isize; 3] {
        let b = self.blocks[s / BV];
        let l = s % BV;
        [
            (b[0] * B + l % B) as isize,
            (b[1] * B + (l / B) % B) as isize,
            (b[2] * B + l / (B * B)) as isize,
        ]
    }

    /// True when the slot's cell lies inside the domain (not block padding).
    #[inline]
    pub fn in_domain(&self, s: usize) -> bool {
        let c = self.cell(s);
        (c[0] as usize) < self.n[0] && (c[1] as usize) < self.n[1] && (c[2] as usize) < self.n[2]
    }

    /// Neighbour slot of `s` shifted by `off` cells (face neighbours from the table).
    #[inline]
    pub fn neighbor(&self, s: usize, off: [isize; 3]) -> Option<usize> {
        let d = match off {
            [-1, 0, 0] => 0,
            [1, 0, 0] => 1,
            [0, -1, 0] => 2,
            [0, 1, 0] => 3,
            [0, 0, -1] => 4,
            [0, 0, 1] => 5,
            _ => {
                let c = self.cell(s);
                return self.slot(c[0] + off[0], c[1] + off[1], c[2] + off[2]);
            }
        };
        let t = self.nbr[s][d];
        (t != NONE).then_some(t as usize)
    }

    /// Position in cell units (cell centres at half-integers).
    #[inline]
    pub fn to_grid(&self, x: &Vec3) -> Vec3 {
        (x - self.origin) / self.dx
    }

    /// Cell containing a position, clamped to the domain.
    #[inline]
    pub fn cell_of(&self, x: &Vec3) -> [isize; 3] {
        let q = self.to_grid(x);
        [0, 1, 2].map(|d| (q[d].floor() as isize).clamp(0, self.n[d] as isize - 1))
    }

    /// Allocates the blocks within `margin` cells of any point and zeroes every field.
    pub fn activate(&mut self, points: &[Vec3], margin: usize) {
        let flags: Vec<AtomicBool> = (0..self.block_of.len())
            .map(|_| AtomicBool::new(false))
            .collect();
        let m = margin as isize;
        points.par_iter().for_each(|p| {
            let c = self.cell_of(p);
            let lo = [0, 1, 2].map(|d| ((c[d] - m).max(0) as usize) / B);
            let hi = [0, 1, 2].map(|d| ((c[d] + m).min(self.n[d] as isize - 1) as usize) / B);
            for bz in lo[2]..=hi[2] {
                for by in lo[1]..=hi[1] {
                    for bx in lo[0]..=hi[0] {
                        flags[(bz * self.nb[1] + by) * self.nb[0] + bx]
                            .store(true, Ordering::Relaxed);
                    }
                }
            }
        });
        self.blocks.clear();
        for (idx, f) in flags.iter().enumerate() {
            if f.load(Ordering::Relaxed) {
                self.block_of[idx] = self.blocks.len() as u32;
                let bx = idx % self.nb[0];
                let by = (idx / self.nb[0]) % self.nb[1];
                let bz = idx / (self.nb[0] * self.nb[1]);
                self.blocks.push([bx, by, bz]);
            } else {
                self.block_of[idx] = NONE;
            }
        }
        let ns = self.slots();
        for a in 0..3 {
            for f in [
                &mut self.u[a],
                &mut self.u_old[a],
                &mut self.weight[a],
                &mut self.mass[a],
            ] {
                f.clear();
                f.resize(ns, 0.0);
            }
        }
        self.phi.clear();
        self.phi.resize(ns, self.dx);
        let g: &MacGrid = self;
        let nbr: Vec<[u32; 6]> = (0..ns)
            .into_par_iter()
            .map(|s| {
                let c = g.cell(s);
                let mut n = [NONE; 6];
                for (d, o) in FACE_OFFSETS.iter().enumerate() {
                    if let Some(t) = g.slot(c[0] + o[0], c[1] + o[1], c[2] + o[2]) {
                        n[d] = t as u32;
                    }
                }
                n
            })
            .collect();
        self.nbr = nbr;
    }

    /// World position of the centre of face `a` of slot `s`.
    #[inline]
    pub fn face_pos(&self, s: usize, a: usize) -> Vec3 {
        let c = self.cell(s);
        let mut q = Vec3::new(c[0] as Real + 0.5, c[1] as Real + 0.5, c[2] as Real + 0.5);
        q[a] -= 0.5;
        self.origin + q * self.dx
    }

    /// World position of the centre of the cell in slot `s`.
    #[inline]
    pub fn cell_pos(&self, s: usize) -> Vec3 {
        let c = self.cell(s);
        self.origin
            + Vec3::new(c[0] as Real + 0.5, c[1] as Real + 0.5, c[2] as Real + 0.5) * self.dx
    }

    /// Computes the open fraction of every face from the solids (cut cells,
    /// Batty et al. 2007): faces on the domain boundary or past it are closed;
    /// others are `1 − (area of the face inside solids)`, the area estimated
    /// from the bilinear interpolant of the SDF at the four face corners on an
    /// 8×8 sub-sample where the corners disagree in sign.
    pub fn compute_weights(&mut self, solids: &SolidSet) {
        let ns = self.slots();
        for a in 0..3 {
            let w: Vec<Real> = (0..ns)
                .into_par_iter()
                .map(|s| {
                    let c = self.cell(s);
                    if !self.in_domain(s) || c[a] == 0 {
                        return 0.0;
                    }
                    if solids.is_empty() {
                        return 1.0;
                    }
                    let (b1, b2) = ((a + 1) % 3, (a + 2) % 3);
                    let base =
                        self.origin + Vec3::new(c[0] as Real, c[1] as Real, c[2] as Real) * self.dx;
                    let mut e1 = Vec3::zeros();
                    e1[b1] = self.dx;
                    let mut e2 = Vec3::zeros();
                    e2[b2] = self.dx;
                    let p = [
                        solids.phi(&base),
                        solids.phi(&(base + e1)),
                        solids.phi(&(base + e2)),
                        solids.phi(&(base + e1 + e2)),
                    ];
                    1.0 - fraction_inside(p)
                })
                .collect();
            self.weight[a] = w;
        }
    }

    /// Trilinear interpolation of face component `a` at world position `x`.
    /// Tangential indices are clamped to the domain (free slip at walls);
    /// faces outside the allocated blocks or on the far wall read 0.
    #[inline]
    pub fn sample(&self, field: &[Real], a: usize, x: &Vec3) -> Real {
        let (idx, w) = self.stencil(a, x);
        let mut acc = 0.0;
        for k in 0..8 {
            if idx[k] != NONE {
                acc += w[k] * field[idx[k] as usize];
            }
        }
        acc
    }

    /// The eight faces (slots, [`NONE`] where absent) and trilinear weights
    /// that [`Self::sample`] uses for component `a` at `x`.
    #[inline]
    pub fn stencil(&self, a: usize, x: &Vec3) -> ([u32; 8], [Real; 8]) {
        self.stencil_clamped(a, x, false)
    }

    /// [`Self::stencil`]; with `skip_walls` the faces on the domain walls are
    /// replaced by their interior neighbours (a zero-gradient extension), as the
    /// FLIP increment needs: the wall faces hold 0 before and after the
    /// projection, which would otherwise hide the change of a particle's
    /// normal velocity next to a wall from the FLIP update.
    #[inline]
    pub fn stencil_clamped(&self, a: usize, x: &Vec3, skip_walls: bool) -> ([u32; 8], [Real; 8]) {
        let q = self.to_grid(x);
        let mut f = [q.x - 0.5, q.y - 0.5, q.z - 0.5];
        f[a] = q[a];
        let mut i0 = [0isize; 3];
        let mut t = [0.0; 3];
        for d in 0..3 {
            let n = self.n[d] as Real;
            let (lo, hi) = match (d == a, skip_walls) {
                (true, true) => (1.0, n - 1.0),
                (true, false) => (0.0, n),
                _ => (0.0, n - 1.0),
            };
            let fd = f[d].clamp(lo, hi);
            let fl = fd.floor().min((hi - 1.0).max(lo));
            i0[d] = fl as isize;
            t[d] = fd - fl;
        }
        let mut idx = [NONE; 8];
        let mut ws = [0.0; 8];
        for dz in 0..2 {
            let wz = if dz == 0 { 1.0 - t[2] } else { t[2] };
            for dy in 0..2 {
                let wy = if dy == 0 { 1.0 - t[1] } else { t[1] };
                for dxi in 0..2 {
                    let wx = if dxi == 0 { 1.0 - t[0] } else { t[0] };
                    let k = ((dz * 2 + dy) * 2 + dxi) as usize;
                    if let Some(s) = self.slot(i0[0] + dxi, i0[1] + dy, i0[2] + dz) {
                        idx[k] = s as u32;
                        ws[k] = wx * wy * wz;
                    }
                }
            }
        }
        (idx, ws)
    }

    /// [`Self::stencil`] with the gradient (1/m) of each trilinear weight, for APIC.
    #[inline]
    pub fn stencil_grad(&self, a: usize, x: &Vec3) -> ([u32; 8], [Real; 8], [Vec3; 8]) {
        let (idx, w) = self.stencil(a, x);
        let q = self.to_grid(x);
        let mut f = [q.x - 0.5, q.y - 0.5, q.z - 0.5];
        f[a] = q[a];
        // recover the fractional coordinates the stencil used
        let mut t = [0.0; 3];
        for d in 0..3 {
            let n = self.n[d] as Real;
            let hi = if d == a { n } else { n - 1.0 };
            let fd = f[d].clamp(0.0, hi);
            t[d] = fd - fd.floor().min((hi - 1.0).max(0.0));
        }
        let inv = 1.0 / self.dx;
        let mut g = [Vec3::zeros(); 8];
        for (k, gk) in g.iter_mut().enumerate() {
            let o = [k & 1, (k >> 1) & 1, (k >> 2) & 1];
            let h: [Real; 3] = [0, 1, 2].map(|d| if o[d] == 1 { t[d] } else { 1.0 - t[d] });
            let s: [Real; 3] = [0, 1, 2].map(|d| if o[d] == 1 { inv } else { -inv });
            *gk = Vec3::new(s[0] * h[1] * h[2], h[0] * s[1] * h[2], h[0] * h[1] * s[2]);
        }
        (idx, w, g)
    }

    /// Grid velocity at `x` (m/s) and the gradient ∇u_a (1/s) of each
    /// component's trilinear interpolant there, a = 0, 1, 2 (APIC's affine
    /// rows; the band correction of the coupled solve).
    #[inline]
    pub fn velocity_gradient(&self, x: &Vec3) -> (Vec3, [Vec3; 3]) {
        let (mut v, mut g) = (Vec3::zeros(), [Vec3::zeros(); 3]);
        for a in 0..3 {
            let (idx, w, gw) = self.stencil_grad(a, x);
            for k in 0..8 {
                if idx[k] != NONE {
                    let u = self.u[a][idx[k] as usize];
                    v[a] += w[k] * u;
                    g[a] += gw[k] * u;
                }
            }
        }
        (v, g)
    }

    /// Grid velocity at `x` (m/s).
    #[inline]
    pub fn velocity(&self, x: &Vec3) -> Vec3 {
        Vec3::new(
            self.sample(&self.u[0], 0, x),
            self.sample(&self.u[1], 1, x),
            self.sample(&self.u[2], 2, x),
        )
    }

    /// Liquid volume measured on the grid (m³): Σ clamp(½ − φ/Δx, 0, 1) Δx³ over cells.
    pub fn liquid_volume(&self) -> Real {
        let parts: Vec<Real> = self
            .phi
            .par_chunks(BV)
            .enumerate()
            .map(|(b, ph)| {
                let mut s = 0.0;
                for (l, p) in ph.iter().enumerate() {
                    if self.in_domain(b * BV + l) {
                        s += (0.5 - p / self.dx).clamp(0.0, 1.0);
                    }
                }
                s
            })
            .collect();
        parts.iter().sum::<Real>() * self.dx.powi(3)
    }

    /// Number of liquid cells (φ < 0).
    pub fn liquid_cells(&self) -> usize {
        self.phi.par_iter().filter(|p| **p < 0.0).count()
    }
}

/// Fraction of a unit square inside (φ < 0), from the SDF at its corners
/// `[p00, p10, p01, p11]`, bilinearly interpolated on an 8×8 sub-sample.
pub fn fraction_inside(p: [Real; 4]) -> Real {
    if p.iter().all(|v| *v < 0.0) {
        return 1.0;
    }
    if p.iter().all(|v| *v >= 0.0) {
        return 0.0;
    }
    let mut inside = 0;
    for j in 0..8 {
        let y = (j as Real + 0.5) / 8.0;
        for i in 0..8 {
            let x = (i as Real + 0.5) / 8.0;
            let v = p[0] * (1.0 - x) * (1.0 - y)
                + p[1] * x * (1.0 - y)
                + p[2] * (1.0 - x) * y
                + p[3] * x * y;
            if v < 0.0 {
                inside += 1;
            }
        }
    }
    inside as Real / 64.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slot_and_cell_round_trip() {
        let mut g = MacGrid::new(Vec3::zeros(), Vec3::new(2.0, 1.0, 1.5), 0.1);
        assert_eq!(g.n, [20, 10, 15]);
        g.activate(&[Vec3::new(1.0, 0.5, 0.7)], 2);
        for s in 0..g.slots() {
            let c = g.cell(s);
            if g.in_domain(s) {
                assert_eq!(g.slot(c[0], c[1], c[2]), Some(s));
            }
        }
        // a linear field is reproduced exactly by the interpolation
        for a in 0..3 {
            for s in 0..g.slots() {
                let p = g.face_pos(s, a);
                g.u[a][s] = 1.0 + 2.0 * p.x - p.y + 0.5 * p.z;
            }
        }
        let x = Vec3::new(1.03, 0.47, 0.66);
        for a in 0..3 {
            let v = g.sample(&g.u[a], a, &x);
            assert!((v - (1.0 + 2.0 * x.x - x.y + 0.5 * x.z)).abs() < 1e-12);
        }
    }

    #[test]
    fn storage_scales_with_the_liquid_not_the_domain() {
        // 512³ cells (134M); a 2-cell cluster of points allocates at most 2³ blocks
        let mut g = MacGrid::new(Vec3::zeros(), Vec3::repeat(1.0), 1.0 / 512.0);
        let pts: Vec<Vec3> = (0..100)
            .map(|i| Vec3::repeat(0.3) + Vec3::repeat(i as Real * 4e-5))
            .collect();
        g.activate(&pts, 2);
        assert!(g.blocks.len() <= 8, "{} blocks", g.blocks.len());
        assert!(g.slots() <= 8 * BV && g.u[0].len() == g.slots() && g.phi.len() == g.slots());
        assert_eq!(g.block_of.len(), 64 * 64 * 64);
    }

    #[test]
    fn fraction_inside_of_half_plane() {
        assert!((fraction_inside([-1.0, 1.0, -1.0, 1.0]) - 0.5).abs() < 1e-12);
        assert_eq!(fraction_inside([-1.0; 4]), 1.0);
        assert_eq!(fraction_inside([1.0; 4]), 0.0);
    }
}
