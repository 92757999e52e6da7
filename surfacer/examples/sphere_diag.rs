//! Diagnostic: where the sphere test's level-set error comes from.
use surfacer::levelset::voxel_of;
use surfacer::{ParticleFrame, Real, SurfaceOptions, Vec3};

fn rand01(s: &mut u64) -> f64 {
    *s = s.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *s;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
}

fn main() {
    let dx: Real = 0.05;
    let r: Real = std::env::var("R")
        .map(|s| s.parse().unwrap())
        .unwrap_or(0.6);
    let jit: Real = std::env::var("JIT")
        .map(|s| s.parse().unwrap())
        .unwrap_or(0.2);
    let mut f = ParticleFrame::default();
    let n = (r / dx).ceil() as i32 + 1;
    let mut s = 12345u64;
    let ps = dx * (3.0 / (4.0 * std::f64::consts::PI)).cbrt();
    for i in -n..=n {
        for j in -n..=n {
            for k in -n..=n {
                let p = Vec3::new(i as Real, j as Real, k as Real) * dx;
                if p.norm() <= r * (1.0 + 1e-9) {
                    let mut jv = || (rand01(&mut s) - 0.5) * jit * dx;
                    let q = p + Vec3::new(jv(), jv(), jv());
                    let id = f.len() as u32;
                    f.push(
                        q,
                        Vec3::x(),
                        id,
                        0,
                        ps,
                        1000.0 * dx * dx * dx,
                        Vec3::zeros(),
                    );
                }
            }
        }
    }
    let rr = (3.0 * f.len() as Real / (4.0 * std::f64::consts::PI)).cbrt() * dx;
    let mut o = SurfaceOptions::default();
    let args: Vec<String> = std::env::args().collect();
    if args.len() > 1 {
        o.aniso.lambda = args[1].parse().unwrap();
    }
    if args.len() > 2 {
        o.iso = args[2].parse().unwrap();
    }
    if args.len() > 3 {
        o.smooth_iterations = args[3].parse().unwrap();
    }
    let g = surfacer::surface_particles(&f, &o).unwrap();
    let h = g.stats.voxel;
    let mut errs: Vec<(Real, Vec3, Real)> = Vec::new();
    for l in &g.levelset.leaves {
        for n in 0..512 {
            let k = voxel_of(l.origin, n);
            let x = Vec3::new(k[0] as Real, k[1] as Real, k[2] as Real) * h;
            let exact = x.norm() - rr;
            if exact.abs() < h {
                errs.push(((l.phi[n] as Real - exact) / h, x, exact / h));
            }
        }
    }
    let nn = errs.len() as Real;
    let mean = errs.iter().map(|e| e.0).sum::<Real>() / nn;
    let rms = (errs.iter().map(|e| e.0 * e.0).sum::<Real>() / nn).sqrt();
    errs.sort_by(|a, b| b.0.abs().partial_cmp(&a.0.abs()).unwrap());
    println!(
        "R {rr:.4} h {h}: mean {mean:.3} rms {rms:.3} max {:.3}, shift {:.4} voxels",
        errs[0].0,
        g.stats.volume_shift / h
    );
    let mm = g.mesh.pos.iter().map(|p| (p.norm() - rr) / h);
    let (mut mx, mut s1) = (0.0f64, 0.0);
    for e in mm {
        mx = mx.max(e.abs());
        s1 += e;
    }
    println!("mesh max {mx:.3} mean {:.3}", s1 / g.mesh.pos.len() as Real);
    for e in errs.iter().take(8) {
        // mesh-surface radius along this direction: nearest mesh vertex direction
        let d = e.1.normalize();
        let best = g
            .mesh
            .pos
            .iter()
            .max_by(|a, b| {
                a.normalize()
                    .dot(&d)
                    .partial_cmp(&b.normalize().dot(&d))
                    .unwrap()
            })
            .unwrap();
        println!(
            "err {:+.3} at dir {:?} exact {:+.3}, mesh radius there {:+.3} voxels",
            e.0,
            (d * 100.0).map(|x| x.round() / 100.0),
            e.2,
            (best.norm() - rr) / h
        );
    }
}
