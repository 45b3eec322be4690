//! Shared helpers of the integration tests: meshes and the tables every evaluator is
//! checked on.
//!
//! `cases` gives, for a mesh, every scheme's own table (`Scheme::all()`) and, for the patch
//! kinds no scheme of this build produces, synthetic tables (degree-elevated flat
//! triangles lifted along the normal by a smooth bump, and for PN's normal field the
//! interpolated corner normals), each with the shader file that evaluates it.
#![allow(dead_code)]

use glam::DVec3;

use g1tess::gpu::shaders::{self, ShaderFile};
use g1tess::mesh::{LoadOptions, Mesh};
use g1tess::patch::basis::bezier_powers;
use g1tess::patch::{PatchKind, PatchTable, Scheme};

pub const MESHES: [&str; 4] = ["sphere320", "torus200", "spot.obj", "fandisk.obj"];

pub fn load(name: &str) -> Mesh {
    let spec = if name.ends_with(".obj") {
        format!("{}/../shared/meshes/{name}", env!("CARGO_MANIFEST_DIR"))
    } else {
        name.to_string()
    };
    Mesh::load(&spec, &LoadOptions::default()).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// A smooth bump on barycentric powers (0 at the corners).
fn bump(p: [u32; 3], n: u32) -> f64 {
    let b = p.map(|x| x as f64 / n as f64);
    4.0 * (b[0] * b[1] + b[1] * b[2] + 0.5 * b[2] * b[0]) + 0.3 * (b[1] - b[2])
}

/// A table of `kind` over `mesh` that no scheme of this build produces (see the module
/// comment); `scheme` is only a label here.
pub fn synthetic(mesh: &Mesh, kind: PatchKind) -> PatchTable {
    let base = PatchTable::build(mesh, Scheme::Flat, &Default::default()).unwrap();
    let (degree, field) = match kind {
        PatchKind::Bezier(n) => (n, false),
        PatchKind::PnNormals => (3, true),
        PatchKind::Gregory => unreachable!("G1 has its scheme"),
    };
    let mut points = Vec::with_capacity(mesh.triangles.len() * kind.stride());
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let q = tri.map(|v| mesh.positions[v as usize]);
        let h = 0.1 * (q[1] - q[0]).length().max((q[2] - q[0]).length());
        let f = base.flat_normals[t];
        for p in bezier_powers(degree) {
            let x: DVec3 = (0..3).map(|k| p[k] as f64 / degree as f64 * q[k]).sum();
            points.push(x + h * bump(p, degree) * f);
        }
        if field {
            let n = mesh.corner_normals[t];
            for p in bezier_powers(2) {
                let v: DVec3 = (0..3).map(|k| p[k] as f64 / 2.0 * n[k]).sum();
                points.push(v + 0.05 * bump(p, 2) * f);
            }
        }
    }
    PatchTable {
        scheme: Scheme::Flat,
        kind,
        stride: kind.stride(),
        points,
        flat_normals: base.flat_normals,
        fallbacks: 0,
    }
}

/// (file, table) pairs covering every shader file and every kind it serves on `mesh`.
pub fn cases(mesh: &Mesh) -> Vec<(ShaderFile, PatchTable, String)> {
    let mut out = Vec::new();
    let mut covered = Vec::new();
    for scheme in Scheme::all() {
        let table = PatchTable::build(mesh, scheme, &Default::default()).unwrap();
        let file = shaders::scheme_file(scheme, table.kind).unwrap();
        covered.push((file, table.kind));
        out.push((file, table, format!("scheme {scheme}")));
    }
    for (file, kind) in shaders::variants() {
        if !covered.contains(&(file, kind)) {
            out.push((
                file,
                synthetic(mesh, kind),
                format!("{} on a synthetic {kind:?} table", file.name),
            ));
        }
    }
    out
}
