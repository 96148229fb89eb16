//! Minimal probe sets: pruning keeps coverage and never grows the set; greedy cover reaches
//! targets with few probes and respects budgets; bad targets and budgets are errors.

use glam::Vec3;
use probe_place::{
    atlas::{Atlas, AtlasParams, BackfaceVote, FreeSpace, free_space_grid},
    minimal::{CoverParams, MinimalSetError, minimal_cover, prune_redundant},
    optimize::GibbsParams,
    viewers::view_samples_per_view,
};
use probe_scene::Scene;
use probe_scene::builtin::grid_cell_centers;

mod support;

fn setup(name: &str, texels: usize, cells: f32) -> (Scene, AtlasParams, Vec<Vec3>) {
    let scene = Scene::builtin(name).unwrap();
    let pool = free_space_grid(
        &BackfaceVote::new(&scene),
        scene.bounds().size().max_element() / cells,
    );
    let params = AtlasParams::for_texel_count(&scene, texels);
    (scene, params, pool)
}

#[test]
fn pruning_a_dense_grid_keeps_full_coverage_with_far_fewer_probes() {
    let (scene, params, pool) = setup("colonnade", 2000, 14.0);
    let atlas = Atlas::build(&scene, &params, &pool).unwrap();
    assert_eq!(atlas.coverage(&pool), 1.0);
    let pruned = prune_redundant(&atlas, &pool, 1.0).unwrap();
    assert_eq!(pruned.coverage_before, 1.0);
    assert_eq!(pruned.coverage_after, 1.0);
    assert!(
        pruned.kept.len() < pool.len() / 4,
        "{} of {}",
        pruned.kept.len(),
        pool.len()
    );
    let kept: Vec<Vec3> = pruned.kept.iter().map(|&i| pool[i]).collect();
    assert_eq!(atlas.coverage(&kept), 1.0);
    // Irredundant: dropping any one kept probe loses coverage.
    for skip in 0..kept.len() {
        let fewer: Vec<Vec3> = kept
            .iter()
            .enumerate()
            .filter(|(i, _)| *i != skip)
            .map(|(_, p)| *p)
            .collect();
        assert!(atlas.coverage(&fewer) < 1.0, "probe {skip} was redundant");
    }
    // Pruning never grows a set and keeps partial coverage as it was.
    let some = &pool[..pool.len() / 3];
    let partial = prune_redundant(&atlas, some, 1.0).unwrap();
    assert!(partial.kept.len() <= some.len());
    assert_eq!(partial.coverage_after, partial.coverage_before);
    // A lower floor lets it drop more.
    let loose = prune_redundant(&atlas, &pool, 0.9).unwrap();
    assert!(loose.kept.len() < pruned.kept.len());
    assert!(loose.coverage_after >= 0.9);
}

#[test]
fn greedy_cover_reaches_full_coverage_and_beats_the_grid_count() {
    let (scene, params, pool) = setup("colonnade", 2000, 14.0);
    let atlas = Atlas::build(&scene, &params, &pool).unwrap();
    let free = BackfaceVote::new(&scene);
    let set = minimal_cover(&atlas, &free, &pool, &CoverParams::full_coverage()).unwrap();
    assert!(set.reached_target);
    assert_eq!(set.coverage, 1.0);
    let probes = set.positions();
    assert_eq!(atlas.coverage(&probes), 1.0);
    assert!(probes.iter().all(|p| free.is_free(*p)));
    // The curve rises monotonically to 1.
    assert!(set.coverage_by_count.windows(2).all(|w| w[0] < w[1]));
    assert_eq!(*set.coverage_by_count.last().unwrap(), 1.0);
    assert_eq!(set.coverage_by_count.len(), set.chosen.len() + set.pruned);
    // A regular grid of the same count over the bounds falls short.
    let n = probes.len() as u32;
    for dims in [[n, 1, 1], [n.div_ceil(2), 1, 2], [n.div_ceil(4), 2, 2]] {
        let grid = grid_cell_centers(&scene.bounds(), dims);
        assert!(grid.len() >= probes.len());
        let coverage = atlas.coverage(&grid);
        assert!(coverage < 1.0, "grid {dims:?}: {coverage}");
    }
    // Same inputs, same set.
    let again = minimal_cover(&atlas, &free, &pool, &CoverParams::full_coverage()).unwrap();
    assert_eq!(again, set);
}

#[test]
fn budgets_are_respected_and_targets_met() {
    let (scene, params, pool) = setup("cornell", 2500, 14.0);
    let atlas = Atlas::build(&scene, &params, &pool).unwrap();
    let free = BackfaceVote::new(&scene);
    let full = minimal_cover(&atlas, &free, &pool, &CoverParams::full_coverage()).unwrap();
    assert!(full.reached_target && full.positions.len() >= 2);
    for budget in 1..full.positions.len() {
        let set = minimal_cover(
            &atlas,
            &free,
            &pool,
            &CoverParams {
                budget: Some(budget),
                ..CoverParams::full_coverage()
            },
        )
        .unwrap();
        assert!(set.positions.len() <= budget);
        assert!(!set.reached_target);
        // The greedy prefix: its coverage is the curve's value at this count.
        assert_eq!(set.coverage, full.coverage_by_count[budget - 1]);
    }
    // A 90 % target needs no more probes than full coverage, and reaches 90 %.
    let ninety = minimal_cover(
        &atlas,
        &free,
        &pool,
        &CoverParams {
            target_coverage: 0.9,
            ..CoverParams::full_coverage()
        },
    )
    .unwrap();
    assert!(ninety.reached_target && ninety.coverage >= 0.9);
    assert!(ninety.positions.len() < full.positions.len());
    // Refinement under a tight budget moves the probes and never loses coverage.
    let refined = minimal_cover(
        &atlas,
        &free,
        &pool,
        &CoverParams {
            budget: Some(2),
            refine: Some(GibbsParams {
                max_iterations: 10,
                ..GibbsParams::with_step(0.03)
            }),
            ..CoverParams::full_coverage()
        },
    )
    .unwrap();
    let unrefined_coverage = full.coverage_by_count[1];
    assert!(refined.positions.len() <= 2);
    assert!(refined.coverage >= unrefined_coverage);
    let refinement = refined.refinement.as_ref().expect("refinement ran");
    assert!(refinement.history.len() > 1);
    assert!(refined.positions().iter().all(|p| free.is_free(*p)));
}

#[test]
fn bad_budgets_targets_and_pools_are_errors() {
    let (scene, params, pool) = setup("cornell", 800, 10.0);
    let atlas = Atlas::build(&scene, &params, &pool).unwrap();
    let free = BackfaceVote::new(&scene);
    let full = CoverParams::full_coverage();
    assert!(matches!(
        minimal_cover(
            &atlas,
            &free,
            &pool,
            &CoverParams {
                budget: Some(0),
                ..full
            }
        ),
        Err(MinimalSetError::ZeroBudget)
    ));
    for target in [0.0f32, -0.5, 1.01, f32::NAN] {
        let err = minimal_cover(
            &atlas,
            &free,
            &pool,
            &CoverParams {
                target_coverage: target,
                ..full
            },
        )
        .unwrap_err();
        assert!(
            matches!(err, MinimalSetError::CoverageOutOfRange { .. }),
            "{target}: {err}"
        );
        assert!(matches!(
            prune_redundant(&atlas, &pool, target),
            Err(MinimalSetError::CoverageOutOfRange { .. })
        ));
    }
    assert!(matches!(
        minimal_cover(&atlas, &free, &[], &full),
        Err(MinimalSetError::NoCandidates { given: 0 })
    ));
    // Candidates all outside the bounds.
    let outside = [Vec3::splat(10.0), Vec3::splat(-10.0)];
    assert!(matches!(
        minimal_cover(&atlas, &free, &outside, &full),
        Err(MinimalSetError::NoCandidates { given: 2 })
    ));
    assert!(matches!(
        prune_redundant(&atlas, &[Vec3::ONE, Vec3::new(f32::NAN, 0.0, 0.0)], 1.0),
        Err(MinimalSetError::NonFiniteCandidate { index: 1, .. })
    ));
    let bad_refine = CoverParams {
        budget: Some(1),
        refine: Some(GibbsParams::with_step(-1.0)),
        ..full
    };
    assert!(matches!(
        minimal_cover(&atlas, &free, &pool, &bad_refine),
        Err(MinimalSetError::Refinement(_))
    ));
}

#[test]
fn a_target_held_by_each_view_is_met_in_every_view() {
    // The colonnade seen from four corners: a target over all views together leaves one view
    // far below it; held by each view, it is met in all four.
    let (scene, params, pool) = setup("colonnade", 2000, 14.0);
    let cameras = support::corner_cameras(&scene);
    let atlas = Atlas::from_view_samples(
        &scene,
        &params,
        view_samples_per_view(&scene, &cameras, 300),
        &pool,
    )
    .unwrap();
    let labels = atlas.sample_views();
    assert_eq!(labels.len(), atlas.samples().len());
    let per_view = |probes: &[Vec3]| atlas.view_coverages(probes);
    assert_eq!(per_view(&[]), vec![0.0; cameras.len()]);
    let free = BackfaceVote::new(&scene);
    let target = |each_view| CoverParams {
        target_coverage: 0.8,
        each_view,
        ..CoverParams::full_coverage()
    };
    let pooled = minimal_cover(&atlas, &free, &pool, &target(false)).unwrap();
    let each = minimal_cover(&atlas, &free, &pool, &target(true)).unwrap();
    assert!(pooled.reached_target && pooled.coverage >= 0.8);
    // Over all views together one view stays at 72 %.
    let pooled_views = per_view(&pooled.positions());
    assert!(
        pooled_views.iter().any(|c| *c < 0.75),
        "each view's coverage {pooled_views:?}"
    );
    assert!(each.reached_target, "{each:?}");
    let coverages = per_view(&each.positions());
    assert!(
        coverages.iter().all(|c| *c >= 0.8 - 1e-9),
        "each view's coverage {coverages:?}"
    );
    assert!(each.positions.len() >= pooled.positions.len());
    // Pruned to what each view needs: dropping any probe loses some view's target.
    for skip in 0..each.positions.len() {
        let mut fewer = each.positions();
        fewer.remove(skip);
        assert!(
            per_view(&fewer).iter().any(|c| *c < 0.8 - 1e-9),
            "probe {skip} was not needed"
        );
    }
}
