//! Curved PN triangles (Vlachos, Peters, Boyd & Mitchell 2001), `docs/schemes.md`.
//!
//! Geometry: a cubic Bézier triangle with corners b_(3 on i) = P_i, edge points
//! b_(2 on i, 1 on j) = (2 P_i + P_j − w_ij n_i)/3 with w_ij = (P_j − P_i)·n_i, and centre
//! b_111 = E + (E − V)/2 (E the mean of the six edge points, V the mean of the corners).
//!
//! Two named schemes share this geometry:
//! - `pn` ([`crate::patch::PatchKind::Bezier`]`(3)`): the normal is the exact normal
//!   S_s × S_t of the cubic. That is Table 1's PN row.
//! - `pn-normals` ([`crate::patch::PatchKind::PnNormals`]): the normal is PN's separate
//!   quadratic normal field (for shading), with corners n_i and edge coefficients
//!   n_ij = h_ij/|h_ij|, h_ij = n_i + n_j − v_ij (P_j − P_i),
//!   v_ij = 2 (P_j − P_i)·(n_i + n_j)/|P_j − P_i|². Vlachos et al. write the field as
//!   Σ n_ijk w^i u^j v^k with no multinomial factors, so in the Bernstein form the table uses
//!   the edge coefficient is n_ij/2. The field is continuous across edges by construction,
//!   but it is not the normal of the geometry: its statistics are reported under their own
//!   name.

use glam::DVec3;

use super::basis::bezier_index;
use super::{SchemeOptions, TriangleBuilder};
use crate::mesh::Mesh;
use crate::Result;

/// The 10 cubic control points of one triangle in `bezier_powers(3)` order.
pub fn geometry(q: [DVec3; 3], n: [DVec3; 3]) -> [DVec3; 10] {
    let mut c = [DVec3::ZERO; 10];
    let mut edge_sum = DVec3::ZERO;
    for i in 0..3 {
        let mut p = [0u32; 3];
        p[i] = 3;
        c[bezier_index(3, p)] = q[i];
        for j in [(i + 1) % 3, (i + 2) % 3] {
            let w = (q[j] - q[i]).dot(n[i]);
            let b = (2.0 * q[i] + q[j] - w * n[i]) / 3.0;
            let mut p = [0u32; 3];
            p[i] = 2;
            p[j] = 1;
            c[bezier_index(3, p)] = b;
            edge_sum += b;
        }
    }
    let e = edge_sum / 6.0;
    let v = (q[0] + q[1] + q[2]) / 3.0;
    c[bezier_index(3, [1, 1, 1])] = e + 0.5 * (e - v);
    c
}

/// Edge coefficient n_ij of the quadratic normal field (unit, or the normalised mean of
/// the two normals where h_ij vanishes; the bool says whether that fallback was taken).
pub fn normal_edge(pi: DVec3, ni: DVec3, pj: DVec3, nj: DVec3) -> (DVec3, bool) {
    let e = pj - pi;
    let l2 = e.length_squared();
    let v = if l2 > 0.0 {
        2.0 * e.dot(ni + nj) / l2
    } else {
        0.0
    };
    let h = ni + nj - v * e;
    match h.try_normalize() {
        Some(x) => (x, false),
        None => ((ni + nj).try_normalize().unwrap_or(ni), true),
    }
}

/// The 6 normal-field coefficients of one triangle in `bezier_powers(2)` order (Bernstein
/// form, see the module documentation). `ids` orient each edge by increasing vertex id so
/// neighbours compute bitwise the same coefficient.
pub fn normal_field(
    q: [DVec3; 3],
    n: [DVec3; 3],
    ids: [u32; 3],
    fallbacks: &mut usize,
) -> [DVec3; 6] {
    let mut c = [DVec3::ZERO; 6];
    for k in 0..3 {
        let mut p = [0u32; 3];
        p[k] = 2;
        c[bezier_index(2, p)] = n[k];
        let (a, b) = (k, (k + 1) % 3);
        let (h, fell_back) = if ids[a] <= ids[b] {
            normal_edge(q[a], n[a], q[b], n[b])
        } else {
            normal_edge(q[b], n[b], q[a], n[a])
        };
        *fallbacks += fell_back as usize;
        let mut p = [0u32; 3];
        p[a] = 1;
        p[b] = 1;
        c[bezier_index(2, p)] = 0.5 * h;
    }
    c
}

struct PnBuilder<'a> {
    mesh: &'a Mesh,
    with_normal_field: bool,
}

impl TriangleBuilder for PnBuilder<'_> {
    /// The 10 cubic points, then (with the normal field) its 6 coefficients.
    fn build(&self, t: usize, out: &mut [DVec3]) -> usize {
        let mesh = self.mesh;
        let tri = mesh.triangles[t];
        let q = tri.map(|v| mesh.positions[v as usize]);
        let n = mesh.corner_normals[t];
        out[..10].copy_from_slice(&geometry(q, n));
        let mut fallbacks = 0;
        if self.with_normal_field {
            out[10..16].copy_from_slice(&normal_field(q, n, tri, &mut fallbacks));
        }
        fallbacks
    }
}

/// `pn`: the cubic geometry with its exact normal.
pub fn prepare<'a>(mesh: &'a Mesh, _: &SchemeOptions) -> Result<Box<dyn TriangleBuilder + 'a>> {
    Ok(Box::new(PnBuilder {
        mesh,
        with_normal_field: false,
    }))
}

/// `pn-normals`: the cubic geometry with the quadratic normal field.
pub fn prepare_normals<'a>(
    mesh: &'a Mesh,
    _: &SchemeOptions,
) -> Result<Box<dyn TriangleBuilder + 'a>> {
    Ok(Box::new(PnBuilder {
        mesh,
        with_normal_field: true,
    }))
}
