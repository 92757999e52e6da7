//! Typed errors of the surfacer; every variant names the place and carries the numbers.
use std::path::PathBuf;

/// Everything that can go wrong while surfacing a cache.
#[derive(Debug, thiserror::Error)]
pub enum SurfaceError {
    /// A file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// the file
        path: PathBuf,
        /// the OS error
        source: std::io::Error,
    },
    /// A cache PLY could not be parsed.
    #[error("{path}: not a readable PLY cache frame: {reason}")]
    Ply {
        /// the file
        path: PathBuf,
        /// what the parser said
        reason: String,
    },
    /// A property required by `docs/cache-format.md` is missing.
    #[error(
        "{path}: element `vertex` has no property `{name}` (required by docs/cache-format.md)"
    )]
    MissingProperty {
        /// the file
        path: PathBuf,
        /// the property name
        name: String,
    },
    /// A value in a cache is NaN or infinite, or out of its documented range.
    #[error("{path}: particle {index}: property `{name}` = {value} is invalid ({reason})")]
    BadValue {
        /// the file
        path: PathBuf,
        /// vertex index in the file
        index: usize,
        /// property name
        name: &'static str,
        /// the offending value
        value: f64,
        /// why it is rejected
        reason: &'static str,
    },
    /// No `particles.####.ply` frames were found.
    #[error("{dir}: no particles.####.ply frames found{extra}")]
    NoFrames {
        /// the cache folder
        dir: PathBuf,
        /// the frame range asked for, if any
        extra: String,
    },
    /// An option is out of range.
    #[error("option {name} = {value} is invalid: {reason}")]
    BadOption {
        /// option name
        name: &'static str,
        /// its value
        value: f64,
        /// why
        reason: &'static str,
    },
    /// Non-finite values were produced (never written to disk).
    #[error("frame {frame}: {count} non-finite values in {what}; nothing written")]
    NonFinite {
        /// frame number
        frame: u32,
        /// which output
        what: &'static str,
        /// how many
        count: usize,
    },
    /// The grid would be larger than the index space or the voxel budget.
    #[error("grid too large: {voxels:.3e} voxels in the bounding box at voxel size {voxel_size} m exceeds the index range (|index| < 2^18 voxels from the origin); use a larger --voxel-size")]
    GridTooLarge {
        /// voxels in the bounding box
        voxels: f64,
        /// voxel size (m)
        voxel_size: f64,
    },
}

impl SurfaceError {
    /// Wraps an I/O error with its path.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        SurfaceError::Io {
            path: path.into(),
            source,
        }
    }
}
