//! Constraint faces and the interpolation J of eq. (18) (paper §7).
//!
//! The paper marks a MAC face as a constraint face when a sheet particle
//! lies in its control volume and interpolates the sheet velocities onto it.
//! Here J is the normalised transpose of the trilinear face stencil: a face
//! f of axis a gets
//!
//! J_{f,i} = w_{fi} / Σ_j w_{fj},   w_{fi} = Π_d (1 − |x_{f,d} − x_{i,d}| / Δx)₊,
//!
//! over the sheet particles whose stencil touches it (|x_f − x_i|_∞ < Δx),
//! so a constant sheet velocity is reproduced exactly and the faces between
//! the particles' cells are constrained too. This support is one cell wider
//! than the paper's control volume: every free-surface face within a cell of
//! the sheet becomes a constraint face, so no pressure leaks through a
//! free-surface face the sheet layer missed (the paper samples particles
//! more densely for the same reason, Appendix F). Only faces that are open
//! (cut-cell weight ≥ [`MIN_OPEN`]), not on the domain walls, and next to at
//! least one liquid cell enter K: the face mass of eq. (19) belongs to the
//! liquid.

use crate::grid::extrapolate::is_wall_face;
use crate::grid::projection::{FaceSides, Poisson};
use crate::grid::{MacGrid, NONE};
use crate::math::{Real, Vec3};
use rayon::prelude::*;

/// Smallest open fraction of a constraint face. A face nearly closed by a
/// cut-cell solid (a jet's sheet layer next to its nozzle's wall) would
/// make a row of size w_f ≪ 1 in eq. (24) and stall ILU(0)-BiCGSTAB; such a
/// face is left to the pressure and the solid's free-slip condition.
pub const MIN_OPEN: Real = 0.1;

/// The constraint faces (rows of K) and J, in (axis, slot) order.
#[derive(Clone, Debug, Default)]
pub struct Constraints {
    /// Axis and slot (lower face of that slot's cell) of each constraint face.
    pub faces: Vec<(usize, usize)>,
    /// Liquid sides and ghost-fluid fraction θ of each face.
    pub sides: Vec<FaceSides>,
    /// Open fraction w_f of each face.
    pub weight: Vec<Real>,
    /// Liquid fraction of each face's control volume: the share of the
    /// face mass ρΔx³w_f that the sheet drags ([`Constraints::set_mass`]);
    /// the ghost-fluid θ until set.
    pub mass: Vec<Real>,
    /// J in compressed rows: `col[ptr[f]..ptr[f+1]]` are sheet particles
    /// (joint index), `val` their weights (each row sums to 1).
    pub ptr: Vec<usize>,
    /// Particle column of each entry.
    pub col: Vec<u32>,
    /// Weight of each entry.
    pub val: Vec<Real>,
    /// Constraint index of face (a, s), or [`NONE`] (one table per axis).
    pub of_face: [Vec<u32>; 3],
    /// Smallest mass fraction a face carries in the solve
    /// ([`super::system::mono_theta`]; `coupling.mass_floor`).
    pub floor: Real,
}

impl Constraints {
    /// Number of constraint faces.
    pub fn len(&self) -> usize {
        self.faces.len()
    }

    /// True when no face is constrained.
    pub fn is_empty(&self) -> bool {
        self.faces.is_empty()
    }

    /// Entries of row f of J: (sheet particle, weight).
    pub fn row(&self, f: usize) -> impl Iterator<Item = (usize, Real)> + '_ {
        (self.ptr[f]..self.ptr[f + 1]).map(|k| (self.col[k] as usize, self.val[k]))
    }

    /// (J u)_f: the sheet velocity component of the face's axis interpolated onto it.
    pub fn interpolate(&self, f: usize, u: &[Vec3]) -> Real {
        let a = self.faces[f].0;
        self.row(f).map(|(i, w)| w * u[i][a]).sum()
    }

    /// Measures each face's liquid fraction from a level set that ends at the
    /// sheet instead of the pressure solve's: ψ = φ + `shift` at the two cell
    /// centres beside the face (φ of `sys`, extended into solids), and
    /// θ_m = 1 (both inside), 0 (both outside) or ψ_in/(ψ_in − ψ_out).
    ///
    /// With `shift` = kΔx − s/2 (k the level-set radius of the volume
    /// particles, s their spacing) ψ's zero crossing sits half a spacing
    /// outside the outermost volume layer, where the sheet layer's own mass
    /// begins: the liquid past the sheet, which the pressure solve needs for
    /// Young–Laplace, no longer joins the sheet's inertia.
    pub fn set_mass(&mut self, g: &MacGrid, sys: &Poisson, shift: Real) {
        let mut m = Vec::new();
        self.masses_into(g, sys, shift, &mut m);
        self.mass = m;
    }

    /// [`Constraints::set_mass`] with the shift moved by δ ∈ [−`range`, `range`]
    /// so that the constraint faces' masses (at least [`Constraints::floor`],
    /// as the solve uses them) and the free faces' ghost-fluid masses add up
    /// to `target` (Σ w θ over every face beside a liquid cell, three axes:
    /// three times the liquid volume in cells); returns δ and whether it
    /// stayed at a bound.
    ///
    /// Why: the pressure's level set and ψ are particle-union level sets on
    /// the grid, and with the floor on the faces past the sheet the grid
    /// carried 3–7 % more mass than the volume particles in the l = 2
    /// droplet (R = 8Δx to 4Δx), inertia that lengthened its period. The sum
    /// falls as δ grows (ψ larger is less liquid), so δ is found by
    /// bisection; it stays at a bound when no δ in range reaches the target.
    /// One global δ serves every body of the scene.
    pub fn set_mass_balanced(
        &mut self,
        g: &MacGrid,
        sys: &Poisson,
        shift: Real,
        target: Real,
        range: Real,
    ) -> (Real, bool) {
        let want = target - free_mass(g, sys, self);
        // the masses at shift + d into `m`, and their sum as the solve uses them
        let sum_at = |d: Real, m: &mut Vec<Real>| -> Real {
            self.masses_into(g, sys, shift + d, m);
            m.iter()
                .zip(&self.weight)
                .map(|(m, w)| m.max(self.floor) * w)
                .sum()
        };
        let mut m = Vec::with_capacity(self.len());
        let found = if sum_at(-range, &mut m) <= want {
            (-range, true)
        } else if sum_at(range, &mut m) >= want {
            (range, true)
        } else {
            let (mut lo, mut hi) = (-range, range);
            for _ in 0..BISECTIONS {
                let mid = 0.5 * (lo + hi);
                if sum_at(mid, &mut m) > want {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            let d = 0.5 * (lo + hi);
            sum_at(d, &mut m);
            (d, false)
        };
        self.mass = m;
        found
    }

    /// θ_m of every constraint face for ψ = φ + `shift`, into `out`.
    fn masses_into(&self, g: &MacGrid, sys: &Poisson, shift: Real, out: &mut Vec<Real>) {
        let psi = |t: Option<usize>| t.map_or(g.dx, |t| sys.phi[t]) + shift;
        self.faces
            .par_iter()
            .map(|&(a, s)| {
                let mut o = [0isize; 3];
                o[a] = -1;
                let (lo, hi) = (psi(g.neighbor(s, o)), psi(Some(s)));
                match (lo < 0.0, hi < 0.0) {
                    (true, true) => 1.0,
                    (false, false) => 0.0,
                    (true, false) => lo / (lo - hi),
                    (false, true) => hi / (hi - lo),
                }
            })
            .collect_into_vec(out);
    }

    /// Constraint index of face (a, s).
    #[inline]
    pub fn index(&self, a: usize, s: usize) -> Option<usize> {
        let i = self.of_face[a][s];
        (i != NONE).then_some(i as usize)
    }
}

/// Bisection steps of [`Constraints::set_mass_balanced`] (δ to 2⁻²⁴ of its range).
const BISECTIONS: usize = 24;

/// Σ w θ (ghost fluid) over the faces beside a liquid cell that are not in
/// `k`, summed in cell order.
fn free_mass(g: &MacGrid, sys: &Poisson, k: &Constraints) -> Real {
    use crate::grid::projection::unit;
    sys.cells
        .iter()
        .map(|&c| {
            let mut m = 0.0;
            for a in 0..3 {
                let mut one = |s: usize| {
                    if k.index(a, s).is_none() {
                        if let Some(sd) = sys.face(g, a, s) {
                            m += g.weight[a][s] * sd.theta;
                        }
                    }
                };
                one(c);
                if let Some(n) = g.neighbor(c, unit(a, 1)) {
                    if sys.unknown(n).is_none() {
                        one(n);
                    }
                }
            }
            m
        })
        .sum()
}

/// Finds the constraint faces of the sheet particles at `x` (joint indices
/// `0..x.len()`) and builds J. Deterministic: entries are sorted by face,
/// then particle.
pub fn constraints(g: &MacGrid, sys: &Poisson, x: &[Vec3]) -> Constraints {
    constraints_of(g, sys, x, |_| true)
}

/// [`constraints`] of the sheet particles i with `keep(i)` only (the others
/// constrain no face; joint indices are unchanged).
pub fn constraints_of(
    g: &MacGrid,
    sys: &Poisson,
    x: &[Vec3],
    keep: impl Fn(usize) -> bool + Sync,
) -> Constraints {
    // (axis, slot, particle, weight) of every stencil entry
    let mut entries: Vec<(u8, u32, u32, Real)> = x
        .par_iter()
        .enumerate()
        .filter(|(i, _)| keep(*i))
        .flat_map_iter(|(i, p)| {
            (0..3).flat_map(move |a| {
                let (idx, w) = g.stencil(a, p);
                (0..8).filter_map(move |k| {
                    (idx[k] != NONE && w[k] > 0.0).then_some((a as u8, idx[k], i as u32, w[k]))
                })
            })
        })
        .collect();
    entries.par_sort_unstable_by(|p, q| (p.0, p.1, p.2).cmp(&(q.0, q.1, q.2)));
    // the runs of one face, then each face's K membership in parallel
    let mut runs = Vec::new();
    let mut k = 0;
    while k < entries.len() {
        let (a, s) = (entries[k].0, entries[k].1);
        let mut e = k;
        while e < entries.len() && entries[e].0 == a && entries[e].1 == s {
            e += 1;
        }
        runs.push((k, e));
        k = e;
    }
    let sides: Vec<Option<FaceSides>> = runs
        .par_iter()
        .map(|&(k, _)| {
            let (a, s) = (entries[k].0 as usize, entries[k].1 as usize);
            (!is_wall_face(g, s, a) && g.weight[a][s] >= MIN_OPEN && !g.is_prescribed(a, s))
                .then(|| sys.face(g, a, s))
                .flatten()
        })
        .collect();
    let ns = g.slots();
    let mut c = Constraints {
        ptr: vec![0],
        of_face: [vec![NONE; ns], vec![NONE; ns], vec![NONE; ns]],
        floor: super::system::MASS_FLOOR,
        ..Default::default()
    };
    for (&(k, e), sides) in runs.iter().zip(sides) {
        let (a, s) = (entries[k].0 as usize, entries[k].1 as usize);
        if let Some(sides) = sides {
            let total: Real = entries[k..e].iter().map(|t| t.3).sum();
            c.of_face[a][s] = c.faces.len() as u32;
            c.faces.push((a, s));
            c.sides.push(sides);
            c.mass.push(sides.theta);
            c.weight.push(g.weight[a][s]);
            for t in &entries[k..e] {
                c.col.push(t.2);
                c.val.push(t.3 / total);
            }
            c.ptr.push(c.col.len());
        }
    }
    c
}
