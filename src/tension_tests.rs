//! Unit tests of [`crate::tension`] (kept apart to keep the module short).
use super::*;
use crate::neighbors::neighbor_lists;
use faer::sparse::Triplet;

/// Three-point Laplacian of a uniformly sampled closed curve (ring of n
/// particles, radius R): (x_{i−1} − 2x_i + x_{i+1}) / s², with s the chord.
fn ring_laplacian(n: usize, r: Real) -> (Vec<Vec3>, SparseRowMat<usize, Real>) {
    let x: Vec<Vec3> = (0..n)
        .map(|i| {
            let t = 2.0 * std::f64::consts::PI * i as Real / n as Real;
            Vec3::new(r * t.cos(), r * t.sin(), 0.0)
        })
        .collect();
    let s = (x[1] - x[0]).norm();
    let mut t = Vec::new();
    for i in 0..n {
        t.push(Triplet::new(i, i, -2.0 / (s * s)));
        t.push(Triplet::new(i, (i + 1) % n, 1.0 / (s * s)));
        t.push(Triplet::new(i, (i + n - 1) % n, 1.0 / (s * s)));
    }
    (x, SparseRowMat::try_new_from_triplets(n, n, &t).unwrap())
}

#[test]
fn ring_contracts_at_the_laplace_rate_and_fixed_rows_hold() {
    // a filament ring of radius R: κn = −x/R², so one step from rest gives
    // u ≈ Δt σ S κn / m, radially inward with magnitude Δt σ S/(m R)
    let (n, r) = (200, 0.05);
    let (x, l) = ring_laplacian(n, r);
    let (sigma, dt) = (0.03, 1e-4);
    let mass = vec![1e-6; n];
    let area = vec![2e-5; n];
    let u0 = vec![Vec3::zeros(); n];
    let f = vec![Vec3::zeros(); n];
    let mut fixed = vec![false; n];
    fixed[7] = true;
    let mut u_fixed = u0.clone();
    u_fixed[7] = Vec3::new(0.0, 0.0, 0.3);
    let sys = TensionSystem {
        laplacian: l.as_ref(),
        mass: &mass,
        area: &area,
        x: &x,
        u: &u_fixed,
        f_explicit: &f,
        fixed: &fixed,
        drag: &[],
        nu: 0.0,
        sigma,
        dt,
        curvature: CurvaturePart::Full,
        diffusive: false,
        theta: 1.0,
    };
    let sol = solve(&sys, &BicgstabParams::default()).unwrap();
    let expect = dt * sigma * area[0] / (mass[0] * r);
    for i in [0, 50, 123] {
        let radial = sol.u[i].dot(&x[i].normalize());
        assert!(radial < 0.0);
        // implicit damping makes it slightly smaller; discretisation error O(s²/R²)
        assert!(
            (radial.abs() - expect).abs() < 2e-3 * expect,
            "{i}: {radial} vs {expect}"
        );
    }
    assert_eq!(sol.u[7], Vec3::new(0.0, 0.0, 0.3));
    assert!(sol.info.iter().all(|s| s.rel_residual <= 1e-8));
}

#[test]
fn implicit_viscosity_damps_a_ring_mode_at_the_backward_euler_rate() {
    // σ = 0, ν > 0: u_z = cos(kθ) on a ring of radius R is an eigenmode of
    // the Laplace–Beltrami operator (−k²/R²), so one implicit step gives
    // u_z / (1 + νΔt k²/R²)
    let (n, r, k) = (200, 0.05, 3.0);
    let (x, l) = ring_laplacian(n, r);
    let (nu, dt) = (1e-4, 0.01);
    let u: Vec<Vec3> = x
        .iter()
        .map(|p| Vec3::new(0.0, 0.0, (k * p.y.atan2(p.x)).cos()))
        .collect();
    let (mass, area, f) = (vec![1e-6; n], vec![2e-5; n], vec![Vec3::zeros(); n]);
    let fixed = vec![false; n];
    let sys = TensionSystem {
        laplacian: l.as_ref(),
        mass: &mass,
        area: &area,
        x: &x,
        u: &u,
        f_explicit: &f,
        fixed: &fixed,
        drag: &[],
        nu,
        sigma: 0.0,
        dt,
        curvature: CurvaturePart::Full,
        diffusive: false,
        theta: 1.0,
    };
    let sol = solve(&sys, &BicgstabParams::default()).unwrap();
    let factor = 1.0 / (1.0 + nu * dt * k * k / (r * r));
    for i in [0, 17, 101] {
        let got = sol.u[i].z / u[i].z;
        assert!(
            (got - factor).abs() < 1e-3 * factor,
            "{i}: {got} vs {factor}"
        );
    }
}

#[test]
fn large_steps_stay_bounded() {
    // the semi-implicit scheme does not blow up at dt far beyond the
    // explicit capillary limit: the speed stays below the explicit estimate
    let (n, r) = (100, 0.01);
    let (x, l) = ring_laplacian(n, r);
    let mass = vec![1e-7; n];
    let area = vec![1e-5; n];
    let u = vec![Vec3::zeros(); n];
    let f = vec![Vec3::zeros(); n];
    let fixed = vec![false; n];
    let sys = TensionSystem {
        laplacian: l.as_ref(),
        mass: &mass,
        area: &area,
        x: &x,
        u: &u,
        f_explicit: &f,
        fixed: &fixed,
        drag: &[],
        nu: 0.0,
        sigma: 3.0,
        dt: 0.05,
        curvature: CurvaturePart::Full,
        diffusive: false,
        theta: 1.0,
    };
    let sol = solve(&sys, &BicgstabParams::default()).unwrap();
    let explicit = 0.05 * 3.0 * 1e-5 / (1e-7 * r);
    assert!(sol
        .u
        .iter()
        .all(|v| v.norm().is_finite() && v.norm() < explicit));
}

#[test]
fn rim_and_bud_point_into_the_material() {
    // half sheet in y ≥ 0 with a rim particle at the origin
    let h = 0.1;
    let mut x = vec![Vec3::zeros()];
    let mut codim = vec![Codim::Filament];
    for i in -3..=3 {
        for j in 1..=3 {
            x.push(Vec3::new(i as Real * 0.03, j as Real * 0.03, 0.0));
            codim.push(Codim::Sheet);
        }
    }
    x.push(Vec3::new(0.03, 0.0, 0.0));
    codim.push(Codim::Filament);
    let nl = neighbor_lists(&x, h);
    let frame = Mat3::from_columns(&[Vec3::x(), -Vec3::y(), Vec3::z()]); // b² pointing away on purpose
    assert_eq!(
        filament_role(0, &frame, &x, &codim, nl.of(0), h, 0.5),
        FilamentRole::Rim
    );
    let f = rim_force(0, &frame, &x, &codim, nl.of(0), 0.05, 2e-6, 1e-3, 1.0);
    assert!(
        (f - Vec3::new(0.0, 0.05 * 2e-6 / 1e-3, 0.0)).norm() < 1e-15,
        "{f}"
    );
    // a free filament end: neighbours only along +x
    let xf: Vec<Vec3> = (0..5)
        .map(|i| Vec3::new(i as Real * 0.03, 0.0, 0.0))
        .collect();
    let cf = vec![Codim::Filament; 5];
    let nf = neighbor_lists(&xf, h);
    let fr = Mat3::identity();
    assert_eq!(
        filament_role(0, &fr, &xf, &cf, nf.of(0), h, 0.5),
        FilamentRole::Bud
    );
    assert_eq!(
        filament_role(2, &fr, &xf, &cf, nf.of(2), h, 0.5),
        FilamentRole::Plain
    );
    let fb = bud_force(
        0,
        &Mat3::from_columns(&[-Vec3::x(), Vec3::y(), Vec3::z()]),
        &xf,
        &cf,
        nf.of(0),
        0.05,
        1e-6,
        1e-3,
    );
    assert!(fb.x > 0.0 && (fb.norm() - 0.05 * 2.0 / 1e-3 * 1e-6).abs() < 1e-15);
}

#[test]
fn sawtooth_has_k_teeth_and_mean_one() {
    let k = 6;
    let saw = Sawtooth {
        corners: k,
        amplitude: 0.4,
        centre: Vec3::zeros(),
        phase: 0.0,
    };
    let n = 6000;
    let vals: Vec<Real> = (0..n)
        .map(|i| {
            let t = 2.0 * std::f64::consts::PI * (i as Real + 0.5) / n as Real;
            saw.at(&Vec3::new(t.cos(), 0.3, t.sin()))
        })
        .collect();
    let mean = vals.iter().sum::<Real>() / n as Real;
    assert!((mean - 1.0).abs() < 1e-3);
    let jumps = (0..n)
        .filter(|&i| vals[(i + 1) % n] < vals[i] - 0.4)
        .count();
    assert_eq!(jumps, k as usize);
    assert!(vals.iter().all(|v| (0.6 - 1e-9..=1.4 + 1e-9).contains(v)));
}

#[test]
fn sawtooth_phase_turns_the_teeth() {
    let saw = |phase: Real| Sawtooth {
        corners: 6,
        amplitude: 0.9,
        centre: Vec3::new(0.2, 0.0, 0.2),
        phase,
    };
    let turn = 0.3;
    for i in 0..100 {
        let t = 0.0628 * i as Real;
        let at = |a: Real| Vec3::new(0.2 + a.cos(), 0.1, 0.2 + a.sin());
        let (a, b) = (saw(0.0).at(&at(t)), saw(turn).at(&at(t + turn)));
        assert!((a - b).abs() < 1e-12, "{t}: {a} vs {b}");
    }
    // the drops sit at the phase: just before it the factor is 1 + a, after it 1 − a
    let s = saw(turn);
    let at = |a: Real| Vec3::new(0.2 + a.cos(), 0.1, 0.2 + a.sin());
    assert!((s.at(&at(turn - 1e-9)) - 1.9).abs() < 1e-6);
    assert!((s.at(&at(turn + 1e-9)) - 0.1).abs() < 1e-6);
}

#[test]
fn normal_part_keeps_the_sheet_normal_and_drops_the_filament_tangent() {
    // a rotated frame: b¹, b², b³ orthonormal
    let (c, s) = (0.6, 0.8);
    let axes = Mat3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0);
    let b1: Vec3 = axes.column(0).into();
    let b2: Vec3 = axes.column(1).into();
    let b3: Vec3 = axes.column(2).into();
    let lx = b1 * 2.0 + b2 * -3.0 + b3 * 5.0;
    let n = normal_part(&axes, true, &lx);
    assert!((n - b3 * 5.0).norm() < 1e-12, "{n}");
    let f = normal_part(&axes, false, &lx);
    assert!((f - (b2 * -3.0 + b3 * 5.0)).norm() < 1e-12, "{f}");
}
