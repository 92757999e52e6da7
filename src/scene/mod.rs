//! Scene description: one typed struct loaded from YAML (`docs/scene-format.md`).
//!
//! Every field states its SI unit; lengths relative to the grid cell say so.
//! Defaults follow the paper where it gives a value (Appendix E: ρ = 1000 kg/m³;
//! Appendix F: initial particle spacing Δx/3, cell size Δx = h).
//!
//! Loading is strict ([`load`]): unknown keys, wrong types, missing required
//! fields and physically invalid values are rejected before any work, with the
//! file, the field path, the line and column, and the reason ([`SceneError`]).
//!
//! Extension points for later stages: `bodies` is a list tagged by `kind`
//! (sheets, filaments and rings add variants to [`FluidBody`]); emitters,
//! wind, transitions and reseeding get their own top-level sections when their
//! stages exist.

mod films;
mod jets;
mod load;
mod sample;
mod validate;

pub use films::{sample_films, FilmBody, FilmImplicit, FilmSettings, RimModulation, WindSettings};
pub use jets::{
    BandSetting, CouplingMethod, CouplingSettings, FaceMassSetting, JetPattern, JetSettings,
    KrylovSetting,
};
pub use load::{load, load_str, load_str_scaled, SceneError};
pub use sample::{sample_bodies, SampleReport};

use serde::{Deserialize, Serialize};

/// Schema version this build reads.
pub const SCHEMA_VERSION: u32 = 1;

/// A whole scene.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// Schema version; must equal [`SCHEMA_VERSION`].
    pub version: u32,
    /// Simulation box and grid.
    pub domain: Domain,
    /// Frame rate, frame count and time-step limits.
    pub time: TimeSettings,
    /// Material constants and external forces.
    #[serde(default)]
    pub physics: Physics,
    /// Numerical settings of the volume solver.
    #[serde(default)]
    pub solver: SolverSettings,
    /// Liquid bodies present at t = 0.
    #[serde(default)]
    pub bodies: Vec<FluidBody>,
    /// Thin films present at t = 0 (sheet particles, rings). A scene with
    /// films and no liquid body runs without a grid.
    #[serde(default)]
    pub films: Vec<FilmBody>,
    /// Settings of the sheet/filament solver.
    #[serde(default)]
    pub film: FilmSettings,
    /// Cylindrical jets emitting liquid during the run (Appendix F).
    #[serde(default)]
    pub jets: Vec<JetSettings>,
    /// Settings of the monolithic grid–particle coupling (eq. 24).
    #[serde(default)]
    pub coupling: CouplingSettings,
    /// Static solids (the domain box is always a closed container as well).
    #[serde(default)]
    pub solids: Vec<Solid>,
    /// Where and under which name caches are written.
    #[serde(default)]
    pub output: Output,
}

/// The simulation box, closed by walls, and the MAC-grid cell size.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Domain {
    /// Lower corner (m).
    pub min: [f64; 3],
    /// Upper corner (m).
    pub max: [f64; 3],
    /// Cell size Δx = h (m).
    pub dx: f64,
}

/// Time settings.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct TimeSettings {
    /// Frames per second (1/s).
    pub fps: f64,
    /// Number of frames to simulate (frame 0, the initial state, is extra).
    pub frames: u32,
    /// Largest substep (s); substeps are also limited by the CFL number.
    #[serde(default = "default_max_dt")]
    pub max_dt: f64,
    /// CFL number: cells a particle may cross per substep.
    #[serde(default = "default_cfl")]
    pub cfl: f64,
}

/// Material constants and external forces.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Physics {
    /// Liquid density ρ (kg/m³).
    #[serde(default = "default_density")]
    pub density: f64,
    /// Surface tension σ (N/m), ≥ 0.
    #[serde(default)]
    pub surface_tension: f64,
    /// Dynamic viscosity μ (Pa·s; the paper's Table 2 lists mPa·s: 0.25 mPa·s = 2.5e-4 Pa·s).
    #[serde(default)]
    pub viscosity: f64,
    /// Gravity (m/s²).
    #[serde(default = "default_gravity")]
    pub gravity: [f64; 3],
    /// Extra uniform body acceleration (m/s²), added to gravity.
    #[serde(default)]
    pub body_force: [f64; 3],
}

/// Numerical settings of the volume solver.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SolverSettings {
    /// Particle–grid transfer: `flip` (PIC/FLIP blend, Zhu & Bridson 2005) or
    /// `apic` (affine particle-in-cell, Jiang et al. 2015).
    #[serde(default)]
    pub transfer: Transfer,
    /// FLIP fraction of the PIC/FLIP blend (0 = PIC, 1 = FLIP); used when `transfer: flip`.
    #[serde(default = "default_flip")]
    pub flip: f64,
    /// Relative residual (‖r‖₂/‖b‖₂) at which the pressure PCG stops.
    #[serde(default = "default_tol")]
    pub pressure_tolerance: f64,
    /// Iteration cap of the pressure PCG.
    #[serde(default = "default_iters")]
    pub pressure_max_iterations: u32,
    /// Relative residual at which each viscosity PCG stops.
    #[serde(default = "default_tol")]
    pub viscosity_tolerance: f64,
    /// Iteration cap of each viscosity PCG.
    #[serde(default = "default_iters")]
    pub viscosity_max_iterations: u32,
    /// Radius of each particle's sphere in the liquid level set, relative to Δx.
    #[serde(default = "default_surface_radius")]
    pub surface_radius: f64,
    /// Keep liquid surfaces that approach each other apart on the grid: both
    /// cells of a face that the volume particles near it do not join are
    /// air, until the particles meet (`grid::bodies`).
    #[serde(default)]
    pub separate_bodies: bool,
    /// Particle-free liquid cells between two liquid surfaces are air
    /// (`grid::transfer::gap_cells`), so approaching surfaces meet.
    #[serde(default = "default_true")]
    pub open_gaps: bool,
    /// How P2G and the velocity extrapolation read the particles near the
    /// free surface: `linear` (a least-squares linear fit at each face and a
    /// linear first two layers of extrapolation) or `mean` (the weighted mean and
    /// a constant extension).
    #[serde(default)]
    pub velocity_fit: crate::grid::VelocityFit,
}

/// Particle–grid velocity transfer scheme.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum Transfer {
    /// PIC/FLIP blend with the fraction `solver.flip`.
    #[default]
    Flip,
    /// APIC: each particle carries an affine velocity matrix.
    Apic,
}

/// A liquid body at t = 0, sampled into codimension-0 particles (Appendix F).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum FluidBody {
    /// Axis-aligned box, sampled on a regular lattice.
    Box {
        /// Lower corner (m).
        min: [f64; 3],
        /// Upper corner (m).
        max: [f64; 3],
        /// Initial velocity (m/s).
        #[serde(default)]
        velocity: [f64; 3],
        /// Particle spacing relative to Δx.
        #[serde(default = "default_spacing")]
        spacing: f64,
        /// Outermost layer of particles sampled as sheet particles (Appendix F);
        /// `None` = yes when σ > 0 ([`FluidBody::surface_layer`]).
        #[serde(default)]
        surface_layer: Option<bool>,
    },
    /// Sphere, sampled on equidistant concentric shells (Appendix F).
    Sphere {
        /// Centre (m).
        center: [f64; 3],
        /// Radius (m).
        radius: f64,
        /// Initial velocity (m/s).
        #[serde(default)]
        velocity: [f64; 3],
        /// Particle spacing relative to Δx.
        #[serde(default = "default_spacing")]
        spacing: f64,
        /// Outermost layer of particles sampled as sheet particles (Appendix F);
        /// `None` = yes when σ > 0 ([`FluidBody::surface_layer`]).
        #[serde(default)]
        surface_layer: Option<bool>,
    },
    /// Axis-aligned ellipsoid, sampled on a regular lattice.
    Ellipsoid {
        /// Centre (m).
        center: [f64; 3],
        /// Semi-axes along x, y, z (m).
        radii: [f64; 3],
        /// Initial velocity (m/s).
        #[serde(default)]
        velocity: [f64; 3],
        /// Particle spacing relative to Δx.
        #[serde(default = "default_spacing")]
        spacing: f64,
        /// Outermost layer of particles sampled as sheet particles (Appendix F);
        /// `None` = yes when σ > 0 ([`FluidBody::surface_layer`]).
        #[serde(default)]
        surface_layer: Option<bool>,
    },
    /// Finite cylinder, sampled on a regular lattice.
    Cylinder {
        /// Centre of the axis segment (m).
        center: [f64; 3],
        /// Axis direction (normalised on load).
        axis: [f64; 3],
        /// Radius (m).
        radius: f64,
        /// Length along the axis (m).
        height: f64,
        /// Initial velocity (m/s).
        #[serde(default)]
        velocity: [f64; 3],
        /// Particle spacing relative to Δx.
        #[serde(default = "default_spacing")]
        spacing: f64,
        /// Outermost layer of particles sampled as sheet particles (Appendix F);
        /// `None` = yes when σ > 0 ([`FluidBody::surface_layer`]).
        #[serde(default)]
        surface_layer: Option<bool>,
    },
}

/// A static solid (Appendix C: cut-cell boundary in the projection).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Solid {
    /// Half space: solid on the side opposite to `normal`.
    Plane {
        /// A point on the plane (m).
        point: [f64; 3],
        /// Normal pointing into the liquid side.
        normal: [f64; 3],
    },
    /// Axis-aligned box.
    Box {
        /// Lower corner (m).
        min: [f64; 3],
        /// Upper corner (m).
        max: [f64; 3],
    },
    /// Sphere.
    Sphere {
        /// Centre (m).
        center: [f64; 3],
        /// Radius (m).
        radius: f64,
    },
    /// Finite capped cylinder.
    Cylinder {
        /// Centre of the axis segment (m).
        center: [f64; 3],
        /// Axis direction.
        axis: [f64; 3],
        /// Radius (m).
        radius: f64,
        /// Length along the axis (m).
        height: f64,
    },
    /// Hollow cylinder open at both ends (a pipe or nozzle): the solid is the
    /// wall between `inner_radius` and `outer_radius`.
    Pipe {
        /// Centre of the axis segment (m).
        center: [f64; 3],
        /// Axis direction.
        axis: [f64; 3],
        /// Radius of the bore (m).
        inner_radius: f64,
        /// Outer radius of the wall (m), > `inner_radius`.
        outer_radius: f64,
        /// Length along the axis (m).
        height: f64,
    },
}

/// Output settings.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq, Default)]
#[serde(deny_unknown_fields)]
pub struct Output {
    /// Folder name of the cache (default: the scene file's stem).
    #[serde(default)]
    pub name: Option<String>,
    /// Parent folder of the cache when `-o` is not given (default `cache`).
    #[serde(default)]
    pub dir: Option<String>,
}

fn default_max_dt() -> f64 {
    0.01
}
fn default_cfl() -> f64 {
    1.0
}
fn default_density() -> f64 {
    1000.0
}
fn default_gravity() -> [f64; 3] {
    [0.0, -9.81, 0.0]
}
fn default_flip() -> f64 {
    0.95
}
fn default_tol() -> f64 {
    1e-8
}
fn default_iters() -> u32 {
    1000
}
fn default_true() -> bool {
    true
}
fn default_surface_radius() -> f64 {
    0.75
}
fn default_spacing() -> f64 {
    1.0 / 3.0
}

impl Default for Physics {
    fn default() -> Self {
        Physics {
            density: default_density(),
            surface_tension: 0.0,
            viscosity: 0.0,
            gravity: default_gravity(),
            body_force: [0.0; 3],
        }
    }
}

impl Default for SolverSettings {
    fn default() -> Self {
        SolverSettings {
            transfer: Transfer::Flip,
            flip: default_flip(),
            pressure_tolerance: default_tol(),
            pressure_max_iterations: default_iters(),
            viscosity_tolerance: default_tol(),
            viscosity_max_iterations: default_iters(),
            surface_radius: default_surface_radius(),
            separate_bodies: false,
            open_gaps: true,
            velocity_fit: crate::grid::VelocityFit::Mean,
        }
    }
}

impl FluidBody {
    /// Particle spacing relative to Δx.
    pub fn spacing(&self) -> f64 {
        match self {
            FluidBody::Box { spacing, .. }
            | FluidBody::Sphere { spacing, .. }
            | FluidBody::Ellipsoid { spacing, .. }
            | FluidBody::Cylinder { spacing, .. } => *spacing,
        }
    }

    /// Whether the outermost layer of the body's particles is sampled as
    /// sheet particles (Appendix F), given the scene's surface tension σ
    /// (N/m): the body's `surface_layer` when set, else σ > 0.
    pub fn surface_layer(&self, sigma: f64) -> bool {
        let s = match self {
            FluidBody::Box { surface_layer, .. }
            | FluidBody::Sphere { surface_layer, .. }
            | FluidBody::Ellipsoid { surface_layer, .. }
            | FluidBody::Cylinder { surface_layer, .. } => *surface_layer,
        };
        s.unwrap_or(sigma > 0.0)
    }

    /// Initial velocity (m/s).
    pub fn velocity(&self) -> [f64; 3] {
        match self {
            FluidBody::Box { velocity, .. }
            | FluidBody::Sphere { velocity, .. }
            | FluidBody::Ellipsoid { velocity, .. }
            | FluidBody::Cylinder { velocity, .. } => *velocity,
        }
    }
}

impl Scene {
    /// True when the scene has liquid (bodies or jets) and so runs on the grid;
    /// false for film-only scenes.
    pub fn has_liquid(&self) -> bool {
        !self.bodies.is_empty() || !self.jets.is_empty()
    }

    /// The same scene at a coarser (S > 1) or finer (S < 1) resolution: Δx is
    /// multiplied by `s`; every particle spacing is relative to Δx and so
    /// follows (`codimfx sim --scale S`). Lengths of bodies, jets and solids
    /// are unchanged. The result must be validated again.
    pub fn scaled(&self, s: f64) -> Scene {
        let mut out = self.clone();
        out.domain.dx *= s;
        out
    }

    /// Total body acceleration: gravity plus the uniform body force (m/s²).
    pub fn acceleration(&self) -> [f64; 3] {
        let g = self.physics.gravity;
        let f = self.physics.body_force;
        [g[0] + f[0], g[1] + f[1], g[2] + f[2]]
    }
}
