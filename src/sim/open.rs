//! Opening a run: loading the scene, then either sampling the initial state
//! and writing frame 0 of a fresh cache, or reading the last complete frame
//! of an existing cache (`--resume`), after checking that the scene file
//! and the resolution scale are the ones the cache was written with.

use super::{io_err, RunOptions, Sim, SimError};
use crate::emitter::Jet;
use crate::film::driver as film_driver;
use crate::frame_record::base_record;
use crate::grid::MacGrid;
use crate::io::manifest::{sha256_hex, Manifest};
use crate::io::ply::{self, frame_name};
use crate::io::write_atomic;
use crate::math::{Real, Vec3};
use crate::scene::{self, sample_bodies, sample_films, SceneError, Transfer};
use crate::solids::SolidSet;
use crate::step::{SimState, StageTimes, StepParams};
use std::path::{Path, PathBuf};

impl Sim {
    /// Loads the scene and either samples the initial state (writing frame 0)
    /// or, with `resume`, reads the last complete frame of the existing cache.
    pub fn open(scene_file: &Path, opt: &RunOptions) -> Result<Sim, SimError> {
        let text = std::fs::read_to_string(scene_file).map_err(|source| SceneError::Io {
            file: scene_file.to_path_buf(),
            source,
        })?;
        Sim::open_text(&text, scene_file, opt)
    }

    /// [`Sim::open`] on scene text; `scene_file` names it in messages, in the
    /// manifest and (its stem) as the default cache name.
    pub fn open_text(text: &str, scene_file: &Path, opt: &RunOptions) -> Result<Sim, SimError> {
        let text = text.to_string();
        let mut scale = opt.scale.unwrap_or(1.0);
        let mut scene = scene::load_str_scaled(&text, scene_file, scale)?;
        let name = scene.output.name.clone().unwrap_or_else(|| {
            scene_file
                .file_stem()
                .map_or("scene".into(), |s| s.to_string_lossy().into_owned())
        });
        let root = opt
            .out_root
            .clone()
            .or_else(|| scene.output.dir.clone().map(PathBuf::from))
            .unwrap_or_else(|| PathBuf::from("cache"));
        let dir = root.join(&name);
        let mpath = dir.join("manifest.json");
        let sha = sha256_hex(&text);
        let old = if opt.resume {
            let m = Manifest::read(&mpath)?;
            match opt.scale {
                Some(s) if s != m.scale => {
                    return Err(SimError::Resume {
                        dir,
                        reason: format!("the cache was written at --scale {}, not {s}", m.scale),
                    })
                }
                None if m.scale != scale => {
                    scale = m.scale;
                    scene = scene::load_str_scaled(&text, scene_file, scale)?;
                }
                _ => {}
            }
            Some(m)
        } else {
            None
        };
        let solids = SolidSet::from_scene(&scene.solids);
        let params = StepParams::from_scene(&scene);
        let d = &scene.domain;
        let grid = MacGrid::new(Vec3::from(d.min), Vec3::from(d.max), d.dx);
        let last_frame = opt.frames.unwrap_or(scene.time.frames);
        let jets: Vec<Jet> = scene
            .jets
            .iter()
            .map(|j| j.emitter(d.dx, scene.physics.density))
            .collect();
        if let Some(manifest) = old {
            if manifest.scene_sha256 != sha {
                return Err(SimError::Resume {
                    dir,
                    reason: format!(
                        "the scene file changed since the cache was written (sha256 {} vs {})",
                        &sha[..12],
                        &manifest.scene_sha256[..manifest.scene_sha256.len().min(12)]
                    ),
                });
            }
            let f = manifest.frames_written;
            let rec = manifest
                .frames
                .iter()
                .find(|r| r.frame == f)
                .cloned()
                .ok_or_else(|| SimError::Resume {
                    dir: dir.clone(),
                    reason: format!("manifest has no record of frame {f}"),
                })?;
            let frame = ply::read(&dir.join(frame_name(f)))?;
            let mut particles = frame.particles;
            particles.next_id = rec.next_id;
            let affine = match (params.transfer, frame.affine) {
                (Transfer::Apic, Some(a)) => a,
                (Transfer::Apic, None) => {
                    return Err(SimError::Resume {
                        dir,
                        reason: format!("frame {f} has no APIC matrices (c00 … c22)"),
                    })
                }
                (Transfer::Flip, _) => Vec::new(),
            };
            let mut manifest = manifest;
            manifest.frames.retain(|r| r.frame <= f);
            let film = (!scene.has_liquid()).then(|| {
                let mut st = film_driver::initial_state(&scene);
                if let (Some(g), Some(v0)) = (st.gas.as_mut(), rec.gas_v0) {
                    g.v0 = v0;
                }
                if let Some(a) = &rec.air {
                    st.air.bubbles = a.bubbles.clone();
                }
                st
            });
            // every frame ends at exactly t = f / fps; recomputing it avoids
            // trusting a decimal round trip of the time through JSON
            let time = f as Real / scene.time.fps;
            return Ok(Sim {
                scene,
                dir,
                state: SimState {
                    particles,
                    grid,
                    solids,
                    affine,
                    film,
                    warm: None,
                },
                params,
                manifest,
                frame: f,
                time,
                last_frame,
                totals: StageTimes::default(),
                dropped_in_solid: 0,
                jets,
                verbose: opt.verbose,
            });
        }
        let film_only = !scene.has_liquid();
        let (particles, rep) = if film_only {
            (sample_films(&scene), Default::default())
        } else {
            sample_bodies(&scene, &solids)
        };
        if particles.is_empty() && jets.is_empty() {
            return Err(SimError::NoLiquid {
                file: scene_file.to_path_buf(),
                dropped: rep.dropped_in_solid,
            });
        }
        std::fs::create_dir_all(&dir).map_err(io_err(&dir))?;
        // a fresh run replaces an old cache of the same name
        for e in std::fs::read_dir(&dir).map_err(io_err(&dir))?.flatten() {
            let n = e.file_name().to_string_lossy().into_owned();
            if n.starts_with("particles.") && n.ends_with(".ply") {
                std::fs::remove_file(e.path()).map_err(io_err(&e.path()))?;
            }
        }
        let apic_zeros =
            (params.transfer == Transfer::Apic).then(|| vec![[Vec3::zeros(); 3]; particles.len()]);
        let mut manifest = Manifest {
            format: "codimfx-cache".into(),
            version: 1,
            scene_name: name,
            scene_file: scene_file.display().to_string(),
            scene_sha256: sha,
            scene_yaml: text,
            fps: scene.time.fps,
            dx: d.dx,
            scale,
            domain_min: d.min,
            domain_max: d.max,
            threads: rayon::current_num_threads(),
            frames_written: 0,
            frames: Vec::new(),
        };
        let fv = super::frame_vectors::frame_vectors(&particles, d.dx);
        let bytes = ply::encode(&particles, fv.as_deref(), apic_zeros.as_deref(), 0, 0.0)?;
        let p0 = dir.join(frame_name(0));
        write_atomic(&p0, &bytes).map_err(io_err(&p0))?;
        manifest.frames.push(base_record(0, 0.0, &particles));
        manifest.write(&mpath)?;
        let mut state = SimState::new(particles, grid, solids);
        state.film = film_only.then(|| film_driver::initial_state(&scene));
        Ok(Sim {
            scene,
            dir,
            state,
            params,
            manifest,
            frame: 0,
            time: 0.0,
            last_frame,
            totals: StageTimes::default(),
            dropped_in_solid: rep.dropped_in_solid,
            jets,
            verbose: opt.verbose,
        })
    }
}
