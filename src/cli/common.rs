//! Arguments shared by every command that reads a mesh.

use clap::Args;

use crate::mesh::{LoadOptions, Mesh, NormalWeighting};
use crate::patch::{PatchTable, Scheme, SchemeOptions};

#[derive(Args, Clone, Debug)]
pub struct InputArgs {
    /// Mesh file (.obj, or .pn point-normal) or built-in mesh: sphere320, torus200, icosphere:L,
    /// torus:NxM[:analytic|:averaged].
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
    /// per smoothing group (replaces any normals the file gives).
    #[arg(long, value_name = "DEG")]
    pub crease_angle: Option<f64>,
    /// Phong tessellation's shape factor α.
    #[arg(long, default_value_t = 0.75)]
    pub phong_alpha: f64,
}

impl InputArgs {
    /// Defaults for a built-in mesh (the default run).
    pub fn builtin(mesh: &str) -> InputArgs {
        InputArgs {
            mesh: mesh.into(),
            scheme: Scheme::G1,
            normals: NormalWeighting::Angle,
            recompute_normals: false,
            crease_angle: None,
            phong_alpha: 0.75,
        }
    }

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

    /// Loads the mesh and builds the scheme's patch table.
    pub fn load(&self) -> anyhow::Result<(Mesh, PatchTable)> {
        let mesh = Mesh::load(&self.mesh, &self.load_options())?;
        let table = PatchTable::build(&mesh, self.scheme, &self.scheme_options())?;
        Ok((mesh, table))
    }
}
