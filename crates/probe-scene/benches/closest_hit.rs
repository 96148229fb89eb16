//! Rays per second of `Scene::closest_hit` against raw obvhs CWBVH traversal on the same rays
//! and the same triangles (Sponza, 262k triangles), single-threaded.
//!
//! Run with `cargo bench -p probe-scene --bench closest_hit`. The rays are those a probe
//! capture casts: from a 4×4×4 grid of points inside the atrium, 1,600 directions each
//! (a Fibonacci sphere), unlimited length: 102,400 rays per iteration.
//!
//! Before criterion's groups, the bench prints the ratio of the two rates measured in
//! interleaved rounds (raw, scene, raw, scene, …; median of 15), which is less sensitive to
//! other load on the machine than two separate criterion runs. It also times loading Sponza
//! (parse, flatten, BVH build) and the parallel batch `Scene::closest_hits`.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::{Vec3, Vec3A};
use obvhs::BvhBuildParams;
use obvhs::cwbvh::builder::build_cwbvh_from_tris;
use obvhs::ray::RayHit;
use obvhs::rt_triangle::RtTriangle;
use probe_scene::{Ray, Scene};
use std::hint::black_box;
use std::time::{Duration, Instant};

fn capture_rays(scene: &Scene) -> Vec<Ray> {
    // Probe positions: a 4×4×4 grid over the atrium (inside the colonnades, above the floor).
    let (min, max) = (Vec3::new(-9.0, 4.5, -3.0), Vec3::new(9.0, 14.0, 3.0));
    assert!(scene.bounds().contains(min) && scene.bounds().contains(max));
    let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    let directions: Vec<Vec3> = (0..1600)
        .map(|i| {
            let y = 1.0 - 2.0 * (i as f32 + 0.5) / 1600.0;
            let r = (1.0 - y * y).sqrt();
            let phi = golden * i as f32;
            Vec3::new(r * phi.cos(), y, r * phi.sin())
        })
        .collect();
    let mut rays = Vec::new();
    for z in 0..4 {
        for y in 0..4 {
            for x in 0..4 {
                let f = Vec3::new(x as f32, y as f32, z as f32) / 3.0;
                let origin = min + (max - min) * f;
                rays.extend(directions.iter().map(|&d| Ray::new(origin, d)));
            }
        }
    }
    rays
}

fn bench(c: &mut Criterion) {
    let path = probe_testdata::scene_path(probe_testdata::SPONZA);
    let scene = Scene::load(&path).expect("Sponza");
    let rays = capture_rays(&scene);

    // The raw baseline: obvhs's own builder (same `medium_build` parameters) and its triangle
    // intersector on triangles reordered into BVH leaf order, as in obvhs's examples.
    let tris: Vec<obvhs::triangle::Triangle> = scene
        .triangles()
        .iter()
        .map(|t| obvhs::triangle::Triangle {
            v0: t.positions[0].into(),
            v1: t.positions[1].into(),
            v2: t.positions[2].into(),
        })
        .collect();
    let bvh = build_cwbvh_from_tris(
        &tris,
        BvhBuildParams::medium_build(),
        &mut Duration::default(),
    );
    let leaf_tris: Vec<RtTriangle> = bvh
        .primitive_indices
        .iter()
        .map(|&i| RtTriangle::from(&tris[i as usize]))
        .collect();
    let obvhs_rays: Vec<obvhs::ray::Ray> = rays
        .iter()
        .map(|r| obvhs::ray::Ray::new_inf(Vec3A::from(r.origin), Vec3A::from(r.direction)))
        .collect();

    // Both find hits for the same rays.
    let raw_hits = obvhs_rays
        .iter()
        .filter(|r| {
            let mut hit = RayHit::none();
            bvh.ray_traverse(**r, &mut hit, |ray, id| leaf_tris[id].intersect(ray))
        })
        .count();
    let scene_hits = rays
        .iter()
        .filter(|r| scene.closest_hit(r, f32::INFINITY).is_some())
        .count();
    println!(
        "{} rays: raw obvhs hits {raw_hits}, Scene::closest_hit hits {scene_hits}",
        rays.len()
    );

    let raw_pass = || {
        let mut sum = 0.0f32;
        for ray in &obvhs_rays {
            let mut hit = RayHit::none();
            if bvh.ray_traverse(*ray, &mut hit, |ray, id| leaf_tris[id].intersect(ray)) {
                sum += hit.t;
            }
        }
        black_box(sum)
    };
    let scene_pass = || {
        let mut sum = 0.0f32;
        for ray in &rays {
            if let Some(hit) = scene.closest_hit(ray, f32::INFINITY) {
                sum += hit.t + hit.shading_normal.x;
            }
        }
        black_box(sum)
    };
    let mut ratios: Vec<f64> = (0..15)
        .map(|_| {
            let start = Instant::now();
            raw_pass();
            let raw = start.elapsed().as_secs_f64();
            let start = Instant::now();
            scene_pass();
            let wrapped = start.elapsed().as_secs_f64();
            raw / wrapped
        })
        .collect();
    ratios.sort_by(f64::total_cmp);
    println!(
        "interleaved rounds: Scene::closest_hit rate / raw obvhs rate = {:.3} (median of 15; min {:.3}, max {:.3})",
        ratios[7], ratios[0], ratios[14]
    );

    let mut group = c.benchmark_group("sponza_capture_rays");
    group.throughput(Throughput::Elements(rays.len() as u64));
    group.sample_size(20);
    group.measurement_time(Duration::from_secs(8));
    group.bench_function("raw_obvhs_closest_hit", |b| b.iter(raw_pass));
    group.bench_function("scene_closest_hit", |b| b.iter(scene_pass));
    group.bench_function("scene_occluded", |b| {
        b.iter(|| {
            let blocked = rays
                .iter()
                .filter(|ray| scene.occluded(ray, f32::INFINITY))
                .count();
            black_box(blocked)
        })
    });
    group.bench_function("scene_closest_hits_batch_parallel", |b| {
        b.iter(|| black_box(scene.closest_hits(&rays, f32::INFINITY).len()))
    });
    group.finish();

    let mut load = c.benchmark_group("sponza_load");
    load.sample_size(10);
    load.measurement_time(Duration::from_secs(10));
    load.bench_function("scene_load", |b| {
        b.iter(|| black_box(Scene::load(&path).expect("Sponza").triangles().len()))
    });
    load.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
