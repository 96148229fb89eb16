//! Times the candidate generators on a scene and prints what they made.
//!
//! ```text
//! cargo run --release -p probe-place --example candidates -- [SCENE] [sdf|medial|voxels|all] [KEY=VALUE...]
//! ```
//!
//! `KEY=VALUE` overrides a parameter of [`SdfParams`] or [`MedialParams`] by field name
//! (`voxel_size=0.2`, `coverage_factor=3`, `sample_count=50000`, ...); a key both have sets both.
//!
//! `SCENE` is `builtin:NAME`, a glTF path, or `sponza`, `godot_room`, `cornell_box` for the
//! shared scenes (default `sponza`). Times are wall-clock on all cores (rayon).

use probe_place::candidates::{
    MedialParams, SdfParams, VoxelGrid, VoxelState, inside_geometry, medial_candidates,
    sdf_candidates,
};
use probe_scene::Scene;
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let spec = args.first().map_or("sponza", String::as_str);
    let what = args.get(1).map_or("all", String::as_str);
    let overrides: Vec<(&str, f64)> = args
        .iter()
        .skip(2)
        .map(|a| {
            let (k, v) = a.split_once('=').expect("KEY=VALUE");
            (k, v.parse::<f64>().expect("a number"))
        })
        .collect();
    let path = match spec {
        "sponza" => probe_testdata::scene_path(probe_testdata::SPONZA),
        "godot_room" => probe_testdata::scene_path(probe_testdata::GODOT_ROOM),
        "cornell_box" => probe_testdata::scene_path(probe_testdata::CORNELL_BOX),
        "two_sided_plane" => probe_testdata::scene_path(probe_testdata::TWO_SIDED_PLANE),
        other => other.into(),
    };
    let start = Instant::now();
    let scene = Scene::open(&path.to_string_lossy())?;
    println!(
        "scene {} ({} triangles), bounds {:?}: loaded in {:.2} s",
        scene.name(),
        scene.triangles().len(),
        scene.bounds(),
        start.elapsed().as_secs_f64()
    );
    let mut sdf_params = SdfParams::for_scene(&scene);
    let mut medial_params = MedialParams::for_scene(&scene);
    for &(key, value) in &overrides {
        let mut known = true;
        match key {
            "voxel_size" => {
                sdf_params.voxel_size = value as f32;
                medial_params.voxel_size = value as f32;
            }
            "coverage_factor" => {
                sdf_params.coverage_factor = value as f32;
                medial_params.coverage_factor = value as f32;
            }
            "max_cluster_radius" => {
                sdf_params.max_cluster_radius = value as f32;
                medial_params.max_cluster_radius = value as f32;
            }
            "min_clearance" => sdf_params.min_clearance = value as f32,
            "min_cluster_voxels" => sdf_params.min_cluster_voxels = value as usize,
            "sample_count" => medial_params.sample_count = value as usize,
            "seed" => medial_params.seed = value as u64,
            "min_radius" => medial_params.min_radius = value as f32,
            "min_cluster_balls" => medial_params.min_cluster_balls = value as usize,
            "initial_radius" => medial_params.initial_radius = value as f32,
            _ => known = false,
        }
        assert!(known, "unknown parameter {key}");
    }
    if what == "voxels" || what == "all" {
        let params = sdf_params.clone();
        let start = Instant::now();
        let voxels = VoxelGrid::build(&scene, params.voxel_size)?;
        let built = start.elapsed().as_secs_f64();
        let start = Instant::now();
        let _field = voxels.distance_field();
        println!(
            "voxels {:?} at {:.3} m: free {}, surface {}, inside {} ({} solid and {} sealed-air \
             pockets): {built:.2} s, distance transform {:.2} s",
            voxels.dims(),
            voxels.voxel_size(),
            voxels.count(VoxelState::Free),
            voxels.count(VoxelState::Surface),
            voxels.count(VoxelState::Inside),
            voxels.inside_components(),
            voxels.enclosed_free_components(),
            start.elapsed().as_secs_f64()
        );
    }
    if what == "sdf" || what == "all" {
        let params = sdf_params;
        let start = Instant::now();
        let sdf = sdf_candidates(&scene, &params)?;
        let seconds = start.elapsed().as_secs_f64();
        let inside = count_inside(&scene, &sdf.probes.positions);
        println!(
            "sdf: {} probes in {seconds:.2} s ({params:?}); skeleton {} voxels, {} pieces kept, \
             {} dropped; {} small clusters; clusters {:?}; inside geometry {inside}",
            sdf.probes.len(),
            sdf.skeleton_voxels,
            sdf.pieces_kept,
            sdf.pieces_dropped,
            sdf.small_clusters,
            sdf.clusters
        );
        print_positions(&sdf.probes.positions);
    }
    if what == "medial" || what == "all" {
        let params = medial_params;
        let start = Instant::now();
        let medial = medial_candidates(&scene, &params)?;
        let seconds = start.elapsed().as_secs_f64();
        let inside = count_inside(&scene, &medial.probes.positions);
        println!(
            "medial: {} probes in {seconds:.2} s ({} samples); {} balls shrunk, {} open, {} kept; \
             {} small clusters; clusters {:?}; inside geometry {inside}",
            medial.probes.len(),
            params.sample_count,
            medial.balls_shrunk,
            medial.balls_open,
            medial.balls.len(),
            medial.small_clusters,
            medial.clusters
        );
        print_positions(&medial.probes.positions);
    }
    Ok(())
}

fn count_inside(scene: &Scene, positions: &[glam::Vec3]) -> usize {
    positions
        .iter()
        .filter(|&&p| inside_geometry(scene, p))
        .count()
}

fn print_positions(positions: &[glam::Vec3]) {
    if positions.len() <= 100 {
        for p in positions {
            println!("  ({:.3}, {:.3}, {:.3})", p.x, p.y, p.z);
        }
    }
}
