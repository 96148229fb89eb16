//! The reference renderer and the evaluation rays.

use glam::{Vec2, Vec3};
use probe_capture::{
    Component, Environment, Image, Reflection, RenderError, RenderSettings, Shader,
    accumulate_rays, find_camera, no_progress, reflection_rays, render, render_gbuffer,
    trace_reference,
};
use probe_scene::{Camera, Material, Scene, Triangle};

fn quad(corners: [Vec3; 4], material: u32) -> [Triangle; 2] {
    let [a, b, c, d] = corners;
    let n = (b - a).cross(c - a).normalize();
    let t = |p: [Vec3; 3]| Triangle {
        positions: p,
        normals: [n; 3],
        uvs: [Vec2::ZERO; 3],
        material,
    };
    [t([a, b, c]), t([a, c, d])]
}

/// A floor at y = 0 facing up and a wall at z = −3 facing +Z, under a uniform sky.
fn floor_and_wall() -> Scene {
    let mut triangles = quad(
        [
            Vec3::new(-20.0, 0.0, 20.0),
            Vec3::new(20.0, 0.0, 20.0),
            Vec3::new(20.0, 0.0, -20.0),
            Vec3::new(-20.0, 0.0, -20.0),
        ],
        0,
    )
    .to_vec();
    triangles.extend(quad(
        [
            Vec3::new(-20.0, 0.0, -3.0),
            Vec3::new(20.0, 0.0, -3.0),
            Vec3::new(20.0, 10.0, -3.0),
            Vec3::new(-20.0, 10.0, -3.0),
        ],
        1,
    ));
    Scene::from_triangles(
        "floor and wall",
        triangles,
        vec![
            Material::diffuse("floor", Vec3::splat(0.5)),
            Material::diffuse("wall", Vec3::new(0.8, 0.4, 0.2)),
        ],
        Vec::new(),
        Vec::new(),
    )
    .unwrap()
}

#[test]
fn mirror_rays_reflect_about_the_normal() {
    let scene = floor_and_wall();
    let camera = Camera::look_at(
        Vec3::new(0.0, 2.0, 2.0),
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::Y,
        0.8,
    );
    let gbuffer = render_gbuffer(&scene, &camera, 16, 12).unwrap();
    assert_eq!(gbuffer.pixels.len(), 16 * 12);
    let centre = gbuffer.pixels[6 * 16 + 8].expect("the floor");
    assert!(centre.geometric_normal.y > 0.999);
    assert!(!centre.back_face);
    let rays = reflection_rays(&gbuffer, Reflection::Mirror, 2, 7).unwrap();
    // Every floor pixel gets two rays of weight ½.
    let hits = gbuffer.pixels.iter().flatten().count();
    assert_eq!(rays.len(), 2 * hits);
    for ray in &rays {
        assert!((ray.weight - 0.5).abs() < 1e-6);
        let sample = gbuffer.pixels[ray.pixel as usize].unwrap();
        let incoming = -sample.towards_camera;
        let n = sample.shading_normal;
        let mirror = incoming - 2.0 * incoming.dot(n) * n;
        assert!((ray.direction - mirror).length() < 1e-5);
        assert!((ray.origin - sample.position).length() < 1e-3);
    }
    // The reference along a mirror ray from the floor: it meets the wall at the distance the
    // geometry gives, and the radiance is the wall's.
    let shader = Shader::new(&scene, Environment::uniform_sky(Vec3::ONE), 0).unwrap();
    let samples = trace_reference(&shader, &rays, 1, 3, &no_progress);
    assert_eq!(samples.len(), rays.len());
    for (ray, sample) in rays.iter().zip(&samples) {
        match sample.hit {
            Some(hit) => {
                assert_eq!(hit.material, 1);
                let t = (-3.0 - ray.origin.z) / ray.direction.z;
                assert!((hit.t - t).abs() < 1e-3 * t, "{} vs {t}", hit.t);
                // The wall's colour, or black where its one sky sample was blocked.
                assert!(sample.radiance.x >= sample.radiance.z);
                assert!(sample.radiance.x <= 0.8 + 1e-5);
            }
            None => assert_eq!(sample.radiance, Vec3::ONE),
        }
    }
}

#[test]
fn ggx_rays_are_seeded_and_weighted() {
    let scene = floor_and_wall();
    let camera = Camera::look_at(Vec3::new(0.0, 2.0, 2.0), Vec3::ZERO, Vec3::Y, 0.8);
    let gbuffer = render_gbuffer(&scene, &camera, 8, 8).unwrap();
    let ggx = Reflection::Ggx { roughness: 0.5 };
    let a = reflection_rays(&gbuffer, ggx, 4, 1).unwrap();
    let b = reflection_rays(&gbuffer, ggx, 4, 1).unwrap();
    let c = reflection_rays(&gbuffer, ggx, 4, 2).unwrap();
    assert_eq!(a, b);
    assert_ne!(a, c);
    for ray in &a {
        assert!(ray.weight > 0.0 && ray.weight <= 0.25 + 1e-6);
        let sample = gbuffer.pixels[ray.pixel as usize].unwrap();
        assert!(ray.direction.dot(sample.geometric_normal) > 0.0);
    }
    // Rays spread around the mirror direction.
    let spread: f32 = a
        .iter()
        .map(|ray| {
            let s = gbuffer.pixels[ray.pixel as usize].unwrap();
            let i = -s.towards_camera;
            let mirror = i - 2.0 * i.dot(s.shading_normal) * s.shading_normal;
            ray.direction.angle_between(mirror)
        })
        .sum::<f32>()
        / a.len() as f32;
    assert!(spread > 0.05 && spread < 1.0, "{spread}");
    for bad in [0.0, -0.1, 1.5, f32::NAN] {
        assert!(matches!(
            reflection_rays(&gbuffer, Reflection::Ggx { roughness: bad }, 1, 0),
            Err(RenderError::InvalidSetting {
                parameter: "roughness",
                ..
            })
        ));
    }
    assert!(reflection_rays(&gbuffer, Reflection::Mirror, 0, 0).is_err());
}

#[test]
fn glossy_component_is_the_sum_over_the_reference_rays() {
    let scene = Scene::builtin("cornell").unwrap();
    let camera = scene.default_camera();
    let mut settings = RenderSettings::new(20, 16);
    settings.samples_per_pixel = 2;
    settings.seed = 9;
    settings.reflection = Reflection::Ggx { roughness: 0.3 };
    settings.shading_samples = 2;
    let image = render(&scene, &camera, &settings, &no_progress).unwrap();
    let gbuffer = render_gbuffer(&scene, &camera, 20, 16).unwrap();
    let rays = reflection_rays(&gbuffer, settings.reflection, 2, 9).unwrap();
    let shader = Shader::new(&scene, Environment::for_scene(&scene), 1).unwrap();
    let radiance: Vec<Vec3> = trace_reference(&shader, &rays, 2, 9, &no_progress)
        .iter()
        .map(|s| s.radiance)
        .collect();
    let rebuilt = accumulate_rays(20, 16, &rays, &radiance).unwrap();
    assert_eq!(image, rebuilt);
    assert!(image.mean().max_element() > 0.0);
    assert!(
        image
            .rgb
            .iter()
            .flatten()
            .all(|v| v.is_finite() && *v >= 0.0)
    );
    assert!(matches!(
        accumulate_rays(20, 16, &rays, &radiance[1..]),
        Err(RenderError::LengthMismatch { .. })
    ));
    // Deterministic across thread counts.
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let single = pool.install(|| render(&scene, &camera, &settings, &no_progress).unwrap());
    assert_eq!(image, single);
}

#[test]
fn direct_and_full_renders_of_the_cornell_box() {
    let scene = Scene::builtin("cornell").unwrap();
    let camera = scene.default_camera();
    let mut settings = RenderSettings::new(24, 24);
    settings.samples_per_pixel = 4;
    settings.component = Component::Direct;
    let direct = render(&scene, &camera, &settings, &no_progress).unwrap();
    settings.component = Component::Full;
    settings.bounces = 7;
    let full = render(&scene, &camera, &settings, &no_progress).unwrap();
    // Indirect light only adds: away from the directly seen light (clamped out here, its few
    // jittered hits are noisy), the full image is brighter.
    let clamped_mean = |image: &Image| {
        image
            .rgb
            .iter()
            .map(|p| Vec3::from(*p).min(Vec3::ONE))
            .sum::<Vec3>()
            / image.rgb.len() as f32
    };
    let (d, f) = (clamped_mean(&direct), clamped_mean(&full));
    assert!(
        f.x > d.x * 1.1 && f.y > d.y * 1.1 && f.z > d.z * 1.1,
        "{d} vs {f}"
    );
    // The light itself is seen directly near the top centre: its emission (17, 12, 4).
    let brightest = direct.rgb.iter().fold(0.0f32, |m, p| m.max(p[0]));
    assert!(brightest > 5.0, "{brightest}");
    let dir = tempfile::tempdir().unwrap();
    let exr = dir.path().join("full.exr");
    full.save_exr(&exr).unwrap();
    assert_eq!(Image::load_exr(&exr).unwrap(), full);
    full.save_png(dir.path().join("full.png")).unwrap();
    let png = image::open(dir.path().join("full.png")).unwrap();
    assert_eq!((png.width(), png.height()), (24, 24));
    // Bad settings are named.
    settings.bounces = 1025;
    assert!(matches!(
        render(&scene, &camera, &settings, &no_progress),
        Err(RenderError::InvalidSetting {
            parameter: "bounces",
            ..
        })
    ));
    assert!(matches!(
        find_camera(&scene, "nope"),
        Err(RenderError::UnknownCamera { .. })
    ));
    assert_eq!(find_camera(&scene, "default").unwrap(), camera);
}

#[test]
fn more_shading_samples_lower_the_reference_noise() {
    let scene = Scene::builtin("cornell").unwrap();
    let gbuffer = render_gbuffer(&scene, &scene.default_camera(), 16, 16).unwrap();
    let rays = reflection_rays(&gbuffer, Reflection::Mirror, 1, 0).unwrap();
    let shader = Shader::new(&scene, Environment::BLACK, 1).unwrap();
    let spread = |samples: u32| {
        let a = trace_reference(&shader, &rays, samples, 1, &no_progress);
        let b = trace_reference(&shader, &rays, samples, 2, &no_progress);
        a.iter()
            .zip(&b)
            .map(|(x, y)| {
                assert_eq!(x.hit, y.hit);
                f64::from((x.radiance - y.radiance).length_squared())
            })
            .sum::<f64>()
            / rays.len() as f64
    };
    let (one, sixteen) = (spread(1), spread(16));
    assert!(sixteen * 4.0 < one, "{one} vs {sixteen}");
}
