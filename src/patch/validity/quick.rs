//! The certificate's quick test of a G1 (Gregory) patch on its whole domain, before any
//! subdivision ([`quick_gregory`]): sufficient tests, each a few dozen products, that
//! certify the bulk of the patches of a fine mesh; where they fail, the subdivision
//! ([`super::check_patch`]) decides.

use glam::DVec3;

use super::{
    blend_extent, restrict, tables, BlendExtent, Cell, Pairs, Scratch, QUARTIC_BOUNDARY,
    QUARTIC_INTERIOR, QUARTIC_UP,
};

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
    #[cfg(target_arch = "x86_64")]
    if cpu_has!("avx") {
        // SAFETY: the CPU has AVX (checked just above).
        return unsafe { quick_half_avx(c, nref) } != Quick::Neither;
    }
    quick_half(c, nref) != Quick::Neither
}

/// [`quick_half`] compiled for AVX (the same operations, so the same result).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
fn quick_half_avx(c: &[DVec3], nref: DVec3) -> Quick {
    quick_half(c, nref)
}

/// Which half of [`quick_gregory`] certifies a patch: the first ([`quick_flat`], or J_P's
/// coefficients less whole lengths), the second ([`NormalPart`]'s bound, tried only where
/// the first fails), or neither.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Quick {
    First,
    Second,
    Neither,
}

/// [`quick_gregory`], telling which half certifies ([`Quick`]).
#[inline(always)]
pub(super) fn quick_half(c: &[DVec3], nref: DVec3) -> Quick {
    let (ds, dt, r, cmax) = quick_quartic(c);
    if quick_flat(c, &ds, &dt, r, nref, cmax) {
        return Quick::First;
    }
    let ps = ds[..10].iter().map(|v| v.length()).fold(0.0, f64::max);
    let pt = dt[..10].iter().map(|v| v.length()).fold(0.0, f64::max);
    let jmin = quartic_jmin(&ds[..10], &dt[..10], nref);
    // The same rounding tolerance as [`Geometry::new`] (degree 4 here).
    let tol = 1e-9 * ps * pt + 64.0 * f64::EPSILON * cmax * 4.0 * (ps + pt);
    if jmin - (ps * r + r * pt + r * r) - tol > 0.0 {
        Quick::First
    } else if NormalPart::of(c, &ds, &dt, cmax, nref).whole(jmin) > 0.0 {
        Quick::Second
    } else {
        Quick::Neither
    }
}

/// The smallest Bernstein coefficient of J_P = (P_s × P_t) · n (degree 6) from the
/// derivative coefficients `ds` and `dt` of a quartic P (degree 3, the first 10 of each)
/// on a domain.
#[inline(always)]
fn quartic_jmin(ds: &[DVec3], dt: &[DVec3], n: DVec3) -> f64 {
    let tn: [DVec3; 10] = std::array::from_fn(|j| dt[j].cross(n));
    // Each coefficient summed over its terms (`Tables::by_coefficient`), the smallest kept.
    let mut jmin = f64::INFINITY;
    for terms in tables().by_coefficient[3].each() {
        let mut c = 0.0;
        for &(a, b, w) in terms {
            c += w * ds[a].dot(tn[b]);
        }
        jmin = jmin.min(c);
    }
    jmin
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

/// The second half of [`quick_gregory`], and the second bound of the subdivision's cells
/// ([`NormalPart::lower`]), for patches whose Gregory points differ mostly along the
/// normal. With S = P + Σ_m ρ_m ΔG_m (P the quartic of [`quick_quartic`]),
/// J = J_P + Σ_m ∂_t ρ_m (P_s × ΔG_m) · n + Σ_m ∂_s ρ_m (ΔG_m × P_t) · n +
/// Σ_{m ≠ k} ∂_s ρ_m ∂_t ρ_k (ΔG_m × ΔG_k) · n (the terms with m = k vanish). On a domain
/// (the whole one, or a cell) each |∂ρ| has a bound ([`QUICK_BLEND_BOUND`] on the whole,
/// [`blend_slopes`] on a cell), and (P_s × ΔG_m) · n, a Bernstein sum of (ds_j × ΔG_m) · n
/// with weights summing to 1, is at most the largest of those in size; so only the parts
/// of ΔG_m and of the tangents across n count, where [`quick_gregory`]'s first half takes
/// whole lengths. The linearised blend of [`super::Geometry::bound`] is far from J on large
/// cells (its Taylor remainder dwarfs J there); this bound is not.
pub(super) struct NormalPart {
    /// The derivative coefficient pairs (along s and t, degree 3) of P on the whole domain.
    pairs: Pairs,
    /// The parts of the Gregory points' differences across n.
    pub across: Across,
    nref: DVec3,
    /// The rounding tolerance, counting the Gregory points' differences beside the
    /// tangents.
    tol: f64,
}

impl NormalPart {
    /// The part of G1 patch `c` (its 18 control points; unit flat normal `nref`).
    pub(super) fn new(c: &[DVec3], nref: DVec3) -> NormalPart {
        let (ds, dt, _, cmax) = quick_quartic(c);
        Self::of(c, &ds, &dt, cmax, nref)
    }

    /// [`Self::new`] from [`quick_quartic`]'s derivative coefficients `ds`, `dt` and
    /// largest control point coordinate `cmax`.
    fn of(c: &[DVec3], ds: &[DVec3; 15], dt: &[DVec3; 15], cmax: f64, nref: DVec3) -> NormalPart {
        let dg: [DVec3; 3] = std::array::from_fn(|m| c[12 + 2 * m] - c[13 + 2 * ((m + 2) % 3)]);
        let mut pairs = [[DVec3::ZERO; 2]; 15];
        for j in 0..10 {
            pairs[j] = [ds[j], dt[j]];
        }
        let b = QUICK_BLEND_BOUND;
        let r: f64 = dg.iter().map(|g| g.length()).sum();
        let ps = ds[..10].iter().map(|d| d.length()).fold(0.0, f64::max) + b * r;
        let pt = dt[..10].iter().map(|d| d.length()).fold(0.0, f64::max) + b * r;
        let tol = 1e-9 * ps * pt + 64.0 * f64::EPSILON * cmax * 4.0 * (ps + pt);
        NormalPart {
            pairs,
            across: Across::new(&dg, nref),
            nref,
            tol,
        }
    }

    /// The bound on the whole domain, J_P's smallest coefficient there being `jmin`.
    pub(super) fn whole(&self, jmin: f64) -> f64 {
        let b = QUICK_BLEND_BOUND;
        self.bound(&self.pairs, jmin, &[(b, b); 3])
    }

    /// A lower bound of J on `cell`, certified where positive: P's derivatives restricted
    /// to the cell (their Bernstein coefficients there) and each |∂ρ_m| bounded on the cell.
    pub(super) fn lower(&self, cell: &Cell, scratch: &mut Scratch<[DVec3; 2]>) -> f64 {
        #[cfg(target_arch = "x86_64")]
        if cpu_has!("avx") {
            // SAFETY: the CPU has AVX (checked just above).
            return unsafe { self.lower_avx(cell, scratch) };
        }
        self.lower_inlined(cell, scratch)
    }

    /// [`Self::lower`] compiled for AVX (the same operations, so the same result).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    fn lower_avx(&self, cell: &Cell, scratch: &mut Scratch<[DVec3; 2]>) -> f64 {
        self.lower_inlined(cell, scratch)
    }

    /// See [`Self::lower`].
    #[inline(always)]
    fn lower_inlined(&self, cell: &Cell, scratch: &mut Scratch<[DVec3; 2]>) -> f64 {
        let mut r = [[DVec3::ZERO; 2]; 15];
        restrict(&self.pairs, 3, cell, scratch, &mut r);
        let ds: [DVec3; 10] = std::array::from_fn(|j| r[j][0]);
        let dt: [DVec3; 10] = std::array::from_fn(|j| r[j][1]);
        let slopes: [(f64, f64); 3] = std::array::from_fn(|m| blend_slopes(m, cell));
        self.bound(&r, quartic_jmin(&ds, &dt, self.nref), &slopes)
    }

    /// The bound on a domain where P's derivative pairs are `r`, J_P's smallest coefficient
    /// is `jmin` and |∂ρ_m/∂s|, |∂ρ_m/∂t| are at most `slopes[m]`.
    #[inline(always)]
    fn bound(&self, r: &Pairs, jmin: f64, slopes: &[(f64, f64); 3]) -> f64 {
        let (a, c) = self.across.maxima(&r[..10]);
        jmin - self.across.remainder(&a, &c, slopes) - self.tol
    }
}

/// What J takes from the Gregory points' differences ΔG_m = G_{m,1} − G_{m−1,2} beside a
/// polynomial part P whose derivative coefficients are known ([`NormalPart`], and the
/// linearised blend's remainder in [`super::Geometry::bound`]): with S = P + Σ_m ρ_m ΔG_m
/// and |∂_s ρ_m| ≤ b_s,m, |∂_t ρ_m| ≤ b_t,m on a domain, |J − J_P| is at most
/// Σ_m (b_t,m max_j |(ds_j × ΔG_m) · n| + b_s,m max_j |(ΔG_m × dt_j) · n|) plus
/// Σ_{m ≠ k} b_s,m b_t,k |(ΔG_m × ΔG_k) · n|, since (P_s × ΔG_m) · n is a Bernstein sum of
/// the (ds_j × ΔG_m) · n with weights summing to 1, and the terms with m = k vanish.
pub(super) struct Across {
    /// ΔG_m × n, so that (d × ΔG_m) · n = d · (ΔG_m × n) and (ΔG_m × d) · n = −d · (ΔG_m × n).
    pub gn: [DVec3; 3],
    /// |(ΔG_m × ΔG_k) · n| (m ≠ k).
    pairs: [[f64; 3]; 3],
}

impl Across {
    /// The terms of differences `dg` across the unit normal `n`.
    pub(super) fn new(dg: &[DVec3; 3], n: DVec3) -> Across {
        Across {
            gn: std::array::from_fn(|m| dg[m].cross(n)),
            pairs: std::array::from_fn(|m| {
                std::array::from_fn(|k| {
                    if m == k {
                        0.0
                    } else {
                        dg[m].cross(dg[k]).dot(n).abs()
                    }
                })
            }),
        }
    }

    /// For each m, max_j |ds_j · (ΔG_m × n)| and max_j |dt_j · (ΔG_m × n)| over the pairs `r`.
    pub(super) fn maxima(&self, r: &[[DVec3; 2]]) -> ([f64; 3], [f64; 3]) {
        let side = |v: usize| {
            std::array::from_fn(|m| {
                let g = self.gn[m];
                r.iter()
                    .map(|d| dot(d[v].to_array(), g).abs())
                    .fold(0.0, f64::max)
            })
        };
        (side(0), side(1))
    }

    /// The bound on |J − J_P| from [`Self::maxima`] `a` (along s) and `c` (along t) and the
    /// slopes' bounds.
    pub(super) fn remainder(&self, a: &[f64; 3], c: &[f64; 3], slopes: &[(f64, f64); 3]) -> f64 {
        let mut cross = 0.0;
        for m in 0..3 {
            cross += slopes[m].1 * a[m] + slopes[m].0 * c[m];
        }
        let mut pairs = 0.0;
        for m in 0..3 {
            for k in 0..3 {
                if m != k {
                    pairs += slopes[m].0 * slopes[k].1 * self.pairs[m][k];
                }
            }
        }
        cross + pairs
    }
}

/// d · g, component by component in order (the four-lane bound repeats it lane by lane).
#[inline(always)]
pub(super) fn dot(d: [f64; 3], g: DVec3) -> f64 {
    d[0] * g.x + d[1] * g.y + d[2] * g.z
}

/// Bounds on |∂ρ/∂s| and |∂ρ/∂t| on `cell` for ρ = 12 x² y z (φ − 1/2) of corner m (x, y, z
/// = b_m, b_{m+1}, b_{m+2}, σ = y + z, φ = y/σ, ψ = φ − 1/2), never above
/// [`QUICK_BLEND_BOUND`]:
/// - ∂ρ/∂x = 24 x y z ψ;
/// - ∂ρ/∂y = 12 x² (z ψ + y z ∂_y φ) with y z ∂_y φ = y z²/σ² = y (1 − φ)²;
/// - ∂ρ/∂z = 12 x² (y ψ + y z ∂_z φ) with y z ∂_z φ = −y² z/σ² = −z φ².
///
/// x, y and z are affine, so their largest values on the cell are at its corners; φ is a
/// linear fraction, so where σ > 0 at every corner (then on the whole cell) its range is
/// that of its values at the corners, and [0, 1] otherwise. ∂/∂s = ∂_{b1} − ∂_{b0} and
/// ∂/∂t = ∂_{b2} − ∂_{b0}.
#[inline(always)]
pub(super) fn blend_slopes(m: usize, cell: &Cell) -> (f64, f64) {
    let (im, iy, iz) = (m, (m + 1) % 3, (m + 2) % 3);
    let BlendExtent {
        xm,
        ym,
        zm,
        mut lo,
        mut hi,
        smin,
    } = blend_extent(m, cell);
    // A corner with y + z = 0 is the pole, where φ takes every value of [0, 1] nearby.
    if smin <= 0.0 {
        (lo, hi) = (0.0, 1.0);
    }
    let psi = (lo - 0.5).abs().max((hi - 0.5).abs());
    let mut d = [0.0; 3];
    d[im] = 24.0 * xm * ym * zm * psi;
    d[iy] = 12.0 * xm * xm * (zm * psi + ym * (1.0 - lo) * (1.0 - lo));
    d[iz] = 12.0 * xm * xm * (ym * psi + zm * hi * hi);
    (
        (d[1] + d[0]).min(QUICK_BLEND_BOUND),
        (d[2] + d[0]).min(QUICK_BLEND_BOUND),
    )
}

#[cfg(test)]
mod tests {
    use super::{blend_slopes, NormalPart};
    use crate::patch::validity::{blend_terms, children, jacobian, Cell, Geometry, Work};
    use crate::{LoadOptions, Mesh, PatchTable, Scheme, SchemeOptions};

    /// Every cell of the first `depth` levels of the subdivision of the whole domain.
    fn cells(depth: u32) -> Vec<Cell> {
        let mut all = vec![[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]];
        let mut level = all.clone();
        for _ in 0..depth {
            level = level.iter().flat_map(children).collect();
            all.extend(&level);
        }
        all
    }

    /// The point of `cell` at barycentric `w` (of the cell).
    fn at(cell: &Cell, w: [f64; 3]) -> [f64; 3] {
        std::array::from_fn(|j| (0..3).map(|k| w[k] * cell[k][j]).sum())
    }

    /// [`blend_slopes`] bounds |∂ρ/∂s| and |∂ρ/∂t| on every cell of four levels of the
    /// subdivision: central differences (h = 1e-7, exact to O(h²) ≈ 1e-14 against a
    /// derivative of order 1) at the 136 points of a level-15 grid of each cell, the
    /// domain's edges left out (φ is singular at corner m), stay within the bound plus
    /// 1e-6 (the differences' rounding, 1e-16/h). And the bound is not vacuous: on a cell
    /// of width 1/16 at the domain's centre it is below half the whole domain's.
    #[test]
    fn blend_slopes_bound_the_blend_on_each_cell() {
        let rho = |m: usize, b: [f64; 3]| {
            let (x, y, z) = (b[m], b[(m + 1) % 3], b[(m + 2) % 3]);
            12.0 * x * x * y * z * (y / (y + z) - 0.5)
        };
        let h = 1e-7;
        let n = 15;
        let mut checked = 0;
        for cell in cells(4) {
            for m in 0..3 {
                let (bs, bt) = blend_slopes(m, &cell);
                for i in 0..=n {
                    for j in 0..=n - i {
                        let w = [i, j, n - i - j].map(|k| k as f64 / n as f64);
                        let b = at(&cell, w);
                        if b.iter().any(|&x| x < 2.0 * h) {
                            continue;
                        }
                        for (dir, bound) in [([-1.0, 1.0, 0.0], bs), ([-1.0, 0.0, 1.0], bt)] {
                            let p = |e: f64| std::array::from_fn(|k| b[k] + e * dir[k]);
                            let d = (rho(m, p(h)) - rho(m, p(-h))) / (2.0 * h);
                            assert!(d.abs() <= bound + 1e-6, "{cell:?} {m} {b:?}: {d} > {bound}");
                            checked += 1;
                        }
                    }
                }
            }
        }
        assert!(checked > 100_000, "{checked}");
        let third = 1.0 / 3.0;
        let d = 1.0 / 64.0;
        let centre = [
            [third + 2.0 * d, third - d, third - d],
            [third - d, third + 2.0 * d, third - d],
            [third - d, third - d, third + 2.0 * d],
        ];
        for m in 0..3 {
            let (bs, bt) = blend_slopes(m, &centre);
            assert!(bs < 0.5 && bt < 0.5, "{m}: {bs} {bt}");
        }
    }

    /// Every cell of three levels of the subdivision of G1 patches of Suzanne and the bunny
    /// that [`NormalPart::lower`] certifies has J > 0 at the 45 points of a level-8
    /// grid of the cell by the patch's own f64 evaluation (independent of the bound), and
    /// the bound certifies cells that the whole domain's test does not (the count is
    /// deterministic).
    #[test]
    fn normal_part_certifies_only_positive_jacobians() {
        let all = cells(3);
        let mut certified = Vec::new();
        for (file, table, every) in sampled_g1_tables() {
            let mut count = 0;
            let mut work = Work::new();
            for i in (0..table.len()).step_by(every) {
                let part = NormalPart::new(table.patch(i), table.flat_normals[i]);
                for cell in &all[1..] {
                    if part.lower(cell, &mut work.one) > 0.0 {
                        count += 1;
                        assert_positive_on(&table, i, cell, file);
                    }
                }
            }
            certified.push(count);
        }
        // Of 968 × 84 and 716 × 84 cells (the bunny's patches are smooth: all of them).
        assert_eq!(certified, vec![68_556, 60_144]);
    }

    /// The G1 tables of Suzanne and the bunny, with the step of the patches the tests of
    /// the cell bounds take: every Suzanne patch, every 97th of the bunny's.
    fn sampled_g1_tables() -> Vec<(&'static str, PatchTable, usize)> {
        [("suzanne.obj", 1), ("stanford-bunny.obj", 97)]
            .into_iter()
            .map(|(file, every)| {
                let path = format!("{}/tests/data/{file}", env!("CARGO_MANIFEST_DIR"));
                let mesh = Mesh::load(&path, &LoadOptions::default()).unwrap();
                let opts = SchemeOptions::default();
                (
                    file,
                    PatchTable::build(&mesh, Scheme::G1, &opts).unwrap(),
                    every,
                )
            })
            .collect()
    }

    /// J > 0 at the 45 points of a level-8 grid of `cell` of patch `i`, by the patch's own
    /// f64 evaluation (independent of any bound).
    fn assert_positive_on(table: &PatchTable, i: usize, cell: &Cell, file: &str) {
        for a in 0..=8u32 {
            for b in 0..=8 - a {
                let w = [a, b, 8 - a - b].map(|k| k as f64 / 8.0);
                let (j, _) = jacobian(table, i, at(cell, w));
                assert!(j > 0.0, "{file} patch {i} cell {cell:?}: J = {j}");
            }
        }
    }

    /// [`blend_terms`] bounds the derivatives of what the linearised blend leaves out,
    /// ρ = 12 x² y z (φ − φ̂), on every cell of four levels: central differences (as in
    /// [`blend_slopes_bound_the_blend_on_each_cell`], same step, points and 1e-6 for their
    /// rounding) stay within the bound. And the bound follows ρ as the cell shrinks: on the
    /// central cell of width 1/16 it is at most 4× the largest difference found there (the
    /// bound takes each factor's maximum over the cell separately; measured: 2.8–3.7×), and
    /// on its central child, of width 1/32, at most half the parent's (the bound is O(h);
    /// measured: 0.28–0.30).
    #[test]
    fn blend_terms_bound_the_linearised_remainder() {
        let rest = |m: usize, ell: [f64; 3], b: [f64; 3]| {
            let (x, y, z) = (b[m], b[(m + 1) % 3], b[(m + 2) % 3]);
            let lin: f64 = (0..3).map(|k| ell[k] * b[k]).sum();
            12.0 * x * x * y * z * (y / (y + z) - lin)
        };
        let h = 1e-7;
        let n = 15;
        let largest = |cell: &Cell, m: usize| {
            let (ell, bs, bt) = blend_terms(m, cell);
            let mut seen = [0.0f64; 2];
            for i in 0..=n {
                for j in 0..=n - i {
                    let w = [i, j, n - i - j].map(|k| k as f64 / n as f64);
                    let b = at(cell, w);
                    if b.iter().any(|&x| x < 2.0 * h) {
                        continue;
                    }
                    for (v, dir) in [[-1.0, 1.0, 0.0], [-1.0, 0.0, 1.0]].iter().enumerate() {
                        let p = |e: f64| std::array::from_fn(|k| b[k] + e * dir[k]);
                        let d = (rest(m, ell, p(h)) - rest(m, ell, p(-h))) / (2.0 * h);
                        seen[v] = seen[v].max(d.abs());
                    }
                }
            }
            ([bs, bt], seen)
        };
        let mut checked = 0;
        for cell in cells(4) {
            for m in 0..3 {
                let (bound, seen) = largest(&cell, m);
                for v in 0..2 {
                    assert!(
                        seen[v] <= bound[v] + 1e-6,
                        "{cell:?} {m}: {seen:?} > {bound:?}"
                    );
                }
                checked += 1;
            }
        }
        assert_eq!(checked, 3 * 341);
        let third = 1.0 / 3.0;
        let centre = |d: f64| {
            [
                [third + 2.0 * d, third - d, third - d],
                [third - d, third + 2.0 * d, third - d],
                [third - d, third - d, third + 2.0 * d],
            ]
        };
        for m in 0..3 {
            let (bound, seen) = largest(&centre(1.0 / 64.0), m);
            let (half, _) = largest(&centre(-1.0 / 128.0), m);
            for v in 0..2 {
                assert!(bound[v] <= 4.0 * seen[v], "{m}: {bound:?} against {seen:?}");
                assert!(half[v] <= 0.5 * bound[v], "{m}: {half:?} against {bound:?}");
            }
        }
    }

    /// Every cell of three levels of the subdivision of G1 patches of Suzanne and the bunny
    /// that [`Geometry::bound`] certifies has J > 0 at the 45 points of a level-8 grid of
    /// the cell by the patch's own f64 evaluation (independent of the bound); and the
    /// bound with [`super::Across`]'s remainder certifies cells that whole lengths do not
    /// (the same bound without it). The counts are deterministic.
    #[test]
    fn cell_bounds_certify_only_positive_jacobians() {
        let all = cells(3);
        let mut certified = Vec::new();
        for (file, table, every) in sampled_g1_tables() {
            let (mut count, mut by_lengths) = (0, 0);
            let mut work = Work::new();
            for i in (0..table.len()).step_by(every) {
                let geom = Geometry::new(&table, i);
                let mut lengths = Geometry::new(&table, i);
                lengths.normal_part = None;
                for cell in &all[1..] {
                    let whole = lengths.bound(cell, &mut work.one).0 > 0.0;
                    if geom.bound(cell, &mut work.one).0 <= 0.0 {
                        assert!(!whole, "{file} {i} {cell:?}");
                        continue;
                    }
                    count += 1;
                    by_lengths += whole as usize;
                    assert_positive_on(&table, i, cell, file);
                }
            }
            certified.push((count, by_lengths));
        }
        // Of 968 × 84 and 716 × 84 cells: on Suzanne 13,376 are certified only with the parts
        // across n, on the bunny 1,163.
        assert_eq!(certified, vec![(63_262, 49_886), (60_117, 58_954)]);
    }
}
