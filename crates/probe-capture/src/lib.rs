//! Rendering light-field probes from a scene, and the path-traced reference they are judged by.
//!
//! `probe-capture` sits above [`probe_scene`] (geometry, materials, lights, BVH) and
//! [`probe_octa`] (octahedral maps and their filters). It
//!
//! - **bakes probes** ([`bake`]): per probe, at an octahedral resolution up to 1024², one ray
//!   through each texel centre gives the hit's radial distance and normal
//!   ([`capture_geometry`]), and jittered rays through each texel give the mean radiance of
//!   the surface that centre ray met (emission, direct light from punctual lights, emissive
//!   triangles, sun and sky, plus diffuse bounces; samples that pass that surface's edge are
//!   left out of the texel's radiance, not of its irradiance). probe-octa then derives the
//!   padded maps, the min/max distance pyramid, distance moments, irradiance and L2 SH. The result is a [`ProbeBake`] of flat,
//!   probe-major, padded arrays that a GPU uploads as is;
//! - **stores bakes** ([`ProbeBake::save`], [`ProbeBake::load`]): a directory with a JSON
//!   manifest and 32-bit float EXR texture arrays with named channels, written atomically,
//!   read back bit for bit, refused for another scene or a newer format;
//! - **shards bakes** ([`bake_shard`], [`merge_shards`]): shard `K/N` of the probes bakes on
//!   its own machine into a [`PartialBake`]; the `N` partial bakes merge into the bake an
//!   unsharded run gives, byte for byte once saved (each probe's samples are keyed by its
//!   index in the whole set); missing, duplicate or mismatched shards are refused;
//! - **renders the reference** ([`render`]): direct light, the seeds' one-bounce indirect
//!   glossy component and full global illumination, to an [`Image`] saved as EXR or
//!   tone-mapped PNG, and the **evaluation rays** the probe tracer is compared on
//!   ([`render_gbuffer`], [`reflection_rays`], [`trace_reference`], [`accumulate_rays`]),
//!   and the order a GPU traces them fastest in ([`TileOrder`]: 8×8 pixel tiles).
//!
//! Bake and reference shade with one core, the [`Shader`], so "shade the true hit the same
//! way" holds by construction.
//!
//! ```
//! use probe_capture::{
//!     BakeSettings, Component, ProbeBake, RenderSettings, Sampling, bake, no_progress, render,
//! };
//! use probe_scene::{Scene, glam::Vec3};
//!
//! let scene = Scene::builtin("cornell")?;
//! let centre = Vec3::new(0.278, 0.27, 0.28);
//!
//! // Two probes at 32² (padded 34²), 2 samples per texel, direct light plus one bounce.
//! let settings = BakeSettings { resolution: 32, sampling: Sampling::fixed(2), ..Default::default() };
//! let probes = bake(&scene, &[centre, centre + Vec3::Y * 0.1], &settings, &no_progress)?;
//! assert_eq!(probes.distances().len(), 2 * 34 * 34);
//! // Straight down from the first probe, the floor is 0.27 m away.
//! let down = probes.distance_map(0).unwrap().sample(-Vec3::Y);
//! assert!((down - 0.27).abs() < 0.01);
//! // Almost no ray meets the back of a wall (the measured walls leave hairline gaps).
//! assert!(probes.stats()[0].back_face_share < 0.01);
//!
//! // Save and load: the same bytes come back; another scene is refused.
//! let dir = std::env::temp_dir().join(format!("probe-capture-doc-{}", std::process::id()));
//! probes.save(&dir)?;
//! assert_eq!(ProbeBake::load(&dir, Some(&scene))?, probes);
//! assert!(ProbeBake::load(&dir, Some(&Scene::builtin("boxes")?)).is_err());
//! # std::fs::remove_dir_all(&dir)?;
//!
//! // The reference: a small one-bounce glossy image from the scene's camera.
//! let mut render_settings = RenderSettings::new(16, 16);
//! render_settings.samples_per_pixel = 2;
//! render_settings.component = Component::Direct;
//! let image = render(&scene, &scene.default_camera(), &render_settings, &no_progress)?;
//! assert!(image.mean().max_element() > 0.0);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! # Design choices
//! - **Rays go through the octahedral texels themselves**, not through a cube map that is
//!   then resampled (as seeds 001 and 003 do with a rasteriser): a ray tracer can, and it
//!   avoids the resampling blur. Distance and normal come from the texel-centre ray, the
//!   value a bilinear reader interpolates between; radiance is the mean over rays across
//!   the texel's octahedral square.
//! - **Converged by default** ([`Sampling`]): every random decision of a texel's samples is
//!   a dimension of an Owen-scrambled Sobol sequence; the samples are split into
//!   independently scrambled replicates whose spread estimates each texel's noise; a second
//!   pass adds samples where that noise is above the target. Emitters are reached by light
//!   sampling and bounce rays with multiple importance sampling. The bake records per probe
//!   the samples taken and the noise left ([`ProbeSampling`]).
//! - **Misses** store the distance [`MISS_DISTANCE`] (1e9 m, finite so GPU filtering stays
//!   finite), a zero normal and the sky's radiance.
//! - **Lambertian surfaces** with the base colour as albedo (the probes' assumption); back
//!   faces of single-sided materials are black (see [`Shader`]).
//! - **Default light**: a scene with no punctual light and no emissive material gets
//!   [`Environment::DEFAULT_DAYLIGHT`] (a sun and a gradient sky); others get a black sky
//!   unless an environment is given.
//! - **Determinism**: every random number comes from a stream keyed by the seed and the
//!   work item ([`SobolSampler::for_key`] in bakes, [`Rng::for_key`] in references); sums over texels run in a fixed order. Same inputs and
//!   seed give the same bytes on any number of threads.
//! - **Parallelism**: rayon over probes and texel rows (bake) and image rows or ray blocks
//!   (render), behind the default `parallel` feature; without it the same work runs on the
//!   calling thread and gives the same bytes. The library never prints; long operations take
//!   a progress callback.

#![forbid(unsafe_code)]

mod atomic;
mod bake;
mod bake_io;
mod environment;
mod evaluation;
mod exr_io;
mod final_image;
mod image;
mod par;
mod preview;
mod render;
mod rng;
mod shading;
mod shard;

pub use bake::{
    BakeError, BakeSettings, BakedRadiance, MAX_BAKE_RESOLUTION, MISS_DISTANCE, NOISE_REPLICATES,
    ProbeBake, ProbeGeometry, ProbeSampling, ProbeStats, Progress, RANGE_SAMPLES, Sampling, bake,
    bake_memory_estimate, bake_with_limit, capture_geometry, no_progress,
};
pub use bake_io::{BAKE_FORMAT_VERSION, BakeLoadError, BakeSaveError, MANIFEST_FILE};
pub use environment::Environment;
pub use evaluation::{
    EvaluationRay, GBuffer, GBufferSample, MAX_LOBE_SECTORS, ReferenceSample, Reflection,
    TileOrder, accumulate_rays, ggx_lobe_mean, ggx_sub_lobe_parts, ggx_sub_lobes, reflection_rays,
    render_gbuffer, sub_lobe_roughness, trace_reference,
};
pub use final_image::{
    DIELECTRIC_F0, FinalParts, MIRROR_ROUGHNESS, SpecularRays, SurfaceResponse, diffuse_reference,
    direct_image, filtered_specular_rays, filtered_specular_sub_lobe_rays, fresnel_schlick,
    reference_final, specular_albedo, specular_rays,
};
pub use image::{Image, ImageError};
pub use preview::{PreviewError, PreviewPaths};
pub use render::{Component, RenderError, RenderSettings, find_camera, render, render_final_parts};
pub use rng::{Rng, Sampler, SobolSampler};
pub use shading::{RUSSIAN_ROULETTE_BOUNCES, Shader, ShaderError};
pub use shard::{
    MergeError, PartialBake, Shard, ShardError, bake_shard, merge_shards, probe_set_hash,
};
