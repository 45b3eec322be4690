//! Screen-space levels on the GPU: a compute pass (`shaders/levels.wgsl`, mirroring
//! [`crate::tess::screen::edge_level`]) that fills a per-edge level buffer on the device
//! from device-resident positions and edges, so a renderer can recompute the levels every
//! frame without reading anything back. [`gpu_screen_levels`] uploads, dispatches and reads
//! the levels back (tests, one-off use).

use wgpu::util::DeviceExt;

use crate::gpu::Precision;
use crate::mesh::{Adjacency, Mesh};
use crate::tess::screen::{ScreenView, W_MIN};
use crate::{Error, Result};

/// The WGSL source of the level pass.
pub const LEVELS_WGSL: &str = include_str!("../../shaders/levels.wgsl");

/// Threads per workgroup of `levels_main` (`LEVELS_WORKGROUP` in the shader).
pub const LEVELS_WORKGROUP: u32 = 64;

/// The shader's `Params` (uniform, 96 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct LevelParams {
    /// World → clip space, column after column (as [`ScreenView::view_proj`]), in f32.
    pub view_proj: [f32; 16],
    /// Viewport width and height in pixels.
    pub viewport: [f32; 2],
    /// Wanted length of an output segment, pixels.
    pub target_px: f32,
    /// Cap on every level.
    pub max_level: u32,
    /// Edges to level (threads past the last do nothing).
    pub edges: u32,
    /// Clip-space w at or below which a point counts as behind the eye.
    pub w_min: f32,
    /// Workgroups along x of the dispatch ([`LevelPass::groups`]), to number the edges of
    /// a 2-D dispatch; 0 until the caller sets it.
    pub groups_x: u32,
    /// Padding to 96 bytes (0).
    pub pad: u32,
}

impl LevelParams {
    /// Parameters for `edges` edges seen through `view` (the matrix rounded to f32).
    pub fn new(view: &ScreenView, edges: u32) -> LevelParams {
        LevelParams {
            view_proj: view.view_proj.to_cols_array().map(|x| x as f32),
            viewport: view.viewport.map(|x| x as f32),
            target_px: view.target_px as f32,
            max_level: view.max_level,
            edges,
            w_min: W_MIN as f32,
            groups_x: 0,
            pad: 0,
        }
    }
}

/// The level pass: its pipeline and bind group layout (0 params, 1 positions `vec4<f32>`,
/// 2 edges `vec2<u32>`, 3 levels `u32`).
pub struct LevelPass {
    /// The bind group layout (bindings 0 to 3 above).
    pub layout: wgpu::BindGroupLayout,
    /// The compute pipeline of `levels_main`.
    pub pipeline: wgpu::ComputePipeline,
}

impl LevelPass {
    /// Builds the pass (the source validated with naga first).
    pub fn new(device: &wgpu::Device) -> Result<LevelPass> {
        crate::gpu::shaders::validate(LEVELS_WGSL, Precision::F32)
            .map_err(|e| Error::Gpu(format!("shaders/levels.wgsl: {e}")))?;
        let entry = |binding, ty| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty,
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        };
        use wgpu::BufferBindingType as B;
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("g1tess levels"),
            entries: &[
                entry(0, B::Uniform),
                entry(1, B::Storage { read_only: true }),
                entry(2, B::Storage { read_only: true }),
                entry(3, B::Storage { read_only: false }),
            ],
        });
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("levels.wgsl"),
            source: wgpu::ShaderSource::Wgsl(LEVELS_WGSL.into()),
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("g1tess levels"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("levels.wgsl"),
            layout: Some(&pipeline_layout),
            module: &module,
            entry_point: Some("levels_main"),
            compilation_options: Default::default(),
            cache: None,
        });
        Ok(LevelPass { layout, pipeline })
    }

    /// The bind group of `buffers` (params, positions, edges, levels) for this pass.
    pub fn bind_group(
        &self,
        device: &wgpu::Device,
        buffers: [&wgpu::Buffer; 4],
    ) -> wgpu::BindGroup {
        crate::gpu::bind_buffers(device, "g1tess levels", &self.layout, &buffers)
    }

    /// Records the pass into `encoder`: `params` (a uniform buffer of [`LevelParams`],
    /// written by the caller with `groups_x` from [`LevelPass::groups`]), `positions`,
    /// `edges` and `levels` stay on the device. Makes a bind group each call:
    /// [`ScreenLevels`] keeps its own and its buffers.
    pub fn record(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        buffers: [&wgpu::Buffer; 4],
        groups: (u32, u32),
    ) {
        let bind_group = self.bind_group(device, buffers);
        self.record_with(encoder, &bind_group, groups);
    }

    /// Records the pass with a bind group made by [`LevelPass::bind_group`].
    pub fn record_with(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        bind_group: &wgpu::BindGroup,
        groups: (u32, u32),
    ) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("g1tess levels"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, bind_group, &[]);
        pass.dispatch_workgroups(groups.0, groups.1, 1);
    }

    /// Workgroup counts (x, y) for `edges` edges, at most `max_per_dim` per dimension.
    pub fn groups(edges: u32, max_per_dim: u32) -> (u32, u32) {
        let groups = edges.div_ceil(LEVELS_WORKGROUP).max(1);
        let x = groups.min(max_per_dim.max(1));
        (x, groups.div_ceil(x))
    }
}

/// Screen-space levels of every edge of `mesh` computed on the GPU (positions rounded to
/// f32) and read back: the same as [`crate::tess::screen::screen_levels`]'s edge levels up
/// to f32 rounding where the projected length is a whole number of targets. `adjacency`
/// must be `mesh.adjacency()` (the order of the levels).
pub fn gpu_screen_levels(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    mesh: &Mesh,
    adjacency: &Adjacency,
    view: &ScreenView,
) -> Result<Vec<u32>> {
    view.check()?;
    let ne = adjacency.edges.len();
    if ne == 0 {
        return Ok(Vec::new());
    }
    let screen = ScreenLevels::with_adjacency(device, mesh, adjacency)?;
    let bytes = 4 * ne as u64;
    let staging = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("levels staging"),
        size: bytes.div_ceil(16) * 16,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
        label: Some("g1tess levels"),
    });
    screen.record_params(queue, &mut encoder, LevelParams::new(view, screen.edges));
    encoder.copy_buffer_to_buffer(&screen.levels, 0, &staging, 0, bytes);
    queue.submit([encoder.finish()]);
    crate::gpu::read_buffer(device, &staging, bytes, |b| {
        bytemuck::cast_slice::<u8, u32>(b).to_vec()
    })
}

/// One frame's view for [`ScreenLevels`], in the f32 a host holds: world → clip space
/// (`glam::Mat4`, column vectors, as wgpu's clip space wants), the viewport in pixels, the
/// wanted length of an output segment in pixels and the cap on every level.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScreenFrame {
    /// World → clip space.
    pub view_proj: glam::Mat4,
    /// Viewport width and height in pixels.
    pub viewport: [f32; 2],
    /// Wanted length of an output segment, pixels.
    pub target_px: f32,
    /// Cap on every level (1..=[`crate::MAX_LEVEL`]).
    pub max_level: u32,
}

impl ScreenFrame {
    /// The f64 view of the CPU's [`crate::screen_levels`] for the same frame (the matrix
    /// widened exactly), for comparing both.
    pub fn view(&self) -> ScreenView {
        ScreenView {
            view_proj: self.view_proj.as_dmat4(),
            viewport: self.viewport.map(f64::from),
            target_px: f64::from(self.target_px),
            max_level: self.max_level,
        }
    }
}

/// Screen-space levels that own their buffers: built once from the device and the mesh
/// (its positions as `vec4<f32>`, its edges in the order of `mesh.adjacency()`, which is
/// the order [`crate::GpuTessellator`] numbers them in), they record each frame's levels
/// into the host's encoder from a [`ScreenFrame`], for
/// [`crate::GpuTessellator::tessellate_screen`] or [`ScreenLevels::source`]. Nothing is
/// read back and no bind group is made per frame.
pub struct ScreenLevels {
    pass: LevelPass,
    params: wgpu::Buffer,
    levels: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    edges: u32,
    groups: (u32, u32),
}

impl ScreenLevels {
    /// Uploads the positions and edges of `mesh` and builds the pass.
    pub fn new(device: &wgpu::Device, mesh: &Mesh) -> Result<ScreenLevels> {
        Self::with_adjacency(device, mesh, &mesh.adjacency())
    }

    fn with_adjacency(
        device: &wgpu::Device,
        mesh: &Mesh,
        adjacency: &Adjacency,
    ) -> Result<ScreenLevels> {
        let ne = adjacency.edges.len();
        let edges = u32::try_from(ne)
            .map_err(|_| Error::Invalid(format!("{}: {ne} edges are too many", mesh.name)))?;
        let pass = LevelPass::new(device)?;
        // Bindings are never empty: a vertex and an edge at least.
        let mut positions: Vec<[f32; 4]> = mesh
            .positions
            .iter()
            .map(|p| [p.x as f32, p.y as f32, p.z as f32, 1.0])
            .collect();
        positions.resize(positions.len().max(1), [0.0; 4]);
        let mut ends: Vec<[u32; 2]> = adjacency.edges.iter().map(|e| e.v).collect();
        ends.resize(ends.len().max(1), [0; 2]);
        use wgpu::BufferUsages as U;
        let init = |label, contents: &[u8], usage| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage,
            })
        };
        let params = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("level params"),
            size: std::mem::size_of::<LevelParams>() as u64,
            usage: U::UNIFORM | U::COPY_DST,
            mapped_at_creation: false,
        });
        let pos_buf = init(
            "level positions",
            bytemuck::cast_slice(&positions),
            U::STORAGE,
        );
        let edge_buf = init("level edges", bytemuck::cast_slice(&ends), U::STORAGE);
        let levels = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("levels"),
            size: (4 * ne as u64).max(16).div_ceil(16) * 16,
            usage: U::STORAGE | U::COPY_SRC,
            mapped_at_creation: false,
        });
        let bind_group = pass.bind_group(device, [&params, &pos_buf, &edge_buf, &levels]);
        let max_dim = device.limits().max_compute_workgroups_per_dimension;
        Ok(ScreenLevels {
            pass,
            params,
            levels,
            bind_group,
            edges,
            groups: LevelPass::groups(edges, max_dim),
        })
    }

    /// Records this frame's levels into `encoder` (the parameters written with
    /// `queue.write_buffer`, so submit the encoder before recording again). Errors on a
    /// viewport, target or cap out of range or a matrix that is not finite.
    pub fn record(
        &self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        frame: &ScreenFrame,
    ) -> Result<()> {
        frame.view().check()?;
        let params = LevelParams {
            view_proj: frame.view_proj.to_cols_array(),
            viewport: frame.viewport,
            target_px: frame.target_px,
            max_level: frame.max_level,
            edges: self.edges,
            w_min: W_MIN as f32,
            groups_x: 0,
            pad: 0,
        };
        self.record_params(queue, encoder, params);
        Ok(())
    }

    /// Records the pass with `params`, whose workgroup count is set here.
    fn record_params(
        &self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        mut params: LevelParams,
    ) {
        params.groups_x = self.groups.0;
        queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
        if self.edges > 0 {
            self.pass
                .record_with(encoder, &self.bind_group, self.groups);
        }
    }

    /// The level buffer: one u32 per edge (`STORAGE | COPY_SRC`).
    pub fn levels(&self) -> &wgpu::Buffer {
        &self.levels
    }

    /// Edges of the mesh (entries of [`ScreenLevels::levels`]).
    pub fn edges(&self) -> u32 {
        self.edges
    }

    /// The levels as [`crate::GpuTessellator::tessellate_levels`] takes them, inner levels
    /// by `rule`.
    pub fn source(&self, rule: crate::InnerRule) -> crate::LevelSource<'_> {
        crate::LevelSource::Device {
            levels: &self.levels,
            rule,
        }
    }
}
