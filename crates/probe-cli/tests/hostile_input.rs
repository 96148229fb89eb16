//! The command line on hostile input (issue 15): load warnings in `scene-info` and `--json`,
//! requests over `--max-memory` refused in one line before work starts, and a failed bake
//! writing nothing over the bake already there.

mod support;

use probe_testdata::folder_contents;
use std::path::Path;
use support::{probes, stderr};

/// One triangle, and a texture pointing at an image that does not exist, which no material
/// uses.
fn dangling_texture_scene(dir: &Path) -> String {
    let mut bin = Vec::new();
    for v in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0] {
        bin.extend_from_slice(&v.to_le_bytes());
    }
    std::fs::write(dir.join("mesh.bin"), bin).unwrap();
    let json = r#"{"asset": {"version": "2.0"},
      "buffers": [{"uri": "mesh.bin", "byteLength": 36}],
      "bufferViews": [{"buffer": 0, "byteLength": 36}],
      "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}],
      "textures": [{"source": 3}],
      "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
      "nodes": [{"mesh": 0}], "scene": 0, "scenes": [{"nodes": [0]}]}"#;
    let path = dir.join("dangling.gltf");
    std::fs::write(&path, json).unwrap();
    path.to_string_lossy().into_owned()
}

#[test]
fn scene_info_lists_warnings_and_bake_prints_them() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dangling_texture_scene(dir.path());
    let output = probes(&["scene-info", &scene, "--json"]);
    assert!(output.status.success(), "{}", stderr(&output));
    let report: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
    let warnings = report["warnings"].as_array().unwrap();
    assert!(
        warnings
            .iter()
            .any(|w| w.as_str().unwrap().contains("textures[0].source")),
        "{warnings:?}"
    );
    let out = dir.path().join("bake");
    let output = probes(&[
        "bake",
        &scene,
        "--probes",
        "grid:1x1x1",
        "--res",
        "4",
        "--spp",
        "1",
        "--bounces",
        "0",
        "--out",
        out.to_str().unwrap(),
        "--json",
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(
        stderr(&output).contains("probes: warning: dangling: textures[0].source"),
        "{}",
        stderr(&output)
    );
    let report: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
    assert_eq!(
        report["scene_warnings"].as_array().unwrap().len(),
        warnings.len()
    );
}

#[test]
fn over_the_memory_limit_is_refused_and_nothing_is_written_over() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("bake");
    let bake = |extra: &[&str]| {
        let mut args = vec![
            "bake",
            "builtin:cornell",
            "--probes",
            "grid:1x1x1",
            "--spp",
            "1",
            "--bounces",
            "0",
            "--out",
            out.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        probes(&args)
    };
    let output = bake(&["--res", "4"]);
    assert!(output.status.success(), "{}", stderr(&output));
    let before = folder_contents(&out).unwrap();
    let output = bake(&["--res", "1024", "--max-memory", "64M"]);
    assert!(!output.status.success());
    let text = stderr(&output);
    assert_eq!(text.trim_end().lines().count(), 1, "{text}");
    assert!(
        text.contains("a bake of 1 probes at 1024²") && text.contains("64.0 MiB"),
        "{text}"
    );
    let after = folder_contents(&out).unwrap();
    assert_eq!(
        after, before,
        "the refused bake changed the bake already there"
    );
    // A malformed size is an argument error.
    let output = bake(&["--res", "4", "--max-memory", "lots"]);
    assert!(!output.status.success());
    assert!(
        stderr(&output).contains("not a memory size"),
        "{}",
        stderr(&output)
    );
    // Render refuses an image too large for the limit before loading anything.
    let output = probes(&[
        "render",
        out.to_str().unwrap(),
        "--width",
        "100000",
        "--height",
        "100000",
        "--out",
        dir.path().join("x.exr").to_str().unwrap(),
        "--max-memory",
        "1G",
    ]);
    assert!(!output.status.success());
    assert!(
        stderr(&output).contains("a 100000×100000 render"),
        "{}",
        stderr(&output)
    );
    assert!(!dir.path().join("x.exr").exists());
}
