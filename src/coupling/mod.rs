//! Codimensional coupling (paper §7, eqs. 18–24): the grid pressure of the
//! volume, the semi-implicit surface tension of the sheet and filament
//! particles (§6, eq. 17) and the impulses λ on the constraint faces, solved
//! as one system per substep. This replaces the projection (Algorithm 1,
//! step 7) whenever a scene has surface tension.
//!
//! - [`surface`]: masses, control areas, rim/bud forces and the joint MLS
//!   Laplacian of the particles (eqs. 14–17, Appendix D);
//! - [`faces`]: the constraint faces K and the interpolation J (eq. 18);
//! - [`system`]: eq. (24) as the paper writes it (`Method::Monolithic`), or
//!   with λ eliminated exactly (`Method::Schur`), both solved with GMRES
//!   (default) or the paper's BiCGSTAB ([`Krylov`]), preconditioned by an
//!   incomplete LU, at the scene's tolerance (paper: 1e-9);
//! - [`jump`]: with `coupling.layer: jump`, a volume's surface layer gives
//!   the grid a ghost-fluid pressure jump σκ instead of tension rows and
//!   constraint faces (free sheets and filaments keep eq. 24);
//! - `forms`: one form assembled, factored and solved, and the solve
//!   without coupling rows;
//! - [`cut`]: with `coupling.layer: cut`, the liquid ends at a volume's
//!   surface layer, whose particles close the cells it crosses (their
//!   normal flux in the cells' continuity, the cells' pressure on them).
//!
//! Both methods give the same face velocities, pressures and particle
//! velocities up to the solver tolerance; the reduced one is smaller (no λ
//! rows) and better conditioned (`codimfx bench coupling` compares them on
//! the same state, `docs/benchmarks.md`). Without constraint faces the
//! blocks decouple: the pressure is solved alone with PCG/MIC(0) and the
//! particles with the tension solve of §6, so no coupling rows are built.

pub mod band;
pub mod codim;
pub mod cut;
pub mod faces;
mod forms;
pub mod jump;
pub mod params;
pub mod release;
pub mod reseed;
pub mod surface;
pub mod system;
pub mod warm;

use crate::grid::extrapolate::{constrain_solids, extrapolate};
use crate::grid::projection::Poisson;
use crate::grid::MacGrid;
use crate::linsolve::SolveError;
use crate::math::{Real, Vec3};
use crate::particles::Particles;
use crate::solids::SolidSet;
pub use band::{band_correction, band_extension, band_probes, BandProbes, BAND_PROBE};
pub use params::{
    BandVelocity, CouplingError, CouplingInfo, CouplingParams, FaceMass, Krylov, LayerTension,
    Method, GMRES_RESTART, MAX_OUTLIER_ROUNDS,
};
use std::time::Instant;
pub use surface::{SurfaceCounts, SurfaceParams};
pub use system::IluOrder;
use system::{eq24_residual, Form, Scalars};
pub use warm::WarmStart;

fn solve_err(stage: &'static str) -> impl Fn(SolveError) -> CouplingError {
    move |source| CouplingError::Solve { stage, source }
}

/// Algorithm 1 step 7 with surface tension: solves the coupled system,
/// writes the projected face velocities into `grid.u` (extended `layers`
/// layers, free slip in solids) and u^{n+1} into the sheet and filament
/// particles of `parts`. `warm` holds the previous substep's solution
/// ([`WarmStart`]); it seeds this solve and is replaced by its solution.
pub fn solve(
    grid: &mut MacGrid,
    solids: &SolidSet,
    parts: &mut Particles,
    prm: &CouplingParams,
    dt: Real,
    layers: usize,
    warm: &mut Option<WarmStart>,
) -> Result<CouplingInfo, CouplingError> {
    let mut info = CouplingInfo::default();
    let t = Instant::now();
    let mut surf = surface::build(parts, &prm.surface)?;
    let jump = prm.layer == LayerTension::Jump;
    // with the jump, a volume's surface layer (where the body is deep enough)
    // takes no tension row: it is held at its velocity in the particle block
    // and moves with the grid
    let totals = volume_totals(parts);
    let spacing = volume_spacing(totals, prm.surface.density);
    let points = jump.then(|| {
        let (h, s) = (prm.surface.mls.h, spacing.unwrap_or(0.0));
        jump::layer_points(&surf, h, grid.dx, prm.surface.sigma, s)
    });
    if let Some(p) = &points {
        info.jump_particles = p.iter().filter(|x| x.is_some()).count();
        for (fixed, p) in surf.fixed.iter_mut().zip(p) {
            *fixed |= p.is_some();
        }
        info.trimmed_cells =
            jump::trim_level_set(grid, &surf, p, spacing.unwrap_or(0.0), 1.5 * grid.dx);
    }
    info.operators_s = t.elapsed().as_secs_f64();
    info.particles = surf.len();
    info.counts = surf.counts;
    info.fits = surf.fits;
    let t = Instant::now();
    let sheets = &surf.nb.x[..surf.n_sheet()];
    let cut_mode = prm.layer == LayerTension::Cut;
    let constrains = |i: usize| {
        if cut_mode {
            !surf.attached[i]
        } else {
            points.as_ref().is_none_or(|p| p[i].is_none())
        }
    };
    // with the cut layer: ψ zero half a spacing inside the layer
    let cut = (cut_mode && spacing.is_some()).then(|| {
        let shift = prm.surface_radius * grid.dx - 0.5 * spacing.unwrap_or(0.0);
        cut::Cut::build(
            grid,
            solids,
            &surf,
            prm.surface.mls.h,
            shift,
            spacing.unwrap_or(0.0),
            prm.surface.density,
        )
    });
    if cut.is_some() {
        // the liquid up to the cut carries the body's mass
        let f = cut::LAYER_INERTIA;
        for (m, a) in surf.mass.iter_mut().zip(&surf.attached) {
            if *a {
                *m *= f;
            }
        }
    }
    if let Some(c) = &cut {
        info.cut_cells = c.cut_cells;
        info.cut_free_cells = c.free_cells;
        info.cut_light_faces = c.light_faces;
    }
    // the grid's system and K, and beside them the particles' order in the
    // coupled system (it needs only the Laplacian's pattern)
    let ((full, constrained, released, shift), order) = {
        let grid = &*grid;
        rayon::join(
            || {
                let full = match &cut {
                    Some(c) => c.poisson(grid, |_, _| false),
                    None => Poisson::build(grid, solids, |_, _| false),
                };
                // K after the pre-solve release, with the face masses of
                // eq. (19) (per face, so releasing more faces later leaves
                // the others' as they are)
                let mut constrained = faces::constraints_of(grid, &full, sheets, constrains);
                constrained.floor = prm.mass_floor;
                let released = constrained.release_enclosed(grid, &full, sheets);
                let mut shift_used = None;
                if let Some(s) = spacing {
                    let shift = prm.surface_radius * grid.dx - 0.5 * s;
                    match prm.face_mass {
                        FaceMass::Sheet => constrained.set_mass(grid, &full, shift),
                        // (with the cut layer the faces' mass has no volume to
                        // balance when none is constrained)
                        FaceMass::Balanced if cut.is_some() && constrained.is_empty() => {}
                        FaceMass::Balanced => {
                            let target = 3.0 * totals.0 / (prm.surface.density * grid.dx.powi(3));
                            let (d, bounded) =
                                constrained.set_mass_balanced(grid, &full, shift, target, s);
                            shift_used = Some((d / grid.dx, bounded));
                        }
                        FaceMass::LevelSet => {}
                    }
                }
                (full, constrained, released, shift_used)
            },
            || {
                (prm.ilu_order == IluOrder::ParticlesFirst)
                    .then(|| system::particle_order(&surf))
                    .transpose()
            },
        )
    };
    if let Some((d, bounded)) = shift {
        info.mass_shift = d;
        info.mass_shift_bounded = bounded;
    }
    let porder = order.map_err(solve_err("coupled system order"))?;
    info.cells = full.cells.len();
    info.theta_clamps = full.theta_clamps;
    let sc = Scalars {
        dt,
        sigma: prm.surface.sigma,
        viscosity: prm.surface.viscosity,
        density: prm.surface.density,
        dx: grid.dx,
        theta: prm.surface.tension_theta,
    };
    let mut full = full;
    if let Some(p) = &points {
        let scale = dt / (sc.density * grid.dx);
        let air = jump::air_values(
            grid,
            &full,
            &constrained,
            &surf,
            p,
            prm.surface.mls.h,
            scale,
        );
        info.jump_faces = air.len();
        full.set_air(grid, air);
    }
    // the band's probes, read once from v** before the extension changes
    // the constraint faces (band::band_probes)
    let probes = match prm.band {
        BandVelocity::Extrapolated | BandVelocity::Extended => Some(band_probes(grid, &surf)),
        BandVelocity::Sheet => None,
    };
    // the liquid's velocity at the constraint faces, from below the band
    // (band::band_extension); u_old with it, so that FLIP carries to the
    // volume particles only what the solve changes
    if let (BandVelocity::Extended, Some(probes)) = (prm.band, &probes) {
        let ext = band_extension(grid, &constrained, probes);
        for (f, &e) in ext.iter().enumerate() {
            let (a, s) = constrained.faces[f];
            if grid.weight[a][s] > 0.0 && !grid.is_prescribed(a, s) {
                let du = e - grid.u[a][s];
                full.shift_face_velocity(grid, a, s, du);
                grid.u[a][s] = e;
                grid.u_old[a][s] = e;
            }
        }
    }
    // the velocity jump no substep makes physically (release::outlier_bound)
    let v_ref = grid
        .u
        .iter()
        .flat_map(|c| c.iter())
        .chain(parts.v.iter().flat_map(|v| v.iter()))
        .fold(0.0 as Real, |m, v| m.max(v.abs()));
    let bound = release::outlier_bound(v_ref, sc.sigma, sc.density, sc.dx);
    // cells around which the solve found outliers (release::outlier_cells)
    let mut around: Vec<usize> = Vec::new();
    // set after both methods failed: the weakly pinned cells are released
    let mut weak = false;
    let (k, vstar, sys, x, kept, u) = loop {
        let mut k = constrained.clone();
        info.released_faces = released + k.release_around(grid, &full, &around);
        if weak {
            info.released_faces += k.release_weak(grid, &full);
        }
        info.faces = k.len();
        if k.is_empty() && cut.as_ref().is_none_or(|c| c.entries.is_empty()) {
            return forms::solve_uncoupled(
                grid,
                solids,
                parts,
                prm,
                dt,
                layers,
                &surf,
                &full,
                cut.as_ref(),
                info,
                t,
            );
        }
        let mut vstar: Vec<Real> = k.faces.iter().map(|&(a, s)| grid.u[a][s]).collect();
        // K v = K (J u + c): in the face rows, v** − c takes the place of v**
        let band = match &probes {
            Some(p) => band_correction(grid, &surf, &k, p),
            None => vec![0.0; k.len()],
        };
        for (v, c) in vstar.iter_mut().zip(&band) {
            *v -= c;
        }
        // the chosen method; if its solve fails, the other one (counted)
        // (the cut layer's rows are built for the reduced form only)
        let order: &[Form] = match prm.method {
            _ if cut.is_some() => &[Form::Reduced],
            Method::Monolithic => &[Form::Monolithic, Form::Reduced],
            Method::Schur => &[Form::Reduced, Form::Monolithic],
        };
        let mut attempt = None;
        let mut failed = None;
        for (n, &form) in order.iter().enumerate() {
            let t = if n == 0 && around.is_empty() && !weak {
                t
            } else {
                Instant::now()
            };
            match forms::solve_form(
                form,
                grid,
                solids,
                &full,
                &surf,
                &k,
                &vstar,
                &band,
                sc,
                prm,
                &mut info,
                t,
                warm.as_ref(),
                porder.as_ref(),
                cut.as_ref(),
            ) {
                Ok(r) => {
                    attempt = Some(r);
                    break;
                }
                Err(e) if n + 1 < order.len() => {
                    info.method_fallbacks += 1;
                    info.first_failure = Some(e.to_string());
                }
                Err(e) => failed = Some(e),
            }
        }
        if let Some(e) = failed {
            // both failed: once, release the weakly pinned enclosed cells
            // and solve again (counted as a release round)
            if !weak && k.release_weak(grid, &full) > 0 {
                weak = true;
                info.outlier_rounds += 1;
                continue;
            }
            if order.len() == 1 {
                return Err(e);
            }
            return Err(CouplingError::BothFailed {
                first: info.first_failure.take().unwrap_or_default(),
                second: Box::new(e),
            });
        }
        let (sys, x, kept) = attempt.expect("a solve succeeded or returned");
        let q = &x[sys.qo..sys.qo + sys.nq];
        let u: Vec<Vec3> = (0..sys.np)
            .map(|i| Vec3::new(x[sys.u_row(i, 0)], x[sys.u_row(i, 1)], x[sys.u_row(i, 2)]))
            .collect();
        // (with the cut layer a face moves by its mobility times the jump
        // of q, a closed face not at all, and a constraint face to J u
        // whatever q: the particles' u bounds those)
        let bad = match &cut {
            Some(c) => release::outlier_cells(
                grid,
                &full,
                q,
                &surf.nb.x,
                &u,
                bound,
                |a, f, s, o| match f {
                    Some(f) if k.index(a, f).is_some() => 0.0,
                    Some(f) => c.velocity_gain(a, f, s, o),
                    None => 0.0,
                },
            ),
            None => {
                release::outlier_cells(grid, &full, q, &surf.nb.x, &u, bound, release::uniform_gain)
            }
        };
        if bad.is_empty() {
            break (k, vstar, sys, x, kept, u);
        }
        let fresh = bad.iter().any(|c| around.binary_search(c).is_err());
        if !fresh || info.outlier_rounds == MAX_OUTLIER_ROUNDS {
            return Err(CouplingError::Outlier {
                at: grid.cell_pos(bad[0]),
                bound,
                rounds: info.outlier_rounds,
            });
        }
        info.outlier_rounds += 1;
        around.extend(bad);
        around.sort_unstable();
        around.dedup();
    };
    *warm = Some(kept);
    let q = &x[sys.qo..sys.qo + sys.nq];
    // (Gq)_f and the velocity change that takes each constraint face from
    // the pressure update of the ghost-fluid projection to (J u)_f
    let gq: Vec<Real> = (0..k.len())
        .map(|f| {
            let sd = k.sides[f];
            let ql = sd.lo.map_or(0.0, |c| q[c as usize]);
            let qh = sd.hi.map_or(0.0, |c| q[c as usize]);
            qh - ql
        })
        .collect();
    let ju: Vec<Real> = (0..k.len()).map(|f| k.interpolate(f, &u)).collect();
    let dv: Vec<Real> = (0..k.len())
        .map(|f| ju[f] - vstar[f] + gq[f] / k.sides[f].theta)
        .collect();
    info.interior_pressure = interior_pressure(&full, q, grid.dx, sc);
    if prm.verify && cut.is_none() {
        // μ_f = θ_f ((J u)_f − v**_f) + (Gq)_f from the face rows
        let mu: Vec<Real> = (0..k.len())
            .map(|f| system::mono_theta(&k, f) * (ju[f] - vstar[f]) + gq[f])
            .collect();
        info.eq24_residual = Some(eq24_residual(&full, &surf, &k, &vstar, sc, q, &u, &mu)?);
    }
    let extra = |a, s| k.index(a, s).map_or(0.0, |f| dv[f]);
    let mut valid = match &cut {
        Some(c) => c.apply(grid, &full, q, |a, s| k.index(a, s).is_some(), extra),
        None => full.apply(grid, q, extra),
    };
    // the momentum the layer took in the solve, which its velocity from
    // the grid below drops, back to its body's faces (Cut::hand_back)
    if let Some(c) = &cut {
        let dp: Vec<(Vec3, Vec3)> = (0..surf.len())
            .filter(|&i| surf.attached[i])
            .map(|i| {
                (
                    surf.nb.x[i],
                    surf.mass[i] * (u[i] - parts.v[surf.nb.store[i]]),
                )
            })
            .collect();
        c.hand_back(grid, &dp, sc.density);
    }
    extrapolate(grid, &mut valid, layers);
    constrain_solids(grid, solids);
    // the surface layer of a volume moves with the liquid it bounds: its
    // velocity is the projected grid velocity (its own u^{n+1} agrees with
    // it through the constraint faces up to the modes that J averages out,
    // which would otherwise drift the layer off the volume)
    let mut u = u;
    for (i, &s) in surf.nb.store.iter().enumerate() {
        if surf.attached[i] {
            u[i] = match &cut {
                Some(c) => c.layer_velocity(grid, &parts.x[s]),
                None => grid.velocity(&parts.x[s]),
            };
        }
    }
    write_back(parts, &surf, &u);
    Ok(info)
}

/// Mass (kg) and number of the volume particles, summed in store order.
fn volume_totals(parts: &Particles) -> (Real, usize) {
    let (mut m, mut n) = (0.0, 0usize);
    for (c, mass) in parts.codim.iter().zip(&parts.mass) {
        if *c == crate::particles::Codim::Volume {
            m += mass;
            n += 1;
        }
    }
    (m, n)
}

/// Spacing (m) of the volume particles, (m̄/ρ)^{1/3} from their mean mass
/// (`totals` from [`volume_totals`]); `None` without volume particles.
fn volume_spacing((m, n): (Real, usize), density: Real) -> Option<Real> {
    (n > 0 && m > 0.0).then(|| (m / n as Real / density).cbrt())
}

/// Mean of p = q ρ Δx / Δt over cells with φ < −Δx.
fn interior_pressure(full: &Poisson, q: &[Real], dx: Real, sc: Scalars) -> Real {
    let (mut sum, mut n) = (0.0, 0usize);
    for (i, &s) in full.cells.iter().enumerate() {
        if full.phi[s] < -dx {
            sum += q[i];
            n += 1;
        }
    }
    if n == 0 {
        0.0
    } else {
        sum / n as Real * sc.density * dx / sc.dt
    }
}

/// u^{n+1} and the updated radii into the store (fixed particles keep theirs;
/// a surface layer held in the solve by `coupling.layer: jump` is not fixed
/// in the store and takes its u).
fn write_back(parts: &mut Particles, surf: &surface::Surface, u: &[Vec3]) {
    for (i, &s) in surf.nb.store.iter().enumerate() {
        if !parts.fixed[s] {
            parts.v[s] = u[i];
        }
        if let Some(r) = surf.radius[i] {
            parts.radius[s] = r;
        }
    }
}
