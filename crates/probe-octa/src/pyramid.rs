//! Seam-aware min/max pyramids of radial distance for hi-Z tracing (seed 000 §4.3).

use glam::{Vec2, Vec3};

use crate::layout::{OctaLayout, ResolutionError};
use crate::map::OctaMap;

/// How a tracer reads the finest level, which decides what each coarse texel must bound.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum FineRead {
    /// The tracer reads the interior texel containing the direction ([`OctaMap::sample_nearest`],
    /// WGSL `textureLoad`). A coarse texel bounds exactly the fine texels it covers.
    Nearest,
    /// The tracer reads bilinearly through the padding ([`OctaMap::sample`], a GPU bilinear
    /// sampler). A direction inside a fine texel can blend its 8 neighbours, across seams via
    /// the border, so a coarse texel covering `k×k` fine texels bounds the `(k+2)×(k+2)` padded
    /// texels around them. Also valid for [`FineRead::Nearest`] readers, only looser.
    Bilinear,
}

/// Why a pyramid could not be built or a level could not be given.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum PyramidError {
    /// The map's resolution is not a power of two (levels halve it). Fix: build the distance
    /// map at a power-of-two resolution.
    #[error(transparent)]
    Resolution(#[from] ResolutionError),
    /// `max_levels` was 0. Fix: ask for at least 1 level (seed 000 uses 6–7; `u32::MAX` builds
    /// all the way to 1×1).
    #[error("`max_levels` is 0; a pyramid has at least its finest level")]
    ZeroLevels,
    /// No level is down-sampled by `downsample`. Fix: pass a power of two up to
    /// `2^(level_count − 1)`.
    #[error("no level is down-sampled by {downsample}: the pyramid has {level_count} levels")]
    DownsampleUnavailable {
        /// The factor asked for.
        downsample: u32,
        /// Levels the pyramid holds.
        level_count: usize,
    },
}

/// A min/max pyramid of a radial-distance octahedral map, for hi-Z tracing and for McGuire
/// 2017's low-resolution minimum-distance map.
///
/// Level `k` is an `N/2^k × N/2^k` octahedral grid (same conventions as [`OctaLayout`], no
/// border), row-major, each texel a `Vec2` holding `(min, max)`. Level `k` texel `(x, y)` covers
/// the fine interior texels `[x·2^k, (x+1)·2^k) × [y·2^k, (y+1)·2^k)`.
///
/// **Guarantee.** For every direction `d` whose octahedral point lies in that texel's square,
/// the value a tracer reads from the fine map at `d` (per [`FineRead`]) lies in `[min, max]`:
/// exactly for [`FineRead::Nearest`]; for [`FineRead::Bilinear`] up to the rounding of the
/// bilinear blend itself (a few ulps). NaN texels are ignored by min and max.
#[derive(Debug, Clone, PartialEq)]
pub struct MinMaxPyramid {
    fine_read: FineRead,
    resolution: u32,
    levels: Vec<Vec<Vec2>>,
}

impl MinMaxPyramid {
    /// Builds up to `max_levels` levels (at most `log2(N) + 1`, ending at 1×1) from a padded
    /// distance map, for a tracer that reads the fine level as `fine_read` says.
    ///
    /// # Errors
    /// [`PyramidError::Resolution`] if the map's resolution is not a power of two;
    /// [`PyramidError::ZeroLevels`] if `max_levels` is 0.
    pub fn build(
        distance: &OctaMap<f32>,
        fine_read: FineRead,
        max_levels: u32,
    ) -> Result<Self, PyramidError> {
        let layout = distance.layout();
        let n = layout.resolution();
        if !n.is_power_of_two() {
            return Err(ResolutionError::NotPowerOfTwo {
                parameter: "distance.resolution()",
                value: n,
            }
            .into());
        }
        if max_levels == 0 {
            return Err(PyramidError::ZeroLevels);
        }
        let count = (n.trailing_zeros() + 1).min(max_levels) as usize;
        let mut levels = Vec::with_capacity(count);
        levels.push(match fine_read {
            FineRead::Nearest => nearest_level(distance),
            FineRead::Bilinear => bilinear_level(distance),
        });
        let mut size = n as usize;
        while levels.len() < count {
            let coarse = reduce(levels.last().expect("level 0 exists"), size);
            size /= 2;
            levels.push(coarse);
        }
        Ok(Self {
            fine_read,
            resolution: n,
            levels,
        })
    }

    /// How the fine level is assumed to be read.
    #[inline]
    pub fn fine_read(&self) -> FineRead {
        self.fine_read
    }

    /// Number of levels held.
    #[inline]
    pub fn level_count(&self) -> usize {
        self.levels.len()
    }

    /// Texels per side of level `level` (`N / 2^level`), or `None` past the last level.
    #[inline]
    pub fn level_resolution(&self, level: usize) -> Option<u32> {
        (level < self.levels.len()).then(|| self.resolution >> level)
    }

    /// The `(min, max)` texels of a level, row-major, or `None` past the last level.
    #[inline]
    pub fn level(&self, level: usize) -> Option<&[Vec2]> {
        self.levels.get(level).map(Vec::as_slice)
    }

    /// `(min, max)` of the level texel containing a direction, or `None` past the last level.
    #[inline]
    pub fn min_max(&self, level: usize, direction: Vec3) -> Option<Vec2> {
        let texels = self.levels.get(level)?;
        let size = self.resolution >> level;
        let layout = OctaLayout::new(size).ok()?;
        let [x, y] = layout.texel_containing(direction);
        Some(texels[(y * size + x) as usize])
    }

    /// The minimum-distance map down-sampled by `downsample` (McGuire 2017 uses 16: 1024² →
    /// 64²), as a padded octahedral map: each texel is a lower bound of every fine value a tracer
    /// can read inside it.
    ///
    /// # Errors
    /// [`PyramidError::DownsampleUnavailable`] unless `downsample` is a power of two whose level
    /// was built.
    pub fn min_distance_map(&self, downsample: u32) -> Result<OctaMap<f32>, PyramidError> {
        let unavailable = PyramidError::DownsampleUnavailable {
            downsample,
            level_count: self.levels.len(),
        };
        if !downsample.is_power_of_two() {
            return Err(unavailable);
        }
        let level = downsample.trailing_zeros() as usize;
        let Some(texels) = self.levels.get(level) else {
            return Err(unavailable);
        };
        let mins: Vec<f32> = texels.iter().map(|t| t.x).collect();
        OctaMap::from_interior(self.resolution >> level, &mins).map_err(|_| unavailable)
    }
}

/// Level 0 for nearest readers: each texel bounds itself.
fn nearest_level(distance: &OctaMap<f32>) -> Vec<Vec2> {
    let layout = distance.layout();
    let n = layout.resolution();
    let mut out = Vec::with_capacity((n as usize).pow(2));
    for iy in 0..n {
        let start = layout.interior_index(0, iy);
        out.extend(
            distance.texels()[start..start + n as usize]
                .iter()
                .map(|&r| Vec2::splat(r)),
        );
    }
    out
}

/// Level 0 for bilinear readers: min/max over the 3×3 padded neighbourhood of each interior
/// texel (every tap a bilinear read inside the texel can touch), separably, keeping only three
/// rows of horizontal results at a time.
fn bilinear_level(distance: &OctaMap<f32>) -> Vec<Vec2> {
    let layout = distance.layout();
    let n = layout.resolution() as usize;
    let side = n + 2;
    let texels = distance.texels();
    // Horizontal 3-tap min/max of padded row `py`, interior columns, into `(lo, hi)`.
    let horizontal = |py: usize, lo: &mut [f32], hi: &mut [f32]| {
        let row = &texels[py * side..(py + 1) * side];
        for (((l, h), (a, b)), c) in lo
            .iter_mut()
            .zip(hi.iter_mut())
            .zip(row.iter().zip(&row[1..]))
            .zip(&row[2..])
        {
            *l = a.min(*b).min(*c);
            *h = a.max(*b).max(*c);
        }
    };
    // Ring of three horizontal rows: padded rows py ≡ slot (mod 3).
    let mut ring_min = vec![0.0f32; 3 * n];
    let mut ring_max = vec![0.0f32; 3 * n];
    for py in 0..2 {
        horizontal(
            py,
            &mut ring_min[py * n..(py + 1) * n],
            &mut ring_max[py * n..(py + 1) * n],
        );
    }
    let mut out = vec![Vec2::ZERO; n * n];
    for (iy, out_row) in out.chunks_exact_mut(n).enumerate() {
        let newest = (iy + 2) % 3;
        horizontal(
            iy + 2,
            &mut ring_min[newest * n..(newest + 1) * n],
            &mut ring_max[newest * n..(newest + 1) * n],
        );
        let (m0, rest) = ring_min.split_at(n);
        let (m1, m2) = rest.split_at(n);
        let (x0, rest) = ring_max.split_at(n);
        let (x1, x2) = rest.split_at(n);
        for (ix, texel) in out_row.iter_mut().enumerate() {
            *texel = Vec2::new(
                m0[ix].min(m1[ix]).min(m2[ix]),
                x0[ix].max(x1[ix]).max(x2[ix]),
            );
        }
    }
    out
}

/// Halves a `size × size` level: each coarse texel takes the min of mins and max of maxes of
/// its 2×2 children.
fn reduce(fine: &[Vec2], size: usize) -> Vec<Vec2> {
    let half = size / 2;
    let mut out = Vec::with_capacity(half * half);
    for y in 0..half {
        let r0 = &fine[2 * y * size..(2 * y + 1) * size];
        let r1 = &fine[(2 * y + 1) * size..(2 * y + 2) * size];
        for x in 0..half {
            let (a, b, c, d) = (r0[2 * x], r0[2 * x + 1], r1[2 * x], r1[2 * x + 1]);
            out.push(Vec2::new(
                a.x.min(b.x).min(c.x).min(d.x),
                a.y.max(b.y).max(c.y).max(d.y),
            ));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn levels_and_errors() {
        let map = OctaMap::from_fn(16, |d| 1.0 + d.x).unwrap();
        let all = MinMaxPyramid::build(&map, FineRead::Bilinear, u32::MAX).unwrap();
        assert_eq!(all.level_count(), 5);
        assert_eq!(all.level_resolution(4), Some(1));
        assert_eq!(all.level_resolution(5), None);
        let top = all.level(4).unwrap()[0];
        assert!(
            (top.x - 0.0).abs() < 0.05 && (top.y - 2.0).abs() < 0.05,
            "{top}"
        );
        let limited = MinMaxPyramid::build(&map, FineRead::Nearest, 2).unwrap();
        assert_eq!(limited.level_count(), 2);
        assert_eq!(
            MinMaxPyramid::build(&map, FineRead::Nearest, 0),
            Err(PyramidError::ZeroLevels)
        );
        let odd = OctaMap::from_fn(12, |_| 1.0).unwrap();
        assert!(matches!(
            MinMaxPyramid::build(&odd, FineRead::Nearest, 3),
            Err(PyramidError::Resolution(ResolutionError::NotPowerOfTwo {
                value: 12,
                ..
            }))
        ));
        assert_eq!(all.min_distance_map(4).unwrap().resolution(), 4);
        assert!(limited.min_distance_map(4).is_err());
        assert!(all.min_distance_map(3).is_err());
        assert!(all.min_distance_map(0).is_err());
    }
}
