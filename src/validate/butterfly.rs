//! Implicit diffusion on a mixed sheet–filament "butterfly" (paper Fig. 12,
//! joint operator §3.2.4).
//!
//! The wing is the region r < 1 + 0.6 cos 2θ of the plane, sampled on a
//! square lattice of spacing Δ and bent to z = 0.15 x² (sheet particles);
//! its outline is the rim, and two tails hang from the lower waist (filament
//! particles, spacing Δ). Heat s = 1 is injected within 0.15 of the wing
//! root (the origin), s = 0 elsewhere, and spread by backward Euler
//! (I − Δt L) s⁺ = s with the joint Laplacian.
//!
//! Reported honestly: the MLS operator is not conservative, so the total
//! heat Σ s_i (equal-weight particles) drifts; the maximum principle asks
//! that no new extrema appear, min ≥ 0 and max ≤ 1.

use super::time::{rightmost_eigenvalue, ShiftedLu};
use super::ValidateError;
use crate::math::{Real, Vec3};
use crate::mls::{FitStats, JointLaplacian, MlsParams, Neighborhoods};
use crate::particles::Codim;
use serde::Serialize;
use std::f64::consts::PI;
use std::time::Instant;

/// The case's parameters.
#[derive(Clone, Debug)]
pub struct Butterfly {
    /// Particle spacing Δ (m).
    pub spacing: Real,
    /// Backward-Euler step (s).
    pub dt: Real,
    /// Number of steps.
    pub steps: usize,
    /// Operator parameters (h should be ≈ 3.5 Δ).
    pub mls: MlsParams,
}

/// Figures of a run.
#[derive(Clone, Debug, Serialize)]
pub struct ButterflyReport {
    /// Sheet particles.
    pub sheet_particles: usize,
    /// Filament particles (rim and tails).
    pub filament_particles: usize,
    /// Steps taken.
    pub steps: usize,
    /// Step (s).
    pub dt: Real,
    /// Σ s at the start.
    pub heat_start: Real,
    /// Σ s at the end.
    pub heat_end: Real,
    /// (end − start) / start.
    pub heat_drift: Real,
    /// Minimum over all particles and steps.
    pub min_all: Real,
    /// Maximum at the end.
    pub max_end: Real,
    /// Largest excursion outside [0, 1] over all steps.
    pub max_principle_violation: Real,
    /// Fraction of particles with s > 1e-3 at the end.
    pub heated_fraction: Real,
    /// Σ s over filament particles at the end.
    pub filament_heat_end: Real,
    /// Rightmost eigenvalue estimate of L (re).
    pub rightmost_eigenvalue: Real,
    /// Fit fallbacks.
    pub fit_stats: FitStats,
    /// Seconds end to end.
    pub seconds: Real,
}

fn outline(theta: Real) -> Real {
    1.0 + 0.6 * (2.0 * theta).cos()
}

fn bend(x: Real, y: Real) -> Vec3 {
    Vec3::new(x, y, 0.15 * x * x)
}

/// The butterfly's particles: positions and codimensions.
pub fn butterfly_particles(spacing: Real) -> (Vec<Vec3>, Vec<Codim>) {
    let mut x = Vec::new();
    let mut c = Vec::new();
    let n = (1.7 / spacing).ceil() as i64;
    for i in -n..=n {
        for j in -n..=n {
            let (px, py) = (i as Real * spacing, j as Real * spacing);
            let r = (px * px + py * py).sqrt();
            let th = py.atan2(px);
            // keep interior points at least 0.7Δ inside the rim
            if r < outline(th) - 0.7 * spacing {
                x.push(bend(px, py));
                c.push(Codim::Sheet);
            }
        }
    }
    // rim: the outline at arc-length spacing ≈ Δ
    let fine = 20_000;
    let pt = |t: Real| {
        let r = outline(t);
        (r * t.cos(), r * t.sin())
    };
    let mut acc = 0.0;
    let mut prev = pt(0.0);
    x.push(bend(prev.0, prev.1));
    c.push(Codim::Filament);
    for k in 1..fine {
        let p = pt(2.0 * PI * k as Real / fine as Real);
        acc += ((p.0 - prev.0).powi(2) + (p.1 - prev.1).powi(2)).sqrt();
        prev = p;
        if acc >= spacing {
            acc = 0.0;
            x.push(bend(p.0, p.1));
            c.push(Codim::Filament);
        }
    }
    // tails from the lower waist
    for side in [-1.0, 1.0] {
        let t0 = -0.5 * PI + side * 0.25;
        let (x0, y0) = pt(t0);
        let dir = (side * 0.25, -1.0);
        let norm = (dir.0 * dir.0 + dir.1 * dir.1 as Real).sqrt();
        let m = (0.8 / spacing).round() as usize;
        for k in 1..=m {
            let s = k as Real * spacing;
            x.push(bend(x0 + s * dir.0 / norm, y0 + s * dir.1 / norm));
            c.push(Codim::Filament);
        }
    }
    (x, c)
}

impl Butterfly {
    /// Runs the case.
    pub fn run(&self) -> Result<ButterflyReport, ValidateError> {
        let start = Instant::now();
        if !(self.spacing > 0.005 && self.spacing < 0.5) {
            return Err(ValidateError::Param {
                what: "spacing",
                value: self.spacing,
                reason: "must lie in (0.005, 0.5)",
            });
        }
        if self.steps == 0 {
            return Err(ValidateError::Param {
                what: "steps",
                value: 0.0,
                reason: "must be at least 1",
            });
        }
        let (x, c) = butterfly_particles(self.spacing);
        let nb = Neighborhoods::build(&x, &c, self.mls.h)?;
        let l = JointLaplacian::assemble(&nb, &self.mls)?;
        let lu = ShiftedLu::new(&l, self.dt)?;
        let mut s: Vec<Real> =
            nb.x.iter()
                .map(|p| if p.xy().norm() < 0.15 { 1.0 } else { 0.0 })
                .collect();
        let heat_start: Real = s.iter().sum();
        let mut violation: Real = 0.0;
        let mut min_all = Real::INFINITY;
        for _ in 0..self.steps {
            lu.solve(&mut s);
            for &v in &s {
                let v = if v.is_finite() { v } else { Real::INFINITY };
                violation = violation.max(-v).max(v - 1.0);
                min_all = min_all.min(v);
            }
        }
        let heat_end: Real = s.iter().sum();
        let max_end = s.iter().fold(Real::NEG_INFINITY, |a, &b| a.max(b));
        let heated = s.iter().filter(|&&v| v > 1e-3).count() as Real / s.len() as Real;
        let filament_heat_end: Real = s[nb.n_sheet..].iter().sum();
        let (re, _) = rightmost_eigenvalue(&lu, l.n(), 40, 11);
        Ok(ButterflyReport {
            sheet_particles: nb.n_sheet,
            filament_particles: nb.len() - nb.n_sheet,
            steps: self.steps,
            dt: self.dt,
            heat_start,
            heat_end,
            heat_drift: (heat_end - heat_start) / heat_start,
            min_all,
            max_end,
            max_principle_violation: violation.max(0.0),
            heated_fraction: heated,
            filament_heat_end,
            rightmost_eigenvalue: re,
            fit_stats: l.stats,
            seconds: start.elapsed().as_secs_f64(),
        })
    }
}
