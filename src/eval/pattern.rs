//! Sample patterns: the barycentric grid of level n, explicit (patch, point) lists, and the
//! continuity pattern of shared edges ([`EdgePairs`]).

/// One evaluation point on one patch.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PatchPoint {
    /// The patch (triangle) index.
    pub patch: u32,
    /// Barycentric coordinates (b0 + b1 + b2 = 1).
    pub b: [f64; 3],
}

/// Where to evaluate.
#[derive(Clone, Debug)]
pub enum Pattern {
    /// Every patch on the grid of level n: (n + 1)(n + 2)/2 points (see
    /// [`grid_barycentrics`]).
    Grid {
        /// The level n: n segments along each patch edge.
        level: u32,
    },
    /// Explicit points.
    Points(Vec<PatchPoint>),
}

impl Pattern {
    /// Number of samples for a table of `patches` patches.
    pub fn len(&self, patches: usize) -> usize {
        match self {
            Pattern::Grid { level } => grid_len(*level).saturating_mul(patches),
            Pattern::Points(p) => p.len(),
        }
    }

    /// Whether a table of `patches` patches has no sample.
    pub fn is_empty(&self, patches: usize) -> bool {
        self.len(patches) == 0
    }

    /// Samples of one item of the pattern's chunks ([`crate::Chunk::first`] counts items):
    /// a grid's patches, or points.
    pub fn item_len(&self) -> usize {
        match self {
            Pattern::Grid { level } => grid_len(*level),
            Pattern::Points(_) => 1,
        }
    }
}

/// One use of an edge by a patch: the patch, and the barycentric slots of the edge's start
/// and end vertex on it (`from != to`, both below 3). At parameter t the point is
/// `b[from] = 1 − t`, `b[to] = t`, the third coordinate 0.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EdgeSide {
    /// The patch that uses the edge.
    pub patch: u32,
    /// Barycentric slot of the edge's start vertex on the patch.
    pub from: u8,
    /// Barycentric slot of the edge's end vertex on the patch.
    pub to: u8,
}

/// The continuity pattern of shared edges (Table 1 of `spec/EVALUATION.md`): for each pair
/// (the two uses of one interior edge, walked from the same start vertex), for each sample
/// i in `0..samples` at t = i / (samples − 1), the point on side 0 then the same point on
/// side 1. Both ends are exact (t = 0 and t = 1; a single sample is t = 0).
///
/// The samples are [`len`](Self::len) = 2 · samples · pairs evaluation points, in exactly
/// the order of [`points`](Self::points) (so a result index is `2 · (samples · pair + i) +
/// side`), at 12 bytes per edge instead of an explicit point list's 2 · samples · 32.
/// Evaluated with [`crate::eval::Evaluator::evaluate_edges`]: the CPU backend computes
/// the basis once per (from, to, i) and never looks a point up; any backend gives the same
/// values as [`Pattern::Points`] of [`points`](Self::points).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct EdgePairs {
    /// Samples per edge, both ends included.
    pub samples: u32,
    /// The two uses of each interior edge, walked from the same start vertex.
    pub pairs: Vec<[EdgeSide; 2]>,
}

impl EdgePairs {
    /// Evaluation points: 2 · samples per pair.
    pub fn len(&self) -> usize {
        2 * self.samples as usize * self.pairs.len()
    }

    /// Whether the pattern has no evaluation point.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// (1 − t, t) of sample `i`: t = i / (samples − 1), exactly 0 and 1 at the ends.
    #[inline]
    pub fn params(&self, i: u32) -> (f64, f64) {
        let n = self.samples.saturating_sub(1).max(1);
        ((n - i.min(n)) as f64 / n as f64, i.min(n) as f64 / n as f64)
    }

    /// Barycentric point of sample `i` on `side`.
    #[inline]
    pub fn barycentric(&self, side: EdgeSide, i: u32) -> [f64; 3] {
        let (s, t) = self.params(i);
        let mut b = [0.0; 3];
        b[side.from as usize] = s;
        b[side.to as usize] = t;
        b
    }

    /// Evaluation point `index` (in [`len`](Self::len) order).
    pub fn point(&self, index: usize) -> PatchPoint {
        let per = self.samples as usize;
        let (q, side) = (index / 2, index % 2);
        let e = self.pairs[q / per][side];
        PatchPoint {
            patch: e.patch,
            b: self.barycentric(e, (q % per) as u32),
        }
    }

    /// Appends evaluation points `range` (in [`len`](Self::len) order) to `out`.
    pub fn points_into(&self, range: std::ops::Range<usize>, out: &mut Vec<PatchPoint>) {
        out.extend(range.map(|k| self.point(k)));
    }

    /// Every evaluation point, as an explicit list.
    pub fn points(&self) -> Vec<PatchPoint> {
        let mut out = Vec::with_capacity(self.len());
        self.points_into(0..self.len(), &mut out);
        out
    }

    /// Checks every side against a table of `patches` patches.
    pub fn check(&self, patches: usize) -> crate::Result<()> {
        for (k, pair) in self.pairs.iter().enumerate() {
            for e in pair {
                if e.patch as usize >= patches {
                    return Err(crate::Error::Invalid(format!(
                        "edge pair {k}: patch {} of a table of {patches} patches",
                        e.patch
                    )));
                }
                if e.from == e.to || e.from > 2 || e.to > 2 {
                    return Err(crate::Error::Invalid(format!(
                        "edge pair {k}: barycentric slots {} -> {} (two different slots of 0, 1, 2 expected)",
                        e.from, e.to
                    )));
                }
            }
        }
        Ok(())
    }
}

/// Points per patch on the grid of level n (saturating at `usize::MAX / 2` where the
/// product does not fit: at level `u32::MAX` on 64-bit targets, from level 65,535 on
/// 32-bit ones; estimates of memory that use it then refuse rather than wrap).
pub fn grid_len(level: u32) -> usize {
    let n = level as usize;
    n.saturating_add(1).saturating_mul(n.saturating_add(2)) / 2
}

/// Index of grid point (i, j) (b1 = i/n, b2 = j/n) in grid order: rows of constant j,
/// i increasing.
pub fn grid_index(level: u32, i: u32, j: u32) -> usize {
    let n = level as usize;
    let j = j as usize;
    // Rows 0..j hold n + 1, n, ..., n + 2 − j points.
    j * (n + 1) - j * (j.saturating_sub(1)) / 2 + i as usize
}

/// Grid indices of the three corners of the grid of level n: corner k is the point with
/// b_k = 1 (the patch's input vertex k).
pub fn grid_corners(level: u32) -> [usize; 3] {
    let n = level.max(1);
    [
        grid_index(n, 0, 0),
        grid_index(n, n, 0),
        grid_index(n, 0, n),
    ]
}

/// Barycentric points of the grid of level n (n ≥ 1), rows of constant b2 = j/n with
/// b1 = i/n increasing; b0 = (n − i − j)/n exactly.
pub fn grid_barycentrics(level: u32) -> Vec<[f64; 3]> {
    let n = level.max(1);
    let nf = n as f64;
    let mut out = Vec::with_capacity(grid_len(n));
    for j in 0..=n {
        for i in 0..=n - j {
            out.push([(n - i - j) as f64 / nf, i as f64 / nf, j as f64 / nf]);
        }
    }
    out
}

/// Triangles of the grid of level n as local indices, oriented like the patch
/// (counter-clockwise in (b1, b2), so like the input triangle).
pub fn grid_triangles(level: u32) -> Vec<[u32; 3]> {
    let n = level.max(1);
    let mut out = Vec::with_capacity(n as usize * n as usize);
    for j in 0..n {
        for i in 0..n - j {
            let a = grid_index(n, i, j) as u32;
            let b = grid_index(n, i + 1, j) as u32;
            let c = grid_index(n, i, j + 1) as u32;
            out.push([a, b, c]);
            if i + 1 < n - j {
                let d = grid_index(n, i + 1, j + 1) as u32;
                out.push([b, d, c]);
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use crate::eval::pattern::{
        grid_barycentrics, grid_corners, grid_index, grid_len, grid_triangles,
    };

    /// The largest level's count does not fit a 64-bit product: it saturates, so a
    /// memory estimate built on it refuses instead of wrapping to a small figure.
    #[test]
    #[cfg(target_pointer_width = "64")]
    fn the_largest_grid_saturates() {
        assert_eq!(grid_len(u32::MAX), usize::MAX / 2);
        // The level below fits: 2^32 (2^32 − 1) / 2.
        assert_eq!(grid_len(u32::MAX - 1), (1usize << 31) * (u32::MAX as usize));
        // A pattern's sample count saturates with it.
        let grid = crate::eval::Pattern::Grid { level: u32::MAX };
        assert_eq!(grid.len(3), usize::MAX);
        // Gmsh's node count is the grid's, past the orders whose product overflows a u32.
        assert_eq!(
            crate::io::msh::triangle_node_count(70_000),
            70_001 * 70_002 / 2
        );
    }

    #[test]
    fn grid_index_and_triangles() {
        for n in 1..=9 {
            let b = grid_barycentrics(n);
            assert_eq!(b.len(), grid_len(n));
            for j in 0..=n {
                for i in 0..=n - j {
                    let p = b[grid_index(n, i, j)];
                    assert_eq!(p[1], i as f64 / n as f64);
                    assert_eq!(p[2], j as f64 / n as f64);
                }
            }
            assert_eq!(grid_triangles(n).len(), (n * n) as usize);
            assert_eq!(grid_len(n), (n as usize + 1) * (n as usize + 2) / 2);
            let c = grid_corners(n);
            assert_eq!(c, [0, n as usize, grid_len(n) - 1]);
            for (k, &g) in c.iter().enumerate() {
                assert_eq!(b[g][k], 1.0);
            }
        }
    }
}
