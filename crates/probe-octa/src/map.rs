//! `OctaMap<T>`: a padded octahedral map with seam-correct bilinear sampling.

use glam::{Vec2, Vec3, Vec4};

use crate::layout::{OctaLayout, ResolutionError};

/// A value that can be stored in a map and filtered: a weighted sum of texels must make sense.
///
/// Implemented for `f32`, `Vec2`, `Vec3`, `Vec4` and `[f32; K]`.
pub trait Texel: Copy {
    /// The additive identity.
    fn zero() -> Self;
    /// `self + other · weight`.
    fn add_scaled(self, other: Self, weight: f32) -> Self;
}

impl Texel for f32 {
    #[inline]
    fn zero() -> Self {
        0.0
    }
    #[inline]
    fn add_scaled(self, other: Self, weight: f32) -> Self {
        self + other * weight
    }
}

macro_rules! impl_texel_for_vector {
    ($($ty:ty),*) => {$(
        impl Texel for $ty {
            #[inline]
            fn zero() -> Self {
                <$ty>::ZERO
            }
            #[inline]
            fn add_scaled(self, other: Self, weight: f32) -> Self {
                self + other * weight
            }
        }
    )*};
}
impl_texel_for_vector!(Vec2, Vec3, Vec4);

impl<const K: usize> Texel for [f32; K] {
    #[inline]
    fn zero() -> Self {
        [0.0; K]
    }
    #[inline]
    fn add_scaled(mut self, other: Self, weight: f32) -> Self {
        for (a, b) in self.iter_mut().zip(other) {
            *a += b * weight;
        }
        self
    }
}

/// Why map data was refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum MapError {
    /// The resolution is unusable; see [`ResolutionError`].
    #[error(transparent)]
    Resolution(#[from] ResolutionError),
    /// A texel buffer has the wrong number of texels. Fix: pass `N²` texels for an interior
    /// buffer, `(N+2)²` for a padded one, `6·M²` for a cube map of face size `M`.
    #[error("`{parameter}` holds {actual} texels; the layout needs {expected}")]
    LengthMismatch {
        /// The parameter that held the buffer.
        parameter: &'static str,
        /// The number of texels the layout needs.
        expected: usize,
        /// The number given.
        actual: usize,
    },
    /// A texel index lies outside the interior. Fix: keep `ix, iy < resolution`.
    #[error("texel ({ix}, {iy}) lies outside the {resolution}×{resolution} interior")]
    TexelOutOfRange {
        /// Column asked for.
        ix: u32,
        /// Row asked for.
        iy: u32,
        /// Interior resolution of the map.
        resolution: u32,
    },
}

/// An `N×N` octahedral map of `T`, stored padded as `(N+2)²` texels (see [`OctaLayout`]).
///
/// Every constructor and [`Self::set`] keep the border equal to what [`Self::pad`] would
/// write, so [`Self::sample`] is seam-correct at all times; only after writing through
/// [`Self::texels_mut`] must the caller call [`Self::pad`].
#[derive(Debug, Clone, PartialEq)]
pub struct OctaMap<T> {
    layout: OctaLayout,
    texels: Vec<T>,
}

impl<T: Texel> OctaMap<T> {
    /// A map with every texel set to `value`.
    ///
    /// # Errors
    /// [`ResolutionError`] for a resolution of 0 or above [`crate::MAX_RESOLUTION`].
    pub fn filled(resolution: u32, value: T) -> Result<Self, ResolutionError> {
        let layout = OctaLayout::new(resolution)?;
        Ok(Self {
            layout,
            texels: vec![value; layout.padded_len()],
        })
    }

    /// A map whose interior texel holds `f(direction through the texel centre)`, then padded.
    /// `f` is called once per interior texel, row by row from texel `(0, 0)`.
    ///
    /// # Errors
    /// [`ResolutionError`] for a resolution of 0 or above [`crate::MAX_RESOLUTION`].
    pub fn from_fn(resolution: u32, mut f: impl FnMut(Vec3) -> T) -> Result<Self, ResolutionError> {
        let layout = OctaLayout::new(resolution)?;
        let mut texels = vec![T::zero(); layout.padded_len()];
        for iy in 0..resolution {
            for ix in 0..resolution {
                texels[layout.interior_index(ix, iy)] = f(layout.texel_direction(ix, iy));
            }
        }
        layout.pad_unchecked(&mut texels);
        Ok(Self { layout, texels })
    }

    /// A map from `N²` interior texels in row-major order (`iy·N + ix`), then padded.
    ///
    /// # Errors
    /// [`MapError::Resolution`] or [`MapError::LengthMismatch`] (parameter `interior`).
    pub fn from_interior(resolution: u32, interior: &[T]) -> Result<Self, MapError> {
        let layout = OctaLayout::new(resolution)?;
        let n = resolution as usize;
        if interior.len() != n * n {
            return Err(MapError::LengthMismatch {
                parameter: "interior",
                expected: n * n,
                actual: interior.len(),
            });
        }
        let mut texels = vec![T::zero(); layout.padded_len()];
        for (iy, row) in interior.chunks_exact(n).enumerate() {
            let start = layout.interior_index(0, iy as u32);
            texels[start..start + n].copy_from_slice(row);
        }
        layout.pad_unchecked(&mut texels);
        Ok(Self { layout, texels })
    }

    /// A map from `(N+2)²` padded texels as stored (e.g. read back from a GPU). The border is
    /// kept as given; call [`Self::pad`] if it may be stale.
    ///
    /// # Errors
    /// [`MapError::Resolution`] or [`MapError::LengthMismatch`] (parameter `padded`).
    pub fn from_padded(resolution: u32, padded: Vec<T>) -> Result<Self, MapError> {
        let layout = OctaLayout::new(resolution)?;
        if padded.len() != layout.padded_len() {
            return Err(MapError::LengthMismatch {
                parameter: "padded",
                expected: layout.padded_len(),
                actual: padded.len(),
            });
        }
        Ok(Self {
            layout,
            texels: padded,
        })
    }

    /// The map's layout.
    #[inline]
    pub fn layout(&self) -> OctaLayout {
        self.layout
    }

    /// Interior texels per side, `N`.
    #[inline]
    pub fn resolution(&self) -> u32 {
        self.layout.resolution()
    }

    /// All `(N+2)²` padded texels in storage order (ready to upload as a texture).
    #[inline]
    pub fn texels(&self) -> &[T] {
        &self.texels
    }

    /// Mutable padded texels; call [`Self::pad`] after changing interior edge texels.
    #[inline]
    pub fn texels_mut(&mut self) -> &mut [T] {
        &mut self.texels
    }

    /// The padded texels, consuming the map.
    pub fn into_texels(self) -> Vec<T> {
        self.texels
    }

    /// Interior texel `(ix, iy)`, or `None` outside the interior.
    #[inline]
    pub fn get(&self, ix: u32, iy: u32) -> Option<T> {
        let n = self.layout.resolution();
        (ix < n && iy < n).then(|| self.texels[self.layout.interior_index(ix, iy)])
    }

    /// Sets interior texel `(ix, iy)` and the border texels that copy it, so the map stays padded.
    ///
    /// # Errors
    /// [`MapError::TexelOutOfRange`] outside the interior.
    pub fn set(&mut self, ix: u32, iy: u32, value: T) -> Result<(), MapError> {
        let n = self.layout.resolution();
        if ix >= n || iy >= n {
            return Err(MapError::TexelOutOfRange {
                ix,
                iy,
                resolution: n,
            });
        }
        let (px, py) = (ix + 1, iy + 1);
        self.texels[self.layout.padded_index(px, py)] = value;
        // The border copies of (px, py): invert the rules of `OctaLayout::border_source`.
        let s = n + 1;
        let mut targets = [None; 5];
        if px == 1 {
            targets[0] = Some((0, s - py));
        }
        if px == n {
            targets[1] = Some((s, s - py));
        }
        if py == 1 {
            targets[2] = Some((s - px, 0));
        }
        if py == n {
            targets[3] = Some((s - px, s));
        }
        targets[4] = match (px == 1, px == n, py == 1, py == n) {
            (true, _, true, _) => Some((s, s)),
            (true, _, _, true) => Some((s, 0)),
            (_, true, true, _) => Some((0, s)),
            (_, true, _, true) => Some((0, 0)),
            _ => None,
        };
        // With N = 1 one interior texel feeds every border texel.
        if n == 1 {
            self.texels.fill(value);
            return Ok(());
        }
        for (tx, ty) in targets.into_iter().flatten() {
            self.texels[self.layout.padded_index(tx, ty)] = value;
        }
        Ok(())
    }

    /// Rewrites the border from the interior (seed 001, Listing 4.4; see
    /// [`OctaLayout::border_source`]).
    pub fn pad(&mut self) {
        self.layout.pad_unchecked(&mut self.texels);
    }

    /// Bilinear sample in a direction, seam-correct through the padding: what a GPU bilinear
    /// sampler returns for the padded texture at [`OctaLayout::texture_uv`] (up to the GPU's
    /// reduced-precision filter weights). Directions that do not encode (zero, NaN) sample at
    /// `+z`, as [`crate::encode`] defines.
    ///
    /// Keep texels finite: like a GPU, the blend multiplies every tap by its weight, and an
    /// infinite texel times a zero weight is NaN. Store misses as a large finite distance.
    #[inline]
    pub fn sample(&self, direction: Vec3) -> T {
        self.sample_octa(crate::encode(direction))
    }

    /// Bilinear sample at octahedral coordinates (clamped to `[-1, 1]²`).
    #[inline]
    pub fn sample_octa(&self, octa: Vec2) -> T {
        let c = self.layout.octa_to_texel_coords(octa) - Vec2::splat(0.5);
        // c ∈ [0.5, N + 0.5], so the four taps lie in the padded grid.
        let last = self.layout.resolution();
        let x0 = (c.x.floor().max(0.0) as u32).min(last);
        let y0 = (c.y.floor().max(0.0) as u32).min(last);
        let tx = (c.x - x0 as f32).clamp(0.0, 1.0);
        let ty = (c.y - y0 as f32).clamp(0.0, 1.0);
        let i00 = self.layout.padded_index(x0, y0);
        let i01 = i00 + self.layout.padded_size() as usize;
        let (t00, t10, t01, t11) = (
            self.texels[i00],
            self.texels[i00 + 1],
            self.texels[i01],
            self.texels[i01 + 1],
        );
        T::zero()
            .add_scaled(t00, (1.0 - tx) * (1.0 - ty))
            .add_scaled(t10, tx * (1.0 - ty))
            .add_scaled(t01, (1.0 - tx) * ty)
            .add_scaled(t11, tx * ty)
    }

    /// The interior texel whose square contains the direction (nearest lookup, `texelFetch`).
    #[inline]
    pub fn sample_nearest(&self, direction: Vec3) -> T {
        let [ix, iy] = self.layout.texel_containing(direction);
        self.texels[self.layout.interior_index(ix, iy)]
    }

    /// A map of the same layout with `f` applied to every stored texel (border included).
    pub fn map<U: Texel>(&self, f: impl FnMut(T) -> U) -> OctaMap<U> {
        OctaMap {
            layout: self.layout,
            texels: self.texels.iter().copied().map(f).collect(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn smooth(d: Vec3) -> f32 {
        0.3 + 0.5 * d.x - 0.25 * d.y + 0.4 * d.z * d.z + 0.2 * (3.0 * d.x * d.y).sin()
    }

    #[test]
    fn set_keeps_the_border_padded() {
        for n in [1, 2, 3, 8] {
            let mut map = OctaMap::filled(n, 0.0f32).unwrap();
            let mut value = 1.0;
            for iy in 0..n {
                for ix in 0..n {
                    map.set(ix, iy, value).unwrap();
                    value += 1.0;
                    let mut repadded = map.clone();
                    repadded.pad();
                    assert_eq!(map, repadded, "n={n} after ({ix},{iy})");
                }
            }
            assert_eq!(
                map.set(n, 0, 1.0),
                Err(MapError::TexelOutOfRange {
                    ix: n,
                    iy: 0,
                    resolution: n
                })
            );
            assert_eq!(map.get(0, n), None);
        }
    }

    #[test]
    fn constructors_agree_and_check_lengths() {
        let a = OctaMap::from_fn(6, smooth).unwrap();
        let interior: Vec<f32> = (0..36).map(|i| a.get(i % 6, i / 6).unwrap()).collect();
        let b = OctaMap::from_interior(6, &interior).unwrap();
        assert_eq!(a, b);
        let c = OctaMap::from_padded(6, a.texels().to_vec()).unwrap();
        assert_eq!(a, c);
        assert_eq!(
            OctaMap::from_interior(6, &interior[1..]),
            Err(MapError::LengthMismatch {
                parameter: "interior",
                expected: 36,
                actual: 35
            })
        );
        assert!(OctaMap::<f32>::from_padded(6, vec![0.0; 63]).is_err());
        assert!(OctaMap::filled(0, 0.0f32).is_err());
        assert!(a.layout().pad(&mut [0.0f32; 3]).is_err());
    }

    #[test]
    fn samples_reproduce_texels_at_centres() {
        let map = OctaMap::from_fn(16, |d| [d.x, d.y, d.z]).unwrap();
        for iy in 0..16 {
            for ix in 0..16 {
                let d = map.layout().texel_direction(ix, iy);
                let expected = map.get(ix, iy).unwrap();
                let got = map.sample(d);
                let nearest = map.sample_nearest(d);
                assert_eq!(nearest, expected);
                for k in 0..3 {
                    assert!((got[k] - expected[k]).abs() < 1e-4, "({ix},{iy})");
                }
            }
        }
    }

    /// Bilinear interpolation is first-order here: a smooth function of direction has kinks in
    /// octahedral coordinates along the axes and the fold `|u| + |v| = 1`.
    #[test]
    fn bilinear_error_shrinks_with_resolution() {
        let mut previous = f32::INFINITY;
        for n in [16, 64, 256] {
            let map = OctaMap::from_fn(n, smooth).unwrap();
            let mut worst = 0.0f32;
            for i in 0..2000 {
                let d = crate::decode(Vec2::new(
                    (i as f32 * 0.618_034).fract() * 2.0 - 1.0,
                    (i as f32 * 0.754_877_7).fract() * 2.0 - 1.0,
                ));
                worst = worst.max((map.sample(d) - smooth(d)).abs());
            }
            assert!(worst < previous * 0.35, "n={n}: {worst} vs {previous}");
            previous = worst;
        }
        assert!(previous < 3e-3, "{previous}");
    }

    #[test]
    fn map_applies_to_every_texel() {
        let map = OctaMap::from_fn(4, smooth).unwrap();
        let doubled = map.map(|r| Vec2::new(r, r * r));
        for (a, b) in map.texels().iter().zip(doubled.texels()) {
            assert_eq!(Vec2::new(*a, a * a), *b);
        }
    }
}
