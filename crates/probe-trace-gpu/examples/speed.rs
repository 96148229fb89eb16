//! Time and texel fetches of one 1920×1080 ray set, hi-Z against two-level, on the GPU (the
//! first wgpu adapter: lavapipe on the machines here, an NVIDIA H200 in
//! `scripts/h200-figures.sh`) and on the CPU twin, in one run; beside them the baseline a
//! user weighs the probes against, the exact trace of the same rays against the scene's BVH
//! (`Scene::closest_hits`, on all CPU threads), and the hybrid (those BVH hits, radiance
//! looked up in the probes on the GPU and on the CPU twin).
//!
//! The rays are the mirror reflections of Sponza's `CameraMain` at 1920×1080 (pixels whose
//! primary ray hits nothing are dropped); grid probes (default 8×2×4 = 64) baked by the test
//! support's mini capture. Both methods give the same answers (they are exact twins on conservative
//! bounds), so the fetch and time ratios are at equal accuracy.
//!
//! ```text
//! LP_NUM_THREADS=2 cargo run --release -p probe-trace-gpu --example speed -- [resolution] [width height] [grid] [repeats]
//! ```
//!
//! With `repeats` > 1 (default 1) every GPU trace and look-up runs that many times after the
//! warm-up and the table gives the median of each time (wall and timestamps), with the spread
//! (min–max) of the timestamps on a line below; the CPU twin and the BVH still run once.
//! `SPEED_SHUFFLE=SEED` traces the rays in a seeded random order instead of the pixels' (to
//! measure what the rays' coherence is worth on a GPU); `SPEED_ORDER=tiles|morton` traces
//! the pixels in 8×8 tiles or along the Z-order curve instead of row by row; `SPEED_NUDGE=1`
//! also traces every ray one ulp away on the CPU twin and counts the answers that move.

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

/// How two answers to the same rays differ where they do: rays whose status differs, and
/// rays with the same status whose positions are more than 1e-4 apart (with the largest gap).
fn disagreements(a: &[RayResult], b: &[RayResult]) -> String {
    let status = a
        .iter()
        .zip(b)
        .filter(|(x, y)| x.status != y.status)
        .count();
    let gaps: Vec<f32> = a
        .iter()
        .zip(b)
        .filter(|(x, y)| x.status == y.status)
        .map(|(x, y)| (x.position - y.position).length())
        .filter(|gap| *gap > 1e-4)
        .collect();
    format!(
        "{status} differ in status, {} in position only (largest gap {:.4})",
        gaps.len(),
        gaps.iter().copied().fold(0.0f32, f32::max)
    )
}

/// The pixels of a `width`×`height` image in the order their rays are traced: `rows` (row
/// by row), `tiles` (the renderers' `probe_capture::TileOrder`: 8×8 tiles, row by row within a
/// tile and tiles row by row) or `morton` (the Z-order curve over the pixel coordinates).
fn pixel_order(order: &str, width: u32, height: u32) -> Vec<(u32, u32)> {
    let mut pixels: Vec<(u32, u32)> = (0..height)
        .flat_map(|y| (0..width).map(move |x| (x, y)))
        .collect();
    match order {
        "rows" => {}
        "tiles" => {
            let tile = probe_capture::TileOrder::TILE;
            pixels.sort_by_key(|&(x, y)| (y / tile, x / tile, y % tile, x % tile));
        }
        "morton" => pixels.sort_by_key(|&(x, y)| {
            (0..16).fold(0u64, |code, bit| {
                code | (u64::from((x >> bit) & 1) << (2 * bit))
                    | (u64::from((y >> bit) & 1) << (2 * bit + 1))
            })
        }),
        other => panic!("SPEED_ORDER {other:?}: one of rows, tiles, morton"),
    }
    pixels
}

/// Fisher–Yates with the project's seeded generator (`probe_capture::Rng`): the same seed
/// gives the same order.
fn shuffle<T>(items: &mut [T], seed: u64) {
    let mut rng = probe_capture::Rng::for_key(seed, &[]);
    for i in (1..items.len()).rev() {
        let bits = (u64::from(rng.next_u32()) << 32) | u64::from(rng.next_u32());
        items.swap(i, (bits % (i as u64 + 1)) as usize);
    }
}

/// The median wall and timestamp times of repeated GPU calls; prints the timestamps' spread
/// when there is more than one call.
fn medians(what: &str, timings: &[probe_trace_gpu::Timing]) -> (Duration, Option<Duration>) {
    let median = |mut v: Vec<Duration>| {
        v.sort();
        v[v.len() / 2]
    };
    let wall = median(timings.iter().map(|t| t.wall).collect());
    let stamps: Option<Vec<Duration>> = timings.iter().map(|t| t.gpu).collect();
    if timings.len() > 1
        && let Some(s) = &stamps
    {
        eprintln!(
            "{what}: {} calls, GPU timestamps min {:.3} ms, max {:.3} ms; wall min {:.3} ms, max {:.3} ms",
            s.len(),
            s.iter().min().unwrap().as_secs_f64() * 1e3,
            s.iter().max().unwrap().as_secs_f64() * 1e3,
            timings.iter().map(|t| t.wall).min().unwrap().as_secs_f64() * 1e3,
            timings.iter().map(|t| t.wall).max().unwrap().as_secs_f64() * 1e3,
        );
    }
    (wall, stamps.map(median))
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
    let repeats: usize = args
        .next()
        .map_or(1, |s| s.parse().expect("repeats: a count ≥ 1"))
        .max(1);

    let t = Instant::now();
    let scene = Scene::load(probe_testdata::scene_path(probe_testdata::SPONZA)).unwrap();
    eprintln!("Sponza loaded in {:?}", t.elapsed());
    let camera = scene.camera("CameraMain").unwrap().clone();
    let order = std::env::var("SPEED_ORDER").unwrap_or_else(|_| "rows".to_owned());
    let primary: Vec<Ray> = pixel_order(&order, width, height)
        .into_iter()
        .map(|(x, y)| camera.ray(x, y, width, height, glam::Vec2::ZERO))
        .collect();
    eprintln!("pixels in {order} order");
    let mut bvh_rays = reflection_rays(&scene, &primary);
    if let Some(seed) = std::env::var("SPEED_SHUFFLE").ok().map(|s| {
        s.parse::<u64>()
            .expect("SPEED_SHUFFLE: a seed (unsigned integer)")
    }) {
        shuffle(&mut bvh_rays, seed);
        eprintln!("rays shuffled (seed {seed})");
    }
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
        let runs: Vec<_> = (0..repeats)
            .map(|_| gpu.trace(&gpu_field, &rays, &options(method)).unwrap())
            .collect();
        let (wall, stamps) = medians(
            method.name(),
            &runs.iter().map(|r| r.timing).collect::<Vec<_>>(),
        );
        let g = runs.into_iter().next().unwrap();
        let c = cpu.trace(&cpu_field, &rays, &options(method)).unwrap();
        if std::env::var_os("SPEED_NUDGE").is_some() {
            // The same rays one ulp away (each origin and direction component's next f32
            // up), on the CPU twin: how many answers a rounding difference can move.
            let nudge = |v: [f32; 3]| v.map(|x| f32::from_bits(x.to_bits() + 1));
            let nudged: Vec<_> = rays
                .iter()
                .map(|r| probe_trace_gpu::TraceRay {
                    origin: nudge(r.origin),
                    direction: nudge(r.direction),
                    ..*r
                })
                .collect();
            let n = cpu.trace(&cpu_field, &nudged, &options(method)).unwrap();
            let same = same_answers(&n.results, &c.results);
            eprintln!(
                "{}: CPU twin, rays one ulp away: {same} of {} rays answer the same; {}",
                method.name(),
                rays.len(),
                disagreements(&n.results, &c.results)
            );
        }
        let agree = same_answers(&g.results, &c.results);
        eprintln!(
            "{}: GPU and CPU agree on {agree} of {} rays{}",
            method.name(),
            rays.len(),
            if agree < rays.len() {
                format!("; {}", disagreements(&g.results, &c.results))
            } else {
                String::new()
            }
        );
        figures.push((
            method,
            TraceSummary::of(&g.results),
            wall,
            stamps,
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
            "| {} | {:.1} % | {:.1} % | {:.1} % | {:.2} | {:.2} | {:.3} ms | {} | {:.3} s |",
            method.name(),
            100.0 * s.hit_rate(),
            100.0 * s.misses as f64 / s.rays as f64,
            100.0 * s.unknown_rate(),
            s.fetches_per_ray,
            s.probes_per_ray,
            wall.as_secs_f64() * 1e3,
            stamps.map_or("n/a".to_owned(), |d| format!(
                "{:.3} ms",
                d.as_secs_f64() * 1e3
            )),
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
    let runs: Vec<_> = (0..repeats)
        .map(|_| gpu.look_up(&gpu_field, &queries, &defaults).unwrap())
        .collect();
    let (look_up_wall, look_up_stamps) = medians(
        "hybrid look-up",
        &runs.iter().map(|r| r.timing).collect::<Vec<_>>(),
    );
    let g = runs.into_iter().next().unwrap();
    let c = cpu.look_up(&cpu_field, &queries, &defaults).unwrap();
    // The look-up's answers: the same probe and status, radiance within what the device's
    // rounding moves.
    let agree = g
        .results
        .iter()
        .zip(&c.results)
        .filter(|(x, y)| {
            x.status == y.status
                && x.probe == y.probe
                && x.radiance
                    .abs_diff_eq(y.radiance, 1e-4 * (1.0 + y.radiance.length()))
        })
        .count();
    println!(
        "hybrid look-up: GPU and CPU agree on {agree} of {} queries (status, probe, radiance)",
        queries.len()
    );
    let s = TraceSummary::of(&g.results);
    println!(
        "| BVH (`Scene::closest_hits`, all CPU threads) | {:.1} % | {:.1} % | 0 | | | | | {:.3} s |",
        100.0 * hits.iter().filter(|h| h.is_some()).count() as f64 / hits.len() as f64,
        100.0 * hits.iter().filter(|h| h.is_none()).count() as f64 / hits.len() as f64,
        bvh.as_secs_f64(),
    );
    println!(
        "| hybrid: BVH + look-up | {:.1} % | {:.1} % | {:.1} % | {:.2} | {:.2} | BVH + {:.3} ms | BVH + {} | BVH + {:.3} s |",
        100.0 * s.hit_rate(),
        100.0 * s.misses as f64 / s.rays as f64,
        100.0 * s.unknown_rate(),
        s.fetches_per_ray,
        s.probes_per_ray,
        look_up_wall.as_secs_f64() * 1e3,
        look_up_stamps.map_or("n/a".to_owned(), |d| format!(
            "{:.3} ms",
            d.as_secs_f64() * 1e3
        )),
        c.timing.wall.as_secs_f64(),
    );
    let (h, t) = (&figures[0], &figures[1]);
    println!(
        "against the BVH: CPU twin hi-Z {:.2}×, two-level {:.2}×, hybrid (BVH + CPU look-up) {:.2}×; GPU hi-Z {:.2}× (wall), {} (timestamps), hybrid (BVH + GPU look-up) {:.2}×",
        h.4.as_secs_f64() / bvh.as_secs_f64(),
        t.4.as_secs_f64() / bvh.as_secs_f64(),
        (bvh + c.timing.wall).as_secs_f64() / bvh.as_secs_f64(),
        h.2.as_secs_f64() / bvh.as_secs_f64(),
        h.3.map_or("n/a".to_owned(), |d| format!(
            "{:.2}×",
            d.as_secs_f64() / bvh.as_secs_f64()
        )),
        (bvh + look_up_wall).as_secs_f64() / bvh.as_secs_f64(),
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
