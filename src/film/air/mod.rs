//! The air inside a blown bag and inside the bubbles it makes (Fig. 2).
//!
//! The paper's blowing bubble "generates some separate bubbles" but does not
//! say how its air behaves. A wind that presses on the film's normal makes a
//! steady bag, and a gust makes a finger that collapses within one frame
//! once the wind stops: nothing inside holds it, and it never pinches
//! (docs/decisions.md, "Static rings keep their attachment row"). What slows
//! a real bag's collapse is its air, which must leave through the bag's
//! narrowest section, where it flows fastest: the pressure there is the
//! atmosphere's while the bag beyond it is held up, so the neck closes first
//! and traps the air beyond it.
//!
//! Model (`film.bag_air`, docs/decisions.md "Bubbles blown off a ring"):
//! - **Bag.** The sheet particles of the film that holds the ring, profiled
//!   along the ring's axis a (through the ring's centre o, pointing with the
//!   wind): bins of width h/2 in s = (x − o)·a; the section at the upstream
//!   face of bin k has the radius R_k of the bin's widest wall particle, and
//!   an area of at least the projected area of the bin's walls that face
//!   downstream (the first section is the ring). The air is incompressible:
//!   the walls beyond section k, left to tension and wind, change the volume
//!   beyond it at the rate V̇_k = Σ A_i n_i·u_i (one-face areas A_i, normals
//!   out of the bag), and that air crosses the section at v_k = |V̇_k| / πR_k².
//!   While the bag empties, the *mouth* is the section where that air is
//!   fastest (among those with a twentieth of the bag's volume beyond them):
//!   the lowest pressure, where the air leaves as a jet at
//!   Q = sign(p) A_m √(2|p|/ρ_air) (Bernoulli, discharge coefficient 1,
//!   A_m = π R_m²); while it fills, the mouth is the ring. The bag's excess
//!   pressure p acts along n on the walls beyond the mouth with the Bernoulli
//!   profile p (1 − v_k²/v_m²): the air at rest at the far end has the bag's
//!   pressure, the air in the mouth the atmosphere's, so the neck is not held
//!   and closes. The walls before the mouth feel no air (the jet's region).
//!   p is the root of V̇(u) + c p + sign(p) A_m √(2|p|/ρ_air) = 0, with c the
//!   volume rate per pascal (monotone in p, one root, closed form in √|p|).
//! - **Jet.** While a jet blows a gust ([`super::Wind::jet_blowing`]), the
//!   air it blows into the bag is trapped there: every wall of the bag feels
//!   the jet's stagnation pressure c_d ρ_air |w(x)|² ([`jet_forces`]) instead
//!   of its drag, and the bag's air is not solved for.
//! - **Bubbles.** A film that is no longer connected to the ring and whose
//!   surface closes (|Σ A_i n_i| < 2 % of Σ A_i: a hole of radius at most
//!   ~0.28 R; sphericity at least 1/3) becomes a bubble of rest volume V_0,
//!   its enclosed volume then. Its air cannot leave: p is the root of
//!   V̇(u) + β (V − V_0)/Δt + c p = 0 (β = 0.2 draws a volume drift back over
//!   a few steps). A bubble is followed from step to step by a sample of its
//!   particles' ids; one that lost a third of its volume or joined the
//!   ring's film has burst and lets its air go. Bubbles whose films join
//!   merge: the joined film holds the sum of their rest volumes (the
//!   burst test compares its volume with that sum).
//!
//! Each pressure is a Lagrange multiplier on the sheet velocities after the
//! tension solve, implicit with the tension ([`stage`]): a second tension
//! solve with a probe pressure in every pocket gives each pocket's response
//! du per pascal (tension included; the pockets lie in separate components
//! of the film, so one probe serves all), c = Σ A_i n_i·du_i, and
//! u ← u + p du. Applied with lumped masses instead, the pressure pushed a
//! stretched film's thin parts out faster than tension could answer within
//! the step, and the film shattered; an explicit gas spring stiff enough to
//! hold a 1 µm film (1e-3 kg/m²) would need substeps far below the film's
//! own. Air inertia and the unsteady Bernoulli term are neglected (the bag's
//! air moves at a few m/s over centimetres).

use crate::math::{Real, Vec3};

/// Where the bag hangs: the ring's centre and its axis, pointing with the wind.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AirParams {
    /// Centre of the ring (m).
    pub origin: Vec3,
    /// Unit axis of the ring, pointing with the wind (downstream).
    pub axis: Vec3,
    /// Radius of the ring (m): the mouth when the bag has no neck.
    pub ring_radius: Real,
    /// Air density (kg/m³).
    pub density: Real,
    /// Bin width of the bag's profile (m).
    pub bin: Real,
    /// Fewest sheet particles of a closed film that counts as a bubble.
    pub min_bubble: usize,
    /// Largest |Σ A n| / Σ A of a closed film.
    pub closure: Real,
    /// Fraction of a bubble's volume error drawn back per step.
    pub relax: Real,
    /// Smallest sphericity of a closed film that counts as a bubble.
    pub sphericity: Real,
    /// Relative volume change at which a bubble counts as burst.
    pub burst: Real,
}

impl AirParams {
    /// Defaults for a ring at `origin` with axis `axis` (normalised here),
    /// support radius `h`.
    pub fn new(origin: Vec3, axis: Vec3, ring_radius: Real, density: Real, h: Real) -> AirParams {
        AirParams {
            origin,
            axis: axis.normalize(),
            ring_radius,
            density,
            bin: 0.5 * h,
            min_bubble: 50,
            closure: 0.02,
            relax: 0.2,
            sphericity: 1.0 / 3.0,
            burst: 1.0 / 3.0,
        }
    }
}

/// A closed film with its trapped air.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Bubble {
    /// Rest volume (m³): the enclosed volume when it closed.
    pub v0: Real,
    /// Ids of some of its particles, to find it again in the next step.
    pub ids: Vec<u64>,
    /// Excess pressure of its air in the last step (Pa).
    #[serde(default)]
    pub pressure: Real,
}

/// The bubbles that have left the ring (carried from step to step, and in
/// the manifest for a resumed run).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct AirState {
    /// Closed films, in the order they closed.
    pub bubbles: Vec<Bubble>,
}

/// What the air did in one step.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AirInfo {
    /// Excess pressure in the bag (Pa).
    pub bag_pressure: Real,
    /// Radius of the bag's mouth (m).
    pub mouth_radius: Real,
    /// Distance of the mouth from the ring along the axis (m).
    pub mouth_offset: Real,
    /// Volume of the bag beyond the mouth (m³, from its profile).
    pub bag_volume: Real,
    /// Bubbles after this step.
    pub bubbles: usize,
    /// Bubbles that closed in this step.
    pub new_bubbles: usize,
    /// Bubbles lost in this step: burst (a third of their volume gone) or
    /// joined to the ring's film.
    pub burst: usize,
    /// Bubbles that met another bubble in this step and now share its air
    /// (one bubble holds the sum of their rest volumes).
    pub merged: usize,
    /// Largest relative volume error of a bubble, |V − V_0| / V_0.
    pub bubble_volume_error: Real,
}

/// Connected components of the sheet neighbour graph: a label per particle
/// and the number of components.
pub fn components<'a>(n: usize, nbrs: impl Fn(usize) -> &'a [u32]) -> (Vec<u32>, usize) {
    crate::neighbors::components(
        n,
        |_| true,
        |i, push| {
            for &j in nbrs(i) {
                push(j as usize);
            }
        },
    )
}

/// The pressure p of an air volume whose walls, left alone, change it at the
/// rate `g` (m³/s), with `c` = Δt Σ A²/m and a mouth of area `mouth`:
/// the root of g + c p + sign(p) A_m √(2|p|/ρ) = 0.
pub fn bag_pressure(g: Real, c: Real, mouth: Real, density: Real) -> Real {
    if c <= 0.0 || g == 0.0 {
        return 0.0;
    }
    // in y = √|p|: c y² + b y − |g| = 0, the positive root in a stable form
    let b = mouth * (2.0 / density).sqrt();
    let y = 2.0 * g.abs() / (b + (b * b + 4.0 * c * g.abs()).sqrt());
    -g.signum() * y * y
}

/// Everything [`plan`] and [`stage`] read about the film's sheet particles (indices
/// 0..n, the film store's sheet block).
pub struct Sheets<'a> {
    /// Positions.
    pub x: &'a [Vec3],
    /// Masses.
    pub mass: &'a [Real],
    /// One-face (Voronoi) areas.
    pub area: &'a [Real],
    /// Unit normals, consistent within each component.
    pub normals: &'a [Vec3],
    /// Static boundary particles (the ring).
    pub fixed: &'a [bool],
    /// Stable ids.
    pub id: &'a [u64],
}

/// The bag's and the bubbles' geometry in one step: what [`plan`] and
/// [`jet_forces`] act on (positions and normals do not change between the
/// explicit forces and the projection).
#[derive(Clone, Debug, Default)]
pub struct Survey {
    /// Component label of each sheet particle.
    pub(super) label: Vec<u32>,
    /// Members of each component.
    pub(super) members: Vec<Vec<usize>>,
    /// Whether a component holds ring particles.
    pub(super) on_ring: Vec<bool>,
    /// The bag: the free particles of the ring's film.
    pub bag: Vec<usize>,
    /// Profile bin of each bag particle.
    pub(super) bin: Vec<usize>,
    /// Radius of the section at the upstream face of each bin (m).
    pub(super) radius: Vec<Real>,
    /// +1 when the normals of the bag point out of it, −1 otherwise.
    pub sign: Real,
    /// The ring's axis and the profile's bin width (m).
    axis: Vec3,
    width: Real,
}

/// Finds the films, the bag's profile and its mouth (module doc).
/// `nbrs(i)` lists the sheet neighbours of i.
pub fn survey<'a>(s: &Sheets, nbrs: impl Fn(usize) -> &'a [u32], prm: &AirParams) -> Survey {
    let n = s.x.len();
    let (label, nc) = components(n, nbrs);
    let mut members: Vec<Vec<usize>> = vec![Vec::new(); nc];
    for i in 0..n {
        members[label[i] as usize].push(i);
    }
    let on_ring: Vec<bool> = members
        .iter()
        .map(|m| m.iter().any(|&i| s.fixed[i]))
        .collect();
    let mut sv = Survey {
        label,
        members,
        on_ring,
        sign: 1.0,
        axis: prm.axis,
        width: prm.bin,
        ..Survey::default()
    };
    // the bag: the ring's film, beyond its mouth
    let bag: Vec<usize> = (0..n)
        .filter(|&i| sv.on_ring[sv.label[i] as usize] && !s.fixed[i])
        .collect();
    if bag.is_empty() {
        return sv;
    }
    let a = prm.axis;
    // normals out of the bag: away from a point on the axis one ring radius
    // upstream (a flat film then points downstream, a bag's walls outwards)
    let up = prm.origin - a * prm.ring_radius;
    let out: Real = bag
        .iter()
        .map(|&i| s.area[i] * s.normals[i].dot(&(s.x[i] - up)))
        .sum();
    sv.sign = if out < 0.0 { -1.0 } else { 1.0 };
    let prof: Vec<usize> = bag
        .iter()
        .map(|&i| ((s.x[i] - prm.origin).dot(&a).max(0.0) / prm.bin) as usize)
        .collect();
    let nbin = prof.iter().max().map_or(1, |k| k + 1);
    // the section at the upstream face of bin k: the widest of its walls
    // (an empty section has closed: radius 0); the first is the ring
    let mut radius = vec![0.0; nbin];
    for (&i, &k) in bag.iter().zip(&prof) {
        let d = s.x[i] - prm.origin;
        radius[k] = Real::max(radius[k], (d - a * d.dot(&a)).norm());
    }
    radius[0] = prm.ring_radius;
    sv.bag = bag;
    sv.bin = prof;
    sv.radius = radius;
    sv
}

impl Survey {
    /// The bag's mouth for sheet velocities `u` (module doc): its bin (0 for
    /// the ring), and the pressure profile φ_k = 1 − (v_k / v_m)² beyond it
    /// (Bernoulli: the air at rest has the bag's pressure, the air in the
    /// mouth the atmosphere's), per bin.
    pub(super) fn mouth(&self, s: &Sheets, u: &[Vec3]) -> (usize, Vec<Real>) {
        let nbin = self.radius.len();
        // the air crossing each section: the volume rate of the walls beyond
        // it (tension and wind, before the air acts) through its area
        let mut gb = vec![0.0; nbin];
        for (&i, &k) in self.bag.iter().zip(&self.bin) {
            gb[k] += self.sign * s.area[i] * s.normals[i].dot(&u[i]);
        }
        for k in (0..nbin.saturating_sub(1)).rev() {
            gb[k] += gb[k + 1];
        }
        // a section is at least as wide as the walls of its bin that face
        // downstream (the tip's last bins hold a few particles of its cap)
        let mut cap = vec![0.0; nbin];
        for (&i, &k) in self.bag.iter().zip(&self.bin) {
            cap[k] += s.area[i] * (self.sign * s.normals[i].dot(&self.axis)).max(0.0);
        }
        // the volume beyond each section, from the profile
        let pi = std::f64::consts::PI;
        let mut vol: Vec<Real> = self
            .radius
            .iter()
            .map(|r| pi * r * r * self.width)
            .collect();
        for k in (0..nbin.saturating_sub(1)).rev() {
            vol[k] += vol[k + 1];
        }
        // while the bag empties, the section where its air is fastest (the
        // lowest pressure), among those with a twentieth of the bag's volume
        // or more beyond them; while it fills, the ring
        let speed: Vec<Real> = (0..nbin)
            .map(|k| {
                let sec = Real::max(pi * self.radius[k] * self.radius[k], cap[k]);
                if sec > 0.0 {
                    -gb[k] / sec
                } else {
                    Real::INFINITY
                }
            })
            .collect();
        let mut k_m = 0;
        let mut best = 0.0;
        if gb[0] < 0.0 {
            for (k, &v) in speed.iter().enumerate() {
                if vol[k] < 0.05 * vol[0] {
                    break;
                }
                if v > best {
                    best = v;
                    k_m = k;
                }
            }
        }
        let phi = speed
            .iter()
            .map(|&v| {
                if best > 0.0 && best.is_finite() && v > 0.0 {
                    (1.0 - (v / best).powi(2)).clamp(0.0, 1.0)
                } else {
                    1.0
                }
            })
            .collect();
        (k_m, phi)
    }
}

/// While a jet blows into the bag, its air is held at the jet's
/// stagnation pressure: `p(x)` (Pa) on every wall of the bag, along the
/// outward normal. Returns the forces (N) per sheet particle.
pub fn jet_forces(s: &Sheets, sv: &Survey, p: impl Fn(&Vec3) -> Real) -> Vec<(usize, Vec3)> {
    sv.bag
        .iter()
        .map(|&i| (i, s.normals[i] * (sv.sign * p(&s.x[i]) * s.area[i])))
        .collect()
}

impl<'a> Sheets<'a> {
    /// The sheet block (the first `n_sheet` particles) of a film sub-store,
    /// with its one-face areas and oriented normals.
    pub fn of(
        film: &'a crate::particles::Particles,
        n_sheet: usize,
        area: &'a [Real],
        normals: &'a [Vec3],
    ) -> Sheets<'a> {
        Sheets {
            x: &film.x[..n_sheet],
            mass: &film.mass[..n_sheet],
            area: &area[..n_sheet],
            normals,
            fixed: &film.fixed[..n_sheet],
            id: &film.id[..n_sheet],
        }
    }
}

/// Excess pressure (Pa) of the probe solve: of the order of a soap film's
/// Laplace pressure, so the response is resolved well above the solver's
/// tolerance.
pub const PROBE_PRESSURE: Real = 1.0;

/// Stage 4 with a jet: while it blows ([`super::Wind::jet_blowing`]), adds
/// the jet's stagnation pressure c ρ_air |w(x)|² on the bag's walls to the
/// forces `f` ([`jet_forces`]) and returns which sheet particles got it (they
/// feel no drag of the jet besides).
pub fn trapped_jet(
    s: &Sheets,
    sv: &Survey,
    wind: Option<&super::Wind>,
    t: Real,
    f: &mut [Vec3],
) -> Vec<bool> {
    let mut hit = vec![false; s.x.len()];
    if let Some(w) = wind.filter(|w| w.jet_blowing(t)) {
        let stagnation = |x: &Vec3| w.drag * w.air_density * w.at(t, x).norm_squared();
        for (i, fj) in jet_forces(s, sv, stagnation) {
            f[i] += fj;
            hit[i] = true;
        }
    }
    hit
}

impl Survey {
    /// Component label of each sheet particle.
    pub fn labels(&self) -> &[u32] {
        &self.label
    }
}

pub use pockets::{plan, stage, Plan, Pocket};

mod pockets;
#[cfg(test)]
mod tests;
