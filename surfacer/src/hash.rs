//! Small hashing and neighbour-search helpers shared by the stages: an Fx-style hasher for
//! integer keys (std's SipHash is needlessly slow for voxel keys) and a cell grid for
//! fixed-radius neighbour queries with deterministic (index-sorted) cell contents.
use crate::{Real, Vec3};
use rayon::prelude::*;
use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

/// Fx hasher (multiply-rotate), deterministic and fast for integer keys.
#[derive(Default, Clone, Copy)]
pub struct FxHasher(u64);

impl Hasher for FxHasher {
    #[inline]
    fn finish(&self) -> u64 {
        self.0
    }
    #[inline]
    fn write(&mut self, bytes: &[u8]) {
        // 8 bytes at a time ([i32; 3] keys arrive here as one 12-byte slice)
        let mut c = bytes.chunks_exact(8);
        for w in &mut c {
            self.write_u64(u64::from_le_bytes(w.try_into().unwrap_or([0; 8])));
        }
        let r = c.remainder();
        if !r.is_empty() {
            let mut b = [0u8; 8];
            b[..r.len()].copy_from_slice(r);
            self.write_u64(u64::from_le_bytes(b));
        }
    }
    #[inline]
    fn write_u64(&mut self, i: u64) {
        self.0 = (self.0.rotate_left(5) ^ i).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }
    #[inline]
    fn write_i32(&mut self, i: i32) {
        self.write_u64(i as u32 as u64);
    }
    #[inline]
    fn write_u32(&mut self, i: u32) {
        self.write_u64(i as u64);
    }
    #[inline]
    fn write_usize(&mut self, i: usize) {
        self.write_u64(i as u64);
    }
}

/// A `HashMap` with the Fx hasher.
pub type FxMap<K, V> = HashMap<K, V, BuildHasherDefault<FxHasher>>;

/// Integer coordinates of a voxel or block.
pub type Key = [i32; 3];

/// Cell → range in [`CellGrid::order`]: a dense table of range starts over the cells' bounding
/// box when that is small, a hash map otherwise.
enum Cells {
    Dense {
        lo: Key,
        dim: [i32; 3],
        /// start of cell c's range; its end is start[c + 1]
        start: Vec<u32>,
    },
    Hash(FxMap<Key, (u32, u32)>),
}

/// Cells (at most this many, and at most 4 per point) for which the dense table is used.
const DENSE_CELLS: i64 = 1 << 24;

/// Uniform cell grid over a point set; cells hold point indices in increasing order.
pub struct CellGrid {
    inv_h: Real,
    cells: Cells,
    order: Vec<u32>,
    /// positions in cell order (contiguous per cell, for cache locality)
    sorted: Vec<Vec3>,
}

impl CellGrid {
    /// Points in cell order (each cell's points by increasing index).
    pub fn order(&self) -> &[u32] {
        &self.order
    }

    /// Positions in cell order.
    pub fn sorted(&self) -> &[Vec3] {
        &self.sorted
    }

    /// Range in [`Self::order`] of the points of cell `key` (if occupied).
    #[inline]
    pub fn cell_range(&self, key: Key) -> Option<(u32, u32)> {
        match &self.cells {
            Cells::Dense { lo, dim, start } => {
                let d = [key[0] - lo[0], key[1] - lo[1], key[2] - lo[2]];
                if (0..3).any(|a| d[a] < 0 || d[a] >= dim[a]) {
                    return None;
                }
                let c = ((d[0] as usize * dim[1] as usize) + d[1] as usize) * dim[2] as usize
                    + d[2] as usize;
                let (s, e) = (start[c], start[c + 1]);
                (e > s).then_some((s, e))
            }
            Cells::Hash(m) => m.get(&key).copied(),
        }
    }

    /// Cell of a point.
    #[inline]
    pub fn cell_key(&self, p: &Vec3) -> Key {
        cell_of(p, self.inv_h)
    }

    /// Cell size.
    pub fn cell_size(&self) -> Real {
        1.0 / self.inv_h
    }

    /// Bins `points` into cells of size `h`.
    pub fn build(points: &[Vec3], h: Real) -> CellGrid {
        Self::build_with(points, h, DENSE_CELLS)
    }

    /// [`Self::build`] with the dense table for at most `dense_limit` cells. Both paths give the
    /// same order: by cell (x, then y, then z), then by index.
    fn build_with(points: &[Vec3], h: Real, dense_limit: i64) -> CellGrid {
        let inv_h = 1.0 / h;
        let bounds = |(l, u): (Key, Key), (m, v): (Key, Key)| {
            (
                [l[0].min(m[0]), l[1].min(m[1]), l[2].min(m[2])],
                [u[0].max(v[0]), u[1].max(v[1]), u[2].max(v[2])],
            )
        };
        let empty = ([i32::MAX; 3], [i32::MIN; 3]);
        let (lo, hi) = points
            .par_iter()
            .map(|p| {
                let k = cell_of(p, inv_h);
                (k, k)
            })
            .reduce(|| empty, bounds);
        let dim = [0, 1, 2].map(|a| (hi[a] as i64 - lo[a] as i64 + 1).max(0));
        let ncells = dim[0] * dim[1] * dim[2];
        if !points.is_empty() && ncells <= dense_limit && ncells <= 4 * points.len() as i64 + 64 {
            // stable counting sort by the dense cell index (indices stay increasing per cell)
            let dim = dim.map(|d| d as i32);
            let cell: Vec<u32> = points
                .par_iter()
                .map(|p| {
                    let k = cell_of(p, inv_h);
                    (((k[0] - lo[0]) as usize * dim[1] as usize + (k[1] - lo[1]) as usize)
                        * dim[2] as usize
                        + (k[2] - lo[2]) as usize) as u32
                })
                .collect();
            let (start, order) = counting_sort(&cell, ncells as usize);
            drop(cell);
            return CellGrid {
                inv_h,
                cells: Cells::Dense { lo, dim, start },
                sorted: order.par_iter().map(|&i| points[i as usize]).collect(),
                order,
            };
        }
        let mut keyed: Vec<(Key, u32)> = points
            .iter()
            .enumerate()
            .map(|(i, p)| (cell_of(p, inv_h), i as u32))
            .collect();
        keyed.par_sort_unstable();
        let mut cells = FxMap::default();
        let mut s = 0;
        while s < keyed.len() {
            let mut e = s + 1;
            while e < keyed.len() && keyed[e].0 == keyed[s].0 {
                e += 1;
            }
            cells.insert(keyed[s].0, (s as u32, e as u32));
            s = e;
        }
        let order: Vec<u32> = keyed.into_iter().map(|(_, i)| i).collect();
        CellGrid {
            inv_h,
            cells: Cells::Hash(cells),
            sorted: order.iter().map(|&i| points[i as usize]).collect(),
            order,
        }
    }

    /// Calls `f(j, d²)` for every point `j` with `|p_j − q| ≤ r`, cells visited in a fixed order
    /// so results are deterministic.
    pub fn for_each_within(
        &self,
        _points: &[Vec3],
        q: &Vec3,
        r: Real,
        mut f: impl FnMut(usize, Real),
    ) {
        let c = cell_of(q, self.inv_h);
        let r2 = r * r;
        let m = (r * self.inv_h).ceil() as i32;
        let h = 1.0 / self.inv_h;
        // squared gap between q and the cell at offset d along one axis
        let gap2 = |qa: Real, ca: i32, d: i32| -> Real {
            let g = if d < 0 {
                qa - (ca + d + 1) as Real * h
            } else if d > 0 {
                (ca + d) as Real * h - qa
            } else {
                0.0
            };
            g * g
        };
        for dx in -m..=m {
            let gx = gap2(q.x, c[0], dx);
            for dy in -m..=m {
                let gy = gx + gap2(q.y, c[1], dy);
                for dz in -m..=m {
                    if gy + gap2(q.z, c[2], dz) > r2 {
                        continue;
                    }
                    if let Some((s, e)) = self.cell_range([c[0] + dx, c[1] + dy, c[2] + dz]) {
                        let (s, e) = (s as usize, e as usize);
                        for (p, &j) in self.sorted[s..e].iter().zip(&self.order[s..e]) {
                            let d2 = (p - q).norm_squared();
                            if d2 <= r2 {
                                f(j as usize, d2);
                            }
                        }
                    }
                }
            }
        }
    }
}

/// Cell containing `p` for cells of size `1/inv_h`.
#[inline]
pub fn cell_of(p: &Vec3, inv_h: Real) -> Key {
    [
        floor_i(p.x * inv_h),
        floor_i(p.y * inv_h),
        floor_i(p.z * inv_h),
    ]
}

/// `x.floor() as i32` without a libm call (x86-64's baseline has no `roundsd`): the same value for
/// every x, NaN and out-of-range values included (both saturate the same way).
#[inline]
fn floor_i(x: Real) -> i32 {
    let i = x as i32;
    i.saturating_sub(((i as Real) > x) as i32)
}

/// Stable counting sort of the indices `0..keys.len()` by `keys` (each < `buckets`): (start of
/// each key's run, with a final end; the indices). Parallel over chunks of the keys, each chunk
/// writing its own disjoint slots: the result is the serial sort's for any thread count. Chunks
/// keep one count per bucket each, so only one is used when there are more buckets than keys.
/// Turns the per-chunk bucket counts of a parallel counting sort into each
/// chunk's first slot per bucket (buckets in order, chunks in order within a
/// bucket) and returns the buckets' first slots (`buckets + 1` entries).
pub(crate) fn chunk_starts<T>(at: &mut [Vec<T>], buckets: usize) -> Vec<T>
where
    T: Copy + Default + std::ops::Add<Output = T>,
{
    let mut start = vec![T::default(); buckets + 1];
    for b in 0..buckets {
        let mut s = start[b];
        for c in at.iter_mut() {
            let m = c[b];
            c[b] = s;
            s = s + m;
        }
        start[b + 1] = s;
    }
    start
}

pub fn counting_sort(keys: &[u32], buckets: usize) -> (Vec<u32>, Vec<u32>) {
    let n = keys.len();
    let chunks = if buckets <= n {
        rayon::current_num_threads().max(1)
    } else {
        1
    };
    let len = n.div_ceil(chunks).max(1 << 16);
    let mut at: Vec<Vec<u32>> = keys
        .par_chunks(len)
        .map(|c| {
            let mut m = vec![0u32; buckets];
            for &k in c {
                m[k as usize] += 1;
            }
            m
        })
        .collect();
    let start = chunk_starts(&mut at, buckets);
    let mut order: Vec<u32> = Vec::with_capacity(n);
    struct Slots(*mut u32);
    // SAFETY (Sync): chunks write disjoint slots (below)
    unsafe impl Sync for Slots {}
    let out = Slots(order.as_mut_ptr());
    keys.par_chunks(len)
        .zip(at.par_iter_mut())
        .enumerate()
        .for_each(|(ci, (c, at))| {
            let out = &out;
            for (j, &k) in c.iter().enumerate() {
                let slot = &mut at[k as usize];
                // SAFETY: the runs partition 0..n and each slot is claimed by one key once
                unsafe { *out.0.add(*slot as usize) = (ci * len + j) as u32 };
                *slot += 1;
            }
        });
    // SAFETY: all n slots were written above
    unsafe { order.set_len(n) };
    (start, order)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cell_grid_finds_exactly_the_points_within_r() {
        let pts: Vec<Vec3> = (0..200)
            .map(|i| {
                let t = i as Real * 0.37;
                Vec3::new(t.sin() * 2.0, (1.3 * t).cos() * 2.0, (0.7 * t).sin())
            })
            .collect();
        // cells equal to and smaller than the radius (regression: smaller cells once missed points)
        for cell in [0.5, 0.25, 0.17] {
            let g = CellGrid::build(&pts, cell);
            for q in &pts[..40] {
                let mut found = Vec::new();
                g.for_each_within(&pts, q, 0.5, |j, _| found.push(j));
                found.sort();
                let brute: Vec<usize> = (0..pts.len())
                    .filter(|&j| (pts[j] - q).norm() <= 0.5)
                    .collect();
                assert_eq!(found, brute, "cell {cell}");
            }
        }
    }

    #[test]
    fn floor_and_counting_sort_match_the_plain_versions() {
        for x in [
            0.0,
            -0.0,
            0.5,
            -0.5,
            -1.0,
            1.0,
            2.9999,
            -2.0001,
            1e12,
            -1e12,
            Real::NAN,
        ] {
            assert_eq!(floor_i(x), x.floor() as i32, "{x}");
        }
        let mut r = 5u64;
        let keys: Vec<u32> = (0..200_000)
            .map(|_| {
                r = r
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                ((r >> 33) % 1000) as u32
            })
            .collect();
        let (start, order) = counting_sort(&keys, 1000);
        let mut want: Vec<u32> = (0..keys.len() as u32).collect();
        want.sort_by_key(|&i| keys[i as usize]);
        assert_eq!(order, want);
        assert_eq!(start[1000] as usize, keys.len());
        for b in 0..1000 {
            let run = &order[start[b] as usize..start[b + 1] as usize];
            assert!(run.iter().all(|&i| keys[i as usize] == b as u32));
        }
    }

    #[test]
    fn dense_and_hashed_cells_give_the_same_grid() {
        let pts: Vec<Vec3> = (0..500)
            .map(|i| {
                let t = i as Real * 0.61;
                Vec3::new(
                    t.sin() * 1.5,
                    (0.9 * t).cos() * 1.5 - 3.0,
                    (0.3 * t).sin() + 7.0,
                )
            })
            .collect();
        let d = CellGrid::build_with(&pts, 0.3, DENSE_CELLS);
        let h = CellGrid::build_with(&pts, 0.3, 0);
        assert!(matches!(d.cells, Cells::Dense { .. }) && matches!(h.cells, Cells::Hash(_)));
        assert_eq!(d.order, h.order);
        for p in &pts {
            let k = d.cell_key(p);
            for dk in [[0, 0, 0], [1, 0, 0], [0, -1, 0], [0, 0, 40]] {
                let q = [k[0] + dk[0], k[1] + dk[1], k[2] + dk[2]];
                assert_eq!(d.cell_range(q), h.cell_range(q));
            }
        }
    }
}
