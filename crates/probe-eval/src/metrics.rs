//! What a trace measured against the reference: ray by ray (status, hit position within a
//! probe texel's footprint, radiance) and image by image (MSE, tone-mapped MSE, relative MSE,
//! PSNR). BRIEF, "How quality is measured".

use probe_capture::{Image, ProbeBake, ReferenceSample};
use probe_scene::Hit;
use probe_trace_gpu::{RayResult, RayStatus};
use serde::Serialize;

use crate::pipeline::{Selection, Tracer};

/// What one trace of a view's rays through one probe set measured.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TraceMetrics {
    /// The tracer.
    pub tracer: Tracer,
    /// The selection.
    pub selection: Selection,
    /// Rays traced.
    pub rays: usize,
    /// Milliseconds on the device (GPU timestamps when available, else wall-clock of the call).
    pub trace_ms: f64,
    /// Wall-clock milliseconds of the call (ray upload, dispatch, read-back).
    pub wall_ms: f64,
    /// Whether `trace_ms` comes from GPU timestamps.
    pub gpu_timestamps: bool,
    /// Mean texel fetches per ray.
    pub fetches_per_ray: f64,
    /// Mean probes tried per ray.
    pub probes_per_ray: f64,
    /// Share of rays answered HIT.
    pub hit_rate: f64,
    /// Share of rays answered UNKNOWN (fallback radiance).
    pub unknown_rate: f64,
    /// Share of rays whose status agrees with the BVH (HIT where it hits, MISS where it misses).
    pub status_agreement: f64,
    /// Of the rays both call hits, the share whose hit lies within one probe texel footprint of
    /// the true hit (footprint: the texel's size at the answering probe's distance, widened for
    /// obliquity up to 5×).
    pub within_footprint: f64,
    /// Mean distance between the probe hit and the true hit over rays both call hits (metres).
    pub mean_position_error: f64,
    /// Mean squared radiance error per ray (RGB mean), before weighting into pixels.
    pub ray_mse: f64,
    /// Mean squared error of the glossy image against the reference image.
    pub mse: f64,
    /// Mean squared error after mapping both images' channels by `x / (1 + x)` (Reinhard).
    /// HDR MSE is dominated by the few pixels that reflect an emitter (radiance 17 in the
    /// Cornell box: one such pixel of 12,288 adds 0.02), so it jumps between runs that differ in
    /// a pixel or two; this one weighs every pixel alike. The headline figures use it.
    pub mse_tonemapped: f64,
    /// MSE divided by the reference image's mean squared value (comparable across scenes).
    pub relative_mse: f64,
    /// PSNR in dB against the reference's peak.
    pub psnr: f64,
    /// Mean LDR-FLIP against the reference ([`flip`]; 0 = indistinguishable, 1 = most
    /// different).
    pub flip: f64,
    /// The reference's noise floor: the estimated tone-mapped variance of the reference image
    /// ([`crate::convergence`]). An error near it is the reference's noise, not the probes'.
    pub reference_noise: f64,
    /// The bake's noise floor: the tone-mapped variance of this traced image due to the bake's
    /// Monte Carlo noise, when measured (two bakes with different seeds: half their images'
    /// tone-mapped MSE); `None` when not measured. (A bake's own figure,
    /// [`probe_capture::ProbeBake::noise`], is a mean over its texels, not over what an
    /// image reads.)
    pub bake_noise: Option<f64>,
    /// The tone-mapped MSE of the same trace through that second bake, when measured: the
    /// figure `mse_tonemapped` would have been with another seed.
    pub second_bake_mse_tonemapped: Option<f64>,
    /// Each pixel class's share of the pixels and of `mse_tonemapped` ([`classify_pixels`]).
    pub classes: Vec<ClassShare>,
}

/// What the texel footprint of a hit needs from a bake: its resolution and probe positions
/// (so a comparison can be redone after the bake itself is dropped).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Footprints<'a> {
    /// Interior texels per side.
    pub resolution: u32,
    /// Probe positions.
    pub positions: &'a [glam::Vec3],
}

impl<'a> Footprints<'a> {
    /// A bake's.
    pub fn of(baked: &'a ProbeBake) -> Footprints<'a> {
        Footprints {
            resolution: baked.resolution(),
            positions: baked.positions(),
        }
    }

    /// [`texel_footprint`] ([`EXACT_HIT_TOLERANCE`] for no probe or one out of range: an
    /// answer no probe gave is right only where it is the exact hit, up to rounding).
    pub fn at(&self, probe: Option<u32>, hit: &Hit) -> f32 {
        let texel_angle = 2.0 * std::f32::consts::PI.sqrt() / self.resolution.max(1) as f32;
        probe
            .and_then(|p| self.positions.get(p as usize))
            .map_or(EXACT_HIT_TOLERANCE, |position| {
                let to_hit = hit.position - *position;
                let distance = to_hit.length();
                let cosine = if distance > 0.0 {
                    hit.geometric_normal.dot(to_hit / distance).abs().max(0.2)
                } else {
                    1.0
                };
                distance * texel_angle / cosine
            })
    }
}

/// How far apart two casts of one ray against the BVH may put its hit (metres): the
/// position an answer without a probe (the shaded BVH hits) must match.
pub const EXACT_HIT_TOLERANCE: f32 = 1e-4;

/// The size of the answering probe's texel at the true hit: the texel's angular size (a sphere
/// of 4π cut into `resolution²` texels) times the distance, over the cosine of incidence
/// (at least 0.2). [`EXACT_HIT_TOLERANCE`] when no probe answered.
pub fn texel_footprint(baked: &ProbeBake, probe: Option<u32>, hit: &Hit) -> f32 {
    Footprints::of(baked).at(probe, hit)
}

/// The mean squared channel value of an image (its "power": what relative MSE divides by).
pub fn mean_square(image: &Image) -> f64 {
    image
        .rgb
        .iter()
        .map(|p| p.iter().map(|v| f64::from(*v).powi(2)).sum::<f64>() / 3.0)
        .sum::<f64>()
        / image.rgb.len().max(1) as f64
}

/// MSE of two same-sized images after `x / (1 + x)` per channel (negative values clamp to 0).
pub fn tonemapped_mse(image: &Image, reference: &Image) -> f64 {
    let map = |v: f32| {
        let v = f64::from(v.max(0.0));
        v / (1.0 + v)
    };
    let sum: f64 = image
        .rgb
        .iter()
        .zip(&reference.rgb)
        .map(|(a, b)| (0..3).map(|k| (map(a[k]) - map(b[k])).powi(2)).sum::<f64>())
        .sum();
    sum / (3 * image.rgb.len().max(1)) as f64
}

/// Ray-by-ray agreement of a trace with the BVH reference (the ray-level fields of
/// [`TraceMetrics`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayComparison {
    /// Share of rays whose status agrees with the BVH.
    pub status_agreement: f64,
    /// Of the rays both call hits, the share within one probe texel footprint of the true hit.
    pub within_footprint: f64,
    /// Mean distance between probe hit and true hit over rays both call hits (metres).
    pub mean_position_error: f64,
    /// Mean squared radiance error per ray (RGB mean).
    pub ray_mse: f64,
}

/// Compares traced `results` with the `reference` ray by ray (one entry each, same order);
/// footprints are those of `baked`'s probes ([`texel_footprint`]).
pub fn compare_rays(
    baked: &ProbeBake,
    reference: &[ReferenceSample],
    results: &[RayResult],
) -> RayComparison {
    compare_rays_with(Footprints::of(baked), reference, results)
}

/// [`compare_rays`] with the footprints given directly.
pub fn compare_rays_with(
    footprints: Footprints<'_>,
    reference: &[ReferenceSample],
    results: &[RayResult],
) -> RayComparison {
    // The angular size of a texel of mean solid angle 4π/N².
    let (mut agree, mut both, mut within, mut error_sum, mut se) =
        (0usize, 0usize, 0usize, 0.0f64, 0.0f64);
    for (truth, result) in reference.iter().zip(results) {
        let d = result.radiance - truth.radiance;
        se += f64::from(d.length_squared()) / 3.0;
        match (&truth.hit, result.status) {
            (Some(hit), RayStatus::Hit) => {
                agree += 1;
                both += 1;
                let error = (result.position - hit.position).length();
                error_sum += f64::from(error);
                let footprint = footprints.at(result.probe, hit);
                within += usize::from(error <= footprint);
            }
            (None, RayStatus::Miss) => agree += 1,
            _ => {}
        }
    }
    let n = results.len().max(1) as f64;
    RayComparison {
        status_agreement: agree as f64 / n,
        within_footprint: within as f64 / both.max(1) as f64,
        mean_position_error: error_sum / both.max(1) as f64,
        ray_mse: se / n,
    }
}

/// What went right or wrong at one pixel of a traced image: an exhaustive classification by
/// the pixel's main ray (its largest weight) against the BVH's answer.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum PixelClass {
    /// HIT within the answering probe's texel footprint of the true hit ([`texel_footprint`])
    /// and radiance within [`RADIANCE_TOLERANCE`] of the reference.
    CorrectHit,
    /// HIT on the right surface (within the footprint) but radiance off by more than
    /// [`RADIANCE_TOLERANCE`]: the probes' radiance, not their geometry, is wrong.
    RadianceError,
    /// HIT where the true hit is farther than one texel footprint away (another surface).
    WrongHit,
    /// HIT where the ray truly leaves the scene.
    FalseHit,
    /// MISS where the ray truly hits a surface.
    WrongMiss,
    /// MISS where the ray truly leaves the scene.
    CorrectMiss,
    /// UNKNOWN: no probe could finish the ray (seed 003's fallback radiance).
    Unknown,
    /// No evaluation ray (the camera sees no surface there): both images are 0.
    NoRay,
}

impl PixelClass {
    /// Every class, in table order.
    pub const ALL: [PixelClass; 8] = [
        PixelClass::CorrectHit,
        PixelClass::RadianceError,
        PixelClass::WrongHit,
        PixelClass::FalseHit,
        PixelClass::WrongMiss,
        PixelClass::CorrectMiss,
        PixelClass::Unknown,
        PixelClass::NoRay,
    ];

    /// The name used in reports.
    pub fn name(self) -> &'static str {
        match self {
            PixelClass::CorrectHit => "correct hit",
            PixelClass::RadianceError => "radiance-only error",
            PixelClass::WrongHit => "wrong hit",
            PixelClass::FalseHit => "hit on a miss",
            PixelClass::WrongMiss => "wrong miss",
            PixelClass::CorrectMiss => "correct miss",
            PixelClass::Unknown => "unknown (fallback)",
            PixelClass::NoRay => "no ray",
        }
    }

    /// The class's colour in the error-class image (linear RGB in 0..1; written with
    /// exposure 1, so a colour shows as its sRGB encoding).
    pub fn colour(self) -> [f32; 3] {
        match self {
            PixelClass::CorrectHit => [0.0, 0.35, 0.0],
            PixelClass::RadianceError => [1.0, 0.8, 0.0],
            PixelClass::WrongHit => [1.0, 0.0, 0.0],
            PixelClass::FalseHit => [1.0, 0.0, 1.0],
            PixelClass::WrongMiss => [0.0, 0.8, 1.0],
            PixelClass::CorrectMiss => [0.0, 0.0, 0.5],
            PixelClass::Unknown => [1.0, 1.0, 1.0],
            PixelClass::NoRay => [0.0, 0.0, 0.0],
        }
    }

    /// The colour's name, for legends.
    pub fn colour_name(self) -> &'static str {
        match self {
            PixelClass::CorrectHit => "green",
            PixelClass::RadianceError => "yellow",
            PixelClass::WrongHit => "red",
            PixelClass::FalseHit => "magenta",
            PixelClass::WrongMiss => "cyan",
            PixelClass::CorrectMiss => "blue",
            PixelClass::Unknown => "white",
            PixelClass::NoRay => "black",
        }
    }
}

/// The largest per-channel difference of tone-mapped (`x / (1 + x)`) radiance at which a hit
/// on the right surface still counts as a [`PixelClass::CorrectHit`] (about 13 of 255 levels).
pub const RADIANCE_TOLERANCE: f64 = 0.05;

/// One class's part of an image: its share of the pixels and of the tone-mapped MSE.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ClassShare {
    /// The class.
    pub class: PixelClass,
    /// Share of the image's pixels.
    pub pixels: f64,
    /// Share of the image's tone-mapped MSE (the shares sum to 1 unless the MSE is 0, when
    /// all are 0).
    pub mse: f64,
}

/// A traced image's pixels by class ([`classify_pixels`]).
#[derive(Clone, Debug, PartialEq)]
pub struct PixelClasses {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// One class per pixel, row by row.
    pub classes: Vec<PixelClass>,
}

fn tone(v: f32) -> f64 {
    let v = f64::from(v.max(0.0));
    v / (1.0 + v)
}

/// Classifies each pixel of a traced image by its main ray (the ray of largest weight; ties:
/// the first): `rays` are the view's evaluation rays, `reference` and `results` one entry per
/// ray, `image` and `reference_image` the traced and reference images the rays make. Radiance
/// is compared per pixel (tone-mapped, [`RADIANCE_TOLERANCE`]).
pub fn classify_pixels(
    footprints: Footprints<'_>,
    rays: &[probe_capture::EvaluationRay],
    reference: &[ReferenceSample],
    results: &[RayResult],
    image: &Image,
    reference_image: &Image,
) -> PixelClasses {
    let pixels = image.rgb.len();
    let mut main: Vec<Option<(usize, f32)>> = vec![None; pixels];
    for (i, ray) in rays.iter().enumerate() {
        if let Some(slot) = main.get_mut(ray.pixel as usize)
            && slot.is_none_or(|(_, w)| ray.weight > w)
        {
            *slot = Some((i, ray.weight));
        }
    }
    let classes = main
        .iter()
        .enumerate()
        .map(|(pixel, main)| {
            let Some((i, _)) = *main else {
                return PixelClass::NoRay;
            };
            let (Some(truth), Some(result)) = (reference.get(i), results.get(i)) else {
                return PixelClass::NoRay;
            };
            match (&truth.hit, result.status) {
                (_, RayStatus::Unknown) => PixelClass::Unknown,
                (None, RayStatus::Miss) => PixelClass::CorrectMiss,
                (Some(_), RayStatus::Miss) => PixelClass::WrongMiss,
                (None, RayStatus::Hit) => PixelClass::FalseHit,
                (Some(hit), RayStatus::Hit) => {
                    let error = (result.position - hit.position).length();
                    if error > footprints.at(result.probe, hit) {
                        PixelClass::WrongHit
                    } else {
                        let (a, b) = (image.rgb[pixel], reference_image.rgb[pixel]);
                        let off = (0..3)
                            .map(|k| (tone(a[k]) - tone(b[k])).abs())
                            .fold(0.0, f64::max);
                        if off > RADIANCE_TOLERANCE {
                            PixelClass::RadianceError
                        } else {
                            PixelClass::CorrectHit
                        }
                    }
                }
            }
        })
        .collect();
    PixelClasses {
        width: image.width,
        height: image.height,
        classes,
    }
}

impl PixelClasses {
    /// Each class's share of the pixels and of the tone-mapped MSE of `image` against
    /// `reference` ([`tonemapped_mse`] split by pixel), in [`PixelClass::ALL`] order.
    pub fn shares(&self, image: &Image, reference: &Image) -> Vec<ClassShare> {
        let mut count = [0usize; PixelClass::ALL.len()];
        let mut error = [0.0f64; PixelClass::ALL.len()];
        for ((class, a), b) in self.classes.iter().zip(&image.rgb).zip(&reference.rgb) {
            let k = PixelClass::ALL.iter().position(|c| c == class).unwrap_or(0);
            count[k] += 1;
            error[k] += (0..3)
                .map(|c| (tone(a[c]) - tone(b[c])).powi(2))
                .sum::<f64>();
        }
        let pixels = self.classes.len().max(1) as f64;
        let total: f64 = error.iter().sum();
        PixelClass::ALL
            .iter()
            .enumerate()
            .map(|(k, &class)| ClassShare {
                class,
                pixels: count[k] as f64 / pixels,
                mse: if total > 0.0 { error[k] / total } else { 0.0 },
            })
            .collect()
    }

    /// The error-class image: each pixel its class's [`PixelClass::colour`].
    pub fn image(&self) -> Image {
        let mut out = Image::new(self.width, self.height);
        for (o, class) in out.rgb.iter_mut().zip(&self.classes) {
            *o = class.colour();
        }
        out
    }
}

/// An image as FLIP reads it: each channel tone-mapped by `x / (1 + x)` (the headline MSE's
/// map) and sRGB-encoded to 8 bits.
fn flip_rgb8(image: &Image) -> Vec<u8> {
    image
        .rgb
        .iter()
        .flat_map(|p| {
            p.map(|v| {
                let v = tone(v);
                let s = if v <= 0.003_130_8 {
                    12.92 * v
                } else {
                    1.055 * v.powf(1.0 / 2.4) - 0.055
                };
                (s * 255.0).round().clamp(0.0, 255.0) as u8
            })
        })
        .collect()
}

/// NVIDIA's LDR-FLIP (Andersson et al. 2020, through the `nv-flip` crate) of `image` against
/// `reference`, both tone-mapped by `x / (1 + x)` and sRGB-encoded first, at the default
/// 67 pixels per degree (a 0.7 m wide 4K monitor seen from 0.7 m). Returns the per-pixel FLIP
/// error (0 = indistinguishable, 1 = most different), row by row, and its mean.
///
/// # Errors
/// [`crate::EvalError::Image`] when the sizes differ.
pub fn flip(image: &Image, reference: &Image) -> Result<(Vec<f32>, f64), crate::EvalError> {
    // Image::mse checks the sizes and the pixel count.
    image.mse(reference)?;
    let (w, h) = (reference.width, reference.height);
    let test = nv_flip::FlipImageRgb8::with_data(w, h, &flip_rgb8(image));
    let truth = nv_flip::FlipImageRgb8::with_data(w, h, &flip_rgb8(reference));
    let error = nv_flip::flip(truth, test, nv_flip::DEFAULT_PIXELS_PER_DEGREE);
    let values = error.to_vec();
    let mean = values.iter().map(|v| f64::from(*v)).sum::<f64>() / values.len().max(1) as f64;
    Ok((values, mean))
}

/// The FLIP error map as 8-bit RGB (FLIP's magma colour map: black = no error, yellow-white =
/// the most), row by row.
pub fn flip_map_rgb8(width: u32, height: u32, error: &[f32]) -> Vec<u8> {
    nv_flip::FlipImageFloat::with_data(width, height, error)
        .apply_color_lut(&nv_flip::magma_lut())
        .to_vec()
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;
    use probe_capture::{BakeSettings, EvaluationRay, Sampling, bake, no_progress};
    use probe_scene::Scene;

    fn result(status: RayStatus, position: Vec3, radiance: Vec3) -> RayResult {
        RayResult {
            status,
            t: 1.0,
            position,
            normal: Vec3::Y,
            radiance,
            probe: Some(0),
            probes_tried: 1,
            texel_fetches: 1,
        }
    }

    /// A hand-made 2×4 case with one pixel of each class: the classes come out as made, each
    /// has 1/8 of the pixels, the MSE shares sum to 1 and equal each pixel's part.
    #[test]
    fn class_shares_sum_to_one_and_match_a_hand_made_case() {
        let scene = Scene::builtin("cornell").unwrap();
        let probe = scene.bounds().center();
        let settings = BakeSettings {
            resolution: 8,
            sampling: Sampling::fixed(1),
            ..BakeSettings::default()
        };
        let baked = bake(&scene, &[probe], &settings, &no_progress).unwrap();
        // A true hit 1 m from the probe: the footprint is 2√π/8 ≈ 0.44 m or more.
        let hit = scene
            .closest_hit(&probe_scene::Ray::new(probe, Vec3::NEG_Y), f32::INFINITY)
            .unwrap();
        let at = hit.position;
        let far = at + Vec3::new(0.0, 0.0, 5.0);
        let radiance = Vec3::splat(0.5);
        // (truth hit?, status, position, traced radiance) per ray; pixel 7 has no ray.
        let cases = [
            (true, RayStatus::Hit, at, radiance),              // correct hit
            (true, RayStatus::Hit, at, Vec3::splat(2.0)),      // radiance-only error
            (true, RayStatus::Hit, far, Vec3::splat(0.3)),     // wrong hit
            (false, RayStatus::Hit, at, Vec3::splat(0.1)),     // hit on a miss
            (true, RayStatus::Miss, Vec3::ZERO, Vec3::ZERO),   // wrong miss
            (false, RayStatus::Miss, Vec3::ZERO, radiance),    // correct miss
            (true, RayStatus::Unknown, Vec3::ZERO, Vec3::ONE), // unknown
        ];
        let rays: Vec<EvaluationRay> = (0..cases.len() as u32)
            .map(|pixel| EvaluationRay {
                pixel,
                origin: probe,
                direction: Vec3::NEG_Y,
                weight: 1.0,
            })
            .collect();
        let reference: Vec<ReferenceSample> = cases
            .iter()
            .map(|c| ReferenceSample {
                hit: c.0.then_some(hit),
                radiance,
            })
            .collect();
        let results: Vec<RayResult> = cases.iter().map(|c| result(c.1, c.2, c.3)).collect();
        let mut image = Image::new(2, 4);
        let mut truth = Image::new(2, 4);
        for (i, c) in cases.iter().enumerate() {
            image.rgb[i] = c.3.to_array();
            truth.rgb[i] = radiance.to_array();
        }
        let classes = classify_pixels(
            Footprints::of(&baked),
            &rays,
            &reference,
            &results,
            &image,
            &truth,
        );
        assert_eq!(&classes.classes[..], &PixelClass::ALL[..]);
        let shares = classes.shares(&image, &truth);
        let total_mse: f64 = shares.iter().map(|s| s.mse).sum();
        assert!((total_mse - 1.0).abs() < 1e-12);
        assert!(shares.iter().all(|s| (s.pixels - 0.125).abs() < 1e-12));
        let mse = tonemapped_mse(&image, &truth);
        for (i, share) in shares.iter().enumerate() {
            let own: f64 = (0..3)
                .map(|k| (tone(image.rgb[i][k]) - tone(truth.rgb[i][k])).powi(2))
                .sum::<f64>()
                / 24.0;
            assert!((share.mse * mse - own).abs() < 1e-12, "{share:?}");
        }
        assert_eq!(shares[0].mse, 0.0);
        assert_eq!(shares[7].mse, 0.0);
        assert_eq!(classes.image().rgb[2], PixelClass::WrongHit.colour());
    }

    /// FLIP of an image with itself is 0; of known pairs it is what NVIDIA's reference
    /// implementation (the C++ FLIP that `nv-flip` builds) gives, and a small change scores
    /// low but above 0, more for a larger change.
    #[test]
    fn flip_is_zero_for_identical_images_and_matches_known_pairs() {
        let mut a = Image::new(32, 32);
        for (i, p) in a.rgb.iter_mut().enumerate() {
            let v = (i % 32) as f32 / 8.0;
            *p = [v, 0.5 * v, 0.25];
        }
        let (map, mean) = flip(&a, &a).unwrap();
        assert_eq!(mean, 0.0);
        assert!(map.iter().all(|v| *v == 0.0));
        let mut black = Image::new(32, 32);
        let mut white = Image::new(32, 32);
        for p in &mut black.rgb {
            *p = [0.0; 3];
        }
        for p in &mut white.rgb {
            *p = [1e9; 3];
        }
        // Uniform black vs uniform white (sRGB 0 vs 255): no features, so FLIP is the colour
        // term alone; HyAB(black, white) = 100 against the largest difference (green–blue)
        // maps to 0.9674 in the reference implementation on 32×32 uniform images.
        let (_, black_white) = flip(&white, &black).unwrap();
        assert!((black_white - 0.9674).abs() < 1e-3, "{black_white}");
        let mut small = a.clone();
        let mut large = a.clone();
        for (s, l) in small.rgb.iter_mut().zip(&mut large.rgb) {
            s[0] *= 1.05;
            l[0] *= 1.5;
        }
        let (_, small_mean) = flip(&small, &a).unwrap();
        let (_, large_mean) = flip(&large, &a).unwrap();
        assert!(small_mean > 0.0 && small_mean < large_mean && large_mean < 1.0);
        assert!(flip(&Image::new(2, 2), &a).is_err());
    }
}
