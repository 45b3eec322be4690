//! `g1tess stats`: continuity statistics of one mesh and scheme.

use clap::Args;

use super::{out, BackendArgs, InputArgs};
use crate::analysis::stats::stats_report;
use crate::mesh::Mesh;

#[derive(Args, Clone, Debug)]
pub struct StatsArgs {
    #[command(flatten)]
    pub input: InputArgs,
    #[command(flatten)]
    pub backend: BackendArgs,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    pub memory: super::MemoryArgs,
    /// Nothing on stderr about the adapter or the CPU fallback (the statistics are still
    /// printed).
    #[arg(long, short)]
    pub quiet: bool,
    /// Also measure fairness (on the CPU, from the whole patch table): the bending energy
    /// ∫(κ1²+κ2²)dA from the patches' exact first and second derivatives, and the G2
    /// defect, the jump of the normal curvature across each non-crease interior edge at its
    /// 21 samples (max and mean). Quadrature: each patch cut into six Duffy triangles
    /// collapsed at its corners, 2×2 square cells each, 3×3 Gauss-Legendre nodes per cell,
    /// a cell refined where its children's sum differs by more than 1e-4 of the patch's
    /// energy. Patches the validity certificate does not prove valid (folds: unbounded
    /// energy) are left out of both and counted.
    #[arg(long)]
    pub fairness: bool,
}

pub fn run(a: &StatsArgs) -> anyhow::Result<()> {
    // No whole patch table: the statistics build the patches a chunk of edges at a time.
    let budget = a.memory.budget();
    budget.check_load("stats", &a.input.mesh)?;
    let mesh = a.input.load_mesh()?;
    budget.check_stats("stats", &mesh)?;
    check_fairness(a, &mesh)?;
    if a.backend.backend == super::common::Backend::Gpu {
        return run_gpu(a, &mesh);
    }
    let mut backend = a.backend.clone();
    backend.quiet |= a.quiet;
    let evaluator = backend.evaluator(crate::gpu::Precision::F64)?;
    // With --repair-folds (--fair) the statistics are those of the repaired (fair) mesh.
    let (mesh, repair, fair) = repaired_or_faired(a, &mesh)?;
    let mut report = stats_report(
        &mesh,
        a.input.scheme,
        &a.input.scheme_options(),
        evaluator.as_ref(),
    )?;
    report.repair = repair;
    let fairness = if a.fairness {
        let table =
            crate::patch::PatchTable::build(&mesh, a.input.scheme, &a.input.scheme_options())?;
        Some(measure_fairness(&mesh, &table)?)
    } else {
        None
    };
    print_report(a, report, fairness, fair)
}

/// Refuses `--fairness` where the whole patch table, the adjacency and the edge list it
/// needs (beside the mesh) exceed the memory budget.
fn check_fairness(a: &StatsArgs, mesh: &Mesh) -> anyhow::Result<()> {
    if !a.fairness {
        return Ok(());
    }
    let stride = a.input.scheme.kind().layout().stride as u64;
    let patches = mesh.triangles.len() as u64;
    // 24 bytes per control point and flat normal; about 1.5 edges per triangle, each some
    // 80 bytes in the adjacency and the list of edge sides.
    a.memory.budget().check(
        "stats",
        &format!("--fairness on {patches} patches"),
        patches.saturating_mul(stride * 24 + 24 + 120),
        &format!("the patch table of {stride} control points each and the edges"),
    )
}

/// The fairness measures of `table` (the whole mesh's).
fn measure_fairness(
    mesh: &Mesh,
    table: &crate::patch::PatchTable,
) -> anyhow::Result<crate::analysis::fairness::FairnessReport> {
    let adjacency = mesh.adjacency();
    Ok(crate::analysis::fairness::fairness(
        mesh,
        &adjacency,
        table,
        &Default::default(),
    )?)
}

/// `stats --backend gpu`: the edge samples evaluated and reduced on the device
/// ([`crate::gpu::stats`]), only the aggregates read back; the whole patch table is built.
fn run_gpu(a: &StatsArgs, mesh: &Mesh) -> anyhow::Result<()> {
    use crate::analysis::stats::{EdgeStats, StatsReport};
    use crate::eval::Evaluator;
    use crate::gpu::eval::GpuEvaluator;
    let precision = a.backend.precision.unwrap_or(crate::gpu::Precision::F64);
    let ctx = crate::cli::common::shared_gpu()?;
    let gpu = GpuEvaluator::new(ctx.clone(), precision)?;
    if !(a.backend.quiet || a.quiet) {
        out::stderr_line(&format!("gpu: {} ({precision})", ctx.describe()));
    }
    let stride = a.input.scheme.kind().layout().stride as u64;
    let patches = mesh.triangles.len() as u64;
    a.memory.budget().check(
        "stats",
        &format!("the GPU statistics' table of {patches} patches"),
        patches.saturating_mul(stride * 24),
        &format!("{stride} control points each, beside the mesh"),
    )?;
    // With --repair-folds (--fair) the statistics are those of the repaired (fair) mesh,
    // as on the CPU.
    let (mesh, repair, fair) = repaired_or_faired(a, mesh)?;
    let mesh = mesh.as_ref();
    let table = crate::patch::PatchTable::build(mesh, a.input.scheme, &a.input.scheme_options())?;
    let adjacency = mesh.adjacency();
    let c = crate::gpu::stats::gpu_continuity(&gpu, mesh, &adjacency, &table)?;
    let mut report = StatsReport::new(
        mesh,
        EdgeStats::new(mesh).counts(),
        a.input.scheme,
        table.fallbacks,
        c,
        gpu.describe(),
    );
    report.patches = crate::patch::validity::count(&table);
    report.repair = repair;
    let fairness = if a.fairness {
        Some(measure_fairness(mesh, &table)?)
    } else {
        None
    };
    print_report(a, report, fairness, fair)
}

/// The report on stdout: JSON, or text whose mesh name is escaped ([`out::escape`]), then
/// an empty line. With `--fairness`, its measures: a `fairness` object after the report's
/// fields, or two more lines.
fn print_report(
    a: &StatsArgs,
    mut report: crate::analysis::stats::StatsReport,
    fairness: Option<crate::analysis::fairness::FairnessReport>,
    fair: Option<crate::analysis::fair::FairReport>,
) -> anyhow::Result<()> {
    note_undecided(a, &report.patches);
    if a.json {
        let json = if fairness.is_none() && fair.is_none() {
            serde_json::to_string(&report)?
        } else {
            serde_json::to_string(&WithFairness {
                report: &report,
                fairness: fairness.as_ref(),
                fair: fair.as_ref(),
            })?
        };
        out::stdout_json(&json)?;
    } else {
        let fair_line = fair
            .map(|f| format!("\n{}", f.to_text(&out::escape(&report.mesh))))
            .unwrap_or_default();
        report.mesh = out::escape(&report.mesh).into_owned();
        let extra = fairness
            .map(|f| format!("\n{}", f.to_text()))
            .unwrap_or_default();
        out::stdout_line(&format!("{}{fair_line}{extra}\n", report.to_text()))?;
    }
    Ok(())
}

/// `stats --json` with `--fairness` or `--fair`: the report's fields, then `fairness` and
/// `fair` where present.
#[derive(serde::Serialize)]
struct WithFairness<'a> {
    #[serde(flatten)]
    report: &'a crate::analysis::stats::StatsReport,
    #[serde(skip_serializing_if = "Option::is_none")]
    fairness: Option<&'a crate::analysis::fairness::FairnessReport>,
    #[serde(skip_serializing_if = "Option::is_none")]
    fair: Option<&'a crate::analysis::fair::FairReport>,
}

/// The mesh the statistics are of: repaired with `--repair-folds`, fair with `--fair`
/// (with the report, for the output), else `mesh` itself.
#[allow(clippy::type_complexity)]
fn repaired_or_faired<'a>(
    a: &StatsArgs,
    mesh: &'a Mesh,
) -> anyhow::Result<(
    std::borrow::Cow<'a, Mesh>,
    Option<crate::patch::repair::RepairReport>,
    Option<crate::analysis::fair::FairReport>,
)> {
    let quiet = a.quiet || a.backend.quiet;
    if let Some((m, report)) = a.input.faired(mesh, quiet)? {
        return Ok((std::borrow::Cow::Owned(m), None, Some(report)));
    }
    let (m, repair) = a.input.repaired(mesh, quiet)?;
    Ok((m, repair, None))
}

/// A note on stderr where the certificate left patches undecided (not with `--quiet`).
fn note_undecided(a: &StatsArgs, patches: &crate::PatchCounts) {
    if let Some(note) = crate::patch::validity::undecided_note(patches) {
        if !(a.quiet || a.backend.quiet) {
            out::stderr_line(&format!("note: {note}"));
        }
    }
}
