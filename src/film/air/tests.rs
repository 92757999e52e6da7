//! Unit tests of [`super`]: the outflow root, components, bubbles, the
//! bag's mouth and the jet's trapped air.
use super::*;
use std::f64::consts::PI;

/// `n` points on a sphere of radius `r` about `c` (golden spiral), with
/// outward normals and equal areas.
fn sphere(n: usize, r: Real, c: Vec3) -> (Vec<Vec3>, Vec<Vec3>, Vec<Real>) {
    let ga = PI * (3.0 - (5.0 as Real).sqrt());
    let nrm: Vec<Vec3> = (0..n)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as Real + 0.5) / n as Real;
            let rho = (1.0 - z * z).sqrt();
            let t = ga * i as Real;
            Vec3::new(rho * t.cos(), rho * t.sin(), z)
        })
        .collect();
    let x = nrm.iter().map(|n| c + n * r).collect();
    (x, nrm, vec![4.0 * PI * r * r / n as Real; n])
}

/// Every particle's neighbours within `h` (brute force).
fn neighbours(x: &[Vec3], h: Real) -> Vec<Vec<u32>> {
    (0..x.len())
        .map(|i| {
            (0..x.len())
                .filter(|&j| j != i && (x[j] - x[i]).norm() < h)
                .map(|j| j as u32)
                .collect()
        })
        .collect()
}

/// A test film's sheet data: uniform areas and masses, ids 0..n, its
/// neighbour lists within `h`.
struct Film {
    x: Vec<Vec3>,
    nrm: Vec<Vec3>,
    fixed: Vec<bool>,
    area: Vec<Real>,
    mass: Vec<Real>,
    id: Vec<u64>,
    nb: Vec<Vec<u32>>,
}

impl Film {
    fn new(
        x: Vec<Vec3>,
        nrm: Vec<Vec3>,
        fixed: Vec<bool>,
        area: Real,
        mass: Real,
        h: Real,
    ) -> Film {
        let n = x.len();
        let nb = neighbours(&x, h);
        Film {
            x,
            nrm,
            fixed,
            area: vec![area; n],
            mass: vec![mass; n],
            id: (0..n as u64).collect(),
            nb,
        }
    }

    fn sheets(&self) -> Sheets<'_> {
        Sheets {
            x: &self.x,
            mass: &self.mass,
            area: &self.area,
            normals: &self.nrm,
            fixed: &self.fixed,
            id: &self.id,
        }
    }
}

fn params(h: Real) -> AirParams {
    AirParams::new(Vec3::zeros(), Vec3::new(0.0, 1.0, 0.0), 0.02, 1.2, h)
}

#[test]
fn bag_pressure_is_the_root_of_the_outflow_balance() {
    let rho = 1.2;
    for (g, c, a) in [(-2e-5, 3e-6, 1e-4), (4e-6, 2e-6, 5e-5), (-1e-3, 1e-7, 1e-3)] {
        let p: Real = bag_pressure(g, c, a, rho);
        let q = p.signum() * a * (2.0 * p.abs() / rho).sqrt();
        let residual = g + c * p + q;
        assert!(
            residual.abs() < 1e-12 * g.abs(),
            "{g} {c} {a}: p = {p}, residual {residual}"
        );
        // a bag that shrinks pushes its air out: p > 0; one that grows sucks
        assert_eq!(p.signum(), -g.signum());
    }
    // a closed mouth: the volume rate is cancelled exactly
    assert!((bag_pressure(-3e-5, 2e-6, 0.0, rho) - 15.0).abs() < 1e-9);
    assert_eq!(bag_pressure(0.0, 1e-6, 1e-4, rho), 0.0);
}

#[test]
fn components_split_disconnected_films() {
    let nbrs: Vec<Vec<u32>> = vec![vec![1], vec![0, 2], vec![1], vec![4], vec![3], vec![]];
    let (label, n) = components(6, |i| &nbrs[i]);
    assert_eq!(n, 3);
    assert_eq!(label, vec![0, 0, 0, 1, 1, 2]);
}

#[test]
fn a_free_closed_film_becomes_a_bubble_that_holds_its_volume() {
    let (r, h) = (0.01, 0.0025);
    let (x, nrm, area) = sphere(2000, r, Vec3::new(0.0, 0.05, 0.0));
    let n = x.len();
    let film = Film::new(x, nrm, vec![false; n], area[0], 1e-9, h);
    let (nrm, area, mass) = (&film.nrm, &film.area, &film.mass);
    let s = film.sheets();
    let prm = params(h);
    let sv = survey(&s, |i| &film.nb[i], &prm);
    assert!(sv.bag.is_empty(), "no ring: no bag");
    // tension alone shrinks it: every wall moves inwards at 0.3 m/s
    let mut u: Vec<Vec3> = nrm.iter().map(|m| -m * 0.3).collect();
    let mut st = AirState::default();
    let dt = 1e-4;
    let mut plan = plan(&s, &sv, &u, &prm, &mut st, dt, false);
    assert_eq!(plan.info.new_bubbles, 1);
    assert_eq!(st.bubbles.len(), 1);
    let v_sphere = 4.0 / 3.0 * PI * r.powi(3);
    assert!(
        (st.bubbles[0].v0 / v_sphere - 1.0).abs() < 0.01,
        "{}",
        st.bubbles[0].v0
    );
    assert!(st.bubbles[0].ids.len() >= 30);
    // the probe response of lumped masses: Δt A n / m per pascal
    let du: Vec<Vec3> = (0..n).map(|i| nrm[i] * (dt * area[i] / mass[i])).collect();
    plan.apply(&s, sv.labels(), &mut u, &du, prm.density, &mut st);
    let rate: Real = (0..n).map(|i| area[i] * nrm[i].dot(&u[i])).sum();
    let before = 4.0 * PI * r * r * 0.3;
    assert!(
        rate.abs() < 1e-9 * before,
        "volume rate {rate} against {before}"
    );
    // what that took: p = −V̇ / Σ A²Δt/m
    let p = before / (n as Real * area[0] * area[0] * dt / mass[0]);
    assert!((st.bubbles[0].pressure / p - 1.0).abs() < 1e-9);
    // and the next step finds the same bubble again by its ids
    let plan2 = super::plan(&s, &sv, &u, &prm, &mut st, dt, false);
    assert_eq!((plan2.info.new_bubbles, st.bubbles.len()), (0, 1));
}

#[test]
fn two_bubbles_that_meet_merge_and_keep_both_airs() {
    let (r, h) = (0.01, 0.0025);
    let (x, nrm, _) = sphere(2000, r, Vec3::zeros());
    let n = x.len();
    let film = Film::new(
        x,
        nrm,
        vec![false; n],
        4.0 * PI * r * r / n as Real,
        1e-9,
        h,
    );
    let s = film.sheets();
    let prm = params(h);
    let sv = survey(&s, |i| &film.nb[i], &prm);
    // two bubbles of half the sphere's volume each, whose films are now
    // one: the ids of one are the even particles, of the other the odd
    let v = 4.0 / 3.0 * PI * r.powi(3);
    let half = |k: u64| Bubble {
        v0: 0.5 * v,
        ids: (0..32).map(|j| s.id[(2 * j + k) as usize * 7]).collect(),
        pressure: 0.0,
    };
    let mut st = AirState {
        bubbles: vec![half(0), half(1)],
    };
    let u = vec![Vec3::zeros(); n];
    let p = plan(&s, &sv, &u, &prm, &mut st, 1e-4, false);
    assert_eq!((p.info.burst, p.info.merged, st.bubbles.len()), (0, 1, 1));
    assert!((st.bubbles[0].v0 / v - 1.0).abs() < 1e-12);
    assert_eq!(p.pockets.len(), 1);
    // the merged film's volume is the sum of both airs to the sampling's
    // accuracy
    assert!(
        p.info.bubble_volume_error < 0.01,
        "{}",
        p.info.bubble_volume_error
    );
}

#[test]
fn an_open_cap_or_a_crumpled_sheet_is_no_bubble() {
    let (r, h) = (0.01, 0.0025);
    let (x, nrm, area) = sphere(2000, r, Vec3::zeros());
    // the upper 80 % of a sphere: a bubble with a hole of radius 0.8 R
    let keep: Vec<usize> = (0..x.len()).filter(|&i| nrm[i].z > -0.6).collect();
    let pick = |v: &[Vec3]| keep.iter().map(|&i| v[i]).collect::<Vec<_>>();
    let (x, nrm) = (pick(&x), pick(&nrm));
    let n = x.len();
    let cap = Film::new(x, nrm, vec![false; n], area[0], 1e-9, h);
    let s = cap.sheets();
    let prm = params(h);
    let sv = survey(&s, |i| &cap.nb[i], &prm);
    let mut st = AirState::default();
    let p = plan(&s, &sv, &vec![Vec3::zeros(); n], &prm, &mut st, 1e-4, false);
    assert_eq!((p.info.new_bubbles, p.pockets.len()), (0, 0));
    // a flat square sheet whose normals alternate: Σ A n = 0, no volume
    let x: Vec<Vec3> = (0..400)
        .map(|i| Vec3::new((i % 20) as Real * 1e-3, 0.0, (i / 20) as Real * 1e-3))
        .collect();
    let nrm: Vec<Vec3> = (0..400)
        .map(|i| Vec3::new(0.0, if i % 2 == 0 { 1.0 } else { -1.0 }, 0.0))
        .collect();
    let flat = Film::new(x, nrm, vec![false; 400], 1e-6, 1e-9, h);
    let s = flat.sheets();
    let sv = survey(&s, |i| &flat.nb[i], &prm);
    let p = plan(
        &s,
        &sv,
        &vec![Vec3::zeros(); 400],
        &prm,
        &mut st,
        1e-4,
        false,
    );
    assert_eq!((p.info.new_bubbles, p.pockets.len()), (0, 0));
}

/// A bag on a ring of radius 20 mm along +y: a flat annulus at s = 0,
/// a tube of radius `r_neck` for s in (0, 10 mm), then a sphere of
/// radius 15 mm; walls with outward normals, equal areas.
fn bulb_on_a_ring(r_neck: Real) -> (Vec<Vec3>, Vec<Vec3>, Vec<bool>) {
    let mut x = Vec::new();
    let mut nrm = Vec::new();
    let mut fixed = Vec::new();
    let ring = 0.02;
    for k in 0..120 {
        let t = 2.0 * PI * k as Real / 120.0;
        x.push(Vec3::new(ring * t.cos(), 0.0, ring * t.sin()));
        nrm.push(Vec3::new(0.0, 1.0, 0.0));
        fixed.push(true);
    }
    let d = 0.0006;
    // annulus
    let mut rr = r_neck;
    while rr < ring {
        let m = (2.0 * PI * rr / d) as usize;
        for k in 0..m {
            let t = 2.0 * PI * k as Real / m as Real;
            x.push(Vec3::new(rr * t.cos(), 0.0, rr * t.sin()));
            nrm.push(Vec3::new(0.0, 1.0, 0.0));
            fixed.push(false);
        }
        rr += d;
    }
    // tube
    let mut y = d;
    let m = (2.0 * PI * r_neck / d) as usize;
    while y < 0.01 {
        for k in 0..m {
            let t = 2.0 * PI * k as Real / m as Real;
            x.push(Vec3::new(r_neck * t.cos(), y, r_neck * t.sin()));
            nrm.push(Vec3::new(t.cos(), 0.0, t.sin()));
            fixed.push(false);
        }
        y += d;
    }
    // bulb, minus the cap where the tube enters
    let (rb, cy) = (0.015, 0.01 + (0.015 * 0.015 - r_neck * r_neck).sqrt());
    let (xs, ns, _) = sphere(8000, rb, Vec3::new(0.0, cy, 0.0));
    for (p, n) in xs.into_iter().zip(ns) {
        if p.y > 0.01 {
            x.push(p);
            nrm.push(n);
            fixed.push(false);
        }
    }
    (x, nrm, fixed)
}

#[test]
fn the_mouth_of_a_collapsing_bulb_is_its_neck() {
    let h = 0.0015;
    let (x, nrm, fixed) = bulb_on_a_ring(0.004);
    let n = x.len();
    let film = Film::new(x, nrm, fixed, 0.0006 * 0.0006, 1e-10, h);
    let (x, nrm, fixed, area, mass) = (&film.x, &film.nrm, &film.fixed, &film.area, &film.mass);
    let s = film.sheets();
    let prm = params(h);
    let sv = survey(&s, |i| &film.nb[i], &prm);
    assert_eq!(sv.bag.len(), n - 120, "one film on the ring");
    assert_eq!(sv.sign, 1.0);
    // every wall moves inwards: the bulb's air leaves through the neck
    let u: Vec<Vec3> = (0..n)
        .map(|i| {
            if fixed[i] {
                Vec3::zeros()
            } else {
                -nrm[i] * 0.2
            }
        })
        .collect();
    let mut st = AirState::default();
    let dt = 1e-4;
    let mut p = plan(&s, &sv, &u, &prm, &mut st, dt, false);
    assert!(
        p.info.mouth_offset > 0.0 && p.info.mouth_offset < 0.01,
        "{:?}",
        p.info
    );
    assert!((p.info.mouth_radius - 0.004).abs() < 2e-4, "{:?}", p.info);
    assert_eq!(p.pockets.len(), 1);
    // the pressure: the outflow through the neck balances what is left
    let mut u2 = u.clone();
    let du: Vec<Vec3> = (0..n)
        .map(|i| {
            if fixed[i] {
                Vec3::zeros()
            } else {
                nrm[i] * (dt * area[i] / mass[i])
            }
        })
        .collect();
    // the probe applied the Bernoulli weights: scale the response alike
    let w: Vec<Real> = {
        let mut w = vec![0.0; n];
        for (i, f) in p.forces(&s, 1.0) {
            w[i] = f.norm() / area[i];
        }
        w
    };
    let du: Vec<Vec3> = (0..n).map(|i| du[i] * w[i]).collect();
    p.apply(&s, sv.labels(), &mut u2, &du, prm.density, &mut st);
    let pb = p.info.bag_pressure;
    assert!(pb > 0.0, "{pb}");
    let walls: Vec<usize> = (0..n)
        .filter(|&i| !fixed[i] && x[i].y >= p.info.mouth_offset)
        .collect();
    let rate: Real = walls.iter().map(|&i| area[i] * nrm[i].dot(&u2[i])).sum();
    let q = PI * p.info.mouth_radius.powi(2) * (2.0 * pb / prm.density).sqrt();
    assert!(
        (rate + q).abs() < 1e-6 * q,
        "volume rate {rate}, outflow {q}"
    );
    // the walls in the mouth feel the atmosphere's pressure, the bulb's
    // far end nearly all of the bag's
    let top = (0..n)
        .max_by(|&a, &b| x[a].y.partial_cmp(&x[b].y).unwrap())
        .unwrap();
    assert!(w[top] > 0.9, "{}", w[top]);
    let min_w = walls.iter().map(|&i| w[i]).fold(1.0, Real::min);
    assert!(min_w < 0.1, "{min_w}");
}

#[test]
fn while_a_jet_blows_the_bag_is_left_to_its_stagnation_pressure() {
    let h = 0.0015;
    let (x, nrm, fixed) = bulb_on_a_ring(0.004);
    let n = x.len();
    let film = Film::new(x, nrm, fixed, 0.0006 * 0.0006, 1e-10, h);
    let (nrm, area) = (&film.nrm, &film.area);
    let s = film.sheets();
    let prm = params(h);
    let sv = survey(&s, |i| &film.nb[i], &prm);
    let u = vec![Vec3::zeros(); n];
    let p = plan(&s, &sv, &u, &prm, &mut AirState::default(), 1e-4, true);
    assert!(p.pockets.is_empty());
    let f = jet_forces(&s, &sv, |_| 2.0);
    assert_eq!(f.len(), n - 120);
    for (i, fi) in f {
        assert!((fi - nrm[i] * (2.0 * area[i])).norm() < 1e-15);
    }
}
