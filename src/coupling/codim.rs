//! Codimension update of a liquid scene (paper §8, Algorithm 1 line 2):
//! the four rules of [`crate::transition`] applied to the volume, sheet and
//! filament particles together.
//!
//! - Frames: a volume particle takes the weighted-PCA frame (eqs. 25–29) of
//!   all its neighbours within h, so at the liquid's surface b³ is the
//!   normal (a half ball is thinnest across its flat side); a sheet
//!   particle the frame of its sheet neighbours; a filament particle that of
//!   its filament neighbours.
//! - 0→1: a volume particle whose π/3 cones along ±b³ hold volume/sheet
//!   particles on one side only is exposed and joins the surface layer (or
//!   the volume is thinner than the thin distance across it).
//! - 1→0: a sheet particle with volume particles in both π/4 cones has been
//!   engulfed.
//! - 1→2 applies to free sheets only (in [`new_codim`]): a sheet particle
//!   with a volume particle within h is part of a liquid surface, whose end
//!   at a nozzle or a wall is not a thin sheet's rim (the rule would
//!   otherwise turn the upstream edge of every jet's surface layer into
//!   filaments).
//! - 2→3: a filament particle without filament neighbours is a droplet.
//! - 2→0 and 2→1 (not in the paper, see [`new_codim`]): a filament particle
//!   engulfed by the volume returns to it; one with a volume particle within
//!   h joins the body's surface layer.
//!
//! Masses do not change (a particle keeps its mass through a transition),
//! so mass is conserved exactly. A particle that joins the volume (1→0,
//! 2→0) takes the mass-weighted mean velocity of its volume neighbours.

use crate::math::{Mat3, Real, Vec3};
use crate::mls::frame::pca_frame;
use crate::neighbors::CellGrid;
use crate::particles::{Codim, Particles};
use crate::solids::SolidSet;
use crate::transition::{new_codim, TransitionCounts, TransitionParams};
use rayon::prelude::*;

/// A liquid source (a jet's nozzle): the liquid at its emission plane is
/// connected to the reservoir behind it, so particles within `depth` of
/// the plane and inside the jet's radius (plus h) keep their codimension —
/// the newest layer is never "exposed" at its back.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Source {
    /// A point of the emission plane on the jet axis (m).
    pub origin: Vec3,
    /// Unit jet direction.
    pub direction: Vec3,
    /// Jet radius (m).
    pub radius: Real,
    /// Depth of the protected region downstream of the plane (m).
    pub depth: Real,
}

impl Source {
    /// True when `x` lies in the protected region.
    pub fn protects(&self, x: &Vec3, h: Real) -> bool {
        let d = x - self.origin;
        let a = d.dot(&self.direction);
        a > -h && a < self.depth && (d - self.direction * a).norm() < self.radius + h
    }
}

/// Applies the transition rules to every non-fixed particle of `parts`
/// outside the source regions. A volume particle within h of a solid keeps
/// its codimension: its empty cone faces the wall, not air (a droplet
/// spreading on a plane would otherwise turn its wetted face into sheet
/// particles).
///
/// The particles are visited cell by cell (cells of size h). A volume
/// particle that is [`surrounded`] keeps its codimension without its
/// neighbour list, frame or cone census being built: the result is the
/// one the full test gives, bit for bit (tested), and deep inside a body
/// most volume particles are.
pub fn update(
    parts: &mut Particles,
    prm: &TransitionParams,
    sources: &[Source],
    solids: &SolidSet,
) -> TransitionCounts {
    let h = prm.h;
    let x = &parts.x;
    let codim = &parts.codim;
    let grid = CellGrid::build(x, h);
    let h2 = h * h;
    // per cell: the particles that change, with the velocity of those that
    // join a body (a sheet or filament particle that joins takes the body's
    // local velocity, a PIC reset: FLIP would keep its own velocity, less
    // 5 % per substep, and a light rim particle engulfed at 60 m/s held the
    // CFL substep at 3e-5 s for 40 substeps in the fluid polygon)
    let changes: Vec<Vec<(u32, Codim, Option<Vec3>)>> = grid
        .cells()
        .par_iter()
        .map_init(
            || (Block::default(), Vec::new()),
            |(block, row), c| {
                block.gather(&grid, c, x, codim);
                let mut out = Vec::new();
                for &p in grid.members(c) {
                    let p = p as usize;
                    if held(p, parts, sources, solids, h) {
                        continue;
                    }
                    if codim[p] == Codim::Volume
                        && surrounded(p, &x[p], block, h, prm.thin_distance)
                    {
                        continue;
                    }
                    // the neighbours within h, ascending (as `neighbor_lists`)
                    row.clear();
                    let xp = x[p];
                    row.extend(
                        block
                            .id
                            .iter()
                            .zip(&block.x)
                            .filter(|(&q, xq)| q as usize != p && (*xq - xp).norm_squared() < h2)
                            .map(|(&q, _)| q),
                    );
                    let next = by_the_rules(p, parts, row, prm);
                    if next == codim[p] {
                        continue;
                    }
                    let v = (next == Codim::Volume)
                        .then(|| joined_velocity(p, parts, row, h))
                        .flatten();
                    out.push((p as u32, next, v));
                }
                out
            },
        )
        .collect();
    let mut next = codim.clone();
    for (p, c, v) in changes.into_iter().flatten() {
        next[p as usize] = c;
        if let Some(v) = v {
            parts.v[p as usize] = v;
        }
    }
    TransitionCounts::apply(&mut parts.codim, next)
}

/// True when particle `p` keeps its codimension whatever its neighbours:
/// fixed, a point, in a jet's source region, or a volume particle within h
/// of a solid.
fn held(p: usize, parts: &Particles, sources: &[Source], solids: &SolidSet, h: Real) -> bool {
    let (x, codim) = (&parts.x, &parts.codim);
    parts.fixed[p]
        || codim[p] == Codim::Point
        || sources.iter().any(|s| s.protects(&x[p], h))
        || (codim[p] == Codim::Volume && !solids.is_empty() && solids.phi(&x[p]) < h)
}

/// The codimension the §8 rules give particle `p` with its neighbours
/// `nbrs` within h (ascending): the weighted-PCA frame of its neighbours of
/// the same kind (a volume particle: all but points), then [`new_codim`].
fn by_the_rules(p: usize, parts: &Particles, nbrs: &[u32], prm: &TransitionParams) -> Codim {
    let (x, codim) = (&parts.x, &parts.codim);
    let same = |q: usize| match codim[p] {
        Codim::Volume => codim[q] != Codim::Point,
        Codim::Sheet => codim[q] == Codim::Sheet,
        Codim::Filament => codim[q] == Codim::Filament,
        Codim::Point => false,
    };
    let frame: Mat3 = pca_frame(
        &x[p],
        nbrs.iter()
            .map(|&q| q as usize)
            .filter(|&q| same(q))
            .map(|q| x[q]),
        prm.h,
    )
    .axes;
    new_codim(p, &frame, x, codim, &parts.fixed, nbrs, prm)
}

/// The mass-weighted mean velocity of the volume particles within h of a
/// particle that joins the volume; `None` when it has none.
fn joined_velocity(p: usize, parts: &Particles, nbrs: &[u32], h: Real) -> Option<Vec3> {
    let (mut m, mut mom) = (0.0, Vec3::zeros());
    for &q in nbrs {
        let q = q as usize;
        if q != p && parts.codim[q] == Codim::Volume && (parts.x[q] - parts.x[p]).norm() < h {
            m += parts.mass[q];
            mom += parts.v[q] * parts.mass[q];
        }
    }
    (m > 0.0).then(|| mom / m)
}

/// cos 30°: the half-aperture of the cones around the 26 cube directions in
/// [`surrounded`].
const COVER_COS: Real = 0.866_025_403_784_438_6;

/// The particles of a cell's 3 × 3 × 3 block of cells (every particle that
/// can lie within h of one of the cell's), ascending, with their positions
/// and codimensions side by side (read in order, not gathered per query),
/// and the positions of its sheet particles.
#[derive(Default)]
struct Block {
    id: Vec<u32>,
    x: Vec<Vec3>,
    codim: Vec<Codim>,
    sheet_x: Vec<Vec3>,
}

impl Block {
    fn gather(&mut self, grid: &CellGrid, c: &crate::neighbors::Cell, x: &[Vec3], codim: &[Codim]) {
        self.id.clear();
        grid.gather_block(c, &mut self.id);
        self.id.sort_unstable();
        self.x.clear();
        self.x.extend(self.id.iter().map(|&q| x[q as usize]));
        self.codim.clear();
        self.codim
            .extend(self.id.iter().map(|&q| codim[q as usize]));
        self.sheet_x.clear();
        self.sheet_x.extend(
            self.x
                .iter()
                .zip(&self.codim)
                .filter(|(_, &k)| k == Codim::Sheet)
                .map(|(x, _)| *x),
        );
    }
}

/// True when volume particle `p` keeps its codimension whatever its frame:
/// no sheet particle lies within `thin`·h/√0.75 (so the volume is not thin
/// across it, see below), and each of the 26 directions (i, j, k) ∈ {−1, 0, 1}³ \ 0 has a volume
/// particle within h and within 30° of it. Every unit vector lies within
/// 27.57° of one of those directions (their covering radius), so every cone
/// of half-aperture 30° + 27.57° < 60° — and so the π/3 cone of the
/// 0→1 rule along ±b³ for any b³ — holds a volume particle: the rule finds
/// both cones occupied. `block` holds every particle that can lie within h
/// of p (at `xp`). Stops at the first failing sheet or once all 26
/// directions are covered.
///
/// The sheet bound: the thin rule needs sheet particles s₁, s₂ within h in
/// the two opposite cones (so at least 60° apart seen from p) closer than
/// `thin`·h to each other. With r₁, r₂ their distances from p and M the
/// larger, |s₁ − s₂|² ≥ r₁² + r₂² − r₁r₂ ≥ ¾M², so both lie within
/// `thin`·h/√0.75 of p.
fn surrounded(p: usize, xp: &Vec3, block: &Block, h: Real, thin: Real) -> bool {
    let xp = *xp;
    let near = thin * h / (0.75 as Real).sqrt() * (1.0 + 1e-9);
    for xq in &block.sheet_x {
        let r = (xq - xp).norm();
        if r > 0.0 && r < near {
            return false;
        }
    }
    // bit 9(i+1) + 3(j+1) + (k+1) for direction (i, j, k); bit 13 is (0, 0, 0)
    const FULL: u32 = ((1 << 27) - 1) & !(1 << 13);
    let s2 = std::f64::consts::FRAC_1_SQRT_2;
    let s3 = 1.0 / (3.0 as Real).sqrt();
    let mut mask = 0u32;
    for ((&q, xq), &kq) in block.id.iter().zip(&block.x).zip(&block.codim) {
        if q as usize == p || kq != Codim::Volume {
            continue;
        }
        let d = xq - xp;
        let r = d.norm();
        if r == 0.0 || r >= h {
            continue;
        }
        let t = COVER_COS * r;
        let (a, b, c) = (d.x.abs(), d.y.abs(), d.z.abs());
        // only directions whose non-zero components share d's signs can lie
        // within 30° of it (an opposite sign caps the cosine at √(2/3))
        let sx = if d.x >= 0.0 { 2 } else { 0 };
        let sy = if d.y >= 0.0 { 2 } else { 0 };
        let sz = if d.z >= 0.0 { 2 } else { 0 };
        let bit = |i: u32, j: u32, k: u32| 1u32 << (9 * i + 3 * j + k);
        if a >= t {
            mask |= bit(sx, 1, 1);
        }
        if b >= t {
            mask |= bit(1, sy, 1);
        }
        if c >= t {
            mask |= bit(1, 1, sz);
        }
        if (a + b) * s2 >= t {
            mask |= bit(sx, sy, 1);
        }
        if (a + c) * s2 >= t {
            mask |= bit(sx, 1, sz);
        }
        if (b + c) * s2 >= t {
            mask |= bit(1, sy, sz);
        }
        if (a + b + c) * s3 >= t {
            mask |= bit(sx, sy, sz);
        }
        if mask == FULL {
            return true;
        }
    }
    false
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A lattice box of volume particles with spacing s.
    fn block(n: usize, s: Real) -> Particles {
        let mut p = Particles::new();
        for i in 0..n {
            for j in 0..n {
                for k in 0..n {
                    let x = Vec3::new(i as Real, j as Real, k as Real) * s;
                    p.push(x, Vec3::zeros(), 1.0, 0.5 * s, Codim::Volume);
                }
            }
        }
        p
    }

    /// The straightforward update (all neighbour lists, a frame and the
    /// rules for every particle) that [`update`] must reproduce.
    fn update_reference(
        parts: &mut Particles,
        prm: &TransitionParams,
        sources: &[Source],
        solids: &SolidSet,
    ) -> TransitionCounts {
        let h = prm.h;
        let x = &parts.x;
        let codim = &parts.codim;
        let lists = crate::neighbors::neighbor_lists(x, h);
        let next: Vec<Codim> = (0..x.len())
            .map(|p| {
                if held(p, parts, sources, solids, h) {
                    codim[p]
                } else {
                    by_the_rules(p, parts, lists.of(p), prm)
                }
            })
            .collect();
        let joined: Vec<(usize, Vec3)> = (0..x.len())
            .filter(|&p| codim[p] != Codim::Volume && next[p] == Codim::Volume)
            .filter_map(|p| joined_velocity(p, parts, lists.of(p), h).map(|v| (p, v)))
            .collect();
        for (p, v) in joined {
            parts.v[p] = v;
        }
        TransitionCounts::apply(&mut parts.codim, next)
    }

    /// A jittered ball of volume particles (spacing h/3) with sheet
    /// particles in its outer shell and in one side of it, a filament line through
    /// it and a loose sheet patch beside it; every particle with its own
    /// velocity.
    fn jittered_scene(h: Real) -> Particles {
        let s = h / 3.0;
        let mut seed = 12345u64;
        let mut rnd = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((seed >> 11) as Real / (1u64 << 53) as Real) - 0.5
        };
        let mut p = Particles::new();
        let n = 24;
        let r = 0.5 * n as Real * s;
        for i in 0..=n {
            for j in 0..=n {
                for k in 0..=n {
                    let c = Vec3::new(i as Real, j as Real, k as Real) * s - Vec3::repeat(r);
                    let q = c + Vec3::new(rnd(), rnd(), rnd()) * 0.3 * s;
                    let d = q.norm();
                    if d > r {
                        continue;
                    }
                    let kind = if d > r - 0.6 * s || (i < 8 && (i * 7 + j * 3 + k) % 13 == 0) {
                        Codim::Sheet
                    } else {
                        Codim::Volume
                    };
                    let v = Vec3::new(rnd(), rnd(), rnd());
                    p.push(q, v, 1.0 + 0.1 * rnd(), 0.3 * s, kind);
                }
            }
        }
        for i in 0..40 {
            let q = Vec3::new(-r + i as Real * 0.4 * s, 0.3 * s, 0.1 * s);
            p.push(q, Vec3::new(rnd(), 0.0, 0.0), 0.2, 0.1 * s, Codim::Filament);
        }
        for i in 0..8 {
            for j in 0..8 {
                let q = Vec3::new(r + 0.5 * h + i as Real * 0.4 * s, j as Real * 0.4 * s, 0.0);
                p.push(q, Vec3::new(0.0, rnd(), 0.0), 0.3, 0.1 * s, Codim::Sheet);
            }
        }
        p
    }

    #[test]
    fn the_cell_walk_with_the_surrounded_shortcut_matches_the_full_rules_bit_for_bit() {
        let h = 0.01;
        let prm = TransitionParams::paper(h);
        let base = jittered_scene(h);
        // and the same ball bare, with no sheet layer: its outer volume
        // particles see air in one cone
        let mut bare = base.clone();
        for (c, x) in bare.codim.iter_mut().zip(&bare.x) {
            if *c == Codim::Sheet && x.norm() < 4.0 * h {
                *c = Codim::Volume;
            }
        }
        let mut bare_ref = bare.clone();
        let cbare = update(&mut bare, &prm, &[], &SolidSet::default());
        assert_eq!(
            cbare,
            update_reference(&mut bare_ref, &prm, &[], &SolidSet::default())
        );
        assert_eq!(bare.codim, bare_ref.codim);
        assert!(cbare.volume_to_sheet > 500, "{cbare:?}");
        let (mut a, mut b) = (base.clone(), base.clone());
        let ca = update(&mut a, &prm, &[], &SolidSet::default());
        let cb = update_reference(&mut b, &prm, &[], &SolidSet::default());
        assert_eq!(ca, cb);
        assert_eq!(a.codim, b.codim);
        assert_eq!(a.v, b.v);
        // the scene exercises the rules and the shortcut
        assert!(ca.volume_to_sheet > 0 && ca.sheet_to_volume > 0, "{ca:?}");
        let grid = CellGrid::build(&base.x, h);
        let (mut deep, mut vol) = (0, 0);
        let mut block = Block::default();
        for c in grid.cells() {
            block.gather(&grid, c, &base.x, &base.codim);
            for &p in grid.members(c) {
                if base.codim[p as usize] == Codim::Volume {
                    vol += 1;
                    deep += surrounded(
                        p as usize,
                        &base.x[p as usize],
                        &block,
                        h,
                        prm.thin_distance,
                    ) as usize;
                }
            }
        }
        assert!(
            deep * 5 > vol,
            "{deep} of {vol} volume particles surrounded"
        );
        assert!(deep < vol);
    }

    #[test]
    fn exposed_layer_becomes_sheet_and_an_engulfed_sheet_returns() {
        let s = 0.25;
        let n = 12;
        let mut p = block(n, s);
        let prm = TransitionParams::paper(4.0 * s);
        let mass0 = p.total_mass();
        let c = update(&mut p, &prm, &[], &SolidSet::default());
        // the outer layer of the cube is exposed on faces; corners/edges too
        let on_boundary = |x: &Vec3| {
            x.iter()
                .any(|&v| v.abs() < 1e-9 || (v - (n - 1) as Real * s).abs() < 1e-9)
        };
        for i in 0..p.len() {
            let deep = p.x[i]
                .iter()
                .all(|&v| v > 1.5 * s && v < (n as Real - 2.5) * s);
            if deep {
                assert_eq!(p.codim[i], Codim::Volume, "interior particle {i} changed");
            }
            if on_boundary(&p.x[i]) {
                assert_eq!(
                    p.codim[i],
                    Codim::Sheet,
                    "surface particle {i} at {}",
                    p.x[i]
                );
            }
        }
        assert!(c.volume_to_sheet as usize >= 6 * (n - 2) * (n - 2));
        assert_eq!(c.sheet_to_volume, 0);
        assert_eq!(p.total_mass(), mass0);
        // a sheet particle placed inside the volume is engulfed and takes
        // the body's velocity
        let body_v = Vec3::new(0.1, 0.0, -0.05);
        for v in p.v.iter_mut() {
            *v = body_v;
        }
        let mid = (n as Real - 1.0) * 0.5 * s;
        let q = p.push(
            Vec3::new(mid, mid, mid + 0.1 * s),
            Vec3::new(60.0, 0.0, 0.0),
            1.0,
            0.1,
            Codim::Sheet,
        );
        let c = update(&mut p, &prm, &[], &SolidSet::default());
        assert_eq!(p.codim[q], Codim::Volume);
        assert!(c.sheet_to_volume >= 1);
        assert!((p.v[q] - body_v).norm() < 1e-15, "{}", p.v[q]);
    }
}
