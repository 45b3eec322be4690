//! The f32 grid kernel ([`Evaluator::evaluate_f32`] on a grid): f32 weights in blocks of
//! 8 samples (16 for AVX-512F), AVX-512F or AVX2+FMA detected at run time or portable
//! code, control points relative to each patch's first point, corners overwritten with the
//! input vertices rounded once. Every lane of the AVX-512F and AVX2 kernels runs the same
//! operations in the same order (the same fused multiply-adds), so both give bitwise the
//! same samples.
//!
//! Chunks are small enough to stay in the caches ([`PIPELINE_SAMPLES`]), and the kernel
//! fills the next chunk on the thread pool while the sink reads the current one.

use std::sync::{Mutex, PoisonError};

use rayon::prelude::*;

use super::CpuEvaluator;
#[cfg(doc)] // links in the documentation
use crate::eval::Evaluator;
use crate::eval::{grid_barycentrics, grid_corners, stage_samples, Chunk, ChunkF32};
use crate::patch::{PatchBuilder, PatchKind, PatchTable};
use crate::Result;

/// Samples per SIMD block of the AVX2 and portable kernels.
const LANES: usize = 8;
/// Samples per SIMD block of the AVX-512F kernel.
const LANES16: usize = 16;

/// Most samples in one chunk of [`CpuEvaluator::grid_f32`] (fewer where `chunk_samples`
/// asks; one patch at least): two chunks of positions and normals (1.5 MiB each), the
/// one the sink reads and the one the kernel fills meanwhile, stay in the cores' caches.
pub const PIPELINE_SAMPLES: usize = 1 << 16;

/// Basis values of a grid level in f32, laid out for the fast path: for each block of
/// `width` samples and each control point, `width` values of w, ∂w/∂s, ∂w/∂t (padding
/// samples have weight 0), `width` 16 where the CPU has AVX-512F (the 8-lane kernels take
/// each block in two halves), else `LANES`.
#[derive(Clone, Debug)]
pub struct GridWeightsF32 {
    /// The patch kind the weights are for.
    pub kind: crate::patch::PatchKind,
    /// The grid level.
    pub level: u32,
    /// Samples per patch.
    pub per: usize,
    /// Blocks of `width` samples per patch.
    pub blocks: usize,
    /// Leading control points that are geometry.
    pub geometry: usize,
    /// Control points per patch.
    pub stride: usize,
    data: Vec<f32>,
    /// Samples per block: [`LANES16`] or [`LANES`].
    width: usize,
}

/// The weights of every sample `b` of a grid in blocks of `lanes` samples.
fn weight_blocks(kind: crate::patch::PatchKind, b: &[[f64; 3]], lanes: usize) -> Vec<f32> {
    let stride = kind.stride();
    let blocks = b.len().div_ceil(lanes);
    let mut data = vec![0f32; blocks * stride * 3 * lanes];
    for (s, b) in b.iter().enumerate() {
        let w = kind.weights(*b);
        let (blk, l) = (s / lanes, s % lanes);
        for j in 0..stride {
            let o = ((blk * stride + j) * 3) * lanes + l;
            data[o] = w.w[j] as f32;
            data[o + lanes] = w.ws[j] as f32;
            data[o + 2 * lanes] = w.wt[j] as f32;
        }
    }
    data
}

impl GridWeightsF32 {
    /// The weights of `kind` on the grid of `level` (computed in f64, rounded once).
    pub fn new(kind: crate::patch::PatchKind, level: u32) -> GridWeightsF32 {
        let level = level.max(1);
        let b = grid_barycentrics(level);
        let per = b.len();
        let width = if cpu_has!("avx512f") { LANES16 } else { LANES };
        GridWeightsF32 {
            kind,
            level,
            per,
            blocks: per.div_ceil(width),
            geometry: kind.geometry(),
            stride: kind.stride(),
            data: weight_blocks(kind, &b, width),
            width,
        }
    }
}

type Lanes = [f32; LANES];

/// The few vector operations of the fast path, on `N` f32 lanes, each lane by lane the
/// scalar operation (`madd` one fused multiply-add on the vector kernels).
trait Simd<const N: usize>: Copy {
    fn zero() -> Self;
    fn load(w: &[f32; N]) -> Self;
    fn splat(x: f32) -> Self;
    /// self + w · c.
    fn madd(self, w: Self, c: Self) -> Self;
    fn mul(self, o: Self) -> Self;
    fn sub(self, o: Self) -> Self;
    fn sqrt(self) -> Self;
    fn recip(self) -> Self;
    fn add(self, o: Self) -> Self;
    /// `a` where `len` is a usable length (neither tiny nor infinite nor NaN), else `b`.
    fn select_usable(len: Self, a: Self, b: Self) -> Self;
    fn store(self) -> [f32; N];
    /// Writes sample l of (x, y, z) to `out[l]`.
    #[inline(always)]
    fn interleave(x: Self, y: Self, z: Self, out: &mut [[f32; 3]; N]) {
        let [x, y, z] = [x.store(), y.store(), z.store()];
        for (l, o) in out.iter_mut().enumerate() {
            *o = [x[l], y[l], z[l]];
        }
    }
}

/// Whether a normal of length `len` is usable (neither tiny nor infinite nor NaN).
#[inline(always)]
fn usable(len: f32) -> bool {
    len > crate::patch::MIN_NORMAL_LEN_F32 && len < f32::INFINITY
}

/// Plain arrays (any CPU; the compiler vectorises what it can).
#[derive(Clone, Copy)]
struct Portable(Lanes);

impl Simd<LANES> for Portable {
    #[inline(always)]
    fn zero() -> Self {
        Portable([0.0; LANES])
    }
    #[inline(always)]
    fn load(w: &Lanes) -> Self {
        Portable(*w)
    }
    #[inline(always)]
    fn splat(x: f32) -> Self {
        Portable([x; LANES])
    }
    #[inline(always)]
    fn madd(self, w: Self, c: Self) -> Self {
        Portable(std::array::from_fn(|l| w.0[l] * c.0[l] + self.0[l]))
    }
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        Portable(std::array::from_fn(|l| self.0[l] * o.0[l]))
    }
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        Portable(std::array::from_fn(|l| self.0[l] - o.0[l]))
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        Portable(self.0.map(f32::sqrt))
    }
    #[inline(always)]
    fn recip(self) -> Self {
        Portable(self.0.map(|x| 1.0 / x))
    }
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        Portable(std::array::from_fn(|l| self.0[l] + o.0[l]))
    }
    #[inline(always)]
    fn select_usable(len: Self, a: Self, b: Self) -> Self {
        Portable(std::array::from_fn(|l| {
            if usable(len.0[l]) {
                a.0[l]
            } else {
                b.0[l]
            }
        }))
    }
    #[inline(always)]
    fn store(self) -> Lanes {
        self.0
    }
}

/// AVX2 + FMA registers (used only after runtime detection).
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
struct Avx2(std::arch::x86_64::__m256);

#[cfg(target_arch = "x86_64")]
impl Simd<LANES> for Avx2 {
    #[inline(always)]
    fn zero() -> Self {
        // SAFETY (all methods): only reached from `patch_f32_avx2`, compiled for and
        // called on CPUs with AVX2 and FMA; loads and stores take whole arrays of 8.
        unsafe { Avx2(std::arch::x86_64::_mm256_setzero_ps()) }
    }
    #[inline(always)]
    fn load(w: &Lanes) -> Self {
        unsafe { Avx2(std::arch::x86_64::_mm256_loadu_ps(w.as_ptr())) }
    }
    #[inline(always)]
    fn splat(x: f32) -> Self {
        unsafe { Avx2(std::arch::x86_64::_mm256_set1_ps(x)) }
    }
    #[inline(always)]
    fn madd(self, w: Self, c: Self) -> Self {
        unsafe { Avx2(std::arch::x86_64::_mm256_fmadd_ps(w.0, c.0, self.0)) }
    }
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        unsafe { Avx2(std::arch::x86_64::_mm256_mul_ps(self.0, o.0)) }
    }
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        unsafe { Avx2(std::arch::x86_64::_mm256_sub_ps(self.0, o.0)) }
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        unsafe { Avx2(std::arch::x86_64::_mm256_sqrt_ps(self.0)) }
    }
    #[inline(always)]
    fn recip(self) -> Self {
        unsafe {
            use std::arch::x86_64::*;
            Avx2(_mm256_div_ps(_mm256_set1_ps(1.0), self.0))
        }
    }
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        unsafe { Avx2(std::arch::x86_64::_mm256_add_ps(self.0, o.0)) }
    }
    #[inline(always)]
    fn select_usable(len: Self, a: Self, b: Self) -> Self {
        unsafe {
            use std::arch::x86_64::*;
            // Ordered comparisons: false where len is NaN.
            let big = _mm256_cmp_ps::<_CMP_GT_OQ>(
                len.0,
                _mm256_set1_ps(crate::patch::MIN_NORMAL_LEN_F32),
            );
            let finite = _mm256_cmp_ps::<_CMP_LT_OQ>(len.0, _mm256_set1_ps(f32::INFINITY));
            Avx2(_mm256_blendv_ps(b.0, a.0, _mm256_and_ps(big, finite)))
        }
    }
    #[inline(always)]
    fn store(self) -> Lanes {
        let mut out = [0f32; LANES];
        unsafe { std::arch::x86_64::_mm256_storeu_ps(out.as_mut_ptr(), self.0) };
        out
    }
}

/// AVX-512F registers, 16 lanes (used only after runtime detection).
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
struct Avx512(std::arch::x86_64::__m512);

#[cfg(target_arch = "x86_64")]
impl Simd<LANES16> for Avx512 {
    #[inline(always)]
    fn zero() -> Self {
        // SAFETY (all methods): only reached from `patch_f32_avx512`, compiled for and
        // called on CPUs with AVX-512F; loads and stores take whole arrays of 16.
        unsafe { Avx512(std::arch::x86_64::_mm512_setzero_ps()) }
    }
    #[inline(always)]
    fn load(w: &[f32; LANES16]) -> Self {
        unsafe { Avx512(std::arch::x86_64::_mm512_loadu_ps(w.as_ptr())) }
    }
    #[inline(always)]
    fn splat(x: f32) -> Self {
        unsafe { Avx512(std::arch::x86_64::_mm512_set1_ps(x)) }
    }
    #[inline(always)]
    fn madd(self, w: Self, c: Self) -> Self {
        unsafe { Avx512(std::arch::x86_64::_mm512_fmadd_ps(w.0, c.0, self.0)) }
    }
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        unsafe { Avx512(std::arch::x86_64::_mm512_mul_ps(self.0, o.0)) }
    }
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        unsafe { Avx512(std::arch::x86_64::_mm512_sub_ps(self.0, o.0)) }
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        unsafe { Avx512(std::arch::x86_64::_mm512_sqrt_ps(self.0)) }
    }
    #[inline(always)]
    fn recip(self) -> Self {
        unsafe {
            use std::arch::x86_64::*;
            Avx512(_mm512_div_ps(_mm512_set1_ps(1.0), self.0))
        }
    }
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        unsafe { Avx512(std::arch::x86_64::_mm512_add_ps(self.0, o.0)) }
    }
    #[inline(always)]
    fn select_usable(len: Self, a: Self, b: Self) -> Self {
        unsafe {
            use std::arch::x86_64::*;
            // Ordered comparisons: false where len is NaN.
            let big = _mm512_cmp_ps_mask::<_CMP_GT_OQ>(
                len.0,
                _mm512_set1_ps(crate::patch::MIN_NORMAL_LEN_F32),
            );
            let finite = _mm512_cmp_ps_mask::<_CMP_LT_OQ>(len.0, _mm512_set1_ps(f32::INFINITY));
            Avx512(_mm512_mask_blend_ps(big & finite, b.0, a.0))
        }
    }
    /// Two two-source permutations per 16 output values: (x, y) then z.
    #[inline(always)]
    fn interleave(x: Self, y: Self, z: Self, out: &mut [[f32; 3]; LANES16]) {
        let out: &mut [f32; 3 * LANES16] = bytemuck::cast_mut(out);
        for (r, o) in out.chunks_exact_mut(LANES16).enumerate() {
            unsafe {
                use std::arch::x86_64::*;
                let xy = _mm512_loadu_epi32(INTERLEAVE[r][0].as_ptr());
                let with_z = _mm512_loadu_epi32(INTERLEAVE[r][1].as_ptr());
                let t = _mm512_permutex2var_ps(x.0, xy, y.0);
                _mm512_storeu_ps(o.as_mut_ptr(), _mm512_permutex2var_ps(t, with_z, z.0));
            }
        }
    }
    #[inline(always)]
    fn store(self) -> [f32; LANES16] {
        let mut out = [0f32; LANES16];
        unsafe { std::arch::x86_64::_mm512_storeu_ps(out.as_mut_ptr(), self.0) };
        out
    }
}

/// Indices of [`Avx512::interleave`]: for each third r of the output (values f = 16r + e,
/// sample f / 3, coordinate f % 3), where x and y are taken from (x: s, y: 16 + s), then
/// where z is (16 + s) and which values stay (e).
#[cfg(target_arch = "x86_64")]
const INTERLEAVE: [[[i32; LANES16]; 2]; 3] = {
    let mut idx = [[[0i32; LANES16]; 2]; 3];
    let mut r = 0;
    while r < 3 {
        let mut e = 0;
        while e < LANES16 {
            let f = LANES16 * r + e;
            let (s, c) = ((f / 3) as i32, f % 3);
            idx[r][0][e] = match c {
                0 => s,
                1 => LANES16 as i32 + s,
                _ => 0,
            };
            idx[r][1][e] = if c == 2 { LANES16 as i32 + s } else { e as i32 };
            e += 1;
        }
        r += 1;
    }
    idx
};

/// Evaluates one patch: `cp` its control points relative to `origin` (geometry) or as
/// they are (normal field), `flat` its fallback normal.
#[inline(always)]
fn patch_f32<const N: usize, S: Simd<N>>(
    g: &GridWeightsF32,
    cp: &[[f32; 3]],
    origin: [f32; 3],
    flat: [f32; 3],
    pos: &mut [[f32; 3]],
    nrm: &mut [[f32; 3]],
) {
    let (geometry, field) = cp.split_at(g.geometry);
    let lanes = |w: &[f32]| -> S { S::load(w[..N].try_into().unwrap()) };
    // Blocks of `m` samples, each taken in `m / N` parts of N lanes.
    let m = g.width;
    let parts =
        (0..g.data.len() / (g.stride * 3 * m)).flat_map(|blk| (0..m / N).map(move |h| (blk, h)));
    for (blk, h) in parts {
        let wb = &g.data[blk * g.stride * 3 * m..(blk + 1) * g.stride * 3 * m];
        let (wg, wf) = wb.split_at(g.geometry * 3 * m);
        let first = blk * m + h * N;
        if first >= g.per {
            break;
        }
        let [mut px, mut py, mut pz] = [S::zero(); 3];
        let [mut sx, mut sy, mut sz] = [S::zero(); 3];
        let [mut tx, mut ty, mut tz] = [S::zero(); 3];
        for (c, w3) in geometry.iter().zip(wg.chunks_exact(3 * m)) {
            let w = lanes(&w3[h * N..]);
            let ws = lanes(&w3[m + h * N..]);
            let wt = lanes(&w3[2 * m + h * N..]);
            let [cx, cy, cz] = c.map(S::splat);
            px = px.madd(w, cx);
            py = py.madd(w, cy);
            pz = pz.madd(w, cz);
            sx = sx.madd(ws, cx);
            sy = sy.madd(ws, cy);
            sz = sz.madd(ws, cz);
            tx = tx.madd(wt, cx);
            ty = ty.madd(wt, cy);
            tz = tz.madd(wt, cz);
        }
        let (nx, ny, nz) = if field.is_empty() {
            (
                sy.mul(tz).sub(sz.mul(ty)),
                sz.mul(tx).sub(sx.mul(tz)),
                sx.mul(ty).sub(sy.mul(tx)),
            )
        } else {
            // PN: the quadratic normal field.
            let [mut nx, mut ny, mut nz] = [S::zero(); 3];
            for (c, w3) in field.iter().zip(wf.chunks_exact(3 * m)) {
                let w = lanes(&w3[h * N..]);
                let [cx, cy, cz] = c.map(S::splat);
                nx = nx.madd(w, cx);
                ny = ny.madd(w, cy);
                nz = nz.madd(w, cz);
            }
            (nx, ny, nz)
        };
        let len = nx.mul(nx).madd(ny, ny).madd(nz, nz).sqrt();
        let scale = len.recip();
        let [ox, oy, oz] = origin.map(S::splat);
        let [px, py, pz] = [ox.add(px), oy.add(py), oz.add(pz)];
        let [fx, fy, fz] = flat.map(S::splat);
        let [nx, ny, nz] = [
            S::select_usable(len, nx.mul(scale), fx),
            S::select_usable(len, ny.mul(scale), fy),
            S::select_usable(len, nz.mul(scale), fz),
        ];
        let count = N.min(g.per - first);
        if count == N {
            let (p, n) = (&mut pos[first..first + N], &mut nrm[first..first + N]);
            S::interleave(px, py, pz, p.try_into().expect("a whole block"));
            S::interleave(nx, ny, nz, n.try_into().expect("a whole block"));
        } else {
            let [px, py, pz] = [px.store(), py.store(), pz.store()];
            let [nx, ny, nz] = [nx.store(), ny.store(), nz.store()];
            for l in 0..count {
                pos[first + l] = [px[l], py[l], pz[l]];
                nrm[first + l] = [nx[l], ny[l], nz[l]];
            }
        }
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn patch_f32_avx2(
    g: &GridWeightsF32,
    cp: &[[f32; 3]],
    origin: [f32; 3],
    flat: [f32; 3],
    pos: &mut [[f32; 3]],
    nrm: &mut [[f32; 3]],
) {
    patch_f32::<LANES, Avx2>(g, cp, origin, flat, pos, nrm)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn patch_f32_avx512(
    g: &GridWeightsF32,
    cp: &[[f32; 3]],
    origin: [f32; 3],
    flat: [f32; 3],
    pos: &mut [[f32; 3]],
    nrm: &mut [[f32; 3]],
) {
    patch_f32::<LANES16, Avx512>(g, cp, origin, flat, pos, nrm)
}

/// Instruction set of the f32 fast path.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum F32Kernel {
    /// AVX-512F (16 lanes) where the CPU has it, else AVX2 + FMA (8 lanes) where it has
    /// them (detected at run time), else portable. Both vector kernels give bitwise the
    /// same samples.
    Auto,
    /// AVX2 + FMA where the CPU has them, even where it has AVX-512F; else portable.
    Avx2,
    /// Plain Rust on arrays, any CPU.
    Portable,
}

/// The code that runs a patch.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Isa {
    Avx512,
    Avx2,
    Portable,
}

impl F32Kernel {
    fn isa(self) -> Isa {
        match self {
            F32Kernel::Auto if cpu_has!("avx512f") => Isa::Avx512,
            F32Kernel::Auto | F32Kernel::Avx2 if cpu_has!("avx2", "fma") => Isa::Avx2,
            _ => Isa::Portable,
        }
    }

    /// The kernel that actually runs: "avx512f", "avx2+fma" or "portable".
    pub fn name(self) -> &'static str {
        match self.isa() {
            Isa::Avx512 => "avx512f",
            Isa::Avx2 => "avx2+fma",
            Isa::Portable => "portable",
        }
    }
}

/// Evaluates patches `first..first + pos.len() / per` into `pos` and `nrm` (rayon over
/// patches, the calling pool's threads).
fn run_patches_f32(
    table: &PatchTable,
    g: &GridWeightsF32,
    kernel: F32Kernel,
    first: usize,
    pos: &mut [[f32; 3]],
    nrm: &mut [[f32; 3]],
) {
    // AVX-512F only on weights in blocks of 16 (laid out so where the CPU has it).
    let isa = match kernel.isa() {
        Isa::Avx512 if g.width != LANES16 => F32Kernel::Avx2.isa(),
        isa => isa,
    };
    let corners = grid_corners(g.level);
    pos.par_chunks_mut(g.per)
        .zip(nrm.par_chunks_mut(g.per))
        .enumerate()
        .for_each(|(k, (p, n))| {
            let i = first + k;
            let c = table.patch(i);
            let o = c[0];
            let mut cp = [[0f32; 3]; crate::patch::basis::MAX_POINTS];
            // Geometry relative to the first point, the normal field as it is: two loops
            // without a branch per point.
            let (geometry, field) = c.split_at(g.geometry.min(c.len()));
            let (cp_geometry, cp_field) = cp.split_at_mut(geometry.len());
            for (d, x) in cp_geometry.iter_mut().zip(geometry) {
                let v = *x - o;
                *d = [v.x as f32, v.y as f32, v.z as f32];
            }
            for (d, x) in cp_field.iter_mut().zip(field) {
                *d = [x.x as f32, x.y as f32, x.z as f32];
            }
            let f = table.flat_normals[i];
            let origin = [o.x as f32, o.y as f32, o.z as f32];
            let flat = [f.x as f32, f.y as f32, f.z as f32];
            let cp = &cp[..g.stride];
            match isa {
                // SAFETY: the CPU has AVX-512F (checked by `cpu_has!` in `isa`).
                #[cfg(target_arch = "x86_64")]
                Isa::Avx512 => unsafe { patch_f32_avx512(g, cp, origin, flat, p, n) },
                // SAFETY: the CPU has AVX2 and FMA (checked by `cpu_has!` in `isa`).
                #[cfg(target_arch = "x86_64")]
                Isa::Avx2 => unsafe { patch_f32_avx2(g, cp, origin, flat, p, n) },
                _ => patch_f32::<LANES, Portable>(g, cp, origin, flat, p, n),
            }
            // The input vertices rounded once (origin + relative offset may differ by an
            // ulp).
            for (k, &c) in corners.iter().enumerate() {
                p[c] = crate::eval::to_f32(table.corner(i, k));
            }
        });
}

/// Where the f32 kernel's patches come from.
enum Source<'s, 'm> {
    /// A table of every patch.
    Table(&'s PatchTable),
    /// A builder, one chunk's table at a time; what sees each chunk's table.
    Built(
        &'s PatchBuilder<'m>,
        &'s mut (dyn FnMut(usize, &PatchTable) + Send),
    ),
}

/// One of the two sets of buffers of the kernel's steps: the samples of a chunk, and for
/// a [`Source::Built`], the chunk's table.
struct ChunkBuffers {
    positions: Vec<[f32; 3]>,
    normals: Vec<[f32; 3]>,
    table: Option<PatchTable>,
}

impl CpuEvaluator {
    /// The f32 kernel on the grid of `weights.level` with precomputed weights, streamed in
    /// chunks (what [`Evaluator::evaluate_f32`] runs for a grid; callers that evaluate the
    /// same level many times keep the weights).
    pub fn grid_f32(
        &self,
        table: &PatchTable,
        weights: &GridWeightsF32,
        sink: &mut dyn FnMut(ChunkF32<'_>) -> Result<()>,
    ) -> Result<()> {
        self.grid_f32_chunks(table, weights, PIPELINE_SAMPLES, &mut |_| {}, sink)
    }

    /// [`Self::grid_f32`] with a stage run on each chunk in the thread-pool job that
    /// evaluated it, before the sink gets the chunk (see
    /// [`Evaluator::evaluate_f32_staged`]); chunks of at most
    /// [`stage_samples`](crate::eval::stage_samples) samples, so that each thread's share
    /// of the chunk and what the stage builds of it stay in its core's cache.
    pub(crate) fn grid_f32_staged(
        &self,
        table: &PatchTable,
        weights: &GridWeightsF32,
        stage: &mut (dyn FnMut(ChunkF32<'_>) + Send),
        sink: &mut dyn FnMut(ChunkF32<'_>) -> Result<()>,
    ) -> Result<()> {
        self.grid_f32_chunks(table, weights, stage_samples(), stage, sink)
    }

    /// The f32 kernel in chunks of at most `most` samples (and `chunk_samples`; one patch
    /// at least), each staged in the pool job that evaluated it.
    fn grid_f32_chunks(
        &self,
        table: &PatchTable,
        weights: &GridWeightsF32,
        most: usize,
        stage: &mut (dyn FnMut(ChunkF32<'_>) + Send),
        sink: &mut dyn FnMut(ChunkF32<'_>) -> Result<()>,
    ) -> Result<()> {
        self.source_chunks(Source::Table(table), weights, most, stage, sink)
    }

    /// [`Self::grid_f32_staged`] of the patches `builder` builds, each chunk's table built
    /// in the pool job that evaluates it (the table of the whole mesh is never held: a few
    /// chunks' tables at a time), and seen there by `seen` (its first patch's index, its
    /// table), in order, before it is evaluated.
    pub(crate) fn grid_f32_built(
        &self,
        builder: &PatchBuilder<'_>,
        weights: &GridWeightsF32,
        seen: &mut (dyn FnMut(usize, &PatchTable) + Send),
        stage: &mut (dyn FnMut(ChunkF32<'_>) + Send),
        sink: &mut dyn FnMut(ChunkF32<'_>) -> Result<()>,
    ) -> Result<()> {
        let source = Source::Built(builder, seen);
        self.source_chunks(source, weights, stage_samples(), stage, sink)
    }

    /// The f32 kernel over `source` in chunks of at most `most` samples (and
    /// `chunk_samples`; one patch at least), each staged in the pool job that evaluated it.
    fn source_chunks(
        &self,
        mut source: Source<'_, '_>,
        weights: &GridWeightsF32,
        most: usize,
        stage: &mut (dyn FnMut(ChunkF32<'_>) + Send),
        sink: &mut dyn FnMut(ChunkF32<'_>) -> Result<()>,
    ) -> Result<()> {
        let (kind, n) = match &source {
            Source::Table(t) => (t.kind, t.len()),
            Source::Built(b, _) => (b.kind(), b.mesh().triangles.len()),
        };
        check_weights(kind, weights)?;
        let per = weights.per;
        let kernel = self.f32_kernel;
        let chunk = self.chunk_samples.min(most);
        let patches_per_chunk = (chunk / per).max(1).min(n.max(1));
        let buffers = |patches: usize| ChunkBuffers {
            positions: vec![[0f32; 3]; patches * per],
            normals: vec![[0f32; 3]; patches * per],
            table: None,
        };
        // A second set only where there is a second chunk.
        let (mut cur, mut next) = (
            buffers(patches_per_chunk),
            buffers(if n > patches_per_chunk {
                patches_per_chunk
            } else {
                0
            }),
        );
        // The first error of a chunk's construction, returned by the sink's next step.
        let failed = Mutex::new(None);
        // The kernel fills the next chunk on the pool, and the stage takes it there, while
        // the sink reads this one.
        crate::pipelined::double_buffered(
            &mut cur,
            &mut next,
            n,
            patches_per_chunk,
            |first, count, b| {
                let (p, q) = (
                    &mut b.positions[..count * per],
                    &mut b.normals[..count * per],
                );
                match &mut source {
                    Source::Table(table) => run_patches_f32(table, weights, kernel, first, p, q),
                    Source::Built(builder, seen) => {
                        let t = b.table.get_or_insert_with(|| builder.empty_table());
                        if let Err(e) = builder.range_into(first..first + count, t) {
                            failed
                                .lock()
                                .unwrap_or_else(PoisonError::into_inner)
                                .get_or_insert(e);
                            return;
                        }
                        seen(first, t);
                        run_patches_f32(t, weights, kernel, 0, p, q);
                    }
                }
                stage(Chunk {
                    first,
                    positions: p,
                    normals: q,
                })
            },
            |first, count, b| {
                if let Some(e) = failed.lock().unwrap_or_else(PoisonError::into_inner).take() {
                    return Err(e);
                }
                sink(Chunk {
                    first,
                    positions: &b.positions[..count * per],
                    normals: &b.normals[..count * per],
                })
            },
        )?;
        match failed.into_inner().unwrap_or_else(PoisonError::into_inner) {
            Some(e) => Err(e),
            None => Ok(()),
        }
    }

    /// The f32 kernel into caller-owned arrays of `grid_len(level) × table.len()` samples
    /// (the whole output at once, no chunks: `bench`'s memory-bound figure).
    pub fn grid_f32_into(
        &self,
        table: &PatchTable,
        weights: &GridWeightsF32,
        positions: &mut [[f32; 3]],
        normals: &mut [[f32; 3]],
    ) -> Result<()> {
        check_weights(table.kind, weights)?;
        let n = weights.per * table.len();
        if positions.len() != n || normals.len() != n {
            return Err(crate::Error::Invalid(format!(
                "f32 grid of level {}: {} positions and {} normals given for {n} samples",
                weights.level,
                positions.len(),
                normals.len(),
            )));
        }
        run_patches_f32(table, weights, self.f32_kernel, 0, positions, normals);
        Ok(())
    }
}

fn check_weights(kind: PatchKind, weights: &GridWeightsF32) -> Result<()> {
    if weights.kind != kind {
        return Err(crate::Error::Invalid(format!(
            "grid weights of {:?} used on a table of {:?}",
            weights.kind, kind
        )));
    }
    Ok(())
}
