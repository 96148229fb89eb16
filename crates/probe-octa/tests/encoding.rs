//! Octahedral encoding: f32 round trip and the quantised 16- and 32-bit forms.

mod common;

use common::{angle, random_direction, rng};
use glam::Vec2;
use probe_octa::{decode, decode_snorm8, decode_snorm16, encode, encode_snorm8, encode_snorm16};

/// 10⁶ seeded random directions survive encode → decode within 1e-5 rad.
#[test]
fn f32_round_trip_is_below_1e_5_radians() {
    let mut rng = rng(1);
    let mut worst = 0.0f64;
    for _ in 0..1_000_000 {
        let d = random_direction(&mut rng);
        let p = encode(d);
        assert!(
            p.abs().max_element() <= 1.0,
            "{d} encodes outside the square: {p}"
        );
        worst = worst.max(angle(decode(p), d));
    }
    assert!(worst < 1e-5, "worst round-trip error {worst} rad");
}

/// Mean and max angular error in degrees of a quantised round trip.
fn quantised_error(
    count: usize,
    seed: u64,
    round_trip: impl Fn(glam::Vec3) -> glam::Vec3,
) -> (f64, f64) {
    let mut rng = rng(seed);
    let (mut sum, mut max) = (0.0f64, 0.0f64);
    for _ in 0..count {
        let d = random_direction(&mut rng);
        let e = angle(round_trip(d), d).to_degrees();
        sum += e;
        max = max.max(e);
    }
    (sum / count as f64, max)
}

/// 2×8-bit snorm: the brief's (Cigolle et al. 2014) 16-bit figures are mean 0.34°, max 0.95°.
#[test]
fn sixteen_bit_error_matches_the_published_figures() {
    let (mean, max) = quantised_error(1_000_000, 2, |d| decode_snorm8(encode_snorm8(d)));
    assert!((0.32..=0.36).contains(&mean), "mean {mean}°");
    assert!((0.90..=1.00).contains(&max), "max {max}°");
}

/// 2×16-bit snorm: the brief's 32-bit figures are mean 0.0013°, max 0.0036°.
#[test]
fn thirty_two_bit_error_matches_the_published_figures() {
    let (mean, max) = quantised_error(1_000_000, 3, |d| decode_snorm16(encode_snorm16(d)));
    assert!((0.00123..=0.00137).contains(&mean), "mean {mean}°");
    assert!((0.0033..=0.0039).contains(&max), "max {max}°");
}

/// Every 8-bit code decodes to a direction that re-encodes to an equivalent code (the same
/// code, or its mirror on a seam where two codes are one direction).
#[test]
fn every_eight_bit_code_is_stable() {
    for x in i8::MIN..=i8::MAX {
        for y in i8::MIN..=i8::MAX {
            let d = decode_snorm8([x, y]);
            assert!((d.length() - 1.0).abs() < 1e-6);
            let again = decode_snorm8(encode_snorm8(d));
            assert!(angle(again, d) < 1e-6, "code ({x}, {y})");
            let [qx, qy] = encode_snorm8(d);
            if x.unsigned_abs() < 127 && y.unsigned_abs() < 127 && x != i8::MIN && y != i8::MIN {
                // Off the seams, the code itself comes back.
                assert_eq!([qx, qy], [x, y]);
            }
        }
    }
}

/// The encoder's outputs cover the whole square and decode(encode(.)) is the identity on
/// points of the square off the seams.
#[test]
fn encode_inverts_decode_off_the_seams() {
    let mut rng = rng(4);
    for _ in 0..100_000 {
        let p = common::random_octa(&mut rng);
        if p.abs().max_element() > 0.999_99 {
            continue;
        }
        let q = encode(decode(p));
        assert!(q.abs_diff_eq(p, 2e-6), "{p} -> {q}");
    }
    assert_eq!(encode(decode(Vec2::new(0.25, -0.5))), Vec2::new(0.25, -0.5));
}
