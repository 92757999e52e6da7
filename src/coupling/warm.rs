//! Warm start of the coupled solve (eq. 24) from the previous substep.
//!
//! Between two substeps of a frame the pressure of the liquid and the
//! impulses on the constraint faces change little: the dripping jet after its
//! splash keeps a hydrostatic and capillary pressure field that moves with the
//! liquid. BiCGSTAB started from q = 0, μ = 0 (with the particles' current
//! velocities for u) spends its first iterations rebuilding that field. The
//! previous substep's solution is kept per grid cell and per constraint face,
//! in physical units (p = q ρΔx/Δt in Pa, λ-rate μ/Δt), and seeds the next
//! solve where the same cell or face is an unknown again. The sparse grid is
//! rebuilt every substep, so cells and faces are keyed by their global cell
//! coordinates. The seeded guess is used only when its residual is smaller
//! than the cold guess's (one product with A each).
//!
//! The simulation clears the state at the start of every frame
//! ([`crate::sim`]), so a run resumed from a frame's cache continues bit for
//! bit: the first substep of a frame always starts cold.
use super::faces::Constraints;
use super::system::{Assembled, Scalars};
use crate::grid::projection::Poisson;
use crate::grid::MacGrid;
use crate::linsolve::Operator;
use crate::math::Real;

/// The previous substep's solution, by global cell (and face axis).
#[derive(Clone, Debug, Default)]
pub struct WarmStart {
    /// (cell key, pressure in Pa), sorted by key.
    cells: Vec<(u64, Real)>,
    /// (cell key × 3 + axis, μ/Δt), sorted by key.
    faces: Vec<(u64, Real)>,
}

/// Global key of slot `s`'s cell.
fn key(grid: &MacGrid, s: usize) -> u64 {
    let c = grid.cell(s);
    ((c[0] as u64 * grid.n[1] as u64) + c[1] as u64) * grid.n[2] as u64 + c[2] as u64
}

fn lookup(list: &[(u64, Real)], k: u64) -> Option<Real> {
    list.binary_search_by_key(&k, |e| e.0)
        .ok()
        .map(|i| list[i].1)
}

impl WarmStart {
    /// Keeps the solution `x` of `sys` (pressure cells of `poisson`, faces of `k`).
    pub fn capture(
        grid: &MacGrid,
        poisson: &Poisson,
        k: &Constraints,
        sys: &Assembled,
        x: &[Real],
        sc: Scalars,
    ) -> WarmStart {
        let to_p = sc.density * sc.dx / sc.dt;
        let mut cells: Vec<(u64, Real)> = poisson
            .cells
            .iter()
            .enumerate()
            .map(|(i, &s)| (key(grid, s), x[sys.qo + i] * to_p))
            .collect();
        cells.sort_unstable_by_key(|e| e.0);
        let mut faces: Vec<(u64, Real)> = (0..sys.nk)
            .map(|f| {
                let (a, s) = k.faces[f];
                (key(grid, s) * 3 + a as u64, x[sys.mo + f] / sc.dt)
            })
            .collect();
        faces.sort_unstable_by_key(|e| e.0);
        WarmStart { cells, faces }
    }

    /// Writes the kept values into the q and μ blocks of `x` where the same
    /// cell or face is an unknown of `sys`; returns how many were seeded.
    pub fn seed(
        &self,
        grid: &MacGrid,
        poisson: &Poisson,
        k: &Constraints,
        sys: &Assembled,
        sc: Scalars,
        x: &mut [Real],
    ) -> usize {
        let to_q = sc.dt / (sc.density * sc.dx);
        let mut n = 0;
        for (i, &s) in poisson.cells.iter().enumerate() {
            if let Some(p) = lookup(&self.cells, key(grid, s)) {
                x[sys.qo + i] = p * to_q;
                n += 1;
            }
        }
        for f in 0..sys.nk {
            let (a, s) = k.faces[f];
            if let Some(m) = lookup(&self.faces, key(grid, s) * 3 + a as u64) {
                x[sys.mo + f] = m * sc.dt;
                n += 1;
            }
        }
        n
    }
}

/// ‖b − A x‖.
pub fn residual_norm(a: &dyn Operator, b: &[Real], x: &[Real]) -> Real {
    let mut ax = vec![0.0; b.len()];
    a.matvec(x, &mut ax);
    b.iter()
        .zip(&ax)
        .map(|(b, y)| (b - y) * (b - y))
        .sum::<Real>()
        .sqrt()
}
