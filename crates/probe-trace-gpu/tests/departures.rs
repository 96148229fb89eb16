//! Rays that leave a surface are answered from where they leave it, not by a probe that sees
//! that surface from behind (a self-hit a few millimetres out). Sponza's drapes and folds
//! are where this happens: rays along their normals (the lobe of a roughness-1 material).

mod support;

use glam::{Vec2, Vec3};
use probe_index::ProbeGrid;
use probe_scene::{Ray, Scene};
use probe_trace_gpu::{RayStatus, TraceOptions, Tracer};
use support::{capture_bake, cpu_grid_field, to_trace_rays};

/// Sponza's `CameraMain` at 120×68: a ray from each primary hit built by `leave` (from the hit
/// and the normals turned to the viewer's side), traced through 64 probes at the cell
/// centres of the atrium region (eval.toml, 8 × 2 × 4) at 128², the CPU twin's defaults.
fn sponza_departures(
    leave: impl Fn(&Ray, &probe_scene::Hit, Vec3, Vec3) -> Option<Ray>,
) -> (Scene, Vec<Ray>, Vec<probe_trace_gpu::RayResult>) {
    let scene = Scene::load(probe_testdata::scene_path(probe_testdata::SPONZA)).unwrap();
    let camera = scene.camera("CameraMain").unwrap().clone();
    let (w, h) = (120, 68);
    let rays: Vec<Ray> = (0..w * h)
        .filter_map(|i| {
            let primary = camera.ray(i % w, i / w, w, h, Vec2::ZERO);
            let hit = scene.closest_hit(&primary, f32::INFINITY)?;
            let flip = if hit.geometric_normal.dot(primary.direction) < 0.0 {
                1.0
            } else {
                -1.0
            };
            leave(
                &primary,
                &hit,
                hit.geometric_normal * flip,
                hit.shading_normal * flip,
            )
        })
        .collect();
    let (lo, hi) = (Vec3::new(-20.0, 4.0, -9.0), Vec3::new(17.3, 15.0, 7.6));
    let spacing = (hi - lo) / Vec3::new(8.0, 2.0, 4.0);
    let grid = ProbeGrid::new(lo + spacing * 0.5, spacing, [8, 2, 4]).unwrap();
    let bake = capture_bake(&scene, &grid.positions(), 128);
    let (mut tracer, field) = cpu_grid_field(&bake, grid);
    let results = tracer
        .trace(&field, &to_trace_rays(&rays), &TraceOptions::default())
        .unwrap()
        .results;
    (scene, rays, results)
}

/// The rays answered with a hit within `within` of their start whose true hit lies farther
/// than `truth_beyond` (or nowhere).
fn hits_near_the_start(
    scene: &Scene,
    rays: &[Ray],
    results: &[probe_trace_gpu::RayResult],
    within: f32,
    truth_beyond: f32,
) -> usize {
    rays.iter()
        .zip(results)
        .filter(|(ray, r)| {
            r.status == RayStatus::Hit
                && r.t < within
                && scene
                    .closest_hit(ray, f32::INFINITY)
                    .is_none_or(|truth| truth.t > truth_beyond)
        })
        .count()
}

#[test]
fn rays_leaving_sponzas_surfaces_do_not_hit_at_their_start() {
    // Rays along the normal of each primary hit, leaving the surface.
    let (scene, rays, results) = sponza_departures(|_, hit, geometric, shading| {
        (shading.dot(geometric) > 0.0).then(|| Ray::from_surface(hit.position, geometric, shading))
    });
    let self_hits = hits_near_the_start(&scene, &rays, &results, 0.05, 0.2);
    let share = self_hits as f64 / rays.len() as f64;
    eprintln!(
        "{self_hits} self-hits of {} rays ({:.3} %)",
        rays.len(),
        100.0 * share
    );
    assert!(
        share < 0.001,
        "{self_hits} self-hits of {} rays",
        rays.len()
    );
}

/// A mirror reflection ray that leaves a surface beside a convex edge (a moulding, a column's
/// base) starts behind the plane of the neighbouring face a probe sees there, and only goes
/// deeper behind it: it never crosses it, so that probe hands it on instead of answering a hit
/// a few centimetres out (`fine_test`: the ray's origin lies behind the plane too).
#[test]
fn reflections_that_start_behind_a_plane_do_not_hit_it() {
    let (scene, rays, results) = sponza_departures(|primary, hit, geometric, _| {
        let d = primary.direction;
        let r = d - 2.0 * d.dot(geometric) * geometric;
        Some(Ray::from_surface(hit.position, geometric, r))
    });
    let early = hits_near_the_start(&scene, &rays, &results, 0.1, 0.5);
    eprintln!(
        "{early} hits within 0.1 m of the start of {} reflection rays",
        rays.len()
    );
    assert!(early < 20, "{early} hits within 0.1 m of the start");
}
