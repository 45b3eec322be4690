//! Device-resident tessellation: the welded, indexed surface of a patch table written by
//! compute passes straight into a vertex and an index buffer on the host program's own
//! `wgpu::Device`, ready for its render pass, with nothing read back.
//!
//! wgpu has no tessellation stage; [`GpuTessellator`] stands in for one. It is built once
//! on the host's device and queue from a [`Mesh`] and its [`PatchTable`] (any patch kind,
//! any backend the host chose), uploads the patch data and a level-independent
//! [`Topology`] table once, and then, frame after frame, records the tessellation of any
//! uniform grid level into the host's `CommandEncoder`:
//!
//! - [`GpuTessellator::vertices`]: one entry per vertex record, absolute f32 position and
//!   unit f32 normal, 24 bytes ([`vertex_layout`]), usable as `VERTEX | STORAGE`;
//! - [`GpuTessellator::indices`]: `u32` triangle indices (`INDEX | STORAGE`), level² per
//!   patch;
//! - [`GpuTessellator::indirect`]: the `draw_indexed_indirect` arguments
//!   ([`wgpu::util::DrawIndexedIndirectArgs`], `INDIRECT`), and [`TessCounts`] on the host.
//!
//! Buffers are reused while they are large enough for the level asked for.
//!
//! **Numbering.** The output is the one of [`crate::tess::stitch::StitchPlan`] (records in
//! the order they first appear, patch after patch: corners, edges from their lower vertex
//! id, the interior in grid order), so the CPU and GPU paths give the same vertex and index
//! buffers up to the rounding of the evaluated samples. Shared vertices and edge samples
//! are written once, by the first patch that uses them (no cracks); where the input splits
//! normals (creases) an edge sample has one record per side, with that side's normal and
//! the owner's position. Corner samples are the input vertices rounded once to f32, bit for
//! bit.
//!
//! **The topology table.** Every item of that order (a corner record, a block of n − 1
//! edge records, a patch's interior) starts at `a + b (n − 1) + c (n − 1)(n − 2)/2`,
//! where `a`, `b` and `c` count the corner records, edge blocks and interiors before it,
//! none of which depends on the level n. [`Topology`] keeps `(a, b, c)` of every item a
//! patch refers to ([`TOPO_STRIDE`] u32 per patch), so one compute pass places every
//! sample and writes every triangle at any level, with no plan per level.
//!
//! **Per-edge levels.** [`GpuTessellator::tessellate_levels`] tessellates with a level per
//! edge and an inner level per patch ([`crate::tess::layout`]'s pattern, after OpenSubdiv
//! Bfr) from a device buffer of edge levels (as [`crate::gpu::screen::LevelPass`]
//! writes them from the camera, inner levels by an [`InnerRule`]) or from host
//! [`Levels`], with nothing read back: the same table serves, `b (n − 1)` and
//! `c (n − 1)(n − 2)/2` becoming the exclusive prefix sums, over edge blocks and over
//! patches in creation order, of each block's `E − 1` and each interior's
//! `(n' − 1)(n' − 2)/2` samples, computed on the device each time
//! (`shaders/tessellate_levels.wgsl`: inner levels, four prefix sums, the indirect draw
//! and dispatch arguments from their totals, one thread per sample, a serial walk of each
//! patch's pattern for its triangles). The output is
//! [`crate::tess::stitch::StitchPlan::with_levels`]'s numbering and triangles exactly.
//! Buffers are sized for a level cap (`max_level`) and reused while large enough.
//!
//! ```no_run
//! # fn demo(
//! #     device: &wgpu::Device,
//! #     queue: &wgpu::Queue,
//! #     pipeline: &wgpu::RenderPipeline,
//! #     target: &wgpu::TextureView,
//! # ) -> g1tess::Result<()> {
//! use g1tess::gpu::tessellator::GpuTessellator;
//! use g1tess::gpu::Precision;
//! use g1tess::mesh::Mesh;
//! use g1tess::patch::{PatchTable, Scheme};
//!
//! // Once: the patches, their upload and the topology table.
//! let mesh = Mesh::load("icosphere:2", &Default::default())?;
//! let table = PatchTable::build(&mesh, Scheme::G1, &Default::default())?;
//! let mut tess = GpuTessellator::new(device, queue, &mesh, &table, Precision::F32)?;
//!
//! // Every frame: tessellate at this frame's level and draw, in one encoder.
//! let level = 8;
//! let mut encoder = device.create_command_encoder(&Default::default());
//! tess.tessellate(device, queue, &mut encoder, level)?;
//! {
//!     let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
//!         label: Some("surface"),
//!         color_attachments: &[Some(wgpu::RenderPassColorAttachment {
//!             view: target,
//!             depth_slice: None,
//!             resolve_target: None,
//!             ops: wgpu::Operations::default(),
//!         })],
//!         depth_stencil_attachment: None,
//!         timestamp_writes: None,
//!         occlusion_query_set: None,
//!         multiview_mask: None,
//!     });
//!     // A pipeline whose vertex buffer 0 is g1tess::gpu::tessellator::vertex_layout():
//!     // @location(0) position, @location(1) unit normal, both vec3<f32>.
//!     pass.set_pipeline(pipeline);
//!     tess.draw(&mut pass); // vertex + index buffers, draw_indexed_indirect
//! }
//! queue.submit([encoder.finish()]);
//! # Ok(())
//! # }
//! ```

use std::collections::HashMap;

use crate::eval::{grid_barycentrics, grid_len};
use crate::gpu::eval::{basis_table, push_patch_data, Params, Real};
use crate::mesh::creases::{normal_key, split_ends};
use crate::mesh::{Adjacency, Mesh};
use crate::patch::{PatchKind, PatchTable};
use crate::tess::adaptive::{InnerRule, Levels};
use crate::tess::layout::MAX_LEVEL;
use crate::{Error, Result};

use super::shaders;
use super::Precision;

/// `shaders/tessellate.wgsl`, appended (after [`tess_header`]) to the evaluation module of
/// the patch kind.
pub const TESS_WGSL: &str = include_str!("../../shaders/tessellate.wgsl");

/// Threads per workgroup of the tessellation entry points.
pub const TESS_WORKGROUP: u32 = 64;
/// u32 per patch in the topology table.
pub const TOPO_STRIDE: usize = 36;
/// Offset of corner k's `(a, b, c, flags)`: `TOPO_CORNER + 4k`.
pub const TOPO_CORNER: usize = 0;
/// Offset of local edge k's `(a, b, c, flags, owner a, owner b, owner c)`: `TOPO_EDGE + 7k`.
pub const TOPO_EDGE: usize = 12;
/// Offset of the interior's `(a, b)` (its c is the patch index).
pub const TOPO_INTERIOR: usize = 33;
/// The patch writes the record (it created it).
pub const FLAG_WRITE: u32 = 1;
/// The local edge runs from the higher vertex id to the lower one.
pub const FLAG_REVERSED: u32 = 2;
/// Split normals: the records are this patch's, their positions the owner's.
pub const FLAG_COPY: u32 = 4;

/// Bytes of one vertex: position then unit normal, 3 f32 each.
pub const VERTEX_BYTES: u64 = 24;

/// The vertex attributes: location 0 position (`Float32x3`, offset 0), location 1 unit
/// normal (`Float32x3`, offset 12).
pub const VERTEX_ATTRIBUTES: [wgpu::VertexAttribute; 2] =
    wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3];

/// The layout of [`GpuTessellator::vertices`] for a render pipeline: stride 24 bytes, per
/// vertex, [`VERTEX_ATTRIBUTES`].
pub fn vertex_layout() -> wgpu::VertexBufferLayout<'static> {
    wgpu::VertexBufferLayout {
        array_stride: VERTEX_BYTES,
        step_mode: wgpu::VertexStepMode::Vertex,
        attributes: &VERTEX_ATTRIBUTES,
    }
}

/// The header the tessellation WGSL is appended after: the table layout and workgroup
/// size above, so `shaders/tessellate.wgsl` never copies the numbers.
pub fn tess_header() -> String {
    format!(
        "// generated by src/gpu/tessellator.rs (tess_header)\n\
         const TESS_WORKGROUP: u32 = {TESS_WORKGROUP}u;\n\
         const TOPO_STRIDE: u32 = {TOPO_STRIDE}u;\n\
         const TOPO_CORNER: u32 = {TOPO_CORNER}u;\n\
         const TOPO_EDGE: u32 = {TOPO_EDGE}u;\n\
         const TOPO_INTERIOR: u32 = {TOPO_INTERIOR}u;\n\
         const FLAG_WRITE: u32 = {FLAG_WRITE}u;\n\
         const FLAG_REVERSED: u32 = {FLAG_REVERSED}u;\n\
         const FLAG_COPY: u32 = {FLAG_COPY}u;\n"
    )
}

/// Complete WGSL of the tessellation module of `kind`: the evaluation module
/// ([`shaders::module_source`]), [`tess_header`], `shaders/tessellate.wgsl`.
pub fn tess_module_source(kind: PatchKind, precision: Precision) -> Result<String> {
    Ok(format!(
        "{}\n// ---- src/gpu/tessellator.rs ----\n{}\n// ---- shaders/tessellate.wgsl ----\n{}",
        shaders::module_source(kind, precision)?,
        tess_header(),
        TESS_WGSL
    ))
}

/// The level-independent numbering of the stitched output (module documentation).
#[derive(Clone, Debug)]
pub struct Topology {
    /// [`TOPO_STRIDE`] u32 per patch.
    pub table: Vec<u32>,
    /// Corner records (distinct (vertex, corner normal) pairs).
    pub corner_records: u32,
    /// Edge record blocks (one per edge, one more per extra side of a split edge).
    pub edge_blocks: u32,
    /// Blocks whose positions are copied from the owner's (split normals).
    pub copied_blocks: u32,
    pub patches: usize,
    /// Edge (index in the adjacency) of each record block, in creation order.
    pub block_edge: Vec<u32>,
    /// Edge (index in the adjacency) of local edge k of patch p, at 3p + k.
    pub patch_edges: Vec<u32>,
    /// Edges of the adjacency.
    pub edges: usize,
}

/// The record of one grid point: its id, the table's flags, and the record its position
/// comes from (the owner's where [`FLAG_COPY`], else itself).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Rec {
    pub id: u32,
    pub flags: u32,
    pub source: u32,
}

impl Topology {
    /// The table of `mesh` (whose adjacency is `adjacency`), numbered as
    /// [`crate::tess::stitch::StitchPlan::new`] numbers the output.
    pub fn new(mesh: &Mesh, adjacency: &Adjacency) -> Result<Topology> {
        let nf = mesh.triangles.len();
        if nf as u64 >= u32::MAX as u64 / 4 {
            return Err(Error::Invalid(format!(
                "{}: {nf} triangles are too many for 32-bit indices",
                mesh.name
            )));
        }
        let split: Vec<bool> = split_ends(mesh, adjacency)
            .iter()
            .map(|s| s[0] || s[1])
            .collect();
        const NONE: u32 = u32::MAX;
        let mut use_edge = vec![NONE; 3 * nf];
        let mut use_rev = vec![false; 3 * nf];
        for (e, edge) in adjacency.edges.iter().enumerate() {
            for u in &edge.uses {
                let i = 3 * u.triangle as usize + u.local as usize;
                use_edge[i] = e as u32;
                use_rev[i] = mesh.triangles[u.triangle as usize][u.local as usize] != edge.v[0];
            }
        }
        if let Some(u) = use_edge.iter().position(|&e| e == NONE) {
            return Err(Error::Invalid(format!(
                "{}: edge {} of triangle {} is missing from the adjacency",
                mesh.name,
                u % 3,
                u / 3
            )));
        }
        let mut table = vec![0u32; TOPO_STRIDE * nf];
        let mut groups: HashMap<(u32, [u64; 3]), [u32; 3]> = HashMap::new();
        let mut edge_block: Vec<Option<[u32; 3]>> = vec![None; adjacency.edges.len()];
        let (mut a, mut b, mut copied) = (0u32, 0u32, 0u32);
        let mut block_edge = Vec::with_capacity(adjacency.edges.len());
        for (t, tri) in mesh.triangles.iter().enumerate() {
            let row = &mut table[t * TOPO_STRIDE..(t + 1) * TOPO_STRIDE];
            let c = t as u32;
            for (k, &v) in tri.iter().enumerate() {
                let key = (v, normal_key(mesh.corner_normals[t][k]));
                let (abc, flags) = match groups.get(&key) {
                    Some(&abc) => (abc, 0),
                    None => {
                        let abc = [a, b, c];
                        groups.insert(key, abc);
                        a += 1;
                        (abc, FLAG_WRITE)
                    }
                };
                let o = TOPO_CORNER + 4 * k;
                row[o..o + 3].copy_from_slice(&abc);
                row[o + 3] = flags;
            }
            for k in 0..3 {
                let u = 3 * t + k;
                let e = use_edge[u] as usize;
                let rev = if use_rev[u] { FLAG_REVERSED } else { 0 };
                let (own, owner, flags) = match edge_block[e] {
                    None => {
                        let abc = [a, b, c];
                        edge_block[e] = Some(abc);
                        block_edge.push(e as u32);
                        b += 1;
                        (abc, abc, FLAG_WRITE)
                    }
                    Some(owner) if split[e] => {
                        let abc = [a, b, c];
                        block_edge.push(e as u32);
                        b += 1;
                        copied += 1;
                        (abc, owner, FLAG_WRITE | FLAG_COPY)
                    }
                    Some(owner) => (owner, owner, 0),
                };
                let o = TOPO_EDGE + 7 * k;
                row[o..o + 3].copy_from_slice(&own);
                row[o + 3] = flags | rev;
                row[o + 4..o + 7].copy_from_slice(&owner);
            }
            row[TOPO_INTERIOR] = a;
            row[TOPO_INTERIOR + 1] = b;
        }
        Ok(Topology {
            table,
            corner_records: a,
            edge_blocks: b,
            copied_blocks: copied,
            patches: nf,
            block_edge,
            patch_edges: use_edge,
            edges: adjacency.edges.len(),
        })
    }

    /// Vertex records at `level`: `a + b (n − 1) + patches (n − 1)(n − 2)/2` with the
    /// totals (exact, in u64).
    pub fn records(&self, level: u32) -> u64 {
        let n = level.max(1) as u64;
        self.corner_records as u64
            + self.edge_blocks as u64 * (n - 1)
            + self.patches as u64 * ((n - 1) * n.saturating_sub(2) / 2)
    }

    /// Triangle indices at `level`: 3 n² per patch.
    pub fn index_count(&self, level: u32) -> u64 {
        3 * self.patches as u64 * (level as u64).pow(2)
    }

    fn topo(&self, p: u32, o: usize) -> u32 {
        self.table[p as usize * TOPO_STRIDE + o]
    }

    fn item_base(&self, p: u32, o: usize, n: u32) -> u32 {
        let em = n - 1;
        let interior = em * n.saturating_sub(2) / 2;
        self.topo(p, o) + self.topo(p, o + 1) * em + self.topo(p, o + 2) * interior
    }

    /// The triangles of every patch at `level` as record ids, in the order the GPU writes
    /// them ([`grid_triangle_index`]); the CPU mirror of the index buffer.
    pub fn triangles(&self, level: u32) -> Vec<[u32; 3]> {
        let n = level.max(1);
        let mut out = vec![[0u32; 3]; self.patches * (n * n) as usize];
        for p in 0..self.patches as u32 {
            let base = p as usize * (n * n) as usize;
            for j in 0..n {
                for i in 0..n - j {
                    let t = base + grid_triangle_index(n, i, j) as usize;
                    let a = record_of(self, p, n, i, j).id;
                    let b = record_of(self, p, n, i + 1, j).id;
                    let c = record_of(self, p, n, i, j + 1).id;
                    out[t] = [a, b, c];
                    if i + j + 1 < n {
                        out[t + 1] = [b, record_of(self, p, n, i + 1, j + 1).id, c];
                    }
                }
            }
        }
        out
    }
}

/// Record of grid point (i, j) (b1 = i/n, b2 = j/n) of patch `p` at level `n`, from the
/// table alone (`record_of` of `shaders/tessellate.wgsl` mirrors it).
pub fn record_of(topology: &Topology, p: u32, n: u32, i: u32, j: u32) -> Rec {
    let em = n - 1;
    let corner = match (i, j) {
        (0, 0) => Some(0),
        (i, 0) if i == n => Some(1),
        (0, j) if j == n => Some(2),
        _ => None,
    };
    if let Some(k) = corner {
        let o = TOPO_CORNER + 4 * k;
        let id = topology.item_base(p, o, n);
        return Rec {
            id,
            flags: topology.topo(p, o + 3),
            source: id,
        };
    }
    let edge = if j == 0 {
        Some((0, i))
    } else if i + j == n {
        Some((1, j))
    } else if i == 0 {
        Some((2, n - j))
    } else {
        None
    };
    if let Some((k, s)) = edge {
        let o = TOPO_EDGE + 7 * k;
        let flags = topology.topo(p, o + 3);
        let m = if flags & FLAG_REVERSED != 0 {
            em - s
        } else {
            s - 1
        };
        let id = topology.item_base(p, o, n) + m;
        let source = if flags & FLAG_COPY != 0 {
            topology.item_base(p, o + 4, n) + m
        } else {
            id
        };
        return Rec { id, flags, source };
    }
    let interior = em * n.saturating_sub(2) / 2;
    let base =
        topology.topo(p, TOPO_INTERIOR) + topology.topo(p, TOPO_INTERIOR + 1) * em + p * interior;
    let id = base + (j - 1) * em - (j - 1) * j / 2 + i - 1;
    Rec {
        id,
        flags: FLAG_WRITE,
        source: id,
    }
}

/// Index of the upward triangle of grid point (i, j) among a patch's n² triangles in
/// [`crate::eval::grid_triangles`] order (the downward one, where there is one, follows):
/// row j starts at `2 n j − j²`.
pub fn grid_triangle_index(n: u32, i: u32, j: u32) -> u32 {
    2 * n * j - j * j + 2 * i
}

/// What one tessellation produced.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TessCounts {
    pub level: u32,
    /// Vertex records written (entries of [`GpuTessellator::vertices`]).
    pub vertices: u32,
    /// Indices written (3 per triangle).
    pub indices: u32,
}

impl TessCounts {
    pub fn triangles(&self) -> u32 {
        self.indices / 3
    }
}

/// `Tess` of `shaders/tessellate.wgsl`, byte for byte.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct TessUniform {
    pub main_count: u32,
    pub main_groups_x: u32,
    pub copy_count: u32,
    pub copy_groups_x: u32,
    pub bounds_count: u32,
    pub bounds_groups_x: u32,
    pub pad: [u32; 2],
    pub axes: [[f32; 4]; 3],
}

/// `shaders/tessellate_levels.wgsl`: per-edge tessellation, appended (after
/// [`tess_header`]) to the evaluation module of the patch kind.
pub const TESS_LEVELS_WGSL: &str = include_str!("../../shaders/tessellate_levels.wgsl");

/// Complete WGSL of the per-edge tessellation module of `kind`: the evaluation module,
/// [`tess_header`], `shaders/tessellate_levels.wgsl`.
pub fn tess_levels_module_source(kind: PatchKind, precision: Precision) -> Result<String> {
    Ok(format!(
        "{}\n// ---- src/gpu/tessellator.rs ----\n{}\n// ---- shaders/tessellate_levels.wgsl ----\n{}",
        shaders::module_source(kind, precision)?,
        tess_header(),
        TESS_LEVELS_WGSL
    ))
}

/// Where [`GpuTessellator::tessellate_levels`] takes its levels from.
#[derive(Clone, Copy, Debug)]
pub enum LevelSource<'a> {
    /// A device buffer (`STORAGE`) of one u32 level per edge of the mesh's adjacency, as
    /// [`crate::gpu::screen::LevelPass`] writes it; inner levels by `rule`. Levels are
    /// clamped to 1..=max_level on the device.
    Device {
        levels: &'a wgpu::Buffer,
        rule: InnerRule,
    },
    /// Levels on the host (edge and inner levels in 1..=max_level), uploaded.
    Host(&'a Levels),
}

/// Offsets (u32) in [`GpuTessellator::level_state`]: the totals (block samples, interior
/// samples, patch samples, triangles).
pub const LV_STATE_TOTALS: usize = 0;
/// The `draw_indexed_indirect` arguments (also copied to [`GpuTessellator::indirect`]).
pub const LV_STATE_DRAW: usize = 4;
/// The vertex records written.
pub const LV_STATE_RECORDS: usize = 12;
/// u32 at the head of the state buffer.
const LV_STATE_HEAD: usize = 16;
/// Workgroups of the scan pass: one per prefix sum.
const LV_SCANS: u32 = 4;

/// `Lv` of `shaders/tessellate_levels.wgsl`, byte for byte.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
struct LvUniform {
    patches: u32,
    blocks: u32,
    edges: u32,
    max_level: u32,
    rule: u32,
    patch_groups_x: u32,
    max_groups: u32,
    corner_records: u32,
    pinfo: u32,
    block_off: u32,
    int_off: u32,
    pt_off: u32,
    tri_off: u32,
    copy_groups_x: u32,
    pad: [u32; 2],
}

/// Upper bounds of one per-edge tessellation with levels up to `max_level`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LevelCapacity {
    pub max_level: u32,
    /// Vertex records at most (the exact count is at [`LV_STATE_RECORDS`] on the device).
    pub vertices: u64,
    /// Indices at most (the exact count is in the indirect arguments).
    pub indices: u64,
    /// Samples evaluated at most.
    pub samples: u64,
}

/// Pipelines and buffers of per-edge tessellation (made on first use).
struct LevelTess {
    max_level: u32,
    layout1: wgpu::BindGroupLayout,
    patch: wgpu::ComputePipeline,
    scan: wgpu::ComputePipeline,
    finish: wgpu::ComputePipeline,
    points: wgpu::ComputePipeline,
    triangles: wgpu::ComputePipeline,
    /// Group 0 of the per-edge passes: its own parameters and basis table.
    group0: wgpu::BindGroup,
    copy: wgpu::ComputePipeline,
    uniform: wgpu::Buffer,
    statics: wgpu::Buffer,
    state: wgpu::Buffer,
    dispatch: wgpu::Buffer,
    host_levels: wgpu::Buffer,
}

impl Topology {
    /// Upper bounds of a per-edge tessellation whose levels are at most `max_level`: the
    /// pattern raises inner levels to 3 at least, so L = max(max_level, 3) bounds the inner
    /// level, L² the triangles of a patch.
    pub fn level_capacity(&self, max_level: u32) -> LevelCapacity {
        let m = max_level.max(1) as u64;
        let l = m.max(3);
        let interior = (l - 1) * (l - 2) / 2;
        let p = self.patches as u64;
        LevelCapacity {
            max_level,
            vertices: self.corner_records as u64 + self.edge_blocks as u64 * (m - 1) + p * interior,
            indices: 3 * p * l * l,
            samples: p * (3 * m + interior),
        }
    }
}

/// Grids whose basis table is at most this large read it (computed once per level on the
/// CPU); finer levels compute the basis in the shader.
pub const MAX_GRID_TABLE_BYTES: u64 = 32 << 20;

/// The tessellator: pipelines, the uploaded patch data and topology, the output buffers.
pub struct GpuTessellator {
    kind: PatchKind,
    precision: Precision,
    topology: Topology,
    max_binding: u64,
    max_groups: u32,
    layout0: wgpu::BindGroupLayout,
    layout1: wgpu::BindGroupLayout,
    main_table: wgpu::ComputePipeline,
    main_basis: wgpu::ComputePipeline,
    copy: wgpu::ComputePipeline,
    bounds_pipeline: wgpu::ComputePipeline,
    params: wgpu::Buffer,
    patch_data: wgpu::Buffer,
    grid_w: wgpu::Buffer,
    tess_uniform: wgpu::Buffer,
    topo_buffer: wgpu::Buffer,
    vertices: wgpu::Buffer,
    indices: wgpu::Buffer,
    indirect: wgpu::Buffer,
    bounds: wgpu::Buffer,
    group0: wgpu::BindGroup,
    group1: wgpu::BindGroup,
    uniform: TessUniform,
    counts: Option<TessCounts>,
    levels: Option<LevelTess>,
}

/// Bytes rounded up to a multiple of 16, at least 16.
fn padded(bytes: u64) -> u64 {
    bytes.max(16).div_ceil(16) * 16
}

/// A buffer of at least `size` bytes ([`padded`]).
fn new_buffer(
    device: &wgpu::Device,
    label: &str,
    size: u64,
    usage: wgpu::BufferUsages,
) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: padded(size),
        usage,
        mapped_at_creation: false,
    })
}

/// Replaces `buf` with a new buffer of `bytes` when it is smaller; true when it did (its
/// bind group must then be made again).
fn grow(
    device: &wgpu::Device,
    buf: &mut wgpu::Buffer,
    bytes: u64,
    label: &str,
    usage: wgpu::BufferUsages,
) -> bool {
    if buf.size() >= bytes {
        return false;
    }
    *buf = new_buffer(device, label, bytes, usage);
    true
}

/// Validates the WGSL generated from shaders/`file` for `kind` and makes its module.
fn checked_module(
    device: &wgpu::Device,
    file: &str,
    kind: PatchKind,
    precision: Precision,
    source: String,
) -> Result<wgpu::ShaderModule> {
    shaders::validate(&source, precision)
        .map_err(|e| Error::Gpu(format!("shaders/{file} ({kind:?}): {e}")))?;
    Ok(device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(file),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    }))
}

/// The compute pipeline of `module`'s entry point `entry`.
fn compute_pipeline(
    device: &wgpu::Device,
    layout: &wgpu::PipelineLayout,
    module: &wgpu::ShaderModule,
    entry: &str,
) -> wgpu::ComputePipeline {
    device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(entry),
        layout: Some(layout),
        module,
        entry_point: Some(entry),
        compilation_options: Default::default(),
        cache: None,
    })
}

fn entry(binding: u32, ty: wgpu::BindingType) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty,
        count: None,
    }
}

fn uniform_ty() -> wgpu::BindingType {
    wgpu::BindingType::Buffer {
        ty: wgpu::BufferBindingType::Uniform,
        has_dynamic_offset: false,
        min_binding_size: None,
    }
}

fn storage_ty(read_only: bool) -> wgpu::BindingType {
    wgpu::BindingType::Buffer {
        ty: wgpu::BufferBindingType::Storage { read_only },
        has_dynamic_offset: false,
        min_binding_size: None,
    }
}

fn patch_bytes<R: Real>(table: &PatchTable) -> Vec<u8> {
    let mut out: Vec<R> = Vec::with_capacity(table.len() * 3 * shaders::patch_vecs(table.kind));
    for i in 0..table.len() {
        push_patch_data(table, i, &mut out);
    }
    bytemuck::cast_slice(&out).to_vec()
}

/// The basis of every grid point of `level`, laid out as `eval_table` of
/// `shaders/common.wgsl` reads it.
fn grid_weight_bytes<R: Real>(kind: PatchKind, level: u32) -> Vec<u8> {
    bytemuck::cast_slice(&basis_table::<R>(kind, &grid_barycentrics(level))).to_vec()
}

/// First point of the grid of level `l` in the per-edge basis table: the points of the
/// grids of levels 1..l − 1, l (l + 1)(l + 2)/6 − 1.
pub fn level_grid_base(l: u32) -> u64 {
    let l = l as u64;
    l * (l + 1) * (l + 2) / 6 - 1
}

/// The basis of every point of the grids of levels 1..=`top`, level after level, laid out
/// as `eval_table` of `shaders/common.wgsl` reads it (per = all the points).
fn level_weight_bytes<R: Real>(kind: PatchKind, top: u32) -> Vec<u8> {
    // Level l's grid starts at `level_grid_base(l)`: the grids of levels 1..=top in order.
    let points: Vec<[f64; 3]> = (1..=top).flat_map(grid_barycentrics).collect();
    debug_assert_eq!(points.len() as u64, level_grid_base(top + 1));
    bytemuck::cast_slice(&basis_table::<R>(kind, &points)).to_vec()
}

/// Workgroups (x, y) for `count` threads, at most `max` per dimension.
fn groups(count: u32, max: u32) -> Result<(u32, u32)> {
    let g = count.div_ceil(TESS_WORKGROUP).max(1);
    let x = g.min(max.max(1));
    let y = g.div_ceil(x);
    if y > max {
        return Err(Error::Gpu(format!(
            "{count} tessellation threads need more than {max} × {max} workgroups"
        )));
    }
    Ok((x, y))
}

impl GpuTessellator {
    /// Builds the pipelines of `table`'s patch kind in `precision` on the host's device and
    /// uploads the patch data and the topology of `mesh` (the table's mesh). Errors when the
    /// device lacks what the shaders need (`SHADER_F64` for f64, storage buffers in compute
    /// shaders) or a buffer exceeds its limits.
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        mesh: &Mesh,
        table: &PatchTable,
        precision: Precision,
    ) -> Result<GpuTessellator> {
        if table.len() != mesh.triangles.len() {
            return Err(Error::Invalid(format!(
                "{}: a patch table of {} patches for {} triangles",
                mesh.name,
                table.len(),
                mesh.triangles.len()
            )));
        }
        if precision == Precision::F64 && !device.features().contains(wgpu::Features::SHADER_F64) {
            return Err(Error::Gpu(
                "the device was opened without SHADER_F64: f64 tessellation needs it \
                 (request the feature when the adapter offers it); f32 works"
                    .into(),
            ));
        }
        let limits = device.limits();
        if limits.max_storage_buffers_per_shader_stage < 6 || limits.max_bind_groups < 2 {
            return Err(Error::Gpu(format!(
                "tessellation needs 6 storage buffers per compute shader and 2 bind groups; \
                 the device allows {} and {}",
                limits.max_storage_buffers_per_shader_stage, limits.max_bind_groups
            )));
        }
        let max_binding = (limits.max_storage_buffer_binding_size).min(limits.max_buffer_size);
        let max_groups = limits.max_compute_workgroups_per_dimension;
        let topology = Topology::new(mesh, &mesh.adjacency())?;
        let module = checked_module(
            device,
            "tessellate.wgsl",
            table.kind,
            precision,
            tess_module_source(table.kind, precision)?,
        )?;
        let layout0 = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("g1tess tessellate eval"),
            entries: &[
                entry(0, uniform_ty()),
                entry(1, storage_ty(true)),
                entry(4, storage_ty(true)),
            ],
        });
        let layout1 = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("g1tess tessellate"),
            entries: &[
                entry(0, uniform_ty()),
                entry(1, storage_ty(true)),
                entry(2, storage_ty(false)),
                entry(3, storage_ty(false)),
                entry(4, storage_ty(false)),
            ],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("g1tess tessellate"),
            bind_group_layouts: &[Some(&layout0), Some(&layout1)],
            immediate_size: 0,
        });
        let make = |entry: &str| compute_pipeline(device, &pipeline_layout, &module, entry);
        let data = match precision {
            Precision::F32 => patch_bytes::<f32>(table),
            Precision::F64 => patch_bytes::<f64>(table),
        };
        let topo_bytes: &[u8] = bytemuck::cast_slice(&topology.table);
        for (what, bytes) in [("patch data", data.len()), ("topology", topo_bytes.len())] {
            if bytes as u64 > max_binding {
                return Err(Error::Gpu(format!(
                    "{}: the {what} of {} patches takes {bytes} bytes, over the device's \
                     storage binding limit of {max_binding}",
                    mesh.name,
                    table.len()
                )));
            }
        }
        use wgpu::BufferUsages as U;
        let buffer = |label, size: u64, usage| new_buffer(device, label, size, usage);
        let params = buffer(
            "tess params",
            std::mem::size_of::<Params>() as u64,
            U::UNIFORM | U::COPY_DST,
        );
        let patch_data = buffer(
            "tess patch data",
            data.len() as u64,
            U::STORAGE | U::COPY_DST,
        );
        queue.write_buffer(&patch_data, 0, &data);
        let topo_buffer = buffer(
            "tess topology",
            topo_bytes.len() as u64,
            U::STORAGE | U::COPY_DST,
        );
        queue.write_buffer(&topo_buffer, 0, topo_bytes);
        let grid_w = buffer("tess grid weights", 16, U::STORAGE | U::COPY_DST);
        let tess_uniform = buffer(
            "tess uniform",
            std::mem::size_of::<TessUniform>() as u64,
            U::UNIFORM | U::COPY_DST,
        );
        let vertices = buffer("tess vertices", 16, Self::VERTEX_USAGE);
        let indices = buffer("tess indices", 16, Self::INDEX_USAGE);
        let indirect = buffer(
            "tess indirect",
            std::mem::size_of::<wgpu::util::DrawIndexedIndirectArgs>() as u64,
            U::INDIRECT | U::COPY_DST | U::COPY_SRC,
        );
        let bounds = buffer("tess bounds", 24, U::STORAGE | U::COPY_SRC | U::COPY_DST);
        let group0 = Self::bind0(device, &layout0, &params, &patch_data, &grid_w);
        let group1 = Self::bind1(
            device,
            &layout1,
            &tess_uniform,
            &topo_buffer,
            &vertices,
            &indices,
            &bounds,
        );
        Ok(GpuTessellator {
            kind: table.kind,
            precision,
            topology,
            max_binding,
            max_groups,
            main_table: make("tess_main"),
            main_basis: make("tess_basis_main"),
            copy: make("tess_copy_main"),
            bounds_pipeline: make("tess_bounds_main"),
            layout0,
            layout1,
            params,
            patch_data,
            grid_w,
            tess_uniform,
            topo_buffer,
            vertices,
            indices,
            indirect,
            bounds,
            group0,
            group1,
            uniform: TessUniform::default(),
            counts: None,
            levels: None,
        })
    }

    /// Usage of the vertex buffer.
    pub const VERTEX_USAGE: wgpu::BufferUsages = wgpu::BufferUsages::VERTEX
        .union(wgpu::BufferUsages::STORAGE)
        .union(wgpu::BufferUsages::COPY_SRC)
        .union(wgpu::BufferUsages::COPY_DST);
    /// Usage of the index buffer.
    pub const INDEX_USAGE: wgpu::BufferUsages = wgpu::BufferUsages::INDEX
        .union(wgpu::BufferUsages::STORAGE)
        .union(wgpu::BufferUsages::COPY_SRC)
        .union(wgpu::BufferUsages::COPY_DST);

    fn bind0(
        device: &wgpu::Device,
        layout: &wgpu::BindGroupLayout,
        params: &wgpu::Buffer,
        patch_data: &wgpu::Buffer,
        grid_w: &wgpu::Buffer,
    ) -> wgpu::BindGroup {
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("g1tess tessellate eval"),
            layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: params.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: patch_data.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 4,
                    resource: grid_w.as_entire_binding(),
                },
            ],
        })
    }

    fn bind1(
        device: &wgpu::Device,
        layout: &wgpu::BindGroupLayout,
        uniform: &wgpu::Buffer,
        topology: &wgpu::Buffer,
        vertices: &wgpu::Buffer,
        indices: &wgpu::Buffer,
        bounds: &wgpu::Buffer,
    ) -> wgpu::BindGroup {
        let entries: Vec<wgpu::BindGroupEntry<'_>> = [uniform, topology, vertices, indices, bounds]
            .into_iter()
            .enumerate()
            .map(|(b, buf)| wgpu::BindGroupEntry {
                binding: b as u32,
                resource: buf.as_entire_binding(),
            })
            .collect();
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("g1tess tessellate"),
            layout,
            entries: &entries,
        })
    }

    /// Whether level `level` (≥ 1) fits: 32-bit indices and thread counts, and the vertex
    /// and index buffers within the device's storage binding limit (the error says which).
    pub fn check_level(&self, level: u32) -> Result<()> {
        if level == 0 {
            return Err(Error::Invalid(
                "tessellation level must be at least 1".into(),
            ));
        }
        let topo = &self.topology;
        let records = topo.records(level);
        let index_count = topo.index_count(level);
        let per = grid_len(level) as u64;
        let threads = topo.patches as u64 * per;
        let copy_threads = topo.patches as u64 * 3 * (level as u64 - 1);
        if records >= u32::MAX as u64
            || index_count >= u32::MAX as u64
            || threads >= u32::MAX as u64
            || copy_threads >= u32::MAX as u64
        {
            return Err(Error::Invalid(format!(
                "level {level} on {} patches exceeds 32-bit vertex indices",
                topo.patches
            )));
        }
        let vertex_bytes = records * VERTEX_BYTES;
        let index_bytes = index_count * 4;
        for (what, bytes) in [("vertex", vertex_bytes), ("index", index_bytes)] {
            if bytes > self.max_binding {
                return Err(Error::Gpu(format!(
                    "level {level} on {} patches needs a {} MB {what} buffer, over the \
                     device's storage binding limit of {} MB",
                    topo.patches,
                    bytes / 1_000_000,
                    self.max_binding / 1_000_000
                )));
            }
        }
        Ok(())
    }

    /// Records the tessellation at grid level `level` (≥ 1) into `encoder`: the vertex,
    /// index and indirect buffers hold the welded surface once the encoder's work has run.
    /// The level's parameters (and its basis table) are written with `queue.write_buffer`,
    /// so submit the encoder before tessellating again. Buffers are reused while large
    /// enough; a finer level allocates larger ones (call [`GpuTessellator::vertices`] and
    /// [`GpuTessellator::indices`] again after this).
    pub fn tessellate(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        level: u32,
    ) -> Result<TessCounts> {
        self.check_level(level)?;
        let topo = &self.topology;
        let records = topo.records(level);
        let index_count = topo.index_count(level);
        let per = grid_len(level) as u64;
        let threads = topo.patches as u64 * per;
        let copy_threads = topo.patches as u64 * 3 * (level as u64 - 1);
        let vertex_bytes = records * VERTEX_BYTES;
        let index_bytes = index_count * 4;
        let rb = self.precision.bytes() as u64;
        let table_bytes = per * self.kind.stride() as u64 * 3 * rb;
        let use_table = table_bytes <= MAX_GRID_TABLE_BYTES.min(self.max_binding);
        use wgpu::BufferUsages as U;
        let mut rebind0 = false;
        if use_table {
            rebind0 = grow(
                device,
                &mut self.grid_w,
                table_bytes,
                "tess grid weights",
                U::STORAGE | U::COPY_DST,
            );
            let w = match self.precision {
                Precision::F32 => grid_weight_bytes::<f32>(self.kind, level),
                Precision::F64 => grid_weight_bytes::<f64>(self.kind, level),
            };
            queue.write_buffer(&self.grid_w, 0, &w);
        }
        if rebind0 {
            self.group0 = Self::bind0(
                device,
                &self.layout0,
                &self.params,
                &self.patch_data,
                &self.grid_w,
            );
        }
        let grew_vertices = grow(
            device,
            &mut self.vertices,
            vertex_bytes,
            "tess vertices",
            Self::VERTEX_USAGE,
        );
        let grew_indices = grow(
            device,
            &mut self.indices,
            index_bytes,
            "tess indices",
            Self::INDEX_USAGE,
        );
        if grew_vertices || grew_indices {
            self.group1 = Self::bind1(
                device,
                &self.layout1,
                &self.tess_uniform,
                &self.topo_buffer,
                &self.vertices,
                &self.indices,
                &self.bounds,
            );
        }
        let (mx, my) = groups(threads as u32, self.max_groups)?;
        let (cx, cy) = groups(copy_threads as u32, self.max_groups)?;
        let params = Params {
            count: threads as u32,
            first_local: 0,
            level,
            per: per as u32,
            groups_x: mx,
            _pad: [0; 3],
        };
        queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
        self.uniform = TessUniform {
            main_count: threads as u32,
            main_groups_x: mx,
            copy_count: copy_threads as u32,
            copy_groups_x: cx,
            ..TessUniform::default()
        };
        queue.write_buffer(&self.tess_uniform, 0, bytemuck::bytes_of(&self.uniform));
        let args = wgpu::util::DrawIndexedIndirectArgs {
            index_count: index_count as u32,
            instance_count: 1,
            first_index: 0,
            base_vertex: 0,
            first_instance: 0,
        };
        queue.write_buffer(&self.indirect, 0, args.as_bytes());
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("g1tess tessellate"),
                timestamp_writes: None,
            });
            pass.set_pipeline(if use_table {
                &self.main_table
            } else {
                &self.main_basis
            });
            pass.set_bind_group(0, &self.group0, &[]);
            pass.set_bind_group(1, &self.group1, &[]);
            pass.dispatch_workgroups(mx, my, 1);
        }
        if self.topology.copied_blocks > 0 && copy_threads > 0 {
            // A pass of its own: the owners' positions are written by the one above.
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("g1tess tessellate split normals"),
                timestamp_writes: None,
            });
            pass.set_pipeline(&self.copy);
            pass.set_bind_group(0, &self.group0, &[]);
            pass.set_bind_group(1, &self.group1, &[]);
            pass.dispatch_workgroups(cx, cy, 1);
        }
        let counts = TessCounts {
            level,
            vertices: records as u32,
            indices: index_count as u32,
        };
        self.counts = Some(counts);
        Ok(counts)
    }

    /// Builds the per-edge pipelines and buffers for levels up to `max_level`, or reuses
    /// those built while large enough.
    fn level_tess(&mut self, device: &wgpu::Device, max_level: u32) -> Result<()> {
        if let Some(lt) = &self.levels {
            if lt.max_level >= max_level {
                return Ok(());
            }
        }
        let topo = &self.topology;
        let module = checked_module(
            device,
            "tessellate_levels.wgsl",
            self.kind,
            self.precision,
            tess_levels_module_source(self.kind, self.precision)?,
        )?;
        let layout1 = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("g1tess tessellate levels"),
            entries: &[
                entry(0, uniform_ty()),
                entry(1, storage_ty(true)),
                entry(2, storage_ty(false)),
                entry(3, storage_ty(false)),
                entry(4, storage_ty(true)),
                entry(5, storage_ty(true)),
                entry(6, storage_ty(false)),
            ],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("g1tess tessellate levels"),
            bind_group_layouts: &[Some(&self.layout0), Some(&layout1)],
            immediate_size: 0,
        });
        let make = |entry: &str| compute_pipeline(device, &pipeline_layout, &module, entry);
        use wgpu::BufferUsages as U;
        let buffer = |label, size: u64, usage| new_buffer(device, label, size, usage);
        let mut statics_data: Vec<u32> = topo
            .patch_edges
            .iter()
            .chain(&topo.block_edge)
            .copied()
            .collect();
        // Bindings are never empty.
        statics_data.resize(statics_data.len().max(4), 0);
        let statics = wgpu::util::DeviceExt::create_buffer_init(
            device,
            &wgpu::util::BufferInitDescriptor {
                label: Some("tess level statics"),
                contents: bytemuck::cast_slice(&statics_data),
                usage: U::STORAGE,
            },
        );
        // The basis of every grid level up to the cap (every sample of the pattern is a
        // point of one of them), as eval_table reads it; computed in the shader where too
        // large.
        let top = max_level.max(3);
        let per = level_grid_base(top + 1);
        let rb = self.precision.bytes() as u64;
        let table_bytes = per * self.kind.stride() as u64 * 3 * rb;
        let use_table = table_bytes <= MAX_GRID_TABLE_BYTES.min(self.max_binding);
        let grid_w = if use_table {
            let bytes = match self.precision {
                Precision::F32 => level_weight_bytes::<f32>(self.kind, top),
                Precision::F64 => level_weight_bytes::<f64>(self.kind, top),
            };
            wgpu::util::DeviceExt::create_buffer_init(
                device,
                &wgpu::util::BufferInitDescriptor {
                    label: Some("tess level weights"),
                    contents: &bytes,
                    usage: U::STORAGE,
                },
            )
        } else {
            buffer("tess level weights", 16, U::STORAGE)
        };
        let params = Params {
            count: 0,
            first_local: 0,
            level: top,
            per: per as u32,
            groups_x: 0,
            _pad: [0; 3],
        };
        let params = wgpu::util::DeviceExt::create_buffer_init(
            device,
            &wgpu::util::BufferInitDescriptor {
                label: Some("tess level params"),
                contents: bytemuck::bytes_of(&params),
                usage: U::UNIFORM,
            },
        );
        let group0 = Self::bind0(device, &self.layout0, &params, &self.patch_data, &grid_w);
        let p = topo.patches as u64;
        let state_len = LV_STATE_HEAD as u64 + 4 * p + topo.edge_blocks as u64 + 1 + 3 * p;
        let lt = LevelTess {
            max_level,
            patch: make("lv_patch_main"),
            scan: make("lv_scan_main"),
            finish: make("lv_finish_main"),
            points: make(if use_table {
                "lv_points_main"
            } else {
                "lv_points_basis_main"
            }),
            group0,
            triangles: make("lv_triangles_main"),
            copy: make("lv_copy_main"),
            layout1,
            uniform: buffer(
                "tess level uniform",
                std::mem::size_of::<LvUniform>() as u64,
                U::UNIFORM | U::COPY_DST,
            ),
            statics,
            state: buffer(
                "tess level state",
                4 * state_len,
                U::STORAGE | U::COPY_SRC | U::COPY_DST,
            ),
            dispatch: buffer("tess level dispatch", 12, U::INDIRECT | U::COPY_DST),
            host_levels: buffer(
                "tess host levels",
                4 * (topo.edges as u64 + p),
                U::STORAGE | U::COPY_DST,
            ),
        };
        self.levels = Some(lt);
        Ok(())
    }

    /// Whether levels up to `max_level` fit: 32-bit indices and thread counts, and the
    /// vertex and index buffers within the device's storage binding limit.
    pub fn check_max_level(&self, max_level: u32) -> Result<LevelCapacity> {
        if max_level == 0 || max_level > MAX_LEVEL {
            return Err(Error::Invalid(format!(
                "a level cap of {max_level} is outside 1..={MAX_LEVEL}"
            )));
        }
        let topo = &self.topology;
        let cap = topo.level_capacity(max_level);
        if cap.vertices >= u32::MAX as u64
            || cap.indices >= u32::MAX as u64
            || cap.samples >= u32::MAX as u64
        {
            return Err(Error::Invalid(format!(
                "levels up to {max_level} on {} patches exceed 32-bit vertex indices",
                topo.patches
            )));
        }
        for (what, bytes) in [
            ("vertex", cap.vertices * VERTEX_BYTES),
            ("index", cap.indices * 4),
        ] {
            if bytes > self.max_binding {
                return Err(Error::Gpu(format!(
                    "levels up to {max_level} on {} patches need a {} MB {what} buffer, over \
                     the device's storage binding limit of {} MB",
                    topo.patches,
                    bytes / 1_000_000,
                    self.max_binding / 1_000_000
                )));
            }
        }
        Ok(cap)
    }

    /// Records the tessellation with a level per edge into `encoder`, with nothing read
    /// back: inner levels, the prefix sums that number the output
    /// ([`crate::tess::stitch::StitchPlan::with_levels`]'s numbering exactly), the
    /// samples, the triangles ([`crate::tess::layout`]'s pattern) and the indirect draw
    /// arguments are all computed on the device. Buffers are sized for levels up to
    /// `max_level` (levels above it are clamped to it) and reused while large enough;
    /// call [`GpuTessellator::vertices`] and [`GpuTessellator::indices`] again after this.
    /// Host levels are written with `queue.write_buffer`, so submit the encoder before
    /// tessellating again. The exact counts stay on the device: the indirect arguments and
    /// [`GpuTessellator::level_state`].
    ///
    /// Screen-space levels every frame, computed and used on the device:
    ///
    /// ```no_run
    /// # fn demo(
    /// #     device: &wgpu::Device,
    /// #     queue: &wgpu::Queue,
    /// #     tess: &mut g1tess::gpu::tessellator::GpuTessellator,
    /// #     // LevelPass bindings: positions (vec4<f32> per vertex), edges (the two
    /// #     // vertex ids of each adjacency edge), levels (u32 per edge, STORAGE).
    /// #     positions: &wgpu::Buffer,
    /// #     edges: &wgpu::Buffer,
    /// #     levels: &wgpu::Buffer,
    /// #     params: &wgpu::Buffer,
    /// #     edge_count: u32,
    /// #     view_proj: glam::DMat4,
    /// # ) -> g1tess::Result<()> {
    /// use g1tess::gpu::tessellator::LevelSource;
    /// use g1tess::tess::adaptive::InnerRule;
    /// use g1tess::tess::screen::ScreenView;
    /// use g1tess::gpu::screen::{LevelParams, LevelPass};
    ///
    /// let pass = LevelPass::new(device)?; // once
    /// let max_level = 16;
    /// // Every frame: levels from the camera, then the tessellation, in one encoder.
    /// let view = ScreenView { view_proj, viewport: [1280.0, 720.0], target_px: 8.0, max_level };
    /// let groups = LevelPass::groups(edge_count, device.limits().max_compute_workgroups_per_dimension);
    /// let mut p = LevelParams::new(&view, edge_count);
    /// p.groups_x = groups.0;
    /// queue.write_buffer(params, 0, bytemuck::bytes_of(&p));
    /// let mut encoder = device.create_command_encoder(&Default::default());
    /// pass.record(device, &mut encoder, [params, positions, edges, levels], groups);
    /// let source = LevelSource::Device { levels, rule: InnerRule::Max };
    /// tess.tessellate_levels(device, queue, &mut encoder, source, max_level)?;
    /// // ... a render pass: tess.draw(&mut pass) (draw_indexed_indirect) ...
    /// queue.submit([encoder.finish()]);
    /// # Ok(())
    /// # }
    /// ```
    pub fn tessellate_levels(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        source: LevelSource<'_>,
        max_level: u32,
    ) -> Result<LevelCapacity> {
        let cap = self.check_max_level(max_level)?;
        let topo = &self.topology;
        let (ne, np) = (topo.edges, topo.patches);
        let rule = match source {
            LevelSource::Device { levels, rule } => {
                if levels.size() < 4 * ne as u64 {
                    return Err(Error::Invalid(format!(
                        "a level buffer of {} bytes for {ne} edges (4 bytes each)",
                        levels.size()
                    )));
                }
                match rule {
                    InnerRule::Max => 0,
                    InnerRule::Mean => 1,
                    InnerRule::Min => 2,
                }
            }
            LevelSource::Host(l) => {
                if l.edges.len() != ne || l.inner.len() != np {
                    return Err(Error::Invalid(format!(
                        "{} edge and {} inner levels for {ne} edges and {np} patches",
                        l.edges.len(),
                        l.inner.len()
                    )));
                }
                let bad = l.edges.iter().enumerate().map(|(e, &v)| ("edge", e, v));
                let bad = bad.chain(l.inner.iter().enumerate().map(|(p, &v)| ("patch", p, v)));
                if let Some((what, i, v)) = bad.into_iter().find(|t| t.2 == 0 || t.2 > max_level) {
                    return Err(Error::Invalid(format!(
                        "level {v} of {what} {i} is outside 1..={max_level}"
                    )));
                }
                3
            }
        };
        self.level_tess(device, max_level)?;
        let a = grow(
            device,
            &mut self.vertices,
            cap.vertices * VERTEX_BYTES,
            "tess vertices",
            Self::VERTEX_USAGE,
        );
        let b = grow(
            device,
            &mut self.indices,
            cap.indices * 4,
            "tess indices",
            Self::INDEX_USAGE,
        );
        if a || b {
            self.group1 = Self::bind1(
                device,
                &self.layout1,
                &self.tess_uniform,
                &self.topo_buffer,
                &self.vertices,
                &self.indices,
                &self.bounds,
            );
        }
        let topo = &self.topology;
        let lt = self.levels.as_ref().expect("built above");
        let (px, py) = groups(np as u32, self.max_groups)?;
        let (cx, cy) = groups(3 * np as u32, self.max_groups)?;
        let pinfo = LV_STATE_HEAD as u32;
        let block_off = pinfo + 4 * np as u32;
        let int_off = block_off + topo.edge_blocks + 1;
        let uniform = LvUniform {
            patches: np as u32,
            blocks: topo.edge_blocks,
            edges: ne as u32,
            max_level,
            rule,
            patch_groups_x: px,
            max_groups: self.max_groups,
            corner_records: topo.corner_records,
            pinfo,
            block_off,
            int_off,
            pt_off: int_off + np as u32,
            tri_off: int_off + 2 * np as u32,
            copy_groups_x: cx,
            pad: [0; 2],
        };
        queue.write_buffer(&lt.uniform, 0, bytemuck::bytes_of(&uniform));
        let levels = match source {
            LevelSource::Device { levels, .. } => levels,
            LevelSource::Host(l) => {
                let data: Vec<u32> = l.edges.iter().chain(&l.inner).copied().collect();
                queue.write_buffer(&lt.host_levels, 0, bytemuck::cast_slice(&data));
                &lt.host_levels
            }
        };
        let bufs = [
            &lt.uniform,
            &self.topo_buffer,
            &self.vertices,
            &self.indices,
            &lt.statics,
            levels,
            &lt.state,
        ];
        let entries: Vec<wgpu::BindGroupEntry<'_>> = bufs
            .into_iter()
            .enumerate()
            .map(|(b, buf)| wgpu::BindGroupEntry {
                binding: b as u32,
                resource: buf.as_entire_binding(),
            })
            .collect();
        let group1 = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("g1tess tessellate levels"),
            layout: &lt.layout1,
            entries: &entries,
        });
        let pass = |encoder: &mut wgpu::CommandEncoder,
                    label: &str,
                    pipeline: &wgpu::ComputePipeline,
                    dispatch: Option<(u32, u32)>| {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some(label),
                timestamp_writes: None,
            });
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, &lt.group0, &[]);
            pass.set_bind_group(1, &group1, &[]);
            match dispatch {
                Some((x, y)) => pass.dispatch_workgroups(x, y, 1),
                None => pass.dispatch_workgroups_indirect(&lt.dispatch, 0),
            }
        };
        // Each pass reads what the one before wrote.
        pass(
            encoder,
            "g1tess levels per patch",
            &lt.patch,
            Some((px, py)),
        );
        pass(encoder, "g1tess levels scan", &lt.scan, Some((LV_SCANS, 1)));
        pass(encoder, "g1tess levels finish", &lt.finish, Some((1, 1)));
        encoder.copy_buffer_to_buffer(&lt.state, 4 * 9, &lt.dispatch, 0, 12);
        encoder.copy_buffer_to_buffer(&lt.state, 4 * LV_STATE_DRAW as u64, &self.indirect, 0, 20);
        pass(encoder, "g1tess levels samples", &lt.points, None);
        pass(
            encoder,
            "g1tess levels triangles",
            &lt.triangles,
            Some((px, py)),
        );
        if topo.copied_blocks > 0 {
            pass(
                encoder,
                "g1tess levels split normals",
                &lt.copy,
                Some((cx, cy)),
            );
        }
        self.counts = None;
        Ok(cap)
    }

    /// The state of the last per-edge tessellation (u32): totals at [`LV_STATE_TOTALS`],
    /// draw arguments at [`LV_STATE_DRAW`], vertex records at [`LV_STATE_RECORDS`]; `None`
    /// before the first.
    pub fn level_state(&self) -> Option<&wgpu::Buffer> {
        self.levels.as_ref().map(|l| &l.state)
    }

    /// Records, after [`GpuTessellator::tessellate`] in the same submission, the extent of
    /// the surface along three directions into [`GpuTessellator::bounds`]: the largest
    /// `p · axes[k]` and the largest `−p · axes[k]` over the vertices, as order-preserving
    /// keys ([`decode_bounds`]). An aggregate for fitting a camera (24 bytes).
    pub fn record_bounds(
        &mut self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        axes: [[f32; 3]; 3],
    ) -> Result<()> {
        let counts = self.counts.ok_or_else(|| {
            Error::Invalid(
                "bounds need a uniform tessellation (tessellate) recorded before them".into(),
            )
        })?;
        let (bx, by) = groups(counts.vertices, self.max_groups)?;
        self.uniform.bounds_count = counts.vertices;
        self.uniform.bounds_groups_x = bx;
        self.uniform.axes = axes.map(|a| [a[0], a[1], a[2], 0.0]);
        queue.write_buffer(&self.tess_uniform, 0, bytemuck::bytes_of(&self.uniform));
        encoder.clear_buffer(&self.bounds, 0, None);
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("g1tess tessellate bounds"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&self.bounds_pipeline);
        pass.set_bind_group(0, &self.group0, &[]);
        pass.set_bind_group(1, &self.group1, &[]);
        pass.dispatch_workgroups(bx, by, 1);
        Ok(())
    }

    /// Sets the vertex buffer (slot 0) and index buffer of `pass` and draws the surface
    /// through the indirect arguments.
    pub fn draw(&self, pass: &mut wgpu::RenderPass<'_>) {
        pass.set_vertex_buffer(0, self.vertices.slice(..));
        pass.set_index_buffer(self.indices.slice(..), wgpu::IndexFormat::Uint32);
        pass.draw_indexed_indirect(&self.indirect, 0);
    }

    /// The vertex buffer: [`TessCounts::vertices`] entries of [`vertex_layout`].
    pub fn vertices(&self) -> &wgpu::Buffer {
        &self.vertices
    }

    /// The index buffer: [`TessCounts::indices`] `u32` record ids, 3 per triangle.
    pub fn indices(&self) -> &wgpu::Buffer {
        &self.indices
    }

    /// The `draw_indexed_indirect` arguments of the last tessellation.
    pub fn indirect(&self) -> &wgpu::Buffer {
        &self.indirect
    }

    /// The keys of [`GpuTessellator::record_bounds`]: 6 u32.
    pub fn bounds(&self) -> &wgpu::Buffer {
        &self.bounds
    }

    /// Counts of the last tessellation.
    pub fn counts(&self) -> Option<TessCounts> {
        self.counts
    }

    /// The topology table uploaded.
    pub fn topology(&self) -> &Topology {
        &self.topology
    }

    pub fn kind(&self) -> PatchKind {
        self.kind
    }

    pub fn precision(&self) -> Precision {
        self.precision
    }
}

/// The f32 of an order-preserving key of `shaders/tessellate.wgsl` (`order_key`).
pub fn key_to_f32(key: u32) -> f32 {
    if key & 0x8000_0000 != 0 {
        f32::from_bits(key & 0x7fff_ffff)
    } else {
        f32::from_bits(!key)
    }
}

/// The extent read from [`GpuTessellator::bounds`]: (smallest, largest) projection on each
/// axis.
pub fn decode_bounds(keys: [u32; 6]) -> ([f32; 3], [f32; 3]) {
    let hi = [0, 1, 2].map(|k| key_to_f32(keys[k]));
    let lo = [0, 1, 2].map(|k| -key_to_f32(keys[3 + k]));
    (lo, hi)
}
