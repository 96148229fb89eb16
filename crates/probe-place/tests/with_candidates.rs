//! The atlas and optimisers with the candidate generators: one "inside geometry" rule, the SDF
//! voxels as free space, and Gibbs / pruning applied to SDF candidates (seed 000 Fig. 3.9).

use glam::Vec3;
use probe_place::{
    atlas::{Atlas, AtlasParams, BackfaceVote, FreeSpace, VoxelFreeSpace, free_space_grid},
    candidates::{SdfParams, inside_geometry, sdf_candidates},
    minimal::prune_redundant,
    optimize::{GibbsParams, gibbs},
};
use probe_scene::Scene;

#[test]
fn backface_vote_agrees_with_inside_geometry() {
    for name in ["boxes", "leak-gap", "colonnade"] {
        let scene = Scene::builtin(name).unwrap();
        let vote = BackfaceVote::new(&scene);
        let bounds = scene.bounds();
        let mut inside = 0;
        // A lattice that passes through walls, boxes, pillars and air.
        for i in 0..9 {
            for j in 0..5 {
                for k in 0..7 {
                    let t = Vec3::new(i as f32 / 8.0, j as f32 / 4.0, k as f32 / 6.0);
                    let p = bounds.min + (bounds.max - bounds.min) * (0.02 + 0.96 * t);
                    let expected = inside_geometry(&scene, p);
                    assert_eq!(vote.inside_geometry(p), expected, "{name} {p}");
                    inside += usize::from(expected);
                }
            }
        }
        assert!(inside > 0, "{name}: the lattice should cross some solid");
    }
}

#[test]
fn sdf_voxels_as_free_space() {
    // `boxes`: sealed room (no flood from outside reaches its air) with 32 closed boxes.
    let scene = Scene::builtin("boxes").unwrap();
    let sdf = sdf_candidates(&scene, &SdfParams::for_scene(&scene)).unwrap();
    let voxels = VoxelFreeSpace::new(&sdf.voxels, scene.bounds());
    let vote = BackfaceVote::new(&scene);
    let spacing = scene.bounds().size().max_element() / 20.0;
    let voxel_pool = free_space_grid(&voxels, spacing);
    let vote_pool = free_space_grid(&vote, spacing);
    // The voxels keep about one voxel of clearance, the vote 0.25 % of the diagonal (3 cm
    // here), so the voxel pool holds more points next to walls; neither holds one inside
    // a wall or a box.
    assert!(voxel_pool.len() >= vote_pool.len());
    assert!(voxel_pool.iter().all(|p| !inside_geometry(&scene, *p)));
    assert!(vote_pool.iter().all(|p| voxels.is_free(*p)));
    // Either pool judges the same surfaces reachable.
    let params = AtlasParams::for_texel_count(&scene, 2000);
    let by_voxels = Atlas::build(&scene, &params, &voxel_pool).unwrap();
    let by_vote = Atlas::build(&scene, &params, &vote_pool).unwrap();
    let (a, b) = (
        by_voxels.samples().len() as f32,
        by_vote.samples().len() as f32,
    );
    assert!((a - b).abs() < 0.03 * b, "{a} vs {b} texels");
    // The SDF candidates all stand in the voxels' free space, and the atlas reports none
    // inside geometry.
    assert!(sdf.probes.positions.iter().all(|p| voxels.is_free(*p)));
    assert!(
        sdf.probes
            .positions
            .iter()
            .all(|p| !vote.inside_geometry(*p))
    );
}

#[test]
fn gibbs_and_pruning_on_sdf_candidates() {
    // Seed 000 Fig. 3.9: SDF candidates in the Cornell box, refined by Gibbs sampling.
    let scene = Scene::builtin("cornell").unwrap();
    let params = SdfParams {
        voxel_size: 0.01,
        ..SdfParams::for_scene(&scene)
    };
    let sdf = sdf_candidates(&scene, &params).unwrap();
    let candidates = sdf.probes.positions.clone();
    assert!(!candidates.is_empty());
    let free = BackfaceVote::new(&scene);
    let pool = free_space_grid(&free, 0.035);
    let atlas = Atlas::build(&scene, &AtlasParams::for_texel_count(&scene, 2500), &pool).unwrap();
    let before = atlas.coverage(&candidates);
    let refined = gibbs(
        &atlas,
        &free,
        &candidates,
        &GibbsParams {
            max_iterations: 20,
            ..GibbsParams::with_step(0.03)
        },
    )
    .unwrap();
    assert_eq!(refined.history[0].coverage, before);
    assert!(refined.coverage >= before);
    assert!(refined.fully_covered || refined.iterations == 20);
    assert!(refined.positions().iter().all(|p| free.is_free(*p)));
    // Pruning the refined set keeps its coverage with no more probes.
    let pruned = prune_redundant(&atlas, &refined.positions(), 1.0).unwrap();
    assert!(pruned.kept.len() <= candidates.len());
    assert_eq!(pruned.coverage_after, pruned.coverage_before);
}
