//! Materials from glTF: factors times texture means, and alpha-mask textures.
//!
//! Only images that a material reduces to a constant (base colour, emissive,
//! metallic-roughness) or keeps as a mask are read; normal and occlusion maps are never opened.
//! A needed image that is missing is an error naming its URI (see `LoadError::MissingFile`):
//! silently falling back to the factor alone would change the scene's colours.

use super::{alpha_mode_without_texture, read_uri, texture_image_index};
use crate::error::{LoadError, LoadWarning};
use crate::material::{AlphaMode, AlphaTexture, Material, TextureWrap};
use glam::Vec3;
use std::collections::HashMap;
use std::path::Path;
use std::sync::Arc;

/// An image decoded to 8-bit RGBA.
struct Rgba8 {
    width: u32,
    height: u32,
    pixels: Vec<u8>,
}

struct ImageCache<'a> {
    path: &'a Path,
    document: &'a gltf::Document,
    warnings: &'a mut Vec<LoadWarning>,
    base: &'a Path,
    buffers: &'a [Vec<u8>],
    decoded: HashMap<usize, Arc<Rgba8>>,
}

impl ImageCache<'_> {
    /// The decoded image a texture reads (its `source`, or a decoded format's extension
    /// source; see `texture_image_index`).
    fn texture(&mut self, texture: &gltf::Texture<'_>) -> Result<Arc<Rgba8>, LoadError> {
        let image = texture_image_index(self.document.as_json(), texture.index())
            .and_then(|index| self.document.images().nth(index))
            .ok_or_else(|| LoadError::Invalid {
                path: self.path.to_owned(),
                problems: format!(
                    "textures[{}] has no image this loader can read (no valid `source`)",
                    texture.index()
                ),
            })?;
        self.get(&image)
    }

    fn get(&mut self, image: &gltf::Image<'_>) -> Result<Arc<Rgba8>, LoadError> {
        if let Some(done) = self.decoded.get(&image.index()) {
            return Ok(Arc::clone(done));
        }
        let what = format!("image {}", image.index());
        let (bytes, label) = match image.source() {
            gltf::image::Source::Uri { uri, .. } => {
                (read_uri(self.path, self.base, uri, &what)?, uri.to_owned())
            }
            gltf::image::Source::View { view, .. } => {
                let label = format!("bufferView {}", view.index());
                let bytes = self
                    .buffers
                    .get(view.buffer().index())
                    .and_then(|data| {
                        data.get(view.offset()..view.offset().checked_add(view.length())?)
                    })
                    .ok_or_else(|| LoadError::BadReference {
                        path: self.path.to_owned(),
                        what: what.clone(),
                        uri: label.clone(),
                        message: "the buffer view reaches past its buffer".to_owned(),
                    })?;
                (bytes.to_vec(), label)
            }
        };
        let decoded = image::load_from_memory(&bytes).map_err(|e| LoadError::BadImage {
            path: self.path.to_owned(),
            image: image.index(),
            uri: if label.starts_with("data:") {
                "data: URI".to_owned()
            } else {
                label
            },
            message: e.to_string(),
        })?;
        if bytes.starts_with(b"DDS ") {
            self.warnings.push(LoadWarning::DecodedImageFormat {
                image: image.index(),
                format: "DDS".to_owned(),
            });
        }
        let rgba = decoded.to_rgba8();
        let image_data = Arc::new(Rgba8 {
            width: rgba.width(),
            height: rgba.height(),
            pixels: rgba.into_raw(),
        });
        self.decoded.insert(image.index(), Arc::clone(&image_data));
        Ok(image_data)
    }
}

/// sRGB-encoded byte to linear value.
fn srgb_to_linear_table() -> [f32; 256] {
    let mut table = [0.0; 256];
    for (i, value) in table.iter_mut().enumerate() {
        let c = i as f32 / 255.0;
        *value = if c <= 0.04045 {
            c / 12.92
        } else {
            ((c + 0.055) / 1.055).powf(2.4)
        };
    }
    table
}

/// The mean of the RGB channels over texels whose alpha byte passes `keep`, decoded with
/// `decode`; `None` if no texel passes.
fn mean_rgb(image: &Rgba8, decode: impl Fn(u8) -> f32, keep: impl Fn(u8) -> bool) -> Option<Vec3> {
    let mut sum = [0.0f64; 3];
    let mut count = 0usize;
    for texel in image.pixels.chunks_exact(4) {
        if keep(texel[3]) {
            for c in 0..3 {
                sum[c] += f64::from(decode(texel[c]));
            }
            count += 1;
        }
    }
    (count > 0).then(|| {
        let n = count as f64;
        Vec3::new(
            (sum[0] / n) as f32,
            (sum[1] / n) as f32,
            (sum[2] / n) as f32,
        )
    })
}

fn wrap(mode: gltf::texture::WrappingMode) -> TextureWrap {
    match mode {
        gltf::texture::WrappingMode::Repeat => TextureWrap::Repeat,
        gltf::texture::WrappingMode::MirroredRepeat => TextureWrap::MirroredRepeat,
        gltf::texture::WrappingMode::ClampToEdge => TextureWrap::ClampToEdge,
    }
}

/// All of the document's materials, in file order.
pub(crate) fn load_materials(
    path: &Path,
    base: &Path,
    document: &gltf::Document,
    buffers: &[Vec<u8>],
    warnings: &mut Vec<LoadWarning>,
) -> Result<Vec<Material>, LoadError> {
    let srgb = srgb_to_linear_table();
    let linear = |b: u8| f32::from(b) / 255.0;
    let mut cache = ImageCache {
        path,
        document,
        warnings: &mut *warnings,
        base,
        buffers,
        decoded: HashMap::new(),
    };
    let mut materials = Vec::with_capacity(document.materials().len());
    for (index, material) in document.materials().enumerate() {
        let name = material
            .name()
            .map_or_else(|| format!("material{index}"), str::to_owned);
        let pbr = material.pbr_metallic_roughness();
        let factor = pbr.base_color_factor();
        let mut alpha = alpha_mode_without_texture(&material);
        if alpha == AlphaMode::Blend {
            cache.warnings.push(LoadWarning::BlendTreatedAsOpaque {
                material: name.clone(),
            });
        }
        let mut base_color = Vec3::new(factor[0], factor[1], factor[2]);
        if let Some(info) = pbr.base_color_texture() {
            let texture = info.texture();
            let image = cache.texture(&texture)?;
            let mean = match &mut alpha {
                AlphaMode::Mask {
                    cutoff,
                    texture: mask,
                    ..
                } => {
                    let factor_alpha = factor[3].clamp(0.0, 1.0);
                    let scaled: Vec<u8> = image
                        .pixels
                        .chunks_exact(4)
                        .map(|t| (f32::from(t[3]) * factor_alpha).round() as u8)
                        .collect();
                    let sampler = texture.sampler();
                    *mask = AlphaTexture::new(
                        image.width,
                        image.height,
                        scaled,
                        wrap(sampler.wrap_s()),
                        wrap(sampler.wrap_t()),
                    )
                    .map(Arc::new);
                    let threshold = *cutoff;
                    mean_rgb(
                        &image,
                        |b| srgb[b as usize],
                        |a| f32::from(a) / 255.0 * factor_alpha >= threshold,
                    )
                    .or_else(|| mean_rgb(&image, |b| srgb[b as usize], |_| true))
                }
                _ => mean_rgb(&image, |b| srgb[b as usize], |_| true),
            };
            base_color *= mean.unwrap_or(Vec3::ONE);
        }
        let mut metallic = pbr.metallic_factor();
        let mut roughness = pbr.roughness_factor();
        if let Some(info) = pbr.metallic_roughness_texture() {
            let image = cache.texture(&info.texture())?;
            if let Some(mean) = mean_rgb(&image, linear, |_| true) {
                roughness *= mean.y;
                metallic *= mean.z;
            }
        }
        let strength = material.emissive_strength().unwrap_or(1.0);
        let mut emissive = Vec3::from(material.emissive_factor()) * strength;
        if emissive != Vec3::ZERO
            && let Some(info) = material.emissive_texture()
        {
            let image = cache.texture(&info.texture())?;
            emissive *= mean_rgb(&image, |b| srgb[b as usize], |_| true).unwrap_or(Vec3::ONE);
        }
        materials.push(Material {
            name,
            base_color,
            metallic,
            roughness,
            emissive,
            double_sided: material.double_sided(),
            alpha,
        });
    }
    Ok(materials)
}
