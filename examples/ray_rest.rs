//! Resting droplet at R = 4Δx, Δt = 0.01 s, 1 s: largest particle speed
//! and interior pressure against 2σ/R, for both band velocities.
//! Arguments (all optional): R/Δx, substeps, level-set radius (× Δx),
//! `coupling.mass_floor`. `LAYER=jump` in the environment runs the
//! surface layer's tension as a ghost-fluid jump (`coupling.layer: jump`);
//! `FIT=linear` sets `solver.velocity_fit: linear`, `FACE=balanced` the
//! balanced face mass.
use codimfx::coupling::BandVelocity;
use codimfx::math::Real;
use codimfx::step::{step, StageTimes};
use codimfx::validate::droplet::DropletCase;

fn main() {
    let cells: Real = std::env::args().nth(1).map_or(4.0, |s| s.parse().unwrap());
    let n: usize = std::env::args().nth(2).map_or(100, |s| s.parse().unwrap());
    let sr: Option<Real> = std::env::args().nth(3).map(|s| s.parse().unwrap());
    let floor: Option<Real> = std::env::args().nth(4).map(|s| s.parse().unwrap());
    let jump = std::env::var("LAYER").is_ok_and(|v| v == "jump");
    for band in [
        BandVelocity::Sheet,
        BandVelocity::Extrapolated,
        BandVelocity::Extended,
    ] {
        let mut case = DropletCase {
            band,
            ..DropletCase::paper(cells)
        };
        if std::env::var("FACE").is_ok_and(|v| v == "balanced") {
            case.face_mass = codimfx::coupling::FaceMass::Balanced;
        }
        if jump {
            case.layer = codimfx::coupling::LayerTension::Jump;
        }
        if let Some(sr) = sr {
            case.surface_radius = sr;
        }
        if let Some(f) = floor {
            case.mass_floor = f;
        }
        let (mut st, mut prm) = case.build().unwrap();
        if std::env::var("FIT").is_ok_and(|v| v == "linear") {
            prm.velocity_fit = codimfx::grid::VelocityFit::Linear;
        }
        let mut trace = Vec::new();
        let t = std::time::Instant::now();
        let (mut it, mut p, mut vmax) = (0usize, 0.0, 0.0);
        for k in 0..n {
            let info = step(&mut st, &prm, 0.01, &mut StageTimes::default()).unwrap();
            let c = info.coupling.unwrap();
            it += c.iterations;
            if k == 0 {
                p = c.interior_pressure;
            }
            vmax = st.particles.v.iter().map(|v| v.norm()).fold(0.0, Real::max);
            if (k + 1) % 20 == 0 {
                trace.push(format!("{vmax:.1e}"));
            }
        }
        println!(
            "{band:?}: largest speed every 20 substeps {}",
            trace.join(" ")
        );
        println!(
            "{band:?}: R = {cells}Δx, first-step p/(2σ/R) − 1 = {:+.2} %, max speed after {n} steps {vmax:.3e} m/s, mean iterations {:.0}, wall {:.1} s",
            100.0 * (p / case.young_laplace() - 1.0),
            it as Real / n as Real,
            t.elapsed().as_secs_f64()
        );
    }
}
