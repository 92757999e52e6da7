//! A free liquid slab in zero gravity, the thick sheet edge of the fluid
//! chain (paper §10.2, Fig. 1) on its own.
//!
//! Each edge of a flat sheet is pulled back by the tension of its two
//! faces, 2σ per unit length, whatever its thickness h: across the plane
//! x = x_mid the faces pull the half x < x_mid with σ per unit length of
//! the cut's perimeter, and the flat interior holds no pressure. So the
//! x-momentum of that half grows as P(t) = 2σL t (L the edge length; the
//! rounded side rims add σ(2 − π/2)h, under 3 % here), and the edge
//! retracts towards the Taylor–Culick speed v = √(2σ/(ρh)) (Culick 1960),
//! reaching it within a few t_c = √(ρh³/σ).
//!
//! The slab is sampled like the scenes' bodies (spacing Δx/2, the outer
//! layer as sheet particles; a slab thinner than a cell as two layers of
//! sheet particles half its thickness apart, a sub-cell sheet) and stepped with a fixed Δt by
//! [`crate::step::step`]. `offset` places its faces relative to the grid
//! (the cell fraction of the lower face), since a slab a few cells thick
//! sees the grid (docs/decisions.md, "Thick sheet edges").

use crate::coupling::LayerTension;
use crate::math::Real;
use crate::scene::SceneError;
use crate::step::{step, SimState, StageTimes, StepError, StepParams};
use std::time::Instant;

/// A slab case.
#[derive(Clone, Copy, Debug)]
pub struct SlabCase {
    /// Cell size Δx (m).
    pub dx: Real,
    /// Thickness h in cells.
    pub cells: Real,
    /// Lower face at (6.5 + offset) cells above the domain's floor.
    pub offset: Real,
    /// Extent along x (m): the two edges that are measured.
    pub width: Real,
    /// Extent along z (m): the edge length L.
    pub length: Real,
    /// Surface tension σ (N/m).
    pub sigma: Real,
    /// Level-set radius of the liquid, relative to Δx (`solver.surface_radius`).
    pub surface_radius: Real,
    /// How the surface layer carries its tension (`coupling.layer`).
    pub layer: LayerTension,
}

impl SlabCase {
    /// The fluid chain's edge: Δx = 1/480 m and σ = 0.045 N/m as in
    /// `fluid_chain.yaml`, three cells (6.25 mm) thick, 50 × 40 mm.
    pub fn chain() -> SlabCase {
        SlabCase {
            dx: 1.0 / 480.0,
            cells: 3.0,
            offset: 0.0,
            width: 0.05,
            length: 0.04,
            sigma: 0.045,
            surface_radius: 1.0,
            layer: LayerTension::Coupled,
        }
    }

    /// Particle spacing relative to Δx: Δx/2, or half the thickness for a
    /// slab thinner than a cell (two layers of sheet particles, a sub-cell sheet).
    pub fn spacing(&self) -> Real {
        (0.5 * self.cells).min(0.5)
    }

    /// Thickness h (m).
    pub fn thickness(&self) -> Real {
        self.cells * self.dx
    }

    /// Taylor–Culick speed √(2σ/(ρh)), ρ = 1000 (m/s).
    pub fn taylor_culick(&self) -> Real {
        (2.0 * self.sigma / (1000.0 * self.thickness())).sqrt()
    }

    /// The pull 2σL on each half (N).
    pub fn pull(&self) -> Real {
        2.0 * self.sigma * self.length
    }

    /// Capillary time √(ρh³/σ) (s).
    pub fn capillary_time(&self) -> Real {
        (1000.0 * self.thickness().powi(3) / self.sigma).sqrt()
    }

    /// Slab bounds (min, max) in the case's domain.
    fn bounds(&self) -> ([Real; 3], [Real; 3]) {
        let m = 0.02;
        let y0 = (6.5 + self.offset) * self.dx;
        (
            [m, y0, m],
            [m + self.width, y0 + self.thickness(), m + self.length],
        )
    }

    /// The scene (zero gravity, no viscosity) and its sampled state.
    pub fn build(&self) -> Result<(SimState, StepParams), SceneError> {
        let (lo, hi) = self.bounds();
        let yaml = format!(
            "version: 1\n\
             domain: {{min: [0,0,0], max: [{x},{y},{z}], dx: {dx}}}\n\
             time: {{fps: 100, frames: 1}}\n\
             physics: {{gravity: [0,0,0], surface_tension: {s}}}\n\
             solver: {{surface_radius: {sr}}}\n\
             coupling: {{layer: {layer}}}\n\
             bodies:\n  - {{kind: box, min: [{a},{b},{c}], max: [{d},{e},{f}], spacing: {sp}}}\n",
            x = hi[0] + lo[0],
            y = hi[1] + lo[1],
            z = hi[2] + lo[2],
            dx = self.dx,
            s = self.sigma,
            sr = self.surface_radius,
            sp = self.spacing(),
            layer = match self.layer {
                LayerTension::Coupled => "coupled",
                LayerTension::Jump => "jump",
                LayerTension::Cut => "cut",
            },
            a = lo[0],
            b = lo[1],
            c = lo[2],
            d = hi[0],
            e = hi[1],
            f = hi[2],
        );
        let (state, prm, _) = super::liquid_case(&yaml, "slab.yaml")?;
        Ok((state, prm))
    }
}

/// One sample of a slab run.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct SlabSample {
    /// Time (s).
    pub t: Real,
    /// Inward x-momentum of a half (kg m/s): the mean of the two halves'.
    pub momentum: Real,
    /// momentum / (2σL t): 1 when the edge feels its full pull.
    pub pull_ratio: Real,
    /// Mean inward displacement of the two x edges at mid-length (m).
    pub retraction: Real,
    /// Taylor–Culick distance v t (m).
    pub taylor_culick: Real,
}

/// The mean of the two halves' inward x-momenta (the half x < `mid`
/// counted along +x, the other along −x), and the extreme x of the
/// particles within `band` of the middle of the length (the two edges).
fn measure(st: &SimState, mid: Real, zc: Real, band: Real) -> (Real, [Real; 2]) {
    let p = &st.particles;
    let (mut mom, mut lo, mut hi) = (0.0, Real::MAX, Real::MIN);
    for i in 0..p.len() {
        let x = p.x[i];
        let s = if x.x < mid { 1.0 } else { -1.0 };
        mom += 0.5 * s * p.mass[i] * p.v[i].x;
        if (x.z - zc).abs() < band {
            lo = lo.min(x.x);
            hi = hi.max(x.x);
        }
    }
    (mom, [lo, hi])
}

/// Runs the slab with substep `dt` to `t_end`, sampling every `every`
/// steps and at the end; returns the samples and the wall time (s).
pub fn retract(
    case: &SlabCase,
    dt: Real,
    t_end: Real,
    every: usize,
) -> Result<(Vec<SlabSample>, Real), SlabError> {
    if !(dt > 0.0 && t_end >= dt && every >= 1) {
        return Err(SlabError::Param {
            reason: format!("need dt > 0, t_end ≥ dt and a sampling interval ≥ 1 (dt {dt}, t_end {t_end}, every {every})"),
        });
    }
    let (mut st, prm) = case.build()?;
    let (lo, hi) = case.bounds();
    let mid = 0.5 * (lo[0] + hi[0]);
    let zc = 0.5 * (lo[2] + hi[2]);
    let band = 0.25 * case.length;
    let (_, e0) = measure(&st, mid, zc, band);
    let wall = Instant::now();
    let steps = (t_end / dt).round() as usize;
    let mut out = Vec::new();
    for k in 1..=steps {
        step(&mut st, &prm, dt, &mut StageTimes::default())?;
        if k % every == 0 || k == steps {
            let t = k as Real * dt;
            let (mom, e) = measure(&st, mid, zc, band);
            out.push(SlabSample {
                t,
                momentum: mom,
                pull_ratio: mom / (case.pull() * t),
                retraction: 0.5 * ((e[0] - e0[0]) + (e0[1] - e[1])),
                taylor_culick: case.taylor_culick() * t,
            });
        }
    }
    Ok((out, wall.elapsed().as_secs_f64()))
}

/// Why a slab run failed.
#[derive(Debug, thiserror::Error)]
pub enum SlabError {
    /// The scene could not be built.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// A substep failed.
    #[error(transparent)]
    Step(#[from] StepError),
    /// A run parameter is out of range.
    #[error("slab run: {reason}")]
    Param {
        /// What is wrong.
        reason: String,
    },
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_slab_is_sampled_with_its_surface_layer_where_the_case_puts_it() {
        let case = SlabCase {
            width: 0.02,
            length: 0.015,
            ..SlabCase::chain()
        };
        let (st, _) = case.build().unwrap();
        let p = &st.particles;
        let (lo, hi) = case.bounds();
        let m: Real = p.mass.iter().sum();
        let vol = (hi[0] - lo[0]) * (hi[1] - lo[1]) * (hi[2] - lo[2]);
        // the samples carry the box's liquid mass
        assert!((m / (1000.0 * vol) - 1.0).abs() < 1e-9, "mass {m}");
        // both codimensions are there, and everything lies in the box
        let sheets = p
            .codim
            .iter()
            .filter(|c| **c == crate::particles::Codim::Sheet)
            .count();
        assert!(sheets > 0 && sheets < p.len());
        for x in &p.x {
            for d in 0..3 {
                assert!(x[d] >= lo[d] - 1e-12 && x[d] <= hi[d] + 1e-12);
            }
        }
        // 6.25 mm thick: v = √(2σ/ρh) = 0.12 m/s, t_c = 0.073 s
        assert!((case.taylor_culick() - 0.12).abs() < 1e-3);
        assert!((case.capillary_time() - 0.0733).abs() < 1e-3);
    }
}
