//! Locates the shared test scenes (`../shared/scenes/` beside the workspace root) for the
//! workspace's tests, examples and benchmarks, so that no test spells a relative path itself;
//! reads a folder's files for tests that compare outputs byte for byte
//! ([`folder_contents`]); and draws the deterministic numbers tests build their random cases
//! from ([`Lcg`]).
//!
//! The folder can be moved with the `PROBE_SCENES_DIR` environment variable.
//!
//! ```
//! let sponza = probe_testdata::scene_path(probe_testdata::SPONZA);
//! assert!(sponza.ends_with("sponza/Sponza_basecolor.gltf"));
//! ```

use std::path::{Path, PathBuf};

/// The classic Cornell box (32 triangles, emissive ceiling quad).
pub const CORNELL_BOX: &str = "cornell_box/CornellBox-Original.gltf";
/// Crytek Sponza with mean-colour textures (262,087 instanced triangles, 4 cameras, no lights).
pub const SPONZA: &str = "sponza/Sponza_basecolor.gltf";
/// Sponza as published: requires `AMD_split_roughnessMetallic` and misses 83 images; must be refused.
pub const SPONZA_AS_PUBLISHED: &str = "sponza/Sponza.gltf";
/// The Breakfast room (262,687 instanced triangles, 3 cameras, no lights).
pub const BREAKFAST_ROOM: &str = "breakfast_room/BreakfastRoom.gltf";
/// The Godot room: one closed 10×5×10 m room with a doorway (63,720 triangles).
pub const GODOT_ROOM: &str = "godot_room/room.glb";
/// One double-sided quad of zero thickness.
pub const TWO_SIDED_PLANE: &str = "failure_cases/two_sided_plane/TwoSidedPlane.glb";
/// One cube drawn 125 times through `EXT_mesh_gpu_instancing`.
pub const GPU_INSTANCING: &str = "failure_cases/gpu_instancing/simple-instancing.glb";
/// A box whose positions are all non-finite; must be refused naming the accessor.
pub const INVALID_INFINITES: &str = "failure_cases/invalid_box_with_infinites/BoxWithInfinites.glb";
/// A primitive with an index past the vertex count; must be refused naming the primitive.
pub const INVALID_INDEX_OUT_OF_RANGE: &str =
    "failure_cases/invalid_index_out_of_range/IndexOutOfRange.gltf";
/// The folder of the 16 primitive-mode test files.
pub const PRIMITIVE_MODES_DIR: &str = "failure_cases/primitive_modes";

/// The folder that holds the shared scenes.
pub fn scenes_dir() -> PathBuf {
    match std::env::var_os("PROBE_SCENES_DIR") {
        Some(dir) => PathBuf::from(dir),
        None => PathBuf::from(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../../shared/scenes"
        )),
    }
}

/// The path of a shared scene file or folder, given relative to the scenes folder
/// (one of this crate's constants, or any other relative path).
pub fn scene_path(relative: &str) -> PathBuf {
    scenes_dir().join(relative)
}

/// Whether the shared scenes are present (they are in CI and beside every checkout here).
pub fn scenes_available() -> bool {
    scene_path(CORNELL_BOX).is_file()
}

/// Every file directly in `dir` with its bytes, sorted by name: two folders hold the same
/// files byte for byte exactly when their contents are equal.
///
/// # Errors
/// Any error reading the folder or one of its files.
pub fn folder_contents(dir: &Path) -> std::io::Result<Vec<(String, Vec<u8>)>> {
    let mut files = std::fs::read_dir(dir)?
        .map(|entry| {
            let entry = entry?;
            let bytes = std::fs::read(entry.path())?;
            Ok((entry.file_name().to_string_lossy().into_owned(), bytes))
        })
        .collect::<std::io::Result<Vec<_>>>()?;
    files.sort();
    Ok(files)
}

/// Deterministic numbers in `[0, 1)` from a seed (a 64-bit linear congruential generator,
/// Knuth's MMIX constants, the top 24 bits): the same seed gives the same numbers on every
/// machine, so tests that draw random cases from it are reproducible.
///
/// ```
/// let mut a = probe_testdata::Lcg(7);
/// let mut b = probe_testdata::Lcg(7);
/// let x = a.uniform();
/// assert!((0.0..1.0).contains(&x));
/// assert_eq!(x, b.uniform());
/// ```
#[derive(Clone, Debug)]
pub struct Lcg(pub u64);

impl Lcg {
    /// The next number, in `[0, 1)`.
    pub fn uniform(&mut self) -> f32 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }
}
