//! The outline of a horizontal sheet seen from above, and its Fourier modes
//! in the yaw angle: how many corners a fluid polygon has (§10.2, Fig. 16).
//!
//! The sheet's and rim's particles (codimension 1 and 2) are binned by their
//! yaw φ about a vertical (y) axis through `centre`; the outline radius of a
//! bin is the largest horizontal distance from the axis in it (an empty bin
//! takes the mean of the others). The amplitude of mode k is
//! |2/N Σ_b R_b e^{−ikφ_b}|, so a radius R̄ + A cos(kφ) has amplitude A in
//! mode k. Its crest, the yaw φ_k of a maximum of A cos(k(φ − φ_k)), is
//! arg(Σ_b R_b e^{ikφ_b})/k, reported in [0°, 360°/k): where the corners
//! (k ≥ 3) or the long axis (k = 2) point, φ measured from +x towards +z.
//! Points (droplets) and volume particles are left out: droplets flung from
//! the corners are not the outline.

use crate::math::{Real, Vec3};
use crate::particles::{Codim, Particles};

/// Outline radius and Fourier amplitudes of one frame.
#[derive(Clone, Debug, PartialEq)]
pub struct OutlineModes {
    /// Mean outline radius (m).
    pub mean_radius: Real,
    /// `amplitude[k]`: amplitude of mode k (m), for k = 0..=kmax (index 0 is 0).
    pub amplitude: Vec<Real>,
    /// `crest[k]`: yaw of one crest of mode k (degrees, in [0, 360/k); index 0 is 0).
    pub crest: Vec<Real>,
    /// Sheet and filament particles measured.
    pub particles: usize,
}

impl OutlineModes {
    /// The modes 2..=kmax sorted by amplitude, strongest first.
    pub fn strongest(&self) -> Vec<(usize, Real)> {
        let mut v: Vec<(usize, Real)> = (2..self.amplitude.len())
            .map(|k| (k, self.amplitude[k]))
            .collect();
        v.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
        v
    }
}

/// Measures the outline of the sheet and filament particles of `parts` in
/// `bins` yaw bins about the vertical through `centre`, with modes up to
/// `kmax` (at most (bins − 1)/2, which the bins resolve). `None` when there
/// are no sheet or filament particles, or no bins.
pub fn outline_modes(
    parts: &Particles,
    centre: &Vec3,
    bins: usize,
    kmax: usize,
) -> Option<OutlineModes> {
    if bins == 0 {
        return None;
    }
    // N bins resolve modes up to (N − 1)/2
    let kmax = kmax.min((bins - 1) / 2);
    let mut r = vec![Real::NAN; bins];
    let mut n = 0;
    for i in 0..parts.len() {
        if !matches!(parts.codim[i], Codim::Sheet | Codim::Filament) {
            continue;
        }
        let d = parts.x[i] - centre;
        let phi = d.z.atan2(d.x); // yaw about y, as `tension::sawtooth`
        let b = (((phi + std::f64::consts::PI) / std::f64::consts::TAU * bins as Real) as usize)
            .min(bins - 1);
        let rad = d.x.hypot(d.z);
        if r[b].is_nan() || rad > r[b] {
            r[b] = rad;
        }
        n += 1;
    }
    if n == 0 {
        return None;
    }
    let filled: Vec<Real> = r.iter().copied().filter(|v| !v.is_nan()).collect();
    let mean_filled = filled.iter().sum::<Real>() / filled.len() as Real;
    for v in r.iter_mut() {
        if v.is_nan() {
            *v = mean_filled;
        }
    }
    let mean = r.iter().sum::<Real>() / bins as Real;
    let (amplitude, crest) = (0..=kmax)
        .map(|k| {
            if k == 0 {
                return (0.0, 0.0);
            }
            let (mut c, mut s) = (0.0, 0.0);
            for (b, v) in r.iter().enumerate() {
                let phi = -std::f64::consts::PI
                    + (b as Real + 0.5) * std::f64::consts::TAU / bins as Real;
                c += (v - mean) * (k as Real * phi).cos();
                s += (v - mean) * (k as Real * phi).sin();
            }
            // Σ (R − R̄) cos(k(φ − φ_k)) is largest at φ_k = atan2(s, c)/k
            let period = 360.0 / k as Real;
            let crest = (s.atan2(c).to_degrees() / k as Real).rem_euclid(period);
            (2.0 * c.hypot(s) / bins as Real, crest)
        })
        .unzip();
    Some(OutlineModes {
        mean_radius: mean,
        amplitude,
        crest,
        particles: n,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Sheet particles filling the star-shaped region r ≤ R(φ) in the plane
    /// y = 0 on a square lattice of spacing s.
    fn sheet(radius: impl Fn(Real) -> Real, rmax: Real, s: Real) -> Particles {
        let mut p = Particles::new();
        let n = (rmax / s).ceil() as i32;
        for i in -n..=n {
            for j in -n..=n {
                let (x, z) = (i as Real * s, j as Real * s);
                if x.hypot(z) <= radius(z.atan2(x)) {
                    p.push(
                        Vec3::new(x, 0.0, z),
                        Vec3::zeros(),
                        1.0,
                        0.1 * s,
                        Codim::Sheet,
                    );
                }
            }
        }
        p
    }

    #[test]
    fn a_regular_hexagon_has_mode_6_and_a_disc_none() {
        let c = Vec3::zeros();
        let s = 5e-4;
        // a regular hexagon of circumradius R: r(φ) = R cos(π/6) / cos(φ mod π/3 − π/6)
        let big = 0.1;
        let hex = |phi: Real| {
            let t = (phi + 10.0 * std::f64::consts::PI).rem_euclid(std::f64::consts::PI / 3.0);
            big * (std::f64::consts::PI / 6.0).cos() / (t - std::f64::consts::PI / 6.0).cos()
        };
        let m = outline_modes(&sheet(hex, big, s), &c, 72, 12).unwrap();
        assert_eq!(m.strongest()[0].0, 6, "{:?}", m.strongest());
        // against the exact outline's largest radius in each bin (fine
        // sampling): mean and mode 6 within the lattice spacing
        let w = std::f64::consts::TAU / 72.0;
        let exact: Vec<(Real, Real)> = (0..72)
            .map(|b| {
                let lo = -std::f64::consts::PI + b as Real * w;
                let r = (0..=100)
                    .map(|t| hex(lo + w * t as Real / 100.0))
                    .fold(0.0, Real::max);
                (lo + 0.5 * w, r)
            })
            .collect();
        let mean: Real = exact.iter().map(|e| e.1).sum::<Real>() / 72.0;
        let (c6, s6) = exact.iter().fold((0.0, 0.0), |(c, sn), &(p, r)| {
            (
                c + (r - mean) * (6.0 * p).cos(),
                sn + (r - mean) * (6.0 * p).sin(),
            )
        });
        let a6 = 2.0 * c6.hypot(s6) / 72.0;
        assert!(
            (m.mean_radius - mean).abs() < s,
            "{} {}",
            m.mean_radius,
            mean
        );
        assert!((m.amplitude[6] - a6).abs() < s, "{} {a6}", m.amplitude[6]);
        // a disc: every mode below the lattice's sampling error
        let disc = outline_modes(&sheet(|_| big, big, s), &c, 72, 12).unwrap();
        assert!((disc.mean_radius - big).abs() < s, "{}", disc.mean_radius);
        assert!(
            disc.strongest()[0].1 < 0.2 * m.amplitude[6],
            "{:?}",
            disc.strongest()
        );
        // a cosine outline R̄ + A cos 6φ gives A in mode 6
        let a = 0.02;
        let cos6 = outline_modes(
            &sheet(|phi| 0.08 + a * (6.0 * phi).cos(), big, s),
            &c,
            72,
            12,
        )
        .unwrap();
        assert!(
            (cos6.amplitude[6] - a).abs() < 0.05 * a,
            "{}",
            cos6.amplitude[6]
        );
        assert!(outline_modes(&Particles::new(), &c, 72, 12).is_none());
        assert!(outline_modes(&sheet(hex, big, s), &c, 0, 12).is_none());
        let few = outline_modes(&sheet(hex, big, s), &c, 9, 12).unwrap();
        assert_eq!(few.amplitude.len(), 5);
    }

    #[test]
    fn the_crest_gives_where_the_corners_and_the_long_axis_point() {
        let c = Vec3::zeros();
        let (s, big) = (5e-4, 0.1);
        // five corners at 20° + 72°j, and a long axis at 115° (= −65°)
        for (k, at, expect) in [
            (5_usize, 20.0_f64, 20.0),
            (2, 115.0, 115.0),
            (2, -65.0, 115.0),
        ] {
            let r = |phi: Real| 0.08 + 0.01 * (k as Real * (phi - at.to_radians())).cos();
            let m = outline_modes(&sheet(r, big, s), &c, 72, 12).unwrap();
            assert_eq!(m.strongest()[0].0, k, "{:?}", m.strongest());
            let period = 360.0 / k as Real;
            let off = (m.crest[k] - expect).rem_euclid(period);
            let off = off.min(period - off);
            // the bins are 5° wide; the lattice's sampling error shifts the
            // crest by far less than a bin
            assert!(off < 1.0, "k = {k}: crest {} against {expect}", m.crest[k]);
            assert!((0.0..period).contains(&m.crest[k]), "{}", m.crest[k]);
        }
    }
}
