//! Errors and warnings of scene construction.

use std::fmt;
use std::path::PathBuf;

/// Why a scene file (or built-in name) could not be turned into a [`Scene`](crate::Scene).
///
/// Every variant names the file and the offending item; each says how to fix it.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum LoadError {
    /// The scene file itself could not be read.
    ///
    /// Fix: check the path (relative paths are relative to the working directory) and the
    /// file's permissions.
    #[error("cannot read scene file {path}: {source}")]
    Read {
        /// The scene file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },

    /// The file is neither glTF 2.0 JSON nor binary glTF (GLB), or its JSON does not parse.
    ///
    /// Fix: pass a `.gltf` or `.glb` file; re-export it if it is damaged.
    #[error("{path} is not a glTF 2.0 file: {message}")]
    NotGltf {
        /// The scene file.
        path: PathBuf,
        /// What the parser reported.
        message: String,
    },

    /// The glTF document breaks the glTF 2.0 schema (dangling indices, invalid enums, ...).
    ///
    /// Fix: run the file through the Khronos glTF validator and correct the items it lists
    /// (the same JSON paths are given here).
    #[error("{path} is not valid glTF 2.0: {problems}")]
    Invalid {
        /// The scene file.
        path: PathBuf,
        /// The problems, as `json.path: problem`, separated by `; `.
        problems: String,
    },

    /// The file lists an extension in `extensionsRequired` that this crate cannot honour
    /// (it honours `KHR_lights_punctual`, `KHR_materials_emissive_strength`,
    /// `EXT_mesh_gpu_instancing` and, with the `dds` feature, `MSFT_texture_dds`), and some
    /// item of the file uses it: mesh compression (`KHR_draco_mesh_compression`,
    /// `EXT_meshopt_compression`) that is not decoded, material models that change colour.
    /// A required extension no item uses is only a warning
    /// ([`LoadWarning::RequiredExtensionUnused`]).
    ///
    /// Fix: use a variant of the asset that does not need the extension (for Crytek Sponza,
    /// `Sponza_basecolor.gltf` instead of `Sponza.gltf`), or convert it with a tool such as
    /// glTF-Transform.
    #[error("{path} requires the glTF extension {extension}, which probe-scene cannot honour")]
    UnsupportedExtension {
        /// The scene file.
        path: PathBuf,
        /// The extension's name.
        extension: String,
    },

    /// A buffer or image the file references does not exist.
    ///
    /// Fix: put the missing file next to the scene file (URIs are relative to it), or remove
    /// the reference from the glTF.
    #[error("{path} references {what} {uri:?}, which does not exist (looked for {resolved})")]
    MissingFile {
        /// The scene file.
        path: PathBuf,
        /// What references it, e.g. `buffer 0` or `image 3`.
        what: String,
        /// The URI as written in the file.
        uri: String,
        /// Where it was looked for.
        resolved: PathBuf,
    },

    /// A buffer or image exists but cannot be read: I/O failure, broken base64 `data:` URI,
    /// unsupported URI scheme (only relative paths, `file:` and `data:` are read), or a
    /// binary chunk that the GLB does not have.
    ///
    /// Fix: repair the reference or the file it points to; embed remote resources.
    #[error("{path}: cannot read {what} ({uri}): {message}")]
    BadReference {
        /// The scene file.
        path: PathBuf,
        /// What references it, e.g. `buffer 0` or `image 3`.
        what: String,
        /// The URI, or `GLB binary chunk` / `bufferView N`.
        uri: String,
        /// What went wrong.
        message: String,
    },

    /// A buffer holds fewer bytes than its `byteLength` declares.
    ///
    /// Fix: re-export the asset; the `.bin` file is truncated or belongs to another version.
    #[error("{path}: buffer {buffer} holds {actual} bytes but declares byteLength {expected}")]
    BufferTooShort {
        /// The scene file.
        path: PathBuf,
        /// The buffer's index.
        buffer: usize,
        /// The declared length.
        expected: usize,
        /// The bytes available.
        actual: usize,
    },

    /// An accessor (or buffer view behind it) is unusable: it reaches past its data, has the
    /// wrong type for its use, or a stride smaller than its elements.
    ///
    /// Fix: correct the accessor in the file; the reason names the inconsistency.
    #[error("{path}: accessor {accessor}{}: {reason}", quoted_name(name))]
    BadAccessor {
        /// The scene file.
        path: PathBuf,
        /// The accessor's index.
        accessor: usize,
        /// The accessor's name, empty when it has none.
        name: String,
        /// What is wrong.
        reason: String,
    },

    /// A position accessor holds a NaN or infinite coordinate.
    ///
    /// Fix: repair the mesh in a modelling tool; such vertices cannot be placed in a BVH.
    #[error(
        "{path}: accessor {accessor}{} holds a non-finite position at element {element}",
        quoted_name(name)
    )]
    NonFinitePosition {
        /// The scene file.
        path: PathBuf,
        /// The POSITION accessor's index.
        accessor: usize,
        /// The accessor's name, empty when it has none.
        name: String,
        /// The first offending element (vertex).
        element: usize,
    },

    /// A primitive's index refers past the end of its vertex attributes.
    ///
    /// Fix: re-export the mesh; the index buffer does not belong to these vertices.
    #[error(
        "{path}: mesh {mesh}{} primitive {primitive} uses vertex index {index}, but it has only {vertex_count} vertices",
        quoted_name(mesh_name)
    )]
    IndexOutOfRange {
        /// The scene file.
        path: PathBuf,
        /// The mesh's index.
        mesh: usize,
        /// The mesh's name, empty when it has none.
        mesh_name: String,
        /// The primitive's index within the mesh.
        primitive: usize,
        /// The offending index value.
        index: u32,
        /// The number of vertices the primitive's attributes hold.
        vertex_count: usize,
    },

    /// An image a material needs cannot be decoded (PNG, JPEG and, with the `dds` feature,
    /// DDS are decoded).
    ///
    /// Fix: convert the image to PNG or JPEG, or repair it.
    #[error("{path}: image {image} ({uri}) cannot be decoded: {message}")]
    BadImage {
        /// The scene file.
        path: PathBuf,
        /// The image's index.
        image: usize,
        /// The image's URI, or `bufferView N`.
        uri: String,
        /// The decoder's message.
        message: String,
    },

    /// A node's `EXT_mesh_gpu_instancing` data is malformed (missing or mismatched attribute
    /// accessors, wrong types).
    ///
    /// Fix: give TRANSLATION (VEC3), ROTATION (VEC4) and SCALE (VEC3) accessors of equal count.
    #[error("{path}: node {node}: bad EXT_mesh_gpu_instancing: {reason}")]
    BadInstancing {
        /// The scene file.
        path: PathBuf,
        /// The node's index.
        node: usize,
        /// What is wrong.
        reason: String,
    },

    /// The node hierarchy has a cycle (a node is its own ancestor).
    ///
    /// Fix: correct the `children` lists so that the nodes form a forest.
    #[error("{path}: node {node} is its own ancestor (cycle in the node hierarchy)")]
    NodeCycle {
        /// The scene file.
        path: PathBuf,
        /// A node on the cycle.
        node: usize,
    },

    /// A node's world transform (or an instance's) is not finite, or turns a vertex non-finite.
    ///
    /// Fix: correct the node's matrix or TRS values.
    #[error(
        "{path}: node {node}{} has a non-finite world transform",
        quoted_name(name)
    )]
    NonFiniteTransform {
        /// The scene file.
        path: PathBuf,
        /// The node's index.
        node: usize,
        /// The node's name, empty when it has none.
        name: String,
    },

    /// `Scene::builtin` or `Scene::open("builtin:…")` was given an unknown name.
    ///
    /// Fix: use one of the names listed (also in [`BUILTIN_SCENES`](crate::BUILTIN_SCENES)).
    #[error("unknown built-in scene {name:?}; the built-ins are {}", crate::BUILTIN_SCENES.join(", "))]
    UnknownBuiltin {
        /// The name asked for.
        name: String,
    },

    /// [`Scene::open`](crate::Scene::open) was given a file path, but this build of
    /// `probe-scene` has no glTF loader.
    ///
    /// Fix: enable the crate's `gltf` feature (on by default; it was turned off with
    /// `default-features = false`), or open a `builtin:NAME` scene.
    #[error(
        "cannot load {path}: probe-scene was built without its `gltf` feature; enable it to load glTF files"
    )]
    LoaderDisabled {
        /// The path asked for.
        path: PathBuf,
    },

    /// The file declares more triangles (accessor counts times node instances) than the
    /// memory limit holds; refused before any mesh is decoded.
    ///
    /// Fix: check the file (a damaged accessor count or instance list gives this), split the
    /// scene, or raise the limit ([`Scene::load_with_limit`](crate::Scene::load_with_limit),
    /// `--max-memory`) if the machine has the memory.
    #[error("{path}: {source}")]
    TooLarge {
        /// The scene file.
        path: PathBuf,
        /// The estimate and the limit.
        source: crate::memory::MemoryExceeded,
    },

    /// The loaded data could not be assembled into a scene.
    ///
    /// Fix: see the inner [`BuildError`].
    #[error("{path}: {source}")]
    Build {
        /// The scene file.
        path: PathBuf,
        /// Why the scene could not be built.
        source: BuildError,
    },
}

/// Why [`Scene::from_triangles`](crate::Scene::from_triangles) refused its input.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum BuildError {
    /// A triangle has a NaN or infinite position, normal or texture coordinate.
    ///
    /// Fix: drop or repair the triangle before building.
    #[error("triangle {triangle} has a non-finite {attribute}")]
    NonFiniteVertex {
        /// The triangle's index.
        triangle: usize,
        /// `"position"`, `"normal"` or `"uv"`.
        attribute: &'static str,
    },

    /// A triangle has a position coordinate beyond ±[`MAX_COORDINATE`](crate::MAX_COORDINATE)
    /// (10^18 m), where the BVH's surface-area arithmetic overflows.
    ///
    /// Fix: the mesh is damaged or its units are wrong; repair or rescale it.
    #[error("triangle {triangle} has a position coordinate beyond ±{limit:e} m")]
    PositionOutOfRange {
        /// The triangle's index.
        triangle: usize,
        /// The limit, [`MAX_COORDINATE`](crate::MAX_COORDINATE).
        limit: f32,
    },

    /// A triangle names a material that does not exist.
    ///
    /// Fix: pass the material, or use an index below the number of materials.
    #[error("triangle {triangle} uses material {material}, but there are only {material_count}")]
    MaterialOutOfRange {
        /// The triangle's index.
        triangle: usize,
        /// The material index it names.
        material: u32,
        /// The number of materials given.
        material_count: usize,
    },

    /// A material has a non-finite or negative colour, or a factor outside `[0, 1]`.
    ///
    /// Fix: correct the named field.
    #[error("material {material}{} is invalid: {reason}", quoted_name(name))]
    InvalidMaterial {
        /// The material's index.
        material: usize,
        /// The material's name.
        name: String,
        /// What is wrong.
        reason: String,
    },

    /// A light has a non-finite position, zero direction, negative intensity, or cone angles
    /// outside `0 ≤ inner < outer ≤ π/2`.
    ///
    /// Fix: correct the named field.
    #[error("light {light}{} is invalid: {reason}", quoted_name(name))]
    InvalidLight {
        /// The light's index.
        light: usize,
        /// The light's name.
        name: String,
        /// What is wrong.
        reason: String,
    },

    /// A camera has a non-finite position, non-orthonormal axes, or a field of view outside
    /// `(0, π)`.
    ///
    /// Fix: build it with [`Camera::look_at`](crate::Camera::look_at).
    #[error("camera {camera}{} is invalid: {reason}", quoted_name(name))]
    InvalidCamera {
        /// The camera's index.
        camera: usize,
        /// The camera's name.
        name: String,
        /// What is wrong.
        reason: String,
    },

    /// More triangles than `u32` indices can address.
    ///
    /// Fix: split the scene.
    #[error("{count} triangles exceed the limit of {}", u32::MAX)]
    TooManyTriangles {
        /// The number of triangles given.
        count: usize,
    },
}

fn quoted_name(name: &str) -> String {
    if name.is_empty() {
        String::new()
    } else {
        format!(" ({name:?})")
    }
}

/// Something a loader ignored or repaired: the scene loaded, but not everything in the file
/// is in it as written. Shown with `Display`.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum LoadWarning {
    /// An extension in `extensionsUsed` (not required) that this crate does not interpret.
    IgnoredExtension {
        /// The extension's name.
        extension: String,
    },
    /// Primitives of a non-triangle mode (points, lines, line loops, line strips) were skipped.
    SkippedPrimitives {
        /// The glTF mode name (`POINTS`, `LINES`, `LINE_LOOP`, `LINE_STRIP`).
        mode: &'static str,
        /// How many primitives (per mesh instance) were skipped.
        primitives: usize,
        /// How many points or line segments they held.
        elements: usize,
    },
    /// A material with `alphaMode: BLEND` is treated as opaque.
    BlendTreatedAsOpaque {
        /// The material's name.
        material: String,
    },
    /// A POSITION accessor lacks the `min`/`max` that glTF requires; bounds are computed.
    MissingPositionBounds {
        /// The accessor's index.
        accessor: usize,
    },
    /// A primitive has no normals; every vertex got its face's geometric normal.
    MissingNormals {
        /// The mesh's index.
        mesh: usize,
        /// The primitive's index within the mesh.
        primitive: usize,
    },
    /// A primitive's vertex or index count does not fit its mode; the trailing ones were dropped.
    IncompletePrimitive {
        /// The mesh's index.
        mesh: usize,
        /// The primitive's index within the mesh.
        primitive: usize,
        /// How many trailing vertices (or indices) were dropped.
        dropped: usize,
    },
    /// A camera that is not perspective (orthographic) was skipped.
    SkippedCamera {
        /// The camera's name.
        camera: String,
        /// Why.
        reason: String,
    },
    /// A feature of the file that has no effect on the loaded scene (skins, morph targets,
    /// texture transforms, ...).
    IgnoredFeature {
        /// What was ignored and where.
        feature: String,
    },
    /// The file names no default scene; its first scene (or, without scenes, all root nodes)
    /// was loaded.
    NoDefaultScene,
    /// The glTF schema is broken in an item the loader never reads (a texture no material
    /// slot it reads uses, pointing at an image that does not exist; a normal map's dangling
    /// index), so the defect cannot change the scene. A file that every mainstream viewer
    /// opens is not refused for it.
    UnreadDefect {
        /// The JSON path of the defect, e.g. `textures[3].source`.
        item: String,
        /// What the validator reports, e.g. `Index out of bounds`.
        problem: String,
        /// Why it cannot change the scene.
        safe: String,
    },
    /// An extension listed in `extensionsRequired` that this crate does not implement, but
    /// that no item of the file uses (e.g. `MSFT_texture_dds` in a file without textures), so
    /// there is nothing it could change.
    RequiredExtensionUnused {
        /// The extension's name.
        extension: String,
    },
    /// An image in a format other than PNG or JPEG (DDS, for `MSFT_texture_dds`) was decoded
    /// for the mean colour (or alpha mask) the material keeps.
    DecodedImageFormat {
        /// The image's index.
        image: usize,
        /// The format, e.g. `DDS`.
        format: String,
    },
}

impl fmt::Display for LoadWarning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LoadWarning::IgnoredExtension { extension } => {
                write!(f, "optional extension {extension} ignored")
            }
            LoadWarning::SkippedPrimitives {
                mode,
                primitives,
                elements,
            } => write!(
                f,
                "skipped {primitives} {mode} primitive(s) holding {elements} {}",
                if *mode == "POINTS" {
                    "point(s)"
                } else {
                    "line segment(s)"
                }
            ),
            LoadWarning::BlendTreatedAsOpaque { material } => {
                write!(
                    f,
                    "material {material:?} uses alpha BLEND; treated as opaque"
                )
            }
            LoadWarning::MissingPositionBounds { accessor } => {
                write!(
                    f,
                    "POSITION accessor {accessor} has no min/max; bounds computed"
                )
            }
            LoadWarning::MissingNormals { mesh, primitive } => write!(
                f,
                "mesh {mesh} primitive {primitive} has no normals; flat normals used"
            ),
            LoadWarning::IncompletePrimitive {
                mesh,
                primitive,
                dropped,
            } => write!(
                f,
                "mesh {mesh} primitive {primitive}: {dropped} trailing vertex index(es) do not form a triangle; dropped"
            ),
            LoadWarning::SkippedCamera { camera, reason } => {
                write!(f, "camera {camera:?} skipped: {reason}")
            }
            LoadWarning::IgnoredFeature { feature } => write!(f, "ignored: {feature}"),
            LoadWarning::UnreadDefect {
                item,
                problem,
                safe,
            } => write!(
                f,
                "{item}: {problem}; ignored, as the loader never reads it ({safe})"
            ),
            LoadWarning::RequiredExtensionUnused { extension } => write!(
                f,
                "required extension {extension} is not implemented but no item of the file uses it, so it cannot change the scene"
            ),
            LoadWarning::DecodedImageFormat { image, format } => write!(
                f,
                "image {image} is {format}; decoded for the material's mean colour or alpha mask"
            ),
            LoadWarning::NoDefaultScene => {
                write!(
                    f,
                    "no default scene; the first scene (or all root nodes) loaded"
                )
            }
        }
    }
}
