//! Punctual lights (glTF `KHR_lights_punctual`), placed in world space.

use glam::Vec3;

/// A punctual light in world space. Colours are linear RGB; units follow `KHR_lights_punctual`.
///
/// Emissive surfaces are not lights in this sense: they are materials with a non-zero
/// [`Material::emissive`](crate::Material::emissive).
#[derive(Clone, Debug, PartialEq)]
pub enum Light {
    /// Emits in all directions from a point.
    Point {
        /// The name from the file (or generated, `"light{index}"`).
        name: String,
        /// World-space position.
        position: Vec3,
        /// Linear RGB colour.
        color: Vec3,
        /// Luminous intensity in candela.
        intensity: f32,
        /// Distance beyond which the light has no effect; `None` for unlimited.
        range: Option<f32>,
    },
    /// Emits in a cone around `direction`.
    Spot {
        /// The name from the file (or generated).
        name: String,
        /// World-space position.
        position: Vec3,
        /// Unit direction of the cone's axis (the direction light travels).
        direction: Vec3,
        /// Linear RGB colour.
        color: Vec3,
        /// Luminous intensity in candela.
        intensity: f32,
        /// Angle in radians from the axis where the fall-off starts.
        inner_cone: f32,
        /// Angle in radians from the axis where the light ends.
        outer_cone: f32,
        /// Distance beyond which the light has no effect; `None` for unlimited.
        range: Option<f32>,
    },
    /// Parallel light from infinitely far away (a sun).
    Directional {
        /// The name from the file (or generated).
        name: String,
        /// Unit direction the light travels (from the light towards the scene).
        direction: Vec3,
        /// Linear RGB colour.
        color: Vec3,
        /// Illuminance in lux on a surface facing the light.
        illuminance: f32,
        /// Unused by directional lights in glTF; kept for completeness (`None` normally).
        range: Option<f32>,
    },
}

impl Light {
    /// The light's name.
    pub fn name(&self) -> &str {
        match self {
            Light::Point { name, .. }
            | Light::Spot { name, .. }
            | Light::Directional { name, .. } => name,
        }
    }

    /// The light's linear RGB colour.
    pub fn color(&self) -> Vec3 {
        match self {
            Light::Point { color, .. }
            | Light::Spot { color, .. }
            | Light::Directional { color, .. } => *color,
        }
    }

    /// The light's range, if limited.
    pub fn range(&self) -> Option<f32> {
        match self {
            Light::Point { range, .. }
            | Light::Spot { range, .. }
            | Light::Directional { range, .. } => *range,
        }
    }

    /// The position, or `None` for a directional light.
    pub fn position(&self) -> Option<Vec3> {
        match self {
            Light::Point { position, .. } | Light::Spot { position, .. } => Some(*position),
            Light::Directional { .. } => None,
        }
    }
}
