//! The wgpu tracer: a device, two compute pipelines (trace and diffuse shading) built once, and
//! storage buffers that are reused across calls and grown only when a call needs more.

use std::borrow::Cow;
use std::time::{Duration, Instant};

use bytemuck::{Pod, Zeroable};
use wgpu::util::DeviceExt;

use crate::cpu::{DiffuseOutput, TraceOutput};
use crate::error::{GpuError, TraceError, UploadError};
use crate::input::{FieldOptions, Interpolation, IrradianceField, LightField, ProbeSelection};
use crate::packed::{
    DiffuseParams, PackedField, PackedIrradiance, PackedSelection, TraceParams, diffuse_params,
    prepare_points, prepare_rays, trace_params,
};
use crate::ray::{
    DiffuseOptions, DiffuseResult, RayRecord, RayResult, ShadingPoint, Timing, TraceOptions,
    TraceRay,
};

/// The trace shader: `common.wgsl` followed by `trace.wgsl`.
pub(crate) const TRACE_WGSL: &str =
    concat!(include_str!("common.wgsl"), include_str!("trace.wgsl"));
/// The diffuse shader: `common.wgsl` followed by `diffuse.wgsl`.
pub(crate) const DIFFUSE_WGSL: &str =
    concat!(include_str!("common.wgsl"), include_str!("diffuse.wgsl"));

/// Threads per workgroup in both shaders.
const WORKGROUP: u32 = 64;
/// Most rays (or points) per dispatch; larger calls are split.
const MAX_CHUNK: usize = 1 << 20;

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

/// Per-call buffers of a pass: input items, output items, read-back copy, uniform block.
struct Io {
    capacity: usize,
    input: wgpu::Buffer,
    output: wgpu::Buffer,
    readback: wgpu::Buffer,
    uniform: wgpu::Buffer,
}

/// The light field on the device.
struct GpuField {
    meta: PackedField,
    selection: PackedSelection,
    positions: wgpu::Buffer,
    geometry: wgpu::Buffer,
    pyramid: wgpu::Buffer,
    radiance: wgpu::Buffer,
    words: wgpu::Buffer,
}

/// The irradiance field on the device.
struct GpuIrradiance {
    meta: PackedIrradiance,
    positions: wgpu::Buffer,
    irradiance: wgpu::Buffer,
    moments: wgpu::Buffer,
    words: wgpu::Buffer,
}

/// The GPU tracer: build it once from a device, [`upload`](Self::upload) probes, then
/// [`trace`](Self::trace) as many ray sets as needed. Pipelines are created once; per-call
/// buffers are reused and grow only when a call needs more.
pub struct GpuTracer {
    device: wgpu::Device,
    queue: wgpu::Queue,
    limits: wgpu::Limits,
    timestamps: Option<Timestamps>,
    trace_pass: Pass,
    diffuse_pass: Pass,
    field: Option<GpuField>,
    irradiance: Option<GpuIrradiance>,
    trace_io: Option<Io>,
    diffuse_io: Option<Io>,
    trace_bind_group: Option<wgpu::BindGroup>,
    diffuse_bind_group: Option<wgpu::BindGroup>,
}

impl std::fmt::Debug for GpuTracer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GpuTracer")
            .field("field_uploaded", &self.field.is_some())
            .field("irradiance_uploaded", &self.irradiance.is_some())
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

/// Builds a pipeline over `[uniform, input, output, extra read-only storage…]`.
fn make_pass(device: &wgpu::Device, label: &str, source: &str, entry: &str, extra: u32) -> Pass {
    let mut entries = vec![
        uniform_entry(0),
        storage_entry(1, true),
        storage_entry(2, false),
    ];
    entries.extend((0..extra).map(|i| storage_entry(3 + i, true)));
    let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some(label),
        entries: &entries,
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

impl GpuTracer {
    /// A tracer on the context's device.
    ///
    /// # Errors
    /// [`GpuError::Unsupported`] if the device cannot build the pipelines.
    pub fn new(context: &GpuContext) -> Result<Self, GpuError> {
        Self::from_device(context.device.clone(), context.queue.clone())
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
        if limits.max_compute_invocations_per_workgroup < WORKGROUP {
            return Err(unsupported(
                "it cannot run 64-thread compute workgroups".to_owned(),
            ));
        }
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let trace_pass = make_pass(&device, "probe trace", TRACE_WGSL, "trace_main", 5);
        let diffuse_pass = make_pass(&device, "probe diffuse", DIFFUSE_WGSL, "diffuse_main", 4);
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
        Ok(Self {
            device,
            queue,
            limits,
            timestamps,
            trace_pass,
            diffuse_pass,
            field: None,
            irradiance: None,
            trace_io: None,
            diffuse_io: None,
            trace_bind_group: None,
            diffuse_bind_group: None,
        })
    }

    /// Whether this device measures pass times with timestamp queries.
    pub fn has_timestamps(&self) -> bool {
        self.timestamps.is_some()
    }

    /// A read-only storage buffer holding `data`, checked against the device's limits.
    fn storage_buffer(
        &self,
        label: &'static str,
        data: &[u8],
    ) -> Result<wgpu::Buffer, UploadError> {
        let bytes = data.len() as u64;
        let limit = self
            .limits
            .max_storage_buffer_binding_size
            .min(self.limits.max_buffer_size);
        if bytes > limit {
            return Err(UploadError::TooLarge {
                buffer: label,
                bytes,
                limit,
            });
        }
        Ok(self
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: data,
                usage: wgpu::BufferUsages::STORAGE,
            }))
    }

    /// Checks a light field and its selection and uploads them (replacing any earlier one).
    ///
    /// # Errors
    /// [`UploadError`] naming the bad slice, element or parameter, or the buffer that does not
    /// fit the device's limits.
    pub fn upload(
        &mut self,
        field: &LightField<'_>,
        selection: &ProbeSelection<'_>,
        options: &FieldOptions,
    ) -> Result<(), UploadError> {
        let mut meta = PackedField::new(field, options)?;
        let selection = PackedSelection::new(selection, meta.probe_count as usize)?;
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
        self.field = Some(GpuField {
            meta,
            selection,
            positions,
            geometry,
            pyramid,
            radiance,
            words,
        });
        self.trace_bind_group = None;
        Ok(())
    }

    /// Checks and uploads irradiance and moment maps and the interpolation scheme.
    ///
    /// # Errors
    /// As [`Self::upload`].
    pub fn upload_irradiance(
        &mut self,
        field: &IrradianceField<'_>,
        interpolation: &Interpolation<'_>,
    ) -> Result<(), UploadError> {
        let mut meta = PackedIrradiance::new(field, interpolation)?;
        let positions = self.storage_buffer(
            "irradiance positions",
            bytemuck::cast_slice(&meta.positions),
        )?;
        let irradiance =
            self.storage_buffer("irradiance", bytemuck::cast_slice(&meta.irradiance))?;
        let moments = self.storage_buffer("moments", bytemuck::cast_slice(&meta.moments))?;
        let words = self.storage_buffer("interpolation", bytemuck::cast_slice(&meta.words))?;
        meta.irradiance = Vec::new();
        meta.moments = Vec::new();
        meta.words = Vec::new();
        self.irradiance = Some(GpuIrradiance {
            meta,
            positions,
            irradiance,
            moments,
            words,
        });
        self.diffuse_bind_group = None;
        Ok(())
    }

    /// Items per dispatch for items of `in_size` and results of `out_size` bytes.
    fn chunk_limit(&self, in_size: usize, out_size: usize) -> usize {
        let limit = self
            .limits
            .max_storage_buffer_binding_size
            .min(self.limits.max_buffer_size) as usize;
        MAX_CHUNK.min(limit / in_size.max(out_size)).max(1)
    }

    /// Traces `rays` on the device.
    ///
    /// # Errors
    /// [`TraceError::NotUploaded`] before [`Self::upload`]; [`TraceError::BadInput`] for a bad
    /// ray; [`TraceError::BadOption`] for bad options; [`TraceError::Device`] if the device
    /// fails.
    pub fn trace(
        &mut self,
        rays: &[TraceRay],
        options: &TraceOptions,
    ) -> Result<TraceOutput, TraceError> {
        let start = Instant::now();
        let Some(field) = &self.field else {
            return Err(TraceError::NotUploaded {
                what: "light field",
                call: "upload",
            });
        };
        let mut params = trace_params(&field.meta, &field.selection, options)?;
        let rays = prepare_rays(rays)?;
        let chunk = self.chunk_limit(size_of::<TraceRay>(), size_of::<RayRecord>());
        let items = rays.len().min(chunk);
        if ensure_io::<TraceRay, RayRecord, TraceParams>(
            &self.device,
            &mut self.trace_io,
            items,
            "trace",
        ) {
            self.trace_bind_group = None;
        }
        if self.trace_bind_group.is_none() {
            let field = self.field.as_ref().expect("checked above");
            let io = self.trace_io.as_ref().expect("ensured above");
            self.trace_bind_group =
                Some(self.device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("probe trace"),
                    layout: &self.trace_pass.layout,
                    entries: &bind_entries(&[
                        &io.uniform,
                        &io.input,
                        &io.output,
                        &field.positions,
                        &field.geometry,
                        &field.pyramid,
                        &field.radiance,
                        &field.words,
                    ]),
                }));
        }
        let mut results = Vec::with_capacity(rays.len());
        let mut gpu = self.timestamps.as_ref().map(|_| Duration::ZERO);
        for part in rays.chunks(chunk) {
            let (groups_x, groups_y, row) = self.grid_of(part.len());
            params.ray_count = part.len() as u32;
            params.threads_per_row = row;
            let (records, time) = self.dispatch::<TraceRay, RayRecord>(
                true,
                part,
                bytemuck::bytes_of(&params),
                (groups_x, groups_y),
            )?;
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

    /// Shades `points` diffusely from the uploaded irradiance probes on the device.
    ///
    /// # Errors
    /// [`TraceError::NotUploaded`] before [`Self::upload_irradiance`];
    /// [`TraceError::BadInput`] for a bad point; [`TraceError::BadOption`] for bad options;
    /// [`TraceError::Device`] if the device fails.
    pub fn shade_diffuse(
        &mut self,
        points: &[ShadingPoint],
        options: &DiffuseOptions,
    ) -> Result<DiffuseOutput, TraceError> {
        let start = Instant::now();
        let Some(irradiance) = &self.irradiance else {
            return Err(TraceError::NotUploaded {
                what: "irradiance field",
                call: "upload_irradiance",
            });
        };
        let mut params = diffuse_params(&irradiance.meta, options)?;
        let points = prepare_points(points)?;
        let chunk = self.chunk_limit(size_of::<ShadingPoint>(), 16);
        let items = points.len().min(chunk);
        if ensure_io::<ShadingPoint, [f32; 4], DiffuseParams>(
            &self.device,
            &mut self.diffuse_io,
            items,
            "diffuse",
        ) {
            self.diffuse_bind_group = None;
        }
        if self.diffuse_bind_group.is_none() {
            let ir = self.irradiance.as_ref().expect("checked above");
            let io = self.diffuse_io.as_ref().expect("ensured above");
            self.diffuse_bind_group =
                Some(self.device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("probe diffuse"),
                    layout: &self.diffuse_pass.layout,
                    entries: &bind_entries(&[
                        &io.uniform,
                        &io.input,
                        &io.output,
                        &ir.positions,
                        &ir.irradiance,
                        &ir.moments,
                        &ir.words,
                    ]),
                }));
        }
        let mut results = Vec::with_capacity(points.len());
        let mut gpu = self.timestamps.as_ref().map(|_| Duration::ZERO);
        for part in points.chunks(chunk) {
            let (groups_x, groups_y, row) = self.grid_of(part.len());
            params.point_count = part.len() as u32;
            params.threads_per_row = row;
            let (out, time) = self.dispatch::<ShadingPoint, [f32; 4]>(
                false,
                part,
                bytemuck::bytes_of(&params),
                (groups_x, groups_y),
            )?;
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

    /// Workgroups `(x, y)` and threads per row for `items` invocations.
    fn grid_of(&self, items: usize) -> (u32, u32, u32) {
        let groups = (items as u32).div_ceil(WORKGROUP).max(1);
        let max = self.limits.max_compute_workgroups_per_dimension.max(1);
        let x = groups.min(max);
        let y = groups.div_ceil(x);
        (x, y, x * WORKGROUP)
    }

    /// Runs one dispatch of the trace (`trace = true`) or diffuse pass over `items` and reads
    /// the results back.
    fn dispatch<In: Pod, Out: Pod>(
        &self,
        trace: bool,
        items: &[In],
        uniform: &[u8],
        groups: (u32, u32),
    ) -> Result<(Vec<Out>, Option<Duration>), TraceError> {
        let (pass, io, bind_group) = if trace {
            (
                &self.trace_pass,
                self.trace_io.as_ref(),
                self.trace_bind_group.as_ref(),
            )
        } else {
            (
                &self.diffuse_pass,
                self.diffuse_io.as_ref(),
                self.diffuse_bind_group.as_ref(),
            )
        };
        let (Some(io), Some(bind_group)) = (io, bind_group) else {
            unreachable!("buffers and bind group are made before dispatching");
        };
        let scope = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let memory_scope = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        self.queue.write_buffer(&io.uniform, 0, uniform);
        self.queue
            .write_buffer(&io.input, 0, bytemuck::cast_slice(items));
        let out_bytes = (items.len() * size_of::<Out>()) as u64;
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
            cpass.set_pipeline(&pass.pipeline);
            cpass.set_bind_group(0, bind_group, &[]);
            cpass.dispatch_workgroups(groups.0, groups.1, 1);
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

/// Bind-group entries for buffers bound in order from binding 0.
fn bind_entries<'a>(buffers: &[&'a wgpu::Buffer]) -> Vec<wgpu::BindGroupEntry<'a>> {
    buffers
        .iter()
        .enumerate()
        .map(|(i, b)| wgpu::BindGroupEntry {
            binding: i as u32,
            resource: b.as_entire_binding(),
        })
        .collect()
}

/// Makes sure `io` holds at least `items` items; returns whether buffers were (re)made.
fn ensure_io<In: Pod, Out: Pod, U: Pod>(
    device: &wgpu::Device,
    io: &mut Option<Io>,
    items: usize,
    label: &str,
) -> bool {
    if io.as_ref().is_some_and(|io| io.capacity >= items) {
        return false;
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
        uniform: buffer(
            "uniform",
            size_of::<U>(),
            wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        ),
    });
    true
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
