//! The triangular sweeps of [`super::TripledIlu`]: z = U⁻¹ L⁻¹ r, P's
//! rows once for the three components, its two halves in parallel.

use super::super::ilu0::Triangle;
use super::super::Preconditioner;
use super::elimination::split_at_many;
use super::TripledIlu;
use rayon::prelude::*;

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
