//! Fixed-radius neighbour search shared by every stage.
//!
//! A uniform cell grid (cell size = search radius) over the points, stored as
//! a sorted cell list: points are ordered by cell with a counting sort and a
//! hash map gives each occupied cell its contiguous range. A query visits the
//! 27 cells around it. Memory is O(points), independent of the bounding box.
//! `docs/decisions.md` records the measurement against kiddo's k-d tree that
//! chose this structure.
//!
//! Results are deterministic: every neighbour list is sorted by index, and
//! the parallel build does not depend on the thread count.

use crate::math::{Real, Vec3};
use rayon::prelude::*;
use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

/// A small multiplicative hasher for integer cell keys (std's SipHash is
/// several times slower here and the keys are not attacker-controlled).
#[derive(Default, Clone, Copy)]
pub struct CellHasher(u64);

impl Hasher for CellHasher {
    #[inline]
    fn finish(&self) -> u64 {
        self.0
    }
    #[inline]
    fn write(&mut self, bytes: &[u8]) {
        // a cell key [i32; 3] arrives here as one 12-byte slice (integer
        // slices hash their bytes at once): mix it 4 bytes at a time, not
        // byte by byte (the per-byte loop was ~5 % of a film step's profile)
        let mut chunks = bytes.chunks_exact(4);
        for c in &mut chunks {
            self.write_u64(u32::from_le_bytes([c[0], c[1], c[2], c[3]]) as u64);
        }
        for &b in chunks.remainder() {
            self.write_u64(b as u64);
        }
    }
    #[inline]
    fn write_i32(&mut self, i: i32) {
        self.write_u64(i as u32 as u64);
    }
    #[inline]
    fn write_u64(&mut self, i: u64) {
        self.0 = (self.0.rotate_left(5) ^ i).wrapping_mul(0x51_7C_C1_B7_27_22_0A_95);
    }
    #[inline]
    fn write_usize(&mut self, i: usize) {
        self.write_u64(i as u64);
    }
}

/// Hash map keyed by cell, with [`CellHasher`].
pub type CellMap<V> = HashMap<Cell, V, BuildHasherDefault<CellHasher>>;

/// Integer cell coordinate.
pub type Cell = [i32; 3];

/// Cell of a point for a grid of cell size `h`.
#[inline]
pub fn cell_of(p: &Vec3, inv_h: Real) -> Cell {
    [
        (p.x * inv_h).floor() as i32,
        (p.y * inv_h).floor() as i32,
        (p.z * inv_h).floor() as i32,
    ]
}

/// A uniform grid over a point set, for fixed-radius queries.
#[derive(Clone, Debug)]
pub struct CellGrid {
    h: Real,
    inv_h: Real,
    /// Point indices ordered by cell.
    order: Vec<u32>,
    /// For every occupied cell, the range of `order` that holds its points.
    ranges: CellMap<(u32, u32)>,
    /// Occupied cells in sorted order (deterministic traversal).
    cells: Vec<Cell>,
}

impl CellGrid {
    /// Builds the grid over `points` with cell size `h` (> 0, finite).
    pub fn build(points: &[Vec3], h: Real) -> CellGrid {
        assert!(
            h > 0.0 && h.is_finite(),
            "cell size must be positive and finite"
        );
        let inv_h = 1.0 / h;
        let cells: Vec<Cell> = points.par_iter().map(|p| cell_of(p, inv_h)).collect();
        let mut order: Vec<u32> = (0..points.len() as u32).collect();
        // Stable sort by cell: ties keep index order, so the grid is deterministic.
        order.par_sort_by_key(|&i| cells[i as usize]);
        let mut ranges =
            CellMap::with_capacity_and_hasher(points.len() / 4 + 1, Default::default());
        let mut occupied = Vec::new();
        let mut s = 0usize;
        while s < order.len() {
            let c = cells[order[s] as usize];
            let mut e = s + 1;
            while e < order.len() && cells[order[e] as usize] == c {
                e += 1;
            }
            ranges.insert(c, (s as u32, e as u32));
            occupied.push(c);
            s = e;
        }
        CellGrid {
            h,
            inv_h,
            order,
            ranges,
            cells: occupied,
        }
    }

    /// Cell size.
    pub fn cell_size(&self) -> Real {
        self.h
    }

    /// Calls `f(j, d²)` for every point `j` of the grid with |x_j − q| < r.
    /// `r` must not exceed the cell size. The visiting order is deterministic
    /// but not sorted.
    #[inline]
    pub fn for_each_within(
        &self,
        points: &[Vec3],
        q: &Vec3,
        r: Real,
        mut f: impl FnMut(usize, Real),
    ) {
        debug_assert!(r <= self.h * (1.0 + 1e-12));
        let r2 = r * r;
        for cell in self.block(&cell_of(q, self.inv_h)) {
            for &j in cell {
                let d2 = (points[j as usize] - q).norm_squared();
                if d2 < r2 {
                    f(j as usize, d2);
                }
            }
        }
    }

    /// The occupied cells, sorted.
    pub fn cells(&self) -> &[Cell] {
        &self.cells
    }

    /// The points of cell `c` (ascending indices; empty when unoccupied).
    pub fn members(&self, c: &Cell) -> &[u32] {
        self.ranges
            .get(c)
            .map_or(&[], |&(s, e)| &self.order[s as usize..e as usize])
    }

    /// Appends the points of the 27 cells around `c` (itself included) to
    /// `out`, cell by cell: the candidates of every query in `c` within the
    /// cell size.
    pub fn gather_block(&self, c: &Cell, out: &mut Vec<u32>) {
        for cell in self.block(c) {
            out.extend_from_slice(cell);
        }
    }

    /// The points of each of the 27 cells around `c` (itself included), in
    /// a fixed order.
    fn block<'a>(&'a self, c: &Cell) -> impl Iterator<Item = &'a [u32]> + 'a {
        let c = *c;
        (-1..=1).flat_map(move |dx| {
            (-1..=1).flat_map(move |dy| {
                (-1..=1).map(move |dz| self.members(&[c[0] + dx, c[1] + dy, c[2] + dz]))
            })
        })
    }

    /// True when some point of the grid lies within `r` of `q` (`r` at most
    /// the cell size); stops at the first one found.
    pub fn any_within(&self, points: &[Vec3], q: &Vec3, r: Real) -> bool {
        debug_assert!(r <= self.h * (1.0 + 1e-12));
        let r2 = r * r;
        self.block(&cell_of(q, self.inv_h)).any(|cell| {
            cell.iter()
                .any(|&j| (points[j as usize] - q).norm_squared() < r2)
        })
    }
}

/// Neighbour lists in compressed-row form: the neighbours of query `i` are
/// `indices[offsets[i]..offsets[i+1]]`, sorted by index.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct NeighborLists {
    /// Row offsets, `len() = queries + 1`.
    pub offsets: Vec<usize>,
    /// Neighbour indices into the searched point set.
    pub indices: Vec<u32>,
}

impl NeighborLists {
    /// Neighbours of query `i`.
    #[inline]
    pub fn of(&self, i: usize) -> &[u32] {
        &self.indices[self.offsets[i]..self.offsets[i + 1]]
    }

    /// Number of query rows.
    pub fn len(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    /// True when there are no rows.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Mean number of neighbours per row.
    pub fn mean_count(&self) -> Real {
        if self.is_empty() {
            0.0
        } else {
            self.indices.len() as Real / self.len() as Real
        }
    }

    fn from_rows(rows: Vec<Vec<u32>>) -> NeighborLists {
        let mut offsets = Vec::with_capacity(rows.len() + 1);
        offsets.push(0);
        let total: usize = rows.iter().map(|r| r.len()).sum();
        let mut indices = Vec::with_capacity(total);
        for r in rows {
            indices.extend_from_slice(&r);
            offsets.push(indices.len());
        }
        NeighborLists { offsets, indices }
    }
}

/// All pairs within `radius` inside one point set; a point is not its own
/// neighbour. Each list is sorted by index.
pub fn neighbor_lists(points: &[Vec3], radius: Real) -> NeighborLists {
    let grid = CellGrid::build(points, radius);
    let r2 = radius * radius;
    // Queries are visited cell by cell: the 27 surrounding ranges are looked
    // up once per cell and their candidates copied into a contiguous buffer.
    let per_cell: Vec<Vec<(u32, Vec<u32>)>> = grid
        .cells
        .par_iter()
        .map(|c| {
            let mut cand: Vec<u32> = Vec::with_capacity(256);
            grid.gather_block(c, &mut cand);
            cand.sort_unstable();
            let cand_x: Vec<Vec3> = cand.iter().map(|&j| points[j as usize]).collect();
            let (s, e) = grid.ranges[c];
            grid.order[s as usize..e as usize]
                .iter()
                .map(|&i| {
                    let xi = points[i as usize];
                    let row: Vec<u32> = cand
                        .iter()
                        .zip(&cand_x)
                        .filter(|(&j, xj)| j != i && (*xj - xi).norm_squared() < r2)
                        .map(|(&j, _)| j)
                        .collect();
                    (i, row)
                })
                .collect()
        })
        .collect();
    let mut rows = vec![Vec::new(); points.len()];
    for cell in per_cell {
        for (i, row) in cell {
            rows[i as usize] = row;
        }
    }
    NeighborLists::from_rows(rows)
}

/// For every query point, the points of `points` within `radius` (a query
/// that coincides with a point does see it). Each list is sorted by index.
pub fn neighbor_lists_between(queries: &[Vec3], points: &[Vec3], radius: Real) -> NeighborLists {
    let grid = CellGrid::build(points, radius);
    let rows: Vec<Vec<u32>> = queries
        .par_iter()
        .map(|q| {
            let mut row = Vec::with_capacity(64);
            grid.for_each_within(points, q, radius, |j, _| row.push(j as u32));
            row.sort_unstable();
            row
        })
        .collect();
    NeighborLists::from_rows(rows)
}

/// The same lists as [`neighbor_lists`], found with kiddo's immutable k-d
/// tree. Kept for the benchmark that compares the two (`codimfx bench
/// neighbors`) and as an independent check in tests.
pub fn neighbor_lists_kiddo(points: &[Vec3], radius: Real) -> NeighborLists {
    use kiddo::{ImmutableKdTree, SquaredEuclidean};
    let pts: Vec<[Real; 3]> = points.iter().map(|p| [p.x, p.y, p.z]).collect();
    let Ok(tree) = ImmutableKdTree::<Real, 3>::new_from_slice(&pts) else {
        return NeighborLists::from_rows(vec![Vec::new(); pts.len()]);
    };
    let r2 = radius * radius;
    let rows: Vec<Vec<u32>> = (0..pts.len())
        .into_par_iter()
        .map(|i| {
            let mut row: Vec<u32> = tree
                .query(&pts[i])
                .within::<SquaredEuclidean<Real>>(r2)
                .unsorted()
                .execute()
                .into_iter()
                .filter(|n| n.item as usize != i && n.distance < r2)
                .map(|n| n.item)
                .collect();
            row.sort_unstable();
            row
        })
        .collect();
    NeighborLists::from_rows(rows)
}

/// Connected components of a graph on the nodes 0..n: a label per node
/// (`u32::MAX` for the nodes `active` leaves out) and the number of
/// components, numbered in the order of their lowest node.
/// `neighbors(i, push)` calls `push(j)` for each neighbour j of i; j out of
/// range or inactive is skipped. Used for a film's separate sheets
/// (`film::air`) and the cut liquid's bodies (`coupling::cut`).
pub fn components(
    n: usize,
    active: impl Fn(usize) -> bool,
    neighbors: impl Fn(usize, &mut dyn FnMut(usize)),
) -> (Vec<u32>, usize) {
    let mut label = vec![u32::MAX; n];
    let mut count = 0u32;
    let mut stack = Vec::new();
    for s in 0..n {
        if label[s] != u32::MAX || !active(s) {
            continue;
        }
        label[s] = count;
        stack.push(s);
        while let Some(i) = stack.pop() {
            neighbors(i, &mut |j| {
                if j < n && label[j] == u32::MAX && active(j) {
                    label[j] = count;
                    stack.push(j);
                }
            });
        }
        count += 1;
    }
    (label, count as usize)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lattice(n: usize, s: Real) -> Vec<Vec3> {
        let mut v = Vec::new();
        for i in 0..n {
            for j in 0..n {
                for k in 0..n {
                    // a little deterministic jitter so no distance ties the radius exactly
                    let j3 = ((i * 7 + j * 13 + k * 29) % 17) as Real / 17.0 * 0.1 * s;
                    v.push(Vec3::new(
                        i as Real * s + j3,
                        j as Real * s - j3,
                        k as Real * s + 0.5 * j3,
                    ));
                }
            }
        }
        v
    }

    fn brute(points: &[Vec3], r: Real) -> NeighborLists {
        let rows = (0..points.len())
            .map(|i| {
                (0..points.len())
                    .filter(|&j| j != i && (points[i] - points[j]).norm_squared() < r * r)
                    .map(|j| j as u32)
                    .collect()
            })
            .collect();
        NeighborLists::from_rows(rows)
    }

    #[test]
    fn grid_matches_brute_force_and_kiddo() {
        let pts = lattice(9, 0.1);
        let r = 0.23;
        let a = neighbor_lists(&pts, r);
        assert_eq!(a, brute(&pts, r));
        assert_eq!(a, neighbor_lists_kiddo(&pts, r));
        assert!(a.mean_count() > 20.0);
    }

    #[test]
    fn negative_coordinates_and_between() {
        let pts: Vec<Vec3> = lattice(6, 0.1)
            .into_iter()
            .map(|p| p - Vec3::new(0.3, 0.3, 0.3))
            .collect();
        let q = vec![Vec3::new(0.0, 0.0, 0.0), Vec3::new(-0.3, -0.3, -0.3)];
        let nl = neighbor_lists_between(&q, &pts, 0.15);
        for (qi, qp) in q.iter().enumerate() {
            let expect: Vec<u32> = (0..pts.len())
                .filter(|&j| (pts[j] - qp).norm_squared() < 0.15 * 0.15)
                .map(|j| j as u32)
                .collect();
            assert_eq!(nl.of(qi), &expect[..]);
        }
    }
}
