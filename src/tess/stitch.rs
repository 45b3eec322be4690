//! Stitching: the indexed output surface of a grid evaluation, built while the samples
//! stream in (output side; input welding of coincident file vertices is
//! [`crate::mesh`]'s).
//!
//! Every patch is evaluated on the grid of level n ([`Pattern::Grid`]); the stitched mesh
//! keeps
//! - one position per input vertex, taken from the first triangle that uses the vertex;
//! - n − 1 positions per edge, taken from the first triangle that uses the edge (its
//!   *owner*); every other triangle of the edge maps its own edge samples onto these, so
//!   positions on shared edges are bitwise identical whatever the backend;
//! - the (n − 1)(n − 2)/2 interior points of each patch.
//!
//! Triangles keep the input's orientation (the grid triangles of a patch are oriented
//! like the patch). A closed manifold input gives a closed manifold output with the same
//! Euler characteristic. Boundary and non-manifold edges are kept as they are: each use of
//! a non-manifold edge maps onto the owner's samples.
//!
//! **Precision.** The stitcher is generic over the sample precision ([`Vector`]): `DVec3`
//! for the f64 reference, `[f32; 3]` for files, which then go kernel → stitcher → writer in
//! f32 with no f64 round trip.
//!
//! **Split normals.** Positions are always shared. Normals are carried by *vertex records*
//! (a position id and a normal): a position has one record, except where the input splits
//! normals: an input vertex has one record per distinct corner normal around it (bitwise,
//! see [`crate::mesh::creases`]), and each sample inside an edge whose triangles disagree
//! on an end normal (a crease) has one record per triangle of the edge, each with the
//! normal its own patch evaluates there. OBJ files keep both (`v` = positions, `vn` =
//! records, `f p//r`); formats with one attribute set per vertex (PLY, glTF) write the
//! records, so their meshes are cut along creases, as split normals require there.
//!
//! **Attributes.** Per-corner texture coordinates and colours of the input
//! ([`Mesh::attributes`]) are interpolated linearly in each patch's barycentric domain (at
//! a corner the input value itself) and handed over per new record
//! ([`PatchOut::new_attributes`]). They split records like normals do: an input vertex has
//! one record per distinct (normal, attributes) around it, and an edge whose triangles
//! disagree on an end's attributes (a UV seam) gets one record per triangle for each
//! sample, each with its own side's values. Positions stay shared across a seam.
//!
//! Memory: the plan is O(triangles); while streaming, the stitcher keeps the positions of
//! the input vertices and edge samples (V + E(n − 1) points) and the output of one batch
//! of patches (fewer patches per batch at high levels), so big outputs never need the
//! whole sample array. [`memory_estimate`] gives the figure before anything is allocated.
//!
//! Order: positions and records are numbered in the order they first appear when the
//! patches are visited in order, and within a patch: corners 0, 1, 2, edges 0, 1, 2 (each
//! from its lower-numbered vertex to the other), then the interior in grid order
//! ([`crate::tess::numbering`], which the GPU tessellator's table shares). A writer can
//! therefore emit each patch's new positions and records as soon as it arrives.

use std::ops::Range;

use glam::DVec3;
use rayon::prelude::*;

use crate::eval::cpu::CpuEvaluator;
use crate::eval::{
    grid_len, grid_triangles, stage_samples, Evaluator, PatchPoint, Pattern, Vector,
};
use crate::mesh::{Adjacency, CornerAttributes, Mesh};
use crate::patch::validity::{Certifier, PatchCounts};
use crate::patch::{PatchBuilder, PatchTable};
use crate::progress::{NoProgress, Progress};
use crate::tess::layout;
use crate::tess::levels::Levels;
use crate::tess::numbering::{
    corner_grid, edge_grid, interior_rows, Bases, Item, Numbering, Order,
};
use crate::{Error, Result};

mod stitcher;
use stitcher::Stitcher;

const NONE: u32 = u32::MAX;

/// One vertex record of the stitched mesh: a shared position with the normal of one side.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VertexRecord<V = DVec3> {
    /// The shared position.
    pub position: V,
    /// The unit normal of the patch on this record's side.
    pub normal: V,
    /// Index of the shared position.
    pub position_id: u32,
}

/// The attributes of one vertex record, interpolated from its patch's corners: texture
/// coordinates and colour (red, green, blue, alpha); the parts the input has not are 0.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RecordAttributes {
    /// Texture coordinates (u, v).
    pub uv: [f32; 2],
    /// Colour: red, green, blue, alpha.
    pub color: [f32; 4],
}

/// What stitching found in the input topology.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct StitchReport {
    /// Edges used by one triangle.
    pub boundary_edges: usize,
    /// Edges used by three or more triangles.
    pub nonmanifold_edges: usize,
    /// Edges whose triangles disagree on an end normal or an end's attributes (creases,
    /// UV seams): their samples get one record per triangle.
    pub split_edges: usize,
    /// Records beyond one per position (split normals).
    pub extra_records: usize,
}

/// The numbering of a stitched grid output, from the topology alone.
#[derive(Clone, Debug)]
pub struct StitchPlan {
    /// Grid level of every patch.
    pub level: u32,
    /// Shared positions.
    pub positions: usize,
    /// Vertex records (≥ positions; more where normals are split).
    pub records: usize,
    /// Output triangles: level² per patch.
    pub triangles: usize,
    /// What stitching found in the input topology.
    pub report: StitchReport,
    /// Patches (triangles of the mesh).
    patches: usize,
    /// Vertices the triangles use: the store slots of corner samples.
    corner_items: usize,
    /// Edges: the blocks of shared positions on edges.
    blocks: usize,
    /// Per edge use 3t + k: the edge (index in the adjacency).
    use_edge: Vec<u32>,
    // Per corner 3t + k, all read in patch order while stitching: what it does
    // ([`OWNS`], [`NEW_REC`]), its store slot (its vertex, numbered by first use), its
    // position id and its record id.
    corner_flags: Vec<u8>,
    corner_slot: Vec<u32>,
    corner_pos: Vec<u32>,
    corner_rec: Vec<u32>,
    // Per edge use 3t + k: what it does ([`OWNS`], [`NEW_REC`], [`REV`]), its edge's
    // block of shared positions (edges numbered by first use), the position id and the
    // record id of its canonical sample 1.
    use_flags: Vec<u8>,
    use_block: Vec<u32>,
    use_pos: Vec<u32>,
    use_rec: Vec<u32>,
    interior_pos: Vec<u32>,
    interior_rec: Vec<u32>,
    /// Whether the record ids are the position ids (no vertex with a second normal or
    /// attributes, no split edge): `corner_rec`, `use_rec` and `interior_rec` are then
    /// empty.
    records_are_positions: bool,
    /// Per level, computed once: grid index of each corner, of the sample at step
    /// i (1..n) along local edge k (`edge_g[k(n − 1) + i − 1]`), and the interior rows.
    corner_g: [u32; 3],
    edge_g: Vec<u32>,
    interior: Vec<Range<usize>>,
    /// Per-edge levels ([`StitchPlan::with_levels`]); `None` for a uniform plan.
    adaptive: Option<Box<AdaptivePlan>>,
    /// The mesh's per-corner attributes, when it has any.
    attrs: Option<Box<CornerAttributes>>,
}

/// A corner or edge use that is its vertex's or edge's first use: it stores its samples for
/// the others and makes their positions.
const OWNS: u8 = 1;
/// A corner or edge use that makes its records (always where it [`OWNS`]; also a corner
/// with a normal or attributes of its own, a use of a split edge).
const NEW_REC: u8 = 2;
/// An edge use whose local direction (corner k → k + 1) runs from the higher to the lower
/// vertex id, against the canonical sample order.
const REV: u8 = 4;

/// Linear interpolation of three corner values at barycentric coordinates `b`, in f64.
fn interpolate<const N: usize>(corners: &[[f32; N]; 3], b: [f64; 3]) -> [f32; N] {
    std::array::from_fn(|c| {
        (b[0] * corners[0][c] as f64 + b[1] * corners[1][c] as f64 + b[2] * corners[2][c] as f64)
            as f32
    })
}

/// The per-edge part of a non-uniform plan.
#[derive(Clone, Debug)]
struct AdaptivePlan {
    /// Level of each edge (index in the adjacency).
    edge_level: Vec<u32>,
    /// Inner level of each patch, as given (the pattern raises it where it must,
    /// [`layout::effective_inner`]).
    inner: Vec<u32>,
    /// Store slot of each block's first sample (after the corner slots), blocks in the
    /// order they are made.
    block_store: Vec<u32>,
}

/// The flags, position ids and record ids of `uses` corners or edge uses, `item(u)` each,
/// filled in parallel in blocks of uses.
fn fill_uses(
    uses: usize,
    with_rec: bool,
    item: impl Fn(usize) -> (u8, u32, u32) + Sync,
) -> (Vec<u8>, Vec<u32>, Vec<u32>) {
    const BLOCK: usize = 1 << 12;
    let (mut flags, mut pos) = (vec![0u8; uses], vec![0u32; uses]);
    // Without records apart, the record ids are not kept (an empty array).
    let mut rec = vec![0u32; if with_rec { uses } else { 0 }];
    let chunks = flags
        .par_chunks_mut(BLOCK)
        .zip(pos.par_chunks_mut(BLOCK))
        .enumerate();
    if with_rec {
        chunks
            .zip(rec.par_chunks_mut(BLOCK))
            .for_each(|((i, (f, p)), r)| {
                for (j, ((f, p), r)) in f.iter_mut().zip(p).zip(r).enumerate() {
                    (*f, *p, *r) = item(i * BLOCK + j);
                }
            });
    } else {
        chunks.for_each(|(i, (f, p))| {
            for (j, (f, p)) in f.iter_mut().zip(p).enumerate() {
                (*f, *p, _) = item(i * BLOCK + j);
            }
        });
    }
    (flags, pos, rec)
}

impl StitchPlan {
    /// Plans the stitched output of `mesh` on the grid of level `level` (≥ 1).
    pub fn new(mesh: &Mesh, adjacency: &Adjacency, level: u32) -> Result<StitchPlan> {
        if level == 0 {
            return Err(Error::Invalid("level must be at least 1".into()));
        }
        Self::build(mesh, adjacency, level, None)
    }

    /// Plans the stitched output of `mesh` with a level per edge and an inner level per
    /// patch ([`Levels`]; the pattern of each patch is `layout`'s). Where every edge and
    /// inner level are equal this is [`StitchPlan::new`] of that level: the same
    /// numbering, evaluated on the grid.
    pub fn with_levels(mesh: &Mesh, adjacency: &Adjacency, levels: &Levels) -> Result<StitchPlan> {
        levels.check(mesh, adjacency)?;
        if let Some(n) = levels.uniform_level() {
            return Self::new(mesh, adjacency, n);
        }
        let top = levels
            .edges
            .iter()
            .chain(&levels.inner)
            .copied()
            .max()
            .unwrap_or(1);
        let adaptive = AdaptivePlan {
            edge_level: levels.edges.clone(),
            inner: levels.inner.clone(),
            // Once the blocks are numbered (`resolve`).
            block_store: Vec::new(),
        };
        Self::build(mesh, adjacency, top, Some(Box::new(adaptive)))
    }

    fn build(
        mesh: &Mesh,
        adjacency: &Adjacency,
        level: u32,
        adaptive: Option<Box<AdaptivePlan>>,
    ) -> Result<StitchPlan> {
        let n = level;
        let nf = mesh.triangles.len();
        let a = &mesh.attributes;
        let lens = [
            a.uvs.as_ref().map(Vec::len),
            a.colors.as_ref().map(Vec::len),
        ];
        if let Some(len) = lens.into_iter().flatten().find(|&l| l != nf) {
            return Err(Error::Invalid(format!(
                "{}: per-corner attributes for {len} triangles, the mesh has {nf}",
                mesh.name
            )));
        }
        let attrs = (a.uvs.is_some() || a.colors.is_some()).then(|| Box::new(a.clone()));
        let uniform = adaptive.is_none();
        let mut numbering = Numbering::new(mesh, adjacency, attrs.as_deref())?;
        let nv = mesh.positions.len();
        let mut plan = StitchPlan {
            level,
            positions: 0,
            records: 0,
            triangles: 0,
            report: StitchReport {
                boundary_edges: adjacency.boundary,
                nonmanifold_edges: adjacency.nonmanifold,
                split_edges: numbering.split.iter().filter(|&&s| s).count(),
                extra_records: 0,
            },
            patches: nf,
            corner_items: 0,
            blocks: 0,
            use_edge: std::mem::take(&mut numbering.use_edge),
            corner_flags: Vec::new(),
            corner_slot: Vec::new(),
            corner_pos: Vec::new(),
            corner_rec: Vec::new(),
            use_flags: Vec::new(),
            use_block: Vec::new(),
            use_pos: Vec::new(),
            use_rec: Vec::new(),
            interior_pos: Vec::new(),
            interior_rec: Vec::new(),
            records_are_positions: false,
            corner_g: [0, 1, 2].map(|k| corner_grid(n, k) as u32),
            // A uniform plan's grid tables, once its counts are in range (below).
            edge_g: Vec::new(),
            interior: Vec::new(),
            adaptive,
            attrs,
        };
        // Upper bound on records: every corner, edge use and interior point its own.
        let mut bound = nv as u64;
        let mut triangles = 0u64;
        let mut interiors = Vec::with_capacity(if uniform { 0 } else { nf });
        // Every patch of a uniform plan has the same counts: nf times the first's.
        let counted = if uniform { nf.min(1) } else { nf };
        for p in 0..counted {
            let (e, inner) = plan.patch_levels(p);
            let interior = layout::interior_count(e, inner) as u64;
            let copies = if uniform { nf as u64 } else { 1 };
            // Saturating: an absurd level is refused below, not wrapped into range.
            let samples = layout::point_count(e, inner) as u64;
            bound = bound.saturating_add(copies.saturating_mul(samples));
            let patch_triangles = layout::triangle_count(e, inner) as u64;
            triangles = triangles.saturating_add(copies.saturating_mul(patch_triangles));
            if !uniform {
                interiors.push(interior);
            }
        }
        if bound >= NONE as u64 || triangles >= NONE as u64 {
            return Err(Error::Invalid(format!(
                "{}: {} gives too many vertices for 32-bit indices",
                mesh.name,
                if uniform {
                    format!("level {level}")
                } else {
                    format!("levels up to {level}")
                }
            )));
        }
        // Made only now: at a level refused above they would not fit in memory (3 (n − 1)
        // indices, 48 GiB at level u32::MAX).
        if uniform {
            plan.edge_g = (0..3)
                .flat_map(|k| (1..n).map(move |i| edge_grid(n, k, i) as u32))
                .collect();
            plan.interior = interior_rows(n);
        }
        plan.triangles = triangles as usize;
        plan.resolve(numbering, &interiors);
        Ok(plan)
    }

    /// Takes the ids of `numbering` at the plan's levels (`interiors`: each patch's interior
    /// samples, for per-edge levels), per corner and edge use in patch order (what the
    /// stitcher reads of each patch lies together, whatever the vertex and edge ids).
    fn resolve(&mut self, mut numbering: Numbering, interiors: &[u64]) {
        // Where the records are the positions, their ids are the positions' ids.
        self.records_are_positions = numbering.records.is_none();
        let block_sizes = |order: &Order| -> Vec<u64> {
            order
                .block_first
                .iter()
                .map(|&u| self.edge_samples(self.use_edge[u as usize] as usize) as u64)
                .collect()
        };
        let bases = |order: &Order| match &self.adaptive {
            None => Bases::grid(self.level),
            Some(_) => Bases::prefix(block_sizes(order), interiors.iter().copied()),
        };
        let (records, positions) = (numbering.records(), &numbering.positions);
        let (rb, pb) = (bases(records), bases(positions));
        // Per-edge levels: each block's first store slot.
        let block_store: Option<Vec<u32>> = self.adaptive.as_ref().map(|_| {
            let mut slot = 0u64;
            block_sizes(positions)
                .into_iter()
                .map(|size| {
                    let first = slot as u32;
                    slot += size;
                    first
                })
                .collect()
        });
        // Every id fits: the caller checked the bound on records.
        let id = |b: &Bases, item: Item| b.base(item) as u32;
        let flag = |yes: bool, f: u8| if yes { f } else { 0 };
        // One pass over the corners and one over the edge uses, in parallel.
        let uses = 3 * self.patches;
        let apart = !self.records_are_positions;
        // Where the records are the positions, only the positions are looked up (the
        // record id is not kept).
        (self.corner_flags, self.corner_pos, self.corner_rec) = fill_uses(uses, apart, |c| {
            let owns = positions.makes_corner(c);
            let (new_rec, rec) = match apart {
                true => (records.makes_corner(c), id(&rb, records.corner_item(c))),
                false => (owns, 0),
            };
            (
                flag(owns, OWNS) | flag(new_rec, NEW_REC),
                id(&pb, positions.corner_item(c)),
                rec,
            )
        });
        let rev = &numbering.use_rev;
        (self.use_flags, self.use_pos, self.use_rec) = fill_uses(uses, apart, |u| {
            let owns = positions.makes_block(u);
            let (new_rec, rec) = match apart {
                true => (records.makes_block(u), id(&rb, records.block_item(u))),
                false => (owns, 0),
            };
            (
                flag(owns, OWNS) | flag(new_rec, NEW_REC) | flag(rev[u], REV),
                id(&pb, positions.block_item(u)),
                rec,
            )
        });
        let patches = 0..self.patches;
        if apart {
            self.interior_rec = patches
                .clone()
                .into_par_iter()
                .map(|p| id(&rb, records.interior_item(p)))
                .collect();
        }
        self.interior_pos = patches
            .into_par_iter()
            .map(|p| id(&pb, positions.interior_item(p)))
            .collect();
        self.positions = pb.base(positions.end()) as usize;
        self.records = rb.base(records.end()) as usize;
        self.report.extra_records = self.records - self.positions;
        self.corner_items = positions.corner_first.len();
        self.blocks = positions.block_first.len();
        if let (Some(a), Some(b)) = (&mut self.adaptive, block_store) {
            a.block_store = b;
        }
        // Vertices and edges numbered by first use: the corner items and blocks.
        self.corner_slot = std::mem::take(&mut numbering.positions.corner);
        self.use_block = std::mem::take(&mut numbering.positions.block);
    }

    /// Whether the output records carry texture coordinates
    /// (`RecordAttributes::uv`).
    pub fn has_uvs(&self) -> bool {
        self.attrs.as_ref().is_some_and(|a| a.uvs.is_some())
    }

    /// Whether the output records carry colours (`RecordAttributes::color`).
    pub fn has_colors(&self) -> bool {
        self.attrs.as_ref().is_some_and(|a| a.colors.is_some())
    }

    /// Whether the colours' alpha channel came from the input.
    pub fn colors_have_alpha(&self) -> bool {
        self.attrs.as_ref().is_some_and(|a| a.alpha)
    }

    /// Whether the output records carry attributes ([`PatchOut::new_attributes`]).
    pub fn has_attributes(&self) -> bool {
        self.attrs.is_some()
    }

    /// Number of patches.
    pub fn patches(&self) -> usize {
        self.patches
    }

    /// Whether every patch is the grid of [`level`](Self::level) (evaluated with
    /// [`Pattern::Grid`], samples in grid order); otherwise patches have their own
    /// patterns, evaluated through [`Pattern::Points`] in `layout`'s local order.
    pub fn is_uniform(&self) -> bool {
        self.adaptive.is_none()
    }

    /// Level of edge `e` (index in the adjacency).
    pub fn edge_level(&self, e: usize) -> u32 {
        match &self.adaptive {
            Some(a) => a.edge_level[e],
            None => self.level,
        }
    }

    /// Samples strictly inside edge `e`.
    fn edge_samples(&self, e: usize) -> u32 {
        self.edge_level(e) - 1
    }

    /// Levels of patch `p`: its local edges (corner k → k + 1) and its inner level.
    pub fn patch_levels(&self, p: usize) -> ([u32; 3], u32) {
        match &self.adaptive {
            Some(a) => (
                [0, 1, 2].map(|k| a.edge_level[self.use_edge[3 * p + k] as usize]),
                a.inner[p],
            ),
            None => ([self.level; 3], self.level),
        }
    }

    /// Samples of patch `p`.
    pub fn patch_len(&self, p: usize) -> usize {
        match &self.adaptive {
            Some(_) => {
                let (e, inner) = self.patch_levels(p);
                layout::point_count(e, inner)
            }
            None => grid_len(self.level),
        }
    }

    /// Barycentric coordinates of patch `p`'s samples in its sample order (grid order for a
    /// uniform plan, `layout`'s local order otherwise), appended to `out`.
    pub fn patch_points(&self, p: usize, out: &mut Vec<[f64; 3]>) {
        match &self.adaptive {
            Some(_) => {
                let (e, inner) = self.patch_levels(p);
                layout::points(e, inner, out);
            }
            None => out.extend(crate::eval::grid_barycentrics(self.level)),
        }
    }

    /// Triangles of patch `p` as indices into its samples (in sample order), appended to
    /// `out`.
    pub fn patch_local_triangles(&self, p: usize, out: &mut Vec<[u32; 3]>) {
        match &self.adaptive {
            Some(_) => {
                let (e, inner) = self.patch_levels(p);
                layout::triangles(e, inner, out);
            }
            None => out.extend(grid_triangles(self.level)),
        }
    }

    /// Samples of the store of shared edge samples: every block's (the store of corner
    /// samples has [`corner_items`](Self::corner_items)).
    fn block_store_len(&self) -> usize {
        match &self.adaptive {
            Some(a) => a.edge_level.iter().map(|&l| l as usize - 1).sum::<usize>(),
            None => self.blocks * (self.level as usize - 1),
        }
    }

    /// Slot in the block store of block `b`'s canonical sample 1 (its samples follow).
    #[inline]
    fn block_slot(&self, b: u32) -> usize {
        match &self.adaptive {
            Some(a) => a.block_store[b as usize] as usize,
            None => b as usize * (self.level as usize - 1),
        }
    }

    /// Where patch `p`'s corners, edge samples and interior lie in its samples. A uniform
    /// plan answers from its per-level tables (inline: the stitcher asks for every patch);
    /// otherwise `scratch` holds the answer.
    #[inline]
    fn local_map<'s>(&'s self, p: usize, scratch: &'s mut LocalScratch) -> LocalMap<'s> {
        match &self.adaptive {
            None => {
                let m = self.level as usize - 1;
                LocalMap {
                    corner: self.corner_g,
                    edges: [0, 1, 2].map(|k| &self.edge_g[k * m..(k + 1) * m]),
                    interior: &self.interior,
                }
            }
            Some(_) => self.local_map_adaptive(p, scratch),
        }
    }

    /// [`local_map`](Self::local_map) of a patch of a non-uniform plan, into `scratch`.
    fn local_map_adaptive<'s>(&self, p: usize, scratch: &'s mut LocalScratch) -> LocalMap<'s> {
        let (e, inner) = self.patch_levels(p);
        let (ranges, interior) = layout::local_edges(e, inner);
        scratch.edges.clear();
        let mut ends = [0usize; 3];
        for (k, r) in ranges.into_iter().enumerate() {
            scratch.edges.extend(r);
            ends[k] = scratch.edges.len();
        }
        scratch.interior.clear();
        scratch.interior.push(interior);
        let (a, rest) = scratch.edges.split_at(ends[0]);
        let (b, c) = rest.split_at(ends[1] - ends[0]);
        LocalMap {
            corner: [0, 1, 2],
            edges: [a, b, c],
            interior: &scratch.interior,
        }
    }

    /// Record id and position id of every sample of patch `p`, in its sample order (grid
    /// order for a uniform plan).
    pub fn local_ids(&self, p: usize, rec: &mut Vec<u32>, pos: &mut Vec<u32>) {
        let mut scratch = LocalScratch::default();
        self.local_ids_with(p, rec, pos, &mut scratch)
    }

    fn local_ids_with(
        &self,
        p: usize,
        rec: &mut Vec<u32>,
        pos: &mut Vec<u32>,
        scratch: &mut LocalScratch,
    ) {
        let len = self.patch_len(p);
        // Every sample is written below (corners, edges, interior), so buffers of the
        // right length are reused as they are.
        if rec.len() != len {
            rec.clear();
            rec.resize(len, NONE);
        }
        if pos.len() != len {
            pos.clear();
            pos.resize(len, NONE);
        }
        let map = self.local_map(p, scratch);
        let (corner_rec, use_rec, interior_rec) = if self.records_are_positions {
            (&self.corner_pos, &self.use_pos, &self.interior_pos)
        } else {
            (&self.corner_rec, &self.use_rec, &self.interior_rec)
        };
        for k in 0..3 {
            let g = map.corner[k] as usize;
            rec[g] = corner_rec[3 * p + k];
            pos[g] = self.corner_pos[3 * p + k];
        }
        for k in 0..3 {
            let u = 3 * p + k;
            let (r0, p0) = (use_rec[u], self.use_pos[u]);
            let eg = map.edges[k];
            // Canonical sample m (1..n) lies at step n − m on a reversed use.
            let mut put = |m: u32, g: u32| {
                rec[g as usize] = r0 + m;
                pos[g as usize] = p0 + m;
            };
            if self.use_flags[u] & REV != 0 {
                eg.iter().rev().zip(0..).for_each(|(&g, m)| put(m, g));
            } else {
                eg.iter().zip(0..).for_each(|(&g, m)| put(m, g));
            }
        }
        let (mut r, mut q) = (interior_rec[p], self.interior_pos[p]);
        for row in map.interior {
            for (a, b) in rec[row.clone()].iter_mut().zip(&mut pos[row.clone()]) {
                *a = r;
                *b = q;
                r += 1;
                q += 1;
            }
        }
    }

    /// Output triangles (record ids) of patch `p`, appended to `out`; `scratch` and
    /// `grid` (= `grid_triangles(level)`, used by uniform plans) are reused between calls.
    pub fn patch_triangles(
        &self,
        p: usize,
        grid: &[[u32; 3]],
        scratch: &mut (Vec<u32>, Vec<u32>),
        out: &mut Vec<[u32; 3]>,
    ) {
        self.local_ids(p, &mut scratch.0, &mut scratch.1);
        let rec = &scratch.0;
        if self.is_uniform() {
            out.extend(grid.iter().map(|t| t.map(|i| rec[i as usize])));
        } else {
            let start = out.len();
            self.patch_local_triangles(p, out);
            for t in &mut out[start..] {
                *t = t.map(|i| rec[i as usize]);
            }
        }
    }
}

/// Where one patch's corners, edge samples (local edge k from corner k, steps 1..E_k) and
/// interior runs lie in its samples.
struct LocalMap<'a> {
    corner: [u32; 3],
    edges: [&'a [u32]; 3],
    interior: &'a [Range<usize>],
}

/// The buffers a non-uniform [`LocalMap`] lives in.
#[derive(Clone, Debug, Default)]
struct LocalScratch {
    edges: Vec<u32>,
    interior: Vec<Range<usize>>,
}

/// What the stitcher hands to a [`StitchSink`] for one patch. The fields a sink does not
/// ask for in [`StitchSink::needs`] are empty.
pub struct PatchOut<'a, V = DVec3> {
    /// Index of the patch (its triangle in the mesh).
    pub patch: usize,
    /// Positions first appearing in this patch, in id order ([`Needs::positions`]).
    pub new_positions: &'a [V],
    /// Records first appearing in this patch, in id order.
    pub new_records: &'a [VertexRecord<V>],
    /// Attributes of each of `new_records`, when the plan carries any
    /// ([`StitchPlan::has_attributes`]); empty otherwise.
    pub new_attributes: &'a [RecordAttributes],
    /// This patch's triangles as record ids ([`Needs::triangles`]).
    pub triangles: &'a [[u32; 3]],
    /// The same triangles as position ids ([`Needs::triangles`]).
    pub position_triangles: &'a [[u32; 3]],
    /// Shared position of every grid point of the patch, grid order
    /// ([`Needs::grid_positions`]).
    pub grid_positions: &'a [V],
    /// The patch's triangles as grid indices (the same for every patch).
    pub grid_triangles: &'a [[u32; 3]],
}

/// Which parts of [`PatchOut`] a sink reads (the stitcher skips building the others).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Needs {
    /// `new_positions`.
    pub positions: bool,
    /// `triangles` and `position_triangles`.
    pub triangles: bool,
    /// `grid_positions`.
    pub grid_positions: bool,
}

impl Needs {
    /// Every part.
    pub const ALL: Needs = Needs {
        positions: true,
        triangles: true,
        grid_positions: true,
    };
    /// The new vertex records alone (each carries its position).
    pub const RECORDS: Needs = Needs {
        positions: false,
        triangles: false,
        grid_positions: false,
    };
}

/// A consumer of stitched output, patch after patch.
pub trait StitchSink<V = DVec3> {
    /// What the sink reads of each [`PatchOut`] (default: everything).
    fn needs(&self) -> Needs {
        Needs::ALL
    }
    /// Takes the output of one patch; patches come in order.
    fn patch(&mut self, out: &PatchOut<'_, V>) -> Result<()>;
}

/// A sink that keeps nothing: counts what it was handed (throughput measurements). It
/// asks for the records alone.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CountingSink {
    pub patches: usize,
    /// One more than the largest position id seen (the positions, once every patch is in).
    pub positions: usize,
    pub records: usize,
}

impl<V> StitchSink<V> for CountingSink {
    fn needs(&self) -> Needs {
        Needs::RECORDS
    }
    fn patch(&mut self, out: &PatchOut<'_, V>) -> Result<()> {
        self.patches += 1;
        let top = out.new_records.iter().map(|r| r.position_id).max();
        self.positions = self.positions.max(top.map_or(0, |t| t as usize + 1));
        self.records += out.new_records.len();
        Ok(())
    }
}

/// Most patches of the grid of `level` whose output the stitcher builds in parallel
/// before the sink sees them in order (a run; it holds two, the one the sink reads and the
/// one built meanwhile): a run holds at most `samples` grid points (the stages'
/// [`crate::eval::stage_samples`]), one patch at least.
pub fn batch_patches(level: u32, samples: usize) -> usize {
    (samples / grid_len(level).max(1)).max(1)
}

/// What a stitched evaluation holds while it streams ([`memory_estimate`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StitchMemory {
    /// Points in the stitcher's store of shared samples: V + E(n − 1).
    pub store_points: u64,
    /// The plan (O(triangles)), bytes.
    pub plan_bytes: u64,
    /// The store, bytes.
    pub store_bytes: u64,
    /// One chunk of samples from the evaluator (positions and normals, twice: the
    /// evaluator's buffer and what it hands over), bytes.
    pub chunk_bytes: u64,
    /// Two batches of patch outputs ([`batch_patches`]: the one the sink reads and the one
    /// built meanwhile), bytes.
    pub batch_bytes: u64,
    /// The patches of those two batches (at most the triangles): the stages whose patch
    /// tables the CPU builds meanwhile hold as many.
    pub batch_patches: u64,
}

impl StitchMemory {
    #[cfg(test)]
    /// Everything together, bytes.
    pub fn total(&self) -> u64 {
        self.plan_bytes
            .saturating_add(self.store_bytes)
            .saturating_add(self.chunk_bytes)
            .saturating_add(self.batch_bytes)
    }
}

/// Estimates, before anything is built, what stitching `triangles` triangles over
/// `vertices` vertices and `edges` edges at `level` holds, with samples of `sample_bytes`
/// bytes per point (12 for f32, 24 for f64), an evaluator handing over chunks of
/// `chunk_samples` samples (whole patches, one at least) and a sink that reads `needs`.
/// Every product saturates, so absurd levels give absurd (not wrapped) figures. Upper
/// bounds for a manifold mesh, within a few percent of what is allocated.
pub fn memory_estimate(
    vertices: usize,
    edges: usize,
    triangles: usize,
    level: u32,
    sample_bytes: u64,
    chunk_samples: usize,
    needs: Needs,
) -> StitchMemory {
    let n = level.max(1) as u64;
    let (v, e, t) = (vertices as u64, edges as u64, triangles as u64);
    let per = (n + 1).saturating_mul(n + 2) / 2;
    let n2 = n.saturating_mul(n);
    let store_points = v.saturating_add(e.saturating_mul(n - 1));
    // Per triangle: its vertex ids (12), per corner and edge use: edge, direction, corner
    // record, flag, use record, flag (15 × 3), interior ids (8); per vertex and edge two
    // ids; the corner-normal groups (a hash entry of ~48 bytes per corner at most).
    let plan_bytes = (t.saturating_mul(12 + 45 + 8))
        .saturating_add((v + e).saturating_mul(8))
        .saturating_add(t.saturating_mul(3 * 48));
    let chunk_points = per
        .max((chunk_samples as u64).min(per.saturating_mul(t)))
        .max(1);
    let chunk_bytes = chunk_points.saturating_mul(2 * 2 * sample_bytes);
    // A patch's output: records (position, normal, id), local ids, and what the sink asks
    // for: new positions, grid positions, triangles by record and by position id.
    let mut patch = per.saturating_mul(2 * sample_bytes + 4 + 8);
    if needs.positions {
        patch = patch.saturating_add(per.saturating_mul(sample_bytes));
    }
    if needs.grid_positions {
        patch = patch.saturating_add(per.saturating_mul(sample_bytes));
    }
    if needs.triangles {
        patch = patch.saturating_add(n2.saturating_mul(24));
    }
    let batch = (2 * batch_patches(level.max(1), stage_samples()) as u64).min(t.max(1));
    let batch_bytes = patch
        .saturating_mul(batch)
        .saturating_add(n2.saturating_mul(12));
    StitchMemory {
        store_points,
        plan_bytes,
        store_bytes: store_points.saturating_mul(sample_bytes),
        chunk_bytes,
        batch_bytes,
        batch_patches: batch,
    }
}

/// A stitched mesh held in memory (small runs, tests, pictures).
#[derive(Clone, Debug)]
pub struct StitchedMesh<V = DVec3> {
    /// Shared positions.
    pub positions: Vec<V>,
    /// Normal of each vertex record.
    pub normals: Vec<V>,
    /// Position id of each vertex record.
    pub record_position: Vec<u32>,
    /// Triangles as record ids.
    pub triangles: Vec<[u32; 3]>,
    /// Attributes of each vertex record, when the plan carries any
    /// ([`StitchPlan::has_attributes`]); empty otherwise.
    pub attributes: Vec<RecordAttributes>,
}

impl<V> Default for StitchedMesh<V> {
    fn default() -> Self {
        StitchedMesh {
            positions: Vec::new(),
            normals: Vec::new(),
            record_position: Vec::new(),
            triangles: Vec::new(),
            attributes: Vec::new(),
        }
    }
}

impl<V: Vector> StitchSink<V> for StitchedMesh<V> {
    fn needs(&self) -> Needs {
        Needs {
            positions: true,
            triangles: true,
            grid_positions: false,
        }
    }

    fn patch(&mut self, out: &PatchOut<'_, V>) -> Result<()> {
        self.positions.extend_from_slice(out.new_positions);
        for r in out.new_records {
            self.normals.push(r.normal);
            self.record_position.push(r.position_id);
        }
        self.triangles.extend_from_slice(out.triangles);
        self.attributes.extend_from_slice(out.new_attributes);
        Ok(())
    }
}

impl<V: Vector> StitchedMesh<V> {
    /// Triangles as position ids (the stitched topology).
    pub fn position_triangles(&self) -> Vec<[u32; 3]> {
        self.triangles
            .iter()
            .map(|t| t.map(|r| self.record_position[r as usize]))
            .collect()
    }

    /// Position of every vertex record.
    pub fn record_positions(&self) -> Vec<V> {
        self.record_position
            .iter()
            .map(|&p| self.positions[p as usize])
            .collect()
    }
}

/// Most samples a run of patches of a non-uniform plan holds ([`PatchRuns`]; one patch at
/// least): 8 MiB of [`PatchPoint`]s.
pub const RUN_POINTS: usize = 1 << 18;

/// The evaluation points of a non-uniform plan, a run of whole patches at a time (about
/// [`RUN_POINTS`] samples), each patch's samples in its sample order.
pub struct PatchRuns<'a> {
    plan: &'a StitchPlan,
    next: usize,
    points: Vec<PatchPoint>,
    bary: Vec<[f64; 3]>,
}

impl<'a> PatchRuns<'a> {
    pub fn new(plan: &'a StitchPlan) -> PatchRuns<'a> {
        PatchRuns {
            plan,
            next: 0,
            points: Vec::new(),
            bary: Vec::new(),
        }
    }

    /// The next run: its first patch, its number of patches and its points (hand the list
    /// back with [`give_back`](Self::give_back) to reuse it).
    pub fn next_run(&mut self) -> Option<(usize, usize, Vec<PatchPoint>)> {
        let plan = self.plan;
        if self.next >= plan.patches() {
            return None;
        }
        let first = self.next;
        let mut points = std::mem::take(&mut self.points);
        points.clear();
        while self.next < plan.patches()
            && (points.is_empty() || points.len() + plan.patch_len(self.next) <= RUN_POINTS)
        {
            self.bary.clear();
            plan.patch_points(self.next, &mut self.bary);
            let patch = self.next as u32;
            points.extend(self.bary.iter().map(|&b| PatchPoint { patch, b }));
            self.next += 1;
        }
        Some((first, self.next - first, points))
    }

    /// Returns a point list for the next run to reuse.
    pub fn give_back(&mut self, points: Vec<PatchPoint>) {
        self.points = points;
    }
}

/// Evaluates `table` on the grid of `plan.level` (a uniform plan; the patterns of a
/// non-uniform plan through [`Pattern::Points`], a run of patches at a time) with `evaluator` in the precision `V`
/// ([`Vector::evaluate`]: f32 runs the evaluator's native f32 path) and stitches the result
/// into `sink`; returns the largest snap distance (`Stitcher::max_snap`). `progress`
/// gets the phase "evaluating" over the patches, advanced chunk by chunk.
pub fn stitch_into<V: Vector>(
    plan: &StitchPlan,
    table: &PatchTable,
    evaluator: &dyn Evaluator,
    sink: &mut dyn StitchSink<V>,
    progress: &dyn Progress,
) -> Result<f64> {
    if table.len() != plan.patches() {
        return Err(Error::Invalid(format!(
            "stitching: a table of {} patches for a plan of {}",
            table.len(),
            plan.patches()
        )));
    }
    let mut stitcher = Stitcher::<V>::new(plan, sink.needs());
    progress.start("evaluating", plan.patches() as u64);
    if plan.is_uniform() {
        stitcher.run_grid(evaluator, table, sink, progress)?;
    } else {
        let mut run = PatchRuns::new(plan);
        let (mut pos, mut nrm) = (Vec::new(), Vec::new());
        while let Some((first, count, points)) = run.next_run() {
            pos.clear();
            nrm.clear();
            let pattern = Pattern::Points(points);
            V::evaluate(evaluator, table, &pattern, &mut |c| {
                pos.extend_from_slice(c.positions);
                nrm.extend_from_slice(c.normals);
                Ok(())
            })?;
            stitcher.push_patches(first, &pos, &nrm, sink)?;
            progress.inc(count as u64);
            if let Pattern::Points(p) = pattern {
                run.give_back(p);
            }
        }
    }
    stitched(&stitcher)
}

/// [`stitch_into`] in f32 on the CPU of the patches `builder` builds, each chunk's table
/// built where it is evaluated (the whole table is never held) and seen by `seen` (its
/// first patch, its table; a [`Certifier`], as [`stitch_certified`] does) before it is
/// evaluated; `plan` must be uniform. The samples are bitwise those of [`stitch_into`]
/// with the CPU evaluator on the table `builder` builds.
pub fn stitch_built(
    plan: &StitchPlan,
    builder: &PatchBuilder<'_>,
    cpu: &CpuEvaluator,
    seen: &mut (dyn FnMut(usize, &PatchTable) + Send),
    sink: &mut dyn StitchSink<[f32; 3]>,
    progress: &dyn Progress,
) -> Result<f64> {
    let patches = builder.mesh().triangles.len();
    if patches != plan.patches() || !plan.is_uniform() {
        return Err(Error::Invalid(format!(
            "stitching: a builder of {patches} patches for a plan of {} (uniform: {})",
            plan.patches(),
            plan.is_uniform()
        )));
    }
    crate::eval::cpu::grid_fits(plan.level, builder.kind().stride() * 12 + 24)?;
    let mut stitcher = Stitcher::<[f32; 3]>::new(plan, sink.needs());
    progress.start("evaluating", plan.patches() as u64);
    stitcher.run_grid_built(cpu, builder, seen, sink, progress)?;
    stitched(&stitcher)
}

/// The largest snap distance of a stitching, or the error of one that was not given every
/// patch.
fn stitched<V: Vector>(stitcher: &Stitcher<'_, V>) -> Result<f64> {
    if !stitcher.is_complete() {
        return Err(Error::Invalid(
            "stitching: the evaluator did not deliver every patch".into(),
        ));
    }
    Ok(stitcher.max_snap())
}

/// What `tessellate` runs on the CPU at one level: [`stitch_built`] with each chunk's
/// table seen by a [`Certifier`], whose subdivisions run at the end; the largest snap
/// distance and the verdicts counted (those of `validity::count` on the whole table).
pub fn stitch_certified(
    plan: &StitchPlan,
    builder: &PatchBuilder<'_>,
    cpu: &CpuEvaluator,
    sink: &mut dyn StitchSink<[f32; 3]>,
    progress: &dyn Progress,
) -> Result<(f64, PatchCounts)> {
    let mut certifier = Certifier::new();
    let snap = stitch_built(
        plan,
        builder,
        cpu,
        &mut |_, t| certifier.see(t),
        sink,
        progress,
    )?;
    Ok((snap, certifier.finish()))
}

/// Stitches the whole grid evaluation of `level` in memory, in precision `V`.
pub fn stitch_in<V: Vector>(
    mesh: &Mesh,
    table: &PatchTable,
    evaluator: &dyn Evaluator,
    level: u32,
) -> Result<(StitchedMesh<V>, StitchPlan, f64)> {
    let plan = StitchPlan::new(mesh, &mesh.adjacency(), level)?;
    let mut out = StitchedMesh::default();
    let snap = stitch_into(&plan, table, evaluator, &mut out, &NoProgress)?;
    Ok((out, plan, snap))
}

/// [`stitch_in`] in f64 (the reference: pictures, tests).
pub fn stitch(
    mesh: &Mesh,
    table: &PatchTable,
    evaluator: &dyn Evaluator,
    level: u32,
) -> Result<(StitchedMesh, StitchPlan, f64)> {
    stitch_in::<DVec3>(mesh, table, evaluator, level)
}

/// Stitches the evaluation of any plan (uniform or per-edge levels) in memory, in
/// precision `V`; returns the mesh and the largest snap distance.
pub fn stitch_plan<V: Vector>(
    plan: &StitchPlan,
    table: &PatchTable,
    evaluator: &dyn Evaluator,
) -> Result<(StitchedMesh<V>, f64)> {
    let mut out = StitchedMesh::default();
    let snap = stitch_into(plan, table, evaluator, &mut out, &NoProgress)?;
    Ok((out, snap))
}
