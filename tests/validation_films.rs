//! Film validation against analytic results (paper Fig. 6, Appendix E).

use codimfx::film::catenoid::{catenoid_neck, neck_radius, CatenoidSetup};
use codimfx::film::step::advance_by;
use codimfx::film::{FilmParams, FilmState};
use codimfx::math::{Real, Vec3};
use codimfx::particles::Particles;

/// Advances one frame of length `frame_dt` in substeps limited to `cfl`
/// particle spacings of motion.
fn advance(
    p: &mut Particles,
    st: &mut FilmState,
    prm: &FilmParams,
    frame_dt: Real,
    spacing: Real,
    cfl: Real,
) {
    advance_by(p, st, prm, frame_dt, spacing, cfl).expect("film step");
}

#[test]
fn catenoid_settles_to_the_minimal_surface() {
    // rings of radius R = 0.0512 m at d = 0.0384 m (paper), d/R = 0.75 < 1.3255
    let s = 0.002;
    let set = CatenoidSetup::paper(s);
    let mut p = set.particles();
    let m0 = p.total_mass();
    let mut prm = FilmParams::new(3.0 * s, 0.015);
    prm.gravity = Vec3::zeros();
    prm.damping = 30.0; // air drag so the film settles instead of ringing
    let mut st = FilmState::default();
    for _ in 0..25 {
        advance(&mut p, &mut st, &prm, 0.005, s, 0.5);
    }
    let a = catenoid_neck(set.radius, set.length).unwrap();
    let r = neck_radius(&p, 0.6 * s).unwrap();
    let err = (r / a - 1.0).abs();
    assert!(
        err < 0.02,
        "neck radius {r} vs catenoid {a}: {:.2} %",
        err * 100.0
    );
    // the cylinder's own radius is 8.4 % off: the film really moved
    assert!((set.radius / a - 1.0) > 0.08);
    let vmax = p.v.iter().map(|v| v.norm()).fold(0.0, Real::max);
    assert!(vmax < 1e-3, "not settled: {vmax} m/s");
    assert!(p.all_finite());
    assert!((p.total_mass() - m0).abs() < 1e-12 * m0, "mass changed");
}

#[test]
fn sphere_deformation_reseeding_keeps_the_sheet_and_returns() {
    use codimfx::film::deformation::{run, DeformationSetup};
    // coarse version of Fig. 15 (paper: ~50k → ~170k → ~100k particles)
    let set = DeformationSetup::paper(0.01);
    let h = set.h_over_spacing * set.spacing;
    let r = run(&set, |_, _| {}).unwrap();
    // stretching adds particles, the return removes most of them again
    assert!(
        r.particles_max_stretch as f64 > 2.0 * r.particles_start as f64,
        "{r:?}"
    );
    assert!(
        r.particles_end < r.particles_max_stretch && r.particles_end > r.particles_start,
        "{r:?}"
    );
    // the exact end state is the initial sphere (R = 0.15): errors well inside h
    assert!(r.mean_distance_rel * 0.15 < 0.01 * h, "{r:?}");
    assert!(r.max_distance_rel * 0.15 < 0.5 * h, "{r:?}");
    // at maximal stretch the sheet has no hole larger than the reseeding grid resolves
    assert!(r.coverage_max_stretch > 0.85, "{r:?}");
    assert!(r.max_gap_max_stretch < 0.8, "{r:?}");
}

#[test]
fn catenoid_beyond_the_critical_separation_pinches() {
    // d = 1.9 × 0.0384 m = 1.425 R > 1.3255 R: no catenoid exists, the neck must close
    let s = 0.002;
    let mut set = CatenoidSetup::paper(s);
    set.length *= 1.9;
    assert!(catenoid_neck(set.radius, set.length).is_none());
    let mut p = set.particles();
    let m0 = p.total_mass();
    let mut prm = FilmParams::new(3.0 * s, 0.015);
    prm.gravity = Vec3::zeros();
    prm.damping = 30.0;
    let mut st = FilmState::default();
    for _ in 0..40 {
        advance(&mut p, &mut st, &prm, 0.005, s, 0.5);
    }
    // nothing of the film is left near the middle ring of the original cylinder
    let r = neck_radius(&p, 2.0 * s);
    assert!(
        r.is_none_or(|r| r < 0.2 * set.radius),
        "neck {r:?} did not close"
    );
    assert!(p.all_finite());
    assert!((p.total_mass() - m0).abs() < 1e-12 * m0);
}

#[test]
fn film_viscosity_decays_spherical_harmonics_at_the_surface_laplacian_rate() {
    // Implicit MLS viscosity (eq. 13) alone (σ = 0, no transitions/reseeding):
    // (M − μΔt V L) u = M u*. A velocity component equal to a degree-l
    // spherical harmonic on a sphere of radius R is an eigenfunction of the
    // Laplace–Beltrami operator with eigenvalue −l(l+1)/R², so one step
    // multiplies it by 1/(1 + ν Δt l(l+1)/R²), ν = μ/ρ.
    use codimfx::film::deformation::latitude_sphere;
    use codimfx::film::step::step;
    use codimfx::particles::Codim;
    let (r, s) = (0.05, 0.004);
    let dt = 0.01;
    for (l, mode) in [
        (1, (|z: Real| z) as fn(Real) -> Real),
        (2, |z: Real| 1.5 * z * z - 0.5),
    ] {
        let lambda = (l * (l + 1)) as Real / (r * r);
        let mut prm = FilmParams::new(3.0 * s, 0.0);
        prm.gravity = Vec3::zeros();
        prm.transitions = None;
        prm.reseed = None;
        // ν Δt λ = 1: the mode halves in one step
        prm.viscosity = prm.density / (dt * lambda);
        let mut p = Particles::new();
        let u0 = 1e-3;
        for x in latitude_sphere(Vec3::zeros(), r, s) {
            let v = Vec3::new(u0 * mode(x.z / r), 0.0, 0.0);
            p.push(x, v, 1e-9, 5e-7, Codim::Sheet);
        }
        let m0 = p.total_mass();
        let project = |p: &Particles| {
            let (mut num, mut den) = (0.0, 0.0);
            for i in 0..p.len() {
                let y = mode(p.x[i].z / p.x[i].norm());
                num += p.v[i].x * y;
                den += y * y;
            }
            num / den
        };
        let a0 = project(&p);
        let mut st = FilmState::default();
        let info = step(&mut p, &mut st, &prm, dt).expect("film step");
        assert!(
            info.viscosity_solve[0].iterations > 0,
            "viscosity solve skipped"
        );
        let a1 = project(&p);
        let got = a1 / a0;
        let want = 1.0 / (1.0 + prm.viscosity / prm.density * dt * lambda);
        // decay rate (1/factor − 1 = νΔtλ_h) against the analytic eigenvalue
        let rate_err = ((1.0 / got - 1.0) / (1.0 / want - 1.0) - 1.0).abs();
        eprintln!(
            "l = {l}: {} particles, factor {got:.5} vs {want:.5}, eigenvalue error {:.2} %",
            p.len(),
            rate_err * 100.0
        );
        assert!(
            rate_err < 0.03,
            "l = {l}: eigenvalue off by {:.2} %",
            rate_err * 100.0
        );
        // the other components stay at rest, the mode keeps its shape
        let off: Real = (0..p.len())
            .map(|i| p.v[i].y.abs().max(p.v[i].z.abs()))
            .fold(0.0, Real::max);
        assert!(off < 1e-6 * u0, "y/z velocity appeared: {off}");
        let resid: Real = (0..p.len())
            .map(|i| (p.v[i].x - a1 * mode(p.x[i].z / p.x[i].norm())).abs())
            .fold(0.0, Real::max);
        assert!(
            resid < 0.05 * a1.abs(),
            "mode lost its shape: {resid} vs {a1}"
        );
        assert!((p.total_mass() - m0).abs() <= 1e-12 * m0);
        // μ = 0 skips the solve and leaves the velocity alone
        prm.viscosity = 0.0;
        let v1 = p.v.clone();
        let info = step(&mut p, &mut st, &prm, dt).expect("film step");
        assert_eq!(info.viscosity_solve[0].iterations, 0);
        let dv = (0..p.len())
            .map(|i| (p.v[i] - v1[i]).norm())
            .fold(0.0, Real::max);
        assert!(dv <= 1e-12 * u0, "velocity changed without viscosity: {dv}");
    }
}
