//! Test support: flat-shaded triangles and quads for scenes built in code.
#![allow(dead_code)]

use glam::Vec3;
use probe_scene::Triangle;

/// A flat-shaded triangle (its geometric normal at every vertex).
pub fn triangle(positions: [Vec3; 3], material: u32) -> Triangle {
    Triangle::flat(positions, material)
}

/// A quad `a b c d` (in order around its edge) wound so its normal points along `facing`.
pub fn quad(corners: [Vec3; 4], facing: Vec3, material: u32) -> [Triangle; 2] {
    let [a, b, c, d] = corners;
    let (a, b, c, d) = if (b - a).cross(c - a).dot(facing) >= 0.0 {
        (a, b, c, d)
    } else {
        (a, d, c, b)
    };
    [triangle([a, b, c], material), triangle([a, c, d], material)]
}
