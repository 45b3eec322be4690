//! Relaxation, after the search: as little as needed. Normals go back towards their input
//! values, cuts are undone and split groups joined again, wherever the patches around stay
//! certified.

use std::collections::HashMap;

use glam::DVec3;

use super::driver::{count_uncertified, record, store, Search};
use super::geometry::{angle_deg, nearest_facing, towards};
use super::groups::set_group;
use super::search::FACING_STEPS;
use crate::mesh::creases::normal_key;
use crate::Result;

/// Groups whose normal changed, with the angle of the change in degrees, largest first.
type Moved = Vec<(f64, u32)>;

impl Search<'_> {
    /// Every step of the relaxation, in order (those after a flattening cascade only where
    /// one ran).
    pub(super) fn relax(&mut self) -> Result<()> {
        if self.flattened > 0 {
            self.restore_vertices()?;
        }
        let moved = self.moved();
        self.move_back(&moved)?;
        self.undo_cuts()?;
        if self.flattened > 0 {
            self.regroup()?;
        }
        self.move_back_together(&moved)
    }

    /// After a cascade, each touched vertex (largest change first) goes back to its input
    /// normals at every corner, cuts and flat corners undone, where every patch around it
    /// stays certified.
    fn restore_vertices(&mut self) -> Result<()> {
        let (groups, mesh) = (&self.groups, self.mesh);
        let mut at: HashMap<u32, f64> = HashMap::new();
        for &g in &self.touched {
            let a = angle_deg(groups.normal(mesh, g), groups.normal(&self.work, g));
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
            self.restore_vertex(v)?;
        }
        Ok(())
    }

    /// Vertex `v` back to its input normals at every corner where every patch around it
    /// stays certified (not at a fin's vertex, nor where a patch around is uncertified).
    fn restore_vertex(&mut self, v: u32) -> Result<()> {
        let (groups, mesh, work) = (&self.groups, self.mesh, &mut self.work);
        let at = &groups.at_vertex[v as usize];
        if at.iter().any(|&g| groups.at_fin(g)) {
            return Ok(());
        }
        let corners: Vec<u32> = at
            .iter()
            .flat_map(|&g| groups.corners(g).iter().copied())
            .collect();
        let mut ring: Vec<u32> = corners.iter().map(|&c| c / 3).collect();
        ring.sort_unstable();
        ring.dedup();
        if count_uncertified(&self.verdicts, &ring) > 0 {
            return Ok(());
        }
        let old: Vec<DVec3> = corners
            .iter()
            .map(|&c| work.corner_normals[c as usize / 3][c as usize % 3])
            .collect();
        for &c in &corners {
            let (t, k) = (c as usize / 3, c as usize % 3);
            work.corner_normals[t][k] = mesh.corner_normals[t][k];
        }
        if let Some(v) = self.cx.verdicts_upto(work, &ring, 0)? {
            store(&mut self.verdicts, &ring, &v);
        } else {
            for (&c, &n) in corners.iter().zip(&old) {
                work.corner_normals[c as usize / 3][c as usize % 3] = n;
            }
        }
        Ok(())
    }

    /// The touched groups whose normal is not the input's, largest change first.
    fn moved(&self) -> Moved {
        let (groups, mesh) = (&self.groups, self.mesh);
        let mut moved: Moved = self
            .touched
            .iter()
            .map(|&g| {
                (
                    angle_deg(groups.normal(mesh, g), groups.normal(&self.work, g)),
                    g,
                )
            })
            .filter(|&(a, _)| a > 0.0)
            .collect();
        moved.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        moved
    }

    /// Each moved normal (largest change first) goes back to its input value, or 3/4,
    /// 1/2 or 1/4 of the way there, or to its nearest normal to the input facing its
    /// triangles by a margin, the option nearest to the input where every patch around it
    /// stays certified.
    fn move_back(&mut self, moved: &Moved) -> Result<()> {
        for &(_, g) in moved {
            if self.groups.at_fin(g) {
                continue;
            }
            let mut ring: Vec<u32> = self.groups.triangles_around(g).collect();
            ring.sort_unstable();
            ring.dedup();
            let was = count_uncertified(&self.verdicts, &ring);
            if was > 0 {
                // Around a patch still uncertified the search's normals stay: they are the
                // best it found for that patch's neighbourhood.
                continue;
            }
            let cur = self.groups.normal(&self.work, g);
            for n in self.options_back(g) {
                let mut sink = Vec::new();
                set_group(&mut self.work, &self.groups, g, n, &mut sink);
                if let Some(v) = self.cx.verdicts_upto(&self.work, &ring, was)? {
                    store(&mut self.verdicts, &ring, &v);
                    break;
                }
                set_group(&mut self.work, &self.groups, g, cur, &mut sink);
            }
        }
        Ok(())
    }

    /// The normals [`Self::move_back`] tries for group `g`, nearest to the input first,
    /// each nearer than its normal now.
    fn options_back(&self, g: u32) -> Vec<DVec3> {
        let groups = &self.groups;
        let (n0, cur) = (groups.normal(self.mesh, g), groups.normal(&self.work, g));
        // A cut group goes at most 3/4 of the way (all the way would give both of its
        // groups one normal, undoing the cut, which the next pass decides).
        let cut = self.in_cuts.contains(&g);
        let ws: &[f64] = if cut {
            &[0.75, 0.5, 0.25]
        } else {
            &[1.0, 0.75, 0.5, 0.25]
        };
        // Also the nearest normals to the input one that face all of the group's
        // triangles by a margin (the corner condition; not for a cut's groups): tried with
        // the others, nearest to the input first.
        let mut options: Vec<DVec3> = ws.iter().map(|&w| towards(cur, n0, w)).collect();
        if !cut {
            let f: Vec<DVec3> = groups.face_normals(g, &self.faces).collect();
            options.extend(
                FACING_STEPS
                    .iter()
                    .filter_map(|&m| nearest_facing(n0, &f, m)),
            );
        }
        let far = angle_deg(n0, cur);
        options.retain(|&n| angle_deg(n0, n) < far);
        options.sort_by(|a, b| angle_deg(n0, *a).total_cmp(&angle_deg(n0, *b)));
        options
    }

    /// Each cut, latest first, is undone (both groups back to their input normal, the
    /// creases gone) where the certificate then counts no more uncertified patches.
    fn undo_cuts(&mut self) -> Result<()> {
        for &[g, h] in self.cuts.iter().rev() {
            let (groups, work) = (&self.groups, &mut self.work);
            let n0 = groups.normal(self.mesh, g);
            let old = [groups.normal(work, g), groups.normal(work, h)];
            let mut ring: Vec<u32> = groups.triangles_around(g).collect();
            ring.sort_unstable();
            ring.dedup();
            let was = count_uncertified(&self.verdicts, &ring);
            let mut sink = Vec::new();
            set_group(work, groups, g, n0, &mut sink);
            set_group(work, groups, h, n0, &mut sink);
            if let Some(v) = self.cx.verdicts_upto(work, &ring, was)? {
                store(&mut self.verdicts, &ring, &v);
                self.splits -= 1;
            } else {
                set_group(work, groups, g, old[0], &mut sink);
                set_group(work, groups, h, old[1], &mut sink);
            }
        }
        Ok(())
    }

    /// After a cascade, the creases it made that are no longer needed: at each touched
    /// vertex, the groups that were one normal group in the input get one normal again
    /// (their corners' mean normal, or one of theirs), where every patch around stays
    /// certified.
    fn regroup(&mut self) -> Result<()> {
        let mut verts: Vec<u32> = self
            .touched
            .iter()
            .map(|&g| self.groups.vertex[g as usize])
            .collect();
        verts.sort_unstable();
        verts.dedup();
        for v in verts {
            let at = self.groups.at_vertex[v as usize].clone();
            if at.iter().any(|&g| self.groups.at_fin(g)) {
                continue;
            }
            let ring = self.groups.triangles(at.iter().copied());
            if count_uncertified(&self.verdicts, &ring) > 0 {
                continue;
            }
            // Groups of the vertex by their input normal (one input group each).
            let mut parts: Vec<([u64; 3], Vec<u32>)> = Vec::new();
            for &g in &at {
                let key = normal_key(self.groups.normal(self.mesh, g));
                match parts.iter_mut().find(|(k, _)| *k == key) {
                    Some((_, list)) => list.push(g),
                    None => parts.push((key, vec![g])),
                }
            }
            for (_, part) in parts {
                self.join(&part, &ring)?;
            }
        }
        Ok(())
    }

    /// The groups `part` (one input group) get one normal again, the mean of their
    /// corners' normals or one of theirs, the first that keeps every patch of `ring`
    /// certified.
    fn join(&mut self, part: &[u32], ring: &[u32]) -> Result<()> {
        let (groups, work) = (&self.groups, &mut self.work);
        let now: Vec<DVec3> = part.iter().map(|&g| groups.normal(work, g)).collect();
        if now.iter().all(|n| normal_key(*n) == normal_key(now[0])) {
            return Ok(());
        }
        let mean = part
            .iter()
            .map(|&g| groups.normal(work, g) * groups.corners(g).len() as f64)
            .sum::<DVec3>()
            .try_normalize();
        let mut options: Vec<DVec3> = mean.into_iter().collect();
        options.extend(now.iter().copied());
        let mut sink = Vec::new();
        for n in options {
            for &g in part {
                set_group(work, groups, g, n, &mut sink);
            }
            if let Some(vs) = self.cx.verdicts_upto(work, ring, 0)? {
                record(&mut self.verdicts, &mut self.changed, ring, &vs);
                break;
            }
            for (&g, &n) in part.iter().zip(&now) {
                set_group(work, groups, g, n, &mut sink);
            }
        }
        Ok(())
    }

    /// Last, the moved groups of one triangle together (two close corners of a sliver
    /// need nearly one normal, so neither goes back alone): each to its nearest normal to
    /// the input facing its triangles by a margin, or all to the nearest one to the mean
    /// of their input normals facing all of their triangles, or each a fraction of the way
    /// back; the option with the smallest largest change that the certificate accepts.
    fn move_back_together(&mut self, moved: &Moved) -> Result<()> {
        let groups = &self.groups;
        let mut gs: Vec<u32> = moved
            .iter()
            .map(|&(_, g)| g)
            .filter(|g| {
                !self.in_cuts.contains(g) && !groups.frozen.contains(g) && !groups.at_fin(*g)
            })
            .collect();
        gs.sort_unstable();
        let mut by_triangle: Vec<Vec<u32>> = Vec::new();
        for t in groups.triangles(gs.iter().copied()) {
            let own: Vec<u32> = (0..3)
                .map(|k| groups.of_corner[3 * t as usize + k])
                .filter(|g| gs.binary_search(g).is_ok())
                .collect();
            if own.len() >= 2 {
                by_triangle.push(own);
            }
        }
        for own in &by_triangle {
            self.move_back_group(own)?;
        }
        Ok(())
    }

    /// [`Self::move_back_together`] for the groups `own` of one triangle.
    fn move_back_group(&mut self, own: &[u32]) -> Result<()> {
        let (groups, work) = (&self.groups, &mut self.work);
        let cur: Vec<DVec3> = own.iter().map(|&g| groups.normal(work, g)).collect();
        let n0: Vec<DVec3> = own.iter().map(|&g| groups.normal(self.mesh, g)).collect();
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
        if count_uncertified(&self.verdicts, &ring) > 0 {
            return Ok(());
        }
        let faces_of = |gs: &[u32]| -> Vec<DVec3> {
            gs.iter()
                .flat_map(|&g| groups.face_normals(g, &self.faces))
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
                set_group(work, groups, g, n, &mut sink);
            }
            if let Some(v) = self.cx.verdicts_upto(work, &ring, 0)? {
                store(&mut self.verdicts, &ring, &v);
                break;
            }
            for (&g, &n) in own.iter().zip(&cur) {
                set_group(work, groups, g, n, &mut sink);
            }
        }
        Ok(())
    }
}
