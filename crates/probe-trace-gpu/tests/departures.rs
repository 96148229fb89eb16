//! Rays that leave a surface are answered from where they leave it, not by a probe that sees
//! that surface from behind (a self-hit a few millimetres out). Sponza's drapes and folds
//! are where this happens: rays along their normals (the lobe of a roughness-1 material).

mod support;

use glam::{Vec2, Vec3};
use probe_index::ProbeGrid;
use probe_scene::{Ray, Scene};
use probe_trace_gpu::{RayStatus, TraceOptions, Tracer};
use support::{capture_bake, cpu_grid_field, to_trace_rays};

#[test]
fn rays_leaving_sponzas_surfaces_do_not_hit_at_their_start() {
    let scene = Scene::load(probe_testdata::scene_path(probe_testdata::SPONZA)).unwrap();
    let camera = scene.camera("CameraMain").unwrap().clone();
    // Rays along the normal of each primary hit of a 120×68 image, leaving the surface.
    let (w, h) = (120, 68);
    let rays: Vec<Ray> = (0..w * h)
        .filter_map(|i| {
            let primary = camera.ray(i % w, i / w, w, h, Vec2::ZERO);
            let hit = scene.closest_hit(&primary, f32::INFINITY)?;
            // Normals turned to the viewer's side; the ray leaves along the shading normal.
            let flip = if hit.geometric_normal.dot(primary.direction) < 0.0 {
                1.0
            } else {
                -1.0
            };
            let (geometric, shading) = (hit.geometric_normal * flip, hit.shading_normal * flip);
            (shading.dot(geometric) > 0.0)
                .then(|| Ray::from_surface(hit.position, geometric, shading))
        })
        .collect();
    // 64 probes at the cell centres of the atrium region (eval.toml), 8 × 2 × 4.
    let (lo, hi) = (Vec3::new(-20.0, 4.0, -9.0), Vec3::new(17.3, 15.0, 7.6));
    let spacing = (hi - lo) / Vec3::new(8.0, 2.0, 4.0);
    let grid = ProbeGrid::new(lo + spacing * 0.5, spacing, [8, 2, 4]).unwrap();
    let bake = capture_bake(&scene, &grid.positions(), 128);
    let (mut tracer, field) = cpu_grid_field(&bake, grid);
    let results = tracer
        .trace(&field, &to_trace_rays(&rays), &TraceOptions::default())
        .unwrap()
        .results;
    let self_hits = rays
        .iter()
        .zip(&results)
        .filter(|(ray, r)| {
            r.status == RayStatus::Hit
                && r.t < 0.05
                && scene
                    .closest_hit(ray, f32::INFINITY)
                    .is_none_or(|truth| truth.t > 0.2)
        })
        .count();
    let share = self_hits as f64 / rays.len() as f64;
    eprintln!(
        "{self_hits} self-hits of {} rays ({:.3} %)",
        rays.len(),
        100.0 * share
    );
    assert!(
        share < 0.003,
        "{self_hits} self-hits of {} rays",
        rays.len()
    );
}
