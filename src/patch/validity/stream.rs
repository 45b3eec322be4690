//! The certificate of a table seen a chunk at a time ([`Certifier`]): what an evaluation
//! that builds each chunk's patches where it evaluates them (`tess::stitch::stitch_built`)
//! needs, since the table of the whole mesh is never held.

use glam::DVec3;
use rayon::prelude::*;

use super::{check_listed, classify, PatchCounts, Scratch, Stage};
use crate::patch::PatchTable;

/// The verdicts of a table's patches counted from its chunks, in order: each chunk's first
/// stages at once, and the patches the subdivisions decide kept (their control points and
/// stages) until [`finish`](Self::finish). The counts are [`super::count`]'s of the whole
/// table: the subdivisions run on the same patches, in the same order, within the budgets
/// of the same patch count.
pub struct Certifier {
    /// The verdicts the first stages gave.
    done: PatchCounts,
    /// The patches the subdivisions decide, in the order seen (a table of the chunks'
    /// scheme from the first chunk on).
    kept: Option<PatchTable>,
    /// Their stages, with their index in `kept`.
    stages: Vec<(usize, Stage)>,
    /// Patches seen.
    seen: usize,
}

impl Certifier {
    /// A certifier that has seen nothing yet.
    pub fn new() -> Certifier {
        Certifier {
            done: PatchCounts::default(),
            kept: None,
            stages: Vec::new(),
            seen: 0,
        }
    }

    /// Takes the next chunk of the table (its patches follow those seen).
    pub fn see(&mut self, chunk: &PatchTable) {
        let stages: Vec<Stage> = (0..chunk.len())
            .into_par_iter()
            .map_init(
                || Scratch::new([DVec3::ZERO; 2]),
                |scratch, i| classify(chunk, i, scratch).0,
            )
            .collect();
        let kept = self.kept.get_or_insert_with(|| PatchTable {
            points: Vec::new(),
            flat_normals: Vec::new(),
            fallbacks: 0,
            ..*chunk
        });
        for (i, stage) in stages.into_iter().enumerate() {
            match stage {
                Stage::Done(v) => self.done = self.done.with(&v),
                _ => {
                    self.stages.push((kept.len(), stage));
                    kept.points.extend_from_slice(chunk.patch(i));
                    kept.flat_normals.push(chunk.flat_normals[i]);
                }
            }
        }
        self.seen += chunk.len();
    }

    /// The verdicts of every patch seen, counted.
    pub fn finish(self) -> PatchCounts {
        match &self.kept {
            Some(kept) => check_listed(kept, &self.stages, self.seen)
                .iter()
                .fold(self.done, |c, r| c.with(&r.0)),
            None => self.done,
        }
    }
}

impl Default for Certifier {
    fn default() -> Self {
        Certifier::new()
    }
}
