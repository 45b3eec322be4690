//! Triangle meshes with per-corner unit normals: loading, welding, normals, adjacency and
//! the built-in meshes of the paper.

pub mod adjacency;
pub mod creases;
pub mod generators;
pub mod normals;
pub mod obj;
pub mod pn_file;
pub mod weld;

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
                pn_file::load_pn(path)?
            } else {
                obj::load_obj(path, opts)?
            }
        };
        mesh.apply_options(opts)?;
        Ok(mesh)
    }

    /// What every source does last: the options' normal recomputation and crease split,
    /// then [`Mesh::validate`].
    fn apply_options(&mut self, opts: &LoadOptions) -> Result<()> {
        if opts.recompute_normals {
            let n = normals::vertex_normals(&self.positions, &self.triangles, opts.weighting);
            self.corner_normals = self
                .triangles
                .iter()
                .map(|t| t.map(|v| n[v as usize]))
                .collect();
        }
        if let Some(angle) = opts.crease_angle {
            creases::split_normals_by_angle(self, angle, opts.weighting)?;
        }
        self.validate()
    }

    /// Builds a mesh from an in-memory triangle soup, the way a renderer or another library
    /// holds one: `positions`, `triangles` indexing them (counter-clockwise seen from the
    /// outside) and, optionally, one normal per position.
    ///
    /// The input is checked first: a non-finite coordinate, a zero or non-finite normal, a
    /// normal count that differs from the position count or a triangle index out of range is
    /// an error naming the element (`"NAME: vertex 12 has a non-finite coordinate"`). The soup
    /// is then welded exactly like file input ([`weld::weld`]: equal coordinates, `-0.0`
    /// equal to `0.0`, so a split-vertex mesh comes out closed); triangles that collapse and
    /// unused vertices are dropped and counted in [`Mesh::load_report`]. Each corner keeps
    /// the normal given for its input vertex (renormalised), so split normals survive the
    /// weld; without normals they are estimated with `opts.weighting`. The options'
    /// normal recomputation and crease angle apply as for [`Mesh::load`].
    ///
    /// ```
    /// use g1tess::eval::{cpu::CpuEvaluator, Evaluator, Pattern};
    /// use g1tess::mesh::{LoadOptions, Mesh};
    /// use g1tess::patch::{PatchTable, Scheme, SchemeOptions};
    ///
    /// // A tetrahedron, outward, without normals (they are estimated).
    /// let positions = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    /// let triangles = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
    /// let mesh = Mesh::from_soup("tetra", &positions, &triangles, None, &LoadOptions::default())?;
    /// let table = PatchTable::build(&mesh, Scheme::G1, &SchemeOptions::default())?;
    /// let (points, normals) =
    ///     CpuEvaluator::default().evaluate_all(&table, &Pattern::Grid { level: 8 })?;
    /// assert_eq!(points.len(), 4 * 45); // 45 samples per patch at level 8
    /// assert!(normals.iter().all(|n| (n.length() - 1.0).abs() < 1e-12));
    /// # Ok::<(), g1tess::Error>(())
    /// ```
    pub fn from_soup<P: Copy + Into<DVec3>>(
        name: impl Into<String>,
        positions: &[P],
        triangles: &[[u32; 3]],
        normals: Option<&[P]>,
        opts: &LoadOptions,
    ) -> Result<Mesh> {
        let name = name.into();
        let positions: Vec<DVec3> = positions.iter().map(|&p| p.into()).collect();
        if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
            return Err(Error::mesh(
                &name,
                format!("vertex {i} has a non-finite coordinate"),
            ));
        }
        let nv = positions.len();
        if let Some((t, v)) = triangles
            .iter()
            .enumerate()
            .find_map(|(t, tri)| tri.iter().find(|&&v| v as usize >= nv).map(|&v| (t, v)))
        {
            return Err(Error::mesh(
                &name,
                format!(
                    "triangle {t} has vertex index {v}, out of range (the soup has {nv} vertices)"
                ),
            ));
        }
        let unit: Option<Vec<DVec3>> = match normals {
            None => None,
            Some(n) if n.len() != nv => {
                return Err(Error::mesh(
                    &name,
                    format!(
                        "{} normals for {nv} vertices (one per vertex expected)",
                        n.len()
                    ),
                ))
            }
            Some(n) => Some(
                n.iter()
                    .enumerate()
                    .map(|(i, &n)| {
                        let n: DVec3 = n.into();
                        let len = n.length();
                        if len == 0.0 || !len.is_finite() {
                            Err(Error::mesh(
                                &name,
                                format!("normal {i} is zero or non-finite"),
                            ))
                        } else {
                            Ok(n / len)
                        }
                    })
                    .collect::<Result<_>>()?,
            ),
        };
        let mut corner_normals: Vec<[DVec3; 3]> = match &unit {
            Some(n) => triangles.iter().map(|t| t.map(|v| n[v as usize])).collect(),
            None => Vec::new(),
        };
        let mut triangles = triangles.to_vec();
        let mut report = LoadReport::default();
        let positions = weld::weld(&positions, &mut triangles, &mut corner_normals, &mut report)?;
        if triangles.is_empty() {
            return Err(Error::mesh(
                &name,
                if report.degenerate_triangles_dropped > 0 {
                    "empty mesh: every triangle is degenerate"
                } else {
                    "empty mesh: no triangles"
                },
            ));
        }
        if unit.is_none() {
            report.normals_estimated = 3 * triangles.len();
            let n = normals::vertex_normals(&positions, &triangles, opts.weighting);
            corner_normals = triangles.iter().map(|t| t.map(|v| n[v as usize])).collect();
        }
        let mut mesh = Mesh {
            name,
            positions,
            triangles,
            corner_normals,
            load_report: report,
        };
        mesh.apply_options(opts)?;
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

    /// Edge adjacency of the triangles.
    pub fn adjacency(&self) -> Adjacency {
        Adjacency::new(&self.triangles)
    }
}
