//! Device-resident tessellation: the welded, indexed surface of a patch table written by
//! compute passes straight into a vertex and an index buffer on the host program's own
//! `wgpu::Device`, ready for its render pass, with nothing read back.
//!
//! [`GpuTessellator`] stands in for the tessellation stage wgpu lacks. Built once from a
//! [`Mesh`] and its [`PatchTable`], it records into the host's `CommandEncoder` the
//! tessellation of a uniform level ([`GpuTessellator::tessellate`]) or of per-edge levels
//! kept on the device ([`GpuTessellator::tessellate_levels`]), leaving
//! [`GpuTessellator::vertices`] (24 bytes per record, [`vertex_layout`]),
//! [`GpuTessellator::indices`] and [`GpuTessellator::indirect`], numbered as the stitcher
//! numbers files, at any level, by the [`Topology`] table (`docs/gpu.md` explains both).
//!
//! A host opens its device with the published limits and features, builds the
//! tessellator, [`crate::ScreenLevels`] and every pipeline once, then records each frame's
//! levels, tessellation and draw into one encoder, reading nothing back:
//!
//! ```no_run
//! # fn demo(
//! #     adapter: &wgpu::Adapter,
//! #     pipeline: &wgpu::RenderPipeline,
//! #     target: &wgpu::TextureView,
//! #     camera: impl Fn(u32) -> glam::Mat4,
//! #     begin_pass: impl for<'a> Fn(&'a mut wgpu::CommandEncoder, &wgpu::TextureView) -> wgpu::RenderPass<'a>,
//! # ) -> g1tess::Result<()> {
//! use g1tess::wgpu; // the wgpu g1tess is built with (30)
//! use g1tess::{GpuTessellator, InnerRule, Mesh, PatchTable, Precision, Scheme};
//! use g1tess::{ScreenFrame, ScreenLevels};
//!
//! // Once: a device that can run every pass, the patches, the levels' own buffers.
//! let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
//!     required_features: GpuTessellator::required_features(Precision::F32),
//!     required_limits: GpuTessellator::required_limits(), // large meshes: the adapter's sizes
//!     ..Default::default()
//! }))
//! .map_err(|e| g1tess::Error::Gpu(e.to_string()))?;
//! let mesh = Mesh::load("icosphere:2", &Default::default())?;
//! let table = PatchTable::build(&mesh, Scheme::G1, &Default::default())?;
//! let mut tess = GpuTessellator::new(&device, &queue, &mesh, &table, Precision::F32)?;
//! let screen = ScreenLevels::new(&device, &mesh)?;
//! tess.prepare(&device, 16)?; // every pipeline and buffer, before the first frame
//!
//! for frame in 0..3 {
//!     // The host's f32 camera; levels aim at 8-pixel segments, at most 16.
//!     let view_proj = camera(frame);
//!     let view = ScreenFrame { view_proj, viewport: [1280.0, 720.0], target_px: 8.0, max_level: 16 };
//!     let mut encoder = device.create_command_encoder(&Default::default());
//!     tess.tessellate_screen(&device, &queue, &mut encoder, &screen, &view, InnerRule::Max)?;
//!     // The host's render pass and pipeline, whose `VertexState::buffers` is
//!     // `&[Some(g1tess::vertex_layout())]`: @location(0) position, (1) unit normal.
//!     let mut pass = begin_pass(&mut encoder, target);
//!     pass.set_pipeline(pipeline);
//!     tess.draw(&mut pass); // vertex + index buffers, draw_indexed_indirect
//!     drop(pass);
//!     queue.submit([encoder.finish()]);
//! }
//! // Tools and tests only: the exact counts, read back asynchronously.
//! let triangles = pollster::block_on(tess.read_counts(&device, &queue))?.triangles();
//! # Ok(())
//! # }
//! ```

// The topology table (filled from `tess::numbering`, the stitcher's numbering),
// `record_of` (what the shaders mirror) and the tessellator's state are here; its
// construction and buffers, uniform levels, per-edge levels and the WGSL assembly each have
// a file.
mod buffers;
mod host;
mod levels;
mod shader;
mod uniform;

use crate::mesh::{Adjacency, Mesh};
use crate::patch::PatchKind;
use crate::tess::numbering::{canonical_sample, grid_point, Bases, GridPoint, Item, Numbering};
use crate::{Error, Result};

use super::Precision;

#[cfg(test)]
pub use levels::LV_STATE_RECORDS;
pub use levels::{LevelCapacity, LevelSource};
#[cfg(test)]
pub use shader::{tess_levels_module_source, tess_module_source, TESS_LEVELS_WGSL, TESS_WGSL};

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
/// vertex, `VERTEX_ATTRIBUTES`. wgpu 30's `VertexState::buffers` takes options:
/// `buffers: &[Some(g1tess::vertex_layout())]`.
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
    /// `TOPO_STRIDE` u32 per patch.
    pub table: Vec<u32>,
    /// Corner records (distinct (vertex, corner normal) pairs).
    pub corner_records: u32,
    /// Edge record blocks (one per edge, one more per extra side of a split edge).
    pub edge_blocks: u32,
    /// Blocks whose positions are copied from the owner's (split normals).
    pub copied_blocks: u32,
    /// Patches (triangles of the mesh).
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
    /// [`crate::tess::stitch::StitchPlan::new`] numbers the output: the same
    /// `Numbering`, without attributes (the vertices carry none).
    pub fn new(mesh: &Mesh, adjacency: &Adjacency) -> Result<Topology> {
        let nf = mesh.triangles.len();
        if nf as u64 >= u32::MAX as u64 / 4 {
            return Err(Error::Invalid(format!(
                "{}: {nf} triangles are too many for 32-bit indices",
                mesh.name
            )));
        }
        let numbering = Numbering::new(mesh, adjacency, None)?;
        Ok(Topology::from_numbering(&numbering, adjacency.edges.len()))
    }

    /// The table of `numbering` (of a mesh with `edges` adjacency edges): every item's
    /// (a, b, c) and flags, per patch.
    pub(crate) fn from_numbering(numbering: &Numbering, edges: usize) -> Topology {
        let rec = numbering.records();
        let nf = numbering.patches();
        let abc = |item: Item| [item.a, item.b, item.c];
        let mut table = vec![0u32; TOPO_STRIDE * nf];
        for (t, row) in table.chunks_exact_mut(TOPO_STRIDE).enumerate() {
            for k in 0..3 {
                let c = 3 * t + k;
                let o = TOPO_CORNER + 4 * k;
                row[o..o + 3].copy_from_slice(&abc(rec.corner_item(c)));
                row[o + 3] = if rec.makes_corner(c) { FLAG_WRITE } else { 0 };
            }
            for k in 0..3 {
                let u = 3 * t + k;
                let owner = numbering.owner(u);
                let mut flags = match (rec.makes_block(u), owner == u) {
                    (false, _) => 0,
                    (true, true) => FLAG_WRITE,
                    (true, false) => FLAG_WRITE | FLAG_COPY,
                };
                if numbering.use_rev[u] {
                    flags |= FLAG_REVERSED;
                }
                let o = TOPO_EDGE + 7 * k;
                row[o..o + 3].copy_from_slice(&abc(rec.block_item(u)));
                row[o + 3] = flags;
                row[o + 4..o + 7].copy_from_slice(&abc(rec.block_item(owner)));
            }
            let interior = rec.interior_item(t);
            row[TOPO_INTERIOR] = interior.a;
            row[TOPO_INTERIOR + 1] = interior.b;
        }
        let end = rec.end();
        Topology {
            table,
            corner_records: end.a,
            edge_blocks: end.b,
            copied_blocks: numbering.copied_blocks(),
            patches: nf,
            block_edge: numbering.block_edges(rec).collect(),
            patch_edges: numbering.use_edge.clone(),
            edges,
        }
    }

    /// The totals: every corner record, edge block and interior (the end of the order).
    pub(crate) fn end(&self) -> Item {
        Item {
            a: self.corner_records,
            b: self.edge_blocks,
            c: self.patches as u32,
        }
    }

    /// Vertex records at `level`: `a + b (n − 1) + patches (n − 1)(n − 2)/2` with the
    /// totals (exact, in u64).
    pub fn records(&self, level: u32) -> u64 {
        Bases::grid(level).base(self.end())
    }

    /// Triangle indices at `level`: 3 n² per patch.
    pub fn index_count(&self, level: u32) -> u64 {
        3 * self.patches as u64 * (level as u64).pow(2)
    }

    fn topo(&self, p: u32, o: usize) -> u32 {
        self.table[p as usize * TOPO_STRIDE + o]
    }

    /// The item whose (a, b, c) is at offset `o` of patch `p`'s entry.
    fn item(&self, p: u32, o: usize) -> Item {
        Item {
            a: self.topo(p, o),
            b: self.topo(p, o + 1),
            c: self.topo(p, o + 2),
        }
    }

    /// The triangles of every patch at `level` as record ids, in the order the GPU writes
    /// them (`grid_triangle_index`); the CPU mirror of the index buffer.
    pub fn triangles(&self, level: u32) -> Vec<[u32; 3]> {
        let n = level.max(1);
        let per = n as usize * n as usize;
        let mut out = vec![[0u32; 3]; self.patches * per];
        for p in 0..self.patches as u32 {
            let base = p as usize * per;
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
/// table alone (`record_of` of `shaders/tessellate.wgsl` mirrors it): the first id of the
/// item the point belongs to at level n ([`Bases::grid`]), plus its place in the item.
pub fn record_of(topology: &Topology, p: u32, n: u32, i: u32, j: u32) -> Rec {
    let bases = Bases::grid(n);
    // Ids wrap as the shader's u32 arithmetic does.
    let base = |item: Item| bases.base(item) as u32;
    match grid_point(n, i, j) {
        GridPoint::Corner(k) => {
            let o = TOPO_CORNER + 4 * k;
            let id = base(topology.item(p, o));
            Rec {
                id,
                flags: topology.topo(p, o + 3),
                source: id,
            }
        }
        GridPoint::Edge(k, s) => {
            let o = TOPO_EDGE + 7 * k;
            let flags = topology.topo(p, o + 3);
            let m = canonical_sample(n - 1, s, flags & FLAG_REVERSED != 0);
            let id = base(topology.item(p, o)).wrapping_add(m);
            let source = if flags & FLAG_COPY != 0 {
                base(topology.item(p, o + 4)).wrapping_add(m)
            } else {
                id
            };
            Rec { id, flags, source }
        }
        GridPoint::Interior(m) => {
            let interior = Item {
                a: topology.topo(p, TOPO_INTERIOR),
                b: topology.topo(p, TOPO_INTERIOR + 1),
                c: p,
            };
            let id = base(interior).wrapping_add(m);
            Rec {
                id,
                flags: FLAG_WRITE,
                source: id,
            }
        }
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

/// `bytes` in MiB (2²⁰ bytes) for messages, as the limits they are compared with are
/// powers of two: one decimal, with the exact byte count.
fn mib(bytes: u64) -> String {
    format!(
        "{:.1} MiB ({bytes} bytes)",
        bytes as f64 / f64::from(1u32 << 20)
    )
}

/// What one tessellation produced.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TessCounts {
    /// The grid level of every patch (uniform levels), or the level cap (per-edge levels,
    /// [`GpuTessellator::read_counts`]).
    pub level: u32,
    /// Vertex records written (entries of [`GpuTessellator::vertices`]).
    pub vertices: u32,
    /// Indices written (3 per triangle).
    pub indices: u32,
}

impl TessCounts {
    /// Triangles written (indices / 3).
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
    /// The level cap of the last per-edge tessellation (`None` after a uniform one).
    level_cap: Option<u32>,
    /// The bind group of the per-edge passes with the level buffer it binds, kept while
    /// the buffers it binds stay the same.
    level_group: Option<(wgpu::Buffer, wgpu::BindGroup)>,
}

impl GpuTessellator {
    /// Sets the vertex buffer (slot 0) and index buffer of `pass` and draws the surface
    /// through the indirect arguments.
    pub fn draw(&self, pass: &mut wgpu::RenderPass<'_>) {
        pass.set_vertex_buffer(0, self.vertices.slice(..));
        pass.set_index_buffer(self.indices.slice(..), wgpu::IndexFormat::Uint32);
        pass.draw_indexed_indirect(&self.indirect, 0);
    }

    /// The vertex buffer: [`TessCounts::vertices`] entries of [`vertex_layout`]; usage
    /// [`GpuTessellator::VERTEX_USAGE`] (`VERTEX | STORAGE | COPY_SRC | COPY_DST`). It is
    /// replaced when a tessellation needs more room than it has (never after
    /// [`GpuTessellator::prepare`] within its cap): take it again after tessellating.
    pub fn vertices(&self) -> &wgpu::Buffer {
        &self.vertices
    }

    /// The index buffer: [`TessCounts::indices`] `u32` record ids, 3 per triangle; usage
    /// [`GpuTessellator::INDEX_USAGE`] (`INDEX | STORAGE | COPY_SRC | COPY_DST`), replaced
    /// as the vertex buffer is.
    pub fn indices(&self) -> &wgpu::Buffer {
        &self.indices
    }

    /// The `draw_indexed_indirect` arguments of the last tessellation (20 bytes:
    /// `wgpu::util::DrawIndexedIndirectArgs`); usage `INDIRECT | COPY_DST | COPY_SRC`.
    pub fn indirect(&self) -> &wgpu::Buffer {
        &self.indirect
    }

    /// The keys of [`GpuTessellator::record_bounds`]: 6 u32; usage
    /// `STORAGE | COPY_SRC | COPY_DST`.
    pub fn bounds(&self) -> &wgpu::Buffer {
        &self.bounds
    }

    /// Counts of the last uniform tessellation, known on the host; `None` after per-edge
    /// levels, whose counts stay on the device ([`GpuTessellator::read_counts`] reads them).
    pub fn counts(&self) -> Option<TessCounts> {
        self.counts
    }

    /// The topology table uploaded.
    pub fn topology(&self) -> &Topology {
        &self.topology
    }

    /// How the patches of its table are evaluated.
    pub fn kind(&self) -> PatchKind {
        self.kind
    }

    /// The working precision of its evaluation.
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

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use super::*;
    use crate::mesh::LoadOptions;
    use crate::tess::layout;
    use crate::tess::levels::Levels;
    use crate::tess::stitch::StitchPlan;

    /// A unit box without its top, creases at 45°: 4 boundary edges, 8 creased box edges.
    fn open_box() -> Mesh {
        let positions: Vec<DVec3> = (0..8)
            .map(|v| DVec3::new((v & 1) as f64, (v >> 1 & 1) as f64, (v >> 2) as f64))
            .collect();
        let quads = [
            [0, 2, 3, 1],
            [0, 1, 5, 4],
            [1, 3, 7, 5],
            [3, 2, 6, 7],
            [2, 0, 4, 6],
        ];
        let triangles: Vec<[u32; 3]> = quads
            .iter()
            .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
            .collect();
        let opts = LoadOptions {
            crease_angle: Some(45.0),
            ..LoadOptions::default()
        };
        Mesh::from_soup("open box", &positions, &triangles, None, &opts).unwrap()
    }

    /// The uploaded table is the one filled from the stitcher's numbering, and read as the
    /// per-edge shader reads it (each item at a + the samples of the blocks before it + the
    /// samples of the interiors before it, running sums written out here) it gives
    /// `StitchPlan::with_levels`'s record of every sample of every patch, with creases, a
    /// boundary, and edge levels 1..=6.
    #[test]
    fn topology_table_is_the_stitch_numbering_at_per_edge_levels() {
        let mesh = open_box();
        let adj = mesh.adjacency();
        let topo = Topology::new(&mesh, &adj).unwrap();
        let numbering = Numbering::new(&mesh, &adj, None).unwrap();
        let same = Topology::from_numbering(&numbering, adj.edges.len());
        assert_eq!(
            (topo.table.len(), &topo.table),
            (10 * TOPO_STRIDE, &same.table)
        );
        // Every box edge but the 4 of the open top is a crease with a block per side.
        assert_eq!((adj.boundary, topo.copied_blocks), (4, 8));
        assert_eq!(topo.edge_blocks as usize, adj.edges.len() + 8);
        // A record per face at each vertex (faces meet at 90°): 3 at the bottom corners,
        // 2 at the top ones; 17 edges (12 of the box, 5 quad diagonals), each with a block.
        assert_eq!(topo.corner_records, 4 * 3 + 4 * 2);
        assert_eq!(adj.edges.len(), 17);
        let edges: Vec<u32> = (0..adj.edges.len() as u32)
            .map(|e| 1 + (5 * e + 2) % 6)
            .collect();
        let inner = (0..10u32)
            .map(|p| {
                let e = [0, 1, 2].map(|k| edges[topo.patch_edges[3 * p as usize + k] as usize]);
                if p % 2 == 0 {
                    e.into_iter().max().unwrap()
                } else {
                    2
                }
            })
            .collect();
        let levels = Levels { edges, inner };
        let plan = StitchPlan::with_levels(&mesh, &adj, &levels).unwrap();
        assert!(!plan.is_uniform());
        // The device's scans: samples of the blocks and interiors before each.
        let mut block_off = vec![0u32];
        for &e in &topo.block_edge {
            block_off.push(block_off.last().unwrap() + levels.edges[e as usize] - 1);
        }
        let mut int_off = vec![0u32];
        for p in 0..10 {
            let (e, inner) = plan.patch_levels(p);
            int_off.push(int_off.last().unwrap() + layout::interior_count(e, inner) as u32);
        }
        let at = |p: u32, o: usize| {
            let [a, b, c] = [0, 1, 2].map(|i| topo.topo(p, o + i));
            a + block_off[b as usize] + int_off[c as usize]
        };
        let (mut rec, mut pos) = (Vec::new(), Vec::new());
        let mut record_position = vec![u32::MAX; plan.records];
        let mut written = vec![0u32; plan.records];
        let mut copies = Vec::new();
        for p in 0..10u32 {
            plan.local_ids(p as usize, &mut rec, &mut pos);
            let mut want = Vec::new();
            let mut write = Vec::new();
            for k in 0..3 {
                want.push(at(p, TOPO_CORNER + 4 * k));
                write.push(topo.topo(p, TOPO_CORNER + 4 * k + 3) & FLAG_WRITE != 0);
            }
            let (e, inner) = plan.patch_levels(p as usize);
            for (k, &l) in e.iter().enumerate() {
                let o = TOPO_EDGE + 7 * k;
                let flags = topo.topo(p, o + 3);
                for s in 1..l {
                    let m = canonical_sample(l - 1, s, flags & FLAG_REVERSED != 0);
                    want.push(at(p, o) + m);
                    write.push(flags & FLAG_WRITE != 0);
                    if flags & FLAG_COPY != 0 {
                        copies.push((at(p, o) + m, at(p, o + 4) + m));
                    }
                }
            }
            let (a, b) = (topo.topo(p, TOPO_INTERIOR), topo.topo(p, TOPO_INTERIOR + 1));
            let interior = a + block_off[b as usize] + int_off[p as usize];
            for m in 0..layout::interior_count(e, inner) as u32 {
                want.push(interior + m);
                write.push(true);
            }
            assert_eq!(rec, want, "patch {p}");
            for ((&r, &q), &w) in rec.iter().zip(&pos).zip(&write) {
                record_position[r as usize] = q;
                written[r as usize] += w as u32;
            }
        }
        // Every record written once; split records take an owner record's position.
        assert!(written.iter().all(|&w| w == 1), "{written:?}");
        assert!(!copies.is_empty());
        for (id, source) in copies {
            assert_ne!(id, source);
            assert_eq!(
                record_position[id as usize],
                record_position[source as usize]
            );
        }
    }
}
