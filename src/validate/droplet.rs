//! Droplet cases of the coupled solver (paper §7) with analytic answers:
//!
//! - a resting droplet of radius R without gravity: the pressure jump is
//!   Young–Laplace's 2σ/R and the velocity stays zero (spurious currents);
//! - the l = 2 oscillation of a slightly ellipsoidal droplet: Rayleigh's
//!   ω² = 8σ/(ρR³) (Lamb 1932, §275), measured from the vertical extent.
//!
//! The droplet is sampled as Appendix F says: equidistributed concentric
//! shells at the initial spacing Δx/4, the outermost shell as sheet
//! particles (the surface layer). The level-set radius of the liquid is
//! `surface_radius` Δx around the volume particles (see `docs/decisions.md`
//! for its effect on the Young–Laplace jump and on the oscillation).

use crate::coupling::{BandVelocity, FaceMass, LayerTension, Method};
use crate::grid::MacGrid;
use crate::math::{Real, Vec3};
use crate::particles::Codim;
use crate::scene::{load_str, sample_bodies, SceneError};
use crate::solids::SolidSet;
use crate::step::{coupling_params, step, SimState, StageTimes, StepError, StepParams};
use std::time::Instant;

/// A droplet case.
#[derive(Clone, Copy, Debug)]
pub struct DropletCase {
    /// Radius R (m).
    pub radius: Real,
    /// Surface tension σ (N/m).
    pub sigma: Real,
    /// Cell size Δx (m).
    pub dx: Real,
    /// Level-set radius of the volume particles, relative to Δx.
    pub surface_radius: Real,
    /// Coupled solve.
    pub method: Method,
    /// Mass of the constraint faces.
    /// How P2G reads the particles at the surface (`solver.velocity_fit`).
    pub velocity_fit: crate::grid::VelocityFit,
    pub face_mass: FaceMass,
    /// Velocity the constraint faces are held to.
    pub band: BandVelocity,
    /// Smallest mass fraction of a constraint face (`coupling.mass_floor`).
    pub mass_floor: Real,
    /// How the surface layer carries its tension (`coupling.layer`).
    pub layer: LayerTension,
    /// Relative elongation e along y of the l = 2 ellipsoid (volume
    /// preserving: y × (1 + e), x and z × (1 + e)^{-1/2}); 0 for a sphere.
    pub elongation: Real,
    /// Implicit weight θ of the tension (`coupling.tension_theta`).
    pub tension_theta: Real,
}

impl DropletCase {
    /// The paper's droplet (R = 0.0128 m, σ = 0.03 N/m) at R/Δx = `cells`.
    pub fn paper(cells: Real) -> DropletCase {
        DropletCase {
            radius: 0.0128,
            sigma: 0.03,
            dx: 0.0128 / cells,
            surface_radius: 1.0,
            method: Method::Monolithic,
            face_mass: FaceMass::Balanced,
            velocity_fit: crate::grid::VelocityFit::Mean,
            band: BandVelocity::default(),
            mass_floor: crate::coupling::system::MASS_FLOOR,
            layer: LayerTension::Coupled,
            elongation: 0.0,
            tension_theta: crate::coupling::system::TENSION_THETA,
        }
    }

    /// Young–Laplace jump 2σ/R (Pa).
    pub fn young_laplace(&self) -> Real {
        2.0 * self.sigma / self.radius
    }

    /// Rayleigh's l = 2 period 2π/ω, ω² = 8σ/(ρR³), ρ = 1000 (s).
    pub fn rayleigh_period(&self) -> Real {
        2.0 * std::f64::consts::PI / (8.0 * self.sigma / (1000.0 * self.radius.powi(3))).sqrt()
    }

    /// The initial state and the substep parameters.
    pub fn build(&self) -> Result<(SimState, StepParams), SceneError> {
        let (r, dx) = (self.radius, self.dx);
        let l = 2.5 * r * (1.0 + self.elongation);
        let yaml = format!(
            "version: 1\ndomain: {{min: [{m},{m},{m}], max: [{l},{l},{l}], dx: {dx}}}\n\
             time: {{fps: 30, frames: 1}}\n\
             physics: {{gravity: [0,0,0]}}\n\
             solver: {{surface_radius: {sr}}}\n\
             bodies:\n  - {{kind: sphere, center: [0,0,0], radius: {r}, spacing: 0.25}}\n",
            m = -l,
            sr = self.surface_radius
        );
        let mut scene = load_str(&yaml, std::path::Path::new("droplet.yaml"))?;
        let solids = SolidSet::from_scene(&scene.solids);
        let (mut parts, _) = sample_bodies(&scene, &solids);
        let s = 0.25 * dx;
        let e = self.elongation;
        for i in 0..parts.len() {
            if parts.x[i].norm() > r - 0.75 * s {
                parts.codim[i] = Codim::Sheet;
            }
            let x = parts.x[i];
            parts.x[i] = Vec3::new(
                x.x / (1.0 + e).sqrt(),
                x.y * (1.0 + e),
                x.z / (1.0 + e).sqrt(),
            );
        }
        scene.physics.surface_tension = self.sigma;
        let mut prm = StepParams::from_scene(&scene);
        prm.velocity_fit = self.velocity_fit;
        let mut cp = coupling_params(&scene);
        cp.method = self.method;
        cp.face_mass = self.face_mass;
        cp.band = self.band;
        cp.mass_floor = self.mass_floor;
        cp.layer = self.layer;
        cp.surface.tension_theta = self.tension_theta;
        prm.coupling = Some(cp);
        let grid = MacGrid::new(prm.lo, prm.hi, dx);
        Ok((SimState::new(parts, grid, solids), prm))
    }
}

/// Result of an oscillation run.
#[derive(Clone, Debug)]
pub struct Oscillation {
    /// Measured period (s): twice the time between the first maximum of
    /// the vertical extent (t = 0) and its first minimum, refined by a
    /// parabola through the three samples around the minimum.
    pub period: Real,
    /// Rayleigh's period (s).
    pub rayleigh: Real,
    /// Relative error of the period.
    pub error: Real,
    /// Substeps run.
    pub steps: usize,
    /// Wall time (s).
    pub wall_s: Real,
    /// Particles.
    pub particles: usize,
    /// (t, vertical extent) samples.
    pub trace: Vec<(Real, Real)>,
    /// With [`oscillate_period`]: the second swing of the vertical extent
    /// (first minimum to the next maximum) over the first (t = 0 to the
    /// minimum). A linear oscillation whose amplitude falls by r every half
    /// period gives r; an inviscid droplet, 1 (water at R = 12.8 mm: 0.991).
    pub swing_ratio: Option<Real>,
}

/// Runs the l = 2 oscillation with substep `dt` until the vertical extent
/// has passed its first minimum (at most 1.2 × Rayleigh's period).
pub fn oscillate(case: &DropletCase, dt: Real) -> Result<Oscillation, OscError> {
    run(case, dt, false)
}

/// As [`oscillate`], then on to the next maximum (at most 2.4 × Rayleigh's
/// period), which gives [`Oscillation::swing_ratio`]: the numerical damping.
pub fn oscillate_period(case: &DropletCase, dt: Real) -> Result<Oscillation, OscError> {
    run(case, dt, true)
}

/// Whether the trace turned at its second-last sample (`down`: from falling
/// to rising, a minimum).
fn turned(trace: &[(Real, Real)], down: bool) -> bool {
    let n = trace.len();
    n >= 3 && {
        let (a, b, c) = (trace[n - 3].1, trace[n - 2].1, trace[n - 1].1);
        if down {
            b < a && b <= c
        } else {
            b > a && b >= c
        }
    }
}

fn run(case: &DropletCase, dt: Real, full: bool) -> Result<Oscillation, OscError> {
    let (mut st, prm) = case.build()?;
    let extent = |st: &SimState| {
        st.particles
            .x
            .iter()
            .map(|x| x.y)
            .fold(Real::MIN, Real::max)
    };
    let mut trace = vec![(0.0, extent(&st))];
    let tr = case.rayleigh_period();
    let wall = Instant::now();
    let mut t = 0.0;
    let mut steps = 0;
    let (mut min, mut max) = (None, None);
    let limit = if full { 2.4 } else { 1.2 };
    while t < limit * tr {
        step(&mut st, &prm, dt, &mut StageTimes::default())?;
        t += dt;
        steps += 1;
        trace.push((t, extent(&st)));
        let n = trace.len();
        if min.is_none() {
            if turned(&trace, true) {
                min = Some(n - 2);
                if !full {
                    break;
                }
            }
        } else if turned(&trace, false) {
            max = Some(n - 2);
            break;
        }
    }
    let k = min.ok_or(OscError::NoMinimum { time: t })?;
    let swing_ratio = if full {
        let m = max.ok_or(OscError::NoMinimum { time: t })?;
        Some((trace[m].1 - trace[k].1) / (trace[0].1 - trace[k].1))
    } else {
        None
    };
    let (t0, y0) = trace[k - 1];
    let (_, y1) = trace[k];
    let (_, y2) = trace[k + 1];
    let denom = y0 - 2.0 * y1 + y2;
    let off = if denom > 0.0 {
        0.5 * (y0 - y2) / denom
    } else {
        0.0
    };
    let tmin = t0 + dt * (1.0 + off);
    let period = 2.0 * tmin;
    Ok(Oscillation {
        period,
        rayleigh: tr,
        error: period / tr - 1.0,
        steps,
        wall_s: wall.elapsed().as_secs_f64(),
        particles: st.particles.len(),
        trace,
        swing_ratio,
    })
}

/// Why an oscillation run failed.
#[derive(Debug, thiserror::Error)]
pub enum OscError {
    /// The scene could not be built.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// A substep failed.
    #[error(transparent)]
    Step(#[from] StepError),
    /// The extent had no minimum within 1.2 Rayleigh periods (or, for a
    /// full period, no maximum after it within 2.4).
    #[error("the droplet's extent did not turn by t = {time} s (over-damped or far too slow)")]
    NoMinimum {
        /// Time reached (s).
        time: Real,
    },
}
