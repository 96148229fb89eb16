//! Prefiltered radiance for glossy reflections: GGX lobe convolutions of an octahedral map and
//! the per-probe pyramid a cone tracer reads (one lobe per level, coarser levels for wider
//! lobes).
//!
//! **Lobe.** A GGX (Trowbridge–Reitz) lobe of roughness `α` about a direction `d`, with the
//! normal, view and mirror direction all equal to `d` (the split-sum assumption of Karis
//! 2013): a source direction `ω` is weighted by `D(h) · max(0, d·ω)` with `h` the half vector
//! of `d` and `ω` and `D(h) ∝ 1 / ((d·h)² (α² − 1) + 1)²`, normalised. Half of such a lobe's
//! weight lies within [`ggx_lobe_angle`]`(α) = 2·atan(α)` of `d` (the GGX half-vector CDF:
//! `P(tan θ_h < x) = x² / (α² + x²)`).

use glam::Vec3;

use crate::filter::FilterError;
use crate::layout::{OctaLayout, ResolutionError};
use crate::map::{OctaMap, Texel};

/// The share of a GGX lobe's weight left out of [`ggx_filter`]: source directions whose half
/// vector is farther from the lobe's axis than this tail are skipped (the rest renormalised).
pub const GGX_TAIL: f32 = 0.02;

/// The median angle (radians) between a GGX lobe's axis and the directions it weights, for
/// GGX roughness `alpha` (`α`, the square of perceptual roughness): `2·atan(α)`.
#[inline]
pub fn ggx_lobe_angle(alpha: f32) -> f32 {
    2.0 * alpha.atan()
}

/// The GGX `α` whose lobe has median angle `angle` (radians): `tan(angle / 2)`, the inverse of
/// [`ggx_lobe_angle`].
#[inline]
pub fn ggx_alpha_for_angle(angle: f32) -> f32 {
    (0.5 * angle).tan()
}

/// The mean angular size (radians) of a texel of an `N×N` octahedral map: `√(4π) / N`, the
/// side of a square of the mean solid angle `4π / N²`.
#[inline]
pub fn texel_angle(resolution: u32) -> f32 {
    2.0 * std::f32::consts::PI.sqrt() / resolution as f32
}

/// Interior texel `(ix, iy)` of an `n×n` map for `ix, iy ∈ (−n, 2n)`, through the octahedral
/// wrap (crossing the edge `u = ±1` at `v` re-enters at `−v`; the border rule of
/// [`OctaLayout::pad`] extended past one texel).
///
/// ```
/// // One texel left of the first column is the first column, mirrored top to bottom.
/// assert_eq!(probe_octa::fold(-1, 0, 8), (0, 7));
/// // Past a corner both ways: the opposite corner.
/// assert_eq!(probe_octa::fold(-1, -1, 8), (7, 7));
/// ```
#[inline]
pub fn fold(ix: i32, iy: i32, n: i32) -> (i32, i32) {
    let (mut x, mut y) = (ix, iy);
    if x < 0 {
        (x, y) = (-1 - x, n - 1 - y);
    } else if x >= n {
        (x, y) = (2 * n - 1 - x, n - 1 - y);
    }
    if y < 0 {
        (x, y) = (n - 1 - x, -1 - y);
    } else if y >= n {
        (x, y) = (n - 1 - x, 2 * n - 1 - y);
    }
    (x, y)
}

/// The GGX weight of source direction `d_i` for a lobe about `d_o` (unnormalised, without the
/// solid angle), or `None` below the tail cut `cos_limit` (on `d_o·d_i`).
#[inline]
fn ggx_weight(d_o: Vec3, d_i: Vec3, alpha2: f32, cos_limit: f32) -> Option<f32> {
    let cosine = d_o.dot(d_i);
    if cosine <= cos_limit {
        return None;
    }
    // cos²θ_h = (1 + d_o·d_i) / 2 for the half vector of two unit vectors.
    let cos2_h = 0.5 * (1.0 + cosine);
    let denominator = cos2_h * (alpha2 - 1.0) + 1.0;
    Some(cosine / (denominator * denominator))
}

/// `d_o·d_i` at the tail cut: the half-vector angle `θ_h` with `P(θ_h > θ) = GGX_TAIL`,
/// `tan² θ_h = α² (1 − tail) / tail`, as a cosine of the reflected angle `2θ_h` (at least 0:
/// the lobe's `max(0, d·ω)` ends at 90°).
fn tail_cos_limit(alpha: f32) -> f32 {
    let tan2 = alpha * alpha * (1.0 - GGX_TAIL) / GGX_TAIL;
    let cos2_h = 1.0 / (1.0 + tan2);
    (2.0 * cos2_h - 1.0).max(0.0)
}

/// The GGX lobe mean of `source` at an output resolution: texel `o` holds
/// `Σ_i w_i v_i / Σ_i w_i` over the source's interior texels, `w_i = D(h_i) · max(0, d_o·ω_i) ·
/// Ω_i` (the lobe in the module documentation, `Ω_i` the texel's exact solid angle), leaving
/// out the lobe's outer [`GGX_TAIL`] of weight. Works in directions, so it is continuous
/// across the octahedral seams; the result is padded. A constant map stays constant.
///
/// Sources are gathered from a window of texels around each output direction, folded through
/// the octahedral wrap (each texel counted once), sized from the tail's angle; wide lobes
/// visit every source texel.
///
/// # Errors
/// [`FilterError::Resolution`] for a bad `resolution`; [`FilterError::InvalidLobe`] (parameter
/// `alpha`) for an `alpha` that is not finite and positive.
pub fn ggx_filter<T: Texel>(
    source: &OctaMap<T>,
    resolution: u32,
    alpha: f32,
) -> Result<OctaMap<T>, FilterError> {
    if !(alpha.is_finite() && alpha > 0.0) {
        return Err(FilterError::InvalidLobe {
            parameter: "alpha",
            value: alpha,
        });
    }
    OctaLayout::new(resolution)?;
    let layout = source.layout();
    let n = layout.resolution();
    let solid_angles = layout.texel_solid_angles();
    let directions: Vec<Vec3> = (0..n)
        .flat_map(|iy| (0..n).map(move |ix| (ix, iy)))
        .map(|(ix, iy)| layout.texel_direction(ix, iy))
        .collect();
    let values: Vec<T> = (0..n)
        .flat_map(|iy| (0..n).map(move |ix| (ix, iy)))
        .map(|(ix, iy)| source.texels()[layout.interior_index(ix, iy)])
        .collect();
    let alpha2 = alpha * alpha;
    let cos_limit = tail_cos_limit(alpha);
    // Moving one texel (2/N in octahedral units) turns a direction by at least 2/N radians
    // (the mapping's smallest angular rate is 1 rad per unit, at the poles): a window of
    // `angle · N / 2` texels, plus one for the texel the output falls in, holds the lobe.
    let angle = cos_limit.acos();
    let half = (angle * n as f32 * 0.5).ceil() as i32 + 1;
    let brute = 2 * half + 1 >= n as i32;
    let mut stamp = vec![u32::MAX; (n as usize).pow(2)];
    let mut counter = 0u32;
    let map = OctaMap::from_fn(resolution, |d_o| {
        let mut sum = T::zero();
        let mut weight_sum = 0.0f32;
        let mut add = |i: usize| {
            if let Some(w) = ggx_weight(d_o, directions[i], alpha2, cos_limit) {
                let w = w * solid_angles[i];
                sum = sum.add_scaled(values[i], w);
                weight_sum += w;
            }
        };
        if brute {
            (0..directions.len()).for_each(&mut add);
        } else {
            let [cx, cy] = layout.texel_containing(d_o);
            let ni = n as i32;
            for dy in -half..=half {
                for dx in -half..=half {
                    let (x, y) = fold(cx as i32 + dx, cy as i32 + dy, ni);
                    let i = (y * ni + x) as usize;
                    if stamp[i] != counter {
                        stamp[i] = counter;
                        add(i);
                    }
                }
            }
            counter = counter.wrapping_add(1);
        }
        if weight_sum > 0.0 {
            T::zero().add_scaled(sum, 1.0 / weight_sum)
        } else {
            T::zero()
        }
    })?;
    Ok(map)
}

/// Halves a map's resolution: each output texel is the solid-angle-weighted mean of the 2×2
/// source texels it covers (the octahedral texel grids nest), so the map's integral over the
/// sphere is kept. The result is padded.
///
/// # Errors
/// [`FilterError::Resolution`] ([`ResolutionError::NotPowerOfTwo`] wording aside: any odd or
/// 1-texel resolution is refused) when the resolution cannot be halved.
pub fn downsample_box<T: Texel>(source: &OctaMap<T>) -> Result<OctaMap<T>, FilterError> {
    let layout = source.layout();
    let n = layout.resolution();
    if n < 2 || n % 2 == 1 {
        return Err(ResolutionError::NotPowerOfTwo {
            parameter: "source.resolution()",
            value: n,
        }
        .into());
    }
    let half = n / 2;
    let solid_angles = layout.texel_solid_angles();
    let mut interior = Vec::with_capacity((half as usize).pow(2));
    for y in 0..half {
        for x in 0..half {
            let mut sum = T::zero();
            let mut weight = 0.0f32;
            for (ix, iy) in [
                (2 * x, 2 * y),
                (2 * x + 1, 2 * y),
                (2 * x, 2 * y + 1),
                (2 * x + 1, 2 * y + 1),
            ] {
                let w = solid_angles[(iy * n + ix) as usize];
                sum = sum.add_scaled(source.texels()[layout.interior_index(ix, iy)], w);
                weight += w;
            }
            interior.push(T::zero().add_scaled(sum, 1.0 / weight));
        }
    }
    OctaMap::from_interior(half, &interior).map_err(|_| {
        FilterError::Resolution(ResolutionError::NotPowerOfTwo {
            parameter: "source.resolution()",
            value: n,
        })
    })
}

/// The GGX `α` of level `level >= 1` of a [`glossy_pyramid`] over an `N×N` map: the lobe whose
/// median angle is one texel of the level (`N >> level`), [`ggx_alpha_for_angle`]`(`
/// [`texel_angle`]`(N >> level))`.
#[inline]
pub fn glossy_level_alpha(resolution: u32, level: u32) -> f32 {
    ggx_alpha_for_angle(texel_angle((resolution >> level).max(1)))
}

/// The prefiltered radiance pyramid of one probe: level `k` (`1..=levels`) is the map at
/// resolution `N >> k`, each texel the GGX lobe mean ([`ggx_filter`]) of the radiance with
/// `α_k =` [`glossy_level_alpha`]`(N, k)` (median lobe angle = one texel of the level), the
/// source being the radiance box-downsampled ([`downsample_box`]) to `N >> (k − 1)`, two
/// source texels per output texel. Level 0, the map itself, is not repeated. Levels stop at
/// a 2×2 map, so at most `log2(N) − 1` are returned.
///
/// A tracer with a cone of angle `φ` seen from the probe reads level
/// `log2(φ / texel_angle(N))`, interpolating between levels.
///
/// # Errors
/// [`FilterError::Resolution`] unless `N` is a power of two of at least 4 (when `levels > 0`).
pub fn glossy_pyramid<T: Texel>(
    radiance: &OctaMap<T>,
    levels: u32,
) -> Result<Vec<OctaMap<T>>, FilterError> {
    let n = radiance.resolution();
    if levels == 0 {
        return Ok(Vec::new());
    }
    if !n.is_power_of_two() || n < 4 {
        return Err(ResolutionError::NotPowerOfTwo {
            parameter: "radiance.resolution()",
            value: n,
        }
        .into());
    }
    let count = levels.min(n.trailing_zeros() - 1);
    let mut out = Vec::with_capacity(count as usize);
    let mut source: Option<OctaMap<T>> = None;
    for k in 1..=count {
        let level = {
            let src = source.as_ref().unwrap_or(radiance);
            ggx_filter(src, n >> k, glossy_level_alpha(n, k))?
        };
        out.push(level);
        if k < count {
            let next = downsample_box(source.as_ref().unwrap_or(radiance))?;
            source = Some(next);
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A smooth test map with structure in every direction.
    fn smooth(d: Vec3) -> Vec3 {
        Vec3::new(
            1.0 + 0.5 * d.x + 0.3 * d.y * d.z,
            1.0 + (3.0 * d.z).sin() * 0.4,
            1.5 + 0.5 * d.y * d.x - 0.2 * d.z,
        )
    }

    /// Every source texel visited (no window): the definition.
    fn brute<T: Texel>(source: &OctaMap<T>, resolution: u32, alpha: f32) -> OctaMap<T> {
        let layout = source.layout();
        let n = layout.resolution();
        let omega = layout.texel_solid_angles();
        let cos_limit = tail_cos_limit(alpha);
        OctaMap::from_fn(resolution, |d_o| {
            let (mut sum, mut total) = (T::zero(), 0.0f32);
            for iy in 0..n {
                for ix in 0..n {
                    if let Some(w) = ggx_weight(
                        d_o,
                        layout.texel_direction(ix, iy),
                        alpha * alpha,
                        cos_limit,
                    ) {
                        let w = w * omega[(iy * n + ix) as usize];
                        sum = sum.add_scaled(source.texels()[layout.interior_index(ix, iy)], w);
                        total += w;
                    }
                }
            }
            T::zero().add_scaled(sum, 1.0 / total)
        })
        .unwrap()
    }

    fn integral(map: &OctaMap<Vec3>) -> Vec3 {
        let layout = map.layout();
        let n = layout.resolution();
        let omega = layout.texel_solid_angles();
        let mut sum = Vec3::ZERO;
        for iy in 0..n {
            for ix in 0..n {
                sum += map.texels()[layout.interior_index(ix, iy)] * omega[(iy * n + ix) as usize];
            }
        }
        sum
    }

    #[test]
    fn window_equals_the_definition() {
        // A rough map with detail at every texel, narrow and wide lobes.
        let source = OctaMap::from_fn(64, |d| {
            Vec3::new((17.0 * d.x).sin(), (13.0 * d.y * d.z).cos(), d.z * d.z)
        })
        .unwrap();
        for (resolution, alpha) in [(32, glossy_level_alpha(64, 1)), (16, 0.12), (8, 0.4)] {
            let fast = ggx_filter(&source, resolution, alpha).unwrap();
            let slow = brute(&source, resolution, alpha);
            for (a, b) in fast.texels().iter().zip(slow.texels()) {
                assert!((*a - *b).abs().max_element() < 1e-4, "{a} {b} at α {alpha}");
            }
        }
    }

    #[test]
    fn constant_stays_constant_and_energy_is_kept() {
        let constant = OctaMap::filled(32, Vec3::new(0.25, 2.0, 7.0)).unwrap();
        for level in glossy_pyramid(&constant, 8).unwrap() {
            for t in level.texels() {
                assert!(
                    (*t - Vec3::new(0.25, 2.0, 7.0)).abs().max_element() < 1e-4,
                    "{t}"
                );
            }
        }
        let map = OctaMap::from_fn(64, smooth).unwrap();
        let total = integral(&map);
        let pyramid = glossy_pyramid(&map, 8).unwrap();
        assert_eq!(pyramid.len(), 5);
        for (k, level) in pyramid.iter().enumerate() {
            assert_eq!(level.resolution(), 64 >> (k + 1));
            let relative = (integral(level) - total).abs() / total;
            assert!(relative.max_element() < 0.01, "level {}: {relative}", k + 1);
        }
        let down = downsample_box(&map).unwrap();
        let relative = (integral(&down) - total).abs() / total;
        assert!(relative.max_element() < 1e-5, "{relative}");
    }

    #[test]
    fn levels_blur_and_seams_are_continuous() {
        // A sharp step: each level is smoother than the one before.
        let map = OctaMap::from_fn(64, |d| if d.x > 0.0 { 4.0f32 } else { 0.0 }).unwrap();
        let pyramid = glossy_pyramid(&map, 4).unwrap();
        let near_step = Vec3::new(0.08, 0.6, 0.8).normalize();
        let mut previous = map.sample(near_step);
        for level in &pyramid {
            let v = level.sample(near_step);
            assert!(v < previous && v > 2.0, "{v} after {previous}");
            previous = v;
        }
        // Across each octahedral seam (the lower hemisphere's fold lines) and at the −z pole,
        // bilinear reads of every level agree within what the map's slope allows.
        let smooth_map = OctaMap::from_fn(64, smooth).unwrap();
        let levels = glossy_pyramid(&smooth_map, 5).unwrap();
        let eps = 1e-3;
        let pairs = [
            (Vec3::new(0.6, eps, -0.8), Vec3::new(0.6, -eps, -0.8)),
            (Vec3::new(-0.6, eps, -0.8), Vec3::new(-0.6, -eps, -0.8)),
            (Vec3::new(eps, 0.6, -0.8), Vec3::new(-eps, 0.6, -0.8)),
            (Vec3::new(eps, -0.6, -0.8), Vec3::new(-eps, -0.6, -0.8)),
            (Vec3::new(eps, eps, -1.0), Vec3::new(-eps, -eps, -1.0)),
        ];
        for level in &levels {
            for (a, b) in pairs {
                let (va, vb) = (level.sample(a.normalize()), level.sample(b.normalize()));
                assert!((va - vb).abs().max_element() < 0.01, "{va} {vb}");
            }
        }
    }

    #[test]
    fn bad_input_is_refused() {
        let map = OctaMap::filled(16, 1.0f32).unwrap();
        assert!(matches!(
            ggx_filter(&map, 8, 0.0),
            Err(FilterError::InvalidLobe {
                parameter: "alpha",
                ..
            })
        ));
        assert!(ggx_filter(&map, 8, f32::NAN).is_err());
        assert!(ggx_filter(&map, 0, 0.1).is_err());
        let odd = OctaMap::filled(12, 1.0f32).unwrap();
        assert!(glossy_pyramid(&odd, 2).is_err());
        assert!(glossy_pyramid(&odd, 0).unwrap().is_empty());
        assert!(downsample_box(&OctaMap::filled(1, 1.0f32).unwrap()).is_err());
        assert!((ggx_lobe_angle(ggx_alpha_for_angle(0.3)) - 0.3).abs() < 1e-6);
    }
}
