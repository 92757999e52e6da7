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

/// Uniform cell grid over a point set; cells hold point indices in increasing order.
pub struct CellGrid {
    inv_h: Real,
    cells: FxMap<Key, (u32, u32)>,
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
        self.cells.get(&key).copied()
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
        let inv_h = 1.0 / h;
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
            cells,
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
                    if let Some(&(s, e)) = self.cells.get(&[c[0] + dx, c[1] + dy, c[2] + dz]) {
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
        (p.x * inv_h).floor() as i32,
        (p.y * inv_h).floor() as i32,
        (p.z * inv_h).floor() as i32,
    ]
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
}
