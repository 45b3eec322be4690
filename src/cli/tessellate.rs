//! `g1tess tessellate`: evaluate every patch on a grid in f32 and write the stitched
//! surface: the evaluator's f32 path (the CPU's SIMD kernel, the GPU's f32 shaders) feeds
//! the stitcher and the writer in f32, with no f64 round trip. Per-edge levels
//! (`--tolerance`) are point lists, which the CPU evaluates in f64 and rounds once.

use std::path::PathBuf;

use clap::Args;

use super::common::{human_bytes, human_count, tessellation_need, whole_number, MemoryArgs};
use super::out;
use super::progress;
use super::TEMP_FILES;
use super::{BackendArgs, InputArgs};
use crate::eval::cpu::CpuEvaluator;
use crate::io::atomic;
use crate::io::writers::{write_stitched, MeshFormat};
use crate::mesh::creases::split_ends;
use crate::mesh::{Adjacency, Mesh};
use crate::patch::validity::fold_line_of;
use crate::patch::{PatchBuilder, PatchTable};
use crate::tess::adaptive::{levels_for_tolerance, ToleranceLevels, ToleranceOptions};
use crate::tess::stitch::{stitch_certified, stitch_into, StitchPlan};

/// Default cap on the levels `--tolerance` chooses.
pub const DEFAULT_MAX_LEVEL: u32 = 64;

/// Refinement rounds `--tolerance` runs after its first measurement, at most.
const TOLERANCE_ROUNDS: u32 = 8;

/// Output formats by name (`--format`, needed with `-o -`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum FormatArg {
    Obj,
    Ply,
    Stl,
    Glb,
}

impl From<FormatArg> for MeshFormat {
    fn from(f: FormatArg) -> MeshFormat {
        match f {
            FormatArg::Obj => MeshFormat::Obj,
            FormatArg::Ply => MeshFormat::Ply,
            FormatArg::Stl => MeshFormat::Stl,
            FormatArg::Glb => MeshFormat::Glb,
        }
    }
}

#[derive(Args, Clone, Debug)]
pub struct TessellateArgs {
    #[command(flatten)]
    pub input: InputArgs,
    #[command(flatten)]
    pub backend: BackendArgs,
    /// Grid level: n segments per edge, (n+1)(n+2)/2 points per patch (at least 1).
    #[arg(
        long,
        default_value_t = 8,
        conflicts_with_all = ["tolerance", "tolerance_rel"],
        allow_negative_numbers = true,
        value_parser = whole_number(1, u32::MAX)
    )]
    pub level: u32,
    /// Instead of --level: choose a level per edge and per patch so that the flat output
    /// triangles deviate from the curved surface by at most EPS (absolute, the mesh's
    /// units; positive), measured at 10 points inside every output triangle.
    #[arg(
        long,
        value_name = "EPS",
        conflicts_with = "tolerance_rel",
        allow_hyphen_values = true
    )]
    pub tolerance: Option<f64>,
    /// Like --tolerance, with EPS = R × the diagonal of the mesh's bounding box.
    #[arg(long, value_name = "R", allow_hyphen_values = true)]
    pub tolerance_rel: Option<f64>,
    /// Cap on the levels --tolerance or --tolerance-rel may choose (default 64, at most
    /// 4096).
    #[arg(
        long,
        value_name = "N",
        allow_negative_numbers = true,
        value_parser = whole_number(1, crate::tess::layout::MAX_LEVEL)
    )]
    pub max_level: Option<u32>,
    /// Output file; the format follows the extension: .obj, .ply (binary), .stl (binary),
    /// .glb (glTF 2.0 binary). `-` writes to standard output (OBJ, PLY, STL; needs
    /// --format). A symbolic link is written through to its target; a directory, device or
    /// FIFO is refused, and so is the input mesh itself.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Output format, instead of the extension's (needed with `-o -`).
    #[arg(long, value_enum)]
    pub format: Option<FormatArg>,
    #[command(flatten)]
    pub memory: MemoryArgs,
    /// Print a JSON summary on stdout: {"output", "mesh", "scheme", "level", "backend",
    /// "precision" (what the samples were evaluated in; the file holds f32),
    /// "vertices", "triangles", "crease_edges", "seam_edges", ...} (docs/cli.md).
    #[arg(long)]
    pub json: bool,
    /// No progress bars and no summary line on stderr.
    #[arg(long, short)]
    pub quiet: bool,
}

pub fn run(a: &TessellateArgs) -> anyhow::Result<()> {
    let format = output_format(a)?;
    let cap = check_levels(a)?;
    let mesh = a.input.load_mesh()?;
    if let Some(note) = super::common::f32_range(&mesh)? {
        out::stderr_line(&note);
    }
    let uniform = a.tolerance.is_none() && a.tolerance_rel.is_none();
    let plain = uniform && !a.input.repair_folds && !a.input.fair;
    // At one level on the input mesh on the CPU, each chunk's patches are built, certified
    // and evaluated in the pool job that evaluates them: no table of the whole mesh.
    let built = plain && a.backend.evaluates_on_cpu();
    // At one level on the input mesh (no repair), the plan needs neither the table nor the
    // certificate: the numbering (one pass in order) is built beside them.
    let (mesh, table, mut folds, adjacency, early_plan) = if built {
        let adjacency = mesh.adjacency();
        let plan = StitchPlan::new(&mesh, &adjacency, a.level);
        (mesh, None, None, adjacency, Some(plan))
    } else if plain {
        let adjacency = mesh.adjacency();
        let (prepared, plan) = rayon::join(
            || a.input.table_of(&mesh),
            || StitchPlan::new(&mesh, &adjacency, a.level),
        );
        let (table, folds) = prepared?;
        (mesh, Some(table), folds, adjacency, Some(plan))
    } else {
        let (mesh, table, folds) = a.input.prepare(mesh, a.quiet)?;
        let adjacency = mesh.adjacency();
        (mesh, Some(table), folds, adjacency, None)
    };
    if let Some(line) = folds.take() {
        out::stderr_line(&line);
    }
    let patches = match table {
        Some(t) => Patches::Table(t),
        None => Patches::Built(PatchBuilder::new(
            &mesh,
            a.input.scheme,
            &a.input.scheme_options(),
        )?),
    };
    let (scheme, stride) = match &patches {
        Patches::Table(t) => (t.scheme, t.stride),
        Patches::Built(b) => (a.input.scheme, b.kind().stride()),
    };
    let eps = match (a.tolerance, a.tolerance_rel) {
        (Some(t), _) => Some(t),
        (None, Some(r)) => Some(r * mesh.diagonal()),
        (None, None) => None,
    };
    // A tolerance (per-edge levels) has a table: its runs are not built.
    let chosen: Option<(ToleranceLevels, f64)> = match (eps, &patches) {
        (Some(eps), Patches::Table(table)) => Some((
            choose_levels(a, &mesh, &adjacency, table, format, eps, cap)?,
            eps,
        )),
        _ => None,
    };
    // The memory estimate of the largest level (an upper bound for per-edge levels), made
    // before the plan is built.
    let level = match &chosen {
        Some((t, _)) => t
            .levels
            .edges
            .iter()
            .chain(&t.levels.inner)
            .copied()
            .max()
            .unwrap_or(1),
        None => a.level,
    };
    check_memory(
        a,
        &mesh,
        &adjacency,
        stride,
        format,
        level,
        chosen.is_some(),
    )?;
    let plan = match (&chosen, early_plan) {
        (_, Some(plan)) => plan?,
        (Some((t, _)), None) => StitchPlan::with_levels(&mesh, &adjacency, &t.levels)?,
        (None, None) => StitchPlan::new(&mesh, &adjacency, a.level)?,
    };
    let backend = BackendArgs {
        quiet: a.quiet,
        ..a.backend.clone()
    };
    let evaluator = backend.evaluator(crate::gpu::Precision::F32)?;
    // The file's comment names the mesh escaped: a newline in the name would start a line
    // of its own in an OBJ (a forged vertex or face).
    let name = out::escape(&mesh.name);
    let title = match &chosen {
        Some((_, eps)) => format!("g1tess: {name}, scheme {scheme}, tolerance {eps:e}"),
        None => format!("g1tess: {name}, scheme {scheme}, level {}", a.level),
    };
    let bar = progress::bar(plan.patches() as u64, "evaluating", "patches", a.quiet);
    let mut snap = 0.0;
    write_stitched::<[f32; 3]>(
        &a.output,
        &TEMP_FILES,
        format,
        &plan,
        &title,
        &bar,
        &mut |sink| {
            snap = match &patches {
                Patches::Table(t) => stitch_into(&plan, t, evaluator.as_ref(), sink, &bar)?,
                Patches::Built(b) => {
                    let cpu = CpuEvaluator::default();
                    let (snap, counts) = stitch_certified(&plan, b, &cpu, sink, &bar)?;
                    folds = fold_line_of(&mesh.name, scheme, &counts);
                    snap
                }
            };
            Ok(())
        },
    )?;
    bar.finish();
    // The certificate of a built evaluation is done with it.
    if let Some(line) = folds {
        out::stderr_line(&line);
    }
    let done = Tessellated {
        mesh: &mesh,
        scheme: scheme.to_string(),
        plan: &plan,
        format,
        level,
        backend: evaluator.describe(),
        precision: match evaluator.gpu_precision() {
            Some(p) => p.name(),
            // The CPU: the f32 SIMD kernel on a uniform grid; per-edge levels are point
            // lists, evaluated in f64 and rounded once.
            None if plan.is_uniform() => "f32",
            None => "f64",
        },
        edges: EdgeKinds::new(&mesh, &adjacency, &plan),
        seam_kind: match (
            mesh.attributes.uvs.is_some(),
            mesh.attributes.colors.is_some(),
        ) {
            (false, true) => "colour seam",
            (true, true) => "UV/colour seam",
            _ => "UV seam",
        },
        snap,
    };
    report(a, &done, chosen.as_ref(), cap)
}

/// Where `tessellate`'s patches come from: a table of every patch (per-edge levels, a
/// repair, the GPU), or, at one level on the CPU, a builder that builds each chunk's
/// patches where they are evaluated ([`stitch_certified`]).
enum Patches<'m> {
    Table(PatchTable),
    Built(PatchBuilder<'m>),
}

/// The output format, and the refusals that need no work: a format that cannot stream to
/// standard output, `--json` with `-o -`, and an output that is a directory, a device, a
/// FIFO or the input itself.
fn output_format(a: &TessellateArgs) -> anyhow::Result<MeshFormat> {
    anyhow::ensure!(a.level >= 1, "--level must be at least 1");
    let stdout = atomic::is_stdout(&a.output);
    let format = match (a.format, stdout) {
        (Some(f), _) => MeshFormat::from(f),
        (None, true) => anyhow::bail!("-o - (standard output) needs --format obj|ply|stl"),
        (None, false) => MeshFormat::from_path(&a.output)?,
    };
    if stdout {
        anyhow::ensure!(
            format.streams(),
            "--format glb cannot go to standard output (its header holds the bounds, known \
             only at the end); write it to a file"
        );
        anyhow::ensure!(
            !a.json,
            "--json prints on standard output, which -o - already writes the mesh to"
        );
    } else {
        // Refuse a directory, device or FIFO, and the input itself, before any work.
        atomic::resolve_output(&a.output)?;
        atomic::refuse_input_files(&a.output, std::path::Path::new(&a.input.mesh))?;
    }
    Ok(format)
}

/// Checks --tolerance, --tolerance-rel and --max-level; returns the level cap.
fn check_levels(a: &TessellateArgs) -> anyhow::Result<u32> {
    if let Some(t) = a.tolerance.or(a.tolerance_rel) {
        anyhow::ensure!(
            t.is_finite() && t > 0.0,
            "--tolerance and --tolerance-rel take a positive distance (got {t})"
        );
    }
    let cap = a.max_level.unwrap_or(DEFAULT_MAX_LEVEL);
    anyhow::ensure!(
        a.max_level.is_none() || a.tolerance.is_some() || a.tolerance_rel.is_some(),
        "--max-level caps the levels --tolerance or --tolerance-rel choose; give one of them"
    );
    anyhow::ensure!(
        (1..=crate::tess::layout::MAX_LEVEL).contains(&cap),
        "--max-level must be in 1..={}",
        crate::tess::layout::MAX_LEVEL
    );
    Ok(cap)
}

/// The levels that meet the tolerance `eps` (up to `cap`), measured on the f64 reference.
fn choose_levels(
    a: &TessellateArgs,
    mesh: &Mesh,
    adjacency: &Adjacency,
    table: &PatchTable,
    format: MeshFormat,
    eps: f64,
    cap: u32,
) -> anyhow::Result<ToleranceLevels> {
    // The levels are not known before they are measured: refuse up front what the cap
    // could need (the measurements hold the same stitch store, in f64).
    let (need, _, _) = tessellation_need(
        mesh,
        adjacency.edges.len(),
        table.stride,
        cap,
        format.needs(),
        format.buffer_bytes(cap, mesh.triangles.len()),
    );
    a.memory.budget().check(
        "tessellate",
        &format!("levels up to the cap {cap}"),
        need.saturating_mul(2)
            .saturating_add(crate::tess::adaptive::measure_bytes(cap)),
        "the f64 measurements at the level cap; lower --max-level",
    )?;
    let bar = progress::bar(mesh.triangles.len() as u64, "measuring", "patches", a.quiet);
    let t = levels_for_tolerance(
        mesh,
        adjacency,
        table,
        &crate::eval::cpu::CpuEvaluator::default(),
        &ToleranceOptions {
            tolerance: eps,
            max_level: cap,
            rounds: TOLERANCE_ROUNDS,
        },
        &bar,
    )?;
    bar.finish();
    Ok(t)
}

/// Refuses a tessellation at `level` (the largest of per-edge levels when `adaptive`)
/// that would exceed the memory budget.
fn check_memory(
    a: &TessellateArgs,
    mesh: &Mesh,
    adjacency: &Adjacency,
    stride: usize,
    format: MeshFormat,
    level: u32,
    adaptive: bool,
) -> anyhow::Result<()> {
    let (need, estimate, weights) = tessellation_need(
        mesh,
        adjacency.edges.len(),
        stride,
        level,
        format.needs(),
        format.buffer_bytes(level, mesh.triangles.len()),
    );
    // The grid's count, saturating where level u32::MAX overflows it (and is refused).
    let per_patch = crate::eval::grid_len(level) as u64;
    a.memory.budget().check(
        "tessellate",
        &if adaptive {
            format!("levels up to {level}")
        } else {
            format!("level {level}")
        },
        need,
        &format!(
            "{} samples per patch, {} of basis weights, stitch store of {} points, {} per \
             batch of patch output",
            human_count(per_patch),
            human_bytes(weights),
            human_count(estimate.store_points),
            human_bytes(estimate.batch_bytes)
        ),
    )
}

/// The input edges the output is cut along, by kind.
struct EdgeKinds {
    /// Interior edges whose two triangles give an end different normals: the creases, as
    /// `stats` counts them.
    creases: usize,
    /// Edges whose triangles agree on the normals but not on the texture coordinates or
    /// colours at an end (UV seams).
    seams: usize,
    /// Every edge whose samples get one record per triangle: creases, seams, and
    /// non-manifold edges whose triangles disagree on a normal.
    split: usize,
}

impl EdgeKinds {
    fn new(mesh: &Mesh, adjacency: &Adjacency, plan: &StitchPlan) -> EdgeKinds {
        let split = plan.report.split_edges;
        // The plan splits every edge whose uses disagree on an end normal (and more): where
        // it splits none, there is no crease and no seam to look for.
        if split == 0 {
            return EdgeKinds {
                creases: 0,
                seams: 0,
                split,
            };
        }
        let ends = split_ends(mesh, adjacency);
        let by_normal = ends.iter().filter(|s| s[0] || s[1]).count();
        let creases = ends
            .iter()
            .zip(&adjacency.edges)
            .filter(|(s, e)| e.is_interior() && (s[0] || s[1]))
            .count();
        EdgeKinds {
            creases,
            // The plan splits an edge where the normals or the attributes disagree.
            seams: split.saturating_sub(by_normal),
            split,
        }
    }
}

/// What was written, for the summary.
struct Tessellated<'a> {
    mesh: &'a Mesh,
    scheme: String,
    plan: &'a StitchPlan,
    format: MeshFormat,
    level: u32,
    backend: String,
    /// The precision the samples were evaluated in.
    precision: &'static str,
    edges: EdgeKinds,
    /// What the seams split: "UV seam", "colour seam" or "UV/colour seam".
    seam_kind: &'static str,
    snap: f64,
}

/// The JSON summary on stdout, or the summary lines on stderr (unless quiet); then the
/// refusal of an unmet tolerance (the file is written with the levels reached).
fn report(
    a: &TessellateArgs,
    d: &Tessellated<'_>,
    chosen: Option<&(ToleranceLevels, f64)>,
    cap: u32,
) -> anyhow::Result<()> {
    let plan = d.plan;
    if a.json {
        let mut summary = serde_json::json!({
            "output": a.output.display().to_string(),
            "mesh": d.mesh.name,
            "scheme": d.scheme,
            "level": d.level,
            "backend": d.backend,
            "precision": d.precision,
            "vertices": plan.positions,
            "triangles": plan.triangles,
            "format": d.format,
            "vertex_records": plan.records,
            "file_vertices": d.format.file_vertices(plan),
            "crease_edges": d.edges.creases,
            "seam_edges": d.edges.seams,
            "split_edges": d.edges.split,
            "boundary_edges": plan.report.boundary_edges,
            "nonmanifold_edges": plan.report.nonmanifold_edges,
            "max_weld_snap": d.snap,
        });
        if let Some((t, eps)) = chosen {
            let range = |v: &[u32]| {
                serde_json::json!([
                    v.iter().copied().min().unwrap_or(1),
                    v.iter().copied().max().unwrap_or(1)
                ])
            };
            summary["adaptive"] = serde_json::json!({
                "tolerance": eps,
                "tolerance_met": t.met,
                "max_deviation": t.deviation.max,
                "measured_triangles": t.deviation.triangles,
                "points_per_triangle": crate::tess::adaptive::DEVIATION_POINTS.len(),
                "measured_points": t.deviation.points,
                "measured_on": "the f64 reference surface of the same levels",
                "measurements": t.rounds + 1,
                "max_level": cap,
                "capped_patches": t.capped_patches,
                "edge_levels": range(&t.levels.edges),
                "inner_levels": range(&t.levels.inner),
            });
        }
        out::stdout_json(&summary.to_string())?;
    } else if !a.quiet {
        out::stderr_line(&format!(
            "wrote {}: {} vertices ({} vertex records), {} triangles; {} boundary, {} \
             non-manifold, {} crease edges, {} {} edges; max stitch snap {:.3e}",
            a.output.display(),
            plan.positions,
            plan.records,
            plan.triangles,
            plan.report.boundary_edges,
            plan.report.nonmanifold_edges,
            d.edges.creases,
            d.edges.seams,
            d.seam_kind,
            d.snap
        ));
        if let Some((t, eps)) = chosen {
            out::stderr_line(&format!(
                "tolerance {eps:.3e}: measured deviation {:.3e} at {} points of {} triangles, \
                 edge levels {}..{}, {} measurement(s)",
                t.deviation.max,
                t.deviation.points,
                t.deviation.triangles,
                t.levels.edges.iter().min().unwrap_or(&1),
                t.levels.edges.iter().max().unwrap_or(&1),
                t.rounds + 1
            ));
        }
    }
    if let Some((t, eps)) = chosen {
        anyhow::ensure!(
            t.met,
            "tolerance {eps:e} not met: the measured deviation is {:e} ({} patches at the level \
             cap {cap}; raise --max-level); {} was written with these levels",
            t.deviation.max,
            t.capped_patches,
            a.output.display()
        );
    }
    Ok(())
}
