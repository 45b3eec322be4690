//! What leaves the library: continuity statistics, mesh files, control nets, the distance
//! study, and (feature `cli`) its plots and progress bars.

pub mod atomic;
pub mod distance;
pub mod msh;
pub mod nets;
#[cfg(feature = "cli")]
pub mod plot;
pub mod stats;
pub mod table1;
pub mod writers;
