//! `manifest.json` of a cache folder (`docs/cache-format.md`): the scene copy
//! and its SHA-256, frame rate, frames written, and one record per frame with
//! the statistics a TD checks (counts per codimension, substeps, wall time per
//! stage — 0 for skipped stages —, solver iterations and residuals, speeds,
//! mass, counted fallbacks) plus what `--resume` needs to continue bit for bit
//! (simulated time and the next particle id).

use super::write_atomic;
use crate::math::Real;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

/// Linear-solver statistics over a frame's substeps.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct SolverStats {
    /// Number of solves.
    pub solves: u32,
    /// Sum of iterations.
    pub iterations_total: u64,
    /// Largest iteration count of one solve.
    pub iterations_max: u32,
    /// Largest final relative residual ‖r‖₂/‖b‖₂.
    pub residual_max: Real,
    /// Final relative residual of the frame's last solve.
    pub residual_last: Real,
    /// Solves that stopped at the iteration cap (their result was used).
    pub unconverged: u32,
}

impl SolverStats {
    /// Adds one solve.
    pub fn add(&mut self, it: u32, res: Real, converged: bool) {
        self.solves += 1;
        self.iterations_total += it as u64;
        self.iterations_max = self.iterations_max.max(it);
        self.residual_max = self.residual_max.max(res);
        self.residual_last = res;
        self.unconverged += (!converged) as u32;
    }
}

/// One substep's length and pressure solve.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct SubstepRecord {
    /// Substep length (s).
    pub dt: Real,
    /// Pressure PCG iterations.
    pub iterations: u32,
    /// Final relative residual of the pressure PCG.
    pub residual: Real,
    /// Pressure unknowns (liquid cells).
    pub cells: usize,
    /// Shift δ/Δx of the balanced face masses' level set (0 without a
    /// coupled solve or with another `coupling.face_mass`).
    #[serde(default)]
    pub mass_shift: Real,
    /// Surface-layer particles that carried the pressure jump, and the
    /// free-surface faces that took it (`coupling.layer: jump`; omitted
    /// when 0).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub jump_particles: usize,
    /// See `jump_particles`.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub jump_faces: usize,
}

fn is_zero(n: &usize) -> bool {
    *n == 0
}

/// Particle speed statistics (m/s).
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct Speed {
    /// Smallest speed.
    pub min: Real,
    /// Largest speed.
    pub max: Real,
    /// Mean speed.
    pub mean: Real,
}

/// Recorded, counted corrections.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct Fallbacks {
    /// Particles projected out of a solid after advection.
    pub solid_pushouts: u64,
    /// Particles clamped back into the domain box.
    pub wall_clamps: u64,
    /// Free-surface faces whose ghost-fluid θ was clamped.
    pub theta_clamps: u64,
    /// Film particles whose speed was limited to `film.max_speed`.
    #[serde(default)]
    pub speed_clamps: u64,
    /// Film substeps retried at half length after a failed solve.
    #[serde(default)]
    pub step_halvings: u64,
    /// Coupled solves (eq. 24) redone with the other method after the
    /// chosen one failed to converge.
    #[serde(default)]
    pub coupling_method_switches: u64,
    /// Constraint faces released around enclosed cells whose null mode the
    /// particles did not pin (`Constraints::release_enclosed`).
    #[serde(default)]
    pub released_faces: u64,
    /// Coupled solves redone after outlier velocities, with the enclosed
    /// cells around them released (`coupling::release::outlier_cells`), or
    /// after both methods failed, with the weakly pinned enclosed cells
    /// released (`Constraints::release_weak`).
    #[serde(default)]
    pub outlier_resolves: u64,
    /// Coupled substeps whose balanced face masses could not be brought to
    /// the volume particles' mass within one particle spacing of the level
    /// set (`coupling.face_mass: balanced`; the shift stayed at its bound).
    #[serde(default)]
    pub mass_shift_bounded: u64,
}

/// The air of a blown bag over one frame (`film::air`).
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct AirRecord {
    /// Bubbles at the end of the frame (rest volume, some particle ids).
    pub bubbles: Vec<crate::film::air::Bubble>,
    /// Bubbles that closed during the frame.
    pub new_bubbles: u32,
    /// Bubbles lost during the frame (burst, or joined to the ring's film).
    #[serde(default)]
    pub burst: u32,
    /// Bubbles that met another bubble during the frame and merged with it.
    #[serde(default)]
    pub merged: u32,
    /// Largest excess pressure in the bag over the frame's substeps (Pa).
    pub bag_pressure_max: Real,
    /// Smallest excess pressure in the bag (Pa; negative while it inflates).
    pub bag_pressure_min: Real,
    /// Radius of the bag's mouth at the frame's end (m).
    pub mouth_radius: Real,
    /// Distance of the mouth from the ring at the frame's end (m).
    pub mouth_offset: Real,
    /// Volume of the bag beyond its mouth at the frame's end (m³).
    pub bag_volume: Real,
    /// Largest relative volume error of a bubble over the frame.
    pub bubble_volume_error: Real,
}

/// One frame's record.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct FrameRecord {
    /// Frame number (0 = initial state).
    pub frame: u32,
    /// Simulated time at the end of the frame (s).
    pub time: Real,
    /// Next particle id to hand out (for resume).
    pub next_id: u64,
    /// Particle counts by codimension name.
    pub counts: BTreeMap<String, usize>,
    /// Substeps taken in the frame.
    pub substeps: u32,
    /// Smallest and largest substep (s).
    pub dt_min: Real,
    /// Largest substep (s).
    pub dt_max: Real,
    /// Wall time of the frame (s), including the cache write.
    pub wall_s: Real,
    /// Wall time per stage (s); stages skipped in the frame show 0.
    pub stage_s: BTreeMap<String, Real>,
    /// Pressure PCG statistics.
    pub pressure: SolverStats,
    /// Viscosity PCG statistics (no solves when μ = 0).
    pub viscosity: SolverStats,
    /// Particle speeds (m/s).
    pub speed: Speed,
    /// Total particle mass (kg).
    pub total_mass: Real,
    /// Liquid volume measured on the grid in the frame's last substep (m³).
    pub liquid_volume: Real,
    /// Largest number of pressure unknowns in a substep.
    pub liquid_cells: usize,
    /// Largest number of allocated 8³ blocks in a substep.
    pub blocks: usize,
    /// Counted corrections.
    pub fallbacks: Fallbacks,
    /// Every substep's length and pressure solve, in order.
    #[serde(default)]
    pub substep_log: Vec<SubstepRecord>,
    /// Film surface-tension solves (BiCGSTAB + ILU(0)), all components.
    #[serde(default)]
    pub tension: SolverStats,
    /// Codimension transitions during the frame (§8).
    #[serde(default)]
    pub transitions: crate::transition::TransitionCounts,
    /// Reseeding during the frame (§9).
    #[serde(default)]
    pub reseed: crate::reseed::ReseedCounts,
    /// Rest volume of the film's gas pocket (m³), needed to resume.
    #[serde(default)]
    pub gas_v0: Option<Real>,
    /// The air of a blown bag and its bubbles (`film.bag_air`): the bubbles
    /// at the frame's end (needed to resume) and the frame's figures.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub air: Option<AirRecord>,
    /// Particles emitted by jets during the frame.
    #[serde(default)]
    pub emitted: u64,
    /// Largest number of constraint faces (λ unknowns of eq. 24) in a substep.
    #[serde(default)]
    pub constraint_faces: usize,
    /// Sheet and filament particles of the coupled solve in the frame's
    /// last substep, by role.
    #[serde(default)]
    pub surface: crate::coupling::SurfaceCounts,
    /// Coupled solves of the frame that started from the previous substep's
    /// solution (every one but the frame's first, unless the seeded guess had
    /// the larger residual).
    #[serde(default)]
    pub warm_starts: u32,
}

/// The whole manifest.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct Manifest {
    /// Always `codimfx-cache`.
    pub format: String,
    /// Manifest version (1).
    pub version: u32,
    /// Cache folder name.
    pub scene_name: String,
    /// Scene file as given on the command line.
    pub scene_file: String,
    /// SHA-256 of the scene text (hex).
    pub scene_sha256: String,
    /// Verbatim copy of the scene text.
    pub scene_yaml: String,
    /// Frames per second.
    pub fps: Real,
    /// Cell size Δx (m) the run used (the scene's, times `scale`).
    pub dx: Real,
    /// Resolution scale of the run (`codimfx sim --scale S`: Δx × S; 1 = the scene's).
    #[serde(default = "one")]
    pub scale: Real,
    /// Domain box (m).
    pub domain_min: [Real; 3],
    /// Domain box (m).
    pub domain_max: [Real; 3],
    /// Rayon threads used.
    pub threads: usize,
    /// Last complete frame on disk.
    pub frames_written: u32,
    /// Per-frame records, frame 0 first.
    pub frames: Vec<FrameRecord>,
}

fn one() -> Real {
    1.0
}

/// Manifest I/O errors.
#[derive(Debug, thiserror::Error)]
pub enum ManifestError {
    /// File system error.
    #[error("{path}: {source}")]
    Io {
        /// File.
        path: String,
        /// Underlying error.
        source: std::io::Error,
    },
    /// Malformed JSON.
    #[error("{path}: {source}")]
    Json {
        /// File.
        path: String,
        /// Underlying error.
        source: serde_json::Error,
    },
}

impl Manifest {
    /// Writes the manifest atomically.
    pub fn write(&self, path: &Path) -> Result<(), ManifestError> {
        let s = serde_json::to_vec_pretty(self).map_err(|source| ManifestError::Json {
            path: path.display().to_string(),
            source,
        })?;
        write_atomic(path, &s).map_err(|source| ManifestError::Io {
            path: path.display().to_string(),
            source,
        })
    }

    /// Reads a manifest.
    pub fn read(path: &Path) -> Result<Manifest, ManifestError> {
        let s = std::fs::read(path).map_err(|source| ManifestError::Io {
            path: path.display().to_string(),
            source,
        })?;
        serde_json::from_slice(&s).map_err(|source| ManifestError::Json {
            path: path.display().to_string(),
            source,
        })
    }
}

/// Hex SHA-256 of a text.
pub fn sha256_hex(text: &str) -> String {
    use sha2::{Digest, Sha256};
    Sha256::digest(text.as_bytes())
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}
