//! Per-edge tessellation levels: given per edge ([`Levels::from_edges`]), from a function
//! of the edge ([`Levels::from_fn`]), from the screen ([`crate::tess::screen`]) or chosen
//! for a tolerance ([`levels_for_tolerance`]). Stitched by
//! [`StitchPlan::with_levels`](crate::tess::stitch::StitchPlan::with_levels) with the
//! pattern of [`crate::tess::layout`]: both triangles of an edge use the edge's one level,
//! so the output is watertight by construction.
//!
//! ```
//! use g1tess::CpuEvaluator;
//! use g1tess::{LoadOptions, Mesh};
//! use g1tess::{PatchTable, Scheme, SchemeOptions};
//! use g1tess::{InnerRule, Levels};
//! use g1tess::{stitch_plan, StitchPlan};
//!
//! let mesh = Mesh::load("sphere320", &LoadOptions::default())?;
//! let adjacency = mesh.adjacency();
//! let table = PatchTable::build(&mesh, Scheme::G1, &SchemeOptions::default())?;
//! // About one segment per 0.05 units of edge length; patches as fine as their finest edge.
//! let levels = Levels::from_fn(
//!     &mesh,
//!     &adjacency,
//!     |e| (e.p[0].distance(e.p[1]) / 0.05).ceil().max(1.0) as u32,
//!     InnerRule::Max,
//! )?;
//! let plan = StitchPlan::with_levels(&mesh, &adjacency, &levels)?;
//! let (surface, _snap) = stitch_plan::<[f32; 3]>(&plan, &table, &CpuEvaluator::default())?;
//! assert_eq!(surface.triangles.len(), plan.triangles);
//! # Ok::<(), g1tess::Error>(())
//! ```
//!
//! **Tolerance.** The levels come from a measured curvature proxy, then are checked by
//! sampling:
//! 1. every patch is evaluated (f64) on the grid of level 4; the largest second difference
//!    along the three grid directions, divided by the step squared, estimates D, the
//!    largest second derivative of the patch along an edge direction (per unit of the
//!    edge parameter). A flat triangle of the grid of level n deviates from a quadratic by
//!    at most ½ Σ λ_i λ_j |e_ijᵀ H e_ij| ≤ D / (6 n²), so the patch asks for
//!    n_p = ⌈√(D / (6 ε))⌉ as its inner level; an edge takes the largest n_p of its
//!    triangles;
//! 2. the stitched surface (f64) is measured: 10 points inside every output triangle (the
//!    barycentric points (a, b, c)/6 with a, b, c ≥ 1), each flat point compared with the
//!    patch evaluated (f64) at the same parameter: the distance between them bounds the
//!    distance from the flat point to the surface;
//! 3. patches whose measured deviation exceeds ε are refined (inner level scaled by
//!    √(measured / ε) with 5 % to spare, one step at least; their edges follow) and the
//!    surface is measured again, until every patch is within ε, or the level cap or the
//!    number of rounds is reached;
//! 4. once within ε, the levels are coarsened: c = d n² (d the patch's measured deviation at
//!    level n) predicts the smallest level within ε; patches are lowered to it (later
//!    attempts: one level at least), measured, and those that fail go back and never try
//!    that level again; the measured levels with the fewest triangles are kept.
//!
//! The result says whether ε was met and reports the measured deviation of exactly the
//! levels it returns; it never claims a tolerance it did not measure.

use glam::DVec3;

use crate::eval::{Evaluator, PatchPoint, Pattern};
use crate::mesh::{Adjacency, Mesh};
use crate::patch::PatchTable;
use crate::progress::Progress;
use crate::tess::layout::MAX_LEVEL;
use crate::tess::stitch::{stitch_into, Needs, PatchOut, StitchPlan, StitchSink};
use crate::{Error, Result};

pub use crate::tess::levels::{InnerRule, Levels};

/// Interior points of an output triangle at which its deviation is measured: (a, b, c)/6
/// with a, b, c ≥ 1 (10 points).
pub const DEVIATION_POINTS: [[f64; 3]; 10] = {
    let mut out = [[0.0; 3]; 10];
    let mut k = 0;
    let mut a = 1;
    while a <= 4 {
        let mut b = 1;
        while a + b <= 5 {
            let c = 6 - a - b;
            out[k] = [a as f64 / 6.0, b as f64 / 6.0, c as f64 / 6.0];
            k += 1;
            b += 1;
        }
        a += 1;
    }
    out
};

/// Measured deviation of a stitched surface from its patches (`measure_deviation`).
#[derive(Clone, Debug, PartialEq)]
pub struct Deviation {
    /// Largest over every measured point.
    pub max: f64,
    /// Largest per patch.
    pub per_patch: Vec<f64>,
    /// Output triangles measured.
    pub triangles: usize,
    /// Points measured (10 per triangle).
    pub points: usize,
}

/// Points a measurement evaluates at once.
const MEASURE_POINTS: usize = 1 << 16;

/// Bytes that [`measure_deviation`]'s own buffers hold beside the stitcher's, for patches
/// of levels up to `level`: the barycentric coordinates of one patch's grid points, and
/// the points queued for evaluation (at most [`MEASURE_POINTS`] and one triangle's more)
/// with their flat points.
pub fn measure_bytes(level: u32) -> u64 {
    let n = level.max(1) as u64;
    let per = (n + 1).saturating_mul(n + 2) / 2;
    let queued = (MEASURE_POINTS + 10 * 64) as u64;
    let point = (std::mem::size_of::<PatchPoint>() + std::mem::size_of::<DVec3>()) as u64;
    per.saturating_mul(std::mem::size_of::<[f64; 3]>() as u64)
        .saturating_add(queued * point)
}

/// The sink that measures: queues (patch point, flat point) pairs, evaluates the patch
/// points in runs.
struct Measure<'a> {
    plan: &'a StitchPlan,
    table: &'a PatchTable,
    reference: &'a dyn Evaluator,
    bary: Vec<[f64; 3]>,
    points: Vec<PatchPoint>,
    flat: Vec<DVec3>,
    dev: Deviation,
}

impl Measure<'_> {
    fn flush(&mut self) -> Result<()> {
        if self.points.is_empty() {
            return Ok(());
        }
        let pattern = Pattern::Points(std::mem::take(&mut self.points));
        let (flat, dev) = (&self.flat, &mut self.dev);
        let Pattern::Points(points) = &pattern else {
            unreachable!("built as points above")
        };
        self.reference.evaluate(self.table, &pattern, &mut |c| {
            for (k, s) in c.positions.iter().enumerate() {
                let i = c.first + k;
                let d = s.distance(flat[i]);
                let p = points[i].patch as usize;
                dev.max = dev.max.max(d);
                dev.per_patch[p] = dev.per_patch[p].max(d);
            }
            Ok(())
        })?;
        dev.points += flat.len();
        if let Pattern::Points(mut p) = pattern {
            p.clear();
            self.points = p;
        }
        self.flat.clear();
        Ok(())
    }
}

impl StitchSink<DVec3> for Measure<'_> {
    fn needs(&self) -> Needs {
        Needs {
            positions: false,
            triangles: false,
            grid_positions: true,
        }
    }

    fn patch(&mut self, out: &PatchOut<'_, DVec3>) -> Result<()> {
        self.bary.clear();
        self.plan.patch_points(out.patch, &mut self.bary);
        let patch = out.patch as u32;
        for t in out.grid_triangles {
            let b = t.map(|i| self.bary[i as usize]);
            let p = t.map(|i| out.grid_positions[i as usize]);
            for w in DEVIATION_POINTS {
                let mut q = [0.0; 3];
                for (k, qk) in q.iter_mut().enumerate() {
                    *qk = w[0] * b[0][k] + w[1] * b[1][k] + w[2] * b[2][k];
                }
                self.points.push(PatchPoint { patch, b: q });
                self.flat.push(w[0] * p[0] + w[1] * p[1] + w[2] * p[2]);
            }
            // Within a patch too: one patch at a high level has millions of triangles.
            if self.points.len() >= MEASURE_POINTS {
                self.flush()?;
            }
        }
        self.dev.triangles += out.grid_triangles.len();
        Ok(())
    }
}

/// Measures how far the flat triangles of `plan`'s stitched surface (evaluated in f64 by
/// `reference`) lie from the patches: at [`DEVIATION_POINTS`] inside every output
/// triangle, the distance between the flat point and the patch evaluated (f64, by
/// `reference`) at the same parameter.
pub fn measure_deviation(
    plan: &StitchPlan,
    table: &PatchTable,
    reference: &dyn Evaluator,
    progress: &dyn Progress,
) -> Result<Deviation> {
    let mut m = Measure::new(plan, table, reference);
    stitch_into::<DVec3>(plan, table, reference, &mut m, progress)?;
    m.flush()?;
    Ok(m.dev)
}

impl<'a> Measure<'a> {
    fn new(plan: &'a StitchPlan, table: &'a PatchTable, reference: &'a dyn Evaluator) -> Self {
        Measure {
            plan,
            table,
            reference,
            bary: Vec::new(),
            points: Vec::with_capacity(MEASURE_POINTS + 10 * 64),
            flat: Vec::new(),
            dev: Deviation {
                max: 0.0,
                per_patch: vec![0.0; plan.patches()],
                triangles: 0,
                points: 0,
            },
        }
    }
}

/// What [`levels_for_tolerance`] is asked.
///
/// Built from [`ToleranceOptions::new`] (or [`ToleranceOptions::default()`]) and the
/// `with_*` methods:
///
/// ```
/// let opts = g1tess::ToleranceOptions::new(1e-3).with_max_level(32);
/// assert_eq!((opts.tolerance, opts.max_level, opts.rounds), (1e-3, 32, 8));
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub struct ToleranceOptions {
    /// Largest deviation allowed (absolute, the mesh's units; default 1e-3).
    pub tolerance: f64,
    /// Cap on every level (default 64, as `g1tess tessellate --tolerance`).
    pub max_level: u32,
    /// Most refinement rounds after the first measurement (coarsening attempts once the
    /// tolerance is met come on top: four at most, two measurements each; default 8, as
    /// `g1tess tessellate --tolerance`).
    pub rounds: u32,
}

impl Default for ToleranceOptions {
    fn default() -> Self {
        ToleranceOptions {
            tolerance: 1e-3,
            max_level: 64,
            rounds: 8,
        }
    }
}

impl ToleranceOptions {
    /// The defaults with this tolerance.
    pub fn new(tolerance: f64) -> Self {
        ToleranceOptions::default().with_tolerance(tolerance)
    }

    /// Sets [`ToleranceOptions::tolerance`].
    pub fn with_tolerance(mut self, tolerance: f64) -> Self {
        self.tolerance = tolerance;
        self
    }

    /// Sets [`ToleranceOptions::max_level`].
    pub fn with_max_level(mut self, max_level: u32) -> Self {
        self.max_level = max_level;
        self
    }

    /// Sets [`ToleranceOptions::rounds`].
    pub fn with_rounds(mut self, rounds: u32) -> Self {
        self.rounds = rounds;
        self
    }
}

/// Levels chosen for a tolerance, with their measured deviation.
#[derive(Clone, Debug)]
pub struct ToleranceLevels {
    /// The chosen edge and inner levels.
    pub levels: Levels,
    /// The measurement of the final levels.
    pub deviation: Deviation,
    /// Whether the measured deviation is within the tolerance.
    pub met: bool,
    /// Measurements after the first.
    pub rounds: u32,
    /// Patches at the level cap whose deviation still exceeds the tolerance.
    pub capped_patches: usize,
}

/// Curvature proxy D of every patch (see the module notes): the largest second difference
/// on the grid of level 4 along the three grid directions, over the step squared.
pub fn curvature_proxy(table: &PatchTable, reference: &dyn Evaluator) -> Result<Vec<f64>> {
    const N: u32 = 4;
    let per = crate::eval::grid_len(N);
    let idx = |i: u32, j: u32| crate::eval::pattern::grid_index(N, i, j);
    let mut out = Vec::with_capacity(table.len());
    reference.evaluate(table, &Pattern::Grid { level: N }, &mut |c| {
        for p in c.positions.chunks_exact(per) {
            let mut d2 = 0f64;
            for j in 0..=N {
                for i in 0..=N - j {
                    let a = p[idx(i, j)];
                    // Directions (1, 0), (0, 1), (−1, 1): the three edge directions.
                    if i + j + 2 <= N {
                        let s = a - 2.0 * p[idx(i + 1, j)] + p[idx(i + 2, j)];
                        d2 = d2.max(s.length_squared());
                        let s = a - 2.0 * p[idx(i, j + 1)] + p[idx(i, j + 2)];
                        d2 = d2.max(s.length_squared());
                    }
                    if i >= 2 {
                        let s = a - 2.0 * p[idx(i - 1, j + 1)] + p[idx(i - 2, j + 2)];
                        d2 = d2.max(s.length_squared());
                    }
                }
            }
            out.push(d2.sqrt() * (N * N) as f64);
        }
        Ok(())
    })?;
    Ok(out)
}

/// Edge levels as the largest inner level of their triangles.
fn edges_from_inner(adjacency: &Adjacency, inner: &[u32]) -> Vec<u32> {
    adjacency
        .edges
        .iter()
        .map(|e| {
            e.uses
                .iter()
                .map(|u| inner[u.triangle as usize])
                .max()
                .unwrap_or(1)
        })
        .collect()
}

/// Chooses levels so that the stitched surface's flat triangles deviate from the patches
/// by at most `opts.tolerance` (see the module notes), measuring with `reference` (the
/// f64 evaluator). `progress` sees each measurement.
pub fn levels_for_tolerance(
    mesh: &Mesh,
    adjacency: &Adjacency,
    table: &PatchTable,
    reference: &dyn Evaluator,
    opts: &ToleranceOptions,
    progress: &dyn Progress,
) -> Result<ToleranceLevels> {
    let eps = opts.tolerance;
    if !(eps.is_finite() && eps > 0.0) {
        return Err(Error::Invalid(format!(
            "{}: tolerance {eps} (a positive finite distance expected)",
            mesh.name
        )));
    }
    if opts.max_level == 0 || opts.max_level > MAX_LEVEL {
        return Err(Error::Invalid(format!(
            "{}: level cap {} (1..={MAX_LEVEL} expected)",
            mesh.name, opts.max_level
        )));
    }
    let cap = opts.max_level;
    let d = curvature_proxy(table, reference)?;
    let mut inner: Vec<u32> = d
        .iter()
        .map(|&d| ((d / (6.0 * eps)).sqrt().ceil().clamp(1.0, cap as f64)) as u32)
        .collect();
    let measure = |inner: &[u32]| -> Result<(Levels, Deviation)> {
        let levels = Levels {
            edges: edges_from_inner(adjacency, inner),
            inner: inner.to_vec(),
        };
        let plan = StitchPlan::with_levels(mesh, adjacency, &levels)?;
        let deviation = measure_deviation(&plan, table, reference, progress)?;
        Ok((levels, deviation))
    };
    let result = |levels: Levels, deviation: Deviation, rounds: u32, inner: &[u32]| {
        let capped = deviation
            .per_patch
            .iter()
            .zip(inner)
            .filter(|&(&dp, &n)| dp > eps && n >= cap)
            .count();
        ToleranceLevels {
            levels,
            met: deviation.max <= eps,
            rounds,
            capped_patches: capped,
            deviation,
        }
    };
    // Refine: patches over ε are raised (the deviation falls as 1/n²: scaled by
    // √(measured / ε) with 5 % to spare, one step at least) until every patch is within ε.
    let mut round = 0;
    let (mut levels, mut deviation) = measure(&inner)?;
    while deviation.max > eps {
        let mut changed = false;
        for (p, &dp) in deviation.per_patch.iter().enumerate() {
            let n = inner[p];
            if dp > eps && n < cap {
                let want = (n as f64 * (dp / eps).sqrt() * 1.05).ceil() as u32;
                inner[p] = want.max(n + 1).min(cap);
                changed = true;
            }
        }
        if !changed || round >= opts.rounds {
            return Ok(result(levels, deviation, round, &inner));
        }
        round += 1;
        (levels, deviation) = measure(&inner)?;
    }
    // Coarsen: c = d n² predicts the smallest level within ε for each patch (one level
    // lower at least, the model being rough at low levels); patches that then fail go back
    // to their level and never try that lower one again.
    let mut best = result(levels, deviation, round, &inner);
    let mut best_inner = inner.clone();
    let mut lowest = vec![1u32; inner.len()];
    let mut aggressive = false;
    let mut attempts = 0;
    while attempts < COARSEN_ATTEMPTS {
        inner.clone_from(&best_inner);
        let mut changed = false;
        for (p, &dp) in best.deviation.per_patch.iter().enumerate() {
            let n = inner[p];
            let mut want = ((dp / eps).sqrt() * n as f64).ceil() as u32;
            if aggressive {
                want = want.min(n.saturating_sub(1));
            }
            let next = want.max(lowest[p]).max(1);
            if next < n {
                inner[p] = next;
                changed = true;
            }
        }
        if !changed {
            if aggressive {
                break;
            }
            aggressive = true;
            continue;
        }
        attempts += 1;
        round += 1;
        let (mut levels, mut deviation) = measure(&inner)?;
        if deviation.max > eps {
            for (p, &dp) in deviation.per_patch.iter().enumerate() {
                if dp > eps && inner[p] < best_inner[p] {
                    lowest[p] = inner[p] + 1;
                    inner[p] = best_inner[p];
                }
            }
            round += 1;
            (levels, deviation) = measure(&inner)?;
        }
        if deviation.max <= eps && deviation.triangles < best.deviation.triangles {
            best = result(levels, deviation, round, &inner);
            best_inner.clone_from(&inner);
        } else if aggressive {
            break;
        } else {
            aggressive = true;
        }
    }
    best.rounds = round;
    Ok(best)
}

/// Coarsening attempts of [`levels_for_tolerance`] once the tolerance is met.
const COARSEN_ATTEMPTS: usize = 4;

#[cfg(test)]
mod tests {
    use super::{Measure, MEASURE_POINTS};
    use crate::eval::cpu::CpuEvaluator;
    use crate::progress::NoProgress;
    use crate::tess::stitch::{stitch_into, StitchPlan};
    use crate::{InnerRule, Levels, LoadOptions, Mesh, PatchTable, Scheme, SchemeOptions};
    use glam::DVec3;

    /// One patch at level 128 has 16,384 output triangles, 163,840 points to measure: the
    /// measurement evaluates them a bounded run at a time, so what it queues never
    /// outgrows [`MEASURE_POINTS`] and one triangle's points (it held the whole patch's,
    /// 9 GB at level 4,096, before).
    #[test]
    fn a_measurement_queues_a_bounded_number_of_points() {
        let p = [DVec3::ZERO, DVec3::X, DVec3::Y];
        let n = [DVec3::new(0.2, 0.1, 1.0).normalize(), DVec3::Z, DVec3::Z];
        let mesh =
            Mesh::from_soup("one", &p, &[[0, 1, 2]], Some(&n), &LoadOptions::default()).unwrap();
        let adjacency = mesh.adjacency();
        let table = PatchTable::build(&mesh, Scheme::G1, &SchemeOptions::default()).unwrap();
        let levels = Levels::from_fn(&mesh, &adjacency, |_| 128, InnerRule::Max).unwrap();
        let plan = StitchPlan::with_levels(&mesh, &adjacency, &levels).unwrap();
        let reference = CpuEvaluator::default();
        let mut m = Measure::new(&plan, &table, &reference);
        stitch_into::<DVec3>(&plan, &table, &reference, &mut m, &NoProgress).unwrap();
        m.flush().unwrap();
        assert_eq!((m.dev.triangles, m.dev.points), (128 * 128, 10 * 128 * 128));
        let most = MEASURE_POINTS + 10 * 64;
        assert_eq!(m.points.capacity(), most);
        // The flat points grow by doubling up to the run's length.
        assert!(m.flat.capacity() <= 2 * most, "{}", m.flat.capacity());
        assert!(m.dev.max > 0.0 && m.dev.max.is_finite());
    }
}
