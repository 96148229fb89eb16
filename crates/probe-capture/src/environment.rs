//! Sun and sky: the light that comes from outside the scene.

use glam::Vec3;
use probe_scene::Scene;

/// Light from outside the scene: a sun (a directional light, a delta in direction) and a sky
/// (radiance of rays that leave the scene), in the scene's linear radiance units.
///
/// The sky is a simple vertical gradient: a direction `d` (unit, `+Y` up) sees
/// `sky_horizon + (sky_zenith − sky_horizon) · d.y` above the horizon (`d.y ≥ 0`) and
/// `sky_ground` below it. Set all three equal for a uniform sky
/// ([`Environment::uniform_sky`]). The sun is not visible to rays (it is a delta); it only
/// lights surfaces through shadow rays, as the scene's own directional lights do.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Environment {
    /// Unit direction the sunlight travels (from the sun towards the scene).
    pub sun_direction: Vec3,
    /// Illuminance on a surface facing the sun, before `sun_color`.
    pub sun_illuminance: f32,
    /// Linear RGB colour of the sun, multiplied with `sun_illuminance`.
    pub sun_color: Vec3,
    /// Sky radiance straight up (`+Y`).
    pub sky_zenith: Vec3,
    /// Sky radiance at the horizon.
    pub sky_horizon: Vec3,
    /// Radiance of every direction below the horizon.
    pub sky_ground: Vec3,
}

impl Environment {
    /// No sun and a black sky: only the scene's own lights and emitters shine.
    pub const BLACK: Environment = Environment {
        sun_direction: Vec3::NEG_Y,
        sun_illuminance: 0.0,
        sun_color: Vec3::ONE,
        sky_zenith: Vec3::ZERO,
        sky_horizon: Vec3::ZERO,
        sky_ground: Vec3::ZERO,
    };

    /// The documented default daylight, used for scenes with no light at all (no punctual
    /// light and no emissive material), such as Sponza and the Breakfast room:
    ///
    /// - sun travelling along `(−0.35, −1, −0.25)` normalised (about 67° above the horizon,
    ///   shining from `+X+Z` towards `−X−Z`), colour `(1, 0.95, 0.88)`, illuminance 20;
    /// - sky radiance `(0.8, 1.1, 1.6)` at the zenith, `(1.3, 1.4, 1.5)` at the horizon and a
    ///   ground of `(0.3, 0.28, 0.25)`.
    ///
    /// The numbers are relative, not photometric: a white surface facing the sun reflects a
    /// radiance of about `20/π ≈ 6.4`, and the sky gives a horizontal surface about a fifth of
    /// the sun's illuminance, as on a clear day. They keep HDR values well inside the range
    /// of 16-bit floats for GPU textures.
    pub const DEFAULT_DAYLIGHT: Environment = Environment {
        sun_direction: Vec3::new(-0.321_520_65, -0.918_630_4, -0.229_657_6),
        sun_illuminance: 20.0,
        sun_color: Vec3::new(1.0, 0.95, 0.88),
        sky_zenith: Vec3::new(0.8, 1.1, 1.6),
        sky_horizon: Vec3::new(1.3, 1.4, 1.5),
        sky_ground: Vec3::new(0.3, 0.28, 0.25),
    };

    /// A uniform sky of the given radiance and no sun.
    pub fn uniform_sky(radiance: Vec3) -> Environment {
        Environment {
            sky_zenith: radiance,
            sky_horizon: radiance,
            sky_ground: radiance,
            ..Environment::BLACK
        }
    }

    /// The environment a scene gets when none is given: [`Environment::DEFAULT_DAYLIGHT`] if
    /// the scene has no punctual light and no emissive material, [`Environment::BLACK`]
    /// otherwise.
    pub fn for_scene(scene: &Scene) -> Environment {
        let lit = !scene.lights().is_empty() || scene.materials().iter().any(|m| m.is_emissive());
        if lit {
            Environment::BLACK
        } else {
            Environment::DEFAULT_DAYLIGHT
        }
    }

    /// This environment with the sun travelling along `direction` (normalised here).
    pub fn with_sun_direction(self, direction: Vec3) -> Environment {
        Environment {
            sun_direction: direction.normalize_or_zero(),
            ..self
        }
    }

    /// This environment with the sun's illuminance set to `illuminance`.
    pub fn with_sun_illuminance(self, illuminance: f32) -> Environment {
        Environment {
            sun_illuminance: illuminance,
            ..self
        }
    }

    /// Sky radiance seen along a unit direction.
    #[inline]
    pub fn sky_radiance(&self, direction: Vec3) -> Vec3 {
        if direction.y >= 0.0 {
            self.sky_horizon + (self.sky_zenith - self.sky_horizon) * direction.y.min(1.0)
        } else {
            self.sky_ground
        }
    }

    /// Whether the sky is black everywhere.
    pub fn sky_is_black(&self) -> bool {
        self.sky_zenith == Vec3::ZERO
            && self.sky_horizon == Vec3::ZERO
            && self.sky_ground == Vec3::ZERO
    }

    /// The sun's illuminance times its colour (zero without a sun).
    pub fn sun_irradiance(&self) -> Vec3 {
        self.sun_color * self.sun_illuminance
    }

    /// Checks that every value is finite and non-negative and that a shining sun has a
    /// direction; returns the offending field's name and the reason otherwise.
    pub(crate) fn check(&self) -> Result<(), (&'static str, &'static str)> {
        let colour_ok = |v: Vec3| v.is_finite() && v.min_element() >= 0.0;
        if !(self.sun_illuminance.is_finite() && self.sun_illuminance >= 0.0) {
            return Err(("sun_illuminance", "must be finite and >= 0"));
        }
        for (name, value) in [
            ("sun_color", self.sun_color),
            ("sky_zenith", self.sky_zenith),
            ("sky_horizon", self.sky_horizon),
            ("sky_ground", self.sky_ground),
        ] {
            if !colour_ok(value) {
                return Err((name, "must be finite and >= 0 in every channel"));
            }
        }
        if !self.sun_direction.is_finite()
            || (self.sun_illuminance > 0.0 && self.sun_direction.length_squared() < 1e-12)
        {
            return Err(("sun_direction", "must be finite and non-zero"));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_sun_is_unit_and_sky_gradient_is_continuous() {
        let sun = Environment::DEFAULT_DAYLIGHT.sun_direction;
        assert!((sun.length() - 1.0).abs() < 1e-6);
        assert!((sun - Vec3::new(-0.35, -1.0, -0.25).normalize()).length() < 1e-6);
        let env = Environment::DEFAULT_DAYLIGHT;
        assert_eq!(env.sky_radiance(Vec3::Y), env.sky_zenith);
        assert_eq!(env.sky_radiance(Vec3::X), env.sky_horizon);
        assert_eq!(env.sky_radiance(-Vec3::Y), env.sky_ground);
        assert!(env.check().is_ok());
        assert!(Environment::BLACK.sky_is_black());
        let bad = env.with_sun_illuminance(f32::NAN);
        assert_eq!(bad.check().unwrap_err().0, "sun_illuminance");
    }
}
