//! From the volume fraction f to a narrow-band signed distance φ (inside negative) whose zero set
//! is the iso-surface f = f_iso.
//!
//! 1. Seeds: every voxel with a 6-neighbour on the other side of the iso-value. Along each such
//!    axis the crossing lies at distance d_a = Δx (f − f_iso)/(f − f_nb) (linear interpolation);
//!    the seed's distance is the distance to the plane through those crossings,
//!    |φ| = (Σ_a d_a⁻²)^(−1/2), and its closest surface point is cp = x + φ ∇f/|∇f|.
//! 2. Closest-point propagation (a vector distance transform, Danielsson 1980): layer by layer
//!    outward from the seeds, an unset voxel takes, among its 26 set neighbours, the closest
//!    point nearest to it: φ = ±|x − cp|, with the velocity of the voxel that closest point came
//!    from. Layers are computed from the previous layers only (Jacobi order), so the result is
//!    independent of the thread count. Propagation stops past the band.
//!
//! The sign of every voxel comes from f itself, so inside never depends on the propagation.
use crate::density::{DensityField, SignField};
use crate::hash::Key;
use crate::leafbits::{crossings, dilate26, padded_front, FACE_YZ, Z0, Z7};
use crate::levelset::{
    leaf_origin, voxel_index, voxel_of, WorkGrid, WorkLeaf, LEAF_DIM, LEAF_SIZE,
};
use crate::{Real, Vec3};
use rayon::prelude::*;

/// Counts from the redistancing, for the report.
#[derive(Debug, Clone, Default)]
pub struct RedistanceInfo {
    /// seed voxels next to the crossing
    pub seeds: usize,
    /// seeds whose gradient vanished (closest point taken as the voxel itself)
    pub flat_gradient: usize,
    /// voxels set by propagation
    pub propagated: usize,
}

/// A seed: (voxel, φ, closest point as an offset (see [`CP_UNIT`]), velocity).
type Entry = (Key, f32, [i16; 3], [f32; 3]);
/// A propagated voxel: (index in leaf, φ, closest-point offset, velocity source).
type Update = (usize, f32, [i16; 3], u32);

/// Closest points are stored as offsets from their voxel in units of 1/4096 voxel (range ±8
/// voxels; propagation keeps them within band + 1): exact integer shifts from voxel to voxel.
pub const CP_UNIT: Real = 1.0 / 4096.0;

pub use crate::band::{conserve_volume, smooth_band};

/// Builds the band of half width `band`·Δx around f = `iso`. The field is consumed once the seeds
/// are taken (only its signs are kept). Returns the grid, the origins of density blocks entirely
/// inside that are not in the band, the signs, and counts.
pub fn redistance(
    d: DensityField,
    iso: f32,
    band: Real,
) -> (WorkGrid, Vec<Key>, SignField, RedistanceInfo) {
    let h = d.voxel;
    let bg = (band * h) as f32;
    let mut info = RedistanceInfo::default();

    // blocks entirely on one side of the iso-value (1 inside, 2 outside, 0 mixed)
    let side: Vec<u8> = d
        .blocks
        .par_iter()
        .map(|b| {
            let n_in = b.f.iter().filter(|&&f| f >= iso).count();
            match n_in {
                LEAF_SIZE => 1,
                0 => 2,
                _ => 0,
            }
        })
        .collect();
    // a uniform block whose six face neighbours are uniform on the same side has no seeds
    let no_seeds = |bi: usize| {
        let sd = side[bi];
        let o = d.blocks[bi].origin;
        sd != 0
            && (0..6).all(|f| {
                let mut q = o;
                q[f / 2] += if f % 2 == 0 { -8 } else { 8 };
                match d.index.get(&q) {
                    Some(&j) => side[j] == sd,
                    None if d.interior.binary_search(&q).is_ok() => sd == 1,
                    None => sd == 2,
                }
            })
    };
    // the signs first: they find each block's seed voxels with bit operations
    let signs = SignField::new(&d, iso);
    // seeds per block (each list sized exactly: no doubling of one large vector)
    let seeds: Vec<Vec<(Entry, bool)>> = d
        .blocks
        .par_iter()
        .enumerate()
        .filter(|(bi, _)| !no_seeds(*bi))
        .map(|(bi, b)| {
            let mut out = Vec::new();
            // voxels with a 6-neighbour on the other side of the iso-value
            let cand = crossings(&signs.blocks[bi].1, &|a, s| {
                let mut q = b.origin;
                q[a] += 8 * s;
                signs.mask(q)
            });
            // the six face-neighbour blocks (slot 2a + (s > 0)), or their tile value
            let face: [(Option<&crate::density::DensityBlock>, f32); 6] =
                std::array::from_fn(|q| {
                    let mut o = b.origin;
                    o[q / 2] += if q % 2 == 0 { -8 } else { 8 };
                    match d.index.get(&o) {
                        Some(&j) => (Some(&d.blocks[j]), 0.0),
                        None if d.interior.binary_search(&o).is_ok() => (None, 1.0),
                        None => (None, 0.0),
                    }
                });
            let fetch = |nb: Key, q: usize| -> f32 {
                match face[q] {
                    (Some(bl), _) => bl.f[voxel_index(nb)],
                    (None, t) => t,
                }
            };
            for n in (0..LEAF_SIZE).filter(|&n| cand[n >> 6] >> (n & 63) & 1 == 1) {
                let ijk = voxel_of(b.origin, n);
                let f = b.f[n];
                let ins = f >= iso;
                let mut inv2 = 0.0f64;
                let mut grad = Vec3::zeros();
                // voxel whose velocity the seed takes (itself, or across the crossing when f ≤ 0)
                let mut vel_from: Option<(Key, usize)> = None;
                let mut any = false;
                for a in 0..3 {
                    let mut dmin = Real::INFINITY;
                    let mut fs = [0f32; 2];
                    for (si, s) in [-1i32, 1].into_iter().enumerate() {
                        let mut nb = ijk;
                        nb[a] += s;
                        // same block: direct index; otherwise a lookup
                        let fnb = if (nb[a] & !7) == b.origin[a] {
                            b.f[voxel_index(nb)]
                        } else {
                            fetch(nb, 2 * a + si)
                        };
                        fs[si] = fnb;
                        if (fnb >= iso) != ins {
                            let t = ((f - iso) as Real / (f - fnb) as Real).clamp(0.0, 1.0);
                            dmin = dmin.min(t * h);
                            if f <= 0.0 {
                                vel_from = Some((nb, 2 * a + si));
                            }
                            any = true;
                        }
                    }
                    grad[a] = (fs[1] - fs[0]) as Real / (2.0 * h);
                    if dmin.is_finite() {
                        let dd = dmin.max(1e-3 * h);
                        inv2 += 1.0 / (dd * dd);
                    }
                }
                if !any {
                    continue;
                }
                let vel = match vel_from {
                    None => b.vel(n),
                    Some((nb, q)) if (nb[q / 2] & !7) == b.origin[q / 2] => b.vel(voxel_index(nb)),
                    Some((nb, q)) => face[q].0.map_or([0.0; 3], |bl| bl.vel(voxel_index(nb))),
                };
                let phi = (1.0 / inv2.sqrt()) * if ins { -1.0 } else { 1.0 };
                let gn = grad.norm();
                let flat = gn.is_nan() || gn <= 0.0;
                // closest point x + φ ∇f/|∇f|, as an offset in voxels
                let off = if flat {
                    Vec3::zeros()
                } else {
                    phi * grad / (gn * h)
                };
                let q = |v: Real| (v / CP_UNIT).round().clamp(-32767.0, 32767.0) as i16;
                out.push(((ijk, phi as f32, [q(off.x), q(off.y), q(off.z)], vel), flat));
            }
            out.shrink_to_fit();
            out
        })
        .filter(|v| !v.is_empty())
        .collect();
    info.seeds = seeds.iter().map(|v| v.len()).sum();
    drop(d);
    let mask = |o: Key| signs.mask(o);
    info.flat_gradient = seeds
        .par_iter()
        .map(|v| v.iter().filter(|s| s.1).count())
        .sum();

    let mut grid = WorkGrid::new(h, bg);
    // one leaf per block with seeds, built in parallel; seed k (in block order) is velocity
    // source k. `front[li]`: voxels of leaf li set in the previous layer
    let mut base = Vec::with_capacity(seeds.len());
    let mut total = 0usize;
    for v in &seeds {
        base.push(total);
        total += v.len();
    }
    let built: Vec<(Box<WorkLeaf>, [u64; 8])> = seeds
        .par_iter()
        .zip(base.par_iter())
        .map(|(list, &a)| {
            let origin = leaf_origin(list[0].0 .0);
            let mut l = WorkLeaf::new(origin, bg, mask(origin));
            for (k, (e, _)) in list.iter().enumerate() {
                let n = voxel_index(e.0);
                l.phi[n] = e.1;
                l.cp[n] = e.2;
                l.src[n] = (a + k) as u32;
                l.set[n >> 6] |= 1 << (n & 63);
            }
            let set = l.set;
            (l, set)
        })
        .collect();
    grid.sources = seeds.iter().flatten().map(|(e, _)| e.3).collect();
    let mut front: Vec<[u64; 8]> = Vec::with_capacity(built.len());
    for (l, set) in built {
        grid.index.insert(l.origin, grid.leaves.len());
        grid.leaves.push(l);
        front.push(set);
    }
    drop(seeds);
    // the 27 neighbour leaves of each leaf (slot (dx+1)·9 + (dy+1)·3 + dz+1, NONE if missing),
    // kept up to date as leaves are created instead of hashing 27 origins per leaf and layer
    let slot_key = |o: Key, sl: usize| -> Key {
        let d = [sl as i32 / 9 - 1, sl as i32 / 3 % 3 - 1, sl as i32 % 3 - 1];
        [o[0] + 8 * d[0], o[1] + 8 * d[1], o[2] + 8 * d[2]]
    };
    let mut nbt: Vec<[u32; 27]> = {
        let g = &grid;
        (0..g.leaves.len())
            .into_par_iter()
            .map(|li| {
                let o = g.leaves[li].origin;
                std::array::from_fn(|sl| g.index.get(&slot_key(o, sl)).map_or(NONE, |&j| j as u32))
            })
            .collect()
    };

    let layers = band.ceil() as usize + 1;
    let limit = (band + 1.0) * h;
    for _ in 0..layers {
        // create the neighbour leaves in which a front voxel on a leaf face gives some voxel a
        // distance within the limit (exact: a voxel is set iff one of its set neighbours' closest
        // points is within the limit, and every set voxel was once front); sorted: deterministic
        let lim2 = (limit / (CP_UNIT * h)).powi(2);
        let g = &grid;
        let nb_t = &nbt;
        let mut need: Vec<Key> = front
            .par_iter()
            .enumerate()
            .filter(|(_, fr)| {
                // faces touched by the front (layout: word x, bit 8y + z)
                let any = fr.iter().fold(0u64, |a, &w| a | w);
                fr[0] != 0 || fr[7] != 0 || any & (0xFF | (0xFF << 56) | Z0 | Z7) != 0
            })
            .flat_map_iter(|(li, fr)| {
                let l = &g.leaves[li];
                let o = l.origin;
                // neighbour leaves that exist (slot (dx+1)·9 + (dy+1)·3 + dz+1)
                let exists: [bool; 27] = std::array::from_fn(|sl| nb_t[li][sl] != NONE);
                let mut want = [false; 27];
                if exists.iter().all(|&e| e) {
                    return Vec::new();
                }
                // front voxels on the leaf's faces, in index order (word x, bit 8y + z)
                for (x, &w) in fr.iter().enumerate() {
                    let mut bits = if x == 0 || x == 7 { w } else { w & FACE_YZ };
                    while bits != 0 {
                        let n = x * 64 + bits.trailing_zeros() as usize;
                        bits &= bits - 1;
                        let k = voxel_of([0, 0, 0], n);
                        let c = l.cp[n];
                        for dx in -1..=1i32 {
                            for dy in -1..=1i32 {
                                for dz in -1..=1i32 {
                                    let d = [dx, dy, dz];
                                    let side = |a: usize| {
                                        let q = k[a] + d[a];
                                        if q < 0 {
                                            0
                                        } else if q > 7 {
                                            2
                                        } else {
                                            1
                                        }
                                    };
                                    let sl = side(0) * 9 + side(1) * 3 + side(2);
                                    if exists[sl] || want[sl] {
                                        continue;
                                    }
                                    let e = [0, 1, 2].map(|a| c[a] as i64 - d[a] as i64 * 4096);
                                    let d2 = (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]) as Real;
                                    want[sl] = d2 <= lim2 && e.iter().all(|v| v.abs() <= 32767);
                                }
                            }
                        }
                    }
                }
                (0..27)
                    .filter(|&sl| want[sl])
                    .map(|sl| {
                        let d = [sl as i32 / 9 - 1, sl as i32 / 3 % 3 - 1, sl as i32 % 3 - 1];
                        [o[0] + 8 * d[0], o[1] + 8 * d[1], o[2] + 8 * d[2]]
                    })
                    .collect::<Vec<Key>>()
            })
            .collect();
        need.par_sort_unstable();
        need.dedup();
        // leaves created on the calling thread (see docs/decisions.md), then their neighbour
        // rows looked up in parallel in the final index, and the links from older leaves set
        let first_new = grid.leaves.len();
        for &k in &need {
            grid.ensure(k, &mask);
        }
        let g = &grid;
        let rows: Vec<[u32; 27]> = (first_new..g.leaves.len())
            .into_par_iter()
            .map(|li| {
                let k = g.leaves[li].origin;
                std::array::from_fn(|sl| g.index.get(&slot_key(k, sl)).map_or(NONE, |&j| j as u32))
            })
            .collect();
        for (t, row) in rows.iter().enumerate() {
            for (sl, &j) in row.iter().enumerate() {
                if j != NONE && (j as usize) < first_new {
                    nbt[j as usize][26 - sl] = (first_new + t) as u32;
                }
            }
        }
        nbt.extend(rows);
        front.resize(grid.leaves.len(), [0; 8]);
        // leaves that may receive new values: those with or next to front voxels
        let g = &grid;
        let fr = &front;
        let nb_t = &nbt;
        let nbrs = |li: usize| -> [Option<usize>; 27] {
            nb_t[li].map(|j| (j != NONE).then_some(j as usize))
        };
        let updates: Vec<(usize, Vec<Update>)> = (0..g.leaves.len())
            .into_par_iter()
            .filter_map(|li| {
                let nb = nbrs(li);
                if nb.iter().flatten().all(|&j| fr[j].iter().all(|&w| w == 0)) {
                    return None;
                }
                let leaf = &g.leaves[li];
                let o = leaf.origin;
                // (leaf, voxel) of a neighbour voxel given local coordinates in -1..=8
                let at = |k: [i32; 3]| -> Option<(usize, usize)> {
                    let s = |x: i32| {
                        if x < 0 {
                            0
                        } else if x > 7 {
                            2
                        } else {
                            1
                        }
                    };
                    let j = nb[(s(k[0]) * 9 + s(k[1]) * 3 + s(k[2])) as usize]?;
                    Some((j, voxel_index([k[0] & 7, k[1] & 7, k[2] & 7])))
                };
                // candidates: the front dilated by one voxel (26-neighbourhood), minus set voxels
                let front_of = |s: usize| -> [u64; 8] { nb[s].map_or([0; 8], |j| fr[j]) };
                let dil = dilate26(&front_of);
                // the front bits of the leaf padded by one voxel, built on the first candidate
                // on a leaf face: row (x + 1)·10 + y + 1 for x, y in −1..=8, bit z + 1
                let mut pad: Option<[u16; 100]> = None;
                let mut out = Vec::new();
                let mut sign: Option<[u64; 8]> = None;
                // candidates in index order (word x, bit 8y + z)
                for x in 0..LEAF_DIM as usize {
                    let mut cand = dil[x] & !leaf.set[x];
                    while cand != 0 {
                        let n = x * 64 + cand.trailing_zeros() as usize;
                        cand &= cand - 1;
                        let k = voxel_of([0, 0, 0], n);
                        // nearest closest point among the set neighbours, in voxel units
                        let mut best = (i64::MAX, [0i16; 3], 0u32);
                        let mut consider = |lj: &WorkLeaf, m: usize, d: [i32; 3]| {
                            let c = lj.cp[m];
                            let e = [0, 1, 2].map(|a| c[a] as i64 + d[a] as i64 * 4096);
                            let d2 = e[0] * e[0] + e[1] * e[1] + e[2] * e[2];
                            if d2 < best.0 && e.iter().all(|v| v.abs() <= 32767) {
                                best = (d2, e.map(|v| v as i16), lj.src[m]);
                            }
                        };
                        if k.iter().all(|&c| c > 0 && c < 7) {
                            // all 26 neighbours in this leaf, and only the front ones can win: a
                            // voxel set before the previous layer had this candidate as a candidate
                            // once (or its leaf was not needed) and was then farther than the limit,
                            // so it cannot give a distance within the limit now. The front bits
                            // around the voxel, 3 rows of 3 per x-word, in (dx, dy, dz) order
                            let sh = 8 * (k[1] - 1) + (k[2] - 1);
                            for dx in -1..=1 {
                                let mut bits = (fr[li][(k[0] + dx) as usize] >> sh) & 0x07_0707;
                                while bits != 0 {
                                    let b = bits.trailing_zeros() as i32;
                                    bits &= bits - 1;
                                    let (dy, dz) = (b / 8 - 1, b % 8 - 1);
                                    let m = (n as i32 + dx * 64 + dy * 8 + dz) as usize;
                                    consider(leaf, m, [dx, dy, dz]);
                                }
                            }
                        } else {
                            // only front neighbours can win (as above); the same (dx, dy, dz)
                            // order as the interior case
                            let pad = pad.get_or_insert_with(|| padded_front(&front_of));
                            for dx in -1..=1 {
                                for dy in -1..=1 {
                                    let row = pad[((k[0] + dx + 1) * 10 + k[1] + dy + 1) as usize];
                                    let mut bits = (row >> k[2]) & 0b111;
                                    while bits != 0 {
                                        let dz = bits.trailing_zeros() as i32 - 1;
                                        bits &= bits - 1;
                                        let (j, m) = at([k[0] + dx, k[1] + dy, k[2] + dz])
                                            .expect("a front voxel lies in an existing leaf");
                                        consider(&g.leaves[j], m, [dx, dy, dz]);
                                    }
                                }
                            }
                        }
                        if best.0 == i64::MAX {
                            continue;
                        }
                        let dist = (best.0 as Real).sqrt() * CP_UNIT * h;
                        if dist > limit {
                            continue;
                        }
                        // the signs of this leaf's voxels (what `inside` gives), looked up once
                        let sg = *sign.get_or_insert_with(|| mask(o));
                        let s = if sg[n >> 6] >> (n & 63) & 1 == 1 {
                            -1.0
                        } else {
                            1.0
                        };
                        out.push((n, (s * dist) as f32, best.1, best.2));
                    }
                }
                (!out.is_empty()).then_some((li, out))
            })
            .collect();
        if updates.is_empty() {
            break;
        }
        // applied leaf by leaf in parallel (each list belongs to one leaf; the lists are freed
        // by the workers that built them)
        info.propagated += updates.iter().map(|u| u.1.len()).sum::<usize>();
        let mut slot = vec![u32::MAX; grid.leaves.len()];
        for (k, u) in updates.iter().enumerate() {
            slot[u.0] = k as u32;
        }
        let mut lists: Vec<Option<Vec<Update>>> = updates.into_iter().map(|u| Some(u.1)).collect();
        let lists_at = ListSlots(lists.as_mut_ptr());
        grid.leaves
            .par_iter_mut()
            .zip(front.par_iter_mut())
            .zip(slot.par_iter())
            .for_each(|((l, fr), &k)| {
                *fr = [0; 8];
                if k == u32::MAX {
                    return;
                }
                let lists_at = &lists_at;
                // SAFETY: `slot` maps distinct leaves to distinct lists, so each list is taken
                // by exactly one leaf
                let list = unsafe { (*lists_at.0.add(k as usize)).take() }.unwrap_or_default();
                for (n, phi, cp, from) in list {
                    l.phi[n] = phi;
                    l.cp[n] = cp;
                    l.src[n] = from;
                    l.set[n >> 6] |= 1 << (n & 63);
                    fr[n >> 6] |= 1 << (n & 63);
                }
            });
        drop(lists);
    }
    // leaves the band never reached hold only ±background, which the signs give anyway; the
    // closest points are no longer needed (3 of the 7 kB per leaf)
    drop((front, nbt));
    grid.leaves.retain(|l| l.set.iter().any(|&w| w != 0));
    grid.leaves.par_iter_mut().for_each(|l| l.cp = Vec::new());
    crate::alloc::trim();
    grid.index = grid
        .leaves
        .iter()
        .enumerate()
        .map(|(i, l)| (l.origin, i))
        .collect();

    let extra_inside: Vec<Key> = signs
        .blocks
        .par_iter()
        .filter(|b| {
            !grid.index.contains_key(&b.0)
                && b.1.iter().map(|w| w.count_ones() as usize).sum::<usize>() * 2 > LEAF_SIZE
        })
        .map(|b| b.0)
        .chain(
            signs
                .interior
                .par_iter()
                .filter(|b| !grid.index.contains_key(*b))
                .copied(),
        )
        .collect();
    (grid, extra_inside, signs, info)
}

/// The per-leaf update lists of a layer, taken by the leaves in parallel.
struct ListSlots(*mut Option<Vec<Update>>);
// SAFETY: each list is taken by exactly one leaf (see its use in `redistance`)
unsafe impl Sync for ListSlots {}

/// No neighbour leaf in a slot of the neighbour table.
const NONE: u32 = u32::MAX;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bit_dilation_matches_brute_force() {
        // one voxel per neighbour leaf at pseudo-random places, plus some in the centre
        let mut masks = [[0u64; 8]; 27];
        let mut s = 7u64;
        for m in masks.iter_mut() {
            for _ in 0..6 {
                s = s
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                let n = (s >> 33) as usize % 512;
                m[n >> 6] |= 1 << (n & 63);
            }
        }
        let got = dilate26(&|i| masks[i]);
        for n in 0..512 {
            let k = voxel_of([0, 0, 0], n);
            let mut want = false;
            for dx in -1..=1 {
                for dy in -1..=1 {
                    for dz in -1..=1 {
                        let q = [k[0] + dx, k[1] + dy, k[2] + dz];
                        let sl = |v: i32| {
                            if v < 0 {
                                0
                            } else if v > 7 {
                                2
                            } else {
                                1
                            }
                        };
                        let m = masks[(sl(q[0]) * 9 + sl(q[1]) * 3 + sl(q[2])) as usize];
                        let qi = voxel_index([q[0] & 7, q[1] & 7, q[2] & 7]);
                        want |= m[qi >> 6] >> (qi & 63) & 1 == 1;
                    }
                }
            }
            assert_eq!(got[n >> 6] >> (n & 63) & 1 == 1, want, "voxel {k:?}");
        }
    }
}
