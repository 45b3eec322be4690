//! Shared by the quadratic point–normal schemes (Phong tessellation, Nagata, NLSA): a
//! quadratic Bézier triangle is its three corners P_i plus one edge point C_ij per edge,
//! and each scheme only says how C_ij follows from (P_i, n_i, P_j, n_j).

use glam::DVec3;

use super::basis::bezier_index;
use super::TriangleBuilder;
use crate::mesh::Mesh;

/// Builds the quadratic patch of any triangle of a mesh from a scheme's edge point: given
/// the two end points and unit normals of an edge, its edge point and whether the scheme
/// took its documented fallback on that edge.
pub struct QuadraticBuilder<'a, F> {
    pub mesh: &'a Mesh,
    pub edge_point: F,
}

impl<F> TriangleBuilder for QuadraticBuilder<'_, F>
where
    F: Fn(DVec3, DVec3, DVec3, DVec3) -> (DVec3, bool) + Sync,
{
    /// Control points (6, [`super::basis::bezier_powers`]`(2)` order) of triangle `t`; the
    /// fallbacks counted are the triangle's edges that took one.
    ///
    /// Each edge point is computed with the edge run from the lower to the higher vertex
    /// id, so the two triangles of an edge get bitwise the same boundary curve.
    fn build(&self, t: usize, out: &mut [DVec3]) -> usize {
        let mesh = self.mesh;
        let tri = mesh.triangles[t];
        let q = tri.map(|v| mesh.positions[v as usize]);
        let n = mesh.corner_normals[t];
        let mut fallbacks = 0;
        for k in 0..3 {
            let mut p = [0u32; 3];
            p[k] = 2;
            out[bezier_index(2, p)] = q[k];
            let (a, b) = (k, (k + 1) % 3);
            let (e, fell_back) = if tri[a] <= tri[b] {
                (self.edge_point)(q[a], n[a], q[b], n[b])
            } else {
                (self.edge_point)(q[b], n[b], q[a], n[a])
            };
            fallbacks += fell_back as usize;
            let mut p = [0u32; 3];
            p[a] = 1;
            p[b] = 1;
            out[bezier_index(2, p)] = e;
        }
        fallbacks
    }
}
