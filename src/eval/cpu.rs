//! The CPU backend: f64 evaluation, parallel over patches with rayon. It is the reference
//! every other backend is tested against.

use glam::DVec3;
use rayon::prelude::*;

use super::{grid_barycentrics, grid_len, Chunk, Evaluator, Pattern};
use crate::patch::basis::Weights;
use crate::patch::PatchTable;
use crate::Result;

/// The CPU evaluator.
#[derive(Clone, Debug)]
pub struct CpuEvaluator {
    /// Samples per chunk handed to the sink (bounded memory for any mesh size).
    pub chunk_samples: usize,
}

impl Default for CpuEvaluator {
    fn default() -> Self {
        CpuEvaluator {
            chunk_samples: 1 << 20,
        }
    }
}

/// Basis values at every point of the grid of level n: the same for every patch of a
/// table, so computed once.
pub fn grid_weights(table: &PatchTable, level: u32) -> Vec<Weights> {
    grid_barycentrics(level)
        .into_iter()
        .map(|b| table.kind.weights(b))
        .collect()
}

impl Evaluator for CpuEvaluator {
    fn describe(&self) -> String {
        format!("cpu (f64, {} threads)", rayon::current_num_threads())
    }

    fn evaluate(
        &self,
        table: &PatchTable,
        pattern: &Pattern,
        sink: &mut dyn FnMut(Chunk<'_>) -> Result<()>,
    ) -> Result<()> {
        match pattern {
            Pattern::Grid { level } => {
                let weights = grid_weights(table, *level);
                let per = grid_len(*level);
                let patches_per_chunk = (self.chunk_samples / per).max(1);
                let mut pos = Vec::new();
                let mut nrm = Vec::new();
                let mut first = 0;
                while first < table.len() {
                    let count = patches_per_chunk.min(table.len() - first);
                    pos.resize(count * per, DVec3::ZERO);
                    nrm.resize(count * per, DVec3::ZERO);
                    pos.par_chunks_mut(per)
                        .zip(nrm.par_chunks_mut(per))
                        .enumerate()
                        .for_each(|(k, (p, n))| {
                            for (s, w) in weights.iter().enumerate() {
                                let sp = table.eval_weights(first + k, w);
                                p[s] = sp.p;
                                n[s] = sp.n;
                            }
                        });
                    sink(Chunk {
                        first,
                        positions: &pos,
                        normals: &nrm,
                    })?;
                    first += count;
                }
                Ok(())
            }
            Pattern::Points(points) => {
                for (c, chunk) in points.chunks(self.chunk_samples.max(1)).enumerate() {
                    let (pos, nrm): (Vec<DVec3>, Vec<DVec3>) = chunk
                        .par_iter()
                        .map(|pp| {
                            let sp = table.eval(pp.patch as usize, pp.b);
                            (sp.p, sp.n)
                        })
                        .unzip();
                    sink(Chunk {
                        first: c * self.chunk_samples.max(1),
                        positions: &pos,
                        normals: &nrm,
                    })?;
                }
                Ok(())
            }
        }
    }
}
