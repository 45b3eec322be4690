//! Evaluation of patch tables: one interface, [`Evaluator`], and the CPU backend (f64
//! reference, rayon); the GPU backend (wgpu compute) is [`crate::gpu::eval`], a layer up.
//! Results stream to the consumer chunk by chunk.

pub mod cpu;
pub mod pattern;

use glam::DVec3;

pub use pattern::{
    grid_barycentrics, grid_corners, grid_len, grid_triangles, EdgePairs, EdgeSide, PatchPoint,
    Pattern,
};

use crate::patch::PatchTable;
use crate::Result;

/// Working precision of the GPU shaders.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "kebab-case")]
pub enum Precision {
    /// 32-bit floats: every adapter.
    F32,
    /// 64-bit floats: adapters with `SHADER_F64` (lavapipe has it).
    F64,
}

impl Precision {
    /// Bytes of one real.
    pub fn bytes(self) -> usize {
        match self {
            Precision::F32 => 4,
            Precision::F64 => 8,
        }
    }

    /// The name used on the command line and in reports ("f32", "f64").
    pub fn name(self) -> &'static str {
        match self {
            Precision::F32 => "f32",
            Precision::F64 => "f64",
        }
    }
}

impl std::fmt::Display for Precision {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// A contiguous run of evaluated samples, in the precision the consumer asked for: `DVec3`
/// (the f64 reference, [`Evaluator::evaluate`]) or `[f32; 3]` ([`ChunkF32`],
/// [`Evaluator::evaluate_f32`]).
///
/// For [`Pattern::Grid`] `first` is the first patch of the chunk and the samples are
/// `grid_len(level)` per patch in grid order; for [`Pattern::Points`] and `EdgePairs`
/// `first` is the index of the first point. Corner samples (b = a unit vector) are the input vertices bit for
/// bit, in either precision (f32: the input rounded once).
pub struct Chunk<'a, V = DVec3> {
    /// The first patch ([`Pattern::Grid`]) or the first point (the other patterns).
    pub first: usize,
    /// Evaluated positions, one per sample.
    pub positions: &'a [V],
    /// Unit normals, in step with `positions`.
    pub normals: &'a [V],
}

/// A chunk of f32 samples (writers, GPUs).
pub type ChunkF32<'a> = Chunk<'a, [f32; 3]>;

/// Rounds an f64 vector to f32 once per component.
#[inline]
pub fn to_f32(v: DVec3) -> [f32; 3] {
    [v.x as f32, v.y as f32, v.z as f32]
}

/// The precision of evaluated samples: `DVec3` (the f64 reference) or `[f32; 3]` (writers,
/// GPUs, the CPU's SIMD kernel). Consumers generic over it (`crate::tess::stitch`, the
/// writers) pick the precision; [`Vector::evaluate`] calls the matching
/// [`Evaluator`] method, so the samples never make a round trip through the other one.
pub trait Vector: Copy + Send + Sync + PartialEq + std::fmt::Debug + 'static {
    /// A value no evaluation produces (unfilled slots).
    const NAN: Self;
    /// "f64" or "f32".
    const NAME: &'static str;
    /// The value in f64 (exact for both precisions).
    fn to_dvec3(self) -> DVec3;
    /// An f64 value in this precision (rounded once for f32).
    fn from_dvec3(v: DVec3) -> Self;
    /// The value in f32 (rounded once from f64; as it is for f32).
    fn to_f32(self) -> [f32; 3];
    /// Appends " x y z", each the shortest decimal that reads back, in f64, to exactly
    /// this precision's value (text formats).
    fn write_text(self, out: &mut String);
    /// Evaluates `pattern` on `table` with `evaluator` in this precision.
    fn evaluate(
        evaluator: &dyn Evaluator,
        table: &PatchTable,
        pattern: &Pattern,
        sink: &mut dyn FnMut(Chunk<'_, Self>) -> Result<()>,
    ) -> Result<()>;
    /// [`Vector::evaluate`] with a stage before the sink (see
    /// [`Evaluator::evaluate_f32_staged`]): f32 runs the evaluator's
    /// `evaluate_f32_staged`; the default stages the chunks of [`Vector::evaluate`]
    /// (`staged_chunks`).
    fn evaluate_staged(
        evaluator: &dyn Evaluator,
        table: &PatchTable,
        pattern: &Pattern,
        stage: &mut (dyn FnMut(Chunk<'_, Self>) + Send),
        sink: &mut dyn FnMut(Chunk<'_, Self>) -> Result<()>,
    ) -> Result<()> {
        staged_chunks(
            pattern.item_len(),
            |s| Self::evaluate(evaluator, table, pattern, s),
            stage,
            sink,
        )
    }
}

impl Vector for DVec3 {
    const NAN: Self = DVec3::NAN;
    const NAME: &'static str = "f64";
    #[inline]
    fn to_dvec3(self) -> DVec3 {
        self
    }
    #[inline]
    fn from_dvec3(v: DVec3) -> Self {
        v
    }
    #[inline]
    fn to_f32(self) -> [f32; 3] {
        to_f32(self)
    }
    fn write_text(self, out: &mut String) {
        use std::fmt::Write as _;
        let _ = write!(out, " {:?} {:?} {:?}", self.x, self.y, self.z);
    }
    fn evaluate(
        evaluator: &dyn Evaluator,
        table: &PatchTable,
        pattern: &Pattern,
        sink: &mut dyn FnMut(Chunk<'_, Self>) -> Result<()>,
    ) -> Result<()> {
        evaluator.evaluate(table, pattern, sink)
    }
}

impl Vector for [f32; 3] {
    const NAN: Self = [f32::NAN; 3];
    const NAME: &'static str = "f32";
    #[inline]
    fn to_dvec3(self) -> DVec3 {
        DVec3::new(self[0] as f64, self[1] as f64, self[2] as f64)
    }
    #[inline]
    fn from_dvec3(v: DVec3) -> Self {
        to_f32(v)
    }
    #[inline]
    fn to_f32(self) -> [f32; 3] {
        self
    }
    /// Each f32 written as the shortest decimal of its exact f64 value, so that a reader in
    /// either precision gets the sample back bit for bit (g1tess reads text in f64: the
    /// shortest f32 decimal, "0.1", would come back as another number than 0.1f32).
    fn write_text(self, out: &mut String) {
        use std::fmt::Write as _;
        let [x, y, z] = self.map(f64::from);
        let _ = write!(out, " {x:?} {y:?} {z:?}");
    }
    fn evaluate(
        evaluator: &dyn Evaluator,
        table: &PatchTable,
        pattern: &Pattern,
        sink: &mut dyn FnMut(Chunk<'_, Self>) -> Result<()>,
    ) -> Result<()> {
        evaluator.evaluate_f32(table, pattern, sink)
    }
    fn evaluate_staged(
        evaluator: &dyn Evaluator,
        table: &PatchTable,
        pattern: &Pattern,
        stage: &mut (dyn FnMut(Chunk<'_, Self>) + Send),
        sink: &mut dyn FnMut(Chunk<'_, Self>) -> Result<()>,
    ) -> Result<()> {
        evaluator.evaluate_f32_staged(table, pattern, stage, sink)
    }
}

/// Samples a stage gets at most per thread of the pool ([`stage_samples`]): 384 KiB of
/// f32 positions and normals, so that a thread's share of a chunk and what a stage builds
/// of it (the stitcher: 28 bytes a sample) stay in a core's cache. (On the 1.1 M-triangle
/// bunny at level 8 on 2 cores, 2^14 a stage took 0.75 CPU s where 2^16 took 0.85.)
pub const STAGE_SAMPLES: usize = 1 << 14;

/// Samples a stage gets at most (whole patches of a grid, one at least), from
/// [`staged_chunks`] and from the CPU's f32 grid kernel: [`STAGE_SAMPLES`] for each thread
/// of the pool (64 at most), so that every thread has a share of each stage's parallel
/// steps. A stage's steps end in a join and the stages follow one another, so stages of
/// 2^14 samples on 16 threads left most of them waiting: on 16 Xeon cores, stitching the
/// 2 M-triangle ogre at level 8 into a counting sink (patches built and certified per
/// stage, as `tessellate` runs it) took 1.40–1.50 s with stages of 2^14 samples and
/// 0.68–0.73 s with 2^18 (level 4: 0.71–0.79 and 0.42–0.46 s).
pub(crate) fn stage_samples() -> usize {
    STAGE_SAMPLES * rayon::current_num_threads().clamp(1, 64)
}

/// The staged evaluation through a plain one: `evaluate` hands its chunks (of items of
/// `item_len` samples: a grid's patches, or points) to a sink that splits each into runs of
/// whole items of at most [`stage_samples`] samples (one item at least), runs `stage` on
/// run k + 1 on the thread pool while `sink` reads run k on the calling thread, each run
/// staged before the sink gets it. The default of [`Evaluator::evaluate_f32_staged`] and
/// [`Vector::evaluate_staged`].
pub fn staged_chunks<V: Sync>(
    item_len: usize,
    evaluate: impl FnOnce(&mut dyn FnMut(Chunk<'_, V>) -> Result<()>) -> Result<()>,
    stage: &mut (dyn FnMut(Chunk<'_, V>) + Send),
    sink: &mut dyn FnMut(Chunk<'_, V>) -> Result<()>,
) -> Result<()> {
    let item_len = item_len.max(1);
    let step = (stage_samples() / item_len).max(1);
    evaluate(&mut |c: Chunk<'_, V>| {
        let items = c.positions.len().div_ceil(item_len);
        // Item `start` is patch (grid) or point `c.first + start`.
        let run = |start: usize, len: usize| {
            let r = start * item_len..((start + len) * item_len).min(c.positions.len());
            Chunk {
                first: c.first + start,
                positions: &c.positions[r.clone()],
                // Whatever an evaluator hands over, no panic: the consumer checks lengths.
                normals: c.normals.get(r).unwrap_or(&[]),
            }
        };
        crate::pipelined::double_buffered(
            &mut (),
            &mut (),
            items,
            step,
            |start, len, _: &mut ()| stage(run(start, len)),
            |start, len, _: &()| sink(run(start, len)),
        )
    })
}

/// [`Evaluator::evaluate_f32`] through the f64 evaluation: each value rounded once (so
/// corners are the input rounded to f32, bit for bit, where the f64 corners are exact).
/// The default of `evaluate_f32`, and what a backend's own override falls back to for
/// patterns its native kernel does not cover.
pub fn evaluate_f32_via_f64(
    evaluator: &(impl Evaluator + ?Sized),
    table: &PatchTable,
    pattern: &Pattern,
    sink: &mut dyn FnMut(ChunkF32<'_>) -> Result<()>,
) -> Result<()> {
    let (mut pos, mut nrm) = (Vec::new(), Vec::new());
    evaluator.evaluate(table, pattern, &mut |c| {
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

/// Most evaluation points [`evaluate_edges_via_points`] expands at once (8 MiB of
/// [`PatchPoint`]s).
pub const EDGE_EXPAND_POINTS: usize = 1 << 18;

/// [`Evaluator::evaluate_edges`] through [`Pattern::Points`]: the points expanded
/// [`EDGE_EXPAND_POINTS`] at a time, each run evaluated by `evaluator.evaluate` and its
/// chunks renumbered in the whole pattern. The default of `evaluate_edges`.
pub fn evaluate_edges_via_points(
    evaluator: &(impl Evaluator + ?Sized),
    table: &PatchTable,
    edges: &EdgePairs,
    sink: &mut dyn FnMut(Chunk<'_>) -> Result<()>,
) -> Result<()> {
    edges.check(table.len())?;
    let total = edges.len();
    let mut points = Vec::with_capacity(EDGE_EXPAND_POINTS.min(total));
    let mut start = 0;
    while start < total {
        let end = (start + EDGE_EXPAND_POINTS).min(total);
        points.clear();
        edges.points_into(start..end, &mut points);
        let pattern = Pattern::Points(std::mem::take(&mut points));
        evaluator.evaluate(table, &pattern, &mut |c| {
            sink(Chunk {
                first: start + c.first,
                positions: c.positions,
                normals: c.normals,
            })
        })?;
        if let Pattern::Points(p) = pattern {
            points = p;
        }
        start = end;
    }
    Ok(())
}

/// What the continuity statistics need of one sample of an edge pattern (the sample on its
/// two patches, points `p0, p1` and unit normals `n0, n1`): `cos = n0 · n1` and
/// `gap2 = |p0 − p1|²`. `gap2` is always bitwise [`PairProducts::of`] (glam's
/// `length_squared`, unfused, in its order); `cos` is within `PAIR_COS_TOLERANCE` of
/// [`PairProducts::of`] (a backend may compute it from the unnormalised normals, see
/// [`Evaluator::evaluate_edge_products`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PairProducts {
    /// n0 · n1, the cosine of the angle between the two unit normals.
    pub cos: f64,
    /// |p0 − p1|², the squared gap between the two points.
    pub gap2: f64,
}

impl PairProducts {
    /// The products of one sample on its two patches.
    #[inline]
    pub fn of(p: [DVec3; 2], n: [DVec3; 2]) -> PairProducts {
        PairProducts {
            cos: n[0].dot(n[1]),
            gap2: (p[0] - p[1]).length_squared(),
        }
    }
}

#[cfg(test)]
/// How far [`Evaluator::evaluate_edge_products`] may put a sample's cos from
/// [`PairProducts::of`] on the same points: 32 u (u = 2⁻⁵³, 2⁻⁴⁸ ≈ 3.6e-15). The CPU's
/// quotient of the unnormalised cross products is within 18.5u + O(u²) of it (derivation
/// at the CPU's `products`), and a flat fallback normal, a unit vector to a few u, adds its
/// own rounding; 32u bounds both.
pub const PAIR_COS_TOLERANCE: f64 = 1.0 / (1u64 << 48) as f64;

/// A run of [`PairProducts`] of an edge pattern: `first` is the index of its first sample
/// (sample k is points 2k and 2k + 1 of [`EdgePairs::points`]).
pub struct PairChunk<'a> {
    /// Index of the run's first sample in the pattern.
    pub first: usize,
    /// The products of the run's samples, in order.
    pub pairs: &'a [PairProducts],
}

/// [`Evaluator::evaluate_edge_products`] through [`Evaluator::evaluate_edges`]: the
/// points' chunks checked to arrive in order, a sample split between two chunks joined.
/// The default of `evaluate_edge_products`.
pub fn edge_products_via_points(
    evaluator: &(impl Evaluator + ?Sized),
    table: &PatchTable,
    edges: &EdgePairs,
    sink: &mut dyn FnMut(PairChunk<'_>) -> Result<()>,
) -> Result<()> {
    let mut pending: Option<(DVec3, DVec3)> = None;
    let mut next = 0usize;
    let mut out = Vec::new();
    evaluator.evaluate_edges(table, edges, &mut |chunk| {
        let (mut pos, mut nrm) = (chunk.positions, chunk.normals);
        if chunk.first != next || pos.len() != nrm.len() {
            return Err(crate::Error::Invalid(format!(
                "evaluator delivered points from {} where {next} was due",
                chunk.first
            )));
        }
        next += pos.len();
        out.clear();
        if let (Some((p0, n0)), Some(&p1), Some(&n1)) = (pending, pos.first(), nrm.first()) {
            out.push(PairProducts::of([p0, p1], [n0, n1]));
            pending = None;
            (pos, nrm) = (&pos[1..], &nrm[1..]);
        }
        out.extend(
            pos.chunks_exact(2)
                .zip(nrm.chunks_exact(2))
                .map(|(p, n)| PairProducts::of([p[0], p[1]], [n[0], n[1]])),
        );
        if pos.len() % 2 == 1 {
            pending = Some((pos[pos.len() - 1], nrm[nrm.len() - 1]));
        }
        // With a sample pending from the last chunk, `out` starts with that sample.
        sink(PairChunk {
            first: chunk.first / 2,
            pairs: &out,
        })
    })?;
    if next != edges.len() || pending.is_some() {
        return Err(crate::Error::Invalid(format!(
            "evaluator returned {next} of {} edge points",
            edges.len()
        )));
    }
    Ok(())
}

/// A backend that evaluates positions and unit normals of a patch table.
pub trait Evaluator {
    /// Which backend and device, for reports ("cpu (2 threads)", the adapter's name, ...).
    fn describe(&self) -> String;

    /// The working precision when this evaluator runs on a GPU (its device can then
    /// tessellate in place, see `crate::gpu::tessellator`); `None` for the CPU, or a GPU
    /// backend that could not open (its evaluation then reports why).
    fn gpu_precision(&self) -> Option<Precision> {
        None
    }

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
        evaluate_f32_via_f64(self, table, pattern, sink)
    }

    /// [`Self::evaluate_f32`] with a stage between the evaluation and the sink: each chunk
    /// goes to `stage` (which prepares what the sink will read; the stitcher builds its
    /// patches' output there), then to `sink`, in order, stage k always before sink k and
    /// stage k + 1 possibly while the sink reads chunk k. The CPU's grid kernel runs the
    /// stage in the thread-pool job that evaluated the chunk, so the stage's own parallel
    /// work stays on the pool while the calling thread feeds the sink; the default splits
    /// the chunks of [`Self::evaluate_f32`] (`staged_chunks`).
    fn evaluate_f32_staged(
        &self,
        table: &PatchTable,
        pattern: &Pattern,
        stage: &mut (dyn FnMut(ChunkF32<'_>) + Send),
        sink: &mut dyn FnMut(ChunkF32<'_>) -> Result<()>,
    ) -> Result<()> {
        staged_chunks(
            pattern.item_len(),
            |s| self.evaluate_f32(table, pattern, s),
            stage,
            sink,
        )
    }

    /// Evaluates the edge pattern `edges` on `table` (f64), chunk by chunk in its point
    /// order: the same values as [`Pattern::Points`] of `EdgePairs::points`. The default
    /// expands the points a bounded run at a time (`EDGE_EXPAND_POINTS`) and evaluates
    /// those; the CPU backend evaluates the pattern directly.
    fn evaluate_edges(
        &self,
        table: &PatchTable,
        edges: &EdgePairs,
        sink: &mut dyn FnMut(Chunk<'_>) -> Result<()>,
    ) -> Result<()> {
        evaluate_edges_via_points(self, table, edges, sink)
    }

    /// The `PairProducts` of every sample of `edges` on `table`, chunk by chunk in
    /// sample order: those of the points [`Self::evaluate_edges`] gives, `gap2` bitwise
    /// `PairProducts::of` and `cos` within `PAIR_COS_TOLERANCE` of it. The default
    /// pairs those points (`edge_products_via_points`, bitwise `PairProducts::of`); the
    /// CPU backend computes each edge's products right after its points, while they are in
    /// cache, its cos from the cross products S_s × S_t without normalising them (one
    /// square root and one division per sample instead of two and six).
    fn evaluate_edge_products(
        &self,
        table: &PatchTable,
        edges: &EdgePairs,
        sink: &mut dyn FnMut(PairChunk<'_>) -> Result<()>,
    ) -> Result<()> {
        edge_products_via_points(self, table, edges, sink)
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
