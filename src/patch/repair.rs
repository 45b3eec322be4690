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
//! Method (a local, monotone search; the certificate of [`super::validity`] is the test):
//! 1. Every patch gets its verdict. If all are valid, nothing changes at all.
//! 2. For each patch that is not valid, one of its corners is chosen: the one whose normal
//!    makes the largest angle with the triangle's own normal n_f, among those not yet moved
//!    all the way. Its group's normal moves one step (1/8) along the great circle from its
//!    input value n_0 towards the group's *central normal* m: the direction that maximises
//!    the smallest cosine to the face normals of the group's triangles (the axis of their
//!    smallest enclosing cone, found by the Bădoiu–Clarkson iteration on the unit sphere).
//!    That is the normal with the least tilt to every face around the vertex: a normal far
//!    from one thin face (the usual cause of a fold on scanned meshes) comes back towards
//!    it without leaving the others.
//! 3. A group already at m moves on (second stage) towards the mean of the face normals of
//!    the patches still invalid around it, one step at a time.
//! 4. The patches around every group moved are rebuilt and checked again; the rounds stop
//!    when every patch is certified or nothing can move any more.
//!
//! The report gives the number of vertices touched, the largest angle between a new and an
//! input normal, and the largest distance between the repaired and the unrepaired surface
//! at equal parameters (an upper bound of their Hausdorff distance) over a grid of level 8
//! on every patch that changed.

use std::collections::{HashMap, HashSet};

use glam::DVec3;
use rayon::prelude::*;
use serde::Serialize;

use super::validity::{check_patch, check_table, PatchCounts, Verdict};
use super::{PatchBuilder, PatchTable, Scheme, SchemeOptions, TriangleBuilder};
use crate::mesh::creases::normal_key;
use crate::mesh::Mesh;
use crate::Result;

/// Fraction of the way to its target a normal moves per round.
const STEP: f64 = 1.0 / 8.0;
/// Most rounds before the repair gives up on what is left.
const MAX_ROUNDS: usize = 96;
/// Grid level at which the repaired and unrepaired surfaces are compared.
const DISTANCE_LEVEL: u32 = 8;

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
    /// Rounds of the search.
    pub rounds: usize,
}

impl RepairReport {
    /// One line for people.
    pub fn to_text(&self, mesh: &str, scheme: Scheme) -> String {
        format!(
            "{mesh}: {scheme} fold repair: {} folded and {} undecided patches before, {} \
             folded and {} undecided after; {} vertices touched ({} corners), largest \
             normal change {:.3}°, surface moved at most {:.3e}",
            self.before.folded,
            self.before.undecided,
            self.after.folded,
            self.after.undecided,
            self.vertices_touched,
            self.corners_changed,
            self.max_normal_change_deg,
            self.max_distance
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
    let opts = SchemeOptions {
        repair_folds: false,
        ..*opts
    };
    match plan(mesh, scheme, &opts)? {
        Some(p) => Ok((p.mesh, p.report)),
        None => {
            let table = PatchTable::build(mesh, scheme, &opts)?;
            let c = super::validity::count(&table);
            Ok((
                mesh.clone(),
                RepairReport {
                    before: c,
                    after: c,
                    ..Default::default()
                },
            ))
        }
    }
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
    let Some(p) = plan(mesh, scheme, &opts)? else {
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
    /// Corners of group g: `corners[start[g]..start[g + 1]]`.
    start: Vec<u32>,
    corners: Vec<u32>,
    vertex: Vec<u32>,
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
        let mut start = vec![0u32];
        let mut corners = Vec::with_capacity(by_vertex.len());
        let mut vertex = Vec::new();
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
                for &c in cs {
                    if normal_key(mesh.corner_normals[c as usize / 3][c as usize % 3]) == *key {
                        of_corner[c as usize] = g;
                        corners.push(c);
                    }
                }
                start.push(corners.len() as u32);
                vertex.push(v as u32);
            }
        }
        Groups {
            of_corner,
            start,
            corners,
            vertex,
        }
    }

    fn corners(&self, g: u32) -> &[u32] {
        &self.corners[self.start[g as usize] as usize..self.start[g as usize + 1] as usize]
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

/// State of one moved group.
#[derive(Clone, Copy)]
struct Move {
    n0: DVec3,
    /// First-stage target (central normal) and weight.
    central: DVec3,
    w1: f64,
    /// Second stage: its start (the first stage's end) and weight.
    w2: f64,
}

fn plan(mesh: &Mesh, scheme: Scheme, opts: &SchemeOptions) -> Result<Option<Plan>> {
    let table0 = PatchTable::build(mesh, scheme, opts)?;
    let mut verdicts = check_table(&table0);
    let before = verdicts.iter().fold(PatchCounts::default(), add);
    let mut bad: Vec<u32> = (0..verdicts.len() as u32)
        .filter(|&t| verdicts[t as usize] != Verdict::Valid)
        .collect();
    if bad.is_empty() {
        return Ok(None);
    }
    let groups = Groups::new(mesh);
    let faces: Vec<DVec3> = table0.flat_normals.clone();
    let mut work = mesh.clone();
    let mut moves: HashMap<u32, Move> = HashMap::new();
    let mut changed: HashSet<u32> = HashSet::new();
    // Groups that cannot help: their faces' normals fit in no open hemisphere around the
    // central normal, or a step made their surroundings worse (undone).
    let mut frozen: HashSet<u32> = HashSet::new();
    let mut rounds = 0;
    while !bad.is_empty() && rounds < MAX_ROUNDS {
        rounds += 1;
        // Second-stage targets: mean face normal of the invalid patches around a group.
        let mut pull: HashMap<u32, DVec3> = HashMap::new();
        let mut bumped: Vec<u32> = Vec::new();
        for &t in &bad {
            let tri = t as usize;
            let nf = faces[tri];
            let corner_group = |k: usize| groups.of_corner[3 * tri + k];
            // The corner with the largest tilt to this face, not yet at its central normal.
            let tilt = |k: usize| work.corner_normals[tri][k].dot(nf);
            let mut order = [0usize, 1, 2];
            order.sort_by(|&a, &b| tilt(a).total_cmp(&tilt(b)));
            let first = order.iter().copied().find(|&k| {
                !frozen.contains(&corner_group(k))
                    && moves.get(&corner_group(k)).is_none_or(|m| m.w1 < 1.0)
            });
            match first {
                Some(k) => bumped.push(corner_group(k)),
                None => {
                    for k in order {
                        if !frozen.contains(&corner_group(k)) {
                            *pull.entry(corner_group(k)).or_insert(DVec3::ZERO) += nf;
                        }
                    }
                }
            }
        }
        bumped.sort_unstable();
        bumped.dedup();
        let mut moved: Vec<u32> = Vec::new();
        for &g in &bumped {
            if !moves.contains_key(&g) {
                let cs = groups.corners(g);
                let f: Vec<DVec3> = cs.iter().map(|&c| faces[c as usize / 3]).collect();
                let m = central(&f, DVec3::Z);
                // No normal makes every face around this group face the same side.
                if f.iter().any(|x| x.dot(m) <= 0.0) {
                    frozen.insert(g);
                    continue;
                }
            }
            let m = moves.entry(g).or_insert_with(|| {
                let cs = groups.corners(g);
                let n0 = mesh.corner_normals[cs[0] as usize / 3][cs[0] as usize % 3];
                let f: Vec<DVec3> = cs.iter().map(|&c| faces[c as usize / 3]).collect();
                Move {
                    n0,
                    central: central(&f, n0),
                    w1: 0.0,
                    w2: 0.0,
                }
            });
            m.w1 = (m.w1 + STEP).min(1.0);
            moved.push(g);
        }
        let mut targets: HashMap<u32, DVec3> = HashMap::new();
        for (g, p) in pull {
            let Some(m) = moves.get_mut(&g) else { continue };
            if m.w2 >= 1.0 {
                continue;
            }
            if let Some(p) = p.try_normalize() {
                m.w2 = (m.w2 + STEP).min(1.0);
                targets.insert(g, p);
                moved.push(g);
            }
        }
        if moved.is_empty() {
            break;
        }
        moved.sort_unstable();
        moved.dedup();
        let mut previous: Vec<(u32, DVec3, Move)> = Vec::new();
        let mut affected: Vec<u32> = Vec::new();
        for &g in &moved {
            let m = moves[&g];
            let first = towards(m.n0, m.central, m.w1);
            let c0 = groups.corners(g)[0] as usize;
            let cur = work.corner_normals[c0 / 3][c0 % 3];
            let n = match targets.get(&g) {
                // The second stage moves on from where the group is.
                Some(&p) => towards(cur, p, STEP / (1.0 - m.w2 + STEP)),
                None if m.w2 > 0.0 => cur,
                None => first,
            };
            let mut before = m;
            if targets.contains_key(&g) {
                before.w2 -= STEP;
            } else {
                before.w1 -= STEP;
            }
            previous.push((g, cur, before));
            set_group(&mut work, &groups, g, n, &mut affected);
        }
        affected.sort_unstable();
        affected.dedup();
        let old: HashMap<u32, Verdict> = affected
            .iter()
            .map(|&t| (t, verdicts[t as usize]))
            .collect();
        check(&work, scheme, opts, &affected, &mut verdicts)?;
        // Undo (and freeze) every group whose patches got worse.
        let worse = |g: u32, verdicts: &[Verdict]| {
            let tris = groups.corners(g).iter().map(|&c| c / 3);
            let before = tris.clone().filter(|t| old[t] != Verdict::Valid).count();
            let after = tris
                .filter(|&t| verdicts[t as usize] != Verdict::Valid)
                .count();
            after > before
        };
        let undo: Vec<(u32, DVec3, Move)> = previous
            .into_iter()
            .filter(|(g, _, _)| worse(*g, &verdicts))
            .collect();
        if !undo.is_empty() {
            let mut again = Vec::new();
            for (g, n, m) in undo {
                set_group(&mut work, &groups, g, n, &mut again);
                moves.insert(g, m);
                frozen.insert(g);
            }
            again.sort_unstable();
            again.dedup();
            check(&work, scheme, opts, &again, &mut verdicts)?;
        }
        changed.extend(affected.iter().copied());
        let mut next: Vec<u32> = bad
            .iter()
            .chain(affected.iter())
            .copied()
            .filter(|&t| verdicts[t as usize] != Verdict::Valid)
            .collect();
        next.sort_unstable();
        next.dedup();
        bad = next;
    }
    let after = verdicts.iter().fold(PatchCounts::default(), add);
    let mut changed: Vec<u32> = changed.into_iter().collect();
    changed.sort_unstable();
    // What changed, measured on the final normals.
    let mut vertices = HashSet::new();
    let mut corners = 0;
    let mut max_angle = 0.0f64;
    for (&g, m) in &moves {
        let c = groups.corners(g)[0] as usize;
        let n = work.corner_normals[c / 3][c % 3];
        if normal_key(n) != normal_key(m.n0) {
            vertices.insert(groups.vertex[g as usize]);
            corners += groups.corners(g).len();
            // atan2 of |n0 × n| and n0 · n: accurate at small angles too.
            max_angle = max_angle.max(m.n0.cross(n).length().atan2(m.n0.dot(n)).to_degrees());
        }
    }
    let builder = PatchBuilder::new(&work, scheme, opts)?;
    let table = builder.table_of(&changed, 0)?;
    let grid = grid_points(DISTANCE_LEVEL);
    let max_distance = changed
        .par_iter()
        .enumerate()
        .map(|(i, &t)| {
            grid.iter()
                .map(|&b| (table.eval(i, b).p - table0.eval(t as usize, b).p).length())
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
        rounds,
    };
    Ok(Some(Plan {
        mesh: work,
        changed,
        report,
    }))
}

/// Sets the normal of every corner of group `g` to `n`, listing their triangles.
fn set_group(work: &mut Mesh, groups: &Groups, g: u32, n: DVec3, tris: &mut Vec<u32>) {
    for &c in groups.corners(g) {
        work.corner_normals[c as usize / 3][c as usize % 3] = n;
        tris.push(c / 3);
    }
}

/// Rebuilds and checks the patches of `tris` on `work`.
fn check(
    work: &Mesh,
    scheme: Scheme,
    opts: &SchemeOptions,
    tris: &[u32],
    verdicts: &mut [Verdict],
) -> Result<()> {
    let builder = PatchBuilder::new(work, scheme, opts)?;
    let table = builder.table_of(tris, 0)?;
    let v: Vec<Verdict> = (0..tris.len())
        .into_par_iter()
        .map(|i| check_patch(&table, i))
        .collect();
    for (i, &t) in tris.iter().enumerate() {
        verdicts[t as usize] = v[i];
    }
    Ok(())
}

fn add(c: PatchCounts, v: &Verdict) -> PatchCounts {
    let mut c = c;
    match v {
        Verdict::Valid => c.valid += 1,
        Verdict::Folded { .. } => c.folded += 1,
        Verdict::Undecided => c.undecided += 1,
    }
    c
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
