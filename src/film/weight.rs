//! A soap film's weight carried by its surfactant to the ring that holds it
//! (`film.marangoni`; an addition to the paper, whose film scenes name no
//! gravity).
//!
//! A liquid sheet has no shear strength: hung from a ring under gravity, the
//! paper's model lets it slide down inside itself, thinning at the top and
//! draining into the ring at the bottom. In the blowing bubble (`--scale 2`)
//! film particles within h of the ring moved towards it at up to 1 cm/s in
//! the lower half and away from it at 3 mm/s in the upper half, and the
//! ring's particles absorbed 15 % of the film's mass by t = 0.6 s
//! (docs/decisions.md, "The ring soaks up the film's mass"). A soap film does
//! not drain like that: its surfactant makes the tension vary along the film
//! (Gibbs–Marangoni elasticity) and the gradient holds the film's weight:
//! on a vertical film of thickness τ the two faces' tension difference
//! across a height dz carries the slice's weight, 2 dσ/dz = ρ g τ. For
//! τ = 1 µm that is a difference of 2·10⁻⁴ N/m across the blowing bubble's
//! 38 mm ring, 2 % of σ = 0.01 N/m, so the tension stays uniform to that
//! accuracy and only the stress it adds along the film matters.
//!
//! So with `film.marangoni` a sheet particle connected to a fixed (ring)
//! particle through sheet neighbours within h feels only the normal part
//! (g·n) n of gravity; the part along the film is carried to the ring. A
//! detached film (a bubble) keeps the whole of gravity: it falls freely,
//! and uniform gravity on a free body moves it without draining it.
//! Filament and point particles keep the whole of gravity.

use crate::math::{Real, Vec3};

/// Marks the sheet particles `0..n_sheet` connected to a fixed sheet
/// particle through sheet neighbours (`nbrs(i)`, indices ≥ `n_sheet` are
/// skipped). Linear in the sheet particles and their neighbours.
pub fn held<'a>(n_sheet: usize, fixed: &[bool], nbrs: impl Fn(usize) -> &'a [u32]) -> Vec<bool> {
    let mut seen = vec![false; n_sheet];
    let mut stack: Vec<usize> = (0..n_sheet).filter(|&i| fixed[i]).collect();
    for &i in &stack {
        seen[i] = true;
    }
    while let Some(i) = stack.pop() {
        for &q in nbrs(i) {
            let q = q as usize;
            if q < n_sheet && !seen[q] {
                seen[q] = true;
                stack.push(q);
            }
        }
    }
    seen
}

/// Removes the part of gravity along the film from the forces `f` of the
/// held, moving sheet particles: f_i −= m_i (g − (g·n_i) n_i). `normal(i)`
/// is sheet particle i's unit normal. Returns how many particles were held.
pub fn carry_to_ring(
    f: &mut [Vec3],
    mass: &[Real],
    fixed: &[bool],
    held: &[bool],
    gravity: Vec3,
    normal: impl Fn(usize) -> Vec3,
) -> usize {
    let mut n = 0;
    for (i, &h) in held.iter().enumerate() {
        if h && !fixed[i] {
            let nn = normal(i);
            f[i] -= (gravity - nn * gravity.dot(&nn)) * mass[i];
            n += 1;
        }
    }
    n
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::neighbors::neighbor_lists;

    /// A vertical strip of film hanging from a fixed row, with a detached
    /// patch below it: the strip feels only gravity's normal part, the
    /// patch all of it, and a vertical film's normal part is zero.
    #[test]
    fn a_film_hung_from_a_ring_keeps_only_the_normal_weight_a_detached_one_all() {
        let h = 0.01;
        let s = 0.4 * h;
        let mut x = Vec::new();
        let mut fixed = Vec::new();
        // the ring: a row at y = 0; the film: rows below it to y = -10 s;
        // a separate patch from y = -20 s to -25 s (more than h below)
        for j in (0..=10).chain(20..=25) {
            for i in 0..12 {
                x.push(Vec3::new(i as Real * s, -(j as Real) * s, 0.0));
                fixed.push(j == 0);
            }
        }
        let n = x.len();
        let nl = neighbor_lists(&x, h);
        let held = held(n, &fixed, |i| nl.of(i));
        for i in 0..n {
            assert_eq!(held[i], x[i].y > -10.5 * s, "particle {i} at {:?}", x[i]);
        }
        let mass = vec![2.0; n];
        let g = Vec3::new(0.0, -9.81, 0.0);
        // the film lies in the xy plane (normal z): gravity along -y is all
        // along the film; a tilted gravity keeps its z part
        let g_tilt = Vec3::new(0.0, -9.81, 3.0);
        for (grav, normal_part) in [(g, Vec3::zeros()), (g_tilt, Vec3::new(0.0, 0.0, 3.0))] {
            let mut f: Vec<Vec3> = mass.iter().map(|&m| grav * m).collect();
            let k = carry_to_ring(&mut f, &mass, &fixed, &held, grav, |_| Vec3::z());
            assert_eq!(k, 10 * 12);
            for i in 0..n {
                let want = if held[i] && !fixed[i] {
                    normal_part * 2.0
                } else {
                    grav * 2.0
                };
                assert!((f[i] - want).norm() < 1e-12, "{i}: {:?} vs {want:?}", f[i]);
            }
        }
    }
}
