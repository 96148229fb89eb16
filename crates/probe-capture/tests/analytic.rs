//! The reference renderer and the capture against analytic answers: a white furnace, a point
//! light over a plane, and radial distances inside a box.

use std::f32::consts::PI;

use glam::Vec3;
use probe_capture::{
    BakeSettings, Component, Environment, MISS_DISTANCE, RenderSettings, Rng, Sampling, Shader,
    bake, capture_geometry, no_progress, render,
};
use probe_scene::{Camera, Light, Material, Ray, Scene, Triangle};

mod support;
use support::{quad, triangle};

/// A closed axis-aligned box whose faces face inward.
fn inward_box(min: Vec3, max: Vec3, material: u32, skip_top: bool) -> Vec<Triangle> {
    let v = |x: f32, y: f32, z: f32| Vec3::new(x, y, z);
    let (x0, y0, z0, x1, y1, z1) = (min.x, min.y, min.z, max.x, max.y, max.z);
    let mut faces = vec![
        quad(
            [v(x0, y0, z0), v(x0, y1, z0), v(x0, y1, z1), v(x0, y0, z1)],
            Vec3::X,
            material,
        ),
        quad(
            [v(x1, y0, z0), v(x1, y1, z0), v(x1, y1, z1), v(x1, y0, z1)],
            -Vec3::X,
            material,
        ),
        quad(
            [v(x0, y0, z0), v(x1, y0, z0), v(x1, y0, z1), v(x0, y0, z1)],
            Vec3::Y,
            material,
        ),
        quad(
            [v(x0, y0, z0), v(x1, y0, z0), v(x1, y1, z0), v(x0, y1, z0)],
            Vec3::Z,
            material,
        ),
        quad(
            [v(x0, y0, z1), v(x1, y0, z1), v(x1, y1, z1), v(x0, y1, z1)],
            -Vec3::Z,
            material,
        ),
    ];
    if !skip_top {
        faces.push(quad(
            [v(x0, y1, z0), v(x1, y1, z0), v(x1, y1, z1), v(x0, y1, z1)],
            -Vec3::Y,
            material,
        ));
    }
    faces.into_iter().flatten().collect()
}

/// An icosphere of radius `r` with flat, inward-facing triangles.
fn inward_sphere(r: f32, subdivisions: u32, material: u32) -> Vec<Triangle> {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let vertices = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ]
    .map(|p| Vec3::from(p).normalize());
    let faces = [
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    let mut tris: Vec<[Vec3; 3]> = faces
        .iter()
        .map(|f| [vertices[f[0]], vertices[f[1]], vertices[f[2]]])
        .collect();
    for _ in 0..subdivisions {
        tris = tris
            .iter()
            .flat_map(|[a, b, c]| {
                let ab = ((*a + *b) * 0.5).normalize();
                let bc = ((*b + *c) * 0.5).normalize();
                let ca = ((*c + *a) * 0.5).normalize();
                [[*a, ab, ca], [*b, bc, ab], [*c, ca, bc], [ab, bc, ca]]
            })
            .collect();
    }
    tris.into_iter()
        .map(|[a, b, c]| {
            // The icosahedron's faces wind outward; swap to face the centre.
            triangle([a * r, c * r, b * r], material)
        })
        .collect()
}

/// White furnace: inside a closed sphere whose walls all emit `Le` and reflect with albedo
/// `a`, the radiance everywhere is `Le / (1 − a)` (full GI), and `Le (1 + a)` with direct
/// light only.
#[test]
fn white_furnace() {
    let (le, albedo) = (1.5f32, 0.6f32);
    let material = Material {
        emissive: Vec3::splat(le),
        ..Material::diffuse("furnace", Vec3::splat(albedo))
    };
    let scene = Scene::from_triangles(
        "furnace",
        inward_sphere(2.0, 2, 0),
        vec![material],
        Vec::new(),
        Vec::new(),
    )
    .unwrap();
    let camera = Camera::look_at(Vec3::new(0.3, -0.2, 0.1), Vec3::X, Vec3::Y, 1.2);
    let mut settings = RenderSettings::new(8, 8);
    settings.component = Component::Full;
    settings.samples_per_pixel = 32;
    settings.bounces = 63;
    settings.seed = 11;
    let image = render(&scene, &camera, &settings, &no_progress).unwrap();
    let expected = le / (1.0 - albedo);
    let mean = image.mean();
    for k in 0..3 {
        assert!(
            (mean[k] - expected).abs() < 0.02 * expected,
            "full GI {mean} vs {expected}"
        );
    }
    // Every pixel stays within Monte-Carlo error of the answer (32 paths, with Russian
    // roulette after three bounces), and the noise averages out over the image.
    for p in &image.rgb {
        assert!((p[0] - expected).abs() < 0.4 * expected, "{p:?}");
    }

    settings.component = Component::Direct;
    let direct = render(&scene, &camera, &settings, &no_progress).unwrap();
    let expected_direct = le * (1.0 + albedo);
    // With flat facets and area sampling proportional to area, the direct estimate is
    // nearly noise-free.
    let mean = direct.mean();
    assert!(
        (mean.x - expected_direct).abs() < 0.01 * expected_direct,
        "direct {mean} vs {expected_direct}"
    );

    // A probe bake agrees with the renderer: one bounce gives Le (1 + a + a²).
    let bake_settings = BakeSettings {
        resolution: 8,
        sampling: Sampling::fixed(4),
        bounces: 1,
        ..Default::default()
    };
    let probes = bake(
        &scene,
        &[Vec3::new(0.2, 0.5, -0.3)],
        &bake_settings,
        &no_progress,
    )
    .unwrap();
    let expected_one_bounce = le * (1.0 + albedo + albedo * albedo);
    let map = probes.radiance_map(0).unwrap();
    let mut sum = 0.0;
    for iy in 0..8 {
        for ix in 0..8 {
            sum += map.get(ix, iy).unwrap().x;
        }
    }
    let mean = sum / 64.0;
    assert!(
        (mean - expected_one_bounce).abs() < 0.02 * expected_one_bounce,
        "bake {mean} vs {expected_one_bounce}"
    );
    // The irradiance map holds the reflected light only (the emission the probe sees is
    // left to direct lighting): π (L − Le) for a uniform radiance L; the SH DC term of the
    // whole radiance is L √(4π).
    let irradiance = probes.irradiance_map(0).unwrap().get(2, 3).unwrap();
    let reflected = PI * (mean - le);
    assert!(
        (irradiance.x - reflected).abs() < 0.05 * reflected,
        "{irradiance} vs {reflected}"
    );
    let dc = probes.sh()[0].coefficients[0].x;
    assert!((dc - mean * (4.0 * PI).sqrt()).abs() < 0.02 * dc, "{dc}");
}

/// A large plane with albedo ρ lit by a point light of intensity I at height h.
fn plane_scene(lights: Vec<Light>, albedo: f32, occluder: bool) -> Scene {
    let s = 50.0;
    let mut triangles = quad(
        [
            Vec3::new(-s, 0.0, -s),
            Vec3::new(s, 0.0, -s),
            Vec3::new(s, 0.0, s),
            Vec3::new(-s, 0.0, s),
        ],
        Vec3::Y,
        0,
    )
    .to_vec();
    if occluder {
        // A small horizontal plate between the light and the point (2, 0, 0).
        triangles.extend(quad(
            [
                Vec3::new(1.0, 1.0, -0.2),
                Vec3::new(1.4, 1.0, -0.2),
                Vec3::new(1.4, 1.0, 0.2),
                Vec3::new(1.0, 1.0, 0.2),
            ],
            Vec3::Y,
            0,
        ));
    }
    Scene::from_triangles(
        "plane",
        triangles,
        vec![Material::diffuse("grey", Vec3::splat(albedo))],
        lights,
        Vec::new(),
    )
    .unwrap()
}

/// The shaded radiance at the plane point `point` seen from straight above.
fn radiance_at(shader: &Shader<'_>, point: Vec3, rng: &mut Rng) -> Vec3 {
    let ray = Ray::new(
        point + Vec3::new(0.01, 3.0, 0.02),
        -Vec3::new(0.01, 3.0, 0.02),
    );
    let hit = shader
        .scene()
        .closest_hit(&ray, f32::INFINITY)
        .expect("the plane");
    assert!((hit.position - point).length() < 1e-4);
    shader.outgoing_radiance(&hit, -ray.direction, rng)
}

#[test]
fn point_light_over_a_plane() {
    let (intensity, height, albedo) = (40.0f32, 2.5f32, 0.6f32);
    let light = Vec3::new(0.0, height, 0.0);
    let scene = plane_scene(
        vec![Light::Point {
            name: "bulb".into(),
            position: light,
            color: Vec3::new(1.0, 0.5, 0.25),
            intensity,
            range: None,
        }],
        albedo,
        false,
    );
    let shader = Shader::new(&scene, Environment::BLACK, 0).unwrap();
    let mut rng = Rng::for_key(1, &[]);
    for point in [
        Vec3::ZERO,
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(-2.0, 0.0, 3.0),
        Vec3::new(4.0, 0.0, -6.0),
        Vec3::new(0.3, 0.0, 0.2),
    ] {
        let to_light = light - point;
        let r2 = to_light.length_squared();
        let cos = to_light.normalize().y;
        let irradiance = intensity * cos / r2;
        let expected = Vec3::new(1.0, 0.5, 0.25) * irradiance * albedo / PI;
        let got = radiance_at(&shader, point, &mut rng);
        assert!(
            (got - expected).abs().max_element() < 1e-4 * expected.max_element(),
            "{point}: {got} vs {expected}"
        );
    }
    // Behind an occluder the point is in shadow; beside it, lit as before.
    let shadowed = plane_scene(
        vec![Light::Point {
            name: "bulb".into(),
            position: light,
            color: Vec3::ONE,
            intensity,
            range: None,
        }],
        albedo,
        true,
    );
    let shader = Shader::new(&shadowed, Environment::BLACK, 0).unwrap();
    assert_eq!(
        radiance_at(&shader, Vec3::new(2.0, 0.0, 0.0), &mut rng),
        Vec3::ZERO
    );
    assert!(radiance_at(&shader, Vec3::new(-2.0, 0.0, 0.0), &mut rng).x > 0.0);
}

#[test]
fn spot_directional_and_range() {
    let albedo = 0.5;
    let spot = Light::Spot {
        name: "spot".into(),
        position: Vec3::new(0.0, 2.0, 0.0),
        direction: -Vec3::Y,
        color: Vec3::ONE,
        intensity: 10.0,
        inner_cone: 0.3,
        outer_cone: 0.5,
        range: None,
    };
    let scene = plane_scene(vec![spot], albedo, false);
    let shader = Shader::new(&scene, Environment::BLACK, 0).unwrap();
    let mut rng = Rng::for_key(2, &[]);
    // Inside the inner cone: the full intensity.
    let centre = radiance_at(&shader, Vec3::ZERO, &mut rng).x;
    assert!((centre - 10.0 / 4.0 * albedo / PI).abs() < 1e-5);
    // Outside the outer cone (angle atan(2/2) = 45° > 0.5 rad): dark.
    assert_eq!(
        radiance_at(&shader, Vec3::new(2.0, 0.0, 0.0), &mut rng).x,
        0.0
    );
    // Between the cones: the squared smooth fall-off.
    let angle = 0.4f32;
    let point = Vec3::new(2.0 * angle.tan(), 0.0, 0.0);
    let t = (angle.cos() - 0.5f32.cos()) / (0.3f32.cos() - 0.5f32.cos());
    let r2 = 4.0 + point.x * point.x;
    let expected = 10.0 * angle.cos() / r2 * t * t * albedo / PI;
    let got = radiance_at(&shader, point, &mut rng).x;
    assert!(
        (got - expected).abs() < 1e-4 * expected,
        "{got} vs {expected}"
    );

    // A directional light: E cos θ.
    let sun = Light::Directional {
        name: "sun".into(),
        direction: Vec3::new(1.0, -2.0, 0.0),
        color: Vec3::ONE,
        illuminance: 3.0,
        range: None,
    };
    let scene = plane_scene(vec![sun], albedo, false);
    let shader = Shader::new(&scene, Environment::BLACK, 0).unwrap();
    let got = radiance_at(&shader, Vec3::new(0.5, 0.0, 0.5), &mut rng).x;
    let expected = 3.0 * (2.0 / 5f32.sqrt()) * albedo / PI;
    assert!((got - expected).abs() < 1e-5, "{got} vs {expected}");

    // Range: KHR_lights_punctual's window clamp(1 − (d/range)⁴, 0, 1).
    let ranged = Light::Point {
        name: "ranged".into(),
        position: Vec3::new(0.0, 1.0, 0.0),
        color: Vec3::ONE,
        intensity: 5.0,
        range: Some(2.0),
    };
    let scene = plane_scene(vec![ranged], albedo, false);
    let shader = Shader::new(&scene, Environment::BLACK, 0).unwrap();
    let point = Vec3::new(1.0, 0.0, 0.0);
    let d = 2f32.sqrt();
    let expected = 5.0 * (1.0 / d) / (d * d) * (1.0 - (d / 2.0).powi(4)) * albedo / PI;
    let got = radiance_at(&shader, point, &mut rng).x;
    assert!(
        (got - expected).abs() < 1e-4 * expected,
        "{got} vs {expected}"
    );
    assert_eq!(
        radiance_at(&shader, Vec3::new(3.0, 0.0, 0.0), &mut rng).x,
        0.0
    );
}

/// A small emissive square far above a point acts like a point source of intensity Le·A.
#[test]
fn emissive_area_light_matches_its_far_field() {
    let (le, side, height, albedo) = (200.0f32, 0.1f32, 3.0f32, 0.7f32);
    let h = side / 2.0;
    let mut triangles = quad(
        [
            Vec3::new(-50.0, 0.0, -50.0),
            Vec3::new(50.0, 0.0, -50.0),
            Vec3::new(50.0, 0.0, 50.0),
            Vec3::new(-50.0, 0.0, 50.0),
        ],
        Vec3::Y,
        0,
    )
    .to_vec();
    triangles.extend(quad(
        [
            Vec3::new(-h, height, -h),
            Vec3::new(h, height, -h),
            Vec3::new(h, height, h),
            Vec3::new(-h, height, h),
        ],
        -Vec3::Y,
        1,
    ));
    let scene = Scene::from_triangles(
        "area",
        triangles,
        vec![
            Material::diffuse("floor", Vec3::splat(albedo)),
            Material::emitter("light", Vec3::splat(le)),
        ],
        Vec::new(),
        Vec::new(),
    )
    .unwrap();
    let shader = Shader::new(&scene, Environment::BLACK, 0).unwrap();
    assert_eq!(shader.emissive_triangle_count(), 2);
    let mut rng = Rng::for_key(3, &[]);
    let point = Vec3::new(1.0, 0.0, 0.5);
    let to_light = Vec3::new(0.0, height, 0.0) - point;
    let r2 = to_light.length_squared();
    let cos = to_light.y / r2.sqrt();
    // cos θ at the point and at the light are equal here.
    let expected = le * side * side * cos * cos / r2 * albedo / PI;
    let n = 4000;
    let mut sum = 0.0f64;
    for _ in 0..n {
        sum += f64::from(radiance_at(&shader, point, &mut rng).x);
    }
    let mean = (sum / f64::from(n)) as f32;
    assert!(
        (mean - expected).abs() < 0.01 * expected,
        "{mean} vs {expected}"
    );
}

/// Ray distance from `origin` along `d` to the inside of the box `[min, max]`.
fn box_exit_distance(origin: Vec3, d: Vec3, min: Vec3, max: Vec3) -> f32 {
    let mut t = f32::INFINITY;
    for k in 0..3 {
        if d[k] > 0.0 {
            t = t.min((max[k] - origin[k]) / d[k]);
        } else if d[k] < 0.0 {
            t = t.min((min[k] - origin[k]) / d[k]);
        }
    }
    t
}

#[test]
fn radial_distances_inside_a_box_are_exact() {
    let (min, max) = (Vec3::new(-1.0, -0.5, -2.0), Vec3::new(2.0, 1.5, 1.0));
    let scene = Scene::from_triangles(
        "box",
        inward_box(min, max, 0, false),
        vec![Material::diffuse("wall", Vec3::splat(0.5))],
        Vec::new(),
        Vec::new(),
    )
    .unwrap();
    let probe = Vec3::new(0.3, 0.2, -0.4);
    let geometry =
        capture_geometry(&scene, &[probe, Vec3::new(1.5, 1.0, 0.5)], 32, &no_progress).unwrap();
    for (index, &origin) in geometry.positions().iter().enumerate() {
        let map = geometry.distance_map(index).unwrap();
        let normals = geometry.normal_map(index).unwrap();
        let layout = map.layout();
        let mut worst = 0.0f32;
        for iy in 0..32 {
            for ix in 0..32 {
                let d = layout.texel_direction(ix, iy);
                let expected = box_exit_distance(origin, d, min, max);
                let got = map.get(ix, iy).unwrap();
                worst = worst.max((got - expected).abs() / expected);
                // The normal is the wall's inward normal: opposite to the exit axis.
                let normal = normals.get(ix, iy).unwrap();
                assert!(normal.dot(d) < 0.0, "({ix},{iy}): {normal} {d}");
                assert!((normal.length() - 1.0).abs() < 1e-5);
            }
        }
        assert!(worst < 2e-6, "probe {index}: relative error {worst}");
        let stats = geometry.stats()[index];
        assert_eq!(stats.back_face_share, 0.0);
        assert_eq!(stats.miss_share, 0.0);
        let nearest = (origin - min).min(max - origin).min_element();
        assert!(stats.min_distance >= nearest - 1e-5, "{stats:?}");
        assert!(stats.min_distance < nearest + 0.15, "{stats:?}");
    }

    // Without a ceiling the upward texels miss: the documented sentinel and a zero normal.
    let open = Scene::from_triangles(
        "open box",
        inward_box(min, max, 0, true),
        vec![Material::diffuse("wall", Vec3::splat(0.5))],
        Vec::new(),
        Vec::new(),
    )
    .unwrap();
    let geometry = capture_geometry(&open, &[probe], 16, &no_progress).unwrap();
    let map = geometry.distance_map(0).unwrap();
    let [ix, iy] = map.layout().texel_containing(Vec3::Y);
    assert_eq!(map.get(ix, iy), Some(MISS_DISTANCE));
    assert_eq!(
        geometry.normals()[map.layout().interior_index(ix, iy)],
        Vec3::ZERO
    );
    let stats = geometry.stats()[0];
    assert!(
        stats.miss_share > 0.05 && stats.miss_share < 0.5,
        "{stats:?}"
    );
    assert!(stats.mean_distance < 4.0);
}

/// Inside a black furnace sphere (every surface emits `Le`, albedo 0) a probe sees nothing
/// but emission: its radiance is `Le` and its irradiance map, which holds only reflected light
/// (the light sources are left to direct lighting), is exactly zero.
#[test]
fn irradiance_maps_leave_out_the_light_sources_the_probe_sees() {
    let le = 2.0f32;
    let scene = Scene::from_triangles(
        "black furnace",
        inward_sphere(2.0, 2, 0),
        vec![Material::emitter("furnace", Vec3::splat(le))],
        Vec::new(),
        Vec::new(),
    )
    .unwrap();
    let settings = BakeSettings {
        resolution: 8,
        sampling: Sampling::fixed(4),
        irradiance_resolution: 4,
        bounces: 2,
        seed: 3,
        environment: Some(Environment::BLACK),
        ..Default::default()
    };
    let probes = bake(
        &scene,
        &[Vec3::new(0.2, -0.1, 0.3)],
        &settings,
        &no_progress,
    )
    .unwrap();
    for r in probes.radiance_map(0).unwrap().texels() {
        assert_eq!(*r, Vec3::splat(le));
    }
    for e in probes.irradiance_map(0).unwrap().texels() {
        assert_eq!(*e, Vec3::ZERO);
    }
}
