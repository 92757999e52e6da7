//! Volume fraction field of the volume particles: f(x) = Σ_j V_j W_j(x) with the anisotropic
//! kernels of [`crate::anisotropy`] (Yu & Turk 2013 eq. 5, with the particle volume V_j in place of
//! m_j/ρ_j), and the kernel-weighted velocity u(x) = Σ_j V_j W_j(x) v_j / f(x).
//!
//! The field is computed block by block (8³ voxels, the level set's leaf size): each particle is
//! binned into the blocks its kernel box touches, and every block sums its particles in index
//! order — parallel over blocks and independent of the thread count. Only blocks some kernel
//! touches exist; a block is kept at 16 bytes per voxel until the band is built. Blocks are stored
//! inline in one vector, so dropping the field returns its memory to the system at once.
use crate::anisotropy::Kernels;
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
    /// kernel-weighted velocity (m/s)
    pub vel: [[f32; 3]; LEAF_SIZE],
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
            Some(&b) => self.blocks[b].vel[voxel_index(ijk)],
            None => [0.0; 3],
        }
    }
    /// Bytes held.
    pub fn memory_bytes(&self) -> usize {
        self.blocks.len() * LEAF_SIZE * 16
    }
}

/// Blocks (origins) overlapped by the box `c ± e` (voxel size `1/inv`).
fn blocks_of(c: Vec3, e: Vec3, inv: Real) -> impl Iterator<Item = Key> {
    let lo = leaf_origin(((c - e) * inv).map(|x| x.ceil() as i32).into());
    let hi = leaf_origin(((c + e) * inv).map(|x| x.floor() as i32).into());
    let step = LEAF_DIM as usize;
    (lo[0]..=hi[0]).step_by(step).flat_map(move |x| {
        (lo[1]..=hi[1])
            .step_by(step)
            .flat_map(move |y| (lo[2]..=hi[2]).step_by(step).map(move |z| [x, y, z]))
    })
}

/// Sorted, deduplicated union of per-thread key sets.
fn key_set(it: impl ParallelIterator<Item = Key>) -> Vec<Key> {
    let sets = it
        .fold(FxMap::<Key, ()>::default, |mut m, k| {
            m.insert(k, ());
            m
        })
        .reduce(FxMap::default, |mut a, b| {
            if a.len() < b.len() {
                return b.into_iter().fold(a, |mut m, (k, _)| {
                    m.insert(k, ());
                    m
                });
            }
            a.extend(b);
            a
        });
    let mut v: Vec<Key> = sets.into_keys().collect();
    v.par_sort_unstable();
    v
}

/// Sums the kernels (with particle velocities `vel`, indexed by `k.index`) on the grid of voxel
/// size `h`, in the *band blocks* only: blocks within `reach` (m) of a particle that is not deep
/// (or within its kernel box and two voxels). Blocks that only deep kernels touch are recorded as
/// interior (their voxels are ≥ ~0.6 r − kernel radius inside the liquid: f ≥ 1 − lattice noise).
pub fn rasterize(k: &Kernels, vel: &[Vec3], h: Real, reach: Real) -> DensityField {
    let inv = 1.0 / h;
    let nk = k.center.len();
    let t0 = std::time::Instant::now();
    let band = key_set(
        (0..nk)
            .into_par_iter()
            .filter(|&i| !k.deep[i])
            .flat_map_iter(|i| {
                let e = k.extent_of(i).add_scalar(2.0 * h).sup(&Vec3::repeat(reach));
                blocks_of(k.center_of(i), e, inv)
            }),
    );
    let band_index: FxMap<Key, ()> = band.iter().map(|&b| (b, ())).collect();
    let interior = key_set(
        (0..nk)
            .into_par_iter()
            .filter(|&i| k.deep[i])
            .flat_map_iter(|i| blocks_of(k.center_of(i), k.extent_of(i), inv))
            .filter(|b| !band_index.contains_key(b)),
    );
    // (block, kernel) pairs in band blocks
    let mut pairs: Vec<(Key, u32)> = (0..nk)
        .into_par_iter()
        .flat_map_iter(|i| {
            blocks_of(k.center_of(i), k.extent_of(i), inv)
                .filter(|b| band_index.contains_key(b))
                .map(move |b| (b, i as u32))
        })
        .collect();
    drop(band_index);
    let t1 = t0.elapsed().as_secs_f64();
    pairs.par_sort_unstable();
    let t2 = t0.elapsed().as_secs_f64();
    let mut groups: Vec<(usize, usize)> = Vec::new();
    let mut s = 0;
    while s < pairs.len() {
        let mut e = s + 1;
        while e < pairs.len() && pairs[e].0 == pairs[s].0 {
            e += 1;
        }
        groups.push((s, e));
        s = e;
    }
    let blocks: Vec<DensityBlock> = groups
        .par_iter()
        .map(|&(s, e)| {
            let origin = pairs[s].0;
            let mut f = [0f64; LEAF_SIZE];
            let mut m = [[0f64; 3]; LEAF_SIZE];
            let ob = Vec3::new(origin[0] as Real, origin[1] as Real, origin[2] as Real);
            for &(_, pi) in &pairs[s..e] {
                let i = pi as usize;
                let ex = k.extent_of(i) * inv;
                // centre in voxel units relative to the block; G in voxel units (q = Gv (x − c))
                let c = k.center_of(i) * inv - ob;
                let gs = k.g[i];
                let amp = k.amp[i] as Real;
                let v = vel[k.index[i] as usize];
                let lo = (c - ex).map(|x| (x.ceil() as i32).max(0));
                let hi = (c + ex).map(|x| (x.floor() as i32).min(LEAF_DIM - 1));
                let mut add = |x: i32, y: i32, z: i32, s2: Real| {
                    if s2 < 1.0 {
                        let t = 1.0 - s2;
                        let w = amp * t * t * t;
                        let n = ((x << 6) | (y << 3) | z) as usize;
                        f[n] += w;
                        m[n][0] += w * v.x;
                        m[n][1] += w * v.y;
                        m[n][2] += w * v.z;
                    }
                };
                if gs[1] == 0.0 && gs[2] == 0.0 && gs[4] == 0.0 && gs[0] == gs[3] && gs[0] == gs[5]
                {
                    // isotropic: |q|² = s² |x − c|², z-interval from the radius
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
                            let zr = (r2 - rxy).sqrt();
                            let z0 = ((c.z - zr).ceil() as i32).max(lo.z);
                            let z1 = ((c.z + zr).floor() as i32).min(hi.z);
                            for z in z0..=z1 {
                                let dz = z as Real - c.z;
                                add(x, y, z, s2 * (rxy + dz * dz));
                            }
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
                // |u + z gz|² < 1 is a quadratic in z: visit only its interval
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
                        let disc = qb * qb - qa * (qc - 1.0);
                        if disc <= 0.0 {
                            continue;
                        }
                        let sd = disc.sqrt();
                        let z0 = (((-qb - sd) / qa).ceil() as i32).max(lo.z);
                        let z1 = (((-qb + sd) / qa).floor() as i32).min(hi.z);
                        for z in z0..=z1 {
                            let q = u + gz * z as Real;
                            add(x, y, z, q.norm_squared());
                        }
                    }
                }
            }
            let mut fo = [0f32; LEAF_SIZE];
            let mut vo = [[0f32; 3]; LEAF_SIZE];
            for n in 0..LEAF_SIZE {
                fo[n] = f[n] as f32;
                if f[n] > 0.0 {
                    vo[n] = [
                        (m[n][0] / f[n]) as f32,
                        (m[n][1] / f[n]) as f32,
                        (m[n][2] / f[n]) as f32,
                    ];
                }
            }
            DensityBlock {
                origin,
                f: fo,
                vel: vo,
            }
        })
        .collect();
    if std::env::var("SURFACER_DEBUG").is_ok() {
        eprintln!(
            "density: sets+pairs {t1:.2} sort {:.2} blocks {:.2} s, {} pairs",
            t2 - t1,
            t0.elapsed().as_secs_f64() - t2,
            pairs.len()
        );
    }
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
