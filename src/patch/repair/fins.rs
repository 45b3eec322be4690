//! Fins (G1, first): a doubled triangle (two triangles on the same three vertices in both
//! orders, glued along their edges) whose vertices need a crease is split off the surface,
//! both of its sides flat, its edges straight in every use.

use std::collections::HashMap;

use glam::DVec3;

use super::driver::{count_uncertified, record, Search};
use super::groups::{set_group, Groups};
use crate::mesh::Mesh;
use crate::patch::validity::Verdict;
use crate::Result;

/// Corners whose normal must stay perpendicular to a fin edge's direction (corner,
/// direction).
type Pins = Vec<(u32, DVec3)>;

/// What [`Search::split_fin`] set: the groups, and the corners it pinned.
type FinSplit = (Vec<u32>, Pins);

/// Groups with the directions of the fin edges their normal must be perpendicular to.
type EdgeDirections = Vec<(u32, Vec<DVec3>)>;

impl Search<'_> {
    /// Each doubled triangle with a copy uncertified is split off the surface
    /// ([`Self::split_fin`]); its groups and the surface's groups it constrains are left
    /// alone by everything that follows, and checked at the end.
    pub(super) fn split_fins(&mut self) -> Result<()> {
        for pair in doubled_triangles(self.mesh) {
            if pair
                .iter()
                .all(|&t| self.verdicts[t as usize] == Verdict::Valid)
            {
                continue;
            }
            if let Some((gs, pins)) = self.split_fin(pair)? {
                self.touched.extend(gs.iter().copied());
                self.groups.frozen.extend(gs);
                self.groups
                    .fins
                    .extend(self.work.triangles[pair[0] as usize]);
                self.pinned.extend(pins);
            }
        }
        self.forced.resize(self.groups.list.len(), false);
        Ok(())
    }

    /// Splits a doubled triangle (`pair`, [`doubled_triangles`]) off the surface: its two
    /// sides face opposite ways, so no normal shared at a vertex faces both (the crease is
    /// forced there). Each of its six corners gets its own group with its triangle's face
    /// normal: the fin's edges get straight curves (between its two sides the crease
    /// direction of opposite normals is the edge itself) and both sides are flat patches.
    /// An edge of the fin that other triangles use too (the edge along which the fin
    /// stands on the surface: more than two uses, no crease curve) must then be straight
    /// in their patches as well, so the groups of those uses at both of its ends get
    /// normals perpendicular to it ([`fin_constraints`], [`perpendicular`]): every face
    /// normal of a triangle on the edge is perpendicular to it, so all uses build the same
    /// straight segment, watertight. Only the fin's own edges (two uses: its two sides)
    /// become creases; every edge of the surface keeps its normals shared. Kept where the
    /// certificate counts fewer uncertified patches around the fin's vertices; returns the
    /// groups set (left alone from then on) and, for each corner of the other uses at a
    /// fin edge's ends, that edge's direction (its normal must stay perpendicular to it).
    fn split_fin(&mut self, pair: [u32; 2]) -> Result<Option<FinSplit>> {
        let Search {
            work,
            groups,
            faces,
            cx,
            verdicts,
            changed,
            ..
        } = self;
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
        let mut sink = Vec::new();
        for &t in &pair {
            for k in 0..3 {
                let h = groups.own_group(3 * t + k, &mut splits);
                set_group(work, groups, h, faces[t as usize], &mut sink);
                set.push(h);
            }
        }
        let (dirs, pins) = fin_constraints(work, groups, pair, tri);
        let mut ok = true;
        for (g, ds) in &dirs {
            let Some(n) = perpendicular(groups.normal(work, *g), ds) else {
                ok = false;
                break;
            };
            set_group(work, groups, *g, n, &mut sink);
            set.push(*g);
        }
        let was = count_uncertified(verdicts, &ring);
        let v = if ok {
            cx.verdicts_of(work, &ring)?
        } else {
            Vec::new()
        };
        if !ok || v.iter().filter(|x| **x != Verdict::Valid).count() >= was {
            groups.undo_trial(work, &ring, old, &splits);
            return Ok(None);
        }
        record(verdicts, changed, &ring, &v);
        Ok(Some((set, pins)))
    }
}

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

/// The groups of the other uses at the ends of each edge of the fin `pair` (vertices
/// `tri`) that other triangles use too, each with the directions of those edges, and the
/// corners whose normal must stay perpendicular to an edge (those uses' corners and the
/// fin's own there, flat), with its direction.
fn fin_constraints(
    work: &Mesh,
    groups: &Groups,
    pair: [u32; 2],
    tri: [u32; 3],
) -> (EdgeDirections, Pins) {
    let mut dirs: EdgeDirections = Vec::new();
    let mut pins = Vec::new();
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
                if uses.is_empty() {
                    continue;
                }
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
    (dirs, pins)
}

/// The normal nearest to `cur` perpendicular to the unit directions `ds`: `cur` projected
/// for one direction, their cross product (on the side of `cur`) for two or more, where
/// every direction is perpendicular to it to 1e-12; `None` where there is none.
fn perpendicular(cur: DVec3, ds: &[DVec3]) -> Option<DVec3> {
    match ds {
        [d] => (cur - cur.dot(*d) * *d).try_normalize(),
        [d, e, ..] => d
            .cross(*e)
            .try_normalize()
            .map(|x| if x.dot(cur) < 0.0 { -x } else { x })
            .filter(|x| ds.iter().all(|f| f.dot(*x).abs() <= 1e-12)),
        [] => Some(cur),
    }
}
