//! Per-edge tessellation: a level per edge and an inner level per patch, numbered and
//! triangulated on the device (module documentation of the parent, "Per-edge levels").

use crate::eval::grid_barycentrics;
use crate::gpu::eval::{basis_table, Params, Real};
use crate::gpu::Precision;
use crate::patch::PatchKind;
use crate::tess::adaptive::{InnerRule, Levels};
use crate::tess::layout::MAX_LEVEL;
use crate::tess::numbering::{interior_len, Bases};
use crate::{Error, Result};

use super::buffers::{groups, new_buffer};
use super::shader::{
    checked_module, compute_pipeline, entry, storage_ty, tess_levels_module_source, uniform_ty,
};
use super::{level_grid_base, GpuTessellator, Topology, MAX_GRID_TABLE_BYTES, VERTEX_BYTES};

/// Where [`GpuTessellator::tessellate_levels`] takes its levels from.
#[derive(Clone, Copy, Debug)]
pub enum LevelSource<'a> {
    /// A device buffer (`STORAGE`) of one u32 level per edge of the mesh's adjacency, as
    /// [`crate::gpu::screen::LevelPass`] writes it; inner levels by `rule`. Levels are
    /// clamped to 1..=max_level on the device.
    Device {
        /// The level buffer: one u32 per edge.
        levels: &'a wgpu::Buffer,
        /// How each patch's inner level follows from its three edge levels.
        rule: InnerRule,
    },
    /// Levels on the host (edge and inner levels in 1..=max_level), uploaded.
    Host(&'a Levels),
}

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
    /// The level cap these bounds hold for.
    pub max_level: u32,
    /// Vertex records at most (the exact count is at `LV_STATE_RECORDS` on the device).
    pub vertices: u64,
    /// Indices at most (the exact count is in the indirect arguments).
    pub indices: u64,
    /// Samples evaluated at most.
    pub samples: u64,
}

/// Pipelines and buffers of per-edge tessellation (made on first use).
pub(super) struct LevelTess {
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

impl LevelTess {
    /// The state buffer ([`GpuTessellator::level_state`]).
    pub(super) fn state(&self) -> &wgpu::Buffer {
        &self.state
    }
}

impl Topology {
    /// Upper bounds of a per-edge tessellation whose levels are at most `max_level`: the
    /// pattern raises inner levels to 3 at least, so L = max(max_level, 3) bounds the inner
    /// level, L² the triangles of a patch.
    pub fn level_capacity(&self, max_level: u32) -> LevelCapacity {
        let m = max_level.max(1) as u64;
        let l = m.max(3);
        let interior = interior_len(l as u32);
        let p = self.patches as u64;
        // Every block at most m − 1 samples, every interior at most the inner level's.
        let most = Bases::Uniform {
            block: m - 1,
            interior,
        };
        LevelCapacity {
            max_level,
            vertices: most.base(self.end()),
            indices: 3 * p * l * l,
            samples: p * (3 * m + interior),
        }
    }

    /// The inner rule of `source` as `shaders/tessellate_levels.wgsl` reads it (0 max,
    /// 1 mean, 2 min, 3 host inner levels), after checking the levels against this
    /// topology: a device buffer's size, or host levels' counts and range 1..=`max_level`.
    fn inner_rule_code(&self, source: LevelSource<'_>, max_level: u32) -> Result<u32> {
        let (ne, np) = (self.edges, self.patches);
        match source {
            LevelSource::Device { levels, rule } => {
                if levels.size() < 4 * ne as u64 {
                    return Err(Error::Invalid(format!(
                        "a level buffer of {} bytes for {ne} edges (4 bytes each)",
                        levels.size()
                    )));
                }
                Ok(match rule {
                    InnerRule::Max => 0,
                    InnerRule::Mean => 1,
                    InnerRule::Min => 2,
                })
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
                Ok(3)
            }
        }
    }
}

/// The basis of every point of the grids of levels 1..=`top`, level after level, laid out
/// as `eval_table` of `shaders/common.wgsl` reads it (per = all the points).
fn level_weight_bytes<R: Real>(kind: PatchKind, top: u32) -> Vec<u8> {
    // Level l's grid starts at `level_grid_base(l)`: the grids of levels 1..=top in order.
    let points: Vec<[f64; 3]> = (1..=top).flat_map(grid_barycentrics).collect();
    debug_assert_eq!(points.len() as u64, level_grid_base(top + 1));
    bytemuck::cast_slice(&basis_table::<R>(kind, &points)).to_vec()
}

impl GpuTessellator {
    /// Builds the per-edge pipelines and buffers for levels up to `max_level`, or reuses
    /// those built while large enough.
    pub(super) fn level_tess(&mut self, device: &wgpu::Device, max_level: u32) -> Result<()> {
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
        self.level_group = None;
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
                return Err(Error::limit(
                    "max_storage_buffer_binding_size",
                    bytes,
                    self.max_binding,
                    format!(
                        "levels up to {max_level} on {} patches need a {} {what} buffer, \
                         over the device's storage binding limit of {}",
                        topo.patches,
                        super::mib(bytes),
                        super::mib(self.max_binding)
                    ),
                ));
            }
        }
        Ok(cap)
    }

    /// Records the tessellation with a level per edge into `encoder`, with nothing read
    /// back: inner levels, the prefix sums that number the output
    /// ([`crate::tess::stitch::StitchPlan::with_levels`]'s numbering exactly), the
    /// samples, the triangles (`crate::tess::layout`'s pattern) and the indirect draw
    /// arguments are all computed on the device. Buffers are sized for levels up to
    /// `max_level` (levels above it are clamped to it) and reused while large enough;
    /// call [`GpuTessellator::vertices`] and [`GpuTessellator::indices`] again after this.
    /// Host levels are written with `queue.write_buffer`, so submit the encoder before
    /// tessellating again. The exact counts stay on the device: the indirect arguments and
    /// [`GpuTessellator::level_state`].
    ///
    /// Screen-space levels every frame, computed and used on the device
    /// ([`crate::ScreenLevels`] owns the level buffers;
    /// [`GpuTessellator::tessellate_screen`] records both steps in one call):
    ///
    /// ```no_run
    /// # fn demo(
    /// #     device: &wgpu::Device,
    /// #     queue: &wgpu::Queue,
    /// #     mesh: &g1tess::Mesh,
    /// #     tess: &mut g1tess::GpuTessellator,
    /// #     view_proj: glam::Mat4,
    /// # ) -> g1tess::Result<()> {
    /// use g1tess::{InnerRule, ScreenFrame, ScreenLevels};
    ///
    /// let screen = ScreenLevels::new(device, mesh)?; // once: positions, edges, levels
    /// let max_level = 16;
    /// // Every frame: levels from the camera, then the tessellation, in one encoder.
    /// let frame = ScreenFrame { view_proj, viewport: [1280.0, 720.0], target_px: 8.0, max_level };
    /// let mut encoder = device.create_command_encoder(&Default::default());
    /// screen.record(queue, &mut encoder, &frame)?;
    /// tess.tessellate_levels(device, queue, &mut encoder, screen.source(InnerRule::Max), max_level)?;
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
        let rule = self.topology.inner_rule_code(source, max_level)?;
        self.level_tess(device, max_level)?;
        self.grow_outputs(device, cap.vertices * VERTEX_BYTES, cap.indices * 4);
        let topo = &self.topology;
        let (ne, np) = (topo.edges, topo.patches);
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
        let cached = matches!(&self.level_group, Some((b, _)) if b == levels);
        if !cached {
            let bufs = [
                &lt.uniform,
                &self.topo_buffer,
                &self.vertices,
                &self.indices,
                &lt.statics,
                levels,
                &lt.state,
            ];
            let group1 =
                crate::gpu::bind_buffers(device, "g1tess tessellate levels", &lt.layout1, &bufs);
            self.level_group = Some((levels.clone(), group1));
        }
        let (_, group1) = self.level_group.as_ref().expect("made above");
        self.record_level_passes(lt, encoder, group1, (px, py), (cx, cy));
        self.counts = None;
        self.level_cap = Some(max_level);
        Ok(cap)
    }

    /// Records the per-edge passes of `lt` with `group1` (the parameters and levels
    /// written): levels per patch, the scans, their totals, the samples, the triangles,
    /// and the split-normal copies where there are split edges. The last two arguments are
    /// the workgroups (x, y) of one thread per patch and of one per local edge.
    fn record_level_passes(
        &self,
        lt: &LevelTess,
        encoder: &mut wgpu::CommandEncoder,
        group1: &wgpu::BindGroup,
        (px, py): (u32, u32),
        (cx, cy): (u32, u32),
    ) {
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
            pass.set_bind_group(1, group1, &[]);
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
        if self.topology.copied_blocks > 0 {
            pass(
                encoder,
                "g1tess levels split normals",
                &lt.copy,
                Some((cx, cy)),
            );
        }
    }

    /// The state of the last per-edge tessellation (u32): totals at offset 0,
    /// draw arguments at `LV_STATE_DRAW`, vertex records at `LV_STATE_RECORDS`; `None`
    /// before the first.
    pub fn level_state(&self) -> Option<&wgpu::Buffer> {
        self.levels.as_ref().map(|l| &l.state)
    }
}
