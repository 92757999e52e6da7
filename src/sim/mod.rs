//! The frame loop: CFL substepping, per-frame caches, resume and stopping.
//!
//! Each frame advances the state to `t = frame / fps` in substeps of
//! `Δt = min(cfl Δx / (max|u| + √(Δx|a|)), max_dt)`, never leaving a sliver
//! shorter than half the previous substep before the frame's end. After a
//! frame the particles are written to `particles.NNNN.ply` and the manifest is
//! updated, both through a temporary name and a rename, so a frame appears
//! only when complete. Since a substep depends only on the particle state
//! (`step` module docs) and the caches hold positions and velocities in double
//! precision, `resume` continues from the last complete frame bit for bit.
//! A stop flag (Ctrl-C in the binary) is checked after every frame.
//!
//! Jets (Appendix F) emit before each substep [t, t + Δt) the layers whose
//! emission times fall in it ([`crate::emitter::Jet::emit_placed`]); which
//! layers exist is a function of time alone, so a resumed run (whose time is
//! exactly frame / fps) emits the same particles. The frame record counts
//! them (`emitted`).

mod frame_vectors;
mod open;

use crate::emitter::Jet;
use crate::film::driver as film_driver;
use crate::frame_record::{base_record, report_substep};
use crate::io::manifest::{FrameRecord, Manifest, ManifestError, SubstepRecord};
use crate::io::ply::{self, frame_name, PlyError};
use crate::io::write_atomic;
use crate::math::{Real, Vec3};
use crate::particles::spatial_order;
use crate::scene::{Scene, SceneError, Transfer};
use crate::step::{cfl_dt, step, SimState, StageTimes, StepError, StepParams};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

/// Why a run failed.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// The scene did not load.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// File system error.
    #[error("{path}: {source}")]
    Io {
        /// Path.
        path: PathBuf,
        /// Underlying error.
        source: std::io::Error,
    },
    /// Cache file error.
    #[error(transparent)]
    Ply(#[from] PlyError),
    /// Manifest error.
    #[error(transparent)]
    Manifest(#[from] ManifestError),
    /// A substep failed.
    #[error("frame {frame}, t = {time:.6} s{}: {source}", after_halvings(*halvings))]
    Step {
        /// Frame being computed.
        frame: u32,
        /// Simulated time when it failed (s).
        time: Real,
        /// Times the failing substep had been halved and retried.
        halvings: u32,
        /// The stage error.
        source: StepError,
    },
    /// Sampling produced no particle at all.
    #[error(
        "{file}: field `bodies`: no liquid particle left: all {dropped} samples fell inside solids"
    )]
    NoLiquid {
        /// Scene file.
        file: PathBuf,
        /// Samples dropped inside solids.
        dropped: usize,
    },
    /// The cache cannot be resumed.
    #[error("cannot resume {dir}: {reason}")]
    Resume {
        /// Cache folder.
        dir: PathBuf,
        /// Why.
        reason: String,
    },
}

/// How to run.
#[derive(Clone, Debug, Default)]
pub struct RunOptions {
    /// Parent folder of the cache (the scene's `output.dir`, else `cache`, when `None`).
    pub out_root: Option<PathBuf>,
    /// Last frame to simulate (default: the scene's `time.frames`).
    pub frames: Option<u32>,
    /// Continue after the last complete frame of an existing cache.
    pub resume: bool,
    /// Resolution scale: Δx × scale, particle spacings follow (relative to
    /// Δx). `None`: 1 for a new run, the cache's scale when resuming.
    pub scale: Option<Real>,
    /// Print every substep of a liquid scene to stderr.
    pub verbose: bool,
}

/// A run in progress.
pub struct Sim {
    /// The scene.
    pub scene: Scene,
    /// Cache folder.
    pub dir: PathBuf,
    /// Solver state.
    pub state: SimState,
    /// Substep parameters.
    pub params: StepParams,
    /// The manifest as written so far.
    pub manifest: Manifest,
    /// Last complete frame.
    pub frame: u32,
    /// Simulated time (s).
    pub time: Real,
    /// Last frame to simulate.
    pub last_frame: u32,
    /// Stage times summed over the run (s).
    pub totals: StageTimes,
    /// Seed samples dropped because they fell inside solids.
    pub dropped_in_solid: usize,
    /// The scene's jets (their emission state is a function of time).
    pub jets: Vec<Jet>,
    /// Print every substep to stderr ([`RunOptions::verbose`]).
    pub verbose: bool,
}

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> SimError + '_ {
    move |source| SimError::Io {
        path: path.to_path_buf(),
        source,
    }
}

fn after_halvings(n: u32) -> String {
    if n == 0 {
        String::new()
    } else {
        format!(", after {n} halvings of the substep")
    }
}

/// Consecutive halvings of a liquid substep before the run stops.
const MAX_HALVINGS: u32 = 4;

/// A liquid substep that failed in a solve or left non-finite particles is
/// retried with half the substep; an error of the film step has already
/// been retried inside it.
fn retry_with_half_step(e: &StepError) -> bool {
    !matches!(e, StepError::Film(_))
}

/// Emits every jet's layers of [t0, t1) before the substep [t0, t1), placed
/// at their free-flight positions at t0 (the substep carries them on); keeps
/// the APIC matrices aligned. Returns the number of particles added.
fn emit_jets(jets: &[Jet], t0: Real, t1: Real, st: &mut SimState) -> usize {
    let n: usize = jets
        .iter()
        .map(|j| j.emit_placed(t0, t1, t0, &mut st.particles))
        .sum();
    if n > 0 && !st.affine.is_empty() {
        st.affine.resize(st.particles.len(), [Vec3::zeros(); 3]);
    }
    n
}

impl Sim {
    /// Reorders the particles by [`spatial_order`] on cells of size `cell`;
    /// the APIC data follow them.
    fn sort_particles(&mut self, cell: Real) {
        let order = spatial_order(&self.state.particles, cell);
        self.state.particles.permute(&order);
        if !self.state.affine.is_empty() {
            let a = std::mem::take(&mut self.state.affine);
            self.state.affine = order.iter().map(|&i| a[i]).collect();
        }
    }

    /// Simulates and writes the next frame; returns its record.
    pub fn advance_frame(&mut self) -> Result<FrameRecord, SimError> {
        let wall = Instant::now();
        let f = self.frame + 1;
        let t_end = f as Real / self.scene.time.fps;
        let mut times = StageTimes::default();
        let mut rec = FrameRecord::default();
        let (mut dt_min, mut dt_max) = (Real::INFINITY, 0.0 as Real);
        let mut substeps = 0;
        let dx = self.scene.domain.dx;
        // each frame's first coupled solve starts cold: what a resumed run sees
        self.state.warm = None;
        // and its particles in space order (so does a resumed run's)
        self.sort_particles(dx);
        // a failed coupled solve is retried from the same state with half the
        // substep (at most MAX_HALVINGS times in a row); the cap then holds
        // for the rest of the frame
        let mut dt_cap = Real::INFINITY;
        let mut failures = 0u32;
        while self.time < t_end {
            let rem = t_end - self.time;
            let (dt, last) = if let Some(fp) = &self.params.film {
                film_driver::film_substep(
                    &self.scene,
                    fp.wind.as_ref(),
                    &self.state.particles,
                    self.time,
                    rem,
                )
            } else {
                let mut dt = cfl_dt(
                    &self.state.particles,
                    dx,
                    self.params.accel,
                    self.scene.time.cfl,
                    self.scene.time.max_dt,
                );
                // particles about to leave a nozzle count in the CFL limit too
                let v_jet = self
                    .jets
                    .iter()
                    .filter(|j| j.stop > self.time)
                    .map(|j| j.speed)
                    .fold(0.0, Real::max);
                if v_jet > 0.0 {
                    dt = dt.min(self.scene.time.cfl * dx / v_jet);
                }
                dt = dt.min(crate::coupling::jump::capillary_limit(&self.scene, dx));
                film_driver::fit_to_frame(dt.min(dt_cap), rem)
            };
            let t1 = if last { t_end } else { self.time + dt };
            let before = self.params.film.is_none().then(|| {
                (
                    self.state.particles.clone(),
                    self.state.affine.clone(),
                    self.state.warm.clone(),
                )
            });
            let emitted = emit_jets(&self.jets, self.time, t1, &mut self.state) as u64;
            // jets that are on during [t, t1) feed the liquid through their nozzle disk
            self.params.inflow = self
                .jets
                .iter()
                .filter(|j| self.time < j.stop && t1 > j.start)
                .map(|j| crate::grid::Inflow {
                    origin: j.origin,
                    direction: j.direction,
                    radius: j.radius,
                    speed: j.speed,
                })
                .collect();
            if let Some(fs) = self.state.film.as_mut() {
                fs.time = self.time;
            }
            let info = match step(&mut self.state, &self.params, dt, &mut times) {
                Ok(info) => info,
                Err(source) => match before {
                    Some((particles, affine, warm))
                        if failures < MAX_HALVINGS && retry_with_half_step(&source) =>
                    {
                        self.state.particles = particles;
                        self.state.affine = affine;
                        self.state.warm = warm;
                        dt_cap = 0.5 * dt;
                        failures += 1;
                        rec.fallbacks.step_halvings += 1;
                        eprintln!(
                            "warning: frame {f}, t = {:.6} s: {source}; retrying with Δt = {:.3e} s",
                            self.time, dt_cap
                        );
                        continue;
                    }
                    _ => {
                        return Err(SimError::Step {
                            frame: f,
                            time: self.time,
                            halvings: failures,
                            source,
                        })
                    }
                },
            };
            failures = 0;
            rec.emitted += emitted;
            self.time = t1;
            substeps += 1;
            dt_min = dt_min.min(dt);
            dt_max = dt_max.max(dt);
            rec.transitions.add(&info.transitions);
            rec.reseed.add(&info.reseed);
            rec.fallbacks.wall_clamps += info.advect.wall_clamps as u64;
            if let Some(fs) = &info.film {
                let tol = self.params.film.as_ref().map_or(0.0, |fp| fp.solver.tol);
                for si in &fs.info.tension_solve {
                    rec.tension.add(
                        si.iterations as u32,
                        si.rel_residual,
                        si.rel_residual <= 10.0 * tol,
                    );
                }
                for si in &fs.info.viscosity_solve {
                    if si.iterations > 0 {
                        rec.viscosity
                            .add(si.iterations as u32, si.rel_residual, true);
                    }
                }
                rec.fallbacks.step_halvings += fs.halvings as u64;
                rec.fallbacks.speed_clamps += fs.speed_clamps as u64;
                if let Some(a) = &fs.info.air {
                    let r = rec.air.get_or_insert_with(Default::default);
                    r.new_bubbles += a.new_bubbles as u32;
                    r.burst += a.burst as u32;
                    r.merged += a.merged as u32;
                    r.bag_pressure_max = r.bag_pressure_max.max(a.bag_pressure);
                    r.bag_pressure_min = r.bag_pressure_min.min(a.bag_pressure);
                    r.mouth_radius = a.mouth_radius;
                    r.mouth_offset = a.mouth_offset;
                    r.bag_volume = a.bag_volume;
                    r.bubble_volume_error = r.bubble_volume_error.max(a.bubble_volume_error);
                }
                continue;
            }
            let s = &info.pressure.solve;
            if self.verbose {
                report_substep(
                    f,
                    substeps,
                    self.time,
                    dt,
                    &info,
                    &self.state.particles,
                    &wall,
                );
            }
            rec.pressure.add(s.iterations, s.rel_residual, s.converged);
            rec.substep_log.push(SubstepRecord {
                dt,
                iterations: s.iterations,
                residual: s.rel_residual,
                cells: info.pressure.cells,
                mass_shift: info.coupling.as_ref().map_or(0.0, |c| c.mass_shift),
                jump_particles: info.coupling.as_ref().map_or(0, |c| c.jump_particles),
                jump_faces: info.coupling.as_ref().map_or(0, |c| c.jump_faces),
            });
            if let Some(v) = info.viscosity {
                for s in v {
                    rec.viscosity.add(s.iterations, s.rel_residual, s.converged);
                }
            }
            rec.fallbacks.solid_pushouts += info.advect.solid_pushouts as u64;
            rec.fallbacks.theta_clamps += info.pressure.theta_clamps as u64;
            if let Some(c) = &info.coupling {
                rec.constraint_faces = rec.constraint_faces.max(c.faces);
                rec.surface = c.counts;
                rec.fallbacks.coupling_method_switches += c.method_fallbacks as u64;
                rec.fallbacks.released_faces += c.released_faces as u64;
                rec.fallbacks.outlier_resolves += c.outlier_rounds as u64;
                rec.fallbacks.mass_shift_bounded += c.mass_shift_bounded as u64;
                rec.warm_starts += (c.warm_seeded > 0) as u32;
            }
            rec.liquid_volume = info.liquid_volume;
            rec.liquid_cells = rec.liquid_cells.max(info.pressure.cells);
            rec.blocks = rec.blocks.max(info.blocks);
        }
        if let Some(fs) = &self.state.film {
            rec.gas_v0 = fs.gas.map(|g| g.v0);
            if let Some(r) = rec.air.as_mut() {
                r.bubbles = fs.air.bubbles.clone();
            }
        }
        let p = &self.state.particles;
        let affine =
            (self.params.transfer == Transfer::Apic).then_some(self.state.affine.as_slice());
        let fv = frame_vectors::frame_vectors(p, self.scene.domain.dx);
        let bytes = ply::encode(p, fv.as_deref(), affine, f, self.time)?;
        let path = self.dir.join(frame_name(f));
        write_atomic(&path, &bytes).map_err(io_err(&path))?;
        let base = base_record(f, self.time, p);
        let rec = FrameRecord {
            frame: base.frame,
            time: base.time,
            next_id: base.next_id,
            counts: base.counts,
            speed: base.speed,
            total_mass: base.total_mass,
            substeps,
            dt_min: if substeps > 0 { dt_min } else { 0.0 },
            dt_max,
            stage_s: times.0.clone(),
            wall_s: wall.elapsed().as_secs_f64(),
            ..rec
        };
        self.totals.merge(&times);
        self.frame = f;
        self.manifest.frames.push(rec.clone());
        self.manifest.frames_written = f;
        self.manifest.write(&self.dir.join("manifest.json"))?;
        Ok(rec)
    }

    /// Runs frames until `last_frame` or until `stop` is set (checked after each frame).
    pub fn run(
        &mut self,
        stop: &AtomicBool,
        mut on_frame: impl FnMut(&Sim, &FrameRecord),
    ) -> Result<(), SimError> {
        while self.frame < self.last_frame && !stop.load(Ordering::SeqCst) {
            let r = self.advance_frame()?;
            on_frame(self, &r);
        }
        Ok(())
    }
}
