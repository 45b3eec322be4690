//! Evaluation of patch tables: one interface, a CPU backend (f64 reference, rayon) and a
//! GPU backend (wgpu compute). Results stream to the consumer chunk by chunk.

pub mod cpu;
pub mod gpu;
pub mod pattern;

use glam::DVec3;

pub use pattern::{grid_barycentrics, grid_len, grid_triangles, PatchPoint, Pattern};

use crate::patch::PatchTable;
use crate::Result;

/// A contiguous run of evaluated samples, in the precision the consumer asked for: `DVec3`
/// (the f64 reference, [`Evaluator::evaluate`]) or `[f32; 3]` ([`ChunkF32`],
/// [`Evaluator::evaluate_f32`]).
///
/// For [`Pattern::Grid`] `first` is the first patch of the chunk and the samples are
/// `grid_len(level)` per patch in grid order; for [`Pattern::Points`] `first` is the index
/// of the first point. Corner samples (b = a unit vector) are the input vertices bit for
/// bit, in either precision (f32: the input rounded once).
pub struct Chunk<'a, V = DVec3> {
    pub first: usize,
    pub positions: &'a [V],
    pub normals: &'a [V],
}

/// A chunk of f32 samples (writers, GPUs).
pub type ChunkF32<'a> = Chunk<'a, [f32; 3]>;

/// Rounds an f64 vector to f32 once per component.
#[inline]
pub fn to_f32(v: DVec3) -> [f32; 3] {
    [v.x as f32, v.y as f32, v.z as f32]
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

    /// Evaluates `pattern` on `table` in f32, chunk by chunk. Backends with a native f32
    /// kernel override this; the default evaluates in f64 and rounds each value once (so
    /// corners are the input rounded to f32, bit for bit).
    fn evaluate_f32(
        &self,
        table: &PatchTable,
        pattern: &Pattern,
        sink: &mut dyn FnMut(ChunkF32<'_>) -> Result<()>,
    ) -> Result<()> {
        let (mut pos, mut nrm) = (Vec::new(), Vec::new());
        self.evaluate(table, pattern, &mut |c| {
            pos.clear();
            nrm.clear();
            pos.extend(c.positions.iter().map(|&p| to_f32(p)));
            nrm.extend(c.normals.iter().map(|&n| to_f32(n)));
            sink(Chunk {
                first: c.first,
                positions: &pos,
                normals: &nrm,
            })
        })
    }

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
