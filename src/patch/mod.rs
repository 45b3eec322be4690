//! Patch tables: for each triangle of a mesh, the control points of one curved patch,
//! in f64, ignorant of the backend that evaluates them (OpenSubdiv's Far/Osd split).
//!
//! One scheme = one file here + one WGSL file in `shaders/`. A table is plain arrays
//! (`stride` points per patch, patch-major) so a GPU can take it as it is.

pub mod basis;
pub mod flat;
pub mod g1;
pub mod nagata;
pub mod nlsa;
pub mod phong;
pub mod pn;
pub mod quadratic;

use glam::DVec3;

use crate::mesh::Mesh;
use crate::{Error, Result};
use basis::Weights;

/// The surface construction applied to every triangle.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, clap::ValueEnum, serde::Serialize)]
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

impl Scheme {
    /// Every scheme, in the order reports list them.
    pub fn all() -> Vec<Scheme> {
        vec![
            Scheme::G1,
            Scheme::Phong,
            Scheme::Nagata,
            Scheme::NagataGuarded,
            Scheme::Nlsa,
            Scheme::Pn,
            Scheme::PnNormals,
            Scheme::Flat,
        ]
    }

    /// The name used on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            Scheme::G1 => "g1",
            Scheme::Phong => "phong",
            Scheme::Nagata => "nagata",
            Scheme::NagataGuarded => "nagata-guarded",
            Scheme::Nlsa => "nlsa",
            Scheme::Pn => "pn",
            Scheme::PnNormals => "pn-normals",
            Scheme::Flat => "flat",
        }
    }

    pub fn parse(s: &str) -> Result<Scheme> {
        Scheme::all()
            .into_iter()
            .find(|x| x.name() == s)
            .ok_or_else(|| {
                let names: Vec<_> = Scheme::all().iter().map(|x| x.name()).collect();
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
#[derive(Clone, Copy, Debug)]
pub struct SchemeOptions {
    /// Phong tessellation's shape factor α (default 3/4, the paper's).
    pub phong_alpha: f64,
}

impl Default for SchemeOptions {
    fn default() -> Self {
        SchemeOptions { phong_alpha: 0.75 }
    }
}

/// How a table's control points are evaluated.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum PatchKind {
    /// Bézier triangle of this degree; points in [`basis::bezier_powers`] order. The normal
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
pub const MIN_NORMAL_LEN_F64: f64 = 1e-300;
/// The same threshold for f32 evaluation (CPU SIMD kernel and f32 shaders).
pub const MIN_NORMAL_LEN_F32: f32 = 1e-30;

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

    /// Leading control points that are geometry (see [`Layout::geometry`]).
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
    pub fn weights(self, b: [f64; 3]) -> Weights {
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
    pub p: DVec3,
    /// ∂S/∂s along b = (1 − s − t, s, t).
    pub ds: DVec3,
    /// ∂S/∂t.
    pub dt: DVec3,
    /// Unit normal S_s × S_t / |S_s × S_t|, or the fallback described at [`unit_normal`].
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
    pub scheme: Scheme,
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
        let (kind, (points, fallbacks)) = match scheme {
            Scheme::G1 => (PatchKind::Gregory, g1::build(mesh)),
            Scheme::Phong => {
                if !opts.phong_alpha.is_finite() {
                    return Err(Error::Invalid(format!(
                        "phong: shape factor α must be finite, got {}",
                        opts.phong_alpha
                    )));
                }
                (PatchKind::Bezier(2), phong::build(mesh, opts.phong_alpha))
            }
            Scheme::Nagata => (
                PatchKind::Bezier(2),
                nagata::build(mesh, nagata::Guard::None),
            ),
            Scheme::NagataGuarded => (
                PatchKind::Bezier(2),
                nagata::build(mesh, nagata::Guard::Bounded),
            ),
            Scheme::Nlsa => (PatchKind::Bezier(2), nlsa::build(mesh)),
            Scheme::Pn => (PatchKind::Bezier(3), pn::build(mesh, false)),
            Scheme::PnNormals => (PatchKind::PnNormals, pn::build(mesh, true)),
            Scheme::Flat => (PatchKind::Bezier(1), flat::build(mesh)),
        };
        let flat_normals = mesh
            .triangles
            .iter()
            .map(|t| crate::mesh::normals::face_normal(t.map(|v| mesh.positions[v as usize])))
            .collect();
        let table = PatchTable {
            scheme,
            kind,
            stride: kind.stride(),
            points,
            flat_normals,
            fallbacks,
        };
        debug_assert_eq!(table.points.len(), table.stride * mesh.triangles.len());
        if let Some(i) = table.points.iter().position(|p| !p.is_finite()) {
            return Err(Error::mesh(
                &mesh.name,
                format!(
                    "{scheme}: patch {} has a non-finite control point (degenerate input)",
                    i / table.stride
                ),
            ));
        }
        Ok(table)
    }

    /// Number of patches.
    pub fn len(&self) -> usize {
        self.flat_normals.len()
    }

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
    pub fn eval_weights(&self, i: usize, w: &Weights) -> SurfacePoint {
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

    /// Evaluates patch `i` at barycentric `b` (b0 + b1 + b2 = 1; b_k weighs corner k).
    pub fn eval(&self, i: usize, b: [f64; 3]) -> SurfacePoint {
        self.eval_weights(i, &self.kind.weights(b))
    }
}
