//! The final image: what an engine shows, split into the parts a probe renderer computes in
//! different ways, and their path-traced truth.
//!
//! The model, shared by the probes' renderer (probe-eval) and the reference here:
//! - At the primary hit (the pixel centre's, from the [`GBuffer`]) the glTF metallic-roughness
//!   material: `F0 = mix(0.04, base_color, metallic)`; a GGX specular lobe with `α =
//!   roughness²`, weighted by Fresnel–Schlick; a Lambertian diffuse lobe of albedo
//!   `(1 − metallic)(1 − E(n·v)) base_color`, where `E` is the specular lobe's own
//!   directional albedo ([`specular_albedo`]), so the two lobes together reflect at most what
//!   arrives (a property test holds it).
//! - **direct**: the primary hit's emission plus the diffuse lobe times the direct irradiance
//!   of every light, the sun and the emitters, with exact (BVH) shadow rays
//!   ([`Shader::direct_irradiance`]).
//! - **diffuse**: the diffuse lobe times the indirect irradiance: light the surfaces around
//!   reflect, and the sky ([`Shader::reflected_radiance`]); probes hold exactly this
//!   ([`ProbeBake::irradiance`](crate::ProbeBake::irradiance)).
//! - **specular**: reflection rays sampled from the GGX lobe ([`specular_rays`]), each carrying
//!   the radiance at its hit (emission included: emitters seen in reflection are the specular
//!   part of direct light) times its Fresnel tint.
//! - Beyond the primary hit every surface is Lambertian, in the probes and in the reference
//!   alike (a probe stores one radiance per direction, exact only for Lambertian surfaces),
//!   and punctual lights and the sun draw no specular highlight (no reflection ray can hit
//!   them); both sides leave out the same light, so comparisons measure only the probes.

use crate::bake::Progress;
use crate::evaluation::{EvaluationRay, GBuffer, GBufferSample, accumulate_rays};
use crate::image::Image;
use crate::par::*;
use crate::render::RenderError;
use crate::rng::{Rng, cosine_hemisphere, orthonormal_basis};
use crate::shading::Shader;
use crate::{evaluation, trace_reference};
use glam::Vec3;
use probe_scene::{Material, Ray, Scene};

/// Perceptual roughness below which a material's specular lobe is traced as a mirror (one
/// ray per pixel, weight `F(n·v)`).
pub const MIRROR_ROUGHNESS: f32 = 0.03;

/// Dielectric reflectance at normal incidence (index of refraction 1.5), glTF's default.
pub const DIELECTRIC_F0: f32 = 0.04;

/// Random-number streams of the final image's passes (distinct from every other stream).
const SPECULAR_STREAM: u64 = 0xF1A1_0001;
const DIRECT_STREAM: u64 = 0xF1A1_0002;
const DIFFUSE_STREAM: u64 = 0xF1A1_0003;

/// How a material reflects at one viewing angle: its two lobes' weights.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceResponse {
    /// Albedo of the Lambertian lobe, `(1 − metallic)(1 − E(n·v)) base_color`, `E` the
    /// specular lobe's directional albedo ([`specular_albedo`]).
    pub diffuse: Vec3,
    /// Reflectance of the specular lobe at normal incidence, `mix(0.04, base_color, metallic)`.
    pub f0: Vec3,
    /// Perceptual roughness (GGX `α = roughness²`).
    pub roughness: f32,
}

impl SurfaceResponse {
    /// The response of `material` seen at cosine `n_dot_v` between the shading normal and the
    /// direction to the viewer.
    pub fn of(material: &Material, n_dot_v: f32) -> SurfaceResponse {
        let metallic = material.metallic.clamp(0.0, 1.0);
        let roughness = material.roughness.clamp(0.0, 1.0);
        let f0 = Vec3::splat(DIELECTRIC_F0).lerp(material.base_color, metallic);
        let mut response = SurfaceResponse {
            diffuse: Vec3::ZERO,
            f0,
            roughness,
        };
        if metallic < 1.0 {
            let specular_share = specular_albedo(&response, n_dot_v).min(Vec3::ONE);
            response.diffuse =
                (Vec3::ONE - specular_share) * (1.0 - metallic) * material.base_color;
        }
        response
    }

    /// The response at a G-buffer sample.
    pub fn at(scene: &Scene, sample: &GBufferSample) -> SurfaceResponse {
        let material = &scene.materials()[sample.material as usize];
        SurfaceResponse::of(
            material,
            sample.shading_normal.dot(sample.towards_camera).max(0.0),
        )
    }
}

/// Schlick's Fresnel: `F0 + (1 − F0)(1 − cos)⁵`.
#[inline]
pub fn fresnel_schlick(f0: Vec3, cos: f32) -> Vec3 {
    let k = (1.0 - cos.clamp(0.0, 1.0)).powi(5);
    f0 + (Vec3::ONE - f0) * k
}

/// The specular rays of a final image and the Fresnel tint of each: the pixel's value is
/// `Σ weight × tint × radiance` over its rays ([`SpecularRays::image`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SpecularRays {
    /// The rays, ordered by pixel; `weight` holds the sample's share and its masking term.
    pub rays: Vec<EvaluationRay>,
    /// Per ray, the Fresnel–Schlick tint at the sampled microfacet (for
    /// [`filtered_specular_rays`], the lobe's whole directional albedo).
    pub tints: Vec<Vec3>,
    /// Per ray, the perceptual roughness of the lobe it samples (0 for mirrors): what a
    /// prefiltered lookup blurs by.
    pub roughness: Vec<f32>,
}

impl SpecularRays {
    /// The specular image from each ray's arriving radiance.
    ///
    /// # Errors
    /// [`RenderError::LengthMismatch`] when `radiance` has not one value per ray.
    pub fn image(&self, gbuffer: &GBuffer, radiance: &[Vec3]) -> Result<Image, RenderError> {
        if radiance.len() != self.rays.len() {
            return Err(RenderError::LengthMismatch {
                rays: self.rays.len(),
                radiance: radiance.len(),
            });
        }
        let tinted: Vec<Vec3> = radiance
            .iter()
            .zip(&self.tints)
            .map(|(l, t)| *l * *t)
            .collect();
        accumulate_rays(gbuffer.width, gbuffer.height, &self.rays, &tinted)
    }
}

/// The specular rays of every front-facing G-buffer pixel: one mirror ray where the
/// material's roughness is under [`MIRROR_ROUGHNESS`], otherwise `rays_per_pixel` rays
/// sampled from GGX's visible normals (Heitz 2018) with the material's `α = roughness²`, each
/// weighted by Smith's masking of its direction and tinted by Fresnel–Schlick at its
/// microfacet (an unbiased estimate of the specular lobe's reflected radiance). Rays below the
/// surface are left out. Seeded per pixel.
///
/// # Errors
/// [`RenderError::InvalidSetting`] for `rays_per_pixel` of 0 or above 65536.
pub fn specular_rays(
    scene: &Scene,
    gbuffer: &GBuffer,
    rays_per_pixel: u32,
    seed: u64,
) -> Result<SpecularRays, RenderError> {
    check_samples("rays_per_pixel", rays_per_pixel)?;
    Ok(rays_of_front_pixels(gbuffer, |pixel, s| {
        let mut rays = Vec::new();
        let response = SurfaceResponse::at(scene, &s);
        let (n, v) = (s.shading_normal, s.towards_camera);
        let lobe_roughness = if response.roughness < MIRROR_ROUGHNESS {
            0.0
        } else {
            response.roughness
        };
        let mut push = |direction: Vec3, weight: f32, tint: Vec3| {
            if weight > 0.0 && direction.dot(s.geometric_normal) > 0.0 {
                rays.push((
                    EvaluationRay::leaving(pixel, &s, direction, weight),
                    tint,
                    lobe_roughness,
                ));
            }
        };
        if response.roughness < MIRROR_ROUGHNESS {
            let n_dot_v = n.dot(v).max(0.0);
            push(
                (2.0 * n_dot_v * n - v).normalize(),
                1.0,
                fresnel_schlick(response.f0, n_dot_v),
            );
            return rays;
        }
        let mut rng = Rng::for_key(seed, &[SPECULAR_STREAM, pixel as u64]);
        let alpha = (response.roughness * response.roughness).max(1e-4);
        let (t, b) = orthonormal_basis(n);
        let local_view = Vec3::new(v.dot(t), v.dot(b), v.dot(n));
        let share = 1.0 / rays_per_pixel as f32;
        for _ in 0..rays_per_pixel {
            let m = evaluation::sample_ggx_vndf(local_view, alpha, rng.next_vec2());
            let local = (2.0 * local_view.dot(m) * m - local_view).normalize();
            if local.z <= 0.0 {
                continue;
            }
            let direction = (t * local.x + b * local.y + n * local.z).normalize();
            push(
                direction,
                share * evaluation::smith_g1(alpha, local.z),
                fresnel_schlick(response.f0, local_view.dot(m).max(0.0)),
            );
        }
        rays
    }))
}

/// `rays_of(pixel, sample)` over every front-facing G-buffer pixel (in parallel), gathered in
/// pixel order: `(ray, tint, roughness)` per ray.
fn rays_of_front_pixels(
    gbuffer: &GBuffer,
    rays_of: impl Fn(usize, GBufferSample) -> Vec<(EvaluationRay, Vec3, f32)> + Sync,
) -> SpecularRays {
    let per_pixel: Vec<Vec<(EvaluationRay, Vec3, f32)>> = gbuffer
        .pixels
        .par_iter()
        .enumerate()
        .with_min_len(64)
        .map(|(pixel, sample)| match sample.filter(|s| !s.back_face) {
            Some(s) => rays_of(pixel, s),
            None => Vec::new(),
        })
        .collect();
    let mut out = SpecularRays::default();
    for (ray, tint, roughness) in per_pixel.into_iter().flatten() {
        out.rays.push(ray);
        out.tints.push(tint);
        out.roughness.push(roughness);
    }
    out
}

/// The specular lobe's directional albedo at `n·v`: the mean of the estimator
/// [`specular_rays`] uses (Fresnel at the sampled microfacet × Smith's masking of the
/// reflected direction, over GGX's visible normals); Fresnel at `n·v` for mirrors. What a
/// prefiltered lookup multiplies its radiance by (the split-sum approximation: the lobe's
/// radiance and its albedo taken apart). Schlick's Fresnel is linear in `F0`, so the albedo is
/// `F0·A + B` with `A` and `B` depending on roughness and `n·v` only (Karis 2013): they come
/// from a table of 33 × 33 entries, each a 16 × 16 midpoint quadrature, built once and read
/// bilinearly.
pub fn specular_albedo(response: &SurfaceResponse, n_dot_v: f32) -> Vec3 {
    if response.roughness < MIRROR_ROUGHNESS {
        return fresnel_schlick(response.f0, n_dot_v);
    }
    let (a, b) = albedo_terms(response.roughness, n_dot_v);
    response.f0 * a + Vec3::splat(b)
}

/// Entries per side of the split-sum table (roughness and `n·v` from 0 to 1).
const ALBEDO_TABLE: usize = 33;

/// `(A, B)` of [`specular_albedo`], read bilinearly from the table.
fn albedo_terms(roughness: f32, n_dot_v: f32) -> (f32, f32) {
    static TABLE: std::sync::OnceLock<Vec<(f32, f32)>> = std::sync::OnceLock::new();
    let table = TABLE.get_or_init(|| {
        let last = (ALBEDO_TABLE - 1) as f32;
        let mut entries = Vec::with_capacity(ALBEDO_TABLE * ALBEDO_TABLE);
        for r in 0..ALBEDO_TABLE {
            for c in 0..ALBEDO_TABLE {
                entries.push(albedo_quadrature(r as f32 / last, c as f32 / last));
            }
        }
        entries
    });
    let last = (ALBEDO_TABLE - 1) as f32;
    let (x, y) = (
        roughness.clamp(0.0, 1.0) * last,
        n_dot_v.clamp(0.0, 1.0) * last,
    );
    let (r0, c0) = (
        (x.floor() as usize).min(ALBEDO_TABLE - 2),
        (y.floor() as usize).min(ALBEDO_TABLE - 2),
    );
    let (fr, fc) = (x - r0 as f32, y - c0 as f32);
    let at = |r: usize, c: usize| table[r * ALBEDO_TABLE + c];
    let lerp =
        |p: (f32, f32), q: (f32, f32), t: f32| (p.0 + (q.0 - p.0) * t, p.1 + (q.1 - p.1) * t);
    lerp(
        lerp(at(r0, c0), at(r0, c0 + 1), fc),
        lerp(at(r0 + 1, c0), at(r0 + 1, c0 + 1), fc),
        fr,
    )
}

/// `A = ∫ (1 − k) G1` and `B = ∫ k G1`, `k = (1 − v·m)⁵`, over GGX's visible normals by a
/// 16 × 16 midpoint quadrature.
fn albedo_quadrature(roughness: f32, n_dot_v: f32) -> (f32, f32) {
    let n_dot_v = n_dot_v.max(1e-4);
    let view = Vec3::new((1.0 - n_dot_v * n_dot_v).max(0.0).sqrt(), 0.0, n_dot_v);
    let alpha = (roughness * roughness).max(1e-4);
    const STEPS: u32 = 16;
    let (mut a, mut b) = (0.0f32, 0.0f32);
    for i in 0..STEPS {
        for j in 0..STEPS {
            let u = glam::Vec2::new(
                (i as f32 + 0.5) / STEPS as f32,
                (j as f32 + 0.5) / STEPS as f32,
            );
            let m = evaluation::sample_ggx_vndf(view, alpha, u);
            let l = 2.0 * view.dot(m) * m - view;
            if l.z > 0.0 {
                let k = (1.0 - view.dot(m).clamp(0.0, 1.0)).powi(5);
                let g = evaluation::smith_g1(alpha, l.z);
                a += (1.0 - k) * g;
                b += k * g;
            }
        }
    }
    let n = (STEPS * STEPS) as f32;
    (a / n, b / n)
}

/// One specular ray per front-facing pixel for a prefiltered lookup: along the GGX lobe's
/// dominant direction (the mirror direction pulled towards the normal as roughness grows;
/// Lagarde and de Rousiers 2014), weight 1, tinted by the lobe's directional albedo
/// ([`specular_albedo`]), with the lobe's roughness; the tracer reads radiance prefiltered to
/// that roughness where the ray lands. No randomness: no noise, and a bias where the lobe
/// straddles geometry the one ray does not see.
pub fn filtered_specular_rays(scene: &Scene, gbuffer: &GBuffer) -> SpecularRays {
    rays_of_front_pixels(gbuffer, |pixel, s| {
        filtered_specular_rays_of(&SurfaceResponse::at(scene, &s), pixel, &s)
    })
}

/// The one ray of [`filtered_specular_rays`] for one pixel (none when its direction falls
/// below the surface): the ray, its tint and its roughness.
fn filtered_specular_rays_of(
    response: &SurfaceResponse,
    pixel: usize,
    s: &GBufferSample,
) -> Vec<(EvaluationRay, Vec3, f32)> {
    let (n, v) = (s.shading_normal, s.towards_camera);
    let n_dot_v = n.dot(v).max(0.0);
    let mirror = (2.0 * n_dot_v * n - v).normalize();
    let (direction, roughness) = if response.roughness < MIRROR_ROUGHNESS {
        (mirror, 0.0)
    } else {
        let alpha = response.roughness * response.roughness;
        let smoothness = (1.0 - alpha).clamp(0.0, 1.0);
        let pull = smoothness * (smoothness.sqrt() + alpha);
        (n.lerp(mirror, pull).normalize(), response.roughness)
    };
    if direction.dot(s.geometric_normal) <= 0.0 {
        return Vec::new();
    }
    vec![(
        EvaluationRay::leaving(pixel, s, direction, 1.0),
        specular_albedo(response, n_dot_v),
        roughness,
    )]
}

/// [`filtered_specular_rays`] with each glossy lobe cut into `sectors` parts by azimuth
/// ([`evaluation::ggx_sub_lobes`]): one ray along each part's mean, weighted by the part's
/// share of the lobe's weight (the shares of a pixel sum to 1, so the pixel keeps the lobe's
/// albedo as its tint), with the cone of one part ([`evaluation::sub_lobe_roughness`]) as the
/// ray's roughness. Mirrors keep their one ray; `sectors` 1 is [`filtered_specular_rays`].
/// More rays per pixel for less of the bias one cone has where the lobe straddles geometry.
///
/// # Errors
/// [`RenderError::InvalidSetting`] for `sectors` outside 1 to [`evaluation::MAX_LOBE_SECTORS`].
pub fn filtered_specular_sub_lobe_rays(
    scene: &Scene,
    gbuffer: &GBuffer,
    sectors: u32,
) -> Result<SpecularRays, RenderError> {
    if !(1..=evaluation::MAX_LOBE_SECTORS).contains(&sectors) {
        return Err(RenderError::InvalidSetting {
            parameter: "sectors",
            value: sectors.to_string(),
            reason: "must be from 1 to 8 (rays per glossy pixel)",
        });
    }
    if sectors == 1 {
        return Ok(filtered_specular_rays(scene, gbuffer));
    }
    Ok(rays_of_front_pixels(gbuffer, |pixel, s| {
        let response = SurfaceResponse::at(scene, &s);
        if response.roughness < MIRROR_ROUGHNESS {
            return filtered_specular_rays_of(&response, pixel, &s);
        }
        let n_dot_v = s.shading_normal.dot(s.towards_camera).max(0.0);
        let parts = evaluation::ggx_sub_lobes(
            s.towards_camera,
            s.shading_normal,
            s.geometric_normal,
            response.roughness,
            sectors,
        );
        let total: f32 = parts.iter().map(|(_, w)| w).sum();
        let tint = specular_albedo(&response, n_dot_v);
        let roughness = evaluation::sub_lobe_roughness(response.roughness, sectors);
        parts
            .into_iter()
            .map(|(direction, share)| {
                (
                    EvaluationRay::leaving(pixel, &s, direction, share / total),
                    tint,
                    roughness,
                )
            })
            .collect()
    }))
}

/// The direct part of the final image: each front-facing pixel's emission plus its diffuse
/// lobe times [`Shader::direct_irradiance`] with `emitter_samples` emitter samples; the sky
/// where nothing is hit (no probe holds what the camera sees directly). Seeded per pixel.
///
/// # Errors
/// [`RenderError::InvalidSetting`] for `emitter_samples` of 0 or above 65536.
pub fn direct_image(
    shader: &Shader<'_>,
    gbuffer: &GBuffer,
    emitter_samples: u32,
    seed: u64,
) -> Result<Image, RenderError> {
    check_samples("emitter_samples", emitter_samples)?;
    let scene = shader.scene();
    Ok(per_pixel(gbuffer, |pixel, sample| match sample {
        None => {
            let (x, y) = (pixel as u32 % gbuffer.width, pixel as u32 / gbuffer.width);
            let ray = gbuffer
                .camera
                .ray(x, y, gbuffer.width, gbuffer.height, glam::Vec2::ZERO);
            shader.background(ray.direction)
        }
        Some(s) if s.back_face => Vec3::ZERO,
        Some(s) => {
            let mut rng = Rng::for_key(seed, &[DIRECT_STREAM, pixel as u64]);
            let material = &scene.materials()[s.material as usize];
            let emission = if material.is_emissive() {
                material.emissive
            } else {
                Vec3::ZERO
            };
            let response = SurfaceResponse::at(scene, s);
            let irradiance = shader.direct_irradiance(
                s.position,
                s.geometric_normal,
                s.shading_normal,
                s.triangle,
                emitter_samples,
                &mut rng,
            );
            emission + response.diffuse * irradiance / std::f32::consts::PI
        }
    }))
}

/// The path-traced truth of a diffuse lobe's indirect light: per front-facing pixel, `albedo`
/// (the lobe's albedo at that sample) times the mean of [`Shader::reflected_radiance`] over
/// `samples` cosine-distributed directions (the indirect irradiance over π). With
/// `albedo = base_color` it is the reference of `probes render --component diffuse`; with
/// [`SurfaceResponse::diffuse`] the final image's diffuse part. Seeded per pixel;
/// `progress` receives `(rows done, rows)`.
///
/// # Errors
/// [`RenderError::InvalidSetting`] for `samples` of 0 or above 65536.
pub fn diffuse_reference(
    shader: &Shader<'_>,
    gbuffer: &GBuffer,
    albedo: &(dyn Fn(&GBufferSample) -> Vec3 + Sync),
    samples: u32,
    seed: u64,
    progress: Progress<'_>,
) -> Result<Image, RenderError> {
    check_samples("samples_per_pixel", samples)?;
    let done = std::sync::atomic::AtomicUsize::new(0);
    let width = gbuffer.width as usize;
    let image = per_pixel(gbuffer, |pixel, sample| {
        let value = match sample {
            Some(s) if !s.back_face => {
                let lobe = albedo(s);
                if lobe.max_element() <= 0.0 {
                    Vec3::ZERO
                } else {
                    let mut rng = Rng::for_key(seed, &[DIFFUSE_STREAM, pixel as u64]);
                    let mut sum = Vec3::ZERO;
                    for _ in 0..samples {
                        let direction = cosine_hemisphere(s.shading_normal, rng.next_vec2());
                        if direction.dot(s.geometric_normal) <= 0.0 {
                            continue;
                        }
                        let ray = Ray::from_surface(s.position, s.geometric_normal, direction);
                        sum += shader.reflected_radiance(&ray, &mut rng);
                    }
                    lobe * sum / samples as f32
                }
            }
            _ => Vec3::ZERO,
        };
        if (pixel + 1) % width == 0 {
            let d = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
            progress(d, gbuffer.height as usize);
        }
        value
    });
    Ok(image)
}

/// The final image in its parts; [`FinalParts::sum`] is the image.
#[derive(Clone, Debug, PartialEq)]
pub struct FinalParts {
    /// Emission and direct light (diffuse lobe, exact shadows); the sky where nothing is hit.
    pub direct: Image,
    /// Indirect diffuse: the diffuse lobe times the indirect irradiance.
    pub diffuse: Image,
    /// The specular lobe's reflected radiance (indirect and from emitters).
    pub specular: Image,
}

impl FinalParts {
    /// The final image: the parts' sum.
    pub fn sum(&self) -> Image {
        let mut image = self.direct.clone();
        for (pixel, (d, s)) in image
            .rgb
            .iter_mut()
            .zip(self.diffuse.rgb.iter().zip(&self.specular.rgb))
        {
            for k in 0..3 {
                pixel[k] += d[k] + s[k];
            }
        }
        image
    }
}

/// The path-traced final image of `gbuffer`'s view in its parts: `samples` emitter samples,
/// diffuse directions and specular rays per pixel (more lower the noise; a reference wants
/// hundreds), light beyond the primary hit shaded by `shader` (whose bounces should be the
/// bake's). `progress` receives `(done, total)` over the three passes.
///
/// # Errors
/// [`RenderError::InvalidSetting`] for `samples` of 0 or above 65536.
pub fn reference_final(
    shader: &Shader<'_>,
    gbuffer: &GBuffer,
    samples: u32,
    seed: u64,
    progress: Progress<'_>,
) -> Result<FinalParts, RenderError> {
    let scene = shader.scene();
    let rows = gbuffer.height as usize;
    let direct = direct_image(shader, gbuffer, samples, seed)?;
    let diffuse = diffuse_reference(
        shader,
        gbuffer,
        &|s| SurfaceResponse::at(scene, s).diffuse,
        samples,
        seed,
        &|done, _| progress(done, 2 * rows),
    )?;
    let specular = specular_rays(scene, gbuffer, samples, seed)?;
    let traced = trace_reference(shader, &specular.rays, 1, seed, &|done, total| {
        progress(rows + done * rows / total.max(1), 2 * rows)
    });
    let radiance: Vec<Vec3> = traced.iter().map(|t| t.radiance).collect();
    Ok(FinalParts {
        direct,
        diffuse,
        specular: specular.image(gbuffer, &radiance)?,
    })
}

fn per_pixel(
    gbuffer: &GBuffer,
    shade: impl Fn(usize, &Option<GBufferSample>) -> Vec3 + Sync,
) -> Image {
    let values: Vec<Vec3> = gbuffer
        .pixels
        .par_iter()
        .enumerate()
        .with_min_len(64)
        .map(|(pixel, sample)| shade(pixel, sample))
        .collect();
    let mut image = Image::new(gbuffer.width, gbuffer.height);
    for (out, value) in image.rgb.iter_mut().zip(values) {
        *out = value.to_array();
    }
    image
}

fn check_samples(parameter: &'static str, value: u32) -> Result<(), RenderError> {
    if value == 0 || value > 65_536 {
        return Err(RenderError::InvalidSetting {
            parameter,
            value: value.to_string(),
            reason: "must be from 1 to 65536",
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig {
            rng_seed: proptest::test_runner::RngSeed::Fixed(1),
            ..ProptestConfig::default()
        })]
        /// The split conserves energy: for any white material, the diffuse lobe's albedo plus
        /// the specular lobe's directional albedo is at most 1 (within the quadrature's error),
        /// at every viewing angle.
        #[test]
        fn diffuse_and_specular_together_reflect_at_most_what_arrives(
            metallic in 0.0f32..=1.0,
            roughness in 0.0f32..=1.0,
            n_dot_v in 0.05f32..=1.0,
        ) {
            let material = Material {
                metallic,
                roughness,
                ..Material::diffuse("white", Vec3::ONE)
            };
            let response = SurfaceResponse::of(&material, n_dot_v);
            let total = response.diffuse + specular_albedo(&response, n_dot_v);
            prop_assert!(total.max_element() <= 1.02, "{total} at metallic {metallic}, roughness {roughness}, n·v {n_dot_v}");
            prop_assert!(response.diffuse.min_element() >= 0.0);
        }
    }

    /// The stochastic rays and the filtered ray agree in expectation: per pixel, the sum of
    /// the stochastic rays' weight × tint (the specular lobe's albedo, estimated) is the
    /// filtered ray's tint ([`specular_albedo`]) within Monte Carlo error.
    #[test]
    fn stochastic_and_filtered_specular_weights_agree() {
        let scene = Scene::builtin("cornell").unwrap();
        let gbuffer = crate::render_gbuffer(&scene, &scene.default_camera(), 4, 4).unwrap();
        let stochastic = specular_rays(&scene, &gbuffer, 4096, 1).unwrap();
        let filtered = filtered_specular_rays(&scene, &gbuffer);
        assert!(!filtered.rays.is_empty());
        for (ray, tint) in filtered.rays.iter().zip(&filtered.tints) {
            let sum: Vec3 = stochastic
                .rays
                .iter()
                .zip(&stochastic.tints)
                .filter(|(r, _)| r.pixel == ray.pixel)
                .map(|(r, t)| *t * r.weight)
                .sum();
            let relative = ((sum - *tint).abs() / tint.max(Vec3::splat(1e-6))).max_element();
            assert!(relative < 0.05, "pixel {}: {sum} vs {tint}", ray.pixel);
        }
        assert!(
            filtered.roughness.iter().all(|&r| r == 1.0),
            "the box is rough"
        );
    }

    /// Sub-lobe rays keep each glossy pixel's whole lobe: per pixel the weights sum to 1, at
    /// most `sectors` rays share the filtered ray's tint, each with one part's cone; mirrors
    /// and one sector are the filtered rays; 0 and 9 sectors are refused.
    #[test]
    fn sub_lobe_specular_rays_keep_each_pixels_lobe() {
        let scene = Scene::builtin("colonnade").unwrap();
        let gbuffer = crate::render_gbuffer(&scene, &scene.default_camera(), 16, 12).unwrap();
        let one = filtered_specular_rays(&scene, &gbuffer);
        assert_eq!(
            filtered_specular_sub_lobe_rays(&scene, &gbuffer, 1).unwrap(),
            one
        );
        for sectors in [0, evaluation::MAX_LOBE_SECTORS + 1] {
            assert!(filtered_specular_sub_lobe_rays(&scene, &gbuffer, sectors).is_err());
        }
        for sectors in 2..=evaluation::MAX_LOBE_SECTORS {
            let split = filtered_specular_sub_lobe_rays(&scene, &gbuffer, sectors).unwrap();
            let mut split_pixels = 0;
            for pixel in 0..gbuffer.pixels.len() as u32 {
                let of = |rays: &SpecularRays| -> Vec<usize> {
                    (0..rays.rays.len())
                        .filter(|&i| rays.rays[i].pixel == pixel)
                        .collect()
                };
                let (parts, whole) = (of(&split), of(&one));
                if parts.is_empty() {
                    continue;
                }
                assert!(parts.len() <= sectors as usize, "pixel {pixel}");
                let total: f32 = parts.iter().map(|&i| split.rays[i].weight).sum();
                assert!((total - 1.0).abs() < 1e-4, "pixel {pixel}: {total}");
                let Some(&w) = whole.first() else { continue };
                let whole_roughness = one.roughness[w];
                for &i in &parts {
                    assert_eq!(split.tints[i], one.tints[w], "pixel {pixel}");
                    let expected = if whole_roughness == 0.0 {
                        0.0
                    } else {
                        evaluation::sub_lobe_roughness(whole_roughness, sectors)
                    };
                    assert_eq!(split.roughness[i], expected, "pixel {pixel}");
                }
                if whole_roughness == 0.0 {
                    assert_eq!(parts.len(), 1, "a mirror pixel keeps one ray");
                } else if parts.len() > 1 {
                    split_pixels += 1;
                    assert!(split.roughness[parts[0]] < whole_roughness);
                }
            }
            assert!(split_pixels > 0, "{sectors} sectors split no lobe");
        }
    }

    #[test]
    fn a_metal_has_no_diffuse_lobe_and_a_dielectric_diffuses_what_its_specular_leaves() {
        let metal = Material {
            metallic: 1.0,
            roughness: 0.5,
            ..Material::diffuse("gold", Vec3::new(1.0, 0.8, 0.3))
        };
        let response = SurfaceResponse::of(&metal, 0.7);
        assert_eq!(response.diffuse, Vec3::ZERO);
        assert_eq!(response.f0, metal.base_color);
        let dielectric = SurfaceResponse::of(&Material::diffuse("grey", Vec3::splat(0.5)), 1.0);
        assert_eq!(dielectric.f0, Vec3::splat(DIELECTRIC_F0));
        let specular = specular_albedo(&dielectric, 1.0).x;
        // Rough (α = 1): single-scattering GGX loses much to masking (E ≈ 0.31 F0 here).
        assert!(
            specular > 0.2 * DIELECTRIC_F0 && specular < DIELECTRIC_F0,
            "{specular}"
        );
        assert!((dielectric.diffuse.x - 0.5 * (1.0 - specular)).abs() < 1e-6);
    }
}
