//! Every preset in `presets/` loads, validates and samples its initial state;
//! the droplet scenes' initial particle counts are within 30 % of the paper's
//! Table 1 (#C0, #C1), the film scenes start with its #C1 (catenoid 63k,
//! bursting bubble 70k), and the jet scenes emit the paper's flux. Counts are
//! printed (`cargo test --release --test presets -- --nocapture`).
use codimfx::particles::{Codim, Particles};
use codimfx::scene::{load, load_str_scaled, sample_bodies, sample_films, Scene};
use codimfx::solids::SolidSet;
use std::path::{Path, PathBuf};

fn presets() -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir("presets")
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "yaml"))
        .collect();
    v.sort();
    v
}

fn initial(s: &Scene) -> Particles {
    if s.has_liquid() {
        sample_bodies(s, &SolidSet::from_scene(&s.solids)).0
    } else {
        sample_films(s)
    }
}

fn cells(s: &Scene) -> [usize; 3] {
    let d = &s.domain;
    [0, 1, 2].map(|a| ((d.max[a] - d.min[a]) / d.dx).round() as usize)
}

/// A row of the paper's Table 1: grid resolution and, where they describe
/// the initial state (the droplet scenes), #C0 and #C1.
type Table1Row = ([usize; 3], Option<(f64, f64)>);

fn table1(name: &str) -> Option<Table1Row> {
    let (res, counts) = match name {
        "droplet_on_plane" | "droplet_on_plane_mu005" | "droplet_on_plane_mu025" => {
            ([64, 64, 64], Some((52e3, 9.7e3)))
        }
        "droplet_collision" => ([64, 64, 64], Some((191e3, 20e3))),
        n if n.starts_with("dripping") => ([64, 200, 64], None),
        "fluid_chain" | "fluid_chain_fast" | "fluid_chain_links" => ([96, 256, 96], None),
        "waterbell" => ([192, 192, 192], None),
        "polygon" | "polygon8" | "polygon_fast" | "polygon8_fast" => ([192, 72, 192], None),
        _ => return None,
    };
    Some((res, counts))
}

#[test]
fn every_preset_loads_and_samples_with_the_papers_resolution_and_counts() {
    let all = presets();
    assert!(all.len() >= 15, "{all:?}");
    println!(
        "| preset | grid | C0 at t=0 | C1 at t=0 | Table 1 C0 / C1 | jet particles/s (C0 + C1) |"
    );
    println!("|---|---|---|---|---|---|");
    let mut checked = 0;
    for p in &all {
        let s = load(p).unwrap_or_else(|e| panic!("{e}"));
        let name = p.file_stem().unwrap().to_string_lossy().into_owned();
        let parts = initial(&s);
        let c = parts.counts();
        let (c0, c1) = (c[Codim::Volume as usize], c[Codim::Sheet as usize]);
        assert!(
            !parts.is_empty() || !s.jets.is_empty(),
            "{name}: nothing to simulate"
        );
        assert!(parts.x.iter().all(|x| x.iter().all(|c| c.is_finite())));
        // emission over one second of every jet
        let mut emitted = Particles::new();
        for j in &s.jets {
            j.emitter(s.domain.dx, s.physics.density)
                .emit(0.0, 1.0, &mut emitted);
        }
        let e = emitted.counts();
        let mut table = String::from("–");
        if let Some((res, counts)) = table1(&name) {
            assert_eq!(cells(&s), res, "{name}: Table 1 grid");
            assert!((s.domain.dx - 1.0 / 480.0).abs() < 1e-15, "{name}: dx");
            if let Some((t0, t1)) = counts {
                table = format!("{:.0}k / {:.1}k", t0 / 1e3, t1 / 1e3);
                for (got, want, what) in [(c0, t0, "C0"), (c1, t1, "C1")] {
                    let r = got as f64 / want;
                    assert!(
                        (0.7..=1.3).contains(&r),
                        "{name}: {what} = {got} is {r:.2} x Table 1's {want}"
                    );
                }
                checked += 1;
            }
            if !s.jets.is_empty() {
                // mass flux of each jet: rho v pi (R + s/2)^2 within 10 %
                let flux: f64 = s
                    .jets
                    .iter()
                    .map(|j| {
                        let sp = j.spacing * s.domain.dx;
                        s.physics.density
                            * j.speed
                            * std::f64::consts::PI
                            * (j.radius + 0.5 * sp).powi(2)
                    })
                    .sum();
                let m = emitted.total_mass();
                assert!((m / flux - 1.0).abs() < 0.1, "{name}: {m} kg/s vs {flux}");
                assert!(e[Codim::Sheet as usize] > 0 && e[Codim::Volume as usize] > 0);
            }
        }
        println!(
            "| {name} | {:?} | {c0} | {c1} | {table} | {} + {} |",
            cells(&s),
            e[Codim::Volume as usize],
            e[Codim::Sheet as usize]
        );
    }
    assert_eq!(
        checked, 4,
        "the four droplet presets were compared with Table 1"
    );
}

#[test]
fn the_polygon_presets_modulate_the_rim_with_6_and_8_corners() {
    for (f, k) in [
        ("presets/polygon.yaml", 6),
        ("presets/polygon8.yaml", 8),
        ("presets/polygon_fast.yaml", 6),
        ("presets/polygon8_fast.yaml", 8),
    ] {
        let s = load(Path::new(f)).unwrap();
        let m = s.film.rim_modulation.as_ref().unwrap();
        assert_eq!(m.corners, k);
        let prm = codimfx::film::driver::params_from_scene(&s);
        let saw = prm.rim_modulation.unwrap();
        assert_eq!((saw.corners, saw.amplitude), (k, m.amplitude));
        assert_eq!(saw.centre, codimfx::math::Vec3::from(m.center));
        assert_eq!(saw.phase, 0.0);
    }
}

#[test]
fn every_preset_runs_at_half_resolution_with_fewer_particles() {
    // `--scale 2`: dx doubles, spacings follow; volumes hold ~1/8 of the
    // particles, films ~1/4, jets emit ~1/8 per second
    for p in presets() {
        let text = std::fs::read_to_string(&p).unwrap();
        let full = load(&p).unwrap();
        let half = load_str_scaled(&text, &p, 2.0).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(half.domain.dx, 2.0 * full.domain.dx);
        let (a, b) = (initial(&full).len() as f64, initial(&half).len() as f64);
        if a > 0.0 {
            let want = if full.has_liquid() { 8.0 } else { 4.0 };
            let r = a / b;
            assert!(
                r > 0.7 * want && r < 1.3 * want,
                "{}: {a} -> {b} particles, ratio {r:.2} (expected ~{want})",
                p.display()
            );
        }
        let rate = |s: &Scene| {
            let mut e = Particles::new();
            for j in &s.jets {
                j.emitter(s.domain.dx, s.physics.density)
                    .emit(0.0, 1.0, &mut e);
            }
            e.len() as f64
        };
        if !full.jets.is_empty() {
            let r = rate(&full) / rate(&half);
            assert!(
                r > 5.6 && r < 10.4,
                "{}: jet rate ratio {r:.2}",
                p.display()
            );
        }
    }
}

#[test]
fn the_film_presets_start_with_table_1s_particle_counts() {
    // Table 1's #C1 for the film scenes that start as one sampled film: the
    // film catenoid (63k; the static and the pinching preset share the
    // film) and the bursting bubble (70k). The blowing bubble's 239k counts
    // the separate bubbles it blows, which a ring's membrane does not start
    // with.
    for (name, want) in [
        ("catenoid", 63e3),
        ("catenoid_pinch", 63e3),
        ("bursting_bubble", 70e3),
    ] {
        let s = load(Path::new(&format!("presets/{name}.yaml"))).unwrap();
        assert!(!s.has_liquid(), "{name}: a film scene");
        let p = initial(&s);
        let sheet = p.counts()[Codim::Sheet as usize] as f64;
        let r = sheet / want;
        assert!(
            (0.95..=1.1).contains(&r),
            "{name}: {sheet} sheet particles, {r:.3} x Table 1's {want}"
        );
    }
}
