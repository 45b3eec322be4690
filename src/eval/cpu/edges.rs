//! The f64 edge kernel of the statistics ([`Evaluator::evaluate_edges`] and
//! [`Evaluator::evaluate_edge_products`]): the basis of an edge pattern computed once per
//! call, then each side of a pair evaluated in f64 lanes, AVX-512F (8 lanes) or AVX (4
//! lanes) detected at run time, bitwise the sparse reference.

use glam::DVec3;

#[cfg(doc)] // links in the documentation
use crate::eval::Evaluator;
use crate::eval::{EdgePairs, PairProducts};
use crate::patch::basis::SparseWeights;
use crate::patch::PatchTable;

/// Instruction set of the f64 edge kernel ([`Evaluator::evaluate_edges`] and
/// [`Evaluator::evaluate_edge_products`]). Points are bitwise the same with every choice
/// (each is bitwise `PatchTable::eval_sparse`); products are bitwise the same between the
/// two lane kernels, and within the bound of [`Evaluator::evaluate_edge_products`] of
/// those without lanes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EdgeKernel {
    /// The widest the CPU has (detected at run time): AVX-512F (8 lanes), else AVX (4
    /// lanes), else none.
    Auto,
    /// AVX (4 lanes) where the CPU has it, else none.
    Avx,
    /// No lanes: every point through its sparse weights.
    Sparse,
}

impl EdgeKernel {
    /// f64 lanes of the kernel that runs on this CPU (0: none).
    pub fn lanes(self) -> usize {
        match self {
            EdgeKernel::Auto if cpu_has!("avx512f") => 8,
            EdgeKernel::Auto | EdgeKernel::Avx if cpu_has!("avx") => 4,
            _ => 0,
        }
    }

    /// The kernel that runs on this CPU: "avx512f", "avx" or "sparse".
    pub fn name(self) -> &'static str {
        match self.lanes() {
            8 => "avx512f",
            4 => "avx",
            _ => "sparse",
        }
    }
}

/// Basis weights of an edge pattern, computed once per call: for each ordered slot pair
/// (from, to) and each sample, the weights at b[from] = 1 − t, b[to] = t, both sparse (as
/// [`PatchTable::eval_sparse`] takes them) and, for the lane kernel, dense over the points
/// any sample of that pair weighs, in blocks of `width` samples.
// Some fields are read only by the x86-64 lane kernels.
#[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
pub(super) struct EdgeWeights {
    kind: crate::patch::PatchKind,
    per: usize,
    /// Pair (from, to) at `(3 · from + to) · per`.
    w: Vec<SparseWeights>,
    /// Pair (from, to) at `3 · from + to` (empty without lanes).
    dense: Vec<DenseEdgeWeights>,
    /// Lanes of the kernel that runs ([`EdgeKernel::lanes`]): 8 (AVX-512F), 4 (AVX) or 0
    /// (none: every side evaluated sparsely).
    width: usize,
    /// [`min_len2`], for the kernel's products mode.
    min_len2: f64,
}

/// The largest f64 whose square root (correctly rounded) is not above
/// [`crate::patch::MIN_NORMAL_LEN_F64`]: as the rounded square root is monotonic,
/// `sqrt(d) > MIN_NORMAL_LEN_F64` exactly where `d > min_len2()`, so the products mode
/// picks the flat normal at exactly the samples where the unit normals do.
pub fn min_len2() -> f64 {
    let m = crate::patch::MIN_NORMAL_LEN_F64;
    // Neighbours of a positive finite f64 through its bits (f64::next_up is newer than
    // the crate's minimum Rust).
    let up = |t: f64| f64::from_bits(t.to_bits() + 1);
    let down = |t: f64| f64::from_bits(t.to_bits() - 1);
    let mut t = m * m;
    while t.sqrt() > m {
        t = down(t);
    }
    while up(t).sqrt() <= m {
        t = up(t);
    }
    t
}

/// The weights of one (from, to) pair for the lane kernel.
// Some fields are read only by the x86-64 lane kernels.
#[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
#[derive(Default)]
struct DenseEdgeWeights {
    /// Samples per block (the kernel's lanes).
    width: usize,
    /// For each block of `width` samples and each geometry control point with a nonzero
    /// weight at some sample (in increasing order): `width` values of w, ∂w/∂s, ∂w/∂t
    /// (padding samples 0).
    data: Vec<f64>,
    /// The terms the kernel adds, per block and per value (w, ∂w/∂s, ∂w/∂t): those points,
    /// in increasing order, where that value is nonzero in some sample of the block, each
    /// as (offset of its `width` values in `data`, point). The others are skipped: their
    /// products are ±0 on a finite point, and adding ±0 to a sum that started at +0 leaves
    /// it bitwise as it is (such a sum is never −0). Stored as rows of one term per value
    /// (row i holds term i of each of the three lists), so that the kernel's loop adds to
    /// all nine sums at once (their additions overlap instead of waiting on one sum's
    /// chain); a list shorter than the block's longest is padded at its end with a term of
    /// zero weights (the last `width` values of `data`) on point 0, which adds ±0 as well.
    rows: Vec<[(u32, u8); 3]>,
    /// Block b's rows are `rows[ranges[b][0]..ranges[b][1]]`.
    ranges: Vec<[u32; 2]>,
    /// One more than the largest point of `rows` (0 without rows): the kernel runs only on
    /// patches of at least that many points.
    points: usize,
    /// Every term's `width` values lie within `data` (checked once here, so that the
    /// kernel reads them without a bounds check per term).
    fits: bool,
}

impl DenseEdgeWeights {
    /// Lanes of the kernel's blocks (samples rounded up to whole blocks).
    fn lanes(&self) -> usize {
        self.ranges.len() * self.width
    }
}

thread_local! {
    /// The edge weights of the last call on this thread: a streaming caller (statistics)
    /// evaluates many small edge patterns of one kind and sample count.
    static EDGE_WEIGHTS: std::cell::RefCell<Option<std::rc::Rc<EdgeWeights>>> =
        const { std::cell::RefCell::new(None) };
}

impl EdgeWeights {
    /// [`EdgeWeights::new`], kept for the next call with the same kind, sample count and
    /// width (the weights depend on nothing else).
    pub(super) fn cached(
        table: &PatchTable,
        edges: &EdgePairs,
        width: usize,
    ) -> std::rc::Rc<EdgeWeights> {
        EDGE_WEIGHTS.with(|cell| {
            let mut cell = cell.borrow_mut();
            match &*cell {
                Some(w)
                    if w.kind == table.kind
                        && w.per == edges.samples as usize
                        && w.width == width =>
                {
                    w.clone()
                }
                _ => {
                    let w = std::rc::Rc::new(EdgeWeights::new(table, edges, width));
                    *cell = Some(w.clone());
                    w
                }
            }
        })
    }

    fn new(table: &PatchTable, edges: &EdgePairs, width: usize) -> EdgeWeights {
        let per = edges.samples as usize;
        let geometry = table.kind.geometry();
        let mut w = Vec::with_capacity(9 * per);
        let mut dense = Vec::with_capacity(9);
        for from in 0..3u8 {
            for to in 0..3u8 {
                let first = w.len();
                for i in 0..per as u32 {
                    // from == to never occurs (checked); its entries are unused filler.
                    let side = crate::eval::EdgeSide { patch: 0, from, to };
                    let b = if from == to {
                        [1.0, 0.0, 0.0]
                    } else {
                        edges.barycentric(side, i)
                    };
                    w.push(SparseWeights::new(table.kind.weights(b), geometry));
                }
                if width == 0 {
                    continue;
                }
                let blocks = per.div_ceil(width);
                let samples = &w[first..];
                let idx: Vec<u8> = (0..geometry as u8)
                    .filter(|&j| samples.iter().any(|s| s.terms().0.contains(&j)))
                    .collect();
                let mut data = vec![0.0; blocks * idx.len() * 3 * width];
                for (i, s) in samples.iter().enumerate() {
                    let (blk, l) = (i / width, i % width);
                    for (k, &j) in idx.iter().enumerate() {
                        let o = (blk * idx.len() + k) * 3 * width + l;
                        let j = j as usize;
                        let v = [s.full.w[j], s.full.ws[j], s.full.wt[j]];
                        for (c, &x) in v.iter().enumerate() {
                            data[o + c * width] = x;
                        }
                    }
                }
                // The padding terms' weights: `width` zeros after the blocks.
                let zeros = data.len() as u32;
                data.extend(std::iter::repeat_n(0.0, width));
                let mut rows = Vec::new();
                let mut ranges = Vec::with_capacity(blocks);
                for blk in 0..blocks {
                    let lists: [Vec<(u32, u8)>; 3] = std::array::from_fn(|c| {
                        let mut list = Vec::new();
                        for (k, &j) in idx.iter().enumerate() {
                            let o = (blk * idx.len() + k) * 3 * width + c * width;
                            if data[o..o + width].iter().any(|&x| x != 0.0) {
                                list.push((o as u32, j));
                            }
                        }
                        list
                    });
                    let start = rows.len() as u32;
                    let n = lists.iter().map(Vec::len).max().unwrap_or(0);
                    rows.extend((0..n).map(|i| {
                        std::array::from_fn(|c| lists[c].get(i).copied().unwrap_or((zeros, 0)))
                    }));
                    ranges.push([start, rows.len() as u32]);
                }
                let points = rows
                    .iter()
                    .flatten()
                    .map(|&(_, j)| j as usize + 1)
                    .max()
                    .unwrap_or(0);
                let fits = rows
                    .iter()
                    .flatten()
                    .all(|&(o, _)| o as usize + width <= data.len());
                dense.push(DenseEdgeWeights {
                    width,
                    data,
                    rows,
                    ranges,
                    points,
                    fits,
                });
            }
        }
        EdgeWeights {
            kind: table.kind,
            per,
            w,
            dense,
            width,
            min_len2: min_len2(),
        }
    }

    /// Evaluates one pair's 2 · per points into `p` and `n`; the ends are the input
    /// vertices as they are. `lanes` is scratch for the lane kernel.
    #[inline]
    pub(super) fn pair(
        &self,
        table: &PatchTable,
        pair: &[crate::eval::EdgeSide; 2],
        p: &mut [DVec3],
        n: &mut [DVec3],
        lanes: &mut Vec<f64>,
    ) {
        for (side, e) in pair.iter().enumerate() {
            let patch = e.patch as usize;
            let at = 3 * e.from as usize + e.to as usize;
            if self.side_lanes::<false>(table, e, lanes) {
                let l = self.dense[at].lanes();
                for i in 0..self.per {
                    let v = |k: usize| {
                        DVec3::new(
                            lanes[k * l + i],
                            lanes[(k + 1) * l + i],
                            lanes[(k + 2) * l + i],
                        )
                    };
                    p[2 * i + side] = v(0);
                    n[2 * i + side] = v(3);
                }
            } else {
                let w = &self.w[at * self.per..(at + 1) * self.per];
                for (i, w) in w.iter().enumerate() {
                    let sp = table.eval_sparse(patch, w);
                    p[2 * i + side] = sp.p;
                    n[2 * i + side] = sp.n;
                }
            }
            p[side] = table.corner(patch, e.from as usize);
            if self.per > 1 {
                p[2 * (self.per - 1) + side] = table.corner(patch, e.to as usize);
            }
        }
    }

    /// The lane kernel on side `e` into `lanes` (resized), where it runs and its values
    /// are those of the sparse evaluation: the dense kernel adds the terms a sample's
    /// sparse list skips, ±0 on a finite point, which leaves every sum bitwise as it is
    /// (see `SparseWeights`); it says whether every sum came out finite, and then every
    /// point it multiplied was finite (a product with a non-finite point is ±∞ or NaN, and
    /// a sum that takes one stays non-finite). `false`: evaluate the side sparsely. `RAW`:
    /// the products mode (see [`edge_side`]).
    #[inline]
    fn side_lanes<const RAW: bool>(
        &self,
        table: &PatchTable,
        e: &crate::eval::EdgeSide,
        lanes: &mut Vec<f64>,
    ) -> bool {
        #[cfg(target_arch = "x86_64")]
        if self.width > 0 && table.kind.geometry() == table.stride {
            let d = &self.dense[3 * e.from as usize + e.to as usize];
            lanes.resize(if RAW { 7 } else { 6 } * d.lanes(), 0.0);
            let (patch, min) = (e.patch as usize, self.min_len2);
            // SAFETY: `width` is 8 only where the CPU has AVX-512F, else 4 only where it
            // has AVX (EdgeKernel::lanes).
            return unsafe {
                if self.width == 8 {
                    edge_side_avx512::<RAW>(table, patch, d, lanes, min)
                } else {
                    edge_side_avx::<RAW>(table, patch, d, lanes, min)
                }
            };
        }
        let _ = (table, e, lanes);
        false
    }

    /// The products of one pair's samples into `out` (`per` of them): both sides by the
    /// lane kernel in its products mode and the products lane by lane ([`products`]), or
    /// where a side cannot take the lane kernel, the points by [`Self::pair`] and
    /// [`PairProducts::of`]. `scratch` holds the lanes of both sides and the points.
    #[inline]
    pub(super) fn pair_products(
        &self,
        table: &PatchTable,
        pair: &[crate::eval::EdgeSide; 2],
        out: &mut [PairProducts],
        scratch: &mut PairScratch,
    ) {
        #[cfg(target_arch = "x86_64")]
        if self.side_lanes::<true>(table, &pair[0], &mut scratch.a)
            && self.side_lanes::<true>(table, &pair[1], &mut scratch.b)
        {
            let l = self.dense[3 * pair[0].from as usize + pair[0].to as usize].lanes();
            // The ends: the input vertices as they are.
            for (e, v) in pair.iter().zip([&mut scratch.a, &mut scratch.b]) {
                let patch = e.patch as usize;
                let mut set = |i: usize, q: DVec3| {
                    v[i] = q.x;
                    v[l + i] = q.y;
                    v[2 * l + i] = q.z;
                };
                set(0, table.corner(patch, e.from as usize));
                if self.per > 1 {
                    set(self.per - 1, table.corner(patch, e.to as usize));
                }
            }
            // SAFETY: `side_lanes` ran the lane kernel of this width, so the CPU has its
            // instruction set.
            unsafe {
                if self.width == 8 {
                    products_avx512(&scratch.a, &scratch.b, l, out)
                } else {
                    products_avx(&scratch.a, &scratch.b, l, out)
                }
            };
            return;
        }
        let (p, n) = (&mut scratch.p, &mut scratch.n);
        p.resize(2 * self.per, DVec3::ZERO);
        n.resize(2 * self.per, DVec3::ZERO);
        self.pair(table, pair, p, n, &mut scratch.a);
        for (k, o) in out.iter_mut().enumerate() {
            *o = PairProducts::of([p[2 * k], p[2 * k + 1]], [n[2 * k], n[2 * k + 1]]);
        }
    }
}

/// Per-job buffers of [`EdgeWeights::pair_products`].
// Some fields are read only by the x86-64 lane kernels.
#[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
#[derive(Default)]
pub(super) struct PairScratch {
    a: Vec<f64>,
    b: Vec<f64>,
    p: Vec<DVec3>,
    n: Vec<DVec3>,
}

/// The few f64 vector operations of the edge kernel, each lane by lane as the scalar
/// operation (no fused operations), so that every lane width gives bitwise the same values.
#[cfg(target_arch = "x86_64")]
trait F64Lanes: Copy {
    /// Lanes per register.
    const N: usize;
    type Mask: Copy;
    fn zero() -> Self;
    fn splat(x: f64) -> Self;
    /// The first `N` values of `s`.
    fn load(s: &[f64]) -> Self;
    /// The `N` values from `p`.
    ///
    /// # Safety
    /// `p` points to `N` readable f64 values.
    unsafe fn load_ptr(p: *const f64) -> Self;
    /// Into the first `N` values of `s`.
    fn store(self, s: &mut [f64]);
    fn add(self, o: Self) -> Self;
    fn sub(self, o: Self) -> Self;
    fn mul(self, o: Self) -> Self;
    fn div(self, o: Self) -> Self;
    fn sqrt(self) -> Self;
    /// Ordered comparisons (false where either side is NaN).
    fn gt(self, o: Self) -> Self::Mask;
    fn lt(self, o: Self) -> Self::Mask;
    fn ge(self, o: Self) -> Self::Mask;
    fn le(self, o: Self) -> Self::Mask;
    fn and(a: Self::Mask, b: Self::Mask) -> Self::Mask;
    /// Every lane of `m` is set.
    fn all(m: Self::Mask) -> bool;
    /// `a` where `m` is set, else `b`.
    fn select(m: Self::Mask, a: Self, b: Self) -> Self;
    /// Some lane is NaN.
    fn any_nan(self) -> bool;
}

/// AVX registers, 4 lanes (used only after runtime detection).
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
struct Avx4(std::arch::x86_64::__m256d);

// SAFETY (every method of Avx4): only reached from functions compiled with AVX enabled
// (`edge_side_avx`, `products_avx`), called where the CPU has it; loads and stores touch
// the first four values of slices checked to hold them.
#[cfg(target_arch = "x86_64")]
impl F64Lanes for Avx4 {
    const N: usize = 4;
    type Mask = std::arch::x86_64::__m256d;
    #[inline(always)]
    fn zero() -> Self {
        unsafe { Avx4(std::arch::x86_64::_mm256_setzero_pd()) }
    }
    #[inline(always)]
    fn splat(x: f64) -> Self {
        unsafe { Avx4(std::arch::x86_64::_mm256_set1_pd(x)) }
    }
    #[inline(always)]
    fn load(s: &[f64]) -> Self {
        let s = &s[..4];
        unsafe { Avx4(std::arch::x86_64::_mm256_loadu_pd(s.as_ptr())) }
    }
    #[inline(always)]
    unsafe fn load_ptr(p: *const f64) -> Self {
        unsafe { Avx4(std::arch::x86_64::_mm256_loadu_pd(p)) }
    }
    #[inline(always)]
    fn store(self, s: &mut [f64]) {
        let s = &mut s[..4];
        unsafe { std::arch::x86_64::_mm256_storeu_pd(s.as_mut_ptr(), self.0) }
    }
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        unsafe { Avx4(std::arch::x86_64::_mm256_add_pd(self.0, o.0)) }
    }
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        unsafe { Avx4(std::arch::x86_64::_mm256_sub_pd(self.0, o.0)) }
    }
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        unsafe { Avx4(std::arch::x86_64::_mm256_mul_pd(self.0, o.0)) }
    }
    #[inline(always)]
    fn div(self, o: Self) -> Self {
        unsafe { Avx4(std::arch::x86_64::_mm256_div_pd(self.0, o.0)) }
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        unsafe { Avx4(std::arch::x86_64::_mm256_sqrt_pd(self.0)) }
    }
    #[inline(always)]
    fn gt(self, o: Self) -> Self::Mask {
        use std::arch::x86_64::*;
        unsafe { _mm256_cmp_pd::<_CMP_GT_OQ>(self.0, o.0) }
    }
    #[inline(always)]
    fn lt(self, o: Self) -> Self::Mask {
        use std::arch::x86_64::*;
        unsafe { _mm256_cmp_pd::<_CMP_LT_OQ>(self.0, o.0) }
    }
    #[inline(always)]
    fn ge(self, o: Self) -> Self::Mask {
        use std::arch::x86_64::*;
        unsafe { _mm256_cmp_pd::<_CMP_GE_OQ>(self.0, o.0) }
    }
    #[inline(always)]
    fn le(self, o: Self) -> Self::Mask {
        use std::arch::x86_64::*;
        unsafe { _mm256_cmp_pd::<_CMP_LE_OQ>(self.0, o.0) }
    }
    #[inline(always)]
    fn and(a: Self::Mask, b: Self::Mask) -> Self::Mask {
        unsafe { std::arch::x86_64::_mm256_and_pd(a, b) }
    }
    #[inline(always)]
    fn all(m: Self::Mask) -> bool {
        unsafe { std::arch::x86_64::_mm256_movemask_pd(m) == 0b1111 }
    }
    #[inline(always)]
    fn select(m: Self::Mask, a: Self, b: Self) -> Self {
        unsafe { Avx4(std::arch::x86_64::_mm256_blendv_pd(b.0, a.0, m)) }
    }
    #[inline(always)]
    fn any_nan(self) -> bool {
        use std::arch::x86_64::*;
        unsafe { _mm256_movemask_pd(_mm256_cmp_pd::<_CMP_UNORD_Q>(self.0, self.0)) != 0 }
    }
}

/// AVX-512F registers, 8 lanes (used only after runtime detection).
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
struct Avx8(std::arch::x86_64::__m512d);

// SAFETY (every method of Avx8): only reached from functions compiled with AVX-512F
// enabled (`edge_side_avx512`, `products_avx512`), called where the CPU has it; loads and
// stores touch the first eight values of slices checked to hold them.
#[cfg(target_arch = "x86_64")]
impl F64Lanes for Avx8 {
    const N: usize = 8;
    type Mask = std::arch::x86_64::__mmask8;
    #[inline(always)]
    fn zero() -> Self {
        unsafe { Avx8(std::arch::x86_64::_mm512_setzero_pd()) }
    }
    #[inline(always)]
    fn splat(x: f64) -> Self {
        unsafe { Avx8(std::arch::x86_64::_mm512_set1_pd(x)) }
    }
    #[inline(always)]
    fn load(s: &[f64]) -> Self {
        let s = &s[..8];
        unsafe { Avx8(std::arch::x86_64::_mm512_loadu_pd(s.as_ptr())) }
    }
    #[inline(always)]
    unsafe fn load_ptr(p: *const f64) -> Self {
        unsafe { Avx8(std::arch::x86_64::_mm512_loadu_pd(p)) }
    }
    #[inline(always)]
    fn store(self, s: &mut [f64]) {
        let s = &mut s[..8];
        unsafe { std::arch::x86_64::_mm512_storeu_pd(s.as_mut_ptr(), self.0) }
    }
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        unsafe { Avx8(std::arch::x86_64::_mm512_add_pd(self.0, o.0)) }
    }
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        unsafe { Avx8(std::arch::x86_64::_mm512_sub_pd(self.0, o.0)) }
    }
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        unsafe { Avx8(std::arch::x86_64::_mm512_mul_pd(self.0, o.0)) }
    }
    #[inline(always)]
    fn div(self, o: Self) -> Self {
        unsafe { Avx8(std::arch::x86_64::_mm512_div_pd(self.0, o.0)) }
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        unsafe { Avx8(std::arch::x86_64::_mm512_sqrt_pd(self.0)) }
    }
    #[inline(always)]
    fn gt(self, o: Self) -> Self::Mask {
        use std::arch::x86_64::*;
        unsafe { _mm512_cmp_pd_mask::<_CMP_GT_OQ>(self.0, o.0) }
    }
    #[inline(always)]
    fn lt(self, o: Self) -> Self::Mask {
        use std::arch::x86_64::*;
        unsafe { _mm512_cmp_pd_mask::<_CMP_LT_OQ>(self.0, o.0) }
    }
    #[inline(always)]
    fn ge(self, o: Self) -> Self::Mask {
        use std::arch::x86_64::*;
        unsafe { _mm512_cmp_pd_mask::<_CMP_GE_OQ>(self.0, o.0) }
    }
    #[inline(always)]
    fn le(self, o: Self) -> Self::Mask {
        use std::arch::x86_64::*;
        unsafe { _mm512_cmp_pd_mask::<_CMP_LE_OQ>(self.0, o.0) }
    }
    #[inline(always)]
    fn and(a: Self::Mask, b: Self::Mask) -> Self::Mask {
        a & b
    }
    #[inline(always)]
    fn all(m: Self::Mask) -> bool {
        m == 0xff
    }
    #[inline(always)]
    fn select(m: Self::Mask, a: Self, b: Self) -> Self {
        // mask_blend takes its second vector where the mask is set.
        unsafe { Avx8(std::arch::x86_64::_mm512_mask_blend_pd(m, b.0, a.0)) }
    }
    #[inline(always)]
    fn any_nan(self) -> bool {
        use std::arch::x86_64::*;
        unsafe { _mm512_cmp_pd_mask::<_CMP_UNORD_Q>(self.0, self.0) != 0 }
    }
}

/// One side of an edge (patch `patch`, every geometry point finite, no normal field),
/// `V::N` samples per register, each sum the same products added in the same order as
/// [`PatchTable::eval_sparse`] and the normal computed as [`crate::patch::unit_normal`]
/// does (cross product, dot, sqrt, division, each lane by lane, no fused operations, the
/// flat normal where the length is not above [`crate::patch::MIN_NORMAL_LEN_F64`] or not
/// finite), so bitwise its values where every point it multiplies is finite. Writes lanes:
/// `out[k · L + i]` for sample i (L = `d.lanes()`) is its position's x, y, z for k = 0, 1,
/// 2 and its unit normal's for k = 3, 4, 5. `RAW` (the products mode): rows 3, 4, 5 are
/// the cross product S_s × S_t itself and row 6 its squared length as `unit_normal` sums
/// it, where that normal is used (squared length above `min_len2`, see [`min_len2`], and
/// finite), else the flat normal and 1. Returns whether every sum (all lanes, padding
/// included) was finite, which holds only where every point it multiplied was.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn edge_side<V: F64Lanes, const RAW: bool>(
    table: &PatchTable,
    patch: usize,
    d: &DenseEdgeWeights,
    out: &mut [f64],
    min_len2: f64,
) -> bool {
    let lanes = d.lanes();
    let out = &mut out[..if RAW { 7 } else { 6 } * lanes];
    // x − x summed over the sums of every block: +0 while all are finite, NaN from the
    // first sum that is ±∞ or NaN on.
    let mut nonfinite = V::zero();
    let c = table.patch(patch);
    if !d.fits || d.width != V::N || d.points > c.len() {
        // Never on weights built for this table's kind (checked here once per side, so
        // that the terms are read unchecked): the sparse evaluation takes the side.
        return false;
    }
    let flat = table.flat_normals[patch];
    let (fx, fy, fz) = (V::splat(flat.x), V::splat(flat.y), V::splat(flat.z));
    let inf = V::splat(f64::INFINITY);
    let min = V::splat(if RAW {
        min_len2
    } else {
        crate::patch::MIN_NORMAL_LEN_F64
    });
    // (No closures here: a closure is a function of its own, without the caller's target
    // features, and would call every intrinsic out of line.)
    for (blk, r) in d.ranges.iter().enumerate() {
        let z = V::zero();
        let mut acc = [[z; 3]; 3];
        // SAFETY: every term's point is below `d.points` ≤ `c.len()` and its `V::N` =
        // `d.width` values lie within `d.data` (`d.fits`), both checked above.
        unsafe { add_rows(&d.rows[r[0] as usize..r[1] as usize], c, &d.data, &mut acc) };
        let [[px, py, pz], [sx, sy, sz], [tx, ty, tz]] = acc;
        let all = (px.add(py).add(pz.add(sx))).add(sy.add(sz).add(tx.add(ty).add(tz)));
        nonfinite = nonfinite.add(all.sub(all));
        // S_s × S_t as DVec3::cross, its squared length as DVec3::length.
        let nx = sy.mul(tz).sub(ty.mul(sz));
        let ny = sz.mul(tx).sub(tz.mul(sx));
        let nz = sx.mul(ty).sub(tx.mul(sy));
        let dot = nx.mul(nx).add(ny.mul(ny)).add(nz.mul(nz));
        let at = blk * V::N;
        px.store(&mut out[at..]);
        py.store(&mut out[lanes + at..]);
        pz.store(&mut out[2 * lanes + at..]);
        let normal = if RAW {
            // dot > min_len2 exactly where sqrt(dot) > MIN; dot < ∞ where sqrt(dot) < ∞
            // (both false on NaN).
            let ok = V::and(dot.gt(min), dot.lt(inf));
            V::select(ok, dot, V::splat(1.0)).store(&mut out[6 * lanes + at..]);
            [
                V::select(ok, nx, fx),
                V::select(ok, ny, fy),
                V::select(ok, nz, fz),
            ]
        } else {
            let len = dot.sqrt();
            // len > MIN and len < ∞, both false on NaN: `len.is_finite()` for len ≥ 0.
            let ok = V::and(len.gt(min), len.lt(inf));
            [
                V::select(ok, nx.div(len), fx),
                V::select(ok, ny.div(len), fy),
                V::select(ok, nz.div(len), fz),
            ]
        };
        normal[0].store(&mut out[3 * lanes + at..]);
        normal[1].store(&mut out[4 * lanes + at..]);
        normal[2].store(&mut out[5 * lanes + at..]);
    }
    !nonfinite.any_nan()
}

/// Adds w · c_j for term c (offset of w in `data`, j) of each row of `rows` to the three
/// sums `acc[c]`, in order. Reads without bounds checks (about a third of the
/// instructions of a term were the checks).
///
/// # Safety
/// Every term has j < `c.len()` and `o + V::N ≤ data.len()`.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn add_rows<V: F64Lanes>(
    rows: &[[(u32, u8); 3]],
    c: &[DVec3],
    data: &[f64],
    acc: &mut [[V; 3]; 3],
) {
    let (cp, dp) = (c.as_ptr(), data.as_ptr());
    for row in rows {
        for (a, &(o, j)) in acc.iter_mut().zip(row) {
            // SAFETY: in bounds by the caller's guarantee.
            let (cj, w) = unsafe { (*cp.add(j as usize), V::load_ptr(dp.add(o as usize))) };
            a[0] = a[0].add(w.mul(V::splat(cj.x)));
            a[1] = a[1].add(w.mul(V::splat(cj.y)));
            a[2] = a[2].add(w.mul(V::splat(cj.z)));
        }
    }
}

/// The seven rows of the products mode at lane `at` of `v` (rows of `lanes` values).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn rows7<V: F64Lanes>(v: &[f64], lanes: usize, at: usize) -> [V; 7] {
    let mut r = [V::zero(); 7];
    for (k, x) in r.iter_mut().enumerate() {
        *x = V::load(&v[k * lanes + at..]);
    }
    r
}

/// The products of one pair's samples from both sides' lanes (`a`, `b` as [`edge_side`]
/// writes them in its products mode, corner positions already set), `per` samples:
/// gap² as [`PairProducts::of`] (the same operations in the same order, bitwise), and cos
/// from the two cross products c_a, c_b and their squared lengths d_a, d_b as
/// `(c_a · c_b) / sqrt(d_a · d_b)`: one square root and one division per sample where
/// the unit normals take two and six. Where `d_a · d_b` is not a normal finite number
/// (cross products shorter than about 1e-77 or longer than 1e77) the block takes the unit
/// normals `c / sqrt(d)`, exactly those of the points, and their dot product: bitwise
/// [`PairProducts::of`].
///
/// Error of the quotient (u = 2⁻⁵³, c_a, c_b the computed cross products, ĉ = c/|c|):
/// the unit normals' route gives |c| to 2.5u (3u in the squared length, halved, and the
/// sqrt's u), each component of c/|c| to 3.5u and their dot product to 3u more, so
/// |cos_points − ĉ_a · ĉ_b| ≤ 10u (Σ|ĉ_aj ĉ_bj| ≤ 1); the quotient has 3u · |c_a||c_b|
/// in the dot product, 7u in d_a · d_b, 4.5u after its sqrt and u in the division, so
/// |cos − ĉ_a · ĉ_b| ≤ 8.5u. Hence |cos − cos_points| ≤ 18.5u + O(u²) < 20u ≈ 2.2e-15;
/// a flat normal f (a unit vector to a few u, taken with d = 1) adds its own rounding.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn products<V: F64Lanes>(a: &[f64], b: &[f64], lanes: usize, out: &mut [PairProducts]) {
    let per = out.len();
    let (a, b) = (&a[..7 * lanes], &b[..7 * lanes]);
    let (tiny, huge) = (V::splat(f64::MIN_POSITIVE), V::splat(f64::MAX));
    let (mut c, mut g) = ([0.0f64; 8], [0.0f64; 8]);
    for at in (0..per).step_by(V::N) {
        let [apx, apy, apz, acx, acy, acz, ad] = rows7::<V>(a, lanes, at);
        let [bpx, bpy, bpz, bcx, bcy, bcz, bd] = rows7::<V>(b, lanes, at);
        // |p0 − p1|² as DVec3::length_squared: (x x + y y) + z z.
        let (dx, dy, dz) = (apx.sub(bpx), apy.sub(bpy), apz.sub(bpz));
        let gap2 = dx.mul(dx).add(dy.mul(dy)).add(dz.mul(dz));
        let q = ad.mul(bd);
        let cos = if V::all(V::and(q.ge(tiny), q.le(huge))) {
            let dot = acx.mul(bcx).add(acy.mul(bcy)).add(acz.mul(bcz));
            dot.div(q.sqrt())
        } else {
            // The unit normals, as `edge_side` computes them outside the products mode
            // (the flat normal f with d = 1 gives f / 1 = f), and n0 · n1 as DVec3::dot.
            let (la, lb) = (ad.sqrt(), bd.sqrt());
            let (ax, ay, az) = (acx.div(la), acy.div(la), acz.div(la));
            let (bx, by, bz) = (bcx.div(lb), bcy.div(lb), bcz.div(lb));
            ax.mul(bx).add(ay.mul(by)).add(az.mul(bz))
        };
        cos.store(&mut c);
        gap2.store(&mut g);
        for (l, o) in out[at..(at + V::N).min(per)].iter_mut().enumerate() {
            *o = PairProducts {
                cos: c[l],
                gap2: g[l],
            };
        }
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
fn edge_side_avx<const RAW: bool>(
    table: &PatchTable,
    patch: usize,
    d: &DenseEdgeWeights,
    out: &mut [f64],
    min_len2: f64,
) -> bool {
    edge_side::<Avx4, RAW>(table, patch, d, out, min_len2)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn edge_side_avx512<const RAW: bool>(
    table: &PatchTable,
    patch: usize,
    d: &DenseEdgeWeights,
    out: &mut [f64],
    min_len2: f64,
) -> bool {
    edge_side::<Avx8, RAW>(table, patch, d, out, min_len2)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
fn products_avx(a: &[f64], b: &[f64], lanes: usize, out: &mut [PairProducts]) {
    products::<Avx4>(a, b, lanes, out)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn products_avx512(a: &[f64], b: &[f64], lanes: usize, out: &mut [PairProducts]) {
    products::<Avx8>(a, b, lanes, out)
}

#[cfg(test)]
mod tests {
    use super::min_len2;

    /// `min_len2` is the exact threshold: its root is not above the minimum length, the
    /// next f64's is.
    #[test]
    fn min_len2_is_the_square_root_threshold() {
        let (t, m) = (min_len2(), crate::patch::MIN_NORMAL_LEN_F64);
        let next = f64::from_bits(t.to_bits() + 1);
        assert!(t > 0.0 && t.sqrt() <= m && next.sqrt() > m, "{t:e}");
    }
}
