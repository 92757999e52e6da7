//! Geometry of the surfacer against analytic shapes: a sphere of volume particles (level set and
//! mesh against the sphere's SDF, volume within 2 %), a flat sheet (hole-free slab), a curved
//! sheet, a helix (one connected tube), and watertight, manifold meshes throughout.
mod common;
use common::*;
use surfacer::levelset::voxel_of;
use surfacer::{surface_particles, ParticleFrame, Real, SurfaceOptions, TriMesh, Vec3};

fn assert_closed_manifold(m: &TriMesh, what: &str) {
    let e = m.edge_stats();
    assert!(!m.tris.is_empty(), "{what}: empty mesh");
    assert_eq!(
        (e.boundary, e.non_manifold, e.misoriented),
        (0, 0, 0),
        "{what}: {e:?}"
    );
}

/// Errors (mean, rms, max) of values against an exact function, in voxels.
fn stats(v: impl Iterator<Item = Real>, h: Real) -> (Real, Real, Real) {
    let (mut s, mut s2, mut mx, mut n) = (0.0, 0.0, 0.0f64, 0.0);
    for e in v {
        s += e;
        s2 += e * e;
        mx = mx.max(e.abs());
        n += 1.0;
    }
    (s / n / h, (s2 / n).sqrt() / h, mx / h)
}

#[test]
fn sphere_of_volume_particles_matches_the_sphere() {
    // jittered lattice (±0.1 Δ) inside a ball of 12 Δ with an even surface layer; voxel Δ/2
    let dx = 0.05;
    let mut f = ParticleFrame::default();
    let r = shell_ball(
        &mut f,
        Vec3::zeros(),
        0.6,
        dx,
        0.2,
        Vec3::new(1.0, 0.0, 0.0),
    );
    let g = surface_particles(&f, &SurfaceOptions::default()).unwrap();
    let h = g.stats.voxel;
    assert!((h - 0.5 * dx).abs() < 1e-9);
    // level-set values at active voxels within one voxel of the sphere
    let ls = &g.levelset;
    let vals = ls.leaves.iter().flat_map(|l| {
        (0..512).filter_map(move |n| {
            let k = voxel_of(l.origin, n);
            let x = Vec3::new(k[0] as Real, k[1] as Real, k[2] as Real) * h;
            let exact = x.norm() - r;
            (exact.abs() < h).then(|| l.phi[n] as Real - exact)
        })
    });
    let (lmean, lrms, lmax) = stats(vals, h);
    let m = &g.mesh;
    let (mmean, mrms, mmax) = stats(m.pos.iter().map(|p| p.norm() - r), h);
    let vol = m.volume();
    let exact_vol = 4.0 / 3.0 * std::f64::consts::PI * r.powi(3);
    eprintln!(
        "sphere R={r:.4} Δx={h}: level set mean {lmean:.3} rms {lrms:.3} max {lmax:.3} voxels; mesh mean {mmean:.3} rms {mrms:.3} max {mmax:.3} voxels; volume {:+.3} %; {} tris",
        100.0 * (vol / exact_vol - 1.0),
        m.tris.len()
    );
    // the ball as a simulator leaves it (lattice interior, surface layer spread evenly on the
    // sphere; see `shell_ball` and docs/decisions.md): systematic error within 0.05 voxel, rms
    // within 0.15 and every level-set value and mesh vertex within half a voxel of the sphere
    assert!(
        lmean.abs() < 0.05 && lrms < 0.15 && lmax < 0.5,
        "level set: mean {lmean} rms {lrms} max {lmax} voxels"
    );
    assert!(
        mmean.abs() < 0.05 && mrms < 0.15 && mmax < 0.5,
        "mesh: mean {mmean} rms {mrms} max {mmax} voxels"
    );
    assert!((vol / exact_vol - 1.0).abs() < 0.02);
    assert_closed_manifold(m, "sphere");
    assert_eq!(m.components(), 1);
    // velocity carried to the mesh
    let mean_vx = m.vel.iter().map(|v| v.x).sum::<Real>() / m.vel.len() as Real;
    assert!((mean_vx - 1.0).abs() < 1e-3, "mean vx {mean_vx}");
}

#[test]
fn faceted_lattice_ball_stays_within_its_facets() {
    // the bare jittered lattice (±0.1 Δ) in a ball of 12 Δ, no surface layer: along ⟨110⟩ its
    // outermost (110) plane lies 0.28 Δ = 0.56 voxel inside the volume-equivalent sphere and the
    // surface follows the particles there (measured max 0.64 voxel), so only rms and mean are
    // held to the sphere
    let dx = 0.05;
    let mut f = ParticleFrame::default();
    let r = ball(&mut f, Vec3::zeros(), 0.6, dx, 0.2, Vec3::zeros());
    let g = surface_particles(&f, &SurfaceOptions::default()).unwrap();
    let h = g.stats.voxel;
    let m = &g.mesh;
    let (mmean, mrms, mmax) = stats(m.pos.iter().map(|p| p.norm() - r), h);
    eprintln!("faceted ball: mesh mean {mmean:.3} rms {mrms:.3} max {mmax:.3} voxels");
    assert!(
        mmean.abs() < 0.05 && mrms < 0.25 && mmax < 0.7,
        "mesh: mean {mmean} rms {mrms} max {mmax} voxels"
    );
    assert_closed_manifold(m, "faceted ball");
}

#[test]
fn lone_droplet_does_not_vanish() {
    let dx = 0.05;
    let mut f = ParticleFrame::default();
    ball(&mut f, Vec3::zeros(), 0.3, dx, 0.0, Vec3::zeros());
    f.push(
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::zeros(),
        9999,
        0,
        pscale_of(dx),
        0.125,
        Vec3::zeros(),
    );
    let g = surface_particles(&f, &SurfaceOptions::default()).unwrap();
    assert!(g.levelset.sample(&Vec3::new(1.0, 0.0, 0.0)) < 0.0);
    assert_eq!(g.mesh.components(), 2);
    assert_closed_manifold(&g.mesh, "ball + droplet");
}

#[test]
fn flat_sheet_of_disks_is_a_hole_free_slab() {
    let mut f = ParticleFrame::default();
    let (side, ds, th) = (0.4, 0.02, 0.004);
    flat_sheet(&mut f, 0.0, side, ds, th);
    // a few volume particles far away set the voxel size: Δ = 0.02 → Δx = 0.01
    ball(
        &mut f,
        Vec3::new(2.0, 0.0, 0.0),
        0.05,
        0.02,
        0.0,
        Vec3::zeros(),
    );
    let g = surface_particles(&f, &SurfaceOptions::default()).unwrap();
    let h = g.stats.voxel;
    let ls = &g.levelset;
    // every vertical ray through the sheet's interior meets φ < 0
    let n = (0.45 * side / h) as i32;
    let mut escaped = 0;
    for i in -n..=n {
        for j in -n..=n {
            let hit = (-4..=4).any(|k| ls.value([i, j, k]) < 0.0);
            escaped += (!hit) as usize;
        }
    }
    assert_eq!(escaped, 0, "{escaped} rays escape through the sheet");
    // rays at tilted angles too (sampled trilinearly)
    for a in 0..20 {
        let x0 = Vec3::new(-0.15 + 0.015 * a as Real, 0.1 - 0.01 * a as Real, 0.05);
        let d = Vec3::new(0.3, 0.2, -1.0).normalize();
        let hit = (0..200).any(|s| ls.sample(&(x0 + d * (s as Real * 0.0005))) < 0.0);
        assert!(hit, "tilted ray {a} escapes");
    }
    assert_closed_manifold(&g.mesh, "sheet level set");
    assert_closed_manifold(&g.sheets, "sheet disks");
    // the sheet's own mesh is one component (the ball is another)
    assert_eq!(g.mesh.components(), 2);
    // velocity of the sheet reaches its mesh
    let near: Vec<&Vec3> = g
        .mesh
        .pos
        .iter()
        .zip(&g.mesh.vel)
        .filter(|(p, _)| p.x.abs() < 0.1)
        .map(|(_, v)| v)
        .collect();
    assert!(near.iter().all(|v| (v.z - 1.0).abs() < 1e-6));
}

#[test]
fn curved_sheet_is_closed_and_hole_free() {
    let mut f = ParticleFrame::default();
    curved_sheet(&mut f, 0.2, 0.3, 0.02, 0.004);
    ball(
        &mut f,
        Vec3::new(2.0, 0.0, 0.0),
        0.05,
        0.02,
        0.0,
        Vec3::zeros(),
    );
    let g = surface_particles(&f, &SurfaceOptions::default()).unwrap();
    let ls = &g.levelset;
    // radial rays from the axis cross the wall
    for a in 0..36 {
        let t = a as Real * 10f64.to_radians();
        let d = Vec3::new(t.cos(), t.sin(), 0.0);
        let hit =
            (0..300).any(|s| ls.sample(&(d * (0.1 + s as Real * 0.0007) + Vec3::z() * 0.05)) < 0.0);
        assert!(hit, "radial ray at {a}0° escapes");
    }
    assert_closed_manifold(&g.mesh, "curved sheet");
}

#[test]
fn helix_filament_is_one_connected_tube() {
    let mut f = ParticleFrame::default();
    let n = helix(&mut f, 0.1, 0.08, 2.0, 0.01, 0.006);
    ball(
        &mut f,
        Vec3::new(2.0, 0.0, 0.0),
        0.05,
        0.02,
        0.0,
        Vec3::zeros(),
    );
    let g = surface_particles(&f, &SurfaceOptions::default()).unwrap();
    assert_eq!(
        g.stats.chains, 1,
        "helix of {n} particles must chain into one polyline"
    );
    // level-set mesh: helix + ball = two components, watertight
    assert_closed_manifold(&g.mesh, "helix level set");
    assert_eq!(g.mesh.components(), 2);
    assert_closed_manifold(&g.filaments, "helix tube");
    assert_eq!(g.filaments.components(), 1);
    // the tube passes through every particle
    for i in f.indices_of(2) {
        assert!(g.levelset.sample(&f.pos[i]) < 0.0);
    }
}

#[test]
fn anisotropic_kernels_give_a_flatter_free_surface_than_isotropic() {
    // a jittered slab 24Δ × 24Δ × 6Δ: its top face should be a plane
    let dx = 0.05;
    let mut f = ParticleFrame::default();
    let mut s = 99u64;
    for i in 0..24 {
        for j in 0..24 {
            for k in 0..6 {
                let mut jit = || (rand01(&mut s) - 0.5) * 0.3 * dx;
                let p = Vec3::new(
                    i as Real * dx + jit(),
                    j as Real * dx + jit(),
                    k as Real * dx + jit(),
                );
                let id = f.len() as u32;
                f.push(
                    p,
                    Vec3::zeros(),
                    id,
                    0,
                    pscale_of(dx),
                    RHO * dx.powi(3),
                    Vec3::zeros(),
                );
            }
        }
    }
    let top_rms = |aniso: bool| {
        let mut o = SurfaceOptions::default();
        o.aniso.anisotropic = aniso;
        let g = surface_particles(&f, &o).unwrap();
        let z: Vec<Real> = g
            .mesh
            .pos
            .iter()
            .filter(|p| {
                p.z > 3.0 * dx
                    && (4.0 * dx..19.0 * dx).contains(&p.x)
                    && (4.0 * dx..19.0 * dx).contains(&p.y)
            })
            .map(|p| p.z)
            .collect();
        let mean = z.iter().sum::<Real>() / z.len() as Real;
        let rms = (z.iter().map(|v| (v - mean).powi(2)).sum::<Real>() / z.len() as Real).sqrt();
        (rms / g.stats.voxel, mean)
    };
    let (ra, ma) = top_rms(true);
    let (ri, mi) = top_rms(false);
    eprintln!("top face rms: anisotropic {ra:.3} voxels (z̄ {ma:.4}), isotropic {ri:.3} voxels (z̄ {mi:.4})");
    assert!(ra < ri, "anisotropic {ra} vs isotropic {ri}");
    assert!(ra < 0.1, "anisotropic top face rms {ra} voxels");
    // volume conservation puts both top faces half a spacing above the last layer (z = 5.5 Δ)
    assert!((ma - 5.5 * dx).abs() < 0.1 * dx && (mi - 5.5 * dx).abs() < 0.1 * dx);
}

#[test]
fn sheet_disks_get_the_sheets_thickness_from_mass() {
    // thick sheet (6 voxels) so the clamp does not act: slab thickness = mass / (ρ s²)
    let mut f = ParticleFrame::default();
    let (ds, th) = (0.02, 0.06);
    flat_sheet(&mut f, 0.0, 0.3, ds, th);
    ball(
        &mut f,
        Vec3::new(2.0, 0.0, 0.0),
        0.05,
        0.02,
        0.0,
        Vec3::zeros(),
    );
    let g = surface_particles(&f, &SurfaceOptions::default()).unwrap();
    let h = g.stats.voxel;
    // φ along the normal through the centre crosses zero at ±th/2
    let z0 = (1..60)
        .map(|k| k as Real * 0.1 * h)
        .find(|&z| g.levelset.sample(&Vec3::new(0.0, 0.0, z)) > 0.0)
        .unwrap();
    assert!(
        (z0 - 0.5 * th).abs() < 0.3 * h,
        "half thickness {z0} vs {}",
        0.5 * th
    );
}
