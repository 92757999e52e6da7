//! One substep of the solver, sequencing the stages of the paper's Algorithm 1
//! that exist so far (the black, PIC/FLIP steps):
//!
//! | Alg. 1 | stage | module |
//! |---|---|---|
//! | 4 | body force on all particles | [`add_body_force`] |
//! | 5 | particles → grid (C-0), liquid level set | `grid::transfer` |
//! | 6 | viscosity on the grid, eq. (13) (skipped when μ = 0) | `grid::viscosity` |
//! | 7 | projection (ghost-fluid free surface, cut-cell solids) | `grid::projection` |
//! | 8 | grid → particles, PIC/FLIP or APIC | `grid::transfer` |
//! | 1 | advection (midpoint rule through the grid) | `advect` |
//!
//! Algorithm 1 is a cycle; this substep starts at step 4 and ends with the
//! advection of step 1, so the particle state alone (positions, velocities)
//! defines the next substep: a run resumed from a cached frame continues bit
//! for bit. Steps 2–3 (codimension update §8, reseeding §9) go right after
//! the advection, the MLS viscosity of §5 next to the grid viscosity, and the
//! monolithic tension/coupling solve of §7 replaces the projection call.
//!
//! Scenes without liquid (films, filaments and droplets only) allocate no
//! grid: for them [`step`] runs Algorithm 1 on the particles alone
//! ([`crate::film::step`]: advection, §8 transitions, §9 reseeding,
//! explicit forces, §5 viscosity, §6 semi-implicit tension), halving the
//! substep when a solve fails, and the grid stages report 0 s.

use crate::advect::{advect, AdvectInfo};
use crate::coupling::{self, CouplingError, CouplingInfo, CouplingParams, Method, SurfaceParams};
use crate::film::step::step_with_retry;
use crate::film::{FilmError, FilmParams, FilmState, FilmStepInfo};
use crate::grid::pcg::{NotFinite, PcgParams, SolveInfo};
use crate::grid::projection::{project_liquid, ProjectionInfo};
use crate::grid::transfer::{
    grid_to_particles, grid_to_particles_apic, transfer_to_grid, P2gSettings,
};
use crate::grid::viscosity::viscosity;
use crate::grid::MacGrid;
use crate::linsolve::BicgstabParams;
use crate::math::{Real, Vec3};
use crate::mls::MlsParams;
use crate::particles::{Codim, Particles};
use crate::scene::{CouplingMethod, Scene, Transfer};
use crate::solids::SolidSet;
use crate::transition::{TransitionCounts, TransitionParams};
use std::collections::BTreeMap;
use std::time::Instant;

/// Stage names, in the order they run; every substep reports all of them.
pub const STAGES: [&str; 12] = [
    "body_force",
    "p2g",
    "viscosity",
    "projection",
    "mls_operators",
    "coupled_assembly",
    "coupled_factor",
    "coupled_solve",
    "g2p",
    "advect",
    "transition",
    "reseed",
];

/// Wall time per stage (s), accumulated.
#[derive(Clone, Debug, PartialEq)]
pub struct StageTimes(pub BTreeMap<String, Real>);

impl Default for StageTimes {
    fn default() -> Self {
        StageTimes(STAGES.iter().map(|s| (s.to_string(), 0.0)).collect())
    }
}

impl StageTimes {
    /// Adds `secs` to a stage.
    pub fn add(&mut self, stage: &str, secs: Real) {
        *self.0.entry(stage.to_string()).or_insert(0.0) += secs;
    }

    /// Adds every stage of `other`.
    pub fn merge(&mut self, other: &StageTimes) {
        for (k, v) in &other.0 {
            self.add(k, *v);
        }
    }

    /// Sum over stages (s).
    pub fn total(&self) -> Real {
        self.0.values().sum()
    }
}

fn timed<T>(times: &mut StageTimes, stage: &str, f: impl FnOnce() -> T) -> T {
    let t = Instant::now();
    let r = f();
    times.add(stage, t.elapsed().as_secs_f64());
    r
}

/// Solver parameters of a substep, taken from the scene.
#[derive(Clone, Debug)]
pub struct StepParams {
    /// Body acceleration (m/s²).
    pub accel: Vec3,
    /// Density ρ (kg/m³).
    pub density: Real,
    /// Viscosity μ (Pa·s).
    pub viscosity: Real,
    /// Transfer scheme.
    pub transfer: Transfer,
    /// FLIP fraction.
    pub flip: Real,
    /// How P2G and the extrapolation read the particles near the surface
    /// (`solver.velocity_fit`).
    pub velocity_fit: crate::grid::VelocityFit,
    /// Level-set particle radius relative to Δx.
    pub surface_radius: Real,
    /// Keep separate liquid bodies apart on the grid (`solver.separate_bodies`).
    pub separate_bodies: bool,
    /// Open the particle-free gaps between two liquid surfaces (`solver.open_gaps`).
    pub open_gaps: bool,
    /// Pressure PCG stopping rule.
    pub pressure: PcgParams,
    /// Viscosity PCG stopping rule.
    pub viscous: PcgParams,
    /// Blocks are allocated this many cells around particles.
    pub margin: usize,
    /// Domain box (m).
    pub lo: Vec3,
    /// Domain box (m).
    pub hi: Vec3,
    /// Jet inflow disks active in the coming substep (set by the frame loop).
    pub inflow: Vec<crate::grid::Inflow>,
    /// Surface tension coupling (§7); `None` when σ = 0 and the scene has
    /// no sheet or filament particles (the plain projection runs).
    pub coupling: Option<CouplingParams>,
    /// Scenes without liquid: the film step's parameters (no grid stage
    /// runs); `None` for scenes with liquid.
    pub film: Option<FilmParams>,
}

impl StepParams {
    /// The settings of step 5 (P2G).
    pub fn p2g(&self) -> P2gSettings {
        P2gSettings {
            margin: self.margin,
            surface_radius: self.surface_radius,
            separate_bodies: self.separate_bodies,
            open_gaps: self.open_gaps,
            fit: self.velocity_fit,
        }
    }

    /// Parameters of a validated scene.
    pub fn from_scene(s: &Scene) -> StepParams {
        let a = s.acceleration();
        StepParams {
            accel: Vec3::new(a[0], a[1], a[2]),
            density: s.physics.density,
            viscosity: s.physics.viscosity,
            transfer: s.solver.transfer,
            flip: s.solver.flip,
            velocity_fit: s.solver.velocity_fit,
            surface_radius: s.solver.surface_radius,
            separate_bodies: s.solver.separate_bodies,
            open_gaps: s.solver.open_gaps,
            pressure: PcgParams {
                tolerance: s.solver.pressure_tolerance,
                max_iterations: s.solver.pressure_max_iterations,
            },
            viscous: PcgParams {
                tolerance: s.solver.viscosity_tolerance,
                max_iterations: s.solver.viscosity_max_iterations,
            },
            margin: s.time.cfl.ceil() as usize + 2,
            lo: Vec3::from(s.domain.min),
            hi: Vec3::from(s.domain.max),
            inflow: Vec::new(),
            coupling: (s.physics.surface_tension > 0.0).then(|| coupling_params(s)),
            film: (!s.has_liquid()).then(|| crate::film::driver::params_from_scene(s)),
        }
    }
}

/// The coupled solve's parameters of a scene: MLS support h = Δx (Appendix
/// F), the film fit order, transitions and rim modulation of `film:`, the
/// method and BiCGSTAB rule of `coupling:`.
pub fn coupling_params(s: &Scene) -> CouplingParams {
    let h = s.domain.dx;
    CouplingParams {
        method: match s.coupling.method {
            CouplingMethod::Monolithic => Method::Monolithic,
            CouplingMethod::Schur => Method::Schur,
        },
        ilu_order: s.coupling.ordering,
        face_fill: s.coupling.face_fill,
        shared_block: s.coupling.shared_block,
        fill_passes: if s.coupling.tail_fill {
            s.coupling.fill_passes as usize
        } else {
            0
        },
        mass_floor: s.coupling.mass_floor,
        solver: BicgstabParams {
            tol: s.coupling.tolerance,
            max_iter: s.coupling.max_iterations as usize,
        },
        krylov: match s.coupling.krylov {
            crate::scene::KrylovSetting::Gmres => coupling::Krylov::Gmres {
                restart: s.coupling.restart as usize,
            },
            crate::scene::KrylovSetting::Bicgstab => coupling::Krylov::Bicgstab,
        },
        surface: SurfaceParams {
            mls: MlsParams {
                order: s.film.order,
                ..MlsParams::new(h)
            },
            sigma: s.physics.surface_tension,
            density: s.physics.density,
            viscosity: s.physics.viscosity,
            bud_angle: std::f64::consts::PI / 6.0,
            rim_modulation: s.film.rim_modulation.as_ref().map(|m| m.sawtooth()),
            diffusive: s.film.diffusive(),
            tension_theta: s.coupling.tension_theta,
        },
        pressure: PcgParams {
            tolerance: s.solver.pressure_tolerance,
            max_iterations: s.solver.pressure_max_iterations,
        },
        verify: false,
        face_mass: match s.coupling.face_mass {
            crate::scene::FaceMassSetting::Balanced => coupling::FaceMass::Balanced,
            crate::scene::FaceMassSetting::Sheet => coupling::FaceMass::Sheet,
            crate::scene::FaceMassSetting::LevelSet => coupling::FaceMass::LevelSet,
        },
        band: match s.coupling.band {
            crate::scene::BandSetting::Sheet => coupling::BandVelocity::Sheet,
            crate::scene::BandSetting::Extrapolated => coupling::BandVelocity::Extrapolated,
            crate::scene::BandSetting::Extended => coupling::BandVelocity::Extended,
        },
        surface_radius: s.solver.surface_radius,
        layer: s.coupling.layer,
        transitions: s.film.transitions.then(|| TransitionParams::paper(h)),
        reseed: s
            .film
            .reseed
            .then(|| crate::reseed::ReseedParams::liquid(h, s.physics.density)),
        sources: s
            .jets
            .iter()
            .map(|j| {
                let d = Vec3::from(j.direction).normalize();
                coupling::codim::Source {
                    origin: Vec3::from(j.origin),
                    direction: d,
                    radius: j.radius,
                    // the layers emitted within one substep at the CFL limit, plus h
                    depth: 2.0 * h,
                }
            })
            .collect(),
    }
}

/// Everything a substep reads and writes.
#[derive(Clone, Debug)]
pub struct SimState {
    /// The particle store.
    pub particles: Particles,
    /// The sparse MAC grid (rebuilt every substep).
    pub grid: MacGrid,
    /// Static solids.
    pub solids: SolidSet,
    /// APIC affine velocity per particle (row a = ∇u_a, 1/s), aligned with
    /// `particles`; empty unless `solver.transfer: apic`. Stages that insert
    /// or delete particles keep it aligned (new particles: zero).
    pub affine: Vec<[Vec3; 3]>,
    /// State of the film step (the enclosed gas of a bubble), for scenes
    /// without liquid.
    pub film: Option<FilmState>,
    /// The previous substep's coupled solution, the next solve's starting
    /// guess (cleared at the start of every frame, so a resumed run continues
    /// bit for bit).
    pub warm: Option<coupling::WarmStart>,
}

impl SimState {
    /// A state with no APIC data yet (it is sized on the first APIC substep).
    pub fn new(particles: Particles, grid: MacGrid, solids: SolidSet) -> SimState {
        SimState {
            particles,
            grid,
            solids,
            affine: Vec::new(),
            film: None,
            warm: None,
        }
    }
}

/// What one substep did.
#[derive(Clone, Debug, Default)]
pub struct SubstepInfo {
    /// Substep length (s).
    pub dt: Real,
    /// Pressure projection record.
    pub pressure: ProjectionInfo,
    /// Coupled solve record (scenes with surface tension).
    pub coupling: Option<CouplingInfo>,
    /// Codimension transitions after the advection (§8).
    pub transitions: TransitionCounts,
    /// Reseeding of the sheets and filaments after the transitions (§9).
    pub reseed: crate::reseed::ReseedCounts,
    /// Viscosity solves (x, y, z), `None` when skipped (μ = 0).
    pub viscosity: Option<[SolveInfo; 3]>,
    /// Corrections during advection.
    pub advect: AdvectInfo,
    /// Liquid volume on the grid after P2G (m³).
    pub liquid_volume: Real,
    /// Allocated grid blocks.
    pub blocks: usize,
    /// The film step's record (scenes without liquid).
    pub film: Option<FilmSubstep>,
}

/// What a film substep did besides the common fields.
#[derive(Clone, Debug, Default)]
pub struct FilmSubstep {
    /// The last (sub-)step's record.
    pub info: FilmStepInfo,
    /// Times the substep was halved after a failed solve.
    pub halvings: u32,
    /// Velocities clamped to `film.max_speed`.
    pub speed_clamps: usize,
}

/// Why a substep failed.
#[derive(Debug, thiserror::Error)]
pub enum StepError {
    /// A film step failed even after halving the substep.
    #[error("film step failed: {0}")]
    Film(#[from] FilmError),
    /// The coupled pressure/tension solve failed.
    #[error("coupled surface tension solve: {0}")]
    Coupling(#[from] CouplingError),
    /// The pressure solve produced non-finite values.
    #[error("pressure projection: {0}")]
    Pressure(NotFinite),
    /// A viscosity solve produced non-finite values.
    #[error("grid viscosity: {0}")]
    Viscosity(NotFinite),
    /// Particles with non-finite state after a stage.
    #[error("{count} particles have non-finite position or velocity after stage `{stage}`")]
    NonFinite {
        /// Stage name.
        stage: &'static str,
        /// Offending particles.
        count: usize,
    },
}

/// Algorithm 1 step 4: `u ← u + Δt a` on every non-fixed particle.
pub fn add_body_force(parts: &mut Particles, accel: Vec3, dt: Real) {
    for (v, f) in parts.v.iter_mut().zip(&parts.fixed) {
        if !f {
            *v += accel * dt;
        }
    }
}

/// In debug builds, fails when a stage left a non-finite particle (release
/// builds check once per substep, after the advection, and before every cache write).
fn debug_check(p: &Particles, stage: &'static str) -> Result<(), StepError> {
    if cfg!(debug_assertions) {
        let count = count_non_finite(p);
        if count > 0 {
            return Err(StepError::NonFinite { stage, count });
        }
    }
    Ok(())
}

fn count_non_finite(p: &Particles) -> usize {
    p.x.iter()
        .zip(&p.v)
        .filter(|(x, v)| !(x.iter().all(|c| c.is_finite()) && v.iter().all(|c| c.is_finite())))
        .count()
}

/// Advances the state by one substep of length `dt` (s).
pub fn step(
    st: &mut SimState,
    p: &StepParams,
    dt: Real,
    times: &mut StageTimes,
) -> Result<SubstepInfo, StepError> {
    if let Some(fp) = &p.film {
        return film_substep(st, fp, p, dt, times);
    }
    let mut info = SubstepInfo {
        dt,
        ..Default::default()
    };
    let apic = p.transfer == Transfer::Apic;
    if apic {
        st.affine.resize(st.particles.len(), [Vec3::zeros(); 3]);
    }
    let SimState {
        particles,
        grid,
        solids,
        affine,
        warm,
        ..
    } = st;
    // 4: body force
    timed(times, "body_force", || {
        add_body_force(particles, p.accel, dt)
    });
    debug_check(particles, "body_force")?;
    // 5: particles → grid
    timed(times, "p2g", || {
        let c = apic.then_some(affine.as_slice());
        transfer_to_grid(grid, particles, solids, &p.p2g(), c)
    });
    // 6: viscosity, grid part of eq. (13); the MLS part for C-1/C-2 joins here
    info.viscosity = if p.viscosity > 0.0 {
        let v = timed(times, "viscosity", || {
            viscosity(grid, p.viscosity, p.density, dt, p.viscous)
        });
        Some(v.map_err(StepError::Viscosity)?)
    } else {
        times.add("viscosity", 0.0); // skipped (μ = 0): reported as 0
        None
    };
    // jet nozzles: the liquid enters through its emission disk at the jet's velocity
    grid.set_inflow(&p.inflow);
    // 7: projection, or with surface tension the coupled solve of §7
    if let Some(cp) = &p.coupling {
        let c = coupling::solve(grid, solids, particles, cp, dt, p.margin + 1, warm)?;
        times.add("mls_operators", c.operators_s);
        times.add("coupled_assembly", c.assemble_s);
        times.add("coupled_factor", c.factor_s);
        times.add("coupled_solve", c.solve_s);
        info.pressure = ProjectionInfo {
            solve: SolveInfo {
                iterations: c.iterations as u32,
                rel_residual: c.rel_residual,
                converged: true,
            },
            cells: c.cells,
            theta_clamps: c.theta_clamps,
        };
        info.coupling = Some(c);
    } else {
        info.pressure = timed(times, "projection", || {
            project_liquid(grid, solids, p.pressure, p.margin + 1)
        })
        .map_err(StepError::Pressure)?;
    }
    // 8: grid → particles
    timed(times, "g2p", || match p.transfer {
        Transfer::Flip => grid_to_particles(grid, particles, p.flip),
        Transfer::Apic => grid_to_particles_apic(grid, particles, affine),
    });
    debug_check(particles, "g2p")?;
    // 1: advection (first step of the next cycle of Algorithm 1)
    info.advect = timed(times, "advect", || {
        advect(particles, grid, solids, p.lo, p.hi, dt)
    });
    info.blocks = grid.blocks.len();
    info.liquid_volume = grid.liquid_volume();
    // 2: codimension update (§8) of the next cycle
    if let Some((tp, src)) = p
        .coupling
        .as_ref()
        .and_then(|c| c.transitions.as_ref().map(|t| (t, &c.sources)))
    {
        info.transitions = timed(times, "transition", || {
            coupling::codim::update(particles, tp, src, solids)
        });
    } else {
        times.add("transition", 0.0);
    }
    // 3: reseeding (§9) of the sheets and filaments
    if let Some((rp, cp)) = p
        .coupling
        .as_ref()
        .and_then(|c| c.reseed.as_ref().map(|r| (r, c)))
    {
        info.reseed = timed(times, "reseed", || {
            coupling::reseed::reseed_surface(particles, affine, rp, &cp.surface.mls, &cp.sources)
        })
        .map_err(|e| StepError::Coupling(CouplingError::Mls(e)))?;
    } else {
        times.add("reseed", 0.0);
    }
    let bad = count_non_finite(particles);
    if bad > 0 {
        return Err(StepError::NonFinite {
            stage: "advect",
            count: bad,
        });
    }
    Ok(info)
}

/// The substep of a scene without liquid: Algorithm 1 on the particles
/// alone ([`crate::film::step::step`], halved up to 4 times when a solve
/// fails), then droplets stopped at the domain box and the optional speed
/// limit (both counted).
fn film_substep(
    st: &mut SimState,
    fp: &FilmParams,
    p: &StepParams,
    dt: Real,
    times: &mut StageTimes,
) -> Result<SubstepInfo, StepError> {
    let fs = st.film.get_or_insert_with(FilmState::default);
    let (info, halvings) = step_with_retry(&mut st.particles, fs, fp, dt, 4)?;
    let tm = &info.timings;
    for (k, v) in [
        ("advect", tm.advect),
        ("transition", tm.transition),
        ("reseed", tm.reseed),
        ("film_forces", tm.forces),
        ("film_viscosity", tm.viscosity),
        ("mls_operators", tm.operators),
        ("tension", tm.tension),
    ] {
        times.add(k, v);
    }
    let wall_clamps = crate::film::driver::close_walls(&mut st.particles, p.lo, p.hi);
    let mut speed_clamps = 0;
    if fp.max_speed > 0.0 {
        for v in st.particles.v.iter_mut() {
            let m = v.norm();
            if m > fp.max_speed {
                *v *= fp.max_speed / m;
                speed_clamps += 1;
            }
        }
    }
    Ok(SubstepInfo {
        dt,
        transitions: info.transitions,
        reseed: info.reseed,
        advect: AdvectInfo {
            wall_clamps,
            ..Default::default()
        },
        film: Some(FilmSubstep {
            info,
            halvings,
            speed_clamps,
        }),
        ..Default::default()
    })
}

/// Largest stable substep (s) for the current particle velocities:
/// `Δt = cfl Δx / (max|u| + √(Δx |a|))`, capped by `max_dt`. Points
/// (C = 3, ballistic droplets) never touch the grid and are left out: in
/// the fluid polygon a 4.5e-9 kg droplet shot off a rim at 13 m/s held the
/// whole scene at 1.6e-4 s substeps for a frame (`docs/decisions.md`).
pub fn cfl_dt(parts: &Particles, dx: Real, accel: Vec3, cfl: Real, max_dt: Real) -> Real {
    let vmax = parts
        .v
        .iter()
        .zip(&parts.codim)
        .filter(|(_, c)| **c != Codim::Point)
        .map(|(v, _)| v.norm())
        .fold(0.0, Real::max);
    let denom = vmax + (dx * accel.norm()).sqrt();
    if denom > 0.0 {
        (cfl * dx / denom).min(max_dt)
    } else {
        max_dt
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_substep_follows_the_fastest_particle_that_touches_the_grid() {
        let mut p = Particles::new();
        p.push(
            Vec3::zeros(),
            Vec3::new(0.0, -2.0, 0.0),
            1.0,
            0.01,
            Codim::Volume,
        );
        p.push(
            Vec3::zeros(),
            Vec3::new(1.0, 0.0, 0.0),
            1.0,
            0.01,
            Codim::Sheet,
        );
        let dx = 0.01;
        let g = Vec3::new(0.0, -9.81, 0.0);
        let dt = cfl_dt(&p, dx, g, 1.0, 1.0);
        assert!((dt - dx / (2.0 + (dx * 9.81 as Real).sqrt())).abs() < 1e-15);
        // a droplet at 100 m/s changes nothing; a filament at 100 m/s does
        p.push(
            Vec3::zeros(),
            Vec3::new(100.0, 0.0, 0.0),
            1.0,
            0.01,
            Codim::Point,
        );
        assert_eq!(cfl_dt(&p, dx, g, 1.0, 1.0), dt);
        p.codim[2] = Codim::Filament;
        assert!(cfl_dt(&p, dx, g, 1.0, 1.0) < 0.03 * dt);
    }
}
