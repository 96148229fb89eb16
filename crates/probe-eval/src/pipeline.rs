//! The measured pipeline shared by `probes demo`, `probes eval` and the failure suite: the
//! evaluation rays of one camera and their path-traced reference ([`EvalView`]), a bake
//! ([`bake_for_view`], [`light_field`]), its indexes ([`build_index`]), and traces of those
//! rays through the probes with every tracer and selection ([`trace_view`]), each compared with
//! the reference ray by ray and image by image ([`crate::metrics`]; BRIEF, "How quality is
//! measured").

use std::time::Instant;

use glam::Vec3;
use probe_capture::{
    BakeSettings, BakedRadiance, Environment, EvaluationRay, Image, MISS_DISTANCE, ProbeBake,
    Progress, ReferenceSample, Reflection, Sampling, Shader, TileOrder, accumulate_rays, bake,
    reflection_rays, render_gbuffer, trace_reference,
};
use probe_index::{IndexOptions, IndexReport, ProbeGrid, ProbeIndex, SvoOptions};
use probe_scene::{Camera, Ray, Scene};
use probe_trace_gpu::Tracer as _;
use probe_trace_gpu::{
    AnyField, AnyIrradiance, AnyTracer, CpuTracer, DiffuseOptions, DiffuseOutput, FieldOptions,
    Interpolation, IrradianceField, LightField, ProbeSelection, RayResult, ShadingPoint,
    SurfaceQuery, TraceMethod, TraceOptions, TraceOutput, TraceRay, TraceSummary,
};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::EvalError;
use crate::convergence::{HalfSums, ReferenceNoise, half_sample_noise, pass_seed};
use crate::metrics::{
    Footprints, PixelClasses, TraceMetrics, classify_pixels, compare_rays_with, flip, mean_square,
    tonemapped_mse,
};

/// How the evaluation rays of a view are made (also the `[view]` table of `eval.toml`; every
/// field optional).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ViewSettings {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Reflection rays per pixel.
    pub rays_per_pixel: u32,
    /// Perceptual GGX roughness of every surface; 0 for mirror reflections.
    pub roughness: f32,
    /// Shading samples per reference hit (area-light and bounce samples averaged) of the
    /// first render: two half-sample passes of half as many each (rounded up), so that the
    /// reference's noise is estimated from the start ([`crate::convergence`]);
    /// [`EvalView::refine`] adds more.
    pub shading_samples: u32,
    /// Diffuse bounces in the radiance a reflection ray picks up (the bake's, too).
    pub bounces: u32,
    /// Seed of every random choice.
    pub seed: u64,
    /// The bakes' radiance smoothing ([`probe_capture::BakeSettings::denoise`]; 0: off).
    pub bake_denoise: f32,
}

impl Default for ViewSettings {
    fn default() -> Self {
        Self {
            width: 320,
            height: 180,
            rays_per_pixel: 1,
            roughness: 0.0,
            shading_samples: 8,
            bounces: 1,
            seed: 7,
            bake_denoise: 0.0,
        }
    }
}

impl ViewSettings {
    /// The reflection lobe.
    pub fn reflection(&self) -> Reflection {
        if self.roughness > 0.0 {
            Reflection::Ggx {
                roughness: self.roughness,
            }
        } else {
            Reflection::Mirror
        }
    }
}

/// One camera's evaluation rays and their reference: the ground truth every trace is judged by.
pub struct EvalView {
    /// The camera.
    pub camera: Camera,
    /// How the rays were made.
    pub settings: ViewSettings,
    /// The lighting shared by reference and bake.
    pub environment: Environment,
    /// Secondary (reflection) rays from the camera's G-buffer.
    pub rays: Vec<EvaluationRay>,
    /// The BVH's answer for each ray, shaded.
    pub reference: Vec<ReferenceSample>,
    /// The one-bounce glossy reference image (weighted mean of the reference radiance).
    pub reference_image: Image,
    /// Samples used and the reference's estimated noise (tone-mapped variance).
    pub reference_noise: ReferenceNoise,
    /// Seconds to render the reference (all passes).
    pub seconds: f64,
    halves: HalfSums,
    pass_samples: u32,
}

impl EvalView {
    /// Renders the camera's G-buffer, makes its reflection rays and traces them against the BVH
    /// in two independent half-sample passes (`settings.shading_samples` in all), which give
    /// the reference's noise estimate ([`crate::convergence`]).
    ///
    /// # Errors
    /// [`EvalError::Render`] for bad settings.
    pub fn render(
        scene: &Scene,
        camera: Camera,
        settings: ViewSettings,
        progress: Progress<'_>,
    ) -> Result<EvalView, EvalError> {
        let start = Instant::now();
        let environment = Environment::for_scene(scene);
        let gbuffer = render_gbuffer(scene, &camera, settings.width, settings.height)?;
        let rays = reflection_rays(
            &gbuffer,
            settings.reflection(),
            settings.rays_per_pixel,
            settings.seed,
        )?;
        let mut view = EvalView {
            camera,
            settings,
            environment,
            reference: Vec::new(),
            reference_image: Image::new(settings.width, settings.height),
            reference_noise: ReferenceNoise {
                samples: 0,
                passes: 0,
                noise: f64::INFINITY,
                target: None,
                converged: false,
            },
            seconds: 0.0,
            halves: HalfSums::new(rays.len()),
            pass_samples: settings.shading_samples.max(1).div_ceil(2),
            rays,
        };
        view.add_passes(scene, 2, progress)?;
        view.seconds = start.elapsed().as_secs_f64();
        Ok(view)
    }

    /// Adds `passes` reference passes (pass `k` seeded [`pass_seed`]`(seed ^ 0x5eed, k)`) and
    /// updates the reference, its image and its noise estimate.
    fn add_passes(
        &mut self,
        scene: &Scene,
        passes: u32,
        progress: Progress<'_>,
    ) -> Result<(), EvalError> {
        let shader = Shader::new(scene, self.environment, self.settings.bounces)?;
        for _ in 0..passes {
            let seed = pass_seed(self.settings.seed ^ 0x5eed, self.halves.passes());
            let samples = trace_reference(&shader, &self.rays, self.pass_samples, seed, progress);
            let radiance: Vec<Vec3> = samples.iter().map(|r| r.radiance).collect();
            self.halves.add(&radiance);
            if self.reference.is_empty() {
                self.reference = samples;
            }
        }
        let (width, height) = (self.settings.width, self.settings.height);
        let mean = self.halves.mean();
        for (sample, radiance) in self.reference.iter_mut().zip(&mean) {
            sample.radiance = *radiance;
        }
        self.reference_image = accumulate_rays(width, height, &self.rays, &mean)?;
        let half = |k: usize| accumulate_rays(width, height, &self.rays, &self.halves.half_mean(k));
        let noise = half_sample_noise(&half(0)?, &half(1)?);
        self.reference_noise = ReferenceNoise {
            samples: self.halves.passes() * self.pass_samples,
            passes: self.halves.passes(),
            noise,
            target: self.reference_noise.target,
            converged: self.reference_noise.target.is_some_and(|t| noise <= t),
        };
        Ok(())
    }

    /// Refines the reference until its noise estimate is at most `fraction` of the smallest
    /// tone-mapped MSE of `images` against it (the pipeline's default: 0.05, "trace first,
    /// then converge the reference to 5 % of the smallest error"), doubling the passes each
    /// round, up to `max_samples` shading samples per hit. The smallest error is measured
    /// again after each round (a noisy reference inflates it). With no images, or all equal
    /// to the reference, nothing is refined. Returns how far it went (also in
    /// [`Self::reference_noise`]).
    ///
    /// # Errors
    /// [`EvalError::Render`] / [`EvalError::Shader`] as [`Self::render`]; [`EvalError::Config`]
    /// for a `fraction` that is not positive and finite.
    pub fn refine(
        &mut self,
        scene: &Scene,
        images: &[&Image],
        fraction: f64,
        max_samples: u32,
        progress: Progress<'_>,
    ) -> Result<ReferenceNoise, EvalError> {
        if !(fraction.is_finite() && fraction > 0.0) {
            return Err(EvalError::Config {
                path: None,
                reason: format!(
                    "reference noise fraction {fraction}: give a positive share such as 0.05"
                ),
            });
        }
        let start = Instant::now();
        loop {
            let smallest = images
                .iter()
                .map(|image| tonemapped_mse(image, &self.reference_image))
                .fold(f64::INFINITY, f64::min);
            if !smallest.is_finite() || smallest <= 0.0 {
                break;
            }
            let target = fraction * smallest;
            self.reference_noise.target = Some(target);
            self.reference_noise.converged = self.reference_noise.noise <= target;
            let passes = self.halves.passes();
            if self.reference_noise.converged || (2 * passes) * self.pass_samples > max_samples {
                break;
            }
            self.add_passes(scene, passes, progress)?;
        }
        self.seconds += start.elapsed().as_secs_f64();
        Ok(self.reference_noise)
    }

    /// The rays in the tracer's form (each starting at `t = 0` from its offset origin).
    pub fn trace_rays(&self) -> Vec<TraceRay> {
        self.rays
            .iter()
            .map(|r| TraceRay::new(r.origin, r.direction))
            .collect()
    }

    /// The glossy image of traced `results` (one per ray of [`Self::trace_rays`]), weighted into
    /// pixels as the reference image is.
    ///
    /// # Errors
    /// [`EvalError::Image`] if `results` does not have one entry per ray.
    pub fn image_of(&self, results: &[RayResult]) -> Result<Image, EvalError> {
        let radiance: Vec<Vec3> = results.iter().map(|r| r.radiance).collect();
        Ok(accumulate_rays(
            self.settings.width,
            self.settings.height,
            &self.rays,
            &radiance,
        )?)
    }
}

/// Bakes probes for an evaluation: the view's environment, so that bake and reference light
/// the scene alike, and the view's seed.
///
/// # Errors
/// [`EvalError::Bake`] for bad settings or positions.
pub fn bake_for_view(
    scene: &Scene,
    positions: &[Vec3],
    resolution: u32,
    sampling: Sampling,
    view: &EvalView,
    progress: Progress<'_>,
) -> Result<(ProbeBake, f64), EvalError> {
    bake_for_view_seeded(
        scene,
        positions,
        resolution,
        sampling,
        view,
        view.settings.seed,
        progress,
    )
}

/// [`bake_for_view`] with another seed: a second, independent bake of the same probes
/// measures the bake's noise (half the tone-mapped MSE between the two traced images is the
/// variance of one).
///
/// # Errors
/// [`EvalError::Bake`] for bad settings or positions.
pub fn bake_for_view_seeded(
    scene: &Scene,
    positions: &[Vec3],
    resolution: u32,
    sampling: Sampling,
    view: &EvalView,
    seed: u64,
    progress: Progress<'_>,
) -> Result<(ProbeBake, f64), EvalError> {
    let settings = view_bake_settings(resolution, sampling, view, seed);
    timed_bake(scene, positions, &settings, progress)
}

/// The bake [`Tracer::Split`] reads, made directly for an evaluation: the bake
/// [`indirect_bake`] makes from [`bake_for_view_seeded`]'s of the same `seed`, to the byte,
/// without baking the outgoing radiance first (where the split is the only tracer asked for,
/// that bake is never read). The view's own seed gives [`bake_for_view`]'s counterpart;
/// another gives an independent bake, for the bake's noise.
///
/// # Errors
/// [`EvalError::Bake`] for bad settings or positions.
pub fn bake_reflected_for_view(
    scene: &Scene,
    positions: &[Vec3],
    resolution: u32,
    sampling: Sampling,
    view: &EvalView,
    seed: u64,
    progress: Progress<'_>,
) -> Result<(ProbeBake, f64), EvalError> {
    let settings = split_bake_settings(view_bake_settings(resolution, sampling, view, seed));
    timed_bake(scene, positions, &settings, progress)
}

/// The bake of `settings` and its wall time in seconds.
fn timed_bake(
    scene: &Scene,
    positions: &[Vec3],
    settings: &BakeSettings,
    progress: Progress<'_>,
) -> Result<(ProbeBake, f64), EvalError> {
    let start = Instant::now();
    let baked = bake(scene, positions, settings, progress)?;
    Ok((baked, start.elapsed().as_secs_f64()))
}

/// The settings of [`bake_for_view_seeded`].
fn view_bake_settings(
    resolution: u32,
    sampling: Sampling,
    view: &EvalView,
    seed: u64,
) -> BakeSettings {
    BakeSettings {
        resolution,
        sampling,
        bounces: view.settings.bounces,
        seed,
        environment: Some(view.environment),
        denoise: view.settings.bake_denoise,
        ..BakeSettings::default()
    }
}

/// The probe data of a bake as the tracers take it, without the bake's per-texel distance
/// ranges: measured, they turn some wrong answers into UNKNOWN but more right answers too
/// (accuracy example, 2026-12-02: Sponza's grid 7.34 % → 6.25 % wrong and 6.77 % → 8.32 %
/// UNKNOWN at equal radiance error; the Breakfast room 89.5 % → 85.9 % answered within a
/// footprint and 20 % more radiance error). To trace with them, set
/// `distance_range: Some(baked.distance_ranges())`.
pub fn light_field(baked: &ProbeBake) -> LightField<'_> {
    LightField {
        resolution: baked.resolution(),
        positions: baked.positions(),
        radial_distance: baked.distances(),
        normals: baked.normals(),
        radiance: baked.radiance(),
        distance_range: None,
        sky_distance: MISS_DISTANCE * 0.5,
        geometry_bounds: baked.scene_bounds(),
    }
}

/// Bytes of a bake as the tracer holds it, split as seed 000's Table 5.2: the distance probes
/// (per padded texel a 16-byte geometry record — distance, normal, depth bounds — plus the hi-Z
/// pyramid, 8 bytes per coarse texel) and the other textures (radiance, 12 bytes per padded
/// texel, and the tracer's sky map, 12 bytes per direction texel once; irradiance and
/// distance moments for diffuse shading).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct ProbeMemory {
    /// Geometry records and the min/max pyramid.
    pub distance_bytes: u64,
    /// Radiance, irradiance and moments.
    pub other_bytes: u64,
}

impl ProbeMemory {
    /// The memory of `baked` with a hi-Z pyramid of `top_level` levels above full resolution.
    pub fn of(baked: &ProbeBake, top_level: u32) -> ProbeMemory {
        let probes = baked.probe_count() as u64;
        let n = u64::from(baked.resolution());
        let padded = (n + 2) * (n + 2);
        let mut pyramid = 0;
        let mut side = n;
        for _ in 0..top_level {
            side /= 2;
            if side == 0 {
                break;
            }
            pyramid += side * side;
        }
        let per_probe_other = (baked.irradiance().len() as u64 * 12
            + baked.moments().len() as u64 * 8)
            / probes.max(1);
        ProbeMemory {
            distance_bytes: probes * (padded * 16 + pyramid * 8),
            // Plus the sky map the tracer packs once for all probes (N² radiance texels).
            other_bytes: probes * (padded * 12 + per_probe_other) + n * n * 12,
        }
    }
}

/// Index structures of a probe set, with their report.
pub struct BuiltIndex {
    /// Delaunay, nearest-probe tree, Voronoi neighbours, octree.
    pub index: ProbeIndex,
    /// Counts, bytes and times.
    pub report: IndexReport,
    /// The regular grid's cage indexing, when the probes are a full regular grid.
    pub grid: Option<ProbeGrid>,
    /// Seconds to build everything.
    pub seconds: f64,
}

impl BuiltIndex {
    /// Seed 000's Voronoi selection over this index; `None` when the probes span no volume
    /// (no tetrahedralization, so no neighbour maps).
    pub fn voronoi(&self) -> Option<ProbeSelection<'_>> {
        Some(ProbeSelection::Voronoi {
            nearest: &self.index.nearest,
            neighbours: self.index.neighbours.as_ref()?,
        })
    }
}

/// Builds the Delaunay tetrahedralization, the nearest-probe tree, the Voronoi-sphere
/// neighbour maps and the sparse voxel octree of `positions` (no edge casts: the probes are
/// baked already).
///
/// # Errors
/// [`EvalError::Index`].
pub fn build_index(
    scene: &Scene,
    positions: &[Vec3],
    svo_depth: u32,
    grid: Option<ProbeGrid>,
    seed: u64,
) -> Result<BuiltIndex, EvalError> {
    let start = Instant::now();
    let options = IndexOptions {
        edge_casts: None,
        neighbour_resolution: 16,
        svo: Some(SvoOptions {
            max_depth: svo_depth,
            seed,
            ..SvoOptions::default()
        }),
    };
    let (index, report) = ProbeIndex::build(positions, scene, &options)?;
    Ok(BuiltIndex {
        index,
        report,
        grid,
        seconds: start.elapsed().as_secs_f64(),
    })
}

/// Which probes a ray tries.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Selection {
    /// The regular grid's 8-cage, seed 003 Alg. 6 order (only for full regular grids).
    Grid,
    /// The sparse voxel octree of best probes (seed 000 Alg. 5).
    Svo,
    /// The nearest probe and its Voronoi-sphere neighbours (seed 000 Alg. 4).
    Voronoi,
}

impl Selection {
    /// Every selection.
    pub const ALL: [Selection; 3] = [Selection::Grid, Selection::Svo, Selection::Voronoi];

    /// The name used on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            Selection::Grid => "grid",
            Selection::Svo => "svo",
            Selection::Voronoi => "voronoi",
        }
    }

    /// The tracer's selection over `index`, or `None` when it does not apply (a grid cage for
    /// probes that are not a full regular grid).
    pub fn of<'a>(self, index: &'a BuiltIndex) -> Option<ProbeSelection<'a>> {
        match self {
            Selection::Grid => index.grid.map(ProbeSelection::Grid),
            Selection::Svo => index
                .index
                .svo
                .as_ref()
                .map(ProbeSelection::SparseVoxelOctree),
            Selection::Voronoi => index.voronoi(),
        }
    }

    /// Bytes of the selection structure.
    pub fn bytes(self, index: &BuiltIndex) -> u64 {
        match self {
            Selection::Grid => 0,
            Selection::Svo => index.report.svo.as_ref().map_or(0, |s| s.bytes as u64),
            Selection::Voronoi => {
                (index.report.nearest_bytes + index.report.neighbour_bytes) as u64
            }
        }
    }
}

/// How a ray is answered: through the light-field probes by one of the two single-probe
/// marches, or by the hybrid (geometry from the scene's BVH, radiance from the probes that
/// see the hit: what a renderer with ray tracing would do with the same probes).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Tracer {
    /// McGuire 2017's coarse DDA and fine march.
    TwoLevel,
    /// Hi-Z over the min/max pyramid (seed 000 §4.3).
    HiZ,
    /// Exact hits from the scene's BVH (on the CPU here), radiance from the probes
    /// ([`probe_trace_gpu::Tracer::look_up`] on the device), bounded below by the hit's own
    /// emission; where a bake's irradiance probes are at hand ([`Device::hit_shading`]), hits
    /// no probe shows are shaded with them and exact direct light.
    Hybrid,
    /// Exact hits from the scene's BVH shaded the way DDGI answers a ray-traced reflection:
    /// emission, direct light with shadow rays, and the bake's irradiance probes for the light
    /// the surroundings reflect ([`HitShading`]); misses read the environment. No light-field
    /// probe is read: the baseline for what their radiance adds.
    Shaded,
    /// Exact hits from the scene's BVH, the light split: emission and the light sources'
    /// direct light with shadow rays (as [`Tracer::Shaded`]), and the light the hit reflects
    /// from its surroundings and the sky looked up in light-field probes that hold only that
    /// ([`BakedRadiance::Indirect`], baked at the bake's positions and settings by
    /// [`Device::hit_shading_for`]); hits no probe shows are shaded as the shaded tracer's.
    /// The sun's shadow edges are drawn by shadow rays, the rest at texel resolution.
    Split,
}

impl Tracer {
    /// The light-field tracers.
    pub const ALL: [Tracer; 2] = [Tracer::TwoLevel, Tracer::HiZ];

    /// The light-field tracers and the hybrid.
    pub const WITH_HYBRID: [Tracer; 3] = [Tracer::TwoLevel, Tracer::HiZ, Tracer::Hybrid];

    /// The light-field tracers and the three tracers that cast rays against the BVH.
    pub const WITH_BVH: [Tracer; 5] = [
        Tracer::TwoLevel,
        Tracer::HiZ,
        Tracer::Hybrid,
        Tracer::Shaded,
        Tracer::Split,
    ];

    /// Whether the tracer casts its rays against the scene's BVH (the hybrid, the shaded hits
    /// and the split) rather than through the light field.
    pub fn uses_bvh(self) -> bool {
        matches!(self, Tracer::Hybrid | Tracer::Shaded | Tracer::Split)
    }

    /// The name used on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            Tracer::TwoLevel => "two-level",
            Tracer::HiZ => "hiz",
            Tracer::Hybrid => "hybrid",
            Tracer::Shaded => "shaded",
            Tracer::Split => "split",
        }
    }

    /// The tracer's options (the hybrid's look-up uses only the candidate options).
    pub fn options(self) -> TraceOptions {
        TraceOptions {
            method: match self {
                Tracer::TwoLevel => TraceMethod::TwoLevel,
                Tracer::HiZ | Tracer::Hybrid | Tracer::Shaded | Tracer::Split => TraceMethod::HiZ,
            },
            ..TraceOptions::default()
        }
    }
}

/// How a hit found by the BVH is shaded without the light-field probes (the hybrid's hits that
/// no probe shows; every hit of [`Tracer::Shaded`]): exact shadow rays for the light sources
/// and irradiance probes for the light the surroundings reflect
/// ([`Shader::radiance_with_indirect`]). Made by [`Device::hit_shading`].
pub struct HitShading<'s> {
    shader: Shader<'s>,
    /// `None` for a bake without bounces: the truth at a hit is then its direct light alone.
    irradiance: Option<AnyIrradiance>,
    /// Emitter samples per shaded hit (the emissive triangles' direct light).
    pub emitter_samples: u32,
    /// Seeds the emitter samples (per ray); [`Device::hit_shading`] takes the bake's seed.
    pub seed: u64,
    /// For [`Tracer::Split`] given a bake of the outgoing radiance: the bake of the light the
    /// surfaces reflect ([`BakedRadiance::Indirect`]) made at its positions.
    indirect: Option<ProbeBake>,
    /// Made for [`Tracer::Split`] ([`Device::hit_shading_for`] with that tracer): its probes
    /// hold the reflected light alone, in `indirect` or in the bake given, when that is one.
    split: bool,
}

impl HitShading<'_> {
    /// The bake of the light the surfaces reflect that [`Tracer::Split`] reads, when made
    /// for it ([`Device::hit_shading_for`] with that tracer and a bake of the outgoing
    /// radiance; `None` when the bake given already held the reflected light).
    pub fn indirect_bake(&self) -> Option<&ProbeBake> {
        self.indirect.as_ref()
    }
}

/// The bake whose probes `tracer` reads: `baked` itself, except for [`Tracer::Split`] on a
/// bake of the outgoing radiance, which reads `shading`'s [`HitShading::indirect_bake`]
/// (`None` when there is none). A bake that already holds the reflected light alone
/// ([`BakedRadiance::Indirect`], `probes bake --radiance indirect`) is read by the split as it is.
pub fn bake_read_by<'a>(
    tracer: Tracer,
    baked: &'a ProbeBake,
    shading: Option<&'a HitShading<'_>>,
) -> Option<&'a ProbeBake> {
    if tracer == Tracer::Split && baked.settings().radiance != BakedRadiance::Indirect {
        shading.and_then(HitShading::indirect_bake)
    } else {
        Some(baked)
    }
}

/// Probe resolution of the bake whose irradiance shades BVH hits ([`Device::hit_shading`]):
/// DDGI's probes trace a few hundred rays each; 32² texels hold 1,024.
pub const HIT_SHADING_RESOLUTION: u32 = 32;

/// The radiance smoothing of the bake [`Tracer::Split`] reads ([`BakeSettings::denoise`]):
/// the light the surfaces reflect has none of the light sources' shadow edges, so the
/// edge-preserving smoothing takes out the bake's noise (its fireflies on dark surfaces) and
/// little else. Measured against no smoothing: Sponza's `CameraMain` 1.47e-4 → 1.40e-4
/// (tone-mapped MSE), the image's bake noise 1.4e-5 → 6.1e-6; the demo's Cornell box
/// 1.05–1.11e-5 → 8.7–9.2e-6 (BENCHMARKS.md, "The light split").
pub const SPLIT_INDIRECT_DENOISE: f32 = 2.0;

/// The bake [`Tracer::Split`] reads: `baked`'s positions and settings, its radiance maps
/// holding the light the surfaces reflect ([`BakedRadiance::Indirect`]), smoothed at
/// [`SPLIT_INDIRECT_DENOISE`].
///
/// # Errors
/// [`EvalError::Bake`].
pub fn indirect_bake(scene: &Scene, baked: &ProbeBake) -> Result<ProbeBake, EvalError> {
    let settings = split_bake_settings(baked.settings().clone());
    Ok(bake(scene, baked.positions(), &settings, &|_, _| {})?)
}

/// `settings` made those of the bake [`Tracer::Split`] reads: radiance maps holding the light
/// the surfaces reflect ([`BakedRadiance::Indirect`]), smoothed at [`SPLIT_INDIRECT_DENOISE`].
/// [`indirect_bake`], [`bake_reflected_for_view`] and `probes bake --radiance indirect` all
/// make their bakes so, which is why the split reads any of them to the same bytes.
pub fn split_bake_settings(settings: BakeSettings) -> BakeSettings {
    BakeSettings {
        radiance: BakedRadiance::Indirect,
        denoise: SPLIT_INDIRECT_DENOISE,
        ..settings
    }
}

/// Random-number stream of the hybrid's shaded hits.
const HIT_SHADING_STREAM: u64 = 0x4859_4252;

/// Sets the radiance of `results[i]` for each `i` of `which` (the `k`-th) to
/// `light(k, i, its radiance now, rng)`, on all CPU threads. Each hit's light samples are
/// seeded by its ray's index: the same answers on any number of threads.
fn light_hits(
    shading: &HitShading<'_>,
    which: &[usize],
    results: &mut [RayResult],
    light: impl Fn(usize, usize, Vec3, &mut probe_capture::Rng) -> Vec3 + Sync,
) {
    let lit: Vec<Vec3> = which
        .par_iter()
        .enumerate()
        .map(|(k, &i)| {
            let mut rng =
                probe_capture::Rng::for_key(shading.seed, &[HIT_SHADING_STREAM, i as u64]);
            light(k, i, results[i].radiance, &mut rng)
        })
        .collect();
    for (&i, radiance) in which.iter().zip(lit) {
        results[i].radiance = radiance;
    }
}

/// The GPU tracer when an adapter exists, else the CPU twin (same algorithm, same answers).
pub struct Device {
    tracer: AnyTracer,
}

impl Device {
    /// The CPU twin.
    pub fn cpu() -> Device {
        Device {
            tracer: AnyTracer::new(CpuTracer::new()),
        }
    }

    /// The GPU tracer if an adapter exists, else the CPU twin (and why). With `require_gpu`,
    /// no adapter is an error.
    ///
    /// # Errors
    /// [`EvalError::Gpu`] when `require_gpu` and no adapter could be used.
    pub fn open(require_gpu: bool) -> Result<(Device, Option<String>), EvalError> {
        match AnyTracer::gpu_or_cpu() {
            (tracer, None) => Ok((Device { tracer }, None)),
            (_, Some(error)) if require_gpu => Err(EvalError::Gpu(error)),
            (tracer, Some(error)) => Ok((Device { tracer }, Some(error.to_string()))),
        }
    }

    /// "gpu: NAME" or "cpu twin".
    pub fn describe(&self) -> String {
        self.tracer.describe()
    }

    /// Uploads probe maps and a selection.
    ///
    /// # Errors
    /// [`EvalError::Upload`].
    pub fn upload(
        &mut self,
        field: &LightField<'_>,
        selection: &ProbeSelection<'_>,
    ) -> Result<AnyField, EvalError> {
        Ok(self
            .tracer
            .upload(field, selection, &FieldOptions::default())?)
    }

    /// Uploads probe maps and a selection with field options of the caller's (e.g. prefiltered
    /// glossy levels, [`FieldOptions::glossy_levels`]).
    ///
    /// # Errors
    /// [`EvalError::Upload`].
    pub fn upload_with(
        &mut self,
        field: &LightField<'_>,
        selection: &ProbeSelection<'_>,
        options: &FieldOptions,
    ) -> Result<AnyField, EvalError> {
        Ok(self.tracer.upload(field, selection, options)?)
    }

    /// Traces rays through uploaded probes.
    ///
    /// # Errors
    /// [`EvalError::Trace`].
    pub fn trace(
        &mut self,
        field: &AnyField,
        rays: &[TraceRay],
        options: &TraceOptions,
    ) -> Result<TraceOutput, EvalError> {
        Ok(self.tracer.trace(field, rays, options)?)
    }

    /// Answers `rays` with `tracer`: through the probes in `field`, or for
    /// [`Tracer::Hybrid`] by casting them against `scene`'s BVH and looking the hits' radiance
    /// up in the probes that see them. The hybrid's results carry the BVH's `t` and position,
    /// never less radiance than the hit's material emits towards the ray (the probes' filtered
    /// read would blur an emitter's edge into its darker surround), and its wall time covers
    /// both halves (no device time is reported for it). With `shading`, a hit that no probe
    /// shows (UNKNOWN) is shaded instead ([`HitShading`]: direct light with shadow rays, the
    /// irradiance probes for the rest), not estimated from nearby texels of its surface.
    /// [`Tracer::Split`] needs the `shading` of [`Self::hit_shading_for`] with that tracer,
    /// and `field` uploaded from its [`HitShading::indirect_bake`] ([`bake_read_by`]):
    /// the probes' read is taken as the reflected light alone.
    ///
    /// # Errors
    /// [`EvalError::Trace`].
    pub fn trace_with(
        &mut self,
        scene: &Scene,
        field: &AnyField,
        rays: &[TraceRay],
        tracer: Tracer,
        shading: Option<&HitShading<'_>>,
    ) -> Result<TraceOutput, EvalError> {
        let options = tracer.options();
        if !tracer.uses_bvh() {
            return self.trace(field, rays, &options);
        }
        let start = Instant::now();
        let casts: Vec<Ray> = rays
            .iter()
            .map(|r| Ray::new(Vec3::from(r.origin), Vec3::from(r.direction)))
            .collect();
        let hits = scene.closest_hits(&casts, f32::INFINITY);
        let split = match (tracer, shading) {
            (Tracer::Split, Some(shading)) if shading.split => Some(shading),
            (Tracer::Split, _) => {
                return Err(EvalError::InvalidSetting {
                    parameter: "tracer",
                    value: "split".into(),
                    reason: "the split reads a bake of the light the surfaces reflect and \
                             shades with irradiance probes: make its shading with \
                             Device::hit_shading_for(Tracer::Split, ..), which needs probes \
                             spanning a volume or a regular grid; use hybrid"
                        .into(),
                });
            }
            _ => None,
        };
        if tracer == Tracer::Shaded {
            let shading = shading.ok_or_else(|| EvalError::InvalidSetting {
                parameter: "tracer",
                value: "shaded".into(),
                reason: "the shaded hits blend the bake's irradiance probes, which need probes \
                         spanning a volume or a regular grid; use hybrid"
                    .into(),
            })?;
            let mut results: Vec<RayResult> = casts
                .iter()
                .zip(&hits)
                .map(|(ray, hit)| match hit {
                    Some(hit) => RayResult {
                        status: probe_trace_gpu::RayStatus::Hit,
                        t: hit.t,
                        position: hit.position,
                        normal: hit.geometric_normal,
                        radiance: Vec3::ZERO,
                        probe: None,
                        probes_tried: 0,
                        texel_fetches: 0,
                    },
                    None => RayResult {
                        status: probe_trace_gpu::RayStatus::Miss,
                        t: MISS_DISTANCE,
                        position: ray.origin + ray.direction * MISS_DISTANCE,
                        normal: Vec3::ZERO,
                        radiance: shading.shader.background(ray.direction),
                        probe: None,
                        probes_tried: 0,
                        texel_fetches: 0,
                    },
                })
                .collect();
            let every_hit: Vec<usize> = (0..hits.len()).filter(|&i| hits[i].is_some()).collect();
            self.shade_hits(shading, &hits, &casts, &every_hit, &mut results)?;
            return Ok(TraceOutput {
                results,
                timing: probe_trace_gpu::Timing {
                    wall: start.elapsed(),
                    gpu: None,
                },
            });
        }
        let queries: Vec<SurfaceQuery> = casts
            .iter()
            .zip(&hits)
            .map(|(ray, hit)| match hit {
                Some(hit) => {
                    SurfaceQuery::surface(hit.position, hit.geometric_normal, ray.direction)
                }
                None => SurfaceQuery::escaped(ray.origin, ray.direction),
            })
            .collect();
        let mut output = self.tracer.look_up(field, &queries, &options)?;
        let materials = scene.materials();
        for ((result, hit), ray) in output.results.iter_mut().zip(&hits).zip(&casts) {
            if let Some(hit) = hit {
                result.t = hit.t;
                if split.is_some() {
                    continue; // the probes' read is the reflected light alone
                }
                // What leaves a surface is at least what it emits: where the probes' filtered
                // read blurs an emitter's edge into its darker surround, the exact hit's own
                // emission bounds the answer from below.
                let emitted = materials[hit.material as usize]
                    .emission_towards(hit.geometric_normal, -ray.direction);
                result.radiance = result.radiance.max(emitted);
            }
        }
        if let Some(shading) = split {
            // The light sources' direct light with shadow rays, the probes' reflected light.
            let shown: Vec<usize> = (0..hits.len())
                .filter(|&i| {
                    hits[i].is_some() && output.results[i].status == probe_trace_gpu::RayStatus::Hit
                })
                .collect();
            light_hits(shading, &shown, &mut output.results, |_, i, read, rng| {
                let hit = hits[i].as_ref().expect("a hit");
                shading.shader.radiance_with_reflected(
                    hit,
                    -casts[i].direction,
                    read,
                    shading.emitter_samples,
                    rng,
                )
            });
        }
        if let Some(shading) = shading {
            // What no probe shows (UNKNOWN) is shaded.
            let unshown: Vec<usize> = (0..hits.len())
                .filter(|&i| {
                    hits[i].is_some()
                        && output.results[i].status == probe_trace_gpu::RayStatus::Unknown
                })
                .collect();
            self.shade_hits(shading, &hits, &casts, &unshown, &mut output.results)?;
        }
        output.timing = probe_trace_gpu::Timing {
            wall: start.elapsed(),
            gpu: None,
        };
        Ok(output)
    }

    /// What a BVH tracer needs to shade hits without the light-field probes ([`HitShading`]):
    /// irradiance probes at `baked`'s positions holding one bounce fewer than `baked` (the
    /// truth at a reflection hit, like the light field's radiance, stops `bounces` bounces
    /// after the hit, and irradiance probes hold the light their surroundings reflect, so
    /// `baked`'s own would add a bounce: on the Cornell box with a 2×2×2 grid the shaded
    /// image's error was 3.6 times higher with them), baked again at
    /// [`HIT_SHADING_RESOLUTION`] with `baked`'s other settings and blended over `index`'s
    /// Delaunay tetrahedralization (else its regular grid); a shader of `scene` under the
    /// bake's lights. `None` when the probes span no volume and form no grid. A bake without
    /// bounces needs no irradiance (the truth at a hit is its direct light).
    ///
    /// # Errors
    /// [`EvalError::Bake`], [`EvalError::Upload`], or the shader's error for a bake whose
    /// environment the scene cannot take.
    pub fn hit_shading<'s>(
        &mut self,
        scene: &'s Scene,
        baked: &ProbeBake,
        index: &BuiltIndex,
    ) -> Result<Option<HitShading<'s>>, EvalError> {
        let interpolation = match (index.index.tetrahedralization.as_ref(), index.grid) {
            (Some(tetrahedra), _) => Interpolation::Delaunay(tetrahedra),
            (None, Some(grid)) => Interpolation::Grid(grid),
            (None, None) => return Ok(None),
        };
        let settings = baked.settings();
        let irradiance = if settings.bounces == 0 {
            None
        } else {
            let fewer = BakeSettings {
                resolution: HIT_SHADING_RESOLUTION.min(settings.resolution),
                bounces: settings.bounces - 1,
                radiance: BakedRadiance::Outgoing,
                // A bake of the reflected light was smoothed for the split's read
                // ([`SPLIT_INDIRECT_DENOISE`]), not for these probes: they are baked
                // unsmoothed, as from a default bake of the outgoing radiance.
                denoise: if settings.radiance == BakedRadiance::Indirect {
                    BakeSettings::default().denoise
                } else {
                    settings.denoise
                },
                ..settings.clone()
            };
            let shading_bake = bake(scene, baked.positions(), &fewer, &|_, _| {})?;
            Some(self.upload_irradiance(&shading_bake, &interpolation)?)
        };
        let shader = Shader::new(scene, *baked.environment(), settings.bounces)?;
        Ok(Some(HitShading {
            shader,
            irradiance,
            emitter_samples: 16,
            // The bake's seed: two bakes with different seeds then differ by the light
            // samples too, and the demo's bake noise (half their images' MSE) holds both.
            seed: settings.seed,
            indirect: None,
            split: false,
        }))
    }

    /// [`Self::hit_shading`] where `tracer` casts rays against the BVH ([`Tracer::uses_bvh`]),
    /// else `None` (the light-field tracers shade nothing). For [`Tracer::Split`] on a bake of
    /// the outgoing radiance the light field of the light the surfaces reflect is baked too
    /// ([`indirect_bake`]): a second bake at `baked`'s positions and resolution, as long as
    /// `baked` took. A bake that holds the reflected light already
    /// ([`BakedRadiance::Indirect`]) is read as it is, with no second bake.
    ///
    /// # Errors
    /// As [`Self::hit_shading`]; [`EvalError::InvalidSetting`] for a bake of the reflected
    /// light with any tracer but the split, whose images would lack the light sources.
    pub fn hit_shading_for<'s>(
        &mut self,
        tracer: Tracer,
        scene: &'s Scene,
        baked: &ProbeBake,
        index: &BuiltIndex,
    ) -> Result<Option<HitShading<'s>>, EvalError> {
        let holds_reflected = baked.settings().radiance == BakedRadiance::Indirect;
        if holds_reflected && tracer != Tracer::Split {
            return Err(EvalError::InvalidSetting {
                parameter: "tracer",
                value: tracer.name().into(),
                reason: "the bake holds only the light its surfaces reflect \
                         (BakedRadiance::Indirect), which only the split reads: use \
                         Tracer::Split, or a bake of the outgoing radiance"
                    .into(),
            });
        }
        if !tracer.uses_bvh() {
            return Ok(None);
        }
        let shading = self.hit_shading(scene, baked, index)?;
        match (tracer, shading) {
            (Tracer::Split, Some(mut shading)) => {
                if !holds_reflected {
                    shading.indirect = Some(indirect_bake(scene, baked)?);
                }
                shading.split = true;
                Ok(Some(shading))
            }
            (_, shading) => Ok(shading),
        }
    }

    /// Replaces the radiance of the answers at `which` (indices of rays that hit: the
    /// hybrid's unshown hits, every hit of the shaded tracer) by the hit shaded with `shading`
    /// (the shadow rays and light samples on all CPU threads, the irradiance probes on the
    /// device).
    fn shade_hits(
        &mut self,
        shading: &HitShading<'_>,
        hits: &[Option<probe_scene::Hit>],
        casts: &[Ray],
        which: &[usize],
        results: &mut [RayResult],
    ) -> Result<(), EvalError> {
        let mut unseen = Vec::new();
        let mut points = Vec::new();
        for &i in which {
            let hit = hits[i].as_ref().expect("only rays that hit are shaded");
            let towards_viewer = -casts[i].direction;
            match shading.shader.visible_normals(hit, towards_viewer) {
                Some((_, shading_normal)) => {
                    unseen.push(i);
                    points.push(ShadingPoint::new(hit.position, shading_normal));
                }
                // The back of a single-sided surface reflects nothing.
                None => results[i].radiance = shading.shader.emission(hit, towards_viewer),
            }
        }
        if unseen.is_empty() {
            return Ok(());
        }
        let indirect: Vec<Vec3> = match &shading.irradiance {
            Some(irradiance) => self
                .shade_diffuse(irradiance, &points, &DiffuseOptions::default())?
                .results
                .iter()
                .map(|r| r.irradiance)
                .collect(),
            None => vec![Vec3::ZERO; points.len()],
        };
        light_hits(shading, &unseen, results, |k, i, _, rng| {
            let hit = hits[i].as_ref().expect("a hit");
            shading.shader.radiance_with_indirect(
                hit,
                -casts[i].direction,
                indirect[k],
                shading.emitter_samples,
                rng,
            )
        });
        Ok(())
    }

    /// Uploads a bake's irradiance probes (irradiance and distance moments) for diffuse
    /// shading, blended by `interpolation`.
    ///
    /// # Errors
    /// [`EvalError::Upload`].
    pub fn upload_irradiance(
        &mut self,
        baked: &ProbeBake,
        interpolation: &Interpolation<'_>,
    ) -> Result<AnyIrradiance, EvalError> {
        let settings = baked.settings();
        // DDGI's inactive probes: those whose baked view is mostly back faces sit inside
        // geometry (`probes bake` warns of them) and are left out of the blend.
        let inside_geometry: Vec<bool> =
            baked.stats().iter().map(|s| s.inside_geometry()).collect();
        let field = IrradianceField {
            positions: baked.positions(),
            irradiance_resolution: settings.irradiance_resolution,
            irradiance: baked.irradiance(),
            moments_resolution: settings.moments_resolution,
            moments: baked.moments(),
            surfels: baked.surfels(),
            inside_geometry: &inside_geometry,
        };
        Ok(self.tracer.upload_irradiance(&field, interpolation)?)
    }

    /// Shades points diffusely from uploaded irradiance probes.
    ///
    /// # Errors
    /// [`EvalError::Trace`].
    pub fn shade_diffuse(
        &mut self,
        irradiance: &AnyIrradiance,
        points: &[ShadingPoint],
        options: &DiffuseOptions,
    ) -> Result<DiffuseOutput, EvalError> {
        Ok(self.tracer.shade_diffuse(irradiance, points, options)?)
    }
}

/// One trace of a view's rays through a bake, before it is compared with the reference (so
/// the reference can be refined after tracing: [`EvalView::refine`]).
pub struct TracedView {
    /// The tracer.
    pub tracer: Tracer,
    /// The selection.
    pub selection: Selection,
    /// One result per ray.
    pub results: Vec<RayResult>,
    /// The probes' glossy image.
    pub image: Image,
    /// Milliseconds on the device (GPU timestamps when available).
    pub gpu_ms: Option<f64>,
    /// Wall-clock milliseconds of the call.
    pub wall_ms: f64,
}

/// Traces a view's rays through a bake with one tracer and selection, the BVH tracers'
/// hits shaded with `shading` where the light field cannot answer ([`Device::hit_shading`]
/// of the same bake); `None` when the selection does not apply to the probes, or for
/// [`Tracer::Shaded`] without `shading`.
///
/// # Errors
/// [`EvalError`] from upload or trace.
#[allow(clippy::too_many_arguments)]
pub fn trace_only(
    device: &mut Device,
    scene: &Scene,
    baked: &ProbeBake,
    index: &BuiltIndex,
    view: &EvalView,
    rays: &[TraceRay],
    tracer: Tracer,
    selection: Selection,
    shading: Option<&HitShading<'_>>,
) -> Result<Option<TracedView>, EvalError> {
    let Some(probe_selection) = selection.of(index) else {
        return Ok(None);
    };
    if tracer == Tracer::Shaded && shading.is_none() {
        return Ok(None);
    }
    let Some(read) = bake_read_by(tracer, baked, shading) else {
        return Ok(None);
    };
    let field = device.upload(&light_field(read), &probe_selection)?;
    // Traced in 8×8 pixel tiles (faster on a GPU; the answers do not depend on the order).
    let order = TileOrder::of(&view.rays, view.settings.width);
    let tiled = order.apply(rays);
    // Warm up: the first dispatch compiles the pipeline (lavapipe: seconds without Mesa's
    // shader cache, ~0.1 s with it).
    let warm = tiled.len().min(256);
    device.trace_with(scene, &field, &tiled[..warm], tracer, shading)?;
    let mut output = device.trace_with(scene, &field, &tiled, tracer, shading)?;
    output.results = order.restore(output.results);
    let image = view.image_of(&output.results)?;
    Ok(Some(TracedView {
        tracer,
        selection,
        gpu_ms: output.timing.gpu.map(|d| d.as_secs_f64() * 1e3),
        wall_ms: output.timing.wall.as_secs_f64() * 1e3,
        results: output.results,
        image,
    }))
}

/// Compares a trace with the view's reference as it is now (`footprints` of the bake traced:
/// [`Footprints::of`]): every metric of
/// [`TraceMetrics`], the reference's noise beside them, `bake_noise` as given, and the pixel
/// classes (returned too, for the error-class image).
///
/// # Errors
/// [`EvalError::Image`] for a trace of another view.
pub fn compare_trace(
    footprints: Footprints<'_>,
    view: &EvalView,
    traced: &TracedView,
    bake_noise: Option<f64>,
) -> Result<(TraceMetrics, PixelClasses), EvalError> {
    let image = &traced.image;
    let summary = TraceSummary::of(&traced.results);
    let comparison = compare_rays_with(footprints, &view.reference, &traced.results);
    let mse = image.mse(&view.reference_image)?;
    let reference_power = mean_square(&view.reference_image);
    let classes = classify_pixels(
        footprints,
        &view.rays,
        &view.reference,
        &traced.results,
        image,
        &view.reference_image,
    );
    let metrics = TraceMetrics {
        tracer: traced.tracer,
        selection: traced.selection,
        rays: traced.results.len(),
        trace_ms: traced.gpu_ms.unwrap_or(traced.wall_ms),
        wall_ms: traced.wall_ms,
        gpu_timestamps: traced.gpu_ms.is_some(),
        fetches_per_ray: summary.fetches_per_ray,
        probes_per_ray: summary.probes_per_ray,
        hit_rate: summary.hit_rate(),
        unknown_rate: summary.unknown_rate(),
        status_agreement: comparison.status_agreement,
        within_footprint: comparison.within_footprint,
        mean_position_error: comparison.mean_position_error,
        ray_mse: comparison.ray_mse,
        mse,
        relative_mse: if reference_power > 0.0 {
            mse / reference_power
        } else {
            mse
        },
        psnr: image.psnr(&view.reference_image)?,
        mse_tonemapped: tonemapped_mse(image, &view.reference_image),
        flip: flip(image, &view.reference_image)?.1,
        reference_noise: view.reference_noise.noise,
        bake_noise,
        second_bake_mse_tonemapped: None,
        classes: classes.shares(image, &view.reference_image),
    };
    Ok((metrics, classes))
}

/// Traces a view's rays through a bake with one tracer and selection, and compares with the
/// reference as it is ([`trace_only`], then [`compare_trace`] with the bake's noise not
/// measured). Returns the metrics and the probes' glossy image.
///
/// # Errors
/// [`EvalError`] from upload or trace.
#[allow(clippy::too_many_arguments)]
pub fn trace_view(
    device: &mut Device,
    scene: &Scene,
    baked: &ProbeBake,
    index: &BuiltIndex,
    view: &EvalView,
    rays: &[TraceRay],
    tracer: Tracer,
    selection: Selection,
) -> Result<Option<(TraceMetrics, Image)>, EvalError> {
    let shading = device.hit_shading_for(tracer, scene, baked, index)?;
    let Some(traced) = trace_only(
        device,
        scene,
        baked,
        index,
        view,
        rays,
        tracer,
        selection,
        shading.as_ref(),
    )?
    else {
        return Ok(None);
    };
    let (metrics, _) = compare_trace(Footprints::of(baked), view, &traced, None)?;
    Ok(Some((metrics, traced.image)))
}
