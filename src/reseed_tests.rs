//! Unit tests of [`crate::reseed`] (kept apart to keep the module short).
use super::*;
use crate::neighbors::neighbor_lists;

fn flat_sheet(n: usize, s: Real, hole: Option<(usize, usize)>) -> Particles {
    let mut p = Particles::new();
    for i in 0..n {
        for j in 0..n {
            if Some((i, j)) == hole {
                continue;
            }
            let v = Vec3::new(0.1 * i as Real, -0.2 * j as Real, 0.05);
            p.push(
                Vec3::new(i as Real * s, j as Real * s, 0.0),
                v,
                1.0 + 0.01 * (i + j) as Real,
                0.01,
                Codim::Sheet,
            );
        }
    }
    p
}

/// Reseeds `p` with identity frames (a sheet in the xy plane, filaments
/// along x) and neighbour lists within h.
fn reseed_identity(p: &mut Particles, shape: &dyn LocalShape, prm: &ReseedParams) -> ReseedCounts {
    let frames = vec![Mat3::identity(); p.len()];
    let nl = neighbor_lists(&p.x, prm.h);
    reseed(p, &frames, |i| nl.of(i), shape, prm)
}

fn momentum(p: &Particles) -> Vec3 {
    (0..p.len()).map(|i| p.v[i] * p.mass[i]).sum()
}

#[test]
fn hole_in_sheet_is_filled_once_conserving_mass_and_momentum() {
    let h = 0.1;
    let s = 0.4 * h; // one particle per tangent cell
    let mut p = flat_sheet(11, s, Some((5, 5)));
    let (m0, j0) = (p.total_mass(), momentum(&p));
    let c = reseed_identity(&mut p, &FlatShape, &ReseedParams::paper(h));
    assert_eq!(c.sheet_inserted, 1, "{c:?}");
    assert_eq!(c.sheet_removed, 0);
    let new = p.len() - 1;
    assert!((p.x[new] - Vec3::new(5.0 * s, 5.0 * s, 0.0)).norm() < 1e-12);
    assert!((p.total_mass() - m0).abs() < 1e-12 * m0);
    assert!((momentum(&p) - j0).norm() < 1e-12 * j0.norm());
}

#[test]
fn new_particle_lies_on_the_fitted_surface() {
    struct Bowl;
    impl LocalShape for Bowl {
        fn height(&self, _: usize, u: Real, v: Real) -> Real {
            u * u + v * v
        }
        fn curve(&self, _: usize, _: Real) -> (Real, Real) {
            (0.0, 0.0)
        }
    }
    let h = 0.1;
    let mut p = flat_sheet(11, 0.4 * h, Some((5, 5)));
    reseed_identity(&mut p, &Bowl, &ReseedParams::paper(h));
    let new = *p.id.last().unwrap();
    let k = p.id.iter().position(|&i| i == new).unwrap();
    // seeded by some neighbour q: z = |x_new - x_q|² in q's frame
    let z = p.x[k].z;
    assert!(z > 0.0 && z <= 2.0 * (0.4 * h).powi(2) + 1e-12, "z = {z}");
}

#[test]
fn close_pairs_are_merged_conserving_mass_and_momentum() {
    let h = 0.1;
    let mut p = flat_sheet(6, 0.4 * h, None);
    p.push(
        Vec3::new(0.401 * h, 0.0, 0.0),
        Vec3::new(3.0, 0.0, 0.0),
        2.0,
        0.01,
        Codim::Sheet,
    );
    let (m0, j0, n0) = (p.total_mass(), momentum(&p), p.len());
    let c = reseed_identity(&mut p, &FlatShape, &ReseedParams::paper(h));
    assert_eq!(c.sheet_removed, 1);
    assert_eq!(c.sheet_inserted, 0);
    assert_eq!(p.len(), n0 - 1);
    assert!((p.total_mass() - m0).abs() < 1e-12 * m0);
    assert!((momentum(&p) - j0).norm() < 1e-12 * j0.norm());
}

/// Ten filament particles of mass 1 along x, spacing 0.4h except one gap of
/// 0.8h between particles 4 and 5.
fn stretched_line(h: Real) -> Particles {
    let mut p = Particles::new();
    let mut xs: Vec<Real> = (0..5).map(|i| i as Real * 0.4 * h).collect();
    xs.extend((5..10).map(|i| (i as Real + 1.0) * 0.4 * h));
    for x in xs {
        p.push(
            Vec3::new(x, 0.0, 0.0),
            Vec3::y(),
            1.0,
            0.01,
            Codim::Filament,
        );
    }
    p
}

#[test]
fn stretched_filament_gains_a_particle_in_each_gap() {
    let h = 0.1;
    let mut p = stretched_line(h);
    let m0 = p.total_mass();
    let c = reseed_identity(&mut p, &FlatShape, &ReseedParams::paper(h));
    assert_eq!(c.filament_inserted, 1, "{c:?}");
    assert!(p
        .x
        .iter()
        .any(|x| (x - Vec3::new(2.0 * h, 0.0, 0.0)).norm() < 1e-12));
    assert!((p.total_mass() - m0).abs() < 1e-12);
}

#[test]
fn fixed_particles_are_never_removed() {
    let h = 0.1;
    let mut p = Particles::new();
    p.push(Vec3::zeros(), Vec3::zeros(), 1.0, 0.01, Codim::Sheet);
    p.push(
        Vec3::new(0.001, 0.0, 0.0),
        Vec3::zeros(),
        1.0,
        0.01,
        Codim::Sheet,
    );
    p.fixed[1] = true;
    p.fixed[0] = true;
    let c = reseed_identity(&mut p, &FlatShape, &ReseedParams::paper(h));
    assert_eq!(c.sheet_removed, 0);
    assert_eq!(p.len(), 2);
}

/// Rows 0.6 h apart along y, particles 0.15 h apart along x: no empty cell
/// has all eight neighbours filled, so only the gap-line rule inserts, and
/// it puts the new rows halfway between the old ones.
#[test]
fn gap_lines_fill_a_sheet_stretched_in_one_direction() {
    let h = 0.1;
    let mut base = Particles::new();
    for j in 0..7 {
        for i in 0..40 {
            let x = Vec3::new(i as Real * 0.15 * h, j as Real * 0.6 * h, 0.0);
            base.push(x, Vec3::new(0.0, 0.1, 0.0), 1.0, 0.01, Codim::Sheet);
        }
    }
    let mut off = base.clone();
    let c = reseed_identity(&mut off, &FlatShape, &ReseedParams::paper(h));
    assert_eq!(c.sheet_inserted, 0, "{c:?}");
    let prm = ReseedParams {
        gap_lines: true,
        ..ReseedParams::paper(h)
    };
    let (m0, j0) = (base.total_mass(), momentum(&base));
    let mut on = base.clone();
    let c = reseed_identity(&mut on, &FlatShape, &prm);
    assert!(c.sheet_inserted > 0, "{c:?}");
    for k in base.len()..on.len() {
        // halfway between two rows (y = (j + 1/2) 0.6 h), inside the sheet
        let r = on.x[k].y / (0.6 * h) - 0.5;
        assert!(
            (r - r.round()).abs() < 1e-9 && r > -0.1 && r < 5.1,
            "{:?}",
            on.x[k]
        );
    }
    assert!((on.total_mass() - m0).abs() < 1e-12 * m0);
    assert!((momentum(&on) - j0).norm() < 1e-12 * j0.norm());
}

/// Ten fixed (ring) sheet particles of mass 2, 0.3 h apart along x,
/// moving at `v`.
fn ring(h: Real, v: Vec3) -> Particles {
    let mut p = Particles::new();
    for i in 0..10 {
        let k = p.push(
            Vec3::new(i as Real * 0.3 * h, 0.0, 0.0),
            v,
            2.0,
            0.01,
            Codim::Sheet,
        );
        p.fixed[k] = true;
    }
    p
}

#[test]
fn rim_particles_reaching_a_ring_merge_into_it_and_the_ring_keeps_its_motion() {
    let h = 0.1;
    let ring_v = Vec3::new(0.0, 0.0, 0.05);
    let mut p = ring(h, ring_v);
    // a rim particle 0.1 h from the ring, one 0.5 h away
    p.push(
        Vec3::new(0.3 * h, 0.1 * h, 0.0),
        Vec3::new(0.0, -5.0, 0.0),
        1.0,
        0.01,
        Codim::Filament,
    );
    p.push(
        Vec3::new(0.3 * h, 0.5 * h, 0.0),
        Vec3::new(0.0, -5.0, 0.0),
        1.0,
        0.01,
        Codim::Filament,
    );
    let m0 = p.total_mass();
    let c = reseed_identity(&mut p, &FlatShape, &ReseedParams::paper(h));
    assert_eq!(c.boundary_absorbed, 1, "{c:?}");
    assert_eq!(p.len(), 11);
    assert!((p.total_mass() - m0).abs() < 1e-12 * m0);
    assert!((p.mass[1] - 3.0).abs() < 1e-12);
    for i in 0..10 {
        assert_eq!(p.v[i], ring_v);
        assert!(p.fixed[i]);
    }
}

#[test]
fn a_rim_collects_free_sheet_particles_but_not_a_liquid_bodys_surface_layer() {
    let h = 0.1;
    let prm = ReseedParams::paper(h);
    // a filament particle with two sheet particles 0.2 h from it, one on each
    // side; a volume particle 0.78 h from the second (1.12 h from the first)
    // makes the second a surface sheet
    let build = |with_volume: bool| {
        let mut p = Particles::new();
        p.push(Vec3::zeros(), Vec3::zeros(), 1.0, 0.01, Codim::Filament);
        p.push(
            Vec3::new(0.2 * h, 0.0, 0.0),
            Vec3::x(),
            1.0,
            0.01,
            Codim::Sheet,
        );
        p.push(
            Vec3::new(-0.2 * h, 0.0, 0.0),
            Vec3::x(),
            1.0,
            0.01,
            Codim::Sheet,
        );
        if with_volume {
            p.push(
                Vec3::new(-0.8 * h, 0.0, -0.5 * h),
                Vec3::zeros(),
                1.0,
                0.01,
                Codim::Volume,
            );
        }
        p
    };
    let mut free = build(false);
    assert_eq!(absorb_into_rims(&mut free, &prm, &[]), 2);
    assert_eq!(free.len(), 1);
    assert!((free.mass[0] - 3.0).abs() < 1e-12);
    let mut body = build(true);
    let m0 = body.total_mass();
    assert_eq!(absorb_into_rims(&mut body, &prm, &[]), 1);
    assert_eq!(body.len(), 3);
    assert_eq!(body.codim.iter().filter(|c| **c == Codim::Sheet).count(), 1);
    assert!(body
        .x
        .iter()
        .any(|x| (x - Vec3::new(-0.2 * h, 0.0, 0.0)).norm() < 1e-15));
    assert!((body.total_mass() - m0).abs() < 1e-12 * m0);
    // the same volume particle passed from outside the store (a liquid
    // scene's reseeding of its sheet/filament set)
    let mut set = build(false);
    let outside = [Vec3::new(-0.8 * h, 0.0, -0.5 * h)];
    assert_eq!(absorb_into_rims(&mut set, &prm, &outside), 1);
    assert_eq!(set.len(), 2);
}

#[test]
fn a_filament_particle_inside_a_flat_film_collects_nothing_one_on_its_edge_does() {
    // a 9 × 9 sheet at spacing 0.25 h; one filament particle replaces its
    // centre, another its edge's middle; each has sheet particles 0.25 h away
    let (h, s) = (0.1, 0.025);
    let at = |i: usize, j: usize| Vec3::new(i as Real * s, j as Real * s, 0.0);
    let build = |fil: (usize, usize)| {
        let mut p = flat_sheet(9, s, Some(fil));
        p.push(at(fil.0, fil.1), Vec3::zeros(), 1.0, 0.01, Codim::Filament);
        p
    };
    let paper = ReseedParams::paper(h);
    let film = ReseedParams {
        rim_gap: std::f64::consts::FRAC_PI_2,
        ..paper.clone()
    };
    // inside: the paper's rule collects the four nearest (0.25 h < 0.3 h),
    // the film rule none
    assert_eq!(absorb_into_rims(&mut build((4, 4)), &paper, &[]), 4);
    let mut inside = build((4, 4));
    let m0 = inside.total_mass();
    assert_eq!(absorb_into_rims(&mut inside, &film, &[]), 0);
    assert_eq!(inside.len(), 81);
    assert!((inside.total_mass() - m0).abs() < 1e-12 * m0);
    // on the edge (a gap of π on the open side) both rules collect its
    // three sheet neighbours
    assert_eq!(absorb_into_rims(&mut build((4, 0)), &paper, &[]), 3);
    assert_eq!(absorb_into_rims(&mut build((4, 0)), &film, &[]), 3);
}

#[test]
fn the_mass_floor_stops_insertion_and_merges_what_is_below_it() {
    let h = 0.1;
    // the stretched line: the new particle takes 1/5 of each of its four
    // donors, 0.8
    let line = || stretched_line(h);
    let floor = |m: Real| ReseedParams {
        min_mass: m,
        ..ReseedParams::paper(h)
    };
    let mut p = line();
    assert_eq!(
        reseed_identity(&mut p, &FlatShape, &floor(0.75)).filament_inserted,
        1
    );
    let mut p = line();
    let c = reseed_identity(&mut p, &FlatShape, &floor(0.85));
    assert_eq!(c.filament_inserted, 0, "{c:?}");
    assert_eq!(c.light_merged, 0, "{c:?}");
    // one particle below the floor (but not below 0.2 × its neighbours' mean)
    // merges into its nearest neighbour, mass and momentum exact
    let mut p = line();
    p.mass[2] = 0.5;
    let (m0, q0) = (p.total_mass(), momentum(&p));
    let c = reseed_identity(&mut p, &FlatShape, &floor(0.55));
    assert_eq!(c.light_merged, 1, "{c:?}");
    assert_eq!(p.len(), 9 + c.filament_inserted as usize);
    assert!((p.total_mass() - m0).abs() < 1e-12);
    assert!((momentum(&p) - q0).norm() < 1e-12);
    // the liquid floor: 10 % of ρ(h/4)³
    let l = ReseedParams::liquid(h, 1000.0);
    assert!((l.min_mass - 0.1 * 1000.0 * (0.025 as Real).powi(3)).abs() < 1e-15);
}

#[test]
fn a_light_particle_merges_at_the_centre_of_mass() {
    // a light sheet particle between lattice sites merges into its nearest
    // neighbour, which moves to the pair's centre of mass: mass, momentum
    // and the first moment Σ m x are all unchanged
    let (h, s) = (0.1, 0.04);
    let mut p = flat_sheet(5, s, None);
    p.push(
        Vec3::new(2.3 * s, 2.0 * s, 0.001),
        Vec3::new(0.0, 0.0, 1.0),
        0.02,
        0.01,
        Codim::Sheet,
    );
    let first = |p: &Particles| -> Vec3 { (0..p.len()).map(|i| p.x[i] * p.mass[i]).sum() };
    let (m0, q0, x0) = (p.total_mass(), momentum(&p), first(&p));
    let prm = ReseedParams::paper(h);
    assert_eq!(merge::merge_light(&mut p, Codim::Sheet, &prm), 1);
    assert_eq!(p.len(), 25);
    assert!((p.total_mass() - m0).abs() < 1e-12);
    assert!((momentum(&p) - q0).norm() < 1e-12);
    assert!(
        (first(&p) - x0).norm() < 1e-14,
        "{}",
        (first(&p) - x0).norm()
    );
    // the survivor (the lattice site (2, 2), mass 1.04) moved towards it
    let k = 2 * 5 + 2;
    let want = (Vec3::new(2.0 * s, 2.0 * s, 0.0) * 1.04
        + Vec3::new(2.3 * s, 2.0 * s, 0.001) * 0.02)
        / 1.06;
    assert!((p.x[k] - want).norm() < 1e-15, "{} vs {want}", p.x[k]);
}

#[test]
fn a_sheet_particle_far_heavier_than_its_neighbours_becomes_a_droplet() {
    // one lattice site holds 20× its neighbours' mass: with heavy_fraction
    // 10 it turns into a point, mass and momentum unchanged; off (0, the
    // paper's setting) nothing changes
    let (h, s) = (0.1, 0.04);
    let mut p = flat_sheet(5, s, None);
    let k = 2 * 5 + 2;
    p.mass[k] = 21.0;
    let (m0, q0) = (p.total_mass(), momentum(&p));
    let mut prm = ReseedParams::paper(h);
    assert_eq!(merge::shed_heavy(&mut p, &prm), 0);
    prm.heavy_fraction = 10.0;
    assert_eq!(merge::shed_heavy(&mut p, &prm), 1);
    assert_eq!(p.codim[k], Codim::Point);
    assert_eq!(p.codim.iter().filter(|c| **c == Codim::Point).count(), 1);
    assert!((p.total_mass() - m0).abs() < 1e-12);
    assert!((momentum(&p) - q0).norm() < 1e-12);
}
