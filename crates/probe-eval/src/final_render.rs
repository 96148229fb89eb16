//! The final image through probes: what an engine would show, in the parts probe-capture's
//! model splits it into ([`probe_capture::FinalParts`]), each computed the way a renderer with
//! probes computes it.
//!
//! - **direct**: emission plus the diffuse lobe times the direct irradiance with exact shadow
//!   rays against the BVH (what an engine does with shadow maps), the same estimator as the
//!   reference's ([`probe_capture::direct_image`]) with fewer emitter samples;
//! - **diffuse**: the diffuse lobe times the irradiance probes' blend with Chebyshev
//!   visibility (the bake's irradiance holds indirect light only, so no light source is
//!   counted twice);
//! - **specular**: the GGX lobe's reflection rays ([`probe_capture::specular_rays`]) traced
//!   through the light-field probes with the chosen tracer, each ray's answer tinted by its
//!   Fresnel weight.
//!
//! ```no_run
//! use probe_capture::{ProbeBake, render_gbuffer};
//! use probe_eval::final_render::{FinalOptions, render_final};
//! use probe_eval::pipeline::{Device, build_index};
//! use probe_scene::Scene;
//!
//! let scene = Scene::builtin("cornell")?;
//! let baked = ProbeBake::load("cornell-bake", Some(&scene))?;
//! let camera = scene.cameras()[0].clone();
//! let gbuffer = render_gbuffer(&scene, &camera, 320, 180)?;
//! let index = build_index(&scene, baked.positions(), 7, None, 0)?;
//! let (mut device, _) = Device::open(false)?;
//! let rendered = render_final(&mut device, &scene, &baked, &index, &gbuffer, &FinalOptions::default())?;
//! rendered.parts.sum().save_png("final.png")?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use crate::EvalError;
use crate::glossy::GLOSSY_LEVELS;
use crate::metrics::tonemapped_mse;
use crate::pipeline::{BuiltIndex, Device, Selection, Tracer, light_field};
use glam::Vec3;
use probe_capture::{
    FinalParts, GBuffer, Image, ProbeBake, Shader, SurfaceResponse, TileOrder, direct_image,
    filtered_specular_sub_lobe_rays, specular_rays,
};
use probe_scene::Scene;
use probe_trace_gpu::{
    DiffuseOptions, FieldOptions, Interpolation, ShadingPoint, TraceOptions, TraceRay, TraceSummary,
};
use std::time::Instant;

/// How the irradiance probes are blended for the diffuse part.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DiffuseBlend {
    /// Trilinear over the regular grid's cage (DDGI); the probes must be a full regular grid.
    Grid,
    /// Barycentric over the Delaunay tetrahedron holding the point.
    Delaunay,
}

/// How the specular part is traced.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpecularMode {
    /// Rays sampled from each material's GGX lobe ([`probe_capture::specular_rays`]):
    /// unbiased, noisy at one ray per pixel.
    Stochastic,
    /// One ray per pixel along the lobe's dominant direction whose radiance is read from the
    /// probes' prefiltered GGX levels at the cone's footprint
    /// ([`probe_capture::filtered_specular_rays`]; [`crate::glossy::GLOSSY_LEVELS`] levels):
    /// no noise, a bias where the lobe straddles geometry. Not with [`Tracer::Hybrid`] or
    /// [`Tracer::Shaded`].
    Filtered,
}

/// The mode's name in tables: `filtered` or `stochastic`.
pub fn specular_name(mode: SpecularMode) -> &'static str {
    match mode {
        SpecularMode::Filtered => "filtered",
        SpecularMode::Stochastic => "stochastic",
    }
}

/// Settings of [`render_final`]. `Default` gives hi-Z through the octree, Delaunay diffuse,
/// filtered specular blended over 4 probes and 16 emitter samples per pixel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FinalOptions {
    /// The light-field tracer of the specular rays.
    pub tracer: Tracer,
    /// How specular rays choose probes.
    pub selection: Selection,
    /// How the diffuse part blends the irradiance probes.
    pub blend: DiffuseBlend,
    /// The diffuse shading's options (visibility, bias).
    pub diffuse: DiffuseOptions,
    /// How the specular part is traced.
    pub specular: SpecularMode,
    /// Probes whose prefiltered reads are blended for each [`SpecularMode::Filtered`] ray
    /// ([`TraceOptions::glossy_blend`]: the nearest probes of the shading point that see the
    /// hit; 0 reads the answering probe alone). Default: the tracer's (6), measured on the
    /// Cornell box, Sponza and the Breakfast room against one probe (BENCHMARKS.md, "The
    /// final image").
    pub glossy_blend: u32,
    /// Rays per glossy pixel of [`SpecularMode::Filtered`], 1 to 8: each material's GGX lobe
    /// cut by azimuth into this many parts, one narrower cone each
    /// ([`probe_capture::filtered_specular_sub_lobe_rays`]); mirrors keep one ray. Default 1.
    /// Must be 1 with [`SpecularMode::Stochastic`].
    pub specular_sectors: u32,
    /// Specular rays per pixel of [`SpecularMode::Stochastic`] (materials rougher than
    /// [`probe_capture::MIRROR_ROUGHNESS`]; mirrors take one).
    pub specular_rays_per_pixel: u32,
    /// Emitter samples per pixel of the direct light's area lights.
    pub emitter_samples: u32,
    /// Seed of the specular rays and the emitter samples.
    pub seed: u64,
}

impl Default for FinalOptions {
    fn default() -> Self {
        FinalOptions {
            tracer: Tracer::HiZ,
            selection: Selection::Svo,
            blend: DiffuseBlend::Delaunay,
            diffuse: DiffuseOptions::default(),
            specular: SpecularMode::Filtered,
            glossy_blend: TraceOptions::default().glossy_blend,
            specular_sectors: 1,
            specular_rays_per_pixel: 1,
            emitter_samples: 16,
            seed: 0,
        }
    }
}

/// Milliseconds each part took (wall clock; device time where the device reports it).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct PartTimes {
    /// The direct light on the CPU (shadow rays against the BVH, on rayon's threads).
    pub direct_ms: f64,
    /// Diffuse shading from the irradiance probes (upload excluded).
    pub diffuse_ms: f64,
    /// Diffuse shading, device time.
    pub diffuse_gpu_ms: Option<f64>,
    /// The specular trace through the light field (upload excluded).
    pub specular_ms: f64,
    /// The specular trace, device time.
    pub specular_gpu_ms: Option<f64>,
    /// The untimed first dispatches that compile the two pipelines.
    pub first_dispatch_ms: f64,
}

/// A final image through probes.
pub struct ProbeFinal {
    /// The parts; [`FinalParts::sum`] is the image.
    pub parts: FinalParts,
    /// What each part cost.
    pub times: PartTimes,
    /// The specular rays' answers (hits, misses, UNKNOWN).
    pub specular: TraceSummary,
    /// Shading points of the diffuse part.
    pub shading_points: usize,
}

/// Rays or points of the untimed first dispatch that compiles a pipeline.
const WARM_UP_ITEMS: usize = 256;

/// Renders the final image of `gbuffer`'s view through `baked`'s probes (see the module).
/// `index` is [`crate::pipeline::build_index`] of `baked`'s positions (its tetrahedralization
/// blends the diffuse part).
///
/// # Errors
/// [`EvalError::InvalidSetting`] when the options ask for what the probes cannot give (a
/// grid blend of probes that are not a regular grid, a selection the index lacks);
/// [`EvalError`] from the shader, upload, trace or shading.
pub fn render_final(
    device: &mut Device,
    scene: &Scene,
    baked: &ProbeBake,
    index: &BuiltIndex,
    gbuffer: &GBuffer,
    options: &FinalOptions,
) -> Result<ProbeFinal, EvalError> {
    let shader = Shader::new(scene, *baked.environment(), baked.settings().bounces)?;
    let mut times = PartTimes::default();

    let start = Instant::now();
    let direct = direct_image(&shader, gbuffer, options.emitter_samples, options.seed)?;
    times.direct_ms = start.elapsed().as_secs_f64() * 1e3;

    // Diffuse: the irradiance probes at every front-facing primary hit.
    let tetrahedra;
    let interpolation = match options.blend {
        DiffuseBlend::Grid => {
            Interpolation::Grid(index.grid.ok_or_else(|| EvalError::InvalidSetting {
                parameter: "blend",
                value: "grid".into(),
                reason: "the probes are not a full regular grid; blend by Delaunay".into(),
            })?)
        }
        // The index already holds the probes' tetrahedralization; a set that spans no
        // volume has none, and building it gives the error that says why.
        DiffuseBlend::Delaunay => match index.index.tetrahedralization.as_ref() {
            Some(built) => Interpolation::Delaunay(built),
            None => {
                tetrahedra = probe_index::Tetrahedralization::build(baked.positions())
                    .map_err(probe_index::IndexError::from)?;
                Interpolation::Delaunay(&tetrahedra)
            }
        },
    };
    let irradiance = device.upload_irradiance(baked, &interpolation)?;
    let mut pixels = Vec::new();
    let mut points = Vec::new();
    let mut lobes = Vec::new();
    for (i, sample) in gbuffer.pixels.iter().enumerate() {
        if let Some(s) = sample.filter(|s| !s.back_face) {
            pixels.push(i);
            points.push(ShadingPoint::new(s.position, s.shading_normal));
            lobes.push(SurfaceResponse::at(scene, &s).diffuse);
        }
    }
    let first = Instant::now();
    device.shade_diffuse(
        &irradiance,
        &points[..points.len().min(WARM_UP_ITEMS)],
        &options.diffuse,
    )?;
    times.first_dispatch_ms += first.elapsed().as_secs_f64() * 1e3;
    let shaded = device.shade_diffuse(&irradiance, &points, &options.diffuse)?;
    times.diffuse_ms = shaded.timing.wall.as_secs_f64() * 1e3;
    times.diffuse_gpu_ms = shaded.timing.gpu.map(|d| d.as_secs_f64() * 1e3);
    let mut diffuse = Image::new(gbuffer.width, gbuffer.height);
    for ((&pixel, result), lobe) in pixels.iter().zip(&shaded.results).zip(&lobes) {
        diffuse.rgb[pixel] = (result.irradiance * *lobe / std::f32::consts::PI).to_array();
    }

    // Specular: the GGX lobe's rays through the light field.
    if options.tracer == Tracer::Split {
        return Err(EvalError::InvalidSetting {
            parameter: "tracer",
            value: "split".into(),
            reason: "the final image's specular rays read the bake's own radiance, and the \
                     split reads a second bake of reflected light only; use hybrid, shaded, \
                     hi-Z or two-level here (the split answers the glossy component)"
                .into(),
        });
    }
    let filtered = options.specular == SpecularMode::Filtered;
    if filtered && options.tracer.uses_bvh() {
        return Err(EvalError::InvalidSetting {
            parameter: "specular",
            value: "filtered".into(),
            reason: "the hybrid and shaded tracers read no prefiltered levels; use hi-Z or \
                     two-level, or stochastic specular rays"
                .into(),
        });
    }
    if !filtered && options.specular_sectors != 1 {
        return Err(EvalError::InvalidSetting {
            parameter: "specular_sectors",
            value: options.specular_sectors.to_string(),
            reason: "sectors cut a filtered lobe; stochastic specular rays take \
                     specular_rays_per_pixel instead"
                .into(),
        });
    }
    let rays = if filtered {
        filtered_specular_sub_lobe_rays(scene, gbuffer, options.specular_sectors)?
    } else {
        specular_rays(
            scene,
            gbuffer,
            options.specular_rays_per_pixel,
            options.seed,
        )?
    };
    let probe_selection = options
        .selection
        .of(index)
        .ok_or_else(|| EvalError::InvalidSetting {
            parameter: "selection",
            value: options.selection.name().into(),
            reason: "the index has no such selection for these probes (a grid selection \
                         needs a regular grid; Voronoi needs probes that span a volume)"
                .into(),
        })?;
    let field_options = FieldOptions {
        glossy_levels: if filtered { GLOSSY_LEVELS } else { 0 },
        ..FieldOptions::default()
    };
    let field = device.upload_with(&light_field(baked), &probe_selection, &field_options)?;
    let trace_rays: Vec<TraceRay> = rays
        .rays
        .iter()
        .map(|r| TraceRay::new(r.origin, r.direction))
        .collect();
    // A filtered trace takes one roughness per call: the rays are traced in groups of equal
    // roughness (one per material roughness in the view) and put back in order.
    // Each group and the stochastic trace go in 8×8 pixel tiles (faster on a GPU; the
    // answers do not depend on the order).
    let order = TileOrder::of(&rays.rays, gbuffer.width);
    let mut groups: Vec<(f32, Vec<usize>)> = Vec::new();
    if filtered {
        for &i in order.indices() {
            let r = rays.roughness[i];
            match groups.iter_mut().find(|(g, _)| *g == r) {
                Some((_, members)) => members.push(i),
                None => groups.push((r, vec![i])),
            }
        }
    }
    let hit_shading = device.hit_shading_for(options.tracer, scene, baked, index)?;
    let first = Instant::now();
    let warm = &trace_rays[..trace_rays.len().min(WARM_UP_ITEMS)];
    if filtered {
        device.trace(&field, warm, &options.tracer.options())?;
    } else {
        device.trace_with(scene, &field, warm, options.tracer, hit_shading.as_ref())?;
    }
    times.first_dispatch_ms += first.elapsed().as_secs_f64() * 1e3;
    let traced = if filtered {
        let mut results = vec![None; trace_rays.len()];
        let mut wall = std::time::Duration::ZERO;
        let mut gpu = Some(std::time::Duration::ZERO);
        for (roughness, members) in &groups {
            let subset: Vec<TraceRay> = members.iter().map(|&i| trace_rays[i]).collect();
            let cone = TraceOptions {
                glossy_roughness: *roughness,
                glossy_blend: options.glossy_blend,
                ..options.tracer.options()
            };
            let output = device.trace(&field, &subset, &cone)?;
            wall += output.timing.wall;
            gpu = gpu.zip(output.timing.gpu).map(|(a, b)| a + b);
            for (&i, result) in members.iter().zip(output.results) {
                results[i] = Some(result);
            }
        }
        probe_trace_gpu::TraceOutput {
            // Every ray is in one group: each slot was filled.
            results: results.into_iter().flatten().collect(),
            timing: probe_trace_gpu::Timing { wall, gpu },
        }
    } else {
        let mut output = device.trace_with(
            scene,
            &field,
            &order.apply(&trace_rays),
            options.tracer,
            hit_shading.as_ref(),
        )?;
        output.results = order.restore(output.results);
        output
    };
    times.specular_ms = traced.timing.wall.as_secs_f64() * 1e3;
    times.specular_gpu_ms = traced.timing.gpu.map(|d| d.as_secs_f64() * 1e3);
    let radiance: Vec<Vec3> = traced.results.iter().map(|r| r.radiance).collect();
    let specular = rays.image(gbuffer, &radiance)?;

    Ok(ProbeFinal {
        parts: FinalParts {
            direct,
            diffuse,
            specular,
        },
        times,
        specular: TraceSummary::of(&traced.results),
        shading_points: points.len(),
    })
}

/// A tone-mapped MSE per part and for the whole final image.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct PartErrors {
    /// The final image (the parts' sum).
    pub image: f64,
    /// Emission and direct light.
    pub direct: f64,
    /// Indirect diffuse.
    pub diffuse: f64,
    /// Specular.
    pub specular: f64,
}

impl PartErrors {
    /// The tone-mapped MSE of each part of `a` against `b`, and of the sums.
    pub fn between(a: &FinalParts, b: &FinalParts) -> PartErrors {
        PartErrors {
            image: tonemapped_mse(&a.sum(), &b.sum()),
            direct: tonemapped_mse(&a.direct, &b.direct),
            diffuse: tonemapped_mse(&a.diffuse, &b.diffuse),
            specular: tonemapped_mse(&a.specular, &b.specular),
        }
    }

    fn scaled(self, factor: f64) -> PartErrors {
        PartErrors {
            image: self.image * factor,
            direct: self.direct * factor,
            diffuse: self.diffuse * factor,
            specular: self.specular * factor,
        }
    }
}

/// The path-traced final image of a view, with its noise.
pub struct FinalReference {
    /// The parts: the mean of two independent halves.
    pub parts: FinalParts,
    /// The noise of each part (the variance of the mean of the halves, tone-mapped: a quarter
    /// of the MSE between the halves).
    pub noise: PartErrors,
    /// Samples of each part per pixel, both halves together.
    pub samples: u32,
    /// Seconds to render.
    pub seconds: f64,
}

/// Renders the path-traced final image of `gbuffer`'s view as two halves of `samples / 2`
/// samples (seeds `seed` and `seed + 1`), lit as `baked` was (its environment and bounces),
/// and estimates each part's noise from their difference. `progress` receives `(done, total)`.
///
/// # Errors
/// [`EvalError::Render`] for `samples` under 2 or above 131072; [`EvalError::Shader`].
pub fn reference_final(
    scene: &Scene,
    baked: &ProbeBake,
    gbuffer: &GBuffer,
    samples: u32,
    seed: u64,
    progress: probe_capture::Progress<'_>,
) -> Result<FinalReference, EvalError> {
    let start = Instant::now();
    let shader = Shader::new(scene, *baked.environment(), baked.settings().bounces)?;
    let half = samples / 2;
    let a =
        probe_capture::reference_final(&shader, gbuffer, half, seed, &|d, t| progress(d, 2 * t))?;
    let b = probe_capture::reference_final(&shader, gbuffer, half, seed + 1, &|d, t| {
        progress(t + d, 2 * t)
    })?;
    let mean = |x: &Image, y: &Image| {
        let mut out = x.clone();
        for (o, v) in out.rgb.iter_mut().zip(&y.rgb) {
            for k in 0..3 {
                o[k] = 0.5 * (o[k] + v[k]);
            }
        }
        out
    };
    let noise = PartErrors::between(&a, &b).scaled(0.25);
    Ok(FinalReference {
        parts: FinalParts {
            direct: mean(&a.direct, &b.direct),
            diffuse: mean(&a.diffuse, &b.diffuse),
            specular: mean(&a.specular, &b.specular),
        },
        noise,
        samples: 2 * half,
        seconds: start.elapsed().as_secs_f64(),
    })
}

/// A final image through probes against its reference, with every noise floor.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct FinalComparison {
    /// Tone-mapped MSE against the reference, per part.
    pub mse: PartErrors,
    /// The reference's own noise, per part.
    pub reference_noise: PartErrors,
    /// The bake's noise per part (half the MSE between the images of two bakes with different
    /// seeds), when a second bake was rendered.
    pub bake_noise: Option<PartErrors>,
    /// The render's own noise per part (half the MSE between two renders of one bake with
    /// different seeds: the direct light's emitter samples and the specular rays), when a
    /// second render was made.
    pub render_noise: Option<PartErrors>,
    /// Mean FLIP of the final image.
    pub flip: f64,
    /// What each part cost.
    pub times: PartTimes,
}

/// Compares `probes` with `reference`; `other_bake` (the same render through a bake with
/// another seed) and `other_seed` (the same bake rendered with another seed) give the noise
/// floors.
///
/// # Errors
/// [`EvalError::Image`] when the sizes differ.
pub fn compare_final(
    probes: &ProbeFinal,
    other_bake: Option<&ProbeFinal>,
    other_seed: Option<&ProbeFinal>,
    reference: &FinalReference,
) -> Result<FinalComparison, EvalError> {
    let image = probes.parts.sum();
    let (_, flip) = crate::metrics::flip(&image, &reference.parts.sum())?;
    Ok(FinalComparison {
        mse: PartErrors::between(&probes.parts, &reference.parts),
        reference_noise: reference.noise,
        bake_noise: other_bake.map(|o| PartErrors::between(&probes.parts, &o.parts).scaled(0.5)),
        render_noise: other_seed.map(|o| PartErrors::between(&probes.parts, &o.parts).scaled(0.5)),
        flip,
        times: probes.times,
    })
}

/// Renders the final image through `baked` and compares it with `reference`: the render
/// noise from a second render with seed `options.seed + 1`, the bake noise from a render
/// through `second` (the same probes baked with another seed), when given.
///
/// # Errors
/// [`EvalError`] from [`render_final`] or [`compare_final`].
#[allow(clippy::too_many_arguments, reason = "the whole comparison's inputs")]
pub fn render_and_compare(
    device: &mut Device,
    scene: &Scene,
    baked: &ProbeBake,
    second: Option<&ProbeBake>,
    index: &BuiltIndex,
    gbuffer: &GBuffer,
    options: &FinalOptions,
    reference: &FinalReference,
) -> Result<(ProbeFinal, FinalComparison), EvalError> {
    let first = render_final(device, scene, baked, index, gbuffer, options)?;
    let other_bake = match second {
        Some(second) => Some(render_final(
            device, scene, second, index, gbuffer, options,
        )?),
        None => None,
    };
    let other_seed = render_final(
        device,
        scene,
        baked,
        index,
        gbuffer,
        &FinalOptions {
            seed: options.seed + 1,
            ..*options
        },
    )?;
    let comparison = compare_final(&first, other_bake.as_ref(), Some(&other_seed), reference)?;
    Ok((first, comparison))
}
