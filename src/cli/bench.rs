//! `g1tess bench`: throughput of every evaluator on dense grids, against the machine's
//! memory write bandwidth measured in the same run.
//!
//! For each mesh, scheme and level: the patch-table build time, and samples per second of
//! the CPU f32 fast path (1 thread and all threads, streamed in chunks; and all threads
//! into one pre-faulted array of the whole output), the f64 CPU reference (all threads),
//! the GPU without readback (uploads + dispatches) and with readback (results in host
//! memory as f64, chunk by chunk). Each throughput is also given as a fraction of the
//! write roofline: bandwidth / 24 bytes (an f32 position and normal per sample).
//!
//! `--end-to-end` instead times what a user runs, in one process (see [`run_end_to_end`]):
//! `tessellate` into memory and to a binary PLY file, `stats` on a ~1 M-triangle mesh and
//! loading an OBJ, each beside a same-run baseline (a plain sequential write of the same
//! bytes, a `wc -w`-equivalent read of the same file).

use std::io::IsTerminal;
use std::time::{Duration, Instant};

use anyhow::Context;
use clap::Args;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use rayon::prelude::*;
use serde::Serialize;

use crate::eval::cpu::{CpuEvaluator, F32Kernel, GridWeightsF32};
use crate::eval::{grid_len, Evaluator, Pattern};
use crate::gpu::eval::{CeilingShape, GpuEvaluator};
use crate::gpu::{GpuContext, Precision};
use crate::mesh::{LoadOptions, Mesh};
use crate::patch::{PatchTable, Scheme, SchemeOptions};

mod end_to_end;
use super::common::whole_number;
use super::out;
use end_to_end::run_end_to_end;

/// Bytes one sample writes: f32 position + f32 normal.
pub const SAMPLE_BYTES: f64 = 24.0;

/// The default mesh, relative to the crate root (where `cargo run` runs).
const DEFAULT_MESH: &str = "tests/data/stanford-bunny.obj";

#[derive(Args, Clone, Debug)]
pub struct BenchArgs {
    /// Meshes (OBJ, PLY, STL, glTF .gltf/.glb or .pn files, or built-ins); default
    /// tests/data/stanford-bunny.obj.
    pub meshes: Vec<String>,
    /// Grid levels.
    #[arg(
        long,
        value_delimiter = ',',
        default_values_t = [8u32, 16, 32],
        allow_negative_numbers = true,
        value_parser = whole_number(1, u32::MAX)
    )]
    pub levels: Vec<u32>,
    /// Schemes (default: all).
    #[arg(long, value_enum, value_delimiter = ',')]
    pub schemes: Vec<Scheme>,
    /// GPU working precision.
    #[arg(long, value_enum, default_value = "f32")]
    pub precision: Precision,
    /// Samples per chunk of the CPU evaluators (a chunk's output is one reused buffer: one
    /// that fits in the last-level cache is never written back to memory).
    #[arg(long, default_value_t = 1 << 20, allow_negative_numbers = true)]
    pub cpu_chunk_samples: usize,
    /// Skip the GPU even when an adapter is present.
    #[arg(long)]
    pub no_gpu: bool,
    /// Skip the f64 CPU reference (the slowest measurement).
    #[arg(long)]
    pub no_reference: bool,
    /// Size of the buffer the write bandwidth is measured on, MiB (well above the last-level
    /// cache for a memory figure).
    #[arg(long, default_value_t = 1024, allow_negative_numbers = true)]
    pub bandwidth_mib: usize,
    /// Keep wgpu's runtime checks (bounds checks, loop bounding) in the GPU shaders, to
    /// measure what they cost (by default the crate's own shaders are created trusted).
    #[arg(long)]
    pub gpu_runtime_checks: bool,
    /// Run GPU grids with one thread per sample even on a software adapter (whose default
    /// is one thread per patch, see `GpuEvaluator::patch_loop`), to measure the difference.
    #[arg(long)]
    pub gpu_thread_per_sample: bool,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    pub memory: super::common::MemoryArgs,
    /// No progress bar.
    #[arg(long, short)]
    pub quiet: bool,
    /// Time the commands end to end instead of the kernels: tessellate (into memory and to
    /// a binary PLY file), stats and OBJ loading, beside a plain write and a word count.
    #[arg(long)]
    pub end_to_end: bool,
    /// For a machine with a real GPU: the adapter, its memory bandwidth (a device-side
    /// buffer copy), then device-resident evaluation (no readback), evaluation read back
    /// as f32, a frame of the device-resident tessellator (`GpuTessellator`, buffers kept),
    /// and the GPU statistics path, each as a fraction of that bandwidth, on the
    /// first mesh and scheme (default the bunny, G1) at each of `--levels`
    /// (scripts/gpu-check.sh).
    #[arg(long)]
    pub gpu_check: bool,
    /// End to end: grid level of the rows `tessellate_memory` (evaluation only) and
    /// `tessellate_ply_file`.
    #[arg(
        long,
        default_value_t = 32,
        allow_negative_numbers = true,
        value_parser = whole_number(1, u32::MAX)
    )]
    pub tess_level: u32,
    /// End to end: levels of the rows that tessellate into memory with set-up and
    /// evaluation timed apart (`tessellate_setup`, `tessellate_eval`,
    /// `tessellate_setup_eval`): the levels users run. `--tess-level` is the level of the
    /// `tessellate_memory` and file rows.
    #[arg(
        long,
        value_delimiter = ',',
        default_values_t = [4u32, 8, 16],
        allow_negative_numbers = true,
        value_parser = whole_number(1, u32::MAX)
    )]
    pub memory_levels: Vec<u32>,
    /// End to end: level at which the mesh is tessellated into the OBJ that is loaded and
    /// given to stats (4: the bunny becomes a 1.1 M-triangle mesh).
    #[arg(
        long,
        default_value_t = 4,
        allow_negative_numbers = true,
        value_parser = whole_number(1, u32::MAX)
    )]
    pub stats_level: u32,
    /// End to end: folder for the temporary files (default: the system's temporary folder);
    /// they are removed afterwards.
    #[arg(long)]
    pub dir: Option<std::path::PathBuf>,
}

/// One throughput figure.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Rate {
    pub seconds: f64,
    pub samples_per_s: f64,
    /// samples_per_s × 24 bytes / the all-threads write bandwidth.
    pub roofline_fraction: f64,
}

#[derive(Clone, Debug, Serialize)]
pub struct Row {
    pub mesh: String,
    pub scheme: String,
    pub triangles: usize,
    pub level: u32,
    pub samples: usize,
    /// Patch-table build time (best of 3), seconds.
    pub build_s: f64,
    pub cpu_f32_1_thread: Rate,
    pub cpu_f32_all_threads: Rate,
    /// All threads, the whole output in one pre-faulted array (every byte goes to memory).
    pub cpu_f32_all_threads_whole_output: Rate,
    pub cpu_f64_reference_all_threads: Option<Rate>,
    pub gpu_dispatch_only: Option<Rate>,
    pub gpu_with_readback: Option<Rate>,
    /// The full `Evaluator::evaluate_f32` into a sink that encodes each sample as a writer
    /// does (24 bytes interleaved into a reused buffer), double-buffered readback: the
    /// device computes the next dispatch while the host encodes.
    pub gpu_to_f32_sink: Option<Rate>,
    /// The same with one output buffer (device and host take turns).
    pub gpu_to_f32_sink_single_buffer: Option<Rate>,
    /// The minimal shader (`shaders/ceiling.wgsl`: 24 bytes written per sample, nothing
    /// read) over the same number of samples, the faster of its two ways of storing them
    /// (one sample per invocation stored value by value, or four stored as vec4s as
    /// `grid_patch_main` does): the most any evaluation shader can do on this device.
    pub gpu_ceiling: Option<Rate>,
    /// gpu_dispatch_only ÷ gpu_ceiling (samples per second).
    pub gpu_ceiling_fraction: Option<f64>,
    /// The minimal shader with one sample per invocation, stored value by value
    /// (`ceiling_main`; the ceiling of earlier reports).
    pub gpu_ceiling_per_sample: Option<Rate>,
    /// gpu_dispatch_only ÷ gpu_ceiling_per_sample.
    pub gpu_ceiling_per_sample_fraction: Option<f64>,
    /// The patch loop's bound where the grid runs one thread per patch (software adapters):
    /// `grid_patch_main` as this kind runs it, with the same uploads, control-point loads,
    /// normalisation and stores, evaluating nothing (`shaders/loop_bound.wgsl`). No
    /// evaluation of the kind in that loop can be faster.
    pub gpu_loop_bound: Option<Rate>,
    /// gpu_loop_bound ÷ gpu_ceiling: the most of the ceiling an evaluation in the patch
    /// loop can reach.
    pub gpu_loop_bound_fraction: Option<f64>,
    /// gpu_dispatch_only ÷ cpu_f32_all_threads (samples per second), the same run.
    pub gpu_cpu_f32_fraction: Option<f64>,
}

#[derive(Clone, Debug, Serialize)]
pub struct Machine {
    pub cpu: String,
    pub threads: usize,
    pub os: String,
    pub cpu_kernel: String,
    /// Samples per chunk of the CPU evaluators.
    pub cpu_chunk_samples: usize,
    pub gpu: Option<String>,
    /// The adapter's limits that matter here.
    pub gpu_limits: Option<String>,
    pub gpu_precision: String,
    /// Why there are no GPU figures, if there are none.
    pub gpu_note: Option<String>,
    /// Memory write bandwidth, all threads / one thread, GB/s (10^9 bytes), best of 3
    /// fills of a buffer of `bandwidth_buffer_mib`.
    pub write_bandwidth_gbs: f64,
    pub write_bandwidth_1_thread_gbs: f64,
    pub bandwidth_buffer_mib: usize,
    /// Samples per second the all-threads bandwidth allows at 24 bytes per sample.
    pub roofline_samples_per_s: f64,
}

#[derive(Clone, Debug, Serialize)]
pub struct BenchReport {
    pub machine: Machine,
    pub rows: Vec<Row>,
}

fn cpu_model() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|m| m.trim().to_string())
        })
        .unwrap_or_else(|| std::env::consts::ARCH.to_string())
}

/// Best-of-3 time to fill `buf` with f32 stores (ordinary stores, like the evaluators').
fn fill_bandwidth(buf: &mut [f32], pool: &rayon::ThreadPool) -> f64 {
    let mut best = f64::INFINITY;
    for rep in 0..3 {
        let v = rep as f32 + 1.5;
        let t = Instant::now();
        pool.install(|| {
            buf.par_chunks_mut(1 << 20).for_each(|c| {
                for x in c.iter_mut() {
                    *x = v;
                }
            })
        });
        best = best.min(t.elapsed().as_secs_f64());
        std::hint::black_box(&buf[buf.len() / 2]);
    }
    (buf.len() * 4) as f64 / best / 1e9
}

/// Write bandwidth in GB/s with all threads and with one, on a buffer of `mib` MiB.
/// Refuses a bandwidth buffer over the memory budget, before it is allocated.
fn check_bandwidth_buffer(a: &BenchArgs, budget: &super::common::Budget) -> anyhow::Result<()> {
    let bytes = (a.bandwidth_mib.max(1) as u64).saturating_mul(1 << 20);
    budget.check(
        "bench",
        &format!("--bandwidth-mib {}", a.bandwidth_mib),
        bytes,
        "the buffer the write bandwidth is measured on",
    )
}

pub fn write_bandwidth(mib: usize) -> anyhow::Result<(f64, f64)> {
    let mut buf = vec![0f32; (mib.max(1) << 20) / 4];
    // Fault every page in before timing.
    buf.par_chunks_mut(1024).for_each(|c| c[0] = 1.0);
    let all = rayon::ThreadPoolBuilder::new().build()?;
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
    Ok((
        fill_bandwidth(&mut buf, &all),
        fill_bandwidth(&mut buf, &one),
    ))
}

/// Runs `f` until at least `min` has passed (at least once, at most 5 times); best time.
fn best_time(min: Duration, mut f: impl FnMut() -> anyhow::Result<()>) -> anyhow::Result<f64> {
    let start = Instant::now();
    let mut best = f64::INFINITY;
    for _ in 0..5 {
        let t = Instant::now();
        f()?;
        best = best.min(t.elapsed().as_secs_f64());
        if start.elapsed() >= min {
            break;
        }
    }
    Ok(best)
}

fn load_mesh(spec: &str) -> anyhow::Result<Mesh> {
    let opts = LoadOptions::default();
    if spec == DEFAULT_MESH && !std::path::Path::new(spec).exists() {
        // Run from elsewhere than the crate root: try the crate root the binary was built in.
        let beside = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/stanford-bunny.obj");
        if std::path::Path::new(beside).exists() {
            return Ok(Mesh::load(beside, &opts)?);
        }
    }
    Mesh::load(spec, &opts).with_context(|| format!("bench mesh {spec}"))
}

pub fn run(a: &BenchArgs) -> anyhow::Result<()> {
    if a.end_to_end {
        if let Some(dir) = &a.dir {
            check_dir(dir)?;
        }
        return run_end_to_end(a);
    }
    if a.gpu_check {
        return run_gpu_check(a);
    }
    anyhow::ensure!(
        a.levels.iter().all(|&l| l >= 1),
        "--levels must be at least 1"
    );
    let meshes = if a.meshes.is_empty() {
        vec![DEFAULT_MESH.to_string()]
    } else {
        a.meshes.clone()
    };
    let schemes = if a.schemes.is_empty() {
        Scheme::all()
    } else {
        a.schemes.clone()
    };
    let steps = (meshes.len() * schemes.len() * a.levels.len()) as u64;
    let bar = progress_bar(a.quiet, steps);

    let budget = a.memory.budget();
    check_bandwidth_buffer(a, &budget)?;
    bar.set_message("memory write bandwidth");
    let (bw, bw1) = write_bandwidth(a.bandwidth_mib)?;
    let roofline = bw * 1e9 / SAMPLE_BYTES;

    let (mut gpu, gpu_note) = gpu_evaluator(a);
    if let Some(note) = &gpu_note {
        bar.suspend(|| out::stderr_line(&format!("note: no GPU figures: {note}")));
    }
    let machine = Machine {
        cpu: cpu_model(),
        threads: rayon::current_num_threads(),
        os: format!("{} {}", std::env::consts::OS, std::env::consts::ARCH),
        cpu_kernel: F32Kernel::Auto.name().to_string(),
        cpu_chunk_samples: a.cpu_chunk_samples.max(1),
        gpu: gpu.as_ref().map(|g| g.context().describe()),
        gpu_limits: gpu.as_ref().map(|g| g.context().limits_summary()),
        gpu_precision: a.precision.to_string(),
        gpu_note,
        write_bandwidth_gbs: bw,
        write_bandwidth_1_thread_gbs: bw1,
        bandwidth_buffer_mib: a.bandwidth_mib,
        roofline_samples_per_s: roofline,
    };

    let bench = KernelBench {
        one: rayon::ThreadPoolBuilder::new().num_threads(1).build()?,
        cpu: CpuEvaluator::with_chunk_samples(a.cpu_chunk_samples.max(1)),
        min: Duration::from_millis(500),
        roofline,
        reference: !a.no_reference,
    };
    let mut rows = Vec::new();
    for spec in &meshes {
        let mesh = load_mesh(spec)?;
        check_output_budget(a, &budget, &mesh, &schemes)?;
        for &scheme in &schemes {
            let (table, build_s) = build_table(&mesh, scheme)?;
            for &level in &a.levels {
                bar.set_message(format!(
                    "{} {scheme} level {level}",
                    out::escape(&mesh.name)
                ));
                let times = bench.times(&table, level, gpu.as_mut())?;
                rows.push(bench.row(&mesh, scheme, &table, build_s, level, times));
                bar.inc(1);
            }
        }
    }
    bar.finish_and_clear();
    let report = BenchReport { machine, rows };
    if a.json {
        out::stdout_json(&serde_json::to_string(&report)?)?;
    } else {
        let mut report = report;
        for row in &mut report.rows {
            row.mesh = out::escape(&row.mesh).into_owned();
        }
        out::stdout_line(&to_text(&report))?;
    }
    Ok(())
}

/// Refuses a `--dir` that is not an existing directory, naming it, before any work.
fn check_dir(dir: &std::path::Path) -> anyhow::Result<()> {
    match std::fs::metadata(dir) {
        Ok(m) if m.is_dir() => Ok(()),
        Ok(_) => anyhow::bail!("--dir {}: not a directory", dir.display()),
        Err(e) => anyhow::bail!("--dir {}: {e}", dir.display()),
    }
}

/// A bar of `steps` steps on standard error, hidden when `quiet` or not a terminal.
fn progress_bar(quiet: bool, steps: u64) -> ProgressBar {
    let show = !quiet && std::io::stderr().is_terminal();
    let bar = ProgressBar::with_draw_target(
        Some(steps),
        if show {
            ProgressDrawTarget::stderr()
        } else {
            ProgressDrawTarget::hidden()
        },
    );
    bar.set_style(
        ProgressStyle::with_template("{elapsed_precise} [{bar:30}] {pos}/{len} {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar
}

/// The GPU evaluator the arguments ask for, or why there is none.
fn gpu_evaluator(a: &BenchArgs) -> (Option<GpuEvaluator>, Option<String>) {
    if a.no_gpu {
        return (None, Some("--no-gpu".to_string()));
    }
    match crate::cli::common::shared_gpu().and_then(|c| GpuEvaluator::new(c, a.precision)) {
        Ok(mut g) => {
            g.shader_runtime_checks = a.gpu_runtime_checks;
            g.patch_loop &= !a.gpu_thread_per_sample;
            (Some(g), None)
        }
        Err(e) => (None, Some(e.to_string())),
    }
}

/// Refuses a level whose whole output (f32 positions and normals, one array each), beside
/// the basis weights (stride × 3 f32 per grid point, the largest stride) and a CPU chunk in
/// f64 (the reference), is over the memory budget.
fn check_output_budget(
    a: &BenchArgs,
    budget: &super::common::Budget,
    mesh: &Mesh,
    schemes: &[Scheme],
) -> anyhow::Result<()> {
    let stride = schemes
        .iter()
        .map(|s| s.kind().layout().stride)
        .max()
        .unwrap_or(1) as u64;
    for &level in &a.levels {
        let per = grid_len(level) as u64;
        let samples = per.saturating_mul(mesh.triangles.len() as u64);
        let need = samples
            .saturating_mul(SAMPLE_BYTES as u64)
            .saturating_add(per.saturating_mul(stride * 12))
            .saturating_add((a.cpu_chunk_samples.max(1) as u64).saturating_mul(48));
        budget.check(
            "bench",
            &format!("{} at level {level}", mesh.name),
            need,
            &format!(
                "the whole output of {} samples in one array",
                super::common::human_count(samples)
            ),
        )?;
    }
    Ok(())
}

/// The patch table of `mesh` under `scheme`, and its build time (best of 3), seconds.
fn build_table(mesh: &Mesh, scheme: Scheme) -> anyhow::Result<(PatchTable, f64)> {
    let opts = SchemeOptions::default();
    let mut table = None;
    let mut build_s = f64::INFINITY;
    for _ in 0..3 {
        let t = Instant::now();
        table = Some(PatchTable::build(mesh, scheme, &opts)?);
        build_s = build_s.min(t.elapsed().as_secs_f64());
    }
    Ok((table.expect("built three times"), build_s))
}

/// What the kernel measurements of one run share.
struct KernelBench {
    /// A pool of one thread.
    one: rayon::ThreadPool,
    cpu: CpuEvaluator,
    /// Least time spent on one figure.
    min: Duration,
    /// Samples per second the all-threads write bandwidth allows.
    roofline: f64,
    /// Whether the f64 CPU reference is timed.
    reference: bool,
}

/// The best times of one grid, seconds.
struct Times {
    samples: usize,
    cpu1: f64,
    cpu_all: f64,
    whole: f64,
    reference: Option<f64>,
    gpu: Option<GpuTimes>,
}

/// The best GPU times of one grid, seconds.
struct GpuTimes {
    dispatch: f64,
    readback: f64,
    /// The ceiling stored value by value, and as vec4s.
    ceiling_per_sample: f64,
    ceiling_quads: f64,
    sink_double_buffer: f64,
    sink_single_buffer: f64,
    /// Infinite where the kind has no loop bound.
    loop_bound: f64,
}

impl KernelBench {
    /// Times the grid of `level` on `table`: the CPU f32 paths, the f64 reference (unless
    /// skipped), then the GPU where there is one.
    fn times(
        &self,
        table: &PatchTable,
        level: u32,
        gpu: Option<&mut GpuEvaluator>,
    ) -> anyhow::Result<Times> {
        let (cpu, min) = (&self.cpu, self.min);
        let samples = grid_len(level) * table.len();
        let weights = GridWeightsF32::new(table.kind, level);
        let fast = || {
            cpu.grid_f32(table, &weights, &mut |c| {
                std::hint::black_box(c.positions.last());
                Ok(())
            })
            .map_err(anyhow::Error::from)
        };
        let cpu1 = best_time(min, || self.one.install(fast))?;
        let cpu_all = best_time(min, fast)?;
        let whole = {
            let mut pos = vec![[0f32; 3]; samples];
            let mut nrm = vec![[0f32; 3]; samples];
            let mut run = || {
                cpu.grid_f32_into(table, &weights, &mut pos, &mut nrm)
                    .map_err(anyhow::Error::from)
            };
            run()?; // first touch of every page, untimed
            best_time(min, run)?
        };
        let reference = if self.reference {
            Some(best_time(Duration::ZERO, || {
                cpu.evaluate(table, &Pattern::Grid { level }, &mut |c| {
                    std::hint::black_box(c.positions.last());
                    Ok(())
                })?;
                Ok(())
            })?)
        } else {
            None
        };
        let gpu = match gpu {
            Some(g) => Some(gpu_times(g, table, level, samples, min)?),
            None => None,
        };
        Ok(Times {
            samples,
            cpu1,
            cpu_all,
            whole,
            reference,
            gpu,
        })
    }

    /// The row of one grid: its times as rates, and the ratios between them.
    fn row(
        &self,
        mesh: &Mesh,
        scheme: Scheme,
        table: &PatchTable,
        build_s: f64,
        level: u32,
        times: Times,
    ) -> Row {
        let samples = times.samples;
        let rate = |seconds: f64| Rate {
            seconds,
            samples_per_s: samples as f64 / seconds,
            roofline_fraction: samples as f64 / seconds / self.roofline,
        };
        let g = times.gpu.as_ref();
        let dispatch = g.map(|g| rate(g.dispatch));
        let ceiling = g.map(|g| rate(g.ceiling_per_sample.min(g.ceiling_quads)));
        let ceiling1 = g.map(|g| rate(g.ceiling_per_sample));
        let bound = g.and_then(|g| g.loop_bound.is_finite().then(|| rate(g.loop_bound)));
        let cpu_all_rate = rate(times.cpu_all);
        Row {
            mesh: mesh.name.clone(),
            scheme: scheme.to_string(),
            triangles: table.len(),
            level,
            samples,
            build_s,
            cpu_f32_1_thread: rate(times.cpu1),
            cpu_f32_all_threads: cpu_all_rate,
            cpu_f32_all_threads_whole_output: rate(times.whole),
            cpu_f64_reference_all_threads: times.reference.map(rate),
            gpu_dispatch_only: dispatch,
            gpu_with_readback: g.map(|g| rate(g.readback)),
            gpu_to_f32_sink: g.map(|g| rate(g.sink_double_buffer)),
            gpu_to_f32_sink_single_buffer: g.map(|g| rate(g.sink_single_buffer)),
            gpu_ceiling: ceiling,
            gpu_ceiling_fraction: dispatch
                .zip(ceiling)
                .map(|(d, c)| d.samples_per_s / c.samples_per_s),
            gpu_ceiling_per_sample: ceiling1,
            gpu_ceiling_per_sample_fraction: dispatch
                .zip(ceiling1)
                .map(|(d, c)| d.samples_per_s / c.samples_per_s),
            gpu_loop_bound: bound,
            gpu_loop_bound_fraction: bound
                .zip(ceiling)
                .map(|(b, c)| b.samples_per_s / c.samples_per_s),
            gpu_cpu_f32_fraction: dispatch.map(|d| d.samples_per_s / cpu_all_rate.samples_per_s),
        }
    }
}

/// Times the grid of `level` on `table` (`samples` samples) on the GPU: dispatches alone
/// beside the ceilings and the loop bound, then read back, then into an f32 sink with two
/// output buffers and with one.
fn gpu_times(
    g: &mut GpuEvaluator,
    table: &PatchTable,
    level: u32,
    samples: usize,
    min: Duration,
) -> anyhow::Result<GpuTimes> {
    // The first run builds the pipelines and warms the driver.
    g.time_grid(table, 1)?;
    g.time_ceiling(1, CeilingShape::PerSample)?;
    g.time_ceiling(1, CeilingShape::Quads)?;
    let bound_pipes = g.loop_bound(table.kind)?;
    // The dispatch, the two ceilings and the loop bound in turn, round after round, so that
    // the host's changes of speed reach all of them alike; the best of each. The times the
    // calls return (each builds or finds its pipelines before its clock starts).
    let mut best = [f64::INFINITY; 4];
    let start = Instant::now();
    for round in 0..5 {
        let mut take = |k: usize, t: Duration| {
            best[k] = best[k].min(t.as_secs_f64());
        };
        take(0, g.time_grid(table, level)?.elapsed);
        take(1, g.time_ceiling(samples, CeilingShape::PerSample)?.elapsed);
        take(2, g.time_ceiling(samples, CeilingShape::Quads)?.elapsed);
        if let Some(b) = &bound_pipes {
            if let Some(t) = g.time_loop_bound(b, table, level)? {
                take(3, t.elapsed);
            }
        }
        if round >= 1 && start.elapsed() >= 2 * min {
            break;
        }
    }
    let [dispatch, ceiling_per_sample, ceiling_quads, loop_bound] = best;
    let readback = best_time(Duration::ZERO, || {
        g.evaluate(table, &Pattern::Grid { level }, &mut |c| {
            std::hint::black_box(c.positions.last());
            Ok(())
        })?;
        Ok(())
    })?;
    let mut encoded: Vec<u8> = Vec::new();
    let mut to_sink = |g: &GpuEvaluator| {
        best_time(Duration::ZERO, || {
            g.evaluate_f32(table, &Pattern::Grid { level }, &mut |c| {
                encode_samples(c.positions, c.normals, &mut encoded);
                std::io::Write::write_all(&mut std::io::sink(), &encoded)
                    .map_err(|e| crate::Error::Invalid(e.to_string()))
            })?;
            Ok(())
        })
    };
    g.double_buffer = false;
    let sink_single_buffer = to_sink(g)?;
    g.double_buffer = true;
    let sink_double_buffer = to_sink(g)?;
    Ok(GpuTimes {
        dispatch,
        readback,
        ceiling_per_sample,
        ceiling_quads,
        sink_double_buffer,
        sink_single_buffer,
        loop_bound,
    })
}

/// What a binary writer does with a chunk: each sample's f32 position and normal
/// interleaved into `out` (24 bytes a sample, the buffer reused).
fn encode_samples(positions: &[[f32; 3]], normals: &[[f32; 3]], out: &mut Vec<u8>) {
    out.clear();
    out.reserve(positions.len() * 24);
    for (p, n) in positions.iter().zip(normals) {
        out.extend_from_slice(bytemuck::cast_slice(p));
        out.extend_from_slice(bytemuck::cast_slice(n));
    }
}

/// The report as a Markdown table (what BENCHMARKS.md records).
pub fn to_text(r: &BenchReport) -> String {
    let m = &r.machine;
    let mut s = format!(
        "machine: {} · {} threads · {} · CPU kernel {}, {} samples per chunk\n\
         gpu: {}{}\n\
         memory write bandwidth ({} MiB buffer): {:.2} GB/s all threads, {:.2} GB/s 1 thread → roofline {:.1} M samples/s at 24 B/sample\n\n\
         | mesh | scheme | level | samples | build ms | CPU f32 1 thr M/s (roof) | CPU f32 all M/s (roof) | CPU f32 all, whole output M/s (roof) | CPU f64 ref all M/s | GPU dispatch M/s (roof) | GPU +readback M/s (roof) | GPU → f32 sink M/s (1 buffer) | GPU ceiling M/s (per sample) | dispatch ÷ ceiling (per sample) | loop bound M/s (÷ ceiling) | dispatch ÷ CPU f32 all |\n\
         |---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
        m.cpu,
        m.threads,
        m.os,
        m.cpu_kernel,
        m.cpu_chunk_samples,
        m.gpu.clone().unwrap_or_else(|| "none".into()),
        match (&m.gpu_note, &m.gpu_limits) {
            (Some(n), _) => format!(" ({n})"),
            (None, Some(l)) => format!(" ({}; {l})", m.gpu_precision),
            (None, None) => format!(" ({})", m.gpu_precision),
        },
        m.bandwidth_buffer_mib,
        m.write_bandwidth_gbs,
        m.write_bandwidth_1_thread_gbs,
        m.roofline_samples_per_s / 1e6,
    );
    let percent = |x: Option<f64>| x.map_or("–".to_string(), |f| format!("{:.0}%", 100.0 * f));
    let cell = |r: Option<&Rate>| match r {
        Some(r) => format!(
            "{:.1} ({:.0}%)",
            r.samples_per_s / 1e6,
            100.0 * r.roofline_fraction
        ),
        None => "–".into(),
    };
    for row in &r.rows {
        s += &format!(
            "| {} | {} | {} | {} | {:.1} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |\n",
            row.mesh,
            row.scheme,
            row.level,
            row.samples,
            row.build_s * 1e3,
            cell(Some(&row.cpu_f32_1_thread)),
            cell(Some(&row.cpu_f32_all_threads)),
            cell(Some(&row.cpu_f32_all_threads_whole_output)),
            row.cpu_f64_reference_all_threads
                .map(|r| format!("{:.1}", r.samples_per_s / 1e6))
                .unwrap_or_else(|| "–".into()),
            cell(row.gpu_dispatch_only.as_ref()),
            cell(row.gpu_with_readback.as_ref()),
            match (row.gpu_to_f32_sink, row.gpu_to_f32_sink_single_buffer) {
                (Some(d), Some(o)) => format!(
                    "{:.1} ({:.1})",
                    d.samples_per_s / 1e6,
                    o.samples_per_s / 1e6
                ),
                _ => "–".into(),
            },
            match (row.gpu_ceiling, row.gpu_ceiling_per_sample) {
                (Some(c), Some(c1)) => format!(
                    "{:.1} ({:.1})",
                    c.samples_per_s / 1e6,
                    c1.samples_per_s / 1e6
                ),
                _ => "–".into(),
            },
            match (
                row.gpu_ceiling_fraction,
                row.gpu_ceiling_per_sample_fraction
            ) {
                (Some(_), Some(_)) => format!(
                    "{} ({})",
                    percent(row.gpu_ceiling_fraction),
                    percent(row.gpu_ceiling_per_sample_fraction)
                ),
                _ => "–".into(),
            },
            match row.gpu_loop_bound {
                Some(b) => format!(
                    "{:.1} ({})",
                    b.samples_per_s / 1e6,
                    percent(row.gpu_loop_bound_fraction)
                ),
                None => "–".into(),
            },
            percent(row.gpu_cpu_f32_fraction),
        );
    }
    s
}

// ---- GPU check ----

/// One row of `bench --gpu-check`.
#[derive(Clone, Debug, Serialize)]
pub struct GpuCheckRow {
    /// "device_resident", "readback_f32", "tessellator_frame", "statistics".
    pub step: String,
    pub what: String,
    pub level: Option<u32>,
    pub samples: u64,
    pub seconds: f64,
    pub samples_per_s: f64,
    /// Bytes the device moves per sample: the output it writes (evaluation rows), the two
    /// evaluation points it reads (statistics).
    pub bytes_per_sample: u64,
    /// samples_per_s × bytes_per_sample / 10^9.
    pub gb_per_s: f64,
    /// gb_per_s ÷ the device's copy bandwidth (bytes read + written per second).
    pub bandwidth_fraction: f64,
}

#[derive(Clone, Debug, Serialize)]
pub struct GpuCheckReport {
    pub gpu: String,
    pub gpu_limits: String,
    pub precision: String,
    /// Device memory bandwidth: a buffer copy on the device, bytes read + written per
    /// second, 10^9 bytes (best of 5 copies of `copy_mib`).
    pub copy_bandwidth_gbs: f64,
    pub copy_mib: u64,
    pub mesh: String,
    pub triangles: usize,
    pub scheme: String,
    pub rows: Vec<GpuCheckRow>,
}

/// Bytes read + written per second (10^9) of a device-side copy between two buffers of
/// `bytes` (best of 5, the first copy untimed), and the size used.
fn copy_bandwidth(ctx: &GpuContext, bytes: u64) -> anyhow::Result<(f64, u64)> {
    let bytes = bytes.min(ctx.max_binding_bytes()).max(1 << 20) / 4 * 4;
    let make = |label, usage| {
        ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: bytes,
            usage,
            mapped_at_creation: false,
        })
    };
    use wgpu::BufferUsages as U;
    let src = make("copy source", U::COPY_SRC | U::COPY_DST);
    let dst = make("copy destination", U::COPY_DST);
    // Touch both buffers first (drivers may allocate on first use).
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    enc.clear_buffer(&src, 0, None);
    enc.clear_buffer(&dst, 0, None);
    ctx.queue.submit([enc.finish()]);
    ctx.wait()?;
    let mut best = f64::INFINITY;
    for rep in 0..6 {
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        enc.copy_buffer_to_buffer(&src, 0, &dst, 0, bytes);
        let t = Instant::now();
        ctx.queue.submit([enc.finish()]);
        ctx.wait()?;
        if rep > 0 {
            best = best.min(t.elapsed().as_secs_f64());
        }
    }
    ctx.check()?;
    Ok((2.0 * bytes as f64 / best / 1e9, bytes))
}

/// `bench --gpu-check`: see [`BenchArgs::gpu_check`].
pub fn run_gpu_check(a: &BenchArgs) -> anyhow::Result<()> {
    anyhow::ensure!(
        a.levels.iter().all(|&l| l >= 1),
        "--levels must be at least 1"
    );
    let ctx = crate::cli::common::shared_gpu()?;
    let mut gpu = GpuEvaluator::new(ctx.clone(), a.precision)?;
    gpu.shader_runtime_checks = a.gpu_runtime_checks;
    gpu.patch_loop &= !a.gpu_thread_per_sample;
    if !a.quiet {
        out::stderr_line(&format!("gpu: {}", ctx.describe()));
    }
    let spec = a.meshes.first().map_or(DEFAULT_MESH, |m| m.as_str());
    let scheme = a.schemes.first().copied().unwrap_or(Scheme::G1);
    let mesh = load_mesh(spec)?;
    let table = PatchTable::build(&mesh, scheme, &SchemeOptions::default())?;
    let copy_bytes = (a.bandwidth_mib.max(1) as u64) << 20;
    let (bw, copy_used) = copy_bandwidth(&ctx, copy_bytes)?;
    let out_bytes = (OUT_BYTES_PER_SAMPLE * a.precision.bytes()) as u64;
    let mut rows = Vec::new();
    let mut row = |step: &str, what: String, level, samples: u64, seconds: f64, bps: u64| {
        let rate = samples as f64 / seconds;
        let gb = rate * bps as f64 / 1e9;
        rows.push(GpuCheckRow {
            step: step.into(),
            what,
            level,
            samples,
            seconds,
            samples_per_s: rate,
            bytes_per_sample: bps,
            gb_per_s: gb,
            bandwidth_fraction: gb / bw,
        });
    };
    let min = Duration::from_millis(500);
    // Pipelines built, driver warm.
    gpu.time_grid(&table, 1)?;
    // The device-resident tessellator as a wgpu host runs it each frame: built once, then
    // one encoder per frame (evaluation, weld and indices on the device), submitted and
    // waited for; nothing read back.
    let mut tess = crate::GpuTessellator::new(&ctx.device, &ctx.queue, &mesh, &table, a.precision)?;
    for &level in &a.levels {
        let samples = (grid_len(level) * table.len()) as u64;
        if !a.quiet {
            out::stderr_line(&format!("bench: level {level}, {samples} samples"));
        }
        let d = best_time(min, || {
            gpu.time_grid(&table, level)?;
            Ok(())
        })?;
        row(
            "device_resident",
            "uploads + dispatches into a device buffer, no readback".into(),
            Some(level),
            samples,
            d,
            out_bytes,
        );
        let r = best_time(Duration::ZERO, || {
            gpu.evaluate_f32(&table, &Pattern::Grid { level }, &mut |c| {
                std::hint::black_box(c.positions.last());
                Ok(())
            })?;
            Ok(())
        })?;
        row(
            "readback_f32",
            "evaluate_f32: double-buffered readback, samples handed to a sink".into(),
            Some(level),
            samples,
            r,
            out_bytes,
        );
        if let Err(e) = tess.check_level(level) {
            if !a.quiet {
                out::stderr_line(&format!(
                    "bench: no tessellator_frame row at level {level}: {e}"
                ));
            }
        } else {
            let mut frame = || -> anyhow::Result<crate::gpu::tessellator::TessCounts> {
                let mut encoder = ctx.device.create_command_encoder(&Default::default());
                let counts = tess.tessellate(&ctx.device, &ctx.queue, &mut encoder, level)?;
                ctx.queue.submit([encoder.finish()]);
                ctx.wait()?;
                Ok(counts)
            };
            let counts = frame()?; // buffers grown to this level
            let f = best_time(min, || frame().map(|_| ()))?;
            ctx.check()?;
            let vertices = counts.vertices as u64;
            let bytes =
                vertices * crate::gpu::tessellator::VERTEX_BYTES + 4 * counts.indices as u64;
            row(
                "tessellator_frame",
                "GpuTessellator::tessellate: one frame's encoder (vertices, welded indices) \
                 submitted and waited for, buffers kept; samples are vertices, bytes the \
                 vertex and index bytes written per vertex (rounded)"
                    .into(),
                Some(level),
                vertices,
                f,
                bytes.div_ceil(vertices.max(1)),
            );
        }
    }
    // The tessellator's buffers (1.7 GB at the bunny's level 32) are not needed again.
    drop(tess);
    let f64_stats = ctx.supports_f64();
    let stats_gpu = GpuEvaluator::new(
        ctx.clone(),
        if f64_stats {
            Precision::F64
        } else {
            Precision::F32
        },
    )?;
    let mut pairs = 0u64;
    let adjacency = mesh.adjacency();
    // Once untimed: the statistics pipelines built, the driver's shader cache warm (a first
    // run on a fresh NVIDIA machine took 0.94 s against 0.10 s).
    crate::gpu::stats::gpu_continuity(&stats_gpu, &mesh, &adjacency, &table)?;
    let s = best_time(Duration::ZERO, || {
        let c = crate::gpu::stats::gpu_continuity(&stats_gpu, &mesh, &adjacency, &table)?;
        pairs = (c.samples + c.crease_samples) as u64;
        Ok(())
    })?;
    // Each edge sample reads its two evaluation points (barycentrics and patch index).
    let point_bytes = 4 * stats_gpu.precision().bytes() as u64;
    row(
        "statistics",
        format!(
            "stats --backend gpu ({}): edge samples evaluated and reduced on the device, one record per 64 samples read back; samples are edge sample pairs, bytes the two points read",
            stats_gpu.precision()
        ),
        None,
        pairs,
        s,
        2 * point_bytes,
    );
    let report = GpuCheckReport {
        gpu: ctx.describe(),
        gpu_limits: ctx.limits_summary(),
        precision: a.precision.to_string(),
        copy_bandwidth_gbs: bw,
        copy_mib: copy_used >> 20,
        mesh: mesh.name.clone(),
        triangles: table.len(),
        scheme: scheme.to_string(),
        rows,
    };
    if a.json {
        out::stdout_json(&serde_json::to_string(&report)?)?;
    } else {
        let mut report = report;
        report.mesh = out::escape(&report.mesh).into_owned();
        out::stdout_line(&gpu_check_text(&report))?;
    }
    Ok(())
}

/// Reals a sample writes: position and normal.
const OUT_BYTES_PER_SAMPLE: usize = 6;

/// The GPU check as text (what BENCHMARKS.md records).
pub fn gpu_check_text(r: &GpuCheckReport) -> String {
    let mut s = format!(
        "gpu: {} ({}; {})\n\
         device copy bandwidth ({} MiB buffer): {:.1} GB/s (read + write)\n\
         mesh: {} ({} triangles), scheme {}\n\n\
         | step | level | samples | seconds | M samples/s | GB/s | × copy bandwidth | what |\n\
         |---|---|---|---|---|---|---|---|\n",
        r.gpu,
        r.precision,
        r.gpu_limits,
        r.copy_mib,
        r.copy_bandwidth_gbs,
        r.mesh,
        r.triangles,
        r.scheme
    );
    for row in &r.rows {
        s += &format!(
            "| {} | {} | {} | {:.4} | {:.1} | {:.2} | {:.1}% | {} |\n",
            row.step,
            row.level.map_or("–".into(), |l| l.to_string()),
            row.samples,
            row.seconds,
            row.samples_per_s / 1e6,
            row.gb_per_s,
            100.0 * row.bandwidth_fraction,
            row.what
        );
    }
    s
}
