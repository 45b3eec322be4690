//! The f32 grid kernel ([`Evaluator::evaluate_f32`] on a grid): f32 weights in blocks of
//! 8 samples, AVX2+FMA detected at run time or portable code, control points relative to
//! each patch's first point, corners overwritten with the input vertices rounded once.

use rayon::prelude::*;

use super::CpuEvaluator;
#[cfg(doc)] // links in the documentation
use crate::eval::Evaluator;
use crate::eval::{grid_barycentrics, grid_corners, Chunk, ChunkF32};
use crate::patch::PatchTable;
use crate::Result;

/// Samples per SIMD block of the fast path.
const LANES: usize = 8;

/// Basis values of a grid level in f32, laid out for the fast path: for each block of
/// [`LANES`] samples and each control point, `LANES` values of w, ∂w/∂s, ∂w/∂t
/// (padding samples have weight 0).
#[derive(Clone, Debug)]
pub struct GridWeightsF32 {
    pub kind: crate::patch::PatchKind,
    pub level: u32,
    /// Samples per patch.
    pub per: usize,
    /// Blocks of `LANES` samples per patch.
    pub blocks: usize,
    /// Leading control points that are geometry.
    pub geometry: usize,
    /// Control points per patch.
    pub stride: usize,
    data: Vec<f32>,
}

impl GridWeightsF32 {
    /// The weights of `kind` on the grid of `level` (computed in f64, rounded once).
    pub fn new(kind: crate::patch::PatchKind, level: u32) -> GridWeightsF32 {
        let level = level.max(1);
        let b = grid_barycentrics(level);
        let per = b.len();
        let blocks = per.div_ceil(LANES);
        let stride = kind.stride();
        let geometry = kind.geometry();
        let mut data = vec![0f32; blocks * stride * 3 * LANES];
        for (s, b) in b.iter().enumerate() {
            let w = kind.weights(*b);
            let (blk, l) = (s / LANES, s % LANES);
            for j in 0..stride {
                let o = ((blk * stride + j) * 3) * LANES + l;
                data[o] = w.w[j] as f32;
                data[o + LANES] = w.ws[j] as f32;
                data[o + 2 * LANES] = w.wt[j] as f32;
            }
        }
        GridWeightsF32 {
            kind,
            level,
            per,
            blocks,
            geometry,
            stride,
            data,
        }
    }
}

type Lanes = [f32; LANES];

/// The few vector operations of the fast path, on [`LANES`] f32 lanes.
trait Simd: Copy {
    fn zero() -> Self;
    fn load(w: &Lanes) -> Self;
    fn splat(x: f32) -> Self;
    /// self + w · c.
    fn madd(self, w: Self, c: Self) -> Self;
    fn mul(self, o: Self) -> Self;
    fn sub(self, o: Self) -> Self;
    fn sqrt(self) -> Self;
    fn recip(self) -> Self;
    fn store(self) -> Lanes;
}

/// Plain arrays (any CPU; the compiler vectorises what it can).
#[derive(Clone, Copy)]
struct Portable(Lanes);

impl Simd for Portable {
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
    fn store(self) -> Lanes {
        self.0
    }
}

/// AVX2 + FMA registers (used only after runtime detection).
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
struct Avx2(std::arch::x86_64::__m256);

#[cfg(target_arch = "x86_64")]
impl Simd for Avx2 {
    #[inline(always)]
    fn zero() -> Self {
        // SAFETY (all methods): only reached from `patch_f32_avx2`, compiled for and
        // called on CPUs with AVX2 and FMA.
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
    fn store(self) -> Lanes {
        let mut out = [0f32; LANES];
        unsafe { std::arch::x86_64::_mm256_storeu_ps(out.as_mut_ptr(), self.0) };
        out
    }
}

/// Evaluates one patch: `cp` its control points relative to `origin` (geometry) or as
/// they are (normal field), `flat` its fallback normal.
#[inline(always)]
fn patch_f32<S: Simd>(
    g: &GridWeightsF32,
    cp: &[[f32; 3]],
    origin: [f32; 3],
    flat: [f32; 3],
    pos: &mut [[f32; 3]],
    nrm: &mut [[f32; 3]],
) {
    let (geometry, field) = cp.split_at(g.geometry);
    let lanes = |w: &[f32]| -> S { S::load(w.try_into().unwrap()) };
    for (blk, wb) in g.data.chunks_exact(g.stride * 3 * LANES).enumerate() {
        let (wg, wf) = wb.split_at(g.geometry * 3 * LANES);
        let [mut px, mut py, mut pz] = [S::zero(); 3];
        let [mut sx, mut sy, mut sz] = [S::zero(); 3];
        let [mut tx, mut ty, mut tz] = [S::zero(); 3];
        for (c, w3) in geometry.iter().zip(wg.chunks_exact(3 * LANES)) {
            let w = lanes(&w3[..LANES]);
            let ws = lanes(&w3[LANES..2 * LANES]);
            let wt = lanes(&w3[2 * LANES..]);
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
            for (c, w3) in field.iter().zip(wf.chunks_exact(3 * LANES)) {
                let w = lanes(&w3[..LANES]);
                let [cx, cy, cz] = c.map(S::splat);
                nx = nx.madd(w, cx);
                ny = ny.madd(w, cy);
                nz = nz.madd(w, cz);
            }
            (nx, ny, nz)
        };
        let len = nx.mul(nx).madd(ny, ny).madd(nz, nz).sqrt();
        let scale = len.recip();
        let [px, py, pz] = [px.store(), py.store(), pz.store()];
        let [nx, ny, nz] = [
            nx.mul(scale).store(),
            ny.mul(scale).store(),
            nz.mul(scale).store(),
        ];
        let len = len.store();
        let first = blk * LANES;
        let count = LANES.min(g.per - first);
        let (pos, nrm) = (
            &mut pos[first..first + count],
            &mut nrm[first..first + count],
        );
        for l in 0..count {
            pos[l] = [origin[0] + px[l], origin[1] + py[l], origin[2] + pz[l]];
            // Usable length: neither tiny nor infinite nor NaN (else the flat normal).
            nrm[l] = if len[l] > crate::patch::MIN_NORMAL_LEN_F32 && len[l] < f32::INFINITY {
                [nx[l], ny[l], nz[l]]
            } else {
                flat
            };
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
    patch_f32::<Avx2>(g, cp, origin, flat, pos, nrm)
}

fn has_avx2_fma() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// Instruction set of the f32 fast path.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum F32Kernel {
    /// AVX2 + FMA where the CPU has them (detected at run time), else portable.
    Auto,
    /// Plain Rust on arrays, any CPU.
    Portable,
}

impl F32Kernel {
    /// The kernel that actually runs: "avx2+fma" or "portable".
    pub fn name(self) -> &'static str {
        if self == F32Kernel::Auto && has_avx2_fma() {
            "avx2+fma"
        } else {
            "portable"
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
    let avx2 = kernel == F32Kernel::Auto && has_avx2_fma();
    let corners = grid_corners(g.level);
    pos.par_chunks_mut(g.per)
        .zip(nrm.par_chunks_mut(g.per))
        .enumerate()
        .for_each(|(k, (p, n))| {
            let i = first + k;
            let c = table.patch(i);
            let o = c[0];
            let mut cp = [[0f32; 3]; crate::patch::basis::MAX_POINTS];
            for (j, x) in c.iter().enumerate() {
                let v = if j < g.geometry { *x - o } else { *x };
                cp[j] = [v.x as f32, v.y as f32, v.z as f32];
            }
            let f = table.flat_normals[i];
            let origin = [o.x as f32, o.y as f32, o.z as f32];
            let flat = [f.x as f32, f.y as f32, f.z as f32];
            let cp = &cp[..g.stride];
            #[cfg(target_arch = "x86_64")]
            if avx2 {
                // SAFETY: the CPU has AVX2 and FMA (checked by has_avx2_fma).
                unsafe { patch_f32_avx2(g, cp, origin, flat, p, n) };
            } else {
                patch_f32::<Portable>(g, cp, origin, flat, p, n);
            }
            #[cfg(not(target_arch = "x86_64"))]
            {
                let _ = avx2;
                patch_f32::<Portable>(g, cp, origin, flat, p, n);
            }
            // The input vertices rounded once (origin + relative offset may differ by an
            // ulp).
            for (k, &c) in corners.iter().enumerate() {
                p[c] = crate::eval::to_f32(table.corner(i, k));
            }
        });
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
        check_weights(table, weights)?;
        let per = weights.per;
        let patches_per_chunk = (self.chunk_samples / per).max(1).min(table.len().max(1));
        let mut pos = vec![[0f32; 3]; patches_per_chunk * per];
        let mut nrm = vec![[0f32; 3]; patches_per_chunk * per];
        let mut first = 0;
        while first < table.len() {
            let count = patches_per_chunk.min(table.len() - first);
            let (p, n) = (&mut pos[..count * per], &mut nrm[..count * per]);
            run_patches_f32(table, weights, self.f32_kernel, first, p, n);
            sink(Chunk {
                first,
                positions: p,
                normals: n,
            })?;
            first += count;
        }
        Ok(())
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
        check_weights(table, weights)?;
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

fn check_weights(table: &PatchTable, weights: &GridWeightsF32) -> Result<()> {
    if weights.kind != table.kind {
        return Err(crate::Error::Invalid(format!(
            "grid weights of {:?} used on a table of {:?}",
            weights.kind, table.kind
        )));
    }
    Ok(())
}
