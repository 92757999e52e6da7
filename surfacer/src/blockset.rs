//! Sets of 8³ blocks for the density pass: the union of many kernels' block boxes, block
//! origin → index tables, and the grouping of (block, kernel) pairs by block. Each is parallel and
//! gives the same result for any thread count.
use crate::hash::{chunk_starts, FxMap, Key};
use crate::levelset::LEAF_DIM;
use rayon::prelude::*;

/// Blocks (at most this many) for which a dense table is used instead of hashing.
const DENSE_BLOCKS: i64 = 1 << 22;

/// A box of block indices (origins / 8, inclusive).
pub(crate) type BlockBox = ([i32; 3], [i32; 3]);

/// Block origins (sorted, deduplicated) of the union of the block boxes `bx(i)` for `i < n` (`None`:
/// no box): a dense table over their bounds when that is small, per-thread hash sets otherwise.
/// Parallel and without storing the boxes (they are recomputed for the two passes); the result is
/// a set, so it does not depend on the thread count.
pub(crate) fn union_of_boxes(
    n: usize,
    bx: &(impl Fn(usize) -> Option<BlockBox> + Sync),
) -> Vec<Key> {
    union_of_boxes_with(n, bx, DENSE_BLOCKS)
}

fn union_of_boxes_with(
    n: usize,
    bx: &(impl Fn(usize) -> Option<BlockBox> + Sync),
    dense_limit: i64,
) -> Vec<Key> {
    let (lo, hi) = (0..n)
        .into_par_iter()
        .filter_map(bx)
        .fold(
            || ([i32::MAX; 3], [i32::MIN; 3]),
            |(l, h), b| {
                (
                    [l[0].min(b.0[0]), l[1].min(b.0[1]), l[2].min(b.0[2])],
                    [h[0].max(b.1[0]), h[1].max(b.1[1]), h[2].max(b.1[2])],
                )
            },
        )
        .reduce(
            || ([i32::MAX; 3], [i32::MIN; 3]),
            |(l, h), (m, g)| {
                (
                    [l[0].min(m[0]), l[1].min(m[1]), l[2].min(m[2])],
                    [h[0].max(g[0]), h[1].max(g[1]), h[2].max(g[2])],
                )
            },
        );
    if lo[0] > hi[0] {
        return Vec::new();
    }
    let d = [0, 1, 2].map(|a| (hi[a] - lo[a] + 1).max(0) as i64);
    if d[0] * d[1] * d[2] <= dense_limit {
        use std::sync::atomic::{AtomicBool, Ordering::Relaxed};
        let (dy, dz) = (d[1] as usize, d[2] as usize);
        let mark: Vec<AtomicBool> = (0..(d[0] * d[1] * d[2]) as usize)
            .map(|_| AtomicBool::new(false))
            .collect();
        (0..n).into_par_iter().filter_map(bx).for_each(|(a, b)| {
            for x in a[0]..=b[0] {
                for y in a[1]..=b[1] {
                    let row = (((x - lo[0]) as usize) * dy + (y - lo[1]) as usize) * dz;
                    for m in &mark[row + (a[2] - lo[2]) as usize..=row + (b[2] - lo[2]) as usize] {
                        m.store(true, Relaxed);
                    }
                }
            }
        });
        return mark
            .par_iter()
            .enumerate()
            .filter(|(_, m)| m.load(Relaxed))
            .map(|(n, _)| {
                let (x, y, z) = (n / (dy * dz), n / dz % dy, n % dz);
                [
                    (x as i32 + lo[0]) * LEAF_DIM,
                    (y as i32 + lo[1]) * LEAF_DIM,
                    (z as i32 + lo[2]) * LEAF_DIM,
                ]
            })
            .collect();
    }
    let sets = (0..n)
        .into_par_iter()
        .filter_map(bx)
        .fold(FxMap::<Key, ()>::default, |mut m, (a, b)| {
            for x in a[0]..=b[0] {
                for y in a[1]..=b[1] {
                    for z in a[2]..=b[2] {
                        m.insert([x * LEAF_DIM, y * LEAF_DIM, z * LEAF_DIM], ());
                    }
                }
            }
            m
        })
        .reduce(FxMap::default, |mut a, b| {
            a.extend(b);
            a
        });
    let mut v: Vec<Key> = sets.into_keys().collect();
    v.par_sort_unstable();
    v
}

/// Block origin → index into a sorted list of blocks (dense table over their bounds when small).
pub(crate) enum BlockIds {
    Dense {
        lo: [i32; 3],
        d: [i32; 3],
        id: Vec<u32>,
    },
    Sparse(FxMap<Key, u32>),
}

impl BlockIds {
    pub(crate) fn new(blocks: &[Key]) -> Self {
        Self::new_with(blocks, DENSE_BLOCKS)
    }
    fn new_with(blocks: &[Key], dense_limit: i64) -> Self {
        let Some(first) = blocks.first() else {
            return BlockIds::Sparse(FxMap::default());
        };
        let (mut lo, mut hi) = (*first, *first);
        for b in blocks {
            for a in 0..3 {
                lo[a] = lo[a].min(b[a]);
                hi[a] = hi[a].max(b[a]);
            }
        }
        let lo = lo.map(|x| x >> 3);
        let d = [0, 1, 2].map(|a| (hi[a] >> 3) - lo[a] + 1);
        if (d[0] as i64) * (d[1] as i64) * (d[2] as i64) <= dense_limit {
            let mut id = vec![u32::MAX; (d[0] * d[1] * d[2]) as usize];
            for (n, b) in blocks.iter().enumerate() {
                let q = [0, 1, 2].map(|a| (b[a] >> 3) - lo[a]);
                id[((q[0] * d[1] + q[1]) * d[2] + q[2]) as usize] = n as u32;
            }
            BlockIds::Dense { lo, d, id }
        } else {
            BlockIds::Sparse(
                blocks
                    .iter()
                    .enumerate()
                    .map(|(n, &b)| (b, n as u32))
                    .collect(),
            )
        }
    }
    /// Index of the block with block coordinates `q` (origin / 8).
    #[inline]
    pub(crate) fn get(&self, q: [i32; 3]) -> Option<u32> {
        match self {
            BlockIds::Dense { lo, d, id } => {
                let r = [q[0] - lo[0], q[1] - lo[1], q[2] - lo[2]];
                if (0..3).any(|a| r[a] < 0 || r[a] >= d[a]) {
                    return None;
                }
                let v = id[((r[0] * d[1] + r[1]) * d[2] + r[2]) as usize];
                (v != u32::MAX).then_some(v)
            }
            BlockIds::Sparse(m) => m.get(&q.map(|x| x * LEAF_DIM)).copied(),
        }
    }
}

/// The kernels `0..n` grouped by block, each block's kernels in increasing order: `blocks_of(i,
/// f)` calls `f` with the index (< `blocks`) of every block kernel `i` reaches, each once.
/// Returns (start of each block's run, with a final end; the kernels). A stable counting sort
/// without storing the (block, kernel) pairs: chunks of kernels count their blocks, then walk
/// them again writing each kernel into its own disjoint slots. Same result for any thread count.
pub(crate) fn group_by_block(
    n: usize,
    blocks: usize,
    blocks_of: &(impl Fn(usize, &mut dyn FnMut(u32)) + Sync),
) -> (Vec<usize>, Vec<u32>) {
    let len = n.div_ceil(rayon::current_num_threads().max(1)).max(1 << 14);
    let chunks = n.div_ceil(len);
    let range = |c: usize| c * len..((c + 1) * len).min(n);
    // per-chunk counts, turned into each chunk's first slot per block
    let mut at: Vec<Vec<usize>> = (0..chunks)
        .into_par_iter()
        .map(|c| {
            let mut m = vec![0usize; blocks];
            for i in range(c) {
                blocks_of(i, &mut |b| m[b as usize] += 1);
            }
            m
        })
        .collect();
    let start = chunk_starts(&mut at, blocks);
    let total = start[blocks];
    let mut list: Vec<u32> = Vec::with_capacity(total);
    struct Slots(*mut u32);
    // SAFETY (Sync): chunks write disjoint slots (below)
    unsafe impl Sync for Slots {}
    let out = Slots(list.as_mut_ptr());
    at.par_iter_mut().enumerate().for_each(|(c, at)| {
        let out = &out;
        for i in range(c) {
            blocks_of(i, &mut |b| {
                let k = &mut at[b as usize];
                // SAFETY: slot k < total (the runs partition 0..total), and each slot belongs to
                // exactly one (chunk, kernel, block)
                unsafe { *out.0.add(*k) = i as u32 };
                *k += 1;
            });
        }
    });
    // SAFETY: every slot of 0..total was written exactly once above (the second walk visits the
    // same (kernel, block) pairs as the count)
    unsafe { list.set_len(total) };
    (start, list)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dense_and_hashed_block_sets_agree() {
        let boxes = vec![
            ([0, 0, 0], [2, 1, 3]),
            ([-3, 1, 2], [-1, 1, 2]),
            ([1, 1, 1], [4, 2, 2]),
            ([40, -7, 9], [41, -7, 10]),
        ];
        let mut brute: Vec<Key> = Vec::new();
        for (a, b) in &boxes {
            for x in a[0]..=b[0] {
                for y in a[1]..=b[1] {
                    for z in a[2]..=b[2] {
                        brute.push([x * 8, y * 8, z * 8]);
                    }
                }
            }
        }
        brute.sort_unstable();
        brute.dedup();
        let bx = |i: usize| Some(boxes[i]);
        let dense = union_of_boxes_with(boxes.len(), &bx, i64::MAX);
        let hashed = union_of_boxes_with(boxes.len(), &bx, 0);
        // both tables give the set of block origins, sorted
        assert_eq!(dense, brute);
        assert_eq!(hashed, brute);
        assert!(union_of_boxes_with(0, &bx, i64::MAX).is_empty());
        // the parallel grouping equals a stable serial sort of the (block, kernel) pairs
        let reach = |i: usize| -> Vec<u32> {
            let mut r = (i as u64).wrapping_mul(6364136223846793005) ^ 0x9E37_79B9;
            (0..(i % 4))
                .map(|_| {
                    r = r
                        .wrapping_mul(6364136223846793005)
                        .wrapping_add(1442695040888963407);
                    ((r >> 33) % 97) as u32
                })
                .collect::<std::collections::BTreeSet<u32>>()
                .into_iter()
                .collect()
        };
        let n = 100_000;
        let (start, list) = group_by_block(n, 100, &|i, f| reach(i).into_iter().for_each(f));
        let mut want: Vec<(u32, u32)> = (0..n)
            .flat_map(|i| reach(i).into_iter().map(move |b| (b, i as u32)))
            .collect();
        want.sort_by_key(|p| p.0);
        assert_eq!(list, want.iter().map(|p| p.1).collect::<Vec<_>>());
        assert_eq!(start[100], want.len());
        for b in 0..100 {
            assert!(want[start[b]..start[b + 1]].iter().all(|p| p.0 == b as u32));
        }
    }
}
