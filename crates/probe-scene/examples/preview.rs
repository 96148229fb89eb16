//! Renders a quick preview of a scene from its default camera (or a named one) to a PNG:
//! albedo shaded by the cosine to the eye, emitters at full brightness, misses in sky blue.
//!
//! `cargo run --release -p probe-scene --example preview -- SPEC OUT.png [CAMERA] [WIDTH]`

use glam::{Vec2, Vec3};
use probe_scene::{Ray, Scene};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 3 {
        eprintln!("usage: preview <file|builtin:NAME> <out.png> [camera] [width]");
        std::process::exit(2);
    }
    let scene = Scene::open(&args[1]).unwrap_or_else(|e| {
        eprintln!("{e}");
        std::process::exit(1)
    });
    let camera = match args.get(3).filter(|name| !name.is_empty()) {
        Some(name) => scene.camera(name).cloned().expect("no such camera"),
        None => scene.default_camera(),
    };
    let width: u32 = args.get(4).map_or(480, |w| w.parse().expect("width"));
    let height = (width as f32 / camera.aspect.unwrap_or(4.0 / 3.0)).round() as u32;
    let rays: Vec<Ray> = (0..height)
        .flat_map(|y| (0..width).map(move |x| (x, y)))
        .map(|(x, y)| camera.ray(x, y, width, height, Vec2::ZERO))
        .collect();
    let start = std::time::Instant::now();
    let hits = scene.closest_hits(&rays, f32::INFINITY);
    eprintln!(
        "{} rays in {:.3} s",
        rays.len(),
        start.elapsed().as_secs_f64()
    );
    let mut pixels = Vec::with_capacity(rays.len() * 3);
    for (ray, hit) in rays.iter().zip(&hits) {
        let color = match hit {
            None => Vec3::new(0.55, 0.7, 0.9),
            Some(hit) => {
                let material = &scene.materials()[hit.material as usize];
                if material.is_emissive() {
                    Vec3::ONE
                } else {
                    let cosine = ray.direction.dot(hit.shading_normal).abs();
                    let tint = if hit.front_face {
                        Vec3::ONE
                    } else {
                        Vec3::new(1.0, 0.3, 0.3)
                    };
                    material.base_color * (0.25 + 0.75 * cosine) * tint
                }
            }
        };
        for c in color.to_array() {
            pixels.push((c.clamp(0.0, 1.0).powf(1.0 / 2.2) * 255.0).round() as u8);
        }
    }
    image::RgbImage::from_raw(width, height, pixels)
        .expect("size")
        .save(&args[2])
        .expect("write png");
}
