//! Enclosed gas of closed films (bubbles) and wind on films.
//!
//! The paper's bubbles (Figs. 2, 9) do not say how a closed film keeps its
//! volume; without it surface tension alone collapses a soap bubble (the
//! Laplace pressure 4σ/R is unbalanced). Without air, even an open (bursting)
//! spherical film collapses in 1/π of the time its rim needs to retract
//! (collapse time R√(ρτ/2σ) against πR/v_TC with v_TC = √(2σ/ρτ), whatever
//! σ and τ), while in reality the air inside cannot leave that fast.
//! codimfx gives such a film an isothermal gas pocket: p_in V = p_0 V_0,
//! with V the volume the film encloses and p_0 the pressure at which the
//! rest volume V_0 is in balance (p_0 − p_atm = 4σ/R_0 for a sphere of
//! radius R_0, both faces). The excess pressure acts on each sheet particle
//! along its outward normal: f_i = (p_in − p_atm) A_i n_i, with A_i the
//! one-face Voronoi area. The pressure force is explicit, so the ambient
//! pressure p_atm sets the stiffness: with the real 101 kPa a 0.1 % volume
//! error gives 100 Pa against a Laplace pressure of 0.03 Pa and the step
//! blows up; presets use p_atm = 0 (a *soft* gas whose pressure scale is the
//! Laplace pressure itself), which keeps the shape without that stiffness.
//! A rest volume V_0 ≤ 0 is measured on the first step.
//!
//! Volume (divergence theorem): V = ⅓ Σ A_i (x_i − c)·n_i over the film's
//! sheet particles with outward unit normals n_i and any reference point c.
//! PCA normals (b³) have no sign; [`orient_normals`] makes them consistent by
//! a breadth-first walk over the neighbour graph, starting from the particle
//! farthest from the centroid, whose outward direction is certain.
//!
//! Wind: a sheet particle in a wind of velocity w feels the normal drag
//! f = c ρ_air A ((w − u)·n) |(w − u)·n| n, with a user drag coefficient c
//! and A the particle's one-face (Voronoi) area: the wind's dynamic pressure
//! c ρ_air ((w − u)·n)² is a pressure difference across the whole film, like
//! the gas pressure, so a film held still in the wind balances it with its
//! Laplace pressure 4σ/R (two faces); the membrane is pushed along its
//! normal, as in the blowing-bubble scene (Fig. 2). Integrated implicitly
//! in the normal velocity, see [`wind_drag`].

use crate::math::{Real, Vec3};
use std::collections::VecDeque;

/// Flips the given unit normals so that neighbouring ones agree and, in
/// each connected component, the normals point away from the component's
/// centroid c on (count) majority: Σ n_i·(x_i − c) > 0.
///
/// The vote, not one seed particle, fixes the sign: on any spherical cap
/// (a bubble with its hole, whatever its size) the outward normal satisfies
/// n·(x − c) = R − n·(c − O) > 0 at *every* point, because the cap's
/// centroid c lies inside the sphere of centre O. A single seed (the
/// particle farthest from c, at the rim) carries the tilted normal of an open
/// edge and flipped a whole bursting-bubble cap inwards once the hole passed
/// the equator; the gas pressure then pushed the film inwards.
/// `nbrs(i)` lists the film neighbours of particle i (indices into `x`).
/// Returns the number of connected components found.
pub fn orient_normals<'a>(
    x: &[Vec3],
    normals: &mut [Vec3],
    nbrs: impl Fn(usize) -> &'a [u32],
) -> usize {
    let n = x.len();
    if n == 0 {
        return 0;
    }
    let mut done = vec![false; n];
    let mut components = 0;
    let mut queue = VecDeque::new();
    loop {
        // seed: the farthest not-yet-oriented particle from the centroid of the rest
        let rest: Vec<usize> = (0..n).filter(|&i| !done[i]).collect();
        if rest.is_empty() {
            break;
        }
        let c: Vec3 = rest.iter().map(|&i| x[i]).sum::<Vec3>() / rest.len() as Real;
        let seed = *rest
            .iter()
            .max_by(|&&a, &&b| {
                (x[a] - c)
                    .norm_squared()
                    .partial_cmp(&(x[b] - c).norm_squared())
                    .unwrap()
                    .then(b.cmp(&a))
            })
            .unwrap();
        if normals[seed].dot(&(x[seed] - c)) < 0.0 {
            normals[seed] = -normals[seed];
        }
        done[seed] = true;
        queue.push_back(seed);
        components += 1;
        let mut members = vec![seed];
        while let Some(i) = queue.pop_front() {
            for &j in nbrs(i) {
                let j = j as usize;
                if !done[j] {
                    if normals[j].dot(&normals[i]) < 0.0 {
                        normals[j] = -normals[j];
                    }
                    done[j] = true;
                    queue.push_back(j);
                    members.push(j);
                }
            }
        }
        // majority vote of the component about its own centroid
        let cc: Vec3 = members.iter().map(|&i| x[i]).sum::<Vec3>() / members.len() as Real;
        let vote: Real = members
            .iter()
            .map(|&i| normals[i].dot(&(x[i] - cc)).signum())
            .sum();
        if vote < 0.0 {
            for &i in &members {
                normals[i] = -normals[i];
            }
        }
    }
    components
}

/// Enclosed volume ⅓ Σ A_i (x_i − c)·n_i with outward normals.
pub fn enclosed_volume(x: &[Vec3], normals: &[Vec3], area: &[Real]) -> Real {
    if x.is_empty() {
        return 0.0;
    }
    let c: Vec3 = x.iter().sum::<Vec3>() / x.len() as Real;
    x.iter()
        .zip(normals)
        .zip(area)
        .map(|((p, n), a)| a * (p - c).dot(n))
        .sum::<Real>()
        / 3.0
}

/// Least-squares sphere through oriented surface samples: minimises
/// Σ a_i |x_i − c − R n_i|² over the centre c and radius R (a 4×4 linear
/// system). Unlike the divergence-theorem volume it does not change when a
/// hole opens in the film, so it measures the *gas* volume of an open
/// (bursting) bubble as (4/3)πR³. Returns `None` for degenerate input.
pub fn fit_sphere(x: &[Vec3], normals: &[Vec3], area: &[Real]) -> Option<(Vec3, Real)> {
    // unknowns (c, R): rows [I | n_i] weighted by a_i
    let mut m = nalgebra::Matrix4::<Real>::zeros();
    let mut b = nalgebra::Vector4::<Real>::zeros();
    for ((p, n), a) in x.iter().zip(normals).zip(area) {
        let row = [
            nalgebra::Vector4::new(1.0, 0.0, 0.0, n.x),
            nalgebra::Vector4::new(0.0, 1.0, 0.0, n.y),
            nalgebra::Vector4::new(0.0, 0.0, 1.0, n.z),
        ];
        for (k, r) in row.iter().enumerate() {
            m += r * r.transpose() * *a;
            b += r * (p[k] * a);
        }
    }
    let sol = m.lu().solve(&b)?;
    let r = sol[3];
    (r.is_finite() && r > 0.0).then(|| (Vec3::new(sol[0], sol[1], sol[2]), r))
}

/// An isothermal gas pocket enclosed by a film.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct GasPocket {
    /// Rest volume V_0 (m³).
    pub v0: Real,
    /// Excess pressure at the rest volume, p_0 − p_atm (Pa).
    pub dp0: Real,
    /// Ambient pressure p_atm (Pa).
    pub p_atm: Real,
}

impl GasPocket {
    /// A pocket in balance with a spherical film of radius `r0` and tension
    /// `sigma` (two faces: Δp = 4σ/R), at ambient pressure `p_atm`.
    pub fn balanced_sphere(r0: Real, sigma: Real, p_atm: Real) -> GasPocket {
        GasPocket {
            v0: 4.0 / 3.0 * std::f64::consts::PI * r0.powi(3),
            dp0: 4.0 * sigma / r0,
            p_atm,
        }
    }

    /// Excess pressure p_in − p_atm at volume `v` (isothermal: p V = const).
    pub fn excess_pressure(&self, v: Real) -> Real {
        if v <= 0.0 {
            return self.dp0;
        }
        (self.p_atm + self.dp0) * self.v0 / v - self.p_atm
    }
}

/// Pressure forces (N) on the film particles: excess pressure × area along the outward normal.
pub fn pressure_forces(normals: &[Vec3], area: &[Real], excess_pressure: Real) -> Vec<Vec3> {
    normals
        .iter()
        .zip(area)
        .map(|(n, a)| n * (excess_pressure * a))
        .collect()
}

/// Normal wind drag on a film particle (N), explicit; see the module doc.
pub fn wind_force(
    wind: &Vec3,
    u: &Vec3,
    normal: &Vec3,
    area: Real,
    rho_air: Real,
    drag: Real,
) -> Vec3 {
    // the split of [`wind_drag`] evaluated at the current velocity
    let (d, f) = wind_drag(wind, u, normal, area, rho_air, drag);
    f - u * d
}

/// The wind drag of [`wind_force`] split for an implicit step: a drag
/// coefficient d = c ρ_air A |r| (kg/s, r = (w − u)·n at the start of the
/// step) for the system's diagonal, and the force d ((w·n) n + u_t) to add to
/// the explicit forces, u_t the tangential part of u. The step then applies
/// d ((w − u^{n+1})·n) n + d (u_t − u_t^{n+1}): the normal drag at the new
/// velocity (linearised about r) and no net tangential drag at steady state.
/// An explicit drag is unstable for a soap film: kΔt/m = c ρ_air |r| Δt/(ρτ)
/// ≈ 8 at 1.5 m/s, Δt = 5 ms, τ = 1 µm (the blowing-bubble film came apart in
/// its first frame); and a backward-Euler force computed before the solve
/// (f = k r/(1 + kΔt/m)) is wrong whenever tension holds the film (1/7 of the
/// drag on a film at rest in the wind).
pub fn wind_drag(
    wind: &Vec3,
    u: &Vec3,
    normal: &Vec3,
    area: Real,
    rho_air: Real,
    drag: Real,
) -> (Real, Vec3) {
    let rel = (wind - u).dot(normal);
    let d = drag * rho_air * area * rel.abs();
    let ut = u - normal * u.dot(normal);
    (d, (normal * wind.dot(normal) + ut) * d)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::neighbors::neighbor_lists;

    fn golden_sphere(n: usize, r: Real) -> Vec<Vec3> {
        let ga = std::f64::consts::PI * (3.0 - (5.0 as Real).sqrt());
        (0..n)
            .map(|i| {
                let z = 1.0 - 2.0 * (i as Real + 0.5) / n as Real;
                let rho = (1.0 - z * z).sqrt();
                let t = ga * i as Real;
                Vec3::new(r * rho * t.cos(), r * rho * t.sin(), r * z) + Vec3::new(0.3, -0.1, 2.0)
            })
            .collect()
    }

    #[test]
    fn cap_smaller_than_a_hemisphere_is_oriented_outwards_despite_a_bad_rim_normal() {
        // the bottom cap of a bursting bubble once the hole passed the equator
        let (n, r) = (4000, 0.05);
        let c = Vec3::new(0.3, -0.1, 2.0);
        let x: Vec<Vec3> = golden_sphere(n, r)
            .into_iter()
            .filter(|p| (p - c).z < -(1.2 as Real).cos() * r)
            .collect();
        let m = x.len();
        let outward: Vec<Vec3> = x.iter().map(|p| (p - c).normalize()).collect();
        let mut normals: Vec<Vec3> = outward
            .iter()
            .enumerate()
            .map(|(i, nn)| nn * if i % 3 == 0 { -1.0 } else { 1.0 })
            .collect();
        // the particle farthest from the cap's centroid (a rim particle) gets a
        // tilted normal: away from the centroid, yet against the true normal
        let cc: Vec3 = x.iter().sum::<Vec3>() / m as Real;
        let seed = (0..m)
            .max_by(|&a, &b| {
                (x[a] - cc)
                    .norm_squared()
                    .partial_cmp(&(x[b] - cc).norm_squared())
                    .unwrap()
                    .then(b.cmp(&a))
            })
            .unwrap();
        let d = (x[seed] - cc).normalize();
        let cphi = d.dot(&outward[seed]);
        assert!(cphi > 0.0 && cphi < 1.0);
        let k = 0.5 * (cphi + 1.0 / cphi);
        normals[seed] = (d - outward[seed] * k).normalize();
        assert!(normals[seed].dot(&d) > 0.0 && normals[seed].dot(&outward[seed]) < 0.0);
        let nl = neighbor_lists(
            &x,
            3.0 * r * (4.0 * std::f64::consts::PI / n as Real).sqrt(),
        );
        assert_eq!(orient_normals(&x, &mut normals, |i| nl.of(i)), 1);
        let wrong = (0..m)
            .filter(|&i| i != seed && normals[i].dot(&outward[i]) < 0.0)
            .count();
        assert_eq!(wrong, 0, "{wrong} of {m} normals point inwards");
        // and the sphere fit through the oriented cap finds the bubble
        let area = vec![1.0; m];
        let (fc, fr) = fit_sphere(&x, &normals, &area).unwrap();
        assert!((fr / r - 1.0).abs() < 1e-3 && (fc - c).norm() < 1e-3 * r);
    }

    #[test]
    fn sphere_normals_oriented_and_volume_exact_to_sampling() {
        let (n, r) = (4000, 0.05);
        let x = golden_sphere(n, r);
        let c = Vec3::new(0.3, -0.1, 2.0);
        // unsigned normals with random signs
        let mut normals: Vec<Vec3> = x
            .iter()
            .enumerate()
            .map(|(i, p)| (p - c).normalize() * if i % 3 == 0 { -1.0 } else { 1.0 })
            .collect();
        let nl = neighbor_lists(
            &x,
            3.0 * r * (4.0 * std::f64::consts::PI / n as Real).sqrt(),
        );
        assert_eq!(orient_normals(&x, &mut normals, |i| nl.of(i)), 1);
        assert!(x.iter().zip(&normals).all(|(p, nn)| (p - c).dot(nn) > 0.0));
        let area = vec![4.0 * std::f64::consts::PI * r * r / n as Real; n];
        let v = enclosed_volume(&x, &normals, &area);
        let exact = 4.0 / 3.0 * std::f64::consts::PI * r.powi(3);
        assert!((v - exact).abs() < 1e-3 * exact, "{v} vs {exact}");
    }

    #[test]
    fn sphere_fit_ignores_a_hole() {
        let (n, r) = (4000, 0.05);
        let c = Vec3::new(0.3, -0.1, 2.0);
        let all = golden_sphere(n, r);
        // open cap: drop the top 30 % of the sphere
        let x: Vec<Vec3> = all.into_iter().filter(|p| p.z - c.z < 0.4 * r).collect();
        let normals: Vec<Vec3> = x.iter().map(|p| (p - c).normalize()).collect();
        let area = vec![1.0; x.len()];
        let (cf, rf) = fit_sphere(&x, &normals, &area).unwrap();
        assert!(
            (rf - r).abs() < 1e-12 && (cf - c).norm() < 1e-12,
            "{rf} {cf}"
        );
        // the divergence-theorem volume of the open cap is far from the sphere's
        let v = enclosed_volume(&x, &normals, &area);
        assert!(
            v < 0.9 * 4.0 / 3.0 * std::f64::consts::PI * r.powi(3) * x.len() as Real / n as Real
                * 1e9
        );
    }

    #[test]
    fn isothermal_gas_balances_and_resists() {
        let g = GasPocket::balanced_sphere(0.05, 0.01, 101_325.0);
        assert!((g.excess_pressure(g.v0) - 0.8).abs() < 1e-9);
        // compressed to half the volume: pressure roughly doubles (absolute)
        let dp = g.excess_pressure(0.5 * g.v0);
        assert!((dp + g.p_atm - 2.0 * (g.p_atm + 0.8)).abs() < 1e-6);
        let f = pressure_forces(&[Vec3::x()], &[2.0], 3.0);
        assert_eq!(f[0], Vec3::new(6.0, 0.0, 0.0));
    }

    #[test]
    fn wind_pushes_along_the_normal_only() {
        let f = wind_force(
            &Vec3::new(1.0, 2.0, 0.0),
            &Vec3::zeros(),
            &Vec3::x(),
            0.5,
            1.2,
            1.0,
        );
        assert!((f - Vec3::new(0.6, 0.0, 0.0)).norm() < 1e-15);
        let f = wind_force(
            &Vec3::new(-1.0, 0.0, 0.0),
            &Vec3::zeros(),
            &Vec3::x(),
            0.5,
            1.2,
            1.0,
        );
        assert!(f.x < 0.0);
    }

    #[test]
    fn wind_drag_split_gives_the_drag_at_steady_state() {
        let w = Vec3::new(1.0, 0.5, 0.0);
        let u = Vec3::new(0.2, 0.3, 0.1);
        let n = Vec3::x();
        let (d, f) = wind_drag(&w, &u, &n, 0.5, 1.2, 1.0);
        // at u^{n+1} = u the split force equals the explicit drag
        let total = f - u * d;
        let explicit = wind_force(&w, &u, &n, 0.5, 1.2, 1.0);
        assert!((total - explicit).norm() < 1e-15, "{total} {explicit}");
        // implicit: one particle of mass m alone, any Δt, never passes w·n
        let (m, dt) = (1e-3, 10.0);
        let un = (m * u.x + dt * f.x) / (m + dt * d);
        assert!(un > u.x && un < w.x);
    }
}
