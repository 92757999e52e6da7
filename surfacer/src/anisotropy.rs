//! Anisotropic kernels for volume particles, after Yu & Turk, *Reconstructing Surfaces of
//! Particle-Based Fluids Using Anisotropic Kernels* (ACM TOG 2013).
//!
//! For particle i with neighbours j within r = `radius_rel`·Δ (Δ the particle spacing), weights
//! w_ij = 1 − (|x_i − x_j|/r)³ (Yu & Turk eq. 11):
//!
//! * smoothed centre (eq. 6):   x̄_i = (1 − λ) x_i + λ Σ_j w_ij x_j / Σ_j w_ij
//! * weighted covariance (eq. 8): C_i = Σ_j w_ij (x_j − x_i^w)(x_j − x_i^w)ᵀ / Σ_j w_ij
//! * C_i = R Σ Rᵀ (eigen-decomposition, σ1 ≥ σ2 ≥ σ3), then (eq. 10)
//!   Σ̃ = k_s diag(σ1, max(σ2, σ1/k_r), max(σ3, σ1/k_r)) if N_i > N_ε, else k_n I
//! * G_i = (1/h) R Σ̃⁻¹ Rᵀ, kernel W_i(x) = σ_P det(G_i) P(|G_i (x − x̄_i)|) (eq. 5)
//!
//! with P(s) = (1 − s²)³ on s < 1, σ_P = 315/(64π) so that ∫W = 1, and h = r/2 (Yu & Turk use a
//! covariance radius twice the kernel radius). k_s is not a fixed number in the paper (it depends
//! on units); here it is chosen so that a full neighbourhood of uniform density gives Σ̃ = I:
//! for these weights the eigenvalues of C are 0.15 r², so k_s = `ks_rel` / (0.15 r²).
//! Particles with N_i ≤ N_ε keep the isotropic kernel k_n·h, so lone droplets never vanish.
use crate::hash::CellGrid;
use crate::{Mat3, Real, Vec3};
use rayon::prelude::*;

/// Parameters of the anisotropic kernels (defaults: Yu & Turk 2013, λ = 0.9, k_r = 4, k_n = 0.5,
/// N_ε = 25).
#[derive(Debug, Clone)]
pub struct AnisoParams {
    /// use anisotropic kernels (false: isotropic kernels of radius h for every particle)
    pub anisotropic: bool,
    /// covariance neighbourhood radius r, relative to the particle spacing Δ
    pub radius_rel: Real,
    /// centre smoothing λ (0 = none)
    pub lambda: Real,
    /// maximal ratio of largest to smallest kernel axis k_r
    pub kr: Real,
    /// scale of k_s relative to the automatic value 1/(0.15 r²)
    pub ks_rel: Real,
    /// isotropic kernel scale k_n for particles with few neighbours
    pub kn: Real,
    /// neighbour count N_ε below which a particle keeps the isotropic kernel
    pub n_eps: usize,
}

impl Default for AnisoParams {
    fn default() -> Self {
        AnisoParams {
            anisotropic: true,
            radius_rel: 3.0,
            lambda: 0.9,
            kr: 4.0,
            ks_rel: 1.0,
            kn: 0.5,
            n_eps: 25,
        }
    }
}

/// Kernel normalisation σ_P = 315/(64π) for P(s) = (1 − s²)³ on the unit ball.
pub const SIGMA_P: Real = 315.0 / (64.0 * std::f64::consts::PI);

/// Per-particle kernels, structure of arrays, in cell order: kernel k belongs to particle
/// `index[k]`. Stored in f32 (positions to ~1e-7 relative, far below a voxel; the density rows
/// take their coefficients in f64 from these).
#[derive(Debug, Clone, Default)]
pub struct Kernels {
    /// particle index of each kernel
    pub index: Vec<u32>,
    /// kernel centres x̄ (m)
    pub center: Vec<[f32; 3]>,
    /// shape of each kernel: an index into [`Self::g`] and [`Self::extent`], or [`PLAIN`] for the
    /// plain isotropic kernel of radius h (G = I/h, extent h) that most deep particles have
    pub shape: Vec<u32>,
    /// symmetric G matrices (1/m): xx, xy, xz, yy, yz, zz, of the kernels that are not plain
    pub g: Vec<[f32; 6]>,
    /// σ_P det(G) · particle volume — the kernel's peak contribution to the volume fraction
    pub amp: Vec<f32>,
    /// half extents of the kernel's axis-aligned bounding box (m), of the kernels that are not
    /// plain
    pub extent: Vec<[f32; 3]>,
    /// G (1/m) and half extent (m) of the plain kernel
    pub plain: ([f32; 6], [f32; 3]),
    /// deep particles: full, symmetric neighbourhood (see [`is_deep`]), ≳ 0.45 r from any free
    /// surface; the density is evaluated only near particles that are not deep
    pub deep: Vec<bool>,
    /// particles that kept the isotropic kernel (N ≤ N_ε or anisotropy off)
    pub isotropic: usize,
}

impl Kernels {
    /// Centre of kernel `i` in f64.
    #[inline]
    pub fn center_of(&self, i: usize) -> Vec3 {
        let c = self.center[i];
        Vec3::new(c[0] as Real, c[1] as Real, c[2] as Real)
    }
    /// Half extents of kernel `i` in f64.
    #[inline]
    pub fn extent_of(&self, i: usize) -> Vec3 {
        let c = match self.shape[i] {
            PLAIN => self.plain.1,
            s => self.extent[s as usize],
        };
        Vec3::new(c[0] as Real, c[1] as Real, c[2] as Real)
    }
    /// Symmetric G of kernel `i` (xx, xy, xz, yy, yz, zz; 1/m).
    #[inline]
    pub fn g_sym(&self, i: usize) -> [f32; 6] {
        match self.shape[i] {
            PLAIN => self.plain.0,
            s => self.g[s as usize],
        }
    }
    /// G of kernel `i` in f64.
    #[inline]
    pub fn g_of(&self, i: usize) -> Mat3 {
        let g = self.g_sym(i).map(|x| x as Real);
        Mat3::new(g[0], g[1], g[2], g[1], g[3], g[4], g[2], g[4], g[5])
    }
    /// Bytes held.
    pub fn memory_bytes(&self) -> usize {
        self.index.len() * (4 + 12 + 4 + 4 + 1) + self.g.len() * (24 + 12)
    }
}

/// [`Kernels::shape`] of a plain kernel.
pub const PLAIN: u32 = u32::MAX;

/// Kernel support h = r/2 for spacing `dx`.
pub fn kernel_radius(p: &AnisoParams, dx: Real) -> Real {
    0.5 * p.radius_rel * dx
}

/// A particle is *deep* when its neighbourhood (radius r) holds at least 80 % of the particles a
/// uniform lattice of its own volume would put there and its weighted neighbour mean (weights
/// 1 − (d/r)³) lies within 0.1 r of it. A free surface at distance d cuts a cap off the
/// neighbourhood: at d = 0.45 r the cap holds 18 % of the ball and shifts the weighted mean by
/// 0.1 r (at 0.3 r: 28 %, 0.16 r), so deep particles are ≳ 0.45 r inside, and every voxel within the
/// band of the iso-surface is within r + 2 voxels of a particle that is not deep: the density is
/// evaluated only there (see [`crate::density::rasterize`]). (80 % and not more: on a jittered
/// lattice the count within r = 3Δ varies by ±7 % from the 30 lattice points at distance 3Δ.)
pub fn is_deep(n_with_self: usize, mean_offset: Real, r: Real, vol: Real) -> bool {
    let full = 4.0 / 3.0 * std::f64::consts::PI * r * r * r / vol;
    n_with_self as Real >= 0.8 * full && mean_offset <= 0.1 * r
}

/// Candidate neighbours of one cell (the 27 cells around it), relative to the cell's corner, in
/// f32 lanes of 8 (padded far away).
#[derive(Default)]
struct Candidates {
    cell: Option<crate::hash::Key>,
    /// fewest particles in one of the 27 cells (0 if one is empty)
    min_count: u32,
    /// candidate arrays filled for `cell`
    built: bool,
    x: Vec<f32>,
    y: Vec<f32>,
    z: Vec<f32>,
}

const LANES: usize = 8;

/// Count of candidates within r (d² ≤ r2) and sums of w, w d (3), w d dᵀ (xx xy xz yy yz zz) with
/// w = 1 − (|d| inv_r)³, d = candidate − q; candidate arrays padded to a multiple of [`LANES`].
fn moments(
    x: &[f32],
    y: &[f32],
    z: &[f32],
    q: [f32; 3],
    r2: f32,
    inv_r: f32,
) -> (usize, [Real; 10]) {
    #[cfg(target_arch = "x86_64")]
    {
        // SSE2 is part of x86_64: always available
        unsafe { moments_sse2(x, y, z, q, r2, inv_r) }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let mut n = 0usize;
        let mut acc = [0f32; 10];
        for j in 0..x.len() {
            let (dx, dy, dz) = (x[j] - q[0], y[j] - q[1], z[j] - q[2]);
            let d2 = dx * dx + dy * dy + dz * dz;
            if d2 <= r2 {
                let t = d2.sqrt() * inv_r;
                let w = 1.0 - t * t * t;
                n += 1;
                let (wx, wy, wz) = (w * dx, w * dy, w * dz);
                for (a, v) in acc.iter_mut().zip([
                    w,
                    wx,
                    wy,
                    wz,
                    wx * dx,
                    wx * dy,
                    wx * dz,
                    wy * dy,
                    wy * dz,
                    wz * dz,
                ]) {
                    *a += v;
                }
            }
        }
        (n, acc.map(|a| a as Real))
    }
}

#[cfg(target_arch = "x86_64")]
#[inline]
unsafe fn moments_sse2(
    x: &[f32],
    y: &[f32],
    z: &[f32],
    q: [f32; 3],
    r2: f32,
    inv_r: f32,
) -> (usize, [Real; 10]) {
    use std::arch::x86_64::*;
    debug_assert!(x.len().is_multiple_of(LANES) && y.len() == x.len() && z.len() == x.len());
    unsafe {
        let (qx, qy, qz) = (_mm_set1_ps(q[0]), _mm_set1_ps(q[1]), _mm_set1_ps(q[2]));
        let (vr2, vinv, one) = (_mm_set1_ps(r2), _mm_set1_ps(inv_r), _mm_set1_ps(1.0));
        let mut acc = [_mm_setzero_ps(); 10];
        let mut cnt = _mm_setzero_si128();
        let mut j = 0;
        while j < x.len() {
            let dx = _mm_sub_ps(_mm_loadu_ps(x.as_ptr().add(j)), qx);
            let dy = _mm_sub_ps(_mm_loadu_ps(y.as_ptr().add(j)), qy);
            let dz = _mm_sub_ps(_mm_loadu_ps(z.as_ptr().add(j)), qz);
            let d2 = _mm_add_ps(
                _mm_add_ps(_mm_mul_ps(dx, dx), _mm_mul_ps(dy, dy)),
                _mm_mul_ps(dz, dz),
            );
            let m = _mm_cmple_ps(d2, vr2);
            let t = _mm_mul_ps(_mm_sqrt_ps(d2), vinv);
            let w = _mm_and_ps(m, _mm_sub_ps(one, _mm_mul_ps(_mm_mul_ps(t, t), t)));
            // the mask is −1 per lane inside
            cnt = _mm_sub_epi32(cnt, _mm_castps_si128(m));
            let (wx, wy, wz) = (_mm_mul_ps(w, dx), _mm_mul_ps(w, dy), _mm_mul_ps(w, dz));
            let v = [
                w,
                wx,
                wy,
                wz,
                _mm_mul_ps(wx, dx),
                _mm_mul_ps(wx, dy),
                _mm_mul_ps(wx, dz),
                _mm_mul_ps(wy, dy),
                _mm_mul_ps(wy, dz),
                _mm_mul_ps(wz, dz),
            ];
            for (a, v) in acc.iter_mut().zip(v) {
                *a = _mm_add_ps(*a, v);
            }
            j += 4;
        }
        let mut out = [0.0; 10];
        for (o, a) in out.iter_mut().zip(acc) {
            let mut l = [0f32; 4];
            _mm_storeu_ps(l.as_mut_ptr(), a);
            *o = l.iter().map(|&v| v as Real).sum();
        }
        let mut c = [0i32; 4];
        _mm_storeu_si128(c.as_mut_ptr() as *mut __m128i, cnt);
        (c.iter().sum::<i32>() as usize, out)
    }
}

/// Builds the kernels of the particles `pos` with volumes `vol` (m³) and spacing `dx` (m).
pub fn build_kernels(pos: &[Vec3], vol: &[Real], dx: Real, p: &AnisoParams) -> Kernels {
    build_kernels_owned(pos.to_vec(), vol, dx, p)
}

/// [`build_kernels`] taking the positions over: they are freed once copied into cell order.
pub fn build_kernels_owned(pos: Vec<Vec3>, vol: &[Real], dx: Real, p: &AnisoParams) -> Kernels {
    let r = p.radius_rel * dx;
    let h = kernel_radius(p, dx);
    let ks = p.ks_rel / (0.15 * r * r);
    let n = pos.len();
    let grid = CellGrid::build(&pos, r);
    drop(pos);
    let sorted = grid.sorted();
    let cs = grid.cell_size();
    let r2 = (r * r) as f32;
    let inv_r = (1.0 / r) as f32;
    // sums over the neighbours within r (self included) of w, w d, w d dᵀ, d = x_j − x_i, with
    // w = 1 − (|d|/r)³, in f32 lanes (a fixed order: deterministic for any thread count)
    let sums = |cand: &mut Candidates, k: usize| -> (usize, Real, Vec3, [Real; 6]) {
        let xi = sorted[k];
        let key = grid.cell_key(&xi);
        let corner = Vec3::new(key[0] as Real, key[1] as Real, key[2] as Real) * cs;
        if !cand.built {
            cand.built = true;
            cand.x.clear();
            cand.y.clear();
            cand.z.clear();
            for dx in -1..=1 {
                for dy in -1..=1 {
                    for dz in -1..=1 {
                        if let Some((s, e)) =
                            grid.cell_range([key[0] + dx, key[1] + dy, key[2] + dz])
                        {
                            for q in &sorted[s as usize..e as usize] {
                                let d = q - corner;
                                cand.x.push(d.x as f32);
                                cand.y.push(d.y as f32);
                                cand.z.push(d.z as f32);
                            }
                        }
                    }
                }
            }
            while !cand.x.len().is_multiple_of(LANES) {
                cand.x.push(1e15);
                cand.y.push(1e15);
                cand.z.push(1e15);
            }
        }
        let q = xi - corner;
        let (n, a) = moments(
            &cand.x,
            &cand.y,
            &cand.z,
            [q.x as f32, q.y as f32, q.z as f32],
            r2,
            inv_r,
        );
        (
            n,
            a[0],
            Vec3::new(a[1], a[2], a[3]),
            [a[4], a[5], a[6], a[7], a[8], a[9]],
        )
    };
    let sym = |m: &Mat3| {
        [
            m[(0, 0)] as f32,
            m[(0, 1)] as f32,
            m[(0, 2)] as f32,
            m[(1, 1)] as f32,
            m[(1, 2)] as f32,
            m[(2, 2)] as f32,
        ]
    };
    let v3 = |v: &Vec3| [v.x as f32, v.y as f32, v.z as f32];
    // the kernel of the particle at sorted position k: (centre, G, amp, extent, isotropic, deep)
    type Rec = ([f32; 3], [f32; 6], f32, [f32; 3], bool, bool);
    let kernel_of = |cand: &mut Candidates, k: usize, i: usize| -> Rec {
        let xi = sorted[k];
        let key = grid.cell_key(&xi);
        if cand.cell != Some(key) {
            cand.cell = Some(key);
            cand.built = false;
            cand.min_count = u32::MAX;
            for d in 0..27 {
                let c = [
                    key[0] + d / 9 - 1,
                    key[1] + d / 3 % 3 - 1,
                    key[2] + d % 3 - 1,
                ];
                let m = grid.cell_range(c).map_or(0, |(s, e)| e - s);
                cand.min_count = cand.min_count.min(m);
            }
        }
        if cand.min_count as Real >= 0.5 * cs * cs * cs / vol[i] {
            // every cell of the 3×3×3 block around (side 3r) holds ≥ 50 % of a uniform lattice's
            // count: a free surface cuts at most half of an outer cell, so it is ≥ r/2 away and
            // the particle is deep (≥ 0.45 r, see [`is_deep`]). Fast path: no neighbourhood sums,
            // and no centre smoothing, which on a full symmetric neighbourhood would only move
            // the centre by λ times the particle's offset from its neighbours' mean
            let s = 1.0 / h;
            return (
                v3(&xi),
                sym(&(Mat3::identity() * s)),
                (SIGMA_P * s * s * s * vol[i]) as f32,
                v3(&Vec3::repeat(h)),
                !p.anisotropic,
                true,
            );
        }
        let (n_all, wsum, m1, m2) = sums(cand, k);
        let n = n_all.saturating_sub(1);
        let mean = m1 / wsum;
        let center = xi + p.lambda * mean;
        let deep = is_deep(n_all, mean.norm(), r, vol[i]);
        let iso = |scale: Real, deep: bool| {
            let s = 1.0 / (scale * h);
            let g = Mat3::identity() * s;
            (
                v3(&center),
                sym(&g),
                (SIGMA_P * s * s * s * vol[i]) as f32,
                v3(&Vec3::repeat(scale * h)),
                true,
                deep,
            )
        };
        if !p.anisotropic {
            return iso(1.0, deep);
        }
        if n <= p.n_eps {
            return iso(p.kn, false);
        }
        let c = Mat3::new(
            m2[0], m2[1], m2[2], m2[1], m2[3], m2[4], m2[2], m2[4], m2[5],
        ) / wsum
            - mean * mean.transpose();
        let (eigenvalues, rm) = crate::eigen3::sym_eigen3(&c);
        let s1 = eigenvalues.max();
        if eigenvalues.iter().any(|s| !s.is_finite()) || s1 <= 0.0 {
            return iso(p.kn, false);
        }
        let floor = s1 / p.kr;
        let sig = eigenvalues.map(|s| ks * s.max(floor));
        let inv = Mat3::from_diagonal(&sig.map(|s| 1.0 / s));
        let g = rm * inv * rm.transpose() / h;
        let det = 1.0 / (sig.x * sig.y * sig.z * h * h * h);
        // bounding box of the ellipsoid {x : |G x| < 1} = h R Σ̃ (unit ball)
        let a = rm * Mat3::from_diagonal(&sig) * h;
        let ext = Vec3::new(a.row(0).norm(), a.row(1).norm(), a.row(2).norm());
        (
            v3(&center),
            sym(&g),
            (SIGMA_P * det * vol[i]) as f32,
            v3(&ext),
            false,
            deep,
        )
    };

    // kernels stay in cell order (better locality for the density pass); `index` maps back.
    // Shapes that are not plain are collected per chunk of kernels and concatenated in chunk
    // order (deterministic for any thread count).
    const CHUNK: usize = 4096;
    let plain = (sym(&(Mat3::identity() / h)), v3(&Vec3::repeat(h)));
    let mut k = Kernels {
        index: grid.order().to_vec(),
        center: vec![[0.0; 3]; n],
        shape: vec![PLAIN; n],
        g: Vec::new(),
        amp: vec![0.0; n],
        extent: Vec::new(),
        plain,
        deep: vec![false; n],
        isotropic: 0,
    };
    let index = &k.index;
    type Part = (Vec<[f32; 6]>, Vec<[f32; 3]>, usize);
    let parts: Vec<Part> = k
        .center
        .par_chunks_mut(CHUNK)
        .zip(k.amp.par_chunks_mut(CHUNK))
        .zip(k.deep.par_chunks_mut(CHUNK))
        .zip(k.shape.par_chunks_mut(CHUNK))
        .enumerate()
        .map_init(Candidates::default, |cand, (ci, (((c, a), d), sh))| {
            let (mut gs, mut es, mut iso) = (Vec::new(), Vec::new(), 0);
            for j in 0..c.len() {
                let kk = ci * CHUNK + j;
                let (cc, g, aa, e, f, dd) = kernel_of(cand, kk, index[kk] as usize);
                (c[j], a[j], d[j]) = (cc, aa, dd);
                iso += f as usize;
                if (g, e) != plain {
                    sh[j] = gs.len() as u32;
                    gs.push(g);
                    es.push(e);
                }
            }
            (gs, es, iso)
        })
        .collect();
    let mut base = Vec::with_capacity(parts.len());
    for (gs, es, iso) in parts {
        base.push(k.g.len() as u32);
        k.g.extend_from_slice(&gs);
        k.extent.extend_from_slice(&es);
        k.isotropic += iso;
    }
    k.shape
        .par_chunks_mut(CHUNK)
        .zip(base.par_iter())
        .for_each(|(sh, &b)| {
            for s in sh.iter_mut().filter(|s| **s != PLAIN) {
                *s += b;
            }
        });
    k.g.shrink_to_fit();
    k.extent.shrink_to_fit();
    k
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lattice(n: i32, dx: Real) -> Vec<Vec3> {
        let mut v = Vec::new();
        for i in 0..n {
            for j in 0..n {
                for k in 0..n {
                    v.push(Vec3::new(i as Real, j as Real, k as Real) * dx);
                }
            }
        }
        v
    }

    #[test]
    fn interior_kernels_are_nearly_isotropic_and_unit_volume() {
        let dx = 0.1;
        let pos = lattice(11, dx);
        let vol = vec![dx * dx * dx; pos.len()];
        let k = build_kernels(&pos, &vol, dx, &AnisoParams::default());
        let at = |p: usize| k.index.iter().position(|&i| i as usize == p).unwrap();
        let mid_p = 5 * 121 + 5 * 11 + 5;
        let mid = at(mid_p);
        // centre unchanged by symmetric smoothing
        assert!((k.center_of(mid) - pos[mid_p]).norm() < 1e-6);
        // Σ̃ ≈ I in the bulk: G ≈ I/h within the lattice's deviation from a continuum (< 15 %)
        let h = kernel_radius(&AnisoParams::default(), dx);
        let e = nalgebra::SymmetricEigen::new(k.g_of(mid)).eigenvalues * h;
        for v in e.iter() {
            assert!((v - 1.0).abs() < 0.15, "eigenvalue of hG = {v}");
        }
        // surface particle (face centre) is flattened along the face normal, at most k_r
        let face = at(5 * 121 + 5 * 11);
        let e = nalgebra::SymmetricEigen::new(k.g_of(face)).eigenvalues;
        let ratio = e.max() / e.min();
        assert!(ratio > 1.3 && ratio <= 4.0 + 1e-9, "axis ratio {ratio}");
    }

    #[test]
    fn lone_particle_keeps_isotropic_kernel() {
        let pos = vec![Vec3::zeros(), Vec3::new(10.0, 0.0, 0.0)];
        let k = build_kernels(&pos, &[1e-3, 1e-3], 0.1, &AnisoParams::default());
        assert_eq!(k.isotropic, 2);
        let g = k.g_of(0);
        assert!((g - g.transpose()).norm() < 1e-12);
        assert!((g[(0, 0)] - g[(1, 1)]).abs() < 1e-12);
    }
}
