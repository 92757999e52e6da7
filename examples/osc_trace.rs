//! The l = 2 droplet traced over two periods: every substep, the vertical and
//! horizontal extents (relative to 2R, minus 1) and the kinetic energy
//! (`docs/decisions.md`, "The tension's implicit weight").
//! Arguments (optional): R/Δx (4), Δt (0.01), elongation e (0.05).
//! Environment: THETA (`coupling.tension_theta`), FLIP (`solver.flip`),
//! APIC (APIC transfer), NOTRANS / NORESEED (no transitions / reseeding),
//! LAYER=jump, BAND=sheet|extended (`coupling.band`), FIT=mean
//! (`solver.velocity_fit: mean`), SIGMA (σ in N/m), INITV=A (start from the potential flow
//! A(−x, 2y, −z) instead of rest; with SIGMA≈0 the kinetic energy should stay).
use codimfx::math::Real;
use codimfx::step::{step, StageTimes};
use codimfx::validate::droplet::DropletCase;
fn main() {
    let cells: Real = std::env::args().nth(1).map_or(4.0, |s| s.parse().unwrap());
    let dt: Real = std::env::args().nth(2).map_or(0.01, |s| s.parse().unwrap());
    let e: Real = std::env::args().nth(3).map_or(0.05, |s| s.parse().unwrap());
    let mut case = DropletCase {
        elongation: e,
        ..DropletCase::paper(cells)
    };
    if std::env::var("LAYER").is_ok_and(|v| v == "jump") {
        case.layer = codimfx::coupling::LayerTension::Jump;
    }
    if let Ok(t) = std::env::var("THETA") {
        case.tension_theta = t.parse().unwrap();
    }
    match std::env::var("BAND").as_deref() {
        Ok("sheet") => case.band = codimfx::coupling::BandVelocity::Sheet,
        Ok("extended") => case.band = codimfx::coupling::BandVelocity::Extended,
        _ => {}
    }
    if let Ok(sg) = std::env::var("SIGMA") {
        case.sigma = sg.parse().unwrap();
    }
    let (mut st, mut prm) = case.build().unwrap();
    if let Ok(a) = std::env::var("INITV") {
        let a: Real = a.parse().unwrap();
        for i in 0..st.particles.len() {
            let x = st.particles.x[i];
            st.particles.v[i] = codimfx::math::Vec3::new(-a * x.x, 2.0 * a * x.y, -a * x.z);
        }
    }
    if std::env::var("FIT").is_ok_and(|v| v == "linear") {
        prm.velocity_fit = codimfx::grid::VelocityFit::Linear;
    }
    if let Ok(f) = std::env::var("FLIP") {
        prm.flip = f.parse().unwrap();
    }
    if std::env::var("APIC").is_ok() {
        prm.transfer = codimfx::scene::Transfer::Apic;
    }
    if let Some(c) = prm.coupling.as_mut() {
        if std::env::var("NOTRANS").is_ok() {
            c.transitions = None;
        }
        if std::env::var("NORESEED").is_ok() {
            c.reseed = None;
        }
    }
    let tr = case.rayleigh_period();
    let n = (2.2 * tr / dt) as usize;
    let ext = |st: &codimfx::step::SimState| {
        let (mut ymax, mut ymin, mut xmax, mut xmin) = (Real::MIN, Real::MAX, Real::MIN, Real::MAX);
        let mut ke = 0.0;
        for i in 0..st.particles.len() {
            let x = st.particles.x[i];
            ymax = ymax.max(x.y);
            ymin = ymin.min(x.y);
            xmax = xmax.max(x.x);
            xmin = xmin.min(x.x);
            ke += 0.5 * st.particles.mass[i] * st.particles.v[i].norm_squared();
        }
        (ymax - ymin, xmax - xmin, ke)
    };
    let (y, x, k) = ext(&st);
    println!(
        "t 0 ey {:.5} ex {:.5} ke {:.3e}",
        y / (2.0 * case.radius) - 1.0,
        x / (2.0 * case.radius) - 1.0,
        k
    );
    for s in 1..=n {
        step(&mut st, &prm, dt, &mut StageTimes::default()).unwrap();
        let (y, x, k) = ext(&st);
        println!(
            "t {:.3} ey {:+.5} ex {:+.5} ke {:.3e}",
            s as Real * dt,
            y / (2.0 * case.radius) - 1.0,
            x / (2.0 * case.radius) - 1.0,
            k
        );
    }
    println!("rayleigh {tr:.4}");
}
