//! surfacer — turns codimfx particle caches into renderable geometry.
//!
//! Pipeline per frame (each stage a function with its own options struct):
//!
//! 1. [`cache`]: read a `particles.####.ply` frame by property name (`docs/cache-format.md`).
//! 2. [`anisotropy`]: Yu & Turk (2013) anisotropic kernels for volume particles (codim 0).
//! 3. [`density`]: kernels summed into a blocked volume-fraction field.
//! 4. [`redistance`]: zero crossing → narrow-band signed distance (closest-point propagation).
//! 5. [`sheets`], [`filaments`]: oriented disks (codim 1), tubes (codim 2) and spheres (codim 3),
//!    unioned into the level set and also meshed explicitly.
//! 6. [`mesh`]: marching cubes of the zero crossing (watertight, manifold).
//! 7. [`vdb`], [`ply`]: writers; [`pipeline`]: per-frame driver with atomic outputs;
//!    [`alloc`]: the allocator setting a surfacing process opts into.
//!
//! The crate does not depend on the `codimfx` solver; it only knows the cache format.

pub mod alloc;
pub mod anisotropy;
pub mod band;
mod blockset;
pub mod cache;
pub mod density;
pub mod eigen3;
pub mod error;
pub mod filaments;
pub mod hash;
mod leafbits;
pub mod levelset;
pub mod mesh;
pub mod pipeline;
pub mod ply;
pub mod redistance;
pub mod sheets;
pub mod vdb;

pub use cache::ParticleFrame;
pub use error::SurfaceError;
pub use levelset::LevelSet;
pub use mesh::TriMesh;
pub use pipeline::{
    surface_cache, surface_frame, surface_particles, FrameGeometry, SurfaceOptions,
};

/// Floating-point type used for all geometry (positions in metres).
pub type Real = f64;
/// A 3-vector in world space.
pub type Vec3 = nalgebra::Vector3<Real>;
/// A 3×3 matrix.
pub type Mat3 = nalgebra::Matrix3<Real>;
