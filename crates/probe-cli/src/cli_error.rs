//! The CLI's error type: every crate's error, plus the CLI's own argument errors.

/// Everything a `probes` command can fail with.
#[derive(Debug, thiserror::Error)]
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
