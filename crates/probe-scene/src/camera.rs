//! Pinhole perspective cameras.

use crate::geometry::Ray;
use glam::{Vec2, Vec3};

/// A pinhole perspective camera in world space.
///
/// `forward` and `up` are unit length and orthogonal; the camera's right is `forward × up`
/// (right-handed, as glTF: a camera with `forward = −Z`, `up = +Y` has `right = +X`).
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    /// The camera's name (from the file, or `"default"` for computed and built-in poses).
    pub name: String,
    /// The eye position, world space.
    pub position: Vec3,
    /// Unit viewing direction.
    pub forward: Vec3,
    /// Unit up direction, orthogonal to `forward`.
    pub up: Vec3,
    /// Vertical field of view in radians.
    pub yfov: f32,
    /// The width / height ratio the file asks for, if any. [`Camera::ray`] uses the image's own
    /// `width / height` instead, so callers wanting this ratio choose image sizes to match.
    pub aspect: Option<f32>,
}

impl Camera {
    /// A camera at `position` looking at `target`, with `up` as the approximate up direction
    /// (made orthogonal to the view direction) and vertical field of view `yfov` in radians.
    /// Named `"look_at"`; without an aspect ratio.
    ///
    /// When `up` is parallel to the view direction another up is chosen (`+Z`, or `+X` if that
    /// is parallel too); when `target == position` the camera looks along `−Z`.
    pub fn look_at(position: Vec3, target: Vec3, up: Vec3, yfov: f32) -> Camera {
        let forward = (target - position).try_normalize().unwrap_or(Vec3::NEG_Z);
        let right = [up, Vec3::Z, Vec3::X]
            .into_iter()
            .find_map(|candidate| forward.cross(candidate).try_normalize())
            .unwrap_or(Vec3::X);
        Camera {
            name: "look_at".to_owned(),
            position,
            forward,
            up: right.cross(forward),
            yfov,
            aspect: None,
        }
    }

    /// The unit right direction, `forward × up`.
    pub fn right(&self) -> Vec3 {
        self.forward.cross(self.up)
    }

    /// The primary ray through pixel `(pixel_x, pixel_y)` of a `width × height` image, where
    /// pixel `(0, 0)` is the top-left one and `jitter` is the offset from the pixel's centre in
    /// pixels (`Vec2::ZERO` for the centre, components in `[−0.5, 0.5)` to stay inside the
    /// pixel). The aspect ratio is `width / height`.
    pub fn ray(&self, pixel_x: u32, pixel_y: u32, width: u32, height: u32, jitter: Vec2) -> Ray {
        let width = width.max(1) as f32;
        let height = height.max(1) as f32;
        let tan_half = (0.5 * self.yfov).tan();
        let ndc_x = 2.0 * (pixel_x as f32 + 0.5 + jitter.x) / width - 1.0;
        let ndc_y = 1.0 - 2.0 * (pixel_y as f32 + 0.5 + jitter.y) / height;
        let direction = self.forward
            + self.right() * (ndc_x * tan_half * width / height)
            + self.up * (ndc_y * tan_half);
        Ray::new(self.position, direction)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn look_at_is_orthonormal() {
        let c = Camera::look_at(
            Vec3::new(0.0, 1.0, 5.0),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::Y,
            1.0,
        );
        assert!((c.forward - Vec3::NEG_Z).length() < 1e-6);
        assert!((c.up - Vec3::Y).length() < 1e-6);
        assert!((c.right() - Vec3::X).length() < 1e-6);
        let straight_down = Camera::look_at(Vec3::Y, Vec3::ZERO, Vec3::Y, 1.0);
        assert!(straight_down.up.is_normalized());
        assert!(straight_down.up.dot(straight_down.forward).abs() < 1e-6);
    }

    #[test]
    fn pixel_rays() {
        let c = Camera::look_at(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 90f32.to_radians());
        // The centre of a 2×2 image lies on the pixel corners; pixel (0,0) is top-left.
        let top_left = c.ray(0, 0, 2, 2, Vec2::ZERO);
        assert!(top_left.direction.x < 0.0 && top_left.direction.y > 0.0);
        let bottom_right = c.ray(1, 1, 2, 2, Vec2::ZERO);
        assert!(bottom_right.direction.x > 0.0 && bottom_right.direction.y < 0.0);
        // The top edge of the image is at 45° with a 90° vertical field of view.
        let edge = c.ray(0, 0, 1, 1, Vec2::new(0.0, -0.5));
        assert!((edge.direction.y - edge.direction.z.abs()).abs() < 1e-6);
        let centre = c.ray(0, 0, 1, 1, Vec2::ZERO);
        assert!((centre.direction - Vec3::NEG_Z).length() < 1e-6);
    }
}
