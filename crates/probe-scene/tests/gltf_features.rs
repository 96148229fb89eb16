//! glTF features and failures on small hand-written files: node transforms (mirroring, non-uniform
//! scale), lights, cameras, materials with textures and alpha masks, and every kind of refusal.

use glam::{Vec2, Vec3};
use probe_scene::{AlphaMode, Light, LoadError, LoadWarning, Ray, Scene};
use std::path::{Path, PathBuf};

/// The binary buffer: one triangle (positions, normals, uvs, u16 indices).
fn mesh_bin() -> Vec<u8> {
    let mut bytes = Vec::new();
    let floats = |bytes: &mut Vec<u8>, values: &[f32]| {
        for v in values {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
    };
    floats(&mut bytes, &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
    let n = std::f32::consts::FRAC_1_SQRT_2;
    floats(&mut bytes, &[n, n, 0.0, n, n, 0.0, n, n, 0.0]);
    floats(&mut bytes, &[0.0, 0.0, 1.0, 0.0, 0.0, 1.0]);
    for i in [0u16, 1, 2, 0] {
        bytes.extend_from_slice(&i.to_le_bytes());
    }
    assert_eq!(bytes.len(), 104);
    bytes
}

const GLTF: &str = r#"{
  "asset": {"version": "2.0"},
  "extensionsUsed": ["KHR_lights_punctual", "KHR_materials_emissive_strength", "KHR_texture_transform"],
  "extensionsRequired": ["KHR_materials_emissive_strength"REQUIRED],
  "extensions": {"KHR_lights_punctual": {"lights": [
    {"type": "point", "name": "lamp", "color": [1, 0.5, 0.25], "intensity": 20, "range": 10},
    {"type": "spot", "intensity": 5, "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.6}}
  ]}},
  "buffers": [{"uri": "BUFFER", "byteLength": 104}],
  "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 96}, {"buffer": 0, "byteOffset": 96, "byteLength": 8}],
  "accessors": [
    {"bufferView": 0, "byteOffset": 0, "componentType": 5126, "count": POSITION_COUNT, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]SPARSE},
    {"bufferView": 0, "byteOffset": 36, "componentType": 5126, "count": 3, "type": "VEC3"},
    {"bufferView": 0, "byteOffset": 72, "componentType": 5126, "count": 3, "type": "VEC2"},
    {"bufferView": 1, "byteOffset": 0, "componentType": 5123, "count": 3, "type": "SCALAR"}
  ],
  "images": [{"uri": "IMAGE"}],
  "textures": [{"source": 0}],
  "materials": [
    {"name": "lit", "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.25, 1, 1], "metallicFactor": 0.25, "roughnessFactor": 0.75},
     "emissiveFactor": [1, 0.5, 0], "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 4}}},
    {"name": "leaf", "alphaMode": "MASK", "doubleSided": true, "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "metallicFactor": 0}},
    {"name": "glass", "alphaMode": "BLEND"}
  ],
  "meshes": [
    {"name": "tri", "primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}, "indices": 3, "material": 0}]},
    {"name": "leafy", "primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}, "indices": 3, "material": 1}]}
  ],
  "cameras": [{"name": "view", "type": "perspective", "perspective": {"yfov": 0.8, "aspectRatio": 1.5, "znear": 0.1}}],
  "nodes": [
    {"name": "root", "translation": [10, 0, 0], "children": [1, 2, 3, 4, 5]},
    {"name": "mirrored", "scale": [-1, 2, 1], "mesh": 0CHILDREN},
    {"name": "lamp", "translation": [1, 2, 3], "extensions": {"KHR_lights_punctual": {"light": 0}}},
    {"name": "spot", "rotation": [-0.70710678, 0, 0, 0.70710678], "extensions": {"KHR_lights_punctual": {"light": 1}}},
    {"name": "camera node", "translation": [0, 0, 5], "camera": 0},
    {"name": "masked", "translation": [0, 0, -1], "mesh": 1}
  ],
  "scene": 0,
  "scenes": [{"nodes": [0]}]
}"#;

/// Writes `scene.gltf` (the template with substitutions), `mesh.bin` and `mask.png` into a
/// fresh temporary folder.
fn write(substitutions: &[(&str, &str)]) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let mut json = GLTF.to_owned();
    let defaults = [
        ("REQUIRED", ""),
        ("BUFFER", "mesh.bin"),
        ("POSITION_COUNT", "3"),
        ("IMAGE", "mask.png"),
        ("CHILDREN", ""),
        ("SPARSE", ""),
    ];
    for (key, default) in defaults {
        let value = substitutions
            .iter()
            .find(|(k, _)| *k == key)
            .map_or(default, |(_, v)| *v);
        json = json.replace(key, value);
    }
    std::fs::write(dir.path().join("scene.gltf"), json).unwrap();
    std::fs::write(dir.path().join("mesh.bin"), mesh_bin()).unwrap();
    // 2×2 RGBA: red (opaque), green (transparent) / blue (opaque), white (transparent).
    let mask = image::RgbaImage::from_raw(
        2,
        2,
        vec![
            255, 0, 0, 255, 0, 255, 0, 0, 0, 0, 255, 255, 255, 255, 255, 0,
        ],
    )
    .unwrap();
    mask.save(dir.path().join("mask.png")).unwrap();
    let path = dir.path().join("scene.gltf");
    (dir, path)
}

fn load(substitutions: &[(&str, &str)]) -> Result<Scene, LoadError> {
    let (_dir, path) = write(substitutions);
    Scene::load(&path)
}

#[test]
fn node_transforms_mirror_and_scale() {
    let scene = load(&[]).unwrap();
    assert_eq!(scene.triangles().len(), 2);
    assert_eq!(scene.unique_triangle_count(), 2);
    // root T(10, 0, 0) · S(−1, 2, 1): the mirror flips the winding back so the face still
    // faces +Z, as its normals do.
    let mirrored = &scene.triangles()[0];
    let expected = [
        Vec3::new(10.0, 0.0, 0.0),
        Vec3::new(10.0, 2.0, 0.0),
        Vec3::new(9.0, 0.0, 0.0),
    ];
    assert_eq!(mirrored.positions, expected);
    assert_eq!(mirrored.geometric_normal(), Vec3::Z);
    // Normals go through the inverse transpose diag(−1, ½, 1): (1, 1, 0) → (−1, ½, 0).
    let n = Vec3::new(-1.0, 0.5, 0.0).normalize();
    for normal in mirrored.normals {
        assert!((normal - n).length() < 1e-6, "{normal}");
    }
    let hit = scene
        .closest_hit(&Ray::new(Vec3::new(9.8, 0.5, 1.0), -Vec3::Z), f32::INFINITY)
        .unwrap();
    assert_eq!(hit.triangle, 0);
    assert!(hit.front_face);
    assert!((hit.shading_normal - n).length() < 1e-6);
}

#[test]
fn sparse_accessors_substitute_elements() {
    // Replace vertex 2 with the bytes of the first normal, (√½, √½, 0): the sparse index is the
    // u16 `2` at byte 4 of bufferView 1, the value the normal at byte 36 of bufferView 0.
    let sparse = r#", "sparse": {"count": 1, "indices": {"bufferView": 1, "byteOffset": 4, "componentType": 5123}, "values": {"bufferView": 0, "byteOffset": 36}}"#;
    let scene = load(&[("SPARSE", sparse)]).unwrap();
    let h = std::f32::consts::FRAC_1_SQRT_2;
    // Mirrored copy: T(10, 0, 0) · S(−1, 2, 1), winding flipped (p2 stored second).
    let moved = Vec3::new(10.0 - h, 2.0 * h, 0.0);
    assert!((scene.triangles()[0].positions[1] - moved).length() < 1e-6);
    // The masked copy: T(10, 0, −1).
    let moved = Vec3::new(10.0 + h, h, -1.0);
    assert!((scene.triangles()[1].positions[2] - moved).length() < 1e-6);
}

#[test]
fn lights_and_cameras_are_placed_by_their_nodes() {
    let scene = load(&[]).unwrap();
    assert_eq!(scene.lights().len(), 2);
    match &scene.lights()[0] {
        Light::Point {
            name,
            position,
            color,
            intensity,
            range,
        } => {
            assert_eq!(name, "lamp");
            assert_eq!(*position, Vec3::new(11.0, 2.0, 3.0));
            assert_eq!(*color, Vec3::new(1.0, 0.5, 0.25));
            assert_eq!((*intensity, *range), (20.0, Some(10.0)));
        }
        other => panic!("{other:?}"),
    }
    match &scene.lights()[1] {
        Light::Spot {
            name,
            position,
            direction,
            inner_cone,
            outer_cone,
            range,
            ..
        } => {
            assert_eq!(name, "light1");
            assert_eq!(*position, Vec3::new(10.0, 0.0, 0.0));
            assert!((*direction - -Vec3::Y).length() < 1e-6, "{direction}");
            assert_eq!((*inner_cone, *outer_cone, *range), (0.2, 0.6, None));
        }
        other => panic!("{other:?}"),
    }
    let camera = scene.camera("view").unwrap();
    assert_eq!(camera.position, Vec3::new(10.0, 0.0, 5.0));
    assert_eq!(camera.forward, -Vec3::Z);
    assert_eq!(camera.up, Vec3::Y);
    assert_eq!((camera.yfov, camera.aspect), (0.8, Some(1.5)));
    assert_eq!(scene.default_camera(), *camera);
}

#[test]
fn materials_factors_textures_and_warnings() {
    let scene = load(&[]).unwrap();
    let materials = scene.materials();
    assert_eq!(materials.len(), 3);
    let lit = &materials[0];
    assert_eq!(lit.base_color, Vec3::new(0.5, 0.25, 1.0));
    assert_eq!((lit.metallic, lit.roughness), (0.25, 0.75));
    assert_eq!(lit.emissive, Vec3::new(4.0, 2.0, 0.0));
    assert!(!lit.double_sided && lit.alpha == AlphaMode::Opaque);
    // The mask's mean colour is over its opaque texels: red and blue.
    let leaf = &materials[1];
    assert!((leaf.base_color - Vec3::new(0.5, 0.0, 0.5)).length() < 1e-6);
    assert!(leaf.double_sided);
    match &leaf.alpha {
        AlphaMode::Mask {
            cutoff,
            texture: Some(texture),
            ..
        } => {
            assert_eq!(*cutoff, 0.5);
            assert_eq!((texture.width(), texture.height()), (2, 2));
            assert_eq!(texture.alpha(), &[255, 0, 255, 0]);
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(materials[2].alpha, AlphaMode::Blend);
    let warnings = scene.warnings();
    assert!(warnings.contains(&LoadWarning::IgnoredExtension {
        extension: "KHR_texture_transform".into()
    }));
    assert!(warnings.contains(&LoadWarning::BlendTreatedAsOpaque {
        material: "glass".into()
    }));
    assert_eq!(warnings.len(), 2, "{warnings:?}");
}

#[test]
fn mask_texture_cuts_the_loaded_triangle() {
    let scene = load(&[]).unwrap();
    // The masked copy spans x ∈ [10, 11], y ∈ [0, 1] at z = −1 with uv = (x − 10, y).
    let at = |x: f32, y: f32| {
        scene
            .closest_hit(&Ray::new(Vec3::new(x, y, 1.0), -Vec3::Z), f32::INFINITY)
            .map(|h| (h.triangle, h.t))
    };
    assert_eq!(at(10.25, 0.25), Some((1, 2.0))); // red texel
    assert_eq!(at(10.75, 0.2), None); // green, transparent
    assert_eq!(at(10.2, 0.7), Some((1, 2.0))); // blue texel
    let uv = scene.triangles()[1].uv(Vec2::new(0.75, 0.2));
    assert_eq!(uv, Vec2::new(0.75, 0.2));
}

#[test]
fn missing_buffer_is_named() {
    match load(&[("BUFFER", "missing.bin")]).unwrap_err() {
        LoadError::MissingFile {
            what,
            uri,
            resolved,
            path,
        } => {
            assert_eq!((what.as_str(), uri.as_str()), ("buffer 0", "missing.bin"));
            assert!(resolved.ends_with("missing.bin"));
            assert!(path.ends_with("scene.gltf"));
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn missing_image_is_named() {
    let error = load(&[("IMAGE", "textures/missing%20leaf.png")]).unwrap_err();
    match &error {
        LoadError::MissingFile {
            what,
            uri,
            resolved,
            ..
        } => {
            assert_eq!(what, "image 0");
            assert_eq!(uri, "textures/missing%20leaf.png");
            assert!(resolved.ends_with(Path::new("textures/missing leaf.png")));
        }
        other => panic!("{other:?}"),
    }
    assert!(error.to_string().contains("missing%20leaf.png"));
}

#[test]
fn required_extension_no_item_uses_is_a_warning() {
    // Required, but no item of the file carries it: nothing it could change (the refusal of
    // a used one is in `hostile_gltf.rs`).
    let scene = load(&[("REQUIRED", r#", "KHR_draco_mesh_compression""#)]).unwrap();
    assert!(
        scene.warnings().iter().any(|w| matches!(w,
            LoadWarning::RequiredExtensionUnused { extension } if extension == "KHR_draco_mesh_compression")),
        "{:?}",
        scene.warnings()
    );
}

#[test]
fn accessor_past_its_buffer_is_named() {
    let error = load(&[("POSITION_COUNT", "300")]).unwrap_err();
    match &error {
        LoadError::BadAccessor {
            accessor, reason, ..
        } => {
            assert_eq!(*accessor, 0);
            assert!(reason.contains("past"), "{reason}");
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn node_cycle_is_refused() {
    let error = load(&[("CHILDREN", r#", "children": [0]"#)]).unwrap_err();
    assert!(matches!(error, LoadError::NodeCycle { .. }), "{error:?}");
    // A node with two parents is refused too (glTF node hierarchies are forests).
    let error = load(&[("CHILDREN", r#", "children": [5]"#)]).unwrap_err();
    assert!(
        matches!(&error, LoadError::Invalid { problems, .. } if problems.contains("nodes[5]")),
        "{error:?}"
    );
}

#[test]
fn unsupported_uri_scheme_is_refused() {
    let error = load(&[("BUFFER", "https://example.com/mesh.bin")]).unwrap_err();
    assert!(
        matches!(&error, LoadError::BadReference { what, .. } if what == "buffer 0"),
        "{error:?}"
    );
}

#[test]
fn missing_and_garbage_files() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("nothing.gltf");
    match Scene::load(&missing).unwrap_err() {
        LoadError::Read { path, source } => {
            assert_eq!(path, missing);
            assert_eq!(source.kind(), std::io::ErrorKind::NotFound);
        }
        other => panic!("{other:?}"),
    }
    // Pseudo-random bytes, a truncated GLB header, JSON that is not glTF, and an empty file.
    let mut state = 0x9e37_79b9_u32;
    let noise: Vec<u8> = (0..4096)
        .map(|_| {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            state as u8
        })
        .collect();
    let cases: [(&str, &[u8]); 4] = [
        ("noise.glb", &noise),
        ("truncated.glb", b"glTF\x02\x00\x00\x00\xff\xff"),
        ("object.gltf", br#"{"meshes": 3}"#),
        ("empty.gltf", b""),
    ];
    for (name, bytes) in cases {
        let path = dir.path().join(name);
        std::fs::write(&path, bytes).unwrap();
        let error = Scene::load(&path).unwrap_err();
        assert!(
            matches!(error, LoadError::NotGltf { .. }),
            "{name}: {error:?}"
        );
        assert!(error.to_string().contains(name), "{error}");
    }
    // A directory is not a file.
    assert!(matches!(
        Scene::load(dir.path()).unwrap_err(),
        LoadError::Read { .. }
    ));
    // `open` routes paths to `load`.
    assert!(matches!(
        Scene::open(missing.to_str().unwrap()).unwrap_err(),
        LoadError::Read { .. }
    ));
}
