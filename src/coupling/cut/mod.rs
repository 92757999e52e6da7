//! Cut-cell coupling of a volume's surface layer (`coupling.layer: cut`),
//! beyond the paper's §7.
//!
//! Eq. (24) hands the layer's tension to the grid through the constraint
//! faces of eq. (18): every face in the particles' control volume moves
//! with J u. A liquid cell past the sheet whose open faces are all
//! constraint faces then has a continuity row on J u alone, which forbids
//! the sheet's tangential compression there (`docs/decisions.md`, "The
//! coupled layer holds a body's edges"). Here the liquid ends at the sheet
//! instead, and the sheet is the moving boundary of the cells it crosses:
//!
//! - ψ, the cut's level set: within 2Δx of the layer, the signed distance
//!   to the tangent plane of the nearest layer particle (its normal b³
//!   turned outward), zero [`OFFSET`] spacings past it; elsewhere the
//!   liquid level set φ moved by `shift`. Liquid cells: ψ < 0, and near the
//!   layer every cell the cut reaches ([`CELL_REACH`]); a cell whose every
//!   face is closed is none. A separation rule's air cells
//!   (`solver.separate_bodies`, `solver.open_gaps`) count only through φ:
//!   near the layer ψ is the layer's, and keeping them air there cut the
//!   facing sides of the collision's cubes short (the left cube fell to
//!   16.3 mm/s by frame 12, against 18.85 without);
//! - a face between two liquid cells carries its liquid aperture a_f, the
//!   fraction of the face with ψ < 0 from ψ at its corners
//!   ([`crate::grid::fraction_inside`]), its share of the flux; its
//!   inertia m̂_f is the mass the particles hand it, Σ_p m_p w_fp over the
//!   volume particles (the last P2G) and the layer, so that the momentum
//!   the solve gives the faces is the momentum the grid-to-particle
//!   transfer gives the particles (with the aperture as the mass, a free
//!   cube lost 6 % of its momentum in 14 frames; `docs/decisions.md`,
//!   "The cut layer's faces weigh what the particles put on them");
//! - the rest of a liquid cell's boundary is the sheet. Its area vector is
//!   the closure A_c = Σ_f n_{c,f} w_f (1 − a_f) Δx² (n the face's outward
//!   normal, w its open fraction; 0 inside the liquid), and the layer
//!   particles within [`REACH`] of the cell centre that face the same way
//!   carry its flux with weights ω_ic ∝ S_i (1 − r²/R²)² max(0, n_i · Â_c/|Â_c|),
//!   Σ_i ω_ic = 1 (in a thin sheet of liquid the other face's particles are
//!   within reach too);
//! - continuity of cell c: Σ_f s_{c,f} a_f w_f v_f Δx² + A_c · Σ_i ω_ic u_i
//!   = 0 with v_f = v*_f − (a_f w_f / m̂_f) (q_hi − q_lo); the particle i
//!   feels the transpose, Δt Σ_c p_c ω_ic A_c.
//!
//! With the closure a uniform translation is divergence free in every cell,
//! whatever the apertures. At rest the pressure of the cells a particle
//! closes balances its tension σ S_i (L x)_i; no liquid lies past the sheet
//! and no continuity row constrains the sheet's area. In the scaled
//! unknowns of [`super::system`] (q = Δt p/(ρΔx), m̂ = m/(ρΔx³)) the cell
//! row gains Â_c ω_ic · u_i and particle i's row (negated as eq. 24 is)
//! gains Â_c ω_ic q_c, Â = A/Δx²: the two blocks are each other's
//! transposes. A liquid cell with sheet area but no layer particle within
//! reach (a hole in the layer, a body without one) keeps the ghost-fluid
//! free surface there (q = 0 at ψ = 0), counted as a free cell.

mod system;

use super::surface::Surface;
use crate::grid::projection::unit;
use crate::grid::{fraction_inside, MacGrid, NONE};
use crate::math::{Real, Vec3};
use crate::neighbors::CellGrid;
use crate::solids::SolidSet;
use rayon::prelude::*;

/// Radius (cells) within which the layer particles close a cut cell: the
/// layer lies up to one spacing past ψ = 0 and the cell centre up to a
/// cell inside it.
pub const REACH: Real = 1.5;

/// Where the liquid ends past the layer particles, in particle spacings:
/// a body's surface lies half a spacing past its outermost particles. The
/// resting droplet's pressure is then within 1.3 % of 2σ/R at R = 4–8 Δx
/// (with the cut at the particles, +8.6 % to +2.8 %: the tension acts on
/// the layer's area, the pressure on the cut's).
pub const OFFSET: Real = 0.5;

/// Cells whose centre lies within this many Δx outside ψ = 0 near the
/// layer are liquid cells: √3/2 takes in every cell the cut surface
/// reaches. With only the cells whose centre is inside, the cut's area fell
/// short of the layer's (the faces the sheet crosses outside those cells
/// close at the cell boundary) and the resting pressure was 5 % high at
/// R = 4 Δx.
pub const CELL_REACH: Real = 0.87;

/// Fraction of the layer particles' mass they keep as inertia in the solve.
/// The faces already carry the layer's mass (the particles take the grid's
/// velocity after the solve), so the whole mass counts the layer twice. But
/// the layer's inertia is what holds its particles where the pressure
/// balances their tension poorly, at a thin sheet's rim: at 0.25 the slab
/// of `validate slab` failed (particle speeds over 6 m/s in the solve) at
/// 1.5–3 cells for some offsets, at 0.1 at every one (faces of aperture
/// mass, session 38). With the faces' particle mass, the l = 2 period at
/// R = 6.144 Δx is +0.2 % at 0.5 (Δt = 0.01 s; +1.3 % at 0.005 s), +1.4 %
/// at 0.75, +2.4 % at 1.
pub const LAYER_INERTIA: Real = 0.5;

/// Least inertia of a cut liquid face, as a fraction of its area a_f w_f
/// (in ρΔx³): a face the particles barely reach would otherwise take any
/// pressure gradient at once. Counted in [`Cut::light_faces`].
pub const MASS_FLOOR: Real = 0.1;

/// Least share of a layer particle's trilinear weights that
/// [`layer_stencil`] must keep to leave out the closed faces.
pub const LAYER_STENCIL_MIN: Real = 0.25;

/// The trilinear stencil (axis `a`) of a layer particle at `x` without the
/// faces the sheet closes between two liquid cells (`aperture` 0, both
/// `cells` liquid), renormalized; the whole stencil when the rest carry
/// less than [`LAYER_STENCIL_MIN`] of its weight. The layer's mass goes
/// onto the faces, and its velocity comes back from them, with these
/// weights, so the two agree. Such a face lies between two bodies less than
/// a cell apart, and its extrapolated velocity averages both: a layer
/// particle reading it slowed its body (the collision's left cube fell to
/// 18.98 mm/s by frame 10 with the whole stencil, where one cube alone kept
/// 19.62). The faces outside a single body keep the velocity extended from
/// it: leaving out every face that is not between liquid cells made the
/// l = 2 period +1.9 % (Δt = 0.01 s) and +3.4 % (0.005 s) at R = 6.144 Δx,
/// against +0.2 % and +1.3 %.
pub fn layer_stencil(
    g: &MacGrid,
    aperture: &[Real],
    cells: &[bool],
    a: usize,
    x: &Vec3,
) -> ([u32; 8], [Real; 8]) {
    let (mut idx, mut w) = g.stencil(a, x);
    // kept: every face but one the sheet closes between two liquid cells
    let liquid: [bool; 8] = std::array::from_fn(|k| {
        if idx[k] == NONE {
            return false;
        }
        let f = idx[k] as usize;
        let lower = g.neighbor(f, unit(a, -1));
        !(aperture[f] <= 0.0 && cells[f] && lower.is_some_and(|l| cells[l]))
    });
    let sum: Real = (0..8).filter(|&k| liquid[k]).map(|k| w[k]).sum();
    if sum < LAYER_STENCIL_MIN {
        return (idx, w);
    }
    for k in 0..8 {
        if liquid[k] {
            w[k] /= sum;
        } else {
            idx[k] = NONE;
            w[k] = 0.0;
        }
    }
    (idx, w)
}

/// Closures smaller than this (in Δx²) are rounding: the cell is interior.
const MIN_CLOSURE: Real = 1e-3;

/// The cut geometry of one substep.
#[derive(Clone, Debug)]
pub struct Cut {
    /// ψ at the cell centres (extended half a cell into solids).
    pub psi: Vec<Real>,
    /// Liquid cell of each slot.
    pub liquid: Vec<bool>,
    /// Liquid cells with sheet area and no layer particle within reach:
    /// ghost-fluid free surface on their faces to air.
    pub free: Vec<bool>,
    /// Aperture of the lower face of each slot, per axis (between two
    /// liquid cells; 0 elsewhere).
    pub aperture: [Vec<Real>; 3],
    /// Mobility of the lower face of each slot between two liquid cells:
    /// its area a_f w_f over its inertia m̂_f, the particles' mass on it in
    /// ρΔx³ (1 elsewhere).
    pub mobility: [Vec<Real>; 3],
    /// (cell slot, particle (joint index), ω_ic Â_c), by slot then particle.
    pub entries: Vec<(usize, usize, Vec3)>,
    /// Liquid cells closed by the sheet.
    pub cut_cells: usize,
    /// Of which free ([`Cut::free`]).
    pub free_cells: usize,
    /// Liquid faces whose inertia was floored ([`MASS_FLOOR`]).
    pub light_faces: usize,
}

impl Cut {
    /// The geometry for ψ = `grid.phi` + `shift`; the layer particles of
    /// `surf` (its `attached` sheet particles) close the cut cells.
    pub fn build(
        g: &MacGrid,
        solids: &SolidSet,
        surf: &Surface,
        h: Real,
        shift: Real,
        spacing: Real,
        density: Real,
    ) -> Cut {
        let ns = g.slots();
        let dx = g.dx;
        let offset = -OFFSET * spacing;
        let tau = CELL_REACH * dx;
        // the layer particles, their outward normals (b³ turned up the
        // level set's gradient) and their buckets by cell (key, joint index)
        let layer: Vec<usize> = (0..surf.n_sheet()).filter(|&i| surf.attached[i]).collect();
        let phi_at = |c: [isize; 3]| g.slot(c[0], c[1], c[2]).map(|t| g.phi[t]);
        let mut normal = vec![Vec3::zeros(); surf.len()];
        for &i in &layer {
            let x = surf.nb.x[i];
            // outward: away from the volume particles within h (as the
            // jump's layer points), else up the level set's gradient
            let mut out = Vec3::zeros();
            if let Some((volume, cells)) = &surf.volume {
                let (mut sum, mut count) = (Vec3::zeros(), 0usize);
                cells.for_each_within(volume, &x, h, |j, _| {
                    sum += volume[j];
                    count += 1;
                });
                if count > 0 {
                    out = x - sum / count as Real;
                }
            }
            if out == Vec3::zeros() {
                let c = g.cell_of(&x);
                for a in 0..3 {
                    let (mut lo, mut hi) = (c, c);
                    lo[a] -= 1;
                    hi[a] += 1;
                    if let (Some(l), Some(h)) = (phi_at(lo), phi_at(hi)) {
                        out[a] = h - l;
                    }
                }
            }
            let n: Vec3 = surf.axes[i].column(2).into();
            normal[i] = if n.dot(&out) < 0.0 { -n } else { n };
        }
        // the layer particles' positions in a cell grid of size 2Δx (the
        // widest query), indices into `layer`
        let pts: Vec<Vec3> = layer.iter().map(|&i| surf.nb.x[i]).collect();
        let search = CellGrid::build(&pts, 2.0 * dx);
        // near the layer: the signed distance to the tangent plane of the
        // nearest layer particle (+ offset); elsewhere φ + shift
        let near_sdf = |x: &Vec3| -> Option<Real> {
            let mut best: Option<(Real, usize)> = None;
            search.for_each_within(&pts, x, 2.0 * dx, |j, d| {
                let i = layer[j];
                if best.is_none_or(|b| d < b.0 || (d == b.0 && i < b.1)) {
                    best = Some((d, i));
                }
            });
            best.map(|(_, i)| (x - surf.nb.x[i]).dot(&normal[i]) + offset)
        };
        let (psi, near): (Vec<Real>, Vec<bool>) = (0..ns)
            .into_par_iter()
            .map(|s| {
                let x = g.cell_pos(s);
                let sdf = if g.in_domain(s) { near_sdf(&x) } else { None };
                let p = sdf.unwrap_or(g.phi[s] + shift);
                if !solids.is_empty() && p < 0.5 * dx && solids.phi(&x) < 0.0 {
                    (p.min(-0.5 * dx), sdf.is_some())
                } else {
                    (p, sdf.is_some())
                }
            })
            .unzip();
        let open = |s: usize, a: usize| -> Real {
            match g.neighbor(s, unit(a, 1)) {
                Some(t) => g.weight[a][s] + g.weight[a][t],
                None => g.weight[a][s],
            }
        };
        let mut liquid: Vec<bool> = (0..ns)
            .into_par_iter()
            .map(|s| {
                let bound = if near[s] { tau } else { 0.0 };
                g.in_domain(s) && psi[s] < bound && (0..3).map(|a| open(s, a)).sum::<Real>() > 0.0
            })
            .collect();
        // ψ at a node (lower corner of cell c): the layer's plane distance
        // near it, else the mean of its 8 cells
        let node_at = |c: [isize; 3]| -> Real {
            let x = g.origin + Vec3::new(c[0] as Real, c[1] as Real, c[2] as Real) * dx;
            near_sdf(&x).unwrap_or_else(|| {
                let mut sum = 0.0;
                for dk in -1..=0 {
                    for dj in -1..=0 {
                        for di in -1..=0 {
                            sum += g
                                .slot(c[0] + di, c[1] + dj, c[2] + dk)
                                .map_or(dx, |t| psi[t]);
                        }
                    }
                }
                sum / 8.0
            })
        };
        // ψ at the lower corner of every slot that is a corner of a liquid
        // cell, once (a node serves up to twelve faces, and the apertures are
        // recomputed when lone cells are dropped)
        let nodes: Vec<Real> = (0..ns)
            .into_par_iter()
            .map(|s| {
                let c = g.cell(s);
                let corner_of_liquid = (0..8).any(|k: isize| {
                    g.slot(c[0] - (k & 1), c[1] - ((k >> 1) & 1), c[2] - ((k >> 2) & 1))
                        .is_some_and(|t| liquid[t])
                });
                if corner_of_liquid {
                    node_at(c)
                } else {
                    Real::NAN
                }
            })
            .collect();
        let node = |c: [isize; 3]| -> Real {
            g.slot(c[0], c[1], c[2])
                .map(|t| nodes[t])
                .filter(|v| !v.is_nan())
                .unwrap_or_else(|| node_at(c))
        };
        // the aperture of the lower face (axis a) of slot s between two
        // liquid cells: its fraction with ψ < 0
        let apertures = |liquid: &[bool]| -> [Vec<Real>; 3] {
            [0, 1, 2].map(|a| {
                (0..ns)
                    .into_par_iter()
                    .map(|s| {
                        let lo = match g.neighbor(s, unit(a, -1)) {
                            Some(l) => l,
                            None => return 0.0,
                        };
                        if !(liquid[s] && liquid[lo]) || g.weight[a][s] == 0.0 {
                            return 0.0;
                        }
                        let c = g.cell(s);
                        let (b, d) = ((a + 1) % 3, (a + 2) % 3);
                        let at = |i: isize, j: isize| {
                            let mut n = c;
                            n[b] += i;
                            n[d] += j;
                            node(n)
                        };
                        let p = [at(0, 0), at(1, 0), at(0, 1), at(1, 1)];
                        fraction_inside(p)
                    })
                    .collect()
            })
        };
        // a cell whose every face is closed has neither a flux nor a sheet
        // area (the closure of six closed faces is 0): it is no liquid cell
        let mut aperture = apertures(&liquid);
        for _ in 0..3 {
            let lone: Vec<usize> = (0..ns)
                .into_par_iter()
                .filter(|&s| {
                    liquid[s]
                        && (0..3).all(|a| {
                            aperture[a][s] == 0.0
                                && g.neighbor(s, unit(a, 1))
                                    .is_none_or(|t| aperture[a][t] == 0.0)
                        })
                })
                .collect();
            if lone.is_empty() {
                break;
            }
            for s in lone {
                liquid[s] = false;
            }
            aperture = apertures(&liquid);
        }
        // Â_c = Σ_f n_out (w − open) over the six faces of a liquid cell
        let closure = |s: usize| -> Vec3 {
            let mut v = Vec3::zeros();
            for a in 0..3 {
                let w = g.weight[a][s];
                if w > 0.0 && !g.is_prescribed(a, s) {
                    v[a] -= w * (1.0 - aperture[a][s]);
                }
                if let Some(t) = g.neighbor(s, unit(a, 1)) {
                    let w = g.weight[a][t];
                    if w > 0.0 && !g.is_prescribed(a, t) {
                        v[a] += w * (1.0 - aperture[a][t]);
                    }
                }
            }
            v
        };
        let reach = REACH * dx;
        let cells: Vec<usize> = (0..ns).filter(|&s| liquid[s]).collect();
        let per_cell: Vec<Option<Vec<(usize, usize, Vec3)>>> = cells
            .par_iter()
            .map(|&s| {
                let a_c = closure(s);
                if a_c.norm() < MIN_CLOSURE {
                    return Some(Vec::new());
                }
                let xc = g.cell_pos(s);
                let mut found: Vec<(usize, Real)> = Vec::new();
                let dir = a_c.normalize();
                search.for_each_within(&pts, &xc, reach, |j, d| {
                    let i = layer[j];
                    let q = d / (reach * reach);
                    let cos = normal[i].dot(&dir);
                    if cos > 0.0 {
                        found.push((i, surf.area[i] * (1.0 - q) * (1.0 - q) * cos));
                    }
                });
                found.sort_unstable_by_key(|e| e.0);
                let total: Real = found.iter().map(|e| e.1).sum();
                if total <= 0.0 || !total.is_finite() {
                    return None;
                }
                Some(
                    found
                        .into_iter()
                        .map(|(i, w)| (s, i, a_c * (w / total)))
                        .collect(),
                )
            })
            .collect();
        let mut free = vec![false; ns];
        let mut entries = Vec::new();
        let (mut cut_cells, mut free_cells) = (0, 0);
        for (&s, e) in cells.iter().zip(per_cell) {
            match e {
                None => {
                    free[s] = true;
                    free_cells += 1;
                    cut_cells += 1;
                }
                Some(e) => {
                    cut_cells += (!e.is_empty()) as usize;
                    entries.extend(e);
                }
            }
        }
        // the faces' inertia: the mass the particles hand them (the volume
        // particles' from the last P2G, the layer's scattered here with the
        // same trilinear weights)
        let mut layer_mass: [Vec<Real>; 3] = [vec![0.0; ns], vec![0.0; ns], vec![0.0; ns]];
        for i in (0..surf.len()).filter(|&i| surf.attached[i]) {
            for (a, m) in layer_mass.iter_mut().enumerate() {
                let (idx, w) = layer_stencil(g, &aperture[a], &liquid, a, &surf.nb.x[i]);
                for k in (0..8).filter(|&k| idx[k] != NONE) {
                    m[idx[k] as usize] += w[k] * surf.mass[i];
                }
            }
        }
        let unit = density * dx.powi(3);
        let mut light_faces = 0;
        let mobility = [0, 1, 2].map(|a| {
            let (ap, lm) = (&aperture[a], &layer_mass[a]);
            let per: Vec<(Real, bool)> = (0..ns)
                .into_par_iter()
                .map(|s| {
                    if ap[s] <= 0.0 {
                        return (1.0, false);
                    }
                    let area = ap[s] * g.weight[a][s];
                    let m = (g.mass[a][s] + lm[s]) / unit;
                    let floor = MASS_FLOOR * area;
                    (area / m.max(floor), m < floor)
                })
                .collect();
            light_faces += per.iter().filter(|e| e.1).count();
            per.into_iter().map(|e| e.0).collect()
        });
        Cut {
            psi,
            liquid,
            free,
            aperture,
            mobility,
            light_faces,
            entries,
            cut_cells,
            free_cells,
        }
    }
}
