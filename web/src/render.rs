//! The render pipelines of the viewer: the tessellator's surface drawn from its own buffers
//! (`GpuTessellator::draw`, indexed and indirect), the wireframe pulled from the same
//! buffers, and the validity overlay.

use g1tess::wgpu;
use g1tess::GpuTessellator;
use wgpu::util::DeviceExt;

/// The depth buffer's format.
const DEPTH: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// How the surface is shaded (the `#shading` names).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Shading {
    Normals = 0,
    Lit = 1,
    Wireframe = 2,
    Validity = 3,
}

impl Shading {
    pub fn parse(name: &str) -> Result<Shading, String> {
        match name {
            "normals" => Ok(Shading::Normals),
            "lit" => Ok(Shading::Lit),
            "wireframe" => Ok(Shading::Wireframe),
            "validity" => Ok(Shading::Validity),
            _ => Err(format!(
                "unknown shading '{name}' (known: normals, lit, wireframe, validity)"
            )),
        }
    }
}

/// `View` of `view.wgsl`.
#[repr(C)]
#[derive(Clone, Copy)]
struct ViewUniform {
    view_proj: [f32; 16],
    eye: [f32; 4],
    mode: [u32; 4],
}

impl ViewUniform {
    fn bytes(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(96);
        for x in self.view_proj.iter().chain(&self.eye) {
            out.extend_from_slice(&x.to_le_bytes());
        }
        for x in self.mode {
            out.extend_from_slice(&x.to_le_bytes());
        }
        out
    }
}

/// Flat triangles with a colour each corner: position (3 f32), RGBA (4 f32).
pub struct Overlay {
    buffer: wgpu::Buffer,
    vertices: u32,
}

impl Overlay {
    /// `triangles` as (corners, colour); `None` when there are none.
    pub fn new(device: &wgpu::Device, triangles: &[([[f32; 3]; 3], [f32; 4])]) -> Option<Self> {
        if triangles.is_empty() {
            return None;
        }
        let mut data = Vec::with_capacity(triangles.len() * 3 * 28);
        for (corners, colour) in triangles {
            for c in corners {
                for x in c.iter().chain(colour) {
                    data.extend_from_slice(&x.to_le_bytes());
                }
            }
        }
        let buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("validity overlay"),
            contents: &data,
            usage: wgpu::BufferUsages::VERTEX,
        });
        Some(Overlay {
            buffer,
            vertices: triangles.len() as u32 * 3,
        })
    }
}

/// Pipelines, the view's uniform and the depth buffer.
pub struct Renderer {
    surface_pipeline: wgpu::RenderPipeline,
    wire_pipeline: wgpu::RenderPipeline,
    mark_pipeline: wgpu::RenderPipeline,
    wire_layout: wgpu::BindGroupLayout,
    uniform: wgpu::Buffer,
    view_group: wgpu::BindGroup,
    /// The wireframe's bind group with the vertex and index buffers it binds.
    wire_group: Option<(wgpu::Buffer, wgpu::Buffer, wgpu::BindGroup)>,
    depth: wgpu::TextureView,
    size: (u32, u32),
}

/// One render pipeline of `view.wgsl`.
struct PipelineSpec<'a> {
    vs: &'a str,
    fs: &'a str,
    buffers: &'a [Option<wgpu::VertexBufferLayout<'a>>],
    blend: Option<wgpu::BlendState>,
    depth_compare: wgpu::CompareFunction,
    depth_write: bool,
}

fn pipeline(
    device: &wgpu::Device,
    module: &wgpu::ShaderModule,
    layout: &wgpu::PipelineLayout,
    format: wgpu::TextureFormat,
    spec: PipelineSpec<'_>,
) -> wgpu::RenderPipeline {
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(spec.vs),
        layout: Some(layout),
        vertex: wgpu::VertexState {
            module,
            entry_point: Some(spec.vs),
            compilation_options: Default::default(),
            buffers: spec.buffers,
        },
        primitive: wgpu::PrimitiveState {
            topology: wgpu::PrimitiveTopology::TriangleList,
            cull_mode: None,
            ..Default::default()
        },
        depth_stencil: Some(wgpu::DepthStencilState {
            format: DEPTH,
            depth_write_enabled: Some(spec.depth_write),
            depth_compare: Some(spec.depth_compare),
            stencil: Default::default(),
            bias: Default::default(),
        }),
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module,
            entry_point: Some(spec.fs),
            compilation_options: Default::default(),
            targets: &[Some(wgpu::ColorTargetState {
                format,
                blend: spec.blend,
                write_mask: wgpu::ColorWrites::ALL,
            })],
        }),
        multiview_mask: None,
        cache: None,
    })
}

fn layout_entry(
    binding: u32,
    stage: wgpu::ShaderStages,
    ty: wgpu::BufferBindingType,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: stage,
        ty: wgpu::BindingType::Buffer {
            ty,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

fn depth_view(device: &wgpu::Device, (width, height): (u32, u32)) -> wgpu::TextureView {
    device
        .create_texture(&wgpu::TextureDescriptor {
            label: Some("depth"),
            size: wgpu::Extent3d {
                width,
                height,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: DEPTH,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
            view_formats: &[],
        })
        .create_view(&Default::default())
}

impl Renderer {
    pub fn new(device: &wgpu::Device, format: wgpu::TextureFormat, size: (u32, u32)) -> Renderer {
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("view.wgsl"),
            source: wgpu::ShaderSource::Wgsl(include_str!("view.wgsl").into()),
        });
        let both = wgpu::ShaderStages::VERTEX_FRAGMENT;
        let view_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("view"),
            entries: &[layout_entry(0, both, wgpu::BufferBindingType::Uniform)],
        });
        let read = wgpu::BufferBindingType::Storage { read_only: true };
        let wire_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("wireframe"),
            entries: &[
                layout_entry(0, wgpu::ShaderStages::VERTEX, read),
                layout_entry(1, wgpu::ShaderStages::VERTEX, read),
            ],
        });
        let plain = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("view"),
            bind_group_layouts: &[Some(&view_layout)],
            immediate_size: 0,
        });
        let pulled = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("wireframe"),
            bind_group_layouts: &[Some(&view_layout), Some(&wire_layout)],
            immediate_size: 0,
        });
        let less = wgpu::CompareFunction::Less;
        let surface_pipeline = pipeline(
            device,
            &module,
            &plain,
            format,
            PipelineSpec {
                vs: "vs",
                fs: "fs",
                buffers: &[Some(g1tess::vertex_layout())],
                blend: None,
                depth_compare: less,
                depth_write: true,
            },
        );
        let wire_pipeline = pipeline(
            device,
            &module,
            &pulled,
            format,
            PipelineSpec {
                vs: "vs_wire",
                fs: "fs_wire",
                buffers: &[],
                blend: None,
                depth_compare: less,
                depth_write: true,
            },
        );
        let mark_attributes = wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x4];
        let mark_pipeline = pipeline(
            device,
            &module,
            &plain,
            format,
            PipelineSpec {
                vs: "vs_mark",
                fs: "fs_mark",
                buffers: &[Some(wgpu::VertexBufferLayout {
                    array_stride: 28,
                    step_mode: wgpu::VertexStepMode::Vertex,
                    attributes: &mark_attributes,
                })],
                blend: Some(wgpu::BlendState::ALPHA_BLENDING),
                // Marked on top: the flat triangles lie partly inside the curved surface.
                depth_compare: wgpu::CompareFunction::Always,
                depth_write: false,
            },
        );
        let uniform = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("view"),
            size: 96,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let view_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("view"),
            layout: &view_layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: uniform.as_entire_binding(),
            }],
        });
        Renderer {
            surface_pipeline,
            wire_pipeline,
            mark_pipeline,
            wire_layout,
            uniform,
            view_group,
            wire_group: None,
            depth: depth_view(device, size),
            size,
        }
    }

    /// Keeps the depth buffer the size of the target.
    pub fn resize(&mut self, device: &wgpu::Device, size: (u32, u32)) {
        if size != self.size {
            self.depth = depth_view(device, size);
            self.size = size;
        }
    }

    /// The wireframe's bind group, made again only when the tessellator's buffers change.
    fn wire_group(&mut self, device: &wgpu::Device, tess: &GpuTessellator) -> &wgpu::BindGroup {
        let (v, i) = (tess.vertices(), tess.indices());
        let stale = match &self.wire_group {
            Some((gv, gi, _)) => gv != v || gi != i,
            None => true,
        };
        if stale {
            let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("wireframe"),
                layout: &self.wire_layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: v.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: i.as_entire_binding(),
                    },
                ],
            });
            self.wire_group = Some((v.clone(), i.clone(), group));
        }
        &self.wire_group.as_ref().expect("just made").2
    }

    /// Records the frame's render pass into `encoder`: the surface as `shading` says, and
    /// with validity shading the overlay.
    #[allow(clippy::too_many_arguments)]
    pub fn draw(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        target: &wgpu::TextureView,
        tess: &GpuTessellator,
        camera: (g1tess::glam::Mat4, g1tess::glam::Vec3),
        shading: Shading,
        overlay: Option<&Overlay>,
    ) {
        let (view_proj, eye) = camera;
        let uniform = ViewUniform {
            view_proj: view_proj.to_cols_array(),
            eye: [eye.x, eye.y, eye.z, 1.0],
            mode: [shading as u32, 0, 0, 0],
        };
        queue.write_buffer(&self.uniform, 0, &uniform.bytes());
        if shading == Shading::Wireframe {
            self.wire_group(device, tess);
        }
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("view"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: target,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color {
                        r: 0.0,
                        g: 0.0,
                        b: 0.0,
                        a: 1.0,
                    }),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &self.depth,
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
        pass.set_bind_group(0, &self.view_group, &[]);
        if shading == Shading::Wireframe {
            let group = &self.wire_group.as_ref().expect("made above").2;
            pass.set_pipeline(&self.wire_pipeline);
            pass.set_bind_group(1, group, &[]);
            // The indexed arguments' first four words read as a plain draw's: index count
            // as vertex count, instances, first index 0 as first vertex, base vertex 0 as
            // first instance.
            pass.draw_indirect(tess.indirect(), 0);
        } else {
            pass.set_pipeline(&self.surface_pipeline);
            tess.draw(&mut pass);
        }
        if let (Shading::Validity, Some(o)) = (shading, overlay) {
            pass.set_pipeline(&self.mark_pipeline);
            pass.set_vertex_buffer(0, o.buffer.slice(..));
            pass.draw(0..o.vertices, 0..1);
        }
    }
}
