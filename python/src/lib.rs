//! `g1tess._native`: the compiled part of the `g1tess` package (python/g1tess).
//!
//! [`PyMesh`] (`g1tess._native.Mesh`) holds a welded mesh and the scheme options it was
//! loaded with; [`load`] reads one from a file or a built-in spec. Arrays cross as numpy
//! arrays: inputs are read in place (C-contiguous, of the dtype asked for), outputs are
//! Rust buffers handed to numpy without a copy (a tessellation's as the stitcher made
//! them, a mesh's arrays copied once out of the mesh). Every call releases the GIL while
//! the library works. Library errors become `OSError` (files; `FileNotFoundError` for a
//! missing one) or `ValueError` (anything else) with the library's one-line message, the
//! text the command line prints after `error: `.

use std::io::ErrorKind;
use std::path::{Path, PathBuf};

use g1tess::{
    export_msh, generators, levels_for_tolerance, stats_report, stitch_into, write_stitched,
    CpuEvaluator, FairOptions, LoadOptions, Mesh, MeshFormat, NoProgress, NormalWeighting,
    PatchTable, RepairOptions, RepairReport, Scheme, SchemeOptions, StitchPlan, StitchedMesh,
    TempFiles, ToleranceLevels, ToleranceOptions, MAX_LEVEL,
};
use numpy::ndarray::{Array2, Array3};
use numpy::{IntoPyArray, PyArray2, PyArray3, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::{
    PyFileNotFoundError, PyIsADirectoryError, PyOSError, PyPermissionError, PyValueError,
};
use pyo3::prelude::*;

/// Default cap on the levels a tolerance chooses (`g1tess tessellate --max-level`).
const DEFAULT_MAX_LEVEL: u32 = 64;

/// Refinement rounds after the first measurement when a tolerance chooses the levels, as
/// `g1tess tessellate --tolerance` runs them.
const TOLERANCE_ROUNDS: u32 = 8;

/// Grid level when neither a level nor a tolerance is given (`g1tess tessellate`).
const DEFAULT_LEVEL: u32 = 8;

/// The library's error as the Python exception of its kind.
fn py_err(e: g1tess::Error) -> PyErr {
    let message = e.to_string();
    match e {
        g1tess::Error::Io { cause, .. } => match cause.kind() {
            ErrorKind::NotFound => PyFileNotFoundError::new_err(message),
            ErrorKind::PermissionDenied => PyPermissionError::new_err(message),
            ErrorKind::IsADirectory => PyIsADirectoryError::new_err(message),
            _ => PyOSError::new_err(message),
        },
        _ => PyValueError::new_err(message),
    }
}

/// The error of `Mesh::load(spec)`: `FileNotFoundError` where `spec` names neither a file
/// nor a built-in mesh (the library reports that as a bad argument), else [`py_err`].
fn load_err(spec: &str, e: g1tess::Error) -> PyErr {
    // `spec_triangles` answers without building a mesh; where it finds no well-formed
    // built-in, `from_spec` only parses (an error for a malformed one, `None` otherwise).
    let missing = matches!(e, g1tess::Error::Invalid(_))
        && generators::spec_triangles(spec).is_none()
        && !Path::new(spec).exists()
        && matches!(generators::from_spec(spec), Ok(None));
    if missing {
        PyFileNotFoundError::new_err(e.to_string())
    } else {
        py_err(e)
    }
}

fn invalid(message: impl Into<String>) -> g1tess::Error {
    g1tess::Error::Invalid(message.into())
}

fn scheme(name: &str) -> PyResult<Scheme> {
    Scheme::parse(name).map_err(py_err)
}

/// The evaluator for `backend`: the package runs on the CPU (`auto` included).
fn evaluator(backend: &str) -> PyResult<CpuEvaluator> {
    match backend {
        "cpu" | "auto" => Ok(CpuEvaluator::default()),
        "gpu" => Err(PyValueError::new_err(
            "backend 'gpu' is not available: the g1tess Python package runs on the CPU \
             (backend 'cpu' or 'auto'); the g1tess command line has the GPU backend",
        )),
        other => Err(PyValueError::new_err(format!(
            "unknown backend '{other}' (known: cpu, auto)"
        ))),
    }
}

/// The options of `g1tess --normals/--recompute-normals/--crease-angle` (load) and
/// `--phong-alpha` (patches).
fn options(
    weighting: &str,
    recompute_normals: bool,
    crease_angle: Option<f64>,
    phong_alpha: f64,
) -> PyResult<(LoadOptions, SchemeOptions)> {
    let weighting = match weighting {
        "angle" => NormalWeighting::Angle,
        "area" => NormalWeighting::Area,
        "unweighted" => NormalWeighting::Unweighted,
        other => {
            return Err(PyValueError::new_err(format!(
                "unknown normal weighting '{other}' (known: angle, area, unweighted)"
            )))
        }
    };
    if !phong_alpha.is_finite() {
        return Err(PyValueError::new_err(format!(
            "phong_alpha must be a finite number, got {phong_alpha}"
        )));
    }
    let load = LoadOptions::default()
        .with_weighting(weighting)
        .with_recompute_normals(recompute_normals)
        .with_crease_angle(crease_angle);
    let scheme = SchemeOptions::default().with_phong_alpha(phong_alpha);
    Ok((load, scheme))
}

/// The fold repair (`--repair-folds`): the mesh with repaired normals and the report.
fn repair(
    mesh: &Mesh,
    scheme: Scheme,
    opts: &SchemeOptions,
) -> g1tess::Result<(Mesh, RepairReport)> {
    g1tess::repair(
        mesh,
        scheme,
        &RepairOptions::default().with_scheme_options(*opts),
    )
}

/// How a tessellation chooses its grid (`g1tess tessellate --level`, or `--tolerance` /
/// `--tolerance-rel` with `--max-level`).
#[derive(Clone, Copy, Debug)]
enum Grid {
    Uniform(u32),
    /// Levels per edge and per patch within a distance, absolute or relative to the
    /// bounding box's diagonal, each at most `cap`.
    Tolerance {
        distance: Distance,
        cap: u32,
    },
}

#[derive(Clone, Copy, Debug)]
enum Distance {
    Absolute(f64),
    Relative(f64),
}

impl Grid {
    /// The grid the arguments ask for, checked as `g1tess tessellate` checks them.
    fn new(
        level: Option<u32>,
        tolerance: Option<f64>,
        tolerance_rel: Option<f64>,
        max_level: Option<u32>,
    ) -> PyResult<Grid> {
        let distance = match (tolerance, tolerance_rel) {
            (Some(_), Some(_)) => {
                return Err(PyValueError::new_err(
                    "tolerance and tolerance_rel exclude each other",
                ))
            }
            (Some(t), None) => Some((t, Distance::Absolute(t))),
            (None, Some(r)) => Some((r, Distance::Relative(r))),
            (None, None) => None,
        };
        let Some((t, distance)) = distance else {
            if max_level.is_some() {
                return Err(PyValueError::new_err(
                    "max_level caps the levels tolerance or tolerance_rel choose; give one of \
                     them",
                ));
            }
            let level = level.unwrap_or(DEFAULT_LEVEL);
            if level == 0 {
                return Err(PyValueError::new_err("level must be at least 1"));
            }
            return Ok(Grid::Uniform(level));
        };
        if level.is_some() {
            return Err(PyValueError::new_err(
                "level and tolerance (or tolerance_rel) exclude each other",
            ));
        }
        if !(t.is_finite() && t > 0.0) {
            return Err(PyValueError::new_err(format!(
                "tolerance and tolerance_rel take a positive distance (got {t})"
            )));
        }
        let cap = max_level.unwrap_or(DEFAULT_MAX_LEVEL);
        if !(1..=MAX_LEVEL).contains(&cap) {
            return Err(PyValueError::new_err(format!(
                "max_level must be in 1..={MAX_LEVEL}"
            )));
        }
        Ok(Grid::Tolerance { distance, cap })
    }

    /// The stitch plan of `table` on this grid (the levels measured where a tolerance
    /// chooses them), the title the writers put in a file, and what the tolerance met.
    fn plan(self, mesh: &Mesh, table: &PatchTable) -> g1tess::Result<Planned> {
        let adjacency = mesh.adjacency();
        let (distance, cap) = match self {
            Grid::Uniform(level) => {
                return Ok(Planned {
                    plan: StitchPlan::new(mesh, &adjacency, level)?,
                    title: format!(
                        "g1tess: {}, scheme {}, level {level}",
                        mesh.name, table.scheme
                    ),
                    tolerance: None,
                })
            }
            Grid::Tolerance { distance, cap } => (distance, cap),
        };
        let eps = match distance {
            Distance::Absolute(t) => t,
            Distance::Relative(r) => r * mesh.diagonal(),
        };
        let chosen = levels_for_tolerance(
            mesh,
            &adjacency,
            table,
            &CpuEvaluator::default(),
            &ToleranceOptions::default()
                .with_tolerance(eps)
                .with_max_level(cap)
                .with_rounds(TOLERANCE_ROUNDS),
            &NoProgress,
        )?;
        Ok(Planned {
            plan: StitchPlan::with_levels(mesh, &adjacency, &chosen.levels)?,
            title: format!(
                "g1tess: {}, scheme {}, tolerance {eps:e}",
                mesh.name, table.scheme
            ),
            tolerance: Some((chosen, eps, cap)),
        })
    }
}

/// A stitch plan ready to evaluate ([`Grid::plan`]).
struct Planned {
    plan: StitchPlan,
    title: String,
    /// Where a tolerance chose the levels: what was measured, the distance and the cap.
    tolerance: Option<(ToleranceLevels, f64, u32)>,
}

impl Planned {
    /// Fails, as `g1tess tessellate` does after writing, where the measured deviation
    /// exceeds the tolerance; `written` names the file written all the same.
    fn check_met(&self, written: Option<&Path>) -> g1tess::Result<()> {
        let Some((t, eps, cap)) = &self.tolerance else {
            return Ok(());
        };
        if t.met {
            return Ok(());
        }
        let written = written
            .map(|p| format!("; {} was written with these levels", p.display()))
            .unwrap_or_default();
        Err(invalid(format!(
            "tolerance {eps:e} not met: the measured deviation is {:e} ({} patches at the \
             level cap {cap}; raise max_level){written}",
            t.deviation.max, t.capped_patches
        )))
    }
}

/// (rows, 3) of `a` as triples, read in place.
fn triples<'a, T: numpy::Element>(
    what: &str,
    a: &'a PyReadonlyArray2<'_, T>,
) -> PyResult<&'a [[T; 3]]> {
    if a.shape()[1] != 3 {
        return Err(PyValueError::new_err(format!(
            "{what} must have shape (N, 3), got {:?}",
            a.shape()
        )));
    }
    Ok(a.as_slice()?.as_chunks::<3>().0)
}

/// A triangle mesh with per-corner unit normals and the scheme options it was loaded with
/// (`g1tess.Mesh` wraps it).
#[pyclass(name = "Mesh", module = "g1tess._native", frozen)]
struct PyMesh {
    mesh: Mesh,
    options: SchemeOptions,
}

#[pymethods]
impl PyMesh {
    /// Mesh(name, vertices, triangles, normals, *, normal_weighting="angle",
    /// recompute_normals=False, crease_angle=None, phong_alpha=0.75): a triangle soup
    /// (C-contiguous float64 (N, 3), uint32 (M, 3), float64 (N, 3) or None), welded like
    /// file input (`Mesh::from_soup`). The arrays are read in place with the GIL
    /// released: no thread may write them until the call returns.
    #[new]
    #[pyo3(signature = (
        name, vertices, triangles, normals=None, *, normal_weighting="angle",
        recompute_normals=false, crease_angle=None, phong_alpha=0.75
    ))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        name: String,
        vertices: PyReadonlyArray2<'_, f64>,
        triangles: PyReadonlyArray2<'_, u32>,
        normals: Option<PyReadonlyArray2<'_, f64>>,
        normal_weighting: &str,
        recompute_normals: bool,
        crease_angle: Option<f64>,
        phong_alpha: f64,
    ) -> PyResult<PyMesh> {
        let (load, options) = options(
            normal_weighting,
            recompute_normals,
            crease_angle,
            phong_alpha,
        )?;
        let v = triples("vertices", &vertices)?;
        let t = triples("triangles", &triangles)?;
        let n = normals
            .as_ref()
            .map(|n| triples("normals", n))
            .transpose()?;
        let mesh = py
            .detach(|| Mesh::from_soup(name, v, t, n, &load))
            .map_err(py_err)?;
        Ok(PyMesh { mesh, options })
    }

    /// The name shown in reports (the file name, or the soup's name).
    #[getter]
    fn name(&self) -> &str {
        &self.mesh.name
    }

    /// Welded vertex positions, (N, 3) float64.
    #[getter]
    fn vertices<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let v: Vec<[f64; 3]> = self.mesh.positions.iter().map(|p| p.to_array()).collect();
        Array2::from(v).into_pyarray(py)
    }

    /// Triangles as indices into the vertices, (M, 3) uint32.
    #[getter]
    fn triangles<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<u32>> {
        Array2::from(self.mesh.triangles.clone()).into_pyarray(py)
    }

    /// Unit normal of each corner of each triangle, (M, 3, 3) float64.
    #[getter]
    fn corner_normals<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray3<f64>> {
        let n: Vec<[[f64; 3]; 3]> = self
            .mesh
            .corner_normals
            .iter()
            .map(|c| c.map(|n| n.to_array()))
            .collect();
        Array3::from(n).into_pyarray(py)
    }

    /// tessellate(scheme="g1", level=None, *, tolerance=None, tolerance_rel=None,
    /// max_level=None, backend="cpu") -> (positions float32 (V, 3), triangles uint32
    /// (F, 3), normals float32 (V, 3)): the stitched surface's vertex records as `g1tess
    /// tessellate --backend cpu` writes them to PLY.
    #[pyo3(signature = (
        scheme="g1", level=None, *, tolerance=None, tolerance_rel=None, max_level=None,
        backend="cpu"
    ))]
    #[allow(clippy::type_complexity, clippy::too_many_arguments)]
    fn tessellate<'py>(
        &self,
        py: Python<'py>,
        scheme: &str,
        level: Option<u32>,
        tolerance: Option<f64>,
        tolerance_rel: Option<f64>,
        max_level: Option<u32>,
        backend: &str,
    ) -> PyResult<(
        Bound<'py, PyArray2<f32>>,
        Bound<'py, PyArray2<u32>>,
        Bound<'py, PyArray2<f32>>,
    )> {
        let scheme = self::scheme(scheme)?;
        let grid = Grid::new(level, tolerance, tolerance_rel, max_level)?;
        let ev = evaluator(backend)?;
        let out = py
            .detach(|| -> g1tess::Result<_> {
                let table = PatchTable::build(&self.mesh, scheme, &self.options)?;
                let planned = grid.plan(&self.mesh, &table)?;
                let mut out = StitchedMesh::<[f32; 3]>::default();
                stitch_into(&planned.plan, &table, &ev, &mut out, &NoProgress)?;
                planned.check_met(None)?;
                Ok(out)
            })
            .map_err(py_err)?;
        let positions = Array2::from(out.record_positions()).into_pyarray(py);
        let triangles = Array2::from(out.triangles).into_pyarray(py);
        let normals = Array2::from(out.normals).into_pyarray(py);
        Ok((positions, triangles, normals))
    }

    /// write_tessellation(path, scheme="g1", level=None, *, tolerance=None,
    /// tolerance_rel=None, max_level=None, backend="cpu") -> (vertices, triangles): the
    /// stitched surface written to `path` (.obj, .ply, .stl or .glb), atomically, as
    /// `g1tess tessellate --backend cpu` writes it; the counts are the file's.
    #[pyo3(signature = (
        path, scheme="g1", level=None, *, tolerance=None, tolerance_rel=None,
        max_level=None, backend="cpu"
    ))]
    #[allow(clippy::too_many_arguments)]
    fn write_tessellation(
        &self,
        py: Python<'_>,
        path: PathBuf,
        scheme: &str,
        level: Option<u32>,
        tolerance: Option<f64>,
        tolerance_rel: Option<f64>,
        max_level: Option<u32>,
        backend: &str,
    ) -> PyResult<(usize, usize)> {
        let scheme = self::scheme(scheme)?;
        let grid = Grid::new(level, tolerance, tolerance_rel, max_level)?;
        let ev = evaluator(backend)?;
        py.detach(|| -> g1tess::Result<_> {
            let format = MeshFormat::from_path(&path)?;
            let table = PatchTable::build(&self.mesh, scheme, &self.options)?;
            let planned = grid.plan(&self.mesh, &table)?;
            let plan = &planned.plan;
            write_stitched::<[f32; 3]>(
                &path,
                &TempFiles::default(),
                format,
                plan,
                &planned.title,
                &NoProgress,
                &mut |sink| stitch_into(plan, &table, &ev, sink, &NoProgress).map(|_| ()),
            )?;
            planned.check_met(Some(&path))?;
            Ok((format.file_vertices(plan), plan.triangles))
        })
        .map_err(py_err)
    }

    /// stats_json(scheme="g1", *, backend="cpu") -> str: what `g1tess stats --backend cpu
    /// --json` prints.
    #[pyo3(signature = (scheme="g1", *, backend="cpu"))]
    fn stats_json(&self, py: Python<'_>, scheme: &str, backend: &str) -> PyResult<String> {
        let scheme = self::scheme(scheme)?;
        let ev = evaluator(backend)?;
        py.detach(|| -> g1tess::Result<String> {
            let r = stats_report(&self.mesh, scheme, &self.options, &ev)?;
            serde_json::to_string(&r).map_err(|e| invalid(e.to_string()))
        })
        .map_err(py_err)
    }

    /// export_msh(path, order, binary, scheme) -> str: `g1tess export-msh`, its JSON
    /// summary.
    fn export_msh(
        &self,
        py: Python<'_>,
        path: PathBuf,
        order: u32,
        binary: bool,
        scheme: &str,
    ) -> PyResult<String> {
        let scheme = self::scheme(scheme)?;
        py.detach(|| -> g1tess::Result<String> {
            let table = PatchTable::build(&self.mesh, scheme, &self.options)?;
            let s = export_msh(
                &self.mesh,
                &table,
                order,
                binary,
                &path,
                &TempFiles::default(),
                &NoProgress,
            )?;
            serde_json::to_string(&s).map_err(|e| invalid(e.to_string()))
        })
        .map_err(py_err)
    }

    /// fair(normal_bound_deg, sweeps) -> (Mesh, str): the fair G1 surface's mesh (what
    /// `--fair` does: normals and tangent lengths chosen to lower the bending energy,
    /// every patch certified, no crease made; normals given in the file move at most
    /// `normal_bound_deg` degrees; at most `sweeps` sweeps) and the report as JSON (the
    /// `fair` object of `stats --fair --json`).
    fn fair(
        &self,
        py: Python<'_>,
        normal_bound_deg: f64,
        sweeps: usize,
    ) -> PyResult<(PyMesh, String)> {
        let opts = FairOptions::default()
            .with_normal_bound_deg(normal_bound_deg)
            .with_sweeps(sweeps)
            .with_scheme_options(self.options);
        let (mesh, json) = py
            .detach(|| -> g1tess::Result<_> {
                let (fair, report) = g1tess::fair(&self.mesh, &opts)?;
                let json = serde_json::to_string(&report).map_err(|e| invalid(e.to_string()))?;
                Ok((fair, json))
            })
            .map_err(py_err)?;
        let options = self.options;
        Ok((PyMesh { mesh, options }, json))
    }

    /// repair_folds(scheme) -> (Mesh, str): the mesh with its normals repaired so that
    /// every `scheme` patch is certified valid (what `--repair-folds` does), and the
    /// repair's report as JSON (the `repair` object of `stats --json`).
    fn repair_folds(&self, py: Python<'_>, scheme: &str) -> PyResult<(PyMesh, String)> {
        let scheme = self::scheme(scheme)?;
        let (mesh, json) = py
            .detach(|| -> g1tess::Result<_> {
                let (fixed, report) = repair(&self.mesh, scheme, &self.options)?;
                let json = serde_json::to_string(&report).map_err(|e| invalid(e.to_string()))?;
                Ok((fixed, json))
            })
            .map_err(py_err)?;
        let options = self.options;
        Ok((PyMesh { mesh, options }, json))
    }
}

/// load(path, *, normal_weighting="angle", recompute_normals=False, crease_angle=None,
/// phong_alpha=0.75) -> Mesh: a mesh file or a built-in mesh, as the command line reads
/// it with `--normals`, `--recompute-normals`, `--crease-angle` and `--phong-alpha`.
#[pyfunction]
#[pyo3(signature = (
    path, *, normal_weighting="angle", recompute_normals=false, crease_angle=None,
    phong_alpha=0.75
))]
fn load(
    py: Python<'_>,
    path: String,
    normal_weighting: &str,
    recompute_normals: bool,
    crease_angle: Option<f64>,
    phong_alpha: f64,
) -> PyResult<PyMesh> {
    let (load, options) = options(
        normal_weighting,
        recompute_normals,
        crease_angle,
        phong_alpha,
    )?;
    let mesh = py
        .detach(|| Mesh::load(&path, &load))
        .map_err(|e| load_err(&path, e))?;
    Ok(PyMesh { mesh, options })
}

/// The compiled part of g1tess (see the package g1tess).
#[pymodule]
#[pyo3(name = "_native")]
fn native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyMesh>()?;
    m.add_function(wrap_pyfunction!(load, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
