//! The stitcher: evaluated samples in, each patch's output out, to the sink in patch order
//! (the numbering is the parent's [`StitchPlan`]).
//!
//! Samples arrive a run of whole patches at a time, and each run is *staged*, then
//! *drained*:
//! - the stage ([`Stager::stage`]) writes the samples the run's patches own (first uses of
//!   vertices and edges, whose slots follow one another in patch order) into the store of
//!   shared samples, then builds every patch's output, reading the samples the patches
//!   share from the store; both steps run in parallel (rayon);
//! - the drain ([`Drainer::drain`]) hands the run's patches to the sink, in order, on the
//!   calling thread.
//!
//! A uniform plan is evaluated through [`Vector::evaluate_staged`]: the CPU's f32 kernel
//! stages each chunk in the thread-pool job that evaluated it, while the calling thread
//! drains the chunk before it into the sink, so the pool is handed work once a chunk (of
//! up to `stage_samples()` samples) rather than once per few patches. Runs of a non-uniform
//! plan ([`Stitcher::push_patches`]) are staged and drained the same way.

use std::sync::{Mutex, PoisonError};

use rayon::prelude::*;

use super::{
    interpolate, LocalScratch, Needs, PatchOut, RecordAttributes, StitchPlan, StitchSink,
    VertexRecord, NEW_REC, NONE, OWNS, REV,
};
use crate::eval::cpu::{CpuEvaluator, GridWeightsF32};
use crate::eval::{grid_len, grid_triangles, stage_samples, Chunk, Evaluator, Pattern, Vector};
use crate::mesh::CornerAttributes;
use crate::patch::{PatchBuilder, PatchTable};
use crate::progress::Progress;
use crate::{Error, Result};

/// One patch's output, built in parallel, handed to the sink in order. `records` and
/// `new_positions` keep the length of the patch's samples (a patch never has more), filled
/// up to `nrec` and `npos`, so nothing is cleared or reallocated between patches of one
/// size.
struct PatchBuf<V> {
    new_positions: Vec<V>,
    npos: usize,
    records: Vec<VertexRecord<V>>,
    nrec: usize,
    triangles: Vec<[u32; 3]>,
    position_triangles: Vec<[u32; 3]>,
    grid_positions: Vec<V>,
    local_rec: Vec<u32>,
    local_pos: Vec<u32>,
    /// A non-uniform patch's own triangles (sample indices) and local map.
    local_triangles: Vec<[u32; 3]>,
    scratch: LocalScratch,
    snap: f64,
    /// Attributes of the new records; a non-uniform patch's barycentric coordinates.
    attributes: Vec<RecordAttributes>,
    bary: Vec<[f64; 3]>,
}

impl<V> Default for PatchBuf<V> {
    fn default() -> Self {
        PatchBuf {
            new_positions: Vec::new(),
            npos: 0,
            records: Vec::new(),
            nrec: 0,
            triangles: Vec::new(),
            position_triangles: Vec::new(),
            grid_positions: Vec::new(),
            local_rec: Vec::new(),
            local_pos: Vec::new(),
            local_triangles: Vec::new(),
            scratch: LocalScratch::default(),
            snap: 0.0,
            attributes: Vec::new(),
            bary: Vec::new(),
        }
    }
}

/// The outputs of one staged run of whole patches.
struct Run<V> {
    /// The run's first patch and its number of patches.
    first: usize,
    count: usize,
    bufs: Vec<PatchBuf<V>>,
    /// Why the stage refused the run's samples (the drain returns it).
    error: Option<Error>,
}

/// What the stages and the drains share: the two runs (stage k builds run k mod 2, which
/// drain k reads; stage k + 1 builds the other meanwhile), and the per-level tables.
struct Shared<V> {
    runs: [Mutex<Run<V>>; 2],
    /// The grid's triangles (uniform plans).
    grid: Vec<[u32; 3]>,
    /// Barycentric coordinates of the grid (uniform plans with attributes).
    grid_bary: Vec<[f64; 3]>,
}

impl<V> Shared<V> {
    /// Run `k` mod 2, locked (a stage and a drain never want the same one at once; a
    /// panic in one propagates, so a poisoned lock is taken as it is).
    fn run(&self, k: usize) -> std::sync::MutexGuard<'_, Run<V>> {
        self.runs[k % 2]
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
    }
}

/// The stages' side: the store of shared samples and the patches staged so far.
struct Stager<'a, V> {
    plan: &'a StitchPlan,
    needs: Needs,
    /// The samples of the corner items (vertices), then of the blocks (edges), each
    /// written by the use that owns it, in the order the plan numbers them (by first
    /// use): slot `corner_slot` and `block_slot`. Both are the plan's length from the
    /// start (NaN where nothing is written yet).
    corners: Vec<V>,
    blocks: Vec<V>,
    /// How many of `corners` and of `blocks` are written: the owners staged so far.
    stored: (usize, usize),
    /// Patches staged.
    next: usize,
    /// Stages run.
    calls: usize,
    /// Where each patch of the run being staged starts in its samples, and the end.
    offsets: Vec<usize>,
}

/// The drains' side.
struct Drainer {
    /// Patches handed to the sink.
    next: usize,
    /// Drains run.
    calls: usize,
    /// Largest distance between a patch's own evaluation of a shared point and the shared
    /// position it was mapped onto (0 for the owner; rounding for a surface whose patches
    /// meet; the size of the crack otherwise).
    max_snap: f64,
}

/// Turns evaluated samples into stitched output, patch by patch (see the module).
pub(super) struct Stitcher<'a, V> {
    stager: Stager<'a, V>,
    drainer: Drainer,
    shared: Shared<V>,
}

impl<'a, V: Vector> Stitcher<'a, V> {
    /// A stitcher of `plan` for a sink that reads `needs`.
    pub fn new(plan: &'a StitchPlan, needs: Needs) -> Stitcher<'a, V> {
        let run = || {
            Mutex::new(Run {
                first: 0,
                count: 0,
                bufs: Vec::new(),
                error: None,
            })
        };
        Stitcher {
            stager: Stager {
                plan,
                needs,
                // Filled on the pool, which maps their pages in (the stages write them
                // in parallel).
                corners: crate::par::filled_with(plan.corner_items, || V::NAN),
                blocks: crate::par::filled_with(plan.block_store_len(), || V::NAN),
                stored: (0, 0),
                next: 0,
                calls: 0,
                offsets: Vec::new(),
            },
            drainer: Drainer {
                next: 0,
                calls: 0,
                max_snap: 0.0,
            },
            shared: Shared {
                runs: [run(), run()],
                grid: if plan.is_uniform() {
                    grid_triangles(plan.level)
                } else {
                    Vec::new()
                },
                grid_bary: if plan.is_uniform() && plan.has_attributes() {
                    crate::eval::grid_barycentrics(plan.level)
                } else {
                    Vec::new()
                },
            },
        }
    }

    /// All patches handed to the sink.
    pub fn is_complete(&self) -> bool {
        self.drainer.next == self.stager.plan.patches()
    }

    /// The largest snap distance so far (see [`Drainer::max_snap`]).
    pub fn max_snap(&self) -> f64 {
        self.drainer.max_snap
    }

    /// Evaluates `table` on the grid of the (uniform) plan's level with `evaluator` and
    /// stitches every chunk into `sink` (`progress` advanced chunk by chunk).
    pub fn run_grid(
        &mut self,
        evaluator: &dyn Evaluator,
        table: &PatchTable,
        sink: &mut dyn StitchSink<V>,
        progress: &dyn Progress,
    ) -> Result<()> {
        let pattern = Pattern::Grid {
            level: self.stager.plan.level,
        };
        self.run_staged(sink, progress, |stage, drain| {
            V::evaluate_staged(evaluator, table, &pattern, stage, drain)
        })
    }

    /// Runs `evaluate` with the stitcher's two steps: the stage of each chunk (on the
    /// thread pool, where the chunk was evaluated) and the drain of each chunk into `sink`
    /// (advancing `progress`), in order.
    fn run_staged(
        &mut self,
        sink: &mut dyn StitchSink<V>,
        progress: &dyn Progress,
        evaluate: impl FnOnce(
            &mut (dyn FnMut(Chunk<'_, V>) + Send),
            &mut dyn FnMut(Chunk<'_, V>) -> Result<()>,
        ) -> Result<()>,
    ) -> Result<()> {
        let Stitcher {
            stager,
            drainer,
            shared,
        } = self;
        let plan = stager.plan;
        evaluate(
            &mut |c: Chunk<'_, V>| stager.stage(c.first, c.positions, c.normals, shared),
            &mut |c: Chunk<'_, V>| {
                let n = drainer.drain(c.first, plan, shared, sink)?;
                progress.inc(n as u64);
                Ok(())
            },
        )
    }
}

impl Stitcher<'_, [f32; 3]> {
    /// [`Self::run_grid`] with the CPU's f32 kernel on patches `builder` builds a chunk at
    /// a time (`CpuEvaluator::grid_f32_built`; `seen` takes each chunk's table).
    pub fn run_grid_built(
        &mut self,
        cpu: &CpuEvaluator,
        builder: &PatchBuilder<'_>,
        seen: &mut (dyn FnMut(usize, &PatchTable) + Send),
        sink: &mut dyn StitchSink<[f32; 3]>,
        progress: &dyn Progress,
    ) -> Result<()> {
        let weights = GridWeightsF32::new(builder.kind(), self.stager.plan.level);
        self.run_staged(sink, progress, |stage, drain| {
            cpu.grid_f32_built(builder, &weights, seen, stage, drain)
        })
    }
}

impl<'a, V: Vector> Stitcher<'a, V> {
    /// Stitches the samples of whole patches, from patch `first` on (the next one), each
    /// in its sample order ([`StitchPlan::patch_points`]): what a [`Pattern::Points`]
    /// evaluation of those points gives. Runs of about `stage_samples()` samples are staged
    /// on the thread pool while the sink takes the run before.
    pub fn push_patches(
        &mut self,
        first: usize,
        positions: &[V],
        normals: &[V],
        sink: &mut dyn StitchSink<V>,
    ) -> Result<()> {
        let Stitcher {
            stager,
            drainer,
            shared,
        } = self;
        let plan = stager.plan;
        // Where each run starts (patch, sample): whole patches, up to `most` samples
        // (one patch at least). The last run ends where the samples do: a length that is
        // not whole patches is its stage's error.
        let most = stage_samples();
        let mut cuts = vec![(first, 0)];
        let (mut p, mut end, mut run) = (first, 0, 0);
        while end < positions.len() && p < plan.patches() {
            let len = plan.patch_len(p);
            if run > 0 && run + len > most {
                cuts.push((p, end));
                run = 0;
            }
            (p, end, run) = (p + 1, end + len, run + len);
        }
        let at = |k: usize| {
            let (p0, s0) = cuts[k];
            (p0, s0..cuts.get(k + 1).map_or(positions.len(), |c| c.1))
        };
        crate::pipelined::double_buffered(
            &mut (),
            &mut (),
            cuts.len(),
            1,
            |k, _, _: &mut ()| {
                let (p0, r) = at(k);
                let nrm = normals.get(r.clone()).unwrap_or(&[]);
                stager.stage(p0, &positions[r], nrm, shared)
            },
            |k, _, _: &()| drainer.drain(at(k).0, plan, shared, sink).map(|_| ()),
        )
    }
}

impl<V: Vector> Stager<'_, V> {
    /// Stages the samples of whole patches from patch `first` (the next one): the owners'
    /// samples into the store, then every patch's output, built in parallel into the next
    /// run. Samples that do not continue the staged patches leave the error in the run.
    fn stage(&mut self, first: usize, positions: &[V], normals: &[V], shared: &Shared<V>) {
        let mut run = shared.run(self.calls);
        self.calls += 1;
        run.first = first;
        run.count = 0;
        run.error = self.offsets_of(first, positions.len(), normals.len()).err();
        if run.error.is_some() {
            return;
        }
        let count = self.offsets.len() - 1;
        let offsets = std::mem::take(&mut self.offsets);
        let at = |j: usize| offsets[j]..offsets[j + 1];
        self.store_owned(first, count, positions, &offsets);
        if run.bufs.len() < count {
            run.bufs.resize_with(count, PatchBuf::default);
        }
        let Stager {
            plan,
            needs,
            corners,
            blocks,
            ..
        } = &*self;
        let store = Store { corners, blocks };
        // About 1024 samples a job: rayon's splitting costs little beside them.
        let min_len = (1024 / (positions.len() / count.max(1)).max(1)).max(1);
        run.bufs[..count]
            .par_iter_mut()
            .enumerate()
            .with_min_len(min_len)
            .for_each(|(j, buf)| {
                let p = first + j;
                let (pos, nrm) = (&positions[at(j)], &normals[at(j)]);
                build_patch(plan, &store, &shared.grid, p, pos, nrm, *needs, buf);
                if let Some(attrs) = &plan.attrs {
                    build_attributes(plan, attrs, &shared.grid_bary, p, buf);
                }
            });
        run.count = count;
        self.offsets = offsets;
        self.next += count;
    }

    /// Where the patches from `first` start in samples of `len` positions and `normals`
    /// normals (into `offsets`), or why these are not whole patches continuing the staged
    /// ones.
    fn offsets_of(&mut self, first: usize, len: usize, normals: usize) -> Result<()> {
        let plan = self.plan;
        self.offsets.clear();
        self.offsets.push(0);
        if plan.is_uniform() {
            let per = grid_len(plan.level);
            if first != self.next
                || !len.is_multiple_of(per)
                || normals != len
                || first + len / per > plan.patches()
            {
                return Err(Error::Invalid(format!(
                    "stitching: chunk at patch {first} with {len} samples does not continue patch {} of {} (grid of {per})",
                    self.next,
                    plan.patches(),
                )));
            }
            self.offsets.extend((1..=len / per).map(|j| j * per));
            return Ok(());
        }
        let (mut p, mut end) = (first, 0);
        while end < len && p < plan.patches() {
            end += plan.patch_len(p);
            self.offsets.push(end);
            p += 1;
        }
        if first != self.next || end != len || normals != len {
            return Err(Error::Invalid(format!(
                "stitching: {len} samples from patch {first} are not whole patches continuing patch {} of {}",
                self.next,
                plan.patches()
            )));
        }
        Ok(())
    }

    /// Writes the samples that patches `first..first + count` own (their first uses of
    /// vertices and edges; patch j's samples at `offsets[j]..offsets[j + 1]` of
    /// `positions`) into the store, in parallel. Slots are numbered by first use, so the
    /// owners' slots follow one another in patch order: each group of patches counts what
    /// it owns, and writes into its own stretch of the store from there.
    fn store_owned(&mut self, first: usize, count: usize, positions: &[V], offsets: &[usize]) {
        let plan = self.plan;
        // About 4096 samples a group: a job that costs more than rayon's hand-over.
        let group = (4096 * count / positions.len().max(1)).max(1);
        let groups: Vec<std::ops::Range<usize>> = (0..count)
            .step_by(group)
            .map(|j| j..(j + group).min(count))
            .collect();
        // What each group owns: corner samples, block samples (an edge's samples).
        let owned: Vec<(usize, usize)> = groups
            .par_iter()
            .map(|r| {
                let mut n = (0, 0);
                for i in 3 * (first + r.start)..3 * (first + r.end) {
                    n.0 += usize::from(plan.corner_flags[i] & OWNS != 0);
                    if plan.use_flags[i] & OWNS != 0 {
                        n.1 += plan.edge_samples(plan.use_edge[i] as usize) as usize;
                    }
                }
                n
            })
            .collect();
        // Each group's stretches of the two stores.
        let (mut corners, mut blocks) = (
            &mut self.corners[self.stored.0..],
            &mut self.blocks[self.stored.1..],
        );
        let mut jobs = Vec::with_capacity(groups.len());
        let mut at = self.stored;
        for (r, &(nc, nb)) in groups.into_iter().zip(&owned) {
            let (c, c_rest) = std::mem::take(&mut corners).split_at_mut(nc);
            let (b, b_rest) = std::mem::take(&mut blocks).split_at_mut(nb);
            (corners, blocks) = (c_rest, b_rest);
            jobs.push((r, c, b, at));
            at = (at.0 + nc, at.1 + nb);
        }
        self.stored = at;
        jobs.into_par_iter()
            .for_each_init(LocalScratch::default, |scratch, (r, c, b, stored)| {
                let (mut nc, mut nb) = (0, 0);
                for j in r {
                    let (p, pos) = (first + j, &positions[offsets[j]..offsets[j + 1]]);
                    let map = plan.local_map(p, scratch);
                    for k in 0..3 {
                        let i = 3 * p + k;
                        if plan.corner_flags[i] & OWNS != 0 {
                            debug_assert_eq!(plan.corner_slot[i] as usize, stored.0 + nc);
                            c[nc] = pos[map.corner[k] as usize];
                            nc += 1;
                        }
                    }
                    for k in 0..3 {
                        let u = 3 * p + k;
                        let flags = plan.use_flags[u];
                        if flags & OWNS != 0 {
                            debug_assert_eq!(plan.block_slot(plan.use_block[u]), stored.1 + nb);
                            let eg = map.edges[k];
                            let out = &mut b[nb..nb + eg.len()];
                            // Canonical sample m (1..n) lies at step n − m on a reversed use.
                            if flags & REV != 0 {
                                for (o, &g) in out.iter_mut().zip(eg.iter().rev()) {
                                    *o = pos[g as usize];
                                }
                            } else {
                                for (o, &g) in out.iter_mut().zip(eg) {
                                    *o = pos[g as usize];
                                }
                            }
                            nb += eg.len();
                        }
                    }
                }
                debug_assert_eq!((nc, nb), (c.len(), b.len()));
            });
    }
}

impl Drainer {
    /// Hands the patches of the next staged run (from patch `first`) to `sink`, in order;
    /// returns their number, or the stage's error, or the sink's.
    fn drain<V: Vector>(
        &mut self,
        first: usize,
        plan: &StitchPlan,
        shared: &Shared<V>,
        sink: &mut dyn StitchSink<V>,
    ) -> Result<usize> {
        let mut run = shared.run(self.calls);
        self.calls += 1;
        if let Some(e) = run.error.take() {
            return Err(e);
        }
        if run.first != first || first != self.next {
            return Err(Error::Invalid(format!(
                "stitching: patches from {first} handed over where patch {} was due",
                self.next
            )));
        }
        for (j, buf) in run.bufs[..run.count].iter().enumerate() {
            self.max_snap = self.max_snap.max(buf.snap);
            sink.patch(&PatchOut {
                patch: first + j,
                new_positions: &buf.new_positions[..buf.npos],
                new_records: &buf.records[..buf.nrec],
                new_attributes: if plan.attrs.is_some() {
                    &buf.attributes
                } else {
                    &[]
                },
                triangles: &buf.triangles,
                position_triangles: &buf.position_triangles,
                grid_positions: &buf.grid_positions,
                grid_triangles: if plan.is_uniform() {
                    &shared.grid
                } else {
                    &buf.local_triangles
                },
            })?;
        }
        self.next += run.count;
        Ok(run.count)
    }
}

/// The store of shared samples, as the builds read it.
struct Store<'s, V> {
    corners: &'s [V],
    blocks: &'s [V],
}

/// Builds patch `p`'s output into `buf`: its samples `pos` and normals `nrm`, the samples
/// it shares from `store` (where another patch owns them).
#[allow(clippy::too_many_arguments)]
fn build_patch<V: Vector>(
    plan: &StitchPlan,
    store: &Store<'_, V>,
    grid: &[[u32; 3]],
    p: usize,
    pos: &[V],
    nrm: &[V],
    needs: Needs,
    buf: &mut PatchBuf<V>,
) {
    let per = pos.len();
    if buf.records.len() != per {
        let blank = VertexRecord {
            position: V::NAN,
            normal: V::NAN,
            position_id: NONE,
        };
        buf.records.clear();
        buf.records.resize(per, blank);
    }
    if needs.positions && buf.new_positions.len() != per {
        buf.new_positions.clear();
        buf.new_positions.resize(per, V::NAN);
    }
    buf.grid_positions.clear();
    if needs.grid_positions {
        buf.grid_positions.extend_from_slice(pos);
    }
    let (mut nrec, mut npos) = (0, 0);
    let records = &mut buf.records[..];
    let new_positions = &mut buf.new_positions[..];
    let grid_positions = &mut buf.grid_positions[..];
    let map = plan.local_map(p, &mut buf.scratch);
    // Largest squared snap distance.
    let mut snap2 = 0f64;
    // Sample g (position id `pid`) maps onto the shared sample q.
    let mut visit = |g: usize, q: V, pid: u32, owner: bool, new_rec: bool| {
        if owner {
            if needs.positions {
                new_positions[npos] = q;
                npos += 1;
            }
        } else {
            snap2 = snap2.max(pos[g].to_dvec3().distance_squared(q.to_dvec3()));
        }
        if needs.grid_positions {
            grid_positions[g] = q;
        }
        if new_rec {
            // Field by field, as the interior's below.
            let r = &mut records[nrec];
            r.position = q;
            r.normal = nrm[g];
            r.position_id = pid;
            nrec += 1;
        }
    };
    for k in 0..3 {
        let c = 3 * p + k;
        let flags = plan.corner_flags[c];
        let g = map.corner[k] as usize;
        let owner = flags & OWNS != 0;
        // The owner's own sample is the one it stored.
        let q = if owner {
            pos[g]
        } else {
            store.corners[plan.corner_slot[c] as usize]
        };
        visit(g, q, plan.corner_pos[c], owner, flags & NEW_REC != 0);
    }
    for k in 0..3 {
        let u = 3 * p + k;
        let flags = plan.use_flags[u];
        let (owner, new_rec) = (flags & OWNS != 0, flags & NEW_REC != 0);
        let eg = map.edges[k];
        let pid0 = plan.use_pos[u];
        // Canonical sample m (1..n) lies at step n − m on a reversed use.
        let steps = |m: usize| {
            if flags & REV != 0 {
                eg[eg.len() - 1 - m] as usize
            } else {
                eg[m] as usize
            }
        };
        if owner {
            for (m, pid) in (0..eg.len()).zip(pid0..) {
                let g = steps(m);
                visit(g, pos[g], pid, true, new_rec);
            }
        } else {
            let s0 = plan.block_slot(plan.use_block[u]);
            let shared = &store.blocks[s0..s0 + eg.len()];
            for ((m, &q), pid) in shared.iter().enumerate().zip(pid0..) {
                visit(steps(m), q, pid, false, new_rec);
            }
        }
    }
    buf.snap = snap2.sqrt();
    let mut id = plan.interior_pos[p];
    for row in map.interior {
        let len = row.len();
        if needs.positions {
            new_positions[npos..npos + len].copy_from_slice(&pos[row.clone()]);
            npos += len;
        }
        let out = &mut records[nrec..nrec + len];
        // Field by field: a whole-record store goes through the stack, and the misaligned
        // reload stalls store forwarding on every sample.
        for ((r, position), normal) in out.iter_mut().zip(&pos[row.clone()]).zip(&nrm[row.clone()])
        {
            r.position = *position;
            r.normal = *normal;
            r.position_id = id;
            id += 1;
        }
        nrec += len;
    }
    buf.nrec = nrec;
    buf.npos = npos;
    buf.triangles.clear();
    buf.position_triangles.clear();
    let tris: &[[u32; 3]] = if plan.is_uniform() {
        grid
    } else {
        buf.local_triangles.clear();
        if needs.triangles || needs.grid_positions {
            plan.patch_local_triangles(p, &mut buf.local_triangles);
        }
        &buf.local_triangles
    };
    if needs.triangles {
        plan.local_ids_with(p, &mut buf.local_rec, &mut buf.local_pos, &mut buf.scratch);
        let (rec, pid) = (&buf.local_rec, &buf.local_pos);
        buf.triangles
            .extend(tris.iter().map(|t| t.map(|i| rec[i as usize])));
        buf.position_triangles
            .extend(tris.iter().map(|t| t.map(|i| pid[i as usize])));
    }
}

/// Builds the attributes of patch `p`'s new records into `buf.attributes`, in record order
/// (corners, edge uses in canonical order, interior), each interpolated at its sample's
/// barycentric coordinates in patch `p` (`grid_bary` for a uniform plan).
fn build_attributes<V>(
    plan: &StitchPlan,
    attrs: &CornerAttributes,
    grid_bary: &[[f64; 3]],
    p: usize,
    buf: &mut PatchBuf<V>,
) {
    let bary: &[[f64; 3]] = if plan.is_uniform() {
        grid_bary
    } else {
        buf.bary.clear();
        plan.patch_points(p, &mut buf.bary);
        &buf.bary
    };
    let uv = attrs.uvs.as_ref().map(|u| &u[p]);
    let color = attrs.colors.as_ref().map(|c| &c[p]);
    let at = |g: u32| {
        let b = bary[g as usize];
        RecordAttributes {
            uv: uv.map_or([0.0; 2], |u| interpolate(u, b)),
            color: color.map_or([0.0; 4], |c| interpolate(c, b)),
        }
    };
    let out = &mut buf.attributes;
    out.clear();
    let map = plan.local_map(p, &mut buf.scratch);
    for k in 0..3 {
        if plan.corner_flags[3 * p + k] & NEW_REC != 0 {
            out.push(at(map.corner[k]));
        }
    }
    for k in 0..3 {
        let flags = plan.use_flags[3 * p + k];
        if flags & NEW_REC != 0 {
            // Canonical sample m (1..n) lies at step n − m on a reversed use.
            if flags & REV != 0 {
                out.extend(map.edges[k].iter().rev().map(|&g| at(g)));
            } else {
                out.extend(map.edges[k].iter().map(|&g| at(g)));
            }
        }
    }
    for row in map.interior {
        out.extend(row.clone().map(|g| at(g as u32)));
    }
}
