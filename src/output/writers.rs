//! Mesh writers. Every file is written atomically (see [`super::atomic`]).

use std::io::Write;
use std::path::Path;

use glam::DVec3;

use super::atomic::write_atomic;
use crate::Result;

/// An indexed triangle mesh with one normal per vertex, as produced by tessellation.
#[derive(Clone, Debug, Default)]
pub struct IndexedMesh {
    pub positions: Vec<DVec3>,
    pub normals: Vec<DVec3>,
    pub triangles: Vec<[u32; 3]>,
}

/// Writes an OBJ file with `v`, `vn` and `f v//vn` lines (17 significant digits, so the
/// values read back exactly).
pub fn write_obj(path: &Path, mesh: &IndexedMesh) -> Result<()> {
    write_atomic(path, |w| {
        writeln!(
            w,
            "# g1tess output: {} vertices, {} triangles",
            mesh.positions.len(),
            mesh.triangles.len()
        )?;
        for p in &mesh.positions {
            writeln!(w, "v {:?} {:?} {:?}", p.x, p.y, p.z)?;
        }
        for n in &mesh.normals {
            writeln!(w, "vn {:?} {:?} {:?}", n.x, n.y, n.z)?;
        }
        for t in &mesh.triangles {
            let [a, b, c] = t.map(|i| i + 1);
            writeln!(w, "f {a}//{a} {b}//{b} {c}//{c}")?;
        }
        Ok(())
    })
}
