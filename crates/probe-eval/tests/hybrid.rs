//! The hybrid tracer (exact BVH hits, radiance looked up in the probes): what it answers on an
//! emitter is never below the emitter's own radiance, even where the probes' filtered read
//! blurs the emitter's edge into the darker ceiling around it. Runs on the CPU twin.

use glam::Vec3;
use probe_capture::{BakeSettings, Sampling, bake, no_progress};
use probe_eval::pipeline::{Device, Selection, Tracer, build_index, light_field};
use probe_scene::{Ray, Scene};
use probe_trace_gpu::TraceRay;

#[test]
fn the_hybrid_answers_an_emitter_with_at_least_its_emission() {
    let scene = Scene::builtin("cornell").unwrap();
    let bounds = scene.bounds();
    let positions: Vec<Vec3> = (0..8)
        .map(|i| {
            let corner = Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, (i >> 2) as f32);
            bounds.min + bounds.size() * (0.25 + 0.5 * corner)
        })
        .collect();
    let settings = BakeSettings {
        resolution: 32,
        sampling: Sampling::fixed(4),
        seed: 3,
        ..BakeSettings::default()
    };
    let baked = bake(&scene, &positions, &settings, &no_progress).unwrap();
    let index = build_index(&scene, baked.positions(), 5, None, 0).unwrap();
    let mut device = Device::cpu();
    let selection = Selection::Svo.of(&index).unwrap();
    let field = device.upload(&light_field(&baked), &selection).unwrap();

    // Rays from the floor's centre up across the ceiling: a fan dense enough that many end
    // within a probe texel of the light's edge.
    let origin = Vec3::new(
        bounds.center().x,
        bounds.min.y + 0.05 * bounds.size().y,
        bounds.center().z,
    );
    let top = bounds.max.y;
    let mut rays = Vec::new();
    for i in 0..64 {
        for j in 0..64 {
            let target = Vec3::new(
                bounds.min.x + bounds.size().x * (0.2 + 0.6 * i as f32 / 63.0),
                top,
                bounds.min.z + bounds.size().z * (0.2 + 0.6 * j as f32 / 63.0),
            );
            rays.push(TraceRay::new(origin, (target - origin).normalize()));
        }
    }
    let output = device
        .trace_with(&scene, &field, &rays, Tracer::Hybrid)
        .unwrap();
    let casts: Vec<Ray> = rays
        .iter()
        .map(|r| Ray::new(Vec3::from(r.origin), Vec3::from(r.direction)))
        .collect();
    let hits = scene.closest_hits(&casts, f32::INFINITY);
    let materials = scene.materials();
    let mut on_emitter = 0;
    let mut off_emitter = 0;
    for (hit, result) in hits.iter().zip(&output.results) {
        let hit = hit.expect("every ray of the fan hits the ceiling or the light");
        let material = &materials[hit.material as usize];
        if material.is_emissive() {
            on_emitter += 1;
            assert!(
                result.radiance.cmpge(material.emissive).all(),
                "radiance {} on an emitter of {}",
                result.radiance,
                material.emissive
            );
        } else {
            off_emitter += 1;
        }
    }
    // The fan crosses the light's edge: both sides are hit.
    assert!(
        on_emitter > 100 && off_emitter > 100,
        "{on_emitter} / {off_emitter}"
    );
}
