//! Time and texel fetches of one 1920×1080 ray set, hi-Z against two-level, on the GPU (the
//! first wgpu adapter: lavapipe on the machines here) and on the CPU twin, in one run; beside
//! them the baseline a user weighs the probes against, the exact trace of the same rays
//! against the scene's BVH (`Scene::closest_hits`, on all CPU threads), and the hybrid (those
//! BVH hits, radiance looked up in the probes on the GPU and on the CPU twin).
//!
//! The rays are the mirror reflections of Sponza's `CameraMain` at 1920×1080 (pixels whose
//! primary ray hits nothing are dropped); grid probes (default 8×2×4 = 64) baked by the test
//! support's mini capture. Both methods give the same answers (they are exact twins on conservative
//! bounds), so the fetch and time ratios are at equal accuracy.
//!
//! ```text
//! LP_NUM_THREADS=2 cargo run --release -p probe-trace-gpu --example speed -- [resolution] [width height] [grid]
//! ```

#[path = "../tests/support/mod.rs"]
mod support;

use std::time::{Duration, Instant};

use glam::Vec3;
use probe_index::ProbeGrid;
use probe_scene::{Ray, Scene};
use probe_trace_gpu::{
    CpuTracer, FieldOptions, GpuContext, GpuTracer, ProbeSelection, RayResult, TraceMethod,
    TraceOptions, TraceSummary, Tracer,
};
use support::{albedo_shade, hit_queries, mini_capture, reflection_rays, to_trace_rays};

fn options(method: TraceMethod) -> TraceOptions {
    TraceOptions {
        method,
        ..TraceOptions::default()
    }
}

fn same_answers(a: &[RayResult], b: &[RayResult]) -> usize {
    a.iter()
        .zip(b)
        .filter(|(x, y)| x.status == y.status && (x.position - y.position).length() <= 1e-4)
        .count()
}

fn main() {
    let mut args = std::env::args().skip(1);
    let resolution: u32 = args.next().map_or(256, |s| s.parse().expect("resolution"));
    let width: u32 = args.next().map_or(1920, |s| s.parse().expect("width"));
    let height: u32 = args.next().map_or(1080, |s| s.parse().expect("height"));
    // Probe grid counts, e.g. `8x2x4` (the default: 64 probes over the atrium and galleries).
    let counts: Vec<u32> = args
        .next()
        .unwrap_or_else(|| "8x2x4".to_owned())
        .split('x')
        .map(|c| c.parse().expect("grid counts like 8x2x4"))
        .collect();

    let t = Instant::now();
    let scene = Scene::load(probe_testdata::scene_path(probe_testdata::SPONZA)).unwrap();
    eprintln!("Sponza loaded in {:?}", t.elapsed());
    let camera = scene.camera("CameraMain").unwrap().clone();
    let mut primary = Vec::with_capacity((width * height) as usize);
    for y in 0..height {
        for x in 0..width {
            primary.push(camera.ray(x, y, width, height, glam::Vec2::ZERO));
        }
    }
    let bvh_rays = reflection_rays(&scene, &primary);
    let rays = to_trace_rays(&bvh_rays);
    drop(primary);
    let shade = albedo_shade(&scene);
    // The grid spans x ∈ [-21, 21], y ∈ [6, 14], z ∈ [-6, 6].
    let span = Vec3::new(42.0, 8.0, 12.0);
    let spacing = span
        / Vec3::new(
            counts[0] as f32 - 1.0,
            counts[1] as f32 - 1.0,
            counts[2] as f32 - 1.0,
        );
    let grid = ProbeGrid::new(
        Vec3::new(-21.0, 6.0, -6.0),
        spacing,
        [counts[0], counts[1], counts[2]],
    )
    .unwrap();
    let t = Instant::now();
    let bake = mini_capture(&scene, &grid.positions(), resolution, 1000.0, &shade);
    eprintln!(
        "{} probes at {resolution}² baked in {:?}",
        grid.probe_count(),
        t.elapsed()
    );
    let selection = ProbeSelection::Grid(grid);

    let context = GpuContext::new().expect("a GPU adapter (e.g. lavapipe)");
    let info = context.adapter_info();
    println!(
        "adapter: {} ({:?}, {})",
        info.name, info.backend, info.driver_info
    );
    let mut gpu = GpuTracer::new(&context).unwrap();
    let gpu_field = gpu
        .upload(&bake.field(), &selection, &FieldOptions::default())
        .unwrap();
    let mut cpu = CpuTracer::new();
    let cpu_field = cpu
        .upload(&bake.field(), &selection, &FieldOptions::default())
        .unwrap();

    // Warm up: the first dispatch compiles the pipeline on lavapipe.
    for method in [TraceMethod::HiZ, TraceMethod::TwoLevel] {
        gpu.trace(&gpu_field, &rays[..4096.min(rays.len())], &options(method))
            .unwrap();
    }

    println!(
        "rays: {} (reflections of {width}×{height} camera rays)",
        rays.len()
    );
    let mut gpu_results = Vec::new();
    let mut figures: Vec<(
        TraceMethod,
        TraceSummary,
        Duration,
        Option<Duration>,
        Duration,
    )> = Vec::new();
    for method in [TraceMethod::HiZ, TraceMethod::TwoLevel] {
        let g = gpu.trace(&gpu_field, &rays, &options(method)).unwrap();
        let c = cpu.trace(&cpu_field, &rays, &options(method)).unwrap();
        let agree = same_answers(&g.results, &c.results);
        eprintln!(
            "{}: GPU and CPU agree on {agree} of {} rays",
            method.name(),
            rays.len()
        );
        figures.push((
            method,
            TraceSummary::of(&g.results),
            g.timing.wall,
            g.timing.gpu,
            c.timing.wall,
        ));
        gpu_results.push(g.results);
    }
    let agree = same_answers(&gpu_results[0], &gpu_results[1]);
    println!(
        "hi-Z and two-level give the same answer for {agree} of {} rays",
        rays.len()
    );
    println!(
        "| method | hit | miss | unknown | fetches/ray | probes/ray | GPU wall | GPU timestamps | CPU twin wall |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    for (method, s, wall, stamps, cpu_wall) in &figures {
        println!(
            "| {} | {:.1} % | {:.1} % | {:.1} % | {:.2} | {:.2} | {:.3} s | {} | {:.3} s |",
            method.name(),
            100.0 * s.hits as f64 / s.rays as f64,
            100.0 * s.misses as f64 / s.rays as f64,
            100.0 * s.unknown as f64 / s.rays as f64,
            s.fetches_per_ray,
            s.probes_per_ray,
            wall.as_secs_f64(),
            stamps.map_or("n/a".to_owned(), |d| format!("{:.3} s", d.as_secs_f64())),
            cpu_wall.as_secs_f64(),
        );
    }
    // The baseline: the same rays against the BVH, then the hybrid's look-up of those hits.
    let bvh_time = |rays: &[Ray]| {
        let t = Instant::now();
        let hits = scene.closest_hits(rays, f32::INFINITY);
        (hits, t.elapsed())
    };
    let _ = bvh_time(&bvh_rays[..4096.min(bvh_rays.len())]);
    let (hits, bvh) = bvh_time(&bvh_rays);
    let queries = hit_queries(&bvh_rays, &hits);
    let defaults = TraceOptions::default();
    gpu.look_up(&gpu_field, &queries[..4096.min(queries.len())], &defaults)
        .unwrap();
    let g = gpu.look_up(&gpu_field, &queries, &defaults).unwrap();
    let c = cpu.look_up(&cpu_field, &queries, &defaults).unwrap();
    let s = TraceSummary::of(&g.results);
    println!(
        "| BVH (`Scene::closest_hits`, all CPU threads) | {:.1} % | {:.1} % | 0 | | | | | {:.3} s |",
        100.0 * hits.iter().filter(|h| h.is_some()).count() as f64 / hits.len() as f64,
        100.0 * hits.iter().filter(|h| h.is_none()).count() as f64 / hits.len() as f64,
        bvh.as_secs_f64(),
    );
    println!(
        "| hybrid: BVH + look-up | {:.1} % | {:.1} % | {:.1} % | {:.2} | {:.2} | BVH + {:.3} s | BVH + {} | BVH + {:.3} s |",
        100.0 * s.hits as f64 / s.rays as f64,
        100.0 * s.misses as f64 / s.rays as f64,
        100.0 * s.unknown as f64 / s.rays as f64,
        s.fetches_per_ray,
        s.probes_per_ray,
        g.timing.wall.as_secs_f64(),
        g.timing
            .gpu
            .map_or("n/a".to_owned(), |d| format!("{:.3} s", d.as_secs_f64())),
        c.timing.wall.as_secs_f64(),
    );
    let (h, t) = (&figures[0], &figures[1]);
    println!(
        "against the BVH: CPU twin hi-Z {:.2}×, two-level {:.2}×, hybrid (BVH + CPU look-up) {:.2}×; lavapipe hi-Z {:.2}× (wall), hybrid (BVH + lavapipe look-up) {:.2}×",
        h.4.as_secs_f64() / bvh.as_secs_f64(),
        t.4.as_secs_f64() / bvh.as_secs_f64(),
        (bvh + c.timing.wall).as_secs_f64() / bvh.as_secs_f64(),
        h.2.as_secs_f64() / bvh.as_secs_f64(),
        (bvh + g.timing.wall).as_secs_f64() / bvh.as_secs_f64(),
    );
    println!(
        "hi-Z / two-level: fetches {:.3}, GPU wall {:.3}, GPU timestamps {}, CPU twin {:.3}",
        h.1.fetches_per_ray / t.1.fetches_per_ray,
        h.2.as_secs_f64() / t.2.as_secs_f64(),
        match (h.3, t.3) {
            (Some(a), Some(b)) => format!("{:.3}", a.as_secs_f64() / b.as_secs_f64()),
            _ => "n/a".to_owned(),
        },
        h.4.as_secs_f64() / t.4.as_secs_f64(),
    );
}
