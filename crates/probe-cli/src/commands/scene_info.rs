//! `probes scene-info`: what a scene holds.

use crate::cli_error::CliError;
use crate::output::Report;
use crate::spec::MemoryArgs;
use probe_scene::{AlphaMode, Light, Scene};
use serde_json::{Value, json};
use std::fmt::Write as _;
use std::time::Instant;

/// Arguments of `probes scene-info`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// A glTF 2.0 file (.gltf or .glb) or `builtin:NAME` (cornell, colonnade, boxes,
    /// leak-closed, leak-gap).
    pub scene: String,
    /// The memory limit for the scene's declared size.
    #[command(flatten)]
    pub memory: MemoryArgs,
}

/// Loads the scene and summarises it.
pub fn run(args: &Args) -> Result<Box<dyn Report>, CliError> {
    let start = Instant::now();
    // The warnings are part of the report, not printed to stderr as the other commands do.
    let scene = Scene::open_with_limit(&args.scene, args.memory.limit())?;
    let load_seconds = start.elapsed().as_secs_f64();
    Ok(Box::new(SceneInfo {
        scene,
        load_seconds,
    }))
}

struct SceneInfo {
    scene: Scene,
    load_seconds: f64,
}

fn vec3(v: glam::Vec3) -> Value {
    json!([v.x, v.y, v.z])
}

fn light_json(light: &Light) -> Value {
    match light {
        Light::Point {
            name,
            position,
            color,
            intensity,
            range,
        } => json!({
            "type": "point", "name": name, "position": vec3(*position), "color": vec3(*color),
            "intensity_cd": intensity, "range": range,
        }),
        Light::Spot {
            name,
            position,
            direction,
            color,
            intensity,
            inner_cone,
            outer_cone,
            range,
        } => json!({
            "type": "spot", "name": name, "position": vec3(*position),
            "direction": vec3(*direction), "color": vec3(*color), "intensity_cd": intensity,
            "inner_cone_rad": inner_cone, "outer_cone_rad": outer_cone, "range": range,
        }),
        Light::Directional {
            name,
            direction,
            color,
            illuminance,
            ..
        } => json!({
            "type": "directional", "name": name, "direction": vec3(*direction),
            "color": vec3(*color), "illuminance_lux": illuminance,
        }),
    }
}

fn alpha_name(alpha: &AlphaMode) -> String {
    match alpha {
        AlphaMode::Opaque => "opaque".into(),
        AlphaMode::Mask {
            cutoff, texture, ..
        } => match texture {
            Some(t) => format!("mask {cutoff} ({}x{} texture)", t.width(), t.height()),
            None => format!("mask {cutoff}"),
        },
        AlphaMode::Blend => "blend".into(),
    }
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

impl Report for SceneInfo {
    fn json(&self) -> Value {
        let s = &self.scene;
        let bounds = s.bounds();
        let camera_json = |c: &probe_scene::Camera| {
            json!({
                "name": c.name, "position": vec3(c.position), "forward": vec3(c.forward),
                "up": vec3(c.up), "yfov_rad": c.yfov, "aspect": c.aspect,
            })
        };
        json!({
            "command": "scene-info",
            "scene": s.name(),
            "source": s.source().to_string(),
            "triangles": s.triangles().len(),
            "unique_triangles": s.unique_triangle_count(),
            "bounds": { "min": vec3(bounds.min), "max": vec3(bounds.max) },
            "materials": s.materials().iter().map(|m| json!({
                "name": m.name, "base_color": vec3(m.base_color), "metallic": m.metallic,
                "roughness": m.roughness, "emissive": vec3(m.emissive),
                "double_sided": m.double_sided, "alpha": alpha_name(&m.alpha),
            })).collect::<Vec<_>>(),
            "lights": s.lights().iter().map(light_json).collect::<Vec<_>>(),
            "cameras": s.cameras().iter().map(camera_json).collect::<Vec<_>>(),
            "default_camera": camera_json(&s.default_camera()),
            "warnings": s.warnings().iter().map(ToString::to_string).collect::<Vec<_>>(),
            "content_hash": hex(&s.content_hash()),
            "load_seconds": self.load_seconds,
        })
    }

    fn text(&self) -> String {
        let s = &self.scene;
        let bounds = s.bounds();
        let mut out = String::new();
        let _ = writeln!(out, "scene      {} ({})", s.name(), s.source());
        let _ = writeln!(
            out,
            "triangles  {} instanced, {} unique",
            s.triangles().len(),
            s.unique_triangle_count()
        );
        let _ = writeln!(
            out,
            "bounds     [{:.3}, {:.3}, {:.3}] .. [{:.3}, {:.3}, {:.3}] m",
            bounds.min.x, bounds.min.y, bounds.min.z, bounds.max.x, bounds.max.y, bounds.max.z
        );
        let _ = writeln!(out, "materials  {}", s.materials().len());
        for m in s.materials() {
            let _ = writeln!(
                out,
                "  {:<24} base [{:.3} {:.3} {:.3}] rough {:.2} metal {:.2}{}{} {}",
                m.name,
                m.base_color.x,
                m.base_color.y,
                m.base_color.z,
                m.roughness,
                m.metallic,
                if m.is_emissive() { " emissive" } else { "" },
                if m.double_sided { " double-sided" } else { "" },
                alpha_name(&m.alpha),
            );
        }
        let _ = writeln!(out, "lights     {}", s.lights().len());
        for light in s.lights() {
            let _ = writeln!(out, "  {}", light_json(light));
        }
        let _ = writeln!(out, "cameras    {}", s.cameras().len());
        for c in s.cameras() {
            let _ = writeln!(
                out,
                "  {:<20} at [{:.2} {:.2} {:.2}] looking [{:.2} {:.2} {:.2}], yfov {:.1} deg",
                c.name,
                c.position.x,
                c.position.y,
                c.position.z,
                c.forward.x,
                c.forward.y,
                c.forward.z,
                c.yfov.to_degrees()
            );
        }
        let d = s.default_camera();
        let _ = writeln!(
            out,
            "default    {} at [{:.2} {:.2} {:.2}]",
            d.name, d.position.x, d.position.y, d.position.z
        );
        let _ = writeln!(out, "warnings   {}", s.warnings().len());
        for w in s.warnings() {
            let _ = writeln!(out, "  {w}");
        }
        let _ = writeln!(out, "hash       {}", hex(&s.content_hash()));
        let _ = writeln!(out, "loaded in  {:.3} s", self.load_seconds);
        out
    }
}
