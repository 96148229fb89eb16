//! A damaged bake (issue 15): truncated or swapped EXR files, a manifest with wrong counts,
//! NaN, zero or huge resolutions, missing files, a bake of another scene, a bake too large for
//! the memory limit. Each is refused with one error line naming the file or field at fault,
//! and loading never writes: the damaged directory is left exactly as it was.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use exr::prelude::WritableImage;
use glam::Vec3;
use probe_capture::{BakeLoadError, BakeSettings, MANIFEST_FILE, ProbeBake, Sampling, bake};
use probe_scene::Scene;
use probe_scene::memory::MemoryLimit;

const EXR_FILES: [&str; 6] = [
    "radiance.exr",
    "geometry.exr",
    "pyramid.exr",
    "moments.exr",
    "irradiance.exr",
    "sh.exr",
];

/// A small bake of the built-in Cornell box, saved under a fresh temporary folder.
fn saved_bake() -> (tempfile::TempDir, PathBuf, Scene) {
    let scene = Scene::builtin("cornell").unwrap();
    let settings = BakeSettings {
        resolution: 8,
        sampling: Sampling::fixed(1),
        moments_resolution: 4,
        irradiance_resolution: 4,
        pyramid_levels: 2,
        filter_source_resolution: 8,
        ..Default::default()
    };
    let positions = [Vec3::new(0.28, 0.27, 0.28), Vec3::new(0.12, 0.45, 0.15)];
    let baked = bake(&scene, &positions, &settings, &|_, _| {}).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bake");
    baked.save(&path).unwrap();
    (dir, path, scene)
}

/// Every file of the directory with its bytes.
fn snapshot(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| {
            let e = e.unwrap();
            (
                e.file_name().to_string_lossy().into_owned(),
                std::fs::read(e.path()).unwrap(),
            )
        })
        .collect()
}

/// Loads the damaged bake, checks that the error is one line containing `expect` and that
/// nothing in the directory changed, and returns the error.
fn refused(path: &Path, scene: Option<&Scene>, expect: &str) -> BakeLoadError {
    let before = snapshot(path);
    let error = ProbeBake::load(path, scene).expect_err(expect);
    let text = error.to_string();
    assert!(!text.contains('\n'), "more than one line: {text}");
    assert!(text.contains(expect), "{text:?} does not name {expect:?}");
    assert_eq!(snapshot(path), before, "loading changed the bake directory");
    error
}

fn edit_manifest(path: &Path, edit: impl FnOnce(&mut serde_json::Value)) {
    let manifest = path.join(MANIFEST_FILE);
    let mut value: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&manifest).unwrap()).unwrap();
    edit(&mut value);
    std::fs::write(&manifest, value.to_string()).unwrap();
}

#[test]
fn damaged_exr_files_are_refused() {
    let (_dir, path, scene) = saved_bake();
    let radiance = path.join("radiance.exr");
    let original = std::fs::read(&radiance).unwrap();
    // Truncated.
    std::fs::write(&radiance, &original[..original.len() * 2 / 3]).unwrap();
    let error = refused(&path, Some(&scene), "radiance.exr");
    assert!(matches!(error, BakeLoadError::Exr { .. }), "{error:?}");
    // Swapped with another file of the same bake: the channels are not there.
    std::fs::copy(path.join("geometry.exr"), &radiance).unwrap();
    let error = refused(&path, Some(&scene), "radiance.R");
    assert!(
        matches!(error, BakeLoadError::MissingChannel { .. }),
        "{error:?}"
    );
    // Not EXR at all.
    std::fs::write(&radiance, b"{\"format\": \"probe-capture bake\"}").unwrap();
    let error = refused(&path, Some(&scene), "radiance.exr");
    assert!(matches!(error, BakeLoadError::Exr { .. }), "{error:?}");
    // A NaN texel.
    std::fs::write(&radiance, &original).unwrap();
    let mut image = exr::prelude::read_all_flat_layers_from_file(&radiance).unwrap();
    match &mut image.layer_data[0].channel_data.list[1].sample_data {
        exr::prelude::FlatSamples::F32(samples) => samples[7] = f32::NAN,
        other => panic!("{other:?}"),
    }
    image.write().to_file(&radiance).unwrap();
    let error = refused(&path, Some(&scene), "non-finite");
    assert!(
        matches!(error, BakeLoadError::NonFiniteTexel { texel: 7, .. }),
        "{error:?}"
    );
    std::fs::write(&radiance, &original).unwrap();
    assert!(ProbeBake::load(&path, Some(&scene)).is_ok());
}

#[test]
fn damaged_manifests_are_refused() {
    let (_dir, path, scene) = saved_bake();
    let manifest = path.join(MANIFEST_FILE);
    let original = std::fs::read_to_string(&manifest).unwrap();
    let restore = || std::fs::write(&manifest, &original).unwrap();

    // Wrong counts.
    edit_manifest(&path, |m| m["probe_count"] = serde_json::json!(3));
    let error = refused(&path, Some(&scene), "probe_count");
    assert!(matches!(error, BakeLoadError::InvalidManifest { .. }));
    restore();
    edit_manifest(&path, |m| {
        m["positions"].as_array_mut().unwrap().pop();
    });
    refused(&path, Some(&scene), "1 positions");
    restore();
    // NaN: JSON has no NaN, so a NaN written as text is malformed; a number too large for
    // f32 reads as infinity and is refused as not finite.
    std::fs::write(
        &manifest,
        original.replacen(
            "\"positions\": [\n    [\n      0.28",
            "\"positions\": [\n    [\n      NaN",
            1,
        ),
    )
    .unwrap();
    assert_ne!(std::fs::read_to_string(&manifest).unwrap(), original);
    let error = refused(&path, Some(&scene), "manifest.json");
    assert!(matches!(error, BakeLoadError::Manifest { .. }), "{error:?}");
    restore();
    edit_manifest(&path, |m| m["positions"][1][2] = serde_json::json!(1e39));
    refused(&path, Some(&scene), "not finite");
    restore();
    // Zero and huge resolutions.
    for resolution in [0u64, 1 << 20, 3] {
        edit_manifest(&path, |m| {
            m["resolution"] = serde_json::json!(resolution);
            m["settings"]["resolution"] = serde_json::json!(resolution);
        });
        let error = refused(&path, Some(&scene), "resolution");
        assert!(
            matches!(error, BakeLoadError::InvalidManifest { .. }),
            "{resolution}: {error:?}"
        );
        restore();
    }
    // A resolution that disagrees with the EXR files.
    edit_manifest(&path, |m| {
        m["resolution"] = serde_json::json!(16);
        m["settings"]["resolution"] = serde_json::json!(16);
        m["padded_size"] = serde_json::json!(18);
    });
    let error = refused(&path, Some(&scene), "radiance.exr");
    assert!(
        matches!(error, BakeLoadError::WrongLayer { .. }),
        "{error:?}"
    );
    restore();
    assert!(ProbeBake::load(&path, Some(&scene)).is_ok());
}

#[test]
fn missing_files_another_scene_and_memory_are_refused() {
    let (_dir, path, scene) = saved_bake();
    for file in EXR_FILES.iter().chain([&MANIFEST_FILE]) {
        let full = path.join(file);
        let bytes = std::fs::read(&full).unwrap();
        std::fs::remove_file(&full).unwrap();
        let error = refused(&path, Some(&scene), file);
        assert!(
            matches!(error, BakeLoadError::Io { .. }),
            "{file}: {error:?}"
        );
        std::fs::write(&full, bytes).unwrap();
    }
    // A bake of another scene.
    let boxes = Scene::builtin("boxes").unwrap();
    let error = refused(&path, Some(&boxes), "cornell");
    assert!(matches!(error, BakeLoadError::SceneMismatch { .. }));
    // A bake larger than the memory limit is refused before its EXR files are read.
    std::fs::remove_file(path.join("radiance.exr")).unwrap();
    let error =
        ProbeBake::load_with_limit(&path, Some(&scene), MemoryLimit::bytes(4096)).unwrap_err();
    let text = error.to_string();
    assert!(
        matches!(error, BakeLoadError::OverMemory { .. }),
        "{error:?}"
    );
    assert!(
        text.contains("2 probes at 8²") && text.contains("4.0 KiB"),
        "{text}"
    );
}
