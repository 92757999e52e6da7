//! PLY mesh writer (via ply-rs-bw, binary little endian) and the atomic-file helper.
//!
//! Vertex properties: `x y z` (float), `nx ny nz` (float, unit vertex normal), `vx vy vz`
//! (float, m/s); faces: `vertex_indices` (list uchar int). Houdini and Blender read these as
//! point attributes `N` / `v` (Blender ≥ 4 keeps `vx vy vz` as an attribute).
use crate::{SurfaceError, TriMesh};
use ply_rs_bw::ply::{
    Addable, ElementDef, Encoding, Header, PropertyAccess, PropertyDef, PropertyType, ScalarType,
};
use ply_rs_bw::writer::Writer;
use std::io::{BufWriter, Write};
use std::path::Path;

/// Writes a file by calling `f` on a buffered writer to `path.tmp-<pid>`, then renaming it onto
/// `path`, so a reader never sees a half-written file.
pub fn write_atomically(
    path: &Path,
    f: impl FnOnce(&mut BufWriter<std::fs::File>) -> std::io::Result<()>,
) -> Result<(), SurfaceError> {
    let mut tmp = path.as_os_str().to_owned();
    tmp.push(format!(".tmp-{}", std::process::id()));
    let tmp = std::path::PathBuf::from(tmp);
    let file = std::fs::File::create(&tmp).map_err(|e| SurfaceError::io(&tmp, e))?;
    let mut w = BufWriter::with_capacity(1 << 20, file);
    let res = f(&mut w).and_then(|_| w.flush());
    drop(w);
    if let Err(e) = res {
        let _ = std::fs::remove_file(&tmp);
        return Err(SurfaceError::io(path, e));
    }
    std::fs::rename(&tmp, path).map_err(|e| SurfaceError::io(path, e))
}

/// One vertex row of the mesh PLY (the writer's element type; only its header writer is used,
/// the body is written directly).
enum Row {
    V([f32; 9]),
}

const VNAMES: [&str; 9] = ["x", "y", "z", "nx", "ny", "nz", "vx", "vy", "vz"];

impl PropertyAccess for Row {
    fn new() -> Self {
        Row::V([0.0; 9])
    }
    fn get_float(&self, name: &str) -> Option<f32> {
        match self {
            Row::V(v) => VNAMES.iter().position(|n| *n == name).map(|i| v[i]),
        }
    }
}

/// Writes `mesh` as a binary PLY at `path`, atomically.
pub fn write_mesh(path: &Path, mesh: &TriMesh, comment: &str) -> Result<(), SurfaceError> {
    let mut header = Header::new();
    header.encoding = Encoding::BinaryLittleEndian;
    header.comments.push(comment.to_string());
    let mut ve = ElementDef::new("vertex".into());
    for n in VNAMES {
        ve.properties.add(PropertyDef::new(
            n.into(),
            PropertyType::Scalar(ScalarType::Float),
        ));
    }
    ve.count = mesh.pos.len();
    let mut fe = ElementDef::new("face".into());
    fe.properties.add(PropertyDef::new(
        "vertex_indices".into(),
        PropertyType::List(ScalarType::UChar, ScalarType::Int),
    ));
    fe.count = mesh.tris.len();
    header.elements.add(ve.clone());
    header.elements.add(fe.clone());
    write_atomically(path, |w| {
        let wr = Writer::<Row>::new();
        wr.write_header(w, &header)?;
        // the body as the header declares it (binary little endian), written directly: vertices
        // as 9 f32, faces as a u8 count 3 and 3 i32
        let mut buf = Vec::with_capacity(1 << 16);
        for i in 0..mesh.pos.len() {
            let (p, n, v) = (mesh.pos[i], mesh.normal[i], mesh.vel[i]);
            for x in [p.x, p.y, p.z, n.x, n.y, n.z, v.x, v.y, v.z] {
                buf.extend_from_slice(&(x as f32).to_le_bytes());
            }
            if buf.len() >= 1 << 16 {
                w.write_all(&buf)?;
                buf.clear();
            }
        }
        for t in &mesh.tris {
            buf.push(3);
            for &k in t {
                buf.extend_from_slice(&(k as i32).to_le_bytes());
            }
            if buf.len() >= 1 << 16 {
                w.write_all(&buf)?;
                buf.clear();
            }
        }
        w.write_all(&buf)
    })
}
