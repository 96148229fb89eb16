//! The CLI's error type: every crate's error, plus the CLI's own argument errors.

/// Everything a `probes` command can fail with.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CliError {
    /// The scene could not be loaded.
    #[error(transparent)]
    Scene(#[from] probe_scene::LoadError),
    /// The probe positions could not be read.
    #[error(transparent)]
    Probes(#[from] probe_place::ProbeSetError),
    /// Indexing failed.
    #[error("indexing: {0}")]
    Index(#[from] probe_index::IndexError),
    /// Baking failed.
    #[error("baking: {0}")]
    Bake(#[from] probe_capture::BakeError),
    /// The bake could not be saved.
    #[error("saving the bake: {0}")]
    BakeSave(#[from] probe_capture::BakeSaveError),
    /// The bake could not be read.
    #[error("reading the bake: {0}")]
    BakeLoad(#[from] probe_capture::BakeLoadError),
    /// Shards could not be merged.
    #[error("merging shards: {0}")]
    Merge(#[from] probe_capture::MergeError),
    /// Previews could not be written.
    #[error("writing previews: {0}")]
    Preview(#[from] probe_capture::PreviewError),
    /// Rendering failed.
    #[error("rendering: {0}")]
    Render(#[from] probe_capture::RenderError),
    /// An image could not be written or read.
    #[error("image: {0}")]
    Image(#[from] probe_capture::ImageError),
    /// Placement failed.
    #[error("placement: {0}")]
    Place(#[from] probe_place::pipeline::PlaceError),
    /// A top view could not be drawn.
    #[error("top view: {0}")]
    TopView(#[from] probe_eval::top_view::TopViewError),
    /// An evaluation step failed.
    #[error(transparent)]
    Eval(#[from] probe_eval::EvalError),
    /// The request would exceed the memory limit (`--max-memory`, or the machine's memory).
    #[error(transparent)]
    Memory(#[from] probe_scene::memory::MemoryExceeded),
    /// A command-line value could not be understood.
    #[error("invalid {parameter} {value:?}: {reason}")]
    InvalidArgument {
        /// The flag or positional argument.
        parameter: &'static str,
        /// What was given.
        value: String,
        /// What is wrong and what is accepted.
        reason: String,
    },
}

/// The error and its chain of causes on one line.
pub fn one_line(error: &CliError) -> String {
    let mut text = error.to_string();
    let mut source = std::error::Error::source(error);
    while let Some(cause) = source {
        let cause_text = cause.to_string();
        if !text.contains(&cause_text) {
            text.push_str(": ");
            text.push_str(&cause_text);
        }
        source = cause.source();
    }
    text.replace('\n', " ")
}
