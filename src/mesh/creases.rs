//! Creases: edges across which the surface normal may jump.
//!
//! An interior edge is a crease where its two triangles give different normals to one of
//! its end vertices (split normals, as flat-shaded or creased exports have). Meshes without
//! normals get such splits from [`split_normals_by_angle`]: every edge whose dihedral angle
//! exceeds a threshold separates smoothing groups, and each group of faces around a vertex
//! gets its own estimated normal.
//!
//! Normals are compared bitwise: two corners carry "the same" normal only if the values are
//! identical, which is what a file's shared `vn` index or one estimated normal gives.

use glam::DVec3;
use rayon::prelude::*;

use super::normals::{corner_weights, face_normal, NormalWeighting};
use super::{Adjacency, EdgeUse, Mesh};
use crate::{Error, Result};

/// Bit pattern of a normal, the key under which corners share a normal.
#[inline]
pub fn normal_key(n: DVec3) -> [u64; 3] {
    [n.x.to_bits(), n.y.to_bits(), n.z.to_bits()]
}

/// Corner (0, 1, 2) of triangle `t` that is vertex `v`.
#[inline]
pub fn corner_of(triangles: &[[u32; 3]], t: u32, v: u32) -> usize {
    let tri = triangles[t as usize];
    (0..3).find(|&k| tri[k] == v).unwrap_or(0)
}

/// Normal of the corner of `u.triangle` at vertex `v`.
#[inline]
pub fn use_normal(mesh: &Mesh, u: EdgeUse, v: u32) -> DVec3 {
    mesh.corner_normals[u.triangle as usize][corner_of(&mesh.triangles, u.triangle, v)]
}

/// For every edge of `adjacency` (same order), whether its uses disagree on the normal at
/// each end (`[at v[0], at v[1]]`). Boundary edges never disagree; non-manifold edges do when
/// any two of their uses differ.
pub fn split_ends(mesh: &Mesh, adjacency: &Adjacency) -> Vec<[bool; 2]> {
    adjacency
        .edges
        .par_iter()
        .map(|e| {
            std::array::from_fn(|end| {
                let v = e.v[end];
                let first = normal_key(use_normal(mesh, e.uses[0], v));
                e.uses[1..]
                    .iter()
                    .any(|&u| normal_key(use_normal(mesh, u, v)) != first)
            })
        })
        .collect()
}

#[cfg(test)]
/// For every edge of `adjacency`, whether it is a crease: an interior edge (two uses) whose
/// triangles give different normals to one of its ends.
pub fn crease_edges(mesh: &Mesh, adjacency: &Adjacency) -> Vec<bool> {
    split_ends(mesh, adjacency)
        .iter()
        .zip(&adjacency.edges)
        .map(|(s, e)| e.is_interior() && (s[0] || s[1]))
        .collect()
}

/// Marks every edge whose dihedral angle (between its two faces' normals) exceeds
/// `angle_deg` as a crease and re-estimates every corner normal per smoothing group: the
/// faces around a vertex that are connected across non-crease edges share one normal,
/// the weighted mean of their face normals. Any normals the mesh had are replaced.
/// Boundary edges separate nothing; the uses of a non-manifold edge are joined pairwise
/// where their dihedral angle is within the threshold. Returns the number of crease edges.
pub fn split_normals_by_angle(
    mesh: &mut Mesh,
    angle_deg: f64,
    weighting: NormalWeighting,
) -> Result<usize> {
    if !(0.0..=180.0).contains(&angle_deg) {
        return Err(Error::Invalid(format!(
            "the crease angle must be between 0 and 180 degrees, got {angle_deg}"
        )));
    }
    let cos_limit = angle_deg.to_radians().cos();
    let adjacency = mesh.adjacency();
    let faces: Vec<DVec3> = mesh
        .triangles
        .iter()
        .map(|t| face_normal(t.map(|v| mesh.positions[v as usize])))
        .collect();
    // Union-find over corners 3t + k.
    let mut parent: Vec<u32> = (0..3 * mesh.triangles.len() as u32).collect();
    fn find(parent: &mut [u32], mut x: u32) -> u32 {
        while parent[x as usize] != x {
            let up = parent[parent[x as usize] as usize];
            parent[x as usize] = up;
            x = up;
        }
        x
    }
    let corner =
        |u: EdgeUse, v: u32| 3 * u.triangle + corner_of(&mesh.triangles, u.triangle, v) as u32;
    let mut creases = 0;
    for e in &adjacency.edges {
        let mut joined_all = true;
        for (i, &a) in e.uses.iter().enumerate() {
            for &b in &e.uses[i + 1..] {
                let c = faces[a.triangle as usize].dot(faces[b.triangle as usize]);
                // A degenerate face (zero normal) joins its neighbours.
                let smooth = c >= cos_limit
                    || faces[a.triangle as usize] == DVec3::ZERO
                    || faces[b.triangle as usize] == DVec3::ZERO;
                if !smooth {
                    joined_all = false;
                    continue;
                }
                for v in e.v {
                    let (ra, rb) = (
                        find(&mut parent, corner(a, v)),
                        find(&mut parent, corner(b, v)),
                    );
                    if ra != rb {
                        parent[ra.max(rb) as usize] = ra.min(rb);
                    }
                }
            }
        }
        if e.is_interior() && !joined_all {
            creases += 1;
        }
    }
    // Weighted sums per group root.
    let n = 3 * mesh.triangles.len();
    let mut acc = vec![DVec3::ZERO; n];
    let mut fallback = vec![DVec3::ZERO; n];
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let p = tri.map(|v| mesh.positions[v as usize]);
        let Some((unit, w)) = corner_weights(p, weighting) else {
            continue;
        };
        for k in 0..3 {
            let w = w[k];
            let r = find(&mut parent, (3 * t + k) as u32) as usize;
            acc[r] += w * unit;
            fallback[r] += unit;
        }
    }
    let group_normal: Vec<DVec3> = (0..n)
        .map(|r| {
            acc[r]
                .try_normalize()
                .or_else(|| fallback[r].try_normalize())
                .unwrap_or(DVec3::Z)
        })
        .collect();
    for t in 0..mesh.triangles.len() {
        for k in 0..3 {
            let r = find(&mut parent, (3 * t + k) as u32) as usize;
            mesh.corner_normals[t][k] = group_normal[r];
        }
    }
    mesh.load_report.normals_estimated = n;
    Ok(creases)
}

#[cfg(test)]
mod tests {
    use crate::mesh::creases::{crease_edges, split_normals_by_angle};
    use crate::mesh::normals::face_normal;
    use crate::{Mesh, NormalWeighting};
    use glam::DVec3;

    /// A unit cube, 12 triangles, outward, one normal per vertex (smooth).
    fn cube() -> Mesh {
        let p: Vec<DVec3> = crate::tests::common::cube_corners()
            .into_iter()
            .map(DVec3::from)
            .collect();
        let mut tris = Vec::new();
        for q in crate::tests::common::CUBE_QUADS {
            tris.push([q[0], q[1], q[2]]);
            tris.push([q[0], q[2], q[3]]);
        }
        let c = DVec3::splat(0.5);
        let n: Vec<DVec3> = p.iter().map(|x| (*x - c).normalize()).collect();
        Mesh::from_soup("cube", &p, &tris, Some(&n), &Default::default()).unwrap()
    }

    #[test]
    fn cube_creases_by_angle() {
        let mut m = cube();
        let adj = m.adjacency();
        assert_eq!(adj.interior, 18);
        assert!(crease_edges(&m, &adj).iter().all(|c| !c));
        // The 12 cube edges are 90° creases, the 6 face diagonals are flat.
        let n = split_normals_by_angle(&mut m, 30.0, NormalWeighting::Angle).unwrap();
        assert_eq!(n, 12);
        let creases = crease_edges(&m, &adj);
        assert_eq!(creases.iter().filter(|&&c| c).count(), 12);
        // Every corner normal is now its face's normal.
        for (t, tri) in m.triangles.iter().enumerate() {
            let f = face_normal(tri.map(|v| m.positions[v as usize]));
            for k in 0..3 {
                assert!((m.corner_normals[t][k] - f).length() < 1e-15);
            }
        }
        // Above 90°, nothing is a crease.
        let mut m2 = cube();
        assert_eq!(
            split_normals_by_angle(&mut m2, 95.0, NormalWeighting::Angle).unwrap(),
            0
        );
        assert!(crease_edges(&m2, &adj).iter().all(|c| !c));
        assert!(split_normals_by_angle(&mut m2, -1.0, NormalWeighting::Angle).is_err());
    }
}
