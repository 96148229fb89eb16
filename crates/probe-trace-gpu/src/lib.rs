//! `probe_trace_gpu`: trace rays through light-field probes on the GPU (wgpu 30, WGSL compute)
//! and on the CPU, with the same algorithms on the same numbers.
//!
//! A light-field probe stores, per octahedral texel, the radial distance, normal and radiance
//! of the first surface its centre sees (seed 003 §4; McGuire et al. 2017). Given many probes,
//! this crate answers ray queries from them: for each ray, *HIT* (where, which normal, what
//! radiance), *MISS* (the ray leaves everything the probes saw, or, given the scene's bounds,
//! leaves those) or *UNKNOWN* (no probe tried could see the whole ray). It also shades points diffusely from low-resolution irradiance
//! probes with Chebyshev visibility (seed 001 §4.3.6–4.3.7).
//!
//! - [`LightField`] / [`IrradianceField`]: the probe data as plain slices (padded octahedral
//!   maps of `probe-octa`'s layout, probes one after another) — no dependency on the baker.
//! - [`ProbeSelection`] / [`Interpolation`]: which probes a ray tries (a regular grid's cage,
//!   the sparse voxel octree or the Voronoi-sphere neighbours of `probe-index`), and how
//!   diffuse shading blends probes (trilinear or Delaunay barycentric).
//! - [`Tracer`]: what both tracers do. [`GpuTracer`] (built once on a [`GpuContext`] or an
//!   engine's own `wgpu::Device`) and [`CpuTracer`] (its twin) `upload` probes and return the
//!   uploaded field as a value you hold ([`GpuField`] / [`CpuField`]), then `trace` ray sets
//!   through it ([`TraceRay`] → [`RayResult`]) with [`TraceOptions`] (hi-Z or two-level,
//!   probe cap, back-face rejection); [`Tracer::look_up`] answers surface points found by an
//!   exact ray cast (the hybrid tracer); `upload_irradiance` / `shade_diffuse` likewise.
//!   Tracing before uploading does not compile. [`AnyTracer`] boxes either, chosen at run time.
//! - For engines: [`GpuTracer::record_trace`] records a trace from rays already in a GPU
//!   buffer into a results buffer, into the caller's `wgpu::CommandEncoder` ([`TraceBuffers`],
//!   [`RayRecord`]); [`TRACE_WGSL`], [`trace_bind_group_layout_entries`] and
//!   [`GpuTracer::bind_trace`] let an engine build its own pipeline around the shader.
//! - [`DeviceFootprint`]: the storage buffers a field takes on the device, byte for byte, and
//!   their check against a device's `max_buffer_size` and `max_storage_buffer_binding_size`.
//!   [`GpuTracer`] runs it before packing or creating any buffer and refuses a field that does
//!   not fit with [`UploadError::DeviceLimit`] (the buffer, its size, the limit and what to
//!   lower); run it before baking to choose probes and resolution for a device.
//!
//! # Example
//!
//! Eight probes in a closed 4 m box room, their maps computed analytically here (a baker such as
//! `probe-capture` fills them from a scene), and one ray traced on the CPU and, when a GPU
//! adapter exists, on the GPU:
//!
//! ```
//! use glam::Vec3;
//! use probe_index::ProbeGrid;
//! use probe_octa::OctaLayout;
//! use probe_trace_gpu::{CpuTracer, FieldOptions, GpuContext, GpuTracer, LightField};
//! use probe_trace_gpu::{ProbeSelection, RayStatus, TraceOptions, TraceRay, Tracer};
//!
//! // The room [-2, 2]³, walls facing in; each wall has its own colour.
//! fn wall(p: Vec3, d: Vec3) -> (f32, Vec3, Vec3) {
//!     let t = (Vec3::splat(2.0) * d.signum() - p) / d;
//!     let axis = if t.x <= t.y && t.x <= t.z { 0 } else if t.y <= t.z { 1 } else { 2 };
//!     let mut normal = Vec3::ZERO;
//!     normal[axis] = -d[axis].signum();
//!     (t[axis], normal, normal.abs() * 0.5 + Vec3::splat(0.25))
//! }
//!
//! let grid = ProbeGrid::new(Vec3::splat(-0.5), Vec3::ONE, [2, 2, 2])?;
//! let positions = grid.positions();
//! let n = 32;
//! let layout = OctaLayout::new(n)?;
//! let (mut distance, mut normals, mut radiance) = (Vec::new(), Vec::new(), Vec::new());
//! for &p in &positions {
//!     let mut maps = (vec![0.0; layout.padded_len()], vec![Vec3::ZERO; layout.padded_len()],
//!                     vec![Vec3::ZERO; layout.padded_len()]);
//!     for iy in 0..n {
//!         for ix in 0..n {
//!             let (t, normal, colour) = wall(p, layout.texel_direction(ix, iy));
//!             let i = layout.interior_index(ix, iy);
//!             (maps.0[i], maps.1[i], maps.2[i]) = (t, normal, colour);
//!         }
//!     }
//!     distance.extend(maps.0);
//!     normals.extend(maps.1);
//!     radiance.extend(maps.2);
//! }
//! let field = LightField {
//!     resolution: n,
//!     positions: &positions,
//!     radial_distance: &distance,
//!     normals: &normals,
//!     radiance: &radiance,
//!     distance_range: None,
//!     sky_distance: 1000.0,
//!     geometry_bounds: None,
//! };
//!
//! // A ray from inside the room towards the +x wall.
//! let rays = [TraceRay::new(Vec3::new(0.3, 0.2, -0.1), Vec3::new(1.0, 0.3, 0.2))];
//! let mut cpu = CpuTracer::new();
//! // The uploaded field is a value: tracing needs one, so it cannot come before the upload.
//! let on_cpu = cpu.upload(&field, &ProbeSelection::Grid(grid), &FieldOptions::default())?;
//! let hit = cpu.trace(&on_cpu, &rays, &TraceOptions::default())?.results[0];
//! assert_eq!(hit.status, RayStatus::Hit);
//! assert!((hit.position.x - 2.0).abs() < 0.02, "{}", hit.position);
//! assert_eq!(hit.radiance, Vec3::new(0.75, 0.25, 0.25));
//!
//! // The same on the GPU, when one (or Mesa's lavapipe) is available.
//! if let Ok(context) = GpuContext::new() {
//!     let mut gpu = GpuTracer::new(&context)?;
//!     let on_gpu = gpu.upload(&field, &ProbeSelection::Grid(grid), &FieldOptions::default())?;
//!     let gpu_hit = gpu.trace(&on_gpu, &rays, &TraceOptions::default())?.results[0];
//!     assert_eq!(gpu_hit.status, RayStatus::Hit);
//!     assert!((gpu_hit.position - hit.position).length() < 1e-4);
//! }
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! # The algorithms
//!
//! **One probe** (seed 003 Alg. 3, McGuire 2017). The ray, seen from the probe, is split at
//! the probe's x, y, z = 0 planes into ≤ 4 pieces, each a straight segment in octahedral space
//! (`probe-octa`'s `split_ray`); a point σ along a segment maps back to the ray parameter
//! perspective-correctly (the L1 norm is the homogeneous weight). Each segment is walked cell
//! by cell with an integer full-resolution cursor (a DDA that never re-derives a cell from a
//! float position along the axis it crosses). A full-resolution texel is decided by the
//! **fine test** against its surface model: the plane through the stored point with the stored
//! normal, with depth bounds `near`/`far` over the texel's cone and a thickness
//! `thickness_scale · D · β / cos γ` (seed 003 §7.1's dynamic epsilon, here in the probe's
//! terms: distance `D`, texel angular radius `β`, incidence `γ`). A ray wholly nearer than
//! `near` passes in front; entering beyond `far` or behind the plane by more than the thickness
//! it is hidden (UNKNOWN at the texel's entry); moving out of the thickness layer it passes (a
//! ray leaving the surface it starts on); crossing into the plane it hits, at the plane
//! crossing — except where it starts behind the plane (a ray leaving a face next to a convex
//! edge), which is no hit. Hits on surfaces facing away from the ray are rejected (seed 003
//! §7.2: UNKNOWN, so another probe continues). Texels at an occluding edge (a neighbour's
//! surface stacked behind theirs, or sky beside them) or seen more obliquely than 76° never
//! report hits, only "in front" or UNKNOWN: beyond the edge their cone shows something else
//! ([`FieldOptions::conservative_edges`] is a stricter policy with fewer wrong answers and more
//! UNKNOWN).
//!
//! **Hi-Z** (seed 000 §4.3, after Uludag 2014) walks a min/max pyramid of those `near`/`far`
//! bounds, going up a level when the ray passes a cell in front of its minimum and enters a new
//! parent, down where it may reach a surface; a ray entering a cell beyond its maximum is
//! UNKNOWN at once. The top level is [`TraceOptions::hiz_top_level`] (default 6, seed 000's
//! limit). **Two-level** (McGuire 2017) is a DDA over the minimum of one coarse level
//! ([`TraceOptions::coarse_downsample`], default 16) with a fine march inside the coarse cells
//! the ray may reach a surface in. Because the pyramids bound the fine test exactly, both
//! methods give the same answers; they differ in texel fetches and time.
//!
//! **Many probes** (seed 003 Alg. 5, seed 000 Alg. 4–5). A ray asks the selection for
//! candidates at its origin and tries them in order; when one answers UNKNOWN at parameter `t`
//! beyond where it started, the ray asks again at `t` with that probe as the failed one and
//! continues from `t` (no part of the ray is traced twice by successive probes); when it
//! answers UNKNOWN without progress, the next candidate tries from the same point. Grids give
//! the 8-cage in seed 003 Alg. 6 order (first the probe behind the point along the ray, then
//! `(i + 3) mod 8`), the octree the best 4 probes of the leaf holding the point, Voronoi the
//! nearest probe and then the failed probe's neighbours towards the point. When those have all
//! failed at a point, the probes nearest to it follow (the nearest probe's row of a table of
//! each probe's 16 nearest, [`TraceOptions::nearest_candidates`]): a selection offers probes by
//! where they are, and at a failure point the probes that can see past it are often just
//! beyond the cage. A candidate is tried only if its depth map can show the point the ray
//! restarts from (one fetch: the point in front of its texel's plane, within the plane's
//! thickness for the selection's own candidates, strictly for the nearest ones); others are
//! skipped without counting. At most [`TraceOptions::max_probes`] probes are tried (16 by
//! default, chosen by measurement). If all fail, the ray is UNKNOWN with an **estimate**: the
//! first candidate for the last decided point that sees it marches the rest of the ray with
//! relaxed rules, taking the first place where the ray goes behind or crosses what it saw (at
//! edges and back faces too) as the hit, and its radiance there (seed 003 §5.4's environment
//! map fallback, made local: the probe's texel in the ray's direction only if it sees the ray
//! leave). For a mirror ray (no cone) whose guess is where the ray went out of the probe's
//! sight, the same probe marches on past what it does not see to where the ray next crosses
//! a stored surface or leaves the scene's bounds (the far guess), and the radiance is the mean
//! of both guesses' (a guess past the bounds reads the sky): the true end lies between them.
//!
//! **Distance ranges.** A bake may give, per texel, the nearest and farthest distance its rays
//! across the texel found ([`LightField::distance_range`]). A texel whose cone holds geometry
//! nearer than its centre's plane allows (a chain, a leaf, an edge inside the texel) is then a
//! nearer edge: a ray meeting it there is handed on, not passed in front of geometry the
//! centre ray missed. One holding farther geometry cannot place a hit. This trades wrong
//! answers for UNKNOWN ones: measured on Sponza, 1.1 points fewer wrong answers for 1.5 more
//! UNKNOWN; on the Breakfast room it cost 3.6 points of right answers (BENCHMARKS.md), so
//! probe-eval traces without them and a renderer that prefers no answer to a wrong one
//! passes them.
//!
//! **The hybrid** ([`Tracer::look_up`]). A renderer that can cast rays against its geometry
//! exactly (a BVH, hardware ray queries) needs only the radiance at the hit: for each
//! [`SurfaceQuery`], the selection's candidates for the point (then the nearest probes) are
//! asked whether their texel towards the point shows it (the point on the texel's plane, the
//! probe on its lit side, the texel's surface facing like the query's normal: in a crease the
//! point lies within the thickness of both walls' texels), and the best by view cosine over
//! distance answers with the blend of its texels around the point that show it. An escaped
//! ray takes the sky from a candidate that sees sky in its direction. No march: about 12
//! fetches a query.
//!
//! **Diffuse** (seed 001, DDGI): trilinear grid or Delaunay barycentric weights (outside the
//! probes' convex hull, those of the nearest hull point, so the blend stays continuous there)
//! times, optionally, DDGI's smooth backface term and the Chebyshev weight of the probe's
//! distance moments seen from the shading point (moved along its normal by `normal_bias`)
//! raised to `visibility_exponent` and floored at `min_weight`, normalised; irradiance maps
//! are sampled bilinearly through their padding. See [`DiffuseOptions`].
//!
//! # What a texel fetch is
//!
//! One read of one stored texel of a per-probe map: a full-resolution geometry texel (distance,
//! normal and bounds are one 16-byte record), a pyramid texel (its min and max are one 8-byte
//! record), or a radiance texel (one per answered ray: the hit's, the sky's or the fallback's).
//! Selection structures (cage arithmetic, octree nodes, k-d tree, neighbour maps) are not
//! counted. Both tracers count the same, so [`RayResult::texel_fetches`] agree exactly.
//!
//! # On the device
//!
//! Storage buffers, read by the WGSL and the CPU twin alike: probe positions (16 B each);
//! geometry per padded texel, 16 B (distance with an edge flag, octahedral snorm16 normal,
//! `near`, `far` with an edge flag); radiance per padded texel, 12 B; the pyramid levels 1…,
//! 8 B per texel (about a third of the texel count), level-major with an offset table; the
//! selection's words. A 256² probe takes about 2.1 MB. The convenience calls'
//! ([`Tracer::trace`] on a slice) ray and result buffers are sized for the largest call so far
//! (at most 2²⁰ rays per dispatch; larger calls are split) and reused.
//! GPU time comes from timestamp queries when the device supports them ([`Timing::gpu`]).
//! On lavapipe a pipeline is compiled on its first dispatch (0.06–0.12 s measured here); time
//! later calls.
//!
//! # For a renderer (the `probes render` CLI)
//!
//! Build a [`GpuContext`] (a clear [`GpuError`] if no adapter exists), a [`GpuTracer`] (or
//! [`AnyTracer::gpu_or_cpu`], which falls back to the CPU twin), upload the bake's maps with
//! the index's selection, make one [`TraceRay`] per pixel (camera rays for primary
//! visibility, or reflection rays from a G-buffer for the glossy component), call
//! [`Tracer::trace`] and write [`RayResult::radiance`]; [`TraceSummary::of`] gives the hit
//! rate, fetches and probes per ray, and [`TraceOutput::timing`] the time. For the diffuse
//! component, upload an [`IrradianceField`] and call [`Tracer::shade_diffuse`] on the
//! G-buffer's points and normals.
//!
//! # For an engine (rays and results stay on the GPU)
//!
//! Make the tracer on the engine's device ([`GpuTracer::from_device`]) and upload once. Each
//! frame, a pass of the engine writes [`TraceRay`]s (unit directions) into a `STORAGE` buffer;
//! [`GpuTracer::record_trace`] (or a [`TraceBinding`] made once by [`GpuTracer::bind_trace`]
//! and recorded every frame) records the trace into the engine's command encoder, writing one
//! [`RayRecord`] per ray into a second `STORAGE` buffer that the engine's next pass reads
//! (its WGSL mirror is on [`RayRecord`]). Nothing blocks or reads back. Buffer sizes and
//! usages are checked when binding ([`TraceError::BadBuffer`]). The same holds for diffuse
//! shading ([`GpuTracer::record_diffuse`], [`DiffuseBuffers`]). To build a pipeline of your
//! own instead (say, the shader inside a larger module), take [`TRACE_WGSL`],
//! [`TRACE_ENTRY_POINT`] and [`trace_bind_group_layout_entries`] (which binding holds what),
//! and bind [`TraceBinding::bind_group`] at group 0, dispatching
//! [`TraceBinding::workgroups`]. The example `engine_frames` renders several frames this
//! way, with rays made and results consumed by compute passes of its own; a test runs it.
//!
//! # Design choices
//!
//! - **One set of numbers.** Both tracers read the same packed arrays (`PackedField`), written
//!   once at upload; the CPU twin is the WGSL transcribed line by line, so tests can demand
//!   agreement ray by ray rather than statistically.
//! - **Planes, not spheres.** McGuire's test compares the ray's radial distance with the stored
//!   one; a per-texel plane with the stored normal places hits exactly on flat surfaces, lets a
//!   ray leave the surface it starts on without a self-hit, and makes the thickness a distance
//!   from the surface rather than along the probe's view.
//! - **Conservative pyramids of the fine test's own bounds**, built at upload from the distance
//!   and normal maps (so the baker need not know the tracer's surface model), make hi-Z and
//!   two-level exact twins and let hi-Z stop early on a hidden ray.
//! - **Undecided is an answer.** Edge texels hand the ray on instead of guessing; a ray no probe
//!   can finish is UNKNOWN with an estimate (position, normal and radiance of the relaxed
//!   march's guess), never a silent wrong hit: callers see which answers are guesses.

mod cpu;
mod error;
mod footprint;
mod gpu;
mod input;
mod packed;
mod pyramid;
mod ray;
mod surface;
mod tracer;

pub use cpu::{
    CpuField, CpuIrradiance, CpuTracer, DiffuseOutput, FetchKind, FetchPhase, FetchProfile,
    PHASE_WINDOW_TEXELS, PROFILE_LEVELS, TraceOutput,
};
pub use error::{DiffuseOptionsError, GpuError, TraceError, UploadError};
pub use footprint::{DeviceBuffer, DeviceFootprint};
pub use gpu::{
    DIFFUSE_ENTRY_POINT, DIFFUSE_WGSL, DiffuseBinding, DiffuseBuffers, GpuContext, GpuField,
    GpuIrradiance, GpuTracer, TRACE_ENTRY_POINT, TRACE_WGSL, TraceBinding, TraceBuffers,
    WORKGROUP_SIZE, diffuse_bind_group_layout_entries, trace_bind_group_layout_entries,
};
pub use input::{FieldOptions, Interpolation, IrradianceField, LightField, ProbeSelection};
pub use packed::{GLOSSY_WIDE_TAN, MAX_CONE_ANGLE};
pub use ray::{
    DiffuseOptions, DiffuseResult, RayRecord, RayResult, RayStatus, ShadingPoint, SurfaceQuery,
    Timing, TraceMethod, TraceOptions, TraceRay, TraceSummary,
};
pub use tracer::{AnyField, AnyIrradiance, AnyTracer, Tracer};
