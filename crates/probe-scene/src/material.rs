//! Materials: the few PBR quantities probe work needs, and alpha-mask textures.

use glam::{Vec2, Vec3};
use std::sync::Arc;

/// A surface material, reduced to constants (glTF metallic-roughness model).
///
/// Textures other than alpha masks are reduced to their mean: `base_color` is the base-colour
/// factor times the texture's mean colour, `emissive` the emissive factor times the emissive
/// strength times the emissive texture's mean, and so on. Colours are linear RGB.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// The name from the file, or a generated one (`"material{index}"`, `"default"`).
    pub name: String,
    /// Linear RGB albedo in `[0, 1]`: `baseColorFactor.rgb ×` the texture's mean colour (the mean
    /// over the texels that pass the alpha test for [`AlphaMode::Mask`] materials).
    pub base_color: Vec3,
    /// Metalness in `[0, 1]`: `metallicFactor ×` the mean of the metallic-roughness texture's
    /// blue channel.
    pub metallic: f32,
    /// Perceptual roughness in `[0, 1]`: `roughnessFactor ×` the mean of that texture's green
    /// channel.
    pub roughness: f32,
    /// Emitted linear radiance (W·sr⁻¹·m⁻² in the scene's units):
    /// `emissiveFactor × emissive_strength ×` the emissive texture's mean colour.
    pub emissive: Vec3,
    /// Whether both faces are meant to be rendered (glTF `doubleSided`). Ray casting always
    /// reports both faces; this flag is for shading.
    pub double_sided: bool,
    /// How the base colour's alpha is used.
    pub alpha: AlphaMode,
}

impl Material {
    /// A matte, single-sided, opaque material of the given linear albedo.
    pub fn diffuse(name: impl Into<String>, base_color: Vec3) -> Material {
        Material {
            name: name.into(),
            base_color,
            metallic: 0.0,
            roughness: 1.0,
            emissive: Vec3::ZERO,
            double_sided: false,
            alpha: AlphaMode::Opaque,
        }
    }

    /// A matte, black-bodied emitter of the given linear radiance.
    pub fn emitter(name: impl Into<String>, radiance: Vec3) -> Material {
        Material {
            emissive: radiance,
            ..Material::diffuse(name, Vec3::ZERO)
        }
    }

    /// The glTF default material, used for primitives that name none: white, `metallic = 1`,
    /// `roughness = 1`, single-sided, opaque (glTF 2.0 §3.9.6).
    pub fn gltf_default() -> Material {
        Material {
            name: "default".to_owned(),
            base_color: Vec3::ONE,
            metallic: 1.0,
            roughness: 1.0,
            emissive: Vec3::ZERO,
            double_sided: false,
            alpha: AlphaMode::Opaque,
        }
    }

    /// Whether the material emits light (any emissive component above zero).
    pub fn is_emissive(&self) -> bool {
        self.emissive.max_element() > 0.0
    }

    /// The radiance the material emits from a surface with `geometric_normal` towards a viewer
    /// in direction `towards_viewer`: its emission on the side it emits from (the normal's
    /// side; both sides when double-sided), zero otherwise.
    pub fn emission_towards(&self, geometric_normal: Vec3, towards_viewer: Vec3) -> Vec3 {
        if self.is_emissive() && (self.double_sided || geometric_normal.dot(towards_viewer) >= 0.0)
        {
            self.emissive
        } else {
            Vec3::ZERO
        }
    }
}

/// How a material's alpha is interpreted.
#[derive(Clone, Debug, PartialEq)]
pub enum AlphaMode {
    /// Fully opaque; alpha is ignored.
    Opaque,
    /// Cut-outs: the surface exists where alpha ≥ `cutoff` and is absent elsewhere. Ray casting
    /// samples `texture` at the hit's UV and ignores the hit where the alpha is below `cutoff`.
    /// Without a texture the constant base-colour alpha decides for the whole material.
    Mask {
        /// The alpha threshold (glTF `alphaCutoff`, default 0.5).
        cutoff: f32,
        /// The texture's alpha times the base-colour factor's alpha, or `None` when the material
        /// has no base-colour texture.
        texture: Option<Arc<AlphaTexture>>,
        /// The base-colour factor's alpha, used when `texture` is `None`.
        constant_alpha: f32,
    },
    /// Alpha blending. Treated as opaque by ray casting (the loader warns).
    Blend,
}

impl AlphaMode {
    /// Whether a surface point with texture coordinate `uv` exists (passes the alpha test).
    /// Always true for [`AlphaMode::Opaque`] and [`AlphaMode::Blend`].
    #[inline]
    pub fn passes(&self, uv: Vec2) -> bool {
        match self {
            AlphaMode::Mask {
                cutoff,
                texture,
                constant_alpha,
            } => {
                let alpha = match texture {
                    Some(texture) => texture.sample(uv),
                    None => *constant_alpha,
                };
                alpha >= *cutoff
            }
            AlphaMode::Opaque | AlphaMode::Blend => true,
        }
    }
}

/// How texture coordinates outside `[0, 1]` map into a texture (glTF sampler wrap modes).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum TextureWrap {
    /// Tile the texture (glTF `REPEAT`, the default).
    Repeat,
    /// Tile, mirroring every other tile (glTF `MIRRORED_REPEAT`).
    MirroredRepeat,
    /// Clamp to the edge texels (glTF `CLAMP_TO_EDGE`).
    ClampToEdge,
}

impl TextureWrap {
    /// The texel index for coordinate `coordinate` on an axis of `size` texels.
    #[inline]
    fn texel(self, coordinate: f32, size: u32) -> u32 {
        let scaled = coordinate * size as f32;
        // Non-finite coordinates map to texel 0 (`as` saturates, NaN becomes 0).
        let index = scaled.floor() as i64;
        let size = i64::from(size);
        let wrapped = match self {
            TextureWrap::Repeat => index.rem_euclid(size),
            TextureWrap::ClampToEdge => index.clamp(0, size - 1),
            TextureWrap::MirroredRepeat => {
                let period = index.rem_euclid(2 * size);
                if period < size {
                    period
                } else {
                    2 * size - 1 - period
                }
            }
        };
        wrapped as u32
    }
}

/// The alpha channel of a mask texture at its full resolution, one byte per texel, row-major
/// from the top-left (glTF UV `(0, 0)`). Sampled with the nearest texel.
#[derive(Clone, Debug, PartialEq)]
pub struct AlphaTexture {
    width: u32,
    height: u32,
    wrap_u: TextureWrap,
    wrap_v: TextureWrap,
    alpha: Vec<u8>,
}

impl AlphaTexture {
    /// A mask texture of `width × height` texels from row-major alpha bytes (255 = opaque).
    /// Returns `None` when a size is zero or `alpha.len() != width × height`.
    pub fn new(
        width: u32,
        height: u32,
        alpha: Vec<u8>,
        wrap_u: TextureWrap,
        wrap_v: TextureWrap,
    ) -> Option<AlphaTexture> {
        let expected = (width as usize).checked_mul(height as usize)?;
        (width > 0 && height > 0 && alpha.len() == expected).then_some(AlphaTexture {
            width,
            height,
            wrap_u,
            wrap_v,
            alpha,
        })
    }

    /// Width in texels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in texels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The wrap modes along u and v.
    pub fn wrap(&self) -> (TextureWrap, TextureWrap) {
        (self.wrap_u, self.wrap_v)
    }

    /// The alpha bytes, row-major from the top-left.
    pub fn alpha(&self) -> &[u8] {
        &self.alpha
    }

    /// The alpha in `[0, 1]` of the texel nearest to `uv`.
    #[inline]
    pub fn sample(&self, uv: Vec2) -> f32 {
        let x = self.wrap_u.texel(uv.x, self.width);
        let y = self.wrap_v.texel(uv.y, self.height);
        f32::from(self.alpha[y as usize * self.width as usize + x as usize]) * (1.0 / 255.0)
    }

    /// The share of texels with alpha at or above `cutoff`.
    pub fn coverage(&self, cutoff: f32) -> f32 {
        let threshold = (cutoff * 255.0).ceil().clamp(0.0, 256.0) as u16;
        let passing = self
            .alpha
            .iter()
            .filter(|&&a| u16::from(a) >= threshold)
            .count();
        passing as f32 / self.alpha.len() as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrap_modes() {
        assert_eq!(TextureWrap::Repeat.texel(1.25, 4), 1);
        assert_eq!(TextureWrap::Repeat.texel(-0.1, 4), 3);
        assert_eq!(TextureWrap::ClampToEdge.texel(-3.0, 4), 0);
        assert_eq!(TextureWrap::ClampToEdge.texel(7.0, 4), 3);
        assert_eq!(TextureWrap::MirroredRepeat.texel(1.1, 4), 3);
        assert_eq!(TextureWrap::MirroredRepeat.texel(1.9, 4), 0);
        assert_eq!(TextureWrap::MirroredRepeat.texel(-0.1, 4), 0);
        assert_eq!(TextureWrap::Repeat.texel(f32::NAN, 4), 0);
    }

    #[test]
    fn mask_sampling() {
        // 2×2: left column opaque, right column transparent.
        let texture = AlphaTexture::new(
            2,
            2,
            vec![255, 0, 255, 0],
            TextureWrap::Repeat,
            TextureWrap::Repeat,
        )
        .unwrap();
        let mode = AlphaMode::Mask {
            cutoff: 0.5,
            texture: Some(Arc::new(texture.clone())),
            constant_alpha: 1.0,
        };
        assert!(mode.passes(Vec2::new(0.25, 0.75)));
        assert!(!mode.passes(Vec2::new(0.75, 0.25)));
        assert!(mode.passes(Vec2::new(1.25, 0.25)));
        assert!((texture.coverage(0.5) - 0.5).abs() < 1e-6);
        assert!(
            AlphaTexture::new(2, 2, vec![0; 3], TextureWrap::Repeat, TextureWrap::Repeat).is_none()
        );
        assert!(AlphaMode::Opaque.passes(Vec2::ZERO));
        let constant = AlphaMode::Mask {
            cutoff: 0.5,
            texture: None,
            constant_alpha: 0.2,
        };
        assert!(!constant.passes(Vec2::ZERO));
    }
}
