//! What leaves the library as files: mesh files, Gmsh MSH, control nets, written
//! atomically ([`atomic`], with the caller's [`TempFiles`]), and (feature `cli`) plots.

pub mod atomic;
pub mod msh;
pub mod nets;
#[cfg(feature = "cli")]
pub mod plot;
pub mod writers;

pub use atomic::TempFiles;
