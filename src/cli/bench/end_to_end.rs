//! `g1tess bench --end-to-end`: the commands a user runs, timed in one process, each
//! beside a same-run baseline (see [`run_end_to_end`]).

use std::time::Instant;

use serde::Serialize;

use super::{cpu_model, load_mesh, BenchArgs, DEFAULT_MESH};
use crate::analysis::stats::stats_report;
use crate::cli::common::tessellation_need;
use crate::cli::TEMP_FILES;
use crate::eval::cpu::{CpuEvaluator, F32Kernel};
use crate::eval::grid_len;
use crate::io::writers::{ply_file_bytes, write_stitched, MeshFormat};
use crate::mesh::{Adjacency, LoadOptions, Mesh};
use crate::patch::{PatchBuilder, Scheme, SchemeOptions};
use crate::progress::NoProgress;
use crate::tess::stitch::{stitch_certified, CountingSink, Needs, StitchPlan};

/// One end-to-end measurement.
#[derive(Clone, Debug, Serialize)]
pub struct EndToEndRow {
    /// What was timed: "tessellate_setup", "tessellate_eval", "tessellate_setup_eval"
    /// (once per level of `--memory-levels`), "tessellate_memory", "tessellate_ply_file",
    /// "plain_write", "piped_write", "load_obj", "count_words", "wc_w", "stats".
    pub step: String,
    /// Grid level of a tessellation row (none for the others).
    pub level: Option<u32>,
    /// How, in words.
    pub what: String,
    pub seconds: f64,
    /// CPU seconds of this process during the step (all threads; none for `wc_w`, another
    /// process).
    pub cpu_seconds: Option<f64>,
    /// Samples produced or consumed (tessellation grid samples, stats edge samples).
    pub samples: Option<u64>,
    pub samples_per_s: Option<f64>,
    /// Bytes written or read.
    pub bytes: Option<u64>,
    /// bytes / seconds / 10^6.
    pub mb_per_s: Option<f64>,
    /// seconds / the baseline's seconds (tessellate_ply_file and piped_write: plain_write;
    /// load_obj: count_words).
    pub ratio_to_baseline: Option<f64>,
}

#[derive(Clone, Debug, Serialize)]
pub struct EndToEndMachine {
    pub cpu: String,
    /// CPUs the process may use.
    pub cpus: usize,
    pub threads: usize,
    pub os: String,
    pub cpu_kernel: String,
    /// Folder of the temporary files.
    pub dir: String,
}

#[derive(Clone, Debug, Serialize)]
pub struct EndToEndReport {
    pub machine: EndToEndMachine,
    pub mesh: String,
    pub triangles: usize,
    pub scheme: String,
    pub tess_level: u32,
    /// Levels of the rows with set-up and evaluation apart.
    pub memory_levels: Vec<u32>,
    pub stats_level: u32,
    /// Triangles of the mesh given to stats and loaded from OBJ.
    pub stats_triangles: usize,
    pub rows: Vec<EndToEndRow>,
}

/// A temporary file of the end-to-end run: created new (`O_EXCL`, never through a link
/// planted at its name) under an unpredictable name, listed in [`TEMP_FILES`] (so that
/// SIGINT and SIGTERM remove it), removed when dropped. The writes through the output
/// path replace it by renaming onto it.
struct TempFile(std::path::PathBuf);

impl Drop for TempFile {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.0);
        TEMP_FILES.unlist(&self.0);
    }
}

/// A plain sequential write of `bytes` bytes into `f` (1 MiB blocks through one buffer,
/// then fsync, as the writers do): the baseline of writing a file of that size here.
fn plain_write(mut f: std::fs::File, bytes: u64) -> anyhow::Result<()> {
    use std::io::Write;
    let block = vec![0x5au8; 1 << 20];
    let mut left = bytes;
    while left > 0 {
        let n = left.min(block.len() as u64) as usize;
        f.write_all(&block[..n])?;
        left -= n as u64;
    }
    f.sync_all()?;
    Ok(())
}

/// `bytes` bytes written as the mesh writers write them ([`write_atomic_piped`]: a writer
/// thread, direct I/O where the file system suits it, temporary file, fsync, rename), in
/// 1 MiB pieces of one buffer: what `tessellate_ply_file` would take if computing and
/// encoding cost nothing.
fn piped_write(path: &std::path::Path, bytes: u64) -> anyhow::Result<()> {
    use std::io::Write;
    let block = vec![0x5au8; 1 << 20];
    crate::io::atomic::write_atomic_piped(path, &TEMP_FILES, |w| {
        let mut left = bytes;
        while left > 0 {
            let n = left.min(block.len() as u64) as usize;
            w.write_all(&block[..n])
                .map_err(|e| crate::Error::io(path, e))?;
            left -= n as u64;
        }
        Ok(())
    })?;
    Ok(())
}

/// Whitespace-separated words of a file, read through a 1 MiB buffer (what `wc -w` does).
fn count_words(path: &std::path::Path) -> anyhow::Result<u64> {
    use std::io::Read;
    let mut f = std::fs::File::open(path)?;
    let mut buf = vec![0u8; 1 << 20];
    let (mut words, mut in_word) = (0u64, false);
    loop {
        let n = f.read(&mut buf)?;
        if n == 0 {
            return Ok(words);
        }
        for &b in &buf[..n] {
            let space = matches!(b, b' ' | b'\n' | b'\t' | b'\r' | 0x0b | 0x0c);
            words += (!space && !in_word) as u64;
            in_word = !space;
        }
    }
}

/// Runs the real `wc -w` on `path`: (seconds, words), or None where there is no `wc`.
fn real_wc(path: &std::path::Path) -> Option<(f64, u64)> {
    let t = Instant::now();
    let out = std::process::Command::new("wc")
        .arg("-w")
        .arg(path)
        .output()
        .ok()?;
    let s = t.elapsed().as_secs_f64();
    let words = String::from_utf8_lossy(&out.stdout)
        .split_whitespace()
        .next()?
        .parse()
        .ok()?;
    out.status.success().then_some((s, words))
}

fn available_cpus() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// CPU time of this process so far (all threads, user + system), from `/proc/self/stat`
/// in clock ticks of 1/100 s; None where there is no such file.
fn process_cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the command name (which is in parentheses and may hold spaces).
    let rest = stat.get(stat.rfind(')')? + 2..)?;
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks = f.get(11)?.parse::<u64>().ok()? + f.get(12)?.parse::<u64>().ok()?;
    Some(ticks as f64 / 100.0)
}

/// Wall and CPU seconds of one run of `f`.
fn timed(f: impl FnOnce() -> anyhow::Result<()>) -> anyhow::Result<(f64, Option<f64>)> {
    let c0 = process_cpu_seconds();
    let t = Instant::now();
    f()?;
    let wall = t.elapsed().as_secs_f64();
    let cpu = process_cpu_seconds().zip(c0).map(|(b, a)| b - a);
    Ok((wall, cpu))
}

/// The faster of `runs` runs of `f` (wall time), with its CPU time.
fn best_of(
    runs: usize,
    mut f: impl FnMut() -> anyhow::Result<()>,
) -> anyhow::Result<(f64, Option<f64>)> {
    let mut best = (f64::INFINITY, None);
    for _ in 0..runs.max(1) {
        let r = timed(&mut f)?;
        if r.0 < best.0 {
            best = r;
        }
    }
    Ok(best)
}

/// `bench --end-to-end`: the commands a user runs, timed in one process on the first mesh
/// (default the bunny) with the first scheme (default G1), CPU backend:
/// - at each of `--memory-levels` (4, 8, 16): `tessellate_setup`, what `tessellate`
///   builds before it evaluates (adjacency, stitch plan; once), `tessellate_eval`, the
///   evaluation into memory as `tessellate` runs it (per chunk: the patches built and their
///   certificate's first stage, the f32 grid kernel, the stitcher in f32; then the
///   certificate's subdivisions for its fold warning; into a sink that keeps nothing; best
///   of 2), and `tessellate_setup_eval`, their sum;
/// - `tessellate_memory`: the evaluation into memory at `--tess-level` (best of 2; the
///   `tessellate_eval` measurement where that level is one of `--memory-levels`);
/// - `tessellate_ply_file`: the same into a binary PLY file (atomic write, fsync), beside
///   `plain_write` of the same byte count and `piped_write` (the same bytes through the
///   writers' own output path, nothing computed); the three alternate, plain first, best of
///   2 each;
/// - `load_obj`: `Mesh::load` of the mesh tessellated at `--stats-level` and written as
///   OBJ (f32 values), beside `count_words` (a buffered `wc -w` in Rust) and the real
///   `wc -w` where present (best of 2 each, the file in the page cache for all);
/// - `stats`: adjacency, patch table and the continuity statistics of that mesh, after
///   loading.
///
/// Each row also gives the CPU seconds of the process during the step, which tell a
/// loaded machine's figures from an idle one's.
pub fn run_end_to_end(a: &BenchArgs) -> anyhow::Result<()> {
    anyhow::ensure!(
        a.tess_level >= 1 && a.stats_level >= 1,
        "--tess-level and --stats-level must be at least 1"
    );
    let spec = a.meshes.first().map_or(DEFAULT_MESH, |m| m.as_str());
    let scheme = a.schemes.first().copied().unwrap_or(Scheme::G1);
    let temp = TempNames {
        dir: a.dir.clone().unwrap_or_else(std::env::temp_dir),
    };
    let say = |what: &str| {
        if !a.quiet {
            crate::cli::out::stderr_line(&format!("bench: {what}"));
        }
    };
    let cpu = CpuEvaluator::with_chunk_samples(a.cpu_chunk_samples.max(1));
    let mut rows = EndToEndRows::default();

    let budget = a.memory.budget();
    let mesh = load_mesh(spec)?;
    let levels = time_memory_levels(&mesh, scheme, &cpu, &budget, &a.memory_levels, &say)?;
    rows.0.extend(levels.rows);
    let adjacency = match levels.adjacency {
        Some(adjacency) => adjacency,
        None => mesh.adjacency(),
    };
    let builder = PatchBuilder::new(&mesh, scheme, &SchemeOptions::default())?;
    let level = a.tess_level;
    let (need, _, _) = tessellation_need(
        &mesh,
        adjacency.edges.len(),
        builder.kind().stride(),
        level,
        MeshFormat::Ply.needs(),
        MeshFormat::Ply.buffer_bytes(level, mesh.triangles.len()),
    );
    budget.check("bench", &format!("--tess-level {level}"), need, "")?;
    let plan = StitchPlan::new(&mesh, &adjacency, level)?;
    let samples = (grid_len(level) * mesh.triangles.len()) as u64;

    // The evaluation of this level, where a row of `--memory-levels` measured it.
    let measured = levels.evals.iter().find(|e| e.0 == level).map(|e| e.1);
    let memory = match measured {
        Some(t) => t,
        None => {
            say(&format!(
                "tessellate {} level {level} into memory",
                mesh.name
            ));
            time_evaluation(&plan, &builder, &cpu)?
        }
    };
    rows.push(
        "tessellate_memory",
        format!(
            "patches built and certified per chunk, f32 kernel -> stitcher (f32) -> sink keeping nothing; {} positions, {} records{}",
            plan.positions,
            plan.records,
            if measured.is_some() {
                " (the measurement of row tessellate_eval of this level)"
            } else {
                ""
            }
        ),
        memory,
        Some(samples),
        None,
        None,
    )
    .level = Some(level);

    say("plain writes alternating with tessellations into a binary PLY file");
    let bytes = ply_file_bytes(&plan, "bench");
    let writes = time_file_writes(&plan, &builder, &cpu, &temp, bytes)?;
    rows.push(
        "tessellate_ply_file",
        "tessellate into binary PLY on disk (atomic: temporary file, fsync, rename); best of 2, alternating with plain_write and piped_write (plain, piped, PLY, plain, piped, PLY)".into(),
        writes.file,
        Some(samples),
        Some(bytes),
        Some(writes.plain.0),
    )
    .level = Some(level);
    rows.push(
        "plain_write",
        "the same byte count in 1 MiB blocks, fsync; best of 2, alternating with the others".into(),
        writes.plain,
        None,
        Some(bytes),
        None,
    );
    rows.push(
        "piped_write",
        "the same byte count through the writers' own output path (PipedWriter: direct I/O where the file system suits it, atomic), nothing computed: the floor of tessellate_ply_file; best of 2, alternating with the others".into(),
        writes.piped,
        None,
        Some(bytes),
        Some(writes.plain.0),
    );

    say(&format!("OBJ of {} at level {}", mesh.name, a.stats_level));
    let obj_plan = StitchPlan::new(&mesh, &adjacency, a.stats_level)?;
    let big = time_obj_loading(&obj_plan, &builder, &cpu, &temp, &say, &mut rows)?;

    say(&format!("stats on {} triangles", big.triangles.len()));
    let mut pairs = 0;
    let stats = timed(|| {
        // Exactly what `g1tess stats --backend cpu` runs after loading.
        let r = stats_report(&big, scheme, &SchemeOptions::default(), &cpu)?;
        pairs = (r.samples + r.crease_samples) as u64;
        Ok(())
    })?;
    rows.push(
        "stats",
        "`stats` after loading: edge index, patches built per chunk of edges, continuity (f64 CPU reference); samples are edge sample pairs".into(),
        stats,
        Some(pairs),
        None,
        None,
    );

    let report = EndToEndReport {
        machine: EndToEndMachine {
            cpu: cpu_model(),
            cpus: available_cpus(),
            threads: rayon::current_num_threads(),
            os: format!("{} {}", std::env::consts::OS, std::env::consts::ARCH),
            cpu_kernel: F32Kernel::Auto.name().to_string(),
            dir: temp.dir.display().to_string(),
        },
        mesh: mesh.name.clone(),
        triangles: mesh.triangles.len(),
        scheme: scheme.to_string(),
        tess_level: level,
        memory_levels: a.memory_levels.clone(),
        stats_level: a.stats_level,
        stats_triangles: big.triangles.len(),
        rows: rows.0,
    };
    if a.json {
        crate::cli::out::stdout_json(&serde_json::to_string(&report)?)?;
    } else {
        crate::cli::out::stdout_line(&end_to_end_text(&report))?;
    }
    Ok(())
}

/// Wall and CPU seconds of a step (see [`timed`]).
type WallCpu = (f64, Option<f64>);

/// The best of 2 evaluations of `plan` into memory as `tessellate` runs them
/// ([`stitch_certified`] into a sink that keeps nothing, [`CountingSink`]).
fn time_evaluation(
    plan: &StitchPlan,
    builder: &PatchBuilder<'_>,
    cpu: &CpuEvaluator,
) -> anyhow::Result<WallCpu> {
    best_of(2, || {
        let mut sink = CountingSink::default();
        std::hint::black_box(stitch_certified(
            plan,
            builder,
            cpu,
            &mut sink,
            &NoProgress,
        )?);
        anyhow::ensure!(sink.records == plan.records, "stitching lost records");
        Ok(())
    })
}

/// What `tessellate` builds before it evaluates a uniform level on the CPU: the adjacency,
/// the scheme's builder (G1 checks its options; nothing per patch) and, after the memory
/// check, the stitch plan of `level`; with the seconds of the adjacency and of the plan.
/// The patches are built and certified in the evaluation ([`stitch_certified`]).
struct SetUp<'m> {
    builder: PatchBuilder<'m>,
    adjacency: Adjacency,
    plan: StitchPlan,
    parts: [f64; 2],
}

impl<'m> SetUp<'m> {
    fn build(
        mesh: &'m Mesh,
        scheme: Scheme,
        level: u32,
        budget: &crate::cli::common::Budget,
    ) -> anyhow::Result<SetUp<'m>> {
        let t = Instant::now();
        let adjacency = mesh.adjacency();
        let t_adjacency = t.elapsed().as_secs_f64();
        let builder = PatchBuilder::new(mesh, scheme, &SchemeOptions::default())?;
        let (need, _, _) = tessellation_need(
            mesh,
            adjacency.edges.len(),
            builder.kind().stride(),
            level,
            Needs::RECORDS,
            (0, 0),
        );
        budget.check("bench", &format!("--memory-levels {level}"), need, "")?;
        let t = Instant::now();
        let plan = StitchPlan::new(mesh, &adjacency, level)?;
        let t_plan = t.elapsed().as_secs_f64();
        Ok(SetUp {
            builder,
            adjacency,
            plan,
            parts: [t_adjacency, t_plan],
        })
    }
}

/// The rows of [`time_memory_levels`], the evaluation time of each level, and the
/// adjacency of the last level's set-up (for the rows that follow).
struct MemoryLevels {
    rows: Vec<EndToEndRow>,
    evals: Vec<(u32, WallCpu)>,
    adjacency: Option<Adjacency>,
}

/// For each of `levels`, a tessellation of `mesh` into memory as `tessellate` runs it,
/// set-up and evaluation apart: `tessellate_setup` ([`SetUp`], once: a fresh run's
/// figure), `tessellate_eval` ([`time_evaluation`], best of 2) and `tessellate_setup_eval`
/// (the sum of the two), each with the level's grid samples.
fn time_memory_levels(
    mesh: &Mesh,
    scheme: Scheme,
    cpu: &CpuEvaluator,
    budget: &crate::cli::common::Budget,
    levels: &[u32],
    say: &dyn Fn(&str),
) -> anyhow::Result<MemoryLevels> {
    let mut out = MemoryLevels {
        rows: Vec::new(),
        evals: Vec::new(),
        adjacency: None,
    };
    let mut rows = EndToEndRows::default();
    for &level in levels {
        say(&format!(
            "tessellate {} level {level} into memory: set-up, evaluation",
            mesh.name
        ));
        let mut built = None;
        let setup = timed(|| {
            built = Some(SetUp::build(mesh, scheme, level, budget)?);
            Ok(())
        })?;
        let s = built.expect("built in the timed step");
        let eval = time_evaluation(&s.plan, &s.builder, cpu)?;
        let samples = Some((grid_len(level) * mesh.triangles.len()) as u64);
        let [adjacency, plan] = s.parts;
        rows.push(
            "tessellate_setup",
            format!(
                "adjacency {adjacency:.3} s, stitch plan {plan:.3} s; once (the patches are built and certified in tessellate_eval)"
            ),
            setup,
            samples,
            None,
            None,
        )
        .level = Some(level);
        rows.push(
            "tessellate_eval",
            format!(
                "per chunk: patches built (G1 construction included), their certificate's first stage, f32 kernel, stitcher (f32); then the certificate's subdivisions (the fold warning's count); sink keeping nothing; {} positions, {} records; best of 2",
                s.plan.positions, s.plan.records
            ),
            eval,
            samples,
            None,
            None,
        )
        .level = Some(level);
        let both = (setup.0 + eval.0, setup.1.zip(eval.1).map(|(a, b)| a + b));
        rows.push(
            "tessellate_setup_eval",
            "tessellate_setup + tessellate_eval: into memory from a loaded mesh".into(),
            both,
            samples,
            None,
            None,
        )
        .level = Some(level);
        out.evals.push((level, eval));
        out.adjacency = Some(s.adjacency);
    }
    out.rows = rows.0;
    Ok(out)
}

/// The rows of the end-to-end report, in the order measured.
#[derive(Default)]
struct EndToEndRows(Vec<EndToEndRow>);

impl EndToEndRows {
    /// Adds the row of `step`, its rates and its ratio to the `baseline`'s seconds.
    fn push(
        &mut self,
        step: &str,
        what: String,
        (seconds, cpu_seconds): WallCpu,
        samples: Option<u64>,
        bytes: Option<u64>,
        baseline: Option<f64>,
    ) -> &mut EndToEndRow {
        self.0.push(EndToEndRow {
            step: step.into(),
            level: None,
            what,
            seconds,
            cpu_seconds,
            samples,
            samples_per_s: samples.map(|n| n as f64 / seconds),
            bytes,
            mb_per_s: bytes.map(|b| b as f64 / seconds / 1e6),
            ratio_to_baseline: baseline.map(|b| seconds / b),
        });
        self.0.last_mut().expect("a row was pushed")
    }
}

/// Where the end-to-end run's temporary files go: `dir/g1tess-bench-RANDOM.extension`.
struct TempNames {
    dir: std::path::PathBuf,
}

impl TempNames {
    /// A new, empty temporary file of `extension` (see [`TempFile`]) and the file open for
    /// writing.
    fn file(&self, extension: &str) -> anyhow::Result<(TempFile, std::fs::File)> {
        let (path, file) = TEMP_FILES
            .create_listed(&self.dir, "g1tess-bench-", &format!(".{extension}"), None)
            .map_err(|e| crate::Error::io(&self.dir, e))?;
        Ok((TempFile(path), file))
    }
}

/// The best times of the three file writes of the end-to-end run.
struct FileWrites {
    /// The tessellation into a binary PLY file.
    file: WallCpu,
    /// [`plain_write`] of the PLY's byte count.
    plain: WallCpu,
    /// [`piped_write`] of the PLY's byte count.
    piped: WallCpu,
}

/// The plain write, the piped write and the PLY file of `plan` alternate (plain, piped,
/// PLY, plain, piped, PLY), best of 2 each: the first large write after other work pays
/// the page cache's reclaim, which a single ordered pair would charge to whichever went
/// first. Each file is removed after its timing. The plain write has the PLY's size,
/// `bytes`, known from the plan.
fn time_file_writes(
    plan: &StitchPlan,
    builder: &PatchBuilder<'_>,
    cpu: &CpuEvaluator,
    temp: &TempNames,
    bytes: u64,
) -> anyhow::Result<FileWrites> {
    let (mut file, mut plain) = ((f64::INFINITY, None), (f64::INFINITY, None));
    let mut piped = (f64::INFINITY, None);
    for _ in 0..2 {
        let (plain_file, f) = temp.file("plain")?;
        let t = timed(|| plain_write(f, bytes))?;
        drop(plain_file);
        if t.0 < plain.0 {
            plain = t;
        }
        let (piped_file, _) = temp.file("piped")?;
        let t = timed(|| piped_write(&piped_file.0, bytes))?;
        drop(piped_file);
        if t.0 < piped.0 {
            piped = t;
        }
        let (ply, _) = temp.file("ply")?;
        let t = timed(|| {
            write_stitched::<[f32; 3]>(
                &ply.0,
                &TEMP_FILES,
                MeshFormat::Ply,
                plan,
                "bench",
                &NoProgress,
                &mut |sink| stitch_certified(plan, builder, cpu, sink, &NoProgress).map(|_| ()),
            )?;
            Ok(())
        })?;
        let len = std::fs::metadata(&ply.0)?.len();
        drop(ply);
        anyhow::ensure!(
            len == bytes,
            "the PLY file has {len} bytes, the plan says {bytes}"
        );
        if t.0 < file.0 {
            file = t;
        }
    }
    Ok(FileWrites { file, plain, piped })
}

/// Writes the tessellation of `obj_plan` as an OBJ file and times loading it beside
/// counting its words (in Rust, and with the system's `wc -w` where present), adding the
/// rows `load_obj`, `count_words` and `wc_w`. Returns the loaded mesh.
fn time_obj_loading(
    obj_plan: &StitchPlan,
    builder: &PatchBuilder<'_>,
    cpu: &CpuEvaluator,
    temp: &TempNames,
    say: &dyn Fn(&str),
    rows: &mut EndToEndRows,
) -> anyhow::Result<Mesh> {
    let (obj, _) = temp.file("obj")?;
    write_stitched::<[f32; 3]>(
        &obj.0,
        &TEMP_FILES,
        MeshFormat::Obj,
        obj_plan,
        "bench",
        &NoProgress,
        &mut |sink| stitch_certified(obj_plan, builder, cpu, sink, &NoProgress).map(|_| ()),
    )?;
    let obj_bytes = std::fs::metadata(&obj.0)?.len();
    let mut words = 0;
    let count = best_of(2, || {
        words = count_words(&obj.0)?;
        Ok(())
    })?;
    // Best of 2, as the others.
    let wc = match (real_wc(&obj.0), real_wc(&obj.0)) {
        (Some(x), Some(y)) => Some((x.0.min(y.0), x.1)),
        (x, _) => x,
    };
    say("load the OBJ");
    let obj_spec = obj.0.display().to_string();
    let mut loaded = None;
    let load = best_of(2, || {
        loaded = Some(Mesh::load(&obj_spec, &LoadOptions::default())?);
        Ok(())
    })?;
    let big = loaded.expect("loaded at least once");
    drop(obj);
    rows.push(
        "load_obj",
        format!("Mesh::load of the OBJ ({} triangles)", big.triangles.len()),
        load,
        None,
        Some(obj_bytes),
        Some(count.0),
    );
    rows.push(
        "count_words",
        format!("whitespace-separated words, 1 MiB buffer ({words} words)"),
        count,
        None,
        Some(obj_bytes),
        None,
    );
    if let Some((s, w)) = wc {
        rows.push(
            "wc_w",
            format!("the system's wc -w ({w} words)"),
            (s, None),
            None,
            Some(obj_bytes),
            None,
        );
    }
    Ok(big)
}

/// The end-to-end report as a Markdown table (what BENCHMARKS.md records).
pub fn end_to_end_text(r: &EndToEndReport) -> String {
    let m = &r.machine;
    let mut s = format!(
        "machine: {} · {} CPUs, {} threads · {} · CPU kernel {} · files in {}\n\
         mesh: {} ({} triangles), scheme {}, tessellation level {} (into memory also at {}); stats and OBJ: level {} ({} triangles)\n\n\
         | step | level | seconds | CPU s | M samples/s | MB/s | × baseline | what |\n|---|---|---|---|---|---|---|---|\n",
        m.cpu,
        m.cpus,
        m.threads,
        m.os,
        m.cpu_kernel,
        m.dir,
        r.mesh,
        r.triangles,
        r.scheme,
        r.tess_level,
        r.memory_levels
            .iter()
            .map(|l| l.to_string())
            .collect::<Vec<_>>()
            .join(", "),
        r.stats_level,
        r.stats_triangles
    );
    let opt = |x: Option<f64>, scale: f64, digits: usize| {
        x.map_or("–".to_string(), |v| format!("{:.*}", digits, v / scale))
    };
    for row in &r.rows {
        s += &format!(
            "| {} | {} | {:.3} | {} | {} | {} | {} | {} |\n",
            row.step,
            row.level.map_or("–".to_string(), |l| l.to_string()),
            row.seconds,
            opt(row.cpu_seconds, 1.0, 2),
            opt(row.samples_per_s, 1e6, 1),
            opt(row.mb_per_s, 1.0, 0),
            opt(row.ratio_to_baseline, 1.0, 2),
            row.what
        );
    }
    s
}
