//! Lagrange triangles of order P in Gmsh's node order, and the Bernstein bound of their
//! Jacobian: what `export-msh` writes and measures (`io::msh`), and what the fold
//! repair checks a G1 patch's cubic element with (`patch::repair`).

use glam::DVec3;

/// Nodes of the triangle of order `p`: (p + 1)(p + 2)/2, in `usize` and saturating (as
/// `eval::grid_len`, which this layer does not reach).
pub fn triangle_node_count(p: u32) -> usize {
    let p = p as usize;
    p.saturating_add(1).saturating_mul(p.saturating_add(2)) / 2
}

/// The nodes of Gmsh's triangle of order `p` (0 gives the single node (0, 0)) as lattice
/// points (a, b), the node sitting at (u, v) = (a/p, b/p): vertices, edge nodes in edge
/// order from each edge's first vertex, then the interior as the triangle of order p − 3
/// shifted by (1, 1) (Gmsh's `gmshGenerateMonomialsTriangle`).
pub fn triangle_nodes(p: u32) -> Vec<[u32; 2]> {
    if p == 0 {
        return vec![[0, 0]];
    }
    let corners = [[0, 0], [p, 0], [0, p]];
    let mut out = corners.to_vec();
    for e in 0..3 {
        let (a, b) = (corners[e], corners[(e + 1) % 3]);
        for i in 1..p {
            // The lattice point i/p of the way from a to b (coordinates stay in 0..=p).
            let at = |s: u32, t: u32| (s * (p - i) + t * i) / p;
            out.push([at(a[0], b[0]), at(a[1], b[1])]);
        }
    }
    if p >= 3 {
        out.extend(
            triangle_nodes(p - 3)
                .into_iter()
                .map(|[a, b]| [a + 1, b + 1]),
        );
    }
    out
}

/// Value and derivative at `x` of the 1-D Lagrange factor l_i(x) = Π_{m<i} (p x − m)/(m + 1)
/// (1 at x = i/p, 0 at x = 0, 1/p, …, (i − 1)/p).
fn lagrange_factor(i: u32, p: u32, x: f64) -> (f64, f64) {
    let pf = p as f64;
    let mut v = 1.0;
    let mut d = 0.0;
    for m in 0..i {
        let f = (pf * x - m as f64) / (m as f64 + 1.0);
        let df = pf / (m as f64 + 1.0);
        d = d * f + v * df;
        v *= f;
    }
    (v, d)
}

/// Lagrange shape functions at one point: values, and derivatives by u and v.
#[derive(Clone, Debug, PartialEq)]
pub struct Shapes {
    /// Values, one per node.
    pub w: Vec<f64>,
    /// Derivatives by u = b1, one per node.
    pub ws: Vec<f64>,
    /// Derivatives by v = b2, one per node.
    pub wt: Vec<f64>,
}

/// The Lagrange shape functions of the triangle of order `p` at barycentric `b` (Gmsh's node
/// order, [`triangle_nodes`]): values and derivatives by u = b1 and v = b2.
pub fn lagrange_triangle(p: u32, b: [f64; 3]) -> Shapes {
    let nodes = triangle_nodes(p);
    let zero = vec![0.0; nodes.len()];
    let mut w = Shapes {
        w: zero.clone(),
        ws: zero.clone(),
        wt: zero,
    };
    for (n, &[a, bb]) in nodes.iter().enumerate() {
        let c = p - a - bb;
        let (l0, d0) = lagrange_factor(c, p, b[0]);
        let (l1, d1) = lagrange_factor(a, p, b[1]);
        let (l2, d2) = lagrange_factor(bb, p, b[2]);
        w.w[n] = l0 * l1 * l2;
        // b0 = 1 − u − v: ∂/∂u = ∂/∂b1 − ∂/∂b0, ∂/∂v = ∂/∂b2 − ∂/∂b0.
        w.ws[n] = l0 * d1 * l2 - d0 * l1 * l2;
        w.wt[n] = l0 * l1 * d2 - d0 * l1 * l2;
    }
    w
}

/// Barycentric points of the grid of level `n` (i along u, j along v), row by row.
pub fn grid(n: u32) -> Vec<[f64; 3]> {
    let nf = n.max(1) as f64;
    let mut out = Vec::new();
    for j in 0..=n {
        for i in 0..=n - j {
            let (u, v) = (i as f64 / nf, j as f64 / nf);
            out.push([1.0 - u - v, u, v]);
        }
    }
    out
}

/// The inverse of the collocation matrix of the Bernstein basis of degree `q` at the
/// lattice points of [`grid`]`(q)`: Bernstein coefficients = inverse × samples.
pub fn bernstein_inverse(q: u32) -> Vec<Vec<f64>> {
    let pts = grid(q);
    let powers: Vec<[u32; 3]> = (0..=q)
        .flat_map(|j| (0..=q - j).map(move |i| [q - i - j, i, j]))
        .collect();
    let fact = |n: u32| (1..=n).map(f64::from).product::<f64>();
    let m = pts.len();
    let mut a: Vec<Vec<f64>> = pts
        .iter()
        .map(|b| {
            powers
                .iter()
                .map(|p| {
                    fact(q) / (fact(p[0]) * fact(p[1]) * fact(p[2]))
                        * b[0].powi(p[0] as i32)
                        * b[1].powi(p[1] as i32)
                        * b[2].powi(p[2] as i32)
                })
                .collect()
        })
        .collect();
    let mut inv: Vec<Vec<f64>> = (0..m)
        .map(|i| (0..m).map(|j| f64::from(u8::from(i == j))).collect())
        .collect();
    // Gauss–Jordan with partial pivoting; the matrix is regular (unisolvent lattice).
    for col in 0..m {
        let piv = (col..m)
            .max_by(|&x, &y| a[x][col].abs().total_cmp(&a[y][col].abs()))
            .unwrap_or(col);
        a.swap(col, piv);
        inv.swap(col, piv);
        let d = a[col][col];
        for j in 0..m {
            a[col][j] /= d;
            inv[col][j] /= d;
        }
        for r in 0..m {
            if r != col && a[r][col] != 0.0 {
                let f = a[r][col];
                for j in 0..m {
                    a[r][j] -= f * a[col][j];
                    inv[r][j] -= f * inv[col][j];
                }
            }
        }
    }
    inv
}

/// The Bernstein bound of J = (x_u × x_v) · n̂ of Lagrange triangles of one order P: J is
/// a polynomial of degree 2P − 2, sampled at the lattice of that degree and turned into
/// Bernstein coefficients, which bound it (every value lies between the smallest and the
/// largest).
#[derive(Clone, Debug)]
pub struct JacobianBound {
    /// Shape functions at the lattice points of degree 2P − 2.
    shapes: Vec<Shapes>,
    /// Bernstein coefficients = inverse × samples.
    inverse: Vec<Vec<f64>>,
}

impl JacobianBound {
    pub fn new(order: u32) -> JacobianBound {
        let q = 2 * order - 2;
        JacobianBound {
            shapes: grid(q)
                .iter()
                .map(|&b| lagrange_triangle(order, b))
                .collect(),
            inverse: bernstein_inverse(q),
        }
    }

    /// min c / max |c| over the Bernstein coefficients c of J for the element with nodes
    /// `x` (Gmsh's order) and unit normal `n_hat` of its straight triangle: 1 for a
    /// straight element, at most the true min J / max |J|, ≤ 0 where it may fold; 0 where
    /// every coefficient is 0 or one is not finite.
    pub fn min_scaled(&self, x: &[DVec3], n_hat: DVec3) -> f64 {
        let j: Vec<f64> = self
            .shapes
            .iter()
            .map(|w| {
                let (mut xu, mut xv) = (DVec3::ZERO, DVec3::ZERO);
                for (n, xn) in x.iter().enumerate() {
                    xu += w.ws[n] * *xn;
                    xv += w.wt[n] * *xn;
                }
                xu.cross(xv).dot(n_hat)
            })
            .collect();
        let coeffs: Vec<f64> = self
            .inverse
            .iter()
            .map(|row| row.iter().zip(&j).map(|(a, b)| a * b).sum())
            .collect();
        let lo = coeffs.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = coeffs.iter().fold(0.0f64, |m, c| m.max(c.abs()));
        if hi > 0.0 && lo.is_finite() {
            lo / hi
        } else {
            0.0
        }
    }
}
