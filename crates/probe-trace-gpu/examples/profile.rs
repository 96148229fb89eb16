//! Where the texel fetches go, hi-Z against two-level, on the same rays: histograms by pyramid
//! level, by what each fetch decided, by phase along each probe's trace (near its start, in
//! free flight, near its end), by hand-off order and by outcome ([`FetchProfile`]).
//!
//! Rays: mirror reflections of a camera's G-buffer (probe-capture's evaluation rays). Probes:
//! a regular grid or probe-place's candidates, baked by probe-capture (set `PROBE_BAKE_CACHE`
//! to a folder to keep bakes between runs). The CPU twin makes the same fetches as the GPU.
//!
//! ```text
//! cargo run --release -p probe-trace-gpu --example profile -- [sponza|cornell] [grid|sdf|medial] [resolution] [width height]
//! ```

#[path = "../tests/support/mod.rs"]
mod support;

use std::time::Instant;

use glam::Vec3;
use probe_index::{NearestProbe, ProbeGrid, Tetrahedralization, VoronoiNeighbours};
use probe_scene::Scene;
use probe_trace_gpu::{
    CpuTracer, FetchProfile, FieldOptions, ProbeSelection, TraceMethod, TraceOptions, Tracer,
};
use support::{capture_bake, evaluation_rays, placement, to_trace_rays};

/// The scene, its camera and its regular grid (the layouts of `accuracy` and `speed`).
pub fn scene_setup(name: &str) -> (Scene, probe_scene::Camera, ProbeGrid) {
    match name {
        "cornell" => {
            let scene = Scene::open("builtin:cornell").unwrap();
            let camera = scene.default_camera();
            let grid = ProbeGrid::new(
                Vec3::splat(0.06),
                Vec3::new(0.43, 0.43, 0.44) / 2.0,
                [3, 3, 3],
            )
            .unwrap();
            (scene, camera, grid)
        }
        _ => {
            let scene = Scene::load(probe_testdata::scene_path(probe_testdata::SPONZA)).unwrap();
            let camera = scene.camera("CameraMain").unwrap().clone();
            let grid = ProbeGrid::new(
                Vec3::new(-21.0, 6.0, -6.0),
                Vec3::new(6.0, 8.0, 4.0),
                [8, 2, 4],
            )
            .unwrap();
            (scene, camera, grid)
        }
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let scene_name = args.first().map_or("sponza", String::as_str);
    let placement_name = args.get(1).map_or("grid", String::as_str);
    let resolution: u32 = args.get(2).map_or(256, |s| s.parse().expect("resolution"));
    let width: u32 = args.get(3).map_or(320, |s| s.parse().expect("width"));
    let height: u32 = args.get(4).map_or(180, |s| s.parse().expect("height"));

    let t = Instant::now();
    let (scene, camera, grid) = scene_setup(scene_name);
    let rays = evaluation_rays(&scene, &camera, width, height);
    let positions = if placement_name == "grid" {
        grid.positions()
    } else {
        placement(&scene, placement_name)
    };
    let bake = capture_bake(&scene, &positions, resolution);
    eprintln!(
        "{scene_name}: {} rays, {} {placement_name} probes at {resolution}², set up in {:.1?}",
        rays.len(),
        positions.len(),
        t.elapsed()
    );
    let tets;
    let neighbours;
    let nearest;
    let selection = if placement_name == "grid" {
        ProbeSelection::Grid(grid)
    } else {
        tets = Tetrahedralization::build(&positions).unwrap();
        neighbours = VoronoiNeighbours::bake(&tets, 16).unwrap();
        nearest = NearestProbe::new(&positions);
        ProbeSelection::Voronoi {
            nearest: &nearest,
            neighbours: &neighbours,
        }
    };
    let mut tracer = CpuTracer::new();
    let field = tracer
        .upload(&bake.field(), &selection, &FieldOptions::default())
        .unwrap();
    let trace_rays = to_trace_rays(&rays);
    let mut profiles: Vec<FetchProfile> = Vec::new();
    for method in [TraceMethod::HiZ, TraceMethod::TwoLevel] {
        let options = TraceOptions {
            method,
            ..TraceOptions::default()
        };
        let profile = tracer
            .profile_fetches(&field, &trace_rays, &options)
            .unwrap();
        println!(
            "\n### {scene_name}, {} {placement_name} probes at {resolution}², {} ({} selection)\n",
            positions.len(),
            method.name(),
            selection.name()
        );
        println!("{profile}");
        profiles.push(profile);
    }
    println!(
        "\nhi-Z / two-level fetches: {:.3}",
        profiles[0].fetches as f64 / profiles[1].fetches as f64
    );
    // Equal accuracy: both methods answer every ray the same.
    let answers: Vec<_> = [TraceMethod::HiZ, TraceMethod::TwoLevel]
        .iter()
        .map(|&method| {
            let options = TraceOptions {
                method,
                ..TraceOptions::default()
            };
            tracer.trace(&field, &trace_rays, &options).unwrap().results
        })
        .collect();
    let same = answers[0]
        .iter()
        .zip(&answers[1])
        .filter(|(a, b)| a.status == b.status && (a.position - b.position).length() <= 1e-5)
        .count();
    println!(
        "same answer from both methods: {same} of {} rays",
        trace_rays.len()
    );
}
