//! Splitting world rays into straight octahedral segments, with degenerate cases.

mod common;

use glam::{Vec2, Vec3};
use probe_octa::{OctaSegments, RaySplitError, encode, split_ray};
use proptest::prelude::*;

/// Distance from `p` to the 2-D segment `[a, b]`.
fn distance_to_segment(p: Vec2, a: Vec2, b: Vec2) -> f32 {
    let ab = b - a;
    let t = if ab.length_squared() > 0.0 {
        ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0)
    } else {
        0.0
    };
    p.distance(a + ab * t)
}

/// Checks coverage of `[t_min, t_max]` and the straightness of every piece; returns the
/// largest distance of a sampled ray point's octahedral image from its piece's segment, less
/// what single-precision rounding alone allows at that point.
///
/// A ray point is computed to about `ε·scale` (ε the f32 epsilon, `scale` the magnitudes of
/// the origin, probe and `direction·t`) and the octahedral map magnifies an error by up to
/// `2 / |p|₁`, so near the probe centre the image of a sampled point moves by far more than
/// the segment's own error (a ray passing 0.1 mm from a probe 5 m from the origin).
fn check(
    pieces: &OctaSegments,
    probe: Vec3,
    origin: Vec3,
    direction: Vec3,
    t_min: f32,
    t_max: f32,
) -> f32 {
    assert!((1..=4).contains(&pieces.len()), "{} pieces", pieces.len());
    assert_eq!(pieces[0].t_start, t_min);
    assert_eq!(pieces[pieces.len() - 1].t_end, t_max);
    for pair in pieces.windows(2) {
        assert_eq!(pair[0].t_end, pair[1].t_start);
        assert!(pair[0].t_start < pair[0].t_end);
    }
    let mut worst = 0.0f32;
    for piece in pieces.iter() {
        assert!(piece.octa_start.abs().max_element() <= 1.0);
        assert!(piece.octa_end.abs().max_element() <= 1.0);
        if !(piece.t_start.is_finite() && piece.t_end.is_finite()) {
            continue;
        }
        for k in 1..100 {
            let t = piece.t_start + (piece.t_end - piece.t_start) * k as f32 / 100.0;
            let point = origin + direction * t - probe;
            let scale = origin.abs().max_element()
                + probe.abs().max_element()
                + (direction * t).abs().max_element();
            // Several roundings on either side (the test's point and the split's), each at
            // most ε·scale per coordinate; the probe centre itself has no direction (∞).
            let rounding = 16.0 * f32::EPSILON * scale * 2.0 / point.abs().element_sum();
            let p = encode(point);
            let off = distance_to_segment(p, piece.octa_start, piece.octa_end);
            worst = worst.max(off - rounding);
        }
    }
    worst
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 2000,
        rng_seed: proptest::test_runner::RngSeed::Fixed(1),
        ..ProptestConfig::default()
    })]

    /// Random rays near a random probe: the pieces cover the range and are straight.
    #[test]
    fn random_rays_split_into_straight_pieces(
        probe in prop::array::uniform3(-5.0f32..5.0),
        origin in prop::array::uniform3(-5.0f32..5.0),
        direction in prop::array::uniform3(-1.0f32..1.0),
        t_min in -3.0f32..3.0,
        length in 0.01f32..10.0,
    ) {
        let (probe, origin, direction) =
            (Vec3::from(probe), Vec3::from(origin), Vec3::from(direction));
        prop_assume!(direction.length() > 1e-3);
        let t_max = t_min + length;
        let pieces = split_ray(probe, origin, direction, t_min, t_max).unwrap();
        let worst = check(&pieces, probe, origin, direction, t_min, t_max);
        prop_assert!(worst < 2e-5, "off-segment distance {}", worst);
        // Each cut lies on one of the probe's planes.
        for piece in pieces.iter().skip(1) {
            let q = origin + direction * piece.t_start - probe;
            let scale = origin.abs().max_element() + probe.abs().max_element()
                + direction.abs().max_element() * piece.t_start.abs();
            prop_assert!(q.abs().min_element() <= 1e-5 * scale.max(1.0), "{}", q);
        }
    }
}

#[test]
fn a_ray_through_every_octant_gives_four_pieces() {
    // From (−,−,−) to (+,+,+) crossing the three planes at different t.
    let origin = Vec3::new(-1.0, -2.0, -3.0);
    let direction = Vec3::ONE;
    let pieces = split_ray(Vec3::ZERO, origin, direction, 0.0, 5.0).unwrap();
    assert_eq!(pieces.len(), 4);
    let cuts: Vec<f32> = pieces.iter().skip(1).map(|p| p.t_start).collect();
    assert_eq!(cuts, [1.0, 2.0, 3.0]);
    assert!(check(&pieces, Vec3::ZERO, origin, direction, 0.0, 5.0) < 1e-5);
}

#[test]
fn pieces_crossing_a_fold_end_on_their_own_side() {
    // Below the probe (z < 0), crossing x = 0: the octahedral map folds there, so the piece
    // before the cut ends on the u < 0 side and the piece after starts on the u > 0 side.
    let origin = Vec3::new(-1.0, 0.5, -1.0);
    let pieces = split_ray(Vec3::ZERO, origin, Vec3::X, 0.0, 2.0).unwrap();
    assert_eq!(pieces.len(), 2);
    assert!(pieces[0].octa_end.x < 0.0, "{}", pieces[0].octa_end);
    assert!(pieces[1].octa_start.x > 0.0, "{}", pieces[1].octa_start);
    // They are the same direction: mirror images across the outer edge v = +1.
    assert!((pieces[0].octa_end.y - 1.0).abs() < 1e-6);
    assert!((pieces[0].octa_end.x + pieces[1].octa_start.x).abs() < 1e-6);
    // Upper hemisphere crossings are continuous instead.
    let pieces = split_ray(Vec3::ZERO, Vec3::new(-1.0, 0.5, 1.0), Vec3::X, 0.0, 2.0).unwrap();
    assert_eq!(pieces[0].octa_end, pieces[1].octa_start);
}

#[test]
fn a_ray_through_the_probe_centre() {
    let direction = Vec3::new(1.0, 2.0, -0.5);
    let probe = Vec3::new(0.5, 0.5, 0.5);
    let origin = probe - direction * 2.0;
    let pieces = split_ray(probe, origin, direction, 0.0, 5.0).unwrap();
    // One cut at t = 2 (all three planes at once, merged); each side is a single point.
    assert_eq!(pieces.len(), 2);
    assert_eq!(pieces[0].t_end, 2.0);
    assert!(pieces[0].octa_start.abs_diff_eq(encode(-direction), 1e-6));
    assert!(pieces[0].octa_end.abs_diff_eq(encode(-direction), 1e-6));
    assert!(pieces[1].octa_start.abs_diff_eq(encode(direction), 1e-6));
    assert!(pieces[1].octa_end.abs_diff_eq(encode(direction), 1e-6));
    // Starting exactly at the centre.
    let pieces = split_ray(probe, probe, direction, 0.0, 1.0).unwrap();
    assert_eq!(pieces.len(), 1);
    assert!(pieces[0].octa_start.abs_diff_eq(encode(direction), 1e-6));
}

#[test]
fn rays_parallel_to_or_inside_a_plane() {
    // Parallel to z = 0 (direction has no z): crosses x = 0 and y = 0 only.
    let pieces = split_ray(
        Vec3::ZERO,
        Vec3::new(-1.0, -2.0, 0.5),
        Vec3::X + Vec3::Y,
        0.0,
        4.0,
    )
    .unwrap();
    assert_eq!(pieces.len(), 3);
    assert!(
        check(
            &pieces,
            Vec3::ZERO,
            Vec3::new(-1.0, -2.0, 0.5),
            Vec3::X + Vec3::Y,
            0.0,
            4.0
        ) < 1e-5
    );
    // Lying in the plane y = 0, below the probe: one piece per side of x = 0, each straight.
    let origin = Vec3::new(-2.0, 0.0, -1.0);
    let pieces = split_ray(Vec3::ZERO, origin, Vec3::X, 0.0, 4.0).unwrap();
    assert_eq!(pieces.len(), 2);
    assert!(check(&pieces, Vec3::ZERO, origin, Vec3::X, 0.0, 4.0) < 1e-5);
    // Lying in the plane z = 0: the equator, the diamond |u| + |v| = 1.
    let origin = Vec3::new(-2.0, 1.0, 0.0);
    let pieces = split_ray(Vec3::ZERO, origin, Vec3::X, 0.0, 4.0).unwrap();
    for piece in pieces.iter() {
        for p in [piece.octa_start, piece.octa_end] {
            assert!((p.x.abs() + p.y.abs() - 1.0).abs() < 1e-6, "{p}");
        }
    }
}

#[test]
fn zero_length_and_infinite_ranges() {
    let origin = Vec3::new(1.0, 2.0, 3.0);
    let direction = Vec3::new(-1.0, 0.0, 0.0);
    let pieces = split_ray(Vec3::ZERO, origin, direction, 1.0, 1.0).unwrap();
    assert_eq!(pieces.len(), 1);
    assert_eq!((pieces[0].t_start, pieces[0].t_end), (1.0, 1.0));
    assert_eq!(pieces[0].octa_start, pieces[0].octa_end);
    assert_eq!(pieces[0].octa_start, encode(origin + direction));

    // To infinity: the last piece ends at the octahedral point of the direction itself.
    let pieces = split_ray(Vec3::ZERO, origin, direction, 0.0, f32::INFINITY).unwrap();
    assert_eq!(pieces.len(), 2);
    assert_eq!(pieces[1].t_end, f32::INFINITY);
    assert_eq!(pieces[1].octa_end, encode(direction));
    let pieces = split_ray(
        Vec3::ZERO,
        origin,
        direction,
        f32::NEG_INFINITY,
        f32::INFINITY,
    )
    .unwrap();
    assert_eq!(pieces[0].octa_start, encode(-direction));
}

#[test]
fn bad_rays_are_refused_with_the_parameter_named() {
    let ok = Vec3::ONE;
    assert_eq!(
        split_ray(Vec3::new(f32::NAN, 0.0, 0.0), ok, ok, 0.0, 1.0),
        Err(RaySplitError::NonFinite { parameter: "probe" })
    );
    assert_eq!(
        split_ray(ok, Vec3::INFINITY, ok, 0.0, 1.0),
        Err(RaySplitError::NonFinite {
            parameter: "origin"
        })
    );
    assert_eq!(
        split_ray(ok, ok, Vec3::ZERO, 0.0, 1.0),
        Err(RaySplitError::ZeroDirection)
    );
    assert!(matches!(
        split_ray(ok, ok, ok, 2.0, 1.0),
        Err(RaySplitError::InvalidRange { .. })
    ));
    assert!(split_ray(ok, ok, ok, f32::NAN, 1.0).is_err());
    let message = split_ray(ok, ok, Vec3::new(0.0, f32::NAN, 0.0), 0.0, 1.0)
        .unwrap_err()
        .to_string();
    assert!(message.contains("direction"), "{message}");
}
