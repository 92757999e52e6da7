//! Removal half of reseeding (paper §9): merging close and light
//! particles, rim collection and rim arrival at a ring. Split from
//! [`super`] to keep the files short; every function conserves mass and
//! momentum exactly.

use super::ReseedParams;
use crate::math::{Real, Vec3};
use crate::neighbors::CellGrid;
use crate::particles::{Codim, Particles};
use rayon::prelude::*;

/// Adds particle `gone`'s mass and momentum to particle `keep` (velocity
/// and radius become mass-weighted means); the caller deletes `gone`.
pub(super) fn merge_into(parts: &mut Particles, keep: usize, gone: usize) {
    let (mk, mg) = (parts.mass[keep], parts.mass[gone]);
    let m = mk + mg;
    if parts.fixed[keep] {
        // a boundary (ring) particle takes the mass but keeps its prescribed
        // velocity: momentum goes to the boundary, as on a wall
        parts.mass[keep] = m;
        return;
    }
    if m > 0.0 {
        parts.v[keep] = (parts.v[keep] * mk + parts.v[gone] * mg) / m;
        parts.radius[keep] = (parts.radius[keep] * mk + parts.radius[gone] * mg) / m;
    }
    parts.mass[keep] = m;
}

/// [`merge_into`], with the survivor moved to the pair's centre of mass
/// (a fixed survivor stays), so the merge keeps the centre of mass as well
/// as mass and momentum and leaves no gap on the side of the removed
/// particle. Used for light particles ([`merge_light`]): merged in place,
/// the fragments of a pinch (catenoid at s = 2 mm) left heavy particles
/// with one-sided neighbourhoods that the cone test took for rims, and the
/// film tore from them. Not used by [`remove_close`]: at a retracting edge
/// the centroid moves the edge particle back by half a spacing per merge,
/// and the funnel of the catenoid pinch then retracted at 7.27 m/s instead
/// of 6.47 (Taylor–Culick 5.48; `tests/films_pinch.rs`).
pub(super) fn merge_at_centroid(parts: &mut Particles, keep: usize, gone: usize) {
    let (mk, mg) = (parts.mass[keep], parts.mass[gone]);
    if !parts.fixed[keep] && mk + mg > 0.0 {
        parts.x[keep] = (parts.x[keep] * mk + parts.x[gone] * mg) / (mk + mg);
    }
    merge_into(parts, keep, gone);
}

/// Indices and positions of the particles of codimension `kind`; `None`
/// when there are fewer than two (nothing to merge).
fn of_kind(parts: &Particles, kind: Codim) -> Option<(Vec<usize>, Vec<Vec3>)> {
    let idx: Vec<usize> = (0..parts.len())
        .filter(|&i| parts.codim[i] == kind)
        .collect();
    if idx.len() < 2 {
        return None;
    }
    let pts = idx.iter().map(|&i| parts.x[i]).collect();
    Some((idx, pts))
}

/// Removes particles of codimension `kind` closer than the threshold to a
/// surviving one, merging mass and momentum. Returns the number removed.
pub(super) fn remove_close(parts: &mut Particles, kind: Codim, prm: &ReseedParams) -> u64 {
    let Some((idx, pts)) = of_kind(parts, kind) else {
        return 0;
    };
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
/// (or below `min_mass`) into its nearest such neighbour (mass and momentum
/// added). Repeated
/// insertions in a region that keeps stretching split masses geometrically;
/// a particle 1/10 of its neighbours' mass makes the tension system (rows
/// scaled by σΔt²S/m) stiff enough to blow up (bursting bubble, s = 4 mm,
/// step 45: v = 2·10³ m/s on a 2.9·10⁻¹⁰ kg particle among 1.6·10⁻⁸ kg ones).
pub(super) fn merge_light(parts: &mut Particles, kind: Codim, prm: &ReseedParams) -> u64 {
    if prm.light_fraction <= 0.0 && prm.min_mass <= 0.0 {
        return 0;
    }
    let Some((idx, pts)) = of_kind(parts, kind) else {
        return 0;
    };
    let grid = CellGrid::build(&pts, prm.h);
    // The light test of `p` given the current masses and survivors: the
    // nearest alive non-fixed neighbour when p is light.
    let test = |a: usize, parts: &Particles, alive: &[bool]| -> Option<usize> {
        let p = idx[a];
        let (mut sum, mut cnt) = (0.0, 0usize);
        let mut best: Option<(Real, usize)> = None;
        grid.for_each_within(&pts, &pts[a], prm.h, |b, d2| {
            let q = idx[b];
            if q != p && alive[q] {
                sum += parts.mass[q];
                cnt += 1;
                if !parts.fixed[q] && best.is_none_or(|(bd, bq)| d2 < bd || (d2 == bd && q < bq)) {
                    best = Some((d2, q));
                }
            }
        });
        let (_, q) = best?;
        let light = parts.mass[p] < prm.light_fraction * sum / cnt as Real;
        (light || parts.mass[p] < prm.min_mass).then_some(q)
    };
    // The sequential pass below visits the particles in order and merges
    // each light one at once, which changes its neighbours' tests. The tests
    // of all particles against the initial state run in parallel first; in
    // the pass a particle is re-tested only when it was light initially or a
    // merge happened within h of it (its test inputs changed), so the result
    // is the one of testing every particle in turn, at a fraction of the cost.
    let all_alive = vec![true; parts.len()];
    let view: &Particles = parts;
    let light0: Vec<bool> = (0..idx.len())
        .into_par_iter()
        .map(|a| !view.fixed[idx[a]] && test(a, view, &all_alive).is_some())
        .collect();
    let pos: Vec<usize> = {
        let mut v = vec![usize::MAX; parts.len()];
        for (a, &i) in idx.iter().enumerate() {
            v[i] = a;
        }
        v
    };
    let mut dirty = light0;
    let mut alive = vec![true; parts.len()];
    let mut n = 0;
    for (a, &p) in idx.iter().enumerate() {
        if parts.fixed[p] || !alive[p] || !dirty[a] {
            continue;
        }
        if let Some(q) = test(a, parts, &alive) {
            merge_at_centroid(parts, q, p);
            alive[p] = false;
            n += 1;
            for c in [a, pos[q]] {
                grid.for_each_within(&pts, &pts[c], prm.h, |b, _| dirty[b] = true);
            }
        }
    }
    parts.retain(&alive);
    n
}

/// Turns every non-fixed sheet particle heavier than `heavy_fraction` × the
/// mean mass of its sheet neighbours within h into a point particle (a
/// droplet leaving the film; mass and momentum unchanged). Returns the
/// number turned. A pinch merges the neck's film into a few particles, up
/// to 200× their neighbours' mass (catenoid at s = 1.33 mm); left in the
/// film they lag behind their light neighbours, their neighbourhoods open
/// on one side, and the cone test turns them into rims that tear the film.
pub(super) fn shed_heavy(parts: &mut Particles, prm: &ReseedParams) -> u64 {
    if prm.heavy_fraction <= 0.0 {
        return 0;
    }
    let Some((idx, pts)) = of_kind(parts, Codim::Sheet) else {
        return 0;
    };
    let grid = CellGrid::build(&pts, prm.h);
    let view: &Particles = parts;
    let heavy: Vec<bool> = (0..idx.len())
        .into_par_iter()
        .map(|a| {
            let p = idx[a];
            if view.fixed[p] {
                return false;
            }
            let (mut sum, mut cnt) = (0.0, 0usize);
            grid.for_each_within(&pts, &pts[a], prm.h, |b, _| {
                let q = idx[b];
                if q != p && !view.fixed[q] {
                    sum += view.mass[q];
                    cnt += 1;
                }
            });
            cnt > 0 && view.mass[p] > prm.heavy_fraction * sum / cnt as Real
        })
        .collect();
    let mut n = 0;
    for (a, &p) in idx.iter().enumerate() {
        if heavy[a] {
            parts.codim[p] = Codim::Point;
            n += 1;
        }
    }
    n
}

/// Rim collection: every non-fixed sheet particle closer than
/// `absorb_distance·h` to a filament particle is merged into the nearest one
/// (mass and momentum added, the rim particle keeps its position). This is
/// how a retracting rim gathers the film it sweeps (Taylor–Culick): without
/// it a light rim particle, pulled by the rim tension 2σl, overtakes the
/// sheet instead of collecting it.
///
/// Only free-film sheet particles are collected: one with a volume particle
/// within h is the surface layer of a liquid body (Appendix F). Absorbing it
/// opened a hole in the layer that the volume→sheet rule refilled from the
/// volume, so a rim lying on a liquid body pumped the body into itself
/// (the fluid polygon, `docs/decisions.md`).
///
/// With [`ReseedParams::rim_gap`] set, a filament particle that its sheet
/// neighbours surround ([`crate::transition::surrounded_by_sheet`]) collects
/// nothing: it lies inside a film, not on its edge. After a catenoid's pinch
/// such particles flipped 1→2 and back from one substep to the next, and
/// while filaments they merged the film around them into themselves (249,
/// then 1,562 sheet particles in frames 14 and 15 at Δx = 0.0058): the
/// hole that left ran back to the ring.
pub(super) fn absorb_into_rims(parts: &mut Particles, prm: &ReseedParams, volume: &[Vec3]) -> u64 {
    let on_volume = near_volume(parts, volume, prm.h);
    let inside = inside_film(parts, prm);
    absorb_nearest(
        parts,
        prm.absorb_distance * prm.h,
        |p, i| p.codim[i] == Codim::Filament && !inside[i],
        |p, i| p.codim[i] == Codim::Sheet && !p.fixed[i] && !on_volume[i],
    )
}

/// For every particle: a filament particle surrounded by its sheet
/// neighbours within h, with no gap wider than [`ReseedParams::rim_gap`]
/// (all false when the gap is 0).
fn inside_film(parts: &Particles, prm: &ReseedParams) -> Vec<bool> {
    let fil: Vec<usize> = (0..parts.len())
        .filter(|&i| parts.codim[i] == Codim::Filament)
        .collect();
    let mut inside = vec![false; parts.len()];
    if prm.rim_gap <= 0.0 || fil.is_empty() {
        return inside;
    }
    let grid = CellGrid::build(&parts.x, prm.h);
    let flags: Vec<bool> = fil
        .par_iter()
        .map(|&p| {
            let mut nbrs = Vec::new();
            grid.for_each_within(&parts.x, &parts.x[p], prm.h, |q, _| nbrs.push(q as u32));
            crate::transition::surrounded_by_sheet(
                p,
                prm.h,
                prm.rim_gap,
                &parts.x,
                &parts.codim,
                &nbrs,
            )
        })
        .collect();
    for (&p, f) in fil.iter().zip(flags) {
        inside[p] = f;
    }
    inside
}

/// For every non-volume particle of `parts`: is a volume particle of
/// `parts`, or a point of `volume`, within `r`?
pub(super) fn near_volume(parts: &Particles, volume: &[Vec3], r: Real) -> Vec<bool> {
    let vol: Vec<Vec3> = (0..parts.len())
        .filter(|&i| parts.codim[i] == Codim::Volume)
        .map(|i| parts.x[i])
        .chain(volume.iter().copied())
        .collect();
    if vol.is_empty() {
        return vec![false; parts.len()];
    }
    let grid = CellGrid::build(&vol, r);
    (0..parts.len())
        .into_par_iter()
        .map(|i| {
            if parts.codim[i] == Codim::Volume {
                return false;
            }
            grid.any_within(&vol, &parts.x[i], r)
        })
        .collect()
}

/// Merges every particle with `absorbed(i)` into the nearest particle with
/// `target(j)` closer than `r` (mass and momentum added; the target keeps its
/// position and radius, a fixed target its velocity). Returns the count.
pub(super) fn absorb_nearest(
    parts: &mut Particles,
    r: Real,
    target: impl Fn(&Particles, usize) -> bool,
    absorbed: impl Fn(&Particles, usize) -> bool,
) -> u64 {
    let tg: Vec<usize> = (0..parts.len()).filter(|&i| target(parts, i)).collect();
    if r <= 0.0 || tg.is_empty() {
        return 0;
    }
    let tx: Vec<Vec3> = tg.iter().map(|&i| parts.x[i]).collect();
    let grid = CellGrid::build(&tx, r);
    let mut alive = vec![true; parts.len()];
    let mut n = 0;
    for i in 0..parts.len() {
        if !absorbed(parts, i) {
            continue;
        }
        let mut best: Option<(Real, usize)> = None;
        grid.for_each_within(&tx, &parts.x[i], r, |b, d2| {
            if best.is_none_or(|(bd, bb)| d2 < bd || (d2 == bd && b < bb)) {
                best = Some((d2, b));
            }
        });
        if let Some((_, b)) = best {
            let q = tg[b];
            let rq = parts.radius[q];
            merge_into(parts, q, i);
            parts.radius[q] = rq; // a rim keeps its tube radius; it is recomputed from mass
            alive[i] = false;
            n += 1;
        }
    }
    parts.retain(&alive);
    n
}

/// Rim arrival at a boundary: every non-fixed filament particle closer than
/// `absorb_distance·h` to a fixed (ring) particle is merged into the nearest
/// one (mass added; the ring keeps its prescribed velocity, see
/// `merge_into`). After a catenoid pinches, the two half-films retract to
/// their rings as free rims; without this the rim particles piled up against
/// the ring, where no line-like filament fit exists, and filament reseeding
/// and the rim force fed on each other (speeds of 10³–10⁴ m/s within five
/// frames, coarse probe). Sheet particles next to a ring are the film's
/// attachment and are left alone.
pub(super) fn absorb_into_boundary(parts: &mut Particles, prm: &ReseedParams) -> u64 {
    absorb_nearest(
        parts,
        prm.absorb_distance * prm.h,
        |p, i| p.fixed[i],
        |p, i| p.codim[i] == Codim::Filament && !p.fixed[i],
    )
}
