//! Surfels: what a probe sees, as surface patches that can be seen again from elsewhere.
//!
//! An irradiance map holds the light arriving *at the probe*. A point a short way off sees the
//! same surfaces under other angles and at other distances: near a wall the wall beside it
//! fills half its sky, where the probe saw that wall small and far. A probe that also keeps its
//! radial distances and hit normals knows where those surfaces are, so the light arriving at
//! any point can be re-gathered from them: each block of `B×B` texels of the probe's
//! full-resolution maps becomes one [`Surfel`] (its area-weighted centroid, mean normal, area
//! and mean radiance, plus the sky it saw), and [`surfel_irradiance`] sums the surfels'
//! cosine-weighted solid angles seen from the point. This is the near-field correction of
//! diffuse probe shading: the probe's own irradiance map stays the answer at the probe, and
//! the surfels say how much brighter or darker a point nearby is.

use std::borrow::Borrow;

use glam::Vec3;

use crate::layout::{OctaLayout, ResolutionError};
use crate::map::OctaMap;

/// One block of a probe's texels as a surface patch, world space.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Surfel {
    /// Area-weighted centroid of the block's hit points.
    pub position: Vec3,
    /// Total area of the block's hit points, square metres: each texel's solid angle × d² over
    /// the cosine between its ray and the surface (the cosine floored at
    /// [`MIN_SURFEL_COSINE`]). 0 when every texel of the block saw the sky.
    pub area: f32,
    /// Unit area-weighted mean normal of the hit surfaces (towards the probe); zero when
    /// `area` is 0.
    pub normal: Vec3,
    /// Area-weighted mean radiance leaving the hit points towards the probe.
    pub radiance: Vec3,
    /// Solid angle (steradians) of the block's texels that saw no geometry.
    pub sky_solid_angle: f32,
    /// Unit solid-angle-weighted mean direction of those texels; zero when there are none.
    pub sky_direction: Vec3,
    /// Their mean radiance.
    pub sky_radiance: Vec3,
}

/// The smallest cosine between a texel's ray and the surface it hit that [`surfel_map`]
/// divides by: a surface seen edge-on would otherwise get an unbounded area.
pub const MIN_SURFEL_COSINE: f32 = 0.05;

/// Why [`surfel_map`] refused its input.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SurfelError {
    /// The surfel resolution is not a power of two from 1 to the maps' resolution. Fix: pass
    /// a power of two no larger than the maps' (8 is the bake's default).
    #[error(
        "surfel resolution {surfels} must be a power of two from 1 to the maps' resolution {maps}"
    )]
    Resolution {
        /// The surfel resolution asked for.
        surfels: u32,
        /// The maps' resolution.
        maps: u32,
    },
    /// The three maps have different resolutions. Fix: pass a probe's own distance, normal and
    /// radiance maps.
    #[error(
        "the distance, normal and radiance maps have resolutions {distance}, {normal} and {radiance}"
    )]
    Mismatch {
        /// Resolution of the distance map.
        distance: u32,
        /// Resolution of the normal map.
        normal: u32,
        /// Resolution of the radiance map.
        radiance: u32,
    },
    /// See [`ResolutionError`].
    #[error(transparent)]
    Layout(#[from] ResolutionError),
}

/// The `resolution × resolution` surfels of one probe at `position`, row-major over the
/// blocks of its maps (block `(bx, by)` is surfel `by · resolution + bx` and covers the
/// texels `bx·B .. (bx+1)·B` by `by·B .. (by+1)·B`, `B = N / resolution`). Texels whose
/// `distance` is `sky_distance` or more saw the sky.
///
/// # Errors
/// [`SurfelError`] for a resolution that does not divide the maps' or maps of different
/// resolutions.
///
/// # Example
/// ```
/// use glam::Vec3;
/// use probe_octa::{OctaMap, surfel_irradiance, surfel_map};
///
/// // A probe at the centre of a closed box 2 m wide whose walls all leave radiance 1.
/// let distance = OctaMap::from_fn(64, |d: Vec3| 1.0 / d.abs().max_element())?;
/// let normal = OctaMap::from_fn(64, |d: Vec3| {
///     let a = d.abs();
///     let axis = if a.x >= a.y && a.x >= a.z { Vec3::X * d.x.signum() }
///         else if a.y >= a.z { Vec3::Y * d.y.signum() } else { Vec3::Z * d.z.signum() };
///     -axis
/// })?;
/// let radiance = OctaMap::filled(64, Vec3::ONE)?;
/// let surfels = surfel_map(Vec3::ZERO, &distance, &normal, &radiance, 1e9, 16)?;
/// assert_eq!(surfels.len(), 256);
/// // A uniformly bright enclosure gives irradiance π everywhere inside, near a wall too.
/// for x in [Vec3::ZERO, Vec3::new(0.9, 0.2, -0.3)] {
///     let e = surfel_irradiance(&surfels, x, Vec3::NEG_X);
///     assert!((e.x / std::f32::consts::PI - 1.0).abs() < 0.1, "{e}");
/// }
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn surfel_map(
    position: Vec3,
    distance: &OctaMap<f32>,
    normal: &OctaMap<Vec3>,
    radiance: &OctaMap<Vec3>,
    sky_distance: f32,
    resolution: u32,
) -> Result<Vec<Surfel>, SurfelError> {
    let n = distance.resolution();
    if normal.resolution() != n || radiance.resolution() != n {
        return Err(SurfelError::Mismatch {
            distance: n,
            normal: normal.resolution(),
            radiance: radiance.resolution(),
        });
    }
    if !resolution.is_power_of_two() || resolution > n || !n.is_multiple_of(resolution) {
        return Err(SurfelError::Resolution {
            surfels: resolution,
            maps: n,
        });
    }
    let layout = OctaLayout::new(n)?;
    let solid_angles = layout.texel_solid_angles();
    let block = n / resolution;
    let mut out = vec![Surfel::default(); (resolution * resolution) as usize];
    for iy in 0..n {
        for ix in 0..n {
            let texel = layout.padded_index(ix + 1, iy + 1);
            let d = distance.texels()[texel];
            let l = radiance.texels()[texel];
            let omega = solid_angles[(iy * n + ix) as usize];
            let w = layout.texel_direction(ix, iy);
            let s = &mut out[((iy / block) * resolution + ix / block) as usize];
            if d >= sky_distance || !d.is_finite() {
                s.sky_solid_angle += omega;
                s.sky_direction += w * omega;
                s.sky_radiance += l * omega;
                continue;
            }
            let facing = normal.texels()[texel];
            let cosine = facing.dot(w).abs().max(MIN_SURFEL_COSINE);
            let area = omega * d * d / cosine;
            s.position += (position + w * d) * area;
            s.normal += facing * area;
            s.area += area;
            s.radiance += l * area;
        }
    }
    for s in &mut out {
        if s.area > 0.0 {
            s.position /= s.area;
            s.radiance /= s.area;
            s.normal = s.normal.normalize_or_zero();
        }
        if s.sky_solid_angle > 0.0 {
            s.sky_radiance /= s.sky_solid_angle;
            s.sky_direction = s.sky_direction.normalize_or_zero();
        }
    }
    Ok(out)
}

/// Irradiance `E = ∫ L max(0, n·ω) dω` at point `x` with unit normal `n` gathered from
/// `surfels`: each surfel that faces `x` and lies in front of `n` adds its radiance times the
/// cosine-weighted solid angle it subtends, `A cos θₓ cos θₛ / (r² + A/π)` (a disc's form
/// factor, bounded as `r → 0`), and each block's sky adds `L Ω max(0, n·ω)`.
///
/// A hemisphere's cosine-weighted solid angle is π, and the gathered light is scaled to it
/// ([`coverage_scale`]). Where the surfels cover less (a surface `x` sees that the probe does
/// not, or blocks averaged across an edge into a patch facing neither wall), the rest is
/// filled with the mean radiance of what they cover; where they cover more, surfaces hidden
/// from `x` behind others are counted with them (nothing is occluded here: a surface the probe
/// saw counts even where something between hides it from `x`), and the overlap is averaged.
///
/// `surfels` is any sequence of surfels or references to them (a slice, or surfels unpacked
/// on the fly from a GPU buffer's layout).
pub fn surfel_irradiance(
    surfels: impl IntoIterator<Item = impl Borrow<Surfel>>,
    x: Vec3,
    n: Vec3,
) -> Vec3 {
    let mut sum = Vec3::ZERO;
    let mut coverage = 0.0f32;
    for s in surfels {
        let s = s.borrow();
        if s.area > 0.0 {
            let v = s.position - x;
            let r2 = v.length_squared();
            if r2 > 0.0 {
                let w = v / r2.sqrt();
                let cx = n.dot(w);
                let cs = -s.normal.dot(w);
                if cx > 0.0 && cs > 0.0 {
                    let c = s.area * cx * cs / (r2 + s.area * std::f32::consts::FRAC_1_PI);
                    sum += s.radiance * c;
                    coverage += c;
                }
            }
        }
        if s.sky_solid_angle > 0.0 {
            let c = s.sky_solid_angle * n.dot(s.sky_direction).max(0.0);
            sum += s.sky_radiance * c;
            coverage += c;
        }
    }
    sum * coverage_scale(coverage)
}

/// The factor [`surfel_irradiance`] scales the gathered light by when the surfels cover the
/// cosine-weighted solid angle `coverage` of the hemisphere (π in full): `π / coverage`,
/// clamped to `[MIN_COVERAGE_SCALE, MAX_COVERAGE_SCALE]`.
pub fn coverage_scale(coverage: f32) -> f32 {
    (std::f32::consts::PI / coverage.max(1e-6)).clamp(MIN_COVERAGE_SCALE, MAX_COVERAGE_SCALE)
}

/// The largest factor [`surfel_irradiance`] scales the gathered light by (a hemisphere at
/// least a quarter covered).
pub const MAX_COVERAGE_SCALE: f32 = 4.0;

/// The smallest factor [`surfel_irradiance`] scales the gathered light by (surfels counting a
/// hemisphere at most twice over).
pub const MIN_COVERAGE_SCALE: f32 = 0.5;

/// The near-field factor by which a probe's irradiance at `x` differs from its irradiance at
/// the probe, per channel: `(E_x + ε) / (E_p + ε)`, capped at [`MAX_PARALLAX_GAIN`], where
/// `E_x` is [`surfel_irradiance`] at `x` and `E_p` the same at the probe (`at_probe`; sample it
/// from [`surfel_irradiance_map`]), and `ε` is 5 % of `E_p`'s channel mean (so a channel the
/// probe barely sees is not scaled by the ratio of two small numbers).
pub fn parallax_gain(at_point: Vec3, at_probe: Vec3) -> Vec3 {
    let eps = 0.05 * (at_probe.x + at_probe.y + at_probe.z) / 3.0 + 1e-12;
    ((at_point + Vec3::splat(eps)) / (at_probe + Vec3::splat(eps)))
        .min(Vec3::splat(MAX_PARALLAX_GAIN))
}

/// The largest factor [`parallax_gain`] returns.
pub const MAX_PARALLAX_GAIN: f32 = 16.0;

/// [`surfel_irradiance`] at the probe's own `position` for every texel normal of a
/// `resolution²` octahedral map (padded): what the surfels give where the irradiance map is
/// exact, the denominator of [`parallax_gain`].
///
/// # Errors
/// [`ResolutionError`] for a resolution of 0 or above the maps' limit.
pub fn surfel_irradiance_map(
    surfels: &[Surfel],
    position: Vec3,
    resolution: u32,
) -> Result<OctaMap<Vec3>, ResolutionError> {
    OctaMap::from_fn(resolution, |n| surfel_irradiance(surfels, position, n))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Maps of a probe at `probe` inside the axis-aligned box `[lo, hi]` whose walls leave
    /// `wall(normal)` radiance.
    fn box_maps(
        probe: Vec3,
        lo: Vec3,
        hi: Vec3,
        n: u32,
        wall: impl Fn(Vec3) -> Vec3,
    ) -> (OctaMap<f32>, OctaMap<Vec3>, OctaMap<Vec3>) {
        let hit = |d: Vec3| -> (f32, Vec3) {
            let mut best = (f32::INFINITY, Vec3::ZERO);
            for axis in 0..3 {
                if d[axis] == 0.0 {
                    continue;
                }
                let plane = if d[axis] > 0.0 { hi[axis] } else { lo[axis] };
                let t = (plane - probe[axis]) / d[axis];
                if t < best.0 {
                    let mut normal = Vec3::ZERO;
                    normal[axis] = -d[axis].signum();
                    best = (t, normal);
                }
            }
            best
        };
        (
            OctaMap::from_fn(n, |d| hit(d).0).unwrap(),
            OctaMap::from_fn(n, |d| hit(d).1).unwrap(),
            OctaMap::from_fn(n, |d| wall(hit(d).1)).unwrap(),
        )
    }

    #[test]
    fn at_the_probe_the_surfels_give_the_irradiance_map() {
        // A box with differently lit walls: at the probe, the surfels' irradiance matches
        // the cosine convolution of the radiance map.
        let wall = |normal: Vec3| Vec3::new(0.2, 0.5, 1.0) * (1.5 + normal.x + 0.5 * normal.y);
        let probe = Vec3::new(0.3, -0.2, 0.1);
        let (d, nm, l) = box_maps(probe, Vec3::splat(-1.0), Vec3::new(1.0, 1.2, 0.8), 64, wall);
        let surfels = surfel_map(probe, &d, &nm, &l, 1e9, 16).unwrap();
        let irradiance = crate::irradiance_map(&l, 6).unwrap();
        let at_probe = surfel_irradiance_map(&surfels, probe, 6).unwrap();
        for (a, b) in irradiance.texels().iter().zip(at_probe.texels()) {
            let relative = (*a - *b).abs().max_element() / a.max_element();
            assert!(relative < 0.1, "map {a} surfels {b}");
        }
    }

    #[test]
    fn the_sky_counts_as_distant_light() {
        // No geometry: the surfels hold only sky, and every point gets the sky's irradiance.
        let d = OctaMap::filled(32, 1e9f32).unwrap();
        let nm = OctaMap::filled(32, Vec3::ZERO).unwrap();
        let l = OctaMap::from_fn(32, |d: Vec3| Vec3::splat(d.y.max(0.0))).unwrap();
        let surfels = surfel_map(Vec3::ZERO, &d, &nm, &l, 1e9, 8).unwrap();
        assert!(surfels.iter().all(|s| s.area == 0.0));
        let up = surfel_irradiance(&surfels, Vec3::new(5.0, 1.0, -3.0), Vec3::Y);
        // ∫ cos² over the upper hemisphere = 2π/3.
        assert!(
            (up.x / (2.0 * std::f32::consts::PI / 3.0) - 1.0).abs() < 0.03,
            "{up}"
        );
    }

    #[test]
    fn bad_resolutions_are_refused() {
        let d = OctaMap::filled(16, 1.0f32).unwrap();
        let nm = OctaMap::filled(16, Vec3::Z).unwrap();
        let l = OctaMap::filled(16, Vec3::ONE).unwrap();
        for r in [0, 3, 32] {
            assert!(matches!(
                surfel_map(Vec3::ZERO, &d, &nm, &l, 1e9, r),
                Err(SurfelError::Resolution { .. })
            ));
        }
        let small = OctaMap::filled(8, Vec3::ONE).unwrap();
        assert!(matches!(
            surfel_map(Vec3::ZERO, &d, &nm, &small, 1e9, 4),
            Err(SurfelError::Mismatch { .. })
        ));
    }

    proptest! {
        #![proptest_config(ProptestConfig {
            rng_seed: proptest::test_runner::RngSeed::Fixed(1),
            ..ProptestConfig::default()
        })]
        /// In a closed box of uniform radiance every point receives π L from every normal:
        /// the surfels of a probe anywhere inside tile the walls, seen from anywhere inside
        /// at least a surfel's size (here about 0.3 m) from the walls. (Nearer a wall, the
        /// few surfel centres beside the point are seen at grazing angles, and the gather
        /// falls short: 0.34 π at 6 cm from a wall near a corner.)
        #[test]
        fn a_uniform_enclosure_gives_pi_everywhere(
            probe in prop::array::uniform3(-0.8f32..0.8),
            x in prop::array::uniform3(-0.7f32..0.7),
            normal in prop::array::uniform3(-1.0f32..1.0),
        ) {
            let n = Vec3::from(normal);
            prop_assume!(n.length() > 0.1);
            let n = n.normalize();
            let (d, nm, l) = box_maps(Vec3::from(probe), Vec3::splat(-1.0), Vec3::ONE, 64, |_| Vec3::ONE);
            let surfels = surfel_map(Vec3::from(probe), &d, &nm, &l, 1e9, 16).unwrap();
            let e = surfel_irradiance(&surfels, Vec3::from(x), n).x / std::f32::consts::PI;
            prop_assert!((e - 1.0).abs() < 0.25, "E/π = {e}");
            let gain = parallax_gain(Vec3::splat(e), Vec3::ONE);
            prop_assert!(gain.x <= MAX_PARALLAX_GAIN);
        }
    }

    #[test]
    fn gain_is_one_at_equal_irradiance_and_capped() {
        let e = Vec3::new(0.5, 1.0, 2.0);
        assert!((parallax_gain(e, e) - Vec3::ONE).abs().max_element() < 1e-6);
        assert_eq!(
            parallax_gain(Vec3::splat(1e6), Vec3::splat(1.0)),
            Vec3::splat(16.0)
        );
    }
}
