//! The render pass: the welded surface's triangles (vertex records: position and normal
//! as f32, [`crate::gpu::tessellator::vertex_layout`]) drawn three times into one
//! multisampled texture, one viewport per normal component, then resolved and read back
//! as RGBA rows. The vertices and indices are either the GPU tessellation's own buffers
//! ([`render_tessellated`]: nothing but a 24-byte extent comes back before drawing) or
//! a CPU surface uploaded into buffers of the same layout ([`render_panels_on`]); both
//! go through [`draw`]. Everything here works on a `wgpu::Device` and `Queue`;
//! [`render_panels`] runs it on a [`GpuContext`] the caller opened.

use wgpu::util::DeviceExt;

use super::camera::Camera;
use super::isophotes::isophote_wgsl;
use super::{Panels, RenderOptions, Shading, BACKGROUND, RAMP, RAMP_SEGMENTS};
use crate::gpu::tessellator::{decode_bounds, vertex_layout, GpuTessellator, VERTEX_BYTES};
use crate::gpu::GpuContext;
use crate::tess::stitch::StitchedMesh;
use crate::{Error, Result};

/// The render shader's source file, without its generated header.
pub const RENDER_WGSL: &str = include_str!("../../shaders/render.wgsl");

const SAMPLES: u32 = 4;
const COLOR: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;
const DEPTH: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// The uniform block of `shaders/render.wgsl` (`struct Uniforms`), byte for byte.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Uniforms {
    /// Rows of the orthographic map ([`Camera::rows`]).
    pub rows: [[f32; 4]; 3],
    /// The normal component drawn: 0, 1 or 2.
    pub component: u32,
    pub pad: [u32; 3],
}

/// The render module's WGSL: the ramp's constants generated from [`RAMP`], then
/// `shaders/render.wgsl`.
pub fn shader_source() -> String {
    let stops: Vec<String> = RAMP
        .iter()
        .map(|[r, g, b]| format!("    vec3<f32>({r}.0, {g}.0, {b}.0),\n"))
        .collect();
    format!(
        "// Generated from render::RAMP.\n\
         var<private> STOPS: array<vec3<f32>, {n}> = array<vec3<f32>, {n}>(\n{stops});\n\
         const SEGMENTS: f32 = {segments}.0;\n\
         const LAST_SEGMENT: u32 = {last}u;\n\n{RENDER_WGSL}",
        n = RAMP.len(),
        stops = stops.concat(),
        segments = RAMP_SEGMENTS,
        last = RAMP_SEGMENTS - 1,
    )
}

/// The source and fragment entry point of `shading`: the render module's WGSL as it is
/// for the normal components; with the isophote entry point appended for isophotes.
pub fn shaded_source(shading: Shading) -> (String, &'static str) {
    match shading {
        Shading::Normals => (shader_source(), "fs"),
        Shading::Isophotes => (
            format!("{}\n{}", shader_source(), isophote_wgsl()),
            "fs_isophotes",
        ),
    }
}

/// How many indices a draw takes.
#[derive(Clone, Copy, Debug)]
pub enum IndexCount<'a> {
    /// Known on the host.
    Direct(u32),
    /// From `draw_indexed_indirect` arguments on the device
    /// ([`GpuTessellator::indirect`]).
    Indirect(&'a wgpu::Buffer),
}

/// What [`draw`] draws: vertices of [`vertex_layout`] and `u32` triangle indices.
#[derive(Clone, Copy, Debug)]
pub struct Geometry<'a> {
    /// The vertex buffer.
    pub vertices: &'a wgpu::Buffer,
    /// The index buffer.
    pub indices: &'a wgpu::Buffer,
    /// How many indices to draw.
    pub count: IndexCount<'a>,
}

/// Draws `mesh` (welded, with its record normals) in three panels coloured by n_x, n_y,
/// n_z, on `gpu`.
pub fn render_panels(
    gpu: &GpuContext,
    mesh: &StitchedMesh,
    opts: &RenderOptions,
) -> Result<Panels> {
    if mesh.triangles.is_empty() {
        return Err(Error::Invalid("render: no triangles".into()));
    }
    render_panels_on(gpu, mesh, opts)
}

/// [`render_panels`] on a given GPU context: the surface (computed on the host) is
/// uploaded into a vertex and an index buffer and drawn by [`draw`].
pub fn render_panels_on(
    gpu: &GpuContext,
    mesh: &StitchedMesh,
    opts: &RenderOptions,
) -> Result<Panels> {
    if mesh.triangles.is_empty() {
        return Err(Error::Invalid("render: no triangles".into()));
    }
    let limits = gpu.device.limits();
    let size = opts.panel.max(super::MIN_PANEL).min(super::max_panel(gpu));
    let camera = Camera::fit(&mesh.positions, opts.view, opts.up)?;
    let bytes = (VERTEX_BYTES * mesh.normals.len() as u64).max(12 * mesh.triangles.len() as u64);
    if bytes > limits.max_buffer_size {
        return Err(Error::limit(
            "max_buffer_size",
            bytes,
            limits.max_buffer_size,
            format!(
                "{}: {} vertices and {} triangles exceed the device's buffer size ({} bytes); \
                 evaluate the surface on a coarser grid",
                gpu.describe(),
                mesh.normals.len(),
                mesh.triangles.len(),
                limits.max_buffer_size
            ),
        ));
    }
    let (vertices, indices, count) = upload(&gpu.device, mesh);
    let geometry = Geometry {
        vertices: &vertices,
        indices: &indices,
        count: IndexCount::Direct(count),
    };
    let rgba = draw_shaded(
        &gpu.device,
        &gpu.queue,
        &geometry,
        &camera.rows(),
        size,
        opts.shading,
    )?;
    gpu.check()?;
    Ok(Panels { panel: size, rgba })
}

/// Uploads a host surface into a vertex buffer of [`vertex_layout`] (record positions and
/// normals rounded to f32) and an index buffer; returns them and the index count.
pub fn upload(dev: &wgpu::Device, mesh: &StitchedMesh) -> (wgpu::Buffer, wgpu::Buffer, u32) {
    let mut vertices: Vec<f32> = Vec::with_capacity(6 * mesh.normals.len());
    for (r, n) in mesh.record_position.iter().zip(&mesh.normals) {
        let p = mesh.positions[*r as usize];
        vertices.extend_from_slice(&[
            p.x as f32, p.y as f32, p.z as f32, n.x as f32, n.y as f32, n.z as f32,
        ]);
    }
    let indices: Vec<u32> = mesh.triangles.iter().flatten().copied().collect();
    let vbuf = dev.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("render vertices"),
        contents: bytemuck::cast_slice(&vertices),
        usage: wgpu::BufferUsages::VERTEX,
    });
    let ibuf = dev.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("render indices"),
        contents: bytemuck::cast_slice(&indices),
        usage: wgpu::BufferUsages::INDEX,
    });
    (vbuf, ibuf, indices.len() as u32)
}

/// Tessellates at `level` on the GPU with `tess` (built on `gpu`'s device) and draws the
/// result from the tessellator's own buffers. Only the surface's extent along the camera's
/// axes (24 bytes, [`GpuTessellator::record_bounds`]) comes back to fit the camera, as
/// [`Camera::fit`] fits it to a host surface.
pub fn render_tessellated(
    gpu: &GpuContext,
    tess: &mut GpuTessellator,
    level: u32,
    opts: &RenderOptions,
) -> Result<Panels> {
    let (dev, queue) = (&gpu.device, &gpu.queue);
    let size = opts.panel.max(super::MIN_PANEL).min(super::max_panel(gpu));
    let frame = Camera::frame(opts.view, opts.up)?;
    let axes = frame.map(|a| a.as_vec3().to_array());
    let staging = dev.create_buffer(&wgpu::BufferDescriptor {
        label: Some("render extent"),
        size: 24,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let mut enc = dev.create_command_encoder(&Default::default());
    let counts = tess.tessellate(dev, queue, &mut enc, level)?;
    if counts.indices == 0 {
        return Err(Error::Invalid("render: no triangles".into()));
    }
    tess.record_bounds(queue, &mut enc, axes)?;
    enc.copy_buffer_to_buffer(tess.bounds(), 0, &staging, 0, 24);
    queue.submit([enc.finish()]);
    let keys: Vec<u32> =
        crate::gpu::read_buffer(dev, &staging, 24, |b| bytemuck::cast_slice(b).to_vec())?;
    gpu.check()?;
    let keys: [u32; 6] = keys
        .try_into()
        .map_err(|_| Error::Gpu("render: short extent read back".into()))?;
    let (lo, hi) = decode_bounds(keys);
    let camera = Camera::from_extent(
        frame,
        glam::Vec3::from(lo).as_dvec3(),
        glam::Vec3::from(hi).as_dvec3(),
    )?;
    let geometry = Geometry {
        vertices: tess.vertices(),
        indices: tess.indices(),
        count: IndexCount::Indirect(tess.indirect()),
    };
    let rgba = draw_shaded(dev, queue, &geometry, &camera.rows(), size, opts.shading)?;
    gpu.check()?;
    Ok(Panels { panel: size, rgba })
}

/// The render pipeline of `shaders/render.wgsl` (with `shading`'s fragment entry point) and
/// its uniform layout.
fn pipeline(dev: &wgpu::Device, shading: Shading) -> (wgpu::RenderPipeline, wgpu::BindGroupLayout) {
    let (source, fragment) = shaded_source(shading);
    let module = dev.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("render"),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    });
    let bgl = dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("render uniforms"),
        entries: &[wgpu::BindGroupLayoutEntry {
            binding: 0,
            visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: false,
                min_binding_size: wgpu::BufferSize::new(std::mem::size_of::<Uniforms>() as u64),
            },
            count: None,
        }],
    });
    let layout = dev.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("render"),
        bind_group_layouts: &[Some(&bgl)],
        immediate_size: 0,
    });
    let pipeline = dev.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("render"),
        layout: Some(&layout),
        vertex: wgpu::VertexState {
            module: &module,
            entry_point: Some("vs"),
            compilation_options: Default::default(),
            buffers: &[Some(vertex_layout())],
        },
        primitive: wgpu::PrimitiveState {
            topology: wgpu::PrimitiveTopology::TriangleList,
            cull_mode: None,
            ..Default::default()
        },
        depth_stencil: Some(wgpu::DepthStencilState {
            format: DEPTH,
            depth_write_enabled: Some(true),
            depth_compare: Some(wgpu::CompareFunction::Less),
            stencil: Default::default(),
            bias: Default::default(),
        }),
        multisample: wgpu::MultisampleState {
            count: SAMPLES,
            ..Default::default()
        },
        fragment: Some(wgpu::FragmentState {
            module: &module,
            entry_point: Some(fragment),
            compilation_options: Default::default(),
            targets: &[Some(wgpu::ColorTargetState {
                format: COLOR,
                blend: None,
                write_mask: wgpu::ColorWrites::ALL,
            })],
        }),
        multiview_mask: None,
        cache: None,
    });
    (pipeline, bgl)
}

/// Draws `geometry` under the map `rows` into three `size`-pixel panels side by side,
/// coloured by the normal components' ramp; returns their RGBA rows, top to bottom, 4
/// bytes per pixel.
pub fn draw(
    dev: &wgpu::Device,
    queue: &wgpu::Queue,
    geometry: &Geometry<'_>,
    rows: &[[f32; 4]; 3],
    size: u32,
) -> Result<Vec<u8>> {
    draw_shaded(dev, queue, geometry, rows, size, Shading::Normals)
}

/// [`draw`] with the panels coloured by `shading`.
pub fn draw_shaded(
    dev: &wgpu::Device,
    queue: &wgpu::Queue,
    geometry: &Geometry<'_>,
    rows: &[[f32; 4]; 3],
    size: u32,
    shading: Shading,
) -> Result<Vec<u8>> {
    let width = 3 * size;
    let (pipeline, bgl) = pipeline(dev, shading);
    let bind_groups: Vec<wgpu::BindGroup> = (0..3u32)
        .map(|component| {
            let uniforms = Uniforms {
                rows: *rows,
                component,
                pad: [0; 3],
            };
            let buf = dev.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("render uniforms"),
                contents: bytemuck::bytes_of(&uniforms),
                usage: wgpu::BufferUsages::UNIFORM,
            });
            dev.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("render uniforms"),
                layout: &bgl,
                entries: &[wgpu::BindGroupEntry {
                    binding: 0,
                    resource: buf.as_entire_binding(),
                }],
            })
        })
        .collect();
    let extent = wgpu::Extent3d {
        width,
        height: size,
        depth_or_array_layers: 1,
    };
    let texture = |label, format, samples, usage| {
        dev.create_texture(&wgpu::TextureDescriptor {
            label: Some(label),
            size: extent,
            mip_level_count: 1,
            sample_count: samples,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage,
            view_formats: &[],
        })
    };
    let msaa = texture(
        "render msaa",
        COLOR,
        SAMPLES,
        wgpu::TextureUsages::RENDER_ATTACHMENT,
    );
    let resolved = texture(
        "render resolved",
        COLOR,
        1,
        wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
    );
    let depth = texture(
        "render depth",
        DEPTH,
        SAMPLES,
        wgpu::TextureUsages::RENDER_ATTACHMENT,
    );
    let view = |t: &wgpu::Texture| t.create_view(&Default::default());
    let (msaa_view, resolved_view, depth_view) = (view(&msaa), view(&resolved), view(&depth));
    let bg = wgpu::Color {
        r: BACKGROUND[0] as f64 / 255.0,
        g: BACKGROUND[1] as f64 / 255.0,
        b: BACKGROUND[2] as f64 / 255.0,
        a: 1.0,
    };
    let row_bytes = width * 4;
    let padded =
        row_bytes.div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
    let staging = dev.create_buffer(&wgpu::BufferDescriptor {
        label: Some("render readback"),
        size: padded as u64 * size as u64,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let mut enc = dev.create_command_encoder(&Default::default());
    {
        let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("normal components"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &msaa_view,
                depth_slice: None,
                resolve_target: Some(&resolved_view),
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(bg),
                    store: wgpu::StoreOp::Discard,
                },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &depth_view,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(1.0),
                    store: wgpu::StoreOp::Discard,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&pipeline);
        pass.set_vertex_buffer(0, geometry.vertices.slice(..));
        pass.set_index_buffer(geometry.indices.slice(..), wgpu::IndexFormat::Uint32);
        for (c, bind) in bind_groups.iter().enumerate() {
            pass.set_viewport(
                (c as u32 * size) as f32,
                0.0,
                size as f32,
                size as f32,
                0.0,
                1.0,
            );
            pass.set_bind_group(0, bind, &[]);
            match geometry.count {
                IndexCount::Direct(n) => pass.draw_indexed(0..n, 0, 0..1),
                IndexCount::Indirect(args) => pass.draw_indexed_indirect(args, 0),
            }
        }
    }
    enc.copy_texture_to_buffer(
        wgpu::TexelCopyTextureInfo {
            texture: &resolved,
            mip_level: 0,
            origin: wgpu::Origin3d::ZERO,
            aspect: wgpu::TextureAspect::All,
        },
        wgpu::TexelCopyBufferInfo {
            buffer: &staging,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(padded),
                rows_per_image: Some(size),
            },
        },
        extent,
    );
    queue.submit([enc.finish()]);
    crate::gpu::read_buffer(dev, &staging, staging.size(), |data| {
        let mut rgba = Vec::with_capacity((row_bytes * size) as usize);
        for row in data.chunks(padded as usize).take(size as usize) {
            rgba.extend_from_slice(&row[..row_bytes as usize]);
        }
        rgba
    })
}
