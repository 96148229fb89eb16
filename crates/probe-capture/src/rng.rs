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

/// A source of uniform random numbers in `[0, 1)` for the [`crate::Shader`] and the bake:
/// independent ones ([`Rng`]) or a randomised low-discrepancy sequence ([`SobolSampler`]).
///
/// Each call draws the next *dimension* of one sample: the shader asks for the numbers of a
/// path in a fixed order (emitter choice, the point on it, the bounce direction, …), so a
/// low-discrepancy sampler can stratify every decision across the samples of one texel.
pub trait Sampler {
    /// The next uniform number in `[0, 1)`.
    fn next_f32(&mut self) -> f32;

    /// The next two uniform numbers in `[0, 1)`, meant to be used together (a 2-D decision
    /// such as a direction or a point on a triangle).
    fn next_vec2(&mut self) -> Vec2;
}

impl Sampler for Rng {
    #[inline]
    fn next_f32(&mut self) -> f32 {
        Rng::next_f32(self)
    }

    #[inline]
    fn next_vec2(&mut self) -> Vec2 {
        Rng::next_vec2(self)
    }
}

/// Owen-scrambled, shuffled Sobol points (Burley 2020, "Practical Hash-based Owen
/// Scrambling"), one 2-D pair of dimensions at a time.
///
/// Sample `index` of a stream draws each call from a fresh pair of dimensions `d`: the index
/// is shuffled by a nested uniform scramble seeded by `(seed, d)`, then the first two Sobol
/// dimensions of the shuffled index are each Owen-scrambled with their own seed. Every pair
/// is therefore a (0,2)-sequence in base 2: any `2^m` consecutive samples (from a multiple of
/// `2^m`) of one pair fall one in each of the `2^m` elementary intervals of any shape, while
/// different pairs (and different seeds) are statistically independent. Different seeds give
/// independent randomisations of the same sequence, so the spread between estimates made
/// with different seeds is an unbiased measure of the estimator's variance (randomised
/// quasi-Monte Carlo).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SobolSampler {
    seed: u64,
    index: u32,
    dimension: u32,
}

impl SobolSampler {
    /// Sample `index` of the stream keyed by `seed` and the work item `indices` (as
    /// [`Rng::for_key`]).
    pub fn for_key(seed: u64, indices: &[u64], index: u32) -> SobolSampler {
        let mut h = mix64(seed ^ 0x5851_f42d_4c95_7f2d);
        for (i, &key) in indices.iter().enumerate() {
            h = mix64(
                h ^ mix64(key.wrapping_add((i as u64 + 1).wrapping_mul(0x2545_f491_4f6c_dd1d))),
            );
        }
        SobolSampler {
            seed: h,
            index,
            dimension: 0,
        }
    }

    /// The next pair's two 32-bit values.
    #[inline]
    fn next_pair_bits(&mut self) -> (u32, u32) {
        let key = mix64(self.seed ^ u64::from(self.dimension).wrapping_mul(0x9e37_79b9_7f4a_7c15));
        self.dimension = self.dimension.wrapping_add(1);
        let shuffled = nested_uniform_scramble(self.index, key as u32);
        let x = nested_uniform_scramble(shuffled.reverse_bits(), (key >> 32) as u32);
        let y = nested_uniform_scramble(sobol_second_dimension(shuffled), mix64(key) as u32);
        (x, y)
    }
}

/// 32 bits to a float in `[0, 1)` (24 bits kept).
#[inline]
fn unit_float(bits: u32) -> f32 {
    (bits >> 8) as f32 * (1.0 / 16_777_216.0)
}

impl Sampler for SobolSampler {
    #[inline]
    fn next_f32(&mut self) -> f32 {
        unit_float(self.next_pair_bits().0)
    }

    #[inline]
    fn next_vec2(&mut self) -> Vec2 {
        let (x, y) = self.next_pair_bits();
        Vec2::new(unit_float(x), unit_float(y))
    }
}

/// The second Sobol dimension of `index` (the first is `index.reverse_bits()`): its
/// generator matrix is Pascal's triangle mod 2, so the direction numbers are
/// `v₀ = 2³¹, v_{k+1} = v_k ⊕ (v_k ≫ 1)`.
#[inline]
fn sobol_second_dimension(mut index: u32) -> u32 {
    let mut direction = 1u32 << 31;
    let mut value = 0u32;
    while index != 0 {
        if index & 1 != 0 {
            value ^= direction;
        }
        index >>= 1;
        direction ^= direction >> 1;
    }
    value
}

/// A base-2 nested uniform (Owen) scramble of the 32-bit fraction `x` by the hash-based
/// Laine–Karras permutation (Burley 2020's constants): each bit is flipped depending on the
/// seed and the bits above it only, so the scramble keeps every elementary interval's points
/// in one elementary interval.
#[inline]
fn nested_uniform_scramble(x: u32, seed: u32) -> u32 {
    let mut v = x.reverse_bits();
    v = v.wrapping_add(seed);
    v ^= v.wrapping_mul(0x6c50_b47c);
    v ^= v.wrapping_mul(0xb82f_1e52);
    v ^= v.wrapping_mul(0xc7af_e638);
    v ^= v.wrapping_mul(0x8d22_f6e6);
    v.reverse_bits()
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

    /// Any 2^m consecutive (aligned) samples of one pair of dimensions put one point in each
    /// of the 2^m elementary intervals of every shape (a (0, m, 2)-net), for several seeds,
    /// pairs and blocks.
    #[test]
    fn sobol_pairs_are_nets_in_every_block() {
        for seed in [0u64, 1, 99] {
            for m in [2u32, 4, 6] {
                let count = 1u32 << m;
                for block in [0u32, 1, 5] {
                    let mut points = Vec::new();
                    for i in 0..count {
                        let mut s = SobolSampler::for_key(seed, &[3, 4], block * count + i);
                        let _first = s.next_vec2();
                        points.push(s.next_vec2());
                    }
                    for x_bits in 0..=m {
                        let (nx, ny) = (1u32 << x_bits, 1u32 << (m - x_bits));
                        let mut seen = vec![false; count as usize];
                        for p in &points {
                            let cx = ((p.x * nx as f32) as u32).min(nx - 1);
                            let cy = ((p.y * ny as f32) as u32).min(ny - 1);
                            let cell = (cy * nx + cx) as usize;
                            assert!(
                                !seen[cell],
                                "seed {seed}, 2^{m} points, block {block}: two in cell {cx},{cy} of {nx}x{ny}"
                            );
                            seen[cell] = true;
                        }
                    }
                }
            }
        }
    }

    /// The scramble is a randomisation: every value is uniform in mean over seeds, and
    /// different seeds, pairs and work items give different points.
    #[test]
    fn sobol_streams_are_deterministic_uniform_and_distinct() {
        let draw = |seed: u64, key: u64, index: u32| {
            let mut s = SobolSampler::for_key(seed, &[key], index);
            (s.next_vec2(), s.next_f32())
        };
        assert_eq!(draw(1, 2, 3), draw(1, 2, 3));
        assert_ne!(draw(1, 2, 3), draw(2, 2, 3));
        assert_ne!(draw(1, 2, 3), draw(1, 3, 3));
        let mut sum = glam::DVec3::ZERO;
        let n = 20_000u64;
        for key in 0..n {
            let (p, q) = draw(7, key, 0);
            for v in [p.x, p.y, q] {
                assert!((0.0..1.0).contains(&v));
            }
            sum += glam::DVec3::new(f64::from(p.x), f64::from(p.y), f64::from(q));
        }
        let mean = sum / n as f64;
        assert!(
            (mean - glam::DVec3::splat(0.5)).abs().max_element() < 0.01,
            "{mean}"
        );
        // Two pairs of one sample are uncorrelated across keys.
        let mut product = 0.0f64;
        for key in 0..n {
            let mut s = SobolSampler::for_key(7, &[key], 5);
            let a = s.next_vec2();
            let b = s.next_vec2();
            product += f64::from((a.x - 0.5) * (b.x - 0.5));
        }
        assert!((product / n as f64).abs() < 0.005);
    }

    /// Stratification pays: the mean of a smooth 2-D integrand over 64 Sobol samples is far
    /// closer to the truth, over many seeds, than over 64 independent ones.
    #[test]
    fn sobol_estimates_have_lower_variance_than_independent_ones() {
        let f = |p: Vec2| (p.x * 3.0).sin() * p.y + p.y * p.y;
        let truth = (1.0 - 3.0f64.cos()) / 3.0 * 0.5 + 1.0 / 3.0;
        let (mut sobol, mut independent) = (0.0f64, 0.0f64);
        for seed in 0..200u64 {
            let (mut a, mut b) = (0.0f64, 0.0f64);
            let mut rng = Rng::for_key(seed, &[]);
            for i in 0..64 {
                a += f64::from(f(SobolSampler::for_key(seed, &[], i).next_vec2()));
                b += f64::from(f(rng.next_vec2()));
            }
            sobol += (a / 64.0 - truth).powi(2);
            independent += (b / 64.0 - truth).powi(2);
        }
        assert!(sobol * 20.0 < independent, "{sobol} vs {independent}");
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
