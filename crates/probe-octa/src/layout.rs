//! Texel layout of an `N×N` octahedral map stored with a 1-texel border as `(N+2)²` texels.

use glam::{DVec2, DVec3, Vec2, Vec3};

use crate::octahedral::{decode, encode};

/// Largest interior resolution a layout accepts (the padded map then has `16386²` texels).
pub const MAX_RESOLUTION: u32 = 16_384;

/// Why an octahedral or cube-map resolution was refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum ResolutionError {
    /// The resolution was 0. Fix: pass at least 1 (a useful octahedral map has 8 or more).
    #[error("`{parameter}` is 0; a map needs at least 1 texel per side")]
    Zero {
        /// The parameter that held the resolution.
        parameter: &'static str,
    },
    /// The resolution exceeds [`MAX_RESOLUTION`]. Fix: use a smaller map; GPUs rarely
    /// accept 2-D textures wider than 16384 anyway.
    #[error("`{parameter}` is {value}, above the limit of {max}")]
    TooLarge {
        /// The parameter that held the resolution.
        parameter: &'static str,
        /// The value given.
        value: u32,
        /// The largest value accepted.
        max: u32,
    },
    /// The operation halves the resolution level by level, so it must be a power of two.
    /// Fix: resample the map to a power-of-two resolution (e.g. 64, 256, 1024).
    #[error("`{parameter}` is {value}, which is not a power of two")]
    NotPowerOfTwo {
        /// The parameter that held the resolution.
        parameter: &'static str,
        /// The value given.
        value: u32,
    },
}

/// Checks a resolution parameter: `1..=MAX_RESOLUTION`.
pub(crate) fn check_resolution(parameter: &'static str, value: u32) -> Result<(), ResolutionError> {
    if value == 0 {
        Err(ResolutionError::Zero { parameter })
    } else if value > MAX_RESOLUTION {
        Err(ResolutionError::TooLarge {
            parameter,
            value,
            max: MAX_RESOLUTION,
        })
    } else {
        Ok(())
    }
}

/// The layout of an octahedral map with `N×N` interior texels and a 1-texel border.
///
/// Conventions (see the crate documentation for the full statement):
/// * interior texel `(ix, iy)`, `0 <= ix, iy < N`, covers octahedral coordinates
///   `u ∈ [-1 + 2·ix/N, -1 + 2·(ix+1)/N]` and likewise `v` with `iy`; its centre is
///   `-1 + (2·ix + 1)/N`. `ix` grows with `u`, `iy` with `v`; interior texel `(0, 0)` is the
///   corner `(u, v) = (-1, -1)`.
/// * storage is row-major over the padded `(N+2)×(N+2)` grid, row `py` after row `py − 1`:
///   padded texel `(px, py)` is element `py·(N+2) + px`, and interior `(ix, iy)` is padded
///   `(ix+1, iy+1)`.
/// * border texels copy interior texels as in seed 001, Listing 4.4 (see [`Self::border_source`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct OctaLayout {
    resolution: u32,
}

impl OctaLayout {
    /// A layout with `resolution × resolution` interior texels.
    ///
    /// # Errors
    /// [`ResolutionError::Zero`] or [`ResolutionError::TooLarge`].
    pub fn new(resolution: u32) -> Result<Self, ResolutionError> {
        check_resolution("resolution", resolution)?;
        Ok(Self { resolution })
    }

    /// Interior texels per side, `N`.
    #[inline]
    pub fn resolution(&self) -> u32 {
        self.resolution
    }

    /// Texels per side of the padded storage, `N + 2`.
    #[inline]
    pub fn padded_size(&self) -> u32 {
        self.resolution + 2
    }

    /// Number of stored texels, `(N + 2)²`.
    #[inline]
    pub fn padded_len(&self) -> usize {
        let side = self.padded_size() as usize;
        side * side
    }

    /// Storage index of padded texel `(px, py)`: `py·(N+2) + px`. Callers keep `px, py <= N+1`.
    #[inline]
    pub fn padded_index(&self, px: u32, py: u32) -> usize {
        py as usize * self.padded_size() as usize + px as usize
    }

    /// Storage index of interior texel `(ix, iy)`, i.e. of padded texel `(ix+1, iy+1)`.
    #[inline]
    pub fn interior_index(&self, ix: u32, iy: u32) -> usize {
        self.padded_index(ix + 1, iy + 1)
    }

    /// Octahedral coordinates of the centre of interior texel `(ix, iy)`; indices past the
    /// edge are clamped to `N − 1`.
    #[inline]
    pub fn texel_center(&self, ix: u32, iy: u32) -> Vec2 {
        let n = self.resolution as f32;
        let ix = ix.min(self.resolution - 1) as f32;
        let iy = iy.min(self.resolution - 1) as f32;
        Vec2::new((2.0 * ix + 1.0) / n - 1.0, (2.0 * iy + 1.0) / n - 1.0)
    }

    /// Unit direction through the centre of interior texel `(ix, iy)` (indices clamped to `N − 1`).
    #[inline]
    pub fn texel_direction(&self, ix: u32, iy: u32) -> Vec3 {
        decode(self.texel_center(ix, iy))
    }

    /// Continuous padded texel coordinates of a direction: padded texel `(px, py)` spans
    /// `[px, px+1) × [py, py+1)` and has its centre at `(px + 0.5, py + 0.5)`; the interior spans
    /// `[1, N+1]²`. So `c = 1 + (octa + 1)/2 · N`.
    #[inline]
    pub fn texel_coords(&self, direction: Vec3) -> Vec2 {
        self.octa_to_texel_coords(encode(direction))
    }

    /// [`Self::texel_coords`] from octahedral coordinates (clamped to `[-1, 1]²`).
    #[inline]
    pub fn octa_to_texel_coords(&self, octa: Vec2) -> Vec2 {
        let n = self.resolution as f32;
        let o = octa.clamp(Vec2::NEG_ONE, Vec2::ONE);
        Vec2::ONE + (o + Vec2::ONE) * (0.5 * n)
    }

    /// Normalised texture coordinates of a direction over the whole padded texture, as a GPU
    /// sampler takes them: `texel_coords / (N + 2)`. Sampling the padded texture there with
    /// bilinear filtering gives [`crate::OctaMap::sample`].
    #[inline]
    pub fn texture_uv(&self, direction: Vec3) -> Vec2 {
        self.texel_coords(direction) / self.padded_size() as f32
    }

    /// Interior texel `(ix, iy)` whose square contains the direction (nearest-texel lookup).
    #[inline]
    pub fn texel_containing(&self, direction: Vec3) -> [u32; 2] {
        self.octa_texel_containing(encode(direction))
    }

    /// Interior texel whose square contains the octahedral point (clamped to the map).
    #[inline]
    pub fn octa_texel_containing(&self, octa: Vec2) -> [u32; 2] {
        let n = self.resolution as f32;
        let o = octa.clamp(Vec2::NEG_ONE, Vec2::ONE);
        let f = (o + Vec2::ONE) * (0.5 * n);
        let last = self.resolution - 1;
        // `as u32` saturates negative values to 0.
        [(f.x as u32).min(last), (f.y as u32).min(last)]
    }

    /// For a border texel, the padded coordinates of the interior texel it copies (seed 001,
    /// Listing 4.4); `None` for interior texels and coordinates outside the padded grid.
    ///
    /// With `S = N + 1` (the last padded index):
    /// * left/right columns mirror rows: `(0, py) ← (1, S − py)`, `(S, py) ← (N, S − py)`;
    /// * top/bottom rows mirror columns: `(px, 0) ← (S − px, 1)`, `(px, S) ← (S − px, N)`;
    /// * each corner takes the diagonally opposite interior corner:
    ///   `(0, 0) ← (N, N)`, `(S, 0) ← (1, N)`, `(0, S) ← (N, 1)`, `(S, S) ← (1, 1)`.
    ///
    /// This is the octahedral wrap: the outer edge `u = ±1` is folded onto itself about its
    /// midpoint, so `(±1, v)` and `(±1, −v)` are the same direction (likewise for `v = ±1`),
    /// and all four corners are `−z`.
    #[inline]
    pub fn border_source(&self, px: u32, py: u32) -> Option<[u32; 2]> {
        let n = self.resolution;
        let s = n + 1;
        if px > s || py > s {
            return None;
        }
        let left_or_right = px == 0 || px == s;
        let top_or_bottom = py == 0 || py == s;
        match (left_or_right, top_or_bottom) {
            (false, false) => None,
            (true, true) => Some([if px == 0 { n } else { 1 }, if py == 0 { n } else { 1 }]),
            (true, false) => Some([if px == 0 { 1 } else { n }, s - py]),
            (false, true) => Some([s - px, if py == 0 { 1 } else { n }]),
        }
    }

    /// Fills the border of a padded slice laid out by this layout from its interior.
    ///
    /// # Errors
    /// [`crate::MapError::LengthMismatch`] if `texels.len() != (N+2)²`.
    pub fn pad<T: Copy>(&self, texels: &mut [T]) -> Result<(), crate::MapError> {
        if texels.len() != self.padded_len() {
            return Err(crate::MapError::LengthMismatch {
                parameter: "texels",
                expected: self.padded_len(),
                actual: texels.len(),
            });
        }
        self.pad_unchecked(texels);
        Ok(())
    }

    /// [`Self::pad`] for slices known to have the right length.
    pub(crate) fn pad_unchecked<T: Copy>(&self, texels: &mut [T]) {
        let s = self.resolution + 1;
        let mut copy = |px: u32, py: u32| {
            if let Some([sx, sy]) = self.border_source(px, py) {
                texels[self.padded_index(px, py)] = texels[self.padded_index(sx, sy)];
            }
        };
        for p in 0..=s {
            copy(p, 0);
            copy(p, s);
            copy(0, p);
            copy(s, p);
        }
    }

    /// Exact solid angle (steradians) subtended by interior texel `(ix, iy)`; indices are
    /// clamped to `N − 1`. The texels of a map sum to `4π`.
    ///
    /// Each texel square maps to planar pieces of the octahedron `|x|+|y|+|z| = 1`, whose solid
    /// angles are summed exactly (Van Oosterom and Strackee's triangle formula) in `f64`.
    pub fn texel_solid_angle(&self, ix: u32, iy: u32) -> f32 {
        let n = f64::from(self.resolution);
        let ix = f64::from(ix.min(self.resolution - 1));
        let iy = f64::from(iy.min(self.resolution - 1));
        let u0 = 2.0 * ix / n - 1.0;
        let v0 = 2.0 * iy / n - 1.0;
        rect_solid_angle(u0, u0 + 2.0 / n, v0, v0 + 2.0 / n) as f32
    }

    /// [`Self::texel_solid_angle`] of every interior texel, row-major over the interior
    /// (`iy·N + ix`), computed with one shared table of corner integrals.
    pub fn texel_solid_angles(&self) -> Vec<f32> {
        let n = self.resolution as usize;
        let nf = f64::from(self.resolution);
        let corners: Vec<f64> = (0..=n).map(|i| 2.0 * i as f64 / nf - 1.0).collect();
        if n % 2 == 1 {
            // A texel straddles u = 0; the general rectangle formula handles that.
            let mut out = Vec::with_capacity(n * n);
            for iy in 0..n {
                for ix in 0..n {
                    out.push(rect_solid_angle(
                        corners[ix],
                        corners[ix + 1],
                        corners[iy],
                        corners[iy + 1],
                    ) as f32);
                }
            }
            return out;
        }
        // Even N: every texel lies in one quadrant, so its solid angle is an
        // inclusion–exclusion of the quadrant integral F at its corners.
        let table: Vec<f64> = {
            let mut t = Vec::with_capacity((n + 1) * (n + 1));
            for &b in &corners {
                for &a in &corners {
                    t.push(quadrant_solid_angle(a.abs(), b.abs()));
                }
            }
            t
        };
        let at = |i: usize, j: usize| table[j * (n + 1) + i];
        let mut out = Vec::with_capacity(n * n);
        for iy in 0..n {
            for ix in 0..n {
                let value = at(ix + 1, iy + 1) - at(ix, iy + 1) - at(ix + 1, iy) + at(ix, iy);
                out.push(value.abs() as f32);
            }
        }
        out
    }
}

/// Solid angle of the octahedral rectangle `[u0, u1] × [v0, v1]` (`u0 <= u1`, `v0 <= v1`,
/// all in `[-1, 1]`), split into its parts in the four quadrants, each mirrored into the first.
pub(crate) fn rect_solid_angle(u0: f64, u1: f64, v0: f64, v1: f64) -> f64 {
    // Positive and (mirrored) negative parts of each interval, as [lo, hi] in [0, 1].
    let parts = |lo: f64, hi: f64| -> [(f64, f64); 2] {
        [(lo.max(0.0), hi.max(0.0)), ((-hi).max(0.0), (-lo).max(0.0))]
    };
    let mut total = 0.0;
    for (a0, a1) in parts(u0, u1) {
        if a1 <= a0 {
            continue;
        }
        for (b0, b1) in parts(v0, v1) {
            if b1 <= b0 {
                continue;
            }
            total += quadrant_solid_angle(a1, b1)
                - quadrant_solid_angle(a0, b1)
                - quadrant_solid_angle(a1, b0)
                + quadrant_solid_angle(a0, b0);
        }
    }
    total
}

/// `F(a, b)`: solid angle of the octahedral rectangle `[0, a] × [0, b]`, `a, b ∈ [0, 1]`.
///
/// The part with `u + v <= 1` lies on the face `x + y + z = 1` at `(u, v, 1 − u − v)`; the part
/// with `u + v >= 1` is folded onto `x + y − z = 1` at `(1 − v, 1 − u, 1 − u − v)`. Both are
/// convex polygons, fanned into triangles.
fn quadrant_solid_angle(a: f64, b: f64) -> f64 {
    if a <= 0.0 || b <= 0.0 {
        return 0.0;
    }
    let rect = [
        DVec2::new(0.0, 0.0),
        DVec2::new(a, 0.0),
        DVec2::new(a, b),
        DVec2::new(0.0, b),
    ];
    let upper = clip_sum(&rect, 1.0, true);
    let lower = clip_sum(&rect, 1.0, false);
    let upper_angle = polygon_solid_angle(&upper, |p| DVec3::new(p.x, p.y, 1.0 - p.x - p.y));
    let lower_angle = polygon_solid_angle(&lower, |p| {
        DVec3::new(1.0 - p.y, 1.0 - p.x, 1.0 - p.x - p.y)
    });
    upper_angle + lower_angle
}

/// Clips a convex polygon (at most 4 vertices) to `u + v <= limit` (`keep_below`) or
/// `u + v >= limit`. Returns up to 5 vertices.
fn clip_sum(polygon: &[DVec2; 4], limit: f64, keep_below: bool) -> Vec<DVec2> {
    let inside = |p: DVec2| {
        if keep_below {
            p.x + p.y <= limit
        } else {
            p.x + p.y >= limit
        }
    };
    let mut out = Vec::with_capacity(5);
    for i in 0..polygon.len() {
        let current = polygon[i];
        let next = polygon[(i + 1) % polygon.len()];
        let (ci, ni) = (inside(current), inside(next));
        if ci {
            out.push(current);
        }
        if ci != ni {
            let sc = current.x + current.y - limit;
            let sn = next.x + next.y - limit;
            let t = sc / (sc - sn);
            out.push(current + (next - current) * t);
        }
    }
    out
}

/// Solid angle of a planar convex polygon (octahedral vertices lifted to 3-D by `lift`).
fn polygon_solid_angle(polygon: &[DVec2], lift: impl Fn(DVec2) -> DVec3) -> f64 {
    if polygon.len() < 3 {
        return 0.0;
    }
    let first = lift(polygon[0]);
    let mut total = 0.0;
    for pair in polygon[1..].windows(2) {
        total += triangle_solid_angle(first, lift(pair[0]), lift(pair[1]));
    }
    total
}

/// Van Oosterom–Strackee: solid angle of the triangle `(a, b, c)` seen from the origin.
fn triangle_solid_angle(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let (la, lb, lc) = (a.length(), b.length(), c.length());
    let numerator = a.dot(b.cross(c)).abs();
    let denominator = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
    2.0 * numerator.atan2(denominator)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn quadrant_is_a_quarter_sphere() {
        assert!((quadrant_solid_angle(1.0, 1.0) - PI).abs() < 1e-12);
        // Each quadrant of the map is a quarter of the sphere, by symmetry.
        for (u0, u1, v0, v1) in [
            (-1.0, 0.0, 0.0, 1.0),
            (0.0, 1.0, -1.0, 0.0),
            (-1.0, 0.0, -1.0, 0.0),
        ] {
            assert!((rect_solid_angle(u0, u1, v0, v1) - PI).abs() < 1e-12);
        }
        // The rectangle [0, 1] x [0, 0.5] and its mirror image about u = v agree.
        assert!((quadrant_solid_angle(1.0, 0.5) - quadrant_solid_angle(0.5, 1.0)).abs() < 1e-12);
        assert!((rect_solid_angle(-1.0, 1.0, -1.0, 1.0) - 4.0 * PI).abs() < 1e-12);
    }

    #[test]
    fn texel_solid_angles_sum_to_the_sphere_and_match_the_jacobian() {
        for n in [1, 2, 3, 6, 7, 14, 64] {
            let layout = OctaLayout::new(n).unwrap();
            let all = layout.texel_solid_angles();
            let sum: f64 = all.iter().map(|&a| f64::from(a)).sum();
            assert!((sum - 4.0 * PI).abs() < 1e-5, "n={n}: {sum}");
            for iy in 0..n {
                for ix in 0..n {
                    let single = layout.texel_solid_angle(ix, iy);
                    let batch = all[(iy * n + ix) as usize];
                    assert!((single - batch).abs() <= 1e-6 * single.max(1e-3), "n={n}");
                    // Solid-angle density of the map is |d|₁³ per unit (u, v) area; the
                    // midpoint rule is first-order where texels straddle the fold.
                    if n >= 14 {
                        let d = layout.texel_direction(ix, iy);
                        let l1 = d.x.abs() + d.y.abs() + d.z.abs();
                        let midpoint = l1.powi(3) * (2.0 / n as f32).powi(2);
                        assert!(
                            (midpoint - single).abs() < 2.0 / n as f32 * single,
                            "n={n} ({ix},{iy})"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn border_sources_are_interior_and_listing_4_4() {
        let layout = OctaLayout::new(8).unwrap();
        let s = 9;
        assert_eq!(layout.border_source(0, 0), Some([8, 8]));
        assert_eq!(layout.border_source(0, s), Some([8, 1]));
        assert_eq!(layout.border_source(s, 0), Some([1, 8]));
        assert_eq!(layout.border_source(s, s), Some([1, 1]));
        assert_eq!(layout.border_source(0, 1), Some([1, 8]));
        assert_eq!(layout.border_source(0, 3), Some([1, 6]));
        assert_eq!(layout.border_source(s, 2), Some([8, 7]));
        assert_eq!(layout.border_source(3, 0), Some([6, 1]));
        assert_eq!(layout.border_source(3, s), Some([6, 8]));
        assert_eq!(layout.border_source(4, 4), None);
        assert_eq!(layout.border_source(10, 0), None);
        for p in 0..=s {
            for q in [0, s] {
                for [x, y] in [layout.border_source(p, q), layout.border_source(q, p)]
                    .into_iter()
                    .flatten()
                {
                    assert!((1..=8).contains(&x) && (1..=8).contains(&y));
                }
            }
        }
    }

    #[test]
    fn texel_lookup_inverts_texel_centres() {
        for n in [1, 5, 16] {
            let layout = OctaLayout::new(n).unwrap();
            for iy in 0..n {
                for ix in 0..n {
                    let d = layout.texel_direction(ix, iy);
                    assert_eq!(layout.texel_containing(d), [ix, iy]);
                    let c = layout.texel_coords(d);
                    let expected = Vec2::new(ix as f32 + 1.5, iy as f32 + 1.5);
                    assert!(c.abs_diff_eq(expected, 1e-4), "{c} vs {expected}");
                }
            }
        }
    }

    #[test]
    fn resolution_errors_name_the_parameter() {
        assert_eq!(
            OctaLayout::new(0),
            Err(ResolutionError::Zero {
                parameter: "resolution"
            })
        );
        assert!(matches!(
            OctaLayout::new(MAX_RESOLUTION + 1),
            Err(ResolutionError::TooLarge { value, .. }) if value == MAX_RESOLUTION + 1
        ));
        let message = OctaLayout::new(0).unwrap_err().to_string();
        assert!(message.contains("resolution"), "{message}");
    }
}
