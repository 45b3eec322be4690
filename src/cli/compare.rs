//! `g1tess compare`: Table 1 — the continuity protocol for every scheme on each mesh.

use clap::Args;

use super::out;
use super::BackendArgs;
use crate::analysis::table1;
use crate::mesh::{LoadOptions, NormalWeighting};
use crate::patch::{Scheme, SchemeOptions};

#[derive(Args, Clone, Debug)]
pub struct CompareArgs {
    /// Meshes: files (OBJ, PLY, STL, glTF .gltf/.glb, .pn) or built-ins (sphere320,
    /// torus200, icosphere:L, torus:NxM[:analytic|:averaged]); default: the paper's
    /// sphere320 and torus200.
    #[arg(default_values_t = ["sphere320".to_string(), "torus200".to_string()])]
    pub meshes: Vec<String>,
    /// Print a JSON array, one object per mesh and scheme (the fields of `stats --json`),
    /// instead of markdown.
    #[arg(long)]
    pub json: bool,
    /// Schemes to compare (comma-separated); default: all.
    #[arg(long, value_enum, value_delimiter = ',')]
    pub schemes: Vec<Scheme>,
    /// Weighting of face normals where vertex normals are estimated.
    #[arg(long, value_enum, default_value = "angle")]
    pub normals: NormalWeighting,
    /// Estimate normals even where the file gives them.
    #[arg(long)]
    pub recompute_normals: bool,
    /// Phong tessellation's shape factor α (any finite number).
    #[arg(long, default_value_t = 0.75, allow_hyphen_values = true)]
    pub phong_alpha: f64,
    #[command(flatten)]
    pub backend: BackendArgs,
    #[command(flatten)]
    pub memory: super::common::MemoryArgs,
    /// Nothing on stderr about the adapter or the CPU fallback (the table is still
    /// printed).
    #[arg(long, short)]
    pub quiet: bool,
}

impl CompareArgs {
    /// The paper's comparison (the default run's).
    pub fn paper() -> CompareArgs {
        CompareArgs {
            meshes: vec!["sphere320".into(), "torus200".into()],
            json: false,
            schemes: Vec::new(),
            normals: NormalWeighting::Angle,
            recompute_normals: false,
            phong_alpha: 0.75,
            backend: BackendArgs::default(),
            memory: Default::default(),
            quiet: false,
        }
    }

    pub fn schemes(&self) -> Vec<Scheme> {
        if self.schemes.is_empty() {
            Scheme::all()
        } else {
            self.schemes.clone()
        }
    }

    /// Runs the comparison on the chosen backend (GPU in f64 by default, else the CPU).
    pub fn reports(&self) -> anyhow::Result<Vec<crate::analysis::stats::StatsReport>> {
        // Meshes are loaded one at a time: each must fit (its statistics stream).
        let budget = self.memory.budget();
        for mesh in &self.meshes {
            budget.check_load("compare", mesh)?;
        }
        Ok(table1::compare(
            &self.meshes,
            &LoadOptions {
                weighting: self.normals,
                recompute_normals: self.recompute_normals,
                ..Default::default()
            },
            &self.schemes(),
            &SchemeOptions {
                phong_alpha: self.phong_alpha,
            },
            BackendArgs {
                quiet: self.backend.quiet || self.quiet,
                ..self.backend.clone()
            }
            .evaluator(crate::gpu::Precision::F64)?
            .as_ref(),
        )?)
    }
}

pub fn run(a: &CompareArgs) -> anyhow::Result<()> {
    let reports = a.reports()?;
    if a.json {
        out::stdout_json(&serde_json::to_string_pretty(&reports)?)?;
    } else {
        // The names as they are shown: escaped ([`out::escape`]).
        let mut reports = reports;
        for r in &mut reports {
            r.mesh = out::escape(&r.mesh).into_owned();
        }
        out::stdout(&table1::to_markdown(&reports))?;
    }
    Ok(())
}
