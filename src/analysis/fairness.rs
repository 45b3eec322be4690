//! Fairness of a surface, from its patches' exact first and second derivatives: the
//! bending energy ∫ (κ₁² + κ₂²) dA, per patch and in total ([`BendingEnergy`]), and the
//! jump of the normal curvature across edges, the G2 defect ([`g2_defect`]).
//!
//! **Derivatives.** Every basis function's second derivatives are analytic (module `jet`):
//! the Bernstein monomials of the Bézier kinds (PnNormals: its cubic geometry; its normal
//! field is not the surface's), and the G1 patch's Gregory weights α = 12 x² g(y, z) with
//! g = y² z / (y + z) (β by symmetry), written through u = y / (y + z), v = z / (y + z):
//! g_yy = 2v³, g_yz = u³ + 3u²v, g_zz = −2u³ are bounded. At the patch corner x = 1 they
//! depend on the direction of approach; on an edge sample there the direction is the
//! edge's, which gives the limit along the edge.
//!
//! **Bending energy.** With E, F, G and L, M, N the two fundamental forms in the patch
//! parameters (s, t), κ₁² + κ₂² = 4H² − 2K and dA = |S_s × S_t| ds dt. Quadrature
//! ([`BendingEnergy`]): the domain is cut at its centroid and edge midpoints into six
//! triangles, each mapped from the unit square collapsed onto its patch corner (Duffy
//! 1982), where the G1 patch's direction-dependent corners become smooth (a symmetric
//! triangle rule on a uniform grid converges only as O(k⁻²) there: the 7-point rule of
//! degree 5 changed spot's G1 energy by 1.8e-3 from 8 × 8 to 16 × 16 cells). Each square
//! is cut into k × k cells, each integrated by the 3 × 3 Gauss–Legendre rule (degree 5 in
//! each variable, so O(h⁶) on smooth integrands; exact for polynomials of degree 4 in s, t)
//! and compared with the sum over its children: quarters, or at the corner its radial half
//! and the outer half in two. Where they differ by more than the tolerance (1e-4 of the
//! patch's energy), the children are refined alike, to [`MAX_DEPTH`] levels and
//! [`MAX_REFINED`] cells per patch. Defaults k = 2 and 1e-4: no test mesh's energy changes
//! by 1e-3 from k = 2 to k = 4 (figures in `docs/cli.md`). The basis derivatives at the
//! nodes of the base cells, their children and, for k ≤ 2, their grandchildren (the first
//! refinement) are computed once per kind ([`BendingEnergy::new`]); one patch allocates
//! nothing. At a fold (J = (S_s × S_t) · n_f ≤ 0, the validity certificate's criterion)
//! the energy is unbounded: such patches are counted apart, not summed.
//!
//! **G2 defect.** At the 21 samples per interior edge of the continuity statistics
//! ([`crate::analysis::stats::edge_pairs`]), each side's normal curvature in the direction
//! D = N × T across the edge (N the side's unit normal S_s × S_t / |S_s × S_t|, T the edge
//! tangent); the jump |κ_L − κ_R| (κ_R taken with N_L's orientation), its largest and mean
//! value over the non-crease interior edges, and both times the bounding-box diagonal
//! (dimensionless). A G2 surface has 0.

use glam::DVec3;
use rayon::prelude::*;
use serde::Serialize;

use super::jet::jet;
use crate::analysis::stats::{edge_pairs, SAMPLES_PER_EDGE};
use crate::eval::EdgeSide;
use crate::mesh::creases::{normal_key, use_normal};
use crate::mesh::{Adjacency, Mesh};
use crate::patch::basis::MAX_POINTS;
use crate::patch::validity::{check_table, Verdict};
use crate::patch::{PatchKind, PatchTable, MIN_NORMAL_LEN_F64};
use crate::{Error, Result};

/// The quadrature ([`BendingEnergy`]), in words.
pub const RULE: &str = "6 Duffy triangles per patch, k x k square cells each, 3x3 Gauss-Legendre \
                        per cell, adaptive";

/// Default cells per side of each of a patch's six Duffy squares (k): 2, so 24 base cells
/// and their 84 children, 972 nodes per patch before any refinement (see the figures in
/// `docs/cli.md`).
pub const DEFAULT_SUBDIVISIONS: u32 = 2;

/// Largest k accepted.
pub const MAX_SUBDIVISIONS: u32 = 8;

/// Base cells at most (6 k² at [`MAX_SUBDIVISIONS`]).
const MAX_BASE_CELLS: usize = 6 * (MAX_SUBDIVISIONS * MAX_SUBDIVISIONS) as usize;

/// Default tolerance of a cell (relative to the patch's energy): see
/// [`FairnessOptions::tolerance`].
pub const DEFAULT_TOLERANCE: f64 = 1e-4;

/// Options of the fairness measures: [`FairnessOptions::default()`] and `with_*`.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub struct FairnessOptions {
    /// Cells per side of each of a patch's six Duffy squares (k; default
    /// 2, 1 to 8).
    pub subdivisions: u32,
    /// A cell's integral is taken from its quarters where they differ from the cell's own
    /// by at most this fraction of the patch's energy, and refined otherwise (default
    /// 1e-4; above 0 and below 1).
    pub tolerance: f64,
}

impl FairnessOptions {
    /// Sets [`FairnessOptions::subdivisions`].
    pub fn with_subdivisions(mut self, subdivisions: u32) -> Self {
        self.subdivisions = subdivisions;
        self
    }

    /// Sets [`FairnessOptions::tolerance`].
    pub fn with_tolerance(mut self, tolerance: f64) -> Self {
        self.tolerance = tolerance;
        self
    }

    fn check(&self) -> Result<()> {
        if !(1..=MAX_SUBDIVISIONS).contains(&self.subdivisions) {
            return Err(Error::Invalid(format!(
                "fairness: {} subdivisions (1 to {MAX_SUBDIVISIONS})",
                self.subdivisions
            )));
        }
        if !(self.tolerance > 0.0 && self.tolerance < 1.0) {
            return Err(Error::Invalid(format!(
                "fairness: tolerance {} (above 0 and below 1)",
                self.tolerance
            )));
        }
        Ok(())
    }
}

impl Default for FairnessOptions {
    fn default() -> Self {
        FairnessOptions {
            subdivisions: DEFAULT_SUBDIVISIONS,
            tolerance: DEFAULT_TOLERANCE,
        }
    }
}

/// The 3-point Gauss–Legendre rule on [0, 1]: nodes and weights (summing to 1), exact for
/// polynomials of degree 5.
fn gauss3() -> [(f64, f64); 3] {
    let d = 0.15f64.sqrt();
    [
        (0.5 - d, 5.0 / 18.0),
        (0.5, 8.0 / 18.0),
        (0.5 + d, 5.0 / 18.0),
    ]
}

/// The six triangles of a patch's domain in (s, t), each a patch corner, the midpoint of an
/// edge at that corner and the centroid: each of area 1/12.
fn duffy_triangle(k: usize) -> [(f64, f64); 3] {
    let g = (1.0 / 3.0, 1.0 / 3.0);
    let corners = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0)];
    let mids = [(0.5, 0.0), (0.5, 0.5), (0.0, 0.5)];
    // Corner m with the midpoints of its edges m (to m + 1) and m − 1 (from m − 1).
    let m = k / 2;
    let mid = if k.is_multiple_of(2) {
        mids[m]
    } else {
        mids[(m + 2) % 3]
    };
    [corners[m], mid, g]
}

/// A cell [u, u + du] × [v, v + dv] of the unit square mapped onto Duffy triangle `tri`
/// (see [`Cell::nodes`]).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Cell {
    tri: usize,
    u: f64,
    v: f64,
    du: f64,
    dv: f64,
}

impl Cell {
    /// The cells it is refined into, the first `n` of the array. A cell on the side u = 0
    /// (at the patch corner) is halved radially, its outer half cut in two across (3
    /// children): refinement towards the corner then costs 3 cells per level, where
    /// quartering would double the cells along the side at every level. Others are
    /// quartered.
    fn children(self) -> ([Cell; 4], usize) {
        let (hu, hv) = (0.5 * self.du, 0.5 * self.dv);
        let cell = |u: f64, v: f64, du: f64, dv: f64| Cell {
            u: self.u + u,
            v: self.v + v,
            du,
            dv,
            ..self
        };
        if self.u == 0.0 {
            (
                [
                    cell(0.0, 0.0, hu, self.dv),
                    cell(hu, 0.0, hu, hv),
                    cell(hu, hv, hu, hv),
                    cell(hu, hv, hu, hv),
                ],
                3,
            )
        } else {
            (
                [
                    cell(0.0, 0.0, hu, hv),
                    cell(hu, 0.0, hu, hv),
                    cell(0.0, hv, hu, hv),
                    cell(hu, hv, hu, hv),
                ],
                4,
            )
        }
    }

    /// The 3 × 3 Gauss–Legendre nodes of the cell as barycentric points of the patch, with
    /// their weights: (u, v) ↦ C + u ((1 − v)(M − C) + v (G − C)) collapses the square's
    /// side u = 0 onto the patch corner C (Duffy 1982), with Jacobian u |(M − C) × (G − C)|
    /// = u / 6.
    fn nodes(self) -> impl Iterator<Item = ([f64; 3], f64)> {
        let [c, m, g] = duffy_triangle(self.tri);
        let rule = gauss3();
        rule.into_iter().flat_map(move |(x, wx)| {
            rule.into_iter().map(move |(y, wy)| {
                let (u, v) = (self.u + x * self.du, self.v + y * self.dv);
                let d = (
                    (1.0 - v) * (m.0 - c.0) + v * (g.0 - c.0),
                    (1.0 - v) * (m.1 - c.1) + v * (g.1 - c.1),
                );
                let (s, t) = (c.0 + u * d.0, c.1 + u * d.1);
                let weight = wx * wy * self.du * self.dv * u / 6.0;
                ([1.0 - s - t, s, t], weight)
            })
        })
    }
}

/// Nodes per cell.
const CELL_NODES: usize = 9;

/// A patch's geometry control points and the (unnormalised) normal of its triangle,
/// (c₁ − c₀) × (c₂ − c₀) of its corners.
#[derive(Clone, Copy)]
struct Geom<'a> {
    points: &'a [DVec3],
    flat: DVec3,
}

/// (κ₁² + κ₂²) |S_s × S_t| from S_s, S_t, S_ss, S_st, S_tt; none where the tangents are
/// parallel (|S_s × S_t| ≤ [`MIN_NORMAL_LEN_F64`]), where the patch is folded (J = (S_s ×
/// S_t) · `flat` ≤ 0, `flat` its triangle's normal: the validity certificate's criterion)
/// or where it is not finite.
#[inline]
fn energy_density(a: &[DVec3; 5], flat: DVec3) -> Option<f64> {
    let [su, sv, suu, suv, svv] = *a;
    let c = su.cross(sv);
    let w2 = c.length_squared();
    let w = w2.sqrt();
    if !(w > MIN_NORMAL_LEN_F64 && w.is_finite() && c.dot(flat) > 0.0) {
        return None;
    }
    let (e, f, g) = (su.dot(su), su.dot(sv), sv.dot(sv));
    // L, M, N times w = |S_s × S_t|: 2H = (eN − 2fM + gL) / w³ and K = (LN − M²) / w⁴ in
    // these, so (4H² − 2K) w = ((eN − 2fM + gL)² − 2w²(LN − M²)) / w⁵.
    let (l, m, n) = (suu.dot(c), suv.dot(c), svv.dot(c));
    let two_h = e * n - 2.0 * f * m + g * l;
    let density = (two_h * two_h - 2.0 * w2 * (l * n - m * m)) / (w2 * w2 * w);
    density.is_finite().then_some(density)
}

/// Σ weight × density over nodes given by their basis derivatives (`derivs`: per node, per
/// point of `c`); none where a node is singular. With AVX the three coordinates go in one
/// register: the same products and sums per coordinate, so bitwise the same result.
#[inline]
fn node_sum(p: Geom<'_>, derivs: &[[f64; 5]], weights: &[f64]) -> Option<f64> {
    #[cfg(target_arch = "x86_64")]
    if cpu_has!("avx") {
        // SAFETY: the CPU has AVX (checked just above).
        return unsafe { node_sum_avx(p, derivs, weights) };
    }
    node_sum_scalar(p, derivs, weights)
}

/// [`node_sum`] without SIMD.
fn node_sum_scalar(p: Geom<'_>, derivs: &[[f64; 5]], weights: &[f64]) -> Option<f64> {
    let c = p.points;
    let mut sum = 0.0;
    for (w, d) in weights.iter().zip(derivs.chunks_exact(c.len())) {
        let mut a = [DVec3::ZERO; 5];
        for (cj, dj) in c.iter().zip(d) {
            for (ak, wk) in a.iter_mut().zip(dj) {
                *ak += *wk * *cj;
            }
        }
        sum += w * energy_density(&a, p.flat)?;
    }
    Some(sum)
}

/// [`node_sum`] with S_s, ..., S_tt accumulated in AVX registers.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
fn node_sum_avx(p: Geom<'_>, derivs: &[[f64; 5]], weights: &[f64]) -> Option<f64> {
    use std::arch::x86_64::*;
    let c = p.points;
    let mask = _mm256_setr_epi64x(-1, -1, -1, 0);
    let mut points = [_mm256_setzero_pd(); MAX_POINTS];
    for (q, cj) in points.iter_mut().zip(c) {
        // SAFETY: reads the three f64 of `cj` (DVec3 is repr(C) x, y, z); the fourth lane
        // is masked off and not read.
        *q = unsafe { _mm256_maskload_pd(cj as *const DVec3 as *const f64, mask) };
    }
    let points = &points[..c.len().min(MAX_POINTS)];
    let out = |r: __m256d| {
        let mut a = [0.0f64; 4];
        // SAFETY: stores four f64 into a four-element array.
        unsafe { _mm256_storeu_pd(a.as_mut_ptr(), r) };
        DVec3::new(a[0], a[1], a[2])
    };
    let mut sum = 0.0;
    for (w, d) in weights.iter().zip(derivs.chunks_exact(c.len())) {
        let mut acc = [_mm256_setzero_pd(); 5];
        for (q, dj) in points.iter().zip(d) {
            for (ak, wk) in acc.iter_mut().zip(dj) {
                *ak = _mm256_add_pd(*ak, _mm256_mul_pd(_mm256_set1_pd(*wk), *q));
            }
        }
        sum += w * energy_density(&acc.map(out), p.flat)?;
    }
    Some(sum)
}

/// Deepest refinement below the children of a base cell: halving 40 times reaches 1e-12
/// of the cell's side.
pub const MAX_DEPTH: u32 = 40;

/// Most cells refined (their children evaluated, 27 or 36 nodes) per patch: a patch whose
/// integrand is not integrable (a fold, where S_s × S_t changes direction) stops there.
pub const MAX_REFINED: u32 = 1024;

/// The bending energy ∫ (κ₁² + κ₂²) dA of patches of one kind (module comment): the basis
/// derivatives at the nodes of the base cells and their quarters are computed once, here;
/// the nodes of deeper cells, where a patch needs them, on the way.
///
/// ```
/// use g1tess::{BendingEnergy, FairnessOptions, Mesh, PatchTable, Scheme};
///
/// let mesh = Mesh::load("icosphere:3", &Default::default())?;
/// let table = PatchTable::build(&mesh, Scheme::G1, &Default::default())?;
/// let energy = BendingEnergy::new(table.kind, &FairnessOptions::default())?;
/// let first = energy.patch(&table, 0); // one patch, no allocation
/// let total = energy.total(&table)?; // every patch, in parallel
/// // The unit sphere's is 8π; the G1 sphere of 1280 triangles is close.
/// assert!((total.energy / (8.0 * std::f64::consts::PI) - 1.0).abs() < 1e-5);
/// assert!(first > 0.0 && total.singular_patches == 0 && total.unresolved_patches == 0);
/// # Ok::<(), g1tess::Error>(())
/// ```
#[derive(Clone, Debug)]
pub struct BendingEnergy {
    kind: PatchKind,
    geometry: usize,
    opts: FairnessOptions,
    /// The base cells: k × k per Duffy triangle.
    cells: Vec<Cell>,
    /// First node of each base cell's family (its 9 nodes, then the 9 of each child), and
    /// the end.
    first: Vec<usize>,
    /// (w_s, w_t, w_ss, w_st, w_tt) of each geometry control point, node after node.
    derivs: Vec<[f64; 5]>,
    /// Quadrature weight of each node (same order).
    weights: Vec<f64>,
    /// The base cells' grandchildren (where k ≤ [`GRANDCHILDREN_UP_TO`]), the cells the
    /// refinement evaluates first: the first node of the grandchildren of each base cell's
    /// child q at `4 b + q`, and the end; their nodes as above.
    grand_first: Vec<usize>,
    grand_derivs: Vec<[f64; 5]>,
    grand_weights: Vec<f64>,
}

/// Largest k whose base cells' grandchildren [`BendingEnergy::new`] computes the nodes of:
/// 2.5 MB of basis derivatives at k = 2 for the G1 patch (24 base cells, 384
/// grandchildren); 4 k² times that above.
const GRANDCHILDREN_UP_TO: u32 = 2;

/// Energy of a whole table.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct EnergyTotal {
    /// Sum of the energies of the patches without a singular node.
    pub energy: f64,
    /// Patches left out: a node where S_s × S_t vanishes, turns against the triangle's
    /// normal (a fold) or is not finite.
    pub singular_patches: usize,
    /// Patches left out: the refinement stopped short of the tolerance
    /// ([`PatchEnergy::resolved`]).
    pub unresolved_patches: usize,
    /// The sum of the estimates of the unresolved patches (where they diverge, a lower
    /// bound that grows with the refinement).
    pub unresolved_energy: f64,
    /// Patches left out: not certified valid ([`BendingEnergy::total_certified`] only).
    pub uncertified_patches: usize,
}

/// One patch's energy with how it was found ([`BendingEnergy::measure`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PatchEnergy {
    /// The estimate: +∞ where a node is singular, NaN for too few points.
    pub energy: f64,
    /// Every cell met the tolerance within 40 halvings and 1,024 refined cells; where not,
    /// `energy` is the finest estimate reached, typically growing without bound with the
    /// refinement (an integrand that is not integrable).
    pub resolved: bool,
}

/// Patches per block of a parallel sum: blocks are summed in order, so the total does not
/// depend on the threads.
const ENERGY_BLOCK: usize = 256;

impl BendingEnergy {
    /// The rule for patches of `kind` with `opts` (errors: options out of range).
    pub fn new(kind: PatchKind, opts: &FairnessOptions) -> Result<BendingEnergy> {
        opts.check()?;
        let geometry = kind.geometry();
        let k = opts.subdivisions as usize;
        let size = 1.0 / k as f64;
        let mut cells = Vec::with_capacity(6 * k * k);
        for tri in 0..6 {
            for i in 0..k {
                for j in 0..k {
                    cells.push(Cell {
                        tri,
                        u: i as f64 * size,
                        v: j as f64 * size,
                        du: size,
                        dv: size,
                    });
                }
            }
        }
        let mut first = vec![0];
        let (mut derivs, mut weights) = (Vec::new(), Vec::new());
        let mut grand_first = vec![0];
        let (mut grand_derivs, mut grand_weights) = (Vec::new(), Vec::new());
        let push = |cells: &mut dyn Iterator<Item = Cell>,
                    derivs: &mut Vec<[f64; 5]>,
                    weights: &mut Vec<f64>| {
            for (b, w) in cells.flat_map(Cell::nodes) {
                let j = jet(kind, b, None);
                derivs.extend(
                    j.d[..geometry]
                        .iter()
                        .map(|d| [d[1], d[2], d[3], d[4], d[5]]),
                );
                weights.push(w);
            }
        };
        for cell in &cells {
            let (children, n) = cell.children();
            let family = std::iter::once(*cell).chain(children.into_iter().take(n));
            push(&mut family.into_iter(), &mut derivs, &mut weights);
            first.push(weights.len());
            if opts.subdivisions > GRANDCHILDREN_UP_TO {
                continue;
            }
            // Four slots per base cell, empty past its n children.
            for (q, child) in children.iter().enumerate() {
                if q < n {
                    let (grand, m) = child.children();
                    let mut grand = grand.into_iter().take(m);
                    push(&mut grand, &mut grand_derivs, &mut grand_weights);
                }
                grand_first.push(grand_weights.len());
            }
        }
        Ok(BendingEnergy {
            kind,
            geometry,
            opts: *opts,
            cells,
            first,
            derivs,
            weights,
            grand_first,
            grand_derivs,
            grand_weights,
        })
    }

    /// The patch kind it integrates.
    pub fn kind(&self) -> PatchKind {
        self.kind
    }

    /// Its options.
    pub fn options(&self) -> &FairnessOptions {
        &self.opts
    }

    /// The geometry points `c` of a patch with its triangle's normal.
    fn geom<'a>(&self, c: &'a [DVec3]) -> Geom<'a> {
        let [a, b, d] = self.kind.layout().corners.map(|k| c[k]);
        Geom {
            points: c,
            flat: (b - a).cross(d - a),
        }
    }

    /// The precomputed nodes of base cell `b`: `part` 0 is the cell, 1.. its children.
    fn family(&self, b: usize, part: std::ops::Range<usize>) -> (&[[f64; 5]], &[f64]) {
        let n = self.first[b];
        let r = n + part.start * CELL_NODES..(n + part.end * CELL_NODES).min(self.first[b + 1]);
        let g = self.geometry;
        (&self.derivs[r.start * g..r.end * g], &self.weights[r])
    }

    /// The precomputed nodes of grandchild `i` of base cell `b` through its child `q`
    /// (slot `4 b + q`), where [`BendingEnergy::new`] computed them.
    fn grandchild(&self, slot: usize, i: usize) -> Option<(&[[f64; 5]], &[f64])> {
        let start = *self.grand_first.get(slot)? + i * CELL_NODES;
        let r = start..start + CELL_NODES;
        if r.end > *self.grand_first.get(slot + 1)? {
            return None;
        }
        let g = self.geometry;
        Some((
            &self.grand_derivs[r.start * g..r.end * g],
            &self.grand_weights[r],
        ))
    }

    /// The integral over `cell`, its nodes evaluated here: their basis derivatives on the
    /// stack, summed by [`node_sum`] as the precomputed nodes are.
    fn cell_sum(&self, p: Geom<'_>, cell: Cell) -> Option<f64> {
        let g = self.geometry;
        let mut derivs = [[0.0; 5]; CELL_NODES * MAX_POINTS];
        let mut weights = [0.0; CELL_NODES];
        for (i, (b, w)) in cell.nodes().enumerate() {
            let j = jet(self.kind, b, None);
            for (out, d) in derivs[i * g..(i + 1) * g].iter_mut().zip(&j.d) {
                *out = [d[1], d[2], d[3], d[4], d[5]];
            }
            weights[i] = w;
        }
        node_sum(p, &derivs[..CELL_NODES * g], &weights)
    }

    /// The integral over `cell` whose rule gave `whole`: the sum over its children
    /// ([`Cell::children`]) where it is within `tol` of `whole`, else each child refined;
    /// with whether every cell met the tolerance (none where a node is singular). Each
    /// evaluation of children takes one of `budget`; with none left, or at [`MAX_DEPTH`],
    /// the estimate is taken as it is. `slot`: where the children's nodes are precomputed
    /// ([`Self::grandchild`]); the same sums as computed here.
    #[allow(clippy::too_many_arguments)]
    fn refine(
        &self,
        c: Geom<'_>,
        cell: Cell,
        whole: f64,
        tol: f64,
        depth: u32,
        budget: &mut u32,
        slot: Option<usize>,
    ) -> Option<(f64, bool)> {
        if *budget == 0 || depth > MAX_DEPTH {
            return Some((whole, false));
        }
        *budget -= 1;
        let (children, n) = cell.children();
        let mut parts = [0.0; 4];
        for (i, (p, q)) in parts.iter_mut().zip(&children[..n]).enumerate() {
            *p = match slot.and_then(|k| self.grandchild(k, i)) {
                Some((d, w)) => node_sum(c, d, w)?,
                None => self.cell_sum(c, *q)?,
            };
        }
        let sum: f64 = parts[..n].iter().sum();
        if (sum - whole).abs() <= tol {
            return Some((sum, true));
        }
        let mut total = (0.0, true);
        for (p, q) in parts.into_iter().zip(&children[..n]) {
            let (e, ok) = self.refine(c, *q, p, tol, depth + 1, budget, None)?;
            total = (total.0 + e, total.1 && ok);
        }
        Some(total)
    }

    /// The adaptive energy of one patch's geometry points `c`.
    fn adaptive(&self, c: Geom<'_>) -> PatchEnergy {
        const SINGULAR: PatchEnergy = PatchEnergy {
            energy: f64::INFINITY,
            resolved: true,
        };
        // Every base cell's rule and its children's (summed), kept on the stack.
        let mut base = [[0.0f64; 2]; MAX_BASE_CELLS];
        let mut reference = 0.0;
        for (b, slot) in base.iter_mut().enumerate().take(self.cells.len()) {
            let (d, w) = self.family(b, 0..1);
            let Some(whole) = node_sum(c, d, w) else {
                return SINGULAR;
            };
            let (d, w) = self.family(b, 1..5);
            let Some(children) = node_sum(c, d, w) else {
                return SINGULAR;
            };
            *slot = [whole, children];
            reference += children;
        }
        let first = self.settle(c, &base[..self.cells.len()], reference);
        // Where the refinement found far more than the base cells showed (a concentrated
        // integrand), their tolerance was too strict for the patch: once more against what
        // was found.
        if first.energy.is_finite() && first.energy > 2.0 * reference {
            return self.settle(c, &base[..self.cells.len()], first.energy);
        }
        first
    }

    /// The patch's integral from its base cells' rules (`base`: each cell's and its
    /// children's), refining the cells that miss the tolerance relative to `reference`.
    fn settle(&self, c: Geom<'_>, base: &[[f64; 2]], reference: f64) -> PatchEnergy {
        const SINGULAR: PatchEnergy = PatchEnergy {
            energy: f64::INFINITY,
            resolved: true,
        };
        let mut budget = MAX_REFINED;
        // A floor for flat patches, whose rounding is no error to chase.
        let tol = self.opts.tolerance * reference.abs().max(1e-12);
        let mut out = PatchEnergy {
            energy: 0.0,
            resolved: true,
        };
        for (b, &[whole, children]) in base.iter().enumerate() {
            if (children - whole).abs() <= tol {
                out.energy += children;
                continue;
            }
            let (cells, n) = self.cells[b].children();
            for (q, cell) in cells.into_iter().take(n).enumerate() {
                let (d, w) = self.family(b, q + 1..q + 2);
                let Some(part) = node_sum(c, d, w) else {
                    return SINGULAR;
                };
                let slot = Some(4 * b + q);
                let Some((e, ok)) = self.refine(c, cell, part, tol, 1, &mut budget, slot) else {
                    return SINGULAR;
                };
                out.energy += e;
                out.resolved &= ok;
            }
        }
        out
    }

    /// The energy of one patch of this kind from its control points (a table's
    /// [`PatchTable::patch`], or candidates of an optimiser), adaptive (module comment):
    /// +∞ where a node is singular (S_s × S_t vanishes there), NaN where fewer than the
    /// kind's geometry points are given. Allocates nothing.
    pub fn points(&self, points: &[DVec3]) -> f64 {
        self.measure(points).energy
    }

    /// [`Self::points`] with whether the refinement met the tolerance.
    pub fn measure(&self, points: &[DVec3]) -> PatchEnergy {
        match points.get(..self.geometry) {
            Some(c) => self.adaptive(self.geom(c)),
            None => PatchEnergy {
                energy: f64::NAN,
                resolved: false,
            },
        }
    }

    /// [`Self::points`] by the fixed rule of the quarters of the base cells only (no
    /// refinement): a smooth function of the control points, for optimisers, and cheaper;
    /// exact where the integrand is smooth enough for it.
    pub fn points_fixed(&self, points: &[DVec3]) -> f64 {
        let Some(c) = points.get(..self.geometry) else {
            return f64::NAN;
        };
        let c = self.geom(c);
        let mut sum = 0.0;
        for b in 0..self.cells.len() {
            let (d, w) = self.family(b, 1..5);
            match node_sum(c, d, w) {
                Some(e) => sum += e,
                None => return f64::INFINITY,
            }
        }
        sum
    }

    /// The energy of patch `i` of `table` (a table of this kind; see [`Self::points`]).
    pub fn patch(&self, table: &PatchTable, i: usize) -> f64 {
        self.points(table.patch(i))
    }

    fn check(&self, table: &PatchTable) -> Result<()> {
        if table.kind == self.kind {
            Ok(())
        } else {
            Err(Error::Invalid(format!(
                "bending energy: a table of {:?} patches given to the rule of {:?}",
                table.kind, self.kind
            )))
        }
    }

    /// The energy of every patch of `table`, in parallel (+∞ where singular).
    pub fn energies(&self, table: &PatchTable) -> Result<Vec<f64>> {
        self.check(table)?;
        Ok((0..table.len())
            .into_par_iter()
            .map(|i| self.patch(table, i))
            .collect())
    }

    /// The energy of the whole table, in parallel; bitwise the same whatever the threads.
    /// Folds that no node sees are not found here: see [`Self::total_certified`].
    pub fn total(&self, table: &PatchTable) -> Result<EnergyTotal> {
        self.sum(table, None)
    }

    /// [`Self::total`] of the patches certified valid (`verdicts`, one per patch, from
    /// [`crate::check_table`]); the others are counted in
    /// [`EnergyTotal::uncertified_patches`]. A folded patch's energy is unbounded (its
    /// curvature grows without bound about the fold): left out, it is named, not summed.
    pub fn total_certified(&self, table: &PatchTable, verdicts: &[Verdict]) -> Result<EnergyTotal> {
        if verdicts.len() != table.len() {
            return Err(Error::Invalid(format!(
                "bending energy: {} verdicts for {} patches",
                verdicts.len(),
                table.len()
            )));
        }
        self.sum(table, Some(verdicts))
    }

    fn sum(&self, table: &PatchTable, verdicts: Option<&[Verdict]>) -> Result<EnergyTotal> {
        self.check(table)?;
        Ok(sum_parts(table.len(), |i| {
            let left_out = verdicts.is_some_and(|v| v[i] != Verdict::Valid);
            (!left_out).then(|| self.part(table, i))
        }))
    }

    /// The energy of patch `i` of `table` (of this kind) as [`Self::total`] finds it.
    fn part(&self, table: &PatchTable, i: usize) -> PatchEnergy {
        self.adaptive(self.geom(&table.patch(i)[..self.geometry]))
    }

    /// [`Self::part`] of every patch of `table` that `wanted` names, `None` for the others, in
    /// parallel: a chunk's share of [`total_of_parts`] (the caller holds no table of the
    /// whole mesh).
    pub(crate) fn parts(
        &self,
        table: &PatchTable,
        wanted: impl Fn(usize) -> bool + Sync,
    ) -> Result<Vec<Option<PatchEnergy>>> {
        self.check(table)?;
        Ok((0..table.len())
            .into_par_iter()
            .map(|i| wanted(i).then(|| self.part(table, i)))
            .collect())
    }
}

/// The total of one energy per patch (`None`: left out, not certified), summed as
/// [`BendingEnergy::total_certified`] sums them: bitwise its total where the parts are its
/// patches' energies.
pub(crate) fn total_of_parts(parts: &[Option<PatchEnergy>]) -> EnergyTotal {
    sum_parts(parts.len(), |i| parts[i])
}

/// The sum of `n` patches' parts (`part(i)`, `None` where left out) in blocks of
/// [`ENERGY_BLOCK`], each in order, the blocks in parallel and added in order.
fn sum_parts(n: usize, part: impl Fn(usize) -> Option<PatchEnergy> + Sync) -> EnergyTotal {
    let blocks: Vec<EnergyTotal> = (0..n.div_ceil(ENERGY_BLOCK))
        .into_par_iter()
        .map(|b| {
            let mut t = EnergyTotal::default();
            for i in b * ENERGY_BLOCK..((b + 1) * ENERGY_BLOCK).min(n) {
                let Some(e) = part(i) else {
                    t.uncertified_patches += 1;
                    continue;
                };
                if !e.energy.is_finite() {
                    t.singular_patches += 1;
                } else if e.resolved {
                    t.energy += e.energy;
                } else {
                    t.unresolved_patches += 1;
                    t.unresolved_energy += e.energy;
                }
            }
            t
        })
        .collect();
    blocks
        .iter()
        .fold(EnergyTotal::default(), |a, b| EnergyTotal {
            energy: a.energy + b.energy,
            singular_patches: a.singular_patches + b.singular_patches,
            unresolved_patches: a.unresolved_patches + b.unresolved_patches,
            unresolved_energy: a.unresolved_energy + b.unresolved_energy,
            uncertified_patches: a.uncertified_patches + b.uncertified_patches,
        })
}

/// The normal curvature, in the direction across an edge, of a surface with derivatives
/// S_s, S_t, S_ss, S_st, S_tt (`a`), where the edge runs along (ts, tt) in (s, t); and
/// the unit normal it is taken against. None where S_s × S_t vanishes.
#[inline]
fn curvature_across(a: &[DVec3; 5], (ts, tt): (f64, f64)) -> Option<(f64, DVec3)> {
    let [su, sv, suu, suv, svv] = *a;
    let c = su.cross(sv);
    let w2 = c.length_squared();
    let w = w2.sqrt();
    if !(w > MIN_NORMAL_LEN_F64 && w.is_finite()) {
        return None;
    }
    let n = c / w;
    let d = n.cross(ts * su + tt * sv);
    // D = a S_s + b S_t: the first fundamental form's system, solved by Cramer's rule.
    let (e, f, g) = (su.dot(su), su.dot(sv), sv.dot(sv));
    let (p, q) = (d.dot(su), d.dot(sv));
    let (da, db) = ((g * p - f * q) / w2, (e * q - f * p) / w2);
    let len2 = (da * su + db * sv).length_squared();
    let k = n.dot(da * da * suu + 2.0 * da * db * suv + db * db * svv) / len2;
    k.is_finite().then_some((k, n))
}

/// Basis derivatives of one patch kind at every edge sample of the statistics, for each
/// ordered pair of corners (from, to).
struct EdgeProbe {
    geometry: usize,
    /// (w_s, w_t, w_ss, w_st, w_tt) per geometry point, per sample, per (from, to).
    derivs: Vec<[f64; 5]>,
}

impl EdgeProbe {
    fn new(kind: PatchKind, pattern: &crate::eval::EdgePairs) -> EdgeProbe {
        let geometry = kind.geometry();
        let n = pattern.samples;
        let mut derivs = Vec::with_capacity(9 * n as usize * geometry);
        for from in 0..3u8 {
            for to in 0..3u8 {
                for i in 0..n {
                    let side = EdgeSide { patch: 0, from, to };
                    let b = pattern.barycentric(side, i);
                    // At an end, the corner is approached along the edge from the other.
                    let toward = if b[from as usize] == 1.0 {
                        Some(to as usize)
                    } else {
                        Some(from as usize)
                    };
                    let j = jet(kind, b, (from != to).then_some(toward).flatten());
                    derivs.extend(
                        j.d[..geometry]
                            .iter()
                            .map(|d| [d[1], d[2], d[3], d[4], d[5]]),
                    );
                }
            }
        }
        EdgeProbe { geometry, derivs }
    }

    /// Normal curvature across the edge of `side` at sample `i` (see
    /// [`curvature_across`]).
    fn side(&self, table: &PatchTable, side: EdgeSide, i: u32) -> Option<(f64, DVec3)> {
        let g = self.geometry;
        let (from, to) = (side.from as usize, side.to as usize);
        let per = self.derivs.len() / (9 * g);
        let at = ((3 * from + to) * per + i as usize) * g;
        let d = &self.derivs[at..at + g];
        let mut a = [DVec3::ZERO; 5];
        for (cj, dj) in table.patch(side.patch as usize).iter().zip(d) {
            for (ak, wk) in a.iter_mut().zip(dj) {
                *ak += *wk * *cj;
            }
        }
        // The edge direction in (s, t): b = (1 − τ) e_from + τ e_to with s = b1, t = b2.
        let unit = |k: usize, c: usize| (k == c) as i32 as f64;
        let dir = (unit(to, 1) - unit(from, 1), unit(to, 2) - unit(from, 2));
        curvature_across(&a, dir)
    }
}

/// The jump of the normal curvature across the interior edges that are not creases.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct G2Defect {
    /// Non-crease interior edges measured.
    pub edges: usize,
    /// Non-crease interior edges left out: a side not certified valid ([`fairness`] only).
    pub uncertified_edges: usize,
    /// Edge samples measured (21 per edge, less those with a singular side).
    pub samples: usize,
    /// Samples left out: S_s × S_t vanishes on a side.
    pub singular_samples: usize,
    /// Largest |κ_L − κ_R| (0 without samples), in inverse length units.
    pub max: f64,
    /// Mean |κ_L − κ_R| over the samples (0 without samples).
    pub mean: f64,
    /// `max` times the bounding-box diagonal (dimensionless).
    pub max_relative: f64,
    /// `mean` times the bounding-box diagonal.
    pub mean_relative: f64,
    /// The edge (its two vertices) where the largest jump is.
    pub worst_edge: Option<[u32; 2]>,
}

/// Running sums of the G2 defect over a block of edges.
#[derive(Clone, Copy, Default)]
struct JumpPart {
    samples: usize,
    singular: usize,
    sum: f64,
    max: f64,
    worst: Option<[u32; 2]>,
}

impl JumpPart {
    fn merge(mut self, b: &JumpPart) -> JumpPart {
        self.samples += b.samples;
        self.singular += b.singular;
        self.sum += b.sum;
        if b.max > self.max {
            self.max = b.max;
            self.worst = b.worst;
        }
        self
    }
}

/// Edges per block of the parallel G2 defect (merged in order: bitwise the same result
/// whatever the threads).
const EDGE_BLOCK: usize = 1024;

/// The G2 defect of `table` (the whole mesh's) over the non-crease interior edges of
/// `mesh`, at the edge samples of the continuity statistics. Parallel, deterministic.
pub fn g2_defect(mesh: &Mesh, adjacency: &Adjacency, table: &PatchTable) -> Result<G2Defect> {
    g2_defect_of(mesh, adjacency, table, None)
}

/// [`g2_defect`] over the edges whose two patches are certified valid (`verdicts`, where
/// given); the others are counted in [`G2Defect::uncertified_edges`].
fn g2_defect_of(
    mesh: &Mesh,
    adjacency: &Adjacency,
    table: &PatchTable,
    verdicts: Option<&[Verdict]>,
) -> Result<G2Defect> {
    same_size(mesh, table)?;
    let pattern = edge_pairs(mesh, adjacency);
    let mut uncertified = 0;
    let edges: Vec<([u32; 2], [EdgeSide; 2])> = adjacency
        .interior_edges()
        .zip(&pattern.pairs)
        .filter(|(e, _)| {
            !e.v.iter().any(|&x| {
                normal_key(use_normal(mesh, e.uses[0], x))
                    != normal_key(use_normal(mesh, e.uses[1], x))
            })
        })
        .filter(|(_, sides)| {
            let valid = verdicts
                .is_none_or(|v| sides.iter().all(|s| v[s.patch as usize] == Verdict::Valid));
            uncertified += !valid as usize;
            valid
        })
        .map(|(e, sides)| (e.v, *sides))
        .collect();
    let probe = EdgeProbe::new(table.kind, &pattern);
    let parts: Vec<JumpPart> = edges
        .par_chunks(EDGE_BLOCK)
        .map(|block| {
            let mut part = JumpPart::default();
            for (v, sides) in block {
                for i in 0..SAMPLES_PER_EDGE {
                    let (Some((kl, nl)), Some((kr, nr))) = (
                        probe.side(table, sides[0], i),
                        probe.side(table, sides[1], i),
                    ) else {
                        part.singular += 1;
                        continue;
                    };
                    let kr = if nl.dot(nr) < 0.0 { -kr } else { kr };
                    let jump = (kl - kr).abs();
                    part.samples += 1;
                    part.sum += jump;
                    if jump > part.max {
                        part.max = jump;
                        part.worst = Some(*v);
                    }
                }
            }
            part
        })
        .collect();
    let total = parts.iter().fold(JumpPart::default(), |a, b| a.merge(b));
    let diagonal = mesh.diagonal();
    let mean = if total.samples > 0 {
        total.sum / total.samples as f64
    } else {
        0.0
    };
    Ok(G2Defect {
        edges: edges.len(),
        uncertified_edges: uncertified,
        samples: total.samples,
        singular_samples: total.singular,
        max: total.max,
        mean,
        max_relative: total.max * diagonal,
        mean_relative: mean * diagonal,
        worst_edge: total.worst,
    })
}

fn same_size(mesh: &Mesh, table: &PatchTable) -> Result<()> {
    if table.len() == mesh.triangles.len() {
        return Ok(());
    }
    Err(Error::mesh(
        &mesh.name,
        format!(
            "patch table of {} patches for {} triangles",
            table.len(),
            mesh.triangles.len()
        ),
    ))
}

/// The fairness measures of one surface ([`fairness`]).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FairnessReport {
    /// Bending energy ∫ (κ₁² + κ₂²) dA of the patches certified valid, less those
    /// counted below (dimensionless).
    pub energy: f64,
    /// Patches left out of `energy`: not certified valid (folded or undecided; the
    /// statistics' `patches` say which).
    pub uncertified_patches: usize,
    /// Patches left out of `energy`: a node where S_s × S_t vanishes.
    pub singular_patches: usize,
    /// Patches left out of `energy`: the refinement stopped short of the tolerance.
    pub unresolved_patches: usize,
    /// Their estimates' sum (a lower bound where they diverge).
    pub unresolved_energy: f64,
    /// The quadrature, in words: six Duffy triangles per patch, k × k square cells each,
    /// 3 × 3 Gauss–Legendre per cell, adaptive.
    pub rule: &'static str,
    /// Cells per side of each Duffy square (k).
    pub subdivisions: u32,
    /// Tolerance of a cell, relative to its patch's energy.
    pub tolerance: f64,
    /// The jump of normal curvature across the non-crease interior edges.
    pub g2: G2Defect,
}

impl FairnessReport {
    /// Human-readable summary, two lines.
    pub fn to_text(&self) -> String {
        let g = &self.g2;
        let g2 = if g.samples == 0 {
            "G2 defect: no non-crease interior edge".to_string()
        } else {
            format!(
                "G2 defect |κL-κR| across {} non-crease edges ({} samples): max {:.3e} \
                 mean {:.3e} (× bbox diagonal: max {:.3e} mean {:.3e})",
                g.edges, g.samples, g.max, g.mean, g.max_relative, g.mean_relative
            )
        };
        let mut notes = Vec::new();
        if self.uncertified_patches > 0 {
            notes.push(format!(
                "{} patches not certified valid left out",
                self.uncertified_patches
            ));
        }
        if self.singular_patches > 0 {
            notes.push(format!(
                "{} singular patches left out",
                self.singular_patches
            ));
        }
        if self.unresolved_patches > 0 {
            notes.push(format!(
                "{} patches left out, not integrable to the tolerance (estimates {:.3e} and \
                 growing with the refinement)",
                self.unresolved_patches, self.unresolved_energy
            ));
        }
        if g.uncertified_edges > 0 {
            notes.push(format!(
                "{} edges beside them left out of the G2 defect",
                g.uncertified_edges
            ));
        }
        if g.singular_samples > 0 {
            notes.push(format!(
                "{} singular edge samples left out",
                g.singular_samples
            ));
        }
        let notes: String = notes.iter().map(|n| format!(" · {n}")).collect();
        format!(
            "bending energy ∫(κ1²+κ2²)dA {:.6e} (Duffy squares of {k}×{k} cells, 3×3 \
             Gauss-Legendre, adaptive to {:.0e} per cell){notes}\n{g2}",
            self.energy,
            self.tolerance,
            k = self.subdivisions,
        )
    }
}

/// The fairness measures of `table` (the whole mesh's patches of one scheme): the bending
/// energy of its patches certified valid ([`BendingEnergy::total_certified`], the
/// certificate run here) and its G2 defect ([`g2_defect`]) across the edges between them.
pub fn fairness(
    mesh: &Mesh,
    adjacency: &Adjacency,
    table: &PatchTable,
    opts: &FairnessOptions,
) -> Result<FairnessReport> {
    same_size(mesh, table)?;
    let rule = BendingEnergy::new(table.kind, opts)?;
    let verdicts = check_table(table);
    let energy = rule.total_certified(table, &verdicts)?;
    Ok(FairnessReport {
        energy: energy.energy,
        uncertified_patches: energy.uncertified_patches,
        singular_patches: energy.singular_patches,
        unresolved_patches: energy.unresolved_patches,
        unresolved_energy: energy.unresolved_energy,
        rule: RULE,
        subdivisions: opts.subdivisions,
        tolerance: opts.tolerance,
        g2: g2_defect_of(mesh, adjacency, table, Some(&verdicts))?,
    })
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use super::{jet, EdgeProbe};
    use crate::analysis::stats::SAMPLES_PER_EDGE;
    use crate::eval::EdgePairs;
    use crate::patch::{PatchKind, PatchTable, Scheme, SchemeOptions};
    use crate::{LoadOptions, Mesh};

    /// Interior points, a point on an edge and points near corners.
    const POINTS: [[f64; 3]; 6] = [
        [0.2, 0.3, 0.5],
        [0.6, 0.25, 0.15],
        [0.1, 0.1, 0.8],
        [0.45, 0.55, 0.0],
        [0.98, 0.01, 0.01],
        [0.05, 0.9, 0.05],
    ];

    /// The tables of every kind on Suzanne (irregular triangles, estimated normals).
    fn tables() -> Vec<PatchTable> {
        let path = format!("{}/tests/data/suzanne.obj", env!("CARGO_MANIFEST_DIR"));
        let mesh = Mesh::load(&path, &LoadOptions::default()).unwrap();
        [
            Scheme::G1,
            Scheme::Flat,
            Scheme::Phong,
            Scheme::Pn,
            Scheme::PnNormals,
        ]
        .iter()
        .map(|&s| PatchTable::build(&mesh, s, &SchemeOptions::default()).unwrap())
        .collect()
    }

    /// The jets' values and first derivatives are the evaluators' basis (`PatchKind::
    /// weights`), up to the rounding of differently ordered sums.
    #[test]
    fn first_order_is_the_basis_of_every_kind() {
        for kind in PatchKind::all() {
            for b in POINTS {
                let w = kind.weights(b);
                let j = jet(kind, b, None);
                for p in 0..kind.geometry() {
                    let d = j.d[p];
                    for (got, want) in [(d[0], w.w[p]), (d[1], w.ws[p]), (d[2], w.wt[p])] {
                        // Weights and derivatives are below 50 in size: 1e-13 is a few
                        // hundred ulps of them.
                        assert!((got - want).abs() < 1e-13, "{kind:?} {b:?} point {p}");
                    }
                }
            }
        }
    }

    /// Central second differences of patch `i`'s positions (`PatchTable::eval`) at `b`
    /// with step `h` in s and t: S_ss, S_st, S_tt.
    fn central(table: &PatchTable, i: usize, b: [f64; 3], h: f64) -> [DVec3; 3] {
        let at = |ds: f64, dt: f64| {
            let (s, t) = (b[1] + ds * h, b[2] + dt * h);
            table.eval(i, [1.0 - s - t, s, t]).p
        };
        let p0 = at(0.0, 0.0);
        [
            (at(1.0, 0.0) - 2.0 * p0 + at(-1.0, 0.0)) / (h * h),
            (at(1.0, 1.0) - at(1.0, -1.0) - at(-1.0, 1.0) + at(-1.0, -1.0)) / (4.0 * h * h),
            (at(0.0, 1.0) - 2.0 * p0 + at(0.0, -1.0)) / (h * h),
        ]
    }

    /// S_ss, S_st and S_tt from the jets agree with central differences of the positions
    /// `PatchTable::eval` returns, on every kind. The differences' error is c h² (measured
    /// on the G1 patches: 94 h² of the patch's size, falling 4× per halving of h, so the
    /// jets are their limit); Richardson's extrapolation (4 D(h/2) − D(h)) / 3 removes that
    /// term and leaves O(h⁴) plus rounding.
    #[test]
    fn second_derivatives_match_central_differences_of_positions() {
        let h = 2e-3;
        let mut worst: f64 = 0.0;
        for table in tables() {
            for i in (0..table.len()).step_by(37) {
                let c = table.patch(i);
                // The patch's size, the scale of its derivatives.
                let size = c.iter().map(|p| (*p - c[0]).length()).fold(0.0, f64::max);
                for b in &POINTS[..3] {
                    let (coarse, fine) =
                        (central(&table, i, *b, h), central(&table, i, *b, h / 2.0));
                    let d = jet(table.kind, *b, None).apply(table.patch(i));
                    let p = table.eval(i, *b).p;
                    assert!((d[0] - p).length() <= 1e-14 * (1.0 + p.length()));
                    for k in 0..3 {
                        let extrapolated = (4.0 * fine[k] - coarse[k]) / 3.0;
                        let err = (d[3 + k] - extrapolated).length() / size;
                        worst = worst.max(err);
                        // Left after extrapolation: the h⁴ term, (94 h²)² ≈ 1e-8 of the
                        // size, and rounding, about 8 ε |S| / (h/2)² ≈ 2e-9 |S| with |S| /
                        // size up to about 50 (Suzanne's unit-sized head, patches of 0.02
                        // to 0.2): 1e-7 of the size. 1e-6 leaves a margin of 10.
                        assert!(
                            err < 1e-6,
                            "{:?} patch {i} {b:?} derivative {k}: {err}",
                            table.kind
                        );
                    }
                }
            }
        }
        eprintln!("largest relative difference to extrapolated central differences: {worst:.2e}");
    }

    /// At an edge sample on a patch corner, the G1 patch's second derivatives are those of
    /// the limit along the edge: close to the jets a little way along it.
    #[test]
    fn corner_samples_are_the_limit_along_the_edge() {
        let table = tables().remove(0);
        assert_eq!(table.kind, PatchKind::Gregory);
        let pattern = EdgePairs {
            samples: SAMPLES_PER_EDGE,
            pairs: Vec::new(),
        };
        let probe = EdgeProbe::new(table.kind, &pattern);
        let tau = 1e-7;
        let mut worst: f64 = 0.0;
        for i in (0..table.len()).step_by(29) {
            for (from, to) in [(0u8, 1u8), (1, 0), (1, 2), (2, 1), (2, 0), (0, 2)] {
                let g = probe.geometry;
                let per = SAMPLES_PER_EDGE as usize;
                let at = (3 * from as usize + to as usize) * per * g;
                let mut b = [0.0; 3];
                b[from as usize] = 1.0 - tau;
                b[to as usize] = tau;
                let near = jet(table.kind, b, None).apply(table.patch(i));
                let mut corner = [DVec3::ZERO; 5];
                for (cj, dj) in table.patch(i).iter().zip(&probe.derivs[at..at + g]) {
                    for (a, w) in corner.iter_mut().zip(dj) {
                        *a += *w * *cj;
                    }
                }
                let scale = near[3].length() + near[4].length() + near[5].length();
                for k in 0..5 {
                    let err = (corner[k] - near[k + 1]).length() / scale;
                    worst = worst.max(err);
                    // The derivatives change by O(τ) along the edge: 1e-7 times a few
                    // hundred (their own derivatives over their size).
                    assert!(err < 1e-4, "patch {i} {from}->{to} derivative {k}: {err}");
                }
            }
        }
        eprintln!("largest relative difference at corners: {worst:.2e}");
    }

    /// The AVX sums are the scalar sums, bit for bit (the same products and sums per
    /// coordinate), on every base node of the G1 patches of Suzanne.
    #[test]
    fn simd_node_sums_are_the_scalar_ones() {
        use super::{node_sum, node_sum_scalar, BendingEnergy, FairnessOptions};
        let table = tables().remove(0);
        let e = BendingEnergy::new(table.kind, &FairnessOptions::default()).unwrap();
        let mut compared = 0;
        for i in 0..table.len() {
            let g = e.geom(&table.patch(i)[..18]);
            let (a, b) = (
                node_sum_scalar(g, &e.derivs, &e.weights),
                node_sum(g, &e.derivs, &e.weights),
            );
            assert_eq!(a.map(f64::to_bits), b.map(f64::to_bits), "patch {i}");
            compared += a.is_some() as usize;
        }
        assert!(compared > table.len() / 2);
    }

    /// The base cells' grandchildren, whose nodes [`BendingEnergy::new`] computes, give
    /// bitwise the energies of nodes computed on the way, on every kind (Suzanne's tables,
    /// whose patches refine), and the cache is kept to k ≤ 2.
    #[test]
    fn precomputed_grandchildren_change_no_energy() {
        use super::{BendingEnergy, FairnessOptions, GRANDCHILDREN_UP_TO};
        let (mut refined, mut compared) = (0, 0);
        for table in tables() {
            let cached = BendingEnergy::new(table.kind, &FairnessOptions::default()).unwrap();
            assert_eq!(cached.grand_first.len(), 4 * cached.cells.len() + 1);
            let mut computed = cached.clone();
            computed.grand_first.clear();
            for i in 0..table.len() {
                let (a, b) = (cached.patch(&table, i), computed.patch(&table, i));
                assert_eq!(a.to_bits(), b.to_bits(), "{:?} patch {i}", table.kind);
                compared += a.is_finite() as usize;
                let fixed = cached.points_fixed(table.patch(i));
                refined += (a != fixed) as usize;
            }
        }
        assert!(
            compared > 4500 && refined > 1000,
            "{compared} compared, {refined} refined"
        );
        let k = GRANDCHILDREN_UP_TO + 1;
        let opts = FairnessOptions::default().with_subdivisions(k);
        let e = BendingEnergy::new(PatchKind::Gregory, &opts).unwrap();
        assert_eq!(e.grand_first.len(), 1);
    }

    /// The nodes of each base cell, and those of its children, integrate every polynomial
    /// of degree 4 in (s, t) exactly over the domain: ∫ s^a t^b = a! b! / (a + b + 2)!.
    /// (Duffy's map makes s^a t^b of degree a + b in u and v, times the Jacobian's u:
    /// within the 3-point Gauss rule's degree 5.) Up to rounding: cell bounds i/k and sums
    /// of up to 2,200 terms (measured 7e-15 at k = 3).
    #[test]
    fn nodes_integrate_polynomials_of_degree_4_exactly() {
        use super::{BendingEnergy, FairnessOptions, CELL_NODES};
        let f = |n: u32| (1..=n).map(f64::from).product::<f64>();
        for k in 1..=3 {
            let e = BendingEnergy::new(
                PatchKind::Bezier(1),
                &FairnessOptions::default().with_subdivisions(k),
            )
            .unwrap();
            // The nodes as `new` lays them out: per base cell, its own then its children's.
            let mut whole = Vec::new();
            let mut children = Vec::new();
            for cell in &e.cells {
                whole.extend(cell.nodes());
                let (c, n) = cell.children();
                children.extend(c[..n].iter().flat_map(|c| c.nodes()));
            }
            assert_eq!(whole.len() + children.len(), e.weights.len());
            assert_eq!(whole.len(), e.cells.len() * CELL_NODES);
            for a in 0..=4u32 {
                for b in 0..=4 - a {
                    let exact = f(a) * f(b) / f(a + b + 2);
                    for nodes in [&whole, &children] {
                        let got: f64 = nodes
                            .iter()
                            .map(|(p, w)| w * p[1].powi(a as i32) * p[2].powi(b as i32))
                            .sum();
                        assert!(
                            (got - exact).abs() < 1e-13,
                            "k {k} s^{a} t^{b}: {got} vs {exact}"
                        );
                    }
                }
            }
        }
    }
}
