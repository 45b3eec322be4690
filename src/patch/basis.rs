//! Basis functions of every patch kind at a barycentric point, with their homogeneous
//! derivatives. A patch is `S(b) = Σ w_j(b) c_j` over its control points `c_j`; its tangents
//! are `S_s = Σ ws_j c_j` and `S_t = Σ wt_j c_j` with `ws = ∂w/∂b1 − ∂w/∂b0` and
//! `wt = ∂w/∂b2 − ∂w/∂b0` (the surface parametrised by b = (1 − s − t, s, t)).
//!
//! `shaders/common.wgsl` and the per-scheme shaders compute the same functions.

use super::PatchKind;

/// Most control points of any patch kind (G1: 12 boundary + 6 Gregory points).
pub const MAX_POINTS: usize = 18;

/// Basis values and tangent-direction derivatives at one point.
#[derive(Clone, Copy, Debug)]
pub struct Weights {
    pub n: usize,
    pub w: [f64; MAX_POINTS],
    pub ws: [f64; MAX_POINTS],
    pub wt: [f64; MAX_POINTS],
}

impl Weights {
    pub fn zero(n: usize) -> Self {
        Weights {
            n,
            w: [0.0; MAX_POINTS],
            ws: [0.0; MAX_POINTS],
            wt: [0.0; MAX_POINTS],
        }
    }
}

/// Control-point powers (on b0, b1, b2) of a Bézier triangle of degree `n`, in the order
/// used by every table: i (power on b0) from n down to 0, then j from n − i down to 0.
pub fn bezier_powers(n: u32) -> Vec<[u32; 3]> {
    let mut out = Vec::new();
    for i in (0..=n).rev() {
        for j in (0..=n - i).rev() {
            out.push([i, j, n - i - j]);
        }
    }
    out
}

/// Index of the control point with powers (i, j, k) in [`bezier_powers`] order.
pub fn bezier_index(n: u32, p: [u32; 3]) -> usize {
    let i = p[0];
    // Rows with power i' > i come first: row i' holds n − i' + 1 points.
    let before: u32 = (i + 1..=n).map(|ii| n - ii + 1).sum();
    (before + (n - i - p[1])) as usize
}

pub(crate) fn factorial(n: u32) -> f64 {
    (1..=n).map(|x| x as f64).product()
}

/// Powers x⁰ … x⁴ of one coordinate, or more for higher degrees ([`Powers::get`]).
const POWERS: usize = 5;

/// The powers of a point's three barycentric coordinates, each computed once per point
/// (the basis functions share them), bitwise those of `f64::powi`.
pub(crate) struct Powers([[f64; POWERS]; 3]);

impl Powers {
    pub(crate) fn new(b: [f64; 3]) -> Powers {
        Powers(b.map(|x| std::array::from_fn(|e| powi(x, e as u32))))
    }

    /// b_m^e.
    #[inline]
    pub(crate) fn get(&self, m: usize, e: u32) -> f64 {
        match self.0[m].get(e as usize) {
            Some(&v) => v,
            None => powi(self.0[m][1], e),
        }
    }
}

/// x^e by repeated squaring, the algorithm of `f64::powi` (compiler-rt's `__powidf2`, and
/// LLVM's expansion for a constant exponent), so bitwise its value: 1, x, x·x, x·(x·x),
/// (x·x)·(x·x), …
#[inline]
fn powi(x: f64, e: u32) -> f64 {
    let (mut r, mut a, mut e) = (1.0, x, e);
    loop {
        if e & 1 == 1 {
            r *= a;
        }
        e >>= 1;
        if e == 0 {
            return r;
        }
        a *= a;
    }
}

/// Value and homogeneous gradient (∂/∂b0, ∂/∂b1, ∂/∂b2) of the monomial
/// `c · b0^i b1^j b2^k`, from the powers `b` of the point.
#[inline]
fn monomial(c: f64, p: [u32; 3], b: &Powers) -> (f64, [f64; 3]) {
    let v = [b.get(0, p[0]), b.get(1, p[1]), b.get(2, p[2])];
    let d = |m: usize| {
        if p[m] == 0 {
            0.0
        } else {
            p[m] as f64 * b.get(m, p[m] - 1)
        }
    };
    (
        c * v[0] * v[1] * v[2],
        [
            c * d(0) * v[1] * v[2],
            c * v[0] * d(1) * v[2],
            c * v[0] * v[1] * d(2),
        ],
    )
}

/// Bernstein basis of degree `n` at `b` with tangent derivatives.
pub fn bezier(n: u32, b: [f64; 3]) -> Weights {
    let powers = bezier_powers(n);
    let mut out = Weights::zero(powers.len());
    let nf = factorial(n);
    let pw = Powers::new(b);
    for (idx, p) in powers.iter().enumerate() {
        let c = nf / (factorial(p[0]) * factorial(p[1]) * factorial(p[2]));
        let (v, g) = monomial(c, *p, &pw);
        out.w[idx] = v;
        out.ws[idx] = g[1] - g[0];
        out.wt[idx] = g[2] - g[0];
    }
    out
}

/// Powers (on b0, b1, b2) of the G1 patch's 12 boundary points: edge k's points L_{k,0..3}
/// (power 4 − j on vertex k, j on vertex k + 1).
pub fn g1_boundary_powers() -> [[u32; 3]; 12] {
    let mut out = [[0; 3]; 12];
    for k in 0..3 {
        for j in 0..4u32 {
            let mut p = [0u32; 3];
            p[k] = 4 - j;
            p[(k + 1) % 3] = j;
            out[4 * k + j as usize] = p;
        }
    }
    out
}

/// Basis of the G1 patch (`spec/G1-CONSTRUCTION.md`): 12 quartic Bernstein
/// functions on the boundary points, then for m = 0, 1, 2 the Gregory weights
/// α_m on G_{m,1} (slot 12 + 2m) and β_{m+1} on G_{m,2} (slot 13 + 2m).
pub fn g1(b: [f64; 3]) -> Weights {
    let mut out = Weights::zero(18);
    let pw = Powers::new(b);
    for (idx, p) in g1_boundary_powers().iter().enumerate() {
        let c = 24.0 / (factorial(p[0]) * factorial(p[1]) * factorial(p[2]));
        let (v, g) = monomial(c, *p, &pw);
        out.w[idx] = v;
        out.ws[idx] = g[1] - g[0];
        out.wt[idx] = g[2] - g[0];
    }
    for m in 0..3 {
        let (im, iy, iz) = (m, (m + 1) % 3, (m + 2) % 3);
        let (x, y, z) = (b[im], b[iy], b[iz]);
        let s = y + z;
        // Homogeneous gradient by (x, y, z) of alpha_m and beta_m; all tend to 0 at s = 0.
        let (a, da, be, dbe) = if s > 0.0 {
            let s2 = s * s;
            (
                12.0 * x * x * y * y * z / s,
                [
                    24.0 * x * y * y * z / s,
                    12.0 * x * x * y * z * (y + 2.0 * z) / s2,
                    12.0 * x * x * y * y * y / s2,
                ],
                12.0 * x * x * y * z * z / s,
                [
                    24.0 * x * y * z * z / s,
                    12.0 * x * x * z * z * z / s2,
                    12.0 * x * x * y * z * (z + 2.0 * y) / s2,
                ],
            )
        } else {
            (0.0, [0.0; 3], 0.0, [0.0; 3])
        };
        // Map (x, y, z) derivatives back onto (b0, b1, b2).
        let mut ga = [0.0; 3];
        let mut gb = [0.0; 3];
        for (slot, &bi) in [im, iy, iz].iter().enumerate() {
            ga[bi] = da[slot];
            gb[bi] = dbe[slot];
        }
        // alpha_m weighs G_{m,1}; beta_m weighs G_{m-1,2}, stored at slot 13 + 2(m − 1).
        let sa = 12 + 2 * m;
        let sb = 13 + 2 * ((m + 2) % 3);
        out.w[sa] = a;
        out.ws[sa] = ga[1] - ga[0];
        out.wt[sa] = ga[2] - ga[0];
        out.w[sb] = be;
        out.ws[sb] = gb[1] - gb[0];
        out.wt[sb] = gb[2] - gb[0];
    }
    out
}

/// Basis of [`crate::patch::PatchKind::PnNormals`]: the cubic Bernstein basis with its
/// derivatives in slots 0..10, the quadratic basis values (for the normal field, no
/// derivatives) in slots 10..16.
pub fn pn_normals(b: [f64; 3]) -> Weights {
    let cubic = bezier(3, b);
    let quad = bezier(2, b);
    let mut out = cubic;
    out.n = 16;
    out.w[10..16].copy_from_slice(&quad.w[..6]);
    out
}

/// [`Weights`] with the geometry control points whose three weights (w, ∂w/∂s, ∂w/∂t) are
/// not all zero, and those weights packed per point. Skipping a point whose weights are all
/// zero changes nothing (its terms are ±0 on a finite point, and a running sum started at
/// +0 is never −0), so an evaluation through the list is bitwise the full one; on an edge
/// (one b_k = 0) about half the points drop out.
#[derive(Clone, Copy, Debug)]
pub struct SparseWeights {
    pub full: Weights,
    idx: [u8; MAX_POINTS],
    /// (w, ∂w/∂s, ∂w/∂t, 0) of point `idx[k]`.
    terms: [[f64; 4]; MAX_POINTS],
    len: u8,
}

impl SparseWeights {
    /// The list of `full` over the first `geometry` control points.
    pub fn new(full: Weights, geometry: usize) -> SparseWeights {
        let mut idx = [0u8; MAX_POINTS];
        let mut terms = [[0.0; 4]; MAX_POINTS];
        let mut len = 0;
        for j in 0..geometry.min(MAX_POINTS) {
            let t = [full.w[j], full.ws[j], full.wt[j], 0.0];
            if t != [0.0; 4] {
                idx[len] = j as u8;
                terms[len] = t;
                len += 1;
            }
        }
        SparseWeights {
            full,
            idx,
            terms,
            len: len as u8,
        }
    }

    /// The control points with a nonzero weight (increasing) and their weights.
    #[inline]
    pub fn terms(&self) -> (&[u8], &[[f64; 4]]) {
        let n = self.len as usize;
        (&self.idx[..n], &self.terms[..n])
    }
}

/// Basis weights of one patch kind per distinct barycentric point (keyed by its bits), for
/// up to [`WeightMemo::CAPACITY`] / 2 points; beyond that, weights are computed per point.
pub struct WeightMemo {
    kind: PatchKind,
    /// Open addressing: the key and index into `weights` + 1 (0: an empty slot).
    slots: Box<[([u64; 3], u16); WeightMemo::CAPACITY]>,
    weights: Vec<SparseWeights>,
    scratch: Option<Box<SparseWeights>>,
}

impl WeightMemo {
    const CAPACITY: usize = 256;

    pub fn new(kind: PatchKind) -> WeightMemo {
        WeightMemo {
            kind,
            slots: Box::new([([0; 3], 0); WeightMemo::CAPACITY]),
            weights: Vec::new(),
            scratch: None,
        }
    }

    /// The weights at `b`.
    #[inline]
    pub fn get(&mut self, b: [f64; 3]) -> &SparseWeights {
        let key = b.map(f64::to_bits);
        let h = (key[0] ^ key[1].rotate_left(21) ^ key[2].rotate_left(42))
            .wrapping_mul(0x9E37_79B9_7F4A_7C15);
        let mut i = (h >> 56) as usize;
        loop {
            let (k, s) = self.slots[i];
            if s == 0 {
                break;
            }
            if k == key {
                return &self.weights[s as usize - 1];
            }
            i = (i + 1) % WeightMemo::CAPACITY;
        }
        let w = SparseWeights::new(self.kind.weights(b), self.kind.geometry());
        if self.weights.len() < WeightMemo::CAPACITY / 2 {
            self.weights.push(w);
            self.slots[i] = (key, self.weights.len() as u16);
            return &self.weights[self.weights.len() - 1];
        }
        self.scratch.insert(Box::new(w))
    }
}

#[cfg(test)]
mod tests {
    use crate::patch::basis::{bezier, bezier_index, bezier_powers, g1};

    #[test]
    fn bezier_index_matches_order() {
        for n in 1..=4 {
            for (i, p) in bezier_powers(n).iter().enumerate() {
                assert_eq!(bezier_index(n, *p), i);
            }
        }
    }

    #[test]
    fn partitions_of_unity() {
        for b in [[0.2, 0.3, 0.5], [1.0, 0.0, 0.0], [0.0, 0.25, 0.75]] {
            for n in 1..=3 {
                let w = bezier(n, b);
                assert!((w.w[..w.n].iter().sum::<f64>() - 1.0).abs() < 1e-15);
                assert!(w.ws[..w.n].iter().sum::<f64>().abs() < 1e-14);
            }
            let w = g1(b);
            assert!((w.w.iter().sum::<f64>() - 1.0).abs() < 1e-15, "{b:?}");
            assert!(w.ws.iter().sum::<f64>().abs() < 1e-14);
            assert!(w.wt.iter().sum::<f64>().abs() < 1e-14);
        }
    }

    /// The powers are bitwise `f64::powi`'s (the bases computed from them are then the
    /// ones `powi` gave), on coordinates of every magnitude, signed zeros and non-finite
    /// values included.
    #[test]
    fn powers_are_powi_bit_for_bit() {
        let mut xs = vec![0.0, -0.0, 1.0, -1.0, f64::INFINITY, f64::NAN, 1e-300, 1e300];
        let mut x = 0.123_456_789_f64;
        for _ in 0..10_000 {
            // A deterministic spread over [0, 1] and beyond.
            x = (x * 3.987_654_321 + 0.011).fract();
            xs.extend([x, 1.0 - x, x * 7.0 - 3.0]);
        }
        for &x in &xs {
            let p = super::Powers::new([x, 0.5, 0.25]);
            for e in 0..12u32 {
                let want = x.powi(e as i32);
                assert_eq!(p.get(0, e).to_bits(), want.to_bits(), "{x:e}^{e}");
                assert_eq!(super::powi(x, e).to_bits(), want.to_bits(), "{x:e}^{e}");
            }
        }
    }
}
