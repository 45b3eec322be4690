//! The fair G1 surface: vertex normals and tangent lengths chosen to lower the bending
//! energy ∫ (κ₁² + κ₂²) dA while the surface stays G1, watertight, interpolating and
//! certified free of folds ([`fair`]). The search itself is in the repair's module (it
//! moves normal groups and arm factors under the validity certificate, as the repair
//! does); the energy it minimises is the adaptive [`BendingEnergy::points`] with one cell
//! per Duffy square (the fixed rule, [`BendingEnergy::points_fixed`], missed the energy
//! concentrated near a fold between its nodes, and the search found such places), and the
//! report gives [`BendingEnergy::total_certified`] (two cells per square) before and after. Method, sources and
//! figures: `docs/fair.md`.

use serde::Serialize;

use super::fairness::{total_of_parts, BendingEnergy, EnergyTotal, FairnessOptions};
use crate::mesh::Mesh;
use crate::patch::repair::fair::{run, Params};
use crate::patch::validity::{check_in_chunks, singular_at_a_corner, PatchCounts, Verdict};
use crate::patch::{PatchBuilder, Scheme, SchemeOptions};
use crate::progress::{NoProgress, Progress};
use crate::{Error, Result};

/// Options of [`fair`].
///
/// ```
/// use g1tess::FairOptions;
/// let opts = FairOptions::default().with_normal_bound_deg(10.0).with_sweeps(4);
/// assert_eq!(opts.normal_bound_deg, 10.0);
/// assert_eq!(opts.sweeps, 4);
/// assert!(opts.arms);
/// ```
#[derive(Clone, Copy, Debug)]
#[non_exhaustive]
pub struct FairOptions {
    /// Largest angle, in degrees, between a normal given in the file and the fair one
    /// (default 15). Estimated normals are free: where the loader estimated every corner's
    /// normal ([`crate::LoadReport::normals_estimated`]) none is bounded; where it
    /// estimated some, all are bounded.
    pub normal_bound_deg: f64,
    /// Most sweeps over the normal groups and edges (default 6).
    pub sweeps: usize,
    /// The sweeps stop when one lowers the energy by less than this fraction of it
    /// (default 1e-3).
    pub tolerance: f64,
    /// Whether the tangent lengths (arm factors of the interior edges' boundary curves)
    /// are searched too (default true).
    pub arms: bool,
    /// Smallest and largest arm factor (default [0.5, 2]).
    pub arm_range: [f64; 2],
    /// Cells per side of each Duffy square of the adaptive quadrature the search
    /// minimises (default 1: 270 nodes per patch before any refinement).
    pub subdivisions: u32,
    /// Options of the G1 scheme (the table is built with them afterwards).
    pub scheme_options: SchemeOptions,
}

impl Default for FairOptions {
    fn default() -> Self {
        FairOptions {
            normal_bound_deg: 15.0,
            sweeps: 6,
            tolerance: 1e-3,
            arms: true,
            arm_range: [0.5, 2.0],
            subdivisions: 1,
            scheme_options: SchemeOptions::default(),
        }
    }
}

impl FairOptions {
    /// With the bound on the file's normals (degrees, 0 to 180).
    pub fn with_normal_bound_deg(mut self, deg: f64) -> Self {
        self.normal_bound_deg = deg;
        self
    }
    /// With at most `sweeps` sweeps.
    pub fn with_sweeps(mut self, sweeps: usize) -> Self {
        self.sweeps = sweeps;
        self
    }
    /// With the stopping tolerance (relative decrease of one sweep).
    pub fn with_tolerance(mut self, tolerance: f64) -> Self {
        self.tolerance = tolerance;
        self
    }
    /// With or without the search of tangent lengths.
    pub fn with_arms(mut self, arms: bool) -> Self {
        self.arms = arms;
        self
    }
    /// With the range of the arm factors (0 < smallest ≤ 1 ≤ largest).
    pub fn with_arm_range(mut self, range: [f64; 2]) -> Self {
        self.arm_range = range;
        self
    }
    /// With the subdivisions of the search's quadrature.
    pub fn with_subdivisions(mut self, subdivisions: u32) -> Self {
        self.subdivisions = subdivisions;
        self
    }
    /// With the G1 scheme's options.
    pub fn with_scheme_options(mut self, scheme_options: SchemeOptions) -> Self {
        self.scheme_options = scheme_options;
        self
    }

    fn check(&self) -> Result<()> {
        let b = self.normal_bound_deg;
        let [lo, hi] = self.arm_range;
        if !(0.0..=180.0).contains(&b) {
            return Err(Error::Invalid(format!(
                "fair: normal bound {b}° is not between 0 and 180"
            )));
        }
        if !(lo > 0.0 && lo <= 1.0 && hi >= 1.0 && hi.is_finite()) {
            return Err(Error::Invalid(format!(
                "fair: arm range [{lo}, {hi}] does not hold 1 within (0, ∞)"
            )));
        }
        if self.tolerance.is_nan() || self.tolerance < 0.0 {
            return Err(Error::Invalid(format!(
                "fair: tolerance {} is not a number ≥ 0",
                self.tolerance
            )));
        }
        Ok(())
    }
}

/// What [`fair`] did.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FairReport {
    /// Verdicts of the input's G1 patches (the certificate's).
    pub before: PatchCounts,
    /// Verdicts of the fair surface's.
    pub after: PatchCounts,
    /// Bending energy of the input's certified patches (adaptive rule, the default
    /// [`FairnessOptions`]).
    pub energy_before: EnergyTotal,
    /// Bending energy of the fair surface's certified patches (same rule).
    pub energy_after: EnergyTotal,
    /// The bound on the normals' change, in degrees; `None` where every normal was
    /// estimated (free).
    pub normal_bound_deg: Option<f64>,
    /// Largest angle between a fair normal and the input one, in degrees.
    pub max_normal_change_deg: f64,
    /// Interior edges that are creases of the fair surface and not of the input (0 by
    /// construction: normal groups are never split).
    pub creases_made: usize,
    /// Patches that the crease-free start (the repair's crease-free phase and arm step,
    /// then the bound) left uncertified (by the repair's judge, which also refuses a patch
    /// whose cubic Lagrange element may fold); the sweeps may certify some of them.
    pub start_uncertified: usize,
    /// Normal groups whose triangles' face normals fit in no open hemisphere (a crease
    /// is forced there; 0 where every input patch is certified).
    pub crease_forced_groups: usize,
    /// Lower bound, in degrees, of the normal change of any repair that keeps G1 (0 where
    /// every input patch is certified).
    pub normal_change_lower_bound_deg: f64,
    /// Patches of the fair surface left uncertified (folded or undecided) whose Jacobian is
    /// 0 at a corner, so that no certificate can prove them valid
    /// ([`crate::singular_at_a_corner`]). Where the two edges of a
    /// triangle at a vertex are crease edges between the same two normals, both boundary
    /// curves leave the vertex along the line where the two tangent planes meet, for any
    /// choice of the normals: the crease structure of the input forces such a patch.
    pub singular_at_a_corner: usize,
    /// Normal groups brought back to the bound after the crease-free start.
    pub groups_clamped: usize,
    /// Normal groups the sweeps leave alone (at a vertex of more than 32 corners).
    pub groups_left_out: usize,
    /// Moves kept: of normals, of the arm pairs of edges.
    pub normal_moves: usize,
    /// Moves of arm pairs kept.
    pub arm_moves: usize,
    /// Best trials that the certificate refused.
    pub moves_refused: usize,
    /// Interior edges with scaled arms.
    pub arm_edges_scaled: usize,
    /// Smallest and largest arm factor ([1, 1] where none).
    pub arm_scale_range: [f64; 2],
    /// Sweeps run.
    pub sweeps: usize,
    /// The search's objective (the adaptive rule with [`FairOptions::subdivisions`],
    /// summed over the patches where it is finite) at its start and end.
    pub objective: [f64; 2],
}

impl FairReport {
    /// One line for people.
    pub fn to_text(&self, mesh: &str) -> String {
        let bound = self
            .normal_bound_deg
            .map_or("estimated normals free".to_string(), |b| {
                format!("file normals within {b}°")
            });
        format!(
            "{mesh}: fair G1: bending energy {:.4e} -> {:.4e} ({} and {} patches left out); \
             {} folded and {} undecided patches before, {} folded and {} undecided after{}; \
             largest normal change {:.3}° ({bound}); {} creases made; arms of {} edges \
             scaled by {:.3}–{:.3}; {} sweeps",
            self.energy_before.energy,
            self.energy_after.energy,
            left_out(&self.energy_before),
            left_out(&self.energy_after),
            self.before.folded,
            self.before.undecided,
            self.after.folded,
            self.after.undecided,
            match self.singular_at_a_corner {
                0 => String::new(),
                n => format!(" ({n} with J = 0 at a corner, which no certificate proves valid)"),
            },
            self.max_normal_change_deg,
            self.creases_made,
            self.arm_edges_scaled,
            self.arm_scale_range[0],
            self.arm_scale_range[1],
            self.sweeps
        )
    }
}

/// Patches per chunk of [`measure`] where [`fair`] calls it (the whole mesh's table is
/// never held).
const CHUNK: usize = 1 << 15;

/// The verdicts of the G1 patches of `mesh` counted, the bending energy (`exact`) of the
/// certified ones, and how many of the others are [`singular_at_a_corner`]: what
/// [`crate::check_table`] and [`BendingEnergy::total_certified`] give on the whole table,
/// bit for bit, from chunks of `chunk` patches built one at a time ([`check_in_chunks`]).
/// Reports each chunk's patches to `progress`.
pub(crate) fn measure(
    mesh: &Mesh,
    scheme_options: &SchemeOptions,
    exact: &BendingEnergy,
    progress: &dyn Progress,
    chunk: usize,
) -> Result<(PatchCounts, EnergyTotal, usize)> {
    let builder = PatchBuilder::new(mesh, Scheme::G1, scheme_options)?;
    let mut parts = Vec::with_capacity(mesh.triangles.len());
    let mut singular = 0;
    let (_, decided) = check_in_chunks(&builder, chunk, |table, _, first| {
        // Only the patches the first stage certified now; those the subdivisions decide
        // are integrated from the certifier's copy once they are certified.
        parts.extend(exact.parts(table, |i| first[i] == Some(Verdict::Valid))?);
        singular += (0..table.len())
            .filter(|&i| matches!(first[i], Some(v) if v != Verdict::Valid))
            .filter(|&i| singular_at_a_corner(table, i))
            .count();
        progress.inc(table.len() as u64);
        Ok(())
    })?;
    if let Some(kept) = &decided.table {
        let valid = |k: usize| decided.verdicts[k] == Verdict::Valid;
        for (k, part) in exact.parts(kept, valid)?.into_iter().enumerate() {
            parts[decided.at[k]] = part;
            singular += usize::from(!valid(k) && singular_at_a_corner(kept, k));
        }
    }
    Ok((decided.counts, total_of_parts(&parts), singular))
}

/// Patches an energy total leaves out.
fn left_out(e: &EnergyTotal) -> usize {
    e.uncertified_patches + e.singular_patches + e.unresolved_patches
}

/// `mesh` with vertex normals and G1 tangent lengths
/// ([`crate::CornerAttributes::arm_scales`]) chosen to lower the bending energy of its G1
/// surface, and the report. The vertices are kept bit for bit; every non-crease edge stays
/// G1 (normal groups move whole, arms of an edge alike in both uses); no patch certified
/// valid after the crease-free start is lost (some others may be certified on the way);
/// no crease is made; the file's normals move
/// at most [`FairOptions::normal_bound_deg`]. Deterministic, whatever the threads. Build
/// the G1 table from the returned mesh.
///
/// ```
/// use g1tess::{fair, generators, FairOptions};
/// let mesh = generators::icosphere(1);
/// let (faired, report) = fair(&mesh, &FairOptions::default().with_sweeps(2))?;
/// assert_eq!(faired.positions, mesh.positions);
/// assert!(report.energy_after.energy <= report.energy_before.energy);
/// assert_eq!(report.creases_made, 0);
/// # Ok::<(), g1tess::Error>(())
/// ```
pub fn fair(mesh: &Mesh, opts: &FairOptions) -> Result<(Mesh, FairReport)> {
    fair_with_progress(mesh, opts, &NoProgress)
}

/// [`fair`], reporting its phases to `progress`: the energy of the input and of the
/// result (patches), the crease-free start, the first judging (patches) and each sweep
/// (normal groups and interior edges). The result is the same as [`fair`]'s.
pub fn fair_with_progress(
    mesh: &Mesh,
    opts: &FairOptions,
    progress: &dyn Progress,
) -> Result<(Mesh, FairReport)> {
    opts.check()?;
    let kind = Scheme::G1.kind();
    let exact = BendingEnergy::new(kind, &FairnessOptions::default())?;
    let search_rule = BendingEnergy::new(
        kind,
        &FairnessOptions::default().with_subdivisions(opts.subdivisions),
    )?;
    let measure = |m: &Mesh| {
        progress.start("fair: energy", m.triangles.len() as u64);
        measure(m, &opts.scheme_options, &exact, progress, CHUNK)
    };
    let (before, energy_before, _) = measure(mesh)?;
    let corners = 3 * mesh.triangles.len();
    let free = corners > 0 && mesh.load_report.normals_estimated >= corners;
    let params = Params {
        bound_deg: (!free).then_some(opts.normal_bound_deg),
        sweeps: opts.sweeps,
        tolerance: opts.tolerance,
        arms: opts.arms,
        arm_range: opts.arm_range,
        scheme_options: opts.scheme_options,
    };
    let energy = |p: &[glam::DVec3]| search_rule.points(p);
    // The search runs on a worker of the pool: each trial integrates a few patches in
    // parallel, and from outside the pool every such call would hand its work to a worker
    // and sleep until it is done (3.8 million context switches in one sweep of a 124,008-
    // triangle mesh, 0.26 million on a worker). The result is the same either way (the
    // energies are summed in order).
    let (out_mesh, out) = rayon::scope(|_| run(mesh, &params, &energy, progress))?;
    let (after, energy_after, singular) = measure(&out_mesh)?;
    let report = FairReport {
        before,
        after,
        energy_before,
        energy_after,
        normal_bound_deg: params.bound_deg,
        max_normal_change_deg: out.max_normal_change_deg,
        creases_made: out.creases_made,
        start_uncertified: out.start_left,
        crease_forced_groups: out.forced_groups,
        normal_change_lower_bound_deg: out.lower_bound_deg,
        singular_at_a_corner: singular,
        groups_clamped: out.clamped_groups,
        groups_left_out: out.groups_left_out,
        normal_moves: out.normal_moves,
        arm_moves: out.arm_moves,
        moves_refused: out.refused,
        arm_edges_scaled: out.arm_edges_scaled,
        arm_scale_range: out.arm_scale_range,
        sweeps: out.sweeps,
        objective: out.objective,
    };
    Ok((out_mesh, report))
}
