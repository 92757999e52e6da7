//! Physical and numerical validity of a parsed scene, checked once at load.
//! Each failure is `(field path, reason with the offending numbers)`.

use super::{FluidBody, Scene, Solid, SCHEMA_VERSION};

type Check = Result<(), (String, String)>;

fn fail(path: impl Into<String>, reason: impl Into<String>) -> Check {
    Err((path.into(), reason.into()))
}

fn finite3(path: &str, v: &[f64; 3]) -> Check {
    if v.iter().all(|c| c.is_finite()) {
        Ok(())
    } else {
        fail(path, format!("{v:?} is not finite"))
    }
}

fn positive(path: &str, v: f64) -> Check {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        fail(path, format!("must be positive and finite, got {v}"))
    }
}

fn nonzero3(path: &str, v: &[f64; 3]) -> Check {
    finite3(path, v)?;
    if v.iter().map(|c| c * c).sum::<f64>() > 1e-24 {
        Ok(())
    } else {
        fail(path, format!("direction {v:?} has zero length"))
    }
}

fn body_bounds(b: &FluidBody) -> ([f64; 3], [f64; 3]) {
    match b {
        FluidBody::Box { min, max, .. } => (*min, *max),
        FluidBody::Sphere { center, radius, .. } => {
            (center.map(|c| c - radius), center.map(|c| c + radius))
        }
        FluidBody::Ellipsoid { center, radii, .. } => (
            [
                center[0] - radii[0],
                center[1] - radii[1],
                center[2] - radii[2],
            ],
            [
                center[0] + radii[0],
                center[1] + radii[1],
                center[2] + radii[2],
            ],
        ),
        FluidBody::Cylinder {
            center,
            axis,
            radius,
            height,
            ..
        } => {
            let n = (axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]).sqrt();
            let mut lo = [0.0; 3];
            let mut hi = [0.0; 3];
            for d in 0..3 {
                let a = axis[d] / n;
                // extent of a capped cylinder along axis d
                let e = 0.5 * height * a.abs() + radius * (1.0 - a * a).max(0.0).sqrt();
                lo[d] = center[d] - e;
                hi[d] = center[d] + e;
            }
            (lo, hi)
        }
    }
}

fn check_body(i: usize, b: &FluidBody, s: &Scene) -> Check {
    let p = format!("bodies[{i}]");
    let sp = b.spacing();
    if !(sp.is_finite() && sp > 0.0 && sp <= 1.0) {
        return fail(
            format!("{p}.spacing"),
            format!("must be in (0, 1] (relative to dx), got {sp}"),
        );
    }
    finite3(&format!("{p}.velocity"), &b.velocity())?;
    match b {
        FluidBody::Box { min, max, .. } => {
            finite3(&format!("{p}.min"), min)?;
            finite3(&format!("{p}.max"), max)?;
            for d in 0..3 {
                if max[d] <= min[d] {
                    return fail(
                        format!("{p}.max"),
                        format!("max {max:?} must exceed min {min:?} on every axis"),
                    );
                }
            }
        }
        FluidBody::Sphere { center, radius, .. } => {
            finite3(&format!("{p}.center"), center)?;
            positive(&format!("{p}.radius"), *radius)?;
        }
        FluidBody::Ellipsoid { center, radii, .. } => {
            finite3(&format!("{p}.center"), center)?;
            for r in radii {
                positive(&format!("{p}.radii"), *r)?;
            }
        }
        FluidBody::Cylinder {
            center,
            axis,
            radius,
            height,
            ..
        } => {
            finite3(&format!("{p}.center"), center)?;
            nonzero3(&format!("{p}.axis"), axis)?;
            positive(&format!("{p}.radius"), *radius)?;
            positive(&format!("{p}.height"), *height)?;
        }
    }
    let (lo, hi) = body_bounds(b);
    let (dlo, dhi) = (s.domain.min, s.domain.max);
    for d in 0..3 {
        if lo[d] < dlo[d] - 1e-12 || hi[d] > dhi[d] + 1e-12 {
            return fail(
                p,
                format!(
                    "body spans [{:.6}, {:.6}] on axis {} but the domain is [{}, {}]",
                    lo[d],
                    hi[d],
                    ["x", "y", "z"][d],
                    dlo[d],
                    dhi[d]
                ),
            );
        }
    }
    Ok(())
}

fn check_solid(i: usize, s: &Solid) -> Check {
    let p = format!("solids[{i}]");
    match s {
        Solid::Plane { point, normal } => {
            finite3(&format!("{p}.point"), point)?;
            nonzero3(&format!("{p}.normal"), normal)
        }
        Solid::Box { min, max } => {
            finite3(&format!("{p}.min"), min)?;
            finite3(&format!("{p}.max"), max)?;
            for d in 0..3 {
                if max[d] <= min[d] {
                    return fail(
                        format!("{p}.max"),
                        format!("max {max:?} must exceed min {min:?} on every axis"),
                    );
                }
            }
            Ok(())
        }
        Solid::Sphere { center, radius } => {
            finite3(&format!("{p}.center"), center)?;
            positive(&format!("{p}.radius"), *radius)
        }
        Solid::Cylinder {
            center,
            axis,
            radius,
            height,
        } => {
            finite3(&format!("{p}.center"), center)?;
            nonzero3(&format!("{p}.axis"), axis)?;
            positive(&format!("{p}.radius"), *radius)?;
            positive(&format!("{p}.height"), *height)
        }
        Solid::Pipe {
            center,
            axis,
            inner_radius,
            outer_radius,
            height,
        } => {
            finite3(&format!("{p}.center"), center)?;
            nonzero3(&format!("{p}.axis"), axis)?;
            positive(&format!("{p}.inner_radius"), *inner_radius)?;
            positive(&format!("{p}.outer_radius"), *outer_radius)?;
            if outer_radius <= inner_radius {
                return fail(
                    format!("{p}.outer_radius"),
                    format!(
                        "outer radius {outer_radius} m must exceed the inner radius {inner_radius} m"
                    ),
                );
            }
            positive(&format!("{p}.height"), *height)
        }
    }
}

/// Checks every value of a parsed scene.
pub fn validate(s: &Scene) -> Check {
    if s.version != SCHEMA_VERSION {
        return fail(
            "version",
            format!(
                "this build reads schema version {SCHEMA_VERSION}, got {}",
                s.version
            ),
        );
    }
    let d = &s.domain;
    finite3("domain.min", &d.min)?;
    finite3("domain.max", &d.max)?;
    positive("domain.dx", d.dx)?;
    for a in 0..3 {
        let ext = d.max[a] - d.min[a];
        if ext <= 0.0 {
            return fail(
                "domain.max",
                format!("max {:?} must exceed min {:?} on every axis", d.max, d.min),
            );
        }
        let n = ext / d.dx;
        if n < 2.0 - 1e-9 {
            return fail(
                "domain.dx",
                format!("dx = {} leaves fewer than 2 cells across {ext} m", d.dx),
            );
        }
        if n > 8192.0 {
            return fail(
                "domain.dx",
                format!("dx = {} gives {n:.0} cells on one axis (limit 8192)", d.dx),
            );
        }
    }
    let t = &s.time;
    positive("time.fps", t.fps)?;
    positive("time.max_dt", t.max_dt)?;
    if !(t.cfl.is_finite() && t.cfl > 0.0 && t.cfl <= 5.0) {
        return fail("time.cfl", format!("must be in (0, 5], got {}", t.cfl));
    }
    let ph = &s.physics;
    positive("physics.density", ph.density)?;
    if !(ph.viscosity.is_finite() && ph.viscosity >= 0.0) {
        return fail(
            "physics.viscosity",
            format!("must be >= 0 Pa·s, got {}", ph.viscosity),
        );
    }
    if !(ph.surface_tension.is_finite() && ph.surface_tension >= 0.0) {
        return fail(
            "physics.surface_tension",
            format!("must be >= 0 N/m and finite, got {}", ph.surface_tension),
        );
    }
    finite3("physics.gravity", &ph.gravity)?;
    finite3("physics.body_force", &ph.body_force)?;
    let so = &s.solver;
    if !(0.0..=1.0).contains(&so.flip) {
        return fail("solver.flip", format!("must be in [0, 1], got {}", so.flip));
    }
    for (name, v) in [
        ("solver.pressure_tolerance", so.pressure_tolerance),
        ("solver.viscosity_tolerance", so.viscosity_tolerance),
    ] {
        if !(v.is_finite() && v > 0.0 && v < 1.0) {
            return fail(name, format!("must be in (0, 1), got {v}"));
        }
    }
    if so.pressure_max_iterations == 0 {
        return fail("solver.pressure_max_iterations", "must be at least 1");
    }
    if so.viscosity_max_iterations == 0 {
        return fail("solver.viscosity_max_iterations", "must be at least 1");
    }
    if !(so.surface_radius.is_finite() && (0.5..=2.0).contains(&so.surface_radius)) {
        return fail(
            "solver.surface_radius",
            format!(
                "must be in [0.5, 2] (relative to dx), got {}",
                so.surface_radius
            ),
        );
    }
    if s.bodies.is_empty() && s.films.is_empty() && s.jets.is_empty() {
        return fail("bodies", "the scene has no liquid body, no jet and no film");
    }
    super::films::validate(s)?;
    super::jets::validate(s)?;
    for (i, b) in s.bodies.iter().enumerate() {
        check_body(i, b, s)?;
    }
    for (i, so) in s.solids.iter().enumerate() {
        check_solid(i, so)?;
    }
    if let Some(n) = &s.output.name {
        if n.is_empty() || n.contains(['/', '\\']) || n == "." || n == ".." {
            return fail("output.name", format!("{n:?} is not a plain folder name"));
        }
    }
    Ok(())
}
