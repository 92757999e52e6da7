//! The fluid chain's first link (Fig. 3; Bush & Hasha 2004):
//! `presets/fluid_chain_links.yaml` at `--scale 2` (Δx = 4.2 mm), two jets
//! of radius a = 8 mm at v₀ = 0.6 m/s colliding at 90° at y = 0.48 m, with
//! σ = 0.2 N/m.
//!
//! The collision spreads a sheet in the plane normal to the jets' plane (here
//! the y–z plane). Taylor's thickness distribution puts h r = a² sin³45°
//! sideways, and the rim stops where the sheet's speed v₀ meets the
//! Taylor–Culick speed √(2σ/ρh): the sheet opens to 2 r_lat =
//! sin³45° ρa²v₀²/σ = 40.7 mm across. Its rims then pull it shut below: the
//! first link.
use codimfx::particles::Codim;
use codimfx::sim::Sim;
use std::sync::atomic::AtomicBool;

mod common;

/// Extent (1st to 99th percentile) along z and along x of the sheet,
/// filament and volume particles with y in [lo, hi); `None` with fewer than
/// 20 of them.
fn extents(sim: &Sim, lo: f64, hi: f64) -> Option<(f64, f64)> {
    let p = &sim.state.particles;
    let (mut z, mut x) = (Vec::new(), Vec::new());
    for i in 0..p.len() {
        if p.codim[i] != Codim::Point && p.x[i].y >= lo && p.x[i].y < hi {
            z.push(p.x[i].z);
            x.push(p.x[i].x);
        }
    }
    if z.len() < 20 {
        return None;
    }
    let spread = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        let at = |q: f64| v[((v.len() - 1) as f64 * q).round() as usize];
        at(0.99) - at(0.01)
    };
    Some((spread(&mut z), spread(&mut x)))
}

#[test]
fn the_collision_sheet_opens_to_its_taylor_width_and_closes_into_a_link() {
    let (mut sim, _cache) = common::open_preset("fluid_chain_links", 22, Some(2.0), |t| t);
    sim.run(&AtomicBool::new(false), |_, _| {}).unwrap();
    assert!(sim.state.particles.all_finite());
    let (sigma, a, v0) = (0.2, 0.008, 0.6);
    let width = 0.5_f64.sqrt().powi(3) * 1000.0 * a * a * v0 * v0 / sigma;
    // 3 cm bands from 2 cm under the collision down
    let bands: Vec<(f64, f64, f64)> = (0..8)
        .filter_map(|k| {
            let hi = 0.46 - 0.03 * k as f64;
            extents(&sim, hi - 0.03, hi).map(|(z, x)| (hi, z, x))
        })
        .collect();
    for (hi, z, x) in &bands {
        eprintln!(
            "y < {hi:.2}: across {:.1} mm, along the jets' plane {:.1} mm",
            z * 1e3,
            x * 1e3
        );
    }
    // the sheet: its widest band in the upper 9 cm, thin in x
    let (k, &(_, wide, thick)) = bands[..3]
        .iter()
        .enumerate()
        .max_by(|a, b| a.1 .1.total_cmp(&b.1 .1))
        .unwrap();
    eprintln!(
        "widest {:.1} mm against Taylor's {:.1} mm",
        wide * 1e3,
        width * 1e3
    );
    assert!(
        (0.8..1.2).contains(&(wide / width)),
        "the sheet is {:.1} mm wide, Taylor's width {:.1} mm",
        wide * 1e3,
        width * 1e3
    );
    assert!(
        thick < 0.3 * wide,
        "a column, not a sheet: {thick} x {wide}"
    );
    // the link: further down, within 20 cm of the collision, the rims have
    // pulled the sheet in to less than half its width
    let closed = bands[k + 1..]
        .iter()
        .find(|(hi, z, _)| *hi > 0.30 && *z < 0.5 * wide);
    assert!(closed.is_some(), "the sheet does not close: {bands:?}");
}

/// The same preset with the cut layer (`coupling.layer: cut`), 20 frames at
/// `--scale 2`. Nothing in the scene drives a particle faster than a fall
/// from the nozzles at the jets' speed, v₀ + g t, plus the speed the
/// Laplace pressure of a cell-sized feature can give, √(4σ/(ρΔx)) (0.44
/// m/s). Two faults of the cut once broke that bound (docs/decisions.md,
/// "Two faults the fluid chain found"). The free cells' faces to air took
/// 100 × their rows' pressure gradient, which threw particles at 5.6 m/s
/// at frame 18 (bound 2.8). Then the outlier rule read a jump of q across
/// closed faces as a velocity, and it halved the substep four times and
/// stopped the run at frame 19.
#[test]
fn the_cut_layer_runs_the_chain_with_no_particle_faster_than_its_fall() {
    let (mut sim, _cache) = common::open_preset("fluid_chain_links", 20, Some(2.0), |t| {
        format!("{t}coupling:\n  layer: cut\n")
    });
    let (v0, g, sigma, rho, dx): (f64, f64, f64, f64, f64) = (0.6, 9.81, 0.2, 1000.0, 2.0 / 480.0);
    let capillary: f64 = (4.0 * sigma / (rho * dx)).sqrt();
    let mut worst: (f64, u32) = (0.0, 0);
    let mut halvings = 0;
    sim.run(&AtomicBool::new(false), |_, r| {
        let bound = v0 + g * r.time + capillary;
        eprintln!(
            "frame {}: fastest {:.2} m/s, bound {:.2}",
            r.frame, r.speed.max, bound
        );
        if r.speed.max / bound > worst.0 {
            worst = (r.speed.max / bound, r.frame);
        }
        halvings += r.fallbacks.step_halvings;
    })
    .unwrap();
    assert!(sim.state.particles.all_finite());
    assert!(
        worst.0 < 1.0,
        "frame {}: a particle at {:.2} × the fall's bound",
        worst.1,
        worst.0
    );
    assert_eq!(halvings, 0, "substeps halved");
}
