//! Per-particle MLS operators: gradient, divergence, Laplace–Beltrami and the
//! curvature vector (paper eqs. 7, 8, 35; §3.2.2–§3.2.4).
//!
//! In scaled local coordinates η = ξ/h the geometry is a graph
//! ζ = F(η) (sheet) or (ζ², ζ³) = F(η) (filament), fitted with the same
//! factorised least-squares problem as the fields ([`super::fit`]).
//!
//! Sheets, at η = 0 with F_k = ∂_k F, F_kl = ∂_k∂_l F:
//!
//! * metric g_kl = δ_kl + F_k F_l (eq. 6), tangents t_1 = (1, 0, F_1),
//!   t_2 = (0, 1, F_2) (§3.2.2; Appendix B's (1, β₂, 0) is a slip);
//! * ∇s = g^{kl} ∂_l s t_k (eq. 7a); ∇·v = g^{kl} t_k · ∂_l v (eq. 7b for
//!   a tangential field);
//! * Δs = g^{kl} (∂_k∂_l s − Γ^m_{kl} ∂_m s), Γ^m_{kl} = g^{mn} F_n F_kl
//!   (eq. 7c keeps only the first term; `christoffel` keeps both).
//!
//! Filaments, with G = 1 + F₂'² + F₃'², tangent t = (1, F₂', F₃') (eq. 8):
//! ∇s = s'/G t, ∇·v = t·v'/G, Δs = (s'' − (F₂'F₂'' + F₃'F₃'')/G · s')/G.
//!
//! Every result is divided by h (first derivatives) or h² (second) to return
//! to world units. The curvature vector κn = ∇²x applies the Laplace–Beltrami
//! weights to the member positions.
//!
//! Joint operator (§3.2.4): a sheet particle's fit takes its filament
//! neighbours with weight × `filament_weight_in_sheet`; a filament
//! particle's field fit takes sheet neighbours with weight ×
//! `sheet_weight_in_filament`, while its frame and curve geometry use
//! filament neighbours only (sheet points lie off the curve).

use super::fit::{n_terms, LsqFit};
use super::frame::{pca_frame, Frame};
use super::{FitStats, MlsError, MlsParams, Weighting};
use crate::math::{Real, Vec3};
use crate::neighbors::{neighbor_lists, NeighborLists};
use crate::particles::Codim;
use rayon::prelude::*;

/// The joint sheet + filament particle set with its neighbour lists.
///
/// Joint index: sheet particles first, then filament particles, each in
/// store order, so the Laplacian blocks are contiguous.
#[derive(Clone, Debug)]
pub struct Neighborhoods {
    /// Store index of each joint index.
    pub store: Vec<usize>,
    /// Number of sheet particles (joint indices `0..n_sheet`).
    pub n_sheet: usize,
    /// Positions in joint order (m).
    pub x: Vec<Vec3>,
    /// Neighbour lists on the joint index (self excluded, sorted).
    pub lists: NeighborLists,
}

impl Neighborhoods {
    /// Selects the sheet and filament particles of a store and finds their
    /// neighbours within `h`. Volume and point particles are left out.
    pub fn build(x: &[Vec3], codim: &[Codim], h: Real) -> Result<Neighborhoods, MlsError> {
        if codim.len() != x.len() {
            return Err(MlsError::Length {
                what: "codim",
                got: codim.len(),
                expected: x.len(),
            });
        }
        if !(h > 0.0 && h.is_finite()) {
            return Err(MlsError::InvalidParam {
                field: "h",
                value: h,
                reason: "must be positive and finite",
            });
        }
        if let Some(i) = x.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
            return Err(MlsError::NonFinite { index: i });
        }
        let mut store: Vec<usize> = (0..x.len()).filter(|&i| codim[i] == Codim::Sheet).collect();
        let n_sheet = store.len();
        store.extend((0..x.len()).filter(|&i| codim[i] == Codim::Filament));
        let xj: Vec<Vec3> = store.iter().map(|&i| x[i]).collect();
        let lists = neighbor_lists(&xj, h);
        Ok(Neighborhoods {
            store,
            n_sheet,
            x: xj,
            lists,
        })
    }

    /// All particles are sheet particles (in the given order).
    pub fn sheet(x: &[Vec3], h: Real) -> Result<Neighborhoods, MlsError> {
        Neighborhoods::build(x, &vec![Codim::Sheet; x.len()], h)
    }

    /// Number of particles on the joint index.
    pub fn len(&self) -> usize {
        self.x.len()
    }

    /// True when there is no sheet or filament particle.
    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }

    /// Codimension of joint index `p`.
    #[inline]
    pub fn codim(&self, p: usize) -> Codim {
        if p < self.n_sheet {
            Codim::Sheet
        } else {
            Codim::Filament
        }
    }
}

/// The fitted neighbourhood of one particle: frame, geometry and the
/// factorised field fit, reusable for any number of fields.
#[derive(Clone, Debug)]
pub struct LocalFit {
    /// Joint index of the particle.
    pub center: usize,
    /// Sheet or filament.
    pub codim: Codim,
    /// Local frame (eqs. 25–29).
    pub frame: Frame,
    /// Joint indices of the members: the particle itself first, then its neighbours.
    pub members: Vec<u32>,
    /// Support radius h (m).
    pub h: Real,
    /// The factorised field fit (H of eq. 34, not formed).
    pub field: LsqFit,
    /// First derivatives of the geometry at η = 0: (F_1, F_2) on a sheet,
    /// (F₂', F₃') on a filament (scaled coordinates).
    pub slope: [Real; 2],
    /// Second derivatives: (F_11, F_12, F_22) on a sheet, (F₂'', F₃'', 0)
    /// on a filament (scaled coordinates).
    pub second: [Real; 3],
    /// One-sided neighbourhood: the Laplacian uses the boundary row.
    pub boundary: bool,
}

/// Result of fitting one particle.
#[derive(Clone, Debug)]
pub enum FitOutcome {
    /// A fit of the requested order.
    Full(LocalFit),
    /// A fit of a lower order (the requested one was rank deficient).
    Lowered(LocalFit),
    /// No fit of order ≥ 2 exists; `isolated` when there is no neighbour.
    NoRow {
        /// True when the particle has no neighbour.
        isolated: bool,
    },
}

impl FitOutcome {
    /// The fit, when there is one.
    pub fn fit(&self) -> Option<&LocalFit> {
        match self {
            FitOutcome::Full(f) | FitOutcome::Lowered(f) => Some(f),
            FitOutcome::NoRow { .. } => None,
        }
    }

    fn stats(&self) -> FitStats {
        let mut s = FitStats {
            particles: 1,
            ..FitStats::default()
        };
        match self {
            FitOutcome::Full(f) => {
                s.full_order = 1;
                s.boundary = usize::from(f.boundary);
            }
            FitOutcome::Lowered(f) => {
                s.lowered_order = 1;
                s.boundary = usize::from(f.boundary);
            }
            FitOutcome::NoRow { isolated } => {
                s.no_row = 1;
                s.isolated = usize::from(*isolated);
            }
        }
        s
    }
}

/// Fit weight Ψ of a neighbour at distance `d` among `n` neighbours (eq. 32).
#[inline]
fn neighbour_weight(w: Weighting, d: Vec3, h: Real, n: usize) -> Real {
    let base = 1.0 / n as Real;
    match w {
        Weighting::Paper => base,
        Weighting::Wendland => {
            let r = (d.norm() / h).min(1.0);
            let a = 1.0 - r;
            base * a * a * a * a * (1.0 + 4.0 * r)
        }
    }
}

/// Whether neighbour `q` takes part in the frame and geometry of `p`.
#[inline]
fn in_geometry(nb: &Neighborhoods, p: usize, q: usize, params: &MlsParams) -> bool {
    match nb.codim(p) {
        Codim::Filament => nb.codim(q) == Codim::Filament,
        _ => nb.codim(q) == Codim::Sheet || params.filament_weight_in_sheet > 0.0,
    }
}

/// The weighted-PCA frame of joint particle `p` (eqs. 25–29).
pub fn particle_frame(nb: &Neighborhoods, p: usize, params: &MlsParams) -> Frame {
    let others = nb
        .lists
        .of(p)
        .iter()
        .map(|&q| q as usize)
        .filter(|&q| in_geometry(nb, p, q, params))
        .map(|q| nb.x[q]);
    pca_frame(&nb.x[p], others, params.h)
}

/// Frames of all joint particles, in parallel (deterministic).
pub fn par_frames(nb: &Neighborhoods, params: &MlsParams) -> Vec<Frame> {
    (0..nb.len())
        .into_par_iter()
        .map(|p| particle_frame(nb, p, params))
        .collect()
}

/// Fits the neighbourhood of joint particle `p` in the given frame, lowering
/// the order until the fit is full rank.
pub fn fit_particle(nb: &Neighborhoods, p: usize, frame: &Frame, params: &MlsParams) -> FitOutcome {
    let nbrs = nb.lists.of(p);
    if nbrs.is_empty() {
        return FitOutcome::NoRow { isolated: true };
    }
    let h = params.h;
    let cp = nb.codim(p);
    let m = nbrs.len() + 1;
    let mut members = Vec::with_capacity(m);
    members.push(p as u32);
    members.extend_from_slice(nbrs);
    let mut eta = Vec::with_capacity(m);
    let mut height = Vec::with_capacity(m); // geometry values: ζ³ (sheet) or ζ², ζ³ (filament)
    let mut w_field = Vec::with_capacity(m);
    let mut w_geom = Vec::with_capacity(m);
    let n = nbrs.len();
    for (k, &q) in members.iter().enumerate() {
        let q = q as usize;
        let d = nb.x[q] - nb.x[p];
        let l = frame.to_local(&d) / h;
        let (wf, wg) = if k == 0 {
            (1.0, 1.0)
        } else {
            let base = neighbour_weight(params.weighting, d, h, n);
            let cross = match (cp, nb.codim(q)) {
                (Codim::Sheet, Codim::Filament) => params.filament_weight_in_sheet,
                (Codim::Filament, Codim::Sheet) => params.sheet_weight_in_filament,
                _ => 1.0,
            };
            let g = if in_geometry(nb, p, q, params) {
                base * cross
            } else {
                0.0
            };
            (
                base * cross,
                if cp == Codim::Filament {
                    g
                } else {
                    base * cross
                },
            )
        };
        if cp == Codim::Sheet {
            eta.push([l.x, l.y]);
            height.push([l.z, 0.0]);
        } else {
            eta.push([l.x, 0.0]);
            height.push([l.y, l.z]);
        }
        w_field.push(wf);
        w_geom.push(wg);
    }
    let vars = if cp == Codim::Sheet { 2 } else { 1 };
    // boundary test: Ψ-weighted mean tangential offset of the neighbours
    let (mut c1, mut c2, mut wsum) = (0.0, 0.0, 0.0);
    for (e, w) in eta.iter().zip(&w_field).skip(1) {
        c1 += w * e[0];
        c2 += w * e[1];
        wsum += w;
    }
    let boundary = wsum > 0.0 && (c1 * c1 + c2 * c2).sqrt() / wsum > params.boundary_offset;
    let separate_geometry = w_field != w_geom;
    for order in (2..=params.order).rev() {
        let Some(field) = LsqFit::new(vars, order, &eta, &w_field, params.pivot_tol) else {
            continue;
        };
        let geom_fit;
        let g = if separate_geometry {
            match LsqFit::new(vars, order, &eta, &w_geom, params.pivot_tol) {
                Some(f) => {
                    geom_fit = f;
                    &geom_fit
                }
                None => continue,
            }
        } else {
            &field
        };
        let (slope, second) = if vars == 2 {
            let c = g.coefficients(&height.iter().map(|v| v[0]).collect::<Vec<_>>());
            ([c[1], c[2]], [2.0 * c[3], c[4], 2.0 * c[5]])
        } else {
            let c2 = g.coefficients(&height.iter().map(|v| v[0]).collect::<Vec<_>>());
            let c3 = g.coefficients(&height.iter().map(|v| v[1]).collect::<Vec<_>>());
            ([c2[1], c3[1]], [2.0 * c2[2], 2.0 * c3[2], 0.0])
        };
        let fit = LocalFit {
            center: p,
            codim: cp,
            frame: *frame,
            members,
            h,
            field,
            slope,
            second,
            boundary,
        };
        return if order == params.order {
            FitOutcome::Full(fit)
        } else {
            FitOutcome::Lowered(fit)
        };
    }
    FitOutcome::NoRow { isolated: false }
}

/// Builds every particle's fit once and maps it with `f` (`None` for a
/// particle without operator row), in parallel; results in joint order.
pub fn par_fit_map<T: Send>(
    nb: &Neighborhoods,
    frames: &[Frame],
    params: &MlsParams,
    f: impl Fn(usize, Option<&LocalFit>) -> T + Sync,
) -> (Vec<T>, FitStats) {
    let out: Vec<(T, FitStats)> = (0..nb.len())
        .into_par_iter()
        .map(|p| {
            let o = fit_particle(nb, p, &frames[p], params);
            (f(p, o.fit()), o.stats())
        })
        .collect();
    let mut stats = FitStats::default();
    let mut vals = Vec::with_capacity(out.len());
    for (v, s) in out {
        stats = stats.merge(s);
        vals.push(v);
    }
    (vals, stats)
}

impl LocalFit {
    /// Values of a joint-indexed field at the members.
    pub fn gather(&self, field: &[Real]) -> Vec<Real> {
        self.members.iter().map(|&q| field[q as usize]).collect()
    }

    /// Inverse metric (scaled coordinates): [g^11, g^12, g^22] on a sheet,
    /// [1/G, 0, 0] on a filament.
    pub fn inverse_metric(&self) -> [Real; 3] {
        let [a, b] = self.slope;
        if self.codim == Codim::Sheet {
            let (g11, g12, g22) = (1.0 + a * a, a * b, 1.0 + b * b);
            let det = g11 * g22 - g12 * g12;
            [g22 / det, -g12 / det, g11 / det]
        } else {
            [1.0 / (1.0 + a * a + b * b), 0.0, 0.0]
        }
    }

    /// World-space tangents t_1, t_2 (sheet) or t and zero (filament), in
    /// scaled units (unit along the frame axes).
    pub fn tangents(&self) -> [Vec3; 2] {
        let [a, b] = self.slope;
        if self.codim == Codim::Sheet {
            [
                self.frame.to_world(&Vec3::new(1.0, 0.0, a)),
                self.frame.to_world(&Vec3::new(0.0, 1.0, b)),
            ]
        } else {
            [self.frame.to_world(&Vec3::new(1.0, a, b)), Vec3::zeros()]
        }
    }

    /// Unit normal of a sheet fit (world), t_1 × t_2 normalised.
    pub fn normal(&self) -> Vec3 {
        let [t1, t2] = self.tangents();
        t1.cross(&t2).normalize()
    }

    /// The Laplace–Beltrami functional d with Δs = dᵀβ / h² (eq. 7c/8c, plus
    /// the metric-derivative term when `christoffel`).
    pub fn laplacian_functional(&self, christoffel: bool) -> Vec<Real> {
        let mut d = vec![0.0; self.field.k];
        let [a, b] = self.slope;
        if self.codim == Codim::Sheet {
            let [gi11, gi12, gi22] = self.inverse_metric();
            d[3] = 2.0 * gi11;
            d[4] = 2.0 * gi12;
            d[5] = 2.0 * gi22;
            if christoffel {
                // g^{kl} F_kl, then Γ^m = g^{mn} F_n (g^{kl} F_kl)
                let [f11, f12, f22] = self.second;
                let c = gi11 * f11 + 2.0 * gi12 * f12 + gi22 * f22;
                let (n1, n2) = (gi11 * a + gi12 * b, gi12 * a + gi22 * b);
                d[1] = -c * n1;
                d[2] = -c * n2;
            }
        } else {
            let g = 1.0 + a * a + b * b;
            d[2] = 2.0 / g;
            if christoffel {
                d[1] = -(a * self.second[0] + b * self.second[1]) / (g * g);
            }
        }
        d
    }

    /// Laplace–Beltrami weights r_q over the members: Δs_p = Σ_q r_q s_q
    /// (1/m²); the boundary row (module docs of [`super`]) for a boundary particle.
    pub fn laplacian_row(&self, christoffel: bool) -> Vec<Real> {
        let inv_h2 = 1.0 / (self.h * self.h);
        if self.boundary {
            return self.boundary_row();
        }
        let mut r = self
            .field
            .functional_row(&self.laplacian_functional(christoffel));
        r.iter_mut().for_each(|v| *v *= inv_h2);
        r
    }

    /// The boundary row: Δs ≈ (2k/m₂) Σ_q Ψ_q (s_q − s_p) / Σ_q Ψ_q (1/m²).
    pub fn boundary_row(&self) -> Vec<Real> {
        let m = self.field.members();
        let dims = if self.codim == Codim::Sheet { 2.0 } else { 1.0 };
        let (mut wsum, mut m2) = (0.0, 0.0);
        for q in 1..m {
            let b1 = self.field.basis(q, 1);
            let b2 = if self.codim == Codim::Sheet {
                self.field.basis(q, 2)
            } else {
                0.0
            };
            let r2 = b1 * b1 + b2 * b2;
            let w = self.field.weight(q);
            wsum += w;
            m2 += w * r2;
        }
        let mut row = vec![0.0; m];
        if wsum <= 0.0 || m2 <= 0.0 {
            return row;
        }
        let c = 2.0 * dims / (m2 / wsum) / (self.h * self.h) / wsum;
        for (q, r) in row.iter_mut().enumerate().skip(1) {
            *r = c * self.field.weight(q);
        }
        row[0] = -row[1..].iter().sum::<Real>();
        row
    }

    /// Surface gradient of a scalar given its member values (eq. 7a / 8a), world units.
    pub fn gradient(&self, values: &[Real]) -> Vec3 {
        let c = self.field.coefficients(values);
        let [t1, t2] = self.tangents();
        let gi = self.inverse_metric();
        let g = if self.codim == Codim::Sheet {
            (gi[0] * c[1] + gi[1] * c[2]) * t1 + (gi[1] * c[1] + gi[2] * c[2]) * t2
        } else {
            gi[0] * c[1] * t1
        };
        g / self.h
    }

    /// Surface divergence of a vector field given its member values (world
    /// vectors): g^{kl} t_k · ∂_l v (eq. 7b / 8b), world units.
    pub fn divergence(&self, values: &[Vec3]) -> Real {
        let comp = |i: usize| {
            self.field
                .coefficients(&values.iter().map(|v| v[i]).collect::<Vec<_>>())
        };
        let (cx, cy, cz) = (comp(0), comp(1), comp(2));
        let dv = |l: usize| Vec3::new(cx[l], cy[l], cz[l]);
        let [t1, t2] = self.tangents();
        let gi = self.inverse_metric();
        let d = if self.codim == Codim::Sheet {
            let (d1, d2) = (dv(1), dv(2));
            gi[0] * t1.dot(&d1) + gi[1] * (t1.dot(&d2) + t2.dot(&d1)) + gi[2] * t2.dot(&d2)
        } else {
            gi[0] * t1.dot(&dv(1))
        };
        d / self.h
    }

    /// Number of basis terms of the field fit.
    pub fn terms(&self) -> usize {
        n_terms(
            if self.codim == Codim::Sheet { 2 } else { 1 },
            self.field.order,
        )
    }
}

/// Surface gradients of a joint-indexed scalar field (zero where no fit).
pub fn par_gradients(nb: &Neighborhoods, params: &MlsParams, s: &[Real]) -> (Vec<Vec3>, FitStats) {
    let frames = par_frames(nb, params);
    par_fit_map(nb, &frames, params, |_, f| {
        f.map_or(Vec3::zeros(), |f| f.gradient(&f.gather(s)))
    })
}

/// Surface divergences of a joint-indexed vector field (zero where no fit).
pub fn par_divergences(
    nb: &Neighborhoods,
    params: &MlsParams,
    v: &[Vec3],
) -> (Vec<Real>, FitStats) {
    let frames = par_frames(nb, params);
    par_fit_map(nb, &frames, params, |_, f| {
        f.map_or(0.0, |f| {
            f.divergence(&f.members.iter().map(|&q| v[q as usize]).collect::<Vec<_>>())
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::validate::sampling::sphere_latitude;

    #[test]
    fn gradient_and_divergence_on_the_unit_sphere() {
        let x = sphere_latitude(1.0, 0.05, 0.0, 1);
        let nb = Neighborhoods::sheet(&x, 0.25).unwrap();
        let params = MlsParams::new(0.25);
        // ∇z = e_z − (e_z·n) n
        let s: Vec<Real> = nb.x.iter().map(|p| p.z).collect();
        let (g, st) = par_gradients(&nb, &params, &s);
        assert_eq!(st.full_order, nb.len());
        let gerr =
            nb.x.iter()
                .zip(&g)
                .map(|(p, g)| (g - (Vec3::z() - p.z * p)).norm())
                .fold(0.0, Real::max);
        assert!(gerr < 1e-5, "gradient error {gerr}");
        // ∇·x = 2 on a sphere (surface divergence of the identity)
        let (d, _) = par_divergences(&nb, &params, &nb.x);
        let derr = d.iter().map(|v| (v - 2.0).abs()).fold(0.0, Real::max);
        assert!(derr < 1e-5, "divergence error {derr}");
        // tangential rotation field (−y, x, 0) is divergence free
        let v: Vec<Vec3> = nb.x.iter().map(|p| Vec3::new(-p.y, p.x, 0.0)).collect();
        let (d, _) = par_divergences(&nb, &params, &v);
        assert!(d.iter().all(|v| v.abs() < 1e-6));
    }

    #[test]
    fn filament_gradient_divergence_and_laplacian_on_a_circle() {
        use crate::validate::sampling::circle;
        let x = circle(1.0, 0.02);
        let nb = Neighborhoods::build(&x, &vec![Codim::Filament; x.len()], 0.1).unwrap();
        let params = MlsParams::new(0.1);
        // s = x: ∇s = (t·e_x) t with t the unit tangent; Δs = −x on the unit circle
        let s: Vec<Real> = nb.x.iter().map(|p| p.x).collect();
        let (g, st) = par_gradients(&nb, &params, &s);
        assert_eq!((st.full_order, st.boundary), (nb.len(), 0));
        for (p, g) in nb.x.iter().zip(&g) {
            let t = Vec3::new(-p.y, p.x, 0.0);
            assert!((g - t.x * t).norm() < 1e-6, "{g:?}");
        }
        let l = super::super::JointLaplacian::assemble(&nb, &params).unwrap();
        let mut ls = vec![0.0; s.len()];
        l.apply(&s, &mut ls);
        assert!(nb.x.iter().zip(&ls).all(|(p, v)| (v + p.x).abs() < 1e-5));
        // ∇·x = 1 along a curve
        let (d, _) = par_divergences(&nb, &params, &nb.x);
        assert!(d.iter().all(|v| (v - 1.0).abs() < 1e-6), "{:?}", &d[..3]);
    }
}
