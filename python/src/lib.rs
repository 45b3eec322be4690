//! `g1tess._native`: the Python extension behind the `g1tess` package (python/g1tess).
//!
//! Written against PyO3 without its procedural macros, on purpose: the macros pull in a
//! second `syn` with other features, which changes the build of `serde_derive` and with it
//! of every crate that uses serde (wgpu, naga, …), so the extension could not reuse the
//! dependencies `cargo test --release` has just built. Without them the extension compiles
//! PyO3, the library without its `cli` feature, and itself.
//!
//! The module holds plain functions; a mesh travels as a capsule (`g1tess.Mesh` wraps it),
//! arrays as native-endian bytes (the package converts them to and from numpy, so no numpy
//! headers are needed). Every function releases the GIL while the library works. Library
//! errors become `OSError` (files) or `ValueError` (anything else) with the library's
//! one-line message, the text the command line prints after `error: `.

use std::ffi::CStr;
use std::path::Path;

use g1tess::eval::cpu::CpuEvaluator;
use g1tess::mesh::{LoadOptions, Mesh};
use g1tess::output::msh::export_msh;
use g1tess::output::stats::stats_report;
use g1tess::output::writers::{write_stitched, MeshFormat};
use g1tess::patch::{PatchTable, Scheme, SchemeOptions};
use g1tess::progress::NoProgress;
use g1tess::tess::stitch::{stitch_in, stitch_into, StitchPlan};
use glam::DVec3;
use pyo3::exceptions::{PyOSError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyCFunction, PyCapsule, PyCapsuleMethods, PyDict, PyTuple};
use pyo3::{ffi, IntoPyObjectExt};

/// Name of the capsules that hold a [`Mesh`].
const MESH: &CStr = c"g1tess.Mesh";

/// The library's error as the Python exception of its kind.
fn py_err(e: g1tess::Error) -> PyErr {
    match e {
        g1tess::Error::Io { .. } => PyOSError::new_err(e.to_string()),
        _ => PyValueError::new_err(e.to_string()),
    }
}

fn scheme(name: &str) -> PyResult<Scheme> {
    Scheme::parse(name).map_err(py_err)
}

fn level(level: u32) -> PyResult<u32> {
    if level == 0 {
        return Err(PyValueError::new_err("level must be at least 1"));
    }
    Ok(level)
}

/// Native-endian f64 triples from `bytes`.
fn triples(bytes: &[u8]) -> Vec<DVec3> {
    bytes
        .chunks_exact(24)
        .map(|c| {
            let f = |i: usize| f64::from_ne_bytes(c[8 * i..8 * i + 8].try_into().unwrap_or([0; 8]));
            DVec3::new(f(0), f(1), f(2))
        })
        .collect()
}

/// The native-endian bytes of a slice of plain numbers.
fn ne_bytes<T: Copy, const N: usize>(v: &[T], f: impl Fn(T) -> [u8; N]) -> Vec<u8> {
    let mut out = Vec::with_capacity(v.len() * N);
    for &x in v {
        out.extend(f(x));
    }
    out
}

/// Positional argument `i` of `args`, converted.
fn arg<'py, T: FromPyObjectOwned<'py>>(args: &Bound<'py, PyTuple>, i: usize) -> PyResult<T> {
    args.get_item(i)
        .map_err(|_| PyTypeError::new_err(format!("missing argument {i}")))?
        .extract::<T>()
        .map_err(Into::into)
}

/// The mesh in the capsule given as argument 0. It lives as long as the capsule, which
/// the caller's argument tuple holds for the whole call.
fn mesh_arg<'a>(args: &'a Bound<'_, PyTuple>) -> PyResult<&'a Mesh> {
    let item = args.get_item(0)?;
    let capsule = item
        .cast::<PyCapsule>()
        .map_err(|_| PyTypeError::new_err("argument 0 must be a g1tess.Mesh capsule"))?;
    let ptr = capsule.pointer_checked(Some(MESH))?;
    // SAFETY: capsules named MESH are made only by `wrap`, from a `Box<Mesh>` that lives
    // until the capsule is destroyed; the argument tuple keeps the capsule alive, and the
    // mesh is never mutated.
    Ok(unsafe { &*(ptr.as_ptr() as *const Mesh) })
}

fn wrap(py: Python<'_>, mesh: Mesh) -> PyResult<Py<PyAny>> {
    Ok(PyCapsule::new_with_value(py, mesh, MESH)?
        .into_any()
        .unbind())
}

fn bytes3(py: Python<'_>, (a, b, c): (Vec<u8>, Vec<u8>, Vec<u8>)) -> PyResult<Py<PyAny>> {
    (
        PyBytes::new(py, &a),
        PyBytes::new(py, &b),
        PyBytes::new(py, &c),
    )
        .into_py_any(py)
}

type Args<'a, 'py> = &'a Bound<'py, PyTuple>;

/// load(path) -> mesh: a mesh file or a built-in mesh, as the command line reads it.
fn load(args: Args) -> PyResult<Py<PyAny>> {
    let py = args.py();
    let path: String = arg(args, 0)?;
    let mesh = py
        .detach(|| Mesh::load(&path, &LoadOptions::default()))
        .map_err(py_err)?;
    wrap(py, mesh)
}

/// from_soup(name, vertices, triangles, normals) -> mesh: f64 triples, u32 triples, f64
/// triples or None, as bytes (`Mesh::from_soup`).
fn from_soup(args: Args) -> PyResult<Py<PyAny>> {
    let py = args.py();
    let name: String = arg(args, 0)?;
    let (v, t, n) = (args.get_item(1)?, args.get_item(2)?, args.get_item(3)?);
    let vertices = v.cast::<PyBytes>()?.as_bytes();
    let triangles = t.cast::<PyBytes>()?.as_bytes();
    let normals = if n.is_none() {
        None
    } else {
        Some(n.cast::<PyBytes>()?.as_bytes())
    };
    let mesh = py
        .detach(|| {
            let v = triples(vertices);
            let t: Vec<[u32; 3]> = triangles
                .chunks_exact(12)
                .map(|c| {
                    std::array::from_fn(|i| {
                        u32::from_ne_bytes(c[4 * i..4 * i + 4].try_into().unwrap_or([0; 4]))
                    })
                })
                .collect();
            let n = normals.map(triples);
            Mesh::from_soup(name, &v, &t, n.as_deref(), &LoadOptions::default())
        })
        .map_err(py_err)?;
    wrap(py, mesh)
}

/// name(mesh) -> str.
fn name(args: Args) -> PyResult<Py<PyAny>> {
    mesh_arg(args)?.name.clone().into_py_any(args.py())
}

/// arrays(mesh) -> (vertices f64, triangles u32, corner normals f64), as bytes.
fn arrays(args: Args) -> PyResult<Py<PyAny>> {
    let m = mesh_arg(args)?;
    let flat = |v: &[DVec3]| {
        ne_bytes(
            &v.iter().flat_map(|p| p.to_array()).collect::<Vec<_>>(),
            f64::to_ne_bytes,
        )
    };
    let v = flat(&m.positions);
    let t = ne_bytes(&m.triangles.concat(), u32::to_ne_bytes);
    let n = flat(&m.corner_normals.concat());
    bytes3(args.py(), (v, t, n))
}

/// tessellate(mesh, scheme, level) -> (positions f32, triangles u32, normals f32) of the
/// stitched surface's vertex records, as bytes: the CPU's f32 kernel, as `g1tess
/// tessellate --backend cpu` writes them to PLY.
fn tessellate(args: Args) -> PyResult<Py<PyAny>> {
    let py = args.py();
    let mesh = mesh_arg(args)?;
    let scheme = scheme(&arg::<String>(args, 1)?)?;
    let level = level(arg(args, 2)?)?;
    let out = py
        .detach(|| -> g1tess::Result<_> {
            let table = PatchTable::build(mesh, scheme, &SchemeOptions::default())?;
            let (out, _, _) = stitch_in::<[f32; 3]>(mesh, &table, &CpuEvaluator::default(), level)?;
            let v = ne_bytes(&out.record_positions().concat(), f32::to_ne_bytes);
            let f = ne_bytes(&out.triangles.concat(), u32::to_ne_bytes);
            let n = ne_bytes(&out.normals.concat(), f32::to_ne_bytes);
            Ok((v, f, n))
        })
        .map_err(py_err)?;
    bytes3(py, out)
}

/// write_tessellation(mesh, path, scheme, level) -> (vertices, triangles): the stitched
/// surface written to `path` (.obj, .ply, .stl or .glb), atomically, as `g1tess tessellate
/// --backend cpu` writes it.
fn write_tessellation(args: Args) -> PyResult<Py<PyAny>> {
    let py = args.py();
    let mesh = mesh_arg(args)?;
    let path: String = arg(args, 1)?;
    let scheme = scheme(&arg::<String>(args, 2)?)?;
    let level = level(arg(args, 3)?)?;
    let counts = py
        .detach(|| -> g1tess::Result<_> {
            let path = Path::new(&path);
            let format = MeshFormat::from_path(path)?;
            let table = PatchTable::build(mesh, scheme, &SchemeOptions::default())?;
            let plan = StitchPlan::new(mesh, &mesh.adjacency(), level)?;
            let title = format!(
                "g1tess: {}, scheme {}, level {level}",
                mesh.name, table.scheme
            );
            let ev = CpuEvaluator::default();
            write_stitched::<[f32; 3]>(path, format, &plan, &title, &NoProgress, &mut |sink| {
                stitch_into(&plan, &table, &ev, sink, &NoProgress).map(|_| ())
            })?;
            Ok((format.file_vertices(&plan), plan.triangles))
        })
        .map_err(py_err)?;
    counts.into_py_any(py)
}

/// stats_json(mesh, scheme) -> str: what `g1tess stats --backend cpu --json` prints.
fn stats_json(args: Args) -> PyResult<Py<PyAny>> {
    let py = args.py();
    let mesh = mesh_arg(args)?;
    let scheme = scheme(&arg::<String>(args, 1)?)?;
    let json = py
        .detach(|| -> g1tess::Result<String> {
            let r = stats_report(
                mesh,
                scheme,
                &SchemeOptions::default(),
                &CpuEvaluator::default(),
            )?;
            serde_json::to_string(&r).map_err(|e| g1tess::Error::Invalid(e.to_string()))
        })
        .map_err(py_err)?;
    json.into_py_any(py)
}

/// export_msh(mesh, path, order, binary, scheme) -> str: `g1tess export-msh`, its JSON
/// summary.
fn export_msh_json(args: Args) -> PyResult<Py<PyAny>> {
    let py = args.py();
    let mesh = mesh_arg(args)?;
    let path: String = arg(args, 1)?;
    let order: u32 = arg(args, 2)?;
    let binary: bool = arg(args, 3)?;
    let scheme = scheme(&arg::<String>(args, 4)?)?;
    let json = py
        .detach(|| -> g1tess::Result<String> {
            let table = PatchTable::build(mesh, scheme, &SchemeOptions::default())?;
            let s = export_msh(mesh, &table, order, binary, Path::new(&path), &NoProgress)?;
            serde_json::to_string(&s).map_err(|e| g1tess::Error::Invalid(e.to_string()))
        })
        .map_err(py_err)?;
    json.into_py_any(py)
}

/// repair_folds(mesh, scheme) -> (mesh, str): the mesh with its normals repaired so that
/// every `scheme` patch is certified valid (`patch::repair::repair`, what `--repair-folds`
/// does), and the repair's report as JSON (the `repair` object of `stats --json`).
fn repair_folds(args: Args) -> PyResult<Py<PyAny>> {
    let py = args.py();
    let mesh = mesh_arg(args)?;
    let scheme = scheme(&arg::<String>(args, 1)?)?;
    let (fixed, json) = py
        .detach(|| -> g1tess::Result<_> {
            let (fixed, report) =
                g1tess::patch::repair::repair(mesh, scheme, &SchemeOptions::default())?;
            let json = serde_json::to_string(&report)
                .map_err(|e| g1tess::Error::Invalid(e.to_string()))?;
            Ok((fixed, json))
        })
        .map_err(py_err)?;
    (wrap(py, fixed)?, json).into_py_any(py)
}

type Function = fn(Args) -> PyResult<Py<PyAny>>;

const FUNCTIONS: &[(&CStr, Function)] = &[
    (c"load", load),
    (c"from_soup", from_soup),
    (c"name", name),
    (c"arrays", arrays),
    (c"tessellate", tessellate),
    (c"write_tessellation", write_tessellation),
    (c"stats_json", stats_json),
    (c"export_msh", export_msh_json),
    (c"repair_folds", repair_folds),
];

fn init(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    for &(name, f) in FUNCTIONS {
        let func = PyCFunction::new_closure(
            py,
            Some(name),
            None,
            move |args: &Bound<'_, PyTuple>, kwargs: Option<&Bound<'_, PyDict>>| {
                if kwargs.is_some_and(|k| !k.is_empty()) {
                    return Err(PyTypeError::new_err("keyword arguments are not accepted"));
                }
                f(args)
            },
        )?;
        m.add(name.to_str().unwrap_or("function"), func)?;
    }
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}

static mut MODULE_DEF: ffi::PyModuleDef = ffi::PyModuleDef {
    m_base: ffi::PyModuleDef_HEAD_INIT,
    m_name: c"g1tess._native".as_ptr(),
    m_doc: c"The compiled part of g1tess (see the package g1tess).".as_ptr(),
    m_size: -1,
    m_methods: std::ptr::null_mut(),
    m_slots: std::ptr::null_mut(),
    m_traverse: None,
    m_clear: None,
    m_free: None,
};

/// The module's initialisation, called by the interpreter on `import g1tess._native`.
///
/// # Safety
/// Called by CPython with the GIL held, once per import.
#[allow(non_snake_case)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn PyInit__native() -> *mut ffi::PyObject {
    Python::attach(|py| {
        // SAFETY: MODULE_DEF is a valid module definition, handed only to the interpreter.
        let m = unsafe { ffi::PyModule_Create(&raw mut MODULE_DEF) };
        if m.is_null() {
            return m;
        }
        // SAFETY: `m` is a new (owned) reference to a module object.
        let module = unsafe { Bound::from_owned_ptr(py, m) };
        let result = module
            .cast_into::<PyModule>()
            .map_err(PyErr::from)
            .and_then(|module| init(&module).map(|()| module));
        match result {
            Ok(module) => module.into_ptr(),
            Err(e) => {
                e.restore(py);
                std::ptr::null_mut()
            }
        }
    })
}
