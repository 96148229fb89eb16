//! glTF 2.0 loading: document, buffers, node hierarchy, instancing, materials, lights, cameras.
//!
//! The document is parsed without the `gltf` crate's validation, then validated here so that a
//! few benign deviations (POSITION without `min`/`max`) become warnings, required extensions are
//! checked against what this crate honours, and every error names the file and the item.
//! Buffers and images are read here too (not through `gltf::import`), so that a missing file is
//! reported by its URI.

mod accessor;
mod images;

use crate::camera::Camera;
use crate::error::{LoadError, LoadWarning};
use crate::geometry::Triangle;
use crate::light::Light;
use crate::material::{AlphaMode, Material};
use crate::memory::MemoryLimit;
use accessor::{AccessorProblem, read_f32, read_indices};
use glam::{Mat3, Mat4, Quat, Vec2, Vec3, Vec4};
use gltf::accessor::Dimensions;
use gltf::mesh::Mode;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Extensions whose meaning this loader implements; a file may require these.
pub(crate) const HONOURED_EXTENSIONS: &[&str] = &[
    "KHR_lights_punctual",
    "KHR_materials_emissive_strength",
    "EXT_mesh_gpu_instancing",
];

const INSTANCING: &str = "EXT_mesh_gpu_instancing";

/// Everything read from a file, ready to become a `Scene`.
pub(crate) struct LoadedScene {
    pub triangles: Vec<Triangle>,
    pub materials: Vec<Material>,
    pub lights: Vec<Light>,
    pub cameras: Vec<Camera>,
    pub unique_triangle_count: usize,
    pub warnings: Vec<LoadWarning>,
}

/// One mesh primitive decoded in its mesh's local space (shared by all instances).
struct LocalPrimitive {
    positions: Vec<Vec3>,
    normals: Option<Vec<Vec3>>,
    uvs: Option<Vec<Vec2>>,
    triangles: Vec<[u32; 3]>,
    material: u32,
}

/// Counts of skipped non-triangle primitives per mode.
#[derive(Default)]
struct Skipped {
    primitives: usize,
    elements: usize,
}

struct Loader<'a> {
    path: &'a Path,
    limit: MemoryLimit,
    base: PathBuf,
    document: &'a gltf::Document,
    buffers: Vec<Vec<u8>>,
    warnings: Vec<LoadWarning>,
    /// Decoded primitives per mesh, filled on first use.
    meshes: HashMap<usize, Arc<Vec<LocalPrimitive>>>,
    skipped: [Skipped; 4],
    default_material: Option<u32>,
    material_count: u32,
    triangles: Vec<Triangle>,
    lights: Vec<Light>,
    cameras: Vec<Camera>,
    ignored: Vec<String>,
}

/// Loads a `.gltf` or `.glb` file.
pub(crate) fn load(path: &Path, limit: MemoryLimit) -> Result<LoadedScene, LoadError> {
    let bytes = std::fs::read(path).map_err(|source| LoadError::Read {
        path: path.to_owned(),
        source,
    })?;
    // The gltf crate subtracts the 12-byte header from a GLB's declared length unchecked
    // (found by fuzzing: an overflow panic with overflow checks on).
    if bytes.starts_with(b"glTF") {
        let declared = bytes
            .get(8..12)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]));
        if declared.is_none_or(|length| length < 12) {
            return Err(LoadError::NotGltf {
                path: path.to_owned(),
                message: format!(
                    "GLB header declares a total length of {}, less than its own 12 bytes",
                    declared.map_or_else(|| "nothing".to_owned(), |l| l.to_string())
                ),
            });
        }
    }
    let gltf =
        gltf::Gltf::from_slice_without_validation(&bytes).map_err(|e| LoadError::NotGltf {
            path: path.to_owned(),
            message: e.to_string(),
        })?;
    let gltf::Gltf { document, blob } = gltf;
    let mut warnings = Vec::new();
    let json =
        gltf::json::serialize::to_value(document.as_json()).map_err(|e| LoadError::NotGltf {
            path: path.to_owned(),
            message: e.to_string(),
        })?;
    check_extensions(path, &document, &json, &mut warnings)?;
    drop(json);
    validate(path, &document, &mut warnings)?;

    let base = path.parent().map(Path::to_owned).unwrap_or_default();
    let buffers = load_buffers(path, &base, &document, blob)?;
    let mut loader = Loader {
        path,
        limit,
        base,
        document: &document,
        buffers,
        warnings,
        meshes: HashMap::new(),
        skipped: Default::default(),
        default_material: None,
        material_count: document.materials().len() as u32,
        triangles: Vec::new(),
        lights: Vec::new(),
        cameras: Vec::new(),
        ignored: Vec::new(),
    };
    loader.walk_scene()?;
    let mut materials = images::load_materials(
        loader.path,
        &loader.base,
        &document,
        &loader.buffers,
        &mut loader.warnings,
    )?;
    if loader.default_material.is_some() {
        materials.push(Material::gltf_default());
    }
    for (mode, skipped) in ["POINTS", "LINES", "LINE_LOOP", "LINE_STRIP"]
        .into_iter()
        .zip(&loader.skipped)
    {
        if skipped.primitives > 0 {
            loader.warnings.push(LoadWarning::SkippedPrimitives {
                mode,
                primitives: skipped.primitives,
                elements: skipped.elements,
            });
        }
    }
    for feature in std::mem::take(&mut loader.ignored) {
        loader
            .warnings
            .push(LoadWarning::IgnoredFeature { feature });
    }
    let unique_triangle_count = loader
        .meshes
        .values()
        .map(|primitives| primitives.iter().map(|p| p.triangles.len()).sum::<usize>())
        .sum();
    Ok(LoadedScene {
        triangles: loader.triangles,
        materials,
        lights: loader.lights,
        cameras: loader.cameras,
        unique_triangle_count,
        warnings: loader.warnings,
    })
}

/// Texture-format extensions this loader can decode for the mean colour it keeps (through
/// the `image` crate's decoders), with the cargo feature that enables each.
pub(crate) const DECODED_TEXTURE_FORMATS: &[(&str, bool)] =
    &[("MSFT_texture_dds", cfg!(feature = "dds"))];

/// Extensions that change how existing items are read without adding data of their own, so
/// their absence from every item says nothing: they stay refused when required.
const EXTENSIONS_WITHOUT_DATA: &[&str] = &["KHR_mesh_quantization"];

/// Whether any `extensions` object of the document (at any depth) holds `extension`.
fn extension_present(value: &gltf::json::Value, extension: &str) -> bool {
    match value {
        gltf::json::Value::Object(map) => map.iter().any(|(key, child)| {
            (key == "extensions"
                && child
                    .as_object()
                    .is_some_and(|extensions| extensions.contains_key(extension)))
                || extension_present(child, extension)
        }),
        gltf::json::Value::Array(items) => items.iter().any(|c| extension_present(c, extension)),
        _ => false,
    }
}

fn check_extensions(
    path: &Path,
    document: &gltf::Document,
    json: &gltf::json::Value,
    warnings: &mut Vec<LoadWarning>,
) -> Result<(), LoadError> {
    for extension in document.extensions_required() {
        if HONOURED_EXTENSIONS.contains(&extension) {
            continue;
        }
        let decoded = DECODED_TEXTURE_FORMATS
            .iter()
            .any(|&(name, enabled)| name == extension && enabled);
        if decoded {
            // Honoured: textures that carry it are decoded (see `images`).
            continue;
        }
        if !EXTENSIONS_WITHOUT_DATA.contains(&extension) && !extension_present(json, extension) {
            warnings.push(LoadWarning::RequiredExtensionUnused {
                extension: extension.to_owned(),
            });
            continue;
        }
        return Err(LoadError::UnsupportedExtension {
            path: path.to_owned(),
            extension: extension.to_owned(),
        });
    }
    for extension in document.extensions_used() {
        let required = document.extensions_required().any(|r| r == extension);
        if !HONOURED_EXTENSIONS.contains(&extension) && !required {
            warnings.push(LoadWarning::IgnoredExtension {
                extension: extension.to_owned(),
            });
        }
    }
    Ok(())
}

/// The index in `json_path` after `prefix` (`textures[3].source` → 3 for `textures[`).
fn path_index(json_path: &str, prefix: &str) -> Option<usize> {
    let rest = json_path.strip_prefix(prefix)?;
    rest[..rest.find(']')?].parse().ok()
}

/// The textures, images and samplers the loader reads: those of the base-colour,
/// metallic-roughness and emissive slots of some material (normal and occlusion maps are
/// never opened). Only indices that exist are listed.
struct UsedItems {
    textures: Vec<bool>,
    images: Vec<bool>,
    samplers: Vec<bool>,
}

/// The image a texture is read from: its `source`, or for a texture without a valid one its
/// `MSFT_texture_dds` source where DDS is decoded. `None` when it has neither.
pub(crate) fn texture_image_index(root: &gltf::json::Root, texture: usize) -> Option<usize> {
    let texture = root.textures.get(texture)?;
    let source = texture.source.value();
    if source < root.images.len() {
        return Some(source);
    }
    let extensions = texture.extensions.as_ref()?;
    DECODED_TEXTURE_FORMATS
        .iter()
        .filter(|&&(_, enabled)| enabled)
        .find_map(|&(name, _)| {
            let index = extensions.others.get(name)?.get("source")?.as_u64()?;
            usize::try_from(index)
                .ok()
                .filter(|&i| i < root.images.len())
        })
}

fn used_items(root: &gltf::json::Root) -> UsedItems {
    let mut used = UsedItems {
        textures: vec![false; root.textures.len()],
        images: vec![false; root.images.len()],
        samplers: vec![false; root.samplers.len()],
    };
    for material in &root.materials {
        let pbr = &material.pbr_metallic_roughness;
        let slots = [
            pbr.base_color_texture.as_ref().map(|t| t.index.value()),
            pbr.metallic_roughness_texture
                .as_ref()
                .map(|t| t.index.value()),
            material.emissive_texture.as_ref().map(|t| t.index.value()),
        ];
        for texture in slots.into_iter().flatten() {
            let Some(slot) = used.textures.get_mut(texture) else {
                continue;
            };
            *slot = true;
            if let Some(image) = texture_image_index(root, texture) {
                used.images[image] = true;
            }
            if let Some(sampler) = root.textures[texture].sampler.as_ref()
                && let Some(slot) = used.samplers.get_mut(sampler.value())
            {
                *slot = true;
            }
        }
    }
    used
}

/// Whether a schema problem at `json_path` lies in an item the loader never reads; if so,
/// why going on is safe (empty: it is no problem for this loader, e.g. a texture without
/// `source` that a decoded format's extension gives its image).
fn unread_item(json_path: &str, root: &gltf::json::Root, used: &UsedItems) -> Option<String> {
    if let Some(texture) = path_index(json_path, "textures[") {
        if used.textures.get(texture) == Some(&false) {
            return Some(format!(
                "no material's base-colour, metallic-roughness or emissive slot uses texture {texture}"
            ));
        }
        // A used texture without a valid `source` that is read from a decoded format's
        // extension instead.
        // Not a defect at all: such a texture is valid under its extension (an empty
        // reason means no warning).
        if json_path == format!("textures[{texture}].source")
            && texture_image_index(root, texture).is_some()
        {
            return Some(String::new());
        }
        return None;
    }
    if let Some(image) = path_index(json_path, "images[") {
        return (used.images.get(image) == Some(&false)).then(|| {
            format!("image {image} belongs to no texture that a material's colour, metallic-roughness or emissive slot uses")
        });
    }
    if let Some(sampler) = path_index(json_path, "samplers[") {
        return (used.samplers.get(sampler) == Some(&false))
            .then(|| format!("sampler {sampler} belongs to no texture the loader reads"));
    }
    if let Some(material) = path_index(json_path, "materials[") {
        let rest = &json_path[json_path.find(']')? + 1..];
        if rest.starts_with(".normalTexture") || rest.starts_with(".occlusionTexture") {
            return Some(format!(
                "material {material}'s normal and occlusion maps are never read (materials keep constant colours)"
            ));
        }
    }
    None
}

/// Schema validation with the `gltf-json` validator, keeping what this loader can live with.
fn validate(
    path: &Path,
    document: &gltf::Document,
    warnings: &mut Vec<LoadWarning>,
) -> Result<(), LoadError> {
    use gltf::json::validation::{Checked, Error, Validate};
    let root = document.as_json();
    let invalid = |problems: String| LoadError::Invalid {
        path: path.to_owned(),
        problems,
    };
    // gltf-json's primitive hook indexes the POSITION accessor without a bounds check; make
    // sure it cannot panic.
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            for (semantic, index) in &primitive.attributes {
                if index.value() >= root.accessors.len() {
                    let name = match semantic {
                        Checked::Valid(semantic) => semantic.to_string(),
                        Checked::Invalid => "?".to_owned(),
                    };
                    return Err(invalid(format!(
                        "meshes[{m}].primitives[{p}].attributes[\"{name}\"]: index {} out of bounds ({} accessors)",
                        index.value(),
                        root.accessors.len()
                    )));
                }
            }
        }
    }
    let mut problems = Vec::new();
    root.validate(root, gltf::json::Path::new, &mut |path, error| {
        problems.push((path().to_string(), error));
    });
    let used = used_items(root);
    let mut fatal = Vec::new();
    for (json_path, error) in problems {
        let is_position_bound =
            json_path.ends_with("[\"POSITION\"].min") || json_path.ends_with("[\"POSITION\"].max");
        if is_position_bound && error == Error::Missing {
            // Reported once per accessor below.
            continue;
        }
        if json_path.starts_with("extensionsRequired") {
            // Checked against this loader's own list in `check_extensions`.
            continue;
        }
        if let Some(safe) = unread_item(&json_path, root, &used) {
            if safe.is_empty() {
                continue;
            }
            warnings.push(LoadWarning::UnreadDefect {
                item: json_path,
                problem: error.to_string(),
                safe,
            });
            continue;
        }
        fatal.push(format!("{json_path}: {error}"));
    }
    if !fatal.is_empty() {
        return Err(invalid(fatal.join("; ")));
    }
    let mut without_bounds: Vec<usize> = document
        .meshes()
        .flat_map(|mesh| mesh.primitives())
        .filter_map(|primitive| primitive.get(&gltf::Semantic::Positions))
        .filter(|accessor| accessor.min().is_none() || accessor.max().is_none())
        .map(|accessor| accessor.index())
        .collect();
    without_bounds.sort_unstable();
    without_bounds.dedup();
    warnings.extend(
        without_bounds
            .into_iter()
            .map(|accessor| LoadWarning::MissingPositionBounds { accessor }),
    );
    Ok(())
}

/// Decodes `%XX` escapes of a relative URI.
fn percent_decode(uri: &str) -> String {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' && i + 2 < bytes.len() {
            let hex = std::str::from_utf8(&bytes[i + 1..i + 3])
                .ok()
                .and_then(|h| u8::from_str_radix(h, 16).ok());
            if let Some(byte) = hex {
                out.push(byte);
                i += 3;
                continue;
            }
        }
        out.push(bytes[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// Reads a resource named by a URI: `data:` (base64), `file:` or a path relative to `base`.
/// `what` names the referencing item for errors (`buffer 0`, `image 3`).
pub(crate) fn read_uri(
    path: &Path,
    base: &Path,
    uri: &str,
    what: &str,
) -> Result<Vec<u8>, LoadError> {
    let bad = |message: String| LoadError::BadReference {
        path: path.to_owned(),
        what: what.to_owned(),
        uri: shorten_uri(uri),
        message,
    };
    if uri.starts_with("data:") {
        return gltf::buffer::Data::from_source(gltf::buffer::Source::Uri(uri), None)
            .map(|data| data.0)
            .map_err(|e| bad(format!("invalid data URI: {e}")));
    }
    let relative = if let Some(rest) = uri.strip_prefix("file://") {
        rest
    } else if let Some(rest) = uri.strip_prefix("file:") {
        rest
    } else if uri.contains("://") || uri.split('/').next().is_some_and(|s| s.contains(':')) {
        return Err(bad(
            "unsupported URI scheme (only relative paths, file: and data:)".into(),
        ));
    } else {
        uri
    };
    let resolved = base.join(percent_decode(relative));
    std::fs::read(&resolved).map_err(|e| {
        if e.kind() == std::io::ErrorKind::NotFound {
            LoadError::MissingFile {
                path: path.to_owned(),
                what: what.to_owned(),
                uri: uri.to_owned(),
                resolved: resolved.clone(),
            }
        } else {
            bad(format!("{}: {e}", resolved.display()))
        }
    })
}

/// A URI for messages: `data:` URIs are cut after their media type.
fn shorten_uri(uri: &str) -> String {
    if uri.starts_with("data:") {
        let head: String = uri.chars().take(40).collect();
        format!("{head}…")
    } else {
        uri.to_owned()
    }
}

fn load_buffers(
    path: &Path,
    base: &Path,
    document: &gltf::Document,
    mut blob: Option<Vec<u8>>,
) -> Result<Vec<Vec<u8>>, LoadError> {
    let mut buffers = Vec::with_capacity(document.buffers().len());
    for buffer in document.buffers() {
        let what = format!("buffer {}", buffer.index());
        let data = match buffer.source() {
            gltf::buffer::Source::Bin => blob.take().ok_or_else(|| LoadError::BadReference {
                path: path.to_owned(),
                what: what.clone(),
                uri: "GLB binary chunk".to_owned(),
                message: "the file has no binary chunk (or it is used twice)".to_owned(),
            })?,
            gltf::buffer::Source::Uri(uri) => read_uri(path, base, uri, &what)?,
        };
        if data.len() < buffer.length() {
            return Err(LoadError::BufferTooShort {
                path: path.to_owned(),
                buffer: buffer.index(),
                expected: buffer.length(),
                actual: data.len(),
            });
        }
        buffers.push(data);
    }
    Ok(buffers)
}

fn mat4(matrix: [[f32; 4]; 4]) -> Mat4 {
    Mat4::from_cols_array_2d(&matrix)
}

impl Loader<'_> {
    fn accessor_error(&self, problem: AccessorProblem) -> LoadError {
        LoadError::BadAccessor {
            path: self.path.to_owned(),
            accessor: problem.accessor,
            name: problem.name,
            reason: problem.reason,
        }
    }

    /// Checks that the nodes form a forest (glTF 2.0 §3.5.3): at most one parent each and no
    /// cycles, so that the walk below visits each node once per scene root.
    fn check_hierarchy(&self) -> Result<(), LoadError> {
        let document = self.document;
        let mut parent: Vec<Option<usize>> = vec![None; document.nodes().len()];
        for node in document.nodes() {
            for child in node.children() {
                if let Some(other) = parent[child.index()] {
                    return Err(LoadError::Invalid {
                        path: self.path.to_owned(),
                        problems: format!(
                            "nodes[{}] is a child of both nodes[{other}] and nodes[{}]; the node hierarchy must be a forest",
                            child.index(),
                            node.index()
                        ),
                    });
                }
                parent[child.index()] = Some(node.index());
            }
        }
        for start in 0..parent.len() {
            let mut current = start;
            for _ in 0..=parent.len() {
                match parent[current] {
                    Some(up) if up == start => {
                        return Err(LoadError::NodeCycle {
                            path: self.path.to_owned(),
                            node: start,
                        });
                    }
                    Some(up) => current = up,
                    None => break,
                }
            }
        }
        Ok(())
    }

    fn walk_scene(&mut self) -> Result<(), LoadError> {
        self.check_hierarchy()?;
        let document = self.document;
        let roots: Vec<gltf::Node<'_>> = match document.default_scene() {
            Some(scene) => scene.nodes().collect(),
            None => {
                self.warnings.push(LoadWarning::NoDefaultScene);
                match document.scenes().next() {
                    Some(scene) => scene.nodes().collect(),
                    None => {
                        let mut is_child = vec![false; document.nodes().len()];
                        for node in document.nodes() {
                            for child in node.children() {
                                is_child[child.index()] = true;
                            }
                        }
                        document.nodes().filter(|n| !is_child[n.index()]).collect()
                    }
                }
            }
        };
        self.check_declared_size(&roots)?;
        let node_count = document.nodes().len();
        let mut stack: Vec<(gltf::Node<'_>, Mat4, usize)> = roots
            .into_iter()
            .rev()
            .map(|n| (n, Mat4::IDENTITY, 0))
            .collect();
        while let Some((node, parent, depth)) = stack.pop() {
            if depth > node_count {
                return Err(LoadError::NodeCycle {
                    path: self.path.to_owned(),
                    node: node.index(),
                });
            }
            let world = parent * mat4(node.transform().matrix());
            if !world.is_finite() {
                return Err(self.non_finite_transform(&node));
            }
            self.visit_node(&node, world)?;
            let children: Vec<_> = node.children().collect();
            for child in children.into_iter().rev() {
                stack.push((child, world, depth + 1));
            }
        }
        Ok(())
    }

    /// Refuses, before any mesh is decoded, a scene whose accessor counts (times its node
    /// instances and `EXT_mesh_gpu_instancing` copies) declare more triangles than the scene
    /// can index or the memory limit can hold.
    fn check_declared_size(&self, roots: &[gltf::Node<'_>]) -> Result<(), LoadError> {
        let node_count = self.document.nodes().len();
        let mut total: u128 = 0;
        let mut stack: Vec<(gltf::Node<'_>, usize)> =
            roots.iter().map(|n| (n.clone(), 0)).collect();
        while let Some((node, depth)) = stack.pop() {
            if depth > node_count {
                // A cycle: the walk reports it.
                return Ok(());
            }
            if let Some(mesh) = node.mesh() {
                let per_mesh: u128 = mesh
                    .primitives()
                    .map(|p| {
                        let n = p
                            .indices()
                            .or_else(|| p.get(&gltf::Semantic::Positions))
                            .map_or(0, |a| a.count()) as u128;
                        match p.mode() {
                            Mode::Triangles => n / 3,
                            Mode::TriangleStrip | Mode::TriangleFan => n.saturating_sub(2),
                            _ => 0,
                        }
                    })
                    .sum();
                let instances = node
                    .extension_value(INSTANCING)
                    .and_then(|_| self.instance_count(&node))
                    .unwrap_or(1) as u128;
                total = total.saturating_add(per_mesh.saturating_mul(instances));
            }
            stack.extend(node.children().map(|c| (c, depth + 1)));
        }
        if total > crate::scene::MAX_TRIANGLES as u128 {
            return Err(LoadError::Build {
                path: self.path.to_owned(),
                source: crate::error::BuildError::TooManyTriangles {
                    count: usize::try_from(total).unwrap_or(usize::MAX),
                },
            });
        }
        let estimate = (total as u64).saturating_mul(crate::scene::BYTES_PER_TRIANGLE);
        self.limit
            .check(
                format!("a scene of {total} triangles (declared by its accessors)"),
                estimate,
            )
            .map_err(|source| LoadError::TooLarge {
                path: self.path.to_owned(),
                source,
            })
    }

    fn non_finite_transform(&self, node: &gltf::Node<'_>) -> LoadError {
        LoadError::NonFiniteTransform {
            path: self.path.to_owned(),
            node: node.index(),
            name: node.name().unwrap_or_default().to_owned(),
        }
    }

    fn visit_node(&mut self, node: &gltf::Node<'_>, world: Mat4) -> Result<(), LoadError> {
        if let Some(mesh) = node.mesh() {
            if node.skin().is_some() {
                self.ignore(format!(
                    "skin of node {} (mesh drawn in bind pose)",
                    node.index()
                ));
            }
            if mesh.primitives().any(|p| p.morph_targets().len() > 0) {
                self.ignore(format!(
                    "morph targets of mesh {} (base shape used)",
                    mesh.index()
                ));
            }
            let primitives = self.mesh_primitives(&mesh)?;
            let instances = self.instance_matrices(node)?;
            match instances {
                Some(instances) => {
                    for instance in instances {
                        let matrix = world * instance;
                        if !matrix.is_finite() {
                            return Err(self.non_finite_transform(node));
                        }
                        self.emit(node, &primitives, matrix)?;
                    }
                }
                None => self.emit(node, &primitives, world)?,
            }
            self.count_skipped(&mesh, node);
        }
        if let Some(camera) = node.camera() {
            self.add_camera(node, &camera, world);
        }
        if let Some(light) = node.light() {
            self.add_light(&light, world);
        }
        Ok(())
    }

    fn ignore(&mut self, feature: String) {
        if !self.ignored.contains(&feature) {
            self.ignored.push(feature);
        }
    }

    /// Counts the mesh's non-triangle primitives once per drawn instance.
    fn count_skipped(&mut self, mesh: &gltf::Mesh<'_>, node: &gltf::Node<'_>) {
        let instances = node
            .extension_value(INSTANCING)
            .and_then(|_| self.instance_count(node))
            .unwrap_or(1);
        for primitive in mesh.primitives() {
            let slot = match primitive.mode() {
                Mode::Points => 0,
                Mode::Lines => 1,
                Mode::LineLoop => 2,
                Mode::LineStrip => 3,
                _ => continue,
            };
            let n = primitive
                .indices()
                .or_else(|| primitive.get(&gltf::Semantic::Positions))
                .map_or(0, |a| a.count());
            let elements = match primitive.mode() {
                Mode::Points => n,
                Mode::Lines => n / 2,
                Mode::LineLoop => {
                    if n >= 2 {
                        n
                    } else {
                        0
                    }
                }
                _ => n.saturating_sub(1),
            };
            self.skipped[slot].primitives += instances;
            self.skipped[slot].elements += elements * instances;
        }
    }

    fn instance_count(&self, node: &gltf::Node<'_>) -> Option<usize> {
        let attributes = node.extension_value(INSTANCING)?.get("attributes")?;
        ["TRANSLATION", "ROTATION", "SCALE"]
            .iter()
            .filter_map(|k| attributes.get(*k)?.as_u64())
            .filter_map(|i| self.document.accessors().nth(i as usize))
            .map(|a| a.count())
            .next()
    }

    /// The per-instance matrices of `EXT_mesh_gpu_instancing`, or `None` without it.
    fn instance_matrices(&self, node: &gltf::Node<'_>) -> Result<Option<Vec<Mat4>>, LoadError> {
        let Some(extension) = node.extension_value(INSTANCING) else {
            return Ok(None);
        };
        let bad = |reason: String| LoadError::BadInstancing {
            path: self.path.to_owned(),
            node: node.index(),
            reason,
        };
        let attributes = extension
            .get("attributes")
            .and_then(|a| a.as_object())
            .ok_or_else(|| bad("no \"attributes\" object".to_owned()))?;
        let mut count: Option<usize> = None;
        let mut read = |name: &str, dims: Dimensions| -> Result<Option<Vec<f32>>, LoadError> {
            let Some(value) = attributes.get(name) else {
                return Ok(None);
            };
            let index = value
                .as_u64()
                .ok_or_else(|| bad(format!("{name} is not an accessor index")))?;
            let accessor = self
                .document
                .accessors()
                .nth(index as usize)
                .ok_or_else(|| {
                    bad(format!(
                        "{name} names accessor {index}, which does not exist"
                    ))
                })?;
            if let Some(n) = count
                && n != accessor.count()
            {
                return Err(bad(format!(
                    "{name} (accessor {index}) has {} elements, other attributes {n}",
                    accessor.count()
                )));
            }
            count = Some(accessor.count());
            read_f32(&accessor, &self.buffers, &[dims])
                .map(Some)
                .map_err(|p| self.accessor_error(p))
        };
        let translation = read("TRANSLATION", Dimensions::Vec3)?;
        let rotation = read("ROTATION", Dimensions::Vec4)?;
        let scale = read("SCALE", Dimensions::Vec3)?;
        let Some(count) = count else {
            return Err(bad("none of TRANSLATION, ROTATION, SCALE given".to_owned()));
        };
        let matrices = (0..count)
            .map(|i| {
                let t = translation
                    .as_ref()
                    .map_or(Vec3::ZERO, |v| Vec3::from_slice(&v[3 * i..]));
                let r = rotation.as_ref().map_or(Quat::IDENTITY, |v| {
                    Quat::from_vec4(Vec4::from_slice(&v[4 * i..])).normalize()
                });
                let s = scale
                    .as_ref()
                    .map_or(Vec3::ONE, |v| Vec3::from_slice(&v[3 * i..]));
                Mat4::from_scale_rotation_translation(s, r, t)
            })
            .collect();
        Ok(Some(matrices))
    }

    /// The mesh's triangle primitives in local space, decoded once per mesh.
    fn mesh_primitives(
        &mut self,
        mesh: &gltf::Mesh<'_>,
    ) -> Result<Arc<Vec<LocalPrimitive>>, LoadError> {
        if let Some(done) = self.meshes.get(&mesh.index()) {
            return Ok(Arc::clone(done));
        }
        let mut primitives = Vec::new();
        for primitive in mesh.primitives() {
            if matches!(
                primitive.mode(),
                Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
            ) {
                primitives.push(self.decode_primitive(mesh, &primitive)?);
            }
        }
        let primitives = Arc::new(primitives);
        self.meshes.insert(mesh.index(), Arc::clone(&primitives));
        Ok(primitives)
    }

    fn decode_primitive(
        &mut self,
        mesh: &gltf::Mesh<'_>,
        primitive: &gltf::Primitive<'_>,
    ) -> Result<LocalPrimitive, LoadError> {
        let buffers = &self.buffers;
        let position_accessor =
            primitive
                .get(&gltf::Semantic::Positions)
                .ok_or_else(|| LoadError::Invalid {
                    path: self.path.to_owned(),
                    problems: format!(
                        "meshes[{}].primitives[{}] has no POSITION",
                        mesh.index(),
                        primitive.index()
                    ),
                })?;
        let flat = read_f32(&position_accessor, buffers, &[Dimensions::Vec3])
            .map_err(|p| self.accessor_error(p))?;
        if let Some(bad) = flat.iter().position(|v| !v.is_finite()) {
            return Err(LoadError::NonFinitePosition {
                path: self.path.to_owned(),
                accessor: position_accessor.index(),
                name: position_accessor.name().unwrap_or_default().to_owned(),
                element: bad / 3,
            });
        }
        let positions: Vec<Vec3> = flat.chunks_exact(3).map(Vec3::from_slice).collect();
        let vertex_count = positions.len();

        let check_count = |accessor: &gltf::Accessor<'_>, what: &str| {
            if accessor.count() == vertex_count {
                Ok(())
            } else {
                Err(LoadError::BadAccessor {
                    path: self.path.to_owned(),
                    accessor: accessor.index(),
                    name: accessor.name().unwrap_or_default().to_owned(),
                    reason: format!(
                        "{what} has {} elements but POSITION has {vertex_count}",
                        accessor.count()
                    ),
                })
            }
        };

        let normals = match primitive.get(&gltf::Semantic::Normals) {
            Some(accessor) => {
                check_count(&accessor, "NORMAL")?;
                let flat = read_f32(&accessor, buffers, &[Dimensions::Vec3])
                    .map_err(|p| self.accessor_error(p))?;
                Some(
                    flat.chunks_exact(3)
                        .map(|n| {
                            let n = Vec3::from_slice(n);
                            if n.is_finite() { n } else { Vec3::ZERO }
                        })
                        .collect::<Vec<_>>(),
                )
            }
            None => None,
        };
        let tex_coord = primitive
            .material()
            .pbr_metallic_roughness()
            .base_color_texture()
            .map_or(0, |info| info.tex_coord());
        let uvs = match primitive.get(&gltf::Semantic::TexCoords(tex_coord)) {
            Some(accessor) => {
                check_count(&accessor, "TEXCOORD")?;
                let flat = read_f32(&accessor, buffers, &[Dimensions::Vec2])
                    .map_err(|p| self.accessor_error(p))?;
                Some(
                    flat.chunks_exact(2)
                        .map(|t| {
                            let t = Vec2::from_slice(t);
                            if t.is_finite() { t } else { Vec2::ZERO }
                        })
                        .collect::<Vec<_>>(),
                )
            }
            None => None,
        };
        let indices: Vec<u32> = match primitive.indices() {
            Some(accessor) => {
                read_indices(&accessor, buffers).map_err(|p| self.accessor_error(p))?
            }
            None => (0..vertex_count as u32).collect(),
        };
        if let Some(&index) = indices.iter().find(|&&i| i as usize >= vertex_count) {
            return Err(LoadError::IndexOutOfRange {
                path: self.path.to_owned(),
                mesh: mesh.index(),
                mesh_name: mesh.name().unwrap_or_default().to_owned(),
                primitive: primitive.index(),
                index,
                vertex_count,
            });
        }
        let (triangles, dropped) = triangulate(primitive.mode(), &indices);
        if dropped > 0 {
            self.warnings.push(LoadWarning::IncompletePrimitive {
                mesh: mesh.index(),
                primitive: primitive.index(),
                dropped,
            });
        }
        if normals.is_none() && !triangles.is_empty() {
            self.warnings.push(LoadWarning::MissingNormals {
                mesh: mesh.index(),
                primitive: primitive.index(),
            });
        }
        let material = match primitive.material().index() {
            Some(index) => index as u32,
            None => *self.default_material.get_or_insert(self.material_count),
        };
        Ok(LocalPrimitive {
            positions,
            normals,
            uvs,
            triangles,
            material,
        })
    }

    /// Appends the primitives' triangles transformed by `matrix`.
    fn emit(
        &mut self,
        node: &gltf::Node<'_>,
        primitives: &[LocalPrimitive],
        matrix: Mat4,
    ) -> Result<(), LoadError> {
        let linear = Mat3::from_mat4(matrix);
        let normal_matrix = linear.inverse().transpose();
        let flip = linear.determinant() < 0.0;
        for primitive in primitives {
            let world: Vec<Vec3> = primitive
                .positions
                .iter()
                .map(|&p| matrix.transform_point3(p))
                .collect();
            if world.iter().any(|p| !p.is_finite()) {
                return Err(self.non_finite_transform(node));
            }
            let count = self.triangles.len() + primitive.triangles.len();
            if count > crate::scene::MAX_TRIANGLES {
                return Err(LoadError::Build {
                    path: self.path.to_owned(),
                    source: crate::error::BuildError::TooManyTriangles { count },
                });
            }
            self.triangles.reserve(primitive.triangles.len());
            for &[a, b, c] in &primitive.triangles {
                let order = if flip { [a, c, b] } else { [a, b, c] };
                let positions = order.map(|i| world[i as usize]);
                let geometric = (positions[1] - positions[0])
                    .cross(positions[2] - positions[0])
                    .normalize_or_zero();
                let normals = match &primitive.normals {
                    Some(normals) => order.map(|i| {
                        let n = (normal_matrix * normals[i as usize]).normalize_or_zero();
                        if n == Vec3::ZERO { geometric } else { n }
                    }),
                    None => [geometric; 3],
                };
                let uvs = match &primitive.uvs {
                    Some(uvs) => order.map(|i| uvs[i as usize]),
                    None => [Vec2::ZERO; 3],
                };
                self.triangles.push(Triangle {
                    positions,
                    normals,
                    uvs,
                    material: primitive.material,
                });
            }
        }
        Ok(())
    }

    fn add_camera(&mut self, node: &gltf::Node<'_>, camera: &gltf::Camera<'_>, world: Mat4) {
        let name = camera
            .name()
            .or(node.name())
            .map_or_else(|| format!("camera{}", camera.index()), str::to_owned);
        let gltf::camera::Projection::Perspective(perspective) = camera.projection() else {
            self.warnings.push(LoadWarning::SkippedCamera {
                camera: name,
                reason: "orthographic projection".to_owned(),
            });
            return;
        };
        let yfov = perspective.yfov();
        let position = world.transform_point3(Vec3::ZERO);
        let forward = world.transform_vector3(Vec3::NEG_Z).normalize_or_zero();
        let up_hint = world.transform_vector3(Vec3::Y);
        let right = forward.cross(up_hint).normalize_or_zero();
        if forward == Vec3::ZERO
            || right == Vec3::ZERO
            || !(yfov > 0.0 && yfov < std::f32::consts::PI)
        {
            self.warnings.push(LoadWarning::SkippedCamera {
                camera: name,
                reason: "degenerate node transform or field of view".to_owned(),
            });
            return;
        }
        self.cameras.push(Camera {
            name,
            position,
            forward,
            up: right.cross(forward),
            yfov,
            aspect: perspective.aspect_ratio(),
        });
    }

    fn add_light(&mut self, light: &gltf::khr_lights_punctual::Light<'_>, world: Mat4) {
        use gltf::khr_lights_punctual::Kind;
        let name = light
            .name()
            .map_or_else(|| format!("light{}", light.index()), str::to_owned);
        let color = Vec3::from(light.color());
        let intensity = light.intensity();
        let range = light.range();
        let position = world.transform_point3(Vec3::ZERO);
        let direction = world.transform_vector3(Vec3::NEG_Z).normalize_or_zero();
        let direction = if direction == Vec3::ZERO {
            Vec3::NEG_Z
        } else {
            direction
        };
        self.lights.push(match light.kind() {
            Kind::Point => Light::Point {
                name,
                position,
                color,
                intensity,
                range,
            },
            Kind::Spot {
                inner_cone_angle,
                outer_cone_angle,
            } => Light::Spot {
                name,
                position,
                direction,
                color,
                intensity,
                inner_cone: inner_cone_angle,
                outer_cone: outer_cone_angle,
                range,
            },
            Kind::Directional => Light::Directional {
                name,
                direction,
                color,
                illuminance: intensity,
                range,
            },
        });
    }
}

/// Index triples of a triangle-mode primitive (glTF 2.0 §3.7.2.1 orderings) and the number of
/// trailing indices that form no triangle.
fn triangulate(mode: Mode, indices: &[u32]) -> (Vec<[u32; 3]>, usize) {
    let n = indices.len();
    match mode {
        Mode::Triangles => (
            indices
                .chunks_exact(3)
                .map(|c| [c[0], c[1], c[2]])
                .collect(),
            n % 3,
        ),
        Mode::TriangleStrip if n >= 3 => (
            (0..n - 2)
                .map(|i| {
                    if i % 2 == 0 {
                        [indices[i], indices[i + 1], indices[i + 2]]
                    } else {
                        [indices[i], indices[i + 2], indices[i + 1]]
                    }
                })
                .collect(),
            0,
        ),
        Mode::TriangleFan if n >= 3 => (
            (1..n - 1)
                .map(|i| [indices[i], indices[i + 1], indices[0]])
                .collect(),
            0,
        ),
        _ => (Vec::new(), n),
    }
}

/// The alpha mode of a glTF material (texture filled in by `images`).
pub(crate) fn alpha_mode_without_texture(material: &gltf::Material<'_>) -> AlphaMode {
    match material.alpha_mode() {
        gltf::material::AlphaMode::Opaque => AlphaMode::Opaque,
        gltf::material::AlphaMode::Mask => AlphaMode::Mask {
            cutoff: material.alpha_cutoff().unwrap_or(0.5),
            texture: None,
            constant_alpha: material.pbr_metallic_roughness().base_color_factor()[3],
        },
        gltf::material::AlphaMode::Blend => AlphaMode::Blend,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strip_and_fan_orderings() {
        let (strip, dropped) = triangulate(Mode::TriangleStrip, &[0, 3, 1, 2]);
        assert_eq!(strip, vec![[0, 3, 1], [3, 2, 1]]);
        assert_eq!(dropped, 0);
        let (fan, _) = triangulate(Mode::TriangleFan, &[0, 3, 2, 1]);
        assert_eq!(fan, vec![[3, 2, 0], [2, 1, 0]]);
        let (list, dropped) = triangulate(Mode::Triangles, &[0, 1, 2, 3]);
        assert_eq!(list, vec![[0, 1, 2]]);
        assert_eq!(dropped, 1);
        let (none, dropped) = triangulate(Mode::TriangleStrip, &[0, 1]);
        assert!(none.is_empty());
        assert_eq!(dropped, 2);
    }

    #[test]
    fn percent_decoding() {
        assert_eq!(percent_decode("a%20b.png"), "a b.png");
        assert_eq!(percent_decode("100%"), "100%");
        assert_eq!(percent_decode("%zz"), "%zz");
    }
}
