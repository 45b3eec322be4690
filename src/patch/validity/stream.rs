//! The certificate of a table seen a chunk at a time ([`Certifier`]): what an evaluation
//! that builds each chunk's patches where it evaluates them (`tess::stitch::stitch_built`)
//! needs, since the table of the whole mesh is never held.

use super::{check_listed, first_stages, PatchCounts, Stage, Verdict};
use crate::patch::{PatchBuilder, PatchTable};
use crate::Result;

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
    /// Their index among the patches seen.
    at: Vec<usize>,
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
            at: Vec::new(),
            seen: 0,
        }
    }

    /// Takes the next chunk of the table (its patches follow those seen).
    pub fn see(&mut self, chunk: &PatchTable) {
        self.take(chunk, |_| {});
    }

    /// [`Self::see`], returning the verdict of each patch of `chunk` that the first stage
    /// gave (`None` where the subdivisions decide: [`Self::finish_verdicts`] gives those).
    pub fn see_verdicts(&mut self, chunk: &PatchTable) -> Vec<Option<Verdict>> {
        let mut out = Vec::with_capacity(chunk.len());
        self.take(chunk, |v| out.push(v));
        out
    }

    /// [`Self::see`], handing `first` each patch's first-stage verdict in order.
    fn take(&mut self, chunk: &PatchTable, mut first: impl FnMut(Option<Verdict>)) {
        let stages = first_stages(chunk, 0..chunk.len());
        let kept = self.kept.get_or_insert_with(|| PatchTable {
            points: Vec::new(),
            flat_normals: Vec::new(),
            fallbacks: 0,
            ..*chunk
        });
        for (i, stage) in stages.into_iter().enumerate() {
            match stage {
                Stage::Done(v) => {
                    self.done = self.done.with(&v);
                    first(Some(v));
                }
                _ => {
                    self.stages.push((kept.len(), stage));
                    self.at.push(self.seen + i);
                    kept.points.extend_from_slice(chunk.patch(i));
                    kept.flat_normals.push(chunk.flat_normals[i]);
                    first(None);
                }
            }
        }
        self.seen += chunk.len();
    }

    /// The verdicts of every patch seen, counted.
    pub fn finish(self) -> PatchCounts {
        self.finish_verdicts().counts
    }

    /// The verdicts of every patch seen, counted, with those the subdivisions gave.
    pub fn finish_verdicts(self) -> Decided {
        let verdicts: Vec<Verdict> = match &self.kept {
            Some(kept) => check_listed(kept, &self.stages, self.seen)
                .into_iter()
                .map(|r| r.0)
                .collect(),
            None => Vec::new(),
        };
        Decided {
            counts: verdicts.iter().fold(self.done, PatchCounts::with),
            verdicts,
            at: self.at,
            table: self.kept,
        }
    }
}

/// What the subdivisions of a [`Certifier`] decided, beside the counts of all.
pub struct Decided {
    /// The verdicts of every patch seen, counted.
    pub counts: PatchCounts,
    /// The verdicts of the patches the subdivisions decided, in the order seen.
    pub verdicts: Vec<Verdict>,
    /// Their index among the patches seen.
    pub at: Vec<usize>,
    /// Their patches (patch k is the k-th of `verdicts`); `None` where nothing was seen.
    pub table: Option<PatchTable>,
}

/// The verdicts of every patch that `builder` builds, [`super::check_table`]'s of the
/// whole table bit for bit, from chunks of `chunk` patches built one at a time in the same
/// memory (the subdivisions run at the end, as [`Certifier`] runs them). `each` sees every
/// chunk: its table, the index of its first patch and the first stage's verdicts (`None`
/// where the subdivisions decide). Returns every verdict, with what the subdivisions
/// decided.
pub fn check_in_chunks(
    builder: &PatchBuilder<'_>,
    chunk: usize,
    mut each: impl FnMut(&PatchTable, usize, &[Option<Verdict>]) -> Result<()>,
) -> Result<(Vec<Verdict>, Decided)> {
    let mut certifier = Certifier::new();
    let mut verdicts = Vec::with_capacity(builder.mesh().triangles.len());
    builder.for_each_chunk(chunk, |table, start| {
        let first = certifier.see_verdicts(table);
        each(table, start, &first)?;
        verdicts.extend(first.iter().map(|v| v.unwrap_or(Verdict::Undecided)));
        Ok(())
    })?;
    let decided = certifier.finish_verdicts();
    for (&i, v) in decided.at.iter().zip(&decided.verdicts) {
        verdicts[i] = *v;
    }
    Ok((verdicts, decided))
}

impl Default for Certifier {
    fn default() -> Self {
        Certifier::new()
    }
}
