//! Bakes: determinism, derived maps, statistics, settings errors, save/load and previews.

use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

use glam::Vec3;
use probe_capture::{
    BAKE_FORMAT_VERSION, BakeError, BakeLoadError, BakeSaveError, BakeSettings, Environment,
    MANIFEST_FILE, MISS_DISTANCE, ProbeBake, Sampling, bake, no_progress,
};
use probe_octa::{FineRead, MinMaxPyramid, OctaMap, ShL2Rgb, distance_moments, irradiance_map};
use probe_scene::Scene;
use probe_scene::builtin::{BOXES_GRID, grid_cell_centers};

fn small_settings() -> BakeSettings {
    BakeSettings {
        resolution: 16,
        sampling: Sampling::fixed(2),
        moments_resolution: 6,
        irradiance_resolution: 4,
        pyramid_levels: 3,
        seed: 42,
        ..Default::default()
    }
}

fn cornell() -> Scene {
    Scene::builtin("cornell").unwrap()
}

fn cornell_probes() -> Vec<Vec3> {
    vec![
        Vec3::new(0.28, 0.27, 0.28),
        Vec3::new(0.12, 0.45, 0.15),
        Vec3::new(0.45, 0.1, 0.05),
    ]
}

#[test]
fn bakes_are_deterministic_across_thread_counts() {
    let scene = cornell();
    let probes = cornell_probes();
    let settings = small_settings();
    let a = bake(&scene, &probes, &settings, &no_progress).unwrap();
    let b = bake(&scene, &probes, &settings, &no_progress).unwrap();
    assert_eq!(a, b);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let single = pool.install(|| bake(&scene, &probes, &settings, &no_progress).unwrap());
    assert_eq!(a, single);
    // Bit for bit, including the radiance.
    let bits = |bake: &ProbeBake| -> Vec<u32> {
        bake.radiance()
            .iter()
            .flat_map(|v| v.to_array().map(f32::to_bits))
            .collect()
    };
    assert_eq!(bits(&a), bits(&single));
    // Another seed changes the noise but not the geometry.
    let other = bake(
        &scene,
        &probes,
        &BakeSettings {
            seed: 43,
            ..settings.clone()
        },
        &no_progress,
    )
    .unwrap();
    assert_ne!(a.radiance(), other.radiance());
    assert_eq!(a.distances(), other.distances());
}

#[test]
fn derived_maps_are_probe_octa_filters_of_the_maps() {
    let scene = cornell();
    let settings = small_settings();
    let probes = bake(&scene, &cornell_probes(), &settings, &no_progress).unwrap();
    assert_eq!(probes.probe_count(), 3);
    let len = 18 * 18;
    assert_eq!(probes.radiance().len(), 3 * len);
    assert_eq!(probes.normals().len(), 3 * len);
    assert_eq!(probes.distances().len(), 3 * len);
    assert_eq!(probes.distance_ranges().len(), 3 * len);
    assert_eq!(probes.moments().len(), 3 * 8 * 8);
    assert_eq!(probes.irradiance().len(), 3 * 6 * 6);
    assert_eq!(probes.sh().len(), 3);
    assert_eq!(probes.pyramid_level_count(), 3);
    assert_eq!(probes.pyramid_texels_per_probe(), 256 + 64 + 16);
    assert_eq!(probes.pyramid().len(), 3 * (256 + 64 + 16));
    assert_eq!(probes.surfels().len(), 3 * 8 * 8);
    for p in 0..3 {
        let distance = probes.distance_map(p).unwrap();
        let radiance = probes.radiance_map(p).unwrap();
        // The padded border follows probe-octa's layout.
        let mut repadded = distance.clone();
        repadded.pad();
        assert_eq!(repadded, distance);
        let pyramid = MinMaxPyramid::build(&distance, FineRead::Bilinear, 3).unwrap();
        for level in 0..3 {
            assert_eq!(
                probes.pyramid_level(p, level).unwrap(),
                pyramid.level(level as usize).unwrap()
            );
        }
        assert!(probes.pyramid_level(p, 3).is_none());
        // Each texel's range holds its centre's distance, and its border is padded like the
        // distances. The box is open on one side: some texels straddle its rim, seeing the
        // wall in part of their cone and the sky in the rest.
        let ranges = &probes.distance_ranges()[p * len..(p + 1) * len];
        let (mut spread, mut rim) = (0, 0);
        for (t, (range, &d)) in ranges.iter().zip(distance.texels()).enumerate() {
            assert!(
                range.x <= d && d <= range.y,
                "texel {t}: {range} around {d}"
            );
            spread += usize::from(range.y > range.x);
            rim += usize::from(range.x < MISS_DISTANCE && range.y >= MISS_DISTANCE);
        }
        let mut padded_ranges = OctaMap::from_padded(16, ranges.to_vec()).unwrap();
        padded_ranges.pad();
        assert_eq!(padded_ranges.texels(), ranges);
        assert!(
            spread > len / 2,
            "only {spread} texels see a range of distances"
        );
        assert!(
            rim > 0 && rim < len / 4,
            "{rim} texels on the open side's rim"
        );
        let clamped = distance.map(|r| r.min(probes.moments_max_distance()));
        assert_eq!(
            probes.moments_map(p).unwrap(),
            distance_moments(&clamped, 6, 50.0).unwrap()
        );
        // The irradiance leaves out the ceiling light the probe sees: below what the whole
        // radiance gives wherever the normal faces up, equal where it faces down (within 3 %:
        // the irradiance integrates every sample, while a texel's radiance is the mean of
        // those that meet its centre's surface, and at 16² many texels straddle a block's
        // silhouette or the open side's rim; per irradiance texel, within 10 %).
        let with_light = irradiance_map(&radiance, 4).unwrap();
        let indirect = probes.irradiance_map(p).unwrap();
        let (up, down) = (Vec3::Y, -Vec3::Y);
        let texel = |map: &OctaMap<Vec3>, direction: Vec3| map.sample(direction);
        // (Probe 2, low by the open front, sees the light in under a texel's solid angle and
        // its two samples per texel miss it.)
        assert!(
            p == 2 || texel(&indirect, up).x < 0.8 * texel(&with_light, up).x,
            "probe {p} up: {} vs {}",
            texel(&indirect, up),
            texel(&with_light, up)
        );
        let (a, b) = (texel(&indirect, down), texel(&with_light, down));
        assert!(
            (a - b).abs().max_element() < 0.03 * b.max_element(),
            "probe {p} down: {a} vs {b}"
        );
        for (a, b) in indirect.texels().iter().zip(with_light.texels()) {
            assert!(
                (*a - *b).max_element() <= 0.1 * b.max_element().max(1e-6),
                "probe {p}: {a} vs {b}"
            );
        }
        // The surfels hold the same light without emission: gathered at the probe facing the
        // light they give about the indirect irradiance (coarsely: 8² surfels of a 16² map),
        // well below the irradiance with the light.
        let surfels = &probes.surfels()[p * 64..(p + 1) * 64];
        let gathered = probe_octa::surfel_irradiance(surfels, probes.positions()[p], up);
        let (map, lit) = (texel(&indirect, up), texel(&with_light, up));
        assert!(
            (gathered - map).abs().max_element() <= 0.5 * map.max_element() + 1e-3,
            "probe {p}: surfels {gathered}, indirect map {map}, with light {lit}"
        );
        assert!(
            p == 2 || gathered.x < 0.8 * lit.x,
            "probe {p}: {gathered} vs {lit}"
        );
        assert_eq!(probes.sh()[p], ShL2Rgb::project(&radiance));
        // Sane values: finite, non-negative radiance; some light everywhere in the box.
        assert!(
            radiance
                .texels()
                .iter()
                .all(|r| r.is_finite() && r.min_element() >= 0.0)
        );
        assert!(radiance.texels().iter().any(|r| r.max_element() > 0.0));
    }
    assert!(probes.radiance_map(3).is_none());
    assert!(probes.pyramid_level(3, 0).is_none());

    // The environment used was black (the Cornell box has an emitter).
    assert_eq!(*probes.environment(), Environment::BLACK);
}

#[test]
fn reduced_filter_sources_change_the_filtered_maps_little() {
    let scene = cornell();
    let settings = BakeSettings {
        resolution: 64,
        sampling: Sampling::fixed(1),
        moments_resolution: 14,
        irradiance_resolution: 6,
        filter_source_resolution: 64,
        ..small_settings()
    };
    let positions = &cornell_probes()[..1];
    let full = bake(&scene, positions, &settings, &no_progress).unwrap();
    let reduced = bake(
        &scene,
        positions,
        &BakeSettings {
            filter_source_resolution: 32,
            ..settings
        },
        &no_progress,
    )
    .unwrap();
    assert_eq!(reduced.radiance(), full.radiance());
    assert_ne!(reduced.moments(), full.moments());
    let mut worst = 0.0f32;
    for (a, b) in reduced.moments().iter().zip(full.moments()) {
        worst = worst.max((a.x - b.x).abs() / b.x);
    }
    assert!(worst < 0.05, "moments: {worst}");
    let mut worst = 0.0f32;
    for (a, b) in reduced.irradiance().iter().zip(full.irradiance()) {
        worst = worst.max((*a - *b).abs().max_element() / b.max_element());
    }
    assert!(worst < 0.02, "irradiance: {worst}");
    // L2 SH barely notice the reduction.
    let (a, b) = (reduced.sh()[0], full.sh()[0]);
    let scale = b.coefficients[0].max_element();
    for (x, y) in a.coefficients.iter().zip(&b.coefficients) {
        assert!((*x - *y).abs().max_element() < 0.01 * scale, "{x} vs {y}");
    }
}

#[test]
fn back_face_share_finds_probes_inside_boxes() {
    let scene = Scene::builtin("boxes").unwrap();
    let centres = grid_cell_centers(&scene.bounds(), BOXES_GRID);
    let positions = vec![centres[0], centres[13], Vec3::new(0.0, 1.5, 0.0)];
    let geometry = probe_capture::capture_geometry(&scene, &positions, 32, &no_progress).unwrap();
    let stats = geometry.stats();
    for inside in &stats[..2] {
        assert!(inside.back_face_share > 0.99, "{inside:?}");
        assert!(inside.min_distance <= 0.15 + 1e-4 && inside.mean_distance < 0.27);
    }
    assert_eq!(stats[2].back_face_share, 0.0, "{:?}", stats[2]);
    assert_eq!(stats[2].miss_share, 0.0);
    assert!(stats[2].mean_distance > 1.0);
    // The stored normals mark back faces: they point away from the probe exactly there.
    let layout = probe_octa::OctaLayout::new(32).unwrap();
    for (probe, stats) in stats.iter().enumerate() {
        let mut away = 0;
        for iy in 0..32 {
            for ix in 0..32 {
                let normal =
                    geometry.normals()[probe * layout.padded_len() + layout.interior_index(ix, iy)];
                away += usize::from(normal.dot(layout.texel_direction(ix, iy)) > 0.0);
            }
        }
        assert_eq!(away as f32 / 1024.0, stats.back_face_share, "probe {probe}");
    }
}

#[test]
fn progress_reaches_the_total() {
    let scene = cornell();
    let calls = AtomicUsize::new(0);
    let last = Mutex::new((0usize, 0usize));
    let progress = |done: usize, total: usize| {
        calls.fetch_add(1, Ordering::Relaxed);
        let mut last = last.lock().unwrap();
        if done > last.0 {
            *last = (done, total);
        }
    };
    let settings = small_settings();
    bake(&scene, &cornell_probes(), &settings, &progress).unwrap();
    let (done, total) = *last.lock().unwrap();
    assert_eq!(total, 4 * 3 * 16 + 3);
    assert_eq!(done, total);
    assert_eq!(calls.load(Ordering::Relaxed), total);
}

#[test]
fn invalid_settings_name_the_parameter() {
    let scene = cornell();
    let p = [Vec3::splat(0.2)];
    let parameter = |settings: BakeSettings| match bake(&scene, &p, &settings, &no_progress) {
        Err(BakeError::InvalidSetting { parameter, .. }) => parameter,
        other => panic!("expected an invalid setting, got {other:?}"),
    };
    for resolution in [0, 100, 2048] {
        let message = bake(
            &scene,
            &p,
            &BakeSettings {
                resolution,
                ..small_settings()
            },
            &no_progress,
        )
        .unwrap_err()
        .to_string();
        assert!(message.contains("resolution"), "{message}");
        assert_eq!(
            parameter(BakeSettings {
                resolution,
                ..small_settings()
            }),
            "resolution"
        );
    }
    assert_eq!(
        parameter(BakeSettings {
            sampling: Sampling::fixed(0),
            ..small_settings()
        }),
        "samples_per_texel"
    );
    assert_eq!(
        parameter(BakeSettings {
            moments_resolution: 0,
            ..small_settings()
        }),
        "moments_resolution"
    );
    assert_eq!(
        parameter(BakeSettings {
            irradiance_resolution: 1000,
            ..small_settings()
        }),
        "irradiance_resolution"
    );
    assert_eq!(
        parameter(BakeSettings {
            filter_source_resolution: 48,
            ..small_settings()
        }),
        "filter_source_resolution"
    );
    assert_eq!(
        parameter(BakeSettings {
            pyramid_levels: 0,
            ..small_settings()
        }),
        "pyramid_levels"
    );
    assert_eq!(
        parameter(BakeSettings {
            moments_lobe_power: f32::NAN,
            ..small_settings()
        }),
        "moments_lobe_power"
    );
    assert_eq!(
        parameter(BakeSettings {
            moments_max_distance: Some(-1.0),
            ..small_settings()
        }),
        "moments_max_distance"
    );
    assert!(matches!(
        bake(&scene, &[], &small_settings(), &no_progress),
        Err(BakeError::NoProbes)
    ));
    assert!(matches!(
        bake(
            &scene,
            &[Vec3::ZERO, Vec3::new(0.0, f32::NAN, 0.0)],
            &small_settings(),
            &no_progress
        ),
        Err(BakeError::InvalidPosition { probe: 1, .. })
    ));
    let bad_sky = BakeSettings {
        environment: Some(Environment::uniform_sky(Vec3::new(1.0, -1.0, 0.0))),
        ..small_settings()
    };
    let message = bake(&scene, &p, &bad_sky, &no_progress)
        .unwrap_err()
        .to_string();
    assert!(message.contains("sky_zenith"), "{message}");
}

#[test]
fn default_daylight_lights_a_scene_without_lights() {
    // A scene with a light of its own gets no daylight.
    let lit = Scene::builtin("colonnade").unwrap();
    assert_eq!(Environment::for_scene(&lit), Environment::BLACK);
    // The boxes scene with its emitter and ceiling removed: nothing but the default sun and sky.
    let boxes = Scene::builtin("boxes").unwrap();
    let materials: Vec<_> = boxes
        .materials()
        .iter()
        .map(|m| probe_scene::Material {
            emissive: Vec3::ZERO,
            ..m.clone()
        })
        .collect();
    // An open-topped variant: drop the ceiling slab and the light quad under it (every
    // triangle lying wholly above y = 2.98).
    let triangles: Vec<_> = boxes
        .triangles()
        .iter()
        .filter(|t| !t.positions.iter().all(|p| p.y >= 2.98))
        .copied()
        .collect();
    let dark = Scene::from_triangles("open boxes", triangles, materials, vec![], vec![]).unwrap();
    assert_eq!(Environment::for_scene(&dark), Environment::DEFAULT_DAYLIGHT);
    let probes = bake(
        &dark,
        &[Vec3::new(0.0, 1.5, 0.0)],
        &BakeSettings {
            resolution: 16,
            sampling: Sampling::fixed(1),
            bounces: 0,
            ..small_settings()
        },
        &no_progress,
    )
    .unwrap();
    assert_eq!(*probes.environment(), Environment::DEFAULT_DAYLIGHT);
    let map = probes.radiance_map(0).unwrap();
    // Straight up is the sky (near the zenith: the texel averages jittered directions).
    let up = map.sample_nearest(Vec3::Y);
    let zenith = Environment::DEFAULT_DAYLIGHT.sky_zenith;
    assert!((up - zenith).abs().max_element() < 0.02, "{up}");
    assert!(probes.stats()[0].miss_share > 0.1);
    // The floor is lit by sun and sky.
    assert!(map.sample_nearest(-Vec3::Y).max_element() > 0.0);
}

fn baked_cornell() -> (Scene, ProbeBake) {
    let scene = cornell();
    let probes = bake(&scene, &cornell_probes(), &small_settings(), &no_progress).unwrap();
    (scene, probes)
}

#[test]
fn save_and_load_round_trip_exactly() {
    let (scene, probes) = baked_cornell();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bake");
    probes.save(&path).unwrap();
    for file in [
        MANIFEST_FILE,
        "radiance.exr",
        "geometry.exr",
        "pyramid.exr",
        "moments.exr",
        "irradiance.exr",
        "sh.exr",
    ] {
        assert!(path.join(file).is_file(), "{file}");
    }
    let loaded = ProbeBake::load(&path, Some(&scene)).unwrap();
    assert_eq!(loaded, probes);
    let bounds = scene.bounds();
    assert_eq!(loaded.scene_bounds(), Some([bounds.min, bounds.max]));
    let loaded = ProbeBake::load(&path, None).unwrap();
    assert_eq!(loaded, probes);
    // Saving is deterministic too: a second save gives the same files, byte for byte.
    let again = tempfile::tempdir().unwrap();
    loaded.save(again.path().join("bake")).unwrap();
    for file in [MANIFEST_FILE, "radiance.exr", "geometry.exr", "pyramid.exr"] {
        assert_eq!(
            std::fs::read(path.join(file)).unwrap(),
            std::fs::read(again.path().join("bake").join(file)).unwrap(),
            "{file}"
        );
    }
    // No temporary files are left beside the bake.
    let entries: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(entries, vec![std::ffi::OsString::from("bake")]);

    // Saving again replaces the bake; a different bake comes back.
    let other = bake(
        &scene,
        &cornell_probes()[..1],
        &small_settings(),
        &no_progress,
    )
    .unwrap();
    other.save(&path).unwrap();
    assert_eq!(ProbeBake::load(&path, Some(&scene)).unwrap(), other);

    // The manifest records what the issue asks for.
    let manifest: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(path.join(MANIFEST_FILE)).unwrap()).unwrap();
    assert_eq!(manifest["format_version"], BAKE_FORMAT_VERSION);
    assert_eq!(manifest["resolution"], 16);
    assert_eq!(manifest["positions"].as_array().unwrap().len(), 1);
    assert!(
        manifest["tool"]
            .as_str()
            .unwrap()
            .starts_with("probe-capture ")
    );
    assert_eq!(
        manifest["scene"]["content_hash"].as_str().unwrap().len(),
        64
    );
    assert!(
        manifest["units"]["distance"]
            .as_str()
            .unwrap()
            .contains("metres")
    );
    assert_eq!(
        manifest["miss_distance"].as_f64().unwrap() as f32,
        MISS_DISTANCE
    );
    assert_eq!(manifest["settings"]["samples_per_texel"], 2);
}

/// A bake saved before surfels existed (no `surfel_resolution` in its manifest) loads with
/// none, and everything else as saved.
#[test]
fn bakes_saved_before_surfels_load_without_them() {
    let (scene, probes) = baked_cornell();
    assert!(!probes.surfels().is_empty());
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bake");
    probes.save(&path).unwrap();
    let manifest_path = path.join(MANIFEST_FILE);
    let mut manifest: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&manifest_path).unwrap()).unwrap();
    manifest["settings"]
        .as_object_mut()
        .unwrap()
        .remove("surfel_resolution")
        .unwrap();
    std::fs::write(&manifest_path, manifest.to_string()).unwrap();
    let loaded = ProbeBake::load(&path, Some(&scene)).unwrap();
    assert!(loaded.surfels().is_empty());
    assert_eq!(loaded.settings().surfel_resolution, 0);
    assert_eq!(loaded.irradiance(), probes.irradiance());
    assert_eq!(loaded.radiance(), probes.radiance());
}

#[test]
fn load_refuses_other_scenes_newer_formats_and_damage() {
    let (scene, probes) = baked_cornell();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bake");
    probes.save(&path).unwrap();

    let boxes = Scene::builtin("boxes").unwrap();
    let error = ProbeBake::load(&path, Some(&boxes)).unwrap_err();
    assert!(
        matches!(error, BakeLoadError::SceneMismatch { .. }),
        "{error}"
    );
    assert!(error.to_string().contains("cornell"), "{error}");

    // A newer format version is refused before anything else is read.
    let manifest_path = path.join(MANIFEST_FILE);
    let original = std::fs::read_to_string(&manifest_path).unwrap();
    let mut value: serde_json::Value = serde_json::from_str(&original).unwrap();
    value["format_version"] = serde_json::json!(BAKE_FORMAT_VERSION + 1);
    value["some_future_field"] = serde_json::json!([1, 2, 3]);
    std::fs::write(&manifest_path, value.to_string()).unwrap();
    let error = ProbeBake::load(&path, Some(&scene)).unwrap_err();
    assert!(
        matches!(error, BakeLoadError::NewerFormat { found, .. } if found == u64::from(BAKE_FORMAT_VERSION) + 1),
        "{error}"
    );
    assert!(error.to_string().contains("newer"), "{error}");

    // An older format (version 1 recorded no noise estimates) asks for a re-bake.
    let mut value: serde_json::Value = serde_json::from_str(&original).unwrap();
    value["format_version"] = serde_json::json!(1);
    std::fs::write(&manifest_path, value.to_string()).unwrap();
    let error = ProbeBake::load(&path, Some(&scene)).unwrap_err();
    assert!(
        matches!(error, BakeLoadError::OlderFormat { found: 1, .. }),
        "{error}"
    );
    assert!(error.to_string().contains("re-bake"), "{error}");

    // A manifest without its per-probe noise records, or with a negative noise, is refused.
    let mut value: serde_json::Value = serde_json::from_str(&original).unwrap();
    value.as_object_mut().unwrap().remove("sampling");
    std::fs::write(&manifest_path, value.to_string()).unwrap();
    let error = ProbeBake::load(&path, None).unwrap_err();
    assert!(matches!(error, BakeLoadError::Manifest { .. }), "{error}");
    assert!(error.to_string().contains("sampling"), "{error}");
    let mut value: serde_json::Value = serde_json::from_str(&original).unwrap();
    value["sampling"][0]["noise"] = serde_json::json!(-1.0);
    std::fs::write(&manifest_path, value.to_string()).unwrap();
    let error = ProbeBake::load(&path, None).unwrap_err();
    assert!(
        matches!(error, BakeLoadError::InvalidManifest { .. }),
        "{error}"
    );

    // Not a bake manifest; malformed JSON; inconsistent counts.
    std::fs::write(&manifest_path, r#"{"format": "something else"}"#).unwrap();
    assert!(matches!(
        ProbeBake::load(&path, None),
        Err(BakeLoadError::NotABake { .. })
    ));
    std::fs::write(&manifest_path, &original[..original.len() / 2]).unwrap();
    assert!(matches!(
        ProbeBake::load(&path, None),
        Err(BakeLoadError::Manifest { .. })
    ));
    let mut value: serde_json::Value = serde_json::from_str(&original).unwrap();
    value["probe_count"] = serde_json::json!(5);
    std::fs::write(&manifest_path, value.to_string()).unwrap();
    assert!(matches!(
        ProbeBake::load(&path, None),
        Err(BakeLoadError::InvalidManifest { .. })
    ));
    std::fs::write(&manifest_path, &original).unwrap();
    assert_eq!(ProbeBake::load(&path, None).unwrap(), probes);

    // A truncated EXR, a missing one, a missing manifest.
    let radiance = path.join("radiance.exr");
    let bytes = std::fs::read(&radiance).unwrap();
    std::fs::write(&radiance, &bytes[..bytes.len() / 2]).unwrap();
    let error = ProbeBake::load(&path, None).unwrap_err();
    assert!(matches!(error, BakeLoadError::Exr { .. }), "{error}");
    assert!(error.to_string().contains("radiance.exr"), "{error}");
    std::fs::remove_file(&radiance).unwrap();
    let error = ProbeBake::load(&path, None).unwrap_err();
    assert!(matches!(error, BakeLoadError::Io { .. }), "{error}");
    assert!(error.to_string().contains("radiance.exr"), "{error}");
    // A file from another bake (different size) is refused.
    let other = bake(
        &scene,
        &cornell_probes()[..1],
        &small_settings(),
        &no_progress,
    )
    .unwrap();
    let other_path = dir.path().join("other");
    other.save(&other_path).unwrap();
    std::fs::copy(other_path.join("radiance.exr"), &radiance).unwrap();
    let error = ProbeBake::load(&path, None).unwrap_err();
    assert!(matches!(error, BakeLoadError::WrongLayer { .. }), "{error}");
    std::fs::remove_file(&manifest_path).unwrap();
    assert!(matches!(
        ProbeBake::load(&path, None),
        Err(BakeLoadError::Io { .. })
    ));
}

#[test]
fn save_refuses_to_replace_other_data() {
    let (_, probes) = baked_cornell();
    let dir = tempfile::tempdir().unwrap();
    let target = dir.path().join("precious");
    std::fs::create_dir(&target).unwrap();
    std::fs::write(target.join("notes.txt"), "keep me").unwrap();
    let error = probes.save(&target).unwrap_err();
    assert!(
        matches!(error, BakeSaveError::NotABakeDirectory { .. }),
        "{error}"
    );
    assert_eq!(
        std::fs::read_to_string(target.join("notes.txt")).unwrap(),
        "keep me"
    );
    let file = dir.path().join("a-file");
    std::fs::write(&file, "x").unwrap();
    assert!(probes.save(&file).is_err());
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "x");
    // An empty directory may be filled; a missing parent is created.
    let empty = dir.path().join("empty");
    std::fs::create_dir(&empty).unwrap();
    probes.save(&empty).unwrap();
    probes.save(dir.path().join("a/b/c")).unwrap();
    assert!(ProbeBake::load(dir.path().join("a/b/c"), None).is_ok());
}

#[test]
fn previews_are_written() {
    let (_, probes) = baked_cornell();
    let dir = tempfile::tempdir().unwrap();
    let paths = probes.write_previews(1, dir.path()).unwrap();
    for path in [&paths.radiance, &paths.normal, &paths.distance] {
        let image = image::open(path).unwrap();
        assert_eq!(
            (image.width(), image.height()),
            (16, 16),
            "{}",
            path.display()
        );
        let rgb = image.to_rgb8();
        // Not a blank picture.
        let first = rgb.get_pixel(0, 0);
        assert!(rgb.pixels().any(|p| p != first), "{}", path.display());
    }
    assert!(paths.radiance.ends_with("probe0001_radiance.png"));
    assert!(probes.write_previews(3, dir.path()).is_err());
}

#[test]
fn bake_over_the_memory_limit_is_refused_before_tracing() {
    let scene = cornell();
    let settings = BakeSettings {
        resolution: 1024,
        ..small_settings()
    };
    let positions = vec![Vec3::splat(0.25); 64];
    let estimate = probe_capture::bake_memory_estimate(positions.len(), &settings);
    // 64 probes at 1026² padded texels, 96 bytes each: over 6 GiB.
    assert!(estimate > 6 << 30, "{estimate}");
    let limit = probe_scene::memory::MemoryLimit::bytes(1 << 30);
    let start = std::time::Instant::now();
    let error = probe_capture::bake_with_limit(&scene, &positions, &settings, limit, &no_progress)
        .unwrap_err();
    assert!(matches!(error, BakeError::OverMemory(_)), "{error:?}");
    let text = error.to_string();
    assert!(
        text.contains("64 probes at 1024²") && text.contains("1.0 GiB"),
        "{text}"
    );
    assert!(start.elapsed().as_secs_f64() < 1.0);
}

/// Radiance smoothing (`BakeSettings::denoise`) brings a noisy bake closer to a converged one
/// of the same probes and keeps the light's edge: on the built-in Cornell box (three probes
/// at 32², 4 samples per texel against 128), the tone-mapped squared error against the
/// converged maps falls (measured 11.67 → 10.77 at strength 2; texels more than 0.1 off: 51 →
/// 31), and every texel that sees the light in the converged bake still does. (Per texel the
/// gain is modest: at 8 and 16 samples strength 2 is neutral and 4 is worse; BENCHMARKS.md,
/// "Radiance smoothing".)
#[test]
fn denoise_lowers_the_noise_and_keeps_the_light() {
    let scene = cornell();
    let probes = cornell_probes();
    let noisy = BakeSettings {
        resolution: 32,
        sampling: Sampling::fixed(4),
        ..small_settings()
    };
    let converged = bake(
        &scene,
        &probes,
        &BakeSettings {
            sampling: Sampling::fixed(128),
            seed: 7,
            ..noisy.clone()
        },
        &no_progress,
    )
    .unwrap();
    let raw = bake(&scene, &probes, &noisy, &no_progress).unwrap();
    let smoothed = bake(
        &scene,
        &probes,
        &BakeSettings {
            denoise: 2.0,
            ..noisy.clone()
        },
        &no_progress,
    )
    .unwrap();
    let tone = |v: Vec3| v.max(Vec3::ZERO) / (Vec3::ONE + v.max(Vec3::ZERO));
    let error = |b: &ProbeBake| -> f64 {
        b.radiance()
            .iter()
            .zip(converged.radiance())
            .map(|(&a, &t)| f64::from((tone(a) - tone(t)).length_squared()))
            .sum()
    };
    let (e_raw, e_smoothed) = (error(&raw), error(&smoothed));
    eprintln!("squared error against 128 samples: {e_raw:.3} unsmoothed, {e_smoothed:.3} smoothed");
    assert!(e_smoothed < 0.95 * e_raw, "{e_smoothed} against {e_raw}");
    // The light (radiance ~17) against the ceiling (~0.1): no texel wholly on it is smoothed
    // away (texels across its edge are partly lit and noisy at 4 samples either way).
    let mut light = 0;
    for (&s, &t) in smoothed.radiance().iter().zip(converged.radiance()) {
        if t.element_sum() > 24.0 {
            light += 1;
            assert!(s.element_sum() > 12.0, "{s} where the light is {t}");
        }
    }
    assert!(light > 0, "the probes see the light");
    // The noise a bake reports is its samples', before smoothing.
    assert_eq!(raw.noise(), smoothed.noise());
    // A strength out of range is refused, naming the setting.
    let bad = BakeSettings {
        denoise: f32::NAN,
        ..noisy
    };
    let error = bake(&scene, &probes, &bad, &no_progress).unwrap_err();
    assert!(error.to_string().contains("denoise"), "{error}");
}
