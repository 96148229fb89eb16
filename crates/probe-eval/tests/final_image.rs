//! The final image through probes (issue 14): the GPU and its CPU twin agree on it within a
//! stated tolerance, and it stays near the path-traced final image.
//!
//! Without an adapter the GPU comparison prints a message and passes; with
//! `PROBE_REQUIRE_GPU=1` it fails instead.

use glam::Vec3;
use probe_capture::{BakeSettings, Image, ProbeBake, Sampling, bake, no_progress, render_gbuffer};
use probe_eval::final_render::{
    DiffuseBlend, FinalOptions, ProbeFinal, reference_final, render_final,
};
use probe_eval::metrics::tonemapped_mse;
use probe_eval::pipeline::{BuiltIndex, Device, build_index};
use probe_scene::Scene;

const SIZE: u32 = 64;

fn cornell_bake(scene: &Scene) -> ProbeBake {
    let bounds = scene.bounds();
    let mut positions = Vec::new();
    for i in 0..3 {
        for j in 0..3 {
            for k in 0..3 {
                let t = Vec3::new(i as f32, j as f32, k as f32) * 0.25 + Vec3::splat(0.25);
                positions.push(bounds.min + bounds.size() * t);
            }
        }
    }
    let settings = BakeSettings {
        resolution: 32,
        sampling: Sampling::fixed(8),
        seed: 5,
        ..BakeSettings::default()
    };
    bake(scene, &positions, &settings, &no_progress).unwrap()
}

fn render(device: &mut Device, scene: &Scene, baked: &ProbeBake, index: &BuiltIndex) -> ProbeFinal {
    let gbuffer = render_gbuffer(scene, &scene.default_camera(), SIZE, SIZE).unwrap();
    let options = FinalOptions {
        blend: DiffuseBlend::Delaunay,
        ..FinalOptions::default()
    };
    render_final(device, scene, baked, index, &gbuffer, &options).unwrap()
}

fn tonemapped(image: &Image) -> Vec<[f32; 3]> {
    image
        .rgb
        .iter()
        .map(|p| p.map(|v| v.max(0.0) / (1.0 + v.max(0.0))))
        .collect()
}

#[test]
fn gpu_and_cpu_twin_agree_on_the_final_image() {
    let scene = Scene::builtin("cornell").unwrap();
    let baked = cornell_bake(&scene);
    let index = build_index(&scene, baked.positions(), 6, None, 0).unwrap();
    let require = std::env::var("PROBE_REQUIRE_GPU").as_deref() == Ok("1");
    let (mut gpu, fallback) = Device::open(require).unwrap();
    if let Some(reason) = fallback {
        eprintln!(
            "skipping the GPU comparison: {reason} (set PROBE_REQUIRE_GPU=1 to fail instead)"
        );
        return;
    }
    let on_gpu = render(&mut gpu, &scene, &baked, &index);
    let on_cpu = render(&mut Device::cpu(), &scene, &baked, &index);
    // The direct light is computed on the CPU in both: identical.
    assert_eq!(on_gpu.parts.direct, on_cpu.parts.direct);
    // Tolerance: the two agree ray by ray on all but a few rays (float order in the march),
    // so at least 99.5 % of pixels lie within 1e-3 tone-mapped and the mean difference is
    // under 1e-4.
    let (a, b) = (
        tonemapped(&on_gpu.parts.sum()),
        tonemapped(&on_cpu.parts.sum()),
    );
    let mut close = 0usize;
    let mut total = 0.0f64;
    for (p, q) in a.iter().zip(&b) {
        let d = (0..3).map(|k| (p[k] - q[k]).abs()).fold(0.0f32, f32::max);
        close += usize::from(d <= 1e-3);
        total += f64::from(d);
    }
    let share = close as f64 / a.len() as f64;
    let mean = total / a.len() as f64;
    eprintln!(
        "GPU against CPU twin: {:.2} % of pixels within 1e-3, mean difference {mean:.2e}",
        100.0 * share
    );
    assert!(
        share >= 0.995,
        "only {:.2} % of pixels agree",
        100.0 * share
    );
    assert!(mean < 1e-4, "mean difference {mean:.2e}");
}

#[test]
fn the_final_image_through_probes_is_near_the_path_traced_one() {
    let scene = Scene::builtin("cornell").unwrap();
    let baked = cornell_bake(&scene);
    let index = build_index(&scene, baked.positions(), 6, None, 0).unwrap();
    let probes = render(&mut Device::cpu(), &scene, &baked, &index);
    let gbuffer = render_gbuffer(&scene, &scene.default_camera(), SIZE, SIZE).unwrap();
    let reference = reference_final(&scene, &baked, &gbuffer, 64, 0, &no_progress).unwrap();
    // Every part is lit. Measured: the error is 3.9 % of a black image's (27 probes at 32²,
    // 1 specular ray per pixel, whose noise is most of it); the bound leaves room for seeds.
    for part in [
        &probes.parts.direct,
        &probes.parts.diffuse,
        &probes.parts.specular,
    ] {
        assert!(part.mean().max_element() > 0.0);
    }
    let error = tonemapped_mse(&probes.parts.sum(), &reference.parts.sum());
    let black = tonemapped_mse(&Image::new(SIZE, SIZE), &reference.parts.sum());
    assert!(
        error < 0.06 * black,
        "final image MSE {error:.2e} against {black:.2e} for a black image"
    );
    // The direct light is the same estimator on both sides: only noise apart.
    let direct = tonemapped_mse(&probes.parts.direct, &reference.parts.direct);
    assert!(direct < 1e-3 * black, "direct MSE {direct:.2e}");
    assert!(reference.noise.image < 0.5 * error.max(1e-6) || reference.noise.image < 1e-4);
}
