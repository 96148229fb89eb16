//! Splitting a world-space ray into the ≤ 4 straight segments it makes in a probe's
//! octahedral map (McGuire et al. 2017; Evangelakos 2015).

use glam::{Vec2, Vec3};

use crate::octahedral::sign_not_zero;

/// Why a ray could not be split.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum RaySplitError {
    /// A component of `probe`, `origin` or `direction` is NaN or infinite. Fix: pass finite
    /// vectors (a ray to infinity uses `t_max = f32::INFINITY`, not an infinite origin).
    #[error("`{parameter}` has a NaN or infinite component")]
    NonFinite {
        /// The offending parameter.
        parameter: &'static str,
    },
    /// `direction` is the zero vector, so the ray has no direction. Fix: pass a non-zero
    /// direction (it need not be normalised).
    #[error("`direction` is the zero vector")]
    ZeroDirection,
    /// `t_min` or `t_max` is NaN, or `t_min > t_max`. Fix: pass `t_min <= t_max`
    /// (infinite values are allowed).
    #[error("the range [{t_min}, {t_max}] is not an ordered pair of numbers")]
    InvalidRange {
        /// Start of the range given.
        t_min: f32,
        /// End of the range given.
        t_max: f32,
    },
}

/// One straight piece of a ray in a probe's octahedral map: the ray points for
/// `t ∈ [t_start, t_end]` encode onto the 2-D segment from `octa_start` to `octa_end`.
///
/// Endpoints are limits from inside the piece, so a piece that ends on a plane where the
/// octahedral map folds (e.g. crossing `x = 0` below the `z = 0` plane) ends on its own side of
/// the map. An endpoint at infinite `t` is the octahedral point of `±direction`; an endpoint at
/// the probe centre (a ray through it) is the limit direction of travel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OctaSegment {
    /// Ray parameter where the piece starts.
    pub t_start: f32,
    /// Ray parameter where the piece ends (`>= t_start`).
    pub t_end: f32,
    /// Octahedral coordinates of the ray point at `t_start`.
    pub octa_start: Vec2,
    /// Octahedral coordinates of the ray point at `t_end`.
    pub octa_end: Vec2,
}

/// The 1 to 4 pieces of a split ray, in increasing `t`, covering `[t_min, t_max]` exactly:
/// the first starts at `t_min`, the last ends at `t_max`, and each starts where the previous
/// ended. No allocation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OctaSegments {
    segments: [OctaSegment; 4],
    len: usize,
}

impl OctaSegments {
    /// The pieces in increasing `t`.
    #[inline]
    pub fn as_slice(&self) -> &[OctaSegment] {
        &self.segments[..self.len]
    }
}

impl std::ops::Deref for OctaSegments {
    type Target = [OctaSegment];
    #[inline]
    fn deref(&self) -> &[OctaSegment] {
        self.as_slice()
    }
}

/// Splits the ray `origin + t·direction`, `t ∈ [t_min, t_max]`, seen from a probe at `probe`,
/// into its straight octahedral pieces.
///
/// The ray is cut where it crosses the probe's planes `x = 0`, `y = 0`, `z = 0` (relative to
/// `probe`) strictly inside the range; inside each piece the point stays in one octant, where
/// octahedral encoding is a projective map, so the piece is a straight 2-D segment. Three
/// planes give at most four pieces.
///
/// Degenerate cases are defined, not refused:
/// * a ray through the probe centre is cut there (all three planes at one `t`); each side is a
///   single octahedral point (`−direction` before, `direction` after);
/// * a ray parallel to a plane never crosses it; a ray lying in a plane keeps `signNotZero`'s
///   `+` side for that axis throughout, which is still one straight segment;
/// * `t_min == t_max` gives one piece of zero length.
///
/// # Errors
/// [`RaySplitError`] for non-finite vectors, a zero direction, or a NaN/reversed range.
pub fn split_ray(
    probe: Vec3,
    origin: Vec3,
    direction: Vec3,
    t_min: f32,
    t_max: f32,
) -> Result<OctaSegments, RaySplitError> {
    for (parameter, v) in [
        ("probe", probe),
        ("origin", origin),
        ("direction", direction),
    ] {
        if !v.is_finite() {
            return Err(RaySplitError::NonFinite { parameter });
        }
    }
    if direction == Vec3::ZERO {
        return Err(RaySplitError::ZeroDirection);
    }
    if t_min.is_nan() || t_max.is_nan() || t_min > t_max {
        return Err(RaySplitError::InvalidRange { t_min, t_max });
    }
    let relative = origin - probe;

    // Plane crossings strictly inside the range, with the axes crossed there (bit mask).
    let mut cuts: [(f32, u8); 3] = [(0.0, 0); 3];
    let mut cut_count = 0;
    for axis in 0..3 {
        if direction[axis] != 0.0 {
            let t = -relative[axis] / direction[axis];
            if t > t_min && t < t_max {
                cuts[cut_count] = (t, 1 << axis);
                cut_count += 1;
            }
        }
    }
    let cuts = &mut cuts[..cut_count];
    cuts.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
    // Merge cuts at the same t (a ray through an edge or the centre of the octant frame).
    let mut merged: [(f32, u8); 3] = [(0.0, 0); 3];
    let mut merged_count = 0;
    for &(t, mask) in cuts.iter() {
        if merged_count > 0 && merged[merged_count - 1].0 == t {
            merged[merged_count - 1].1 |= mask;
        } else {
            merged[merged_count] = (t, mask);
            merged_count += 1;
        }
    }

    // Boundaries t_min, cuts..., t_max with the axes that vanish at each.
    let mut bounds = [(t_min, 0u8); 5];
    bounds[1..=merged_count].copy_from_slice(&merged[..merged_count]);
    bounds[merged_count + 1] = (t_max, 0);
    let piece_count = merged_count + 1;

    let placeholder = OctaSegment {
        t_start: t_min,
        t_end: t_max,
        octa_start: Vec2::ZERO,
        octa_end: Vec2::ZERO,
    };
    let mut segments = [placeholder; 4];
    for (i, segment) in segments.iter_mut().take(piece_count).enumerate() {
        let (t0, mask0) = bounds[i];
        let (t1, mask1) = bounds[i + 1];
        let signs = interior_signs(relative, direction, t0, t1);
        *segment = OctaSegment {
            t_start: t0,
            t_end: t1,
            octa_start: endpoint(relative, direction, t0, mask0, signs, true),
            octa_end: endpoint(relative, direction, t1, mask1, signs, false),
        };
    }
    Ok(OctaSegments {
        segments,
        len: piece_count,
    })
}

/// Signs (±1, `signNotZero`) of the point coordinates strictly inside the piece `(t0, t1)`.
fn interior_signs(relative: Vec3, direction: Vec3, t0: f32, t1: f32) -> Vec3 {
    let inside = match (t0.is_finite(), t1.is_finite()) {
        (true, true) => 0.5 * t0 + 0.5 * t1,
        (true, false) => t0 + t0.abs().max(1.0),
        (false, true) => t1 - t1.abs().max(1.0),
        (false, false) => 0.0,
    };
    let p = relative + direction * inside;
    // A coordinate that is zero at an interior point is zero on the whole piece (the ray lies
    // in that plane, or touches it only at a cut), so signNotZero's + is the consistent choice.
    let s = |v: f32| if v >= 0.0 { 1.0 } else { -1.0 };
    Vec3::new(s(p.x), s(p.y), s(p.z))
}

/// Octahedral point of the ray at `t`, as the limit from inside a piece whose coordinates have
/// `signs`. `vanishing` marks axes whose plane the ray crosses exactly at `t`.
fn endpoint(
    relative: Vec3,
    direction: Vec3,
    t: f32,
    vanishing: u8,
    signs: Vec3,
    piece_starts_here: bool,
) -> Vec2 {
    let mut p = relative + direction * t;
    if !p.is_finite() {
        // Infinite (or overflowing) t: the point's direction tends to ±direction.
        p = direction * t.signum();
    }
    for axis in 0..3 {
        if vanishing & (1 << axis) != 0 {
            p[axis] = 0.0;
        }
    }
    if p == Vec3::ZERO {
        // The ray passes through the probe centre here: the limit direction of travel.
        p = if piece_starts_here {
            direction
        } else {
            -direction
        };
    }
    encode_in_octant(p, signs)
}

/// [`crate::encode`] with the octant given by `signs` instead of the point's own signs, so
/// points on a plane get the limit value of the side they belong to.
#[inline]
fn encode_in_octant(p: Vec3, signs: Vec3) -> Vec2 {
    // Finite coordinates whose L1 norm overflows are scaled down exactly first.
    let p = if p.x.abs() + p.y.abs() + p.z.abs() > f32::MAX {
        p * (2.0f32).powi(-64)
    } else {
        p
    };
    let l1 = p.x.abs() + p.y.abs() + p.z.abs();
    let q = Vec2::new(p.x.abs() * signs.x, p.y.abs() * signs.y) / l1;
    if signs.z < 0.0 {
        (Vec2::ONE - Vec2::new(q.y.abs(), q.x.abs())) * sign_not_zero(Vec2::new(signs.x, signs.y))
    } else {
        q
    }
}
