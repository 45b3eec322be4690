//! The fallback (every scheme; for G1 what the crease-free phase and the arm step leave):
//! the search with cuts, the isolation of triangles turned away from everything around
//! them, and (G1) the last resort that flattens patches, which ends with every patch
//! certified.

use std::collections::HashSet;

use glam::DVec3;

use super::check::{badness, Checker, RingTable};
use super::driver::{count_uncertified, record, Search};
use super::geometry::{central, fan_order, parallel};
use super::groups::{set_group, Groups};
use super::search::faces_of_group;
use crate::mesh::Mesh;
use crate::patch::validity::Verdict;
use crate::patch::Scheme;
use crate::Result;

/// Largest closed fan whose every two-run cut [`best_cut`] tries (n(n − 1)/2 of them);
/// larger fans are cut as if open (n − 1 cuts).
const MAX_CLOSED_CUT_FAN: usize = 32;
/// Smallest cosine between a group's normal and its faces' normals below which the
/// fallback first gives the group its central normal.
const PREPASS_MARGIN: f64 = 0.1;

impl Search<'_> {
    /// The fallback: the arm step first (G1; where it certifies everything nothing else
    /// runs), then the isolation of triangles turned away from everything around them
    /// (G1), central normals for the groups that do not face their triangles, and the
    /// rounds of moves and cuts.
    pub(super) fn fallback(&mut self) -> Result<()> {
        self.bad = self.uncertified();
        if self.bad.is_empty() {
            return Ok(());
        }
        if self.cx.scheme == Scheme::G1 {
            self.crease_free_left = self.bad.clone();
            if self.arm()? {
                return Ok(());
            }
            for t in self.bad.clone() {
                self.isolate(t, false)?;
            }
            let verdicts = &self.verdicts;
            self.bad.retain(|&t| verdicts[t as usize] != Verdict::Valid);
        }
        self.central_normals()?;
        self.bad = self.uncertified();
        self.search_rounds(true)
    }

    /// Every normal group at a corner of an uncertified patch that does not face all of
    /// its own triangles by a margin (smallest cosine to their face normals below
    /// [`PREPASS_MARGIN`]) gets its central normal, where that faces them better: the
    /// corner condition n_f · N > 0 of every patch around it, which no later move can do
    /// without.
    fn central_normals(&mut self) -> Result<()> {
        let mut seen = HashSet::new();
        for t in self.bad.clone() {
            for k in 0..3 {
                let g = self.groups.of_corner[3 * t as usize + k];
                if !seen.insert(g) || self.groups.frozen.contains(&g) {
                    continue;
                }
                let f = faces_of_group(&self.groups, &self.faces, g);
                let cur = self.groups.normal(&self.work, g);
                let margin = |n: DVec3| f.iter().map(|x| x.dot(n)).fold(f64::INFINITY, f64::min);
                let c = central(&f, cur);
                if margin(cur) < PREPASS_MARGIN && margin(c) > margin(cur) {
                    self.set_and_judge(g, c)?;
                }
            }
        }
        Ok(())
    }

    /// The last resorts of G1, where a patch is still uncertified: the isolation of
    /// [`Self::isolate_sliver`] whatever its neighbours' orientation, then the
    /// flattening cascade ([`Self::flatten_cascade`]), which ends with every patch
    /// certified.
    pub(super) fn last_resorts(&mut self) -> Result<()> {
        for t in self.bad.clone() {
            if self.verdicts[t as usize] != Verdict::Valid {
                self.isolate(t, true)?;
            }
        }
        if count_uncertified(&self.verdicts, &self.bad) > 0 {
            self.flattened = self.flatten_cascade()?;
        }
        Ok(())
    }

    /// [`Self::isolate_sliver`], counted where kept.
    fn isolate(&mut self, t: u32, any: bool) -> Result<()> {
        if let Some(gs) = self.isolate_sliver(t, any)? {
            self.touched.extend(gs);
            self.splits += 6;
            self.slivers += 1;
        }
        Ok(())
    }

    /// The best cut of a corner group of patch `tri` ([`best_cut`]), where one helps;
    /// returns whether one was made.
    pub(super) fn cut(&mut self, tri: usize) -> Result<bool> {
        let Some(cut) = best_cut(
            &mut self.work,
            &mut self.groups,
            &self.faces,
            &self.cx,
            &self.verdicts,
            tri,
        )?
        else {
            return Ok(false);
        };
        record(
            &mut self.verdicts,
            &mut self.changed,
            &cut.ring,
            &cut.verdicts,
        );
        self.touched.insert(cut.groups[0]);
        self.touched.insert(cut.groups[1]);
        self.in_cuts.extend(cut.groups);
        self.cuts.push(cut.groups);
        self.splits += 1;
        Ok(true)
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
    fn isolate_sliver(&mut self, t: u32, any: bool) -> Result<Option<[u32; 9]>> {
        let Search {
            work,
            groups,
            faces,
            cx,
            verdicts,
            changed,
            ..
        } = self;
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
            let edge = |w: u32| {
                (work.positions[w as usize] - work.positions[v as usize]).normalize_or_zero()
            };
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
            let choice = fewest_uncertified(cx, n.saturating_sub(2), |i| {
                let j = i + 1;
                let hb = groups.split(g, &order[j + 1..]);
                let na = perp(central_of(&order[1..=j], old), *e1);
                let nb = perp(central_of(&order[j + 1..], old), *e2);
                set_group(work, groups, g, na, &mut sink);
                set_group(work, groups, hb, nb, &mut sink);
                let table = cx.ring_table(work, &around);
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
            cx.verdicts_upto(work, &ring, was.saturating_sub(1))?
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
    fn flatten_cascade(&mut self) -> Result<usize> {
        let Search {
            work,
            groups,
            faces,
            cx,
            verdicts,
            changed,
            touched,
            ..
        } = self;
        let mut flat: HashSet<u32> = HashSet::new();
        let mut count = 0;
        while let Some(t) = (0..verdicts.len() as u32)
            .find(|&t| verdicts[t as usize] != Verdict::Valid && !flat.contains(&t))
        {
            flat.insert(t);
            count += 1;
            let tri = work.triangles[t as usize];
            for k in 0..3 {
                flatten_corner(work, groups, faces, cx, 3 * t + k as u32)?;
            }
            let ring = groups.ring(tri);
            let v = cx.verdicts_of(work, &ring)?;
            record(verdicts, changed, &ring, &v);
            for &v in &tri {
                touched.extend(groups.at_vertex[v as usize].iter().copied());
            }
        }
        Ok(count)
    }
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
    cx: &Checker,
    c: u32,
) -> Result<()> {
    let v = work.triangles[c as usize / 3][c as usize % 3];
    let mut sink = Vec::new();
    let all: Vec<u32> = groups.at_vertex[v as usize]
        .iter()
        .flat_map(|&g| groups.corners(g).iter().copied())
        .collect();
    // At a vertex of a split fin every corner is made flat: the face normal of a triangle
    // on the fin's edge is perpendicular to it, so that edge stays straight in every use.
    let fin = groups.fins.contains(&v);
    let Some((order, closed)) = fan_order(work, &all).filter(|_| !fin) else {
        for x in all {
            make_flat(work, groups, faces, x, &mut sink);
        }
        return Ok(());
    };
    make_flat(work, groups, faces, c, &mut sink);
    let Some(at) = order.iter().position(|&x| x == c) else {
        return Ok(());
    };
    let mut ring: Vec<u32> = all.iter().map(|&x| x / 3).collect();
    ring.sort_unstable();
    ring.dedup();
    let fan = Fan {
        v,
        order,
        closed,
        at,
        ring,
    };
    for d in [-1isize, 1] {
        flatten_run(work, groups, faces, cx, &fan, d, &mut sink)?;
    }
    Ok(())
}

/// Makes corner `x` flat: its face normal in a group of its own, or bitwise the normal of
/// a flat corner at its vertex with the same face normal to 1e-9 radians (the other half
/// of a planar quad): the crease direction between two such normals would be their
/// rounding error, their common normal keeps the edge between them smooth, and straight.
fn make_flat(work: &mut Mesh, groups: &mut Groups, faces: &[DVec3], x: u32, sink: &mut Vec<u32>) {
    let v = work.triangles[x as usize / 3][x as usize % 3];
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
}

/// The corners around vertex `v` in fan order ([`fan_order`]), whether the fan closes,
/// the position of the corner made flat, and the triangles around `v`.
struct Fan {
    v: u32,
    order: Vec<u32>,
    closed: bool,
    at: usize,
    ring: Vec<u32>,
}

impl Fan {
    /// The fan position `d` steps from `i`: modulo the fan's length where it closes,
    /// `None` past its ends where it does not.
    fn step(&self, i: usize, d: isize) -> Option<usize> {
        let n = self.order.len();
        if self.closed {
            Some((i as isize + d).rem_euclid(n as isize) as usize)
        } else {
            let j = i as isize + d;
            (0..n as isize).contains(&j).then_some(j as usize)
        }
    }

    /// The direction of the edge from `v` shared by fan positions i and i + 1.
    fn edge_dir(&self, work: &Mesh, i: usize) -> DVec3 {
        let x = self.order[i] as usize;
        let w = work.triangles[x / 3][(x % 3 + 2) % 3];
        (work.positions[w as usize] - work.positions[self.v as usize]).normalize_or_zero()
    }
}

/// The run of the fan next to its flat corner on side `d` (away from it while in one
/// group and not flat) gets normals perpendicular to the edges it shares with flat
/// corners ([`flatten_corner`]).
fn flatten_run(
    work: &mut Mesh,
    groups: &mut Groups,
    faces: &[DVec3],
    cx: &Checker,
    fan: &Fan,
    d: isize,
    sink: &mut Vec<u32>,
) -> Result<()> {
    let (order, n, at) = (&fan.order, fan.order.len(), fan.at);
    let Some(start) = fan.step(at, d) else {
        return Ok(());
    };
    let s0 = order[start];
    if flat_corner(work, groups, faces, s0) {
        return Ok(());
    }
    let g = groups.of_corner[s0 as usize];
    // The run: from `start` away from the flat corner while in the same group and not flat.
    let mut run = vec![start];
    let mut i = start;
    while let Some(j) = fan.step(i, d) {
        if j == at
            || groups.of_corner[order[j] as usize] != g
            || flat_corner(work, groups, faces, order[j])
        {
            break;
        }
        run.push(j);
        i = j;
    }
    let far = fan
        .step(i, d)
        .filter(|&j| flat_corner(work, groups, faces, order[j]));
    // In fan order: `run` from the lower end; the edge at each flat end.
    let (near_edge, far_edge) = if d > 0 {
        (
            fan.edge_dir(work, (start + n - 1) % n),
            far.map(|_| fan.edge_dir(work, i)),
        )
    } else {
        (
            fan.edge_dir(work, start),
            far.map(|j| fan.edge_dir(work, j)),
        )
    };
    let corners: Vec<u32> = run.iter().map(|&j| order[j]).collect();
    // `corners` runs from the flat corner outwards.
    let h = if groups.corners(g).len() > corners.len() {
        groups.split(g, &corners)
    } else {
        g
    };
    let old = groups.normal(work, h);
    let m = corners.len();
    if far_edge.is_some() && m == 1 {
        make_flat(work, groups, faces, corners[0], sink);
        return Ok(());
    }
    let perp = |n: DVec3, e: DVec3| (n - n.dot(e) * e).try_normalize().unwrap_or(n);
    let central_of = |cs: &[u32]| {
        let f: Vec<DVec3> = cs.iter().map(|&x| faces[x as usize / 3]).collect();
        central(&f, old)
    };
    // Option j: the first j corners (from the flat corner) perpendicular to the near edge,
    // the rest perpendicular to the far edge, or keeping their normal.
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
    let choice = fewest_uncertified(cx, js.len(), |i| {
        let rest = apply(work, groups, js[i], sink);
        let table = cx.ring_table(work, &fan.ring);
        if let Some(r) = rest {
            groups.unsplit(h, r);
        }
        set_group(work, groups, h, old, sink);
        table
    })?;
    if let Some(i) = choice {
        apply(work, groups, js[i], sink);
    }
    Ok(())
}

/// Of `n` trials, the one whose patches (`table_of(i)`, the trial undone again) have the
/// fewest uncertified, then the smallest [`badness`], then the smallest index. Every
/// trial's badness is measured first; they are then certified in order of (badness,
/// index), each only as far as it could still win (one uncertified patch fewer than the
/// best so far).
fn fewest_uncertified(
    cx: &Checker,
    n: usize,
    mut table_of: impl FnMut(usize) -> Result<RingTable>,
) -> Result<Option<usize>> {
    let mut b = Vec::with_capacity(n);
    for i in 0..n {
        b.push(badness(&*table_of(i)?, &cx.grids.coarse));
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
        if let Some(bad) = cx.uncertified_upto(&table_of(i)?, limit) {
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
/// `groups`, or `None` (nothing changed) where no cut lowers the number of uncertified
/// patches around the vertex. A cut splits the group's fan of triangles into two runs of
/// neighbours (along two of its edges where the fan closes around the vertex, along one
/// where the vertex is on a boundary); each run gets the central normal of its faces, so
/// both fit their own triangles. A cut helps when it leaves fewer uncertified patches around
/// its vertex, or as many with a [`badness`] at least 10 % smaller; among all helping cuts
/// of the three corners' groups, the one with the fewest uncertified patches wins (then the
/// smallest badness).
fn best_cut(
    work: &mut Mesh,
    groups: &mut Groups,
    faces: &[DVec3],
    cx: &Checker,
    verdicts: &[Verdict],
    t: usize,
) -> Result<Option<Cut>> {
    let grid = &cx.grids.coarse;
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
        let b0 = badness(&*cx.ring_table(work, &ring)?, grid);
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
            let b = badness(&*cx.ring_table(work, &ring)?, grid);
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
        let counted = cx.uncertified_upto(&cx.ring_table(work, ring)?, limit);
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
    let verdicts = cx.verdicts_of(work, &ring)?;
    Ok(Some(Cut {
        groups: [g, h],
        ring,
        verdicts,
    }))
}
