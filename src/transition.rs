//! Codimension transitions (paper §8, Fig. 13).
//!
//! Every rule looks at a particle's neighbourhood through a pair of opposite
//! spherical cones of radius h with apex at the particle, along one axis of
//! its local frame F_p (Appendix A): b³ (the normal) for the volume↔sheet
//! rules, b² (the in-plane normal of a sheet edge) for sheet→filament.
//! [`cone_census`] is that one shared test; the rules below only read its
//! counts.
//!
//! **Cone angle.** The paper's "cone angle θ" is read as the *half* aperture:
//! a neighbour q is inside the cone along a when the angle between x_q − x_p
//! and a is at most θ. With the paper's initial spacing h/3 this puts on
//! average ≈ 4–5 neighbours of an interior sheet particle in each π/6 cone,
//! so "exactly one cone is occupied" identifies an edge reliably; with a full
//! aperture of π/6 an interior particle's cone holds ≈ 2 and random sampling
//! holes trigger false edges. The constructed cases in the tests (a flat
//! sheet edge, a sheet touching a volume, a thinning sheet, an isolated
//! filament particle) pin this reading down.
//!
//! Rules (the new codimension is computed for all particles from the old
//! state, then applied at once, so the result does not depend on order):
//! - 0→1: cones along b³ with θ = π/3: exactly one cone holds volume or sheet
//!   particles (the particle sits on one side of the interface), or both
//!   cones hold sheet particles and the closest pair across the two cones is
//!   nearer than `thin_distance` (the volume has become thin).
//! - 1→0: cones along b³ with θ = π/4 both hold volume particles.
//! - 1→2: cones along b² with θ = π/6: exactly one cone holds sheet or
//!   filament particles (the particle is on a sheet's edge), and no volume
//!   particle lies within h. The last condition is not in the paper: a sheet
//!   particle with a volume neighbour is the surface layer of a liquid body
//!   (Appendix F), whose end at a nozzle, a wall or a thick rim is not a
//!   thin sheet's rim (without it the upstream edge of every jet's surface
//!   layer turned into filaments).
//! - 2→3: no filament particle within h.
//! - 2→0 (not in the paper): a filament particle whose π/4 cones along ±b²
//!   and ±b³ all hold volume particles lies inside a liquid body, like the
//!   engulfed sheet particle of 1→0. Without it, rims that a liquid body
//!   flowed over stayed inside it and filament reseeding multiplied them
//!   (the fluid polygon's pancake held ~1,300 filament particles with a
//!   median of 44 volume neighbours each, `docs/decisions.md`).
//! - 2→1 (not in the paper): otherwise a filament particle with a volume
//!   particle within h has come to lie on a liquid body's surface, and joins
//!   its surface layer: the converse of the free-sheets-only 1→2 rule.
//! - 2→1 in film scenes (not in the paper; [`TransitionParams::film`]): a
//!   filament particle inside a flat film, its sheet neighbours all around
//!   it ([`surrounded_by_sheet`]). After a catenoid pinches, the neck's
//!   last filament particles stay at each half-film's apex; once the funnel
//!   has flattened they sit inside the film, and as rims they absorbed the
//!   film around them and opened it back to the ring.
//!
//! The paper implements no 2→1; this module does so in liquid scenes for
//! filaments on a body's surface, and in film scenes for filaments inside
//! a flat film.

use crate::math::{Mat3, Real, Vec3};
use crate::particles::Codim;
use rayon::prelude::*;

/// What the two cones along ±axis contain.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ConeCensus {
    /// Neighbours per codimension inside the cone along +axis.
    pub plus: [u32; 4],
    /// Neighbours per codimension inside the cone along −axis.
    pub minus: [u32; 4],
    /// Sheet neighbours inside the + cone (indices into the particle arrays).
    pub plus_sheet: Vec<u32>,
    /// Sheet neighbours inside the − cone.
    pub minus_sheet: Vec<u32>,
}

impl ConeCensus {
    /// Number of neighbours of the given codimensions in the + and − cone.
    pub fn count(&self, codims: &[Codim]) -> (u32, u32) {
        let p = codims.iter().map(|c| self.plus[*c as usize]).sum();
        let m = codims.iter().map(|c| self.minus[*c as usize]).sum();
        (p, m)
    }

    /// True when exactly one of the two cones holds a particle of `codims`.
    pub fn one_sided(&self, codims: &[Codim]) -> bool {
        let (p, m) = self.count(codims);
        (p > 0) != (m > 0)
    }
}

/// Counts the neighbours of particle `p` inside the two opposite cones of
/// half-aperture `half_angle` and radius `h` along ±`axis` (unit vector).
/// Neighbours at the apex (distance 0) belong to neither cone.
pub fn cone_census(
    p: usize,
    axis: &Vec3,
    half_angle: Real,
    h: Real,
    x: &[Vec3],
    codim: &[Codim],
    nbrs: &[u32],
) -> ConeCensus {
    let cos_t = half_angle.cos();
    let mut c = ConeCensus::default();
    for &q in nbrs {
        let q = q as usize;
        if q == p {
            continue;
        }
        let d = x[q] - x[p];
        let r = d.norm();
        if r == 0.0 || r >= h {
            continue;
        }
        let ca = d.dot(axis) / r;
        let k = codim[q] as usize;
        if ca >= cos_t {
            c.plus[k] += 1;
            if codim[q] == Codim::Sheet {
                c.plus_sheet.push(q as u32);
            }
        } else if -ca >= cos_t {
            c.minus[k] += 1;
            if codim[q] == Codim::Sheet {
                c.minus_sheet.push(q as u32);
            }
        }
    }
    c
}

/// Whether the sheet neighbours within h of particle `p` (at least five)
/// surround it in a flat film: x_p lies in their best-fit plane (within
/// 0.2 of their in-plane spread), and projected on that plane the widest
/// angle between consecutive ones, seen from x_p, is below `max_gap`. A
/// filament particle on a film's edge sees its sheet neighbours in a
/// half-disc, and the tip of a funnel retracting after a pinch stands above
/// its ring of neighbours; one left inside a flat film (the pinched neck's
/// debris once the funnel has flattened) has them all around.
pub fn surrounded_by_sheet(
    p: usize,
    h: Real,
    max_gap: Real,
    x: &[Vec3],
    codim: &[Codim],
    nbrs: &[u32],
) -> bool {
    let d: Vec<Vec3> = nbrs
        .iter()
        .map(|&q| q as usize)
        .filter(|&q| q != p && codim[q] == Codim::Sheet)
        .map(|q| x[q] - x[p])
        .filter(|d| {
            let r = d.norm();
            r > 0.0 && r < h
        })
        .collect();
    if d.len() < 5 {
        return false;
    }
    // their plane through their centroid c; x_p must lie in it (a cone's
    // apex does not: it stands cot α times the ring's radius above it)
    let c = d.iter().fold(Vec3::zeros(), |a, v| a + v) / d.len() as Real;
    let plane = crate::mls::frame::frame_from_covariance(
        d.iter()
            .fold(Mat3::zeros(), |m, v| m + (v - c) * (v - c).transpose()),
    );
    let (e1, e2, n) = (plane.axis(0), plane.axis(1), plane.axis(2));
    let spread = (d
        .iter()
        .map(|v| (v - n * n.dot(v)).norm_squared())
        .sum::<Real>()
        / d.len() as Real)
        .sqrt();
    if n.dot(&c).abs() > 0.2 * spread {
        return false;
    }
    let mut ang: Vec<Real> = d.iter().map(|v| v.dot(&e2).atan2(v.dot(&e1))).collect();
    ang.sort_by(|a, b| a.total_cmp(b));
    let wrap = ang[0] + std::f64::consts::TAU - ang[ang.len() - 1];
    ang.windows(2).map(|w| w[1] - w[0]).fold(wrap, Real::max) < max_gap
}

/// Parameters of the transition rules (paper §8). Angles in radians
/// (half apertures, see the module doc), distances relative to h.
#[derive(Clone, Debug, PartialEq)]
pub struct TransitionParams {
    /// Support radius h (m).
    pub h: Real,
    /// 0→1 cone half-aperture along b³ (paper: π/3).
    pub volume_to_sheet_angle: Real,
    /// 0→1 "volume is thin" distance between sheet particles across the two cones, relative to h.
    pub thin_distance: Real,
    /// 1→0 cone half-aperture along b³ (paper: π/4).
    pub sheet_to_volume_angle: Real,
    /// 1→2 cone half-aperture along b² (paper: π/6).
    pub sheet_to_filament_angle: Real,
    /// 2→1 in a free film (not in the paper): a filament particle whose
    /// sheet neighbours within h surround it, leaving no gap wider than
    /// this angle in their own plane ([`surrounded_by_sheet`]), lies inside
    /// the film, not on its edge. 0 (liquid scenes) disables the rule; film
    /// scenes use π/2. An edge particle's neighbours leave a gap of about π.
    /// 1→2 only needs the 60° wedge along b² empty, so a particle can meet
    /// both rules and flip between them from one substep to the next (seen
    /// on a freshly split film, docs/decisions.md, "2→1 inside a flat film").
    pub filament_to_sheet_gap: Real,
    /// Enable the volume↔sheet rules (off in film-only scenes).
    pub volume_rules: bool,
}

impl TransitionParams {
    /// The paper's angles for support radius `h`; thin distance 0.5 h.
    pub fn paper(h: Real) -> Self {
        use std::f64::consts::PI;
        TransitionParams {
            h,
            volume_to_sheet_angle: PI / 3.0,
            thin_distance: 0.5,
            sheet_to_volume_angle: PI / 4.0,
            sheet_to_filament_angle: PI / 6.0,
            filament_to_sheet_gap: 0.0,
            volume_rules: true,
        }
    }

    /// The rules of a film-only scene: no volume rules, and 2→1 for a
    /// filament particle inside a flat film (docs/decisions.md, "After the
    /// split").
    pub fn film(h: Real) -> Self {
        use std::f64::consts::PI;
        TransitionParams {
            volume_rules: false,
            filament_to_sheet_gap: PI / 2.0,
            ..TransitionParams::paper(h)
        }
    }
}

/// Number of transitions of each kind in one update.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct TransitionCounts {
    /// Volume → sheet.
    pub volume_to_sheet: u64,
    /// Sheet → volume.
    pub sheet_to_volume: u64,
    /// Sheet → filament.
    pub sheet_to_filament: u64,
    /// Filament → point.
    pub filament_to_point: u64,
    /// Filament → volume (engulfed by a liquid body).
    #[serde(default)]
    pub filament_to_volume: u64,
    /// Filament → sheet (lying on a liquid body's surface).
    #[serde(default)]
    pub filament_to_sheet: u64,
}

impl TransitionCounts {
    /// Writes the new codimensions `next` over `codim` and counts the
    /// transitions among them.
    pub fn apply(codim: &mut [Codim], next: Vec<Codim>) -> TransitionCounts {
        let mut n = TransitionCounts::default();
        for (c, nc) in codim.iter_mut().zip(next) {
            match (*c, nc) {
                (Codim::Volume, Codim::Sheet) => n.volume_to_sheet += 1,
                (Codim::Sheet, Codim::Volume) => n.sheet_to_volume += 1,
                (Codim::Sheet, Codim::Filament) => n.sheet_to_filament += 1,
                (Codim::Filament, Codim::Point) => n.filament_to_point += 1,
                (Codim::Filament, Codim::Volume) => n.filament_to_volume += 1,
                (Codim::Filament, Codim::Sheet) => n.filament_to_sheet += 1,
                _ => {}
            }
            *c = nc;
        }
        n
    }

    /// Adds the counts of `o` (frame totals over substeps).
    pub fn add(&mut self, o: &TransitionCounts) {
        self.volume_to_sheet += o.volume_to_sheet;
        self.sheet_to_volume += o.sheet_to_volume;
        self.sheet_to_filament += o.sheet_to_filament;
        self.filament_to_point += o.filament_to_point;
        self.filament_to_volume += o.filament_to_volume;
        self.filament_to_sheet += o.filament_to_sheet;
    }

    /// Total number of events.
    pub fn total(&self) -> u64 {
        self.volume_to_sheet
            + self.sheet_to_volume
            + self.sheet_to_filament
            + self.filament_to_point
            + self.filament_to_volume
            + self.filament_to_sheet
    }
}

/// Smallest distance between a particle of `a` and one of `b`.
fn min_cross_distance(x: &[Vec3], a: &[u32], b: &[u32]) -> Real {
    let mut best = Real::INFINITY;
    for &i in a {
        for &j in b {
            best = best.min((x[i as usize] - x[j as usize]).norm());
        }
    }
    best
}

/// True when a volume particle lies within `h` of particle `p`.
fn has_volume_within(p: usize, x: &[Vec3], codim: &[Codim], nbrs: &[u32], h: Real) -> bool {
    nbrs.iter().any(|&q| {
        let q = q as usize;
        q != p && codim[q] == Codim::Volume && (x[q] - x[p]).norm() < h
    })
}

/// True when the π/4 cones (`sheet_to_volume_angle`) along ± every axis of
/// `axes` all hold volume particles: the particle lies inside a liquid body.
fn engulfed(
    p: usize,
    axes: &[Vec3],
    x: &[Vec3],
    codim: &[Codim],
    nbrs: &[u32],
    prm: &TransitionParams,
) -> bool {
    axes.iter().all(|a| {
        let c = cone_census(p, a, prm.sheet_to_volume_angle, prm.h, x, codim, nbrs);
        let (vp, vm) = c.count(&[Codim::Volume]);
        vp > 0 && vm > 0
    })
}

/// The codimension particle `p` should have, given the current state.
/// `frame` holds b¹, b², b³ as columns; `nbrs` are all neighbours within h
/// (any codimension). Fixed (boundary) particles never change.
pub fn new_codim(
    p: usize,
    frame: &Mat3,
    x: &[Vec3],
    codim: &[Codim],
    fixed: &[bool],
    nbrs: &[u32],
    prm: &TransitionParams,
) -> Codim {
    if fixed[p] {
        return codim[p];
    }
    let b2: Vec3 = frame.column(1).into();
    let b3: Vec3 = frame.column(2).into();
    match codim[p] {
        Codim::Volume if prm.volume_rules => {
            let c = cone_census(p, &b3, prm.volume_to_sheet_angle, prm.h, x, codim, nbrs);
            let one_side = c.one_sided(&[Codim::Volume, Codim::Sheet]);
            let thin = !c.plus_sheet.is_empty()
                && !c.minus_sheet.is_empty()
                && min_cross_distance(x, &c.plus_sheet, &c.minus_sheet) < prm.thin_distance * prm.h;
            if one_side || thin {
                Codim::Sheet
            } else {
                Codim::Volume
            }
        }
        Codim::Sheet => {
            if prm.volume_rules {
                let c = cone_census(p, &b3, prm.sheet_to_volume_angle, prm.h, x, codim, nbrs);
                let (vp, vm) = c.count(&[Codim::Volume]);
                if vp > 0 && vm > 0 {
                    return Codim::Volume;
                }
            }
            if prm.volume_rules && has_volume_within(p, x, codim, nbrs, prm.h) {
                // the surface layer of a liquid body: its edge is the body, not a rim
                return Codim::Sheet;
            }
            let c = cone_census(p, &b2, prm.sheet_to_filament_angle, prm.h, x, codim, nbrs);
            if c.one_sided(&[Codim::Sheet, Codim::Filament]) {
                Codim::Filament
            } else {
                Codim::Sheet
            }
        }
        Codim::Filament => {
            if prm.volume_rules {
                if engulfed(p, &[b2, b3], x, codim, nbrs, prm) {
                    return Codim::Volume;
                }
                if has_volume_within(p, x, codim, nbrs, prm.h) {
                    return Codim::Sheet;
                }
            }
            if prm.filament_to_sheet_gap > 0.0
                && surrounded_by_sheet(p, prm.h, prm.filament_to_sheet_gap, x, codim, nbrs)
            {
                return Codim::Sheet;
            }
            let has_filament = nbrs.iter().any(|&q| {
                let q = q as usize;
                q != p && codim[q] == Codim::Filament && (x[q] - x[p]).norm() < prm.h
            });
            if has_filament {
                Codim::Filament
            } else {
                Codim::Point
            }
        }
        c => c,
    }
}

/// Updates every particle's codimension at once (Algorithm 1, line 2) and
/// returns the counts of each transition. `frames[i]` is particle i's local
/// frame (columns b¹, b², b³) and `nbrs(i)` its neighbours within h.
pub fn update_codims<'a>(
    x: &[Vec3],
    codim: &mut [Codim],
    fixed: &[bool],
    frames: &[Mat3],
    nbrs: impl Fn(usize) -> &'a [u32] + Sync,
    prm: &TransitionParams,
) -> TransitionCounts {
    let old: &[Codim] = codim;
    let next: Vec<Codim> = (0..x.len())
        .into_par_iter()
        .map(|p| new_codim(p, &frames[p], x, old, fixed, nbrs(p), prm))
        .collect();
    TransitionCounts::apply(codim, next)
}

#[cfg(test)]
#[path = "transition_tests.rs"]
mod tests;
