//! Liquid bodies kept apart on the grid until their particles meet
//! (`solver.separate_bodies`; a grid-side aid to §8's merging, not in the
//! paper).
//!
//! The level set reaches `surface_radius` Δx past the outermost volume
//! particles, so two surfaces closer than about 2 Δx share liquid cells, and
//! the projection keeps the particle-free liquid between them incompressible:
//! approaching droplets stop before they touch (docs/decisions.md,
//! "Approaching surfaces repel on the grid").
//!
//! The rule is local. A face between two liquid cells *separates* when the
//! volume particles do not join the two cells near it: with p and q the
//! nearest volume particles of the two cells, and the window of 4 Δx around
//! the face centre cut into sub-cells about one particle spacing wide
//! ([`sub_cells`]), p's sub-cell does not reach q's through occupied
//! sub-cells (26-neighbours) inside the window. Both
//! cells of a separating face become air, the same two cells that a rule by
//! whole bodies (connected components of the volume particles) would open.
//! The search is skipped (the face joins) when p and q lie in touching
//! sub-cells, or a particle of the two cells lies within a sub-cell width of
//! the face centre: inside the liquid, or across a gap narrower than two
//! sub-cells, where the particles are about to meet anyway.
//!
//! Why local and not by bodies: two droplets that touch at one spot are one
//! body everywhere, and a rule by bodies then closes the whole gap between
//! them. In the droplet collision the cubes' rounded faces first came within
//! 1.8 mm (0.85 Δx) at four spots 6.7 mm off the axis, in frame 11; with
//! whole bodies the gap on the axis (volume particles 3 mm apart) became
//! liquid at once, the approach stopped within the frame (the facing sheet
//! layers' speed fell from 22 to −1 mm/s) and the two sheet layers stayed
//! 2.3–2.7 mm apart as an internal film for the rest of the run.

use super::projection::unit;
use super::transfer::CellSort;
use super::MacGrid;
use crate::math::{Real, Vec3};
use crate::particles::Particles;
use rayon::prelude::*;

/// Window half-width in cells.
const HALF: isize = 2;

/// Sub-cells per cell along an axis: about one volume particle per sub-cell
/// inside the liquid, from the mean number of volume particles per liquid
/// cell (`per_cell`), between 2 (Δx/2, the width of a gap that stays
/// joined at most) and 4.
pub fn sub_cells(per_cell: Real) -> usize {
    (per_cell.max(0.0).cbrt().floor() as usize).clamp(2, 4)
}

/// The liquid cells that a separating face borders (see the module doc).
/// `phi` is the level set (φ < 0 liquid), `near[s]` the offset of slot s's
/// nearest volume particle from its centre in cells (∞ when none).
pub fn separated_cells(
    g: &MacGrid,
    sort: &CellSort,
    parts: &Particles,
    phi: &[Real],
    near: &[Vec3],
) -> Vec<bool> {
    let liquid = |s: usize| g.in_domain(s) && phi[s] < 0.0;
    let cells = (0..g.slots())
        .into_par_iter()
        .filter(|&s| liquid(s))
        .count();
    let sub = sub_cells(sort.order.len() as Real / cells.max(1) as Real);
    // per slot: does the face towards its +a neighbour separate
    let face: Vec<[bool; 3]> = (0..g.slots())
        .into_par_iter()
        .map(|s| {
            let mut out = [false; 3];
            if !liquid(s) {
                return out;
            }
            for (a, o) in out.iter_mut().enumerate() {
                if let Some(t) = g.neighbor(s, unit(a, 1)) {
                    *o = liquid(t) && separates(g, sort, parts, s, t, a, near, sub);
                }
            }
            out
        })
        .collect();
    (0..g.slots())
        .into_par_iter()
        .map(|s| {
            (0..3).any(|a| face[s][a] || g.neighbor(s, unit(a, -1)).is_some_and(|t| face[t][a]))
        })
        .collect()
}

/// Does the face between slot s and its +a neighbour t separate?
fn separates(
    g: &MacGrid,
    sort: &CellSort,
    parts: &Particles,
    s: usize,
    t: usize,
    a: usize,
    near: &[Vec3],
    sub: usize,
) -> bool {
    let inv_dx = 1.0 / g.dx;
    // sub-cells along an axis of the window
    let w = 2 * HALF as usize * sub;
    let c = g.cell(s);
    // window origin (cells): the face centre minus HALF along every axis
    let mut w0 = [0.0 as Real; 3];
    for b in 0..3 {
        w0[b] = c[b] as Real + if b == a { 1.0 } else { 0.5 } - HALF as Real;
    }
    let sub_of = |x: Vec3| -> Option<[usize; 3]> {
        let mut k = [0usize; 3];
        for b in 0..3 {
            let v = ((x[b] - w0[b]) * sub as Real).floor();
            if !(0.0..w as Real).contains(&v) {
                return None;
            }
            k[b] = v as usize;
        }
        Some(k)
    };
    let cells = |x: &Vec3| (x - g.origin) * inv_dx;
    let centre_of = |u: usize| {
        let cu = g.cell(u);
        Vec3::new(cu[0] as Real, cu[1] as Real, cu[2] as Real) + Vec3::repeat(0.5)
    };
    let (Some(from), Some(to)) = (
        sub_of(centre_of(s) + near[s]),
        sub_of(centre_of(t) + near[t]),
    ) else {
        // a nearest particle outside the window: keep the cells liquid
        return false;
    };
    // the two nearest particles in touching sub-cells: joined
    if (0..3).all(|b| from[b].abs_diff(to[b]) <= 1) {
        return false;
    }
    // a particle within a sub-cell of the face centre: inside the liquid,
    // or a gap narrower than two sub-cells, which joins anyway
    let f = Vec3::from(w0).add_scalar(HALF as Real);
    let r2 = (1.0 / sub as Real).powi(2);
    if sort
        .in_slot(s)
        .iter()
        .chain(sort.in_slot(t))
        .any(|&p| (cells(&parts.x[p as usize]) - f).norm_squared() < r2)
    {
        return false;
    }
    // occupancy of the window's sub-cells
    let idx = |k: [usize; 3]| (k[0] * w + k[1]) * w + k[2];
    let mut occupied = vec![false; w * w * w];
    for dz in -HALF..=HALF {
        for dy in -HALF..=HALF {
            for dxi in -HALF..=HALF {
                let Some(u) = g.slot(c[0] + dxi, c[1] + dy, c[2] + dz) else {
                    continue;
                };
                for &p in sort.in_slot(u) {
                    if let Some(k) = sub_of(cells(&parts.x[p as usize])) {
                        occupied[idx(k)] = true;
                    }
                }
            }
        }
    }
    // flood from p's sub-cell
    let mut seen = vec![false; w * w * w];
    let mut stack = vec![from];
    seen[idx(from)] = true;
    while let Some(k) = stack.pop() {
        if k == to {
            return false;
        }
        for d in 0..27usize {
            let o = [d / 9, d / 3 % 3, d % 3];
            let mut n = [0usize; 3];
            let mut inside = true;
            for b in 0..3 {
                let v = k[b] + o[b];
                if v == 0 || v > w {
                    inside = false;
                    break;
                }
                n[b] = v - 1;
            }
            if inside && occupied[idx(n)] && !seen[idx(n)] {
                seen[idx(n)] = true;
                stack.push(n);
            }
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::particles::Codim;

    /// Two slabs of volume particles (spacing Δx/4) along x with their
    /// facing layers `gap` cells apart, joined by a bridge of the same
    /// lattice at |y − 2.5| < `bridge` cells when `bridge` > 0; returns the
    /// separated cells' x indices on the row through the slabs' middle (y
    /// cell 9) and through the bridge (y cell 2), both at z cell 10.
    fn opened(gap: Real, bridge: Real) -> (Vec<isize>, Vec<isize>) {
        let dx = 0.1;
        let mut parts = Particles::default();
        let n = |len: Real| (len * 4.0).round() as usize;
        for i in 0..=n(6.0 + gap) {
            let x = 4.0 + 0.25 * i as Real;
            for j in 0..=n(12.0) {
                let y = 1.0 + 0.25 * j as Real;
                for k in 0..=n(7.0) {
                    let z = 7.0 + 0.25 * k as Real;
                    let in_gap = x > 7.0 + 1e-9 && x < 7.0 + gap - 1e-9;
                    if !in_gap || (bridge > 0.0 && (y - 2.5).abs() < bridge) {
                        let p = Vec3::new(x, y, z) * dx;
                        parts.push(p, Vec3::zeros(), 1.0, 0.1, Codim::Volume);
                    }
                }
            }
        }
        let mut g = MacGrid::new(Vec3::zeros(), Vec3::repeat(2.2), dx);
        g.activate(&parts.x, 2);
        let sort = super::super::transfer::sort_particles(&g, &parts);
        // φ = distance to the nearest particle − Δx, over the 27 cells around
        let (mut phi, mut near) = (
            vec![dx; g.slots()],
            vec![Vec3::repeat(Real::INFINITY); g.slots()],
        );
        for s in (0..g.slots()).filter(|&s| g.in_domain(s)) {
            let (c, o) = (g.cell(s), g.cell_pos(s));
            for d in 0..27isize {
                let Some(u) = g.slot(c[0] + d / 9 - 1, c[1] + d / 3 % 3 - 1, c[2] + d % 3 - 1)
                else {
                    continue;
                };
                for &p in sort.in_slot(u) {
                    let e = (parts.x[p as usize] - o) / dx;
                    if e.norm() < near[s].norm() {
                        near[s] = e;
                        phi[s] = (e.norm() - 1.0) * dx;
                    }
                }
            }
        }
        let sep = separated_cells(&g, &sort, &parts, &phi, &near);
        let row = |j: isize| {
            (0..22)
                .filter(|&i| g.slot(i, j, 10).is_some_and(|s| sep[s]))
                .collect::<Vec<_>>()
        };
        (row(9), row(2))
    }

    #[test]
    fn a_gap_opens_away_from_a_bridge_and_closes_at_it() {
        // volume layers 1.5 Δx apart (the collision's axis at frame 11):
        // the two cells between them open
        let (mid, at) = opened(1.5, 0.0);
        assert_eq!(mid, vec![7, 8], "row through the middle");
        assert_eq!(at, vec![7, 8]);
        // a bridge 8 cells away leaves the middle open and closes the gap at it
        let (mid, at) = opened(1.5, 1.0);
        assert_eq!(mid, vec![7, 8], "row through the middle, bridged far away");
        assert!(at.is_empty(), "at the bridge: {at:?}");
        // one body without a gap opens nothing
        let (mid, at) = opened(0.0, 0.0);
        assert!(mid.is_empty() && at.is_empty(), "{mid:?} {at:?}");
    }
}
