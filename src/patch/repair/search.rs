//! The crease-free search (G1, first) and the rounds of moves it shares with the fallback:
//! normals move, group by group or a few groups together, where the sampled measure
//! improves and the certificate counts no more uncertified patches around.

use std::collections::{HashMap, HashSet};

use glam::DVec3;

use super::check::{badness, Checker};
use super::driver::{count_uncertified, record, Search};
use super::geometry::{central, corner_shortfall, max_min_direction, nearest_facing, towards};
use super::groups::{set_group, with_moves, Groups, HUB_CORNERS};
use crate::mesh::creases::normal_key;
use crate::mesh::Mesh;
use crate::patch::validity::Verdict;
use crate::patch::PatchTable;
use crate::Result;

/// Fractions of the way to a target a normal may move, tried smallest first.
const WEIGHTS: [f64; 6] = [1.0 / 16.0, 1.0 / 8.0, 1.0 / 4.0, 1.0 / 2.0, 3.0 / 4.0, 1.0];
/// Most rounds of the fallback before it gives up on what is left.
const MAX_ROUNDS: usize = 96;
/// Smallest cosine n_f · N to each of its triangles that the crease-free phase first gives
/// a group that does not face them all (the nearest such normal, [`nearest_facing`]).
const FACING: f64 = 0.05;
/// Margins of the nearest facing normals the crease-free phase's moves try.
pub(super) const FACING_STEPS: [f64; 6] = [0.02, 0.05, 0.1, 0.2, 0.3, 0.5];
/// Trials of largest gain per patch and round that the crease-free phase certifies.
const CERTIFY_TRIALS: usize = 8;
/// Most rounds of the crease-free phase (each certifies up to [`CERTIFY_TRIALS`] trials
/// per patch; what is left then goes to the fallback).
const CREASE_FREE_ROUNDS: usize = 12;
/// Most sweeps over its groups of one joint move ([`joint_corners`]).
const JOINT_SWEEPS: usize = 24;
/// Most passes of joint moves in the crease-free phase.
const JOINT_PASSES: usize = 3;
/// Weight of [`corner_shortfall`] in [`joint_corners`]'s measure.
const CORNER_WEIGHT: f64 = 10.0;

/// Moves of group normals: (group, new normal).
pub(super) type Moves = Vec<(u32, DVec3)>;

/// A trial of the crease-free phase: its gain, its moves, its ring.
type Trial = (f64, Moves, Vec<u32>);

impl Search<'_> {
    /// The crease-free phase (G1): each group at a corner of an uncertified patch that
    /// does not face its triangles gets the nearest normal that does, then the rounds of
    /// moves and joint moves. What it leaves uncertified goes to the arm step.
    pub(super) fn crease_free(&mut self) -> Result<()> {
        self.face_triangles()?;
        self.bad = self.uncertified();
        self.search_rounds(false)
    }

    /// Every group at a corner of an uncertified patch that faces some of its triangles by
    /// less than FACING (n_f · N) gets the nearest normal that faces them all by FACING
    /// (by the largest smallest cosine where that is less than FACING); a group where no
    /// normal faces them all is left to the fallback.
    fn face_triangles(&mut self) -> Result<()> {
        let mut gs: Vec<u32> = self
            .bad
            .iter()
            .flat_map(|&t| (0..3).map(move |k| 3 * t as usize + k))
            .map(|c| self.groups.of_corner[c])
            .collect();
        gs.sort_unstable();
        gs.dedup();
        for g in gs {
            if self.forced[g as usize] || self.groups.frozen.contains(&g) {
                continue;
            }
            let f: Vec<DVec3> = self.groups.face_normals(g, &self.faces).collect();
            let cur = self.groups.normal(&self.work, g);
            if f.iter().all(|x| x.dot(cur) >= FACING) {
                continue;
            }
            let Some(target) =
                nearest_facing(cur, &f, FACING).or_else(|| max_min_direction(&f).map(|(n, _)| n))
            else {
                continue;
            };
            self.set_and_judge(g, target)?;
        }
        Ok(())
    }

    /// Sets the normal of group `g` to `n`, judges the patches around it and marks `g`
    /// touched.
    pub(super) fn set_and_judge(&mut self, g: u32, n: DVec3) -> Result<()> {
        let mut ring = Vec::new();
        set_group(&mut self.work, &self.groups, g, n, &mut ring);
        ring.sort_unstable();
        ring.dedup();
        let v = self.cx.verdicts_of(&self.work, &ring)?;
        record(&mut self.verdicts, &mut self.changed, &ring, &v);
        self.touched.insert(g);
        Ok(())
    }

    /// Rounds of moves on the uncertified patches; in the crease-free phase (not
    /// `fallback`), joint moves of the groups around what the rounds leave, up to
    /// [`JOINT_PASSES`] times while they help, each followed by the rounds again.
    pub(super) fn search_rounds(&mut self, fallback: bool) -> Result<()> {
        let mut joint_done = 0;
        let mut refused: HashSet<Vec<u64>> = HashSet::new();
        loop {
            self.rounds_of_moves(fallback)?;
            self.bad = self.uncertified();
            if fallback || joint_done >= JOINT_PASSES || self.bad.is_empty() {
                return Ok(());
            }
            joint_done += 1;
            if !self.joint_pass(&mut refused)? {
                return Ok(());
            }
            self.bad = self.uncertified();
        }
    }

    /// Rounds over the uncertified patches while something improves (at most
    /// [`MAX_ROUNDS`]; in the crease-free phase at most [`CREASE_FREE_ROUNDS`], and none
    /// after two that certify nothing more).
    fn rounds_of_moves(&mut self, fallback: bool) -> Result<()> {
        let mut phase_rounds = 0;
        let (mut fewest_bad, mut stalled) = (self.bad.len(), 0);
        let most = if fallback {
            MAX_ROUNDS
        } else {
            CREASE_FREE_ROUNDS
        };
        while !self.bad.is_empty() && phase_rounds < most {
            phase_rounds += 1;
            self.rounds += 1;
            let mut improved = false;
            let mut hubs_tried = HashSet::new();
            for t in self.bad.clone() {
                if self.verdicts[t as usize] != Verdict::Valid {
                    improved |= self.improve(t as usize, fallback, &mut hubs_tried)?;
                }
            }
            let verdicts = &self.verdicts;
            self.bad.retain(|&t| verdicts[t as usize] != Verdict::Valid);
            if self.bad.len() < fewest_bad {
                fewest_bad = self.bad.len();
                stalled = 0;
            } else {
                stalled += 1;
            }
            if (!fallback && stalled >= 2) || !improved {
                break;
            }
        }
        Ok(())
    }

    /// One patch's turn in a round: the best move of its corner groups is kept where the
    /// certificate agrees; in the fallback, where no move helps, a cut. Returns whether
    /// something changed.
    fn improve(
        &mut self,
        tri: usize,
        fallback: bool,
        hubs_tried: &mut HashSet<u32>,
    ) -> Result<bool> {
        let candidates = self.candidates(tri, fallback, hubs_tried);
        let hub = |g: u32| self.groups.corners(g).len() > HUB_CORNERS;
        hubs_tried.extend(
            candidates
                .iter()
                .flatten()
                .map(|&(g, _)| g)
                .filter(|&g| hub(g)),
        );
        let (best, scored) = self.score(candidates, fallback)?;
        // The crease-free phase prefers, among the trials of largest gain, the one with
        // the fewest uncertified patches around it where that is fewer than now (the
        // measure's grid can miss a fold the certificate sees).
        if let Some(moves) = self.fewest_of(scored)?.or(best) {
            return self.apply_moves(&moves);
        }
        if !fallback {
            return Ok(false);
        }
        // No move of one normal helps: the fan of one corner's vertex is cut along one or
        // two of its edges into two groups, each with its own normal (a new crease there),
        // kept only where the certificate counts fewer uncertified patches.
        self.cut(tri)
    }

    /// The candidate moves for patch `tri`: each of its groups towards its central normal,
    /// the face normal or the mean of the patch's corner normals, and (crease-free) to its
    /// nearest facing normals; its groups together towards the face normal; two or three
    /// of them together towards the central normal of all their faces (a sliver's close
    /// corners need nearly the same normal: their curves to the far corner must not
    /// cross), and (crease-free) each or all to their nearest facing normals.
    ///
    /// None moves a hub ([`HUB_CORNERS`]) of `tried`, those an earlier patch of the round
    /// tried: a move of a hub changes every patch around it, and tried for each of them in
    /// every round, the moves of a hub shared by n patches would cost O(n²).
    fn candidates(&self, tri: usize, fallback: bool, tried: &HashSet<u32>) -> Vec<Moves> {
        let (groups, faces, work) = (&self.groups, &self.faces, &self.work);
        let mean = work.corner_normals[tri]
            .iter()
            .copied()
            .sum::<DVec3>()
            .try_normalize();
        let own: Vec<u32> = (0..3).map(|k| groups.of_corner[3 * tri + k]).collect();
        let mut candidates: Vec<Moves> = Vec::new();
        let left_out = |g: &u32| groups.frozen.contains(g) || tried.contains(g);
        for &g in own.iter().filter(|g| !left_out(g)) {
            let cur = groups.normal(work, g);
            let f = faces_of_group(groups, faces, g);
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
        for w in WEIGHTS
            .into_iter()
            .filter(|_| !own.iter().any(|g| tried.contains(g)))
        {
            candidates.push(
                own.iter()
                    .filter(|g| !groups.frozen.contains(g))
                    .map(|&g| (g, towards(groups.normal(work, g), faces[tri], w)))
                    .collect(),
            );
        }
        let sets: [&[usize]; 4] = [&[0, 1], &[1, 2], &[2, 0], &[0, 1, 2]];
        for set in sets {
            let gs: Vec<u32> = set.iter().map(|&k| own[k]).collect();
            if gs
                .iter()
                .any(|g| gs.iter().filter(|h| *h == g).count() > 1 || left_out(g))
            {
                continue;
            }
            self.set_candidates(tri, &gs, fallback, &mut candidates);
        }
        candidates
    }

    /// The candidates of [`Self::candidates`] that move the groups `gs` of patch `tri`
    /// together.
    fn set_candidates(&self, tri: usize, gs: &[u32], fallback: bool, out: &mut Vec<Moves>) {
        let (groups, faces, work) = (&self.groups, &self.faces, &self.work);
        let f: Vec<DVec3> = gs
            .iter()
            .flat_map(|&g| groups.corners(g))
            .map(|&c| faces[c as usize / 3])
            .collect();
        let target = central(&f, faces[tri]);
        for w in WEIGHTS {
            out.push(
                gs.iter()
                    .map(|&g| (g, towards(groups.normal(work, g), target, w)))
                    .collect(),
            );
        }
        if fallback {
            return;
        }
        // Crease-free phase: the groups together, each to its nearest normal facing its
        // own triangles by a margin.
        for m in FACING_STEPS {
            let moves: Option<Moves> = gs
                .iter()
                .map(|&g| {
                    let f = faces_of_group(groups, faces, g);
                    nearest_facing(groups.normal(work, g), &f, m).map(|n| (g, n))
                })
                .collect();
            out.extend(moves);
        }
        // And one normal for all of them, the nearest to their mean facing all of their
        // triangles (a sliver's close corners).
        let mean = gs
            .iter()
            .map(|&g| groups.normal(work, g))
            .sum::<DVec3>()
            .try_normalize();
        for m in FACING_STEPS {
            if let Some(n) = mean.and_then(|x| nearest_facing(x, &f, m)) {
                out.push(gs.iter().map(|&g| (g, n)).collect());
            }
        }
    }

    /// Scores `candidates` by the gain of the measure over the patches around the moved
    /// groups (the only patches those normals change): the grid measure of level 6 in the
    /// fallback; of level 12 plus the element bound's shortfall in the crease-free phase,
    /// where a move must also keep each moved group facing its triangles (by
    /// `FACING_STEPS[0]`, or as much as before). Returns the move of largest gain, where
    /// it gains, and (crease-free) every trial.
    fn score(
        &mut self,
        candidates: Vec<Moves>,
        fallback: bool,
    ) -> Result<(Option<Moves>, Vec<Trial>)> {
        let Search {
            cx,
            work,
            groups,
            faces,
            ..
        } = self;
        let grid = if fallback {
            &cx.grids.coarse
        } else {
            &cx.grids.fine
        };
        let measure = |table: &PatchTable| cx.measure(table, grid, !fallback);
        let mut best: Option<(f64, Moves)> = None;
        let mut scored: Vec<Trial> = Vec::new();
        // The measure of each ring as it is now, by ring.
        let mut now_of: HashMap<Vec<u32>, f64> = HashMap::new();
        for moves in candidates {
            if moves
                .iter()
                .all(|&(g, n)| normal_key(n) == normal_key(groups.normal(work, g)))
            {
                continue;
            }
            // The crease-free phase keeps every corner condition it has met.
            if !fallback
                && moves.iter().any(|&(g, n)| {
                    groups.facing(g, faces, n)
                        < FACING_STEPS[0].min(groups.facing(g, faces, groups.normal(work, g)))
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
                    let x = measure(&*cx.ring_table(work, &ring)?);
                    now_of.insert(ring.clone(), x);
                    x
                }
            };
            let b = with_moves(work, groups, &moves, |w| -> Result<_> {
                Ok(measure(&*cx.ring_table(w, &ring)?))
            })?;
            let gain = now - b;
            if !fallback {
                scored.push((gain, moves.clone(), ring));
            }
            if gain > 1e-9 * now && best.as_ref().is_none_or(|(x, _)| gain > *x) {
                best = Some((gain, moves));
            }
        }
        Ok((best.map(|(_, m)| m), scored))
    }

    /// Of the [`CERTIFY_TRIALS`] trials of largest gain, the one with the fewest
    /// uncertified patches around it where that is fewer than now; each is certified only
    /// as far as it could still win.
    fn fewest_of(&mut self, mut scored: Vec<Trial>) -> Result<Option<Moves>> {
        scored.sort_by(|a, b| b.0.total_cmp(&a.0));
        let mut fewest: Option<(usize, usize)> = None;
        for (i, (_, moves, ring)) in scored.iter().take(CERTIFY_TRIALS).enumerate() {
            let was = count_uncertified(&self.verdicts, ring);
            let Some(limit) = fewest.map_or(was.checked_sub(1), |(c, _)| c.checked_sub(1)) else {
                break;
            };
            let cx = &self.cx;
            let counted = with_moves(&mut self.work, &self.groups, moves, |w| -> Result<_> {
                Ok(cx.uncertified_upto(&cx.ring_table(w, ring)?, limit))
            })?;
            if let Some(c) = counted {
                fewest = Some((c, i));
            }
        }
        Ok(fewest.map(|(_, i)| scored.swap_remove(i).1))
    }

    /// Applies `moves` where the certificate counts no more uncertified patches around
    /// them than before (it can disagree with the sampled measure); returns whether they
    /// were kept.
    fn apply_moves(&mut self, moves: &[(u32, DVec3)]) -> Result<bool> {
        let old: Moves = moves
            .iter()
            .map(|&(g, _)| (g, self.groups.normal(&self.work, g)))
            .collect();
        let mut ring = Vec::new();
        for &(g, n) in moves {
            set_group(&mut self.work, &self.groups, g, n, &mut ring);
        }
        ring.sort_unstable();
        ring.dedup();
        let was = count_uncertified(&self.verdicts, &ring);
        let Some(v) = self.cx.verdicts_upto(&self.work, &ring, was)? else {
            for &(g, n) in old.iter().rev() {
                set_group(&mut self.work, &self.groups, g, n, &mut ring);
            }
            return Ok(false);
        };
        record(&mut self.verdicts, &mut self.changed, &ring, &v);
        self.touched.extend(moves.iter().map(|&(g, _)| g));
        Ok(true)
    }

    /// Joint moves, once the rounds stall: the normals of every group within one ring of
    /// the patches left move together ([`joint_corners`]), one cluster of them at a time
    /// (those whose rings share a group), kept where the certificate counts fewer
    /// uncertified patches around them. A cluster refused before with the same normals is
    /// not tried again. Returns whether any was kept.
    fn joint_pass(&mut self, refused: &mut HashSet<Vec<u64>>) -> Result<bool> {
        let mut any = false;
        for region in self.joint_clusters() {
            let old: Moves = region
                .iter()
                .map(|&g| (g, self.groups.normal(&self.work, g)))
                .collect();
            let key: Vec<u64> = old
                .iter()
                .flat_map(|&(g, n)| std::iter::once(g as u64).chain(normal_key(n)))
                .collect();
            if refused.contains(&key) {
                continue;
            }
            let moved = joint_corners(
                &mut self.work,
                self.mesh,
                &self.groups,
                &self.faces,
                &region,
                &self.cx,
            )?;
            let mut ring: Vec<u32> = region
                .iter()
                .flat_map(|&g| self.groups.triangles_around(g))
                .collect();
            ring.sort_unstable();
            ring.dedup();
            let was = count_uncertified(&self.verdicts, &ring);
            let v = self.cx.verdicts_of(&self.work, &ring)?;
            let now = v.iter().filter(|x| **x != Verdict::Valid).count();
            if now >= was {
                let mut sink = Vec::new();
                for &(g, n) in old.iter().rev() {
                    set_group(&mut self.work, &self.groups, g, n, &mut sink);
                }
                refused.insert(key);
                continue;
            }
            record(&mut self.verdicts, &mut self.changed, &ring, &v);
            self.touched.extend(
                moved
                    .iter()
                    .zip(&old)
                    .filter(|(a, b)| a.1 != b.1)
                    .map(|(a, _)| a.0),
            );
            any = true;
        }
        Ok(any)
    }

    /// The groups within one ring of each patch left (not forced, not frozen), merged
    /// where they share a group, sorted.
    fn joint_clusters(&self) -> Vec<Vec<u32>> {
        let groups = &self.groups;
        let regions = self.bad.iter().map(|&t| {
            let mut r: Vec<u32> = (0..3)
                .map(|k| groups.of_corner[3 * t as usize + k])
                .flat_map(|g| groups.triangles_around(g).collect::<Vec<_>>())
                .flat_map(|t| (0..3).map(move |k| 3 * t as usize + k))
                .map(|c| groups.of_corner[c])
                .filter(|&g| !self.forced[g as usize] && !groups.frozen.contains(&g))
                .collect();
            r.sort_unstable();
            r.dedup();
            r
        });
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
        clusters
    }
}

/// The face normals of the triangles of group `g` (degenerate ones included).
pub(super) fn faces_of_group(groups: &Groups, faces: &[DVec3], g: u32) -> Vec<DVec3> {
    groups
        .corners(g)
        .iter()
        .map(|&c| faces[c as usize / 3])
        .collect()
}

/// Crease-free joint move of the normals of the groups `region` (a pattern search on the
/// sphere, each group in turn, 8 directions, steps from 0.2 down to 0.0125 radians):
/// lowers [`corner_shortfall`] of the triangles around them, plus the grid measure and the
/// element bound's shortfall, plus a small pull towards each group's input normal; every
/// moved group keeps facing its triangles by `FACING_STEPS[0]` (or by no less than
/// before). Returns the moved groups' new normals, `work` left with them.
fn joint_corners(
    work: &mut Mesh,
    mesh: &Mesh,
    groups: &Groups,
    faces: &[DVec3],
    region: &[u32],
    cx: &Checker,
) -> Result<Moves> {
    const PULL: f64 = 1e-3;
    let grid = &cx.grids.coarse;
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
    // (shortfall, shortfall plus the pull towards the input normal) of group i at `n`.
    let score = |work: &Mesh, i: usize, n: DVec3| -> Result<(f64, f64)> {
        let table = cx.ring_patches(work, &around[i])?;
        let short = CORNER_WEIGHT * corner_shortfall(work, &around[i])
            + badness(&table, grid)
            + cx.element.shortfall(&table);
        Ok((short, short + PULL * (1.0 - n.dot(input(region[i])))))
    };
    let mut sink = Vec::new();
    let mut step: f64 = 0.2;
    let mut sweeps = 0;
    while step >= 0.0125 && sweeps < JOINT_SWEEPS {
        sweeps += 1;
        let mut better = false;
        for (i, &g) in region.iter().enumerate() {
            let cur = groups.normal(work, g);
            let (short, now) = score(work, i, cur)?;
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
                let s = score(work, i, n)?.1;
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
