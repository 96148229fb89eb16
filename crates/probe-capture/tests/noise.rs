//! The bake's own noise estimate: present in the manifest for every probe, and in agreement
//! with the noise measured from two bakes that differ only in their seed; adaptive sampling
//! brings the noise down towards its target where the cap allows.

use glam::Vec3;
use probe_capture::{BakeSettings, MANIFEST_FILE, ProbeBake, Sampling, bake, no_progress};
use probe_scene::Scene;

fn probes() -> Vec<Vec3> {
    vec![
        Vec3::new(0.28, 0.27, 0.28),
        Vec3::new(0.12, 0.45, 0.15),
        Vec3::new(0.45, 0.1, 0.05),
    ]
}

fn baked(scene: &Scene, sampling: Sampling, seed: u64) -> ProbeBake {
    let settings = BakeSettings {
        resolution: 32,
        sampling,
        bounces: 1,
        seed,
        moments_resolution: 6,
        irradiance_resolution: 4,
        pyramid_levels: 3,
        ..BakeSettings::default()
    };
    bake(scene, &probes(), &settings, &no_progress).unwrap()
}

/// Per probe, half the mean over texels of the tone-mapped squared difference of two bakes
/// (mean over channels): the variance of one bake's texel values.
fn two_seed_noise(a: &ProbeBake, b: &ProbeBake) -> Vec<f64> {
    let layout = a.layout();
    let n = layout.resolution();
    (0..a.probe_count())
        .map(|p| {
            let (ma, mb) = (a.radiance_map(p).unwrap(), b.radiance_map(p).unwrap());
            let mut sum = 0.0f64;
            for iy in 0..n {
                for ix in 0..n {
                    let tone = |v: Vec3| v / (Vec3::ONE + v);
                    let d = tone(ma.get(ix, iy).unwrap()) - tone(mb.get(ix, iy).unwrap());
                    sum += f64::from(d.length_squared()) / 3.0;
                }
            }
            sum / f64::from(n * n) / 2.0
        })
        .collect()
}

/// The per-probe noise the manifest of a saved bake records.
fn manifest_noise(baked: &ProbeBake) -> Vec<Option<f64>> {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bake");
    baked.save(&path).unwrap();
    let manifest: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(path.join(MANIFEST_FILE)).unwrap()).unwrap();
    let sampling = manifest["sampling"]
        .as_array()
        .expect("the manifest has a `sampling` record per probe");
    assert_eq!(sampling.len(), baked.probe_count());
    for (record, probe) in sampling.iter().zip(baked.sampling()) {
        assert_eq!(record["samples"].as_u64(), Some(probe.samples));
    }
    sampling.iter().map(|r| r["noise"].as_f64()).collect()
}

/// The bake's noise estimate (the mean of the manifest's per-probe figures) agrees with the
/// two-seed measurement within 2×, and every probe's within 3×: a probe's figure is a mean
/// over its texels of heavy-tailed variances (a rare bright path in one texel), which one
/// pair of seeds and one degree of freedom per texel measure more loosely.
fn check_agreement(sampling: Sampling) {
    let scene = Scene::builtin("cornell").unwrap();
    let (a, b) = (baked(&scene, sampling, 0), baked(&scene, sampling, 1));
    let measured = two_seed_noise(&a, &b);
    let (estimated_a, estimated_b) = (manifest_noise(&a), manifest_noise(&b));
    let mut estimated = Vec::new();
    for (probe, measured) in measured.iter().enumerate() {
        let (Some(ea), Some(eb)) = (estimated_a[probe], estimated_b[probe]) else {
            panic!("{sampling:?}: probe {probe} has no noise estimate in the manifest");
        };
        let probe_estimate = (ea + eb) / 2.0;
        let ratio = probe_estimate / measured;
        eprintln!(
            "{sampling:?}, probe {probe}: manifest {probe_estimate:.3e}, two seeds {measured:.3e}, ratio {ratio:.2}"
        );
        assert!(
            (1.0 / 3.0..=3.0).contains(&ratio),
            "{sampling:?}, probe {probe}: manifest noise {probe_estimate:.3e}, two seeds {measured:.3e} (ratio {ratio:.2})"
        );
        estimated.push(probe_estimate);
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let (estimated, measured) = (mean(&estimated), mean(&measured));
    // The bake's own figure is the same mean.
    let bake_figure = (a.noise().unwrap() + b.noise().unwrap()) / 2.0;
    assert!((bake_figure - estimated).abs() <= 1e-6 * estimated.max(1e-12));
    let ratio = estimated / measured;
    assert!(
        (0.5..=2.0).contains(&ratio),
        "{sampling:?}: the bake's noise estimate {estimated:.3e}, two seeds {measured:.3e} (ratio {ratio:.2})"
    );
}

#[test]
fn manifest_noise_agrees_with_two_seeds_for_fixed_sampling() {
    check_agreement(Sampling::fixed(8));
}

#[test]
fn manifest_noise_agrees_with_two_seeds_for_adaptive_sampling() {
    check_agreement(Sampling::adaptive(8, 64, 1e-4));
}

#[test]
fn one_sample_per_texel_has_no_estimate_and_says_so() {
    let scene = Scene::builtin("cornell").unwrap();
    let one = baked(&scene, Sampling::fixed(1), 0);
    assert_eq!(one.noise(), None);
    assert!(manifest_noise(&one).iter().all(Option::is_none));
}

#[test]
fn adaptive_sampling_spends_samples_where_the_noise_is_and_lowers_it() {
    let scene = Scene::builtin("cornell").unwrap();
    let fixed = baked(&scene, Sampling::fixed(4), 0);
    let target = 1e-4;
    let adaptive = baked(&scene, Sampling::adaptive(4, 64, target as f32), 0);
    let (fixed_noise, adaptive_noise) = (fixed.noise().unwrap(), adaptive.noise().unwrap());
    assert!(
        fixed_noise > 2.0 * target,
        "the case must need more samples: {fixed_noise:.2e}"
    );
    assert!(
        adaptive_noise < fixed_noise / 2.0,
        "adaptive {adaptive_noise:.2e} vs fixed {fixed_noise:.2e}"
    );
    // Not every texel needs the cap: samples go where the noise is.
    let spp = adaptive.mean_samples_per_texel();
    assert!(spp > 4.0 && spp < 48.0, "{spp} samples per texel");
    for probe in adaptive.sampling() {
        assert!((0.0..=1.0).contains(&probe.capped_share));
    }
    // The same inputs give the same bytes.
    assert_eq!(
        baked(&scene, Sampling::adaptive(4, 64, target as f32), 0),
        adaptive
    );
}

#[test]
fn sampling_settings_are_checked() {
    let cases = [
        (Sampling::fixed(0), "samples_per_texel"),
        (Sampling::adaptive(8, 4, 1e-4), "max_samples_per_texel"),
        (Sampling::adaptive(4, 8, 0.0), "noise_target"),
        (Sampling::adaptive(4, 8, f32::NAN), "noise_target"),
        (Sampling::adaptive(4, 70_000, 1e-4), "max_samples_per_texel"),
    ];
    for (sampling, parameter) in cases {
        match sampling.validate() {
            Err(probe_capture::BakeError::InvalidSetting { parameter: p, .. }) => {
                assert_eq!(p, parameter, "{sampling:?}");
            }
            other => panic!("{sampling:?}: {other:?}"),
        }
    }
    assert!(Sampling::default().validate().is_ok());
}
