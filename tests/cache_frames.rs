//! Liquid scenes' caches carry the sheet normal of every sheet particle and
//! the tangent of every filament particle (`docs/cache-format.md`), as film
//! scenes' do: the surfacer orients its disks by them, and Houdini or Blender
//! users read them as `N`. A droplet's surface layer (Appendix F) is a sphere
//! of sheet particles, so its normals are radial.
use codimfx::io::ply;
use codimfx::particles::Codim;
use codimfx::sim::{RunOptions, Sim};
use std::sync::atomic::AtomicBool;

const DROP: &str = "\
version: 1
domain: {min: [0, 0, 0], max: [0.04, 0.04, 0.04], dx: 0.0025}
time: {fps: 100, frames: 1, max_dt: 0.005}
physics: {gravity: [0, 0, 0], surface_tension: 0.03}
bodies:
  - kind: sphere
    center: [0.02, 0.02, 0.02]
    radius: 0.0128
    spacing: 0.5
";

#[test]
fn a_liquid_cache_carries_the_sheet_normals() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("drop.yaml");
    std::fs::write(&scene, DROP).unwrap();
    let opt = RunOptions {
        out_root: Some(dir.path().to_path_buf()),
        frames: Some(1),
        resume: false,
        scale: None,
        verbose: false,
    };
    let mut sim = Sim::open(&scene, &opt).unwrap();
    sim.run(&AtomicBool::new(false), |_, _| {}).unwrap();
    for f in 0..=1 {
        let fr = ply::read(&dir.path().join("drop").join(ply::frame_name(f))).unwrap();
        let p = &fr.particles;
        let (mut sheets, mut radial) = (0, 0);
        for i in 0..p.len() {
            let n = fr.frame_vec[i];
            match p.codim[i] {
                Codim::Volume | Codim::Point => assert_eq!(n.norm(), 0.0),
                Codim::Sheet => {
                    sheets += 1;
                    assert!(
                        (n.norm() - 1.0).abs() < 1e-9,
                        "frame {f}: |n| = {}",
                        n.norm()
                    );
                    let r = (p.x[i] - codimfx::Vec3::new(0.02, 0.02, 0.02)).normalize();
                    if n.dot(&r).abs() > 0.95 {
                        radial += 1;
                    }
                }
                Codim::Filament => assert!((n.norm() - 1.0).abs() < 1e-9),
            }
        }
        assert!(sheets > 500, "frame {f}: {sheets} sheet particles");
        assert!(
            radial as f64 > 0.95 * sheets as f64,
            "frame {f}: {radial} of {sheets} sheet normals within 18° of the radius"
        );
    }
}
