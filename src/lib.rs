//! codimfx — codimensional surface-tension liquids with MLS particles.
//!
//! Implements Wang, Jin, Luo, Yang, Zhu, *Codimensional Surface Tension Flow
//! using Moving-Least-Squares Particles*, ACM TOG 39(4), 2020. See
//! `docs/architecture.md` for the module map and the data flow of a step.

pub mod area;
pub mod coupling;
pub mod emitter;
pub mod film;
pub mod gas;
pub mod linsolve;
pub mod math;
pub mod mls;
pub mod neighbors;
pub mod outline;
pub mod particles;
pub mod reseed;
pub mod tension;
pub mod transition;
pub mod validate;

pub use math::{Real, Vec3};
pub use particles::{Codim, Particles};
pub mod advect;
mod frame_record;
pub mod grid;
pub mod io;
pub mod preview;
pub mod scene;
pub mod sim;
pub mod solids;
pub mod step;
