//! Shared by the quadratic point–normal schemes (Phong tessellation, Nagata, NLSA): a
//! quadratic Bézier triangle is its three corners P_i plus one edge point C_ij per edge,
//! and each scheme only says how C_ij follows from (P_i, n_i, P_j, n_j).

use glam::DVec3;

use super::basis::bezier_index;
use crate::mesh::Mesh;

/// The edge point of one edge from its two end points and unit normals, and whether the
/// scheme took its documented fallback on that edge.
pub type EdgePointFn<'a> = dyn Fn(DVec3, DVec3, DVec3, DVec3) -> (DVec3, bool) + 'a;

/// Control points (6 per triangle, [`super::basis::bezier_powers`]`(2)` order) of every
/// triangle of `mesh`, and the number of triangle edges that took a fallback.
///
/// Each edge point is computed with the edge run from the lower to the higher vertex id,
/// so the two triangles of an edge get bitwise the same boundary curve.
pub fn build(mesh: &Mesh, edge_point: &EdgePointFn<'_>) -> (Vec<DVec3>, usize) {
    let mut fallbacks = 0;
    let mut points = Vec::with_capacity(mesh.triangles.len() * 6);
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let q = tri.map(|v| mesh.positions[v as usize]);
        let n = mesh.corner_normals[t];
        let mut c = [DVec3::ZERO; 6];
        for k in 0..3 {
            let mut p = [0u32; 3];
            p[k] = 2;
            c[bezier_index(2, p)] = q[k];
            let (a, b) = (k, (k + 1) % 3);
            let (e, fell_back) = if tri[a] <= tri[b] {
                edge_point(q[a], n[a], q[b], n[b])
            } else {
                edge_point(q[b], n[b], q[a], n[a])
            };
            fallbacks += fell_back as usize;
            let mut p = [0u32; 3];
            p[a] = 1;
            p[b] = 1;
            c[bezier_index(2, p)] = e;
        }
        points.extend_from_slice(&c);
    }
    (points, fallbacks)
}
