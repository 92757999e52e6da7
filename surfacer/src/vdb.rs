//! OpenVDB writer for the level set (`surface`, FloatGrid, class `level set`) and its velocity
//! (`v`, Vec3SGrid), in OpenVDB's own file format version 224 with a 5-4-3 tree, zip and
//! active-mask compression (leaf buffers hold their active values only, as OpenVDB writes level
//! sets). vdb-rs only reads, and no maintained Rust crate writes VDB; the layout follows
//! OpenVDB's `io/Archive.cc`, `io/Compression.h` and the node classes (facts in
//! `shared/notes/vdb-format.md`, decision in `docs/decisions.md`).
//!
//! Layout: header (magic, version, library version, "has grid offsets", UUID, file metadata, grid
//! count); per grid a descriptor (name, type, parent, three stream offsets) and the grid
//! (compression flags, metadata, transform `UniformScaleMap`, topology, leaf buffers).
//! Topology: root (background, tiles, children sorted by origin) → 32³ internal nodes → 16³
//! internal nodes → 8³ leaves; each internal node writes child mask, value mask and its tile
//! values (metadata byte 6 "all values" + zipped buffer), then its children in index order.
//! Inactive voxels and tiles inside the surface hold −background (from [`LevelSet::inside`]), so
//! readers see the inside as inside.
use crate::hash::Key;
use crate::levelset::LevelSet;
use crate::SurfaceError;
use flate2::{Compress, Compression, FlushCompress, Status};
use rayon::prelude::*;
use std::collections::BTreeMap;
use std::io::Write;
use std::path::Path;

const COMPRESS_ZIP: u32 = 1;
/// `io::COMPRESS_ACTIVE_MASK`: leaf buffers may hold only their active values
const COMPRESS_ACTIVE_MASK: u32 = 2;
/// `io::Compression.h` per-buffer metadata: every inactive value is +background
const NO_MASK_OR_INACTIVE_VALS: u8 = 0;
/// every inactive value is −background
const NO_MASK_AND_MINUS_BG: u8 = 1;
/// inactive values are ±background, a selection mask (on: +background) follows
const MASK_AND_NO_INACTIVE_VALS: u8 = 3;
/// all 512 values follow
const ALL_VALUES: u8 = 6;

struct Out(Vec<u8>);

impl Out {
    fn u8(&mut self, v: u8) {
        self.0.push(v);
    }
    fn u32(&mut self, v: u32) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn i32(&mut self, v: i32) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn i64(&mut self, v: i64) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn f64(&mut self, v: f64) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn str(&mut self, s: &str) {
        self.u32(s.len() as u32);
        self.0.extend_from_slice(s.as_bytes());
    }
    fn mask(&mut self, words: &[u64]) {
        for w in words {
            self.0.extend_from_slice(&w.to_le_bytes());
        }
    }
    /// OpenVDB `zipToStream`: i64 size then zlib data, or −size then raw bytes. `c` is a
    /// compressor reused from buffer to buffer (its state is reset here; allocating a new one
    /// per leaf cost a few hundred kB each).
    fn zipped(&mut self, raw: &[u8], c: &mut Compress) {
        match zlib(c, raw) {
            Some(z) if z.len() < raw.len() => {
                self.i64(z.len() as i64);
                self.0.extend_from_slice(&z);
            }
            _ => {
                self.i64(-(raw.len() as i64));
                self.0.extend_from_slice(raw);
            }
        }
    }
    fn values(&mut self, raw: &[u8]) {
        self.u8(ALL_VALUES);
        with_compressor(|c| self.zipped(raw, c));
    }
}

/// Calls `f` with this thread's zlib compressor (level 1), created on first use and kept: a new
/// one allocates and clears a few hundred kB, and the writer compresses ~20 k buffers per file.
/// [`zlib`] resets it before each stream, so the output does not depend on what it compressed
/// before.
fn with_compressor<R>(f: impl FnOnce(&mut Compress) -> R) -> R {
    thread_local! {
        static ZIP: std::cell::RefCell<Option<Compress>> = const { std::cell::RefCell::new(None) };
    }
    ZIP.with(|z| {
        let mut z = z.borrow_mut();
        f(z.get_or_insert_with(|| Compress::new(Compression::fast(), true)))
    })
}

/// zlib stream of `raw` (None: the compressor failed or the result is not smaller).
fn zlib(c: &mut Compress, raw: &[u8]) -> Option<Vec<u8>> {
    c.reset();
    let mut z = Vec::with_capacity(raw.len() / 2 + 64);
    loop {
        let done = c.total_in() as usize;
        match c.compress_vec(&raw[done..], &mut z, FlushCompress::Finish) {
            Ok(Status::StreamEnd) => return Some(z),
            Ok(_) if z.len() < raw.len() => z.reserve(raw.len() / 2 + 64),
            _ => return None,
        }
    }
}

/// Internal-node hierarchy: level-2 origin → level-1 origin → (leaf slots, inside-tile slots).
type Tree = BTreeMap<Key, BTreeMap<Key, (Vec<usize>, Vec<usize>)>>;

fn mask_bit(words: &mut [u64], i: usize) {
    words[i >> 6] |= 1 << (i & 63);
}

fn n1_index(k: Key) -> usize {
    ((((k[0] & 127) >> 3) << 8) | (((k[1] & 127) >> 3) << 4) | ((k[2] & 127) >> 3)) as usize
}

fn n2_index(k: Key) -> usize {
    ((((k[0] & 4095) >> 7) << 10) | (((k[1] & 4095) >> 7) << 5) | ((k[2] & 4095) >> 7)) as usize
}

fn build_tree(ls: &LevelSet) -> Tree {
    let mut t: Tree = BTreeMap::new();
    let up = |k: Key, m: i32| [k[0] & !m, k[1] & !m, k[2] & !m];
    for (i, l) in ls.leaves.iter().enumerate() {
        let e = t.entry(up(l.origin, 4095)).or_default();
        e.entry(up(l.origin, 127)).or_default().0.push(i);
    }
    for (i, k) in ls.inside.iter().enumerate() {
        let e = t.entry(up(*k, 4095)).or_default();
        e.entry(up(*k, 127)).or_default().1.push(i);
    }
    t
}

/// Which grid is being written.
#[derive(Clone, Copy, PartialEq)]
enum Kind {
    Surface,
    Velocity,
}

/// Little-endian bytes of the values, 4 at a time (collecting a byte-wise `flat_map` cost ~3 %
/// of the surfacing CPU on the benchmark blob).
fn f32_bytes(v: impl Iterator<Item = f32>) -> Vec<u8> {
    let mut out = Vec::with_capacity(4 * v.size_hint().0);
    for x in v {
        out.extend_from_slice(&x.to_le_bytes());
    }
    out
}

fn write_grid(o: &mut Out, ls: &LevelSet, tree: &Tree, kind: Kind) {
    let (name, ty) = match kind {
        Kind::Surface => ("surface", "Tree_float_5_4_3"),
        Kind::Velocity => ("v", "Tree_vec3s_5_4_3"),
    };
    let comps = if kind == Kind::Surface { 1 } else { 3 };
    let bg = if kind == Kind::Surface {
        ls.background
    } else {
        0.0
    };
    o.str(name);
    o.str(ty);
    o.str("");
    let offsets_at = o.0.len();
    o.i64(0);
    o.i64(0);
    o.i64(0);
    let grid_pos = o.0.len();
    o.u32(COMPRESS_ZIP | COMPRESS_ACTIVE_MASK);
    // metadata
    let class = if kind == Kind::Surface {
        "level set"
    } else {
        "unknown"
    };
    let mut meta: Vec<(&str, &str)> = vec![("class", class), ("name", name)];
    if kind == Kind::Velocity {
        meta.push(("vector_type", "contravariant relative"));
    }
    o.u32(meta.len() as u32);
    for (k, v) in meta {
        o.str(k);
        o.str("string");
        o.str(v);
    }
    // transform
    let h = ls.voxel;
    o.str("UniformScaleMap");
    for v in [h, h, 1.0 / h, 1.0 / (h * h), 0.5 / h] {
        for _ in 0..3 {
            o.f64(v);
        }
    }
    // topology
    o.u32(1);
    for _ in 0..comps {
        o.0.extend_from_slice(&bg.to_le_bytes());
    }
    o.u32(0);
    o.u32(tree.len() as u32);
    let tile = |inside: bool| -> [f32; 3] {
        match kind {
            Kind::Surface => [if inside { -bg } else { bg }, 0.0, 0.0],
            Kind::Velocity => [0.0; 3],
        }
    };
    let push_val = |buf: &mut Vec<f32>, v: [f32; 3]| buf.extend_from_slice(&v[..comps]);
    for (o2, n1s) in tree {
        for c in o2 {
            o.i32(*c);
        }
        let mut child2 = vec![0u64; 512];
        for o1 in n1s.keys() {
            mask_bit(&mut child2, n2_index(*o1));
        }
        o.mask(&child2);
        o.mask(&vec![0u64; 512]);
        let mut vals = Vec::with_capacity(32768 * comps);
        for i in 0..32768 {
            let is_child = child2[i >> 6] >> (i & 63) & 1 == 1;
            push_val(&mut vals, if is_child { [0.0; 3] } else { tile(false) });
        }
        o.values(&f32_bytes(vals.into_iter()));
        for (o1, (leaves, insides)) in n1s {
            let mut child1 = vec![0u64; 64];
            for &l in leaves {
                mask_bit(&mut child1, n1_index(ls.leaves[l].origin));
            }
            let mut inside1 = vec![false; 4096];
            for &k in insides {
                inside1[n1_index(ls.inside[k])] = true;
            }
            o.mask(&child1);
            o.mask(&[0u64; 64]);
            let mut vals = Vec::with_capacity(4096 * comps);
            for (i, &ins) in inside1.iter().enumerate() {
                let is_child = child1[i >> 6] >> (i & 63) & 1 == 1;
                push_val(&mut vals, if is_child { [0.0; 3] } else { tile(ins) });
            }
            o.values(&f32_bytes(vals.into_iter()));
            let _ = o1;
            // leaves in index order (leaves are sorted by origin, which is index order here)
            let mut ls_sorted = leaves.clone();
            ls_sorted.sort_by_key(|&l| n1_index(ls.leaves[l].origin));
            for l in ls_sorted {
                o.mask(&ls.leaves[l].active);
            }
        }
    }
    // buffers, same order: all leaves in tree order, encoded in parallel in chunks (few
    // fork-joins, bounded memory) and appended in order
    let block_pos = o.0.len();
    let mut order: Vec<usize> = Vec::with_capacity(ls.leaves.len());
    for n1s in tree.values() {
        for (leaves, _) in n1s.values() {
            let start = order.len();
            order.extend_from_slice(leaves);
            order[start..].sort_by_key(|&l| n1_index(ls.leaves[l].origin));
        }
    }
    for chunk in order.chunks(4096) {
        let bufs: Vec<Vec<u8>> = chunk
            .par_iter()
            .map(|&l| with_compressor(|c| leaf_buffer(&ls.leaves[l], kind, bg, c)))
            .collect();
        for b in bufs {
            o.0.extend_from_slice(&b);
        }
    }
    let end_pos = o.0.len();
    let mut at = offsets_at;
    for v in [grid_pos, block_pos, end_pos] {
        o.0[at..at + 8].copy_from_slice(&(v as i64).to_le_bytes());
        at += 8;
    }
}

/// One leaf's buffer: its active mask, then its values with OpenVDB's mask compression (what it
/// writes for level sets itself): only the active values, the inactive ones being ±background (a
/// selection mask says which) for φ and background (0) for the velocity.
fn leaf_buffer(leaf: &crate::levelset::Leaf, kind: Kind, bg: f32, c: &mut Compress) -> Vec<u8> {
    let mut b = Out(Vec::new());
    b.mask(&leaf.active);
    let on = |n: usize| leaf.active[n >> 6] >> (n & 63) & 1 == 1;
    let raw = match kind {
        Kind::Surface => {
            let (mut plus, mut minus, mut other) = (false, false, false);
            let mut sel = [0u64; 8];
            for n in (0..512).filter(|&n| !on(n)) {
                let v = leaf.phi[n];
                if v == bg {
                    plus = true;
                    sel[n >> 6] |= 1 << (n & 63);
                } else if v == -bg {
                    minus = true;
                } else {
                    other = true;
                }
            }
            if other {
                b.u8(ALL_VALUES);
                b.zipped(&f32_bytes(leaf.phi.iter().copied()), c);
                return b.0;
            }
            if plus && minus {
                b.u8(MASK_AND_NO_INACTIVE_VALS);
                b.mask(&sel);
            } else if minus {
                b.u8(NO_MASK_AND_MINUS_BG);
            } else {
                b.u8(NO_MASK_OR_INACTIVE_VALS);
            }
            f32_bytes((0..512).filter(|&n| on(n)).map(|n| leaf.phi[n]))
        }
        Kind::Velocity => {
            b.u8(NO_MASK_OR_INACTIVE_VALS);
            f32_bytes((0..512).filter_map(|n| leaf.vel_at(n)).flatten())
        }
    };
    b.zipped(&raw, c);
    b.0
}

/// Encodes the level set and its velocity as a VDB file in memory.
pub fn encode(ls: &LevelSet) -> Vec<u8> {
    let tree = build_tree(ls);
    let mut o = Out(Vec::new());
    o.i64(0x5644_4220);
    o.u32(224);
    o.u32(10);
    o.u32(0);
    o.u8(1);
    // a UUID derived from the contents, so identical inputs give identical files
    let mut hsh = crate::hash::FxHasher::default();
    use std::hash::Hasher;
    for l in &ls.leaves {
        hsh.write_i32(l.origin[0]);
        hsh.write_i32(l.origin[1]);
        hsh.write_i32(l.origin[2]);
    }
    hsh.write_u64(ls.voxel.to_bits());
    let a = hsh.finish();
    let b = a.rotate_left(29) ^ 0x9E37_79B9_7F4A_7C15;
    let hex = format!("{a:016x}{b:016x}");
    let uuid = format!(
        "{}-{}-{}-{}-{}",
        &hex[0..8],
        &hex[8..12],
        &hex[12..16],
        &hex[16..20],
        &hex[20..32]
    );
    o.0.extend_from_slice(uuid.as_bytes());
    o.u32(0);
    o.u32(2);
    write_grid(&mut o, ls, &tree, Kind::Surface);
    write_grid(&mut o, ls, &tree, Kind::Velocity);
    o.0
}

/// Writes `surface` and `v` to `path`, atomically.
pub fn write_vdb(path: &Path, ls: &LevelSet) -> Result<(), SurfaceError> {
    let bytes = encode(ls);
    crate::ply::write_atomically(path, |w| w.write_all(&bytes))
}
