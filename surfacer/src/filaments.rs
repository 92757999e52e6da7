//! Filament particles (codimension 2) as tubes, point particles (codimension 3) as spheres.
//!
//! Chaining: each filament particle looks, within `search_rel` × its spacing, for its nearest
//! neighbour ahead (along its tangent b¹, inside a 60° cone) and behind. A link i–j is kept when
//! it is mutual (j also chose i, ahead or behind, so a flipped tangent sign does not matter);
//! every particle then has at most two links, and the links form open polylines and closed
//! loops. The spacing of a filament particle is its length mass / (ρ π r²). A particle without
//! links becomes a capsule of its own length along its tangent.
//!
//! The level set gets one capsule per link (radii interpolated along it), so the tube is the
//! union of rounded segments; tube radii are clamped below by `min_radius_voxels` · Δx. The
//! explicit mesh sweeps a `sides`-gon along each polyline with parallel-transported frames, with
//! end caps on open chains.
use crate::cache::ParticleFrame;
use crate::hash::CellGrid;
use crate::levelset::Prim;
use crate::mesh::TriMesh;
use crate::sheets::any_perp;
use crate::{Real, Vec3};

/// Parameters of the tubes.
#[derive(Debug, Clone)]
pub struct FilamentParams {
    /// liquid density ρ (kg/m³) for the particle length mass / (ρ π r²)
    pub density: Real,
    /// search radius for chaining, relative to the median particle length
    pub search_rel: Real,
    /// minimal tube radius relative to the voxel size
    pub min_radius_voxels: Real,
    /// sides of the explicit tube mesh
    pub sides: usize,
}

impl Default for FilamentParams {
    fn default() -> Self {
        FilamentParams {
            density: 1000.0,
            search_rel: 2.5,
            min_radius_voxels: 0.75,
            sides: 8,
        }
    }
}

/// Polylines of filament particles (indices into the frame); `closed` for loops.
#[derive(Debug, Clone)]
pub struct Chain {
    /// particle indices in order
    pub nodes: Vec<usize>,
    /// the last node links back to the first
    pub closed: bool,
}

/// Chains the filament particles of `frame`.
pub fn chain_filaments(frame: &ParticleFrame, p: &FilamentParams) -> Vec<Chain> {
    let idx = frame.indices_of(2);
    if idx.is_empty() {
        return Vec::new();
    }
    let pts: Vec<Vec3> = idx.iter().map(|&i| frame.pos[i]).collect();
    let mut len: Vec<Real> = idx
        .iter()
        .map(|&i| frame.mass[i] / (p.density * std::f64::consts::PI * frame.pscale[i].powi(2)))
        .collect();
    len.sort_by(|a, b| a.total_cmp(b));
    let median = len[len.len() / 2];
    let search = (p.search_rel * median).max(1e-9);
    let grid = CellGrid::build(&pts, search);
    let picks: Vec<[Option<usize>; 2]> = (0..idx.len())
        .map(|a| {
            let t = frame.frame[idx[a]];
            let t = if t.norm() > 0.0 {
                t.normalize()
            } else {
                Vec3::x()
            };
            let mut best = [(Real::INFINITY, None); 2];
            grid.for_each_within(&pts, &pts[a], search, |j, d2| {
                if j == a || d2 == 0.0 {
                    return;
                }
                let d = pts[j] - pts[a];
                let c = d.dot(&t) / d2.sqrt();
                let slot = if c > 0.5 {
                    0
                } else if c < -0.5 {
                    1
                } else {
                    return;
                };
                if d2 < best[slot].0 || (d2 == best[slot].0 && Some(j) < best[slot].1) {
                    best[slot] = (d2, Some(j));
                }
            });
            [best[0].1, best[1].1]
        })
        .collect();
    let mut adj: Vec<Vec<usize>> = vec![Vec::new(); idx.len()];
    for a in 0..idx.len() {
        for j in picks[a].into_iter().flatten() {
            if picks[j].contains(&Some(a)) && a < j {
                adj[a].push(j);
                adj[j].push(a);
            }
        }
    }
    let mut seen = vec![false; idx.len()];
    let mut chains = Vec::new();
    let walk = |start: usize, seen: &mut Vec<bool>| {
        let mut nodes = vec![start];
        seen[start] = true;
        let mut prev = usize::MAX;
        let mut cur = start;
        let mut closed = false;
        loop {
            let next = adj[cur].iter().copied().find(|&n| n != prev && !seen[n]);
            match next {
                Some(n) => {
                    seen[n] = true;
                    nodes.push(n);
                    prev = cur;
                    cur = n;
                }
                None => {
                    if nodes.len() > 2 && adj[cur].contains(&start) {
                        closed = true;
                    }
                    break;
                }
            }
        }
        Chain {
            nodes: nodes.into_iter().map(|a| idx[a]).collect(),
            closed,
        }
    };
    for a in 0..idx.len() {
        if !seen[a] && adj[a].len() <= 1 {
            chains.push(walk(a, &mut seen));
        }
    }
    for a in 0..idx.len() {
        if !seen[a] {
            chains.push(walk(a, &mut seen));
        }
    }
    chains
}

fn radius(frame: &ParticleFrame, i: usize, min_r: Real) -> Real {
    frame.pscale[i].max(min_r)
}

/// Capsules of the chains, plus spheres for the point particles (codim 3), with velocities.
pub fn tube_prims(
    frame: &ParticleFrame,
    chains: &[Chain],
    voxel: Real,
    p: &FilamentParams,
) -> Vec<(Prim, Vec3)> {
    let min_r = p.min_radius_voxels * voxel;
    let mut out = Vec::new();
    for ch in chains {
        let n = ch.nodes.len();
        if n == 1 {
            let i = ch.nodes[0];
            let t = frame.frame[i];
            let t = if t.norm() > 0.0 {
                t.normalize()
            } else {
                Vec3::x()
            };
            let half =
                0.5 * frame.mass[i] / (p.density * std::f64::consts::PI * frame.pscale[i].powi(2));
            let r = radius(frame, i, min_r);
            let half = (half - r).max(0.0);
            out.push((
                Prim::Capsule {
                    a: frame.pos[i] - half * t,
                    b: frame.pos[i] + half * t,
                    ra: r,
                    rb: r,
                },
                frame.vel[i],
            ));
            continue;
        }
        let segs = if ch.closed { n } else { n - 1 };
        for s in 0..segs {
            let (i, j) = (ch.nodes[s], ch.nodes[(s + 1) % n]);
            out.push((
                Prim::Capsule {
                    a: frame.pos[i],
                    b: frame.pos[j],
                    ra: radius(frame, i, min_r),
                    rb: radius(frame, j, min_r),
                },
                0.5 * (frame.vel[i] + frame.vel[j]),
            ));
        }
    }
    for i in frame.indices_of(3) {
        out.push((
            Prim::Sphere {
                c: frame.pos[i],
                r: radius(frame, i, min_r),
            },
            frame.vel[i],
        ));
    }
    out
}

/// Explicit tube meshes of the chains (capsule-like tubes for single particles) and spheres for
/// the points, all closed.
pub fn tubes_mesh(
    frame: &ParticleFrame,
    chains: &[Chain],
    prims: &[(Prim, Vec3)],
    voxel: Real,
    p: &FilamentParams,
) -> TriMesh {
    let min_r = p.min_radius_voxels * voxel;
    let mut m = TriMesh::default();
    let sides = p.sides.max(3);
    let mut k = 0;
    for ch in chains {
        // polyline points, radii, velocities
        let (pts, rad, vel): (Vec<Vec3>, Vec<Real>, Vec<Vec3>) = if ch.nodes.len() == 1 {
            let Prim::Capsule { a, b, ra, .. } = prims[k].0 else {
                continue;
            };
            k += 1;
            let v = prims[k - 1].1;
            let t = (b - a).try_normalize(0.0).unwrap_or_else(Vec3::x);
            (
                vec![a - 0.5 * ra * t, b + 0.5 * ra * t],
                vec![ra, ra],
                vec![v, v],
            )
        } else {
            k += if ch.closed {
                ch.nodes.len()
            } else {
                ch.nodes.len() - 1
            };
            (
                ch.nodes.iter().map(|&i| frame.pos[i]).collect(),
                ch.nodes.iter().map(|&i| radius(frame, i, min_r)).collect(),
                ch.nodes.iter().map(|&i| frame.vel[i]).collect(),
            )
        };
        sweep(
            &mut m,
            &pts,
            &rad,
            &vel,
            ch.closed && ch.nodes.len() > 2,
            sides,
        );
    }
    for (prim, v) in &prims[k..] {
        if let Prim::Sphere { c, r } = *prim {
            sphere(&mut m, c, r, *v, sides);
        }
    }
    m
}

fn sweep(m: &mut TriMesh, pts: &[Vec3], rad: &[Real], vel: &[Vec3], closed: bool, sides: usize) {
    let n = pts.len();
    let tangent = |i: usize| -> Vec3 {
        let (a, b) = if closed {
            (pts[(i + n - 1) % n], pts[(i + 1) % n])
        } else {
            (pts[i.saturating_sub(1)], pts[(i + 1).min(n - 1)])
        };
        (b - a).try_normalize(0.0).unwrap_or_else(Vec3::x)
    };
    let base = m.pos.len() as u32;
    let mut u = any_perp(&tangent(0));
    for i in 0..n {
        let t = tangent(i);
        // parallel transport: remove the tangential part of the previous frame vector
        u = (u - u.dot(&t) * t)
            .try_normalize(1e-12)
            .unwrap_or_else(|| any_perp(&t));
        let w = t.cross(&u);
        for s in 0..sides {
            let a = 2.0 * std::f64::consts::PI * s as Real / sides as Real;
            let d = a.cos() * u + a.sin() * w;
            m.pos.push(pts[i] + rad[i] * d);
            m.normal.push(d);
            m.vel.push(vel[i]);
        }
    }
    let ring = |i: usize, s: usize| base + (i * sides + s % sides) as u32;
    let segs = if closed { n } else { n - 1 };
    for i in 0..segs {
        let j = (i + 1) % n;
        for s in 0..sides {
            m.tris.push([ring(i, s), ring(j, s + 1), ring(j, s)]);
            m.tris.push([ring(i, s), ring(i, s + 1), ring(j, s + 1)]);
        }
    }
    if !closed {
        for (i, sign) in [(0usize, -1.0), (n - 1, 1.0)] {
            let c = m.pos.len() as u32;
            m.pos.push(pts[i]);
            m.normal.push(sign * tangent(i));
            m.vel.push(vel[i]);
            for s in 0..sides {
                if sign < 0.0 {
                    m.tris.push([c, ring(i, s + 1), ring(i, s)]);
                } else {
                    m.tris.push([c, ring(i, s), ring(i, s + 1)]);
                }
            }
        }
    }
}

fn sphere(m: &mut TriMesh, c: Vec3, r: Real, v: Vec3, sides: usize) {
    let stacks = (sides / 2).max(2);
    let base = m.pos.len() as u32;
    let pole = |m: &mut TriMesh, d: Vec3| {
        m.pos.push(c + r * d);
        m.normal.push(d);
        m.vel.push(v);
    };
    pole(m, Vec3::z());
    for i in 1..stacks {
        let th = std::f64::consts::PI * i as Real / stacks as Real;
        for s in 0..sides {
            let ph = 2.0 * std::f64::consts::PI * s as Real / sides as Real;
            pole(
                m,
                Vec3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos()),
            );
        }
    }
    pole(m, -Vec3::z());
    let ring = |i: usize, s: usize| base + 1 + ((i - 1) * sides + s % sides) as u32;
    let last = base + 1 + ((stacks - 1) * sides) as u32;
    for s in 0..sides {
        m.tris.push([base, ring(1, s), ring(1, s + 1)]);
        m.tris
            .push([last, ring(stacks - 1, s + 1), ring(stacks - 1, s)]);
    }
    for i in 1..stacks - 1 {
        for s in 0..sides {
            m.tris
                .push([ring(i, s), ring(i + 1, s), ring(i + 1, s + 1)]);
            m.tris
                .push([ring(i, s), ring(i + 1, s + 1), ring(i, s + 1)]);
        }
    }
}
