//! The band velocity (`coupling.band: extrapolated`): how much the liquid's
//! velocity changes between a surface layer's
//! particles and the constraint faces J holds to them (§7, eq. 18; see
//! `docs/decisions.md`, "Band velocity").

use super::faces::Constraints;
use super::surface::Surface;
use crate::grid::MacGrid;
use crate::math::{Real, Vec3};

/// c_f = Σ_i J_fi (∇u_a)_i · (x_f − x_i) for each constraint face f of axis
/// a: how much the liquid's velocity changes between the sheet particles
/// and the face ([`super::BandVelocity::Extrapolated`]).
///
/// (∇u)_i is the gradient of v** (the grid velocity before the solve: u^n
/// carried by the particles, so the correction lags one substep) at the
/// point [`BAND_PROBE`] Δx inside the liquid along the particle's normal,
/// past the band of constraint faces: inside the band the grid's velocity
/// is the constraint's own, so the gradient must be read from the free
/// liquid below. All of it counts, not only the normal derivative: J
/// averages particles that sit beside the face along the sheet as well as
/// across it, and on a curved layer the tangential offsets do not cancel.
/// With the normal derivative alone the grid velocity at the layer
/// particles after the solve was 0.977 of their own in an l = 2 flow at
/// R = 4Δx, and the layer, which takes the grid's velocity, lost 2 % of the
/// droplet's kinetic energy every substep; with the whole gradient, 0.999
/// (`docs/decisions.md`, "The band correction takes the whole gradient").
/// The normal is oriented by the liquid level set. A particle whose probe
/// point is not at least Δx/2 inside the liquid (a body thinner than the
/// probe depth), and every free sheet, keeps c = 0 (the sheet's own
/// velocity).
pub fn band_correction(
    grid: &MacGrid,
    surf: &Surface,
    k: &Constraints,
    probes: &BandProbes,
) -> Vec<Real> {
    face_sums(grid, k, |a, xf, i| {
        probes.0[i]
            .as_ref()
            .map(|p| p.grad[a].dot(&(xf - surf.nb.x[i])))
    })
    .into_iter()
    .map(|(c, _)| c)
    .collect()
}

/// The liquid's velocity at each constraint face, extended linearly from
/// the probe points of the sheet particles J joins to it:
/// Σ_i J_fi (u_a(y_i) + (∇u_a)(y_i) · (x_f − y_i)), y_i the probe point
/// [`BAND_PROBE`] Δx below particle i, and the face's own value `grid.u`
/// for the share of J whose particles have no probe (free sheets, thin
/// bodies) or whose probe is less than [`EXTENSION_DEPTH`] Δx deep.
///
/// Inside the band the face velocities that P2G gathers from the volume
/// particles are biased toward the liquid's inside: the particles around
/// such a face all lie on one side of it, so their weighted mean samples
/// the velocity at their centroid, not at the face. In an l = 2 flow at
/// R = 4Δx the constraint faces' P2G values were 16 % below the flow's,
/// while (J u)_f + c_f matched it within 0.1 %; the coupled solve then
/// pulled the surface layer toward the biased faces, and the droplet lost
/// ~1 % of its kinetic energy every substep (`docs/decisions.md`, "A
/// linear velocity at the free surface").
pub fn band_extension(grid: &MacGrid, k: &Constraints, probes: &BandProbes) -> Vec<Real> {
    face_sums(grid, k, |a, xf, i| {
        probes.0[i]
            .as_ref()
            .filter(|p| p.depth >= EXTENSION_DEPTH * grid.dx)
            .map(|p| p.v[a] + p.grad[a].dot(&(xf - p.y)))
    })
    .into_iter()
    .enumerate()
    .map(|(f, (e, w))| {
        let (a, s) = k.faces[f];
        e + (1.0 - w) * grid.u[a][s]
    })
    .collect()
}

/// The grid's velocity and its gradient at a probe point.
struct Probe {
    y: Vec3,
    /// −φ at the probe's cell (m).
    depth: Real,
    v: Vec3,
    grad: [Vec3; 3],
}

/// The probes of a substep's sheet particles, read once from v** before
/// the solve and shared by [`band_extension`] and [`band_correction`]
/// (and by the retries of a failed solve, whose grid they precede).
pub struct BandProbes(Vec<Option<Probe>>);

/// The probe of each sheet particle attached to a volume: the point
/// [`BAND_PROBE`] Δx inside the liquid along its normal (oriented by the
/// level set), if that point is at least Δx/2 inside the liquid.
pub fn band_probes(grid: &MacGrid, surf: &Surface) -> BandProbes {
    BandProbes(probes(grid, surf))
}

fn probes(grid: &MacGrid, surf: &Surface) -> Vec<Option<Probe>> {
    use rayon::prelude::*;
    let d = BAND_PROBE * grid.dx;
    let phi_at = |y: &Vec3| {
        let c = grid.cell_of(y);
        grid.slot(c[0], c[1], c[2])
            .map_or(Real::MAX, |s| grid.phi[s])
    };
    (0..surf.n_sheet())
        .into_par_iter()
        .map(|i| {
            if !surf.attached[i] {
                return None;
            }
            let x = surf.nb.x[i];
            let n: Vec3 = surf.axes[i].column(2).into();
            let (lo, hi) = (phi_at(&(x - d * n)), phi_at(&(x + d * n)));
            let (n, inner) = if lo <= hi { (n, lo) } else { (-n, hi) };
            (inner < -0.5 * grid.dx).then(|| {
                let y = x - d * n;
                let (v, grad) = grid.velocity_gradient(&y);
                Probe {
                    y,
                    depth: -inner,
                    v,
                    grad,
                }
            })
        })
        .collect()
}

/// Per constraint face f of axis a: Σ_i J_fi t(a, x_f, i) over the
/// particles for which `t` is `Some`, and the sum of their J_fi.
fn face_sums(
    grid: &MacGrid,
    k: &Constraints,
    t: impl Fn(usize, Vec3, usize) -> Option<Real> + Sync,
) -> Vec<(Real, Real)> {
    use rayon::prelude::*;
    (0..k.len())
        .into_par_iter()
        .map(|f| {
            let (a, s) = k.faces[f];
            let xf = grid.face_pos(s, a);
            k.row(f)
                .fold((0.0, 0.0), |(sum, w), (i, j)| match t(a, xf, i) {
                    Some(v) => (sum + j * v, w + j),
                    None => (sum, w),
                })
        })
        .collect()
}

/// Depth (× Δx, −φ at the probe's cell) a probe needs for
/// [`band_extension`]. In a jet two cells across (the dripping preset at
/// `--scale 2`) the probe lands near the far side, and the gradient it
/// reads there, between the nozzle's solid and inflow faces, is not the
/// flow's: with every probe at least Δx/2 deep the largest speed grew from
/// 0.12 to 0.59 m/s in 10 frames (spurious sideways flow at the nozzle's
/// mouth), with 1 Δx to 0.28 m/s; with 1.5 Δx no probe of that jet
/// qualifies, and the droplets at R = 3 and 4 Δx keep every probe.
pub const EXTENSION_DEPTH: Real = 1.5;

/// Depth (× Δx) below a sheet particle at which [`band_correction`] reads
/// the liquid's velocity: past the band of constraint faces, which reaches
/// about Δx inside the sheet. 1.5, 2 and 3 gave the same period within
/// 0.5 points (`docs/decisions.md`).
pub const BAND_PROBE: Real = 2.0;
