//! Edge adjacency: which triangles use each edge, and what is wrong with the topology.

/// One use of an edge by a triangle: the triangle and its local edge k (from corner k to
/// corner k+1).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EdgeUse {
    pub triangle: u32,
    pub local: u8,
}

/// An undirected edge between welded vertices `v[0] < v[1]` and its uses.
#[derive(Clone, Debug)]
pub struct MeshEdge {
    pub v: [u32; 2],
    pub uses: Vec<EdgeUse>,
}

impl MeshEdge {
    /// Used by exactly two triangles.
    pub fn is_interior(&self) -> bool {
        self.uses.len() == 2
    }
}

/// Edges of a triangle mesh with the counts the statistics report.
#[derive(Clone, Debug, Default)]
pub struct Adjacency {
    pub edges: Vec<MeshEdge>,
    /// Edges used by exactly two triangles.
    pub interior: usize,
    /// Edges used by one triangle.
    pub boundary: usize,
    /// Edges used by three or more triangles.
    pub nonmanifold: usize,
    /// Interior edges whose two triangles run along it in the same direction (inconsistent
    /// orientation).
    pub misoriented: usize,
}

impl Adjacency {
    pub fn new(triangles: &[[u32; 3]]) -> Adjacency {
        let mut uses: Vec<(u32, u32, EdgeUse)> = Vec::with_capacity(triangles.len() * 3);
        for (t, tri) in triangles.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                uses.push((
                    a.min(b),
                    a.max(b),
                    EdgeUse {
                        triangle: t as u32,
                        local: k as u8,
                    },
                ));
            }
        }
        uses.sort_unstable_by_key(|&(a, b, u)| (a, b, u.triangle, u.local));
        let mut adj = Adjacency::default();
        let mut i = 0;
        while i < uses.len() {
            let (a, b, _) = uses[i];
            let mut j = i;
            while j < uses.len() && uses[j].0 == a && uses[j].1 == b {
                j += 1;
            }
            let edge = MeshEdge {
                v: [a, b],
                uses: uses[i..j].iter().map(|u| u.2).collect(),
            };
            match edge.uses.len() {
                1 => adj.boundary += 1,
                2 => {
                    adj.interior += 1;
                    let dir = |u: EdgeUse| triangles[u.triangle as usize][u.local as usize] == a;
                    if dir(edge.uses[0]) == dir(edge.uses[1]) {
                        adj.misoriented += 1;
                    }
                }
                _ => adj.nonmanifold += 1,
            }
            adj.edges.push(edge);
            i = j;
        }
        adj
    }

    /// The interior (two-triangle) edges.
    pub fn interior_edges(&self) -> impl Iterator<Item = &MeshEdge> {
        self.edges.iter().filter(|e| e.is_interior())
    }
}
