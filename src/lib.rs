//! g1tess: smooth curved surfaces from flat triangle meshes with vertex normals.
//!
//! Data flows one way (see `ARCHITECTURE.md`):
//! [`mesh`] (load, weld, adjacency, normals, generators) → [`patch`] (one file per scheme,
//! backend-agnostic f64 control-point tables) → [`eval`] (CPU and GPU evaluators, sample
//! patterns) → [`output`] (statistics, writers, pictures, plots).

pub mod cli;
pub mod error;
pub mod eval;
pub mod gpu;
pub mod mesh;
pub mod output;
pub mod patch;
pub mod progress;
pub mod tess;

pub use error::{Error, Result};
