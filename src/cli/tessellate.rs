//! `g1tess tessellate`: evaluate every patch on a grid in f32 and write the stitched
//! surface: the evaluator's f32 path (the CPU's SIMD kernel, the GPU's f32 shaders) feeds
//! the stitcher and the writer in f32, with no f64 round trip.

use std::path::PathBuf;

use clap::Args;

use super::common::{human_bytes, human_count, tessellation_need, MemoryArgs};
use super::progress;
use super::TEMP_FILES;
use super::{BackendArgs, InputArgs};
use crate::io::atomic;
use crate::io::writers::{write_stitched, MeshFormat};
use crate::tess::adaptive::{levels_for_tolerance, ToleranceLevels, ToleranceOptions};
use crate::tess::stitch::{stitch_into, StitchPlan};

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
    /// Grid level: n segments per edge, (n+1)(n+2)/2 points per patch.
    #[arg(long, default_value_t = 8, conflicts_with_all = ["tolerance", "tolerance_rel"])]
    pub level: u32,
    /// Instead of --level: choose a level per edge and per patch so that the flat output
    /// triangles deviate from the curved surface by at most EPS (absolute, the mesh's
    /// units), measured at 10 points inside every output triangle.
    #[arg(long, value_name = "EPS", conflicts_with = "tolerance_rel")]
    pub tolerance: Option<f64>,
    /// Like --tolerance, with EPS = R × the diagonal of the mesh's bounding box.
    #[arg(long, value_name = "R")]
    pub tolerance_rel: Option<f64>,
    /// Cap on the levels --tolerance may choose.
    #[arg(long, value_name = "N")]
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
    /// "vertices", "triangles", ...} (see the README).
    #[arg(long)]
    pub json: bool,
    /// No progress bars and no summary line on stderr.
    #[arg(long, short)]
    pub quiet: bool,
}

pub fn run(a: &TessellateArgs) -> anyhow::Result<()> {
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
        atomic::refuse_same_file(&a.output, std::path::Path::new(&a.input.mesh))?;
    }
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
    let (mesh, table, folds) = a.input.load()?;
    if let Some(line) = folds {
        eprintln!("{line}");
    }
    let adjacency = mesh.adjacency();
    let eps = match (a.tolerance, a.tolerance_rel) {
        (Some(t), _) => Some(t),
        (None, Some(r)) => Some(r * mesh.diagonal()),
        (None, None) => None,
    };
    let chosen: Option<ToleranceLevels> = match eps {
        Some(eps) => {
            // The levels are not known before they are measured: refuse up front what the
            // cap could need (the measurements hold the same stitch store, in f64).
            let (need, _, _) = tessellation_need(
                &mesh,
                adjacency.edges.len(),
                table.stride,
                cap,
                format.needs(),
                format.buffer_bytes(cap, mesh.triangles.len()),
            );
            a.memory.budget().check(
                "tessellate",
                &format!("levels up to the cap {cap}"),
                need.saturating_mul(2),
                "the f64 measurements at the level cap; lower --max-level",
            )?;
            let bar = progress::bar(mesh.triangles.len() as u64, "measuring", "patches", a.quiet);
            let t = levels_for_tolerance(
                &mesh,
                &adjacency,
                &table,
                &crate::eval::cpu::CpuEvaluator::default(),
                &ToleranceOptions {
                    tolerance: eps,
                    max_level: cap,
                    rounds: TOLERANCE_ROUNDS,
                },
                &bar,
            )?;
            bar.finish();
            Some(t)
        }
        None => None,
    };
    // The memory estimate of the largest level (an upper bound for per-edge levels), made
    // before the plan is built.
    let level = match &chosen {
        Some(t) => t
            .levels
            .edges
            .iter()
            .chain(&t.levels.inner)
            .copied()
            .max()
            .unwrap_or(1),
        None => a.level,
    };
    let (need, estimate, weights) = tessellation_need(
        &mesh,
        adjacency.edges.len(),
        table.stride,
        level,
        format.needs(),
        format.buffer_bytes(level, mesh.triangles.len()),
    );
    let per_patch = (level as u64 + 1) * (level as u64 + 2) / 2;
    a.memory.budget().check(
        "tessellate",
        &if chosen.is_none() {
            format!("level {level}")
        } else {
            format!("levels up to {level}")
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
    )?;
    let plan = match &chosen {
        Some(t) => StitchPlan::with_levels(&mesh, &adjacency, &t.levels)?,
        None => StitchPlan::new(&mesh, &adjacency, a.level)?,
    };
    let backend = BackendArgs {
        quiet: a.quiet,
        ..a.backend.clone()
    };
    let evaluator = backend.evaluator(crate::gpu::Precision::F32)?;
    let title = match (&chosen, eps) {
        (Some(_), Some(eps)) => format!(
            "g1tess: {}, scheme {}, tolerance {eps:e}",
            mesh.name, table.scheme
        ),
        _ => format!(
            "g1tess: {}, scheme {}, level {}",
            mesh.name, table.scheme, a.level
        ),
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
            snap = stitch_into(&plan, &table, evaluator.as_ref(), sink, &bar)?;
            Ok(())
        },
    )?;
    bar.finish();
    if a.json {
        let mut summary = serde_json::json!({
            "output": a.output.display().to_string(),
            "mesh": mesh.name,
            "scheme": table.scheme.to_string(),
            "level": level,
            "backend": evaluator.describe(),
            "precision": "f32",
            "vertices": plan.positions,
            "triangles": plan.triangles,
            "format": format,
            "vertex_records": plan.records,
            "file_vertices": format.file_vertices(&plan),
            "crease_edges": plan.report.split_edges,
            "boundary_edges": plan.report.boundary_edges,
            "nonmanifold_edges": plan.report.nonmanifold_edges,
            "max_weld_snap": snap,
        });
        if let (Some(t), Some(eps)) = (&chosen, eps) {
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
        println!("{summary}");
    } else if !a.quiet {
        eprintln!(
            "wrote {}: {} vertices ({} with split normals), {} triangles; \
             {} boundary, {} non-manifold, {} crease edges; max stitch snap {:.3e}",
            a.output.display(),
            plan.positions,
            plan.records,
            plan.triangles,
            plan.report.boundary_edges,
            plan.report.nonmanifold_edges,
            plan.report.split_edges,
            snap
        );
        if let (Some(t), Some(eps)) = (&chosen, eps) {
            eprintln!(
                "tolerance {eps:.3e}: measured deviation {:.3e} at {} points of {} triangles, \
                 edge levels {}..{}, {} measurement(s)",
                t.deviation.max,
                t.deviation.points,
                t.deviation.triangles,
                t.levels.edges.iter().min().unwrap_or(&1),
                t.levels.edges.iter().max().unwrap_or(&1),
                t.rounds + 1
            );
        }
    }
    if let (Some(t), Some(eps)) = (&chosen, eps) {
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
