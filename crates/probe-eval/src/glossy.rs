//! Filtered glossy reflections (issue 14, item 2): one cone ray per pixel instead of many GGX
//! samples. The ray leaves along the mean of the GGX lobe; the tracer reads its radiance from
//! the probes' prefiltered levels ([`probe_trace_gpu::TraceOptions::glossy_roughness`]); the
//! pixel weighs it with the lobe's mean weight, what [`probe_capture::reflection_rays`]' GGX
//! samples (Smith's `G1` under visible-normal sampling, Fresnel 1) average to, which
//! [`probe_capture::ggx_lobe_mean`] integrates by a fixed quadrature (no noise).

use probe_capture::{EvaluationRay, GBuffer, RenderError};
use rayon::prelude::*;

/// Prefiltered glossy levels a filtered trace uploads
/// ([`probe_trace_gpu::FieldOptions::glossy_levels`]; down to 2×2 at 128²).
pub const GLOSSY_LEVELS: u32 = 6;

/// One filtered reflection ray per G-buffer pixel that hits a front face (or a double-sided
/// surface), along the mean of the GGX lobe the stochastic rays sample and weighted by their
/// mean weight ([`probe_capture::ggx_lobe_mean`]: a fixed 64-point quadrature per pixel that
/// leaves out directions below the shading or the geometric surface, as
/// [`probe_capture::reflection_rays`] does). Trace them with
/// `TraceOptions::glossy_roughness = roughness` through a field uploaded with glossy levels
/// and accumulate as [`probe_capture::accumulate_rays`] does. Pixels whose whole lobe falls
/// below the surface get no ray.
///
/// The mean, not the mirror direction: where the surface cuts the lobe (grazing views, normal
/// maps tilting the shading normal) the mirror ray skims the surface and often ends on the
/// wrong thing, while the lobe's visible part points higher (Sponza at roughness 0.3: 3.60e-3
/// with the mirror direction and the view-cosine albedo, 2.92e-3 with the mean; BENCHMARKS.md,
/// "Filtered glossy").
///
/// # Errors
/// [`RenderError::InvalidSetting`] for a `roughness` outside `(0, 1]`.
pub fn filtered_reflection_rays(
    gbuffer: &GBuffer,
    roughness: f32,
) -> Result<Vec<EvaluationRay>, RenderError> {
    sub_lobe_rays(gbuffer, roughness, 1)
}

/// `sectors` filtered rays per pixel (1 to 8; 1 is [`filtered_reflection_rays`]): the GGX lobe
/// cut by azimuth into parts ([`probe_capture::ggx_sub_lobes`]), one ray along each part's
/// mean weighted by its share. Trace them with `TraceOptions::glossy_roughness =`
/// [`sub_lobe_roughness`]`(roughness, sectors)`, the cone of a part. A speed–accuracy knob
/// between one cone per pixel and many stochastic rays: two sectors halve the lobe along the
/// plane of incidence, where a grazing view stretches it.
///
/// # Errors
/// [`RenderError::InvalidSetting`] for a `roughness` outside `(0, 1]` or `sectors` outside
/// 1 to 8.
pub fn sub_lobe_rays(
    gbuffer: &GBuffer,
    roughness: f32,
    sectors: u32,
) -> Result<Vec<EvaluationRay>, RenderError> {
    if !(roughness > 0.0 && roughness <= 1.0) {
        return Err(RenderError::InvalidSetting {
            parameter: "roughness",
            value: roughness.to_string(),
            reason: "must lie in (0, 1]",
        });
    }
    if !(1..=probe_capture::MAX_LOBE_SECTORS).contains(&sectors) {
        return Err(RenderError::InvalidSetting {
            parameter: "sectors",
            value: sectors.to_string(),
            reason: "must be from 1 to 8 (rays per pixel)",
        });
    }
    Ok(gbuffer
        .pixels
        .par_iter()
        .enumerate()
        .with_min_len(64)
        .flat_map_iter(|(pixel, sample)| {
            let lobes = match sample.filter(|s| !s.back_face) {
                Some(s) => probe_capture::ggx_sub_lobes(
                    s.towards_camera,
                    s.shading_normal,
                    s.geometric_normal,
                    roughness,
                    sectors,
                )
                .into_iter()
                .map(|(direction, weight)| EvaluationRay::leaving(pixel, &s, direction, weight))
                .collect(),
                None => Vec::new(),
            };
            lobes.into_iter()
        })
        .collect())
}

pub use probe_capture::sub_lobe_roughness;

#[cfg(test)]
mod tests {
    use super::*;
    use probe_capture::{Reflection, reflection_rays, render_gbuffer};
    use probe_scene::Scene;

    /// The quadrature albedo is the mean weight of many GGX samples of the same pixels.
    #[test]
    fn albedo_is_the_mean_sample_weight() {
        let scene = Scene::open("builtin:cornell").unwrap();
        let camera = scene.default_camera();
        let gbuffer = render_gbuffer(&scene, &camera, 24, 24).unwrap();
        for roughness in [0.1, 0.3, 0.6] {
            let filtered = filtered_reflection_rays(&gbuffer, roughness).unwrap();
            let sampled = reflection_rays(&gbuffer, Reflection::Ggx { roughness }, 256, 3).unwrap();
            let total =
                |rays: &[EvaluationRay]| rays.iter().map(|r| f64::from(r.weight)).sum::<f64>();
            let (a, b) = (total(&filtered), total(&sampled));
            assert!(
                (a - b).abs() < 0.01 * b,
                "roughness {roughness}: {a} vs {b}"
            );
        }
        assert!(filtered_reflection_rays(&gbuffer, 0.0).is_err());
        // A nearly smooth lobe keeps all its weight.
        let view = glam::Vec3::new(0.7, (1.0f32 - 0.49).sqrt(), 0.0);
        let (_, weight) =
            probe_capture::ggx_lobe_mean(view, glam::Vec3::Y, glam::Vec3::Y, 0.01).unwrap();
        assert!((weight - 1.0).abs() < 1e-3, "{weight}");
    }

    /// Sub-lobe rays keep each pixel's weight, one sector is the filtered ray, and each
    /// part's cone is narrower than the lobe's.
    #[test]
    fn sub_lobes_split_the_lobe_and_keep_its_weight() {
        let scene = Scene::open("builtin:cornell").unwrap();
        let gbuffer = render_gbuffer(&scene, &scene.default_camera(), 16, 16).unwrap();
        let filtered = filtered_reflection_rays(&gbuffer, 0.3).unwrap();
        assert_eq!(sub_lobe_rays(&gbuffer, 0.3, 1).unwrap(), filtered);
        let per_pixel = |rays: &[EvaluationRay]| {
            let mut sums = vec![0.0f64; 256];
            for r in rays {
                sums[r.pixel as usize] += f64::from(r.weight);
            }
            sums
        };
        for sectors in [2, 4] {
            let split = sub_lobe_rays(&gbuffer, 0.3, sectors).unwrap();
            assert!(
                split.len() > filtered.len() && split.len() <= sectors as usize * filtered.len()
            );
            for (a, b) in per_pixel(&split).iter().zip(per_pixel(&filtered)) {
                assert!((a - b).abs() < 1e-5, "{a} vs {b}");
            }
            let narrower = sub_lobe_roughness(0.3, sectors);
            assert!(narrower < 0.3 && narrower > 0.0, "{narrower}");
        }
        assert!((sub_lobe_roughness(0.3, 1) - 0.3).abs() < 1e-6);
        assert!(sub_lobe_rays(&gbuffer, 0.3, 0).is_err());
        assert!(sub_lobe_rays(&gbuffer, 0.3, 9).is_err());
    }
}
