//! Tessellation output: the stitched surface of a grid evaluation ([`stitch`]), streamed
//! patch by patch to writers or kept in memory.

pub mod stitch;
