//! HDR images: EXR and tone-mapped PNG output, and error metrics.

use std::io;
use std::path::{Path, PathBuf};

use glam::Vec3;

use crate::atomic;
use crate::exr_io::{self, ExrLayer};

/// Why an image could not be written, read or compared.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ImageError {
    /// A file could not be created, renamed or read. Fix: check the path and permissions.
    #[error("{}: {source}", path.display())]
    Io {
        /// The path.
        path: PathBuf,
        /// The underlying error.
        source: io::Error,
    },
    /// The EXR encoder or decoder failed. Fix: for reading, check that the file is an EXR
    /// with `R`, `G`, `B` channels (as [`Image::save_exr`] writes).
    #[error("{}: EXR: {source}", path.display())]
    Exr {
        /// The file.
        path: PathBuf,
        /// The `exr` crate's error.
        source: exr::error::Error,
    },
    /// The PNG encoder failed. Fix: check the path and free space.
    #[error("{}: PNG: {source}", path.display())]
    Png {
        /// The file.
        path: PathBuf,
        /// The `image` crate's error.
        source: ::image::ImageError,
    },
    /// An EXR file lacks the `R`, `G` or `B` channel. Fix: pass an RGB EXR.
    #[error("{}: no {channel:?} channel", path.display())]
    MissingChannel {
        /// The file.
        path: PathBuf,
        /// The missing channel.
        channel: &'static str,
    },
    /// Two images compared have different sizes. Fix: render both at the same size.
    #[error("image sizes differ: {left:?} vs {right:?}")]
    SizeMismatch {
        /// `(width, height)` of `self`.
        left: (u32, u32),
        /// `(width, height)` of the other image.
        right: (u32, u32),
    },
    /// The image has no pixels, or `rgb` does not hold `width × height` pixels. Fix: build
    /// images with [`Image::new`].
    #[error("image of {width}×{height} holds {pixels} pixels")]
    BadSize {
        /// Width.
        width: u32,
        /// Height.
        height: u32,
        /// Pixels held.
        pixels: usize,
    },
}

/// A linear HDR RGB image, row-major from the top-left pixel.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width × height` linear RGB pixels, row by row from the top.
    pub rgb: Vec<[f32; 3]>,
}

impl Image {
    /// A black image.
    pub fn new(width: u32, height: u32) -> Image {
        Image {
            width,
            height,
            rgb: vec![[0.0; 3]; width as usize * height as usize],
        }
    }

    fn check(&self) -> Result<(), ImageError> {
        if self.width == 0
            || self.height == 0
            || self.rgb.len() != self.width as usize * self.height as usize
        {
            return Err(ImageError::BadSize {
                width: self.width,
                height: self.height,
                pixels: self.rgb.len(),
            });
        }
        Ok(())
    }

    /// The pixel at `(x, y)`, or `None` outside the image.
    pub fn pixel(&self, x: u32, y: u32) -> Option<Vec3> {
        if x >= self.width || y >= self.height {
            return None;
        }
        self.rgb
            .get(y as usize * self.width as usize + x as usize)
            .map(|&p| Vec3::from(p))
    }

    /// The mean of all pixels.
    pub fn mean(&self) -> Vec3 {
        let sum = self.rgb.iter().fold([0.0f64; 3], |acc, p| {
            [
                acc[0] + f64::from(p[0]),
                acc[1] + f64::from(p[1]),
                acc[2] + f64::from(p[2]),
            ]
        });
        let n = self.rgb.len().max(1) as f64;
        Vec3::new(
            (sum[0] / n) as f32,
            (sum[1] / n) as f32,
            (sum[2] / n) as f32,
        )
    }

    /// Mean squared error over all pixels and the three channels.
    ///
    /// # Errors
    /// [`ImageError::SizeMismatch`] when the sizes differ.
    pub fn mse(&self, other: &Image) -> Result<f64, ImageError> {
        if (self.width, self.height) != (other.width, other.height)
            || self.rgb.len() != other.rgb.len()
        {
            return Err(ImageError::SizeMismatch {
                left: (self.width, self.height),
                right: (other.width, other.height),
            });
        }
        let sum: f64 = self
            .rgb
            .iter()
            .zip(&other.rgb)
            .map(|(a, b)| {
                (0..3)
                    .map(|k| (f64::from(a[k]) - f64::from(b[k])).powi(2))
                    .sum::<f64>()
            })
            .sum();
        Ok(sum / (3 * self.rgb.len().max(1)) as f64)
    }

    /// Peak signal-to-noise ratio in dB against `reference`, with the reference's largest
    /// channel value as the peak: `10 log10(peak² / mse)` (infinite for identical images).
    ///
    /// # Errors
    /// [`ImageError::SizeMismatch`] when the sizes differ.
    pub fn psnr(&self, reference: &Image) -> Result<f64, ImageError> {
        let mse = self.mse(reference)?;
        let peak = reference
            .rgb
            .iter()
            .flatten()
            .fold(0.0f32, |m, &v| m.max(v)) as f64;
        Ok(10.0 * (peak * peak / mse).log10())
    }

    /// Writes the image as a 32-bit float EXR with channels `R`, `G`, `B` (atomically: a
    /// temporary file renamed into place).
    ///
    /// # Errors
    /// [`ImageError`] on I/O or encoding failure, or for an inconsistent image.
    pub fn save_exr(&self, path: impl AsRef<Path>) -> Result<(), ImageError> {
        self.check()?;
        let path = path.as_ref();
        let channels = ["R", "G", "B"]
            .iter()
            .enumerate()
            .map(|(k, name)| ((*name).to_owned(), self.rgb.iter().map(|p| p[k]).collect()))
            .collect();
        let layer = ExrLayer {
            name: "rgb".into(),
            width: self.width as usize,
            height: self.height as usize,
            channels,
        };
        atomic::write_file(path, io_error, |temporary| {
            exr_io::write(temporary, vec![layer]).map_err(|source| ImageError::Exr {
                path: path.to_owned(),
                source,
            })
        })
    }

    /// Reads an RGB EXR (the first layer with `R`, `G`, `B` channels).
    ///
    /// # Errors
    /// [`ImageError::Exr`] for unreadable files, [`ImageError::MissingChannel`].
    pub fn load_exr(path: impl AsRef<Path>) -> Result<Image, ImageError> {
        let path = path.as_ref();
        let layers = exr_io::read(path).map_err(|source| ImageError::Exr {
            path: path.to_owned(),
            source,
        })?;
        let layer = layers
            .iter()
            .find(|l| l.channels.iter().any(|c| c.0 == "R"))
            .or(layers.first())
            .ok_or(ImageError::MissingChannel {
                path: path.to_owned(),
                channel: "R",
            })?;
        let channel = |name: &'static str| {
            layer
                .channels
                .iter()
                .find(|c| c.0 == name)
                .map(|c| &c.1)
                .ok_or(ImageError::MissingChannel {
                    path: path.to_owned(),
                    channel: name,
                })
        };
        let (r, g, b) = (channel("R")?, channel("G")?, channel("B")?);
        Ok(Image {
            width: layer.width as u32,
            height: layer.height as u32,
            rgb: (0..r.len()).map(|i| [r[i], g[i], b[i]]).collect(),
        })
    }

    /// The exposure [`Image::save_png`] uses: `0.18` divided by the log-average luminance
    /// of the non-black pixels (1 for a black image).
    pub fn auto_exposure(&self) -> f32 {
        let (mut sum, mut count) = (0.0f64, 0usize);
        for p in &self.rgb {
            let y = luminance(Vec3::from(*p));
            if y > 1e-6 && y.is_finite() {
                sum += f64::from(y).ln();
                count += 1;
            }
        }
        if count == 0 {
            return 1.0;
        }
        (0.18 / (sum / count as f64).exp()) as f32
    }

    /// Writes a tone-mapped 8-bit sRGB PNG with [`Image::auto_exposure`] (atomically).
    ///
    /// # Errors
    /// [`ImageError`] on I/O or encoding failure, or for an inconsistent image.
    pub fn save_png(&self, path: impl AsRef<Path>) -> Result<(), ImageError> {
        self.save_png_with_exposure(path, self.auto_exposure())
    }

    /// Writes a PNG: each pixel times `exposure`, through the ACES filmic curve
    /// (Narkowicz's fit), then sRGB-encoded to 8 bits (atomically).
    ///
    /// # Errors
    /// [`ImageError`] on I/O or encoding failure, or for an inconsistent image.
    pub fn save_png_with_exposure(
        &self,
        path: impl AsRef<Path>,
        exposure: f32,
    ) -> Result<(), ImageError> {
        self.check()?;
        write_png_rgb8(
            path.as_ref(),
            &self.to_rgb8(exposure),
            self.width,
            self.height,
        )
    }

    /// The pixels as [`Image::save_png_with_exposure`] encodes them: times `exposure`, ACES
    /// filmic, sRGB, 8-bit RGB row by row (for composing pictures of several images).
    pub fn to_rgb8(&self, exposure: f32) -> Vec<u8> {
        self.rgb
            .iter()
            .flat_map(|p| p.map(|v| srgb8(aces(v * exposure))))
            .collect()
    }
}

fn io_error(path: &Path, source: io::Error) -> ImageError {
    ImageError::Io {
        path: path.to_owned(),
        source,
    }
}

/// Writes 8-bit RGB bytes as a PNG, atomically.
pub(crate) fn write_png_rgb8(
    path: &Path,
    bytes: &[u8],
    width: u32,
    height: u32,
) -> Result<(), ImageError> {
    atomic::write_file(path, io_error, |temporary| {
        ::image::save_buffer_with_format(
            temporary,
            bytes,
            width,
            height,
            ::image::ExtendedColorType::Rgb8,
            ::image::ImageFormat::Png,
        )
        .map_err(|source| ImageError::Png {
            path: path.to_owned(),
            source,
        })
    })
}

/// Rec. 709 luminance of linear RGB.
#[inline]
pub(crate) fn luminance(c: Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// Narkowicz's ACES filmic fit, clamped to `[0, 1]` (NaN → 0).
#[inline]
pub(crate) fn aces(x: f32) -> f32 {
    let x = x.max(0.0);
    let y = (x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14);
    if y.is_nan() { 0.0 } else { y.clamp(0.0, 1.0) }
}

/// Linear `[0, 1]` to an 8-bit sRGB code.
#[inline]
pub(crate) fn srgb8(linear: f32) -> u8 {
    let c = linear.clamp(0.0, 1.0);
    let encoded = if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    };
    (encoded * 255.0 + 0.5) as u8
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn metrics() {
        let mut a = Image::new(2, 1);
        let mut b = Image::new(2, 1);
        a.rgb[0] = [1.0, 1.0, 1.0];
        b.rgb[0] = [1.0, 1.0, 1.0];
        b.rgb[1] = [0.0, 0.3, 0.0];
        assert!((a.mse(&b).unwrap() - 0.09 / 6.0).abs() < 1e-7);
        assert_eq!(a.mse(&a).unwrap(), 0.0);
        assert!(a.psnr(&a).unwrap().is_infinite());
        let psnr = a.psnr(&b).unwrap();
        assert!((psnr - 10.0 * (1.0 / (0.09f64 / 6.0)).log10()).abs() < 1e-4);
        assert!(matches!(
            a.mse(&Image::new(1, 2)),
            Err(ImageError::SizeMismatch { .. })
        ));
    }

    #[test]
    fn tone_curve_is_monotone_and_bounded() {
        let mut previous = 0u8;
        for i in 0..1000 {
            let v = srgb8(aces(i as f32 * 0.01));
            assert!(v >= previous);
            previous = v;
        }
        assert_eq!(srgb8(aces(0.0)), 0);
        assert!(srgb8(aces(100.0)) >= 254);
        assert_eq!(srgb8(aces(f32::NAN)), 0);
    }
}
