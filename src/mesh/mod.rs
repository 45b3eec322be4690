//! Triangle meshes with per-corner unit normals: loading, welding, normals, adjacency and
//! the built-in meshes of the paper.

pub mod adjacency;
pub mod creases;
pub mod generators;
pub mod normals;
pub mod obj;
pub mod pn;

use glam::DVec3;
use std::path::Path;

pub use adjacency::{Adjacency, EdgeUse, MeshEdge};
pub use normals::NormalWeighting;

use crate::{Error, Result};

/// A welded triangle mesh. Every position is unique (welded by exact coordinates) and used
/// by at least one triangle; normals live on triangle corners so a vertex may carry
/// different normals in different faces (split normals, creases).
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    /// Name shown in reports: the file name or the built-in spec.
    pub name: String,
    pub positions: Vec<DVec3>,
    /// Counter-clockwise seen from the side the normals point to.
    pub triangles: Vec<[u32; 3]>,
    /// Unit normal at each corner of each triangle (always renormalised).
    pub corner_normals: Vec<[DVec3; 3]>,
    /// What loading changed or found (dropped vertices, estimated normals, ...).
    pub load_report: LoadReport,
}

/// What the loader did to the input, for the statistics output.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct LoadReport {
    /// Input vertices that no face uses (dropped).
    pub unused_vertices_dropped: usize,
    /// Input vertices merged into another one at the same position.
    pub vertices_welded: usize,
    /// Triangles dropped because two of their corners are the same welded vertex.
    pub degenerate_triangles_dropped: usize,
    /// Polygons with more than three corners that were triangulated.
    pub polygons_triangulated: usize,
    /// Corners whose normal was estimated (the file gave none for them).
    pub normals_estimated: usize,
}

/// How to obtain a mesh: options shared by every command that reads one.
#[derive(Clone, Debug)]
pub struct LoadOptions {
    /// Weighting of face normals when a vertex normal must be estimated.
    pub weighting: NormalWeighting,
    /// Estimate normals even where the file gives them.
    pub recompute_normals: bool,
    /// Mark edges with a dihedral angle above this many degrees as creases and estimate
    /// normals per smoothing group (see [`creases::split_normals_by_angle`]).
    pub crease_angle: Option<f64>,
}

impl Default for LoadOptions {
    fn default() -> Self {
        Self {
            weighting: NormalWeighting::Angle,
            recompute_normals: false,
            crease_angle: None,
        }
    }
}

/// The name a mesh read from `path` carries in reports: its file name.
pub(crate) fn display_name(path: &Path) -> String {
    path.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| path.display().to_string())
}

impl Mesh {
    /// Loads a mesh from a built-in spec (see [`generators::from_spec`]) or a file (OBJ, or
    /// the point-normal format `.pn`).
    pub fn load(spec: &str, opts: &LoadOptions) -> Result<Mesh> {
        let mut mesh = if let Some(m) = generators::from_spec(spec)? {
            m
        } else {
            let path = Path::new(spec);
            if !path.exists() {
                return Err(Error::Invalid(format!(
                    "{spec}: no such file, and not a built-in mesh (built-ins: {})",
                    generators::BUILTIN_HELP
                )));
            }
            let ext = path.extension().map(|e| e.to_ascii_lowercase());
            if ext.as_deref() == Some(std::ffi::OsStr::new("pn")) {
                pn::load_pn(path)?
            } else {
                obj::load_obj(path, opts)?
            }
        };
        if opts.recompute_normals {
            let n = normals::vertex_normals(&mesh.positions, &mesh.triangles, opts.weighting);
            mesh.corner_normals = mesh
                .triangles
                .iter()
                .map(|t| t.map(|v| n[v as usize]))
                .collect();
        }
        if let Some(angle) = opts.crease_angle {
            creases::split_normals_by_angle(&mut mesh, angle, opts.weighting)?;
        }
        mesh.validate()?;
        Ok(mesh)
    }

    /// Checks the invariants every later stage relies on: at least one triangle, indices in
    /// range, finite coordinates, unit normals.
    pub fn validate(&self) -> Result<()> {
        if self.triangles.is_empty() {
            return Err(Error::mesh(&self.name, "empty mesh: no triangles"));
        }
        if self.corner_normals.len() != self.triangles.len() {
            return Err(Error::mesh(&self.name, "normals do not match triangles"));
        }
        for (i, p) in self.positions.iter().enumerate() {
            if !p.is_finite() {
                return Err(Error::mesh(
                    &self.name,
                    format!("vertex {i} has a non-finite coordinate"),
                ));
            }
        }
        let nv = self.positions.len() as u32;
        for (t, tri) in self.triangles.iter().enumerate() {
            if tri.iter().any(|&v| v >= nv) {
                return Err(Error::mesh(
                    &self.name,
                    format!("triangle {t} has a vertex index out of range"),
                ));
            }
            for n in &self.corner_normals[t] {
                if !n.is_finite() || (n.length() - 1.0).abs() > 1e-9 {
                    return Err(Error::mesh(
                        &self.name,
                        format!("triangle {t} has a zero or non-finite normal"),
                    ));
                }
            }
        }
        Ok(())
    }

    /// Axis-aligned bounding box (min, max) of the positions.
    pub fn bbox(&self) -> (DVec3, DVec3) {
        self.positions.iter().fold(
            (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
            |(lo, hi), p| (lo.min(*p), hi.max(*p)),
        )
    }

    /// Length of the bounding-box diagonal.
    pub fn diagonal(&self) -> f64 {
        let (lo, hi) = self.bbox();
        (hi - lo).length()
    }

    /// Builds a mesh with one normal per vertex.
    pub fn from_vertex_normals(
        name: impl Into<String>,
        positions: Vec<DVec3>,
        normals: &[DVec3],
        triangles: Vec<[u32; 3]>,
    ) -> Mesh {
        let corner_normals = triangles
            .iter()
            .map(|t| t.map(|v| normals[v as usize].normalize()))
            .collect();
        Mesh {
            name: name.into(),
            positions,
            triangles,
            corner_normals,
            load_report: LoadReport::default(),
        }
    }

    /// Edge adjacency of the triangles.
    pub fn adjacency(&self) -> Adjacency {
        Adjacency::new(&self.triangles)
    }
}
