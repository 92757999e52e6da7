//! The sparse narrow-band level set: 8³ leaves of signed distance (inside negative) and velocity,
//! keyed by their origin, plus a list of interior leaf-sized tiles (−background). Memory is
//! proportional to the surface: a leaf exists only where some voxel lies within the band
//! |φ| < `band`·Δx. The leaf layout matches OpenVDB's 5-4-3 tree so the writer in [`crate::vdb`]
//! copies leaves as they are.
//!
//! [`WorkGrid`] is the mutable form used while building (redistancing, unioning primitives).
use crate::hash::{FxMap, Key};
use crate::{Real, Vec3};
use rayon::prelude::*;

/// Voxels per leaf edge.
pub const LEAF_DIM: i32 = 8;
/// Voxels per leaf.
pub const LEAF_SIZE: usize = 512;

/// Origin (lowest voxel) of the leaf containing voxel `ijk`.
#[inline]
pub fn leaf_origin(ijk: Key) -> Key {
    [ijk[0] & !7, ijk[1] & !7, ijk[2] & !7]
}

/// Linear index of voxel `ijk` inside its leaf (OpenVDB order: z fastest).
#[inline]
pub fn voxel_index(ijk: Key) -> usize {
    (((ijk[0] & 7) << 6) | ((ijk[1] & 7) << 3) | (ijk[2] & 7)) as usize
}

/// Voxel coordinates of linear index `n` in the leaf at `origin`.
#[inline]
pub fn voxel_of(origin: Key, n: usize) -> Key {
    let n = n as i32;
    [
        origin[0] + (n >> 6),
        origin[1] + ((n >> 3) & 7),
        origin[2] + (n & 7),
    ]
}

/// One finished leaf.
#[derive(Debug, Clone)]
pub struct Leaf {
    /// voxel coordinates of voxel 0
    pub origin: Key,
    /// signed distance (m), clamped to ±background; inside negative
    pub phi: Box<[f32; LEAF_SIZE]>,
    /// velocity (m/s) of the active voxels, in voxel order (inactive voxels have none: 0 in the
    /// `v` grid)
    pub vel: Vec<[f32; 3]>,
    /// active voxels (|φ| < background), bit n of word n/64
    pub active: [u64; 8],
}

impl Leaf {
    /// Velocity of voxel `n` if it is active.
    #[inline]
    pub fn vel_at(&self, n: usize) -> Option<[f32; 3]> {
        let (w, b) = (n >> 6, n & 63);
        if self.active[w] >> b & 1 == 0 {
            return None;
        }
        let rank = self.active[..w]
            .iter()
            .map(|x| x.count_ones() as usize)
            .sum::<usize>()
            + (self.active[w] & ((1u64 << b) - 1)).count_ones() as usize;
        self.vel.get(rank).copied()
    }
}

/// A finished sparse level set with voxel centres at `ijk · voxel`.
#[derive(Debug, Clone, Default)]
pub struct LevelSet {
    /// voxel size Δx (m)
    pub voxel: Real,
    /// background = band half width (m)
    pub background: f32,
    /// leaves sorted by origin
    pub leaves: Vec<Leaf>,
    /// origins of leaf-sized regions entirely inside (value −background), sorted
    pub inside: Vec<Key>,
    index: FxMap<Key, u32>,
    inside_set: FxMap<Key, ()>,
}

impl LevelSet {
    /// Assembles a level set from leaves and interior tiles (both are sorted here).
    pub fn new(voxel: Real, background: f32, mut leaves: Vec<Leaf>, mut inside: Vec<Key>) -> Self {
        leaves.par_sort_unstable_by_key(|l| l.origin);
        inside.sort_unstable();
        let index = leaves
            .iter()
            .enumerate()
            .map(|(i, l)| (l.origin, i as u32))
            .collect();
        let inside_set = inside.iter().map(|k| (*k, ())).collect();
        LevelSet {
            voxel,
            background,
            leaves,
            inside,
            index,
            inside_set,
        }
    }

    /// The leaf with this origin, if present.
    pub fn leaf(&self, origin: Key) -> Option<&Leaf> {
        self.index.get(&origin).map(|&i| &self.leaves[i as usize])
    }

    /// φ at voxel `ijk` (±background away from the band).
    pub fn value(&self, ijk: Key) -> f32 {
        let o = leaf_origin(ijk);
        match self.leaf(o) {
            Some(l) => l.phi[voxel_index(ijk)],
            None if self.inside_set.contains_key(&o) => -self.background,
            None => self.background,
        }
    }

    /// Velocity at voxel `ijk` (zero away from the band).
    pub fn velocity(&self, ijk: Key) -> Vec3 {
        match self.leaf(leaf_origin(ijk)) {
            Some(l) => match l.vel_at(voxel_index(ijk)) {
                Some(v) => Vec3::new(v[0] as Real, v[1] as Real, v[2] as Real),
                None => Vec3::zeros(),
            },
            None => Vec3::zeros(),
        }
    }

    /// Trilinear interpolation of φ at world point `p`.
    pub fn sample(&self, p: &Vec3) -> Real {
        let q = p / self.voxel;
        let b = [q.x.floor(), q.y.floor(), q.z.floor()];
        let f = [q.x - b[0], q.y - b[1], q.z - b[2]];
        let b = [b[0] as i32, b[1] as i32, b[2] as i32];
        let mut s = 0.0;
        for c in 0..8 {
            let (dx, dy, dz) = (c >> 2 & 1, c >> 1 & 1, c & 1);
            let w = (if dx == 1 { f[0] } else { 1.0 - f[0] })
                * (if dy == 1 { f[1] } else { 1.0 - f[1] })
                * (if dz == 1 { f[2] } else { 1.0 - f[2] });
            s += w * self.value([b[0] + dx, b[1] + dy, b[2] + dz]) as Real;
        }
        s
    }

    /// Number of active voxels.
    pub fn active_count(&self) -> usize {
        self.leaves
            .iter()
            .map(|l| {
                l.active
                    .iter()
                    .map(|w| w.count_ones() as usize)
                    .sum::<usize>()
            })
            .sum()
    }

    /// Bytes held by the leaves and tiles.
    pub fn memory_bytes(&self) -> usize {
        self.leaves
            .iter()
            .map(|l| std::mem::size_of::<Leaf>() + LEAF_SIZE * 4 + l.vel.len() * 12)
            .sum::<usize>()
            + self.inside.len() * 24
    }
}

/// A primitive unioned into the level set: its exact (or conservative) signed distance.
#[derive(Debug, Clone, Copy)]
pub enum Prim {
    /// a rounded disk (pancake): centre, unit normal, radius, half thickness
    Disk {
        /// centre (m)
        c: Vec3,
        /// unit normal
        n: Vec3,
        /// outer radius (m)
        r: Real,
        /// half thickness (m)
        t: Real,
    },
    /// a capsule with radii interpolated along its axis
    Capsule {
        /// end a (m)
        a: Vec3,
        /// end b (m)
        b: Vec3,
        /// radius at a (m)
        ra: Real,
        /// radius at b (m)
        rb: Real,
    },
    /// a sphere
    Sphere {
        /// centre (m)
        c: Vec3,
        /// radius (m)
        r: Real,
    },
}

impl Prim {
    /// Signed distance at `p` (inside negative).
    pub fn sdf(&self, p: &Vec3) -> Real {
        match *self {
            Prim::Disk { c, n, r, t } => {
                let q = p - c;
                let z = q.dot(&n);
                let rad = (q - z * n).norm();
                let core = (r - t).max(0.0);
                let dr = (rad - core).max(0.0);
                (dr * dr + z * z).sqrt() - t
            }
            Prim::Capsule { a, b, ra, rb } => {
                let ab = b - a;
                let l2 = ab.norm_squared();
                let s = if l2 > 0.0 {
                    ((p - a).dot(&ab) / l2).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                (p - (a + s * ab)).norm() - (ra + s * (rb - ra))
            }
            Prim::Sphere { c, r } => (p - c).norm() - r,
        }
    }

    /// Axis-aligned bounding box (min, max).
    pub fn bbox(&self) -> (Vec3, Vec3) {
        match *self {
            Prim::Disk { c, r, t, .. } => {
                let e = Vec3::repeat(r + t);
                (c - e, c + e)
            }
            Prim::Capsule { a, b, ra, rb } => {
                let e = Vec3::repeat(ra.max(rb));
                (a.inf(&b) - e, a.sup(&b) + e)
            }
            Prim::Sphere { c, r } => (c - Vec3::repeat(r), c + Vec3::repeat(r)),
        }
    }
}

/// A leaf under construction (boxed, so that [`WorkGrid::finish`] frees each as it is converted).
#[derive(Clone)]
pub struct WorkLeaf {
    /// origin
    pub origin: Key,
    /// φ (m)
    pub phi: [f32; LEAF_SIZE],
    /// closest surface point of each set voxel, as an offset from the voxel in units of
    /// [`crate::redistance::CP_UNIT`] voxels ([`LEAF_SIZE`] entries while the band is propagated,
    /// then freed: the later stages only need φ)
    pub cp: Vec<[i16; 3]>,
    /// velocity source of each set voxel: index into [`WorkGrid::sources`]
    pub src: [u32; LEAF_SIZE],
    /// voxels whose φ has been computed
    pub set: [u64; 8],
}

impl WorkLeaf {
    /// A leaf whose voxels hold −background where `inside` (bit n of word n/64) and +background
    /// elsewhere.
    pub fn new(origin: Key, bg: f32, inside: [u64; 8]) -> Box<Self> {
        let mut l = Box::new(WorkLeaf {
            origin,
            phi: [bg; LEAF_SIZE],
            cp: vec![[0; 3]; LEAF_SIZE],
            src: [u32::MAX; LEAF_SIZE],
            set: [0; 8],
        });
        for (n, v) in l.phi.iter_mut().enumerate() {
            if inside[n >> 6] >> (n & 63) & 1 == 1 {
                *v = -bg;
            }
        }
        l
    }
    /// Is voxel `n` set?
    #[inline]
    pub fn is_set(&self, n: usize) -> bool {
        self.set[n >> 6] >> (n & 63) & 1 == 1
    }
}

/// The mutable level set used while building.
pub struct WorkGrid {
    /// voxel size (m)
    pub voxel: Real,
    /// background (m)
    pub bg: f32,
    /// leaves
    pub leaves: Vec<Box<WorkLeaf>>,
    /// origin → index into `leaves`
    pub index: FxMap<Key, usize>,
    /// velocities of the surface points (seeds, then primitives) that voxels take theirs from
    pub sources: Vec<[f32; 3]>,
}

impl WorkGrid {
    /// An empty grid.
    pub fn new(voxel: Real, bg: f32) -> Self {
        WorkGrid {
            voxel,
            bg,
            leaves: Vec::new(),
            index: FxMap::default(),
            sources: Vec::new(),
        }
    }

    /// World position of voxel `ijk`.
    #[inline]
    pub fn world(&self, ijk: Key) -> Vec3 {
        Vec3::new(ijk[0] as Real, ijk[1] as Real, ijk[2] as Real) * self.voxel
    }

    /// Index of the leaf at `origin`, creating it with the inside mask `inside(origin)`.
    pub fn ensure(&mut self, origin: Key, inside: &(impl Fn(Key) -> [u64; 8] + Sync)) -> usize {
        if let Some(&i) = self.index.get(&origin) {
            return i;
        }
        self.leaves
            .push(WorkLeaf::new(origin, self.bg, inside(origin)));
        self.index.insert(origin, self.leaves.len() - 1);
        self.leaves.len() - 1
    }

    /// Unions primitives (with their velocities) into the grid: φ = min(φ, sdf), velocity taken
    /// from the primitive wherever it is the closest surface. Primitives are applied in index
    /// order within each leaf, so the result does not depend on the thread count.
    pub fn union_prims(
        &mut self,
        prims: &[(Prim, Vec3)],
        inside: &(impl Fn(Key) -> [u64; 8] + Sync),
    ) {
        let h = self.voxel;
        let margin = self.bg as Real + h;
        let mut pairs: Vec<(Key, u32)> = Vec::new();
        let mut boxes = Vec::with_capacity(prims.len());
        for (pi, (p, _)) in prims.iter().enumerate() {
            let (lo, hi) = p.bbox();
            let lo = ((lo - Vec3::repeat(margin)) / h).map(|x| x.ceil() as i32);
            let hi = ((hi + Vec3::repeat(margin)) / h).map(|x| x.floor() as i32);
            boxes.push((lo, hi));
            let (ol, oh) = (
                leaf_origin([lo.x, lo.y, lo.z]),
                leaf_origin([hi.x, hi.y, hi.z]),
            );
            let mut x = ol[0];
            while x <= oh[0] {
                let mut y = ol[1];
                while y <= oh[1] {
                    let mut z = ol[2];
                    while z <= oh[2] {
                        pairs.push(([x, y, z], pi as u32));
                        z += LEAF_DIM;
                    }
                    y += LEAF_DIM;
                }
                x += LEAF_DIM;
            }
        }
        pairs.par_sort_unstable();
        let mut lists: Vec<Vec<u32>> = vec![Vec::new(); self.leaves.len()];
        for (k, pi) in pairs {
            let li = self.ensure(k, inside);
            if li >= lists.len() {
                lists.resize(li + 1, Vec::new());
            }
            lists[li].push(pi);
        }
        let bg = self.bg;
        let base = self.sources.len() as u32;
        self.sources.extend(
            prims
                .iter()
                .map(|(_, v)| [v.x as f32, v.y as f32, v.z as f32]),
        );
        self.leaves
            .par_iter_mut()
            .zip(lists.par_iter())
            .for_each(|(leaf, list)| {
                for &pi in list {
                    let (prim, _) = &prims[pi as usize];
                    let (lo, hi) = boxes[pi as usize];
                    let o = leaf.origin;
                    for x in lo.x.max(o[0])..=hi.x.min(o[0] + 7) {
                        for y in lo.y.max(o[1])..=hi.y.min(o[1] + 7) {
                            for z in lo.z.max(o[2])..=hi.z.min(o[2] + 7) {
                                let p = Vec3::new(x as Real, y as Real, z as Real) * h;
                                let d = prim.sdf(&p).clamp(-(bg as Real), bg as Real) as f32;
                                let n = voxel_index([x, y, z]);
                                if d < leaf.phi[n] {
                                    leaf.phi[n] = d;
                                    leaf.src[n] = base + pi;
                                    leaf.set[n >> 6] |= 1 << (n & 63);
                                }
                            }
                        }
                    }
                }
            });
    }

    /// Finishes: clamps, marks active voxels, drops leaves without active voxels (recording those
    /// inside as interior tiles, together with `extra_inside` leaf origins).
    pub fn finish(self, extra_inside: Vec<Key>) -> LevelSet {
        let bg = self.bg;
        let present: FxMap<Key, ()> = self.leaves.iter().map(|l| (l.origin, ())).collect();
        let sources = &self.sources;
        let done: Vec<(Option<Leaf>, Option<Key>)> = self
            .leaves
            .into_par_iter()
            .map(|w| {
                let mut active = [0u64; 8];
                let mut phi = Box::new([0f32; LEAF_SIZE]);
                let mut neg = 0;
                for n in 0..LEAF_SIZE {
                    let v = w.phi[n].clamp(-bg, bg);
                    if v.abs() < bg {
                        active[n >> 6] |= 1 << (n & 63);
                    } else {
                        // inactive voxels hold exactly ±background
                        phi[n] = if v < 0.0 { -bg } else { bg };
                    }
                    if v.abs() < bg {
                        phi[n] = v;
                    }
                    neg += (v < 0.0) as usize;
                }
                if active.iter().all(|&a| a == 0) {
                    return (None, (neg * 2 > LEAF_SIZE).then_some(w.origin));
                }
                let mut vel = Vec::with_capacity(
                    active
                        .iter()
                        .map(|a| a.count_ones() as usize)
                        .sum::<usize>(),
                );
                for n in 0..LEAF_SIZE {
                    if active[n >> 6] >> (n & 63) & 1 == 1 {
                        vel.push(sources.get(w.src[n] as usize).copied().unwrap_or([0.0; 3]));
                    }
                }
                (
                    Some(Leaf {
                        origin: w.origin,
                        phi,
                        vel,
                        active,
                    }),
                    None,
                )
            })
            .collect();
        let mut leaves = Vec::new();
        let mut inside = Vec::new();
        for (l, k) in done {
            leaves.extend(l);
            inside.extend(k);
        }
        inside.extend(
            extra_inside
                .into_iter()
                .filter(|k| !present.contains_key(k)),
        );
        inside.sort_unstable();
        inside.dedup();
        LevelSet::new(self.voxel, bg, leaves, inside)
    }
}
