//! Set-up shared by the integration tests.

use glam::Vec3;
use probe_scene::{Camera, Scene};

/// Four cameras at mid height near the corners of `scene`'s bounds, each looking level at
/// the centre: a small view set whose views see different parts of a room.
pub fn corner_cameras(scene: &Scene) -> Vec<Camera> {
    let bounds = scene.bounds();
    let centre = bounds.center();
    [(0.15, 0.15), (0.85, 0.15), (0.15, 0.85), (0.85, 0.85)]
        .iter()
        .map(|&(u, w)| {
            let eye = bounds.min + bounds.size() * Vec3::new(u, 0.4, w);
            Camera::look_at(eye, Vec3::new(centre.x, eye.y, centre.z), Vec3::Y, 1.0)
        })
        .collect()
}
