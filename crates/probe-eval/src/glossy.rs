//! Filtered glossy reflections (issue 14, item 2): one cone ray per pixel instead of many GGX
//! samples. The ray leaves along the mean of the GGX lobe; the tracer reads its radiance from
//! the probes' prefiltered levels ([`probe_trace_gpu::TraceOptions::glossy_roughness`]); the
//! pixel weighs it with the lobe's mean weight, what [`probe_capture::reflection_rays`]' GGX
//! samples (Smith's `G1` under visible-normal sampling, Fresnel 1) average to, which
//! [`probe_capture::ggx_lobe_mean`] integrates by a fixed quadrature (no noise).

use glam::Vec3;
use probe_capture::{EvaluationRay, GBuffer, Image, RenderError};
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
    check_roughness(roughness)?;
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

/// Sub-lobes traced one per pixel and shared between neighbours ("interleaved", as
/// checkerboard rendering and stochastic screen-space reflections reuse their neighbours'
/// rays): [`sub_lobe_rays`] cuts each pixel's lobe into `sectors` parts, but here each pixel
/// traces only one of them, by a fixed pattern (2 parts: a checkerboard; 4 parts: 2×2 tiles),
/// and [`InterleavedSubLobes::resolve`] takes every other part from the nearest pixels that
/// traced it and see the same surface (normals within 25°, on the pixel's plane within 1 % of
/// its distance from the camera), averaging its own part with theirs. Part `k` of neighbouring pixels covers the same azimuths
/// about their views ([`probe_capture::ggx_sub_lobe_parts`]), so the image has the sub-lobes'
/// narrower cones at one ray per pixel. A part no neighbour can stand in for is left out and
/// the pixel's traced parts are scaled up to its whole weight.
///
/// Trace [`InterleavedSubLobes::rays`] with `TraceOptions::glossy_roughness =`
/// [`sub_lobe_roughness`]`(roughness, sectors)`.
#[derive(Clone, Debug, PartialEq)]
pub struct InterleavedSubLobes {
    width: u32,
    height: u32,
    sectors: u32,
    /// Per pixel and part (`pixel * sectors + k`): the part's share of the lobe's weight,
    /// 0 where the part is empty or the pixel has no front-facing surface.
    shares: Vec<f32>,
    /// Per pixel: the index into `rays` of the ray it traced, if any.
    ray_of_pixel: Vec<Option<u32>>,
    /// Per ray: the part it traces.
    part_of_ray: Vec<u8>,
    rays: Vec<EvaluationRay>,
    /// Per pixel: what the resolve compares between neighbours, for a front-facing surface.
    surfaces: Vec<Option<Surface>>,
}

/// What decides whether two pixels see the same surface.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Surface {
    position: Vec3,
    geometric_normal: Vec3,
    shading_normal: Vec3,
    distance: f32,
}

/// Where a pixel's plane must hold its neighbour, as a share of the pixel's distance from
/// the camera, for the neighbour's part to stand in for its own.
const SAME_PLANE: f32 = 0.01;
/// The least cosine between two pixels' shading normals for one's part to stand in for the
/// other's (25°).
const SAME_NORMAL: f32 = 0.906;
/// A pixel's own ray's weight in its part's mean, against 1 for each neighbour on the same
/// surface that traced the same part (the diagonals of a checkerboard). Chosen on Sponza at
/// roughness 0.3: neighbours left out 2.269e-3; own weight 1, 2, 4, 8: 2.274e-3, 2.221e-3,
/// 2.201e-3, 2.214e-3 (BENCHMARKS.md, "Interleaved sub-lobes"); the neighbours also take the
/// pattern's checkerboard out of the picture.
const OWN_WEIGHT: f32 = 4.0;

impl InterleavedSubLobes {
    /// The rays to trace: at most one per pixel, weighted by its part's share (so that
    /// [`probe_capture::accumulate_rays`] of them is the image of the traced parts alone).
    pub fn rays(&self) -> &[EvaluationRay] {
        &self.rays
    }

    /// Parts each pixel's lobe is cut into.
    pub fn sectors(&self) -> u32 {
        self.sectors
    }

    /// The image from the traced rays' radiance (`radiance[i]` for `rays()[i]`): per pixel,
    /// the sum over its parts of each part's share times its radiance, each part the mean of
    /// the rays of the pixel's 3×3 neighbourhood that traced it and see the same surface,
    /// its own ray weighing 4 against 1 for each neighbour's.
    ///
    /// A `radiance` shorter than `rays()` leaves the pixels of the missing rays' parts to
    /// their neighbours.
    pub fn resolve(&self, radiance: &[Vec3]) -> Image {
        let (w, h, k) = (self.width as i64, self.height as i64, self.sectors as usize);
        let mut image = Image::new(self.width, self.height);
        let traced = |pixel: usize| -> Option<(usize, Vec3)> {
            let ray = self.ray_of_pixel[pixel]? as usize;
            Some((usize::from(self.part_of_ray[ray]), *radiance.get(ray)?))
        };
        image
            .rgb
            .par_iter_mut()
            .enumerate()
            .with_min_len(64)
            .for_each(|(pixel, out)| {
                let Some(s) = self.surfaces[pixel] else {
                    return;
                };
                let shares = &self.shares[pixel * k..(pixel + 1) * k];
                let whole: f32 = shares.iter().sum();
                if whole <= 0.0 {
                    return;
                }
                let (x, y) = (pixel as i64 % w, pixel as i64 / w);
                // Per part: the weighted sum of its rays' radiance and their weight (at most
                // 4 parts).
                let mut sums = [(Vec3::ZERO, 0.0f32); 4];
                if let Some((part, value)) = traced(pixel) {
                    sums[part] = (OWN_WEIGHT * value, OWN_WEIGHT);
                }
                for dy in -1..=1 {
                    for dx in -1..=1 {
                        let (nx, ny) = (x + dx, y + dy);
                        if (dx, dy) == (0, 0) || nx < 0 || ny < 0 || nx >= w || ny >= h {
                            continue;
                        }
                        let neighbour = (ny * w + nx) as usize;
                        let Some((part, value)) = traced(neighbour) else {
                            continue;
                        };
                        let Some(q) = self.surfaces[neighbour] else {
                            continue;
                        };
                        let on_plane = s.geometric_normal.dot(q.position - s.position).abs()
                            <= SAME_PLANE * s.distance;
                        if on_plane && s.shading_normal.dot(q.shading_normal) >= SAME_NORMAL {
                            sums[part].0 += value;
                            sums[part].1 += 1.0;
                        }
                    }
                }
                let (mut value, mut known) = (Vec3::ZERO, 0.0f32);
                for (share, (sum, count)) in shares.iter().zip(&sums) {
                    if *share > 0.0 && *count > 0.0 {
                        value += *share * *sum / *count;
                        known += share;
                    }
                }
                if known > 0.0 {
                    *out = (value * (whole / known)).to_array();
                }
            });
        image
    }
}

/// The part pixel `(x, y)` traces when its lobe is cut into `sectors` parts: a checkerboard
/// for 2, 2×2 tiles for 4.
fn interleaved_part(x: u32, y: u32, sectors: u32) -> u32 {
    match sectors {
        2 => (x + y) % 2,
        _ => x % 2 + 2 * (y % 2),
    }
}

/// Interleaved sub-lobes of every G-buffer pixel with a front-facing surface: its lobe cut
/// into `sectors` (2 or 4) parts, the part its place in the pattern names traced (or, where
/// that part is empty, its first non-empty part after it). See [`InterleavedSubLobes`].
///
/// # Errors
/// [`RenderError::InvalidSetting`] for a `roughness` outside `(0, 1]` or `sectors` other than
/// 2 or 4.
pub fn interleaved_sub_lobe_rays(
    gbuffer: &GBuffer,
    roughness: f32,
    sectors: u32,
) -> Result<InterleavedSubLobes, RenderError> {
    check_roughness(roughness)?;
    if !matches!(sectors, 2 | 4) {
        return Err(RenderError::InvalidSetting {
            parameter: "sectors",
            value: sectors.to_string(),
            reason: "interleaved sub-lobes take 2 (a checkerboard) or 4 (2×2 tiles)",
        });
    }
    let k = sectors as usize;
    let width = gbuffer.width.max(1);
    let parts: Vec<Vec<Option<(Vec3, f32)>>> = gbuffer
        .pixels
        .par_iter()
        .with_min_len(64)
        .map(|sample| match sample.filter(|s| !s.back_face) {
            Some(s) => probe_capture::ggx_sub_lobe_parts(
                s.towards_camera,
                s.shading_normal,
                s.geometric_normal,
                roughness,
                sectors,
            ),
            None => vec![None; k],
        })
        .collect();
    let mut lobes = InterleavedSubLobes {
        width: gbuffer.width,
        height: gbuffer.height,
        sectors,
        shares: Vec::with_capacity(parts.len() * k),
        ray_of_pixel: vec![None; parts.len()],
        part_of_ray: Vec::new(),
        rays: Vec::new(),
        surfaces: Vec::with_capacity(parts.len()),
    };
    for (pixel, pixel_parts) in parts.iter().enumerate() {
        let front = gbuffer.pixels[pixel].filter(|s| !s.back_face);
        lobes.surfaces.push(front.map(|s| Surface {
            position: s.position,
            geometric_normal: s.geometric_normal,
            shading_normal: s.shading_normal,
            distance: s.distance,
        }));
        lobes
            .shares
            .extend(pixel_parts.iter().map(|p| p.map_or(0.0, |(_, w)| w)));
        let (x, y) = (pixel as u32 % width, pixel as u32 / width);
        let first = interleaved_part(x, y, sectors) as usize;
        let chosen = (0..k)
            .map(|i| (first + i) % k)
            .find_map(|part| pixel_parts[part].map(|lobe| (part, lobe)));
        if let (Some((part, (direction, share))), Some(s)) = (chosen, front) {
            lobes.ray_of_pixel[pixel] = Some(lobes.rays.len() as u32);
            lobes.part_of_ray.push(part as u8);
            lobes
                .rays
                .push(EvaluationRay::leaving(pixel, &s, direction, share));
        }
    }
    Ok(lobes)
}

fn check_roughness(roughness: f32) -> Result<(), RenderError> {
    if roughness > 0.0 && roughness <= 1.0 {
        Ok(())
    } else {
        Err(RenderError::InvalidSetting {
            parameter: "roughness",
            value: roughness.to_string(),
            reason: "must lie in (0, 1]",
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use probe_capture::{Reflection, accumulate_rays, reflection_rays, render_gbuffer};
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
        let view = Vec3::new(0.7, (1.0f32 - 0.49).sqrt(), 0.0);
        let (_, weight) = probe_capture::ggx_lobe_mean(view, Vec3::Y, Vec3::Y, 0.01).unwrap();
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
        let per_pixel = |rays: &[EvaluationRay]| weight_per_pixel(rays, 256);
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

    /// Interleaved sub-lobes trace one ray per pixel and, where the light changes smoothly
    /// with direction, resolve to the image of every part traced in every pixel.
    #[test]
    fn interleaved_sub_lobes_resolve_to_every_part_traced() {
        let scene = Scene::open("builtin:cornell").unwrap();
        let (w, h) = (48, 40);
        let gbuffer = render_gbuffer(&scene, &scene.default_camera(), w, h).unwrap();
        let light = |d: Vec3| d * 0.5 + Vec3::splat(0.5);
        let filtered = filtered_reflection_rays(&gbuffer, 0.3).unwrap();
        for sectors in [2, 4] {
            let lobes = interleaved_sub_lobe_rays(&gbuffer, 0.3, sectors).unwrap();
            assert_eq!(lobes.sectors(), sectors);
            assert_eq!(lobes.rays().len(), filtered.len());
            let radiance: Vec<Vec3> = lobes.rays().iter().map(|r| light(r.direction)).collect();
            let image = lobes.resolve(&radiance);
            let every = sub_lobe_rays(&gbuffer, 0.3, sectors).unwrap();
            let every_radiance: Vec<Vec3> = every.iter().map(|r| light(r.direction)).collect();
            let truth = accumulate_rays(w, h, &every, &every_radiance).unwrap();
            // Each pixel's own part alone, scaled to the lobe's weight: what sharing improves on.
            let own_part = accumulate_rays(w, h, lobes.rays(), &radiance).unwrap();
            let mut scaled = own_part.clone();
            let whole = weight_per_pixel(&filtered, (w * h) as usize);
            let own = weight_per_pixel(lobes.rays(), (w * h) as usize);
            for ((rgb, whole), own) in scaled.rgb.iter_mut().zip(whole).zip(own) {
                if own > 0.0 {
                    *rgb = (Vec3::from(*rgb) * (whole / own) as f32).to_array();
                }
            }
            let (shared, alone) = (image.mse(&truth).unwrap(), scaled.mse(&truth).unwrap());
            assert!(
                shared < 0.1 * alone,
                "{sectors} parts: {shared:.3e} against {alone:.3e}"
            );
        }
        // A lone pixel has no neighbour: its own part stands for the whole lobe.
        let one = render_gbuffer(&scene, &scene.default_camera(), 1, 1).unwrap();
        let lobes = interleaved_sub_lobe_rays(&one, 0.3, 2).unwrap();
        let whole = filtered_reflection_rays(&one, 0.3).unwrap()[0].weight;
        let image = lobes.resolve(&[Vec3::ONE]);
        assert!(
            (image.rgb[0][0] - whole).abs() < 1e-5,
            "{:?} against {whole}",
            image.rgb[0]
        );
        assert!(interleaved_sub_lobe_rays(&gbuffer_of(&scene), 0.3, 3).is_err());
        assert!(interleaved_sub_lobe_rays(&gbuffer_of(&scene), 0.0, 2).is_err());
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig {
            cases: 24,
            rng_seed: proptest::test_runner::RngSeed::Fixed(1),
            ..proptest::prelude::ProptestConfig::default()
        })]
        /// Where every ray reads one radiance, the resolve gives each pixel that radiance
        /// times its lobe's whole weight, whatever the image's size, the roughness and the
        /// number of parts (edge pixels, whose neighbours lack a part, included): sharing
        /// moves light between parts, never makes or loses it.
        #[test]
        fn the_resolve_keeps_a_constant_light(
            width in 1u32..24,
            height in 1u32..24,
            roughness in 0.05f32..1.0,
            four in proptest::bool::ANY,
            value in 0.01f32..20.0,
        ) {
            let scene = Scene::open("builtin:cornell").unwrap();
            let gbuffer = render_gbuffer(&scene, &scene.default_camera(), width, height).unwrap();
            let sectors = if four { 4 } else { 2 };
            let lobes = interleaved_sub_lobe_rays(&gbuffer, roughness, sectors).unwrap();
            let radiance = vec![Vec3::splat(value); lobes.rays().len()];
            let image = lobes.resolve(&radiance);
            let whole = weight_per_pixel(
                &filtered_reflection_rays(&gbuffer, roughness).unwrap(),
                (width * height) as usize,
            );
            for (pixel, rgb) in image.rgb.iter().enumerate() {
                let expected = value * whole[pixel] as f32;
                proptest::prop_assert!(
                    (rgb[0] - expected).abs() <= 1e-4 * expected.max(1.0),
                    "pixel {pixel}: {} against {expected}", rgb[0]
                );
            }
        }
    }

    /// The sum of the rays' weights in each of `pixels` pixels.
    fn weight_per_pixel(rays: &[EvaluationRay], pixels: usize) -> Vec<f64> {
        let mut sums = vec![0.0f64; pixels];
        for r in rays {
            sums[r.pixel as usize] += f64::from(r.weight);
        }
        sums
    }

    fn gbuffer_of(scene: &Scene) -> GBuffer {
        render_gbuffer(scene, &scene.default_camera(), 4, 4).unwrap()
    }
}
