//! The frame vectors a cache frame carries (`docs/cache-format.md`, `nx ny
//! nz`): the sheet normal b³ for C = 1, the filament tangent b¹ for C = 2,
//! zero for the others, from the MLS frames (eqs. 25–29) of the sheet and
//! filament particles with support `h`. Written for every scene: liquid
//! scenes wrote zeros until session 35, so the surfacer's disks of their
//! sheets all faced +z.

use crate::math::{Real, Vec3};
use crate::mls::operators::{par_frames, Neighborhoods};
use crate::mls::MlsParams;
use crate::particles::{Codim, Particles};

/// The frame vectors of `p`, or `None` (zeros in the cache) when no
/// particle is a sheet or a filament.
pub fn frame_vectors(p: &Particles, h: Real) -> Option<Vec<Vec3>> {
    if !p
        .codim
        .iter()
        .any(|c| matches!(c, Codim::Sheet | Codim::Filament))
    {
        return None;
    }
    let mut out = vec![Vec3::zeros(); p.len()];
    let Ok(nb) = Neighborhoods::build(&p.x, &p.codim, h) else {
        return Some(out);
    };
    let frames = par_frames(&nb, &MlsParams::new(h));
    for (j, &i) in nb.store.iter().enumerate() {
        out[i] = if p.codim[i] == Codim::Sheet {
            frames[j].axis(2)
        } else {
            frames[j].axis(0)
        };
    }
    Some(out)
}
