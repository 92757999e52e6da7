//! Releasing constraint faces whose impulses eq. (24) cannot determine.
//!
//! A liquid cell c whose every open face is a constraint face carries a
//! mode z = (q_c = 1, μ_f = −s_{c,f} on its faces) that leaves every cell
//! and face row of eq. (24) unchanged (§7: the face rows hold the face
//! velocity to J u whatever the pressure is, and the impulses take up any
//! pressure). Only the particle rows see it, through −Σ_f J_{f,i} w_f
//! s_{c,f}, and a sheet particle near the cell's centre, with equal weights
//! on opposite faces, does not pin it. Two rules release such faces, which
//! then become plain Poisson faces (to a liquid or a ghost-fluid air cell):
//!
//! - before the solve, [`Constraints::release_enclosed`]: cells whose mode
//!   the particles do not pin (‖A z‖² < [`MIN_PIN`]);
//! - after a solve, [`outlier_cells`] and [`Constraints::release_around`]:
//!   where two surface layers face each other across a gap narrower than a
//!   cell (liquid folding onto itself: the polygon's thick rim at frame 83),
//!   several such cells share their faces, and the modes they combine into
//!   are pinned only weakly (‖A z‖² of single cells 0.04–1.4 there). The
//!   solve then returns pressures of ±90 m/s (q units) next to each other,
//!   which launch particles at ~100 m/s. The enclosed cells around every
//!   cell whose velocity jump is far beyond the substep's physical scales
//!   ([`outlier_bound`]) lose their constraint faces and the solve is redone.

use super::faces::Constraints;
use crate::grid::extrapolate::is_wall_face;
use crate::grid::projection::Poisson;
use crate::grid::{MacGrid, NONE};
use crate::math::{Real, Vec3};
use rayon::prelude::*;

/// Smallest pinning ‖A z‖² of an enclosed cell's null mode before its
/// constraint faces are released ([`Constraints::release_enclosed`]).
pub const MIN_PIN: Real = 1e-2;

/// Pin below which [`Constraints::release_weak`] releases a cell's
/// constraint faces after a failed solve: the single-cell pins of the
/// weakly pinned combined modes were 0.04–1.4 at the polygon's frame 83,
/// those of surface layers ≥ 0.069 in the droplet tests.
pub const WEAK_PIN: Real = 2.0;

/// A velocity jump across a face larger than this multiple of the
/// substep's velocity scale marks an outlier ([`outlier_bound`]).
pub const OUTLIER_FACTOR: Real = 10.0;

/// Largest curvature of a tension row, as in
/// [`super::surface::MAX_CURVATURE_H`] (κ h ≤ 8 per principal direction).
const CAPILLARY_KH: Real = 2.0 * super::surface::MAX_CURVATURE_H;

impl Constraints {
    /// The constraint faces of cell slot `c` and ‖A z‖² over the particle
    /// rows of its null mode z = (q_c = 1, μ_f = −s_{c,f}), if every open
    /// face of `c` is a constraint (or prescribed) face, whichever its
    /// neighbours are (liquid or air: a constraint face to an air cell
    /// carries the mode as well); `None` otherwise (an open face without
    /// constraint pins the mode through the cell row).
    pub fn null_mode(&self, g: &MacGrid, c: usize) -> Option<(Vec<usize>, Real)> {
        let mut faces = Vec::with_capacity(6);
        for a in 0..3 {
            for k in [0isize, 1] {
                let mut o = [0isize; 3];
                o[a] = 2 * k - 1;
                let nb = g.neighbor(c, o)?;
                // the face between c and nb is the lower face of the upper cell
                let f = if k == 0 { c } else { nb };
                if g.weight[a][f] <= 0.0 || is_wall_face(g, f, a) || g.is_prescribed(a, f) {
                    continue;
                }
                faces.push(self.index(a, f)?);
            }
        }
        // (A z) by particle row: the terms of each (particle, axis) summed
        // in face order (a stable sort keeps it), the squares in row order
        let mut terms: Vec<((u32, usize), Real)> = Vec::with_capacity(64);
        for &i in &faces {
            let (a, f) = self.faces[i];
            let s_cf = if f == c { -1.0 } else { 1.0 };
            for k in self.ptr[i]..self.ptr[i + 1] {
                terms.push(((self.col[k], a), self.val[k] * self.weight[i] * s_cf));
            }
        }
        terms.sort_by_key(|e| e.0);
        let mut pin = 0.0;
        let mut k = 0;
        while k < terms.len() {
            let mut v = 0.0;
            let key = terms[k].0;
            while k < terms.len() && terms[k].0 == key {
                v += terms[k].1;
                k += 1;
            }
            pin += v * v;
        }
        Some((faces, pin))
    }

    /// Releases the constraint faces of every liquid cell that holds a sheet
    /// particle (`x`: the sheet particles) and whose null mode the particles
    /// do not pin ([`Constraints::null_mode`] with ‖A z‖² < [`MIN_PIN`]). A
    /// surface layer's particles sit on one side of the cell and pin the
    /// mode (‖A z‖² ≥ 0.084 in the resting-droplet and l = 2 tests, ≥ 0.069
    /// in the droplet collision); a sheet particle trapped inside the liquid
    /// near the cell's centre does not (‖A z‖² = 0): BiCGSTAB then stagnates
    /// (the droplet collision at frame 93 stopped at a relative residual
    /// 9.5e-3, with q = 49 in that cell; the polygon at frame 83 at 8e-4,
    /// with q = ±3e9 in a cell beside air). Returns the number of faces
    /// released.
    pub fn release_enclosed(&mut self, g: &MacGrid, sys: &Poisson, x: &[Vec3]) -> usize {
        let mut holds_sheet = vec![false; g.slots()];
        for p in x {
            let c = g.cell_of(p);
            if let Some(s) = g.slot(c[0], c[1], c[2]) {
                holds_sheet[s] = true;
            }
        }
        let cells: Vec<usize> = sys
            .cells
            .iter()
            .copied()
            .filter(|&c| holds_sheet[c])
            .collect();
        self.release_below(g, &cells, MIN_PIN)
    }

    /// Releases the constraint faces of every liquid cell whose null mode
    /// the particles pin by less than [`WEAK_PIN`] (‖A z‖² from
    /// [`Constraints::null_mode`]), whether or not it holds a sheet particle.
    /// The fallback of a solve that failed with both methods: weakly pinned
    /// cells combine into modes that BiCGSTAB cannot resolve (the fluid
    /// polygon with staggered jets at frame 7 stagnated at 1e-5 with every
    /// Δt). Returns the number released.
    pub fn release_weak(&mut self, g: &MacGrid, sys: &Poisson) -> usize {
        self.release_below(g, &sys.cells, WEAK_PIN)
    }

    /// Releases the faces of each of `cells` whose null mode is pinned by
    /// less than `bound` (the cells tested in parallel); returns how many.
    fn release_below(&mut self, g: &MacGrid, cells: &[usize], bound: Real) -> usize {
        let loose: Vec<Vec<usize>> = cells
            .par_iter()
            .with_min_len(64)
            .filter_map(|&c| self.null_mode(g, c).filter(|m| m.1 < bound).map(|m| m.0))
            .collect();
        let mut drop = vec![false; self.len()];
        for i in loose.into_iter().flatten() {
            drop[i] = true;
        }
        self.drop_faces(&drop)
    }

    /// Releases the constraint faces of every liquid cell within one cell
    /// (26-neighbourhood) of the given cell slots whose every open face is
    /// a constraint face, whatever its pin. Returns the number released.
    pub fn release_around(&mut self, g: &MacGrid, sys: &Poisson, slots: &[usize]) -> usize {
        let mut drop = vec![false; self.len()];
        for &s in slots {
            for o in (0..27isize).map(|k| [k % 3 - 1, (k / 3) % 3 - 1, k / 9 - 1]) {
                let Some(c) = g.neighbor(s, o).filter(|&c| sys.unknown(c).is_some()) else {
                    continue;
                };
                if let Some((faces, _)) = self.null_mode(g, c) {
                    for i in faces {
                        drop[i] = true;
                    }
                }
            }
        }
        self.drop_faces(&drop)
    }

    /// Removes the faces marked in `drop`; returns how many.
    fn drop_faces(&mut self, drop: &[bool]) -> usize {
        let released = drop.iter().filter(|&&d| d).count();
        if released == 0 {
            return 0;
        }
        let old = std::mem::take(self);
        let ns = old.of_face[0].len();
        *self = Constraints {
            ptr: vec![0],
            of_face: [vec![NONE; ns], vec![NONE; ns], vec![NONE; ns]],
            floor: old.floor,
            ..Default::default()
        };
        for f in (0..old.len()).filter(|&f| !drop[f]) {
            let (a, s) = old.faces[f];
            self.of_face[a][s] = self.faces.len() as u32;
            self.faces.push((a, s));
            self.sides.push(old.sides[f]);
            self.weight.push(old.weight[f]);
            self.mass.push(old.mass[f]);
            for k in old.ptr[f]..old.ptr[f + 1] {
                self.col.push(old.col[k]);
                self.val.push(old.val[k]);
            }
            self.ptr.push(self.col.len());
        }
        released
    }
}

/// The largest velocity jump across a face (m/s) that a substep of length
/// `dt` can make physically, times [`OUTLIER_FACTOR`]: the largest speed
/// `v_ref` before the solve (particles and the faces' v**, which hold the
/// body forces) plus the capillary speed √(σ κ_max / ρ) of the largest
/// curvature a tension row allows, κ_max = 16/Δx (two principal curvatures
/// of 8/h).
pub fn outlier_bound(v_ref: Real, sigma: Real, density: Real, dx: Real) -> Real {
    OUTLIER_FACTOR * (v_ref + (sigma * CAPILLARY_KH / (density * dx)).sqrt())
}

/// Slots of the liquid cells across one of whose faces the scaled pressure
/// q jumps by more than `bound` (to 0 across a face to air), as the
/// velocity change it makes there, plus the cells of the particles whose
/// solved velocity `u` exceeds it (`x`: their positions).
///
/// `gain(axis, face, cell, other)` is the velocity change per unit jump of
/// q across the face (`face`: its slot, `None` at the domain's edge;
/// `cell`: the liquid cell's slot; `other`: whether the far side is an
/// unknown too): 1 for the ghost-fluid system ([`uniform_gain`]); the cut
/// layer's faces move by their mobility times the jump, and a face the
/// sheet closes not at all ([`super::cut::Cut::velocity_gain`]).
pub fn outlier_cells(
    g: &MacGrid,
    sys: &Poisson,
    q: &[Real],
    x: &[Vec3],
    u: &[Vec3],
    bound: Real,
    gain: impl Fn(usize, Option<usize>, usize, bool) -> Real,
) -> Vec<usize> {
    let mut out = Vec::new();
    for (i, &c) in sys.cells.iter().enumerate() {
        let bad = (0..6).any(|k| {
            let (a, up) = (k / 2, k % 2 == 1);
            let mut o = [0isize; 3];
            o[a] = if up { 1 } else { -1 };
            let n = g.neighbor(c, o);
            let other = n.and_then(|n| sys.unknown(n));
            let qn = other.map_or(0.0, |n| q[n as usize]);
            let face = if up { n } else { Some(c) };
            gain(a, face, c, other.is_some()) * (q[i] - qn).abs() > bound
        });
        if bad {
            out.push(c);
        }
    }
    for (p, v) in x.iter().zip(u) {
        if v.norm() > bound {
            let c = g.cell_of(p);
            if let Some(s) = g.slot(c[0], c[1], c[2]) {
                out.push(s);
            }
        }
    }
    out.sort_unstable();
    out.dedup();
    out
}

/// The `gain` of [`outlier_cells`] for the ghost-fluid system: q itself.
pub fn uniform_gain(_: usize, _: Option<usize>, _: usize, _: bool) -> Real {
    1.0
}

#[cfg(test)]
pub(crate) mod tests {
    use super::super::faces::constraints;
    use super::*;
    use crate::grid::transfer::{transfer_to_grid, P2gSettings};
    use crate::particles::{Codim, Particles};
    use crate::solids::SolidSet;

    /// The grid and pressure system of a block of liquid at rest (volume
    /// particles spaced Δx/3 over [0.2, 1.167]³, Δx = 0.1; also used by
    /// `jump`'s tests).
    pub(crate) fn block() -> (MacGrid, Poisson) {
        let dx = 0.1;
        let mut p = Particles::default();
        for i in 0..30 {
            for j in 0..30 {
                for k in 0..30 {
                    let x =
                        Vec3::new(i as Real, j as Real, k as Real) * (dx / 3.0) + Vec3::repeat(0.2);
                    p.push(x, Vec3::zeros(), 1.0, 0.01, Codim::Volume);
                }
            }
        }
        let mut g = MacGrid::new(Vec3::zeros(), Vec3::repeat(1.4), dx);
        let set = P2gSettings::plain(1.0);
        transfer_to_grid(&mut g, &p, &SolidSet::default(), &set, None);
        let sys = Poisson::build(&g, &SolidSet::default(), |_, _| false);
        (g, sys)
    }

    /// The block with sheet particles at `at`: its constraint faces, and
    /// those [`Constraints::release_enclosed`] releases.
    fn released(at: &[Vec3]) -> (usize, usize) {
        let (g, sys) = block();
        let mut k = constraints(&g, &sys, at);
        let before = k.len();
        (before, k.release_enclosed(&g, &sys, at))
    }

    #[test]
    fn outliers_are_found_and_the_enclosed_cells_around_them_released() {
        let (g, sys) = block();
        let slot = |c: [isize; 3]| g.slot(c[0], c[1], c[2]).unwrap();
        // the polygon's bound: v_ref 1.05 m/s, σ 0.05, Δx = 1/480
        let b = outlier_bound(1.05, 0.05, 1000.0, 1.0 / 480.0);
        assert!((b - 10.0 * (1.05 + (0.05 * 16.0 * 480.0 / 1000.0 as Real).sqrt())).abs() < 1e-12);
        assert!(b > 16.0 && b < 17.0, "{b}");
        // hydrostatic-like smooth q (jumps of 0.5 m/s per cell) is no outlier
        let q: Vec<Real> = sys
            .cells
            .iter()
            .map(|&c| 0.5 * g.cell_pos(c)[1] / g.dx)
            .collect();
        let smooth = outlier_cells(&g, &sys, &q, &[], &[], 10.0, uniform_gain);
        assert!(smooth.is_empty(), "{smooth:?}");
        let q0 = vec![0.0; sys.cells.len()];
        // a spike of 50 in one cell marks it and its six neighbours
        let mut q = q0.clone();
        let c = slot([6, 6, 6]);
        q[sys.unknown(c).unwrap() as usize] = 50.0;
        let bad = outlier_cells(&g, &sys, &q, &[], &[], 10.0, uniform_gain);
        assert_eq!(bad.len(), 7, "{bad:?}");
        assert!(bad.contains(&c));
        // the same jump across faces that move a tenth of it (the cut
        // layer's heavy faces) is none; a face that does not move (closed
        // by the sheet) spares the neighbour behind it
        let light = outlier_cells(&g, &sys, &q, &[], &[], 10.0, |_, _, _, _| 0.1);
        assert!(light.is_empty(), "{light:?}");
        let up = slot([7, 6, 6]);
        let closed = |a: usize, f: Option<usize>, _: usize, _: bool| {
            if a == 0 && f == Some(up) {
                0.0
            } else {
                1.0
            }
        };
        let bad = outlier_cells(&g, &sys, &q, &[], &[], 10.0, closed);
        assert_eq!(bad.len(), 6, "{bad:?}");
        assert!(bad.contains(&c) && !bad.contains(&up));
        // a particle faster than the bound marks its cell
        let x = [Vec3::new(0.45, 0.55, 0.65)];
        let bad = outlier_cells(
            &g,
            &sys,
            &q0,
            &x,
            &[Vec3::new(0.0, 12.0, 0.0)],
            10.0,
            uniform_gain,
        );
        assert_eq!(bad, vec![slot([4, 5, 6])]);
        // sheet particles a third of a cell off the centres of a 3×3×3 group
        // of cells: each cell is enclosed by constraint faces and pinned
        // (release_enclosed keeps them); release_around frees the group
        let mut at = Vec::new();
        for i in 5..8 {
            for j in 5..8 {
                for k in 5..8 {
                    at.push(Vec3::new(i as Real + 0.5, j as Real + 0.8, k as Real + 0.5) * g.dx);
                }
            }
        }
        let mut kc = constraints(&g, &sys, &at);
        assert_eq!(kc.clone().release_enclosed(&g, &sys, &at), 0);
        let before = kc.len();
        let n = kc.release_around(&g, &sys, &[c]);
        assert!(n > 0 && kc.len() == before - n, "{n} of {before}");
        assert!(
            kc.null_mode(&g, c).is_none(),
            "the outlier cell keeps no enclosed mode"
        );
    }

    #[test]
    fn a_sheet_particle_trapped_at_a_cell_centre_releases_its_faces() {
        // the centre of cell (6, 6, 6), deep in the block: every face row of
        // J holds this particle alone, so opposite faces cancel (‖A z‖ = 0)
        let (n, r) = released(&[Vec3::repeat(0.65)]);
        assert_eq!((n, r), (6, 6));
        // two particles 0.1 Δx inside the cell's lower x face and the next
        // cell's: the face rows mix them with different weights, which pins
        // both cells' modes (‖A z‖² = 1.62 and 0.02)
        let (n, r) = released(&[Vec3::new(0.61, 0.65, 0.65), Vec3::new(0.71, 0.65, 0.65)]);
        assert!(n >= 7, "{n} constraint faces");
        assert_eq!(r, 0);
        // the centre of the surface cell (12, 6, 6), whose +x neighbour is
        // air: the face to the air cell is a constraint face too, and the
        // mode is the same (the polygon's frame 83 stalled on such a cell)
        let (n, r) = released(&[Vec3::new(1.25, 0.65, 0.65)]);
        assert_eq!((n, r), (6, 6));
    }

    #[test]
    fn after_a_failed_solve_weakly_pinned_cells_are_released() {
        // the two particles of the test above pin their cells by 1.62 and
        // 0.02: release_enclosed keeps both, release_weak frees both, and no
        // cell with a pin below WEAK_PIN is left
        let (g, sys) = block();
        let at = [Vec3::new(0.61, 0.65, 0.65), Vec3::new(0.71, 0.65, 0.65)];
        let mut k = constraints(&g, &sys, &at);
        let pins: Vec<Real> = sys
            .cells
            .iter()
            .filter_map(|&c| k.null_mode(&g, c).map(|m| m.1))
            .collect();
        assert_eq!(pins.len(), 2, "{pins:?}");
        assert!(
            pins.iter().all(|&p| p > MIN_PIN && p < WEAK_PIN),
            "{pins:?}"
        );
        let before = k.len();
        assert_eq!(k.clone().release_enclosed(&g, &sys, &at), 0);
        let n = k.release_weak(&g, &sys);
        assert!(n > 0 && k.len() == before - n, "{n} of {before}");
        assert!(sys
            .cells
            .iter()
            .all(|&c| k.null_mode(&g, c).is_none_or(|m| m.1 >= WEAK_PIN)));
    }
}
