//! Unit tests of [`crate::transition`] (kept apart to keep the module short).
use super::*;
use crate::neighbors::neighbor_lists;

/// A flat square sheet in the xy plane, spacing s, n×n particles.
fn sheet(n: usize, s: Real) -> Vec<Vec3> {
    let mut v = Vec::new();
    for i in 0..n {
        for j in 0..n {
            v.push(Vec3::new(i as Real * s, j as Real * s, 0.0));
        }
    }
    v
}

/// [`update_codims`] on a copy of `codim` with no fixed particles and
/// neighbour lists within `prm.h`.
fn update_all(
    x: &[Vec3],
    codim: &[Codim],
    frames: &[Mat3],
    prm: &TransitionParams,
) -> (Vec<Codim>, TransitionCounts) {
    let nl = neighbor_lists(x, prm.h);
    let mut c = codim.to_vec();
    let n = update_codims(x, &mut c, &vec![false; x.len()], frames, |i| nl.of(i), prm);
    (c, n)
}

/// A (2n+1)³ lattice block of spacing s centred at the origin: volume
/// particles, except `kind` where `inner(i, j, k)`.
fn block(
    n: i32,
    s: Real,
    inner: impl Fn(i32, i32, i32) -> bool,
    kind: Codim,
) -> (Vec<Vec3>, Vec<Codim>) {
    let mut x = Vec::new();
    let mut codim = Vec::new();
    for i in -n..=n {
        for j in -n..=n {
            for k in -n..=n {
                x.push(Vec3::new(i as Real, j as Real, k as Real) * s);
                codim.push(if inner(i, j, k) { kind } else { Codim::Volume });
            }
        }
    }
    (x, codim)
}

/// In-plane frame for a particle of the flat sheet whose b² points away
/// from the sheet's centre (what PCA gives at an edge), b³ = z.
fn edge_frame(x: &Vec3, centre: &Vec3) -> Mat3 {
    let mut d = x - centre;
    d.z = 0.0;
    let b2 = if d.norm() > 0.0 {
        d.normalize()
    } else {
        Vec3::x()
    };
    let b3 = Vec3::z();
    let b1 = b2.cross(&b3);
    Mat3::from_columns(&[b1, b2, b3])
}

#[test]
fn flat_sheet_edge_becomes_filament_interior_stays() {
    let h = 0.3;
    let n = 11;
    let x = sheet(n, h / 3.0);
    let centre = x[(n / 2) * n + n / 2];
    let codim = vec![Codim::Sheet; x.len()];
    let frames: Vec<Mat3> = x.iter().map(|p| edge_frame(p, &centre)).collect();
    let (c, counts) = update_all(&x, &codim, &frames, &TransitionParams::paper(h));
    for i in 0..n {
        for j in 0..n {
            let on_edge = i == 0 || j == 0 || i == n - 1 || j == n - 1;
            let k = i * n + j;
            // edge particles whose b² points straight out (the mid-edge ones) must turn;
            // every interior particle must stay a sheet
            if !on_edge {
                assert_eq!(c[k], Codim::Sheet, "interior particle {i},{j} changed");
            } else if i == n / 2 || j == n / 2 {
                assert_eq!(c[k], Codim::Filament, "edge particle {i},{j} kept");
            }
        }
    }
    assert!(counts.sheet_to_filament >= 4 * (n as u64 - 2) - 8);
    assert_eq!(
        counts.volume_to_sheet + counts.sheet_to_volume + counts.filament_to_point,
        0
    );
}

#[test]
fn volume_surface_layer_becomes_sheet_and_interior_stays() {
    // a slab of volume particles, z in [0, 5s]; b³ = z for everyone
    let h = 0.3;
    let s = h / 3.0;
    let mut x = Vec::new();
    for i in 0..8 {
        for j in 0..8 {
            for k in 0..6 {
                x.push(Vec3::new(i as Real * s, j as Real * s, k as Real * s));
            }
        }
    }
    let codim = vec![Codim::Volume; x.len()];
    let frames = vec![Mat3::identity(); x.len()];
    let (c, n) = update_all(&x, &codim, &frames, &TransitionParams::paper(h));
    for (idx, p) in x.iter().enumerate() {
        let k = (p.z / s).round() as i32;
        let expect = if k == 0 || k == 5 {
            Codim::Sheet
        } else {
            Codim::Volume
        };
        assert_eq!(c[idx], expect, "layer {k}");
    }
    assert_eq!(n.volume_to_sheet, 2 * 64);
}

#[test]
fn sheet_inside_volume_merges_and_thin_volume_turns_to_sheet() {
    let h = 0.3;
    let s = h / 3.0;
    // a sheet particle at the centre of a volume block → 1→0
    let (x, codim) = block(2, s, |i, j, k| (i, j, k) == (0, 0, 0), Codim::Sheet);
    let centre = codim.iter().position(|c| *c == Codim::Sheet).unwrap();
    let frames = vec![Mat3::identity(); x.len()];
    let fixed = vec![false; x.len()];
    let nl = neighbor_lists(&x, h);
    let prm = TransitionParams::paper(h);
    assert_eq!(
        new_codim(
            centre,
            &frames[centre],
            &x,
            &codim,
            &fixed,
            nl.of(centre),
            &prm
        ),
        Codim::Volume
    );

    // a volume particle squeezed between two sheets 0.3h apart → 0→1 (thin)
    let mut x = vec![Vec3::zeros()];
    let mut codim = vec![Codim::Volume];
    for i in -2..=2 {
        for j in -2..=2 {
            for z in [-0.15 * h, 0.15 * h] {
                x.push(Vec3::new(i as Real * s, j as Real * s, z));
                codim.push(Codim::Sheet);
            }
        }
    }
    let nl = neighbor_lists(&x, h);
    let fixed = vec![false; x.len()];
    let f = Mat3::identity();
    assert_eq!(
        new_codim(0, &f, &x, &codim, &fixed, nl.of(0), &prm),
        Codim::Sheet
    );
    // same sandwich, sheets 1.6 h apart: not thin, and both sides hold particles → stays volume
    for (p, c) in x.iter_mut().zip(&codim) {
        if *c == Codim::Sheet {
            p.z = p.z.signum() * 0.8 * h;
        }
    }
    let nl = neighbor_lists(&x, h);
    assert_eq!(
        new_codim(0, &f, &x, &codim, &fixed, nl.of(0), &prm),
        Codim::Volume
    );
}

#[test]
fn a_sheet_edge_on_a_volume_body_is_not_a_rim() {
    // the flat sheet of the edge test, plus a volume particle 0.5 h under
    // the mid-point of one edge: that edge particle stays a sheet, the
    // other mid-edge particles still turn
    let h = 0.3;
    let n = 11;
    let mut x = sheet(n, h / 3.0);
    let centre = x[(n / 2) * n + n / 2];
    let mut frames: Vec<Mat3> = x.iter().map(|p| edge_frame(p, &centre)).collect();
    let edge = n / 2; // (i, j) = (0, n/2)
    let below = x[edge] - Vec3::new(0.0, 0.0, 0.5 * h);
    x.push(below);
    frames.push(Mat3::identity());
    let mut codim = vec![Codim::Sheet; n * n];
    codim.push(Codim::Volume);
    let fixed = vec![false; x.len()];
    let nl = neighbor_lists(&x, h);
    let prm = TransitionParams::paper(h);
    let at = |k: usize| new_codim(k, &frames[k], &x, &codim, &fixed, nl.of(k), &prm);
    assert_eq!(at(edge), Codim::Sheet);
    assert_eq!(at((n - 1) * n + n / 2), Codim::Filament);
    assert_eq!(at((n / 2) * n), Codim::Filament);
    // a film-only scene has no volume rules, and the edge turns as before
    let film = TransitionParams {
        volume_rules: false,
        ..prm.clone()
    };
    let k = edge;
    assert_eq!(
        new_codim(k, &frames[k], &x, &codim, &fixed, nl.of(k), &film),
        Codim::Filament
    );
}

#[test]
fn a_filament_inside_a_volume_body_returns_to_volume_one_on_its_surface_to_sheet() {
    let h = 0.3;
    let s = h / 3.0;
    // a line of filament particles along x through a 5×5×5 volume block
    let (mut x, codim) = block(2, s, |_, j, k| j == 0 && k == 0, Codim::Filament);
    let frames = vec![Mat3::identity(); x.len()];
    let fixed = vec![false; x.len()];
    let (c, n) = update_all(&x, &codim, &frames, &TransitionParams::paper(h));
    let centre = x.iter().position(|p| p.norm() == 0.0).unwrap();
    assert_eq!(c[centre], Codim::Volume);
    assert!(n.filament_to_volume >= 1);
    // the same line lying on the block's top face (volume below only)
    // joins the surface layer; 1.2 h above it, it stays a filament
    for (z, kind, count) in [
        (3.0 * s, Codim::Sheet, 5),
        (2.0 * s + 1.2 * h, Codim::Filament, 0),
    ] {
        for p in x.iter_mut().zip(&codim) {
            if *p.1 == Codim::Filament {
                p.0.z = z;
            }
        }
        let (c, n) = update_all(&x, &codim, &frames, &TransitionParams::paper(h));
        assert_eq!(n.filament_to_volume, 0);
        assert_eq!(n.filament_to_sheet, count);
        assert_eq!(c[centre], kind);
    }
    // and a film-only scene never applies the rule, even to the buried line
    let film = TransitionParams {
        volume_rules: false,
        ..TransitionParams::paper(h)
    };
    for p in x.iter_mut().zip(&codim) {
        if *p.1 == Codim::Filament {
            p.0.z = 0.0;
        }
    }
    let nl = neighbor_lists(&x, h);
    let mut c = codim.clone();
    let n = update_codims(&x, &mut c, &fixed, &frames, |i| nl.of(i), &film);
    assert_eq!(n.filament_to_volume, 0);
}

#[test]
fn lone_filament_particle_becomes_point_fixed_never_changes() {
    let h = 0.1;
    let x = vec![
        Vec3::zeros(),
        Vec3::new(0.05, 0.0, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
    ];
    let mut codim = vec![Codim::Filament; 3];
    let frames = vec![Mat3::identity(); 3];
    let nl = neighbor_lists(&x, h);
    let n = update_codims(
        &x,
        &mut codim,
        &[false, false, false],
        &frames,
        |i| nl.of(i),
        &TransitionParams::paper(h),
    );
    assert_eq!(codim, vec![Codim::Filament, Codim::Filament, Codim::Point]);
    assert_eq!(n.filament_to_point, 1);
    let mut codim = vec![Codim::Filament; 3];
    update_codims(
        &x,
        &mut codim,
        &[false, false, true],
        &frames,
        |i| nl.of(i),
        &TransitionParams::paper(h),
    );
    assert_eq!(codim[2], Codim::Filament);
}

#[test]
fn census_is_independent_of_neighbour_order() {
    let h = 0.3;
    let x = sheet(7, 0.1);
    let codim = vec![Codim::Sheet; x.len()];
    let nl = neighbor_lists(&x, h);
    let p = 24;
    let mut rev: Vec<u32> = nl.of(p).to_vec();
    rev.reverse();
    let a = cone_census(p, &Vec3::x(), 0.5, h, &x, &codim, nl.of(p));
    let b = cone_census(p, &Vec3::x(), 0.5, h, &x, &codim, &rev);
    assert_eq!(a.plus, b.plus);
    assert_eq!(a.minus, b.minus);
}

#[test]
fn a_filament_inside_a_flat_film_rejoins_it_an_edge_or_a_funnel_tip_does_not() {
    let h = 0.3;
    let s = 0.1;
    // a 7 × 7 sheet in the xy plane, its centre particle a filament
    let x = sheet(7, s);
    let centre = 24;
    let mut codim = vec![Codim::Sheet; x.len()];
    codim[centre] = Codim::Filament;
    let frames = vec![Mat3::identity(); x.len()];
    let fixed = vec![false; x.len()];
    let nl = neighbor_lists(&x, h);
    let film = TransitionParams::film(h);
    let at = |x: &[Vec3], codim: &[Codim], k: usize, prm: &TransitionParams| {
        new_codim(k, &frames[k], x, codim, &fixed, nl.of(k), prm)
    };
    assert_eq!(at(&x, &codim, centre, &film), Codim::Sheet);
    // the paper's rules (liquid scenes) do not return it to the film: with
    // no filament neighbour it becomes a point
    assert_eq!(
        at(&x, &codim, centre, &TransitionParams::paper(h)),
        Codim::Point
    );
    // a filament on the sheet's edge (the middle of a side) stays one
    let mut edge = vec![Codim::Sheet; x.len()];
    edge[3] = Codim::Filament;
    edge[2] = Codim::Filament;
    edge[4] = Codim::Filament;
    assert_eq!(at(&x, &edge, 3, &film), Codim::Filament);
    // the centre lifted into the tip of a funnel (1.5 spacings above its
    // neighbours' plane) does not rejoin the film (alone, it is a point)
    let mut tip = x.clone();
    tip[centre].z += 1.5 * s;
    let nl2 = neighbor_lists(&tip, h);
    assert_eq!(
        new_codim(
            centre,
            &frames[centre],
            &tip,
            &codim,
            &fixed,
            nl2.of(centre),
            &film
        ),
        Codim::Point
    );
    assert!(!surrounded_by_sheet(
        centre,
        h,
        film.filament_to_sheet_gap,
        &tip,
        &codim,
        nl2.of(centre)
    ));
    assert!(surrounded_by_sheet(
        centre,
        h,
        film.filament_to_sheet_gap,
        &x,
        &codim,
        nl.of(centre)
    ));
}
