//! The wgpu tracer: a device, two compute pipelines (trace and diffuse shading) built once;
//! uploaded fields as values holding their storage buffers; a recording path that binds the
//! caller's buffers and records into the caller's command encoder; and the convenience calls
//! (upload rays, dispatch, read back) built on it.

use std::borrow::Cow;
use std::num::NonZeroU64;
use std::time::{Duration, Instant};

use bytemuck::{Pod, Zeroable};
use wgpu::util::DeviceExt;

use crate::cpu::{DiffuseOutput, TraceOutput};
use crate::error::{GpuError, TraceError, UploadError};
use crate::footprint::DeviceFootprint;
use crate::input::{FieldOptions, Interpolation, IrradianceField, LightField, ProbeSelection};
use crate::packed::{
    MAX_RESOLUTION, MIN_RESOLUTION, PackedField, PackedIrradiance, PackedSelection, diffuse_params,
    prepare_points, prepare_rays, trace_params,
};
use crate::ray::{
    DiffuseOptions, DiffuseResult, RayRecord, RayResult, ShadingPoint, SurfaceQuery, Timing,
    TraceOptions, TraceRay,
};
use crate::tracer::Tracer;

/// The trace shader's WGSL source (`common.wgsl` followed by `trace.wgsl`), for engines that
/// build their own pipeline: entry point [`TRACE_ENTRY_POINT`], workgroups of
/// [`WORKGROUP_SIZE`] threads, one bind group (group 0) laid out as
/// [`trace_bind_group_layout_entries`] says. [`GpuTracer::bind_trace`] makes a bind group for
/// that layout from an uploaded field and the caller's ray and result buffers.
pub const TRACE_WGSL: &str = concat!(include_str!("common.wgsl"), include_str!("trace.wgsl"));
/// The diffuse shader's WGSL source (`common.wgsl` followed by `diffuse.wgsl`): entry point
/// [`DIFFUSE_ENTRY_POINT`], layout [`diffuse_bind_group_layout_entries`].
pub const DIFFUSE_WGSL: &str = concat!(include_str!("common.wgsl"), include_str!("diffuse.wgsl"));
/// The trace shader's entry point.
pub const TRACE_ENTRY_POINT: &str = "trace_main";
/// The trace shader's second entry point: the hybrid tracer's radiance look-up of surface
/// points ([`Tracer::look_up`]), with the same bind group layout, binding 1 holding
/// [`SurfaceQuery`]s instead of rays.
pub const LOOK_UP_ENTRY_POINT: &str = "look_up_main";
/// The diffuse shader's entry point.
pub const DIFFUSE_ENTRY_POINT: &str = "diffuse_main";
/// Threads per workgroup in both shaders (`@workgroup_size(64)`): one ray or point each.
pub const WORKGROUP_SIZE: u32 = 64;

/// Most rays (or points) per dispatch of the convenience calls; larger calls are split.
const MAX_CHUNK: usize = 1 << 20;

/// The trace shader's bind group 0, binding by binding:
///
/// | binding | type | holds |
/// |---|---|---|
/// | 0 | uniform | the trace parameters (`TraceParams` in the WGSL, 352 B): options, selection header, ray count and threads per dispatch row; written by [`GpuTracer::bind_trace`] |
/// | 1 | storage, read | the rays, [`TraceRay`] (32 B each) |
/// | 2 | storage, read-write | the results, [`RayRecord`] (64 B each), one per ray in order |
/// | 3 | storage, read | probe centres, `vec4<f32>` per probe |
/// | 4 | storage, read | geometry per padded texel, `vec4<u32>`: distance bits (sign bit: farther edge), octahedral snorm16 normal, `near` bits, `far` bits (sign bit: nearer edge) |
/// | 5 | storage, read | the min/max pyramids, levels 1…, `vec4<u32>` per texel |
/// | 6 | storage, read | radiance, 3 × f32 per padded texel |
/// | 7 | storage, read | the selection's words (octree nodes and leaves, or k-d tree and neighbour table) |
///
/// Bindings 0 and 3–7 come from the tracer ([`GpuTracer::bind_trace`]); 1 and 2 are the
/// caller's ([`TraceBuffers`]). All are visible to the compute stage only.
pub fn trace_bind_group_layout_entries() -> [wgpu::BindGroupLayoutEntry; 8] {
    [
        uniform_entry(0),
        storage_entry(1, true),
        storage_entry(2, false),
        storage_entry(3, true),
        storage_entry(4, true),
        storage_entry(5, true),
        storage_entry(6, true),
        storage_entry(7, true),
    ]
}

/// The diffuse shader's bind group 0, binding by binding:
///
/// | binding | type | holds |
/// |---|---|---|
/// | 0 | uniform | the diffuse parameters (`DiffuseParams` in the WGSL, 128 B); written by [`GpuTracer::bind_diffuse`] |
/// | 1 | storage, read | the shading points, [`ShadingPoint`] (32 B each) |
/// | 2 | storage, read-write | the results, `vec4<f32>` per point: irradiance RGB, then the weight sum ([`DiffuseResult`]) |
/// | 3 | storage, read | probe centres, `vec4<f32>` per probe |
/// | 4 | storage, read | irradiance, 3 × f32 per padded texel |
/// | 5 | storage, read | distance moments, `vec2<f32>` per padded texel |
/// | 6 | storage, read | the interpolation's words (grid cage or tetrahedra and k-d tree) |
/// | 7 | storage, read | surfels, 5 × `vec4<f32>` each (one zero `vec4` when none were uploaded) |
pub fn diffuse_bind_group_layout_entries() -> [wgpu::BindGroupLayoutEntry; 8] {
    [
        uniform_entry(0),
        storage_entry(1, true),
        storage_entry(2, false),
        storage_entry(3, true),
        storage_entry(4, true),
        storage_entry(5, true),
        storage_entry(6, true),
        storage_entry(7, true),
    ]
}

/// A wgpu device and queue for the tracer, found by [`GpuContext::new`].
#[derive(Clone, Debug)]
pub struct GpuContext {
    device: wgpu::Device,
    queue: wgpu::Queue,
    info: wgpu::AdapterInfo,
}

impl GpuContext {
    /// Finds an adapter and opens a device on it. The adapter can be steered with wgpu's
    /// environment variables (`WGPU_BACKEND`, `WGPU_POWER_PREF`, `WGPU_ADAPTER_NAME`). The
    /// device gets the adapter's storage-buffer size limits and, where available, timestamp
    /// queries (for [`Timing::gpu`]).
    ///
    /// # Errors
    /// [`GpuError::NoAdapter`] when no adapter exists (install a Vulkan driver, e.g. Mesa's
    /// lavapipe); [`GpuError::Device`] or [`GpuError::Unsupported`] when it cannot serve.
    pub fn new() -> Result<Self, GpuError> {
        pollster::block_on(Self::new_async())
    }

    /// [`Self::new`] as a future.
    ///
    /// # Errors
    /// As [`Self::new`].
    pub async fn new_async() -> Result<Self, GpuError> {
        let instance =
            wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        let adapter = match std::env::var("WGPU_ADAPTER_NAME") {
            Ok(name) => {
                let wanted = name.to_lowercase();
                let mut found = None;
                for adapter in instance.enumerate_adapters(wgpu::Backends::all()).await {
                    if adapter.get_info().name.to_lowercase().contains(&wanted) {
                        found = Some(adapter);
                        break;
                    }
                }
                found.ok_or(GpuError::Unsupported {
                    adapter: name,
                    reason: "no adapter has this name (WGPU_ADAPTER_NAME)".to_owned(),
                })?
            }
            Err(_) => instance
                .request_adapter(&wgpu::RequestAdapterOptions {
                    power_preference: wgpu::PowerPreference::from_env().unwrap_or_default(),
                    ..Default::default()
                })
                .await
                .map_err(|source| GpuError::NoAdapter { source })?,
        };
        let info = adapter.get_info();
        let available = adapter.limits();
        let mut limits = wgpu::Limits::default();
        if !limits.check_limits(&available) {
            return Err(GpuError::Unsupported {
                adapter: info.name.clone(),
                reason: "it does not reach WebGPU's default limits".to_owned(),
            });
        }
        limits.max_storage_buffer_binding_size = available.max_storage_buffer_binding_size;
        limits.max_buffer_size = available.max_buffer_size;
        let features = adapter.features() & wgpu::Features::TIMESTAMP_QUERY;
        let (device, queue) = adapter
            .request_device(&wgpu::DeviceDescriptor {
                label: Some("probe-trace-gpu"),
                required_features: features,
                required_limits: limits,
                ..Default::default()
            })
            .await
            .map_err(|source| GpuError::Device {
                adapter: info.name.clone(),
                source,
            })?;
        Ok(Self {
            device,
            queue,
            info,
        })
    }

    /// The device.
    pub fn device(&self) -> &wgpu::Device {
        &self.device
    }

    /// The queue.
    pub fn queue(&self) -> &wgpu::Queue {
        &self.queue
    }

    /// The adapter's name, backend and driver.
    pub fn adapter_info(&self) -> &wgpu::AdapterInfo {
        &self.info
    }

    /// A warning when wgpu fell back to its OpenGL backend: it does when no Vulkan (or
    /// Metal, DX12) driver is installed, and on a machine without a GPU that means Mesa's
    /// llvmpipe through GL, which traces the same answers but not at the speed of lavapipe
    /// or a GPU, so timings taken there are not the figures they look like. `None` on every
    /// other backend.
    pub fn backend_note(&self) -> Option<String> {
        backend_note(&self.info)
    }
}

/// [`GpuContext::backend_note`] of an adapter.
fn backend_note(info: &wgpu::AdapterInfo) -> Option<String> {
    (info.backend == wgpu::Backend::Gl).then(|| {
        "wgpu fell back to OpenGL: no Vulkan driver was found (install one, e.g. Debian's \
         mesa-vulkan-drivers for lavapipe, or set WGPU_BACKEND to choose)"
            .to_owned()
    })
}

/// Timestamp queries around each compute pass.
struct Timestamps {
    set: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    readback: wgpu::Buffer,
    period_ns: f32,
}

/// One compute pipeline and its bind-group layout.
struct Pass {
    layout: wgpu::BindGroupLayout,
    pipeline: wgpu::ComputePipeline,
}

/// Per-call buffers of a convenience call: input items, output items, read-back copy.
struct Io {
    capacity: usize,
    input: wgpu::Buffer,
    output: wgpu::Buffer,
    readback: wgpu::Buffer,
}

/// A light field and its probe selection on the device: storage buffers and the parameters
/// the trace shader needs, made by [`GpuTracer`]'s [`Tracer::upload`]. Hold it as long as you
/// trace through it; dropping it frees the buffers (once no submitted work uses them).
pub struct GpuField {
    tracer: u64,
    meta: PackedField,
    selection: PackedSelection,
    positions: wgpu::Buffer,
    geometry: wgpu::Buffer,
    pyramid: wgpu::Buffer,
    radiance: wgpu::Buffer,
    words: wgpu::Buffer,
}

impl std::fmt::Debug for GpuField {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GpuField")
            .field("probe_count", &self.meta.probe_count)
            .field("resolution", &self.meta.resolution)
            .field("bytes", &self.bytes())
            .finish_non_exhaustive()
    }
}

impl GpuField {
    /// Probes in the field.
    pub fn probe_count(&self) -> u32 {
        self.meta.probe_count
    }

    /// Interior texels per side of each probe's maps.
    pub fn resolution(&self) -> u32 {
        self.meta.resolution
    }

    /// Bytes of device memory the field's buffers take.
    pub fn bytes(&self) -> u64 {
        [
            &self.positions,
            &self.geometry,
            &self.pyramid,
            &self.radiance,
            &self.words,
        ]
        .iter()
        .map(|b| b.size())
        .sum()
    }
}

/// Irradiance probes on the device, made by [`GpuTracer`]'s [`Tracer::upload_irradiance`].
pub struct GpuIrradiance {
    tracer: u64,
    meta: PackedIrradiance,
    positions: wgpu::Buffer,
    irradiance: wgpu::Buffer,
    moments: wgpu::Buffer,
    words: wgpu::Buffer,
    surfels: wgpu::Buffer,
}

impl std::fmt::Debug for GpuIrradiance {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GpuIrradiance")
            .field("probe_count", &self.meta.probe_count)
            .finish_non_exhaustive()
    }
}

impl GpuIrradiance {
    /// Probes in the field.
    pub fn probe_count(&self) -> u32 {
        self.meta.probe_count
    }
}

/// The caller's buffers for recording a trace on the device ([`GpuTracer::bind_trace`],
/// [`GpuTracer::record_trace`]).
///
/// - `rays`: `count` [`TraceRay`]s (32 bytes each, tightly packed from offset 0), usage
///   [`wgpu::BufferUsages::STORAGE`] (plus whatever fills it: `COPY_DST` for uploads, nothing
///   more when a compute pass of yours writes it). Directions must be unit length and ranges
///   `0 <= t_min <= t_max` with `t_min` finite: the device cannot check what is in a buffer,
///   and does not normalise (the convenience [`Tracer::trace`] checks and normalises on the
///   CPU before it uploads).
/// - `results`: room for `count` [`RayRecord`]s (64 bytes each), usage `STORAGE` (plus
///   `COPY_SRC` to read them back, if you do). Ray `i`'s record is written at index `i`.
/// - `count`: rays to trace, from the start of both buffers.
#[derive(Clone, Copy, Debug)]
pub struct TraceBuffers<'a> {
    /// The rays.
    pub rays: &'a wgpu::Buffer,
    /// Where the results go.
    pub results: &'a wgpu::Buffer,
    /// How many rays.
    pub count: u32,
}

/// The caller's buffers for recording diffuse shading ([`GpuTracer::bind_diffuse`],
/// [`GpuTracer::record_diffuse`]).
///
/// - `points`: `count` [`ShadingPoint`]s (32 bytes each), usage `STORAGE`; normals must be
///   unit length and everything finite (not checked on the device).
/// - `results`: room for `count` `vec4<f32>` (16 bytes each: irradiance RGB, then the weight
///   sum, as in [`DiffuseResult`]), usage `STORAGE`.
/// - `count`: points to shade, from the start of both buffers.
#[derive(Clone, Copy, Debug)]
pub struct DiffuseBuffers<'a> {
    /// The shading points.
    pub points: &'a wgpu::Buffer,
    /// Where the results go.
    pub results: &'a wgpu::Buffer,
    /// How many points.
    pub count: u32,
}

/// A bound dispatch: pipeline, bind group and workgroup grid.
#[derive(Clone, Debug)]
struct Bound {
    pipeline: wgpu::ComputePipeline,
    bind_group: wgpu::BindGroup,
    workgroups: [u32; 3],
    count: u32,
}

impl Bound {
    fn record_in_pass(&self, pass: &mut wgpu::ComputePass<'_>) {
        if self.count == 0 {
            return;
        }
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.bind_group, &[]);
        let [x, y, z] = self.workgroups;
        pass.dispatch_workgroups(x, y, z);
    }

    fn record(&self, encoder: &mut wgpu::CommandEncoder, label: &str) {
        if self.count == 0 {
            return;
        }
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(label),
            timestamp_writes: None,
        });
        self.record_in_pass(&mut pass);
    }
}

/// One trace, bound and ready to record: the tracer's pipeline, a bind group over the field
/// and the caller's [`TraceBuffers`] with its own parameter block, and the workgroup grid.
/// Made by [`GpuTracer::bind_trace`]; record it every frame the buffers' contents change
/// (nothing is allocated per record), and bind again only when the field, the buffers, the
/// count or the options do.
#[derive(Clone, Debug)]
pub struct TraceBinding {
    bound: Bound,
}

/// One diffuse shading pass, bound and ready to record ([`GpuTracer::bind_diffuse`]).
#[derive(Clone, Debug)]
pub struct DiffuseBinding {
    bound: Bound,
}

macro_rules! binding_methods {
    ($name:ident, $label:literal) => {
        impl $name {
            /// Records the dispatch into `encoder` in a compute pass of its own. Nothing is
            /// submitted, waited for or read back; passes recorded after it in the same
            /// encoder (or later submissions) see its results. Records nothing for a count
            /// of 0.
            pub fn record(&self, encoder: &mut wgpu::CommandEncoder) {
                self.bound.record(encoder, $label);
            }

            /// Records the dispatch into a compute pass the caller has begun (it sets the
            /// pipeline and bind group 0, which the caller's next dispatch must set again).
            pub fn record_in_pass(&self, pass: &mut wgpu::ComputePass<'_>) {
                self.bound.record_in_pass(pass);
            }

            /// The bind group (group 0 of the layout), for a pipeline of the caller's own
            /// built from the same WGSL and layout.
            pub fn bind_group(&self) -> &wgpu::BindGroup {
                &self.bound.bind_group
            }

            /// The workgroup grid `[x, y, 1]` the parameter block was written for: dispatch
            /// exactly this with a pipeline of your own.
            pub fn workgroups(&self) -> [u32; 3] {
                self.bound.workgroups
            }

            /// Items (rays or points) bound.
            pub fn count(&self) -> u32 {
                self.bound.count
            }
        }
    };
}
binding_methods!(TraceBinding, "probe trace");
binding_methods!(DiffuseBinding, "probe diffuse");

/// The GPU tracer: build it once from a device, [`Tracer::upload`] probes (getting a
/// [`GpuField`]), then trace ray sets through it: [`Tracer::trace`] from a slice (upload,
/// dispatch, read back), or [`Self::record_trace`] from rays already on the device into the
/// caller's command encoder. Pipelines are created once; the convenience calls' buffers are
/// reused and grow only when a call needs more.
pub struct GpuTracer {
    /// Tags the fields this tracer uploads (wgpu's device equality compares ids, which
    /// devices of different instances can share).
    id: u64,
    device: wgpu::Device,
    queue: wgpu::Queue,
    limits: wgpu::Limits,
    adapter: Option<String>,
    timestamps: Option<Timestamps>,
    trace_pass: Pass,
    look_up_pass: Pass,
    diffuse_pass: Pass,
    trace_io: Option<Io>,
    diffuse_io: Option<Io>,
}

impl std::fmt::Debug for GpuTracer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GpuTracer")
            .field("adapter", &self.adapter)
            .field("timestamps", &self.timestamps.is_some())
            .finish_non_exhaustive()
    }
}

fn storage_entry(binding: u32, read_only: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

fn uniform_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

/// Builds a pipeline over the bind-group layout `entries`.
fn make_pass(
    device: &wgpu::Device,
    label: &str,
    source: &str,
    entry: &str,
    entries: &[wgpu::BindGroupLayoutEntry],
) -> Pass {
    let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some(label),
        entries,
    });
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(label),
        bind_group_layouts: &[Some(&layout)],
        immediate_size: 0,
    });
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(label),
        source: wgpu::ShaderSource::Wgsl(Cow::Borrowed(source)),
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(label),
        layout: Some(&pipeline_layout),
        module: &module,
        entry_point: Some(entry),
        compilation_options: wgpu::PipelineCompilationOptions::default(),
        cache: None,
    });
    Pass { layout, pipeline }
}

/// A caller's input or output buffer checked for `count` items of `stride` bytes: bound from
/// offset 0 over exactly those items (at least one).
fn checked_binding<'a>(
    name: &'static str,
    buffer: &'a wgpu::Buffer,
    count: u32,
    stride: u64,
) -> Result<wgpu::BufferBinding<'a>, TraceError> {
    if !buffer.usage().contains(wgpu::BufferUsages::STORAGE) {
        return Err(TraceError::BadBuffer {
            buffer: name,
            reason: format!(
                "its usage is {:?}; it needs wgpu::BufferUsages::STORAGE",
                buffer.usage()
            ),
        });
    }
    let needed = u64::from(count.max(1)) * stride;
    if buffer.size() < needed {
        return Err(TraceError::BadBuffer {
            buffer: name,
            reason: format!(
                "it holds {} bytes; {} items of {stride} bytes need {needed} (at least one item)",
                buffer.size(),
                count.max(1)
            ),
        });
    }
    Ok(wgpu::BufferBinding {
        buffer,
        offset: 0,
        size: NonZeroU64::new(needed),
    })
}

impl GpuTracer {
    /// A tracer on the context's device.
    ///
    /// # Errors
    /// [`GpuError::Unsupported`] if the device cannot build the pipelines.
    pub fn new(context: &GpuContext) -> Result<Self, GpuError> {
        let mut tracer = Self::from_device(context.device.clone(), context.queue.clone())?;
        tracer.adapter = Some(format!(
            "{} ({:?}){}",
            context.info.name,
            context.info.backend,
            context
                .backend_note()
                .map_or(String::new(), |n| format!(" — {n}"))
        ));
        Ok(tracer)
    }

    /// A tracer on an existing device (for engines that own theirs). Timestamp queries are
    /// used if the device was created with [`wgpu::Features::TIMESTAMP_QUERY`].
    ///
    /// # Errors
    /// [`GpuError::Unsupported`] if the device has fewer than 7 storage buffers per stage or
    /// cannot build the pipelines.
    pub fn from_device(device: wgpu::Device, queue: wgpu::Queue) -> Result<Self, GpuError> {
        let limits = device.limits();
        let unsupported = |reason: String| GpuError::Unsupported {
            adapter: "the given device".to_owned(),
            reason,
        };
        if limits.max_storage_buffers_per_shader_stage < 7 {
            return Err(unsupported(format!(
                "it allows {} storage buffers per shader stage; the tracer needs 7",
                limits.max_storage_buffers_per_shader_stage
            )));
        }
        if limits.max_compute_invocations_per_workgroup < WORKGROUP_SIZE {
            return Err(unsupported(
                "it cannot run 64-thread compute workgroups".to_owned(),
            ));
        }
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let trace_pass = make_pass(
            &device,
            "probe trace",
            TRACE_WGSL,
            TRACE_ENTRY_POINT,
            &trace_bind_group_layout_entries(),
        );
        let look_up_pass = make_pass(
            &device,
            "probe look-up",
            TRACE_WGSL,
            LOOK_UP_ENTRY_POINT,
            &trace_bind_group_layout_entries(),
        );
        let diffuse_pass = make_pass(
            &device,
            "probe diffuse",
            DIFFUSE_WGSL,
            DIFFUSE_ENTRY_POINT,
            &diffuse_bind_group_layout_entries(),
        );
        if let Some(error) = pollster::block_on(scope.pop()) {
            return Err(unsupported(format!("the shaders failed to build: {error}")));
        }
        let timestamps = device
            .features()
            .contains(wgpu::Features::TIMESTAMP_QUERY)
            .then(|| Timestamps {
                set: device.create_query_set(&wgpu::QuerySetDescriptor {
                    label: Some("probe pass timestamps"),
                    ty: wgpu::QueryType::Timestamp,
                    count: 2,
                }),
                resolve: device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("probe timestamp resolve"),
                    size: 16,
                    usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                    mapped_at_creation: false,
                }),
                readback: device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("probe timestamp readback"),
                    size: 16,
                    usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                }),
                period_ns: queue.get_timestamp_period(),
            });
        static NEXT_ID: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
        Ok(Self {
            id: NEXT_ID.fetch_add(1, std::sync::atomic::Ordering::Relaxed),
            device,
            queue,
            limits,
            adapter: None,
            timestamps,
            trace_pass,
            look_up_pass,
            diffuse_pass,
            trace_io: None,
            diffuse_io: None,
        })
    }

    /// Whether this device measures pass times with timestamp queries.
    pub fn has_timestamps(&self) -> bool {
        self.timestamps.is_some()
    }

    /// The device the tracer runs on.
    pub fn device(&self) -> &wgpu::Device {
        &self.device
    }

    /// The trace pipeline's bind-group layout ([`trace_bind_group_layout_entries`] on this
    /// device), for a pipeline layout of the caller's own.
    pub fn trace_bind_group_layout(&self) -> &wgpu::BindGroupLayout {
        &self.trace_pass.layout
    }

    /// The diffuse pipeline's bind-group layout ([`diffuse_bind_group_layout_entries`]).
    pub fn diffuse_bind_group_layout(&self) -> &wgpu::BindGroupLayout {
        &self.diffuse_pass.layout
    }

    /// The trace compute pipeline ([`TRACE_WGSL`] at [`TRACE_ENTRY_POINT`]).
    pub fn trace_pipeline(&self) -> &wgpu::ComputePipeline {
        &self.trace_pass.pipeline
    }

    /// The diffuse compute pipeline ([`DIFFUSE_WGSL`] at [`DIFFUSE_ENTRY_POINT`]).
    pub fn diffuse_pipeline(&self) -> &wgpu::ComputePipeline {
        &self.diffuse_pass.pipeline
    }

    /// A read-only storage buffer holding `data`, checked against the device's limits (the
    /// upload checked the footprint before packing; this guards the packed sizes).
    fn storage_buffer(
        &self,
        label: &'static str,
        data: &[u8],
    ) -> Result<wgpu::Buffer, UploadError> {
        crate::footprint::check_buffer(
            label,
            data.len() as u64,
            "upload fewer probes or bake at a lower resolution",
            &self.limits,
        )?;
        Ok(self
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: data,
                usage: wgpu::BufferUsages::STORAGE,
            }))
    }

    /// The largest storage binding this device allows.
    fn binding_limit(&self) -> u64 {
        self.limits
            .max_storage_buffer_binding_size
            .min(self.limits.max_buffer_size)
    }

    /// `Err(ForeignField)` unless this tracer uploaded the field tagged `tracer`.
    fn check_owner(&self, tracer: u64) -> Result<(), TraceError> {
        if tracer == self.id {
            Ok(())
        } else {
            Err(TraceError::ForeignField {
                uploaded_by: format!("another GPU tracer (number {tracer})"),
                tracer: format!("{} (number {})", Tracer::describe(self), self.id),
            })
        }
    }

    /// Workgroups `[x, y, 1]` and threads per row for `count` invocations.
    fn grid_of(&self, item: &'static str, count: u32) -> Result<([u32; 3], u32), TraceError> {
        let groups = count.div_ceil(WORKGROUP_SIZE).max(1);
        let max = self.limits.max_compute_workgroups_per_dimension.max(1);
        let x = groups.min(max);
        let y = groups.div_ceil(x);
        if y > max {
            return Err(TraceError::TooManyItems {
                item,
                count: u64::from(count),
                limit: u64::from(max) * u64::from(max) * u64::from(WORKGROUP_SIZE),
            });
        }
        Ok(([x, y, 1], x * WORKGROUP_SIZE))
    }

    /// Checks `count` items of `stride` bytes against the device's binding limit.
    fn check_count(&self, item: &'static str, count: u32, stride: u64) -> Result<(), TraceError> {
        let limit = self.binding_limit() / stride;
        if u64::from(count) > limit {
            return Err(TraceError::TooManyItems {
                item,
                count: u64::from(count),
                limit,
            });
        }
        Ok(())
    }

    /// Checks a recording call's input and results buffers and its item count, and lays out
    /// its dispatch: the rules the trace and diffuse bindings share.
    fn checked_io<'a>(&self, io: CallIo<'a>) -> Result<CheckedIo<'a>, TraceError> {
        let (input_name, input, input_stride) = io.input;
        let (results, result_stride) = io.results;
        self.check_count(io.item, io.count, io.limit_stride)?;
        if input == results {
            return Err(TraceError::BadBuffer {
                buffer: "results",
                reason: format!(
                    "it is the {input_name} buffer; the shader reads one and writes the other"
                ),
            });
        }
        let input = checked_binding(input_name, input, io.count, input_stride)?;
        let results = checked_binding("results", results, io.count, result_stride)?;
        let (workgroups, threads_per_row) = self.grid_of(io.item, io.count)?;
        Ok(CheckedIo {
            input,
            results,
            workgroups,
            threads_per_row,
            count: io.count,
        })
    }

    /// A dispatch of `pass` bound to its parameter block (a small uniform buffer of its own,
    /// so several bindings can be recorded into one encoder), the checked call buffers and
    /// the field's buffers after them.
    fn bound<const N: usize>(
        &self,
        pass: &Pass,
        label: &'static str,
        params: &impl Pod,
        io: CheckedIo<'_>,
        field: [wgpu::BufferBinding<'_>; N],
    ) -> Bound {
        let uniform = self
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(&format!("{label} parameters")),
                contents: bytemuck::bytes_of(params),
                usage: wgpu::BufferUsages::UNIFORM,
            });
        let mut entries = vec![uniform.as_entire_buffer_binding(), io.input, io.results];
        entries.extend(field);
        let bind_group = self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(label),
            layout: &pass.layout,
            entries: &bind_entries(entries),
        });
        Bound {
            pipeline: pass.pipeline.clone(),
            bind_group,
            workgroups: io.workgroups,
            count: io.count,
        }
    }

    /// Binds a trace of `buffers.count` rays from `buffers.rays` into `buffers.results`
    /// through `field` with `options`: checks everything that can be checked on the CPU, writes
    /// the parameter block (its own small uniform buffer, so several bindings can be recorded
    /// into one encoder) and makes the bind group. Blocks on nothing.
    ///
    /// # Errors
    /// [`TraceError::BadOption`] for bad options; [`TraceError::BadBuffer`] for a buffer
    /// without `STORAGE` usage, too small for `count`, or the same buffer for rays and
    /// results; [`TraceError::TooManyItems`] when `count` rays exceed what the device can bind
    /// at once; [`TraceError::ForeignField`] for a field another tracer uploaded.
    pub fn bind_trace(
        &self,
        field: &GpuField,
        buffers: &TraceBuffers<'_>,
        options: &TraceOptions,
    ) -> Result<TraceBinding, TraceError> {
        self.bind_pass(&self.trace_pass, "probe trace", field, buffers, options)
    }

    /// [`Self::bind_trace`] for the trace pipeline or the look-up's.
    fn bind_pass(
        &self,
        pass: &Pass,
        label: &'static str,
        field: &GpuField,
        buffers: &TraceBuffers<'_>,
        options: &TraceOptions,
    ) -> Result<TraceBinding, TraceError> {
        self.check_owner(field.tracer)?;
        let mut params = trace_params(&field.meta, &field.selection, options)?;
        let (ray_size, record_size) = (size_of::<TraceRay>() as u64, size_of::<RayRecord>() as u64);
        let io = self.checked_io(CallIo {
            item: "ray",
            count: buffers.count,
            limit_stride: ray_size.max(record_size),
            input: ("rays", buffers.rays, ray_size),
            results: (buffers.results, record_size),
        })?;
        params.ray_count = buffers.count;
        params.threads_per_row = io.threads_per_row;
        Ok(TraceBinding {
            bound: self.bound(
                pass,
                label,
                &params,
                io,
                [
                    field.positions.as_entire_buffer_binding(),
                    field.geometry.as_entire_buffer_binding(),
                    field.pyramid.as_entire_buffer_binding(),
                    field.radiance.as_entire_buffer_binding(),
                    field.words.as_entire_buffer_binding(),
                ],
            ),
        })
    }

    /// Records a trace of the rays in `buffers.rays` into `buffers.results` into the caller's
    /// `encoder`, in a compute pass of its own: no submission, no waiting, no read-back. The
    /// results are there for passes recorded after it (or later submissions). The same as
    /// [`Self::bind_trace`] then [`TraceBinding::record`]; bind once and record the binding
    /// to avoid making a bind group per frame.
    ///
    /// # Errors
    /// As [`Self::bind_trace`].
    pub fn record_trace(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        field: &GpuField,
        buffers: &TraceBuffers<'_>,
        options: &TraceOptions,
    ) -> Result<(), TraceError> {
        self.bind_trace(field, buffers, options)?.record(encoder);
        Ok(())
    }

    /// Binds a radiance look-up of `buffers.count` [`SurfaceQuery`]s (in `buffers.rays`,
    /// 32 bytes each like rays) into `buffers.results` ([`RayRecord`]s) through `field`: the
    /// hybrid tracer's second half ([`Tracer::look_up`]), recorded like a trace.
    ///
    /// # Errors
    /// As [`Self::bind_trace`].
    pub fn bind_look_up(
        &self,
        field: &GpuField,
        buffers: &TraceBuffers<'_>,
        options: &TraceOptions,
    ) -> Result<TraceBinding, TraceError> {
        self.bind_pass(&self.look_up_pass, "probe look-up", field, buffers, options)
    }

    /// Binds diffuse shading of `buffers.count` points from `buffers.points` into
    /// `buffers.results` with `irradiance` and `options` (see [`Self::bind_trace`]).
    ///
    /// # Errors
    /// As [`Self::bind_trace`], for points.
    pub fn bind_diffuse(
        &self,
        irradiance: &GpuIrradiance,
        buffers: &DiffuseBuffers<'_>,
        options: &DiffuseOptions,
    ) -> Result<DiffuseBinding, TraceError> {
        self.check_owner(irradiance.tracer)?;
        let mut params = diffuse_params(&irradiance.meta, options)?;
        let point_size = size_of::<ShadingPoint>() as u64;
        let io = self.checked_io(CallIo {
            item: "shading point",
            count: buffers.count,
            limit_stride: point_size,
            input: ("points", buffers.points, point_size),
            results: (buffers.results, 16),
        })?;
        params.point_count = buffers.count;
        params.threads_per_row = io.threads_per_row;
        Ok(DiffuseBinding {
            bound: self.bound(
                &self.diffuse_pass,
                "probe diffuse",
                &params,
                io,
                [
                    irradiance.positions.as_entire_buffer_binding(),
                    irradiance.irradiance.as_entire_buffer_binding(),
                    irradiance.moments.as_entire_buffer_binding(),
                    irradiance.words.as_entire_buffer_binding(),
                    irradiance.surfels.as_entire_buffer_binding(),
                ],
            ),
        })
    }

    /// Records diffuse shading of the points in `buffers.points` into `buffers.results` into
    /// the caller's `encoder` (see [`Self::record_trace`]).
    ///
    /// # Errors
    /// As [`Self::bind_diffuse`].
    pub fn record_diffuse(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        irradiance: &GpuIrradiance,
        buffers: &DiffuseBuffers<'_>,
        options: &DiffuseOptions,
    ) -> Result<(), TraceError> {
        self.bind_diffuse(irradiance, buffers, options)?
            .record(encoder);
        Ok(())
    }

    /// Items per dispatch of the convenience calls for items of `in_size` and results of
    /// `out_size` bytes.
    fn chunk_limit(&self, in_size: usize, out_size: usize) -> usize {
        MAX_CHUNK
            .min(self.binding_limit() as usize / in_size.max(out_size))
            .max(1)
    }

    /// Submits one bound dispatch over `input` (written into `io.input` first), with
    /// timestamps when the device has them, and reads `count` results back.
    fn run<Out: Pod>(
        &self,
        bound: &Bound,
        io: &Io,
        input: &[u8],
    ) -> Result<(Vec<Out>, Option<Duration>), TraceError> {
        let scope = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let memory_scope = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        self.queue.write_buffer(&io.input, 0, input);
        let out_bytes = u64::from(bound.count) * size_of::<Out>() as u64;
        let mut encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("probe pass"),
            });
        {
            let mut cpass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("probe pass"),
                timestamp_writes: self.timestamps.as_ref().map(|t| {
                    wgpu::ComputePassTimestampWrites {
                        query_set: &t.set,
                        beginning_of_pass_write_index: Some(0),
                        end_of_pass_write_index: Some(1),
                    }
                }),
            });
            bound.record_in_pass(&mut cpass);
        }
        encoder.copy_buffer_to_buffer(&io.output, 0, &io.readback, 0, out_bytes);
        if let Some(t) = &self.timestamps {
            encoder.resolve_query_set(&t.set, 0..2, &t.resolve, 0);
            encoder.copy_buffer_to_buffer(&t.resolve, 0, &t.readback, 0, 16);
        }
        self.queue.submit([encoder.finish()]);
        let out: Vec<Out> = read_back(&self.device, &io.readback, out_bytes)?;
        let time = match &self.timestamps {
            Some(t) => {
                let stamps: Vec<u64> = read_back(&self.device, &t.readback, 16)?;
                let ticks = stamps[1].saturating_sub(stamps[0]);
                Some(Duration::from_nanos(
                    (ticks as f64 * f64::from(t.period_ns)) as u64,
                ))
            }
            None => None,
        };
        if let Some(error) = pollster::block_on(memory_scope.pop()) {
            return Err(TraceError::Device {
                message: error.to_string(),
            });
        }
        if let Some(error) = pollster::block_on(scope.pop()) {
            return Err(TraceError::Device {
                message: error.to_string(),
            });
        }
        Ok((out, time))
    }
}

impl Tracer for GpuTracer {
    type Field = GpuField;
    type Irradiance = GpuIrradiance;

    /// `"gpu: ADAPTER (BACKEND)"` for a tracer made from a [`GpuContext`], `"gpu: the
    /// caller's device"` for one made [`from_device`](GpuTracer::from_device).
    fn describe(&self) -> String {
        match &self.adapter {
            Some(adapter) => format!("gpu: {adapter}"),
            None => "gpu: the caller's device".to_owned(),
        }
    }

    fn upload(
        &self,
        field: &LightField<'_>,
        selection: &ProbeSelection<'_>,
        options: &FieldOptions,
    ) -> Result<GpuField, UploadError> {
        // Every buffer against the device's limits before packing or creating any (an
        // invalid resolution is left to the packing's own error).
        let n = field.resolution;
        if n.is_power_of_two() && (MIN_RESOLUTION..=MAX_RESOLUTION).contains(&n) {
            DeviceFootprint::light_field_with_glossy(
                field.positions.len(),
                n,
                options.glossy_levels,
                Some(selection),
            )
            .check(&self.limits)?;
        }
        let mut meta = PackedField::new(field, options)?;
        let selection = PackedSelection::new(selection, field.positions)?;
        let positions = self.storage_buffer("positions", bytemuck::cast_slice(&meta.positions))?;
        let geometry = self.storage_buffer("geometry", bytemuck::cast_slice(&meta.geometry))?;
        let pyramid_data: &[[u32; 4]] = if meta.pyramid.is_empty() {
            &[[0; 4]]
        } else {
            &meta.pyramid
        };
        let pyramid = self.storage_buffer("pyramid", bytemuck::cast_slice(pyramid_data))?;
        let radiance = self.storage_buffer("radiance", bytemuck::cast_slice(&meta.radiance))?;
        let words = self.storage_buffer("selection", bytemuck::cast_slice(&selection.words))?;
        // The device holds the data now; keep only the parameters.
        meta.geometry = Vec::new();
        meta.pyramid = Vec::new();
        meta.radiance = Vec::new();
        Ok(GpuField {
            tracer: self.id,
            meta,
            selection,
            positions,
            geometry,
            pyramid,
            radiance,
            words,
        })
    }

    fn upload_irradiance(
        &self,
        field: &IrradianceField<'_>,
        interpolation: &Interpolation<'_>,
    ) -> Result<GpuIrradiance, UploadError> {
        DeviceFootprint::irradiance(
            field.positions.len(),
            field.irradiance_resolution.min(1 << 16),
            field.moments_resolution.min(1 << 16),
            Some(interpolation),
            field.surfels.len() / field.positions.len().max(1),
        )
        .check(&self.limits)?;
        let mut meta = PackedIrradiance::new(field, interpolation)?;
        let positions = self.storage_buffer(
            "irradiance positions",
            bytemuck::cast_slice(&meta.positions),
        )?;
        let irradiance =
            self.storage_buffer("irradiance", bytemuck::cast_slice(&meta.irradiance))?;
        let surfels = self.storage_buffer("surfels", bytemuck::cast_slice(&meta.surfels))?;
        let moments = self.storage_buffer("moments", bytemuck::cast_slice(&meta.moments))?;
        let words = self.storage_buffer("interpolation", bytemuck::cast_slice(&meta.words))?;
        meta.irradiance = Vec::new();
        meta.surfels = Vec::new();
        meta.moments = Vec::new();
        meta.words = Vec::new();
        Ok(GpuIrradiance {
            tracer: self.id,
            meta,
            positions,
            irradiance,
            moments,
            words,
            surfels,
        })
    }

    /// Traces `rays`: checks and normalises them on the CPU, then per chunk of at most 2²⁰
    /// rays writes them into the tracer's own buffers, records the trace with
    /// [`GpuTracer::bind_trace`] (the recording path) and reads the results back.
    fn trace(
        &mut self,
        field: &GpuField,
        rays: &[TraceRay],
        options: &TraceOptions,
    ) -> Result<TraceOutput, TraceError> {
        let start = Instant::now();
        self.check_owner(field.tracer)?;
        trace_params(&field.meta, &field.selection, options)?;
        let rays = prepare_rays(rays)?;
        self.run_records(field, &rays, options, false, start)
    }

    /// Looks up `queries` (checked and normalised on the CPU) chunk by chunk through
    /// [`GpuTracer::bind_look_up`] and reads the results back.
    fn look_up(
        &mut self,
        field: &GpuField,
        queries: &[SurfaceQuery],
        options: &TraceOptions,
    ) -> Result<TraceOutput, TraceError> {
        let start = Instant::now();
        self.check_owner(field.tracer)?;
        trace_params(&field.meta, &field.selection, options)?;
        let queries = crate::packed::prepare_queries(queries)?;
        self.run_records(field, &queries, options, true, start)
    }

    /// Shades `points`: checked on the CPU, then chunk by chunk through
    /// [`GpuTracer::bind_diffuse`] and read back.
    fn shade_diffuse(
        &mut self,
        irradiance: &GpuIrradiance,
        points: &[ShadingPoint],
        options: &DiffuseOptions,
    ) -> Result<DiffuseOutput, TraceError> {
        let start = Instant::now();
        self.check_owner(irradiance.tracer)?;
        diffuse_params(&irradiance.meta, options)?;
        let points = prepare_points(points)?;
        let chunk = self.chunk_limit(size_of::<ShadingPoint>(), 16);
        ensure_io::<ShadingPoint, [f32; 4]>(
            &self.device,
            &mut self.diffuse_io,
            points.len().min(chunk),
            "diffuse",
        );
        let io = self.diffuse_io.as_ref().expect("ensured above");
        let mut results = Vec::with_capacity(points.len());
        let mut gpu = self.timestamps.as_ref().map(|_| Duration::ZERO);
        for part in points.chunks(chunk) {
            let binding = self.bind_diffuse(
                irradiance,
                &DiffuseBuffers {
                    points: &io.input,
                    results: &io.output,
                    count: part.len() as u32,
                },
                options,
            )?;
            let (out, time) =
                self.run::<[f32; 4]>(&binding.bound, io, bytemuck::cast_slice(part))?;
            if let (Some(total), Some(t)) = (gpu.as_mut(), time) {
                *total += t;
            }
            results.extend(out.into_iter().map(|v| DiffuseResult {
                irradiance: glam::Vec3::new(v[0], v[1], v[2]),
                weight: v[3],
            }));
        }
        Ok(DiffuseOutput {
            results,
            timing: Timing {
                wall: start.elapsed(),
                gpu,
            },
        })
    }
}

impl GpuTracer {
    /// The convenience trace or look-up: `items` (rays or queries, 32 bytes each) written
    /// chunk by chunk into the tracer's buffers, dispatched and read back.
    fn run_records<In: Pod>(
        &mut self,
        field: &GpuField,
        items: &[In],
        options: &TraceOptions,
        look_up: bool,
        start: Instant,
    ) -> Result<TraceOutput, TraceError> {
        let rays = items;
        let chunk = self.chunk_limit(size_of::<TraceRay>(), size_of::<RayRecord>());
        ensure_io::<TraceRay, RayRecord>(
            &self.device,
            &mut self.trace_io,
            rays.len().min(chunk),
            "trace",
        );
        let io = self.trace_io.as_ref().expect("ensured above");
        let mut results = Vec::with_capacity(rays.len());
        let mut gpu = self.timestamps.as_ref().map(|_| Duration::ZERO);
        for part in rays.chunks(chunk) {
            let buffers = TraceBuffers {
                rays: &io.input,
                results: &io.output,
                count: part.len() as u32,
            };
            let binding = if look_up {
                self.bind_look_up(field, &buffers, options)?
            } else {
                self.bind_trace(field, &buffers, options)?
            };
            let (records, time) =
                self.run::<RayRecord>(&binding.bound, io, bytemuck::cast_slice(part))?;
            if let (Some(total), Some(t)) = (gpu.as_mut(), time) {
                *total += t;
            }
            results.extend(records.into_iter().map(RayResult::from));
        }
        Ok(TraceOutput {
            results,
            timing: Timing {
                wall: start.elapsed(),
                gpu,
            },
        })
    }
}

/// Bind-group entries for buffer bindings in order from binding 0.
fn bind_entries(buffers: Vec<wgpu::BufferBinding<'_>>) -> Vec<wgpu::BindGroupEntry<'_>> {
    (0..)
        .zip(buffers)
        .map(|(binding, buffer)| wgpu::BindGroupEntry {
            binding,
            resource: wgpu::BindingResource::Buffer(buffer),
        })
        .collect()
}

/// A recording call's buffers, before they are checked.
struct CallIo<'a> {
    /// What one item is, for errors (`ray`, `shading point`).
    item: &'static str,
    /// Items in the call.
    count: u32,
    /// Bytes per item counted against the device's binding limit.
    limit_stride: u64,
    /// The input buffer: its name, the buffer and bytes per item.
    input: (&'static str, &'a wgpu::Buffer, u64),
    /// The results buffer and bytes per result.
    results: (&'a wgpu::Buffer, u64),
}

/// A recording call's buffers, checked, and its dispatch.
struct CheckedIo<'a> {
    input: wgpu::BufferBinding<'a>,
    results: wgpu::BufferBinding<'a>,
    workgroups: [u32; 3],
    threads_per_row: u32,
    count: u32,
}

/// Makes sure `io` holds at least `items` items (grown geometrically).
fn ensure_io<In: Pod, Out: Pod>(
    device: &wgpu::Device,
    io: &mut Option<Io>,
    items: usize,
    label: &str,
) {
    if io.as_ref().is_some_and(|io| io.capacity >= items) {
        return;
    }
    // Grow geometrically so that slowly growing calls do not reallocate every time.
    let capacity = items
        .max(io.as_ref().map_or(0, |io| io.capacity * 2).min(MAX_CHUNK))
        .max(64);
    let buffer = |what: &str, size: usize, usage: wgpu::BufferUsages| {
        device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(&format!("probe {label} {what}")),
            size: size as u64,
            usage,
            mapped_at_creation: false,
        })
    };
    *io = Some(Io {
        capacity,
        input: buffer(
            "input",
            capacity * size_of::<In>(),
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        ),
        output: buffer(
            "output",
            capacity * size_of::<Out>(),
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        ),
        readback: buffer(
            "readback",
            capacity * size_of::<Out>(),
            wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        ),
    });
}

/// Maps the first `bytes` of `buffer`, waits, and copies them out.
fn read_back<T: Pod + Zeroable>(
    device: &wgpu::Device,
    buffer: &wgpu::Buffer,
    bytes: u64,
) -> Result<Vec<T>, TraceError> {
    let slice = buffer.slice(0..bytes);
    let (sender, receiver) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |result| {
        let _ = sender.send(result);
    });
    device
        .poll(wgpu::PollType::wait_indefinitely())
        .map_err(|e| TraceError::Device {
            message: e.to_string(),
        })?;
    match receiver.recv() {
        Ok(Ok(())) => {}
        Ok(Err(e)) => {
            return Err(TraceError::Device {
                message: format!("mapping the results failed: {e}"),
            });
        }
        Err(_) => {
            return Err(TraceError::Device {
                message: "the device dropped the mapping request".to_owned(),
            });
        }
    }
    let out = {
        let view = slice.get_mapped_range().map_err(|e| TraceError::Device {
            message: format!("reading the results failed: {e}"),
        })?;
        bytemuck::pod_collect_to_vec::<u8, T>(&view)
    };
    buffer.unmap();
    Ok(out)
}

#[cfg(test)]
mod tests;
