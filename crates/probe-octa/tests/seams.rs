//! Seam-correct bilinear sampling: just across every outer edge and around the corners
//! (all four corners are `−z`), maps of smooth functions of direction are continuous, and a
//! sampler without the padding is not.

use glam::{Vec2, Vec3};
use probe_octa::{OctaMap, decode, encode};

/// `a·d + k (c·d)²` with `|c| = 1`: its gradient on the sphere is at most `|a| + 2|k|`.
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

fn functions() -> Vec<Smooth> {
    vec![
        Smooth {
            a: Vec3::new(0.7, -0.4, 0.5),
            k: 0.6,
            c: Vec3::new(1.0, 2.0, -2.0).normalize(),
        },
        Smooth {
            a: Vec3::new(-0.2, 1.0, 0.1),
            k: -0.8,
            c: Vec3::new(0.3, -0.1, 1.0).normalize(),
        },
        Smooth {
            a: Vec3::new(0.0, 0.0, 1.0),
            k: 1.0,
            c: Vec3::new(1.0, 1.0, 0.0).normalize(),
        },
    ]
}

/// Bilinear sampling that ignores the padding: taps clamped to the interior, as a plain
/// clamp-to-edge texture sampler of the unpadded map would read.
fn sample_clamped(map: &OctaMap<f32>, direction: Vec3) -> f32 {
    let layout = map.layout();
    let n = layout.resolution() as f32;
    let c = layout.texel_coords(direction) - Vec2::splat(0.5);
    let x0 = c.x.floor();
    let y0 = c.y.floor();
    let (tx, ty) = (c.x - x0, c.y - y0);
    let tap = |x: f32, y: f32| {
        let x = x.clamp(1.0, n) as u32;
        let y = y.clamp(1.0, n) as u32;
        map.texels()[layout.padded_index(x, y)]
    };
    tap(x0, y0) * (1.0 - tx) * (1.0 - ty)
        + tap(x0 + 1.0, y0) * tx * (1.0 - ty)
        + tap(x0, y0 + 1.0) * (1.0 - tx) * ty
        + tap(x0 + 1.0, y0 + 1.0) * tx * ty
}

/// A seam point, and the 3-D direction that crosses the seam there.
/// Edges `u = ±1` are the half-plane `y = 0, z < 0` (crossed along y); edges `v = ±1` are
/// `x = 0, z < 0` (crossed along x).
fn edge_points(count: usize) -> Vec<(Vec2, Vec3)> {
    let mut out = Vec::new();
    for i in 0..count {
        // Stay away from the corners (tested separately) and the edge midpoints (equator).
        let s = -0.98 + 1.96 * (i as f32 + 0.5) / count as f32;
        out.push((Vec2::new(1.0, s), Vec3::Y));
        out.push((Vec2::new(-1.0, s), Vec3::Y));
        out.push((Vec2::new(s, 1.0), Vec3::X));
        out.push((Vec2::new(s, -1.0), Vec3::X));
    }
    out
}

/// Largest difference between the two sides of every outer edge, for a sampler.
fn worst_edge_jump(
    map: &OctaMap<f32>,
    step: f32,
    sample: impl Fn(&OctaMap<f32>, Vec3) -> f32,
) -> f32 {
    let mut worst = 0.0f32;
    for (point, across) in edge_points(200) {
        let on_seam = decode(point);
        let plus = (on_seam + across * step).normalize();
        let minus = (on_seam - across * step).normalize();
        // The two sides really land on opposite sides of the map.
        assert!(encode(plus).distance(encode(minus)) > 0.1 * point.abs().min_element());
        worst = worst.max((sample(map, plus) - sample(map, minus)).abs());
    }
    worst
}

#[test]
fn outer_edges_are_continuous_and_the_bound_shrinks_with_resolution() {
    for f in functions() {
        let mut previous_bound = f32::INFINITY;
        for n in [16u32, 64, 256] {
            let map = OctaMap::from_fn(n, |d| f.eval(d)).unwrap();
            // Angular size of a texel, roughly; step a hundredth of it to either side.
            let texel_angle = 4.0 / n as f32;
            let step = 0.01 * texel_angle;
            let padded = worst_edge_jump(&map, step, |m, d| m.sample(d));
            let clamped = worst_edge_jump(&map, step, sample_clamped);
            // The step itself moves the value by up to 0.02 texel·gradient; measured jumps are
            // about 0.01 with the padding and 0.2–0.37 without it.
            let bound = 0.03 * texel_angle * f.lipschitz();
            assert!(padded <= bound, "n={n}: padded jump {padded} > {bound}");
            // Without the padding the jump is of the order of a texel's worth of gradient.
            assert!(
                clamped > 4.0 * bound,
                "n={n}: clamped jump {clamped} not detected"
            );
            assert!(bound < previous_bound);
            previous_bound = bound;

            // On the seam itself, the sample approaches the true value as resolution grows.
            let mut worst = 0.0f32;
            for (point, _) in edge_points(50) {
                let d = decode(point);
                worst = worst.max((map.sample(d) - f.eval(d)).abs());
            }
            assert!(worst <= 1.5 * texel_angle * f.lipschitz(), "n={n}: {worst}");
        }
    }
}

#[test]
fn the_four_corners_meet_continuously_at_minus_z() {
    for f in functions() {
        for n in [16u32, 64, 256] {
            let map = OctaMap::from_fn(n, |d| f.eval(d)).unwrap();
            let texel_angle = 4.0 / n as f32;
            let at_pole = map.sample(Vec3::NEG_Z);
            for corner in [
                Vec2::ONE,
                Vec2::NEG_ONE,
                Vec2::new(1.0, -1.0),
                Vec2::new(-1.0, 1.0),
            ] {
                let value = map.sample_octa(corner);
                assert!((value - at_pole).abs() < 1e-6, "n={n}: corner {corner}");
            }
            // A small circle around −z passes through all four corner regions of the map.
            let radius = 0.01 * texel_angle;
            let steps = 720;
            let mut previous = None;
            let mut corners_seen = [false; 4];
            for i in 0..=steps {
                let phi = std::f32::consts::TAU * i as f32 / steps as f32;
                let d = Vec3::new(radius * phi.cos(), radius * phi.sin(), -1.0).normalize();
                let p = encode(d);
                corners_seen[usize::from(p.x > 0.0) * 2 + usize::from(p.y > 0.0)] = true;
                let value = map.sample(d);
                assert!(
                    (value - at_pole).abs() <= 0.1 * texel_angle * f.lipschitz(),
                    "n={n}: {value} vs {at_pole} at {phi}"
                );
                if let Some(last) = previous {
                    let jump: f32 = value - last;
                    assert!(
                        jump.abs() <= 0.05 * texel_angle * f.lipschitz(),
                        "n={n} at {phi}"
                    );
                }
                previous = Some(value);
            }
            assert_eq!(corners_seen, [true; 4]);
            assert!((at_pole - f.eval(Vec3::NEG_Z)).abs() <= texel_angle * f.lipschitz());
        }
    }
}

/// The same holds for vector texels (here RGB as `[f32; 3]`).
#[test]
fn vector_maps_are_seam_correct_too() {
    let n = 32;
    let map = OctaMap::from_fn(n, |d: Vec3| [d.x, d.y * d.z, 1.0 - d.z]).unwrap();
    let texel_angle = 4.0 / n as f32;
    for (point, across) in edge_points(100) {
        let on_seam = decode(point);
        let a = map.sample((on_seam + across * 0.01 * texel_angle).normalize());
        let b = map.sample((on_seam - across * 0.01 * texel_angle).normalize());
        for k in 0..3 {
            assert!(
                (a[k] - b[k]).abs() <= 0.05 * texel_angle,
                "{point}: {a:?} vs {b:?}"
            );
        }
    }
}
