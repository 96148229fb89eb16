//! Helpers shared by the integration tests: seeded random directions and angles.

#![allow(dead_code)]

use glam::{DVec3, Vec2, Vec3};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;

/// A seeded generator.
pub fn rng(seed: u64) -> Pcg64Mcg {
    Pcg64Mcg::seed_from_u64(seed)
}

/// A uniformly random unit direction (z uniform in [-1, 1], azimuth uniform).
pub fn random_direction(rng: &mut impl Rng) -> Vec3 {
    let z: f64 = rng.random_range(-1.0..=1.0);
    let phi: f64 = rng.random_range(0.0..std::f64::consts::TAU);
    let r = (1.0 - z * z).max(0.0).sqrt();
    DVec3::new(r * phi.cos(), r * phi.sin(), z).as_vec3()
}

/// A uniformly random point of the octahedral square.
pub fn random_octa(rng: &mut impl Rng) -> Vec2 {
    Vec2::new(rng.random_range(-1.0..=1.0), rng.random_range(-1.0..=1.0))
}

/// Angle between two directions in radians, in f64 with atan2 (accurate for tiny angles).
pub fn angle(a: Vec3, b: Vec3) -> f64 {
    let (a, b) = (a.as_dvec3().normalize(), b.as_dvec3().normalize());
    a.cross(b).length().atan2(a.dot(b))
}
