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
//! volume particles do not join the two cells across it: with p and q the
//! nearest volume particles of the two cells, and space cut into sub-cells
//! about one particle spacing wide ([`sub_cells`]), no chain of occupied
//! sub-cells (26-neighbours) leads from p's to q's inside a tube of
//! [`TUBE`] sub-cells around the segment pq. Both cells of a separating face
//! become air, the same two cells that a rule by whole bodies (connected
//! components of the volume particles) would open. Inside the liquid the
//! straight line from p to q already runs through occupied sub-cells, and
//! the flood is skipped.
//!
//! Why local and not by bodies: two droplets that touch at one spot are one
//! body everywhere, and a rule by bodies then closes the whole gap between
//! them. In the droplet collision the cubes' rounded faces first came within
//! 1.8 mm (0.85 Δx) at four spots 6.7 mm off the axis, in frame 11; with
//! whole bodies the gap on the axis (volume particles 3 mm apart) became
//! liquid at once, the approach stopped within the frame (the facing sheet
//! layers' speed fell from 22 to −1 mm/s) and the two sheet layers stayed
//! 2.3–2.7 mm apart as an internal film for the rest of the run. A first
//! local version joined the two cells when a chain of occupied sub-cells
//! linked p and q anywhere within 2 Δx of the face: the bridge between the
//! cubes then joined the gap's cells within 2 Δx of its edge, and the gap
//! stayed open around a bridge of 9–10 mm radius to frame 100. The tube asks
//! whether the particles join *across* the face.

use super::projection::unit;
use super::MacGrid;
use crate::math::{Real, Vec3};
use crate::particles::{Codim, Particles};
use rayon::prelude::*;

/// Sub-cells per cell along an axis: about one volume particle per sub-cell
/// inside the liquid, from the mean number of volume particles per liquid
/// cell (`per_cell`), between 2 and 4 (sub-cells Δx/2 to Δx/4 wide: the
/// flood joins particles across a gap narrower than about one sub-cell).
pub fn sub_cells(per_cell: Real) -> usize {
    (per_cell.max(0.0).cbrt().floor() as usize).clamp(2, 4)
}

/// Half-width of the tube around the segment pq that a joining path of
/// sub-cells must stay in, in sub-cells (from a sub-cell's centre).
const TUBE: Real = 1.5;

/// The sub-cells that hold a volume particle, as a bit set over the
/// particles' bounding box (sub-cell coordinates are cells × `k`, from the
/// grid origin).
struct Occupancy {
    k: usize,
    lo: [i64; 3],
    n: [i64; 3],
    bits: Vec<u64>,
}

impl Occupancy {
    fn new(g: &MacGrid, parts: &Particles, k: usize) -> Occupancy {
        let scale = k as Real / g.dx;
        let key = |x: &Vec3| [0, 1, 2].map(|a| ((x[a] - g.origin[a]) * scale).floor() as i64);
        let keys: Vec<[i64; 3]> = parts
            .x
            .par_iter()
            .zip(parts.codim.par_iter())
            .filter(|(_, c)| **c == Codim::Volume)
            .map(|(x, _)| key(x))
            .collect();
        let mut lo = [i64::MAX; 3];
        let mut hi = [i64::MIN; 3];
        for q in &keys {
            for a in 0..3 {
                lo[a] = lo[a].min(q[a]);
                hi[a] = hi[a].max(q[a]);
            }
        }
        let n = [0, 1, 2].map(|a| (hi[a] - lo[a] + 1).max(0));
        let mut o = Occupancy {
            k,
            lo,
            n,
            bits: vec![0; ((n[0] * n[1] * n[2]) as usize).div_ceil(64)],
        };
        for q in &keys {
            let i = o.index(*q).expect("inside the bounding box");
            o.bits[i / 64] |= 1 << (i % 64);
        }
        o
    }

    fn index(&self, q: [i64; 3]) -> Option<usize> {
        let r = [0, 1, 2].map(|a| q[a] - self.lo[a]);
        (0..3)
            .all(|a| (0..self.n[a]).contains(&r[a]))
            .then(|| ((r[0] * self.n[1] + r[1]) * self.n[2] + r[2]) as usize)
    }

    fn occupied(&self, q: [i64; 3]) -> bool {
        self.index(q)
            .is_some_and(|i| self.bits[i / 64] >> (i % 64) & 1 == 1)
    }

    /// Sub-cell of a point given in cells from the grid origin.
    fn of(&self, x: Vec3) -> [i64; 3] {
        [0, 1, 2].map(|a| (x[a] * self.k as Real).floor() as i64)
    }
}

/// The liquid cells that a separating face borders (see the module doc).
/// `phi` is the level set (φ < 0 liquid), `near[s]` the offset of slot s's
/// nearest volume particle from its centre in cells (∞ when none).
pub fn separated_cells(g: &MacGrid, parts: &Particles, phi: &[Real], near: &[Vec3]) -> Vec<bool> {
    let liquid = |s: usize| g.in_domain(s) && phi[s] < 0.0 && near[s].iter().all(|v| v.is_finite());
    let cells = (0..g.slots())
        .into_par_iter()
        .filter(|&s| liquid(s))
        .count();
    if cells == 0 {
        return vec![false; g.slots()];
    }
    let volume = parts
        .codim
        .par_iter()
        .filter(|c| **c == Codim::Volume)
        .count();
    let occ = Occupancy::new(g, parts, sub_cells(volume as Real / cells as Real));
    let nearest = |s: usize| {
        let c = g.cell(s);
        Vec3::new(c[0] as Real, c[1] as Real, c[2] as Real) + Vec3::repeat(0.5) + near[s]
    };
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
                    *o = liquid(t) && !joined(&occ, nearest(s), nearest(t));
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

/// Are the particles at p and q (cells from the grid origin) joined by
/// occupied sub-cells (26-neighbours) within [`TUBE`] sub-cells of the
/// segment pq?
fn joined(occ: &Occupancy, p: Vec3, q: Vec3) -> bool {
    let (from, to) = (occ.of(p), occ.of(q));
    if (0..3).all(|a| from[a].abs_diff(to[a]) <= 1) {
        return true;
    }
    let k = occ.k as Real;
    let (ps, qs) = (p * k, q * k);
    let d = qs - ps;
    let len2 = d.norm_squared();
    // the straight line through occupied sub-cells: joined
    let steps = (len2.sqrt() * 2.0).ceil() as usize;
    if (0..=steps).all(|i| occ.occupied(occ.of((ps + d * (i as Real / steps as Real)) / k))) {
        return true;
    }
    let in_tube = |c: [i64; 3]| {
        let m = Vec3::new(c[0] as Real, c[1] as Real, c[2] as Real) + Vec3::repeat(0.5);
        let l = ((m - ps).dot(&d) / len2).clamp(0.0, 1.0);
        (m - ps - d * l).norm_squared() <= TUBE * TUBE
    };
    // flood inside the tube's bounding box
    let lo = [0, 1, 2].map(|a| from[a].min(to[a]) - 2);
    let n = [0, 1, 2].map(|a| from[a].max(to[a]) + 3 - lo[a]);
    let idx = |c: [i64; 3]| (((c[0] - lo[0]) * n[1] + c[1] - lo[1]) * n[2] + c[2] - lo[2]) as usize;
    let inside = |c: [i64; 3]| (0..3).all(|a| (lo[a]..lo[a] + n[a]).contains(&c[a]));
    let mut seen = vec![false; (n[0] * n[1] * n[2]) as usize];
    let mut stack = vec![from];
    seen[idx(from)] = true;
    while let Some(c) = stack.pop() {
        for o in 0..27i64 {
            let m = [c[0] + o / 9 - 1, c[1] + o / 3 % 3 - 1, c[2] + o % 3 - 1];
            if m == to {
                return true;
            }
            if inside(m) && !seen[idx(m)] && occ.occupied(m) && in_tube(m) {
                seen[idx(m)] = true;
                stack.push(m);
            }
        }
    }
    false
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two slabs of volume particles (spacing Δx/4) along x with their
    /// facing layers `gap` cells apart, joined by a bridge of the same
    /// lattice at |y − 2.5| < `bridge` cells when `bridge` > 0; returns the
    /// separated cells' x indices on the rows through the slabs' middle (y
    /// cell 9), beside the bridge (y cell 4, a cell from its edge) and
    /// through it (y cell 2), all at z cell 10.
    fn opened(gap: Real, bridge: Real) -> [Vec<isize>; 3] {
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
        let sep = separated_cells(&g, &parts, &phi, &near);
        let row = |j: isize| {
            (0..22)
                .filter(|&i| g.slot(i, j, 10).is_some_and(|s| sep[s]))
                .collect::<Vec<_>>()
        };
        [row(9), row(4), row(2)]
    }

    #[test]
    fn a_gap_opens_away_from_a_bridge_and_closes_at_it() {
        // volume layers 1.5 Δx apart (the collision's axis at frame 11):
        // the two cells between them open on every row
        let open = vec![7, 8];
        assert_eq!(opened(1.5, 0.0), [open.clone(), open.clone(), open.clone()]);
        // a bridge at y < 3.5 cells closes the gap through it and leaves it
        // open a cell beside it (a rule by whole bodies, or by a window of
        // 2 Δx around the face, closes all three rows)
        let [mid, beside, at] = opened(1.5, 1.0);
        assert_eq!(mid, open, "row through the middle");
        assert_eq!(beside, open, "row a cell beside the bridge");
        assert!(at.is_empty(), "row through the bridge: {at:?}");
        // one body without a gap opens nothing
        assert!(opened(0.0, 0.0).iter().all(|r| r.is_empty()));
    }

    #[test]
    fn no_liquid_opens_nothing() {
        let mut parts = Particles::default();
        parts.push(Vec3::repeat(0.5), Vec3::zeros(), 1.0, 0.1, Codim::Sheet);
        let mut g = MacGrid::new(Vec3::zeros(), Vec3::repeat(1.0), 0.1);
        g.activate(&parts.x, 2);
        let n = g.slots();
        let near = vec![Vec3::repeat(Real::INFINITY); n];
        let sep = separated_cells(&g, &parts, &vec![0.1; n], &near);
        assert_eq!(sep.len(), n);
        assert!(sep.iter().all(|s| !s));
    }
}
