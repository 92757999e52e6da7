//! The codimension-1/2 solver for scenes made of thin sheets and filaments
//! (soap films, membranes, rims, threads): Algorithm 1 without the grid.
//!
//! A film-only scene allocates no grid and runs none of the grid stages;
//! its step is [`step::step`]: advection, codimension update (§8),
//! reseeding (§9), body forces, optional MLS viscosity (§5, eq. 13) and the
//! semi-implicit surface tension of §6 (eq. 16) with explicit rim and bud
//! tension. Scenes with a liquid volume use the coupled step instead.

pub mod advance;
pub mod air;
pub mod catenoid;
pub mod deformation;
pub mod driver;
pub mod shape;
pub mod step;
pub mod viscosity;
pub mod weight;

use crate::gas::GasPocket;
use crate::linsolve::{BicgstabParams, SolveError, SolveInfo};
use crate::math::{Real, Vec3};
use crate::mls::{FitStats, MlsError, MlsParams};
use crate::reseed::{ReseedCounts, ReseedParams};
use crate::transition::{TransitionCounts, TransitionParams};

/// Wind blowing on films: a uniform velocity, normal drag (see [`crate::gas::wind_force`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Wind {
    /// Wind velocity (m/s).
    pub velocity: Vec3,
    /// Air density (kg/m³).
    pub air_density: Real,
    /// Drag coefficient (dimensionless).
    pub drag: Real,
    /// Gusts: the wind blows only during these windows; always when `None`.
    pub gust: Option<Gust>,
    /// A jet: the wind blows within this radius (m) of the line through
    /// `origin` along the velocity (cosine taper over the outer quarter);
    /// everywhere when `None`.
    pub radius: Option<Real>,
    /// A point on the jet's axis (m).
    pub origin: Vec3,
}

/// Gusts of wind: on from `start` for `duration`, repeated every `period`
/// (once when `period` is 0).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Gust {
    /// Start of the first gust (s).
    pub start: Real,
    /// Length of each gust (s).
    pub duration: Real,
    /// Time from one gust's start to the next (s); 0 for a single gust.
    pub period: Real,
    /// Fraction of the velocity that blows between gusts, everywhere (a
    /// uniform breeze that carries blown bubbles away); 0 for still air.
    pub between: Real,
}

impl Wind {
    /// Whether a gust (or the steady wind) blows at time `t`; between gusts
    /// the wind blows at the `between` fraction of its velocity (still air
    /// when 0, whose drag still acts on moving films).
    pub fn blowing(&self, t: Real) -> bool {
        match &self.gust {
            None => true,
            Some(g) => {
                let mut tt = t - g.start;
                if tt >= 0.0 && g.period > 0.0 {
                    tt %= g.period;
                }
                tt >= 0.0 && tt < g.duration
            }
        }
    }

    /// Whether a jet (a wind with a radius) blows a gust, or steadily, at
    /// time `t`: the air it blows into a bag is trapped there ([`air`]).
    /// The breeze between gusts flows around the film instead.
    pub fn jet_blowing(&self, t: Real) -> bool {
        self.radius.is_some() && self.blowing(t)
    }

    /// The wind's velocity at time `t` and point `x`.
    pub fn at(&self, t: Real, x: &Vec3) -> Vec3 {
        let scale = match &self.gust {
            Some(g) if !self.blowing(t) => g.between,
            _ => 1.0,
        };
        let Some(r) = self.radius else {
            return self.velocity * scale;
        };
        if scale < 1.0 {
            // the breeze between gusts blows everywhere
            return self.velocity * scale;
        }
        let w = self.velocity.norm();
        if w == 0.0 {
            return Vec3::zeros();
        }
        let a = self.velocity / w;
        let d = x - self.origin;
        let rho = (d - a * d.dot(&a)).norm() / r;
        let taper = if rho <= 0.75 {
            1.0
        } else if rho >= 1.0 {
            0.0
        } else {
            0.5 * (1.0 + (std::f64::consts::PI * (rho - 0.75) / 0.25).cos())
        };
        self.velocity * taper
    }
}

/// Parameters of the film step. Units are SI; lengths relative to h say so.
#[derive(Clone, Debug, PartialEq)]
pub struct FilmParams {
    /// MLS operators for surface tension (h, fit order, weights). The sheet
    /// weight in filament fits is forced to 0 for tension (§7).
    pub mls: MlsParams,
    /// Surface tension σ (N/m).
    pub sigma: Real,
    /// Liquid density ρ (kg/m³).
    pub density: Real,
    /// Dynamic viscosity μ (Pa·s); 0 skips the viscosity solve.
    pub viscosity: Real,
    /// Gravity (m/s²).
    pub gravity: Vec3,
    /// A film held by a ring carries the part of its weight along the film
    /// to the ring (surfactant, [`weight`]): only gravity's normal part acts
    /// on its sheet particles.
    pub marangoni: bool,
    /// Free films have two faces: their tension area is doubled.
    pub free_film: bool,
    /// Linear air drag on film particles (1/s): f = −c m u. 0 = none.
    pub damping: Real,
    /// Wind on sheet particles.
    pub wind: Option<Wind>,
    /// Air inside a blown bag and its bubbles ([`air`]); `None` for none.
    pub air: Option<air::AirParams>,
    /// Codimension transitions (§8); `None` disables them.
    pub transitions: Option<TransitionParams>,
    /// Reseeding (§9); `None` disables it.
    pub reseed: Option<ReseedParams>,
    /// Linear solver of the tension (and viscosity) systems.
    pub solver: BicgstabParams,
    /// Half-aperture of the cones that find filament ends (rad).
    pub bud_angle: Real,
    /// A filament particle whose neighbourhood's second PCA eigenvalue
    /// exceeds this fraction of the first is a clump and becomes a point.
    pub clump_ratio: Real,
    /// A sheet particle with fewer than 3 sheet neighbours, or whose
    /// neighbourhood is line-like (second PCA eigenvalue below this fraction
    /// of the first), spans no plane: it becomes a filament particle, or a
    /// point when it has no neighbour at all (counted as sheet → filament,
    /// plus filament → point).
    pub sheet_line_ratio: Real,
    /// Rim tension modulation (fluid polygon, §10.2).
    pub rim_modulation: Option<crate::tension::Sawtooth>,
    /// Speed limit (m/s) applied after each substep of a scene, counted
    /// (`fallbacks.speed_clamps`); 0 for none.
    pub max_speed: Real,
    /// Implicit tension on the diffusive part of L only
    /// ([`crate::tension::split`], `film.implicit: diffusive`).
    pub diffusive: bool,
}

impl FilmParams {
    /// Paper defaults for support radius `h`, tension `sigma`, density 1000.
    ///
    /// The tension operator uses a *cubic* fit, not the quartic default of
    /// the MLS module: next to a boundary (a ring) a film particle sees only
    /// one row of particles on one side, and a quartic along that direction
    /// becomes interpolatory (exactly five distinct levels), giving rows with
    /// weights ~10× the median; BiCGSTAB then stalls (catenoid, s = 2 mm:
    /// 235–1000 iterations, no convergence at 1e-9 on the second step). The
    /// cubic fit solves in ~10 iterations and gives a neck error of 0.024 %
    /// (quadratic: 0.040 %). See `docs/decisions.md`.
    pub fn new(h: Real, sigma: Real) -> FilmParams {
        FilmParams {
            mls: MlsParams {
                order: 3,
                ..MlsParams::new(h)
            },
            sigma,
            density: 1000.0,
            viscosity: 0.0,
            gravity: Vec3::new(0.0, -9.81, 0.0),
            marangoni: false,
            free_film: true,
            damping: 0.0,
            wind: None,
            air: None,
            transitions: Some(TransitionParams::film(h)),
            reseed: Some(ReseedParams {
                rim_gap: std::f64::consts::FRAC_PI_2,
                ..ReseedParams::paper(h)
            }),
            solver: BicgstabParams::default(),
            bud_angle: std::f64::consts::PI / 6.0,
            clump_ratio: 0.3,
            sheet_line_ratio: 0.05,
            rim_modulation: None,
            max_speed: 0.0,
            diffusive: false,
        }
    }
}

/// State carried between film steps besides the particles.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FilmState {
    /// Gas enclosed by the film (bubbles), if any.
    pub gas: Option<GasPocket>,
    /// Bubbles blown off a ring (`film.bag_air`).
    pub air: air::AirState,
    /// Time at the start of the next step (s): the frame loop sets it before
    /// each substep; each step advances it.
    pub time: Real,
}

/// Wall-clock seconds spent in each stage of one step (0 for skipped stages).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FilmTimings {
    /// Advection.
    pub advect: f64,
    /// Neighbours, frames, codimension update.
    pub transition: f64,
    /// Reseeding.
    pub reseed: f64,
    /// Areas, thickness and explicit forces.
    pub forces: f64,
    /// Viscosity solve (0 when μ = 0).
    pub viscosity: f64,
    /// MLS fits and Laplacian assembly.
    pub operators: f64,
    /// Tension system assembly, ILU(0) and BiCGSTAB.
    pub tension: f64,
}

impl FilmTimings {
    /// Adds the stage times of `o`.
    pub fn add(&mut self, o: &FilmTimings) {
        self.advect += o.advect;
        self.transition += o.transition;
        self.reseed += o.reseed;
        self.forces += o.forces;
        self.viscosity += o.viscosity;
        self.operators += o.operators;
        self.tension += o.tension;
    }
}

/// What one film step did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FilmStepInfo {
    /// Stage times.
    pub timings: FilmTimings,
    /// Solver figures of the tension solve, per component.
    pub tension_solve: [SolveInfo; 3],
    /// Solver figures of the viscosity solve, per component (zero when skipped).
    pub viscosity_solve: [SolveInfo; 3],
    /// Transition counts.
    pub transitions: TransitionCounts,
    /// Reseeding counts.
    pub reseed: ReseedCounts,
    /// MLS fit outcomes of the tension operator.
    pub fits: FitStats,
    /// Enclosed gas volume (m³), when the scene has gas.
    pub gas_volume: Option<Real>,
    /// What the bag's and bubbles' air did (`film.bag_air`).
    pub air: Option<air::AirInfo>,
    /// Stages 4–6 reused the neighbourhoods, frames and Laplacian rows of
    /// stage 2 (the particle set did not change in between).
    pub reused_neighborhoods: bool,
}

/// Why a film step failed.
#[derive(Debug, thiserror::Error)]
pub enum FilmError {
    /// The MLS stage rejected its input.
    #[error("MLS operators: {0}")]
    Mls(#[from] MlsError),
    /// A linear solve failed.
    #[error("{stage} solve: {source}")]
    Solve {
        /// Which solve.
        stage: &'static str,
        /// The solver's error.
        source: SolveError,
    },
    /// A non-finite value appeared after a stage.
    #[error("non-finite particle state after stage `{stage}` (particle id {id})")]
    NonFinite {
        /// The stage.
        stage: &'static str,
        /// Stable id of the first offending particle.
        id: u64,
    },
}
