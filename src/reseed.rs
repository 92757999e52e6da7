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
//! **Gap lines (addition to §9).** A sheet stretched along one tangent
//! direction only (the neck of a catenoid whose rings separate: rows pulled
//! apart axially while the circumference shrinks) opens whole empty lines of
//! cells; no empty cell then has all eight neighbours filled and the paper's
//! rule never inserts, until the rows are too far apart for a cubic fit
//! (three distinct levels across h) and the tension solve blows up. With
//! `gap_lines` (on for scenes with moving rings) an empty cell whose three cells on both sides across one grid
//! axis are filled is filled too, halfway between the particles of the two
//! cells across the gap. A free edge or a hole wider than a cell has one side
//! empty and stays open.
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
use crate::neighbors::{cell_of, neighbor_lists_between, CellMap};
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
    /// Also fill an empty cell lying in a gap line (its three cells on both
    /// sides across one grid axis filled), not only a cell with all eight
    /// neighbours filled: a film stretched in one direction only opens whole
    /// empty lines of cells that the paper's rule never fills. Off in
    /// [`ReseedParams::paper`]; on for scenes whose rings move (see
    /// `docs/decisions.md`, "Moving rings").
    pub gap_lines: bool,
    /// A sheet particle closer than this (relative to h) to a filament
    /// particle is absorbed by it (rim collection); 0 disables it.
    pub absorb_distance: Real,
    /// Rim collection only by filament particles on a film's edge: one whose
    /// sheet neighbours within h surround it, leaving no gap wider than this
    /// angle ([`crate::transition::surrounded_by_sheet`]), lies inside a
    /// flat film and collects nothing. 0 (liquid scenes, the paper) lets
    /// every filament particle collect; film scenes use π/2, the gap of
    /// their 2→1 rule (docs/decisions.md, "Inside a film, no rim collects").
    pub rim_gap: Real,
    /// A particle lighter than this fraction of the mean mass of its
    /// same-codimension neighbours is merged into the nearest one; 0 disables it.
    pub light_fraction: Real,
    /// Mass floor (kg): no particle lighter than this is inserted, and one
    /// lighter than this is merged into its nearest same-codimension
    /// neighbour like a light one; 0 disables it. Liquid scenes set it
    /// ([`ReseedParams::liquid`]); film scenes, whose sheets may be µm thin,
    /// leave it off.
    pub min_mass: Real,
    /// A sheet particle heavier than this multiple of the mean mass of its
    /// sheet neighbours within h is a droplet, not film: it becomes a point
    /// particle (`heavy_shed`); 0 disables it. Off in
    /// [`ReseedParams::paper`]; on for scenes whose rings move, where the
    /// pinch gathers the neck's film into a few particles
    /// ([`HEAVY_FRACTION`], docs/decisions.md).
    pub heavy_fraction: Real,
}

/// [`ReseedParams::heavy_fraction`] of scenes whose rings move.
pub const HEAVY_FRACTION: Real = 10.0;

impl ReseedParams {
    /// The paper's values for support radius `h`, removal at 0.15 h.
    pub fn paper(h: Real) -> Self {
        ReseedParams {
            h,
            cell: 0.4,
            remove_distance: 0.15,
            merge_distance: 0.25,
            donors: 4,
            gap_lines: false,
            absorb_distance: 0.3,
            rim_gap: 0.0,
            light_fraction: 0.2,
            min_mass: 0.0,
            heavy_fraction: 0.0,
        }
    }

    /// [`ReseedParams::paper`] for a liquid scene of density `rho`, with the
    /// mass floor at [`LIQUID_MIN_MASS`] × ρ (h/4)³ (the lightest volume
    /// particle of the paper's samplings, spacing Δx/4 with h = Δx).
    pub fn liquid(h: Real, rho: Real) -> Self {
        ReseedParams {
            min_mass: LIQUID_MIN_MASS * rho * (0.25 * h).powi(3),
            ..Self::paper(h)
        }
    }
}

/// Mass floor of reseeding in liquid scenes, relative to the mass of a
/// volume particle at spacing h/4. In the fluid polygon, filament reseeding
/// along a stretched rim split its particles again and again, down to
/// 1e-10 kg (0.03 % of a volume particle's mass); the rim force 2σl on such
/// a particle accelerates it at ~10⁵ m/s², and the CFL substep fell to
/// 1e-5 s. With the floor at 0.02 the rim still shot 3e-9 kg particles off at
/// 13–15 m/s (`docs/decisions.md`). 0.1 × ρ(h/4)³ is a droplet of radius
/// Δx/14.
pub const LIQUID_MIN_MASS: Real = 0.1;

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
    /// Filament particles that reached a boundary (ring) particle and were
    /// merged into it (the rim of a retracted film wets the ring).
    #[serde(default)]
    pub boundary_absorbed: u64,
    /// Filament particles left out of filament insertion because their
    /// neighbourhood is not line-like (a clump) or their frame is not a
    /// filament frame (a counted guard, see [`reseed_guarded`]).
    #[serde(default)]
    pub filament_skipped: u64,
    /// Sheet particles much heavier than their sheet neighbours turned
    /// into points ([`ReseedParams::heavy_fraction`]).
    #[serde(default)]
    pub heavy_shed: u64,
}

impl ReseedCounts {
    /// Particles inserted (sheets and filaments).
    pub fn inserted(&self) -> u64 {
        self.sheet_inserted + self.filament_inserted
    }

    /// Particles removed: merged into a neighbour, absorbed by a rim or a ring.
    pub fn removed(&self) -> u64 {
        self.sheet_removed
            + self.filament_removed
            + self.absorbed
            + self.light_merged
            + self.boundary_absorbed
    }

    /// Adds the counts of `o`.
    pub fn add(&mut self, o: &ReseedCounts) {
        self.sheet_inserted += o.sheet_inserted;
        self.sheet_removed += o.sheet_removed;
        self.filament_inserted += o.filament_inserted;
        self.filament_removed += o.filament_removed;
        self.absorbed += o.absorbed;
        self.light_merged += o.light_merged;
        self.boundary_absorbed += o.boundary_absorbed;
        self.filament_skipped += o.filament_skipped;
        self.heavy_shed += o.heavy_shed;
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
                         // sum of the cell coordinates of the particles in each cell (and count)
    let mut mean = [[(0.0, 0.0, 0.0); 5]; 5];
    mean[2][2] = (0.0, 0.0, 1.0);
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
            let m = &mut mean[u as usize][v as usize];
            m.0 += u - 2.5;
            m.1 += v - 2.5;
            m.2 += 1.0;
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
            // a gap line: the film stretched along one tangent direction only
            // (the neck of a catenoid whose rings separate) leaves whole lines of
            // cells empty, so no empty cell has all eight neighbours filled; a
            // cell whose three cells on *both* sides across one grid axis are
            // filled lies in such a gap and is filled too (a free edge or a
            // hole larger than one cell has one side empty and is left alone)
            let side = |a: (i32, i32), b: (i32, i32)| {
                (-1i32..=1).all(|k| {
                    let (ia, ja) = (i as i32 + a.0 + k * b.0, j as i32 + a.1 + k * b.1);
                    filled[ia as usize][ja as usize]
                })
            };
            let across_u = side((-1, 0), (0, 1)) && side((1, 0), (0, 1));
            let across_v = side((0, -1), (1, 0)) && side((0, 1), (1, 0));
            let gap_line = prm.gap_lines && (across_u || across_v);
            if surrounded || gap_line {
                let (mut u, mut v) = ((i as Real - 2.0) * c, (j as Real - 2.0) * c);
                if !surrounded {
                    // in a gap line the new particle goes halfway between the
                    // particles of the two cells across the gap (the cell
                    // centre can lie next to one side when the gap is < 2 cells)
                    let (a, b) = if across_u {
                        (mean[i - 1][j], mean[i + 1][j])
                    } else {
                        (mean[i][j - 1], mean[i][j + 1])
                    };
                    if a.2 > 0.0 && b.2 > 0.0 {
                        let mid = |k: usize| {
                            let (pa, pb) = if k == 0 { (a.0, b.0) } else { (a.1, b.1) };
                            0.5 * (pa / a.2 + pb / b.2) * c
                        };
                        if across_u {
                            u = mid(0);
                        } else {
                            v = mid(1);
                        }
                    }
                }
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
        if f * cand.iter().map(|&(_, j)| parts.mass[j]).sum::<Real>() < prm.min_mass {
            continue;
        }
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

#[path = "reseed_merge.rs"]
mod merge;
use merge::{absorb_into_boundary, absorb_into_rims, merge_light, remove_close, shed_heavy};

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
    reseed_guarded(parts, frames, nbrs, shape, prm, |_| true, &[])
}

/// [`reseed`] with a guard on filament insertion: filament particle `p`
/// proposes candidates only when `filament_ok(p)`; the others are counted in
/// [`ReseedCounts::filament_skipped`]. The film step passes "the frame was
/// built from filament neighbours and is line-like" (PCA λ₂ ≤ ratio × λ₁):
/// on a clump no curve fits, and inserting along a garbage tangent
/// multiplied clumps on the bursting bubble. `volume` holds the positions of
/// volume particles that are not in `parts` (a liquid scene reseeds its
/// sheet/filament set on its own): a sheet particle within h of one is a
/// liquid body's surface layer, which rims do not collect.
pub fn reseed_guarded<'a>(
    parts: &mut Particles,
    frames: &[Mat3],
    nbrs: impl Fn(usize) -> &'a [u32] + Sync,
    shape: &dyn LocalShape,
    prm: &ReseedParams,
    filament_ok: impl Fn(usize) -> bool + Sync,
    volume: &[Vec3],
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
    c.absorbed = absorb_into_rims(parts, prm, volume);
    c.boundary_absorbed = absorb_into_boundary(parts, prm);
    c.light_merged =
        merge_light(parts, Codim::Sheet, prm) + merge_light(parts, Codim::Filament, prm);
    c.sheet_removed = remove_close(parts, Codim::Sheet, prm);
    c.filament_removed = remove_close(parts, Codim::Filament, prm);
    c.heavy_shed = shed_heavy(parts, prm);
    c
}

#[cfg(test)]
#[path = "reseed_tests.rs"]
mod tests;
