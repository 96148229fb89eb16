//! The on-disk bake: a directory with a JSON manifest and EXR texture arrays.

use std::collections::BTreeMap;
use std::io;
use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};
use probe_octa::{OctaLayout, ShL2Rgb, Surfel};
use probe_scene::Scene;
use probe_scene::memory::MemoryLimit;
use serde::{Deserialize, Serialize};

use crate::atomic;
use crate::bake::{
    BakeSettings, BakedRadiance, MAX_BAKE_RESOLUTION, MISS_DISTANCE, ProbeBake, ProbeSampling,
    ProbeStats,
};
use crate::environment::Environment;
use crate::exr_io::{self, ExrLayer, ExrRead};
use crate::shard::{Shard, ShardRecord};

/// The bake format version this crate writes and the newest it reads.
pub const BAKE_FORMAT_VERSION: u32 = 4;

/// The `format` field of every bake manifest.
const FORMAT_NAME: &str = "probe-capture bake";
/// The manifest's file name inside a bake directory.
pub const MANIFEST_FILE: &str = "manifest.json";

const RADIANCE_FILE: &str = "radiance.exr";
const GEOMETRY_FILE: &str = "geometry.exr";
const PYRAMID_FILE: &str = "pyramid.exr";
const MOMENTS_FILE: &str = "moments.exr";
const IRRADIANCE_FILE: &str = "irradiance.exr";
const SH_FILE: &str = "sh.exr";

/// Why a bake could not be saved. Nothing at the destination is lost in any case.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum BakeSaveError {
    /// A file or directory could not be created, written or renamed. Fix: check the path,
    /// the permissions and the free space.
    #[error("{}: {source}", path.display())]
    Io {
        /// The path that failed.
        path: PathBuf,
        /// The underlying error.
        source: io::Error,
    },
    /// The EXR encoder failed. Fix: usually a full disk or a permission problem; see the
    /// message.
    #[error("{}: writing EXR failed: {source}", path.display())]
    Exr {
        /// The file being written.
        path: PathBuf,
        /// The encoder's error.
        source: exr::error::Error,
    },
    /// The manifest could not be serialised. Fix: report a bug; every bake serialises.
    #[error("{}: {source}", path.display())]
    Manifest {
        /// The manifest's path.
        path: PathBuf,
        /// The serialiser's error.
        source: serde_json::Error,
    },
    /// The destination exists and is neither a bake directory (one holding
    /// `manifest.json`) nor an empty directory, so replacing it could lose data. Fix: choose
    /// another path or remove it yourself.
    #[error("{} exists and is not a bake directory; refusing to replace it", path.display())]
    NotABakeDirectory {
        /// The destination.
        path: PathBuf,
    },
}

/// Why a bake could not be loaded.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum BakeLoadError {
    /// A file could not be read. Fix: check that the directory is a complete bake (the
    /// manifest lists the files) and readable.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file that failed.
        path: PathBuf,
        /// The underlying error.
        source: io::Error,
    },
    /// The manifest is not valid JSON or lacks fields. Fix: re-bake; manifests are written
    /// whole by [`ProbeBake::save`].
    #[error("{}: malformed manifest: {source}", path.display())]
    Manifest {
        /// The manifest's path.
        path: PathBuf,
        /// The parser's error.
        source: serde_json::Error,
    },
    /// The manifest is not a probe-capture bake manifest. Fix: point at a directory written
    /// by [`ProbeBake::save`].
    #[error("{}: not a probe-capture bake manifest (format is {found:?})", path.display())]
    NotABake {
        /// The manifest's path.
        path: PathBuf,
        /// The `format` field found, if any.
        found: Option<String>,
    },
    /// The bake was written in a newer format than this crate reads. Fix: update
    /// probe-capture, or re-bake with this version.
    #[error(
        "{}: bake format version {found} is newer than the supported version {supported}",
        path.display()
    )]
    NewerFormat {
        /// The manifest's path.
        path: PathBuf,
        /// The version in the manifest.
        found: u64,
        /// [`BAKE_FORMAT_VERSION`].
        supported: u32,
    },
    /// The bake was written in an older format than this crate reads (version 1 has no
    /// per-probe noise estimates, version 2 no per-texel distance ranges, version 3's
    /// irradiance maps count the light sources the probes see directly). Fix: re-bake with
    /// this version.
    #[error(
        "{}: bake format version {found} is older than the supported version {supported} \
         (version 1 records no noise estimates, version 2 no distance ranges, version 3's \
         irradiance includes direct light): re-bake it with this version",
        path.display()
    )]
    OlderFormat {
        /// The manifest's path.
        path: PathBuf,
        /// The version in the manifest.
        found: u64,
        /// [`BAKE_FORMAT_VERSION`].
        supported: u32,
    },
    /// The manifest's values are inconsistent (counts, resolutions, settings). Fix: re-bake;
    /// the file was edited or damaged.
    #[error("{}: invalid manifest: {reason}", path.display())]
    InvalidManifest {
        /// The manifest's path.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
    /// The bake was made from another scene (its content hash differs). Fix: load it with the
    /// scene it was baked from, or re-bake for this scene.
    #[error(
        "the bake was made from scene {bake_scene:?} (content hash {bake_hash}), not from \
         {scene:?} (content hash {scene_hash})"
    )]
    SceneMismatch {
        /// The scene name in the manifest.
        bake_scene: String,
        /// The content hash in the manifest (hex).
        bake_hash: String,
        /// The name of the scene given.
        scene: String,
        /// The content hash of the scene given (hex).
        scene_hash: String,
    },
    /// An EXR file is damaged or not EXR. Fix: re-bake.
    #[error("{}: reading EXR failed: {source}", path.display())]
    Exr {
        /// The file.
        path: PathBuf,
        /// The decoder's error.
        source: exr::error::Error,
    },
    /// An EXR file lacks a layer or channel the manifest promises. Fix: re-bake.
    #[error("{}: missing layer {layer:?} channel {channel:?}", path.display())]
    MissingChannel {
        /// The file.
        path: PathBuf,
        /// The layer's name.
        layer: String,
        /// The channel's name.
        channel: String,
    },
    /// A texel of an EXR file is NaN or infinite (bakes hold only finite values; misses store
    /// a finite sky distance). Fix: re-bake; the file is damaged or was edited.
    #[error(
        "{}: layer {layer:?} channel {channel:?} holds a non-finite value at texel {texel}",
        path.display()
    )]
    NonFiniteTexel {
        /// The file.
        path: PathBuf,
        /// The layer's name.
        layer: String,
        /// The channel's name.
        channel: String,
        /// The first offending texel (row-major index in the layer).
        texel: usize,
    },
    /// The bake the manifest describes would not fit the memory limit
    /// ([`bake_memory_estimate`](crate::bake_memory_estimate)); refused before any EXR is
    /// read. Fix: check the manifest (a damaged probe count or resolution gives this), or
    /// raise the limit ([`ProbeBake::load_with_limit`], `--max-memory`).
    #[error("{}: {source}", path.display())]
    OverMemory {
        /// The manifest's path.
        path: PathBuf,
        /// The estimate and the limit.
        source: probe_scene::memory::MemoryExceeded,
    },
    /// The directory holds one shard of a sharded bake ([`PartialBake`](crate::PartialBake)),
    /// not a whole bake. Fix: merge the shards first ([`merge_shards`](crate::merge_shards),
    /// `probes bake-merge OUT SHARD_DIR...`) and load the merged bake.
    #[error(
        "{}: this is shard {index}/{count} of a sharded bake (probes {start}..{end} of \
         {total}), not a whole bake: merge the shards first (`probes bake-merge OUT SHARD_DIR...`)",
        path.display()
    )]
    PartialBake {
        /// The manifest's path.
        path: PathBuf,
        /// The shard's index `K`.
        index: u32,
        /// The shard count `N`.
        count: u32,
        /// The shard's first probe (index in the whole set).
        start: usize,
        /// One past the shard's last probe.
        end: usize,
        /// Probes in the whole set.
        total: usize,
    },
    /// The directory holds a whole bake where a shard of a sharded bake was expected. Fix:
    /// pass the directories written by `probes bake --shard K/N` ([`PartialBake::save`](crate::PartialBake::save)).
    #[error(
        "{}: a whole bake, not a shard of a sharded bake (its manifest has no `shard` record); \
         pass the directories written by `probes bake --shard K/N`",
        path.display()
    )]
    NotAShard {
        /// The manifest's path.
        path: PathBuf,
    },
    /// An EXR layer has another size than the manifest implies, or a channel is not stored
    /// as 32-bit float. Fix: re-bake; the file does not belong to this manifest.
    #[error("{}: layer {layer:?}: {reason}", path.display())]
    WrongLayer {
        /// The file.
        path: PathBuf,
        /// The layer's name.
        layer: String,
        /// What differs.
        reason: String,
    },
}

/// Lowercase hex of bytes.
pub(crate) fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
struct ManifestEnvironment {
    sun_direction: [f32; 3],
    sun_illuminance: f32,
    sun_color: [f32; 3],
    sky_zenith: [f32; 3],
    sky_horizon: [f32; 3],
    sky_ground: [f32; 3],
}

impl From<&Environment> for ManifestEnvironment {
    fn from(e: &Environment) -> Self {
        ManifestEnvironment {
            sun_direction: e.sun_direction.to_array(),
            sun_illuminance: e.sun_illuminance,
            sun_color: e.sun_color.to_array(),
            sky_zenith: e.sky_zenith.to_array(),
            sky_horizon: e.sky_horizon.to_array(),
            sky_ground: e.sky_ground.to_array(),
        }
    }
}

impl From<&ManifestEnvironment> for Environment {
    fn from(e: &ManifestEnvironment) -> Self {
        Environment {
            sun_direction: Vec3::from(e.sun_direction),
            sun_illuminance: e.sun_illuminance,
            sun_color: Vec3::from(e.sun_color),
            sky_zenith: Vec3::from(e.sky_zenith),
            sky_horizon: Vec3::from(e.sky_horizon),
            sky_ground: Vec3::from(e.sky_ground),
        }
    }
}

#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
struct ManifestSettings {
    resolution: u32,
    samples_per_texel: u32,
    max_samples_per_texel: u32,
    /// Tone-mapped variance per texel (`null`: fixed sampling).
    noise_target: Option<f32>,
    bounces: u32,
    seed: u64,
    /// The environment given in the settings (`null`: chosen for the scene).
    environment: Option<ManifestEnvironment>,
    pyramid_levels: u32,
    moments_resolution: u32,
    moments_lobe_power: f32,
    moments_max_distance: Option<f32>,
    irradiance_resolution: u32,
    filter_source_resolution: u32,
    /// Absent in bakes saved before surfels existed: none.
    #[serde(default)]
    surfel_resolution: u32,
    /// Absent in bakes saved before radiance smoothing existed: off.
    #[serde(default)]
    denoise: f32,
    /// Absent for the outgoing radiance (every bake saved before the indirect one existed).
    #[serde(default, skip_serializing_if = "is_outgoing")]
    radiance: ManifestRadiance,
}

/// [`BakedRadiance`] in a manifest.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, Default, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
enum ManifestRadiance {
    #[default]
    Outgoing,
    Indirect,
}

fn is_outgoing(radiance: &ManifestRadiance) -> bool {
    *radiance == ManifestRadiance::Outgoing
}

impl From<BakedRadiance> for ManifestRadiance {
    fn from(r: BakedRadiance) -> Self {
        match r {
            BakedRadiance::Outgoing => ManifestRadiance::Outgoing,
            BakedRadiance::Indirect => ManifestRadiance::Indirect,
        }
    }
}

impl From<ManifestRadiance> for BakedRadiance {
    fn from(r: ManifestRadiance) -> Self {
        match r {
            ManifestRadiance::Outgoing => BakedRadiance::Outgoing,
            ManifestRadiance::Indirect => BakedRadiance::Indirect,
        }
    }
}

#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
struct ManifestScene {
    name: String,
    /// Where the scene came from (`Scene::source`: a glTF path or `builtin:NAME`), so that
    /// tools can reopen it; absent in bakes of scenes built from triangles.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    source: Option<String>,
    content_hash: String,
    /// The scene's bounding box (min and max corners); absent in bakes saved before it was
    /// recorded.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    bounds: Option<[[f32; 3]; 2]>,
}

#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
struct ManifestStats {
    back_face_share: f32,
    miss_share: f32,
    mean_distance: f32,
    min_distance: f32,
}

/// Per probe: the radiance samples taken and the noise they leave.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
struct ManifestSampling {
    samples: u64,
    /// Mean over texels of the variance of the texel's value, tone-mapped (`null` with fewer
    /// than two samples per texel).
    noise: Option<f32>,
    capped_share: f32,
}

#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
struct ManifestLayer {
    name: String,
    width: usize,
    height: usize,
    channels: Vec<String>,
}

#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
struct ManifestFile {
    file: String,
    description: String,
    layers: Vec<ManifestLayer>,
}

/// Which part of a sharded bake a partial bake holds (absent in whole bakes).
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
struct ManifestShard {
    /// The shard's index `K` (0-based).
    index: u32,
    /// The shard count `N`.
    count: u32,
    /// The shard's first probe, as an index in the whole set.
    probe_start: usize,
    /// One past the shard's last probe.
    probe_end: usize,
    /// Probes in the whole set.
    total_probes: usize,
    /// SHA-256 of the whole set's positions (`probe_set_hash`), hex.
    probe_set_hash: String,
}

#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
struct Manifest {
    format: String,
    format_version: u32,
    tool: String,
    scene: ManifestScene,
    /// Present only in a partial bake (one shard of a sharded bake).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    shard: Option<ManifestShard>,
    units: BTreeMap<String, String>,
    probe_count: usize,
    resolution: u32,
    padded_size: u32,
    miss_distance: f32,
    positions: Vec<[f32; 3]>,
    settings: ManifestSettings,
    environment: ManifestEnvironment,
    moments_max_distance: f32,
    pyramid_levels: u32,
    files: Vec<ManifestFile>,
    stats: Vec<ManifestStats>,
    sampling: Vec<ManifestSampling>,
}

/// Splits `count` items of `K` floats into `K` channels.
fn split_channels<const K: usize>(
    names: [&str; K],
    values: impl Iterator<Item = [f32; K]>,
) -> Vec<(String, Vec<f32>)> {
    let mut channels: Vec<(String, Vec<f32>)> = names
        .iter()
        .map(|n| ((*n).to_owned(), Vec::new()))
        .collect();
    for value in values {
        for (channel, v) in channels.iter_mut().zip(value) {
            channel.1.push(v);
        }
    }
    channels
}

/// The channels of a surfel layer, in [`surfel_channels`]' order.
const SURFEL_CHANNELS: [&str; 17] = [
    "surfel.X",
    "surfel.Y",
    "surfel.Z",
    "surfel.area",
    "surfel.normal.X",
    "surfel.normal.Y",
    "surfel.normal.Z",
    "surfel.R",
    "surfel.G",
    "surfel.B",
    "sky.solid_angle",
    "sky.X",
    "sky.Y",
    "sky.Z",
    "sky.R",
    "sky.G",
    "sky.B",
];

fn surfel_channels(s: &Surfel) -> [f32; 17] {
    [
        s.position.x,
        s.position.y,
        s.position.z,
        s.area,
        s.normal.x,
        s.normal.y,
        s.normal.z,
        s.radiance.x,
        s.radiance.y,
        s.radiance.z,
        s.sky_solid_angle,
        s.sky_direction.x,
        s.sky_direction.y,
        s.sky_direction.z,
        s.sky_radiance.x,
        s.sky_radiance.y,
        s.sky_radiance.z,
    ]
}

fn surfel_from_channels(c: &[f32; 17]) -> Surfel {
    Surfel {
        position: Vec3::new(c[0], c[1], c[2]),
        area: c[3],
        normal: Vec3::new(c[4], c[5], c[6]),
        radiance: Vec3::new(c[7], c[8], c[9]),
        sky_solid_angle: c[10],
        sky_direction: Vec3::new(c[11], c[12], c[13]),
        sky_radiance: Vec3::new(c[14], c[15], c[16]),
    }
}

/// The files of a bake, in memory, with the layers they hold.
fn bake_files(bake: &ProbeBake) -> Vec<(&'static str, &'static str, Vec<ExrLayer>)> {
    let probes = bake.probe_count();
    let side = bake.layout().padded_size() as usize;
    let moments_side = bake.settings.moments_resolution as usize + 2;
    let irradiance_side = bake.settings.irradiance_resolution as usize + 2;
    let mut pyramid_layers = Vec::new();
    let per_probe = bake.pyramid_texels_per_probe();
    for level in 0..bake.pyramid_levels {
        let size = (bake.resolution() >> level) as usize;
        let texels = (0..probes).flat_map(|p| {
            bake.pyramid_level(p, level)
                .unwrap_or(&[])
                .iter()
                .map(|t| t.to_array())
        });
        debug_assert_eq!(bake.pyramid.len(), per_probe * probes);
        pyramid_layers.push(ExrLayer {
            name: format!("level{level}"),
            width: size,
            height: size * probes,
            channels: split_channels(["pyramid.min", "pyramid.max"], texels),
        });
    }
    let mut irradiance_layers = vec![ExrLayer {
        name: "irradiance".into(),
        width: irradiance_side,
        height: irradiance_side * probes,
        channels: split_channels(
            ["irradiance.R", "irradiance.G", "irradiance.B"],
            bake.irradiance.iter().map(|v| v.to_array()),
        ),
    }];
    let surfels_side = (bake.settings.surfels_per_side() as usize).pow(2);
    if surfels_side > 0 {
        irradiance_layers.push(ExrLayer {
            name: "surfels".into(),
            width: surfels_side,
            height: probes,
            channels: split_channels(SURFEL_CHANNELS, bake.surfels.iter().map(surfel_channels)),
        });
    }
    vec![
        (
            RADIANCE_FILE,
            "radiance: linear HDR RGB, (N+2)² padded octahedral map per probe, probes stacked vertically",
            vec![ExrLayer {
                name: "radiance".into(),
                width: side,
                height: side * probes,
                channels: split_channels(
                    ["radiance.R", "radiance.G", "radiance.B"],
                    bake.radiance.iter().map(|v| v.to_array()),
                ),
            }],
        ),
        (
            GEOMETRY_FILE,
            "hit normal (world space, zero for misses), radial distance in metres (miss_distance for misses) and the nearest and farthest distance over the texel's sub-texel rays, layout as radiance",
            vec![ExrLayer {
                name: "geometry".into(),
                width: side,
                height: side * probes,
                channels: split_channels(
                    [
                        "normal.X",
                        "normal.Y",
                        "normal.Z",
                        "distance.R",
                        "range.min",
                        "range.max",
                    ],
                    bake.normals
                        .iter()
                        .zip(&bake.distances)
                        .zip(&bake.distance_ranges)
                        .map(|((n, &d), r)| [n.x, n.y, n.z, d, r.x, r.y]),
                ),
            }],
        ),
        (
            PYRAMID_FILE,
            "min/max radial-distance pyramid: layer levelK is (N/2^K)² texels per probe without border, probes stacked vertically",
            pyramid_layers,
        ),
        (
            MOMENTS_FILE,
            "distance moments (E[r], E[r²]) of clamped distances, (M+2)² padded per probe, probes stacked vertically",
            vec![ExrLayer {
                name: "moments".into(),
                width: moments_side,
                height: moments_side * probes,
                channels: split_channels(
                    ["moments.mean", "moments.mean2"],
                    bake.moments.iter().map(|v| v.to_array()),
                ),
            }],
        ),
        (
            IRRADIANCE_FILE,
            "irradiance (cosine convolution of radiance), (K+2)² padded per probe, probes stacked vertically; surfels (when the settings ask for them): S² per probe in a row, one row per probe",
            irradiance_layers,
        ),
        (
            SH_FILE,
            "L2 spherical harmonics of radiance: row = probe, column = coefficient (probe-octa ShL2Rgb order)",
            vec![ExrLayer {
                name: "sh".into(),
                width: 9,
                height: probes,
                channels: split_channels(
                    ["sh.R", "sh.G", "sh.B"],
                    bake.sh
                        .iter()
                        .flat_map(|sh| sh.coefficients.iter().map(|c| c.to_array())),
                ),
            }],
        ),
    ]
}

fn units() -> BTreeMap<String, String> {
    [
        ("distance", "metres along the unit texel direction from the probe"),
        (
            "radiance",
            "linear RGB radiance in the scene's units (emissive materials' W·sr⁻¹·m⁻²; punctual lights' candela and lux taken as radiometric)",
        ),
        ("irradiance", "radiance × steradians (a constant radiance L gives πL)"),
        ("normal", "unit world-space vector, +Y up"),
        ("positions", "metres, world space, +Y up"),
    ]
    .into_iter()
    .map(|(k, v)| (k.to_owned(), v.to_owned()))
    .collect()
}

impl ProbeBake {
    /// Writes the bake to directory `dir`: `manifest.json` (format version, scene name and
    /// content hash, probe positions, resolution, units, settings, environment, per-probe
    /// stats, the files and their channels, tool version) and six EXR files of 32-bit float
    /// texture arrays (each probe's padded map below the previous one): `radiance.exr`
    /// (`radiance.R/G/B`), `geometry.exr` (`normal.X/Y/Z`, `distance.R`, `range.min/max`),
    /// `pyramid.exr` (one layer per level, `pyramid.min/max`), `moments.exr`
    /// (`moments.mean/mean2`),
    /// `irradiance.exr` (`irradiance.R/G/B`) and `sh.exr` (`sh.R/G/B`, 9 columns per probe).
    ///
    /// The write is atomic: everything goes to a temporary directory beside `dir`, which then
    /// replaces `dir`. An existing `dir` is replaced only if it is a bake (holds
    /// `manifest.json`) or empty.
    ///
    /// # Errors
    /// [`BakeSaveError`]; on error `dir` is unchanged.
    pub fn save(&self, dir: impl AsRef<Path>) -> Result<(), BakeSaveError> {
        self.save_with_shard(dir.as_ref(), None)
    }

    /// [`ProbeBake::save`], recording `shard` in the manifest when the bake is one shard of a
    /// sharded bake.
    pub(crate) fn save_with_shard(
        &self,
        dir: &Path,
        shard: Option<&ShardRecord>,
    ) -> Result<(), BakeSaveError> {
        let io_error = |path: &Path, source| BakeSaveError::Io {
            path: path.to_owned(),
            source,
        };
        let may_replace = |dir: &Path| -> Result<(), BakeSaveError> {
            let not_a_bake = || BakeSaveError::NotABakeDirectory {
                path: dir.to_owned(),
            };
            if !dir.is_dir() {
                return Err(not_a_bake());
            }
            if dir.join(MANIFEST_FILE).is_file() {
                return Ok(());
            }
            let mut entries = std::fs::read_dir(dir).map_err(|e| io_error(dir, e))?;
            if entries.next().is_some() {
                return Err(not_a_bake());
            }
            Ok(())
        };
        atomic::write_dir(dir, io_error, may_replace, |temporary| {
            let files = bake_files(self);
            let mut manifest = self.manifest(&files);
            manifest.shard = shard.map(|r| ManifestShard {
                index: r.shard.index(),
                count: r.shard.count(),
                probe_start: r.probe_range.start,
                probe_end: r.probe_range.end,
                total_probes: r.total_probes,
                probe_set_hash: hex(&r.probe_set_hash),
            });
            for (file, _, layers) in files {
                let path = temporary.join(file);
                exr_io::write(&path, layers).map_err(|source| BakeSaveError::Exr {
                    path: dir.join(file),
                    source,
                })?;
            }
            let text = serde_json::to_string_pretty(&manifest).map_err(|source| {
                BakeSaveError::Manifest {
                    path: dir.join(MANIFEST_FILE),
                    source,
                }
            })?;
            std::fs::write(temporary.join(MANIFEST_FILE), text + "\n")
                .map_err(|e| io_error(&dir.join(MANIFEST_FILE), e))
        })
    }

    fn manifest(&self, files: &[(&'static str, &'static str, Vec<ExrLayer>)]) -> Manifest {
        let s = &self.settings;
        Manifest {
            format: FORMAT_NAME.to_owned(),
            format_version: BAKE_FORMAT_VERSION,
            tool: format!("probe-capture {}", env!("CARGO_PKG_VERSION")),
            scene: ManifestScene {
                name: self.scene_name.clone(),
                source: self.scene_source.clone(),
                content_hash: hex(&self.scene_content_hash),
                bounds: self.scene_bounds.map(|b| b.map(|c| c.to_array())),
            },
            shard: None,
            units: units(),
            probe_count: self.probe_count(),
            resolution: self.resolution(),
            padded_size: self.layout().padded_size(),
            miss_distance: MISS_DISTANCE,
            positions: self.positions.iter().map(|p| p.to_array()).collect(),
            settings: ManifestSettings {
                resolution: s.resolution,
                samples_per_texel: s.sampling.samples_per_texel,
                max_samples_per_texel: s.sampling.max_samples_per_texel,
                noise_target: s.sampling.noise_target,
                bounces: s.bounces,
                seed: s.seed,
                environment: s.environment.as_ref().map(ManifestEnvironment::from),
                pyramid_levels: s.pyramid_levels,
                moments_resolution: s.moments_resolution,
                moments_lobe_power: s.moments_lobe_power,
                moments_max_distance: s.moments_max_distance,
                irradiance_resolution: s.irradiance_resolution,
                filter_source_resolution: s.filter_source_resolution,
                surfel_resolution: s.surfel_resolution,
                denoise: s.denoise,
                radiance: s.radiance.into(),
            },
            environment: ManifestEnvironment::from(&self.environment),
            moments_max_distance: self.moments_max_distance,
            pyramid_levels: self.pyramid_levels,
            files: files
                .iter()
                .map(|(file, description, layers)| ManifestFile {
                    file: (*file).to_owned(),
                    description: (*description).to_owned(),
                    layers: layers
                        .iter()
                        .map(|l| ManifestLayer {
                            name: l.name.clone(),
                            width: l.width,
                            height: l.height,
                            channels: l.channels.iter().map(|c| c.0.clone()).collect(),
                        })
                        .collect(),
                })
                .collect(),
            stats: self
                .stats
                .iter()
                .map(|s| ManifestStats {
                    back_face_share: s.back_face_share,
                    miss_share: s.miss_share,
                    mean_distance: s.mean_distance,
                    min_distance: s.min_distance,
                })
                .collect(),
            sampling: self
                .sampling
                .iter()
                .map(|p| ManifestSampling {
                    samples: p.samples,
                    noise: p.noise,
                    capped_share: p.capped_share,
                })
                .collect(),
        }
    }

    /// Reads a bake written by [`ProbeBake::save`]. With `scene`, the bake must have been
    /// made from that scene (same [`Scene::content_hash`]). The data read back equals the
    /// data saved, bit for bit.
    ///
    /// # Errors
    /// [`BakeLoadError::NewerFormat`] for a bake from a newer format version,
    /// [`BakeLoadError::OlderFormat`] for one from an older version,
    /// [`BakeLoadError::SceneMismatch`] for another scene, and the other variants of
    /// [`BakeLoadError`] for missing, damaged or inconsistent files.
    pub fn load(dir: impl AsRef<Path>, scene: Option<&Scene>) -> Result<ProbeBake, BakeLoadError> {
        ProbeBake::load_with_limit(dir, scene, MemoryLimit::machine())
    }

    /// [`ProbeBake::load`] with a memory limit other than the machine's: a manifest whose
    /// probe count and resolutions would not fit `limit` is refused
    /// ([`BakeLoadError::OverMemory`]) before any EXR file is read.
    ///
    /// # Errors
    /// As [`ProbeBake::load`].
    pub fn load_with_limit(
        dir: impl AsRef<Path>,
        scene: Option<&Scene>,
        limit: MemoryLimit,
    ) -> Result<ProbeBake, BakeLoadError> {
        Ok(ProbeBake::load_part(dir.as_ref(), scene, limit, false)?.0)
    }

    /// Loads a whole bake (`shard == false`; a partial bake is refused with
    /// [`BakeLoadError::PartialBake`]) or one shard of a sharded bake (`shard == true`; a
    /// whole bake is refused with [`BakeLoadError::NotAShard`]), with the shard's record.
    pub(crate) fn load_part(
        dir: &Path,
        scene: Option<&Scene>,
        limit: MemoryLimit,
        shard: bool,
    ) -> Result<(ProbeBake, Option<ShardRecord>), BakeLoadError> {
        let ManifestRead {
            path: manifest_path,
            manifest,
            checked,
        } = read_manifest(dir)?;
        match (&checked.shard, shard) {
            (Some(record), false) => {
                return Err(BakeLoadError::PartialBake {
                    path: manifest_path,
                    index: record.shard.index(),
                    count: record.shard.count(),
                    start: record.probe_range.start,
                    end: record.probe_range.end,
                    total: record.total_probes,
                });
            }
            (None, true) => {
                return Err(BakeLoadError::NotAShard {
                    path: manifest_path,
                });
            }
            _ => {}
        }
        if let Some(scene) = scene {
            let scene_hash = hex(&scene.content_hash());
            if scene_hash != manifest.scene.content_hash {
                return Err(BakeLoadError::SceneMismatch {
                    bake_scene: manifest.scene.name.clone(),
                    bake_hash: manifest.scene.content_hash.clone(),
                    scene: scene.name().to_owned(),
                    scene_hash,
                });
            }
        }
        limit
            .check(
                format_args!(
                    "loading a bake of {} probes at {}²",
                    manifest.probe_count, manifest.resolution
                ),
                crate::bake::bake_memory_estimate(manifest.probe_count, &checked.settings),
            )
            .map_err(|source| BakeLoadError::OverMemory {
                path: manifest_path.clone(),
                source,
            })?;
        let probes = manifest.probe_count;
        let n = manifest.resolution as usize;
        let side = n + 2;
        let moments_side = manifest.settings.moments_resolution as usize + 2;
        let irradiance_side = manifest.settings.irradiance_resolution as usize + 2;

        let radiance_layers = read_file(dir, RADIANCE_FILE)?;
        let radiance = take_channels(
            dir,
            RADIANCE_FILE,
            &radiance_layers,
            "radiance",
            (side, side * probes),
            ["radiance.R", "radiance.G", "radiance.B"],
        )?
        .map(Vec3::from_array)
        .collect();
        let geometry_layers = read_file(dir, GEOMETRY_FILE)?;
        let geometry: Vec<[f32; 6]> = take_channels(
            dir,
            GEOMETRY_FILE,
            &geometry_layers,
            "geometry",
            (side, side * probes),
            [
                "normal.X",
                "normal.Y",
                "normal.Z",
                "distance.R",
                "range.min",
                "range.max",
            ],
        )?
        .collect();
        let normals = geometry
            .iter()
            .map(|g| Vec3::new(g[0], g[1], g[2]))
            .collect();
        let distances = geometry.iter().map(|g| g[3]).collect();
        let distance_ranges = geometry.iter().map(|g| Vec2::new(g[4], g[5])).collect();
        let pyramid_layers = read_file(dir, PYRAMID_FILE)?;
        let mut per_level: Vec<Vec<Vec2>> = Vec::new();
        for level in 0..manifest.pyramid_levels {
            let size = n >> level;
            per_level.push(
                take_channels(
                    dir,
                    PYRAMID_FILE,
                    &pyramid_layers,
                    &format!("level{level}"),
                    (size, size * probes),
                    ["pyramid.min", "pyramid.max"],
                )?
                .map(Vec2::from_array)
                .collect(),
            );
        }
        let mut pyramid = Vec::new();
        for p in 0..probes {
            for (level, texels) in per_level.iter().enumerate() {
                let len = (n >> level).pow(2);
                pyramid.extend_from_slice(&texels[p * len..(p + 1) * len]);
            }
        }
        let moments_layers = read_file(dir, MOMENTS_FILE)?;
        let moments = take_channels(
            dir,
            MOMENTS_FILE,
            &moments_layers,
            "moments",
            (moments_side, moments_side * probes),
            ["moments.mean", "moments.mean2"],
        )?
        .map(Vec2::from_array)
        .collect();
        let irradiance_layers = read_file(dir, IRRADIANCE_FILE)?;
        let irradiance = take_channels(
            dir,
            IRRADIANCE_FILE,
            &irradiance_layers,
            "irradiance",
            (irradiance_side, irradiance_side * probes),
            ["irradiance.R", "irradiance.G", "irradiance.B"],
        )?
        .map(Vec3::from_array)
        .collect();
        let surfels_side = (checked.settings.surfels_per_side() as usize).pow(2);
        let surfels = if surfels_side == 0 {
            Vec::new()
        } else {
            take_channels(
                dir,
                IRRADIANCE_FILE,
                &irradiance_layers,
                "surfels",
                (surfels_side, probes),
                SURFEL_CHANNELS,
            )?
            .map(|c| surfel_from_channels(&c))
            .collect()
        };
        let sh_layers = read_file(dir, SH_FILE)?;
        let coefficients: Vec<Vec3> = take_channels(
            dir,
            SH_FILE,
            &sh_layers,
            "sh",
            (9, probes),
            ["sh.R", "sh.G", "sh.B"],
        )?
        .map(Vec3::from_array)
        .collect();
        let sh = coefficients
            .chunks_exact(9)
            .map(|c| ShL2Rgb {
                coefficients: std::array::from_fn(|i| c[i]),
            })
            .collect();

        let bake = ProbeBake {
            scene_name: manifest.scene.name,
            scene_source: manifest.scene.source,
            scene_content_hash: checked.scene_hash,
            scene_bounds: manifest.scene.bounds.map(|b| b.map(Vec3::from)),
            settings: checked.settings,
            environment: Environment::from(&manifest.environment),
            moments_max_distance: manifest.moments_max_distance,
            positions: manifest.positions.iter().copied().map(Vec3::from).collect(),
            layout: checked.layout,
            radiance,
            normals,
            distances,
            distance_ranges,
            pyramid_levels: manifest.pyramid_levels,
            pyramid,
            moments,
            irradiance,
            sh,
            surfels,
            stats: manifest
                .stats
                .iter()
                .map(|s| ProbeStats {
                    back_face_share: s.back_face_share,
                    miss_share: s.miss_share,
                    mean_distance: s.mean_distance,
                    min_distance: s.min_distance,
                })
                .collect(),
            sampling: manifest
                .sampling
                .iter()
                .map(|s| ProbeSampling {
                    samples: s.samples,
                    noise: s.noise,
                    capped_share: s.capped_share,
                })
                .collect(),
        };
        Ok((bake, checked.shard))
    }
}

struct CheckedManifest {
    layout: OctaLayout,
    settings: BakeSettings,
    scene_hash: [u8; 32],
    shard: Option<ShardRecord>,
}

/// A bake's manifest, read and checked (no EXR file read).
struct ManifestRead {
    path: PathBuf,
    manifest: Manifest,
    checked: CheckedManifest,
}

/// Reads and checks the manifest of the bake in `dir`: its format, version and consistency.
fn read_manifest(dir: &Path) -> Result<ManifestRead, BakeLoadError> {
    let manifest_path = dir.join(MANIFEST_FILE);
    let text = std::fs::read_to_string(&manifest_path).map_err(|source| BakeLoadError::Io {
        path: manifest_path.clone(),
        source,
    })?;
    let value: serde_json::Value =
        serde_json::from_str(&text).map_err(|source| BakeLoadError::Manifest {
            path: manifest_path.clone(),
            source,
        })?;
    let format = value.get("format").and_then(|f| f.as_str());
    if format != Some(FORMAT_NAME) {
        return Err(BakeLoadError::NotABake {
            path: manifest_path,
            found: format.map(str::to_owned),
        });
    }
    let version = value.get("format_version").and_then(|v| v.as_u64());
    match version {
        Some(v) if v > u64::from(BAKE_FORMAT_VERSION) => {
            return Err(BakeLoadError::NewerFormat {
                path: manifest_path,
                found: v,
                supported: BAKE_FORMAT_VERSION,
            });
        }
        Some(v) if v == u64::from(BAKE_FORMAT_VERSION) => {}
        Some(v) if v >= 1 => {
            return Err(BakeLoadError::OlderFormat {
                path: manifest_path,
                found: v,
                supported: BAKE_FORMAT_VERSION,
            });
        }
        _ => {
            return Err(BakeLoadError::InvalidManifest {
                path: manifest_path,
                reason: "`format_version` is missing or not a positive integer".into(),
            });
        }
    }
    let manifest: Manifest =
        serde_json::from_value(value).map_err(|source| BakeLoadError::Manifest {
            path: manifest_path.clone(),
            source,
        })?;
    let checked = check_manifest(&manifest).map_err(|reason| BakeLoadError::InvalidManifest {
        path: manifest_path.clone(),
        reason,
    })?;
    Ok(ManifestRead {
        path: manifest_path,
        manifest,
        checked,
    })
}

/// What a bake's manifest says about it, read without its EXR files (for checking shards
/// against each other before loading them).
pub(crate) struct BakeHeader {
    /// The scene's name.
    pub(crate) scene_name: String,
    /// The scene's content hash.
    pub(crate) scene_hash: [u8; 32],
    /// The settings the bake was made with.
    pub(crate) settings: BakeSettings,
    /// The environment it was lit with.
    pub(crate) environment: Environment,
    /// The distance moments were clamped at.
    pub(crate) moments_max_distance: f32,
    /// Probes in this bake.
    pub(crate) probe_count: usize,
    /// The shard record, for a partial bake.
    pub(crate) shard: Option<ShardRecord>,
}

/// Reads the header of the bake in `dir` ([`BakeHeader`]).
pub(crate) fn read_header(dir: &Path) -> Result<BakeHeader, BakeLoadError> {
    let read = read_manifest(dir)?;
    Ok(BakeHeader {
        scene_name: read.manifest.scene.name,
        scene_hash: read.checked.scene_hash,
        settings: read.checked.settings,
        environment: Environment::from(&read.manifest.environment),
        moments_max_distance: read.manifest.moments_max_distance,
        probe_count: read.manifest.probe_count,
        shard: read.checked.shard,
    })
}

/// Parses 64 hex digits.
fn parse_hash(hash: &str) -> Option<[u8; 32]> {
    if hash.len() != 64 || !hash.bytes().all(|b| b.is_ascii_hexdigit()) {
        return None;
    }
    let mut bytes = [0u8; 32];
    for (i, byte) in bytes.iter_mut().enumerate() {
        *byte = u8::from_str_radix(&hash[2 * i..2 * i + 2], 16).ok()?;
    }
    Some(bytes)
}

/// Checks a manifest's shard record against its probe count.
fn check_shard(m: &Manifest) -> Result<Option<ShardRecord>, String> {
    let Some(r) = &m.shard else {
        return Ok(None);
    };
    let shard = Shard::new(r.index, r.count).map_err(|e| format!("`shard`: {e}"))?;
    let range = r.probe_start..r.probe_end;
    if r.total_probes < r.count as usize {
        return Err(format!(
            "`shard.total_probes` {} is less than `shard.count` {}",
            r.total_probes, r.count
        ));
    }
    if shard.probe_range(r.total_probes) != range || range.len() != m.probe_count {
        return Err(format!(
            "`shard` says probes {}..{} of {} for shard {shard}, which holds probes {:?}, \
             and the manifest has {} probes",
            r.probe_start,
            r.probe_end,
            r.total_probes,
            shard.probe_range(r.total_probes),
            m.probe_count
        ));
    }
    let probe_set_hash = parse_hash(&r.probe_set_hash)
        .ok_or_else(|| "`shard.probe_set_hash` is not 64 hex digits".to_owned())?;
    Ok(Some(ShardRecord {
        shard,
        probe_range: range,
        total_probes: r.total_probes,
        probe_set_hash,
    }))
}

fn check_manifest(m: &Manifest) -> Result<CheckedManifest, String> {
    let s = &m.settings;
    let settings = BakeSettings {
        resolution: s.resolution,
        sampling: crate::bake::Sampling {
            samples_per_texel: s.samples_per_texel,
            max_samples_per_texel: s.max_samples_per_texel,
            noise_target: s.noise_target,
        },
        bounces: s.bounces,
        seed: s.seed,
        environment: s.environment.as_ref().map(Environment::from),
        pyramid_levels: s.pyramid_levels,
        moments_resolution: s.moments_resolution,
        moments_lobe_power: s.moments_lobe_power,
        moments_max_distance: s.moments_max_distance,
        irradiance_resolution: s.irradiance_resolution,
        filter_source_resolution: s.filter_source_resolution,
        surfel_resolution: s.surfel_resolution,
        denoise: s.denoise,
        radiance: s.radiance.into(),
    };
    settings.validate().map_err(|e| e.to_string())?;
    if m.resolution != s.resolution || m.resolution > MAX_BAKE_RESOLUTION {
        return Err(format!(
            "`resolution` {} differs from the settings' {}",
            m.resolution, s.resolution
        ));
    }
    let layout = OctaLayout::new(m.resolution).map_err(|e| e.to_string())?;
    if m.padded_size != layout.padded_size() {
        return Err(format!(
            "`padded_size` {} is not resolution + 2",
            m.padded_size
        ));
    }
    if m.probe_count == 0 {
        return Err("`probe_count` is 0".into());
    }
    if m.positions.len() != m.probe_count
        || m.stats.len() != m.probe_count
        || m.sampling.len() != m.probe_count
    {
        return Err(format!(
            "`probe_count` is {} but there are {} positions, {} stats and {} sampling records",
            m.probe_count,
            m.positions.len(),
            m.stats.len(),
            m.sampling.len()
        ));
    }
    if let Some(p) = m.sampling.iter().position(|p| {
        p.noise.is_some_and(|v| !(v.is_finite() && v >= 0.0))
            || !(0.0..=1.0).contains(&p.capped_share)
    }) {
        return Err(format!(
            "probe {p}'s sampling record has a noise that is not a finite non-negative number or a capped share outside 0..1"
        ));
    }
    if m.positions.iter().flatten().any(|c| !c.is_finite()) {
        return Err("a probe position is not finite".into());
    }
    let expected_levels = (m.resolution.trailing_zeros() + 1).min(s.pyramid_levels);
    if m.pyramid_levels != expected_levels {
        return Err(format!(
            "`pyramid_levels` is {} but the settings give {expected_levels}",
            m.pyramid_levels
        ));
    }
    if m.miss_distance != MISS_DISTANCE {
        return Err(format!(
            "`miss_distance` is {} but this version uses {MISS_DISTANCE}",
            m.miss_distance
        ));
    }
    let scene_hash = parse_hash(&m.scene.content_hash)
        .ok_or_else(|| "`scene.content_hash` is not 64 hex digits".to_owned())?;
    Ok(CheckedManifest {
        layout,
        settings,
        scene_hash,
        shard: check_shard(m)?,
    })
}

fn read_file(dir: &Path, file: &str) -> Result<Vec<ExrRead>, BakeLoadError> {
    let path = dir.join(file);
    if !path.is_file() {
        return Err(BakeLoadError::Io {
            source: io::Error::new(io::ErrorKind::NotFound, "file missing from the bake"),
            path,
        });
    }
    exr_io::read(&path).map_err(|source| BakeLoadError::Exr { path, source })
}

/// The named channels of a layer, zipped texel by texel.
fn take_channels<const K: usize>(
    dir: &Path,
    file: &str,
    layers: &[ExrRead],
    layer_name: &str,
    size: (usize, usize),
    names: [&str; K],
) -> Result<impl Iterator<Item = [f32; K]>, BakeLoadError> {
    let path = dir.join(file);
    let layer = layers
        .iter()
        .find(|l| l.name == layer_name)
        .or(if layers.len() == 1 {
            layers.first()
        } else {
            None
        })
        .ok_or_else(|| BakeLoadError::MissingChannel {
            path: path.clone(),
            layer: layer_name.to_owned(),
            channel: names[0].to_owned(),
        })?;
    if (layer.width, layer.height) != size {
        return Err(BakeLoadError::WrongLayer {
            path,
            layer: layer_name.to_owned(),
            reason: format!(
                "size is {}×{}, the manifest implies {}×{}",
                layer.width, layer.height, size.0, size.1
            ),
        });
    }
    let mut channels: Vec<Vec<f32>> = Vec::with_capacity(K);
    for name in names {
        let (_, samples, converted) =
            layer.channels.iter().find(|c| c.0 == name).ok_or_else(|| {
                BakeLoadError::MissingChannel {
                    path: path.clone(),
                    layer: layer_name.to_owned(),
                    channel: name.to_owned(),
                }
            })?;
        if *converted {
            return Err(BakeLoadError::WrongLayer {
                path,
                layer: layer_name.to_owned(),
                reason: format!("channel {name:?} is not stored as 32-bit float"),
            });
        }
        if let Some(texel) = samples.iter().position(|v| !v.is_finite()) {
            return Err(BakeLoadError::NonFiniteTexel {
                path,
                layer: layer_name.to_owned(),
                channel: name.to_owned(),
                texel,
            });
        }
        channels.push(samples.clone());
    }
    let count = size.0 * size.1;
    Ok((0..count).map(move |i| std::array::from_fn(|k| channels[k][i])))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    /// Positions, stats and settings travel as JSON numbers: serde_json must give back the
    /// same f32 bits for any finite value.
    #[test]
    fn json_round_trips_f32_bits() {
        let mut rng = Rng::for_key(99, &[]);
        let mut values = vec![
            0.0f32,
            -0.0,
            f32::MIN_POSITIVE,
            f32::MAX,
            f32::MIN,
            1e-45,
            MISS_DISTANCE,
        ];
        while values.len() < 300_000 {
            let v = f32::from_bits(rng.next_u32());
            if v.is_finite() {
                values.push(v);
            }
        }
        for chunk in values.chunks(3) {
            let triple: [f32; 3] = std::array::from_fn(|i| chunk[i % chunk.len()]);
            let text = serde_json::to_string(&triple).unwrap();
            let back: [f32; 3] = serde_json::from_str(&text).unwrap();
            for (a, b) in triple.iter().zip(&back) {
                assert_eq!(a.to_bits(), b.to_bits(), "{a:e} → {text}");
            }
        }
    }
}
