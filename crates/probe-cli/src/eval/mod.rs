//! Evaluation: the measured pipeline (place, bake, index, trace, compare with the path-traced
//! reference), the `probes demo` run, the `probes eval` sweep with its report and charts, and
//! the failure suite.

pub mod demo;
pub mod failures;
pub mod pipeline;
pub mod sweep;

use std::path::PathBuf;

/// Everything an evaluation step can fail with; each variant names the stage.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum EvalError {
    /// A scene could not be loaded.
    #[error(transparent)]
    Scene(#[from] probe_scene::LoadError),
    /// Rendering the reference or the evaluation rays failed.
    #[error("reference: {0}")]
    Render(#[from] probe_capture::RenderError),
    /// The shading setup was refused.
    #[error("shading: {0}")]
    Shader(#[from] probe_capture::ShaderError),
    /// Baking failed.
    #[error("baking: {0}")]
    Bake(#[from] probe_capture::BakeError),
    /// Probe previews could not be written.
    #[error("previews: {0}")]
    Preview(#[from] probe_capture::PreviewError),
    /// An image operation failed.
    #[error("image: {0}")]
    Image(#[from] probe_capture::ImageError),
    /// Indexing failed.
    #[error("indexing: {0}")]
    Index(#[from] probe_index::IndexError),
    /// The grid could not be indexed as a cage.
    #[error("grid cage: {0}")]
    Grid(#[from] probe_index::GridError),
    /// No GPU adapter could be used.
    #[error("gpu: {0}")]
    Gpu(#[from] probe_trace_gpu::GpuError),
    /// Uploading probes to the tracer failed.
    #[error("tracer upload: {0}")]
    Upload(#[from] probe_trace_gpu::UploadError),
    /// Tracing failed.
    #[error("trace: {0}")]
    Trace(#[from] probe_trace_gpu::TraceError),
    /// Placement failed.
    #[error("placement: {0}")]
    Place(#[from] crate::placement::PlaceError),
    /// A chart could not be drawn.
    #[error("chart: {0}")]
    Chart(#[from] crate::chart::ChartError),
    /// A top view could not be drawn.
    #[error("top view: {0}")]
    TopView(#[from] crate::top_view::TopViewError),
    /// The configuration is invalid.
    #[error("configuration {}: {reason}", path.as_ref().map_or("(defaults)".to_owned(), |p| p.display().to_string()))]
    Config {
        /// The configuration file, if any.
        path: Option<PathBuf>,
        /// What is wrong.
        reason: String,
    },
    /// An output file could not be written.
    #[error("cannot write {}: {source}", path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
}

/// Writes `bytes` to `path` atomically: a temporary file beside it, then a rename.
pub fn write_atomic(path: &std::path::Path, bytes: &[u8]) -> Result<(), EvalError> {
    let error = |source| EvalError::Write {
        path: path.to_owned(),
        source,
    };
    if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent).map_err(error)?;
    }
    let mut temporary = path.as_os_str().to_owned();
    temporary.push(format!(".{}.tmp", std::process::id()));
    let temporary = PathBuf::from(temporary);
    std::fs::write(&temporary, bytes).map_err(error)?;
    std::fs::rename(&temporary, path).map_err(|e| {
        let _ = std::fs::remove_file(&temporary);
        error(e)
    })
}
