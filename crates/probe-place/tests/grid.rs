//! Regular grids, DDGI-style classification and relocation, the inside test and probe-set files.

use glam::Vec3;
use probe_place::PlacementMethod;
use probe_place::{
    ProbeSet, ProbeSetError,
    candidates::{
        CandidateError, ClassifyParams, MAX_GRID_DIM, MAX_GRID_PROBES, MAX_RELOCATION_FRACTION,
        RegularGrid, classify_grid, inside_geometry,
    },
};
use probe_scene::builtin::{BOXES_BOX_SIZE, BOXES_GRID, grid_cell_centers};
use probe_scene::{Aabb, Material, Scene, Triangle};

fn boxes() -> Scene {
    Scene::open("builtin:boxes").expect("built-in scene")
}

#[test]
fn grid_counts_and_positions() {
    let bounds = Aabb::new(Vec3::new(-1.0, 0.0, 2.0), Vec3::new(3.0, 2.0, 5.0));
    let grid = RegularGrid::new(bounds, [4, 2, 3]).unwrap();
    assert_eq!(grid.len(), 24);
    assert_eq!(grid.cell_size(), Vec3::new(1.0, 1.0, 1.0));
    let positions = grid.positions();
    assert_eq!(positions.len(), 24);
    assert_eq!(positions[0], Vec3::new(-0.5, 0.5, 2.5));
    assert_eq!(positions[1], Vec3::new(0.5, 0.5, 2.5)); // x fastest
    assert_eq!(positions[4], Vec3::new(-0.5, 1.5, 2.5)); // then y
    assert_eq!(positions[8], Vec3::new(-0.5, 0.5, 3.5)); // then z
    assert_eq!(positions[23], Vec3::new(2.5, 1.5, 4.5));
    assert_eq!(grid.cell_of(23), [3, 1, 2]);
    for p in &positions {
        assert!(bounds.contains(*p));
    }
    // The same convention as the scene crate's (which the `boxes` scene is built on).
    assert_eq!(positions, grid_cell_centers(&bounds, [4, 2, 3]));
}

#[test]
fn grid_spec_over_scene_bounds() {
    let scene = boxes();
    let set = ProbeSet::from_spec("grid:4x2x4", &scene).unwrap();
    assert_eq!(set.len(), 32);
    assert_eq!(
        set.method,
        PlacementMethod::Grid {
            dims: [4, 2, 4],
            bounds: scene.bounds()
        }
    );
    assert_eq!(set.method.name(), "grid");
    let parameters = set.method.parameters();
    assert_eq!(parameters["dims"], serde_json::json!([4, 2, 4]));
    // Parameters are written as the shortest decimals of their f32 values.
    assert_eq!(
        parameters["bounds"],
        serde_json::json!([[-4.2, -0.2, -4.2], [4.2, 3.2, 4.2]])
    );
    assert_eq!(
        set.positions,
        grid_cell_centers(&scene.bounds(), BOXES_GRID)
    );
    let set = ProbeSet::from_spec("grid:1x1x1", &scene).unwrap();
    assert_eq!(set.positions, vec![scene.bounds().center()]);
}

#[test]
fn absurd_grid_dims_are_refused() {
    let scene = boxes();
    for spec in [
        "grid:0x2x4",
        "grid:4x0x4",
        "grid:2000x1x1",
        "grid:1024x1024x2",
    ] {
        let err = ProbeSet::from_spec(spec, &scene).unwrap_err();
        assert!(
            matches!(
                err,
                ProbeSetError::Grid(CandidateError::InvalidGridDims { .. })
            ),
            "{spec}: {err}"
        );
        assert!(err.to_string().contains("1..=1024"), "{err}");
    }
    assert!(RegularGrid::new(scene.bounds(), [MAX_GRID_DIM, 1, 1]).is_ok());
    assert!(RegularGrid::new(scene.bounds(), [1024, 1024, 1]).is_ok());
    assert_eq!(MAX_GRID_PROBES, 1024 * 1024);
    for spec in ["grid:4x2", "grid:axbxc", "grid:4x2x-1", "grid:"] {
        let err = ProbeSet::from_spec(spec, &scene).unwrap_err();
        assert!(
            matches!(err, ProbeSetError::InvalidSpec { .. }),
            "{spec}: {err}"
        );
        assert!(err.to_string().contains("grid:NXxNYxNZ"), "{err}");
    }
    let err = RegularGrid::new(Aabb::EMPTY, [1, 1, 1]).unwrap_err();
    assert!(matches!(err, CandidateError::InvalidBounds { .. }));
    let nan = Aabb::new(Vec3::ZERO, Vec3::new(1.0, f32::NAN, 1.0));
    assert!(RegularGrid::new(nan, [1, 1, 1]).is_err());
}

#[test]
fn empty_scene_is_refused() {
    let scene = Scene::from_triangles(
        "empty",
        Vec::new(),
        vec![Material::diffuse("m", Vec3::ONE)],
        Vec::new(),
        Vec::new(),
    )
    .unwrap();
    let err = RegularGrid::over_scene(&scene, [2, 2, 2]).unwrap_err();
    assert_eq!(
        err,
        CandidateError::EmptyScene {
            scene: "empty".to_owned()
        }
    );
    let err = ProbeSet::from_spec("grid:2x2x2", &scene).unwrap_err();
    assert!(err.to_string().contains("no triangles"), "{err}");
    let grid = RegularGrid::new(Aabb::new(Vec3::ZERO, Vec3::ONE), [2, 2, 2]).unwrap();
    assert!(matches!(
        classify_grid(&scene, &grid, &ClassifyParams::default()),
        Err(CandidateError::EmptyScene { .. })
    ));
}

#[test]
fn bad_classify_params_are_refused() {
    let scene = boxes();
    let grid = RegularGrid::over_scene(&scene, [2, 2, 2]).unwrap();
    let cases = [
        ClassifyParams {
            ray_count: 0,
            ..Default::default()
        },
        ClassifyParams {
            ray_count: 1 << 20,
            ..Default::default()
        },
        ClassifyParams {
            backface_threshold: f32::NAN,
            ..Default::default()
        },
        ClassifyParams {
            backface_threshold: 1.5,
            ..Default::default()
        },
        ClassifyParams {
            min_frontface_fraction: -0.1,
            ..Default::default()
        },
        ClassifyParams {
            iterations: 0,
            ..Default::default()
        },
    ];
    for params in cases {
        let err = classify_grid(&scene, &grid, &params).unwrap_err();
        assert!(
            matches!(err, CandidateError::InvalidParameter { .. }),
            "{err}"
        );
    }
}

/// Whether `p` lies in one of the `boxes` scene's small closed boxes.
fn in_a_box(scene: &Scene, p: Vec3) -> bool {
    let half = 0.5 * BOXES_BOX_SIZE;
    grid_cell_centers(&scene.bounds(), BOXES_GRID)
        .iter()
        .any(|c| (p - *c).abs().max_element() < half)
}

#[test]
fn classification_removes_probes_inside_the_boxes() {
    let scene = boxes();
    let grid = RegularGrid::over_scene(&scene, BOXES_GRID).unwrap();
    // Every cell centre of this grid lies inside a closed box.
    assert!(grid.positions().iter().all(|&p| in_a_box(&scene, p)));
    let classified = classify_grid(
        &scene,
        &grid,
        &ClassifyParams {
            relocate: false,
            ..Default::default()
        },
    )
    .unwrap();
    assert!(classified.positions.is_empty());
    assert_eq!(classified.removed, (0..32).collect::<Vec<_>>());
    assert_eq!(classified.probe_set().method.name(), "grid-classified");

    // A grid whose centres are in the open keeps all its probes where they are.
    let open = RegularGrid::over_scene(&scene, [3, 1, 3]).unwrap();
    let classified = classify_grid(
        &scene,
        &open,
        &ClassifyParams {
            relocate: false,
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(classified.positions, open.positions());
    assert!(classified.removed.is_empty());
}

#[test]
fn relocation_moves_probes_out_of_the_boxes_within_45_percent_of_a_cell() {
    let scene = boxes();
    let grid = RegularGrid::over_scene(&scene, BOXES_GRID).unwrap();
    let relocated = classify_grid(&scene, &grid, &ClassifyParams::default()).unwrap();
    assert_eq!(
        relocated.positions.len(),
        32,
        "removed {:?}",
        relocated.removed
    );
    let centers = grid.positions();
    let cell = grid.cell_size();
    for (&p, &index) in relocated.positions.iter().zip(&relocated.cells) {
        assert!(
            !in_a_box(&scene, p),
            "probe {index} still in its box at {p}"
        );
        assert!(!inside_geometry(&scene, p), "probe {index} at {p}");
        let offset = (p - centers[index]) / cell;
        assert!(
            offset.length() < MAX_RELOCATION_FRACTION,
            "probe {index} moved {offset} cells"
        );
        // It left its box: at least half the box's size from the centre.
        assert!((p - centers[index]).abs().max_element() >= 0.5 * BOXES_BOX_SIZE);
    }
    let set = relocated.probe_set();
    assert!(matches!(
        set.method,
        PlacementMethod::ClassifiedGrid {
            dims: [4, 2, 4],
            removed: 0,
            relocated: true,
            ..
        }
    ));
    assert_eq!(set.method.name(), "grid-relocated");
    assert_eq!(set.len(), 32);
}

#[test]
fn inside_geometry_on_closed_and_open_shapes() {
    let scene = boxes();
    // Box centres are inside; the room's air is not; inside a wall slab is.
    assert!(inside_geometry(&scene, Vec3::new(-3.15, 0.65, -3.15)));
    assert!(!inside_geometry(&scene, Vec3::new(0.0, 1.5, 0.0)));
    assert!(!inside_geometry(&scene, Vec3::new(-2.0, 1.5, 2.0)));
    assert!(inside_geometry(&scene, Vec3::new(-4.1, 1.5, 0.0)));
    assert!(inside_geometry(&scene, Vec3::new(0.0, f32::NAN, 0.0)));
    // A zero-thickness double-sided quad has no inside.
    let mut quad = Material::diffuse("quad", Vec3::ONE);
    quad.double_sided = true;
    let v = Vec3::new;
    let triangles = vec![
        triangle([v(-1.0, 0.0, -1.0), v(1.0, 0.0, 1.0), v(1.0, 0.0, -1.0)]),
        triangle([v(-1.0, 0.0, -1.0), v(-1.0, 0.0, 1.0), v(1.0, 0.0, 1.0)]),
    ];
    let plane = Scene::from_triangles("plane", triangles, vec![quad], vec![], vec![]).unwrap();
    for y in [-0.5, -1e-3, 1e-3, 0.5] {
        assert!(!inside_geometry(&plane, v(0.1, y, 0.2)));
    }
}

fn triangle(positions: [Vec3; 3]) -> Triangle {
    Triangle::flat(positions, 0)
}

#[test]
fn probe_set_files_are_written_atomically_and_read_back() {
    let scene = boxes();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("probes.json");
    let set = RegularGrid::over_scene(&scene, [3, 2, 2])
        .unwrap()
        .probe_set();
    set.save(&path).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(
        text.starts_with("{\n  \"format\": \"probes/1\",\n  \"method\": \"grid\""),
        "{text}"
    );
    // Nothing else was left in the folder (the temporary file was renamed).
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    let back = ProbeSet::load(&path).unwrap();
    assert_eq!(back, set);
    let via_spec = ProbeSet::from_spec(path.to_str().unwrap(), &scene).unwrap();
    assert_eq!(via_spec, set);
    // Saving the same set again gives the same bytes.
    set.save(&path).unwrap();
    assert_eq!(std::fs::read_to_string(&path).unwrap(), text);

    // A failed save (NaN position) leaves the earlier file intact.
    let bad = ProbeSet::new(vec![Vec3::NAN]);
    assert!(bad.save(&path).is_err());
    assert_eq!(std::fs::read_to_string(&path).unwrap(), text);
    // Writing into a missing folder names the file.
    let missing = dir.path().join("no/such/folder/probes.json");
    let err = set.save(&missing).unwrap_err();
    assert!(matches!(err, ProbeSetError::Io { .. }));
    assert!(err.to_string().contains("probes.json"), "{err}");
    let err = ProbeSet::load(dir.path().join("absent.json")).unwrap_err();
    assert!(matches!(err, ProbeSetError::Io { .. }), "{err}");
    std::fs::write(
        dir.path().join("bad.json"),
        "{\"format\": \"probes/1\", \"positions\": [[1, 2, 3],]}",
    )
    .unwrap();
    let err = ProbeSet::load(dir.path().join("bad.json")).unwrap_err();
    assert!(
        err.to_string().contains("bad.json") && err.to_string().contains("line 1"),
        "{err}"
    );
}
