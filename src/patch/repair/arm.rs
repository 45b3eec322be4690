//! The arm step (G1, after the crease-free phase): the tangent lengths of the boundary
//! curves of the uncertified patches' edges are scaled (both ends' arms of an edge, in
//! both of its uses, so the patches stay G1 and watertight), kept only where that
//! certifies every one of them.

use std::collections::HashSet;

use super::bound::LAGRANGE_MARGIN;
use super::check::{scaled_jacobian, Checker};
use super::driver::Search;
use super::geometry::corner_values;
use crate::mesh::Mesh;
use crate::patch::validity::Verdict;
use crate::patch::{Scheme, SurfacePoint};
use crate::Result;

/// Smallest and largest arm factor the arm step tries.
const ARM_RANGE: [f64; 2] = [0.1, 4.0];
/// Factors the arm step's starts give the arms at each patch's weakest corner.
const ARM_STARTS: [f64; 5] = [0.3, 0.6, 1.6, 2.5, 4.0];
/// The arm step's pattern search stops when its step (log scale) is below this.
const ARM_STEP_END: f64 = 0.02;

/// An interior edge: its two half-edges (the lower first) and its vertices (the lower
/// first).
pub(super) type Edge = ([u32; 2], [u32; 2]);

impl Search<'_> {
    /// The arm step on the patches `self.bad` ([`arm_step`]); where it certifies them all,
    /// they and the patches across their edges are marked certified and changed, nothing
    /// is left to do, and it returns true.
    pub(super) fn arm(&mut self) -> Result<bool> {
        let Some(tris) = arm_step(&mut self.work, &self.cx, &self.bad)? else {
            return Ok(false);
        };
        for t in tris {
            self.verdicts[t as usize] = Verdict::Valid;
            self.changed.insert(t);
        }
        self.bad.clear();
        Ok(true)
    }
}

/// The number of interior edges whose arms `work` scales, and the smallest and largest
/// factor among them ([1, 1] where none).
pub(super) fn arm_summary(work: &Mesh) -> (usize, [f64; 2]) {
    let Some(a) = &work.attributes.arm_scales else {
        return (0, [1.0, 1.0]);
    };
    let mut edges = HashSet::new();
    let mut range = [f64::INFINITY, f64::NEG_INFINITY];
    for (t, s) in a.iter().enumerate() {
        for (k, s) in s.iter().enumerate() {
            if *s == [1.0, 1.0] {
                continue;
            }
            let tri = work.triangles[t];
            let (a, b) = (tri[k], tri[(k + 1) % 3]);
            edges.insert([a.min(b), a.max(b)]);
            for x in s {
                range = [range[0].min(*x), range[1].max(*x)];
            }
        }
    }
    if edges.is_empty() {
        return (0, [1.0, 1.0]);
    }
    (edges.len(), range)
}

/// Sets the arm factors of the interior edges `edges` to `exp(x[2 i])` at the lower
/// vertex of edge i and `exp(x[2 i + 1])` at its higher one, in both uses.
fn set_arms(work: &mut Mesh, edges: &[Edge], x: &[f64]) {
    for (i, edge) in edges.iter().enumerate() {
        set_edge_arms(work, edge, [x[2 * i].exp(), x[2 * i + 1].exp()]);
    }
}

/// Sets the arm factors of `edge` to `s` (at its lower vertex, at its higher one) in both
/// of its uses.
pub(super) fn set_edge_arms(work: &mut Mesh, edge: &Edge, s: [f64; 2]) {
    let n = work.triangles.len();
    let Mesh {
        triangles: tris,
        attributes,
        ..
    } = work;
    let a = attributes
        .arm_scales
        .get_or_insert_with(|| vec![[[1.0; 2]; 3]; n]);
    let (hs, v) = edge;
    for &h in hs {
        let (t, k) = (h as usize / 3, h as usize % 3);
        a[t][k] = if tris[t][k] == v[0] { s } else { [s[1], s[0]] };
    }
}

/// The arm step's measure of the patches of `tris` on `work` (G1): the smallest, over
/// them, of the scaled Jacobian J/(|S_s| |S_t|) along n_f on a grid and on rays close to
/// each corner (the folds it meets sit there), and of the bound of the cubic Lagrange
/// element above [`LAGRANGE_MARGIN`] (the search refuses below it). With `check`, the
/// finer grid and more rays (to check a result before it is certified).
fn arm_measure(work: &Mesh, cx: &Checker, tris: &[u32], check: bool) -> Result<f64> {
    // Rays: radii (barycentric) and directions between the corner's two edges; more of
    // both for the check.
    let (radii, dirs, grid): (&[f64], u32, _) = if check {
        (
            &[
                0.001, 0.003, 0.006, 0.01, 0.015, 0.02, 0.03, 0.045, 0.06, 0.08,
            ],
            8,
            &cx.grids.check,
        )
    } else {
        (&[0.002, 0.006, 0.015, 0.03, 0.06], 4, &cx.grids.fine)
    };
    let table = cx.ring_patches(work, tris)?;
    let mut m = f64::INFINITY;
    for i in 0..table.len() {
        let nf = table.flat_normals[i];
        let sj = |p: SurfacePoint| scaled_jacobian(&p, nf).2;
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
        m = m.min(cx.element.of(&table, i) - LAGRANGE_MARGIN);
    }
    Ok(m)
}

/// The arm step (G1, after the crease-free phase): the patches `bad` are clustered (those
/// whose edges' triangles overlap), and for each cluster the two arm factors of each
/// interior edge of its patches (log scale, within [`ARM_RANGE`]) are searched
/// ([`search_arms`]). Kept only where every cluster is certified: then `work` carries the
/// factors ([`crate::mesh::CornerAttributes::arm_scales`]) and the triangles whose patch
/// changed are returned; otherwise `work` is left as it was and `None` returned.
fn arm_step(work: &mut Mesh, cx: &Checker, bad: &[u32]) -> Result<Option<Vec<u32>>> {
    if cx.scheme != Scheme::G1 || bad.is_empty() || work.attributes.arm_scales.is_some() {
        return Ok(None);
    }
    let mut changed = Vec::new();
    for (patches, tris) in &clusters(&cx.twins, bad) {
        let edges = interior_edges(work, &cx.twins, patches);
        let Some(best) = search_arms(work, cx, patches, tris, &edges)? else {
            work.attributes.arm_scales = None;
            return Ok(None);
        };
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

/// The patches `bad` in clusters whose sets of triangles (each patch and those across its
/// interior edges) overlap: (patches, triangles), both sorted, the clusters sorted.
fn clusters(twins: &[u32], bad: &[u32]) -> Vec<(Vec<u32>, Vec<u32>)> {
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
    clusters
}

/// The interior edges of the triangles `patches`, each once, in the order met.
fn interior_edges(work: &Mesh, twins: &[u32], patches: &[u32]) -> Vec<Edge> {
    let mut edges: Vec<Edge> = Vec::new();
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
    edges
}

/// The starts of the search: all factors 1, then the arms at each patch's weakest corner
/// ([`corner_values`]) at each of [`ARM_STARTS`] (logarithms).
fn starts(work: &Mesh, patches: &[u32], edges: &[Edge]) -> Vec<Vec<f64>> {
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
    starts
}

/// The arm factors (logarithms) of `edges` for the cluster `patches` (triangles `tris`):
/// a pattern search (steps 0.5 down to [`ARM_STEP_END`], each factor in turn) from each
/// start in turn maximising [`arm_measure`] over `tris`; the first result that is positive
/// on the finer grid and that [`Checker::judge`] accepts on all of them is made as small as
/// it stays accepted (all logarithms scaled by 0.1 up to 0.9, the first accepted, then
/// each arm back to 1, largest first). `None` where no start gives one.
fn search_arms(
    work: &mut Mesh,
    cx: &Checker,
    patches: &[u32],
    tris: &[u32],
    edges: &[Edge],
) -> Result<Option<Vec<f64>>> {
    let n = 2 * edges.len();
    let (lo, hi) = (ARM_RANGE[0].ln(), ARM_RANGE[1].ln());
    let measure = |work: &mut Mesh, x: &[f64], check: bool| -> Result<f64> {
        set_arms(work, edges, x);
        arm_measure(work, cx, tris, check)
    };
    let accepted = |work: &mut Mesh, x: &[f64]| -> Result<bool> {
        set_arms(work, edges, x);
        cx.all_certified(work, tris)
    };
    let mut found = None;
    for mut x in starts(work, patches, edges) {
        let mut fx = measure(work, &x, false)?;
        let mut step = 0.5;
        while step > ARM_STEP_END {
            let mut improved = false;
            for i in 0..n {
                for d in [-1.0, 1.0] {
                    let mut y = x.clone();
                    y[i] = (y[i] + d * step).clamp(lo, hi);
                    let fy = measure(work, &y, false)?;
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
        if measure(work, &x, true)? > 0.0 && accepted(work, &x)? {
            found = Some(x);
            break;
        }
    }
    let Some(mut best) = found else {
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
    Ok(Some(best))
}
