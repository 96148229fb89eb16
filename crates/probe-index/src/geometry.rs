//! The scene queries this crate needs, as a trait, so that it depends on no scene crate: the
//! triangles (for the octree's subdivision), a closest-hit ray cast (for seed 002's edge ray
//! casts) and a segment visibility test (for ranking probes in octree leaves).

use glam::{DVec3, Vec3};

/// The nearest intersection of a ray with the scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayHit {
    /// Distance along the (unit) ray direction.
    pub distance: f32,
    /// Unit geometric normal of the surface hit, either orientation (surfaces are treated as
    /// double-sided).
    pub normal: Vec3,
}

/// Scene geometry as seen by the indexing structures.
///
/// Implement it for your scene (the `probe-scene` crate's `Scene` will implement it behind a
/// feature); the tests implement it with a brute-force triangle soup. Implementations are
/// shared across rayon threads, hence `Sync`.
pub trait SceneGeometry: Sync {
    /// Number of triangles.
    fn triangle_count(&self) -> usize;

    /// Triangle `index` (`index < triangle_count()`), in world space.
    fn triangle(&self, index: usize) -> [Vec3; 3];

    /// The closest hit of the ray `origin + t·direction` for `0 < t ≤ max_distance`;
    /// `direction` is unit length.
    fn closest_hit(&self, origin: Vec3, direction: Vec3, max_distance: f32) -> Option<RayHit>;

    /// Whether the open segment between `from` and `to` is free of geometry. The default casts
    /// a ray and ignores hits within a relative 1e-4 of either end, so points on a surface see
    /// out of it; override it with a faster any-hit query when the scene has one.
    fn segment_visible(&self, from: Vec3, to: Vec3) -> bool {
        let d = to - from;
        let len = d.length();
        if len <= f32::EPSILON {
            return true;
        }
        let margin = len * 1e-4;
        let dir = d / len;
        self.closest_hit(from + dir * margin, dir, len - 2.0 * margin)
            .is_none()
    }
}

#[cfg(feature = "scene")]
impl SceneGeometry for probe_scene::Scene {
    fn triangle_count(&self) -> usize {
        self.triangles().len()
    }

    fn triangle(&self, index: usize) -> [Vec3; 3] {
        self.triangles()[index].positions
    }

    fn closest_hit(&self, origin: Vec3, direction: Vec3, max_distance: f32) -> Option<RayHit> {
        let ray = probe_scene::Ray { origin, direction };
        probe_scene::Scene::closest_hit(self, &ray, max_distance)
            .filter(|hit| hit.t > 0.0)
            .map(|hit| RayHit {
                distance: hit.t,
                normal: hit.geometric_normal,
            })
    }

    /// An any-hit query (`Scene::occluded`) over the segment shrunk by a relative 1e-4 at
    /// both ends.
    fn segment_visible(&self, from: Vec3, to: Vec3) -> bool {
        let d = to - from;
        let len = d.length();
        if len <= f32::EPSILON {
            return true;
        }
        let margin = len * 1e-4;
        let direction = d / len;
        let ray = probe_scene::Ray {
            origin: from + direction * margin,
            direction,
        };
        !self.occluded(&ray, len - 2.0 * margin)
    }
}

/// Exact-as-possible triangle/axis-aligned-box overlap by the separating-axis theorem
/// (Akenine-Möller 2001: 3 box normals, the triangle normal and 9 edge cross products),
/// evaluated in f64 on a box enlarged by a relative 1e-9 so that rounding can only report an
/// overlap that touches, never miss one.
pub fn triangle_overlaps_box(tri: &[Vec3; 3], box_min: Vec3, box_max: Vec3) -> bool {
    let lo = box_min.as_dvec3();
    let hi = box_max.as_dvec3();
    let centre = (lo + hi) * 0.5;
    let half = (hi - lo) * 0.5;
    let half = half + DVec3::splat(half.max_element() * 1e-9);
    let v = tri.map(|p| p.as_dvec3() - centre);
    // Box face normals: the triangle's bounding box against the box.
    for k in 0..3 {
        let mn = v[0][k].min(v[1][k]).min(v[2][k]);
        let mx = v[0][k].max(v[1][k]).max(v[2][k]);
        if mn > half[k] || mx < -half[k] {
            return false;
        }
    }
    let e = [v[1] - v[0], v[2] - v[1], v[0] - v[2]];
    // Triangle normal.
    let n = e[0].cross(e[1]);
    let r = half.x * n.x.abs() + half.y * n.y.abs() + half.z * n.z.abs();
    let s = n.dot(v[0]);
    if s.abs() > r {
        return false;
    }
    // Edge × box axis.
    let axes = [DVec3::X, DVec3::Y, DVec3::Z];
    for edge in &e {
        for axis in &axes {
            let a = axis.cross(*edge);
            if a == DVec3::ZERO {
                continue;
            }
            let p0 = a.dot(v[0]);
            let p1 = a.dot(v[1]);
            let p2 = a.dot(v[2]);
            let r = half.x * a.x.abs() + half.y * a.y.abs() + half.z * a.z.abs();
            let mn = p0.min(p1).min(p2);
            let mx = p0.max(p1).max(p2);
            if mn > r || mx < -r {
                return false;
            }
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn overlap_cases() {
        let lo = Vec3::ZERO;
        let hi = Vec3::ONE;
        // Triangle cutting through the box.
        let t = [
            Vec3::new(-1.0, 0.5, -1.0),
            Vec3::new(3.0, 0.5, -1.0),
            Vec3::new(-1.0, 0.5, 3.0),
        ];
        assert!(triangle_overlaps_box(&t, lo, hi));
        // Large triangle whose bounding box contains the box but whose plane misses it.
        let t = [
            Vec3::new(-5.0, -5.0, 4.0),
            Vec3::new(10.0, -5.0, 4.0),
            Vec3::new(-5.0, 10.0, 4.0),
        ];
        assert!(!triangle_overlaps_box(&t, lo, hi));
        // Triangle near a corner, separated only by an edge cross-product axis.
        let t = [
            Vec3::new(1.2, -0.5, 0.5),
            Vec3::new(1.2, 0.5, -0.6),
            Vec3::new(2.0, 2.0, 2.0),
        ];
        let hit = triangle_overlaps_box(&t, lo, hi);
        // Brute force: sample the triangle densely and test containment.
        let mut inside = false;
        for i in 0..=200 {
            for j in 0..=(200 - i) {
                let (u, v) = (i as f32 / 200.0, j as f32 / 200.0);
                let p = t[0] + (t[1] - t[0]) * u + (t[2] - t[0]) * v;
                if p.cmpge(lo).all() && p.cmple(hi).all() {
                    inside = true;
                }
            }
        }
        assert_eq!(hit, inside);
        // Touching a face counts.
        let t = [
            Vec3::new(1.0, 0.2, 0.2),
            Vec3::new(2.0, 0.2, 0.2),
            Vec3::new(1.0, 0.8, 0.8),
        ];
        assert!(triangle_overlaps_box(&t, lo, hi));
    }
}
