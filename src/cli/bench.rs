//! `g1tess bench`: throughput of every evaluator on dense grids, against the machine's
//! memory write bandwidth measured in the same run.
//!
//! For each mesh, scheme and level: the patch-table build time, and samples per second of
//! the CPU f32 fast path (1 thread and all threads, streamed in chunks; and all threads
//! into one pre-faulted array of the whole output), the f64 CPU reference (all threads),
//! the GPU without readback (uploads + dispatches) and with readback (results in host
//! memory as f64, chunk by chunk). Each throughput is also given as a fraction of the
//! write roofline: bandwidth / 24 bytes (an f32 position and normal per sample).

use std::io::IsTerminal;
use std::time::{Duration, Instant};

use anyhow::Context;
use clap::Args;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use rayon::prelude::*;
use serde::Serialize;

use crate::eval::cpu::{CpuEvaluator, F32Kernel, GridWeightsF32};
use crate::eval::gpu::GpuEvaluator;
use crate::eval::{grid_len, Evaluator, Pattern};
use crate::gpu::{GpuContext, Precision};
use crate::mesh::{LoadOptions, Mesh};
use crate::patch::{PatchTable, Scheme, SchemeOptions};

/// Bytes one sample writes: f32 position + f32 normal.
pub const SAMPLE_BYTES: f64 = 24.0;

/// The default mesh, relative to the crate root (where `cargo run` runs).
const DEFAULT_MESH: &str = "tests/data/stanford-bunny.obj";

#[derive(Args, Clone, Debug)]
pub struct BenchArgs {
    /// Meshes (OBJ files or built-ins); default tests/data/stanford-bunny.obj.
    pub meshes: Vec<String>,
    /// Grid levels.
    #[arg(long, value_delimiter = ',', default_values_t = [8u32, 16, 32])]
    pub levels: Vec<u32>,
    /// Schemes (default: all).
    #[arg(long, value_enum, value_delimiter = ',')]
    pub schemes: Vec<Scheme>,
    /// GPU working precision.
    #[arg(long, value_enum, default_value = "f32")]
    pub precision: Precision,
    /// Samples per chunk of the CPU evaluators (a chunk's output is one reused buffer: one
    /// that fits in the last-level cache is never written back to memory).
    #[arg(long, default_value_t = 1 << 20)]
    pub cpu_chunk_samples: usize,
    /// Skip the GPU even when an adapter is present.
    #[arg(long)]
    pub no_gpu: bool,
    /// Skip the f64 CPU reference (the slowest measurement).
    #[arg(long)]
    pub no_reference: bool,
    /// Size of the buffer the write bandwidth is measured on, MiB (well above the last-level
    /// cache for a memory figure).
    #[arg(long, default_value_t = 1024)]
    pub bandwidth_mib: usize,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
    /// No progress bar.
    #[arg(long, short)]
    pub quiet: bool,
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
    let show = !a.quiet && std::io::stderr().is_terminal();
    let steps = (meshes.len() * schemes.len() * a.levels.len()) as u64;
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

    bar.set_message("memory write bandwidth");
    let (bw, bw1) = write_bandwidth(a.bandwidth_mib)?;
    let roofline = bw * 1e9 / SAMPLE_BYTES;

    let (gpu, gpu_note) = if a.no_gpu {
        (None, Some("--no-gpu".to_string()))
    } else {
        match GpuContext::shared().and_then(|c| GpuEvaluator::new(c, a.precision)) {
            Ok(g) => (Some(g), None),
            Err(e) => (None, Some(e.to_string())),
        }
    };
    if let Some(note) = &gpu_note {
        bar.suspend(|| eprintln!("note: no GPU figures: {note}"));
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

    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
    let cpu = CpuEvaluator::with_chunk_samples(a.cpu_chunk_samples.max(1));
    let min = Duration::from_millis(500);
    let mut rows = Vec::new();
    for spec in &meshes {
        let mesh = load_mesh(spec)?;
        for &scheme in &schemes {
            let opts = SchemeOptions::default();
            let mut table = None;
            let mut build_s = f64::INFINITY;
            for _ in 0..3 {
                let t = Instant::now();
                table = Some(PatchTable::build(&mesh, scheme, &opts)?);
                build_s = build_s.min(t.elapsed().as_secs_f64());
            }
            let table = table.expect("built three times");
            for &level in &a.levels {
                bar.set_message(format!("{} {scheme} level {level}", mesh.name));
                let samples = grid_len(level) * table.len();
                let rate = |seconds: f64| Rate {
                    seconds,
                    samples_per_s: samples as f64 / seconds,
                    roofline_fraction: samples as f64 / seconds / roofline,
                };
                let weights = GridWeightsF32::new(table.kind, level);
                let fast = || {
                    cpu.grid_f32(&table, &weights, &mut |c| {
                        std::hint::black_box(c.positions.last());
                        Ok(())
                    })
                    .map_err(anyhow::Error::from)
                };
                let cpu1 = best_time(min, || one.install(fast))?;
                let cpu_all = best_time(min, fast)?;
                let whole = {
                    let mut pos = vec![[0f32; 3]; samples];
                    let mut nrm = vec![[0f32; 3]; samples];
                    let mut run = || {
                        cpu.grid_f32_into(&table, &weights, &mut pos, &mut nrm)
                            .map_err(anyhow::Error::from)
                    };
                    run()?; // first touch of every page, untimed
                    best_time(min, run)?
                };
                let reference = if a.no_reference {
                    None
                } else {
                    Some(rate(best_time(Duration::ZERO, || {
                        cpu.evaluate(&table, &Pattern::Grid { level }, &mut |c| {
                            std::hint::black_box(c.positions.last());
                            Ok(())
                        })?;
                        Ok(())
                    })?))
                };
                let (dispatch, readback) = match &gpu {
                    Some(g) => {
                        // The first run builds the pipelines and warms the driver.
                        g.time_grid(&table, 1)?;
                        let d = best_time(Duration::ZERO, || {
                            g.time_grid(&table, level)?;
                            Ok(())
                        })?;
                        let r = best_time(Duration::ZERO, || {
                            g.evaluate(&table, &Pattern::Grid { level }, &mut |c| {
                                std::hint::black_box(c.positions.last());
                                Ok(())
                            })?;
                            Ok(())
                        })?;
                        (Some(rate(d)), Some(rate(r)))
                    }
                    None => (None, None),
                };
                rows.push(Row {
                    mesh: mesh.name.clone(),
                    scheme: scheme.to_string(),
                    triangles: table.len(),
                    level,
                    samples,
                    build_s,
                    cpu_f32_1_thread: rate(cpu1),
                    cpu_f32_all_threads: rate(cpu_all),
                    cpu_f32_all_threads_whole_output: rate(whole),
                    cpu_f64_reference_all_threads: reference,
                    gpu_dispatch_only: dispatch,
                    gpu_with_readback: readback,
                });
                bar.inc(1);
            }
        }
    }
    bar.finish_and_clear();
    let report = BenchReport { machine, rows };
    if a.json {
        println!("{}", serde_json::to_string(&report)?);
    } else {
        println!("{}", to_text(&report));
    }
    Ok(())
}

/// The report as a Markdown table (what BENCHMARKS.md records).
pub fn to_text(r: &BenchReport) -> String {
    let m = &r.machine;
    let mut s = format!(
        "machine: {} · {} threads · {} · CPU kernel {}, {} samples per chunk\n\
         gpu: {}{}\n\
         memory write bandwidth ({} MiB buffer): {:.2} GB/s all threads, {:.2} GB/s 1 thread → roofline {:.1} M samples/s at 24 B/sample\n\n\
         | mesh | scheme | level | samples | build ms | CPU f32 1 thr M/s (roof) | CPU f32 all M/s (roof) | CPU f32 all, whole output M/s (roof) | CPU f64 ref all M/s | GPU dispatch M/s (roof) | GPU +readback M/s (roof) |\n\
         |---|---|---|---|---|---|---|---|---|---|---|\n",
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
            "| {} | {} | {} | {} | {:.1} | {} | {} | {} | {} | {} | {} |\n",
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
        );
    }
    s
}
