//! Lighting for placement: [`CaptureOracle`] wires probe-capture's shading into probe-place's
//! [`LightingOracle`] (probe-place knows nothing of probe-capture), and [`place_lit`] runs
//! [`probe_place::pipeline::place`] with it, so seed 002's irradiance-driven methods work on
//! any scene probe-capture can shade.

use glam::Vec3;
use probe_capture::{Environment, Rng, Shader, ShaderError};
use probe_place::irradiance::LightingOracle;
use probe_place::pipeline::{PlaceOptions, Placement, place};
use probe_scene::{Ray, Scene};

use crate::EvalError;

/// The lighting oracle of seed 002's methods, from probe-capture's shading: irradiance on a
/// small surface by Monte-Carlo integration of the shaded radiance arriving over the
/// hemisphere (cosine-weighted, `samples` rays, seeded by the point).
pub struct CaptureOracle<'s> {
    shader: Shader<'s>,
    samples: u32,
    seed: u64,
}

impl<'s> CaptureOracle<'s> {
    /// An oracle over `scene` lit by its default environment (direct light plus `bounces`).
    ///
    /// # Errors
    /// [`ShaderError`] if the lighting is refused.
    pub fn new(
        scene: &'s Scene,
        bounces: u32,
        samples: u32,
        seed: u64,
    ) -> Result<Self, ShaderError> {
        Ok(Self {
            shader: Shader::new(scene, Environment::for_scene(scene), bounces)?,
            samples: samples.max(1),
            seed,
        })
    }
}

impl LightingOracle for CaptureOracle<'_> {
    fn irradiance(&self, point: Vec3) -> Vec3 {
        [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z]
            .into_iter()
            .map(|n| self.irradiance_towards(point, n))
            .fold(Vec3::ZERO, |best, e| {
                if e.dot(Vec3::ONE) > best.dot(Vec3::ONE) {
                    e
                } else {
                    best
                }
            })
    }

    fn irradiance_towards(&self, point: Vec3, normal: Vec3) -> Vec3 {
        self.integrate(point, normal, &|ray, rng| self.shader.trace(ray, rng).1)
    }
}

impl CaptureOracle<'_> {
    /// The indirect irradiance on a small surface at `point` facing `normal`: as
    /// [`LightingOracle::irradiance_towards`] without the emission of the light sources seen
    /// directly ([`Shader::reflected_radiance`]), which is what bakes' irradiance probes hold.
    pub fn indirect_irradiance_towards(&self, point: Vec3, normal: Vec3) -> Vec3 {
        self.integrate(point, normal, &|ray, rng| {
            self.shader.reflected_radiance(ray, rng)
        })
    }

    /// `π ×` the mean of `radiance` over `samples` cosine-distributed rays, seeded by the
    /// point and normal.
    fn integrate(
        &self,
        point: Vec3,
        normal: Vec3,
        radiance: &dyn Fn(&Ray, &mut Rng) -> Vec3,
    ) -> Vec3 {
        let Some(normal) = normal.try_normalize() else {
            return Vec3::ZERO;
        };
        let key = [
            u64::from(point.x.to_bits()),
            u64::from(point.y.to_bits()),
            u64::from(point.z.to_bits()),
            u64::from(normal.x.to_bits()) ^ (u64::from(normal.y.to_bits()) << 32),
            u64::from(normal.z.to_bits()),
        ];
        let mut rng = Rng::for_key(self.seed, &key);
        let (tangent, bitangent) = normal.any_orthonormal_pair();
        let mut sum = Vec3::ZERO;
        for _ in 0..self.samples {
            // Cosine-weighted direction: the estimator of E = ∫ L cos dω is π · mean(L).
            let u = rng.next_vec2();
            let r = u.x.sqrt();
            let phi = std::f32::consts::TAU * u.y;
            let direction = tangent * (r * phi.cos())
                + bitangent * (r * phi.sin())
                + normal * (1.0 - u.x).max(0.0).sqrt();
            sum += radiance(&Ray::new(point, direction), &mut rng);
        }
        sum * (std::f32::consts::PI / self.samples as f32)
    }
}

/// [`probe_place::pipeline::place`] with the scene's own lighting: when the method
/// [needs lighting](probe_place::pipeline::Method::needs_lighting), a [`CaptureOracle`] with one
/// bounce and 64 samples per query, seeded by `options.seed`; otherwise no oracle at all.
///
/// # Errors
/// [`EvalError::Shader`] if the lighting is refused, [`EvalError::Place`] from placement.
pub fn place_lit(scene: &Scene, options: &PlaceOptions) -> Result<Placement, EvalError> {
    let oracle = if options.method.needs_lighting() {
        Some(CaptureOracle::new(scene, 1, 64, options.seed)?)
    } else {
        None
    };
    Ok(place(
        scene,
        options,
        oracle.as_ref().map(|o| o as &dyn LightingOracle),
    )?)
}
