//! `GpuTessellator` in a host program, as a wgpu user writes one: a device opened by the
//! host with the published limits (and one with too few storage buffers, refused with a
//! typed error), screen-space levels that own their buffers, `prepare`, the per-frame loop
//! recording levels, tessellation and a draw into one encoder, and the exact counts read
//! back asynchronously, compared with the CPU's levels and stitch plan.

use g1tess::wgpu;
use g1tess::{
    screen_levels, Error, GpuTessellator, InnerRule, Mesh, PatchTable, Precision, Scheme,
    ScreenFrame, ScreenLevels, StitchPlan,
};

use crate::common;

fn ci() -> bool {
    std::env::var("CI").is_ok_and(|v| v == "true" || v == "1")
}

/// The adapter of the shared context (a host finds its own the same way), or None (SKIP)
/// without one; with CI=true a missing adapter fails.
fn adapter(test: &str) -> Option<wgpu::Adapter> {
    match common::shared_gpu() {
        Ok(ctx) => Some(ctx.adapter.clone()),
        Err(e) => {
            assert!(!ci(), "{test}: CI=true and no GPU adapter: {e}");
            eprintln!("\n======== SKIP {test}: no GPU adapter ({e}) ========\n");
            None
        }
    }
}

fn open(adapter: &wgpu::Adapter, limits: wgpu::Limits) -> (wgpu::Device, wgpu::Queue) {
    pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        label: Some("host"),
        required_features: GpuTessellator::required_features(Precision::F32),
        required_limits: limits,
        ..Default::default()
    }))
    .expect("the adapter opens a device with the published limits")
}

/// A device opened with 6 storage buffers per stage (the uniform passes bind 6, the
/// per-edge ones 8) is refused by `new` with the limit named, instead of returning `Ok`
/// and panicking in wgpu's validation on the first per-edge pass; with the published
/// limits the per-edge pass runs.
#[test]
fn a_device_with_too_few_storage_buffers_is_refused() {
    let Some(adapter) = adapter("a_device_with_too_few_storage_buffers_is_refused") else {
        return;
    };
    let mesh = common::load("icosphere:1");
    let table = PatchTable::build(&mesh, Scheme::G1, &Default::default()).unwrap();
    let six = wgpu::Limits {
        max_storage_buffers_per_shader_stage: 6,
        ..GpuTessellator::required_limits()
    };
    let (device, queue) = open(&adapter, six);
    let e = GpuTessellator::new(&device, &queue, &mesh, &table, Precision::F32)
        .err()
        .expect("a device of 6 storage buffers accepted");
    match &e {
        Error::LimitExceeded {
            name,
            needed,
            allowed,
            ..
        } => assert_eq!(
            (name.as_str(), *needed, *allowed),
            ("max_storage_buffers_per_shader_stage", 8, 6)
        ),
        other => panic!("not a limit error: {other:?}"),
    }
    assert_eq!(e.to_string().lines().count(), 1, "{e}");
    // The published limits are enough for every pass: a per-edge tessellation runs.
    let (device, queue) = open(&adapter, GpuTessellator::required_limits());
    let mut tess = GpuTessellator::new(&device, &queue, &mesh, &table, Precision::F32).unwrap();
    let screen = ScreenLevels::new(&device, &mesh).unwrap();
    let mut encoder = device.create_command_encoder(&Default::default());
    tess.tessellate_screen(
        &device,
        &queue,
        &mut encoder,
        &screen,
        &frame(0, 4),
        InnerRule::Max,
    )
    .unwrap();
    queue.submit([encoder.finish()]);
    let counts = pollster::block_on(tess.read_counts(&device, &queue)).unwrap();
    assert!(counts.indices > 0);
}

/// Frame `k` of a camera circling the origin at distance 3, looking at it (f32, as a
/// host holds it), 640 × 480 pixels, 6-pixel segments, levels up to `max_level`.
fn frame(k: u32, max_level: u32) -> ScreenFrame {
    let a = k as f32 * 0.9;
    let eye = glam::Vec3::new(3.0 * a.cos(), 0.8, 3.0 * a.sin());
    let view = glam::Mat4::look_at_rh(eye, glam::Vec3::ZERO, glam::Vec3::Y);
    let proj = glam::Mat4::perspective_rh(0.8, 640.0 / 480.0, 0.1, 20.0);
    ScreenFrame {
        view_proj: proj * view,
        viewport: [640.0, 480.0],
        target_px: 6.0,
        max_level,
    }
}

/// A render pipeline of the host's own: positions through a matrix, normals as colours,
/// the tessellator's vertex layout.
fn host_pipeline(device: &wgpu::Device) -> (wgpu::RenderPipeline, wgpu::Buffer, wgpu::BindGroup) {
    let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("host"),
        source: wgpu::ShaderSource::Wgsl(
            "@group(0) @binding(0) var<uniform> m: mat4x4<f32>;
             struct O { @builtin(position) p: vec4<f32>, @location(0) n: vec3<f32> };
             @vertex fn vs(@location(0) p: vec3<f32>, @location(1) n: vec3<f32>) -> O {
                 return O(m * vec4<f32>(p, 1.0), n);
             }
             @fragment fn fs(i: O) -> @location(0) vec4<f32> {
                 return vec4<f32>(0.5 * i.n + 0.5, 1.0);
             }"
            .into(),
        ),
    });
    let matrix = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("host matrix"),
        size: 64,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("host"),
        layout: None,
        vertex: wgpu::VertexState {
            module: &shader,
            entry_point: Some("vs"),
            compilation_options: Default::default(),
            buffers: &[Some(g1tess::vertex_layout())],
        },
        fragment: Some(wgpu::FragmentState {
            module: &shader,
            entry_point: Some("fs"),
            compilation_options: Default::default(),
            targets: &[Some(wgpu::TextureFormat::Rgba8Unorm.into())],
        }),
        primitive: wgpu::PrimitiveState::default(),
        depth_stencil: None,
        multisample: wgpu::MultisampleState::default(),
        multiview_mask: None,
        cache: None,
    });
    let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("host"),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[wgpu::BindGroupEntry {
            binding: 0,
            resource: matrix.as_entire_binding(),
        }],
    });
    (pipeline, matrix, group)
}

/// The per-frame loop of the module documentation on spot (5,856 triangles): three frames
/// of screen-space levels, tessellation and a draw in one encoder each, after `prepare`.
/// Each frame's levels equal the CPU's `screen_levels` on every edge, and the counts read
/// back equal the CPU stitch plan's for those levels exactly (without UVs, which the device's vertices do not carry) (both are counts of the same
/// numbering). `prepare` sized the buffers for the cap: no frame replaces them.
#[test]
fn the_per_frame_loop_matches_the_cpu() {
    let Some(adapter) = adapter("the_per_frame_loop_matches_the_cpu") else {
        return;
    };
    let mesh: Mesh = common::load("spot.obj");
    let adjacency = mesh.adjacency();
    // The device's vertices carry positions and normals only: no records split at the
    // UV seams of spot's texture coordinates.
    let mut plain = mesh.clone();
    plain.attributes = Default::default();
    let table = PatchTable::build(&mesh, Scheme::G1, &Default::default()).unwrap();
    let (device, queue) = open(&adapter, GpuTessellator::required_limits());
    let mut tess = GpuTessellator::new(&device, &queue, &mesh, &table, Precision::F32).unwrap();
    let screen = ScreenLevels::new(&device, &mesh).unwrap();
    assert_eq!(screen.edges() as usize, adjacency.edges.len());
    let max_level = 12;
    let cap = tess.prepare(&device, max_level).unwrap();
    let (vertices, indices) = (tess.vertices().clone(), tess.indices().clone());
    let (pipeline, matrix, group) = host_pipeline(&device);
    let target = device.create_texture(&wgpu::TextureDescriptor {
        label: Some("host target"),
        size: wgpu::Extent3d {
            width: 640,
            height: 480,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::Rgba8Unorm,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
        view_formats: &[],
    });
    let view = target.create_view(&Default::default());
    let staging = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("levels staging"),
        size: 4 * adjacency.edges.len() as u64,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut distinct = std::collections::HashSet::new();
    for k in 0..3 {
        let f = frame(k, max_level);
        queue.write_buffer(
            &matrix,
            0,
            bytemuck::cast_slice(&f.view_proj.to_cols_array()),
        );
        let mut encoder = device.create_command_encoder(&Default::default());
        tess.tessellate_screen(&device, &queue, &mut encoder, &screen, &f, InnerRule::Max)
            .unwrap();
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("host surface"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations::default(),
                })],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(&pipeline);
            pass.set_bind_group(0, &group, &[]);
            tess.draw(&mut pass);
        }
        encoder.copy_buffer_to_buffer(screen.levels(), 0, &staging, 0, staging.size());
        queue.submit([encoder.finish()]);
        let gpu_levels: Vec<u32> = g1tess::read_buffer(&device, &staging, staging.size(), |b| {
            bytemuck::cast_slice(b).to_vec()
        })
        .unwrap();
        let cpu = screen_levels(&mesh, &adjacency, &f.view(), InnerRule::Max).unwrap();
        assert_eq!(gpu_levels, cpu.edges, "frame {k}: levels");
        distinct.insert(cpu.edges.clone());
        let counts = pollster::block_on(tess.read_counts(&device, &queue)).unwrap();
        let plan = StitchPlan::with_levels(&plain, &adjacency, &cpu).unwrap();
        assert_eq!(
            (counts.vertices as usize, counts.triangles() as usize),
            (plan.records, plan.triangles),
            "frame {k}: counts"
        );
        assert_eq!(counts.level, max_level);
        assert!(tess.vertices() == &vertices && tess.indices() == &indices);
        assert!(plan.records as u64 <= cap.vertices);
    }
    // The camera moved: the frames' levels differ.
    assert_eq!(distinct.len(), 3);
}
