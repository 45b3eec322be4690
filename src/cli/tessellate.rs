//! `g1tess tessellate`: evaluate every patch on a grid and write the surface.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;

use super::{BackendArgs, InputArgs};
use crate::eval::{grid_len, grid_triangles, Pattern};
use crate::output::writers::{write_obj, IndexedMesh};

#[derive(Args, Clone, Debug)]
pub struct TessellateArgs {
    #[command(flatten)]
    pub input: InputArgs,
    #[command(flatten)]
    pub backend: BackendArgs,
    /// Grid level: n segments per edge, (n+1)(n+2)/2 points per patch.
    #[arg(long, default_value_t = 8)]
    pub level: u32,
    /// Output file (.obj).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Print a JSON summary on stdout: {"output", "mesh", "scheme", "level", "backend",
    /// "vertices", "triangles"}.
    #[arg(long)]
    pub json: bool,
}

pub fn run(a: &TessellateArgs) -> anyhow::Result<()> {
    anyhow::ensure!(a.level >= 1, "--level must be at least 1");
    let (mesh, table) = a.input.load()?;
    let evaluator = a.backend.evaluator(crate::gpu::Precision::F32)?;
    let per = grid_len(a.level);
    let local = grid_triangles(a.level);
    let mut out = IndexedMesh::default();
    evaluator.evaluate(&table, &Pattern::Grid { level: a.level }, &mut |chunk| {
        out.positions.extend_from_slice(chunk.positions);
        out.normals.extend_from_slice(chunk.normals);
        Ok(())
    })?;
    for p in 0..table.len() {
        let base = (p * per) as u32;
        out.triangles
            .extend(local.iter().map(|t| t.map(|i| i + base)));
    }
    write_obj(&a.output, &out).with_context(|| format!("writing {}", a.output.display()))?;
    if a.json {
        let summary = serde_json::json!({
            "output": a.output.display().to_string(),
            "mesh": mesh.name,
            "scheme": table.scheme.to_string(),
            "level": a.level,
            "backend": evaluator.describe(),
            "vertices": out.positions.len(),
            "triangles": out.triangles.len(),
        });
        println!("{summary}");
    } else {
        eprintln!(
            "wrote {}: {} vertices, {} triangles",
            a.output.display(),
            out.positions.len(),
            out.triangles.len()
        );
    }
    Ok(())
}
