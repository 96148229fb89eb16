//! PNG previews of one probe's maps.

use std::path::{Path, PathBuf};

use glam::Vec3;

use crate::bake::{MISS_DISTANCE, ProbeBake};
use crate::image::{Image, ImageError, write_png_rgb8};

/// Why previews could not be written.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PreviewError {
    /// The probe index is past the last probe. Fix: pass an index below `probes`.
    #[error("probe {probe} does not exist; the bake has {probes} probes")]
    NoSuchProbe {
        /// The index asked for.
        probe: usize,
        /// Number of probes in the bake.
        probes: usize,
    },
    /// A PNG could not be written.
    #[error(transparent)]
    Image(#[from] ImageError),
}

/// The files [`ProbeBake::write_previews`] wrote.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PreviewPaths {
    /// Tone-mapped radiance.
    pub radiance: PathBuf,
    /// Normals as colours.
    pub normal: PathBuf,
    /// Radial distance as grey levels.
    pub distance: PathBuf,
}

impl ProbeBake {
    /// Writes PNG previews of probe `probe`'s interior `N × N` maps into `dir` (created if
    /// missing), named `probe{probe:04}_radiance.png`, `…_normal.png`, `…_distance.png`,
    /// each written atomically:
    ///
    /// - radiance tone-mapped with [`Image::save_png`] (automatic exposure, ACES, sRGB);
    /// - normals as `0.5 + 0.5·n` in RGB (misses black);
    /// - distance as grey, bright near and dark far (`1 − √(r / r_max)` with `r_max` the
    ///   largest hit distance), misses light blue and back-face hits red.
    ///
    /// Texel row `N − 1` (octahedral `v = +1`) is the top row of the picture, so the upper
    /// hemisphere's `+Y` points up.
    ///
    /// # Errors
    /// [`PreviewError::NoSuchProbe`], or [`PreviewError::Image`] when writing fails.
    pub fn write_previews(
        &self,
        probe: usize,
        dir: impl AsRef<Path>,
    ) -> Result<PreviewPaths, PreviewError> {
        let no_such = PreviewError::NoSuchProbe {
            probe,
            probes: self.probe_count(),
        };
        let (Some(radiance), Some(normals), Some(distances)) = (
            self.radiance_map(probe),
            self.normal_map(probe),
            self.distance_map(probe),
        ) else {
            return Err(no_such);
        };
        let dir = dir.as_ref();
        let n = self.resolution();
        let layout = self.layout();
        // Interior texels, top row first.
        let texels = |ix: u32, row: u32| layout.interior_index(ix, n - 1 - row);
        let paths = PreviewPaths {
            radiance: dir.join(format!("probe{probe:04}_radiance.png")),
            normal: dir.join(format!("probe{probe:04}_normal.png")),
            distance: dir.join(format!("probe{probe:04}_distance.png")),
        };

        let mut image = Image::new(n, n);
        for row in 0..n {
            for ix in 0..n {
                image.rgb[(row * n + ix) as usize] = radiance.texels()[texels(ix, row)].to_array();
            }
        }
        image.save_png(&paths.radiance)?;

        let to_byte = |v: f32| (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8;
        let mut bytes = Vec::with_capacity((n * n * 3) as usize);
        for row in 0..n {
            for ix in 0..n {
                let normal = normals.texels()[texels(ix, row)];
                let colour = if normal == Vec3::ZERO {
                    Vec3::ZERO
                } else {
                    normal * 0.5 + Vec3::splat(0.5)
                };
                bytes.extend(colour.to_array().map(to_byte));
            }
        }
        write_png_rgb8(&paths.normal, &bytes, n, n)?;

        let max_hit = distances
            .texels()
            .iter()
            .copied()
            .filter(|&r| r < MISS_DISTANCE)
            .fold(0.0f32, f32::max)
            .max(1e-6);
        bytes.clear();
        for row in 0..n {
            for ix in 0..n {
                let index = texels(ix, row);
                let r = distances.texels()[index];
                let colour = if r >= MISS_DISTANCE {
                    Vec3::new(0.55, 0.75, 1.0)
                } else {
                    let grey = 1.0 - (r / max_hit).sqrt();
                    let direction = layout.texel_direction(ix, n - 1 - row);
                    let back_face = normals.texels()[index].dot(direction) > 0.0;
                    if back_face {
                        Vec3::new(0.5 + 0.5 * grey, 0.1 * grey, 0.1 * grey)
                    } else {
                        Vec3::splat(grey)
                    }
                };
                bytes.extend(colour.to_array().map(to_byte));
            }
        }
        write_png_rgb8(&paths.distance, &bytes, n, n)?;
        Ok(paths)
    }
}
