//! Per-frame driver: particles → level set (volume kernels ∪ disks ∪ tubes ∪ spheres) → mesh,
//! and the sequence driver writing `surface.####.vdb`, `mesh.####.ply`, `sheets.####.ply`,
//! `filaments.####.ply` atomically, frames in parallel.
use crate::anisotropy::{build_kernels_owned, AnisoParams};
use crate::cache::{frame_path, list_frames, read_frame, ParticleFrame};
use crate::filaments::{chain_filaments, tube_prims, tubes_mesh, FilamentParams};
use crate::levelset::{LevelSet, WorkGrid};
use crate::mesh::{marching_cubes, TriMesh};
use crate::redistance::{redistance, RedistanceInfo};
use crate::sheets::{disks_mesh, sheet_disks, SheetParams};
use crate::{Real, SurfaceError, Vec3};
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Options of the surfacer.
#[derive(Debug, Clone)]
pub struct SurfaceOptions {
    /// voxel size Δx (m); `None`: `voxel_rel` × the volume particles' spacing
    pub voxel_size: Option<Real>,
    /// voxel size relative to the particle spacing Δ = pscale·(4π/3)^{1/3} (default 0.5)
    pub voxel_rel: Real,
    /// narrow band half width, in voxels (OpenVDB's default: 3)
    pub band_voxels: Real,
    /// iso-value of the volume fraction (0.5: half the bulk value)
    pub iso: Real,
    /// volume kernels
    pub aniso: AnisoParams,
    /// sheet disks
    pub sheets: SheetParams,
    /// filament tubes
    pub filaments: FilamentParams,
    /// frames surfaced at the same time (≥ 1); each uses all threads inside as well
    pub parallel_frames: usize,
    /// passes of the [1 2 1]/4 band filter on the volume level set (see
    /// [`crate::redistance::smooth_band`]; 0 = none)
    pub smooth_iterations: usize,
    /// shift the volume level set so it encloses the particles' volume (see
    /// [`crate::redistance::conserve_volume`])
    pub conserve_volume: bool,
}

impl Default for SurfaceOptions {
    fn default() -> Self {
        SurfaceOptions {
            voxel_size: None,
            voxel_rel: 0.5,
            band_voxels: 3.0,
            iso: 0.5,
            aniso: AnisoParams::default(),
            sheets: SheetParams::default(),
            filaments: FilamentParams::default(),
            parallel_frames: 2,
            smooth_iterations: 1,
            conserve_volume: true,
        }
    }
}

impl SurfaceOptions {
    /// Checks the ranges of every option.
    pub fn validate(&self) -> Result<(), SurfaceError> {
        let bad = |name, value: Real, reason| {
            Err(SurfaceError::BadOption {
                name,
                value,
                reason,
            })
        };
        if let Some(v) = self.voxel_size {
            if !(v > 0.0 && v.is_finite()) {
                return bad("voxel_size", v, "must be a positive length in metres");
            }
        }
        if !(self.voxel_rel > 0.0 && self.voxel_rel.is_finite()) {
            return bad("voxel_rel", self.voxel_rel, "must be positive");
        }
        if !(self.band_voxels >= 1.0 && self.band_voxels <= 16.0) {
            return bad("band_voxels", self.band_voxels, "must be in [1, 16]");
        }
        if !(self.iso > 0.0 && self.iso < 1.0) {
            return bad("iso", self.iso, "must be in (0, 1)");
        }
        if !(self.aniso.lambda >= 0.0 && self.aniso.lambda <= 1.0) {
            return bad("lambda", self.aniso.lambda, "must be in [0, 1]");
        }
        if self.aniso.kr.is_nan() || self.aniso.kr < 1.0 {
            return bad("kr", self.aniso.kr, "must be ≥ 1");
        }
        if !(self.aniso.kn > 0.0 && self.aniso.radius_rel > 0.0 && self.aniso.ks_rel > 0.0) {
            return bad("kn/radius_rel/ks_rel", self.aniso.kn, "must be positive");
        }
        if !(self.sheets.density > 0.0 && self.filaments.density > 0.0) {
            return bad("density", self.sheets.density, "must be positive");
        }
        Ok(())
    }
}

/// Everything computed for one frame.
#[derive(Debug, Clone, Default)]
pub struct FrameGeometry {
    /// the narrow-band level set with velocities
    pub levelset: LevelSet,
    /// its zero crossing
    pub mesh: TriMesh,
    /// explicit disks
    pub sheets: TriMesh,
    /// explicit tubes and spheres
    pub filaments: TriMesh,
    /// counts and timings
    pub stats: FrameStats,
}

/// Counts and timings of one frame.
#[derive(Debug, Clone, Default)]
pub struct FrameStats {
    /// particles per codimension
    pub particles: [usize; 4],
    /// voxel size used (m)
    pub voxel: Real,
    /// volume particles that kept isotropic kernels
    pub isotropic_kernels: usize,
    /// volume particles with a full, symmetric neighbourhood (isotropic fast path)
    pub deep_kernels: usize,
    /// density blocks evaluated (the band blocks)
    pub density_blocks: usize,
    /// blocks only deep kernels reach (interior, not evaluated)
    pub interior_blocks: usize,
    /// redistancing counts
    pub redistance: RedistanceInfo,
    /// shift applied by volume conservation (m, positive = surface moved outward)
    pub volume_shift: Real,
    /// filament chains
    pub chains: usize,
    /// leaves and active voxels of the level set
    pub leaves: usize,
    /// active voxels
    pub active_voxels: usize,
    /// bytes of the grids built for this frame (density field + band, not at the same time)
    pub grid_bytes: usize,
    /// triangles of the level-set mesh
    pub triangles: usize,
    /// seconds per stage: kernels, density, redistance, primitives, mesh
    pub seconds: [Real; 5],
}

/// Spacing Δ of the volume particles from their sphere-equivalent radius.
pub fn volume_spacing(frame: &ParticleFrame) -> Option<Real> {
    let v = frame.indices_of(0);
    let src = if v.is_empty() {
        (0..frame.len()).collect()
    } else {
        v
    };
    if src.is_empty() {
        return None;
    }
    let mean = src.iter().map(|&i| frame.pscale[i]).sum::<Real>() / src.len() as Real;
    Some(mean * (4.0 * std::f64::consts::PI / 3.0).cbrt())
}

/// What the volume stages keep of a frame: the volume particles' positions, volumes and
/// velocities (f32: they only feed the `v` grid and the mesh's `vx vy vz`, stored as f32).
struct VolumeInput {
    pos: Vec<Vec3>,
    vol: Vec<Real>,
    vel: Vec<[f32; 3]>,
}

impl VolumeInput {
    fn of(frame: &ParticleFrame) -> Self {
        let n = frame.codim.iter().filter(|&&c| c == 0).count();
        let mut v = VolumeInput {
            pos: Vec::with_capacity(n),
            vol: Vec::with_capacity(n),
            vel: Vec::with_capacity(n),
        };
        for i in (0..frame.len()).filter(|&i| frame.codim[i] == 0) {
            v.pos.push(frame.pos[i]);
            v.vol
                .push(4.0 / 3.0 * std::f64::consts::PI * frame.pscale[i].powi(3));
            let u = frame.vel[i];
            v.vel.push([u.x as f32, u.y as f32, u.z as f32]);
        }
        v
    }
}

/// The result for a frame without particles: an empty (all outside) level set with a valid
/// transform.
fn empty_geometry(o: &SurfaceOptions) -> FrameGeometry {
    let h = o.voxel_size.unwrap_or(1.0);
    FrameGeometry {
        levelset: LevelSet::new(h, (o.band_voxels * h) as f32, Vec::new(), Vec::new()),
        ..Default::default()
    }
}

/// Checks a frame and picks the voxel size: (particle spacing, stats with the counts and voxel
/// size), or `None` when there is nothing to surface.
fn prepare(
    frame: &ParticleFrame,
    o: &SurfaceOptions,
) -> Result<Option<(Real, FrameStats)>, SurfaceError> {
    o.validate()?;
    let mut st = FrameStats::default();
    for c in &frame.codim {
        st.particles[(*c).min(3) as usize] += 1;
    }
    let Some(dx) = volume_spacing(frame) else {
        return Ok(None);
    };
    let h = o.voxel_size.unwrap_or(o.voxel_rel * dx);
    st.voxel = h;
    // index range check
    let ext = frame.pos.iter().fold(0.0f64, |m, p| m.max(p.amax()));
    if ext / h > ((1u64 << 18) - 64) as Real {
        return Err(SurfaceError::GridTooLarge {
            voxels: (ext / h).powi(3),
            voxel_size: h,
        });
    }
    Ok(Some((dx, st)))
}

/// Surfaces one frame.
pub fn surface_particles(
    frame: &ParticleFrame,
    o: &SurfaceOptions,
) -> Result<FrameGeometry, SurfaceError> {
    let Some((dx, st)) = prepare(frame, o)? else {
        return Ok(empty_geometry(o));
    };
    surface_volume(VolumeInput::of(frame), frame, dx, st, o)
}

/// Surfaces one frame it takes over: the volume particles' data is copied out (positions,
/// volumes, f32 velocities) and the frame is dropped before the volume stages, keeping only its
/// sheet, filament and point particles. Same result as [`surface_particles`], less memory.
pub fn surface_frame(
    frame: ParticleFrame,
    o: &SurfaceOptions,
) -> Result<FrameGeometry, SurfaceError> {
    let Some((dx, st)) = prepare(&frame, o)? else {
        return Ok(empty_geometry(o));
    };
    let mut rest = ParticleFrame::default();
    for i in (0..frame.len()).filter(|&i| frame.codim[i] != 0) {
        rest.push(
            frame.pos[i],
            frame.vel[i],
            frame.id[i],
            frame.codim[i],
            frame.pscale[i],
            frame.mass[i],
            frame.frame[i],
        );
    }
    // the volume particles' columns are filtered in place, the others freed at once
    let ParticleFrame {
        mut pos,
        vel,
        codim,
        mut pscale,
        id,
        mass,
        frame,
    } = frame;
    drop((id, mass, frame));
    fn keep<T>(v: &mut Vec<T>, codim: &[u8]) {
        let mut k = codim.iter();
        v.retain(|_| k.next() == Some(&0));
    }
    let vel32: Vec<[f32; 3]> = vel
        .iter()
        .zip(&codim)
        .filter(|(_, &c)| c == 0)
        .map(|(u, _)| [u.x as f32, u.y as f32, u.z as f32])
        .collect();
    drop(vel);
    keep(&mut pos, &codim);
    keep(&mut pscale, &codim);
    drop(codim);
    for s in pscale.iter_mut() {
        *s = 4.0 / 3.0 * std::f64::consts::PI * s.powi(3);
    }
    let vin = VolumeInput {
        pos,
        vol: pscale,
        vel: vel32,
    };
    surface_volume(vin, &rest, dx, st, o)
}

/// The stages after [`prepare`]: volume particles from `vin`, the other codimensions from `frame`.
fn surface_volume(
    vin: VolumeInput,
    frame: &ParticleFrame,
    dx: Real,
    mut st: FrameStats,
    o: &SurfaceOptions,
) -> Result<FrameGeometry, SurfaceError> {
    let h = st.voxel;
    let band = o.band_voxels;
    let iso = o.iso as f32;
    let has_volume = !vin.pos.is_empty();

    let t = Instant::now();
    let VolumeInput { pos, vol, vel } = vin;
    let kernels = build_kernels_owned(pos, &vol, dx, &o.aniso);
    let target: Real = vol.iter().sum();
    drop(vol);
    st.isotropic_kernels = kernels.isotropic;
    st.deep_kernels = kernels.deep.iter().filter(|&&d| d).count();
    st.seconds[0] = t.elapsed().as_secs_f64();

    let t = Instant::now();
    let reach = o.aniso.radius_rel * dx + 2.0 * h;
    let dens = crate::density::rasterize(&kernels, &vel, h, reach);
    drop((kernels, vel));
    st.density_blocks = dens.blocks.len();
    st.interior_blocks = dens.interior.len();
    let dens_bytes = dens.memory_bytes();
    st.seconds[1] = t.elapsed().as_secs_f64();

    let t = Instant::now();
    let (mut grid, extra_inside, signs, info): (WorkGrid, _, _, _) = redistance(dens, iso, band);
    st.redistance = info;
    if o.smooth_iterations > 0 && has_volume {
        crate::redistance::smooth_band(&mut grid, &|o| signs.mask(o), o.smooth_iterations);
    }
    if o.conserve_volume && has_volume {
        st.volume_shift = crate::redistance::conserve_volume(&mut grid, &signs, target, band);
    }
    st.seconds[2] = t.elapsed().as_secs_f64();

    let t = Instant::now();
    let disks = sheet_disks(frame, h, &o.sheets);
    let chains = chain_filaments(frame, &o.filaments);
    st.chains = chains.len();
    let tubes = tube_prims(frame, &chains, h, &o.filaments);
    let mut prims = disks.clone();
    prims.extend_from_slice(&tubes);
    grid.union_prims(&prims, &|o| signs.mask(o));
    st.grid_bytes =
        dens_bytes + grid.leaves.len() * std::mem::size_of::<crate::levelset::WorkLeaf>();
    drop(signs);
    let ls = grid.finish(extra_inside);
    st.leaves = ls.leaves.len();
    st.active_voxels = ls.active_count();
    st.seconds[3] = t.elapsed().as_secs_f64();

    let t = Instant::now();
    let mesh = marching_cubes(&ls);
    st.triangles = mesh.tris.len();
    let sheets = disks_mesh(&disks, o.sheets.segments);
    let filaments = tubes_mesh(frame, &chains, &tubes, h, &o.filaments);
    st.seconds[4] = t.elapsed().as_secs_f64();
    Ok(FrameGeometry {
        levelset: ls,
        mesh,
        sheets,
        filaments,
        stats: st,
    })
}

/// Output file `name.####.ext` in `dir`.
pub fn output_path(dir: &Path, name: &str, frame: u32, ext: &str) -> PathBuf {
    dir.join(format!("{name}.{frame:04}.{ext}"))
}

/// Counts non-finite values in the level set and meshes; an error names the output.
pub fn check_finite(frame: u32, g: &FrameGeometry) -> Result<(), SurfaceError> {
    let bad_ls: usize = g
        .levelset
        .leaves
        .par_iter()
        .map(|l| {
            l.phi.iter().filter(|v| !v.is_finite()).count()
                + l.vel
                    .iter()
                    .filter(|v| v.iter().any(|c| !c.is_finite()))
                    .count()
        })
        .sum();
    if bad_ls > 0 {
        return Err(SurfaceError::NonFinite {
            frame,
            what: "the level set",
            count: bad_ls,
        });
    }
    for (m, what) in [
        (&g.mesh, "mesh"),
        (&g.sheets, "sheets"),
        (&g.filaments, "filaments"),
    ] {
        let count = m
            .pos
            .iter()
            .chain(&m.vel)
            .chain(&m.normal)
            .filter(|v| v.iter().any(|c| !c.is_finite()))
            .count();
        if count > 0 {
            return Err(SurfaceError::NonFinite { frame, what, count });
        }
    }
    Ok(())
}

/// Writes the four outputs of a frame, each atomically, after checking every value is finite.
pub fn write_outputs(dir: &Path, frame: u32, g: &FrameGeometry) -> Result<(), SurfaceError> {
    check_finite(frame, g)?;
    let c = format!("codimfx surface frame {frame}");
    // the VDB (compressed leaf by leaf on the pool) and the meshes (serial byte copies) are
    // written side by side; each file still appears atomically, and the first error is reported
    let (vdb, meshes) = rayon::join(
        || crate::vdb::write_vdb(&output_path(dir, "surface", frame, "vdb"), &g.levelset),
        || {
            crate::ply::write_mesh(&output_path(dir, "mesh", frame, "ply"), &g.mesh, &c)?;
            crate::ply::write_mesh(&output_path(dir, "sheets", frame, "ply"), &g.sheets, &c)?;
            crate::ply::write_mesh(
                &output_path(dir, "filaments", frame, "ply"),
                &g.filaments,
                &c,
            )
        },
    );
    vdb?;
    meshes
}

/// Surfaces the frames of `cache_dir` (all, or those in `range` inclusive) into `out_dir`,
/// `parallel_frames` at a time, calling `done(frame, stats)` after each. Returns the frames done.
pub fn surface_cache(
    cache_dir: &Path,
    out_dir: &Path,
    range: Option<(u32, u32)>,
    o: &SurfaceOptions,
    done: &(dyn Fn(u32, &FrameStats) + Sync),
) -> Result<Vec<u32>, SurfaceError> {
    o.validate()?;
    let mut frames = list_frames(cache_dir)?;
    if let Some((a, b)) = range {
        frames.retain(|f| (a..=b).contains(f));
    }
    if frames.is_empty() {
        return Err(SurfaceError::NoFrames {
            dir: cache_dir.into(),
            extra: range.map_or(String::new(), |(a, b)| format!(" in {a}-{b}")),
        });
    }
    std::fs::create_dir_all(out_dir).map_err(|e| SurfaceError::io(out_dir, e))?;
    let parallel = frames_in_parallel(cache_dir, &frames, o.parallel_frames);
    for chunk in frames.chunks(parallel) {
        chunk
            .par_iter()
            .map(|&f| {
                let frame = read_frame(&frame_path(cache_dir, f))?;
                let g = surface_frame(frame, o)?;
                write_outputs(out_dir, f, &g)?;
                done(f, &g.stats);
                Ok(())
            })
            .collect::<Result<Vec<()>, SurfaceError>>()?;
    }
    Ok(frames)
}

/// Bytes of peak memory per particle of one frame: `codimfx bench surface` measures ≈ 160 B
/// (peak RSS 133–138 MB for 863 582 particles at voxel = Δ/2, frame included, docs/benchmarks.md
/// round 3); ×3 for other shapes and finer voxels.
const BYTES_PER_PARTICLE: u64 = 512;
/// Bytes per particle in a cache file (docs/cache-format.md: 11 doubles, a uint and a uchar).
const CACHE_BYTES_PER_PARTICLE: u64 = 11 * 8 + 4 + 1;

/// How many frames fit in memory at once: at most `wanted`, at most what `MemAvailable` allows for
/// the largest frame (estimated from its file size), at least 1.
pub fn frames_in_parallel(dir: &Path, frames: &[u32], wanted: usize) -> usize {
    let largest = frames
        .iter()
        .filter_map(|&f| std::fs::metadata(frame_path(dir, f)).ok())
        .map(|m| m.len())
        .max()
        .unwrap_or(0);
    let need = (largest / CACHE_BYTES_PER_PARTICLE).max(1) * BYTES_PER_PARTICLE;
    let avail = std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("MemAvailable:"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|k| k.parse::<u64>().ok())
        })
        .map(|k| k * 1024);
    let fit = match avail {
        Some(a) => (a / need).max(1) as usize,
        None => wanted,
    };
    wanted.max(1).min(fit)
}
