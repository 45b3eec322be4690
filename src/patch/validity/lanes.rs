//! The certificate's bound on four cells at once ([`Geometry::bound4`]): the four children
//! of a cell that the subdivision splits, one in each lane of `[f64; 4]` arrays, so that
//! the restriction of the derivative coefficients to the cells (de Casteljau steps) and
//! J's coefficients (the products) run four cells per instruction stream. Every lane
//! computes what [`Geometry::bound`] computes for its cell, operation for operation in the
//! same order (no fused multiply-add, which Rust never makes on its own), so each lane's
//! result is bitwise that of `bound` (a unit test compares them).

use super::{quick::dot, restrict_by, tables, Cell, Geometry, Scratch, Slopes, Stepper};
#[cfg(test)]
use {super::Pairs, glam::DVec3};

/// Four f64 side by side: one value per cell (per corner in `blend_corners`).
pub(super) type Lanes = [f64; 4];

/// One coefficient pair of four cells: `[s or t][x, y or z][lane]`.
type PairLanes = [[Lanes; 3]; 2];

/// A zero [`PairLanes`].
const ZERO_PAIR: PairLanes = [[[0.0; 4]; 3]; 2];

/// Coefficient pairs of four cells: `[coefficient][s or t][x, y or z][lane]`.
type Pairs4 = [PairLanes; 15];

const ZERO4: Pairs4 = [ZERO_PAIR; 15];

/// A barycentric point per lane: `[coordinate][lane]`.
type Point4 = [Lanes; 3];

/// The buffers of [`Geometry::bound4`], kept by a subdivision for all its cells: each call
/// writes every coefficient it reads (the pairs, their restriction and t × n_f up to the
/// degree's count), so what they held before is never read.
pub(super) struct FourWork {
    restrict: Scratch<PairLanes>,
    d: Pairs4,
    r: Pairs4,
    tn: [[Lanes; 3]; 15],
}

impl FourWork {
    pub(super) fn new() -> FourWork {
        FourWork {
            restrict: Scratch::new(ZERO_PAIR),
            d: ZERO4,
            r: ZERO4,
            tn: [[[0.0; 4]; 3]; 15],
        }
    }
}

/// J's products (`super::products` of one degree) grouped by the coefficient they add
/// to: the terms (α index, β index, weight) of coefficient g are `terms[ends[g]..ends[g +
/// 1]]`, in the products' order, so that a sum over them starting at 0 adds what the
/// products' loop adds to that coefficient, in the same order (bitwise the same sum).
pub(super) struct ByCoefficient {
    terms: Vec<(usize, usize, f64)>,
    ends: Vec<usize>,
}

impl ByCoefficient {
    pub(super) fn new(products: &[(usize, usize, usize, f64)]) -> ByCoefficient {
        let count = products.iter().map(|p| p.2 + 1).max().unwrap_or(0);
        let mut sorted = products.to_vec();
        // Stable: each coefficient's terms keep their order.
        sorted.sort_by_key(|p| p.2);
        let mut ends = vec![0; count + 1];
        for p in &sorted {
            ends[p.2 + 1] += 1;
        }
        for g in 0..count {
            ends[g + 1] += ends[g];
        }
        ByCoefficient {
            terms: sorted.iter().map(|&(a, b, _, w)| (a, b, w)).collect(),
            ends,
        }
    }

    /// Each coefficient's terms, coefficient by coefficient.
    #[inline(always)]
    pub(super) fn each(&self) -> impl Iterator<Item = &[(usize, usize, f64)]> {
        self.ends.windows(2).map(|e| &self.terms[e[0]..e[1]])
    }
}

/// [`super::step`] in every lane (lane l at `u[·][l]`).
#[inline(always)]
fn step4(src: &Pairs4, deg: u32, u: &Point4, dst: &mut Pairs4) {
    let up = &tables().up[deg as usize];
    for (j, ix) in up.iter().enumerate() {
        let (a, b, c) = (&src[ix[0]], &src[ix[1]], &src[ix[2]]);
        for v in 0..2 {
            for k in 0..3 {
                for l in 0..4 {
                    dst[j][v][k][l] =
                        u[0][l] * a[v][k][l] + u[1][l] * b[v][k][l] + u[2][l] * c[v][k][l];
                }
            }
        }
    }
}

/// [`super::restrict`] in every lane: the pairs `d` (degree m ≤ 4) restricted to lane l's
/// cell, whose corner k is `corners[k][·][l]`.
#[inline(always)]
fn restrict4(
    d: &Pairs4,
    m: u32,
    corners: &[Point4; 3],
    scratch: &mut Scratch<PairLanes>,
    out: &mut Pairs4,
) {
    restrict_by(d, m, scratch, &AtCorners(corners), out);
}

/// [`step4`] at four cells' corners.
struct AtCorners<'a>(&'a [Point4; 3]);

impl Stepper<PairLanes> for AtCorners<'_> {
    #[inline(always)]
    fn step(&self, src: &Pairs4, deg: u32, k: usize, dst: &mut Pairs4) {
        step4(src, deg, &self.0[k], dst);
    }
}

impl Geometry {
    /// [`Self::bound`] of each of `cells`, bitwise: with AVX where the CPU has it (the
    /// lanes in one register; the same operations, so the same bits).
    /// `work`: the buffers ([`FourWork`]).
    pub(super) fn bound4(
        &self,
        cells: &[Cell; 4],
        work: &mut FourWork,
    ) -> [(f64, [f64; 3], bool); 4] {
        #[cfg(target_arch = "x86_64")]
        if cpu_has!("avx") {
            // SAFETY: the CPU has AVX (checked above).
            return unsafe { self.bound4_avx(cells, work) };
        }
        self.bound4_lanes(cells, work)
    }

    /// [`Self::bound4_lanes`] compiled for AVX. Not for AVX-512: with its 32 registers the
    /// subdivisions of a 2 M-triangle mesh took 5–6 % less time (0.540–0.547 s against
    /// 0.571–0.578 s, one thread), too little to build on a compiler that once got this
    /// code wrong (rustc 1.95 built for AVX-512 dropped a cell corner from some lanes'
    /// maxima in `blend_corners`, now written so that it does not). The tests check the
    /// AVX-512 build wherever the CPU has it, since `-C target-cpu=native` makes it.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    fn bound4_avx(&self, cells: &[Cell; 4], work: &mut FourWork) -> [(f64, [f64; 3], bool); 4] {
        self.bound4_lanes(cells, work)
    }

    /// See [`Self::bound4`].
    #[inline(always)]
    fn bound4_lanes(&self, cells: &[Cell; 4], work: &mut FourWork) -> [(f64, [f64; 3], bool); 4] {
        let t = tables();
        let m = self.n.max(1) - 1;
        let dlen = t.powers[m as usize].len();
        let FourWork {
            restrict: scratch,
            d,
            r,
            tn,
        } = work;
        let mut slopes = [Slopes::default(); 4];
        // As `cell_pairs`: the derivatives as `derivatives` computes them (keep the two in
        // step; `four_lanes_are_bitwise_the_scalar_bound` compares them), into the lanes.
        let deg = self.n;
        let nf = deg as f64;
        for (l, cell) in cells.iter().enumerate() {
            let (p, sl) = self.cell_points(cell);
            slopes[l] = sl;
            if deg == 0 {
                d[0] = ZERO_PAIR;
            }
            for (j, ix) in t.up[deg as usize].iter().enumerate() {
                let (p0, p1, p2) = (
                    p[ix[0]].to_array(),
                    p[ix[1]].to_array(),
                    p[ix[2]].to_array(),
                );
                for k in 0..3 {
                    d[j][0][k][l] = nf * (p1[k] - p0[k]);
                    d[j][1][k][l] = nf * (p2[k] - p0[k]);
                }
            }
        }
        let corners: [Point4; 3] = std::array::from_fn(|k| {
            std::array::from_fn(|c| std::array::from_fn(|l| cells[l][k][c]))
        });
        restrict4(d, m, &corners, scratch, r);
        // As `finish`: |S_s|, |S_t| bounds, t × n_f, then J's coefficients, per lane.
        let length = |v: &[Lanes; 3], l: usize| {
            (v[0][l] * v[0][l] + v[1][l] * v[1][l] + v[2][l] * v[2][l]).sqrt()
        };
        let n = self.nref;
        for j in 0..dlen {
            let v = &r[j][1];
            for l in 0..4 {
                tn[j][0][l] = v[1][l] * n.z - n.y * v[2][l];
                tn[j][1][l] = v[2][l] * n.x - n.z * v[0][l];
                tn[j][2][l] = v[0][l] * n.y - n.x * v[1][l];
            }
        }
        // Coefficient by coefficient, each sum in registers over its terms in the order of
        // `products` ([`ByCoefficient`]).
        let mut jc = [[0.0f64; 4]; 45];
        for (c, terms) in jc.iter_mut().zip(t.by_coefficient[m as usize].each()) {
            let mut acc = [0.0f64; 4];
            for &(a, b, w) in terms {
                let (s, tb) = (&r[a][0], &tn[b]);
                for l in 0..4 {
                    acc[l] += w * (s[0][l] * tb[0][l] + s[1][l] * tb[1][l] + s[2][l] * tb[2][l]);
                }
            }
            *c = acc;
        }
        // As `finish`, the four lanes side by side: |S_s| and |S_t| bounds (largest lengths,
        // in coefficient order), `Across::maxima` (largest |d · (ΔG_m × n)|, likewise), and
        // J's smallest coefficient (the first smallest, as `conclude`); each lane's values
        // are those of its own fold, the same operations in the same order.
        let (mut ps, mut pt) = ([0.0f64; 4], [0.0f64; 4]);
        for v in &r[..dlen] {
            for l in 0..4 {
                ps[l] = f64::max(ps[l], length(&v[0], l));
                pt[l] = f64::max(pt[l], length(&v[1], l));
            }
        }
        // Not `Option::map` with a closure: the closure was not inlined, and so was compiled
        // without AVX.
        let sides = if let Some(q) = self.normal_part.as_ref() {
            let mut sides = [[[0.0f64; 4]; 3]; 2];
            for d in &r[..dlen] {
                for (v, side) in sides.iter_mut().enumerate() {
                    let x = &d[v];
                    for (m, most) in side.iter_mut().enumerate() {
                        let g = q.across.gn[m];
                        for l in 0..4 {
                            let a = dot([x[0][l], x[1][l], x[2][l]], g).abs();
                            most[l] = f64::max(most[l], a);
                        }
                    }
                }
            }
            Some(sides)
        } else {
            None
        };
        let jlen = t.powers[2 * m as usize].len();
        let (mut imin, mut jmin) = ([0usize; 4], [f64::INFINITY; 4]);
        for (g, c) in jc[..jlen].iter().enumerate() {
            for l in 0..4 {
                if c[l] < jmin[l] {
                    (imin[l], jmin[l]) = (g, c[l]);
                }
            }
        }
        std::array::from_fn(|l| {
            let maxima = sides.as_ref().map(|s| {
                (
                    std::array::from_fn(|m| s[0][m][l]),
                    std::array::from_fn(|m| s[1][m][l]),
                )
            });
            let remainder = self.remainder(ps[l], pt[l], &slopes[l], maxima);
            self.conclude_at(imin[l], jmin[l], remainder, &cells[l])
        })
    }
}

/// [`Pairs`] of one lane of `p` (tests).
#[cfg(test)]
fn lane(p: &Pairs4, l: usize) -> Pairs {
    std::array::from_fn(|j| {
        std::array::from_fn(|v| DVec3::new(p[j][v][0][l], p[j][v][1][l], p[j][v][2][l]))
    })
}

#[cfg(test)]
mod tests {
    use super::super::{children, restrict, scratch, Geometry, Work, WHOLE};
    use super::*;
    use crate::{LoadOptions, Mesh, PatchTable, Scheme, SchemeOptions};

    /// [`ByCoefficient`] holds every product once, under its coefficient, in the products'
    /// order.
    #[test]
    fn products_by_coefficient_keep_their_order() {
        for m in 0..=4u32 {
            let products = &super::super::products(m, &tables().powers[m as usize]);
            let by = ByCoefficient::new(products);
            assert_eq!(by.terms.len(), products.len());
            for g in 0..by.ends.len() - 1 {
                let want: Vec<(usize, usize, f64)> = products
                    .iter()
                    .filter(|p| p.2 == g)
                    .map(|&(a, b, _, w)| (a, b, w))
                    .collect();
                assert!(!want.is_empty());
                assert_eq!(by.terms[by.ends[g]..by.ends[g + 1]], want[..]);
            }
        }
    }

    /// [`Geometry::bound4`] of `cells` by every path this CPU can run: the dispatch, the
    /// portable lanes, and the AVX and AVX-512 builds where the CPU has them.
    fn every_bound4(geom: &Geometry, cells: &[Cell; 4]) -> Vec<[(f64, [f64; 3], bool); 4]> {
        let work = || Work::new().four;
        #[cfg_attr(not(target_arch = "x86_64"), allow(unused_mut))]
        let mut all = vec![
            geom.bound4(cells, &mut work()),
            geom.bound4_lanes(cells, &mut work()),
        ];
        #[cfg(target_arch = "x86_64")]
        {
            if cpu_has!("avx") {
                // SAFETY: the CPU has AVX (checked just above).
                all.push(unsafe { geom.bound4_avx(cells, &mut work()) });
            }
            if cpu_has!("avx512f", "avx512vl") {
                // SAFETY: the CPU has AVX-512F and VL (checked just above).
                all.push(unsafe { bound4_avx512(geom, cells, &mut work()) });
            }
        }
        all
    }

    /// [`Geometry::bound4_lanes`] built for AVX-512, as `-C target-cpu=native` builds it on
    /// such a CPU (the library does not dispatch to it: see [`Geometry::bound4_avx`]).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,avx512vl")]
    fn bound4_avx512(
        geom: &Geometry,
        cells: &[Cell; 4],
        work: &mut FourWork,
    ) -> [(f64, [f64; 3], bool); 4] {
        geom.bound4_lanes(cells, work)
    }

    /// Every lane of [`Geometry::bound4`] by every path (and of [`restrict4`]) is bitwise
    /// the scalar result, on cells down to depth 4 of patches of every kind on Suzanne
    /// (G1's Gregory patches included).
    #[test]
    fn four_lanes_are_bitwise_the_scalar_bound() {
        let path = format!("{}/tests/data/suzanne.obj", env!("CARGO_MANIFEST_DIR"));
        let mesh = Mesh::load(&path, &LoadOptions::default()).unwrap();
        let mut compared = 0;
        for scheme in [Scheme::G1, Scheme::Pn, Scheme::Phong, Scheme::Flat] {
            let table = PatchTable::build(&mesh, scheme, &SchemeOptions::default()).unwrap();
            for i in (0..table.len()).step_by(37) {
                let geom = Geometry::new(&table, i);
                let mut level = vec![WHOLE];
                for _ in 0..4 {
                    let mut next = Vec::new();
                    for cell in &level {
                        let kids = children(cell);
                        let ones = kids.map(|kid| geom.bound(&kid, &mut scratch()));
                        for (path, four) in every_bound4(&geom, &kids).iter().enumerate() {
                            for (k, one) in ones.iter().enumerate() {
                                let at = format!("{scheme} {i} path {path}");
                                assert_eq!(four[k].0.to_bits(), one.0.to_bits(), "{at}");
                                let bits = |b: [f64; 3]| b.map(f64::to_bits);
                                assert_eq!(bits(four[k].1), bits(one.1), "{at}");
                                assert_eq!(four[k].2, one.2, "{at}");
                                compared += 1;
                            }
                        }
                        next.extend(kids);
                    }
                    level = next;
                }
                // The restriction itself, lane by lane.
                let kids = children(&WHOLE);
                let (pair, _) = geom.cell_pairs(&kids[0]);
                // The same pairs in every lane.
                let d: Pairs4 = std::array::from_fn(|j| {
                    std::array::from_fn(|v| pair[j][v].to_array().map(|x| [x; 4]))
                });
                let corners: [Point4; 3] = std::array::from_fn(|k| {
                    std::array::from_fn(|c| std::array::from_fn(|l| kids[l][k][c]))
                });
                let m = geom.n.max(1) - 1;
                let mut r4 = ZERO4;
                restrict4(&d, m, &corners, &mut Scratch::new(ZERO_PAIR), &mut r4);
                for (l, kid) in kids.iter().enumerate() {
                    let mut r = [[DVec3::ZERO; 2]; 15];
                    restrict(&pair, m, kid, &mut scratch(), &mut r);
                    let got = lane(&r4, l);
                    for j in 0..15 {
                        for v in 0..2 {
                            assert_eq!(
                                got[j][v].to_array().map(f64::to_bits),
                                r[j][v].to_array().map(f64::to_bits)
                            );
                        }
                    }
                }
            }
        }
        assert!(compared > 1000, "{compared}");
    }
}
