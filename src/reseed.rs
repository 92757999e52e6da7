//! Particle reseeding of sheets and filaments (paper §9, Fig. 14).
//!
//! **Insertion (sheets).** Around every sheet particle p the sheet
//! neighbours are projected onto its tangent plane (b¹, b²) and binned into a
//! 5×5 grid of cell size 0.4 h centred on x_p. Each of the inner 3×3 cells
//! that is empty while all eight cells around it are filled receives a new
//! particle at the cell centre, lifted onto the local MLS surface
//! ξ³ = f(ξ¹, ξ²) of p. Filaments use the 1-D analogue along b¹: a 5-cell
//! line, the inner 3 cells, both neighbours filled, lifted onto the fitted
//! curve (ξ², ξ³) = f(ξ¹).
//!
//! Candidates from different particles that describe the same hole are
//! merged (a candidate closer than `merge_distance·h` to an earlier accepted
//! one, in particle order, is dropped), so holes are filled once.
//!
//! **Conservation.** A new particle takes a fraction 1/(k+1) of the mass of
//! each of its k nearest donors (existing particles of the same codimension,
//! k ≤ `donors`, each donating at most once per pass) together with that
//! share of their momentum; a donor keeps its velocity. Total mass and
//! momentum are unchanged (to round-off). The once-per-pass rule matters:
//! without it a rim particle surrounded by repeated insertions was drained to
//! 1/150 of its neighbours' mass in the bursting bubble, and its explicit bud
//! force (∝ 1/(m r)) blew up.
//!
//! **Removal.** Visiting particles in order, each deletes its closest
//! neighbour of the same codimension if it is nearer than
//! `remove_distance·h` (paper: between 0.1 h and 0.2 h); the deleted
//! particle's mass and momentum are merged into the survivor.
//!
//! Fixed (boundary) particles are never removed, never donate and never
//! seed; seen from a film particle, the cells beyond a fixed neighbour count
//! as filled, so the gap that opens between a film and a moving ring is
//! refilled. All changes are applied at one point (the end of [`reseed`]).

use crate::math::{Mat3, Real, Vec3};
use crate::neighbors::{cell_of, neighbor_lists_between, CellGrid, CellMap};
use crate::particles::{Codim, Particles};
use rayon::prelude::*;

/// Parameters of reseeding; distances relative to h.
#[derive(Clone, Debug, PartialEq)]
pub struct ReseedParams {
    /// Support radius h (m).
    pub h: Real,
    /// Cell size of the tangent grid, relative to h (paper: 0.4).
    pub cell: Real,
    /// Removal threshold relative to h (paper: 0.1–0.2).
    pub remove_distance: Real,
    /// Candidates closer than this (relative to h) to an accepted one are dropped.
    pub merge_distance: Real,
    /// Maximum number of donors per new particle.
    pub donors: usize,
    /// A sheet particle closer than this (relative to h) to a filament
    /// particle is absorbed by it (rim collection); 0 disables it.
    pub absorb_distance: Real,
    /// A particle lighter than this fraction of the mean mass of its
    /// same-codimension neighbours is merged into the nearest one; 0 disables it.
    pub light_fraction: Real,
}

impl ReseedParams {
    /// The paper's values for support radius `h`, removal at 0.15 h.
    pub fn paper(h: Real) -> Self {
        ReseedParams {
            h,
            cell: 0.4,
            remove_distance: 0.15,
            merge_distance: 0.25,
            donors: 4,
            absorb_distance: 0.3,
            light_fraction: 0.2,
        }
    }
}

/// What one reseeding pass did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct ReseedCounts {
    /// Sheet particles inserted.
    pub sheet_inserted: u64,
    /// Sheet particles removed.
    pub sheet_removed: u64,
    /// Filament particles inserted.
    pub filament_inserted: u64,
    /// Filament particles removed.
    pub filament_removed: u64,
    /// Sheet particles absorbed by a rim (filament) particle.
    pub absorbed: u64,
    /// Light particles merged into a neighbour.
    pub light_merged: u64,
    /// Filament particles left out of filament insertion because their
    /// neighbourhood is not line-like (a clump) or their frame is not a
    /// filament frame (a counted guard, see [`reseed_guarded`]).
    #[serde(default)]
    pub filament_skipped: u64,
}

impl ReseedCounts {
    /// Adds another pass's counts.
    pub fn add(&mut self, b: &ReseedCounts) {
        self.sheet_inserted += b.sheet_inserted;
        self.sheet_removed += b.sheet_removed;
        self.filament_inserted += b.filament_inserted;
        self.filament_removed += b.filament_removed;
        self.absorbed += b.absorbed;
        self.light_merged += b.light_merged;
        self.filament_skipped += b.filament_skipped;
    }
}

/// The local surface (sheets) or curve (filaments) of particle p in its own
/// frame, as fitted by MLS: `height(p, ξ¹, ξ²)` returns ξ³ on a sheet, and
/// `curve(p, ξ¹)` returns (ξ², ξ³) on a filament.
pub trait LocalShape: Sync {
    /// ξ³ of the fitted sheet of particle `p` at (ξ¹, ξ²).
    fn height(&self, p: usize, xi1: Real, xi2: Real) -> Real;
    /// (ξ², ξ³) of the fitted filament of particle `p` at ξ¹.
    fn curve(&self, p: usize, xi1: Real) -> (Real, Real);
}

/// The tangent plane itself (no curvature): the fallback when no fit exists.
pub struct FlatShape;

impl LocalShape for FlatShape {
    fn height(&self, _: usize, _: Real, _: Real) -> Real {
        0.0
    }
    fn curve(&self, _: usize, _: Real) -> (Real, Real) {
        (0.0, 0.0)
    }
}

/// Candidate positions proposed around sheet particle `p`.
fn sheet_candidates(
    p: usize,
    parts: &Particles,
    frame: &Mat3,
    nbrs: &[u32],
    prm: &ReseedParams,
    shape: &dyn LocalShape,
) -> Vec<Vec3> {
    let c = prm.cell * prm.h;
    let mut filled = [[false; 5]; 5];
    filled[2][2] = true; // p itself
    let b1: Vec3 = frame.column(0).into();
    let b2: Vec3 = frame.column(1).into();
    for &q in nbrs {
        let q = q as usize;
        if parts.codim[q] != Codim::Sheet {
            continue;
        }
        let d = parts.x[q] - parts.x[p];
        let (u, v) = (d.dot(&b1) / c + 2.5, d.dot(&b2) / c + 2.5);
        if (0.0..5.0).contains(&u) && (0.0..5.0).contains(&v) {
            filled[u as usize][v as usize] = true;
        }
        if parts.fixed[q] {
            // a boundary (ring) particle closes the film: the cells beyond it,
            // seen from p, count as filled so a gap between the film and a
            // moving ring is refilled
            let (du, dv) = (u - 2.5, v - 2.5);
            for k in 1..=4 {
                let f = 1.0 + 0.5 * k as Real;
                let (uu, vv) = (2.5 + du * f, 2.5 + dv * f);
                if (0.0..5.0).contains(&uu) && (0.0..5.0).contains(&vv) {
                    filled[uu as usize][vv as usize] = true;
                }
            }
        }
    }
    let mut out = Vec::new();
    for i in 1..4 {
        for j in 1..4 {
            if filled[i][j] {
                continue;
            }
            let surrounded = (-1i32..=1).all(|di| {
                (-1i32..=1).all(|dj| {
                    (di == 0 && dj == 0)
                        || filled[(i as i32 + di) as usize][(j as i32 + dj) as usize]
                })
            });
            if surrounded {
                let (u, v) = ((i as Real - 2.0) * c, (j as Real - 2.0) * c);
                let w = shape.height(p, u, v);
                let b3: Vec3 = frame.column(2).into();
                out.push(parts.x[p] + b1 * u + b2 * v + b3 * w);
            }
        }
    }
    out
}

/// Candidate positions proposed around filament particle `p`.
fn filament_candidates(
    p: usize,
    parts: &Particles,
    frame: &Mat3,
    nbrs: &[u32],
    prm: &ReseedParams,
    shape: &dyn LocalShape,
) -> Vec<Vec3> {
    let c = prm.cell * prm.h;
    let mut filled = [false; 5];
    filled[2] = true;
    let b1: Vec3 = frame.column(0).into();
    for &q in nbrs {
        let q = q as usize;
        if parts.codim[q] != Codim::Filament {
            continue;
        }
        let u = (parts.x[q] - parts.x[p]).dot(&b1) / c + 2.5;
        if (0.0..5.0).contains(&u) {
            filled[u as usize] = true;
        }
    }
    let mut out = Vec::new();
    for i in 1..4 {
        if !filled[i] && filled[i - 1] && filled[i + 1] {
            let u = (i as Real - 2.0) * c;
            let (v, w) = shape.curve(p, u);
            out.push(parts.x[p] + b1 * u + frame.column(1) * v + frame.column(2) * w);
        }
    }
    out
}

/// Inserts particles of codimension `kind` at `cands` (in order), merging
/// duplicates and taking mass and momentum from the nearest donors.
fn insert(parts: &mut Particles, kind: Codim, cands: Vec<Vec3>, prm: &ReseedParams) -> u64 {
    let donors_all: Vec<usize> = (0..parts.len())
        .filter(|&i| parts.codim[i] == kind && !parts.fixed[i])
        .collect();
    if donors_all.is_empty() || cands.is_empty() {
        return 0;
    }
    // 1. merge candidates that fill the same hole (deterministic: first wins)
    let merge = prm.merge_distance * prm.h;
    let inv = 1.0 / merge;
    let mut seen: CellMap<Vec<usize>> = CellMap::default();
    let mut accepted: Vec<Vec3> = Vec::new();
    for c in cands {
        let cc = cell_of(&c, inv);
        let mut near = false;
        'scan: for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    if let Some(list) = seen.get(&[cc[0] + dx, cc[1] + dy, cc[2] + dz]) {
                        if list.iter().any(|&a| (accepted[a] - c).norm() < merge) {
                            near = true;
                            break 'scan;
                        }
                    }
                }
            }
        }
        if !near {
            seen.entry(cc).or_default().push(accepted.len());
            accepted.push(c);
        }
    }
    // 2. donors: nearest existing particles of the same kind within h
    let dx: Vec<Vec3> = donors_all.iter().map(|&i| parts.x[i]).collect();
    let nl = neighbor_lists_between(&accepted, &dx, prm.h);
    // each particle donates at most once per pass, so repeated insertions
    // around one particle cannot drain its mass geometrically
    let mut donated = vec![false; parts.len()];
    let mut n = 0;
    for (k, c) in accepted.iter().enumerate() {
        let mut cand: Vec<(Real, usize)> = nl
            .of(k)
            .iter()
            .map(|&j| ((dx[j as usize] - c).norm_squared(), donors_all[j as usize]))
            .filter(|&(_, j)| !donated[j])
            .collect();
        if cand.is_empty() {
            continue;
        }
        cand.sort_by(|a, b| a.partial_cmp(b).unwrap());
        cand.truncate(prm.donors);
        let f = 1.0 / (cand.len() as Real + 1.0);
        let (mut m, mut mom, mut r) = (0.0, Vec3::zeros(), 0.0);
        for &(_, j) in &cand {
            let dm = f * parts.mass[j];
            m += dm;
            mom += parts.v[j] * dm;
            r += parts.radius[j] * dm;
            parts.mass[j] -= dm;
            donated[j] = true;
        }
        if m > 0.0 {
            parts.push(*c, mom / m, m, r / m, kind);
            n += 1;
        }
    }
    n
}

/// Adds particle `gone`'s mass and momentum to particle `keep` (velocity
/// and radius become mass-weighted means); the caller deletes `gone`.
fn merge_into(parts: &mut Particles, keep: usize, gone: usize) {
    let (mk, mg) = (parts.mass[keep], parts.mass[gone]);
    let m = mk + mg;
    if m > 0.0 {
        parts.v[keep] = (parts.v[keep] * mk + parts.v[gone] * mg) / m;
        parts.radius[keep] = (parts.radius[keep] * mk + parts.radius[gone] * mg) / m;
    }
    parts.mass[keep] = m;
}

/// Removes particles of codimension `kind` closer than the threshold to a
/// surviving one, merging mass and momentum. Returns the number removed.
fn remove_close(parts: &mut Particles, kind: Codim, prm: &ReseedParams) -> u64 {
    let idx: Vec<usize> = (0..parts.len())
        .filter(|&i| parts.codim[i] == kind)
        .collect();
    if idx.len() < 2 {
        return 0;
    }
    let pts: Vec<Vec3> = idx.iter().map(|&i| parts.x[i]).collect();
    let r = prm.remove_distance * prm.h;
    let grid = CellGrid::build(&pts, r);
    let mut alive = vec![true; parts.len()];
    let mut n = 0;
    for (a, &p) in idx.iter().enumerate() {
        if !alive[p] {
            continue;
        }
        let mut best: Option<(Real, usize)> = None;
        grid.for_each_within(&pts, &pts[a], r, |b, d2| {
            let q = idx[b];
            if q != p
                && alive[q]
                && !parts.fixed[q]
                && best.is_none_or(|(bd, bq)| d2 < bd || (d2 == bd && q < bq))
            {
                best = Some((d2, q));
            }
        });
        if let Some((_, q)) = best {
            merge_into(parts, p, q);
            alive[q] = false;
            n += 1;
        }
    }
    parts.retain(&alive);
    n
}

/// Merges every non-fixed particle of codimension `kind` whose mass is below
/// `light_fraction` × the mean mass of its same-kind neighbours within h
/// into its nearest such neighbour (mass and momentum added). Repeated
/// insertions in a region that keeps stretching split masses geometrically;
/// a particle 1/10 of its neighbours' mass makes the tension system (rows
/// scaled by σΔt²S/m) stiff enough to blow up (bursting bubble, s = 4 mm,
/// step 45: v = 2·10³ m/s on a 2.9·10⁻¹⁰ kg particle among 1.6·10⁻⁸ kg ones).
fn merge_light(parts: &mut Particles, kind: Codim, prm: &ReseedParams) -> u64 {
    if prm.light_fraction <= 0.0 {
        return 0;
    }
    let idx: Vec<usize> = (0..parts.len())
        .filter(|&i| parts.codim[i] == kind)
        .collect();
    if idx.len() < 2 {
        return 0;
    }
    let pts: Vec<Vec3> = idx.iter().map(|&i| parts.x[i]).collect();
    let grid = CellGrid::build(&pts, prm.h);
    let mut alive = vec![true; parts.len()];
    let mut n = 0;
    for (a, &p) in idx.iter().enumerate() {
        if parts.fixed[p] || !alive[p] {
            continue;
        }
        let (mut sum, mut cnt) = (0.0, 0usize);
        let mut best: Option<(Real, usize)> = None;
        grid.for_each_within(&pts, &pts[a], prm.h, |b, d2| {
            let q = idx[b];
            if q != p && alive[q] {
                sum += parts.mass[q];
                cnt += 1;
                if best.is_none_or(|(bd, bq)| d2 < bd || (d2 == bd && q < bq)) {
                    best = Some((d2, q));
                }
            }
        });
        let Some((_, q)) = best else { continue };
        if parts.mass[p] < prm.light_fraction * sum / cnt as Real {
            merge_into(parts, q, p);
            alive[p] = false;
            n += 1;
        }
    }
    parts.retain(&alive);
    n
}

/// Rim collection: every non-fixed sheet particle closer than
/// `absorb_distance·h` to a filament particle is merged into the nearest one
/// (mass and momentum added, the rim particle keeps its position). This is
/// how a retracting rim gathers the film it sweeps (Taylor–Culick): without
/// it a light rim particle, pulled by the rim tension 2σl, overtakes the
/// sheet instead of collecting it.
fn absorb_into_rims(parts: &mut Particles, prm: &ReseedParams) -> u64 {
    let r = prm.absorb_distance * prm.h;
    if r <= 0.0 {
        return 0;
    }
    let fil: Vec<usize> = (0..parts.len())
        .filter(|&i| parts.codim[i] == Codim::Filament)
        .collect();
    if fil.is_empty() {
        return 0;
    }
    let fx: Vec<Vec3> = fil.iter().map(|&i| parts.x[i]).collect();
    let grid = CellGrid::build(&fx, r);
    let mut alive = vec![true; parts.len()];
    let mut n = 0;
    for i in 0..parts.len() {
        if parts.codim[i] != Codim::Sheet || parts.fixed[i] {
            continue;
        }
        let mut best: Option<(Real, usize)> = None;
        grid.for_each_within(&fx, &parts.x[i], r, |b, d2| {
            if best.is_none_or(|(bd, bb)| d2 < bd || (d2 == bd && b < bb)) {
                best = Some((d2, b));
            }
        });
        if let Some((_, b)) = best {
            let q = fil[b];
            let r = parts.radius[q];
            merge_into(parts, q, i);
            parts.radius[q] = r; // the rim keeps its tube radius; it is recomputed from mass
            alive[i] = false;
            n += 1;
        }
    }
    parts.retain(&alive);
    n
}

/// Reseeds sheets and filaments (Algorithm 1, line 3). `frames[i]` and
/// `nbrs(i)` are particle i's local frame and neighbours within h, computed
/// before the call; `shape` gives the fitted local surface/curve.
pub fn reseed<'a>(
    parts: &mut Particles,
    frames: &[Mat3],
    nbrs: impl Fn(usize) -> &'a [u32] + Sync,
    shape: &dyn LocalShape,
    prm: &ReseedParams,
) -> ReseedCounts {
    reseed_guarded(parts, frames, nbrs, shape, prm, |_| true)
}

/// [`reseed`] with a guard on filament insertion: filament particle `p`
/// proposes candidates only when `filament_ok(p)`; the others are counted in
/// [`ReseedCounts::filament_skipped`]. The film step passes "the frame was
/// built from filament neighbours and is line-like" (PCA λ₂ ≤ ratio × λ₁):
/// on a clump no curve fits, and inserting along a garbage tangent
/// multiplied clumps on the bursting bubble.
pub fn reseed_guarded<'a>(
    parts: &mut Particles,
    frames: &[Mat3],
    nbrs: impl Fn(usize) -> &'a [u32] + Sync,
    shape: &dyn LocalShape,
    prm: &ReseedParams,
    filament_ok: impl Fn(usize) -> bool + Sync,
) -> ReseedCounts {
    let n0 = parts.len();
    let view: &Particles = parts;
    let per: Vec<(Vec<Vec3>, Vec<Vec3>, bool)> = (0..n0)
        .into_par_iter()
        .map(|p| {
            if view.fixed[p] {
                return (Vec::new(), Vec::new(), false);
            }
            match view.codim[p] {
                Codim::Sheet => (
                    sheet_candidates(p, view, &frames[p], nbrs(p), prm, shape),
                    Vec::new(),
                    false,
                ),
                Codim::Filament if !filament_ok(p) => (Vec::new(), Vec::new(), true),
                Codim::Filament => (
                    Vec::new(),
                    filament_candidates(p, view, &frames[p], nbrs(p), prm, shape),
                    false,
                ),
                _ => (Vec::new(), Vec::new(), false),
            }
        })
        .collect();
    let skipped = per.iter().filter(|t| t.2).count() as u64;
    let (mut sc, mut fc) = (Vec::new(), Vec::new());
    for (s, f, _) in per {
        sc.extend(s);
        fc.extend(f);
    }
    let mut c = ReseedCounts {
        sheet_inserted: insert(parts, Codim::Sheet, sc, prm),
        filament_inserted: insert(parts, Codim::Filament, fc, prm),
        filament_skipped: skipped,
        ..Default::default()
    };
    c.absorbed = absorb_into_rims(parts, prm);
    c.light_merged =
        merge_light(parts, Codim::Sheet, prm) + merge_light(parts, Codim::Filament, prm);
    c.sheet_removed = remove_close(parts, Codim::Sheet, prm);
    c.filament_removed = remove_close(parts, Codim::Filament, prm);
    c
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::neighbors::neighbor_lists;

    fn flat_sheet(n: usize, s: Real, hole: Option<(usize, usize)>) -> Particles {
        let mut p = Particles::new();
        for i in 0..n {
            for j in 0..n {
                if Some((i, j)) == hole {
                    continue;
                }
                let v = Vec3::new(0.1 * i as Real, -0.2 * j as Real, 0.05);
                p.push(
                    Vec3::new(i as Real * s, j as Real * s, 0.0),
                    v,
                    1.0 + 0.01 * (i + j) as Real,
                    0.01,
                    Codim::Sheet,
                );
            }
        }
        p
    }

    fn momentum(p: &Particles) -> Vec3 {
        (0..p.len()).map(|i| p.v[i] * p.mass[i]).sum()
    }

    #[test]
    fn hole_in_sheet_is_filled_once_conserving_mass_and_momentum() {
        let h = 0.1;
        let s = 0.4 * h; // one particle per tangent cell
        let mut p = flat_sheet(11, s, Some((5, 5)));
        let (m0, j0) = (p.total_mass(), momentum(&p));
        let frames = vec![Mat3::identity(); p.len()];
        let nl = neighbor_lists(&p.x, h);
        let c = reseed(
            &mut p,
            &frames,
            |i| nl.of(i),
            &FlatShape,
            &ReseedParams::paper(h),
        );
        assert_eq!(c.sheet_inserted, 1, "{c:?}");
        assert_eq!(c.sheet_removed, 0);
        let new = p.len() - 1;
        assert!((p.x[new] - Vec3::new(5.0 * s, 5.0 * s, 0.0)).norm() < 1e-12);
        assert!((p.total_mass() - m0).abs() < 1e-12 * m0);
        assert!((momentum(&p) - j0).norm() < 1e-12 * j0.norm());
    }

    #[test]
    fn new_particle_lies_on_the_fitted_surface() {
        struct Bowl;
        impl LocalShape for Bowl {
            fn height(&self, _: usize, u: Real, v: Real) -> Real {
                u * u + v * v
            }
            fn curve(&self, _: usize, _: Real) -> (Real, Real) {
                (0.0, 0.0)
            }
        }
        let h = 0.1;
        let mut p = flat_sheet(11, 0.4 * h, Some((5, 5)));
        let frames = vec![Mat3::identity(); p.len()];
        let nl = neighbor_lists(&p.x, h);
        reseed(
            &mut p,
            &frames,
            |i| nl.of(i),
            &Bowl,
            &ReseedParams::paper(h),
        );
        let new = *p.id.last().unwrap();
        let k = p.id.iter().position(|&i| i == new).unwrap();
        // seeded by some neighbour q: z = |x_new - x_q|² in q's frame
        let z = p.x[k].z;
        assert!(z > 0.0 && z <= 2.0 * (0.4 * h).powi(2) + 1e-12, "z = {z}");
    }

    #[test]
    fn close_pairs_are_merged_conserving_mass_and_momentum() {
        let h = 0.1;
        let mut p = flat_sheet(6, 0.4 * h, None);
        p.push(
            Vec3::new(0.401 * h, 0.0, 0.0),
            Vec3::new(3.0, 0.0, 0.0),
            2.0,
            0.01,
            Codim::Sheet,
        );
        let (m0, j0, n0) = (p.total_mass(), momentum(&p), p.len());
        let frames = vec![Mat3::identity(); p.len()];
        let nl = neighbor_lists(&p.x, h);
        let c = reseed(
            &mut p,
            &frames,
            |i| nl.of(i),
            &FlatShape,
            &ReseedParams::paper(h),
        );
        assert_eq!(c.sheet_removed, 1);
        assert_eq!(c.sheet_inserted, 0);
        assert_eq!(p.len(), n0 - 1);
        assert!((p.total_mass() - m0).abs() < 1e-12 * m0);
        assert!((momentum(&p) - j0).norm() < 1e-12 * j0.norm());
    }

    #[test]
    fn stretched_filament_gains_a_particle_in_each_gap() {
        let h = 0.1;
        let mut p = Particles::new();
        // spacing 0.4h except one gap of 0.8h between particles 4 and 5
        let mut xs: Vec<Real> = (0..5).map(|i| i as Real * 0.4 * h).collect();
        xs.extend((5..10).map(|i| (i as Real + 1.0) * 0.4 * h));
        for x in xs {
            p.push(
                Vec3::new(x, 0.0, 0.0),
                Vec3::new(0.0, 1.0, 0.0),
                1.0,
                0.01,
                Codim::Filament,
            );
        }
        let m0 = p.total_mass();
        let frames = vec![Mat3::identity(); p.len()];
        let nl = neighbor_lists(&p.x, h);
        let c = reseed(
            &mut p,
            &frames,
            |i| nl.of(i),
            &FlatShape,
            &ReseedParams::paper(h),
        );
        assert_eq!(c.filament_inserted, 1, "{c:?}");
        assert!(p
            .x
            .iter()
            .any(|x| (x - Vec3::new(2.0 * h, 0.0, 0.0)).norm() < 1e-12));
        assert!((p.total_mass() - m0).abs() < 1e-12);
    }

    #[test]
    fn fixed_particles_are_never_removed() {
        let h = 0.1;
        let mut p = Particles::new();
        p.push(Vec3::zeros(), Vec3::zeros(), 1.0, 0.01, Codim::Sheet);
        p.push(
            Vec3::new(0.001, 0.0, 0.0),
            Vec3::zeros(),
            1.0,
            0.01,
            Codim::Sheet,
        );
        p.fixed[1] = true;
        p.fixed[0] = true;
        let frames = vec![Mat3::identity(); 2];
        let nl = neighbor_lists(&p.x, h);
        let c = reseed(
            &mut p,
            &frames,
            |i| nl.of(i),
            &FlatShape,
            &ReseedParams::paper(h),
        );
        assert_eq!(c.sheet_removed, 0);
        assert_eq!(p.len(), 2);
    }
}
