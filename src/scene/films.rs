//! Thin films in scene files: film bodies (membranes sampled as sheet
//! particles, with optional rings of static boundary particles) and the
//! `film:` settings of the codimension-1/2 solver. A scene whose only bodies
//! are films runs without a grid (`docs/scene-format.md`).
//!
//! Sampling (paper Appendix F, "sampled in a similar way" to the circle
//! patterns): spheres by latitude circles, cylinders by circles along the
//! axis, disks by concentric circles — every spacing equal to the particle
//! spacing. Masses are uniform, m = ρ τ A / N with τ the film thickness and
//! A the film's area; ring particles (Appendix C) are fixed sheet particles
//! that take part in the MLS fits and move only with their prescribed
//! velocity.

use super::Scene;
use crate::emitter::circle_pattern;
use crate::film::deformation::latitude_sphere;
use crate::math::{Real, Vec3};
use crate::particles::{Codim, Particles};
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// A film body.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum FilmBody {
    /// A spherical film (bubble), optionally with a hole (bursting bubble).
    Sphere {
        /// Centre (m).
        center: [f64; 3],
        /// Radius (m).
        radius: f64,
        /// Half-angle (rad) of the cap removed around `hole_axis`; 0 = closed.
        #[serde(default)]
        hole_angle: f64,
        /// Direction of the hole's centre from the sphere's centre.
        #[serde(default = "up")]
        hole_axis: [f64; 3],
        /// Initial velocity (m/s).
        #[serde(default)]
        velocity: [f64; 3],
        /// Particle spacing relative to Δx.
        #[serde(default = "default_spacing")]
        spacing: f64,
    },
    /// A cylindrical membrane spanning two coaxial rings (film catenoid).
    Cylinder {
        /// Centre (m).
        center: [f64; 3],
        /// Axis direction.
        axis: [f64; 3],
        /// Radius (m).
        radius: f64,
        /// Length between the rings (m).
        length: f64,
        /// Each ring moves away from the centre along the axis at this speed (m/s).
        #[serde(default)]
        ring_speed: f64,
        /// Particle spacing relative to Δx.
        #[serde(default = "default_spacing")]
        spacing: f64,
    },
    /// A flat membrane held by a ring (blowing bubble).
    Disk {
        /// Centre (m).
        center: [f64; 3],
        /// Normal direction.
        normal: [f64; 3],
        /// Radius of the ring (m).
        radius: f64,
        /// Particle spacing relative to Δx.
        #[serde(default = "default_spacing")]
        spacing: f64,
    },
}

/// Wind blowing on films.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct WindSettings {
    /// Wind velocity (m/s).
    pub velocity: [f64; 3],
    /// Normal drag coefficient (dimensionless).
    #[serde(default = "one")]
    pub drag: f64,
    /// Air density (kg/m³).
    #[serde(default = "air")]
    pub air_density: f64,
    /// Gusts: the wind blows only during them (still air in between).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gust: Option<GustSettings>,
    /// A jet of this radius (m) instead of a uniform wind.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub radius: Option<f64>,
    /// A point on the jet's axis (m); the axis runs along `velocity`.
    #[serde(default)]
    pub origin: [f64; 3],
}

/// `film.wind.gust`: on from `start` for `duration`, every `period` seconds
/// (a single gust when `period` is 0 or absent).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct GustSettings {
    /// Start of the first gust (s).
    #[serde(default)]
    pub start: f64,
    /// Length of each gust (s).
    pub duration: f64,
    /// Time between the starts of two gusts (s); 0 = one gust.
    #[serde(default)]
    pub period: f64,
    /// Fraction of the velocity that blows between gusts (0 = still air).
    #[serde(default)]
    pub between: f64,
}

/// Saw-tooth modulation of the rim tension for the fluid polygon (§10.2,
/// Fig. 16): the rim tension is multiplied by 1 + a·(2·frac(k·(φ − φ₀)/2π) − 1),
/// φ the yaw angle of the particle about the vertical (y) axis through
/// `center` and φ₀ the `phase`.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct RimModulation {
    /// Number of teeth k (corners of the polygon), ≥ 2.
    pub corners: u32,
    /// Amplitude a, in [0, 1).
    pub amplitude: f64,
    /// Point on the vertical axis of the yaw angle (m).
    pub center: [f64; 3],
    /// Turn of the teeth about the axis (degrees); the drops of the tooth
    /// function sit at `phase` + j·360°/k.
    #[serde(default)]
    pub phase: f64,
}

impl RimModulation {
    /// The solver's saw-tooth.
    pub fn sawtooth(&self) -> crate::tension::Sawtooth {
        crate::tension::Sawtooth {
            corners: self.corners,
            amplitude: self.amplitude,
            centre: self.center.into(),
            phase: self.phase.to_radians(),
        }
    }
}

/// Settings of the sheet/filament solver.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct FilmSettings {
    /// Film thickness τ (m); sets the particle masses. Soap films: 0.1–10 µm.
    #[serde(default = "default_thickness")]
    pub thickness: f64,
    /// Linear air drag on film particles (1/s); 0 = none.
    #[serde(default)]
    pub damping: f64,
    /// Closed or bursting films hold a soft gas pocket (docs: `gas` module).
    #[serde(default)]
    pub gas: bool,
    /// Wind on films.
    #[serde(default)]
    pub wind: Option<WindSettings>,
    /// The air inside a film blown off its ring and inside the bubbles it
    /// makes (`film::air`): needs `wind` and a `disk` film.
    #[serde(default)]
    pub bag_air: bool,
    /// A soap film hung from a ring carries the part of its weight along the
    /// film to the ring (Gibbs–Marangoni elasticity, `film::weight`): its
    /// sheet particles feel only gravity's normal part, and it does not
    /// drain into the ring. Off: the paper's liquid sheet.
    #[serde(default)]
    pub marangoni: bool,
    /// MLS fit order of the tension operator (2–4; default 3).
    #[serde(default = "default_order")]
    pub order: usize,
    /// Codimension transitions (§8).
    #[serde(default = "yes")]
    pub transitions: bool,
    /// Reseeding (§9).
    #[serde(default = "yes")]
    pub reseed: bool,
    /// Largest motion per substep, in particle spacings.
    #[serde(default = "default_film_cfl")]
    pub cfl: f64,
    /// Largest motion per substep of a droplet (point particle), in particle
    /// spacings; `cfl` when absent. In a film scene a droplet moves
    /// ballistically (gravity and drag) and meets nothing but the domain box,
    /// so this bounds no error of the droplets' own: it sets how much fast
    /// droplets shorten the films' substeps (docs/decisions.md, "Motion limit
    /// and points").
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub point_cfl: Option<f64>,
    /// Largest motion per substep, in particle spacings, of a sheet or
    /// filament particle that moves *with* its neighbours (within h); its
    /// speed relative to them stays limited by `cfl`. Absent: the absolute
    /// speed is limited by `cfl` (every scene before session 29). A bubble
    /// that drifts away whole needs no short step for its drift. Not
    /// applied while a jet (`film.wind.radius`) blows (docs/decisions.md,
    /// "Motion limit and drift").
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub drift_cfl: Option<f64>,
    /// Speed limit (m/s) applied as a counted fallback; 0 = none.
    #[serde(default)]
    pub max_speed: f64,
    /// BiCGSTAB relative tolerance (paper: 1e-9).
    #[serde(default = "default_film_tol")]
    pub solver_tolerance: f64,
    /// BiCGSTAB iteration budget.
    #[serde(default = "default_film_iters")]
    pub solver_max_iterations: usize,
    /// Saw-tooth modulation of the rim tension (fluid polygon); none by default.
    #[serde(default)]
    pub rim_modulation: Option<RimModulation>,
    /// What of the MLS Laplacian the semi-implicit tension (eq. 16) takes
    /// implicitly: `full` (the paper) or `diffusive`.
    #[serde(default)]
    pub implicit: FilmImplicit,
}

/// `film.implicit`.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum FilmImplicit {
    /// The whole Laplacian, as eq. (16).
    #[default]
    Full,
    /// Its diffusive part (non-negative off-diagonals, zero row sum), the
    /// rest on the previous velocity: a system that stays an M-matrix
    /// whatever the step ([`crate::tension::split`]).
    Diffusive,
}

impl FilmSettings {
    /// Whether the tension takes only the diffusive part of L implicitly.
    pub fn diffusive(&self) -> bool {
        self.implicit == FilmImplicit::Diffusive
    }
}

impl Default for FilmSettings {
    fn default() -> Self {
        FilmSettings {
            thickness: default_thickness(),
            damping: 0.0,
            gas: false,
            wind: None,
            bag_air: false,
            marangoni: false,
            order: default_order(),
            transitions: true,
            reseed: true,
            cfl: default_film_cfl(),
            point_cfl: None,
            drift_cfl: None,
            max_speed: 0.0,
            solver_tolerance: default_film_tol(),
            solver_max_iterations: default_film_iters(),
            rim_modulation: None,
            implicit: FilmImplicit::Full,
        }
    }
}

fn up() -> [f64; 3] {
    [0.0, 1.0, 0.0]
}
fn default_spacing() -> f64 {
    1.0 / 3.0
}
fn one() -> f64 {
    1.0
}
fn air() -> f64 {
    1.2
}
fn yes() -> bool {
    true
}
fn default_thickness() -> f64 {
    1e-6
}
fn default_order() -> usize {
    3
}
fn default_film_cfl() -> f64 {
    0.5
}
fn default_film_tol() -> f64 {
    1e-9
}
fn default_film_iters() -> usize {
    1000
}

type Check = Result<(), (String, String)>;

fn fail(path: impl Into<String>, reason: impl Into<String>) -> Check {
    Err((path.into(), reason.into()))
}

fn pos(path: String, v: f64) -> Check {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        fail(path, format!("must be positive and finite, got {v}"))
    }
}

fn dir(path: String, v: &[f64; 3]) -> Check {
    if v.iter().all(|c| c.is_finite()) && v.iter().map(|c| c * c).sum::<f64>() > 1e-24 {
        Ok(())
    } else {
        fail(path, format!("direction {v:?} must be finite and non-zero"))
    }
}

fn inside(path: String, s: &Scene, c: &[f64; 3], r: f64) -> Check {
    let d = &s.domain;
    if (0..3).all(|k| c[k] - r >= d.min[k] && c[k] + r <= d.max[k]) {
        Ok(())
    } else {
        fail(
            path,
            format!(
                "film (centre {c:?}, extent {r} m) leaves the domain {:?}–{:?}",
                d.min, d.max
            ),
        )
    }
}

/// Checks the film bodies and settings (field path, reason).
pub fn validate(s: &Scene) -> Check {
    for (i, b) in s.films.iter().enumerate() {
        let p = |f: &str| format!("films[{i}].{f}");
        match b {
            FilmBody::Sphere {
                center,
                radius,
                hole_angle,
                hole_axis,
                velocity,
                spacing,
            } => {
                pos(p("radius"), *radius)?;
                if !(0.0..PI).contains(hole_angle) {
                    return fail(
                        p("hole_angle"),
                        format!("must be in [0, π) rad, got {hole_angle}"),
                    );
                }
                dir(p("hole_axis"), hole_axis)?;
                if !velocity.iter().all(|c| c.is_finite()) {
                    return fail(p("velocity"), "must be finite");
                }
                check_spacing(p("spacing"), *spacing, *radius, s)?;
                inside(p("center"), s, center, *radius)?;
            }
            FilmBody::Cylinder {
                center,
                axis,
                radius,
                length,
                ring_speed,
                spacing,
            } => {
                pos(p("radius"), *radius)?;
                pos(p("length"), *length)?;
                dir(p("axis"), axis)?;
                if !ring_speed.is_finite() {
                    return fail(p("ring_speed"), "must be finite");
                }
                check_spacing(p("spacing"), *spacing, *radius, s)?;
                inside(p("center"), s, center, radius.hypot(0.5 * length))?;
            }
            FilmBody::Disk {
                center,
                normal,
                radius,
                spacing,
            } => {
                pos(p("radius"), *radius)?;
                dir(p("normal"), normal)?;
                check_spacing(p("spacing"), *spacing, *radius, s)?;
                inside(p("center"), s, center, *radius)?;
            }
        }
    }
    let f = &s.film;
    pos("film.thickness".into(), f.thickness)?;
    if !(f.damping.is_finite() && f.damping >= 0.0) {
        return fail(
            "film.damping",
            format!("must be >= 0 1/s, got {}", f.damping),
        );
    }
    if !(2..=4).contains(&f.order) {
        return fail("film.order", format!("must be 2, 3 or 4, got {}", f.order));
    }
    if !(f.cfl.is_finite() && f.cfl > 0.0 && f.cfl <= 2.0) {
        return fail(
            "film.cfl",
            format!("must be in (0, 2] spacings, got {}", f.cfl),
        );
    }
    if let Some(c) = f.point_cfl {
        if !(c.is_finite() && c > 0.0 && c <= 1000.0) {
            return fail(
                "film.point_cfl",
                format!("must be in (0, 1000] spacings, got {c}"),
            );
        }
    }
    if let Some(c) = f.drift_cfl {
        if !(c.is_finite() && c >= f.cfl && c <= 10.0) {
            return fail(
                "film.drift_cfl",
                format!("must be in [film.cfl = {}, 10] spacings, got {c}", f.cfl),
            );
        }
    }
    if !(f.max_speed.is_finite() && f.max_speed >= 0.0) {
        return fail(
            "film.max_speed",
            format!("must be >= 0 m/s, got {}", f.max_speed),
        );
    }
    if !(f.solver_tolerance > 0.0 && f.solver_tolerance < 1.0) {
        return fail(
            "film.solver_tolerance",
            format!("must be in (0, 1), got {}", f.solver_tolerance),
        );
    }
    if f.solver_max_iterations == 0 {
        return fail("film.solver_max_iterations", "must be at least 1");
    }
    if let Some(w) = &f.wind {
        if !w.velocity.iter().all(|c| c.is_finite()) {
            return fail("film.wind.velocity", "must be finite");
        }
        if !(w.drag.is_finite() && w.drag >= 0.0) {
            return fail("film.wind.drag", format!("must be >= 0, got {}", w.drag));
        }
        pos("film.wind.air_density".into(), w.air_density)?;
        if let Some(r) = w.radius {
            pos("film.wind.radius".into(), r)?;
        }
        if !w.origin.iter().all(|c| c.is_finite()) {
            return fail("film.wind.origin", "must be finite");
        }
        if let Some(g) = &w.gust {
            if !(g.start.is_finite() && g.start >= 0.0) {
                return fail(
                    "film.wind.gust.start",
                    format!("must be >= 0, got {}", g.start),
                );
            }
            pos("film.wind.gust.duration".into(), g.duration)?;
            if !(g.period.is_finite() && g.period >= 0.0) {
                return fail(
                    "film.wind.gust.period",
                    format!("must be >= 0, got {}", g.period),
                );
            }
            if !(g.between.is_finite() && (0.0..=1.0).contains(&g.between)) {
                return fail(
                    "film.wind.gust.between",
                    format!("must be in [0, 1], got {}", g.between),
                );
            }
            if g.period > 0.0 && g.period < g.duration {
                return fail(
                    "film.wind.gust.period",
                    format!(
                        "must be 0 or at least the duration {}, got {}",
                        g.duration, g.period
                    ),
                );
            }
        }
    }
    if f.bag_air && f.wind.is_none() {
        return fail(
            "film.bag_air",
            "needs film.wind (the air that blows the bag)",
        );
    }
    if f.bag_air && !s.films.iter().any(|b| matches!(b, FilmBody::Disk { .. })) {
        return fail(
            "film.bag_air",
            "needs a `disk` film (the film on its ring is the bag)",
        );
    }
    if let Some(m) = &f.rim_modulation {
        if m.corners < 2 {
            return fail(
                "film.rim_modulation.corners",
                format!("must be at least 2, got {}", m.corners),
            );
        }
        if !(m.amplitude.is_finite() && (0.0..1.0).contains(&m.amplitude)) {
            return fail(
                "film.rim_modulation.amplitude",
                format!(
                    "must be in [0, 1) (the rim tension must stay positive), got {}",
                    m.amplitude
                ),
            );
        }
        if !m.center.iter().all(|c| c.is_finite()) {
            return fail(
                "film.rim_modulation.center",
                format!("{:?} is not finite", m.center),
            );
        }
        if !m.phase.is_finite() {
            return fail(
                "film.rim_modulation.phase",
                format!("must be finite, got {}", m.phase),
            );
        }
    }
    if !s.films.is_empty() && s.has_liquid() {
        return fail(
            "films",
            "free films (`films:`) together with liquid bodies or jets are not supported: the volume step does not run the free-film solver (a liquid's sheets come from its surface layer and from jets)",
        );
    }
    Ok(())
}

fn check_spacing(path: String, sp: f64, radius: f64, s: &Scene) -> Check {
    if !(sp.is_finite() && sp > 0.0 && sp <= 1.0) {
        return fail(
            path,
            format!("must be in (0, 1] (relative to dx), got {sp}"),
        );
    }
    let n = radius / (sp * s.domain.dx);
    if n < 2.0 {
        return fail(
            path,
            format!(
                "spacing {} m leaves fewer than 2 particles across the radius {radius} m",
                sp * s.domain.dx
            ),
        );
    }
    if n > 2000.0 {
        return fail(
            path,
            format!(
                "spacing {} m gives {n:.0} particles across the radius (limit 2000)",
                sp * s.domain.dx
            ),
        );
    }
    Ok(())
}

fn v3(a: &[f64; 3]) -> Vec3 {
    Vec3::new(a[0], a[1], a[2])
}

/// Two unit vectors completing `d` to an orthonormal basis.
fn basis(d: &Vec3) -> (Vec3, Vec3) {
    let a = if d.x.abs() < 0.9 {
        Vec3::x()
    } else {
        Vec3::y()
    };
    let e1 = d.cross(&a).normalize();
    (e1, d.cross(&e1))
}

/// Samples every film body of the scene into sheet particles (rings fixed).
pub fn sample_films(s: &Scene) -> Particles {
    let rho = s.physics.density;
    let tau = s.film.thickness;
    let mut p = Particles::new();
    let add = |p: &mut Particles, pts: Vec<(Vec3, Vec3, bool)>, area: Real| {
        let m = rho * tau * area / pts.len().max(1) as Real;
        for (x, v, fixed) in pts {
            let i = p.push(x, v, m, 0.5 * tau, Codim::Sheet);
            p.fixed[i] = fixed;
        }
    };
    for b in &s.films {
        match b {
            FilmBody::Sphere {
                center,
                radius,
                hole_angle,
                hole_axis,
                velocity,
                spacing,
            } => {
                let c = v3(center);
                let ax = v3(hole_axis).normalize();
                let cos_hole = hole_angle.cos();
                let pts: Vec<(Vec3, Vec3, bool)> =
                    latitude_sphere(c, *radius, spacing * s.domain.dx)
                        .into_iter()
                        .filter(|x| *hole_angle == 0.0 || (x - c).normalize().dot(&ax) < cos_hole)
                        .map(|x| (x, v3(velocity), false))
                        .collect();
                let area = 2.0 * PI * radius * radius * (1.0 + hole_angle.cos());
                add(&mut p, pts, area);
            }
            FilmBody::Cylinder {
                center,
                axis,
                radius,
                length,
                ring_speed,
                spacing,
            } => {
                let (c, a) = (v3(center), v3(axis).normalize());
                let (e1, e2) = basis(&a);
                let sp = spacing * s.domain.dx;
                let nz = (length / sp).round().max(2.0) as usize;
                let dz = length / nz as Real;
                let nt = ((2.0 * PI * radius / sp).round() as usize).max(3);
                let mut pts = Vec::new();
                for k in 0..=nz {
                    let z = -0.5 * length + k as Real * dz;
                    let ring = k == 0 || k == nz;
                    let phase = if k % 2 == 0 { 0.0 } else { 0.5 };
                    for i in 0..nt {
                        let t = 2.0 * PI * (i as Real + phase) / nt as Real;
                        let x = c + a * z + (e1 * t.cos() + e2 * t.sin()) * *radius;
                        let v = if ring {
                            a * (z.signum() * ring_speed)
                        } else {
                            Vec3::zeros()
                        };
                        pts.push((x, v, ring));
                    }
                }
                let area = 2.0 * PI * radius * (length + dz);
                add(&mut p, pts, area);
            }
            FilmBody::Disk {
                center,
                normal,
                radius,
                spacing,
            } => {
                let (c, n) = (v3(center), v3(normal).normalize());
                let (e1, e2) = basis(&n);
                let sp = spacing * s.domain.dx;
                let pts: Vec<(Vec3, Vec3, bool)> = circle_pattern(*radius, sp, 0.0)
                    .into_iter()
                    .map(|(o, outline)| (c + e1 * o[0] + e2 * o[1], Vec3::zeros(), outline))
                    .collect();
                let area = PI * (radius + 0.5 * sp).powi(2);
                add(&mut p, pts, area);
            }
        }
    }
    p
}
