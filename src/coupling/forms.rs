//! The linear solves of one coupled substep ([`super::solve`]): one form of
//! the coupled system (eq. 24 or its Schur reduction; with the cut layer,
//! [`super::cut`], the reduced form with the cut rows) assembled, factored
//! by an incomplete LU and solved by GMRES or BiCGSTAB; and the solve
//! without coupling rows, when no face is constrained and no cell is cut.

use super::system::{self, assemble, Form, Scalars, SystemMatrix};
use super::{
    cut, faces, interior_pressure, solve_err, surface, warm, write_back, CouplingError,
    CouplingInfo, CouplingParams, IluOrder, Krylov, LayerTension, WarmStart,
};
use crate::grid::extrapolate::{constrain_solids, extrapolate};
use crate::grid::pcg::pcg;
use crate::grid::projection::Poisson;
use crate::grid::MacGrid;
use crate::linsolve::{
    bicgstab, gmres, Csr, GmresParams, Ilu0, Operator, Preconditioner, TripledIlu,
};
use crate::math::Real;
use crate::particles::Particles;
use crate::solids::SolidSet;
use crate::tension::{solve as solve_tension, CurvaturePart, TensionSystem};
use std::time::Instant;

/// The solve when no face is constrained: the pressure projection and the
/// particles' tension solve are independent (no coupling rows).
#[allow(clippy::too_many_arguments)]
pub(super) fn solve_uncoupled(
    grid: &mut MacGrid,
    solids: &SolidSet,
    parts: &mut Particles,
    prm: &CouplingParams,
    dt: Real,
    layers: usize,
    surf: &surface::Surface,
    full: &Poisson,
    cut: Option<&cut::Cut>,
    mut info: CouplingInfo,
    t: Instant,
) -> Result<CouplingInfo, CouplingError> {
    // no coupling rows: the two blocks are independent; the pressure is the
    // liquid's projection (`full`, with the surface layer's jump if any)
    info.assemble_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let mut q = vec![0.0; full.a.len()];
    let p = pcg(&full.a, &full.b, &mut q, prm.pressure).map_err(CouplingError::Pressure)?;
    info.iterations = p.iterations as usize;
    info.rel_residual = p.rel_residual;
    info.interior_pressure = interior_pressure(
        full,
        &q,
        grid.dx,
        Scalars {
            dt,
            sigma: prm.surface.sigma,
            viscosity: prm.surface.viscosity,
            density: prm.surface.density,
            dx: grid.dx,
            theta: prm.surface.tension_theta,
        },
    );
    let mut valid = match cut {
        Some(c) => c.apply(grid, full, &q, |_, _| false, |_, _| 0.0),
        None => full.apply(grid, &q, |_, _| 0.0),
    };
    extrapolate(grid, &mut valid, layers);
    constrain_solids(grid, solids);
    if !surf.is_empty() {
        let sys = TensionSystem {
            laplacian: surf.laplacian.as_ref(),
            mass: &surf.mass,
            area: &surf.area,
            x: &surf.nb.x,
            u: &surf.u,
            f_explicit: &surf.force,
            fixed: &surf.fixed,
            drag: &[],
            nu: prm.surface.viscosity / prm.surface.density,
            sigma: prm.surface.sigma,
            dt,
            curvature: CurvaturePart::Normal {
                axes: &surf.axes,
                n_sheet: surf.n_sheet(),
            },
            diffusive: prm.surface.diffusive,
            theta: prm.surface.tension_theta,
        };
        let sol = solve_tension(&sys, &prm.solver).map_err(solve_err("surface tension"))?;
        info.iterations += sol.info.iter().map(|s| s.iterations).sum::<usize>();
        info.rel_residual = sol
            .info
            .iter()
            .fold(info.rel_residual, |m, s| m.max(s.rel_residual));
        let mut u = sol.u;
        if prm.layer != LayerTension::Coupled {
            // the surface layer moves with the liquid it bounds
            for (i, &s) in surf.nb.store.iter().enumerate() {
                if surf.attached[i] {
                    u[i] = grid.velocity(&parts.x[s]);
                }
            }
        }
        write_back(parts, surf, &u);
    }
    info.solve_s = t.elapsed().as_secs_f64();
    Ok(info)
}

/// Assembles, factors and solves one form; returns the system, the solution
/// and the solution kept for the next substep's warm start.
#[allow(clippy::too_many_arguments)]
pub(super) fn solve_form(
    form: Form,
    grid: &MacGrid,
    solids: &SolidSet,
    full: &Poisson,
    surf: &surface::Surface,
    k: &faces::Constraints,
    vstar: &[Real],
    band: &[Real],
    sc: Scalars,
    prm: &CouplingParams,
    info: &mut CouplingInfo,
    t: Instant,
    warm: Option<&WarmStart>,
    order: Option<&system::ParticleOrder>,
    cut: Option<&cut::Cut>,
) -> Result<(system::Assembled, Vec<Real>, WarmStart), CouplingError> {
    let reduced = (form == Form::Reduced).then(|| {
        let skip = |a, s| k.index(a, s).is_some();
        let mut r = match cut {
            Some(c) => c.poisson(grid, skip),
            None => Poisson::build(grid, solids, skip),
        };
        if !full.air.is_empty() {
            r.set_air(grid, full.air.clone());
        }
        r
    });
    let pois = reduced.as_ref().unwrap_or(full);
    let cut_rows = cut.map_or(Vec::new(), |c| c.coupling(pois));
    let sys = assemble(
        form,
        pois,
        surf,
        k,
        vstar,
        band,
        sc,
        prm.ilu_order,
        prm.face_fill,
        prm.shared_block,
        order,
        &cut_rows,
    )
    .map_err(solve_err("coupled system assembly"))?;
    let view = match &sys.matrix {
        SystemMatrix::Shared(m) => View::Shared(m),
        SystemMatrix::General(m) => {
            View::General(Csr::from_faer(m.as_ref()).map_err(solve_err("coupled system"))?)
        }
    };
    let op: &dyn Operator = match &view {
        View::Shared(m) => *m,
        View::General(a) => a,
    };
    let n = op.dims().0;
    info.unknowns = n;
    info.nonzeros = match &view {
        View::Shared(m) => m.nonzeros(),
        View::General(a) => a.val.len(),
    };
    info.assemble_s += t.elapsed().as_secs_f64();
    let t = Instant::now();
    let ilu: Box<dyn Preconditioner> = match &view {
        View::Shared(m) => Box::new(
            TripledIlu::from_tripled(m, prm.fill_passes)
                .map_err(solve_err("coupled system ILU"))?,
        ),
        View::General(a) => {
            // the trailing λ and pressure rows of the particles-first order
            let tail = form == Form::Monolithic && prm.ilu_order == IluOrder::ParticlesFirst;
            let passes = if tail { prm.fill_passes } else { 0 };
            Box::new(
                Ilu0::with_tail_fill(a, sys.mo, passes).map_err(solve_err("coupled system ILU"))?,
            )
        }
    };
    info.factor_s += t.elapsed().as_secs_f64();
    let t = Instant::now();
    let mut x = vec![0.0; n];
    for (i, u) in surf.u.iter().enumerate() {
        for d in 0..3 {
            x[sys.u_row(i, d)] = u[d];
        }
    }
    if let Some(w) = warm {
        let pois = reduced.as_ref().unwrap_or(full);
        let mut xw = x.clone();
        let n = w.seed(grid, pois, k, &sys, sc, &mut xw);
        if n > 0 && warm::residual_norm(op, &sys.rhs, &xw) < warm::residual_norm(op, &sys.rhs, &x) {
            x = xw;
            info.warm_seeded = n;
        }
    }
    let s = match prm.krylov {
        Krylov::Gmres { restart } => gmres(
            op,
            &sys.rhs,
            &mut x,
            ilu.as_ref(),
            &GmresParams {
                tol: prm.solver.tol,
                max_iter: prm.solver.max_iter,
                restart,
            },
        ),
        Krylov::Bicgstab => bicgstab(op, &sys.rhs, &mut x, ilu.as_ref(), &prm.solver),
    };
    info.solve_s += t.elapsed().as_secs_f64();
    let s = s.map_err(solve_err(match (form, prm.krylov) {
        (Form::Monolithic, Krylov::Gmres { .. }) => "coupled system GMRES (monolithic)",
        (Form::Reduced, Krylov::Gmres { .. }) => "coupled system GMRES (Schur)",
        (Form::Monolithic, Krylov::Bicgstab) => "coupled system BiCGSTAB (monolithic)",
        (Form::Reduced, Krylov::Bicgstab) => "coupled system BiCGSTAB (Schur)",
    }))?;
    info.iterations += s.iterations;
    info.rel_residual = s.rel_residual;
    let kept = WarmStart::capture(grid, reduced.as_ref().unwrap_or(full), k, &sys, &x, sc);
    Ok((sys, x, kept))
}

/// The assembled matrix as the solver reads it.
enum View<'a> {
    /// eq. (24) particles first, its particle block stored once.
    Shared(&'a crate::linsolve::Tripled),
    /// General compressed rows.
    General(Csr<'a>),
}
