//! The min/max pyramid is conservative: for any direction inside a coarse texel, the fine value
//! a tracer reads there (nearest, or bilinear through the padding) lies within its [min, max].
//! Seeded loops over many random maps, smooth and discontinuous, and random directions
//! including directions just across seams and corners.

mod common;

use common::{random_direction, random_octa, rng};
use glam::{Vec2, Vec3};
use probe_octa::{FineRead, MinMaxPyramid, OctaLayout, OctaMap, decode};
use rand::Rng;

/// A random radial-distance map of one of several kinds.
fn random_map(rng: &mut impl Rng, n: u32, kind: usize) -> OctaMap<f32> {
    match kind {
        // Smooth: a random linear-plus-quadratic function, kept positive.
        0 => {
            let a = random_direction(rng) * rng.random_range(0.0..3.0);
            let c = random_direction(rng);
            OctaMap::from_fn(n, |d| 5.0 + a.dot(d) + 2.0 * c.dot(d).powi(2)).unwrap()
        }
        // Depth edges: a wall in front of part of the view, random half-spaces of directions.
        1 => {
            let planes: Vec<(Vec3, f32, f32)> = (0..3)
                .map(|_| {
                    (
                        random_direction(rng),
                        rng.random_range(-0.8..0.8),
                        rng.random_range(0.2..20.0),
                    )
                })
                .collect();
            OctaMap::from_fn(n, |d| {
                planes
                    .iter()
                    .filter(|(normal, offset, _)| normal.dot(d) > *offset)
                    .map(|&(_, _, r)| r)
                    .fold(50.0, f32::min)
            })
            .unwrap()
        }
        // Noise: independent random texels.
        2 => OctaMap::from_fn(n, |_| rng.random_range(0.1..100.0)).unwrap(),
        // Sparse spikes: mostly far, a few near texels (thin geometry close to the probe).
        _ => OctaMap::from_fn(n, |_| {
            if rng.random_bool(0.02) {
                rng.random_range(0.05..0.5)
            } else {
                rng.random_range(30.0..31.0)
            }
        })
        .unwrap(),
    }
}

/// Directions to test: uniform, near texel boundaries of the coarse levels, just across the
/// outer edges, and around the corners (`−z`).
fn test_directions(rng: &mut impl Rng, n: u32) -> Vec<Vec3> {
    let mut out = Vec::new();
    for _ in 0..1500 {
        out.push(random_direction(rng));
    }
    let texel = 2.0 / n as f32;
    for _ in 0..600 {
        // Points on fine texel boundaries (which include every coarse boundary), nudged.
        let mut p = random_octa(rng);
        let k = rng.random_range(0..=n) as f32;
        let nudge = rng.random_range(-1e-3..1e-3) * texel;
        if rng.random_bool(0.5) {
            p.x = (-1.0 + k * texel + nudge).clamp(-1.0, 1.0);
        } else {
            p.y = (-1.0 + k * texel + nudge).clamp(-1.0, 1.0);
        }
        out.push(decode(p));
    }
    for _ in 0..600 {
        // Just inside an outer edge, i.e. just across the seam from its mirror.
        let s: f32 = rng.random_range(-1.0..1.0);
        let inset = 1.0 - rng.random_range(0.0..1.5) * texel;
        let p = match rng.random_range(0..4) {
            0 => Vec2::new(inset, s),
            1 => Vec2::new(-inset, s),
            2 => Vec2::new(s, inset),
            _ => Vec2::new(s, -inset),
        };
        out.push(decode(p));
    }
    for _ in 0..300 {
        // Around −z, within a couple of texels of it: the four corners of the map.
        let r = rng.random_range(0.0..2.0) * texel;
        let phi = rng.random_range(0.0..std::f32::consts::TAU);
        out.push(Vec3::new(r * phi.cos(), r * phi.sin(), -1.0).normalize());
    }
    out
}

/// Checks every level of a pyramid against every test direction; returns violations.
fn violations(pyramid: &MinMaxPyramid, map: &OctaMap<f32>, directions: &[Vec3]) -> usize {
    let mut count = 0;
    for &d in directions {
        let value = match pyramid.fine_read() {
            FineRead::Nearest => map.sample_nearest(d),
            FineRead::Bilinear => map.sample(d),
        };
        // A bilinear blend may round a few ulps past its taps.
        let slack = match pyramid.fine_read() {
            FineRead::Nearest => 0.0,
            FineRead::Bilinear => 4.0 * f32::EPSILON * value.abs(),
        };
        for level in 0..pyramid.level_count() {
            let bounds = pyramid.min_max(level, d).unwrap();
            if value < bounds.x - slack || value > bounds.y + slack {
                count += 1;
            }
        }
    }
    count
}

#[test]
fn every_level_bounds_what_a_tracer_reads() {
    let mut rng = rng(11);
    for n in [8u32, 16, 64] {
        let directions = test_directions(&mut rng, n);
        for kind in 0..4 {
            for _ in 0..6 {
                let map = random_map(&mut rng, n, kind);
                for read in [FineRead::Nearest, FineRead::Bilinear] {
                    let pyramid = MinMaxPyramid::build(&map, read, u32::MAX).unwrap();
                    assert_eq!(pyramid.level_count() as u32, n.trailing_zeros() + 1);
                    let bad = violations(&pyramid, &map, &directions);
                    assert_eq!(bad, 0, "n={n} kind={kind} {read:?}");
                }
            }
        }
    }
}

/// The bilinear footprint is needed: a pyramid built for nearest reads is violated by
/// bilinear reads on discontinuous maps (so the test above can fail).
#[test]
fn nearest_footprint_is_not_enough_for_bilinear_reads() {
    let mut rng = rng(12);
    let n = 16;
    let directions = test_directions(&mut rng, n);
    let mut total = 0;
    for kind in [1, 2, 3] {
        let map = random_map(&mut rng, n, kind);
        let nearest = MinMaxPyramid::build(&map, FineRead::Nearest, u32::MAX).unwrap();
        // Pretend a bilinear tracer used the nearest pyramid.
        for &d in &directions {
            let value = map.sample(d);
            let bounds = nearest.min_max(0, d).unwrap();
            if value < bounds.x || value > bounds.y {
                total += 1;
            }
        }
    }
    assert!(total > 100, "only {total} violations");
}

/// Bounds are tight: each coarse texel equals the min/max over exactly its footprint
/// (computed independently from the padded texels and the documented border rules).
#[test]
fn bounds_are_exactly_the_footprint() {
    let mut rng = rng(13);
    let n = 16u32;
    let map = random_map(&mut rng, n, 2);
    let layout = map.layout();
    let padded = |px: u32, py: u32| map.texels()[layout.padded_index(px, py)];
    for read in [FineRead::Nearest, FineRead::Bilinear] {
        let pyramid = MinMaxPyramid::build(&map, read, u32::MAX).unwrap();
        for level in 0..pyramid.level_count() {
            let size = pyramid.level_resolution(level).unwrap();
            let k = n / size;
            let texels = pyramid.level(level).unwrap();
            for y in 0..size {
                for x in 0..size {
                    // Padded range of the footprint.
                    let (lo_x, hi_x, lo_y, hi_y) = match read {
                        FineRead::Nearest => (x * k + 1, (x + 1) * k, y * k + 1, (y + 1) * k),
                        FineRead::Bilinear => (x * k, (x + 1) * k + 1, y * k, (y + 1) * k + 1),
                    };
                    let mut min = f32::INFINITY;
                    let mut max = f32::NEG_INFINITY;
                    for py in lo_y..=hi_y {
                        for px in lo_x..=hi_x {
                            // Border texels hold their documented source's value.
                            let v = padded(px, py);
                            if let Some([sx, sy]) = layout.border_source(px, py) {
                                assert_eq!(v, padded(sx, sy));
                            }
                            min = min.min(v);
                            max = max.max(v);
                        }
                    }
                    assert_eq!(texels[(y * size + x) as usize], Vec2::new(min, max));
                }
            }
        }
    }
}

/// McGuire 2017's two-level tracer: a 16× down-sampled minimum-distance map, padded like any
/// octahedral map, whose texels bound every bilinear read inside them from below.
#[test]
fn sixteen_times_minimum_map() {
    let mut rng = rng(14);
    let map = random_map(&mut rng, 256, 1);
    let pyramid = MinMaxPyramid::build(&map, FineRead::Bilinear, 7).unwrap();
    let low = pyramid.min_distance_map(16).unwrap();
    assert_eq!(low.resolution(), 16);
    assert_eq!(low.texels().len(), 18 * 18);
    let layout = OctaLayout::new(16).unwrap();
    for d in test_directions(&mut rng, 256) {
        let [x, y] = layout.texel_containing(d);
        let bound = low.get(x, y).unwrap();
        assert!(map.sample(d) >= bound * (1.0 - 4.0 * f32::EPSILON), "{d}");
        // Nearest reads of the low map give the same bound.
        assert_eq!(low.sample_nearest(d), bound);
    }
}
