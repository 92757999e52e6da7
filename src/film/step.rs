//! One film step (Algorithm 1 for sheets, filaments and points, no grid).
//!
//! 1. advect: x += Δt u (fixed boundary particles move with their
//!    prescribed velocity);
//! 2. codimension update (§8) on the joint sheet + filament set, then two
//!    counted guards: filament clumps (PCA λ₂ > `clump_ratio` λ₁) become
//!    points, sheet particles that span no plane become filaments (points
//!    when they have no neighbour at all);
//! 3. reseeding (§9), new particles lifted onto the local MLS fit; filament
//!    insertion only along line-like filament frames;
//! 4. control areas (Appendix D), thickness/radius from mass, explicit
//!    forces: gravity, air drag, wind (or a jet's trapped air in a blown
//!    bag), enclosed gas, rim and bud tension (§6); points move
//!    ballistically;
//! 5. viscosity (§5, eq. 13) with the joint Laplacian, only when μ > 0;
//! 6. semi-implicit surface tension (eq. 16) on the joint Laplacian with
//!    the sheet weight in filament fits set to 0 (§7);
//! 7. with `film.bag_air`, the air of a blown bag and its bubbles
//!    ([`super::air`]): one pressure per pocket, implicit with the tension
//!    through a second tension solve with a probe pressure.
//!
//! Neighbourhoods and frames are built once after advection; stages 4–6
//! reuse them when stages 2–3 changed nothing, and rebuild them once
//! otherwise. The reseeding fits only the particles that propose a new one;
//! the tension rows are fitted once, in stage 6.
//!
//! The step works on a sub-store of the sheet and filament particles in
//! joint order (sheets then filaments) so that neighbour lists, frames and
//! matrix rows share one index; the store is rebuilt at the end with the
//! other particles first, in their previous order.

pub use super::advance::{advance_by, film_speed, motion_speed, step_with_retry};
use super::air::{
    stage as air_stage, survey as air_survey, trapped_jet, Sheets, Survey as AirSurvey,
};
use super::shape::FittedShape;
use super::viscosity::viscosity;
use super::{weight, FilmError, FilmParams, FilmState, FilmStepInfo};
use crate::coupling::surface::{particle_terms, SurfaceParams};
use crate::gas::{enclosed_volume, fit_sphere, orient_normals, pressure_forces, wind_drag};
use crate::math::{Mat3, Real, Vec3};
use crate::mls::operators::{par_frames, Neighborhoods};
use crate::mls::{Frame, JointLaplacian, MlsParams};
use crate::particles::{Codim, Particles};
use crate::reseed::reseed_guarded;
use crate::tension::{solve as solve_tension, CurvaturePart, TensionSystem};
use crate::transition::{cone_census, update_codims};
use rayon::prelude::*;
use std::cmp::Ordering;
use std::time::Instant;

/// What stage 2 built and stages 4–6 may reuse.
struct Kept {
    nb: Neighborhoods,
    frames: Vec<Frame>,
}

fn first_non_finite(p: &Particles) -> Option<u64> {
    (0..p.len())
        .find(|&i| {
            !(p.x[i].iter().chain(p.v[i].iter()).all(|c| c.is_finite())
                && p.mass[i].is_finite()
                && p.radius[i].is_finite())
        })
        .map(|i| p.id[i])
}

fn check(p: &Particles, stage: &'static str) -> Result<(), FilmError> {
    match first_non_finite(p) {
        Some(id) => Err(FilmError::NonFinite { stage, id }),
        None => Ok(()),
    }
}

/// Splits the store into (others, film sub-store in joint order).
fn split(parts: &Particles) -> (Particles, Particles) {
    let mut others = Particles {
        next_id: parts.next_id,
        ..Particles::default()
    };
    let mut film = Particles {
        next_id: parts.next_id,
        ..Particles::default()
    };
    let copy = |dst: &mut Particles, i: usize| {
        dst.x.push(parts.x[i]);
        dst.v.push(parts.v[i]);
        dst.mass.push(parts.mass[i]);
        dst.radius.push(parts.radius[i]);
        dst.codim.push(parts.codim[i]);
        dst.id.push(parts.id[i]);
        dst.fixed.push(parts.fixed[i]);
    };
    for c in [Codim::Sheet, Codim::Filament] {
        for i in (0..parts.len()).filter(|&i| parts.codim[i] == c) {
            copy(&mut film, i);
        }
    }
    for i in (0..parts.len()).filter(|&i| !matches!(parts.codim[i], Codim::Sheet | Codim::Filament))
    {
        copy(&mut others, i);
    }
    (others, film)
}

/// Re-joins the two parts (others first).
fn join(mut others: Particles, film: Particles) -> Particles {
    others.append(film);
    others
}

/// Moves points (C = 3) and filament particles that left the joint set:
/// gravity and drag only.
fn ballistic(p: &mut Particles, prm: &FilmParams, dt: Real) {
    for i in 0..p.len() {
        if p.codim[i] == Codim::Point && !p.fixed[i] {
            p.v[i] += prm.gravity * dt;
            p.v[i] *= 1.0 / (1.0 + prm.damping * dt);
        }
    }
}

/// Runs one film step of length `dt` on `parts`.
pub fn step(
    parts: &mut Particles,
    state: &mut FilmState,
    prm: &FilmParams,
    dt: Real,
) -> Result<FilmStepInfo, FilmError> {
    let mut info = FilmStepInfo::default();
    let h = prm.mls.h;

    // 1. advection
    let t = Instant::now();
    parts
        .x
        .par_iter_mut()
        .zip(parts.v.par_iter())
        .for_each(|(x, v)| *x += v * dt);
    check(parts, "advect")?;
    info.timings.advect = t.elapsed().as_secs_f64();

    // 2. codimension update on the joint set
    let t = Instant::now();
    let (mut others, mut film) = split(parts);
    let geom_mls = MlsParams {
        sheet_weight_in_filament: 0.0,
        ..prm.mls
    };
    // neighbourhoods and frames of stage 2, reused by stages 4–6 when neither
    // the transitions nor the reseeding changed the particle set (same
    // positions, same joint order)
    let mut kept: Option<Kept> = None;
    if !film.is_empty() && (prm.transitions.is_some() || prm.reseed.is_some()) {
        let nb = Neighborhoods::build(&film.x, &film.codim, h)?;
        let frames = par_frames(&nb, &geom_mls);
        let axes: Vec<Mat3> = frames.iter().map(|f| f.axes).collect();
        if let Some(tp) = &prm.transitions {
            let was_filament: Vec<bool> =
                film.codim.iter().map(|c| *c == Codim::Filament).collect();
            // a sheet particle within h of a ring particle is attached to the
            // ring, not at a free edge, while film lies beside it: it keeps its
            // codimension. Reseeding fills the gap that opens between a ring and
            // a film pulled away from it (moving rings, or a film blown into a
            // bag on a static ring) with a row ~0.5 spacings from the ring; the
            // ring particles beside it fall outside the π/6 cone along b², so
            // the cone test took the new row for a rim: its rim force launched
            // it (moving rings), or it was absorbed into the ring with the film
            // it had collected, draining the film's mass into the ring until the
            // film tore there (blowing bubble, docs/decisions.md). At a static
            // ring the pin holds only while the cone test without the ring
            // finds film on a side, so a film that has left the ring (a pinched
            // catenoid's half retracting to it) still ends in a rim there.
            let pinned: Vec<bool> = (0..film.len())
                .map(|i| {
                    if film.fixed[i] {
                        return true;
                    }
                    if film.codim[i] != Codim::Sheet {
                        return false;
                    }
                    let nbrs = nb.lists.of(i);
                    let (mut ring, mut moving) = (false, false);
                    for &q in nbrs {
                        let q = q as usize;
                        if film.fixed[q] {
                            ring = true;
                            moving |= film.v[q].norm() > 0.0;
                        }
                    }
                    if !ring || moving {
                        return ring;
                    }
                    let free: Vec<u32> = nbrs
                        .iter()
                        .copied()
                        .filter(|&q| !film.fixed[q as usize])
                        .collect();
                    let b2: Vec3 = axes[i].column(1).into();
                    let c = cone_census(
                        i,
                        &b2,
                        tp.sheet_to_filament_angle,
                        tp.h,
                        &film.x,
                        &film.codim,
                        &free,
                    );
                    let (sp, sm) = c.count(&[Codim::Sheet, Codim::Filament]);
                    sp > 0 || sm > 0
                })
                .collect();
            info.transitions = update_codims(
                &film.x,
                &mut film.codim,
                &pinned,
                &axes,
                |i| nb.lists.of(i),
                tp,
            );
            // a filament particle whose filament neighbourhood is not line-like
            // (second PCA eigenvalue above `clump_ratio` × the first) is a clump:
            // no curve fits it, so it becomes a point (a droplet)
            for (i, f) in frames.iter().enumerate() {
                let [l1, l2, _] = f.eigenvalues;
                // (frames of particles that were filaments already: filament neighbours only)
                if was_filament[i]
                    && film.codim[i] == Codim::Filament
                    && !film.fixed[i]
                    && l1 > 0.0
                    && l2 > prm.clump_ratio * l1
                {
                    film.codim[i] = Codim::Point;
                    info.transitions.filament_to_point += 1;
                }
            }
            // a sheet particle that spans no plane (isolated, fewer than three
            // sheet neighbours, or a line-like neighbourhood) has no sheet fit:
            // it joins the filaments, or becomes a point when alone
            let old: Vec<Codim> = film.codim.clone();
            for (i, f) in frames.iter().enumerate() {
                if old[i] != Codim::Sheet || film.fixed[i] {
                    continue;
                }
                let nbrs = nb.lists.of(i);
                let n_sheet_nbrs = nbrs
                    .iter()
                    .filter(|&&q| old[q as usize] == Codim::Sheet)
                    .count();
                let [l1, l2, _] = f.eigenvalues;
                if nbrs.is_empty() {
                    film.codim[i] = Codim::Point;
                    info.transitions.sheet_to_filament += 1;
                    info.transitions.filament_to_point += 1;
                } else if n_sheet_nbrs < 3
                    || l2.partial_cmp(&(prm.sheet_line_ratio * l1)) == Some(Ordering::Less)
                    || l2.is_nan()
                    || l1.is_nan()
                {
                    film.codim[i] = Codim::Filament;
                    info.transitions.sheet_to_filament += 1;
                }
            }
        }
        info.timings.transition = t.elapsed().as_secs_f64();
        // 3. reseeding
        let t = Instant::now();
        if let Some(rp) = &prm.reseed {
            let shape = FittedShape {
                nb: &nb,
                frames: &frames,
                mls: &geom_mls,
            };
            // filament insertion only along line-like filament frames (the
            // frame of a particle that was a sheet until this step is a
            // sheet frame; a clump has no tangent)
            let nb_joint = nb.n_sheet;
            let line_like = |i: usize| {
                let [l1, l2, _] = frames[i].eigenvalues;
                i >= nb_joint && l1 > 0.0 && l2 <= prm.clump_ratio * l1
            };
            info.reseed = reseed_guarded(
                &mut film,
                &axes,
                |i| nb.lists.of(i),
                &shape,
                rp,
                line_like,
                &[],
            );
        }
        info.timings.reseed = t.elapsed().as_secs_f64();
        let unchanged =
            info.transitions.total() == 0 && info.reseed.inserted() + info.reseed.removed() == 0;
        if unchanged {
            kept = Some(Kept { nb, frames });
        }
    } else {
        info.timings.transition = t.elapsed().as_secs_f64();
    }
    // points that just appeared leave the film set
    let (more_others, film) = split(&film);
    others = join(others, more_others);
    others.next_id = others.next_id.max(film.next_id);
    let mut film = film;
    ballistic(&mut others, prm, dt);
    if film.is_empty() {
        *parts = others;
        check(parts, "reseed")?;
        state.time += dt;
        return Ok(info);
    }

    // 4. areas, thickness, explicit forces
    let t = Instant::now();
    let (nb, frames) = match kept {
        Some(k) => {
            info.reused_neighborhoods = true;
            (k.nb, k.frames)
        }
        None => {
            let nb = Neighborhoods::build(&film.x, &film.codim, h)?;
            let frames = par_frames(&nb, &geom_mls);
            (nb, frames)
        }
    };
    let n = film.len();
    let n_sheet = nb.n_sheet;
    // areas, radii and rim/bud forces: the code the coupled step uses
    // (`coupling::surface::particle_terms`); every film sheet is free (two
    // faces) when `free_film`
    let sp = SurfaceParams {
        mls: geom_mls,
        sigma: prm.sigma,
        density: prm.density,
        // the film step solves viscosity on its own (stage 5)
        viscosity: 0.0,
        bud_angle: prm.bud_angle,
        rim_modulation: prm.rim_modulation,
        diffusive: prm.diffusive,
        // not read by particle_terms; the film's solve below keeps θ = 1
        tension_theta: 1.0,
    };
    let terms = particle_terms(&nb, &frames, |i| film.mass[i], |_| prm.free_film, &sp);
    let voronoi: Vec<Real> = terms.iter().map(|t| t.voronoi).collect();
    let area: Vec<Real> = terms.iter().map(|t| t.area).collect();
    let mut f: Vec<Vec3> = terms.iter().map(|t| t.force).collect();
    for (i, t) in terms.iter().enumerate() {
        if let Some(r) = t.radius {
            film.radius[i] = r;
        }
        f[i] += prm.gravity * film.mass[i] - film.v[i] * (prm.damping * film.mass[i]);
    }
    if prm.marangoni && prm.gravity != Vec3::zeros() {
        let held = weight::held(n_sheet, &film.fixed, |i| nb.lists.of(i));
        weight::carry_to_ring(&mut f, &film.mass, &film.fixed, &held, prm.gravity, |i| {
            frames[i].axis(2)
        });
    }
    // enclosed gas and wind act along the sheet normals
    let mut drag: Vec<Real> = Vec::new();
    // oriented sheet normals and sheet neighbour lists, kept for the air
    let mut sheet_geo: Option<(Vec<Vec3>, Vec<Vec<u32>>)> = None;
    let mut survey: Option<AirSurvey> = None;
    if state.gas.is_some() || prm.wind.is_some() || prm.air.is_some() {
        let mut normals: Vec<Vec3> = frames[..n_sheet].iter().map(|fr| fr.axis(2)).collect();
        let sheet_nbrs: Vec<Vec<u32>> = (0..n_sheet)
            .map(|i| {
                nb.lists
                    .of(i)
                    .iter()
                    .copied()
                    .filter(|&q| (q as usize) < n_sheet)
                    .collect()
            })
            .collect();
        orient_normals(&film.x[..n_sheet], &mut normals, |i| &sheet_nbrs[i]);
        if let Some(g) = state.gas.as_mut() {
            // gas volume from the best-fit sphere: insensitive to holes
            let v = fit_sphere(&film.x[..n_sheet], &normals, &voronoi[..n_sheet])
                .map(|(_, r)| 4.0 / 3.0 * std::f64::consts::PI * r.powi(3))
                .unwrap_or_else(|| {
                    enclosed_volume(&film.x[..n_sheet], &normals, &voronoi[..n_sheet])
                });
            if g.v0 <= 0.0 {
                // rest volume measured on the first step (an open film's
                // volume differs from the closed sphere's)
                g.v0 = v;
            }
            info.gas_volume = Some(v);
            for (i, fp) in pressure_forces(&normals, &voronoi[..n_sheet], g.excess_pressure(v))
                .into_iter()
                .enumerate()
            {
                f[i] += fp;
            }
        }
        // the air of a blown bag: while the jet blows, the walls of the bag
        // feel its stagnation pressure instead of its drag
        let mut in_jet_bag = vec![false; n_sheet];
        if let Some(ap) = &prm.air {
            let sheets = Sheets::of(&film, n_sheet, &voronoi, &normals);
            let wind = prm.wind.as_ref();
            let sv = air_survey(&sheets, |i| &sheet_nbrs[i], ap);
            in_jet_bag = trapped_jet(&sheets, &sv, wind, state.time, &mut f);
            survey = Some(sv);
        }
        if let Some(w) = &prm.wind {
            drag = vec![0.0; n];
            for i in 0..n_sheet {
                let wind_here = if in_jet_bag[i] {
                    Vec3::zeros()
                } else {
                    w.at(state.time, &film.x[i])
                };
                // one-face area: the wind's pressure acts across the film;
                // implicit in the normal velocity (`gas::wind_drag`)
                let (d, fw) = wind_drag(
                    &wind_here,
                    &film.v[i],
                    &normals[i],
                    voronoi[i],
                    w.air_density,
                    w.drag,
                );
                drag[i] = d;
                f[i] += fw;
            }
        }
        sheet_geo = Some((normals, sheet_nbrs));
    }
    info.timings.forces = t.elapsed().as_secs_f64();

    // 5. viscosity (eq. 13), only when μ > 0
    let mut u: Vec<Vec3> = film.v.clone();
    if prm.viscosity > 0.0 {
        let t = Instant::now();
        let lv = JointLaplacian::assemble_with_frames(&nb, &frames, &prm.mls)?;
        info.viscosity_solve = viscosity(&lv.matrix, &film, &mut u, prm, dt)?;
        info.timings.viscosity = t.elapsed().as_secs_f64();
    }

    // 6. semi-implicit surface tension (eq. 16)
    let t = Instant::now();
    let l = JointLaplacian::assemble_with_frames(&nb, &frames, &geom_mls)?;
    info.fits = l.stats;
    info.timings.operators = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let axes: Vec<Mat3> = frames.iter().map(|fr| fr.axes).collect();
    let sys = TensionSystem {
        laplacian: l.matrix.as_ref(),
        mass: &film.mass,
        area: &area,
        x: &film.x,
        u: &u,
        f_explicit: &f,
        fixed: &film.fixed,
        drag: &drag,
        // viscosity has its own solve above (stage 5)
        nu: 0.0,
        sigma: prm.sigma,
        dt,
        curvature: CurvaturePart::Normal {
            axes: &axes,
            n_sheet,
        },
        diffusive: prm.diffusive,
        theta: 1.0,
    };
    let sol = solve_tension(&sys, &prm.solver).map_err(|e| FilmError::Solve {
        stage: "surface tension",
        source: e,
    })?;
    info.tension_solve = sol.info;
    let mut u_new = sol.u;
    // 7. the air of a blown bag and its bubbles: one pressure per pocket,
    //    implicit with the tension through a second solve with a probe
    //    pressure in every pocket (`film::air`)
    if let (Some(ap), Some((normals, _)), Some(sv)) = (&prm.air, &sheet_geo, &survey) {
        let sheets = Sheets::of(&film, n_sheet, &voronoi, normals);
        let jet = prm.wind.as_ref().is_some_and(|w| w.jet_blowing(state.time));
        let probe = |fp: &[(usize, Vec3)]| {
            let mut f_probe = f.clone();
            for &(i, v) in fp {
                f_probe[i] += v;
            }
            let sys = TensionSystem {
                f_explicit: &f_probe,
                ..sys
            };
            solve_tension(&sys, &prm.solver).map(|s| s.u)
        };
        let a = air_stage(
            &sheets,
            sv,
            &mut u_new[..n_sheet],
            ap,
            &mut state.air,
            dt,
            jet,
            probe,
        )
        .map_err(|e| FilmError::Solve {
            stage: "bag air",
            source: e,
        })?;
        info.air = Some(a);
    }
    for (i, v) in u_new.into_iter().enumerate().take(n) {
        if !film.fixed[i] {
            film.v[i] = v;
        }
    }
    state.time += dt;
    info.timings.tension = t.elapsed().as_secs_f64();
    *parts = join(others, film);
    check(parts, "surface tension")?;
    Ok(info)
}
