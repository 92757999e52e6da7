//! The coupled solve's parameters (`solver:` and `coupling:` of a scene),
//! what a solve reports, and why it fails (§7, eq. 24).

use super::codim;
use super::surface::{SurfaceCounts, SurfaceParams};
use super::system::IluOrder;
use crate::grid::pcg::{NotFinite, PcgParams};
use crate::linsolve::{BicgstabParams, SolveError};
use crate::math::{Real, Vec3};
use crate::mls::{FitStats, MlsError};
use serde::{Deserialize, Serialize};

/// How the coupled system is solved.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Method {
    /// eq. (24) as one system [p, u₁, u₂, λ] (the paper).
    #[default]
    Monolithic,
    /// λ eliminated: [u₁, u₂, p].
    Schur,
}

/// The Krylov method of the coupled solve (both right-preconditioned by
/// the same incomplete LU, to the same relative residual).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Krylov {
    /// GMRES(m) with `restart` = m Krylov vectors per cycle
    /// ([`crate::linsolve::gmres()`]): one product with A per iteration.
    Gmres {
        /// Krylov vectors kept per cycle.
        restart: usize,
    },
    /// BiCGSTAB, the paper's ([`crate::linsolve::bicgstab()`]): two
    /// products with A per iteration.
    Bicgstab,
}

/// Default GMRES cycle length (`coupling.restart`): the droplet on a plane
/// after the impact needs up to ~180 vectors, and GMRES(50) stalled there
/// (`docs/decisions.md`, "Two passes of fill, and GMRES").
pub const GMRES_RESTART: usize = 300;

/// Which liquid fraction gives a constraint face its mass (eq. 19's M₍₀₎
/// on the faces the sheet drives).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum FaceMass {
    /// [`FaceMass::Sheet`] with the level set moved (by at most one volume
    /// particle spacing) so that the grid's face masses add up to the
    /// volume particles' mass: the coupled system's inertia is the
    /// liquid's ([`super::faces::Constraints::set_mass_balanced`]). With
    /// P2G's mean (the default `solver.velocity_fit`) it also offsets part
    /// of the mean's bias at the surface; with the linear fit the `sheet`
    /// mass gives the better period (`docs/decisions.md`, "A linear
    /// velocity at the free surface").
    #[default]
    Balanced,
    /// The liquid ends at the sheet layer: the fraction below a level set
    /// half a particle spacing outside the outermost volume particles.
    Sheet,
    /// The ghost-fluid fraction of the pressure solve's level set, which
    /// reaches `surface_radius` Δx past the volume particles.
    LevelSet,
}

/// Which velocity a constraint face is held to (eq. 18's K v = K J u).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum BandVelocity {
    /// (J u)_f: the sheet velocity interpolated onto the face, whatever the
    /// face's distance from the sheet.
    Sheet,
    /// (J u)_f plus the change of the liquid's velocity from each sheet
    /// particle to the face, with the whole velocity gradient read from the
    /// liquid below the band one substep earlier ([`super::band_correction`]).
    #[default]
    Extrapolated,
    /// As [`Self::Extrapolated`], and the faces' velocity before the solve
    /// (v**, the liquid's side of the constraint) extended linearly from
    /// the same points below the band instead of P2G's
    /// ([`super::band_extension`]). With P2G's mean it removed most of the
    /// pure-inertia droplet's loss; with the linear fit it adds nothing to
    /// it and lets the resting droplet's spurious currents grow to 2 mm/s
    /// (`docs/decisions.md`, "A linear velocity at the free surface").
    Extended,
}

/// How a volume's surface layer (sheet particles with a volume particle
/// within h) carries its tension (`coupling.layer`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum LayerTension {
    /// As eq. (24) writes it: the layer's particles carry σS(Lx), the
    /// constraint faces of eq. (18) hand it to the grid (default).
    #[default]
    Coupled,
    /// As a ghost-fluid pressure jump at the free surface, p = −σ n·(Lx)
    /// from the layer's MLS curvature ([`super::jump`]); the layer then
    /// constrains no face, free sheets and filaments keep eq. (24).
    Jump,
    /// The liquid ends at the layer, whose particles close the cells it
    /// crosses ([`super::cut`]): their normal flux enters those cells'
    /// continuity and the cells' pressure pushes on them; the layer
    /// constrains no face, free sheets and filaments keep eq. (24).
    Cut,
}

/// Parameters of the coupled solve.
#[derive(Clone, Debug)]
pub struct CouplingParams {
    /// Which system to solve.
    pub method: Method,
    /// Stopping rule (paper: 1e-9 relative); `max_iter` counts iterations
    /// of the chosen Krylov method.
    pub solver: BicgstabParams,
    /// Krylov method.
    pub krylov: Krylov,
    /// Order of the monolithic system's unknowns for ILU(0).
    pub ilu_order: IluOrder,
    /// Keep the λ–λ fill of the particle rows in ILU(0)'s pattern.
    pub face_fill: bool,
    /// Store the monolithic system's particle block once for the three
    /// velocity components ([`crate::linsolve::Tripled`]; same results).
    pub shared_block: bool,
    /// Passes of level-1 fill in the λ and pressure rows of the monolithic
    /// system's incomplete factorisation (particles-first order only; 0:
    /// ILU(0); [`crate::linsolve::Ilu0::with_tail_fill`]).
    pub fill_passes: usize,
    /// Smallest mass fraction of a constraint face (`coupling.mass_floor`,
    /// [`super::system::MASS_FLOOR`] by default).
    pub mass_floor: Real,
    /// Particle side.
    pub surface: SurfaceParams,
    /// Pressure PCG rule, used when there are no constraint faces.
    pub pressure: PcgParams,
    /// Codimension transitions after each advection (§8); `None` keeps
    /// every particle's codimension.
    pub transitions: Option<crate::transition::TransitionParams>,
    /// Reseeding of the sheets and filaments after the transitions (§9);
    /// `None` leaves the particle set alone.
    pub reseed: Option<crate::reseed::ReseedParams>,
    /// Jet nozzles, where transitions and reseeding are suspended ([`codim::Source`]).
    pub sources: Vec<codim::Source>,
    /// Mass of the constraint faces.
    pub face_mass: FaceMass,
    /// Velocity the constraint faces are held to.
    pub band: BandVelocity,
    /// Level-set radius of the volume particles (× Δx), `solver.surface_radius`.
    pub surface_radius: Real,
    /// How a volume's surface layer carries its tension.
    pub layer: LayerTension,
    /// Also evaluate the residual of the full eq. (24) for the solution
    /// (assembles the monolithic matrix when the Schur method ran).
    pub verify: bool,
}

/// What a coupled solve did.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CouplingInfo {
    /// Liquid cells (pressure unknowns).
    pub cells: usize,
    /// Sheet + filament particles.
    pub particles: usize,
    /// Constraint faces (λ unknowns of eq. 24).
    pub faces: usize,
    /// Unknowns of the system solved.
    pub unknowns: usize,
    /// Non-zeros of its matrix.
    pub nonzeros: usize,
    /// Krylov iterations (BiCGSTAB's take two products with A, GMRES's one).
    pub iterations: usize,
    /// True relative residual of the solved system.
    pub rel_residual: Real,
    /// Relative residual of eq. (24) itself (when verified).
    pub eq24_residual: Option<Real>,
    /// Particle side: areas, forces, Laplacian (s).
    pub operators_s: Real,
    /// Assembly of the system (s).
    pub assemble_s: Real,
    /// ILU(0) factorisation (s).
    pub factor_s: Real,
    /// Krylov solve (s).
    pub solve_s: Real,
    /// Ghost-fluid θ clamps.
    pub theta_clamps: usize,
    /// Unknowns seeded from the previous substep's solution (0: cold start,
    /// or the seeded guess had the larger residual).
    pub warm_seeded: usize,
    /// Solves that failed with the chosen method and were redone with the
    /// other one (a counted fallback).
    pub method_fallbacks: usize,
    /// Constraint faces released around interior liquid cells they enclosed
    /// ([`super::faces::Constraints::release_enclosed`]).
    pub released_faces: usize,
    /// Shift δ/Δx of the level set that gives the constraint faces their
    /// mass (`face_mass: balanced`; 0 otherwise).
    #[serde(default)]
    pub mass_shift: Real,
    /// δ stayed at ± one particle spacing: the face masses could not be
    /// brought to the liquid's.
    #[serde(default)]
    pub mass_shift_bounded: bool,
    /// Solves redone after outlier velocities, with the constraint faces
    /// of the enclosed cells around them released
    /// ([`super::release::outlier_cells`]; at most [`MAX_OUTLIER_ROUNDS`]), plus
    /// the one redone after both methods failed, with the weakly pinned
    /// cells released ([`super::faces::Constraints::release_weak`]).
    pub outlier_rounds: usize,
    /// Why the chosen method failed, when it did.
    #[serde(skip)]
    pub first_failure: Option<String>,
    /// Free-surface faces given the surface layer's pressure jump
    /// (`coupling.layer: jump`; 0 otherwise).
    #[serde(default)]
    pub jump_faces: usize,
    /// Surface-layer particles that carry the jump (deep enough below,
    /// [`super::jump::MIN_DEPTH`]); the others keep eq. (24).
    #[serde(default)]
    pub jump_particles: usize,
    /// Liquid cells turned to air by moving the level set onto the surface
    /// layer (`coupling.layer: jump`; 0 otherwise).
    #[serde(default)]
    pub trimmed_cells: usize,
    /// Liquid cells the surface layer closes (`coupling.layer: cut`; 0
    /// otherwise), and of them the free ones: no layer particle within
    /// reach, a ghost-fluid free surface ([`super::cut::Cut::free`]).
    #[serde(default)]
    pub cut_cells: usize,
    /// See `cut_cells`.
    #[serde(default)]
    pub cut_free_cells: usize,
    /// Liquid faces of the cut whose particle mass fell below
    /// [`super::cut::MASS_FLOOR`] of their area (their inertia is floored).
    #[serde(default)]
    pub cut_light_faces: usize,
    /// Mean pressure (Pa) of the liquid cells deeper than Δx below the
    /// surface (0 if none): the Young–Laplace jump of a droplet at rest.
    pub interior_pressure: Real,
    /// Particle classification.
    pub counts: SurfaceCounts,
    /// MLS fits.
    pub fits: FitStats,
}

/// Why a coupled solve failed.
#[derive(Debug, thiserror::Error)]
pub enum CouplingError {
    /// The MLS operators could not be built.
    #[error("MLS operators of the sheet/filament particles: {0}")]
    Mls(#[from] MlsError),
    /// A linear solve failed.
    #[error("{stage}: {source}")]
    Solve {
        /// Which solve.
        stage: &'static str,
        /// Why.
        source: SolveError,
    },
    /// The chosen method failed and so did the other one.
    #[error("{first}; the other method failed too: {second}")]
    BothFailed {
        /// Why the chosen method failed.
        first: String,
        /// Why the other one failed.
        second: Box<CouplingError>,
    },
    /// The solution still jumps by more than the substep's physical
    /// velocity scale allows ([`super::release::outlier_bound`]) after the
    /// enclosed cells around the outliers lost their constraint faces.
    #[error(
        "coupled solve: velocity jump beyond {bound:.3} m/s at ({:.4}, {:.4}, {:.4}) m after {rounds} rounds of releasing constraint faces",
        at[0], at[1], at[2]
    )]
    Outlier {
        /// Centre of the first outlier cell (m).
        at: Vec3,
        /// The bound (m/s).
        bound: Real,
        /// Rounds of releases done.
        rounds: usize,
    },
    /// The uncoupled pressure solve failed.
    #[error("pressure projection: {0}")]
    Pressure(NotFinite),
}

/// Solves redone after outliers before a substep fails
/// ([`CouplingError::Outlier`]).
pub const MAX_OUTLIER_ROUNDS: usize = 3;
