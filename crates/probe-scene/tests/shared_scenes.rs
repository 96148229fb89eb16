//! The shared test scenes load with the figures in `../shared/scenes/README.md`, and the
//! failure cases fail (or load) the way that README says.

use glam::{Vec2, Vec3};
use probe_scene::{AlphaMode, LoadError, LoadWarning, Ray, Scene};
use probe_testdata::{
    BREAKFAST_ROOM, CORNELL_BOX, GODOT_ROOM, GPU_INSTANCING, INVALID_INDEX_OUT_OF_RANGE,
    INVALID_INFINITES, PRIMITIVE_MODES_DIR, SPONZA, SPONZA_AS_PUBLISHED, TWO_SIDED_PLANE,
    scene_path,
};
use std::sync::OnceLock;

fn load(relative: &str) -> Scene {
    let path = scene_path(relative);
    Scene::load(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// Sponza is loaded once per test binary.
fn sponza() -> &'static Scene {
    static SPONZA_SCENE: OnceLock<Scene> = OnceLock::new();
    SPONZA_SCENE.get_or_init(|| load(SPONZA))
}

fn assert_bounds(scene: &Scene, min: [f32; 3], max: [f32; 3]) {
    let bounds = scene.bounds();
    let close = |a: Vec3, b: [f32; 3]| (a - Vec3::from(b)).abs().max_element() <= 0.01;
    assert!(
        close(bounds.min, min) && close(bounds.max, max),
        "{}: bounds {:?}..{:?}, expected {min:?}..{max:?}",
        scene.name(),
        bounds.min,
        bounds.max
    );
}

#[test]
fn cornell_box_counts_bounds_and_emitter() {
    let scene = load(CORNELL_BOX);
    assert_eq!(scene.triangles().len(), 32);
    assert_eq!(scene.unique_triangle_count(), 32);
    assert_bounds(&scene, [-1.02, 0.0, -1.04], [1.0, 1.99, 0.99]);
    assert!(scene.lights().is_empty());
    let emitters: Vec<_> = scene
        .materials()
        .iter()
        .filter(|m| m.is_emissive())
        .collect();
    assert_eq!(emitters.len(), 1);
    assert_eq!(emitters[0].name, "Light");
    assert_eq!(emitters[0].emissive, Vec3::ONE);
    assert!(scene.materials().iter().all(|m| m.double_sided));
    // No camera in the file: the documented framing pose looks along −Z at the centre.
    let camera = scene.default_camera();
    assert_eq!(camera.name, "default");
    assert!((camera.forward - Vec3::NEG_Z).length() < 1e-6);
    assert!(
        scene
            .bounds()
            .contains(camera.position - Vec3::Z * (camera.position.z - 0.0))
    );
    // The node turns the Z-up data to Y-up: the floor's normals point up.
    let hit = scene
        .closest_hit(&Ray::new(Vec3::new(0.0, 1.0, 0.0), -Vec3::Y), f32::INFINITY)
        .expect("floor below the centre");
    assert!(hit.position.y.abs() < 0.01 && hit.shading_normal.y > 0.99);
}

#[test]
fn cornell_box_hash_is_stable_across_runs() {
    // The hash covers geometry, materials and lights in a fixed byte order; it changes only if
    // the loader's output for this file changes.
    let scene = load(CORNELL_BOX);
    let hex: String = scene
        .content_hash()
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect();
    assert_eq!(
        hex,
        "dd7b0382ed8f7e6273e06c010d43dd94d46e53a9cdf9fc9e25a680b06c4f9b7d"
    );
    assert_eq!(load(CORNELL_BOX).content_hash(), scene.content_hash());
    assert_ne!(load(TWO_SIDED_PLANE).content_hash(), scene.content_hash());
}

#[test]
fn sponza_counts_bounds_cameras_and_no_lights() {
    let scene = sponza();
    assert_eq!(scene.triangles().len(), 262_087);
    assert_eq!(scene.unique_triangle_count(), 115_580);
    assert_bounds(scene, [-26.84, 2.28, -16.48], [24.18, 23.62, 14.90]);
    assert!(scene.lights().is_empty());
    let names: Vec<&str> = scene.cameras().iter().map(|c| c.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "CameraMain",
            "CameraAlternate",
            "CameraBalcony",
            "CameraAlcove"
        ]
    );
    assert_eq!(scene.default_camera().name, "CameraMain");
    let main = scene.camera("CameraMain").unwrap();
    assert!((main.position - Vec3::new(15.4646, 4.3879, 0.4524)).length() < 1e-3);
    assert!((main.yfov - std::f32::consts::FRAC_PI_4).abs() < 1e-6);
    assert_eq!(main.aspect, Some(16.0 / 9.0));
    // The camera looks into the atrium (towards −X) and sees geometry through every pixel of
    // a coarse image (Sponza is closed around the camera except for the open roof).
    assert!(main.forward.x < -0.9);
    let hits = (0..8)
        .flat_map(|y| (0..8).map(move |x| (x, y)))
        .filter(|&(x, y)| {
            scene
                .closest_hit(&main.ray(x, y, 8, 8, Vec2::ZERO), f32::INFINITY)
                .is_some()
        })
        .count();
    assert!(hits >= 56, "{hits} of 64 primary rays hit");
    // Atrium floor at y ≈ 3.98 straight below the main camera.
    let floor = scene
        .closest_hit(&Ray::new(main.position, -Vec3::Y), f32::INFINITY)
        .unwrap();
    assert!(
        (floor.position.y - 3.98).abs() < 0.05,
        "{}",
        floor.position.y
    );
    assert!(scene.warnings().is_empty(), "{:?}", scene.warnings());
}

#[test]
fn sponza_alpha_masks_cut_out_leaves() {
    let scene = sponza();
    let masked: Vec<u32> = scene
        .materials()
        .iter()
        .enumerate()
        .filter(|(_, m)| {
            matches!(
                m.alpha,
                AlphaMode::Mask {
                    texture: Some(_),
                    ..
                }
            )
        })
        .map(|(i, _)| i as u32)
        .collect();
    assert_eq!(masked.len(), 3, "plants, chains and pot plants");
    // For masked triangles, aim a ray at points whose texel is transparent and at points whose
    // texel is opaque, from 1 mm in front of the surface.
    let (mut cut, mut kept) = (0, 0);
    for (index, triangle) in scene.triangles().iter().enumerate() {
        if !masked.contains(&triangle.material) || triangle.area() < 1e-4 {
            continue;
        }
        let alpha = &scene.materials()[triangle.material as usize].alpha;
        let normal = triangle.geometric_normal();
        for b in [
            Vec2::new(0.2, 0.2),
            Vec2::new(0.6, 0.2),
            Vec2::new(0.2, 0.6),
        ] {
            let target = triangle.point(b);
            let ray = Ray::new(target + normal * 1e-3, -normal);
            let hit = scene.closest_hit(&ray, 2e-3);
            let hit_this = hit.is_some_and(|h| h.triangle as usize == index);
            if alpha.passes(triangle.uv(b)) {
                // Another (coplanar or crossing) leaf may be hit first, but something is.
                assert!(hit.is_some(), "opaque texel of triangle {index} not hit");
                kept += 1;
            } else {
                assert!(!hit_this, "transparent texel of triangle {index} was hit");
                cut += 1;
            }
        }
        if cut >= 200 && kept >= 200 {
            break;
        }
    }
    assert!(cut >= 200 && kept >= 200, "cut {cut}, kept {kept}");
}

#[test]
fn sponza_as_published_is_refused_naming_the_extension() {
    let error = Scene::load(scene_path(SPONZA_AS_PUBLISHED)).unwrap_err();
    match &error {
        LoadError::UnsupportedExtension { extension, path } => {
            assert_eq!(extension, "AMD_split_roughnessMetallic");
            assert!(path.ends_with("Sponza.gltf"));
        }
        other => panic!("unexpected error {other:?}"),
    }
    assert!(error.to_string().contains("AMD_split_roughnessMetallic"));
}

#[test]
fn breakfast_room_counts_bounds_cameras_and_warnings() {
    let scene = load(BREAKFAST_ROOM);
    assert_eq!(scene.triangles().len(), 262_687);
    assert_eq!(scene.unique_triangle_count(), 82_291);
    assert_bounds(&scene, [-1.78, 0.0, -2.40], [1.94, 3.0, 2.25]);
    assert!(scene.lights().is_empty());
    let names: Vec<&str> = scene.cameras().iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, ["CameraMain", "CameraTableTop", "CameraTopDown"]);
    // The camera nodes are scaled by 0.5: directions stay unit length.
    for camera in scene.cameras() {
        assert!(camera.forward.is_normalized() && camera.up.is_normalized());
    }
    for extension in ["MSFT_texture_dds", "KHR_materials_specular"] {
        assert!(
            scene.warnings().contains(&LoadWarning::IgnoredExtension {
                extension: extension.to_owned()
            }),
            "{:?}",
            scene.warnings()
        );
    }
    // Textured materials get the texture's mean colour (the JPG/PNG, not the DDS).
    let tiles = scene
        .materials()
        .iter()
        .find(|m| m.name == "FloorTiles")
        .unwrap();
    assert!(tiles.base_color.min_element() > 0.2 && tiles.base_color.max_element() < 0.9);
    assert_ne!(tiles.base_color, Vec3::ONE);
}

#[test]
fn godot_room_counts_and_bounds() {
    let scene = load(GODOT_ROOM);
    assert_eq!(scene.triangles().len(), 63_720);
    assert_eq!(scene.unique_triangle_count(), 63_720);
    assert_bounds(&scene, [-5.0, 0.0, -5.0], [5.0, 5.0, 5.0]);
    // 5 cm walls; above the doorways (which reach y ≈ 3.32) every axis ray from the middle
    // hits an inner face from the front.
    let centre = Vec3::new(0.5, 4.0, 0.5);
    for direction in [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z] {
        let hit = scene
            .closest_hit(&Ray::new(centre, direction), f32::INFINITY)
            .unwrap_or_else(|| panic!("ray along {direction} escaped the room"));
        assert!(hit.front_face);
        let wall = hit.position.dot(direction);
        assert!(
            (wall - 4.95).abs() < 1e-3 || (wall + 0.05).abs() < 1e-3,
            "{direction}: {wall}"
        );
    }
    // Each wall has a doorway (|offset| < 1.24 m, up to y ≈ 3.32): a ray through it escapes.
    for direction in [Vec3::X, -Vec3::X, Vec3::Z, -Vec3::Z] {
        let ray = Ray::new(Vec3::new(0.0, 1.5, 0.0), direction);
        assert!(scene.closest_hit(&ray, f32::INFINITY).is_none());
    }
}

#[test]
fn two_sided_plane_loads() {
    let scene = load(TWO_SIDED_PLANE);
    assert_eq!(scene.triangles().len(), 2);
    assert!(scene.materials()[0].double_sided);
    assert_bounds(&scene, [-1.0, 0.0, -1.0], [1.0, 0.0, 1.0]);
    // Both faces are hit.
    for (origin, direction, front) in [(Vec3::Y, -Vec3::Y, true), (-Vec3::Y, Vec3::Y, false)] {
        let hit = scene
            .closest_hit(&Ray::new(origin * 0.5, direction), f32::INFINITY)
            .unwrap();
        assert_eq!(hit.front_face, front);
        assert!((hit.t - 0.5).abs() < 1e-6);
    }
}

#[test]
fn primitive_modes() {
    /// The mode skipped and how many points or segments it held.
    type Skipped = Option<(&'static str, usize)>;
    // (file number, triangles, skipped)
    let expected: [(u32, usize, Skipped); 16] = [
        (0, 0, Some(("POINTS", 1024))),
        (1, 0, Some(("LINES", 4))),
        (2, 0, Some(("LINE_LOOP", 4))),
        (3, 0, Some(("LINE_STRIP", 4))),
        (4, 2, None),
        (5, 2, None),
        (6, 2, None),
        (7, 0, Some(("POINTS", 1024))),
        (8, 0, Some(("LINES", 4))),
        (9, 0, Some(("LINE_LOOP", 4))),
        (10, 0, Some(("LINE_STRIP", 4))),
        (11, 2, None),
        (12, 2, None),
        (13, 2, None),
        (14, 2, None),
        (15, 2, None),
    ];
    for (number, triangles, skipped) in expected {
        let file = format!("{PRIMITIVE_MODES_DIR}/Mesh_PrimitiveMode_{number:02}.gltf");
        let scene = load(&file);
        assert_eq!(scene.triangles().len(), triangles, "{file}");
        let skip_warnings: Vec<_> = scene
            .warnings()
            .iter()
            .filter_map(|w| match w {
                LoadWarning::SkippedPrimitives {
                    mode,
                    primitives,
                    elements,
                } => Some((*mode, *primitives, *elements)),
                _ => None,
            })
            .collect();
        match skipped {
            Some((mode, elements)) => {
                assert_eq!(skip_warnings, [(mode, 1, elements)], "{file}");
                assert!(scene.bounds().is_empty());
                assert!(
                    scene
                        .closest_hit(&Ray::new(Vec3::Z, -Vec3::Z), f32::INFINITY)
                        .is_none()
                );
            }
            None => {
                assert!(skip_warnings.is_empty(), "{file}");
                // Every triangle file is the same 1×1 quad in the z = 0 plane facing +Z.
                assert_bounds(&scene, [-0.5, -0.5, 0.0], [0.5, 0.5, 0.0]);
                let area: f32 = scene.triangles().iter().map(|t| t.area()).sum();
                assert!((area - 1.0).abs() < 1e-5, "{file}: area {area}");
                for t in scene.triangles() {
                    assert!(t.geometric_normal().z > 0.99, "{file}: {t:?}");
                }
                let hit = scene
                    .closest_hit(&Ray::new(Vec3::new(0.1, 0.2, 1.0), -Vec3::Z), f32::INFINITY)
                    .unwrap();
                assert!(hit.front_face && (hit.t - 1.0).abs() < 1e-6);
            }
        }
    }
}

#[test]
fn gpu_instancing_is_expanded() {
    let scene = load(GPU_INSTANCING);
    assert_eq!(scene.triangles().len(), 1_500);
    assert_eq!(scene.unique_triangle_count(), 12);
    assert_bounds(&scene, [-1.67, -1.67, -1.67], [12.73, 12.73, 12.73]);
    // Every instance is real geometry: 1 mm in front of each instance's first face, a ray
    // back at the face hits that instance's cube.
    for instance in 0..125 {
        let triangle = &scene.triangles()[instance * 12];
        let centre = triangle.point(Vec2::splat(1.0 / 3.0));
        let normal = triangle.geometric_normal();
        let hit = scene
            .closest_hit(&Ray::new(centre + normal * 1e-3, -normal), 1.0)
            .unwrap_or_else(|| panic!("instance {instance} missed"));
        assert!(
            (hit.t - 1e-3).abs() < 1e-4,
            "instance {instance}: t {}",
            hit.t
        );
        assert_eq!(hit.triangle as usize / 12, instance);
        assert!(hit.front_face);
    }
}

#[test]
fn non_finite_positions_are_refused_naming_the_accessor() {
    let error = Scene::load(scene_path(INVALID_INFINITES)).unwrap_err();
    match &error {
        LoadError::NonFinitePosition {
            accessor, element, ..
        } => {
            assert_eq!(*accessor, 2);
            assert_eq!(*element, 0);
        }
        other => panic!("unexpected error {other:?}"),
    }
    let message = error.to_string();
    assert!(message.contains("accessor 2") && message.contains("BoxWithInfinites.glb"));
}

#[test]
fn out_of_range_indices_are_refused_naming_the_primitive() {
    let error = Scene::load(scene_path(INVALID_INDEX_OUT_OF_RANGE)).unwrap_err();
    match &error {
        LoadError::IndexOutOfRange {
            mesh,
            mesh_name,
            primitive,
            index,
            vertex_count,
            ..
        } => {
            assert_eq!((*mesh, mesh_name.as_str(), *primitive), (0, "Mesh", 0));
            assert_eq!((*index, *vertex_count), (255, 24));
        }
        other => panic!("unexpected error {other:?}"),
    }
    assert!(error.to_string().contains("mesh 0 (\"Mesh\") primitive 0"));
}
