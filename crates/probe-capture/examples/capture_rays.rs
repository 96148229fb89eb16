//! Rays per second of the capture's texel-centre pass ([`capture_geometry`]) against raw obvhs
//! closest-hit traversal of the same rays, both on all cores (rayon), in one run.
//!
//! ```text
//! cargo run --release -p probe-capture --example capture_rays -- [RESOLUTION] [REPEATS]
//! ```
//!
//! Sponza (262k triangles); 64 probes on the 4×4×4 atrium grid of probe-scene's
//! `closest_hit` benchmark (`(−9, 4.5, −3)..(9, 14, 3)`); one ray per texel centre at
//! `RESOLUTION²` (default 256, so 4.19 M rays). The capture side includes everything
//! `capture_geometry` does (hit attributes, normal flip, padded maps, per-probe statistics);
//! the raw side is obvhs's own CWBVH builder and triangle test on the same triangles,
//! keeping the closest `t` only. A third timing runs probe-scene's `Scene::closest_hit` alone
//! on the same rays, which splits the capture's overhead into the wrapper's and its own. The
//! three alternate `REPEATS` times (default 5); every repeat's time, the medians and the
//! ratio of the fastest repeats are reported.

use std::time::{Duration, Instant};

use glam::{Vec3, Vec3A};
use obvhs::BvhBuildParams;
use obvhs::cwbvh::builder::build_cwbvh_from_tris;
use obvhs::ray::RayHit;
use obvhs::rt_triangle::RtTriangle;
use probe_capture::{capture_geometry, no_progress};
use probe_octa::OctaLayout;
use probe_scene::Scene;
use rayon::prelude::*;

fn atrium_grid() -> Vec<Vec3> {
    let (min, max) = (Vec3::new(-9.0, 4.5, -3.0), Vec3::new(9.0, 14.0, 3.0));
    let mut positions = Vec::new();
    for z in 0..4 {
        for y in 0..4 {
            for x in 0..4 {
                let f = Vec3::new(x as f32, y as f32, z as f32) / 3.0;
                positions.push(min + (max - min) * f);
            }
        }
    }
    positions
}

fn median(mut times: Vec<Duration>) -> Duration {
    times.sort();
    times[times.len() / 2]
}

fn main() {
    let mut args = std::env::args().skip(1);
    let resolution: u32 = args.next().map_or(256, |a| a.parse().expect("RESOLUTION"));
    let repeats: usize = args.next().map_or(5, |a| a.parse().expect("REPEATS"));
    let path = probe_testdata::scene_path(probe_testdata::SPONZA);
    let scene = Scene::load(&path).expect("Sponza");
    let positions = atrium_grid();
    let layout = OctaLayout::new(resolution).expect("resolution");
    let n = resolution as usize;

    // The raw baseline, as in probe-scene's `closest_hit` bench.
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
    let directions: Vec<Vec3A> = (0..n * n)
        .map(|i| {
            layout
                .texel_direction((i % n) as u32, (i / n) as u32)
                .into()
        })
        .collect();
    let rays: Vec<obvhs::ray::Ray> = positions
        .iter()
        .flat_map(|&p| {
            directions
                .iter()
                .map(move |&d| obvhs::ray::Ray::new_inf(Vec3A::from(p), d))
        })
        .collect();
    let count = rays.len();
    println!(
        "Sponza, {} probes × {resolution}² = {count} texel-centre rays, {} threads",
        positions.len(),
        rayon::current_num_threads()
    );

    let raw = || {
        rays.par_chunks(n)
            .map(|chunk| {
                let mut hits = 0usize;
                let mut sum = 0.0f32;
                for ray in chunk {
                    let mut hit = RayHit::none();
                    if bvh.ray_traverse(*ray, &mut hit, |r, id| leaf_tris[id].intersect(r)) {
                        hits += 1;
                        sum += hit.t;
                    }
                }
                (hits, sum)
            })
            .reduce(|| (0, 0.0), |a, b| (a.0 + b.0, a.1 + b.1))
    };
    let (raw_hits, _) = raw();
    let geometry = capture_geometry(&scene, &positions, resolution, &no_progress).expect("capture");
    let capture_hits = geometry
        .stats()
        .iter()
        .map(|s| ((1.0 - s.miss_share) * (n * n) as f32).round() as usize)
        .sum::<usize>();
    println!("hits: raw obvhs {raw_hits}, capture {capture_hits}");

    // probe-scene's wrapper alone on the same rays, to split the capture's overhead.
    let scene_rays: Vec<probe_scene::Ray> = rays
        .iter()
        .map(|r| probe_scene::Ray {
            origin: r.origin.into(),
            direction: r.direction.into(),
        })
        .collect();
    let wrapper = || {
        scene_rays
            .par_chunks(n)
            .map(|chunk| {
                chunk
                    .iter()
                    .filter_map(|r| scene.closest_hit(r, f32::INFINITY))
                    // Read a hit attribute too, as probe-scene's bench does, so that the
                    // attribute computation is not optimised away.
                    .map(|h| h.t + h.shading_normal.x)
                    .sum::<f32>()
            })
            .sum::<f32>()
    };

    let (mut raw_times, mut wrapper_times, mut capture_times) =
        (Vec::new(), Vec::new(), Vec::new());
    for _ in 0..repeats {
        let start = Instant::now();
        std::hint::black_box(raw());
        raw_times.push(start.elapsed());
        let start = Instant::now();
        std::hint::black_box(wrapper());
        wrapper_times.push(start.elapsed());
        let start = Instant::now();
        std::hint::black_box(
            capture_geometry(&scene, &positions, resolution, &no_progress).expect("capture"),
        );
        capture_times.push(start.elapsed());
    }
    let list = |times: &[Duration]| {
        times
            .iter()
            .map(|t| format!("{:.2}", t.as_secs_f64()))
            .collect::<Vec<_>>()
            .join(" ")
    };
    println!("raw times (s):     {}", list(&raw_times));
    println!("wrapper times (s): {}", list(&wrapper_times));
    println!("capture times (s): {}", list(&capture_times));
    let fastest = |times: &[Duration]| times.iter().min().copied().unwrap_or_default();
    let (raw_fastest, capture_fastest) = (fastest(&raw_times), fastest(&capture_times));
    let (raw_time, wrapper_time, capture_time) = (
        median(raw_times),
        median(wrapper_times),
        median(capture_times),
    );
    let rate = |t: Duration| count as f64 / t.as_secs_f64() / 1e6;
    println!(
        "raw obvhs closest hit: {:.3} s, {:.2} M rays/s",
        raw_time.as_secs_f64(),
        rate(raw_time)
    );
    println!(
        "Scene::closest_hit:    {:.3} s, {:.2} M rays/s",
        wrapper_time.as_secs_f64(),
        rate(wrapper_time)
    );
    println!(
        "capture_geometry:      {:.3} s, {:.2} M rays/s",
        capture_time.as_secs_f64(),
        rate(capture_time)
    );
    println!(
        "capture / raw rate: {:.3}; Scene::closest_hit / raw rate: {:.3}",
        raw_time.as_secs_f64() / capture_time.as_secs_f64(),
        raw_time.as_secs_f64() / wrapper_time.as_secs_f64()
    );
    println!(
        "capture / raw rate from the fastest repeats (load only adds time): {:.3}",
        raw_fastest.as_secs_f64() / capture_fastest.as_secs_f64()
    );
}
