//! The surface layer's tension as a ghost-fluid pressure jump
//! (`coupling.layer: jump`; paper §7 couples it through eq. 24 instead).
//!
//! In eq. (24) a volume's surface layer (sheet particles with a volume
//! particle within h, Appendix F) carries its tension σS(Lx) as a particle
//! force, and the constraint faces of eq. (18) hand it to the grid through
//! the impulses λ. At rest that force is balanced by the pressure of the
//! liquid cells the level set puts just past the sheet, whose continuity
//! rows involve only J u; the same rows hold a thick sheet's edge back
//! (`docs/decisions.md`, "Thick sheet edges").
//!
//! Here the layer's particles instead give the grid the Young–Laplace jump
//! at the free surface (Kang, Fedkiw & Liu 2000): each attached particle's
//! pressure p_i = −σ n_i·(L x)_i (n_i its MLS normal turned out of the
//! liquid, L the joint MLS Laplacian of §5, so p = 2σ/R on a sphere) is
//! averaged with a smooth kernel onto the interface point of every
//! free-surface face within h, and becomes the Dirichlet value of that face's
//! air side ([`crate::grid::projection::Poisson::set_air`]). The layer's
//! particles constrain no face and take no tension row (they are held at
//! their velocity in the particle block, so free sheets and filaments beside
//! them see them as a boundary), and after the solve they move with the
//! grid, as in the coupled form. Free sheets and filaments keep eq. (24).

use super::faces::Constraints;
use super::surface::Surface;
use crate::grid::projection::{unit, FaceValues, Poisson};
use crate::grid::MacGrid;
use crate::linsolve::Csr;
use crate::math::{Real, Vec3};
use crate::neighbors::CellGrid;
use rayon::prelude::*;

/// A surface-layer particle's outward normal and pressure.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LayerPoint {
    /// MLS normal turned out of the liquid.
    pub normal: Vec3,
    /// Pressure at the liquid's surface (Pa); `None` where
    /// [`super::surface::clamp_rows`] dropped the particle's row.
    pub pressure: Option<Real>,
}

/// Depth (× Δx) a body must have below a surface-layer particle, along its
/// inward normal, for the particle to carry the jump. A thinner body (the
/// dripping stream once it has thinned to a cell or two, the droplet on a
/// plane's pancake) is not resolved by the grid once its liquid ends at
/// the layer: with the jump everywhere the stream kinked and broke up and
/// the pancake spread over the whole plane and up the walls. Its layer
/// keeps eq. (24)'s constraint faces and tension rows.
pub const MIN_DEPTH: Real = 2.5;

/// How far (m) the body reaches below `x` along −`n`: the first of the
/// points x − d n, d = s, 3s/2, 2s, … up to `limit`, with no volume
/// particle within 1.5 s (at a box's corner the nearest volume particle is
/// s√3 from the layer particle, along the diagonal).
fn depth(cells: &CellGrid, volume: &[Vec3], x: &Vec3, n: &Vec3, s: Real, limit: Real) -> Real {
    let mut d = s;
    while d < limit {
        if !cells.any_within(volume, &(x - d * n), 1.5 * s) {
            return d;
        }
        d += 0.5 * s;
    }
    limit
}

/// Outward normal and surface pressure of each attached sheet particle
/// whose body is at least [`MIN_DEPTH`] Δx deep below it (`None` for
/// other particles). The normal is the MLS normal turned away
/// from the centroid of the volume particles within h (`surf.volume`, whose
/// cell grid has size h); on a stream one or two cells thick the level set one cell
/// along −n can lie outside again, and a normal oriented by it bent the
/// dripping stream sideways. The layer's particles sit half
/// a volume spacing `s` inside the liquid's surface, so the mean curvature
/// κ = −n·(L x) of the layer is carried out to the surface as for a sphere,
/// κ_Γ = κ/(1 + κ s/4), and p = σκ_Γ (2σ/R on a sphere of radius R).
pub fn layer_points(
    surf: &Surface,
    h: Real,
    dx: Real,
    sigma: Real,
    spacing: Real,
) -> Vec<Option<LayerPoint>> {
    let Ok(l) = Csr::from_faer(surf.laplacian.as_ref()) else {
        return vec![None; surf.len()];
    };
    let Some((volume, cells)) = &surf.volume else {
        return vec![None; surf.len()];
    };
    let volume = volume.as_slice();
    (0..surf.len())
        .into_par_iter()
        .map(|i| {
            if !surf.attached[i] {
                return None;
            }
            let x = surf.nb.x[i];
            let (mut sum, mut count) = (Vec3::zeros(), 0usize);
            cells.for_each_within(volume, &x, h, |j, _| {
                sum += volume[j];
                count += 1;
            });
            if count == 0 {
                return None;
            }
            let n: Vec3 = surf.axes[i].column(2).into();
            let n = if n.dot(&(x - sum / count as Real)) >= 0.0 {
                n
            } else {
                -n
            };
            let s = spacing.clamp(0.1 * dx, h / 1.5);
            if depth(cells, volume, &x, &n, s, MIN_DEPTH * dx) < MIN_DEPTH * dx {
                return None;
            }
            let (lo, hi) = (l.row_ptr[i], l.row_ptr[i + 1]);
            let pressure = (!l.val[lo..hi].iter().all(|v| *v == 0.0)).then(|| {
                let mut lx = Vec3::zeros();
                for k in lo..hi {
                    lx += surf.nb.x[l.col[k]] * l.val[k];
                }
                let kappa = -n.dot(&lx);
                // carried half a spacing out; the denominator stays ≥ ½
                // (κ s/4 ≥ −½ only fails for a concave radius below s/2)
                sigma * kappa / (1.0 + 0.25 * kappa * spacing).max(0.5)
            });
            Some(LayerPoint {
                normal: n,
                pressure,
            })
        })
        .collect()
}

/// Ends the grid's liquid where the sampled body ends, half a volume
/// spacing `s` past its surface layer: every cell whose centre lies within
/// `reach` of an attached particle takes φ = max(φ, (x_c − x_i)·n_i − s/2),
/// with i the nearest such particle and n_i its outward normal. The level
/// set of the volume particles reaches `solver.surface_radius` Δx past the
/// layer, and that liquid would move with the pressure gradient although it
/// is not there. Measured on the l = 2 period at Δt = 0.01 s (`codimfx
/// bench accuracy --layer jump`): +16.2 % at R = 4Δx and +10.3 % at
/// R = 6.144Δx untrimmed, +6.0 % and +2.0 % trimmed. (Ending it at the
/// layer itself gave +3.2 % and +0.4 %, but the slab's pull at offset 0
/// fell from 0.77 to 0.34 of 2σL: `docs/decisions.md`.) Returns the liquid
/// cells turned to air.
pub fn trim_level_set(
    grid: &mut MacGrid,
    surf: &Surface,
    points: &[Option<LayerPoint>],
    spacing: Real,
    reach: Real,
) -> usize {
    let carriers: Vec<usize> = (0..points.len()).filter(|&i| points[i].is_some()).collect();
    if carriers.is_empty() {
        return 0;
    }
    let pts: Vec<Vec3> = carriers.iter().map(|&i| surf.nb.x[i]).collect();
    let cells = CellGrid::build(&pts, reach);
    let g: &MacGrid = grid;
    let phi: Vec<(Real, bool)> = (0..g.slots())
        .into_par_iter()
        .map(|s| {
            let p = g.phi[s];
            if !g.in_domain(s) || p >= g.dx {
                return (p, false);
            }
            let xc = g.cell_pos(s);
            let mut best = (Real::INFINITY, 0usize);
            cells.for_each_within(&pts, &xc, reach, |j, d2| {
                if d2 < best.0 || (d2 == best.0 && j < best.1) {
                    best = (d2, j);
                }
            });
            if best.0 == Real::INFINITY {
                return (p, false);
            }
            let lp = points[carriers[best.1]].expect("carrier");
            let d = (xc - pts[best.1]).dot(&lp.normal) - 0.5 * spacing;
            let q = p.max(d);
            (q, p < 0.0 && q >= 0.0)
        })
        .collect();
    let turned = phi.iter().filter(|x| x.1).count();
    grid.phi = phi.into_iter().map(|x| x.0).collect();
    turned
}

/// The scaled pressure q = p Δt/(ρΔx) at the interface point of every
/// free-surface face of `sys` (open, not prescribed, between a liquid cell
/// and a non-liquid one, not in `k`) that has an attached particle with a
/// pressure within `radius`: the average of those pressures with the
/// weight (1 − r²/radius²)³. `scale` is Δt/(ρΔx). Faces with none keep
/// q = 0.
pub fn air_values(
    grid: &MacGrid,
    sys: &Poisson,
    k: &Constraints,
    surf: &Surface,
    points: &[Option<LayerPoint>],
    radius: Real,
    scale: Real,
) -> FaceValues {
    let pressure: Vec<Option<Real>> = points.iter().map(|p| p.and_then(|p| p.pressure)).collect();
    let carriers: Vec<usize> = (0..pressure.len())
        .filter(|&i| pressure[i].is_some())
        .collect();
    if carriers.is_empty() {
        return FaceValues::default();
    }
    let pts: Vec<Vec3> = carriers.iter().map(|&i| surf.nb.x[i]).collect();
    let cells = CellGrid::build(&pts, radius);
    let entries: Vec<(usize, usize, Real)> = sys
        .cells
        .par_iter()
        .flat_map_iter(|&c| {
            let mut out = Vec::new();
            for a in 0..3 {
                for dir in [-1isize, 1] {
                    let Some(n) = grid.neighbor(c, unit(a, dir)) else {
                        continue;
                    };
                    if sys.unknown(n).is_some() {
                        continue;
                    }
                    let face = if dir < 0 { c } else { n };
                    if grid.weight[a][face] <= 0.0
                        || grid.is_prescribed(a, face)
                        || k.index(a, face).is_some()
                    {
                        continue;
                    }
                    let Some(sd) = sys.face(grid, a, face) else {
                        continue;
                    };
                    let mut xg = grid.cell_pos(c);
                    xg[a] += dir as Real * sd.theta * grid.dx;
                    let (mut sw, mut sp) = (0.0, 0.0);
                    cells.for_each_within(&pts, &xg, radius, |j, d2| {
                        let w = (1.0 - d2 / (radius * radius)).powi(3);
                        sw += w;
                        sp += w * pressure[carriers[j]].unwrap_or(0.0);
                    });
                    if sw > 0.0 {
                        out.push((a, face, scale * sp / sw));
                    }
                }
            }
            out
        })
        .collect();
    FaceValues::new(entries)
}

/// The explicit jump's capillary substep limit √(⟨ρ⟩Δx³/(2πσ)) (Brackbill,
/// Kothe & Zemach 1992) for a scene with `coupling.layer: jump` and
/// σ > 0; infinite otherwise (eq. 24's tension is semi-implicit). ⟨ρ⟩ is
/// the mean density of the two sides, ρ/2 for a liquid in air (the air's
/// density is neglected): a free surface's shortest capillary wave, k =
/// π/Δx, has ω² = σk³/ρ, twice the two-fluid value at ρ. With ρ in place
/// of ρ/2 (6.9 ms instead of 4.9 ms at Δx = 1/480 m, σ = 0.03 N/m) the
/// droplet collision stepped at 5 ms grew lobes, and its energy KE + σA
/// (A the surfaced mesh's area) rose from 223 µJ at t = 0 to 307 µJ at
/// t = 0.7 s; at 2.5 ms it was 178–197 µJ from t = 0.35 to 0.6 s
/// (docs/decisions.md, "The coupled layer holds a body's edges").
pub fn capillary_limit(scene: &crate::scene::Scene, dx: Real) -> Real {
    let sigma = scene.physics.surface_tension;
    if scene.coupling.layer != super::LayerTension::Jump || sigma <= 0.0 {
        return Real::INFINITY;
    }
    let mean_density = 0.5 * scene.physics.density;
    (mean_density * dx.powi(3) / (2.0 * std::f64::consts::PI * sigma)).sqrt()
}

#[cfg(test)]
mod tests {
    use super::super::release::tests::block;
    use super::*;
    use crate::grid::pcg::{pcg, PcgParams};

    /// Every free-surface face of `sys`, with the value `f` at its
    /// interface point.
    fn surface_values(g: &MacGrid, sys: &Poisson, f: impl Fn(&Vec3) -> Real) -> FaceValues {
        let mut e = Vec::new();
        for &c in &sys.cells {
            for a in 0..3 {
                for dir in [-1isize, 1] {
                    let n = g.neighbor(c, unit(a, dir)).unwrap();
                    if sys.unknown(n).is_some() {
                        continue;
                    }
                    let face = if dir < 0 { c } else { n };
                    let sd = sys.face(g, a, face).unwrap();
                    let mut x = g.cell_pos(c);
                    x[a] += dir as Real * sd.theta * g.dx;
                    e.push((a, face, f(&x)));
                }
            }
        }
        FaceValues::new(e)
    }

    #[test]
    fn a_linear_surface_pressure_is_recovered_exactly_inside() {
        // the ghost-fluid jump reproduces linear data: with q_Γ = q₀ + a·x on
        // the interface and no flux, q = q₀ + a·x in every liquid cell, and
        // the projected faces carry the uniform velocity −a Δx (q is scaled)
        let (mut g, mut sys) = block();
        let (q0, a) = (0.3, Vec3::new(0.5, -1.0, 0.25));
        let f = |x: &Vec3| q0 + a.dot(x);
        let air = surface_values(&g, &sys, f);
        assert!(air.len() > 500, "{} faces", air.len());
        assert_eq!(air.get(0, usize::MAX >> 8), 0.0);
        sys.set_air(&g, air.clone());
        assert_eq!(sys.air, air);
        let mut q = vec![0.0; sys.a.len()];
        let prm = PcgParams {
            tolerance: 1e-12,
            max_iterations: 1000,
        };
        pcg(&sys.a, &sys.b, &mut q, prm).unwrap();
        for (i, &c) in sys.cells.iter().enumerate() {
            let want = f(&g.cell_pos(c));
            assert!((q[i] - want).abs() < 1e-9, "{} vs {want}", q[i]);
        }
        // the velocity update uses the same values on the air side
        let valid = sys.apply(&mut g, &q, |_, _| 0.0);
        for ax in 0..3 {
            for (s, &v) in valid[ax].iter().enumerate() {
                if v == 1 && sys.face(&g, ax, s).is_some() {
                    assert!((g.u[ax][s] + a[ax] * g.dx).abs() < 1e-9, "{}", g.u[ax][s]);
                }
            }
        }
    }

    #[test]
    fn a_body_is_deep_below_its_layer_only_if_it_is_thick() {
        // volume particles on a lattice of spacing s, `layers` thick along y
        // below y = 0; the layer particle sits s above the top row
        let (s, dx) = (1.0 / 3.0, 1.0);
        let slab = |layers: usize| -> Vec<Vec3> {
            let mut v = Vec::new();
            for i in -6..=6 {
                for j in 0..layers {
                    for k in -6..=6 {
                        v.push(Vec3::new(i as Real * s, -(j as Real) * s, k as Real * s));
                    }
                }
            }
            v
        };
        let x = Vec3::new(0.0, s, 0.0);
        let n = Vec3::y();
        let limit = MIN_DEPTH * dx;
        for (layers, deep) in [(3, false), (5, false), (8, true), (12, true)] {
            let v = slab(layers);
            let cells = CellGrid::build(&v, dx);
            let d = depth(&cells, &v, &x, &n, s, limit);
            // the march leaves the body 1.5 s below its bottom row
            assert_eq!(d >= limit, deep, "{layers} rows: depth {d}");
            if !deep {
                let bottom = s + (layers - 1) as Real * s;
                assert!(
                    d > bottom && d <= bottom + 2.0 * s,
                    "{layers} rows: {d} vs {bottom}"
                );
            }
        }
    }

    #[test]
    fn face_values_keep_the_last_of_a_repeated_face_and_read_zero_elsewhere() {
        let v = FaceValues::new(vec![(2, 7, 1.0), (0, 9, 2.0), (2, 7, 3.0)]);
        assert_eq!(v.len(), 2);
        assert_eq!(v.get(2, 7), 3.0);
        assert_eq!(v.get(0, 9), 2.0);
        assert_eq!(v.get(1, 9), 0.0);
        assert_eq!(v.iter().collect::<Vec<_>>(), vec![(0, 9, 2.0), (2, 7, 3.0)]);
    }
}
