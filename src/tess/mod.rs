//! Tessellation output: the stitched surface of a grid evaluation ([`stitch`]), streamed
//! patch by patch to writers or kept in memory; per-edge levels ([`adaptive`], the pattern
//! in [`layout`]), levels from a tolerance and from the screen ([`screen`]).

pub mod adaptive;
pub mod layout;
pub mod numbering;
pub mod screen;
pub mod screen_gpu;
pub mod stitch;
