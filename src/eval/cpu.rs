//! The CPU backend: the f64 reference (every other backend is tested against it) and, for
//! grids in f32 ([`Evaluator::evaluate_f32`]), a SIMD kernel (`grid_f32`: f32 weights in
//! blocks of 16 samples with AVX-512F or 8 with AVX2+FMA, detected at run time, or
//! portable code). Edge patterns
//! (statistics) run an f64 lane kernel (`edges`: AVX-512F, 8 lanes, or AVX, 4 lanes,
//! detected at run time), bitwise the sparse reference. All run in parallel over patches
//! with rayon and stream bounded chunks.

use glam::DVec3;
use rayon::prelude::*;

use super::{
    evaluate_f32_via_f64, grid_barycentrics, grid_corners, grid_len, staged_chunks, Chunk,
    ChunkF32, EdgePairs, Evaluator, PairChunk, PairProducts, Pattern,
};
use crate::patch::basis::Weights;
use crate::patch::PatchTable;
use crate::Result;

pub(crate) mod edges;
mod grid_f32;

pub use edges::EdgeKernel;
use edges::{EdgeWeights, PairScratch};
pub use grid_f32::{F32Kernel, GridWeightsF32};

/// The CPU evaluator.
#[derive(Clone, Debug)]
pub struct CpuEvaluator {
    /// Samples per chunk handed to the sink (bounded memory for any mesh size; the f32
    /// grid kernel hands at most 2^16, `PIPELINE_SAMPLES`).
    pub chunk_samples: usize,
    /// Instruction set of the f32 grid kernel ([`Evaluator::evaluate_f32`]).
    pub f32_kernel: F32Kernel,
    /// Instruction set of the f64 edge kernel (statistics' edge samples).
    pub edge_kernel: EdgeKernel,
}

impl Default for CpuEvaluator {
    fn default() -> Self {
        CpuEvaluator {
            chunk_samples: 1 << 20,
            f32_kernel: F32Kernel::Auto,
            edge_kernel: EdgeKernel::Auto,
        }
    }
}

impl CpuEvaluator {
    /// The default evaluator with `chunk_samples` samples per chunk.
    pub fn with_chunk_samples(chunk_samples: usize) -> CpuEvaluator {
        CpuEvaluator {
            chunk_samples,
            ..Default::default()
        }
    }
}

/// Fails, instead of aborting, when the per-grid tables of `level` (`bytes_per_point` at
/// each of its points) cannot be allocated: the allocation is tried and given back.
/// Commands check a memory budget before; this keeps a library call with an absurd level
/// from ending the process.
pub(crate) fn grid_fits(level: u32, bytes_per_point: usize) -> Result<()> {
    let bytes = (grid_len(level) as u128) * bytes_per_point as u128;
    let too_big = || {
        crate::Error::Invalid(format!(
            "the grid of level {level} needs {bytes} bytes of basis tables, more than can be \
             allocated"
        ))
    };
    let bytes = usize::try_from(bytes).map_err(|_| too_big())?;
    let mut probe: Vec<u8> = Vec::new();
    probe.try_reserve_exact(bytes).map_err(|_| too_big())?;
    Ok(())
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
        format!(
            "cpu (f64; f32 grids {}; {} threads)",
            self.f32_kernel.name(),
            rayon::current_num_threads()
        )
    }

    fn evaluate(
        &self,
        table: &PatchTable,
        pattern: &Pattern,
        sink: &mut dyn FnMut(Chunk<'_>) -> Result<()>,
    ) -> Result<()> {
        match pattern {
            Pattern::Grid { level } => {
                grid_fits(*level, std::mem::size_of::<Weights>() + 24)?;
                let weights = grid_weights(table, *level);
                let per = grid_len(*level);
                let corners = grid_corners(*level);
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
                            // The input vertices as they are, whatever the weights' rounding.
                            for (c, &g) in corners.iter().enumerate() {
                                p[g] = table.corner(first + k, c);
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
                if let Some(bad) = points.iter().find(|p| p.patch as usize >= table.len()) {
                    return Err(crate::Error::Invalid(format!(
                        "evaluation point on patch {} of a table of {} patches",
                        bad.patch,
                        table.len()
                    )));
                }
                stream_chunks(
                    points.len(),
                    self.chunk_samples.max(1),
                    sink,
                    |r, pos, nrm| {
                        let chunk = &points[r];
                        // Blocks of points; each rayon job keeps a memo of basis weights per
                        // distinct barycentric point (edge samples have few) and evaluates
                        // through the nonzero ones: bitwise what `table.eval` returns.
                        const BLOCK: usize = 4096;
                        pos.par_chunks_mut(BLOCK)
                            .zip(nrm.par_chunks_mut(BLOCK))
                            .zip(chunk.par_chunks(BLOCK))
                            .for_each_init(
                                || crate::patch::basis::WeightMemo::new(table.kind),
                                |memo, ((p, n), pts)| {
                                    for ((p, n), pp) in p.iter_mut().zip(n.iter_mut()).zip(pts) {
                                        let i = pp.patch as usize;
                                        let sp = table.eval_sparse(i, memo.get(pp.b));
                                        // A corner is the input vertex bit for bit (as on the
                                        // grid and edge paths), whatever the sums give.
                                        let corner =
                                            pp.b.iter().position(|&x| x == 1.0).filter(|&k| {
                                                (0..3).all(|j| j == k || pp.b[j] == 0.0)
                                            });
                                        *p = match corner {
                                            Some(k) => table.corner(i, k),
                                            None => sp.p,
                                        };
                                        *n = sp.n;
                                    }
                                },
                            );
                    },
                )
            }
        }
    }

    /// The basis at every (from, to, sample) computed once per call (sparse, as
    /// `PatchTable::eval_sparse` takes it), then rayon over the pairs: bitwise the
    /// values of [`Pattern::Points`] of `EdgePairs::points`, with no per-point lookup.
    /// Chunks hold whole pairs, about `chunk_samples` points.
    fn evaluate_edges(
        &self,
        table: &PatchTable,
        edges: &EdgePairs,
        sink: &mut dyn FnMut(Chunk<'_>) -> Result<()>,
    ) -> Result<()> {
        edges.check(table.len())?;
        if edges.is_empty() {
            return Ok(());
        }
        let per = edges.samples as usize;
        let cached = EdgeWeights::cached(table, edges, self.edge_kernel.lanes());
        let weights: &EdgeWeights = &cached;
        let pairs_per_chunk = (self.chunk_samples / (2 * per)).max(1);
        let step = 2 * per * pairs_per_chunk;
        stream_chunks(2 * per * edges.pairs.len(), step, sink, |r, pos, nrm| {
            let chunk = &edges.pairs[r.start / (2 * per)..r.end / (2 * per)];
            pos.par_chunks_mut(2 * per)
                .zip(nrm.par_chunks_mut(2 * per))
                .zip(chunk.par_iter())
                .with_min_len(64)
                .for_each_init(Vec::new, |lanes, ((p, n), pair)| {
                    weights.pair(table, pair, p, n, lanes)
                });
        })
    }

    /// [`Self::evaluate_edges`]'s kernel on both sides of each edge into small per-job
    /// lane buffers (in cache), in its products mode (cross products and their squared
    /// lengths instead of unit normals), the products computed from them at once, lane by
    /// lane: gap² bitwise as `PairProducts::of`, cos as the quotient of the cross
    /// products' dot product by the root of their squared lengths' product, within 20u
    /// (u = 2⁻⁵³) of `PairProducts::of` on the points (derivation at `products`). A side
    /// the lane kernel cannot take (no lane kernel, a normal field, a non-finite sum) goes
    /// through the points and `PairProducts::of`. Chunks hold whole pairs, about
    /// `chunk_samples / 2` products.
    fn evaluate_edge_products(
        &self,
        table: &PatchTable,
        edges: &EdgePairs,
        sink: &mut dyn FnMut(PairChunk<'_>) -> Result<()>,
    ) -> Result<()> {
        edges.check(table.len())?;
        if edges.is_empty() {
            return Ok(());
        }
        let per = edges.samples as usize;
        let cached = EdgeWeights::cached(table, edges, self.edge_kernel.lanes());
        let weights: &EdgeWeights = &cached;
        let pairs_per_chunk = (self.chunk_samples / (2 * per)).max(1);
        let mut out = PRODUCTS.take();
        if out.capacity() > 2 * per * pairs_per_chunk.min(edges.pairs.len()) {
            out = Vec::new();
        }
        let mut result = Ok(());
        for (c, chunk) in edges.pairs.chunks(pairs_per_chunk).enumerate() {
            out.resize(chunk.len() * per, PairProducts::default());
            out.par_chunks_mut(per)
                .zip(chunk.par_iter())
                .with_min_len(64)
                .for_each_init(PairScratch::default, |scratch, (o, pair)| {
                    weights.pair_products(table, pair, o, scratch)
                });
            result = sink(PairChunk {
                first: c * pairs_per_chunk * per,
                pairs: &out,
            });
            if result.is_err() {
                break;
            }
        }
        PRODUCTS.set(out);
        result
    }

    /// Grids run the f32 SIMD kernel (see `GridWeightsF32`): control points relative to
    /// each patch's first point, f32 weights computed once per call, corners overwritten
    /// with the input vertices rounded once. Point lists are evaluated in f64 and rounded.
    fn evaluate_f32(
        &self,
        table: &PatchTable,
        pattern: &Pattern,
        sink: &mut dyn FnMut(ChunkF32<'_>) -> Result<()>,
    ) -> Result<()> {
        match pattern {
            Pattern::Grid { level } => {
                grid_fits(*level, table.stride * 12 + 24)?;
                let weights = GridWeightsF32::new(table.kind, *level);
                self.grid_f32(table, &weights, sink)
            }
            Pattern::Points(_) => evaluate_f32_via_f64(self, table, pattern, sink),
        }
    }

    /// Grids run the stage in the pool job of the f32 kernel that evaluated the chunk;
    /// point lists stage the chunks of their f64 evaluation (`staged_chunks`).
    fn evaluate_f32_staged(
        &self,
        table: &PatchTable,
        pattern: &Pattern,
        stage: &mut (dyn FnMut(ChunkF32<'_>) + Send),
        sink: &mut dyn FnMut(ChunkF32<'_>) -> Result<()>,
    ) -> Result<()> {
        match pattern {
            Pattern::Grid { level } => {
                grid_fits(*level, table.stride * 12 + 24)?;
                let weights = GridWeightsF32::new(table.kind, *level);
                self.grid_f32_staged(table, &weights, stage, sink)
            }
            Pattern::Points(_) => staged_chunks(
                1,
                |s| evaluate_f32_via_f64(self, table, pattern, s),
                stage,
                sink,
            ),
        }
    }
}

thread_local! {
    /// Result buffers kept per calling thread between calls: a streaming caller
    /// (statistics) evaluates chunk after chunk without fresh pages each time. Taken out
    /// for the call, so a nested call just gets new ones.
    static BUFFERS: std::cell::Cell<(Vec<DVec3>, Vec<DVec3>)> =
        const { std::cell::Cell::new((Vec::new(), Vec::new())) };
}

thread_local! {
    /// The products buffer of [`CpuEvaluator::evaluate_edge_products`], kept per calling
    /// thread between calls as [`BUFFERS`] is.
    static PRODUCTS: std::cell::Cell<Vec<PairProducts>> = const { std::cell::Cell::new(Vec::new()) };
}

/// This thread's result buffers, dropped where much larger than `need` samples.
fn take_buffers(need: usize) -> (Vec<DVec3>, Vec<DVec3>) {
    let (pos, nrm) = BUFFERS.take();
    if pos.capacity() > 2 * need {
        return (Vec::new(), Vec::new());
    }
    (pos, nrm)
}

/// Evaluates `count` samples `step` at a time into this thread's reused buffers: `fill`
/// computes the samples of a range, and each run goes to `sink` with `first` its first
/// sample's index. Stops at the first error of `sink`.
fn stream_chunks(
    count: usize,
    step: usize,
    sink: &mut dyn FnMut(Chunk<'_>) -> Result<()>,
    fill: impl Fn(std::ops::Range<usize>, &mut [DVec3], &mut [DVec3]),
) -> Result<()> {
    let (mut pos, mut nrm) = take_buffers(step.min(count));
    let mut result = Ok(());
    let mut first = 0;
    while first < count {
        let len = step.min(count - first);
        pos.resize(len, DVec3::ZERO);
        nrm.resize(len, DVec3::ZERO);
        fill(first..first + len, &mut pos, &mut nrm);
        result = sink(Chunk {
            first,
            positions: &pos,
            normals: &nrm,
        });
        if result.is_err() {
            break;
        }
        first += len;
    }
    BUFFERS.set((pos, nrm));
    result
}
