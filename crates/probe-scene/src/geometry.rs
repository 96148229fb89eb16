//! Plain geometric value types: boxes, triangles, rays and ray hits.

use glam::{Vec2, Vec3};

/// An axis-aligned bounding box in world space (metres).
///
/// The empty box ([`Aabb::EMPTY`]) has `min = +∞` and `max = −∞`, so that the union with any
/// point or box is that point or box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// The corner with the smallest coordinates.
    pub min: Vec3,
    /// The corner with the largest coordinates.
    pub max: Vec3,
}

impl Aabb {
    /// The empty box: contains nothing, and is the identity of [`Aabb::union`].
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    /// The box spanning `min..=max`.
    pub const fn new(min: Vec3, max: Vec3) -> Aabb {
        Aabb { min, max }
    }

    /// The smallest box containing all `points` ([`Aabb::EMPTY`] for none).
    pub fn from_points(points: impl IntoIterator<Item = Vec3>) -> Aabb {
        points.into_iter().fold(Aabb::EMPTY, Aabb::including)
    }

    /// Whether the box contains no point (some `min` component exceeds its `max`).
    pub fn is_empty(&self) -> bool {
        self.min.cmpgt(self.max).any()
    }

    /// The extent along each axis (`max − min`); zero for the empty box.
    pub fn size(&self) -> Vec3 {
        if self.is_empty() {
            Vec3::ZERO
        } else {
            self.max - self.min
        }
    }

    /// The centre point; the origin for the empty box.
    pub fn center(&self) -> Vec3 {
        if self.is_empty() {
            Vec3::ZERO
        } else {
            (self.min + self.max) * 0.5
        }
    }

    /// Whether `point` lies inside or on the boundary of the box.
    pub fn contains(&self, point: Vec3) -> bool {
        point.cmpge(self.min).all() && point.cmple(self.max).all()
    }

    /// The smallest box containing both boxes.
    pub fn union(&self, other: &Aabb) -> Aabb {
        Aabb {
            min: self.min.min(other.min),
            max: self.max.max(other.max),
        }
    }

    /// The smallest box containing this box and `point`.
    pub fn including(self, point: Vec3) -> Aabb {
        Aabb {
            min: self.min.min(point),
            max: self.max.max(point),
        }
    }
}

/// One world-space triangle with its per-vertex shading data.
///
/// Winding convention: the geometric normal is `(p1 − p0) × (p2 − p0)` normalised, i.e. the
/// front face is the one from which the vertices appear counter-clockwise (as in glTF).
/// Barycentric convention everywhere in this crate: `b = (b1, b2)` names the point
/// `(1 − b1 − b2)·p0 + b1·p1 + b2·p2`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Triangle {
    /// Vertex positions, world space, metres.
    pub positions: [Vec3; 3],
    /// Vertex normals, world space. Unit length when loaded from files or built-ins; a file
    /// without normals gets the face's geometric normal at every vertex.
    pub normals: [Vec3; 3],
    /// Vertex texture coordinates of the set the material's base-colour texture uses
    /// (glTF convention: `(0, 0)` is the image's top-left corner); zero where the source has none.
    pub uvs: [Vec2; 3],
    /// Index into [`Scene::materials`](crate::Scene::materials).
    pub material: u32,
}

impl Triangle {
    /// A flat-shaded triangle: its geometric normal ([`Self::geometric_normal`]) at every
    /// vertex and zero texture coordinates.
    pub fn flat(positions: [Vec3; 3], material: u32) -> Triangle {
        let mut triangle = Triangle {
            positions,
            normals: [Vec3::ZERO; 3],
            uvs: [Vec2::ZERO; 3],
            material,
        };
        triangle.normals = [triangle.geometric_normal(); 3];
        triangle
    }

    /// The area in square metres.
    pub fn area(&self) -> f32 {
        let [p0, p1, p2] = self.positions;
        0.5 * (p1 - p0).cross(p2 - p0).length()
    }

    /// The unit normal of the plane, from the stored winding (`(p1 − p0) × (p2 − p0)`);
    /// zero for a degenerate (zero-area) triangle.
    pub fn geometric_normal(&self) -> Vec3 {
        let [p0, p1, p2] = self.positions;
        (p1 - p0).cross(p2 - p0).normalize_or_zero()
    }

    /// The point at barycentrics `(b1, b2)`: `(1 − b1 − b2)·p0 + b1·p1 + b2·p2`.
    pub fn point(&self, barycentrics: Vec2) -> Vec3 {
        let [p0, p1, p2] = self.positions;
        interpolate(p0, p1, p2, barycentrics)
    }

    /// The texture coordinate at barycentrics `(b1, b2)`.
    pub fn uv(&self, barycentrics: Vec2) -> Vec2 {
        let [t0, t1, t2] = self.uvs;
        let w = 1.0 - barycentrics.x - barycentrics.y;
        t0 * w + t1 * barycentrics.x + t2 * barycentrics.y
    }

    /// The interpolated vertex normal at barycentrics `(b1, b2)`, normalised; the geometric
    /// normal where the interpolation is zero or not finite.
    pub fn shading_normal(&self, barycentrics: Vec2) -> Vec3 {
        let [n0, n1, n2] = self.normals;
        let n = interpolate(n0, n1, n2, barycentrics).normalize_or_zero();
        if n == Vec3::ZERO {
            self.geometric_normal()
        } else {
            n
        }
    }
}

#[inline(always)]
fn interpolate(a: Vec3, b: Vec3, c: Vec3, barycentrics: Vec2) -> Vec3 {
    let w = 1.0 - barycentrics.x - barycentrics.y;
    a * w + b * barycentrics.x + c * barycentrics.y
}

/// A ray: `origin + t · direction` for `t ≥ 0`.
///
/// **`t_min` convention:** rays start at `t = 0`; this crate never skips a first stretch of the
/// ray. A ray leaving a surface must therefore have its origin moved off that surface, which
/// [`Ray::from_surface`] does robustly. The far end is the `t_max` argument of
/// [`Scene::closest_hit`](crate::Scene::closest_hit) and [`Scene::occluded`](crate::Scene::occluded),
/// which accept hits with `0 ≤ t < t_max`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// The start point, world space.
    pub origin: Vec3,
    /// The direction; unit length, so that `t` is a distance in metres.
    pub direction: Vec3,
}

impl Ray {
    /// A ray from `origin` along `direction`, which is normalised here.
    pub fn new(origin: Vec3, direction: Vec3) -> Ray {
        Ray {
            origin,
            direction: direction.normalize_or_zero(),
        }
    }

    /// A ray leaving the surface point `position` (whose plane has the unit normal
    /// `geometric_normal`) along `direction`, with its origin offset off the surface to the side
    /// `direction` points to, so that it does not hit the surface it starts on.
    ///
    /// The offset is the one of Wächter & Binder, "A Fast and Robust Method for Avoiding
    /// Self-Intersection" (Ray Tracing Gems, ch. 6): a few ulps of the position's magnitude
    /// along the normal, plus a small absolute offset near the origin. `direction` is normalised.
    pub fn from_surface(position: Vec3, geometric_normal: Vec3, direction: Vec3) -> Ray {
        let normal = if geometric_normal.dot(direction) < 0.0 {
            -geometric_normal
        } else {
            geometric_normal
        };
        Ray::new(offset_origin(position, normal), direction)
    }

    /// The point at parameter `t`: `origin + t · direction`.
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + self.direction * t
    }
}

/// Wächter & Binder's origin offset (Ray Tracing Gems, ch. 6, listing 6-1).
fn offset_origin(p: Vec3, n: Vec3) -> Vec3 {
    const ORIGIN: f32 = 1.0 / 32.0;
    const FLOAT_SCALE: f32 = 1.0 / 65536.0;
    const INT_SCALE: f32 = 256.0;
    let offset = |p: f32, n: f32| -> f32 {
        let of_i = (INT_SCALE * n) as i32;
        let bits = p.to_bits() as i32;
        let moved = f32::from_bits(bits.wrapping_add(if p < 0.0 { -of_i } else { of_i }) as u32);
        if p.abs() < ORIGIN {
            p + FLOAT_SCALE * n
        } else {
            moved
        }
    };
    Vec3::new(offset(p.x, n.x), offset(p.y, n.y), offset(p.z, n.z))
}

/// The closest intersection of a ray with a scene's triangles.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Distance along the (unit) ray direction, in `[0, t_max)`.
    pub t: f32,
    /// The hit point, interpolated from the triangle's vertices at `barycentrics`.
    pub position: Vec3,
    /// Index into [`Scene::triangles`](crate::Scene::triangles).
    pub triangle: u32,
    /// `(b1, b2)`: the hit is `(1 − b1 − b2)·p0 + b1·p1 + b2·p2`.
    pub barycentrics: Vec2,
    /// The unit plane normal from the stored winding (see [`Triangle::geometric_normal`]);
    /// not flipped towards the ray.
    pub geometric_normal: Vec3,
    /// The interpolated vertex normal, unit length; the geometric normal where the
    /// interpolation degenerates. Not flipped towards the ray.
    pub shading_normal: Vec3,
    /// Index into [`Scene::materials`](crate::Scene::materials).
    pub material: u32,
    /// Whether the ray hit the front face: `ray.direction · geometric_normal < 0`.
    pub front_face: bool,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn aabb_union_size_center_contains() {
        let a = Aabb::new(Vec3::ZERO, Vec3::ONE);
        let b = Aabb::new(Vec3::splat(-1.0), Vec3::new(0.5, 0.5, 3.0));
        let u = a.union(&b);
        assert_eq!(u, Aabb::new(Vec3::splat(-1.0), Vec3::new(1.0, 1.0, 3.0)));
        assert_eq!(u.size(), Vec3::new(2.0, 2.0, 4.0));
        assert_eq!(u.center(), Vec3::new(0.0, 0.0, 1.0));
        assert!(u.contains(Vec3::new(1.0, -1.0, 3.0)));
        assert!(!u.contains(Vec3::new(1.01, 0.0, 0.0)));
        assert!(Aabb::EMPTY.is_empty());
        assert_eq!(Aabb::EMPTY.union(&a), a);
        assert_eq!(Aabb::EMPTY.size(), Vec3::ZERO);
        assert!(!Aabb::EMPTY.contains(Vec3::ZERO));
        assert_eq!(
            Aabb::from_points([Vec3::X, Vec3::Y, -Vec3::Z]),
            Aabb::new(Vec3::new(0.0, 0.0, -1.0), Vec3::new(1.0, 1.0, 0.0))
        );
    }

    #[test]
    fn triangle_area_normal_point() {
        let t = Triangle {
            positions: [
                Vec3::ZERO,
                Vec3::new(2.0, 0.0, 0.0),
                Vec3::new(0.0, 3.0, 0.0),
            ],
            normals: [Vec3::Z, Vec3::X, Vec3::Z],
            uvs: [Vec2::ZERO, Vec2::X, Vec2::Y],
            material: 0,
        };
        assert!((t.area() - 3.0).abs() < 1e-6);
        assert_eq!(t.geometric_normal(), Vec3::Z);
        assert_eq!(t.point(Vec2::new(0.5, 0.0)), Vec3::new(1.0, 0.0, 0.0));
        assert_eq!(t.point(Vec2::new(0.0, 1.0)), Vec3::new(0.0, 3.0, 0.0));
        assert_eq!(t.uv(Vec2::new(0.25, 0.5)), Vec2::new(0.25, 0.5));
        let n = t.shading_normal(Vec2::new(0.5, 0.0));
        assert!((n - Vec3::new(1.0, 0.0, 1.0).normalize()).length() < 1e-6);
        let flat = Triangle {
            normals: [Vec3::ZERO; 3],
            ..t
        };
        assert_eq!(flat.shading_normal(Vec2::splat(0.3)), Vec3::Z);
    }

    #[test]
    fn surface_offset_moves_to_the_direction_side() {
        for p in [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1e4, -3.0, 0.25),
            Vec3::splat(-7.5),
        ] {
            let up = Ray::from_surface(p, Vec3::Y, Vec3::new(0.2, 1.0, 0.0));
            assert!(up.origin.y > p.y, "{p}: {}", up.origin);
            let down = Ray::from_surface(p, Vec3::Y, Vec3::new(0.2, -1.0, 0.0));
            assert!(down.origin.y < p.y, "{p}: {}", down.origin);
            assert!((up.origin - p).length() < 1e-2);
            assert!((up.direction.length() - 1.0).abs() < 1e-6);
        }
    }
}
