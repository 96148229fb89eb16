//! Where the sweep and the failure suite find files: always an input, never a path built
//! into the crate.

use std::path::{Path, PathBuf};

use probe_eval::failures::SharedScenes;
use probe_eval::sweep::EvalConfig;

#[test]
fn shared_scenes_in_dir_follow_the_shared_layout() {
    let dir = probe_testdata::scenes_dir();
    let shared = SharedScenes::in_dir(&dir);
    assert_eq!(
        shared.two_sided_plane,
        probe_testdata::scene_path(probe_testdata::TWO_SIDED_PLANE)
    );
    assert_eq!(
        shared.cornell_box,
        probe_testdata::scene_path(probe_testdata::CORNELL_BOX)
    );
    assert_eq!(
        shared.godot_room,
        probe_testdata::scene_path(probe_testdata::GODOT_ROOM)
    );
    assert_eq!(
        shared.invalid,
        [
            probe_testdata::INVALID_INFINITES,
            probe_testdata::INVALID_INDEX_OUT_OF_RANGE,
            probe_testdata::SPONZA_AS_PUBLISHED,
        ]
        .map(probe_testdata::scene_path)
        .to_vec()
    );
    if probe_testdata::scenes_available() {
        for file in [
            &shared.two_sided_plane,
            &shared.cornell_box,
            &shared.godot_room,
        ]
        .into_iter()
        .chain(&shared.invalid)
        {
            assert!(file.is_file(), "{} is missing", file.display());
        }
    }
}

#[test]
fn relative_paths_in_a_configuration_are_relative_to_its_file() {
    let dir = tempfile::tempdir().unwrap();
    let config_dir = dir.path().join("configs");
    std::fs::create_dir_all(&config_dir).unwrap();
    let path = config_dir.join("eval.toml");
    std::fs::write(
        &path,
        r#"
scenes_dir = "../scenes"
[[scenes]]
scene = "builtin:cornell"
[[scenes]]
scene = "rooms/room.glb"
[[scenes]]
scene = "/abs/room.glb"
"#,
    )
    .unwrap();
    let config = EvalConfig::load(&path).unwrap();
    assert_eq!(config.scenes_dir, Some(config_dir.join("../scenes")));
    let scenes: Vec<&str> = config.scenes.iter().map(|s| s.scene.as_str()).collect();
    assert_eq!(scenes[0], "builtin:cornell");
    assert_eq!(PathBuf::from(scenes[1]), config_dir.join("rooms/room.glb"));
    assert_eq!(scenes[2], "/abs/room.glb");
}

#[test]
fn the_old_key_shared_scenes_is_still_read() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("eval.toml");
    std::fs::write(&path, "shared_scenes = \"scenes\"\n").unwrap();
    let config = EvalConfig::load(&path).unwrap();
    assert_eq!(config.scenes_dir, Some(dir.path().join("scenes")));
}

#[test]
fn a_configuration_with_no_scenes_dir_names_none() {
    assert_eq!(EvalConfig::default().scenes_dir, None);
    // The repository's eval.toml names the shared scenes beside the checkout.
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let config = EvalConfig::load(&root.join("eval.toml")).unwrap();
    let dir = config.scenes_dir.expect("eval.toml names scenes_dir");
    assert!(dir.ends_with("../shared/scenes"), "{}", dir.display());
    // Where the scenes are found beside the checkout (not moved by `PROBE_SCENES_DIR`),
    // eval.toml's folder holds them.
    if probe_testdata::scenes_available() && std::env::var_os("PROBE_SCENES_DIR").is_none() {
        assert!(dir.join(probe_testdata::CORNELL_BOX).is_file());
    }
}

#[test]
fn an_unreadable_configuration_is_refused_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("eval.toml");
    std::fs::write(&path, "no_such_key = 1\n").unwrap();
    let error = EvalConfig::load(&path).unwrap_err().to_string();
    assert!(
        error.contains("eval.toml") && error.contains("no_such_key"),
        "{error}"
    );
}

/// Every sweep configuration at the repository's root loads (a key renamed in `EvalConfig`
/// would otherwise break a documented command silently), and the one for issue 12's protocol
/// asks for it; the default does not.
#[test]
fn the_repository_configurations_load() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let mut loaded = Vec::new();
    for entry in std::fs::read_dir(&root).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        if name.starts_with("eval") && name.ends_with(".toml") {
            let config = EvalConfig::load(&path).unwrap_or_else(|e| panic!("{name}: {e}"));
            assert_eq!(
                config.learn_from_evaluation_views,
                name == "eval-views-learned.toml",
                "{name}"
            );
            loaded.push(name);
        }
    }
    assert!(loaded.len() >= 4, "{loaded:?}");
    assert!(!EvalConfig::default().learn_from_evaluation_views);
}
