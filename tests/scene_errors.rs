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
    let e = err(&GOOD.replace("  viscosity: 0", "  viscosity: 0\n  surface_tension: -0.07"));
    check(&e, "physics.surface_tension", 12, "-0.07");
    let e = err(&GOOD.replace("  viscosity: 0", "  viscosity: 0\n  surface_tension: .nan"));
    check(&e, "physics.surface_tension", 12, "NaN");
}

#[test]
fn liquids_with_surface_tension_load_with_a_surface_layer() {
    let s = load_str(
        &GOOD.replace("  viscosity: 0", "  viscosity: 0\n  surface_tension: 0.07"),
        Path::new("scene.yaml"),
    )
    .unwrap();
    assert_eq!(s.physics.surface_tension, 0.07);
    assert!(s.bodies.iter().all(|b| b.surface_layer(0.07)));
    // explicit off, and default off without tension
    let s = load_str(
        &GOOD.replace(
            "    radius: 0.1\nsolids",
            "    radius: 0.1\n    surface_layer: false\nsolids",
        ),
        Path::new("scene.yaml"),
    )
    .unwrap();
    assert!(!s.bodies[1].surface_layer(0.07) && !s.bodies[0].surface_layer(0.0));
    let e = err(&GOOD.replace(
        "    radius: 0.1\nsolids",
        "    radius: 0.1\n    surface_layer: maybe\nsolids",
    ));
    assert!(e.path().starts_with("bodies[1]"), "{e}");
    assert!(e.to_string().contains("invalid type"), "{e}");
    assert_eq!(e.location().unwrap().0, 16, "{e}");
}

const JET: &str = "\
jets:
  - origin: [0.5, 0.4, 0.25]
    direction: [0, -1, 0]
    radius: 0.05
    speed: 0.1
";

fn with_jet(jet: &str) -> String {
    format!("{GOOD}{jet}")
}

#[test]
fn jets_load_with_defaults_and_bad_jets_are_rejected() {
    let s = load_str(&with_jet(JET), Path::new("scene.yaml")).unwrap();
    let j = &s.jets[0];
    assert!((j.spacing - 1.0 / 3.0).abs() < 1e-15 && j.start == 0.0 && j.stop.is_none());
    let em = j.emitter(s.domain.dx, s.physics.density);
    assert!(em.stop.is_infinite() && (em.spacing - 0.05 / 3.0).abs() < 1e-15);
    // a jet alone is a liquid scene
    let only = with_jet(JET).replace(
        "bodies:\n  - kind: box\n    min: [0, 0, 0]\n    max: [0.3, 0.3, 0.5]\n  - kind: sphere\n    center: [0.7, 0.25, 0.25]\n    radius: 0.1\n",
        "",
    );
    assert!(!only.contains("bodies"));
    let s = load_str(&only, Path::new("scene.yaml")).unwrap();
    assert!(s.bodies.is_empty() && s.has_liquid());
    // line numbers: GOOD has 22 lines, the jet block starts at line 23
    let e = err(&with_jet(&JET.replace("[0, -1, 0]", "[0, 0, 0]")));
    check(&e, "jets[0].direction", 25, "non-zero");
    let e = err(&with_jet(&JET.replace("speed: 0.1", "speed: 0")));
    check(&e, "jets[0].speed", 27, "got 0 m/s");
    let e = err(&with_jet(&JET.replace("radius: 0.05", "radius: 0.01")));
    check(
        &e,
        "jets[0].radius",
        26,
        "smaller than the particle spacing",
    );
    let e = err(&with_jet(
        &JET.replace("[0.5, 0.4, 0.25]", "[0.5, 0.48, 0.25]"),
    ));
    check(&e, "jets[0].origin", 24, "leaves the domain");
    let e = err(&with_jet(&format!("{JET}    spacing: 1.5\n")));
    check(&e, "jets[0].spacing", 28, "1.5");
    let e = err(&with_jet(&format!("{JET}    start: 1\n    stop: 0.5\n")));
    check(&e, "jets[0].stop", 29, "after start = 1 s");
    let e = err(&with_jet(&format!("{JET}    rate: 3\n")));
    assert!(matches!(e, SceneError::Parse { .. }));
    assert!(e.to_string().contains("unknown field `rate`"), "{e}");
    assert_eq!(e.location().unwrap().0, 28, "{e}");
    // free films cannot join a liquid
    let e = err(&with_jet(
        "films:\n  - kind: disk\n    center: [0.5, 0.25, 0.25]\n    normal: [0, 1, 0]\n    radius: 0.2\n",
    ));
    check(&e, "films", 23, "not supported");
}

#[test]
fn pipes_rim_modulation_and_coupling_settings_are_checked() {
    let pipe = "  - kind: pipe\n    center: [0.5, 0.4, 0.25]\n    axis: [0, 1, 0]\n    inner_radius: 0.05\n    outer_radius: 0.08\n    height: 0.1\n";
    let s = load_str(&format!("{GOOD}{pipe}"), Path::new("scene.yaml")).unwrap();
    assert_eq!(s.solids.len(), 2);
    let e = err(&format!("{GOOD}{}", pipe.replace("0.08", "0.04")));
    check(
        &e,
        "solids[1].outer_radius",
        27,
        "must exceed the inner radius 0.05",
    );
    let e = err(&format!("{GOOD}{}", pipe.replace("inner_radius", "bore")));
    assert!(e.to_string().contains("unknown field `bore`"), "{e}");
    // rim modulation (fluid polygon)
    let rim = "film:\n  rim_modulation:\n    corners: 6\n    amplitude: 0.5\n    center: [0.5, 0.25, 0.25]\n";
    let s = load_str(&format!("{GOOD}{rim}"), Path::new("scene.yaml")).unwrap();
    assert_eq!(s.film.rim_modulation.as_ref().unwrap().corners, 6);
    let e = err(&format!(
        "{GOOD}{}",
        rim.replace("corners: 6", "corners: 1")
    ));
    check(&e, "film.rim_modulation.corners", 25, "at least 2");
    let e = err(&format!(
        "{GOOD}{}",
        rim.replace("amplitude: 0.5", "amplitude: 1.2")
    ));
    check(&e, "film.rim_modulation.amplitude", 26, "1.2");
    // the teeth's turn: degrees, default 0
    assert_eq!(s.film.rim_modulation.as_ref().unwrap().phase, 0.0);
    let s = load_str(
        &format!("{GOOD}{rim}    phase: 30\n"),
        Path::new("scene.yaml"),
    )
    .unwrap();
    let saw = s.film.rim_modulation.as_ref().unwrap().sawtooth();
    assert!((saw.phase - std::f64::consts::PI / 6.0).abs() < 1e-15);
    let e = err(&format!("{GOOD}{rim}    phase: .nan\n"));
    check(&e, "film.rim_modulation.phase", 28, "finite");
    // coupling: defaults and bad values
    let s = load_str(GOOD, Path::new("scene.yaml")).unwrap();
    assert_eq!(s.coupling.tolerance, 1e-9);
    assert_eq!(s.coupling.max_iterations, 2000);
    assert_eq!(
        s.coupling.method,
        codimfx::scene::CouplingMethod::Monolithic
    );
    let s = load_str(
        &format!("{GOOD}coupling: {{method: schur}}\n"),
        Path::new("scene.yaml"),
    )
    .unwrap();
    assert_eq!(s.coupling.method, codimfx::scene::CouplingMethod::Schur);
    let e = err(&format!("{GOOD}coupling:\n  tolerance: 2\n"));
    check(&e, "coupling.tolerance", 24, "(0, 1)");
    let e = err(&format!("{GOOD}coupling:\n  max_iterations: 0\n"));
    check(&e, "coupling.max_iterations", 24, "at least 1");
    assert_eq!(s.coupling.mass_floor, 0.05);
    assert_eq!(s.coupling.krylov, codimfx::scene::KrylovSetting::Gmres);
    assert_eq!(s.coupling.restart, 300);
    assert_eq!(s.coupling.fill_passes, 2);
    let e = err(&format!("{GOOD}coupling:\n  fill_passes: 4\n"));
    check(&e, "coupling.fill_passes", 24, "1, 2 or 3");
    let e = err(&format!("{GOOD}coupling:\n  restart: 0\n"));
    check(&e, "coupling.restart", 24, "[1, 5000]");
    assert_eq!(s.film.implicit, codimfx::scene::FilmImplicit::Full);
    let d = load_str(
        &format!("{GOOD}film: {{implicit: diffusive}}\n"),
        Path::new("scene.yaml"),
    )
    .unwrap();
    assert_eq!(d.film.implicit, codimfx::scene::FilmImplicit::Diffusive);
    assert_eq!(s.film.point_cfl, None);
    let e = err(&format!("{GOOD}film:\n  point_cfl: -1\n"));
    check(&e, "film.point_cfl", 24, "(0, 1000]");
    assert_eq!(s.film.drift_cfl, None);
    let e = err(&format!("{GOOD}film:\n  cfl: 0.5\n  drift_cfl: 0.25\n"));
    check(&e, "film.drift_cfl", 25, "[film.cfl = 0.5, 10]");
    let e = err(&format!("{GOOD}film:\n  implicit: half\n"));
    assert!(e.to_string().contains("unknown variant `half`"), "{e}");
    assert_eq!(e.path(), "film.implicit", "{e}");
    let e = err(&format!("{GOOD}coupling:\n  krylov: cg\n"));
    assert!(e.to_string().contains("unknown variant `cg`"), "{e}");
    assert_eq!(e.path(), "coupling.krylov", "{e}");
    assert_eq!(
        s.coupling.face_mass,
        codimfx::scene::FaceMassSetting::Balanced
    );
    let e = err(&format!("{GOOD}coupling:\n  mass_floor: 0\n"));
    check(&e, "coupling.mass_floor", 24, "[1e-4, 1]");
    assert_eq!(s.coupling.tension_theta, 0.5);
    let e = err(&format!("{GOOD}coupling:\n  tension_theta: 0.3\n"));
    check(&e, "coupling.tension_theta", 24, "[0.5, 1], got 0.3");
    let e = err(&format!("{GOOD}coupling:\n  method: cg\n"));
    assert!(e.to_string().contains("unknown variant `cg`"), "{e}");
    assert_eq!(e.path(), "coupling.method", "{e}");
    assert_eq!(e.location().unwrap().0, 24, "{e}");
}

#[test]
fn a_resolution_scale_rescales_dx_and_is_checked_again() {
    use codimfx::scene::load_str_scaled;
    let s = load_str_scaled(GOOD, Path::new("scene.yaml"), 2.0).unwrap();
    assert_eq!(s.domain.dx, 0.1);
    assert_eq!(s.bodies[0].spacing(), 1.0 / 3.0);
    // 0.5 m / (0.05 m x 6) < 2 cells: rejected, saying the scale did it
    let e = load_str_scaled(GOOD, Path::new("scene.yaml"), 6.0).unwrap_err();
    check(&e, "domain.dx", 5, "fewer than 2 cells");
    assert!(e.to_string().contains("--scale 6"), "{e}");
    let e = load_str_scaled(GOOD, Path::new("scene.yaml"), -1.0).unwrap_err();
    check(&e, "domain.dx", 5, "scale must be positive");
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
        "presets/dripping.yaml",
    ] {
        load(Path::new(p)).unwrap_or_else(|e| panic!("{e}"));
    }
}

const RING: &str = "\
version: 1
domain:
  min: [-0.05, -0.05, -0.05]
  max: [0.05, 0.1, 0.05]
  dx: 0.005
time:
  fps: 30
  frames: 10
physics:
  density: 1000
  surface_tension: 0.01
films:
  - kind: disk
    center: [0, 0, 0]
    normal: [0, 1, 0]
    radius: 0.02
film:
  wind:
    velocity: [0, 3, 0]
";

#[test]
fn wind_jets_gusts_and_bag_air_are_checked() {
    let s = load_str(
        &format!("{RING}    radius: 0.008\n    gust: {{duration: 0.03, period: 0.45}}\n  bag_air: true\n"),
        Path::new("scene.yaml"),
    )
    .unwrap();
    let w = s.film.wind.as_ref().unwrap();
    assert_eq!(w.radius, Some(0.008));
    assert_eq!(w.origin, [0.0; 3]);
    let g = w.gust.as_ref().unwrap();
    assert_eq!((g.start, g.duration, g.period), (0.0, 0.03, 0.45));
    assert!(s.film.bag_air);
    // the solver's wind: a jet that blows during its gusts only
    let prm = codimfx::film::driver::params_from_scene(&s);
    let wind = prm.wind.unwrap();
    let on_axis = codimfx::math::Vec3::new(0.0, 0.05, 0.0);
    let outside = codimfx::math::Vec3::new(0.009, 0.05, 0.0);
    assert_eq!(wind.at(0.01, &on_axis).y, 3.0);
    assert_eq!(wind.at(0.01, &outside).y, 0.0);
    assert_eq!(wind.at(0.04, &on_axis).y, 0.0, "between gusts");
    assert_eq!(wind.at(0.46, &on_axis).y, 3.0, "the second gust");
    assert!(wind.jet_blowing(0.46) && !wind.jet_blowing(0.2));
    // the bag's axis is the disk's normal, turned to point with the wind
    let air = prm.air.unwrap();
    assert_eq!((air.axis.y, air.ring_radius), (1.0, 0.02));
    let e = err(&format!("{RING}  bag_air: true\n")
        .replace("velocity: [0, 3, 0]\n", "")
        .replace("  wind:\n", ""));
    assert_eq!(e.path(), "film.bag_air", "{e}");
    assert!(e.to_string().contains("needs film.wind"), "{e}");
    let no_disk = RING
        .replace("kind: disk", "kind: sphere")
        .replace("    normal: [0, 1, 0]\n", "");
    let e = err(&format!("{no_disk}  bag_air: true\n"));
    assert_eq!(e.path(), "film.bag_air", "{e}");
    assert!(e.to_string().contains("`disk` film"), "{e}");
    let e = err(&format!("{RING}    radius: -0.008\n"));
    assert_eq!(e.path(), "film.wind.radius", "{e}");
    let e = err(&format!(
        "{RING}    gust: {{duration: 0.05, period: 0.02}}\n"
    ));
    assert_eq!(e.path(), "film.wind.gust.period", "{e}");
    assert!(e.to_string().contains("at least the duration 0.05"), "{e}");
    let e = err(&format!("{RING}    gust: {{duration: 0}}\n"));
    assert_eq!(e.path(), "film.wind.gust.duration", "{e}");
    let e = err(&format!("{RING}    gust: {{duration: 0.1, every: 2}}\n"));
    assert!(e.to_string().contains("unknown field `every`"), "{e}");
}
