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
use crate::neighbors::neighbor_lists;
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
pub fn update(
    parts: &mut Particles,
    prm: &TransitionParams,
    sources: &[Source],
    solids: &SolidSet,
) -> TransitionCounts {
    let h = prm.h;
    let x = &parts.x;
    let codim = &parts.codim;
    let lists = neighbor_lists(x, h);
    let same = |p: usize, q: usize| match codim[p] {
        Codim::Volume => codim[q] != Codim::Point,
        Codim::Sheet => codim[q] == Codim::Sheet,
        Codim::Filament => codim[q] == Codim::Filament,
        Codim::Point => false,
    };
    let next: Vec<Codim> = (0..x.len())
        .into_par_iter()
        .map(|p| {
            if parts.fixed[p]
                || codim[p] == Codim::Point
                || sources.iter().any(|s| s.protects(&x[p], h))
                || (codim[p] == Codim::Volume && !solids.is_empty() && solids.phi(&x[p]) < h)
            {
                return codim[p];
            }
            let nb = lists.of(p);
            let frame: Mat3 = pca_frame(
                &x[p],
                nb.iter()
                    .map(|&q| q as usize)
                    .filter(|&q| same(p, q))
                    .map(|q| x[q]),
                h,
            )
            .axes;
            new_codim(p, &frame, x, codim, &parts.fixed, nb, prm)
        })
        .collect();
    // a sheet or filament particle that joins a body takes the body's local
    // velocity (a PIC reset): FLIP would keep its own velocity, less 5 % per
    // substep, and a light rim particle engulfed at 60 m/s held the CFL
    // substep at 3e-5 s for 40 substeps (fluid polygon)
    let joined: Vec<(usize, Vec3)> = (0..x.len())
        .into_par_iter()
        .filter(|&p| codim[p] != Codim::Volume && next[p] == Codim::Volume)
        .filter_map(|p| {
            let (mut m, mut mom) = (0.0, Vec3::zeros());
            for &q in lists.of(p) {
                let q = q as usize;
                if q != p && codim[q] == Codim::Volume && (x[q] - x[p]).norm() < h {
                    m += parts.mass[q];
                    mom += parts.v[q] * parts.mass[q];
                }
            }
            (m > 0.0).then(|| (p, mom / m))
        })
        .collect();
    for (p, v) in joined {
        parts.v[p] = v;
    }
    TransitionCounts::apply(&mut parts.codim, next)
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
