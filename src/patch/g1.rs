//! The Bézier G1 patch of Walton & Meek (1996) as corrected in
//! `../shared/spec/G1-CONSTRUCTION.md`. Mirrored on the GPU by `shaders/g1.wgsl`, which
//! evaluates the table built here.
//!
//! Documented fallbacks (counted in [`crate::patch::PatchTable::fallbacks`]): where a
//! boundary tangent W_i vanishes, its ribbon vector A_i is 0 and λ is 0; where
//! A0 + A2 = 0 (opposite normals with the edge in their plane), A1 = N_a × Ŵ1.

use glam::DVec3;

use crate::mesh::Mesh;

/// The Walton–Meek cubic between (qa, na) and (qb, nb) (Theorem 2.1, Γ the unit edge
/// vector). Normals must be unit vectors.
pub fn walton_meek(qa: DVec3, na: DVec3, qb: DVec3, nb: DVec3) -> [DVec3; 4] {
    let [t0, t1] = walton_meek_offsets(qa, na, qb, nb);
    [qa, qa + t0, qb - t1, qb]
}

/// The offsets V1 − V0 and V3 − V2 of the Walton–Meek cubic, as the construction defines
/// them (one third of the end tangents): perpendicular to `na` and `nb` respectively up to
/// rounding of these short vectors, before any addition to the far larger positions.
pub fn walton_meek_offsets(qa: DVec3, na: DVec3, qb: DVec3, nb: DVec3) -> [DVec3; 2] {
    let e = qb - qa;
    let d = e.length();
    let g = e / d;
    let a0 = na.dot(g);
    let a1 = nb.dot(g);
    let a = na.dot(nb);
    let den = 4.0 - a * a;
    let zeta = 6.0 * (2.0 * a0 + a * a1) / den;
    let theta = 6.0 * (2.0 * a1 + a * a0) / den;
    [
        d * (6.0 * g - 2.0 * zeta * na + theta * nb) / 18.0,
        d * (6.0 * g + zeta * na - 2.0 * theta * nb) / 18.0,
    ]
}

/// Per-edge data of one patch, with the edge run from corner k to corner k + 1.
struct EdgeData {
    /// Quartic boundary points L_0..L_4.
    l: [DVec3; 5],
    w: [DVec3; 3],
    a: [DVec3; 3],
}

fn edge_data(v: [DVec3; 4], na: DVec3, nb: DVec3, fallbacks: &mut usize) -> EdgeData {
    let w = [v[1] - v[0], v[2] - v[1], v[3] - v[2]];
    let unit = |x: DVec3, f: &mut usize| {
        let n = x.length();
        if n > 0.0 {
            x / n
        } else {
            *f += 1;
            DVec3::ZERO
        }
    };
    let a0 = na.cross(unit(w[0], fallbacks));
    let a2 = nb.cross(unit(w[2], fallbacks));
    let sum = a0 + a2;
    let a1 = match sum.try_normalize() {
        Some(x) if sum.length() > 1e-12 => x,
        _ => {
            *fallbacks += 1;
            na.cross(w[1]).normalize_or_zero()
        }
    };
    let l = [
        v[0],
        (v[0] + 3.0 * v[1]) / 4.0,
        (v[1] + v[2]) / 2.0,
        (3.0 * v[2] + v[3]) / 4.0,
        v[3],
    ];
    EdgeData {
        l,
        w,
        a: [a0, a1, a2],
    }
}

/// The 18 control points of one triangle (layout of [`crate::patch::PatchKind::Gregory`]).
/// `ids` are the global vertex ids: each boundary cubic is built in the direction of
/// increasing id, so both neighbours of an edge compute bitwise the same curve.
pub fn patch_points(
    q: [DVec3; 3],
    n: [DVec3; 3],
    ids: [u32; 3],
    fallbacks: &mut usize,
) -> [DVec3; 18] {
    let edges: [EdgeData; 3] = std::array::from_fn(|k| {
        let (a, b) = (k, (k + 1) % 3);
        let v = if ids[a] <= ids[b] {
            walton_meek(q[a], n[a], q[b], n[b])
        } else {
            let r = walton_meek(q[b], n[b], q[a], n[a]);
            [r[3], r[2], r[1], r[0]]
        };
        edge_data(v, n[a], n[b], fallbacks)
    });
    let mut out = [DVec3::ZERO; 18];
    for k in 0..3 {
        out[4 * k..4 * k + 4].copy_from_slice(&edges[k].l[..4]);
    }
    for k in 0..3 {
        let e = &edges[k];
        let prev = &edges[(k + 2) % 3];
        let next = &edges[(k + 1) % 3];
        let d0 = prev.l[3] - 0.5 * (e.l[0] + e.l[1]);
        let d3 = next.l[1] - 0.5 * (e.l[3] + e.l[4]);
        let ratio = |d: DVec3, w: DVec3| {
            let w2 = w.length_squared();
            if w2 > 0.0 {
                d.dot(w) / w2
            } else {
                0.0
            }
        };
        let lambda0 = ratio(d0, e.w[0]);
        let mu0 = d0.dot(e.a[0]);
        let lambda1 = ratio(d3, e.w[2]);
        let mu1 = d3.dot(e.a[2]);
        let d1 = (2.0 / 3.0) * lambda0 * e.w[1]
            + (1.0 / 3.0) * lambda1 * e.w[0]
            + (2.0 / 3.0) * mu0 * e.a[1]
            + (1.0 / 3.0) * mu1 * e.a[0];
        let d2 = (1.0 / 3.0) * lambda0 * e.w[2]
            + (2.0 / 3.0) * lambda1 * e.w[1]
            + (1.0 / 3.0) * mu0 * e.a[2]
            + (2.0 / 3.0) * mu1 * e.a[1];
        out[12 + 2 * k] = 0.5 * (e.l[1] + e.l[2]) + d1;
        out[13 + 2 * k] = 0.5 * (e.l[2] + e.l[3]) + d2;
    }
    out
}

/// Control points of every triangle of `mesh`, and the number of fallbacks taken.
pub fn build(mesh: &Mesh) -> (Vec<DVec3>, usize) {
    let mut fallbacks = 0;
    let mut points = Vec::with_capacity(mesh.triangles.len() * 18);
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let q = tri.map(|v| mesh.positions[v as usize]);
        points.extend_from_slice(&patch_points(
            q,
            mesh.corner_normals[t],
            *tri,
            &mut fallbacks,
        ));
    }
    (points, fallbacks)
}
