//! The orthographic camera of the pictures: an orthonormal frame (right, up, towards the
//! viewer) and the map into clip space fitted to the surface's bounding box in that frame.

use glam::DVec3;

use crate::{Error, Result};

/// Margin around the surface: the larger half-extent across the view is scaled by this
/// (4 %), so the surface never touches the panel's border.
pub const MARGIN: f64 = 1.04;

/// Margin of the depth range (2 %), so the nearest and farthest points are not clipped.
pub const DEPTH_MARGIN: f64 = 1.02;

/// An orthographic camera looking along −`towards`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Picture x (to the right), unit.
    pub right: DVec3,
    /// Picture y (up), unit.
    pub up: DVec3,
    /// From the surface towards the viewer, unit.
    pub towards: DVec3,
    /// Centre of the bounding box, in (right, up, towards) coordinates.
    pub centre: DVec3,
    /// Half side of the square view (half the larger extent across the view, with
    /// `MARGIN`).
    pub half_extent: f64,
    /// Half of the depth range (with `DEPTH_MARGIN`).
    pub half_depth: f64,
}

impl Camera {
    /// The camera looking along −`view`, with `up` projected perpendicular to it (any
    /// perpendicular when `up` is along `view`), fitted to `positions`.
    pub fn fit(positions: &[DVec3], view: DVec3, up: DVec3) -> Result<Camera> {
        let [x, y, z] = Camera::frame(view, up)?;
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for p in positions {
            let q = DVec3::new(p.dot(x), p.dot(y), p.dot(z));
            lo = lo.min(q);
            hi = hi.max(q);
        }
        Camera::from_extent([x, y, z], lo, hi)
    }

    /// The camera's frame (right, up, towards the viewer) for looking along −`view` with
    /// `up` projected perpendicular to it (any perpendicular when `up` is along `view`).
    pub fn frame(view: DVec3, up: DVec3) -> Result<[DVec3; 3]> {
        let z = view
            .try_normalize()
            .ok_or_else(|| Error::Invalid("render: the view direction is zero".into()))?;
        let mut up = up - up.dot(z) * z;
        if up.length() < 1e-9 {
            // Up along the view: take any perpendicular.
            up = z.any_orthonormal_vector();
        }
        let y = up.normalize();
        Ok([y.cross(z), y, z])
    }

    /// The camera of `frame` ([`Camera::frame`]) fitted to a surface whose coordinates along
    /// the frame's axes span `lo..hi` (e.g. the extent a GPU pass found).
    pub fn from_extent(frame: [DVec3; 3], lo: DVec3, hi: DVec3) -> Result<Camera> {
        let [x, y, z] = frame;
        if !lo.is_finite() || !hi.is_finite() || lo.cmpgt(hi).any() {
            return Err(Error::Invalid("render: empty or non-finite surface".into()));
        }
        let half = 0.5 * (hi - lo);
        Ok(Camera {
            right: x,
            up: y,
            towards: z,
            centre: 0.5 * (lo + hi),
            // Square panels: the larger of the two extents. The floor keeps a point or a
            // flat surface drawable (no division by zero).
            half_extent: (half.x.max(half.y) * MARGIN).max(1e-300),
            half_depth: (half.z * DEPTH_MARGIN).max(1e-300),
        })
    }

    /// Clip coordinates of `p`: x and y in [−1, 1] across the panel (y up), depth in
    /// [0, 1] with nearer points (larger p·towards) smaller.
    pub fn clip(&self, p: DVec3) -> DVec3 {
        DVec3::new(
            (p.dot(self.right) - self.centre.x) / self.half_extent,
            (p.dot(self.up) - self.centre.y) / self.half_extent,
            0.5 - (p.dot(self.towards) - self.centre.z) * (0.5 / self.half_depth),
        )
    }

    /// [`Camera::clip`] as the shader's three rows: clip_i = dot(row_i.xyz, p) + row_i.w.
    pub fn rows(&self) -> [[f32; 4]; 3] {
        let row = |axis: DVec3, centre: f64, scale: f64, offset: f64| -> [f32; 4] {
            [
                (axis.x * scale) as f32,
                (axis.y * scale) as f32,
                (axis.z * scale) as f32,
                (offset - centre * scale) as f32,
            ]
        };
        let e = self.half_extent;
        [
            row(self.right, self.centre.x, 1.0 / e, 0.0),
            row(self.up, self.centre.y, 1.0 / e, 0.0),
            row(self.towards, self.centre.z, -0.5 / self.half_depth, 0.5),
        ]
    }
}
