//! Parsing of scene and probe specifications shared by the commands.

use crate::cli_error::CliError;
use probe_place::ProbeSet;
use probe_scene::Scene;

/// Opens a scene given as a glTF path or `builtin:NAME`.
pub fn open_scene(spec: &str) -> Result<Scene, CliError> {
    Ok(Scene::open(spec)?)
}

/// Reads probe positions from a `probes/1` JSON file or the shorthand `grid:NXxNYxNZ`
/// (cell centres of an NX×NY×NZ division of the scene bounds).
pub fn probe_set(spec: &str, scene: &Scene) -> Result<ProbeSet, CliError> {
    Ok(ProbeSet::from_spec(spec, scene)?)
}
