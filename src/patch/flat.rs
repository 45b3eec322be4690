//! The flat triangle (degree-1 Bézier), the baseline every curved scheme is measured
//! against. Its normal is the face normal; its distance to a curved surface falls as h².

use glam::DVec3;

use crate::mesh::Mesh;

/// The three corners of every triangle (`bezier_powers(1)` order: P_0, P_1, P_2).
pub fn build(mesh: &Mesh) -> (Vec<DVec3>, usize) {
    let points = mesh
        .triangles
        .iter()
        .flat_map(|t| t.map(|v| mesh.positions[v as usize]))
        .collect();
    (points, 0)
}
