//! Accuracy of the tracer against exact BVH hits of the same rays (BRIEF, "How quality is
//! measured"): mirror reflection rays from a camera's first hits, traced through grid probes
//! baked by the test support's mini capture (one BVH ray per texel centre; radiance = base
//! colour + emission), compared with the BVH's closest hits.
//!
//! Prints Markdown table rows. The CPU twin is used (the GPU gives the same answers; see the
//! `gpu_trace` tests).
//!
//! ```text
//! cargo run --release -p probe-trace-gpu --example accuracy -- [cornell|sponza|all]
//! ```

#[path = "../tests/support/mod.rs"]
mod support;

use std::time::Instant;

use glam::Vec3;
use probe_index::{
    NearestProbe, ProbeGrid, SparseVoxelOctree, SvoOptions, Tetrahedralization, VoronoiNeighbours,
};
use probe_scene::{Ray, Scene};
use probe_trace_gpu::{
    CpuTracer, FieldOptions, ProbeSelection, TraceMethod, TraceOptions, TraceSummary, Tracer,
};
use support::{accuracy, albedo_shade, camera_rays, mini_capture, reflection_rays, to_trace_rays};

fn header() {
    println!(
        "| scene | probes | res | selector | options | rays | true hits seen by a probe | of those, within 1 footprint | within 2 | wrong answers | unknown | radiance MSE | fetches/ray hi-Z | fetches/ray two-level | probes/ray |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
}

#[allow(clippy::too_many_arguments)]
fn row(
    scene: &Scene,
    scene_label: &str,
    grid: ProbeGrid,
    resolution: u32,
    sky: f32,
    rays: &[Ray],
    selectors: &[&str],
    field_options: FieldOptions,
) {
    let shade = albedo_shade(scene);
    let positions = grid.positions();
    let t = Instant::now();
    let bake = mini_capture(scene, &positions, resolution, sky, &shade);
    let bake_time = t.elapsed();
    let trace_rays = to_trace_rays(rays);
    for &name in selectors {
        let tets;
        let neighbours;
        let nearest;
        let svo;
        let selection = match name {
            "grid" => ProbeSelection::Grid(grid),
            "svo" => {
                svo = SparseVoxelOctree::build(
                    scene,
                    &positions,
                    &SvoOptions {
                        max_depth: 7,
                        ..SvoOptions::default()
                    },
                )
                .unwrap();
                ProbeSelection::SparseVoxelOctree(&svo)
            }
            _ => {
                tets = Tetrahedralization::build(&positions).unwrap();
                neighbours = VoronoiNeighbours::bake(&tets, 16).unwrap();
                nearest = NearestProbe::new(&positions);
                ProbeSelection::Voronoi {
                    nearest: &nearest,
                    neighbours: &neighbours,
                }
            }
        };
        let mut tracer = CpuTracer::new();
        let field = tracer
            .upload(&bake.field(), &selection, &field_options)
            .unwrap();
        let hiz = tracer
            .trace(&field, &trace_rays, &TraceOptions::default())
            .unwrap();
        let two = tracer
            .trace(
                &field,
                &trace_rays,
                &TraceOptions {
                    method: TraceMethod::TwoLevel,
                    ..TraceOptions::default()
                },
            )
            .unwrap();
        let a = accuracy(scene, &bake, rays, &hiz.results, &shade);
        let s_hiz = TraceSummary::of(&hiz.results);
        let s_two = TraceSummary::of(&two.results);
        let pct = |x: usize, of: usize| 100.0 * x as f64 / of.max(1) as f64;
        let options = if field_options.conservative_edges {
            "conservative_edges"
        } else {
            "default"
        };
        println!(
            "| {scene_label} | {} | {resolution}² | {name} | {options} | {} | {:.1} % | {:.1} % | {:.1} % | {:.2} % | {:.1} % | {:.4} | {:.1} | {:.1} | {:.2} |",
            positions.len(),
            a.rays,
            pct(a.seen, a.true_hits),
            100.0 * a.seen_rate(),
            pct(a.seen_correct_2, a.seen),
            pct(a.wrong_answers, a.rays),
            pct(a.unknown, a.rays),
            a.radiance_mse,
            s_hiz.fetches_per_ray,
            s_two.fetches_per_ray,
            s_hiz.probes_per_ray,
        );
        eprintln!(
            "  ({scene_label}, {name}: bake {bake_time:?}, hi-Z {:?}, two-level {:?} on the CPU; escapes {} of which answered miss {})",
            hiz.timing.wall, two.timing.wall, a.escapes, a.escapes_correct
        );
    }
}

fn cornell() {
    let scene = Scene::open("builtin:cornell").unwrap();
    let rays = reflection_rays(&scene, &camera_rays(&scene, 128, 96));
    for k in [3u32, 4, 5] {
        let grid = ProbeGrid::new(
            Vec3::splat(0.06),
            Vec3::new(0.43, 0.43, 0.44) / (k - 1) as f32,
            [k, k, k],
        )
        .unwrap();
        for resolution in [64, 128, 256] {
            let selectors: &[&str] = if k == 4 && resolution == 128 {
                &["grid", "svo", "voronoi"]
            } else {
                &["grid"]
            };
            row(
                &scene,
                "cornell",
                grid,
                resolution,
                50.0,
                &rays,
                selectors,
                FieldOptions::default(),
            );
        }
    }
    let grid = ProbeGrid::new(
        Vec3::splat(0.06),
        Vec3::splat(0.215).with_z(0.22),
        [3, 3, 3],
    )
    .unwrap();
    row(
        &scene,
        "cornell",
        grid,
        64,
        50.0,
        &rays,
        &["grid"],
        FieldOptions {
            conservative_edges: true,
            ..FieldOptions::default()
        },
    );
}

fn sponza() {
    let t = Instant::now();
    let scene = Scene::load(probe_testdata::scene_path(probe_testdata::SPONZA)).unwrap();
    eprintln!("  (Sponza loaded in {:?})", t.elapsed());
    let camera = scene.camera("CameraMain").unwrap().clone();
    let mut primary = Vec::new();
    let (w, h) = (160, 90);
    for y in 0..h {
        for x in 0..w {
            primary.push(camera.ray(x, y, w, h, glam::Vec2::ZERO));
        }
    }
    let rays = reflection_rays(&scene, &primary);
    // 64 probes (seed 000's Sponza count), 8 × 2 × 4 over the atrium and galleries.
    let grid = ProbeGrid::new(
        Vec3::new(-21.0, 6.0, -6.0),
        Vec3::new(6.0, 8.0, 4.0),
        [8, 2, 4],
    )
    .unwrap();
    for resolution in [128, 256] {
        row(
            &scene,
            "sponza",
            grid,
            resolution,
            1000.0,
            &rays,
            &["grid", "svo", "voronoi"],
            FieldOptions::default(),
        );
    }
}

fn main() {
    let which = std::env::args().nth(1).unwrap_or_else(|| "all".to_owned());
    header();
    if which == "cornell" || which == "all" {
        cornell();
    }
    if which == "sponza" || which == "all" {
        sponza();
    }
}
