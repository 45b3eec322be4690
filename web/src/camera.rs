//! The orbit camera: a perspective view of the mesh's bounding sphere.

use g1tess::glam::{Mat4, Quat, Vec3};

/// Eye, target, up and vertical field of view; near and far planes from the mesh's
/// bounding sphere.
#[derive(Clone, Copy, Debug)]
pub struct Camera {
    pub eye: Vec3,
    pub target: Vec3,
    pub up: Vec3,
    pub fovy_deg: f32,
    /// The bounding sphere's centre and radius (near and far planes).
    pub centre: Vec3,
    pub radius: f32,
}

impl Camera {
    /// Looks at the sphere (`centre`, `radius`) along −z with y up, filling the view.
    pub fn fit(centre: Vec3, radius: f32) -> Camera {
        let radius = if radius > 0.0 { radius } else { 1.0 };
        let fovy_deg = 40.0f32;
        let distance = 1.1 * radius / (fovy_deg.to_radians() / 2.0).sin();
        Camera {
            eye: centre + Vec3::Z * distance,
            target: centre,
            up: Vec3::Y,
            fovy_deg,
            centre,
            radius,
        }
    }

    /// The view-projection matrix (right-handed, depth 0..1) for `aspect` = width / height:
    /// near and far enclose the bounding sphere with a margin of one radius.
    pub fn view_proj(&self, aspect: f32) -> Mat4 {
        let view = Mat4::look_at_rh(self.eye, self.target, self.up);
        let distance = (self.centre - self.eye).length();
        let far = distance + 2.0 * self.radius;
        let near = (distance - 2.0 * self.radius).max(far * 1e-4);
        let proj = Mat4::perspective_rh(self.fovy_deg.to_radians(), aspect, near, far);
        proj * view
    }

    /// Turns the eye about the target: `dx` about the up axis, `dy` about the right axis
    /// (radians), never past the poles.
    pub fn orbit(&mut self, dx: f32, dy: f32) {
        let up = self.up.normalize_or(Vec3::Y);
        let offset = self.eye - self.target;
        let turned = Quat::from_axis_angle(up, -dx) * offset;
        let right = turned.cross(up).normalize_or(Vec3::X);
        let tilted = Quat::from_axis_angle(right, -dy) * turned;
        // Keep at least ~3° from the up axis.
        let cos = tilted.normalize_or_zero().dot(up).abs();
        self.eye = self.target + if cos < 0.9986 { tilted } else { turned };
    }

    /// Moves the eye towards the target by the factor `scale` (below 1: closer).
    pub fn zoom(&mut self, scale: f32) {
        let offset = (self.eye - self.target) * scale.clamp(0.05, 20.0);
        let least = self.radius * 1e-3;
        self.eye = self.target + offset.normalize_or(Vec3::Z) * offset.length().max(least);
    }
}
