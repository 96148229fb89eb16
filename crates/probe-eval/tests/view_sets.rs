//! The sweep over view sets (regions of interest, sampled viewpoints, error-driven sets):
//! a small run on the built-in Cornell box.

use probe_eval::sweep::{EvalConfig, SceneConfig, noise_free_error, run_sweep, spearman};
use probe_eval::views::{ViewSetOptions, view_set};
use probe_scene::Scene;

fn small_config() -> EvalConfig {
    let mut config = EvalConfig {
        resolution: 16,
        samples_per_texel: 2,
        max_samples_per_texel: 2,
        atlas_texels: 600,
        gibbs_iterations: 2,
        tracers: vec!["hiz".into()],
        selections: vec!["svo".into()],
        grid_counts: vec![8],
        placements: vec!["sdf".into(), "sdf+views~0.3".into()],
        failure_suite: false,
        views: 2,
        view_seed: 5,
        reference_max_samples: 8,
        ..EvalConfig::default()
    };
    config.view.width = 32;
    config.view.height = 24;
    config.view.shading_samples = 2;
    config.scenes.push(SceneConfig {
        scene: "builtin:cornell".into(),
        cameras: vec!["default".into()],
        grids: Vec::new(),
        placements: Vec::new(),
        region: vec!["0.02,0.02,0.02:0.3,0.52,0.54".into()],
        views: None,
    });
    config
}

#[test]
fn a_scene_with_a_view_set_is_judged_by_its_mean_and_worst_view() {
    let out = tempfile::tempdir().unwrap();
    let report = run_sweep(&small_config(), out.path(), &|_| {}).unwrap();
    // The default camera and two sampled views, three placements.
    let cameras: std::collections::BTreeSet<&str> =
        report.records.iter().map(|r| r.camera.as_str()).collect();
    assert_eq!(cameras.len(), 3, "{cameras:?}");
    assert_eq!(report.view_sets.len(), 3);
    for set in &report.view_sets {
        assert_eq!(set.views, 3);
        let views: Vec<_> = report
            .records
            .iter()
            .filter(|r| r.placement == set.placement)
            .collect();
        assert_eq!(views.len(), 3);
        let mean = views.iter().map(|r| r.trace.mse_tonemapped).sum::<f64>() / 3.0;
        assert!((set.trace.mse_tonemapped - mean).abs() <= 1e-12 * mean.max(1.0));
        let (worst, worst_mse) = set.worst_view.clone().unwrap();
        assert!(worst_mse >= set.trace.mse_tonemapped);
        assert!(views.iter().any(|r| r.camera == worst));
        assert_eq!(
            set.trace.rays,
            views.iter().map(|r| r.trace.rays).sum::<usize>()
        );
        let proxy = set.view_proxy_error.unwrap();
        assert!((0.0..=1.0).contains(&proxy));
    }
    // The error-driven set is judged on views it did not learn from.
    let target = &report.headline.target_errors;
    assert_eq!(target.len(), 1, "{target:?}");
    assert_eq!(target[0].target, 0.3f32 as f64);
    assert!(target[0].training <= 0.3 + 1e-6, "{:?}", target[0]);
    assert!(
        report
            .headline
            .proxy_rank_correlation
            .contains_key("cornell")
    );
    let csv = std::fs::read_to_string(out.path().join("results.csv")).unwrap();
    assert!(csv.lines().next().unwrap().contains("view_proxy_error"));
    assert_eq!(csv.lines().count(), 1 + 9 + 3);
    let markdown = std::fs::read_to_string(out.path().join("report.md")).unwrap();
    assert!(markdown.contains("## View sets"));
}

#[test]
fn a_bad_region_or_placement_target_is_refused_naming_it() {
    let out = tempfile::tempdir().unwrap();
    let mut config = small_config();
    config.scenes[0].region = vec!["0,0,0:1,-1,1".into()];
    let error = run_sweep(&config, out.path(), &|_| {}).unwrap_err();
    assert!(error.to_string().contains("builtin:cornell"), "{error}");
    assert!(error.to_string().contains("inverted"), "{error}");
    let mut config = small_config();
    config.placements = vec!["minimal+views~2".into()];
    let error = run_sweep(&config, out.path(), &|_| {}).unwrap_err();
    assert!(error.to_string().contains("minimal+views~0.05"), "{error}");
}

#[test]
fn the_held_out_view_set_differs_from_the_training_one() {
    let scene = Scene::builtin("cornell").unwrap();
    let options = |seed| ViewSetOptions {
        sampled: 3,
        seed,
        ..ViewSetOptions::default()
    };
    let eval = view_set(&scene, &options(5)).unwrap();
    let training = view_set(&scene, &options(probe_eval::sweep::training_seed(5))).unwrap();
    // The scene's camera is shared; the sampled viewpoints are not.
    assert_eq!(eval[0], training[0]);
    for (a, b) in eval[1..].iter().zip(&training[1..]) {
        assert_ne!(a.position, b.position);
    }
}

#[test]
fn spearman_ranks() {
    let a = [1.0, 2.0, 3.0, 4.0];
    assert_eq!(spearman(&a, &[10.0, 20.0, 30.0, 40.0]), Some(1.0));
    assert_eq!(spearman(&a, &[4.0, 3.0, 2.0, 1.0]), Some(-1.0));
    // Monotone but not linear: still 1.
    assert_eq!(spearman(&a, &[1.0, 8.0, 27.0, 1000.0]), Some(1.0));
    assert_eq!(spearman(&a[..2], &[1.0, 2.0]), None);
    assert_eq!(spearman(&a, &[1.0, 1.0, 1.0, 1.0]), None);
    let tied = spearman(&a, &[1.0, 1.0, 2.0, 3.0]).unwrap();
    assert!(tied > 0.9 && tied < 1.0, "{tied}");
}

/// With the split the only tracer, each placement's bake is the split's bake of the reflected
/// light, made directly: every view's split figures are those of a sweep that bakes the
/// outgoing radiance for another tracer beside it (and then the reflected light from it), and
/// the report says what its bake time is.
#[test]
fn a_split_only_sweep_bakes_the_reflected_light_alone() {
    let with_tracers = |tracers: &[&str]| EvalConfig {
        tracers: tracers.iter().map(|t| (*t).into()).collect(),
        selections: vec!["voronoi".into()],
        grid_counts: vec![8],
        placements: vec!["sdf".into()],
        ..small_config()
    };
    let alone_out = tempfile::tempdir().unwrap();
    let alone = run_sweep(&with_tracers(&["split"]), alone_out.path(), &|_| {}).unwrap();
    let beside_out = tempfile::tempdir().unwrap();
    let beside = run_sweep(
        &with_tracers(&["shaded", "split"]),
        beside_out.path(),
        &|_| {},
    )
    .unwrap();
    let split: Vec<_> = beside
        .records
        .iter()
        .filter(|r| r.trace.tracer == probe_eval::pipeline::Tracer::Split)
        .collect();
    assert_eq!(alone.records.len(), split.len());
    assert!(!split.is_empty());
    for (a, b) in alone.records.iter().zip(&split) {
        assert_eq!((&a.camera, &a.placement), (&b.camera, &b.placement));
        assert_eq!(
            a.trace.mse_tonemapped, b.trace.mse_tonemapped,
            "{}",
            a.camera
        );
        assert_eq!(a.trace.rays, b.trace.rays);
    }
    let markdown = std::fs::read_to_string(alone_out.path().join("report.md")).unwrap();
    assert!(markdown.contains("bake of the light the surfaces reflect"));
    let markdown = std::fs::read_to_string(beside_out.path().join("report.md")).unwrap();
    assert!(!markdown.contains("bake of the light the surfaces reflect"));
}

/// `measure_bake_noise` bakes each placement a second time with another seed: every record
/// gains the image's bake noise, and every other figure is the first bake's, as without it.
#[test]
fn a_second_bake_measures_each_images_bake_noise_and_changes_nothing_else() {
    let config = EvalConfig {
        tracers: vec!["hiz".into(), "split".into()],
        placements: vec!["sdf".into()],
        ..small_config()
    };
    let plain_out = tempfile::tempdir().unwrap();
    let plain = run_sweep(&config, plain_out.path(), &|_| {}).unwrap();
    let noisy_out = tempfile::tempdir().unwrap();
    let noisy = run_sweep(
        &EvalConfig {
            measure_bake_noise: true,
            ..config
        },
        noisy_out.path(),
        &|_| {},
    )
    .unwrap();
    assert_eq!(plain.records.len(), noisy.records.len());
    assert!(!plain.records.is_empty());
    for (a, b) in plain.records.iter().zip(&noisy.records) {
        assert_eq!((&a.camera, &a.placement), (&b.camera, &b.placement));
        assert_eq!(
            a.trace.mse_tonemapped, b.trace.mse_tonemapped,
            "{}",
            a.camera
        );
        assert_eq!(a.trace.bake_noise, None);
        assert_eq!(a.trace.second_bake_mse_tonemapped, None);
        let second = b.trace.second_bake_mse_tonemapped.unwrap();
        assert!(second > 0.0 && second != b.trace.mse_tonemapped, "{second}");
        // 16² texels of 2 samples: the two bakes' images differ.
        let noise = b.trace.bake_noise.unwrap();
        assert!(noise > 0.0 && noise.is_finite(), "{noise}");
        // Half the MSE between two images, each within its error of the reference.
        assert!(noise <= 2.0 * b.trace.mse_tonemapped + 1e-12, "{noise}");
    }
    for set in &noisy.view_sets {
        let views: Vec<f64> = noisy
            .records
            .iter()
            .filter(|r| r.placement == set.placement && r.trace.tracer == set.trace.tracer)
            .map(|r| r.trace.bake_noise.unwrap())
            .collect();
        let mean = views.iter().sum::<f64>() / views.len() as f64;
        assert!((set.trace.bake_noise.unwrap() - mean).abs() <= 1e-12);
        assert!(set.trace.second_bake_mse_tonemapped.is_some());
    }
    assert!(
        noisy
            .headline
            .probes_to_match_best_grid_noise_free
            .contains_key("cornell")
    );
    assert!(
        plain
            .headline
            .probes_to_match_best_grid_noise_free
            .is_empty()
    );
    // The error with the noise taken out: the two bakes' mean less both noises.
    for r in noisy.view_sets.iter().chain(&noisy.records) {
        let t = &r.trace;
        let expected = 0.5 * (t.mse_tonemapped + t.second_bake_mse_tonemapped.unwrap())
            - t.bake_noise.unwrap()
            - t.reference_noise;
        let error = noise_free_error(r).unwrap();
        assert!(
            (error - expected.max(0.0)).abs() <= 1e-15,
            "{error} {expected}"
        );
        assert!(error <= t.mse_tonemapped.max(t.second_bake_mse_tonemapped.unwrap()));
    }
    for r in &plain.records {
        assert_eq!(noise_free_error(r), None);
    }
    // Every CSV row has the header's columns, the second bake's MSE among them.
    let csv = std::fs::read_to_string(noisy_out.path().join("results.csv")).unwrap();
    let header = csv.lines().next().unwrap();
    assert!(header.contains(",bake_noise,second_bake_mse_tonemapped,"));
    let columns = header.split(',').count();
    assert!(csv.lines().all(|line| line.split(',').count() == columns));
    let markdown = std::fs::read_to_string(noisy_out.path().join("report.md")).unwrap();
    assert!(markdown.contains("With the noise taken out"));
    assert!(!markdown.contains("not measured"));
}
