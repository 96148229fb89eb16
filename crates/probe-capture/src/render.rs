//! The reference path tracer: renders a camera's direct light, one-bounce glossy or full
//! global illumination with the shading core.

use std::sync::atomic::{AtomicUsize, Ordering};

use glam::{Vec2, Vec3};
use probe_scene::{Camera, Scene};

use crate::bake::Progress;
use crate::environment::Environment;
use crate::evaluation::{
    PIXEL_STREAM, Reflection, accumulate_rays, reflection_rays, render_gbuffer, trace_reference,
};
use crate::image::Image;
use crate::par::*;
use crate::rng::Rng;
use crate::shading::{Shader, ShaderError};

/// Why a render (or an evaluation-ray step) was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum RenderError {
    /// A setting is out of range. Fix: see the field's documentation in [`RenderSettings`]
    /// or the function's (the message names the parameter and the accepted range).
    #[error("render setting `{parameter}` is {value}: {reason}")]
    InvalidSetting {
        /// The parameter.
        parameter: &'static str,
        /// The value given, as text.
        value: String,
        /// What is accepted.
        reason: &'static str,
    },
    /// No camera of that name in the scene. Fix: use one of `available`, or pass a pose.
    #[error("the scene has no camera named {name:?}; it has {available:?}")]
    UnknownCamera {
        /// The name asked for.
        name: String,
        /// The scene's camera names.
        available: Vec<String>,
    },
    /// [`crate::accumulate_rays`] got a different number of radiance values than rays.
    /// Fix: pass one radiance per ray, in the rays' order.
    #[error("{rays} rays but {radiance} radiance values")]
    LengthMismatch {
        /// Number of rays.
        rays: usize,
        /// Number of radiance values.
        radiance: usize,
    },
    /// The environment is unusable. Fix: see [`ShaderError`].
    #[error(transparent)]
    Shader(#[from] ShaderError),
}

/// The scene's camera called `name`.
///
/// # Errors
/// [`RenderError::UnknownCamera`] listing the scene's camera names.
pub fn find_camera(scene: &Scene, name: &str) -> Result<Camera, RenderError> {
    scene
        .camera(name)
        .cloned()
        .ok_or_else(|| RenderError::UnknownCamera {
            name: name.to_owned(),
            available: scene.cameras().iter().map(|c| c.name.clone()).collect(),
        })
}

/// Which light a reference render shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Component {
    /// Emission plus direct light at the primary hit (the sky where nothing is hit),
    /// averaged over jittered primary rays.
    Direct,
    /// The seeds' indirect glossy component: from the G-buffer of pixel-centre primary rays,
    /// secondary reflection rays ([`crate::reflection_rays`], `samples_per_pixel` per pixel)
    /// traced against the BVH and their true hits shaded with the [`Shader`] (with
    /// [`RenderSettings::bounces`], as a bake), summed with the rays' weights. Exactly
    /// [`crate::trace_reference`] over those rays, so the probe tracer can be compared ray
    /// by ray and image by image.
    Glossy1,
    /// Path-traced global illumination: emission and direct light at the primary hit plus
    /// [`RenderSettings::bounces`] extra diffuse bounces after it (Lambertian, Russian
    /// roulette after [`RUSSIAN_ROULETTE_BOUNCES`](crate::RUSSIAN_ROULETTE_BOUNCES)
    /// bounces), averaged over jittered primary rays. With `bounces = 0` it is `Direct`.
    Full,
    /// Indirect diffuse light, what `probes render --component diffuse` draws from irradiance
    /// probes: at each pixel centre's primary hit, the base colour times the mean of the
    /// reflected radiance ([`Shader::reflected_radiance`], light sources left out, the sky
    /// kept) over `samples_per_pixel` cosine-distributed directions, the surfaces beyond
    /// shaded with [`RenderSettings::bounces`] as a bake's ([`crate::diffuse_reference`]).
    Diffuse,
    /// The final image an engine shows (model in [`crate::FinalParts`]'s module: metallic-
    /// roughness at the primary hit; direct light with exact shadows, indirect diffuse and
    /// GGX specular), path traced from each pixel centre's primary hit with
    /// `samples_per_pixel` samples of each part and [`RenderSettings::bounces`] beyond the
    /// first indirect hit, as a bake's ([`crate::reference_final`]).
    Final,
}

/// How to render a reference image. [`RenderSettings::new`] gives the defaults.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderSettings {
    /// Image width in pixels (1 to 16384).
    pub width: u32,
    /// Image height in pixels (1 to 16384).
    pub height: u32,
    /// Samples per pixel: jittered primary rays for `Direct` and `Full`, reflection rays for
    /// `Glossy1`. 1 to 65536. Default 16.
    pub samples_per_pixel: u32,
    /// Seed of every random choice. Default 0.
    pub seed: u64,
    /// Which component to render. Default `Glossy1`.
    pub component: Component,
    /// Sun and sky; `None` uses [`Environment::for_scene`], as a bake does. Default `None`.
    pub environment: Option<Environment>,
    /// Extra diffuse bounces after direct light (0 = direct light only), as the bake's
    /// [`BakeSettings::bounces`](crate::BakeSettings::bounces): of the radiance shaded at
    /// `Glossy1`'s secondary hits (match the bake's to compare with probes), and of `Full`'s
    /// paths from the primary hit. `Direct` has none and ignores it. At most 1024.
    /// Default 1.
    pub bounces: u32,
    /// Reflection rays of `Glossy1`. Default [`Reflection::Mirror`].
    pub reflection: Reflection,
    /// Shading estimates averaged at each `Glossy1` secondary hit (see
    /// [`crate::trace_reference`]). 1 to 65536. Default 1.
    pub shading_samples: u32,
}

impl RenderSettings {
    /// Defaults for a `width × height` image.
    pub fn new(width: u32, height: u32) -> RenderSettings {
        RenderSettings {
            width,
            height,
            samples_per_pixel: 16,
            seed: 0,
            component: Component::Glossy1,
            environment: None,
            bounces: 1,
            reflection: Reflection::Mirror,
            shading_samples: 1,
        }
    }

    fn validate(&self) -> Result<(), RenderError> {
        let invalid = |parameter: &'static str, value: u32, reason: &'static str| {
            Err(RenderError::InvalidSetting {
                parameter,
                value: value.to_string(),
                reason,
            })
        };
        if self.width == 0 || self.width > 16_384 {
            return invalid("width", self.width, "must be from 1 to 16384");
        }
        if self.height == 0 || self.height > 16_384 {
            return invalid("height", self.height, "must be from 1 to 16384");
        }
        if self.samples_per_pixel == 0 || self.samples_per_pixel > 65_536 {
            return invalid(
                "samples_per_pixel",
                self.samples_per_pixel,
                "must be from 1 to 65536",
            );
        }
        if self.shading_samples == 0 || self.shading_samples > 65_536 {
            return invalid(
                "shading_samples",
                self.shading_samples,
                "must be from 1 to 65536",
            );
        }
        if self.bounces > 1024 {
            return invalid("bounces", self.bounces, "must be at most 1024");
        }
        Ok(())
    }
}

/// Renders `camera` (a pose, or [`find_camera`] by name) with the reference path tracer,
/// spread over rayon's thread pool. Deterministic for a given seed, whatever the number of
/// threads. `progress` receives `(done, total)`: image rows for `Direct` and `Full`, traced
/// rays for `Glossy1`.
///
/// # Errors
/// [`RenderError`] for invalid settings or environment.
pub fn render(
    scene: &Scene,
    camera: &Camera,
    settings: &RenderSettings,
    progress: Progress<'_>,
) -> Result<Image, RenderError> {
    settings.validate()?;
    let environment = settings
        .environment
        .unwrap_or_else(|| Environment::for_scene(scene));
    let (width, height) = (settings.width, settings.height);
    match settings.component {
        Component::Glossy1 => {
            let shader = Shader::new(scene, environment, settings.bounces)?;
            let gbuffer = render_gbuffer(scene, camera, width, height)?;
            let rays = reflection_rays(
                &gbuffer,
                settings.reflection,
                settings.samples_per_pixel,
                settings.seed,
            )?;
            let samples = trace_reference(
                &shader,
                &rays,
                settings.shading_samples,
                settings.seed,
                progress,
            );
            let radiance: Vec<Vec3> = samples.iter().map(|s| s.radiance).collect();
            accumulate_rays(width, height, &rays, &radiance)
        }
        Component::Diffuse => {
            let shader = Shader::new(scene, environment, settings.bounces)?;
            let gbuffer = render_gbuffer(scene, camera, width, height)?;
            crate::diffuse_reference(
                &shader,
                &gbuffer,
                &|s| scene.materials()[s.material as usize].base_color,
                settings.samples_per_pixel,
                settings.seed,
                progress,
            )
        }
        Component::Final => Ok(render_final_parts(scene, camera, settings, progress)?.sum()),
        Component::Direct | Component::Full => {
            let bounces = match settings.component {
                Component::Direct => 0,
                _ => settings.bounces,
            };
            let shader = Shader::new(scene, environment, bounces)?;
            let done = AtomicUsize::new(0);
            let spp = settings.samples_per_pixel;
            let mut image = Image::new(width, height);
            image
                .rgb
                .par_chunks_mut(width as usize)
                .enumerate()
                .for_each(|(y, row)| {
                    for (x, pixel) in row.iter_mut().enumerate() {
                        let index = y as u64 * u64::from(width) + x as u64;
                        let mut rng = Rng::for_key(settings.seed, &[PIXEL_STREAM, index]);
                        let mut sum = Vec3::ZERO;
                        for _ in 0..spp {
                            let jitter = rng.next_vec2() - Vec2::splat(0.5);
                            let ray = camera.ray(x as u32, y as u32, width, height, jitter);
                            sum += shader.trace(&ray, &mut rng).1;
                        }
                        *pixel = (sum / spp as f32).to_array();
                    }
                    let d = done.fetch_add(1, Ordering::Relaxed) + 1;
                    progress(d, height as usize);
                });
            Ok(image)
        }
    }
}

/// The path-traced final image of `camera` in its parts (direct, indirect diffuse, specular;
/// [`crate::reference_final`]) with `settings`' size, samples, seed, environment and bounces;
/// its component and reflection are ignored.
///
/// # Errors
/// [`RenderError`] for invalid settings or environment.
pub fn render_final_parts(
    scene: &Scene,
    camera: &Camera,
    settings: &RenderSettings,
    progress: Progress<'_>,
) -> Result<crate::FinalParts, RenderError> {
    settings.validate()?;
    let environment = settings
        .environment
        .unwrap_or_else(|| Environment::for_scene(scene));
    let shader = Shader::new(scene, environment, settings.bounces)?;
    let gbuffer = render_gbuffer(scene, camera, settings.width, settings.height)?;
    crate::reference_final(
        &shader,
        &gbuffer,
        settings.samples_per_pixel,
        settings.seed,
        progress,
    )
}
