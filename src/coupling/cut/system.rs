//! The cut layer's pressure system and its velocity updates
//! (`coupling.layer: cut`): the rows of the liquid cells, the coupling
//! entries with the layer particles, the faces' update after the solve and
//! what the layer particles read back (see the parent module).

use super::{layer_stencil, Cut};
use crate::grid::projection::{rows, theta, unit, FaceTerm, Poisson};
use crate::grid::transfer::Valid;
use crate::grid::{MacGrid, NONE};
use crate::math::{Real, Vec3};

/// The ghost-fluid θ of a free cell's face to air (ψ `pin` at the cell,
/// `pout` past the face) and whether it was clamped: a cell that lies
/// within [`super::CELL_REACH`] outside ψ = 0 takes the face's whole length
/// (θ = 1). Its row and its faces' update both use it: the update once
/// read θ from ψ as [`Poisson::face`] does, the clamp 0.01 for such a
/// cell, and handed its faces 100 × the pressure gradient the row had
/// solved for (a falling chain's sheet threw particles at 5–30 m/s).
fn ghost_theta(pin: Real, pout: Real) -> (Real, usize) {
    if pin >= 0.0 {
        return (1.0, 0);
    }
    let (t, clamped) = theta(pin, pout);
    (t, clamped as usize)
}

impl Cut {
    /// The pressure system of the cut liquid: a_f w_f between liquid cells,
    /// the ghost-fluid free surface on the faces of free cells to air, and
    /// nothing on the faces the sheet closes (its flux is the particles').
    /// Faces for which `skip(axis, slot)` is true are left out as in
    /// [`Poisson::build`].
    pub fn poisson(&self, g: &MacGrid, skip: impl Fn(usize, usize) -> bool + Sync) -> Poisson {
        let ns = g.slots();
        let dx = g.dx;
        let mut index = vec![NONE; ns];
        let mut cells = Vec::new();
        for (s, i) in index.iter_mut().enumerate() {
            if self.liquid[s] {
                *i = cells.len() as u32;
                cells.push(s);
            }
        }
        let psi = &self.psi;
        let rows = rows(g, &index, &cells, skip, |a, f, s, across, w| match across {
            Some(t) if self.liquid[t] => {
                let ap = self.aperture[a][f];
                if ap > 0.0 {
                    FaceTerm::Liquid {
                        flux: ap * w,
                        coef: ap * w * self.mobility[a][f],
                    }
                } else {
                    FaceTerm::Closed
                }
            }
            _ if self.free[s] => {
                let (theta, clamps) = ghost_theta(psi[s], across.map_or(dx, |t| psi[t]));
                FaceTerm::Air { theta, clamps }
            }
            _ => FaceTerm::Closed,
        });
        Poisson::from_rows(self.psi.clone(), index, cells, rows)
    }

    /// The coupling entries with the cells as unknowns of `sys` (built by
    /// [`Cut::poisson`]): (cell, particle, ω_ic Â_c).
    pub fn coupling(&self, sys: &Poisson) -> Vec<(usize, usize, Vec3)> {
        self.entries
            .iter()
            .filter_map(|&(s, i, v)| sys.unknown(s).map(|c| (c as usize, i, v)))
            .collect()
    }

    /// The grid velocity a layer particle at `x` takes after the solve: its
    /// stencil without the faces the sheet closes between two liquid cells
    /// ([`layer_stencil`]).
    pub fn layer_velocity(&self, g: &MacGrid, x: &Vec3) -> Vec3 {
        let mut v = Vec3::zeros();
        for a in 0..3 {
            let (idx, w) = layer_stencil(g, &self.aperture[a], &self.liquid, a, x);
            for k in (0..8).filter(|&k| idx[k] != NONE) {
                v[a] += w[k] * g.u[a][idx[k] as usize];
            }
        }
        v
    }

    /// The velocity change of face (`a`, `f`) of liquid cell `s` per unit
    /// jump of q across it ([`super::release::outlier_cells`]): its
    /// mobility between two liquid cells (0 if the sheet closes it), 1 on a
    /// free cell's face to air, 0 on a face the sheet closes to air. A jump
    /// of q across a closed face moves nothing: two cut cells with a sliver
    /// of liquid each, closed toward each other and closed by the same
    /// sheet particles, took q = −45 and +46 m/s in the fluid chain while
    /// every face and particle moved at under 2.5 m/s, and the bound
    /// (33 m/s) stopped the run.
    pub fn velocity_gain(&self, a: usize, f: usize, s: usize, other: bool) -> Real {
        if other {
            if self.aperture[a][f] > 0.0 {
                self.mobility[a][f]
            } else {
                0.0
            }
        } else if self.free[s] {
            1.0
        } else {
            0.0
        }
    }

    /// Pressure update of the faces the solve sets: between liquid cells
    /// (u_f − (q_hi − q_lo)), on the free cells' faces to air and on the
    /// constraint faces (`is_k`; ghost-fluid θ as [`Poisson::apply`], plus
    /// `extra`). The faces the sheet closes are left invalid for the
    /// extrapolation. Returns the faces that hold a projected value.
    pub fn apply(
        &self,
        grid: &mut MacGrid,
        sys: &Poisson,
        q: &[Real],
        is_k: impl Fn(usize, usize) -> bool + Sync,
        extra: impl Fn(usize, usize) -> Real + Sync,
    ) -> Valid {
        sys.update_faces(grid, |g, ax, s, u, f| {
            let lower = |ax: usize, s: usize| g.neighbor(s, unit(ax, -1)).unwrap_or(s);
            let ql = f.lo.map_or(0.0, |i| q[i as usize]);
            let qh = f.hi.map_or(0.0, |i| q[i as usize]);
            if is_k(ax, s) {
                return (u - (qh - ql) / f.theta + extra(ax, s), 1);
            }
            // the free cells' faces to air with the θ of their rows
            // (ghost_theta), not the one Poisson::face reads from ψ
            match (f.lo, f.hi) {
                (Some(_), Some(_)) if self.aperture[ax][s] > 0.0 => {
                    (u - self.mobility[ax][s] * (qh - ql), 1)
                }
                (Some(_), None) if self.free[lower(ax, s)] => {
                    let th = ghost_theta(self.psi[lower(ax, s)], self.psi[s]).0;
                    (u - (qh - ql) / th, 1)
                }
                (None, Some(_)) if self.free[s] => {
                    let out = g.neighbor(s, unit(ax, -1)).map_or(g.dx, |l| self.psi[l]);
                    let th = ghost_theta(self.psi[s], out).0;
                    (u - (qh - ql) / th, 1)
                }
                _ => (u, 0),
            }
        })
    }

    /// Hands each body the momentum its layer took in the solve: `dp`
    /// holds each layer particle's position and m̂_i (u_i − v_i), its
    /// solved change at the inertia it had in the solve
    /// ([`super::LAYER_INERTIA`]). Each body's solved liquid faces (an
    /// aperture above 0, not prescribed) get the same velocity change per
    /// axis, Σ_i dp_i / Σ_f m̂_f. A uniform change is divergence free in
    /// every cut cell (the closure's identity), and the layer, which then
    /// reads the grid, moves with it.
    ///
    /// The layer's particles take the grid's velocity after the solve
    /// ([`Cut::layer_velocity`]), which drops the momentum the pressure of
    /// the cells they close gave them. The solve itself conserves momentum:
    /// the faces receive −Σ_c q_c A_c and the layer +Σ_c q_c A_c. But q
    /// does not balance each particle's tension (a cell has one q for
    /// several particles), and where the cut lies unevenly on the grid the
    /// sum is not zero. A cube placed off the grid's symmetry at
    /// `--scale 2` pushed itself by −0.30 mm/s every substep, at rest or
    /// moving at ±20 mm/s alike. Its faces lost −3.8e-6 kg m/s in a substep
    /// while its layer took +3.9e-6 (docs/decisions.md, "The cut layer
    /// hands its body the momentum its layer took").
    pub fn hand_back(&self, g: &mut MacGrid, dp: &[(Vec3, Vec3)], density: Real) {
        let (body, n) = self.bodies(g);
        let unit = density * g.dx.powi(3);
        let mut sum = vec![Vec3::zeros(); n];
        for (x, p) in dp {
            let c = g.cell_of(x);
            if let Some(b) = g
                .slot(c[0], c[1], c[2])
                .map(|s| body[s])
                .filter(|&b| b != NONE)
            {
                sum[b as usize] += p;
            }
        }
        // the solved faces (axis, slot, body) and each body's inertia
        let mut faces = Vec::new();
        let mut mass = vec![Vec3::zeros(); n];
        for (a, ap) in self.aperture.iter().enumerate() {
            for (s, &ap) in ap.iter().enumerate() {
                if ap > 0.0 && !g.is_prescribed(a, s) && body[s] != NONE {
                    let b = body[s] as usize;
                    mass[b][a] += ap * g.weight[a][s] / self.mobility[a][s] * unit;
                    faces.push((a, s, b));
                }
            }
        }
        let du: Vec<Vec3> = sum
            .iter()
            .zip(&mass)
            .map(|(p, m)| Vec3::from_fn(|a, _| if m[a] > 0.0 { p[a] / m[a] } else { 0.0 }))
            .collect();
        for (a, s, b) in faces {
            g.u[a][s] += du[b][a];
        }
    }

    /// The connected bodies of the cut liquid: a body id per slot (cells
    /// joined through faces of aperture > 0), [`NONE`] outside the liquid;
    /// and the number of bodies.
    pub fn bodies(&self, g: &MacGrid) -> (Vec<u32>, usize) {
        crate::neighbors::components(
            g.slots(),
            |s| self.liquid[s],
            |s, push| {
                for a in 0..3 {
                    // the lower face (a, s) and the upper face (a, t)
                    let lo = g.neighbor(s, unit(a, -1)).map(|l| (l, s));
                    let hi = g.neighbor(s, unit(a, 1)).map(|t| (t, t));
                    for (t, f) in [lo, hi].into_iter().flatten() {
                        if self.aperture[a][f] > 0.0 {
                            push(t);
                        }
                    }
                }
            },
        )
    }
}
