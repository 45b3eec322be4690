//! The GPU backend: WGSL compute shaders (`shaders/`) through wgpu, f32 or f64.
//!
//! Control points are uploaded relative to each patch's first control point (so f32 keeps
//! its digits on meshes far from the origin) and the shaders return positions relative to
//! the same point; the CPU adds it back in f64 and renormalises the normals in f64.
//!
//! Work is split so that no storage binding exceeds the adapter's limit and no dispatch
//! dimension exceeds its workgroup limit, and results stream to the sink chunk by chunk.
//! The device work is done by free functions on `(&Device, &Queue, ...)`
//! ([`bind_group_layout`], [`create_pipelines`], [`dispatch`], [`read_back`]).

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use glam::DVec3;
use rayon::prelude::*;

use super::{grid_len, Chunk, Evaluator, PatchPoint, Pattern};
use crate::gpu::shaders::{self, ShaderFile};
use crate::gpu::{GpuContext, Precision};
use crate::patch::{PatchKind, PatchTable};
use crate::{Error, Result};

/// Threads per workgroup (`WORKGROUP` in `shaders/common.wgsl`).
pub const WORKGROUP: u32 = 64;

/// Reals written per sample: position then normal.
const OUT_REALS: usize = 6;

/// A real of the shaders' working precision.
pub trait Real: bytemuck::Pod + Send + Sync {
    const PRECISION: Precision;
    fn of(x: f64) -> Self;
    fn get(self) -> f64;
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

/// The compute pipelines of one (shader file, patch kind, precision).
pub struct Pipelines {
    pub file: ShaderFile,
    pub kind: PatchKind,
    pub precision: Precision,
    /// Grid, basis computed in the shader.
    pub grid: wgpu::ComputePipeline,
    /// Grid, basis read from the precomputed table.
    pub grid_table: wgpu::ComputePipeline,
    pub points: wgpu::ComputePipeline,
}

/// The bind group layout every evaluation shader uses: 0 params (uniform), 1 records,
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

/// Builds the grid and points pipelines of `file` for `kind`. The source is validated with
/// naga first, so a shader error comes back as naga's report.
pub fn create_pipelines(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    file: ShaderFile,
    kind: PatchKind,
    precision: Precision,
) -> Result<Pipelines> {
    let source = shaders::module_source(file, kind, precision);
    shaders::validate(&source, precision)
        .map_err(|e| Error::Gpu(format!("shaders/{}: {e}", file.name)))?;
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
        file,
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
    pub records: wgpu::Buffer,
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
        records_bytes: u64,
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
        let records = buffer("records", records_bytes, U::STORAGE | U::COPY_DST);
        let points = buffer("points", points_bytes.max(32), U::STORAGE | U::COPY_DST);
        let out = buffer("out", out_bytes, U::STORAGE | U::COPY_SRC);
        let staging = buffer("staging", out_bytes, U::MAP_READ | U::COPY_DST);
        let grid_weights = buffer(
            "grid weights",
            grid_weights_bytes.max(32),
            U::STORAGE | U::COPY_DST,
        );
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("g1tess eval"),
            layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: params.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: records.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: points.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: out.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 4,
                    resource: grid_weights.as_entire_binding(),
                },
            ],
        });
        Buffers {
            params,
            records,
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

/// Maps the first `bytes` of the staging buffer, hands them to `f` as reals, unmaps.
pub fn read_back<R: Real, T>(
    device: &wgpu::Device,
    staging: &wgpu::Buffer,
    bytes: u64,
    f: impl FnOnce(&[R]) -> T,
) -> Result<T> {
    let slice = staging.slice(..bytes);
    let (tx, rx) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |r| {
        let _ = tx.send(r);
    });
    crate::gpu::wait(device)?;
    rx.recv()
        .map_err(|_| Error::Gpu("map callback never ran".into()))?
        .map_err(|e| Error::Gpu(format!("mapping the result buffer: {e}")))?;
    let out = {
        let view = slice
            .get_mapped_range()
            .map_err(|e| Error::Gpu(format!("reading the result buffer: {e}")))?;
        let reals: &[R] = bytemuck::try_cast_slice(&view)
            .map_err(|e| Error::Gpu(format!("result buffer: {e}")))?;
        f(reals)
    };
    staging.unmap();
    Ok(out)
}

/// Appends the record of patch `i` (control points relative to the first one, then the
/// flat normal) to `out`, and returns the origin.
fn push_record<R: Real>(table: &PatchTable, i: usize, out: &mut Vec<R>) -> DVec3 {
    let c = table.patch(i);
    let origin = c[0];
    let geometry = shaders::geometry_points(table.kind);
    for (j, p) in c.iter().enumerate() {
        let q = if j < geometry { *p - origin } else { *p };
        out.extend_from_slice(&[R::of(q.x), R::of(q.y), R::of(q.z)]);
    }
    let f = table.flat_normals[i];
    out.extend_from_slice(&[R::of(f.x), R::of(f.y), R::of(f.z)]);
    origin
}

/// Converts `reals` (6 per sample) to f64 positions (plus their patch's origin) and
/// renormalised normals.
fn convert<R: Real>(
    reals: &[R],
    origin_of: impl Fn(usize) -> DVec3 + Sync,
    pos: &mut [DVec3],
    nrm: &mut [DVec3],
) {
    const BLOCK: usize = 4096;
    pos.par_chunks_mut(BLOCK)
        .zip(nrm.par_chunks_mut(BLOCK))
        .enumerate()
        .for_each(|(b, (p, n))| {
            for k in 0..p.len() {
                let t = b * BLOCK + k;
                let r = &reals[t * OUT_REALS..t * OUT_REALS + OUT_REALS];
                let o = origin_of(t);
                p[k] = o + DVec3::new(r[0].get(), r[1].get(), r[2].get());
                let v = DVec3::new(r[3].get(), r[4].get(), r[5].get());
                n[k] = v.try_normalize().unwrap_or(v);
            }
        });
}

/// The consumer of evaluated chunks.
pub type Sink<'a> = dyn FnMut(Chunk<'_>) -> Result<()> + 'a;

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
                "{}: the adapter does not offer SHADER_F64; use --precision f32",
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

    /// The pipelines of `file` for `kind` (built once, then cached).
    pub fn pipelines_for(&self, file: ShaderFile, kind: PatchKind) -> Result<Arc<Pipelines>> {
        let mut cache = self
            .pipelines
            .lock()
            .map_err(|_| Error::Gpu("pipeline cache poisoned".into()))?;
        if let Some(p) = cache.iter().find(|p| p.file == file && p.kind == kind) {
            return Ok(p.clone());
        }
        let p = Arc::new(create_pipelines(
            &self.ctx.device,
            &self.layout,
            file,
            kind,
            self.precision,
        )?);
        self.ctx.check()?;
        cache.push(p.clone());
        Ok(p)
    }

    /// The pipelines of `table`'s scheme and kind.
    pub fn pipelines(&self, table: &PatchTable) -> Result<Arc<Pipelines>> {
        self.pipelines_for(shaders::scheme_file(table.scheme, table.kind)?, table.kind)
    }

    /// [`Evaluator::evaluate`] with an explicit shader file (which must evaluate the
    /// table's kind) instead of the scheme's own.
    pub fn evaluate_with_file(
        &self,
        file: ShaderFile,
        table: &PatchTable,
        pattern: &Pattern,
        sink: &mut dyn FnMut(Chunk<'_>) -> Result<()>,
    ) -> Result<()> {
        if !file.kinds.contains(&table.kind) {
            return Err(Error::Gpu(format!(
                "shaders/{} cannot evaluate patch kind {:?}",
                file.name, table.kind
            )));
        }
        let pipes = self.pipelines_for(file, table.kind)?;
        match (pattern, self.precision) {
            (Pattern::Grid { level }, Precision::F32) => {
                self.grid::<f32>(&pipes, table, *level, Some(sink))
            }
            (Pattern::Grid { level }, Precision::F64) => {
                self.grid::<f64>(&pipes, table, *level, Some(sink))
            }
            (Pattern::Points(p), Precision::F32) => self.points::<f32>(&pipes, table, p, sink),
            (Pattern::Points(p), Precision::F64) => self.points::<f64>(&pipes, table, p, sink),
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

    /// Evaluates the grid of `level`; with `sink` None nothing is read back (the timing of
    /// dispatches alone).
    fn grid<R: Real>(
        &self,
        pipes: &Pipelines,
        table: &PatchTable,
        level: u32,
        mut sink: Option<&mut Sink<'_>>,
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
        let rec_reals = 3 * (table.stride + 1);
        let rec_bytes = rec_reals * rb;
        let per_dispatch = self.limit_samples(sample_bytes)?;
        let by_records = (self.max_binding_bytes / rec_bytes as u64) as usize;
        if by_records == 0 {
            return Err(Error::Gpu(
                "storage binding limit is below one patch".into(),
            ));
        }
        let patches_per_chunk = (self.chunk_samples / per)
            .max(1)
            .min(by_records)
            .min((per_dispatch / per).max(1))
            .min(table.len());
        let out_samples = (patches_per_chunk * per).min(per_dispatch);
        let table_bytes = (per * table.stride * 3 * rb) as u64;
        let use_table = table_bytes <= self.max_grid_table_bytes.min(self.max_binding_bytes);
        let buffers = Buffers::new(
            device,
            &self.layout,
            (patches_per_chunk * rec_bytes) as u64,
            32,
            (out_samples * sample_bytes) as u64,
            if use_table { table_bytes } else { 32 },
        );
        let pipeline = if use_table {
            let w = super::cpu::grid_weights(table, level);
            let mut flat: Vec<R> = vec![R::of(0.0); per * table.stride * 3];
            for (local, w) in w.iter().enumerate() {
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
        let mut records: Vec<R> = Vec::with_capacity(patches_per_chunk * rec_reals);
        let mut origins = Vec::with_capacity(patches_per_chunk);
        let (mut pos, mut nrm) = (Vec::new(), Vec::new());
        let mut first = 0;
        while first < table.len() {
            let count = patches_per_chunk.min(table.len() - first);
            records.clear();
            origins.clear();
            for i in first..first + count {
                origins.push(push_record(table, i, &mut records));
            }
            queue.write_buffer(&buffers.records, 0, bytemuck::cast_slice(&records));
            let total = count * per;
            if sink.is_some() {
                pos.resize(total, DVec3::ZERO);
                nrm.resize(total, DVec3::ZERO);
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
                let copy = if sink.is_some() {
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
                if sink.is_some() {
                    let origins = &origins;
                    let (p, q) = (&mut pos[s0..s0 + n], &mut nrm[s0..s0 + n]);
                    read_back::<R, _>(device, &buffers.staging, copy, |reals| {
                        convert(reals, |t| origins[(s0 + t) / per], p, q)
                    })?;
                    self.ctx.check()?;
                }
                s0 += n;
            }
            if let Some(sink) = sink.as_mut() {
                sink(Chunk {
                    first,
                    positions: &pos,
                    normals: &nrm,
                })?;
            }
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
        sink: &mut dyn FnMut(Chunk<'_>) -> Result<()>,
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
        let rec_reals = 3 * (table.stride + 1);
        let rec_bytes = rec_reals * rb;
        // Worst case every point of a chunk is on its own patch.
        let per_chunk = self
            .limit_samples(sample_bytes.max(point_bytes).max(rec_bytes))?
            .min(self.chunk_samples.max(1))
            .min(points.len());
        let buffers = Buffers::new(
            device,
            &self.layout,
            (per_chunk * rec_bytes) as u64,
            (per_chunk * point_bytes) as u64,
            (per_chunk * sample_bytes) as u64,
            32,
        );
        let mut local = vec![u32::MAX; table.len()];
        let mut used: Vec<usize> = Vec::new();
        let mut records: Vec<R> = Vec::new();
        let mut origins = Vec::new();
        let mut pts: Vec<u8> = Vec::with_capacity(per_chunk * point_bytes);
        let (mut pos, mut nrm) = (Vec::new(), Vec::new());
        for (c, chunk) in points.chunks(per_chunk).enumerate() {
            records.clear();
            origins.clear();
            pts.clear();
            for p in chunk {
                let i = p.patch as usize;
                if local[i] == u32::MAX {
                    local[i] = used.len() as u32;
                    used.push(i);
                    origins.push(push_record(table, i, &mut records));
                }
                for x in p.b {
                    pts.extend_from_slice(bytemuck::bytes_of(&R::of(x)));
                }
                pts.extend_from_slice(&local[i].to_le_bytes());
                pts.resize(pts.len().next_multiple_of(point_bytes), 0);
            }
            queue.write_buffer(&buffers.records, 0, bytemuck::cast_slice(&records));
            queue.write_buffer(&buffers.points, 0, &pts);
            let n = chunk.len();
            let params = Params {
                count: n as u32,
                ..Default::default()
            };
            let copy = (n * sample_bytes) as u64;
            dispatch(
                device,
                queue,
                &pipes.points,
                &buffers,
                params,
                self.max_workgroups_per_dim,
                copy,
            );
            pos.resize(n, DVec3::ZERO);
            nrm.resize(n, DVec3::ZERO);
            let (origins, slot) = (&origins, &local);
            read_back::<R, _>(device, &buffers.staging, copy, |reals| {
                convert(
                    reals,
                    |t| origins[slot[chunk[t].patch as usize] as usize],
                    &mut pos,
                    &mut nrm,
                )
            })?;
            self.ctx.check()?;
            for i in used.drain(..) {
                local[i] = u32::MAX;
            }
            sink(Chunk {
                first: c * per_chunk,
                positions: &pos,
                normals: &nrm,
            })?;
        }
        self.ctx.check()
    }

    /// Runs the grid of `level` on the GPU without reading anything back (uploads and
    /// dispatches, then waits): the time of the device work alone.
    pub fn time_grid(&self, table: &PatchTable, level: u32) -> Result<GridTiming> {
        // Pipelines are built before the clock starts.
        let pipes = self.pipelines(table)?;
        let start = Instant::now();
        match self.precision {
            Precision::F32 => self.grid::<f32>(&pipes, table, level, None)?,
            Precision::F64 => self.grid::<f64>(&pipes, table, level, None)?,
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

    fn evaluate(
        &self,
        table: &PatchTable,
        pattern: &Pattern,
        sink: &mut dyn FnMut(Chunk<'_>) -> Result<()>,
    ) -> Result<()> {
        let file = shaders::scheme_file(table.scheme, table.kind)?;
        self.evaluate_with_file(file, table, pattern, sink)
    }
}
