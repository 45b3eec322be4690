//! A patch basis with its derivatives up to the second order at one point ([`jet`]), for
//! the fairness measures ([`super::fairness`]): the Bernstein monomials of the Bézier kinds
//! and the G1 patch's Gregory weights, analytic (see the module comment there).

#[cfg(test)]
use glam::DVec3;

use crate::patch::basis::{bezier_powers, factorial, g1_boundary_powers, Powers, MAX_POINTS};
use crate::patch::PatchKind;

/// Basis values of one patch kind at one point with their derivatives in the patch
/// parameters (s, t) up to the second: `d[j]` = (w, w_s, w_t, w_ss, w_st, w_tt) of control
/// point j (geometry points only).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Jet {
    pub d: [[f64; 6]; MAX_POINTS],
}

impl Jet {
    /// Adds one basis function from its value, gradient and Hessian in the homogeneous
    /// coordinates (b0, b1, b2), with b = (1 − s − t, s, t): ∂_s = ∂₁ − ∂₀, ∂_t = ∂₂ − ∂₀.
    fn set(&mut self, j: usize, v: f64, g: [f64; 3], h: [[f64; 3]; 3]) {
        self.d[j] = [
            v,
            g[1] - g[0],
            g[2] - g[0],
            h[1][1] - 2.0 * h[0][1] + h[0][0],
            h[1][2] - h[0][1] - h[0][2] + h[0][0],
            h[2][2] - 2.0 * h[0][2] + h[0][0],
        ];
    }

    /// S, S_s, S_t, S_ss, S_st, S_tt of control points `c` (geometry points only).
    #[cfg(test)]
    pub fn apply(&self, c: &[DVec3]) -> [DVec3; 6] {
        let mut out = [DVec3::ZERO; 6];
        for (cj, d) in c.iter().zip(&self.d) {
            for (o, w) in out.iter_mut().zip(d) {
                *o += *w * *cj;
            }
        }
        out
    }
}

/// Value, gradient and Hessian of c · b0^p0 b1^p1 b2^p2, from the powers of b.
fn monomial2(c: f64, p: [u32; 3], b: &Powers) -> (f64, [f64; 3], [[f64; 3]; 3]) {
    let v = [b.get(0, p[0]), b.get(1, p[1]), b.get(2, p[2])];
    let d1 = |m: usize| {
        if p[m] == 0 {
            0.0
        } else {
            p[m] as f64 * b.get(m, p[m] - 1)
        }
    };
    let d2 = |m: usize| {
        if p[m] < 2 {
            0.0
        } else {
            (p[m] * (p[m] - 1)) as f64 * b.get(m, p[m] - 2)
        }
    };
    // The product of the v[q], q ∉ {m, n}, in increasing q.
    let others = |m: usize, n: usize| {
        if m == n {
            let (a, b) = ((m + 1) % 3, (m + 2) % 3);
            v[a.min(b)] * v[a.max(b)]
        } else {
            v[3 - m - n]
        }
    };
    let g = std::array::from_fn(|m| c * d1(m) * others(m, m));
    let h = std::array::from_fn(|m| {
        std::array::from_fn(|n| {
            if n == m {
                c * d2(m) * others(m, m)
            } else {
                c * d1(m) * d1(n) * others(m, n)
            }
        })
    });
    (c * v[0] * v[1] * v[2], g, h)
}

/// The Gregory weight 12 x² g(y, z), g = y² z / (y + z): value, gradient and Hessian in
/// (x, y, z). `dir` = (u, v) is used where y + z = 0 (the corner x = 1): the direction of
/// approach, which the second derivatives depend on there.
fn gregory_term(x: f64, y: f64, z: f64, dir: (f64, f64)) -> (f64, [f64; 3], [[f64; 3]; 3]) {
    let sigma = y + z;
    let (u, v) = if sigma > 0.0 {
        (y / sigma, z / sigma)
    } else {
        dir
    };
    let g = sigma * sigma * u * u * v;
    let gy = sigma * u * v * (u + 2.0 * v);
    let gz = sigma * u * u * u;
    let gyy = 2.0 * v * v * v;
    let gyz = u * u * u + 3.0 * u * u * v;
    let gzz = -2.0 * u * u * u;
    let x2 = 12.0 * x * x;
    (
        x2 * g,
        [24.0 * x * g, x2 * gy, x2 * gz],
        [
            [24.0 * g, 24.0 * x * gy, 24.0 * x * gz],
            [24.0 * x * gy, x2 * gyy, x2 * gyz],
            [24.0 * x * gz, x2 * gyz, x2 * gzz],
        ],
    )
}

/// The basis of `kind` at barycentric `b` with its derivatives up to the second order
/// ([`Jet`]). `toward`: at a patch corner (b_k = 1), the corner the point is approached
/// from along an edge (the Gregory weights' second derivatives are direction-dependent
/// there); elsewhere ignored.
pub(crate) fn jet(kind: PatchKind, b: [f64; 3], toward: Option<usize>) -> Jet {
    let mut out = Jet {
        d: [[0.0; 6]; MAX_POINTS],
    };
    let degree = match kind {
        PatchKind::Bezier(n) => Some(n),
        // The cubic geometry; the quadratic normal field is no part of the surface.
        PatchKind::PnNormals => Some(3),
        PatchKind::Gregory => None,
    };
    match degree {
        Some(n) => {
            let nf = factorial(n);
            let pw = Powers::new(b);
            for (j, p) in bezier_powers(n).iter().enumerate() {
                let c = nf / (factorial(p[0]) * factorial(p[1]) * factorial(p[2]));
                let (v, g, h) = monomial2(c, *p, &pw);
                out.set(j, v, g, h);
            }
        }
        None => {
            let pw = Powers::new(b);
            for (j, p) in g1_boundary_powers().iter().enumerate() {
                let c = 24.0 / (factorial(p[0]) * factorial(p[1]) * factorial(p[2]));
                let (v, g, h) = monomial2(c, *p, &pw);
                out.set(j, v, g, h);
            }
            for m in 0..3 {
                let idx = [m, (m + 1) % 3, (m + 2) % 3];
                let (x, y, z) = (b[idx[0]], b[idx[1]], b[idx[2]]);
                // Approached from corner m + 1: (u, v) = (1, 0); from m + 2: (0, 1).
                let dir = match toward {
                    Some(k) if k == idx[1] => (1.0, 0.0),
                    Some(k) if k == idx[2] => (0.0, 1.0),
                    _ => (0.5, 0.5),
                };
                let (va, ga, ha) = gregory_term(x, y, z, dir);
                // β_m(x, y, z) = 12 x² g(z, y): the same function with y and z swapped.
                let (vb, gb, hb) = gregory_term(x, z, y, (dir.1, dir.0));
                let unswap = [0, 2, 1];
                let (mut gab, mut hab) = ([[0.0; 3]; 2], [[[0.0; 3]; 3]; 2]);
                for (q, &bq) in idx.iter().enumerate() {
                    gab[0][bq] = ga[q];
                    gab[1][bq] = gb[unswap[q]];
                    for (r, &br) in idx.iter().enumerate() {
                        hab[0][bq][br] = ha[q][r];
                        hab[1][bq][br] = hb[unswap[q]][unswap[r]];
                    }
                }
                // α_m weighs G_{m,1} (slot 12 + 2m); β_m weighs G_{m−1,2} (13 + 2(m − 1)).
                out.set(12 + 2 * m, va, gab[0], hab[0]);
                out.set(13 + 2 * ((m + 2) % 3), vb, gab[1], hab[1]);
            }
        }
    }
    out
}
