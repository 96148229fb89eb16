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
}

/// The size of the answering probe's texel at the true hit: the texel's angular size (a sphere
/// of 4π cut into `resolution²` texels) times the distance, over the cosine of incidence
/// (at least 0.2). 0 when no probe answered.
pub fn texel_footprint(baked: &ProbeBake, probe: Option<u32>, hit: &Hit) -> f32 {
    let texel_angle = 2.0 * std::f32::consts::PI.sqrt() / baked.resolution() as f32;
    probe.map_or(0.0, |p| {
        let to_hit = hit.position - baked.positions()[p as usize];
        let distance = to_hit.length();
        let cosine = if distance > 0.0 {
            hit.geometric_normal.dot(to_hit / distance).abs().max(0.2)
        } else {
            1.0
        };
        distance * texel_angle / cosine
    })
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
                let footprint = texel_footprint(baked, result.probe, hit);
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
