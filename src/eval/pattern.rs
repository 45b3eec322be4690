//! Sample patterns: the barycentric grid of level n and explicit (patch, point) lists.

/// One evaluation point on one patch.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PatchPoint {
    pub patch: u32,
    /// Barycentric coordinates (b0 + b1 + b2 = 1).
    pub b: [f64; 3],
}

/// Where to evaluate.
#[derive(Clone, Debug)]
pub enum Pattern {
    /// Every patch on the grid of level n: (n + 1)(n + 2)/2 points (see
    /// [`grid_barycentrics`]).
    Grid { level: u32 },
    /// Explicit points.
    Points(Vec<PatchPoint>),
}

impl Pattern {
    /// Number of samples for a table of `patches` patches.
    pub fn len(&self, patches: usize) -> usize {
        match self {
            Pattern::Grid { level } => grid_len(*level) * patches,
            Pattern::Points(p) => p.len(),
        }
    }

    pub fn is_empty(&self, patches: usize) -> bool {
        self.len(patches) == 0
    }
}

/// Points per patch on the grid of level n.
pub fn grid_len(level: u32) -> usize {
    let n = level as usize;
    (n + 1) * (n + 2) / 2
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
    let mut out = Vec::with_capacity((n * n) as usize);
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
    use super::*;

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
            let c = grid_corners(n);
            assert_eq!(c, [0, n as usize, grid_len(n) - 1]);
            for (k, &g) in c.iter().enumerate() {
                assert_eq!(b[g][k], 1.0);
            }
        }
    }
}
