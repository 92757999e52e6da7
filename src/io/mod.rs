//! Cache files: one module per format (`docs/cache-format.md`).

pub mod manifest;
pub mod ply;

use std::io::Write;
use std::path::Path;

/// Writes `bytes` to `path` atomically: a temporary name in the same folder, then a rename.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let mut tmp = path.as_os_str().to_owned();
    tmp.push(".tmp");
    let tmp = std::path::PathBuf::from(tmp);
    {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
    }
    std::fs::rename(&tmp, path)
}
