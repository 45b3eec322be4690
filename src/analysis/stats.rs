//! Continuity statistics across shared edges (Table 1 protocol of
//! `docs/schemes.md`): 21 points per interior edge, cos of the two patches'
//! unit normals, and the position gap between them.
//!
//! Crease edges (the two triangles give an end vertex different normals, see
//! [`crate::mesh::creases`]) are meant to break the tangent plane: they are left out of the
//! cos statistics and reported on their own (`crease_edges`, `crease_max_gap`).
//!
//! Everything streams: the edges come from a compact [`EdgeIndex`] (or an [`Adjacency`]),
//! a chunk of edges at a time gets the patches of its triangles (built for the chunk by a
//! [`PatchBuilder`], or read from a whole [`PatchTable`]), its edge pattern ([`EdgePairs`]:
//! 12 bytes per edge), [`Evaluator::evaluate_edge_products`] calls (per sample the cos of
//! the two normals and the squared gap, 16 bytes), and those are folded into running
//! statistics. Memory beyond the mesh is the edge index (4 bytes per half-edge
//! and per vertex, 4 per triangle for the chunk's patch numbering) and one chunk. The statistics are accumulated in sample
//! order whatever the chunk size, so every chunking gives bitwise the same result.

use rayon::prelude::*;
use serde::Serialize;

#[cfg(test)]
use crate::eval::PatchPoint;
use crate::eval::{EdgePairs, EdgeSide, Evaluator, PairProducts};
use crate::mesh::adjacency::{EdgeCounts, EdgeIndex};
use crate::mesh::creases::{normal_key, use_normal};
use crate::mesh::{Adjacency, EdgeUse, LoadReport, Mesh};
use crate::patch::g1::any_split_normals;
use crate::patch::repair::RepairReport;
use crate::patch::validity::{count_range, PatchCounts};
use crate::patch::{PatchBuilder, PatchTable, Scheme, SchemeOptions};
use crate::{Error, Result};

/// Samples per edge, end points included (t = 0, 0.05, ..., 1).
pub const SAMPLES_PER_EDGE: u32 = 21;

/// Evaluation points per edge: each sample on both triangles.
const POINTS_PER_EDGE: usize = 2 * SAMPLES_PER_EDGE as usize;

/// Interior edges per chunk by default: about 2¹⁸ evaluation points (a few MB of points,
/// results and patches), large enough that per-chunk costs vanish.
pub const CHUNK_EDGES: usize = (1 << 18) / POINTS_PER_EDGE;

/// cos of the angle between the two patches' normals over all edge samples. Best values:
/// all 1 and std 0; a cos below 0 is a folded patch.
#[derive(Clone, Copy, Debug, Default, Serialize, PartialEq)]
pub struct CosStats {
    /// Smallest cos.
    pub min: f64,
    /// Largest cos.
    pub max: f64,
    /// Mean cos.
    pub mean: f64,
    /// Ordinary sample standard deviation (n − 1), as Table 1.
    pub std: f64,
}

/// Continuity of a surface across its interior edges.
#[derive(Clone, Copy, Debug, Default, Serialize, PartialEq)]
pub struct Continuity {
    /// Edge samples (each a pair of evaluations).
    pub samples: usize,
    /// cos statistics over the edge samples.
    pub cos: CosStats,
    /// Largest 1 − |cos|: 0 when the tangent plane is shared (G1), even where folded.
    pub max_one_minus_abs_cos: f64,
    /// Largest distance between the two patches' positions (0 = watertight).
    pub max_gap: f64,
    /// Samples with cos < 0 (folded patches).
    pub folded: usize,
    /// Interior edges that are creases (left out of everything above).
    pub crease_edges: usize,
    /// Edge samples on crease edges.
    pub crease_samples: usize,
    /// Largest distance between the two patches' positions on crease edges.
    pub crease_max_gap: f64,
}

/// An interior edge as the protocol walks it.
#[derive(Clone, Copy, Debug)]
struct Edge {
    /// End vertices, `v[0] < v[1]`.
    v: [u32; 2],
    uses: [EdgeUse; 2],
    /// The two triangles give an end vertex different normals.
    crease: bool,
}

impl Edge {
    /// The edge, its crease flag not yet computed ([`Edge::with_crease`]).
    fn new(v: [u32; 2], uses: [EdgeUse; 2]) -> Edge {
        Edge {
            v,
            uses,
            crease: false,
        }
    }

    /// Sets the crease flag (done for a chunk of edges in parallel: the corner normals are
    /// scattered reads).
    fn with_crease(&mut self, mesh: &Mesh) {
        let (v, uses) = (self.v, self.uses);
        self.crease = v.iter().any(|&x| {
            normal_key(use_normal(mesh, uses[0], x)) != normal_key(use_normal(mesh, uses[1], x))
        });
    }

    /// Its two uses as edge sides: the barycentric slots of e.v[0] (t = 0) and e.v[1]
    /// (t = 1) on the first and second triangle, which are patches `patch[0]` and
    /// `patch[1]` of the table evaluated.
    fn sides(&self, triangles: &[[u32; 3]], patch: [u32; 2]) -> [EdgeSide; 2] {
        std::array::from_fn(|j| {
            let u = self.uses[j];
            let k = u.local as usize;
            // Coordinate slots of the edge's ends v[0] and v[1] on this triangle.
            let (a, b) = if triangles[u.triangle as usize][k] == self.v[0] {
                (k, (k + 1) % 3)
            } else {
                ((k + 1) % 3, k)
            };
            EdgeSide {
                patch: patch[j],
                from: a as u8,
                to: b as u8,
            }
        })
    }
}

/// The interior edges of an adjacency (crease flags not set).
fn adjacency_edges(adjacency: &Adjacency) -> impl Iterator<Item = Edge> + '_ {
    adjacency
        .interior_edges()
        .map(move |e| Edge::new(e.v, [e.uses[0], e.uses[1]]))
}

/// The interior edges of an edge index (crease flags not set).
fn index_edges<'a>(index: &'a EdgeIndex<'a>) -> impl Iterator<Item = Edge> + 'a {
    index
        .edges()
        .filter(|e| e.is_interior())
        .map(move |e| Edge::new(e.v, [e.use_at(0), e.use_at(1)]))
}

#[cfg(test)]
/// The evaluation points of every interior edge: for each edge and each t, the point on the
/// first triangle then the same point on the second (patch = triangle index), as
/// [`edge_pairs`] lists them.
pub fn edge_points(mesh: &Mesh, adjacency: &Adjacency) -> Vec<PatchPoint> {
    edge_pairs(mesh, adjacency).points()
}

/// The edge pattern of every interior edge ([`SAMPLES_PER_EDGE`] samples each, patch =
/// triangle index), crease edges included.
pub fn edge_pairs(mesh: &Mesh, adjacency: &Adjacency) -> EdgePairs {
    EdgePairs {
        samples: SAMPLES_PER_EDGE,
        pairs: adjacency_edges(adjacency)
            .map(|e| e.sides(&mesh.triangles, e.uses.map(|u| u.triangle)))
            .collect(),
    }
}

/// Edge samples (pairs of evaluations) per block of the running statistics: 48 edges.
/// Blocks are numbered in sample order over the whole run, whatever the chunks, and folded
/// in parallel.
pub const BLOCK_PAIRS: usize = 48 * SAMPLES_PER_EDGE as usize;

/// Statistics of the samples of one block (or the first samples of it). The cos values are
/// summed with the block's first value subtracted (exact for nearby values, so the sums
/// keep the digits that matter); blocks are merged with Chan et al.'s pairwise update.
#[derive(Clone, Copy, Debug)]
pub struct Part {
    pub n: usize,
    pub shift: f64,
    pub s1: f64,
    pub s2: f64,
    pub min: f64,
    pub max: f64,
    pub worst_abs: f64,
    /// Largest squared gap (its square root is the largest gap, exactly).
    pub gap2: f64,
    pub folded: usize,
    pub crease_n: usize,
    pub crease_gap2: f64,
}

impl Part {
    /// An empty part (no samples); not a `Default`, since an empty part is no default.
    #[allow(clippy::new_without_default)]
    pub fn new() -> Part {
        Part {
            n: 0,
            shift: 0.0,
            s1: 0.0,
            s2: 0.0,
            min: f64::INFINITY,
            max: f64::NEG_INFINITY,
            worst_abs: 0.0,
            gap2: 0.0,
            folded: 0,
            crease_n: 0,
            crease_gap2: 0.0,
        }
    }

    #[inline]
    pub fn push(&mut self, s: PairProducts, crease: bool) {
        let gap2 = s.gap2;
        if crease {
            self.crease_n += 1;
            self.crease_gap2 = self.crease_gap2.max(gap2);
            return;
        }
        let c = s.cos;
        if self.n == 0 {
            self.shift = c;
        }
        let d = c - self.shift;
        self.n += 1;
        self.s1 += d;
        self.s2 += d * d;
        self.min = self.min.min(c);
        self.max = self.max.max(c);
        // As f64::max, more cheaply: neither running value is NaN or −0 (they start at +0
        // and only take values 1 − |c| and squared lengths, never −0), so a NaN or equal
        // new value leaves them as they are either way.
        let worst = 1.0 - c.abs();
        if worst > self.worst_abs {
            self.worst_abs = worst;
        }
        if gap2 > self.gap2 {
            self.gap2 = gap2;
        }
        self.folded += (c < 0.0) as usize;
    }

    /// The part of `samples`, none of them on a crease: bitwise that of pushing them in
    /// order ([`Part::push`]). The sums run in one chain in sample order as `push` adds
    /// them; the extremes and the fold count, which do not depend on the order, two
    /// samples at a time (SSE2). The largest 1 − |cos| is 1 − (smallest |cos|): 1 − x is
    /// monotone in x in floating point too, so that is the largest of the rounded values,
    /// and it is never −0. Only where the smallest or largest cos is a zero (+0 and −0
    /// compare equal, and `f64::min` may keep either) are they taken again in order.
    #[cfg(target_arch = "x86_64")]
    pub fn of(samples: &[PairProducts]) -> Part {
        // SAFETY: SSE2 is part of every x86_64 CPU.
        unsafe { Part::of_sse2(samples) }
    }

    /// [`Part::of`] in SSE2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "sse2")]
    fn of_sse2(samples: &[PairProducts]) -> Part {
        use std::arch::x86_64::*;
        let mut p = Part::new();
        let Some(first) = samples.first() else {
            return p;
        };
        let shift = first.cos;
        let (mut s1, mut s2) = (0.0, 0.0);
        // A NaN never replaces a running value, as in `push` (`f64::min` and `f64::max`
        // return the other operand, and `>` is false): minpd and maxpd return their second
        // operand, the running value, where either is NaN.
        let mut lo = _mm_set1_pd(f64::INFINITY);
        let mut hi = _mm_set1_pd(f64::NEG_INFINITY);
        let mut abs_lo = _mm_set1_pd(f64::INFINITY);
        let mut gap2 = _mm_setzero_pd();
        let mut folded = _mm_setzero_si128();
        let sign = _mm_set1_pd(-0.0);
        let mut pairs = samples.chunks_exact(2);
        for pair in &mut pairs {
            let (a, b) = (pair[0], pair[1]);
            let d = a.cos - shift;
            s1 += d;
            s2 += d * d;
            let d = b.cos - shift;
            s1 += d;
            s2 += d * d;
            let c = _mm_set_pd(b.cos, a.cos);
            lo = _mm_min_pd(c, lo);
            hi = _mm_max_pd(c, hi);
            abs_lo = _mm_min_pd(_mm_andnot_pd(sign, c), abs_lo);
            gap2 = _mm_max_pd(_mm_set_pd(b.gap2, a.gap2), gap2);
            // All ones (−1) in a lane whose cos is below 0.
            folded = _mm_sub_epi64(folded, _mm_castpd_si128(_mm_cmplt_pd(c, _mm_setzero_pd())));
        }
        let lanes = |v: __m128d| {
            let mut a = [0.0f64; 2];
            // SAFETY: stores two f64 into a two-element array.
            unsafe { _mm_storeu_pd(a.as_mut_ptr(), v) };
            a
        };
        let (mut lo, mut hi) = (lanes(lo), lanes(hi));
        let (mut abs_lo, mut gap2) = (lanes(abs_lo), lanes(gap2));
        let mut count = [0i64; 2];
        // SAFETY: stores two i64 into a two-element array.
        unsafe { _mm_storeu_si128(count.as_mut_ptr().cast(), folded) };
        let mut folded = (count[0] + count[1]) as usize;
        if let [s] = pairs.remainder() {
            let c = s.cos;
            let d = c - shift;
            s1 += d;
            s2 += d * d;
            // The same rules, on lane 0.
            if c < lo[0] {
                lo[0] = c;
            }
            if c > hi[0] {
                hi[0] = c;
            }
            if c.abs() < abs_lo[0] {
                abs_lo[0] = c.abs();
            }
            if s.gap2 > gap2[0] {
                gap2[0] = s.gap2;
            }
            folded += (c < 0.0) as usize;
        }
        p.n = samples.len();
        p.shift = shift;
        p.s1 = s1;
        p.s2 = s2;
        p.min = if lo[1] < lo[0] { lo[1] } else { lo[0] };
        p.max = if hi[1] > hi[0] { hi[1] } else { hi[0] };
        let worst = 1.0
            - if abs_lo[1] < abs_lo[0] {
                abs_lo[1]
            } else {
                abs_lo[0]
            };
        if worst > 0.0 {
            p.worst_abs = worst;
        }
        p.gap2 = if gap2[1] > gap2[0] { gap2[1] } else { gap2[0] };
        p.folded = folded;
        if p.min == 0.0 {
            p.min = samples.iter().fold(f64::INFINITY, |m, s| m.min(s.cos));
        }
        if p.max == 0.0 {
            p.max = samples.iter().fold(f64::NEG_INFINITY, |m, s| m.max(s.cos));
        }
        p
    }

    /// The part of `samples`, none of them on a crease, as [`Part::push`] makes it.
    #[cfg(not(target_arch = "x86_64"))]
    pub fn of(samples: &[PairProducts]) -> Part {
        let mut p = Part::new();
        for &s in samples {
            p.push(s, false);
        }
        p
    }
}

/// The statistics of every block so far, merged in order.
#[derive(Clone, Copy, Debug)]
struct Totals {
    n: usize,
    mean: f64,
    m2: f64,
    part: Part,
}

impl Totals {
    fn merge(&mut self, b: &Part) {
        let t = &mut self.part;
        t.min = t.min.min(b.min);
        t.max = t.max.max(b.max);
        t.worst_abs = t.worst_abs.max(b.worst_abs);
        t.gap2 = t.gap2.max(b.gap2);
        t.folded += b.folded;
        t.crease_n += b.crease_n;
        t.crease_gap2 = t.crease_gap2.max(b.crease_gap2);
        if b.n == 0 {
            return;
        }
        let nb = b.n as f64;
        let mean_b = b.shift + b.s1 / nb;
        let m2_b = (b.s2 - b.s1 * b.s1 / nb).max(0.0);
        if self.n == 0 {
            self.mean = mean_b;
            self.m2 = m2_b;
        } else {
            let na = self.n as f64;
            let total = na + nb;
            let delta = mean_b - self.mean;
            self.mean += delta * (nb / total);
            self.m2 += m2_b + delta * delta * (na * nb / total);
        }
        self.n += b.n;
    }
}

/// Folds edge samples, in order, into [`Totals`]: the open block continues across calls,
/// whole blocks are folded in parallel, so any split of the samples into calls gives
/// bitwise the same result.
struct Fold {
    totals: Totals,
    open: Part,
    /// Samples folded so far.
    pairs: usize,
}

impl Fold {
    fn new() -> Fold {
        Fold {
            totals: Totals {
                n: 0,
                mean: 0.0,
                m2: 0.0,
                part: Part::new(),
            },
            open: Part::new(),
            pairs: 0,
        }
    }

    /// Folds the products of `samples` (each sample on its two patches); `crease(i)` says
    /// whether sample i (counted over the whole run) lies on a crease edge (none without
    /// it).
    fn add<F: Fn(usize) -> bool + Sync>(&mut self, samples: &[PairProducts], crease: Option<&F>) {
        let crease_free = crease.is_none();
        let crease = |i: usize| crease.is_some_and(|f| f(i));
        let total = samples.len();
        let mut k = 0;
        // Finish the open block.
        let done = self.pairs % BLOCK_PAIRS;
        if done != 0 {
            let take = (BLOCK_PAIRS - done).min(total);
            for (q, &s) in samples[..take].iter().enumerate() {
                self.open.push(s, crease(self.pairs + q));
            }
            k = take;
            self.pairs += take;
            if self.pairs.is_multiple_of(BLOCK_PAIRS) {
                self.totals.merge(&self.open);
                self.open = Part::new();
            }
        }
        // Whole blocks, in parallel, merged in order.
        let crease = &crease;
        let full = (total - k) / BLOCK_PAIRS;
        if full > 0 {
            let first = self.pairs;
            let parts: Vec<Part> = (0..full)
                .into_par_iter()
                .map(|b| {
                    let block = k + b * BLOCK_PAIRS..k + (b + 1) * BLOCK_PAIRS;
                    if crease_free {
                        return Part::of(&samples[block]);
                    }
                    let mut part = Part::new();
                    for (q, &s) in block.clone().zip(&samples[block]) {
                        part.push(s, crease(first + q - k));
                    }
                    part
                })
                .collect();
            for part in &parts {
                self.totals.merge(part);
            }
            k += full * BLOCK_PAIRS;
            self.pairs += full * BLOCK_PAIRS;
        }
        // Open the next block.
        for &s in &samples[k..total] {
            self.open.push(s, crease(self.pairs));
            self.pairs += 1;
        }
    }

    fn finish(mut self, crease_edges: usize) -> Continuity {
        let open = self.open;
        self.totals.merge(&open);
        let Totals { n, mean, m2, part } = self.totals;
        let (min, max) = if n > 0 {
            (part.min, part.max)
        } else {
            (0.0, 0.0)
        };
        Continuity {
            samples: n,
            cos: CosStats {
                min,
                max,
                mean,
                std: if n > 1 {
                    (m2 / (n - 1) as f64).sqrt()
                } else {
                    0.0
                },
            },
            max_one_minus_abs_cos: part.worst_abs,
            max_gap: part.gap2.sqrt(),
            folded: part.folded,
            crease_edges,
            crease_samples: part.crease_n,
            crease_max_gap: part.crease_gap2.sqrt(),
        }
    }
}

/// Where the patches of a chunk come from.
#[derive(Clone, Copy)]
enum Patches<'a, 'm> {
    /// A whole table (patch i = triangle i).
    Table(&'a PatchTable),
    /// Built per chunk.
    Builder(&'a PatchBuilder<'m>),
}

/// Interior edges per evaluation call within a chunk: their samples' products (21 of 16
/// bytes per edge, about 0.7 MB) are folded while they are in cache.
const EVAL_EDGES: usize = 2048;

/// Slot of a triangle never built (in [`run`]'s per-triangle numbering).
const NEVER: u32 = u32::MAX;
/// Slot of a triangle built in an earlier chunk.
const BUILT: u32 = u32::MAX - 1;
/// Slots of a triangle of the current chunk before it is numbered: first build, or again.
const FRESH: u32 = u32::MAX - 2;
const AGAIN: u32 = u32::MAX - 3;
/// Slot of a triangle of the current chunk whose patch is copied from the previous chunk's
/// table, before it is numbered.
const COPY: u32 = u32::MAX - 4;

/// One chunk of edges made ready for evaluation: its edges (crease flags set), the patches
/// of their triangles (builder only) and its edge pattern.
struct Batch {
    edges: Vec<Edge>,
    pattern: EdgePairs,
    /// The chunk's table (builder only), its arrays reused chunk after chunk.
    table: PatchTable,
    /// Triangles of the chunk's table: first builds, then those built again.
    fresh: Vec<u32>,
    again: Vec<u32>,
    /// Triangles of the chunk whose patches are in the previous chunk's table, with their
    /// slot there: copied, not built again.
    copy: Vec<(u32, u32)>,
    /// Fallbacks of the first builds, and crease edges, of the chunk.
    fallbacks: usize,
    creases: usize,
    /// Validity verdicts of the first builds (builder only).
    verdicts: PatchCounts,
}

impl Batch {
    fn new(patches: Patches<'_, '_>, chunk_edges: usize) -> Batch {
        Batch {
            edges: Vec::with_capacity(chunk_edges.min(CHUNK_EDGES)),
            pattern: EdgePairs {
                samples: SAMPLES_PER_EDGE,
                pairs: Vec::with_capacity(chunk_edges.min(CHUNK_EDGES)),
            },
            table: match patches {
                Patches::Table(t) => PatchTable {
                    points: Vec::new(),
                    flat_normals: Vec::new(),
                    ..*t
                },
                Patches::Builder(b) => b.empty_table(),
            },
            fresh: Vec::new(),
            again: Vec::new(),
            copy: Vec::new(),
            fallbacks: 0,
            creases: 0,
            verdicts: PatchCounts::default(),
        }
    }

    /// Takes the next `chunk_edges` edges (none at the end) and prepares them. `done` are
    /// the triangles of the previous chunk's table `prev` (their slots still number them
    /// there: patches needed again are copied from it), marked built afterwards; `slot` is
    /// the per-triangle numbering of [`run`]. Without `split` (no vertex of the mesh has
    /// two normals, [`any_split_normals`]) no edge is a crease and none is looked at.
    #[allow(clippy::too_many_arguments)]
    fn prepare(
        &mut self,
        mesh: &Mesh,
        split: bool,
        edges: &mut (dyn Iterator<Item = Edge> + Send),
        patches: Patches<'_, '_>,
        slot: &mut [u32],
        done: &[u32],
        prev: &PatchTable,
        chunk_edges: usize,
    ) -> Result<()> {
        self.edges.clear();
        self.edges.extend(edges.take(chunk_edges));
        self.fresh.clear();
        self.again.clear();
        self.copy.clear();
        self.fallbacks = 0;
        self.verdicts = PatchCounts::default();
        if self.edges.is_empty() {
            for &t in done {
                slot[t as usize] = BUILT;
            }
            return Ok(());
        }
        if split {
            self.edges
                .par_iter_mut()
                .with_min_len(1024)
                .for_each(|e| e.with_crease(mesh));
        }
        self.creases = self.edges.iter().filter(|e| e.crease).count();
        if let Patches::Builder(b) = patches {
            for u in self.edges.iter().flat_map(|e| e.uses) {
                let s = &mut slot[u.triangle as usize];
                if *s == NEVER {
                    *s = FRESH;
                    self.fresh.push(u.triangle);
                } else if *s == BUILT {
                    *s = AGAIN;
                    self.again.push(u.triangle);
                } else if *s < COPY {
                    self.copy.push((u.triangle, *s));
                    *s = COPY;
                }
            }
            // The rest of the previous chunk's triangles are done with.
            for &t in done {
                let s = &mut slot[t as usize];
                if *s < COPY {
                    *s = BUILT;
                }
            }
            let counted = self.fresh.len();
            self.fresh.append(&mut self.again);
            for (i, &t) in self.fresh.iter().enumerate() {
                slot[t as usize] = i as u32;
            }
            b.table_of_into(&self.fresh, counted, &mut self.table)?;
            self.fallbacks = self.table.fallbacks;
            // Each triangle's patch is certified once, where it is first built.
            self.verdicts = count_range(&self.table, 0..counted);
            // Patches are built the same wherever they are built: copies are bitwise those.
            let stride = self.table.stride;
            for &(t, s) in &self.copy {
                let s = s as usize;
                slot[t as usize] = self.fresh.len() as u32;
                self.fresh.push(t);
                self.table
                    .points
                    .extend_from_slice(&prev.points[s * stride..(s + 1) * stride]);
                self.table.flat_normals.push(prev.flat_normals[s]);
            }
        }
        let triangles = &mesh.triangles;
        let slot: &[u32] = slot;
        self.pattern.pairs.clear();
        self.pattern.pairs.extend(self.edges.iter().map(|e| {
            let patch = e.uses.map(|u| match patches {
                Patches::Table(_) => u.triangle,
                Patches::Builder(_) => slot[u.triangle as usize],
            });
            e.sides(triangles, patch)
        }));
        Ok(())
    }

    /// Evaluates the prepared chunk and folds its samples into `fold`.
    fn evaluate(
        &self,
        patches: Patches<'_, '_>,
        evaluator: &dyn Evaluator,
        fold: &mut Fold,
    ) -> Result<()> {
        let table = match patches {
            Patches::Table(t) => t,
            Patches::Builder(_) => &self.table,
        };
        let batch = &self.edges;
        let first_pair = fold.pairs;
        let crease = |i: usize| {
            batch
                .get((i - first_pair) / SAMPLES_PER_EDGE as usize)
                .is_some_and(|e| e.crease)
        };
        // Without crease edges in the chunk no sample needs looking up.
        let creases = self.creases;
        // The chunk is evaluated a few edges at a time, so that the products are folded
        // while they are still in cache.
        let mut sub = EdgePairs {
            samples: SAMPLES_PER_EDGE,
            pairs: Vec::with_capacity(EVAL_EDGES.min(self.pattern.pairs.len())),
        };
        for pairs in self.pattern.pairs.chunks(EVAL_EDGES) {
            sub.pairs.clear();
            sub.pairs.extend_from_slice(pairs);
            let mut next = 0;
            evaluator.evaluate_edge_products(table, &sub, &mut |chunk| {
                if chunk.first != next {
                    return Err(Error::Invalid(format!(
                        "evaluator delivered samples from {} where {next} was due",
                        chunk.first
                    )));
                }
                next += chunk.pairs.len();
                if creases == 0 {
                    fold.add::<fn(usize) -> bool>(chunk.pairs, None);
                } else {
                    fold.add(chunk.pairs, Some(&crease));
                }
                Ok(())
            })?;
            if 2 * next != sub.len() {
                return Err(Error::Invalid(format!(
                    "evaluator returned {next} of {} edge samples",
                    sub.len() / 2
                )));
            }
        }
        let expected = batch.len() * SAMPLES_PER_EDGE as usize;
        if fold.pairs - first_pair != expected {
            return Err(Error::Invalid(format!(
                "evaluator returned {} of {expected} edge samples",
                fold.pairs - first_pair
            )));
        }
        Ok(())
    }
}

/// The protocol over `edges`, `chunk_edges` edges per evaluation: the continuity and the
/// fallbacks of the construction (each triangle counted once). The next chunk is prepared
/// (edges walked, patches built) while the current one is evaluated and folded; the
/// results are those of doing one after the other.
fn run(
    mesh: &Mesh,
    edges: &mut (dyn Iterator<Item = Edge> + Send),
    patches: Patches<'_, '_>,
    evaluator: &dyn Evaluator,
    chunk_edges: usize,
    split: Option<bool>,
) -> Result<(Continuity, usize, PatchCounts)> {
    let chunk_edges = chunk_edges.max(1);
    let triangles = &mesh.triangles;
    if triangles.len() >= AGAIN as usize {
        return Err(Error::mesh(
            &mesh.name,
            "too many triangles for the statistics",
        ));
    }
    let mut fold = Fold::new();
    let mut crease_edges = 0;
    // Per triangle: its patch in the chunk's table, or one of the marks above.
    let mut slot: Vec<u32> = match patches {
        Patches::Table(_) => Vec::new(),
        Patches::Builder(_) => vec![NEVER; triangles.len()],
    };
    let mut fallbacks = 0;
    let mut verdicts = PatchCounts::default();
    let mut current = Batch::new(patches, chunk_edges);
    let mut next = Batch::new(patches, chunk_edges);
    let empty = current.table.clone();
    let split = split.unwrap_or_else(|| any_split_normals(mesh));
    current.prepare(
        mesh,
        split,
        edges,
        patches,
        &mut slot,
        &[],
        &empty,
        chunk_edges,
    )?;
    while !current.edges.is_empty() {
        crease_edges += current.creases;
        fallbacks += current.fallbacks;
        verdicts = verdicts.merge(current.verdicts);
        let mut prepared = Ok(());
        let evaluated = rayon::in_place_scope(|s| {
            let (next, slot, done, prev) = (&mut next, &mut slot, &current.fresh, &current.table);
            let prepared = &mut prepared;
            let edges = &mut *edges;
            s.spawn(move |_| {
                *prepared =
                    next.prepare(mesh, split, edges, patches, slot, done, prev, chunk_edges);
            });
            current.evaluate(patches, evaluator, &mut fold)
        });
        evaluated?;
        prepared?;
        std::mem::swap(&mut current, &mut next);
    }
    match patches {
        Patches::Table(t) => fallbacks = t.fallbacks,
        Patches::Builder(b) => {
            // Triangles without interior edges were never built; their fallbacks count too.
            let never: Vec<u32> = (0..triangles.len() as u32)
                .filter(|&t| slot[t as usize] == NEVER)
                .collect();
            fallbacks += b.fallbacks_of(&never) + b.prepared_fallbacks();
            // Their patches are certified here, a bounded chunk at a time.
            let mut table = b.empty_table();
            for chunk in never.chunks(1 << 16) {
                b.table_of_into(chunk, 0, &mut table)?;
                verdicts = verdicts.merge(count_range(&table, 0..chunk.len()));
            }
        }
    }
    Ok((fold.finish(crease_edges), fallbacks, verdicts))
}

/// Continuity statistics of `table` over the interior edges of `mesh`, evaluated by
/// `evaluator`: cos and gap over the non-crease edges, the gap alone over crease edges.
/// Streams (edge points a chunk at a time); the table is the whole mesh's.
pub fn continuity(
    mesh: &Mesh,
    adjacency: &Adjacency,
    table: &PatchTable,
    evaluator: &dyn Evaluator,
) -> Result<Continuity> {
    if table.len() != mesh.triangles.len() {
        return Err(Error::mesh(
            &mesh.name,
            format!(
                "patch table of {} patches for {} triangles",
                table.len(),
                mesh.triangles.len()
            ),
        ));
    }
    let mut edges = adjacency_edges(adjacency);
    Ok(run(
        mesh,
        &mut edges,
        Patches::Table(table),
        evaluator,
        CHUNK_EDGES,
        None,
    )?
    .0)
}

/// The continuity protocol on one mesh, for any scheme, in bounded memory: the mesh's
/// compact edge index, and per chunk of edges only the patches of their triangles.
pub struct EdgeStats<'m> {
    mesh: &'m Mesh,
    index: EdgeIndex<'m>,
    /// Interior edges per chunk (default [`CHUNK_EDGES`]).
    pub chunk_edges: usize,
    /// Whether some vertex has split normals ([`any_split_normals`]), where known.
    split: Option<bool>,
}

impl<'m> EdgeStats<'m> {
    pub fn new(mesh: &'m Mesh) -> EdgeStats<'m> {
        EdgeStats {
            mesh,
            index: EdgeIndex::new(&mesh.triangles),
            chunk_edges: CHUNK_EDGES,
            split: None,
        }
    }

    /// The mesh's edge counts.
    pub fn counts(&self) -> EdgeCounts {
        self.index.counts
    }

    #[cfg(test)]
    /// The continuity of `builder`'s patches (built chunk by chunk) and the fallbacks of
    /// its whole construction (as [`PatchTable::fallbacks`] of the whole table).
    pub fn continuity(
        &self,
        builder: &PatchBuilder<'_>,
        evaluator: &dyn Evaluator,
    ) -> Result<(Continuity, usize)> {
        self.continuity_certified(builder, evaluator)
            .map(|(c, fallbacks, _)| (c, fallbacks))
    }

    /// [`EdgeStats::continuity`] and the validity verdicts of every patch
    /// ([`crate::patch::validity`]), each patch certified where the statistics build it
    /// first: the counts of [`crate::patch::validity::count_builder`] without building
    /// the patches a second time.
    pub fn continuity_certified(
        &self,
        builder: &PatchBuilder<'_>,
        evaluator: &dyn Evaluator,
    ) -> Result<(Continuity, usize, PatchCounts)> {
        if !std::ptr::eq(builder.mesh(), self.mesh) {
            return Err(Error::Invalid(
                "statistics: the patch builder belongs to another mesh".into(),
            ));
        }
        let mut edges = index_edges(&self.index);
        run(
            self.mesh,
            &mut edges,
            Patches::Builder(builder),
            evaluator,
            self.chunk_edges,
            self.split,
        )
    }

    /// The full report of `scheme`.
    pub fn report(
        &self,
        scheme: Scheme,
        opts: &SchemeOptions,
        evaluator: &dyn Evaluator,
    ) -> Result<StatsReport> {
        let builder = PatchBuilder::new(self.mesh, scheme, opts)?;
        let (c, fallbacks, patches) = self.continuity_certified(&builder, evaluator)?;
        let mut report = StatsReport::new(
            self.mesh,
            self.counts(),
            scheme,
            fallbacks,
            c,
            evaluator.describe(),
        );
        report.patches = patches;
        Ok(report)
    }
}

/// The statistics report of `scheme` on `mesh`, streamed in bounded memory: what
/// `g1tess stats` prints. The edge index and the search for split normals (both in
/// parallel) run while the scheme prepares its per-mesh data; patches are then built a
/// chunk of edges at a time. For the statistics of a repaired mesh, repair it first
/// ([`crate::patch::repair::repair`]) and set the report's `repair`.
pub fn stats_report(
    mesh: &Mesh,
    scheme: Scheme,
    opts: &SchemeOptions,
    evaluator: &dyn Evaluator,
) -> Result<StatsReport> {
    // The builder stays on this thread (it need not be `Send`); the index and the search
    // run on the pool meanwhile.
    let mut found = None;
    let builder = rayon::in_place_scope(|s| {
        let found = &mut found;
        s.spawn(move |_| *found = Some((EdgeIndex::new(&mesh.triangles), any_split_normals(mesh))));
        PatchBuilder::new(mesh, scheme, opts)
    });
    let builder = builder?;
    let Some((index, split)) = found else {
        return Err(Error::Invalid(
            "statistics: the edge index was not built".into(),
        ));
    };
    let stats = EdgeStats {
        mesh,
        index,
        chunk_edges: CHUNK_EDGES,
        split: Some(split),
    };
    let (c, fallbacks, patches) = stats.continuity_certified(&builder, evaluator)?;
    let mut report = StatsReport::new(
        mesh,
        stats.counts(),
        scheme,
        fallbacks,
        c,
        evaluator.describe(),
    );
    report.patches = patches;
    Ok(report)
}

/// Everything `g1tess stats --json` prints for one mesh and scheme. In JSON, the cos and
/// gap statistics are `null` where there is no sample (no non-crease interior edge).
#[derive(Clone, Debug, Serialize)]
#[serde(into = "StatsJson")]
pub struct StatsReport {
    /// The mesh's name (the file name or the built-in spec).
    pub mesh: String,
    /// The scheme's name.
    pub scheme: String,
    /// Triangles of the mesh.
    pub triangles: usize,
    /// Welded vertices (positions) of the mesh.
    pub vertices: usize,
    /// Edges used by exactly two triangles, creases included.
    pub interior_edges: usize,
    /// Interior edges that are creases: left out of samples, cos, max_gap and folded.
    pub crease_edges: usize,
    /// Edges used by one triangle.
    pub boundary_edges: usize,
    /// Edges used by three or more triangles.
    pub nonmanifold_edges: usize,
    /// Interior edges whose two triangles disagree in orientation.
    pub misoriented_edges: usize,
    /// Edge samples on non-crease interior edges (21 per edge, each a pair of evaluations).
    pub samples: usize,
    /// cos of the angle between the two patches' normals over the samples.
    pub cos: CosStats,
    /// Largest 1 − |cos|: 0 when the tangent plane is shared (G1), even where folded.
    pub max_one_minus_abs_cos: f64,
    /// Largest distance between the two patches' positions (0 = watertight).
    pub max_gap: f64,
    /// max_gap divided by the bounding-box diagonal.
    pub max_gap_relative: f64,
    /// Length of the mesh's bounding-box diagonal.
    pub diagonal: f64,
    /// Samples with cos < 0 (folded patches).
    pub folded: usize,
    /// Edge samples on crease edges.
    pub crease_samples: usize,
    /// Largest position gap between the two patches on crease edges.
    pub crease_max_gap: f64,
    /// Which evaluator ran, as its `describe` says ("cpu (2 threads)", the adapter's name, ...).
    pub backend: String,
    /// Edges where the construction took a documented fallback.
    pub fallbacks: usize,
    /// What loading the mesh changed or found.
    pub load: LoadReport,
    /// Verdicts of the patches' validity certificate (`crate::patch::validity`); all
    /// zero where not computed ([`StatsReport::new`]).
    pub patches: PatchCounts,
    /// What the fold repair changed, where it was asked for.
    pub repair: Option<RepairReport>,
}

/// [`StatsReport`] as JSON: the statistics of samples `null` where there are none.
#[derive(Serialize)]
struct StatsJson {
    mesh: String,
    scheme: String,
    triangles: usize,
    vertices: usize,
    interior_edges: usize,
    crease_edges: usize,
    boundary_edges: usize,
    nonmanifold_edges: usize,
    misoriented_edges: usize,
    samples: usize,
    cos: Option<CosStats>,
    max_one_minus_abs_cos: Option<f64>,
    max_gap: Option<f64>,
    max_gap_relative: Option<f64>,
    diagonal: f64,
    folded: usize,
    crease_samples: usize,
    crease_max_gap: f64,
    backend: String,
    fallbacks: usize,
    load: LoadReport,
    patches: PatchCounts,
    #[serde(skip_serializing_if = "Option::is_none")]
    repair: Option<RepairReport>,
}

impl From<StatsReport> for StatsJson {
    fn from(r: StatsReport) -> StatsJson {
        StatsJson {
            cos: (r.samples > 0).then_some(r.cos),
            max_one_minus_abs_cos: (r.samples > 0).then_some(r.max_one_minus_abs_cos),
            max_gap: (r.samples > 0).then_some(r.max_gap),
            max_gap_relative: (r.samples > 0).then_some(r.max_gap_relative),
            mesh: r.mesh,
            scheme: r.scheme,
            triangles: r.triangles,
            vertices: r.vertices,
            interior_edges: r.interior_edges,
            crease_edges: r.crease_edges,
            boundary_edges: r.boundary_edges,
            nonmanifold_edges: r.nonmanifold_edges,
            misoriented_edges: r.misoriented_edges,
            samples: r.samples,
            diagonal: r.diagonal,
            folded: r.folded,
            crease_samples: r.crease_samples,
            crease_max_gap: r.crease_max_gap,
            backend: r.backend,
            fallbacks: r.fallbacks,
            load: r.load,
            patches: r.patches,
            repair: r.repair,
        }
    }
}

impl StatsReport {
    /// The report of `mesh` and `scheme` from its edge counts, the fallbacks, the continuity
    /// `c` and the evaluator's description; no patch verdicts and no repair.
    pub fn new(
        mesh: &Mesh,
        counts: EdgeCounts,
        scheme: Scheme,
        fallbacks: usize,
        c: Continuity,
        backend: String,
    ) -> StatsReport {
        let diagonal = mesh.diagonal();
        StatsReport {
            mesh: mesh.name.clone(),
            scheme: scheme.to_string(),
            triangles: mesh.triangles.len(),
            vertices: mesh.positions.len(),
            interior_edges: counts.interior,
            crease_edges: c.crease_edges,
            boundary_edges: counts.boundary,
            nonmanifold_edges: counts.nonmanifold,
            misoriented_edges: counts.misoriented,
            samples: c.samples,
            cos: c.cos,
            max_one_minus_abs_cos: c.max_one_minus_abs_cos,
            max_gap: c.max_gap,
            max_gap_relative: if diagonal > 0.0 {
                c.max_gap / diagonal
            } else {
                0.0
            },
            diagonal,
            folded: c.folded,
            crease_samples: c.crease_samples,
            crease_max_gap: c.crease_max_gap,
            backend,
            fallbacks,
            load: mesh.load_report.clone(),
            patches: PatchCounts::default(),
            repair: None,
        }
    }

    /// Human-readable summary, several lines.
    pub fn to_text(&self) -> String {
        let continuity = if self.samples == 0 {
            "no interior edges (no cos or gap statistics)".to_string()
        } else {
            format!(
                "samples {} (21 per non-crease interior edge)\n\
                 cos  min {:.9}  max {:.9}  mean {:.9}  std {:.6e}\n\
                 max 1-|cos| {:.3e} · folded samples (cos < 0) {}\n\
                 max gap {:.3e} ({:.3e} × bbox diagonal)",
                self.samples,
                self.cos.min,
                self.cos.max,
                self.cos.mean,
                self.cos.std,
                self.max_one_minus_abs_cos,
                self.folded,
                self.max_gap,
                self.max_gap_relative,
            )
        };
        let mut out = format!(
            "mesh {} · scheme {} · backend {}\n\
             triangles {} · vertices {} · interior edges {} · boundary edges {} · non-manifold edges {} · misoriented edges {}\n\
             {continuity}{}\n\
             patches: {} certified valid · {} folded · {} undecided",
            self.mesh,
            self.scheme,
            self.backend,
            self.triangles,
            self.vertices,
            self.interior_edges,
            self.boundary_edges,
            self.nonmanifold_edges,
            self.misoriented_edges,
            if self.crease_edges > 0 {
                format!(
                    "\ncrease edges {} (left out of the above) · {} samples · max gap {:.3e}",
                    self.crease_edges, self.crease_samples, self.crease_max_gap
                )
            } else {
                String::new()
            },
            self.patches.valid,
            self.patches.folded,
            self.patches.undecided,
        );
        if let Some(r) = &self.repair {
            out.push_str(&format!(
                "\nfold repair: {} vertices touched ({} corners), largest normal change \
                 {:.3}°, {} edges made creases, surface moved at most {:.3e}; before {} \
                 folded, {} undecided",
                r.vertices_touched,
                r.corners_changed,
                r.max_normal_change_deg,
                r.edges_made_creases,
                r.max_distance,
                r.before.folded,
                r.before.undecided
            ));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::{Part, BLOCK_PAIRS};
    use crate::eval::PairProducts;
    use crate::mesh::creases::normal_key;
    use crate::patch::g1::any_split_normals;
    use crate::LoadOptions;
    use crate::Mesh;

    /// The serial search [`any_split_normals`] replaced: each vertex's first corner in
    /// triangle order is its representative.
    fn serial_split_normals(mesh: &Mesh) -> bool {
        let mut first = vec![u32::MAX; mesh.positions.len()];
        for (t, (tri, normals)) in mesh.triangles.iter().zip(&mesh.corner_normals).enumerate() {
            for k in 0..3 {
                let f = &mut first[tri[k] as usize];
                if *f == u32::MAX {
                    *f = (3 * t + k) as u32;
                    continue;
                }
                let (ft, fk) = (*f as usize / 3, *f as usize % 3);
                if normal_key(mesh.corner_normals[ft][fk]) != normal_key(normals[k]) {
                    return true;
                }
            }
        }
        false
    }

    #[test]
    fn block_parts_are_those_of_pushing_in_order() {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        let special = [0.0, -0.0, f64::NAN, -1.0, 1.0, 1.0000000000000004, -0.5];
        let bits = |p: &Part| {
            (
                [p.n, p.folded, p.crease_n],
                [
                    p.shift,
                    p.s1,
                    p.s2,
                    p.min,
                    p.max,
                    p.worst_abs,
                    p.gap2,
                    p.crease_gap2,
                ]
                .map(f64::to_bits),
            )
        };
        for len in [0, 1, 2, 3, 17, BLOCK_PAIRS] {
            for mix in 0..6 {
                let samples: Vec<PairProducts> = (0..len)
                    .map(|_| {
                        let r = next();
                        let u = (r >> 11) as f64 / (1u64 << 53) as f64;
                        let pick = special[(r % 7) as usize];
                        let cos = match mix {
                            // Near 1 (a smooth surface), then anywhere in [−1, 1].
                            0 => 1.0 - 1e-6 * u,
                            1 => 2.0 * u - 1.0,
                            // Special values among ordinary ones, then only those.
                            2 if r % 5 == 0 => pick,
                            2 => 2.0 * u - 1.0,
                            3 => pick,
                            // Zeros of both signs only (the order-dependent extremes).
                            4 => special[(r % 2) as usize],
                            _ => f64::NAN,
                        };
                        let gap2 = if mix == 3 && r % 3 == 0 {
                            f64::NAN
                        } else {
                            u * 1e-30
                        };
                        PairProducts { cos, gap2 }
                    })
                    .collect();
                let mut pushed = Part::new();
                for &s in &samples {
                    pushed.push(s, false);
                }
                assert_eq!(
                    bits(&Part::of(&samples)),
                    bits(&pushed),
                    "{len} samples, mix {mix}"
                );
            }
        }
    }

    #[test]
    fn parallel_split_search_agrees_with_the_serial_one() {
        let mut seen = [false; 2];
        for name in ["fandisk.obj", "suzanne.obj", "spot.obj"] {
            for crease in [None, Some(30.0)] {
                let opts = LoadOptions::default()
                    .with_recompute_normals(crease.is_some())
                    .with_crease_angle(crease);
                let path = format!("{}/tests/data/{name}", env!("CARGO_MANIFEST_DIR"));
                let mut mesh = Mesh::load(&path, &opts).unwrap();
                for round in 0..2 {
                    let expect = serial_split_normals(&mesh);
                    seen[expect as usize] = true;
                    for threads in [1, 2, 3] {
                        let pool = rayon::ThreadPoolBuilder::new()
                            .num_threads(threads)
                            .build()
                            .unwrap();
                        let got = pool.install(|| any_split_normals(&mesh));
                        assert_eq!(got, expect, "{name} {crease:?} round {round}");
                    }
                    // One corner normal of the last triangle turned a little: a split there.
                    let last = mesh.corner_normals.last_mut().unwrap();
                    last[2] = (last[2] + glam::DVec3::new(0.0, 1e-3, 0.0)).normalize();
                }
            }
        }
        assert_eq!(seen, [true, true]);
    }
}
