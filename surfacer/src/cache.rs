//! Particle cache frames (`docs/cache-format.md`): reading by property name, and a writer used by
//! tests and benchmarks to make caches before real ones exist.
//!
//! Readers look properties up by name, so later versions may append properties; unknown ones are
//! ignored. Every value is checked (finite, `codim` ≤ 3, `pscale` > 0, `mass` ≥ 0) and a bad one
//! is reported with its file, particle index and property.
use crate::{Real, SurfaceError, Vec3};
use ply_rs_bw::parser::Parser;
use ply_rs_bw::ply::{
    Addable, ElementDef, Encoding, Ply, Property, PropertyAccess, PropertyAccessResult,
    PropertyDef, PropertyType, ScalarType,
};
use std::path::{Path, PathBuf};

/// One frame of particles, structure of arrays.
#[derive(Debug, Clone, Default)]
pub struct ParticleFrame {
    /// positions (m)
    pub pos: Vec<Vec3>,
    /// velocities (m/s)
    pub vel: Vec<Vec3>,
    /// stable ids
    pub id: Vec<u32>,
    /// codimension 0 volume, 1 sheet, 2 filament, 3 point
    pub codim: Vec<u8>,
    /// radius (m): sphere-equivalent (C = 0, 3), tube radius (C = 2), half thickness (C = 1)
    pub pscale: Vec<Real>,
    /// mass (kg)
    pub mass: Vec<Real>,
    /// frame vector: sheet normal (C = 1), filament tangent (C = 2), zero otherwise
    pub frame: Vec<Vec3>,
}

impl ParticleFrame {
    /// Number of particles.
    pub fn len(&self) -> usize {
        self.pos.len()
    }
    /// True when there are no particles.
    pub fn is_empty(&self) -> bool {
        self.pos.is_empty()
    }
    /// Appends one particle.
    #[allow(clippy::too_many_arguments)]
    pub fn push(
        &mut self,
        x: Vec3,
        v: Vec3,
        id: u32,
        codim: u8,
        pscale: Real,
        mass: Real,
        n: Vec3,
    ) {
        self.pos.push(x);
        self.vel.push(v);
        self.id.push(id);
        self.codim.push(codim);
        self.pscale.push(pscale);
        self.mass.push(mass);
        self.frame.push(n);
    }
    /// Indices of the particles of codimension `c`.
    pub fn indices_of(&self, c: u8) -> Vec<usize> {
        (0..self.len()).filter(|&i| self.codim[i] == c).collect()
    }
}

/// One PLY vertex row, read and written by name.
#[derive(Debug, Clone, Default)]
struct Row {
    f: [f64; 11], // x y z vx vy vz pscale mass nx ny nz
    id: u32,
    codim: u8,
    seen: u16,
}

const NAMES: [&str; 11] = [
    "x", "y", "z", "vx", "vy", "vz", "pscale", "mass", "nx", "ny", "nz",
];

fn slot(name: &str) -> Option<usize> {
    NAMES.iter().position(|n| *n == name)
}

impl PropertyAccess for Row {
    fn new() -> Self {
        Row::default()
    }
    fn set_property(&mut self, name: &str, p: Property) -> PropertyAccessResult {
        let v = match p {
            Property::Double(v) => v,
            Property::Float(v) => v as f64,
            Property::UInt(v) => v as f64,
            Property::Int(v) => v as f64,
            Property::UChar(v) => v as f64,
            Property::Char(v) => v as f64,
            Property::UShort(v) => v as f64,
            Property::Short(v) => v as f64,
            _ => return PropertyAccessResult::Ignored,
        };
        if let Some(s) = slot(name) {
            self.f[s] = v;
            self.seen |= 1 << s;
        } else if name == "id" {
            self.id = v as u32;
            self.seen |= 1 << 11;
        } else if name == "codim" {
            self.codim = if (0.0..=255.0).contains(&v) {
                v as u8
            } else {
                255
            };
            self.seen |= 1 << 12;
        } else {
            return PropertyAccessResult::Ignored;
        }
        PropertyAccessResult::Set
    }
    fn get_double(&self, name: &str) -> Option<f64> {
        slot(name).map(|s| self.f[s])
    }
    fn get_uint(&self, name: &str) -> Option<u32> {
        (name == "id").then_some(self.id)
    }
    fn get_uchar(&self, name: &str) -> Option<u8> {
        (name == "codim").then_some(self.codim)
    }
}

/// Path of frame `n` in a cache folder: `particles.####.ply`.
pub fn frame_path(dir: &Path, n: u32) -> PathBuf {
    dir.join(format!("particles.{n:04}.ply"))
}

/// Frame numbers present in `dir`, sorted.
pub fn list_frames(dir: &Path) -> Result<Vec<u32>, SurfaceError> {
    let rd = std::fs::read_dir(dir).map_err(|e| SurfaceError::io(dir, e))?;
    let mut v = Vec::new();
    for e in rd {
        let e = e.map_err(|e| SurfaceError::io(dir, e))?;
        let name = e.file_name();
        let Some(s) = name.to_str() else { continue };
        if let Some(num) = s
            .strip_prefix("particles.")
            .and_then(|r| r.strip_suffix(".ply"))
        {
            if num.len() >= 4 && num.bytes().all(|b| b.is_ascii_digit()) {
                if let Ok(n) = num.parse() {
                    v.push(n);
                }
            }
        }
    }
    v.sort_unstable();
    Ok(v)
}

/// Reads one cache frame, checking every value.
pub fn read_frame(path: &Path) -> Result<ParticleFrame, SurfaceError> {
    let f = std::fs::File::open(path).map_err(|e| SurfaceError::io(path, e))?;
    let mut r = std::io::BufReader::new(f);
    let ply = Parser::<Row>::new()
        .read_ply(&mut r)
        .map_err(|e| SurfaceError::Ply {
            path: path.into(),
            reason: e.to_string(),
        })?;
    let def = ply
        .header
        .elements
        .get("vertex")
        .ok_or_else(|| SurfaceError::Ply {
            path: path.into(),
            reason: "no element `vertex`".into(),
        })?;
    for name in NAMES.iter().chain(["id", "codim"].iter()) {
        if !def.properties.contains_key(*name) {
            return Err(SurfaceError::MissingProperty {
                path: path.into(),
                name: (*name).into(),
            });
        }
    }
    let rows = ply
        .payload
        .get("vertex")
        .map(|v| v.as_slice())
        .unwrap_or(&[]);
    let mut out = ParticleFrame::default();
    for (i, r) in rows.iter().enumerate() {
        let bad = |name: &'static str, value: f64, reason: &'static str| SurfaceError::BadValue {
            path: path.into(),
            index: i,
            name,
            value,
            reason,
        };
        for (s, n) in NAMES.iter().enumerate() {
            if !r.f[s].is_finite() {
                return Err(bad(n, r.f[s], "not finite"));
            }
        }
        if r.codim > 3 {
            return Err(bad("codim", r.codim as f64, "codimension must be 0..=3"));
        }
        if r.f[6] <= 0.0 {
            return Err(bad("pscale", r.f[6], "radius must be positive"));
        }
        if r.f[7] < 0.0 {
            return Err(bad("mass", r.f[7], "mass must be non-negative"));
        }
        let v = |a: usize| Vec3::new(r.f[a], r.f[a + 1], r.f[a + 2]);
        out.push(v(0), v(3), r.id, r.codim, r.f[6], r.f[7], v(8));
    }
    Ok(out)
}

/// Writes a frame in the documented cache layout (binary little endian), atomically.
pub fn write_frame(
    path: &Path,
    frame: &ParticleFrame,
    frame_no: u32,
    time: Real,
) -> Result<(), SurfaceError> {
    let mut ply = Ply::<Row>::new();
    ply.header.encoding = Encoding::BinaryLittleEndian;
    ply.header
        .comments
        .push(format!("codimfx cache frame {frame_no} time {time}"));
    let mut el = ElementDef::new("vertex".into());
    let d = |n: &str| PropertyDef::new(n.into(), PropertyType::Scalar(ScalarType::Double));
    for n in &NAMES[..6] {
        el.properties.add(d(n));
    }
    el.properties.add(PropertyDef::new(
        "id".into(),
        PropertyType::Scalar(ScalarType::UInt),
    ));
    el.properties.add(PropertyDef::new(
        "codim".into(),
        PropertyType::Scalar(ScalarType::UChar),
    ));
    for n in &NAMES[6..] {
        el.properties.add(d(n));
    }
    ply.header.elements.add(el);
    let rows: Vec<Row> = (0..frame.len())
        .map(|i| {
            let (x, v, n) = (frame.pos[i], frame.vel[i], frame.frame[i]);
            Row {
                f: [
                    x.x,
                    x.y,
                    x.z,
                    v.x,
                    v.y,
                    v.z,
                    frame.pscale[i],
                    frame.mass[i],
                    n.x,
                    n.y,
                    n.z,
                ],
                id: frame.id[i],
                codim: frame.codim[i],
                seen: 0,
            }
        })
        .collect();
    ply.payload.insert("vertex".into(), rows);
    crate::ply::write_atomically(path, |w| {
        ply_rs_bw::writer::Writer::new()
            .write_ply(w, &mut ply)
            .map(|_| ())
    })
}
