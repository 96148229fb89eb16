//! Cube maps and their resampling into octahedral maps with seed 001's sharpness weight.

use glam::Vec3;

use crate::filter::{FilterError, check_lobe_power};
use crate::layout::{OctaLayout, ResolutionError, check_resolution};
use crate::map::{MapError, OctaMap, Texel};

/// A face of a cube map, in the storage order of GPU cube textures (array layers 0..6).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum CubeFace {
    /// Layer 0, major axis `+x`.
    PositiveX = 0,
    /// Layer 1, major axis `−x`.
    NegativeX = 1,
    /// Layer 2, major axis `+y`.
    PositiveY = 2,
    /// Layer 3, major axis `−y`.
    NegativeY = 3,
    /// Layer 4, major axis `+z`.
    PositiveZ = 4,
    /// Layer 5, major axis `−z`.
    NegativeZ = 5,
}

impl CubeFace {
    /// All faces in layer order.
    pub const ALL: [CubeFace; 6] = [
        CubeFace::PositiveX,
        CubeFace::NegativeX,
        CubeFace::PositiveY,
        CubeFace::NegativeY,
        CubeFace::PositiveZ,
        CubeFace::NegativeZ,
    ];

    /// The array layer of this face, `0..6`.
    #[inline]
    pub fn index(self) -> usize {
        self as usize
    }

    /// `(major axis, s axis, t axis)` as signed unit vectors: a direction `major + sc·s + tc·t`
    /// (with `sc, tc ∈ [-1, 1]`) lies on this face at face coordinates `(sc, tc)`.
    #[inline]
    fn axes(self) -> (Vec3, Vec3, Vec3) {
        match self {
            CubeFace::PositiveX => (Vec3::X, Vec3::NEG_Z, Vec3::NEG_Y),
            CubeFace::NegativeX => (Vec3::NEG_X, Vec3::Z, Vec3::NEG_Y),
            CubeFace::PositiveY => (Vec3::Y, Vec3::X, Vec3::Z),
            CubeFace::NegativeY => (Vec3::NEG_Y, Vec3::X, Vec3::NEG_Z),
            CubeFace::PositiveZ => (Vec3::Z, Vec3::X, Vec3::NEG_Y),
            CubeFace::NegativeZ => (Vec3::NEG_Z, Vec3::NEG_X, Vec3::NEG_Y),
        }
    }

    /// The face a direction hits, with its face coordinates `(sc, tc) ∈ [-1, 1]²`.
    /// Ties between axes go to x, then y. A zero or NaN direction gives `(+z, 0, 0)`.
    #[inline]
    fn of_direction(direction: Vec3) -> (CubeFace, f32, f32) {
        let a = direction.abs();
        let face = if a.x >= a.y && a.x >= a.z && a.x > 0.0 {
            if direction.x >= 0.0 {
                CubeFace::PositiveX
            } else {
                CubeFace::NegativeX
            }
        } else if a.y >= a.z && a.y > 0.0 {
            if direction.y >= 0.0 {
                CubeFace::PositiveY
            } else {
                CubeFace::NegativeY
            }
        } else if a.z > 0.0 {
            if direction.z >= 0.0 {
                CubeFace::PositiveZ
            } else {
                CubeFace::NegativeZ
            }
        } else {
            return (CubeFace::PositiveZ, 0.0, 0.0);
        };
        let (major, s, t) = face.axes();
        let m = direction.dot(major);
        (
            face,
            (direction.dot(s) / m).clamp(-1.0, 1.0),
            (direction.dot(t) / m).clamp(-1.0, 1.0),
        )
    }
}

/// A cube map of `T`: six `M×M` faces.
///
/// Convention (the one Vulkan, D3D, Metal, OpenGL and so wgpu use for cube textures): for a
/// direction with major axis `ma`, face coordinates are
///
/// | face | `sc` | `tc` |
/// |---|---|---|
/// | `+x` | `−z` | `−y` |
/// | `−x` | `+z` | `−y` |
/// | `+y` | `+x` | `+z` |
/// | `−y` | `+x` | `−z` |
/// | `+z` | `+x` | `−y` |
/// | `−z` | `−x` | `−y` |
///
/// divided by `|ma|`; `s = (sc + 1)/2`, `t = (tc + 1)/2`, and texel `(ix, iy)` covers
/// `s ∈ [ix/M, (ix+1)/M]`, `t ∈ [iy/M, (iy+1)/M]`. Storage is face after face in
/// [`CubeFace`] order, each face row-major with row `iy = 0` (`t = 0`) first, which is how
/// texel data is uploaded to a 6-layer cube texture.
#[derive(Debug, Clone, PartialEq)]
pub struct CubeMap<T> {
    face_size: u32,
    texels: Vec<T>,
}

impl<T: Texel> CubeMap<T> {
    /// A cube map whose texel holds `f(direction through the texel centre)`.
    ///
    /// # Errors
    /// [`ResolutionError`] for a face size of 0 or above [`crate::MAX_RESOLUTION`].
    pub fn from_fn(face_size: u32, mut f: impl FnMut(Vec3) -> T) -> Result<Self, ResolutionError> {
        check_resolution("face_size", face_size)?;
        let mut texels = Vec::with_capacity(6 * (face_size as usize).pow(2));
        for face in CubeFace::ALL {
            for iy in 0..face_size {
                for ix in 0..face_size {
                    texels.push(f(texel_direction(face_size, face, ix, iy)));
                }
            }
        }
        Ok(Self { face_size, texels })
    }

    /// A cube map from `6·M²` texels in storage order.
    ///
    /// # Errors
    /// [`MapError::Resolution`] or [`MapError::LengthMismatch`] (parameter `texels`).
    pub fn from_texels(face_size: u32, texels: Vec<T>) -> Result<Self, MapError> {
        check_resolution("face_size", face_size)?;
        let expected = 6 * (face_size as usize).pow(2);
        if texels.len() != expected {
            return Err(MapError::LengthMismatch {
                parameter: "texels",
                expected,
                actual: texels.len(),
            });
        }
        Ok(Self { face_size, texels })
    }

    /// Texels per face side, `M`.
    #[inline]
    pub fn face_size(&self) -> u32 {
        self.face_size
    }

    /// All texels in storage order.
    #[inline]
    pub fn texels(&self) -> &[T] {
        &self.texels
    }

    /// Texel `(ix, iy)` of a face, or `None` outside the face.
    #[inline]
    pub fn get(&self, face: CubeFace, ix: u32, iy: u32) -> Option<T> {
        let m = self.face_size;
        (ix < m && iy < m).then(|| self.texels[self.index(face, ix, iy)])
    }

    #[inline]
    fn index(&self, face: CubeFace, ix: u32, iy: u32) -> usize {
        let m = self.face_size as usize;
        face.index() * m * m + iy as usize * m + ix as usize
    }

    /// Unit direction through the centre of texel `(ix, iy)` of a face (indices clamped to `M − 1`).
    #[inline]
    pub fn texel_direction(&self, face: CubeFace, ix: u32, iy: u32) -> Vec3 {
        texel_direction(self.face_size, face, ix, iy)
    }

    /// The face and texel a direction falls in (nearest lookup). Zero or NaN directions give
    /// the centre texel of `+z`.
    #[inline]
    pub fn texel_containing(&self, direction: Vec3) -> (CubeFace, u32, u32) {
        let (face, sc, tc) = CubeFace::of_direction(direction);
        let m = self.face_size as f32;
        let last = self.face_size - 1;
        let ix = (((sc + 1.0) * 0.5 * m) as u32).min(last);
        let iy = (((tc + 1.0) * 0.5 * m) as u32).min(last);
        (face, ix, iy)
    }

    /// The texel a direction falls in.
    #[inline]
    pub fn sample_nearest(&self, direction: Vec3) -> T {
        let (face, ix, iy) = self.texel_containing(direction);
        self.texels[self.index(face, ix, iy)]
    }

    /// Resamples into an `N×N` octahedral map with seed 001's sharpness weight (eq. 4.9).
    ///
    /// Octahedral texel `o` (centre direction `d_o`) becomes the normalised weighted mean of
    /// the cube texels `c` (centre direction `d_c`, exact solid angle `Ω_c`) with weight
    /// `w = max(0, d_o·d_c)^sharpness · Ω_c`. Texels with `w < 10⁻⁴·Ω_c` are skipped, which bounds
    /// the gather to a cone of half-angle `acos(10^(−4/sharpness))`; a weight of 0 everywhere
    /// (a lobe narrower than the cube texels) falls back to the cube texel containing `d_o`.
    /// Higher sharpness gives crisper maps; plain averaging (`sharpness = 0`, a whole
    /// hemisphere) washes the map out. [`default_sharpness`] matches the lobe to the
    /// octahedral texel size.
    ///
    /// # Errors
    /// [`FilterError::Resolution`] for a bad `resolution`; [`FilterError::InvalidLobe`] for a
    /// negative or non-finite `sharpness`.
    pub fn to_octahedral(
        &self,
        resolution: u32,
        sharpness: f32,
    ) -> Result<OctaMap<T>, FilterError> {
        check_lobe_power("sharpness", sharpness)?;
        OctaLayout::new(resolution)?;
        let m = self.face_size;
        let cutoff = 1e-4f32;
        // Cosine of the gather cone: cos^s >= cutoff.
        let cos_limit = if sharpness > 0.0 {
            cutoff.powf(1.0 / sharpness)
        } else {
            0.0
        };
        let half_angle = cos_limit.clamp(-1.0, 1.0).acos();
        // Exact texel solid angles of one face (all faces are alike).
        let face_solid_angles = face_texel_solid_angles(m);
        let power = LobePower::new(sharpness);
        let directions: Vec<Vec3> = CubeFace::ALL
            .iter()
            .flat_map(|&face| {
                (0..m).flat_map(move |iy| (0..m).map(move |ix| texel_direction(m, face, ix, iy)))
            })
            .collect();
        let map = OctaMap::from_fn(resolution, |d_o| {
            let mut sum = T::zero();
            let mut weight_sum = 0.0f32;
            for face in CubeFace::ALL {
                let Some([x0, x1, y0, y1]) = cone_texel_bounds(face, d_o, half_angle, m) else {
                    continue;
                };
                for iy in y0..=y1 {
                    for ix in x0..=x1 {
                        let index = self.index(face, ix, iy);
                        let cosine = d_o.dot(directions[index]);
                        if cosine <= 0.0 || cosine < cos_limit {
                            continue;
                        }
                        let w = power.apply(cosine) * face_solid_angles[(iy * m + ix) as usize];
                        sum = sum.add_scaled(self.texels[index], w);
                        weight_sum += w;
                    }
                }
            }
            if weight_sum > 0.0 {
                T::zero().add_scaled(sum, 1.0 / weight_sum)
            } else {
                self.sample_nearest(d_o)
            }
        })?;
        Ok(map)
    }
}

/// Sharpness for [`CubeMap::to_octahedral`] that makes the weight lobe's standard deviation
/// (`≈ 1/√sharpness` radians) half the angular width of a texel of an `N×N` octahedral map
/// (`≈ 2√π/N`): `N²/π`. About 62 for DDGI's 14², 1304 for 64², 20861 for 256².
pub fn default_sharpness(resolution: u32) -> f32 {
    (resolution as f32).powi(2) / std::f32::consts::PI
}

/// `x^power` with fast paths for small integer powers.
#[derive(Debug, Clone, Copy)]
pub(crate) struct LobePower {
    power: f32,
    integer: Option<i32>,
}

impl LobePower {
    pub(crate) fn new(power: f32) -> Self {
        let integer = (power.fract() == 0.0 && power <= 64.0).then_some(power as i32);
        Self { power, integer }
    }

    #[inline]
    pub(crate) fn apply(self, x: f32) -> f32 {
        match self.integer {
            Some(1) => x,
            Some(k) => x.powi(k),
            None => x.powf(self.power),
        }
    }
}

/// Direction through the centre of texel `(ix, iy)` of a face of size `m`.
#[inline]
fn texel_direction(m: u32, face: CubeFace, ix: u32, iy: u32) -> Vec3 {
    let mf = m as f32;
    let sc = (2.0 * ix.min(m - 1) as f32 + 1.0) / mf - 1.0;
    let tc = (2.0 * iy.min(m - 1) as f32 + 1.0) / mf - 1.0;
    let (major, s, t) = face.axes();
    (major + s * sc + t * tc).normalize()
}

/// Exact solid angles of the texels of one cube face of size `m`, row-major.
fn face_texel_solid_angles(m: u32) -> Vec<f32> {
    // Solid angle of the face region [0, x] × [0, y] (unit distance): atan2(xy, sqrt(x²+y²+1)).
    let area = |x: f64, y: f64| (x * y).atan2((x * x + y * y + 1.0).sqrt());
    let mf = f64::from(m);
    let edge = |i: u32| 2.0 * f64::from(i) / mf - 1.0;
    let mut out = Vec::with_capacity((m as usize).pow(2));
    for iy in 0..m {
        for ix in 0..m {
            let (x0, x1, y0, y1) = (edge(ix), edge(ix + 1), edge(iy), edge(iy + 1));
            let value = area(x0, y0) - area(x0, y1) - area(x1, y0) + area(x1, y1);
            out.push(value as f32);
        }
    }
    out
}

/// Inclusive texel bounds `[x0, x1, y0, y1]` on a face that contain every direction within
/// `half_angle` of the unit direction `d`, or `None` if the cone misses the face.
///
/// Conservative: bounds the spherical cap by its axis-aligned box, intersects the box with the
/// face's pyramid (`major >= 1/√3`) and projects the box through the face's central projection.
fn cone_texel_bounds(face: CubeFace, d: Vec3, half_angle: f32, m: u32) -> Option<[u32; 4]> {
    let (major, s_axis, t_axis) = face.axes();
    // Range of a unit-vector component `e·axis` over the cap.
    let range = |axis: Vec3| -> (f32, f32) {
        let c = d.dot(axis).clamp(-1.0, 1.0);
        let to_axis = c.acos();
        let to_opposite = std::f32::consts::PI - to_axis;
        let hi = (to_axis - half_angle).max(0.0).cos();
        let lo = -(to_opposite - half_angle).max(0.0).cos();
        (lo, hi)
    };
    let (_, m_hi) = range(major);
    let face_min = 1.0 / 3.0f32.sqrt() - 1e-6;
    if m_hi < face_min {
        return None;
    }
    let (m_lo, _) = range(major);
    let m0 = m_lo.max(face_min);
    let m1 = m_hi.max(m0);
    // Extremes of component/major over the box, both bounds of `major` positive.
    let ratio = |(lo, hi): (f32, f32)| -> (f32, f32) {
        let min = if lo < 0.0 { lo / m0 } else { lo / m1 };
        let max = if hi > 0.0 { hi / m0 } else { hi / m1 };
        (min.clamp(-1.0, 1.0), max.clamp(-1.0, 1.0))
    };
    let (s_lo, s_hi) = ratio(range(s_axis));
    let (t_lo, t_hi) = ratio(range(t_axis));
    let mf = m as f32;
    let last = m - 1;
    let to_texel = |c: f32| (((c + 1.0) * 0.5 * mf) as u32).min(last);
    Some([
        to_texel(s_lo),
        to_texel(s_hi),
        to_texel(t_lo),
        to_texel(t_hi),
    ])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn face_convention_matches_the_table() {
        let cube = CubeMap::from_fn(4, |d| [d.x, d.y, d.z]).unwrap();
        // +x face, texel (0, 0): s = 0 → sc = −1 → z = +1; t = 0 → tc = −1 → y = +1.
        let d = cube.texel_direction(CubeFace::PositiveX, 0, 0);
        assert!(d.x > 0.0 && d.y > 0.0 && d.z > 0.0, "{d}");
        // +y face, texel (0, 0): x = −1, z = −1.
        let d = cube.texel_direction(CubeFace::PositiveY, 0, 0);
        assert!(d.y > 0.0 && d.x < 0.0 && d.z < 0.0, "{d}");
        // −z face, last texel: sc = +1 → x = −1; tc = +1 → y = −1.
        let d = cube.texel_direction(CubeFace::NegativeZ, 3, 3);
        assert!(d.z < 0.0 && d.x < 0.0 && d.y < 0.0, "{d}");
        for face in CubeFace::ALL {
            for iy in 0..4 {
                for ix in 0..4 {
                    let d = cube.texel_direction(face, ix, iy);
                    assert_eq!(cube.texel_containing(d), (face, ix, iy));
                    assert_eq!(cube.get(face, ix, iy), Some([d.x, d.y, d.z]));
                }
            }
        }
        assert_eq!(cube.texel_containing(Vec3::ZERO).0, CubeFace::PositiveZ);
    }

    #[test]
    fn face_solid_angles_sum_to_a_sixth_of_the_sphere() {
        for m in [1, 3, 64] {
            let sum: f64 = face_texel_solid_angles(m)
                .iter()
                .map(|&a| f64::from(a))
                .sum();
            assert!(
                (sum - 4.0 * std::f64::consts::PI / 6.0).abs() < 1e-5,
                "m={m}: {sum}"
            );
        }
    }

    #[test]
    fn cone_bounds_contain_every_direction_in_the_cone() {
        let m = 16;
        let mut state = 0x1234_5678_u32;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            state as f32 / u32::MAX as f32
        };
        for _ in 0..400 {
            let d = crate::decode(glam::Vec2::new(next() * 2.0 - 1.0, next() * 2.0 - 1.0));
            let half_angle = next() * 0.6;
            for face in CubeFace::ALL {
                let bounds = cone_texel_bounds(face, d, half_angle, m);
                for iy in 0..m {
                    for ix in 0..m {
                        let c = texel_direction(m, face, ix, iy);
                        if c.dot(d).clamp(-1.0, 1.0).acos() <= half_angle * 0.999 {
                            let [x0, x1, y0, y1] = bounds.expect("cone reaches this face");
                            assert!((x0..=x1).contains(&ix) && (y0..=y1).contains(&iy));
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn bad_sharpness_is_refused() {
        let cube = CubeMap::from_fn(4, |_| 1.0f32).unwrap();
        assert!(matches!(
            cube.to_octahedral(8, -1.0),
            Err(FilterError::InvalidLobe {
                parameter: "sharpness",
                ..
            })
        ));
        assert!(cube.to_octahedral(8, f32::NAN).is_err());
        assert!(cube.to_octahedral(0, 1.0).is_err());
        assert!(CubeMap::<f32>::from_texels(2, vec![0.0; 23]).is_err());
        assert!(CubeMap::from_fn(0, |_| 0.0f32).is_err());
    }
}
