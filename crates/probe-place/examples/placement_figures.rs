//! The figures of BENCHMARKS.md's "probe-place (optimisation)" section, for one scene:
//! atlas size and build time, Gibbs sampling time (64 probes, 100 iterations by default), the
//! smallest full-coverage regular grid (near-cubic cells, the longest axis cut into 1, 2, 3, ...
//! cells) and the minimal full-coverage set from a dense candidate pool.
//!
//! ```text
//! cargo run --release -p probe-place --example placement_figures -- SCENE \
//!     [--texels 20000] [--reference-spacing 2.0] [--gibbs-probes 8x2x4] \
//!     [--gibbs-iterations 100] [--gibbs-step 0.5] [--grid-cap 4000] [--candidates] \
//!     [--max-escaping 0.4] [--json out.json]
//! ```
//!
//! `--max-escaping S` sets [`BackfaceVote::max_escaping_fraction`]: points from which more than
//! the share `S` of rays escape the scene are outdoors, not free.
//!
//! With `--candidates`, the SDF-skeleton and medial-axis candidates (default parameters) are
//! measured on the atlas too, refined by Gibbs sampling, and added to the minimal cover's pool.
//!
//! `SCENE` is a path or `builtin:NAME`; `sponza`, `godot-room` and `cornell-box` name the
//! shared scenes. Distances are in metres; the defaults for the reference spacing and the
//! Gibbs step are 1/25 and 1/100 of the bounds' longest side.

use probe_place::{
    atlas::{Atlas, AtlasParams, BackfaceVote, FreeSpace, VoxelFreeSpace, free_space_grid},
    candidates::{MedialParams, SdfParams, VoxelGrid, medial_candidates, sdf_candidates},
    minimal::{CoverParams, minimal_cover},
    optimize::{GibbsParams, gibbs},
};
use probe_scene::Scene;
use probe_scene::builtin::grid_cell_centers;
use std::time::Instant;

fn arg<T: std::str::FromStr>(args: &[String], name: &str) -> Option<T> {
    let at = args.iter().position(|a| a == name)?;
    args.get(at + 1)?.parse().ok()
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let spec = args.first().cloned().unwrap_or_else(|| "sponza".to_owned());
    let path = match spec.as_str() {
        "sponza" => probe_testdata::scene_path(probe_testdata::SPONZA)
            .display()
            .to_string(),
        "godot-room" => probe_testdata::scene_path(probe_testdata::GODOT_ROOM)
            .display()
            .to_string(),
        "cornell-box" => probe_testdata::scene_path(probe_testdata::CORNELL_BOX)
            .display()
            .to_string(),
        other => other.to_owned(),
    };
    let t = Instant::now();
    let scene = Scene::open(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let load_s = t.elapsed().as_secs_f64();
    let size = scene.bounds().size();
    let texels: usize = arg(&args, "--texels").unwrap_or(20_000);
    let spacing: f32 = arg(&args, "--reference-spacing").unwrap_or(size.max_element() / 25.0);
    let gibbs_iterations: usize = arg(&args, "--gibbs-iterations").unwrap_or(100);
    let gibbs_step: f32 = arg(&args, "--gibbs-step").unwrap_or(size.max_element() / 100.0);
    let grid_cap: usize = arg(&args, "--grid-cap").unwrap_or(4000);
    let gibbs_dims: [u32; 3] = arg::<String>(&args, "--gibbs-probes")
        .map(|s| {
            let v: Vec<u32> = s.split('x').filter_map(|n| n.parse().ok()).collect();
            [v[0], v[1], v[2]]
        })
        .unwrap_or([8, 2, 4]);
    println!(
        "scene {} ({} triangles), bounds {:?}..{:?}, loaded in {load_s:.2} s",
        scene.name(),
        scene.triangles().len(),
        scene.bounds().min,
        scene.bounds().max
    );

    // Free space: the ray vote and the SDF generator's voxels (1/160 of the longest side) must
    // both agree.
    let t = Instant::now();
    let voxels = VoxelGrid::build(&scene, size.max_element() / 160.0).expect("voxels");
    let mut vote = BackfaceVote::new(&scene);
    vote.max_escaping_fraction = arg(&args, "--max-escaping");
    let free = (vote, VoxelFreeSpace::new(&voxels, scene.bounds()));
    let voxels_s = t.elapsed().as_secs_f64();
    println!("voxels for the free-space test: {voxels_s:.2} s");
    let t = Instant::now();
    let pool = free_space_grid(&free, spacing);
    let pool_s = t.elapsed().as_secs_f64();
    println!(
        "reference grid: spacing {spacing} m, {} free points, {pool_s:.2} s",
        pool.len()
    );

    let params = AtlasParams::for_texel_count(&scene, texels);
    let t = Instant::now();
    let atlas = Atlas::build(&scene, &params, &pool).expect("atlas");
    let atlas_s = t.elapsed().as_secs_f64();
    println!(
        "atlas: texel {:.3} m, {} texels kept, {} unreachable, built in {atlas_s:.2} s",
        params.texel_size,
        atlas.samples().len(),
        atlas.unreachable_texels()
    );

    // Gibbs timing.
    let start = grid_cell_centers(&scene.bounds(), gibbs_dims);
    let inside_at_start = start.iter().filter(|p| free.inside_geometry(**p)).count();
    let t = Instant::now();
    let result = gibbs(
        &atlas,
        &free,
        &start,
        &GibbsParams {
            max_iterations: gibbs_iterations,
            ..GibbsParams::with_step(gibbs_step)
        },
    )
    .expect("gibbs");
    let gibbs_s = t.elapsed().as_secs_f64();
    let moves: usize = result.history.iter().map(|r| r.moves).sum();
    println!(
        "gibbs: {} probes ({gibbs_dims:?} grid, {inside_at_start} inside geometry), step {gibbs_step} m, \
         {} iterations in {gibbs_s:.2} s ({:.3} s/iteration); {moves} moves; coverage {:.4} -> best {:.4}, \
         reward {:.4} -> {:.4}",
        start.len(),
        result.iterations,
        gibbs_s / result.iterations.max(1) as f64,
        result.history[0].coverage,
        result.coverage,
        result.history[0].reward,
        result.reward,
    );

    // Minimal full-coverage set from the dense pool.
    let t = Instant::now();
    let set = minimal_cover(&atlas, &free, &pool, &CoverParams::full_coverage()).expect("cover");
    let cover_s = t.elapsed().as_secs_f64();
    let inside = set
        .positions()
        .iter()
        .filter(|p| free.inside_geometry(**p))
        .count();
    println!(
        "minimal cover: {} probes (greedy {} then pruned {}), coverage {:.4}, {inside} inside geometry, {cover_s:.2} s",
        set.positions.len(),
        set.coverage_by_count.len(),
        set.pruned,
        set.coverage
    );

    // The candidate generators, measured on the same atlas and refined by Gibbs.
    let mut candidates_json = serde_json::Value::Null;
    if args.iter().any(|a| a == "--candidates") {
        let t = Instant::now();
        let sdf = sdf_candidates(&scene, &SdfParams::for_scene(&scene)).expect("sdf");
        let sdf_s = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let medial = medial_candidates(&scene, &MedialParams::for_scene(&scene)).expect("medial");
        let medial_s = t.elapsed().as_secs_f64();
        let sdf_p = sdf.probes.positions.clone();
        let medial_p = medial.probes.positions.clone();
        let t = Instant::now();
        let refined = gibbs(
            &atlas,
            &free,
            &sdf_p,
            &GibbsParams {
                max_iterations: gibbs_iterations,
                ..GibbsParams::with_step(gibbs_step)
            },
        )
        .expect("gibbs");
        let refine_s = t.elapsed().as_secs_f64();
        let mut union = sdf_p.clone();
        union.extend(&medial_p);
        union.extend(&pool);
        let t = Instant::now();
        let mixed =
            minimal_cover(&atlas, &free, &union, &CoverParams::full_coverage()).expect("cover");
        let mixed_s = t.elapsed().as_secs_f64();
        let from_candidates = mixed
            .chosen
            .iter()
            .filter(|&&i| i < sdf_p.len() + medial_p.len())
            .count();
        println!(
            "candidates: SDF {} probes ({sdf_s:.2} s) coverage {:.4}; medial {} probes ({medial_s:.2} s) coverage {:.4}",
            sdf_p.len(),
            atlas.coverage(&sdf_p),
            medial_p.len(),
            atlas.coverage(&medial_p)
        );
        println!(
            "gibbs from the SDF candidates: {} iterations in {refine_s:.2} s, coverage {:.4} -> best {:.4}",
            refined.iterations, refined.history[0].coverage, refined.coverage
        );
        println!(
            "minimal cover over SDF + medial + reference grid: {} probes ({from_candidates} of them SDF/medial candidates), {mixed_s:.2} s",
            mixed.positions.len()
        );
        candidates_json = serde_json::json!({
            "sdf": {"probes": sdf_p.len(), "seconds": sdf_s, "coverage": atlas.coverage(&sdf_p)},
            "medial": {"probes": medial_p.len(), "seconds": medial_s, "coverage": atlas.coverage(&medial_p)},
            "gibbs_from_sdf": {"iterations": refined.iterations, "seconds": refine_s,
                "coverage_start": refined.history[0].coverage, "coverage_best": refined.coverage},
            "minimal_cover_mixed_pool": {"probes": mixed.positions.len(), "from_candidates": from_candidates},
        });
    }

    // Fewer probes for slightly less than full coverage.
    let mut partial = Vec::new();
    for target in [0.99f32, 0.999] {
        let params = CoverParams {
            target_coverage: target,
            ..CoverParams::full_coverage()
        };
        let s = minimal_cover(&atlas, &free, &pool, &params).expect("cover");
        println!(
            "minimal cover for {:.1} %: {} probes (coverage {:.4})",
            100.0 * target,
            s.positions.len(),
            s.coverage
        );
        partial.push(serde_json::json!({"target": target, "probes": s.positions.len(), "coverage": s.coverage}));
    }

    // The smallest full-coverage regular grid: grids of near-cubic cells, the longest axis cut
    // into 1, 2, 3, ... cells and the others in proportion, up to `grid_cap` probes.
    let t = Instant::now();
    let mut grids = Vec::new();
    let mut smallest = None;
    for resolution in 1u32.. {
        let longest = size.max_element();
        let d = |s: f32| ((resolution as f32 * s / longest).round() as u32).max(1);
        let dims = [d(size.x), d(size.y), d(size.z)];
        let count = (dims[0] * dims[1] * dims[2]) as usize;
        if count > grid_cap {
            break;
        }
        let grid = grid_cell_centers(&scene.bounds(), dims);
        let coverage = atlas.coverage(&grid);
        println!("  grid {dims:?} = {count} probes: coverage {coverage:.4}");
        grids.push(serde_json::json!({"dims": dims, "probes": count, "coverage": coverage}));
        if coverage >= 1.0 {
            smallest = Some((dims, count));
            break;
        }
    }
    let grid_s = t.elapsed().as_secs_f64();
    match smallest {
        Some((dims, count)) => println!(
            "smallest full-coverage grid: {dims:?} = {count} probes; minimal set {} = {:.1} % of it \
             (goal: at most 50 %); search {grid_s:.1} s",
            set.positions.len(),
            100.0 * set.positions.len() as f64 / count as f64
        ),
        None => println!(
            "no regular grid of at most {grid_cap} probes reaches full coverage (search {grid_s:.1} s)"
        ),
    }

    if let Some(out) = arg::<String>(&args, "--json") {
        let summary = serde_json::json!({
            "scene": scene.name(),
            "triangles": scene.triangles().len(),
            "reference_spacing": spacing,
            "reference_points": pool.len(),
            "texel_size": params.texel_size,
            "texels": atlas.samples().len(),
            "unreachable_texels": atlas.unreachable_texels(),
            "atlas_seconds": atlas_s,
            "gibbs": {
                "probes": start.len(), "iterations": result.iterations, "step": gibbs_step,
                "seconds": gibbs_s, "coverage_start": result.history[0].coverage,
                "coverage_best": result.coverage, "history": result.history,
            },
            "minimal_cover": {
                "probes": set.positions.len(), "coverage": set.coverage, "seconds": cover_s,
                "coverage_by_count": set.coverage_by_count, "positions": set.positions,
            },
            "minimal_cover_partial": partial,
            "candidates": candidates_json,
            "grids": grids,
            "smallest_full_coverage_grid": smallest.map(|(d, c)| serde_json::json!({"dims": d, "probes": c})),
        });
        std::fs::write(&out, serde_json::to_string_pretty(&summary).unwrap()).expect("write");
        println!("wrote {out}");
    }
}
