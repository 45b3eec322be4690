//! How the search judges patches: the certificate of [`crate::patch::validity`] with the
//! search's own refusals ([`Checker::judge`]), its verdicts kept for the length of one
//! search, and the sampled measure between certificates ([`badness`]).

use std::collections::HashMap;
use std::sync::Mutex;

use glam::DVec3;
use rayon::prelude::*;

use super::bound::{ElementBound, LAGRANGE_MARGIN};
use crate::mesh::adjacency::EdgeUse;
use crate::mesh::Mesh;
use crate::patch::basis::Weights;
use crate::patch::validity::{check_patch, Verdict};
use crate::patch::{PatchBuilder, PatchKind, PatchTable, Scheme, SchemeOptions, SurfacePoint};
use crate::Result;

/// Scaled Jacobian the search aims at everywhere (a margin above 0, the fold).
const MARGIN: f64 = 0.05;
/// Grid level of the search's measure ([`badness`]).
const BADNESS_LEVEL: u32 = 6;
/// Grid level at which [`Checker::uncertified_upto`] looks for points where J is surely
/// negative.
const SURE_LEVEL: u32 = 8;
/// Grid level of the crease-free phase's measure (and of the arm step's search).
const FINE_LEVEL: u32 = 12;
/// Grid level at which the arm step checks its results before they are certified.
const CHECK_LEVEL: u32 = 40;
/// Grid level at which the repaired and unrepaired surfaces are compared.
const DISTANCE_LEVEL: u32 = 8;
/// Most verdicts [`Checker::certify`] keeps before it starts afresh (each key is 57 words).
const MAX_KEPT_VERDICTS: usize = 1 << 18;

/// Verdicts by the bit patterns of a patch's control points and flat normal.
type VerdictMap = HashMap<Box<[u64]>, Verdict>;

/// A barycentric grid with the basis weights of one patch kind at its points, computed
/// once: [`PatchTable::eval`] computes them at every call, and evaluating through them
/// ([`PatchTable::eval_weights`]) gives bitwise the same result.
pub(super) struct Grid {
    pub(super) weights: Vec<Weights>,
}

impl Grid {
    /// The grid of `level` segments per edge ([`grid_points`]) for patches of `kind`.
    fn new(kind: PatchKind, level: u32) -> Grid {
        Grid {
            weights: grid_points(level)
                .into_iter()
                .map(|b| kind.weights(b))
                .collect(),
        }
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

/// The grids of the search, for its scheme's patch kind.
pub(super) struct Grids {
    /// The search's measure ([`BADNESS_LEVEL`]).
    pub(super) coarse: Grid,
    /// The crease-free phase's measure and the arm step's search ([`FINE_LEVEL`]).
    pub(super) fine: Grid,
    /// The arm step's check of its results ([`CHECK_LEVEL`]).
    pub(super) check: Grid,
    /// Where J is surely negative ([`SURE_LEVEL`]).
    sure: Grid,
    /// The distance between the repaired and unrepaired surfaces ([`DISTANCE_LEVEL`]).
    pub(super) distance: Grid,
}

impl Grids {
    fn new(kind: PatchKind) -> Grids {
        Grids {
            coarse: Grid::new(kind, BADNESS_LEVEL),
            fine: Grid::new(kind, FINE_LEVEL),
            check: Grid::new(kind, CHECK_LEVEL),
            sure: Grid::new(kind, SURE_LEVEL),
            distance: Grid::new(kind, DISTANCE_LEVEL),
        }
    }
}

/// What one search builds and judges patches with: the scheme and its options, the mesh's
/// twin half-edges (G1), the grids and the element bound, and the verdicts of the patches
/// certified so far (the search builds the same patch again and again: the patches around
/// a vertex that a trial leaves as they were).
pub(super) struct Checker {
    pub(super) scheme: Scheme,
    pub(super) opts: SchemeOptions,
    /// For each half-edge 3t + k of an edge used by exactly two triangles, the other use's
    /// half-edge; `u32::MAX` otherwise (G1 only, empty for other schemes).
    pub(super) twins: Vec<u32>,
    pub(super) grids: Grids,
    pub(super) element: ElementBound,
    /// Verdicts of [`check_patch`], a function of the patch's control points and flat
    /// normal alone, by their bit patterns.
    verdicts: Mutex<VerdictMap>,
}

/// A table of some triangles' patches ([`Checker::ring_table`]) with their corner normals
/// (for [`Checker::judge`]).
pub(super) struct RingTable {
    table: PatchTable,
    normals: Vec<[DVec3; 3]>,
}

impl std::ops::Deref for RingTable {
    type Target = PatchTable;
    fn deref(&self) -> &PatchTable {
        &self.table
    }
}

impl Checker {
    pub(super) fn new(mesh: &Mesh, scheme: Scheme, opts: &SchemeOptions) -> Checker {
        Checker {
            scheme,
            opts: *opts,
            twins: if scheme == Scheme::G1 {
                super::geometry::twins(mesh)
            } else {
                Vec::new()
            },
            grids: Grids::new(scheme.kind()),
            element: ElementBound::new(),
            verdicts: Mutex::new(HashMap::new()),
        }
    }

    /// The patches of `tris` on `work` with their corner normals ([`Self::ring_patches`]).
    pub(super) fn ring_table(&self, work: &Mesh, tris: &[u32]) -> Result<RingTable> {
        let normals = tris
            .iter()
            .map(|&t| work.corner_normals[t as usize])
            .collect();
        Ok(RingTable {
            table: self.ring_patches(work, tris)?,
            normals,
        })
    }

    /// The patches of `tris` on `work`. G1 builds them here, with the crease curves of
    /// their own edges only ([`crate::patch::g1::shared_curve`], as
    /// [`crate::patch::g1::prepare`] builds them for the whole mesh: bitwise the same
    /// patches); other schemes are prepared for the whole mesh.
    pub(super) fn ring_patches(&self, work: &Mesh, tris: &[u32]) -> Result<PatchTable> {
        let scheme = self.scheme;
        if scheme != Scheme::G1 {
            return PatchBuilder::new(work, scheme, &self.opts)?.table_of(tris, 0);
        }
        let twins = &self.twins;
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
                let c = crate::patch::g1::shared_curve(work, v, uses, &mut fallbacks)?;
                Some(if a == v[0] {
                    c
                } else {
                    [c[3], c[2], c[1], c[0]]
                })
            });
            points.extend_from_slice(&crate::patch::g1::patch_points_with_curves(
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

    /// The verdicts of the patches of `tris` on `work`.
    pub(super) fn verdicts_of(&self, work: &Mesh, tris: &[u32]) -> Result<Vec<Verdict>> {
        let table = self.ring_table(work, tris)?;
        Ok(self.judge_all(&table))
    }

    /// [`Self::judge`] of every patch of `table`.
    fn judge_all(&self, table: &RingTable) -> Vec<Verdict> {
        (0..table.len())
            .into_par_iter()
            .map(|i| self.judge(table, i, table.normals[i]))
            .collect()
    }

    /// Whether [`Self::judge`] accepts every patch of `tris` on `work`.
    pub(super) fn all_certified(&self, work: &Mesh, tris: &[u32]) -> Result<bool> {
        let table = self.ring_table(work, tris)?;
        Ok((0..tris.len())
            .into_par_iter()
            .all(|i| self.judge(&table, i, table.normals[i]) == Verdict::Valid))
    }

    /// The number of uncertified patches of `table` ([`Self::judge`]), or `None` as soon
    /// as it exceeds `limit` (the rest is not certified).
    ///
    /// A patch with J < −1e-9 |S_s| |S_t| at a point of a grid of level 8 (far beyond the
    /// rounding of the evaluation: J is negative there) is counted without its
    /// certificate, which cannot prove it valid; the others are certified after them.
    pub(super) fn uncertified_upto(&self, table: &RingTable, limit: usize) -> Option<usize> {
        let grid = &self.grids.sure;
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
                .filter(|&&i| self.judge(table, i, table.normals[i]) != Verdict::Valid)
                .count();
            if n > limit {
                return None;
            }
        }
        Some(n)
    }

    /// The verdicts of the patches of `tris` on `work`, or `None` as soon as more than
    /// `limit` of them are uncertified ([`Self::uncertified_upto`]).
    pub(super) fn verdicts_upto(
        &self,
        work: &Mesh,
        tris: &[u32],
        limit: usize,
    ) -> Result<Option<Vec<Verdict>>> {
        let table = self.ring_table(work, tris)?;
        if self.uncertified_upto(&table, limit).is_none() {
            return Ok(None);
        }
        Ok(Some(self.judge_all(&table)))
    }

    /// The search's verdict on patch `i` of `table`: the certificate's ([`Self::certify`]),
    /// except that a certified G1 patch whose cubic Lagrange element (the nodes
    /// `export-msh` writes at order 3) may fold ([`ElementBound::of`] at most
    /// [`LAGRANGE_MARGIN`]) counts as undecided, so that the repair gives solvers elements
    /// that do not fold either.
    ///
    /// It also counts as undecided a certified patch that is inside out ([`inside_out`]),
    /// which the certificate (along the face normal) accepts but which meets its
    /// neighbours across smooth edges at cos = −1 (two copies of one triangle in both
    /// orders, glued along two edges, one of them facing away from the normals of all
    /// three vertices).
    ///
    /// These two checks come first and are cheap; a patch they refuse is not certified at
    /// all (the search only tells valid from not valid, so its verdict is the same
    /// whatever the certificate would say, and the patches close to folding are the ones
    /// whose certificate subdivides the most).
    pub(super) fn judge(&self, table: &PatchTable, i: usize, normals: [DVec3; 3]) -> Verdict {
        if inside_out(table, i, normals)
            || (table.scheme == Scheme::G1 && self.element.of(table, i) <= LAGRANGE_MARGIN)
        {
            return Verdict::Undecided;
        }
        self.certify(table, i)
    }

    /// [`check_patch`] of patch `i` of `table`, remembered for the rest of the search.
    pub(super) fn certify(&self, table: &PatchTable, i: usize) -> Verdict {
        let key: Box<[u64]> = table
            .patch(i)
            .iter()
            .chain(std::iter::once(&table.flat_normals[i]))
            .flat_map(|p| p.to_array().map(f64::to_bits))
            .collect();
        let kept = self
            .verdicts
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .get(&key)
            .copied();
        if let Some(v) = kept {
            return v;
        }
        let v = check_patch(table, i);
        let mut m = self.verdicts.lock().unwrap_or_else(|e| e.into_inner());
        if m.len() >= MAX_KEPT_VERDICTS {
            m.clear();
        }
        m.insert(key, v);
        v
    }

    /// The search's measure of `table`: [`badness`] on `grid`, plus (`lagrange`) the
    /// element bound's shortfall ([`ElementBound::shortfall`]).
    pub(super) fn measure(&self, table: &PatchTable, grid: &Grid, lagrange: bool) -> f64 {
        if lagrange {
            badness(table, grid) + self.element.shortfall(table)
        } else {
            badness(table, grid)
        }
    }
}

/// Whether the normal of patch `i` of `table` at a corner turns away from that corner's
/// normal (`normals`): (S_s × S_t) · N ≤ 0.
pub(super) fn inside_out(table: &PatchTable, i: usize, normals: [DVec3; 3]) -> bool {
    (0..3).any(|k| {
        let mut b = [0.0; 3];
        b[k] = 1.0;
        let p = table.eval(i, b);
        p.ds.cross(p.dt).dot(normals[k]) <= 0.0
    })
}

/// How far the patches of `table` are from a scaled Jacobian J/(|S_s| |S_t|) of
/// [`MARGIN`] everywhere: the sum over the points of `grid` of its shortfall (0 for
/// patches well inside the valid ones). The search's measure between certificates.
pub(super) fn badness(table: &PatchTable, grid: &Grid) -> f64 {
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
pub(super) fn scaled_jacobian(p: &SurfacePoint, nf: DVec3) -> (f64, f64, f64) {
    let (j, scale) = (p.ds.cross(p.dt).dot(nf), p.ds.length() * p.dt.length());
    (j, scale, if scale > 0.0 { j / scale } else { -1.0 })
}
