//! The built-in scenes: they load, are well formed, and have the properties their docs promise.

use glam::{Vec2, Vec3};
use probe_scene::builtin::{
    BOXES_BOX_SIZE, BOXES_GRID, LEAK_DARK_ROOM, LEAK_GAP, LEAK_LIT_ROOM, grid_cell_centers,
};
use probe_scene::{BUILTIN_SCENES, Hit, LoadError, Ray, Scene, SceneSource};
use std::collections::HashMap;

fn builtin(name: &str) -> Scene {
    Scene::builtin(name).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// 26 directions: the cube's face, edge and corner directions.
fn directions() -> Vec<Vec3> {
    let mut out = Vec::new();
    for x in -1..=1 {
        for y in -1..=1 {
            for z in -1..=1 {
                if (x, y, z) != (0, 0, 0) {
                    out.push(Vec3::new(x as f32, y as f32, z as f32).normalize());
                }
            }
        }
    }
    out
}

/// Fibonacci-sphere directions, spread evenly.
fn sphere_directions(count: usize) -> Vec<Vec3> {
    let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    (0..count)
        .map(|i| {
            let y = 1.0 - 2.0 * (i as f32 + 0.5) / count as f32;
            let r = (1.0 - y * y).sqrt();
            let phi = golden * i as f32;
            Vec3::new(r * phi.cos(), y, r * phi.sin())
        })
        .collect()
}

#[test]
fn every_builtin_loads_with_positive_areas_and_a_camera() {
    for &name in BUILTIN_SCENES {
        let scene = builtin(name);
        assert_eq!(scene.name(), name);
        assert_eq!(scene.source(), &SceneSource::Builtin(name));
        assert_eq!(scene.source().to_string(), format!("builtin:{name}"));
        assert!(!scene.triangles().is_empty());
        assert_eq!(scene.unique_triangle_count(), scene.triangles().len());
        for (i, t) in scene.triangles().iter().enumerate() {
            assert!(
                t.area() > 1e-6,
                "{name}: triangle {i} has area {}",
                t.area()
            );
            for n in t.normals {
                assert!(n.is_normalized(), "{name}: triangle {i} normal {n}");
            }
        }
        assert!(scene.warnings().is_empty());
        assert_eq!(scene.cameras().len(), 1);
        let camera = scene.default_camera();
        assert_eq!(camera.name, "default");
        assert!(scene.bounds().contains(camera.position) || name == "cornell");
        // The default camera sees the scene: the centre pixel hits something nearby.
        let hit = scene
            .closest_hit(&camera.ray(0, 0, 1, 1, Vec2::ZERO), f32::INFINITY)
            .unwrap_or_else(|| panic!("{name}: the camera looks at nothing"));
        assert!(hit.front_face, "{name}: the camera sees a back face");
        // Sizes are realistic: between a shoebox and a building.
        let size = scene.bounds().size().max_element();
        assert!((0.5..50.0).contains(&size), "{name}: {size} m");
        // Light: an emitter or a punctual light.
        let emitters = scene.materials().iter().filter(|m| m.is_emissive()).count();
        assert!(emitters + scene.lights().len() > 0, "{name} is unlit");
        assert!(scene.materials().iter().all(|m| !m.double_sided));
    }
    assert!(matches!(
        Scene::builtin("temple"),
        Err(LoadError::UnknownBuiltin { name }) if name == "temple"
    ));
    assert_eq!(
        Scene::open("builtin:boxes").unwrap().content_hash(),
        builtin("boxes").content_hash()
    );
}

#[test]
fn builtins_other_than_cornell_are_closed_solids() {
    // Every directed edge a→b has a matching b→a: each slab, box, step and pillar is closed
    // and consistently wound.
    for &name in BUILTIN_SCENES.iter().filter(|n| **n != "cornell") {
        let scene = builtin(name);
        let key = |v: Vec3| v.to_array().map(f32::to_bits);
        let mut edges: HashMap<([u32; 3], [u32; 3]), i32> = HashMap::new();
        for t in scene.triangles() {
            if scene.materials()[t.material as usize].is_emissive() {
                continue; // The emissive quads are single panels.
            }
            for i in 0..3 {
                let (a, b) = (key(t.positions[i]), key(t.positions[(i + 1) % 3]));
                *edges.entry((a, b)).or_default() += 1;
                *edges.entry((b, a)).or_default() -= 1;
            }
        }
        let open = edges.values().filter(|&&c| c != 0).count();
        assert_eq!(open, 0, "{name}: {open} unmatched directed edges");
    }
}

#[test]
fn cornell_has_the_measured_layout() {
    let scene = builtin("cornell");
    assert_eq!(scene.triangles().len(), 32);
    let bounds = scene.bounds();
    assert!(
        (bounds.max - Vec3::new(0.556, 0.5488, 0.5592))
            .abs()
            .max_element()
            < 1e-4
    );
    assert_eq!(bounds.min, Vec3::ZERO);
    let camera = scene.default_camera();
    assert!((camera.position - Vec3::new(0.278, 0.273, -0.8)).length() < 1e-6);
    assert!((camera.yfov.to_degrees() - 39.31).abs() < 0.01);
    // Red on the left, green on the right, as seen from the camera.
    let name_at = |x: u32| {
        let hit = scene
            .closest_hit(&camera.ray(x, 50, 100, 100, Vec2::ZERO), f32::INFINITY)
            .unwrap();
        scene.materials()[hit.material as usize].name.clone()
    };
    assert_eq!(name_at(2), "red");
    assert_eq!(name_at(97), "green");
    // The light faces down into the box.
    let up = Ray::new(Vec3::new(0.278, 0.3, 0.28), Vec3::Y);
    let light = scene.closest_hit(&up, f32::INFINITY).unwrap();
    assert!(scene.materials()[light.material as usize].is_emissive());
    assert!(light.front_face && (light.position.y - 0.5483).abs() < 1e-5);
}

#[test]
fn boxes_enclose_the_grid_cell_centres() {
    let scene = builtin("boxes");
    let centres = grid_cell_centers(&scene.bounds(), BOXES_GRID);
    assert_eq!(centres.len(), 32);
    let half_diagonal = 0.5 * BOXES_BOX_SIZE * 3f32.sqrt();
    for centre in centres {
        for direction in directions() {
            let hit = scene
                .closest_hit(&Ray::new(centre, direction), f32::INFINITY)
                .unwrap_or_else(|| panic!("{centre}: ray along {direction} escaped"));
            // The box is hit from inside, within its half diagonal, on its back face.
            assert!(
                hit.t <= half_diagonal + 1e-5,
                "{centre} {direction}: t {}",
                hit.t
            );
            assert!(!hit.front_face, "{centre} {direction}: front face");
            assert_eq!(scene.materials()[hit.material as usize].name, "box");
        }
    }
    // A point between boxes sees only front faces.
    for direction in sphere_directions(200) {
        let hit = scene
            .closest_hit(
                &Ray::new(Vec3::new(0.0, 1.5, 0.0), direction),
                f32::INFINITY,
            )
            .expect("closed room");
        assert!(hit.front_face, "along {direction}");
    }
}

/// Emissive triangles' sample points (a grid of barycentrics on each).
fn light_samples(scene: &Scene) -> Vec<(Vec3, Vec3)> {
    let mut samples = Vec::new();
    for t in scene.triangles() {
        if !scene.materials()[t.material as usize].is_emissive() {
            continue;
        }
        for i in 0..4 {
            for j in 0..(4 - i) {
                let b = Vec2::new(i as f32 + 0.25, j as f32 + 0.25) / 4.0;
                samples.push((t.point(b), t.geometric_normal()));
            }
        }
    }
    samples
}

fn dark_room_points() -> Vec<Vec3> {
    let (min, size) = (LEAK_DARK_ROOM.min, LEAK_DARK_ROOM.size());
    let mut points = Vec::new();
    for x in 0..8 {
        for y in 0..6 {
            for z in 0..8 {
                let f = Vec3::new(x as f32 + 0.5, y as f32 + 0.5, z as f32 + 0.5)
                    / Vec3::new(8.0, 6.0, 8.0);
                points.push(min + f * size);
            }
        }
    }
    points
}

/// How many (light sample, dark-room point) pairs see each other.
fn visible_pairs(scene: &Scene) -> usize {
    let lights = light_samples(scene);
    assert!(lights.len() >= 20);
    for (p, n) in &lights {
        assert!(
            LEAK_LIT_ROOM.contains(*p),
            "light sample {p} outside the lit room"
        );
        assert!(n.y < -0.99, "the light faces down");
    }
    let mut visible = 0;
    for (light, normal) in &lights {
        for &point in &dark_room_points() {
            let to_point = point - *light;
            let ray = Ray::from_surface(*light, *normal, to_point);
            if !scene.occluded(&ray, to_point.length() - 1e-3) {
                visible += 1;
            }
        }
    }
    visible
}

#[test]
fn leak_closed_wall_blocks_every_ray_from_the_light() {
    let scene = builtin("leak-closed");
    assert_eq!(visible_pairs(&scene), 0);
    // The dividing wall is what blocks: a point in the lit room is visible from the light.
    let (light, normal) = light_samples(&scene)[0];
    let target = Vec3::new(-2.0, 0.5, 1.0);
    let ray = Ray::from_surface(light, normal, target - light);
    assert!(!scene.occluded(&ray, (target - light).length() - 1e-3));
}

#[test]
fn leak_gap_lets_light_through_the_gap_only() {
    let scene = builtin("leak-gap");
    let lights = light_samples(&scene);
    let mut through_gap = 0;
    for (light, normal) in &lights {
        for &point in &dark_room_points() {
            let to_point = point - *light;
            let ray = Ray::from_surface(*light, *normal, to_point);
            let t_max = to_point.length() - 1e-3;
            if scene.occluded(&ray, t_max) {
                continue;
            }
            // An open path crosses the dividing wall's plane inside the gap.
            let t = (0.0 - ray.origin.x) / ray.direction.x;
            let crossing = ray.at(t);
            assert!(
                crossing.z >= LEAK_GAP.min.z - 1e-3,
                "{light} → {point} crosses x = 0 at z = {}",
                crossing.z
            );
            through_gap += 1;
        }
    }
    assert!(through_gap > 100, "only {through_gap} open paths");
    // A ray straight through the gap's middle is not occluded; one beside it is.
    let through = Ray::new(Vec3::new(-1.0, 1.5, 1.6), Vec3::X);
    assert!(!scene.occluded(&through, 2.0));
    let beside = Ray::new(Vec3::new(-1.0, 1.5, 1.0), Vec3::X);
    let hit: Hit = scene.closest_hit(&beside, 2.0).expect("the wall");
    assert!((hit.position.x + 0.1).abs() < 1e-5 && hit.front_face);
}

#[test]
fn colonnade_is_sunlit_through_its_openings() {
    let scene = builtin("colonnade");
    assert_eq!(scene.lights().len(), 1);
    let sun = match &scene.lights()[0] {
        probe_scene::Light::Directional { direction, .. } => *direction,
        other => panic!("{other:?}"),
    };
    assert!(sun.y < 0.0 && sun.is_normalized());
    // The skylight throws a sun patch on the floor between the back pillars (crossed by their
    // shadows); the floor under the gallery stays in shade.
    let mut lit = 0;
    for i in 0..40 {
        let floor = Vec3::new(-3.0 + 0.3 * i as f32, 0.0, -3.0);
        let ray = Ray::from_surface(floor, Vec3::Y, -sun);
        if !scene.occluded(&ray, f32::INFINITY) {
            lit += 1;
        }
    }
    assert!(
        (10..40).contains(&lit),
        "{lit} of 40 floor points see the sun"
    );
    let under_gallery = Vec3::new(0.0, 0.0, -5.5);
    let ray = Ray::from_surface(under_gallery, Vec3::Y, -sun);
    assert!(scene.occluded(&ray, f32::INFINITY));
    // Pillars are round and face outward: a ray at a pillar's axis hits it head-on.
    let hit = scene
        .closest_hit(&Ray::new(Vec3::new(3.0, 2.0, 0.0), Vec3::Z), f32::INFINITY)
        .unwrap();
    assert!((hit.position.z - 2.2).abs() < 1e-3 && hit.front_face);
    assert!(hit.shading_normal.z < -0.99);
    // The stairs climb to the gallery: the top step is level with the gallery floor.
    let down = scene
        .closest_hit(
            &Ray::new(Vec3::new(11.0, 6.0, -3.2), -Vec3::Y),
            f32::INFINITY,
        )
        .unwrap();
    assert!((down.position.y - 4.0).abs() < 1e-4);
}

/// A file path goes to the glTF loader when the crate has one (`gltf`, a default feature) and is
/// refused with an error that names the feature when it has not; built-ins open either way.
#[test]
fn open_sends_paths_to_the_loader_or_names_the_missing_feature() {
    assert_eq!(
        Scene::open("builtin:cornell").unwrap().triangles().len(),
        32
    );
    let missing = std::env::temp_dir().join("probe-scene-no-such-scene.gltf");
    let error = Scene::open(missing.to_str().unwrap()).unwrap_err();
    #[cfg(feature = "gltf")]
    assert!(
        matches!(error, LoadError::Read { ref path, .. } if *path == missing),
        "{error}"
    );
    #[cfg(not(feature = "gltf"))]
    {
        assert!(
            matches!(error, LoadError::LoaderDisabled { ref path } if *path == missing),
            "{error}"
        );
        assert!(error.to_string().contains("`gltf` feature"), "{error}");
    }
}
