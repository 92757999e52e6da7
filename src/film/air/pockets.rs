//! The air pockets of one film step: the bag beyond its mouth and the
//! bubbles, their pressures solved implicitly with the tension (see the
//! parent module's doc).

use super::{bag_pressure, AirInfo, AirParams, AirState, Bubble, Sheets, Survey, PROBE_PRESSURE};
use crate::math::{Real, Vec3};
use std::collections::HashMap;

/// Stage 7: the pockets' pressures, implicit with the tension. `probe`
/// solves the tension system again with the given extra forces (N, per
/// sheet particle) and returns the velocities; one probe with
/// [`PROBE_PRESSURE`] in every pocket gives each pocket's response.
#[allow(clippy::too_many_arguments)]
pub fn stage<E>(
    s: &Sheets,
    sv: &Survey,
    u: &mut [Vec3],
    prm: &AirParams,
    state: &mut AirState,
    dt: Real,
    jet: bool,
    probe: impl FnOnce(&[(usize, Vec3)]) -> Result<Vec<Vec3>, E>,
) -> Result<AirInfo, E> {
    let mut plan = plan(s, sv, u, prm, state, dt, jet);
    if !plan.pockets.is_empty() {
        let up = probe(&plan.forces(s, PROBE_PRESSURE))?;
        let du: Vec<Vec3> = (0..u.len())
            .map(|i| (up[i] - u[i]) / PROBE_PRESSURE)
            .collect();
        plan.apply(s, sv.labels(), u, &du, prm.density, state);
    }
    Ok(plan.info)
}

/// What holds air in one step: the bag beyond its mouth, or a bubble.
#[derive(Clone, Debug)]
enum Kind {
    /// The bag, whose air leaves through a mouth of this area (m²).
    Bag { mouth: Real },
    /// Bubble `index` of the state, with its volume drift β (V − V_0)/Δt
    /// (m³/s).
    Bubble { index: usize, drift: Real },
}

/// One pocket of air: its walls (sheet indices), the sign that turns their
/// normals outward, and the component it moves.
#[derive(Clone, Debug)]
pub struct Pocket {
    walls: Vec<usize>,
    /// The pressure on each wall relative to the pocket's (Bernoulli).
    weight: Vec<Real>,
    sign: Real,
    component: u32,
    kind: Kind,
}

/// The pockets of one step and what the air did.
#[derive(Clone, Debug, Default)]
pub struct Plan {
    /// Air pockets whose pressure this step solves for.
    pub pockets: Vec<Pocket>,
    /// Figures of the step.
    pub info: AirInfo,
}

impl Plan {
    /// The forces (N) of an excess pressure `p` (Pa) in every pocket, per
    /// sheet particle: the right-hand side of the probe solve.
    pub fn forces(&self, s: &Sheets, p: Real) -> Vec<(usize, Vec3)> {
        self.pockets
            .iter()
            .flat_map(|k| {
                k.walls
                    .iter()
                    .zip(&k.weight)
                    .map(move |(&i, &w)| (i, s.normals[i] * (k.sign * p * w * s.area[i])))
            })
            .collect()
    }

    /// Solves each pocket's pressure and adds its response to `u` (module
    /// doc). `du` is the change of the sheet velocities per pascal in every
    /// pocket (the probe solve's, tension included); pockets lie in separate
    /// components, so each moves its own component only.
    pub fn apply(
        &mut self,
        s: &Sheets,
        label: &[u32],
        u: &mut [Vec3],
        du: &[Vec3],
        density: Real,
        state: &mut AirState,
    ) {
        for k in &self.pockets {
            let (mut g, mut c) = (0.0, 0.0);
            for &i in &k.walls {
                g += k.sign * s.area[i] * s.normals[i].dot(&u[i]);
                c += k.sign * s.area[i] * s.normals[i].dot(&du[i]);
            }
            if c <= 0.0 {
                continue;
            }
            let p = match k.kind {
                Kind::Bag { mouth } => {
                    let p = bag_pressure(g, c, mouth, density);
                    self.info.bag_pressure = p;
                    p
                }
                Kind::Bubble { index, drift } => {
                    let p = -(g + drift) / c;
                    if let Some(b) = state.bubbles.get_mut(index) {
                        b.pressure = p;
                    }
                    p
                }
            };
            for i in 0..u.len() {
                if label[i] == k.component {
                    u[i] += du[i] * p;
                }
            }
        }
    }
}

/// Finds this step's air pockets (module doc): follows the bubbles, closes
/// new ones, and finds the bag's mouth from the sheet velocities `u` after
/// the tension solve. While `jet` blows the bag is left to [`super::jet_forces`].
pub fn plan(
    s: &Sheets,
    sv: &Survey,
    u: &[Vec3],
    prm: &AirParams,
    state: &mut AirState,
    dt: Real,
    jet: bool,
) -> Plan {
    let n = s.x.len();
    let mut plan = Plan::default();
    if n == 0 || dt <= 0.0 {
        plan.info.bubbles = state.bubbles.len();
        return plan;
    }
    let (label, members, on_ring) = (&sv.label, &sv.members, &sv.on_ring);
    let nc = members.len();

    // follow the bubbles: the component holding most of each one's ids
    let mut owner: Vec<Option<usize>> = vec![None; nc];
    let mut kept: Vec<Bubble> = Vec::new();
    let bubbles = std::mem::take(&mut state.bubbles);
    let found = follow(s, label, &bubbles);
    // the bubbles in one component met: their airs add up before the
    // intact test, so two touching bubbles merge instead of bursting
    let mut v0 = vec![0.0; nc];
    for (b, c) in bubbles.iter().zip(&found) {
        if let Some(c) = *c {
            v0[c] += b.v0;
        }
    }
    for (b, c) in bubbles.into_iter().zip(found) {
        // a bubble that lost a third of its volume or more has burst (a
        // hole, or torn by a neighbour): its air is gone
        let intact = |c: usize| {
            let v = volume(s, &members[c]);
            (v - v0[c]).abs() < prm.burst * v0[c]
        };
        match c {
            Some(c) if !on_ring[c] && members[c].len() >= prm.min_bubble && intact(c) => {
                match owner[c] {
                    // two bubbles met: one bubble with both airs
                    Some(_) => plan.info.merged += 1,
                    None => {
                        owner[c] = Some(kept.len());
                        kept.push(Bubble { v0: v0[c], ..b });
                    }
                }
            }
            // burst, or fell apart: its air is gone
            _ => plan.info.burst += 1,
        }
    }
    // new bubbles: free, closed films
    for c in 0..nc {
        if on_ring[c] || owner[c].is_some() || members[c].len() < prm.min_bubble {
            continue;
        }
        let m = &members[c];
        let (sum_an, sum_a) = m.iter().fold((Vec3::zeros(), 0.0), |(v, a), &i| {
            (v + s.normals[i] * s.area[i], a + s.area[i])
        });
        if sum_a > 0.0 && sum_an.norm() < prm.closure * sum_a {
            // and it encloses a volume: sphericity V / (A^{3/2} / 6√π) (1
            // for a sphere, A one face) of at least a third, which a
            // crumpled fragment whose normals happen to cancel lacks
            let v = volume(s, m);
            let sphere = sum_a.powf(1.5) / (6.0 * std::f64::consts::PI.sqrt());
            if v > prm.sphericity * sphere {
                owner[c] = Some(kept.len());
                kept.push(Bubble {
                    v0: v,
                    ids: Vec::new(),
                    pressure: 0.0,
                });
                plan.info.new_bubbles += 1;
            }
        }
    }
    // the bubbles hold their volume
    for c in 0..nc {
        let Some(k) = owner[c] else { continue };
        let m = &members[c];
        let v = volume(s, m);
        let b = &mut kept[k];
        plan.info.bubble_volume_error = plan.info.bubble_volume_error.max((v - b.v0).abs() / b.v0);
        plan.pockets.push(Pocket {
            walls: m.clone(),
            weight: vec![1.0; m.len()],
            sign: outward(s, m),
            component: c as u32,
            kind: Kind::Bubble {
                index: k,
                drift: prm.relax * (v - b.v0) / dt,
            },
        });
        // a sample of at most 32 ids, spread over the members
        let step = (m.len() / 32).max(1);
        b.ids = m.iter().step_by(step).take(32).map(|&i| s.id[i]).collect();
    }
    plan.info.bubbles = kept.len();
    state.bubbles = kept;

    if jet || sv.bag.is_empty() {
        return plan;
    }
    // the bag's air leaves through the mouth
    let (k_m, phi) = sv.mouth(s, u);
    let r_m = sv.radius[k_m];
    let (walls, weight): (Vec<usize>, Vec<Real>) = sv
        .bag
        .iter()
        .zip(&sv.bin)
        .filter(|(_, &k)| k >= k_m)
        .map(|(&i, &k)| (i, phi[k]))
        .unzip();
    plan.info.mouth_radius = r_m;
    plan.info.mouth_offset = k_m as Real * prm.bin;
    plan.info.bag_volume = sv.radius[k_m..]
        .iter()
        .map(|r| std::f64::consts::PI * r * r * prm.bin)
        .sum();
    if let Some(&first) = walls.first() {
        plan.pockets.push(Pocket {
            walls,
            weight,
            sign: sv.sign,
            component: label[first],
            kind: Kind::Bag {
                mouth: std::f64::consts::PI * r_m * r_m,
            },
        });
    }
    plan
}

/// The component holding most of each bubble's ids (ties to the lower
/// label), or `None` when none of its ids is left.
fn follow(s: &Sheets, label: &[u32], bubbles: &[Bubble]) -> Vec<Option<usize>> {
    if bubbles.is_empty() {
        return Vec::new();
    }
    let index: HashMap<u64, usize> = s.id.iter().enumerate().map(|(i, &id)| (id, i)).collect();
    bubbles
        .iter()
        .map(|b| {
            let mut votes: HashMap<u32, usize> = HashMap::new();
            for id in &b.ids {
                if let Some(&i) = index.get(id) {
                    *votes.entry(label[i]).or_default() += 1;
                }
            }
            votes
                .into_iter()
                .max_by(|a, b| a.1.cmp(&b.1).then(b.0.cmp(&a.0)))
                .map(|(c, _)| c as usize)
        })
        .collect()
}

/// ⅓ Σ A (x − c)·n over the members, c their centroid: the enclosed volume
/// of a closed film, positive when its normals point outward.
fn signed_volume(s: &Sheets, m: &[usize]) -> Real {
    let c: Vec3 = m.iter().map(|&i| s.x[i]).sum::<Vec3>() / m.len() as Real;
    m.iter()
        .map(|&i| s.area[i] * (s.x[i] - c).dot(&s.normals[i]))
        .sum::<Real>()
        / 3.0
}

/// Enclosed volume of the members, whichever way their normals point.
fn volume(s: &Sheets, m: &[usize]) -> Real {
    signed_volume(s, m).abs()
}

/// +1 when the members' normals point away from their centroid on the
/// whole (out of a closed film), −1 otherwise.
fn outward(s: &Sheets, m: &[usize]) -> Real {
    if signed_volume(s, m) < 0.0 {
        -1.0
    } else {
        1.0
    }
}
