//! Jets and coupling settings in scene files.
//!
//! `jets:` lists cylindrical jets (paper Appendix F): each emits disk-shaped
//! layers of particles, an equidistributed circle pattern whose outline is
//! sheet particles, at a rate set by its speed ([`crate::emitter::Jet`]).
//! `coupling:` holds the settings of the monolithic grid–particle solve of
//! eq. (24) (§7).

use super::Scene;
use crate::emitter::Jet;
use crate::math::Vec3;
use serde::{Deserialize, Serialize};

/// A cylindrical jet (Appendix F).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct JetSettings {
    /// Centre of the nozzle opening (m).
    pub origin: [f64; 3],
    /// Direction of flow (normalised on use).
    pub direction: [f64; 3],
    /// Jet radius R (m): radius of the outline circle of sheet particles.
    pub radius: f64,
    /// Speed v₀ (m/s), > 0; a layer leaves the nozzle every spacing / v₀ seconds.
    pub speed: f64,
    /// Particle spacing relative to Δx (Appendix F: 1/3).
    #[serde(default = "default_spacing")]
    pub spacing: f64,
    /// Time the jet starts emitting (s).
    #[serde(default)]
    pub start: f64,
    /// Time the jet stops emitting (s); `None` = never.
    #[serde(default)]
    pub stop: Option<f64>,
    /// Layout of a layer's circles: `aligned` (Appendix F: every circle
    /// starts at angle 0, which lines the particles up in quasi-hexagonal
    /// spokes) or `staggered` (circle k turned by frac(k φ) of its angular
    /// step: no spokes).
    #[serde(default)]
    pub pattern: JetPattern,
}

/// `jets[].pattern`.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum JetPattern {
    /// Every circle starts at angle 0 (Appendix F).
    #[default]
    Aligned,
    /// Circle k turned by frac(k φ) of its angular step.
    Staggered,
}

/// Linear solver of the monolithic coupling system (eq. 24).
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum CouplingMethod {
    /// The whole system at once, preconditioned by an incomplete LU, as in
    /// the paper.
    #[default]
    Monolithic,
    /// Schur-complement elimination of the impulses λ.
    Schur,
}

/// Settings of the monolithic grid–particle coupling (§7, eq. 24).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CouplingSettings {
    /// Relative residual ‖r‖₂/‖b‖₂ at which the solve stops (paper: 1e-9).
    #[serde(default = "default_tolerance")]
    pub tolerance: f64,
    /// Iteration cap of the solve.
    #[serde(default = "default_max_iterations")]
    pub max_iterations: u32,
    /// How the system is solved.
    #[serde(default)]
    pub method: CouplingMethod,
    /// Krylov method: `gmres` (default: one product with the matrix per
    /// iteration, the residual minimised over each cycle) or `bicgstab`
    /// (the paper's).
    #[serde(default)]
    pub krylov: KrylovSetting,
    /// GMRES cycle length: Krylov vectors kept before a restart (memory:
    /// this many vectors of the system's size).
    #[serde(default = "default_restart")]
    pub restart: u32,
    /// Which liquid fraction gives the constraint faces their mass:
    /// `balanced` (the liquid ends at the sheet layer, moved so that the
    /// grid carries the volume particles' mass), `sheet` (the liquid ends
    /// at the sheet layer) or `level_set` (the pressure solve's level set,
    /// which reaches past it).
    #[serde(default)]
    pub face_mass: FaceMassSetting,
    /// Velocity the constraint faces are held to, and the liquid's
    /// velocity there before the solve: `extrapolated` (the sheet's
    /// velocity plus the liquid's velocity change from the sheet to the
    /// face; the faces' own velocity from P2G), `extended` (the same held
    /// velocity; the faces' own velocity extended linearly from 2Δx inside
    /// the liquid) or `sheet` (the sheet's own velocity, the faces' from
    /// P2G).
    #[serde(default)]
    pub band: BandSetting,
    /// How a volume's surface layer carries its tension: `coupled` (eq. 24,
    /// through the constraint faces) or `jump` (a ghost-fluid pressure jump
    /// σκ at the free surface from the layer's MLS curvature; free sheets
    /// and filaments keep eq. 24).
    #[serde(default)]
    pub layer: crate::coupling::LayerTension,
    /// Order of the monolithic system's unknowns for ILU(0): `equation`
    /// ([q, u, λ] as eq. 24 writes it) or `particles_first` ([u, λ, q], the
    /// particles in reverse Cuthill–McKee order).
    #[serde(default)]
    pub ordering: crate::coupling::IluOrder,
    /// Keep in ILU(0)'s pattern the impulse–impulse entries that
    /// eliminating the particle rows fills in (faces of one axis sharing a
    /// particle); the stored values are zeros, the system is unchanged.
    #[serde(default = "default_face_fill")]
    pub face_fill: bool,
    /// Store the monolithic system's particle block once for the three
    /// velocity components (`I₃ ⊗ P`); `false` stores general rows. The
    /// results are the same bit for bit; shared is faster.
    #[serde(default = "default_shared_block")]
    pub shared_block: bool,
    /// Factorise the monolithic system with one level of fill in its
    /// impulse and pressure rows, among their own columns (`false`: ILU(0)
    /// on A's pattern). Same system and tolerance; far fewer iterations.
    #[serde(default = "default_tail_fill")]
    pub tail_fill: bool,
    /// Passes of that fill (with `tail_fill`), in [1, 3]: each pass adds
    /// the fill that eliminating with the pattern so far creates (1: ILU(1)'s
    /// pattern in those rows; 2, the default: it holds ILU(2)'s).
    #[serde(default = "default_fill_passes")]
    pub fill_passes: u32,
    /// Smallest mass fraction of a constraint face, in (0, 1]. The faces
    /// outside the sheet carry (nearly) no liquid; the floor keeps the
    /// monolithic system's face rows bounded. Smaller is more accurate
    /// (the l = 2 period) and costs iterations (`docs/decisions.md`).
    #[serde(default = "default_mass_floor")]
    pub mass_floor: f64,
    /// Implicit weight θ of the tension, in [0.5, 1]: the particles feel
    /// σS L(xⁿ + θΔt uⁿ⁺¹). The paper's backward Euler (1) damps a capillary
    /// oscillation of frequency ω by e^{−πωΔt} a period; 0.5 halves that
    /// exponent and is the smallest θ that stays stable at any Δt
    /// (`docs/decisions.md`, "The tension's implicit weight").
    #[serde(default = "default_tension_theta")]
    pub tension_theta: f64,
}

/// `coupling.krylov`.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum KrylovSetting {
    /// Restarted GMRES (default).
    #[default]
    Gmres,
    /// BiCGSTAB (the paper's).
    Bicgstab,
}

fn default_restart() -> u32 {
    crate::coupling::GMRES_RESTART as u32
}

fn default_mass_floor() -> f64 {
    crate::coupling::system::MASS_FLOOR
}

fn default_tension_theta() -> f64 {
    crate::coupling::system::TENSION_THETA
}

/// `coupling.band`.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum BandSetting {
    /// The sheet's interpolated velocity.
    Sheet,
    /// Carried to the face with the liquid's velocity gradient (default).
    #[default]
    Extrapolated,
    /// As `extrapolated`, and the faces' own velocity extended from inside
    /// the liquid.
    Extended,
}

fn default_face_fill() -> bool {
    true
}

fn default_shared_block() -> bool {
    true
}

fn default_fill_passes() -> u32 {
    2
}

fn default_tail_fill() -> bool {
    true
}

/// `coupling.face_mass`.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum FaceMassSetting {
    /// As `sheet`, with the level set moved so that the face masses add up
    /// to the volume particles' mass (default).
    #[default]
    Balanced,
    /// The liquid ends at the sheet layer.
    Sheet,
    /// The pressure solve's level set.
    LevelSet,
}

impl Default for CouplingSettings {
    fn default() -> Self {
        CouplingSettings {
            tolerance: default_tolerance(),
            max_iterations: default_max_iterations(),
            method: CouplingMethod::Monolithic,
            krylov: KrylovSetting::Gmres,
            restart: default_restart(),
            face_mass: FaceMassSetting::Balanced,
            band: BandSetting::Extrapolated,
            layer: crate::coupling::LayerTension::Coupled,
            ordering: crate::coupling::IluOrder::default(),
            face_fill: default_face_fill(),
            shared_block: default_shared_block(),
            tail_fill: default_tail_fill(),
            fill_passes: default_fill_passes(),
            mass_floor: default_mass_floor(),
            tension_theta: default_tension_theta(),
        }
    }
}

fn default_spacing() -> f64 {
    1.0 / 3.0
}
fn default_tolerance() -> f64 {
    1e-9
}
fn default_max_iterations() -> u32 {
    2000
}

impl JetSettings {
    /// The emitter of this jet in a scene with cell size `dx` (m) and density `rho` (kg/m³).
    pub fn emitter(&self, dx: f64, rho: f64) -> Jet {
        Jet {
            origin: Vec3::from(self.origin),
            direction: Vec3::from(self.direction).normalize(),
            radius: self.radius,
            speed: self.speed,
            spacing: self.spacing * dx,
            start: self.start,
            stop: self.stop.unwrap_or(f64::INFINITY),
            density: rho,
            stagger: self.pattern == JetPattern::Staggered,
        }
    }
}

type Check = Result<(), (String, String)>;

fn fail(path: impl Into<String>, reason: impl Into<String>) -> Check {
    Err((path.into(), reason.into()))
}

/// Largest number of particles in one emitted layer.
const MAX_LAYER: f64 = 1e6;

/// Checks the jets and the coupling settings (field path, reason).
pub fn validate(s: &Scene) -> Check {
    let d = &s.domain;
    for (i, j) in s.jets.iter().enumerate() {
        let p = |f: &str| format!("jets[{i}].{f}");
        if !j.origin.iter().all(|c| c.is_finite()) {
            return fail(p("origin"), format!("{:?} is not finite", j.origin));
        }
        let r = if j.radius.is_finite() { j.radius } else { 0.0 };
        if !(0..3).all(|k| j.origin[k] - r >= d.min[k] && j.origin[k] + r <= d.max[k]) {
            return fail(
                p("origin"),
                format!(
                    "nozzle (centre {:?}, radius {r} m) leaves the domain {:?}–{:?}",
                    j.origin, d.min, d.max
                ),
            );
        }
        let n2: f64 = j.direction.iter().map(|c| c * c).sum();
        if !(j.direction.iter().all(|c| c.is_finite()) && n2 > 1e-24) {
            return fail(
                p("direction"),
                format!("direction {:?} must be finite and non-zero", j.direction),
            );
        }
        if !(j.radius.is_finite() && j.radius > 0.0) {
            return fail(
                p("radius"),
                format!("must be positive and finite, got {}", j.radius),
            );
        }
        if !(j.speed.is_finite() && j.speed > 0.0) {
            return fail(
                p("speed"),
                format!("must be positive and finite, got {} m/s", j.speed),
            );
        }
        if !(j.spacing.is_finite() && j.spacing > 0.0 && j.spacing <= 1.0) {
            return fail(
                p("spacing"),
                format!("must be in (0, 1] (relative to dx), got {}", j.spacing),
            );
        }
        let sp = j.spacing * d.dx;
        if j.radius < sp {
            return fail(
                p("radius"),
                format!(
                    "radius {} m is smaller than the particle spacing {sp} m (spacing x dx)",
                    j.radius
                ),
            );
        }
        let per_layer = std::f64::consts::PI * (j.radius / sp + 0.5).powi(2);
        if per_layer > MAX_LAYER {
            return fail(
                p("spacing"),
                format!("spacing {sp} m puts ~{per_layer:.0} particles in one layer (limit 1e6)"),
            );
        }
        if !(j.start.is_finite() && j.start >= 0.0) {
            return fail(
                p("start"),
                format!("must be >= 0 s and finite, got {}", j.start),
            );
        }
        if let Some(stop) = j.stop {
            if !(stop.is_finite() && stop > j.start) {
                return fail(
                    p("stop"),
                    format!("must be finite and after start = {} s, got {stop}", j.start),
                );
            }
        }
    }
    let c = &s.coupling;
    if !(c.tolerance.is_finite() && c.tolerance > 0.0 && c.tolerance < 1.0) {
        return fail(
            "coupling.tolerance",
            format!("must be in (0, 1), got {}", c.tolerance),
        );
    }
    if c.max_iterations == 0 {
        return fail("coupling.max_iterations", "must be at least 1");
    }
    if !(1..=3).contains(&c.fill_passes) {
        return fail(
            "coupling.fill_passes",
            format!("must be 1, 2 or 3, got {}", c.fill_passes),
        );
    }
    if !(1..=5000).contains(&c.restart) {
        return fail(
            "coupling.restart",
            format!("must be in [1, 5000], got {}", c.restart),
        );
    }
    if !(c.mass_floor.is_finite() && (1e-4..=1.0).contains(&c.mass_floor)) {
        return fail(
            "coupling.mass_floor",
            format!("must be in [1e-4, 1], got {}", c.mass_floor),
        );
    }
    if !(c.tension_theta.is_finite() && (0.5..=1.0).contains(&c.tension_theta)) {
        return fail(
            "coupling.tension_theta",
            format!("must be in [0.5, 1], got {}", c.tension_theta),
        );
    }
    Ok(())
}
