//! Voxelization, inside/outside classification and the exact distance transform, on built-in
//! scenes and the shared real scenes.

use glam::Vec3;
use probe_place::candidates::{CandidateError, MAX_VOXELS, VoxelGrid, VoxelState};
use probe_scene::builtin::{BOXES_GRID, grid_cell_centers};
use probe_scene::{Material, Scene};

fn shared(relative: &str) -> Scene {
    Scene::load(probe_testdata::scene_path(relative)).expect("shared scene")
}

#[test]
fn two_sided_plane_has_no_interior() {
    let scene = shared(probe_testdata::TWO_SIDED_PLANE);
    let voxels = VoxelGrid::build(&scene, 0.05).unwrap();
    assert_eq!(voxels.count(VoxelState::Inside), 0);
    assert_eq!(voxels.inside_components(), 0);
    assert_eq!(voxels.enclosed_free_components(), 0);
    // The 2 × 2 m quad covers 40 × 40 voxels, one or two layers thick (it lies on voxel
    // faces); everything else is free.
    let surface = voxels.count(VoxelState::Surface);
    assert!((1600..=2 * 42 * 42).contains(&surface), "{surface}");
    assert_eq!(
        voxels.count(VoxelState::Free) + surface,
        voxels.states().len()
    );
    for p in [
        Vec3::new(0.3, 0.2, -0.4),
        Vec3::new(0.3, -0.2, -0.4),
        Vec3::new(0.0, 0.12, 0.0),
    ] {
        assert!(voxels.is_free(p), "{p}");
    }
    assert!(!voxels.is_free(Vec3::new(0.3, 0.0, -0.4)));
}

#[test]
fn godot_room_inside_is_free_walls_are_solid_outside_is_free() {
    let scene = shared(probe_testdata::GODOT_ROOM);
    let voxels = VoxelGrid::build(&scene, 0.0625).unwrap();
    // The room's air, reached from outside through its openings.
    for p in [
        Vec3::new(0.0, 2.5, 0.0),
        Vec3::new(2.0, 1.0, -1.5),
        Vec3::new(-4.5, 4.5, 4.5),
    ] {
        assert_eq!(voxels.state_at(p), VoxelState::Free, "{p}");
    }
    // The 5 cm walls, away from the openings, and the floor and ceiling slabs.
    for p in [
        Vec3::new(4.975, 2.5, 3.5),
        Vec3::new(-4.975, 1.0, -3.5),
        Vec3::new(3.5, 1.0, 4.975),
        Vec3::new(1.0, 0.025, 1.0),
        Vec3::new(1.0, 4.975, 1.0),
    ] {
        assert!(!voxels.is_free(p), "{p}: {:?}", voxels.state_at(p));
    }
    // The spheres stacked in the corners are solid.
    for p in [Vec3::new(3.0, 2.0, -3.0), Vec3::new(-3.0, 3.0, 3.0)] {
        assert_eq!(voxels.state_at(p), VoxelState::Inside, "{p}");
    }
    // Outside the room is free space reached from outside the bounds: both the padding
    // around the bounds and beyond the grid.
    for p in [
        Vec3::new(5.1, 2.5, 3.5),
        Vec3::new(-5.1, 0.5, 0.0),
        Vec3::new(8.0, 2.0, 0.0),
    ] {
        assert!(voxels.is_free(p), "{p}");
    }
    assert_eq!(voxels.enclosed_free_components(), 0);
}

#[test]
fn sponza_atrium_is_free_and_columns_are_solid() {
    let scene = shared(probe_testdata::SPONZA);
    let voxels = VoxelGrid::build(&scene, 0.3).unwrap();
    for p in [
        Vec3::new(0.0, 8.0, -0.6),
        Vec3::new(0.0, 15.0, -0.6),
        Vec3::new(-10.0, 5.0, -0.6),
    ] {
        assert_eq!(voxels.state_at(p), VoxelState::Free, "atrium at {p}");
    }
    // Column axes, found by casting rays along the colonnades (front face in, back face out):
    // the upper gallery's columns at z = −3.85 are 0.77 m wide, the lower ones 1 m.
    for p in [
        Vec3::new(-8.99, 12.0, -3.85),
        Vec3::new(1.14, 12.0, -3.85),
        Vec3::new(6.24, 12.0, -3.85),
        Vec3::new(-14.3, 6.0, -3.85),
        Vec3::new(11.43, 6.0, -3.85),
    ] {
        assert!(
            !voxels.is_free(p),
            "column at {p}: {:?}",
            voxels.state_at(p)
        );
    }
    assert!(voxels.count(VoxelState::Inside) > 1000);
    assert!(voxels.inside_components() > 10);
}

#[test]
fn sealed_room_air_is_free_and_closed_boxes_are_inside() {
    // `boxes` is a room closed by slabs: no flood from outside reaches its air, so the
    // front-face vote must classify it.
    let scene = Scene::open("builtin:boxes").unwrap();
    let voxels = VoxelGrid::build(&scene, 0.05).unwrap();
    assert!(voxels.enclosed_free_components() >= 1);
    assert_eq!(voxels.state_at(Vec3::new(0.0, 1.5, 0.0)), VoxelState::Free);
    assert_eq!(voxels.state_at(Vec3::new(-2.0, 0.3, 2.5)), VoxelState::Free);
    for center in grid_cell_centers(&scene.bounds(), BOXES_GRID) {
        assert_eq!(
            voxels.state_at(center),
            VoxelState::Inside,
            "box at {center}"
        );
    }
    // Inside the 0.2 m wall slabs.
    assert_eq!(
        voxels.state_at(Vec3::new(-4.1, 1.5, 0.0)),
        VoxelState::Inside
    );
    // Outside the room (in the padding) is free.
    assert!(voxels.is_free(Vec3::new(-4.25, 1.5, 0.0)));
}

#[test]
fn grid_geometry_queries() {
    let scene = Scene::open("builtin:cornell").unwrap();
    let voxels = VoxelGrid::build(&scene, 0.1).unwrap();
    // Bounds 0.556 × 0.549 × 0.559: 6 cells each plus 2 of padding on each side.
    assert_eq!(voxels.dims(), [10, 10, 10]);
    assert_eq!(voxels.origin(), scene.bounds().min - Vec3::splat(0.2));
    let cell = [3, 4, 5];
    let center = voxels.center(cell);
    assert_eq!(voxels.cell_at(center), Some(cell));
    assert_eq!(voxels.cell(voxels.index(cell)), cell);
    assert_eq!(voxels.cell_at(Vec3::splat(-1.0)), None);
    assert_eq!(voxels.cell_at(Vec3::NAN), None);
    assert_eq!(voxels.state_at(Vec3::NAN), VoxelState::Inside);
    assert!(voxels.bounds().contains(scene.bounds().min));
    assert!(voxels.bounds().contains(scene.bounds().max));
}

#[test]
fn distance_field_is_exact_against_brute_force() {
    for (scene, size) in [
        ("builtin:cornell", 0.04),
        ("builtin:boxes", 0.4),
        ("builtin:colonnade", 0.8),
    ] {
        let scene = Scene::open(scene).unwrap();
        let voxels = VoxelGrid::build(&scene, size).unwrap();
        let field = voxels.distance_field();
        let [nx, ny, nz] = voxels.dims().map(|d| d as i64);
        let blocked: Vec<[i64; 3]> = (0..voxels.states().len())
            .filter(|&i| voxels.states()[i] != VoxelState::Free)
            .map(|i| voxels.cell(i).map(i64::from))
            .collect();
        assert!(!blocked.is_empty());
        let squared = field.squared_voxel_distances();
        assert_eq!(squared.len() as i64, nx * ny * nz);
        for (i, &d) in squared.iter().enumerate() {
            let c = voxels.cell(i).map(i64::from);
            let brute = blocked
                .iter()
                .map(|b| {
                    let e = [b[0] - c[0], b[1] - c[1], b[2] - c[2]];
                    (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]) as u32
                })
                .min()
                .unwrap();
            assert_eq!(d, brute, "{} voxel {c:?}", scene.name());
        }
        // Metres, and the point query.
        let cell = voxels.cell(squared.len() / 2);
        let metres = (squared[squared.len() / 2] as f32).sqrt() * size;
        assert_eq!(field.distance(cell), metres);
        assert_eq!(field.distance_at(voxels.center(cell)), Some(metres));
        assert_eq!(field.distance_at(Vec3::splat(1e6)), None);
    }
}

#[test]
fn bad_voxel_sizes_and_empty_scenes_are_refused() {
    let scene = Scene::open("builtin:cornell").unwrap();
    for size in [0.0, -0.1, f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        let err = VoxelGrid::build(&scene, size).unwrap_err();
        assert!(
            matches!(err, CandidateError::InvalidVoxelSize { .. }),
            "{size}: {err}"
        );
        assert!(err.to_string().contains("voxel_size"), "{err}");
    }
    for size in [1e-4, f32::MIN_POSITIVE] {
        let err = VoxelGrid::build(&scene, size).unwrap_err();
        match err {
            CandidateError::TooManyVoxels { count, limit, .. } => {
                assert!(count > limit);
                assert_eq!(limit, MAX_VOXELS);
            }
            other => panic!("{size}: {other}"),
        }
    }
    let empty = Scene::from_triangles(
        "nothing",
        Vec::new(),
        vec![Material::diffuse("m", Vec3::ONE)],
        Vec::new(),
        Vec::new(),
    )
    .unwrap();
    let err = VoxelGrid::build(&empty, 0.1).unwrap_err();
    assert!(matches!(err, CandidateError::EmptyScene { ref scene } if scene == "nothing"));
}
