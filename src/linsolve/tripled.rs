//! The coupled system's particle block, stored once for three components.
//!
//! In eq. (24)'s monolithic form, ordered particles first
//! ([`crate::coupling::system::IluOrder::ParticlesFirst`]), rows and columns
//! `3s + d` (d = x, y, z) are component d of the particle in slot s, and
//! the particle–particle block is `I₃ ⊗ P`: the mass −m̂ and the implicit
//! tension ĉ L (eqs. 21/22) act on each component alike. A general sparse
//! row format stores P three times, with three column indices; this one
//! stores it once and reads the three components of a neighbour from
//! consecutive memory. Everything else (the particle rows' entries in the
//! λ columns, the λ and pressure rows) stays in general compressed rows.
//!
//! Its ILU(0) keeps the same sharing. The particle rows come first, and a
//! particle row's entries left of its diagonal are particle entries of
//! its own component, so eliminating them repeats P's elimination for
//! each component: L, the particle part of U and the pivots are P's ILU(0)
//! three times over, which [`super::TripledIlu::from_tripled`] computes once.
//! The factorisation, the products and the triangular solves update and
//! sum every entry in the general format's order, so both give
//! bit-identical results (tested), the shared one with about a third of the
//! work and memory traffic for the particle block (`docs/benchmarks.md`).

use super::ilu0::Triangle;
use super::{Csr, Operator, SolveError};
use rayon::prelude::*;

/// Rows of at least this many particles are worked in parallel chunks.
const CHUNK: usize = 256;

/// `I₃ ⊗ P` on the first 3·np rows and columns, plus the rest.
#[derive(Debug, PartialEq)]
pub struct Tripled {
    pub(super) n: usize,
    pub(super) np: usize,
    /// Particle slots `..halves[0]` and `halves[0]..halves[1]` are not
    /// coupled by P (see [`super::split_halves`]); the triangular solves
    /// work the two in parallel.
    pub(super) halves: [usize; 2],
    /// P by particle slot (columns are particle slots).
    pub(super) p: Triangle,
    /// All other entries, by row of the whole matrix (columns ≥ 3·np in
    /// the particle rows).
    pub(super) rest: Triangle,
    /// Rows from here on (the pressure rows) are factorised and swept in
    /// order; the rows between 3·np and here (the impulse rows) in the
    /// independent blocks their pattern splits into ([`Tripled::with_sequential_tail`]).
    pub(super) seq_from: usize,
}

/// Splits each particle's three rows of `(col, val, rows)` into the shared
/// particle part (columns < 3·np, returned for component 0 as particle
/// slots) and the rest. `None` when the three rows differ in their particle
/// part or a particle entry couples two components. Only the tests convert
/// a general matrix (the assembly builds the shared form directly).
#[cfg(test)]
struct Split {
    shared: Triangle,
    rest: Triangle,
}

#[cfg(test)]
fn split(
    np: usize,
    n: usize,
    col: &[usize],
    val: &[f64],
    rows: impl Fn(usize) -> std::ops::Range<usize>,
    keep_rest: impl Fn(usize, usize) -> bool,
) -> Option<Split> {
    let n3 = 3 * np;
    let (mut sp, mut sc, mut sv) = (vec![0usize], Vec::new(), Vec::new());
    let (mut rp, mut rc, mut rv) = (vec![0usize], Vec::new(), Vec::new());
    for s in 0..np {
        let r0 = rows(3 * s);
        let m = r0.clone().take_while(|&k| col[k] < n3).count();
        for k in r0.start..r0.start + m {
            if !col[k].is_multiple_of(3) {
                return None;
            }
            sc.push((col[k] / 3) as u32);
            sv.push(val[k]);
        }
        sp.push(sc.len());
        for d in 0..3 {
            let r = rows(3 * s + d);
            let md = r.clone().take_while(|&k| col[k] < n3).count();
            if md != m {
                return None;
            }
            for (e, k) in (r.start..r.start + m).enumerate() {
                let k0 = r0.start + e;
                if col[k] != col[k0] + d || val[k].to_bits() != val[k0].to_bits() {
                    return None;
                }
            }
            for k in r.start + m..r.end {
                if keep_rest(3 * s + d, col[k]) {
                    rc.push(col[k] as u32);
                    rv.push(val[k]);
                }
            }
            rp.push(rc.len());
        }
    }
    for i in n3..n {
        for k in rows(i) {
            if keep_rest(i, col[k]) {
                rc.push(col[k] as u32);
                rv.push(val[k]);
            }
        }
        rp.push(rc.len());
    }
    Some(Split {
        shared: Triangle {
            ptr: sp,
            col: sc,
            val: sv,
        },
        rest: Triangle {
            ptr: rp,
            col: rc,
            val: rv,
        },
    })
}

/// `acc` ± Σ_k val[k] x[3 col[k] + d] over row `s` of `t`, for d = 0, 1, 2
/// (subtracting when `sub`).
#[inline]
fn shared_row(t: &Triangle, s: usize, x: &[f64], mut acc: [f64; 3], sub: bool) -> [f64; 3] {
    for k in t.ptr[s]..t.ptr[s + 1] {
        let c = 3 * t.col[k] as usize;
        let v = t.val[k];
        let xs = &x[c..c + 3];
        if sub {
            acc[0] -= v * xs[0];
            acc[1] -= v * xs[1];
            acc[2] -= v * xs[2];
        } else {
            acc[0] += v * xs[0];
            acc[1] += v * xs[1];
            acc[2] += v * xs[2];
        }
    }
    acc
}

impl Tripled {
    /// The shared form of `a` whose first 3·`np` rows and columns are `np`
    /// particles' components; `None` when `a` does not have that structure
    /// (then the general format serves). The tests' reference for the
    /// assembly's shared form.
    #[cfg(test)]
    pub fn from_csr(a: &Csr, np: usize) -> Option<Tripled> {
        let n = a.nrows;
        if a.ncols != n || 3 * np > n || n > u32::MAX as usize {
            return None;
        }
        let rp = a.row_ptr;
        let sp = split(np, n, a.col, a.val, |i| rp[i]..rp[i + 1], |_, _| true)?;
        Some(Tripled {
            n,
            np,
            halves: [np, np],
            p: sp.shared,
            rest: sp.rest,
            seq_from: n,
        })
    }

    /// From P's rows (by particle slot: sorted (slot, value) pairs) and the
    /// other entries of the whole matrix (`rest`, n × n, nothing in the
    /// particle block).
    /// `halves`: particle slots `..halves[0]` and `halves[0]..halves[1]`
    /// that P does not couple (checked).
    pub fn from_parts(
        np: usize,
        halves: [usize; 2],
        p: &[Vec<(u32, f64)>],
        rest: &Csr,
    ) -> Result<Tripled, SolveError> {
        let (n, n3) = (rest.nrows, 3 * np);
        if rest.ncols != n || p.len() != np || n3 > n || n > u32::MAX as usize {
            return Err(SolveError::Dimension(format!(
                "shared particle block of {} particles ({np} expected) in a {}×{} matrix",
                p.len(),
                rest.nrows,
                rest.ncols
            )));
        }
        let mut pt = Triangle {
            ptr: Vec::with_capacity(np + 1),
            col: Vec::with_capacity(p.iter().map(Vec::len).sum()),
            val: Vec::with_capacity(p.iter().map(Vec::len).sum()),
        };
        pt.ptr.push(0);
        for row in p {
            for &(c, v) in row {
                pt.col.push(c);
                pt.val.push(v);
            }
            pt.ptr.push(pt.col.len());
        }
        let mut rt = Triangle {
            ptr: Vec::with_capacity(n + 1),
            col: Vec::with_capacity(rest.val.len()),
            val: rest.val.to_vec(),
        };
        rt.ptr.extend_from_slice(rest.row_ptr);
        for i in 0..n {
            for k in rest.row_ptr[i]..rest.row_ptr[i + 1] {
                if i < n3 && rest.col[k] < n3 {
                    return Err(SolveError::Dimension(format!(
                        "entry ({i}, {}) inside the shared particle block",
                        rest.col[k]
                    )));
                }
                rt.col.push(rest.col[k] as u32);
            }
        }
        Tripled {
            n,
            np,
            halves: [np, np],
            p: pt,
            rest: rt,
            seq_from: n,
        }
        .with_halves(halves)
    }

    /// Lets the factorisation and the triangular solves work the rows
    /// 3·np..`from` in the blocks their pattern splits into (rows that
    /// reference no row of another block in these columns, such as the
    /// impulse rows of the three face axes), in parallel, before the rows
    /// `from`.. in order. The results are the same bit for bit: each row
    /// receives the same updates in the same order. Clamped to 3·np..n.
    pub fn with_sequential_tail(mut self, from: usize) -> Tripled {
        self.seq_from = from.clamp(3 * self.np, self.n);
        self
    }

    /// Declares particle slots `..halves[0]` and `halves[0]..halves[1]`
    /// independent (P couples neither to the other; checked), so that the
    /// triangular solves of [`super::TripledIlu`] work them in parallel.
    pub fn with_halves(mut self, halves: [usize; 2]) -> Result<Tripled, SolveError> {
        let [a, b] = halves;
        let p = &self.p;
        let crossing = |s: usize| {
            let other = if s < a { a..b } else { 0..a };
            (p.ptr[s]..p.ptr[s + 1]).any(|k| other.contains(&(p.col[k] as usize)))
        };
        if a > b || b > self.np || (0..b).any(crossing) {
            return Err(SolveError::Dimension(format!(
                "particle halves ..{a}, {a}..{b} of {} are coupled",
                self.np
            )));
        }
        self.halves = halves;
        Ok(self)
    }

    /// Stored entries (P once).
    pub fn stored(&self) -> usize {
        self.p.val.len() + self.rest.val.len()
    }

    /// Non-zeros of the matrix in general rows (P three times).
    pub fn nonzeros(&self) -> usize {
        3 * self.p.val.len() + self.rest.val.len()
    }
}

impl Operator for Tripled {
    fn dims(&self) -> (usize, usize) {
        (self.n, self.n)
    }

    fn matvec(&self, x: &[f64], y: &mut [f64]) {
        let (yp, yr) = y.split_at_mut(3 * self.np);
        let rest = &self.rest;
        yp.par_chunks_mut(3)
            .enumerate()
            .with_min_len(CHUNK)
            .for_each(|(s, ys)| {
                let acc = shared_row(&self.p, s, x, [0.0; 3], false);
                for d in 0..3 {
                    let i = 3 * s + d;
                    let mut a = acc[d];
                    for k in rest.ptr[i]..rest.ptr[i + 1] {
                        a += rest.val[k] * x[rest.col[k] as usize];
                    }
                    ys[d] = a;
                }
            });
        let n3 = 3 * self.np;
        yr.par_iter_mut()
            .enumerate()
            .with_min_len(CHUNK)
            .for_each(|(e, yi)| {
                let i = n3 + e;
                let mut a = 0.0;
                for k in rest.ptr[i]..rest.ptr[i + 1] {
                    a += rest.val[k] * x[rest.col[k] as usize];
                }
                *yi = a;
            });
    }

    fn all_finite(&self) -> bool {
        self.p
            .val
            .iter()
            .chain(&self.rest.val)
            .all(|v| v.is_finite())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::linsolve::{bicgstab, BicgstabParams, Ilu0};
    use crate::linsolve::{Preconditioner, TripledIlu};
    use faer::sparse::Triplet;

    /// A particle block I₃ ⊗ P (P a non-symmetric ring Laplacian with mass)
    /// coupled to `nk` face rows that each touch one component of a few
    /// particles, and `nq` cell rows on the faces, as eq. (24) is ordered.
    fn coupled(np: usize, nk: usize, nq: usize) -> (usize, Vec<Triplet<usize, usize, f64>>) {
        coupled_in(np, nk, nq, [np, np])
    }

    /// As [`coupled`], P's rings within slots `..a`, `a..b` and `b..`, and
    /// every fourth particle of the first two tied to one of the last.
    fn coupled_in(
        np: usize,
        nk: usize,
        nq: usize,
        [a, b]: [usize; 2],
    ) -> (usize, Vec<Triplet<usize, usize, f64>>) {
        let n = 3 * np + nk + nq;
        let mut t = Vec::new();
        let group = |s: usize| {
            if s < a {
                0..a
            } else if s < b {
                a..b
            } else {
                b..np
            }
        };
        for s in 0..np {
            let w = 1.0 + 0.1 * (s % 7) as f64;
            let g = group(s);
            let len = g.len();
            for d in 0..3 {
                let r = 3 * s + d;
                t.push(Triplet::new(r, r, -2.0 - w));
                for o in [1, 2, 5] {
                    let j = g.start + (s - g.start + o) % len;
                    t.push(Triplet::new(r, 3 * j + d, 0.3 * w / o as f64));
                    let j = g.start + (s - g.start + len - o % len) % len;
                    t.push(Triplet::new(r, 3 * j + d, 0.2 / o as f64));
                }
                if s < b && s % 4 == 0 && b < np {
                    let j = b + s % (np - b);
                    t.push(Triplet::new(r, 3 * j + d, 0.15));
                    t.push(Triplet::new(3 * j + d, r, 0.1));
                }
            }
        }
        for f in 0..nk {
            let m = 3 * np + f;
            // faces sorted by axis, as the assembly orders them
            let d = 3 * f / nk;
            t.push(Triplet::new(m, m, 1.5));
            for e in 0..3 {
                let s = (7 * f + 3 * e) % np;
                t.push(Triplet::new(m, 3 * s + d, -0.4));
                t.push(Triplet::new(3 * s + d, m, -0.4));
            }
            let c = 3 * np + nk + f % nq;
            t.push(Triplet::new(m, c, 0.7));
            t.push(Triplet::new(c, m, 0.7));
        }
        for c in 0..nq {
            let i = 3 * np + nk + c;
            t.push(Triplet::new(i, i, 4.0));
            if c + 1 < nq {
                t.push(Triplet::new(i, i + 1, -1.0));
                t.push(Triplet::new(i + 1, i, -1.0));
            }
        }
        (n, t)
    }

    #[test]
    fn the_shared_particle_block_gives_the_general_format_bit_for_bit() {
        let (n, t) = coupled(60, 25, 10);
        let m = faer::sparse::SparseRowMat::try_new_from_triplets(n, n, &t).unwrap();
        let a = Csr::from_faer(m.as_ref()).unwrap();
        let tr = Tripled::from_csr(&a, 60).expect("the particle block is I3 ⊗ P");
        assert!(
            tr.stored() < a.val.len() / 2,
            "{} of {}",
            tr.stored(),
            a.val.len()
        );
        let x: Vec<f64> = (0..n).map(|i| (i as f64 * 0.77).sin()).collect();
        let (mut y1, mut y2) = (vec![0.0; n], vec![0.0; n]);
        a.matvec(&x, &mut y1);
        Operator::matvec(&tr, &x, &mut y2);
        assert_eq!(y1, y2);
        let ilu = Ilu0::new(&a).unwrap();
        let tilu = TripledIlu::new(&a, 60).unwrap().expect("shared factors");
        let (mut z1, mut z2) = (vec![0.0; n], vec![0.0; n]);
        ilu.apply(&x, &mut z1);
        tilu.apply(&x, &mut z2);
        assert_eq!(z1, z2);
        // and so the solves
        let prm = BicgstabParams::default();
        let (mut s1, mut s2) = (vec![0.0; n], vec![0.0; n]);
        let i1 = bicgstab(&a, &x, &mut s1, &ilu, &prm).unwrap();
        let i2 = bicgstab(&tr, &x, &mut s2, &tilu, &prm).unwrap();
        assert_eq!((i1.iterations, s1), (i2.iterations, s2));
        assert!(i1.rel_residual <= 1e-9);
    }

    #[test]
    fn independent_halves_solved_in_parallel_give_the_general_format_bit_for_bit() {
        let halves = [40, 75];
        let (n, t) = coupled_in(90, 30, 12, halves);
        let m = faer::sparse::SparseRowMat::try_new_from_triplets(n, n, &t).unwrap();
        let a = Csr::from_faer(m.as_ref()).unwrap();
        let tr = Tripled::from_csr(&a, 90)
            .unwrap()
            .with_halves(halves)
            .unwrap();
        let tilu = TripledIlu::from_tripled(&tr, 0).unwrap();
        let ilu = Ilu0::new(&a).unwrap();
        let x: Vec<f64> = (0..n).map(|i| (i as f64 * 0.31).cos()).collect();
        let (mut z1, mut z2) = (vec![0.0; n], vec![0.0; n]);
        ilu.apply(&x, &mut z1);
        tilu.apply(&x, &mut z2);
        assert_eq!(z1, z2);
        // on two threads too
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap();
        let mut z3 = vec![0.0; n];
        pool.install(|| tilu.apply(&x, &mut z3));
        assert_eq!(z1, z3);
        // halves that P couples are refused
        let tr = Tripled::from_csr(&a, 90).unwrap();
        assert!(tr.with_halves([40, 80]).is_err());
        let tr = Tripled::from_csr(&a, 90).unwrap();
        assert!(tr.with_halves([45, 75]).is_err());
    }

    #[test]
    fn face_and_cell_rows_worked_in_parallel_chunks_give_the_general_format_bit_for_bit() {
        // (with and without the tail fill)
        face_and_cell_rows_bit_for_bit();
    }

    fn face_and_cell_rows_bit_for_bit() {
        // 550 rows after the particles: several chunks of the parallel
        // elimination and forward sweep of their particle columns
        let halves = [40, 75];
        let (n, t) = coupled_in(90, 400, 150, halves);
        let m = faer::sparse::SparseRowMat::try_new_from_triplets(n, n, &t).unwrap();
        let a = Csr::from_faer(m.as_ref()).unwrap();
        let x: Vec<f64> = (0..n).map(|i| (i as f64 * 0.53).sin()).collect();
        for (fill, threads) in [
            (0, 1),
            (0, 2),
            (0, 3),
            (1, 1),
            (1, 2),
            (1, 3),
            (2, 1),
            (2, 3),
        ] {
            // with the tail fill too: the λ and pressure rows' extended pattern
            let ilu = Ilu0::with_tail_fill(&a, 3 * 90, fill).unwrap();
            let mut z1 = vec![0.0; n];
            ilu.apply(&x, &mut z1);
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let mut z2 = vec![0.0; n];
            pool.install(|| {
                let tr = Tripled::from_csr(&a, 90)
                    .unwrap()
                    .with_halves(halves)
                    .unwrap();
                let tilu = TripledIlu::from_tripled(&tr, fill).unwrap();
                tilu.apply(&x, &mut z2);
                // the face rows in their independent blocks (every face row
                // its own block; with the fill, one block per axis)
                let tilu =
                    TripledIlu::from_tripled(&tr.with_sequential_tail(3 * 90 + 400), fill).unwrap();
                assert!(
                    tilu.blocks.len() >= if fill > 0 { 4 } else { 400 },
                    "{:?}",
                    tilu.blocks
                );
                let mut z3 = vec![0.0; n];
                tilu.apply(&x, &mut z3);
                assert_eq!(z1, z3, "{threads} threads, tail fill {fill}, blocks");
            });
            assert_eq!(z1, z2, "{threads} threads, tail fill {fill}");
        }
    }

    #[test]
    fn a_particle_block_that_couples_components_is_left_to_the_general_format() {
        let (n, mut t) = coupled(20, 6, 4);
        // x of particle 3 feels y of particle 5: not I3 ⊗ P
        t.push(Triplet::new(9, 16, 0.1));
        let m = faer::sparse::SparseRowMat::try_new_from_triplets(n, n, &t).unwrap();
        let a = Csr::from_faer(m.as_ref()).unwrap();
        assert!(Tripled::from_csr(&a, 20).is_none());
        assert!(TripledIlu::new(&a, 20).unwrap().is_none());
        // one component's value differs
        let (n, mut t) = coupled(20, 6, 4);
        t.push(Triplet::new(4, 4, 1e-3));
        let m = faer::sparse::SparseRowMat::try_new_from_triplets(n, n, &t).unwrap();
        let a = Csr::from_faer(m.as_ref()).unwrap();
        assert!(Tripled::from_csr(&a, 20).is_none());
    }
}
