//! What leaves the library: continuity statistics, mesh files, pictures and plots.

pub mod atomic;
pub mod nets;
pub mod progress;
pub mod stats;
pub mod weld;
pub mod writers;
