//! Low-resolution filtered maps: distance moments (DDGI / seed 001 §4.3.4) and irradiance.

use glam::{Vec2, Vec3};

use crate::cube::LobePower;
use crate::layout::{OctaLayout, ResolutionError};
use crate::map::{OctaMap, Texel};

/// Why a filtering or resampling operation was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum FilterError {
    /// The output (or input) resolution is unusable; see [`ResolutionError`].
    #[error(transparent)]
    Resolution(#[from] ResolutionError),
    /// A lobe exponent (cosine power or sharpness) is negative, NaN or infinite. Fix: pass a
    /// finite value `>= 0`; 0 averages a whole hemisphere, larger values narrow the lobe.
    #[error("`{parameter}` is {value}; it must be finite and >= 0")]
    InvalidLobe {
        /// The parameter that held the exponent.
        parameter: &'static str,
        /// The value given.
        value: f32,
    },
}

/// Checks a lobe exponent: finite and `>= 0`.
pub(crate) fn check_lobe_power(parameter: &'static str, value: f32) -> Result<(), FilterError> {
    if value.is_finite() && value >= 0.0 {
        Ok(())
    } else {
        Err(FilterError::InvalidLobe { parameter, value })
    }
}

/// Interior resolution of DDGI's distance (moment) maps: 14×14 plus the border (16×16 stored).
pub const DDGI_DISTANCE_RESOLUTION: u32 = 14;
/// Interior resolution of DDGI's irradiance maps: 6×6 plus the border (8×8 stored).
pub const DDGI_IRRADIANCE_RESOLUTION: u32 = 6;

/// Source texel directions and exact solid angles, interior order.
fn source_quadrature(layout: OctaLayout) -> (Vec<Vec3>, Vec<f32>) {
    let n = layout.resolution();
    let mut directions = Vec::with_capacity((n as usize).pow(2));
    for iy in 0..n {
        for ix in 0..n {
            directions.push(layout.texel_direction(ix, iy));
        }
    }
    (directions, layout.texel_solid_angles())
}

/// Lobe weights below this fraction of the peak are skipped: the lobe integral then changes by
/// less than `4π·10⁻⁸ / ∫cos^p`, i.e. under 1e-6 relative for powers up to 50.
const NEGLIGIBLE_WEIGHT: f32 = 1e-8;

/// `out(d_o) = Σ_i max(0, d_o·d_i)^power · Ω_i · value(t_i)`, divided by the sum of the
/// weights when `normalise`, over every source texel whose weight is not negligible.
fn lobe_filter<T: Texel, U: Texel>(
    source: &OctaMap<T>,
    resolution: u32,
    power: f32,
    normalise: bool,
    value: impl Fn(T) -> U,
) -> Result<OctaMap<U>, FilterError> {
    OctaLayout::new(resolution)?;
    let layout = source.layout();
    let n = layout.resolution();
    let (directions, solid_angles) = source_quadrature(layout);
    let values: Vec<U> = (0..n)
        .flat_map(|iy| (0..n).map(move |ix| (ix, iy)))
        .map(|(ix, iy)| value(source.texels()[layout.interior_index(ix, iy)]))
        .collect();
    let lobe = LobePower::new(power);
    // cos^power >= NEGLIGIBLE_WEIGHT  <=>  cos >= NEGLIGIBLE_WEIGHT^(1/power).
    let cos_limit = if power > 0.0 {
        NEGLIGIBLE_WEIGHT.powf(1.0 / power)
    } else {
        0.0
    };
    let map = OctaMap::from_fn(resolution, |d_o| {
        let mut sum = U::zero();
        let mut weight_sum = 0.0f32;
        for ((d_i, &omega), &v) in directions.iter().zip(&solid_angles).zip(&values) {
            let cosine = d_o.dot(*d_i);
            if cosine > cos_limit {
                let w = lobe.apply(cosine) * omega;
                sum = sum.add_scaled(v, w);
                weight_sum += w;
            }
        }
        if normalise {
            if weight_sum > 0.0 {
                U::zero().add_scaled(sum, 1.0 / weight_sum)
            } else {
                U::zero()
            }
        } else {
            sum
        }
    })?;
    Ok(map)
}

/// Distance moments for the Chebyshev visibility test: texel `o` holds `(E[r], E[r²])` of the
/// radial distance `r` of `distance` over the normalised lobe `max(0, d_o·ω)^lobe_power`
/// (every source texel weighted by its exact solid angle; weights below `10⁻⁸` of the peak are
/// skipped, which changes the result by under `10⁻⁶` relative).
///
/// DDGI stores these at [`DDGI_DISTANCE_RESOLUTION`]. A lobe about one output texel wide is
/// [`crate::default_sharpness`]`(resolution)` (≈ 62 at 14²); larger exponents narrow it. Clamp
/// infinite distances (misses) to a finite maximum first, e.g. with [`OctaMap::map`]: an
/// infinite texel makes every moment that sees it infinite.
///
/// # Errors
/// [`FilterError::Resolution`] for a bad `resolution`; [`FilterError::InvalidLobe`] for a bad
/// `lobe_power`.
pub fn distance_moments(
    distance: &OctaMap<f32>,
    resolution: u32,
    lobe_power: f32,
) -> Result<OctaMap<Vec2>, FilterError> {
    check_lobe_power("lobe_power", lobe_power)?;
    lobe_filter(distance, resolution, lobe_power, true, |r| {
        Vec2::new(r, r * r)
    })
}

/// Normalised cosine-power lobe mean of any map: texel `o` holds
/// `Σ max(0, d_o·ω_i)^lobe_power Ω_i v_i / Σ max(0, d_o·ω_i)^lobe_power Ω_i`
/// (prefiltered radiance for glossy lookups; [`distance_moments`] is this on `(r, r²)`).
///
/// # Errors
/// As [`distance_moments`].
pub fn lobe_mean<T: Texel>(
    map: &OctaMap<T>,
    resolution: u32,
    lobe_power: f32,
) -> Result<OctaMap<T>, FilterError> {
    check_lobe_power("lobe_power", lobe_power)?;
    lobe_filter(map, resolution, lobe_power, true, |v| v)
}

/// Irradiance (cosine convolution) of a radiance map: texel with normal `n` holds
/// `E(n) = ∫ L(ω) max(0, n·ω) dω`, a quadrature over the source texels with their exact solid
/// angles. A constant radiance `L` gives `π·L`. (DDGI stores irradiance maps at
/// [`DDGI_IRRADIANCE_RESOLUTION`]; divide by π for the cosine-weighted mean radiance.)
///
/// # Errors
/// [`FilterError::Resolution`] for a bad `resolution`.
pub fn irradiance_map<T: Texel>(
    radiance: &OctaMap<T>,
    resolution: u32,
) -> Result<OctaMap<T>, FilterError> {
    lobe_filter(radiance, resolution, 1.0, false, |v| v)
}

/// Chebyshev visibility weight of seed 001 Listing 4.5 / DDGI, before any cubing: the upper
/// bound `σ² / (σ² + (distance − μ)²)` on the chance that the probe sees past `distance`, with
/// `μ = moments.x`, `σ² = |moments.x² − moments.y|`; `1` when `distance <= μ`.
/// Returns a value in `[0, 1]`; NaN input gives 0.
#[inline]
pub fn chebyshev_visibility(moments: Vec2, distance: f32) -> f32 {
    let mean = moments.x;
    if distance <= mean {
        return 1.0;
    }
    let variance = (mean * mean - moments.y).abs();
    let excess = distance - mean;
    let weight = variance / (variance + excess * excess);
    if weight.is_nan() {
        0.0
    } else {
        weight.clamp(0.0, 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chebyshev_bounds() {
        assert_eq!(chebyshev_visibility(Vec2::new(2.0, 4.0), 1.0), 1.0);
        assert_eq!(chebyshev_visibility(Vec2::new(2.0, 4.0), 3.0), 0.0);
        // μ = 2, σ² = 1: at distance 3 the bound is 1 / (1 + 1).
        assert!((chebyshev_visibility(Vec2::new(2.0, 5.0), 3.0) - 0.5).abs() < 1e-6);
        assert_eq!(chebyshev_visibility(Vec2::new(f32::NAN, 0.0), 3.0), 0.0);
    }

    #[test]
    fn lobe_powers_are_checked() {
        let map = OctaMap::filled(8, 1.0f32).unwrap();
        assert!(matches!(
            distance_moments(&map, 4, -2.0),
            Err(FilterError::InvalidLobe {
                parameter: "lobe_power",
                ..
            })
        ));
        assert!(lobe_mean(&map, 4, f32::INFINITY).is_err());
        assert!(irradiance_map(&map, 0).is_err());
    }
}
