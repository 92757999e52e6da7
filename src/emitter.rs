//! Cylindrical jets (paper Appendix F).
//!
//! A jet emits disk-shaped layers of particles at its nozzle: each layer is
//! an *equidistributed circle pattern* — concentric circles at radii R,
//! R − s, R − 2s, … (s the particle spacing), the circle of radius r holding
//! round(2πr/s) evenly spaced particles (one particle at the centre when the
//! innermost radius falls below s/2). The outline circle is made of sheet
//! particles (C = 1), the inside of volume particles (C = 0), so the jet's
//! surface layer is a sheet from the start (Appendix F). Successive layers
//! are rotated by half an angular step so the surface has no straight
//! grooves.
//!
//! Every circle starts at angle 0, and neighbouring circles differ by about
//! 2π ≈ 6 particles, so the pattern lines up in quasi-hexagonal spokes: a
//! six-fold seed for any instability of what the jet feeds (the fluid
//! polygon's rim, docs/decisions.md): the particle of circle k at angle θ
//! sits off the nearest one of circle k + 1 by frac(θ m / 2π) of a step,
//! m = n_k − n_{k+1} ≈ 6, so the alignment of neighbouring circles repeats six
//! times around. With [`Jet::stagger`] circle k is rotated further by
//! frac(k (k + 1)/2 · φ) of its angular step (φ the golden ratio's fractional
//! part). Circles k and k + 1 then differ by frac((k + 1) φ), a different
//! rotation of the six-fold alignment for every pair of circles, so the
//! pairs' alignments no longer add up into spokes. (A constant frac(k φ)
//! would rotate every pair alike and keep the spokes.)
//!
//! Emission rate from speed: a layer leaves the nozzle every s / v seconds.
//! A layer emitted at time t_e and created inside a substep that ends at t
//! is placed at nozzle + d v (t − t_e), so emission is exact in time and
//! independent of the substep size. All particles of a jet have the same
//! mass ρ s³ and velocity v d.

use crate::math::{Real, Vec3};
use crate::particles::{Codim, Particles};

/// A cylindrical jet.
#[derive(Clone, Debug, PartialEq)]
pub struct Jet {
    /// Centre of the nozzle opening (m).
    pub origin: Vec3,
    /// Direction of flow (unit vector).
    pub direction: Vec3,
    /// Jet radius R (m).
    pub radius: Real,
    /// Speed v (m/s), > 0.
    pub speed: Real,
    /// Particle spacing s (m).
    pub spacing: Real,
    /// Start time (s).
    pub start: Real,
    /// Stop time (s); emission ends here.
    pub stop: Real,
    /// Liquid density ρ (kg/m³).
    pub density: Real,
    /// Rotate the circles of a layer against each other (no spokes).
    pub stagger: bool,
}

/// Unit vectors e1, e2 completing `d` to an orthonormal basis.
fn basis(d: &Vec3) -> (Vec3, Vec3) {
    let a = if d.x.abs() < 0.9 {
        Vec3::x()
    } else {
        Vec3::y()
    };
    let e1 = d.cross(&a).normalize();
    let e2 = d.cross(&e1);
    (e1, e2)
}

/// One equidistributed circle pattern of radius `r` and spacing `s`, in the
/// plane (e1, e2): (offset, is_outline) pairs, rotated by `phase` (fraction of
/// the angular step on each circle).
pub fn circle_pattern(r: Real, s: Real, phase: Real) -> Vec<([Real; 2], bool)> {
    circle_pattern_staggered(r, s, phase, false)
}

/// [`circle_pattern`], with circle k (counted from the outline) rotated by a
/// further frac(k (k + 1)/2 · φ) of its angular step when `stagger` is set.
pub fn circle_pattern_staggered(
    r: Real,
    s: Real,
    phase: Real,
    stagger: bool,
) -> Vec<([Real; 2], bool)> {
    const PHI: Real = 0.618_033_988_749_894_8;
    let mut out = Vec::new();
    let mut k = 0;
    loop {
        let rk = r - k as Real * s;
        if rk < 0.5 * s {
            if rk > -0.5 * s + 1e-12
                && out
                    .iter()
                    .all(|(p, _): &([Real; 2], bool)| p[0].hypot(p[1]) > 0.5 * s)
            {
                out.push(([0.0, 0.0], k == 0));
            }
            break;
        }
        let n = ((2.0 * std::f64::consts::PI * rk / s).round() as usize).max(3);
        let ph = if stagger {
            phase + ((k * (k + 1) / 2) as Real * PHI).fract()
        } else {
            phase
        };
        for i in 0..n {
            let t = 2.0 * std::f64::consts::PI * (i as Real + ph) / n as Real;
            out.push(([rk * t.cos(), rk * t.sin()], k == 0));
        }
        k += 1;
    }
    out
}

impl Jet {
    /// Time between two layers (s).
    pub fn period(&self) -> Real {
        self.spacing / self.speed
    }

    /// Number of layers emitted by time `t` (layer k leaves at start + k·period).
    pub fn layers_by(&self, t: Real) -> u64 {
        if t <= self.start {
            return 0;
        }
        let end = t.min(self.stop);
        if end <= self.start {
            return 0;
        }
        // layers at start, start + T, … strictly before `end`
        ((end - self.start) / self.period()).ceil().max(0.0) as u64
    }

    /// Emits the layers whose emission time lies in [t0, t1) into `parts`,
    /// advanced to t1. Returns the number of particles added.
    pub fn emit(&self, t0: Real, t1: Real, parts: &mut Particles) -> usize {
        self.emit_placed(t0, t1, t1, parts)
    }

    /// Emits the layers whose emission time t_e lies in [t0, t1), each placed
    /// where free flight puts it at time `t_at`: nozzle + d v (t_at − t_e).
    /// With `t_at = t0` the layers are created before a substep [t0, t1) at
    /// positions up to v (t1 − t0) behind the nozzle, and the substep's
    /// advection carries them to where [`Jet::emit`] would put them at t1
    /// (the frame loop of `sim` does this, so new particles take part in the
    /// substep's grid solve). Which layers are emitted depends only on t0 and
    /// t1 ([`Jet::layers_by`]), so a resumed run emits the same particles.
    pub fn emit_placed(&self, t0: Real, t1: Real, t_at: Real, parts: &mut Particles) -> usize {
        let (k0, k1) = (self.layers_by(t0), self.layers_by(t1));
        let d = self.direction.normalize();
        let (e1, e2) = basis(&d);
        let mass = self.density * self.spacing.powi(3);
        let v = d * self.speed;
        let mut added = 0;
        for k in k0..k1 {
            let te = self.start + k as Real * self.period();
            let centre = self.origin + v * (t_at - te);
            let phase = if k % 2 == 0 { 0.0 } else { 0.5 };
            for (o, outline) in
                circle_pattern_staggered(self.radius, self.spacing, phase, self.stagger)
            {
                let x = centre + e1 * o[0] + e2 * o[1];
                let c = if outline { Codim::Sheet } else { Codim::Volume };
                parts.push(x, v, mass, 0.5 * self.spacing, c);
                added += 1;
            }
        }
        added
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn jet() -> Jet {
        Jet {
            origin: Vec3::new(0.0, 0.1, 0.0),
            direction: Vec3::new(0.0, -1.0, 0.0),
            radius: 0.008,
            speed: 0.07,
            spacing: 0.008 / 3.0,
            start: 0.0,
            stop: 1.0,
            density: 1000.0,
            stagger: false,
        }
    }

    /// Six-fold spokes of a pattern: every particle of circle k gets the
    /// alignment a = cos(2π δ), δ its angular offset from the nearest particle
    /// of circle k + 1 in that circle's steps, and the result is
    /// |Σ a exp(6 i θ)| / N (1 for perfect six-fold spokes, ~N^(-1/2) for
    /// none).
    fn spokes(p: &[([Real; 2], bool)], s: Real) -> Real {
        use std::f64::consts::PI;
        let ring = |q: &[Real; 2]| (q[0].hypot(q[1]) / s).round() as i64;
        let (mut c, mut sn, mut n) = (0.0, 0.0, 0.0);
        for (q, _) in p {
            let rk = ring(q);
            let inner: Vec<Real> = p
                .iter()
                .filter(|(o, _)| ring(o) == rk - 1)
                .map(|(o, _)| o[1].atan2(o[0]))
                .collect();
            if rk < 2 || inner.len() < 3 {
                continue;
            }
            let t = q[1].atan2(q[0]);
            let step = 2.0 * PI / inner.len() as Real;
            let d = inner
                .iter()
                .map(|u| {
                    let x = (t - u) / step;
                    x - x.round()
                })
                .fold(1.0, |a: Real, x| if x.abs() < a.abs() { x } else { a });
            let a = (2.0 * PI * d).cos();
            c += a * (6.0 * t).cos();
            sn += a * (6.0 * t).sin();
            n += 1.0;
        }
        c.hypot(sn) / n
    }

    #[test]
    fn staggered_circles_leave_no_spokes() {
        // the polygon jets: R = 7 mm, s = Δx/3 at Δx = 1/480 m
        let (r, s) = (0.007, 1.0 / 1440.0);
        let aligned = circle_pattern(r, s, 0.0);
        let staggered = circle_pattern_staggered(r, s, 0.0, true);
        assert_eq!(aligned.len(), staggered.len());
        let (a, b) = (spokes(&aligned, s), spokes(&staggered, s));
        // measured: aligned 0.388, staggered 0.081 (noise level: ~320
        // particles, N^(-1/2) = 0.056)
        assert!(
            a > 0.3 && b < 0.12,
            "six-fold spokes: aligned {a}, staggered {b}"
        );
        for (i, a) in staggered.iter().enumerate() {
            for b in &staggered[i + 1..] {
                let d = (a.0[0] - b.0[0]).hypot(a.0[1] - b.0[1]);
                assert!(d > 0.6 * s, "{d}");
            }
        }
    }

    #[test]
    fn pattern_is_equidistributed_with_a_sheet_outline() {
        let (r, s) = (0.008, 0.008 / 3.0);
        let p = circle_pattern(r, s, 0.0);
        let outline: Vec<_> = p.iter().filter(|(_, o)| *o).collect();
        assert_eq!(
            outline.len(),
            (2.0 * std::f64::consts::PI * 3.0).round() as usize
        );
        assert!(outline
            .iter()
            .all(|(q, _)| (q[0].hypot(q[1]) - r).abs() < 1e-15));
        // area per particle ≈ s² (disk of radius R + s/2 covered)
        let area = std::f64::consts::PI * (r + 0.5 * s).powi(2);
        let per = area / p.len() as Real;
        assert!((per / (s * s) - 1.0).abs() < 0.1, "{}", per / (s * s));
        // nearest-neighbour distance never much below s
        for (i, a) in p.iter().enumerate() {
            for b in &p[i + 1..] {
                let d = (a.0[0] - b.0[0]).hypot(a.0[1] - b.0[1]);
                assert!(d > 0.6 * s, "{d}");
            }
        }
    }

    #[test]
    fn emission_rate_matches_the_flux_and_is_substep_independent() {
        let j = jet();
        let mut one = Particles::new();
        j.emit(0.0, 0.5, &mut one);
        let mut many = Particles::new();
        let n = 37;
        for i in 0..n {
            // what the advection stage does to particles already emitted
            let dt = 0.5 / n as Real;
            for k in 0..many.len() {
                let v = many.v[k];
                many.x[k] += v * dt;
            }
            j.emit(
                0.5 * i as Real / n as Real,
                0.5 * (i + 1) as Real / n as Real,
                &mut many,
            );
        }
        assert_eq!(one.len(), many.len());
        for (a, b) in one.x.iter().zip(&many.x) {
            assert!((a - b).norm() < 1e-12);
        }
        // mass flux ρ v π R² (the pattern's cross-section covers (R + s/2)²)
        let flux = 1000.0 * 0.07 * std::f64::consts::PI * (0.008f64 + 0.5 * j.spacing).powi(2);
        let m = one.total_mass() / 0.5;
        assert!((m / flux - 1.0).abs() < 0.1, "{}", m / flux);
        // everything moves at the jet velocity and lies within the jet radius
        assert!(one
            .v
            .iter()
            .all(|v| (v - Vec3::new(0.0, -0.07, 0.0)).norm() < 1e-15));
        assert!(one
            .x
            .iter()
            .all(|x| x.x.hypot(x.z) <= 0.008 + 1e-12 && x.y <= 0.1));
        assert!(one.codim.contains(&Codim::Sheet) && one.codim.contains(&Codim::Volume));
    }

    #[test]
    fn emission_before_the_substep_lands_where_emission_after_it_does() {
        let j = jet();
        let (t0, t1) = (0.1, 0.2);
        let mut after = Particles::new();
        let n = j.emit(t0, t1, &mut after);
        let mut before = Particles::new();
        assert_eq!(j.emit_placed(t0, t1, t0, &mut before), n);
        assert!(n > 0 && n.is_multiple_of(circle_pattern(j.radius, j.spacing, 0.0).len()));
        for k in 0..n {
            // free flight over the substep
            let x = before.x[k] + before.v[k] * (t1 - t0);
            assert!((x - after.x[k]).norm() < 1e-15);
            // placed no further than one substep of flight behind the nozzle
            let behind = (before.x[k] - j.origin).dot(&j.direction);
            assert!(behind <= 1e-15 && behind >= -j.speed * (t1 - t0) - 1e-15);
        }
        // layer count from time alone: ⌈(t − start)/T⌉ layers by t
        assert_eq!(j.layers_by(0.1), (0.1 / j.period()).ceil() as u64);
        assert_eq!(j.layers_by(0.0), 0);
        assert_eq!(j.layers_by(1e-12), 1);
    }

    #[test]
    fn no_emission_outside_the_window() {
        let mut j = jet();
        j.start = 1.0;
        j.stop = 2.0;
        let mut p = Particles::new();
        assert_eq!(j.emit(0.0, 1.0, &mut p), 0);
        assert!(j.emit(1.0, 1.5, &mut p) > 0);
        let n = p.len();
        assert_eq!(j.emit(2.0, 3.0, &mut p), 0);
        assert_eq!(p.len(), n);
    }
}
