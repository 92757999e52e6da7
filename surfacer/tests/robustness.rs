//! Bad input gives clear errors; results do not depend on the thread count.
mod common;
use common::*;
use surfacer::cache::{frame_path, read_frame, write_frame};
use surfacer::{
    surface_cache, surface_particles, ParticleFrame, SurfaceError, SurfaceOptions, Vec3,
};

fn mixed() -> ParticleFrame {
    let mut f = ParticleFrame::default();
    ball(
        &mut f,
        Vec3::zeros(),
        0.25,
        0.05,
        0.3,
        Vec3::new(0.0, 0.0, -1.0),
    );
    flat_sheet(&mut f, 0.4, 0.3, 0.02, 0.004);
    helix(&mut f, 0.1, 0.05, 1.5, 0.01, 0.004);
    f.push(
        Vec3::new(0.5, 0.5, 0.5),
        Vec3::zeros(),
        77_777,
        3,
        0.01,
        0.004,
        Vec3::zeros(),
    );
    f
}

#[test]
fn same_input_same_bytes_for_any_thread_count() {
    let f = mixed();
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let g = surface_particles(&f, &SurfaceOptions::default()).unwrap();
            (
                surfacer::vdb::encode(&g.levelset),
                g.mesh.pos.clone(),
                g.mesh.tris.clone(),
                g.filaments.tris.len(),
            )
        })
    };
    let a = run(1);
    let b = run(3);
    assert!(a.0 == b.0, "VDB bytes differ between 1 and 3 threads");
    assert_eq!(a.1, b.1);
    assert_eq!(a.2, b.2);
    assert_eq!(a.3, b.3);
}

#[test]
fn mixed_frame_has_all_geometry_and_closed_meshes() {
    let g = surface_particles(&mixed(), &SurfaceOptions::default()).unwrap();
    assert_eq!(g.stats.particles[3], 1);
    assert!(!g.sheets.tris.is_empty() && !g.filaments.tris.is_empty());
    for (m, w) in [
        (&g.mesh, "level set"),
        (&g.sheets, "disks"),
        (&g.filaments, "tubes"),
    ] {
        let e = m.edge_stats();
        assert_eq!(
            (e.boundary, e.non_manifold, e.misoriented),
            (0, 0, 0),
            "{w}: {e:?}"
        );
    }
    // the point particle is inside the level set
    assert!(g.levelset.sample(&Vec3::new(0.5, 0.5, 0.5)) < 0.0);
}

#[test]
fn bad_inputs_are_errors_naming_place_and_reason() {
    let d = tempfile::tempdir().unwrap();
    // no frames
    let e = surface_cache(
        d.path(),
        &d.path().join("o"),
        None,
        &SurfaceOptions::default(),
        &|_, _| {},
    )
    .unwrap_err();
    assert!(matches!(e, SurfaceError::NoFrames { .. }), "{e}");
    // frames outside the range
    let mut f = ParticleFrame::default();
    ball(&mut f, Vec3::zeros(), 0.1, 0.05, 0.0, Vec3::zeros());
    write_frame(&frame_path(d.path(), 3), &f, 3, 0.1).unwrap();
    let e = surface_cache(
        d.path(),
        &d.path().join("o"),
        Some((5, 9)),
        &SurfaceOptions::default(),
        &|_, _| {},
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("5-9"), "{e}");
    // bad options
    let o = SurfaceOptions {
        voxel_size: Some(-1.0),
        ..Default::default()
    };
    let e = surface_particles(&f, &o).unwrap_err().to_string();
    assert!(e.contains("voxel_size") && e.contains("-1"), "{e}");
    // negative radius in a cache
    f.pscale[2] = -0.01;
    write_frame(&frame_path(d.path(), 4), &f, 4, 0.1).unwrap();
    let e = read_frame(&frame_path(d.path(), 4))
        .unwrap_err()
        .to_string();
    assert!(e.contains("particle 2") && e.contains("pscale"), "{e}");
    // missing property
    let p = d.path().join("particles.0005.ply");
    std::fs::write(
        &p,
        "ply\nformat ascii 1.0\nelement vertex 1\nproperty double x\nend_header\n1\n",
    )
    .unwrap();
    let e = read_frame(&p).unwrap_err().to_string();
    assert!(e.contains("`y`"), "{e}");
    // garbage
    std::fs::write(&p, "not a ply").unwrap();
    assert!(read_frame(&p).is_err());
    // empty frame: empty outputs, no panic
    let g = surface_particles(&ParticleFrame::default(), &SurfaceOptions::default()).unwrap();
    assert!(g.mesh.tris.is_empty());
    assert!(!surfacer::vdb::encode(&g.levelset).is_empty());
}

#[test]
fn a_frame_handed_over_gives_the_same_geometry_as_a_borrowed_one() {
    // surface_frame drops the frame after copying the volume particles out (f32 velocities);
    // surface_particles reads it in place: same level set, meshes and velocities
    let mut f = ParticleFrame::default();
    shell_ball(
        &mut f,
        Vec3::zeros(),
        0.3,
        0.05,
        0.2,
        Vec3::new(0.25, -0.5, 1.0),
    );
    flat_sheet(&mut f, 0.6, 0.3, 0.02, 0.004);
    helix(&mut f, 0.1, 0.05, 1.0, 0.01, 0.003);
    let o = SurfaceOptions::default();
    let a = surface_particles(&f, &o).unwrap();
    let b = surfacer::surface_frame(f, &o).unwrap();
    assert!(
        a.levelset.leaves.len() > 20 && a.mesh.tris.len() > 1000,
        "{} leaves, {} triangles",
        a.levelset.leaves.len(),
        a.mesh.tris.len()
    );
    assert_eq!(a.levelset.leaves.len(), b.levelset.leaves.len());
    for (x, y) in a.levelset.leaves.iter().zip(&b.levelset.leaves) {
        assert_eq!(x.origin, y.origin);
        assert_eq!(x.phi, y.phi);
        assert_eq!(x.vel, y.vel);
    }
    for (x, y) in [
        (&a.mesh, &b.mesh),
        (&a.sheets, &b.sheets),
        (&a.filaments, &b.filaments),
    ] {
        assert_eq!(x.tris, y.tris);
        assert_eq!(x.pos, y.pos);
        assert_eq!(x.vel, y.vel);
    }
}
