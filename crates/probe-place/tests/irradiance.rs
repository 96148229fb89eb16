//! Seed 002's irradiance-driven methods with an analytic oracle: a point light in the lit room
//! of `leak-closed`, shadowed by the scene, so the dark room is completely unlit.

use glam::Vec3;
use probe_place::{
    atlas::{BackfaceVote, FreeSpace},
    irradiance::{
        GradientAscentParams, IrradianceError, LightingOracle, PointLightOracle, SpawnMergeParams,
        gradient_ascent, irradiance_gradient, k_means, spawn_and_merge,
    },
};
use probe_scene::Scene;
use probe_scene::builtin::{LEAK_DARK_ROOM, LEAK_LIT_ROOM};

const LIGHT: Vec3 = Vec3::new(-2.1, 2.5, 0.0);

fn leak_closed() -> Scene {
    Scene::builtin("leak-closed").unwrap()
}

fn oracle(scene: &Scene) -> PointLightOracle<'_> {
    PointLightOracle::new(scene, LIGHT, Vec3::splat(10.0))
}

#[test]
fn the_analytic_oracle_falls_off_and_is_shadowed() {
    let scene = leak_closed();
    let o = oracle(&scene);
    let near = o.irradiance(LIGHT - Vec3::Y);
    let far = o.irradiance(LIGHT - Vec3::Y * 2.0);
    assert!((near.x - 10.0).abs() < 1e-3 && (far.x - 2.5).abs() < 1e-3);
    // Behind the complete dividing wall: dark.
    assert_eq!(o.irradiance(Vec3::new(2.0, 1.5, 0.0)), Vec3::ZERO);
    // Facing away from the light: no irradiance; facing it: all of it.
    let p = LIGHT - Vec3::Y;
    assert_eq!(o.irradiance_towards(p, -Vec3::Y), Vec3::ZERO);
    assert!((o.irradiance_towards(p, Vec3::Y) - near).length() < 1e-4);
    // The gradient points at the light.
    let g = irradiance_gradient(&o, Vec3::new(-3.0, 1.0, 1.0));
    assert!(
        g.normalize()
            .dot((LIGHT - Vec3::new(-3.0, 1.0, 1.0)).normalize())
            > 0.95
    );
    assert_eq!(
        irradiance_gradient(&o, Vec3::new(2.0, 1.5, 0.0)),
        Vec3::ZERO
    );
}

#[test]
fn spawn_and_merge_thins_flat_lighting_and_refines_near_the_light() {
    let scene = leak_closed();
    let o = oracle(&scene);
    let free = BackfaceVote::new(&scene);
    let params = SpawnMergeParams::with_spacing(0.5);
    let result = spawn_and_merge(&scene, &o, &free, &params).unwrap();
    let probes = result.positions();
    assert!(probes.iter().all(|p| free.is_free(*p)));
    assert!(!result.spawn_merge_steps.is_empty());
    let lit = probes
        .iter()
        .filter(|p| LEAK_LIT_ROOM.contains(**p))
        .count();
    let dark = probes
        .iter()
        .filter(|p| LEAK_DARK_ROOM.contains(**p))
        .count();
    assert_eq!(lit + dark, probes.len());
    // The starting grid had the same number of points in both (mirror-image) rooms.
    let start = probe_place::atlas::free_space_grid(&free, 0.5);
    let start_dark = start
        .iter()
        .filter(|p| LEAK_DARK_ROOM.contains(**p))
        .count();
    let start_lit = start.iter().filter(|p| LEAK_LIT_ROOM.contains(**p)).count();
    assert!(
        start_dark.abs_diff(start_lit) <= 4,
        "{start_dark} vs {start_lit}"
    );
    // Where the lighting is flat (the dark room) merges leave far fewer probes; the lit room
    // keeps more than the dark one.
    assert!(dark < start_dark / 2, "dark {dark} of {start_dark}");
    assert!(lit > 2 * dark, "lit {lit}, dark {dark}");
    // Spawns cluster around the light: the probes within 1 m of it are denser than the
    // starting grid there.
    let near = |ps: &[Vec3]| ps.iter().filter(|p| p.distance(LIGHT) < 1.0).count();
    assert!(
        near(&probes) > near(&start),
        "{} vs {}",
        near(&probes),
        near(&start)
    );
    // Deterministic.
    assert_eq!(spawn_and_merge(&scene, &o, &free, &params).unwrap(), result);
}

#[test]
fn gradient_ascent_climbs_towards_the_light_and_clusters_the_unlit() {
    // `leak-gap` with the light 0.2 m from the dividing wall: it reaches part of the dark room
    // through the gap, and probes that overshoot it step into the wall or behind it, into the
    // dark, and are sent back (seed 002's second-order rule).
    let scene = Scene::builtin("leak-gap").unwrap();
    const LIGHT: Vec3 = Vec3::new(-0.3, 1.5, 1.0);
    let o = PointLightOracle::new(&scene, LIGHT, Vec3::splat(10.0));
    let free = BackfaceVote::new(&scene);
    let params = GradientAscentParams {
        unlit_clusters: 3,
        ..GradientAscentParams::with_spacing(0.6)
    };
    let start = probe_place::atlas::free_space_grid(&free, 0.6);
    let start_lit: Vec<Vec3> = start
        .iter()
        .copied()
        .filter(|p| o.irradiance(*p).x > 0.0)
        .collect();
    assert!(start_lit.iter().any(|p| LEAK_DARK_ROOM.contains(*p)));
    let result = gradient_ascent(&scene, &o, &free, &params).unwrap();
    let probes = result.positions();
    assert_eq!(result.lit + result.unlit, probes.len());
    assert!(probes.iter().all(|p| free.is_free(*p)));
    // The lit probes moved towards where the irradiance changes most: the light.
    let mean_distance =
        |ps: &[Vec3]| ps.iter().map(|p| p.distance(LIGHT)).sum::<f32>() / ps.len() as f32;
    let lit = &probes[..result.lit];
    assert!(
        mean_distance(lit) < 0.6 * mean_distance(&start_lit),
        "{} vs {}",
        mean_distance(lit),
        mean_distance(&start_lit)
    );
    // Converged probes were merged: fewer lit probes than lit starting points.
    assert!(
        result.lit < start_lit.len() / 2,
        "{} of {}",
        result.lit,
        start_lit.len()
    );
    // Every lit probe is still lit: steps into the dark were reverted, not taken.
    assert!(lit.iter().all(|p| o.irradiance(*p).x > 0.0));
    assert!(
        result
            .ascent_steps
            .iter()
            .any(|(_, reverted)| *reverted > 0)
    );
    // k-means: exactly the 3 requested unlit probes, in the dark room, spread out.
    assert_eq!(result.unlit, 3);
    let unlit = &probes[result.lit..];
    assert!(unlit.iter().all(|p| LEAK_DARK_ROOM.contains(*p)));
    for i in 0..3 {
        for j in i + 1..3 {
            assert!(unlit[i].distance(unlit[j]) > 1.0);
        }
    }
    assert_eq!(gradient_ascent(&scene, &o, &free, &params).unwrap(), result);
}

#[test]
fn k_means_places_the_requested_number_of_centres() {
    let scene = leak_closed();
    let free = BackfaceVote::new(&scene);
    // Three well-separated blobs in the dark room.
    let blobs = [
        Vec3::new(1.0, 1.0, -1.0),
        Vec3::new(3.0, 2.0, 1.0),
        Vec3::new(3.0, 0.7, -1.5),
    ];
    let mut points = Vec::new();
    for (b, centre) in blobs.iter().enumerate() {
        for i in 0..20 {
            let t = i as f32 * 0.7 + b as f32;
            points.push(*centre + Vec3::new(t.sin(), (1.3 * t).cos(), (0.7 * t).sin()) * 0.2);
        }
    }
    for k in 1..=5 {
        let centres = k_means(&points, k, 3, &free);
        assert_eq!(centres.len(), k);
        assert!(centres.iter().all(|c| free.is_free(*c)));
    }
    let centres = k_means(&points, 3, 3, &free);
    for blob in blobs {
        let nearest = centres
            .iter()
            .map(|c| c.distance(blob))
            .fold(f32::MAX, f32::min);
        assert!(nearest < 0.15, "{blob}: {centres:?}");
    }
    assert_eq!(k_means(&points, 3, 3, &free), centres);
    assert_eq!(k_means(&points[..2], 5, 0, &free).len(), 2);
    assert!(k_means(&[], 3, 0, &free).is_empty());
}

#[test]
fn bad_parameters_and_empty_scenes_are_errors() {
    let scene = leak_closed();
    let o = oracle(&scene);
    let free = BackfaceVote::new(&scene);
    let name_of = |e: IrradianceError| match e {
        IrradianceError::InvalidParameter { name, .. } => name,
        other => panic!("{other}"),
    };
    let sm = SpawnMergeParams::with_spacing(0.5);
    for (bad, name) in [
        (SpawnMergeParams { spacing: 0.0, ..sm }, "spacing"),
        (
            SpawnMergeParams {
                contrast_threshold: f32::NAN,
                ..sm
            },
            "contrast_threshold",
        ),
        (
            SpawnMergeParams {
                min_spacing: -1.0,
                ..sm
            },
            "min_spacing",
        ),
        (
            SpawnMergeParams {
                max_probes: 0,
                ..sm
            },
            "max_probes",
        ),
        (
            SpawnMergeParams {
                spacing: 1e-4,
                ..sm
            },
            "spacing",
        ),
    ] {
        assert_eq!(
            name_of(spawn_and_merge(&scene, &o, &free, &bad).unwrap_err()),
            name
        );
    }
    let ga = GradientAscentParams::with_spacing(0.5);
    for (bad, name) in [
        (
            GradientAscentParams {
                step: f32::NAN,
                ..ga
            },
            "step",
        ),
        (
            GradientAscentParams {
                unlit_threshold: -1.0,
                ..ga
            },
            "unlit_threshold",
        ),
    ] {
        assert_eq!(
            name_of(gradient_ascent(&scene, &o, &free, &bad).unwrap_err()),
            name
        );
    }
    let empty =
        Scene::from_triangles("void", Vec::new(), Vec::new(), Vec::new(), Vec::new()).unwrap();
    let free_empty = BackfaceVote::new(&empty);
    let o_empty = PointLightOracle::new(&empty, Vec3::ZERO, Vec3::ONE);
    assert!(matches!(
        spawn_and_merge(&empty, &o_empty, &free_empty, &sm),
        Err(IrradianceError::EmptyScene { .. })
    ));
    assert!(matches!(
        gradient_ascent(&empty, &o_empty, &free_empty, &ga),
        Err(IrradianceError::EmptyScene { .. })
    ));
    // A free-space test whose box holds no free point.
    let walled = free.with_bounds(probe_scene::Aabb::new(
        Vec3::new(-0.05, 1.0, -1.0),
        Vec3::new(0.05, 2.0, 1.0),
    ));
    assert!(!walled.is_free(Vec3::new(0.0, 1.5, 0.0)));
    assert!(matches!(
        spawn_and_merge(&scene, &o, &walled, &sm),
        Err(IrradianceError::NoFreeGridPoint { .. })
    ));
}
