//! One level of fill for the incomplete factorisation of eq. (24) in its
//! trailing rows: the impulse (λ) and pressure rows of the particles-first
//! order [u, λ, q].
//!
//! ILU(0) keeps the pattern of A. Eliminating the particle columns of a λ
//! row, then its λ columns, creates entries among the λ and pressure
//! columns that A does not store: the pattern of the Schur complement
//! J P⁻¹ Jᵀ and of the pressure–impulse coupling it feeds. Dropping them
//! is what makes ILU(0) weak on the coupled system (150 BiCGSTAB
//! iterations on a fluid-chain substep, 23 with them kept;
//! `docs/decisions.md`, "Level-1 fill in the impulse and pressure rows").
//! Here the pattern of rows ≥ `from` is extended, in columns ≥ `from`
//! only, by the fill of level 1 (Saad, *Iterative Methods for Sparse
//! Linear Systems*, §10.3.3): column c joins row i when some j < i of row
//! i's pattern has c > j in its own row. The particle rows keep their
//! pattern, so their block is still shared by the three components
//! ([`super::TripledIlu`]). The added entries are stored as zeros; the
//! numeric factorisation is ILU(0)'s on the extended pattern.

use rayon::prelude::*;

/// [`with_tail_fill`] applied `passes` times, each pass to the pattern the
/// previous one extended (0: unchanged). Pass 1 adds ILU(1)'s fill; pass 2
/// follows the fill of pass 1 as well, so its pattern holds ILU(2)'s and
/// entries of level 3 (level(i, c) = level(i, j) + level(j, c) + 1 with
/// both at most 1).
pub(super) fn with_tail_fill_passes<C: Copy + Send + Sync>(
    ptr: &[usize],
    col: &[C],
    val: &[f64],
    from: usize,
    passes: usize,
    at: impl Fn(C) -> usize + Sync + Copy,
    make: impl Fn(usize) -> C + Sync + Copy,
) -> (Vec<usize>, Vec<C>, Vec<f64>) {
    if passes == 0 {
        return (ptr.to_vec(), col.to_vec(), val.to_vec());
    }
    let mut out = with_tail_fill(ptr, col, val, from, 0, at, make);
    // a pivot left of `from` adds nothing after the first pass: its row is
    // not extended, and the row being extended keeps its entries there
    for _ in 1..passes {
        out = with_tail_fill(&out.0, &out.1, &out.2, from, from, at, make);
    }
    out
}

/// Rows in the compressed pattern `ptr`/`col` (columns sorted per row;
/// `at` reads a stored column as an index) extended below row `from` as described
/// in the module doc: the extended `ptr`, the extended columns (`make`
/// builds one) and the values, where `val` is the original values and the
/// added entries are 0. Rows before `from` are copied unchanged. Pivots
/// (columns j < i of row i) left of `pivots_from` are not followed: 0 for
/// a first pass, `from` for a later one ([`with_tail_fill_passes`]).
pub(super) fn with_tail_fill<C: Copy + Send + Sync>(
    ptr: &[usize],
    col: &[C],
    val: &[f64],
    from: usize,
    pivots_from: usize,
    at: impl Fn(C) -> usize + Sync,
    make: impl Fn(usize) -> C + Sync,
) -> (Vec<usize>, Vec<C>, Vec<f64>) {
    let n = ptr.len() - 1;
    let from = from.min(n);
    // the added columns of each row from `from` on, sorted
    // (a marker per task, stamped with the row, so that each candidate is
    // kept once without sorting them all)
    let per = ((n - from) / (4 * rayon::current_num_threads()).max(1)).max(64);
    let added: Vec<Vec<usize>> = (from..n)
        .into_par_iter()
        .with_min_len(per)
        .map_init(
            // (stamped with the row; n < 2³² for any matrix that fits in memory)
            || vec![u32::MAX; n],
            |mark, i| {
                let stamp = i as u32;
                let row = ptr[i]..ptr[i + 1];
                for k in row.clone() {
                    mark[at(col[k])] = stamp;
                }
                let mut cand = Vec::new();
                for k in row {
                    let j = at(col[k]);
                    if j >= i {
                        break;
                    }
                    if j < pivots_from {
                        continue;
                    }
                    // row j's entries right of its diagonal and from `from` on
                    let rj = &col[ptr[j]..ptr[j + 1]];
                    let lo = j.max(from.saturating_sub(1));
                    for &cj in &rj[rj.partition_point(|&c| at(c) <= lo)..] {
                        let c = at(cj);
                        if mark[c] != stamp {
                            mark[c] = stamp;
                            cand.push(c);
                        }
                    }
                }
                cand.sort_unstable();
                cand
            },
        )
        .collect();
    // the extended rows, merged in parallel chunks of rows into place
    let mut p = Vec::with_capacity(n + 1);
    p.extend_from_slice(&ptr[..=from]);
    for (i, add) in (from..n).zip(&added) {
        p.push(p[i] + ptr[i + 1] - ptr[i] + add.len());
    }
    let total = p[n];
    let mut c = vec![make(0); total];
    let mut v = vec![0.0; total];
    c[..ptr[from]].copy_from_slice(&col[..ptr[from]]);
    v[..ptr[from]].copy_from_slice(&val[..ptr[from]]);
    let bounds: Vec<usize> = (from..n).step_by(per).chain([n]).collect();
    let mut pieces = Vec::with_capacity(bounds.len());
    let (mut cl, mut vl) = (&mut c[ptr[from]..], &mut v[ptr[from]..]);
    for w in bounds.windows(2) {
        let len = p[w[1]] - p[w[0]];
        let (ch, ct) = std::mem::take(&mut cl).split_at_mut(len);
        let (vh, vt) = std::mem::take(&mut vl).split_at_mut(len);
        pieces.push((w[0]..w[1], ch, vh));
        cl = ct;
        vl = vt;
    }
    pieces.into_par_iter().for_each(|(rows, cs, vs)| {
        let mut o = 0;
        for i in rows {
            let mut a = added[i - from].iter().peekable();
            for k in ptr[i]..ptr[i + 1] {
                let j = at(col[k]);
                while let Some(&&x) = a.peek() {
                    if x > j {
                        break;
                    }
                    cs[o] = make(x);
                    o += 1;
                    a.next();
                }
                cs[o] = col[k];
                vs[o] = val[k];
                o += 1;
            }
            for &x in a {
                cs[o] = make(x);
                o += 1;
            }
        }
    });
    (p, c, v)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Rows of a small matrix as (column, value) lists.
    fn rows(p: &[usize], c: &[usize], v: &[f64]) -> Vec<Vec<(usize, f64)>> {
        (0..p.len() - 1)
            .map(|i| (p[i]..p[i + 1]).map(|k| (c[k], v[k])).collect())
            .collect()
    }

    #[test]
    fn level_one_fill_is_added_in_trailing_rows_and_columns_only() {
        // 0: [0, 1, 2, 3]   1: [1, 3]   2: [0, 2]   3: [1, 3, 4]   4: [1, 2, 4]
        let p = vec![0, 4, 6, 8, 11, 14];
        let c = vec![0, 1, 2, 3, 1, 3, 0, 2, 1, 3, 4, 1, 2, 4];
        let v: Vec<f64> = (1..=14).map(f64::from).collect();
        let (ep, ec, ev) = with_tail_fill(&p, &c, &v, 2, 0, |x| x, |x| x);
        let r = rows(&ep, &ec, &ev);
        // rows 0, 1 as they were
        assert_eq!(r[0], vec![(0, 1.0), (1, 2.0), (2, 3.0), (3, 4.0)]);
        assert_eq!(r[1], vec![(1, 5.0), (3, 6.0)]);
        // row 2: pivot 0 reaches 1 (a leading column: not added), 2
        // (stored) and 3 (added)
        assert_eq!(r[2], vec![(0, 7.0), (2, 8.0), (3, 0.0)]);
        // row 3: pivot 1 reaches 3, stored
        assert_eq!(r[3], vec![(1, 9.0), (3, 10.0), (4, 11.0)]);
        // row 4: pivot 1 reaches 3 (added); pivot 2 reaches nothing through
        // row 2's own pattern (the fill (2, 3) is of level 1: not followed)
        assert_eq!(r[4], vec![(1, 12.0), (2, 13.0), (3, 0.0), (4, 14.0)]);
        // two passes: the second follows the first one's fill
        let (qp, qc, qv) = with_tail_fill_passes(&p, &c, &v, 2, 2, |x| x, |x| x);
        let (tp, tc, tv) = with_tail_fill(&ep, &ec, &ev, 2, 0, |x| x, |x| x);
        assert_eq!((&qp, &qc, &qv), (&tp, &tc, &tv));
        // from = n: nothing changes
        let (fp, fc, fv) = with_tail_fill(&p, &c, &v, 5, 0, |x| x, |x| x);
        assert_eq!((fp, fc, fv), (p.clone(), c.clone(), v.clone()));
    }

    /// The 5-point Laplacian of a 4 × 4 grid in natural order: ILU(1)'s
    /// fill of row 5 (cell (1, 1)) is columns 2 and 8 (i − 4 + 1, i + 4 − 1);
    /// the second pass adds column 3 (i − 4 + 2, level 2) through row 2's
    /// own fill (2, 5). Column 7 (i + 4 − 2) would come through (4, 7), which
    /// row 4 (on the grid's edge: no pivot 3) never gets.
    #[test]
    fn a_second_pass_follows_the_first_ones_fill() {
        let m = 4;
        let (mut p, mut c) = (vec![0], Vec::new());
        for i in 0..m * m {
            let (x, y) = (i % m, i / m);
            let mut row = vec![i];
            if y > 0 {
                row.push(i - m);
            }
            if x > 0 {
                row.push(i - 1);
            }
            if x + 1 < m {
                row.push(i + 1);
            }
            if y + 1 < m {
                row.push(i + m);
            }
            row.sort_unstable();
            c.extend(row);
            p.push(c.len());
        }
        let v = vec![1.0; c.len()];
        let cols =
            |(p, c, _): &(Vec<usize>, Vec<usize>, Vec<f64>), i: usize| c[p[i]..p[i + 1]].to_vec();
        let one = with_tail_fill_passes(&p, &c, &v, 0, 1, |x| x, |x| x);
        let two = with_tail_fill_passes(&p, &c, &v, 0, 2, |x| x, |x| x);
        assert_eq!(cols(&one, 5), vec![1, 2, 4, 5, 6, 8, 9]);
        assert_eq!(cols(&two, 5), vec![1, 2, 3, 4, 5, 6, 8, 9]);
        // the original entries keep their values, the added ones are 0
        let (tp, tc, tv) = &two;
        for k in tp[5]..tp[6] {
            let orig = [1, 4, 5, 6, 9].contains(&tc[k]);
            assert_eq!(tv[k], if orig { 1.0 } else { 0.0 });
        }
        let zero = with_tail_fill_passes(&p, &c, &v, 0, 0, |x| x, |x| x);
        assert_eq!(zero, (p, c, v));
    }

    /// Later passes skip the pivots left of `from` (their rows are never
    /// extended and the extended row keeps its entries there, so they add
    /// nothing new): on a random pattern the passes give what passes that
    /// walk every pivot give.
    #[test]
    fn later_passes_skipping_the_leading_pivots_add_the_same_fill() {
        let (n, from) = (120, 50);
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut rnd = |m: usize| {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed % m as u64) as usize
        };
        let (mut p, mut c) = (vec![0], Vec::new());
        for i in 0..n {
            let mut row = vec![i];
            for _ in 0..4 {
                row.push(rnd(n));
            }
            row.sort_unstable();
            row.dedup();
            c.extend(row);
            p.push(c.len());
        }
        let v: Vec<f64> = (0..c.len()).map(|k| k as f64).collect();
        for passes in 1..=3 {
            let mut walked = (p.clone(), c.clone(), v.clone());
            for _ in 0..passes {
                walked = with_tail_fill(&walked.0, &walked.1, &walked.2, from, 0, |x| x, |x| x);
            }
            let skipped = with_tail_fill_passes(&p, &c, &v, from, passes, |x| x, |x| x);
            assert_eq!(skipped, walked, "{passes} passes");
        }
        // the test pattern does grow with each pass
        let one = with_tail_fill_passes(&p, &c, &v, from, 1, |x| x, |x| x);
        let three = with_tail_fill_passes(&p, &c, &v, from, 3, |x| x, |x| x);
        assert!(three.1.len() > one.1.len() && one.1.len() > c.len());
    }
}
