//! Volume fraction field of the volume particles: f(x) = Σ_j V_j W_j(x) with the anisotropic
//! kernels of [`crate::anisotropy`] (Yu & Turk 2013 eq. 5, with the particle volume V_j in place of
//! m_j/ρ_j), and the kernel-weighted velocity u(x) = Σ_j V_j W_j(x) v_j / f(x).
//!
//! The field is computed block by block (8³ voxels, the level set's leaf size): each particle is
//! binned into the blocks its kernel box touches, and every block sums its particles in index
//! order — parallel over blocks and independent of the thread count. Only blocks some kernel
//! touches exist; a block is kept at 10 bytes per voxel (f32 f, u16 velocities) until the band is
//! built. Blocks are stored inline in one vector, so dropping the field returns its memory to the
//! system at once.
use crate::anisotropy::Kernels;
use crate::blockset::{group_by_block, union_of_boxes, BlockIds};
use crate::hash::{FxMap, Key};
use crate::levelset::{leaf_origin, voxel_index, LEAF_DIM, LEAF_SIZE};
use crate::{Real, Vec3};
use rayon::prelude::*;

/// One 8³ block of the field.
pub struct DensityBlock {
    /// voxel coordinates of voxel 0
    pub origin: Key,
    /// volume fraction (1 in the bulk)
    pub f: [f32; LEAF_SIZE],
    /// kernel-weighted velocity, quantised: v = vmin + q · vstep per component (exact where the
    /// block's velocity is uniform; otherwise within (max − min)/131070 of the f32 value)
    pub vq: [[u16; 3]; LEAF_SIZE],
    /// lowest velocity of the block's voxels with f > 0 (m/s)
    pub vmin: [f32; 3],
    /// quantisation step (m/s)
    pub vstep: [f32; 3],
}

impl DensityBlock {
    /// Velocity of voxel `n` (m/s).
    #[inline]
    pub fn vel(&self, n: usize) -> [f32; 3] {
        let q = self.vq[n];
        [0, 1, 2].map(|a| self.vmin[a] + q[a] as f32 * self.vstep[a])
    }
}

/// The blocked field.
#[derive(Default)]
pub struct DensityField {
    /// voxel size (m)
    pub voxel: Real,
    /// blocks sorted by origin
    pub blocks: Vec<DensityBlock>,
    /// origin → index
    pub index: FxMap<Key, usize>,
    /// origins of blocks (sorted) that only deep particles reach: entirely inside, never
    /// evaluated
    pub interior: Vec<Key>,
}

impl DensityField {
    /// Volume fraction at voxel `ijk` (1, the bulk value, in interior blocks; 0 outside every
    /// block).
    #[inline]
    pub fn f(&self, ijk: Key) -> f32 {
        let o = leaf_origin(ijk);
        match self.index.get(&o) {
            Some(&b) => self.blocks[b].f[voxel_index(ijk)],
            None if self.interior.binary_search(&o).is_ok() => 1.0,
            None => 0.0,
        }
    }
    /// Velocity at voxel `ijk`.
    #[inline]
    pub fn vel(&self, ijk: Key) -> [f32; 3] {
        match self.index.get(&leaf_origin(ijk)) {
            Some(&b) => self.blocks[b].vel(voxel_index(ijk)),
            None => [0.0; 3],
        }
    }
    /// Bytes held.
    pub fn memory_bytes(&self) -> usize {
        self.blocks.len() * std::mem::size_of::<DensityBlock>()
    }
}

/// ⌈x⌉ as an integer without a libm call (x86-64's baseline has no `roundsd`): exact for
/// |x| < 2³¹; NaN gives 0 like `x.ceil() as i32`. Used for row bounds in block-local voxel units.
#[inline]
fn ceil_i(x: Real) -> i32 {
    let i = x as i32;
    i + ((i as Real) < x) as i32
}

/// ⌊x⌋ as an integer, see [`ceil_i`].
#[inline]
fn floor_i(x: Real) -> i32 {
    let i = x as i32;
    i - ((i as Real) > x) as i32
}

/// Block-index box (origins / 8, inclusive) overlapped by the box `c ± e` (voxel size `1/inv`).
fn block_box(c: Vec3, e: Vec3, inv: Real) -> ([i32; 3], [i32; 3]) {
    let lo: [i32; 3] = ((c - e) * inv).map(|x| x.ceil() as i32 >> 3).into();
    let hi: [i32; 3] = ((c + e) * inv).map(|x| x.floor() as i32 >> 3).into();
    (lo, hi)
}

/// Sums the kernels (with particle velocities `vel`, indexed by `k.index`) on the grid of voxel
/// size `h`, in the *band blocks* only: blocks within `reach` (m) of a particle that is not deep
/// (or within its kernel box and two voxels). Blocks that only deep kernels touch are recorded as
/// interior (their voxels are ≥ ~0.6 r − kernel radius inside the liquid: f ≥ 1 − lattice noise).
pub fn rasterize(k: &Kernels, vel: &[[f32; 3]], h: Real, reach: Real) -> DensityField {
    let inv = 1.0 / h;
    let nk = k.center.len();
    let band = union_of_boxes(nk, &|i| {
        (!k.deep[i]).then(|| {
            let e = k.extent_of(i).add_scalar(2.0 * h).sup(&Vec3::repeat(reach));
            block_box(k.center_of(i), e, inv)
        })
    });
    let ids = BlockIds::new(&band);
    let mut interior = union_of_boxes(nk, &|i| {
        k.deep[i].then(|| block_box(k.center_of(i), k.extent_of(i), inv))
    });
    interior.retain(|b| ids.get(b.map(|x| x >> 3)).is_none());
    // kernels grouped by band block, each block's in kernel order (a counting sort over the
    // kernels' boxes, without storing the 2.5 M (block, kernel) pairs)
    let (start, list) = group_by_block(nk, band.len(), &|i, f| {
        let (a, b) = block_box(k.center_of(i), k.extent_of(i), inv);
        for x in a[0]..=b[0] {
            for y in a[1]..=b[1] {
                for z in a[2]..=b[2] {
                    if let Some(id) = ids.get([x, y, z]) {
                        f(id);
                    }
                }
            }
        }
    });
    drop(ids);
    let groups: Vec<(Key, usize, usize)> = (0..band.len())
        .filter(|&b| start[b + 1] > start[b])
        .map(|b| (band[b], start[b], start[b + 1]))
        .collect();
    let avx2 = has_avx2();
    let blocks: Vec<DensityBlock> = groups
        .par_iter()
        .map(|&(origin, s, e)| block_sums(k, vel, &list[s..e], origin, h, avx2))
        .collect();
    let index = blocks
        .iter()
        .enumerate()
        .map(|(i, b)| (b.origin, i))
        .collect();
    DensityField {
        voxel: h,
        blocks,
        index,
        interior,
    }
}

/// Whether the CPU has AVX2 (x86-64 only; checked once per call of [`rasterize`]).
fn has_avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::is_x86_feature_detected!("avx2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// [`block_sums_body`] compiled for AVX2 where the CPU has it (one 8-voxel row of f32 is one
/// 256-bit register), for the x86-64 baseline otherwise. Same operations in the same order either
/// way (no FMA is enabled, so nothing is contracted): the sums are bit-identical.
fn block_sums(
    k: &Kernels,
    vel: &[[f32; 3]],
    list: &[u32],
    origin: Key,
    h: Real,
    avx2: bool,
) -> DensityBlock {
    #[cfg(target_arch = "x86_64")]
    if avx2 {
        // SAFETY: `avx2` comes from `is_x86_feature_detected!("avx2")`
        return unsafe { block_sums_avx2(k, vel, list, origin, h) };
    }
    let _ = avx2;
    block_sums_body(k, vel, list, origin, h)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn block_sums_avx2(
    k: &Kernels,
    vel: &[[f32; 3]],
    list: &[u32],
    origin: Key,
    h: Real,
) -> DensityBlock {
    block_sums_body(k, vel, list, origin, h)
}

/// Sums the kernels `list` (in that order) on the block at `origin`, with their velocities.
#[inline(always)]
fn block_sums_body(
    k: &Kernels,
    vel: &[[f32; 3]],
    list: &[u32],
    origin: Key,
    h: Real,
) -> DensityBlock {
    let inv = 1.0 / h;
    // sums in f32, one row of 8 voxels (fixed x, y; z = 0..7) at a time: every row of a
    // kernel's box is a quadratic s²(z) = C + z (B + z A) of the block-local z, evaluated
    // on all 8 voxels (w = 0 where s² ≥ 1) without per-row bounds, in a fixed order
    let mut f = [0f32; LEAF_SIZE];
    let mut m = [[0f32; LEAF_SIZE]; 3];
    let ob = Vec3::new(origin[0] as Real, origin[1] as Real, origin[2] as Real);
    for &pi in list {
        let i = pi as usize;
        let ex = k.extent_of(i) * inv;
        // centre in voxel units relative to the block; G in voxel units (q = Gv (x − c))
        let c = k.center_of(i) * inv - ob;
        let gs = k.g_sym(i);
        let amp = k.amp[i];
        let v = vel[k.index[i] as usize];
        let lo = (c - ex).map(|x| ceil_i(x).max(0));
        let hi = (c + ex).map(|x| floor_i(x).min(LEAF_DIM - 1));
        if lo.z > hi.z {
            continue;
        }
        let mut row = |x: i32, y: i32, qa: Real, qb2: Real, qc: Real| {
            let (qa, qb2, qc) = (qa as f32, qb2 as f32, qc as f32);
            let base = ((x << 6) | (y << 3)) as usize;
            let fr = &mut f[base..base + 8];
            let mut w = [0f32; 8];
            for (z, wz) in w.iter_mut().enumerate() {
                let zz = z as f32;
                let t = (1.0 - (qc + zz * (qb2 + zz * qa))).max(0.0);
                *wz = amp * t * t * t;
            }
            for z in 0..8 {
                fr[z] += w[z];
            }
            for (a, ma) in m.iter_mut().enumerate() {
                let mr = &mut ma[base..base + 8];
                for z in 0..8 {
                    mr[z] += w[z] * v[a];
                }
            }
        };
        if gs[1] == 0.0 && gs[2] == 0.0 && gs[4] == 0.0 && gs[0] == gs[3] && gs[0] == gs[5] {
            // isotropic: s² = sc² (|x − c|² in the row) = sc² (ρ² + (z − c_z)²)
            let sc = gs[0] as Real * h;
            let (s2, r2) = (sc * sc, 1.0 / (sc * sc));
            for x in lo.x..=hi.x {
                let dx = x as Real - c.x;
                for y in lo.y..=hi.y {
                    let dy = y as Real - c.y;
                    let rxy = dx * dx + dy * dy;
                    if rxy >= r2 {
                        continue;
                    }
                    row(x, y, s2, -2.0 * s2 * c.z, s2 * (rxy + c.z * c.z));
                }
            }
            continue;
        }
        let g = k.g_of(i) * h;
        let (gx, gy, gz) = (
            g.column(0).into_owned(),
            g.column(1).into_owned(),
            g.column(2).into_owned(),
        );
        // |u + z gz|² < 1 is a quadratic in z: rows where it has no root are skipped
        let qa = gz.norm_squared();
        if qa <= 0.0 {
            continue;
        }
        let u0 = -(g * c);
        for x in lo.x..=hi.x {
            let ux = u0 + gx * x as Real;
            for y in lo.y..=hi.y {
                let u = ux + gy * y as Real;
                let (qb, qc) = (u.dot(&gz), u.norm_squared());
                if qb * qb - qa * (qc - 1.0) <= 0.0 {
                    continue;
                }
                row(x, y, qa, 2.0 * qb, qc);
            }
        }
    }
    let mut fo = [0f32; LEAF_SIZE];
    let mut vo = [[0f32; 3]; LEAF_SIZE];
    let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    for n in 0..LEAF_SIZE {
        fo[n] = f[n];
        if f[n] > 0.0 {
            for a in 0..3 {
                let v = m[a][n] / f[n];
                vo[n][a] = v;
                lo[a] = lo[a].min(v);
                hi[a] = hi[a].max(v);
            }
        }
    }
    let mut vmin = [0f32; 3];
    let mut vstep = [0f32; 3];
    for a in 0..3 {
        if lo[a] < hi[a] {
            vmin[a] = lo[a];
            vstep[a] = (hi[a] - lo[a]) / 65535.0;
        } else if lo[a] == hi[a] {
            vmin[a] = lo[a];
        }
    }
    let mut vq = [[0u16; 3]; LEAF_SIZE];
    for n in 0..LEAF_SIZE {
        if f[n] > 0.0 {
            for a in 0..3 {
                if vstep[a] > 0.0 {
                    // non-negative: rounding by truncation of x + ½ (no libm call)
                    vq[n][a] = ((vo[n][a] - vmin[a]) / vstep[a] + 0.5).clamp(0.0, 65535.0) as u16;
                }
            }
        }
    }
    DensityBlock {
        origin,
        f: fo,
        vq,
        vmin,
        vstep,
    }
}

/// Inside/outside (f ≥ f_iso) of every voxel of the density blocks, one bit per voxel: what the
/// later stages need once the band is seeded, at 1/128 of the field's memory.
#[derive(Default)]
pub struct SignField {
    /// block origins and their inside masks (bit n of word n/64)
    pub blocks: Vec<(Key, [u64; 8])>,
    /// origins of interior blocks (all inside), sorted
    pub interior: Vec<Key>,
    index: FxMap<Key, usize>,
    interior_index: FxMap<Key, ()>,
}

impl SignField {
    /// Signs of `d` at the iso-value `iso`.
    pub fn new(d: &DensityField, iso: f32) -> Self {
        let blocks: Vec<(Key, [u64; 8])> = d
            .blocks
            .par_iter()
            .map(|b| {
                let mut m = [0u64; 8];
                for n in 0..LEAF_SIZE {
                    if b.f[n] >= iso {
                        m[n >> 6] |= 1 << (n & 63);
                    }
                }
                (b.origin, m)
            })
            .collect();
        let index = blocks.iter().enumerate().map(|(i, b)| (b.0, i)).collect();
        let interior = d.interior.clone();
        let interior_index = interior.iter().map(|&k| (k, ())).collect();
        SignField {
            blocks,
            interior,
            index,
            interior_index,
        }
    }
    /// Inside mask (bit n of word n/64) of the leaf at `origin`.
    pub fn mask(&self, origin: Key) -> [u64; 8] {
        match self.index.get(&origin) {
            Some(&b) => self.blocks[b].1,
            None if self.interior_index.contains_key(&origin) => [u64::MAX; 8],
            None => [0; 8],
        }
    }

    /// Is voxel `ijk` inside (interior blocks: yes; outside every block: no)?
    #[inline]
    pub fn inside(&self, ijk: Key) -> bool {
        let o = leaf_origin(ijk);
        match self.index.get(&o) {
            Some(&b) => {
                let n = voxel_index(ijk);
                self.blocks[b].1[n >> 6] >> (n & 63) & 1 == 1
            }
            None => self.interior_index.contains_key(&o),
        }
    }
}
