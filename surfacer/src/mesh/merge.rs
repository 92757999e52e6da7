//! Merging the per-block meshes of the mesher into one indexed mesh, in parallel.
//!
//! The result is the one of a global sort: vertices numbered in increasing edge key (one vertex
//! per key, position and velocity from its first copy in block order), triangles in block order.
//! Keys order x first (the top bits), so the keys are cut into slabs of whole block columns in x;
//! each slab is sorted and deduplicated on its own, and the slabs' vertices follow one another.
//! Only the slab boundaries depend on the thread count, not the result.
use super::{BlockMesh, TriMesh};
use crate::{Real, Vec3};
use rayon::prelude::*;

/// Grid x index of an edge key (see `edge_key`: 19 bits at bit 43, offset 2^18).
#[inline]
fn key_x(k: u64) -> i32 {
    ((k >> 43) & 0x7_FFFF) as i32 - (1 << 18)
}

/// Merges the meshes `parts` of the blocks at `origins` (sorted, same order): vertices shared
/// between blocks (same edge key) become one. Every vertex of the block at origin o has its key's
/// x in o.x..=o.x + 8.
pub(super) fn merge_blocks(origins: &[[i32; 3]], parts: Vec<BlockMesh>) -> TriMesh {
    debug_assert_eq!(origins.len(), parts.len());
    let mut off = Vec::with_capacity(parts.len() + 1);
    let mut nv = 0usize;
    for p in &parts {
        off.push(nv);
        nv += p.0.len();
    }
    off.push(nv);
    // slabs [xs[j], xs[j + 1]) of whole block columns with about nv / slabs vertices each
    let want = (4 * rayon::current_num_threads()).max(1);
    let mut xs = vec![i32::MIN];
    let mut acc = 0usize;
    for (b, p) in parts.iter().enumerate() {
        if acc * want >= nv * xs.len() && origins[b][0] > *xs.last().unwrap_or(&i32::MIN) {
            xs.push(origins[b][0]);
        }
        acc += p.0.len();
    }
    xs.push(i32::MAX);
    let slabs: Vec<(i32, i32)> = xs.windows(2).map(|w| (w[0], w[1])).collect();
    // per slab: (key, block, local index) of its vertices, sorted; the number of distinct keys
    let sorted: Vec<(Vec<(u64, u32, u32)>, usize)> = slabs
        .par_iter()
        .map(|&(x0, x1)| {
            let first = origins.partition_point(|o| o[0] < x0.saturating_sub(8));
            let last = origins.partition_point(|o| o[0] < x1);
            let mut e: Vec<(u64, u32, u32)> = Vec::new();
            for b in first..last {
                for (i, v) in parts[b].0.iter().enumerate() {
                    let x = key_x(v.0);
                    if x >= x0 && x < x1 {
                        e.push((v.0, b as u32, i as u32));
                    }
                }
            }
            e.sort_unstable();
            let distinct = e
                .iter()
                .enumerate()
                .filter(|(i, v)| *i == 0 || e[i - 1].0 != v.0)
                .count();
            (e, distinct)
        })
        .collect();
    debug_assert_eq!(sorted.iter().map(|s| s.0.len()).sum::<usize>(), nv);
    let mut base = Vec::with_capacity(sorted.len());
    let mut nu = 0usize;
    for s in &sorted {
        base.push(nu);
        nu += s.1;
    }
    let mut remap = vec![0u32; nv];
    struct Slots(*mut u32);
    // SAFETY (Sync): each slab writes the slots of its own vertices only (below)
    unsafe impl Sync for Slots {}
    let out = Slots(remap.as_mut_ptr());
    // the blocks' vertices are not needed once numbered: freed before the triangles are copied
    let (pverts, ptris): (Vec<_>, Vec<_>) = parts.into_iter().unzip();
    // each slab fills its own contiguous range of the final arrays
    let mut pos = vec![Vec3::zeros(); nu];
    let mut vel = vec![Vec3::zeros(); nu];
    let mut ranges = Vec::with_capacity(sorted.len());
    let (mut rp, mut rv) = (&mut pos[..], &mut vel[..]);
    for s in &sorted {
        let (a, b) = std::mem::take(&mut rp).split_at_mut(s.1);
        let (c, d) = std::mem::take(&mut rv).split_at_mut(s.1);
        ranges.push((a, c));
        (rp, rv) = (b, d);
    }
    sorted
        .into_par_iter()
        .zip(base.par_iter())
        .zip(ranges.into_par_iter())
        .for_each(|(((e, _), &b0), (pos, vel))| {
            let out = &out;
            let mut u = 0usize;
            for (i, &(k, b, l)) in e.iter().enumerate() {
                if i == 0 || e[i - 1].0 != k {
                    if i > 0 {
                        u += 1;
                    }
                    let (_, p, w) = pverts[b as usize][l as usize];
                    pos[u] = Vec3::new(p[0] as Real, p[1] as Real, p[2] as Real);
                    vel[u] = Vec3::new(w[0] as Real, w[1] as Real, w[2] as Real);
                }
                // SAFETY: off[b] + l < nv, and every vertex (b, l) lies in exactly one slab (its
                // key's x), so no two writes share a slot
                unsafe { *out.0.add(off[b as usize] + l as usize) = (b0 + u) as u32 };
            }
        });
    drop(pverts);
    crate::alloc::trim();
    // triangles renumbered straight into the final array, each block into its own range
    let mut tris = vec![[0u32; 3]; ptris.iter().map(|t| t.len()).sum()];
    let mut dst = Vec::with_capacity(ptris.len());
    let mut rest = &mut tris[..];
    for t in &ptris {
        let (a, b) = std::mem::take(&mut rest).split_at_mut(t.len());
        dst.push(a);
        rest = b;
    }
    ptris
        .par_iter()
        .zip(dst.into_par_iter())
        .enumerate()
        .for_each(|(b, (t, d))| {
            for (x, y) in d.iter_mut().zip(t) {
                *x = y.map(|i| remap[off[b] + i as usize]);
            }
        });
    drop((ptris, remap));
    crate::alloc::trim();
    let mut mesh = TriMesh {
        pos,
        vel,
        normal: Vec::new(),
        tris,
    };
    mesh.compute_normals();
    mesh
}

/// Vertex normals of `mesh`: normalised sums of the area-weighted normals of the triangles at
/// each vertex, summed in triangle order. Parallel over ranges of vertices, each range scanning all
/// triangles and summing those at its vertices: every vertex gets the serial loop's sum.
pub(super) fn vertex_normals(mesh: &TriMesh) -> Vec<Vec3> {
    let nv = mesh.pos.len();
    let ranges = rayon::current_num_threads().max(1);
    let len = nv.div_ceil(ranges).max(1 << 14);
    let parts: Vec<Vec<Vec3>> = (0..nv.div_ceil(len))
        .into_par_iter()
        .map(|r| {
            let (a, b) = (r * len, ((r + 1) * len).min(nv));
            let mut n = vec![Vec3::zeros(); b - a];
            for t in &mesh.tris {
                let mine = t.map(|v| (v as usize) >= a && (v as usize) < b);
                if !(mine[0] || mine[1] || mine[2]) {
                    continue;
                }
                let (p, q, s) = (
                    mesh.pos[t[0] as usize],
                    mesh.pos[t[1] as usize],
                    mesh.pos[t[2] as usize],
                );
                let fnrm = (q - p).cross(&(s - p));
                for k in 0..3 {
                    if mine[k] {
                        n[t[k] as usize - a] += fnrm;
                    }
                }
            }
            for v in n.iter_mut() {
                let l = v.norm();
                *v = if l > 0.0 { *v / l } else { Vec3::z() };
            }
            n
        })
        .collect();
    let mut out = Vec::with_capacity(nv);
    for p in parts {
        out.extend_from_slice(&p);
    }
    out
}
