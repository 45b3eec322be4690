//! The search's driver: the state every phase reads and changes ([`Search`]), the order of
//! the phases ([`plan`]) and the report ([`Search::finish`]).

use std::collections::HashSet;

use glam::DVec3;
use rayon::prelude::*;

use super::bound::{corner_bound, LAGRANGE_MARGIN};
use super::check::{inside_out, Checker};
use super::geometry::{angle_deg, new_creases};
use super::groups::Groups;
use super::RepairReport;
use crate::mesh::creases::normal_key;
use crate::mesh::Mesh;
use crate::patch::validity::{check_in_chunks, PatchCounts, Verdict};
use crate::patch::{PatchBuilder, Scheme, SchemeOptions};
use crate::Result;

/// Patches per chunk where [`Search::start`] builds and certifies the input's patches.
const START_CHUNK: usize = 1 << 15;

/// What the search found: the repaired mesh and its report, or, where every patch was
/// already certified, the verdicts' counts.
pub(super) enum Plan {
    Repaired(Box<(Mesh, RepairReport)>),
    Valid(PatchCounts),
}

/// The search splitting the doubled triangles ([`Search::split_fins`]), or, where the
/// search then breaks what keeps a fin's shared edges straight (checked at the end),
/// without.
pub(super) fn plan(mesh: &Mesh, scheme: Scheme, opts: &SchemeOptions) -> Result<Plan> {
    match plan_with(mesh, scheme, opts, true)? {
        (plan, false) => Ok(plan),
        (_, true) => Ok(plan_with(mesh, scheme, opts, false)?.0),
    }
}

/// The search (see the module documentation); with `fins`, doubled triangles are split
/// first. Returns the plan and whether a fin's constraints were broken later (then the
/// plan is not used).
fn plan_with(
    mesh: &Mesh,
    scheme: Scheme,
    opts: &SchemeOptions,
    fins: bool,
) -> Result<(Plan, bool)> {
    let mut search = match Search::start(mesh, scheme, opts)? {
        Ok(search) => search,
        Err(counts) => return Ok((Plan::Valid(counts), false)),
    };
    let g1 = scheme == Scheme::G1;
    search.flatten_pages()?;
    if fins && g1 {
        search.split_fins()?;
    }
    // Two phases. G1 first searches without making any crease; what it leaves
    // uncertified, and every other scheme, goes to the arm step (G1) and the search with
    // cuts, isolations and (G1) flattenings.
    if g1 {
        search.crease_free()?;
    }
    search.fallback()?;
    if g1 {
        search.last_resorts()?;
    }
    search.relax()?;
    let broken = search.fins_broken();
    Ok((Plan::Repaired(Box::new(search.finish()?)), broken))
}

/// What the input was: kept for the report.
struct Input {
    /// Their verdicts (the certificate's alone).
    verdicts: Vec<Verdict>,
    before: PatchCounts,
    /// The input's group of each corner (cuts add groups later).
    group_of_corner: Vec<u32>,
    /// [`RepairReport::normal_change_lower_bound_deg`].
    lower_bound: f64,
}

/// The state of one search: what `plan_with` held in its locals, now what each phase
/// (fins, search, arm, fallback, relax) reads and changes.
pub(super) struct Search<'a> {
    /// The input mesh.
    pub(super) mesh: &'a Mesh,
    /// Builds and judges patches.
    pub(super) cx: Checker,
    /// Face normal of each triangle (zero for a degenerate one).
    pub(super) faces: Vec<DVec3>,
    /// The mesh being repaired.
    pub(super) work: Mesh,
    pub(super) groups: Groups,
    /// The search's verdict on each patch of `work` ([`Checker::judge`]).
    pub(super) verdicts: Vec<Verdict>,
    /// The patches the current step works on.
    pub(super) bad: Vec<u32>,
    /// Groups whose normal some step set.
    pub(super) touched: HashSet<u32>,
    /// Triangles whose patch may have changed.
    pub(super) changed: HashSet<u32>,
    /// Groups cut off (6 per isolation; a cut undone later counts no more).
    pub(super) splits: usize,
    /// Triangles isolated ([`Search::isolate_sliver`]).
    pub(super) slivers: usize,
    /// The groups of the cuts, and the cuts in the order made.
    pub(super) in_cuts: HashSet<u32>,
    pub(super) cuts: Vec<[u32; 2]>,
    /// Groups where a crease is forced ([`corner_bound`]).
    pub(super) forced: Vec<bool>,
    /// Corners whose normal must stay perpendicular to a fin edge (corner, direction).
    pub(super) pinned: Vec<(u32, DVec3)>,
    /// Rounds of moves, both phases.
    pub(super) rounds: usize,
    /// [`RepairReport::crease_free_left`].
    pub(super) crease_free_left: Vec<u32>,
    /// Triangles flattened by the last resort.
    pub(super) flattened: usize,
    /// Pages flattened ([`Search::flatten_pages`]).
    pub(super) pages: usize,
    input: Input,
}

impl<'a> Search<'a> {
    /// The search's start on `mesh`: every patch judged (a certified G1 patch whose cubic
    /// Lagrange element may fold, or that is inside out, counts as undecided), or, where
    /// the certificate certifies every patch, their counts.
    pub(super) fn start(
        mesh: &'a Mesh,
        scheme: Scheme,
        opts: &SchemeOptions,
    ) -> Result<std::result::Result<Search<'a>, PatchCounts>> {
        // The input's patches are built and certified a chunk at a time: the whole
        // mesh's table is never held (the repair's end builds the patches it changed
        // again, `measure_changed`).
        let builder = PatchBuilder::new(mesh, scheme, opts)?;
        let mut faces: Vec<DVec3> = Vec::with_capacity(mesh.triangles.len());
        let (mut verdicts, decided) = check_in_chunks(&builder, START_CHUNK, |table, _, _| {
            faces.extend_from_slice(&table.flat_normals);
            Ok(())
        })?;
        let before = decided.counts;
        let mut bad = uncertified(&verdicts);
        if bad.is_empty() {
            return Ok(Err(before));
        }
        let cx = Checker::new(mesh, scheme, opts);
        // The search also refuses a certified G1 patch whose cubic Lagrange element may
        // fold ([`Checker::judge`]), and repairs the input's too.
        let input_verdicts = verdicts.clone();
        if scheme == Scheme::G1 {
            // A second pass over the chunks, taken only where some patch is uncertified.
            builder.for_each_chunk(START_CHUNK, |table, start| {
                let weak: Vec<bool> = (0..table.len())
                    .into_par_iter()
                    .map(|i| {
                        let t = start + i;
                        verdicts[t] == Verdict::Valid
                            && (cx.element.of(table, i) <= LAGRANGE_MARGIN
                                || inside_out(table, i, mesh.corner_normals[t]))
                    })
                    .collect();
                for (i, w) in weak.into_iter().enumerate() {
                    if w {
                        verdicts[start + i] = Verdict::Undecided;
                        bad.push((start + i) as u32);
                    }
                }
                Ok(())
            })?;
            bad.sort_unstable();
        }
        let groups = Groups::new(mesh);
        let (lower_bound, forced) = corner_bound(mesh, &faces, &groups);
        Ok(Ok(Search {
            mesh,
            cx,
            work: mesh.clone(),
            verdicts,
            bad,
            touched: HashSet::new(),
            changed: HashSet::new(),
            splits: 0,
            slivers: 0,
            in_cuts: HashSet::new(),
            cuts: Vec::new(),
            forced,
            pinned: Vec::new(),
            rounds: 0,
            crease_free_left: Vec::new(),
            flattened: 0,
            pages: 0,
            input: Input {
                verdicts: input_verdicts,
                before,
                group_of_corner: groups.of_corner.clone(),
                lower_bound,
            },
            groups,
            faces,
        }))
    }

    /// [`RepairReport::normal_change_lower_bound_deg`] of the input.
    pub(super) fn lower_bound_deg(&self) -> f64 {
        self.input.lower_bound
    }

    /// The patches not certified now, in order.
    pub(super) fn uncertified(&self) -> Vec<u32> {
        uncertified(&self.verdicts)
    }

    /// Whether a fin's constraints no longer hold (the flattening cascade ignores them):
    /// every fin's edges on the surface must still be straight in every use (the normals
    /// at their ends perpendicular to them: rounding only).
    fn fins_broken(&self) -> bool {
        self.pinned.iter().any(|&(c, d)| {
            self.work.corner_normals[c as usize / 3][c as usize % 3]
                .dot(d)
                .abs()
                > 1e-12
        })
    }

    /// Patches left uncertified whose own triangle turns away from the triangles around
    /// it ([`RepairReport::left_on_flipped_triangles`]).
    fn left_on_flipped(&self) -> usize {
        let (groups, faces) = (&self.groups, &self.faces);
        self.bad
            .iter()
            .filter(|&&t| self.verdicts[t as usize] != Verdict::Valid)
            .filter(|&&t| {
                let tri = t as usize;
                let around: DVec3 = (0..3)
                    .flat_map(|k| groups.corners(groups.of_corner[3 * tri + k]))
                    .map(|&c| faces[c as usize / 3])
                    .sum();
                (around - 3.0 * faces[tri]).dot(faces[tri]) < 0.0
            })
            .count()
    }

    /// The repaired mesh and the report: what changed, measured on the final normals.
    fn finish(self) -> Result<(Mesh, RepairReport)> {
        let flipped = self.left_on_flipped();
        let mut changed: Vec<u32> = self.changed.iter().copied().collect();
        changed.sort_unstable();
        let (groups, mesh, work) = (&self.groups, self.mesh, &self.work);
        let mut vertices = HashSet::new();
        let mut corners = 0;
        let mut max_angle = 0.0f64;
        for &g in &self.touched {
            let (n0, n) = (groups.normal(mesh, g), groups.normal(work, g));
            if normal_key(n) != normal_key(n0) {
                vertices.insert(groups.vertex[g as usize]);
                corners += groups.corners(g).len();
                max_angle = max_angle.max(angle_deg(n0, n));
            }
        }
        let (arm_edges_scaled, arm_scale_range) = super::arm::arm_summary(work);
        let (after, max_distance) = self.measure_changed(&changed)?;
        let forced = &self.forced;
        let input_group = &self.input.group_of_corner;
        let report = RepairReport {
            before: self.input.before,
            after,
            vertices_touched: vertices.len(),
            corners_changed: corners,
            patches_changed: changed.len(),
            max_normal_change_deg: max_angle,
            max_distance,
            groups_split: self.splits,
            slivers_isolated: self.slivers,
            edges_made_creases: new_creases(mesh, work),
            left_on_flipped_triangles: flipped,
            triangles_flattened: self.flattened + self.pages,
            rounds: self.rounds,
            normal_change_lower_bound_deg: self.input.lower_bound,
            crease_forced_groups: forced.iter().filter(|&&x| x).count(),
            crease_free_left_forced: self
                .crease_free_left
                .iter()
                .filter(|&&t| (0..3).any(|k| forced[input_group[3 * t as usize + k] as usize]))
                .count(),
            crease_free_left: self.crease_free_left,
            arm_edges_scaled,
            arm_scale_range,
        };
        Ok((self.work, report))
    }

    /// The verdicts' counts after the repair and the largest distance between the
    /// repaired and the unrepaired surface at equal parameters, over the patches
    /// `changed`. The verdicts reported are the certificate's alone (the search also
    /// refuses a G1 patch whose cubic Lagrange element may fold): those of the changed
    /// patches on the whole mesh's builder, the input's elsewhere.
    fn measure_changed(&self, changed: &[u32]) -> Result<(PatchCounts, f64)> {
        let builder = PatchBuilder::new(&self.work, self.cx.scheme, &self.cx.opts)?;
        let table = builder.table_of(changed, 0)?;
        let mut finals = self.input.verdicts.clone();
        let again: Vec<Verdict> = (0..changed.len())
            .into_par_iter()
            .map(|i| self.cx.certify(&table, i))
            .collect();
        for (&t, v) in changed.iter().zip(again) {
            finals[t as usize] = v;
        }
        let after = finals
            .iter()
            .fold(PatchCounts::default(), PatchCounts::with);
        // The input's patches of `changed`, built again: bitwise those of the whole table.
        let table0 =
            PatchBuilder::new(self.mesh, self.cx.scheme, &self.cx.opts)?.table_of(changed, 0)?;
        let grid = &self.cx.grids.distance;
        let max_distance = (0..changed.len())
            .into_par_iter()
            .map(|i| {
                grid.weights
                    .iter()
                    .map(|w| (table.eval_weights(i, w).p - table0.eval_weights(i, w).p).length())
                    .fold(0.0, f64::max)
            })
            .reduce(|| 0.0, f64::max);
        Ok((after, max_distance))
    }
}

/// The indices of the verdicts that are not valid, in order.
fn uncertified(verdicts: &[Verdict]) -> Vec<u32> {
    (0..verdicts.len() as u32)
        .filter(|&t| verdicts[t as usize] != Verdict::Valid)
        .collect()
}

/// The number of patches of `ring` that `verdicts` does not certify.
pub(super) fn count_uncertified(verdicts: &[Verdict], ring: &[u32]) -> usize {
    ring.iter()
        .filter(|&&r| verdicts[r as usize] != Verdict::Valid)
        .count()
}

/// Stores the verdicts `v` of the patches `ring` (in the same order) and marks them changed.
pub(super) fn record(
    verdicts: &mut [Verdict],
    changed: &mut HashSet<u32>,
    ring: &[u32],
    v: &[Verdict],
) {
    debug_assert_eq!(ring.len(), v.len());
    for (&r, &x) in ring.iter().zip(v) {
        verdicts[r as usize] = x;
        changed.insert(r);
    }
}

/// Stores the verdicts `v` of the patches `ring` (in the same order) without marking them
/// changed (a step that moves a normal back towards its input).
pub(super) fn store(verdicts: &mut [Verdict], ring: &[u32], v: &[Verdict]) {
    for (i, &r) in ring.iter().enumerate() {
        verdicts[r as usize] = v[i];
    }
}
