//! Arguments shared by every command that reads a mesh.

#[cfg(feature = "gpu")]
use crate::gpu::GpuContext;
use clap::Args;

use super::{out, progress};
#[cfg(feature = "gpu")]
use std::sync::{Arc, OnceLock};

use crate::analysis::fair::{fair_with_progress, FairOptions, FairReport};
use crate::mesh::{LoadOptions, Mesh, NormalWeighting};
use crate::patch::repair::{repair, repair_line, RepairOptions, RepairReport};
use crate::patch::{PatchTable, Scheme, SchemeOptions};

#[derive(Args, Clone, Debug)]
pub struct InputArgs {
    /// Mesh file (OBJ, PLY, STL, glTF .gltf/.glb, or .pn point-normal) or built-in mesh:
    /// sphere320, torus200, icosphere:L, torus:NxM[:analytic|:averaged].
    pub mesh: String,
    /// Surface scheme.
    #[arg(long, value_enum, default_value = "g1")]
    pub scheme: Scheme,
    /// Weighting of face normals where vertex normals are estimated.
    #[arg(long, value_enum, default_value = "angle")]
    pub normals: NormalWeighting,
    /// Estimate normals even where the file gives them.
    #[arg(long)]
    pub recompute_normals: bool,
    /// Mark edges whose dihedral angle exceeds DEG degrees as creases and estimate normals
    /// per smoothing group (replaces any normals the file gives). DEG is 0 to 180.
    #[arg(long, value_name = "DEG", allow_hyphen_values = true)]
    pub crease_angle: Option<f64>,
    /// Phong tessellation's shape factor α (--scheme phong; any finite number).
    #[arg(long, default_value_t = 0.75, allow_hyphen_values = true)]
    pub phong_alpha: f64,
    /// Change vertex normals as little as needed so that no patch folds (every patch
    /// certified valid); prints what changed.
    #[arg(long)]
    pub repair_folds: bool,
    /// Choose vertex normals and G1 tangent lengths that lower the bending energy, keeping
    /// the vertices, G1 on every smooth edge, every certified patch certified and every
    /// crease as it is (--scheme g1; method in docs/fair.md); prints what changed.
    #[arg(long, conflicts_with = "repair_folds")]
    pub fair: bool,
    /// With --fair: largest change, in degrees, of a normal given in the file (estimated
    /// normals are free). 0 to 180.
    #[arg(long, value_name = "DEG", default_value_t = 15.0)]
    pub normal_bound: f64,
    /// With --fair: most sweeps over the normals and tangent lengths (each sweep costs
    /// about as much as the others; it stops sooner when one gains less than 0.1 %).
    #[arg(long, value_name = "N", default_value_t = 6, requires = "fair")]
    pub fair_sweeps: usize,
}

impl InputArgs {
    pub fn load_options(&self) -> LoadOptions {
        LoadOptions {
            weighting: self.normals,
            recompute_normals: self.recompute_normals,
            crease_angle: self.crease_angle,
        }
    }

    pub fn scheme_options(&self) -> SchemeOptions {
        SchemeOptions {
            phong_alpha: self.phong_alpha,
        }
    }

    /// The options of the repair `--repair-folds` asks for.
    pub fn repair_options(&self) -> RepairOptions {
        RepairOptions::default().with_scheme_options(self.scheme_options())
    }

    /// With `--fair`, the fair mesh and the report ([`fair_with_progress`], with a bar on
    /// stderr unless `quiet`); otherwise `None`. Refused for a scheme other than G1.
    pub fn faired(&self, mesh: &Mesh, quiet: bool) -> anyhow::Result<Option<(Mesh, FairReport)>> {
        if !self.fair {
            return Ok(None);
        }
        anyhow::ensure!(
            self.scheme == Scheme::G1,
            "--fair chooses the normals and tangent lengths of the G1 surface: use it with \
             --scheme g1"
        );
        let opts = FairOptions::default()
            .with_normal_bound_deg(self.normal_bound)
            .with_sweeps(self.fair_sweeps)
            .with_scheme_options(self.scheme_options());
        let bar = progress::bar(0, "fair", "items", quiet);
        let out = fair_with_progress(mesh, &opts, &bar);
        bar.finish();
        Ok(Some(out?))
    }

    /// With `--repair-folds`, `mesh` repaired for the scheme (once: what follows works on
    /// the repaired mesh) and the repair's report; with `--fair`, the fair mesh (its
    /// report's line printed on stderr); otherwise `mesh` itself and no report. `quiet`
    /// hides the fair search's bar.
    pub fn repaired<'a>(
        &self,
        mesh: &'a Mesh,
        quiet: bool,
    ) -> anyhow::Result<(std::borrow::Cow<'a, Mesh>, Option<RepairReport>)> {
        if let Some((m, report)) = self.faired(mesh, quiet)? {
            out::stderr_line(&report.to_text(&mesh.name));
            return Ok((std::borrow::Cow::Owned(m), None));
        }
        if !self.repair_folds {
            return Ok((std::borrow::Cow::Borrowed(mesh), None));
        }
        let (fixed, report) = repair(mesh, self.scheme, &self.repair_options())?;
        Ok((std::borrow::Cow::Owned(fixed), Some(report)))
    }

    /// Loads the mesh, printing what the reader ignored or filled in (its notes) once on
    /// stderr.
    pub fn load_mesh(&self) -> anyhow::Result<Mesh> {
        let mesh = Mesh::load(&self.mesh, &self.load_options())?;
        for note in &mesh.load_report.notes {
            out::stderr_line(&format!("note: {}: {note}", mesh.name));
        }
        Ok(mesh)
    }

    /// The mesh to work on (with `--repair-folds` the repaired one: its new creases are
    /// what the stitcher and writers see), its table, and the line to print about folded
    /// patches or the repair ([`repair_line`]). `quiet` hides the fair search's bar.
    pub fn prepare(
        &self,
        mesh: Mesh,
        quiet: bool,
    ) -> anyhow::Result<(Mesh, PatchTable, Option<String>)> {
        let (m, report) = self.repaired(&mesh, quiet)?;
        let table = PatchTable::build(&m, self.scheme, &self.scheme_options())?;
        let line = repair_line(&m.name, &table, report.as_ref());
        let mesh = match m {
            std::borrow::Cow::Owned(m) => m,
            std::borrow::Cow::Borrowed(_) => mesh,
        };
        Ok((mesh, table, line))
    }

    /// [`Self::prepare`] of `mesh` as it is (no repair: the caller checked
    /// `repair_folds`): its table and the line about its folded patches.
    pub fn table_of(&self, mesh: &Mesh) -> anyhow::Result<(PatchTable, Option<String>)> {
        let table = PatchTable::build(mesh, self.scheme, &self.scheme_options())?;
        let line = repair_line(&mesh.name, &table, None);
        Ok((table, line))
    }
}

/// Significant decimal digits of an f32 in its normal range: 24 bits, log10(2^24).
const F32_DIGITS: f64 = 7.224_719_895_935_548;

/// Checks that f32 output (tessellate's files, render's surface) can hold `mesh`'s
/// coordinates. Below f32's normal range (largest coordinate under 2^-126 ≈ 1.2e-38), f32
/// keeps a fixed step of 2^-149 ≈ 1.4e-45 and loses relative precision: the returned note
/// (one line, "note: NAME: ...") says how much. A mesh whose every coordinate rounds to 0 in
/// f32 (all under about 7e-46) is refused: every vertex would be written as 0 0 0. Larger
/// coordinates than f32 holds are refused where the samples are made (a non-finite f32).
pub fn f32_range(mesh: &Mesh) -> anyhow::Result<Option<String>> {
    let largest = mesh
        .positions
        .iter()
        .flat_map(|p| p.to_array())
        .fold(0.0f64, |m, c| m.max(c.abs()));
    let step = f64::from(f32::from_bits(1)); // 2^-149, the smallest f32 step
    let name = &mesh.name;
    if largest == 0.0 || largest >= f64::from(f32::MIN_POSITIVE) {
        return Ok(None);
    }
    anyhow::ensure!(
        largest as f32 != 0.0,
        "{name}: every coordinate rounds to 0 in f32 (the largest is {largest:.1e}; f32's \
         smallest number is {step:.1e}), so every vertex would be written as 0 0 0; scale \
         the mesh up"
    );
    let relative = step / largest;
    // At the smallest subnormal one step is the whole value: no digit is left.
    let digits = -relative.log10();
    let digits = if digits > 0.0 { digits } else { 0.0 };
    Ok(Some(format!(
        "note: {name}: coordinates are at most {largest:.1e}, below f32's normal range \
         ({:.1e}): f32 keeps steps of {step:.1e}, {relative:.1e} of the largest coordinate \
         (about {:.1} significant digits instead of {F32_DIGITS:.1}); scale the mesh up for \
         full precision",
        f32::MIN_POSITIVE,
        digits,
    )))
}

/// Which evaluator runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Backend {
    /// The CPU (rayon, all threads): the f64 reference, except tessellate's uniform grids,
    /// which an f32 SIMD kernel evaluates.
    Cpu,
    /// WGSL compute shaders on a Vulkan adapter; fails when there is none.
    Gpu,
    /// The GPU, unless the only Vulkan adapters are software ones (lavapipe: the CPU
    /// backend is faster on the same cores) or none can run; then the CPU, with one line
    /// on stderr saying why.
    Auto,
}

/// Backend arguments shared by every command that evaluates patches.
#[derive(Args, Clone, Debug)]
pub struct BackendArgs {
    /// Evaluation backend.
    #[arg(long, value_enum, default_value = "auto")]
    pub backend: Backend,
    /// GPU working precision (f64 needs an adapter with SHADER_F64). Default: f64 for
    /// statistics and distances (stats, compare, sweep, the default run), f32 for geometry
    /// (tessellate, render). The CPU backend does not read it.
    #[arg(long, value_enum)]
    pub precision: Option<crate::gpu::Precision>,
    /// Say nothing on stderr about the adapter or the fallback (set by `--quiet`).
    #[arg(skip)]
    pub quiet: bool,
}

impl Default for BackendArgs {
    fn default() -> Self {
        BackendArgs {
            backend: Backend::Auto,
            precision: None,
            quiet: false,
        }
    }
}

impl BackendArgs {
    /// The evaluator asked for, with `default_precision` on the GPU unless `--precision`
    /// was given. The GPU is opened on the first evaluation (so input errors come first and
    /// alone); then the GPU backend names its adapter on stderr, and `auto` says on stderr
    /// when it falls back to the CPU, and why.
    pub fn evaluator(
        &self,
        default_precision: crate::gpu::Precision,
    ) -> anyhow::Result<Box<dyn crate::eval::Evaluator>> {
        Ok(match self.backend {
            Backend::Cpu => Box::new(crate::eval::cpu::CpuEvaluator::default()),
            backend => Box::new(LazyGpu {
                backend,
                precision: self.precision.unwrap_or(default_precision),
                quiet: self.quiet,
                inner: std::cell::OnceCell::new(),
            }),
        })
    }

    /// Whether these arguments evaluate on the CPU, told without opening a device and
    /// without a word on stderr: `cpu`, or `auto` where every Vulkan adapter is a software
    /// one or there is none (what `auto` then runs on). Where `auto` falls back to the CPU
    /// only after a GPU failed to open, this says no.
    pub fn evaluates_on_cpu(&self) -> bool {
        match self.backend {
            Backend::Cpu => true,
            Backend::Gpu => false,
            Backend::Auto => software_only(&crate::gpu::adapters()),
        }
    }
}

/// Whether every adapter of `adapters` is a software one (true of none).
fn software_only(adapters: &[wgpu::AdapterInfo]) -> bool {
    adapters
        .iter()
        .all(|a| a.device_type == wgpu::DeviceType::Cpu)
}

/// The GPU (or, for `auto`, the CPU fallback), opened on first use.
pub struct LazyGpu {
    pub backend: Backend,
    pub precision: crate::gpu::Precision,
    pub quiet: bool,
    pub inner: std::cell::OnceCell<Box<dyn crate::eval::Evaluator>>,
}

impl LazyGpu {
    fn open(&self) -> crate::Result<Box<dyn crate::eval::Evaluator>> {
        use crate::eval::cpu::CpuEvaluator;
        use crate::gpu::eval::GpuEvaluator;
        let gpu = || -> crate::Result<GpuEvaluator> {
            let ctx = crate::cli::common::shared_gpu()?;
            let ev = GpuEvaluator::new(ctx.clone(), self.precision)?;
            if !self.quiet {
                out::stderr_line(&format!("gpu: {} ({})", ctx.describe(), self.precision));
            }
            Ok(ev)
        };
        if self.backend == Backend::Auto {
            let adapters = crate::gpu::adapters();
            if !adapters.is_empty() && software_only(&adapters) {
                let names: Vec<&str> = adapters.iter().map(|a| a.name.as_str()).collect();
                self.note(&format!(
                    "the only Vulkan adapter is a software one ({}), slower than the CPU \
                     backend on the same cores: using the CPU backend; --backend gpu runs \
                     on it",
                    names.join(", ")
                ));
                return Ok(Box::new(CpuEvaluator::default()));
            }
        }
        Ok(match (self.backend, gpu()) {
            (_, Ok(ev)) => Box::new(ev),
            (Backend::Auto, Err(e)) => {
                self.note(&format!("{e}; falling back to the CPU backend"));
                Box::new(CpuEvaluator::default())
            }
            (_, Err(e)) => return Err(e),
        })
    }

    /// "note: MESSAGE" on stderr, once per process (a command may open several evaluators)
    /// and never with `--quiet`.
    fn note(&self, message: &str) {
        static SAID: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);
        if !self.quiet && !SAID.swap(true, std::sync::atomic::Ordering::Relaxed) {
            out::stderr_line(&format!("note: {message}"));
        }
    }

    fn get(&self) -> crate::Result<&dyn crate::eval::Evaluator> {
        if self.inner.get().is_none() {
            let ev = self.open()?;
            let _ = self.inner.set(ev);
        }
        Ok(self.inner.get().expect("set above").as_ref())
    }
}

impl crate::eval::Evaluator for LazyGpu {
    fn describe(&self) -> String {
        match self.get() {
            Ok(ev) => ev.describe(),
            Err(e) => format!("gpu unavailable ({e})"),
        }
    }

    fn gpu_precision(&self) -> Option<crate::gpu::Precision> {
        self.get().ok()?.gpu_precision()
    }

    fn evaluate(
        &self,
        table: &crate::patch::PatchTable,
        pattern: &crate::eval::Pattern,
        sink: &mut dyn FnMut(crate::eval::Chunk<'_>) -> crate::Result<()>,
    ) -> crate::Result<()> {
        self.get()?.evaluate(table, pattern, sink)
    }

    fn evaluate_f32(
        &self,
        table: &crate::patch::PatchTable,
        pattern: &crate::eval::Pattern,
        sink: &mut dyn FnMut(crate::eval::ChunkF32<'_>) -> crate::Result<()>,
    ) -> crate::Result<()> {
        self.get()?.evaluate_f32(table, pattern, sink)
    }

    // The edge patterns go to the evaluator chosen, so that the CPU fallback keeps its
    // own edge kernel instead of the trait's point-by-point default.
    fn evaluate_edges(
        &self,
        table: &crate::patch::PatchTable,
        edges: &crate::eval::EdgePairs,
        sink: &mut dyn FnMut(crate::eval::Chunk<'_>) -> crate::Result<()>,
    ) -> crate::Result<()> {
        self.get()?.evaluate_edges(table, edges, sink)
    }

    fn evaluate_edge_products(
        &self,
        table: &crate::patch::PatchTable,
        edges: &crate::eval::EdgePairs,
        sink: &mut dyn FnMut(crate::eval::PairChunk<'_>) -> crate::Result<()>,
    ) -> crate::Result<()> {
        self.get()?.evaluate_edge_products(table, edges, sink)
    }
}

/// The memory budget, shared by every command that allocates in proportion to its input or
/// options (flatten it into the command's arguments).
#[derive(Args, Clone, Debug, Default)]
pub struct MemoryArgs {
    /// Memory budget: a run that would hold more is refused before it allocates. SIZE in
    /// bytes, or with a suffix K, M, G or T (powers of 1024; "KiB", "GB"… are read the same
    /// way). Default: half the machine's memory.
    #[arg(long, value_name = "SIZE", value_parser = parse_size, allow_hyphen_values = true)]
    pub max_memory: Option<u64>,
}

impl MemoryArgs {
    /// The budget asked for, or half the machine's memory.
    pub fn budget(&self) -> Budget {
        Budget {
            bytes: self.max_memory.unwrap_or_else(default_budget),
        }
    }
}

/// Half of MemTotal in /proc/meminfo; 4 GiB where that cannot be read.
pub fn default_budget() -> u64 {
    std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|s| {
            let line = s.lines().find(|l| l.starts_with("MemTotal:"))?;
            let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
            Some(kib.saturating_mul(1024) / 2)
        })
        .filter(|&b| b > 0)
        .unwrap_or(4 << 30)
}

/// Parses a size: a whole or decimal number of bytes with an optional suffix K, M, G, T
/// (powers of 1024; an "i", a "B", and spaces are accepted: "8G", "512 MiB", "1.5GB").
pub fn parse_size(s: &str) -> Result<u64, String> {
    let t = s.trim();
    let split = t
        .find(|c: char| !(c.is_ascii_digit() || c == '.'))
        .unwrap_or(t.len());
    let (num, unit) = t.split_at(split);
    let bad = || {
        format!(
            "'{}' is not a size (bytes, or a number with K, M, G or T: \"8G\", \"512M\")",
            s.escape_default()
        )
    };
    let out_of_range = || {
        format!(
            "'{}' is out of range (1 byte to 16 EiB)",
            s.escape_default()
        )
    };
    if let Some(rest) = t.strip_prefix('-') {
        // A negative number is a size out of range, not a malformed one.
        return Err(if parse_size(rest).is_ok() {
            out_of_range()
        } else {
            bad()
        });
    }
    let x: f64 = num.parse().map_err(|_| bad())?;
    let unit = unit.trim().to_ascii_uppercase();
    let unit = unit.trim_end_matches('B').trim_end_matches('I');
    let scale = match unit {
        "" => 1u64,
        "K" => 1 << 10,
        "M" => 1 << 20,
        "G" => 1 << 30,
        "T" => 1 << 40,
        _ => return Err(bad()),
    };
    let bytes = x * scale as f64;
    if !bytes.is_finite() || bytes < 1.0 || bytes >= u64::MAX as f64 {
        return Err(out_of_range());
    }
    Ok(bytes as u64)
}

/// The value parser of a whole-number option whose range starts at `lo` and ends at `hi`
/// (`u32::MAX`: no end). A negative number is read as a number (give the option
/// `allow_negative_numbers`, or clap takes `-1` for an option) and refused with the range;
/// 0 and values up to `u32::MAX` parse, and the command refuses them where they are out
/// of range with its own message.
pub fn whole_number(
    lo: u32,
    hi: u32,
) -> impl Fn(&str) -> Result<u32, String> + Clone + Send + Sync + 'static {
    move |s: &str| {
        let range = if hi == u32::MAX {
            format!("must be at least {lo}")
        } else {
            format!("must be {lo} to {hi}")
        };
        match s.trim().parse::<i64>() {
            Ok(v) if v < 0 => Err(range),
            Ok(v) => u32::try_from(v).map_err(|_| {
                if hi == u32::MAX {
                    format!("must be at most {}", u32::MAX)
                } else {
                    range
                }
            }),
            Err(e) => Err(e.to_string()),
        }
    }
}

/// A size in bytes for people: "512 B", "3.2 MiB", "7.7 GiB".
pub fn human_bytes(b: u64) -> String {
    const UNITS: [&str; 6] = ["KiB", "MiB", "GiB", "TiB", "PiB", "EiB"];
    if b < 1024 {
        return format!("{b} B");
    }
    let mut x = b as f64 / 1024.0;
    let mut u = 0;
    while x >= 1024.0 && u + 1 < UNITS.len() {
        x /= 1024.0;
        u += 1;
    }
    format!("{x:.1} {}", UNITS[u])
}

/// A count for people: "950", "15.0 k", "5.1 G".
pub fn human_count(n: u64) -> String {
    let x = n as f64;
    match n {
        0..1_000 => format!("{n}"),
        1_000..1_000_000 => format!("{:.1} k", x / 1e3),
        1_000_000..1_000_000_000 => format!("{:.1} M", x / 1e6),
        _ => format!("{:.1} G", x / 1e9),
    }
}

/// A memory budget in bytes ([`MemoryArgs`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Budget {
    pub bytes: u64,
}

impl Budget {
    /// Fails with one line when `need` bytes exceed the budget: "COMMAND: WHAT needs about
    /// N (DETAIL), over the memory budget of B (--max-memory)", an
    /// [`crate::Error::OverBudget`].
    pub fn check(&self, command: &str, what: &str, need: u64, detail: &str) -> anyhow::Result<()> {
        if need > self.bytes {
            let detail = if detail.is_empty() {
                String::new()
            } else {
                format!(" ({detail})")
            };
            return Err(crate::Error::OverBudget {
                what: what.to_string(),
                needed: need,
                allowed: self.bytes,
                message: format!(
                    "{command}: {what} needs about {}{detail}, over the memory budget of {} \
                     (--max-memory)",
                    human_bytes(need),
                    human_bytes(self.bytes)
                ),
            }
            .into());
        }
        Ok(())
    }
}

/// Samples per chunk assumed for memory estimates: the larger of the CPU's (2^20) and the
/// GPU's (2^22) defaults.
pub const CHUNK_SAMPLES: usize = 1 << 22;

/// What a stitched f32 tessellation of `mesh` (with `edges` edges, patches of `stride`
/// control points) at `level` holds, for a sink reading `needs` whose writer holds
/// `writer` = (while streaming, afterwards) bytes ([`crate::io::writers::MeshFormat::buffer_bytes`]):
/// (total bytes, the stitcher's estimate, the evaluator's basis weights in bytes).
pub fn tessellation_need(
    mesh: &Mesh,
    edges: usize,
    stride: usize,
    level: u32,
    needs: crate::tess::stitch::Needs,
    writer: (u64, u64),
) -> (u64, crate::tess::stitch::StitchMemory, u64) {
    let estimate = crate::tess::stitch::memory_estimate(
        mesh.positions.len(),
        edges,
        mesh.triangles.len(),
        level,
        12,
        CHUNK_SAMPLES,
        needs,
    );
    // The grid's count, saturating where level u32::MAX overflows it (and is refused).
    let per_patch = crate::eval::grid_len(level) as u64;
    // The evaluator's basis weights at every grid point: stride × 3 f32 (the CPU's f32
    // kernel; the GPU uploads the same table).
    let weights = per_patch.saturating_mul(stride as u64 * 12);
    // Where the CPU builds the patches per stage (`stitch_certified`): two stages' tables
    // (the one evaluated and the one built meanwhile, as many patches as the two batches),
    // each patch `stride` control points and a flat normal of 24 bytes. A stage holds 2^14
    // samples per pool thread (`stage_samples`), so this grows with the pool: about 318 MB
    // at level 1 on 64 threads.
    let tables = estimate
        .batch_patches
        .saturating_mul((stride as u64 + 1) * 24);
    // PLY and glTF write their faces after the evaluation, whose buffers are gone by then.
    let evaluation = weights
        .saturating_add(tables)
        .saturating_add(estimate.chunk_bytes)
        .saturating_add(estimate.batch_bytes)
        .saturating_add(writer.0);
    let need =
        (estimate.plan_bytes + estimate.store_bytes).saturating_add(evaluation.max(writer.1));
    (need, estimate, weights)
}

/// Peak bytes of loading `spec`, estimated before anything is read: a built-in's triangle
/// count times [`LOADED_BYTES_PER_TRIANGLE`], or a file's size times a factor of its kind
/// ([`TEXT_LOAD_FACTOR`], [`BINARY_LOAD_FACTOR`]) plus [`LOAD_OVERHEAD`].
pub fn load_need(spec: &str) -> u64 {
    if let Some(t) = crate::mesh::generators::spec_triangles(spec) {
        return t.saturating_mul(LOADED_BYTES_PER_TRIANGLE);
    }
    let text = std::path::Path::new(spec)
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("obj") || e.eq_ignore_ascii_case("pn"));
    let factor = if text {
        TEXT_LOAD_FACTOR
    } else {
        BINARY_LOAD_FACTOR
    };
    let by_size = std::fs::metadata(spec)
        .map(|m| m.len().saturating_mul(factor).saturating_add(LOAD_OVERHEAD))
        .unwrap_or(0);
    let path = std::path::Path::new(spec);
    let gltf = path
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("gltf") || e.eq_ignore_ascii_case("glb"));
    if gltf {
        // Nodes may instance one mesh many times, and buffer files are held whole.
        if let Some(s) = crate::mesh::gltf::scene_size(path) {
            let need = s
                .vertices
                .saturating_mul(GLTF_BYTES_PER_VERTEX)
                .saturating_add(s.corners.saturating_mul(GLTF_BYTES_PER_CORNER))
                .saturating_add(s.file_buffers)
                .saturating_add(LOAD_OVERHEAD);
            return by_size.max(need);
        }
    }
    by_size
}

/// Bytes per vertex a glTF scene's load holds at its peak: the soup's f64 position and
/// optional normal (24 + 32), its UV and colour (8 + 16), the weld's key and map (16), and
/// the accessor values read as `[f64; 4]` (32) before they are converted. An upper bound:
/// `stats` of 30 instances of an 80,000-triangle grid peaks at 337 MiB (`/usr/bin/time`)
/// against 812 MiB estimated.
pub const GLTF_BYTES_PER_VERTEX: u64 = 128;

/// Bytes per corner (index entry) of a glTF load: the index read as `[f64; 4]` (32) and
/// kept as u32 (4), and a third of a triangle's soup entry (12) and of the welded mesh's
/// triangle, per-corner f64 normal, UV and colour (12 + 72 + 24 + 48): 32 + 4 + 4 + 52.
pub const GLTF_BYTES_PER_CORNER: u64 = 92;

/// Bytes per triangle of a generated mesh: 12 of indices, 72 of per-corner f64 normals,
/// half a vertex of 24 bytes, and the generator's and weld's working arrays (measured:
/// `stats torus:2000x2000`, 8 M triangles, peaks at 1.06 GB, 132 bytes per triangle with
/// the statistics' edge index).
pub const LOADED_BYTES_PER_TRIANGLE: u64 = 160;

/// Peak bytes per byte of an OBJ or `.pn` file: measured 1.4 (`/usr/bin/time -f %M g1tess
/// stats` on the bunny tessellated at level 4, a 120 MB OBJ: 170 MB peak); 2 leaves room
/// for denser text (fewer digits per number).
pub const TEXT_LOAD_FACTOR: u64 = 2;

/// Binary meshes hold 4-byte floats and indices that become 8-byte floats and per-corner
/// normals in memory: up to about 6 times their size.
pub const BINARY_LOAD_FACTOR: u64 = 6;

/// Buffers of a load whatever the file's size: the 8 MiB read chunks and per-thread blocks.
pub const LOAD_OVERHEAD: u64 = 32 << 20;

impl Budget {
    /// Refuses, before reading it, a mesh whose loading would exceed the budget.
    pub fn check_load(&self, command: &str, spec: &str) -> anyhow::Result<()> {
        self.check(
            command,
            &format!("loading {spec}"),
            load_need(spec),
            "estimated",
        )
    }

    /// Refuses continuity statistics of `mesh` that would exceed the budget: the mesh, its
    /// edge index and one chunk of edges (see `analysis::stats`).
    pub fn check_stats(&self, command: &str, mesh: &Mesh) -> anyhow::Result<()> {
        let t = mesh.triangles.len() as u64;
        let v = mesh.positions.len() as u64;
        // Mesh arrays, then the edge index: 4 bytes per half-edge and per vertex, 4 per
        // triangle for the chunk's patch numbering; then one chunk: 2^18 evaluation points
        // of position + normal in f64, their patches and the evaluator's buffers (measured:
        // the bunny's whole run peaks at 36 MB, 24 MB above its mesh and the binary).
        let mesh_bytes = t * 84 + v * 24;
        let index = t * 3 * 4 + v * 4 + t * 4;
        let need = mesh_bytes + index + (32 << 20);
        self.check(
            command,
            &format!("statistics of {}", mesh.name),
            need,
            &format!("{} triangles", human_count(t)),
        )
    }
}

/// The command line's GPU: one context per process, opened on first use (device creation is
/// slow on software drivers); the error, if any, is remembered and returned every time.
#[cfg(feature = "gpu")]
pub fn shared_gpu() -> crate::Result<Arc<GpuContext>> {
    static SHARED: OnceLock<crate::Result<Arc<GpuContext>>> = OnceLock::new();
    match SHARED.get_or_init(|| GpuContext::new().map(Arc::new)) {
        Ok(ctx) => Ok(ctx.clone()),
        Err(crate::Error::NoAdapter { detail, message }) => Err(crate::Error::NoAdapter {
            detail: detail.clone(),
            message: message.clone(),
        }),
        Err(e) => Err(crate::Error::Gpu(e.to_string())),
    }
}

#[cfg(test)]
mod tests;
