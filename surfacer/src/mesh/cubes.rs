//! Marching cubes with a face-consistent table (the pipeline's mesher): the
//! table is generated so that two cubes sharing a face always triangulate it
//! the same way, so the mesh is closed and manifold like the tetrahedral one
//! ([`super::marching_tets`]) with fewer triangles.

use super::*;

/// The twelve cube edges as (corner a, corner b) with b = a + one axis bit (corner bits x=4, y=2,
/// z=1).
pub(super) const CUBE_EDGES: [(u8, u8); 12] = [
    (0, 4),
    (2, 6),
    (1, 5),
    (3, 7),
    (0, 2),
    (4, 6),
    (1, 3),
    (5, 7),
    (0, 1),
    (4, 5),
    (2, 3),
    (6, 7),
];

fn edge_id(a: u8, b: u8) -> u8 {
    let (a, b) = (a.min(b), a.max(b));
    CUBE_EDGES.iter().position(|&e| e == (a, b)).unwrap_or(0) as u8
}

/// Marching-cubes triangles (cube edge ids, oriented outward) of each of the 256 sign
/// configurations, built from a face rule instead of a hand-written table. On every cube face the
/// crossing edges are joined into segments; on an ambiguous face (diagonal corners inside) each
/// segment cuts off one *inside* corner. The rule depends only on the face's four signs, so the
/// two cubes sharing a face draw the same segments and the mesh is closed; every segment is
/// oriented with the inside on a fixed side seen from outside the cube, the segments chain into
/// closed loops around the cube, and each loop is fanned into triangles. Each mesh edge is then a
/// face segment (one triangle in each of the two cubes, opposite directions) or a fan diagonal
/// inside one cube (two triangles of the same loop): closed, manifold, consistently oriented.
pub(super) fn mc_table() -> &'static [Vec<[u8; 3]>; 256] {
    static T: std::sync::OnceLock<[Vec<[u8; 3]>; 256]> = std::sync::OnceLock::new();
    T.get_or_init(|| {
        let cv = |c: u8| {
            let d = corner(c);
            Vec3::new(d[0] as Real, d[1] as Real, d[2] as Real)
        };
        let mid = |e: u8| {
            let (a, b) = CUBE_EDGES[e as usize];
            0.5 * (cv(a) + cv(b))
        };
        // faces: 4 corners in cyclic order, outward normal
        let mut faces: Vec<([u8; 4], Vec3)> = Vec::new();
        for axis in 0..3u8 {
            let bit = 4u8 >> axis;
            let (o1, o2) = match axis {
                0 => (2u8, 1u8),
                1 => (4, 1),
                _ => (4, 2),
            };
            for side in 0..2u8 {
                let base = if side == 1 { bit } else { 0 };
                let mut n = Vec3::zeros();
                n[axis as usize] = if side == 1 { 1.0 } else { -1.0 };
                faces.push(([base, base | o1, base | o1 | o2, base | o2], n));
            }
        }
        std::array::from_fn(|mask| {
            let ins = |c: u8| mask >> c & 1 == 1;
            // oriented segments (from edge, to edge)
            let mut next = [u8::MAX; 12];
            for (fc, n) in &faces {
                let crossings: Vec<usize> = (0..4)
                    .filter(|&k| ins(fc[k]) != ins(fc[(k + 1) % 4]))
                    .collect();
                let mut segs: Vec<(u8, u8, u8)> = Vec::new(); // (edge, edge, inside corner)
                let fe = |k: usize| edge_id(fc[k], fc[(k + 1) % 4]);
                match crossings.len() {
                    2 => {
                        let c = *fc.iter().find(|&&c| ins(c)).unwrap_or(&fc[0]);
                        segs.push((fe(crossings[0]), fe(crossings[1]), c));
                    }
                    4 => {
                        // ambiguous: cut off each inside corner (the edges on both sides of it)
                        for (k, &c) in fc.iter().enumerate() {
                            if ins(c) {
                                segs.push((fe((k + 3) % 4), fe(k), c));
                            }
                        }
                    }
                    _ => {}
                }
                for (a, b, c) in segs {
                    let (pa, pb) = (mid(a), mid(b));
                    let (a, b) = if (pb - pa).cross(n).dot(&(cv(c) - pa)) > 0.0 {
                        (a, b)
                    } else {
                        (b, a)
                    };
                    next[a as usize] = b;
                }
            }
            let mut tris = Vec::new();
            let mut seen = [false; 12];
            for start in 0..12u8 {
                if next[start as usize] == u8::MAX || seen[start as usize] {
                    continue;
                }
                let mut lp = vec![start];
                seen[start as usize] = true;
                let mut e = next[start as usize];
                while e != start && e != u8::MAX && lp.len() <= 12 {
                    seen[e as usize] = true;
                    lp.push(e);
                    e = next[e as usize];
                }
                for k in 1..lp.len().saturating_sub(1) {
                    tris.push([lp[0], lp[k], lp[k + 1]]);
                }
            }
            tris
        })
    })
}

/// Extracts the zero crossing of `ls` by marching cubes with the face-consistent table of
/// [`mc_table`] (closed, manifold, oriented outward). Voxels with φ = 0 count as outside. A
/// vertex is identified by its grid edge, so vertices shared between cubes and leaves are merged
/// exactly; its velocity is interpolated linearly along the edge.
pub fn marching_cubes(ls: &LevelSet) -> TriMesh {
    let table = mc_table();
    let blocks = mesh_blocks(ls);
    let h = ls.voxel;
    const E: usize =
        (LEAF_DIM as usize + 1) * (LEAF_DIM as usize + 1) * (LEAF_DIM as usize + 1) * 3;
    let parts: Vec<BlockMesh> = blocks
        .par_iter()
        .map_init(
            || vec![u32::MAX; E],
            |slot, &o| {
                let nb = Nbhd::gather(ls, o);
                let mut verts: Vec<(u64, [f32; 3], [f32; 3])> = Vec::new();
                let mut tris: Vec<[u32; 3]> = Vec::new();
                if nb.leaves.iter().all(|l| l.is_none())
                    && nb.tile.iter().all(|&t| (t < 0.0) == (nb.tile[0] < 0.0))
                {
                    return (verts, tris);
                }
                // local edge slot: lower corner (0..=8)³ × axis
                let at =
                    |l: [i32; 3], axis: usize| ((l[0] * 9 + l[1]) * 9 + l[2]) as usize * 3 + axis;
                let mut used: Vec<usize> = Vec::new();
                // φ at the 9³ corners of the block's cells, fetched once (index (x·9 + y)·9 + z);
                // velocities are fetched only for the corners of crossing edges
                let mut pv = [0f32; 729];
                for x in 0..=LEAF_DIM {
                    for y in 0..=LEAF_DIM {
                        for z in 0..=LEAF_DIM {
                            pv[((x * 9 + y) * 9 + z) as usize] = nb.phi(o, [x, y, z]);
                        }
                    }
                }
                const OFF: [usize; 8] = [0, 1, 9, 10, 81, 82, 90, 91];
                for x in 0..LEAF_DIM {
                    for y in 0..LEAF_DIM {
                        for z in 0..LEAF_DIM {
                            let base = ((x * 9 + y) * 9 + z) as usize;
                            let mut mask = 0usize;
                            for (c, off) in OFF.iter().enumerate() {
                                mask |= ((pv[base + off] < 0.0) as usize) << c;
                            }
                            if mask == 0 || mask == 255 {
                                continue;
                            }
                            let val = |c: u8| {
                                let d = corner(c);
                                nb.at(o, [x + d[0], y + d[1], z + d[2]])
                            };
                            let mut vid = [u32::MAX; 12];
                            for t in &table[mask] {
                                let mut tri = [0u32; 3];
                                for (k, &e) in t.iter().enumerate() {
                                    if vid[e as usize] == u32::MAX {
                                        let (a, b) = CUBE_EDGES[e as usize];
                                        let (ca, cb) = (corner(a), corner(b));
                                        let axis = (0..3).find(|&q| cb[q] != ca[q]).unwrap_or(0);
                                        let l = [x + ca[0], y + ca[1], z + ca[2]];
                                        let sl = at(l, axis);
                                        if slot[sl] == u32::MAX {
                                            let (pa, va) = val(a);
                                            let (pb, vb) = val(b);
                                            let tt = (pa as Real / (pa as Real - pb as Real))
                                                .clamp(0.0, 1.0);
                                            let g = [o[0] + l[0], o[1] + l[1], o[2] + l[2]];
                                            let mut p =
                                                Vec3::new(g[0] as Real, g[1] as Real, g[2] as Real);
                                            p[axis] += tt;
                                            let p = p * h;
                                            let u = lerp_vel(va, vb, tt);
                                            let mut d = [0i32; 3];
                                            d[axis] = 1;
                                            slot[sl] = verts.len() as u32;
                                            used.push(sl);
                                            verts.push((
                                                edge_key(g, d),
                                                [p.x as f32, p.y as f32, p.z as f32],
                                                u,
                                            ));
                                        }
                                        vid[e as usize] = slot[sl];
                                    }
                                    tri[k] = vid[e as usize];
                                }
                                tris.push(tri);
                            }
                        }
                    }
                }
                for sl in used {
                    slot[sl] = u32::MAX;
                }
                verts.shrink_to_fit();
                tris.shrink_to_fit();
                (verts, tris)
            },
        )
        .collect();
    merge_blocks(&blocks, parts)
}
