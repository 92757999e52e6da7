//! Moving-ring catenoid pinch (paper Fig. 6): rings pulled apart past the
//! critical separation d = 1.3255 R make the neck close; the film splits into
//! two pieces, each attached to its ring; the funnel left by the pinch
//! retracts at the Taylor–Culick speed √(2σ/ρτ) and each piece ends as a
//! film spanning its ring (Fig. 6: "splits into two surfaces"). Coarse
//! (s = 3 mm, ~1.5–3.5k particles), a few seconds.
use codimfx::film::catenoid::CatenoidSetup;
use codimfx::film::step::advance_by;
use codimfx::film::{FilmParams, FilmState};
use codimfx::math::{Real, Vec3};
use codimfx::particles::{Codim, Particles};

/// Connected pieces of the sheet + filament particles (links shorter than
/// `h`): (size, ring particles at z > 0, ring particles at z < 0) each.
fn pieces(p: &Particles, h: Real) -> Vec<(usize, usize, usize)> {
    let idx: Vec<usize> = (0..p.len())
        .filter(|&i| matches!(p.codim[i], Codim::Sheet | Codim::Filament))
        .collect();
    let n = idx.len();
    let mut parent: Vec<usize> = (0..n).collect();
    fn find(p: &mut [usize], mut i: usize) -> usize {
        while p[i] != i {
            p[i] = p[p[i]];
            i = p[i];
        }
        i
    }
    for a in 0..n {
        for b in a + 1..n {
            if (p.x[idx[a]] - p.x[idx[b]]).norm() < h {
                let (ra, rb) = (find(&mut parent, a), find(&mut parent, b));
                if ra != rb {
                    parent[ra.max(rb)] = ra.min(rb);
                }
            }
        }
    }
    let mut out = std::collections::BTreeMap::new();
    for (a, &i) in idx.iter().enumerate() {
        let e = out
            .entry(find(&mut parent, a))
            .or_insert((0usize, 0usize, 0usize));
        e.0 += 1;
        if p.fixed[i] {
            if p.x[i].z > 0.0 {
                e.1 += 1
            } else {
                e.2 += 1
            }
        }
    }
    out.into_values().collect()
}

/// Rim of the lower half: (z, distance to the axis) of its film particle
/// nearest the middle.
fn lower_rim(p: &Particles) -> Option<(Real, Real)> {
    (0..p.len())
        .filter(|&i| !p.fixed[i] && p.codim[i] != Codim::Point && p.x[i].z < 0.0)
        .map(|i| (p.x[i].z, p.x[i].x.hypot(p.x[i].y)))
        .max_by(|a, b| a.0.total_cmp(&b.0))
}

#[test]
fn catenoid_with_separating_rings_pinches_and_splits_into_two_films() {
    let s = 0.003;
    let h = 3.0 * s;
    let mut set = CatenoidSetup::paper(s);
    set.ring_speed = 0.05; // m/s each way
    let (r_ring, sigma, rho, tau) = (set.radius, 0.015, 1000.0, set.thickness);
    let v_tc = (2.0 * sigma / (rho * tau)).sqrt(); // 5.48 m/s
    let mut p = set.particles();
    let m0 = p.total_mass();
    let n_ring = p.fixed.iter().filter(|f| **f).count() / 2;
    let mut prm = FilmParams::new(h, sigma);
    prm.gravity = Vec3::zeros();
    prm.damping = 5.0;
    // as `codimfx sim` does for scenes with moving rings
    prm.reseed.as_mut().unwrap().gap_lines = true;
    let mut st = FilmState::default();
    let sep = |p: &Particles| {
        2.0 * (0..p.len())
            .filter(|&i| p.fixed[i])
            .map(|i| p.x[i].z)
            .fold(0.0, Real::max)
            / r_ring
    };
    // 10 frames of 1/30 s: the rings reach d = 1.40 R, the film stays whole
    for _ in 0..10 {
        advance_by(&mut p, &mut st, &prm, 1.0 / 30.0, s, 0.5).expect("film step");
        assert_eq!(pieces(&p, h).len(), 1);
    }
    assert!(sep(&p) > 1.3255, "rings at {} R", sep(&p));
    // then frames of 1/1500 s through the pinch
    let fdt = 1.0 / 1500.0;
    let (mut split, mut rim) = (None, Vec::new());
    for f in 0..50 {
        advance_by(&mut p, &mut st, &prm, fdt, s, 0.5).expect("film step");
        assert!(p.all_finite());
        assert!((p.total_mass() - m0).abs() <= 1e-12 * m0, "frame {f}: mass");
        let pc: Vec<_> = pieces(&p, h).into_iter().filter(|c| c.0 > 20).collect();
        eprintln!(
            "t +{:.2} ms d/R {:.3} counts {:?} pieces {pc:?} rim {:?}",
            (f + 1) as Real * fdt * 1e3,
            sep(&p),
            p.counts(),
            lower_rim(&p)
        );
        // two pieces, each holding one whole ring and at least 5 rows of film
        let two = pc.len() == 2
            && pc
                .iter()
                .any(|c| c.1 == n_ring && c.2 == 0 && c.0 > 6 * n_ring)
            && pc
                .iter()
                .any(|c| c.2 == n_ring && c.1 == 0 && c.0 > 6 * n_ring);
        if split.is_none() && two {
            split = Some((f, sep(&p)));
        }
        if split.is_some() {
            if let Some(r) = lower_rim(&p).filter(|r| r.1 < 0.2 * r_ring) {
                rim.push(((f + 1) as Real * fdt, r));
            }
        }
    }
    let (f_split, d_split) = split.expect("the film never split into two ring-attached pieces");
    eprintln!(
        "split after {:.2} ms at d = {d_split:.3} R",
        (f_split + 1) as Real * fdt * 1e3
    );
    assert!(d_split > 1.3255 && d_split < 1.5, "{d_split}");
    // the lower half's rim (the tip of the funnel left by the pinch) runs back
    // along the axis at the Taylor–Culick speed
    assert!(rim.len() >= 4, "{rim:?}");
    let ((t0, a), (t1, b)) = (rim[0], *rim.last().unwrap());
    let v = ((b.0 - a.0).powi(2) + (b.1 - a.1).powi(2)).sqrt() / (t1 - t0);
    eprintln!("rim speed {v:.2} m/s (Taylor-Culick {v_tc:.2})");
    assert!((v / v_tc - 1.0).abs() < 0.25, "rim speed {v} vs {v_tc}");
    // each half spans its ring: a piece of film holding the whole ring whose
    // particles come within R/4 of the axis (a disk or cap, not a rim left
    // on the ring); the rings untouched (all there, at radius R, moving with
    // their prescribed speed)
    for side in [-1.0, 1.0] {
        let r_min = (0..p.len())
            .filter(|&i| !p.fixed[i] && p.codim[i] == Codim::Sheet && p.x[i].z * side > 0.0)
            .map(|i| p.x[i].x.hypot(p.x[i].y))
            .fold(Real::INFINITY, Real::min);
        assert!(
            r_min < 0.25 * r_ring,
            "side {side}: film reaches r = {r_min}"
        );
    }
    let pc: Vec<_> = pieces(&p, h).into_iter().filter(|c| c.0 > 20).collect();
    assert!(
        pc.len() == 2 && pc.iter().all(|c| c.1 + c.2 == n_ring && c.0 > 6 * n_ring),
        "{pc:?}"
    );
    let z_ring = 0.5 * sep(&p) * r_ring;
    for i in (0..p.len()).filter(|&i| p.fixed[i]) {
        assert!((p.x[i].x.hypot(p.x[i].y) / r_ring - 1.0).abs() < 1e-12);
        assert!((p.x[i].z.abs() - z_ring).abs() < 1e-12);
        assert!((p.v[i].z.abs() - 0.05).abs() < 1e-12 && p.v[i].xy().norm() == 0.0);
    }
    assert_eq!(p.fixed.iter().filter(|f| **f).count(), 2 * n_ring);
}
