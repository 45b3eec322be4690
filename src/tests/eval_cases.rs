//! Tables every evaluator is checked on (used by `tests/gpu.rs` and `tests/cpu_fast.rs`).
//!
//! `tables` gives, for a mesh, every scheme's own table (`Scheme::all()`); `cases` adds the
//! shader file that evaluates it.
#![allow(dead_code)]

#[cfg(feature = "gpu")]
use std::sync::Arc;

use glam::DVec3;

#[cfg(feature = "gpu")]
use crate::gpu::shaders::{self, ShaderFile};
use crate::patch::basis::Weights;
#[cfg(feature = "gpu")]
use crate::GpuContext;
use crate::{LoadOptions, Mesh};
use crate::{PatchKind, PatchTable, Scheme};

pub use crate::tests::common::load;

pub const MESHES: [&str; 4] = ["sphere320", "torus200", "spot.obj", "fandisk.obj"];

/// (table, label) for every scheme on `mesh`.
pub fn tables(mesh: &Mesh) -> Vec<(PatchTable, String)> {
    Scheme::all()
        .into_iter()
        .map(|scheme| {
            let table = PatchTable::build(mesh, scheme, &Default::default())
                .unwrap_or_else(|e| panic!("{}: {scheme}: {e}", mesh.name));
            (table, format!("scheme {scheme}"))
        })
        .collect()
}

/// (shader file, table, label) for every scheme on `mesh`; together they cover every
/// (shader file, patch kind) pair the GPU can run (checked here).
#[cfg(feature = "gpu")]
pub fn cases(mesh: &Mesh) -> Vec<(ShaderFile, PatchTable, String)> {
    let out: Vec<_> = tables(mesh)
        .into_iter()
        .map(|(table, label)| (shaders::file_for(table.kind), table, label))
        .collect();
    for (file, kind) in shaders::variants() {
        assert!(
            out.iter().any(|(f, t, _)| *f == file && t.kind == kind),
            "no scheme runs shaders/{} for {kind:?}",
            file.name
        );
    }
    out
}

/// Unit roundoff of f32 and f64 (2⁻²⁴ ≈ 5.96e-8 and 2⁻⁵³ ≈ 1.11e-16, rounded up).
pub const EPS32: f64 = 5.97e-8;
pub const EPS64: f64 = 1.12e-16;

/// Predicted rounding error (radians) of patch `i`'s unit normal at basis values `w` when
/// an evaluator rounds with unit roundoff `eps`, working relative to the patch's first
/// control point (as the fast evaluators do), compared with the f64 reference, which works
/// on absolute coordinates. It is moderate on a regular surface and unbounded where the
/// parametrisation is singular (S_s × S_t → 0, e.g. Nagata on creased meshes), where the
/// normal is not defined to the working precision.
pub fn normal_error(table: &PatchTable, i: usize, w: &Weights, eps: f64) -> f64 {
    let c = table.patch(i);
    if table.kind == PatchKind::PnNormals {
        // The normal is the quadratic field Σ w_j c_j over slots 10..16.
        let field: DVec3 = (10..16).map(|j| w.w[j] * c[j]).sum();
        let scale: f64 = (10..16).map(|j| w.w[j].abs() * c[j].length()).sum();
        return (eps + EPS64) * scale / field.length();
    }
    let extent = c.iter().map(|p| p.distance(c[0])).fold(0.0, f64::max);
    let magnitude = c.iter().map(|p| p.length()).fold(0.0, f64::max);
    let (mut ds, mut dt, mut ns, mut nt) = (DVec3::ZERO, DVec3::ZERO, 0.0, 0.0);
    for (j, p) in c.iter().enumerate() {
        ds += w.ws[j] * *p;
        dt += w.wt[j] * *p;
        ns += w.ws[j].abs();
        nt += w.wt[j].abs();
    }
    (eps * extent + EPS64 * magnitude) * (ns * dt.length() + nt * ds.length())
        / ds.cross(dt).length()
}

/// Angle between two normals, accurate for small angles.
pub fn angle(a: DVec3, b: DVec3) -> f64 {
    2.0 * ((a - b).length() / 2.0).min(1.0).asin()
}

/// How many times the predicted rounding error ([`normal_error`]) a normal's error may be:
/// the prediction gives the error's size without the small constant factors (roundings per
/// sum, the normalisation), which 16 covers.
pub const ROUNDING_FACTOR: f64 = 16.0;

/// Whether a sample is regular: `ROUNDING_FACTOR` times its predicted rounding error is
/// within the angle that 1 − dot ≤ `tn` allows. Regular samples are held to `tn`; the
/// others (near singular points of the parametrisation, where the normal is not defined to
/// the working precision) to an angle of `ROUNDING_FACTOR` × the prediction, and are
/// counted in the report.
pub fn regular(predicted: f64, tn: f64) -> bool {
    ROUNDING_FACTOR * predicted <= (2.0 * tn).sqrt()
}

/// Whether the tests run under CI (`CI=true`), where a missing GPU adapter is a failure.
pub fn ci() -> bool {
    std::env::var("CI").is_ok_and(|v| v == "true" || v == "1")
}

/// Every backend a comparison runs on: the CPU with each f32 kernel and, with feature `gpu`
/// where an adapter is present, the GPU in f32 and (with SHADER_F64) f64. With `CI=true` a
/// missing adapter fails; otherwise the GPU entries are absent and a NOTE line says so.
pub fn evaluators() -> Vec<(String, Box<dyn crate::Evaluator>)> {
    use crate::eval::cpu::F32Kernel;
    use crate::CpuEvaluator;
    let mut out: Vec<(String, Box<dyn crate::Evaluator>)> = Vec::new();
    for kernel in [F32Kernel::Auto, F32Kernel::Portable] {
        out.push((
            format!("cpu ({})", kernel.name()),
            Box::new(CpuEvaluator {
                f32_kernel: kernel,
                ..Default::default()
            }),
        ));
    }
    #[cfg(feature = "gpu")]
    gpu_evaluators(&mut out);
    out
}

/// The GPU's entries of [`evaluators`].
#[cfg(feature = "gpu")]
fn gpu_evaluators(out: &mut Vec<(String, Box<dyn crate::Evaluator>)>) {
    use crate::GpuEvaluator;
    use crate::Precision;
    match crate::tests::common::shared_gpu() {
        Ok(ctx) => {
            for precision in [Precision::F32, Precision::F64] {
                match GpuEvaluator::new(ctx.clone(), precision) {
                    Ok(ev) => out.push((format!("gpu ({precision})"), Box::new(ev))),
                    Err(e) if precision == Precision::F64 => {
                        eprintln!("NOTE: no f64 GPU evaluator: {e}")
                    }
                    Err(e) => panic!("GPU adapter present but no f32 evaluator: {e}"),
                }
            }
        }
        Err(e) => {
            assert!(!ci(), "CI=true and no GPU adapter: {e}");
            eprintln!("NOTE: no GPU adapter ({e}): CPU backends only");
        }
    }
}

/// The shared context, or None (SKIP) without an adapter; with CI=true no adapter panics.
#[cfg(feature = "gpu")]
pub fn context(test: &str) -> Option<Arc<GpuContext>> {
    match crate::tests::common::shared_gpu() {
        Ok(c) => Some(c),
        Err(e) => {
            assert!(!ci(), "{test}: CI=true and no GPU adapter: {e}");
            eprintln!("\n======== SKIP {test}: no GPU adapter ({e}) ========\n");
            None
        }
    }
}

/// An open box (a cube without its top, far from the origin) with a normal per face
/// (creases at every box edge): 10 triangles, 4 boundary edges, 8 crease edges.
pub fn open_box() -> Mesh {
    let o = DVec3::new(100.0, -50.0, 20.0);
    let mut positions = Vec::new();
    for z in [0.0, 1.0] {
        for y in [0.0, 1.0] {
            for x in [0.0, 1.0] {
                positions.push(o + DVec3::new(x, y, z));
            }
        }
    }
    // Outward quads (bottom, four sides), each as two triangles.
    let quads = [
        [0, 2, 3, 1],
        [0, 1, 5, 4],
        [1, 3, 7, 5],
        [3, 2, 6, 7],
        [2, 0, 4, 6],
    ];
    let triangles: Vec<[u32; 3]> = quads
        .iter()
        .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
        .collect();
    let opts = LoadOptions::default().with_crease_angle(Some(45.0));
    Mesh::from_soup("open box", &positions, &triangles, None, &opts).unwrap()
}
