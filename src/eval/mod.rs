//! Evaluation of patch tables: one interface, a CPU backend (f64 reference, rayon) and a
//! GPU backend (wgpu compute). Results stream to the consumer chunk by chunk.

pub mod cpu;
pub mod gpu;
pub mod pattern;

use glam::DVec3;

pub use pattern::{grid_barycentrics, grid_len, grid_triangles, PatchPoint, Pattern};

use crate::patch::PatchTable;
use crate::Result;

/// A contiguous run of evaluated samples.
///
/// For [`Pattern::Grid`] `first` is the first patch of the chunk and the samples are
/// `grid_len(level)` per patch in grid order; for [`Pattern::Points`] `first` is the index
/// of the first point.
pub struct Chunk<'a> {
    pub first: usize,
    pub positions: &'a [DVec3],
    pub normals: &'a [DVec3],
}

/// A backend that evaluates positions and unit normals of a patch table.
pub trait Evaluator {
    /// Which backend and device, for reports ("cpu (2 threads)", the adapter's name, ...).
    fn describe(&self) -> String;

    /// Evaluates `pattern` on `table`, handing the results to `sink` in order, chunk by
    /// chunk.
    fn evaluate(
        &self,
        table: &PatchTable,
        pattern: &Pattern,
        sink: &mut dyn FnMut(Chunk<'_>) -> Result<()>,
    ) -> Result<()>;

    /// Evaluates `pattern` into two whole arrays (convenience for small runs and tests).
    fn evaluate_all(
        &self,
        table: &PatchTable,
        pattern: &Pattern,
    ) -> Result<(Vec<DVec3>, Vec<DVec3>)> {
        let mut pos = Vec::new();
        let mut nrm = Vec::new();
        self.evaluate(table, pattern, &mut |c| {
            pos.extend_from_slice(c.positions);
            nrm.extend_from_slice(c.normals);
            Ok(())
        })?;
        Ok((pos, nrm))
    }
}
