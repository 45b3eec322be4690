//! Device-resident tessellation: the welded, indexed surface of a patch table written by
//! compute passes straight into a vertex and an index buffer on the host program's own
//! `wgpu::Device`, ready for its render pass, with nothing read back.
//!
//! [`GpuTessellator`] stands in for the tessellation stage wgpu lacks. Built once from a
//! [`Mesh`] and its [`PatchTable`], it records into the host's `CommandEncoder` the
//! tessellation of a uniform level ([`GpuTessellator::tessellate`]) or of per-edge levels
//! kept on the device ([`GpuTessellator::tessellate_levels`]), leaving
//! [`GpuTessellator::vertices`] (24 bytes per record, [`vertex_layout`]),
//! [`GpuTessellator::indices`] and [`GpuTessellator::indirect`]. The output is
//! [`crate::tess::stitch::StitchPlan`]'s numbering, placed at any level through the
//! level-independent [`Topology`] table (`docs/gpu.md` explains both).
//!
//! ```no_run
//! # fn demo(
//! #     device: &wgpu::Device,
//! #     queue: &wgpu::Queue,
//! #     pipeline: &wgpu::RenderPipeline,
//! #     target: &wgpu::TextureView,
//! # ) -> g1tess::Result<()> {
//! use g1tess::{GpuTessellator, Mesh, PatchTable, Precision, Scheme};
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
//!     // A pipeline whose vertex buffer 0 is g1tess::vertex_layout():
//!     // @location(0) position, @location(1) unit normal, both vec3<f32>.
//!     pass.set_pipeline(pipeline);
//!     tess.draw(&mut pass); // vertex + index buffers, draw_indexed_indirect
//! }
//! queue.submit([encoder.finish()]);
//! # Ok(())
//! # }
//! ```

// The numbering (the topology table, `record_of`: what the shaders mirror) and the
// tessellator's state are here; its construction and buffers, uniform levels, per-edge
// levels and the WGSL assembly each have a file.
mod buffers;
mod levels;
mod shader;
mod uniform;

use std::collections::HashMap;

use crate::mesh::creases::{normal_key, split_ends};
use crate::mesh::{Adjacency, Mesh};
use crate::patch::PatchKind;
use crate::{Error, Result};

use super::Precision;

pub use levels::{LevelCapacity, LevelSource, LV_STATE_DRAW, LV_STATE_RECORDS, LV_STATE_TOTALS};
pub use shader::{
    tess_header, tess_levels_module_source, tess_module_source, TESS_LEVELS_WGSL, TESS_WGSL,
    TESS_WORKGROUP,
};

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

/// First point of the grid of level `l` in the per-edge basis table: the points of the
/// grids of levels 1..l − 1, l (l + 1)(l + 2)/6 − 1.
pub fn level_grid_base(l: u32) -> u64 {
    let l = l as u64;
    l * (l + 1) * (l + 2) / 6 - 1
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
    levels: Option<levels::LevelTess>,
}

impl GpuTessellator {
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
