//! References that converge: a Monte Carlo image rendered in passes until its noise is below a
//! target.
//!
//! **The noise estimator.** The passes are split into two independent halves (even passes and
//! odd passes, the same number of samples each). With `A` and `B` the two half-sample images and
//! `t(x) = x / (1 + x)` the tone map of the headline MSE ([`crate::metrics::tonemapped_mse`]),
//! the noise of the full-sample mean `(A + B) / 2` is
//!
//! ```text
//! noise = tonemapped_mse(A, B) / 4
//! ```
//!
//! `A − B` has twice the variance of one half, and one half twice the variance of the full
//! mean, so `E[(A − B)²] = 4 Var[(A + B) / 2]` (per pixel and channel, in tone-mapped units, to
//! first order in the tone map's slope). The noise is the floor below which an MSE against this
//! reference cannot tell errors apart: an image equal to the truth still scores about `noise`.
//!
//! Each round doubles the passes (so the noise roughly halves) until the estimate is at most
//! the target or the sample cap is reached. Pass `k` takes the seed [`pass_seed`]`(seed, k)`,
//! so the result is deterministic given the seed, and the first two passes do not depend on
//! the target.

use glam::Vec3;
use probe_capture::{Image, Progress, RenderSettings, render};
use probe_scene::{Camera, Scene};
use serde::Serialize;

use crate::EvalError;
use crate::metrics::tonemapped_mse;

/// How far a progressive reference went: what it cost and how noisy it is.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ReferenceNoise {
    /// Samples used in all (per pixel for images, shading samples per hit for evaluation rays).
    pub samples: u32,
    /// Passes rendered (an even number: two halves).
    pub passes: u32,
    /// The estimated noise of the full-sample mean: tone-mapped MSE between the two
    /// half-sample images, over 4 (see the module documentation).
    pub noise: f64,
    /// The target it was refined towards, if any.
    pub target: Option<f64>,
    /// Whether `noise ≤ target` (false when the cap stopped it or there was no target).
    pub converged: bool,
}

/// When a progressive render stops.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum NoiseTarget {
    /// Exactly this many samples (two halves of half as many; at least 2).
    Samples(u32),
    /// Until the noise estimate is at most this (tone-mapped variance), or `max_samples`.
    Noise {
        /// The target noise.
        noise: f64,
        /// The sample cap.
        max_samples: u32,
    },
}

/// The seed of pass `pass` of a progressive render seeded with `seed` (a SplitMix64 step, so
/// passes are independent streams).
pub fn pass_seed(seed: u64, pass: u32) -> u64 {
    if pass == 0 {
        return seed;
    }
    let mut z = seed.wrapping_add(u64::from(pass).wrapping_mul(0x9e37_79b9_7f4a_7c15));
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// The noise of the mean of two independent half-sample images `a` and `b`:
/// `tonemapped_mse(a, b) / 4` (module documentation).
pub fn half_sample_noise(a: &Image, b: &Image) -> f64 {
    tonemapped_mse(a, b) / 4.0
}

/// Running sums of the two halves of a progressive estimate, value by value (pixels or rays).
#[derive(Clone, Debug, PartialEq)]
pub struct HalfSums {
    sums: [Vec<Vec3>; 2],
    passes: u32,
}

impl HalfSums {
    /// Empty sums over `len` values.
    pub fn new(len: usize) -> HalfSums {
        HalfSums {
            sums: [vec![Vec3::ZERO; len], vec![Vec3::ZERO; len]],
            passes: 0,
        }
    }

    /// Adds pass number [`Self::passes`] (even passes to the first half, odd to the second).
    pub fn add(&mut self, values: &[Vec3]) {
        let half = &mut self.sums[(self.passes % 2) as usize];
        for (s, v) in half.iter_mut().zip(values) {
            *s += *v;
        }
        self.passes += 1;
    }

    /// Passes added.
    pub fn passes(&self) -> u32 {
        self.passes
    }

    /// The mean of one half (0 or 1).
    pub fn half_mean(&self, half: usize) -> Vec<Vec3> {
        let n = self.passes / 2 + u32::from(half == 0 && self.passes % 2 == 1);
        let scale = 1.0 / n.max(1) as f32;
        self.sums[half].iter().map(|s| *s * scale).collect()
    }

    /// The mean over every pass.
    pub fn mean(&self) -> Vec<Vec3> {
        let scale = 1.0 / self.passes.max(1) as f32;
        self.sums[0]
            .iter()
            .zip(&self.sums[1])
            .map(|(a, b)| (*a + *b) * scale)
            .collect()
    }
}

fn image_of(width: u32, height: u32, values: &[Vec3]) -> Image {
    let mut image = Image::new(width, height);
    for (p, v) in image.rgb.iter_mut().zip(values) {
        *p = v.to_array();
    }
    image
}

fn pixels(image: &Image) -> Vec<Vec3> {
    image.rgb.iter().map(|p| Vec3::from_array(*p)).collect()
}

/// Renders `settings` progressively with [`probe_capture::render`]: passes of `pass_samples`
/// samples per pixel (`settings.samples_per_pixel` is replaced; at least 1), two to start, then
/// doubling until `target` is met. Returns the full-sample mean image and how far it went.
///
/// # Errors
/// [`EvalError::Render`] for bad settings; [`EvalError::Config`] for a target that is not a
/// positive finite number or a sample count below 2.
pub fn render_converged(
    scene: &Scene,
    camera: &Camera,
    settings: &RenderSettings,
    target: NoiseTarget,
    progress: Progress<'_>,
) -> Result<(Image, ReferenceNoise), EvalError> {
    let invalid = |reason: String| EvalError::Config { path: None, reason };
    let (pass_samples, max_passes, noise_target) = match target {
        NoiseTarget::Samples(samples) => {
            if samples < 2 {
                return Err(invalid(format!(
                    "samples {samples}: a progressive reference needs at least 2 (two halves)"
                )));
            }
            // Two halves of half the samples (an odd count rounds up).
            (samples.div_ceil(2), 2, None)
        }
        NoiseTarget::Noise { noise, max_samples } => {
            if !(noise.is_finite() && noise > 0.0) {
                return Err(invalid(format!(
                    "noise target {noise}: give a positive tone-mapped variance such as 1e-5"
                )));
            }
            let pass = settings.samples_per_pixel.max(1);
            (pass, (max_samples / pass).max(2), Some(noise))
        }
    };
    let mut pass_settings = *settings;
    pass_settings.samples_per_pixel = pass_samples;
    let (width, height) = (settings.width, settings.height);
    let mut sums = HalfSums::new((width * height) as usize);
    let mut noise = f64::INFINITY;
    let mut round_end = 2;
    while sums.passes() < max_passes {
        while sums.passes() < round_end.min(max_passes) {
            pass_settings.seed = pass_seed(settings.seed, sums.passes());
            let image = render(scene, camera, &pass_settings, progress)?;
            sums.add(&pixels(&image));
        }
        noise = half_sample_noise(
            &image_of(width, height, &sums.half_mean(0)),
            &image_of(width, height, &sums.half_mean(1)),
        );
        if noise_target.is_none_or(|t| noise <= t) {
            break;
        }
        round_end *= 2;
    }
    Ok((
        image_of(width, height, &sums.mean()),
        ReferenceNoise {
            samples: sums.passes() * pass_samples,
            passes: sums.passes(),
            noise,
            target: noise_target,
            converged: noise_target.is_some_and(|t| noise <= t),
        },
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use probe_capture::{Component, no_progress};

    fn settings() -> RenderSettings {
        let mut s = RenderSettings::new(24, 24);
        s.component = Component::Direct;
        s.samples_per_pixel = 2;
        s
    }

    /// The progressive render stops as soon as its estimate is below the target, the estimate
    /// agrees with an independent measurement of the noise, and the same seed gives the same
    /// image.
    #[test]
    fn progressive_reference_stops_below_target_and_is_deterministic() {
        let scene = Scene::builtin("cornell").unwrap();
        // The default camera looking down at the boxes and the floor, the light out of view:
        // pixels on the edge of the 17-unit emitter are heavy-tailed (a few jittered rays meet
        // it), which no estimate from a few passes predicts, and they would be most of the
        // noise (BENCHMARKS.md, "Light samples with partners").
        let default = scene.default_camera();
        let camera = Camera::look_at(
            default.position,
            Vec3::new(0.278, 0.0, 0.28),
            Vec3::Y,
            default.yfov * 0.6,
        );
        let (_, coarse) = render_converged(
            &scene,
            &camera,
            &settings(),
            NoiseTarget::Samples(4),
            &no_progress,
        )
        .unwrap();
        assert_eq!((coarse.samples, coarse.passes), (4, 2));
        assert!(coarse.noise > 0.0);
        let target = coarse.noise / 6.0;
        let run = || {
            render_converged(
                &scene,
                &camera,
                &settings(),
                NoiseTarget::Noise {
                    noise: target,
                    max_samples: 1 << 12,
                },
                &no_progress,
            )
            .unwrap()
        };
        let (image, noise) = run();
        assert!(noise.converged, "{noise:?}");
        assert!(noise.noise <= target);
        // Doubling from 2 passes: 6× less noise needs 8× the samples, not fewer.
        assert!(
            noise.passes >= 8 && noise.passes.is_power_of_two(),
            "{noise:?}"
        );
        // One round fewer would not have met the target (it stopped at the first success).
        let (_, fewer) = render_converged(
            &scene,
            &camera,
            &settings(),
            NoiseTarget::Samples(noise.samples / 2),
            &no_progress,
        )
        .unwrap();
        assert!(fewer.noise > target, "{fewer:?} vs target {target}");
        let (again, noise_again) = run();
        assert_eq!(image, again);
        assert_eq!(noise, noise_again);
        // The estimate is the noise: independent renders with other seeds differ from this one
        // by about the two noises together (each of the seven).
        for seed in 1..=7u64 {
            let mut other = settings();
            other.seed = 12_345 + seed;
            let (independent, other_noise) = render_converged(
                &scene,
                &camera,
                &other,
                NoiseTarget::Samples(noise.samples),
                &no_progress,
            )
            .unwrap();
            let measured = tonemapped_mse(&image, &independent);
            let predicted = noise.noise + other_noise.noise;
            assert!(
                measured > predicted / 2.0 && measured < predicted * 2.0,
                "seed {}: measured {measured} predicted {predicted}",
                other.seed
            );
        }
    }

    #[test]
    fn bad_targets_are_refused() {
        let scene = Scene::builtin("cornell").unwrap();
        let camera = scene.default_camera();
        for target in [
            NoiseTarget::Samples(1),
            NoiseTarget::Noise {
                noise: 0.0,
                max_samples: 64,
            },
            NoiseTarget::Noise {
                noise: f64::NAN,
                max_samples: 64,
            },
        ] {
            assert!(matches!(
                render_converged(&scene, &camera, &settings(), target, &no_progress),
                Err(EvalError::Config { .. })
            ));
        }
    }
}
