//! Octahedral encoding of unit directions (Cigolle et al. 2014, as used by McGuire 2017 and RTXGI).

use glam::{Vec2, Vec3};

/// `+1` for components `>= 0` (including `-0.0`), `-1` otherwise: the `signNotZero` of the
/// octahedral-mapping literature, written so that WGSL's `select(-1.0, 1.0, v >= 0.0)` matches it.
#[inline]
pub fn sign_not_zero(v: Vec2) -> Vec2 {
    Vec2::new(
        if v.x >= 0.0 { 1.0 } else { -1.0 },
        if v.y >= 0.0 { 1.0 } else { -1.0 },
    )
}

/// Octahedral coordinates in `[-1, 1]²` of a direction.
///
/// `p = v.xy / (|x| + |y| + |z|)`; if `v.z < 0`, `p = (1 − |p.yx|) · signNotZero(p)`.
/// The input need not be normalised (only its direction matters).
///
/// Defined results for bad input: the zero vector and any vector with a NaN or infinite
/// component encode to `(0, 0)`, the octahedral point of `+z`. Finite vectors too large for
/// their L1 norm to be finite are rescaled first, so they encode correctly.
#[inline]
pub fn encode(direction: Vec3) -> Vec2 {
    let l1 = direction.x.abs() + direction.y.abs() + direction.z.abs();
    if !(l1 > 0.0 && l1 <= f32::MAX) {
        return encode_unusual(direction);
    }
    let p = Vec2::new(direction.x, direction.y) / l1;
    if direction.z < 0.0 {
        (Vec2::ONE - Vec2::new(p.y.abs(), p.x.abs())) * sign_not_zero(p)
    } else {
        p
    }
}

/// The slow path of [`encode`]: zero, non-finite and huge vectors.
#[cold]
fn encode_unusual(direction: Vec3) -> Vec2 {
    if !direction.is_finite() || direction == Vec3::ZERO {
        return Vec2::ZERO;
    }
    // Finite but |x|+|y|+|z| overflowed: scale down by an exact power of two.
    encode(direction * (2.0f32).powi(-64))
}

/// Unit direction of octahedral coordinates: the inverse of [`encode`].
///
/// `v = (o.x, o.y, 1 − |o.x| − |o.y|)`; if `v.z < 0`, `v.xy = (1 − |v.yx|) · signNotZero(v.xy)`;
/// then normalise.
///
/// Defined results for bad input: coordinates are clamped to `[-1, 1]²` first; a NaN or
/// infinite coordinate decodes to `+z`.
#[inline]
pub fn decode(octa: Vec2) -> Vec3 {
    if !octa.is_finite() {
        return Vec3::Z;
    }
    let o = octa.clamp(Vec2::NEG_ONE, Vec2::ONE);
    let z = 1.0 - o.x.abs() - o.y.abs();
    let xy = if z < 0.0 {
        (Vec2::ONE - Vec2::new(o.y.abs(), o.x.abs())) * sign_not_zero(o)
    } else {
        o
    };
    // |(x, y, z)| >= 1/sqrt(3) on the octahedron, so this never divides by zero.
    Vec3::new(xy.x, xy.y, z).normalize()
}

/// Largest magnitude of an 8-bit snorm component.
const SNORM8_MAX: f32 = i8::MAX as f32;
/// Largest magnitude of a 16-bit snorm component.
const SNORM16_MAX: f32 = i16::MAX as f32;

/// A direction quantised to two 8-bit signed-normalised integers (16 bits in all).
///
/// Each octahedral coordinate is rounded to the nearest multiple of `1/127`
/// (`round(clamp(p, -1, 1) · 127)`), exactly what GPU `Rg8Snorm` textures store; `-128` is never
/// produced. Measured error over 10⁶ random directions: see `BENCHMARKS.md` (about 0.34° mean,
/// 0.95° max, as in Cigolle et al. 2014).
#[inline]
pub fn encode_snorm8(direction: Vec3) -> [i8; 2] {
    let p = encode(direction).clamp(Vec2::NEG_ONE, Vec2::ONE) * SNORM8_MAX;
    // `as` saturates, and |p| <= 127 anyway.
    [p.x.round() as i8, p.y.round() as i8]
}

/// Unit direction of an [`encode_snorm8`] pair. Decodes like a GPU `Rg8Snorm` texel:
/// `max(c / 127, -1)`, so `-128` reads as `-1`.
#[inline]
pub fn decode_snorm8(quantised: [i8; 2]) -> Vec3 {
    decode(Vec2::new(
        f32::from(quantised[0]) / SNORM8_MAX,
        f32::from(quantised[1]) / SNORM8_MAX,
    ))
}

/// A direction quantised to two 16-bit signed-normalised integers (32 bits in all).
///
/// Each coordinate is rounded to the nearest multiple of `1/32767`, as GPU `Rg16Snorm` stores it;
/// `-32768` is never produced. Measured error: see `BENCHMARKS.md` (about 0.0013° mean,
/// 0.0036° max).
#[inline]
pub fn encode_snorm16(direction: Vec3) -> [i16; 2] {
    let p = encode(direction).clamp(Vec2::NEG_ONE, Vec2::ONE) * SNORM16_MAX;
    [p.x.round() as i16, p.y.round() as i16]
}

/// Unit direction of an [`encode_snorm16`] pair (`max(c / 32767, -1)` per coordinate).
#[inline]
pub fn decode_snorm16(quantised: [i16; 2]) -> Vec3 {
    decode(Vec2::new(
        f32::from(quantised[0]) / SNORM16_MAX,
        f32::from(quantised[1]) / SNORM16_MAX,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn axes_land_where_documented() {
        let cases = [
            (Vec3::Z, Vec2::new(0.0, 0.0)),
            (Vec3::X, Vec2::new(1.0, 0.0)),
            (Vec3::NEG_X, Vec2::new(-1.0, 0.0)),
            (Vec3::Y, Vec2::new(0.0, 1.0)),
            (Vec3::NEG_Y, Vec2::new(0.0, -1.0)),
        ];
        for (direction, octa) in cases {
            assert_eq!(encode(direction), octa, "{direction}");
            assert!(decode(octa).abs_diff_eq(direction, 1e-7), "{octa}");
        }
        // -z is every corner; the encoder picks (+1, +1).
        assert_eq!(encode(Vec3::NEG_Z), Vec2::ONE);
        for corner in [
            Vec2::ONE,
            Vec2::NEG_ONE,
            Vec2::new(1.0, -1.0),
            Vec2::new(-1.0, 1.0),
        ] {
            assert!(decode(corner).abs_diff_eq(Vec3::NEG_Z, 1e-7));
        }
    }

    #[test]
    fn bad_input_has_defined_results() {
        assert_eq!(encode(Vec3::ZERO), Vec2::ZERO);
        assert_eq!(encode(Vec3::new(f32::NAN, 1.0, 0.0)), Vec2::ZERO);
        assert_eq!(encode(Vec3::new(f32::INFINITY, 1.0, 0.0)), Vec2::ZERO);
        assert_eq!(decode(Vec2::new(f32::NAN, 0.0)), Vec3::Z);
        assert_eq!(decode(Vec2::new(0.0, f32::NEG_INFINITY)), Vec3::Z);
        // Out-of-square input is clamped.
        assert!(decode(Vec2::new(3.0, 0.0)).abs_diff_eq(Vec3::X, 1e-7));
        // Huge finite vectors still encode by direction.
        let huge = Vec3::new(f32::MAX, -f32::MAX, f32::MAX);
        let expected = encode(Vec3::new(1.0, -1.0, 1.0));
        assert!(encode(huge).abs_diff_eq(expected, 1e-7));
        // Tiny (subnormal) vectors too.
        let tiny = Vec3::new(1e-40, 0.0, -1e-40);
        assert!(encode(tiny).abs_diff_eq(encode(Vec3::new(1.0, 0.0, -1.0)), 1e-6));
        assert_eq!(decode_snorm8([i8::MIN, i8::MIN]), decode(Vec2::NEG_ONE));
    }

    #[test]
    fn negative_zero_counts_as_positive() {
        assert_eq!(sign_not_zero(Vec2::new(-0.0, 0.0)), Vec2::ONE);
        assert_eq!(sign_not_zero(Vec2::new(-1e-30, 2.0)), Vec2::new(-1.0, 1.0));
    }
}
