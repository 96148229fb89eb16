//! Parsing of scene and probe specifications shared by the commands.

use crate::cli_error::CliError;
use probe_place::ProbeSet;
use probe_scene::Scene;
use probe_scene::memory::MemoryLimit;

/// Opens a scene given as a glTF path or `builtin:NAME`, printing its load warnings to
/// stderr (`probes: warning: …`, one line each).
pub fn open_scene(spec: &str) -> Result<Scene, CliError> {
    open_scene_with_limit(spec, MemoryLimit::machine())
}

/// [`open_scene`] with a memory limit (`--max-memory`).
pub fn open_scene_with_limit(spec: &str, limit: MemoryLimit) -> Result<Scene, CliError> {
    let scene = Scene::open_with_limit(spec, limit)?;
    for warning in scene.warnings() {
        eprintln!("probes: warning: {}: {warning}", scene.name());
    }
    Ok(scene)
}

/// The scene's load warnings for `--json` reports.
pub fn warnings_json(scene: &Scene) -> serde_json::Value {
    serde_json::Value::from(
        scene
            .warnings()
            .iter()
            .map(ToString::to_string)
            .collect::<Vec<_>>(),
    )
}

/// `--max-memory`, shared by the commands that allocate.
#[derive(clap::Args, Debug)]
pub struct MemoryArgs {
    /// The most memory the command may plan to use (e.g. `16G`, `512M`): a request
    /// estimated above it (scene triangles, bake resolution × probes, octree depth, image and
    /// rays) is refused before work starts. Default: the machine's memory (`MemTotal` of
    /// /proc/meminfo; 8 GiB where it cannot be read).
    #[arg(long, value_parser = parse_memory)]
    pub max_memory: Option<u64>,
}

fn parse_memory(text: &str) -> Result<u64, String> {
    probe_scene::memory::parse_size(text).map_err(|e| e.to_string())
}

impl MemoryArgs {
    /// The limit: `--max-memory` if given, else the machine's.
    pub fn limit(&self) -> MemoryLimit {
        self.max_memory
            .map_or_else(MemoryLimit::machine, MemoryLimit::bytes)
    }
}

/// Reads probe positions from a `probes/1` JSON file or the shorthand `grid:NXxNYxNZ`
/// (cell centres of an NX×NY×NZ division of the scene bounds).
pub fn probe_set(spec: &str, scene: &Scene) -> Result<ProbeSet, CliError> {
    Ok(ProbeSet::from_spec(spec, scene)?)
}

/// Parses `x,y,z` into a vector; `parameter` names the flag in errors.
pub fn parse_vec3(parameter: &'static str, text: &str) -> Result<glam::Vec3, CliError> {
    let invalid = |reason: &str| CliError::InvalidArgument {
        parameter,
        value: text.to_owned(),
        reason: reason.to_owned(),
    };
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    if parts.len() != 3 {
        return Err(invalid("expected three numbers x,y,z"));
    }
    let mut v = [0.0f32; 3];
    for (slot, part) in v.iter_mut().zip(&parts) {
        *slot = part
            .parse::<f32>()
            .map_err(|_| invalid("expected three numbers x,y,z"))?;
        if !slot.is_finite() {
            return Err(invalid("numbers must be finite"));
        }
    }
    Ok(glam::Vec3::from_array(v))
}

/// The camera named `spec` (`default` for the scene's default camera), or a pose
/// `px,py,pz:tx,ty,tz[:yfov_degrees]` (position, target, vertical field of view; 60° if left
/// out; up is +Y).
pub fn camera(scene: &Scene, spec: &str) -> Result<probe_scene::Camera, CliError> {
    if spec == "default" {
        return Ok(scene.default_camera());
    }
    if let Some(found) = scene.camera(spec) {
        return Ok(found.clone());
    }
    let parts: Vec<&str> = spec.split(':').collect();
    if parts.len() == 2 || parts.len() == 3 {
        let position = parse_vec3("--camera", parts[0])?;
        let target = parse_vec3("--camera", parts[1])?;
        let yfov_degrees = match parts.get(2) {
            Some(text) => text
                .parse::<f32>()
                .ok()
                .filter(|f| *f > 0.0 && *f < 180.0)
                .ok_or_else(|| CliError::InvalidArgument {
                    parameter: "--camera",
                    value: spec.to_owned(),
                    reason: "the field of view must be a number of degrees in (0, 180)".into(),
                })?,
            None => 60.0,
        };
        if position == target {
            return Err(CliError::InvalidArgument {
                parameter: "--camera",
                value: spec.to_owned(),
                reason: "the position and the target are the same point".into(),
            });
        }
        return Ok(probe_scene::Camera::look_at(
            position,
            target,
            glam::Vec3::Y,
            yfov_degrees.to_radians(),
        ));
    }
    Err(CliError::InvalidArgument {
        parameter: "--camera",
        value: spec.to_owned(),
        reason: format!(
            "not a camera of the scene ({}) nor a pose px,py,pz:tx,ty,tz[:yfov_degrees]",
            scene
                .cameras()
                .iter()
                .map(|c| c.name.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        ),
    })
}

/// The sun options of the commands that light a scene (`bake`, `reference`).
#[derive(clap::Args, Debug)]
pub struct SunArgs {
    /// Sun direction `x,y,z` (the direction light travels); replaces the default daylight's.
    #[arg(long)]
    pub sun_direction: Option<String>,
    /// Sun illuminance (relative units; the default daylight has 20).
    #[arg(long)]
    pub sun_illuminance: Option<f32>,
}

impl SunArgs {
    /// The lighting environment: the scene's default, with the sun changed if asked (`None`:
    /// the scene's default unchanged).
    ///
    /// # Errors
    /// [`CliError::InvalidArgument`] for a zero or unparsable direction, or a negative or
    /// non-finite illuminance.
    pub fn environment(
        &self,
        scene: &Scene,
    ) -> Result<Option<probe_capture::Environment>, CliError> {
        environment(scene, self.sun_direction.as_deref(), self.sun_illuminance)
    }
}

/// The lighting environment: the scene's default, with the sun changed if asked.
fn environment(
    scene: &Scene,
    sun_direction: Option<&str>,
    sun_illuminance: Option<f32>,
) -> Result<Option<probe_capture::Environment>, CliError> {
    if sun_direction.is_none() && sun_illuminance.is_none() {
        return Ok(None);
    }
    let mut environment = probe_capture::Environment::for_scene(scene);
    if environment.sky_is_black() && environment.sun_illuminance == 0.0 {
        environment = probe_capture::Environment::DEFAULT_DAYLIGHT;
    }
    if let Some(text) = sun_direction {
        let direction = parse_vec3("--sun-direction", text)?;
        if direction.length_squared() == 0.0 {
            return Err(CliError::InvalidArgument {
                parameter: "--sun-direction",
                value: text.to_owned(),
                reason: "the direction must not be zero".into(),
            });
        }
        environment = environment.with_sun_direction(direction);
    }
    if let Some(illuminance) = sun_illuminance {
        if !(illuminance.is_finite() && illuminance >= 0.0) {
            return Err(CliError::InvalidArgument {
                parameter: "--sun-illuminance",
                value: illuminance.to_string(),
                reason: "must be a finite number ≥ 0".into(),
            });
        }
        environment = environment.with_sun_illuminance(illuminance);
    }
    Ok(Some(environment))
}

/// Parses a reflection lobe: `mirror` or `ggx:ROUGHNESS` with roughness in (0, 1].
pub fn reflection(text: &str) -> Result<probe_capture::Reflection, CliError> {
    if text == "mirror" {
        return Ok(probe_capture::Reflection::Mirror);
    }
    if let Some(value) = text.strip_prefix("ggx:")
        && let Ok(roughness) = value.parse::<f32>()
        && roughness > 0.0
        && roughness <= 1.0
    {
        return Ok(probe_capture::Reflection::Ggx { roughness });
    }
    Err(CliError::InvalidArgument {
        parameter: "--reflection",
        value: text.to_owned(),
        reason: "expected `mirror` or `ggx:ROUGHNESS` with roughness in (0, 1]".into(),
    })
}
