//! Repair of folded patches by changing vertex normals as little as needed (and, for G1,
//! the tangent lengths of some boundary curves).
//!
//! Every scheme builds each patch from its triangle's corners and their normals only, so
//! any choice of normals keeps the patch network watertight, and G1 across every edge
//! whose two triangles share its ends' normals. The repair therefore moves whole *normal
//! groups* (the corners of one vertex with bitwise the same normal): smooth edges stay
//! smooth, creases stay creases, unless a step below makes a crease on purpose. A mesh
//! whose patches are all certified valid ([`super::validity`]) comes back bit for bit.
//!
//! [`repair`] is an explicit step: it returns the repaired mesh and a [`RepairReport`];
//! build the patch table from the repaired mesh afterwards. The search runs in layers,
//! each in its own module:
//!
//! 0. *pages*: triangles hanging at a hub by no two-use edge (a book of triangles around
//!    one edge), flat;
//! 1. *fins* (G1): doubled triangles split off the surface, flat;
//! 2. *search*: the crease-free phase (G1): normals moved, one group or a few together,
//!    under the certificate, then joint moves of the groups around what is left;
//! 3. *arm*: the arm step (G1): tangent lengths of the curves of the patches left scaled,
//!    kept only where that certifies them all;
//! 4. *fallback*: moves, cuts of a vertex's fan into two groups, isolation of triangles
//!    turned away from everything around them, and (G1) flattening, which ends with
//!    every G1 patch certified;
//! 5. *relax*: normals back towards the input, cuts undone, where all stays certified.
//!
//! *bound* computes the cubic Lagrange element's Jacobian bound (the search also refuses
//! a G1 patch whose element may fold) and the lower bound of the normal change of any
//! repair that keeps G1, which the report gives. The method, its proofs and the
//! measurements behind its constants are in `docs/repair.md`.
//!
//! ```
//! use g1tess::{check_table, generators, repair, RepairOptions, Verdict};
//! use g1tess::{PatchTable, Scheme, SchemeOptions};
//! let mesh = generators::icosphere(2);
//! let table = PatchTable::build(&mesh, Scheme::G1, &SchemeOptions::default())?;
//! assert!(check_table(&table).iter().all(|v| *v == Verdict::Valid));
//! // Nothing folds, so the repair leaves the mesh bit for bit as it is.
//! let (same, report) = repair(&mesh, Scheme::G1, &RepairOptions::default())?;
//! assert_eq!(same.corner_normals, mesh.corner_normals);
//! assert_eq!(report.vertices_touched, 0);
//! # Ok::<(), g1tess::Error>(())
//! ```

mod arm;
mod bound;
mod check;
mod driver;
pub(crate) mod fair;
mod fallback;
mod fins;
mod geometry;
mod groups;
mod pages;
mod relax;
mod search;

use serde::Serialize;

use super::validity::{count, fold_line, PatchCounts};
use super::{PatchTable, Scheme, SchemeOptions};
use crate::mesh::Mesh;
use crate::Result;

/// Options of [`repair`].
///
/// ```
/// use g1tess::RepairOptions;
/// use g1tess::SchemeOptions;
/// // The default: the schemes' default options (Phong's α = 3/4).
/// assert_eq!(RepairOptions::default().scheme_options.phong_alpha, 0.75);
/// let opts =
///     RepairOptions::default().with_scheme_options(SchemeOptions::default().with_phong_alpha(0.5));
/// assert_eq!(opts.scheme_options.phong_alpha, 0.5);
/// ```
#[derive(Clone, Copy, Debug, Default)]
#[non_exhaustive]
pub struct RepairOptions {
    /// Options of the scheme whose patches are repaired, the ones the table will be built
    /// with afterwards (default: [`SchemeOptions::default`]).
    pub scheme_options: SchemeOptions,
}

impl RepairOptions {
    /// The options with `scheme_options` for the scheme's patches.
    pub fn with_scheme_options(mut self, scheme_options: SchemeOptions) -> RepairOptions {
        self.scheme_options = scheme_options;
        self
    }
}

/// What a repair changed.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct RepairReport {
    /// Verdicts before.
    pub before: PatchCounts,
    /// Verdicts after.
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
    /// of the input), given their own face normal and straight crease edges; their
    /// corners' normal change counts in the largest.
    pub slivers_isolated: usize,
    /// Interior edges that the cuts made creases (left out of the G1 statistics, which
    /// measure the smooth edges; their two patches still share the edge's curve).
    pub edges_made_creases: usize,
    /// Patches left uncertified whose own triangle turns away from the triangles around
    /// it (negative cosine between its face normal and the mean face normal of the
    /// triangles sharing a corner with it): folds of the input mesh itself.
    pub left_on_flipped_triangles: usize,
    /// Triangles flattened by the last resort (their own face normal at each corner,
    /// straight boundary curves: a flat patch), with the patches around that this broke;
    /// and the pages flattened at a hub (triangles joined to the rest by no two-use edge,
    /// at a vertex of many triangles: a book around one edge).
    pub triangles_flattened: usize,
    /// Rounds of the search.
    pub rounds: usize,
    /// Lower bound, in degrees, of the largest normal change of any repair by normals and
    /// tangent lengths that keeps G1 (makes no smooth edge a crease) and leaves every
    /// patch certified with no edge sample at cos < 0: the largest, over components of
    /// triangles joined by smooth edges, of the smaller of the largest θ − 90° and the
    /// largest 90° − θ over their corners not between two crease edges (θ the angle
    /// between the input normal and the face normal). 0 when nothing folds.
    pub normal_change_lower_bound_deg: f64,
    /// Input normal groups whose triangles' face normals fit in no open hemisphere: no
    /// single normal faces all of them, so a crease there is forced (a doubled triangle's
    /// vertices). 0 when nothing folds.
    pub crease_forced_groups: usize,
    /// Patches that the crease-free search (first phase, G1) left uncertified, handed to
    /// the arm step and, where that does not certify them all, to the fallback of cuts,
    /// isolations and flattenings (sorted triangle indices).
    pub crease_free_left: Vec<u32>,
    /// Of those, the patches with a corner in a group where a crease is forced.
    pub crease_free_left_forced: usize,
    /// Interior edges whose boundary curve got scaled arms (tangent lengths) by the arm
    /// step (G1): 0 where it did not run or was not kept.
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

/// `mesh` with its normals (and, for G1, possibly some tangent lengths:
/// [`crate::mesh::CornerAttributes::arm_scales`]) repaired for `scheme`, and what changed
/// (see the module documentation). A mesh whose patches are all certified valid comes
/// back unchanged. The search runs afresh at every call and keeps nothing between calls:
/// repair once and build the table (and anything else) from the repaired mesh.
pub fn repair(mesh: &Mesh, scheme: Scheme, opts: &RepairOptions) -> Result<(Mesh, RepairReport)> {
    Ok(match driver::plan(mesh, scheme, &opts.scheme_options)? {
        driver::Plan::Repaired(p) => *p,
        driver::Plan::Valid(c) => (
            mesh.clone(),
            RepairReport {
                before: c,
                after: c,
                arm_scale_range: [1.0, 1.0],
                ..Default::default()
            },
        ),
    })
}

/// The line `tessellate`, `render` and `export-msh` print about `table` of mesh
/// `mesh_name`, given the repair's `report` when there was one: the report, a warning
/// where a patch is left folded or undecided; without a report the count of folded
/// patches ([`fold_line`]).
pub fn repair_line(
    mesh_name: &str,
    table: &PatchTable,
    report: Option<&RepairReport>,
) -> Option<String> {
    let Some(report) = report else {
        return fold_line(mesh_name, table);
    };
    let c = count(table);
    let line = report.to_text(mesh_name, table.scheme);
    Some(if c.folded > 0 || c.undecided > 0 {
        format!("warning: {line}")
    } else {
        line
    })
}
