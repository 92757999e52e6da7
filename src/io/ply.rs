//! Binary little-endian PLY particle caches, exactly as `docs/cache-format.md`
//! specifies: `x y z vx vy vz` (double), `id` (uint), `codim` (uchar),
//! `pscale mass` (double), `nx ny nz` (double). The reader looks properties up
//! by name and skips unknown ones, so later versions may append properties.

use crate::math::{Real, Vec3};
use crate::particles::{Codim, Particles};
use std::path::Path;

/// Why a cache file could not be written or read.
#[derive(Debug, thiserror::Error)]
pub enum PlyError {
    /// File system error.
    #[error("{path}: {source}")]
    Io {
        /// File.
        path: String,
        /// Underlying error.
        source: std::io::Error,
    },
    /// The file is not a cache this reader understands.
    #[error("{path}: {reason}")]
    Format {
        /// File.
        path: String,
        /// What is wrong.
        reason: String,
    },
    /// A value cannot be stored.
    #[error("particle {index}: {reason}")]
    Value {
        /// Particle index in the store.
        index: usize,
        /// What is wrong.
        reason: String,
    },
}

const PROPS: [(&str, &str); 13] = [
    ("double", "x"),
    ("double", "y"),
    ("double", "z"),
    ("double", "vx"),
    ("double", "vy"),
    ("double", "vz"),
    ("uint", "id"),
    ("uchar", "codim"),
    ("double", "pscale"),
    ("double", "mass"),
    ("double", "nx"),
    ("double", "ny"),
    ("double", "nz"),
];

/// Names of the optional APIC properties `c{a}{d}` = ∂u_a/∂x_d (1/s),
/// appended after `nz` in runs with `solver.transfer: apic`.
pub const AFFINE_PROPS: [&str; 9] = [
    "c00", "c01", "c02", "c10", "c11", "c12", "c20", "c21", "c22",
];

/// Encodes one frame. `frame_vec` holds the sheet normal / filament tangent
/// per particle (zero for C = 0 and C = 3); `None` writes zeros. `affine`
/// (APIC runs) appends the nine [`AFFINE_PROPS`].
pub fn encode(
    p: &Particles,
    frame_vec: Option<&[Vec3]>,
    affine: Option<&[[Vec3; 3]]>,
    frame: u32,
    time: Real,
) -> Result<Vec<u8>, PlyError> {
    if !p.all_finite() {
        let index = (0..p.len())
            .find(|&i| {
                !(p.x[i].iter().chain(p.v[i].iter()).all(|c| c.is_finite())
                    && p.mass[i].is_finite()
                    && p.radius[i].is_finite())
            })
            .unwrap_or(0);
        return Err(PlyError::Value {
            index,
            reason: "non-finite position, velocity, mass or radius; frame not written".into(),
        });
    }
    let mut h = format!(
        "ply\nformat binary_little_endian 1.0\ncomment codimfx cache frame {frame} time {time}\nelement vertex {}\n",
        p.len()
    );
    for (t, n) in PROPS {
        h.push_str(&format!("property {t} {n}\n"));
    }
    if affine.is_some() {
        for n in AFFINE_PROPS {
            h.push_str(&format!("property double {n}\n"));
        }
    }
    // static boundary particles (film rings) exist: write the flag so a
    // resumed run keeps them fixed
    let with_fixed = p.fixed.iter().any(|f| *f);
    if with_fixed {
        h.push_str("property uchar fixed\n");
    }
    h.push_str("end_header\n");
    let mut out = Vec::with_capacity(h.len() + p.len() * 93);
    out.extend_from_slice(h.as_bytes());
    for i in 0..p.len() {
        for c in p.x[i].iter().chain(p.v[i].iter()) {
            out.extend_from_slice(&c.to_le_bytes());
        }
        let id = u32::try_from(p.id[i]).map_err(|_| PlyError::Value {
            index: i,
            reason: format!("id {} does not fit the cache's uint", p.id[i]),
        })?;
        out.extend_from_slice(&id.to_le_bytes());
        out.push(p.codim[i].number());
        out.extend_from_slice(&p.radius[i].to_le_bytes());
        out.extend_from_slice(&p.mass[i].to_le_bytes());
        let n = frame_vec.map_or(Vec3::zeros(), |f| f[i]);
        for c in n.iter() {
            out.extend_from_slice(&c.to_le_bytes());
        }
        if let Some(c) = affine {
            for row in &c[i] {
                for e in row.iter() {
                    if !e.is_finite() {
                        return Err(PlyError::Value {
                            index: i,
                            reason: "non-finite APIC matrix; frame not written".into(),
                        });
                    }
                    out.extend_from_slice(&e.to_le_bytes());
                }
            }
        }
        if with_fixed {
            out.push(u8::from(p.fixed[i]));
        }
    }
    Ok(out)
}

/// A decoded cache frame.
#[derive(Clone, Debug, Default)]
pub struct Frame {
    /// Particles (`fixed` from the optional `fixed` property, else false; `next_id` is max id + 1).
    pub particles: Particles,
    /// Frame vectors `nx ny nz` (zero where absent).
    pub frame_vec: Vec<Vec3>,
    /// APIC matrices, when the file has the [`AFFINE_PROPS`].
    pub affine: Option<Vec<[Vec3; 3]>>,
}

fn size_of(t: &str) -> Option<usize> {
    Some(match t {
        "char" | "uchar" | "int8" | "uint8" => 1,
        "short" | "ushort" | "int16" | "uint16" => 2,
        "int" | "uint" | "float" | "int32" | "uint32" | "float32" => 4,
        "double" | "float64" => 8,
        _ => return None,
    })
}

fn read_num(t: &str, b: &[u8]) -> f64 {
    match t {
        "char" | "int8" => b[0] as i8 as f64,
        "uchar" | "uint8" => b[0] as f64,
        "short" | "int16" => i16::from_le_bytes([b[0], b[1]]) as f64,
        "ushort" | "uint16" => u16::from_le_bytes([b[0], b[1]]) as f64,
        "int" | "int32" => i32::from_le_bytes(b[..4].try_into().unwrap()) as f64,
        "uint" | "uint32" => u32::from_le_bytes(b[..4].try_into().unwrap()) as f64,
        "float" | "float32" => f32::from_le_bytes(b[..4].try_into().unwrap()) as f64,
        _ => f64::from_le_bytes(b[..8].try_into().unwrap()),
    }
}

/// Decodes a cache frame from bytes; `path` is used in messages.
pub fn decode(bytes: &[u8], path: &str) -> Result<Frame, PlyError> {
    let fmt = |reason: String| PlyError::Format {
        path: path.to_string(),
        reason,
    };
    let end = bytes
        .windows(11)
        .position(|w| w == b"end_header\n")
        .ok_or_else(|| fmt("no end_header".into()))?;
    let header =
        std::str::from_utf8(&bytes[..end]).map_err(|_| fmt("header is not UTF-8".into()))?;
    let mut count = None;
    let mut props: Vec<(String, String, usize)> = Vec::new();
    let mut in_vertex = false;
    for (ln, line) in header.lines().enumerate() {
        let w: Vec<&str> = line.split_whitespace().collect();
        match w.as_slice() {
            ["ply"] | [] => {}
            ["format", f, _] if ln == 1 => {
                if *f != "binary_little_endian" {
                    return Err(fmt(format!("format {f} is not binary_little_endian")));
                }
            }
            ["comment", ..] | ["obj_info", ..] => {}
            ["element", name, n] => {
                in_vertex = *name == "vertex";
                if in_vertex {
                    count = Some(
                        n.parse::<usize>()
                            .map_err(|_| fmt(format!("bad vertex count {n}")))?,
                    );
                } else {
                    return Err(fmt(format!("unexpected element {name}")));
                }
            }
            ["property", t, n] if in_vertex => {
                let s = size_of(t).ok_or_else(|| fmt(format!("unsupported property type {t}")))?;
                props.push((t.to_string(), n.to_string(), s));
            }
            _ => return Err(fmt(format!("header line {}: cannot read {line:?}", ln + 1))),
        }
    }
    let count = count.ok_or_else(|| fmt("no vertex element".into()))?;
    let stride: usize = props.iter().map(|p| p.2).sum();
    let body = &bytes[end + 11..];
    if body.len() < count * stride {
        return Err(fmt(format!(
            "truncated: {} bytes of data for {count} vertices of {stride} bytes",
            body.len()
        )));
    }
    let col = |name: &str| -> Option<(usize, String)> {
        let mut off = 0;
        for (t, n, s) in &props {
            if n == name {
                return Some((off, t.clone()));
            }
            off += s;
        }
        None
    };
    let need = |name: &str| col(name).ok_or_else(|| fmt(format!("missing property {name}")));
    let cx = [need("x")?, need("y")?, need("z")?];
    let cv = [need("vx")?, need("vy")?, need("vz")?];
    let (cid, cc, cr, cm) = (need("id")?, need("codim")?, need("pscale")?, need("mass")?);
    let cn = [col("nx"), col("ny"), col("nz")];
    let ca: Option<Vec<(usize, String)>> = AFFINE_PROPS.iter().map(|n| col(n)).collect();
    let cfix = col("fixed");
    let mut f = Frame::default();
    let mut affine = Vec::new();
    let p = &mut f.particles;
    for i in 0..count {
        let r = &body[i * stride..(i + 1) * stride];
        let g = |c: &(usize, String)| read_num(&c.1, &r[c.0..]);
        let codim = Codim::from_number(g(&cc) as u8)
            .ok_or_else(|| fmt(format!("vertex {i}: codim {} not in 0..=3", g(&cc))))?;
        p.push(
            Vec3::new(g(&cx[0]), g(&cx[1]), g(&cx[2])),
            Vec3::new(g(&cv[0]), g(&cv[1]), g(&cv[2])),
            g(&cm),
            g(&cr),
            codim,
        );
        p.id[i] = g(&cid) as u64;
        p.fixed[i] = cfix.as_ref().is_some_and(|c| g(c) != 0.0);
        let n = Vec3::from_fn(|d, _| cn[d].as_ref().map_or(0.0, &g));
        f.frame_vec.push(n);
        if let Some(ca) = &ca {
            affine.push([0, 1, 2].map(|a| Vec3::from_fn(|d, _| g(&ca[3 * a + d]))));
        }
    }
    if ca.is_some() {
        f.affine = Some(affine);
    }
    p.next_id = p.id.iter().max().map_or(0, |m| m + 1);
    Ok(f)
}

/// Reads a cache frame from disk.
pub fn read(path: &Path) -> Result<Frame, PlyError> {
    let bytes = std::fs::read(path).map_err(|source| PlyError::Io {
        path: path.display().to_string(),
        source,
    })?;
    decode(&bytes, &path.display().to_string())
}

/// File name of frame `n`: `particles.NNNN.ply`.
pub fn frame_name(n: u32) -> String {
    format!("particles.{n:04}.ply")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn encode_decode_round_trip_is_exact() {
        let mut p = Particles::new();
        for i in 0..7 {
            let c = Codim::from_number((i % 4) as u8).unwrap();
            p.push(
                Vec3::new(0.1 * i as Real, 1.0 / 3.0, -2.5e-7),
                Vec3::new(1e-300, -0.7, i as Real),
                1e-6 * (i + 1) as Real,
                0.0123,
                c,
            );
        }
        p.retain(&[true, true, false, true, true, true, true]);
        let bytes = encode(&p, None, None, 3, 0.1).unwrap();
        let f = decode(&bytes, "mem").unwrap();
        assert_eq!(f.particles.x, p.x);
        assert_eq!(f.particles.v, p.v);
        assert_eq!(f.particles.id, p.id);
        assert_eq!(f.particles.codim, p.codim);
        assert_eq!(f.particles.mass, p.mass);
        assert_eq!(f.particles.radius, p.radius);
        assert_eq!(f.particles.next_id, 7);
        // the bytes re-encode identically
        assert_eq!(encode(&f.particles, None, None, 3, 0.1).unwrap(), bytes);
        // 13 properties, 93 bytes per particle
        let head = bytes
            .windows(11)
            .position(|w| w == b"end_header\n")
            .unwrap()
            + 11;
        assert_eq!(bytes.len() - head, 6 * 93);
    }

    #[test]
    fn non_finite_frames_are_refused() {
        let mut p = Particles::new();
        p.push(
            Vec3::new(Real::NAN, 0.0, 0.0),
            Vec3::zeros(),
            1.0,
            1.0,
            Codim::Volume,
        );
        assert!(matches!(
            encode(&p, None, None, 1, 0.0),
            Err(PlyError::Value { index: 0, .. })
        ));
    }
}
