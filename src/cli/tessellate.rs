//! `g1tess tessellate`: evaluate every patch on a grid in f32 and write the stitched
//! surface: the evaluator's f32 path (the CPU's SIMD kernel, the GPU's f32 shaders) feeds
//! the stitcher and the writer in f32, with no f64 round trip.

use std::path::PathBuf;

use clap::Args;

use super::common::{human_bytes, human_count, tessellation_need, MemoryArgs};
use super::progress;
use super::{BackendArgs, InputArgs};
use crate::output::atomic;
use crate::output::writers::{write_stitched, MeshFormat};
use crate::tess::stitch::{stitch_into, StitchPlan};

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
    #[arg(long, default_value_t = 8)]
    pub level: u32,
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
    let (mesh, table) = a.input.load()?;
    if let Some(w) = crate::patch::validity::fold_warning(&mesh, &table, &a.input.scheme_options())?
    {
        eprintln!("{w}");
    }
    let adjacency = mesh.adjacency();
    let (need, estimate, weights) = tessellation_need(
        &mesh,
        adjacency.edges.len(),
        table.stride,
        a.level,
        format.needs(),
        format.buffer_bytes(a.level, mesh.triangles.len()),
    );
    let per_patch = (a.level as u64 + 1) * (a.level as u64 + 2) / 2;
    a.memory.budget().check(
        "tessellate",
        &format!("level {}", a.level),
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
    let plan = StitchPlan::new(&mesh, &adjacency, a.level)?;
    let backend = BackendArgs {
        quiet: a.quiet,
        ..a.backend.clone()
    };
    let evaluator = backend.evaluator(crate::gpu::Precision::F32)?;
    let title = format!(
        "g1tess: {}, scheme {}, level {}",
        mesh.name, table.scheme, a.level
    );
    let bar = progress::bar(plan.patches() as u64, "evaluating", "patches", a.quiet);
    let mut snap = 0.0;
    write_stitched::<[f32; 3]>(&a.output, format, &plan, &title, &bar, &mut |sink| {
        snap = stitch_into(&plan, &table, evaluator.as_ref(), sink, &bar)?;
        Ok(())
    })?;
    bar.finish();
    if a.json {
        let summary = serde_json::json!({
            "output": a.output.display().to_string(),
            "mesh": mesh.name,
            "scheme": table.scheme.to_string(),
            "level": a.level,
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
    }
    Ok(())
}
