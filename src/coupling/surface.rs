//! The particle side of the coupled system (paper §6 and §7, eqs. 17, 21,
//! 22): for every sheet and filament particle its mass, control area
//! (Appendix D), explicit forces (rim and bud tension, §6) and the joint MLS
//! Laplacian L (§3.2.4) with the sheet weight in filament fits set to zero
//! (§7), all on the joint index of [`Neighborhoods`] (sheets, then
//! filaments).
//!
//! A sheet particle with a volume particle within h is the surface layer of
//! a liquid body (Appendix F): it has one face, so its tension area is its
//! Voronoi area. A sheet particle with no volume neighbour is a free film
//! (a waterbell's or a polygon's sheet) and has two faces (Appendix D).

use crate::area::{
    filament_areas, filament_length, filament_radius, rim_length, sheet_half_thickness,
    sphere_radius, surface_tension_area, voronoi_area,
};
use crate::math::{Real, Vec3};
use crate::mls::operators::{par_frames, Neighborhoods};
use crate::mls::{FitStats, Frame, JointLaplacian, MlsError, MlsParams};
use crate::neighbors::CellGrid;
use crate::particles::{Codim, Particles};
use crate::tension::{bud_force, filament_role, rim_force, FilamentRole, Sawtooth};
use faer::sparse::SparseRowMat;
use rayon::prelude::*;

/// Parameters of the particle side.
#[derive(Clone, Copy, Debug)]
pub struct SurfaceParams {
    /// MLS operator of the tension (support h = Δx, §10 Appendix F).
    pub mls: MlsParams,
    /// Surface tension σ (N/m).
    pub sigma: Real,
    /// Liquid density ρ (kg/m³).
    pub density: Real,
    /// Dynamic viscosity μ (Pa·s) of the implicit MLS viscosity (eq. 13) on
    /// free sheets and filaments, solved with the tension; 0 skips it.
    pub viscosity: Real,
    /// Half-aperture of the bud cone test (rad).
    pub bud_angle: Real,
    /// Rim tension modulation (fluid polygon, §10.2).
    pub rim_modulation: Option<Sawtooth>,
    /// Implicit tension on the diffusive part of L only, where the tension
    /// is solved on its own ([`crate::tension::split`]; the monolithic
    /// system of eq. 24 keeps L whole).
    pub diffusive: bool,
    /// Implicit weight θ of the tension, in [1/2, 1]: the force is
    /// σS L(xⁿ + θΔt uⁿ⁺¹) (`coupling.tension_theta`; the paper's is 1).
    pub tension_theta: Real,
}

/// Counts of the particle side.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SurfaceCounts {
    /// Sheet particles on a liquid body's surface (one face).
    pub surface_sheets: usize,
    /// Sheet particles of free films (two faces).
    pub free_sheets: usize,
    /// Filament particles bounding a sheet.
    pub rims: usize,
    /// Filament ends.
    pub buds: usize,
    /// Rows dropped because their curvature exceeded [`MAX_CURVATURE_H`]/h
    /// or their weights [`MAX_ROW_WEIGHT_H2`]/h², or whose diagonal was not
    /// negative.
    #[serde(default)]
    pub curvature_clamps: usize,
    /// Sheet half thicknesses and filament radii clamped to the radius of
    /// the particle's own sphere ([`sphere_radius`]).
    #[serde(default)]
    pub radius_clamps: usize,
}

/// Largest Σ_j |L_ij| h² of a tension row. On a resolved sheet the rows
/// sum to 10–13 (resting droplet, R = 4–8 Δx); the first rings of a jet's
/// sheet layer gave a median of 3e3 and a maximum of 1e6, which made
/// eq. (24) unsolvable (BiCGSTAB diverged with either method).
pub const MAX_ROW_WEIGHT_H2: Real = 100.0;

/// Largest curvature magnitude (times h) a tension row may have: a radius
/// of curvature below h/8 (about a third of the particle spacing at Δx/3)
/// is not resolved by the sampling.
pub const MAX_CURVATURE_H: Real = 8.0;

/// Everything eq. (21)–(22) needs of the sheet and filament particles, on
/// the joint index.
pub struct Surface {
    /// Joint index → store index, positions, codimensions.
    pub nb: Neighborhoods,
    /// Masses (kg).
    pub mass: Vec<Real>,
    /// Surface-tension areas S (m²).
    pub area: Vec<Real>,
    /// Explicit forces (rim, bud) (N).
    pub force: Vec<Vec3>,
    /// Velocities u** (m/s).
    pub u: Vec<Vec3>,
    /// Prescribed-velocity particles.
    pub fixed: Vec<bool>,
    /// Frame axes (b¹, b², b³) of each particle: b³ is a sheet's normal, b¹ a
    /// filament's tangent.
    pub axes: Vec<crate::math::Mat3>,
    /// Joint Laplacian L (1/m²).
    pub laplacian: SparseRowMat<usize, Real>,
    /// What the fits did.
    pub fits: FitStats,
    /// Sheet particles on a liquid body's surface (a volume particle
    /// within h); joint order, `false` for filaments.
    pub attached: Vec<bool>,
    /// Positions of the volume particles (store order) with their cell grid
    /// of size h, which decided `attached`; `None` without volume particles.
    pub volume: Option<(Vec<Vec3>, CellGrid)>,
    /// Classification counts.
    pub counts: SurfaceCounts,
    /// Updated radii (half thickness of free sheets, tube radius of
    /// filaments), joint order; `None` where the store keeps its radius.
    pub radius: Vec<Option<Real>>,
}

impl Surface {
    /// The curvature vector ∇²x = (L x)_i with its tangential part removed
    /// ([`crate::tension::normal_part`]).
    pub fn normal_curvature(&self, i: usize, lx: &Vec3) -> Vec3 {
        crate::tension::normal_part(&self.axes[i], i < self.n_sheet(), lx)
    }

    /// Number of particles on the joint index.
    pub fn len(&self) -> usize {
        self.nb.len()
    }

    /// True when the store has no sheet or filament particle.
    pub fn is_empty(&self) -> bool {
        self.nb.is_empty()
    }

    /// Number of sheet particles (the first joint indices).
    pub fn n_sheet(&self) -> usize {
        self.nb.n_sheet
    }
}

/// Control area, explicit tension force and radius of one joint particle
/// (Appendix D, §6): what the coupled step and the film step share.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParticleTerms {
    /// One-face Voronoi area of a sheet particle (sheet neighbours only), 0
    /// for filaments (m²).
    pub voronoi: Real,
    /// Surface-tension area S (m²): the Voronoi area (doubled for a free
    /// film's two faces), S_f of a rim, the lateral area of other filaments.
    pub area: Real,
    /// Explicit rim or bud tension (N).
    pub force: Vec3,
    /// New radius: half thickness of a free sheet, tube radius of a filament;
    /// `None` keeps the stored one.
    pub radius: Option<Real>,
    /// 0 sheet on a liquid body, 1 free sheet, 2 rim, 3 bud, 4 other filament.
    pub class: u8,
}

/// Areas, rim/bud forces and radii of every joint particle of `nb`, with its
/// frames; `mass(i)` is joint particle i's mass, `free(i)` says whether sheet
/// particle i is a free film (two faces) rather than a liquid body's surface.
pub fn particle_terms(
    nb: &Neighborhoods,
    frames: &[Frame],
    mass: impl Fn(usize) -> Real + Sync,
    free: impl Fn(usize) -> bool + Sync,
    prm: &SurfaceParams,
) -> Vec<ParticleTerms> {
    let h = prm.mls.h;
    let n_sheet = nb.n_sheet;
    let codim: Vec<Codim> = (0..nb.len()).map(|i| nb.codim(i)).collect();
    (0..nb.len())
        .into_par_iter()
        .map(|i| {
            let m = mass(i);
            let rmax = sphere_radius(m, prm.density);
            let nbrs = nb.lists.of(i);
            if i < n_sheet {
                let vor = voronoi_area(
                    &nb.x[i],
                    &frames[i].axes,
                    nbrs.iter()
                        .filter(|&&q| (q as usize) < n_sheet)
                        .map(|&q| nb.x[q as usize]),
                    h,
                );
                let free = free(i);
                return ParticleTerms {
                    voronoi: vor,
                    area: surface_tension_area(vor, free),
                    force: Vec3::zeros(),
                    radius: (free && vor > 0.0)
                        .then(|| sheet_half_thickness(m, vor, prm.density).min(rmax)),
                    class: free as u8,
                };
            }
            let fil = || {
                nbrs.iter()
                    .filter(|&&q| q as usize >= n_sheet)
                    .map(|&q| nb.x[q as usize])
            };
            let l = filament_length(&nb.x[i], fil(), 0.5 * h);
            let axes = &frames[i].axes;
            let role = filament_role(i, axes, &nb.x, &codim, nbrs, h, prm.bud_angle);
            // a rim particle carries its share of the rim's length
            // (`rim_length`): a rim band k rows thick pulls with 2σ per metre,
            // not 2kσ
            let l = match role {
                FilamentRole::Rim => {
                    let t: Vec3 = axes.column(0).into();
                    rim_length(&nb.x[i], &t, fil(), h, l)
                }
                _ => l,
            };
            let r = filament_radius(m, l, prm.density).min(rmax);
            let a = filament_areas(r, l);
            let (area, force, class) = match role {
                FilamentRole::Rim => {
                    let md = prm.rim_modulation.map_or(1.0, |s| s.at(&nb.x[i]));
                    let f = rim_force(i, axes, &nb.x, &codim, nbrs, prm.sigma, a.rim, r, md);
                    (a.rim_filament, f, 2)
                }
                FilamentRole::Bud => {
                    let f = bud_force(i, axes, &nb.x, &codim, nbrs, prm.sigma, a.bud, r);
                    (a.lateral, f, 3)
                }
                _ => (a.lateral, Vec3::zeros(), 4),
            };
            ParticleTerms {
                voronoi: 0.0,
                area,
                force,
                radius: Some(r),
                class,
            }
        })
        .collect()
}

/// Drops (zeroes) the tension rows whose weights or curvature the sampling
/// cannot resolve: Σ_j |L_ij| h² above [`MAX_ROW_WEIGHT_H2`] or a normal
/// curvature above [`MAX_CURVATURE_H`]/h, or a diagonal L_ii ≥ 0 (an
/// anti-diffusive row: at the chain's sheet rim L_ii h² = +4.3 made the
/// diagonal of a particle's implicit row −m̂ + ĉL_ii = +0.002 and sent it
/// off at 13 m/s). A fit through a degenerate
/// neighbourhood (the first two rings of a jet's sheet layer, a thin ribbon)
/// can be full rank and still give such a row; it would make the tension
/// explode and the system unsolvable. Its particle gets no tension this
/// step. Returns the number of rows dropped.
pub fn clamp_rows(
    matrix: &mut SparseRowMat<usize, Real>,
    nb: &Neighborhoods,
    axes: &[crate::math::Mat3],
    h: Real,
) -> usize {
    let n = nb.len();
    let n_sheet = nb.n_sheet;
    let kmax = MAX_CURVATURE_H / h;
    let (rp, bad): (Vec<usize>, Vec<bool>) = {
        let m = matrix.as_ref();
        let rp = m.symbolic().row_ptr().to_vec();
        let ci = m.symbolic().col_idx();
        let v = m.val();
        let bad = (0..n)
            .into_par_iter()
            .map(|i| {
                let mut lx = Vec3::zeros();
                for k in rp[i]..rp[i + 1] {
                    lx += nb.x[ci[k]] * v[k];
                }
                let t: Vec3 = axes[i].column(if i < n_sheet { 2 } else { 0 }).into();
                let kn = if i < n_sheet {
                    t.dot(&lx).abs()
                } else {
                    (lx - t * t.dot(&lx)).norm()
                };
                let weight: Real =
                    v[rp[i]..rp[i + 1]].iter().map(|w| w.abs()).sum::<Real>() * h * h;
                // a diffusion row has a negative diagonal; with a positive
                // one the implicit term σΔt²S L_ii cancels the mass on the
                // diagonal of eq. (16)/(24) as Δt grows, and the particle's
                // velocity blows up
                let diag: Real = (rp[i]..rp[i + 1])
                    .filter(|&k| ci[k] == i)
                    .map(|k| v[k])
                    .sum();
                let anti = weight > 0.0 && diag >= 0.0;
                !(kn <= kmax && weight <= MAX_ROW_WEIGHT_H2) || anti
            })
            .collect();
        (rp, bad)
    };
    let vals = matrix.val_mut();
    for i in (0..n).filter(|&i| bad[i]) {
        for v in &mut vals[rp[i]..rp[i + 1]] {
            *v = 0.0;
        }
    }
    bad.iter().filter(|b| **b).count()
}

/// Builds the particle side from the store (velocities after the body force).
pub fn build(parts: &Particles, prm: &SurfaceParams) -> Result<Surface, MlsError> {
    let h = prm.mls.h;
    let geom = MlsParams {
        sheet_weight_in_filament: 0.0,
        ..prm.mls
    };
    let nb = Neighborhoods::build(&parts.x, &parts.codim, h)?;
    let n = nb.len();
    let n_sheet = nb.n_sheet;
    let frames = par_frames(&nb, &geom);
    // volume neighbours decide between one face (liquid surface) and two (film)
    let volume_x: Vec<Vec3> = parts
        .x
        .iter()
        .zip(&parts.codim)
        .filter(|(_, c)| **c == Codim::Volume)
        .map(|(x, _)| *x)
        .collect();
    let volume = (!volume_x.is_empty()).then(|| {
        let grid = CellGrid::build(&volume_x, h);
        (volume_x, grid)
    });
    let on_volume: Vec<bool> = match &volume {
        None => vec![false; n_sheet],
        Some((vx, grid)) => nb.x[..n_sheet]
            .par_iter()
            .map(|x| grid.any_within(vx, x, h))
            .collect(),
    };
    let terms = particle_terms(
        &nb,
        &frames,
        |i| parts.mass[nb.store[i]],
        |i| !on_volume[i],
        prm,
    );
    let rows: Vec<(Real, Vec3, Option<Real>, u8)> = terms
        .iter()
        .map(|t| (t.area, t.force, t.radius, t.class))
        .collect();
    let mut counts = SurfaceCounts::default();
    for (i, r) in rows.iter().enumerate() {
        match r.3 {
            0 if i < n_sheet => counts.surface_sheets += 1,
            1 => counts.free_sheets += 1,
            2 => counts.rims += 1,
            3 => counts.buds += 1,
            _ => {}
        }
    }
    let mut lap = JointLaplacian::assemble_with_frames(&nb, &frames, &geom)?;
    let axes: Vec<crate::math::Mat3> = frames.iter().map(|f| f.axes).collect();
    counts.curvature_clamps = clamp_rows(&mut lap.matrix, &nb, &axes, h);
    counts.radius_clamps = rows
        .iter()
        .zip(&nb.store)
        .filter(|(r, &s)| r.2 == Some(sphere_radius(parts.mass[s], prm.density)))
        .count();
    Ok(Surface {
        mass: nb.store.iter().map(|&s| parts.mass[s]).collect(),
        u: nb.store.iter().map(|&s| parts.v[s]).collect(),
        fixed: nb.store.iter().map(|&s| parts.fixed[s]).collect(),
        area: rows.iter().map(|r| r.0).collect(),
        force: rows.iter().map(|r| r.1).collect(),
        radius: rows.iter().map(|r| r.2).collect(),
        axes: frames.iter().map(|f| f.axes).collect(),
        attached: (0..n).map(|i| i < n_sheet && on_volume[i]).collect(),
        volume,
        laplacian: lap.matrix,
        fits: lap.stats,
        counts,
        nb,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::sparse::Triplet;

    #[test]
    fn anti_diffusive_tension_rows_are_dropped() {
        // five sheet particles of a flat sheet: a centre and four neighbours
        let h = 0.01;
        let s = 0.4 * h;
        let x = vec![
            Vec3::zeros(),
            Vec3::new(s, 0.0, 0.0),
            Vec3::new(-s, 0.0, 0.0),
            Vec3::new(0.0, s, 0.0),
            Vec3::new(0.0, -s, 0.0),
        ];
        let nb = Neighborhoods::build(&x, &[Codim::Sheet; 5], h).unwrap();
        let axes = vec![crate::math::Mat3::identity(); 5];
        // row 0: a five-point Laplacian (diagonal −4/s², the others 1/s²);
        // row 1: the same weights negated, diagonal +4/s² (anti-diffusive)
        let mut t = Vec::new();
        for (r, sign) in [(0usize, 1.0), (1, -1.0)] {
            for j in 0..5 {
                let w = if j == r { -4.0 } else { 1.0 } / (s * s);
                t.push(Triplet::new(r, j, sign * w));
            }
        }
        let mut m = SparseRowMat::try_new_from_triplets(5, 5, &t).unwrap();
        // weights Σ|L|h² = 8 h²/s² = 50 (below the weight bound), curvature 0
        assert_eq!(clamp_rows(&mut m, &nb, &axes, h), 1);
        let r = m.as_ref();
        let row = |i: usize| {
            let rp = r.symbolic().row_ptr();
            r.val()[rp[i]..rp[i + 1]].to_vec()
        };
        assert!(row(0).iter().all(|v| *v != 0.0));
        assert!(row(1).iter().all(|v| *v == 0.0));
    }
}
