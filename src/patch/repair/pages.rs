//! Pages at a hub (every scheme, first): triangles joined to the rest of the mesh by no
//! edge of two uses, hanging at a vertex shared by many triangles (a book: n triangles
//! around one edge). Each gets its own face normal at every corner, flat.

use glam::DVec3;

use super::driver::{count_uncertified, record, Search};
use super::groups::{set_group, Groups};
use crate::mesh::adjacency::EdgeIndex;
use crate::mesh::Mesh;
use crate::patch::validity::Verdict;
use crate::Result;

impl Search<'_> {
    /// The pages of the mesh ([`pages`]), where one of their patches is uncertified: each
    /// corner of each page gets a group of its own with the page's face normal, so the
    /// page is flat and its edges straight. A page has no edge of two uses, so no smooth
    /// edge becomes a crease; its edges of more uses are straight in every use, all of
    /// them pages, so the surface stays watertight along them. One normal at the hub could
    /// not face its pages when they turn all the way around it (a crease is forced), and
    /// the search would move it for each of its n patches, with n patches around each
    /// move. Kept where the certificate counts fewer uncertified pages; their groups are
    /// then left alone by everything that follows.
    pub(super) fn flatten_pages(&mut self) -> Result<()> {
        let list = pages(self.mesh, &self.groups, &self.faces);
        let was = count_uncertified(&self.verdicts, &list);
        if was == 0 {
            return Ok(());
        }
        let Search {
            work,
            groups,
            faces,
            cx,
            verdicts,
            changed,
            ..
        } = self;
        let old: Vec<[DVec3; 3]> = list
            .iter()
            .map(|&t| work.corner_normals[t as usize])
            .collect();
        let mut splits: Vec<(u32, u32)> = Vec::new();
        let mut set = Vec::new();
        let mut sink = Vec::new();
        for &t in &list {
            for k in 0..3 {
                let c = 3 * t + k;
                let g = groups.of_corner[c as usize];
                let alone = groups.corners(g).len() == 1;
                // A corner of its own whose normal is the face normal but for rounding
                // (a page's own vertex) is flat already.
                if alone
                    && (groups.normal(work, g) - faces[t as usize])
                        .abs()
                        .max_element()
                        <= 1e-12
                {
                    continue;
                }
                let h = groups.own_group(c, &mut splits);
                set_group(work, groups, h, faces[t as usize], &mut sink);
                set.push(h);
            }
        }
        let v = cx.verdicts_of(work, &list)?;
        if v.iter().filter(|x| **x != Verdict::Valid).count() >= was {
            groups.undo_trial(work, &list, old, &splits);
            return Ok(());
        }
        record(verdicts, changed, &list, &v);
        self.splits += splits.len();
        self.pages = list.len();
        self.touched.extend(set.iter().copied());
        self.groups.frozen.extend(set.iter().copied());
        self.groups.pages.extend(set);
        self.forced.resize(self.groups.list.len(), false);
        Ok(())
    }
}

/// The pages of `mesh`: triangles with a vertex of more than
/// [`super::groups::HUB_CORNERS`] corners, a face normal (not degenerate), and no edge of
/// exactly two uses, whose edges of more uses are used by pages only (sorted).
pub(super) fn pages(mesh: &Mesh, groups: &Groups, faces: &[DVec3]) -> Vec<u32> {
    let nt = mesh.triangles.len();
    let mut page: Vec<bool> = (0..nt)
        .map(|t| {
            faces[t].length_squared() > 0.25
                && mesh.triangles[t].iter().any(|&v| groups.is_hub(v))
                && (0..3).all(|k| !groups.has_twin(3 * t as u32 + k))
        })
        .collect();
    if !page.iter().any(|&p| p) {
        return Vec::new();
    }
    // The triangles of each edge of more than two uses.
    let index = EdgeIndex::new(&mesh.triangles);
    let shared: Vec<Vec<u32>> = index
        .edges()
        .filter(|e| e.half_edges.len() > 2)
        .map(|e| e.half_edges.iter().map(|&h| h / 3).collect())
        .collect();
    // Until no page shares an edge with a triangle that is not one.
    loop {
        let mut dropped = false;
        for tris in &shared {
            if tris.iter().any(|&t| page[t as usize]) && !tris.iter().all(|&t| page[t as usize]) {
                for &t in tris {
                    dropped |= std::mem::replace(&mut page[t as usize], false);
                }
            }
        }
        if !dropped {
            break;
        }
    }
    (0..nt as u32).filter(|&t| page[t as usize]).collect()
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use super::pages;
    use crate::mesh::Mesh;
    use crate::patch::repair::groups::{Groups, HUB_CORNERS};
    use crate::LoadOptions;

    /// A book of `n` triangles around the edge from vertex 0 to vertex 1 and, where
    /// `strip`, a strip of two triangles joined by a two-use edge, the first of them on
    /// the book's edge too.
    fn book(n: usize, strip: bool) -> Mesh {
        let mut p = vec![DVec3::ZERO, DVec3::Z];
        let mut t = Vec::new();
        for k in 0..n {
            let a = std::f64::consts::TAU * (k as f64 + 0.5) / n as f64;
            p.push(DVec3::new(a.cos(), a.sin(), 0.5));
            t.push([0, 1, 2 + k as u32]);
        }
        if strip {
            let q = p.len() as u32;
            p.push(DVec3::new(2.0, 0.0, 0.5));
            p.push(DVec3::new(2.0, 1.0, 1.0));
            t.push([1, 0, q]);
            t.push([1, q, q + 1]);
        }
        Mesh::from_soup("book", &p, &t, None, &LoadOptions::default()).unwrap()
    }

    fn faces(mesh: &Mesh) -> Vec<DVec3> {
        mesh.triangles
            .iter()
            .map(|t| crate::mesh::normals::face_normal(t.map(|v| mesh.positions[v as usize])))
            .collect()
    }

    /// The pages of a book are its triangles once its edge's ends are hubs; a triangle
    /// joined to another by a two-use edge is none, nor then is any triangle sharing an
    /// edge with it.
    #[test]
    fn pages_are_the_triangles_hanging_at_a_hub() {
        let small = book(HUB_CORNERS - 1, false);
        let g = Groups::new(&small);
        assert!(pages(&small, &g, &faces(&small)).is_empty());
        let n = HUB_CORNERS + 8;
        let big = book(n, false);
        let g = Groups::new(&big);
        assert_eq!(
            pages(&big, &g, &faces(&big)),
            (0..n as u32).collect::<Vec<_>>()
        );
        // The strip's first triangle uses the book's edge: no page shares an edge with a
        // triangle that is not one, so none is left.
        let mixed = book(n, true);
        let g = Groups::new(&mixed);
        assert!(pages(&mixed, &g, &faces(&mixed)).is_empty());
    }

    /// At a hub, the triangles a new normal of a group may change are its own and those
    /// across its two-use edges there; elsewhere every triangle at the vertex.
    #[test]
    fn the_triangles_around_a_hub_group_are_its_own() {
        let n = HUB_CORNERS + 8;
        let big = book(n, true);
        let mut g = Groups::new(&big);
        // Every corner at vertex 0 has the one estimated normal: one group, the n pages'
        // corners and the strip's first triangle's.
        let g0 = g.of_corner[0];
        assert_eq!(g.corners(g0).len(), n + 1);
        // That triangle (n) alone in a group: at vertex 0 its edges are the book's edge
        // (n + 1 uses) and one of one use, so no patch across them changes with it.
        let c = 3 * n as u32 + 1;
        assert_eq!(mixed_corner(&big, c), 0);
        let h = g.split(g0, &[c]);
        let mut around: Vec<u32> = g.triangles_around(h).collect();
        around.sort_unstable();
        assert_eq!(around, vec![n as u32]);
        // The rest of the group: its n pages.
        assert_eq!(g.triangles_around(g0).count(), n);
        // Below the hub size, every triangle at the vertex: 4 pages and the strip's one.
        let small = book(4, true);
        let mut g = Groups::new(&small);
        let g0 = g.of_corner[0];
        let h = g.split(g0, &[3 * 4 + 1]);
        assert_eq!(g.triangles_around(h).count(), 5);
    }

    /// The vertex of corner `c` of `mesh`.
    fn mixed_corner(mesh: &Mesh, c: u32) -> u32 {
        mesh.triangles[c as usize / 3][c as usize % 3]
    }
}
