//! The indexing structures on real scenes through the `scene` feature (`probe_scene::Scene`
//! implements `SceneGeometry`): built-ins and the shared Sponza.

mod support;

use glam::Vec3;
use probe_index::{
    EdgeCastOptions, IndexOptions, NO_PROBE, ProbeIndex, ProbeQuery, ProbeSelector, RayHit,
    SceneGeometry, SparseVoxelOctree, SvoOptions, Tetrahedralization,
};
use probe_scene::Scene;
use support::{Rng, Soup, expected_payload, full_leaf, normals_in};

/// A regular grid of probes over the scene bounds shrunk by 10 % on each side.
fn grid_probes(scene: &Scene, dims: [u32; 3]) -> Vec<Vec3> {
    let b = scene.bounds();
    let margin = b.size() * 0.1;
    let lo = b.min + margin;
    let size = b.size() - margin * 2.0;
    let mut out = Vec::new();
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            for x in 0..dims[0] {
                let t = (Vec3::new(x as f32, y as f32, z as f32) + 0.5)
                    / Vec3::new(dims[0] as f32, dims[1] as f32, dims[2] as f32);
                out.push(lo + size * t);
            }
        }
    }
    out
}

fn soup_of(scene: &Scene) -> Soup {
    Soup::new(scene.triangles().iter().map(|t| t.positions).collect())
}

#[test]
fn scene_queries_agree_with_a_brute_force_caster() {
    for name in ["builtin:cornell", "builtin:colonnade"] {
        let scene = Scene::open(name).unwrap();
        let soup = soup_of(&scene);
        assert_eq!(SceneGeometry::triangle_count(&scene), soup.triangle_count());
        assert_eq!(SceneGeometry::triangle(&scene, 3), soup.triangle(3));
        let b = scene.bounds();
        let mut rng = Rng(4);
        let mut hits = 0;
        for _ in 0..300 {
            let from = b.min + b.size() * Vec3::new(rng.f32(), rng.f32(), rng.f32());
            let to = b.min + b.size() * Vec3::new(rng.f32(), rng.f32(), rng.f32());
            let dir = (to - from).normalize();
            let len = (to - from).length();
            let got: Option<RayHit> = SceneGeometry::closest_hit(&scene, from, dir, len);
            let want = soup.closest_hit(from, dir, len);
            match (got, want) {
                (Some(g), Some(w)) => {
                    hits += 1;
                    assert!(
                        (g.distance - w.distance).abs() < 1e-3 * len.max(1.0),
                        "{name}"
                    );
                    assert!(g.normal.dot(w.normal).abs() > 0.999, "{name}");
                }
                (None, None) => {}
                // Grazing hits on a triangle edge may differ between the two casters.
                (g, w) => {
                    let d = g.or(w).unwrap().distance;
                    assert!(d < 1e-3 || (len - d) < 1e-3, "{name}: {g:?} vs {w:?}");
                }
            }
            assert_eq!(
                scene.segment_visible(from, to),
                soup.segment_visible(from, to),
                "{name}: {from} → {to}"
            );
        }
        assert!(hits > 30, "{name}: {hits} hits");
    }
}

#[test]
fn octree_on_builtin_scenes_matches_an_independent_recomputation() {
    for (name, dims, depth) in [
        ("builtin:cornell", [2, 2, 2], 5),
        ("builtin:colonnade", [4, 2, 4], 4),
    ] {
        let scene = Scene::open(name).unwrap();
        let probes = grid_probes(&scene, dims);
        let options = SvoOptions {
            max_depth: depth,
            visibility_samples: 0,
            surface_shell_levels: 0,
            merge_unseen_leaves: false,
            ..SvoOptions::default()
        };
        let svo = SparseVoxelOctree::build(&scene, &probes, &options).unwrap();
        let b = scene.bounds();
        let mut rng = Rng(5);
        for _ in 0..150 {
            let p = b.min + b.size() * Vec3::new(rng.f32(), rng.f32(), rng.f32());
            let leaf = full_leaf(&scene, &svo, depth, p);
            let planes = if leaf.surface {
                normals_in(&scene, leaf.lo, leaf.hi)
            } else {
                Vec::new()
            };
            let want = expected_payload(&scene, &probes, leaf.lo, leaf.hi, &planes, leaf.surface);
            assert_eq!(svo.lookup(p).0, want, "{name} at {p}");
        }
        // The default (merged) octree answers the same wherever some probe is visible, and is
        // smaller.
        let merged = SparseVoxelOctree::build(
            &scene,
            &probes,
            &SvoOptions {
                max_depth: depth,
                visibility_samples: 0,
                surface_shell_levels: 0,
                ..SvoOptions::default()
            },
        )
        .unwrap();
        assert!(merged.memory_bytes() <= svo.memory_bytes());
        for _ in 0..150 {
            let p = b.min + b.size() * Vec3::new(rng.f32(), rng.f32(), rng.f32());
            let strict = svo.lookup(p).0;
            if strict[0] != NO_PROBE {
                assert_eq!(merged.lookup(p).0, strict, "{name} at {p}");
            }
        }
    }
}

#[test]
fn full_index_on_the_cornell_box() {
    let scene = Scene::open("builtin:cornell").unwrap();
    let probes = grid_probes(&scene, [3, 3, 3]);
    let options = IndexOptions {
        edge_casts: Some(EdgeCastOptions::default()),
        neighbour_resolution: 8,
        svo: Some(SvoOptions {
            max_depth: 6,
            ..SvoOptions::default()
        }),
    };
    let (index, report) = ProbeIndex::build(&probes, &scene, &options).unwrap();
    index
        .tetrahedralization
        .as_ref()
        .unwrap()
        .validate()
        .unwrap();
    // The tall and short blocks stand between grid probes: some edges cross them.
    assert!(report.probes_added > 0, "{report}");
    let svo = index.svo.as_ref().unwrap();
    let stats = report.svo.as_ref().unwrap();
    assert!(stats.bytes < stats.full_bytes);
    // From a point on the floor looking up, every selector proposes probes.
    let query = ProbeQuery {
        position: Vec3::new(0.1, 0.01, 0.1),
        direction: Vec3::Y,
        failed_probe: None,
    };
    assert!(!svo.select(&query).is_empty());
    assert!(!index.voronoi_selector().unwrap().select(&query).is_empty());
    // Every probe the octree proposes there is visible from the query point's voxel centre or
    // near it: at least the first is visible from the point itself.
    let first = svo.select(&query).as_slice()[0];
    assert!(scene.segment_visible(query.position, index.probes[first as usize]));
}

#[test]
fn sponza_octree_and_tetrahedralization() {
    let path = probe_testdata::scene_path(probe_testdata::SPONZA);
    let scene = Scene::load(&path).unwrap();
    assert_eq!(scene.triangles().len(), 262_087);
    let probes = grid_probes(&scene, [6, 3, 3]);
    let t = Tetrahedralization::build(&probes).unwrap();
    t.validate().unwrap();
    let svo = SparseVoxelOctree::build(
        &scene,
        &probes,
        &SvoOptions {
            max_depth: 5,
            ..SvoOptions::default()
        },
    )
    .unwrap();
    let s = svo.stats();
    assert!(s.surface_leaves > 1000 && s.bytes < s.full_bytes, "{s:?}");
    // In the atrium (floor y ≈ 3.98), the octree proposes probes.
    let (leaf, _) = svo.lookup(Vec3::new(0.0, 5.0, 0.0));
    assert_ne!(leaf[0], NO_PROBE);
}
