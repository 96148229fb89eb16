//! `probe_place::pipeline`: the end-to-end placement (method, budget or coverage cut,
//! optimiser, report) that `probes place` and probe-eval run.

use glam::Vec3;
use probe_place::PlacementMethod;
use probe_place::pipeline::{Method, Optimizer, PlaceError, PlaceOptions, fill_to_budget, place};
use probe_place::{
    atlas::{Atlas, AtlasParams, BackfaceVote, free_space_grid},
    irradiance::PointLightOracle,
};
use probe_scene::Scene;

mod support;

fn options(method: Method) -> PlaceOptions {
    PlaceOptions {
        atlas_texels: 1500,
        ..PlaceOptions::new(method)
    }
}

#[test]
fn a_grid_is_placed_whole_and_named() {
    let scene = Scene::builtin("cornell").unwrap();
    let placed = place(&scene, &options(Method::Grid([3, 2, 2])), None).unwrap();
    assert_eq!(placed.probes.len(), 12);
    assert_eq!(placed.full_grid, Some([3, 2, 2]));
    assert_eq!(placed.probes.method.name(), "grid-3x2x2");
    assert_eq!(placed.report.method, placed.probes.method);
    assert!(matches!(
        &placed.probes.method,
        PlacementMethod::Placed(run) if run.method == Method::Grid([3, 2, 2]) && run.optimizer.is_none()
    ));
    assert!(placed.history.is_none());
    assert!(placed.report.coverage > 0.0 && placed.report.coverage <= 1.0);
}

#[test]
fn a_budget_cuts_the_set_and_an_optimiser_records_its_history() {
    let scene = Scene::builtin("cornell").unwrap();
    let placed = place(
        &scene,
        &PlaceOptions {
            budget: Some(3),
            optimize: Some(Optimizer::Gibbs),
            iterations: 2,
            ..options(Method::Grid([3, 3, 3]))
        },
        None,
    )
    .unwrap();
    assert!(placed.probes.len() <= 3);
    assert_eq!(
        placed.full_grid, None,
        "a cut grid is no longer a full grid"
    );
    assert_eq!(placed.probes.method.name(), "grid-3x3x3+gibbs@3");
    assert!(placed.history.is_some_and(|h| !h.is_empty()));
}

#[test]
fn the_same_seed_gives_the_same_probes() {
    let scene = Scene::builtin("boxes").unwrap();
    let run = || {
        place(
            &scene,
            &PlaceOptions {
                seed: 5,
                ..options(Method::Medial)
            },
            None,
        )
        .unwrap()
        .probes
        .positions
    };
    assert_eq!(run(), run());
}

#[test]
fn irradiance_methods_need_an_oracle_and_run_with_one() {
    let scene = Scene::builtin("cornell").unwrap();
    let error = place(&scene, &options(Method::SpawnMerge), None).unwrap_err();
    assert!(
        matches!(&error, PlaceError::NoOracle { method } if method == "spawn-merge"),
        "{error}"
    );
    assert!(Method::SpawnMerge.needs_lighting() && !Method::Sdf.needs_lighting());
    let centre = scene.bounds().center();
    let light = PointLightOracle::new(&scene, centre, Vec3::splat(5.0));
    let placed = place(&scene, &options(Method::SpawnMerge), Some(&light)).unwrap();
    assert!(!placed.probes.is_empty());
    assert!(placed.probes.method.parameters().contains_key("lit"));
    assert!(matches!(
        &placed.probes.method,
        PlacementMethod::Placed(run) if run.lit.is_some() && run.spacing.is_some()
    ));
}

#[test]
fn bad_parameters_are_refused_by_name() {
    let scene = Scene::builtin("cornell").unwrap();
    for (options, parameter) in [
        (
            PlaceOptions {
                coverage: 1.5,
                ..options(Method::Sdf)
            },
            "coverage",
        ),
        (
            PlaceOptions {
                budget: Some(0),
                ..options(Method::Sdf)
            },
            "budget",
        ),
        (
            PlaceOptions {
                step: Some(-1.0),
                ..options(Method::Sdf)
            },
            "step",
        ),
    ] {
        match place(&scene, &options, None) {
            Err(PlaceError::Invalid { parameter: p, .. }) => assert_eq!(p, parameter),
            other => panic!("{parameter}: expected a refusal, got {other:?}"),
        }
    }
}

/// A free-space grid of candidates 0.1 apart and an atlas of about 800 texels reachable from it.
fn pool_and_atlas(scene: &Scene) -> (Vec<Vec3>, Atlas<'_>) {
    let free = BackfaceVote::new(scene);
    let pool = free_space_grid(&free, 0.1);
    let atlas = Atlas::build(scene, &AtlasParams::for_texel_count(scene, 800), &pool).unwrap();
    (pool, atlas)
}

#[test]
fn fill_to_budget_adds_only_probes_that_add_something() {
    let scene = Scene::builtin("cornell").unwrap();
    let (pool, atlas) = pool_and_atlas(&scene);
    let start = vec![pool[0]];
    let filled = fill_to_budget(&atlas, &pool, start.clone(), 4);
    assert_eq!(filled.len(), 4);
    assert_eq!(filled[0], pool[0], "the chosen probes come first");
    for (i, a) in filled.iter().enumerate() {
        assert!(!filled[i + 1..].contains(a), "candidate {a} chosen twice");
    }
    assert!(atlas.coverage(&filled) >= atlas.coverage(&start));
    // A budget already met adds nothing.
    assert_eq!(fill_to_budget(&atlas, &pool, filled.clone(), 2), filled);
}

mod regions {
    use super::*;
    use probe_place::region::{Region, RegionError};

    /// The left half of the Cornell box (x < 0.25 m), clear of both blocks' tops.
    fn left_half() -> Region {
        Region::parse_boxes(["0.02,0.02,0.02:0.25,0.52,0.54"]).unwrap()
    }

    #[test]
    fn every_method_places_inside_the_region_and_records_it() {
        let scene = Scene::builtin("cornell").unwrap();
        let region = left_half();
        for method in [Method::Grid([2, 3, 3]), Method::Sdf, Method::Minimal] {
            let placed = place(
                &scene,
                &PlaceOptions {
                    region: Some(region.clone()),
                    optimize: (method == Method::Sdf).then_some(Optimizer::Gibbs),
                    iterations: 3,
                    ..options(method)
                },
                None,
            )
            .unwrap();
            assert!(!placed.probes.is_empty(), "{method:?}");
            for p in &placed.probes.positions {
                assert!(region.contains(*p), "{method:?}: {p} outside the region");
            }
            let PlacementMethod::Placed(run) = &placed.probes.method else {
                panic!("{method:?}: not a placed run");
            };
            assert_eq!(run.region.as_ref(), Some(&region));
            assert!(placed.probes.method.parameters().contains_key("region"));
        }
    }

    #[test]
    fn the_region_limits_what_coverage_asks_for() {
        let scene = Scene::builtin("cornell").unwrap();
        let whole = place(&scene, &options(Method::Grid([2, 2, 2])), None).unwrap();
        let half = place(
            &scene,
            &PlaceOptions {
                region: Some(left_half()),
                ..options(Method::Grid([2, 2, 2]))
            },
            None,
        )
        .unwrap();
        // Surfaces seen only from the right half (the blocks' faces towards the green wall)
        // are not reachable from the left half: fewer texels are asked for.
        assert!(
            half.report.unreachable_texels > whole.report.unreachable_texels,
            "{} vs {}",
            half.report.unreachable_texels,
            whole.report.unreachable_texels
        );
    }

    #[test]
    fn completion_reaches_full_coverage_within_the_region() {
        let scene = Scene::builtin("cornell").unwrap();
        let region = left_half();
        let plain = place(
            &scene,
            &PlaceOptions {
                region: Some(region.clone()),
                ..options(Method::Grid([2, 2, 2]))
            },
            None,
        )
        .unwrap();
        assert!(plain.report.coverage < 1.0, "the test needs a gap to fill");
        let completed = place(
            &scene,
            &PlaceOptions {
                region: Some(region.clone()),
                complete: true,
                ..options(Method::Grid([2, 2, 2]))
            },
            None,
        )
        .unwrap();
        assert_eq!(completed.report.coverage, 1.0);
        assert!(completed.probes.len() > plain.probes.len());
        assert_eq!(completed.full_grid, None);
        assert_eq!(completed.probes.method.name(), "grid-2x2x2+complete");
        assert!(
            completed
                .probes
                .positions
                .iter()
                .all(|p| region.contains(*p))
        );
        // The grid's probes come first, unchanged.
        assert_eq!(
            &completed.probes.positions[..plain.probes.len()],
            &plain.probes.positions[..]
        );
        // A budget stops the completion.
        let budgeted = place(
            &scene,
            &PlaceOptions {
                region: Some(region),
                complete: true,
                budget: Some(plain.probes.len() + 1),
                ..options(Method::Grid([2, 2, 2]))
            },
            None,
        )
        .unwrap();
        assert!(budgeted.probes.len() <= plain.probes.len() + 1);
    }

    #[test]
    fn bad_regions_are_refused_with_the_reason() {
        let scene = Scene::builtin("cornell").unwrap();
        let run = |boxes: &[&str]| {
            place(
                &scene,
                &PlaceOptions {
                    region: Some(Region::parse_boxes(boxes).unwrap()),
                    ..options(Method::Sdf)
                },
                None,
            )
        };
        let outside = run(&["5,5,5:6,6,6"]).unwrap_err();
        assert!(
            matches!(
                outside,
                PlaceError::Region(RegionError::OutsideScene { index: 0, .. })
            ),
            "{outside}"
        );
        assert!(outside.to_string().contains("scene-info"), "{outside}");
        // Inside the tall block: solid everywhere.
        let solid = run(&["0.35,0.05,0.33:0.39,0.25,0.37"]).unwrap_err();
        assert!(
            matches!(solid, PlaceError::Region(RegionError::NoFreeSpace { .. })),
            "{solid}"
        );
    }
}

#[test]
fn an_error_driven_set_held_by_each_view_reports_its_worst_view() {
    // The colonnade from four corners (as in tests/minimal.rs), an 80 % target held by each
    // view and over all views together.
    let scene = Scene::builtin("colonnade").unwrap();
    let cameras = support::corner_cameras(&scene);
    let run = |each_view| {
        place(
            &scene,
            &PlaceOptions {
                atlas_texels: 2400,
                viewers: Some(cameras.clone()),
                coverage: 0.8,
                each_view,
                ..PlaceOptions::new(Method::Minimal)
            },
            None,
        )
        .unwrap()
    };
    let each = run(true);
    let worst = each.report.worst_view_coverage.unwrap();
    assert!(worst >= 0.8 - 1e-9, "worst view {worst}");
    assert!(each.report.coverage >= worst);
    assert_eq!(
        each.probes.method.parameters().get("each_view"),
        Some(&serde_json::json!(true))
    );
    let together = run(false);
    assert!(together.report.coverage >= 0.8);
    assert!(together.report.worst_view_coverage.is_some());
    assert!(together.probes.len() <= each.probes.len());
    assert!(
        together
            .probes
            .method
            .parameters()
            .get("each_view")
            .is_none()
    );
    // Without views there is no per-view figure, and the JSON report has no such key.
    let plain = place(&scene, &options(Method::Grid([2, 2, 2])), None).unwrap();
    assert_eq!(plain.report.worst_view_coverage, None);
    assert!(!plain.report.to_json().contains("worst_view_coverage"));
}

/// The budget goes to the candidates that raise the texels' best read score most (the
/// tracer's measure: squarely and from close by): no candidate alone reads better than the
/// first pick, and every pick raises the total.
#[test]
fn fill_to_budget_picks_the_best_reader_first() {
    use probe_place::atlas::{READ_REACH, read_score};
    let scene = Scene::builtin("cornell").unwrap();
    let (pool, atlas) = pool_and_atlas(&scene);
    let reach = READ_REACH * atlas.distance_scale();
    let total = |probes: &[Vec3]| -> f64 {
        let mut best = vec![0.0f32; atlas.samples().len()];
        for views in atlas.views_of_probes(probes) {
            for v in views {
                let slot = &mut best[v.sample as usize];
                *slot = slot.max(read_score(&v, reach));
            }
        }
        best.iter().map(|&s| f64::from(s)).sum()
    };
    let filled = fill_to_budget(&atlas, &pool, Vec::new(), 3);
    assert_eq!(filled.len(), 3);
    // Greedy: each pick is the best single addition, so no other candidate beats the first.
    let first = total(&filled[..1]);
    for candidate in pool.iter().step_by(7) {
        assert!(
            total(std::slice::from_ref(candidate)) <= first + 1e-3,
            "{candidate} reads better than the first pick {}",
            filled[0]
        );
    }
    assert!(total(&filled) >= total(&filled[..2]) && total(&filled[..2]) >= first);
}
