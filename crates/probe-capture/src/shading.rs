//! The shading core shared by the probe bake and the reference renderer.

use std::f32::consts::PI;

use glam::Vec3;
use probe_scene::{Hit, Light, Ray, Scene};

use crate::environment::Environment;
use crate::rng::{Sampler, SobolSampler, cosine_hemisphere, uniform_triangle};

/// Bounces after which paths are continued by Russian roulette (with probability equal to the
/// largest channel of the path throughput, at most 1). Paths of up to this many bounces are
/// never cut short, so a bake's default single bounce has no roulette noise.
pub const RUSSIAN_ROULETTE_BOUNCES: u32 = 3;

/// Why a [`Shader`] could not be made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ShaderError {
    /// A field of the [`Environment`] is unusable. Fix: give finite, non-negative colours
    /// and illuminance and a non-zero sun direction.
    #[error("environment field `{field}` {reason}")]
    InvalidEnvironment {
        /// The offending field of [`Environment`].
        field: &'static str,
        /// What is wrong with it.
        reason: &'static str,
    },
}

/// Emissive triangles with a power-proportional sampling table.
#[derive(Debug, Default)]
struct Emitters {
    /// Indices into `Scene::triangles`.
    triangles: Vec<u32>,
    /// Normalised cumulative power, one entry per emitter, the last equal to 1.
    cdf: Vec<f32>,
    /// Probability of choosing each emitter.
    pmf: Vec<f32>,
    /// Per scene triangle, its position in the table (`u32::MAX` for non-emitters), for the
    /// light-sampling pdf of a bounce ray that hits an emitter.
    slot_of_triangle: Vec<u32>,
    /// Per emitter, for [`Self::partner_probability`]: its bounding sphere's centre and
    /// radius and its area over its pmf. Empty with more than [`PARTNER_BOUND_EMITTERS`]
    /// emitters (every partner is then cast).
    spheres: Vec<(Vec3, f32, f32)>,
}

impl Emitters {
    fn new(scene: &Scene) -> Emitters {
        let materials = scene.materials();
        let mut triangles = Vec::new();
        let mut powers = Vec::new();
        let mut slot_of_triangle = Vec::new();
        for (index, triangle) in scene.triangles().iter().enumerate() {
            let material = &materials[triangle.material as usize];
            if !material.is_emissive() {
                continue;
            }
            let area = triangle.area();
            let sides = if material.double_sided { 2.0 } else { 1.0 };
            let power = f64::from(area) * f64::from(material.emissive.element_sum()) * sides;
            if power > 0.0 && power.is_finite() {
                if slot_of_triangle.is_empty() {
                    slot_of_triangle = vec![u32::MAX; scene.triangles().len()];
                }
                slot_of_triangle[index] = triangles.len() as u32;
                triangles.push(index as u32);
                powers.push(power);
            }
        }
        let total: f64 = powers.iter().sum();
        let mut running = 0.0f64;
        let mut cdf = Vec::with_capacity(powers.len());
        for &power in &powers {
            running += power;
            cdf.push((running / total) as f32);
        }
        if let Some(last) = cdf.last_mut() {
            *last = 1.0;
        }
        let pmf: Vec<f32> = powers.iter().map(|&p| (p / total) as f32).collect();
        let spheres = if triangles.len() <= PARTNER_BOUND_EMITTERS {
            triangles
                .iter()
                .zip(&pmf)
                .map(|(&index, &pmf)| {
                    let triangle = &scene.triangles()[index as usize];
                    let [a, b, c] = triangle.positions;
                    let centre = (a + b + c) / 3.0;
                    let radius = centre
                        .distance(a)
                        .max(centre.distance(b))
                        .max(centre.distance(c));
                    (centre, radius, triangle.area() / pmf)
                })
                .collect()
        } else {
            Vec::new()
        };
        Emitters {
            triangles,
            cdf,
            pmf,
            slot_of_triangle,
            spheres,
        }
    }

    /// The probability that a path's last point at `position` casts its light sample's
    /// partner ([`Shader::closing_ray`]) under a black sky, where the partner can only meet
    /// emission. Light sampling picks a point on emitter `t` with solid-angle pdf `p_L =
    /// pmf_t d² / (A_t cos θ_y)`, the partner with `p_B = cos θ_x / π`; their ratio
    /// `ρ = p_B / p_L` is at most `ρ_t = A_t / (π pmf_t (d_t − r_t)²)` over the whole emitter
    /// (`d_t`: the distance to its bounding sphere's centre, `r_t` its radius), and the power
    /// heuristic gives what the partner meets a weight `ρ² / (1 + ρ²)`. So with `q ≥ K ρ_max`
    /// (`K` = [`PARTNER_GAIN`]) a partner cast with probability `q` and weighed by `1/q`
    /// adds at most `Le · albedo · ρ_max / K` to a sample: unbiased (the weights are
    /// unchanged) and never a firefly, and where every light is small or far the ray is
    /// saved. 1 inside an emitter's sphere, with many emitters, or none.
    #[inline]
    fn partner_probability(&self, position: Vec3) -> f32 {
        if self.spheres.is_empty() {
            return 1.0;
        }
        let mut reach = 0.0f32;
        for &(centre, radius, area_over_pmf) in &self.spheres {
            let gap = centre.distance(position) - radius;
            if gap.is_nan() || gap <= 0.0 {
                return 1.0;
            }
            reach = reach.max(area_over_pmf / (PI * gap * gap));
        }
        if reach.is_finite() {
            (PARTNER_GAIN * reach).clamp(PARTNER_MIN, 1.0)
        } else {
            1.0
        }
    }

    /// The solid-angle pdf with which light sampling from `surface` picks the point `hit` on
    /// an emissive triangle, seen at squared distance `distance_squared` and cosine
    /// `light_cosine`; `None` for a triangle that is not in the table.
    #[inline]
    fn solid_angle_pdf(
        &self,
        scene: &Scene,
        triangle: u32,
        distance_squared: f32,
        light_cosine: f32,
    ) -> Option<f32> {
        let slot = *self.slot_of_triangle.get(triangle as usize)?;
        if slot == u32::MAX || light_cosine <= 0.0 {
            return None;
        }
        let area = scene.triangles()[triangle as usize].area();
        Some(self.pmf[slot as usize] / area * distance_squared / light_cosine)
    }

    /// Picks an emitter for a uniform `u` ([`Self::pick`]) and rescales `u` within the
    /// emitter's share of `[0, 1)` to a uniform number of its own.
    #[inline]
    fn pick_rescaled(&self, u: f32) -> (usize, f32) {
        let slot = self.pick(u);
        let below = if slot == 0 { 0.0 } else { self.cdf[slot - 1] };
        let along = ((u - below) / self.pmf[slot]).clamp(0.0, 1.0 - f32::EPSILON);
        (slot, if along.is_finite() { along } else { 0.5 })
    }

    /// Picks an emitter for a uniform `u`: its position in the table.
    #[inline]
    fn pick(&self, u: f32) -> usize {
        self.cdf
            .partition_point(|&c| c <= u)
            .min(self.cdf.len() - 1)
    }
}

/// A surface point ready for shading, seen from one side.
#[derive(Clone, Copy, Debug)]
struct Surface {
    position: Vec3,
    /// The plane normal on the viewer's side.
    geometric_normal: Vec3,
    /// The shading normal on the viewer's side.
    shading_normal: Vec3,
    albedo: Vec3,
    triangle: u32,
}

impl Surface {
    /// The cosine at the shading normal of light arriving from unit `direction`, if the light
    /// reaches the front of both normals.
    #[inline]
    fn cosine_towards(&self, direction: Vec3) -> Option<f32> {
        let cosine = self.shading_normal.dot(direction);
        (cosine > 0.0 && self.geometric_normal.dot(direction) > 0.0).then_some(cosine)
    }

    /// The unit direction to `point`, the squared distance and the cosine of
    /// [`Self::cosine_towards`]; `None` when `point` is on the surface point or behind it.
    #[inline]
    fn towards_point(&self, point: Vec3) -> Option<(Vec3, f32, f32)> {
        let to_point = point - self.position;
        let distance_squared = to_point.length_squared();
        if distance_squared <= 0.0 {
            return None;
        }
        let direction = to_point / distance_squared.sqrt();
        let cosine = self.cosine_towards(direction)?;
        Some((direction, distance_squared, cosine))
    }
}

/// The shading core: the radiance leaving a surface point towards a viewer, used unchanged by
/// the probe bake ([`crate::bake`]) and the reference renderer ([`crate::render`],
/// [`crate::trace_reference`]), so that both "shade the true hit the same way".
///
/// # Model
/// - **Surfaces are Lambertian** with the material's base colour as albedo (the probes'
///   assumption). Metalness and roughness are ignored.
/// - **Sides.** Single-sided materials reflect and emit from their front face only (glTF
///   `doubleSided = false`): their back faces, seen only from inside solids or through
///   modelling gaps, are black and still block light. Double-sided materials act on both
///   faces with the normal flipped towards the viewer.
/// - **Emission** is the material's `emissive` radiance, seen directly by the first ray.
/// - **Direct light** at every surface point: the scene's punctual lights (point and spot with
///   `KHR_lights_punctual`'s inverse-square law, smooth range window and squared cone
///   fall-off; intensity in candela is taken as radiant intensity, so a point light of
///   intensity `I` gives irradiance `I cos θ / r²`), its directional lights and the
///   environment's sun (illuminance times colour times `cos θ`), each with one shadow ray;
///   one emissive triangle sampled as an area light (chosen in proportion to its power,
///   a uniform point on it, one shadow ray); and the sky (see below).
/// - **Bounces.** Each of `bounces` extra bounces continues the path in a cosine-distributed
///   direction; where it hits a surface, that surface's direct light is added. Paths longer
///   than [`RUSSIAN_ROULETTE_BOUNCES`] continue by Russian roulette.
/// - **Multiple importance sampling.** At a point that bounces further, emissive triangles
///   are reached by both strategies, the light sample and the bounce ray (which counts the
///   emission it hits), weighted by the power heuristic (Veach 1997), so surfaces next to a
///   large emitter, where light sampling alone has high variance, get the bounce ray's
///   low-variance estimate. At the last point of a path, one more cosine-distributed ray
///   (which also samples the sky) is the light sample's partner; in a scene without
///   emissive triangles, where there is nothing to weigh, a shadow ray towards the sky alone.
///   Punctual lights and the sun are delta lights (light sampling only); the sky is reached
///   by the cosine-distributed ray (bounce or shadow ray), its own importance sample.
/// - **Sky.** At a point that bounces further, the bounce ray itself samples the sky (a ray
///   that leaves the scene adds the sky radiance); at the last point of a path one
///   cosine-distributed ray does. A black sky costs no rays where there are no emitters.
///
/// With `bounces = 0` the result is emission plus direct light; with many bounces it is full
/// global illumination.
pub struct Shader<'s> {
    scene: &'s Scene,
    environment: Environment,
    bounces: u32,
    emitters: Emitters,
    sun: Option<(Vec3, Vec3)>,
    sky_is_black: bool,
    /// 16 ulps of the scene's largest coordinate: past a surface point's rounding off its
    /// plane, for rays leaving the point itself ([`Self::hit_from_point`]).
    departure: f32,
}

impl std::fmt::Debug for Shader<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Shader")
            .field("scene", &self.scene.name())
            .field("environment", &self.environment)
            .field("bounces", &self.bounces)
            .field("emissive_triangles", &self.emitters.triangles.len())
            .finish()
    }
}

impl<'s> Shader<'s> {
    /// A shader for `scene` lit by its own lights and emitters plus `environment`, adding
    /// `bounces` diffuse bounces to the direct light.
    ///
    /// # Errors
    /// [`ShaderError::InvalidEnvironment`] for non-finite or negative environment values.
    pub fn new(
        scene: &'s Scene,
        environment: Environment,
        bounces: u32,
    ) -> Result<Shader<'s>, ShaderError> {
        environment
            .check()
            .map_err(|(field, reason)| ShaderError::InvalidEnvironment { field, reason })?;
        let sun = (environment.sun_illuminance > 0.0 && environment.sun_color.max_element() > 0.0)
            .then(|| {
                (
                    -environment.sun_direction.normalize(),
                    environment.sun_irradiance(),
                )
            });
        Ok(Shader {
            scene,
            environment,
            bounces,
            emitters: Emitters::new(scene),
            sun,
            sky_is_black: environment.sky_is_black(),
            departure: departure(scene),
        })
    }

    /// The scene this shader lights.
    pub fn scene(&self) -> &'s Scene {
        self.scene
    }

    /// The environment (sun and sky).
    pub fn environment(&self) -> &Environment {
        &self.environment
    }

    /// The number of extra diffuse bounces after direct light.
    pub fn bounces(&self) -> u32 {
        self.bounces
    }

    /// Number of emissive triangles sampled as area lights.
    pub fn emissive_triangle_count(&self) -> usize {
        self.emitters.triangles.len()
    }

    /// Radiance of a ray that leaves the scene in unit direction `direction` (the sky).
    #[inline]
    pub fn background(&self, direction: Vec3) -> Vec3 {
        self.environment.sky_radiance(direction)
    }

    /// Radiance arriving along `ray` (origin already off any surface): the shaded closest hit
    /// or the sky, with the hit.
    pub fn trace<S: Sampler + ?Sized>(&self, ray: &Ray, rng: &mut S) -> (Option<Hit>, Vec3) {
        self.trace_path(ray, false, rng)
    }

    /// Radiance leaving the hit point towards the viewer (`towards_viewer`, a unit vector from
    /// the hit back along the incoming ray): emission plus direct light plus the configured
    /// bounces (see the type's documentation for the model).
    pub fn outgoing_radiance<S: Sampler + ?Sized>(
        &self,
        hit: &Hit,
        towards_viewer: Vec3,
        rng: &mut S,
    ) -> Vec3 {
        self.path_radiance(hit, towards_viewer, false, rng)
    }

    /// [`Self::trace`] with [`Self::indirect_radiance`] at the hit: the radiance a bake of
    /// [`BakedRadiance::Indirect`](crate::BakedRadiance::Indirect) stores.
    pub fn trace_indirect<S: Sampler + ?Sized>(
        &self,
        ray: &Ray,
        rng: &mut S,
    ) -> (Option<Hit>, Vec3) {
        self.trace_path(ray, true, rng)
    }

    /// [`Self::trace`] (`indirect`: [`Self::trace_indirect`]).
    fn trace_path<S: Sampler + ?Sized>(
        &self,
        ray: &Ray,
        indirect: bool,
        rng: &mut S,
    ) -> (Option<Hit>, Vec3) {
        match self.scene.closest_hit(ray, f32::INFINITY) {
            Some(hit) => {
                let radiance = self.path_radiance(&hit, -ray.direction, indirect, rng);
                (Some(hit), radiance)
            }
            None => (None, self.background(ray.direction)),
        }
    }

    /// Radiance leaving the hit towards the viewer less its emission and less the light
    /// sources' direct light at the hit (the punctual lights, the sun and the emissive
    /// triangles: what [`Self::direct_irradiance`] computes with shadow rays): the light the
    /// hit reflects from the sky and from the surfaces around it, with the configured bounces.
    /// A renderer that casts shadow rays at its hits adds the rest itself
    /// ([`Self::radiance_with_reflected`]); its expectation plus theirs is
    /// [`Self::outgoing_radiance`]'s. With `bounces = 0` it is the sky's light alone.
    pub fn indirect_radiance<S: Sampler + ?Sized>(
        &self,
        hit: &Hit,
        towards_viewer: Vec3,
        rng: &mut S,
    ) -> Vec3 {
        self.path_radiance(hit, towards_viewer, true, rng)
    }

    /// The path behind [`Self::outgoing_radiance`]; `indirect` leaves out the hit's emission,
    /// its light sources' samples and the emission its bounce ray meets (their MIS partner).
    fn path_radiance<S: Sampler + ?Sized>(
        &self,
        hit: &Hit,
        towards_viewer: Vec3,
        indirect: bool,
        rng: &mut S,
    ) -> Vec3 {
        let mut radiance = if indirect {
            Vec3::ZERO
        } else {
            self.emission(hit, towards_viewer)
        };
        let mut throughput = Vec3::ONE;
        let mut current = *hit;
        let mut towards = towards_viewer;
        let mut bounce = 0u32;
        while let Some(surface) = self.surface(&current, towards) {
            if surface.albedo.max_element() <= 0.0 {
                break;
            }
            let last = bounce >= self.bounces;
            // The light sources at the hit itself are left out of an indirect path.
            let first_indirect = indirect && bounce == 0;
            // With emissive triangles, the light sample at the last point has a partner too:
            // one cosine-distributed ray ([`Self::closing_ray`]).
            let emitters = !self.emitters.triangles.is_empty();
            let mut direct = if first_indirect {
                Vec3::ZERO
            } else {
                self.light_sources(&surface, !last || emitters, rng)
            };
            if last {
                if emitters {
                    // Under a black sky the partner only meets emission, which its MIS
                    // weight keeps small where every light is small or far: cast it with a
                    // probability and weigh it by the inverse ([`Emitters::partner_probability`]).
                    let cast = if self.sky_is_black {
                        self.emitters.partner_probability(surface.position)
                    } else {
                        1.0
                    };
                    if cast >= 1.0 || rng.next_f32() < cast {
                        direct += self.closing_ray(&surface, !first_indirect, rng) / cast;
                    }
                } else if !self.sky_is_black {
                    direct += self.sky_light(&surface, rng);
                }
                radiance += throughput * direct;
                break;
            }
            radiance += throughput * direct;
            let direction = cosine_hemisphere(surface.shading_normal, rng.next_vec2());
            if direction.dot(surface.geometric_normal) <= 0.0 {
                break;
            }
            let bsdf_pdf = surface.shading_normal.dot(direction).max(0.0) / PI;
            // Cosine sampling cancels the cosine and the 1/π of the Lambertian BRDF.
            throughput *= surface.albedo;
            if bounce >= RUSSIAN_ROULETTE_BOUNCES {
                let survive = throughput.max_element().min(1.0);
                if rng.next_f32() >= survive {
                    break;
                }
                throughput /= survive;
            }
            let ray = Ray::from_surface(surface.position, surface.geometric_normal, direction);
            match self.scene.closest_hit(&ray, f32::INFINITY) {
                Some(next) => {
                    if !first_indirect {
                        radiance +=
                            throughput * self.emission_by_bounce(&next, direction, bsdf_pdf);
                    }
                    current = next;
                    towards = -direction;
                    bounce += 1;
                }
                None => {
                    radiance += throughput * self.background(direction);
                    break;
                }
            }
        }
        radiance
    }

    /// Radiance arriving along `ray` less the emission of the surface it hits: the light
    /// that surface reflects (with the configured bounces), or the sky for a miss. This is
    /// what a bake's irradiance maps integrate ([`ProbeBake::irradiance`]), so a renderer
    /// adding the light sources with shadow rays of its own counts none twice.
    ///
    /// [`ProbeBake::irradiance`]: crate::ProbeBake::irradiance
    pub fn reflected_radiance<S: Sampler + ?Sized>(&self, ray: &Ray, rng: &mut S) -> Vec3 {
        match self.scene.closest_hit(ray, f32::INFINITY) {
            Some(hit) => {
                let towards_viewer = -ray.direction;
                (self.outgoing_radiance(&hit, towards_viewer, rng)
                    - self.emission(&hit, towards_viewer))
                .max(Vec3::ZERO)
            }
            None => self.background(ray.direction),
        }
    }

    /// Direct irradiance at a surface point (normals already turned to the viewer's side, as
    /// a [`GBufferSample`](crate::GBufferSample)'s): every punctual and directional light and
    /// the sun with one shadow ray each, plus the emissive triangles' irradiance from
    /// `emitter_samples` light samples (each with its shadow ray) and half as many
    /// cosine-distributed rays (rounded up) that count the emission they meet, weighted by
    /// multiple importance sampling and stratified by a scrambled Sobol sequence seeded from
    /// `rng` (`triangle`, the point's own, is never its own light). The sky is not included:
    /// the probes' irradiance holds it. Multiply by a diffuse albedo over π for reflected
    /// radiance.
    ///
    /// Against the mean of `emitter_samples` independent light samples, the estimate's
    /// squared error is 21× lower on the built-in Cornell box and 47× lower on the shared Cornell
    /// glTF, whose ceiling sits 1 cm above its light (16 samples; the `direct_light_variance`
    /// example, BENCHMARKS.md "Light samples with partners").
    pub fn direct_irradiance<S: Sampler + ?Sized>(
        &self,
        position: Vec3,
        geometric_normal: Vec3,
        shading_normal: Vec3,
        triangle: u32,
        emitter_samples: u32,
        rng: &mut S,
    ) -> Vec3 {
        let surface = Surface {
            position,
            geometric_normal,
            shading_normal,
            albedo: Vec3::ONE,
            triangle,
        };
        let mut incident = Vec3::ZERO;
        for light in self.scene.lights() {
            incident += self.punctual(&surface, light);
        }
        if let Some((towards_sun, irradiance)) = self.sun {
            incident += self.directional(&surface, towards_sun, irradiance);
        }
        if !self.emitters.triangles.is_empty() && emitter_samples > 0 {
            let cosine_samples = emitter_samples.div_ceil(2);
            incident += self.emitter_irradiance(&surface, emitter_samples, cosine_samples, rng);
        }
        incident
    }

    /// The emissive triangles' irradiance at `surface` from `light_samples` samples of the
    /// emitters (by power, then uniform in area) and `cosine_samples` cosine-distributed rays
    /// that count the emission they meet, combined by the power heuristic (Veach 1997) with
    /// the sample counts. Each strategy's samples are the first points of an Owen-scrambled
    /// Sobol (0,2)-sequence ([`SobolSampler`]) keyed by two draws of `rng`; a light sample's
    /// first coordinate both picks the emitter and, rescaled within its share, places the
    /// point, so the samples stay stratified over the emitters' whole area.
    fn emitter_irradiance<S: Sampler + ?Sized>(
        &self,
        surface: &Surface,
        light_samples: u32,
        cosine_samples: u32,
        rng: &mut S,
    ) -> Vec3 {
        let key = (u64::from(rng.next_f32().to_bits()) << 32) | u64::from(rng.next_f32().to_bits());
        let (light_count, cosine_count) = (light_samples as f32, cosine_samples as f32);
        let point =
            |stream: u64, index: u32| SobolSampler::for_key(key, &[stream], index).next_vec2();
        let mut by_lights = Vec3::ZERO;
        for index in 0..light_samples {
            let u = point(0, index);
            let (slot, along) = self.emitters.pick_rescaled(u.x);
            let barycentrics = uniform_triangle(glam::Vec2::new(along, u.y));
            by_lights +=
                self.emitter_sample_at(surface, slot, barycentrics, |light_pdf, cosine| {
                    power_heuristic(light_count * light_pdf, cosine_count * cosine / PI)
                });
        }
        let mut by_rays = Vec3::ZERO;
        for index in 0..cosine_samples {
            let direction = cosine_hemisphere(surface.shading_normal, point(1, index));
            if direction.dot(surface.geometric_normal) <= 0.0 {
                continue;
            }
            let Some(hit) = self.hit_from_point(surface, direction) else {
                continue;
            };
            if hit.triangle == surface.triangle {
                continue;
            }
            let Some((emitted, light_pdf)) = self.emission_met(&hit, direction) else {
                continue;
            };
            let cosine_pdf = surface.shading_normal.dot(direction).max(0.0) / PI;
            let weight = light_pdf.map_or(1.0, |light_pdf| {
                power_heuristic(cosine_count * cosine_pdf, light_count * light_pdf)
            });
            // Cosine sampling: L cos / pdf = π L.
            by_rays += emitted * (weight * PI);
        }
        let mut irradiance = Vec3::ZERO;
        if light_samples > 0 {
            irradiance += by_lights / light_count;
        }
        if cosine_samples > 0 {
            irradiance += by_rays / cosine_count;
        }
        irradiance
    }

    /// The normals of the hit as a viewer at `towards_viewer` sees it (geometric, shading;
    /// both on the viewer's side), or `None` for the back of a single-sided material, which
    /// reflects nothing.
    pub fn visible_normals(&self, hit: &Hit, towards_viewer: Vec3) -> Option<(Vec3, Vec3)> {
        self.surface(hit, towards_viewer)
            .map(|s| (s.geometric_normal, s.shading_normal))
    }

    /// Radiance leaving the hit towards the viewer when the light the surfaces around it
    /// reflect (and the sky) is known as the irradiance `indirect_irradiance` at it (from
    /// irradiance probes, for instance, which hold exactly that): emission plus the Lambertian
    /// albedo over π times the direct irradiance ([`Self::direct_irradiance`], exact shadow
    /// rays, `emitter_samples` emitter samples) and `indirect_irradiance`. Every surface
    /// beyond the primary hit is Lambertian in this model, as in
    /// [`Self::outgoing_radiance`]; the back of a single-sided material gives its emission
    /// only (zero).
    pub fn radiance_with_indirect<S: Sampler + ?Sized>(
        &self,
        hit: &Hit,
        towards_viewer: Vec3,
        indirect_irradiance: Vec3,
        emitter_samples: u32,
        rng: &mut S,
    ) -> Vec3 {
        self.lit_by_sources(
            hit,
            towards_viewer,
            emitter_samples,
            rng,
            |emitted, albedo, direct| {
                emitted + albedo * (direct + indirect_irradiance) * (1.0 / PI)
            },
        )
    }

    /// Radiance leaving the hit towards the viewer when the light it reflects from its
    /// surroundings and the sky is known as the radiance `reflected` (from probes holding
    /// [`Self::indirect_radiance`], for instance): emission plus the Lambertian albedo over π
    /// times the direct irradiance of the light sources ([`Self::direct_irradiance`], exact
    /// shadow rays, `emitter_samples` emitter samples) plus `reflected`. The back of a
    /// single-sided material gives its emission only (zero).
    pub fn radiance_with_reflected<S: Sampler + ?Sized>(
        &self,
        hit: &Hit,
        towards_viewer: Vec3,
        reflected: Vec3,
        emitter_samples: u32,
        rng: &mut S,
    ) -> Vec3 {
        self.lit_by_sources(
            hit,
            towards_viewer,
            emitter_samples,
            rng,
            |emitted, albedo, direct| emitted + albedo * direct * (1.0 / PI) + reflected,
        )
    }

    /// `light(emission, albedo, direct irradiance)` for the hit's surface as seen from
    /// `towards_viewer` ([`Self::direct_irradiance`] with `emitter_samples`); the emission
    /// alone for the back of a single-sided material.
    fn lit_by_sources<S: Sampler + ?Sized>(
        &self,
        hit: &Hit,
        towards_viewer: Vec3,
        emitter_samples: u32,
        rng: &mut S,
        light: impl FnOnce(Vec3, Vec3, Vec3) -> Vec3,
    ) -> Vec3 {
        let emitted = self.emission(hit, towards_viewer);
        let Some(surface) = self.surface(hit, towards_viewer) else {
            return emitted;
        };
        let direct = self.direct_irradiance(
            surface.position,
            surface.geometric_normal,
            surface.shading_normal,
            surface.triangle,
            emitter_samples,
            rng,
        );
        light(emitted, surface.albedo, direct)
    }

    /// Emitted radiance of the hit towards the viewer: the material's emission on the side it
    /// emits from, zero otherwise.
    #[inline]
    pub fn emission(&self, hit: &Hit, towards_viewer: Vec3) -> Vec3 {
        self.scene.materials()[hit.material as usize]
            .emission_towards(hit.geometric_normal, towards_viewer)
    }

    /// The emission a bounce ray (unit `direction`, sampled with solid-angle pdf `bsdf_pdf`)
    /// picks up at its hit, with the power heuristic's weight against light sampling.
    #[inline]
    fn emission_by_bounce(&self, hit: &Hit, direction: Vec3, bsdf_pdf: f32) -> Vec3 {
        let Some((emitted, light_pdf)) = self.emission_met(hit, direction) else {
            return Vec3::ZERO;
        };
        match light_pdf {
            Some(light_pdf) => emitted * power_heuristic(bsdf_pdf, light_pdf),
            // Not in the light table (no light sample can reach it): the bounce ray is the
            // only strategy.
            None => emitted,
        }
    }

    /// What a ray in unit `direction` meets at `hit` for multiple importance sampling: the
    /// emission sent back along it and the solid-angle pdf with which light sampling picks
    /// that point (`None` for a triangle not in the light table); `None` where nothing is
    /// emitted.
    #[inline]
    fn emission_met(&self, hit: &Hit, direction: Vec3) -> Option<(Vec3, Option<f32>)> {
        let emitted = self.emission(hit, -direction);
        if emitted.max_element() <= 0.0 {
            return None;
        }
        let light_cosine = hit.geometric_normal.dot(direction).abs();
        let light_pdf =
            self.emitters
                .solid_angle_pdf(self.scene, hit.triangle, hit.t * hit.t, light_cosine);
        Some((emitted, light_pdf))
    }

    /// The surface as seen from `towards_viewer`, or `None` for the back of a single-sided
    /// material (black).
    #[inline]
    fn surface(&self, hit: &Hit, towards_viewer: Vec3) -> Option<Surface> {
        let material = &self.scene.materials()[hit.material as usize];
        let (facing, geometric_normal, shading_normal) = normals_towards(hit, towards_viewer);
        if !facing && !material.double_sided {
            return None;
        }
        Some(Surface {
            position: hit.position,
            geometric_normal,
            shading_normal,
            albedo: material.base_color,
            triangle: hit.triangle,
        })
    }

    /// Reflected direct light of the light sources at a surface: punctual and directional
    /// lights, the sun and one emitter sample. With `mis` the emitter sample carries its MIS
    /// weight against a cosine-distributed ray (the bounce ray where the path goes on, else
    /// [`Self::closing_ray`]).
    fn light_sources<S: Sampler + ?Sized>(
        &self,
        surface: &Surface,
        mis: bool,
        rng: &mut S,
    ) -> Vec3 {
        let brdf = surface.albedo * (1.0 / PI);
        // Sum of irradiance-like terms (radiance × cosine / pdf), multiplied by the BRDF once.
        let mut incident = Vec3::ZERO;
        for light in self.scene.lights() {
            incident += self.punctual(surface, light);
        }
        if let Some((towards_sun, irradiance)) = self.sun {
            incident += self.directional(surface, towards_sun, irradiance);
        }
        if !self.emitters.triangles.is_empty() {
            incident += self.emitter_sample(surface, mis, rng);
        }
        brdf * incident
    }

    /// The last point of a path in a scene with emissive triangles: one cosine-distributed
    /// ray, the light sample's MIS partner. It reflects the emission it meets with the power
    /// heuristic's weight (only with `emission`; an indirect path's first point leaves it
    /// out) or, leaving the scene, the sky.
    fn closing_ray<S: Sampler + ?Sized>(
        &self,
        surface: &Surface,
        emission: bool,
        rng: &mut S,
    ) -> Vec3 {
        let direction = cosine_hemisphere(surface.shading_normal, rng.next_vec2());
        if direction.dot(surface.geometric_normal) <= 0.0 {
            return Vec3::ZERO;
        }
        // Cosine sampling: BRDF × L × cos / pdf = albedo × L.
        match self.hit_from_point(surface, direction) {
            Some(hit) if emission => {
                let bsdf_pdf = surface.shading_normal.dot(direction).max(0.0) / PI;
                surface.albedo * self.emission_by_bounce(&hit, direction, bsdf_pdf)
            }
            Some(_) => Vec3::ZERO,
            None => surface.albedo * self.background(direction),
        }
    }

    /// The closest hit of the ray leaving the surface point itself in unit `direction` (in
    /// front of its plane), `t` measured from the point. A cosine-distributed ray that is a
    /// light sample's MIS partner starts here rather than at [`Ray::from_surface`]'s offset
    /// origin: the two strategies must see a light over the same solid angle, and at large
    /// coordinates the offset (256 ulps: 1.6 cm at 1 km) stands measurably closer to a light a
    /// few centimetres away (the light-transport tests' 1 km cases).
    #[inline]
    fn hit_from_point(&self, surface: &Surface, direction: Vec3) -> Option<Hit> {
        let cosine = surface.geometric_normal.dot(direction).max(1e-6);
        let ray = Ray {
            origin: surface.position,
            direction,
        };
        self.scene
            .closest_hit_between(&ray, self.departure / cosine, f32::INFINITY)
    }

    /// The sky's reflected light at the last point of a path in a scene without emissive
    /// triangles: one cosine-distributed shadow ray (the caller skips it under a black sky).
    fn sky_light<S: Sampler + ?Sized>(&self, surface: &Surface, rng: &mut S) -> Vec3 {
        let direction = cosine_hemisphere(surface.shading_normal, rng.next_vec2());
        if direction.dot(surface.geometric_normal) > 0.0 {
            let ray = Ray::from_surface(surface.position, surface.geometric_normal, direction);
            if !self.scene.occluded(&ray, f32::INFINITY) {
                // Cosine sampling: BRDF × L × cos / pdf = albedo × L.
                return surface.albedo * self.background(direction);
            }
        }
        Vec3::ZERO
    }

    /// Irradiance from a punctual light (colour × intensity × attenuation × cos θ / r²), with
    /// its shadow ray.
    fn punctual(&self, surface: &Surface, light: &Light) -> Vec3 {
        match light {
            Light::Directional {
                direction,
                color,
                illuminance,
                ..
            } => self.directional(surface, -*direction, *color * *illuminance),
            Light::Point {
                position,
                color,
                intensity,
                range,
                ..
            } => self.local_light(surface, *position, *color * *intensity, *range, None),
            Light::Spot {
                position,
                direction,
                color,
                intensity,
                inner_cone,
                outer_cone,
                range,
                ..
            } => self.local_light(
                surface,
                *position,
                *color * *intensity,
                *range,
                Some((*direction, inner_cone.cos(), outer_cone.cos())),
            ),
        }
    }

    /// Irradiance from a light at infinity in unit direction `towards_light`.
    #[inline]
    fn directional(&self, surface: &Surface, towards_light: Vec3, irradiance: Vec3) -> Vec3 {
        let Some(cosine) = surface.cosine_towards(towards_light) else {
            return Vec3::ZERO;
        };
        if irradiance.max_element() <= 0.0 {
            return Vec3::ZERO;
        }
        let ray = Ray::from_surface(surface.position, surface.geometric_normal, towards_light);
        if self.scene.occluded(&ray, f32::INFINITY) {
            Vec3::ZERO
        } else {
            irradiance * cosine
        }
    }

    /// Irradiance from a point or spot light (`spot` = axis, cos inner, cos outer).
    fn local_light(
        &self,
        surface: &Surface,
        position: Vec3,
        intensity: Vec3,
        range: Option<f32>,
        spot: Option<(Vec3, f32, f32)>,
    ) -> Vec3 {
        if intensity.max_element() <= 0.0 {
            return Vec3::ZERO;
        }
        let Some((towards_light, distance_squared, cosine)) = surface.towards_point(position)
        else {
            return Vec3::ZERO;
        };
        let distance = distance_squared.sqrt();
        let mut attenuation = 1.0 / distance_squared;
        if let Some(range) = range {
            // KHR_lights_punctual's recommended window: clamp(1 − (d/range)⁴, 0, 1) / d².
            attenuation *= (1.0 - (distance / range).powi(4)).clamp(0.0, 1.0);
        }
        if let Some((axis, cos_inner, cos_outer)) = spot {
            let scale = 1.0 / (cos_inner - cos_outer).max(1e-3);
            let along = axis.dot(-towards_light);
            let t = ((along - cos_outer) * scale).clamp(0.0, 1.0);
            attenuation *= t * t;
        }
        if attenuation <= 0.0 {
            return Vec3::ZERO;
        }
        if self.blocked(surface, position, 1.0) {
            Vec3::ZERO
        } else {
            intensity * (attenuation * cosine)
        }
    }

    /// Whether anything lies between the surface point and a light at `target` (a point
    /// light, or a point on an emitter whose plane the shadow ray meets at cosine
    /// `light_cosine`).
    ///
    /// The shadow ray starts at the surface's offset origin ([`Ray::from_surface`]), and its
    /// direction and length are measured **from that origin**, so that it ends on the target
    /// itself. (Measured from the un-offset hit point instead, the ray runs parallel to the
    /// intended one, past the target by the offset: a surface parallel to a nearby emitter
    /// then saw the emitter's own plane as a blocker, more so at large coordinates.) It stops
    /// short of the target by [`shadow_limit`]'s margin, so the light's own surface never
    /// occludes it. The geometric terms of the estimate stay those of the hit point itself.
    #[inline]
    fn blocked(&self, surface: &Surface, target: Vec3, light_cosine: f32) -> bool {
        let origin = Ray::from_surface(
            surface.position,
            surface.geometric_normal,
            target - surface.position,
        )
        .origin;
        let to_target = target - origin;
        let distance = to_target.length();
        if !distance.is_finite() || distance <= 0.0 {
            return false;
        }
        let ray = Ray {
            origin,
            direction: to_target / distance,
        };
        let limit = shadow_limit(origin, target, distance, light_cosine);
        limit > 0.0 && self.scene.occluded(&ray, limit)
    }

    /// One emissive-triangle sample: `Le · cos θx · cos θy / (r² · pdf_area)`, times the power
    /// heuristic's weight against the cosine-distributed bounce ray when `mis`.
    fn emitter_sample<S: Sampler + ?Sized>(
        &self,
        surface: &Surface,
        mis: bool,
        rng: &mut S,
    ) -> Vec3 {
        let slot = self.emitters.pick(rng.next_f32());
        let barycentrics = uniform_triangle(rng.next_vec2());
        let weight = |light_pdf: f32, cosine: f32| {
            if mis {
                power_heuristic(light_pdf, cosine / PI)
            } else {
                1.0
            }
        };
        self.emitter_sample_at(surface, slot, barycentrics, weight)
    }

    /// The emissive-triangle sample at `barycentrics` on the emitter in table position
    /// `slot`: `Le · cos θx · cos θy / (r² · pdf_area)` times `weight(its solid-angle pdf,
    /// the cosine at the surface)`.
    #[inline]
    fn emitter_sample_at(
        &self,
        surface: &Surface,
        slot: usize,
        barycentrics: glam::Vec2,
        weight: impl FnOnce(f32, f32) -> f32,
    ) -> Vec3 {
        let index = self.emitters.triangles[slot];
        if index == surface.triangle {
            return Vec3::ZERO;
        }
        let triangle = &self.scene.triangles()[index as usize];
        let material = &self.scene.materials()[triangle.material as usize];
        let point = triangle.point(barycentrics);
        let Some((towards_light, distance_squared, cosine)) = surface.towards_point(point) else {
            return Vec3::ZERO;
        };
        let mut light_cosine = -triangle.geometric_normal().dot(towards_light);
        if material.double_sided {
            light_cosine = light_cosine.abs();
        }
        if light_cosine <= 0.0 {
            return Vec3::ZERO;
        }
        let area = triangle.area();
        let pdf_area = self.emitters.pmf[slot] / area;
        if pdf_area.is_nan() || pdf_area <= 0.0 {
            return Vec3::ZERO;
        }
        if self.blocked(surface, point, light_cosine) {
            return Vec3::ZERO;
        }
        let weight = weight(pdf_area * distance_squared / light_cosine, cosine);
        material.emissive * (weight * cosine * light_cosine / (distance_squared * pdf_area))
    }
}

/// 16 ulps of the largest coordinate of `scene`'s bounds (at least of 1/32): how far a
/// surface point's rounding can leave it off its own plane, with room for the triangle
/// test's own rounding.
fn departure(scene: &Scene) -> f32 {
    let bounds = scene.bounds();
    let largest = bounds
        .min
        .abs()
        .max(bounds.max.abs())
        .max_element()
        .max(1.0 / 32.0);
    let largest = if largest.is_finite() { largest } else { 1.0 };
    16.0 * (f32::from_bits(largest.to_bits() + 1) - largest)
}

/// [`Emitters::partner_probability`]'s gain `K`: the partner is always cast where some
/// emitter's bound `ρ_t` reaches 1/4.
const PARTNER_GAIN: f32 = 4.0;

/// [`Emitters::partner_probability`]'s floor: at least one path's last point in eight casts
/// the partner.
const PARTNER_MIN: f32 = 0.125;

/// Above this many emissive triangles every partner is cast (the bound is a loop over them).
const PARTNER_BOUND_EMITTERS: usize = 64;

/// The power heuristic (β = 2) weight of a sample drawn with pdf `chosen` against another
/// strategy with pdf `other` at the same point.
#[inline]
fn power_heuristic(chosen: f32, other: f32) -> f32 {
    let (a, b) = (chosen * chosen, other * other);
    if !a.is_finite() {
        return 1.0;
    }
    if a + b > 0.0 { a / (a + b) } else { 0.0 }
}

/// Whether `hit`'s front faces `towards` (a unit direction to the viewer), and its geometric
/// and shading normals turned to the viewer's side (the shading normal falls back to the
/// geometric one where it would face away).
#[inline]
pub(crate) fn normals_towards(hit: &Hit, towards: Vec3) -> (bool, Vec3, Vec3) {
    let facing = hit.geometric_normal.dot(towards) >= 0.0;
    let sign = if facing { 1.0 } else { -1.0 };
    let geometric_normal = hit.geometric_normal * sign;
    let mut shading_normal = hit.shading_normal * sign;
    if shading_normal.dot(towards) <= 0.0 {
        shading_normal = geometric_normal;
    }
    (facing, geometric_normal, shading_normal)
}

/// The `t_max` of a shadow ray from `origin` to a light at `target`, `distance` apart, whose
/// surface the ray meets at cosine `light_cosine` (1 for a point light): short of the target
/// by a relative 1e-4 of the distance plus 16 ulps of the largest coordinate divided by the
/// cosine. The second term covers the rounding of the target point off its triangle's plane
/// (about an ulp of its coordinates), which a ray meeting the plane at a grazing angle turns
/// into an error along the ray of that much divided by the cosine.
#[inline]
fn shadow_limit(origin: Vec3, target: Vec3, distance: f32, light_cosine: f32) -> f32 {
    let scale = target.abs().max_element().max(origin.abs().max_element());
    let ulps = scale * 16.0 * f32::EPSILON / light_cosine.clamp(1e-3, 1.0);
    distance - 1e-4 * distance - ulps
}

#[cfg(test)]
mod tests {
    use super::*;
    use probe_scene::{Material, Triangle};
    use proptest::prelude::*;

    /// Two emitters of different size and power and a floor: the path's partner probability
    /// from any point bounds what a partner could meet on any emitter point.
    fn two_lights() -> Scene {
        let square = |centre: Vec3, half: f32, material: u32| {
            let c = |dx: f32, dz: f32| centre + Vec3::new(dx, 0.0, dz);
            [
                Triangle::flat([c(-half, -half), c(half, half), c(half, -half)], material),
                Triangle::flat([c(-half, -half), c(-half, half), c(half, half)], material),
            ]
        };
        let mut triangles = square(Vec3::ZERO, 10.0, 0).to_vec();
        triangles.extend(square(Vec3::new(0.0, 3.0, 0.0), 0.5, 1));
        triangles.extend(square(Vec3::new(4.0, 2.0, 1.0), 0.1, 2));
        Scene::from_triangles(
            "two lights",
            triangles,
            vec![
                Material::diffuse("floor", Vec3::splat(0.5)),
                Material::emitter("large", Vec3::splat(2.0)),
                Material::emitter("small", Vec3::splat(40.0)),
            ],
            Vec::new(),
            Vec::new(),
        )
        .unwrap()
    }

    proptest! {
        #![proptest_config(ProptestConfig {
            rng_seed: proptest::test_runner::RngSeed::Fixed(1),
            ..ProptestConfig::default()
        })]
        /// From any point, for any point on any emitter, the cosine-distributed pdf over the
        /// light sample's (with both cosines at their largest, 1) is at most a quarter of
        /// the partner probability unless that is 1; it stays within [1/8, 1].
        #[test]
        fn partner_probability_bounds_every_emitter_point(
            point in (-6.0f32..6.0, 0.01f32..5.0, -6.0f32..6.0),
            slot in 0usize..4,
            barycentrics in (0.0f32..1.0, 0.0f32..1.0),
        ) {
            let scene = two_lights();
            let emitters = Emitters::new(&scene);
            prop_assert_eq!(emitters.triangles.len(), 4);
            let x = Vec3::new(point.0, point.1, point.2);
            let q = emitters.partner_probability(x);
            prop_assert!((PARTNER_MIN..=1.0).contains(&q), "{}", q);
            let triangle = &scene.triangles()[emitters.triangles[slot] as usize];
            // Folded into the triangle.
            let (u, v) = if barycentrics.0 + barycentrics.1 > 1.0 {
                (1.0 - barycentrics.0, 1.0 - barycentrics.1)
            } else {
                barycentrics
            };
            let y = triangle.point(glam::Vec2::new(u, v));
            let ratio =
                triangle.area() / (PI * emitters.pmf[slot] * x.distance_squared(y));
            prop_assert!(
                q >= 1.0 || PARTNER_GAIN * ratio <= q * (1.0 + 1e-4),
                "q {} against the ratio {} at {} (emitter point {})", q, ratio, x, y
            );
        }
    }

    /// Far from small lights the partner is cast at the floor; under a light, always.
    #[test]
    fn partner_probability_is_one_near_a_light_and_the_floor_far_away() {
        let scene = two_lights();
        let emitters = Emitters::new(&scene);
        assert_eq!(emitters.partner_probability(Vec3::new(0.0, 2.9, 0.0)), 1.0);
        assert_eq!(emitters.partner_probability(Vec3::new(4.0, 1.95, 1.0)), 1.0);
        assert_eq!(
            emitters.partner_probability(Vec3::new(-9.0, 0.01, -9.0)),
            PARTNER_MIN
        );
    }
}
