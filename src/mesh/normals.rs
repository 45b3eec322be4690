//! Vertex-normal estimation from face normals.

use glam::DVec3;

use crate::par::filled_with;
use rayon::prelude::*;

/// How face normals are weighted when a vertex normal is estimated.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum NormalWeighting {
    /// Plain mean of the unit normals of the incident faces.
    Unweighted,
    /// Faces weighted by their area.
    Area,
    /// Faces weighted by the corner angle at the vertex (the default: independent of how
    /// the neighbourhood is triangulated).
    Angle,
}

/// Triangles whose corner weights are computed together (in parallel) while the previous
/// block's are summed.
const WEIGHT_BLOCK: usize = 1 << 14;

/// One unit normal per vertex from the incident faces. A vertex whose weighted sum vanishes
/// (or that no face uses) gets the sum of the unweighted unit face normals, and failing
/// that +z, so the result is always a finite unit vector.
///
/// The face normals and corner weights (an `acos` per corner by default) are computed in
/// parallel, a block of triangles at a time, while the block before is added up in one task
/// in triangle order: each vertex's sum takes its terms in the same order as a serial loop,
/// so the result does not depend on the threads.
pub fn vertex_normals(
    positions: &[DVec3],
    triangles: &[[u32; 3]],
    weighting: NormalWeighting,
) -> Vec<DVec3> {
    // Made on the pool (`filled_with`): the sums below add into them in one task.
    let zeros = || filled_with(positions.len(), || DVec3::ZERO);
    let (mut acc, mut fallback) = rayon::join(zeros, zeros);
    let weigh = |block: &[[u32; 3]], out: &mut Vec<Option<(DVec3, [f64; 3])>>| {
        block
            .par_iter()
            .map(|t| corner_weights(t.map(|v| positions[v as usize]), weighting))
            .collect_into_vec(out);
    };
    let mut add = |block: &[[u32; 3]], weights: &[Option<(DVec3, [f64; 3])>]| {
        for (t, cw) in block.iter().zip(weights) {
            let Some((unit, w)) = *cw else {
                continue;
            };
            for k in 0..3 {
                acc[t[k] as usize] += w[k] * unit;
                fallback[t[k] as usize] += unit;
            }
        }
    };
    let blocks: Vec<&[[u32; 3]]> = triangles.chunks(WEIGHT_BLOCK).collect();
    let (mut cur, mut next) = (Vec::new(), Vec::new());
    if let Some(first) = blocks.first() {
        weigh(first, &mut cur);
    }
    for (b, block) in blocks.iter().enumerate() {
        match blocks.get(b + 1) {
            Some(following) => {
                rayon::join(|| add(block, &cur), || weigh(following, &mut next));
            }
            None => add(block, &cur),
        }
        std::mem::swap(&mut cur, &mut next);
    }
    // In place: a new vector would be fresh memory to fault in.
    acc.par_iter_mut()
        .zip(&fallback)
        .for_each(|(a, f)| *a = normal_of_sums(*a, *f));
    acc
}

/// A vertex's normal from its weighted sum `a` and its unweighted sum `f`
/// ([`vertex_normals`]): `a` made unit, else `f`, else +z.
fn normal_of_sums(a: DVec3, f: DVec3) -> DVec3 {
    a.try_normalize()
        .or_else(|| f.try_normalize())
        .unwrap_or(DVec3::Z)
}

/// Unit normal of a flat triangle and the weight of each of its corners in a vertex-normal
/// estimate; `None` for a degenerate (zero-area or non-finite) triangle.
pub fn corner_weights(p: [DVec3; 3], weighting: NormalWeighting) -> Option<(DVec3, [f64; 3])> {
    let cross = (p[1] - p[0]).cross(p[2] - p[0]);
    let len = cross.length();
    if len == 0.0 || !len.is_finite() {
        return None;
    }
    let w = std::array::from_fn(|k| match weighting {
        NormalWeighting::Unweighted => 1.0,
        NormalWeighting::Area => 0.5 * len,
        NormalWeighting::Angle => {
            let e1 = (p[(k + 1) % 3] - p[k]).normalize_or_zero();
            let e2 = (p[(k + 2) % 3] - p[k]).normalize_or_zero();
            e1.dot(e2).clamp(-1.0, 1.0).acos()
        }
    });
    Some((cross / len, w))
}

/// Largest coordinate magnitude a mesh may hold. Normals and patches take lengths of cross
/// products of edges, fourth powers of coordinates: below this bound they stay finite in
/// f64 (edges up to 2e75, cross products up to about 1.2e151, their squares about 1.4e302).
pub const MAX_COORD: f64 = 1e75;

/// `n` scaled to unit length, computed without overflow or underflow (huge and subnormal
/// finite vectors work); `None` for a zero or non-finite vector.
pub fn unit(n: DVec3) -> Option<DVec3> {
    if !n.is_finite() {
        return None;
    }
    // The plain quotient where the squared length is a normal finite f64 (the common case,
    // unchanged bit for bit); scaled by the largest component first elsewhere.
    let len = n.length();
    if len.is_finite() && len >= 1e-150 {
        return Some(n / len);
    }
    let m = n.abs().max_element();
    if m == 0.0 {
        return None;
    }
    let s = n / m;
    Some(s / s.length())
}

/// Whether a triangle has an area, so a normal: the squared length of the cross product of
/// its edges is finite and at least the smallest normal f64. Repeated or collinear corners,
/// and triangles so small that their squared area underflows (edges below about 1e-77),
/// have none.
pub fn has_area(p: [DVec3; 3]) -> bool {
    let sq = (p[1] - p[0]).cross(p[2] - p[0]).length_squared();
    sq.is_finite() && sq >= f64::MIN_POSITIVE
}

/// Unit normal of a flat triangle (zero for a degenerate one).
pub fn face_normal(p: [DVec3; 3]) -> DVec3 {
    (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// [`vertex_normals`] as one loop in triangle order: the sums it must give bit for bit.
    fn serial(positions: &[DVec3], triangles: &[[u32; 3]], w: NormalWeighting) -> Vec<DVec3> {
        let mut acc = vec![DVec3::ZERO; positions.len()];
        let mut fallback = acc.clone();
        for t in triangles {
            if let Some((unit, cw)) = corner_weights(t.map(|v| positions[v as usize]), w) {
                for k in 0..3 {
                    acc[t[k] as usize] += cw[k] * unit;
                    fallback[t[k] as usize] += unit;
                }
            }
        }
        acc.iter()
            .zip(&fallback)
            .map(|(a, f)| normal_of_sums(*a, *f))
            .collect()
    }

    /// On pools of 1 to 8 threads every weighting gives the serial loop's normals bit for
    /// bit: the bunny (several blocks of [`WEIGHT_BLOCK`]), Suzanne, an icosphere, and a
    /// strip with degenerate triangles and an unused vertex; no triangles give +z.
    #[test]
    fn vertex_normals_are_the_serial_sums_on_any_pool() {
        let load = crate::tests::common::load;
        let mut strip = load("icosphere:1");
        strip.triangles.truncate(30);
        strip.triangles.push([0, 0, 1]);
        strip.triangles.push([2, 3, 2]);
        strip.positions.push(DVec3::new(7.0, 8.0, 9.0));
        let meshes = [
            load("stanford-bunny.obj"),
            load("suzanne.obj"),
            load("icosphere:4"),
            strip,
        ];
        assert!(meshes[0].triangles.len() > 2 * WEIGHT_BLOCK);
        let weightings = [
            NormalWeighting::Unweighted,
            NormalWeighting::Area,
            NormalWeighting::Angle,
        ];
        let bits = |n: &[DVec3]| -> Vec<[u64; 3]> {
            n.iter().map(|v| v.to_array().map(f64::to_bits)).collect()
        };
        for mesh in &meshes {
            for w in weightings {
                let want = bits(&serial(&mesh.positions, &mesh.triangles, w));
                for threads in [1, 2, 3, 8] {
                    let pool = rayon::ThreadPoolBuilder::new()
                        .num_threads(threads)
                        .build()
                        .unwrap();
                    let got = pool.install(|| vertex_normals(&mesh.positions, &mesh.triangles, w));
                    assert!(bits(&got) == want, "{} {w:?} {threads} threads", mesh.name);
                }
            }
        }
        let none = vertex_normals(&meshes[3].positions, &[], NormalWeighting::Angle);
        assert!(none.iter().all(|&n| n == DVec3::Z));
    }
}
