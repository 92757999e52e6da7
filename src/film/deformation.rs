//! Sphere deformation under LeVeque's 3-D flow (paper §10.1, Fig. 15): the
//! test of sheet reseeding (§9).
//!
//! The velocity field of LeVeque (1996), as used by Enright et al. (2002), on
//! the unit cube:
//!
//! u = 2 sin²(πx) sin(2πy) sin(2πz) g,  v = −sin(2πx) sin²(πy) sin(2πz) g,
//! w = −sin(2πx) sin(2πy) sin²(πz) g,
//!
//! with a sphere of radius 0.15 centred at (0.35, 0.35, 0.35). As in the
//! paper the flow runs forward to t = 0.61 s (g = 1), the sheet then being
//! stretched the most, and backward (g = −1) to t = 1.22 s, when the exact
//! solution is the initial sphere again. Particles move by the midpoint rule
//! with Δt = 0.01 s; after each step the sheet is reseeded.

use crate::math::{Mat3, Real, Vec3};
use crate::mls::operators::{par_fit_map, par_frames, Neighborhoods};
use crate::mls::{MlsError, MlsParams};
use crate::particles::{Codim, Particles};
use crate::reseed::{reseed, LocalShape, ReseedCounts, ReseedParams};
use rayon::prelude::*;
use std::f64::consts::PI;

/// LeVeque's deformation velocity at `x`, with sign `g` (±1).
pub fn leveque(x: &Vec3, g: Real) -> Vec3 {
    let (sx, sy, sz) = ((PI * x.x).sin(), (PI * x.y).sin(), (PI * x.z).sin());
    let (s2x, s2y, s2z) = (
        (2.0 * PI * x.x).sin(),
        (2.0 * PI * x.y).sin(),
        (2.0 * PI * x.z).sin(),
    );
    Vec3::new(
        2.0 * sx * sx * s2y * s2z,
        -s2x * sy * sy * s2z,
        -s2x * s2y * sz * sz,
    ) * g
}

/// Samples a sphere by latitude circles (Appendix F): circles spaced `s`
/// apart along the meridian, each with round(2πr/s) particles.
pub fn latitude_sphere(centre: Vec3, r: Real, s: Real) -> Vec<Vec3> {
    let nlat = (PI * r / s).round().max(2.0) as usize;
    let mut out = Vec::new();
    for i in 0..=nlat {
        let phi = PI * i as Real / nlat as Real;
        let rho = r * phi.sin();
        let n = ((2.0 * PI * rho / s).round() as usize).max(1);
        for k in 0..n {
            let t = 2.0 * PI * (k as Real + 0.5 * (i % 2) as Real) / n as Real;
            out.push(centre + Vec3::new(rho * t.cos(), rho * t.sin(), r * phi.cos()));
        }
    }
    out
}

/// Settings of the deformation test.
#[derive(Clone, Debug, PartialEq)]
pub struct DeformationSetup {
    /// Initial particle spacing (m, unit cube).
    pub spacing: Real,
    /// Support radius h relative to the spacing.
    pub h_over_spacing: Real,
    /// Time step (s); paper 0.01.
    pub dt: Real,
    /// Reversal time (s); paper 0.61.
    pub t_reverse: Real,
    /// Removal threshold relative to h (paper 0.1–0.2).
    pub remove_distance: Real,
    /// MLS fit order for the reseeding lift.
    pub order: usize,
}

impl DeformationSetup {
    /// The paper's settings at spacing `s`.
    pub fn paper(s: Real) -> Self {
        DeformationSetup {
            spacing: s,
            h_over_spacing: 3.0,
            dt: 0.01,
            t_reverse: 0.61,
            remove_distance: 0.15,
            order: 3,
        }
    }
}

/// Figures of the deformation test.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct DeformationReport {
    /// Particles at t = 0.
    pub particles_start: usize,
    /// Particles at the reversal (maximal stretch).
    pub particles_max_stretch: usize,
    /// Particles at the end.
    pub particles_end: usize,
    /// Largest | |x − c| − R | at the end, relative to R.
    pub max_distance_rel: Real,
    /// Mean | |x − c| − R | at the end, relative to R.
    pub mean_distance_rel: Real,
    /// At maximal stretch: fraction of particles whose 3×3 inner tangent cells are all filled.
    pub coverage_max_stretch: Real,
    /// At maximal stretch: largest nearest-neighbour distance relative to h.
    pub max_gap_max_stretch: Real,
    /// Reseeding totals.
    pub inserted: u64,
    /// Reseeding totals.
    pub removed: u64,
    /// Wall time (s).
    pub seconds: Real,
}

struct Taylor {
    h: Real,
    geo: Vec<Option<([Real; 2], [Real; 3])>>,
}

impl LocalShape for Taylor {
    fn height(&self, p: usize, u: Real, v: Real) -> Real {
        let Some((s, d)) = self.geo[p] else {
            return 0.0;
        };
        let (a, b) = (u / self.h, v / self.h);
        self.h * (s[0] * a + s[1] * b + 0.5 * (d[0] * a * a + 2.0 * d[1] * a * b + d[2] * b * b))
    }
    fn curve(&self, _: usize, _: Real) -> (Real, Real) {
        (0.0, 0.0)
    }
}

/// Coverage figures of a sheet: (fraction of particles with a hole-free
/// tangent neighbourhood, largest nearest-neighbour distance / h).
pub fn coverage(
    x: &[Vec3],
    frames: &[Mat3],
    nb: &Neighborhoods,
    h: Real,
    cell: Real,
) -> (Real, Real) {
    let res: Vec<(bool, Real)> = (0..x.len())
        .into_par_iter()
        .map(|p| {
            let c = cell * h;
            let mut filled = [[false; 5]; 5];
            filled[2][2] = true;
            let (b1, b2): (Vec3, Vec3) = (frames[p].column(0).into(), frames[p].column(1).into());
            let mut nn = Real::INFINITY;
            for &q in nb.lists.of(p) {
                let d = x[q as usize] - x[p];
                nn = nn.min(d.norm());
                let (u, v) = (d.dot(&b1) / c + 2.5, d.dot(&b2) / c + 2.5);
                if (0.0..5.0).contains(&u) && (0.0..5.0).contains(&v) {
                    filled[u as usize][v as usize] = true;
                }
            }
            let full = (1..4).all(|i| (1..4).all(|j| filled[i][j]));
            (full, if nn.is_finite() { nn / h } else { 1.0 })
        })
        .collect();
    let frac = res.iter().filter(|r| r.0).count() as Real / res.len().max(1) as Real;
    (frac, res.iter().map(|r| r.1).fold(0.0, Real::max))
}

fn midpoint(x: &mut [Vec3], dt: Real, g: Real) {
    x.par_iter_mut().for_each(|p| {
        let mid = *p + leveque(p, g) * (0.5 * dt);
        *p += leveque(&mid, g) * dt;
    });
}

/// Runs the test; `on_step(t, particles)` is called after every step.
pub fn run(
    set: &DeformationSetup,
    mut on_step: impl FnMut(Real, usize),
) -> Result<DeformationReport, MlsError> {
    let t0 = std::time::Instant::now();
    let (c, r) = (Vec3::new(0.35, 0.35, 0.35), 0.15);
    let h = set.h_over_spacing * set.spacing;
    let mls = MlsParams {
        order: set.order,
        ..MlsParams::new(h)
    };
    let mut p = Particles::new();
    let area = 4.0 * PI * r * r;
    let pts = latitude_sphere(c, r, set.spacing);
    let m = area / pts.len() as Real;
    for x in pts {
        p.push(x, Vec3::zeros(), m, 0.0, Codim::Sheet);
    }
    let mut rep = DeformationReport {
        particles_start: p.len(),
        ..Default::default()
    };
    let rp = ReseedParams {
        remove_distance: set.remove_distance,
        ..ReseedParams::paper(h)
    };
    let n_steps = (2.0 * set.t_reverse / set.dt).round() as usize;
    let n_half = (set.t_reverse / set.dt).round() as usize;
    let mut totals = ReseedCounts::default();
    for k in 0..n_steps {
        let g = if k < n_half { 1.0 } else { -1.0 };
        midpoint(&mut p.x, set.dt, g);
        let nb = Neighborhoods::build(&p.x, &p.codim, h)?;
        let frames = par_frames(&nb, &mls);
        let axes: Vec<Mat3> = frames.iter().map(|f| f.axes).collect();
        if k + 1 == n_half {
            let (cov, gap) = coverage(&nb.x, &axes, &nb, h, rp.cell);
            rep.coverage_max_stretch = cov;
            rep.max_gap_max_stretch = gap;
        }
        let (geo, _) = par_fit_map(&nb, &frames, &mls, |_, f| f.map(|f| (f.slope, f.second)));
        // all particles are sheets, so the joint order is the store order
        let rc = reseed(&mut p, &axes, |i| nb.lists.of(i), &Taylor { h, geo }, &rp);
        totals.sheet_inserted += rc.sheet_inserted;
        totals.sheet_removed += rc.sheet_removed;
        if k + 1 == n_half {
            rep.particles_max_stretch = p.len();
        }
        on_step((k + 1) as Real * set.dt, p.len());
    }
    rep.particles_end = p.len();
    let d: Vec<Real> = p.x.iter().map(|x| ((x - c).norm() - r).abs() / r).collect();
    rep.max_distance_rel = d.iter().copied().fold(0.0, Real::max);
    rep.mean_distance_rel = d.iter().sum::<Real>() / d.len() as Real;
    rep.inserted = totals.sheet_inserted;
    rep.removed = totals.sheet_removed;
    rep.seconds = t0.elapsed().as_secs_f64();
    Ok(rep)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn leveque_is_divergence_free() {
        let e = 1e-5;
        for x in [Vec3::new(0.3, 0.4, 0.5), Vec3::new(0.7, 0.2, 0.9)] {
            let d = (leveque(&(x + Vec3::x() * e), 1.0).x - leveque(&(x - Vec3::x() * e), 1.0).x
                + leveque(&(x + Vec3::y() * e), 1.0).y
                - leveque(&(x - Vec3::y() * e), 1.0).y
                + leveque(&(x + Vec3::z() * e), 1.0).z
                - leveque(&(x - Vec3::z() * e), 1.0).z)
                / (2.0 * e);
            assert!(d.abs() < 1e-7, "{d}");
        }
    }

    #[test]
    fn latitude_sampling_has_the_spacing() {
        let pts = latitude_sphere(Vec3::zeros(), 1.0, 0.05);
        let per = 4.0 * PI / pts.len() as Real;
        assert!((per / 0.0025 - 1.0).abs() < 0.05, "{per}");
    }
}
