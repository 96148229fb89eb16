//! Property tests of the invariants the rest of the workspace relies on: encoding round trips
//! for any vector (not only unit directions), the texel grid's directions and lookups, split
//! rays whose pieces start and end where the ray's points encode, and bilinear samples that
//! stay within a texel's worth of gradient of the mapped function everywhere, seams and
//! corners included.

mod common;

use common::angle;
use glam::{Vec2, Vec3};
use probe_octa::{OctaLayout, OctaMap, decode, encode, split_ray};
use proptest::prelude::*;

/// A non-zero vector of any length from 1e-6 to 1e6, in any direction.
fn any_vector() -> impl Strategy<Value = Vec3> {
    (prop::array::uniform3(-1.0f32..1.0), -6.0f32..6.0)
        .prop_filter("a direction", |(v, _)| Vec3::from(*v).length() > 1e-3)
        .prop_map(|(v, exponent)| Vec3::from(v) * 10f32.powf(exponent))
}

/// `a·d + k (c·d)²` with `|c| = 1`: its gradient on the sphere is at most `|a| + 2|k|`.
#[derive(Debug, Clone)]
struct Smooth {
    a: Vec3,
    k: f32,
    c: Vec3,
}

impl Smooth {
    fn eval(&self, d: Vec3) -> f32 {
        self.a.dot(d) + self.k * self.c.dot(d).powi(2)
    }
    fn lipschitz(&self) -> f32 {
        self.a.length() + 2.0 * self.k.abs()
    }
}

fn smooth() -> impl Strategy<Value = Smooth> {
    (
        prop::array::uniform3(-1.0f32..1.0),
        -1.0f32..1.0,
        prop::array::uniform3(-1.0f32..1.0),
    )
        .prop_filter("a unit axis", |(_, _, c)| Vec3::from(*c).length() > 0.1)
        .prop_map(|(a, k, c)| Smooth {
            a: Vec3::from(a),
            k,
            c: Vec3::from(c).normalize(),
        })
}

/// A point of one of the four outer edges of the square, away from the corners, with the 3-D
/// axis that crosses the seam there (edges `u = ±1` are `y = 0, z < 0`; `v = ±1` are `x = 0`).
fn seam_point() -> impl Strategy<Value = (Vec2, Vec3)> {
    (0usize..4, -0.98f32..0.98).prop_map(|(edge, s)| match edge {
        0 => (Vec2::new(1.0, s), Vec3::Y),
        1 => (Vec2::new(-1.0, s), Vec3::Y),
        2 => (Vec2::new(s, 1.0), Vec3::X),
        _ => (Vec2::new(s, -1.0), Vec3::X),
    })
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 1000,
        rng_seed: proptest::test_runner::RngSeed::Fixed(1),
        ..ProptestConfig::default()
    })]

    /// Any finite non-zero vector encodes into the square and decodes to its own direction,
    /// whatever its length (the encoder rescales; only the direction matters).
    #[test]
    fn encode_then_decode_keeps_the_direction(v in any_vector()) {
        let p = encode(v);
        prop_assert!(p.abs().max_element() <= 1.0, "{v} encodes outside the square: {p}");
        let d = decode(p);
        prop_assert!((d.length() - 1.0).abs() < 1e-6, "{d} is not unit length");
        let error = angle(d, v);
        prop_assert!(error < 1e-5, "{v}: round trip off by {error} rad");
        // The scale does not matter: the same direction at another length encodes alike.
        prop_assert!(encode(v * 0.001).distance(p) < 1e-6);
    }

    /// Inside the square (away from its outer edges, where opposite sides meet), decoding is
    /// one-to-one and `encode` inverts it.
    #[test]
    fn decode_then_encode_is_the_identity_inside_the_square(
        o in prop::array::uniform2(-0.999f32..0.999)
    ) {
        let o = Vec2::from(o);
        let back = encode(decode(o));
        prop_assert!(back.distance(o) < 2e-6, "{o} comes back as {back}");
    }

    /// Every texel's centre direction lies in that texel, and any direction's texel holds it:
    /// the direction is no farther from the texel's centre than the texel's half-diagonal.
    #[test]
    fn texel_lookups_agree_with_texel_directions(
        log_n in 0u32..10,
        cell in prop::array::uniform2(0.0f64..1.0),
        v in any_vector(),
    ) {
        let n = 1u32 << log_n;
        let layout = OctaLayout::new(n).unwrap();
        let [ix, iy] = cell.map(|c| ((c * f64::from(n)) as u32).min(n - 1));
        prop_assert_eq!(layout.texel_containing(layout.texel_direction(ix, iy)), [ix, iy]);
        let [jx, jy] = layout.texel_containing(v);
        prop_assert!(jx < n && jy < n);
        let offset = encode(v) - layout.texel_center(jx, jy);
        prop_assert!(
            offset.abs().max_element() <= 1.0 / n as f32 + 1e-6,
            "{v} is {offset} from the centre of texel ({jx}, {jy}) at N = {n}"
        );
        // Continuous texel coordinates stay on the interior, next to that texel (padded = +1).
        let c = layout.texel_coords(v);
        prop_assert!(c.min_element() >= 1.0 && c.max_element() <= n as f32 + 1.0, "{c}");
        let centre = Vec2::new(jx as f32 + 1.5, jy as f32 + 1.5);
        prop_assert!((c - centre).abs().max_element() <= 0.5 + 1e-3, "{c} vs {centre}");
    }

    /// A split ray's pieces start and end where the ray's own points encode: each piece's
    /// interior points, just inside its ends, encode next to `octa_start` and `octa_end`.
    #[test]
    fn split_pieces_end_where_the_ray_points_encode(
        probe in prop::array::uniform3(-5.0f32..5.0),
        origin in prop::array::uniform3(-5.0f32..5.0),
        direction in prop::array::uniform3(-1.0f32..1.0),
        t_min in -3.0f32..3.0,
        length in 0.01f32..10.0,
    ) {
        let (probe, origin, direction) =
            (Vec3::from(probe), Vec3::from(origin), Vec3::from(direction));
        prop_assume!(direction.length() > 1e-2);
        let pieces = split_ray(probe, origin, direction, t_min, t_min + length).unwrap();
        for piece in pieces.iter() {
            let span = piece.t_end - piece.t_start;
            if span < 1e-3 {
                continue;
            }
            for (t, end) in [
                (piece.t_start + 1e-4 * span, piece.octa_start),
                (piece.t_end - 1e-4 * span, piece.octa_end),
            ] {
                let point = origin + direction * t - probe;
                // Too close to the probe centre, a point's direction is noise.
                prop_assume!(point.length() > 1e-2);
                // The square's border is folded onto itself (`(1, y)` and `(1, −y)` are one
                // direction, all four corners are −Z), so an end on the border may be any of
                // its equivalent points.
                let on_x = end.x.abs() >= 1.0 - 1e-6;
                let on_y = end.y.abs() >= 1.0 - 1e-6;
                let mut twins = vec![end];
                if on_x {
                    twins.push(Vec2::new(end.x, -end.y));
                }
                if on_y {
                    twins.push(Vec2::new(-end.x, end.y));
                }
                if on_x && on_y {
                    twins.push(-end);
                }
                let encoded = encode(point);
                let gap = twins
                    .iter()
                    .map(|twin| encoded.distance(*twin))
                    .fold(f32::INFINITY, f32::min);
                // The point is 1e-4 of the piece from its end; the map's slope near the probe
                // is about |direction| · span / |point| per unit of t.
                let allowed = 1e-3 + 4e-4 * direction.length() * span / point.length();
                prop_assert!(gap <= allowed, "gap {gap} > {allowed} at t = {t} of {piece:?}");
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 300,
        rng_seed: proptest::test_runner::RngSeed::Fixed(1),
        ..ProptestConfig::default()
    })]

    /// Bilinear sampling through the padding is within a texel's worth of gradient of a smooth
    /// function everywhere, so across the seams too; the two sides of an outer edge, a
    /// hundredth of a texel apart, differ by little more than the step itself.
    #[test]
    fn padded_bilinear_samples_are_continuous_across_seams(
        f in smooth(),
        log_n in 3u32..8,
        d in prop::array::uniform3(-1.0f32..1.0),
        (seam, across) in seam_point(),
    ) {
        let n = 1u32 << log_n;
        let map = OctaMap::from_fn(n, |d| f.eval(d)).unwrap();
        // Angular size of a texel, roughly (as in tests/seams.rs).
        let texel_angle = 4.0 / n as f32;
        let bound = 1.5 * texel_angle * f.lipschitz() + 1e-6;
        let d = Vec3::from(d);
        prop_assume!(d.length() > 1e-3);
        let error = (map.sample(d) - f.eval(d.normalize())).abs();
        prop_assert!(error <= bound, "n = {n}: sample off by {error} > {bound} at {d}");

        let on_seam = decode(seam);
        let step = 0.01 * texel_angle;
        let plus = (on_seam + across * step).normalize();
        let minus = (on_seam - across * step).normalize();
        let jump = (map.sample(plus) - map.sample(minus)).abs();
        let allowed = 0.03 * texel_angle * f.lipschitz() + 1e-6;
        prop_assert!(jump <= allowed, "n = {n}: jump {jump} > {allowed} across {seam}");
    }
}
