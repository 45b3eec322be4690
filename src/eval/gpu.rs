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
//! ([`bind_group_layout`], [`create_pipelines`], [`dispatch`]) and results come back
//! through [`crate::gpu::read_buffer`].

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use glam::DVec3;
use rayon::prelude::*;

use super::{grid_barycentrics, grid_len, Chunk, ChunkF32, Evaluator, PatchPoint, Pattern};
use crate::gpu::shaders::{self, SLOT_CORNERS, SLOT_FLAT_NORMAL, SLOT_ORIGIN_LO};
use crate::gpu::{read_buffer, GpuContext, Precision};
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

/// Builds the grid and points pipelines of `kind`'s module. The source is validated with
/// naga first, so a shader error comes back as naga's report.
pub fn create_pipelines(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    kind: PatchKind,
    precision: Precision,
) -> Result<Pipelines> {
    let file = shaders::file_for(kind);
    let source = shaders::module_source(kind, precision)?;
    shaders::validate(&source, precision)
        .map_err(|e| Error::Gpu(format!("shaders/{} ({kind:?}): {e}", file.name)))?;
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(file.name),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    });
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
    Ok(Pipelines {
        kind,
        precision,
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
    /// Allocates buffers of the given sizes in bytes (each rounded up to a multiple of 16).
    pub fn new(
        device: &wgpu::Device,
        layout: &wgpu::BindGroupLayout,
        patch_data_bytes: u64,
        points_bytes: u64,
        out_bytes: u64,
        grid_weights_bytes: u64,
    ) -> Buffers {
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
        let staging = buffer("staging", out_bytes, U::MAP_READ | U::COPY_DST);
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
    mut params: Params,
    max_workgroups_per_dim: u32,
    copy_bytes: u64,
) {
    let (gx, gy) = workgroups(params.count, max_workgroups_per_dim);
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
        pass.set_bind_group(0, &buffers.bind_group, &[]);
        pass.dispatch_workgroups(gx, gy, 1);
    }
    if copy_bytes > 0 {
        encoder.copy_buffer_to_buffer(&buffers.out, 0, &buffers.staging, 0, copy_bytes);
    }
    queue.submit([encoder.finish()]);
}

/// Appends the patch data of patch `i` to `out` (layout in `shaders/common.wgsl` and
/// [`crate::gpu::shaders::patch_vecs`]): the control points, geometry relative to corner 0;
/// the flat normal; corner 0's low part (corner 0 − its rounding to `R`); the three corners
/// rounded once to `R`.
fn push_patch_data<R: Real>(table: &PatchTable, i: usize, out: &mut Vec<R>) {
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
        s0: usize,
        n: usize,
    ) -> Result<()> {
        let bytes = (n * OUT_REALS * std::mem::size_of::<R>()) as u64;
        let (pos, nrm) = (&mut self.pos[s0..s0 + n], &mut self.nrm[s0..s0 + n]);
        read_buffer(device, staging, bytes, |b| {
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
    pub samples: usize,
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
    layout: wgpu::BindGroupLayout,
    pipelines: Mutex<Vec<Arc<Pipelines>>>,
}

impl GpuEvaluator {
    /// An evaluator on `ctx`. Errors for f64 when the adapter lacks `SHADER_F64`.
    pub fn new(ctx: Arc<GpuContext>, precision: Precision) -> Result<GpuEvaluator> {
        if precision == Precision::F64 && !ctx.supports_f64() {
            return Err(Error::Gpu(format!(
                "{}: the adapter does not offer SHADER_F64: f64 evaluation needs it; f32 works",
                ctx.info.name
            )));
        }
        let layout = bind_group_layout(&ctx.device);
        Ok(GpuEvaluator {
            precision,
            chunk_samples: 1 << 22,
            max_binding_bytes: ctx.max_binding_bytes(),
            max_workgroups_per_dim: ctx.max_workgroups_per_dim(),
            max_grid_table_bytes: 32 << 20,
            layout,
            pipelines: Mutex::new(Vec::new()),
            ctx,
        })
    }

    pub fn context(&self) -> &Arc<GpuContext> {
        &self.ctx
    }

    pub fn precision(&self) -> Precision {
        self.precision
    }

    /// The pipelines of `kind` in this evaluator's precision (built once, then cached:
    /// every scheme of one kind shares them).
    pub fn pipelines(&self, kind: PatchKind) -> Result<Arc<Pipelines>> {
        let mut cache = self
            .pipelines
            .lock()
            .map_err(|_| Error::Gpu("pipeline cache poisoned".into()))?;
        if let Some(p) = cache
            .iter()
            .find(|p| p.kind == kind && p.precision == self.precision)
        {
            return Ok(p.clone());
        }
        let p = Arc::new(create_pipelines(
            &self.ctx.device,
            &self.layout,
            kind,
            self.precision,
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
            return Err(Error::Gpu(format!(
                "storage binding limit of {} bytes is below one sample",
                self.max_binding_bytes
            )));
        }
        Ok(n)
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
            return Err(Error::Gpu(
                "storage binding limit is below one patch".into(),
            ));
        }
        let patches_per_chunk = (self.chunk_samples / per)
            .max(1)
            .min(by_uploads)
            .min((per_dispatch / per).max(1))
            .min(table.len());
        let out_samples = (patches_per_chunk * per).min(per_dispatch);
        let table_bytes = (per * table.stride * 3 * rb) as u64;
        let use_table = table_bytes <= self.max_grid_table_bytes.min(self.max_binding_bytes);
        let buffers = Buffers::new(
            device,
            &self.layout,
            (patches_per_chunk * upload_bytes) as u64,
            32,
            (out_samples * sample_bytes) as u64,
            if use_table { table_bytes } else { 32 },
        );
        let pipeline = if use_table {
            // The basis at every grid point, the same for every patch (computed once, as
            // the CPU backend does), laid out as `grid_w` of shaders/common.wgsl.
            let mut flat: Vec<R> = vec![R::of(0.0); per * table.stride * 3];
            for (local, b) in grid_barycentrics(level).into_iter().enumerate() {
                let w = table.kind.weights(b);
                for j in 0..table.stride {
                    flat[(j * 3) * per + local] = R::of(w.w[j]);
                    flat[(j * 3 + 1) * per + local] = R::of(w.ws[j]);
                    flat[(j * 3 + 2) * per + local] = R::of(w.wt[j]);
                }
            }
            queue.write_buffer(&buffers.grid_weights, 0, bytemuck::cast_slice(&flat));
            &pipes.grid_table
        } else {
            &pipes.grid
        };
        let mut patch_data: Vec<R> = Vec::with_capacity(patches_per_chunk * upload_reals);
        let mut samples = Samples::<R>::new();
        let mut first = 0;
        while first < table.len() {
            let count = patches_per_chunk.min(table.len() - first);
            patch_data.clear();
            for i in first..first + count {
                push_patch_data(table, i, &mut patch_data);
            }
            queue.write_buffer(&buffers.patch_data, 0, bytemuck::cast_slice(&patch_data));
            let total = count * per;
            if target.reads() {
                samples.resize(total);
            }
            let mut s0 = 0;
            while s0 < total {
                let n = out_samples.min(total - s0);
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
                dispatch(
                    device,
                    queue,
                    pipeline,
                    &buffers,
                    params,
                    self.max_workgroups_per_dim,
                    copy,
                );
                if target.reads() {
                    samples.read(device, &buffers.staging, s0, n)?;
                    self.ctx.check()?;
                }
                s0 += n;
            }
            samples.deliver(target, first, |pos| {
                // Grid index 0 is corner 0, index `level` (i = n, j = 0) corner 1, the
                // last index (j = n) corner 2.
                for (p, s) in pos.chunks_mut(per).enumerate() {
                    for (k, local) in [0, level as usize, per - 1].into_iter().enumerate() {
                        s[local] = table.corner(first + p, k);
                    }
                }
            })?;
            first += count;
        }
        self.ctx.wait()?;
        self.ctx.check()
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
                samples.read(device, &buffers.staging, 0, n)?;
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
            samples: grid_len(level.max(1)) * table.len(),
            elapsed: start.elapsed(),
        })
    }
}

impl Evaluator for GpuEvaluator {
    fn describe(&self) -> String {
        format!("gpu ({}, {})", self.precision, self.ctx.describe())
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
