//! Triangles of axis-aligned boxes with brute-force ray casting: the scene of the selection
//! tests, shared by `src/cpu/select.rs`'s unit tests and `tests/selection_properties.rs`.

use glam::Vec3;
use probe_index::{RayHit, SceneGeometry};

/// Axis-aligned boxes as triangles, with brute-force ray casting.
pub struct Boxes(Vec<[Vec3; 3]>);

impl Boxes {
    pub fn new(boxes: &[(Vec3, Vec3)]) -> Self {
        let mut triangles = Vec::new();
        for &(lo, hi) in boxes {
            let corner = |i: u32| {
                Vec3::new(
                    if i & 1 == 0 { lo.x } else { hi.x },
                    if i & 2 == 0 { lo.y } else { hi.y },
                    if i & 4 == 0 { lo.z } else { hi.z },
                )
            };
            for [a, b, c, d] in [
                [0, 1, 3, 2],
                [4, 5, 7, 6],
                [0, 1, 5, 4],
                [2, 3, 7, 6],
                [0, 2, 6, 4],
                [1, 3, 7, 5],
            ] {
                triangles.push([corner(a), corner(b), corner(c)]);
                triangles.push([corner(a), corner(c), corner(d)]);
            }
        }
        Self(triangles)
    }
}

impl SceneGeometry for Boxes {
    fn triangle_count(&self) -> usize {
        self.0.len()
    }

    fn triangle(&self, index: usize) -> [Vec3; 3] {
        self.0[index]
    }

    fn closest_hit(&self, origin: Vec3, direction: Vec3, max_distance: f32) -> Option<RayHit> {
        let mut best: Option<RayHit> = None;
        for [a, b, c] in &self.0 {
            let (e1, e2) = (*b - *a, *c - *a);
            let p = direction.cross(e2);
            let det = e1.dot(p);
            if det.abs() < 1e-12 {
                continue;
            }
            let s = origin - *a;
            let u = s.dot(p) / det;
            let q = s.cross(e1);
            let v = direction.dot(q) / det;
            let t = e2.dot(q) / det;
            if u >= 0.0
                && v >= 0.0
                && u + v <= 1.0
                && t > 0.0
                && t <= max_distance
                && best.is_none_or(|h| t < h.distance)
            {
                best = Some(RayHit {
                    distance: t,
                    normal: e1.cross(e2).normalize(),
                });
            }
        }
        best
    }
}
