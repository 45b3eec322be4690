//! What leaves the library: continuity statistics, mesh files, pictures and plots.

pub mod atomic;
pub mod distance;
pub mod nets;
pub mod plot;
pub mod render;
pub mod stats;
pub mod table1;
pub mod writers;
