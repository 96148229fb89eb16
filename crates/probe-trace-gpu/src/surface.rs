//! The per-texel surface model both tracers use (and the WGSL in `gpu/common.wgsl` mirrors):
//! the texel's angular radius, its surface plane, depth extent and thickness.

use glam::{Vec2, Vec3};

/// Bound on a texel's angular radius: every direction inside interior texel `(i, j)` of an
/// `N×N` octahedral map lies within `K_BETA · l1^1.5 / N` radians of the texel centre's
/// direction `d`, with `l1 = |d.x| + |d.y| + |d.z|` (the map's local scale: its solid-angle
/// density is `l1³` per unit octahedral area). Measured maximum of the ratio: 2.35 at `N = 4`,
/// 2.25 at `N = 64` (test `texel_radius_bound_holds`).
pub(crate) const K_BETA: f32 = 2.4;

/// Surfaces are treated as no more grazing than this (cosine), and never so grazing that the
/// texel's cone would run parallel to them: `cos γ >= max(COS_MIN, 2 sin β)`.
pub(crate) const COS_MIN: f32 = 0.1;

/// Relative safety margin on pyramid bounds, so that a coarse texel's bounds contain every
/// fine texel's bounds however the device rounds.
pub(crate) const PYRAMID_MARGIN: f32 = 1e-5;

/// Octahedral coordinates of the centre of interior texel `(ix, iy)` of an `N×N` map.
#[inline]
pub(crate) fn texel_center(n: u32, ix: u32, iy: u32) -> Vec2 {
    let nf = n as f32;
    Vec2::new(
        (2.0 * ix as f32 + 1.0) / nf - 1.0,
        (2.0 * iy as f32 + 1.0) / nf - 1.0,
    )
}

/// The packed normal meaning "unknown": x = `i16::MIN`, which `encode_snorm16` never
/// produces.
pub(crate) const UNKNOWN_NORMAL: u32 = 0x0000_8000;

/// Packs a unit normal as two 16-bit snorm octahedral coordinates (x in the low half), as WGSL's
/// `unpack2x16snorm` reads them. A zero vector packs as [`UNKNOWN_NORMAL`].
#[inline]
pub(crate) fn pack_normal(normal: Vec3) -> u32 {
    if normal == Vec3::ZERO {
        return UNKNOWN_NORMAL;
    }
    let [x, y] = probe_octa::encode_snorm16(normal);
    u32::from(x as u16) | (u32::from(y as u16) << 16)
}

/// Unpacks [`pack_normal`]; [`UNKNOWN_NORMAL`] gives the zero vector.
#[inline]
pub(crate) fn unpack_normal(packed: u32) -> Vec3 {
    if packed == UNKNOWN_NORMAL {
        return Vec3::ZERO;
    }
    let x = (packed & 0xFFFF) as u16 as i16;
    let y = (packed >> 16) as u16 as i16;
    probe_octa::decode_snorm16([x, y])
}

/// A texel's surface model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct TexelSurface {
    /// Closest radial distance the surface patch (with thickness) can have inside the texel.
    pub near: f32,
    /// Farthest radial distance, likewise.
    pub far: f32,
    /// Thickness accepted behind the plane (radial: `thickness_scale · D · β / cos γ`).
    pub thickness: f32,
    /// The same thickness measured along the plane's normal (`thickness · cos γ`): how far
    /// behind the plane a ray may start, or skim, and still count as leaving its front face.
    /// (The radial thickness grows without bound at grazing incidence: at 32² it let rays
    /// starting behind a 0.2 m wall, 0.55 m from the plane, pass as leaving it.)
    pub plane_thickness: f32,
    /// The plane's normal on the side the probe sees.
    pub visible_normal: Vec3,
    /// `|n·d|` of the stored normal and the texel direction (1 for an unknown normal).
    pub cos_incidence: f32,
}

/// The surface model of a texel at distance `distance` along unit direction `center` (the
/// texel centre), with stored normal `normal` (zero: unknown, taken as facing the probe).
///
/// The texel's surface is the plane through `distance · center` with that normal. Inside the
/// texel's cone (angular radius `β`), a plane meeting the centre direction at angle `γ` lies
/// between `D cos γ / cos(γ − β)` and `D cos γ / cos(γ + β)` from the probe; `near` and `far`
/// widen that by the thickness `thickness_scale · D · β / cos γ`.
#[inline]
pub(crate) fn texel_surface(
    resolution: u32,
    center: Vec3,
    distance: f32,
    normal: Vec3,
    thickness_scale: f32,
) -> TexelSurface {
    let beta = angular_radius(resolution, center);
    let (sin_b, cos_b) = beta.sin_cos();
    let (visible_normal, c) = facing_probe(center, normal);
    let cos_g = c.abs().max(COS_MIN.max(2.0 * sin_b)).min(1.0);
    let sin_g = (1.0 - cos_g * cos_g).max(0.0).sqrt();
    let far_extent = distance * (cos_g / (cos_g * cos_b - sin_g * sin_b) - 1.0);
    let near_extent = distance * (1.0 - cos_g / (cos_g * cos_b + sin_g * sin_b));
    let thickness = thickness_scale * distance * beta / cos_g;
    TexelSurface {
        near: distance - near_extent - thickness,
        far: distance + far_extent + thickness,
        thickness,
        plane_thickness: thickness * cos_g,
        visible_normal,
        cos_incidence: c.abs(),
    }
}

/// The angular radius `β` bound of the texel whose centre direction is `center`
/// ([`K_BETA`]).
#[inline]
fn angular_radius(resolution: u32, center: Vec3) -> f32 {
    let l1 = center.x.abs() + center.y.abs() + center.z.abs();
    K_BETA * l1 * l1.sqrt() / resolution as f32
}

/// A texel's stored `normal` turned to the probe's side (zero: unknown, taken as facing the
/// probe), with the cosine of the stored normal and the centre direction.
#[inline]
fn facing_probe(center: Vec3, normal: Vec3) -> (Vec3, f32) {
    let (n, c) = if normal == Vec3::ZERO {
        (-center, -1.0)
    } else {
        (normal, normal.dot(center))
    };
    (if c <= 0.0 { n } else { -n }, c)
}

/// The part of a texel's surface model that the trace reads at every fetch (the CPU twin's
/// `TexelPlane` and fine test): the plane's visible normal, its thickness (radial and along
/// the normal) and the incidence, without the `near`/`far` extents the bake's bounds need.
/// Each field equals [`texel_surface`]'s bit for bit; it skips the extents' divisions and,
/// where the texel's angular radius is at most 0.05 (every texel from 128² up), the sine that
/// only bounds `cos γ` there (`2 sin β ≤ 2β ≤ 0.1 = COS_MIN`). With this and two smaller
/// savings the CPU twin takes 3–4 % less time (BENCHMARKS.md, "The CPU twin's fetches").
#[inline]
pub(crate) fn texel_plane(
    resolution: u32,
    center: Vec3,
    distance: f32,
    normal: Vec3,
    thickness_scale: f32,
) -> TexelPlaneModel {
    let beta = angular_radius(resolution, center);
    let grazing_floor = if beta <= 0.05 {
        COS_MIN
    } else {
        COS_MIN.max(2.0 * beta.sin())
    };
    let (visible_normal, c) = facing_probe(center, normal);
    let cos_g = c.abs().max(grazing_floor).min(1.0);
    let thickness = thickness_scale * distance * beta / cos_g;
    TexelPlaneModel {
        thickness,
        plane_thickness: thickness * cos_g,
        visible_normal,
        cos_incidence: c.abs(),
    }
}

/// [`texel_plane`]'s answer: [`TexelSurface`] less `near` and `far`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct TexelPlaneModel {
    /// As [`TexelSurface::thickness`].
    pub thickness: f32,
    /// As [`TexelSurface::plane_thickness`].
    pub plane_thickness: f32,
    /// As [`TexelSurface::visible_normal`].
    pub visible_normal: Vec3,
    /// As [`TexelSurface::cos_incidence`].
    pub cos_incidence: f32,
}

#[cfg(test)]
mod tests {
    use super::*;
    use probe_octa::{OctaLayout, decode};

    /// The angular-radius bound holds at every texel of several resolutions (corners and
    /// edge points sampled; the farthest point of a texel from its centre lies on its edge).
    #[test]
    fn texel_radius_bound_holds() {
        for n in [8u32, 16, 64] {
            let layout = OctaLayout::new(n).unwrap();
            let mut worst = 0.0f32;
            for iy in 0..n {
                for ix in 0..n {
                    let c = layout.texel_direction(ix, iy);
                    let l1 = c.x.abs() + c.y.abs() + c.z.abs();
                    let step = 2.0 / n as f32;
                    let (u0, v0) = (-1.0 + ix as f32 * step, -1.0 + iy as f32 * step);
                    let mut angle = 0.0f32;
                    for k in 0..=8 {
                        let s = k as f32 / 8.0 * step;
                        for p in [
                            Vec2::new(u0 + s, v0),
                            Vec2::new(u0 + s, v0 + step),
                            Vec2::new(u0, v0 + s),
                            Vec2::new(u0 + step, v0 + s),
                        ] {
                            angle = angle.max(decode(p).dot(c).clamp(-1.0, 1.0).acos());
                        }
                    }
                    worst = worst.max(angle / (l1 * l1.sqrt() / n as f32));
                }
            }
            assert!(worst < K_BETA, "n={n}: ratio {worst}");
            assert!(worst > 2.0, "n={n}: the bound is loose ({worst})");
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig {
            rng_seed: proptest::test_runner::RngSeed::Fixed(1),
            ..proptest::prelude::ProptestConfig::default()
        })]
        /// The trace's plane model is the full surface model's, bit for bit, at every
        /// resolution the maps take (below 128² the sine still bounds `cos γ`), for stored and
        /// unknown normals at any incidence.
        #[test]
        fn the_plane_model_is_the_surface_models(
            log2_n in 2u32..10,
            fx in 0.0f32..1.0,
            fy in 0.0f32..1.0,
            nx in -1.0f32..1.0,
            ny in -1.0f32..1.0,
            nz in -1.0f32..1.0,
            distance in 0.001f32..100.0,
            thickness_scale in 0.0f32..4.0,
            unknown in proptest::bool::weighted(0.1),
        ) {
            let n = 1u32 << log2_n;
            let (ix, iy) = (((fx * n as f32) as u32).min(n - 1), ((fy * n as f32) as u32).min(n - 1));
            let center = decode(texel_center(n, ix, iy));
            let raw = Vec3::new(nx, ny, nz);
            let normal = if unknown || raw.length() < 1e-3 { Vec3::ZERO } else { raw.normalize() };
            let full = texel_surface(n, center, distance, normal, thickness_scale);
            let plane = texel_plane(n, center, distance, normal, thickness_scale);
            proptest::prop_assert_eq!(plane.thickness.to_bits(), full.thickness.to_bits());
            proptest::prop_assert_eq!(plane.plane_thickness.to_bits(), full.plane_thickness.to_bits());
            proptest::prop_assert_eq!(plane.visible_normal, full.visible_normal);
            proptest::prop_assert_eq!(plane.cos_incidence.to_bits(), full.cos_incidence.to_bits());
        }
    }

    #[test]
    fn normals_round_trip() {
        for d in [Vec3::X, Vec3::NEG_Y, Vec3::new(0.3, -0.4, -0.8).normalize()] {
            let back = unpack_normal(pack_normal(d));
            assert!(back.angle_between(d) < 1e-4, "{d} -> {back}");
        }
        assert_eq!(unpack_normal(pack_normal(Vec3::ZERO)), Vec3::ZERO);
        // +z packs to 0, which is a real normal, not "unknown".
        assert_eq!(pack_normal(Vec3::Z), 0);
        assert_eq!(unpack_normal(0), Vec3::Z);
    }

    #[test]
    fn plane_bounds_contain_the_plane() {
        // A plane at distance 2 along +z, tilted 60° from the centre direction: points of the
        // plane inside the texel's cone lie between near and far.
        let n = 32;
        let layout = OctaLayout::new(n).unwrap();
        let (ix, iy) = (16, 16);
        let center = layout.texel_direction(ix, iy);
        let normal = (-center + Vec3::X * 1.8).normalize();
        let d = 2.0;
        let s = texel_surface(n, center, d, normal, 0.0);
        assert!(s.near < d && d < s.far);
        let y = center * d;
        let step = 2.0 / n as f32;
        let c = texel_center(n, ix, iy);
        for k in 0..=10 {
            for l in 0..=10 {
                let p = c + Vec2::new(
                    (k as f32 / 10.0 - 0.5) * step,
                    (l as f32 / 10.0 - 0.5) * step,
                );
                let dir = decode(p);
                // Intersection of the ray from the probe along dir with the plane.
                let r = y.dot(normal) / dir.dot(normal);
                assert!(
                    r >= s.near - 1e-4 && r <= s.far + 1e-4,
                    "{r} outside [{}, {}]",
                    s.near,
                    s.far
                );
            }
        }
        assert!(s.visible_normal.dot(center) < 0.0);
    }
}
