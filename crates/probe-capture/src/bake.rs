//! Capturing probes: the geometry pass, the radiance pass and the derived maps.

use std::sync::atomic::{AtomicUsize, Ordering};

use glam::{Vec2, Vec3};
use probe_octa::{
    FineRead, MinMaxPyramid, OctaLayout, OctaMap, ShL2Rgb, Texel, irradiance_map, lobe_mean,
};
use probe_scene::{Ray, Scene};

use crate::environment::Environment;
use crate::par::*;
use crate::rng::Rng;
use crate::shading::{Shader, ShaderError};

/// Radial distance stored for texels whose ray leaves the scene (1e9 m): large but finite, so
/// that bilinear filtering on a GPU and the moment filters stay finite. Normals of misses are
/// zero.
pub const MISS_DISTANCE: f32 = 1.0e9;

/// The largest interior resolution [`bake`] accepts (1024², as McGuire 2017).
pub const MAX_BAKE_RESOLUTION: u32 = 1024;

/// A progress callback: called from worker threads with `(completed, total)` work units.
pub type Progress<'a> = &'a (dyn Fn(usize, usize) + Sync);

/// A progress callback that does nothing.
pub fn no_progress(_completed: usize, _total: usize) {}

/// How to bake probes. [`BakeSettings::default`] gives the documented defaults.
#[derive(Clone, Debug, PartialEq)]
pub struct BakeSettings {
    /// Interior octahedral resolution `N` of the radiance, normal and distance maps (stored
    /// padded, `(N+2)²` texels). A power of two from 1 to [`MAX_BAKE_RESOLUTION`] (the
    /// min/max pyramid halves it level by level). Default 256.
    pub resolution: u32,
    /// Jittered radiance samples per texel, stratified on a `⌊√s⌋²` grid over the texel's
    /// octahedral square (the rest uniformly). At least 1. Default 4.
    pub samples_per_texel: u32,
    /// Diffuse bounces added to emission and direct light (see [`Shader`]). Default 1.
    pub bounces: u32,
    /// Seed of every random choice. Default 0.
    pub seed: u64,
    /// Sun and sky; `None` uses [`Environment::for_scene`] (the default daylight for scenes
    /// without any light, black otherwise). Default `None`.
    pub environment: Option<Environment>,
    /// Levels of the min/max distance pyramid (at most `log2 N + 1`; seed 000 uses 6–7).
    /// At least 1. Default 7.
    pub pyramid_levels: u32,
    /// Interior resolution of the distance-moment maps (DDGI: 14). 1 to 256. Default 14.
    pub moments_resolution: u32,
    /// Cosine-power exponent of the moment filter lobe (DDGI: 50). Finite, `>= 0`. Default 50.
    pub moments_lobe_power: f32,
    /// Distances are clamped to this before filtering moments (misses included); `None` uses
    /// the length of the scene's bounding-box diagonal (at least 1 m), which no hit exceeds.
    pub moments_max_distance: Option<f32>,
    /// Interior resolution of the irradiance maps (DDGI: 6). 1 to 256. Default 6.
    pub irradiance_resolution: u32,
    /// The moment and irradiance filters and the SH projection read the full-resolution maps
    /// reduced to at most this resolution by exact solid-angle-weighted 2×2 averaging (of
    /// `(r, r²)` for the moments, so the variance inside a reduced texel is kept). The filters
    /// cost `source texels × output texels`, so this bounds their time at high resolutions
    /// while staying far finer than their lobes. A power of two from 1 to 1024. Default 128.
    pub filter_source_resolution: u32,
}

impl Default for BakeSettings {
    fn default() -> Self {
        BakeSettings {
            resolution: 256,
            samples_per_texel: 4,
            bounces: 1,
            seed: 0,
            environment: None,
            pyramid_levels: 7,
            moments_resolution: probe_octa::DDGI_DISTANCE_RESOLUTION,
            moments_lobe_power: 50.0,
            moments_max_distance: None,
            irradiance_resolution: probe_octa::DDGI_IRRADIANCE_RESOLUTION,
            filter_source_resolution: 128,
        }
    }
}

/// Why a bake (or a geometry capture) was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum BakeError {
    /// A setting is out of range. Fix: see the field's documentation in [`BakeSettings`]
    /// (the message names the field and the accepted range).
    #[error("bake setting `{parameter}` is {value}: {reason}")]
    InvalidSetting {
        /// The [`BakeSettings`] field.
        parameter: &'static str,
        /// The value given, as text.
        value: String,
        /// What is accepted.
        reason: &'static str,
    },
    /// No probe positions were given. Fix: pass at least one position.
    #[error("no probe positions were given")]
    NoProbes,
    /// A probe position is not finite. Fix: pass finite world-space positions.
    #[error("probe {probe} has the non-finite position {position:?}")]
    InvalidPosition {
        /// Index of the probe in the positions given.
        probe: usize,
        /// The position given.
        position: [f32; 3],
    },
    /// The maps would not fit in memory addressable on this machine. Fix: bake fewer probes
    /// or a lower resolution, or bake in batches.
    #[error("{probes} probes at {resolution}² need more memory than this machine can address")]
    TooLarge {
        /// Number of probes asked for.
        probes: usize,
        /// Resolution asked for.
        resolution: u32,
    },
    /// The environment is unusable. Fix: see [`ShaderError`].
    #[error(transparent)]
    Shader(#[from] ShaderError),
}

fn invalid(parameter: &'static str, value: impl ToString, reason: &'static str) -> BakeError {
    BakeError::InvalidSetting {
        parameter,
        value: value.to_string(),
        reason,
    }
}

/// Checks the probe positions and the octahedral resolution shared by every capture.
fn check_capture(positions: &[Vec3], resolution: u32) -> Result<OctaLayout, BakeError> {
    if resolution == 0 || resolution > MAX_BAKE_RESOLUTION || !resolution.is_power_of_two() {
        return Err(invalid(
            "resolution",
            resolution,
            "must be a power of two from 1 to 1024",
        ));
    }
    if positions.is_empty() {
        return Err(BakeError::NoProbes);
    }
    if let Some((probe, p)) = positions.iter().enumerate().find(|(_, p)| !p.is_finite()) {
        return Err(BakeError::InvalidPosition {
            probe,
            position: p.to_array(),
        });
    }
    let layout = OctaLayout::new(resolution).map_err(|_| {
        invalid(
            "resolution",
            resolution,
            "must be a power of two from 1 to 1024",
        )
    })?;
    // Radiance, normals (12 bytes each), distance and pyramid: well under 64 bytes a texel.
    let fits = positions
        .len()
        .checked_mul(layout.padded_len())
        .and_then(|texels| texels.checked_mul(64))
        .is_some_and(|bytes| bytes <= isize::MAX as usize);
    if !fits {
        return Err(BakeError::TooLarge {
            probes: positions.len(),
            resolution,
        });
    }
    Ok(layout)
}

impl BakeSettings {
    /// Checks every field (as [`bake`] does).
    ///
    /// # Errors
    /// [`BakeError::InvalidSetting`] naming the first field out of range, or
    /// [`BakeError::Shader`] for a bad environment.
    pub fn validate(&self) -> Result<(), BakeError> {
        let r = self.resolution;
        if r == 0 || r > MAX_BAKE_RESOLUTION || !r.is_power_of_two() {
            return Err(invalid(
                "resolution",
                r,
                "must be a power of two from 1 to 1024",
            ));
        }
        if self.samples_per_texel == 0 || self.samples_per_texel > 65_536 {
            return Err(invalid(
                "samples_per_texel",
                self.samples_per_texel,
                "must be from 1 to 65536",
            ));
        }
        if self.bounces > 1024 {
            return Err(invalid("bounces", self.bounces, "must be at most 1024"));
        }
        if self.pyramid_levels == 0 {
            return Err(invalid("pyramid_levels", 0, "must be at least 1"));
        }
        for (parameter, value) in [
            ("moments_resolution", self.moments_resolution),
            ("irradiance_resolution", self.irradiance_resolution),
        ] {
            if value == 0 || value > 256 {
                return Err(invalid(parameter, value, "must be from 1 to 256"));
            }
        }
        let f = self.filter_source_resolution;
        if f == 0 || f > MAX_BAKE_RESOLUTION || !f.is_power_of_two() {
            return Err(invalid(
                "filter_source_resolution",
                f,
                "must be a power of two from 1 to 1024",
            ));
        }
        if !(self.moments_lobe_power.is_finite() && self.moments_lobe_power >= 0.0) {
            return Err(invalid(
                "moments_lobe_power",
                self.moments_lobe_power,
                "must be finite and >= 0",
            ));
        }
        if let Some(d) = self.moments_max_distance
            && !(d.is_finite() && d > 0.0)
        {
            return Err(invalid("moments_max_distance", d, "must be finite and > 0"));
        }
        if let Some(environment) = &self.environment {
            environment
                .check()
                .map_err(|(field, reason)| ShaderError::InvalidEnvironment { field, reason })?;
        }
        Ok(())
    }
}

/// Per-probe statistics of what the probe's texel-centre rays hit. Shares count texels (not
/// solid angle) over the `N²` interior texels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProbeStats {
    /// Share of texels whose ray hits the back face of a single-sided surface: near 1 for a
    /// probe inside closed geometry (DDGI turns such probes off).
    pub back_face_share: f32,
    /// Share of texels whose ray leaves the scene.
    pub miss_share: f32,
    /// Mean radial distance over the texels that hit something ([`MISS_DISTANCE`] if none).
    pub mean_distance: f32,
    /// Smallest radial distance over the texels ([`MISS_DISTANCE`] if none hits).
    pub min_distance: f32,
}

/// What one texel-centre ray saw.
struct TexelGeometry {
    distance: f32,
    normal: Vec3,
    back_face: bool,
}

/// Traces one texel-centre ray. The stored normal is the shading normal on the side the ray
/// hit: flipped towards the probe on the back of a double-sided surface, and left pointing
/// away from the probe on the back of a single-sided one, which marks a back-face hit. Where
/// the interpolated normal disagrees with the plane about the side, the plane normal is used,
/// so `normal · direction > 0` holds exactly for back-face hits (up to exactly grazing ones).
fn trace_texel_geometry(scene: &Scene, ray: &Ray) -> TexelGeometry {
    match scene.closest_hit(ray, f32::INFINITY) {
        Some(hit) => {
            let double_sided = scene.materials()[hit.material as usize].double_sided;
            let back_face = !hit.front_face && !double_sided;
            let sign = if !hit.front_face && double_sided {
                -1.0
            } else {
                1.0
            };
            let geometric = hit.geometric_normal * sign;
            let mut normal = hit.shading_normal * sign;
            if (normal.dot(ray.direction) > 0.0) != (geometric.dot(ray.direction) > 0.0) {
                normal = geometric;
            }
            TexelGeometry {
                distance: hit.t,
                normal,
                back_face,
            }
        }
        None => TexelGeometry {
            distance: MISS_DISTANCE,
            normal: Vec3::ZERO,
            back_face: false,
        },
    }
}

#[derive(Clone, Copy, Default)]
struct RowStats {
    back_faces: u32,
    misses: u32,
    distance_sum: f64,
    min_distance: f32,
}

/// The geometry of a set of probes: per probe the radial distance and hit normal of every
/// texel-centre ray (padded maps, probe-major, as in [`ProbeBake`]) and its [`ProbeStats`].
/// Normals are world-space shading normals on the side the ray hit, except on back faces of
/// single-sided surfaces, where they point away from the probe (`normal · direction > 0`):
/// that marks a probe seeing the inside of a solid. This is the first pass
/// of [`bake`]; placement and visibility work that needs no radiance can call
/// [`capture_geometry`] alone.
#[derive(Clone, Debug, PartialEq)]
pub struct ProbeGeometry {
    positions: Vec<Vec3>,
    layout: OctaLayout,
    normals: Vec<Vec3>,
    distances: Vec<f32>,
    stats: Vec<ProbeStats>,
}

impl ProbeGeometry {
    /// The probe positions, world space.
    pub fn positions(&self) -> &[Vec3] {
        &self.positions
    }

    /// The interior resolution `N`.
    pub fn resolution(&self) -> u32 {
        self.layout.resolution()
    }

    /// Radial distances, `(N+2)²` padded texels per probe, probe after probe
    /// ([`MISS_DISTANCE`] for misses).
    pub fn distances(&self) -> &[f32] {
        &self.distances
    }

    /// Hit normals, laid out as [`Self::distances`] (zero for misses).
    pub fn normals(&self) -> &[Vec3] {
        &self.normals
    }

    /// Per-probe statistics.
    pub fn stats(&self) -> &[ProbeStats] {
        &self.stats
    }

    /// Layout of the maps.
    pub fn layout(&self) -> OctaLayout {
        self.layout
    }

    /// One probe's distance map, or `None` past the last probe.
    pub fn distance_map(&self, probe: usize) -> Option<OctaMap<f32>> {
        probe_map(&self.distances, self.layout, probe)
    }

    /// One probe's normal map, or `None` past the last probe.
    pub fn normal_map(&self, probe: usize) -> Option<OctaMap<Vec3>> {
        probe_map(&self.normals, self.layout, probe)
    }
}

/// Copies probe `probe`'s padded slice of a probe-major array into a map.
fn probe_map<T: Texel>(all: &[T], layout: OctaLayout, probe: usize) -> Option<OctaMap<T>> {
    let len = layout.padded_len();
    let texels = all.get(probe * len..(probe + 1) * len)?;
    OctaMap::from_padded(layout.resolution(), texels.to_vec()).ok()
}

/// Casts one ray through the centre of every texel of every probe (in parallel) and records
/// radial distance, hit normal and per-probe statistics. `progress` receives
/// `(rows done, probes × N)`.
///
/// # Errors
/// [`BakeError::InvalidSetting`] (parameter `resolution`: a power of two from 1 to 1024),
/// [`BakeError::NoProbes`], [`BakeError::InvalidPosition`], [`BakeError::TooLarge`].
pub fn capture_geometry(
    scene: &Scene,
    positions: &[Vec3],
    resolution: u32,
    progress: Progress<'_>,
) -> Result<ProbeGeometry, BakeError> {
    let layout = check_capture(positions, resolution)?;
    let total = positions.len() * resolution as usize;
    let done = AtomicUsize::new(0);
    Ok(geometry_pass(scene, positions, layout, &|| {
        let d = done.fetch_add(1, Ordering::Relaxed) + 1;
        progress(d, total);
    }))
}

fn geometry_pass(
    scene: &Scene,
    positions: &[Vec3],
    layout: OctaLayout,
    row_done: &(dyn Fn() + Sync),
) -> ProbeGeometry {
    let n = layout.resolution() as usize;
    let side = layout.padded_size() as usize;
    let len = layout.padded_len();
    let mut normals = vec![Vec3::ZERO; positions.len() * len];
    let mut distances = vec![0.0f32; positions.len() * len];
    let directions: Vec<Vec3> = (0..n * n)
        .map(|i| layout.texel_direction((i % n) as u32, (i / n) as u32))
        .collect();
    let stats: Vec<ProbeStats> = normals
        .par_chunks_mut(len)
        .zip(distances.par_chunks_mut(len))
        .zip(positions.par_iter())
        .map(|((normal_map, distance_map), &origin)| {
            let rows: Vec<RowStats> = normal_map
                .par_chunks_mut(side)
                .zip(distance_map.par_chunks_mut(side))
                .skip(1)
                .take(n)
                .enumerate()
                .map(|(iy, (normal_row, distance_row))| {
                    let mut row = RowStats {
                        min_distance: MISS_DISTANCE,
                        ..RowStats::default()
                    };
                    for ix in 0..n {
                        // Texel directions are unit vectors already.
                        let ray = Ray {
                            origin,
                            direction: directions[iy * n + ix],
                        };
                        let texel = trace_texel_geometry(scene, &ray);
                        normal_row[ix + 1] = texel.normal;
                        distance_row[ix + 1] = texel.distance;
                        if texel.distance >= MISS_DISTANCE {
                            row.misses += 1;
                        } else {
                            row.distance_sum += f64::from(texel.distance);
                            row.min_distance = row.min_distance.min(texel.distance);
                        }
                        row.back_faces += u32::from(texel.back_face);
                    }
                    row_done();
                    row
                })
                .collect();
            // The slices have the layout's length, so padding cannot fail.
            let _ = layout.pad(normal_map);
            let _ = layout.pad(distance_map);
            let mut total = RowStats {
                min_distance: MISS_DISTANCE,
                ..RowStats::default()
            };
            for row in rows {
                total.back_faces += row.back_faces;
                total.misses += row.misses;
                total.distance_sum += row.distance_sum;
                total.min_distance = total.min_distance.min(row.min_distance);
            }
            let texels = (n * n) as f64;
            let hits = n * n - total.misses as usize;
            ProbeStats {
                back_face_share: (f64::from(total.back_faces) / texels) as f32,
                miss_share: (f64::from(total.misses) / texels) as f32,
                mean_distance: if hits > 0 {
                    (total.distance_sum / hits as f64) as f32
                } else {
                    MISS_DISTANCE
                },
                min_distance: total.min_distance,
            }
        })
        .collect();
    ProbeGeometry {
        positions: positions.to_vec(),
        layout,
        normals,
        distances,
        stats,
    }
}

/// Probes baked from a scene: the in-memory form the GPU tracer uploads as is, and what
/// [`ProbeBake::save`] writes.
///
/// Every full-resolution channel is one flat array, probe-major, each probe's map padded to
/// `(N+2)²` texels in probe-octa's layout ([`OctaLayout`]: row-major, interior texel
/// `(ix, iy)` at padded `(ix+1, iy+1)`, border per seed 001 Listing 4.4). So texel `t` of
/// probe `p` is element `p·(N+2)² + t`, and the array is a texture array of `(N+2)²` layers
/// stacked one after another.
///
/// - **radiance**: linear HDR RGB, the mean of [`BakeSettings::samples_per_texel`] jittered
///   samples over the texel's octahedral square, each the [`Shader`]'s outgoing radiance of
///   the hit (emission + direct light + bounces) or the sky for a miss;
/// - **normal**: world-space hit normal of the texel-centre ray (zero for misses; pointing
///   away from the probe only on back faces of single-sided surfaces, see
///   [`ProbeGeometry`]);
/// - **distance**: radial distance in metres of the texel-centre ray's hit
///   ([`MISS_DISTANCE`] for misses);
/// - **pyramid**: min/max radial-distance pyramid ([`MinMaxPyramid`] with
///   [`FineRead::Bilinear`], so it bounds both bilinear and nearest readers): per probe, its
///   levels one after another, level `k` being `(N/2^k)²` texels `(min, max)` without border;
/// - **moments**: `(E[r], E[r²])` of the distance clamped to
///   [`ProbeBake::moments_max_distance`], lobe-filtered with
///   [`BakeSettings::moments_lobe_power`] (probe-octa's [`lobe_mean`] of `(r, r²)`, which is
///   [`probe_octa::distance_moments`]) at [`BakeSettings::moments_resolution`] `M`, padded
///   `(M+2)²` per probe;
/// - **irradiance**: cosine-convolved radiance ([`irradiance_map`]) at
///   [`BakeSettings::irradiance_resolution`] `K`, padded `(K+2)²` per probe;
///
/// (both filters read the maps reduced to [`BakeSettings::filter_source_resolution`]);
/// - **sh**: L2 spherical harmonics of the radiance ([`ShL2Rgb::project`]; call
///   [`ShL2Rgb::irradiance`] for irradiance), one per probe;
/// - **stats**: [`ProbeStats`] per probe.
#[derive(Clone, Debug, PartialEq)]
pub struct ProbeBake {
    pub(crate) scene_name: String,
    pub(crate) scene_source: Option<String>,
    pub(crate) scene_content_hash: [u8; 32],
    pub(crate) settings: BakeSettings,
    pub(crate) environment: Environment,
    pub(crate) moments_max_distance: f32,
    pub(crate) positions: Vec<Vec3>,
    pub(crate) layout: OctaLayout,
    pub(crate) radiance: Vec<Vec3>,
    pub(crate) normals: Vec<Vec3>,
    pub(crate) distances: Vec<f32>,
    pub(crate) pyramid_levels: u32,
    pub(crate) pyramid: Vec<Vec2>,
    pub(crate) moments: Vec<Vec2>,
    pub(crate) irradiance: Vec<Vec3>,
    pub(crate) sh: Vec<ShL2Rgb>,
    pub(crate) stats: Vec<ProbeStats>,
}

impl ProbeBake {
    /// Number of probes.
    pub fn probe_count(&self) -> usize {
        self.positions.len()
    }

    /// The probe positions, world space.
    pub fn positions(&self) -> &[Vec3] {
        &self.positions
    }

    /// Interior resolution `N` of the full-resolution maps.
    pub fn resolution(&self) -> u32 {
        self.layout.resolution()
    }

    /// Layout of the full-resolution maps.
    pub fn layout(&self) -> OctaLayout {
        self.layout
    }

    /// The settings the bake was made with.
    pub fn settings(&self) -> &BakeSettings {
        &self.settings
    }

    /// The environment (sun and sky) the bake was lit with.
    pub fn environment(&self) -> &Environment {
        &self.environment
    }

    /// Name of the scene the bake was made from.
    pub fn scene_name(&self) -> &str {
        &self.scene_name
    }

    /// Where the scene came from, as [`probe_scene::Scene::open`] accepts it (a glTF path as
    /// given when baking, or `builtin:NAME`); `None` for scenes built from triangles.
    pub fn scene_source(&self) -> Option<&str> {
        self.scene_source.as_deref()
    }

    /// [`Scene::content_hash`] of the scene the bake was made from.
    pub fn scene_content_hash(&self) -> [u8; 32] {
        self.scene_content_hash
    }

    /// The distance at which distances were clamped before filtering moments.
    pub fn moments_max_distance(&self) -> f32 {
        self.moments_max_distance
    }

    /// Radiance of all probes, padded `(N+2)²` per probe.
    pub fn radiance(&self) -> &[Vec3] {
        &self.radiance
    }

    /// Hit normals of all probes, padded `(N+2)²` per probe.
    pub fn normals(&self) -> &[Vec3] {
        &self.normals
    }

    /// Radial distances of all probes, padded `(N+2)²` per probe.
    pub fn distances(&self) -> &[f32] {
        &self.distances
    }

    /// Number of pyramid levels per probe.
    pub fn pyramid_level_count(&self) -> u32 {
        self.pyramid_levels
    }

    /// Texels of one probe's pyramid, all levels (`Σ_k (N/2^k)²`).
    pub fn pyramid_texels_per_probe(&self) -> usize {
        (0..self.pyramid_levels)
            .map(|k| ((self.resolution() >> k) as usize).pow(2))
            .sum()
    }

    /// The whole pyramid array: per probe its levels one after another, each `(min, max)`.
    pub fn pyramid(&self) -> &[Vec2] {
        &self.pyramid
    }

    /// Level `level` of probe `probe`'s pyramid (`(N/2^level)²` texels, row-major, no
    /// border), or `None` past the last probe or level.
    pub fn pyramid_level(&self, probe: usize, level: u32) -> Option<&[Vec2]> {
        if probe >= self.probe_count() || level >= self.pyramid_levels {
            return None;
        }
        let start = probe * self.pyramid_texels_per_probe()
            + (0..level)
                .map(|k| ((self.resolution() >> k) as usize).pow(2))
                .sum::<usize>();
        let len = ((self.resolution() >> level) as usize).pow(2);
        self.pyramid.get(start..start + len)
    }

    /// Distance moments of all probes, padded `(M+2)²` per probe (`M` =
    /// [`BakeSettings::moments_resolution`]).
    pub fn moments(&self) -> &[Vec2] {
        &self.moments
    }

    /// Irradiance of all probes, padded `(K+2)²` per probe (`K` =
    /// [`BakeSettings::irradiance_resolution`]).
    pub fn irradiance(&self) -> &[Vec3] {
        &self.irradiance
    }

    /// L2 spherical harmonics of each probe's radiance.
    pub fn sh(&self) -> &[ShL2Rgb] {
        &self.sh
    }

    /// Per-probe statistics.
    pub fn stats(&self) -> &[ProbeStats] {
        &self.stats
    }

    /// Probe `probe`'s radiance map, or `None` past the last probe.
    pub fn radiance_map(&self, probe: usize) -> Option<OctaMap<Vec3>> {
        probe_map(&self.radiance, self.layout(), probe)
    }

    /// Probe `probe`'s normal map, or `None` past the last probe.
    pub fn normal_map(&self, probe: usize) -> Option<OctaMap<Vec3>> {
        probe_map(&self.normals, self.layout(), probe)
    }

    /// Probe `probe`'s radial-distance map, or `None` past the last probe.
    pub fn distance_map(&self, probe: usize) -> Option<OctaMap<f32>> {
        probe_map(&self.distances, self.layout(), probe)
    }

    /// Probe `probe`'s distance-moment map, or `None` past the last probe.
    pub fn moments_map(&self, probe: usize) -> Option<OctaMap<Vec2>> {
        let layout = OctaLayout::new(self.settings.moments_resolution).ok()?;
        probe_map(&self.moments, layout, probe)
    }

    /// Probe `probe`'s irradiance map, or `None` past the last probe.
    pub fn irradiance_map(&self, probe: usize) -> Option<OctaMap<Vec3>> {
        let layout = OctaLayout::new(self.settings.irradiance_resolution).ok()?;
        probe_map(&self.irradiance, layout, probe)
    }
}

/// Bakes probes at `positions` in `scene`: the geometry pass ([`capture_geometry`]), the
/// radiance pass (per texel [`BakeSettings::samples_per_texel`] jittered rays shaded by the
/// [`Shader`]) and the derived maps, all spread over rayon's thread pool.
///
/// Deterministic: every texel draws its random numbers from a generator keyed by
/// `(seed, probe, texel)`, and per-probe sums run in a fixed order, so the same inputs give the
/// same bytes whatever the number of threads. `progress` receives `(done, total)` with
/// `total = 2 · probes · N + probes` (rows of the two passes, then one unit per probe's
/// derived maps); it is called from worker threads.
///
/// # Errors
/// [`BakeError`] for invalid settings or positions (see [`BakeSettings::validate`]).
///
/// # Example
/// ```
/// use probe_capture::{BakeSettings, bake, no_progress};
/// use probe_scene::{Scene, glam::Vec3};
///
/// let scene = Scene::builtin("cornell")?;
/// let settings = BakeSettings { resolution: 16, samples_per_texel: 1, ..Default::default() };
/// let probes = bake(&scene, &[Vec3::new(0.28, 0.27, 0.28)], &settings, &no_progress)?;
/// assert_eq!(probes.radiance().len(), 18 * 18);
/// // The box is open towards −Z: a probe inside sees out through that side only.
/// let stats = probes.stats()[0];
/// assert!(stats.miss_share > 0.05 && stats.miss_share < 0.5);
/// assert!(probes.radiance().iter().all(|r| r.is_finite() && r.min_element() >= 0.0));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn bake(
    scene: &Scene,
    positions: &[Vec3],
    settings: &BakeSettings,
    progress: Progress<'_>,
) -> Result<ProbeBake, BakeError> {
    settings.validate()?;
    let layout = check_capture(positions, settings.resolution)?;
    let environment = settings
        .environment
        .unwrap_or_else(|| Environment::for_scene(scene));
    let shader = Shader::new(scene, environment, settings.bounces)?;
    let n = settings.resolution as usize;
    let probes = positions.len();
    let total = 2 * probes * n + probes;
    let done = AtomicUsize::new(0);
    let tick = || {
        let d = done.fetch_add(1, Ordering::Relaxed) + 1;
        progress(d, total);
    };

    let geometry = geometry_pass(scene, positions, layout, &tick);
    let radiance = radiance_pass(&shader, positions, layout, settings, &tick);

    let moments_max_distance = settings
        .moments_max_distance
        .unwrap_or_else(|| scene.bounds().size().length().max(1.0));
    let len = layout.padded_len();
    let reducer = Reducer::new(layout.resolution(), settings.filter_source_resolution);
    let derived: Vec<DerivedMaps> = (0..probes)
        .into_par_iter()
        .map(|p| {
            let maps = derived_maps(
                layout,
                &reducer,
                &radiance[p * len..(p + 1) * len],
                &geometry.distances[p * len..(p + 1) * len],
                settings,
                moments_max_distance,
            );
            tick();
            maps
        })
        .collect::<Result<_, _>>()?;
    let mut pyramid = Vec::new();
    let mut moments = Vec::new();
    let mut irradiance = Vec::new();
    let mut sh = Vec::with_capacity(probes);
    let mut pyramid_levels = 0;
    for maps in derived {
        pyramid_levels = maps.pyramid_levels;
        pyramid.extend(maps.pyramid);
        moments.extend_from_slice(maps.moments.texels());
        irradiance.extend_from_slice(maps.irradiance.texels());
        sh.push(maps.sh);
    }
    Ok(ProbeBake {
        scene_name: scene.name().to_owned(),
        scene_source: match scene.source() {
            probe_scene::SceneSource::Triangles => None,
            source => Some(source.to_string()),
        },
        scene_content_hash: scene.content_hash(),
        settings: settings.clone(),
        environment,
        moments_max_distance,
        positions: positions.to_vec(),
        layout,
        radiance,
        normals: geometry.normals,
        distances: geometry.distances,
        pyramid_levels,
        pyramid,
        moments,
        irradiance,
        sh,
        stats: geometry.stats,
    })
}

/// The octahedral point of radiance sample `k` of `count` in texel `(ix, iy)`: stratified on
/// an `m × m` grid (`m = ⌊√count⌋`) for the first `m²` samples, uniform for the rest.
#[inline]
fn texel_sample_point(n: f32, ix: u32, iy: u32, k: u32, count: u32, rng: &mut Rng) -> Vec2 {
    let m = (count as f32).sqrt().floor().max(1.0) as u32;
    let jitter = rng.next_vec2();
    let within = if k < m * m {
        (Vec2::new((k % m) as f32, (k / m) as f32) + jitter) / m as f32
    } else {
        jitter
    };
    let texel = Vec2::new(ix as f32, iy as f32) + within.min(Vec2::splat(1.0 - f32::EPSILON));
    texel * (2.0 / n) - Vec2::ONE
}

fn radiance_pass(
    shader: &Shader<'_>,
    positions: &[Vec3],
    layout: OctaLayout,
    settings: &BakeSettings,
    row_done: &(dyn Fn() + Sync),
) -> Vec<Vec3> {
    let n = layout.resolution();
    let side = layout.padded_size() as usize;
    let len = layout.padded_len();
    let count = settings.samples_per_texel;
    let mut radiance = vec![Vec3::ZERO; positions.len() * len];
    radiance
        .par_chunks_mut(len)
        .zip(positions.par_iter())
        .enumerate()
        .for_each(|(probe, (map, &origin))| {
            map.par_chunks_mut(side)
                .skip(1)
                .take(n as usize)
                .enumerate()
                .for_each(|(iy, row)| {
                    let iy = iy as u32;
                    for ix in 0..n {
                        let texel = u64::from(iy) * u64::from(n) + u64::from(ix);
                        let mut rng = Rng::for_key(settings.seed, &[probe as u64, texel]);
                        let mut sum = Vec3::ZERO;
                        for k in 0..count {
                            let octa = texel_sample_point(n as f32, ix, iy, k, count, &mut rng);
                            let ray = Ray {
                                origin,
                                direction: probe_octa::decode(octa),
                            };
                            sum += shader.trace(&ray, &mut rng).1;
                        }
                        row[ix as usize + 1] = sum / count as f32;
                    }
                    row_done();
                });
            let _ = layout.pad(map);
        });
    radiance
}

struct DerivedMaps {
    pyramid_levels: u32,
    pyramid: Vec<Vec2>,
    moments: OctaMap<Vec2>,
    irradiance: OctaMap<Vec3>,
    sh: ShL2Rgb,
}

fn derived_maps(
    layout: OctaLayout,
    reducer: &Reducer,
    radiance: &[Vec3],
    distances: &[f32],
    settings: &BakeSettings,
    moments_max_distance: f32,
) -> Result<DerivedMaps, BakeError> {
    let n = layout.resolution();
    let distance = OctaMap::from_padded(n, distances.to_vec())
        .map_err(|_| invalid("resolution", n, "must be a power of two from 1 to 1024"))?;
    let radiance = OctaMap::from_padded(n, radiance.to_vec())
        .map_err(|_| invalid("resolution", n, "must be a power of two from 1 to 1024"))?;
    let pyramid = MinMaxPyramid::build(&distance, FineRead::Bilinear, settings.pyramid_levels)
        .map_err(|_| {
            invalid(
                "pyramid_levels",
                settings.pyramid_levels,
                "must be at least 1",
            )
        })?;
    let mut levels = Vec::new();
    for level in 0..pyramid.level_count() {
        levels.extend_from_slice(pyramid.level(level).unwrap_or(&[]));
    }
    let moment_source = reducer.reduce(&distance.map(|r| {
        let r = r.min(moments_max_distance);
        Vec2::new(r, r * r)
    }));
    let moments = lobe_mean(
        &moment_source,
        settings.moments_resolution,
        settings.moments_lobe_power,
    )
    .map_err(|_| {
        invalid(
            "moments_resolution",
            settings.moments_resolution,
            "must be from 1 to 256",
        )
    })?;
    let irradiance_source = reducer.reduce(&radiance);
    let irradiance =
        irradiance_map(&irradiance_source, settings.irradiance_resolution).map_err(|_| {
            invalid(
                "irradiance_resolution",
                settings.irradiance_resolution,
                "must be from 1 to 256",
            )
        })?;
    Ok(DerivedMaps {
        pyramid_levels: pyramid.level_count() as u32,
        pyramid: levels,
        moments,
        irradiance,
        sh: ShL2Rgb::project(&irradiance_source),
    })
}

/// Reduces power-of-two maps of one resolution to at most a limit, halving them level by
/// level: each coarse texel is the solid-angle-weighted mean of the 2×2 fine texels it covers
/// (exactly its own square, so the integral of the map over any coarse texel is kept). The
/// solid angles of every level are computed once and shared by all maps.
struct Reducer {
    /// Per halving step, the fine level's layout and its texel solid angles.
    steps: Vec<(OctaLayout, Vec<f32>)>,
}

impl Reducer {
    fn new(resolution: u32, limit: u32) -> Reducer {
        let mut steps = Vec::new();
        let mut n = resolution;
        while n > limit.max(1) && n.is_multiple_of(2) {
            if let Ok(layout) = OctaLayout::new(n) {
                steps.push((layout, layout.texel_solid_angles()));
            }
            n /= 2;
        }
        Reducer { steps }
    }

    /// The reduced map (the map itself when no step is needed). Maps of another resolution
    /// than the reducer's are returned unchanged.
    fn reduce<T: Texel>(&self, map: &OctaMap<T>) -> OctaMap<T> {
        let mut current = map.clone();
        for (fine, angles) in &self.steps {
            if current.layout() != *fine {
                break;
            }
            let n = fine.resolution();
            let half = n / 2;
            let mut interior = Vec::with_capacity((half * half) as usize);
            for y in 0..half {
                for x in 0..half {
                    let mut sum = T::zero();
                    let mut weight = 0.0f32;
                    for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                        let (ix, iy) = (2 * x + dx, 2 * y + dy);
                        let w = angles[(iy * n + ix) as usize];
                        sum = sum.add_scaled(current.texels()[fine.interior_index(ix, iy)], w);
                        weight += w;
                    }
                    interior.push(T::zero().add_scaled(sum, 1.0 / weight));
                }
            }
            match OctaMap::from_interior(half, &interior) {
                Ok(coarse) => current = coarse,
                Err(_) => break,
            }
        }
        current
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reduction_keeps_integrals_over_coarse_texels() {
        let map = OctaMap::from_fn(32, |d: Vec3| Vec2::new(1.0 + d.x * d.y, 2.0 + d.z)).unwrap();
        let coarse = Reducer::new(32, 8).reduce(&map);
        assert_eq!(coarse.resolution(), 8);
        assert_eq!(Reducer::new(32, 64).reduce(&map), map);
        assert_eq!(Reducer::new(32, 32).reduce(&map), map);
        let integral = |m: &OctaMap<Vec2>| {
            let layout = m.layout();
            let angles = layout.texel_solid_angles();
            let n = layout.resolution();
            let mut sum = glam::DVec2::ZERO;
            for iy in 0..n {
                for ix in 0..n {
                    let v = m.get(ix, iy).unwrap();
                    sum += v.as_dvec2() * f64::from(angles[(iy * n + ix) as usize]);
                }
            }
            sum
        };
        let (a, b) = (integral(&map), integral(&coarse));
        assert!(
            (a - b).abs().max_element() < 1e-4 * a.abs().max_element(),
            "{a} vs {b}"
        );
        // The border is padded.
        let mut repadded = coarse.clone();
        repadded.pad();
        assert_eq!(repadded, coarse);
    }
}
