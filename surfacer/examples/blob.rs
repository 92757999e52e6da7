//! Profiling harness: the `codimfx bench surface` blob (sphere r = 0.53 m on a 2×2×0.25 m slab,
//! spacing 0.0125 m, jitter ±0.1) surfaced at voxel = particle radius; prints stage times, heap
//! peak (counting allocator) and VmHWM. `cargo run --release -p surfacer --example blob [OUT_DIR]`
//! (writes the outputs there too). Environment: `STAGES=1` heap peak per stage, `SAMPLE=1` RSS
//! and heap every 20 ms, `BORROWED=1` `surface_particles` instead of handing the frame over,
//! `DEFAULT_MALLOC=1` without `surfacer::alloc::return_freed_memory`, `DEBUG_DEEP=1` deep-particle
//! histogram, `WRITE_XYZ=path` splashsurf's input only.
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;
use surfacer::{ParticleFrame, SurfaceOptions, Vec3};

struct Counting;
static CUR: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        let c = CUR.fetch_add(l.size(), Ordering::Relaxed) + l.size();
        PEAK.fetch_max(c, Ordering::Relaxed);
        unsafe { System.alloc(l) }
    }
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        CUR.fetch_sub(l.size(), Ordering::Relaxed);
        unsafe { System.dealloc(p, l) }
    }
    unsafe fn realloc(&self, p: *mut u8, l: Layout, n: usize) -> *mut u8 {
        if n > l.size() {
            let c = CUR.fetch_add(n - l.size(), Ordering::Relaxed) + n - l.size();
            PEAK.fetch_max(c, Ordering::Relaxed);
        } else {
            CUR.fetch_sub(l.size() - n, Ordering::Relaxed);
        }
        unsafe { System.realloc(p, l, n) }
    }
}
#[global_allocator]
static A: Counting = Counting;

fn rand01(s: &mut u64) -> f64 {
    *s = s.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *s;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
}

fn main() {
    if std::env::var("DEFAULT_MALLOC").is_err() {
        surfacer::alloc::return_freed_memory();
    }
    let dx = 0.0125;
    let (rad, side, th) = (0.53, 2.0, 0.25);
    let mut f = ParticleFrame::default();
    let mut s = 1u64;
    let ps = dx * (3.0 / (4.0 * std::f64::consts::PI)).cbrt();
    let c = Vec3::new(0.0, 0.0, th + 0.05 + rad);
    let half: f64 = side / 2.0;
    let n = ((half.max(c.z + rad)) / dx).ceil() as i64 + 1;
    for i in -n..=n {
        for j in -n..=n {
            for k in 0..=(2 * n) {
                let p = Vec3::new(i as f64, j as f64, k as f64) * dx;
                let in_slab = p.x.abs() <= half && p.y.abs() <= half && p.z <= th;
                let in_ball = (p - c).norm() <= rad;
                if in_slab || in_ball {
                    let mut jit = || (rand01(&mut s) - 0.5) * 0.2 * dx;
                    let q = p + Vec3::new(jit(), jit(), jit());
                    let v = if in_ball {
                        Vec3::new(0.0, 0.0, -1.0)
                    } else {
                        Vec3::zeros()
                    };
                    let id = f.len() as u32;
                    f.push(q, v, id, 0, ps, 1000.0 * dx * dx * dx, Vec3::zeros());
                }
            }
        }
    }
    if std::env::var("DEBUG_DEEP").is_ok() {
        debug_deep(&f);
        return;
    }
    if let Ok(path) = std::env::var("WRITE_XYZ") {
        let mut b = Vec::new();
        for p in &f.pos {
            for c in [p.x, p.y, p.z] {
                b.extend_from_slice(&(c as f32).to_le_bytes());
            }
        }
        std::fs::write(path, b).unwrap();
        return;
    }
    if std::env::var("STAGES").is_ok() {
        stages(&f);
        return;
    }
    let base = CUR.load(Ordering::Relaxed);
    PEAK.store(base, Ordering::Relaxed);
    if std::env::var("SAMPLE").is_ok() {
        // RSS against heap every 20 ms (where the resident peak is)
        let t0 = Instant::now();
        std::thread::spawn(move || loop {
            let s = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
            let rss = s
                .lines()
                .find(|l| l.starts_with("VmRSS:"))
                .unwrap_or("")
                .to_string();
            eprintln!(
                "{:.2} s heap {:.0} MB {rss}",
                t0.elapsed().as_secs_f64(),
                CUR.load(Ordering::Relaxed) as f64 / 1e6
            );
            std::thread::sleep(std::time::Duration::from_millis(20));
        });
    }
    let o = SurfaceOptions {
        voxel_size: Some(dx / 2.0),
        ..Default::default()
    };
    let pvol = f.len() as f64 * dx * dx * dx;
    let np = f.len();
    let t = Instant::now();
    let g = if std::env::var("BORROWED").is_ok() {
        surfacer::surface_particles(&f, &o).unwrap()
    } else {
        surfacer::surface_frame(f, &o).unwrap()
    };
    let tot = t.elapsed().as_secs_f64();
    let st = &g.stats;
    println!(
        "{} particles: total {:.2} s, stages {:?}, heap peak {:.0} MB (input {:.0} MB), leaves {}, active {}, tris {}, verts {}, iso kernels {}, density blocks {}, vol err {:+.3} %",
        np,
        tot,
        st.seconds.map(|x| (x * 100.0).round() / 100.0),
        PEAK.load(Ordering::Relaxed) as f64 / 1e6,
        base as f64 / 1e6,
        st.leaves,
        st.active_voxels,
        st.triangles,
        g.mesh.pos.len(),
        st.isotropic_kernels,
        st.density_blocks,
        100.0 * (g.mesh.volume() / pvol - 1.0)
    );
    eprintln!(
        "{:?} deep {} interior blocks {} components {} edges {:?}",
        st.redistance,
        st.deep_kernels,
        st.interior_blocks,
        g.mesh.components(),
        g.mesh.edge_stats()
    );
    if let Some(dir) = std::env::args().nth(1) {
        let t = Instant::now();
        surfacer::pipeline::write_outputs(std::path::Path::new(&dir), 1, &g).unwrap();
        println!(
            "write {:.2} s, heap peak {:.0} MB",
            t.elapsed().as_secs_f64(),
            PEAK.load(Ordering::Relaxed) as f64 / 1e6
        );
    }
}

#[allow(dead_code)]
fn debug_deep(f: &ParticleFrame) {
    let dx = 0.0125;
    let vol: Vec<f64> = f
        .pscale
        .iter()
        .map(|p| 4.0 / 3.0 * std::f64::consts::PI * p.powi(3))
        .collect();
    let k = surfacer::anisotropy::build_kernels(&f.pos, &vol, dx, &Default::default());
    let c = Vec3::new(0.0, 0.0, 0.25 + 0.05 + 0.53);
    let mut hist = [0usize; 12];
    let mut tot = [0usize; 12];
    for (kk, &i) in k.index.iter().enumerate() {
        let d = 0.53 - (f.pos[i as usize] - c).norm();
        if d > 0.0 {
            let b = ((d / dx) as usize).min(11);
            tot[b] += 1;
            hist[b] += (!k.deep[kk]) as usize;
        }
    }
    eprintln!("non-deep by depth (Δ) in the ball: {hist:?} of {tot:?}");
}

/// The pipeline's volume stages one by one (as `surface_frame` runs them), with the heap peak of
/// each (MB).
fn stages(f: &ParticleFrame) {
    let mb = |x: usize| x as f64 / 1e6;
    let mark = |what: &str| {
        println!(
            "{what}: peak {:.0} MB, now {:.0} MB",
            mb(PEAK.load(Ordering::Relaxed)),
            mb(CUR.load(Ordering::Relaxed))
        );
        PEAK.store(CUR.load(Ordering::Relaxed), Ordering::Relaxed);
    };
    mark("input");
    let o = SurfaceOptions::default();
    let dx = surfacer::pipeline::volume_spacing(f).unwrap();
    let h = dx / 2.0;
    let vol: Vec<f64> = f
        .pscale
        .iter()
        .map(|p| 4.0 / 3.0 * std::f64::consts::PI * p.powi(3))
        .collect();
    let vel: Vec<[f32; 3]> = f
        .vel
        .iter()
        .map(|v| [v.x as f32, v.y as f32, v.z as f32])
        .collect();
    let pos = f.pos.clone();
    mark("extract (input still held)");
    let base = CUR.load(Ordering::Relaxed);
    let k = surfacer::anisotropy::build_kernels_owned(pos, &vol, dx, &o.aniso);
    mark("kernels");
    let d = surfacer::density::rasterize(&k, &vel, h, 3.0 * dx + 2.0 * h);
    drop(k);
    drop(vel);
    mark("density");
    let (mut grid, extra, signs, _) = surfacer::redistance::redistance(d, 0.5, 3.0);
    mark("redistance");
    surfacer::redistance::smooth_band(&mut grid, &|o| signs.mask(o), 1);
    surfacer::redistance::conserve_volume(&mut grid, &signs, f.len() as f64 * dx.powi(3), 3.0);
    drop(signs);
    mark("smooth+volume");
    let ls = grid.finish(extra);
    mark("finish");
    let m = surfacer::mesh::marching_cubes(&ls);
    mark("mesh");
    let _ = surfacer::vdb::encode(&ls);
    mark("vdb encode");
    drop(m);
    println!(
        "(input held by this harness: {:.0} MB; subtract it from the stages after extract)",
        mb(base - vol.len() * 8)
    );
}
