//! Irradiance, distance moments and spherical harmonics against analytic results.

mod common;

use std::f32::consts::PI;

use common::{random_direction, rng};
use glam::{Vec2, Vec3};
use probe_octa::{
    DDGI_DISTANCE_RESOLUTION, DDGI_IRRADIANCE_RESOLUTION, OctaMap, ShL2Rgb, chebyshev_visibility,
    distance_moments, irradiance_map, lobe_mean,
};

/// Irradiance of the clamped-cosine radiance lobe `L(ω) = max(0, a·ω)` at a normal making
/// angle `γ` with `a`: `∫ max(0, a·ω) max(0, n·ω) dω = (2/3)((π − γ) cos γ + sin γ)`.
fn clamped_cosine_irradiance(gamma: f32) -> f32 {
    (2.0 / 3.0) * ((PI - gamma) * gamma.cos() + gamma.sin())
}

#[test]
fn constant_radiance_gives_pi_times_radiance() {
    let radiance = Vec3::new(0.5, 1.0, 2.0);
    let map = OctaMap::filled(64, radiance).unwrap();
    let irradiance = irradiance_map(&map, DDGI_IRRADIANCE_RESOLUTION).unwrap();
    assert_eq!(irradiance.texels().len(), 8 * 8);
    for e in irradiance.texels() {
        assert!(e.abs_diff_eq(radiance * PI, 2e-3 * PI * 2.0), "{e}");
    }
}

#[test]
fn clamped_cosine_lobe_gives_the_known_irradiance() {
    let a = Vec3::new(0.3, -0.5, 0.8).normalize();
    let map = OctaMap::from_fn(128, |d| a.dot(d).max(0.0)).unwrap();
    let irradiance = irradiance_map(&map, 16).unwrap();
    let layout = irradiance.layout();
    for iy in 0..16 {
        for ix in 0..16 {
            let n = layout.texel_direction(ix, iy);
            let expected = clamped_cosine_irradiance(n.angle_between(a));
            let got = irradiance.get(ix, iy).unwrap();
            assert!((got - expected).abs() < 2e-3, "n={n}: {got} vs {expected}");
        }
    }
    // And irradiance maps sample smoothly between texels.
    for d in [Vec3::X, Vec3::NEG_Z, a, -a] {
        let expected = clamped_cosine_irradiance(d.angle_between(a));
        assert!((irradiance.sample(d) - expected).abs() < 0.05, "{d}");
    }
}

/// Over a normalised `cos^p` lobe around `n`, `E[a·ω] = (a·n)(p+1)/(p+2)`, `E[(n·ω)²] =
/// (p+1)/(p+3)`, and the perpendicular part averages `(1 − (p+1)/(p+3))/2` per axis.
#[test]
fn distance_moments_match_the_lobe_integrals() {
    let c = 3.0;
    let a = Vec3::new(0.4, -0.2, 0.6);
    let map = OctaMap::from_fn(128, |d| c + a.dot(d)).unwrap();
    for power in [1.0, 8.0, 50.0] {
        let moments = distance_moments(&map, DDGI_DISTANCE_RESOLUTION, power).unwrap();
        assert_eq!(moments.texels().len(), 16 * 16);
        let layout = moments.layout();
        let mean_cos = (power + 1.0) / (power + 2.0);
        let mean_cos2 = (power + 1.0) / (power + 3.0);
        for iy in 0..DDGI_DISTANCE_RESOLUTION {
            for ix in 0..DDGI_DISTANCE_RESOLUTION {
                let n = layout.texel_direction(ix, iy);
                let along = a.dot(n);
                let perpendicular2 = a.length_squared() - along * along;
                let mean = c + along * mean_cos;
                let mean2 = c * c
                    + 2.0 * c * along * mean_cos
                    + along * along * mean_cos2
                    + perpendicular2 * (1.0 - mean_cos2) / 2.0;
                let got = moments.get(ix, iy).unwrap();
                assert!(
                    (got - Vec2::new(mean, mean2)).abs().max_element() < 2e-3,
                    "p={power} n={n}: {got} vs ({mean}, {mean2})"
                );
            }
        }
    }
}

/// Constant distance: zero variance, so Chebyshev passes everything nearer and nothing
/// farther; a depth edge gives variance only near the edge.
#[test]
fn moments_drive_the_chebyshev_test() {
    let flat = OctaMap::filled(32, 2.0f32).unwrap();
    let moments = distance_moments(&flat, 14, 50.0).unwrap();
    let m = moments.sample(Vec3::new(0.2, 0.3, 0.9));
    assert!((m - Vec2::new(2.0, 4.0)).abs().max_element() < 1e-4, "{m}");
    assert_eq!(chebyshev_visibility(m, 1.9), 1.0);
    assert!(chebyshev_visibility(m, 2.5) < 1e-3);

    // A wall at distance 1 over x > 0, open space at distance 5 elsewhere.
    let edge = OctaMap::from_fn(64, |d| if d.x > 0.0 { 1.0 } else { 5.0 }).unwrap();
    let moments = distance_moments(&edge, 14, 50.0).unwrap();
    let variance = |d: Vec3| {
        let m = moments.sample(d);
        m.y - m.x * m.x
    };
    assert!(variance(Vec3::X) < 1e-3);
    assert!(variance(Vec3::NEG_X) < 1e-2);
    assert!(variance(Vec3::Z) > 1.0, "{}", variance(Vec3::Z));
    // Behind the wall (distance 3 along +x) is occluded; in the open it is visible.
    assert!(chebyshev_visibility(moments.sample(Vec3::X), 3.0) < 0.01);
    assert_eq!(chebyshev_visibility(moments.sample(Vec3::NEG_X), 3.0), 1.0);
}

#[test]
fn lobe_mean_of_power_zero_is_the_hemisphere_average() {
    let map = OctaMap::from_fn(64, |d: Vec3| d.z).unwrap();
    let mean = lobe_mean(&map, 8, 0.0).unwrap();
    // The hemisphere around +z averages z to 1/2; around the equator to 0.
    assert!((mean.sample(Vec3::Z) - 0.5).abs() < 0.02);
    assert!(mean.sample(Vec3::X).abs() < 0.02);
}

/// SH of any polynomial of degree ≤ 2 in the direction is exact (up to the map's quadrature).
#[test]
fn sh_reproduces_linear_and_quadratic_functions() {
    let f = |d: Vec3| {
        Vec3::new(
            1.0 + 0.5 * d.x - 0.25 * d.z,
            0.2 + d.y,
            0.7 * d.x * d.y + 0.3 * d.z * d.z - 0.1 * d.x,
        )
    };
    let map = OctaMap::from_fn(128, f).unwrap();
    let sh = ShL2Rgb::project(&map);
    let mut rng = rng(21);
    for _ in 0..1000 {
        let d = random_direction(&mut rng);
        assert!(
            sh.evaluate(d).abs_diff_eq(f(d), 2e-4),
            "{d}: {} vs {}",
            sh.evaluate(d),
            f(d)
        );
    }
    // A constant projects to exactly √(4π)·L in c₀ (exact texel solid angles); the other
    // coefficients vanish up to the texel-centre quadrature (only the zonal `3z² − 1` term
    // shows it: 0.0065 at 16², 1.1e-4 at 128²).
    for (n, tolerance) in [(16, 1e-2), (128, 2e-4)] {
        let constant = ShL2Rgb::project(&OctaMap::filled(n, Vec3::ONE).unwrap());
        assert!(constant.coefficients[0].abs_diff_eq(Vec3::splat((4.0 * PI).sqrt()), 1e-5));
        for c in &constant.coefficients[1..] {
            assert!(c.abs_max() < tolerance, "n={n}: {c}");
        }
    }
}

trait AbsMax {
    fn abs_max(self) -> f32;
}
impl AbsMax for Vec3 {
    fn abs_max(self) -> f32 {
        self.abs().max_element()
    }
}

/// SH irradiance: exact for constant and linear radiance (`E = πa + (2π/3) b·n`), agrees with
/// the brute-force irradiance map, and is within L2's known truncation error for a clamped
/// cosine lobe.
#[test]
fn sh_irradiance_matches_analytic_and_brute_force() {
    let b = Vec3::new(0.2, -0.4, 0.3);
    let linear = OctaMap::from_fn(128, |d| Vec3::splat(1.5 + b.dot(d))).unwrap();
    let sh = ShL2Rgb::project(&linear).irradiance();
    let brute = irradiance_map(&linear, 12).unwrap();
    let mut rng = rng(22);
    for _ in 0..500 {
        let n = random_direction(&mut rng);
        let expected = PI * 1.5 + 2.0 * PI / 3.0 * b.dot(n);
        assert!((sh.evaluate(n).x - expected).abs() < 1e-3, "{n}");
    }
    let layout = brute.layout();
    for iy in 0..12 {
        for ix in 0..12 {
            let n = layout.texel_direction(ix, iy);
            assert!((brute.get(ix, iy).unwrap().x - sh.evaluate(n).x).abs() < 5e-3);
        }
    }

    let a = Vec3::new(-0.6, 0.1, -0.7).normalize();
    let lobe = OctaMap::from_fn(128, |d| Vec3::splat(a.dot(d).max(0.0))).unwrap();
    let sh = ShL2Rgb::project(&lobe).irradiance();
    let mut worst = 0.0f32;
    for _ in 0..2000 {
        let n = random_direction(&mut rng);
        let expected = clamped_cosine_irradiance(n.angle_between(a));
        worst = worst.max((sh.evaluate(n).x - expected).abs());
    }
    // Relative to the peak 2π/3: L2 keeps the irradiance within a few per cent.
    let relative = worst / (2.0 * PI / 3.0);
    assert!(relative < 0.03, "worst SH irradiance error {relative}");
    assert!(
        relative > 1e-3,
        "a clamped cosine is not band-limited; the error cannot vanish"
    );
}
