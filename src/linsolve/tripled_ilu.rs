//! ILU(0) of the coupled system with the particle block's factors stored
//! once ([`super::Tripled`]).
//!
//! ILU(0) of `I₃ ⊗ P` followed by the λ and pressure rows of eq. (24) is
//! `I₃ ⊗ ILU(0)(P)` in the particle rows: the particle rows come first and a
//! particle row's entries left of its diagonal are particle entries of its
//! own component, so the three components repeat one elimination. It is
//! computed once, P's two independent halves side by side, and the
//! triangular solves sweep the halves in parallel. Every entry receives the
//! same updates in the same order as in [`super::Ilu0`], so the factors and
//! the solves are the general format's, bit for bit (tested in
//! [`super::tripled`]).

use super::ilu0::Triangle;
use super::tripled::Tripled;
use super::{Preconditioner, SolveError};
use rayon::prelude::*;

/// Chunks of the rows `n3..n` for the parallel work on them: boundaries
/// (first row of each chunk, then n), at most 8 per thread and at least
/// 64 rows each, so that each chunk's n-entry marker is worth its cost.
fn tail_chunks(n3: usize, n: usize) -> Vec<usize> {
    let per = ((n - n3) / (8 * rayon::current_num_threads()).max(1)).max(64);
    let mut b: Vec<usize> = (n3..n).step_by(per).collect();
    b.push(n);
    b
}

/// Boundaries of the blocks that rows `n3..seq` of `r` split into: a row
/// of one block has no entry in the columns `n3..seq` of another (its
/// entries there lie between the block's first and last row). First row of
/// each block, then `seq`.
fn tail_blocks(r: &Triangle, n3: usize, seq: usize) -> Vec<usize> {
    let span = |i: usize| {
        let (mut lo, mut hi) = (i, i);
        for k in r.ptr[i]..r.ptr[i + 1] {
            let c = r.col[k] as usize;
            if c >= n3 && c < seq {
                lo = lo.min(c);
                hi = hi.max(c);
            }
        }
        (lo, hi)
    };
    let spans: Vec<(usize, usize)> = (n3..seq).into_par_iter().map(span).collect();
    // a boundary at s: no row before s reaches s or beyond, no row from s on
    // reaches before s
    let mut suffix_lo = vec![seq; spans.len() + 1];
    for e in (0..spans.len()).rev() {
        suffix_lo[e] = suffix_lo[e + 1].min(spans[e].0);
    }
    let mut b = vec![n3];
    let mut reach = 0;
    for e in 0..spans.len() {
        let s = n3 + e;
        if e > 0 && reach < s && suffix_lo[e] >= s {
            b.push(s);
        }
        reach = reach.max(spans[e].1);
    }
    b.push(seq);
    b.dedup();
    b
}

/// Eliminates rows `rows` (≥ n3) in their columns `lo`.. (`lo` ≥ n3; their
/// columns before `lo` are done): `vals` holds the values of entries
/// `base..` of `r`, covering these rows and every row their pivots lie in;
/// `rd` the diagonal entries of rows n3..; `pos` an all-unset marker of the
/// columns n3.. (left unset; a row's entries are marked relative to `base`,
/// and only columns ≥ n3 are ever updated here). The first zero or
/// non-finite pivot is reported.
#[allow(clippy::too_many_arguments)]
fn eliminate_tail(
    r: &Triangle,
    rd: &[usize],
    n3: usize,
    lo: usize,
    rows: std::ops::Range<usize>,
    vals: &mut [f64],
    base: usize,
    pos: &mut [u32],
) -> Result<(), SolveError> {
    for i in rows {
        let row = r.ptr[i]..r.ptr[i + 1];
        // the row's entries in columns n3.. (its particle entries come first)
        let tail = row.start + r.col[row.clone()].partition_point(|&c| (c as usize) < n3)..row.end;
        for k in tail.clone() {
            pos[r.col[k] as usize - n3] = (k - base) as u32;
        }
        for k in tail.clone() {
            let c = r.col[k] as usize;
            if c >= i {
                break;
            }
            if c >= lo {
                let l = vals[k - base] / vals[rd[c - n3] - base];
                vals[k - base] = l;
                for kk in rd[c - n3] + 1..r.ptr[c + 1] {
                    let q = pos[r.col[kk] as usize - n3];
                    if q != u32::MAX {
                        vals[q as usize] -= l * vals[kk - base];
                    }
                }
            }
        }
        for k in tail {
            pos[r.col[k] as usize - n3] = u32::MAX;
        }
        let dv = vals[rd[i - n3] - base];
        if dv == 0.0 || !dv.is_finite() {
            return Err(SolveError::ZeroPivot { row: i });
        }
    }
    Ok(())
}

/// The values `rv` of `r`'s entries split at row `from`: those of the rows
/// before it (read-only), and those of rows `from..` in the chunks of
/// [`tail_chunks`], each with its first row; and the chunks' boundaries.
#[allow(clippy::type_complexity)]
fn split_rows_from<'a>(
    rv: &'a mut [f64],
    r: &Triangle,
    from: usize,
) -> (&'a [f64], Vec<(usize, &'a mut [f64])>, Vec<usize>) {
    let n = r.ptr.len() - 1;
    let (head, tail) = rv.split_at_mut(r.ptr[from]);
    let chunks = tail_chunks(from, n);
    let mut parts = Vec::with_capacity(chunks.len());
    let mut left = tail;
    for w in chunks.windows(2) {
        let (a, b) = left.split_at_mut(r.ptr[w[1]] - r.ptr[w[0]]);
        parts.push((w[0], a));
        left = b;
    }
    (head, parts, chunks)
}

/// Splits `v` (whose element 0 is index `off`) at the given increasing
/// indices (≥ off) into consecutive mutable pieces.
fn split_at_many<'a, T>(mut v: &'a mut [T], off: usize, at: &[usize]) -> Vec<&'a mut [T]> {
    let mut out = Vec::with_capacity(at.len() + 1);
    let mut from = off;
    for &a in at {
        let (head, tail) = std::mem::take(&mut v).split_at_mut(a - from);
        out.push(head);
        v = tail;
        from = a;
    }
    out.push(v);
    out
}

/// ILU(0) of a [`Tripled`] matrix with P's factors stored once.
pub struct TripledIlu {
    n: usize,
    np: usize,
    /// As [`Tripled`]'s.
    halves: [usize; 2],
    /// L of the particle rows (unit diagonal), by slot.
    lp: Triangle,
    /// U of the particle rows in particle columns, by slot.
    up: Triangle,
    /// Pivots of the particle rows, by slot.
    dp: Vec<f64>,
    /// Rows 3·np.. of L (all columns left of the diagonal); rows < 3·np empty.
    lt: Triangle,
    /// Where each row 3·np.. of `lt` passes from particle columns to the
    /// others (indexed from 3·np).
    lt_mid: Vec<usize>,
    /// U entries right of the diagonal outside the shared part: the
    /// particle rows' λ/pressure columns and the other rows' whole U.
    ut: Triangle,
    /// Pivots of rows 3·np.. (indexed from 3·np).
    dt: Vec<f64>,
    /// Boundaries of the independent blocks of rows 3·np..`seq` (first row
    /// of each, then `seq`), worked in parallel; rows `seq`.. in order.
    pub(super) blocks: Vec<usize>,
}

/// ILU(0) elimination of P's rows `rows` and of their entries outside P
/// (Saad, Alg. 10.4): `pv` holds P's values from entry `pv.1` on, `rv` the
/// rest's from entry `rv.1` on, and together they cover these rows and
/// every row their pivots lie in. `pos` is an all-unset marker of n
/// entries (left unset; entries are marked relative to `pv.1` and `rv.1`).
fn eliminate(
    p: &Triangle,
    r: &Triangle,
    pd: &[usize],
    rows: std::ops::Range<usize>,
    (pv, po): (&mut [f64], usize),
    (rv, ro): (&mut [f64], usize),
    pos: &mut [u32],
) -> Result<(), SolveError> {
    for s in rows {
        let row = p.ptr[s]..p.ptr[s + 1];
        for k in row.clone() {
            pos[p.col[k] as usize] = (k - po) as u32;
        }
        for k in row.clone() {
            let j = p.col[k] as usize;
            if j >= s {
                break;
            }
            let l = pv[k - po] / pv[pd[j] - po];
            pv[k - po] = l;
            for kk in pd[j] + 1..p.ptr[j + 1] {
                let q = pos[p.col[kk] as usize];
                if q != u32::MAX {
                    pv[q as usize] -= l * pv[kk - po];
                }
            }
        }
        for k in row.clone() {
            pos[p.col[k] as usize] = u32::MAX;
        }
        let dv = pv[pd[s] - po];
        if dv == 0.0 || !dv.is_finite() {
            return Err(SolveError::ZeroPivot { row: 3 * s });
        }
        for d in 0..3 {
            let i = 3 * s + d;
            for k in r.ptr[i]..r.ptr[i + 1] {
                pos[r.col[k] as usize] = (k - ro) as u32;
            }
            for k in row.clone() {
                let j = p.col[k] as usize;
                if j >= s {
                    break;
                }
                let (l, c) = (pv[k - po], 3 * j + d);
                for kk in r.ptr[c]..r.ptr[c + 1] {
                    let q = pos[r.col[kk] as usize];
                    if q != u32::MAX {
                        rv[q as usize] -= l * rv[kk - ro];
                    }
                }
            }
            for k in r.ptr[i]..r.ptr[i + 1] {
                pos[r.col[k] as usize] = u32::MAX;
            }
        }
    }
    Ok(())
}

/// The entries `rows(i)` of rows `0..nr` of `t`, with the values `v`, as a
/// new triangle.
fn pick(
    t: &Triangle,
    v: &[f64],
    rows: impl Fn(usize) -> std::ops::Range<usize>,
    nr: usize,
) -> Triangle {
    let mut ptr = Vec::with_capacity(nr + 1);
    ptr.push(0);
    for i in 0..nr {
        ptr.push(ptr[i] + rows(i).len());
    }
    let mut out = Triangle {
        col: Vec::with_capacity(ptr[nr]),
        val: Vec::with_capacity(ptr[nr]),
        ptr,
    };
    for i in 0..nr {
        let k = rows(i);
        out.col.extend_from_slice(&t.col[k.clone()]);
        out.val.extend_from_slice(&v[k]);
    }
    out
}

impl TripledIlu {
    /// Factorises `a` and stores it shared; `Ok(None)` when `a` does not
    /// have the structure (see `Tripled::from_csr`; tests only).
    #[cfg(test)]
    pub fn new(a: &super::Csr, np: usize) -> Result<Option<TripledIlu>, SolveError> {
        match Tripled::from_csr(a, np) {
            Some(m) => TripledIlu::from_tripled(&m, 0).map(Some),
            None => Ok(None),
        }
    }

    /// ILU(0) of `m` (Saad, Alg. 10.4, as [`super::Ilu0`]): P's rows are
    /// eliminated once for the three components, each component's λ and
    /// pressure entries of the particle rows with P's multipliers, then
    /// the remaining rows as in the general format. Every entry receives
    /// the same updates in the same order as there, so the factors are
    /// the general ones, bit for bit. A zero or missing pivot is reported
    /// with its row of the whole matrix. With `fill_passes` > 0 the λ and
    /// pressure rows take that many passes of level-1 fill among their own
    /// columns first ([`super::fill`]; as [`super::Ilu0::with_tail_fill`]
    /// from row 3·np).
    pub fn from_tripled(m: &Tripled, fill_passes: usize) -> Result<TripledIlu, SolveError> {
        let (n, np) = (m.n, m.np);
        let n3 = 3 * np;
        let filled;
        // the values being factorised: the filled pattern's own (a fresh
        // copy), or a copy of `m`'s
        let mut rv;
        let r = if fill_passes > 0 && n3 < n {
            let (ptr, col, val) = super::fill::with_tail_fill_passes(
                &m.rest.ptr,
                &m.rest.col,
                &m.rest.val,
                n3,
                fill_passes,
                |c| c as usize,
                |c| c as u32,
            );
            rv = val;
            filled = Triangle {
                ptr,
                col,
                val: Vec::new(),
            };
            &filled
        } else {
            rv = m.rest.val.clone();
            &m.rest
        };
        let p = &m.p;
        let mut pv = p.val.clone();
        // (rows are sorted: the elimination below relies on it too)
        let find = |t: &Triangle, i: usize, c: usize| {
            let row = t.ptr[i]..t.ptr[i + 1];
            t.col[row.clone()]
                .binary_search(&(c as u32))
                .ok()
                .map(|k| row.start + k)
        };
        let mut pd = Vec::with_capacity(np);
        for s in 0..np {
            pd.push(find(p, s, s).ok_or(SolveError::ZeroPivot { row: 3 * s })?);
        }
        let mut rd = Vec::with_capacity(n - n3);
        for i in n3..n {
            rd.push(find(r, i, i).ok_or(SolveError::ZeroPivot { row: i })?);
        }
        // the two halves in parallel (each row's pivots lie in its own half),
        // then the separator; slots of P (< np) and columns of the rest
        // (≥ 3np) never overlap in a marker
        let [ha, hb] = m.halves;
        {
            let (pab, _) = pv.split_at_mut(p.ptr[hb]);
            let (pa, pb) = pab.split_at_mut(p.ptr[ha]);
            let (rab, _) = rv.split_at_mut(r.ptr[3 * hb]);
            let (ra, rb) = rab.split_at_mut(r.ptr[3 * ha]);
            let (fa, fb) = rayon::join(
                || eliminate(p, r, &pd, 0..ha, (pa, 0), (ra, 0), &mut vec![u32::MAX; n]),
                || {
                    let (po, ro) = (p.ptr[ha], r.ptr[3 * ha]);
                    eliminate(
                        p,
                        r,
                        &pd,
                        ha..hb,
                        (pb, po),
                        (rb, ro),
                        &mut vec![u32::MAX; n],
                    )
                },
            );
            fa?;
            fb?;
        }
        let mut pos = vec![u32::MAX; n];
        eliminate(p, r, &pd, hb..np, (&mut pv, 0), (&mut rv, 0), &mut pos)?;
        // the other rows: first their pivots in particle columns, whose rows
        // are final now, so these rows are independent (in parallel chunks,
        // each with its own marker); then, in order, their pivots in each
        // other's columns. Particle columns come first in every row, so each
        // entry receives the same updates in the same order as in one pass.
        {
            let (head, parts, chunks) = split_rows_from(&mut rv, r, n3);
            let pv = &pv;
            parts
                .into_par_iter()
                .zip(chunks.par_windows(2))
                .for_each(|((first, vals), w)| {
                    let base = r.ptr[first];
                    let mut pos = vec![u32::MAX; n];
                    for i in w[0]..w[1] {
                        let row = r.ptr[i]..r.ptr[i + 1];
                        for k in row.clone() {
                            pos[r.col[k] as usize] = (k - base) as u32;
                        }
                        for k in row.clone() {
                            let c = r.col[k] as usize;
                            if c >= n3 {
                                break;
                            }
                            let (s, d) = (c / 3, c % 3);
                            let l = vals[k - base] / pv[pd[s]];
                            vals[k - base] = l;
                            for kk in pd[s] + 1..p.ptr[s + 1] {
                                let q = pos[3 * p.col[kk] as usize + d];
                                if q != u32::MAX {
                                    vals[q as usize] -= l * pv[kk];
                                }
                            }
                            // the particle row's λ/pressure entries
                            for kk in r.ptr[c]..r.ptr[c + 1] {
                                let q = pos[r.col[kk] as usize];
                                if q != u32::MAX {
                                    vals[q as usize] -= l * head[kk];
                                }
                            }
                        }
                        for k in row {
                            pos[r.col[k] as usize] = u32::MAX;
                        }
                    }
                });
        }
        // rows n3..seq: their blocks in parallel (a row's pivots in these
        // columns lie in its own block); then rows seq.. in order
        let seq = m.seq_from.clamp(n3, n);
        let blocks = tail_blocks(r, n3, seq);
        {
            let cuts: Vec<usize> = blocks.iter().map(|&b| r.ptr[b]).collect();
            let mut pieces = split_at_many(&mut rv[..], 0, &cuts);
            let slices: Vec<&mut [f64]> = pieces.drain(1..cuts.len()).collect();
            let firsts: Vec<Result<(), SolveError>> = slices
                .into_par_iter()
                .zip(blocks.par_windows(2))
                .map_init(
                    || vec![u32::MAX; n - n3],
                    |pos, (vals, w)| {
                        eliminate_tail(r, &rd, n3, n3, w[0]..w[1], vals, r.ptr[w[0]], pos)
                    },
                )
                .collect();
            // the first failing row, as the sequential pass would report it
            if let Some(e) = firsts.into_iter().find_map(Result::err) {
                return Err(e);
            }
        }
        // the pressure rows' pivots in the impulse columns (final now): the
        // rows are independent there, so in parallel chunks; then their
        // pivots in each other's columns, in order
        {
            let (head, parts, chunks) = split_rows_from(&mut rv, r, seq);
            let rd = &rd;
            parts
                .into_par_iter()
                .zip(chunks.par_windows(2))
                .for_each(|((first, vals), w)| {
                    let base = r.ptr[first];
                    let mut pos = vec![u32::MAX; n - n3];
                    for i in w[0]..w[1] {
                        // its entries in columns n3.. (the assembly's
                        // pressure rows have no others)
                        let row = r.ptr[i]..r.ptr[i + 1];
                        let row = row.start
                            + r.col[row.clone()].partition_point(|&c| (c as usize) < n3)
                            ..row.end;
                        for k in row.clone() {
                            pos[r.col[k] as usize - n3] = (k - base) as u32;
                        }
                        for k in row.clone() {
                            let c = r.col[k] as usize;
                            if c >= seq {
                                break;
                            }
                            let l = vals[k - base] / head[rd[c - n3]];
                            vals[k - base] = l;
                            for kk in rd[c - n3] + 1..r.ptr[c + 1] {
                                let q = pos[r.col[kk] as usize - n3];
                                if q != u32::MAX {
                                    vals[q as usize] -= l * head[kk];
                                }
                            }
                        }
                        for k in row {
                            pos[r.col[k] as usize - n3] = u32::MAX;
                        }
                    }
                });
        }
        eliminate_tail(
            r,
            &rd,
            n3,
            seq,
            seq..n,
            &mut rv,
            0,
            &mut vec![u32::MAX; n - n3],
        )?;
        let tail_l = |i: usize| if i < n3 { 0..0 } else { r.ptr[i]..rd[i - n3] };
        let tail_u = |i: usize| {
            if i < n3 {
                r.ptr[i]..r.ptr[i + 1]
            } else {
                rd[i - n3] + 1..r.ptr[i + 1]
            }
        };
        // the four triangles are copied out side by side
        let ((lt, ut), (lp, up)) = rayon::join(
            || rayon::join(|| pick(r, &rv, tail_l, n), || pick(r, &rv, tail_u, n)),
            || {
                rayon::join(
                    || pick(p, &pv, |s| p.ptr[s]..pd[s], np),
                    || pick(p, &pv, |s| pd[s] + 1..p.ptr[s + 1], np),
                )
            },
        );
        let lt_mid = (n3..n)
            .map(|i| {
                let row = lt.ptr[i]..lt.ptr[i + 1];
                row.start + lt.col[row].partition_point(|&c| (c as usize) < n3)
            })
            .collect();
        Ok(TripledIlu {
            n,
            np,
            halves: m.halves,
            lp,
            up,
            dp: pd.iter().map(|&k| pv[k]).collect(),
            lt,
            lt_mid,
            ut,
            dt: rd.iter().map(|&k| rv[k]).collect(),
            blocks,
        })
    }
}

/// Forward substitution over P's rows `rows` (unit L), writing `z`, whose
/// element 0 is slot `off`'s component x: every column of these rows is
/// at or after `off`.
fn forward(lp: &Triangle, r: &[f64], z: &mut [f64], off: usize, rows: std::ops::Range<usize>) {
    for s in rows {
        let mut acc = [r[3 * s], r[3 * s + 1], r[3 * s + 2]];
        for k in lp.ptr[s]..lp.ptr[s + 1] {
            let c = 3 * (lp.col[k] as usize - off);
            let v = lp.val[k];
            acc[0] -= v * z[c];
            acc[1] -= v * z[c + 1];
            acc[2] -= v * z[c + 2];
        }
        let o = 3 * (s - off);
        z[o..o + 3].copy_from_slice(&acc);
    }
}

impl TripledIlu {
    /// Back substitution over P's rows `off..end` (descending): `own`
    /// holds slots `off..end`, `far` everything from slot `far_from` on
    /// (the separator and the other rows, already solved). A column of
    /// these rows is either in `off..end` or at or after `far_from`.
    fn backward(&self, own: &mut [f64], off: usize, end: usize, far: &[f64], far_from: usize) {
        let (up, ut) = (&self.up, &self.ut);
        let f0 = 3 * far_from;
        for s in (off..end).rev() {
            let o = 3 * (s - off);
            let mut acc = [own[o], own[o + 1], own[o + 2]];
            for k in up.ptr[s]..up.ptr[s + 1] {
                let c = up.col[k] as usize;
                let v = up.val[k];
                let x = if c < end {
                    &own[3 * (c - off)..3 * (c - off) + 3]
                } else {
                    &far[3 * c - f0..3 * c - f0 + 3]
                };
                acc[0] -= v * x[0];
                acc[1] -= v * x[1];
                acc[2] -= v * x[2];
            }
            for (d, a) in acc.iter_mut().enumerate() {
                let i = 3 * s + d;
                for k in ut.ptr[i]..ut.ptr[i + 1] {
                    *a -= ut.val[k] * far[ut.col[k] as usize - f0];
                }
                *a /= self.dp[s];
            }
            own[o..o + 3].copy_from_slice(&acc);
        }
    }
}

impl Preconditioner for TripledIlu {
    fn apply(&self, r: &[f64], z: &mut [f64]) {
        let (n, np, n3) = (self.n, self.np, 3 * self.np);
        let [a, b] = self.halves;
        let (lt, ut) = (&self.lt, &self.ut);
        // L y = r (unit lower): the halves in parallel, then the separator
        {
            let (za, zb) = z[..3 * b].split_at_mut(3 * a);
            rayon::join(
                || forward(&self.lp, r, za, 0, 0..a),
                || forward(&self.lp, r, zb, a, a..b),
            );
        }
        forward(&self.lp, r, z, 0, b..np);
        // the other rows' particle columns (all solved) in parallel, then
        // their own columns in order: the same sums in the same order
        {
            let (zp, zt) = z.split_at_mut(n3);
            let zp = &*zp;
            zt.par_iter_mut()
                .enumerate()
                .with_min_len(256)
                .for_each(|(e, zi)| {
                    let i = n3 + e;
                    let mut acc = r[i];
                    for k in lt.ptr[i]..self.lt_mid[e] {
                        acc -= lt.val[k] * zp[lt.col[k] as usize];
                    }
                    *zi = acc;
                });
        }
        let own = |zb: &mut [f64], off: usize, rows: std::ops::Range<usize>| {
            for i in rows {
                let mut acc = zb[i - off];
                for k in self.lt_mid[i - n3]..lt.ptr[i + 1] {
                    acc -= lt.val[k] * zb[lt.col[k] as usize - off];
                }
                zb[i - off] = acc;
            }
        };
        let bl = &self.blocks;
        let seq = bl[bl.len() - 1];
        {
            let mut pieces = split_at_many(&mut z[..seq], 0, &bl[..bl.len() - 1]);
            pieces
                .drain(1..)
                .collect::<Vec<_>>()
                .into_par_iter()
                .zip(bl.par_windows(2))
                .for_each(|(zb, w)| own(zb, w[0], w[0]..w[1]));
        }
        own(z, 0, seq..n);
        // U z = y: the other rows, the separator, then the halves in parallel
        // (rows seq.. first; a block's rows reach their own block and seq..)
        let back = |zb: &mut [f64], off: usize, far: &[f64], rows: std::ops::Range<usize>| {
            for i in rows.rev() {
                let mut acc = zb[i - off];
                for k in ut.ptr[i]..ut.ptr[i + 1] {
                    let c = ut.col[k] as usize;
                    acc -= ut.val[k] * if c >= seq { far[c - seq] } else { zb[c - off] };
                }
                zb[i - off] = acc / self.dt[i - n3];
            }
        };
        {
            let (zh, zs) = z.split_at_mut(seq);
            for i in (seq..n).rev() {
                let mut acc = zs[i - seq];
                for k in ut.ptr[i]..ut.ptr[i + 1] {
                    acc -= ut.val[k] * zs[ut.col[k] as usize - seq];
                }
                zs[i - seq] = acc / self.dt[i - n3];
            }
            let zs = &*zs;
            let mut pieces = split_at_many(&mut zh[..], 0, &bl[..bl.len() - 1]);
            pieces
                .drain(1..)
                .collect::<Vec<_>>()
                .into_par_iter()
                .zip(bl.par_windows(2))
                .for_each(|(zb, w)| back(zb, w[0], zs, w[0]..w[1]));
        }
        {
            let (zs, tail) = z[3 * b..].split_at_mut(3 * (np - b));
            self.backward(zs, b, np, tail, np);
        }
        let (zab, far) = z.split_at_mut(3 * b);
        let (za, zb) = zab.split_at_mut(3 * a);
        rayon::join(
            || self.backward(za, 0, a, far, b),
            || self.backward(zb, a, b, far, b),
        );
    }
}
