//! Levels from the screen: each edge gets as many segments as its projected length covers
//! target lengths in pixels, so a renderer gets more triangles near the camera. Both
//! triangles of an edge see the same edge, so the levels stay watertight whatever the
//! view.
//!
//! [`edge_level`] is the computation; `shaders/levels.wgsl` mirrors it on the GPU
//! (`edge_level` there), and [`crate::gpu::screen`] fills a per-edge level buffer on
//! the device with it.

use glam::{DMat4, DVec3};

use crate::mesh::{Adjacency, Mesh};
use crate::tess::layout::MAX_LEVEL;
use crate::tess::levels::{InnerRule, Levels};
use crate::{Error, Result};

/// Clip-space w at or below which a point counts as behind the eye.
pub const W_MIN: f64 = 1e-6;

/// A view for screen-space levels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScreenView {
    /// World → clip space (column vectors, as glam's).
    pub view_proj: DMat4,
    /// Viewport width and height in pixels.
    pub viewport: [f64; 2],
    /// Wanted length of an output segment, pixels.
    pub target_px: f64,
    /// Cap on every level (1..=[`MAX_LEVEL`]).
    pub max_level: u32,
}

impl ScreenView {
    /// Checks the viewport, target and cap.
    pub fn check(&self) -> Result<()> {
        let ok = self.viewport.iter().all(|&v| v.is_finite() && v > 0.0)
            && self.target_px.is_finite()
            && self.target_px > 0.0
            && (1..=MAX_LEVEL).contains(&self.max_level)
            && self.view_proj.is_finite();
        if ok {
            Ok(())
        } else {
            Err(Error::Invalid(format!(
                "screen-space levels: viewport {:?}, target {} px, level cap {}, finite matrix {} \
                 (positive sizes, a cap in 1..={MAX_LEVEL} and a finite matrix expected)",
                self.viewport,
                self.target_px,
                self.max_level,
                self.view_proj.is_finite()
            )))
        }
    }
}

/// Level of the edge from `p0` to `p1` seen through `view`: ⌈projected length in pixels /
/// target⌉, clamped to 1..=max_level. An edge with both ends behind the eye (clip w ≤
/// [`W_MIN`]) gets 1; one crossing the eye plane gets the cap. Mirrored by `edge_level` in
/// `shaders/levels.wgsl`.
pub fn edge_level(view: &ScreenView, p0: DVec3, p1: DVec3) -> u32 {
    let a = view.view_proj * p0.extend(1.0);
    let b = view.view_proj * p1.extend(1.0);
    let cap = view.max_level.max(1);
    let (ba, bb) = (a.w <= W_MIN, b.w <= W_MIN);
    if ba && bb {
        return 1;
    }
    if ba || bb {
        return cap;
    }
    // Pixels from normalised device coordinates: x and y span 2 across the viewport.
    let dx = (a.x / a.w - b.x / b.w) * 0.5 * view.viewport[0];
    let dy = (a.y / a.w - b.y / b.w) * 0.5 * view.viewport[1];
    let segments = (dx * dx + dy * dy).sqrt() / view.target_px;
    if !(segments.is_finite()) {
        return cap;
    }
    segments.ceil().clamp(1.0, cap as f64) as u32
}

/// Screen-space levels of every edge of `mesh` (inner levels by `rule`).
pub fn screen_levels(
    mesh: &Mesh,
    adjacency: &Adjacency,
    view: &ScreenView,
    rule: InnerRule,
) -> Result<Levels> {
    view.check()?;
    Levels::from_fn(mesh, adjacency, |e| edge_level(view, e.p[0], e.p[1]), rule)
}

#[cfg(test)]
mod tests {
    use crate::tess::screen::edge_level;
    use crate::ScreenView;
    use glam::{DMat4, DVec3};

    #[test]
    fn projected_length_over_target() {
        // Orthographic identity: x, y in [−1, 1] span the viewport.
        let view = ScreenView {
            view_proj: DMat4::IDENTITY,
            viewport: [200.0, 100.0],
            target_px: 10.0,
            max_level: 64,
        };
        // 0.5 in x = 50 px: 5 segments; 0.51 = 51 px: 6.
        assert_eq!(edge_level(&view, DVec3::ZERO, DVec3::new(0.5, 0.0, 0.0)), 5);
        assert_eq!(
            edge_level(&view, DVec3::ZERO, DVec3::new(0.51, 0.0, 0.0)),
            6
        );
        // 0.5 in y = 25 px: 3 segments.
        assert_eq!(edge_level(&view, DVec3::ZERO, DVec3::new(0.0, 0.5, 0.0)), 3);
        assert_eq!(edge_level(&view, DVec3::ZERO, DVec3::ZERO), 1);
        assert_eq!(
            edge_level(&view, DVec3::ZERO, DVec3::new(100.0, 0.0, 0.0)),
            64
        );
        // Behind the eye.
        let mut back = view;
        back.view_proj = DMat4::from_cols_array(&[
            1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0,
        ]);
        // w = z.
        let p = |z: f64| DVec3::new(0.1, 0.0, z);
        assert_eq!(edge_level(&back, p(-1.0), p(-2.0)), 1);
        assert_eq!(edge_level(&back, p(-1.0), p(2.0)), 64);
    }
}
