//! Normal groups (the corners of one vertex that carry bitwise the same normal), which
//! every step of the repair moves as one.

use std::collections::HashSet;

use glam::DVec3;

use crate::mesh::creases::normal_key;
use crate::mesh::Mesh;

/// Normal groups: the corners of one vertex that carry bitwise the same normal.
pub(super) struct Groups {
    /// Group of corner 3t + k.
    pub(super) of_corner: Vec<u32>,
    /// Corners of each group.
    pub(super) list: Vec<Vec<u32>>,
    pub(super) vertex: Vec<u32>,
    /// Groups of each vertex.
    pub(super) at_vertex: Vec<Vec<u32>>,
    /// Groups whose normal no later step of the search changes (those of an isolated
    /// triangle, `fallback.rs`, and of a split fin, `fins.rs`); only the last passes move
    /// the isolated ones back towards their input.
    pub(super) frozen: HashSet<u32>,
    /// Vertices of the doubled triangles split off the surface (`fins.rs`): the passes
    /// that move normals back leave every group there alone, and the flattening makes
    /// every corner there flat.
    pub(super) fins: HashSet<u32>,
    /// Groups of the pages flattened at a hub (`pages.rs`): the passes that move normals
    /// back leave them alone.
    pub(super) pages: HashSet<u32>,
    /// Corners at each vertex, all its groups together.
    corners_at: Vec<u32>,
    /// For each half-edge 3t + k of an edge used by exactly two triangles, the other use's
    /// half-edge; `u32::MAX` otherwise.
    twins: Vec<u32>,
}

/// Corners of a vertex above which it is a hub: a new normal of one of its groups changes
/// the patches of that group's triangles and of those across their two-use edges there,
/// which [`Groups::triangles_around`] then lists, instead of every triangle at the vertex
/// (n at a vertex shared by n triangles: listed for each of its n groups, O(n²)). The
/// vertices of the test meshes have at most 11 corners.
pub(super) const HUB_CORNERS: usize = 32;

impl Groups {
    pub(super) fn new(mesh: &Mesh) -> Groups {
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
            pages: HashSet::new(),
            corners_at: (0..nv).map(|v| count[v + 1] - count[v]).collect(),
            twins: super::geometry::twins(mesh),
        }
    }

    /// Whether group `g` is at a vertex of a split fin ([`Self::fins`]) or a flattened
    /// page's ([`Self::pages`]): the passes that move normals back leave it alone.
    pub(super) fn at_fin(&self, g: u32) -> bool {
        self.fins.contains(&self.vertex[g as usize]) || self.pages.contains(&g)
    }

    /// The group of corner `c` alone: its own group, or one split off for it (the split
    /// pushed on `splits` for [`Groups::undo_trial`]).
    pub(super) fn own_group(&mut self, c: u32, splits: &mut Vec<(u32, u32)>) -> u32 {
        let g = self.of_corner[c as usize];
        if self.corners(g).len() == 1 {
            return g;
        }
        let h = self.split(g, &[c]);
        splits.push((g, h));
        h
    }

    /// Undoes a trial: the corner normals of `tris` back to `old` (in order) and the
    /// `splits` made for it unsplit, last first.
    pub(super) fn undo_trial(
        &mut self,
        work: &mut Mesh,
        tris: &[u32],
        old: Vec<[glam::DVec3; 3]>,
        splits: &[(u32, u32)],
    ) {
        for (&t, n) in tris.iter().zip(old) {
            work.corner_normals[t as usize] = n;
        }
        for &(g, h) in splits.iter().rev() {
            self.unsplit(g, h);
        }
    }

    /// Whether vertex `v` is a hub ([`HUB_CORNERS`]).
    pub(super) fn is_hub(&self, v: u32) -> bool {
        self.corners_at[v as usize] as usize > HUB_CORNERS
    }

    /// Whether half-edge `h` is a use of an edge of exactly two uses.
    pub(super) fn has_twin(&self, h: u32) -> bool {
        self.twins[h as usize] != u32::MAX
    }

    pub(super) fn corners(&self, g: u32) -> &[u32] {
        &self.list[g as usize]
    }

    /// The triangles with a corner in one of the groups `gs`, sorted, each once.
    pub(super) fn triangles(&self, gs: impl IntoIterator<Item = u32>) -> Vec<u32> {
        let mut tris: Vec<u32> = gs
            .into_iter()
            .flat_map(|g| self.corners(g).iter().map(|&c| c / 3))
            .collect();
        tris.sort_unstable();
        tris.dedup();
        tris
    }

    /// The triangles around the vertices of `tri` (sorted, each once).
    pub(super) fn ring(&self, tri: [u32; 3]) -> Vec<u32> {
        self.triangles(
            tri.iter()
                .flat_map(|&v| self.at_vertex[v as usize].iter().copied()),
        )
    }

    /// Moves the corners `b` of group `g` into a new group (a new crease at its vertex);
    /// returns the new group.
    pub(super) fn split(&mut self, g: u32, b: &[u32]) -> u32 {
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
    pub(super) fn unsplit(&mut self, g: u32, h: u32) {
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
    /// sides' normals); at a hub ([`HUB_CORNERS`]) only those that do change: the
    /// triangles of `g` and those across their two-use edges at the vertex (a patch is
    /// built from its own corners' normals and the curves it shares across two-use edges).
    pub(super) fn triangles_around(&self, g: u32) -> Box<dyn Iterator<Item = u32> + '_> {
        let v = self.vertex[g as usize] as usize;
        if self.corners_at[v] as usize <= HUB_CORNERS {
            return Box::new(
                self.at_vertex[v]
                    .iter()
                    .flat_map(|&h| self.list[h as usize].iter().map(|&c| c / 3)),
            );
        }
        // The half-edges of a corner's triangle at the vertex: the one leaving it and the
        // one arriving there.
        let across =
            move |h: u32| (self.twins[h as usize] != u32::MAX).then(|| self.twins[h as usize] / 3);
        Box::new(self.list[g as usize].iter().flat_map(move |&c| {
            let arriving = c - c % 3 + (c % 3 + 2) % 3;
            [Some(c / 3), across(c), across(arriving)]
                .into_iter()
                .flatten()
        }))
    }

    /// The face normals (`faces`, by triangle) of the triangles of group `g`, less those
    /// of degenerate triangles (a zero normal: they face every way).
    pub(super) fn face_normals<'a>(
        &'a self,
        g: u32,
        faces: &'a [DVec3],
    ) -> impl Iterator<Item = DVec3> + 'a {
        self.corners(g)
            .iter()
            .map(|&c| faces[c as usize / 3])
            .filter(|x| x.length_squared() > 0.25)
    }

    /// The smallest cosine of `n` to [`Self::face_normals`] of group `g` (+∞ for none).
    pub(super) fn facing(&self, g: u32, faces: &[DVec3], n: DVec3) -> f64 {
        self.face_normals(g, faces)
            .map(|x| x.dot(n))
            .fold(f64::INFINITY, f64::min)
    }

    /// The normal of group `g` in `mesh`.
    pub(super) fn normal(&self, mesh: &Mesh, g: u32) -> DVec3 {
        let c = self.list[g as usize][0] as usize;
        mesh.corner_normals[c / 3][c % 3]
    }
}

/// Sets the normal of every corner of group `g` to `n`, listing the triangles whose patch
/// may change ([`Groups::triangles_around`]).
pub(super) fn set_group(work: &mut Mesh, groups: &Groups, g: u32, n: DVec3, tris: &mut Vec<u32>) {
    for &c in groups.corners(g) {
        work.corner_normals[c as usize / 3][c as usize % 3] = n;
    }
    tris.extend(groups.triangles_around(g));
}

/// `f` on `work` with the group normals of `moves` set, the previous normals put back
/// after it (in reverse order, so a group moved twice gets its first normal back).
pub(super) fn with_moves<T>(
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
