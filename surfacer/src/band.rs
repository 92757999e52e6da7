//! Operations on the finished volume band: the [1 2 1]/4 filter and the volume-preserving shift
//! (split from [`crate::redistance`], which builds the band).
use crate::density::SignField;
use crate::hash::Key;
use crate::levelset::{voxel_index, voxel_of, WorkGrid, LEAF_SIZE};
use crate::Real;
use rayon::prelude::*;

/// Smooths the band with `iterations` passes of the separable [1 2 1]/4 filter (a 3×3×3 binomial,
/// variance ½ voxel² per axis) on the voxels whose φ is set; others keep ±background. The
/// particles' lattice leaves bumps of ~2 voxels' wavelength on the iso-surface (Δ = 2 voxels);
/// one pass damps them by ½ per tangential axis, while a sphere of radius R voxels moves by only
/// ~½/R voxel (corrected by [`conserve_volume`] afterwards). Leaves are filtered independently from
/// the unfiltered values (Jacobi), so the result does not depend on the thread count.
/// `inside(origin)`: the inside bits of the leaf-sized block at `origin` (layout of
/// [`SignField::mask`]), read for neighbours that are not band leaves.
pub fn smooth_band(
    grid: &mut WorkGrid,
    inside: &(impl Fn(Key) -> [u64; 8] + Sync),
    iterations: usize,
) {
    let bg = grid.bg;
    for _ in 0..iterations {
        let g = &*grid;
        let out: Vec<[f32; LEAF_SIZE]> = g
            .leaves
            .par_iter()
            .map(|l| {
                let o = l.origin;
                // padded 10³ block of φ, index (x·10 + y)·10 + z
                let mut p = [0f32; 1000];
                let mut nb: [Option<usize>; 27] = [None; 27];
                // inside bits of the neighbours that are not leaves (looked up once per slot)
                let mut ins = [[0u64; 8]; 27];
                for (sl, slot) in nb.iter_mut().enumerate() {
                    let d = [
                        (sl / 9) as i32 - 1,
                        (sl / 3 % 3) as i32 - 1,
                        (sl % 3) as i32 - 1,
                    ];
                    let q = [o[0] + 8 * d[0], o[1] + 8 * d[1], o[2] + 8 * d[2]];
                    *slot = g.index.get(&q).copied();
                    if slot.is_none() {
                        ins[sl] = inside(q);
                    }
                }
                // row by row: the 8 voxels of a row inside the leaf's z range come from one
                // neighbour (a copy when it is a leaf), the two padding voxels from the z
                // neighbours
                let side = |v: i32| {
                    if v < 0 {
                        0
                    } else if v > 7 {
                        2
                    } else {
                        1
                    }
                };
                let value = |sl: usize, m: usize| -> f32 {
                    match nb[sl] {
                        Some(j) => g.leaves[j].phi[m],
                        None if ins[sl][m >> 6] >> (m & 63) & 1 == 1 => -bg,
                        None => bg,
                    }
                };
                for x in -1..9i32 {
                    for y in -1..9i32 {
                        let sl = (side(x) * 9 + side(y) * 3) as usize;
                        let base = voxel_index([x & 7, y & 7, 0]);
                        let row = (((x + 1) * 10 + y + 1) * 10) as usize;
                        p[row] = value(sl, base + 7);
                        match nb[sl + 1] {
                            Some(j) => p[row + 1..row + 9]
                                .copy_from_slice(&g.leaves[j].phi[base..base + 8]),
                            None => {
                                for z in 0..8 {
                                    p[row + 1 + z] = value(sl + 1, base + z);
                                }
                            }
                        }
                        p[row + 9] = value(sl + 2, base);
                    }
                }
                let at = |x: usize, y: usize, z: usize| (x * 10 + y) * 10 + z;
                let mut a = [0f32; 1000];
                for x in 1..9 {
                    for y in 0..10 {
                        for z in 0..10 {
                            a[at(x, y, z)] = 0.25
                                * (p[at(x - 1, y, z)] + 2.0 * p[at(x, y, z)] + p[at(x + 1, y, z)]);
                        }
                    }
                }
                let mut b = [0f32; 1000];
                for x in 1..9 {
                    for y in 1..9 {
                        for z in 0..10 {
                            b[at(x, y, z)] = 0.25
                                * (a[at(x, y - 1, z)] + 2.0 * a[at(x, y, z)] + a[at(x, y + 1, z)]);
                        }
                    }
                }
                let mut phi = l.phi;
                for (n, v) in phi.iter_mut().enumerate() {
                    if l.is_set(n) {
                        let k = voxel_of([1, 1, 1], n);
                        let (x, y, z) = (k[0] as usize, k[1] as usize, k[2] as usize);
                        *v =
                            0.25 * (b[at(x, y, z - 1)] + 2.0 * b[at(x, y, z)] + b[at(x, y, z + 1)]);
                    }
                }
                phi
            })
            .collect();
        grid.leaves
            .par_iter_mut()
            .zip(out)
            .for_each(|(l, phi)| l.phi = phi);
    }
}

/// Volume-preserving offset. Centre smoothing (λ) and flattened surface kernels pull the
/// iso-surface inward by a fraction of the spacing (Yu & Turk 2013 §4 note the shrinkage). We
/// restore the particles' total volume V_p: with the grid's enclosed volume V(φ) and surface area
/// A(φ), both from a smeared Heaviside of width ε = 1.5 Δx (V = Δx³ Σ H(−φ), A = Δx³ Σ δ(φ)),
/// every band value is shifted by d = (V(φ) − V_p)/A, clamped to ±band/2. Returns the shift (m).
pub fn conserve_volume(grid: &mut WorkGrid, signs: &SignField, target: Real, band: Real) -> Real {
    let h = grid.voxel;
    let eps = 1.5 * h;
    let heav = |x: Real| {
        if x <= -eps {
            0.0
        } else if x >= eps {
            1.0
        } else {
            0.5 * (1.0 + x / eps + (std::f64::consts::PI * x / eps).sin() / std::f64::consts::PI)
        }
    };
    let delta = |x: Real| {
        if x.abs() >= eps {
            0.0
        } else {
            0.5 / eps * (1.0 + (std::f64::consts::PI * x / eps).cos())
        }
    };
    let h3 = h * h * h;
    let interior = signs
        .blocks
        .par_iter()
        .filter(|b| !grid.index.contains_key(&b.0))
        .map(|b| b.1.iter().map(|w| w.count_ones() as Real).sum::<Real>())
        .sum::<Real>()
        + signs
            .interior
            .par_iter()
            .filter(|b| !grid.index.contains_key(*b))
            .count() as Real
            * LEAF_SIZE as Real;
    // Newton iterations move s within ±lim, so a set voxel with |φ| ≥ ε + lim gives H = 0 or 1
    // and δ = 0 whatever s is; voxels that are not set are not shifted. Those are summed once,
    // and only the other set voxels (about a third of the band) are kept, per leaf, for the
    // evaluations: per leaf in parallel, then added in leaf order (a rayon `reduce` adds in an
    // order that depends on work stealing, so its last bits could change from run to run)
    let lim = 0.5 * band * h;
    let reach = eps + lim;
    let per_leaf: Vec<(Real, Real, Vec<f32>)> = grid
        .leaves
        .par_iter()
        .map(|l| {
            let (mut v, mut a) = (0.0, 0.0);
            let mut near = Vec::new();
            for n in 0..LEAF_SIZE {
                let phi = l.phi[n];
                if !l.is_set(n) {
                    v += heav(-(phi as Real));
                    a += delta(phi as Real);
                } else if (phi.abs() as Real) < reach {
                    near.push(phi);
                } else if phi < 0.0 {
                    v += 1.0;
                }
            }
            (v, a, near)
        })
        .collect();
    let eval = |s: Real| {
        let sums: Vec<(Real, Real)> = per_leaf
            .par_iter()
            .map(|(v0, a0, near)| {
                let (mut v, mut a) = (*v0, *a0);
                for &phi in near {
                    let phi = phi as Real + s;
                    v += heav(-phi);
                    a += delta(phi);
                }
                (v, a)
            })
            .collect();
        let (v, a) = sums.iter().fold((0.0, 0.0), |x, y| (x.0 + y.0, x.1 + y.1));
        ((v + interior) * h3, a * h3)
    };
    // Newton iterations on V(s) = V_p (V decreases with s at rate A)
    let mut shift = 0.0;
    for _ in 0..4 {
        let (vol, area) = eval(shift);
        if area.is_nan() || area <= 0.0 {
            break;
        }
        let next = (shift + (vol - target) / area).clamp(-lim, lim);
        let step = (next - shift).abs();
        shift = next;
        if step < 1e-4 * h {
            break;
        }
    }
    let bg = grid.bg;
    grid.leaves.par_iter_mut().for_each(|l| {
        for n in 0..LEAF_SIZE {
            if l.is_set(n) {
                l.phi[n] = (l.phi[n] as Real + shift).clamp(-(bg as Real), bg as Real) as f32;
            }
        }
    });
    shift
}
