//! Bakes on the shared Cornell box and Sponza (few probes, low resolution).

use glam::Vec3;
use probe_capture::{
    BakeSettings, Component, Environment, ProbeBake, RenderSettings, Sampling, bake, find_camera,
    no_progress, render,
};
use probe_scene::Scene;
use probe_testdata::{CORNELL_BOX, SPONZA, scene_path};

fn load(relative: &str) -> Scene {
    let path = scene_path(relative);
    Scene::load(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn assert_sane(probes: &ProbeBake) {
    assert!(
        probes
            .radiance()
            .iter()
            .all(|r| r.is_finite() && r.min_element() >= 0.0)
    );
    assert!(probes.normals().iter().all(|n| n.is_finite()));
    assert!(probes.distances().iter().all(|d| d.is_finite() && *d > 0.0));
    assert!(probes.moments().iter().all(|m| m.is_finite()));
    assert!(probes.irradiance().iter().all(|e| e.is_finite()));
    assert!(probes.pyramid().iter().all(|t| t.x <= t.y));
    for sh in probes.sh() {
        assert!(sh.coefficients.iter().all(|c| c.is_finite()));
    }
}

#[test]
fn shared_cornell_box() {
    let scene = load(CORNELL_BOX);
    // No punctual light but an emissive quad: no daylight.
    assert_eq!(Environment::for_scene(&scene), Environment::BLACK);
    let centre = scene.bounds().center();
    let probes = bake(
        &scene,
        &[centre, centre + Vec3::new(0.3, 0.4, 0.2)],
        &BakeSettings {
            resolution: 32,
            sampling: Sampling::fixed(2),
            ..Default::default()
        },
        &no_progress,
    )
    .unwrap();
    assert_sane(&probes);
    for (p, stats) in probes.stats().iter().enumerate() {
        // Double-sided quads: no back faces; the open front lets some rays out.
        assert_eq!(stats.back_face_share, 0.0, "{stats:?}");
        assert!(stats.miss_share < 0.5, "{stats:?}");
        assert!(
            stats.min_distance > 0.02 && stats.mean_distance < 2.0,
            "{stats:?}"
        );
        // Most of what a probe sees is lit (the emitter is dim: emissive 1, 0.18 m²).
        let radiance = probes.radiance_map(p).unwrap();
        let lit = radiance
            .texels()
            .iter()
            .filter(|r| r.max_element() > 0.0)
            .count();
        assert!(lit > radiance.texels().len() / 2, "probe {p}: {lit}");
    }
    // From the centre, straight up is the light itself (radiance 1, double-sided).
    let up = probes.radiance_map(0).unwrap().sample_nearest(Vec3::Y);
    assert!((up - Vec3::ONE).abs().max_element() < 0.05, "{up}");
    // The reference sees the box from its framing camera.
    let mut settings = RenderSettings::new(16, 16);
    settings.samples_per_pixel = 2;
    settings.component = Component::Direct;
    let image = render(&scene, &scene.default_camera(), &settings, &no_progress).unwrap();
    assert!(image.mean().max_element() > 0.0);
}

#[test]
fn shared_sponza_with_default_daylight() {
    let scene = load(SPONZA);
    assert_eq!(
        Environment::for_scene(&scene),
        Environment::DEFAULT_DAYLIGHT
    );
    // One probe in the atrium (open to the sky), one in a ground-floor side aisle.
    let positions = [Vec3::new(0.0, 8.0, 0.0), Vec3::new(5.0, 6.0, 8.5)];
    let probes = bake(
        &scene,
        &positions,
        &BakeSettings {
            resolution: 16,
            sampling: Sampling::fixed(1),
            moments_resolution: 6,
            ..Default::default()
        },
        &no_progress,
    )
    .unwrap();
    assert_sane(&probes);
    assert_eq!(*probes.environment(), Environment::DEFAULT_DAYLIGHT);
    let atrium = probes.stats()[0];
    assert!(
        atrium.miss_share > 0.0 && atrium.miss_share < 0.5,
        "{atrium:?}"
    );
    assert!(atrium.back_face_share < 0.2, "{atrium:?}");
    assert!(probes.radiance().iter().any(|r| r.max_element() > 0.5));
    // Looking down from the atrium probe: the floor, about 4 m below (floor y ≈ 3.98).
    let down = probes.distance_map(0).unwrap().sample_nearest(-Vec3::Y);
    assert!((down - 4.02).abs() < 0.1, "{down}");
    // The named camera renders.
    let camera = find_camera(&scene, "CameraMain").unwrap();
    let mut settings = RenderSettings::new(12, 8);
    settings.samples_per_pixel = 1;
    settings.component = Component::Direct;
    let image = render(&scene, &camera, &settings, &no_progress).unwrap();
    assert!(image.mean().max_element() > 0.0);
}
