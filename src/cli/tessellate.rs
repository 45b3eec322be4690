//! `g1tess tessellate`: evaluate every patch on a grid and write the welded surface.

use std::path::PathBuf;

use clap::Args;

use super::{BackendArgs, InputArgs};
use crate::output::progress;
use crate::output::weld::{weld_into, WeldPlan};
use crate::output::writers::{write_welded, MeshFormat};

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
    /// .glb (glTF 2.0 binary).
    #[arg(short, long)]
    pub output: PathBuf,
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
    let format = MeshFormat::from_path(&a.output)?;
    let (mesh, table) = a.input.load()?;
    let adjacency = mesh.adjacency();
    let plan = WeldPlan::new(&mesh, &adjacency, a.level)?;
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
    write_welded(&a.output, format, &plan, &title, &bar, &mut |sink| {
        snap = weld_into(&plan, &table, evaluator.as_ref(), sink, &mut |k| {
            bar.inc(k as u64)
        })?;
        bar.set_position(0);
        bar.set_message("writing faces");
        Ok(())
    })?;
    bar.finish_and_clear();
    if a.json {
        let summary = serde_json::json!({
            "output": a.output.display().to_string(),
            "mesh": mesh.name,
            "scheme": table.scheme.to_string(),
            "level": a.level,
            "backend": evaluator.describe(),
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
             {} boundary, {} non-manifold, {} crease edges; max weld snap {:.3e}",
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
