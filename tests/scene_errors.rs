//! Strict scene loading: each class of bad input is rejected before any work
//! with the file, the field path, the line and column, and the reason.
use codimfx::scene::{load, load_str, SceneError};
use std::path::Path;

const GOOD: &str = "\
version: 1
domain:
  min: [0, 0, 0]
  max: [1, 0.5, 0.5]
  dx: 0.05
time:
  fps: 30
  frames: 10
physics:
  density: 1000
  viscosity: 0
bodies:
  - kind: box
    min: [0, 0, 0]
    max: [0.3, 0.3, 0.5]
  - kind: sphere
    center: [0.7, 0.25, 0.25]
    radius: 0.1
solids:
  - kind: sphere
    center: [0.5, 0.0, 0.25]
    radius: 0.1
";

fn err(text: &str) -> SceneError {
    load_str(text, Path::new("scene.yaml")).expect_err("scene must be rejected")
}

fn check(e: &SceneError, path: &str, line: usize, reason: &str) {
    let msg = e.to_string();
    assert_eq!(e.path(), path, "{msg}");
    assert_eq!(e.location().map(|l| l.0), Some(line), "{msg}");
    assert!(msg.starts_with("scene.yaml:"), "{msg}");
    assert!(msg.contains(reason), "expected {reason:?} in {msg}");
}

#[test]
fn the_reference_scene_loads() {
    let s = load_str(GOOD, Path::new("scene.yaml")).unwrap();
    assert_eq!(s.bodies.len(), 2);
    assert_eq!(s.time.cfl, 1.0);
    assert!((s.bodies[0].spacing() - 1.0 / 3.0).abs() < 1e-15);
}

#[test]
fn unknown_keys_are_rejected() {
    let e = err(&GOOD.replace("  viscosity: 0", "  viscosty: 0"));
    assert!(matches!(e, SceneError::Parse { .. }));
    check(&e, "physics.viscosty", 11, "unknown field `viscosty`");
    // inside a tagged list item
    let e = err(&GOOD.replace(
        "    radius: 0.1\nsolids",
        "    radius: 0.1\n    colour: red\nsolids",
    ));
    assert!(e.path().starts_with("bodies[1]"), "{e}");
    assert!(e.to_string().contains("colour"), "{e}");
    assert_eq!(e.location().unwrap().0, 19, "{e}");
    // an unknown body kind
    let e = err(&GOOD.replace("kind: box", "kind: blob"));
    assert!(e.to_string().contains("blob"), "{e}");
    assert_eq!(e.location().unwrap().0, 13, "{e}");
}

#[test]
fn wrong_types_are_rejected() {
    let e = err(&GOOD.replace("dx: 0.05", "dx: fine"));
    check(&e, "domain.dx", 5, "invalid type");
    let e = err(&GOOD.replace("frames: 10", "frames: -3"));
    check(&e, "time.frames", 8, "frames");
}

#[test]
fn missing_required_fields_are_rejected() {
    let e = err(&GOOD.replace("  dx: 0.05\n", ""));
    assert!(e.to_string().contains("missing field `dx`"), "{e}");
    assert_eq!(e.path(), "domain", "{e}");
    let e = err(&GOOD.replace("    radius: 0.1\nsolids", "solids"));
    assert!(e.to_string().contains("missing field `radius`"), "{e}");
    assert!(e.path().starts_with("bodies[1]"), "{e}");
}

#[test]
fn physically_invalid_values_are_rejected_with_their_numbers() {
    let e = err(&GOOD.replace("density: 1000", "density: -5"));
    assert!(matches!(e, SceneError::Invalid { .. }));
    check(&e, "physics.density", 10, "-5");
    let e = err(&GOOD.replace("frames: 10", "frames: 10\n  max_dt: 0"));
    check(&e, "time.max_dt", 9, "positive");
    // a body outside the domain
    let e = err(&GOOD.replace("center: [0.7, 0.25, 0.25]", "center: [0.95, 0.25, 0.25]"));
    check(&e, "bodies[1]", 16, "1.05");
    let e = err(&GOOD.replace("dx: 0.05", "dx: 0"));
    check(&e, "domain.dx", 5, "positive");
    let e = err(&GOOD.replace("radius: 0.1\n", "radius: -0.1\n"));
    check(&e, "bodies[1].radius", 18, "-0.1");
    let e = err(&GOOD.replace("  viscosity: 0", "  viscosity: 0\n  surface_tension: 0.07"));
    check(&e, "physics.surface_tension", 12, "0.07");
}

#[test]
fn malformed_yaml_and_missing_files_are_reported() {
    let e = err("version: 1\ndomain: [\n");
    assert!(e.location().is_some(), "{e}");
    let e = load(Path::new("/nonexistent/scene.yaml")).unwrap_err();
    assert!(matches!(e, SceneError::Io { .. }));
    assert!(e.to_string().contains("/nonexistent/scene.yaml"));
}

#[test]
fn the_presets_load() {
    for p in [
        "presets/dam_break.yaml",
        "presets/droplet_on_plane_nosurface.yaml",
    ] {
        load(Path::new(p)).unwrap_or_else(|e| panic!("{e}"));
    }
}
