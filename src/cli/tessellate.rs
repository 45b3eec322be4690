//! `g1tess tessellate`: evaluate every patch on a grid in f32 and write the stitched
//! surface: the evaluator's f32 path (the CPU's SIMD kernel, the GPU's f32 shaders) feeds
//! the stitcher and the writer in f32, with no f64 round trip.

use std::path::PathBuf;

use clap::Args;

use super::progress;
use super::{BackendArgs, InputArgs};
use crate::output::writers::{write_stitched, MeshFormat};
use crate::tess::stitch::{stitch_into, StitchPlan};

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
