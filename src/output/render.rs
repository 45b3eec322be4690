//! Pictures of the normal field (the paper's figures 13–16): the welded surface drawn
//! headless with a wgpu render pass, coloured by n_x, n_y and n_z in three panels with one
//! colour ramp, under an orthographic camera fitted to the surface's bounding box; then
//! titles and a legend (plotters, the shipped font) and a PNG written atomically.
//!
//! The device is a Vulkan adapter only (lavapipe in tests), opened once per process by
//! [`device`].

use std::path::Path;
use std::sync::Arc;

use glam::DVec3;
use plotters::prelude::*;

use super::plot::register_font;
use crate::gpu::GpuContext;
use crate::tess::stitch::StitchedMesh;
use crate::{Error, Result};

/// Background of the panels (white).
pub const BACKGROUND: [u8; 3] = [255, 255, 255];

/// The colour ramp over [−1, 1]: nine stops, linear in between (turbo-like: dark blue,
/// blue, cyan, green, yellow-green, yellow, orange, red, dark red). The shader holds the
/// same table.
pub const RAMP: [[u8; 3]; 9] = [
    [48, 18, 59],
    [65, 105, 225],
    [32, 170, 230],
    [40, 210, 160],
    [140, 230, 70],
    [230, 215, 50],
    [250, 150, 40],
    [220, 70, 25],
    [122, 4, 3],
];

/// Colour of value `v` in [−1, 1] (clamped), as the shader computes it (up to rounding).
pub fn ramp(v: f64) -> [u8; 3] {
    let t = ((v + 1.0) * 4.0).clamp(0.0, 8.0);
    let i = (t.floor() as usize).min(7);
    let f = t - i as f64;
    std::array::from_fn(|c| {
        let a = RAMP[i][c] as f64;
        let b = RAMP[i + 1][c] as f64;
        (a + (b - a) * f).round() as u8
    })
}

/// How to draw.
#[derive(Clone, Debug)]
pub struct RenderOptions {
    /// Side of one square panel in pixels.
    pub panel: u32,
    /// Direction from the surface towards the camera.
    pub view: DVec3,
    /// Direction that points up in the picture (projected perpendicular to `view`).
    pub up: DVec3,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            panel: 512,
            view: DVec3::Z,
            up: DVec3::Y,
        }
    }
}

/// Three rendered panels (n_x, n_y, n_z), side by side, RGBA rows top to bottom.
#[derive(Clone, Debug)]
pub struct Panels {
    pub panel: u32,
    /// Width 3 × panel, height panel, 4 bytes per pixel.
    pub rgba: Vec<u8>,
}

impl Panels {
    /// RGB of pixel (x, y) of panel `c` (0: n_x, 1: n_y, 2: n_z).
    pub fn pixel(&self, c: usize, x: u32, y: u32) -> [u8; 3] {
        let w = 3 * self.panel as usize;
        let i = 4 * (y as usize * w + c * self.panel as usize + x as usize);
        [self.rgba[i], self.rgba[i + 1], self.rgba[i + 2]]
    }
}

/// The process's GPU (the shared Vulkan-only [`GpuContext`]), opened on first use; an
/// error such as no Vulkan driver is remembered and returned every time.
pub fn device() -> Result<Arc<GpuContext>> {
    GpuContext::shared()
}

const SHADER: &str = r#"
struct Uniforms {
    // Rows of the orthographic map: clip = (dot(x, p) + x.w, dot(y, p) + y.w, ...).
    x: vec4<f32>,
    y: vec4<f32>,
    z: vec4<f32>,
    component: u32,
    pad0: u32,
    pad1: u32,
    pad2: u32,
};

@group(0) @binding(0) var<uniform> u: Uniforms;

var<private> STOPS: array<vec3<f32>, 9> = array<vec3<f32>, 9>(
    vec3<f32>(48.0, 18.0, 59.0),
    vec3<f32>(65.0, 105.0, 225.0),
    vec3<f32>(32.0, 170.0, 230.0),
    vec3<f32>(40.0, 210.0, 160.0),
    vec3<f32>(140.0, 230.0, 70.0),
    vec3<f32>(230.0, 215.0, 50.0),
    vec3<f32>(250.0, 150.0, 40.0),
    vec3<f32>(220.0, 70.0, 25.0),
    vec3<f32>(122.0, 4.0, 3.0),
);

struct VsOut {
    @builtin(position) pos: vec4<f32>,
    @location(0) n: vec3<f32>,
};

@vertex
fn vs(@location(0) p: vec3<f32>, @location(1) n: vec3<f32>) -> VsOut {
    var out: VsOut;
    out.pos = vec4<f32>(
        dot(u.x.xyz, p) + u.x.w,
        dot(u.y.xyz, p) + u.y.w,
        dot(u.z.xyz, p) + u.z.w,
        1.0,
    );
    out.n = n;
    return out;
}

fn ramp(v: f32) -> vec3<f32> {
    let t = clamp((v + 1.0) * 4.0, 0.0, 8.0);
    let i = min(u32(floor(t)), 7u);
    let f = t - f32(i);
    return mix(STOPS[i], STOPS[i + 1u], f) / 255.0;
}

@fragment
fn fs(in: VsOut) -> @location(0) vec4<f32> {
    let n = normalize(in.n);
    return vec4<f32>(ramp(n[u.component]), 1.0);
}
"#;

const SAMPLES: u32 = 4;
const COLOR: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;
const DEPTH: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// The camera: an orthonormal frame (right, up, towards the viewer) and the orthographic
/// map fitted to the surface's bounding box in that frame.
fn camera(mesh: &StitchedMesh, opts: &RenderOptions) -> Result<[[f32; 4]; 3]> {
    let z = opts
        .view
        .try_normalize()
        .ok_or_else(|| Error::Invalid("render: the view direction is zero".into()))?;
    let mut up = opts.up - opts.up.dot(z) * z;
    if up.length() < 1e-9 {
        // Up along the view: take any perpendicular.
        up = z.any_orthonormal_vector();
    }
    let y = up.normalize();
    let x = y.cross(z);
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    for p in &mesh.positions {
        let q = DVec3::new(p.dot(x), p.dot(y), p.dot(z));
        lo = lo.min(q);
        hi = hi.max(q);
    }
    if !lo.is_finite() || !hi.is_finite() {
        return Err(Error::Invalid("render: empty or non-finite surface".into()));
    }
    let c = 0.5 * (lo + hi);
    let half = 0.5 * (hi - lo);
    // Square panels: the larger of the two extents, 4 % margin.
    let e = (half.x.max(half.y) * 1.04).max(1e-300);
    let d = (half.z * 1.02).max(1e-300);
    // clip x = (p·x − c.x)/e, y likewise; depth in [0, 1], nearer (larger p·z) smaller.
    let row = |axis: DVec3, centre: f64, scale: f64, offset: f64| -> [f32; 4] {
        [
            (axis.x * scale) as f32,
            (axis.y * scale) as f32,
            (axis.z * scale) as f32,
            (offset - centre * scale) as f32,
        ]
    };
    Ok([
        row(x, c.x, 1.0 / e, 0.0),
        row(y, c.y, 1.0 / e, 0.0),
        row(z, c.z, -0.5 / d, 0.5),
    ])
}

/// Draws `mesh` (welded, with its record normals) in three panels coloured by n_x, n_y,
/// n_z.
pub fn render_panels(mesh: &StitchedMesh, opts: &RenderOptions) -> Result<Panels> {
    use wgpu::util::DeviceExt;
    if mesh.triangles.is_empty() {
        return Err(Error::Invalid("render: no triangles".into()));
    }
    let gpu = device()?;
    let dev = &gpu.device;
    let limits = dev.limits();
    let size = opts
        .panel
        .clamp(16, 4096)
        .min(limits.max_texture_dimension_2d / 3);
    let width = 3 * size;
    let rows = camera(mesh, opts)?;
    let bytes = (24 * mesh.normals.len()).max(12 * mesh.triangles.len()) as u64;
    if bytes > limits.max_buffer_size {
        return Err(Error::Gpu(format!(
            "{}: {} vertices and {} triangles exceed the device's buffer size ({} bytes); \
             use a lower --level",
            gpu.describe(),
            mesh.normals.len(),
            mesh.triangles.len(),
            limits.max_buffer_size
        )));
    }

    // Vertices: record positions and normals as f32, interleaved.
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
    let module = dev.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("render"),
        source: wgpu::ShaderSource::Wgsl(SHADER.into()),
    });
    let bgl = dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("render uniforms"),
        entries: &[wgpu::BindGroupLayoutEntry {
            binding: 0,
            visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: false,
                min_binding_size: None,
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
            buffers: &[Some(wgpu::VertexBufferLayout {
                array_stride: 24,
                step_mode: wgpu::VertexStepMode::Vertex,
                attributes: &wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3],
            })],
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
            entry_point: Some("fs"),
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
    let bind_groups: Vec<wgpu::BindGroup> = (0..3u32)
        .map(|c| {
            let mut data: Vec<f32> = rows.iter().flatten().copied().collect();
            data.extend_from_slice(&[f32::from_bits(c), 0.0, 0.0, 0.0]);
            let buf = dev.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("render uniforms"),
                contents: bytemuck::cast_slice(&data),
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
        pass.set_vertex_buffer(0, vbuf.slice(..));
        pass.set_index_buffer(ibuf.slice(..), wgpu::IndexFormat::Uint32);
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
            pass.draw_indexed(0..indices.len() as u32, 0, 0..1);
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
    gpu.queue.submit([enc.finish()]);
    let slice = staging.slice(..);
    let (tx, rx) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |r| {
        let _ = tx.send(r);
    });
    dev.poll(wgpu::PollType::wait_indefinitely())
        .map_err(|e| Error::Gpu(format!("device poll: {e}")))?;
    rx.recv()
        .map_err(|_| Error::Gpu("readback never completed".into()))?
        .map_err(|e| Error::Gpu(format!("readback: {e}")))?;
    let mut rgba = Vec::with_capacity((row_bytes * size) as usize);
    {
        let data = slice
            .get_mapped_range()
            .map_err(|e| Error::Gpu(format!("readback: {e}")))?;
        for row in data.chunks(padded as usize).take(size as usize) {
            rgba.extend_from_slice(&row[..row_bytes as usize]);
        }
    }
    staging.unmap();
    gpu.check()?;
    Ok(Panels { panel: size, rgba })
}

/// One row of a picture: a label (the scheme) and its panels.
pub struct Row {
    pub label: String,
    pub panels: Panels,
}

const MARGIN: u32 = 16;
const TITLE: u32 = 34;
const LEGEND: u32 = 70;

/// Composes rows of panels under `caption`, each panel titled n_x, n_y, n_z, with the
/// colour ramp's legend below, and writes a PNG to `path` atomically.
pub fn write_png(path: &Path, caption: &str, rows: &[Row]) -> Result<()> {
    let panel = rows
        .first()
        .map(|r| r.panels.panel)
        .ok_or_else(|| Error::Invalid("render: nothing to draw".into()))?;
    if rows.iter().any(|r| r.panels.panel != panel) {
        return Err(Error::Invalid("render: rows of different sizes".into()));
    }
    let width = 3 * panel + 4 * MARGIN;
    let height = TITLE + rows.len() as u32 * (panel + TITLE) + LEGEND + MARGIN;
    // The panels go into an RGB canvas first, text and legend on top.
    let mut rgb = vec![255u8; (width * height * 3) as usize];
    let mut put = |x: u32, y: u32, c: [u8; 3]| {
        let i = 3 * (y * width + x) as usize;
        rgb[i..i + 3].copy_from_slice(&c);
    };
    for (r, row) in rows.iter().enumerate() {
        let top = TITLE + r as u32 * (panel + TITLE) + TITLE;
        for c in 0..3u32 {
            let left = MARGIN + c * (panel + MARGIN);
            for y in 0..panel {
                for x in 0..panel {
                    put(left + x, top + y, row.panels.pixel(c as usize, x, y));
                }
            }
        }
    }
    // The legend's colour bar.
    let bar_w = (3 * panel + 2 * MARGIN) / 2;
    let bar_x = (width - bar_w) / 2;
    let bar_y = height - MARGIN - LEGEND + 8;
    for x in 0..bar_w {
        let v = -1.0 + 2.0 * (x as f64 + 0.5) / bar_w as f64;
        for y in 0..18 {
            put(bar_x + x, bar_y + y, ramp(v));
        }
    }

    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => std::path::PathBuf::from("."),
    };
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .ok_or_else(|| Error::Invalid(format!("{}: not a file path", path.display())))?;
    let tmp = dir.join(format!(".{name}.tmp-{}.png", std::process::id()));
    let err = |e: String| Error::io(path, std::io::Error::other(format!("drawing failed: {e}")));
    register_font();
    let drawn = (|| -> std::result::Result<(), String> {
        let mut backend = BitMapBackend::new(&tmp, (width, height));
        backend
            .blit_bitmap((0, 0), (width, height), &rgb)
            .map_err(|e| e.to_string())?;
        let root = backend.into_drawing_area();
        let font = |px: u32| ("sans-serif", px as f64).into_font().color(&BLACK);
        root.draw_text(caption, &font(20), (MARGIN as i32, 8))
            .map_err(|e| e.to_string())?;
        for (r, row) in rows.iter().enumerate() {
            let top = (TITLE + r as u32 * (panel + TITLE)) as i32;
            for (c, comp) in ["n_x", "n_y", "n_z"].iter().enumerate() {
                let left = (MARGIN + c as u32 * (panel + MARGIN)) as i32;
                root.draw_text(
                    &format!("{}: {comp}", row.label),
                    &font(18),
                    (left, top + 10),
                )
                .map_err(|e| e.to_string())?;
            }
        }
        for (k, v) in [-1.0, -0.5, 0.0, 0.5, 1.0].iter().enumerate() {
            let x = bar_x as i32 + (k as i32 * (bar_w as i32 - 1)) / 4;
            root.draw(&PathElement::new(
                vec![(x, bar_y as i32 + 18), (x, bar_y as i32 + 24)],
                BLACK,
            ))
            .map_err(|e| e.to_string())?;
            let label = format!("{v}");
            root.draw_text(
                &label,
                &font(15),
                (x - 4 * label.len() as i32, bar_y as i32 + 27),
            )
            .map_err(|e| e.to_string())?;
        }
        root.draw_text(
            "normal component",
            &font(15),
            (bar_x as i32 + bar_w as i32 + 10, bar_y as i32 + 1),
        )
        .map_err(|e| e.to_string())?;
        root.present().map_err(|e| e.to_string())
    })();
    if let Err(e) = drawn {
        let _ = std::fs::remove_file(&tmp);
        return Err(err(e));
    }
    std::fs::rename(&tmp, path).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        Error::io(path, e)
    })
}
