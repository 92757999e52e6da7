//! Test caches generated in the documented PLY layout: a sphere of volume particles, flat and
//! curved sheets, a helix filament, and a mix.
#![allow(dead_code)]
use surfacer::{ParticleFrame, Real, Vec3};

pub const RHO: Real = 1000.0;

/// Deterministic numbers in [0, 1) (SplitMix64).
pub fn rand01(s: &mut u64) -> Real {
    *s = s.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *s;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    ((z ^ (z >> 31)) >> 11) as Real / (1u64 << 53) as Real
}

/// Sphere-equivalent radius of a lattice cell of side `dx`.
pub fn pscale_of(dx: Real) -> Real {
    dx * (3.0 / (4.0 * std::f64::consts::PI)).cbrt()
}

/// Volume particles on a lattice of spacing `dx` (jitter `jit`·dx) inside a ball of radius `r`
/// at `c`, moving with velocity `v`. Returns the frame and the volume-equivalent radius.
pub fn ball(f: &mut ParticleFrame, c: Vec3, r: Real, dx: Real, jit: Real, v: Vec3) -> Real {
    let n = (r / dx).ceil() as i32 + 1;
    let mut s = 12345u64;
    let before = f.len();
    for i in -n..=n {
        for j in -n..=n {
            for k in -n..=n {
                let p = Vec3::new(i as Real, j as Real, k as Real) * dx;
                // lattice points exactly on the sphere belong to the ball (without the tolerance,
                // rounding dropped e.g. (12, 0, 0)·0.05 = 0.6000000000000001 from a ball of 0.6)
                if p.norm() <= r * (1.0 + 1e-12) {
                    let mut jv = || (rand01(&mut s) - 0.5) * jit * dx;
                    let q = c + p + Vec3::new(jv(), jv(), jv());
                    let id = f.len() as u32;
                    f.push(
                        q,
                        v,
                        id,
                        0,
                        pscale_of(dx),
                        RHO * dx * dx * dx,
                        Vec3::zeros(),
                    );
                }
            }
        }
    }
    let count = (f.len() - before) as Real;
    (3.0 * count / (4.0 * std::f64::consts::PI)).cbrt() * dx
}

/// A flat square sheet in the plane z = `z0`, side `side`, particle spacing `ds`, thickness `th`.
pub fn flat_sheet(f: &mut ParticleFrame, z0: Real, side: Real, ds: Real, th: Real) {
    let n = (side / ds).round() as i32;
    for i in 0..=n {
        for j in 0..=n {
            let p = Vec3::new(i as Real * ds - 0.5 * side, j as Real * ds - 0.5 * side, z0);
            let id = f.len() as u32;
            f.push(
                p,
                Vec3::new(0.0, 0.0, 1.0),
                id,
                1,
                0.5 * th,
                RHO * ds * ds * th,
                Vec3::z(),
            );
        }
    }
}

/// A cylindrical sheet (curved) of radius `r`, height `len`, spacing `ds`, thickness `th`.
pub fn curved_sheet(f: &mut ParticleFrame, r: Real, len: Real, ds: Real, th: Real) {
    let na = (2.0 * std::f64::consts::PI * r / ds).round() as i32;
    let nz = (len / ds).round() as i32;
    for a in 0..na {
        let t = 2.0 * std::f64::consts::PI * a as Real / na as Real;
        let n = Vec3::new(t.cos(), t.sin(), 0.0);
        for k in 0..=nz {
            let p = r * n + Vec3::new(0.0, 0.0, k as Real * ds - 0.5 * len);
            let id = f.len() as u32;
            f.push(p, Vec3::zeros(), id, 1, 0.5 * th, RHO * ds * ds * th, n);
        }
    }
}

/// A helix filament: radius `a`, pitch `b` per turn, `turns`, particle spacing `ds`, tube radius
/// `rt`.
pub fn helix(f: &mut ParticleFrame, a: Real, b: Real, turns: Real, ds: Real, rt: Real) -> usize {
    let c = b / (2.0 * std::f64::consts::PI);
    let speed = (a * a + c * c).sqrt();
    let total = turns * 2.0 * std::f64::consts::PI * speed;
    let n = (total / ds).round() as usize;
    for i in 0..=n {
        let t = i as Real * ds / speed;
        let p = Vec3::new(a * t.cos(), a * t.sin(), c * t);
        let tan = Vec3::new(-a * t.sin(), a * t.cos(), c) / speed;
        let id = f.len() as u32;
        let m = RHO * std::f64::consts::PI * rt * rt * ds;
        f.push(p, tan * 0.1, id, 2, rt, m, tan);
    }
    n + 1
}

/// A ball of volume particles as a simulator leaves it at a free surface: a jittered lattice
/// (spacing `dx`, jitter `jit`·dx) strictly inside `r - dx`, and a surface layer of particles
/// spread evenly (Fibonacci spiral, radial jitter `jit`·dx/2) on the sphere of radius `r - dx/2`,
/// so the outermost particles sit half a spacing inside the surface on every direction instead of
/// on a faceted lattice. The layer holds as many particles as bring the total volume (count·dx³)
/// to that of the ball of radius `r`. Returns the volume-equivalent radius.
pub fn shell_ball(f: &mut ParticleFrame, c: Vec3, r: Real, dx: Real, jit: Real, v: Vec3) -> Real {
    let n = (r / dx).ceil() as i32 + 1;
    let mut s = 12345u64;
    let before = f.len();
    let add = |f: &mut ParticleFrame, q: Vec3| {
        let id = f.len() as u32;
        f.push(
            q,
            v,
            id,
            0,
            pscale_of(dx),
            RHO * dx * dx * dx,
            Vec3::zeros(),
        );
    };
    for i in -n..=n {
        for j in -n..=n {
            for k in -n..=n {
                let p = Vec3::new(i as Real, j as Real, k as Real) * dx;
                if p.norm() < r - dx {
                    let mut jv = || (rand01(&mut s) - 0.5) * jit * dx;
                    let q = c + p + Vec3::new(jv(), jv(), jv());
                    add(f, q);
                }
            }
        }
    }
    let total = (4.0 / 3.0 * std::f64::consts::PI * (r / dx).powi(3)).round() as usize;
    let shell = total.saturating_sub(f.len() - before);
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    for i in 0..shell {
        let z = 1.0 - (2.0 * i as Real + 1.0) / shell as Real;
        let rho = (1.0 - z * z).sqrt();
        let t = golden * i as Real;
        let dir = Vec3::new(rho * t.cos(), rho * t.sin(), z);
        let rr = r - 0.5 * dx + (rand01(&mut s) - 0.5) * 0.5 * jit * dx;
        add(f, c + rr * dir);
    }
    let count = (f.len() - before) as Real;
    (3.0 * count / (4.0 * std::f64::consts::PI)).cbrt() * dx
}
