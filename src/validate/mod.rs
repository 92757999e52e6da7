//! Validation cases of the MLS operators against analytic solutions
//! (paper §10.1 and Fig. 12), used by `codimfx validate` and the tests.
//!
//! * [`sphere_diffusion`]: ∂s/∂t = Δs on the unit sphere, s₀ = cos φ (= z),
//!   exact e^{−2t} cos φ (§10.1, Fig. 17), with spatial and time errors
//!   separated and the rightmost eigenvalue of L estimated;
//! * [`curvature`]: κn = Δx on a sphere, torus, cylinder, circle and helix;
//! * [`butterfly`]: implicit diffusion on a sheet wing with filament rim and
//!   tails (joint operator, Fig. 12): heat drift and the maximum principle.
//!
//! [`droplet`], [`slab`] and [`wedge`] are cases of the coupled solver: a
//! droplet's Young–Laplace jump and l = 2 period, a free slab's edge pull,
//! a box edge's capillary recoil.
//!
//! [`sampling`] builds the point sets, [`time`] the integrators.

pub mod butterfly;
pub mod curvature;
pub mod droplet;
pub mod sampling;
pub mod slab;
pub mod sphere_diffusion;
pub mod time;
pub mod wedge;

use crate::math::Real;
use crate::mls::MlsError;
use thiserror::Error;

/// A liquid case's scene from its YAML text (`name` for error messages),
/// its bodies sampled into the state the step works on, and the step's
/// parameters ([`slab`], [`wedge`]).
pub fn liquid_case(
    yaml: &str,
    name: &str,
) -> Result<
    (
        crate::step::SimState,
        crate::step::StepParams,
        crate::scene::Scene,
    ),
    crate::scene::SceneError,
> {
    let scene = crate::scene::load_str(yaml, std::path::Path::new(name))?;
    let solids = crate::solids::SolidSet::from_scene(&scene.solids);
    let (parts, _) = crate::scene::sample_bodies(&scene, &solids);
    let prm = crate::step::StepParams::from_scene(&scene);
    let grid = crate::grid::MacGrid::new(prm.lo, prm.hi, scene.domain.dx);
    Ok((crate::step::SimState::new(parts, grid, solids), prm, scene))
}

/// Errors of a validation case.
#[derive(Debug, Error)]
pub enum ValidateError {
    /// The MLS operator could not be built.
    #[error(transparent)]
    Mls(#[from] MlsError),
    /// The time integration failed.
    #[error(transparent)]
    Time(#[from] time::TimeError),
    /// A case parameter is out of range.
    #[error("validation parameter `{what}` = {value}: {reason}")]
    Param {
        /// Parameter name.
        what: &'static str,
        /// Its value.
        value: Real,
        /// Why it is rejected.
        reason: &'static str,
    },
}

/// Observed convergence order from errors at successive spacings:
/// log(e₁/e₂) / log(Δ₁/Δ₂) for each consecutive pair.
pub fn observed_orders(spacing: &[Real], err: &[Real]) -> Vec<Real> {
    spacing
        .windows(2)
        .zip(err.windows(2))
        .map(|(d, e)| (e[0] / e[1]).ln() / (d[0] / d[1]).ln())
        .collect()
}

/// Largest absolute value of a slice (0 for an empty one).
pub fn max_abs(v: impl IntoIterator<Item = Real>) -> Real {
    v.into_iter().fold(0.0, |a, b| a.max(b.abs()))
}
