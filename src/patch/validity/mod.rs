//! Validity of every patch: does its surface normal ever turn over?
//!
//! A patch S(s, t) over the triangle b = (1 − s − t, s, t) is **valid** when the component
//! J = (S_s × S_t) · n_f of its unnormalised normal along the unit normal n_f of its own
//! flat triangle (corners in input order, counter-clockwise) is positive over the whole
//! domain. n_f is constant over the patch, so for a Bézier triangle of degree d, J is a
//! polynomial of degree 2d − 2 (S_s and S_t are of degree d − 1); and J > 0 says that the
//! patch, projected onto its triangle's plane, is a local diffeomorphism with the
//! triangle's orientation: the patch is locally a graph over its own triangle and its
//! normal never points to the other side. That is the surface analogue of the Jacobian
//! determinant that curved finite elements must keep positive (Johnen, Remacle & Geuzaine,
//! "Geometrical validity of curvilinear finite elements", J. Comput. Phys. 233, 2013).
//! The interpolated vertex normal would be a worse reference: it is what the input claims,
//! not the element's orientation, and it raises J's degree by one.
//!
//! Each patch gets one of three verdicts ([`Verdict`]):
//! - **valid**, proved: on a cell (a subtriangle of the domain) the Bernstein coefficients
//!   of J bound it from below (convex hull property); a cell whose lower bound is positive
//!   is certified, an undecided cell is split into four (midpoint subdivision) down to
//!   [`MAX_DEPTH`] levels or [`MAX_CELLS`] cells per patch, and for the few patches that
//!   leaves undecided once more, down to [`DEEP_DEPTH`] levels or [`DEEP_CELLS`] cells (the
//!   common case pays nothing for it);
//! - **folded**, with a witness (s, t) where the f64 evaluation of the patch itself
//!   ([`PatchTable::eval`]) gives J < 0 by more than its rounding;
//! - **undecided** otherwise (never a guess).
//!
//! **Cost.** A patch that no subdivision can certify (J's coefficient at a corner at most
//! the tolerance: a normal in its triangle's plane) is only searched for a witness. Over
//! a table ([`check_range`]), the subdivisions share budgets proportional to its patch
//! count, so normals in or near their triangles' plane cost a bounded number of cells
//! per patch; a patch whose search stops there is undecided, and the runs say how many
//! were ([`undecided_note`]).
//!
//! **The rational Gregory blend (G1).** The interior point of corner m is the blend
//! I_m = φ G_{m,1} + (1 − φ) G_{m−1,2} with φ = b_{m+1}/(b_{m+1} + b_{m+2}), which is not a
//! polynomial and is singular at corner m. On each cell φ is replaced by its first-order
//! Taylor polynomial φ̂ at the cell's centroid, which makes the patch a quintic Bézier
//! triangle P (J_P of degree 8, bounded in Bernstein form on the cell); what that leaves
//! out, R = Σ_m 12 b_m² b_{m+1} b_{m+2} (φ − φ̂) ΔG_m with ΔG_m = G_{m,1} − G_{m−1,2}, has
//! derivatives bounded on the cell by interval bounds written with φ and 1 − φ (both in
//! [0, 1]) so that nothing divides by b_{m+1} + b_{m+2}: near corner m the factor
//! b_{m+1} b_{m+2} makes them O(h) on a cell of size h, elsewhere the Taylor remainder
//! (φ's second derivatives, at most 2/(b_{m+1} + b_{m+2})², or their exact forms where
//! smaller) makes them O(h) too. Then J ≥ min J_P − (|P_s| r_t + r_s |P_t| + r_s r_t) on the
//! cell, with |P_s|, |P_t| bounded by their Bernstein coefficients and r_s, r_t the
//! remainder bounds; or, where smaller, with only the parts across n_f of P's tangents and
//! of ΔG_m ([`quick::Across`]; R's terms of one corner with itself vanish). At a corner R and its
//! derivatives vanish, so cells at the corners certify as their size shrinks whenever J is
//! positive there.
//!
//! On large cells that Taylor remainder dwarfs J. So a cell it leaves undecided gets a
//! second bound ([`quick::NormalPart`]): the patch as the quartic P with the Gregory
//! points' means plus Σ_m ρ_m ΔG_m, where only the parts of ΔG_m and of P's tangents across
//! the flat normal enter J, each |∂ρ_m| bounded on the cell. The same bound on the whole
//! domain is the last of the quick tests that certify most patches with no subdivision.
//!
//! Rounding: a cell is certified only when its lower bound exceeds a tolerance of 1e-9 of
//! the product of the patch's tangent magnitudes (plus the rounding of the control points'
//! differences), far above the f64 rounding of the few hundred terms each coefficient sums.

use std::sync::OnceLock;

use glam::DVec3;
use rayon::prelude::*;
use serde::Serialize;

use super::{basis, PatchKind, PatchTable};

mod blend;
mod lanes;
mod quick;
mod stream;
mod subdivide;
mod witness;
#[cfg(test)]
use blend::blend_terms;
use blend::{blend_corners, blend_extent, BlendExtent};
#[cfg(test)]
pub(crate) use quick::QUICK_BLEND_BOUND;
#[cfg(test)]
use quick::{quick_flat, quick_half, quick_quartic, Quick};
use quick::{quick_gregory, NormalPart};
pub use stream::{check_in_chunks, Certifier};
#[cfg(test)]
use subdivide::check_within;
#[cfg(test)]
use subdivide::children;
#[cfg(test)]
use subdivide::shared;
use subdivide::{check_listed, CellSearch};
use witness::{grid_witness, FirstWork};
#[cfg(test)]
use {super::PatchBuilder, crate::Result};

/// Deepest midpoint subdivision of a patch's domain tried before a cell is left undecided.
pub const MAX_DEPTH: u32 = 12;
/// Most cells examined per patch before it is left undecided.
pub const MAX_CELLS: usize = 4096;
/// From this depth on, every cell that does not certify is searched for a witness.
const WITNESS_DEPTH: u32 = 6;

/// The verdict on one patch.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Verdict {
    /// J > 0 over the whole domain, proved.
    Valid,
    /// J < 0 at (s, t) (b = (1 − s − t, s, t)), by direct f64 evaluation of the patch:
    /// `jacobian` is J there.
    Folded {
        /// Barycentric coordinate b1 of the point.
        s: f64,
        /// Barycentric coordinate b2 of the point.
        t: f64,
        /// J at the point (negative).
        jacobian: f64,
    },
    /// Neither proved nor refuted within `DEEP_DEPTH` and `DEEP_CELLS`.
    Undecided,
}

/// Verdicts counted over patches.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct PatchCounts {
    /// Patches proved valid.
    pub valid: usize,
    /// Patches found folded.
    pub folded: usize,
    /// Patches left undecided.
    pub undecided: usize,
}

impl PatchCounts {
    /// These counts with one more verdict.
    pub fn with(mut self, v: &Verdict) -> PatchCounts {
        match v {
            Verdict::Valid => self.valid += 1,
            Verdict::Folded { .. } => self.folded += 1,
            Verdict::Undecided => self.undecided += 1,
        }
        self
    }

    /// The sum of two counts.
    pub fn merge(self, o: PatchCounts) -> PatchCounts {
        PatchCounts {
            valid: self.valid + o.valid,
            folded: self.folded + o.folded,
            undecided: self.undecided + o.undecided,
        }
    }

    /// Patches counted.
    pub fn total(&self) -> usize {
        self.valid + self.folded + self.undecided
    }
}

/// J = (S_s × S_t) · n_f of patch `i` at `b` by the patch's own f64 evaluation, and the
/// product |S_s| |S_t| (the scale of its rounding).
pub fn jacobian(table: &PatchTable, i: usize, b: [f64; 3]) -> (f64, f64) {
    jacobian_with(table, i, &table.kind.weights(b))
}

/// [`jacobian`] from the patch kind's basis `w` at the point (bitwise: the tangents are
/// those of the patch's evaluation).
#[inline]
fn jacobian_with(table: &PatchTable, i: usize, w: &basis::Weights) -> (f64, f64) {
    let (ds, dt) = table.tangents_weights(i, w);
    (
        ds.cross(dt).dot(table.flat_normals[i]),
        ds.length() * dt.length(),
    )
}

/// The verdict on every patch of `table` (in parallel), within the bounds on the
/// certificate's cost: the subdivisions of the patches share cell budgets proportional to
/// their count, and a patch whose search stops at its share is undecided, never a guess.
pub fn check_table(table: &PatchTable) -> Vec<Verdict> {
    check_range(table, 0..table.len()).verdicts
}

/// The verdicts of `table` counted (in parallel).
pub fn count(table: &PatchTable) -> PatchCounts {
    count_range(table, 0..table.len())
}

/// The verdicts of patches `range` of `table` counted (in parallel), within the bounds on
/// the certificate's cost ([`check_range`]).
pub fn count_range(table: &PatchTable, range: std::ops::Range<usize>) -> PatchCounts {
    let start = range.start;
    let first = first_stages(table, range);
    // Where the first stage decided every patch (flat meshes, most meshes of most
    // schemes), the verdicts are counted from it, in parallel.
    let done = |s: &Stage| match s {
        Stage::Done(v) => Some(*v),
        _ => None,
    };
    if crate::par::all_indices(first.len(), |k| done(&first[k]).is_some()) {
        return first
            .par_iter()
            .filter_map(done)
            .fold(PatchCounts::default, |c, v| c.with(&v))
            .reduce(PatchCounts::default, PatchCounts::merge);
    }
    check_stages(table, start, first)
        .verdicts
        .iter()
        .fold(PatchCounts::default(), PatchCounts::with)
}

/// [`classify`]'s stage of every patch of `range`, in parallel (one set of buffers per
/// worker).
fn first_stages(table: &PatchTable, range: std::ops::Range<usize>) -> Vec<Stage> {
    range
        .into_par_iter()
        .map_init(FirstWork::new, |work, i| classify(table, i, work).0)
        .collect()
}

/// The verdicts of some patches and what they cost ([`check_range`]; the costs are what
/// the tests of the bounds read).
#[cfg_attr(not(test), allow(dead_code))]
pub struct RangeCheck {
    /// The verdicts, in the order of the range.
    pub verdicts: Vec<Verdict>,
    /// Cells the subdivisions examined, all patches together (a subdivision run again
    /// with a larger share counts once, with its largest count).
    pub cells: usize,
    /// Patches left undecided where a subdivision stopped at its share of a budget (the
    /// others left undecided reached the limits of their subdivisions).
    pub stopped: usize,
}

/// The verdicts of patches `range` of `table` (in parallel), with the certificate's cost
/// bounded per patch and in total. Each patch gets what [`check_patch`] gives it, except
/// that the subdivisions share budgets proportional to the length of the range:
/// - the first subdivisions, [`FIRST_SHARE`] cells per patch of the range and at least
///   [`FIRST_FLOOR`];
/// - the witness searches of the patches that no subdivision can certify
///   ([`Geometry::never_certified`]: normals in their triangle's plane, degenerate
///   triangles), [`WITNESS_SHARE`] cells per patch and at least [`WITNESS_FLOOR`];
/// - the deeper subdivisions of the patches that the first one leaves undecided,
///   [`DEEP_SHARE`] cells per patch and at least [`DEEP_FLOOR`].
///
/// Each budget is shared out evenly among the subdivisions that need it, what the ones
/// that finish within their share leave over going to the others ([`shared`]); so the
/// verdicts depend on nothing but the patches of the range. A subdivision that stops
/// at its share leaves its patch undecided, never a guess; where no budget binds (on
/// every test mesh) each verdict is [`check_patch`]'s.
pub fn check_range(table: &PatchTable, range: std::ops::Range<usize>) -> RangeCheck {
    let start = range.start;
    check_stages(table, start, first_stages(table, range))
}

/// [`check_range`] of the patches from `start` on whose first stages are `first`.
fn check_stages(table: &PatchTable, start: usize, first: Vec<Stage>) -> RangeCheck {
    let n = first.len();
    let listed: Vec<(usize, Stage)> = first
        .iter()
        .enumerate()
        .filter(|(_, s)| !matches!(s, Stage::Done(_)))
        .map(|(k, s)| (start + k, *s))
        .collect();
    let mut out: Vec<(Verdict, usize, bool)> = first
        .iter()
        .map(|s| match s {
            Stage::Done(v) => (*v, 0, false),
            _ => (Verdict::Undecided, 0, false),
        })
        .collect();
    for (&(i, _), r) in listed.iter().zip(check_listed(table, &listed, n)) {
        out[i - start] = r;
    }
    RangeCheck {
        cells: out.iter().map(|o| o.1).sum(),
        stopped: out.iter().filter(|o| o.2).count(),
        verdicts: out.into_iter().map(|o| o.0).collect(),
    }
}

#[cfg(test)]
/// The verdicts of every patch `builder` builds, counted, a chunk of triangles at a time
/// (bounded memory).
pub fn count_builder(builder: &PatchBuilder<'_>) -> Result<PatchCounts> {
    let mut total = PatchCounts::default();
    builder.for_each_chunk(1 << 16, |table, _| {
        total = total.merge(count(table));
        Ok(())
    })?;
    Ok(total)
}

/// Whether no certificate can prove patch `i` of `table` valid, whatever its cost: the
/// Jacobian J is at most the certificate's tolerance at a corner of the domain (the corner's
/// Bernstein coefficient of J). A normal in its triangle's plane, a degenerate triangle, or
/// two boundary curves that leave the corner in one direction make J vanish there; two
/// crease edges at a vertex that separate the same two normals do the last (both of their
/// curves leave along the line where the two tangent planes meet).
pub fn singular_at_a_corner(table: &PatchTable, i: usize) -> bool {
    Geometry::new(table, i).never_certified()
}

/// One line about the folded patches of `table` (built for `mesh`): `None` when every
/// patch is certified valid.
pub fn fold_line(mesh_name: &str, table: &PatchTable) -> Option<String> {
    fold_line_of(mesh_name, table.scheme, &count(table))
}

/// [`fold_line`] of verdicts `c` counted on a table of `scheme`.
pub fn fold_line_of(mesh_name: &str, scheme: super::Scheme, c: &PatchCounts) -> Option<String> {
    (c.folded > 0 || c.undecided > 0).then(|| {
        format!(
            "warning: {mesh_name}: {} of {} {} patches are folded (their normal turns over \
             inside the patch), {} undecided",
            c.folded,
            c.total(),
            scheme,
            c.undecided
        )
    })
}

/// The note a run prints where the certificate left patches undecided (`None` where it
/// left none).
pub fn undecided_note(c: &PatchCounts) -> Option<String> {
    (c.undecided > 0).then(|| {
        format!(
            "{} of {} patches undecided: the validity certificate neither proved them valid \
             nor found a fold within its bounds on cost (cells per patch, and a budget \
             proportional to the patch count); normals in or near their triangle's plane, \
             and two boundary curves that leave a corner in one direction (as two crease \
             edges between the same two normals make them), make patches undecidable",
            c.undecided,
            c.total()
        )
    })
}

/// The barycentric corners of a cell.
type Cell = [[f64; 3]; 3];

/// The whole domain as a cell.
const WHOLE: Cell = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// Index tables of Bézier triangles up to degree 8.
pub struct Tables {
    /// For degree d ≥ 1 and each multi-index γ of degree d − 1 (in `bezier_powers`
    /// order): the indices of γ + e_0, γ + e_1, γ + e_2 in degree d.
    pub up: Vec<Vec<[usize; 3]>>,
    powers: Vec<Vec<[u32; 3]>>,
    /// For m = 0..=4: [`products`] of degree m by coefficient ([`lanes::ByCoefficient`]):
    /// J's coefficients are summed from these, each over its terms in that order.
    by_coefficient: Vec<lanes::ByCoefficient>,
}

/// The products of two Bézier polynomials of degree m (`powers`: the multi-indices of
/// degree m): (α index, β index, α + β index in degree 2m, weight
/// C(m; α) C(m; β) / C(2m; α + β)) over all pairs, row by row: the pair (α, β) is entry
/// α · len + β (len: the coefficients of degree m).
fn products(m: u32, powers: &[[u32; 3]]) -> Vec<(usize, usize, usize, f64)> {
    let mut out = Vec::new();
    for (ia, a) in powers.iter().enumerate() {
        for (ib, b) in powers.iter().enumerate() {
            let g = [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
            let w = multinomial(*a) * multinomial(*b) / multinomial(g);
            out.push((ia, ib, basis::bezier_index(2 * m, g), w));
        }
    }
    out
}

fn multinomial(p: [u32; 3]) -> f64 {
    let f = |n: u32| (1..=n).map(|x| x as f64).product::<f64>();
    f(p[0] + p[1] + p[2]) / (f(p[0]) * f(p[1]) * f(p[2]))
}

pub fn tables() -> &'static Tables {
    static T: OnceLock<Tables> = OnceLock::new();
    T.get_or_init(|| {
        let powers: Vec<Vec<[u32; 3]>> = (0..=8).map(basis::bezier_powers).collect();
        let mut up = vec![Vec::new()];
        for d in 1..=8u32 {
            up.push(
                powers[d as usize - 1]
                    .iter()
                    .map(|g| {
                        std::array::from_fn(|k| {
                            let mut p = *g;
                            p[k] += 1;
                            basis::bezier_index(d, p)
                        })
                    })
                    .collect(),
            );
        }
        let by_coefficient = (0..=4u32)
            .map(|m| lanes::ByCoefficient::new(&products(m, &powers[m as usize])))
            .collect();
        Tables {
            up,
            powers,
            by_coefficient,
        }
    })
}

/// Most coefficients of the polynomials handled: degree 5 (21).
const MAXC: usize = 21;

/// One de Casteljau step at `u` on coefficient pairs of degree `deg` (`src`) into degree
/// `deg − 1` (`dst`).
#[inline(always)]
fn step(src: &Pairs, deg: u32, u: [f64; 3], dst: &mut Pairs) {
    let up = &tables().up[deg as usize];
    for (j, ix) in up.iter().enumerate() {
        let (a, b, c) = (&src[ix[0]], &src[ix[1]], &src[ix[2]]);
        dst[j] = [
            u[0] * a[0] + u[1] * b[0] + u[2] * c[0],
            u[0] * a[1] + u[1] * b[1] + u[2] * c[1],
        ];
    }
}

/// Coefficient pairs of a Bézier triangle of degree at most 4.
type Pairs = [[DVec3; 2]; 15];

/// The pairs of Bézier coefficients (degree m ≤ 4) `d` restricted to `cell` (blossoming:
/// coefficient α of the restriction is the blossom at α_0 copies of the cell's first
/// corner, α_1 of its second, α_2 of its third; the blossoms share their prefixes).
/// Its buffers are `scratch` (a subdivision keeps one set for all its cells).
#[inline(always)]
fn restrict(d: &Pairs, m: u32, cell: &Cell, scratch: &mut Scratch<[DVec3; 2]>, out: &mut Pairs) {
    restrict_by(d, m, scratch, &AtCell(cell), out);
}

/// One de Casteljau step of [`restrict_by`] on coefficients of type `P`: `step(src, deg,
/// k, dst)` steps coefficients of degree `deg` at the cell's corner k. A trait with an
/// inlined method rather than a closure: a closure that is not inlined is compiled
/// without the target features of its caller (AVX in `Geometry::bound4_avx`).
pub(super) trait Stepper<P> {
    fn step(&self, src: &[P; 15], deg: u32, k: usize, dst: &mut [P; 15]);
}

/// [`step`] at the corners of one cell.
struct AtCell<'a>(&'a Cell);

impl Stepper<[DVec3; 2]> for AtCell<'_> {
    #[inline(always)]
    fn step(&self, src: &Pairs, deg: u32, k: usize, dst: &mut Pairs) {
        step(src, deg, self.0[k], dst);
    }
}

/// The buffers of [`restrict_by`]. Each step writes every coefficient that the next one
/// reads, so what a buffer held before a restriction is never read: one set serves every
/// cell of a subdivision, initialised once instead of once per cell.
pub(super) struct Scratch<P> {
    a: [[P; 15]; 5],
    bb: [[P; 15]; 2],
    cc: [[P; 15]; 2],
}

impl<P: Copy> Scratch<P> {
    /// Buffers filled with `zero`.
    pub(super) fn new(zero: P) -> Scratch<P> {
        Scratch {
            a: [[zero; 15]; 5],
            bb: [[zero; 15]; 2],
            cc: [[zero; 15]; 2],
        }
    }
}

/// Fresh buffers for one scalar restriction (tests).
#[cfg(test)]
fn scratch() -> Scratch<[DVec3; 2]> {
    Scratch::new([DVec3::ZERO; 2])
}

/// The buffers of one subdivision: for the four-lane bound and for the scalar
/// restriction.
pub(super) struct Work {
    four: lanes::FourWork,
    one: Scratch<[DVec3; 2]>,
}

impl Work {
    pub(super) fn new() -> Work {
        Work {
            four: lanes::FourWork::new(),
            one: Scratch::new([DVec3::ZERO; 2]),
        }
    }
}

/// The order of the steps of [`restrict`], for coefficients of any type `P` (one pair, or
/// four cells' pairs side by side, `lanes`), each step taken by `stepper` ([`Stepper`]).
/// The steps run between two pairs of buffers, never copying a whole set of coefficients.
#[inline(always)]
fn restrict_by<P: Copy>(
    d: &[P; 15],
    m: u32,
    scratch: &mut Scratch<P>,
    stepper: &impl Stepper<P>,
    out: &mut [P; 15],
) {
    let m = m as usize;
    let Scratch { a, bb, cc } = scratch;
    // a[i]: after i steps at the first corner (degree m − i).
    a[0] = *d;
    for i in 1..=m {
        let (lo, hi) = a.split_at_mut(i);
        stepper.step(&lo[i - 1], (m - i + 1) as u32, 0, &mut hi[0]);
    }
    // b: a[i] after j steps at the second corner (degree m − i − j), in `bb[k]` once
    // stepped; c: b after the steps at the third corner, in `cc`.
    for i in 0..=m {
        let mut b: Option<usize> = None;
        for j in 0..=m - i {
            let deg = m - i - j;
            let value = if deg == 0 {
                match b {
                    None => a[i][0],
                    Some(k) => bb[k][0],
                }
            } else {
                match b {
                    None => stepper.step(&a[i], deg as u32, 2, &mut cc[0]),
                    Some(k) => stepper.step(&bb[k], deg as u32, 2, &mut cc[0]),
                }
                let mut c = 0;
                for dd in (1..deg).rev() {
                    step_over(stepper, cc, c, dd as u32, 2);
                    c ^= 1;
                }
                cc[c][0]
            };
            out[basis::bezier_index(m as u32, [i as u32, j as u32, deg as u32])] = value;
            if j < m - i {
                b = Some(match b {
                    None => {
                        stepper.step(&a[i], deg as u32, 1, &mut bb[0]);
                        0
                    }
                    Some(k) => {
                        step_over(stepper, bb, k, deg as u32, 1);
                        k ^ 1
                    }
                });
            }
        }
    }
}

/// `stepper`'s step from `buf[from]` into the other buffer of the pair ([`restrict_by`]).
#[inline(always)]
fn step_over<P: Copy>(
    stepper: &impl Stepper<P>,
    buf: &mut [[P; 15]; 2],
    from: usize,
    deg: u32,
    k: usize,
) {
    let (x, y) = buf.split_at_mut(1);
    if from == 0 {
        stepper.step(&x[0], deg, k, &mut y[0]);
    } else {
        stepper.step(&y[0], deg, k, &mut x[0]);
    }
}

/// What a Gregory patch's linearised blend leaves out on a cell ([`blend_corners`]): bounds
/// on its derivatives' lengths (r_s = Σ_m |ΔG_m| b_s,m, likewise r_t) and each corner's
/// (b_s,m, b_t,m); zero for a polynomial patch.
#[derive(Clone, Copy, Default)]
struct Slopes {
    rs: f64,
    rt: f64,
    each: [(f64, f64); 3],
}

/// What the bound needs of one patch.
struct Geometry {
    /// Degree of the polynomial part (Gregory: 5, with the linearised blend added per cell).
    n: u32,
    /// Its Bézier coefficients on the whole domain (Gregory: the quartic with G_{m−1,2} as
    /// interior points, raised to degree 5).
    base: [DVec3; MAXC],
    /// Gregory: ΔG_m = G_{m,1} − G_{m−1,2}.
    gregory: Option<[DVec3; 3]>,
    /// Gregory: the second bound tried on a cell the first does not certify.
    normal_part: Option<NormalPart>,
    nref: DVec3,
    /// Absolute tolerance of a certified lower bound (rounding).
    tol: f64,
}

impl Geometry {
    fn new(table: &PatchTable, i: usize) -> Geometry {
        let c = table.patch(i);
        let nref = table.flat_normals[i];
        let mut base = [DVec3::ZERO; MAXC];
        let (n, gregory) = match table.kind {
            PatchKind::Bezier(n) => {
                base[..c.len()].copy_from_slice(c);
                (n, None)
            }
            PatchKind::PnNormals => {
                base[..10].copy_from_slice(&c[..10]);
                (3, None)
            }
            PatchKind::Gregory => {
                let mut q = [DVec3::ZERO; 15];
                for (j, p) in basis::g1_boundary_powers().iter().enumerate() {
                    q[basis::bezier_index(4, *p)] = c[j];
                }
                let mut dg = [DVec3::ZERO; 3];
                for m in 0..3 {
                    let g1 = c[12 + 2 * m];
                    let g2 = c[13 + 2 * ((m + 2) % 3)];
                    q[basis::bezier_index(4, interior_powers(m))] = g2;
                    dg[m] = g1 - g2;
                }
                // Degree elevation: Q5_γ = Σ_k (γ_k / 5) Q_{γ − e_k}.
                let t = tables();
                for (gi, g) in t.powers[5].iter().enumerate() {
                    let mut s = DVec3::ZERO;
                    for k in 0..3 {
                        if g[k] > 0 {
                            let mut p = *g;
                            p[k] -= 1;
                            s += (g[k] as f64 / 5.0) * q[basis::bezier_index(4, p)];
                        }
                    }
                    base[gi] = s;
                }
                (5, Some(dg))
            }
        };
        let len = tables().powers[n as usize].len();
        // Tangent scale of the whole patch: its derivative coefficients' largest lengths.
        let (ds, dt) = derivatives(&base[..len], n);
        let m = (n.max(1) - 1) as usize;
        let dlen = tables().powers[m].len();
        let gs = ds[..dlen].iter().map(|v| v.length()).fold(0.0, f64::max);
        let gt = dt[..dlen].iter().map(|v| v.length()).fold(0.0, f64::max);
        let cmax = c.iter().map(|p| p.abs().max_element()).fold(0.0, f64::max);
        let tol = 1e-9 * gs * gt + 64.0 * f64::EPSILON * cmax * n as f64 * (gs + gt);
        Geometry {
            n,
            base,
            normal_part: gregory.map(|_| NormalPart::new(c, nref)),
            gregory,
            nref,
            tol,
        }
    }

    /// Whether no subdivision can ever certify the patch: J's Bernstein coefficient at a
    /// corner of the domain is at most the tolerance. Every cell that holds that corner
    /// has it as a corner, where its coefficient is bitwise this one ([`restrict`] at a
    /// unit barycentric point selects coefficients exactly, and the linearised blend of a
    /// Gregory patch never reaches the coefficients next to a corner); so every such
    /// cell's lower bound, no more than that coefficient less the tolerance, is at most 0.
    /// A normal in its triangle's plane, or a degenerate triangle, makes J vanish there.
    fn never_certified(&self) -> bool {
        let len = tables().powers[self.n as usize].len();
        // Non-finite coefficients are not selected exactly (0 · ∞ is NaN).
        if !(self.base[..len].iter().all(|p| p.is_finite()) && self.nref.is_finite()) {
            return false;
        }
        let (ds, dt) = derivatives(&self.base[..len], self.n);
        let m = self.n.max(1) - 1;
        (0..3).any(|k| {
            let mut p = [0u32; 3];
            p[k] = m;
            let j = basis::bezier_index(m, p);
            // As [`Self::bound`] sums it: the corner's one product, of weight 1.
            0.0 + 1.0 * ds[j].dot(dt[j].cross(self.nref)) <= self.tol
        })
    }

    /// A lower bound of J on `cell` (certified when positive: the tolerance is taken off),
    /// the barycentric point where its smallest Bernstein coefficient sits (a witness
    /// candidate), and whether that coefficient itself is below the tolerance (the
    /// polynomial part alone does not certify the cell: only then is a witness looked for
    /// at a shallow cell).
    /// `scratch`: the restriction's buffers.
    fn bound(&self, cell: &Cell, scratch: &mut Scratch<[DVec3; 2]>) -> (f64, [f64; 3], bool) {
        let (pair, slopes) = self.cell_pairs(cell);
        let mut r = [[DVec3::ZERO; 2]; 15];
        restrict(&pair, self.n.max(1) - 1, cell, scratch, &mut r);
        self.finish(&r, &slopes, cell)
    }

    /// The first part of [`Self::bound`]: the derivative coefficient pairs (along s and t,
    /// degree n − 1) of the polynomial part on the whole domain, with a Gregory patch's
    /// blend linearised for `cell`, and the bounds on what that leaves out ([`Slopes`]).
    #[inline(always)]
    fn cell_pairs(&self, cell: &Cell) -> (Pairs, Slopes) {
        let t = tables();
        let n = self.n;
        let len = t.powers[n as usize].len();
        let (p, sl) = self.cell_points(cell);
        let (ds, dt) = derivatives(&p[..len], n);
        let m = n.max(1) - 1;
        let dlen = t.powers[m as usize].len();
        let mut pair = [[DVec3::ZERO; 2]; 15];
        for j in 0..dlen {
            pair[j] = [ds[j], dt[j]];
        }
        (pair, sl)
    }

    /// The Bézier coefficients of the polynomial part on the whole domain, with a Gregory
    /// patch's blend linearised for `cell`, and the bounds on what that leaves out (the
    /// first step of [`Self::cell_pairs`]).
    #[inline(always)]
    fn cell_points(&self, cell: &Cell) -> ([DVec3; MAXC], Slopes) {
        let mut p = self.base;
        let mut sl = Slopes::default();
        if let Some(dg) = self.gregory {
            let terms = blend_corners(cell);
            for (m, (d, &(ell, bs, bt))) in dg.iter().zip(&terms).enumerate() {
                // 12 x² y z φ̂ with φ̂ = Σ_k ℓ_k b_k: B⁴_α b_k = (α_k + 1)/5 B⁵_{α + e_k}.
                let a = interior_powers(m);
                for k in 0..3 {
                    let mut g = a;
                    g[k] += 1;
                    p[basis::bezier_index(5, g)] += (ell[k] * (a[k] as f64 + 1.0) / 5.0) * *d;
                }
                let dl = d.length();
                sl.rs += dl * bs;
                sl.rt += dl * bt;
                sl.each[m] = (bs, bt);
            }
        }
        (p, sl)
    }

    /// The last part of [`Self::bound`], from the pairs `r` restricted to `cell`.
    #[inline(always)]
    fn finish(&self, r: &Pairs, sl: &Slopes, cell: &Cell) -> (f64, [f64; 3], bool) {
        let t = tables();
        let m = self.n.max(1) - 1;
        let dlen = t.powers[m as usize].len();
        let ps = r[..dlen].iter().map(|v| v[0].length()).fold(0.0, f64::max);
        let pt = r[..dlen].iter().map(|v| v[1].length()).fold(0.0, f64::max);
        let mut tn = [DVec3::ZERO; 15];
        for (j, v) in r[..dlen].iter().enumerate() {
            tn[j] = v[1].cross(self.nref);
        }
        let mut jc = [0.0f64; 45];
        for (c, terms) in jc.iter_mut().zip(t.by_coefficient[m as usize].each()) {
            *c = terms
                .iter()
                .fold(0.0, |acc, &(a, b, w)| acc + w * r[a][0].dot(tn[b]));
        }
        let maxima = self
            .normal_part
            .as_ref()
            .map(|q| q.across.maxima(&r[..dlen]));
        let remainder = self.remainder(ps, pt, sl, maxima);
        self.conclude(&jc, remainder, cell)
    }

    /// The bound on J − J_P̂ on a cell, P̂ the polynomial part with the blend linearised:
    /// the smaller of |P̂_s| r_t + r_s |P̂_t| + r_s r_t (whole lengths: `ps`, `pt` bound the
    /// tangents) and, for a Gregory patch, [`quick::Across`]'s bound from the parts across n
    /// (`maxima`: [`quick::Across::maxima`] over the cell's pairs, given where the patch
    /// has a normal part), which is never larger but for rounding.
    #[inline(always)]
    fn remainder(
        &self,
        ps: f64,
        pt: f64,
        sl: &Slopes,
        maxima: Option<([f64; 3], [f64; 3])>,
    ) -> f64 {
        let whole = ps * sl.rt + sl.rs * pt + sl.rs * sl.rt;
        match (&self.normal_part, maxima) {
            (Some(q), Some((a, c))) => whole.min(q.across.remainder(&a, &c, &sl.each)),
            _ => whole,
        }
    }

    /// The bound from J's coefficients `jc` on `cell` and the tangent bounds (the end of
    /// [`Self::bound`]).
    #[inline(always)]
    fn conclude(&self, jc: &[f64; 45], remainder: f64, cell: &Cell) -> (f64, [f64; 3], bool) {
        let t = tables();
        let m = self.n.max(1) - 1;
        let jlen = t.powers[2 * m as usize].len();
        let (imin, jmin) =
            jc[..jlen]
                .iter()
                .copied()
                .enumerate()
                .fold(
                    (0, f64::INFINITY),
                    |a, (i, v)| if v < a.1 { (i, v) } else { a },
                );
        self.conclude_at(imin, jmin, remainder, cell)
    }

    /// [`Self::conclude`] from J's smallest coefficient `jmin`, the first at index `imin`.
    #[inline(always)]
    fn conclude_at(
        &self,
        imin: usize,
        jmin: f64,
        remainder: f64,
        cell: &Cell,
    ) -> (f64, [f64; 3], bool) {
        let t = tables();
        let m = self.n.max(1) - 1;
        let lower = jmin - remainder - self.tol;
        // The Greville point of the smallest coefficient, mapped into the cell.
        let g = t.powers[2 * m as usize][imin];
        let deg = (2 * m).max(1) as f64;
        let b =
            std::array::from_fn(|j| (0..3).map(|k| g[k] as f64 / deg * cell[k][j]).sum::<f64>());
        (lower, b, jmin <= self.tol)
    }
}

/// [`basis::bezier_index`] of degree 4, at compile time.
const fn quartic_index(p: [u32; 3]) -> usize {
    let mut before = 0;
    let mut i = p[0] + 1;
    while i <= 4 {
        before += 4 - i + 1;
        i += 1;
    }
    (before + (4 - p[0] - p[1])) as usize
}

/// Slots in the quartic of [`quick_quartic`] of the G1 layout's 12 boundary points
/// ([`basis::g1_boundary_powers`]).
pub const QUARTIC_BOUNDARY: [usize; 12] = {
    let mut out = [0; 12];
    let mut k = 0;
    while k < 3 {
        let mut j = 0;
        while j < 4 {
            let mut p = [0u32; 3];
            p[k] = 4 - j as u32;
            p[(k + 1) % 3] = j as u32;
            out[4 * k + j] = quartic_index(p);
            j += 1;
        }
        k += 1;
    }
    out
};

/// Slots in that quartic of corner m's interior point ([`interior_powers`]).
pub const QUARTIC_INTERIOR: [usize; 3] = [
    quartic_index([2, 1, 1]),
    quartic_index([1, 2, 1]),
    quartic_index([1, 1, 2]),
];

/// `tables().up[4]` at compile time: for each multi-index γ of degree 3 (in
/// [`basis::bezier_powers`] order), the slots of γ + e_0, γ + e_1, γ + e_2 in degree 4.
pub const QUARTIC_UP: [[usize; 3]; 10] = {
    let mut out = [[0; 3]; 10];
    let mut n = 0;
    let mut i = 4;
    while i > 0 {
        i -= 1;
        let mut j = 4 - i;
        while j > 0 {
            j -= 1;
            let g = [i, j, 3 - i - j];
            let mut k = 0;
            while k < 3 {
                let mut p = g;
                p[k] += 1;
                out[n][k] = quartic_index(p);
                k += 1;
            }
            n += 1;
        }
    }
    out
};

/// Powers (2 on m, 1 on m + 1, 1 on m + 2) of corner m's interior point.
pub fn interior_powers(m: usize) -> [u32; 3] {
    let mut a = [1u32; 3];
    a[m] = 2;
    a
}

/// Derivative coefficients (degree n − 1) along s and t of Bézier coefficients of degree n.
fn derivatives(c: &[DVec3], n: u32) -> ([DVec3; 15], [DVec3; 15]) {
    let mut ds = [DVec3::ZERO; 15];
    let mut dt = [DVec3::ZERO; 15];
    if n == 0 {
        return (ds, dt);
    }
    let nf = n as f64;
    for (j, ix) in tables().up[n as usize].iter().enumerate() {
        ds[j] = nf * (c[ix[1]] - c[ix[0]]);
        dt[j] = nf * (c[ix[2]] - c[ix[0]]);
    }
    (ds, dt)
}

/// The verdict on patch `i` of `table`: within [`MAX_DEPTH`] and [`MAX_CELLS`], and for
/// the few patches that leaves undecided, once more within [`DEEP_DEPTH`] and
/// [`DEEP_CELLS`]. A patch that no subdivision can certify
/// ([`Geometry::never_certified`]) gets the first subdivision only, which looks for a
/// witness of a fold (the verdict is folded or undecided).
pub fn check_patch(table: &PatchTable, i: usize) -> Verdict {
    let (stage, geom) = match classify(table, i, &mut FirstWork::new()) {
        (Stage::Done(v), _) => return v,
        (stage, Some(geom)) => (stage, geom),
        (stage, None) => (stage, Geometry::new(table, i)),
    };
    // The first subdivision records what its cells give, which the deeper reads.
    let mut first = CellSearch::new(i, MAX_DEPTH, MAX_CELLS).recording();
    match first.run(table, &geom, usize::MAX).0 {
        Verdict::Undecided if stage == Stage::First => {
            let deep = CellSearch::new(i, DEEP_DEPTH, DEEP_CELLS);
            let mut deep = match first.take_memo() {
                Some(m) => deep.reading(m),
                None => deep,
            };
            deep.run(table, &geom, usize::MAX).0
        }
        v => v,
    }
}

/// Where [`classify`] left a patch.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Stage {
    Done(Verdict),
    /// The subdivisions decide.
    First,
    /// No subdivision can certify it: the first subdivision looks for a witness.
    Witness,
}

/// The first stage of [`check_patch`], before any subdivision: the quick test (G1), the
/// grid of witnesses, and whether a subdivision can certify the patch; with the patch's
/// [`Geometry`] (built to tell the stage) handed on where the subdivisions decide, so that
/// [`check_patch`] does not build it again. `work`: its buffers and the witness grid's
/// basis ([`FirstWork`]).
///
/// A polynomial patch (every kind but G1's Gregory patch) is first bounded on the whole
/// domain by J's Bernstein coefficients, as the subdivision's first cell would be: where
/// that certifies it, no witness can exist (J exceeds the tolerance, far above a
/// witness's −1e-12 |S_s| |S_t|) and the subdivision would stop at that cell, so the
/// verdict is the same for less work (a flat patch: one product). G1's quick test
/// ([`quick_gregory`]) plays that part for the Gregory patch.
fn classify(table: &PatchTable, i: usize, work: &mut FirstWork) -> (Stage, Option<Geometry>) {
    let mut built = None;
    if table.kind == PatchKind::Gregory {
        if quick_gregory(table.patch(i), table.flat_normals[i]) {
            return (Stage::Done(Verdict::Valid), None);
        }
    } else {
        if table.kind == PatchKind::Bezier(1)
            && flat_lower_bound(table.patch(i), table.flat_normals[i]) > 0.0
        {
            return (Stage::Done(Verdict::Valid), None);
        }
        let geom = Geometry::new(table, i);
        if geom.bound(&WHOLE, &mut work.scratch).0 > 0.0 {
            return (Stage::Done(Verdict::Valid), None);
        }
        built = Some(geom);
    }
    if let Some(v) = grid_witness(table, i, work) {
        return (Stage::Done(v), None);
    }
    let geom = built.unwrap_or_else(|| Geometry::new(table, i));
    let stage = if geom.never_certified() {
        Stage::Witness
    } else {
        Stage::First
    };
    (stage, Some(geom))
}

/// [`Geometry::bound`] of a flat patch (degree 1, corners `c`, unit flat normal `nref`) on
/// the whole domain, bitwise: the same operations in the same order, without the general
/// path's coefficient arrays (degree 1 has one derivative pair and one coefficient of J, its
/// restriction to the whole domain is the identity, and there is no blend remainder, so
/// r_s = r_t = 0). J's coefficient is then (c_1 − c_0) · ((c_2 − c_0) × n_f), positive
/// unless the triangle is degenerate.
#[inline]
fn flat_lower_bound(c: &[DVec3], nref: DVec3) -> f64 {
    // As `derivatives(c, 1)` and `Geometry::new` (n = 1).
    let (ds, dt) = (1.0 * (c[1] - c[0]), 1.0 * (c[2] - c[0]));
    let (gs, gt) = (f64::max(0.0, ds.length()), f64::max(0.0, dt.length()));
    let cmax = c.iter().map(|p| p.abs().max_element()).fold(0.0, f64::max);
    let tol = 1e-9 * gs * gt + 64.0 * f64::EPSILON * cmax * 1.0 * (gs + gt);
    // As `Geometry::finish` and `conclude` (one product of weight 1; the fold's minimum).
    let jc = 0.0 + 1.0 * ds.dot(dt.cross(nref));
    let jmin = if jc < f64::INFINITY {
        jc
    } else {
        f64::INFINITY
    };
    let (rs, rt) = (0.0, 0.0);
    jmin - (gs * rt + rs * gt + rs * rt) - tol
}

/// Depth of the second, deeper subdivision of a patch left undecided.
pub const DEEP_DEPTH: u32 = 18;
/// Most cells of the second subdivision.
pub const DEEP_CELLS: usize = 1 << 16;
/// Cells per patch of a range ([`check_range`]) that the first subdivisions of its
/// patches share. Nearly all patches of a mesh take a few cells; the test meshes take
/// 215 on average at most (Suzanne, G1), normals at 17° to their triangles' plane about
/// 550.
pub const FIRST_SHARE: usize = 1024;
/// Cells those first subdivisions share at least: eight whole ones.
pub const FIRST_FLOOR: usize = 8 * MAX_CELLS;
/// Cells per patch of a range that the witness searches of its patches that no
/// subdivision can certify share. An in-plane normal (J = 0 along whole edges) makes
/// every cell along those edges undecided: such a patch would otherwise take its whole
/// first subdivision.
pub const WITNESS_SHARE: usize = 128;
/// Cells those witness searches share at least: four whole first subdivisions.
pub const WITNESS_FLOOR: usize = 4 * MAX_CELLS;
/// Cells per patch of a range that the deeper subdivisions of its patches share. On the
/// test meshes, 1 patch in 120 at most goes deeper (Suzanne, G1), with 7,545 cells at
/// most: 63 per patch of the mesh; a book of 1,000 triangles around one edge, 1 in 40.
pub const DEEP_SHARE: usize = 1024;
/// Cells those deeper subdivisions share at least: four whole ones.
pub const DEEP_FLOOR: usize = 4 * DEEP_CELLS;

#[cfg(test)]
mod tests {
    use super::{
        check_within, classify, flat_lower_bound, grid_witness, interior_powers, quick_flat,
        quick_half, quick_quartic, scratch, shared, tables, FirstWork, Geometry, Quick, Stage,
        Verdict, MAX_CELLS, MAX_DEPTH, QUARTIC_BOUNDARY, QUARTIC_INTERIOR, QUARTIC_UP, WHOLE,
    };
    use crate::patch::basis;
    use crate::patch::validity::jacobian;
    use crate::PatchTable;
    use crate::{LoadOptions, Mesh};
    use crate::{Scheme, SchemeOptions};
    use glam::DVec3;

    /// The compile-time index tables of [`quick_quartic`] are those of the runtime
    /// functions they stand for.
    #[test]
    fn quartic_tables_match_the_basis() {
        for (j, p) in basis::g1_boundary_powers().iter().enumerate() {
            assert_eq!(QUARTIC_BOUNDARY[j], basis::bezier_index(4, *p));
        }
        for (m, &slot) in QUARTIC_INTERIOR.iter().enumerate() {
            assert_eq!(slot, basis::bezier_index(4, interior_powers(m)));
        }
        assert_eq!(tables().up[4], QUARTIC_UP.to_vec());
    }

    /// The products are listed row by row (the order in which each coefficient's sum takes
    /// its terms, [`lanes::ByCoefficient`]): pair (α, β) is entry α · len + β.
    #[test]
    fn products_go_row_by_row() {
        for m in 0..=4u32 {
            let len = tables().powers[m as usize].len();
            let products = &super::products(m, &tables().powers[m as usize]);
            assert_eq!(products.len(), len * len);
            for (k, &(a, b, _, _)) in products.iter().enumerate() {
                assert_eq!((a, b), (k / len, k % len), "m {m}");
            }
        }
    }

    /// Every bunny G1 patch that [`quick_flat`] certifies has J > 0 at the 15 points of a
    /// level-4 barycentric grid by the patch's own f64 evaluation (independent of the
    /// bound), and the pre-test certifies the bulk of the patches of this fine mesh.
    #[test]
    fn quick_flat_certifies_only_positive_jacobians() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/stanford-bunny.obj");
        let mesh = Mesh::load(path, &LoadOptions::default()).unwrap();
        let table = PatchTable::build(&mesh, Scheme::G1, &SchemeOptions::default()).unwrap();
        let mut passed = 0;
        for i in 0..table.len() {
            let c = table.patch(i);
            let (ds, dt, r, cmax) = quick_quartic(c);
            if !quick_flat(c, &ds, &dt, r, table.flat_normals[i], cmax) {
                continue;
            }
            passed += 1;
            for p in basis::bezier_powers(4) {
                let b = p.map(|k| k as f64 / 4.0);
                // Strictly positive: the certificate keeps a margin far above rounding.
                let (j, _) = jacobian(&table, i, b);
                assert!(j > 0.0, "patch {i} at {b:?}: J = {j}");
            }
        }
        // Deterministic: 66,615 of the 69,451 patches.
        assert_eq!((passed, table.len()), (66_615, 69_451));
    }

    /// Every G1 patch of the test meshes that only the second half of
    /// [`super::quick::quick_gregory`] certifies (the first does not) has J > 0 at the 45 points of a level-8
    /// barycentric grid by the patch's own f64 evaluation, and the subdivision alone
    /// certifies it too (so the verdict is the one it had before the test existed).
    #[test]
    fn the_quick_normal_part_certifies_what_the_subdivision_does() {
        let mut only = Vec::new();
        for (file, crease) in [
            ("stanford-bunny.obj", None),
            ("spot.obj", None),
            ("suzanne.obj", None),
            ("fandisk.obj", Some(30.0)),
        ] {
            let path = format!("{}/tests/data/{file}", env!("CARGO_MANIFEST_DIR"));
            let mesh =
                Mesh::load(&path, &LoadOptions::default().with_crease_angle(crease)).unwrap();
            let table = PatchTable::build(&mesh, Scheme::G1, &SchemeOptions::default()).unwrap();
            let mut count = 0;
            for i in 0..table.len() {
                if quick_half(table.patch(i), table.flat_normals[i]) != Quick::Second {
                    continue;
                }
                count += 1;
                for p in basis::bezier_powers(8) {
                    let b = p.map(|k| k as f64 / 8.0);
                    let (j, _) = jacobian(&table, i, b);
                    assert!(j > 0.0, "{file} patch {i} at {b:?}: J = {j}");
                }
                let geom = Geometry::new(&table, i);
                let (v, _, _) = check_within(&table, i, &geom, MAX_DEPTH, MAX_CELLS, usize::MAX);
                assert_eq!(v, Verdict::Valid, "{file} patch {i}");
            }
            only.push(count);
        }
        // Deterministic counts: bunny, spot, Suzanne, fandisk.
        assert_eq!(only, vec![157, 4, 244, 0]);
    }

    /// [`flat_lower_bound`] is bitwise the general [`Geometry::bound`] on the whole domain
    /// for flat patches: every bunny triangle, and made-up ones that are slivers (normal
    /// from the triangle, sin of the angle 1e-12, below the 1e-9 tolerance), degenerate
    /// (zero and non-finite normals), huge or tiny, or flipped against their normal.
    #[test]
    fn flat_bound_is_the_general_bound() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/stanford-bunny.obj");
        let mesh = Mesh::load(path, &LoadOptions::default()).unwrap();
        let mut table = PatchTable::build(&mesh, Scheme::Flat, &SchemeOptions::default()).unwrap();
        let made: [([DVec3; 3], DVec3); 7] = [
            (
                [DVec3::ZERO, DVec3::X, DVec3::new(0.5, 1e-12, 0.0)],
                DVec3::Z,
            ),
            ([DVec3::ZERO, DVec3::X, 2.0 * DVec3::X], DVec3::ZERO),
            ([DVec3::ZERO, DVec3::X, DVec3::Y], DVec3::NAN),
            ([DVec3::ZERO, 1e70 * DVec3::X, 1e70 * DVec3::Y], DVec3::Z),
            (
                [DVec3::ZERO, 1e-160 * DVec3::X, 1e-160 * DVec3::Y],
                DVec3::Z,
            ),
            ([DVec3::ZERO, DVec3::X, DVec3::Y], -DVec3::Z),
            ([DVec3::ONE, DVec3::X, DVec3::INFINITY], DVec3::Z),
        ];
        for (c, n) in made {
            table.points.extend(c);
            table.flat_normals.push(n);
        }
        let mut valid = 0;
        for i in 0..table.len() {
            let general = Geometry::new(&table, i).bound(&WHOLE, &mut scratch()).0;
            let flat = flat_lower_bound(table.patch(i), table.flat_normals[i]);
            assert_eq!(
                flat.to_bits(),
                general.to_bits(),
                "patch {i}: {flat} {general}"
            );
            valid += usize::from(flat > 0.0);
        }
        // Every bunny triangle (the loader drops degenerate ones) and three made-up ones:
        // the huge and tiny ones (the tolerance scales with the triangle; the tiny one's J,
        // 1e-320, is subnormal but positive and its tolerance underflows to 0), and the one
        // with a NaN normal (the general bound's minimum passes over a NaN coefficient; the
        // table's flat normals are never NaN).
        assert_eq!(valid, 69_451 + 3);
    }

    /// [`shared`] on searches that need known numbers of cells: within a budget that
    /// covers them all every one finishes; within a smaller one the largest needs stop at an
    /// even share of what the others leave, and what is charged stays within the budget.
    #[test]
    fn shared_budgets_go_to_the_searches_that_need_them() {
        let needs = [1usize, 5, 3000, 100, 40, 9000, 2];
        let ids: Vec<usize> = (0..needs.len()).collect();
        let runs = std::sync::Mutex::new(vec![0usize; needs.len()]);
        let search = |i: usize, stop: usize| {
            runs.lock().unwrap()[i] += 1;
            if needs[i] <= stop {
                (Verdict::Valid, needs[i], false)
            } else {
                (Verdict::Undecided, stop, true)
            }
        };
        let all: usize = needs.iter().sum();
        let out = shared(&ids, all, |i| i, |&mut i: &mut usize, stop| search(i, stop));
        assert!(out.iter().all(|r| r.0 == Verdict::Valid && !r.2));
        let runs_all = runs.lock().unwrap().clone();
        // The first round (64 cells each) finishes 1, 5, 40 and 2, the second (4,033
        // each) 3,000 and 100, the third 9,000 (9,000 cells left, over twice 4,033).
        assert_eq!(runs_all, vec![1, 1, 2, 2, 1, 3, 1]);
        // 6,000 cells: 48 for the four small ones, the three others an even share of the
        // rest (1,984 each), of which 100 needs little; the two left would get 2,926
        // each, less than twice their share: they stop at 1,984.
        let runs = std::sync::Mutex::new(vec![0usize; needs.len()]);
        let search = |i: usize, stop: usize| {
            runs.lock().unwrap()[i] += 1;
            if needs[i] <= stop {
                (Verdict::Valid, needs[i], false)
            } else {
                (Verdict::Undecided, stop, true)
            }
        };
        let out = shared(
            &ids,
            6000,
            |i| i,
            |&mut i: &mut usize, stop| search(i, stop),
        );
        let stopped: Vec<usize> = (0..needs.len()).filter(|&k| out[k].2).collect();
        assert_eq!(stopped, vec![2, 5]);
        assert_eq!(out[2].1, 1984);
        let charged: usize = out.iter().map(|r| r.1).sum();
        assert!(charged <= 6000, "{charged}");
    }

    /// A subdivision stopped and run on ([`CellSearch`], as [`shared`] runs them) gives
    /// bitwise what one run gives: the same verdict (a fold's witness too) and the same
    /// cells, on every Suzanne patch that goes to a subdivision, G1 and PN, stopped after
    /// 1, 64 and 500 cells.
    #[test]
    fn a_search_run_on_is_the_search_run_once() {
        let path = format!("{}/tests/data/suzanne.obj", env!("CARGO_MANIFEST_DIR"));
        let mesh = Mesh::load(&path, &LoadOptions::default()).unwrap();
        let mut compared = [0usize; 2];
        for scheme in [Scheme::G1, Scheme::Pn] {
            let table = PatchTable::build(&mesh, scheme, &SchemeOptions::default()).unwrap();
            for i in 0..table.len() {
                let Some(geom) = classify(&table, i, &mut FirstWork::new()).1 else {
                    continue;
                };
                let once = check_within(&table, i, &geom, MAX_DEPTH, MAX_CELLS, usize::MAX);
                for first in [1, 64, 500] {
                    let mut search = super::CellSearch::new(i, MAX_DEPTH, MAX_CELLS);
                    let early = search.run(&table, &geom, first);
                    let on = if early.2 {
                        search.run(&table, &geom, usize::MAX)
                    } else {
                        early
                    };
                    let bits = |v: &Verdict| match *v {
                        Verdict::Folded { s, t, jacobian } => {
                            [s, t, jacobian].map(f64::to_bits).to_vec()
                        }
                        Verdict::Valid => vec![0],
                        Verdict::Undecided => vec![1],
                    };
                    assert_eq!(
                        (bits(&on.0), on.1, on.2),
                        (bits(&once.0), once.1, once.2),
                        "{scheme} {i} {first}"
                    );
                    // Stopped only where one run takes more cells.
                    assert_eq!(early.2, once.1 > first, "{scheme} {i}");
                    compared[early.2 as usize] += 1;
                }
            }
        }
        // Searches that finished within their first stop, and searches stopped and run on.
        assert_eq!(compared, [416, 490]);
    }

    /// A deeper subdivision that reads what the first recorded ([`super::CellSearch`]'s
    /// memo) gives bitwise what one without it gives, run at once or stopped after 64
    /// cells and run on, and with the memo of a first subdivision that was itself stopped
    /// and run on: on every patch of Suzanne's G1 surface that the first subdivision leaves
    /// undecided. A search that has ended gives its result again.
    #[test]
    fn a_deeper_search_reading_the_first_is_the_deeper_search() {
        use super::{CellSearch, DEEP_CELLS, DEEP_DEPTH};
        let bits = |r: (Verdict, usize, bool)| {
            let v = match r.0 {
                Verdict::Folded { s, t, jacobian } => [s, t, jacobian].map(f64::to_bits),
                Verdict::Valid => [0; 3],
                Verdict::Undecided => [1; 3],
            };
            (v, r.1, r.2)
        };
        let mut deeper = Vec::new();
        for (file, scheme) in [("suzanne", Scheme::G1), ("suzanne", Scheme::Pn)] {
            let path = format!("{}/tests/data/{file}.obj", env!("CARGO_MANIFEST_DIR"));
            let mesh = Mesh::load(&path, &LoadOptions::default()).unwrap();
            let table = PatchTable::build(&mesh, scheme, &SchemeOptions::default()).unwrap();
            let mut count = 0;
            for i in 0..table.len() {
                let (Stage::First, Some(geom)) = classify(&table, i, &mut FirstWork::new()) else {
                    continue;
                };
                let mut first = CellSearch::new(i, MAX_DEPTH, MAX_CELLS).recording();
                let r = first.run(&table, &geom, usize::MAX);
                if r.0 != Verdict::Undecided {
                    continue;
                }
                let plain = check_within(&table, i, &geom, DEEP_DEPTH, DEEP_CELLS, usize::MAX);
                let memo = first.take_memo().unwrap();
                assert!(memo.len() > 0);
                let mut read = CellSearch::new(i, DEEP_DEPTH, DEEP_CELLS).reading(memo);
                assert_eq!(bits(read.run(&table, &geom, usize::MAX)), bits(plain));
                assert_eq!(bits(read.run(&table, &geom, usize::MAX)), bits(plain));
                assert_eq!(bits(first.run(&table, &geom, usize::MAX)), bits(r));
                // A memo of a first search stopped after 64 cells and run on (it records
                // afresh from there), read by a deeper search also stopped and run on.
                let memo = {
                    let mut f = CellSearch::new(i, MAX_DEPTH, MAX_CELLS).recording();
                    assert!(f.run(&table, &geom, 64).2);
                    assert_eq!(bits(f.run(&table, &geom, usize::MAX)), bits(r));
                    f.take_memo().unwrap()
                };
                assert!(memo.len() > 0);
                let mut read = CellSearch::new(i, DEEP_DEPTH, DEEP_CELLS).reading(memo);
                let early = read.run(&table, &geom, 64);
                assert!(early.2 || bits(early) == bits(plain));
                if early.2 {
                    assert_eq!(bits(read.run(&table, &geom, usize::MAX)), bits(plain));
                }
                count += 1;
            }
            deeper.push(count);
        }
        // Suzanne's PN patches left undecided are never certifiable (no deeper search).
        assert_eq!(deeper, [6, 0]);
    }

    /// A G1 patch whose normals lie in its triangle's plane is never certified: J's
    /// coefficient at a corner is 0, and the whole first subdivision (no bound on its
    /// cells) finds no certifiable cell there; with the normal of its plane it certifies.
    #[test]
    fn in_plane_normals_are_never_certified() {
        let p = [DVec3::ZERO, DVec3::X, DVec3::Y];
        let table = |n: DVec3| {
            let mesh = Mesh::from_soup(
                "one",
                &p,
                &[[0, 1, 2]],
                Some(&[n; 3]),
                &LoadOptions::default(),
            )
            .unwrap();
            PatchTable::build(&mesh, Scheme::G1, &SchemeOptions::default()).unwrap()
        };
        let flat = table(DVec3::Z);
        assert!(!Geometry::new(&flat, 0).never_certified());
        let in_plane = table(DVec3::new(1.0, 1.0, 0.0).normalize());
        let g = Geometry::new(&in_plane, 0);
        assert!(g.never_certified());
        let (v, cells, stopped) = check_within(&in_plane, 0, &g, MAX_DEPTH, MAX_CELLS, usize::MAX);
        assert!(
            v != Verdict::Valid && !stopped && cells > 0,
            "{v:?} after {cells}"
        );
    }

    /// The whole-domain bound that [`classify`] tries first on polynomial patches gives the
    /// verdict the rest would: on every patch of Suzanne (split normals, a non-manifold
    /// edge) and of the fandisk (creases, folds: Nagata's patches fold there) that it
    /// certifies, the grid holds no witness and the subdivision certifies the patch, and
    /// it certifies a patch of every polynomial scheme (the fast path is taken).
    #[test]
    fn the_whole_domain_bound_first_changes_no_verdict() {
        for (file, crease) in [("suzanne.obj", None), ("fandisk.obj", Some(30.0))] {
            let path = format!("{}/tests/data/{file}", env!("CARGO_MANIFEST_DIR"));
            let mesh =
                Mesh::load(&path, &LoadOptions::default().with_crease_angle(crease)).unwrap();
            for scheme in Scheme::all() {
                if scheme == Scheme::G1 {
                    continue;
                }
                let table = PatchTable::build(&mesh, scheme, &SchemeOptions::default()).unwrap();
                let mut work = FirstWork::new();
                let mut fast = 0;
                for i in 0..table.len() {
                    let geom = Geometry::new(&table, i);
                    if geom.bound(&WHOLE, &mut scratch()).0 > 0.0 {
                        fast += 1;
                        assert!(
                            grid_witness(&table, i, &mut work).is_none(),
                            "{file} {scheme} {i}"
                        );
                        let (v, cells, _) =
                            check_within(&table, i, &geom, MAX_DEPTH, MAX_CELLS, usize::MAX);
                        assert_eq!((v, cells), (Verdict::Valid, 1), "{file} {scheme} {i}");
                        let stage = classify(&table, i, &mut FirstWork::new()).0;
                        assert_eq!(stage, Stage::Done(Verdict::Valid));
                    }
                }
                assert!(fast > 0, "{file} {scheme}");
            }
        }
    }
}
