//! Patch tables: for each triangle of a mesh, the control points of one curved patch,
//! in f64, ignorant of the backend that evaluates them (OpenSubdiv's Far/Osd split).
//!
//! A scheme is one file here (its construction, as a [`TriangleBuilder`]) plus one line of
//! [`SCHEMES`], the registry every name, kind and construction is read from, plus its
//! variant of [`Scheme`]. A table is plain arrays (`stride` points per patch, patch-major)
//! so a GPU can take it as it is; [`PatchBuilder`] builds the table of any subset of the
//! triangles (streaming consumers build patches chunk by chunk).

pub mod basis;
pub mod flat;
pub mod g1;
pub mod lagrange;
pub mod nagata;
pub mod nlsa;
pub mod phong;
pub mod pn;
pub mod quadratic;
pub mod repair;
pub mod validity;

use glam::DVec3;
use rayon::prelude::*;

use crate::mesh::Mesh;
use crate::{Error, Result};
use basis::Weights;

/// The surface construction applied to every triangle.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "kebab-case")]
pub enum Scheme {
    /// Bézier G1 (Walton & Meek 1996): quartic boundary, Gregory interior, shared tangent
    /// planes across edges.
    G1,
    /// Phong tessellation (Boubekeur & Alexa 2008), quadratic, shape factor α
    /// (`--phong-alpha`, default 3/4).
    Phong,
    /// Nagata (2005) with ξ = 0: no singularity treatment (the paper's row).
    Nagata,
    /// Nagata with a guard against the ξ = 0 blow-up for nearly parallel normals (see
    /// `nagata.rs`; in the spirit of Neto et al. 2013, rule stated there).
    NagataGuarded,
    /// NLSA (Barrera, Hast & Bengtsson 2002) as reconstructed in `SCHEMES.md`, quadratic.
    Nlsa,
    /// PN triangles (Vlachos et al. 2001): cubic geometry, exact normal (Table 1's row).
    Pn,
    /// PN triangles with their quadratic normal field as the reported normal.
    PnNormals,
    /// The flat triangle (degree-1 Bézier), the baseline.
    Flat,
}

/// Builds the control points of any triangle's patch of one scheme on one mesh (the scheme
/// prepared by its [`SchemeInfo::prepare`]).
pub trait TriangleBuilder: Sync {
    /// Writes the `stride` control points of triangle `t` into `out` and returns the number
    /// of documented fallbacks the construction took for it.
    fn build(&self, t: usize, out: &mut [DVec3]) -> usize;

    /// Fallbacks taken once for the whole mesh while preparing (G1's crease curves).
    fn prepared_fallbacks(&self) -> usize {
        0
    }
}

/// Prepares a scheme for one mesh (precomputing whatever is shared between triangles).
pub type Prepare = for<'a> fn(&'a Mesh, &SchemeOptions) -> Result<Box<dyn TriangleBuilder + 'a>>;

/// One scheme's line of the registry.
#[derive(Clone, Copy)]
pub struct SchemeInfo {
    pub scheme: Scheme,
    /// The name on the command line and in reports (clap's and serde's kebab-case spelling
    /// of the variant; `tests/schemes.rs` checks they agree).
    pub name: &'static str,
    /// How its tables are evaluated (layout, basis, shader).
    pub kind: PatchKind,
    pub prepare: Prepare,
}

/// The registry: every scheme, in the order reports list them, and in the order of the
/// [`Scheme`] variants (checked at compile time).
pub const SCHEMES: &[SchemeInfo] = &[
    SchemeInfo {
        scheme: Scheme::G1,
        name: "g1",
        kind: PatchKind::Gregory,
        prepare: g1::prepare,
    },
    SchemeInfo {
        scheme: Scheme::Phong,
        name: "phong",
        kind: PatchKind::Bezier(2),
        prepare: phong::prepare,
    },
    SchemeInfo {
        scheme: Scheme::Nagata,
        name: "nagata",
        kind: PatchKind::Bezier(2),
        prepare: nagata::prepare,
    },
    SchemeInfo {
        scheme: Scheme::NagataGuarded,
        name: "nagata-guarded",
        kind: PatchKind::Bezier(2),
        prepare: nagata::prepare_guarded,
    },
    SchemeInfo {
        scheme: Scheme::Nlsa,
        name: "nlsa",
        kind: PatchKind::Bezier(2),
        prepare: nlsa::prepare,
    },
    SchemeInfo {
        scheme: Scheme::Pn,
        name: "pn",
        kind: PatchKind::Bezier(3),
        prepare: pn::prepare,
    },
    SchemeInfo {
        scheme: Scheme::PnNormals,
        name: "pn-normals",
        kind: PatchKind::PnNormals,
        prepare: pn::prepare_normals,
    },
    SchemeInfo {
        scheme: Scheme::Flat,
        name: "flat",
        kind: PatchKind::Bezier(1),
        prepare: flat::prepare,
    },
];

// Registry line i describes the variant with discriminant i, so `Scheme::info` indexes.
const _: () = {
    let mut i = 0;
    while i < SCHEMES.len() {
        assert!(SCHEMES[i].scheme as usize == i);
        i += 1;
    }
};

impl Scheme {
    /// Its line of `SCHEMES`.
    pub(crate) fn info(self) -> &'static SchemeInfo {
        &SCHEMES[self as usize]
    }

    /// Every scheme, in the order reports list them.
    pub fn all() -> Vec<Scheme> {
        SCHEMES.iter().map(|i| i.scheme).collect()
    }

    /// The name used on the command line and in reports.
    pub fn name(self) -> &'static str {
        self.info().name
    }

    /// How its tables are evaluated.
    pub fn kind(self) -> PatchKind {
        self.info().kind
    }

    /// The scheme named `s` ([`Scheme::name`]); an error listing the known names otherwise.
    pub fn parse(s: &str) -> Result<Scheme> {
        SCHEMES
            .iter()
            .find(|x| x.name == s)
            .map(|x| x.scheme)
            .ok_or_else(|| {
                let names: Vec<_> = SCHEMES.iter().map(|x| x.name).collect();
                Error::Invalid(format!(
                    "unknown scheme '{s}' (known: {})",
                    names.join(", ")
                ))
            })
    }
}

impl std::fmt::Display for Scheme {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Options of the schemes that have any. Defaults are the paper's.
///
/// Built from [`SchemeOptions::default()`] and the `with_*` methods:
///
/// ```
/// let opts = g1tess::SchemeOptions::default().with_phong_alpha(0.5);
/// assert_eq!(opts.phong_alpha, 0.5);
/// ```
#[derive(Clone, Copy, Debug)]
#[non_exhaustive]
pub struct SchemeOptions {
    /// Phong tessellation's shape factor α (default 3/4, the paper's).
    pub phong_alpha: f64,
}

impl SchemeOptions {
    /// Sets [`SchemeOptions::phong_alpha`].
    pub fn with_phong_alpha(mut self, phong_alpha: f64) -> Self {
        self.phong_alpha = phong_alpha;
        self
    }
}

impl Default for SchemeOptions {
    fn default() -> Self {
        SchemeOptions { phong_alpha: 0.75 }
    }
}

/// How a table's control points are evaluated.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum PatchKind {
    /// Bézier triangle of this degree; points in `basis::bezier_powers` order. The normal
    /// is the exact normal S_s × S_t of the geometry.
    Bezier(u32),
    /// The G1 patch: 12 boundary points (edge k: L_{k,0..3}) then G_{0,1}, G_{0,2}, G_{1,1},
    /// G_{1,2}, G_{2,1}, G_{2,2}.
    Gregory,
    /// PN triangle with its quadratic normal field: the 10 cubic geometry points, then the
    /// 6 quadratic normal-field coefficients (in `bezier_powers(2)` order). Position and
    /// tangents come from the cubic; the reported normal is the normalised quadratic field.
    PnNormals,
}

/// Smallest |S_s × S_t| (f64 evaluation) taken as a usable normal; below it, or where it is
/// not finite, the flat triangle normal is used. The one f64 threshold of every backend.
/// Its square (the sum of squares the length is computed from) must stay a normal f64
/// (≥ 2.2e-308): below about 1.5e-154 the squares lose their digits and the "unit" normal
/// is not unit.
pub const MIN_NORMAL_LEN_F64: f64 = 1e-150;
/// The same threshold for f32 evaluation (CPU SIMD kernel and f32 shaders): squares of
/// lengths above 1e-18 are normal f32 numbers (≥ 1.2e-38), even split over three
/// components. (At 1e-30, a test mesh with its vertices renumbered gave the f32 kernel a
/// normal of length 0.9966.)
pub const MIN_NORMAL_LEN_F32: f32 = 1e-18;

/// Layout facts of one [`PatchKind`]: the single source every backend, writer and shader
/// header reads (see [`PatchKind::layout`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub struct Layout {
    /// Control points per patch.
    pub stride: usize,
    /// Leading control points that are geometry; the rest (PN's normal field) are not
    /// positions and are never moved to a patch-relative origin.
    pub geometry: usize,
    /// Polynomial degree of the geometry.
    pub degree: u32,
    /// The basis is rational (G1's Gregory blend): weights are not polynomials.
    pub rational: bool,
    /// Control point that equals corner k of the input triangle (the surface interpolates
    /// it exactly there).
    pub corners: [usize; 3],
}

impl PatchKind {
    /// The layout of this kind.
    pub const fn layout(self) -> Layout {
        match self {
            PatchKind::Bezier(n) => {
                let stride = ((n + 1) * (n + 2) / 2) as usize;
                Layout {
                    stride,
                    geometry: stride,
                    degree: n,
                    rational: false,
                    // bezier_powers order: (n,0,0) first, (0,n,0) opens the last row,
                    // (0,0,n) closes it.
                    corners: [0, (n * (n + 1) / 2) as usize, stride - 1],
                }
            }
            PatchKind::Gregory => Layout {
                stride: 18,
                geometry: 18,
                degree: 4,
                rational: true,
                // Edge k's boundary cubic starts at corner k: L_{k,0} = point 4k.
                corners: [0, 4, 8],
            },
            PatchKind::PnNormals => Layout {
                stride: 16,
                geometry: 10,
                degree: 3,
                rational: false,
                corners: [0, 6, 9],
            },
        }
    }

    /// Control points per patch.
    pub const fn stride(self) -> usize {
        self.layout().stride
    }

    /// Leading control points that are geometry (see `Layout::geometry`).
    pub const fn geometry(self) -> usize {
        self.layout().geometry
    }

    /// Every kind a table can have, for tests and shader validation.
    pub fn all() -> Vec<PatchKind> {
        vec![
            PatchKind::Bezier(1),
            PatchKind::Bezier(2),
            PatchKind::Bezier(3),
            PatchKind::Gregory,
            PatchKind::PnNormals,
        ]
    }

    /// Basis values and tangent derivatives at `b`.
    pub(crate) fn weights(self, b: [f64; 3]) -> Weights {
        match self {
            PatchKind::Bezier(n) => basis::bezier(n, b),
            PatchKind::Gregory => basis::g1(b),
            PatchKind::PnNormals => basis::pn_normals(b),
        }
    }
}

/// Position, tangents and unit normal of a patch at one point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfacePoint {
    /// The position S.
    pub p: DVec3,
    /// ∂S/∂s along b = (1 − s − t, s, t).
    pub ds: DVec3,
    /// ∂S/∂t.
    pub dt: DVec3,
    /// Unit normal S_s × S_t / |S_s × S_t|, or the fallback described at `unit_normal`.
    pub n: DVec3,
}

/// The exact unit normal from two tangents. Where they are parallel (a degenerate patch)
/// the flat normal `fallback` is returned instead, so the result is never NaN.
#[inline]
pub fn unit_normal(ds: DVec3, dt: DVec3, fallback: DVec3) -> DVec3 {
    let c = ds.cross(dt);
    let len = c.length();
    if len > MIN_NORMAL_LEN_F64 && len.is_finite() {
        c / len
    } else {
        fallback
    }
}

/// Control points of one scheme for every triangle of a mesh.
#[derive(Clone, Debug)]
pub struct PatchTable {
    /// The scheme the table was built for.
    pub scheme: Scheme,
    /// How its patches are evaluated (the scheme's kind).
    pub kind: PatchKind,
    /// Control points per patch (`kind.stride()`).
    pub stride: usize,
    /// `stride` points per patch, patch after patch.
    pub points: Vec<DVec3>,
    /// Flat unit normal of each patch's triangle, the fallback where the patch is singular.
    pub flat_normals: Vec<DVec3>,
    /// Edges where a construction needed its documented fallback (see the scheme's file).
    pub fallbacks: usize,
}

impl PatchTable {
    /// Builds the table of `scheme` for every triangle of `mesh`.
    pub fn build(mesh: &Mesh, scheme: Scheme, opts: &SchemeOptions) -> Result<PatchTable> {
        PatchBuilder::new(mesh, scheme, opts)?.table()
    }

    /// Number of patches.
    pub fn len(&self) -> usize {
        self.flat_normals.len()
    }

    /// Whether the table has no patch.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The input position of corner `k` of patch `i` (its corner control point).
    pub fn corner(&self, i: usize, k: usize) -> DVec3 {
        self.points[i * self.stride + self.kind.layout().corners[k]]
    }

    /// Control points of patch `i`.
    pub fn patch(&self, i: usize) -> &[DVec3] {
        &self.points[i * self.stride..(i + 1) * self.stride]
    }

    /// Evaluates patch `i` at barycentric `b` with precomputed weights.
    #[inline]
    pub(crate) fn eval_weights(&self, i: usize, w: &Weights) -> SurfacePoint {
        let c = self.patch(i);
        let geometry = self.kind.geometry();
        let (mut p, mut ds, mut dt) = (DVec3::ZERO, DVec3::ZERO, DVec3::ZERO);
        for (j, cj) in c[..geometry].iter().enumerate() {
            p += w.w[j] * *cj;
            ds += w.ws[j] * *cj;
            dt += w.wt[j] * *cj;
        }
        let n = if geometry < self.stride {
            let field: DVec3 = (geometry..self.stride).map(|j| w.w[j] * c[j]).sum();
            field.try_normalize().unwrap_or(self.flat_normals[i])
        } else {
            unit_normal(ds, dt, self.flat_normals[i])
        };
        SurfacePoint { p, ds, dt, n }
    }

    /// S_s and S_t of patch `i` from the basis `w`: bitwise [`Self::eval_weights`]'s (the
    /// same sums in the same order; keep the two in step), without the position and the
    /// normal.
    #[inline]
    pub(crate) fn tangents_weights(&self, i: usize, w: &Weights) -> (DVec3, DVec3) {
        let c = self.patch(i);
        let (mut ds, mut dt) = (DVec3::ZERO, DVec3::ZERO);
        for (j, cj) in c[..self.kind.geometry()].iter().enumerate() {
            ds += w.ws[j] * *cj;
            dt += w.wt[j] * *cj;
        }
        (ds, dt)
    }

    /// [`Self::eval_weights`] through the nonzero weights only: bitwise the same result
    /// (see `basis::SparseWeights`; the AVX path multiplies and adds lane by lane, with
    /// no fused operations, in the same order), faster where weights vanish (edges).
    #[inline]
    pub(crate) fn eval_sparse(&self, i: usize, s: &basis::SparseWeights) -> SurfacePoint {
        let c = self.patch(i);
        #[cfg(target_arch = "x86_64")]
        let [p, ds, dt] = if std::arch::is_x86_feature_detected!("avx") {
            // SAFETY: the CPU has AVX (checked just above).
            unsafe { sparse_sums_avx(c, s) }
        } else {
            sparse_sums(c, s)
        };
        #[cfg(not(target_arch = "x86_64"))]
        let [p, ds, dt] = sparse_sums(c, s);
        let geometry = self.kind.geometry();
        let n = if geometry < self.stride {
            let w = &s.full;
            let field: DVec3 = (geometry..self.stride).map(|j| w.w[j] * c[j]).sum();
            field.try_normalize().unwrap_or(self.flat_normals[i])
        } else {
            unit_normal(ds, dt, self.flat_normals[i])
        };
        SurfacePoint { p, ds, dt, n }
    }

    /// Evaluates patch `i` at barycentric `b` (b0 + b1 + b2 = 1; b_k weighs corner k).
    pub fn eval(&self, i: usize, b: [f64; 3]) -> SurfacePoint {
        self.eval_weights(i, &self.kind.weights(b))
    }
}

/// S, S_s and S_t of control points `c` through sparse weights (see
/// [`PatchTable::eval_sparse`]).
#[inline(always)]
fn sparse_sums(c: &[DVec3], s: &basis::SparseWeights) -> [DVec3; 3] {
    let (mut p, mut ds, mut dt) = (DVec3::ZERO, DVec3::ZERO, DVec3::ZERO);
    let (idx, terms) = s.terms();
    for (&j, w) in idx.iter().zip(terms) {
        let cj = c[j as usize];
        p += w[0] * cj;
        ds += w[1] * cj;
        dt += w[2] * cj;
    }
    [p, ds, dt]
}

/// [`sparse_sums`] with the three coordinates in one AVX register: the same products and
/// sums per coordinate, so bitwise the same result.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
fn sparse_sums_avx(c: &[DVec3], s: &basis::SparseWeights) -> [DVec3; 3] {
    use std::arch::x86_64::*;
    let mask = _mm256_setr_epi64x(-1, -1, -1, 0);
    let (mut p, mut ds, mut dt) = (
        _mm256_setzero_pd(),
        _mm256_setzero_pd(),
        _mm256_setzero_pd(),
    );
    let (idx, terms) = s.terms();
    for (&j, w) in idx.iter().zip(terms) {
        let cj: &DVec3 = &c[j as usize];
        // SAFETY: reads the three f64 of `cj` (DVec3 is repr(C) x, y, z); the fourth lane
        // is masked off and not read.
        let v = unsafe { _mm256_maskload_pd(cj as *const DVec3 as *const f64, mask) };
        p = _mm256_add_pd(p, _mm256_mul_pd(_mm256_broadcast_sd(&w[0]), v));
        ds = _mm256_add_pd(ds, _mm256_mul_pd(_mm256_broadcast_sd(&w[1]), v));
        dt = _mm256_add_pd(dt, _mm256_mul_pd(_mm256_broadcast_sd(&w[2]), v));
    }
    let out = |r: __m256d| {
        let mut a = [0.0f64; 4];
        // SAFETY: stores four f64 into a four-element array.
        unsafe { _mm256_storeu_pd(a.as_mut_ptr(), r) };
        DVec3::new(a[0], a[1], a[2])
    };
    [out(p), out(ds), out(dt)]
}

/// One scheme prepared for one mesh: builds the patch table of all or any of its triangles
/// (in parallel), so a consumer can hold only the patches it is evaluating.
pub struct PatchBuilder<'a> {
    mesh: &'a Mesh,
    scheme: Scheme,
    kind: PatchKind,
    inner: Box<dyn TriangleBuilder + 'a>,
}

impl<'a> PatchBuilder<'a> {
    /// Prepares `scheme` for `mesh` (errors: invalid options).
    pub fn new(mesh: &'a Mesh, scheme: Scheme, opts: &SchemeOptions) -> Result<PatchBuilder<'a>> {
        let info = scheme.info();
        Ok(PatchBuilder {
            mesh,
            scheme,
            kind: info.kind,
            inner: (info.prepare)(mesh, opts)?,
        })
    }

    pub fn mesh(&self) -> &'a Mesh {
        self.mesh
    }

    /// The kind of the patches it builds.
    pub fn kind(&self) -> PatchKind {
        self.kind
    }

    /// Fallbacks taken once for the whole mesh while preparing (counted in [`Self::table`]
    /// but in no [`Self::table_of`]).
    pub fn prepared_fallbacks(&self) -> usize {
        self.inner.prepared_fallbacks()
    }

    /// The table of every triangle; its `fallbacks` count the whole construction.
    pub fn table(&self) -> Result<PatchTable> {
        let n = self.mesh.triangles.len();
        let mut t = self.empty_table();
        self.build_with(n, n, &|i| i, &mut t)?;
        t.fallbacks += self.prepared_fallbacks();
        Ok(t)
    }

    /// The table of `triangles` (patch i is triangle `triangles[i]`); its `fallbacks` count
    /// the fallbacks of the first `counted` of them only (so that a consumer building
    /// triangles more than once counts each once).
    pub fn table_of(&self, triangles: &[u32], counted: usize) -> Result<PatchTable> {
        let mut t = self.empty_table();
        self.table_of_into(triangles, counted, &mut t)?;
        Ok(t)
    }

    /// [`Self::table_of`] into `table`, reusing its arrays (a streaming consumer builds
    /// one chunk's table after another in the same memory).
    pub fn table_of_into(
        &self,
        triangles: &[u32],
        counted: usize,
        table: &mut PatchTable,
    ) -> Result<()> {
        self.build_with(triangles.len(), counted, &|i| triangles[i] as usize, table)
    }

    /// [`Self::table_of_into`] of the triangles `range`, in order, every fallback counted.
    pub fn range_into(&self, range: std::ops::Range<usize>, table: &mut PatchTable) -> Result<()> {
        let n = range.len();
        self.build_with(n, n, &|i| range.start + i, table)
    }

    /// Builds the triangles a chunk of `chunk` at a time, in order, into one table whose
    /// memory each chunk reuses, and hands each to `each` with the index of its first
    /// triangle (every fallback counted).
    pub fn for_each_chunk(
        &self,
        chunk: usize,
        mut each: impl FnMut(&PatchTable, usize) -> Result<()>,
    ) -> Result<()> {
        let (n, chunk) = (self.mesh.triangles.len(), chunk.max(1));
        let mut table = self.empty_table();
        for start in (0..n).step_by(chunk) {
            self.range_into(start..(start + chunk).min(n), &mut table)?;
            each(&table, start)?;
        }
        Ok(())
    }

    /// A table of no patches of this scheme.
    pub fn empty_table(&self) -> PatchTable {
        PatchTable {
            scheme: self.scheme,
            kind: self.kind,
            stride: self.kind.stride(),
            points: Vec::new(),
            flat_normals: Vec::new(),
            fallbacks: 0,
        }
    }

    /// The fallbacks of `triangles` (built and dropped).
    pub fn fallbacks_of(&self, triangles: &[u32]) -> usize {
        let stride = self.kind.stride();
        triangles
            .par_iter()
            .map_init(
                || vec![DVec3::ZERO; stride],
                |buf, &t| self.inner.build(t as usize, buf),
            )
            .sum()
    }

    fn build_with(
        &self,
        n: usize,
        counted: usize,
        triangle: &(dyn Fn(usize) -> usize + Sync),
        table: &mut PatchTable,
    ) -> Result<()> {
        let mesh = self.mesh;
        let stride = self.kind.stride();
        *table = PatchTable {
            points: std::mem::take(&mut table.points),
            flat_normals: std::mem::take(&mut table.flat_normals),
            ..self.empty_table()
        };
        table.points.resize(n * stride, DVec3::ZERO);
        table.flat_normals.resize(n, DVec3::ZERO);
        // Fallbacks counted, and whether any control point is not finite (checked while
        // the patch is in cache; the first such one is looked up only on failure).
        let (fallbacks, bad) = table
            .points
            .par_chunks_mut(stride)
            .zip(table.flat_normals.par_iter_mut())
            .enumerate()
            .map(|(i, (out, flat))| {
                let t = triangle(i);
                let tri = mesh.triangles[t];
                *flat = crate::mesh::normals::face_normal(tri.map(|v| mesh.positions[v as usize]));
                let f = self.inner.build(t, out);
                let bad = !out.iter().all(|p| p.is_finite());
                (if i < counted { f } else { 0 }, bad)
            })
            .reduce(|| (0, false), |a, b| (a.0 + b.0, a.1 || b.1));
        table.fallbacks = fallbacks;
        if let Some(i) = bad
            .then(|| table.points.iter().position(|p| !p.is_finite()))
            .flatten()
        {
            return Err(Error::mesh(
                &mesh.name,
                format!(
                    "{}: patch {} has a non-finite control point (degenerate input)",
                    self.scheme,
                    triangle(i / stride)
                ),
            ));
        }
        Ok(())
    }
}
