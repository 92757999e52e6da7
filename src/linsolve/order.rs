//! Reverse Cuthill–McKee ordering (Cuthill & McKee 1969; George 1971) of a
//! sparse pattern, used to number the unknowns before ILU(0).
//!
//! The graph is that of A + Aᵀ (an entry in either triangle is an edge),
//! without forming A + Aᵀ: a vertex's neighbours are its row and its column
//! of A (a transposed copy of the pattern gives the column). Every choice
//! (start vertex, order of a vertex's neighbours) is broken by (degree,
//! index), so the ordering depends only on the pattern.

/// The RCM ordering of the square pattern `row_ptr`/`col` (n rows): the
/// returned `order[k]` is the vertex placed at position k. Each connected
/// component is numbered from its vertex of least degree.
pub fn reverse_cuthill_mckee(n: usize, row_ptr: &[usize], col: &[usize]) -> Vec<usize> {
    // transposed pattern by counting
    let mut t_ptr = vec![0usize; n + 1];
    for &c in &col[..row_ptr[n]] {
        t_ptr[c + 1] += 1;
    }
    for i in 0..n {
        t_ptr[i + 1] += t_ptr[i];
    }
    let mut fill = t_ptr.clone();
    let mut t_col = vec![0usize; row_ptr[n]];
    for i in 0..n {
        for &c in &col[row_ptr[i]..row_ptr[i + 1]] {
            t_col[fill[c]] = i;
            fill[c] += 1;
        }
    }
    let neighbours = |v: usize| {
        col[row_ptr[v]..row_ptr[v + 1]]
            .iter()
            .chain(&t_col[t_ptr[v]..t_ptr[v + 1]])
            .copied()
            .filter(move |&w| w != v)
    };
    let degree: Vec<usize> = (0..n).map(|v| neighbours(v).count()).collect();
    let mut starts: Vec<usize> = (0..n).collect();
    starts.sort_unstable_by_key(|&v| (degree[v], v));
    let mut seen = vec![false; n];
    let mut order = Vec::with_capacity(n);
    let mut next: Vec<usize> = Vec::new();
    for s in starts {
        if seen[s] {
            continue;
        }
        seen[s] = true;
        order.push(s);
        let mut head = order.len() - 1;
        while head < order.len() {
            let v = order[head];
            head += 1;
            next.clear();
            for w in neighbours(v) {
                if !seen[w] {
                    seen[w] = true;
                    next.push(w);
                }
            }
            next.sort_unstable_by_key(|&w| (degree[w], w));
            order.extend_from_slice(&next);
        }
    }
    order.reverse();
    order
}

/// Two halves of an ordering that share no edge, and the separator: the
/// first half of `order` (positions < n/2) stays first; the vertices of the
/// second half that have a neighbour in the first (in either triangle of
/// the pattern) move to the end, in their order. Returns the new order and
/// the ends of the two independent halves: vertices `new[..a]` and
/// `new[a..b]` are not adjacent, so their rows of a triangular solve or an
/// ILU(0) factorisation in the new order do not depend on each other.
/// After a bandwidth-reducing ordering (RCM) the separator is about one
/// level of its breadth-first search.
pub fn split_halves(
    n: usize,
    row_ptr: &[usize],
    col: &[usize],
    order: &[usize],
) -> (Vec<usize>, usize, usize) {
    let mut pos = vec![0usize; n];
    for (p, &v) in order.iter().enumerate() {
        pos[v] = p;
    }
    let m = n / 2;
    let mut sep = vec![false; n];
    for i in 0..n {
        for &j in &col[row_ptr[i]..row_ptr[i + 1]] {
            match (pos[i] < m, pos[j] < m) {
                (true, false) => sep[j] = true,
                (false, true) => sep[i] = true,
                _ => {}
            }
        }
    }
    let first = order[..m].iter().copied();
    let second = order[m..].iter().copied().filter(|&v| !sep[v]);
    let mut new: Vec<usize> = first.chain(second).collect();
    let b = new.len();
    new.extend(order[m..].iter().copied().filter(|&v| sep[v]));
    (new, m, b)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Bandwidth of the pattern under `rank` (vertex → position).
    fn bandwidth(rp: &[usize], col: &[usize], rank: &[usize]) -> usize {
        let mut b = 0;
        for i in 0..rp.len() - 1 {
            for &c in &col[rp[i]..rp[i + 1]] {
                b = b.max(rank[i].abs_diff(rank[c]));
            }
        }
        b
    }

    #[test]
    fn permutation_that_narrows_a_shuffled_grid() {
        // 5-point stencil on a 30×30 grid with the vertices shuffled
        let m = 30;
        let n = m * m;
        let shuffle: Vec<usize> = (0..n).map(|i| (i * 367) % n).collect(); // 367 coprime to 900
        let mut rp = vec![0];
        let mut col = Vec::new();
        let mut rows: Vec<Vec<usize>> = vec![Vec::new(); n];
        for i in 0..m {
            for j in 0..m {
                let v = shuffle[i * m + j];
                let mut r = vec![v];
                if i > 0 {
                    r.push(shuffle[(i - 1) * m + j]);
                }
                if i + 1 < m {
                    r.push(shuffle[(i + 1) * m + j]);
                }
                if j > 0 {
                    r.push(shuffle[i * m + j - 1]);
                }
                if j + 1 < m {
                    r.push(shuffle[i * m + j + 1]);
                }
                r.sort_unstable();
                rows[v] = r;
            }
        }
        for r in &rows {
            col.extend_from_slice(r);
            rp.push(col.len());
        }
        let order = reverse_cuthill_mckee(n, &rp, &col);
        let mut rank = vec![usize::MAX; n];
        for (k, &v) in order.iter().enumerate() {
            assert_eq!(rank[v], usize::MAX, "vertex {v} twice");
            rank[v] = k;
        }
        let identity: Vec<usize> = (0..n).collect();
        let before = bandwidth(&rp, &col, &identity);
        let after = bandwidth(&rp, &col, &rank);
        assert!(after <= m + 1, "bandwidth {before} -> {after}");
        assert!(before > 10 * m);
        // isolated vertices and a non-symmetric pattern are numbered too
        let rp = vec![0, 2, 2, 3, 3];
        let col = vec![0, 2, 2];
        let o = reverse_cuthill_mckee(4, &rp, &col);
        let mut s = o.clone();
        s.sort_unstable();
        assert_eq!(s, vec![0, 1, 2, 3]);
        assert_eq!(o, reverse_cuthill_mckee(4, &rp, &col));
    }

    #[test]
    fn the_halves_of_a_split_share_no_edge() {
        // a 30 × 8 grid graph (5-point), RCM, then split
        let (w, h) = (30usize, 8usize);
        let n = w * h;
        let (mut ptr, mut col) = (vec![0], Vec::new());
        for y in 0..h {
            for x in 0..w {
                let v = y * w + x;
                let mut nb = vec![v];
                if x > 0 {
                    nb.push(v - 1);
                }
                if x + 1 < w {
                    nb.push(v + 1);
                }
                if y > 0 {
                    nb.push(v - w);
                }
                if y + 1 < h {
                    nb.push(v + w);
                }
                nb.sort_unstable();
                col.extend(nb);
                ptr.push(col.len());
            }
        }
        let rcm = reverse_cuthill_mckee(n, &ptr, &col);
        let (new, a, b) = split_halves(n, &ptr, &col, &rcm);
        let mut sorted = new.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (0..n).collect::<Vec<_>>());
        assert_eq!(a, n / 2);
        // the separator is one level of the search: a column of 8 or so
        assert!(n - b >= 8 && n - b <= 2 * h, "separator {}", n - b);
        let half = |v: usize| {
            new.iter()
                .position(|&u| u == v)
                .map(|p| (p < a) as u8 + 2 * (p >= a && p < b) as u8)
        };
        for v in 0..n {
            for &u in &col[ptr[v]..ptr[v + 1]] {
                let (hv, hu) = (half(v).unwrap(), half(u).unwrap());
                assert!(!(hv == 1 && hu == 2 || hv == 2 && hu == 1), "{v} {u}");
            }
        }
    }
}
