//! Light transport against closed forms: the direct irradiance of a square emitter (the
//! differential-area form factor) at small gaps, behind a two-sided emitter and at large
//! coordinates, and a diffuse furnace box for the reference renderer and the bake at several
//! albedos and bounce counts, and the variance of the renderers' stratified direct light.
//!
//! Every tolerance is a number of standard errors of the estimate, measured from the samples
//! themselves, plus a small relative allowance for f32 rounding where stated.

use std::f64::consts::PI;

use glam::Vec3;
use probe_capture::{
    BakeSettings, BakedRadiance, Component, Environment, RenderSettings, Rng, Sampling, Shader,
    bake, no_progress, render,
};
use probe_scene::{Camera, Material, Ray, Scene, Triangle};

mod support;
use support::quad;

/// A horizontal square of half-side `half` centred on `centre`, facing `facing` (±Y).
fn horizontal_square(centre: Vec3, half: f32, facing: Vec3, material: u32) -> [Triangle; 2] {
    let corner = |dx: f32, dz: f32| centre + Vec3::new(dx, 0.0, dz);
    quad(
        [
            corner(-half, -half),
            corner(half, -half),
            corner(half, half),
            corner(-half, half),
        ],
        facing,
        material,
    )
}

/// The form factor from a differential area to a parallel square of half-side `half`
/// centred straight above it at height `gap` (four corner rectangles of
/// `F = 1/(2π) [X/√(1+X²) atan(Y/√(1+X²)) + Y/√(1+Y²) atan(X/√(1+Y²))]`, with `X = Y`).
fn square_form_factor(half: f64, gap: f64) -> f64 {
    let x = half / gap;
    let s = (1.0 + x * x).sqrt();
    4.0 / PI * (x / s) * (x / s).atan()
}

/// Mean and standard error of the mean.
fn mean_and_standard_error(values: &[f64]) -> (f64, f64) {
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    let variance = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, (variance / n).sqrt())
}

/// The standard error of the mean of `values`, once the mean is asserted to agree with
/// `expected`: within five standard errors (a false failure about once in 2·10⁶) plus 1e-3 of
/// the answer for f32 rounding. `case` names the case in the failure message.
fn agreeing_standard_error(values: &[f64], expected: f64, case: &str) -> f64 {
    let (mean, standard_error) = mean_and_standard_error(values);
    assert!(
        (mean - expected).abs() <= 5.0 * standard_error + 1e-3 * expected,
        "{case}: {mean} vs {expected} (standard error {standard_error})"
    );
    standard_error
}

/// How the emitter square of [`emitter_over_receiver`] is made.
#[derive(Clone, Copy, Debug)]
enum EmitterSides {
    /// Single-sided, its front towards the receiver.
    Facing,
    /// Double-sided, its front away from the receiver: the receiver sees its back face.
    TwoSidedBack,
    /// Single-sided, its front away from the receiver: the receiver sees no light.
    Away,
}

const RADIANCE: f32 = 5.0;
const ALBEDO: f32 = 0.5;
const HALF: f32 = 0.05;

/// A large receiving plane (albedo [`ALBEDO`], facing +Y) through `origin` and a square
/// emitter (radiance [`RADIANCE`], half-side [`HALF`]) `gap` above `origin`, parallel to it.
fn emitter_over_receiver(origin: Vec3, gap: f32, sides: EmitterSides) -> Scene {
    let mut triangles = horizontal_square(origin, 20.0, Vec3::Y, 0).to_vec();
    let (facing, material) = match sides {
        EmitterSides::Facing => (-Vec3::Y, 1),
        EmitterSides::TwoSidedBack => (Vec3::Y, 2),
        EmitterSides::Away => (Vec3::Y, 1),
    };
    triangles.extend(horizontal_square(
        origin + Vec3::Y * gap,
        HALF,
        facing,
        material,
    ));
    let two_sided = Material {
        double_sided: true,
        ..Material::emitter("two-sided light", Vec3::splat(RADIANCE))
    };
    Scene::from_triangles(
        "square emitter",
        triangles,
        vec![
            Material::diffuse("receiver", Vec3::splat(ALBEDO)),
            Material::emitter("light", Vec3::splat(RADIANCE)),
            two_sided,
        ],
        Vec::new(),
        Vec::new(),
    )
    .unwrap()
}

/// `samples` one-sample direct-light estimates of the radiance leaving the receiver at
/// `point` (straight below the emitter's centre), seen from above.
fn direct_estimates(scene: &Scene, point: Vec3, gap: f32, samples: usize) -> Vec<f64> {
    let shader = Shader::new(scene, Environment::BLACK, 0).unwrap();
    // A ray straight down from between the plane and the emitter.
    let ray = Ray::new(point + Vec3::Y * (gap * 0.5), -Vec3::Y);
    let hit = scene
        .closest_hit(&ray, f32::INFINITY)
        .expect("the receiver");
    assert_eq!(hit.material, 0, "the ray must hit the receiver");
    assert!((hit.position - point).length() <= 1e-6 * point.abs().max_element().max(1.0));
    let mut rng = Rng::for_key(17, &[gap.to_bits().into()]);
    (0..samples)
        .map(|_| f64::from(shader.outgoing_radiance(&hit, Vec3::Y, &mut rng).x))
        .collect()
}

/// The direct light a point receives from a parallel square emitter agrees with the form
/// factor at gaps of 1 m, 0.1 m and 1 cm, from the emitter's front and from the back of a
/// two-sided emitter, near the origin and with everything moved 1 km away.
///
/// Before the shadow ray's direction and length were measured from its offset origin, the
/// 1 cm gaps received almost nothing and the 0.1 m gap about 0.8 of its due.
#[test]
fn square_emitter_matches_its_form_factor() {
    let samples = 200_000;
    for origin in [Vec3::new(0.013, 0.0, -0.021), Vec3::splat(1.0e3)] {
        for gap in [1.0f32, 0.1, 0.01] {
            for sides in [EmitterSides::Facing, EmitterSides::TwoSidedBack] {
                let scene = emitter_over_receiver(origin, gap, sides);
                let estimates = direct_estimates(&scene, origin, gap, samples);
                // L = ρ/π · E = ρ/π · π Le F = ρ Le F.
                let form_factor = square_form_factor(f64::from(HALF), f64::from(gap));
                let expected = f64::from(ALBEDO * RADIANCE) * form_factor;
                let standard_error = agreeing_standard_error(
                    &estimates,
                    expected,
                    &format!("origin {origin}, gap {gap}, {sides:?}, form factor {form_factor}"),
                );
                let tolerance = 5.0 * standard_error + 1e-3 * expected;
                // The tolerance is tight enough to mean something: under 5 % of the answer.
                assert!(
                    tolerance < 0.05 * expected,
                    "origin {origin}, gap {gap}, {sides:?}: tolerance {tolerance} of {expected}"
                );
            }
            // The back of a single-sided emitter gives nothing.
            let scene = emitter_over_receiver(origin, gap, EmitterSides::Away);
            let estimates = direct_estimates(&scene, origin, gap, 1_000);
            assert!(estimates.iter().all(|&e| e == 0.0), "gap {gap}");
        }
    }
}

/// A point on a ceiling 1 cm above a two-sided light (the Cornell glTF's arrangement, where
/// the ceiling received 0.0004–0.0007 instead of the form factor's 0.103), and the floor of a
/// room below it, see the light from both sides at once: each receives its form factor.
/// The height and half-side of [`ceiling_light`]'s square light, centred on the Y axis.
const LIGHT_HEIGHT: f32 = 0.99;
const LIGHT_HALF: f32 = 0.065;

/// The ceiling, floor and light of [`ceiling_and_floor_of_a_two_sided_light`]: the scene, and
/// per receiver its hit (seen from the gap between it and the light), the direction towards
/// that viewer and the radiance it reflects of the light (albedo × radiance × form factor).
fn ceiling_light() -> (Scene, Vec<(probe_scene::Hit, Vec3, f64)>) {
    let (ceiling, floor, light) = (1.0f32, 0.0f32, LIGHT_HEIGHT);
    let half = LIGHT_HALF;
    let mut triangles = horizontal_square(Vec3::new(0.0, ceiling, 0.0), 3.0, -Vec3::Y, 0).to_vec();
    triangles.extend(horizontal_square(
        Vec3::new(0.0, floor, 0.0),
        3.0,
        Vec3::Y,
        0,
    ));
    triangles.extend(horizontal_square(
        Vec3::new(0.0, light, 0.0),
        half,
        -Vec3::Y,
        1,
    ));
    let two_sided = Material {
        double_sided: true,
        ..Material::emitter("light", Vec3::splat(RADIANCE))
    };
    let scene = Scene::from_triangles(
        "ceiling light",
        triangles,
        vec![Material::diffuse("white", Vec3::splat(ALBEDO)), two_sided],
        Vec::new(),
        Vec::new(),
    )
    .unwrap();
    let receivers = [
        (Vec3::new(0.0, ceiling, 0.0), ceiling - light, -Vec3::Y),
        (Vec3::new(0.0, floor, 0.0), light - floor, Vec3::Y),
    ]
    .into_iter()
    .map(|(point, gap, towards_viewer)| {
        let viewer = point + towards_viewer * (gap * 0.5);
        let ray = Ray::new(viewer, -towards_viewer);
        let hit = scene.closest_hit(&ray, f32::INFINITY).unwrap();
        assert!((hit.position - point).length() < 1e-5);
        let expected =
            f64::from(ALBEDO * RADIANCE) * square_form_factor(f64::from(half), f64::from(gap));
        (hit, towards_viewer, expected)
    })
    .collect();
    (scene, receivers)
}

/// A point on a ceiling 1 cm above a two-sided light (the Cornell glTF's arrangement, where
/// the ceiling received 0.0004–0.0007 instead of the form factor's 0.103), and the floor of a
/// room below it, see the light from both sides at once: each receives its form factor.
#[test]
fn ceiling_and_floor_of_a_two_sided_light() {
    let (scene, receivers) = ceiling_light();
    let shader = Shader::new(&scene, Environment::BLACK, 0).unwrap();
    for (index, (hit, towards_viewer, expected)) in receivers.into_iter().enumerate() {
        let mut rng = Rng::for_key(5, &[index as u64]);
        let estimates: Vec<f64> = (0..400_000)
            .map(|_| f64::from(shader.outgoing_radiance(&hit, towards_viewer, &mut rng).x))
            .collect();
        let standard_error =
            agreeing_standard_error(&estimates, expected, &towards_viewer.to_string());
        assert!(
            standard_error < 0.01 * expected,
            "{towards_viewer}: standard error {standard_error} of {expected}"
        );
    }
}

/// The renderers' direct light ([`Shader::direct_irradiance`], here through
/// [`Shader::radiance_with_reflected`]) gives the same ceiling and floor their form factors,
/// and its 16 stratified light samples with 8 cosine rays under multiple importance sampling
/// have far less variance than 16 independent light samples: over 50× less on the ceiling,
/// 1 cm above the light, where light sampling alone meets the inverse square of tiny
/// distances, and over 3× less on the floor.
#[test]
fn direct_irradiance_meets_the_form_factor_with_less_variance() {
    let (scene, receivers) = ceiling_light();
    let shader = Shader::new(&scene, Environment::BLACK, 0).unwrap();
    for (index, (hit, towards_viewer, expected)) in receivers.into_iter().enumerate() {
        let estimates: Vec<f64> = (0..20_000u64)
            .map(|k| {
                let mut rng = Rng::for_key(11, &[index as u64, k]);
                let radiance =
                    shader.radiance_with_reflected(&hit, towards_viewer, Vec3::ZERO, 16, &mut rng);
                f64::from(radiance.x)
            })
            .collect();
        let standard_error =
            agreeing_standard_error(&estimates, expected, &towards_viewer.to_string());
        // The variance of a mean of 16 independent light samples (a uniform point on the
        // square, nothing in between), from 320,000 of them.
        let mut rng = Rng::for_key(13, &[index as u64]);
        let point = hit.position.as_dvec3();
        let one_sample: Vec<f64> = (0..320_000)
            .map(|_| {
                let (u, v) = (f64::from(rng.next_f32()), f64::from(rng.next_f32()));
                let half = f64::from(LIGHT_HALF);
                let on_light = glam::DVec3::new(
                    (2.0 * u - 1.0) * half,
                    f64::from(LIGHT_HEIGHT),
                    (2.0 * v - 1.0) * half,
                );
                let to_light = on_light - point;
                let distance_squared = to_light.length_squared();
                // Both planes are horizontal: the two cosines are equal.
                let cosine = to_light.y.abs() / distance_squared.sqrt();
                let area = 4.0 * half * half;
                f64::from(ALBEDO * RADIANCE) / PI * cosine * cosine * area / distance_squared
            })
            .collect();
        let one_sample_error = agreeing_standard_error(
            &one_sample,
            expected,
            &format!("{towards_viewer}, independent samples"),
        );
        let independent_variance = one_sample_error.powi(2) * 320_000.0 / 16.0;
        let variance = standard_error.powi(2) * 20_000.0;
        let ratio = independent_variance / variance;
        // Measured: 128× on the ceiling, 6.7× on the floor, which sees the whole light.
        let least = [50.0, 3.0][index];
        assert!(
            ratio > least,
            "{towards_viewer}: variance {variance} against independent samples' \
             {independent_variance} ({ratio}×, expected over {least}×)"
        );
    }
}

/// A closed box `[-1, 1]³` whose walls face inward, all with albedo `albedo` and emission
/// `emission`.
fn furnace_box(albedo: f32, emission: f32) -> Scene {
    let v = Vec3::new;
    let (a, b) = (-1.0f32, 1.0f32);
    let faces = [
        ([v(a, a, a), v(a, b, a), v(a, b, b), v(a, a, b)], Vec3::X),
        ([v(b, a, a), v(b, b, a), v(b, b, b), v(b, a, b)], -Vec3::X),
        ([v(a, a, a), v(b, a, a), v(b, a, b), v(a, a, b)], Vec3::Y),
        ([v(a, b, a), v(b, b, a), v(b, b, b), v(a, b, b)], -Vec3::Y),
        ([v(a, a, a), v(b, a, a), v(b, b, a), v(a, b, a)], Vec3::Z),
        ([v(a, a, b), v(b, a, b), v(b, b, b), v(a, b, b)], -Vec3::Z),
    ];
    let triangles = faces
        .into_iter()
        .flat_map(|(corners, facing)| quad(corners, facing, 0))
        .collect();
    let material = Material {
        emissive: Vec3::splat(emission),
        ..Material::diffuse("furnace wall", Vec3::splat(albedo))
    };
    Scene::from_triangles(
        "furnace box",
        triangles,
        vec![material],
        Vec::new(),
        Vec::new(),
    )
    .unwrap()
}

/// The radiance everywhere in a uniform furnace with `bounces` extra bounces after direct
/// light: `E Σ_{k ≤ bounces+1} a^k` (emission, then one reflection per bounce and one for
/// direct light), which tends to `E / (1 − a)`.
fn furnace_radiance(albedo: f64, emission: f64, bounces: u32) -> f64 {
    emission * (1.0 - albedo.powi(bounces as i32 + 2)) / (1.0 - albedo)
}

/// A uniform furnace box converges to the closed form in the reference renderer (direct and
/// full, at several bounce counts including Russian-roulette ones), at two albedos.
#[test]
fn furnace_box_reference() {
    let emission = 0.8f32;
    // Looking at the middle of a wall, away from the edges (where one-sample area lighting
    // is heavy-tailed).
    let camera = Camera::look_at(
        Vec3::new(0.1, -0.05, 0.2),
        Vec3::new(0.1, -0.05, -1.0),
        Vec3::Y,
        0.6,
    );
    for albedo in [0.3f32, 0.7] {
        let scene = furnace_box(albedo, emission);
        for (component, bounces) in [
            (Component::Direct, 0),
            (Component::Full, 0),
            (Component::Full, 2),
            (Component::Full, 64),
        ] {
            let mut settings = RenderSettings::new(32, 32);
            settings.component = component;
            settings.bounces = bounces;
            settings.samples_per_pixel = 16;
            settings.seed = 3;
            let image = render(&scene, &camera, &settings, &no_progress).unwrap();
            // Every pixel has the same expectation: their spread is the noise.
            let values: Vec<f64> = image.rgb.iter().map(|p| f64::from(p[1])).collect();
            let expected = furnace_radiance(f64::from(albedo), f64::from(emission), bounces);
            let standard_error = agreeing_standard_error(
                &values,
                expected,
                &format!("albedo {albedo}, {component:?}, {bounces} bounces"),
            );
            assert!(
                standard_error < 0.02 * expected,
                "albedo {albedo}, {component:?}, {bounces} bounces: standard error \
                 {standard_error} of {expected}"
            );
        }
        // All bounces: E / (1 − a), up to the truncation a^66 (below 1e-10 here).
        let full = furnace_radiance(f64::from(albedo), f64::from(emission), 64);
        let limit = f64::from(emission) / (1.0 - f64::from(albedo));
        assert!((full - limit).abs() < 1e-9 * limit);
    }
}

/// One probe in the furnace box baked at 32² (8 samples per texel, `bounces`, holding
/// `radiance`): the red radiance of the texels that see a wall away from its edges (near an
/// edge, one-sample area lighting of the neighbouring wall is heavy-tailed, its variance
/// growing as the inverse square of the distance to the edge, which would make the standard
/// error itself unreliable). At least 200 of them.
fn furnace_wall_texels(scene: &Scene, bounces: u32, radiance: BakedRadiance) -> Vec<f64> {
    let settings = BakeSettings {
        resolution: 32,
        sampling: Sampling::fixed(8),
        bounces,
        seed: 9,
        radiance,
        ..Default::default()
    };
    let probe = Vec3::new(0.1, 0.2, -0.15);
    let probes = bake(scene, &[probe], &settings, &no_progress).unwrap();
    let map = probes.radiance_map(0).unwrap();
    let distances = probes.distance_map(0).unwrap();
    let layout = map.layout();
    let values: Vec<f64> = (0..32)
        .flat_map(|iy| (0..32).map(move |ix| (ix, iy)))
        .filter(|&(ix, iy)| {
            let point = probe + layout.texel_direction(ix, iy) * distances.get(ix, iy).unwrap();
            point.abs().to_array().iter().filter(|&&c| c > 0.6).count() == 1
        })
        .map(|(ix, iy)| f64::from(map.get(ix, iy).unwrap().x))
        .collect();
    assert!(values.len() > 200, "{} texels", values.len());
    values
}

/// A probe bake in the furnace box: the mean texel radiance converges to the closed form at
/// 0, 1, 3 and 12 bounces (the last past Russian roulette's start), at two albedos.
#[test]
fn furnace_box_bake() {
    let emission = 1.2f32;
    for albedo in [0.3f32, 0.7] {
        let scene = furnace_box(albedo, emission);
        for bounces in [0u32, 1, 3, 12] {
            let values = furnace_wall_texels(&scene, bounces, BakedRadiance::Outgoing);
            let expected = furnace_radiance(f64::from(albedo), f64::from(emission), bounces);
            let standard_error = agreeing_standard_error(
                &values,
                expected,
                &format!("albedo {albedo}, {bounces} bounces"),
            );
            assert!(
                standard_error < 0.03 * expected,
                "albedo {albedo}, {bounces} bounces: standard error {standard_error} of \
                 {expected}"
            );
        }
    }
}

/// A bake of the reflected light alone ([`BakedRadiance::Indirect`]) in the furnace box holds
/// the closed form less the emission and the direct light (`E + aE`): `E Σ_{2 ≤ k ≤ bounces+1}
/// a^k`, zero without bounces; and a hit shaded with exact direct light plus that reflected
/// light ([`Shader::radiance_with_reflected`]) gives the whole closed form back.
#[test]
fn furnace_box_indirect_bake() {
    let emission = 1.2f32;
    for albedo in [0.3f32, 0.7] {
        let scene = furnace_box(albedo, emission);
        for bounces in [0u32, 1, 3] {
            let values = furnace_wall_texels(&scene, bounces, BakedRadiance::Indirect);
            let (a, e) = (f64::from(albedo), f64::from(emission));
            let expected = furnace_radiance(a, e, bounces) - e - a * e;
            if bounces == 0 {
                let (mean, _) = mean_and_standard_error(&values);
                assert_eq!(mean, 0.0, "albedo {albedo}: no bounce, no reflected light");
                continue;
            }
            let standard_error = agreeing_standard_error(
                &values,
                expected,
                &format!("albedo {albedo}, {bounces} bounces"),
            );
            assert!(
                standard_error < 0.05 * expected,
                "albedo {albedo}, {bounces} bounces: standard error {standard_error} of \
                 {expected}"
            );
            // The rest with shadow rays: emission plus direct light plus the reflected light
            // given is the whole closed form.
            let shader = Shader::new(&scene, Environment::BLACK, bounces).unwrap();
            let ray = Ray::new(Vec3::new(0.1, -0.05, 0.2), -Vec3::Z);
            let hit = scene.closest_hit(&ray, f32::INFINITY).unwrap();
            let mut rng = Rng::for_key(11, &[u64::from(bounces)]);
            let estimates: Vec<f64> = (0..2000)
                .map(|_| {
                    let reflected = Vec3::splat(expected as f32);
                    let shaded = shader.radiance_with_reflected(
                        &hit,
                        -ray.direction,
                        reflected,
                        16,
                        &mut rng,
                    );
                    f64::from(shaded.x)
                })
                .collect();
            let whole = furnace_radiance(a, e, bounces);
            agreeing_standard_error(
                &estimates,
                whole,
                &format!("albedo {albedo}, {bounces} bounces, shaded"),
            );
        }
    }
}
