//! The particle store: structure of arrays with a typed codimension.
//!
//! Paper §3: every particle carries a position, a velocity, a mass and an
//! integer codimension number C (0 volume, 1 thin sheet, 2 filament, 3 point).
//! Here C is the [`Codim`] enum; each particle also carries a radius (used by
//! the rim/bud tension of §6 and the surfacer) and a stable id that survives
//! reseeding and deletion so caches can be followed across frames.
//!
//! Insertion and deletion are applied at one point of the step through
//! [`Particles::retain`] and [`Particles::push`], so indices are stable inside
//! a stage.

use crate::math::{Real, Vec3};
use serde::{Deserialize, Serialize};

/// Codimension of a particle (paper §3: C = 0, 1, 2, 3).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[repr(u8)]
pub enum Codim {
    /// C = 0: inside a fluid volume; its operators live on the MAC grid.
    Volume = 0,
    /// C = 1: on a thin sheet or on the surface of a volume.
    Sheet = 1,
    /// C = 2: on a thin filament (or the rim of a sheet).
    Filament = 2,
    /// C = 3: an isolated droplet.
    Point = 3,
}

impl Codim {
    /// All four codimensions, in order.
    pub const ALL: [Codim; 4] = [Codim::Volume, Codim::Sheet, Codim::Filament, Codim::Point];

    /// The integer codimension number C.
    pub fn number(self) -> u8 {
        self as u8
    }

    /// Parses the integer codimension number C (0–3).
    pub fn from_number(c: u8) -> Option<Codim> {
        match c {
            0 => Some(Codim::Volume),
            1 => Some(Codim::Sheet),
            2 => Some(Codim::Filament),
            3 => Some(Codim::Point),
            _ => None,
        }
    }

    /// Lower-case name, as used in reports.
    pub fn name(self) -> &'static str {
        match self {
            Codim::Volume => "volume",
            Codim::Sheet => "sheet",
            Codim::Filament => "filament",
            Codim::Point => "point",
        }
    }
}

/// Particle store as structure of arrays. All vectors have the same length.
#[derive(Clone, Debug, Default)]
pub struct Particles {
    /// Position (m).
    pub x: Vec<Vec3>,
    /// Velocity (m/s).
    pub v: Vec<Vec3>,
    /// Mass (kg).
    pub mass: Vec<Real>,
    /// Radius (m): sphere-equivalent for volume/point particles, tube radius
    /// for filaments, half thickness for sheets.
    pub radius: Vec<Real>,
    /// Codimension number.
    pub codim: Vec<Codim>,
    /// Stable identifier, unique over the whole run.
    pub id: Vec<u64>,
    /// Static boundary particles (Appendix C rings): take part in fits, never move by the solver.
    pub fixed: Vec<bool>,
    /// Next id to hand out.
    pub next_id: u64,
}

impl Particles {
    /// An empty store.
    pub fn new() -> Self {
        Self::default()
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.x.len()
    }

    /// True when there are no particles.
    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }

    /// Appends a particle and returns its index; assigns a fresh stable id.
    pub fn push(&mut self, x: Vec3, v: Vec3, mass: Real, radius: Real, codim: Codim) -> usize {
        let i = self.x.len();
        self.x.push(x);
        self.v.push(v);
        self.mass.push(mass);
        self.radius.push(radius);
        self.codim.push(codim);
        self.id.push(self.next_id);
        self.fixed.push(false);
        self.next_id += 1;
        i
    }

    /// Moves every particle of `other` to the end of this store (ids kept;
    /// the next id is the larger of the two).
    pub fn append(&mut self, other: Particles) {
        self.next_id = self.next_id.max(other.next_id);
        self.x.extend(other.x);
        self.v.extend(other.v);
        self.mass.extend(other.mass);
        self.radius.extend(other.radius);
        self.codim.extend(other.codim);
        self.id.extend(other.id);
        self.fixed.extend(other.fixed);
    }

    /// Reorders the store: particle k becomes the old particle `order[k]`
    /// (`order` is a permutation of `0..len`).
    pub fn permute(&mut self, order: &[usize]) {
        assert_eq!(order.len(), self.len(), "permutation length");
        self.select(order);
    }

    /// Keeps the particles for which `keep[i]` is true, preserving order.
    pub fn retain(&mut self, keep: &[bool]) {
        assert_eq!(keep.len(), self.len(), "retain mask length");
        let kept: Vec<usize> = (0..keep.len()).filter(|&i| keep[i]).collect();
        self.select(&kept);
    }

    /// Keeps the particles `idx`, in that order: particle k becomes the old
    /// particle `idx[k]`. Every column moves together.
    fn select(&mut self, idx: &[usize]) {
        fn take<T: Clone>(v: &mut Vec<T>, idx: &[usize]) {
            *v = idx.iter().map(|&i| v[i].clone()).collect();
        }
        take(&mut self.x, idx);
        take(&mut self.v, idx);
        take(&mut self.mass, idx);
        take(&mut self.radius, idx);
        take(&mut self.codim, idx);
        take(&mut self.id, idx);
        take(&mut self.fixed, idx);
    }

    /// Indices of the particles of one codimension, in store order.
    pub fn indices_of(&self, c: Codim) -> Vec<usize> {
        (0..self.len()).filter(|&i| self.codim[i] == c).collect()
    }

    /// Number of particles of each codimension, indexed by C.
    pub fn counts(&self) -> [usize; 4] {
        let mut n = [0usize; 4];
        for c in &self.codim {
            n[*c as usize] += 1;
        }
        n
    }

    /// Total mass (kg), summed in id order (deterministic).
    pub fn total_mass(&self) -> Real {
        // summed in id order, so the sum does not depend on the order of
        // the store ([`spatial_order`] reorders it every frame)
        let mut m: Vec<(u64, Real)> = self
            .id
            .iter()
            .copied()
            .zip(self.mass.iter().copied())
            .collect();
        m.sort_unstable_by_key(|e| e.0);
        m.iter().map(|e| e.1).sum()
    }

    /// True when every position, velocity, mass and radius is finite.
    pub fn all_finite(&self) -> bool {
        self.x.iter().all(|p| p.iter().all(|c| c.is_finite()))
            && self.v.iter().all(|p| p.iter().all(|c| c.is_finite()))
            && self.mass.iter().all(|m| m.is_finite())
            && self.radius.iter().all(|r| r.is_finite())
    }
}

/// Largest cell coordinate per axis of [`spatial_order`] (21 bits).
const MORTON_MAX: u64 = (1 << 21) - 1;

/// Spreads the low 21 bits of `v` to every third bit (bit k → bit 3k).
fn spread3(mut v: u64) -> u64 {
    v &= MORTON_MAX;
    v = (v | v << 32) & 0x001f_0000_0000_ffff;
    v = (v | v << 16) & 0x001f_0000_ff00_00ff;
    v = (v | v << 8) & 0x100f_00f0_0f00_f00f;
    v = (v | v << 4) & 0x10c3_0c30_c30c_30c3;
    (v | v << 2) & 0x1249_2492_4924_9249
}

/// The store's indices in Morton (Z-curve) order of the cells of size
/// `cell` that hold the particles, ties broken by id: particles close in
/// space come close in memory. A pure function of positions and ids, so a
/// resumed run orders its particles as the run it continues.
///
/// Why: reseeding appends new particles at the end and removal compacts in
/// place, so after a few frames of a stretching film the neighbours of a
/// particle lie all over memory; every stage that walks neighbour lists (MLS
/// fits, forces, reseeding, the ILU(0) of the tension solve) then misses
/// the cache (docs/decisions.md, "Particles in space order").
pub fn spatial_order(p: &Particles, cell: Real) -> Vec<usize> {
    let lo =
        p.x.iter()
            .fold(Vec3::repeat(Real::INFINITY), |m, x| m.inf(x));
    let q = |t: Real| ((t / cell).max(0.0) as u64).min(MORTON_MAX);
    let mut keys: Vec<(u64, u64, usize)> =
        p.x.iter()
            .zip(&p.id)
            .enumerate()
            .map(|(i, (x, &id))| {
                let d = x - lo;
                let key = spread3(q(d.x)) | spread3(q(d.y)) << 1 | spread3(q(d.z)) << 2;
                (key, id, i)
            })
            .collect();
    keys.sort_unstable();
    keys.into_iter().map(|k| k.2).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn push_retain_keeps_columns_aligned() {
        let mut p = Particles::new();
        for i in 0..5 {
            let c = Codim::from_number((i % 4) as u8).unwrap();
            p.push(
                Vec3::new(i as Real, 0.0, 0.0),
                Vec3::zeros(),
                1.0 + i as Real,
                0.1,
                c,
            );
        }
        p.retain(&[true, false, true, false, true]);
        assert_eq!(p.len(), 3);
        assert_eq!(p.id, vec![0, 2, 4]);
        assert_eq!(p.mass, vec![1.0, 3.0, 5.0]);
        assert_eq!(p.codim, vec![Codim::Volume, Codim::Filament, Codim::Volume]);
        assert_eq!(p.counts(), [2, 0, 1, 0]);
        assert_eq!(p.next_id, 5);
    }

    #[test]
    fn spatial_order_is_a_permutation_that_keeps_columns_aligned_and_groups_cells() {
        // particles of four far-apart cells, pushed in interleaved order
        let mut p = Particles::new();
        let corners = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(9.0, 0.0, 0.0),
            Vec3::new(0.0, 9.0, 0.0),
            Vec3::new(0.0, 0.0, 9.0),
        ];
        for k in 0..12 {
            let c = corners[k % 4] + Vec3::repeat(0.1 * (k / 4) as Real);
            p.push(
                c,
                Vec3::new(k as Real, 0.0, 0.0),
                k as Real,
                0.1,
                Codim::Sheet,
            );
        }
        let order = spatial_order(&p, 1.0);
        let mut seen = order.clone();
        seen.sort_unstable();
        assert_eq!(seen, (0..12).collect::<Vec<_>>());
        let mut q = p.clone();
        q.permute(&order);
        for k in 0..12 {
            // every column moved together: id k carries mass k and v.x = k
            assert_eq!(q.mass[k], q.id[k] as Real);
            assert_eq!(q.v[k].x, q.id[k] as Real);
        }
        // each cell's three particles are contiguous, in id order, and the
        // cells follow the Z-curve: (0,0,0), x, y, z
        let ids: Vec<u64> = q.id.clone();
        assert_eq!(ids, vec![0, 4, 8, 1, 5, 9, 2, 6, 10, 3, 7, 11]);
        // a pure function of the particles
        assert_eq!(spatial_order(&q, 1.0), (0..12).collect::<Vec<_>>());
    }

    #[test]
    fn spread3_interleaves_bits() {
        assert_eq!(spread3(0b1), 0b1);
        assert_eq!(spread3(0b11), 0b1001);
        assert_eq!(spread3(MORTON_MAX), 0x1249_2492_4924_9249);
    }

    #[test]
    fn codim_numbers_round_trip() {
        for c in Codim::ALL {
            assert_eq!(Codim::from_number(c.number()), Some(c));
        }
        assert_eq!(Codim::from_number(4), None);
    }
}
