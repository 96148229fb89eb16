//! Capturing probes: the geometry pass, the radiance pass and the derived maps.

use std::sync::atomic::{AtomicUsize, Ordering};

use glam::{Vec2, Vec3};
use probe_octa::{
    FineRead, MinMaxPyramid, OctaLayout, OctaMap, ShL2Rgb, Surfel, Texel, irradiance_map,
    lobe_mean, surfel_map,
};
use probe_scene::memory::{MemoryExceeded, MemoryLimit};
use probe_scene::{Hit, Ray, Scene};

use crate::environment::Environment;
use crate::par::*;
use crate::rng::{Sampler, SobolSampler};
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
    /// How many radiance samples each texel takes ([`Sampling`]). Default: adaptive, 8 to 128
    /// samples per texel until each probe's mean texel noise is
    /// [`Sampling::DEFAULT_NOISE_TARGET`].
    pub sampling: Sampling,
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
    /// Surfels per side of each probe ([`probe_octa::surfel_map`]): the probe's texels
    /// grouped into `S×S` surface patches (centroid, normal, area, indirect radiance, sky) from
    /// which diffuse shading re-gathers the light arriving at points away from the probe (the
    /// near-field correction, `probe_trace_gpu::DiffuseOptions::parallax`). A power of two up
    /// to 1024, or 0 for none; a bake of lower `resolution` makes one surfel per texel
    /// ([`Self::surfels_per_side`]). Default 8 (64 surfels, 4 KiB per probe): chosen by
    /// measurement against the shading cost (BENCHMARKS.md, "Near-field diffuse"; 16 lowers
    /// the Cornell box's diffuse error a further 1.8× at 2.1–2.5× the shading time).
    pub surfel_resolution: u32,
    /// Edge-preserving smoothing of the radiance maps after sampling, as strong as `k` = this
    /// (0: off). Each texel becomes a weighted mean of the texels within two of it that see
    /// the same surface (normals within 25°, on its plane within two texel footprints; sky
    /// with sky) with weight `exp(-Δ² / (k² (σ²_i + σ²_j)))`, where `Δ` is the difference of
    /// their tone-mapped radiance and `σ²` each texel's estimated noise: differences the
    /// noise explains are averaged away, edges (a light against the ceiling, a shadow's
    /// border) are kept. The derived maps (pyramid, irradiance, surfels) are made from the
    /// smoothed radiance; [`ProbeSampling::noise`] stays the noise before it. Finite, 0 to 8.
    /// Default 0 (measured in BENCHMARKS.md, "Radiance smoothing").
    pub denoise: f32,
    /// What the radiance maps hold. Default [`BakedRadiance::Outgoing`], what the light-field
    /// tracers read; [`BakedRadiance::Indirect`] for a renderer that adds the light sources'
    /// direct light at its hits with shadow rays of its own.
    pub radiance: BakedRadiance,
}

/// What a bake's radiance maps hold ([`BakeSettings::radiance`]). The derived maps (pyramid,
/// moments, irradiance, surfels) are made from them either way.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum BakedRadiance {
    /// All the radiance leaving the surface a texel sees towards the probe: emission, direct
    /// light and bounces ([`Shader::outgoing_radiance`]).
    #[default]
    Outgoing,
    /// The light that surface reflects from the sky and from the surfaces around it, without
    /// its emission and the light sources' direct light ([`Shader::indirect_radiance`]): a
    /// renderer that finds its hits exactly (a BVH) and casts shadow rays there adds those
    /// itself ([`Shader::radiance_with_reflected`]), drawing the sun's shadow edges that a
    /// texel would blur. Such a bake's irradiance maps hold the light those indirect
    /// radiances carry (one bounce of it), not a renderer's diffuse light.
    Indirect,
}

/// How many radiance samples each texel of a bake takes.
///
/// Samples are rays through the texel's octahedral square, each shaded by the [`Shader`];
/// every random decision of a sample (where in the texel, which light point, which bounce
/// direction) is one dimension of an Owen-scrambled Sobol sequence ([`SobolSampler`]), so the
/// samples of a texel stratify each decision. The samples are split into
/// [`NOISE_REPLICATES`] independently scrambled replicates, whose spread gives each texel's
/// noise (the variance of its value, in tone-mapped units).
///
/// - **Fixed** ([`Sampling::fixed`]): every texel takes `samples_per_texel`.
/// - **Adaptive** (the default): every texel takes `samples_per_texel`; then, per probe, the
///   texels take more samples in proportion to their estimated per-sample standard deviation
///   (smoothed over a 3×3 neighbourhood), up to `max_samples_per_texel`, as many as bring
///   the probe's mean texel noise to `noise_target`. For a mean, samples in proportion to
///   the standard deviation cost the fewest samples; a per-texel target would spend most of
///   them on the few noisiest texels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sampling {
    /// Samples every texel takes (the first pass of adaptive sampling). 1 to 65536; at least
    /// 2 for a noise estimate.
    pub samples_per_texel: u32,
    /// The most samples a texel takes (adaptive sampling only acts when this exceeds
    /// `samples_per_texel`). At least `samples_per_texel`, at most 65536.
    pub max_samples_per_texel: u32,
    /// The mean noise each probe's texels are sampled down to (where the cap allows), as a
    /// variance in tone-mapped (`x / (1 + x)`) units (a standard error of 0.006 is about
    /// `3.5e-5`); `None` for fixed sampling. Finite and positive.
    pub noise_target: Option<f32>,
}

impl Sampling {
    /// The default noise target (tone-mapped variance per texel, mean over a probe). Chosen
    /// by measurement (BENCHMARKS.md, "Bakes that converge"): on the Cornell box with 27
    /// probes at 128² the default bake's noise is under 10 % of its error against a
    /// converged reference, at under 4× the time of the former 4-sample default.
    pub const DEFAULT_NOISE_TARGET: f32 = 3.5e-5;

    /// Every texel takes `samples_per_texel` samples.
    pub fn fixed(samples_per_texel: u32) -> Sampling {
        Sampling {
            samples_per_texel,
            max_samples_per_texel: samples_per_texel,
            noise_target: None,
        }
    }

    /// At least `min` and at most `max` samples per texel, until each probe's mean texel noise
    /// is at most `noise_target` (tone-mapped variance).
    pub fn adaptive(min: u32, max: u32, noise_target: f32) -> Sampling {
        Sampling {
            samples_per_texel: min,
            max_samples_per_texel: max,
            noise_target: Some(noise_target),
        }
    }

    /// Checks the fields (as [`bake`] does).
    ///
    /// # Errors
    /// [`BakeError::InvalidSetting`] naming the field out of range.
    pub fn validate(&self) -> Result<(), BakeError> {
        if self.samples_per_texel == 0 || self.samples_per_texel > 65_536 {
            return Err(invalid(
                "samples_per_texel",
                self.samples_per_texel,
                "must be from 1 to 65536",
            ));
        }
        if self.max_samples_per_texel < self.samples_per_texel
            || self.max_samples_per_texel > 65_536
        {
            return Err(invalid(
                "max_samples_per_texel",
                self.max_samples_per_texel,
                "must be at least samples_per_texel and at most 65536",
            ));
        }
        if let Some(target) = self.noise_target
            && !(target.is_finite() && target > 0.0)
        {
            return Err(invalid(
                "noise_target",
                target,
                "must be finite and > 0 (a tone-mapped variance such as 3.5e-5)",
            ));
        }
        Ok(())
    }
}

impl Default for Sampling {
    fn default() -> Self {
        Sampling::adaptive(8, 128, Sampling::DEFAULT_NOISE_TARGET)
    }
}

impl Default for BakeSettings {
    fn default() -> Self {
        BakeSettings {
            resolution: 256,
            sampling: Sampling::default(),
            bounces: 1,
            seed: 0,
            environment: None,
            pyramid_levels: 7,
            moments_resolution: probe_octa::DDGI_DISTANCE_RESOLUTION,
            moments_lobe_power: 50.0,
            moments_max_distance: None,
            irradiance_resolution: probe_octa::DDGI_IRRADIANCE_RESOLUTION,
            filter_source_resolution: 128,
            surfel_resolution: 8,
            denoise: 0.0,
            radiance: BakedRadiance::Outgoing,
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
    /// A sharded bake ([`bake_shard`](crate::bake_shard)) asked for more shards than there
    /// are probes, so some shard would hold none. Fix: use at most as many shards as probes.
    #[error(
        "{shards} shards of {probes} probes would leave a shard without probes: use at most \
         {probes} shards"
    )]
    TooManyShards {
        /// The shard count asked for.
        shards: u32,
        /// The probes in the whole set.
        probes: usize,
    },
    /// The bake's estimated memory ([`bake_memory_estimate`]) exceeds the memory limit;
    /// refused before any ray is traced. Fix: bake fewer probes or a lower resolution, or
    /// raise the limit ([`bake_with_limit`], `--max-memory`) if the machine has the memory.
    #[error(transparent)]
    OverMemory(#[from] MemoryExceeded),
}

/// Bytes a bake holds per padded texel: radiance, normal, distance and distance range (36),
/// the radiance without emission while the irradiance is derived (12),
/// the min/max pyramid (at most 11), their copies while the derived maps are gathered and
/// while the EXR layers are written (47 more), and slack for the per-thread sample sums.
const BYTES_PER_BAKE_TEXEL: u64 = 124;

/// Bytes of one [`Surfel`] (eleven floats plus two vectors of three; rounded up).
const SURFEL_BYTES: u64 = 64;

/// The memory a bake of `probes` probes with `settings` plans to use (its maps, their copies
/// while saving, and the derived maps), in bytes: what [`bake_with_limit`] and
/// [`ProbeBake::load_with_limit`](crate::ProbeBake::load_with_limit) compare with their limit
/// before starting.
pub fn bake_memory_estimate(probes: usize, settings: &BakeSettings) -> u64 {
    let padded = |r: u32| (u64::from(r) + 2).pow(2);
    let per_probe = padded(settings.resolution).saturating_mul(BYTES_PER_BAKE_TEXEL)
        + 2 * (padded(settings.moments_resolution) * 8
            + padded(settings.irradiance_resolution) * 12
            + u64::from(settings.surfels_per_side()).pow(2) * SURFEL_BYTES)
        + 9 * 12;
    (probes as u64).saturating_mul(per_probe)
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
    /// Surfels per side each probe gets: [`Self::surfel_resolution`], at most `resolution`.
    pub fn surfels_per_side(&self) -> u32 {
        self.surfel_resolution.min(self.resolution)
    }

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
        self.sampling.validate()?;
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
        let surfels = self.surfel_resolution;
        if surfels != 0 && (!surfels.is_power_of_two() || surfels > MAX_BAKE_RESOLUTION) {
            return Err(invalid(
                "surfel_resolution",
                surfels,
                "must be 0 (none) or a power of two up to 1024",
            ));
        }
        if !(self.denoise.is_finite() && (0.0..=8.0).contains(&self.denoise)) {
            return Err(invalid(
                "denoise",
                self.denoise,
                "must be finite, from 0 (off) to 8",
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

impl ProbeStats {
    /// The back-face share above which a probe counts as inside geometry (DDGI's fixed-ray
    /// back-face threshold, 0.25).
    pub const INSIDE_GEOMETRY_BACK_FACE_SHARE: f32 = 0.25;

    /// Whether the probe sits inside geometry: more than a quarter of what it sees are back
    /// faces. Diffuse shading leaves such probes out of its blend (DDGI's inactive probes;
    /// `probe_trace_gpu::IrradianceField::inside_geometry`).
    pub fn inside_geometry(&self) -> bool {
        self.back_face_share > Self::INSIDE_GEOMETRY_BACK_FACE_SHARE
    }
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
            TexelGeometry {
                distance: hit.t,
                normal: stored_normal(scene, &hit, ray.direction),
                back_face: !hit.front_face && !double_sided,
            }
        }
        None => TexelGeometry {
            distance: MISS_DISTANCE,
            normal: Vec3::ZERO,
            back_face: false,
        },
    }
}

/// The normal a texel stores for `hit`, met along `direction` ([`trace_texel_geometry`]).
fn stored_normal(scene: &Scene, hit: &Hit, direction: Vec3) -> Vec3 {
    let double_sided = scene.materials()[hit.material as usize].double_sided;
    let sign = if !hit.front_face && double_sided {
        -1.0
    } else {
        1.0
    };
    let geometric = hit.geometric_normal * sign;
    let normal = hit.shading_normal * sign;
    if (normal.dot(direction) > 0.0) != (geometric.dot(direction) > 0.0) {
        geometric
    } else {
        normal
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

/// Sub-texel rays per axis a bake casts to find each texel's distance range
/// ([`ProbeBake::distance_ranges`]): a 3×3 grid at the centres of the texel's ninths.
pub const RANGE_SAMPLES: u32 = 3;

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

/// The nearest and farthest radial distance of probe `origin` over the sub-texel grid of
/// interior texel `(ix, iy)` and its centre's `centre` ([`MISS_DISTANCE`] for misses).
fn texel_distance_range(
    scene: &Scene,
    origin: Vec3,
    layout: OctaLayout,
    (ix, iy): (u32, u32),
    centre: f32,
) -> Vec2 {
    let step = 2.0 / layout.resolution() as f32;
    let k = RANGE_SAMPLES as f32;
    let (mut near, mut far) = (centre, centre);
    for sy in 0..RANGE_SAMPLES {
        for sx in 0..RANGE_SAMPLES {
            let q = Vec2::new(
                -1.0 + (ix as f32 + (sx as f32 + 0.5) / k) * step,
                -1.0 + (iy as f32 + (sy as f32 + 0.5) / k) * step,
            );
            let ray = Ray {
                origin,
                direction: probe_octa::decode(q),
            };
            let t = trace_texel_geometry(scene, &ray).distance;
            near = near.min(t);
            far = far.max(t);
        }
    }
    Vec2::new(near, far)
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

/// Every texel's [`texel_distance_range`], padded maps probe after probe; `row_done` ticks
/// once per interior row.
fn range_pass(
    scene: &Scene,
    positions: &[Vec3],
    layout: OctaLayout,
    distances: &[f32],
    row_done: &(dyn Fn() + Sync),
) -> Vec<Vec2> {
    let n = layout.resolution() as usize;
    let side = layout.padded_size() as usize;
    let len = layout.padded_len();
    let mut ranges = vec![Vec2::ZERO; positions.len() * len];
    ranges
        .par_chunks_mut(len)
        .zip(distances.par_chunks(len))
        .zip(positions.par_iter())
        .for_each(|((range_map, distance_map), &origin)| {
            range_map
                .par_chunks_mut(side)
                .skip(1)
                .take(n)
                .enumerate()
                .for_each(|(iy, row)| {
                    for ix in 0..n {
                        let centre = distance_map[(iy + 1) * side + ix + 1];
                        row[ix + 1] = texel_distance_range(
                            scene,
                            origin,
                            layout,
                            (ix as u32, iy as u32),
                            centre,
                        );
                    }
                    row_done();
                });
            // The slice has the layout's length, so padding cannot fail.
            let _ = layout.pad(range_map);
        });
    ranges
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
/// - **radiance**: linear HDR RGB, the mean of the texel's radiance samples ([`Sampling`])
///   over its octahedral square that meet the surface its centre ray met (facing within 60°
///   of it and on its plane within two texel angles of its distance; for a sky texel, the
///   samples that escape; all samples where none does), each the [`Shader`]'s outgoing
///   radiance of the hit (emission + direct light + bounces) or the sky for a miss. A texel
///   seen at grazing incidence has samples that pass its surface's edge and meet whatever
///   lies beyond; left in, its radiance would be a mixture no point of its surface has;
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
/// - **irradiance**: cosine-convolved *indirect* radiance of every sample ([`irradiance_map`]) at
///   [`BakeSettings::irradiance_resolution`] `K`, padded `(K+2)²` per probe: the radiance
///   without the emission of the surfaces the texels see, so a renderer that adds direct
///   light with its own shadows (`probes render --component final`) counts no light source
///   twice. The sky is kept (it has no shadow rays of its own there);
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
    pub(crate) scene_bounds: Option<[Vec3; 2]>,
    pub(crate) settings: BakeSettings,
    pub(crate) environment: Environment,
    pub(crate) moments_max_distance: f32,
    pub(crate) positions: Vec<Vec3>,
    pub(crate) layout: OctaLayout,
    pub(crate) radiance: Vec<Vec3>,
    pub(crate) normals: Vec<Vec3>,
    pub(crate) distances: Vec<f32>,
    pub(crate) distance_ranges: Vec<Vec2>,
    pub(crate) pyramid_levels: u32,
    pub(crate) pyramid: Vec<Vec2>,
    pub(crate) moments: Vec<Vec2>,
    pub(crate) irradiance: Vec<Vec3>,
    pub(crate) sh: Vec<ShL2Rgb>,
    pub(crate) surfels: Vec<Surfel>,
    pub(crate) stats: Vec<ProbeStats>,
    pub(crate) sampling: Vec<ProbeSampling>,
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

    /// The box holding every triangle of the scene the bake was made from ([`Scene::bounds`]:
    /// min and max corners): nothing lies beyond it, so a tracer may end a ray that leaves it
    /// verified empty as a miss. `None` for bakes saved before it was recorded.
    pub fn scene_bounds(&self) -> Option<[Vec3; 2]> {
        self.scene_bounds
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

    /// Per texel the nearest (`x`) and farthest (`y`) radial distance the baker saw inside
    /// the texel: its centre ray and [`RANGE_SAMPLES`]² sub-texel rays ([`MISS_DISTANCE`] for
    /// misses), laid out as [`Self::distances`]. A nearer sample marks geometry the centre's
    /// plane does not model (a thin or partly covering surface, an edge inside the texel), a
    /// farther one a plane that ends inside it: the tracer's fine test uses both.
    pub fn distance_ranges(&self) -> &[Vec2] {
        &self.distance_ranges
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

    /// Indirect irradiance of all probes, padded `(K+2)²` per probe (`K` =
    /// [`BakeSettings::irradiance_resolution`]): the irradiance of the light the surfaces
    /// around each probe reflect, and of the sky, without the emission of the light sources
    /// it sees (add direct light with shadow rays; see [`ProbeBake`]).
    pub fn irradiance(&self) -> &[Vec3] {
        &self.irradiance
    }

    /// L2 spherical harmonics of each probe's radiance.
    pub fn sh(&self) -> &[ShL2Rgb] {
        &self.sh
    }

    /// The surfels of all probes, [`BakeSettings::surfels_per_side`]² per probe, probe after
    /// probe ([`probe_octa::surfel_map`] of the radiance without emission, as the irradiance
    /// maps): empty when the bake has none (a surfel resolution of 0, or a bake saved before
    /// surfels existed).
    pub fn surfels(&self) -> &[Surfel] {
        &self.surfels
    }

    /// Per-probe statistics.
    pub fn stats(&self) -> &[ProbeStats] {
        &self.stats
    }

    /// Per probe, the samples its radiance took and the noise they leave.
    pub fn sampling(&self) -> &[ProbeSampling] {
        &self.sampling
    }

    /// The bake's estimated radiance noise: the mean of [`ProbeSampling::noise`] over the
    /// probes (tone-mapped variance per texel), `None` if some probe has no estimate.
    pub fn noise(&self) -> Option<f64> {
        let mut sum = 0.0f64;
        for probe in &self.sampling {
            sum += f64::from(probe.noise?);
        }
        Some(sum / self.sampling.len().max(1) as f64)
    }

    /// Mean radiance samples per texel over the whole bake.
    pub fn mean_samples_per_texel(&self) -> f64 {
        let samples: u64 = self.sampling.iter().map(|p| p.samples).sum();
        let n = u64::from(self.resolution());
        samples as f64 / (n * n * self.probe_count().max(1) as u64) as f64
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
/// distance ranges ([`ProbeBake::distance_ranges`]), the radiance pass (per texel the rays
/// [`BakeSettings::sampling`] asks for, shaded by the [`Shader`]) and the derived maps, all
/// spread over rayon's thread pool.
///
/// Deterministic: every sample draws its numbers from a Sobol stream keyed by
/// `(seed, probe, texel, replicate)`, the adaptive pass decides from those alone, and per-probe
/// sums run in a fixed order, so the same inputs give the same bytes whatever the number of
/// threads. `progress` receives `(done, total)` with `total = 4 · probes · N + probes` (rows
/// of the geometry pass, the distance ranges and the two radiance passes, then one unit per
/// probe's derived maps); it is called from worker threads.
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
/// use probe_capture::Sampling;
/// let settings = BakeSettings { resolution: 16, sampling: Sampling::fixed(2), ..Default::default() };
/// let probes = bake(&scene, &[Vec3::new(0.28, 0.27, 0.28)], &settings, &no_progress)?;
/// assert_eq!(probes.radiance().len(), 18 * 18);
/// // The box is open towards −Z: a probe inside sees out through that side only.
/// let stats = probes.stats()[0];
/// assert!(stats.miss_share > 0.05 && stats.miss_share < 0.5);
/// assert!(probes.radiance().iter().all(|r| r.is_finite() && r.min_element() >= 0.0));
/// // Two samples per texel in two independent randomisations give a noise estimate.
/// assert!(probes.noise().is_some_and(|v| v > 0.0));
/// assert_eq!(probes.mean_samples_per_texel(), 2.0);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn bake(
    scene: &Scene,
    positions: &[Vec3],
    settings: &BakeSettings,
    progress: Progress<'_>,
) -> Result<ProbeBake, BakeError> {
    bake_with_limit(scene, positions, settings, MemoryLimit::machine(), progress)
}

/// [`bake`] with a memory limit other than the machine's ([`MemoryLimit::machine`]): a bake
/// whose [`bake_memory_estimate`] exceeds `limit` is refused before any ray is traced.
///
/// # Errors
/// As [`bake`]; [`BakeError::OverMemory`] with the estimate and the limit.
pub fn bake_with_limit(
    scene: &Scene,
    positions: &[Vec3],
    settings: &BakeSettings,
    limit: MemoryLimit,
    progress: Progress<'_>,
) -> Result<ProbeBake, BakeError> {
    bake_probes(scene, positions, 0, settings, limit, progress)
}

/// [`bake_with_limit`] of `positions` taken as probes `first_probe..` of a larger set: the
/// samples of each probe are keyed by its index in that set, so a probe's bytes do not depend
/// on which other probes are baked with it (what sharded bakes rely on, see
/// [`bake_shard`](crate::bake_shard)).
pub(crate) fn bake_probes(
    scene: &Scene,
    positions: &[Vec3],
    first_probe: usize,
    settings: &BakeSettings,
    limit: MemoryLimit,
    progress: Progress<'_>,
) -> Result<ProbeBake, BakeError> {
    settings.validate()?;
    let layout = check_capture(positions, settings.resolution)?;
    limit.check(
        format_args!(
            "a bake of {} probes at {}²",
            positions.len(),
            settings.resolution
        ),
        bake_memory_estimate(positions.len(), settings),
    )?;
    let environment = settings
        .environment
        .unwrap_or_else(|| Environment::for_scene(scene));
    let shader = Shader::new(scene, environment, settings.bounces)?;
    let n = settings.resolution as usize;
    let probes = positions.len();
    let total = 4 * probes * n + probes;
    let done = AtomicUsize::new(0);
    let tick = || {
        let d = done.fetch_add(1, Ordering::Relaxed) + 1;
        progress(d, total);
    };

    let geometry = geometry_pass(scene, positions, layout, &tick);
    let distance_ranges = range_pass(scene, positions, layout, &geometry.distances, &tick);
    let RadianceMaps {
        radiance,
        reflected,
        sampling,
    } = radiance_pass(
        &shader,
        positions,
        first_probe,
        layout,
        settings,
        &geometry,
        &tick,
    );

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
                ProbeMaps {
                    position: positions[p],
                    radiance: &radiance[p * len..(p + 1) * len],
                    reflected: &reflected[p * len..(p + 1) * len],
                    distances: &geometry.distances[p * len..(p + 1) * len],
                    normals: &geometry.normals[p * len..(p + 1) * len],
                },
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
    let mut surfels = Vec::new();
    let mut pyramid_levels = 0;
    for maps in derived {
        surfels.extend(maps.surfels);
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
        scene_bounds: Some([scene.bounds().min, scene.bounds().max]),
        settings: settings.clone(),
        environment,
        moments_max_distance,
        positions: positions.to_vec(),
        layout,
        radiance,
        normals: geometry.normals,
        distances: geometry.distances,
        distance_ranges,
        pyramid_levels,
        pyramid,
        moments,
        irradiance,
        sh,
        surfels,
        stats: geometry.stats,
        sampling,
    })
}

/// Independent randomisations each texel's samples are split into (sample `k` belongs to
/// replicate `k mod 2` and is point `k div 2` of that replicate's scrambled Sobol sequence).
/// Two keep most of the sequence's stratification within each replicate; their one degree
/// of freedom per texel is enough for a probe's mean noise (thousands of texels) and, over a
/// texel's 3×3 neighbourhood, for the adaptive pass.
/// The spread of the replicates' means estimates the variance of the texel's mean without
/// bias, whatever the sequence's stratification gains (randomised quasi-Monte Carlo).
pub const NOISE_REPLICATES: u32 = 2;

/// The surface a texel's centre ray met (from the geometry pass), which its radiance
/// describes: a sample counts towards the texel's radiance only where it meets the same
/// surface ([`TexelSurface::shows`]).
#[derive(Clone, Copy)]
struct TexelSurface {
    /// Where the centre ray met it, relative to the probe; `None` for sky.
    point: Option<Vec3>,
    /// Its normal turned towards the probe.
    normal: Vec3,
    /// How far from its plane a sample's hit may lie (along `normal`).
    tolerance: f32,
}

/// Whether a texel's stored radial distance marks sky (a miss stores [`MISS_DISTANCE`]).
fn is_sky(distance: f32) -> bool {
    distance >= 0.5 * MISS_DISTANCE
}

/// `normal` turned to face back along `direction` (towards where a ray along it came from).
fn facing_back(normal: Vec3, direction: Vec3) -> Vec3 {
    if normal.dot(direction) > 0.0 {
        -normal
    } else {
        normal
    }
}

/// How far from a texel's plane, over the texel's radial distance, a sample's hit may lie and
/// still count as the texel's surface: twice the texel's angle, the reach the smoothing gives
/// a neighbour one texel away ([`denoise_probe`]).
const SURFACE_TOLERANCE_TEXEL_ANGLES: f32 = 2.0;

/// The cosine within which a sample's surface faces like the texel's (60°, the look-up's
/// `SAME_SURFACE_COS` in `probe-trace-gpu`).
const SAME_SURFACE_COS: f32 = 0.5;

impl TexelSurface {
    /// The surface of a texel whose centre ray runs along `direction` and met a surface at
    /// `distance` with `normal` (a miss: [`MISS_DISTANCE`]) at resolution `n`.
    fn new(direction: Vec3, distance: f32, normal: Vec3, n: u32) -> TexelSurface {
        if is_sky(distance) {
            return TexelSurface {
                point: None,
                normal: Vec3::ZERO,
                tolerance: 0.0,
            };
        }
        TexelSurface {
            point: Some(direction * distance),
            normal: facing_back(normal, direction),
            tolerance: SURFACE_TOLERANCE_TEXEL_ANGLES * probe_octa::texel_angle(n) * distance,
        }
    }

    /// Whether a sample along `direction` that met `hit` (`None`: it escaped) shows this
    /// surface: both escaped, or the hit lies within the tolerance of the plane and faces
    /// like it. At grazing incidence a texel's samples fan out along its surface and past its
    /// edge: those that pass the edge meet what lies beyond (the sky, a lit wall) and would
    /// make the texel's radiance a mixture no point of its surface has (a wall 20 cm from a
    /// Sponza probe read the sky's blue three metres away: BENCHMARKS.md, "Texels that show
    /// one surface").
    fn shows(&self, scene: &Scene, direction: Vec3, hit: Option<&Hit>) -> bool {
        match (self.point, hit) {
            (None, None) => true,
            (Some(point), Some(hit)) => {
                let facing = facing_back(stored_normal(scene, hit, direction), direction);
                facing.dot(self.normal) >= SAME_SURFACE_COS
                    && (direction * hit.t - point).dot(self.normal).abs() <= self.tolerance
            }
            _ => false,
        }
    }
}

/// One texel's running sums, per replicate: of every sample, and of the samples that show the
/// texel's surface ([`TexelSurface::shows`]).
#[derive(Clone, Copy, Default)]
struct TexelSums {
    sums: [Vec3; NOISE_REPLICATES as usize],
    /// The samples showing the texel's surface, summed per replicate.
    surface_sums: [Vec3; NOISE_REPLICATES as usize],
    /// How many of each replicate's samples show it.
    surface_counts: [u32; NOISE_REPLICATES as usize],
    /// The emission of the samples' hits (the light sources the probe sees directly), summed
    /// over all samples: what the indirect radiance leaves out.
    emitted: Vec3,
    samples: u32,
}

impl TexelSums {
    /// Adds samples `from..to` of texel `(ix, iy)` of probe `probe`, whose centre ray met
    /// `surface`.
    #[allow(
        clippy::too_many_arguments,
        reason = "one texel's full address and range"
    )]
    fn add(
        &mut self,
        shader: &Shader<'_>,
        content: BakedRadiance,
        origin: Vec3,
        seed: u64,
        probe: usize,
        n: u32,
        (ix, iy): (u32, u32),
        surface: &TexelSurface,
        to: u32,
    ) {
        let texel = u64::from(iy) * u64::from(n) + u64::from(ix);
        for k in self.samples..to {
            let replicate = k % NOISE_REPLICATES;
            let mut sampler = SobolSampler::for_key(
                seed,
                &[probe as u64, texel, u64::from(replicate)],
                k / NOISE_REPLICATES,
            );
            let within = sampler.next_vec2().min(Vec2::splat(1.0 - f32::EPSILON));
            let octa = (Vec2::new(ix as f32, iy as f32) + within) * (2.0 / n as f32) - Vec2::ONE;
            let ray = Ray {
                origin,
                direction: probe_octa::decode(octa),
            };
            let (hit, radiance) = match content {
                BakedRadiance::Outgoing => shader.trace(&ray, &mut sampler),
                BakedRadiance::Indirect => shader.trace_indirect(&ray, &mut sampler),
            };
            let r = replicate as usize;
            self.sums[r] += radiance;
            if surface.shows(shader.scene(), ray.direction, hit.as_ref()) {
                self.surface_sums[r] += radiance;
                self.surface_counts[r] += 1;
            }
            // Nothing emitted is in an indirect sample to leave out afterwards.
            if let (Some(hit), BakedRadiance::Outgoing) = (hit, content) {
                self.emitted += shader.emission(&hit, -ray.direction);
            }
        }
        self.samples = self.samples.max(to);
    }

    /// How many samples each replicate holds.
    fn replicate_counts(&self) -> [u32; NOISE_REPLICATES as usize] {
        std::array::from_fn(|r| (self.samples.saturating_sub(r as u32)).div_ceil(NOISE_REPLICATES))
    }

    /// The texel's radiance: the mean of the samples that show its surface, else (no sample
    /// does: a surface thinner than the samples' spacing) of all of them.
    fn mean(&self) -> Vec3 {
        let shown = self.surface_counts.iter().sum::<u32>();
        if shown > 0 {
            self.surface_sums.iter().copied().sum::<Vec3>() / shown as f32
        } else {
            self.sums.iter().copied().sum::<Vec3>() / self.samples.max(1) as f32
        }
    }

    /// The mean of all samples without the emission of their hits: the light the texel's
    /// surfaces reflect (exactly zero where the texel sees only emitters of black albedo),
    /// over the texel's whole solid angle (the irradiance's source).
    fn indirect_mean(&self) -> Vec3 {
        ((self.sums.iter().copied().sum::<Vec3>() - self.emitted) / self.samples.max(1) as f32)
            .max(Vec3::ZERO)
    }

    /// The estimated variance of [`Self::mean`] in tone-mapped units (mean over the three
    /// channels), from the spread of the replicates' tone-mapped means (of the samples that
    /// show the texel's surface where each replicate holds one, else of all); `None` with
    /// fewer than two replicates. The spread is taken after tone mapping, not through the
    /// tone map's slope at the mean: a texel straddling an emitter's edge has replicates of
    /// 0.5 and 17, whose tone-mapped values differ by 0.6 while the slope at their mean (8.8)
    /// would shrink their linear spread to a tenth of that.
    fn noise(&self) -> Option<f32> {
        let (sums, counts) = if self.surface_counts.iter().all(|&c| c > 0) {
            (self.surface_sums, self.surface_counts)
        } else {
            (self.sums, self.replicate_counts())
        };
        if counts.contains(&0) {
            return None;
        }
        let total = counts.iter().sum::<u32>() as f32;
        let mut weighted = [(0.0f32, Vec3::ZERO); NOISE_REPLICATES as usize];
        let mut mean = Vec3::ZERO;
        for r in 0..NOISE_REPLICATES as usize {
            let count = counts[r] as f32;
            let share = count / total;
            let value = tone(sums[r] / count);
            weighted[r] = (share, value);
            mean += value * share;
        }
        let mut spread = Vec3::ZERO;
        for &(share, value) in &weighted {
            let d = (value - mean) * share;
            spread += d * d;
        }
        let replicates = NOISE_REPLICATES as f32;
        let variance = spread * (replicates / (replicates - 1.0));
        Some(variance.element_sum() / 3.0)
    }
}

/// How a probe's texels were sampled, and the noise left (in [`ProbeBake::sampling`] and the
/// bake manifest).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProbeSampling {
    /// Radiance samples taken over all the probe's texels.
    pub samples: u64,
    /// The estimated noise of the probe's radiance map: the mean over its texels of the
    /// variance of the texel's value, in tone-mapped (`x / (1 + x)`) units, from the spread of
    /// [`NOISE_REPLICATES`] independent randomisations of each texel's samples. Two bakes
    /// with different seeds differ per texel by twice this in mean square. `None` when a
    /// texel has fewer than two samples.
    pub noise: Option<f32>,
    /// Share of texels that took [`Sampling::max_samples_per_texel`] in the adaptive pass (0
    /// for fixed sampling).
    pub capped_share: f32,
}

/// Each texel's variance per sample (its noise times its samples; 0 with fewer than two).
fn per_sample_variances(texels: &[TexelSums]) -> Vec<f32> {
    texels
        .iter()
        .map(|t| t.noise().unwrap_or(0.0) * t.samples as f32)
        .collect()
}

/// Per texel, the samples the adaptive pass asks for. The first pass gives each texel's
/// per-sample variance `s` (its noise times its samples), averaged over its 3×3
/// neighbourhood so that one unlucky estimate neither starves nor floods a texel. The mean
/// noise of the probe's texels, `mean(s / n)`, is smallest for a given number of samples
/// when `n ∝ √s` (Lagrange), so each texel takes `c·√s` samples, clamped to the first pass
/// and the cap, with the one `c` (found by bisection) that brings the mean to the target.
fn adaptive_counts(first: &[TexelSums], n: usize, sampling: &Sampling, target: f32) -> Vec<u32> {
    let per_sample = per_sample_variances(first);
    let mut smoothed = vec![0.0f64; n * n];
    for iy in 0..n {
        for ix in 0..n {
            let mut sum = 0.0f64;
            let mut weight = 0.0f64;
            for y in iy.saturating_sub(1)..(iy + 2).min(n) {
                for x in ix.saturating_sub(1)..(ix + 2).min(n) {
                    sum += f64::from(per_sample[y * n + x]);
                    weight += 1.0;
                }
            }
            smoothed[iy * n + ix] = sum / weight;
        }
    }
    let (low, high) = (
        f64::from(sampling.samples_per_texel),
        f64::from(sampling.max_samples_per_texel),
    );
    // The per-sample standard deviations, taken once for the bisection's inner loop.
    let deviations: Vec<f64> = smoothed.iter().map(|s| s.sqrt()).collect();
    let count = |c: f64, deviation: f64| (c * deviation).ceil().clamp(low, high);
    let mean_noise = |c: f64| {
        smoothed
            .iter()
            .zip(&deviations)
            .map(|(&s, &d)| s / count(c, d))
            .sum::<f64>()
            / (n * n) as f64
    };
    let target = f64::from(target);
    let counts_for =
        |c: f64| -> Vec<u32> { deviations.iter().map(|&d| count(c, d) as u32).collect() };
    if mean_noise(0.0) <= target {
        return counts_for(0.0);
    }
    // Every texel with any variance at the cap: the most the cap allows.
    let largest = deviations
        .iter()
        .filter(|&&d| d > 0.0)
        .map(|&d| high / d)
        .fold(0.0f64, f64::max);
    if mean_noise(largest) > target {
        return counts_for(largest);
    }
    let (mut below, mut above) = (0.0f64, largest);
    for _ in 0..50 {
        let c = 0.5 * (below + above);
        if mean_noise(c) > target {
            below = c;
        } else {
            above = c;
        }
    }
    counts_for(above)
}

/// Tone map of the noise estimates and the smoothing's differences (`x / (1 + x)` per
/// channel, negatives as 0).
fn tone(v: Vec3) -> Vec3 {
    let v = v.max(Vec3::ZERO);
    v / (Vec3::ONE + v)
}

/// Edge-preserving smoothing of one probe's radiance ([`BakeSettings::denoise`]): `map`
/// (padded) gets, in its interior, each texel's weighted mean of the texels within two of it
/// (through the octahedral wrap, [`probe_octa::fold`]) that see the same surface as it, with
/// a Gaussian falloff over the offset and a weight that vanishes where the tone-mapped
/// difference exceeds what the two texels' noise explains (`k` = `strength`). Reads the
/// texels' unsmoothed means, so the order of texels does not matter.
fn denoise_probe(
    layout: OctaLayout,
    map: &mut [Vec3],
    texels: &[TexelSums],
    distances: &[f32],
    normals: &[Vec3],
    strength: f32,
) {
    let n = layout.resolution() as i32;
    let nu = n as usize;
    // Per-texel noise: the per-sample variance averaged over the 3×3 neighbourhood, over the
    // texel's samples (the adaptive pass's estimate).
    let per_sample = per_sample_variances(texels);
    let mut variance = vec![0.0f32; nu * nu];
    for iy in 0..n {
        for ix in 0..n {
            let mut sum = 0.0;
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let (x, y) = probe_octa::fold(ix + dx, iy + dy, n);
                    sum += per_sample[y as usize * nu + x as usize];
                }
            }
            let t = &texels[iy as usize * nu + ix as usize];
            variance[iy as usize * nu + ix as usize] = sum / 9.0 / t.samples.max(1) as f32;
        }
    }
    let footprint = probe_octa::texel_angle(layout.resolution());
    let means: Vec<Vec3> = texels.iter().map(TexelSums::mean).collect();
    let tones: Vec<Vec3> = means.iter().map(|&m| tone(m)).collect();
    let padded = |x: i32, y: i32| layout.padded_index(x as u32 + 1, y as u32 + 1);
    let k2 = strength * strength;
    for iy in 0..n {
        for ix in 0..n {
            let i = iy as usize * nu + ix as usize;
            let pi = padded(ix, iy);
            let (di, ni) = (distances[pi], normals[pi]);
            let sky_i = is_sky(di);
            let qi = layout.texel_direction(ix as u32, iy as u32) * di;
            let (mut sum, mut weight) = (Vec3::ZERO, 0.0f32);
            for dy in -2..=2i32 {
                for dx in -2..=2i32 {
                    let (x, y) = probe_octa::fold(ix + dx, iy + dy, n);
                    let j = y as usize * nu + x as usize;
                    let pj = padded(x, y);
                    let dj = distances[pj];
                    if is_sky(dj) != sky_i {
                        continue;
                    }
                    if !sky_i {
                        if normals[pj].dot(ni) < 0.9 {
                            continue;
                        }
                        let qj = layout.texel_direction(x as u32, y as u32) * dj;
                        let reach = 2.0 * footprint * di * (dx.abs().max(dy.abs()) as f32);
                        if ni.dot(qj - qi).abs() > reach.max(1e-6) {
                            continue;
                        }
                    }
                    let delta = tones[j] - tones[i];
                    let d2 = delta.length_squared() / 3.0;
                    let noise = (variance[i] + variance[j]).max(1e-12);
                    let w =
                        (-d2 / (k2 * noise)).exp() * (-((dx * dx + dy * dy) as f32) / 4.5).exp();
                    sum += means[j] * w;
                    weight += w;
                }
            }
            map[pi] = if weight > 0.0 { sum / weight } else { means[i] };
        }
    }
}

/// What the radiance pass gives: the radiance maps, the same maps without the emission of
/// the surfaces the texels see (the light those surfaces reflect, the source of the
/// indirect-only irradiance), and how each probe was sampled.
struct RadianceMaps {
    radiance: Vec<Vec3>,
    reflected: Vec<Vec3>,
    sampling: Vec<ProbeSampling>,
}

/// The radiance of `positions`, which are probes `first_probe..` of the bake's whole set: a
/// probe's samples are keyed by its index in the whole set.
fn radiance_pass(
    shader: &Shader<'_>,
    positions: &[Vec3],
    first_probe: usize,
    layout: OctaLayout,
    settings: &BakeSettings,
    geometry: &ProbeGeometry,
    row_done: &(dyn Fn() + Sync),
) -> RadianceMaps {
    let n = layout.resolution();
    let nu = n as usize;
    let side = layout.padded_size() as usize;
    let len = layout.padded_len();
    let sampling = settings.sampling;
    let adaptive = sampling
        .noise_target
        .filter(|_| sampling.max_samples_per_texel > sampling.samples_per_texel);
    let mut radiance = vec![Vec3::ZERO; positions.len() * len];
    let mut reflected = vec![Vec3::ZERO; positions.len() * len];
    let stats: Vec<ProbeSampling> = radiance
        .par_chunks_mut(len)
        .zip(reflected.par_chunks_mut(len))
        .zip(positions.par_iter())
        .enumerate()
        .map(|(local, ((map, reflected_map), &origin))| {
            let probe = first_probe + local;
            let probe_distances = &geometry.distances[local * len..(local + 1) * len];
            let probe_normals = &geometry.normals[local * len..(local + 1) * len];
            let surfaces: Vec<TexelSurface> = (0..nu * nu)
                .map(|t| {
                    let (ix, iy) = ((t % nu) as u32, (t / nu) as u32);
                    let padded = layout.padded_index(ix + 1, iy + 1);
                    TexelSurface::new(
                        layout.texel_direction(ix, iy),
                        probe_distances[padded],
                        probe_normals[padded],
                        n,
                    )
                })
                .collect();
            let sample_rows = |texels: &mut [TexelSums], counts: Option<&[u32]>| {
                texels.par_chunks_mut(nu).enumerate().for_each(|(iy, row)| {
                    for (ix, texel) in row.iter_mut().enumerate() {
                        let to = counts.map_or(sampling.samples_per_texel, |c| c[iy * nu + ix]);
                        texel.add(
                            shader,
                            settings.radiance,
                            origin,
                            settings.seed,
                            probe,
                            n,
                            (ix as u32, iy as u32),
                            &surfaces[iy * nu + ix],
                            to,
                        );
                    }
                    row_done();
                });
            };
            let mut texels = vec![TexelSums::default(); nu * nu];
            sample_rows(&mut texels, None);
            let mut capped = 0usize;
            if let Some(target) = adaptive {
                let counts = adaptive_counts(&texels, nu, &sampling, target);
                sample_rows(&mut texels, Some(&counts));
                capped = texels
                    .iter()
                    .filter(|t| t.samples >= sampling.max_samples_per_texel)
                    .count();
            } else {
                for _ in 0..n {
                    row_done();
                }
            }
            let mut samples = 0u64;
            let mut noise = Some(0.0f64);
            for (t, texel) in texels.iter().enumerate() {
                map[(t / nu + 1) * side + t % nu + 1] = texel.mean();
                reflected_map[(t / nu + 1) * side + t % nu + 1] = texel.indirect_mean();
                samples += u64::from(texel.samples);
                noise = noise.zip(texel.noise()).map(|(a, b)| a + f64::from(b));
            }
            if settings.denoise > 0.0 {
                denoise_probe(
                    layout,
                    map,
                    &texels,
                    probe_distances,
                    probe_normals,
                    settings.denoise,
                );
            }
            let _ = layout.pad(map);
            let _ = layout.pad(reflected_map);
            ProbeSampling {
                samples,
                noise: noise.map(|v| (v / (nu * nu) as f64) as f32),
                capped_share: capped as f32 / (nu * nu) as f32,
            }
        })
        .collect();
    RadianceMaps {
        radiance,
        reflected,
        sampling: stats,
    }
}

struct DerivedMaps {
    surfels: Vec<Surfel>,
    pyramid_levels: u32,
    pyramid: Vec<Vec2>,
    moments: OctaMap<Vec2>,
    irradiance: OctaMap<Vec3>,
    sh: ShL2Rgb,
}

/// One probe's full-resolution maps, padded.
struct ProbeMaps<'a> {
    position: Vec3,
    radiance: &'a [Vec3],
    /// The radiance without emission.
    reflected: &'a [Vec3],
    distances: &'a [f32],
    normals: &'a [Vec3],
}

fn derived_maps(
    layout: OctaLayout,
    reducer: &Reducer,
    maps: ProbeMaps<'_>,
    settings: &BakeSettings,
    moments_max_distance: f32,
) -> Result<DerivedMaps, BakeError> {
    let ProbeMaps {
        position,
        radiance,
        reflected,
        distances,
        normals,
    } = maps;
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
    let reflected = OctaMap::from_padded(n, reflected.to_vec())
        .map_err(|_| invalid("resolution", n, "must be a power of two from 1 to 1024"))?;
    let surfels = if settings.surfels_per_side() == 0 {
        Vec::new()
    } else {
        let normals = OctaMap::from_padded(n, normals.to_vec())
            .map_err(|_| invalid("resolution", n, "must be a power of two from 1 to 1024"))?;
        surfel_map(
            position,
            &distance,
            &normals,
            &reflected,
            MISS_DISTANCE,
            settings.surfels_per_side(),
        )
        .map_err(|_| {
            invalid(
                "surfel_resolution",
                settings.surfel_resolution,
                "must be 0 (none) or a power of two up to 1024",
            )
        })?
    };
    let irradiance_source = reducer.reduce(&reflected);
    let irradiance =
        irradiance_map(&irradiance_source, settings.irradiance_resolution).map_err(|_| {
            invalid(
                "irradiance_resolution",
                settings.irradiance_resolution,
                "must be from 1 to 256",
            )
        })?;
    Ok(DerivedMaps {
        surfels,
        pyramid_levels: pyramid.level_count() as u32,
        pyramid: levels,
        moments,
        irradiance,
        sh: ShL2Rgb::project(&reducer.reduce(&radiance)),
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

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig {
            rng_seed: proptest::test_runner::RngSeed::Fixed(3),
            cases: 256,
            ..proptest::prelude::ProptestConfig::default()
        })]
        /// Whatever the probe and texel, the texel's centre ray (what its distance and normal
        /// describe) shows the texel's surface, so a texel whose samples all meet that
        /// surface keeps the mean of all of them; and a sample one texel-angle off meets the
        /// same surface wherever the texel sees a wall head on.
        #[test]
        fn a_texels_centre_ray_shows_its_surface(
            x in 0.01f32..0.55,
            y in 0.01f32..0.54,
            z in 0.01f32..0.55,
            resolution_log2 in 2u32..7,
            u in 0.0f32..1.0,
            v in 0.0f32..1.0,
        ) {
            let scene = Scene::builtin("cornell").unwrap();
            let n = 1u32 << resolution_log2;
            let layout = OctaLayout::new(n).unwrap();
            let (ix, iy) = (((u * n as f32) as u32).min(n - 1), ((v * n as f32) as u32).min(n - 1));
            let direction = layout.texel_direction(ix, iy);
            let origin = Vec3::new(x, y, z);
            let ray = Ray { origin, direction };
            let geometry = trace_texel_geometry(&scene, &ray);
            let surface = TexelSurface::new(direction, geometry.distance, geometry.normal, n);
            let hit = scene.closest_hit(&ray, f32::INFINITY);
            proptest::prop_assert!(surface.shows(&scene, direction, hit.as_ref()));
        }
    }

    /// A probe 20 cm from a black wall that ends a metre to its side, under the default
    /// daylight: the texels that see the wall at grazing incidence near its end have samples
    /// that pass the end and meet the sky. Their radiance is the wall's (black), not a mixture
    /// with the sky, while the irradiance (from every sample) still holds the sky they see.
    #[test]
    fn grazing_texels_hold_their_own_surface_not_what_lies_past_its_edge() {
        let black = probe_scene::Material::diffuse("black wall", Vec3::ZERO);
        let corners = [
            Vec3::new(-1.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 2.0, 0.0),
            Vec3::new(-1.0, 2.0, 0.0),
        ];
        let triangles = vec![
            probe_scene::Triangle::flat([corners[0], corners[1], corners[2]], 0),
            probe_scene::Triangle::flat([corners[0], corners[2], corners[3]], 0),
        ];
        let scene =
            Scene::from_triangles("black wall", triangles, vec![black], vec![], vec![]).unwrap();
        let probe = Vec3::new(0.0, 1.0, 0.2);
        let n = 32;
        let settings = BakeSettings {
            resolution: n,
            sampling: Sampling::fixed(16),
            bounces: 0,
            ..BakeSettings::default()
        };
        let baked = bake(&scene, &[probe], &settings, &no_progress).unwrap();
        let map = baked.radiance_map(0).unwrap();
        let layout = OctaLayout::new(n).unwrap();
        let (mut straddling, mut wall_texels) = (0, 0);
        for iy in 0..n {
            for ix in 0..n {
                let direction = layout.texel_direction(ix, iy);
                let ray = Ray {
                    origin: probe,
                    direction,
                };
                if scene.closest_hit(&ray, f32::INFINITY).is_none() {
                    continue;
                }
                wall_texels += 1;
                assert_eq!(map.get(ix, iy).unwrap(), Vec3::ZERO, "texel ({ix}, {iy})");
                // Does the texel's footprint reach past the wall (one corner of it misses)?
                let step = 2.0 / n as f32;
                let corner_misses =
                    [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)]
                        .iter()
                        .any(|&(a, b)| {
                            let q = Vec2::new(
                                -1.0 + (ix as f32 + a) * step,
                                -1.0 + (iy as f32 + b) * step,
                            );
                            let ray = Ray {
                                origin: probe,
                                direction: probe_octa::decode(q),
                            };
                            scene.closest_hit(&ray, f32::INFINITY).is_none()
                        });
                straddling += u32::from(corner_misses);
            }
        }
        // The test sees the case it is about: wall texels whose samples reach the sky.
        assert!(wall_texels > 100, "{wall_texels}");
        assert!(straddling > 10, "{straddling}");
        // The sky the samples past the wall met still lights the probe's irradiance from
        // the wall's side.
        let irradiance = baked.irradiance_map(0).unwrap();
        assert!(irradiance.sample_nearest(-Vec3::Z).max_element() > 0.0);
    }
}
