//! The evaluation rays shared by the reference renderer and the probe tracer: a camera's
//! G-buffer, secondary reflection rays from it, and the reference radiance along them.

use std::sync::atomic::{AtomicUsize, Ordering};

use glam::{Vec2, Vec3};
use probe_scene::{Camera, Hit, Ray, Scene};

use crate::bake::Progress;
use crate::image::Image;
use crate::par::*;
use crate::render::RenderError;
use crate::rng::{Rng, orthonormal_basis};
use crate::shading::{Shader, normals_towards};

/// Random-stream tags, so that the streams of different stages never coincide.
pub(crate) const PIXEL_STREAM: u64 = 0x5049_5845_4c00_0001;
const REFLECTION_STREAM: u64 = 0x5245_464c_4543_0002;
const TRACE_STREAM: u64 = 0x5452_4143_4500_0003;

/// What a camera's primary ray through a pixel centre hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GBufferSample {
    /// The hit point, world space.
    pub position: Vec3,
    /// The plane normal, flipped to the camera's side.
    pub geometric_normal: Vec3,
    /// The shading normal on the camera's side (the plane normal where the interpolated one
    /// faces away from the camera).
    pub shading_normal: Vec3,
    /// Unit direction from the hit back to the camera.
    pub towards_camera: Vec3,
    /// Distance from the camera, metres.
    pub distance: f32,
    /// Index into [`Scene::triangles`].
    pub triangle: u32,
    /// Index into [`Scene::materials`].
    pub material: u32,
    /// Whether the camera sees the back face of a single-sided material (which the shading
    /// model treats as black and which reflects nothing).
    pub back_face: bool,
}

/// A camera's G-buffer: one primary ray through the centre of each pixel.
#[derive(Clone, Debug, PartialEq)]
pub struct GBuffer {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// The camera.
    pub camera: Camera,
    /// Per pixel (row-major from the top-left), the primary hit or `None` for the sky.
    pub pixels: Vec<Option<GBufferSample>>,
}

/// How secondary rays leave the G-buffer's surfaces.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Reflection {
    /// The mirror direction about the shading normal; weight 1.
    Mirror,
    /// GGX (Trowbridge–Reitz) reflection with perceptual `roughness` in `(0, 1]` (`α =
    /// roughness²`), sampled from the distribution of visible normals (Heitz 2018). The
    /// weight is Smith's masking `G1` of the sampled direction, the BRDF × cos / pdf of a
    /// GGX lobe with Fresnel 1 under separable masking–shadowing.
    Ggx {
        /// Perceptual roughness in `(0, 1]`.
        roughness: f32,
    },
}

/// A secondary ray from a G-buffer pixel, as both the reference and the probe tracer trace it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EvaluationRay {
    /// The pixel, `y · width + x`.
    pub pixel: u32,
    /// The start point, offset off the surface ([`Ray::from_surface`]).
    pub origin: Vec3,
    /// Unit direction.
    pub direction: Vec3,
    /// The ray's share of its pixel: the pixel's value is `Σ weight × radiance` over its
    /// rays (the reflection weight divided by the rays per pixel).
    pub weight: f32,
}

impl EvaluationRay {
    /// The ray of `pixel` leaving its G-buffer sample `s` along `direction`, offset off the
    /// surface along its geometric normal ([`Ray::from_surface`]), with its share `weight`.
    pub fn leaving(pixel: usize, s: &GBufferSample, direction: Vec3, weight: f32) -> Self {
        let ray = Ray::from_surface(s.position, s.geometric_normal, direction);
        EvaluationRay {
            pixel: pixel as u32,
            origin: ray.origin,
            direction: ray.direction,
            weight,
        }
    }

    /// The ray as probe-scene casts it.
    pub fn ray(&self) -> Ray {
        Ray {
            origin: self.origin,
            direction: self.direction,
        }
    }
}

/// An image's rays put in the order a GPU traces fastest: by 8×8 pixel tile (tiles row by
/// row; within a tile the rays keep their order, so each pixel's rays stay together and in
/// sequence). A 64-thread workgroup then traces one tile's neighbouring pixels, whose rays
/// read the same probe texels. On an NVIDIA H200 this took the hi-Z trace of Sponza's
/// 1920×1080 reflections from 26.6 to 18.1 ms at 128² and from 29.8 to 21.9 ms at 256²
/// against row order (a random order took 63.8 ms at 128²), and `probes render`'s from 24.2
/// to 18.2 ms; BENCHMARKS.md, "On a real GPU". Each ray's answer does not depend on the
/// order, so the images are the same to the byte.
///
/// ```
/// use glam::Vec3;
/// use probe_capture::{EvaluationRay, TileOrder};
///
/// // One ray per pixel of a 16×2 image, row by row.
/// let rays: Vec<EvaluationRay> = (0..32)
///     .map(|pixel| EvaluationRay { pixel, origin: Vec3::ZERO, direction: Vec3::X, weight: 1.0 })
///     .collect();
/// let order = TileOrder::of(&rays, 16);
/// let tiled = order.apply(&rays);
/// // The first tile's 16 pixels (x < 8, both rows) come first.
/// assert!(tiled[..16].iter().all(|r| r.pixel % 16 < 8));
/// // Results traced in tile order go back to the rays' order.
/// let pixels: Vec<u32> = order.restore(tiled.iter().map(|r| r.pixel).collect());
/// assert_eq!(pixels, (0..32).collect::<Vec<u32>>());
/// ```
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TileOrder {
    /// `order[k]` is the index (in the rays as given) of the `k`-th ray to trace.
    order: Vec<usize>,
}

impl TileOrder {
    /// The side of a tile, in pixels.
    pub const TILE: u32 = 8;

    /// The tile order of `rays`, whose pixels are `y · width + x`. A `width` of 0 keeps
    /// the rays' order.
    pub fn of(rays: &[EvaluationRay], width: u32) -> TileOrder {
        let mut order: Vec<usize> = (0..rays.len()).collect();
        if width > 0 {
            let tile = |pixel: u32| {
                let (x, y) = (pixel % width, pixel / width);
                (y / Self::TILE, x / Self::TILE)
            };
            // Stable: within a tile, the rays keep their order.
            order.sort_by_key(|&i| tile(rays[i].pixel));
        }
        TileOrder { order }
    }

    /// The permutation itself: the index (in the rays as given) of each ray to trace, in
    /// tile order.
    pub fn indices(&self) -> &[usize] {
        &self.order
    }

    /// The number of rays ordered.
    pub fn len(&self) -> usize {
        self.order.len()
    }

    /// Whether there are no rays.
    pub fn is_empty(&self) -> bool {
        self.order.is_empty()
    }

    /// `items` (one per ray, in the rays' order) in tile order. Items of another count are
    /// returned as they are.
    pub fn apply<T: Clone>(&self, items: &[T]) -> Vec<T> {
        if items.len() != self.order.len() {
            return items.to_vec();
        }
        self.order.iter().map(|&i| items[i].clone()).collect()
    }

    /// `items` in tile order (e.g. the results of tracing [`TileOrder::apply`]'s rays) back
    /// in the rays' order: the inverse of [`TileOrder::apply`]. Items of another count are
    /// returned as they are.
    pub fn restore<T>(&self, items: Vec<T>) -> Vec<T> {
        if items.len() != self.order.len() {
            return items;
        }
        let mut slots: Vec<Option<T>> = std::iter::repeat_with(|| None).take(items.len()).collect();
        for (&i, item) in self.order.iter().zip(items) {
            slots[i] = Some(item);
        }
        // `order` is a permutation, so every slot is filled.
        slots.into_iter().flatten().collect()
    }
}

/// The reference result of one [`EvaluationRay`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReferenceSample {
    /// The true closest hit, or `None` when the ray leaves the scene.
    pub hit: Option<Hit>,
    /// The [`Shader`]'s outgoing radiance at the hit towards the ray's origin, or the sky.
    pub radiance: Vec3,
}

fn check_size(width: u32, height: u32) -> Result<(), RenderError> {
    for (parameter, value) in [("width", width), ("height", height)] {
        if value == 0 || value > 16_384 {
            return Err(RenderError::InvalidSetting {
                parameter,
                value: value.to_string(),
                reason: "must be from 1 to 16384",
            });
        }
    }
    Ok(())
}

/// Casts one primary ray through the centre of every pixel (in parallel) and records what
/// it hit.
///
/// # Errors
/// [`RenderError::InvalidSetting`] for a zero or larger than 16384 `width` or `height`.
pub fn render_gbuffer(
    scene: &Scene,
    camera: &Camera,
    width: u32,
    height: u32,
) -> Result<GBuffer, RenderError> {
    check_size(width, height)?;
    let pixels = (0..width * height)
        .into_par_iter()
        .with_min_len(64)
        .map(|pixel| {
            let ray = camera.ray(pixel % width, pixel / width, width, height, Vec2::ZERO);
            let hit = scene.closest_hit(&ray, f32::INFINITY)?;
            let material = &scene.materials()[hit.material as usize];
            let towards_camera = -ray.direction;
            let (facing, geometric_normal, shading_normal) = normals_towards(&hit, towards_camera);
            Some(GBufferSample {
                position: hit.position,
                geometric_normal,
                shading_normal,
                towards_camera,
                distance: hit.t,
                triangle: hit.triangle,
                material: hit.material,
                back_face: !facing && !material.double_sided,
            })
        })
        .collect();
    Ok(GBuffer {
        width,
        height,
        camera: camera.clone(),
        pixels,
    })
}

/// Smith's masking for GGX with `α` at a direction whose cosine to the normal is `cos`.
#[inline]
pub(crate) fn smith_g1(alpha: f32, cos: f32) -> f32 {
    let cos2 = (cos * cos).max(1e-12);
    let tan2 = (1.0 - cos2).max(0.0) / cos2;
    2.0 / (1.0 + (1.0 + alpha * alpha * tan2).sqrt())
}

/// A GGX visible normal (Heitz 2018, "Sampling the GGX Distribution of Visible Normals") in
/// the local frame where the normal is `+z`, for the local view direction `view`.
#[inline]
pub(crate) fn sample_ggx_vndf(view: Vec3, alpha: f32, u: Vec2) -> Vec3 {
    let vh = Vec3::new(alpha * view.x, alpha * view.y, view.z).normalize();
    let lensq = vh.x * vh.x + vh.y * vh.y;
    let t1 = if lensq > 0.0 {
        Vec3::new(-vh.y, vh.x, 0.0) / lensq.sqrt()
    } else {
        Vec3::X
    };
    let t2 = vh.cross(t1);
    let r = u.x.sqrt();
    let phi = std::f32::consts::TAU * u.y;
    let p1 = r * phi.cos();
    let s = 0.5 * (1.0 + vh.z);
    let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * r * phi.sin();
    let nh = t1 * p1 + t2 * p2 + vh * (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt();
    Vec3::new(alpha * nh.x, alpha * nh.y, nh.z.max(0.0)).normalize()
}

/// Quadrature points per side of [`ggx_lobe_mean`]'s stratified grid (`8² = 64` samples).
const LOBE_MEAN_SIDE: u32 = 8;

/// The most parts [`ggx_sub_lobes`] cuts a lobe into: one per row of its quadrature grid.
pub const MAX_LOBE_SECTORS: u32 = LOBE_MEAN_SIDE;

/// The mean of the GGX reflection lobe that [`reflection_rays`] samples, by a fixed
/// quadrature (the centres of an 8×8 stratified grid of its random numbers; no noise): for
/// perceptual `roughness` at a surface with `shading_normal` and `geometric_normal` seen from
/// `view` (unit, towards the viewer), the direction of the weighted mean of the sampled
/// reflection directions and the mean weight (Smith's `G1`, 0 for a direction below the
/// shading or the geometric surface), as the stochastic rays would average them. `None` when
/// no sample leaves above both surfaces.
///
/// One ray along this direction stands for the whole lobe better than the mirror direction
/// where the surface cuts the lobe: near grazing (or where a normal map tilts the shading
/// normal), the mirror ray skims the surface while the lobe's visible part points higher
/// (BENCHMARKS.md, "Filtered glossy").
///
/// ```
/// use glam::Vec3;
/// let up = Vec3::Y;
/// // Seen at 80° from the normal: the lobe's mean rises above the mirror direction.
/// let view = Vec3::new(-(80f32.to_radians().sin()), 80f32.to_radians().cos(), 0.0);
/// let mirror = 2.0 * up.dot(view) * up - view;
/// let (mean, weight) = probe_capture::ggx_lobe_mean(view, up, up, 0.3).unwrap();
/// assert!(mean.y > mirror.y);
/// assert!(weight > 0.0 && weight <= 1.0);
/// ```
pub fn ggx_lobe_mean(
    view: Vec3,
    shading_normal: Vec3,
    geometric_normal: Vec3,
    roughness: f32,
) -> Option<(Vec3, f32)> {
    ggx_sub_lobes(view, shading_normal, geometric_normal, roughness, 1)
        .into_iter()
        .next()
}

/// The GGX lobe of [`ggx_lobe_mean`] cut into `sectors` parts (1 to [`MAX_LOBE_SECTORS`],
/// clamped) by the azimuth of its
/// visible-normal samples about the view: each part's mean direction and its share of the
/// mean weight (the shares sum to [`ggx_lobe_mean`]'s weight; a part whose samples all fall
/// below the surface is left out). Two sectors split the lobe across the plane of incidence's
/// trace, into the halves nearer and farther from the normal: at a grazing view the lobe is
/// long in that plane and narrow across it, so its halves are what two narrower cones stand
/// for. Empty when no sample leaves above both surfaces.
///
/// ```
/// use glam::Vec3;
/// let up = Vec3::Y;
/// let view = Vec3::new(-(75f32.to_radians().sin()), 75f32.to_radians().cos(), 0.0);
/// let (_, whole) = probe_capture::ggx_lobe_mean(view, up, up, 0.3).unwrap();
/// let halves = probe_capture::ggx_sub_lobes(view, up, up, 0.3, 2);
/// assert_eq!(halves.len(), 2);
/// let shares: f32 = halves.iter().map(|(_, w)| w).sum();
/// assert!((shares - whole).abs() < 1e-5);
/// // The halves lie on either side of the mean, in the plane of incidence (z = 0).
/// assert!(halves.iter().all(|(d, _)| d.z.abs() < 1e-3));
/// assert!(halves[0].0.y != halves[1].0.y);
/// ```
pub fn ggx_sub_lobes(
    view: Vec3,
    shading_normal: Vec3,
    geometric_normal: Vec3,
    roughness: f32,
    sectors: u32,
) -> Vec<(Vec3, f32)> {
    ggx_sub_lobe_parts(view, shading_normal, geometric_normal, roughness, sectors)
        .into_iter()
        .flatten()
        .collect()
}

/// [`ggx_sub_lobes`] with every part in its place: entry `k` is part `k`'s mean direction and
/// share, or `None` where all its samples fall below the surface. Part `k` of one pixel and
/// part `k` of its neighbour cover the same azimuths about their views, so where the two see
/// one surface from nearly one direction they stand for the same light (what
/// `probe_eval::glossy`'s interleaved sub-lobes share between neighbours).
///
/// ```
/// use glam::Vec3;
/// let up = Vec3::Y;
/// let view = Vec3::new(-(60f32.to_radians().sin()), 60f32.to_radians().cos(), 0.0);
/// let parts = probe_capture::ggx_sub_lobe_parts(view, up, up, 0.3, 4);
/// assert_eq!(parts.len(), 4);
/// let kept: Vec<_> = parts.iter().flatten().copied().collect();
/// assert_eq!(kept, probe_capture::ggx_sub_lobes(view, up, up, 0.3, 4));
/// ```
pub fn ggx_sub_lobe_parts(
    view: Vec3,
    shading_normal: Vec3,
    geometric_normal: Vec3,
    roughness: f32,
    sectors: u32,
) -> Vec<Option<(Vec3, f32)>> {
    let sectors = sectors.clamp(1, MAX_LOBE_SECTORS);
    let n = shading_normal;
    let alpha = (roughness * roughness).max(1e-4);
    let (t, b) = orthonormal_basis(n);
    let local_view = Vec3::new(view.dot(t), view.dot(b), view.dot(n));
    let mut sum = vec![Vec3::ZERO; sectors as usize];
    let mut total = vec![0.0f32; sectors as usize];
    let side = LOBE_MEAN_SIDE;
    for i in 0..side * side {
        let u = Vec2::new(
            ((i % side) as f32 + 0.5) / side as f32,
            ((i / side) as f32 + 0.5) / side as f32,
        );
        let m = sample_ggx_vndf(local_view, alpha, u);
        let local = (2.0 * local_view.dot(m) * m - local_view).normalize();
        if local.z <= 0.0 {
            continue;
        }
        let direction = (t * local.x + b * local.y + n * local.z).normalize();
        if direction.dot(geometric_normal) <= 0.0 {
            continue;
        }
        // `u.y` is the sample's azimuth about the view (`φ = 2π u.y`).
        let sector = ((i / side) * sectors / side) as usize;
        let weight = smith_g1(alpha, local.z);
        sum[sector] += weight * direction;
        total[sector] += weight;
    }
    sum.into_iter()
        .zip(total)
        .map(|(sum, total)| {
            let mean = sum.normalize_or_zero();
            (total > 0.0 && mean != Vec3::ZERO).then(|| (mean, total / (side * side) as f32))
        })
        .collect()
}

/// The roughness whose cone ([`probe_octa::ggx_lobe_angle`] of its `α`) is the cone of one
/// of `sectors` parts of a `roughness` lobe ([`ggx_sub_lobes`]): the lobe's angle over
/// `√sectors` (a part has `1/sectors` of the lobe's solid angle). What a prefiltered lookup
/// of one part blurs by.
///
/// ```
/// let whole = 0.3;
/// assert_eq!(probe_capture::sub_lobe_roughness(whole, 1), whole);
/// assert!(probe_capture::sub_lobe_roughness(whole, 4) < whole);
/// ```
pub fn sub_lobe_roughness(roughness: f32, sectors: u32) -> f32 {
    if sectors <= 1 {
        return roughness;
    }
    let angle = probe_octa::ggx_lobe_angle(roughness * roughness) / (sectors as f32).sqrt();
    probe_octa::ggx_alpha_for_angle(angle).sqrt()
}

/// Secondary reflection rays: `rays_per_pixel` per G-buffer pixel that hit a front face (or a
/// double-sided surface), mirror or GGX-sampled with a seeded generator per pixel. Rays whose
/// direction falls below the surface are left out (they contribute nothing), so a pixel may
/// have fewer rays; each ray's weight already includes `1 / rays_per_pixel`. The list is
/// ordered by pixel.
///
/// # Errors
/// [`RenderError::InvalidSetting`] for `rays_per_pixel` of 0 or a roughness outside
/// `(0, 1]`.
pub fn reflection_rays(
    gbuffer: &GBuffer,
    reflection: Reflection,
    rays_per_pixel: u32,
    seed: u64,
) -> Result<Vec<EvaluationRay>, RenderError> {
    if rays_per_pixel == 0 || rays_per_pixel > 65_536 {
        return Err(RenderError::InvalidSetting {
            parameter: "rays_per_pixel",
            value: rays_per_pixel.to_string(),
            reason: "must be from 1 to 65536",
        });
    }
    if let Reflection::Ggx { roughness } = reflection
        && !(roughness > 0.0 && roughness <= 1.0)
    {
        return Err(RenderError::InvalidSetting {
            parameter: "roughness",
            value: roughness.to_string(),
            reason: "must lie in (0, 1]",
        });
    }
    let share = 1.0 / rays_per_pixel as f32;
    let rays = gbuffer
        .pixels
        .par_iter()
        .enumerate()
        .with_min_len(64)
        .flat_map_iter(|(pixel, sample)| {
            let mut rays = Vec::new();
            let Some(s) = sample.filter(|s| !s.back_face) else {
                return rays.into_iter();
            };
            let mut rng = Rng::for_key(seed, &[REFLECTION_STREAM, pixel as u64]);
            let n = s.shading_normal;
            let v = s.towards_camera;
            for _ in 0..rays_per_pixel {
                let (direction, weight) = match reflection {
                    Reflection::Mirror => ((2.0 * n.dot(v) * n - v).normalize(), 1.0),
                    Reflection::Ggx { roughness } => {
                        let alpha = (roughness * roughness).max(1e-4);
                        let (t, b) = orthonormal_basis(n);
                        let local_view = Vec3::new(v.dot(t), v.dot(b), v.dot(n));
                        let m = sample_ggx_vndf(local_view, alpha, rng.next_vec2());
                        let local = (2.0 * local_view.dot(m) * m - local_view).normalize();
                        let direction = (t * local.x + b * local.y + n * local.z).normalize();
                        let weight = if local.z > 0.0 {
                            smith_g1(alpha, local.z)
                        } else {
                            0.0
                        };
                        (direction, weight)
                    }
                };
                if weight <= 0.0 || direction.dot(s.geometric_normal) <= 0.0 {
                    continue;
                }
                rays.push(EvaluationRay::leaving(pixel, &s, direction, weight * share));
            }
            rays.into_iter()
        })
        .collect();
    Ok(rays)
}

/// The reference for the probe tracer: traces each ray against the BVH and shades the true
/// hit with `shader` (the sky for misses), in parallel. The radiance is the mean of
/// `shading_samples` independent estimates of [`Shader::outgoing_radiance`] at the one hit
/// (at least 1; more lower the noise of the light sampling and bounces, e.g. for ray-by-ray
/// comparisons). Ray `i` draws its random numbers from a generator keyed by `(seed, i)`.
/// `progress` receives `(rays done, rays)` in blocks.
pub fn trace_reference(
    shader: &Shader<'_>,
    rays: &[EvaluationRay],
    shading_samples: u32,
    seed: u64,
    progress: Progress<'_>,
) -> Vec<ReferenceSample> {
    const BLOCK: usize = 1024;
    let shading_samples = shading_samples.max(1);
    let done = AtomicUsize::new(0);
    let total = rays.len();
    rays.par_chunks(BLOCK)
        .enumerate()
        .flat_map_iter(|(block, chunk)| {
            let samples: Vec<ReferenceSample> = chunk
                .iter()
                .enumerate()
                .map(|(i, ray)| {
                    let index = (block * BLOCK + i) as u64;
                    let mut rng = Rng::for_key(seed, &[TRACE_STREAM, index]);
                    let ray = ray.ray();
                    match shader.scene().closest_hit(&ray, f32::INFINITY) {
                        Some(hit) => {
                            let mut sum = Vec3::ZERO;
                            for _ in 0..shading_samples {
                                sum += shader.outgoing_radiance(&hit, -ray.direction, &mut rng);
                            }
                            ReferenceSample {
                                hit: Some(hit),
                                radiance: sum / shading_samples as f32,
                            }
                        }
                        None => ReferenceSample {
                            hit: None,
                            radiance: shader.background(ray.direction),
                        },
                    }
                })
                .collect();
            let d = done.fetch_add(chunk.len(), Ordering::Relaxed) + chunk.len();
            progress(d, total);
            samples.into_iter()
        })
        .collect()
}

/// The image `Σ weight × radiance` per pixel over the rays (e.g. the `glossy1` component from
/// [`trace_reference`]'s radiance, or the probe tracer's).
///
/// # Errors
/// [`RenderError::LengthMismatch`] unless there is one radiance per ray;
/// [`RenderError::InvalidSetting`] for a bad size or a ray whose pixel lies outside it.
pub fn accumulate_rays(
    width: u32,
    height: u32,
    rays: &[EvaluationRay],
    radiance: &[Vec3],
) -> Result<Image, RenderError> {
    check_size(width, height)?;
    if rays.len() != radiance.len() {
        return Err(RenderError::LengthMismatch {
            rays: rays.len(),
            radiance: radiance.len(),
        });
    }
    let mut image = Image::new(width, height);
    for (ray, value) in rays.iter().zip(radiance) {
        let pixel =
            image
                .rgb
                .get_mut(ray.pixel as usize)
                .ok_or_else(|| RenderError::InvalidSetting {
                    parameter: "rays",
                    value: format!("pixel {}", ray.pixel),
                    reason: "lies outside the image",
                })?;
        let add = *value * ray.weight;
        pixel[0] += add.x;
        pixel[1] += add.y;
        pixel[2] += add.z;
    }
    Ok(image)
}

#[cfg(test)]
mod tile_order_tests {
    use super::*;
    use proptest::prelude::*;

    fn rays_of(pixels: &[u32]) -> Vec<EvaluationRay> {
        pixels
            .iter()
            .map(|&pixel| EvaluationRay {
                pixel,
                origin: Vec3::ZERO,
                direction: Vec3::Z,
                weight: 1.0,
            })
            .collect()
    }

    proptest! {
        #![proptest_config(ProptestConfig {
            rng_seed: proptest::test_runner::RngSeed::Fixed(1),
            ..ProptestConfig::default()
        })]
        /// Restoring the tile order gives the items back; the order is a permutation that
        /// visits tiles row by row and keeps each tile's rays in their order.
        #[test]
        fn tile_order_is_an_invertible_tile_sort(
            width in 1u32..40,
            height in 1u32..40,
            rays_per_pixel in 1usize..4,
            skip in proptest::collection::vec(any::<bool>(), 1600),
        ) {
            let pixels: Vec<u32> = (0..width * height)
                .filter(|&p| !skip[p as usize % skip.len()])
                .flat_map(|p| std::iter::repeat_n(p, rays_per_pixel))
                .collect();
            let rays = rays_of(&pixels);
            let order = TileOrder::of(&rays, width);
            prop_assert_eq!(order.len(), rays.len());
            let tiled = order.apply(&rays);
            let key = |r: &EvaluationRay| {
                let (x, y) = (r.pixel % width, r.pixel / width);
                (y / TileOrder::TILE, x / TileOrder::TILE)
            };
            for pair in tiled.windows(2) {
                prop_assert!(key(&pair[0]) <= key(&pair[1]));
                if key(&pair[0]) == key(&pair[1]) {
                    prop_assert!(pair[0].pixel <= pair[1].pixel, "a tile's rays keep their order");
                }
            }
            prop_assert_eq!(order.apply(&(0..rays.len()).collect::<Vec<_>>()), order.indices());
            let indices: Vec<usize> = order.restore(order.indices().to_vec());
            prop_assert_eq!(indices, (0..rays.len()).collect::<Vec<_>>());
        }
    }

    #[test]
    fn mismatched_counts_and_zero_width_keep_the_order() {
        let rays = rays_of(&[0, 9, 1, 8]);
        let order = TileOrder::of(&rays, 0);
        assert_eq!(order.apply(&[1, 2, 3, 4]), vec![1, 2, 3, 4]);
        let order = TileOrder::of(&rays, 16);
        assert_eq!(order.apply(&[1, 2, 3, 4]), vec![1, 3, 2, 4]);
        assert_eq!(order.apply(&[5, 6]), vec![5, 6]);
        assert_eq!(order.restore(vec![5, 6, 7]), vec![5, 6, 7]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vndf_samples_reflect_into_the_upper_hemisphere_mostly() {
        let mut rng = Rng::for_key(5, &[]);
        let view = Vec3::new(0.5, 0.0, 0.866).normalize();
        for (alpha, least) in [(0.01f32, 1990), (0.25, 1800), (1.0, 800)] {
            let mut above = 0;
            for _ in 0..2000 {
                let m = sample_ggx_vndf(view, alpha, rng.next_vec2());
                assert!(m.z >= 0.0 && (m.length() - 1.0).abs() < 1e-4);
                // A visible normal faces the viewer.
                assert!(m.dot(view) >= -1e-5);
                let l = 2.0 * view.dot(m) * m - view;
                above += usize::from(l.z > 0.0);
            }
            assert!(above > least, "alpha {alpha}: {above}");
        }
        // With α = 1 and normal incidence the visible normals are cosine-distributed:
        // E[m.z] = 2/3.
        let mean: f32 = (0..20_000)
            .map(|_| sample_ggx_vndf(Vec3::Z, 1.0, rng.next_vec2()).z)
            .sum::<f32>()
            / 20_000.0;
        assert!((mean - 2.0 / 3.0).abs() < 0.01, "{mean}");
        // Nearly smooth: close to the mirror direction.
        let m = sample_ggx_vndf(view, 1e-4, Vec2::new(0.3, 0.7));
        assert!((m - Vec3::Z).length() < 1e-2);
        assert!((smith_g1(0.5, 1.0) - 1.0).abs() < 1e-6);
        assert!(smith_g1(0.5, 0.1) < smith_g1(0.5, 0.9));
    }

    fn unit(theta: f32, phi: f32) -> Vec3 {
        Vec3::new(
            theta.sin() * phi.cos(),
            theta.cos(),
            theta.sin() * phi.sin(),
        )
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig {
            rng_seed: proptest::test_runner::RngSeed::Fixed(1),
            ..proptest::prelude::ProptestConfig::default()
        })]
        /// For any view above the shading surface, any geometric normal within 60° of the
        /// shading normal and any roughness: the lobe mean is a unit direction above the
        /// geometric surface with a weight in (0, 1], or `None` only when the whole lobe falls
        /// below that surface.
        #[test]
        fn lobe_mean_leaves_above_the_surface(
            view_theta in 0.0f32..1.55,
            view_phi in 0.0f32..std::f32::consts::TAU,
            tilt_theta in 0.0f32..1.05,
            tilt_phi in 0.0f32..std::f32::consts::TAU,
            roughness in 0.02f32..=1.0,
        ) {
            let view = unit(view_theta, view_phi);
            let geometric = unit(tilt_theta, tilt_phi);
            match ggx_lobe_mean(view, Vec3::Y, geometric, roughness) {
                Some((mean, weight)) => {
                    proptest::prop_assert!(mean.is_finite() && (mean.length() - 1.0).abs() < 1e-4);
                    proptest::prop_assert!(mean.dot(geometric) > 0.0, "{mean} below {geometric}");
                    proptest::prop_assert!(weight > 0.0 && weight <= 1.0 + 1e-5, "{weight}");
                }
                None => {
                    // Then not even the mirror direction can leave above both surfaces.
                    let mirror = 2.0 * view.y * Vec3::Y - view;
                    proptest::prop_assert!(
                        roughness > 0.1 || mirror.dot(geometric) <= 0.05,
                        "no mean though the mirror {mirror} leaves above {geometric}"
                    );
                }
            }
        }
    }

    /// The quadrature lobe mean is what many random samples of the same lobe average to
    /// (weight within 2 %, direction within 2°), near normal incidence, at grazing views and
    /// with a geometric surface tilted against the shading normal (as a normal map does).
    #[test]
    fn lobe_mean_is_the_mean_of_the_samples() {
        let mut rng = Rng::for_key(11, &[]);
        let n = Vec3::Y;
        for view_degrees in [5.0f32, 45.0, 80.0, 88.0] {
            let a = view_degrees.to_radians();
            let view = Vec3::new(-a.sin(), a.cos(), 0.0);
            for geometric in [n, Vec3::new(0.15, 1.0, 0.0).normalize()] {
                for roughness in [0.1f32, 0.3, 0.6] {
                    let alpha = roughness * roughness;
                    let (t, b) = orthonormal_basis(n);
                    let local_view = Vec3::new(view.dot(t), view.dot(b), view.dot(n));
                    let (mut sum, mut total, count) = (Vec3::ZERO, 0.0f64, 40_000);
                    for _ in 0..count {
                        let m = sample_ggx_vndf(local_view, alpha, rng.next_vec2());
                        let l = (2.0 * local_view.dot(m) * m - local_view).normalize();
                        let d = (t * l.x + b * l.y + n * l.z).normalize();
                        if l.z > 0.0 && d.dot(geometric) > 0.0 {
                            let w = smith_g1(alpha, l.z);
                            sum += w * d;
                            total += f64::from(w);
                        }
                    }
                    let case = format!("view {view_degrees}°, roughness {roughness}, {geometric}");
                    let Some((mean, weight)) = ggx_lobe_mean(view, n, geometric, roughness) else {
                        assert!(total < 1e-3 * count as f64, "{case}: no mean but {total}");
                        continue;
                    };
                    let sampled = total / count as f64;
                    assert!(
                        (f64::from(weight) - sampled).abs() <= 0.02 * sampled + 1e-3,
                        "{case}: weight {weight} vs {sampled}"
                    );
                    let angle = mean.angle_between(sum.normalize()).to_degrees();
                    assert!(angle < 2.0, "{case}: {angle}° apart");
                    assert!((mean.length() - 1.0).abs() < 1e-4 && mean.dot(geometric) > 0.0);
                }
            }
        }
    }
}
