//! `probe_trace_gpu`: trace rays through light-field probes (placeholder doc, rewritten below).

mod cpu;
mod error;
mod gpu;
mod input;
mod packed;
mod ray;
mod surface;

pub use cpu::{CpuTracer, DiffuseOutput, TraceOutput};
pub use gpu::{GpuContext, GpuTracer};
pub use error::{GpuError, TraceError, UploadError};
pub use input::{FieldOptions, Interpolation, IrradianceField, LightField, ProbeSelection};
pub use ray::{
    DiffuseOptions, DiffuseResult, RayResult, RayStatus, ShadingPoint, Timing, TraceMethod,
    TraceOptions, TraceRay, TraceSummary,
};
