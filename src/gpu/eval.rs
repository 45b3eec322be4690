//! The GPU backend: WGSL compute shaders (`shaders/`) through wgpu, f32 or f64.
//!
//! The module is chosen by the table's [`PatchKind`] (see [`crate::gpu::shaders`]) and its
//! pipelines are cached per (kind, precision), so every scheme of one kind shares them.
//!
//! Each patch is uploaded as its *patch data* (`shaders/common.wgsl`): control points
//! relative to its first corner (so f32 keeps its digits on meshes far from the origin),
//! its flat normal, the corner split into a high and a low part, and its three corners
//! rounded once. The shaders add the origin back (high + (low + relative)) and write the
//! corner samples as the uploaded corners, so [`Evaluator::evaluate_f32`] hands the GPU's
//! f32 values to the sink as they are (corners: the input rounded once), while
//! [`Evaluator::evaluate`] widens them, renormalises the normals in f64 and puts the input
//! corners back exactly.
//!
//! Work is split so that no storage binding exceeds the adapter's limit and no dispatch
//! dimension exceeds its workgroup limit, and results stream to the sink chunk by chunk.
//! The device work is done by free functions on `(&Device, &Queue, ...)`
//! ([`bind_group_layout`], [`create_pipelines_with`], [`dispatch`]) and results come back
//! through [`crate::gpu::read_buffer`].

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use glam::DVec3;
use rayon::prelude::*;

use crate::eval::{grid_barycentrics, grid_len, Chunk, ChunkF32, Evaluator, PatchPoint, Pattern};
use crate::gpu::readback::read_buffer_after;
use crate::gpu::shaders::{self, SLOT_CORNERS, SLOT_FLAT_NORMAL, SLOT_ORIGIN_LO};
use crate::gpu::{GpuContext, Precision};
use crate::patch::{PatchKind, PatchTable};
use crate::{Error, Result};

/// Threads per workgroup (the generated `WORKGROUP` of every evaluation shader).
pub use crate::gpu::shaders::WORKGROUP;

/// Reals written per sample: position then normal.
const OUT_REALS: usize = 6;

/// A real of the shaders' working precision.
pub trait Real: bytemuck::Pod + Send + Sync {
    const PRECISION: Precision;
    fn of(x: f64) -> Self;
    fn get(self) -> f64;
    /// The vectors in f32: themselves for f32, rounded once into `scratch` for f64.
    fn as_f32<'a>(v: &'a [[Self; 3]], scratch: &'a mut Vec<[f32; 3]>) -> &'a [[f32; 3]];
}

impl Real for f32 {
    const PRECISION: Precision = Precision::F32;
    #[inline]
    fn of(x: f64) -> f32 {
        x as f32
    }
    #[inline]
    fn get(self) -> f64 {
        self as f64
    }
    fn as_f32<'a>(v: &'a [[f32; 3]], _: &'a mut Vec<[f32; 3]>) -> &'a [[f32; 3]] {
        v
    }
}

impl Real for f64 {
    const PRECISION: Precision = Precision::F64;
    #[inline]
    fn of(x: f64) -> f64 {
        x
    }
    #[inline]
    fn get(self) -> f64 {
        self
    }
    fn as_f32<'a>(v: &'a [[f64; 3]], scratch: &'a mut Vec<[f32; 3]>) -> &'a [[f32; 3]] {
        scratch.clear();
        scratch.extend(v.iter().map(|p| p.map(|x| x as f32)));
        scratch
    }
}

/// `Params` of `shaders/common.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Params {
    pub count: u32,
    pub first_local: u32,
    pub level: u32,
    pub per: u32,
    pub groups_x: u32,
    pub _pad: [u32; 3],
}

/// The compute pipelines of one (patch kind, precision).
pub struct Pipelines {
    pub kind: PatchKind,
    pub precision: Precision,
    /// Whether wgpu's runtime checks were kept ([`shader_module`]).
    pub runtime_checks: bool,
    /// Grid, one thread per patch (`grid_patch_main`: the basis from a uniform table, G1's
    /// evaluated in the shader), with its bind group layout
    /// ([`patch_loop_bind_group_layout`]); none where the device's uniform bindings are
    /// smaller than [`shaders::UNIFORM_TABLE_BYTES`].
    pub grid_patch: Option<(wgpu::BindGroupLayout, wgpu::ComputePipeline)>,
    /// Grid, basis computed in the shader.
    pub grid: wgpu::ComputePipeline,
    /// Grid, basis read from the precomputed table.
    pub grid_table: wgpu::ComputePipeline,
    pub points: wgpu::ComputePipeline,
}

/// The bind group layout every evaluation shader uses: 0 params (uniform), 1 patch data,
/// 2 points (read-only storage), 3 output (storage), 4 grid basis table (read-only).
pub fn bind_group_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    let storage = |binding, read_only| wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    };
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("g1tess eval"),
        entries: &[
            wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            },
            storage(1, true),
            storage(2, true),
            storage(3, false),
            storage(4, true),
        ],
    })
}

/// The bind group layout of `grid_patch_main`: 0 params (uniform), 1 patch data, 5 the
/// grid's basis ([`shaders::UNIFORM_TABLE_BYTES`], uniform), 7 the output (storage, seen
/// as vec4s).
pub fn patch_loop_bind_group_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
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
    use wgpu::BufferBindingType as T;
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("g1tess eval, patch loop"),
        entries: &[
            entry(0, T::Uniform),
            entry(1, T::Storage { read_only: true }),
            entry(5, T::Uniform),
            entry(7, T::Storage { read_only: false }),
        ],
    })
}

/// A module of this crate's own WGSL. With `runtime_checks` false it is created *trusted*:
/// wgpu asks naga for no bounds checks and no loop bounding (`force_loop_bounding` adds a
/// counter to every loop, and index clamps are added to every dynamic index of a local
/// array; on lavapipe both cost far more than the arithmetic). Buffer accesses are still
/// guarded by the driver's robust buffer access where it has it.
///
/// The shaders satisfy what that asks: every loop ends (constant bounds, and `grid_ij`'s
/// search moves one way towards the one row holding its index), every index into a local
/// array is below its length by construction, and the host sizes each binding for the
/// threads it dispatches (threads past `count` return at once).
pub fn shader_module(
    device: &wgpu::Device,
    label: &str,
    source: String,
    runtime_checks: bool,
) -> wgpu::ShaderModule {
    let desc = wgpu::ShaderModuleDescriptor {
        label: Some(label),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    };
    if runtime_checks {
        device.create_shader_module(desc)
    } else {
        // SAFETY: the crate's own shaders, which meet the conditions of
        // `ShaderRuntimeChecks::unchecked` as the doc comment above explains; validated with
        // naga before (`shaders::validate`).
        unsafe { device.create_shader_module_trusted(desc, wgpu::ShaderRuntimeChecks::unchecked()) }
    }
}

/// [`create_pipelines_with`], choosing whether wgpu adds its runtime checks ([`shader_module`]).
pub fn create_pipelines_with(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    kind: PatchKind,
    precision: Precision,
    runtime_checks: bool,
) -> Result<Pipelines> {
    let source = shaders::module_source(kind, precision)?;
    pipelines_from(device, layout, kind, precision, runtime_checks, source)
}

/// The pipelines of `kind` built from `source`, a module with `kind`'s layout (the
/// kind's own, or [`shaders::loop_bound_source`]).
fn pipelines_from(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    kind: PatchKind,
    precision: Precision,
    runtime_checks: bool,
    source: String,
) -> Result<Pipelines> {
    let file = shaders::file_for(kind);
    shaders::validate(&source, precision)
        .map_err(|e| Error::Gpu(format!("shaders/{} ({kind:?}): {e}", file.name)))?;
    let module = shader_module(device, file.name, source, runtime_checks);
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("g1tess eval"),
        bind_group_layouts: &[Some(layout)],
        immediate_size: 0,
    });
    let make = |entry: &str| {
        device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(file.name),
            layout: Some(&pipeline_layout),
            module: &module,
            entry_point: Some(entry),
            compilation_options: Default::default(),
            cache: None,
        })
    };
    // One thread per patch, where the device's uniform bindings hold the basis table.
    let grid_patch = (device.limits().max_uniform_buffer_binding_size
        >= shaders::UNIFORM_TABLE_BYTES as u64)
        .then(|| {
            let layout = patch_loop_bind_group_layout(device);
            let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("g1tess eval, patch loop"),
                bind_group_layouts: &[Some(&layout)],
                immediate_size: 0,
            });
            let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(file.name),
                layout: Some(&pipeline_layout),
                module: &module,
                entry_point: Some("grid_patch_main"),
                compilation_options: Default::default(),
                cache: None,
            });
            (layout, pipeline)
        });
    Ok(Pipelines {
        kind,
        precision,
        runtime_checks,
        grid_patch,
        grid: make("grid_main"),
        grid_table: make("grid_table_main"),
        points: make("points_main"),
    })
}

/// The buffers of one evaluation, reused chunk after chunk.
pub struct Buffers {
    pub params: wgpu::Buffer,
    pub patch_data: wgpu::Buffer,
    pub points: wgpu::Buffer,
    pub out: wgpu::Buffer,
    pub staging: wgpu::Buffer,
    pub grid_weights: wgpu::Buffer,
    pub bind_group: wgpu::BindGroup,
}

impl Buffers {
    /// Allocates buffers of the given sizes in bytes (each rounded up to a multiple of 16),
    /// the staging buffer as large as the output.
    pub fn new(
        device: &wgpu::Device,
        layout: &wgpu::BindGroupLayout,
        patch_data_bytes: u64,
        points_bytes: u64,
        out_bytes: u64,
        grid_weights_bytes: u64,
    ) -> Buffers {
        Self::with_staging(
            device,
            layout,
            [
                patch_data_bytes,
                points_bytes,
                out_bytes,
                grid_weights_bytes,
            ],
            out_bytes,
        )
    }

    /// [`Buffers::new`] with sizes `[patch data, points, out, grid weights]` and a staging
    /// buffer of `staging_bytes` (16 where nothing is read back: a mappable buffer is
    /// host memory the driver may pin).
    pub fn with_staging(
        device: &wgpu::Device,
        layout: &wgpu::BindGroupLayout,
        sizes: [u64; 4],
        staging_bytes: u64,
    ) -> Buffers {
        let [patch_data_bytes, points_bytes, out_bytes, grid_weights_bytes] = sizes;
        let size = |b: u64| b.max(16).div_ceil(16) * 16;
        let buffer = |label, bytes, usage| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: size(bytes),
                usage,
                mapped_at_creation: false,
            })
        };
        use wgpu::BufferUsages as U;
        let params = buffer(
            "params",
            std::mem::size_of::<Params>() as u64,
            U::UNIFORM | U::COPY_DST,
        );
        let patch_data = buffer("patch data", patch_data_bytes, U::STORAGE | U::COPY_DST);
        let points = buffer("points", points_bytes.max(32), U::STORAGE | U::COPY_DST);
        let out = buffer("out", out_bytes, U::STORAGE | U::COPY_SRC);
        let staging = buffer("staging", staging_bytes, U::MAP_READ | U::COPY_DST);
        let grid_weights = buffer(
            "grid weights",
            grid_weights_bytes.max(32),
            U::STORAGE | U::COPY_DST,
        );
        fn entry(binding: u32, buffer: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
            wgpu::BindGroupEntry {
                binding,
                resource: buffer.as_entire_binding(),
            }
        }
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("g1tess eval"),
            layout,
            entries: &[
                entry(0, &params),
                entry(1, &patch_data),
                entry(2, &points),
                entry(3, &out),
                entry(4, &grid_weights),
            ],
        });
        Buffers {
            params,
            patch_data,
            points,
            out,
            staging,
            grid_weights,
            bind_group,
        }
    }
}

/// Workgroup counts (x, y) for `count` threads with at most `max_per_dim` per dimension.
pub fn workgroups(count: u32, max_per_dim: u32) -> (u32, u32) {
    let groups = count.div_ceil(WORKGROUP).max(1);
    let x = groups.min(max_per_dim.max(1));
    (x, groups.div_ceil(x))
}

/// Records one dispatch of `count` threads (with `params.groups_x` filled in here), and,
/// when `copy_bytes` > 0, the copy of that many output bytes to the staging buffer; submits.
pub fn dispatch(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    pipeline: &wgpu::ComputePipeline,
    buffers: &Buffers,
    params: Params,
    max_workgroups_per_dim: u32,
    copy_bytes: u64,
) {
    dispatch_threads(
        device,
        queue,
        pipeline,
        buffers,
        &buffers.out,
        &buffers.staging,
        &buffers.bind_group,
        params,
        params.count,
        max_workgroups_per_dim,
        copy_bytes,
    );
}

/// [`dispatch`] of `threads` threads with `bind_group` (threads ≠ samples: one thread per
/// patch), copying from `out` to `staging`; returns the submission.
#[allow(clippy::too_many_arguments)]
fn dispatch_threads(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    pipeline: &wgpu::ComputePipeline,
    buffers: &Buffers,
    out: &wgpu::Buffer,
    staging: &wgpu::Buffer,
    bind_group: &wgpu::BindGroup,
    mut params: Params,
    threads: u32,
    max_workgroups_per_dim: u32,
    copy_bytes: u64,
) -> wgpu::SubmissionIndex {
    let (gx, gy) = workgroups(threads, max_workgroups_per_dim);
    params.groups_x = gx;
    queue.write_buffer(&buffers.params, 0, bytemuck::bytes_of(&params));
    let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
        label: Some("g1tess eval"),
    });
    {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("g1tess eval"),
            timestamp_writes: None,
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, bind_group, &[]);
        pass.dispatch_workgroups(gx, gy, 1);
    }
    if copy_bytes > 0 {
        encoder.copy_buffer_to_buffer(out, 0, staging, 0, copy_bytes);
    }
    queue.submit([encoder.finish()])
}

/// The basis (w, ∂w/∂s, ∂w/∂t of every control point) of `kind` at `points`, laid out as
/// `grid_w` of `shaders/common.wgsl` reads it: column 3j + d holds derivative d of weight j
/// at every point in order.
pub(crate) fn basis_table<R: Real>(kind: PatchKind, points: &[[f64; 3]]) -> Vec<R> {
    let per = points.len();
    let stride = kind.stride();
    let mut flat: Vec<R> = vec![R::of(0.0); per * stride * 3];
    for (local, &b) in points.iter().enumerate() {
        let w = kind.weights(b);
        for j in 0..stride {
            flat[(j * 3) * per + local] = R::of(w.w[j]);
            flat[(j * 3 + 1) * per + local] = R::of(w.ws[j]);
            flat[(j * 3 + 2) * per + local] = R::of(w.wt[j]);
        }
    }
    flat
}

/// Appends the patch data of patch `i` to `out` (layout in `shaders/common.wgsl` and
/// [`crate::gpu::shaders::patch_vecs`]): the control points, geometry relative to corner 0;
/// the flat normal; corner 0's low part (corner 0 − its rounding to `R`); the three corners
/// rounded once to `R`.
pub(crate) fn push_patch_data<R: Real>(table: &PatchTable, i: usize, out: &mut Vec<R>) {
    let push =
        |out: &mut Vec<R>, v: DVec3| out.extend_from_slice(&[R::of(v.x), R::of(v.y), R::of(v.z)]);
    let start = out.len();
    let origin = table.corner(i, 0);
    let geometry = table.kind.geometry();
    for (j, p) in table.patch(i).iter().enumerate() {
        push(out, if j < geometry { *p - origin } else { *p });
    }
    let rounded = |v: DVec3| DVec3::new(R::of(v.x).get(), R::of(v.y).get(), R::of(v.z).get());
    let extra = [
        (SLOT_FLAT_NORMAL, table.flat_normals[i]),
        (SLOT_ORIGIN_LO, origin - rounded(origin)),
        (SLOT_CORNERS, origin),
        (SLOT_CORNERS + 1, table.corner(i, 1)),
        (SLOT_CORNERS + 2, table.corner(i, 2)),
    ];
    for (slot, (expect, v)) in extra.into_iter().enumerate() {
        debug_assert_eq!(slot, expect);
        push(out, v);
    }
    debug_assert_eq!(out.len() - start, 3 * shaders::patch_vecs(table.kind));
}

/// The bind group of `grid_patch_main` ([`patch_loop_bind_group_layout`]) writing to `out`.
fn patch_loop_bind_group(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    buffers: &Buffers,
    out: &wgpu::Buffer,
    table: &wgpu::Buffer,
) -> wgpu::BindGroup {
    fn entry(binding: u32, buffer: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
        wgpu::BindGroupEntry {
            binding,
            resource: buffer.as_entire_binding(),
        }
    }
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("g1tess eval, patch loop"),
        layout,
        entries: &[
            entry(0, &buffers.params),
            entry(1, &buffers.patch_data),
            entry(5, table),
            entry(7, out),
        ],
    })
}

/// One output buffer of a grid evaluation with its staging buffer and bind groups.
struct Slot {
    out: wgpu::Buffer,
    staging: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    patch_bind_group: Option<wgpu::BindGroup>,
}

impl Slot {
    /// A second output and staging buffer beside `buffers`' (the same sizes), sharing its
    /// inputs.
    fn second(
        device: &wgpu::Device,
        layout: &wgpu::BindGroupLayout,
        buffers: &Buffers,
        patch_loop: Option<(&wgpu::BindGroupLayout, &wgpu::Buffer)>,
    ) -> Slot {
        use wgpu::BufferUsages as U;
        let buffer = |label, like: &wgpu::Buffer, usage| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: like.size(),
                usage,
                mapped_at_creation: false,
            })
        };
        let out = buffer("out (second)", &buffers.out, U::STORAGE | U::COPY_SRC);
        let staging = buffer(
            "staging (second)",
            &buffers.staging,
            U::MAP_READ | U::COPY_DST,
        );
        fn entry(binding: u32, buffer: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
            wgpu::BindGroupEntry {
                binding,
                resource: buffer.as_entire_binding(),
            }
        }
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("g1tess eval (second)"),
            layout,
            entries: &[
                entry(0, &buffers.params),
                entry(1, &buffers.patch_data),
                entry(2, &buffers.points),
                entry(3, &out),
                entry(4, &buffers.grid_weights),
            ],
        });
        let patch_bind_group = patch_loop
            .map(|(layout, table)| patch_loop_bind_group(device, layout, buffers, &out, table));
        Slot {
            out,
            staging,
            bind_group,
            patch_bind_group,
        }
    }
}

/// The basis of every grid point of `level` as `grid_u` of `shaders/common.wgsl` holds it:
/// entry `local * stride + j` is (w, ∂w/∂s, ∂w/∂t, 0) of control point j, 4 reals each.
/// `out` must hold them all.
fn uniform_table<R: Real>(kind: PatchKind, level: u32, out: &mut [R]) {
    let stride = kind.stride();
    for (local, b) in grid_barycentrics(level).into_iter().enumerate() {
        let w = kind.weights(b);
        for j in 0..stride {
            let o = (local * stride + j) * 4;
            out[o] = R::of(w.w[j]);
            out[o + 1] = R::of(w.ws[j]);
            out[o + 2] = R::of(w.wt[j]);
        }
    }
}

/// The dispatches of a grid on `patches` patches: (first patch of its chunk, patches of
/// the chunk, first sample of the dispatch in the chunk, samples). Chunks of
/// `patches_per_chunk` patches of `per` samples, dispatches of up to `out_samples`; with
/// `whole_quads` (the patch loop's quad), a dispatch of whole quads of patches, then the
/// rest.
fn grid_jobs(
    patches: usize,
    patches_per_chunk: usize,
    per: usize,
    out_samples: usize,
    whole_quads: Option<usize>,
) -> Vec<(usize, usize, usize, usize)> {
    let mut jobs = Vec::new();
    let mut first = 0;
    while first < patches {
        let count = patches_per_chunk.min(patches - first);
        let total = count * per;
        let mut s0 = 0;
        while s0 < total {
            let mut n = out_samples.min(total - s0);
            let whole = n / per;
            if let Some(quad) = whole_quads.filter(|&q| whole > q && !whole.is_multiple_of(q)) {
                n = (whole - whole % quad) * per;
            }
            jobs.push((first, count, s0, n));
            s0 += n;
        }
        first += count;
    }
    jobs
}

/// Sets the corner samples of the grids of `level` in `pos` (one grid per patch, from
/// patch `first`) to the patches' corners exactly. Grid index 0 is corner 0, index
/// `level` (i = n, j = 0) corner 1, the last index (j = n) corner 2.
fn grid_corners(table: &PatchTable, level: u32, first: usize, pos: &mut [DVec3]) {
    let per = grid_len(level);
    for (p, s) in pos.chunks_mut(per).enumerate() {
        for (k, local) in [0, level as usize, per - 1].into_iter().enumerate() {
            s[local] = table.corner(first + p, k);
        }
    }
}

fn gcd(a: usize, b: usize) -> usize {
    if b == 0 {
        a
    } else {
        gcd(b, a % b)
    }
}

/// Which corner `b` is (exactly the unit vector e_k), as the shaders decide it.
fn corner_of(b: [f64; 3]) -> Option<usize> {
    (0..3).find(|&k| (0..3).all(|m| b[m] == if m == k { 1.0 } else { 0.0 }))
}

/// Where evaluated samples go.
enum Target<'s> {
    /// The f64 reference interface ([`Evaluator::evaluate`]).
    F64(&'s mut dyn FnMut(Chunk<'_>) -> Result<()>),
    /// f32 samples ([`Evaluator::evaluate_f32`]).
    F32(&'s mut dyn FnMut(ChunkF32<'_>) -> Result<()>),
    /// Nothing is read back (timing of the device work).
    Discard,
}

impl Target<'_> {
    fn reads(&self) -> bool {
        !matches!(self, Target::Discard)
    }
}

/// One chunk's samples as the GPU wrote them (working precision), and the vectors the
/// target gets.
struct Samples<R> {
    pos: Vec<[R; 3]>,
    nrm: Vec<[R; 3]>,
    p32: Vec<[f32; 3]>,
    n32: Vec<[f32; 3]>,
    p64: Vec<DVec3>,
    n64: Vec<DVec3>,
}

impl<R: Real> Samples<R> {
    fn new() -> Self {
        Samples {
            pos: Vec::new(),
            nrm: Vec::new(),
            p32: Vec::new(),
            n32: Vec::new(),
            p64: Vec::new(),
            n64: Vec::new(),
        }
    }

    fn resize(&mut self, n: usize) {
        let zero = [R::of(0.0); 3];
        self.pos.resize(n, zero);
        self.nrm.resize(n, zero);
    }

    /// Copies the output of a dispatch of `n` samples (positions, then normals) from the
    /// staging buffer into samples `s0..s0 + n`.
    fn read(
        &mut self,
        device: &wgpu::Device,
        staging: &wgpu::Buffer,
        after: Option<wgpu::SubmissionIndex>,
        s0: usize,
        n: usize,
    ) -> Result<()> {
        let bytes = (n * OUT_REALS * std::mem::size_of::<R>()) as u64;
        let (pos, nrm) = (&mut self.pos[s0..s0 + n], &mut self.nrm[s0..s0 + n]);
        read_buffer_after(device, staging, bytes, after, |b| {
            let v: &[[R; 3]] = bytemuck::try_cast_slice(b)
                .map_err(|e| Error::Gpu(format!("result buffer: {e}")))?;
            pos.copy_from_slice(&v[..n]);
            nrm.copy_from_slice(&v[n..2 * n]);
            Ok(())
        })?
    }

    /// Hands the samples to `target` as chunk `first`. For the f64 target they are widened,
    /// normals renormalised in f64, and `corners` puts the input corners back exactly.
    fn deliver(
        &mut self,
        target: &mut Target<'_>,
        first: usize,
        corners: impl FnOnce(&mut [DVec3]),
    ) -> Result<()> {
        match target {
            Target::Discard => Ok(()),
            Target::F32(sink) => {
                let positions = R::as_f32(&self.pos, &mut self.p32);
                let normals = R::as_f32(&self.nrm, &mut self.n32);
                sink(Chunk {
                    first,
                    positions,
                    normals,
                })
            }
            Target::F64(sink) => {
                const BLOCK: usize = 4096;
                let n = self.pos.len();
                self.p64.resize(n, DVec3::ZERO);
                self.n64.resize(n, DVec3::ZERO);
                let widen = |v: [R; 3]| DVec3::new(v[0].get(), v[1].get(), v[2].get());
                let (pos, nrm) = (&self.pos, &self.nrm);
                self.p64
                    .par_chunks_mut(BLOCK)
                    .zip(self.n64.par_chunks_mut(BLOCK))
                    .enumerate()
                    .for_each(|(b, (p, q))| {
                        for k in 0..p.len() {
                            let t = b * BLOCK + k;
                            p[k] = widen(pos[t]);
                            let v = widen(nrm[t]);
                            q[k] = v.try_normalize().unwrap_or(v);
                        }
                    });
                corners(&mut self.p64);
                sink(Chunk {
                    first,
                    positions: &self.p64,
                    normals: &self.n64,
                })
            }
        }
    }
}

/// Timings of [`GpuEvaluator::time_grid`].
#[derive(Clone, Copy, Debug)]
pub struct GridTiming {
    /// Wall time from submission to the device's completion.
    pub elapsed: Duration,
}

/// The GPU evaluator.
pub struct GpuEvaluator {
    ctx: Arc<GpuContext>,
    precision: Precision,
    /// Samples per chunk handed to the sink (whole patches for grids, at least one).
    pub chunk_samples: usize,
    /// Largest storage binding in bytes: the adapter's limit; lower it to force splitting.
    pub max_binding_bytes: u64,
    /// Largest workgroup count per dispatch dimension: the adapter's limit; lower it to
    /// force 2-D dispatches.
    pub max_workgroups_per_dim: u32,
    /// Grids read their basis values from a table computed once on the CPU (as the CPU
    /// backend does) when it is at most this many bytes; larger tables (very fine levels),
    /// or 0 here, compute the basis in the shader.
    pub max_grid_table_bytes: u64,
    /// Keep wgpu's runtime checks (bounds checks, loop bounding) in the shaders; off by
    /// default: the shaders are the crate's own (`shader_module`).
    pub shader_runtime_checks: bool,
    /// Grids run one thread per patch (`grid_patch_main`) instead of one per sample where
    /// the kind's basis fits the uniform table, and G1 grids at every level (their basis
    /// is evaluated in the shader): the default on software adapters (`DeviceType::Cpu`,
    /// e.g. lavapipe), whose SIMD lanes then share each patch's reads and store four
    /// samples as vec4s.
    pub patch_loop: bool,
    /// Grids read back through two output buffers, so the device computes dispatch k + 1
    /// while the results of dispatch k are handed to the consumer (default; off: one
    /// buffer, device and host take turns).
    pub double_buffer: bool,
    layout: wgpu::BindGroupLayout,
    pipelines: Mutex<Vec<Arc<Pipelines>>>,
}

impl GpuEvaluator {
    /// An evaluator on `ctx`. Errors for f64 when the adapter lacks `SHADER_F64`.
    pub fn new(ctx: Arc<GpuContext>, precision: Precision) -> Result<GpuEvaluator> {
        if precision == Precision::F64 && !ctx.supports_f64() {
            return Err(Error::missing_feature(
                "SHADER_F64",
                format!(
                    "{}: the adapter does not offer SHADER_F64: f64 evaluation needs it; f32 \
                     works",
                    ctx.info.name
                ),
            ));
        }
        let layout = bind_group_layout(&ctx.device);
        Ok(GpuEvaluator {
            precision,
            chunk_samples: 1 << 22,
            max_binding_bytes: ctx.max_binding_bytes(),
            max_workgroups_per_dim: ctx.max_workgroups_per_dim(),
            max_grid_table_bytes: 32 << 20,
            shader_runtime_checks: false,
            patch_loop: ctx.info.device_type == wgpu::DeviceType::Cpu,
            double_buffer: true,
            layout,
            pipelines: Mutex::new(Vec::new()),
            ctx,
        })
    }

    /// The device this evaluator runs on.
    pub fn context(&self) -> &Arc<GpuContext> {
        &self.ctx
    }

    /// The working precision of its kernels.
    pub fn precision(&self) -> Precision {
        self.precision
    }

    /// The pipelines of `kind` in this evaluator's precision (built once, then cached:
    /// every scheme of one kind shares them).
    pub(crate) fn pipelines(&self, kind: PatchKind) -> Result<Arc<Pipelines>> {
        let mut cache = self
            .pipelines
            .lock()
            .map_err(|_| Error::Gpu("pipeline cache poisoned".into()))?;
        if let Some(p) = cache.iter().find(|p| {
            p.kind == kind
                && p.precision == self.precision
                && p.runtime_checks == self.shader_runtime_checks
        }) {
            return Ok(p.clone());
        }
        let p = Arc::new(create_pipelines_with(
            &self.ctx.device,
            &self.layout,
            kind,
            self.precision,
            self.shader_runtime_checks,
        )?);
        self.ctx.check()?;
        cache.push(p.clone());
        Ok(p)
    }

    /// How many (kind, precision) pipeline sets have been built so far.
    pub fn cached_pipelines(&self) -> usize {
        self.pipelines.lock().map(|c| c.len()).unwrap_or(0)
    }

    /// Evaluates `pattern` on `table` into `target` in the evaluator's precision.
    fn run(&self, table: &PatchTable, pattern: &Pattern, mut target: Target<'_>) -> Result<()> {
        let pipes = self.pipelines(table.kind)?;
        match (pattern, self.precision) {
            (Pattern::Grid { level }, Precision::F32) => {
                self.grid::<f32>(&pipes, table, *level, &mut target)
            }
            (Pattern::Grid { level }, Precision::F64) => {
                self.grid::<f64>(&pipes, table, *level, &mut target)
            }
            (Pattern::Points(p), Precision::F32) => {
                self.points::<f32>(&pipes, table, p, &mut target)
            }
            (Pattern::Points(p), Precision::F64) => {
                self.points::<f64>(&pipes, table, p, &mut target)
            }
        }
    }

    fn limit_samples(&self, bytes_per_sample: usize) -> Result<usize> {
        let by_binding = self.max_binding_bytes / bytes_per_sample as u64;
        let w = self.max_workgroups_per_dim.max(1) as u64;
        let by_groups = w.saturating_mul(w).saturating_mul(WORKGROUP as u64);
        let n = by_binding.min(by_groups).min(u32::MAX as u64 / 2) as usize;
        if n == 0 {
            return Err(Error::limit(
                "max_storage_buffer_binding_size",
                bytes_per_sample as u64,
                self.max_binding_bytes,
                format!(
                    "storage binding limit of {} bytes is below one sample",
                    self.max_binding_bytes
                ),
            ));
        }
        Ok(n)
    }

    /// Whether [`Self::grid`] runs `grid_patch_main` for the grid of `level` on `table` in
    /// reals of `rb` bytes, where the kind's pipelines have it: [`Self::patch_loop`] on,
    /// the kind's basis in the uniform table (G1 evaluates its own: any level), and a whole
    /// patch within one dispatch.
    fn grid_runs_patch_loop(&self, table: &PatchTable, level: u32, rb: usize) -> Result<bool> {
        let per = grid_len(level.max(1));
        let per_dispatch = self.limit_samples(OUT_REALS * rb)?;
        let table_bytes = (per * table.stride * 3 * rb) as u64;
        let use_table = table_bytes <= self.max_grid_table_bytes.min(self.max_binding_bytes);
        let uniform_fits = per * table.stride * 4 * rb <= shaders::UNIFORM_TABLE_BYTES;
        Ok(self.patch_loop
            && ((use_table && uniform_fits) || table.kind == PatchKind::Gregory)
            && per_dispatch >= per)
    }

    /// Evaluates the grid of `level` into `target` (with [`Target::Discard`] nothing is
    /// read back: the timing of dispatches alone).
    fn grid<R: Real>(
        &self,
        pipes: &Pipelines,
        table: &PatchTable,
        level: u32,
        target: &mut Target<'_>,
    ) -> Result<()> {
        let level = level.max(1);
        let per = grid_len(level);
        if per as u64 >= u32::MAX as u64 / 2 {
            return Err(Error::Invalid(format!("grid level {level} is too large")));
        }
        if table.is_empty() {
            return Ok(());
        }
        let (device, queue) = (&self.ctx.device, &self.ctx.queue);
        let rb = R::PRECISION.bytes();
        let sample_bytes = OUT_REALS * rb;
        let upload_reals = 3 * shaders::patch_vecs(table.kind);
        let upload_bytes = upload_reals * rb;
        let per_dispatch = self.limit_samples(sample_bytes)?;
        let by_uploads = (self.max_binding_bytes / upload_bytes as u64) as usize;
        if by_uploads == 0 {
            return Err(Error::limit(
                "max_storage_buffer_binding_size",
                upload_bytes as u64,
                self.max_binding_bytes,
                "storage binding limit is below one patch",
            ));
        }
        let patches_per_chunk = (self.chunk_samples / per)
            .max(1)
            .min(by_uploads)
            .min((per_dispatch / per).max(1))
            .min(table.len());
        let mut out_samples = (patches_per_chunk * per).min(per_dispatch);
        let table_bytes = (per * table.stride * 3 * rb) as u64;
        let use_table = table_bytes <= self.max_grid_table_bytes.min(self.max_binding_bytes);
        // One thread per patch: whole patches per dispatch, the basis in a uniform table
        // (G1 evaluates its basis in the shader: any level).
        let uniform_fits = per * table.stride * 4 * rb <= shaders::UNIFORM_TABLE_BYTES;
        // Patches per dispatch of the patch loop are multiples of `quad`, so that its
        // sample count is a multiple of 4 (grid_patch_main then stores vec4s).
        let quad = 4 / gcd(per, 4);
        let patch_loop = match &pipes.grid_patch {
            Some((layout, pipeline)) if self.grid_runs_patch_loop(table, level, rb)? => {
                let patches = out_samples / per;
                out_samples = if patches >= quad {
                    (patches - patches % quad) * per
                } else {
                    patches * per
                };
                Some((layout, pipeline))
            }
            _ => None,
        };
        let out_bytes = (out_samples * sample_bytes) as u64;
        let buffers = Buffers::with_staging(
            device,
            &self.layout,
            [
                (patches_per_chunk * upload_bytes) as u64,
                32,
                out_bytes,
                if use_table { table_bytes } else { 32 },
            ],
            // Nothing is read back into a target that keeps nothing.
            if target.reads() { out_bytes } else { 16 },
        );
        let patch_uniform = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("grid basis (uniform)"),
            size: if patch_loop.is_some() {
                shaders::UNIFORM_TABLE_BYTES as u64
            } else {
                16
            },
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let patch_bind_group = patch_loop.map(|(layout, _)| {
            if use_table && uniform_fits && table.kind != PatchKind::Gregory {
                let mut flat: Vec<R> = vec![R::of(0.0); shaders::UNIFORM_TABLE_BYTES / rb];
                uniform_table(table.kind, level, &mut flat);
                queue.write_buffer(&patch_uniform, 0, bytemuck::cast_slice(&flat));
            }
            patch_loop_bind_group(device, layout, &buffers, &buffers.out, &patch_uniform)
        });
        let pipeline = if let Some((_, p)) = patch_loop {
            p
        } else if use_table {
            // The basis at every grid point, the same for every patch (computed once, as
            // the CPU backend does), laid out as `grid_w` of shaders/common.wgsl.
            let flat: Vec<R> = basis_table(table.kind, &grid_barycentrics(level));
            queue.write_buffer(&buffers.grid_weights, 0, bytemuck::cast_slice(&flat));
            &pipes.grid_table
        } else {
            &pipes.grid
        };
        let jobs = grid_jobs(
            table.len(),
            patches_per_chunk,
            per,
            out_samples,
            patch_loop.map(|_| quad),
        );
        // Two output and staging buffers when results are read back and there is more than
        // one dispatch: dispatch k + 1 is submitted before the results of dispatch k are
        // read and handed to the target, so the device computes while the host consumes.
        let mut slots = vec![Slot {
            out: buffers.out.clone(),
            staging: buffers.staging.clone(),
            bind_group: buffers.bind_group.clone(),
            patch_bind_group: patch_bind_group.clone(),
        }];
        if target.reads() && jobs.len() > 1 && self.double_buffer {
            slots.push(Slot::second(
                device,
                &self.layout,
                &buffers,
                patch_loop.map(|(layout, _)| (layout, &patch_uniform)),
            ));
        }
        let corners = |first: usize, pos: &mut [DVec3]| grid_corners(table, level, first, pos);
        let mut patch_data: Vec<R> = Vec::with_capacity(patches_per_chunk * upload_reals);
        let mut samples = Samples::<R>::new();
        let mut pending: Option<(usize, wgpu::SubmissionIndex)> = None;
        // Reads dispatch j back from its slot's staging buffer once submission `index` is done.
        let complete = |(j, index): (usize, wgpu::SubmissionIndex),
                        samples: &mut Samples<R>,
                        target: &mut Target<'_>| {
            let staging = &slots[j % slots.len()].staging;
            self.complete(&jobs, j, staging, index, per, samples, target, &corners)
        };
        for (k, &(first, count, s0, n)) in jobs.iter().enumerate() {
            if s0 == 0 {
                patch_data.clear();
                for i in first..first + count {
                    push_patch_data(table, i, &mut patch_data);
                }
                queue.write_buffer(&buffers.patch_data, 0, bytemuck::cast_slice(&patch_data));
            }
            let slot = &slots[k % slots.len()];
            let params = Params {
                count: n as u32,
                first_local: s0 as u32,
                level,
                per: per as u32,
                ..Default::default()
            };
            let copy = if target.reads() {
                (n * sample_bytes) as u64
            } else {
                0
            };
            let (bind_group, threads) = match &slot.patch_bind_group {
                Some(g) => (g, (n / per) as u32),
                None => (&slot.bind_group, n as u32),
            };
            let index = dispatch_threads(
                device,
                queue,
                pipeline,
                &buffers,
                &slot.out,
                &slot.staging,
                bind_group,
                params,
                threads,
                self.max_workgroups_per_dim,
                copy,
            );
            if !target.reads() {
                continue;
            }
            // With one slot, the dispatch just submitted is the one read.
            let ready = if slots.len() == 1 {
                Some((k, index))
            } else {
                pending.replace((k, index))
            };
            if let Some(ready) = ready {
                complete(ready, &mut samples, target)?;
            }
        }
        if let Some(last) = pending {
            complete(last, &mut samples, target)?;
        }
        self.ctx.wait()?;
        self.ctx.check()
    }

    /// Reads dispatch `j` of `jobs` back from `staging` (once submission `index` is done)
    /// into its chunk's samples and, after the chunk's last dispatch, hands the chunk to
    /// `target`. A chunk of one dispatch read as f32 by an f32 target goes from the mapped
    /// buffer straight to the target, without a copy.
    #[allow(clippy::too_many_arguments)]
    fn complete<R: Real>(
        &self,
        jobs: &[(usize, usize, usize, usize)],
        j: usize,
        staging: &wgpu::Buffer,
        index: wgpu::SubmissionIndex,
        per: usize,
        samples: &mut Samples<R>,
        target: &mut Target<'_>,
        corners: &dyn Fn(usize, &mut [DVec3]),
    ) -> Result<()> {
        let device = &self.ctx.device;
        let (first, count, s0, n) = jobs[j];
        let total = count * per;
        if let (Target::F32(sink), true, true) = (
            &mut *target,
            R::PRECISION == Precision::F32,
            s0 == 0 && n == total,
        ) {
            let bytes = (n * OUT_REALS * 4) as u64;
            read_buffer_after(device, staging, bytes, Some(index), |b| {
                let v: &[[f32; 3]] = bytemuck::try_cast_slice(b)
                    .map_err(|e| Error::Gpu(format!("result buffer: {e}")))?;
                sink(Chunk {
                    first,
                    positions: &v[..n],
                    normals: &v[n..2 * n],
                })
            })??;
            return self.ctx.check();
        }
        if s0 == 0 {
            samples.resize(total);
        }
        samples.read(device, staging, Some(index), s0, n)?;
        self.ctx.check()?;
        if s0 + n == total {
            samples.deliver(target, first, |pos| corners(first, pos))?;
        }
        Ok(())
    }

    fn points<R: Real>(
        &self,
        pipes: &Pipelines,
        table: &PatchTable,
        points: &[PatchPoint],
        target: &mut Target<'_>,
    ) -> Result<()> {
        if points.is_empty() {
            return Ok(());
        }
        if let Some(p) = points.iter().find(|p| p.patch as usize >= table.len()) {
            return Err(Error::Invalid(format!(
                "evaluation point on patch {} of a table of {} patches",
                p.patch,
                table.len()
            )));
        }
        let (device, queue) = (&self.ctx.device, &self.ctx.queue);
        let rb = R::PRECISION.bytes();
        let sample_bytes = OUT_REALS * rb;
        let point_bytes = if rb == 4 { 16 } else { 32 };
        let upload_bytes = 3 * shaders::patch_vecs(table.kind) * rb;
        // Worst case every point of a chunk is on its own patch.
        let per_chunk = self
            .limit_samples(sample_bytes.max(point_bytes).max(upload_bytes))?
            .min(self.chunk_samples.max(1))
            .min(points.len());
        let buffers = Buffers::new(
            device,
            &self.layout,
            (per_chunk * upload_bytes) as u64,
            (per_chunk * point_bytes) as u64,
            (per_chunk * sample_bytes) as u64,
            32,
        );
        // Slot of each patch in this chunk's upload (u32::MAX: not uploaded).
        let mut slot = vec![u32::MAX; table.len()];
        let mut used: Vec<usize> = Vec::new();
        let mut patch_data: Vec<R> = Vec::new();
        let mut pts: Vec<u8> = Vec::with_capacity(per_chunk * point_bytes);
        let mut samples = Samples::<R>::new();
        for (c, chunk) in points.chunks(per_chunk).enumerate() {
            patch_data.clear();
            pts.clear();
            for p in chunk {
                let i = p.patch as usize;
                if slot[i] == u32::MAX {
                    slot[i] = used.len() as u32;
                    used.push(i);
                    push_patch_data(table, i, &mut patch_data);
                }
                for x in p.b {
                    pts.extend_from_slice(bytemuck::bytes_of(&R::of(x)));
                }
                pts.extend_from_slice(&slot[i].to_le_bytes());
                pts.resize(pts.len().next_multiple_of(point_bytes), 0);
            }
            queue.write_buffer(&buffers.patch_data, 0, bytemuck::cast_slice(&patch_data));
            queue.write_buffer(&buffers.points, 0, &pts);
            let n = chunk.len();
            let params = Params {
                count: n as u32,
                ..Default::default()
            };
            let copy = if target.reads() {
                (n * sample_bytes) as u64
            } else {
                0
            };
            dispatch(
                device,
                queue,
                &pipes.points,
                &buffers,
                params,
                self.max_workgroups_per_dim,
                copy,
            );
            if target.reads() {
                samples.resize(n);
                samples.read(device, &buffers.staging, None, 0, n)?;
                self.ctx.check()?;
            }
            for i in used.drain(..) {
                slot[i] = u32::MAX;
            }
            samples.deliver(target, c * per_chunk, |pos| {
                for (s, p) in pos.iter_mut().zip(chunk) {
                    if let Some(k) = corner_of(p.b) {
                        *s = table.corner(p.patch as usize, k);
                    }
                }
            })?;
        }
        self.ctx.wait()?;
        self.ctx.check()
    }

    /// Runs the grid of `level` on the GPU without reading anything back (uploads and
    /// dispatches, then waits): the time of the device work alone.
    pub fn time_grid(&self, table: &PatchTable, level: u32) -> Result<GridTiming> {
        // Pipelines are built before the clock starts.
        let pipes = self.pipelines(table.kind)?;
        let start = Instant::now();
        match self.precision {
            Precision::F32 => self.grid::<f32>(&pipes, table, level, &mut Target::Discard)?,
            Precision::F64 => self.grid::<f64>(&pipes, table, level, &mut Target::Discard)?,
        }
        Ok(GridTiming {
            elapsed: start.elapsed(),
        })
    }
}

/// The pipelines of a kind's patch loop with no evaluation ([`GpuEvaluator::loop_bound`]).
pub struct LoopBound {
    pipes: Pipelines,
}

impl GpuEvaluator {
    /// The patch loop's bound for `kind`: `grid_patch_main` as the kind runs it, with a
    /// `kind_loop_point` that evaluates nothing (`shaders/loop_bound.wgsl`): the same
    /// uploads, control-point loads, normalisation and stores. No evaluation of the kind in
    /// that loop runs faster. `None` where grids do not run the patch loop
    /// ([`Self::patch_loop`] off, as on GPUs) or the device has none. Time it with
    /// [`Self::time_loop_bound`].
    pub(crate) fn loop_bound(&self, kind: PatchKind) -> Result<Option<LoopBound>> {
        if !self.patch_loop {
            return Ok(None);
        }
        let pipes = pipelines_from(
            &self.ctx.device,
            &self.layout,
            kind,
            self.precision,
            self.shader_runtime_checks,
            shaders::loop_bound_source(kind, self.precision)?,
        )?;
        self.ctx.check()?;
        Ok(pipes.grid_patch.is_some().then_some(LoopBound { pipes }))
    }

    /// The grid of `level` on `table` through `bound` (of `table.kind`), timed as
    /// [`Self::time_grid`] times a grid. `None` where the grid does not run the patch loop
    /// (a GPU's, or [`Self::patch_loop`] off). Nothing is read back; the samples are
    /// meaningless.
    pub(crate) fn time_loop_bound(
        &self,
        bound: &LoopBound,
        table: &PatchTable,
        level: u32,
    ) -> Result<Option<GridTiming>> {
        if bound.pipes.kind != table.kind
            || !self.grid_runs_patch_loop(table, level, self.precision.bytes())?
        {
            return Ok(None);
        }
        let start = Instant::now();
        match self.precision {
            Precision::F32 => self.grid::<f32>(&bound.pipes, table, level, &mut Target::Discard)?,
            Precision::F64 => self.grid::<f64>(&bound.pipes, table, level, &mut Target::Discard)?,
        }
        Ok(Some(GridTiming {
            elapsed: start.elapsed(),
        }))
    }
}

/// How the ceiling shader (`shaders/ceiling.wgsl`) stores its samples.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CeilingShape {
    /// `ceiling_main`: one sample per invocation, its six values stored one by one.
    PerSample,
    /// `ceiling_quads_main`: four samples per invocation stored as six vec4s, as
    /// `grid_patch_main` stores them.
    Quads,
}

impl GpuEvaluator {
    /// The device's ceiling for an evaluation: `samples` samples written by the minimal
    /// shader (`shaders/ceiling.wgsl`: 24 bytes per sample from its index, nothing read) in
    /// `shape`, dispatched in the chunks a grid uses (quads: rounded up to a multiple of 4
    /// samples), waiting for the device, nothing read back. The pipeline is built before the
    /// clock starts.
    pub(crate) fn time_ceiling(&self, samples: usize, shape: CeilingShape) -> Result<GridTiming> {
        let (device, queue) = (&self.ctx.device, &self.ctx.queue);
        let source = shaders::ceiling_source();
        shaders::validate(&source, Precision::F32)
            .map_err(|e| Error::Gpu(format!("shaders/{}: {e}", shaders::CEILING.name)))?;
        let module = shader_module(
            device,
            shaders::CEILING.name,
            source,
            self.shader_runtime_checks,
        );
        let quads_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("g1tess ceiling, quads"),
            entries: &[0, 7].map(|binding| wgpu::BindGroupLayoutEntry {
                binding,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::Buffer {
                    ty: if binding == 0 {
                        wgpu::BufferBindingType::Uniform
                    } else {
                        wgpu::BufferBindingType::Storage { read_only: false }
                    },
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            }),
        });
        let (layout, entry, per_thread) = match shape {
            CeilingShape::PerSample => (&self.layout, "ceiling_main", 1),
            CeilingShape::Quads => (&quads_layout, "ceiling_quads_main", 4),
        };
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("g1tess ceiling"),
            bind_group_layouts: &[Some(layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(shaders::CEILING.name),
            layout: Some(&pipeline_layout),
            module: &module,
            entry_point: Some(entry),
            compilation_options: Default::default(),
            cache: None,
        });
        let sample_bytes = OUT_REALS * 4;
        let total = samples.next_multiple_of(per_thread);
        let per_dispatch = self
            .limit_samples(sample_bytes)?
            .min(self.chunk_samples.max(1))
            .min(total.max(1));
        let per_dispatch = (per_dispatch - per_dispatch % per_thread).max(per_thread);
        let buffers = Buffers::new(
            device,
            &self.layout,
            32,
            32,
            (per_dispatch * sample_bytes) as u64,
            32,
        );
        let quads_bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("g1tess ceiling, quads"),
            layout: &quads_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: buffers.params.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 7,
                    resource: buffers.out.as_entire_binding(),
                },
            ],
        });
        let bind_group = match shape {
            CeilingShape::PerSample => &buffers.bind_group,
            CeilingShape::Quads => &quads_bind_group,
        };
        self.ctx.check()?;
        let start = Instant::now();
        let mut s0 = 0;
        while s0 < total {
            let n = per_dispatch.min(total - s0);
            let params = Params {
                count: n as u32,
                ..Default::default()
            };
            dispatch_threads(
                device,
                queue,
                &pipeline,
                &buffers,
                &buffers.out,
                &buffers.staging,
                bind_group,
                params,
                (n / per_thread) as u32,
                self.max_workgroups_per_dim,
                0,
            );
            s0 += n;
        }
        self.ctx.wait()?;
        let elapsed = start.elapsed();
        self.ctx.check()?;
        Ok(GridTiming { elapsed })
    }
}

impl Evaluator for GpuEvaluator {
    fn describe(&self) -> String {
        format!("gpu ({}, {})", self.precision, self.ctx.describe())
    }

    fn gpu_precision(&self) -> Option<Precision> {
        Some(self.precision)
    }

    /// Positions and normals widened to f64 (normals renormalised in f64), corners the
    /// input exactly. An f32 evaluator's positions carry f32 rounding.
    fn evaluate(
        &self,
        table: &PatchTable,
        pattern: &Pattern,
        sink: &mut dyn FnMut(Chunk<'_>) -> Result<()>,
    ) -> Result<()> {
        self.run(table, pattern, Target::F64(sink))
    }

    /// The GPU's own f32 values for an f32 evaluator (no f64 round trip), an f64
    /// evaluator's rounded once; corners are the input rounded once to f32.
    fn evaluate_f32(
        &self,
        table: &PatchTable,
        pattern: &Pattern,
        sink: &mut dyn FnMut(ChunkF32<'_>) -> Result<()>,
    ) -> Result<()> {
        self.run(table, pattern, Target::F32(sink))
    }
}
