//! Lenient where a defect cannot change the scene, strict where it could: small hand-made
//! glTF files, one per case (issue 15). Lenient cases load with a warning naming the item and
//! why going on was safe; strict cases are refused with an error naming the item.

use glam::Vec3;
use probe_scene::memory::MemoryLimit;
use probe_scene::{LoadError, LoadWarning, Scene};
use std::path::PathBuf;

/// One triangle: three f32 VEC3 positions (36 bytes), three u16 indices (6 bytes), padding.
fn mesh_bin() -> Vec<u8> {
    let mut bytes = Vec::new();
    for v in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0] {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    for i in [0u16, 1, 2, 0] {
        bytes.extend_from_slice(&i.to_le_bytes());
    }
    bytes
}

/// A 4×4 DDS (DXT1) image, every texel pure red.
fn red_dds() -> Vec<u8> {
    let mut bytes = b"DDS ".to_vec();
    let mut u32s = |values: &[u32]| {
        for v in values {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
    };
    // size, flags (caps | height | width | pixel format), height, width, linear size, depth,
    // mip maps, 11 reserved.
    u32s(&[124, 0x1007, 4, 4, 8, 0, 0]);
    u32s(&[0; 11]);
    // Pixel format: size, flags (FOURCC), "DXT1", bit count and four masks.
    u32s(&[32, 0x4]);
    bytes.extend_from_slice(b"DXT1");
    let mut u32s = |values: &[u32]| {
        for v in values {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
    };
    u32s(&[0; 5]);
    // caps (TEXTURE), caps2, caps3, caps4, reserved.
    u32s(&[0x1000, 0, 0, 0, 0]);
    assert_eq!(bytes.len(), 128);
    // One block: both end colours red (RGB565 0xF800), every index 0.
    bytes.extend_from_slice(&[0x00, 0xF8, 0x00, 0xF8, 0, 0, 0, 0]);
    bytes
}

/// The file: `{EXTRA}` is spliced in at the top level, `{PRIMITIVE}` into the primitive,
/// `{MATERIAL}` into the material.
const TEMPLATE: &str = r#"{
  "asset": {"version": "2.0"},
  "buffers": [{"uri": "mesh.bin", "byteLength": 44}],
  "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 8}],
  "accessors": [
    {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
    {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}
  ],
  "materials": [{"name": "m", "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1]}MATERIAL}],
  "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "material": 0PRIMITIVE}]}],
  "nodes": [{"mesh": 0}],
  "scene": 0,
  "scenes": [{"nodes": [0]}]EXTRA
}"#;

fn write(extra: &str, material: &str, primitive: &str) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let json = TEMPLATE
        .replace("EXTRA", extra)
        .replace("MATERIAL", material)
        .replace("PRIMITIVE", primitive);
    let path = dir.path().join("scene.gltf");
    std::fs::write(&path, json).unwrap();
    std::fs::write(dir.path().join("mesh.bin"), mesh_bin()).unwrap();
    std::fs::write(dir.path().join("red.dds"), red_dds()).unwrap();
    (dir, path)
}

fn load(extra: &str, material: &str, primitive: &str) -> Result<Scene, LoadError> {
    let (_dir, path) = write(extra, material, primitive);
    Scene::load(&path)
}

fn texture_of_missing_image() -> &'static str {
    r#", "images": [{"uri": "red.dds"}], "textures": [{"source": 0}, {"source": 7}]"#
}

// ---- lenient ----

#[test]
fn dangling_texture_no_material_uses_is_a_warning() {
    let scene = load(texture_of_missing_image(), "", "").unwrap();
    assert_eq!(scene.triangles().len(), 1);
    assert_eq!(scene.materials()[0].base_color, Vec3::splat(0.5));
    let warning = scene
        .warnings()
        .iter()
        .find_map(|w| match w {
            LoadWarning::UnreadDefect { item, safe, .. } => Some((item.clone(), safe.clone())),
            _ => None,
        })
        .expect("a warning for the dangling texture");
    assert_eq!(warning.0, "textures[1].source");
    assert!(warning.1.contains("texture 1"), "{}", warning.1);
    let text = scene
        .warnings()
        .iter()
        .map(ToString::to_string)
        .collect::<Vec<_>>();
    assert!(
        text.iter().any(|t| t.contains("textures[1].source")),
        "{text:?}"
    );
}

#[test]
fn dangling_normal_map_is_a_warning() {
    let scene = load("", r#", "normalTexture": {"index": 4}"#, "").unwrap();
    assert!(
        scene.warnings().iter().any(|w| matches!(w,
            LoadWarning::UnreadDefect { item, .. } if item.starts_with("materials[0].normalTexture"))),
        "{:?}",
        scene.warnings()
    );
}

#[test]
fn required_extension_without_subject_is_a_warning() {
    // The file of issue 15: MSFT_texture_dds required, no images at all. And a required
    // compression extension that no primitive uses.
    for extension in ["MSFT_texture_dds", "KHR_draco_mesh_compression"] {
        let extra = format!(
            r#", "extensionsUsed": ["{extension}"], "extensionsRequired": ["{extension}"]"#
        );
        let scene = load(&extra, "", "").unwrap();
        assert_eq!(scene.triangles().len(), 1);
        if extension != "MSFT_texture_dds" {
            assert!(
                scene.warnings().iter().any(|w| matches!(w,
                LoadWarning::RequiredExtensionUnused { extension: e } if e == extension)),
                "{extension}: {:?}",
                scene.warnings()
            );
        }
    }
}

#[test]
fn dds_only_texture_is_decoded_for_its_mean() {
    let extra = r#", "extensionsUsed": ["MSFT_texture_dds"], "extensionsRequired": ["MSFT_texture_dds"],
        "images": [{"uri": "red.dds", "mimeType": "image/vnd-ms.dds"}],
        "textures": [{"extensions": {"MSFT_texture_dds": {"source": 0}}}]"#;
    let (_dir, path) = write(extra, "", "");
    let json = std::fs::read_to_string(&path).unwrap().replace(
        r#""baseColorFactor": [0.5, 0.5, 0.5, 1]"#,
        r#""baseColorFactor": [0.5, 0.5, 0.5, 1], "baseColorTexture": {"index": 0}"#,
    );
    std::fs::write(&path, json).unwrap();
    let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
    let color = scene.materials()[0].base_color;
    assert!(
        (color - Vec3::new(0.5, 0.0, 0.0)).abs().max_element() < 1e-6,
        "{color}"
    );
    assert!(
        scene.warnings().iter().any(|w| matches!(w,
            LoadWarning::DecodedImageFormat { image: 0, format } if format == "DDS")),
        "{:?}",
        scene.warnings()
    );
    // A texture whose only source is the extension's is valid under it: no defect reported.
    assert!(
        !scene
            .warnings()
            .iter()
            .any(|w| matches!(w, LoadWarning::UnreadDefect { .. })),
        "{:?}",
        scene.warnings()
    );
}

// ---- strict ----

#[test]
fn dangling_texture_a_material_uses_is_refused() {
    let error = load(
        texture_of_missing_image(),
        r#", "emissiveFactor": [1, 1, 1], "emissiveTexture": {"index": 1}"#,
        "",
    )
    .unwrap_err();
    assert!(
        matches!(&error, LoadError::Invalid { problems, .. } if problems.contains("textures[1].source")),
        "{error:?}"
    );
}

#[test]
fn used_compression_is_refused() {
    let draco = r#", "extensionsUsed": ["KHR_draco_mesh_compression"], "extensionsRequired": ["KHR_draco_mesh_compression"]"#;
    let error = load(
        draco,
        "",
        r#", "extensions": {"KHR_draco_mesh_compression": {"bufferView": 0, "attributes": {"POSITION": 0}}}"#,
    )
    .unwrap_err();
    assert!(
        matches!(&error, LoadError::UnsupportedExtension { extension, .. } if extension == "KHR_draco_mesh_compression"),
        "{error:?}"
    );
    let (_dir, path) = write(
        r#", "extensionsUsed": ["EXT_meshopt_compression"], "extensionsRequired": ["EXT_meshopt_compression"]"#,
        "",
        "",
    );
    let json = std::fs::read_to_string(&path).unwrap().replace(
        r#""byteLength": 36}"#,
        r#""byteLength": 36, "extensions": {"EXT_meshopt_compression": {"buffer": 0, "byteLength": 36, "byteStride": 12, "count": 3, "mode": "ATTRIBUTES"}}}"#,
    );
    std::fs::write(&path, json).unwrap();
    let error = Scene::load(&path).unwrap_err();
    assert!(
        matches!(&error, LoadError::UnsupportedExtension { extension, .. } if extension == "EXT_meshopt_compression"),
        "{error:?}"
    );
    assert!(error.to_string().contains("EXT_meshopt_compression"));
}

#[test]
fn broken_accessors_and_indices_are_refused() {
    let (_dir, path) = write("", "", "");
    let original = std::fs::read_to_string(&path).unwrap();
    // More positions than the view holds.
    std::fs::write(
        &path,
        original.replacen(
            r#""count": 3, "type": "VEC3""#,
            r#""count": 4, "type": "VEC3""#,
            1,
        ),
    )
    .unwrap();
    assert!(matches!(
        Scene::load(&path).unwrap_err(),
        LoadError::BadAccessor { accessor: 0, .. }
    ));
    // An index past the vertices.
    let mut bin = mesh_bin();
    bin[36..38].copy_from_slice(&9u16.to_le_bytes());
    std::fs::write(&path, &original).unwrap();
    std::fs::write(path.with_file_name("mesh.bin"), &bin).unwrap();
    assert!(matches!(
        Scene::load(&path).unwrap_err(),
        LoadError::IndexOutOfRange { index: 9, .. }
    ));
    // A non-finite position.
    let mut bin = mesh_bin();
    bin[12..16].copy_from_slice(&f32::NAN.to_le_bytes());
    std::fs::write(path.with_file_name("mesh.bin"), &bin).unwrap();
    assert!(matches!(
        Scene::load(&path).unwrap_err(),
        LoadError::NonFinitePosition {
            accessor: 0,
            element: 1,
            ..
        }
    ));
}

#[test]
fn declared_size_over_the_limit_is_refused_before_decoding() {
    // 2^21 − 1 view-less positions (zeros but one sparse substitution: the file's size does
    // not bound them) make 699,050 triangles per drawing, drawn by 64 nodes: 44.7 M triangles
    // declared.
    let nodes: Vec<String> = (0..64).map(|_| r#"{"mesh": 0}"#.to_owned()).collect();
    let roots: Vec<String> = (0..64).map(|i| i.to_string()).collect();
    let (_dir, path) = write("", "", "");
    let json = std::fs::read_to_string(&path)
        .unwrap()
        .replace(
            r#""accessors": ["#,
            r#""accessors": [{"componentType": 5126, "count": 2097151, "type": "VEC3", "min": [0, 0, 0], "max": [1, 0, 0],
                "sparse": {"count": 1, "indices": {"bufferView": 1, "componentType": 5123}, "values": {"bufferView": 0}}}, "#,
        )
        .replace(r#""POSITION": 0}, "indices": 1"#, r#""POSITION": 1}, "indices": 2"#)
        .replace(
            r#""meshes": ["#,
            r#""meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}, "#,
        )
        .replace(r#""nodes": [{"mesh": 0}]"#, &format!(r#""nodes": [{}]"#, nodes.join(", ")))
        .replace(r#""nodes": [0]"#, &format!(r#""nodes": [{}]"#, roots.join(", ")));
    std::fs::write(&path, json).unwrap();
    let start = std::time::Instant::now();
    let error = Scene::load_with_limit(&path, MemoryLimit::bytes(1 << 30)).unwrap_err();
    match &error {
        LoadError::TooLarge { source, .. } => {
            assert_eq!(source.limit, 1 << 30);
            assert!(source.estimate > 1 << 30);
            assert!(
                source.what.contains("44739200 triangles"),
                "{}",
                source.what
            );
        }
        other => panic!("{other:?}"),
    }
    let text = error.to_string();
    assert!(
        text.contains("GiB") && text.contains("--max-memory"),
        "{text}"
    );
    // Refused up front: decoding 44.7 M triangles would take far longer.
    assert!(start.elapsed().as_secs_f64() < 2.0);
}

/// Every shared failure file (and the published Sponza, which must be refused): loads, or is
/// refused with one error line naming the file; never a panic.
#[test]
fn every_shared_failure_file_loads_or_is_refused_in_one_line() {
    let root = probe_testdata::scene_path("failure_cases");
    let mut files = vec![probe_testdata::scene_path("sponza/Sponza.gltf")];
    let mut dirs = vec![root];
    while let Some(dir) = dirs.pop() {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                dirs.push(path);
            } else if path.extension().is_some_and(|e| e == "gltf" || e == "glb") {
                files.push(path);
            }
        }
    }
    files.sort();
    assert!(files.len() >= 21, "{files:?}");
    let mut refused = 0;
    for file in &files {
        match Scene::load(file) {
            Ok(scene) => assert!(
                scene
                    .triangles()
                    .iter()
                    .all(|t| t.positions.iter().all(|p| p.is_finite())),
                "{}",
                file.display()
            ),
            Err(error) => {
                refused += 1;
                let text = error.to_string();
                assert!(!text.contains('\n'), "{text}");
                assert!(text.contains(&*file.to_string_lossy()), "{text}");
            }
        }
    }
    // The two invalid files and the published Sponza.
    assert_eq!(refused, 3);
}
