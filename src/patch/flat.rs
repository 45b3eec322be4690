//! The flat triangle (degree-1 Bézier), the baseline every curved scheme is measured
//! against. Its normal is the face normal; its distance to a curved surface falls as h².

use glam::DVec3;

use super::{SchemeOptions, TriangleBuilder};
use crate::mesh::Mesh;
use crate::Result;

struct FlatBuilder<'a>(&'a Mesh);

impl TriangleBuilder for FlatBuilder<'_> {
    /// The three corners (`bezier_powers(1)` order: P_0, P_1, P_2); no fallbacks.
    fn build(&self, t: usize, out: &mut [DVec3]) -> usize {
        for (o, v) in out.iter_mut().zip(self.0.triangles[t]) {
            *o = self.0.positions[v as usize];
        }
        0
    }
}

/// The scheme prepared for `mesh`.
pub fn prepare<'a>(mesh: &'a Mesh, _: &SchemeOptions) -> Result<Box<dyn TriangleBuilder + 'a>> {
    Ok(Box::new(FlatBuilder(mesh)))
}
