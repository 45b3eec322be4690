//! Tessellation output: the stitched surface of a grid evaluation ([`stitch`]), streamed
//! patch by patch to writers or kept in memory; per-edge levels ([`levels`], the pattern
//! in [`layout`]), chosen for a tolerance ([`adaptive`]) or from the screen ([`screen`];
//! on the GPU, [`crate::gpu::screen`]).

pub mod adaptive;
pub mod layout;
pub mod levels;
pub mod numbering;
pub mod screen;
pub mod stitch;
