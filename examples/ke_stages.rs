//! Kinetic energy through the stages of each substep of the pure-inertia
//! l = 2 droplet (σ ≈ 0, started from the potential flow 0.05 (−x, 2y, −z)
//! 1/s, whose kinetic energy should stay): the particles' own, the grid's
//! interpolated at the particles before and after the solve, after G2P, for
//! the volume and the surface layer apart (`docs/decisions.md`, "A linear
//! velocity at the free surface"). Energies in nJ; `tot` is the kept
//! fraction.
//! Arguments (optional): R/Δx (4), Δt (0.01), substeps (10).
//! Environment: FLIP, APIC, FIT=linear (`solver.velocity_fit`),
//! BAND=extended|sheet (`coupling.band`), NOLAYER (every particle a volume
//! particle and the plain projection).
use codimfx::advect::advect;
use codimfx::grid::transfer::{grid_to_particles, transfer_to_grid};
use codimfx::math::{Real, Vec3};
use codimfx::particles::Codim;
use codimfx::step::SimState;
use codimfx::validate::droplet::DropletCase;
fn ke(st: &SimState, vol: bool, pic: bool, old: bool) -> Real {
    let mut k = 0.0;
    for i in 0..st.particles.len() {
        let isv = st.particles.codim[i] == Codim::Volume;
        if isv != vol {
            continue;
        }
        let v = if pic {
            if old {
                let mut g = st.grid.clone();
                std::mem::swap(&mut g.u, &mut g.u_old);
                g.velocity(&st.particles.x[i])
            } else {
                st.grid.velocity(&st.particles.x[i])
            }
        } else {
            st.particles.v[i]
        };
        k += 0.5 * st.particles.mass[i] * v.norm_squared();
    }
    k
}
fn main() {
    let cells: Real = std::env::args().nth(1).map_or(4.0, |s| s.parse().unwrap());
    let dt: Real = std::env::args().nth(2).map_or(0.01, |s| s.parse().unwrap());
    let nsteps: usize = std::env::args().nth(3).map_or(10, |s| s.parse().unwrap());
    let mut case = DropletCase {
        elongation: 0.0,
        sigma: 1e-9,
        ..DropletCase::paper(cells)
    };
    match std::env::var("BAND").as_deref() {
        Ok("extended") => case.band = codimfx::coupling::BandVelocity::Extended,
        Ok("sheet") => case.band = codimfx::coupling::BandVelocity::Sheet,
        _ => {}
    }
    let (mut st, mut p) = case.build().unwrap();
    let a = 0.05;
    for i in 0..st.particles.len() {
        let x = st.particles.x[i];
        st.particles.v[i] = Vec3::new(-a * x.x, 2.0 * a * x.y, -a * x.z);
    }
    if std::env::var("NOLAYER").is_ok() {
        for c in st.particles.codim.iter_mut() {
            *c = Codim::Volume;
        }
        p.coupling = None;
    }
    if std::env::var("FIT").is_ok_and(|v| v == "linear") {
        p.velocity_fit = codimfx::grid::VelocityFit::Linear;
    }
    if let Ok(f) = std::env::var("FLIP") {
        p.flip = f.parse().unwrap();
    }
    let k0 = ke(&st, true, false, false) + ke(&st, false, false, false);
    for s in 0..nsteps {
        let kv0 = ke(&st, true, false, false);
        let kl0 = ke(&st, false, false, false);
        let apic = std::env::var("APIC").is_ok();
        if apic {
            st.affine.resize(st.particles.len(), [Vec3::zeros(); 3]);
        }
        let aff = st.affine.clone();
        transfer_to_grid(
            &mut st.grid,
            &st.particles,
            &st.solids,
            &p.p2g(),
            apic.then_some(aff.as_slice()),
        );
        let kvg0 = ke(&st, true, true, false);
        let klg0 = ke(&st, false, true, false);
        st.grid.set_inflow(&p.inflow);
        if let Some(cp) = p.coupling.as_ref() {
            coupling_solve(&mut st, cp, dt, p.margin + 1);
        } else {
            codimfx::grid::projection::project_liquid(
                &mut st.grid,
                &st.solids,
                p.pressure,
                p.margin + 1,
            )
            .unwrap();
        }
        let kvg1 = ke(&st, true, true, false);
        let klg1 = ke(&st, false, true, false);
        let kl1 = ke(&st, false, false, false);
        if apic {
            codimfx::grid::transfer::grid_to_particles_apic(
                &st.grid,
                &mut st.particles,
                &mut st.affine,
            );
        } else {
            grid_to_particles(&st.grid, &mut st.particles, p.flip);
        }
        let kv1 = ke(&st, true, false, false);
        let (lo, hi) = (p.lo, p.hi);
        advect(&mut st.particles, &st.grid, &st.solids, lo, hi, dt);
        let kv2 = ke(&st, true, false, false);
        let kl2 = ke(&st, false, false, false);
        if let Some(cp) = p.coupling.as_ref() {
            if let Some(tp) = cp.transitions.as_ref() {
                codimfx::coupling::codim::update(&mut st.particles, tp, &cp.sources, &st.solids);
            }
            if let Some(rp) = cp.reseed.as_ref() {
                codimfx::coupling::reseed::reseed_surface(
                    &mut st.particles,
                    &mut st.affine,
                    rp,
                    &cp.surface.mls,
                    &cp.sources,
                )
                .unwrap();
            }
        }
        let kv3 = ke(&st, true, false, false);
        let kl3 = ke(&st, false, false, false);
        let s9 = |x: Real| x * 1e9;
        println!(
            "{s:3} vol p {:.4} gridold {:.4} gridnew {:.4} flip {:.4} adv {:.4} trans {:.4} | layer p {:.4} gridold {:.4} gridnew {:.4} solved {:.4} adv {:.4} trans {:.4} | tot {:.4}",
            s9(kv0), s9(kvg0), s9(kvg1), s9(kv1), s9(kv2), s9(kv3), s9(kl0), s9(klg0), s9(klg1), s9(kl1), s9(kl2), s9(kl3), (kv3 + kl3) / k0
        );
    }
}
fn coupling_solve(
    st: &mut SimState,
    cp: &codimfx::coupling::CouplingParams,
    dt: Real,
    layers: usize,
) {
    let SimState {
        particles,
        grid,
        solids,
        warm,
        ..
    } = st;
    codimfx::coupling::solve(grid, solids, particles, cp, dt, layers, warm).unwrap();
}
