//! The tessellation pattern of one patch with an integer level per edge and an inner level:
//! where its samples lie and how they are connected.
//!
//! The layout follows OpenSubdiv's Bfr tessellation of a triangular domain
//! (`opensubdiv/bfr/tessellation.cpp`, the non-uniform triangle: an inner uniform
//! tessellation of the inner rate, its outer ring dropped, and the boundary points of each
//! edge's own rate connected to that inner ring by a strip of triangles,
//! `FacetStrip::connectNonUniformFacets`, with the inner ring offset half a step), with
//! integer partitioning (a level n is n equal segments):
//!
//! - all three edge levels equal to the inner level n: the uniform grid of level n
//!   ([`crate::eval::grid_triangles`]), so a uniform level is the special case;
//! - otherwise the inner level is raised to 3 at least (n' = max(n, 3)); the interior points
//!   are the points of the grid of level n' whose three barycentric coordinates are at least
//!   1/n' (a grid of level n' − 3, shifted by one step), connected as that grid; a corner
//!   whose two edges have levels of 2 at least, summing to more than n', is cut off as the
//!   grid cuts it (the triangle of its two nearest edge samples, and the triangle joining
//!   those to the inner ring's corner); the strip of edge k joins its remaining points
//!   (corner to corner, less the cut-off corners) to the n' − 2 points of the inner ring's
//!   side k, walking both by the midpoints of their segments (the inner ring's points at
//!   (s + 1.5)/n' along the edge, s = 0..n' − 3). With every level equal this is exactly
//!   the grid's triangulation; the grid itself is used then.
//!
//! Counts: points = 3 + Σ(E_k − 1) + (n' − 1)(n' − 2)/2, triangles = (n' − 3)² + ΣE_k +
//! 3(n' − 3) (this is n² for the uniform grid too, with n' = n).
//!
//! Local numbering (the order of a patch's samples): corners 0, 1, 2; the E_k − 1 samples of
//! local edge k from corner k towards corner k + 1, for k = 0, 1, 2; then the interior in
//! grid order (rows of constant b2, b1 increasing). Edge sample i of E lies at b_k =
//! (E − i)/E, b_{k+1} = i/E, so both triangles of an edge compute the same barycentric values
//! for its points whichever way they run along it. Triangles are oriented like the patch.

use std::ops::Range;

use crate::eval::pattern::grid_index;
use crate::eval::{grid_len, grid_triangles};

/// Largest level a per-edge or inner level may take.
pub const MAX_LEVEL: u32 = 1 << 12;

/// Whether the pattern is the uniform grid (every edge level equal to the inner level).
#[inline]
pub fn is_uniform(edges: [u32; 3], inner: u32) -> bool {
    edges.iter().all(|&e| e == inner)
}

/// The inner level the pattern uses: `inner` for the uniform grid, max(inner, 3) otherwise
/// (an inner ring needs a point off the boundary).
#[inline]
pub fn effective_inner(edges: [u32; 3], inner: u32) -> u32 {
    if is_uniform(edges, inner) {
        inner
    } else {
        inner.max(3)
    }
}

/// Samples of one patch: 3 + Σ(E_k − 1) + (n' − 1)(n' − 2)/2.
pub fn point_count(edges: [u32; 3], inner: u32) -> usize {
    3 + edges.iter().map(|&e| e as usize - 1).sum::<usize>() + interior_count(edges, inner)
}

/// Interior samples of one patch: (n' − 1)(n' − 2)/2 (none at n' = 1, where n' − 2 is
/// below zero: the product is taken as 0 rather than wrapped).
pub fn interior_count(edges: [u32; 3], inner: u32) -> usize {
    let n = effective_inner(edges, inner) as usize;
    n.saturating_sub(1) * n.saturating_sub(2) / 2
}

/// Triangles of one patch: (n' − 3)² + ΣE_k + 3(n' − 3) (in i128, where n'² fits;
/// saturating at `usize::MAX` where the count does not fit a `usize`).
pub fn triangle_count(edges: [u32; 3], inner: u32) -> usize {
    let n = effective_inner(edges, inner) as i128;
    let sum: i128 = edges.iter().map(|&e| e as i128).sum();
    usize::try_from((n - 3) * (n - 3) + sum + 3 * (n - 3)).unwrap_or(usize::MAX)
}

/// First local index of each edge's samples, and of the interior.
fn bases(edges: [u32; 3]) -> ([u32; 3], u32) {
    let b0 = 3;
    let b1 = b0 + edges[0] - 1;
    let b2 = b1 + edges[1] - 1;
    ([b0, b1, b2], b2 + edges[2] - 1)
}

/// Local index of the samples of local edge k at steps 1..E_k (from corner k), and the
/// range of the interior.
pub fn local_edges(edges: [u32; 3], inner: u32) -> ([Range<u32>; 3], Range<usize>) {
    let (b, int) = bases(edges);
    let ranges = [0, 1, 2].map(|k| b[k]..b[k] + edges[k] - 1);
    let len = interior_count(edges, inner);
    (ranges, int as usize..int as usize + len)
}

/// Local index of grid point (i, j) (b1 = i/n, b2 = j/n) of the grid of level n = the
/// effective inner level, for points on the boundary only where the edge levels equal n.
fn local_of(edges: [u32; 3], n: u32, i: u32, j: u32) -> u32 {
    let (b, int) = bases(edges);
    if j == 0 {
        match i {
            0 => 0,
            _ if i == n => 1,
            _ => b[0] + i - 1,
        }
    } else if i + j == n {
        if j == n {
            2
        } else {
            b[1] + j - 1
        }
    } else if i == 0 {
        b[2] + (n - j) - 1
    } else {
        int + grid_index(n - 3, i - 1, j - 1) as u32
    }
}

/// Appends the barycentric coordinates of the patch's samples, in local order.
pub fn points(edges: [u32; 3], inner: u32, out: &mut Vec<[f64; 3]>) {
    let n = effective_inner(edges, inner);
    out.reserve(point_count(edges, inner));
    for k in 0..3 {
        let mut b = [0.0; 3];
        b[k] = 1.0;
        out.push(b);
    }
    for (k, &e) in edges.iter().enumerate() {
        let ef = e as f64;
        for i in 1..e {
            let mut b = [0.0; 3];
            b[k] = (e - i) as f64 / ef;
            b[(k + 1) % 3] = i as f64 / ef;
            out.push(b);
        }
    }
    let nf = n as f64;
    for j in 1..n.saturating_sub(1) {
        for i in 1..n - j {
            out.push([(n - i - j) as f64 / nf, i as f64 / nf, j as f64 / nf]);
        }
    }
}

/// Appends the patch's triangles (local indices), oriented like the patch.
pub fn triangles(edges: [u32; 3], inner: u32, out: &mut Vec<[u32; 3]>) {
    let n = effective_inner(edges, inner);
    out.reserve(triangle_count(edges, inner));
    if is_uniform(edges, inner) {
        let pts: Vec<[u32; 2]> = (0..=n)
            .flat_map(|j| (0..=n - j).map(move |i| [i, j]))
            .collect();
        debug_assert_eq!(pts.len(), grid_len(n));
        let map: Vec<u32> = pts.iter().map(|&[i, j]| local_of(edges, n, i, j)).collect();
        out.extend(grid_triangles(n).iter().map(|t| t.map(|g| map[g as usize])));
        return;
    }
    rings(edges, n, out);
}

/// The non-uniform pattern's triangles with inner level `n` ≥ 3.
pub fn rings(edges: [u32; 3], n: u32, out: &mut Vec<[u32; 3]>) {
    let (b, int) = bases(edges);
    // The interior: the grid of level n − 3 shifted one step in.
    if n >= 4 {
        out.extend(grid_triangles(n - 3).iter().map(|t| t.map(|g| int + g)));
    }
    // Local index of sample i (0..=E_k) of edge k: corner k, its samples, corner k + 1.
    let outer = |k: usize, i: u32| -> u32 {
        if i == 0 {
            k as u32
        } else if i == edges[k] {
            ((k + 1) % 3) as u32
        } else {
            b[k] + i - 1
        }
    };
    // Inner ring side k, point s: b_k = n − 2 − s, b_{k+1} = 1 + s, b_{k+2} = 1 (steps 1/n).
    let inner_pt = |k: usize, s: u32| -> u32 {
        let mut c = [0u32; 3];
        c[k] = n - 2 - s;
        c[(k + 1) % 3] = 1 + s;
        c[(k + 2) % 3] = 1;
        int + grid_index(n - 3, c[1] - 1, c[2] - 1) as u32
    };
    // Corner k is cut off (as the grid does) by the triangle of its two nearest edge samples,
    // joined to the inner ring's corner k by a second triangle; that one is positive where
    // the inner corner lies beyond the cut: E_{k−1} + E_k > n.
    let cut: [bool; 3] = std::array::from_fn(|k| {
        let (prev, next) = (edges[(k + 2) % 3], edges[k]);
        prev >= 2 && next >= 2 && prev + next > n
    });
    for (k, _) in cut.iter().enumerate().filter(|(_, &c)| c) {
        let kp = (k + 2) % 3;
        let (first, last) = (outer(k, 1), outer(kp, edges[kp] - 1));
        out.push([k as u32, first, last]);
        out.push([first, inner_pt(k, 0), last]);
    }
    for k in 0..3 {
        // The strip of edge k: its samples between the cuts against the inner ring's side.
        let i0 = cut[k] as u64;
        let a = edges[k] as u64 - cut[(k + 1) % 3] as u64;
        let m = (n - 3) as u64;
        let (mut i, mut s) = (i0, 0u64);
        while i < a || s < m {
            // Advance along the edge where its next segment's midpoint (2i + 1)/(2E) comes
            // before the inner ring's, (s + 2)/n.
            if s == m || (i < a && (2 * i + 1) * (n as u64) < 2 * edges[k] as u64 * (s + 2)) {
                out.push([
                    outer(k, i as u32),
                    outer(k, i as u32 + 1),
                    inner_pt(k, s as u32),
                ]);
                i += 1;
            } else {
                out.push([
                    outer(k, i as u32),
                    inner_pt(k, s as u32 + 1),
                    inner_pt(k, s as u32),
                ]);
                s += 1;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::rings;
    use crate::eval::{grid_barycentrics, grid_len};
    use crate::tess::layout::{interior_count, point_count, points, triangle_count, triangles};

    /// Signed area of a triangle in (b1, b2).
    fn area(p: &[[f64; 3]], t: [u32; 3]) -> f64 {
        let [a, b, c] = t.map(|i| p[i as usize]);
        (b[1] - a[1]) * (c[2] - a[2]) - (b[2] - a[2]) * (c[1] - a[1])
    }

    #[test]
    fn uniform_is_the_grid_and_counts_hold() {
        for n in 1..=7 {
            let mut p = Vec::new();
            points([n; 3], n, &mut p);
            let mut g = grid_barycentrics(n);
            let key = |b: &[f64; 3]| (b[1].to_bits(), b[2].to_bits());
            let mut q = p.clone();
            q.sort_by_key(key);
            g.sort_by_key(key);
            assert_eq!(q.len(), g.len());
            for (x, y) in q.iter().zip(&g) {
                assert_eq!(x[1], y[1]);
                assert_eq!(x[2], y[2]);
            }
            let mut t = Vec::new();
            triangles([n; 3], n, &mut t);
            assert_eq!(t.len(), (n * n) as usize);
            // The counts are the grid's: (n + 1)(n + 2)/2 points, (n − 1)(n − 2)/2 inside
            // (none at n = 1 or 2, without wrapping below zero).
            assert_eq!(point_count([n; 3], n), grid_len(n));
            let m = n as usize;
            assert_eq!(
                interior_count([n; 3], n),
                if m < 3 { 0 } else { (m - 1) * (m - 2) / 2 }
            );
        }
    }

    /// A triangle's indices rotated to start at its smallest.
    fn canonical(t: [u32; 3]) -> [u32; 3] {
        let k = (0..3).min_by_key(|&k| t[k]).unwrap();
        [t[k], t[(k + 1) % 3], t[(k + 2) % 3]]
    }

    #[test]
    fn rings_with_equal_levels_are_the_grid() {
        for n in 3..=9 {
            let mut a = Vec::new();
            triangles([n; 3], n, &mut a);
            let mut b = Vec::new();
            rings([n; 3], n, &mut b);
            let mut a: Vec<_> = a.into_iter().map(canonical).collect();
            let mut b: Vec<_> = b.into_iter().map(canonical).collect();
            a.sort();
            b.sort();
            assert_eq!(a, b, "level {n}");
        }
    }

    /// The largest levels' counts: n² triangles (in i128, not an overflowing i64).
    #[test]
    #[cfg(target_pointer_width = "64")]
    fn the_largest_levels_count_without_overflow() {
        let n = u32::MAX;
        assert_eq!(triangle_count([n; 3], n), n as usize * n as usize);
        // Per-edge levels at most n on edges of level 1: 3·1 + 3(n' − 3) + (n' − 3)².
        let m = n as usize - 3;
        assert_eq!(triangle_count([1, 1, 1], n), m * m + 3 + 3 * m);
    }

    #[test]
    fn every_pattern_tiles_the_triangle() {
        for e0 in 1..=6 {
            for e1 in 1..=6 {
                for e2 in [1, 2, 5, 9, 17] {
                    for inner in [1, 2, 3, 4, 5, 6, 7, 12] {
                        let e = [e0, e1, e2];
                        let mut p = Vec::new();
                        points(e, inner, &mut p);
                        assert_eq!(p.len(), point_count(e, inner));
                        let mut t = Vec::new();
                        triangles(e, inner, &mut t);
                        assert_eq!(t.len(), triangle_count(e, inner));
                        // Positive areas summing to the whole triangle (area 1/2 in (b1,
                        // b2)): with every area positive, a sum of exactly the whole means
                        // no overlap and no gap. 1e-12: rounding of the sum of a few
                        // hundred areas.
                        let mut sum = 0.0;
                        for &tri in &t {
                            let a = area(&p, tri);
                            assert!(a > 0.0, "{e:?} {inner}: triangle {tri:?} area {a}");
                            sum += a;
                        }
                        assert!((sum - 1.0).abs() < 1e-12, "{e:?} {inner}: {sum}");
                        // Every boundary segment used once.
                        let mut uses = std::collections::HashMap::new();
                        for tri in &t {
                            for k in 0..3 {
                                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                                *uses.entry((a.min(b), a.max(b))).or_insert(0) += 1;
                            }
                        }
                        let boundary = uses.values().filter(|&&c| c == 1).count();
                        assert_eq!(boundary, (e0 + e1 + e2) as usize);
                        assert!(uses.values().all(|&c| c <= 2));
                    }
                }
            }
        }
    }
}
