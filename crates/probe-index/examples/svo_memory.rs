//! Sparse voxel octree memory on real scenes, for the comparison with seed 000's Table 5.2.
//!
//! Usage:
//! `cargo run --release -p probe-index --example svo_memory -- [SCENE] [DEPTH] [PROBES] [--strict]`
//!
//! `SCENE` is anything `probe_scene::Scene::open` takes (`builtin:cornell`, `builtin:colonnade`,
//! a glTF path) or `sponza` / `cornell_box` for the shared scenes; default: all four at their
//! default settings. `DEPTH` is the octree depth (finest voxel = scene cube / 2^depth).
//! `PROBES` is `NxMxK`: a regular grid of probes over the scene bounds shrunk by 10 % on each
//! side (seed 000 Table 5.2 compares against 8 probes in Cornell and 54 = 6×3×3 in Sponza).
//! `--strict` builds with seed 000's rules to the letter (no surface shell, no merging of
//! unseen voxels) for comparison.

use std::time::Instant;

use glam::Vec3;
use probe_index::{SparseVoxelOctree, SvoOptions};
use probe_scene::Scene;

fn grid_probes(scene: &Scene, dims: [u32; 3]) -> Vec<Vec3> {
    let b = scene.bounds();
    let margin = b.size() * 0.1;
    let lo = b.min + margin;
    let size = b.size() - margin * 2.0;
    let mut out = Vec::new();
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            for x in 0..dims[0] {
                let t = Vec3::new(
                    (x as f32 + 0.5) / dims[0] as f32,
                    (y as f32 + 0.5) / dims[1] as f32,
                    (z as f32 + 0.5) / dims[2] as f32,
                );
                out.push(lo + size * t);
            }
        }
    }
    out
}

fn run(spec: &str, depth: u32, dims: [u32; 3], strict: bool) {
    let path = match spec {
        "sponza" => probe_testdata::scene_path(probe_testdata::SPONZA)
            .to_string_lossy()
            .into_owned(),
        "cornell_box" => probe_testdata::scene_path(probe_testdata::CORNELL_BOX)
            .to_string_lossy()
            .into_owned(),
        other => other.to_string(),
    };
    let clock = Instant::now();
    let scene = match Scene::open(&path) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("{spec}: {e}");
            std::process::exit(1);
        }
    };
    let load = clock.elapsed().as_secs_f64();
    let probes = grid_probes(&scene, dims);
    let mut options = SvoOptions {
        max_depth: depth,
        ..SvoOptions::default()
    };
    if strict {
        options.surface_shell_levels = 0;
        options.merge_unseen_leaves = false;
    }
    let clock = Instant::now();
    let svo = match SparseVoxelOctree::build(&scene, &probes, &options) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("{spec}: {e}");
            std::process::exit(1);
        }
    };
    let build = clock.elapsed().as_secs_f64();
    let s = svo.stats();
    let mb = |b: usize| b as f64 / 1e6;
    println!(
        "scene={spec} triangles={} load_s={load:.2} probes={} depth={depth} strict={strict} \
         cube={:.3} m finest_voxel={:.4} m | full tree: {} nodes, {} surface + {} empty leaves, \
         {:.2} MB | merged: {} node words, {} packed blocks, {} payloads, {:.3} MB \
         ({:.1}x smaller) | leaves without a visible probe {} | visibility queries {} | \
         build {build:.1} s (subdivide {:.2} s, rank {:.1} s, layout {:.2} s)",
        scene.triangles().len(),
        probes.len(),
        svo.header().size,
        s.finest_voxel_size,
        s.full_nodes,
        s.surface_leaves,
        s.empty_leaves,
        mb(s.full_bytes),
        s.nodes,
        s.blocks,
        s.payloads,
        mb(s.bytes),
        s.full_bytes as f64 / s.bytes as f64,
        s.leaves_without_probe,
        s.visibility_queries,
        s.subdivide_time.as_secs_f64(),
        s.rank_time.as_secs_f64(),
        s.layout_time.as_secs_f64(),
    );
}

fn parse_dims(s: &str) -> Option<[u32; 3]> {
    let v: Vec<u32> = s.split('x').filter_map(|p| p.parse().ok()).collect();
    (v.len() == 3 && v.iter().all(|&n| n > 0)).then(|| [v[0], v[1], v[2]])
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let strict = args.iter().any(|a| a == "--strict");
    let positional: Vec<&String> = args.iter().filter(|a| !a.starts_with("--")).collect();
    match positional.first() {
        Some(spec) => {
            let depth = positional.get(1).and_then(|s| s.parse().ok()).unwrap_or(9);
            let dims = positional
                .get(2)
                .and_then(|s| parse_dims(s))
                .unwrap_or([2, 2, 2]);
            run(spec, depth, dims, strict);
        }
        None => {
            run("builtin:cornell", 9, [2, 2, 2], strict);
            run("cornell_box", 9, [2, 2, 2], strict);
            run("builtin:colonnade", 9, [4, 2, 4], strict);
            run("sponza", 9, [6, 3, 3], strict);
        }
    }
}
