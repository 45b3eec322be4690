//! The Bézier G1 patch of Walton & Meek (1996) as corrected in
//! `spec/G1-CONSTRUCTION.md`. Mirrored on the GPU by `shaders/gregory.wgsl`, which
//! evaluates the table built here.
//!
//! Documented fallbacks (counted in [`crate::patch::PatchTable::fallbacks`]): where a
//! boundary tangent W_i vanishes, its ribbon vector A_i is 0 and λ is 0; where
//! A0 + A2 = 0 (opposite normals with the edge in their plane), A1 = N_a × Ŵ1.
//!
//! **Creases.** Where the two triangles of an edge give one of its end vertices different
//! normals (see [`crate::mesh::creases`]), the edge gets one boundary curve built once and
//! shared bitwise by both triangles ([`crease_curve`]): at an end where the normals differ
//! the end tangent is the crease direction N_left × N_right (it lies in both sides' tangent
//! planes), at an end where they agree it is the ordinary Walton–Meek end tangent. Each
//! triangle then builds its ribbon and Gregory points from its own corner normals, so the
//! patch is G1 with its neighbours across every other edge and meets its neighbour across
//! the crease without a crack.
//!
//! **Scaled arms.** A mesh may scale the tangent lengths of an edge's curve
//! ([`crate::mesh::CornerAttributes::arm_scales`], set by the fold repair): the edge then
//! gets one shared curve too ([`shared_curve`]), its arms V1 − V0 and V2 − V3 multiplied
//! by the factors ([`scale_arms`]). Their directions stay in the tangent planes of the
//! ends, and the ribbon vectors A_i depend on the tangents' directions only, so the two
//! patches of the edge stay G1 across it and watertight.

use std::collections::HashMap;

use glam::DVec3;

use super::{SchemeOptions, TriangleBuilder};
use crate::mesh::adjacency::{EdgeIndex, EdgeUse};
use crate::mesh::creases::{normal_key, use_normal};
use crate::mesh::Mesh;
use crate::Result;

/// The Walton–Meek cubic between (qa, na) and (qb, nb) (Theorem 2.1, Γ the unit edge
/// vector). Normals must be unit vectors.
#[inline]
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

#[inline(always)]
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

#[cfg(test)]
/// The 18 control points of one triangle (layout of [`crate::patch::PatchKind::Gregory`]).
/// `ids` are the global vertex ids: each boundary cubic is built in the direction of
/// increasing id, so both neighbours of an edge compute bitwise the same curve.
pub fn patch_points(
    q: [DVec3; 3],
    n: [DVec3; 3],
    ids: [u32; 3],
    fallbacks: &mut usize,
) -> [DVec3; 18] {
    patch_points_with_curves(q, n, ids, [None; 3], fallbacks)
}

/// [`patch_points`] where edge k's boundary cubic may be given (`curves[k]`, running from
/// corner k to corner k + 1), as for crease edges; the other edges get the Walton–Meek
/// cubic of their end points and this triangle's normals.
#[inline]
pub fn patch_points_with_curves(
    q: [DVec3; 3],
    n: [DVec3; 3],
    ids: [u32; 3],
    curves: [Option<[DVec3; 4]>; 3],
    fallbacks: &mut usize,
) -> [DVec3; 18] {
    let mut out = [DVec3::ZERO; 18];
    patch_points_into(q, n, ids, curves, fallbacks, &mut out);
    out
}

/// [`patch_points_with_curves`] written into `out` (a table's slot), not returned.
fn patch_points_into(
    q: [DVec3; 3],
    n: [DVec3; 3],
    ids: [u32; 3],
    curves: [Option<[DVec3; 4]>; 3],
    fallbacks: &mut usize,
    out: &mut [DVec3; 18],
) {
    // Edge k's data, built in place: three named values, not an array built by a closure
    // (which was called out of line and its 264-byte results copied).
    #[inline(always)]
    fn edge(
        k: usize,
        q: &[DVec3; 3],
        n: &[DVec3; 3],
        ids: &[u32; 3],
        curves: &[Option<[DVec3; 4]>; 3],
        fallbacks: &mut usize,
    ) -> EdgeData {
        let (a, b) = (k, (k + 1) % 3);
        let v = if let Some(c) = curves[k] {
            c
        } else if ids[a] <= ids[b] {
            walton_meek(q[a], n[a], q[b], n[b])
        } else {
            let r = walton_meek(q[b], n[b], q[a], n[a]);
            [r[3], r[2], r[1], r[0]]
        };
        edge_data(v, n[a], n[b], fallbacks)
    }
    let e0 = edge(0, &q, &n, &ids, &curves, fallbacks);
    let e1 = edge(1, &q, &n, &ids, &curves, fallbacks);
    let e2 = edge(2, &q, &n, &ids, &curves, fallbacks);
    let edges: [&EdgeData; 3] = [&e0, &e1, &e2];
    for k in 0..3 {
        out[4 * k..4 * k + 4].copy_from_slice(&edges[k].l[..4]);
    }
    for k in 0..3 {
        let e = edges[k];
        let prev = edges[(k + 2) % 3];
        let next = edges[(k + 1) % 3];
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
}

/// [`patch_points_into`] with the three edges in the lanes of AVX2 registers (one edge a
/// lane), for a triangle without given curves: every lane runs the scalar construction's
/// operations in its order (no fused operations), so the points are bitwise those of
/// [`patch_points`]. Where some edge would take a fallback it writes nothing and says
/// `false` (the scalar construction then builds the patch and counts the fallbacks).
#[cfg(target_arch = "x86_64")]
mod lanes {
    use glam::DVec3;
    use std::arch::x86_64::*;

    /// Four f64 lanes (lane k: edge k from corner k to k + 1; lane 3 repeats edge 0).
    #[derive(Clone, Copy)]
    struct L(__m256d);

    // SAFETY (every method of L and V): only reached from `build_avx2`, compiled with AVX2
    // enabled and called only where the CPU has it (`G1Builder::build`).
    impl L {
        #[inline(always)]
        fn new(a: [f64; 4]) -> L {
            unsafe { L(_mm256_loadu_pd(a.as_ptr())) }
        }
        #[inline(always)]
        fn splat(x: f64) -> L {
            unsafe { L(_mm256_set1_pd(x)) }
        }
        #[inline(always)]
        fn add(self, o: L) -> L {
            unsafe { L(_mm256_add_pd(self.0, o.0)) }
        }
        #[inline(always)]
        fn sub(self, o: L) -> L {
            unsafe { L(_mm256_sub_pd(self.0, o.0)) }
        }
        #[inline(always)]
        fn mul(self, o: L) -> L {
            unsafe { L(_mm256_mul_pd(self.0, o.0)) }
        }
        #[inline(always)]
        fn div(self, o: L) -> L {
            unsafe { L(_mm256_div_pd(self.0, o.0)) }
        }
        #[inline(always)]
        fn sqrt(self) -> L {
            unsafe { L(_mm256_sqrt_pd(self.0)) }
        }
        /// Lanes where `self > o` (false on NaN), as a mask.
        #[inline(always)]
        fn gt(self, o: L) -> __m256d {
            unsafe { _mm256_cmp_pd::<_CMP_GT_OQ>(self.0, o.0) }
        }
        /// Lanes where `self` is neither infinite nor NaN, as a mask.
        #[inline(always)]
        fn finite(self) -> __m256d {
            unsafe {
                let abs = _mm256_andnot_pd(_mm256_set1_pd(-0.0), self.0);
                _mm256_cmp_pd::<_CMP_LT_OQ>(abs, _mm256_set1_pd(f64::INFINITY))
            }
        }
        /// Lanes set in both masks.
        #[inline(always)]
        fn and(a: __m256d, b: __m256d) -> __m256d {
            unsafe { _mm256_and_pd(a, b) }
        }
        /// Lanes 0, 1 and 2 (the three edges) of `m` are set.
        #[inline(always)]
        fn edges_set(m: __m256d) -> bool {
            unsafe { _mm256_movemask_pd(m) & 0b111 == 0b111 }
        }
        /// `a` where `m` is set, else `b`.
        #[inline(always)]
        fn select(m: __m256d, a: L, b: L) -> L {
            unsafe { L(_mm256_blendv_pd(b.0, a.0, m)) }
        }
        #[inline(always)]
        fn lanes(self) -> [f64; 4] {
            let mut a = [0.0; 4];
            unsafe { _mm256_storeu_pd(a.as_mut_ptr(), self.0) };
            a
        }
        /// Lane k takes lane (k + 2) mod 3: the previous edge's values.
        #[inline(always)]
        fn prev(self) -> L {
            unsafe { L(_mm256_permute4x64_pd::<0b10_01_00_10>(self.0)) }
        }
        /// Lane k takes lane (k + 1) mod 3: the next edge's values.
        #[inline(always)]
        fn next(self) -> L {
            unsafe { L(_mm256_permute4x64_pd::<0b01_00_10_01>(self.0)) }
        }
    }

    /// A DVec3 per lane, each operation as glam's (component by component, same order).
    #[derive(Clone, Copy)]
    struct V {
        x: L,
        y: L,
        z: L,
    }

    impl V {
        #[inline(always)]
        fn of(p: [DVec3; 4]) -> V {
            V {
                x: L::new(p.map(|v| v.x)),
                y: L::new(p.map(|v| v.y)),
                z: L::new(p.map(|v| v.z)),
            }
        }
        #[inline(always)]
        fn add(self, o: V) -> V {
            V {
                x: self.x.add(o.x),
                y: self.y.add(o.y),
                z: self.z.add(o.z),
            }
        }
        #[inline(always)]
        fn sub(self, o: V) -> V {
            V {
                x: self.x.sub(o.x),
                y: self.y.sub(o.y),
                z: self.z.sub(o.z),
            }
        }
        /// `s * self` (f64 × DVec3).
        #[inline(always)]
        fn scale(self, s: L) -> V {
            V {
                x: s.mul(self.x),
                y: s.mul(self.y),
                z: s.mul(self.z),
            }
        }
        /// `self / s` (DVec3 ÷ f64).
        #[inline(always)]
        fn div(self, s: L) -> V {
            V {
                x: self.x.div(s),
                y: self.y.div(s),
                z: self.z.div(s),
            }
        }
        /// DVec3::dot: (x x' + y y') + z z'.
        #[inline(always)]
        fn dot(self, o: V) -> L {
            self.x.mul(o.x).add(self.y.mul(o.y)).add(self.z.mul(o.z))
        }
        /// DVec3::cross.
        #[inline(always)]
        fn cross(self, r: V) -> V {
            V {
                x: self.y.mul(r.z).sub(r.y.mul(self.z)),
                y: self.z.mul(r.x).sub(r.z.mul(self.x)),
                z: self.x.mul(r.y).sub(r.x.mul(self.y)),
            }
        }
        #[inline(always)]
        fn select(m: __m256d, a: V, b: V) -> V {
            V {
                x: L::select(m, a.x, b.x),
                y: L::select(m, a.y, b.y),
                z: L::select(m, a.z, b.z),
            }
        }
        #[inline(always)]
        fn prev(self) -> V {
            V {
                x: self.x.prev(),
                y: self.y.prev(),
                z: self.z.prev(),
            }
        }
        #[inline(always)]
        fn next(self) -> V {
            V {
                x: self.x.next(),
                y: self.y.next(),
                z: self.z.next(),
            }
        }
        #[inline(always)]
        fn lanes(self) -> [DVec3; 4] {
            let (x, y, z) = (self.x.lanes(), self.y.lanes(), self.z.lanes());
            std::array::from_fn(|k| DVec3::new(x[k], y[k], z[k]))
        }
    }

    /// d · w / |w|² where |w|² > 0, else 0 (the construction's λ).
    #[inline(always)]
    fn ratio(d: V, w: V) -> L {
        let w2 = w.dot(w);
        let zero = L::splat(0.0);
        L::select(w2.gt(zero), d.dot(w).div(w2), zero)
    }

    /// See the module.
    ///
    /// # Safety
    /// The CPU has AVX2 (`cpu_has!("avx2")`).
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn build_avx2(
        q: [DVec3; 3],
        n: [DVec3; 3],
        ids: [u32; 3],
        out: &mut [DVec3; 18],
    ) -> bool {
        let (a3, b3) = ([0, 1, 2, 0], [1, 2, 0, 1]);
        // Edge k from corner a = k to b = k + 1: v0 = q[a], v3 = q[b].
        let v0 = V::of(a3.map(|i| q[i]));
        let v3 = V::of(b3.map(|i| q[i]));
        let na = V::of(a3.map(|i| n[i]));
        let nb = V::of(b3.map(|i| n[i]));
        // The cubic runs from the lower id: swapped lanes build it from b to a.
        let swap = L::new(a3.map(|k| if ids[k] <= ids[(k + 1) % 3] { 0.0 } else { 1.0 }))
            .gt(L::splat(0.5));
        let (p, pn) = (V::select(swap, v3, v0), V::select(swap, nb, na));
        let (r, rn) = (V::select(swap, v0, v3), V::select(swap, na, nb));
        // walton_meek_offsets(p, pn, r, rn).
        let e = r.sub(p);
        let d = e.dot(e).sqrt();
        let g = e.div(d);
        let a0 = pn.dot(g);
        let a1 = rn.dot(g);
        let a = pn.dot(rn);
        let den = L::splat(4.0).sub(a.mul(a));
        let (two, six) = (L::splat(2.0), L::splat(6.0));
        let zeta = six.mul(two.mul(a0).add(a.mul(a1))).div(den);
        let theta = six.mul(two.mul(a1).add(a.mul(a0))).div(den);
        let g6 = g.scale(six);
        let t0 = g6
            .sub(pn.scale(two.mul(zeta)))
            .add(rn.scale(theta))
            .scale(d)
            .div(L::splat(18.0));
        let t1 = g6
            .add(pn.scale(zeta))
            .sub(rn.scale(two.mul(theta)))
            .scale(d)
            .div(L::splat(18.0));
        // [p, p + t0, r − t1, r], reversed on swapped lanes.
        let (pt, rt) = (p.add(t0), r.sub(t1));
        let v1 = V::select(swap, rt, pt);
        let v2 = V::select(swap, pt, rt);
        // edge_data(v, na, nb).
        let w0 = v1.sub(v0);
        let w1 = v2.sub(v1);
        let w2 = v3.sub(v2);
        let zero = L::splat(0.0);
        let (l0, l2) = (w0.dot(w0).sqrt(), w2.dot(w2).sqrt());
        let ra0 = na.cross(w0.div(l0));
        let ra2 = nb.cross(w2.div(l2));
        let sum = ra0.add(ra2);
        let len = sum.dot(sum).sqrt();
        let rcp = L::splat(1.0).div(len);
        // The scalar construction's conditions for no fallback: |W0|, |W2| > 0, and
        // A0 + A2 normalisable with a length above 1e-12.
        let ok = L::and(
            L::and(l0.gt(zero), l2.gt(zero)),
            L::and(L::and(rcp.finite(), rcp.gt(zero)), len.gt(L::splat(1e-12))),
        );
        if !L::edges_set(ok) {
            return false;
        }
        let ra1 = sum.scale(rcp);
        let (three, four, half) = (L::splat(3.0), L::splat(4.0), L::splat(0.5));
        let b1 = v0.add(v1.scale(three)).div(four);
        let b2 = v1.add(v2).div(two);
        let b3 = v2.scale(three).add(v3).div(four);
        // The Gregory points of edge k, from its neighbours' boundary points.
        let d0 = b3.prev().sub(v0.add(b1).scale(half));
        let d3 = b1.next().sub(b3.add(v3).scale(half));
        let lambda0 = ratio(d0, w0);
        let mu0 = d0.dot(ra0);
        let lambda1 = ratio(d3, w2);
        let mu1 = d3.dot(ra2);
        let (c1, c2) = (L::splat(1.0 / 3.0), L::splat(2.0 / 3.0));
        let d1 = w1
            .scale(c2.mul(lambda0))
            .add(w0.scale(c1.mul(lambda1)))
            .add(ra1.scale(c2.mul(mu0)))
            .add(ra0.scale(c1.mul(mu1)));
        let d2 = w2
            .scale(c1.mul(lambda0))
            .add(w1.scale(c2.mul(lambda1)))
            .add(ra2.scale(c1.mul(mu0)))
            .add(ra1.scale(c2.mul(mu1)));
        let g1 = b1.add(b2).scale(half).add(d1);
        let g2 = b2.add(b3).scale(half).add(d2);
        let cols = [v0.lanes(), b1.lanes(), b2.lanes(), b3.lanes()];
        let (g1, g2) = (g1.lanes(), g2.lanes());
        for k in 0..3 {
            for (j, c) in cols.iter().enumerate() {
                out[4 * k + j] = c[k];
            }
            out[12 + 2 * k] = g1[k];
            out[13 + 2 * k] = g2[k];
        }
        true
    }
}

/// Unit crease direction at a vertex whose two sides have unit normals `n0` and `n1`:
/// N0 × N1, computed as N0 × (N1 − N0) so that it stays accurate (and perpendicular to
/// both normals to rounding) when the normals are close, oriented along `g`. Where the
/// normals are parallel or opposite it is undefined: the fallback (counted) is `g`
/// projected on the plane of `n0`, or `g` itself.
pub fn crease_direction(n0: DVec3, n1: DVec3, g: DVec3, fallbacks: &mut usize) -> DVec3 {
    let c = n0.cross(n1 - n0);
    let t = match c.try_normalize() {
        Some(t) if c.length() > 1e-150 => t,
        _ => {
            *fallbacks += 1;
            (g - g.dot(n0) * n0).try_normalize().unwrap_or(g)
        }
    };
    if t.dot(g) < 0.0 {
        -t
    } else {
        t
    }
}

/// The boundary cubic shared by the two triangles of a crease edge from `qa` to `qb`.
/// `na[i]`, `nb[i]` are side i's unit normals at the two ends; `split[0]` / `split[1]` say
/// whether the sides differ at `qa` / `qb`.
///
/// The Walton–Meek cubic is built with, at a split end, the surrogate normal
/// (N_left + N_right)/|·| (perpendicular to the crease direction); at a split end its arm
/// keeps the Walton–Meek length but turns onto the crease direction
/// ([`crease_direction`]), which lies in both sides' tangent planes. An end where the sides
/// agree keeps the ordinary Walton–Meek end tangent (perpendicular to the common normal).
pub fn crease_curve(
    qa: DVec3,
    qb: DVec3,
    na: [DVec3; 2],
    nb: [DVec3; 2],
    split: [bool; 2],
    fallbacks: &mut usize,
) -> [DVec3; 4] {
    let surrogate = |n: [DVec3; 2], s: bool, f: &mut usize| {
        if !s {
            return n[0];
        }
        match (n[0] + n[1]).try_normalize() {
            Some(m) => m,
            None => {
                *f += 1;
                n[0]
            }
        }
    };
    let ma = surrogate(na, split[0], fallbacks);
    let mb = surrogate(nb, split[1], fallbacks);
    let mut v = walton_meek(qa, ma, qb, mb);
    let g = (qb - qa).normalize_or_zero();
    if split[0] {
        let arm = (v[1] - v[0]).length();
        v[1] = qa + arm * crease_direction(na[0], na[1], g, fallbacks);
    }
    if split[1] {
        let arm = (v[3] - v[2]).length();
        v[2] = qb - arm * crease_direction(nb[0], nb[1], g, fallbacks);
    }
    v
}

/// The G1 scheme prepared for one mesh: the shared curves of its crease edges, built once,
/// from which any triangle's patch is built on demand.
struct G1Builder<'a> {
    mesh: &'a Mesh,
    /// Shared curves of crease edges, keyed by half-edge 3t + k, running from corner k to
    /// corner k + 1.
    curves: HashMap<u32, [DVec3; 4]>,
    /// Fallbacks taken while building the crease curves.
    fallbacks: usize,
}

impl TriangleBuilder for G1Builder<'_> {
    fn build(&self, t: usize, out: &mut [DVec3]) -> usize {
        let mesh = self.mesh;
        let tri = mesh.triangles[t];
        let q = tri.map(|v| mesh.positions[v as usize]);
        let given = if self.curves.is_empty() {
            [None; 3]
        } else {
            std::array::from_fn(|k| self.curves.get(&(3 * t as u32 + k as u32)).copied())
        };
        let mut fallbacks = 0;
        let n = mesh.corner_normals[t];
        if let Some(slot) = out.first_chunk_mut::<18>() {
            // SAFETY: the CPU has AVX2 (checked first).
            #[cfg(target_arch = "x86_64")]
            if given.iter().all(Option::is_none)
                && cpu_has!("avx2")
                && unsafe { lanes::build_avx2(q, n, tri, slot) }
            {
                return 0;
            }
            patch_points_into(q, n, tri, given, &mut fallbacks, slot);
        } else {
            out.copy_from_slice(&patch_points_with_curves(q, n, tri, given, &mut fallbacks));
        }
        fallbacks
    }

    fn prepared_fallbacks(&self) -> usize {
        self.fallbacks
    }
}

/// The shared curve of the interior edge `v` (`v[0] < v[1]`, running from `v[0]` to `v[1]`)
/// used by `uses` (in increasing half-edge order, as [`EdgeIndex`] gives them) when it is a
/// crease edge (its uses disagree on an end's normal), or `None`.
pub fn edge_curve(
    mesh: &Mesh,
    v: [u32; 2],
    uses: [EdgeUse; 2],
    fallbacks: &mut usize,
) -> Option<[DVec3; 4]> {
    let [u0, u1] = uses;
    let [a, b] = v;
    let split =
        v.map(|v| normal_key(use_normal(mesh, u0, v)) != normal_key(use_normal(mesh, u1, v)));
    if !(split[0] || split[1]) {
        return None;
    }
    Some(crease_curve(
        mesh.positions[a as usize],
        mesh.positions[b as usize],
        [use_normal(mesh, u0, a), use_normal(mesh, u1, a)],
        [use_normal(mesh, u0, b), use_normal(mesh, u1, b)],
        split,
        fallbacks,
    ))
}

/// `curve` with its arms V1 − V0 and V2 − V3 scaled by `s[0]` and `s[1]`: the end tangents
/// keep their directions (in the tangent planes of the ends), so a curve shared by both
/// triangles of an edge stays G1 there and watertight.
pub fn scale_arms(curve: [DVec3; 4], s: [f64; 2]) -> [DVec3; 4] {
    let [v0, v1, v2, v3] = curve;
    [v0, v0 + s[0] * (v1 - v0), v3 + s[1] * (v2 - v3), v3]
}

/// The arm factors of the edge `v` (`v[0] < v[1]`) that the use `u` gives
/// ([`crate::mesh::CornerAttributes::arm_scales`]), at `v[0]` and at `v[1]`; `[1, 1]`
/// where the mesh has none, and 1 for a factor that is not finite and positive.
pub fn arm_scale(mesh: &Mesh, v: [u32; 2], u: EdgeUse) -> [f64; 2] {
    let Some(s) = mesh
        .attributes
        .arm_scales
        .as_ref()
        .and_then(|a| a.get(u.triangle as usize))
        .and_then(|s| s.get(u.local as usize))
    else {
        return [1.0, 1.0];
    };
    let ok = |x: f64| if x.is_finite() && x > 0.0 { x } else { 1.0 };
    let from = mesh
        .triangles
        .get(u.triangle as usize)
        .map_or(v[0], |t| t[u.local as usize % 3]);
    if from == v[0] {
        [ok(s[0]), ok(s[1])]
    } else {
        [ok(s[1]), ok(s[0])]
    }
}

/// The curve that both uses of the interior edge `v` share (running from `v[0]` to
/// `v[1]`), or `None` where each builds the ordinary Walton–Meek cubic: the crease curve
/// ([`edge_curve`]) or the Walton–Meek cubic of the first use's normals, with its arms
/// scaled by the first use's factors ([`arm_scale`]) where they are not 1.
pub fn shared_curve(
    mesh: &Mesh,
    v: [u32; 2],
    uses: [EdgeUse; 2],
    fallbacks: &mut usize,
) -> Option<[DVec3; 4]> {
    let base = edge_curve(mesh, v, uses, fallbacks);
    let s = arm_scale(mesh, v, uses[0]);
    if s == [1.0, 1.0] {
        return base;
    }
    let c = base.unwrap_or_else(|| {
        let [a, b] = v;
        walton_meek(
            mesh.positions[a as usize],
            use_normal(mesh, uses[0], a),
            mesh.positions[b as usize],
            use_normal(mesh, uses[0], b),
        )
    });
    Some(scale_arms(c, s))
}

/// Whether some vertex gets two different normals from its corners (compared bitwise, by
/// [`normal_key`]). Without such a vertex no edge is a crease: [`edge_curve`] is `None` for
/// every edge. One parallel pass over the corners, 4 bytes per vertex: each vertex's first
/// corner to claim it is its representative and every other corner is compared with it
/// (where a vertex's corners do not all agree, some corner differs from whichever one
/// claimed it, so the claiming order does not matter). `true` (look edge by edge) where
/// the corners cannot be numbered in 32 bits, the corner normals are out of step with the
/// triangles, or a corner names no vertex.
pub fn any_split_normals(mesh: &Mesh) -> bool {
    use rayon::prelude::*;
    use std::sync::atomic::{AtomicU32, Ordering};
    let corners = 3 * mesh.triangles.len();
    if corners >= u32::MAX as usize || mesh.corner_normals.len() != mesh.triangles.len() {
        return true;
    }
    let first: Vec<AtomicU32> =
        crate::par::filled_with(mesh.positions.len(), || AtomicU32::new(u32::MAX));
    mesh.triangles
        .par_iter()
        .zip(mesh.corner_normals.par_iter())
        .enumerate()
        .with_min_len(1 << 12)
        .any(|(t, (tri, normals))| {
            (0..3).any(|k| {
                let Some(f) = first.get(tri[k] as usize) else {
                    return true;
                };
                let mut c = f.load(Ordering::Relaxed);
                if c == u32::MAX {
                    let own = (3 * t + k) as u32;
                    match f.compare_exchange(u32::MAX, own, Ordering::Relaxed, Ordering::Relaxed) {
                        Ok(_) => return false,
                        Err(other) => c = other,
                    }
                }
                let (ft, fk) = (c as usize / 3, c as usize % 3);
                normal_key(mesh.corner_normals[ft][fk]) != normal_key(normals[k])
            })
        })
}

/// The G1 scheme prepared for `mesh`: crease edges (split normals at an end, see
/// [`crate::mesh::creases`]) get one shared [`crease_curve`], built here once, and so do
/// edges whose arms the mesh scales ([`shared_curve`]).
pub fn prepare<'a>(mesh: &'a Mesh, _: &SchemeOptions) -> Result<Box<dyn TriangleBuilder + 'a>> {
    let mut fallbacks = 0;
    let mut curves: HashMap<u32, [DVec3; 4]> = HashMap::new();
    if mesh.attributes.arm_scales.is_none() && !any_split_normals(mesh) {
        return Ok(Box::new(G1Builder {
            mesh,
            curves,
            fallbacks,
        }));
    }
    let index = EdgeIndex::new(&mesh.triangles);
    for e in index.edges().filter(|e| e.is_interior()) {
        let [u0, u1] = [e.use_at(0), e.use_at(1)];
        let [a, _] = e.v;
        let Some(curve) = shared_curve(mesh, e.v, [u0, u1], &mut fallbacks) else {
            continue;
        };
        for u in [u0, u1] {
            let from = mesh.triangles[u.triangle as usize][u.local as usize];
            let c = if from == a {
                curve
            } else {
                [curve[3], curve[2], curve[1], curve[0]]
            };
            curves.insert(u.half_edge(), c);
        }
    }
    Ok(Box::new(G1Builder {
        mesh,
        curves,
        fallbacks,
    }))
}
