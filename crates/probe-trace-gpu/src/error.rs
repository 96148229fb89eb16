//! One error enum per operation family: getting a device ([`GpuError`]), checking and uploading
//! probe data ([`UploadError`]), and tracing or shading ([`TraceError`]).

/// Why no GPU device could be had.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum GpuError {
    /// No adapter (GPU or software rasteriser) is available. Fix: install a Vulkan, Metal or
    /// DX12 driver; on Linux without a GPU, Mesa's software Vulkan (`mesa-vulkan-drivers`,
    /// "lavapipe") is enough. `WGPU_BACKEND` and `WGPU_ADAPTER_NAME` steer the choice.
    #[error(
        "no GPU adapter is available ({source}); install a Vulkan driver (e.g. Mesa's lavapipe, package `mesa-vulkan-drivers`)"
    )]
    NoAdapter {
        /// wgpu's reason.
        #[source]
        source: wgpu::RequestAdapterError,
    },
    /// The adapter refused to create a device with the features and limits asked for. Fix:
    /// update the driver, or use another adapter (`WGPU_ADAPTER_NAME`).
    #[error("adapter `{adapter}` refused a device: {source}")]
    Device {
        /// The adapter's name.
        adapter: String,
        /// wgpu's reason.
        #[source]
        source: wgpu::RequestDeviceError,
    },
    /// The device cannot run the tracer's compute shaders (a downlevel device without compute
    /// or with fewer than 7 storage buffers per stage). Fix: use a device with full compute
    /// support (any Vulkan 1.1, Metal or DX12 device).
    #[error("adapter `{adapter}` cannot run the tracer: {reason}")]
    Unsupported {
        /// The adapter's name.
        adapter: String,
        /// What is missing.
        reason: String,
    },
}

/// Why probe data or selection data was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum UploadError {
    /// The map resolution cannot be used. Fix: bake probes at a power of two from 8 to 4096
    /// (the hi-Z pyramid halves the resolution level by level).
    #[error("`{parameter}` is {value}; it must be a power of two from {min} to {max}")]
    Resolution {
        /// The parameter holding the resolution.
        parameter: &'static str,
        /// The value given.
        value: u32,
        /// Smallest value accepted.
        min: u32,
        /// Largest value accepted.
        max: u32,
    },
    /// There are no probes. Fix: pass at least one probe position and its maps.
    #[error("the light field has no probes")]
    NoProbes,
    /// A slice has the wrong length. Fix: pass `probes × (N+2)²` padded texels per map (probes
    /// one after another, in the padded layout of `probe_octa::OctaLayout`) and one position per
    /// probe.
    #[error("`{parameter}` holds {actual} elements; {expected} are needed")]
    LengthMismatch {
        /// The parameter with the wrong length.
        parameter: &'static str,
        /// Elements needed.
        expected: usize,
        /// Elements given.
        actual: usize,
    },
    /// An element is NaN or infinite. Fix: store sky (no geometry) as a finite distance at or
    /// above `sky_distance`, and keep positions, normals and radiance finite.
    #[error("`{parameter}[{index}]` is not finite")]
    NonFinite {
        /// The parameter holding it.
        parameter: &'static str,
        /// Index of the element.
        index: usize,
    },
    /// A radial distance is negative. Fix: store distances from the probe centre (>= 0).
    #[error("`radial_distance[{index}]` is {value}; distances must be >= 0")]
    NegativeDistance {
        /// Index of the texel.
        index: usize,
        /// The value found.
        value: f32,
    },
    /// A scalar parameter is out of range. Fix: see the parameter's documentation (e.g.
    /// `sky_distance` must be finite and positive, `thickness_scale` finite and >= 0).
    #[error("`{parameter}` is {value}; {requirement}")]
    BadParameter {
        /// The parameter.
        parameter: &'static str,
        /// The value given.
        value: f32,
        /// What it must be.
        requirement: &'static str,
    },
    /// The selection structure was built for a different number of probes. Fix: build the
    /// grid, octree or neighbour maps from the same probe set, in the same order.
    #[error("the {selection} covers {actual} probes but the light field has {expected}")]
    ProbeCountMismatch {
        /// Which structure.
        selection: &'static str,
        /// Probes in the light field.
        expected: usize,
        /// Probes the structure covers.
        actual: usize,
    },
    /// The tetrahedralization's convex hull does not match its tetrahedra (a hull triangle
    /// names a tetrahedron, face or neighbouring triangle that does not exist, or an open
    /// tetrahedron face has no hull triangle). Fix: build it with
    /// `probe_index::Tetrahedralization::build` and pass it unchanged.
    #[error("hull triangle {hull_face} of the tetrahedralization: {reason}")]
    BadHull {
        /// The hull triangle (or, for an open face without one, the tetrahedron).
        hull_face: usize,
        /// What does not match.
        reason: &'static str,
    },
    /// The selection structure names a probe that does not exist. Fix: rebuild it from this
    /// probe set.
    #[error("the {selection} names probe {probe}, but there are only {probe_count} probes")]
    ProbeOutOfRange {
        /// Which structure.
        selection: &'static str,
        /// The probe index found.
        probe: u32,
        /// Probes in the light field.
        probe_count: usize,
    },
    /// A buffer of the field is larger than the device allows (its `max_buffer_size` or
    /// `max_storage_buffer_binding_size`; every buffer is bound whole); refused before any
    /// buffer is created. Fix: what `lower` says (fewer probes, e.g. a split of the set, or a
    /// lower bake resolution), or a device with larger limits. Check ahead of baking with
    /// [`DeviceFootprint`](crate::DeviceFootprint).
    #[error(
        "`{buffer}` needs {} on the device, above its `{limit_name}` of {}: {lower}",
        crate::footprint::describe_bytes(*bytes),
        crate::footprint::describe_bytes(*limit)
    )]
    DeviceLimit {
        /// Which buffer.
        buffer: &'static str,
        /// Bytes it needs.
        bytes: u64,
        /// The device limit it exceeds: `"max_storage_buffer_binding_size"` or
        /// `"max_buffer_size"`.
        limit_name: &'static str,
        /// The limit's value.
        limit: u64,
        /// What to lower.
        lower: &'static str,
    },
    /// The data is too large to address with 32-bit indices in the shaders. Fix: use fewer or
    /// smaller probes.
    #[error("`{buffer}` needs {bytes} bytes, above the limit of {limit}")]
    TooLarge {
        /// Which buffer.
        buffer: &'static str,
        /// Bytes needed.
        bytes: u64,
        /// The limit.
        limit: u64,
    },
}

/// Why a trace or a shading pass failed, or could not be recorded.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum TraceError {
    /// The field was uploaded by another tracer: a GPU field of another `GpuTracer`, or (through
    /// `AnyTracer`) a field of the other kind of tracer. Fix: upload the probes with the
    /// tracer that traces them.
    #[error(
        "the field was uploaded by `{uploaded_by}`, not by this tracer (`{tracer}`); upload it with the tracer that traces it"
    )]
    ForeignField {
        /// The tracer (or device) that uploaded the field.
        uploaded_by: String,
        /// The tracer asked to use it.
        tracer: String,
    },
    /// A ray or shading point is unusable. Fix: pass finite origins, finite non-zero
    /// directions (normals) and `0 <= t_min <= t_max` (`t_max` may be infinite).
    #[error("{item} {index}: {reason}")]
    BadInput {
        /// `"ray"` or `"shading point"`.
        item: &'static str,
        /// Its index.
        index: usize,
        /// What is wrong.
        reason: &'static str,
    },
    /// An option is out of range. Fix: see the option's documentation.
    #[error("option `{option}` is {value}; {requirement}")]
    BadOption {
        /// The option.
        option: &'static str,
        /// The value given.
        value: f64,
        /// What it must be.
        requirement: &'static str,
    },
    /// A buffer given to a recording call (`GpuTracer::bind_trace`, `record_trace` and the
    /// diffuse equivalents) cannot be bound: it lacks a usage flag, is smaller than `count`
    /// items, or is the same buffer as the other one. Fix: create the input and output
    /// buffers separately with `wgpu::BufferUsages::STORAGE`, at least `count ×` the item
    /// size (documented on `TraceBuffers` and `DiffuseBuffers`) bytes each.
    #[error("buffer `{buffer}`: {reason}")]
    BadBuffer {
        /// `"rays"`, `"results"` or `"points"`.
        buffer: &'static str,
        /// What is wrong.
        reason: String,
    },
    /// More items than one dispatch can bind on this device (the device's
    /// `max_storage_buffer_binding_size` over the item size, or its workgroup grid). Fix:
    /// record several calls over smaller buffers.
    #[error("{count} {item}s in one call; this device binds at most {limit}")]
    TooManyItems {
        /// `"ray"` or `"shading point"`.
        item: &'static str,
        /// Items asked for.
        count: u64,
        /// Most items per call on this device.
        limit: u64,
    },
    /// The device reported an error while running the pass (validation, out of memory, or a
    /// lost device). Fix: usually a driver problem; retry with fewer rays per call.
    #[error("the device failed: {message}")]
    Device {
        /// The device's message.
        message: String,
    },
}

/// Text that is not a valid [`crate::DiffuseOptions`] (`key=value,...`).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum DiffuseOptionsError {
    /// An item without `=`. Fix: write `key=value`.
    #[error("`{0}` is not key=value")]
    NotKeyValue(String),
    /// A key the options do not have. Fix: use `visibility`, `normal-bias`, `exponent`,
    /// `min-weight`, `backface` or `parallax`.
    #[error(
        "unknown diffuse option `{0}` (visibility, normal-bias, exponent, min-weight, backface, parallax)"
    )]
    UnknownKey(String),
    /// A value that does not parse. Fix: a number, or `on`/`off` for the switches.
    #[error("diffuse option `{key}`: `{value}` is not a valid value (a number, or on/off)")]
    BadValue {
        /// The key.
        key: String,
        /// The value given.
        value: String,
    },
}
