//! Parsing of scene specifications shared by the commands.

use crate::cli_error::CliError;
use probe_scene::Scene;

/// Opens a scene given as a glTF path or `builtin:NAME`.
pub fn open_scene(spec: &str) -> Result<Scene, CliError> {
    Ok(Scene::open(spec)?)
}
