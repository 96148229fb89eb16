//! A small seeded random number generator and the sampling routines built on it.

use glam::{Vec2, Vec3};

/// PCG32 (O'Neill's `pcg32`, XSH-RR output), seeded by hashing a key.
///
/// Every random choice in this crate draws from an `Rng` made with [`Rng::for_key`] from the
/// user's seed and the indices of the work item (probe, texel, pixel, ray), so results do not
/// depend on how rayon splits the work or how many threads it has.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Rng {
    state: u64,
    increment: u64,
}

/// SplitMix64's finaliser: a bijective 64-bit mix.
#[inline]
fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

const PCG_MULTIPLIER: u64 = 6_364_136_223_846_793_005;

impl Rng {
    /// A generator whose stream is determined by `seed` and the key `indices` (e.g.
    /// `[probe, texel]`). Different keys give statistically independent streams.
    pub fn for_key(seed: u64, indices: &[u64]) -> Rng {
        let mut h = mix64(seed ^ 0x9e37_79b9_7f4a_7c15);
        for (i, &index) in indices.iter().enumerate() {
            h = mix64(
                h ^ mix64(index.wrapping_add((i as u64 + 1).wrapping_mul(0x632b_e59b_d9b4_e019))),
            );
        }
        let increment = (mix64(h ^ 0xda94_2042_e4dd_58b5) << 1) | 1;
        let mut rng = Rng {
            state: 0,
            increment,
        };
        rng.next_u32();
        rng.state = rng.state.wrapping_add(h);
        rng.next_u32();
        rng
    }

    /// The next 32 random bits.
    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old
            .wrapping_mul(PCG_MULTIPLIER)
            .wrapping_add(self.increment);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rotation = (old >> 59) as u32;
        xorshifted.rotate_right(rotation)
    }

    /// A uniform number in `[0, 1)` with 24 random bits.
    #[inline]
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }

    /// Two uniform numbers in `[0, 1)`.
    #[inline]
    pub fn next_vec2(&mut self) -> Vec2 {
        let x = self.next_f32();
        Vec2::new(x, self.next_f32())
    }
}

/// An orthonormal basis `(tangent, bitangent)` completing the unit vector `n` (Duff et al.
/// 2017, "Building an Orthonormal Basis, Revisited").
#[inline]
pub(crate) fn orthonormal_basis(n: Vec3) -> (Vec3, Vec3) {
    let sign = 1.0f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        Vec3::new(b, sign + n.y * n.y * a, -n.y),
    )
}

/// A cosine-distributed direction about the unit normal `n` (pdf `cos θ / π`) from two
/// uniform numbers, by Malley's method (concentric disk, then lifted).
#[inline]
pub(crate) fn cosine_hemisphere(n: Vec3, u: Vec2) -> Vec3 {
    let disk = concentric_disk(u);
    let z = (1.0 - disk.length_squared()).max(0.0).sqrt();
    let (t, b) = orthonormal_basis(n);
    (t * disk.x + b * disk.y + n * z).normalize()
}

/// Shirley–Chiu concentric mapping of the unit square onto the unit disk.
#[inline]
fn concentric_disk(u: Vec2) -> Vec2 {
    let o = u * 2.0 - Vec2::ONE;
    if o.x == 0.0 && o.y == 0.0 {
        return Vec2::ZERO;
    }
    let (r, theta) = if o.x.abs() > o.y.abs() {
        (o.x, std::f32::consts::FRAC_PI_4 * (o.y / o.x))
    } else {
        (
            o.y,
            std::f32::consts::FRAC_PI_2 - std::f32::consts::FRAC_PI_4 * (o.x / o.y),
        )
    };
    Vec2::new(r * theta.cos(), r * theta.sin())
}

/// Barycentrics `(b1, b2)` of a uniformly distributed point on a triangle (the square-root
/// parametrisation), from two uniform numbers.
#[inline]
pub(crate) fn uniform_triangle(u: Vec2) -> Vec2 {
    let s = u.x.sqrt();
    // Point = (1 − s)·p0 + s(1 − u.y)·p1 + s·u.y·p2.
    Vec2::new(s * (1.0 - u.y), s * u.y)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_are_deterministic_and_distinct() {
        let mut a = Rng::for_key(7, &[1, 2]);
        let mut b = Rng::for_key(7, &[1, 2]);
        let mut c = Rng::for_key(7, &[2, 1]);
        let mut d = Rng::for_key(8, &[1, 2]);
        let xa: Vec<u32> = (0..8).map(|_| a.next_u32()).collect();
        let xb: Vec<u32> = (0..8).map(|_| b.next_u32()).collect();
        let xc: Vec<u32> = (0..8).map(|_| c.next_u32()).collect();
        let xd: Vec<u32> = (0..8).map(|_| d.next_u32()).collect();
        assert_eq!(xa, xb);
        assert_ne!(xa, xc);
        assert_ne!(xa, xd);
    }

    #[test]
    fn uniform_floats_have_the_right_mean_and_range() {
        let mut rng = Rng::for_key(1, &[]);
        let n = 100_000;
        let mut sum = 0.0f64;
        for _ in 0..n {
            let x = rng.next_f32();
            assert!((0.0..1.0).contains(&x));
            sum += f64::from(x);
        }
        assert!((sum / n as f64 - 0.5).abs() < 0.005);
    }

    #[test]
    fn cosine_samples_have_mean_cosine_two_thirds() {
        let mut rng = Rng::for_key(3, &[]);
        let n = Vec3::new(0.3, -0.5, 0.8).normalize();
        let count = 50_000;
        let mut sum = 0.0f64;
        for _ in 0..count {
            let d = cosine_hemisphere(n, rng.next_vec2());
            assert!((d.length() - 1.0).abs() < 1e-4);
            let c = d.dot(n);
            assert!(c >= -1e-6);
            sum += f64::from(c);
        }
        // E[cos θ] under the pdf cos θ / π is 2/3.
        assert!((sum / count as f64 - 2.0 / 3.0).abs() < 0.01);
        let (t, b) = orthonormal_basis(n);
        assert!(t.dot(n).abs() < 1e-6 && b.dot(n).abs() < 1e-6 && t.dot(b).abs() < 1e-6);
    }

    #[test]
    fn triangle_samples_are_inside_and_uniform() {
        let mut rng = Rng::for_key(4, &[]);
        let mut mean = Vec2::ZERO;
        for _ in 0..20_000 {
            let b = uniform_triangle(rng.next_vec2());
            assert!(b.x >= 0.0 && b.y >= 0.0 && b.x + b.y <= 1.0 + 1e-6);
            mean += b;
        }
        mean /= 20_000.0;
        // The centroid has barycentrics (1/3, 1/3).
        assert!((mean - Vec2::splat(1.0 / 3.0)).abs().max_element() < 0.01);
    }
}
