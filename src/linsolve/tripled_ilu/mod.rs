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

mod elimination;
mod sweep;

use super::ilu0::Triangle;
use super::tripled::Tripled;
use super::SolveError;
use elimination::{eliminate, eliminate_tail, pick, split_at_many, split_rows_from, tail_blocks};
use rayon::prelude::*;

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
