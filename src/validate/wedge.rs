//! A box's long edges against the recoil of an inviscid liquid wedge.
//!
//! A wedge of inviscid liquid released at rest is pulled back by surface
//! tension alone. Its only scales are σ/ρ and t, so its shape is
//! self-similar with the length (σt²/ρ)^{1/3} (Keller & Miksis 1983,
//! "Surface tension driven flows", SIAM J. Appl. Math. 43): the tip
//! retracts by d(t) = C (σt²/ρ)^{1/3}, C a constant of the wedge angle. A
//! box's long edges are 90° wedges until the recoil reaches the middles of
//! its faces or its ends.
//!
//! The case is the droplet-collision preset's two cubes as one body at rest:
//! 48 × 24 × 24 mm in the preset's 64³ grid (Δx = 1/480 m), sampled at Δx/4
//! with the outer layer as sheet particles, σ = 0.03 N/m, no gravity,
//! stepped by [`crate::step::step`] in frames of 5 ms (the preset's), each
//! split in equal substeps under the jump's capillary limit
//! ([`crate::coupling::jump::capillary_limit`]). The recoil is measured in
//! the cross-sections within 8 mm of the box's middle, where the recoil
//! length (2.3 mm at t = 0.02 s, 4.8 mm at 0.08 s) stays well inside the
//! 12 mm from an edge to the middle of a face and the 16 mm to an end.
//! `codimfx validate wedge`; `tests/wedge.rs`; docs/decisions.md, "The
//! coupled layer holds a body's edges".

use crate::coupling::LayerTension;
use crate::math::{Real, Vec3};
use crate::particles::{Codim, Particles};
use crate::scene::SceneError;
use crate::step::{step, SimState, StageTimes, StepError, StepParams};
use std::time::Instant;

/// Liquid density (kg/m³).
const RHO: Real = 1000.0;
/// Frame length (s), the droplet-collision preset's step.
pub const FRAME: Real = 0.005;

/// A wedge case.
#[derive(Clone, Copy, Debug)]
pub struct WedgeCase {
    /// Surface tension σ (N/m).
    pub sigma: Real,
    /// How the surface layer carries its tension (`coupling.layer`).
    pub layer: LayerTension,
}

impl WedgeCase {
    /// The droplet-collision preset's σ with the given layer.
    pub fn collision(layer: LayerTension) -> WedgeCase {
        WedgeCase { sigma: 0.03, layer }
    }

    /// The similarity length (σt²/ρ)^{1/3} (m).
    pub fn scale(&self, t: Real) -> Real {
        (self.sigma * t * t / RHO).cbrt()
    }

    /// The scene and its sampled state.
    pub fn build(&self) -> Result<(SimState, StepParams, crate::scene::Scene), SceneError> {
        let yaml = format!(
            "version: 1\n\
             domain: {{min: [0,0,0], max: [0.13333333333333333, 0.13333333333333333, 0.13333333333333333], dx: 0.0020833333333333333}}\n\
             time: {{fps: 200, frames: 1, max_dt: {FRAME}}}\n\
             physics: {{density: {RHO}, gravity: [0,0,0], surface_tension: {s}, viscosity: 0}}\n\
             solver: {{surface_radius: 1.0}}\n\
             coupling: {{layer: {layer}}}\n\
             bodies:\n  - {{kind: box, min: [0.04266666666666667, 0.05466666666666667, 0.05466666666666667], \
             max: [0.09066666666666666, 0.07866666666666666, 0.07866666666666666], spacing: 0.25}}\n",
            s = self.sigma,
            layer = match self.layer {
                LayerTension::Coupled => "coupled",
                LayerTension::Jump => "jump",
                LayerTension::Cut => "cut",
            },
        );
        super::liquid_case(&yaml, "wedge.yaml")
    }
}

/// How far out the surface layer reaches along the diagonals of the long
/// edges (m), in the cross-sections within 8 mm of the body's middle along
/// x: the mean over the four quadrants of the mean |y| + |z| (about the
/// centre of mass) of each quadrant's 20 farthest sheet particles, over √2.
/// `None` with fewer than 20 sheet particles in a quadrant.
pub fn edge_reach(p: &Particles) -> Option<Real> {
    let mut m = 0.0;
    let mut c = Vec3::zeros();
    for i in 0..p.len() {
        m += p.mass[i];
        c += p.mass[i] * p.x[i];
    }
    if m <= 0.0 {
        return None;
    }
    c /= m;
    let mut reach = 0.0;
    for (sy, sz) in [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)] {
        let mut l1: Vec<Real> = (0..p.len())
            .filter(|&i| p.codim[i] == Codim::Sheet && (p.x[i].x - c.x).abs() < 8e-3)
            .map(|i| sy * (p.x[i].y - c.y) + sz * (p.x[i].z - c.z))
            .collect();
        if l1.len() < 20 {
            return None;
        }
        l1.sort_by(|a, b| b.total_cmp(a));
        reach += l1[..20].iter().sum::<Real>() / 20.0;
    }
    Some(reach / 4.0 / Real::sqrt(2.0))
}

/// One frame of a wedge run.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct WedgeSample {
    /// Time (s).
    pub t: Real,
    /// Inward displacement of the edges along their diagonals (m).
    pub recoil: Real,
    /// recoil / (σt²/ρ)^{1/3}: Keller & Miksis's constant C once the
    /// recoil is resolved.
    pub ratio: Real,
}

/// Runs the case for `frames` frames of [`FRAME`]; returns a sample per
/// frame, the substep used and the wall time (s).
pub fn recoil(
    case: &WedgeCase,
    frames: usize,
) -> Result<(Vec<WedgeSample>, Real, Real), WedgeError> {
    if frames == 0 {
        return Err(WedgeError::Param {
            reason: "need at least one frame".into(),
        });
    }
    let (mut st, prm, scene) = case.build()?;
    let limit = crate::coupling::jump::capillary_limit(&scene, scene.domain.dx);
    let n = (FRAME / limit.min(FRAME) - 1e-9).ceil().max(1.0);
    let dt = FRAME / n;
    let none = || WedgeError::Param {
        reason: "the box's middle lost its surface layer".into(),
    };
    let r0 = edge_reach(&st.particles).ok_or_else(none)?;
    let wall = Instant::now();
    let mut out = Vec::with_capacity(frames);
    for f in 1..=frames {
        for _ in 0..n as usize {
            step(&mut st, &prm, dt, &mut StageTimes::default())?;
        }
        let t = f as Real * FRAME;
        let d = r0 - edge_reach(&st.particles).ok_or_else(none)?;
        out.push(WedgeSample {
            t,
            recoil: d,
            ratio: d / case.scale(t),
        });
    }
    Ok((out, dt, wall.elapsed().as_secs_f64()))
}

/// Why a wedge run failed.
#[derive(Debug, thiserror::Error)]
pub enum WedgeError {
    /// The scene could not be built.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// A substep failed.
    #[error(transparent)]
    Step(#[from] StepError),
    /// A run parameter is out of range, or the measure has no particles.
    #[error("wedge run: {reason}")]
    Param {
        /// What is wrong.
        reason: String,
    },
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_box_is_sampled_with_its_edges_where_the_case_puts_them() {
        let (st, _, _) = WedgeCase::collision(LayerTension::Jump).build().unwrap();
        let p = &st.particles;
        let m: Real = p.mass.iter().sum();
        // 48 × 24 × 24 mm of water
        assert!(
            (m / (RHO * 0.048 * 0.024 * 0.024) - 1.0).abs() < 1e-9,
            "mass {m}"
        );
        // the layer sits half a spacing (Δx/8) inside the 12 mm half-width:
        // the edge's diagonal reach is (12 − 0.26) √2 mm
        let r = edge_reach(p).unwrap();
        let want = (0.012 - 0.125 / 480.0) * Real::sqrt(2.0);
        assert!((r - want).abs() < 1e-4, "reach {r} against {want}");
        // the similarity length at 0.05 s: (0.03 × 0.0025 / 1000)^(1/3) = 4.22 mm
        let s = WedgeCase::collision(LayerTension::Jump).scale(0.05);
        assert!((s - 4.217e-3).abs() < 1e-5, "{s}");
    }
}
