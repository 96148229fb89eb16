//! Rays in, results out, and the options of a trace.

use std::time::Duration;

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

/// A ray to trace: `origin + t·direction` for `t_min <= t <= t_max` (32 bytes). WGSL mirror:
///
/// ```wgsl
/// struct TraceRay { origin: vec3<f32>, t_min: f32, direction: vec3<f32>, t_max: f32 }
/// ```
///
/// The direction need not be unit length: the tracers normalise it, so `t` is a distance.
/// `t_max` may be infinite.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct TraceRay {
    /// Start point, world space.
    pub origin: [f32; 3],
    /// Smallest `t` considered (>= 0).
    pub t_min: f32,
    /// Direction (normalised by the tracer).
    pub direction: [f32; 3],
    /// Largest `t` considered (may be `f32::INFINITY`).
    pub t_max: f32,
}

impl TraceRay {
    /// A ray over `[0, ∞)`.
    pub fn new(origin: Vec3, direction: Vec3) -> Self {
        Self::with_range(origin, direction, 0.0, f32::INFINITY)
    }

    /// A ray over `[t_min, t_max]`.
    pub fn with_range(origin: Vec3, direction: Vec3, t_min: f32, t_max: f32) -> Self {
        Self {
            origin: origin.to_array(),
            t_min,
            direction: direction.to_array(),
            t_max,
        }
    }
}

/// A point whose radiance the probes are asked for (32 bytes), for the hybrid tracer: the
/// geometry comes from an exact ray cast (a BVH, or a renderer's ray queries), the radiance
/// from the probes that see the point ([`crate::Tracer::look_up`]). WGSL mirror (it shares the
/// trace's binding 1, read there as a [`TraceRay`] whose `t_min` and `t_max` hold the bits of
/// `normal` and `surface`):
///
/// ```wgsl
/// struct SurfaceQuery { position: vec3<f32>, normal: u32, direction: vec3<f32>, surface: u32 }
/// ```
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct SurfaceQuery {
    /// The surface point (or, for an escaped ray, where it started), world space.
    pub position: [f32; 3],
    /// The surface's unit normal on the side the point is seen from, as two octahedral
    /// snorm16 coordinates (x in the low half; `0x8000`: unknown). [`Self::surface`] packs it.
    pub normal: u32,
    /// The direction the point is seen along (the ray's), unit length.
    pub direction: [f32; 3],
    /// 1: a surface point; 0: the ray left the scene, and the answer is the sky the probes
    /// saw along `direction`.
    pub surface: u32,
}

impl SurfaceQuery {
    /// The surface point `position` with normal `normal` (either side: it is turned towards
    /// the viewer), seen along `direction`.
    pub fn surface(position: Vec3, normal: Vec3, direction: Vec3) -> Self {
        let direction = direction.normalize_or_zero();
        let normal = if normal.dot(direction) > 0.0 {
            -normal
        } else {
            normal
        };
        Self {
            position: position.to_array(),
            normal: crate::surface::pack_normal(normal.normalize_or_zero()),
            direction: direction.to_array(),
            surface: 1,
        }
    }

    /// A ray from `origin` along `direction` that hits nothing.
    pub fn escaped(origin: Vec3, direction: Vec3) -> Self {
        Self {
            position: origin.to_array(),
            normal: crate::surface::UNKNOWN_NORMAL,
            direction: direction.normalize_or_zero().to_array(),
            surface: 0,
        }
    }
}

/// What a probe trace concluded about a ray.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum RayStatus {
    /// A probe saw the surface the ray hits: `t`, position, normal and radiance are its.
    Hit,
    /// A probe saw the whole rest of the ray pass in front of everything it captured, out to
    /// the ray's `t_max` or to its sky distance: radiance is that probe's texel in the ray's
    /// direction (its sky).
    Miss,
    /// No probe tried could see the whole ray (the cap on probes was reached or the
    /// candidates ran out). The answer is an estimate (seed 003 §5.4's fallback, made local):
    /// the first candidate for the last decided point that sees that point (else the first
    /// probe tried) marches the rest of the ray with relaxed rules, taking the first place
    /// where the ray may meet what it saw as the hit (going behind a texel's surface, or
    /// crossing its plane at an edge): `t`, position, normal and radiance are that guess's,
    /// and `probe` the estimating probe. If that probe sees the ray leave, radiance is its
    /// texel in the ray's direction (its sky), `t` and position mark how far the ray was
    /// verified empty, and the normal is zero. A mirror ray's radiance, where the guess is
    /// where the ray went out of the probe's sight, is the mean of that guess's and of a far
    /// guess (the same probe marching on past what it does not see; a guess past the scene's
    /// bounds reads the sky along the ray).
    Unknown,
}

impl RayStatus {
    /// The status code the shaders write (0 hit, 1 miss, 2 unknown).
    pub(crate) fn from_code(code: u32) -> Self {
        match code {
            0 => RayStatus::Hit,
            1 => RayStatus::Miss,
            _ => RayStatus::Unknown,
        }
    }
}

/// The result of tracing one ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayResult {
    /// Hit, miss or unknown.
    pub status: RayStatus,
    /// Ray parameter of the hit (Hit); where the answering probe's check ended, the ray's
    /// `t_max`, just inside the probe's sky distance, or past where the ray leaves the
    /// field's geometry bounds (Miss); how far the ray was verified empty (Unknown). Always
    /// finite.
    pub t: f32,
    /// `origin + t·direction`.
    pub position: Vec3,
    /// The stored surface normal at the hit (zero unless Hit).
    pub normal: Vec3,
    /// Radiance of the hit point read by the probe that sees it best (Hit: the answering
    /// probe or one of its nearest), the sky along the ray from a probe that sees clear sky
    /// that way, else the mean of those that do (Miss), or an estimate (Unknown).
    pub radiance: Vec3,
    /// The probe that answered (Hit, Miss) or gave the estimate (Unknown; for a ray no probe
    /// could start, the probe nearest its start, which read along it); `None` only when the
    /// field holds no probe to ask.
    pub probe: Option<u32>,
    /// Single-probe traces run for this ray.
    pub probes_tried: u32,
    /// Texel fetches made for this ray (see the crate documentation for what counts).
    pub texel_fetches: u32,
}

/// The per-ray record the trace shader writes (64 bytes): what a results buffer of
/// [`crate::GpuTracer::record_trace`] holds, one per ray in order. [`RayResult`] is the same
/// thing decoded (`RayResult::from(record)`). WGSL mirror, for a pass of yours that reads the
/// results:
///
/// ```wgsl
/// struct RayRecord {
///     position: vec3<f32>, t: f32,
///     normal: vec3<f32>, status: u32,
///     radiance: vec3<f32>, probe: u32,
///     probes_tried: u32, texel_fetches: u32, pad0: u32, pad1: u32,
/// }
/// ```
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct RayRecord {
    /// [`RayResult::position`].
    pub position: [f32; 3],
    /// [`RayResult::t`].
    pub t: f32,
    /// [`RayResult::normal`].
    pub normal: [f32; 3],
    /// [`RayResult::status`] as a code: 0 hit, 1 miss, 2 unknown.
    pub status: u32,
    /// [`RayResult::radiance`].
    pub radiance: [f32; 3],
    /// [`RayResult::probe`], with `u32::MAX` for none.
    pub probe: u32,
    /// [`RayResult::probes_tried`].
    pub probes_tried: u32,
    /// [`RayResult::texel_fetches`].
    pub texel_fetches: u32,
    /// Padding (zero).
    pub pad: [u32; 2],
}

impl From<RayRecord> for RayResult {
    fn from(r: RayRecord) -> Self {
        RayResult {
            status: RayStatus::from_code(r.status),
            t: r.t,
            position: Vec3::from(r.position),
            normal: Vec3::from(r.normal),
            radiance: Vec3::from(r.radiance),
            probe: (r.probe != u32::MAX).then_some(r.probe),
            probes_tried: r.probes_tried,
            texel_fetches: r.texel_fetches,
        }
    }
}

/// The single-probe trace over a probe's octahedral segments.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum TraceMethod {
    /// Hierarchical: walk the min/max pyramid, going up a level after each texel the ray passes
    /// in front of, down where it may meet a surface (seed 000 §4.3, after Uludag 2014).
    #[default]
    HiZ,
    /// McGuire et al. 2017: a DDA over a low-resolution minimum-distance level finds texels
    /// where the ray may meet a surface; a fine march over the full-resolution texels inside
    /// each such texel decides.
    TwoLevel,
}

impl TraceMethod {
    /// `"hiz"` or `"two-level"`.
    pub fn name(self) -> &'static str {
        match self {
            TraceMethod::HiZ => "hiz",
            TraceMethod::TwoLevel => "two-level",
        }
    }
}

/// Options of one trace call.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TraceOptions {
    /// Hi-Z or two-level.
    pub method: TraceMethod,
    /// Hi-Z: the coarsest pyramid level used, counted above full resolution (seed 000 limits
    /// hi-Z to 6–7 levels). Clamped to the levels the resolution has. Default 6.
    pub hiz_top_level: u32,
    /// Two-level: how many full-resolution texels per side one low-resolution texel covers
    /// (McGuire 2017: 16, 1024² → 64²); a power of two, clamped to the resolution. Default 16.
    pub coarse_downsample: u32,
    /// Most single-probe traces per ray (1..=64). Candidates whose depth map shows the point
    /// the ray restarts from hidden are skipped after one fetch and not counted. Default 16
    /// (measured: BENCHMARKS.md, "A tracer that answers").
    pub max_probes: u32,
    /// When the selection's own candidates for a point have all failed there, also try this
    /// many of the probes nearest to the point (0..=16, a k-d tree query; 0 turns the
    /// extension off, as before). Default 16.
    pub nearest_candidates: u32,
    /// Reject hits on surfaces facing away from the ray (seed 003 §7.2). Default true.
    pub back_face_rejection: bool,
    /// Filtered glossy: the perceptual GGX roughness `r` of every ray (`α = r²`, as
    /// `probe_capture::Reflection::Ggx`), 0..=1; 0 (the default) reads level 0 only. Each ray
    /// stands for a cone of angle `φ = probe_octa::ggx_lobe_angle(α)` about it (the lobe's
    /// median angle; 90° at roughness 1, where the footprint's `tan φ` is taken just below
    /// 90°, so a hit reads the top level): geometry comes from the centre ray as before; the radiance at a hit
    /// `t` along the ray, seen from the answering probe at distance `D`, is read from the
    /// prefiltered level whose texel matches the cone's footprint, `λ = log2(atan(t·tan φ / D)
    /// / texel_angle(N))` (for the sky, `φ` itself), interpolated between the two levels
    /// around `λ` (level 0 is the usual depth-aware read). Needs a field uploaded with
    /// [`crate::FieldOptions::glossy_levels`] > 0.
    pub glossy_roughness: f32,
    /// Filtered glossy (`glossy_roughness > 0`): how many probes a HIT or MISS answer, and an
    /// UNKNOWN ray's estimate, blends (0..=8; 0 reads the answering probe alone). The `k` probes nearest to the ray's origin
    /// (the shading point) each read their prefiltered levels towards the hit (for a MISS,
    /// along the ray, where their own texel there sees the sky), weighted by
    /// `(1 − d²/R²)²` with `R` the distance to the `k+1`-th nearest probe (so the weights,
    /// and the image, are continuous as the origin moves: a probe enters or leaves the blend
    /// at weight 0), times the cosine at which each sees the hit surface; probes that
    /// cannot see the hit (one depth fetch) are left out, and where none can, the answering
    /// probe's read stands. One probe answering each pixel alone shows every change of the
    /// answering probe as a seam (probe-sized patches in rough reflections). Mirror rays
    /// (`glossy_roughness` 0) are not blended. Default 6 (measured against 4 and 8 at
    /// roughness 0.1, 0.3 and 0.6: BENCHMARKS.md, "Filtered glossy", "Six probes").
    pub glossy_blend: u32,
    /// Two probes that agree make a hit: a crossing in a texel beside a farther edge that
    /// does not lie among samples of its surface is refused (UNKNOWN: it may lie beside the
    /// edge), but when most of the texels around it show it, it is put to the probes after
    /// it, and one that refuses a crossing at the same place (within both planes' thickness)
    /// makes it a hit there. Each texel grid puts its edges elsewhere. Default true
    /// (measured on the accuracy example's default rows: within one footprint +0.1 to +0.5
    /// points, UNKNOWN −0.04 to −0.4, radiance error level or lower on nine of ten rows and
    /// +1.7 % on the tenth; BENCHMARKS.md, "Two probes that refuse the same crossing").
    pub agreement: bool,
}

impl Default for TraceOptions {
    fn default() -> Self {
        Self {
            method: TraceMethod::HiZ,
            hiz_top_level: 6,
            coarse_downsample: 16,
            max_probes: 16,
            nearest_candidates: 16,
            back_face_rejection: true,
            glossy_roughness: 0.0,
            glossy_blend: 6,
            agreement: true,
        }
    }
}

/// Timings of one call.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Timing {
    /// Wall-clock time of the whole call (upload of rays, dispatch, read-back).
    pub wall: Duration,
    /// Time between the compute passes' start and end timestamps, summed over dispatches, when
    /// the device supports timestamp queries (`None` otherwise, and always for the CPU tracer).
    pub gpu: Option<Duration>,
}

/// Figures over many results: what the CLI prints.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TraceSummary {
    /// Rays traced.
    pub rays: usize,
    /// Rays answered Hit.
    pub hits: usize,
    /// Rays answered Miss.
    pub misses: usize,
    /// Rays left Unknown.
    pub unknown: usize,
    /// Mean texel fetches per ray.
    pub fetches_per_ray: f64,
    /// Mean single-probe traces per ray.
    pub probes_per_ray: f64,
}

impl TraceSummary {
    /// Counts and means over `results`.
    pub fn of(results: &[RayResult]) -> Self {
        let mut s = TraceSummary {
            rays: results.len(),
            ..TraceSummary::default()
        };
        let (mut fetches, mut probes) = (0u64, 0u64);
        for r in results {
            match r.status {
                RayStatus::Hit => s.hits += 1,
                RayStatus::Miss => s.misses += 1,
                RayStatus::Unknown => s.unknown += 1,
            }
            fetches += u64::from(r.texel_fetches);
            probes += u64::from(r.probes_tried);
        }
        if !results.is_empty() {
            s.fetches_per_ray = fetches as f64 / results.len() as f64;
            s.probes_per_ray = probes as f64 / results.len() as f64;
        }
        s
    }

    /// Share of rays answered (Hit or Miss), in `[0, 1]`.
    pub fn answered_rate(&self) -> f64 {
        if self.rays == 0 {
            0.0
        } else {
            (self.hits + self.misses) as f64 / self.rays as f64
        }
    }

    /// Share of rays answered Hit, in `[0, 1]`.
    pub fn hit_rate(&self) -> f64 {
        if self.rays == 0 {
            0.0
        } else {
            self.hits as f64 / self.rays as f64
        }
    }
    /// Share of rays left Unknown, in `[0, 1]` (0 for no rays).
    pub fn unknown_rate(&self) -> f64 {
        if self.rays == 0 {
            0.0
        } else {
            self.unknown as f64 / self.rays as f64
        }
    }
}

/// A point to shade diffusely (32 bytes). WGSL mirror:
///
/// ```wgsl
/// struct ShadingPoint { position: vec3<f32>, pad0: f32, normal: vec3<f32>, pad1: f32 }
/// ```
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct ShadingPoint {
    /// Surface point, world space.
    pub position: [f32; 3],
    /// Padding.
    pub pad0: f32,
    /// Unit surface normal (normalised by the shader).
    pub normal: [f32; 3],
    /// Padding.
    pub pad1: f32,
}

impl ShadingPoint {
    /// A shading point.
    pub fn new(position: Vec3, normal: Vec3) -> Self {
        Self {
            position: position.to_array(),
            pad0: 0.0,
            normal: normal.to_array(),
            pad1: 0.0,
        }
    }
}

/// Options of diffuse shading.
///
/// Each probe's weight is its interpolation weight (trilinear on a grid; barycentric in the
/// Delaunay tetrahedron, or on the nearest convex-hull triangle outside the hull) times, with
/// `visibility`, `max(chebyshev^visibility_exponent, min_weight)` and, with `backface`, DDGI's
/// smooth backface term `((n·ω + 1)/2)² + 0.2` (ω the direction to the probe). Probes flagged
/// as inside geometry ([`crate::IrradianceField::inside_geometry`]) are left out. Every factor
/// is continuous in the position and, unless every probe of the blend is flagged, the weight
/// sum stays bounded away from zero (`0.2 × min_weight` times the interpolation weights
/// left), so the renormalised blend is continuous too (no facets, no jumps).
///
/// Parsed from `key=value,...` text by [`std::str::FromStr`] (keys `visibility`,
/// `normal-bias`, `exponent`, `min-weight`, `backface`; `on`/`off` for the switches), e.g.
/// `normal-bias=0.05,exponent=2`; keys not given keep their defaults.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DiffuseOptions {
    /// Multiply each probe's weight by the Chebyshev visibility weight of its distance moments
    /// (seed 001 Listing 4.5, DDGI) raised to `visibility_exponent`. `false` gives the
    /// irradiance-only blend that leaks light through walls. Default true.
    pub visibility: bool,
    /// The shading point is moved this far along its normal before the visibility test, so a
    /// surface does not shadow itself (seed 001 biases the distance by 0.01), in metres.
    /// Default 0.1, chosen by measurement (BENCHMARKS.md, "Smooth diffuse"): on the leak rooms
    /// (probes 1–1.4 m apart) 0.02 leaves light leaking under the dividing wall's moments
    /// (tone-mapped MSE 4.0e-7 in the closed room, against 2.9e-8 at 0.1), and on the Cornell
    /// box (probes 0.19 m apart) 0.2 and more start to wash out contact shadows. Scale it with
    /// the probe spacing for much smaller or larger scenes.
    pub normal_bias: f32,
    /// The sharpness of the visibility test: the Chebyshev bound is raised to this power
    /// (DDGI cubes it), from 0 to 16. Default 5, chosen by measurement with the bias: 1 and 2
    /// leak (closed leak room 5.2e-6 and 7.0e-7 at bias 0.05), 5 leaks least (2.2e-9 at bias
    /// 0.1) and is as good as 3 elsewhere.
    pub visibility_exponent: f32,
    /// The smallest visibility factor a probe keeps, above 0 and at most 1 (DDGI clamps at
    /// 1e-6 and crushes small weights): it bounds the weight sum away from zero, so the
    /// renormalisation never jumps where every probe looks occluded. Default 1e-3.
    pub min_weight: f32,
    /// DDGI's smooth backface weighting: probes behind the surface count less (never zero).
    /// Default true.
    pub backface: bool,
    /// Correct each probe's irradiance for the point's offset from the probe with the
    /// probe's surfels ([`crate::IrradianceField::surfels`]; ignored where none were
    /// uploaded): the probe's irradiance map times the per-channel ratio of what its surfels
    /// deliver at the point to what they deliver at the probe ([`probe_octa::parallax_gain`]
    /// of [`probe_octa::surfel_irradiance`]). It restores the near field probes at a distance
    /// cannot hold (the light of a wall beside the point, the darkening into corners) but
    /// ignores occlusion between the point and the surfaces a probe saw. Costs a pass over
    /// every surfel of each blended probe. Default true, chosen by measurement (BENCHMARKS.md,
    /// "Near-field diffuse"): with the bake's default 8² surfels the final image's error falls
    /// 2.0–2.9× on the Cornell box and 1.08–1.27× on Sponza, the leak rooms' diffuse error
    /// 1.2–1.6×, and FLIP falls on every scene measured; the Breakfast room's MSE rises 13–30 %
    /// (on the wall beside its window, where the uncorrected probes already err; a test of
    /// each surfel's visibility from the point does not change it: BENCHMARKS.md, "Where the
    /// near-field diffuse raises the Breakfast room's error").
    pub parallax: bool,
}

impl Default for DiffuseOptions {
    fn default() -> Self {
        Self {
            visibility: true,
            normal_bias: 0.1,
            visibility_exponent: 5.0,
            min_weight: 1e-3,
            backface: true,
            parallax: true,
        }
    }
}

impl std::str::FromStr for DiffuseOptions {
    type Err = crate::error::DiffuseOptionsError;

    fn from_str(text: &str) -> Result<Self, Self::Err> {
        use crate::error::DiffuseOptionsError;
        let mut options = Self::default();
        for item in text.split(',').map(str::trim).filter(|s| !s.is_empty()) {
            let (key, value) = item
                .split_once('=')
                .ok_or_else(|| DiffuseOptionsError::NotKeyValue(item.to_owned()))?;
            let bad = || DiffuseOptionsError::BadValue {
                key: key.to_owned(),
                value: value.to_owned(),
            };
            let switch = || match value {
                "on" | "true" => Ok(true),
                "off" | "false" => Ok(false),
                _ => Err(bad()),
            };
            let number = || value.parse::<f32>().map_err(|_| bad());
            match key {
                "visibility" => options.visibility = switch()?,
                "backface" => options.backface = switch()?,
                "parallax" => options.parallax = switch()?,
                "normal-bias" => options.normal_bias = number()?,
                "exponent" => options.visibility_exponent = number()?,
                "min-weight" => options.min_weight = number()?,
                _ => return Err(DiffuseOptionsError::UnknownKey(key.to_owned())),
            }
        }
        Ok(options)
    }
}

/// The diffuse result at one shading point.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DiffuseResult {
    /// Blended irradiance `E(n)` (divide by π and multiply by albedo for outgoing radiance).
    pub irradiance: Vec3,
    /// Sum of the probes' weights before normalisation (interpolation × visibility): near 0
    /// where every probe was judged occluded.
    pub weight: f32,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The summary's shares count each status over all rays, and are 0 for no rays.
    #[test]
    fn summary_rates_count_statuses() {
        let result = |status| RayResult {
            status,
            t: 0.0,
            position: Vec3::ZERO,
            normal: Vec3::ZERO,
            radiance: Vec3::ZERO,
            probe: None,
            probes_tried: 1,
            texel_fetches: 2,
        };
        let results = [
            result(RayStatus::Hit),
            result(RayStatus::Miss),
            result(RayStatus::Unknown),
            result(RayStatus::Unknown),
        ];
        let s = TraceSummary::of(&results);
        assert_eq!(s.hit_rate(), 0.25);
        assert_eq!(s.answered_rate(), 0.5);
        assert_eq!(s.unknown_rate(), 0.5);
        let empty = TraceSummary::of(&[]);
        assert_eq!(
            (
                empty.hit_rate(),
                empty.answered_rate(),
                empty.unknown_rate()
            ),
            (0.0, 0.0, 0.0)
        );
    }
}
