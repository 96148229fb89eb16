//! Prints a summary of a scene: `cargo run --release -p probe-scene --example scene_info -- SPEC`
//! where SPEC is a glTF path or `builtin:NAME`.

use probe_scene::Scene;
use std::time::Instant;

fn main() {
    let Some(spec) = std::env::args().nth(1) else {
        eprintln!("usage: scene_info <file.gltf|file.glb|builtin:NAME>");
        std::process::exit(2);
    };
    let start = Instant::now();
    match Scene::open(&spec) {
        Ok(scene) => {
            let elapsed = start.elapsed();
            let bounds = scene.bounds();
            println!("{} ({})", scene.name(), scene.source());
            println!("  loaded in {:.3} s", elapsed.as_secs_f64());
            println!(
                "  triangles {} (unique {})",
                scene.triangles().len(),
                scene.unique_triangle_count()
            );
            println!("  bounds {:?} .. {:?}", bounds.min, bounds.max);
            println!("  materials {}", scene.materials().len());
            for m in scene.materials() {
                println!(
                    "    {:?}: base {:?} metallic {} roughness {} emissive {:?} {:?}",
                    m.name,
                    m.base_color,
                    m.metallic,
                    m.roughness,
                    m.emissive,
                    match &m.alpha {
                        probe_scene::AlphaMode::Mask {
                            cutoff, texture, ..
                        } => format!(
                            "mask cutoff {cutoff} texture {:?}",
                            texture
                                .as_ref()
                                .map(|t| (t.width(), t.height(), t.coverage(*cutoff)))
                        ),
                        other => format!("{other:?}"),
                    }
                );
            }
            println!("  lights {:?}", scene.lights());
            for c in scene.cameras() {
                println!("  camera {c:?}");
            }
            println!("  default camera {:?}", scene.default_camera());
            for w in scene.warnings() {
                println!("  warning: {w}");
            }
            let hash = scene.content_hash();
            println!(
                "  content hash {}",
                hash.iter().map(|b| format!("{b:02x}")).collect::<String>()
            );
        }
        Err(e) => {
            println!("error: {e}");
            std::process::exit(1);
        }
    }
}
