//! The CPU twin of the GPU tracer: the same algorithms on the same packed numbers, one ray per
//! call, spread over the machine's threads.

mod diffuse;
pub(crate) mod march;
pub(crate) mod profile;
pub(crate) mod select;

use std::time::Instant;

use glam::{UVec2, Vec3};
use probe_index::NO_PROBE;

use crate::error::{TraceError, UploadError};
use crate::input::{FieldOptions, Interpolation, IrradianceField, LightField, ProbeSelection};
use crate::packed::{
    AGREEMENT_SHOWN_WEIGHT, NEAREST_ROW, PackedField, PackedIrradiance, PackedSelection,
    TraceParams, diffuse_params, padded_index, prepare_points, prepare_rays, trace_params,
};
use crate::ray::{
    DiffuseOptions, DiffuseResult, RayRecord, RayResult, ShadingPoint, SurfaceQuery, Timing,
    TraceOptions, TraceRay,
};
use crate::tracer::Tracer;
use march::{CONTINUE, HIT, MISS, March, ProbeRay, Segment, UNKNOWN, split_segments};
pub use profile::{FetchKind, FetchPhase, FetchProfile, PHASE_WINDOW_TEXELS, PROFILE_LEVELS};
use profile::{FetchLog, RayObserver};
use select::Selector;

/// Results of a trace call, with its timing.
#[derive(Clone, Debug, PartialEq)]
pub struct TraceOutput {
    /// One result per ray, in order.
    pub results: Vec<RayResult>,
    /// How long the call took.
    pub timing: Timing,
}

/// Results of a diffuse shading call, with its timing.
#[derive(Clone, Debug, PartialEq)]
pub struct DiffuseOutput {
    /// One result per shading point, in order.
    pub results: Vec<DiffuseResult>,
    /// How long the call took.
    pub timing: Timing,
}

/// The CPU reference tracer: same inputs, algorithms, texel reads and outputs as
/// [`crate::GpuTracer`], written in Rust step for step as the WGSL. It holds nothing: each
/// upload returns the packed arrays as a [`CpuField`] (or [`CpuIrradiance`]) the caller keeps
/// and passes to [`Tracer::trace`] (or [`Tracer::shade_diffuse`]).
#[derive(Clone, Copy, Debug, Default)]
pub struct CpuTracer;

/// A light field and its probe selection uploaded to the CPU twin: the same packed arrays the
/// GPU tracer puts in its storage buffers.
#[derive(Clone, Debug)]
pub struct CpuField {
    field: PackedField,
    selection: PackedSelection,
}

/// Irradiance probes uploaded to the CPU twin.
#[derive(Clone, Debug)]
pub struct CpuIrradiance {
    irradiance: PackedIrradiance,
}

impl CpuField {
    /// Probes in the field.
    pub fn probe_count(&self) -> u32 {
        self.field.probe_count
    }

    /// Interior texels per side of each probe's maps.
    pub fn resolution(&self) -> u32 {
        self.field.resolution
    }
}

impl CpuIrradiance {
    /// Probes in the field.
    pub fn probe_count(&self) -> u32 {
        self.irradiance.probe_count
    }
}

impl CpuTracer {
    /// The CPU twin.
    pub fn new() -> Self {
        Self
    }

    /// Traces `rays` as [`Tracer::trace`] does and returns where their texel fetches went
    /// ([`FetchProfile`]): a diagnostic for choosing options and for profiling the methods.
    ///
    /// # Errors
    /// As [`Tracer::trace`].
    pub fn profile_fetches(
        &self,
        field: &CpuField,
        rays: &[TraceRay],
        options: &TraceOptions,
    ) -> Result<FetchProfile, TraceError> {
        let (field, selection) = (&field.field, &field.selection);
        let params = trace_params(field, selection, options)?;
        let rays = prepare_rays(rays)?;
        let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
        let chunk = rays.len().div_ceil(threads).max(1);
        let parts: Vec<FetchProfile> = std::thread::scope(|scope| {
            let handles: Vec<_> = rays
                .chunks(chunk)
                .map(|part| {
                    let (field, selection, params) = (field, selection, &params);
                    scope.spawn(move || {
                        let mut profile = FetchProfile::default();
                        for ray in part {
                            trace_ray(field, selection, params, ray, &mut profile);
                        }
                        profile
                    })
                })
                .collect();
            handles
                .into_iter()
                .map(|h| h.join().unwrap_or_default())
                .collect()
        });
        let mut total = FetchProfile::default();
        for part in &parts {
            total.merge(part);
        }
        Ok(total)
    }
}

impl Tracer for CpuTracer {
    type Field = CpuField;
    type Irradiance = CpuIrradiance;

    fn describe(&self) -> String {
        "cpu twin".to_owned()
    }

    fn upload(
        &self,
        field: &LightField<'_>,
        selection: &ProbeSelection<'_>,
        options: &FieldOptions,
    ) -> Result<CpuField, UploadError> {
        let packed = PackedField::new(field, options)?;
        let selection = PackedSelection::new(selection, field.positions)?;
        let field = packed;
        Ok(CpuField { field, selection })
    }

    fn upload_irradiance(
        &self,
        field: &IrradianceField<'_>,
        interpolation: &Interpolation<'_>,
    ) -> Result<CpuIrradiance, UploadError> {
        Ok(CpuIrradiance {
            irradiance: PackedIrradiance::new(field, interpolation)?,
        })
    }

    fn trace(
        &mut self,
        field: &CpuField,
        rays: &[TraceRay],
        options: &TraceOptions,
    ) -> Result<TraceOutput, TraceError> {
        let start = Instant::now();
        let (field, selection) = (&field.field, &field.selection);
        let params = trace_params(field, selection, options)?;
        let rays = prepare_rays(rays)?;
        let records = parallel_map(&rays, |ray| {
            trace_ray(field, selection, &params, ray, &mut ())
        });
        Ok(TraceOutput {
            results: records.into_iter().map(RayResult::from).collect(),
            timing: Timing {
                wall: start.elapsed(),
                gpu: None,
            },
        })
    }

    fn look_up(
        &mut self,
        field: &CpuField,
        queries: &[SurfaceQuery],
        options: &TraceOptions,
    ) -> Result<TraceOutput, TraceError> {
        let start = Instant::now();
        let (field, selection) = (&field.field, &field.selection);
        let params = trace_params(field, selection, options)?;
        let queries = crate::packed::prepare_queries(queries)?;
        let records = parallel_map(&queries, |q| look_up_point(field, selection, &params, q));
        Ok(TraceOutput {
            results: records.into_iter().map(RayResult::from).collect(),
            timing: Timing {
                wall: start.elapsed(),
                gpu: None,
            },
        })
    }

    fn shade_diffuse(
        &mut self,
        irradiance: &CpuIrradiance,
        points: &[ShadingPoint],
        options: &DiffuseOptions,
    ) -> Result<DiffuseOutput, TraceError> {
        let start = Instant::now();
        let irradiance = &irradiance.irradiance;
        let params = diffuse_params(irradiance, options)?;
        let points = prepare_points(points)?;
        let results = parallel_map(&points, |p| diffuse::shade(irradiance, &params, p));
        Ok(DiffuseOutput {
            results,
            timing: Timing {
                wall: start.elapsed(),
                gpu: None,
            },
        })
    }
}

/// Items per block of [`parallel_map`]: small enough that the threads finish together (rays
/// differ in cost by orders of magnitude), large enough that taking a block costs nothing.
const BLOCK: usize = 256;

/// Maps `f` over `items` on all available threads, keeping order. Threads take blocks of
/// [`BLOCK`] items from a shared queue as they finish the last, so a thread that drew cheap
/// rays does not wait idle for one that drew expensive ones.
fn parallel_map<T: Sync, U: Send + Default + Clone>(
    items: &[T],
    f: impl Fn(&T) -> U + Sync,
) -> Vec<U> {
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let mut out = vec![U::default(); items.len()];
    if threads <= 1 || items.len() < 2 * BLOCK {
        for (o, item) in out.iter_mut().zip(items) {
            *o = f(item);
        }
        return out;
    }
    let blocks = std::sync::Mutex::new(out.chunks_mut(BLOCK).zip(items.chunks(BLOCK)));
    std::thread::scope(|scope| {
        for _ in 0..threads {
            let (f, blocks) = (&f, &blocks);
            scope.spawn(move || {
                // A poisoned lock means another worker panicked; the scope re-raises it.
                while let Some((outs, ins)) = blocks.lock().ok().and_then(|mut b| b.next()) {
                    for (o, item) in outs.iter_mut().zip(ins) {
                        *o = f(item);
                    }
                }
            });
        }
    });
    out
}

/// What one probe concluded about the ray from `t_start` on.
#[derive(Default)]
struct ProbeAnswer {
    code: u32,
    t: f32,
    cell: UVec2,
    normal: u32,
    fetches: u32,
    /// Texels along the probe's path where the answer was reached (recorded traces only).
    end_position: f32,
    /// A relaxed march's HIT is a guess where the ray went out of the probe's sight.
    guessed_hidden: bool,
    /// The crossing a strict march refused where it answered UNKNOWN, if put on.
    refused: Option<march::Refusal>,
}

/// Traces the ray through one probe from `t_start` (seed 003 Alg. 3 on the probe's segments).
fn trace_probe<L: FetchLog>(
    field: &PackedField,
    params: &TraceParams,
    probe: u32,
    ray: &TraceRay,
    t_start: f32,
    march: March,
    log: L,
) -> ProbeAnswer {
    let origin = Vec3::from(ray.origin) - field.position(probe);
    let direction = Vec3::from(ray.direction);
    // The ray counts as a miss once it is this far from the probe (just inside the sky).
    let sky = params.sky_distance * 0.999;
    let b = origin.dot(direction);
    let closest = origin - direction * b;
    let h2 = closest.dot(closest);
    let mut answer = ProbeAnswer {
        code: MISS,
        t: t_start,
        cell: UVec2::ZERO,
        normal: 0,
        fetches: 0,
        end_position: 0.0,
        guessed_hidden: false,
        refused: None,
    };
    if origin.length() >= sky {
        return answer;
    }
    let t_sky = -b + (sky * sky - h2).max(0.0).sqrt();
    let t_end = ray.t_max.min(t_sky);
    answer.t = t_end;
    if t_end <= t_start {
        answer.t = t_start;
        return answer;
    }
    let mut segments = [Segment::default(); 4];
    let count = split_segments(origin, direction, t_start, t_end, &mut segments);
    let mut probe_ray = ProbeRay {
        field,
        params,
        probe,
        origin,
        direction,
        t_min: ray.t_min,
        fetches: 0,
        log,
        path_position: 0.0,
        carry_level: 0,
        relaxed: march != March::Strict,
        pass_hidden: march == March::PastHidden,
        guessed_hidden: false,
        refused: None,
        last_radius: (f32::NAN, 0.0),
    };
    for segment in &segments[..count] {
        let outcome = probe_ray.march_segment(segment);
        if outcome.code != CONTINUE {
            answer = ProbeAnswer {
                code: outcome.code,
                t: outcome.t,
                cell: outcome.cell,
                normal: outcome.normal,
                fetches: 0,
                end_position: 0.0,
                guessed_hidden: false,
                refused: probe_ray.refused.filter(|_| outcome.code == UNKNOWN),
            };
            break;
        }
    }
    answer.fetches = probe_ray.fetches;
    answer.end_position = probe_ray.path_position;
    answer.guessed_hidden = probe_ray.guessed_hidden;
    answer
}

/// Radiance of interior texel `cell` of `probe` (one fetch).
fn radiance(field: &PackedField, probe: u32, cell: UVec2) -> [f32; 3] {
    let i = 3 * padded_index(field.resolution, probe, cell.x, cell.y);
    [
        field.radiance[i],
        field.radiance[i + 1],
        field.radiance[i + 2],
    ]
}

/// Interior texel `(ix, iy)` of an `n×n` map, `ix, iy ∈ [-1, n]`, through the octahedral wrap
/// of the map's border (`probe_octa::OctaLayout::border_source`).
fn wrap_texel(ix: i32, iy: i32, n: u32) -> UVec2 {
    let last = n as i32 - 1;
    let (outside_x, outside_y) = (ix < 0 || ix > last, iy < 0 || iy > last);
    let edge = |i: i32| if i < 0 { last } else { 0 };
    let (x, y) = match (outside_x, outside_y) {
        (false, false) => (ix, iy),
        (true, true) => (edge(ix), edge(iy)),
        (true, false) => (if ix < 0 { 0 } else { last }, last - iy),
        (false, true) => (last - ix, if iy < 0 { 0 } else { last }),
    };
    UVec2::new(x as u32, y as u32)
}

/// The direction of `v` (relative to a probe of an `n×n` map) in texel coordinates, texel
/// centres at whole numbers (`gpu/trace.wgsl`'s `bilinear_coordinate`); `None` for `v` at
/// the probe.
fn bilinear_coordinate(n: u32, v: Vec3) -> Option<glam::Vec2> {
    let r = v.length();
    if r <= 0.0 {
        return None;
    }
    let o = probe_octa::encode(v / r).clamp(glam::Vec2::NEG_ONE, glam::Vec2::ONE);
    Some((o + glam::Vec2::ONE) * (0.5 * n as f32) - glam::Vec2::splat(0.5))
}

/// The four texels around the texel coordinate `f` ([`bilinear_coordinate`]) with their
/// bilinear weights, through the map's wrap; the first is the lower left, at `f.floor()`.
fn texels_around(n: u32, f: glam::Vec2) -> [(UVec2, f32); 4] {
    let base = f.floor();
    let frac = f - base;
    std::array::from_fn(|k| {
        let (a, b) = ((k & 1) as i32, (k >> 1) as i32);
        let w =
            if a == 1 { frac.x } else { 1.0 - frac.x } * if b == 1 { frac.y } else { 1.0 - frac.y };
        (wrap_texel(base.x as i32 + a, base.y as i32 + b, n), w)
    })
}

/// The four texels around the direction of `v` (relative to a probe of an `n×n` map) with
/// their bilinear weights, through the map's wrap; `None` for `v` at the probe.
fn bilinear_texels(n: u32, v: Vec3) -> Option<[(UVec2, f32); 4]> {
    bilinear_coordinate(n, v).map(|f| texels_around(n, f))
}

/// The surface one texel of a probe stores, as the point tests read it
/// ([`TexelPlane::offset`]; `gpu/trace.wgsl`'s `texel_plane` step for step).
struct TexelPlane {
    /// The texel's record (distance and edge flag, packed normal, …, far bound and edge flag).
    record: [u32; 4],
    /// The stored radial distance.
    distance: f32,
    /// Where the texel's centre ray meets the stored surface, relative to the probe.
    point: Vec3,
    /// The texel's plane with its thickness.
    surface: crate::surface::TexelPlaneModel,
}

impl TexelPlane {
    /// `texel` of `probe` (one fetch; the caller counts it), or `None` for a sky texel.
    fn of(field: &PackedField, probe: u32, texel: UVec2) -> Option<Self> {
        let n = field.resolution;
        let record = field.geometry[padded_index(n, probe, texel.x, texel.y)];
        let distance = f32::from_bits(record[0] & !crate::packed::SIGN_BIT);
        if distance >= field.sky_distance {
            return None;
        }
        let center = probe_octa::decode(crate::surface::texel_center(n, texel.x, texel.y));
        let normal = crate::surface::unpack_normal(record[1]);
        Some(Self {
            record,
            distance,
            point: center * distance,
            surface: crate::surface::texel_plane(
                n,
                center,
                distance,
                normal,
                field.thickness_scale,
            ),
        })
    }

    /// The signed distance of `v` (relative to the probe) from the plane, positive on the
    /// side the probe sees.
    fn offset(&self, v: Vec3) -> f32 {
        (v - self.point).dot(self.surface.visible_normal)
    }

    /// Whether the plane holds `v` within its thickness.
    fn holds(&self, v: Vec3) -> bool {
        self.offset(v).abs() <= self.surface.plane_thickness
    }

    /// Whether the texel's surface faces like a surface with `normal` (oriented towards the
    /// probe's side; zero: unknown, which any texel does): within 60°
    /// ([`SAME_SURFACE_COS`]). In a crease a point lies within the thickness of both walls'
    /// texels; only those of its own wall show it.
    fn faces_like(&self, normal: Vec3) -> bool {
        normal == Vec3::ZERO || self.surface.visible_normal.dot(normal) >= SAME_SURFACE_COS
    }
}

/// Whether `texel` of `probe` shows the point `v` (relative to the probe: its surface's plane
/// holds `v` within the plane's thickness; one fetch).
fn texel_shows(field: &PackedField, probe: u32, texel: UVec2, v: Vec3) -> bool {
    texel_shows_surface(field, probe, texel, v, Vec3::ZERO)
}

/// [`texel_shows`] for a point of a surface with the known `normal` (zero: unknown, as
/// [`texel_shows`]): the texel's surface must also face the same way
/// ([`TexelPlane::faces_like`]). One fetch.
fn texel_shows_surface(
    field: &PackedField,
    probe: u32,
    texel: UVec2,
    v: Vec3,
    normal: Vec3,
) -> bool {
    TexelPlane::of(field, probe, texel)
        .is_some_and(|plane| plane.holds(v) && plane.faces_like(normal))
}

/// The least cosine between a texel's surface and a point's known normal for the texel to
/// show the point ([`TexelPlane::faces_like`]).
const SAME_SURFACE_COS: f32 = 0.5;

/// How the texels around the direction of the surface point `v` (relative to `probe`) show
/// it ([`texel_shows`]; one fetch each): whether every texel with a bilinear weight does (the
/// point lies **among samples** of its surface), and the bilinear weight of those that do.
/// A crossing in a texel with a farther edge is a hit only among samples: the surface is known
/// at the texel centres around it, and the tracer trusts a plane between samples that agree,
/// as it does inside every texel. Stops once the weight shown can no longer reach
/// [`AGREEMENT_SHOWN_WEIGHT`] (the weight it returns is then below it too).
/// `gpu/trace.wgsl`'s `samples_showing` step for step.
pub(crate) fn samples_showing(
    field: &PackedField,
    probe: u32,
    v: Vec3,
    fetches: &mut u32,
) -> (bool, f32) {
    let Some(texels) = bilinear_texels(field.resolution, v) else {
        return (false, 0.0);
    };
    let (mut all, mut shown, mut hidden) = (true, 0.0f32, 0.0f32);
    for (texel, w) in texels {
        if w <= 0.0 {
            continue;
        }
        *fetches += 1;
        if texel_shows(field, probe, texel, v) {
            shown += w;
        } else {
            all = false;
            hidden += w;
            if hidden > 1.0 - AGREEMENT_SHOWN_WEIGHT {
                break;
            }
        }
    }
    (all, shown)
}

/// The radiance `probe` holds towards the point `v` (relative to the probe) or, with `sky`,
/// in direction `v`: the bilinear blend of the four texels around that direction that show
/// it (for a surface point, the point within the thickness of the texel's plane; for the
/// sky, sky texels), through the map's wrap, so that a surface seen by several texels is not
/// quantised into texel-sized facets and an edge does not blend in what lies behind it. The
/// texel `cell` alone where none does. With `sharp`, a surface point whose texels form a step
/// takes one side of it ([`step_edge`]); a cone's read (`TraceOptions::glossy_roughness` > 0)
/// passes `false` and blends, as its prefiltered levels do. Each texel blended costs a
/// geometry and a radiance fetch; each rejected one a geometry fetch.
#[allow(clippy::too_many_arguments)]
fn filtered_radiance(
    field: &PackedField,
    probe: u32,
    v: Vec3,
    sky: bool,
    sharp: bool,
    cell: UVec2,
    fetches: &mut u32,
) -> [f32; 3] {
    surface_radiance(field, probe, v, sky, sharp, Vec3::ZERO, cell, fetches)
}

/// [`filtered_radiance`] of a point whose surface normal is known (`normal`, oriented
/// towards the probe's side; zero: unknown): only texels whose surface faces like it show
/// it ([`TexelPlane::faces_like`]).
#[allow(clippy::too_many_arguments)]
fn surface_radiance(
    field: &PackedField,
    probe: u32,
    v: Vec3,
    sky: bool,
    sharp: bool,
    normal: Vec3,
    cell: UVec2,
    fetches: &mut u32,
) -> [f32; 3] {
    if let Some(f) = bilinear_coordinate(field.resolution, v) {
        let texels = texels_around(field.resolution, f);
        let (mut sum, mut weight) = (Vec3::ZERO, 0.0f32);
        // Sky reads blend the clear sky texels alone where there are any: a sky texel at a
        // silhouette holds part of the surface's radiance ([`clear_sky_texel`]).
        let (mut clear_sum, mut clear_weight) = (Vec3::ZERO, 0.0f32);
        // A surface point's texels, for the step-edge read.
        let mut shown = [(0.0f32, Vec3::ZERO); 4];
        let mut count = 0;
        for (texel, w) in texels {
            if w <= 0.0 {
                continue;
            }
            *fetches += 1;
            // One load of the texel's record: for the sky, whether it is sky and whether
            // clear sky; for a point, whether its plane holds the point.
            let (shows, clear) = if sky {
                let record =
                    field.geometry[padded_index(field.resolution, probe, texel.x, texel.y)];
                (
                    crate::packed::record_is_sky(record, field.sky_distance),
                    crate::packed::record_is_clear_sky(record, field.sky_distance),
                )
            } else {
                (texel_shows_surface(field, probe, texel, v, normal), false)
            };
            if shows {
                *fetches += 1;
                let value = Vec3::from(radiance(field, probe, texel));
                let read = w * value;
                sum += read;
                weight += w;
                shown[count] = (w, value);
                count += 1;
                if clear {
                    clear_sum += read;
                    clear_weight += w;
                }
            }
        }
        if clear_weight > 0.0 {
            return (clear_sum / clear_weight).to_array();
        }
        if !sky && sharp && is_step(&shown[..count]) {
            // The texels around the four that show the point give the step's two sides
            // where the four are only partly lit (one fetch each, two where it shows it).
            let mut ring = [Vec3::ZERO; 12];
            let mut found = 0;
            let base = f.floor().as_ivec2();
            for (dx, dy) in STEP_EDGE_RING {
                let texel = wrap_texel(base.x + dx, base.y + dy, field.resolution);
                *fetches += 1;
                if texel_shows_surface(field, probe, texel, v, normal) {
                    *fetches += 1;
                    ring[found] = Vec3::from(radiance(field, probe, texel));
                    found += 1;
                }
            }
            if let Some(value) = step_edge(&shown[..count], &ring[..found]) {
                return value.to_array();
            }
        }
        if weight > 0.0 {
            return (sum / weight).to_array();
        }
    }
    *fetches += 1;
    radiance(field, probe, cell)
}

/// The smallest ratio of the brightest to the darkest texel of a bilinear read that
/// [`step_edge`] takes for a step between two radiances.
const STEP_EDGE_RATIO: f32 = 8.0;

/// The smallest tone-mapped (`x / (1 + x)`) difference between the brightest and the darkest
/// texel that [`step_edge`] takes for a step.
const STEP_EDGE_CONTRAST: f32 = 0.25;

/// The texels around a bilinear read's four (offsets from the first of them, the lower
/// left, [`texels_around`]): the 4×4 block less its middle 2×2.
const STEP_EDGE_RING: [(i32, i32); 12] = [
    (-1, -1),
    (0, -1),
    (1, -1),
    (2, -1),
    (-1, 0),
    (2, 0),
    (-1, 1),
    (2, 1),
    (-1, 2),
    (0, 2),
    (1, 2),
    (2, 2),
];

/// The mean of a radiance's channels: what [`step_edge`] compares.
fn channel_mean(v: Vec3) -> f32 {
    (v.x + v.y + v.z) / 3.0
}

/// Whether the texels `shown` (bilinear weight, radiance) that show a surface point form a
/// step: their brightest and darkest (by the mean of the channels) differ by
/// [`STEP_EDGE_RATIO`] and, tone-mapped, by [`STEP_EDGE_CONTRAST`] (an emitter's border, a
/// sharp shadow's).
fn is_step(shown: &[(f32, Vec3)]) -> bool {
    let levels = shown.iter().map(|t| channel_mean(t.1));
    let h = levels.clone().fold(f32::MIN, f32::max);
    let l = levels.fold(f32::MAX, f32::min);
    let tone = |x: f32| x / (1.0 + x);
    shown.len() >= 2 && h > STEP_EDGE_RATIO * l && tone(h) - tone(l) >= STEP_EDGE_CONTRAST
}

/// A sharp read of a step edge between the texels `shown` (bilinear weight, radiance) that
/// show a surface point, given the `ring` of texels around them that show it too: `None`
/// unless `shown` [`is_step`]. Each texel is the mean over its solid angle, so across a
/// step between a bright radiance `H` and a dark one `L` a texel holds `α·H + (1 − α)·L`
/// with `α` the share it sees of the bright side. `H` and `L` are the brightest and darkest
/// texels of `shown` and `ring` together (the ring holds a wholly lit and a wholly dark
/// texel where the four straddle the step partly lit). The bilinear blend of the four
/// texels' `α`s (clamped to `[0, 1]`) crosses ½ within a tenth of a texel of a straight
/// step, while the blend of the radiances smears `H` a whole texel into the dark side (a
/// ceiling beside a light read at a tenth of its radiance is still bright once tone-mapped).
/// So the read is `H` where the blended `α` is at least ½, else `L`. Where no texel of the
/// ring is wholly on a side (a light a texel or two across), a partly lit texel stands for
/// that side and the switch may fall up to a texel from the step (`gpu/trace.wgsl`'s
/// `step_edge` step for step).
fn step_edge(shown: &[(f32, Vec3)], ring: &[Vec3]) -> Option<Vec3> {
    if !is_step(shown) {
        return None;
    }
    let (mut bright, mut dark) = (shown[0].1, shown[0].1);
    for value in shown.iter().map(|t| t.1).chain(ring.iter().copied()) {
        if channel_mean(value) > channel_mean(bright) {
            bright = value;
        }
        if channel_mean(value) < channel_mean(dark) {
            dark = value;
        }
    }
    let (h, l) = (channel_mean(bright), channel_mean(dark));
    let (mut alpha, mut weight) = (0.0f32, 0.0f32);
    for &(w, value) in shown {
        alpha += w * ((channel_mean(value) - l) / (h - l)).clamp(0.0, 1.0);
        weight += w;
    }
    Some(if alpha >= 0.5 * weight { bright } else { dark })
}

/// Bilinear radiance of prefiltered glossy level `level` (>= 1) of `probe` in unit direction
/// `d`, through the level's padding: four fetches.
fn glossy_sample(
    field: &PackedField,
    params: &TraceParams,
    level: u32,
    probe: u32,
    d: Vec3,
    fetches: &mut u32,
) -> Vec3 {
    use glam::Vec2;
    let n = field.resolution >> level;
    let side = n + 2;
    let o = probe_octa::encode(d).clamp(Vec2::NEG_ONE, Vec2::ONE);
    let c = Vec2::ONE + (o + Vec2::ONE) * (0.5 * n as f32) - Vec2::splat(0.5);
    let base = c.floor().clamp(Vec2::ZERO, Vec2::splat(n as f32));
    let frac = (c - base).clamp(Vec2::ZERO, Vec2::ONE);
    let l = level as usize;
    let start = params.glossy_offsets[l / 4][l % 4] + probe * side * side;
    let mut sum = Vec3::ZERO;
    for k in 0..4u32 {
        let (a, b) = (k & 1, k >> 1);
        let wx = if a == 1 { frac.x } else { 1.0 - frac.x };
        let wy = if b == 1 { frac.y } else { 1.0 - frac.y };
        let i = 3 * (start + (base.y as u32 + b) * side + base.x as u32 + a) as usize;
        *fetches += 1;
        sum += (wx * wy)
            * Vec3::new(
                field.radiance[i],
                field.radiance[i + 1],
                field.radiance[i + 2],
            );
    }
    sum
}

/// The radiance a probe's answer gives: at a HIT, the texels that show the hit point
/// (`from_probe`, the hit relative to the probe); otherwise the sky texel in the ray's
/// `direction`.
#[allow(
    clippy::too_many_arguments,
    reason = "one probe's answer and where to read it"
)]
fn answer_radiance(
    field: &PackedField,
    params: &TraceParams,
    probe: u32,
    answer: &ProbeAnswer,
    from_probe: Vec3,
    direction: Vec3,
    fetches: &mut u32,
) -> [f32; 3] {
    if answer.code == HIT {
        glossy_radiance(
            field,
            params,
            probe,
            from_probe,
            false,
            answer.cell,
            answer.t,
            fetches,
        )
    } else {
        let cell = direction_cell(field.resolution, direction);
        glossy_radiance(
            field, params, probe, direction, true, cell, answer.t, fetches,
        )
    }
}

/// The radiance a ray's cone gathers where it ends (`TraceOptions::glossy_roughness`): with
/// no glossy levels in use, [`filtered_radiance`]; else the levels around
/// `λ = log2(φ_p / texel_angle(N))`, linearly interpolated, where `φ_p` is the cone's
/// footprint `t·tan φ` at the hit seen from the probe at `v` (`atan(t·tan φ / |v|)`), or for
/// the sky the cone angle `φ` itself. Level 0 is [`filtered_radiance`].
#[allow(clippy::too_many_arguments)]
fn glossy_radiance(
    field: &PackedField,
    params: &TraceParams,
    probe: u32,
    v: Vec3,
    sky: bool,
    cell: UVec2,
    t: f32,
    fetches: &mut u32,
) -> [f32; 3] {
    let r = v.length();
    if params.glossy_levels == 0 || r <= 0.0 {
        return filtered_radiance(field, probe, v, sky, true, cell, fetches);
    }
    let angle = if sky {
        params.glossy_angle
    } else {
        (t * params.glossy_tan / r).atan()
    };
    let lambda = (angle.max(1e-30) / params.glossy_base_angle)
        .log2()
        .clamp(0.0, params.glossy_levels as f32);
    let lo = lambda.floor() as u32;
    let f = lambda - lambda.floor();
    let d = v / r;
    let a = if lo == 0 {
        // A cone's read blends: the step-edge read is for rays without one.
        Vec3::from(filtered_radiance(
            field,
            probe,
            v,
            sky,
            params.glossy_tan == 0.0,
            cell,
            fetches,
        ))
    } else {
        glossy_sample(field, params, lo, probe, d, fetches)
    };
    if f > 0.0 {
        let b = glossy_sample(field, params, lo + 1, probe, d, fetches);
        return a.lerp(b, f).to_array();
    }
    a.to_array()
}

/// A filtered glossy answer or UNKNOWN estimate blended over the probes nearest to the ray's origin
/// (`TraceOptions::glossy_blend`; `gpu/trace.wgsl`'s `blended_radiance` step for step): each
/// of the `k` nearest reads its prefiltered levels towards the hit (`hit` true, at `end`, the
/// surface's `normal`) or, for a MISS, along `direction` where its own texel sees the sky;
/// weights `(1 − d²/R²)²` (`R`: the `k+1`-th nearest probe's distance) times the cosine at
/// which the probe sees the surface. Where the cone's footprint at the hit is wide as the
/// probe sees it ([`crate::GLOSSY_WIDE_TAN`]), a probe that sees the ray's origin instead of
/// the hit reads too, at its distance weight alone. `own`, the answering probe's read, stands
/// where no blended probe qualifies (or blending is off).
#[allow(
    clippy::too_many_arguments,
    reason = "one ray's end and where to read it"
)]
fn blended_radiance(
    field: &PackedField,
    selection: &PackedSelection,
    params: &TraceParams,
    origin: Vec3,
    direction: Vec3,
    hit: bool,
    end: Vec3,
    normal: Vec3,
    t: f32,
    own: [f32; 3],
    fetches: &mut u32,
) -> [f32; 3] {
    if params.glossy_levels == 0 || params.glossy_blend == 0 || params.kd_count == 0 {
        return own;
    }
    let k = params.glossy_blend as usize;
    let mut near = [(NO_PROBE, 0.0f32); select::MAX_BLEND_QUERY];
    let found = select::nearest_probes(
        &selection.words,
        params.kd_nodes,
        params.kd_count,
        origin,
        k + 1,
        &mut near,
    );
    // Fewer probes than k + 1: all of them, at equal distance weight.
    let radius2 = if found > k { near[k].1 } else { f32::INFINITY };
    let mut sum = Vec3::ZERO;
    let mut total = 0.0f32;
    for &(probe, d2) in &near[..found.min(k)] {
        let falloff = if radius2.is_finite() {
            let u = 1.0 - d2 / radius2;
            u * u
        } else {
            1.0
        };
        if falloff <= 0.0 {
            continue;
        }
        let radiance = if hit {
            let v = end - field.position(probe);
            let r = v.length();
            if r <= 0.0 {
                continue;
            }
            let w = if t * params.glossy_tan >= r * params.glossy_wide_tan {
                // A wide footprint: the probe reads the region around the hit, whether or
                // not it sees the hit itself; it must share the free space of the ray's
                // start or see the hit.
                if !sees_point(field, probe, end, false, fetches)
                    && !sees_point(field, probe, origin, false, fetches)
                {
                    continue;
                }
                falloff
            } else {
                let facing = -normal.dot(v / r);
                if facing <= 0.0 || !sees_point(field, probe, end, false, fetches) {
                    continue;
                }
                falloff * facing
            };
            let cell = direction_cell(field.resolution, v / r);
            let read = glossy_radiance(field, params, probe, v, false, cell, t, fetches);
            (w, read)
        } else {
            *fetches += 1;
            let cell = direction_cell(field.resolution, direction);
            if !sky_texel(field, probe, cell) {
                continue;
            }
            let read = glossy_radiance(field, params, probe, direction, true, cell, t, fetches);
            (falloff, read)
        };
        sum += radiance.0 * Vec3::from(radiance.1);
        total += radiance.0;
    }
    if total > 0.0 {
        (sum / total).to_array()
    } else {
        own
    }
}

/// The radiance at the end of a ray that `probe` answered or estimated ([`answer_radiance`]),
/// blended over the probes nearest to the ray's origin for a filtered ray
/// ([`blended_radiance`]; `normal`: the surface's at a HIT).
#[allow(
    clippy::too_many_arguments,
    reason = "one probe's answer and where to read it"
)]
fn end_radiance(
    field: &PackedField,
    selection: &PackedSelection,
    params: &TraceParams,
    probe: u32,
    answer: &ProbeAnswer,
    origin: Vec3,
    direction: Vec3,
    normal: Vec3,
    fetches: &mut u32,
) -> [f32; 3] {
    let end = origin + direction * answer.t;
    let own = answer_radiance(
        field,
        params,
        probe,
        answer,
        end - field.position(probe),
        direction,
        fetches,
    );
    blended_radiance(
        field,
        selection,
        params,
        origin,
        direction,
        answer.code == HIT,
        end,
        normal,
        answer.t,
        own,
        fetches,
    )
}

/// The interior texel holding `direction`.
fn direction_cell(resolution: u32, direction: Vec3) -> UVec2 {
    let [x, y] = probe_octa::OctaLayout::new(resolution)
        .expect("resolution checked at upload")
        .texel_containing(direction);
    UVec2::new(x, y)
}

/// Whether `probe`'s depth map can show the point `p` (one fetch): the texel holding its
/// direction sees the sky, or a surface that `p` lies no farther than (its `far` bound) and
/// not behind by more than the plane's thickness along its normal (`strict`: not behind it at
/// all). A probe that cannot would answer UNKNOWN at once, without progress (or, from just
/// behind a thin wall, pass the ray through it). The selection's own candidates get the
/// thickness; the nearest-probe extension, which knows nothing of visibility, is strict.
fn sees_point(field: &PackedField, probe: u32, p: Vec3, strict: bool, fetches: &mut u32) -> bool {
    sees_departure(field, probe, p, Vec3::ZERO, strict, fetches)
}

/// [`sees_point`] for the start of a ray leaving `p` along `direction` (zero: no direction).
/// A ray starts on the surface it leaves; a probe on that surface's other side shows the same
/// surface from behind, with `p` within its plane's thickness. It would see the ray pass
/// straight behind what it stored and answer a hit at once (a self-hit). So a texel whose
/// surface holds `p` within the thickness and faces away from `direction` (the ray leaves it
/// through its back) does not see the departure. One fetch, as [`sees_point`].
fn sees_departure(
    field: &PackedField,
    probe: u32,
    p: Vec3,
    direction: Vec3,
    strict: bool,
    fetches: &mut u32,
) -> bool {
    let v = p - field.position(probe);
    let r = v.length();
    if r == 0.0 {
        return true;
    }
    *fetches += 1;
    let cell = direction_cell(field.resolution, v / r);
    let Some(plane) = TexelPlane::of(field, probe, cell) else {
        return true;
    };
    if r > f32::from_bits(plane.record[3] & !crate::packed::SIGN_BIT) {
        return false;
    }
    let surface = &plane.surface;
    let slack = if strict { 0.0 } else { surface.plane_thickness };
    let offset = plane.offset(v);
    if offset.abs() <= surface.plane_thickness && direction.dot(surface.visible_normal) < 0.0 {
        return false;
    }
    offset >= -slack
}

/// Where a ray leaves the geometry bounds (`LightField::geometry_bounds`, widened): `f32::MAX`
/// without bounds, 0 or less when it starts outside them moving away (`gpu/trace.wgsl`'s
/// `bounds_exit` step for step).
fn bounds_exit(params: &TraceParams, origin: Vec3, direction: Vec3) -> f32 {
    if params.bounds_min[3] == 0.0 {
        return f32::MAX;
    }
    let mut t = f32::MAX;
    for axis in 0..3 {
        let (o, d) = (origin[axis], direction[axis]);
        let (lo, hi) = (params.bounds_min[axis], params.bounds_max[axis]);
        if d > 0.0 {
            t = t.min((hi - o) / d);
        } else if d < 0.0 {
            t = t.min((lo - o) / d);
        } else if o < lo || o > hi {
            return 0.0;
        }
    }
    t
}

/// The radiance where a ray (or a guess of its end) ends ([`end_radiance`]): at a HIT, the
/// read there of the probe that sees it best ([`hit_reader`]); at a MISS, or a guess past
/// `t_exit` (nothing lies beyond the scene's bounds), the sky along the ray from a probe whose
/// texel there sees the sky ([`sky_probe`]): for an answered MISS (`answered`) clear sky,
/// else the sky map's ([`sky_map_radiance`]); for an estimate's guess any sky, else `probe`'s
/// read along the ray (the sky map there doubled the error of Sponza's sparse grids, whose
/// rays are mostly estimates: BENCHMARKS.md, "Who reads a hit").
#[allow(clippy::too_many_arguments)]
fn ray_end_radiance(
    field: &PackedField,
    selection: &PackedSelection,
    params: &TraceParams,
    selector: &Selector<'_>,
    origin_list: &select::Candidates,
    probe: u32,
    answer: &ProbeAnswer,
    origin: Vec3,
    direction: Vec3,
    t_exit: f32,
    answered: bool,
    fetches: &mut u32,
) -> [f32; 3] {
    let sky = answer.code == MISS || answer.t > t_exit;
    // An answered MISS reads clear sky (a sky texel at a silhouette holds part of the
    // surface's radiance), else the sky map; an estimate's guess (`!answered`) that leaves
    // the bounds or meets nothing reads any sky as before (its truth is as often the edge as
    // the sky beyond it).
    let miss = answered && answer.code == MISS;
    let mut reader = if sky {
        sky_probe(
            selector,
            field,
            probe,
            origin_list,
            direction,
            miss,
            fetches,
        )
    } else {
        probe
    };
    if reader == NO_PROBE && !miss {
        // A guess past the bounds that no probe asked sees as sky: the probe's own read
        // along the ray, whatever it shows (BENCHMARKS.md, "Who reads a hit": the sky there
        // doubled the error of Sponza's sparse grids, whose rays are mostly such estimates).
        reader = probe;
    }
    if reader == NO_PROBE {
        // A MISS no probe asked sees as clear sky: the sky map's, blended like a probe's read.
        let own = sky_map_radiance(field, direction, fetches);
        let end = origin + direction * answer.t;
        return blended_radiance(
            field,
            selection,
            params,
            origin,
            direction,
            false,
            end,
            Vec3::ZERO,
            answer.t,
            own,
            fetches,
        );
    }
    let mut read = ProbeAnswer {
        code: if sky { MISS } else { answer.code },
        ..*answer
    };
    let normal = if read.code == HIT {
        crate::surface::unpack_normal(read.normal)
    } else {
        Vec3::ZERO
    };
    if read.code == HIT {
        // Read by the probe that sees the hit best.
        let hit = origin + direction * answer.t;
        (reader, read.cell) = hit_reader(
            field, selector, probe, read.cell, hit, normal, origin, fetches,
        );
    }
    end_radiance(
        field, selection, params, reader, &read, origin, direction, normal, fetches,
    )
}

/// The probe that reads a HIT's radiance and its texel there: of `probe`, the one that
/// answered (its texel `cell`), and its nearest probes (its row of the nearest-probe table)
/// that see the point (the texel holding its direction has a plane that holds it) from the
/// side the ray came from, the one that sees it most squarely for its distance: the cosine between the
/// surface's normal and the probe's view over the distance, a quarter for an edge texel (the
/// hybrid tracer's score, [`look_up_point`]). The probe that finished the ray often sees the
/// hit from far off or at a grazing angle, where its texels stretch along the surface and mix
/// what lies beside the point: a probe a few centimetres below the Cornell box's ceiling put
/// the light's radiance on the ceiling beside it, a smear the width of the light
/// (BENCHMARKS.md, "Who reads a hit"). One fetch per candidate examined.
#[allow(clippy::too_many_arguments, reason = "one hit and where to read it")]
fn hit_reader(
    field: &PackedField,
    selector: &Selector<'_>,
    probe: u32,
    cell: UVec2,
    hit: Vec3,
    normal: Vec3,
    origin: Vec3,
    fetches: &mut u32,
) -> (u32, UVec2) {
    // The surface's side the ray came from.
    let side = if normal.dot(origin - hit) >= 0.0 {
        normal
    } else {
        -normal
    };
    // Probe `q`'s view of the hit: from `q`, the cosine with the surface, the distance.
    let view = |q: u32| {
        let v = hit - field.position(q);
        let r = v.length();
        let facing = if r > 0.0 { -side.dot(v) / r } else { 0.0 };
        (v, facing, r)
    };
    let (_, facing, r) = view(probe);
    if r == 0.0 || side == Vec3::ZERO {
        return (probe, cell);
    }
    *fetches += 1;
    let own = field.geometry[padded_index(field.resolution, probe, cell.x, cell.y)];
    let mut best = (probe, cell, facing.max(0.0) / r * edge_weight(own));
    // The answering probe's row of the nearest-probe table: a table read, where the
    // selection's search at the hit (as good on the Cornell box) made every ray on lavapipe
    // 40 % slower (one more inlined copy of the selection).
    let row = select::Candidates::default();
    for i in 0..NEAREST_ROW {
        let q = selector.candidate(&row, probe, NO_PROBE, i);
        if q == NO_PROBE || q == probe {
            continue;
        }
        let (v, facing, r) = view(q);
        // Even an inner texel could not beat the best: no fetch.
        if facing <= 0.0 || facing / r <= best.2 {
            continue;
        }
        let texel = direction_cell(field.resolution, v / r);
        *fetches += 1;
        let Some(plane) = TexelPlane::of(field, q, texel) else {
            continue;
        };
        let score = facing / r * edge_weight(plane.record);
        if plane.holds(v) && score > best.2 {
            best = (q, texel, score);
        }
    }
    (best.0, best.1)
}

/// A texel's weight in the score of the probe that sees a point best ([`hit_reader`],
/// [`look_up_point`]): a quarter for an edge texel (either edge flag), whose plane may not
/// reach the point.
fn edge_weight(record: [u32; 4]) -> f32 {
    if (record[0] | record[3]) & crate::packed::SIGN_BIT != 0 {
        0.25
    } else {
        1.0
    }
}

/// The probe a MISS reads the sky from: `probe` when its texel along `direction` sees the sky
/// (with `clear`, clear sky: [`clear_sky_texel`]; one fetch), else the first of `origin_list`
/// (the selection's candidates at the ray's origin) and then of `probe`'s row of the
/// nearest-probe table whose texel there does (a probe inside a room sees a wall where a ray
/// left through a window), else `NO_PROBE` (a MISS then reads the sky map,
/// [`sky_map_radiance`]; before the map it read a wall or a silhouette's texel).
fn sky_probe(
    selector: &Selector<'_>,
    field: &PackedField,
    probe: u32,
    origin_list: &select::Candidates,
    direction: Vec3,
    clear: bool,
    fetches: &mut u32,
) -> u32 {
    let cell = direction_cell(field.resolution, direction);
    *fetches += 1;
    if sees_sky(field, probe, cell, clear) {
        return probe;
    }
    let (sky, _, examined) =
        first_sky_candidate(selector, field, origin_list, probe, probe, cell, clear);
    *fetches += examined;
    sky
}

/// [`clear_sky_texel`] with `clear`, else [`sky_texel`] (one fetch).
fn sees_sky(field: &PackedField, probe: u32, cell: UVec2, clear: bool) -> bool {
    if clear {
        clear_sky_texel(field, probe, cell)
    } else {
        sky_texel(field, probe, cell)
    }
}

/// The sky map's radiance along `direction` (one fetch; `PackedField::sky_map`): the mean
/// over the probes that see the sky that way, for a MISS none of whose probes does
/// (`gpu/trace.wgsl`'s `sky_map_radiance`).
fn sky_map_radiance(field: &PackedField, direction: Vec3, fetches: &mut u32) -> [f32; 3] {
    let cell = direction_cell(field.resolution, direction);
    let i = 3 * (field.sky_map + cell.y * field.resolution + cell.x) as usize;
    *fetches += 1;
    [
        field.radiance[i],
        field.radiance[i + 1],
        field.radiance[i + 2],
    ]
}

/// Whether `probe` sees the sky towards `exit`, where a ray it verified leaves the geometry
/// bounds (one fetch): then nothing lies beyond the point, and the ray passed it in front of
/// everything, not within the thickness of a surface in the box's face.
fn leaves_into_sky(field: &PackedField, probe: u32, exit: Vec3, fetches: &mut u32) -> bool {
    let v = exit - field.position(probe);
    if v == Vec3::ZERO {
        return false;
    }
    *fetches += 1;
    sky_texel(
        field,
        probe,
        direction_cell(field.resolution, v.normalize()),
    )
}

/// Whether interior texel `cell` of `probe` saw no geometry (one fetch).
fn sky_texel(field: &PackedField, probe: u32, cell: UVec2) -> bool {
    let texel = field.geometry[padded_index(field.resolution, probe, cell.x, cell.y)];
    crate::packed::record_is_sky(texel, field.sky_distance)
}

/// Whether interior texel `cell` of `probe` saw nothing but sky (one fetch;
/// [`crate::packed::record_is_clear_sky`]). What sky radiance is read from.
fn clear_sky_texel(field: &PackedField, probe: u32, cell: UVec2) -> bool {
    let texel = field.geometry[padded_index(field.resolution, probe, cell.x, cell.y)];
    crate::packed::record_is_clear_sky(texel, field.sky_distance)
}

/// The first of the selection's candidates at `x`, then of the probes nearest `x`, whose
/// interior texel `cell` sees the sky ([`first_sky_candidate`]).
fn first_seeing_sky(
    selector: &Selector<'_>,
    field: &PackedField,
    x: Vec3,
    direction: Vec3,
    cell: UVec2,
) -> (u32, u32, u32) {
    let list = selector.select(x, direction, NO_PROBE);
    let anchor = selector.anchor(x);
    first_sky_candidate(selector, field, &list, anchor, NO_PROBE, cell, true)
}

/// The first probe of `list`, then of `anchor`'s row of the nearest-probe table (none for
/// `NO_PROBE`), other than `skip`, whose interior texel `cell` sees the sky ([`sees_sky`],
/// one fetch each): `(that probe or NO_PROBE, the first candidate, candidates examined)`
/// (`gpu/trace.wgsl`'s `first_sky_candidate` step for step).
fn first_sky_candidate(
    selector: &Selector<'_>,
    field: &PackedField,
    list: &select::Candidates,
    anchor: u32,
    skip: u32,
    cell: UVec2,
    clear: bool,
) -> (u32, u32, u32) {
    let extension = if anchor == NO_PROBE {
        0
    } else {
        selector.params.nearest_candidates.min(NEAREST_ROW)
    };
    let (mut first, mut examined) = (NO_PROBE, 0u32);
    for i in 0..list.len + extension {
        let q = selector.candidate(list, anchor, skip, i);
        if q == NO_PROBE || q == skip {
            continue;
        }
        if first == NO_PROBE {
            first = q;
        }
        examined += 1;
        if sees_sky(field, q, cell, clear) {
            return (q, first, examined);
        }
    }
    (NO_PROBE, first, examined)
}

/// The multi-probe trace of one ray (seed 003 Alg. 5 with the selector's order, then the
/// nearest probes), reporting to `observer` (`&mut ()` for none). `gpu/trace.wgsl`'s
/// `trace_ray` step for step: one loop whose last pass, when no candidate is left or the cap
/// is reached, is the estimate's relaxed march.
pub(crate) fn trace_ray<O: RayObserver>(
    field: &PackedField,
    selection: &PackedSelection,
    params: &TraceParams,
    ray: &TraceRay,
    observer: &mut O,
) -> RayRecord {
    let selector = Selector {
        params,
        selection,
        positions: &field.positions,
    };
    let origin = Vec3::from(ray.origin);
    let direction = Vec3::from(ray.direction);
    // Nothing lies beyond the geometry bounds: a ray verified empty past where it leaves
    // them, into what the verifying probe sees as sky there, is a MISS.
    let t_exit = bounds_exit(params, origin, direction);
    // A filtered (cone) ray verified past the bounds: a MISS where it was verified, whose
    // radiance is the estimate's, as for an UNKNOWN ray (a cone whose axis leaves the scene
    // still meets what lies around the axis; the sky along the axis reads that worse:
    // BENCHMARKS, "Rays that leave the scene").
    let mut cone_miss: Option<f32> = None;
    let mut t = ray.t_min;
    let mut list = select::Candidates::default();
    // The candidates at the ray's origin: where a MISS looks for a probe that sees the sky.
    let mut origin_list = select::Candidates::default();
    // The probe that failed at `t` (the selection leaves it out), and the nearest-probe
    // table's row that extends the list once its own candidates have failed.
    let mut failed = NO_PROBE;
    let mut reselect = true;
    let (mut anchor, mut extension, mut extended) = (NO_PROBE, 0u32, false);
    let mut estimating = false;
    // Estimating with no probe that could start the ray: read along it, no march.
    let mut unstarted = false;
    let (mut next, mut tried, mut fetches) = (0u32, 0u32, 0u32);
    let mut fallback = NO_PROBE;
    // The last crossing a probe refused and put on: (probe, t, plane thickness).
    let mut refusal: Option<(u32, f32, f32)> = None;
    let mut record = RayRecord {
        status: UNKNOWN,
        probe: NO_PROBE,
        ..RayRecord::default()
    };
    loop {
        let here = origin + direction * t;
        if reselect {
            list = selector.select(here, direction, failed);
            if t == ray.t_min {
                origin_list = list;
            }
            (next, extension, extended, reselect) = (0, 0, false, false);
        }
        let mut probe = NO_PROBE;
        if tried >= params.max_probes {
            estimating = true;
        } else if next >= list.len + extension {
            if extended || params.nearest_candidates == 0 {
                estimating = true;
            } else {
                anchor = selector.anchor(here);
                if anchor != NO_PROBE {
                    extension = params.nearest_candidates.min(NEAREST_ROW);
                }
                extended = true;
                continue;
            }
        }
        if estimating {
            // No probe could finish the ray: it stays UNKNOWN, with an estimate (seed 003
            // §5.4's fallback, made local) by the first candidate that sees the last decided
            // point (else the first probe tried).
            for i in 0..list.len + extension {
                let q = selector.candidate(&list, anchor, failed, i);
                if q != NO_PROBE && sees_point(field, q, here, i >= list.len, &mut fetches) {
                    probe = q;
                    break;
                }
            }
            if probe == NO_PROBE {
                probe = fallback;
            }
            record.t = t;
            record.position = here.to_array();
            record.probes_tried = tried;
            if probe == NO_PROBE {
                // No probe could start the ray (none sees it leave, none sees where it
                // starts): the probe nearest its start reads along it, as an environment
                // map would, prefiltered at the cone's angle (it read black before:
                // BENCHMARKS.md, "Rays no probe can start"). `here` is the ray's start
                // and `anchor` the probe nearest it, found when the list was extended
                // (with no extension, the list's first candidate).
                probe = if anchor != NO_PROBE || list.len == 0 {
                    anchor
                } else {
                    list.probes[0]
                };
                unstarted = true;
                if probe == NO_PROBE {
                    break;
                }
            }
        } else {
            probe = selector.candidate(&list, anchor, failed, next);
            let strict = next >= list.len;
            // At the ray's start, a candidate must see the ray leave (not the surface it
            // leaves, from behind).
            let departing = if t == ray.t_min {
                direction
            } else {
                Vec3::ZERO
            };
            if probe == NO_PROBE
                || !sees_departure(field, probe, here, departing, strict, &mut fetches)
            {
                next += 1;
                continue;
            }
            tried += 1;
            if fallback == NO_PROBE {
                fallback = probe;
            }
        }
        let march = if estimating {
            March::FirstContact
        } else {
            March::Strict
        };
        let mut answer = if unstarted {
            ProbeAnswer {
                code: UNKNOWN,
                t,
                ..ProbeAnswer::default()
            }
        } else {
            match observer.fetch_log() {
                Some(log) => trace_probe(field, params, probe, ray, t, march, log),
                None => trace_probe(field, params, probe, ray, t, march, ()),
            }
        };
        fetches += answer.fetches;
        if estimating {
            // The relaxed march's first place where the ray may meet what the probe saw; if
            // it sees the ray leave, the radiance in the ray's direction.
            if answer.code == HIT {
                let hit = origin + direction * answer.t;
                record.t = answer.t;
                record.position = hit.to_array();
                record.normal = crate::surface::unpack_normal(answer.normal).to_array();
            }
            record.probe = probe;
            if params.glossy_levels == 0 {
                // A mirror ray (no cone): its true end lies past where the probe loses sight
                // of it (the near guess above) and, unless hidden there, no farther than where
                // it next crosses a surface the probe saw (the far guess, marched no farther
                // than the scene's bounds). The estimate is the mean of the radiance at both;
                // a guess beyond the bounds (nothing lies there) or a MISS reads the sky
                // along the ray (BENCHMARKS.md, "Estimates between two guesses").
                let mut read = |guess: &ProbeAnswer| {
                    Vec3::from(ray_end_radiance(
                        field,
                        selection,
                        params,
                        &selector,
                        &origin_list,
                        probe,
                        guess,
                        origin,
                        direction,
                        t_exit,
                        false,
                        &mut fetches,
                    ))
                };
                let mut radiance = read(&answer);
                // Only a near guess where the ray went out of sight has a far guess apart from
                // it; that march goes on from there.
                if answer.code == HIT && answer.guessed_hidden {
                    let bounded = TraceRay {
                        t_max: ray.t_max.min(t_exit),
                        ..*ray
                    };
                    let (t0, far) = (answer.t, March::PastHidden);
                    let past = match observer.fetch_log() {
                        Some(log) => trace_probe(field, params, probe, &bounded, t0, far, log),
                        None => trace_probe(field, params, probe, &bounded, t0, far, ()),
                    };
                    radiance = 0.5 * (radiance + read(&past));
                    fetches += past.fetches;
                }
                record.radiance = radiance.to_array();
                break;
            }
            // A filtered estimate blends like an answer: one wrong probe's read is the
            // pixel's whole error otherwise (BENCHMARKS.md, "Filtered glossy").
            let normal = Vec3::from(record.normal);
            record.radiance = end_radiance(
                field,
                selection,
                params,
                probe,
                &answer,
                origin,
                direction,
                normal,
                &mut fetches,
            );
            break;
        }
        // Two probes that each refused a crossing beside a farther edge at the same place
        // (within both planes' thickness) agree on a surface there: a hit at their mean.
        // Each texel grid puts its edges elsewhere, so beside one probe's edge another's
        // texels may show the surface; only a refusal most of whose texels show it is put on
        // (BENCHMARKS.md, "Two probes that refuse the same crossing").
        if let Some(crossing) = answer.refused.filter(|_| params.agreement != 0) {
            match refusal {
                Some((other, t0, tolerance))
                    if other != probe
                        && (t0 - crossing.t).abs() < tolerance.min(crossing.tolerance) =>
                {
                    answer.code = HIT;
                    answer.t = 0.5 * (t0 + crossing.t);
                    answer.cell = crossing.cell;
                    answer.normal = crossing.normal;
                }
                _ => refusal = Some((probe, crossing.t, crossing.tolerance)),
            }
        }
        observer.probe_done(answer.code, answer.t > t, answer.end_position, tried - 1);
        if answer.code == UNKNOWN
            && answer.t >= t_exit
            && leaves_into_sky(field, probe, origin + direction * t_exit, &mut fetches)
        {
            if params.glossy_levels > 0 {
                cone_miss = Some(answer.t);
                estimating = true;
                continue;
            }
            answer.code = MISS;
        }
        if answer.code == HIT || answer.code == MISS {
            let hit = origin + direction * answer.t;
            let normal = if answer.code == HIT {
                crate::surface::unpack_normal(answer.normal)
            } else {
                Vec3::ZERO
            };
            // A HIT is read by the probe that sees it best; a MISS reads the sky along the
            // ray, from a probe whose texel there sees clear sky (else the sky map).
            let radiance = ray_end_radiance(
                field,
                selection,
                params,
                &selector,
                &origin_list,
                probe,
                &answer,
                origin,
                direction,
                f32::MAX,
                true,
                &mut fetches,
            );
            record.status = answer.code;
            record.t = answer.t;
            record.position = hit.to_array();
            record.normal = normal.to_array();
            record.radiance = radiance;
            record.probe = probe;
            record.probes_tried = tried;
            record.texel_fetches = fetches;
            observer.ray_done(record.status, fetches);
            return record;
        }
        if answer.t > t {
            t = answer.t;
            failed = probe;
            reselect = true;
        } else {
            next += 1;
        }
    }
    if let Some(t_miss) = cone_miss {
        record.status = MISS;
        record.t = t_miss;
        record.position = (origin + direction * t_miss).to_array();
        record.normal = [0.0; 3];
    }
    record.texel_fetches = fetches;
    observer.ray_done(record.status, fetches);
    record
}

/// The candidates whose texel in a point's direction came nearest to showing it, by the
/// relative gap between the texel's distance and the point's (the best first), for the
/// estimate of a point no probe sees ([`look_up_point`]).
#[derive(Clone, Copy)]
struct NearMisses {
    probes: [u32; 2],
    cells: [UVec2; 2],
    errors: [f32; 2],
}

impl Default for NearMisses {
    fn default() -> Self {
        Self {
            probes: [NO_PROBE; 2],
            cells: [UVec2::ZERO; 2],
            errors: [f32::INFINITY; 2],
        }
    }
}

impl NearMisses {
    /// Keeps `probe` if its `error` is below one of the two kept (ties keep the earlier).
    fn insert(&mut self, probe: u32, cell: UVec2, error: f32) {
        if error < self.errors[0] {
            (self.probes[1], self.cells[1], self.errors[1]) =
                (self.probes[0], self.cells[0], self.errors[0]);
            (self.probes[0], self.cells[0], self.errors[0]) = (probe, cell, error);
        } else if error < self.errors[1] {
            (self.probes[1], self.cells[1], self.errors[1]) = (probe, cell, error);
        }
    }
}

/// How far, in texels either way, [`nearest_surface_texel`] looks from the point's own texel.
pub(crate) const NEAREST_SURFACE_REACH: u32 = 4;

/// The texel of `probe` within [`NEAREST_SURFACE_REACH`] of `cell` (clamped to the map) whose
/// stored point lies nearest to the surface point `v` (relative to the probe) on the point's
/// own surface: facing like `normal` ([`TexelPlane::faces_like`]) and off the point's plane by
/// no more than the texel's plane thickness plus a fifth of its distance from the point, with
/// that distance. `None` when no texel there shows that surface. One fetch per texel; `gpu/trace.wgsl`'s
/// `nearest_surface_texel` step for step.
fn nearest_surface_texel(
    field: &PackedField,
    probe: u32,
    cell: UVec2,
    v: Vec3,
    normal: Vec3,
    fetches: &mut u32,
) -> Option<(UVec2, f32)> {
    let n = field.resolution;
    let (mut found, mut nearest) = (None, f32::INFINITY);
    for y in
        cell.y.saturating_sub(NEAREST_SURFACE_REACH)..=(cell.y + NEAREST_SURFACE_REACH).min(n - 1)
    {
        for x in cell.x.saturating_sub(NEAREST_SURFACE_REACH)
            ..=(cell.x + NEAREST_SURFACE_REACH).min(n - 1)
        {
            let texel = UVec2::new(x, y);
            *fetches += 1;
            let Some(plane) = TexelPlane::of(field, probe, texel) else {
                continue;
            };
            let gap = plane.point - v;
            let distance = gap.length();
            if plane.faces_like(normal)
                && gap.dot(normal).abs() <= plane.surface.plane_thickness + 0.2 * distance
                && distance < nearest
            {
                (found, nearest) = (Some((texel, distance)), distance);
            }
        }
    }
    found
}

/// The radiance of one surface point from the probes that see it (the hybrid tracer's second
/// half; `gpu/trace.wgsl`'s `look_up_point` step for step).
///
/// Candidates are the selection's for the point, then (only if none of those sees it) the
/// nearest probes. A candidate sees the point when it lies on the point's side of the surface
/// and the texel holding the point's direction shows a surface whose plane holds the point
/// within the plane's thickness along its normal and which faces like the point's surface
/// ([`TexelPlane::faces_like`]; one fetch). The best such probe, by the cosine of its view of
/// the surface over its distance (edge texels weighed a quarter), answers HIT with the blend
/// of its texels around the point that face like it ([`surface_radiance`]); where no texel
/// faces like it, the best whose plane merely holds it answers, read without the facing test
/// (a crease's other wall read the point before: BENCHMARKS.md, "The hybrid reads a point
/// from its own surface"). If none sees it: UNKNOWN, an estimate from the point's own
/// surface nearby: of the two candidates whose texel's distance came closest to the point's
/// (every probe facing the point is asked where no candidate does), the texel within
/// [`NEAREST_SURFACE_REACH`] whose stored point lies nearest on that surface
/// ([`nearest_surface_texel`]); where neither shows it, the closest candidate's texel in the
/// point's direction (which shows what hides it). Escaped rays: MISS, the sky along the direction
/// from the first candidate (own, then nearest) whose texel there is clear sky, else the sky
/// map's ([`sky_map_radiance`]).
pub(crate) fn look_up_point(
    field: &PackedField,
    selection: &PackedSelection,
    params: &TraceParams,
    query: &SurfaceQuery,
) -> RayRecord {
    let selector = Selector {
        params,
        selection,
        positions: &field.positions,
    };
    let x = Vec3::from(query.position);
    let direction = Vec3::from(query.direction);
    let mut record = RayRecord {
        status: UNKNOWN,
        probe: NO_PROBE,
        position: query.position,
        ..RayRecord::default()
    };
    if query.surface == 0 {
        // The sky along the ray: from the first candidate whose texel in that direction sees
        // the sky (a probe inside a room sees a wall there, whatever the ray left through),
        // else the sky map's.
        let cell = direction_cell(field.resolution, direction);
        let (sky, first, examined) = first_seeing_sky(&selector, field, x, direction, cell);
        let mut fetches = examined;
        let probe = if sky != NO_PROBE { sky } else { first };
        if probe != NO_PROBE {
            record.status = MISS;
            record.radiance = if sky != NO_PROBE {
                filtered_radiance(field, probe, direction, true, true, cell, &mut fetches)
            } else {
                sky_map_radiance(field, direction, &mut fetches)
            };
            record.probe = probe;
            record.probes_tried = examined;
            record.texel_fetches = fetches;
        }
        return record;
    }
    let list = selector.select(x, direction, NO_PROBE);
    let normal = crate::surface::unpack_normal(query.normal);
    let n = field.resolution;
    let (mut best, mut best_cell, mut best_score) = (NO_PROBE, UVec2::ZERO, 0.0f32);
    // The best probe whose texel holds the point on a surface facing otherwise (a crease's
    // other wall, a curved or small surface): the answer only where no texel faces like it.
    let (mut other, mut other_cell, mut other_score) = (NO_PROBE, UVec2::ZERO, 0.0f32);
    let mut near_misses = NearMisses::default();
    let (mut next, mut examined, mut fetches) = (0u32, 0u32, 0u32);
    let (mut anchor, mut extension, mut extended) = (NO_PROBE, 0u32, false);
    loop {
        if next >= list.len + extension {
            if extended || best != NO_PROBE || params.nearest_candidates == 0 {
                break;
            }
            anchor = selector.anchor(x);
            if anchor != NO_PROBE {
                extension = params.nearest_candidates.min(NEAREST_ROW);
            }
            extended = true;
            continue;
        }
        let probe = selector.candidate(&list, anchor, NO_PROBE, next);
        next += 1;
        if probe == NO_PROBE {
            continue;
        }
        let v = x - field.position(probe);
        let r = v.length();
        if r == 0.0 {
            continue;
        }
        let w = v / r;
        let facing = if normal == Vec3::ZERO {
            1.0
        } else {
            -normal.dot(w)
        };
        if facing <= 0.0 {
            continue;
        }
        examined += 1;
        fetches += 1;
        let cell = direction_cell(n, w);
        let Some(plane) = TexelPlane::of(field, probe, cell) else {
            continue;
        };
        // The texel shows the point: it lies on the texel's plane, within the plane's
        // thickness along its normal, and the texel's surface faces like the point's.
        if plane.holds(v) {
            let score = facing / r * edge_weight(plane.record);
            if plane.faces_like(normal) {
                if score > best_score {
                    (best, best_cell, best_score) = (probe, cell, score);
                }
            } else if score > other_score {
                (other, other_cell, other_score) = (probe, cell, score);
            }
        } else {
            near_misses.insert(probe, cell, (r - plane.distance).abs() / r);
        }
    }
    if best == NO_PROBE && other == NO_PROBE && near_misses.probes[0] == NO_PROBE {
        // No candidate faces the point: every probe that does is asked (rare: a surface
        // turned away from all its candidates).
        for probe in 0..field.probe_count {
            let v = x - field.position(probe);
            let r = v.length();
            if r == 0.0 || (normal != Vec3::ZERO && normal.dot(v) >= 0.0) {
                continue;
            }
            fetches += 1;
            let cell = direction_cell(n, v / r);
            if let Some(plane) = TexelPlane::of(field, probe, cell) {
                near_misses.insert(probe, cell, (r - plane.distance).abs() / r);
            }
        }
    }
    // Where no texel faces like the point, a texel that holds it answers, read without the
    // facing test.
    let (probe, cell, facing_normal) = if best != NO_PROBE {
        record.status = HIT;
        (best, best_cell, normal)
    } else if other != NO_PROBE {
        record.status = HIT;
        (other, other_cell, Vec3::ZERO)
    } else {
        (near_misses.probes[0], near_misses.cells[0], Vec3::ZERO)
    };
    record.probes_tried = examined;
    let (mut probe, mut cell) = (probe, cell);
    if record.status != HIT && probe != NO_PROBE {
        // No probe sees the point: the nearest point of its surface that one of the two
        // nearest misses does see (else the first's texel in its direction, an occluder's).
        let mut nearest = f32::INFINITY;
        for (&candidate, &around) in near_misses.probes.iter().zip(&near_misses.cells) {
            if candidate == NO_PROBE {
                continue;
            }
            let v = x - field.position(candidate);
            if let Some((texel, distance)) =
                nearest_surface_texel(field, candidate, around, v, normal, &mut fetches)
                && distance < nearest
            {
                (probe, cell, nearest) = (candidate, texel, distance);
            }
        }
    }
    if probe != NO_PROBE {
        record.radiance = if record.status == HIT {
            surface_radiance(
                field,
                probe,
                x - field.position(probe),
                false,
                true,
                facing_normal,
                cell,
                &mut fetches,
            )
        } else {
            fetches += 1;
            radiance(field, probe, cell)
        };
        record.probe = probe;
        record.normal = normal.to_array();
    }
    record.texel_fetches = fetches;
    record
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The radiance blend's wrap is the layout's border: every border texel of the padded
    /// map reads the interior texel `OctaLayout::pad` copies into it.
    #[test]
    fn wrap_texel_is_the_layouts_border() {
        for n in [8u32, 16, 64] {
            let layout = probe_octa::OctaLayout::new(n).unwrap();
            for py in 0..n + 2 {
                for px in 0..n + 2 {
                    let got = wrap_texel(px as i32 - 1, py as i32 - 1, n);
                    let [sx, sy] = layout.border_source(px, py).unwrap_or([px, py]);
                    assert_eq!(
                        got,
                        UVec2::new(sx - 1, sy - 1),
                        "n={n}, padded ({px}, {py})"
                    );
                }
            }
        }
    }

    /// A step between a light (17) and a ceiling (0.3) across a line of texels, read at
    /// 1,001 points along it for steps at 0.5 to 1.5 texels. The bilinear blend smears the
    /// light a texel into the ceiling at every step position (0.3 texel before a step at 0.8
    /// the blend is 0.7 × 0.3 + 0.3 × 12.0, tone-mapped 0.79 against the ceiling's 0.23).
    /// With the ring (the texel on each side of the two read), every step-edge read farther
    /// than 0.1 texel from the step is exact and the mean error is under half the blend's
    /// (what is left: reads of one partly lit texel and its wholly lit neighbour, no step by
    /// the ratio, which keep the blend); without the ring (the two texels alone, both partly
    /// lit), the read may switch up to a texel off but its mean error stays below the blend's.
    #[test]
    fn step_edge_is_sharp_where_the_blend_smears() {
        let (light, ceiling) = (Vec3::splat(17.0), Vec3::splat(0.3));
        let tone = |v: Vec3| v.x / (1.0 + v.x);
        // Texel i covers [i − ½, i + ½]; the light covers x ≥ `step`.
        for step in [0.5f32, 0.6, 0.8, 1.0, 1.2, 1.3, 1.5] {
            let texel = |i: f32| {
                let alpha = ((i + 0.5) - step).clamp(0.0, 1.0);
                light * alpha + ceiling * (1.0 - alpha)
            };
            let (mut read_error, mut alone_error, mut blend_error) = (0.0f32, 0.0f32, 0.0f32);
            for k in 0..=1000 {
                let x = -0.5 + 2.5 * k as f32 / 1000.0;
                let i = x.floor();
                let f = x - i;
                // As the tracer reads: texels of no weight are left out.
                let pair = [(1.0 - f, texel(i)), (f, texel(i + 1.0))];
                let shown: Vec<(f32, Vec3)> = pair.into_iter().filter(|t| t.0 > 0.0).collect();
                let ring = [texel(i - 1.0), texel(i + 2.0)];
                let truth = if x >= step { light } else { ceiling };
                let blend = (1.0 - f) * pair[0].1 + f * pair[1].1;
                // Where the texels read are no step, the blend is kept.
                let read = step_edge(&shown, &ring).unwrap_or(blend);
                if is_step(&shown) && (x - step).abs() > 0.1 {
                    assert_eq!(read, truth, "step {step}, read at {x}");
                }
                let alone = step_edge(&shown, &[]).unwrap_or(blend);
                read_error += (tone(read) - tone(truth)).powi(2) / 1001.0;
                alone_error += (tone(alone) - tone(truth)).powi(2) / 1001.0;
                blend_error += (tone(blend) - tone(truth)).powi(2) / 1001.0;
            }
            assert!(
                blend_error > 0.05,
                "step {step}: the blend smears ({blend_error})"
            );
            assert!(
                alone_error < blend_error,
                "step {step}: {alone_error} ≥ {blend_error}"
            );
            assert!(
                read_error <= alone_error && read_error < 0.5 * blend_error,
                "step {step}: {read_error} against {alone_error} without the ring and the blend's {blend_error}"
            );
            if (step - 0.5).fract() == 0.0 {
                assert!(alone_error < 1e-4, "step {step} on a border: {alone_error}");
            }
        }
    }

    /// No step, no change: a smooth gradient (ratio under 8), dark noise (tone-mapped
    /// difference under 0.25) and a single texel keep the bilinear read.
    #[test]
    fn step_edge_leaves_gradients_and_dark_noise() {
        let gradient = [(0.5, Vec3::splat(1.0)), (0.5, Vec3::splat(4.0))];
        // A bright ring does not make a step of texels that are none.
        let ring = [Vec3::splat(17.0), Vec3::ZERO];
        assert_eq!(step_edge(&gradient, &ring), None);
        let dark = [(0.5, Vec3::splat(0.001)), (0.5, Vec3::splat(0.05))];
        assert_eq!(step_edge(&dark, &ring), None);
        assert_eq!(step_edge(&[(1.0, Vec3::splat(17.0))], &ring), None);
        assert_eq!(step_edge(&[], &ring), None);
    }

    proptest::proptest! {
        // A fixed seed: the same cases on every run.
        #![proptest_config(proptest::prelude::ProptestConfig {
            cases: 256,
            rng_seed: proptest::test_runner::RngSeed::Fixed(5),
            failure_persistence: None,
            ..proptest::prelude::ProptestConfig::default()
        })]

        /// From inside the box, `bounds_exit` lands on its surface: the point there is in the
        /// box (within rounding) on a face, and a little farther along the ray it is outside.
        /// From outside, moving away, it is at most 0; without bounds, `f32::MAX`.
        #[test]
        fn bounds_exit_lands_on_the_box(
            lo in proptest::array::uniform3(-50.0f32..50.0),
            size in proptest::array::uniform3(0.01f32..40.0),
            at in proptest::array::uniform3(0.0f32..1.0),
            d in proptest::array::uniform3(-1.0f32..1.0),
        ) {
            let (lo, size) = (Vec3::from(lo), Vec3::from(size));
            let hi = lo + size;
            let d = Vec3::from(d);
            proptest::prop_assume!(d.length() > 1e-3);
            let d = d.normalize();
            let mut params = <TraceParams as bytemuck::Zeroable>::zeroed();
            proptest::prop_assert_eq!(bounds_exit(&params, Vec3::ZERO, d), f32::MAX);
            params.bounds_min = [lo.x, lo.y, lo.z, 1.0];
            params.bounds_max = [hi.x, hi.y, hi.z, 0.0];
            let origin = lo + size * Vec3::from(at);
            let t = bounds_exit(&params, origin, d);
            proptest::prop_assert!(t >= 0.0 && t.is_finite(), "t {}", t);
            let p = origin + d * t;
            let eps = 1e-4 * (1.0 + lo.abs().max(hi.abs()).max_element());
            proptest::prop_assert!(p.cmpge(lo - eps).all() && p.cmple(hi + eps).all(), "{:?}", p);
            let on_face = (p - lo).abs().min_element() <= eps || (p - hi).abs().min_element() <= eps;
            proptest::prop_assert!(on_face, "{:?} not on a face of {:?}..{:?}", p, lo, hi);
            let beyond = origin + d * (t + 10.0 * eps + 1e-3);
            proptest::prop_assert!(beyond.cmplt(lo).any() || beyond.cmpgt(hi).any());
            // Leaving: from just outside the face it crossed, moving on, nothing is ahead.
            proptest::prop_assert!(bounds_exit(&params, beyond, d) <= 0.0);
        }

        /// The step-edge read is one of the texels it was given, the brightest or the
        /// darkest of the four and the ring, and only where the four differ by the ratio
        /// and the tone-mapped contrast.
        #[test]
        fn step_edge_reads_an_extreme_texel(
            texels in proptest::collection::vec(
                (0.01f32..1.0, proptest::array::uniform3(0.0f32..40.0)), 0..=4),
            ring in proptest::collection::vec(proptest::array::uniform3(0.0f32..40.0), 0..=12),
        ) {
            let shown: Vec<(f32, Vec3)> =
                texels.iter().map(|&(w, v)| (w, Vec3::from(v))).collect();
            let ring: Vec<Vec3> = ring.into_iter().map(Vec3::from).collect();
            let levels = shown.iter().map(|t| channel_mean(t.1));
            let h = levels.clone().fold(f32::MIN, f32::max);
            let l = levels.fold(f32::MAX, f32::min);
            let step = shown.len() >= 2
                && h > STEP_EDGE_RATIO * l
                && h / (1.0 + h) - l / (1.0 + l) >= STEP_EDGE_CONTRAST;
            let read = step_edge(&shown, &ring);
            proptest::prop_assert_eq!(read.is_some(), step);
            if let Some(value) = read {
                let all: Vec<Vec3> = shown.iter().map(|t| t.1).chain(ring.iter().copied()).collect();
                let top = all.iter().map(|&v| channel_mean(v)).fold(f32::MIN, f32::max);
                let bottom = all.iter().map(|&v| channel_mean(v)).fold(f32::MAX, f32::min);
                let level = channel_mean(value);
                proptest::prop_assert!(level == top || level == bottom);
                proptest::prop_assert!(all.contains(&value));
            }
        }
    }
}
