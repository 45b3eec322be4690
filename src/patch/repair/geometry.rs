//! Geometry the repair's steps share: directions on the unit sphere, fans around a
//! vertex, edges, and the corner Jacobians of G1 patches.

use std::collections::{HashMap, HashSet};

use glam::DVec3;

use crate::mesh::adjacency::EdgeIndex;
use crate::mesh::creases::normal_key;
use crate::mesh::Mesh;

/// The unit vector maximising the smallest cosine to the unit vectors `f` (approximately:
/// 200 Bădoiu–Clarkson steps from their mean), or `fallback`.
pub(super) fn central(f: &[DVec3], fallback: DVec3) -> DVec3 {
    let mut m = match f.iter().copied().sum::<DVec3>().try_normalize() {
        Some(m) => m,
        None => return fallback,
    };
    for i in 0..200 {
        let worst = f
            .iter()
            .copied()
            .min_by(|a, b| a.dot(m).total_cmp(&b.dot(m)))
            .unwrap_or(m);
        m = match (m + (worst - m) / (i as f64 + 2.0)).try_normalize() {
            Some(x) => x,
            None => break,
        };
    }
    m
}

/// `a` moved a fraction `w` of the way to `b` (normalised linear blend), unit.
pub(super) fn towards(a: DVec3, b: DVec3, w: f64) -> DVec3 {
    if w <= 0.0 {
        return a;
    }
    ((1.0 - w) * a + w * b).try_normalize().unwrap_or(b)
}

/// Angle between unit vectors in degrees (atan2 of |a × b| and a · b: accurate at small
/// angles too).
pub(super) fn angle_deg(a: DVec3, b: DVec3) -> f64 {
    a.cross(b).length().atan2(a.dot(b)).to_degrees()
}

/// Whether unit vectors `a` and `b` are the same direction within 1e-9 radians: two
/// triangles of one planar quad, whose face normals differ by rounding only.
pub(super) fn parallel(a: DVec3, b: DVec3) -> bool {
    a.dot(b) > 0.0 && a.cross(b).length() <= 1e-9
}

/// The corners of group `g` in fan order around its vertex (counter-clockwise: each
/// triangle's edge to the vertex before it is the next one's edge to the vertex after),
/// and whether the fan closes; `None` where the corners form no single fan (non-manifold,
/// or several sheets meeting at the vertex).
pub(super) fn fan_order(mesh: &Mesh, corners: &[u32]) -> Option<(Vec<u32>, bool)> {
    let after = |c: u32| mesh.triangles[c as usize / 3][(c as usize % 3 + 1) % 3];
    let before = |c: u32| mesh.triangles[c as usize / 3][(c as usize % 3 + 2) % 3];
    let mut by_after: HashMap<u32, u32> = HashMap::new();
    for &c in corners {
        if by_after.insert(after(c), c).is_some() {
            return None;
        }
    }
    let succ = |c: u32| by_after.get(&before(c)).copied();
    let has_pred: HashSet<u32> = corners.iter().filter_map(|&c| succ(c)).collect();
    let start = corners
        .iter()
        .copied()
        .find(|c| !has_pred.contains(c))
        .unwrap_or(corners[0]);
    let mut order = vec![start];
    let mut closed = false;
    let mut c = start;
    while let Some(n) = succ(c) {
        if n == start {
            closed = true;
            break;
        }
        if order.len() >= corners.len() {
            return None;
        }
        order.push(n);
        c = n;
    }
    (order.len() == corners.len()).then_some((order, closed))
}

/// For each half-edge 3t + k of an edge used by exactly two triangles, the other use's
/// half-edge; `u32::MAX` otherwise.
pub(super) fn twins(mesh: &Mesh) -> Vec<u32> {
    let index = EdgeIndex::new(&mesh.triangles);
    let mut tw = vec![u32::MAX; 3 * mesh.triangles.len()];
    for e in index.edges().filter(|e| e.is_interior()) {
        tw[e.half_edges[0] as usize] = e.half_edges[1];
        tw[e.half_edges[1] as usize] = e.half_edges[0];
    }
    tw
}

/// Interior edges (two uses) of `work` whose uses disagree on an end's normal, and did not
/// in `mesh` (same triangles).
pub(super) fn new_creases(mesh: &Mesh, work: &Mesh) -> usize {
    let crease = |m: &Mesh, e: &crate::mesh::adjacency::EdgeRef<'_>| {
        let [u0, u1] = [e.use_at(0), e.use_at(1)];
        e.v.iter().any(|&v| {
            normal_key(crate::mesh::creases::use_normal(m, u0, v))
                != normal_key(crate::mesh::creases::use_normal(m, u1, v))
        })
    };
    EdgeIndex::new(&work.triangles)
        .edges()
        .filter(|e| e.is_interior() && crease(work, e) && !crease(mesh, e))
        .count()
}

/// The unit vector with the largest smallest cosine to the unit vectors `f`, and that
/// cosine, exactly (to rounding): where it is positive the optimum has at most three
/// active vectors (equal smallest cosines), so it is one of the candidates enumerated
/// here: a vector of `f`, the bisector of two, or the direction at equal cosines to three
/// (M x = 1 for the matrix M of their rows). Where no open hemisphere holds `f` the
/// largest value found is at most 0. `None` for an empty `f`. Cubic in `f.len()` (fans
/// are small; the quick case of the mean direction facing them all comes first).
///
/// Over [`ENUMERATED`] vectors (a hub's fan: a book of n triangles around one edge has n
/// face normals), by constraint generation: the exact optimum of a subset, starting from
/// one vector, then the vector of `f` with the smallest cosine to it added, until none is
/// below the subset's value (the subset's optimum is then `f`'s) or the subset's value is
/// at most 0 (`f`'s is no more). Each round adds a vector not yet in the subset (its
/// cosine, computed as the subset's were, is below all of theirs), so the rounds end.
pub(super) fn max_min_direction(f: &[DVec3]) -> Option<(DVec3, f64)> {
    if f.len() <= ENUMERATED {
        return enumerate_max_min(f);
    }
    let mut subset = vec![*f.first()?];
    loop {
        let (x, v) = enumerate_max_min(&subset)?;
        let (k, m) =
            f.iter()
                .map(|a| a.dot(x))
                .enumerate()
                .fold(
                    (0, f64::INFINITY),
                    |b, (k, m)| if m < b.1 { (k, m) } else { b },
                );
        if m >= v || v <= 0.0 || subset.len() >= f.len() {
            return Some((x, m.min(v)));
        }
        subset.push(f[k]);
    }
}

/// Vectors up to which [`max_min_direction`] enumerates every candidate (the fans of the
/// test meshes have at most 11).
const ENUMERATED: usize = 32;

/// [`max_min_direction`] by enumeration of every candidate.
fn enumerate_max_min(f: &[DVec3]) -> Option<(DVec3, f64)> {
    let value = |n: DVec3| f.iter().map(|x| x.dot(n)).fold(f64::INFINITY, f64::min);
    let mut best: Option<(DVec3, f64)> = None;
    let mut offer = |n: DVec3| {
        if let Some(n) = n.try_normalize() {
            let v = value(n);
            if best.is_none_or(|(_, b)| v > b) {
                best = Some((n, v));
            }
        }
    };
    for (i, &a) in f.iter().enumerate() {
        offer(a);
        for (j, &b) in f.iter().enumerate().skip(i + 1) {
            offer(a + b);
            for &c in &f[j + 1..] {
                // x = M⁻¹ 1 by Cramer's rule: x · a = x · b = x · c = 1 / det-scaled.
                let (bc, ca, ab) = (b.cross(c), c.cross(a), a.cross(b));
                let det = a.dot(bc);
                if det.abs() > 1e-300 {
                    let x = (bc + ca + ab) / det;
                    offer(x);
                    offer(-x);
                }
            }
        }
    }
    best
}

/// The unit vector nearest to `n` (smallest angle) whose cosine to each of the unit
/// vectors `f` is at least `m` (0 ≤ m < 1), or `None` where none is. The feasible set is
/// an intersection of spherical caps smaller than a hemisphere, so convex, and its point
/// nearest to `n` is `n` itself, the projection of `n` on one cap's circle, or a corner
/// where two circles cross: all are enumerated here and the nearest feasible one is kept
/// (feasible to 1e-12, the rounding of the construction).
pub(super) fn nearest_facing(n: DVec3, f: &[DVec3], m: f64) -> Option<DVec3> {
    let feasible = |x: DVec3| f.iter().all(|a| a.dot(x) >= m - 1e-12);
    if feasible(n) {
        return Some(n);
    }
    let s = (1.0 - m * m).max(0.0).sqrt();
    let mut best: Option<(f64, DVec3)> = None;
    let mut offer = |x: DVec3| {
        if let Some(x) = x.try_normalize() {
            if feasible(x) && best.is_none_or(|(d, _)| x.dot(n) > d) {
                best = Some((x.dot(n), x));
            }
        }
    };
    for (i, &a) in f.iter().enumerate() {
        if let Some(u) = (n - n.dot(a) * a).try_normalize() {
            offer(m * a + s * u);
        }
        for &b in &f[i + 1..] {
            let c = a.dot(b);
            let Some(d) = a.cross(b).try_normalize() else {
                continue;
            };
            // The point of span{a, b} with cosine m to both, then ± along a × b.
            let p = (m / (1.0 + c)) * (a + b);
            let h = 1.0 - p.length_squared();
            if h >= 0.0 {
                offer(p + h.sqrt() * d);
                offer(p - h.sqrt() * d);
            }
        }
    }
    best.map(|(_, x)| x)
}

/// Scaled corner Jacobians below which the crease-free phase's joint moves push a corner
/// up ([`corner_shortfall`]).
pub(super) const CORNER_AIM: f64 = 0.1;

/// The smallest scaled Jacobian of the G1 patch of triangle `t` of `work` at its three
/// corners, from the Walton–Meek end tangents alone: at corner k the patch's S_s × S_t is
/// along the cross product of the tangents of its two boundary curves there, and each
/// tangent depends on the normals of both of its curve's ends (not only on the corner's:
/// the Walton–Meek tangent is the chord projected plus a multiple of the far end's normal
/// projected). The value is the smaller of that cross product along the face normal and
/// along the corner's normal (a patch turned inside out at the corner), over the tangents'
/// lengths.
pub(super) fn corner_values(work: &Mesh, t: usize) -> [f64; 3] {
    let tri = work.triangles[t];
    let q = tri.map(|v| work.positions[v as usize]);
    let n = work.corner_normals[t];
    let nf = crate::mesh::normals::face_normal(q);
    std::array::from_fn(|k| {
        let (i, j) = ((k + 1) % 3, (k + 2) % 3);
        let a = crate::patch::g1::walton_meek_offsets(q[k], n[k], q[i], n[i])[0];
        let b = crate::patch::g1::walton_meek_offsets(q[k], n[k], q[j], n[j])[0];
        let s = a.length() * b.length();
        if s.is_nan() || s <= 0.0 {
            return -1.0;
        }
        let c = a.cross(b);
        (c.dot(nf) / s).min(c.dot(n[k]) / s)
    })
}

/// The corner shortfall of the triangles `tris`: the sum of the squares of their
/// [`corner_values`] below [`CORNER_AIM`].
pub(super) fn corner_shortfall(work: &Mesh, tris: &[u32]) -> f64 {
    tris.iter()
        .flat_map(|&t| corner_values(work, t as usize))
        .map(|v| (CORNER_AIM - v).max(0.0).powi(2))
        .sum()
}

#[cfg(test)]
mod tests {
    use super::{enumerate_max_min, max_min_direction, ENUMERATED};
    use glam::DVec3;

    /// Unit vectors from a fixed linear congruential sequence, within `spread` of +z
    /// (`spread` 2 covers the sphere).
    fn vectors(n: usize, seed: u64, spread: f64) -> Vec<DVec3> {
        let mut s = seed;
        let mut next = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        (0..n)
            .map(|_| {
                let z = 1.0 - spread * next();
                let a = std::f64::consts::TAU * next();
                let r = (1.0 - z * z).max(0.0).sqrt();
                DVec3::new(r * a.cos(), r * a.sin(), z)
            })
            .collect()
    }

    /// Over [`ENUMERATED`] vectors the constraint generation finds the enumeration's
    /// optimum: the same value to 1e-12 (rounding of the normalisations) where a
    /// hemisphere holds them, a value at most 0 where none does (the enumeration's then is
    /// too); the sets are 40 and 120 vectors in caps of 30° to 180°.
    #[test]
    fn constraint_generation_finds_the_enumerations_optimum() {
        for (k, spread) in [0.13, 0.5, 1.0, 1.3, 2.0].into_iter().enumerate() {
            for n in [ENUMERATED + 8, 120] {
                let f = vectors(n, 7 + k as u64, spread);
                let (x, v) = max_min_direction(&f).unwrap();
                let (_, e) = enumerate_max_min(&f).unwrap();
                assert!((x.length() - 1.0).abs() < 1e-15);
                let min = f.iter().map(|a| a.dot(x)).fold(f64::INFINITY, f64::min);
                assert_eq!(min, v, "the value is the smallest cosine to x");
                if e > 0.0 {
                    assert!((v - e).abs() <= 1e-12, "{spread} {n}: {v} {e}");
                } else {
                    assert!(v <= 0.0, "{spread} {n}: {v} {e}");
                }
            }
        }
        // A book's pages: face normals all around the equator, no hemisphere.
        let f: Vec<DVec3> = (0..1000)
            .map(|k| {
                let a = std::f64::consts::TAU * k as f64 / 1000.0;
                DVec3::new(a.cos(), a.sin(), 0.0)
            })
            .collect();
        assert!(max_min_direction(&f).unwrap().1 <= 0.0);
    }
}
