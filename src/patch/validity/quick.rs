//! The certificate's quick test of a G1 (Gregory) patch on its whole domain, before any
//! subdivision ([`quick_gregory`]): sufficient tests, each a few dozen products, that
//! certify the bulk of the patches of a fine mesh; where they fail, the subdivision of
//! [`super::check_within`] decides.

use glam::DVec3;

use super::{tables, QUARTIC_BOUNDARY, QUARTIC_INTERIOR, QUARTIC_UP};

/// Bound on |∂ρ/∂s| and |∂ρ/∂t| over the whole domain for ρ = 12 x² y z (φ − 1/2), the part
/// of corner m's Gregory weight that [`quick_gregory`] leaves out (x, y, z = b_m, b_{m+1},
/// b_{m+2}, φ = y/(y + z)).
///
/// With σ = y + z = 1 − x and u = y/σ, ρ = 6 x² σ² g(u), g(u) = u (1 − u)(2u − 1), |g| ≤ √3/18
/// and |g'| ≤ 1 on [0, 1]. The directions ∂/∂s = ∂_{b1} − ∂_{b0} and ∂/∂t = ∂_{b2} − ∂_{b0}
/// are, for every m, one of ±(e_y − e_x), ±(e_z − e_x), ±(e_y − e_z). Along e_y − e_x
/// (dσ = 1, du = (1 − u)/σ): ∂ρ = 6 x σ [2 (x − σ) g + x g'(u)(1 − u)], and
/// |g'(u)(1 − u)| ≤ |g'| ≤ 1, so |∂ρ| ≤ 6 x (1 − x) [2 |2x − 1| √3/18 + x] ≤ 0.98 for x ∈ [0, 1]; e_z − e_x is the same by
/// the symmetry y ↔ z (g(1 − u) = −g(u)). Along e_y − e_z (dσ = 0, du = 1/σ):
/// ∂ρ = 6 x² σ g'(u), at most 6 · 4/27 ≈ 0.89. Hence 1 bounds all six.
pub const QUICK_BLEND_BOUND: f64 = 1.0;

/// A quick sufficient test that a G1 patch (`c`, its 18 control points) is valid over its
/// whole domain, with no subdivision: the Gregory interior points are replaced by their
/// means (G_{m,1} + G_{m−1,2})/2, which makes the patch a quartic Bézier triangle P (J_P of
/// degree 6, bounded by its Bernstein coefficients); what that leaves out is
/// Σ_m ρ_m ΔG_m with ρ_m = 12 x² y z (φ − 1/2), whose derivatives are at most
/// [`QUICK_BLEND_BOUND`] |ΔG_m| each. Then J ≥ min J_P − (|P_s| r + r |P_t| + r²),
/// r = Σ_m |ΔG_m|. True only when that bound, less the rounding tolerance, is positive;
/// false says nothing (the full certificate decides).
pub(super) fn quick_gregory(c: &[DVec3], nref: DVec3) -> bool {
    let t = tables();
    let (ds, dt, r, cmax) = quick_quartic(c);
    if quick_flat(c, &ds, &dt, r, nref, cmax) {
        return true;
    }
    let ps = ds[..10].iter().map(|v| v.length()).fold(0.0, f64::max);
    let pt = dt[..10].iter().map(|v| v.length()).fold(0.0, f64::max);
    let mut tn = [DVec3::ZERO; 10];
    for (j, v) in dt[..10].iter().enumerate() {
        tn[j] = v.cross(nref);
    }
    let mut jc = [0.0f64; 28];
    for &(a, b, g, w) in &t.products[3] {
        jc[g] += w * ds[a].dot(tn[b]);
    }
    let jmin = jc.iter().copied().fold(f64::INFINITY, f64::min);
    // The same rounding tolerance as [`Geometry::new`] (degree 4 here).
    let tol = 1e-9 * ps * pt + 64.0 * f64::EPSILON * cmax * 4.0 * (ps + pt);
    jmin - (ps * r + r * pt + r * r) - tol > 0.0 || quick_normal_part(c, &ds, &dt, jmin, nref, cmax)
}

/// The second half of [`quick_gregory`], for patches whose Gregory points differ mostly
/// along the normal: with S = P + Σ_m ρ_m ΔG_m, J = J_P + Σ_m ∂_t ρ_m (P_s × ΔG_m) · n +
/// Σ_m ∂_s ρ_m (ΔG_m × P_t) · n + Σ_{m ≠ k} ∂_s ρ_m ∂_t ρ_k (ΔG_m × ΔG_k) · n (the terms with
/// m = k vanish). Each |∂ρ| is at most [`QUICK_BLEND_BOUND`], and (P_s × ΔG_m) · n, a
/// Bernstein sum of (ds_j × ΔG_m) · n with weights summing to 1, is at most the largest of
/// those in size; so only the parts of ΔG_m and of the tangents across n count, where
/// [`quick_gregory`]'s first half takes whole lengths. True only when J_P's smallest
/// Bernstein coefficient `jmin`, less those bounds and a rounding tolerance that counts
/// the Gregory points' differences beside the tangents, is positive.
#[inline(always)]
pub(super) fn quick_normal_part(
    c: &[DVec3],
    ds: &[DVec3; 15],
    dt: &[DVec3; 15],
    jmin: f64,
    nref: DVec3,
    cmax: f64,
) -> bool {
    let dg: [DVec3; 3] = std::array::from_fn(|m| c[12 + 2 * m] - c[13 + 2 * ((m + 2) % 3)]);
    let most = |f: &dyn Fn(&DVec3) -> f64| ds[..10].iter().map(f).fold(0.0, f64::max);
    let most_t = |f: &dyn Fn(&DVec3) -> f64| dt[..10].iter().map(f).fold(0.0, f64::max);
    let mut cross = 0.0;
    for g in &dg {
        cross += most(&|d| d.cross(*g).dot(nref).abs());
        cross += most_t(&|d| g.cross(*d).dot(nref).abs());
    }
    let mut pairs = 0.0;
    for m in 0..3 {
        for k in 0..3 {
            if m != k {
                pairs += dg[m].cross(dg[k]).dot(nref).abs();
            }
        }
    }
    let b = QUICK_BLEND_BOUND;
    let r: f64 = dg.iter().map(|g| g.length()).sum();
    let ps = most(&|d| d.length()) + b * r;
    let pt = most_t(&|d| d.length()) + b * r;
    let tol = 1e-9 * ps * pt + 64.0 * f64::EPSILON * cmax * 4.0 * (ps + pt);
    jmin - b * cross - b * b * pairs - tol > 0.0
}

/// The quartic of [`quick_gregory`] (the Gregory interior points replaced by their means):
/// its derivative coefficients along s and t (degree 3: the first 10 of each), the bound r
/// on the derivatives of what it leaves out, and the largest control point coordinate.
#[inline(always)]
pub(super) fn quick_quartic(c: &[DVec3]) -> ([DVec3; 15], [DVec3; 15], f64, f64) {
    let mut q = [DVec3::ZERO; 15];
    for (j, &slot) in QUARTIC_BOUNDARY.iter().enumerate() {
        q[slot] = c[j];
    }
    let mut r = 0.0;
    for m in 0..3 {
        let g1 = c[12 + 2 * m];
        let g2 = c[13 + 2 * ((m + 2) % 3)];
        q[QUARTIC_INTERIOR[m]] = 0.5 * (g1 + g2);
        r += QUICK_BLEND_BOUND * (g1 - g2).length();
    }
    // As `derivatives(&q, 4)`, with its index table known at compile time.
    let mut ds = [DVec3::ZERO; 15];
    let mut dt = [DVec3::ZERO; 15];
    for (j, ix) in QUARTIC_UP.iter().enumerate() {
        ds[j] = 4.0 * (q[ix[1]] - q[ix[0]]);
        dt[j] = 4.0 * (q[ix[2]] - q[ix[0]]);
    }
    let cmax = c.iter().map(|p| p.abs().max_element()).fold(0.0, f64::max);
    (ds, dt, r, cmax)
}

/// The first, cheaper half of [`quick_gregory`]: the quartic's tangents measured from its
/// flat triangle's edges e_1 = c_1 − c_0 and e_2 = c_2 − c_0 (c_k its corners) instead of
/// J_P's Bernstein coefficients. S_s = P_s + R_s with P_s = Σ_j B_j ds_j (Bernstein
/// weights, summing to 1), so |S_s − e_1| ≤ max_j |ds_j − e_1| + r =: a, likewise
/// |S_t − e_2| ≤ b; with n the unit flat normal, J = ((e_1 + u) × (e_2 + v)) · n ≥
/// (e_1 × e_2) · n − |e_1| b − a |e_2| − a b. True only when that, less a rounding
/// tolerance no smaller than [`quick_gregory`]'s (|ds_j| ≤ |e_1| + a), is positive.
#[inline(always)]
pub(super) fn quick_flat(
    c: &[DVec3],
    ds: &[DVec3; 15],
    dt: &[DVec3; 15],
    r: f64,
    nref: DVec3,
    cmax: f64,
) -> bool {
    let (e1, e2) = (c[4] - c[0], c[8] - c[0]);
    let far = |d: &[DVec3; 15], e: DVec3| {
        d[..10]
            .iter()
            .map(|v| (*v - e).length_squared())
            .fold(0.0, f64::max)
            .sqrt()
    };
    let (a, b) = (far(ds, e1) + r, far(dt, e2) + r);
    let (l1, l2) = (e1.length(), e2.length());
    let (ps, pt) = (l1 + a, l2 + b);
    let tol = 1e-9 * ps * pt + 64.0 * f64::EPSILON * cmax * 4.0 * (ps + pt);
    e1.cross(e2).dot(nref) - (l1 * b + a * l2 + a * b) - tol > 0.0
}
