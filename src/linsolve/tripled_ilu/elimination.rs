//! The elimination phases of [`super::TripledIlu::from_tripled`]: the
//! particle rows (`eliminate`), the impulse and pressure rows in their own
//! columns (`eliminate_tail`), the row chunks and blocks the threads share,
//! and the copy of the factors into triangles (`pick`).

use super::super::ilu0::Triangle;
use super::super::SolveError;
use rayon::prelude::*;

/// Chunks of the rows `n3..n` for the parallel work on them: boundaries
/// (first row of each chunk, then n), at most 8 per thread and at least
/// 64 rows each, so that each chunk's n-entry marker is worth its cost.
pub(super) fn tail_chunks(n3: usize, n: usize) -> Vec<usize> {
    let per = ((n - n3) / (8 * rayon::current_num_threads()).max(1)).max(64);
    let mut b: Vec<usize> = (n3..n).step_by(per).collect();
    b.push(n);
    b
}

/// Boundaries of the blocks that rows `n3..seq` of `r` split into: a row
/// of one block has no entry in the columns `n3..seq` of another (its
/// entries there lie between the block's first and last row). First row of
/// each block, then `seq`.
pub(super) fn tail_blocks(r: &Triangle, n3: usize, seq: usize) -> Vec<usize> {
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
pub(super) fn eliminate_tail(
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
pub(super) fn split_rows_from<'a>(
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
pub(super) fn split_at_many<'a, T>(
    mut v: &'a mut [T],
    off: usize,
    at: &[usize],
) -> Vec<&'a mut [T]> {
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

/// ILU(0) elimination of P's rows `rows` and of their entries outside P
/// (Saad, Alg. 10.4): `pv` holds P's values from entry `pv.1` on, `rv` the
/// rest's from entry `rv.1` on, and together they cover these rows and
/// every row their pivots lie in. `pos` is an all-unset marker of n
/// entries (left unset; entries are marked relative to `pv.1` and `rv.1`).
pub(super) fn eliminate(
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
pub(super) fn pick(
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
