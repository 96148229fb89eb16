//! `probe_octa`: octahedral maps for radiance probes.
//!
//! A light-field probe stores what it sees (radiance, normals, radial distance) in every
//! direction as a square 2-D texture through the octahedral mapping (Cigolle et al. 2014;
//! McGuire et al. 2017). This crate is the bottom of the `probes` workspace and owns that
//! mapping and everything built on it, on the CPU, with conventions the WGSL shaders mirror:
//!
//! * [`encode`] / [`decode`] between directions and octahedral coordinates, and 16- and
//!   32-bit quantised forms ([`encode_snorm8`], [`encode_snorm16`]);
//! * [`OctaLayout`]: texel ↔ direction mapping of an `N×N` map stored with a 1-texel border,
//!   exact texel solid angles, and the border rules of seed 001 Listing 4.4;
//! * [`OctaMap`]: a padded map of any [`Texel`] with seam-correct bilinear [`OctaMap::sample`];
//! * [`CubeMap`] and [`CubeMap::to_octahedral`]: resampling with seed 001's sharpness weight;
//! * [`MinMaxPyramid`]: conservative min/max radial-distance pyramids for hi-Z tracing
//!   (seed 000 §4.3) and McGuire's low-resolution minimum-distance map;
//! * [`distance_moments`], [`irradiance_map`], [`lobe_mean`], [`chebyshev_visibility`]: DDGI's
//!   low-resolution filtered maps; [`glossy_pyramid`] / [`ggx_filter`]: prefiltered radiance
//!   for glossy cone tracing (one GGX lobe per level); [`ShL2Rgb`]: L2 spherical harmonics and their irradiance;
//! * [`surfel_map`] / [`surfel_irradiance`]: a probe's texels as surface patches, re-gathered
//!   from another point (the near-field correction of diffuse shading, [`parallax_gain`]);
//! * [`split_ray`]: the ≤ 4 straight octahedral segments of a world-space ray.
//!
//! It depends on `glam` and `thiserror` only.
//!
//! # Conventions
//!
//! **Axes.** No swizzle: the octahedron's pole is the world `+z` axis. Octahedral coordinates
//! `(u, v) ∈ [-1, 1]²` put `+z` at the centre `(0, 0)`, `+x` at `(1, 0)`, `−x` at `(−1, 0)`,
//! `+y` at `(0, 1)`, `−y` at `(0, −1)`, and `−z` at all four corners. The upper hemisphere
//! `z >= 0` is the inner diamond `|u| + |v| <= 1`; the lower hemisphere folds into the four
//! corner triangles. Formulas (exactly those of the project brief):
//! `p = v.xy / (|x|+|y|+|z|)`, and if `v.z < 0`, `p = (1 − |p.yx|) · signNotZero(p)`; the
//! inverse `v = (o.x, o.y, 1 − |o.x| − |o.y|)`, if `v.z < 0`, `v.xy = (1 − |v.yx|) ·
//! signNotZero(v.xy)`, normalised. `signNotZero(a) = a >= 0 ? 1 : −1` (so `−0.0` counts as
//! `+`). The zero vector and non-finite vectors encode to `(0, 0)`.
//!
//! **Texels.** An `N×N` map's interior texel `(ix, iy)` covers
//! `u ∈ [−1 + 2ix/N, −1 + 2(ix+1)/N]`, `v ∈ [−1 + 2iy/N, −1 + 2(iy+1)/N]` and its value
//! belongs to the direction through its centre `(−1 + (2ix+1)/N, −1 + (2iy+1)/N)`.
//! `ix` grows with `u` (columns), `iy` with `v` (rows). Interior texel `(0, 0)` is the corner
//! `(u, v) = (−1, −1)`; in a GPU texture that is texture coordinate `(0, 0)`, the first texel
//! in memory.
//!
//! **Padded storage.** `(N+2)²` texels, row-major: padded texel `(px, py)` is element
//! `py·(N+2) + px`; interior `(ix, iy)` is padded `(ix+1, iy+1)`. Maps of several probes are
//! stored one after another by the caller. With `S = N + 1`, a border texel copies an interior
//! texel (seed 001, Listing 4.4): `(0, py) ← (1, S−py)`, `(S, py) ← (N, S−py)`,
//! `(px, 0) ← (S−px, 1)`, `(px, S) ← (S−px, N)`, and each corner the diagonally opposite
//! interior corner, `(0,0) ← (N,N)`, `(S,0) ← (1,N)`, `(0,S) ← (N,1)`, `(S,S) ← (1,1)`.
//! That is the octahedral wrap: crossing the outer edge `u = ±1` at `v` re-enters at `−v`.
//!
//! **Sampling.** Continuous padded texel coordinates are `c = 1 + (p + 1)/2 · N`, padded texel
//! `(px, py)` spanning `[px, px+1)` with centre `px + 0.5`. A GPU samples the padded texture at
//! `uv = c / (N + 2)` ([`OctaLayout::texture_uv`]); with bilinear filtering (and any address
//! mode: the taps never leave the padded texture) this is [`OctaMap::sample`], continuous
//! across every seam. Nearest reads ([`OctaMap::sample_nearest`], `textureLoad`) take interior
//! texel `min(floor((p + 1)/2 · N), N − 1)` per axis.
//!
//! **Cube maps** follow the Vulkan/D3D/wgpu face table ([`CubeMap`]); **SH** coefficients the
//! order and constants in [`ShL2Rgb`].
//!
//! # Example
//!
//! ```
//! use glam::Vec3;
//! use probe_octa::{FineRead, MinMaxPyramid, OctaMap, decode, encode, split_ray};
//!
//! // Directions round-trip through octahedral coordinates.
//! let d = Vec3::new(0.3, -0.5, -0.8).normalize();
//! assert!(decode(encode(d)).angle_between(d) < 1e-5);
//!
//! // A 64×64 radial-distance map (stored padded, 66×66) of a probe at the centre of a
//! // box 2 units wide, sampled bilinearly in any direction, seams included.
//! let distance = OctaMap::from_fn(64, |d: Vec3| 1.0 / d.abs().max_element())?;
//! assert_eq!(distance.texels().len(), 66 * 66);
//! let r = distance.sample(Vec3::new(1.0, 0.0, -1e-4));
//! assert!((r - 1.0).abs() < 1e-2);
//!
//! // A conservative min/max pyramid for hi-Z tracing, and McGuire's 16× minimum map.
//! let pyramid = MinMaxPyramid::build(&distance, FineRead::Bilinear, 7)?;
//! let [min, max] = pyramid.min_max(3, Vec3::X).unwrap().to_array();
//! assert!(min <= r && r <= max);
//! assert_eq!(pyramid.min_distance_map(16)?.resolution(), 4);
//!
//! // A ray seen from the probe makes at most four straight octahedral segments.
//! let pieces = split_ray(Vec3::ZERO, Vec3::new(-2.0, 0.5, 0.3), Vec3::X, 0.0, 4.0)?;
//! assert_eq!(pieces.len(), 2); // it crosses the probe's x = 0 plane once
//! assert_eq!(pieces[0].t_end, 2.0);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod cube;
mod filter;
mod glossy;
mod layout;
mod map;
mod octahedral;
mod pyramid;
mod ray;
mod sh;
mod surfel;

pub use cube::{CubeFace, CubeMap, default_sharpness};
pub use filter::{
    DDGI_DISTANCE_RESOLUTION, DDGI_IRRADIANCE_RESOLUTION, FilterError, chebyshev_visibility,
    distance_moments, irradiance_map, lobe_mean,
};
pub use glossy::{
    GGX_TAIL, downsample_box, fold, ggx_alpha_for_angle, ggx_filter, ggx_lobe_angle,
    glossy_level_alpha, glossy_pyramid, texel_angle,
};
pub use layout::{MAX_RESOLUTION, OctaLayout, ResolutionError};
pub use map::{MapError, OctaMap, Texel};
pub use octahedral::{
    decode, decode_snorm8, decode_snorm16, encode, encode_snorm8, encode_snorm16, sign_not_zero,
};
pub use pyramid::{FineRead, MinMaxPyramid, PyramidError};
pub use ray::{OctaSegment, OctaSegments, RaySplitError, split_ray};
pub use sh::ShL2Rgb;
pub use surfel::{
    MAX_COVERAGE_SCALE, MAX_PARALLAX_GAIN, MIN_COVERAGE_SCALE, MIN_SURFEL_COSINE, Surfel,
    SurfelError, coverage_scale, parallax_gain, surfel_irradiance, surfel_irradiance_map,
    surfel_map,
};
