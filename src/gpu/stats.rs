//! Table 1's continuity statistics on the GPU: the edge samples are evaluated and reduced
//! on the device (`shaders/stats.wgsl`), and only one record of aggregates per workgroup
//! of 64 samples comes back, merged on the host in f64 as the CPU statistics merge their
//! blocks (Chan et al.'s pairwise update of mean and M2).
//!
//! The result agrees with [`crate::analysis::stats::stats_report`] on the CPU evaluator
//! within the working precision (`tests/gpu.rs` derives the bounds); in f64 (adapters with
//! `SHADER_F64`, lavapipe has it) to a few f64 ulps of each value.
//!
//! The patches come from a whole [`PatchTable`]; each dispatch uploads only the patches its
//! edges use.

use crate::analysis::stats::{edge_pairs, Continuity, CosStats, SAMPLES_PER_EDGE};
use crate::eval::EdgePairs;
use crate::gpu::eval::{
    bind_group_layout, dispatch, push_patch_data, shader_module, Buffers, GpuEvaluator, Params,
    Real, WORKGROUP,
};
use crate::gpu::readback::read_buffer;
use crate::gpu::shaders::{self, CREASE_BIT, STATS_REALS};
use crate::gpu::Precision;
use crate::mesh::creases::normal_key;
use crate::mesh::{Adjacency, Mesh};
use crate::patch::PatchTable;
use crate::{Error, Result};

/// Edge samples per dispatch (2^16: a few MiB of points and patches).
pub const DISPATCH_SAMPLES: usize = 1 << 16;

/// The running merge of the workgroups' records (`Totals::merge` of the CPU statistics).
struct Merge {
    n: f64,
    mean: f64,
    m2: f64,
    min: f64,
    max: f64,
    worst_abs: f64,
    gap2: f64,
    folded: f64,
    crease_n: f64,
    crease_gap2: f64,
}

impl Merge {
    fn new() -> Merge {
        Merge {
            n: 0.0,
            mean: 0.0,
            m2: 0.0,
            min: f64::INFINITY,
            max: f64::NEG_INFINITY,
            worst_abs: 0.0,
            gap2: 0.0,
            folded: 0.0,
            crease_n: 0.0,
            crease_gap2: 0.0,
        }
    }

    /// Merges one record: n, shift, Σd, Σd², min, max, max 1 − |cos|, max gap², folded,
    /// crease n, crease max gap².
    fn add(&mut self, r: &[f64]) {
        let [nb, shift, s1, s2, min, max, worst, gap2, folded, crease_n, crease_gap2] =
            r.try_into().unwrap_or([0.0; STATS_REALS]);
        self.crease_n += crease_n;
        self.crease_gap2 = self.crease_gap2.max(crease_gap2);
        if nb == 0.0 {
            return;
        }
        self.min = self.min.min(min);
        self.max = self.max.max(max);
        self.worst_abs = self.worst_abs.max(worst);
        self.gap2 = self.gap2.max(gap2);
        self.folded += folded;
        let mean_b = shift + s1 / nb;
        let m2_b = (s2 - s1 * s1 / nb).max(0.0);
        if self.n == 0.0 {
            self.mean = mean_b;
            self.m2 = m2_b;
        } else {
            let total = self.n + nb;
            let delta = mean_b - self.mean;
            self.mean += delta * (nb / total);
            self.m2 += m2_b + delta * delta * (self.n * nb / total);
        }
        self.n += nb;
    }

    fn finish(self, crease_edges: usize) -> Continuity {
        let n = self.n as usize;
        let (min, max) = if n > 0 {
            (self.min, self.max)
        } else {
            (0.0, 0.0)
        };
        Continuity {
            samples: n,
            cos: CosStats {
                min,
                max,
                mean: self.mean,
                std: if n > 1 {
                    (self.m2 / (n - 1) as f64).sqrt()
                } else {
                    0.0
                },
            },
            max_one_minus_abs_cos: self.worst_abs,
            max_gap: self.gap2.sqrt(),
            folded: self.folded as usize,
            crease_edges,
            crease_samples: self.crease_n as usize,
            crease_max_gap: self.crease_gap2.sqrt(),
        }
    }
}

/// Whether the two sides of `pair` give an end vertex different normals (a crease edge,
/// as the CPU statistics decide it: the corner normals' bits differ).
fn is_crease(mesh: &Mesh, pair: &[crate::eval::EdgeSide; 2]) -> bool {
    let [a, b] = pair;
    let n = |s: &crate::eval::EdgeSide, slot: u8| {
        normal_key(mesh.corner_normals[s.patch as usize][slot as usize])
    };
    n(a, a.from) != n(b, b.from) || n(a, a.to) != n(b, b.to)
}

/// The continuity statistics of `table` (the whole mesh's, patch i = triangle i) over the
/// interior edges of `mesh`, evaluated and reduced on `gpu`'s device in its precision.
pub fn gpu_continuity(
    gpu: &GpuEvaluator,
    mesh: &Mesh,
    adjacency: &Adjacency,
    table: &PatchTable,
) -> Result<Continuity> {
    if table.len() != mesh.triangles.len() {
        return Err(Error::mesh(
            &mesh.name,
            format!(
                "patch table of {} patches for {} triangles",
                table.len(),
                mesh.triangles.len()
            ),
        ));
    }
    if table.len() >= CREASE_BIT as usize {
        return Err(Error::mesh(
            &mesh.name,
            "too many triangles for the GPU statistics",
        ));
    }
    let pairs = edge_pairs(mesh, adjacency);
    match gpu.precision() {
        Precision::F32 => run::<f32>(gpu, mesh, table, &pairs),
        Precision::F64 => run::<f64>(gpu, mesh, table, &pairs),
    }
}

fn run<R: Real>(
    gpu: &GpuEvaluator,
    mesh: &Mesh,
    table: &PatchTable,
    pairs: &EdgePairs,
) -> Result<Continuity> {
    let ctx = gpu.context();
    let (device, queue) = (&ctx.device, &ctx.queue);
    let precision = R::PRECISION;
    let source = shaders::stats_source(table.kind, precision)?;
    shaders::validate(&source, precision)
        .map_err(|e| Error::Gpu(format!("shaders/{}: {e}", shaders::STATS.name)))?;
    let module = shader_module(
        device,
        shaders::STATS.name,
        source,
        gpu.shader_runtime_checks,
    );
    let layout = bind_group_layout(device);
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("g1tess stats"),
        bind_group_layouts: &[Some(&layout)],
        immediate_size: 0,
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(shaders::STATS.name),
        layout: Some(&pipeline_layout),
        module: &module,
        entry_point: Some("stats_main"),
        compilation_options: Default::default(),
        cache: None,
    });
    let samples_per_edge = SAMPLES_PER_EDGE as usize;
    let rb = precision.bytes();
    let point_bytes = if rb == 4 { 16 } else { 32 };
    let upload_bytes = 3 * shaders::patch_vecs(table.kind) * rb;
    let edges_per_dispatch = (DISPATCH_SAMPLES / samples_per_edge).max(1);
    let samples_max = edges_per_dispatch * samples_per_edge;
    let groups_max = samples_max.div_ceil(WORKGROUP as usize);
    let record_bytes = STATS_REALS * rb;
    let buffers = Buffers::new(
        device,
        &layout,
        (2 * edges_per_dispatch * upload_bytes) as u64,
        (2 * samples_max * point_bytes) as u64,
        (groups_max * record_bytes) as u64,
        32,
    );
    ctx.check()?;
    let mut slot = vec![u32::MAX; table.len()];
    let mut used: Vec<usize> = Vec::new();
    let mut patch_data: Vec<R> = Vec::new();
    let mut pts: Vec<u8> = Vec::with_capacity(2 * samples_max * point_bytes);
    let mut merge = Merge::new();
    let mut crease_edges = 0;
    let mut records: Vec<f64> = Vec::new();
    for chunk in pairs.pairs.chunks(edges_per_dispatch) {
        patch_data.clear();
        pts.clear();
        for pair in chunk {
            let crease = is_crease(mesh, pair);
            crease_edges += crease as usize;
            for side in pair {
                let i = side.patch as usize;
                if slot[i] == u32::MAX {
                    slot[i] = used.len() as u32;
                    used.push(i);
                    push_patch_data(table, i, &mut patch_data);
                }
            }
            for k in 0..SAMPLES_PER_EDGE {
                for (j, side) in pair.iter().enumerate() {
                    for x in pairs.barycentric(*side, k) {
                        pts.extend_from_slice(bytemuck::bytes_of(&R::of(x)));
                    }
                    let mut index = slot[side.patch as usize];
                    if j == 1 && crease {
                        index |= CREASE_BIT;
                    }
                    pts.extend_from_slice(&index.to_le_bytes());
                    pts.resize(pts.len().next_multiple_of(point_bytes), 0);
                }
            }
        }
        for i in used.drain(..) {
            slot[i] = u32::MAX;
        }
        queue.write_buffer(&buffers.patch_data, 0, bytemuck::cast_slice(&patch_data));
        queue.write_buffer(&buffers.points, 0, &pts);
        let n = chunk.len() * samples_per_edge;
        let groups = n.div_ceil(WORKGROUP as usize);
        let params = Params {
            count: n as u32,
            ..Default::default()
        };
        dispatch(
            device,
            queue,
            &pipeline,
            &buffers,
            params,
            gpu.max_workgroups_per_dim,
            (groups * record_bytes) as u64,
        );
        records.clear();
        read_buffer(
            device,
            &buffers.staging,
            (groups * record_bytes) as u64,
            |b| {
                let v: &[R] = bytemuck::try_cast_slice(b)
                    .map_err(|e| Error::Gpu(format!("statistics buffer: {e}")))?;
                records.extend(v.iter().map(|x| x.get()));
                Ok::<(), Error>(())
            },
        )??;
        ctx.check()?;
        for r in records.chunks_exact(STATS_REALS) {
            merge.add(r);
        }
    }
    Ok(merge.finish(crease_edges))
}
