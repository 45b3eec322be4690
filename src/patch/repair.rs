//! Repair of folded patches by changing vertex normals as little as needed.
//!
//! Every patch scheme here builds each triangle's patch from its three corners and their
//! normals only, and G1 builds each edge's boundary curve and ribbon from the edge's two
//! end points and normals (Walton & Meek 1996), so **any** choice of vertex normals gives
//! a patch network that is G1 across every edge whose two triangles share the normals of
//! its ends, and watertight everywhere (crease edges get one curve built from both sides'
//! normals). The repair therefore only changes normals, and always all the corners of one
//! *normal group* (the corners of one vertex that carry bitwise the same normal) to one new
//! value: smooth edges stay smooth, creases stay creases.
//!
//! G1 can also change the boundary curves' **tangent lengths** (the *arm step*, after
//! the crease-free phase): an edge's Walton–Meek arms scaled by positive factors keep
//! their directions, in the tangent planes of the edge's ends, and both triangles of the
//! edge use the one scaled curve ([`super::g1::shared_curve`]), so the patches stay G1
//! across it and watertight; the factors travel with the mesh
//! ([`crate::mesh::CornerAttributes::arm_scales`]). At the input normals this does not
//! help: on the patches the certificate refuses on the bunny and on Suzanne, scaling the
//! arms of all, or of any one, of a patch's three curves by 0.8 down to 0.1 leaves it
//! folded or undecided, and on Suzanne's 5 patches named below, a joint search over the
//! two arms of each of the patch's three edges (each factor 0.1 to 4, the patches across
//! those edges included) ends with every one of them still folded: the best of 6 starts
//! leaves each patch, and 1 or 2 of the patches across its edges, folded (witnesses with
//! J from −1.3e-6 to −1.4e-4) and inside out at a corner. At the normals the crease-free
//! phase reaches, where the folds sit about 1/10 of the way in from one corner, the same
//! search certifies all 5. (The step does not run on a mesh that already carries arm
//! factors.)
//!
//! **What no repair that keeps G1 can avoid** ([`corner_bound`]). At a corner A of
//! triangle f (unit face normal n_f) with normal N whose two edges of f are not crease
//! edges, every scheme's boundary curves leave A in the plane normal to N, so
//! S_s × S_t = c N there (c = 2 Area a b (n_f · N) for tangents along the chords projected
//! on that plane, a, b > 0 their lengths; G1's Walton–Meek tangents add the far ends'
//! normals projected, so there c depends on all three corners' normals).
//! Along such an edge A → B the patch's normal is λ(u) n(u), n(u) the edge's continuous
//! nonzero normal field from N_A to N_B; a certified patch has J = λ (n · n_f) > 0 on the
//! whole edge, so λ keeps one sign σ, the patch's, and σ (n_f · N) > 0 at every such
//! corner. Across a smooth edge both patches' normals are their λ times the same n(u), so a
//! repair with no edge sample at cos < 0 has one σ on each component of triangles joined by
//! smooth edges. A repair that keeps every smooth edge smooth, certifies every patch and
//! has no cos < 0 sample therefore turns each such corner's normal to within 90° of n_f
//! (σ = +1) or beyond it (σ = −1): it changes the normal by at least θ − 90° or 90° − θ
//! there (θ the input angle between N and n_f). The report's
//! `normal_change_lower_bound_deg` is the largest, over components, of the smaller of the
//! two largest; tangent lengths scale a and b only and change no sign. A crease changes the
//! argument only at the corners between two crease edges (their curves leave along the
//! crease directions), which is how a triangle given its own face normal (a flat corner)
//! escapes it: at the price of the crease. A normal group whose triangles' face normals fit
//! in no open hemisphere (Suzanne's doubled triangle, the same three vertices in both
//! orders) has no single normal facing them all: a crease there is forced
//! (`crease_forced_groups`, found exactly by [`max_min_direction`]).
//!
//! Method: a local search under the certificate of [`super::validity`], for G1 first
//! without making any crease:
//! 1. Every patch gets its verdict. If all are certified valid, nothing changes at all (the
//!    mesh and every patch stay bit for bit as they were).
//!
//! *Fins* (G1, first). A doubled triangle (two triangles on the same three vertices in
//! both orders, glued along their edges: Suzanne's 269 and 270) with a copy uncertified
//! is split off the surface ([`split_fin`]): each of its six corners gets its own group
//! with its triangle's face normal, so both copies are flat patches with straight edges
//! (between the two copies the crease direction of opposite normals is the edge itself),
//! and where the fin stands on the surface (an edge with more than two uses, which gets no
//! shared crease curve) the surface's groups at both of its ends get their normals
//! projected perpendicular to it: every use then builds the same straight segment, and
//! the output stays watertight there. This step makes creases of the fin's own two-use
//! edges (between its two sides) only. Kept where the certificate counts fewer
//! uncertified patches around; these groups are left alone by every later step, and if
//! the search still broke a fin's straight edge the search runs again without fins. The
//! flattening, where it reaches a fin vertex, makes every corner there flat (which keeps
//! the edge straight), so the surface edges at that vertex become creases too (Suzanne:
//! the 5 at vertex 136).
//!
//! *Crease-free phase* (G1, between steps 1 and 2). Each normal group at a corner of an
//! uncertified patch that faces some of its triangles by less than a cosine of 0.05 (where a crease is not
//! forced) gets the nearest normal facing all of them by 0.05 ([`nearest_facing`]: the
//! minimal rotation, exact by enumerating the active constraints), the corner condition
//! above with a margin. Then the rounds of moves of steps 4 and 5, with no cut, on a
//! grid of level 12, with more moves: each group, two or three of the patch's groups
//! each, or all of them with one normal, to the nearest normal facing their triangles by
//! 0.02 to 0.5; a move must keep each moved group facing its triangles (by 0.02, or as
//! much as before); the measure adds the shortfall of the cubic Lagrange element's bound
//! below 0.01; and among the 8 trials of largest gain the one the certificate finds
//! with the fewest uncertified patches around it, where that is fewer than now, is kept
//! (the measure's grid can miss a fold the certificate sees). At most 12 rounds, and
//! none after two that leave as many patches uncertified as before. Then, up to 3 times
//! while it helps, *joint moves*: the patches left are clustered (those whose one-ring
//! groups overlap) and the normals of all the groups of a cluster move together
//! ([`joint_corners`]: a pattern search on the sphere, group by group, 8 directions, steps
//! 0.2 down to 0.0125 radians, each group facing its triangles as the moves require),
//! lowering the corner shortfall of [`corner_values`], the grid shortfall and the
//! Lagrange shortfall of the patches around; a cluster's result is kept where the
//! certificate counts fewer uncertified patches around it, and the rounds run again.
//! The corner values matter because a G1 patch's end tangent at a corner is not the
//! chord projected on the corner's tangent plane alone: the Walton–Meek tangent adds a
//! multiple of the far end's normal projected there, so the corner's Jacobian depends on
//! the normals of all three corners, and the corner condition n_f · N > 0 does not make
//! it positive (Suzanne's eye patches fold at such corners). What it
//! leaves uncertified is reported (`crease_free_left`, and how many of those patches
//! have a corner where a crease is forced) and goes to the arm step.
//!
//! *Arm step* (G1, [`arm_step`]). The patches left are clustered (those whose edges'
//! triangles overlap); for each cluster the two arm factors of each interior edge of its
//! patches (log scale, 0.1 to 4) are searched: a pattern search (steps 0.5 down to 0.02
//! in the logarithm, each factor in turn) from 6 starts (all 1; the arms at each patch's
//! weakest corner, by [`corner_values`], at 0.3, 0.6, 1.6, 2.5 or 4), maximising the
//! smallest scaled Jacobian over the triangles of those edges on a grid of level 12 and
//! on rays close to each corner (where these folds sit), and their Lagrange bound; the
//! first result positive on the finer grid of level 40 that [`judge`] accepts on all of
//! them is made as small as it stays accepted (all logarithms times 0.1 up to 0.9, the
//! first accepted, then each arm back to 1, largest first). The step is kept only where
//! every cluster is certified; then nothing else runs but steps 9 to 11 (whose
//! certificates build the patches with the factors). Suzanne: the crease-free phase
//! leaves triangles 304, 307, 856, 859 and 863, each folding near vertex 137, 138, 465 or
//! 468, whose fans nearly fill a hemisphere (the best normal faces its fan's triangles by
//! a cosine of only 0.02 to 0.06); the arm step certifies all of them and the patches
//! across their edges with 8 edges' arms scaled by 0.578 to 2.117 (304: at vertex 137
//! ×1.956 towards 161 and ×0.578 towards 174; 307: ×2.117 at 138 towards 162, ×0.779 and
//! ×0.687 at both ends of 138–174; 856: ×1.206 and ×1.284 at both ends of 421–465; 859
//! and 863 together: ×1.649 at 468 towards 422 and 420, ×1.649 at 466 on 422–466, ×1.284
//! at 420 on 420–468), so no fallback runs: 0 triangles flattened, 2 crease edges (the
//! fin's own, forced) instead of 28, largest normal change 90.0° instead of 109.6°.
//! Where a cluster is not certified the factors are dropped and what is left goes through
//! steps 2 to 8 (the fallback); other schemes start there. Steps 9 to 11 run in every
//! case.
//!
//! 2. G1: a triangle whose face normal turns away (negative cosine) from every other
//!    triangle at each of its three corners folds the input itself; no normal shared with
//!    them serves it, and normals of its own alone would make its two crease curves at a
//!    corner run along one crease line. Each of its vertices' fans is cut in three: the
//!    triangle, with its own face normal, and two runs of the others, each with the central
//!    normal of its faces turned perpendicular to the triangle's edge it meets; the crease
//!    direction n_f × N is then that edge at both of its ends, so the triangle's boundary
//!    curves are straight and its patch flat ([`isolate_sliver`]). Kept where the
//!    certificate counts fewer uncertified patches around; those groups stay as they are.
//! 3. Then every normal group at a corner of an uncertified patch whose normal faces
//!    its own triangles by less than a cosine of 0.1 (smallest n_f · N over their face
//!    normals n_f) gets its *central normal*, the direction with the largest smallest cosine
//!    to those face normals (the axis of their smallest enclosing cone, by the
//!    Bădoiu–Clarkson iteration on the unit sphere), where that faces them better. At a
//!    corner with end tangents in the plane of N, J has the sign of n_f · N (for tangents
//!    that are the chords projected on that plane, J = |u × v| (n_f · N)² with the
//!    patch's normal ±N by the sign of n_f · N).
//! 4. For each patch that is not certified, a few moves are tried: each group of its three
//!    corners moved 1/16, 1/8, 1/4, 1/2, 3/4 or all of the way (normalised linear blend)
//!    towards (a) the group's central normal, (b) the patch's face normal, (c) the mean of
//!    the patch's three corner normals; the three groups together towards the face normal;
//!    two or three of its groups together towards the central normal of all their faces (a
//!    sliver's close corners need nearly one normal). A move is scored by the shortfall of
//!    the scaled Jacobian J/(|S_s| |S_t|) (the measure of curved finite-element meshing)
//!    below 0.05 on a grid of level 6 over the patches around the moved groups: the only
//!    patches those normals change.
//! 5. The best move is kept when it lowers that shortfall and the certificate finds no
//!    more uncertified patches around it than before; otherwise nothing moves.
//! 6. Where no move helps, the fan of triangles of one of the patch's corner groups is cut
//!    into two runs of neighbours, along two of its edges (one at a boundary vertex), each
//!    run with the central normal of its own faces: a new crease at that vertex, whose
//!    edges get the shared crease curve of [`super::g1::crease_curve`]. Every cut of the
//!    three groups is tried; the one with the fewest uncertified patches around its vertex
//!    (then the smallest shortfall) is kept when it lowers their number, or keeps it with
//!    a shortfall at least 10 % smaller. The edges made creases are counted in the report.
//! 7. Rounds repeat while something improves (at most 96). A G1 patch still uncertified
//!    then gets the isolation of step 2 whatever its neighbours' orientation (its own face
//!    normal, straight crease edges, the fans around cut in three), kept where the
//!    certificate counts fewer uncertified patches around.
//! 8. Last resort, G1 only: a patch still uncertified is *flattened* (its own face
//!    normal in a group of its own at each corner; at each of its vertices the runs of the
//!    fan next to it get the central normal of their faces turned perpendicular to the
//!    edge they share with it, a run between two flat corners cut in two, each part
//!    perpendicular to its own edge, a run of one triangle flat there too; where a run is
//!    cut is chosen by the certificate, then the measure): its three boundary curves are
//!    straight lines and its patch is the flat triangle, which the certificate certifies.
//!    A flat corner stays flat when a neighbour is flattened later (the runs next to it
//!    are rebuilt perpendicular to every flat corner's edge), so each flattening adds one
//!    triangle flat for good; the patches around that it leaves uncertified are flattened
//!    in turn. The cascade ends, at the latest with every triangle flat (a certified
//!    mesh of non-degenerate triangles), so **every patch ends certified**.
//! 9. As little as needed: after a cascade, each touched vertex, largest change first,
//!    goes back to its input normals at every corner (cuts and flat corners undone) where
//!    the patches around stay certified. Then each moved normal whose patches around are
//!    all certified goes back to its input value, or 3/4, 1/2 or 1/4 of the way (3/4 at
//!    most for a cut's groups), or (not for a cut's groups) to the nearest normal to its
//!    input value facing all of its triangles by 0.02 to 0.5, largest change first, the
//!    option nearest to the input that keeps those patches certified; then each cut,
//!    latest first, is undone (both groups back to the input normal) where the
//!    certificate counts no more uncertified patches around it.
//! 10. After a cascade, at each touched vertex the groups that were one group in the
//!     input get one normal again (the mean of their corners' normals, or one of theirs)
//!     where the patches around stay certified: fewer new creases.
//! 11. Last, the moved groups (not a cut's) of each triangle with two or three of them go
//!     back together (a sliver's close corners need nearly one normal, so neither goes
//!     back alone): each to its nearest normal to the input facing its triangles by 0.02
//!     to 0.5, or all to the nearest one to the mean of their input normals facing all of
//!     their triangles, or each 3/4, 1/2 or 1/4 of the way; of the options with a smaller
//!     largest change, the smallest that keeps the patches around certified.
//!
//! The search also refuses a certified patch that is inside out (its normal at a corner
//! turned away from the corner's normal): the certificate, along n_f, accepts it, but it
//! meets its neighbours across smooth edges at cos = −1 ([`judge`]).
//!
//! For G1 the search also refuses a certified patch whose cubic Lagrange element (the
//! element of order 3 that `export-msh` writes, its nodes on the patch) may fold: the
//! smallest Bernstein coefficient of that element's Jacobian along n_f, over the largest,
//! must exceed 1e-6 ([`judge`]); the input's such patches are repaired too (where the
//! input has a folded or undecided patch at all). The report's verdicts are the
//! certificate's alone.
//!
//! Patches left uncertified (none for G1, other schemes have no step 8) are reported, not
//! hidden. The report counts the interior edges that became creases (their uses now
//! disagree on an end's normal).
//!
//! The search builds the G1 patches it scores one triangle at a time, with the crease
//! curves of their own edges only ([`super::g1::edge_curve`], bitwise those of the whole
//! mesh's [`super::g1::prepare`]).
//!
//! The certificate is the search's cost: it is asked once per distinct patch (verdicts
//! are kept by the bit patterns of the patch's control points), a patch whose sampled J
//! is surely negative (below −1e-9 |S_s| |S_t| on a grid of level 8) is counted as
//! uncertified without it, and where the search picks the trial with the fewest
//! uncertified patches, the trials are certified in order of their measure, each only
//! as far as it could still win. [`judge`]'s cheap refusals (inside out, the Lagrange
//! element) come before the certificate, which is then not asked at all (the patches
//! close to folding are those it subdivides most), and the grids' basis weights are
//! computed once ([`Grid`]). None of this changes what the search chooses.
//!
//! The report gives the number of vertices touched, the largest angle between a new and an
//! input normal, and the largest distance between the repaired and the unrepaired surface
//! at equal parameters (an upper bound of their Hausdorff distance) over a grid of level 8
//! on every patch that changed.
//!
//! ```
//! use g1tess::patch::{repair, validity, PatchTable, Scheme, SchemeOptions};
//! let mesh = g1tess::mesh::generators::icosphere(2);
//! let table = PatchTable::build(&mesh, Scheme::G1, &SchemeOptions::default())?;
//! let counts = validity::count(&table);
//! assert_eq!(counts.valid, mesh.triangles.len());
//! // Nothing folds, so the repair leaves the mesh bit for bit as it is.
//! let (same, report) = repair::repair(&mesh, Scheme::G1, &SchemeOptions::default())?;
//! assert_eq!(same.corner_normals, mesh.corner_normals);
//! assert_eq!(report.vertices_touched, 0);
//! # Ok::<(), g1tess::Error>(())
//! ```

use std::collections::{HashMap, HashSet};
use std::hash::{Hash, Hasher};
use std::sync::{Arc, Mutex};

use glam::DVec3;
use rayon::prelude::*;
use serde::Serialize;

use super::basis::Weights;
use super::validity::{check_patch, check_table, PatchCounts, Verdict};
use super::{PatchBuilder, PatchKind, PatchTable, Scheme, SchemeOptions, TriangleBuilder};
use crate::mesh::adjacency::{EdgeIndex, EdgeUse};
use crate::mesh::creases::normal_key;
use crate::mesh::Mesh;
use crate::Result;

/// Fractions of the way to a target a normal may move, tried smallest first.
const WEIGHTS: [f64; 6] = [1.0 / 16.0, 1.0 / 8.0, 1.0 / 4.0, 1.0 / 2.0, 3.0 / 4.0, 1.0];
/// Largest closed fan whose every two-run cut [`best_cut`] tries (n(n − 1)/2 of them);
/// larger fans are cut as if open (n − 1 cuts).
const MAX_CLOSED_CUT_FAN: usize = 32;
/// Most rounds before the repair gives up on what is left.
const MAX_ROUNDS: usize = 96;
/// Scaled Jacobian the search aims at everywhere (a margin above 0, the fold).
const MARGIN: f64 = 0.05;
/// Smallest cosine between a group's normal and its faces' normals below which the first
/// pass gives the group its central normal.
const PREPASS_MARGIN: f64 = 0.1;
/// Smallest cosine n_f · N to each of its triangles that the crease-free phase first gives
/// a group that does not face them all (the nearest such normal, [`nearest_facing`]).
const FACING: f64 = 0.05;
/// Margins of the nearest facing normals the crease-free phase's moves try.
const FACING_STEPS: [f64; 6] = [0.02, 0.05, 0.1, 0.2, 0.3, 0.5];
/// Grid level of the search's measure ([`badness`]).
const BADNESS_LEVEL: u32 = 6;
/// Grid level of the crease-free phase's measure.
const FINE_LEVEL: u32 = 12;
/// Trials of largest gain per patch and round that the crease-free phase certifies.
const CERTIFY_TRIALS: usize = 8;
/// Most rounds of the crease-free phase (each certifies up to [`CERTIFY_TRIALS`] trials
/// per patch; what is left then goes to the fallback).
const CREASE_FREE_ROUNDS: usize = 12;
/// Grid level at which the repaired and unrepaired surfaces are compared.
const DISTANCE_LEVEL: u32 = 8;

/// A trial of the crease-free phase: its gain, its moves (group, new normal), its ring.
type Trial = (f64, Vec<(u32, DVec3)>, Vec<u32>);

/// What a repair changed.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct RepairReport {
    /// Verdicts before and after.
    pub before: PatchCounts,
    pub after: PatchCounts,
    /// Vertices with at least one changed normal.
    pub vertices_touched: usize,
    /// Triangle corners whose normal changed.
    pub corners_changed: usize,
    /// Patches that changed (the triangles around the touched vertices).
    pub patches_changed: usize,
    /// Largest angle between a new normal and the input one, in degrees.
    pub max_normal_change_deg: f64,
    /// Largest distance between the repaired and the unrepaired surface at equal
    /// parameters (grid of level 8 on every changed patch).
    pub max_distance: f64,
    /// Normal groups cut in two (a new crease at their vertex) where no move of one
    /// normal helps.
    pub groups_split: usize,
    /// Triangles that turn away from every other triangle at each of their corners (folds
    /// of the input), given their own face normal and straight crease edges
    /// ([`isolate_sliver`]); their corners' normal change counts in the largest.
    pub slivers_isolated: usize,
    /// Interior edges that the cuts made creases (left out of the G1 statistics, which
    /// measure the smooth edges; their two patches still share the edge's curve).
    pub edges_made_creases: usize,
    /// Patches left uncertified whose own triangle turns away from the triangles around
    /// it (negative cosine between its face normal and the mean face normal of the
    /// triangles sharing a corner with it): folds of the input mesh itself.
    pub left_on_flipped_triangles: usize,
    /// Triangles flattened by the last resort (their own face normal at each corner,
    /// straight boundary curves: a flat patch), with the patches around that this broke.
    pub triangles_flattened: usize,
    /// Rounds of the search.
    pub rounds: usize,
    /// Lower bound, in degrees, of the largest normal change of any repair by normals and
    /// tangent lengths that keeps G1 (makes no smooth edge a crease) and leaves every
    /// patch certified with no edge sample at cos < 0 ([`corner_bound`]): the largest,
    /// over components of triangles joined by smooth edges, of the smaller of the largest
    /// θ − 90° and the largest 90° − θ over their corners not between two crease edges
    /// (θ the angle between the input normal and the face normal). 0 when nothing folds.
    pub normal_change_lower_bound_deg: f64,
    /// Input normal groups whose triangles' face normals fit in no open hemisphere: no
    /// single normal faces all of them, so a crease there is forced (Suzanne's doubled
    /// triangle). 0 when nothing folds.
    pub crease_forced_groups: usize,
    /// Patches that the crease-free search (first phase, G1) left uncertified, handed to
    /// the arm step and, where that does not certify them all, to the fallback of cuts,
    /// isolations and flattenings (sorted triangle indices).
    pub crease_free_left: Vec<u32>,
    /// Of those, the patches with a corner in a group where a crease is forced.
    pub crease_free_left_forced: usize,
    /// Interior edges whose boundary curve got scaled arms (tangent lengths) by the arm
    /// step ([`arm_step`]; G1): 0 where it did not run or was not kept.
    pub arm_edges_scaled: usize,
    /// Smallest and largest arm factor of those edges ([1, 1] where none).
    pub arm_scale_range: [f64; 2],
}

impl RepairReport {
    /// One line for people.
    pub fn to_text(&self, mesh: &str, scheme: Scheme) -> String {
        format!(
            "{mesh}: {scheme} fold repair: {} folded and {} undecided patches before, {} \
             folded and {} undecided after; {} vertices touched ({} corners), largest \
             normal change {:.3}°, {} edges made creases{}, surface moved at most {:.3e}",
            self.before.folded,
            self.before.undecided,
            self.after.folded,
            self.after.undecided,
            self.vertices_touched,
            self.corners_changed,
            self.max_normal_change_deg,
            self.edges_made_creases,
            self.arms_text(),
            self.max_distance
        )
    }

    /// ", arms of N edges scaled by a–b" where the arm step scaled some; empty otherwise.
    pub fn arms_text(&self) -> String {
        if self.arm_edges_scaled == 0 {
            return String::new();
        }
        format!(
            ", arms of {} edges scaled by {:.3}–{:.3}",
            self.arm_edges_scaled, self.arm_scale_range[0], self.arm_scale_range[1]
        )
    }
}

/// The mesh with repaired normals, the triangles whose patch changed and the report;
/// `None` where every patch is already valid.
struct Plan {
    mesh: Mesh,
    changed: Vec<u32>,
    report: RepairReport,
}

/// `mesh` with its normals repaired for `scheme` (see the module documentation) and what
/// changed. A mesh whose patches are all certified valid comes back unchanged.
pub fn repair(mesh: &Mesh, scheme: Scheme, opts: &SchemeOptions) -> Result<(Mesh, RepairReport)> {
    let outcome = cached_plan(mesh, scheme, opts)?;
    Ok(match &outcome.plan {
        Some(p) => (p.mesh.clone(), p.report.clone()),
        None => (mesh.clone(), outcome.report.clone()),
    })
}

/// The mesh and patch table a command works on. With [`SchemeOptions::repair_folds`]: the
/// repaired mesh (so that its new creases and split normals are what stitching, writers
/// and device topology see), its table built without the option (bit for bit the
/// option's patches) and the repair's report. Otherwise `mesh` itself, its table and no
/// report.
pub fn prepared<'a>(
    mesh: &'a Mesh,
    scheme: Scheme,
    opts: &SchemeOptions,
) -> Result<(std::borrow::Cow<'a, Mesh>, PatchTable, Option<RepairReport>)> {
    if !opts.repair_folds {
        let table = PatchTable::build(mesh, scheme, opts)?;
        return Ok((std::borrow::Cow::Borrowed(mesh), table, None));
    }
    let (fixed, report) = repair(mesh, scheme, opts)?;
    let plain = SchemeOptions {
        repair_folds: false,
        ..*opts
    };
    let table = PatchTable::build(&fixed, scheme, &plain)?;
    Ok((std::borrow::Cow::Owned(fixed), table, Some(report)))
}

/// What [`repair`] reports for `mesh`, without copying the repaired mesh. The repair of
/// the same mesh, scheme and options that built a table just before (with
/// [`SchemeOptions::repair_folds`]) is not run again: the last few outcomes are kept.
pub fn report(mesh: &Mesh, scheme: Scheme, opts: &SchemeOptions) -> Result<RepairReport> {
    Ok(cached_plan(mesh, scheme, opts)?.report.clone())
}

/// The outcome of the search on one mesh: its plan (`None` where every patch was already
/// certified) and its report.
struct Outcome {
    plan: Option<Plan>,
    report: RepairReport,
}

/// Outcomes kept, most recent last (a command builds a table and then reports on it; `render`
/// does so once per scheme).
const KEPT: usize = 2;

/// Outcomes of recent searches, by [`fingerprint`].
static OUTCOMES: Mutex<Vec<(u64, Arc<Outcome>)>> = Mutex::new(Vec::new());

/// A 64-bit hash of everything the search depends on: the positions, triangles, corner
/// normals and arm factors (bit patterns), the scheme and its options.
fn fingerprint(mesh: &Mesh, scheme: Scheme, opts: &SchemeOptions) -> u64 {
    let mut h = std::collections::hash_map::DefaultHasher::new();
    scheme.name().hash(&mut h);
    opts.phong_alpha.to_bits().hash(&mut h);
    mesh.positions.len().hash(&mut h);
    for p in &mesh.positions {
        p.to_array().map(f64::to_bits).hash(&mut h);
    }
    mesh.triangles.hash(&mut h);
    for c in &mesh.corner_normals {
        c.map(|n| n.to_array().map(f64::to_bits)).hash(&mut h);
    }
    if let Some(a) = &mesh.attributes.arm_scales {
        for s in a {
            s.map(|s| s.map(f64::to_bits)).hash(&mut h);
        }
    }
    h.finish()
}

/// The search's outcome on `mesh`, from [`OUTCOMES`] or computed (and kept).
fn cached_plan(mesh: &Mesh, scheme: Scheme, opts: &SchemeOptions) -> Result<Arc<Outcome>> {
    let opts = SchemeOptions {
        repair_folds: false,
        ..*opts
    };
    let key = fingerprint(mesh, scheme, &opts);
    let kept = |o: &Mutex<Vec<(u64, Arc<Outcome>)>>| {
        let list = o.lock().unwrap_or_else(|e| e.into_inner());
        list.iter().find(|(k, _)| *k == key).map(|(_, v)| v.clone())
    };
    if let Some(o) = kept(&OUTCOMES) {
        return Ok(o);
    }
    let outcome = Arc::new(match plan(mesh, scheme, &opts)? {
        Some(p) => Outcome {
            report: p.report.clone(),
            plan: Some(p),
        },
        None => {
            let table = PatchTable::build(mesh, scheme, &opts)?;
            let c = super::validity::count(&table);
            Outcome {
                plan: None,
                report: RepairReport {
                    before: c,
                    after: c,
                    arm_scale_range: [1.0, 1.0],
                    ..Default::default()
                },
            }
        }
    });
    let mut list = OUTCOMES.lock().unwrap_or_else(|e| e.into_inner());
    list.retain(|(k, _)| *k != key);
    if list.len() >= KEPT {
        list.remove(0);
    }
    list.push((key, outcome.clone()));
    Ok(outcome)
}

/// The builder of `scheme` on `mesh` with repaired normals (what
/// [`SchemeOptions::repair_folds`] asks for): the unrepaired builder, with the patches that
/// the repair changed built once here from the repaired mesh.
pub(super) fn repaired_builder<'a>(
    mesh: &'a Mesh,
    scheme: Scheme,
    opts: &SchemeOptions,
) -> Result<Box<dyn TriangleBuilder + 'a>> {
    let opts = SchemeOptions {
        repair_folds: false,
        ..*opts
    };
    let base = (scheme.info().prepare)(mesh, &opts)?;
    let outcome = cached_plan(mesh, scheme, &opts)?;
    let Some(p) = &outcome.plan else {
        return Ok(base);
    };
    let rb = PatchBuilder::new(&p.mesh, scheme, &opts)?;
    let stride = rb.kind().stride();
    let mut points = vec![DVec3::ZERO; p.changed.len() * stride];
    let fallbacks: Vec<usize> = points
        .par_chunks_mut(stride)
        .zip(p.changed.par_iter())
        .map(|(out, &t)| rb.inner.build(t as usize, out))
        .collect();
    let slots = p
        .changed
        .iter()
        .enumerate()
        .map(|(i, &t)| (t, i as u32))
        .collect();
    Ok(Box::new(Repaired {
        base,
        slots,
        points,
        fallbacks,
        stride,
        prepared: rb.prepared_fallbacks(),
    }))
}

/// The unrepaired builder with the changed patches substituted.
struct Repaired<'a> {
    base: Box<dyn TriangleBuilder + 'a>,
    slots: HashMap<u32, u32>,
    points: Vec<DVec3>,
    fallbacks: Vec<usize>,
    stride: usize,
    prepared: usize,
}

impl TriangleBuilder for Repaired<'_> {
    fn build(&self, t: usize, out: &mut [DVec3]) -> usize {
        match self.slots.get(&(t as u32)) {
            Some(&s) => {
                let s = s as usize;
                out.copy_from_slice(&self.points[s * self.stride..(s + 1) * self.stride]);
                self.fallbacks[s]
            }
            None => self.base.build(t, out),
        }
    }

    fn prepared_fallbacks(&self) -> usize {
        self.prepared
    }
}

/// Normal groups: the corners of one vertex that carry bitwise the same normal.
struct Groups {
    /// Group of corner 3t + k.
    of_corner: Vec<u32>,
    /// Corners of each group.
    list: Vec<Vec<u32>>,
    vertex: Vec<u32>,
    /// Groups of each vertex.
    at_vertex: Vec<Vec<u32>>,
    /// Groups whose normal no later step of the search changes (those of
    /// [`isolate_sliver`]); only the last pass moves them back towards their input.
    frozen: HashSet<u32>,
    /// Vertices of the doubled triangles split off the surface ([`split_fin`]): the passes
    /// that move normals back leave every group there alone, and the flattening makes
    /// every corner there flat.
    fins: HashSet<u32>,
}

impl Groups {
    fn new(mesh: &Mesh) -> Groups {
        let nv = mesh.positions.len();
        let mut count = vec![0u32; nv + 1];
        for tri in &mesh.triangles {
            for &v in tri {
                count[v as usize + 1] += 1;
            }
        }
        for i in 0..nv {
            count[i + 1] += count[i];
        }
        let mut fill = count.clone();
        let mut by_vertex = vec![0u32; mesh.triangles.len() * 3];
        for (t, tri) in mesh.triangles.iter().enumerate() {
            for (k, &v) in tri.iter().enumerate() {
                by_vertex[fill[v as usize] as usize] = (3 * t + k) as u32;
                fill[v as usize] += 1;
            }
        }
        let mut of_corner = vec![0u32; by_vertex.len()];
        let mut list = Vec::new();
        let mut vertex = Vec::new();
        let mut at_vertex = vec![Vec::new(); nv];
        let mut keys: Vec<[u64; 3]> = Vec::new();
        for v in 0..nv {
            let cs = &by_vertex[count[v] as usize..count[v + 1] as usize];
            keys.clear();
            for &c in cs {
                let key = normal_key(mesh.corner_normals[c as usize / 3][c as usize % 3]);
                if !keys.contains(&key) {
                    keys.push(key);
                }
            }
            for key in &keys {
                let g = vertex.len() as u32;
                let mut corners = Vec::new();
                for &c in cs {
                    if normal_key(mesh.corner_normals[c as usize / 3][c as usize % 3]) == *key {
                        of_corner[c as usize] = g;
                        corners.push(c);
                    }
                }
                list.push(corners);
                vertex.push(v as u32);
                at_vertex[v].push(g);
            }
        }
        Groups {
            of_corner,
            list,
            vertex,
            at_vertex,
            frozen: HashSet::new(),
            fins: HashSet::new(),
        }
    }

    /// Whether group `g` is at a vertex of a split fin ([`Self::fins`]).
    fn at_fin(&self, g: u32) -> bool {
        self.fins.contains(&self.vertex[g as usize])
    }

    fn corners(&self, g: u32) -> &[u32] {
        &self.list[g as usize]
    }

    /// The triangles with a corner in one of the groups `gs`, sorted, each once.
    fn triangles(&self, gs: impl IntoIterator<Item = u32>) -> Vec<u32> {
        let mut tris: Vec<u32> = gs
            .into_iter()
            .flat_map(|g| self.corners(g).iter().map(|&c| c / 3))
            .collect();
        tris.sort_unstable();
        tris.dedup();
        tris
    }

    /// The triangles around the vertices of `tri` (sorted, each once).
    fn ring(&self, tri: [u32; 3]) -> Vec<u32> {
        self.triangles(
            tri.iter()
                .flat_map(|&v| self.at_vertex[v as usize].iter().copied()),
        )
    }

    /// Moves the corners `b` of group `g` into a new group (a new crease at its vertex);
    /// returns the new group.
    fn split(&mut self, g: u32, b: &[u32]) -> u32 {
        let new = self.list.len() as u32;
        self.list[g as usize].retain(|c| !b.contains(c));
        self.list.push(b.to_vec());
        self.vertex.push(self.vertex[g as usize]);
        self.at_vertex[self.vertex[g as usize] as usize].push(new);
        for &c in b {
            self.of_corner[c as usize] = new;
        }
        new
    }

    /// Undoes the last [`Self::split`] of `g` into `h`.
    fn unsplit(&mut self, g: u32, h: u32) {
        let moved = self.list.pop().unwrap_or_default();
        self.vertex.pop();
        self.at_vertex[self.vertex[g as usize] as usize].retain(|&x| x != h);
        for &c in &moved {
            self.of_corner[c as usize] = g;
        }
        self.list[g as usize].extend_from_slice(&moved);
    }

    /// The triangles whose patch a new normal of group `g` may change: every triangle at
    /// its vertex (across a crease edge there, the shared crease curve is built from both
    /// sides' normals).
    fn triangles_around(&self, g: u32) -> impl Iterator<Item = u32> + '_ {
        self.at_vertex[self.vertex[g as usize] as usize]
            .iter()
            .flat_map(|&h| self.list[h as usize].iter().map(|&c| c / 3))
    }

    /// The face normals (`faces`, by triangle) of the triangles of group `g`, less those
    /// of degenerate triangles (a zero normal: they face every way).
    fn face_normals<'a>(&'a self, g: u32, faces: &'a [DVec3]) -> impl Iterator<Item = DVec3> + 'a {
        self.corners(g)
            .iter()
            .map(|&c| faces[c as usize / 3])
            .filter(|x| x.length_squared() > 0.25)
    }

    /// The smallest cosine of `n` to [`Self::face_normals`] of group `g` (+∞ for none).
    fn facing(&self, g: u32, faces: &[DVec3], n: DVec3) -> f64 {
        self.face_normals(g, faces)
            .map(|x| x.dot(n))
            .fold(f64::INFINITY, f64::min)
    }

    /// The normal of group `g` in `mesh`.
    fn normal(&self, mesh: &Mesh, g: u32) -> DVec3 {
        let c = self.list[g as usize][0] as usize;
        mesh.corner_normals[c / 3][c % 3]
    }
}

/// The unit vector maximising the smallest cosine to the unit vectors `f` (approximately:
/// 200 Bădoiu–Clarkson steps from their mean), or `fallback`.
fn central(f: &[DVec3], fallback: DVec3) -> DVec3 {
    let mut m = match f.iter().copied().sum::<DVec3>().try_normalize() {
        Some(m) => m,
        None => return fallback,
    };
    for i in 0..200 {
        let worst = f
            .iter()
            .copied()
            .min_by(|a, b| a.dot(m).total_cmp(&b.dot(m)))
            .unwrap_or(m);
        m = match (m + (worst - m) / (i as f64 + 2.0)).try_normalize() {
            Some(x) => x,
            None => break,
        };
    }
    m
}

/// `a` moved a fraction `w` of the way to `b` (normalised linear blend), unit.
fn towards(a: DVec3, b: DVec3, w: f64) -> DVec3 {
    if w <= 0.0 {
        return a;
    }
    ((1.0 - w) * a + w * b).try_normalize().unwrap_or(b)
}

/// [`plan_with`] splitting the doubled triangles ([`split_fin`]), or, where the search
/// then breaks what keeps a fin's shared edges straight (none of the meshes here), without.
fn plan(mesh: &Mesh, scheme: Scheme, opts: &SchemeOptions) -> Result<Option<Plan>> {
    match plan_with(mesh, scheme, opts, true)? {
        Some((p, false)) => Ok(Some(p)),
        Some((_, true)) => Ok(plan_with(mesh, scheme, opts, false)?.map(|(p, _)| p)),
        None => Ok(None),
    }
}

/// The search (see the module documentation); with `fins`, doubled triangles are split
/// first ([`split_fin`]). Returns the plan and whether a fin's constraints were broken
/// later (then the plan is not used).
fn plan_with(
    mesh: &Mesh,
    scheme: Scheme,
    opts: &SchemeOptions,
    fins: bool,
) -> Result<Option<(Plan, bool)>> {
    let table0 = PatchTable::build(mesh, scheme, opts)?;
    let mut verdicts = check_table(&table0);
    let before = verdicts
        .iter()
        .fold(PatchCounts::default(), PatchCounts::with);
    let mut bad: Vec<u32> = (0..verdicts.len() as u32)
        .filter(|&t| verdicts[t as usize] != Verdict::Valid)
        .collect();
    if bad.is_empty() {
        return Ok(None);
    }
    forget_verdicts();
    // The search also refuses a certified G1 patch whose cubic Lagrange element may fold
    // ([`judge`]), and repairs the input's too.
    let verdicts0 = verdicts.clone();
    if scheme == Scheme::G1 {
        let weak: Vec<bool> = (0..verdicts.len())
            .into_par_iter()
            .map(|t| {
                verdicts[t] == Verdict::Valid
                    && (lagrange3_bound(&table0, t) <= LAGRANGE_MARGIN
                        || inside_out(&table0, t, mesh.corner_normals[t]))
            })
            .collect();
        for (t, w) in weak.into_iter().enumerate() {
            if w {
                verdicts[t] = Verdict::Undecided;
                bad.push(t as u32);
            }
        }
        bad.sort_unstable();
    }
    let mut groups = Groups::new(mesh);
    // The input's group of each corner (those of `forced`; cuts add groups later).
    let input_group = groups.of_corner.clone();
    let faces: Vec<DVec3> = table0.flat_normals.clone();
    let mut work = mesh.clone();
    let mut touched: HashSet<u32> = HashSet::new();
    let mut changed: HashSet<u32> = HashSet::new();
    let mut splits = 0;
    let mut in_cuts: HashSet<u32> = HashSet::new();
    let mut slivers = 0;
    let mut cuts: Vec<[u32; 2]> = Vec::new();
    let twins = if scheme == Scheme::G1 {
        twins(mesh)
    } else {
        Vec::new()
    };
    let grid = Grid::of(scheme.kind(), BADNESS_LEVEL);
    let grid_fine = Grid::of(scheme.kind(), FINE_LEVEL);
    let (lower_bound, mut forced) = corner_bound(mesh, &faces, &groups);
    let mut crease_free_left: Vec<u32> = Vec::new();
    let mut rounds = 0;
    // G1, first: each doubled triangle (a fin) with a copy uncertified is split off the
    // surface ([`split_fin`]); its groups and the surface's groups it constrains are
    // left alone by everything that follows, and checked at the end.
    let mut pinned: Vec<(u32, DVec3)> = Vec::new();
    if fins && scheme == Scheme::G1 {
        for pair in doubled_triangles(mesh) {
            if pair.iter().all(|&t| verdicts[t as usize] == Verdict::Valid) {
                continue;
            }
            if let Some((gs, pins)) = split_fin(
                &mut work,
                &mut groups,
                pair,
                &faces,
                (scheme, opts, &twins),
                &mut verdicts,
                &mut changed,
            )? {
                touched.extend(gs.iter().copied());
                groups.frozen.extend(gs);
                groups.fins.extend(work.triangles[pair[0] as usize]);
                pinned.extend(pins);
            }
        }
        forced.resize(groups.list.len(), false);
    }
    // Two phases. G1 first searches without making any crease (the moves only, after
    // each group that does not face its triangles gets the nearest normal that does);
    // what it leaves uncertified, and every other scheme, goes through the search with
    // cuts, isolations and (G1) flattenings.
    for fallback in [false, true] {
        if !fallback && scheme != Scheme::G1 {
            continue;
        }
        if fallback {
            bad = (0..verdicts.len() as u32)
                .filter(|&t| verdicts[t as usize] != Verdict::Valid)
                .collect();
            if bad.is_empty() {
                break;
            }
            if scheme == Scheme::G1 {
                crease_free_left = bad.clone();
                // The arm step: scaled tangent lengths of the curves of these patches'
                // edges, kept only where it certifies every one of them (and the patches
                // across those edges) without a crease.
                if let Some(tris) = arm_step(&mut work, &bad, (scheme, opts, &twins))? {
                    for t in tris {
                        verdicts[t as usize] = Verdict::Valid;
                        changed.insert(t);
                    }
                    bad.clear();
                    break;
                }
            }
        } else {
            // Every group at a corner of an uncertified patch that faces some of its
            // triangles by less than FACING (n_f · N) gets the nearest normal that faces
            // them all by FACING (by the largest smallest cosine where that is less than
            // FACING); a group where no normal faces them all is left to the fallback.
            let mut gs: Vec<u32> = bad
                .iter()
                .flat_map(|&t| (0..3).map(move |k| 3 * t as usize + k))
                .map(|c| groups.of_corner[c])
                .collect();
            gs.sort_unstable();
            gs.dedup();
            for g in gs {
                if forced[g as usize] || groups.frozen.contains(&g) {
                    continue;
                }
                let f: Vec<DVec3> = groups.face_normals(g, &faces).collect();
                let cur = groups.normal(&work, g);
                if f.iter().all(|x| x.dot(cur) >= FACING) {
                    continue;
                }
                let Some(target) = nearest_facing(cur, &f, FACING)
                    .or_else(|| max_min_direction(&f).map(|(n, _)| n))
                else {
                    continue;
                };
                let mut ring = Vec::new();
                set_group(&mut work, &groups, g, target, &mut ring);
                ring.sort_unstable();
                ring.dedup();
                let v = verdicts_of(&work, scheme, opts, &ring, &twins)?;
                record(&mut verdicts, &mut changed, &ring, &v);
                touched.insert(g);
            }
        }
        if fallback && scheme == Scheme::G1 {
            for &t in &bad {
                if let Some(gs) = isolate_sliver(
                    &mut work,
                    &mut groups,
                    t,
                    &faces,
                    (scheme, opts, &twins),
                    &mut verdicts,
                    &mut changed,
                    &grid,
                    false,
                )? {
                    touched.extend(gs);
                    splits += 6;
                    slivers += 1;
                }
            }
            bad.retain(|&t| verdicts[t as usize] != Verdict::Valid);
        }
        // Then, every normal group at a corner of an uncertified patch that does not face
        // all of its own triangles by a margin (smallest cosine to their face normals below
        // 0.1) gets its central normal, where that faces them better: the corner condition
        // n_f · N > 0 of every patch around it, which no later move can do without.
        let mut seen = HashSet::new();
        for &t in bad.iter().filter(|_| fallback) {
            for k in 0..3 {
                let g = groups.of_corner[3 * t as usize + k];
                if !seen.insert(g) || groups.frozen.contains(&g) {
                    continue;
                }
                let f: Vec<DVec3> = groups
                    .corners(g)
                    .iter()
                    .map(|&c| faces[c as usize / 3])
                    .collect();
                let cur = groups.normal(&work, g);
                let margin = |n: DVec3| f.iter().map(|x| x.dot(n)).fold(f64::INFINITY, f64::min);
                let c = central(&f, cur);
                if margin(cur) < PREPASS_MARGIN && margin(c) > margin(cur) {
                    let mut ring = Vec::new();
                    set_group(&mut work, &groups, g, c, &mut ring);
                    ring.sort_unstable();
                    ring.dedup();
                    let v = verdicts_of(&work, scheme, opts, &ring, &twins)?;
                    record(&mut verdicts, &mut changed, &ring, &v);
                    touched.insert(g);
                }
            }
        }
        bad = (0..verdicts.len() as u32)
            .filter(|&t| verdicts[t as usize] != Verdict::Valid)
            .collect();
        let mut joint_done = 0;
        let mut refused: HashSet<Vec<u64>> = HashSet::new();
        loop {
            let mut phase_rounds = 0;
            let (mut fewest_bad, mut stalled) = (bad.len(), 0);
            while !bad.is_empty()
                && phase_rounds
                    < if fallback {
                        MAX_ROUNDS
                    } else {
                        CREASE_FREE_ROUNDS
                    }
            {
                phase_rounds += 1;
                rounds += 1;
                let mut improved = false;
                // The crease-free phase measures on a finer grid: the folds it meets sit between
                // the points of the coarse one.
                let grid = if fallback { &grid } else { &grid_fine };
                for &t in &bad.clone() {
                    let tri = t as usize;
                    if verdicts[tri] == Verdict::Valid {
                        continue;
                    }
                    // The best move of one corner group of this patch: (badness of the patches
                    // around the group after it, group, new normal).
                    let mut best: Option<(f64, Vec<(u32, DVec3)>)> = None;
                    let corner_normals = work.corner_normals[tri];
                    let mean = corner_normals
                        .iter()
                        .copied()
                        .sum::<DVec3>()
                        .try_normalize();
                    let own: Vec<u32> = (0..3).map(|k| groups.of_corner[3 * tri + k]).collect();
                    // Candidate moves: one group at a time, then the patch's three groups together
                    // towards its face normal.
                    let mut candidates: Vec<Vec<(u32, DVec3)>> = Vec::new();
                    for &g in own.iter().filter(|g| !groups.frozen.contains(g)) {
                        let cur = groups.normal(&work, g);
                        let f: Vec<DVec3> = groups
                            .corners(g)
                            .iter()
                            .map(|&c| faces[c as usize / 3])
                            .collect();
                        let mut targets = vec![central(&f, cur), faces[tri]];
                        targets.extend(mean);
                        for target in targets {
                            for w in WEIGHTS {
                                candidates.push(vec![(g, towards(cur, target, w))]);
                            }
                        }
                        // The nearest normals facing all of the group's triangles by a margin.
                        for m in FACING_STEPS {
                            if let Some(n) = nearest_facing(cur, &f, m) {
                                candidates.push(vec![(g, n)]);
                            }
                        }
                    }
                    for w in WEIGHTS {
                        candidates.push(
                            own.iter()
                                .filter(|g| !groups.frozen.contains(g))
                                .map(|&g| (g, towards(groups.normal(&work, g), faces[tri], w)))
                                .collect(),
                        );
                    }
                    // Two or three of its groups together towards the central normal of all their
                    // faces (a sliver's close corners need nearly the same normal: their curves to
                    // the far corner must not cross).
                    let sets: [&[usize]; 4] = [&[0, 1], &[1, 2], &[2, 0], &[0, 1, 2]];
                    for set in sets {
                        let gs: Vec<u32> = set.iter().map(|&k| own[k]).collect();
                        if gs.iter().any(|g| {
                            gs.iter().filter(|h| *h == g).count() > 1 || groups.frozen.contains(g)
                        }) {
                            continue;
                        }
                        let f: Vec<DVec3> = gs
                            .iter()
                            .flat_map(|&g| groups.corners(g))
                            .map(|&c| faces[c as usize / 3])
                            .collect();
                        let target = central(&f, faces[tri]);
                        for w in WEIGHTS {
                            candidates.push(
                                gs.iter()
                                    .map(|&g| (g, towards(groups.normal(&work, g), target, w)))
                                    .collect(),
                            );
                        }
                        // Crease-free phase: the groups together, each to its nearest normal
                        // facing its own triangles by a margin.
                        for m in FACING_STEPS.iter().filter(|_| !fallback) {
                            let moves: Option<Vec<(u32, DVec3)>> = gs
                                .iter()
                                .map(|&g| {
                                    let f: Vec<DVec3> = groups
                                        .corners(g)
                                        .iter()
                                        .map(|&c| faces[c as usize / 3])
                                        .collect();
                                    nearest_facing(groups.normal(&work, g), &f, *m).map(|n| (g, n))
                                })
                                .collect();
                            candidates.extend(moves);
                        }
                        // And one normal for all of them, the nearest to their mean facing
                        // all of their triangles (a sliver's close corners).
                        let mean = gs
                            .iter()
                            .map(|&g| groups.normal(&work, g))
                            .sum::<DVec3>()
                            .try_normalize();
                        for m in FACING_STEPS.iter().filter(|_| !fallback) {
                            if let Some(n) = mean.and_then(|x| nearest_facing(x, &f, *m)) {
                                candidates.push(gs.iter().map(|&g| (g, n)).collect());
                            }
                        }
                    }
                    // Crease-free phase: every trial, (gain, moves, ring).
                    let mut scored: Vec<Trial> = Vec::new();
                    // The badness of each ring as it is now, by ring.
                    let mut now_of: HashMap<Vec<u32>, f64> = HashMap::new();
                    let measure = |table: &PatchTable| {
                        if fallback {
                            badness(table, grid)
                        } else {
                            badness(table, grid) + lagrange_shortfall(table)
                        }
                    };
                    for moves in candidates {
                        if moves
                            .iter()
                            .all(|&(g, n)| normal_key(n) == normal_key(groups.normal(&work, g)))
                        {
                            continue;
                        }
                        // The crease-free phase keeps every corner condition it has met: a
                        // moved group faces all of its triangles by FACING_STEPS[0], or by no
                        // less than before.
                        if !fallback
                            && moves.iter().any(|&(g, n)| {
                                groups.facing(g, &faces, n)
                                    < FACING_STEPS[0].min(groups.facing(
                                        g,
                                        &faces,
                                        groups.normal(&work, g),
                                    ))
                            })
                        {
                            continue;
                        }
                        let mut ring: Vec<u32> = moves
                            .iter()
                            .flat_map(|&(g, _)| groups.triangles_around(g))
                            .collect();
                        ring.sort_unstable();
                        ring.dedup();
                        let now = match now_of.get(&ring) {
                            Some(&x) => x,
                            None => {
                                let x = measure(&*ring_table(&work, scheme, opts, &ring, &twins)?);
                                now_of.insert(ring.clone(), x);
                                x
                            }
                        };
                        let b = with_moves(&mut work, &groups, &moves, |w| -> Result<_> {
                            Ok(measure(&*ring_table(w, scheme, opts, &ring, &twins)?))
                        })?;
                        let gain = now - b;
                        if !fallback {
                            scored.push((gain, moves.clone(), ring));
                        }
                        if gain > 1e-9 * now && best.as_ref().is_none_or(|(x, _)| gain > *x) {
                            best = Some((gain, moves));
                        }
                    }
                    // The crease-free phase prefers, among the trials of largest gain, the
                    // one with the fewest uncertified patches around it where that is fewer
                    // than now (the measure's grid can miss a fold the certificate sees).
                    scored.sort_by(|a, b| b.0.total_cmp(&a.0));
                    let mut fewest: Option<(usize, usize)> = None;
                    for (i, (_, moves, ring)) in scored.iter().take(CERTIFY_TRIALS).enumerate() {
                        let was = ring
                            .iter()
                            .filter(|&&r| verdicts[r as usize] != Verdict::Valid)
                            .count();
                        let Some(limit) =
                            fewest.map_or(was.checked_sub(1), |(c, _)| c.checked_sub(1))
                        else {
                            break;
                        };
                        let counted = with_moves(&mut work, &groups, moves, |w| -> Result<_> {
                            Ok(uncertified_upto(
                                &ring_table(w, scheme, opts, ring, &twins)?,
                                limit,
                            ))
                        })?;
                        if let Some(c) = counted {
                            fewest = Some((c, i));
                        }
                    }
                    if let Some((_, i)) = fewest {
                        let (gain, moves, _) = scored.swap_remove(i);
                        best = Some((gain, moves));
                    }
                    if let Some((_, moves)) = best {
                        let old: Vec<(u32, DVec3)> = moves
                            .iter()
                            .map(|&(g, _)| (g, groups.normal(&work, g)))
                            .collect();
                        let mut ring = Vec::new();
                        for &(g, n) in &moves {
                            set_group(&mut work, &groups, g, n, &mut ring);
                        }
                        ring.sort_unstable();
                        ring.dedup();
                        let was = ring
                            .iter()
                            .filter(|&&r| verdicts[r as usize] != Verdict::Valid)
                            .count();
                        let Some(v) = verdicts_upto(&work, (scheme, opts, &twins), &ring, was)?
                        else {
                            // The certificate disagrees with the sampled measure: undo.
                            for &(g, n) in old.iter().rev() {
                                set_group(&mut work, &groups, g, n, &mut ring);
                            }
                            continue;
                        };
                        record(&mut verdicts, &mut changed, &ring, &v);
                        touched.extend(moves.iter().map(|&(g, _)| g));
                        improved = true;
                    } else if !fallback {
                        continue;
                    } else if let Some(cut) = best_cut(
                        &mut work,
                        &mut groups,
                        tri,
                        &faces,
                        (scheme, opts, &twins),
                        &verdicts,
                        grid,
                    )? {
                        // No move of one normal helps: the fan of one corner's vertex is cut along
                        // one or two of its edges into two groups, each with its own normal (a new
                        // crease there), kept only where the certificate counts fewer uncertified
                        // patches.
                        record(&mut verdicts, &mut changed, &cut.ring, &cut.verdicts);
                        touched.insert(cut.groups[0]);
                        touched.insert(cut.groups[1]);
                        in_cuts.extend(cut.groups);
                        cuts.push(cut.groups);
                        splits += 1;
                        improved = true;
                    }
                }
                bad.retain(|&t| verdicts[t as usize] != Verdict::Valid);
                // The crease-free phase stops after two rounds that certify nothing more.
                if bad.len() < fewest_bad {
                    fewest_bad = bad.len();
                    stalled = 0;
                } else {
                    stalled += 1;
                }
                if !fallback && stalled >= 2 {
                    break;
                }
                if !improved {
                    break;
                }
            }
            bad = (0..verdicts.len() as u32)
                .filter(|&t| verdicts[t as usize] != Verdict::Valid)
                .collect();
            if fallback || joint_done >= JOINT_PASSES || bad.is_empty() {
                break;
            }
            joint_done += 1;
            // Crease-free phase, once its rounds stall: the normals of every group within one
            // ring of the patches left move together ([`joint_corners`]), one cluster of them
            // at a time (those whose rings share a group), kept where the certificate counts
            // fewer uncertified patches around them; then the rounds again.
            let regions: Vec<Vec<u32>> = bad
                .iter()
                .map(|&t| {
                    let mut r: Vec<u32> = (0..3)
                        .map(|k| groups.of_corner[3 * t as usize + k])
                        .flat_map(|g| groups.triangles_around(g).collect::<Vec<_>>())
                        .flat_map(|t| (0..3).map(move |k| 3 * t as usize + k))
                        .map(|c| groups.of_corner[c])
                        .filter(|&g| !forced[g as usize] && !groups.frozen.contains(&g))
                        .collect();
                    r.sort_unstable();
                    r.dedup();
                    r
                })
                .collect();
            let mut clusters: Vec<Vec<u32>> = Vec::new();
            for r in regions {
                let mut merged = r;
                clusters.retain(|c| {
                    if c.iter().any(|g| merged.binary_search(g).is_ok()) {
                        merged.extend_from_slice(c);
                        merged.sort_unstable();
                        merged.dedup();
                        false
                    } else {
                        true
                    }
                });
                if !merged.is_empty() {
                    clusters.push(merged);
                }
            }
            let mut any = false;
            for region in clusters {
                let old: Vec<(u32, DVec3)> = region
                    .iter()
                    .map(|&g| (g, groups.normal(&work, g)))
                    .collect();
                // A cluster refused before with the same normals is not tried again.
                let key: Vec<u64> = old
                    .iter()
                    .flat_map(|&(g, n)| std::iter::once(g as u64).chain(normal_key(n)))
                    .collect();
                if refused.contains(&key) {
                    continue;
                }
                let moved = joint_corners(
                    &mut work,
                    mesh,
                    &groups,
                    &faces,
                    &region,
                    (scheme, opts, &twins),
                    &grid,
                )?;
                let mut ring: Vec<u32> = region
                    .iter()
                    .flat_map(|&g| groups.triangles_around(g))
                    .collect();
                ring.sort_unstable();
                ring.dedup();
                let was = ring
                    .iter()
                    .filter(|&&r| verdicts[r as usize] != Verdict::Valid)
                    .count();
                let v = verdicts_of(&work, scheme, opts, &ring, &twins)?;
                let now = v.iter().filter(|x| **x != Verdict::Valid).count();
                if now >= was {
                    let mut sink = Vec::new();
                    for &(g, n) in old.iter().rev() {
                        set_group(&mut work, &groups, g, n, &mut sink);
                    }
                    refused.insert(key);
                    continue;
                }
                record(&mut verdicts, &mut changed, &ring, &v);
                touched.extend(
                    moved
                        .iter()
                        .zip(&old)
                        .filter(|(a, b)| a.1 != b.1)
                        .map(|(a, _)| a.0),
                );
                any = true;
            }
            if !any {
                break;
            }
            bad = (0..verdicts.len() as u32)
                .filter(|&t| verdicts[t as usize] != Verdict::Valid)
                .collect();
        }
    }
    // Where the search leaves a G1 patch uncertified, the same isolation as for a
    // triangle turned away from everything around it, kept where it certifies more.
    if scheme == Scheme::G1 {
        for &t in &bad.clone() {
            if verdicts[t as usize] == Verdict::Valid {
                continue;
            }
            if let Some(gs) = isolate_sliver(
                &mut work,
                &mut groups,
                t,
                &faces,
                (scheme, opts, &twins),
                &mut verdicts,
                &mut changed,
                &grid,
                true,
            )? {
                touched.extend(gs);
                splits += 6;
                slivers += 1;
            }
        }
    }
    // And where that leaves any G1 patch uncertified, the cascade of flattenings, which
    // ends with every patch certified.
    let mut flattened = 0;
    if scheme == Scheme::G1 && bad.iter().any(|&t| verdicts[t as usize] != Verdict::Valid) {
        flattened = flatten_cascade(
            &mut work,
            &mut groups,
            &faces,
            (scheme, opts, &twins),
            &mut verdicts,
            &mut changed,
            &mut touched,
            &grid,
        )?;
    }
    // Last, as little as needed. After a cascade, first each touched vertex (largest
    // change first) goes back to its input normals at every corner, cuts and flat corners
    // undone, where every patch around it stays certified.
    if flattened > 0 {
        let mut at: HashMap<u32, f64> = HashMap::new();
        for &g in &touched {
            let a = angle_deg(groups.normal(mesh, g), groups.normal(&work, g));
            let e = at.entry(groups.vertex[g as usize]).or_insert(0.0);
            *e = e.max(a);
        }
        let mut verts: Vec<(f64, u32)> = at
            .into_iter()
            .filter(|&(_, a)| a > 0.0)
            .map(|(v, a)| (a, v))
            .collect();
        verts.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        for (_, v) in verts {
            if groups.at_vertex[v as usize]
                .iter()
                .any(|&g| groups.at_fin(g))
            {
                continue;
            }
            let corners: Vec<u32> = groups.at_vertex[v as usize]
                .iter()
                .flat_map(|&g| groups.corners(g).iter().copied())
                .collect();
            let mut ring: Vec<u32> = corners.iter().map(|&c| c / 3).collect();
            ring.sort_unstable();
            ring.dedup();
            if ring.iter().any(|&r| verdicts[r as usize] != Verdict::Valid) {
                continue;
            }
            let old: Vec<DVec3> = corners
                .iter()
                .map(|&c| work.corner_normals[c as usize / 3][c as usize % 3])
                .collect();
            for &c in &corners {
                let (t, k) = (c as usize / 3, c as usize % 3);
                work.corner_normals[t][k] = mesh.corner_normals[t][k];
            }
            if let Some(v) = verdicts_upto(&work, (scheme, opts, &twins), &ring, 0)? {
                for (i, &r) in ring.iter().enumerate() {
                    verdicts[r as usize] = v[i];
                }
            } else {
                for (&c, &n) in corners.iter().zip(&old) {
                    work.corner_normals[c as usize / 3][c as usize % 3] = n;
                }
            }
        }
    }
    // Then each moved normal (largest change first) goes back to its input value, or 3/4,
    // 1/2 or 1/4 of the way there, where every patch around it stays certified.
    let mut moved: Vec<(f64, u32)> = touched
        .iter()
        .map(|&g| {
            (
                angle_deg(groups.normal(mesh, g), groups.normal(&work, g)),
                g,
            )
        })
        .filter(|&(a, _)| a > 0.0)
        .collect();
    moved.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    for &(_, g) in &moved {
        if groups.at_fin(g) {
            continue;
        }
        let (n0, cur) = (groups.normal(mesh, g), groups.normal(&work, g));
        let mut ring: Vec<u32> = groups.triangles_around(g).collect();
        ring.sort_unstable();
        ring.dedup();
        let was = ring
            .iter()
            .filter(|&&r| verdicts[r as usize] != Verdict::Valid)
            .count();
        if was > 0 {
            // Around a patch still uncertified the search's normals stay: they are the
            // best it found for that patch's neighbourhood.
            continue;
        }
        // A cut group goes at most 3/4 of the way (all the way would give both of its
        // groups one normal, undoing the cut, which the next pass decides).
        let ws: &[f64] = if in_cuts.contains(&g) {
            &[0.75, 0.5, 0.25]
        } else {
            &[1.0, 0.75, 0.5, 0.25]
        };
        // Also the nearest normals to the input one that face all of the group's
        // triangles by a margin (the corner condition; not for a cut's groups): tried with
        // the others, nearest to the input first.
        let mut options: Vec<DVec3> = ws.iter().map(|&w| towards(cur, n0, w)).collect();
        if !in_cuts.contains(&g) {
            let f: Vec<DVec3> = groups.face_normals(g, &faces).collect();
            options.extend(
                FACING_STEPS
                    .iter()
                    .filter_map(|&m| nearest_facing(n0, &f, m)),
            );
        }
        let far = angle_deg(n0, cur);
        options.retain(|&n| angle_deg(n0, n) < far);
        options.sort_by(|a, b| angle_deg(n0, *a).total_cmp(&angle_deg(n0, *b)));
        for n in options {
            let mut sink = Vec::new();
            set_group(&mut work, &groups, g, n, &mut sink);
            if let Some(v) = verdicts_upto(&work, (scheme, opts, &twins), &ring, was)? {
                for (i, &r) in ring.iter().enumerate() {
                    verdicts[r as usize] = v[i];
                }
                break;
            }
            set_group(&mut work, &groups, g, cur, &mut sink);
        }
    }
    // And each cut, latest first, is undone (both groups back to their input normal, the
    // creases gone) where the certificate then counts no more uncertified patches.
    for [g, h] in cuts.iter().rev() {
        let n0 = groups.normal(mesh, *g);
        let old = [groups.normal(&work, *g), groups.normal(&work, *h)];
        let mut ring: Vec<u32> = groups.triangles_around(*g).collect();
        ring.sort_unstable();
        ring.dedup();
        let was = ring
            .iter()
            .filter(|&&r| verdicts[r as usize] != Verdict::Valid)
            .count();
        let mut sink = Vec::new();
        set_group(&mut work, &groups, *g, n0, &mut sink);
        set_group(&mut work, &groups, *h, n0, &mut sink);
        if let Some(v) = verdicts_upto(&work, (scheme, opts, &twins), &ring, was)? {
            for (i, &r) in ring.iter().enumerate() {
                verdicts[r as usize] = v[i];
            }
            splits -= 1;
        } else {
            set_group(&mut work, &groups, *g, old[0], &mut sink);
            set_group(&mut work, &groups, *h, old[1], &mut sink);
        }
    }
    // After a cascade, last, the creases it made that are no longer needed: at each
    // touched vertex, the groups that were one normal group in the input get one normal
    // again (their corners' mean normal, or one of theirs), where every patch around stays
    // certified.
    if flattened > 0 {
        let mut verts: Vec<u32> = touched.iter().map(|&g| groups.vertex[g as usize]).collect();
        verts.sort_unstable();
        verts.dedup();
        for v in verts {
            let at = groups.at_vertex[v as usize].clone();
            if at.iter().any(|&g| groups.at_fin(g)) {
                continue;
            }
            let ring = groups.triangles(at.iter().copied());
            if ring.iter().any(|&r| verdicts[r as usize] != Verdict::Valid) {
                continue;
            }
            // Groups of the vertex by their input normal (one input group each).
            let mut parts: Vec<([u64; 3], Vec<u32>)> = Vec::new();
            for &g in &at {
                let key = normal_key(groups.normal(mesh, g));
                match parts.iter_mut().find(|(k, _)| *k == key) {
                    Some((_, list)) => list.push(g),
                    None => parts.push((key, vec![g])),
                }
            }
            for (_, part) in parts {
                let now: Vec<DVec3> = part.iter().map(|&g| groups.normal(&work, g)).collect();
                if now.iter().all(|n| normal_key(*n) == normal_key(now[0])) {
                    continue;
                }
                let mean = part
                    .iter()
                    .map(|&g| groups.normal(&work, g) * groups.corners(g).len() as f64)
                    .sum::<DVec3>()
                    .try_normalize();
                let mut options: Vec<DVec3> = mean.into_iter().collect();
                options.extend(now.iter().copied());
                let mut sink = Vec::new();
                for n in options {
                    for &g in &part {
                        set_group(&mut work, &groups, g, n, &mut sink);
                    }
                    if let Some(vs) = verdicts_upto(&work, (scheme, opts, &twins), &ring, 0)? {
                        record(&mut verdicts, &mut changed, &ring, &vs);
                        break;
                    }
                    for (&g, &n) in part.iter().zip(&now) {
                        set_group(&mut work, &groups, g, n, &mut sink);
                    }
                }
            }
        }
    }
    // Last, the moved groups of one triangle together (two close corners of a sliver need
    // nearly one normal, so neither goes back alone): each to its nearest normal to the
    // input facing its triangles by a margin, or all to the nearest one to the mean of
    // their input normals facing all of their triangles, or each a fraction of the way
    // back; the option with the smallest largest change that the certificate accepts.
    let mut by_triangle: Vec<(u32, Vec<u32>)> = Vec::new();
    {
        let mut gs: Vec<u32> = moved
            .iter()
            .map(|&(_, g)| g)
            .filter(|g| !in_cuts.contains(g) && !groups.frozen.contains(g) && !groups.at_fin(*g))
            .collect();
        gs.sort_unstable();
        let tris = groups.triangles(gs.iter().copied());
        for t in tris {
            let own: Vec<u32> = (0..3)
                .map(|k| groups.of_corner[3 * t as usize + k])
                .filter(|g| gs.binary_search(g).is_ok())
                .collect();
            if own.len() >= 2 {
                by_triangle.push((t, own));
            }
        }
    }
    for (_, own) in &by_triangle {
        let cur: Vec<DVec3> = own.iter().map(|&g| groups.normal(&work, g)).collect();
        let n0: Vec<DVec3> = own.iter().map(|&g| groups.normal(mesh, g)).collect();
        let worst = |ns: &[DVec3]| {
            ns.iter()
                .zip(&n0)
                .map(|(a, b)| angle_deg(*a, *b))
                .fold(0.0, f64::max)
        };
        let now = worst(&cur);
        let mut ring: Vec<u32> = own
            .iter()
            .flat_map(|&g| groups.triangles_around(g))
            .collect();
        ring.sort_unstable();
        ring.dedup();
        if ring.iter().any(|&r| verdicts[r as usize] != Verdict::Valid) {
            continue;
        }
        let faces_of = |gs: &[u32]| -> Vec<DVec3> {
            gs.iter()
                .flat_map(|&g| groups.face_normals(g, &faces))
                .collect()
        };
        let all = faces_of(own);
        let mean = n0.iter().copied().sum::<DVec3>().try_normalize();
        let mut options: Vec<Vec<DVec3>> = Vec::new();
        for m in FACING_STEPS {
            let each: Option<Vec<DVec3>> = own
                .iter()
                .zip(&n0)
                .map(|(&g, &n)| nearest_facing(n, &faces_of(&[g]), m))
                .collect();
            options.extend(each);
            if let Some(n) = mean.and_then(|x| nearest_facing(x, &all, m)) {
                options.push(vec![n; own.len()]);
            }
        }
        for w in [0.75, 0.5, 0.25] {
            options.push(
                cur.iter()
                    .zip(&n0)
                    .map(|(&c, &n)| towards(c, n, w))
                    .collect(),
            );
        }
        options.retain(|o| worst(o) < now);
        options.sort_by(|a, b| worst(a).total_cmp(&worst(b)));
        for o in options {
            let mut sink = Vec::new();
            for (&g, &n) in own.iter().zip(&o) {
                set_group(&mut work, &groups, g, n, &mut sink);
            }
            if let Some(v) = verdicts_upto(&work, (scheme, opts, &twins), &ring, 0)? {
                for (i, &r) in ring.iter().enumerate() {
                    verdicts[r as usize] = v[i];
                }
                break;
            }
            for (&g, &n) in own.iter().zip(&cur) {
                set_group(&mut work, &groups, g, n, &mut sink);
            }
        }
    }
    // Every fin's constraints must still hold (the flattening cascade ignores them).
    // Every fin's edges on the surface must still be straight in every use (the normals
    // at their ends perpendicular to them: rounding only).
    let broken = pinned.iter().any(|&(c, d)| {
        work.corner_normals[c as usize / 3][c as usize % 3]
            .dot(d)
            .abs()
            > 1e-12
    });
    let flipped = bad
        .iter()
        .filter(|&&t| verdicts[t as usize] != Verdict::Valid)
        .filter(|&&t| {
            let tri = t as usize;
            let around: DVec3 = (0..3)
                .flat_map(|k| groups.corners(groups.of_corner[3 * tri + k]))
                .map(|&c| faces[c as usize / 3])
                .sum();
            (around - 3.0 * faces[tri]).dot(faces[tri]) < 0.0
        })
        .count();
    let mut changed: Vec<u32> = changed.into_iter().collect();
    changed.sort_unstable();
    // What changed, measured on the final normals.
    let mut vertices = HashSet::new();
    let mut corners = 0;
    let mut max_angle = 0.0f64;
    for &g in &touched {
        let (n0, n) = (groups.normal(mesh, g), groups.normal(&work, g));
        if normal_key(n) != normal_key(n0) {
            vertices.insert(groups.vertex[g as usize]);
            corners += groups.corners(g).len();
            max_angle = max_angle.max(angle_deg(n0, n));
        }
    }
    let (arm_edges_scaled, arm_scale_range) = arm_summary(&work);
    let builder = PatchBuilder::new(&work, scheme, opts)?;
    let table = builder.table_of(&changed, 0)?;
    // The verdicts reported are the certificate's alone (the search also refuses a G1
    // patch whose cubic Lagrange element may fold, [`judge`]): those of the changed
    // patches on the whole mesh's builder, the input's elsewhere.
    let mut finals = verdicts0;
    let again: Vec<Verdict> = (0..changed.len())
        .into_par_iter()
        .map(|i| certify(&table, i))
        .collect();
    for (&t, v) in changed.iter().zip(again) {
        finals[t as usize] = v;
    }
    forget_verdicts();
    let after = finals
        .iter()
        .fold(PatchCounts::default(), PatchCounts::with);
    let grid = Grid::of(table.kind, DISTANCE_LEVEL);
    let max_distance = changed
        .par_iter()
        .enumerate()
        .map(|(i, &t)| {
            grid.weights
                .iter()
                .map(|w| {
                    (table.eval_weights(i, w).p - table0.eval_weights(t as usize, w).p).length()
                })
                .fold(0.0, f64::max)
        })
        .reduce(|| 0.0, f64::max);
    drop(table);
    drop(builder);
    let report = RepairReport {
        before,
        after,
        vertices_touched: vertices.len(),
        corners_changed: corners,
        patches_changed: changed.len(),
        max_normal_change_deg: max_angle,
        max_distance,
        groups_split: splits,
        slivers_isolated: slivers,
        edges_made_creases: new_creases(mesh, &work),
        left_on_flipped_triangles: flipped,
        triangles_flattened: flattened,
        rounds,
        normal_change_lower_bound_deg: lower_bound,
        crease_forced_groups: forced.iter().filter(|&&x| x).count(),
        crease_free_left_forced: crease_free_left
            .iter()
            .filter(|&&t| (0..3).any(|k| forced[input_group[3 * t as usize + k] as usize]))
            .count(),
        crease_free_left,
        arm_edges_scaled,
        arm_scale_range,
    };
    Ok(Some((
        Plan {
            mesh: work,
            changed,
            report,
        },
        broken,
    )))
}

/// Smallest and largest arm factor the arm step ([`arm_step`]) tries.
const ARM_RANGE: [f64; 2] = [0.1, 4.0];
/// Factors the arm step's starts give the arms at each patch's weakest corner.
const ARM_STARTS: [f64; 5] = [0.3, 0.6, 1.6, 2.5, 4.0];
/// The arm step's pattern search stops when its step (log scale) is below this.
const ARM_STEP_END: f64 = 0.02;
/// Grid levels of the arm step's measure: for the search, and to check its results
/// before they are certified.
const ARM_LEVELS: [u32; 2] = [12, 40];

/// The number of interior edges whose arms `work` scales, and the smallest and largest
/// factor among them ([1, 1] where none).
fn arm_summary(work: &Mesh) -> (usize, [f64; 2]) {
    let Some(a) = &work.attributes.arm_scales else {
        return (0, [1.0, 1.0]);
    };
    let mut edges = HashSet::new();
    let mut range = [f64::INFINITY, f64::NEG_INFINITY];
    for (t, s) in a.iter().enumerate() {
        for (k, s) in s.iter().enumerate() {
            if *s != [1.0, 1.0] {
                let tri = work.triangles[t];
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                edges.insert([a.min(b), a.max(b)]);
                for x in s {
                    range = [range[0].min(*x), range[1].max(*x)];
                }
            }
        }
    }
    if edges.is_empty() {
        return (0, [1.0, 1.0]);
    }
    (edges.len(), range)
}

/// Sets the arm factors of the interior edges `edges` (each by its two half-edges, the
/// lower first, and its vertices, the lower first) to `exp(x[2 i])` at its lower vertex
/// and `exp(x[2 i + 1])` at its higher one, in both uses.
fn set_arms(work: &mut Mesh, edges: &[([u32; 2], [u32; 2])], x: &[f64]) {
    let n = work.triangles.len();
    let Mesh {
        triangles: tris,
        attributes,
        ..
    } = work;
    let a = attributes
        .arm_scales
        .get_or_insert_with(|| vec![[[1.0; 2]; 3]; n]);
    for (i, (hs, v)) in edges.iter().enumerate() {
        let s = [x[2 * i].exp(), x[2 * i + 1].exp()];
        for &h in hs {
            let (t, k) = (h as usize / 3, h as usize % 3);
            a[t][k] = if tris[t][k] == v[0] { s } else { [s[1], s[0]] };
        }
    }
}

/// The arm step's measure of the patches of `tris` on `work` (G1): the smallest, over
/// them, of the scaled Jacobian J/(|S_s| |S_t|) along n_f on a grid of `level` and on rays
/// close to each corner (the folds it meets sit there), and of the bound of the cubic
/// Lagrange element above [`LAGRANGE_MARGIN`] ([`judge`] refuses below it).
fn arm_measure(
    work: &Mesh,
    ctx: (Scheme, &SchemeOptions, &[u32]),
    tris: &[u32],
    level: u32,
) -> Result<f64> {
    // Rays: radii (barycentric) and directions between the corner's two edges; more of
    // both for the finer level.
    let (radii, dirs): (&[f64], u32) = if level >= ARM_LEVELS[1] {
        (
            &[
                0.001, 0.003, 0.006, 0.01, 0.015, 0.02, 0.03, 0.045, 0.06, 0.08,
            ],
            8,
        )
    } else {
        (&[0.002, 0.006, 0.015, 0.03, 0.06], 4)
    };
    let (scheme, opts, twins) = ctx;
    let table = ring_patches(work, scheme, opts, tris, twins)?;
    let grid = Grid::of(table.kind, level);
    let mut m = f64::INFINITY;
    for i in 0..table.len() {
        let nf = table.flat_normals[i];
        let sj = |p: super::SurfacePoint| scaled_jacobian(&p, nf).2;
        for w in &grid.weights {
            m = m.min(sj(table.eval_weights(i, w)));
        }
        for k in 0..3 {
            for &r in radii {
                for a in 0..=dirs {
                    let w = a as f64 / dirs as f64;
                    let mut b = [0.0; 3];
                    b[k] = 1.0 - r;
                    b[(k + 1) % 3] = r * w;
                    b[(k + 2) % 3] = r * (1.0 - w);
                    m = m.min(sj(table.eval(i, b)));
                }
            }
        }
        m = m.min(lagrange3_bound(&table, i) - LAGRANGE_MARGIN);
    }
    Ok(m)
}

/// Whether [`judge`] accepts every patch of `tris` on `work`.
fn all_certified(work: &Mesh, ctx: (Scheme, &SchemeOptions, &[u32]), tris: &[u32]) -> Result<bool> {
    let (scheme, opts, twins) = ctx;
    let table = ring_table(work, scheme, opts, tris, twins)?;
    Ok((0..tris.len())
        .into_par_iter()
        .all(|i| judge(&table, i, table.normals[i]) == Verdict::Valid))
}

/// The arm step (G1, after the crease-free phase; see the module documentation): the
/// patches `bad` are clustered (those whose edges' triangles overlap), and for each
/// cluster the two arm factors of each interior edge of its patches (log scale, within
/// [`ARM_RANGE`]) are searched: a pattern search from each start in turn maximising
/// [`arm_measure`] over the triangles of those edges, the first result that is positive
/// on the finer grid and that [`judge`] accepts on all of them made as small as it stays
/// accepted (all factors' logarithms scaled by 0.1 up to 1, then each arm back to 1,
/// largest first). Kept only where every cluster is certified: then `work` carries the
/// factors ([`crate::mesh::CornerAttributes::arm_scales`]) and the triangles whose patch
/// changed are returned; otherwise `work` is left as it was and `None` returned.
fn arm_step(
    work: &mut Mesh,
    bad: &[u32],
    ctx: (Scheme, &SchemeOptions, &[u32]),
) -> Result<Option<Vec<u32>>> {
    let twins = ctx.2;
    if ctx.0 != Scheme::G1 || bad.is_empty() || work.attributes.arm_scales.is_some() {
        return Ok(None);
    }
    // The triangles each bad patch's interior edges reach, and clusters of bad patches
    // whose sets overlap.
    let reach = |t: u32| -> Vec<u32> {
        let mut r: Vec<u32> = (0..3)
            .map(|k| twins[3 * t as usize + k])
            .filter(|&o| o != u32::MAX)
            .map(|o| o / 3)
            .chain(std::iter::once(t))
            .collect();
        r.sort_unstable();
        r
    };
    let mut clusters: Vec<(Vec<u32>, Vec<u32>)> = Vec::new();
    for &t in bad {
        let mut patches = vec![t];
        let mut tris = reach(t);
        let mut i = 0;
        while i < clusters.len() {
            if clusters[i].1.iter().any(|x| tris.contains(x)) {
                let (p, r) = clusters.swap_remove(i);
                patches.extend(p);
                tris.extend(r);
                i = 0;
            } else {
                i += 1;
            }
        }
        patches.sort_unstable();
        tris.sort_unstable();
        tris.dedup();
        clusters.push((patches, tris));
    }
    clusters.sort();
    let mut changed = Vec::new();
    for (patches, tris) in &clusters {
        // The cluster's interior edges (half-edges lower first, vertices lower first).
        let mut edges: Vec<([u32; 2], [u32; 2])> = Vec::new();
        for &t in patches {
            for k in 0..3 {
                let h = 3 * t + k as u32;
                let o = twins[h as usize];
                if o == u32::MAX {
                    continue;
                }
                let tri = work.triangles[t as usize];
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                let e = ([h.min(o), h.max(o)], [a.min(b), a.max(b)]);
                if !edges.contains(&e) {
                    edges.push(e);
                }
            }
        }
        // Each patch's weakest corner ([`corner_values`]): its arms are where the starts
        // differ.
        let weak: Vec<u32> = patches
            .iter()
            .map(|&t| {
                let c = corner_values(work, t as usize);
                let k = (0..3).fold(0, |m, k| if c[k] < c[m] { k } else { m });
                work.triangles[t as usize][k]
            })
            .collect();
        let n = 2 * edges.len();
        let mut starts = vec![vec![0.0; n]];
        for s in ARM_STARTS {
            let mut x = vec![0.0; n];
            for (i, (_, v)) in edges.iter().enumerate() {
                for j in 0..2 {
                    if weak.contains(&v[j]) {
                        x[2 * i + j] = s.ln();
                    }
                }
            }
            starts.push(x);
        }
        let (lo, hi) = (ARM_RANGE[0].ln(), ARM_RANGE[1].ln());
        let measure = |work: &mut Mesh, x: &[f64], level: u32| -> Result<f64> {
            set_arms(work, &edges, x);
            arm_measure(work, ctx, tris, level)
        };
        let accepted = |work: &mut Mesh, x: &[f64]| -> Result<bool> {
            set_arms(work, &edges, x);
            all_certified(work, ctx, tris)
        };
        let mut found = None;
        for mut x in starts {
            let mut fx = measure(work, &x, ARM_LEVELS[0])?;
            let mut step = 0.5;
            while step > ARM_STEP_END {
                let mut improved = false;
                for i in 0..n {
                    for d in [-1.0, 1.0] {
                        let mut y = x.clone();
                        y[i] = (y[i] + d * step).clamp(lo, hi);
                        let fy = measure(work, &y, ARM_LEVELS[0])?;
                        if fy > fx {
                            (x, fx) = (y, fy);
                            improved = true;
                        }
                    }
                }
                if !improved {
                    step *= 0.5;
                }
            }
            if measure(work, &x, ARM_LEVELS[1])? > 0.0 && accepted(work, &x)? {
                found = Some(x);
                break;
            }
        }
        let Some(mut best) = found else {
            work.attributes.arm_scales = None;
            return Ok(None);
        };
        for f in [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9] {
            let y: Vec<f64> = best.iter().map(|v| v * f).collect();
            if accepted(work, &y)? {
                best = y;
                break;
            }
        }
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_by(|&a, &b| best[b].abs().total_cmp(&best[a].abs()).then(a.cmp(&b)));
        for i in order {
            if best[i] == 0.0 {
                continue;
            }
            let mut y = best.clone();
            y[i] = 0.0;
            if accepted(work, &y)? {
                best = y;
            }
        }
        set_arms(work, &edges, &best);
        changed.extend(tris.iter().copied());
    }
    if arm_summary(work).0 == 0 {
        work.attributes.arm_scales = None;
    }
    changed.sort_unstable();
    changed.dedup();
    Ok(Some(changed))
}

/// What [`split_fin`] set: the groups, and the corners whose normal must stay
/// perpendicular to a fin edge's direction (corner, direction).
type FinSplit = (Vec<u32>, Vec<(u32, DVec3)>);

/// The pairs of triangles on the same three vertices in both orders (a doubled triangle:
/// a fin of zero thickness, its two sides glued along their edges), sorted.
fn doubled_triangles(mesh: &Mesh) -> Vec<[u32; 2]> {
    let mut by: HashMap<[u32; 3], Vec<u32>> = HashMap::new();
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let mut key = *tri;
        key.sort_unstable();
        by.entry(key).or_default().push(t as u32);
    }
    let mut out: Vec<[u32; 2]> = by
        .values()
        .filter(|ts| ts.len() == 2)
        .filter(|ts| {
            let (a, b) = (
                mesh.triangles[ts[0] as usize],
                mesh.triangles[ts[1] as usize],
            );
            (0..3).any(|r| [a[r], a[(r + 2) % 3], a[(r + 1) % 3]] == b)
        })
        .map(|ts| [ts[0].min(ts[1]), ts[0].max(ts[1])])
        .collect();
    out.sort_unstable();
    out
}

/// Splits a doubled triangle (`pair`, [`doubled_triangles`]) off the surface: its two
/// sides face opposite ways, so no normal shared at a vertex faces both (the crease is
/// forced there, [`corner_bound`]). Each of its six corners gets its own group with its
/// triangle's face normal: the fin's edges get straight curves (between its two sides the
/// crease direction of opposite normals is the edge itself) and both sides are flat
/// patches. An edge of the fin that other triangles use too (the edge along which the fin
/// stands on the surface: more than two uses, no crease curve) must then be straight in
/// their patches as well, so the groups of those uses at both of its ends get normals
/// perpendicular to it (the nearest: the normal projected; two such edges at one group,
/// their cross product): every face normal of a triangle on the edge is perpendicular to
/// it, so all uses build the same straight segment, watertight. Only the fin's own edges
/// (two uses: its two sides) become creases; every edge of the surface keeps its normals
/// shared. Kept where the certificate counts fewer uncertified patches around the fin's
/// vertices; returns the groups set (left alone from then on) and, for each corner of the
/// other uses at a fin edge's ends, that edge's direction (its normal must stay
/// perpendicular to it).
fn split_fin(
    work: &mut Mesh,
    groups: &mut Groups,
    pair: [u32; 2],
    faces: &[DVec3],
    (scheme, opts, twins): (Scheme, &SchemeOptions, &[u32]),
    verdicts: &mut [Verdict],
    changed: &mut HashSet<u32>,
) -> Result<Option<FinSplit>> {
    if pair
        .iter()
        .any(|&t| faces[t as usize].length_squared() < 0.25)
    {
        return Ok(None);
    }
    let tri = work.triangles[pair[0] as usize];
    let ring = groups.ring(tri);
    let old: Vec<[DVec3; 3]> = ring
        .iter()
        .map(|&t| work.corner_normals[t as usize])
        .collect();
    let mut splits: Vec<(u32, u32)> = Vec::new();
    let mut set = Vec::new();
    let mut pins = Vec::new();
    let mut sink = Vec::new();
    for &t in &pair {
        for k in 0..3 {
            let c = 3 * t + k;
            let g = groups.of_corner[c as usize];
            let h = if groups.corners(g).len() > 1 {
                let h = groups.split(g, &[c]);
                splits.push((g, h));
                h
            } else {
                g
            };
            set_group(work, groups, h, faces[t as usize], &mut sink);
            set.push(h);
        }
    }
    // The other uses' groups at the ends of each fin edge, with the edge's direction.
    let mut dirs: Vec<(u32, Vec<DVec3>)> = Vec::new();
    for k in 0..3 {
        let (a, b) = (tri[k], tri[(k + 1) % 3]);
        let d = (work.positions[b as usize] - work.positions[a as usize]).normalize_or_zero();
        for (v, w) in [(a, b), (b, a)] {
            for &g in &groups.at_vertex[v as usize] {
                // The corners of the group in triangles on the edge (not the fin's).
                let uses: Vec<u32> = groups
                    .corners(g)
                    .iter()
                    .copied()
                    .filter(|&c| {
                        let s = c / 3;
                        !pair.contains(&s) && work.triangles[s as usize].contains(&w)
                    })
                    .collect();
                if !uses.is_empty() {
                    // The fin's own corners there too (flat: perpendicular to the edge).
                    let own = pair.iter().map(|&t| {
                        let k = work.triangles[t as usize].iter().position(|&x| x == v);
                        3 * t + k.unwrap_or(0) as u32
                    });
                    pins.extend(uses.iter().copied().chain(own).map(|c| (c, d)));
                    match dirs.iter_mut().find(|(x, _)| *x == g) {
                        Some((_, l)) => l.push(d),
                        None => dirs.push((g, vec![d])),
                    }
                }
            }
        }
    }
    let mut ok = true;
    for (g, ds) in &dirs {
        let cur = groups.normal(work, *g);
        let n = match ds.as_slice() {
            [d] => (cur - cur.dot(*d) * *d).try_normalize(),
            [d, e, ..] => d
                .cross(*e)
                .try_normalize()
                .map(|x| if x.dot(cur) < 0.0 { -x } else { x })
                .filter(|x| ds.iter().all(|f| f.dot(*x).abs() <= 1e-12)),
            [] => Some(cur),
        };
        let Some(n) = n else {
            ok = false;
            break;
        };
        set_group(work, groups, *g, n, &mut sink);
        set.push(*g);
    }
    let was = ring
        .iter()
        .filter(|&&r| verdicts[r as usize] != Verdict::Valid)
        .count();
    let v = if ok {
        verdicts_of(work, scheme, opts, &ring, twins)?
    } else {
        Vec::new()
    };
    if !ok || v.iter().filter(|x| **x != Verdict::Valid).count() >= was {
        for (&t, n) in ring.iter().zip(old) {
            work.corner_normals[t as usize] = n;
        }
        for &(g, h) in splits.iter().rev() {
            groups.unsplit(g, h);
        }
        return Ok(None);
    }
    record(verdicts, changed, &ring, &v);
    Ok(Some((set, pins)))
}

/// Isolates an uncertified G1 patch whose triangle turns away from every other triangle at
/// each of its three corners (negative cosine between their face normals: a fold of the
/// input itself, as a sliver lying backwards in a scanned surface). No normal shared with
/// the triangles around can serve it, and with normals of its own alone its two crease
/// curves at a corner would run along one crease line. So each of its vertices' fans is cut
/// in three: the triangle, with its own face normal, and two runs of the others, the one
/// across each of its edges there with the central normal of its faces turned
/// perpendicular to that edge. Then the crease direction n_f × N along each of its edges is
/// the edge itself at both ends, its three boundary curves are straight and its patch is
/// flat. The cut between the two runs is placed, at each vertex, where the patches around
/// it (the triangle's excepted) have the fewest uncertified and then the smallest
/// [`badness`]. Kept where the certificate counts fewer uncertified patches around the
/// triangle's vertices; its groups are then left alone by the search (only the last pass
/// moves them back towards their input, where the certificate allows). Returns
/// its groups, where it was kept. With `any`, a patch is isolated whatever the orientation
/// of the triangles around it (the last resort for what the search leaves uncertified).
#[allow(clippy::too_many_arguments)]
fn isolate_sliver(
    work: &mut Mesh,
    groups: &mut Groups,
    t: u32,
    faces: &[DVec3],
    (scheme, opts, twins): (Scheme, &SchemeOptions, &[u32]),
    verdicts: &mut [Verdict],
    changed: &mut HashSet<u32>,
    grid: &Grid,
    any: bool,
) -> Result<Option<[u32; 9]>> {
    let tri_t = work.triangles[t as usize];
    let nf = faces[t as usize];
    let mut plans = Vec::new();
    for k in 0..3 {
        let c = 3 * t + k as u32;
        let g = groups.of_corner[c as usize];
        let cs = groups.corners(g).to_vec();
        if groups.frozen.contains(&g)
            || cs.len() < 3
            || (!any
                && cs
                    .iter()
                    .any(|&x| x != c && faces[x as usize / 3].dot(nf) >= 0.0))
        {
            return Ok(None);
        }
        let Some((order, true)) = fan_order(work, &cs) else {
            return Ok(None);
        };
        let Some(at) = order.iter().position(|&x| x == c) else {
            return Ok(None);
        };
        let mut order = order;
        order.rotate_left(at);
        let v = tri_t[k];
        let edge =
            |w: u32| (work.positions[w as usize] - work.positions[v as usize]).normalize_or_zero();
        // order[1] is across the edge to the vertex before the corner, the last one across
        // the edge to the vertex after it.
        plans.push((g, order, edge(tri_t[(k + 2) % 3]), edge(tri_t[(k + 1) % 3])));
    }
    let mut ring: Vec<u32> = plans
        .iter()
        .flat_map(|(g, ..)| groups.triangles_around(*g))
        .collect();
    ring.sort_unstable();
    ring.dedup();
    let was = ring
        .iter()
        .filter(|&&r| verdicts[r as usize] != Verdict::Valid)
        .count();
    let perp = |n: DVec3, e: DVec3| (n - n.dot(e) * e).try_normalize().unwrap_or(n);
    let central_of = |corners: &[u32], fallback: DVec3| {
        let f: Vec<DVec3> = corners.iter().map(|&c| faces[c as usize / 3]).collect();
        central(&f, fallback)
    };
    let mut made = Vec::new();
    let mut sink = Vec::new();
    for (g, order, e1, e2) in &plans {
        let g = *g;
        let old = groups.normal(work, g);
        let ht = groups.split(g, &order[..1]);
        set_group(work, groups, ht, nf, &mut sink);
        let around: Vec<u32> = {
            let mut r: Vec<u32> = groups.triangles_around(g).filter(|&x| x != t).collect();
            r.sort_unstable();
            r.dedup();
            r
        };
        let n = order.len();
        let choice = fewest_uncertified(n.saturating_sub(2), grid, |i| {
            let j = i + 1;
            let hb = groups.split(g, &order[j + 1..]);
            let na = perp(central_of(&order[1..=j], old), *e1);
            let nb = perp(central_of(&order[j + 1..], old), *e2);
            set_group(work, groups, g, na, &mut sink);
            set_group(work, groups, hb, nb, &mut sink);
            let table = ring_table(work, scheme, opts, &around, twins);
            groups.unsplit(g, hb);
            table
        })?;
        let Some(j) = choice.map(|i| i + 1) else {
            groups.unsplit(g, ht);
            set_group(work, groups, g, old, &mut sink);
            break;
        };
        let hb = groups.split(g, &order[j + 1..]);
        let na = perp(central_of(&order[1..=j], old), *e1);
        let nb = perp(central_of(&order[j + 1..], old), *e2);
        set_group(work, groups, g, na, &mut sink);
        set_group(work, groups, hb, nb, &mut sink);
        made.push((g, ht, hb, old));
    }
    // Kept only with fewer uncertified patches than before (`was` ≥ 1: `t` is one).
    let v = if made.len() == 3 {
        verdicts_upto(work, (scheme, opts, twins), &ring, was.saturating_sub(1))?
    } else {
        None
    };
    if let Some(v) = v {
        record(verdicts, changed, &ring, &v);
        let mut out = [0u32; 9];
        for (i, &(g, ht, hb, _)) in made.iter().enumerate() {
            groups.frozen.extend([g, ht, hb]);
            out[3 * i..3 * i + 3].copy_from_slice(&[g, ht, hb]);
        }
        return Ok(Some(out));
    }
    for &(g, ht, hb, old) in made.iter().rev() {
        groups.unsplit(g, hb);
        groups.unsplit(g, ht);
        set_group(work, groups, g, old, &mut sink);
    }
    Ok(None)
}

/// Whether corner `c` is flat: alone in its group, with its triangle's face normal (its two
/// edges at the vertex then leave it along the edges, whatever the crease curve's other
/// side, as long as that side's normal is perpendicular to the edge too or flat).
fn flat_corner(work: &Mesh, groups: &Groups, faces: &[DVec3], c: u32) -> bool {
    let g = groups.of_corner[c as usize];
    groups.corners(g).len() == 1
        && parallel(
            work.corner_normals[c as usize / 3][c as usize % 3],
            faces[c as usize / 3],
        )
}

/// Whether unit vectors `a` and `b` are the same direction within 1e-9 radians: two
/// triangles of one planar quad, whose face normals differ by rounding only.
fn parallel(a: DVec3, b: DVec3) -> bool {
    a.dot(b) > 0.0 && a.cross(b).length() <= 1e-9
}

/// The last resort of G1 (step 8 of the module documentation): every patch still
/// uncertified is flattened, one at a time: its three corners get its face normal, each
/// in a group of its own, and at each of its vertices the runs of the fan on either side
/// get normals perpendicular to the edges they share with it ([`flatten_corner`]), so its
/// three boundary curves are straight and its patch is flat, which the certificate
/// certifies. A flattened triangle stays flat when a neighbour is flattened later: the
/// runs are rebuilt with the constraints of every flat corner around them. The patches
/// around that the flattening breaks are flattened in turn; each step flattens one more
/// triangle for good, so the cascade ends, at the latest with every triangle flat.
/// Returns the number of triangles flattened.
#[allow(clippy::too_many_arguments)]
fn flatten_cascade(
    work: &mut Mesh,
    groups: &mut Groups,
    faces: &[DVec3],
    ctx: (Scheme, &SchemeOptions, &[u32]),
    verdicts: &mut [Verdict],
    changed: &mut HashSet<u32>,
    touched: &mut HashSet<u32>,
    grid: &Grid,
) -> Result<usize> {
    let (scheme, opts, twins) = ctx;
    let mut flat: HashSet<u32> = HashSet::new();
    let mut count = 0;
    while let Some(t) = (0..verdicts.len() as u32)
        .find(|&t| verdicts[t as usize] != Verdict::Valid && !flat.contains(&t))
    {
        flat.insert(t);
        count += 1;
        let tri = work.triangles[t as usize];
        for k in 0..3 {
            flatten_corner(work, groups, faces, ctx, 3 * t + k as u32, grid)?;
        }
        let ring = groups.ring(tri);
        let v = verdicts_of(work, scheme, opts, &ring, twins)?;
        record(verdicts, changed, &ring, &v);
        for &v in &tri {
            touched.extend(groups.at_vertex[v as usize].iter().copied());
        }
    }
    Ok(count)
}

/// Makes corner `c` flat ([`flat_corner`]) and gives the runs of its vertex's fan next to
/// it normals perpendicular to the edges they share with flat corners: a run between two
/// flat corners is cut in two, each part perpendicular to its own edge (a run of one
/// triangle gets its face normal), a run with one flat end has a part next to it
/// perpendicular to that edge and keeps its normal on the rest. Each part's normal is the
/// central normal of its faces turned perpendicular to the edge; where the run is cut is
/// chosen by the fewest uncertified patches around the vertex, then the smallest
/// [`badness`]. At a vertex whose corners form no single fan, every corner there is made
/// flat.
fn flatten_corner(
    work: &mut Mesh,
    groups: &mut Groups,
    faces: &[DVec3],
    (scheme, opts, twins): (Scheme, &SchemeOptions, &[u32]),
    c: u32,
    grid: &Grid,
) -> Result<()> {
    let v = work.triangles[c as usize / 3][c as usize % 3];
    let mut sink = Vec::new();
    // A flat corner gets its face normal, or bitwise the normal of a flat corner at the
    // vertex with the same face normal to 1e-9 radians (the other half of a planar quad):
    // the crease direction between two such normals would be their rounding error, their
    // common normal keeps the edge between them smooth, and straight.
    let make_flat = |work: &mut Mesh, groups: &mut Groups, x: u32, sink: &mut Vec<u32>| {
        let f = faces[x as usize / 3];
        let twin = groups.at_vertex[v as usize]
            .iter()
            .map(|&h| groups.corners(h)[0])
            .filter(|&c| c != x && flat_corner(work, groups, faces, c))
            .map(|c| work.corner_normals[c as usize / 3][c as usize % 3])
            .find(|&n| parallel(n, f));
        let g = groups.of_corner[x as usize];
        let g = if groups.corners(g).len() > 1 {
            groups.split(g, &[x])
        } else {
            g
        };
        set_group(work, groups, g, twin.unwrap_or(f), sink);
    };
    let all: Vec<u32> = groups.at_vertex[v as usize]
        .iter()
        .flat_map(|&g| groups.corners(g).iter().copied())
        .collect();
    // At a vertex of a split fin every corner is made flat: the face normal of a triangle
    // on the fin's edge is perpendicular to it, so that edge stays straight in every use.
    let fin = groups.fins.contains(&v);
    let Some((order, closed)) = fan_order(work, &all).filter(|_| !fin) else {
        for x in all {
            make_flat(work, groups, x, &mut sink);
        }
        return Ok(());
    };
    make_flat(work, groups, c, &mut sink);
    let n = order.len();
    let Some(at) = order.iter().position(|&x| x == c) else {
        return Ok(());
    };
    let mut ring: Vec<u32> = all.iter().map(|&x| x / 3).collect();
    ring.sort_unstable();
    ring.dedup();
    // Fan positions as offsets from `at` in a closed fan; plain indices in an open one.
    let step = |i: usize, d: isize| -> Option<usize> {
        if closed {
            Some((i as isize + d).rem_euclid(n as isize) as usize)
        } else {
            let j = i as isize + d;
            (0..n as isize).contains(&j).then_some(j as usize)
        }
    };
    // The edge from `v` shared by fan positions i and i + 1.
    let edge_dir = |work: &Mesh, i: usize| {
        let x = order[i] as usize;
        let w = work.triangles[x / 3][(x % 3 + 2) % 3];
        (work.positions[w as usize] - work.positions[v as usize]).normalize_or_zero()
    };
    for d in [-1isize, 1] {
        let Some(start) = step(at, d) else {
            continue;
        };
        let s0 = order[start];
        if flat_corner(work, groups, faces, s0) {
            continue;
        }
        let g = groups.of_corner[s0 as usize];
        // The run: from `start` away from `c` while in the same group and not flat.
        let mut run = vec![start];
        let mut i = start;
        while let Some(j) = step(i, d) {
            if j == at
                || groups.of_corner[order[j] as usize] != g
                || flat_corner(work, groups, faces, order[j])
            {
                break;
            }
            run.push(j);
            i = j;
        }
        let far = step(i, d).filter(|&j| flat_corner(work, groups, faces, order[j]));
        // In fan order: `run` from the lower end; the edge at each flat end.
        let (near_edge, far_edge) = if d > 0 {
            (
                edge_dir(work, (start + n - 1) % n),
                far.map(|_| edge_dir(work, i)),
            )
        } else {
            (edge_dir(work, start), far.map(|j| edge_dir(work, j)))
        };
        let corners: Vec<u32> = run.iter().map(|&j| order[j]).collect();
        // `corners` runs from the flat corner `c` outwards.
        let h = if groups.corners(g).len() > corners.len() {
            groups.split(g, &corners)
        } else {
            g
        };
        let old = groups.normal(work, h);
        let m = corners.len();
        if far_edge.is_some() && m == 1 {
            make_flat(work, groups, corners[0], &mut sink);
            continue;
        }
        let perp = |n: DVec3, e: DVec3| (n - n.dot(e) * e).try_normalize().unwrap_or(n);
        let central_of = |cs: &[u32]| {
            let f: Vec<DVec3> = cs.iter().map(|&x| faces[x as usize / 3]).collect();
            central(&f, old)
        };
        // Option j: the first j corners (from `c`) perpendicular to the near edge, the rest
        // perpendicular to the far edge, or keeping their normal.
        let js: Vec<usize> = match far_edge {
            Some(_) => (1..m).collect(),
            None => (1..=m).collect(),
        };
        let apply = |work: &mut Mesh, groups: &mut Groups, j: usize, sink: &mut Vec<u32>| {
            let rest = (j < m).then(|| groups.split(h, &corners[j..]));
            set_group(
                work,
                groups,
                h,
                perp(central_of(&corners[..j]), near_edge),
                sink,
            );
            if let (Some(r), Some(e)) = (rest, far_edge) {
                set_group(work, groups, r, perp(central_of(&corners[j..]), e), sink);
            }
            rest
        };
        let choice = fewest_uncertified(js.len(), grid, |i| {
            let rest = apply(work, groups, js[i], &mut sink);
            let table = ring_table(work, scheme, opts, &ring, twins);
            if let Some(r) = rest {
                groups.unsplit(h, r);
            }
            set_group(work, groups, h, old, &mut sink);
            table
        })?;
        if let Some(i) = choice {
            apply(work, groups, js[i], &mut sink);
        }
    }
    Ok(())
}

/// Of `n` trials, the one whose patches (`table_of(i)`, the trial undone again) have the
/// fewest uncertified, then the smallest [`badness`], then the smallest index. Every
/// trial's badness is measured first; they are then certified in order of (badness,
/// index), each only as far as it could still win (one uncertified patch fewer than the
/// best so far).
fn fewest_uncertified(
    n: usize,
    grid: &Grid,
    mut table_of: impl FnMut(usize) -> Result<RingTable>,
) -> Result<Option<usize>> {
    let mut b = Vec::with_capacity(n);
    for i in 0..n {
        b.push(badness(&*table_of(i)?, grid));
    }
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&x, &y| b[x].total_cmp(&b[y]).then(x.cmp(&y)));
    let mut best: Option<(usize, usize)> = None;
    for i in order {
        let limit = match best {
            Some((0, _)) => break,
            Some((bad, _)) => bad - 1,
            None => usize::MAX,
        };
        if let Some(bad) = uncertified_upto(&table_of(i)?, limit) {
            best = Some((bad, i));
        }
    }
    Ok(best.map(|(_, i)| i))
}

/// A cut of one vertex's normal group into two: the groups, the triangles around the
/// vertex and their new verdicts.
struct Cut {
    groups: [u32; 2],
    ring: Vec<u32>,
    verdicts: Vec<Verdict>,
}

/// The corners of group `g` in fan order around its vertex (counter-clockwise: each
/// triangle's edge to the vertex before it is the next one's edge to the vertex after),
/// and whether the fan closes; `None` where the corners form no single fan (non-manifold,
/// or several sheets meeting at the vertex).
fn fan_order(mesh: &Mesh, corners: &[u32]) -> Option<(Vec<u32>, bool)> {
    let after = |c: u32| mesh.triangles[c as usize / 3][(c as usize % 3 + 1) % 3];
    let before = |c: u32| mesh.triangles[c as usize / 3][(c as usize % 3 + 2) % 3];
    let mut by_after: HashMap<u32, u32> = HashMap::new();
    for &c in corners {
        if by_after.insert(after(c), c).is_some() {
            return None;
        }
    }
    let succ = |c: u32| by_after.get(&before(c)).copied();
    let has_pred: HashSet<u32> = corners.iter().filter_map(|&c| succ(c)).collect();
    let start = corners
        .iter()
        .copied()
        .find(|c| !has_pred.contains(c))
        .unwrap_or(corners[0]);
    let mut order = vec![start];
    let mut closed = false;
    let mut c = start;
    while let Some(n) = succ(c) {
        if n == start {
            closed = true;
            break;
        }
        if order.len() >= corners.len() {
            return None;
        }
        order.push(n);
        c = n;
    }
    (order.len() == corners.len()).then_some((order, closed))
}

/// The best cut of the normal group of a corner of triangle `t`, applied to `work` and
/// `groups`, or `None` (nothing changed) where no cut lowers the number of uncertified
/// patches around the vertex. A cut splits the group's fan of triangles into two runs of
/// neighbours (along two of its edges where the fan closes around the vertex, along one
/// where the vertex is on a boundary); each run gets the central normal of its faces, so
/// both fit their own triangles. A cut helps when it leaves fewer uncertified patches around
/// its vertex, or as many with a [`badness`] at least 10 % smaller; among all helping cuts
/// of the three corners' groups, the one with the fewest uncertified patches wins (then the
/// smallest badness).
#[allow(clippy::too_many_arguments)]
fn best_cut(
    work: &mut Mesh,
    groups: &mut Groups,
    t: usize,
    faces: &[DVec3],
    (scheme, opts, twins): (Scheme, &SchemeOptions, &[u32]),
    verdicts: &[Verdict],
    grid: &Grid,
) -> Result<Option<Cut>> {
    let nf = faces[t];
    // Cuts are scored by the fewest uncertified patches around their vertex, then the
    // smallest badness, then the order they are listed in. All are listed with their
    // badness first; certified in order of (badness, listing), a cut only needs its count
    // up to one less than the best's so far (as many, it loses on badness or order), and
    // up to the ring's count before (one less where its badness is not 10 % smaller).
    struct Listed {
        b: f64,
        group: u32,
        run: Vec<u32>,
        /// Index of the group's ring in `rings`.
        ring: usize,
    }
    let mut listed: Vec<Listed> = Vec::new();
    // (ring, uncertified patches on it now, its badness now)
    let mut rings: Vec<(Vec<u32>, usize, f64)> = Vec::new();
    let set_cut = |work: &mut Mesh, groups: &mut Groups, g: u32, run: &[u32]| {
        let h = groups.split(g, run);
        let mut sink = Vec::new();
        for x in [g, h] {
            let f: Vec<DVec3> = groups
                .corners(x)
                .iter()
                .map(|&c| faces[c as usize / 3])
                .collect();
            set_group(work, groups, x, central(&f, nf), &mut sink);
        }
        h
    };
    for k in 0..3 {
        let g = groups.of_corner[3 * t + k];
        let cs = groups.corners(g).to_vec();
        if cs.len() < 2 || groups.frozen.contains(&g) {
            continue;
        }
        let Some((order, closed)) = fan_order(work, &cs) else {
            continue;
        };
        // A closed fan of n corners has n(n − 1)/2 cuts, each certifying the whole ring:
        // at a high-valence vertex (a UV sphere's pole) only the open cuts are tried.
        let closed = closed && order.len() <= MAX_CLOSED_CUT_FAN;
        let mut ring: Vec<u32> = groups.triangles_around(g).collect();
        ring.sort_unstable();
        ring.dedup();
        let was = ring
            .iter()
            .filter(|&&r| verdicts[r as usize] != Verdict::Valid)
            .count();
        let b0 = badness(&*ring_table(work, scheme, opts, &ring, twins)?, grid);
        let n = order.len();
        // The second run of each cut (the first is the rest of the fan): between fan
        // positions i and i + 1 and between j and j + 1 where the fan closes, after i
        // where it is open.
        let mut runs: Vec<Vec<u32>> = Vec::new();
        if closed {
            for i in 0..n {
                for j in i + 1..n {
                    runs.push(order[i + 1..=j].to_vec());
                }
            }
        } else {
            for i in 0..n - 1 {
                runs.push(order[i + 1..].to_vec());
            }
        }
        let old = groups.normal(work, g);
        for run in runs {
            let h = set_cut(work, groups, g, &run);
            let b = badness(&*ring_table(work, scheme, opts, &ring, twins)?, grid);
            groups.unsplit(g, h);
            set_group(work, groups, g, old, &mut Vec::new());
            listed.push(Listed {
                b,
                group: g,
                run,
                ring: rings.len(),
            });
        }
        rings.push((ring, was, b0));
    }
    let mut by_badness: Vec<usize> = (0..listed.len()).collect();
    by_badness.sort_by(|&x, &y| listed[x].b.total_cmp(&listed[y].b).then(x.cmp(&y)));
    // (uncertified, index in `listed`)
    let mut best: Option<(usize, usize)> = None;
    for i in by_badness {
        let c = &listed[i];
        let (ring, was, b0) = &rings[c.ring];
        // Fewer uncertified patches, or as many and a clearly smaller shortfall (a patch
        // with two bad corners needs a cut at each: the first alone certifies nothing).
        let mut limit = if c.b < 0.9 * b0 {
            Some(*was)
        } else {
            was.checked_sub(1)
        };
        if let Some((bad, _)) = best {
            limit = limit.min(bad.checked_sub(1));
        }
        let Some(limit) = limit else {
            continue;
        };
        let old = groups.normal(work, c.group);
        let h = set_cut(work, groups, c.group, &c.run);
        let counted = uncertified_upto(&ring_table(work, scheme, opts, ring, twins)?, limit);
        groups.unsplit(c.group, h);
        set_group(work, groups, c.group, old, &mut Vec::new());
        if let Some(bad) = counted {
            best = Some((bad, i));
        }
    }
    let Some((_, i)) = best else {
        return Ok(None);
    };
    let (g, run) = (listed[i].group, listed[i].run.clone());
    let h = set_cut(work, groups, g, &run);
    let mut ring: Vec<u32> = groups.triangles_around(g).collect();
    ring.sort_unstable();
    ring.dedup();
    let verdicts = verdicts_of(work, scheme, opts, &ring, twins)?;
    Ok(Some(Cut {
        groups: [g, h],
        ring,
        verdicts,
    }))
}

/// Sets the normal of every corner of group `g` to `n`, listing the triangles whose patch
/// may change ([`Groups::triangles_around`]).
/// `f` on `work` with the group normals of `moves` set, the previous normals put back
/// after it (in reverse order, so a group moved twice gets its first normal back).
fn with_moves<T>(
    work: &mut Mesh,
    groups: &Groups,
    moves: &[(u32, DVec3)],
    f: impl FnOnce(&Mesh) -> T,
) -> T {
    let old: Vec<(u32, DVec3)> = moves
        .iter()
        .map(|&(g, _)| (g, groups.normal(work, g)))
        .collect();
    let mut sink = Vec::new();
    for &(g, n) in moves {
        set_group(work, groups, g, n, &mut sink);
    }
    let out = f(work);
    for &(g, n) in old.iter().rev() {
        set_group(work, groups, g, n, &mut sink);
    }
    out
}

fn set_group(work: &mut Mesh, groups: &Groups, g: u32, n: DVec3, tris: &mut Vec<u32>) {
    for &c in groups.corners(g) {
        work.corner_normals[c as usize / 3][c as usize % 3] = n;
    }
    tris.extend(groups.triangles_around(g));
}

/// Interior edges (two uses) of `work` whose uses disagree on an end's normal, and did not
/// in `mesh` (same triangles).
fn new_creases(mesh: &Mesh, work: &Mesh) -> usize {
    let crease = |m: &Mesh, e: &crate::mesh::adjacency::EdgeRef<'_>| {
        let [u0, u1] = [e.use_at(0), e.use_at(1)];
        e.v.iter().any(|&v| {
            normal_key(crate::mesh::creases::use_normal(m, u0, v))
                != normal_key(crate::mesh::creases::use_normal(m, u1, v))
        })
    };
    EdgeIndex::new(&work.triangles)
        .edges()
        .filter(|e| e.is_interior() && crease(work, e) && !crease(mesh, e))
        .count()
}

/// Angle between unit vectors in degrees (atan2 of |a × b| and a · b: accurate at small
/// angles too).
fn angle_deg(a: DVec3, b: DVec3) -> f64 {
    a.cross(b).length().atan2(a.dot(b)).to_degrees()
}

/// For each half-edge 3t + k of an edge used by exactly two triangles, the other use's
/// half-edge; `u32::MAX` otherwise.
fn twins(mesh: &Mesh) -> Vec<u32> {
    let index = EdgeIndex::new(&mesh.triangles);
    let mut tw = vec![u32::MAX; 3 * mesh.triangles.len()];
    for e in index.edges().filter(|e| e.is_interior()) {
        tw[e.half_edges[0] as usize] = e.half_edges[1];
        tw[e.half_edges[1] as usize] = e.half_edges[0];
    }
    tw
}

/// The patches of `tris` on `work`. G1 (`twins` from [`twins`]) builds them here, with
/// the crease curves of their own edges only ([`super::g1::edge_curve`], as
/// [`super::g1::prepare`] builds them for the whole mesh: bitwise the same patches);
/// other schemes are prepared for the whole mesh.
fn ring_table(
    work: &Mesh,
    scheme: Scheme,
    opts: &SchemeOptions,
    tris: &[u32],
    twins: &[u32],
) -> Result<RingTable> {
    let normals = tris
        .iter()
        .map(|&t| work.corner_normals[t as usize])
        .collect();
    Ok(RingTable {
        table: ring_patches(work, scheme, opts, tris, twins)?,
        normals,
    })
}

/// A table of some triangles' patches ([`ring_table`]) with their corner normals (for
/// [`judge`]).
struct RingTable {
    table: PatchTable,
    normals: Vec<[DVec3; 3]>,
}

impl std::ops::Deref for RingTable {
    type Target = PatchTable;
    fn deref(&self) -> &PatchTable {
        &self.table
    }
}

/// The patches of [`ring_table`].
fn ring_patches(
    work: &Mesh,
    scheme: Scheme,
    opts: &SchemeOptions,
    tris: &[u32],
    twins: &[u32],
) -> Result<PatchTable> {
    if scheme != Scheme::G1 {
        return PatchBuilder::new(work, scheme, opts)?.table_of(tris, 0);
    }
    let mut points = Vec::with_capacity(tris.len() * 18);
    let mut flat_normals = Vec::with_capacity(tris.len());
    let mut fallbacks = 0;
    for &t in tris {
        let tri = work.triangles[t as usize];
        let q = tri.map(|v| work.positions[v as usize]);
        let curves = std::array::from_fn(|k| {
            let h = 3 * t + k as u32;
            let o = twins[h as usize];
            if o == u32::MAX {
                return None;
            }
            let (a, b) = (tri[k], tri[(k + 1) % 3]);
            let v = [a.min(b), a.max(b)];
            let uses = [h.min(o), h.max(o)].map(EdgeUse::from_half_edge);
            let c = super::g1::shared_curve(work, v, uses, &mut fallbacks)?;
            Some(if a == v[0] {
                c
            } else {
                [c[3], c[2], c[1], c[0]]
            })
        });
        points.extend_from_slice(&super::g1::patch_points_with_curves(
            q,
            work.corner_normals[t as usize],
            tri,
            curves,
            &mut fallbacks,
        ));
        flat_normals.push(crate::mesh::normals::face_normal(q));
    }
    Ok(PatchTable {
        scheme,
        kind: scheme.kind(),
        stride: scheme.kind().stride(),
        points,
        flat_normals,
        fallbacks,
    })
}

/// Stores the verdicts `v` of the patches `ring` (in the same order) and marks them changed.
fn record(verdicts: &mut [Verdict], changed: &mut HashSet<u32>, ring: &[u32], v: &[Verdict]) {
    debug_assert_eq!(ring.len(), v.len());
    for (&r, &x) in ring.iter().zip(v) {
        verdicts[r as usize] = x;
        changed.insert(r);
    }
}

/// The verdicts of the patches of `tris` on `work`.
fn verdicts_of(
    work: &Mesh,
    scheme: Scheme,
    opts: &SchemeOptions,
    tris: &[u32],
    twins: &[u32],
) -> Result<Vec<Verdict>> {
    let table = ring_table(work, scheme, opts, tris, twins)?;
    Ok((0..tris.len())
        .into_par_iter()
        .map(|i| judge(&table, i, table.normals[i]))
        .collect())
}

/// The number of uncertified patches of `table` ([`certify`]), or `None` as soon as it
/// exceeds `limit` (the rest is not certified).
///
/// A patch with J < −1e-9 |S_s| |S_t| at a point of a grid of level 8 (far beyond the
/// rounding of the evaluation: J is negative there) is counted without its certificate,
/// which cannot prove it valid; the others are certified after them.
fn uncertified_upto(table: &RingTable, limit: usize) -> Option<usize> {
    let grid = Grid::of(table.kind, SURE_LEVEL);
    // Smallest J / (|S_s| |S_t|) on the grid, and whether J is surely negative there.
    let low: Vec<(f64, bool)> = (0..table.len())
        .map(|i| {
            grid.weights
                .iter()
                .fold((f64::INFINITY, false), |(m, sure), w| {
                    // `validity::jacobian` through the grid's weights (bitwise the same).
                    let p = table.eval_weights(i, w);
                    let (j, scale, sj) = scaled_jacobian(&p, table.flat_normals[i]);
                    (m.min(sj), sure || j < -1e-9 * scale)
                })
        })
        .collect();
    let mut n = low.iter().filter(|x| x.1).count();
    if n > limit {
        return None;
    }
    // The rest, closest to folding first, a few at a time in parallel.
    let mut rest: Vec<usize> = (0..table.len()).filter(|&i| !low[i].1).collect();
    rest.sort_by(|&a, &b| low[a].0.total_cmp(&low[b].0).then(a.cmp(&b)));
    for chunk in rest.chunks(rayon::current_num_threads().max(1)) {
        n += chunk
            .par_iter()
            .filter(|&&i| judge(table, i, table.normals[i]) != Verdict::Valid)
            .count();
        if n > limit {
            return None;
        }
    }
    Some(n)
}

/// Grid level at which [`uncertified_upto`] looks for points where J is surely negative.
const SURE_LEVEL: u32 = 8;

/// The verdicts of the patches of `tris` on `work`, or `None` as soon as more than
/// `limit` of them are uncertified ([`uncertified_upto`]).
fn verdicts_upto(
    work: &Mesh,
    (scheme, opts, twins): (Scheme, &SchemeOptions, &[u32]),
    tris: &[u32],
    limit: usize,
) -> Result<Option<Vec<Verdict>>> {
    let table = ring_table(work, scheme, opts, tris, twins)?;
    if uncertified_upto(&table, limit).is_none() {
        return Ok(None);
    }
    Ok(Some(
        (0..tris.len())
            .into_par_iter()
            .map(|i| judge(&table, i, table.normals[i]))
            .collect(),
    ))
}

/// Most verdicts [`certify`] keeps before it starts afresh (each key is 57 words).
const MAX_KEPT_VERDICTS: usize = 1 << 18;

/// Verdicts by the bit patterns of a patch's control points and flat normal.
type VerdictMap = HashMap<Box<[u64]>, Verdict>;

/// Verdicts of the patches the search has certified, by the bit patterns of their control
/// points and flat normal: the search builds the same patch again and again (the patches
/// around a vertex that a trial leaves as they were), and [`check_patch`] is a function of
/// these alone.
static VERDICTS: Mutex<Option<VerdictMap>> = Mutex::new(None);

/// Smallest [`lagrange3_bound`] the search accepts: far above the rounding of this and of
/// `export-msh`'s computation of the same coefficients.
const LAGRANGE_MARGIN: f64 = 1e-6;

/// The search's verdict on patch `i` of `table`: the certificate's ([`certify`]), except
/// that a certified G1 patch whose cubic Lagrange element (the nodes `export-msh` writes
/// at order 3) may fold ([`lagrange3_bound`] at most [`LAGRANGE_MARGIN`]) counts as
/// undecided, so that the repair gives solvers elements that do not fold either.
///
/// It also counts as undecided a certified patch that is inside out: its normal at a
/// corner turned away from that corner's vertex normal ((S_s × S_t) · N ≤ 0), which the
/// certificate (along the face normal) accepts but which meets its neighbours across
/// smooth edges at cos = −1 (two copies of one triangle in both orders, glued along two
/// edges, one of them facing away from the normals of all three vertices).
///
/// These two checks come first and are cheap; a patch they refuse is not certified at all
/// (the search only tells valid from not valid, so its verdict is the same whatever the
/// certificate would say, and the patches close to folding are the ones whose certificate
/// subdivides the most).
fn judge(table: &PatchTable, i: usize, normals: [DVec3; 3]) -> Verdict {
    if inside_out(table, i, normals)
        || (table.scheme == Scheme::G1 && lagrange3_bound(table, i) <= LAGRANGE_MARGIN)
    {
        return Verdict::Undecided;
    }
    certify(table, i)
}

/// Whether the normal of patch `i` of `table` at a corner turns away from that corner's
/// normal (`normals`): (S_s × S_t) · N ≤ 0.
fn inside_out(table: &PatchTable, i: usize, normals: [DVec3; 3]) -> bool {
    (0..3).any(|k| {
        let mut b = [0.0; 3];
        b[k] = 1.0;
        let p = table.eval(i, b);
        p.ds.cross(p.dt).dot(normals[k]) <= 0.0
    })
}

/// [`check_patch`] of patch `i` of `table`, remembered in [`VERDICTS`].
fn certify(table: &PatchTable, i: usize) -> Verdict {
    let key: Box<[u64]> = table
        .patch(i)
        .iter()
        .chain(std::iter::once(&table.flat_normals[i]))
        .flat_map(|p| p.to_array().map(f64::to_bits))
        .collect();
    let kept = |m: &Mutex<Option<VerdictMap>>| {
        let m = m.lock().unwrap_or_else(|e| e.into_inner());
        m.as_ref().and_then(|m| m.get(&key).copied())
    };
    if let Some(v) = kept(&VERDICTS) {
        return v;
    }
    let v = check_patch(table, i);
    let mut m = VERDICTS.lock().unwrap_or_else(|e| e.into_inner());
    let m = m.get_or_insert_with(HashMap::new);
    if m.len() >= MAX_KEPT_VERDICTS {
        m.clear();
    }
    m.insert(key, v);
    v
}

/// Forgets what [`certify`] kept (at the end of a search).
fn forget_verdicts() {
    *VERDICTS.lock().unwrap_or_else(|e| e.into_inner()) = None;
}

/// How far the patches of `table` are from a scaled Jacobian J/(|S_s| |S_t|) of
/// [`MARGIN`] everywhere: the sum over the points of `grid` of its shortfall (0 for
/// patches well inside the valid ones). The search's measure between certificates.
fn badness(table: &PatchTable, grid: &Grid) -> f64 {
    let mut sum = 0.0;
    for i in 0..table.len() {
        let nf = table.flat_normals[i];
        for w in &grid.weights {
            let (_, _, sj) = scaled_jacobian(&table.eval_weights(i, w), nf);
            sum += (MARGIN - sj).max(0.0);
        }
    }
    sum
}

/// J = (S_s × S_t) · n_f at `p` (as `validity::jacobian`), |S_s| |S_t|, and the scaled
/// Jacobian J/(|S_s| |S_t|), −1 where S_s or S_t vanishes.
fn scaled_jacobian(p: &super::SurfacePoint, nf: DVec3) -> (f64, f64, f64) {
    let (j, scale) = (p.ds.cross(p.dt).dot(nf), p.ds.length() * p.dt.length());
    (j, scale, if scale > 0.0 { j / scale } else { -1.0 })
}

/// Scaled Jacobian of the cubic Lagrange element ([`lagrange3_bound`]) that the
/// crease-free phase's measure aims at for G1 patches: a margin above [`LAGRANGE_MARGIN`].
const LAGRANGE_AIM: f64 = 0.01;

/// The crease-free phase's addition to [`badness`] for G1: for each patch whose cubic
/// Lagrange element's bound is below [`LAGRANGE_AIM`], 10 times its shortfall (the
/// certificate's refusals there sit between the grid's points, or in the element).
fn lagrange_shortfall(table: &PatchTable) -> f64 {
    if table.scheme != Scheme::G1 {
        return 0.0;
    }
    (0..table.len())
        .map(|i| 10.0 * (LAGRANGE_AIM - lagrange3_bound(table, i)).max(0.0))
        .sum()
}

/// A barycentric grid with the basis weights of one patch kind at its points, computed
/// once ([`Grid::of`]): [`PatchTable::eval`] computes them at every call, and evaluating
/// through them ([`PatchTable::eval_weights`]) gives bitwise the same result.
struct Grid {
    weights: Vec<Weights>,
}

/// Grids made so far, by patch kind and level (a handful: the search's levels).
static GRIDS: Mutex<Vec<(PatchKind, u32, Arc<Grid>)>> = Mutex::new(Vec::new());

impl Grid {
    /// The grid of `level` segments per edge ([`grid_points`]) for patches of `kind`.
    fn of(kind: PatchKind, level: u32) -> Arc<Grid> {
        let mut list = GRIDS.lock().unwrap_or_else(|e| e.into_inner());
        if let Some((.., g)) = list.iter().find(|(k, l, _)| *k == kind && *l == level) {
            return g.clone();
        }
        let g = Arc::new(Grid {
            weights: grid_points(level)
                .into_iter()
                .map(|b| kind.weights(b))
                .collect(),
        });
        list.push((kind, level, g.clone()));
        g
    }
}

/// The barycentric points of a grid of `level` segments per edge.
fn grid_points(level: u32) -> Vec<[f64; 3]> {
    let n = level as f64;
    let mut out = Vec::new();
    for i in 0..=level {
        for j in 0..=level - i {
            let (s, t) = (i as f64 / n, j as f64 / n);
            out.push([1.0 - s - t, s, t]);
        }
    }
    out
}

/// The bound `export-msh` reports as the minimum scaled Jacobian
/// ([`super::lagrange::JacobianBound`]) of the cubic Lagrange triangle through patch `i` of
/// `table` at its nodes (the element of order 3 that `export-msh` writes): where it is
/// positive the element cannot fold.
fn lagrange3_bound(table: &PatchTable, i: usize) -> f64 {
    static BOUND: std::sync::OnceLock<super::lagrange::JacobianBound> = std::sync::OnceLock::new();
    let bound = BOUND.get_or_init(|| super::lagrange::JacobianBound::new(3));
    // The basis weights at the element's nodes, computed once (G1's kind is the only one
    // the search asks about; any other is evaluated plainly, bitwise the same).
    static NODES: std::sync::OnceLock<Vec<Weights>> = std::sync::OnceLock::new();
    let node = |&[a, b]: &[u32; 2]| {
        let (u, v) = (a as f64 / 3.0, b as f64 / 3.0);
        [1.0 - u - v, u, v]
    };
    if table.kind != PatchKind::Gregory {
        let x: Vec<DVec3> = super::lagrange::triangle_nodes(3)
            .iter()
            .map(|n| table.eval(i, node(n)).p)
            .collect();
        return bound.min_scaled(&x, table.flat_normals[i]);
    }
    let nodes = NODES.get_or_init(|| {
        super::lagrange::triangle_nodes(3)
            .iter()
            .map(|n| PatchKind::Gregory.weights(node(n)))
            .collect()
    });
    let x: Vec<DVec3> = nodes.iter().map(|w| table.eval_weights(i, w).p).collect();
    bound.min_scaled(&x, table.flat_normals[i])
}

/// Largest smallest cosine below which a set of unit face normals counts as fitting in no
/// open hemisphere ([`max_min_direction`]): far below any cosine a certified corner needs
/// (J at a corner is proportional to its square) and far above the rounding of face
/// normals (two copies of one triangle in both orders give exactly opposite normals, or
/// opposite to about 1e-16).
const NO_HEMISPHERE: f64 = 1e-12;

/// The unit vector with the largest smallest cosine to the unit vectors `f`, and that
/// cosine, exactly (to rounding): where it is positive the optimum has at most three
/// active vectors (equal smallest cosines), so it is one of the candidates enumerated
/// here: a vector of `f`, the bisector of two, or the direction at equal cosines to three
/// (M x = 1 for the matrix M of their rows). Where no open hemisphere holds `f` the
/// largest value found is at most 0. `None` for an empty `f`. Cubic in `f.len()` (fans
/// are small; the quick case of the mean direction facing them all comes first).
fn max_min_direction(f: &[DVec3]) -> Option<(DVec3, f64)> {
    let value = |n: DVec3| f.iter().map(|x| x.dot(n)).fold(f64::INFINITY, f64::min);
    let mut best: Option<(DVec3, f64)> = None;
    let mut offer = |n: DVec3| {
        if let Some(n) = n.try_normalize() {
            let v = value(n);
            if best.is_none_or(|(_, b)| v > b) {
                best = Some((n, v));
            }
        }
    };
    for (i, &a) in f.iter().enumerate() {
        offer(a);
        for (j, &b) in f.iter().enumerate().skip(i + 1) {
            offer(a + b);
            for &c in &f[j + 1..] {
                // x = M⁻¹ 1 by Cramer's rule: x · a = x · b = x · c = 1 / det-scaled.
                let (bc, ca, ab) = (b.cross(c), c.cross(a), a.cross(b));
                let det = a.dot(bc);
                if det.abs() > 1e-300 {
                    let x = (bc + ca + ab) / det;
                    offer(x);
                    offer(-x);
                }
            }
        }
    }
    best
}

/// The unit vector nearest to `n` (smallest angle) whose cosine to each of the unit
/// vectors `f` is at least `m` (0 ≤ m < 1), or `None` where none is. The feasible set is
/// an intersection of spherical caps smaller than a hemisphere, so convex, and its point
/// nearest to `n` is `n` itself, the projection of `n` on one cap's circle, or a corner
/// where two circles cross: all are enumerated here and the nearest feasible one is kept
/// (feasible to 1e-12, the rounding of the construction).
fn nearest_facing(n: DVec3, f: &[DVec3], m: f64) -> Option<DVec3> {
    let feasible = |x: DVec3| f.iter().all(|a| a.dot(x) >= m - 1e-12);
    if feasible(n) {
        return Some(n);
    }
    let s = (1.0 - m * m).max(0.0).sqrt();
    let mut best: Option<(f64, DVec3)> = None;
    let mut offer = |x: DVec3| {
        if let Some(x) = x.try_normalize() {
            if feasible(x) && best.is_none_or(|(d, _)| x.dot(n) > d) {
                best = Some((x.dot(n), x));
            }
        }
    };
    for (i, &a) in f.iter().enumerate() {
        if let Some(u) = (n - n.dot(a) * a).try_normalize() {
            offer(m * a + s * u);
        }
        for &b in &f[i + 1..] {
            let c = a.dot(b);
            let Some(d) = a.cross(b).try_normalize() else {
                continue;
            };
            // The point of span{a, b} with cosine m to both, then ± along a × b.
            let p = (m / (1.0 + c)) * (a + b);
            let h = 1.0 - p.length_squared();
            if h >= 0.0 {
                offer(p + h.sqrt() * d);
                offer(p - h.sqrt() * d);
            }
        }
    }
    best.map(|(_, x)| x)
}

/// What any repair that keeps G1 (turns no smooth edge into a crease) must change, from
/// the input's corner normals and face normals (the report's
/// [`RepairReport::normal_change_lower_bound_deg`] and
/// [`RepairReport::crease_forced_groups`]), with the groups where a crease is forced.
///
/// At a corner A of triangle f with normal N whose two edges of f are no crease edges, the
/// boundary curves leave A along the chords projected on the plane normal to N, so
/// S_s × S_t = 2 Area a b (n_f · N) N there, and along such an edge A → B the patch's
/// normal is λ(u) n(u), with n(u) the edge's continuous nonzero normal field from N_A to
/// N_B. A certified patch has J = λ (n · n_f) > 0 on the whole edge, so λ keeps one sign σ
/// and σ (n_f · N) > 0 at both of its ends; two edges of f meet at a corner, so σ is the
/// patch's. Across a smooth edge both patches' normals are their λ times the same n(u): no
/// sample with cos < 0 needs the same σ on both sides, so σ is constant on each component
/// of triangles joined by smooth edges. Hence every such corner has its angle θ between N'
/// (the repaired normal) and n_f below 90° (σ = +1) or above (σ = −1), and the normal
/// changes by at least θ − 90° or 90° − θ at that corner: the bound is the largest, over
/// components, of the smaller of the two largest. Tangent lengths scale a and b only, and
/// cannot change a sign. Returns (bound in degrees, groups with no open hemisphere).
fn corner_bound(mesh: &Mesh, faces: &[DVec3], groups: &Groups) -> (f64, Vec<bool>) {
    let nt = mesh.triangles.len();
    // Crease half-edges (an interior edge whose two uses disagree on an end's normal) and
    // the components of triangles joined by smooth interior edges (union–find).
    let mut crease = vec![false; 3 * nt];
    let mut parent: Vec<u32> = (0..nt as u32).collect();
    fn root(p: &mut [u32], mut x: u32) -> u32 {
        while p[x as usize] != x {
            p[x as usize] = p[p[x as usize] as usize];
            x = p[x as usize];
        }
        x
    }
    for e in EdgeIndex::new(&mesh.triangles).edges() {
        if !e.is_interior() {
            continue;
        }
        let [u0, u1] = [e.use_at(0), e.use_at(1)];
        let split = e.v.iter().any(|&v| {
            normal_key(crate::mesh::creases::use_normal(mesh, u0, v))
                != normal_key(crate::mesh::creases::use_normal(mesh, u1, v))
        });
        if split {
            crease[e.half_edges[0] as usize] = true;
            crease[e.half_edges[1] as usize] = true;
        } else {
            let (a, b) = (
                root(&mut parent, u0.triangle),
                root(&mut parent, u1.triangle),
            );
            parent[a.max(b) as usize] = a.min(b);
        }
    }
    // Per component: the largest θ − 90° and 90° − θ over its constrained corners.
    let mut worst: HashMap<u32, (f64, f64)> = HashMap::new();
    for t in 0..nt {
        for k in 0..3 {
            if (crease[3 * t + k] && crease[3 * t + (k + 2) % 3])
                || faces[t].length_squared() < 0.25
            {
                continue;
            }
            let theta = angle_deg(mesh.corner_normals[t][k], faces[t]);
            let r = root(&mut parent, t as u32);
            let e = worst.entry(r).or_insert((0.0, 0.0));
            e.0 = e.0.max(theta - 90.0);
            e.1 = e.1.max(90.0 - theta);
        }
    }
    let bound = worst.values().map(|&(p, q)| p.min(q)).fold(0.0, f64::max);
    let forced = (0..groups.list.len() as u32)
        .map(|g| {
            // Degenerate triangles (zero face normal) face every way.
            let f: Vec<DVec3> = groups.face_normals(g, faces).collect();
            let n = groups.normal(mesh, g);
            // Quick case: the group's own normal faces all of them.
            if f.iter().all(|x| x.dot(n) > NO_HEMISPHERE) {
                return false;
            }
            max_min_direction(&f).is_none_or(|(_, v)| v <= NO_HEMISPHERE)
        })
        .collect();
    (bound, forced)
}

/// Scaled corner Jacobians below which [`joint_corners`] pushes a corner up.
const CORNER_AIM: f64 = 0.1;

/// Most sweeps over its groups of one [`joint_corners`].
const JOINT_SWEEPS: usize = 24;

/// Most passes of [`joint_corners`] in the crease-free phase.
const JOINT_PASSES: usize = 3;

/// Weight of [`corner_shortfall`] in [`joint_corners`]'s measure.
const CORNER_WEIGHT: f64 = 10.0;

/// The smallest scaled Jacobian of the G1 patch of triangle `t` of `work` at its three
/// corners, from the Walton–Meek end tangents alone: at corner k the patch's S_s × S_t is
/// along the cross product of the tangents of its two boundary curves there, and each
/// tangent depends on the normals of both of its curve's ends (not only on the corner's:
/// the Walton–Meek tangent is the chord projected plus a multiple of the far end's normal
/// projected). The value is the smaller of that cross product along the face normal and
/// along the corner's normal (a patch turned inside out at the corner), over the tangents'
/// lengths.
fn corner_values(work: &Mesh, t: usize) -> [f64; 3] {
    let tri = work.triangles[t];
    let q = tri.map(|v| work.positions[v as usize]);
    let n = work.corner_normals[t];
    let nf = crate::mesh::normals::face_normal(q);
    std::array::from_fn(|k| {
        let (i, j) = ((k + 1) % 3, (k + 2) % 3);
        let a = super::g1::walton_meek_offsets(q[k], n[k], q[i], n[i])[0];
        let b = super::g1::walton_meek_offsets(q[k], n[k], q[j], n[j])[0];
        let s = a.length() * b.length();
        if s.is_nan() || s <= 0.0 {
            return -1.0;
        }
        let c = a.cross(b);
        (c.dot(nf) / s).min(c.dot(n[k]) / s)
    })
}

/// The corner shortfall of the triangles `tris`: the sum of the squares of their
/// [`corner_values`] below [`CORNER_AIM`].
fn corner_shortfall(work: &Mesh, tris: &[u32]) -> f64 {
    tris.iter()
        .flat_map(|&t| corner_values(work, t as usize))
        .map(|v| (CORNER_AIM - v).max(0.0).powi(2))
        .sum()
}

/// Crease-free joint move of the normals of the groups `region` (a pattern search on the
/// sphere, each group in turn, 8 directions, steps from 0.2 down to 0.0125 radians):
/// lowers [`corner_shortfall`] of the triangles around them, plus a small pull towards each
/// group's input normal; every moved group keeps facing its triangles by
/// `FACING_STEPS[0]` (or by no less than before). Returns the moved groups' new normals,
/// `work` left with them.
fn joint_corners(
    work: &mut Mesh,
    mesh: &Mesh,
    groups: &Groups,
    faces: &[DVec3],
    region: &[u32],
    (scheme, opts, twins): (Scheme, &SchemeOptions, &[u32]),
    grid: &Grid,
) -> Result<Vec<(u32, DVec3)>> {
    let input = |g: u32| {
        let c = groups.corners(g)[0] as usize;
        mesh.corner_normals[c / 3][c % 3]
    };
    let around: Vec<Vec<u32>> = region
        .iter()
        .map(|&g| {
            let mut r: Vec<u32> = groups.triangles_around(g).collect();
            r.sort_unstable();
            r.dedup();
            r
        })
        .collect();
    const PULL: f64 = 1e-3;
    let mut sink = Vec::new();
    let mut step: f64 = 0.2;
    let mut sweeps = 0;
    while step >= 0.0125 && sweeps < JOINT_SWEEPS {
        sweeps += 1;
        let mut better = false;
        for (i, &g) in region.iter().enumerate() {
            let cur = groups.normal(work, g);
            // (shortfall, shortfall plus the pull towards the input normal)
            let score = |work: &Mesh, n: DVec3| -> Result<(f64, f64)> {
                let table = ring_patches(work, scheme, opts, &around[i], twins)?;
                let short = CORNER_WEIGHT * corner_shortfall(work, &around[i])
                    + badness(&table, grid)
                    + lagrange_shortfall(&table);
                Ok((short, short + PULL * (1.0 - n.dot(input(g)))))
            };
            let (short, now) = score(work, cur)?;
            if short <= 0.0 {
                continue;
            }
            let u = cur.any_orthonormal_vector();
            let v = cur.cross(u);
            let floor = FACING_STEPS[0].min(groups.facing(g, faces, cur));
            let mut best = (now, cur);
            for d in 0..8 {
                let phi = d as f64 * std::f64::consts::FRAC_PI_4;
                let n = (cur + step.tan() * (phi.cos() * u + phi.sin() * v)).normalize();
                if groups.facing(g, faces, n) < floor {
                    continue;
                }
                set_group(work, groups, g, n, &mut sink);
                let s = score(work, n)?.1;
                if s < best.0 - 1e-12 {
                    best = (s, n);
                }
            }
            set_group(work, groups, g, best.1, &mut sink);
            sink.clear();
            if best.1 != cur {
                better = true;
            }
        }
        if !better {
            step /= 2.0;
        }
    }
    Ok(region
        .iter()
        .map(|&g| (g, groups.normal(work, g)))
        .collect())
}
