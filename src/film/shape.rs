//! The local shape a film particle's MLS fit gives the reseeding (§9):
//! new particles are lifted onto it (the height of a sheet's fit, the
//! curve of a filament's).

use crate::math::Real;
use crate::mls::operators::{fit_particle, Neighborhoods};
use crate::mls::{Frame, MlsParams};
use crate::reseed::LocalShape;

/// Local geometry of a joint particle for the reseeding, as the Taylor
/// quadratic of its MLS fit (scaled coordinates η = ξ/h): slope and second
/// derivatives at η = 0. Fitted on demand: only particles that propose a new
/// particle need it (a few per step), so the reseeding no longer fits every
/// particle (`docs/benchmarks.md`, "bench films").
pub(crate) struct FittedShape<'a> {
    pub(crate) nb: &'a Neighborhoods,
    pub(crate) frames: &'a [Frame],
    pub(crate) mls: &'a MlsParams,
}

impl FittedShape<'_> {
    fn geo(&self, p: usize) -> Option<([Real; 2], [Real; 3])> {
        fit_particle(self.nb, p, &self.frames[p], self.mls)
            .fit()
            .map(|f| (f.slope, f.second))
    }
}

impl LocalShape for FittedShape<'_> {
    fn height(&self, p: usize, u: Real, v: Real) -> Real {
        let Some((s, d)) = self.geo(p) else {
            return 0.0;
        };
        let h = self.mls.h;
        let (a, b) = (u / h, v / h);
        h * (s[0] * a + s[1] * b + 0.5 * (d[0] * a * a + 2.0 * d[1] * a * b + d[2] * b * b))
    }
    fn curve(&self, p: usize, u: Real) -> (Real, Real) {
        let Some((s, d)) = self.geo(p) else {
            return (0.0, 0.0);
        };
        let h = self.mls.h;
        let a = u / h;
        (
            h * (s[0] * a + 0.5 * d[0] * a * a),
            h * (s[1] * a + 0.5 * d[1] * a * a),
        )
    }
}
