//! The error of the emissive triangles' direct light at surface points: the mean of `N`
//! independent light samples (an emitter chosen by power, a uniform point on it, a shadow
//! ray: what `Shader::direct_irradiance` did before, written out here) against
//! [`Shader::direct_irradiance`]'s `N` stratified light samples with `N/2` cosine rays under
//! multiple importance sampling, in one run.
//!
//! ```text
//! cargo run --release -p probe-capture --example direct_light_variance -- [SCENE…] [N]
//! ```
//!
//! Default scenes: `builtin:cornell` and the shared Cornell glTF (when present); default `N`
//! 16. Points: the first 1,500 visible surface hits of rays from uniform random points in the
//! middle of the scene's bounds (x, z in the middle 40 %, y in the middle 60 %) in uniform
//! random directions, seed 3. Truth: each point's radiance from [`Shader::direct_irradiance`]
//! with 4,096 samples; the mean squared difference between that truth and one from 4,096
//! independent samples is printed as its own noise. Each estimator runs six seeds; reported:
//! the mean squared error over points and seeds (of the radiance's channel mean), the worst
//! point's, and the time on one thread.

use std::time::Instant;

use glam::{Vec2, Vec3};
use probe_capture::{Environment, Rng, Shader};
use probe_scene::{Hit, Ray, Scene};

/// The emissive triangles with their powers' cumulative distribution.
struct Emitters {
    triangles: Vec<u32>,
    cdf: Vec<f64>,
    total: f64,
}

impl Emitters {
    fn new(scene: &Scene) -> Emitters {
        let (mut triangles, mut cdf, mut total) = (Vec::new(), Vec::new(), 0.0f64);
        for (index, triangle) in scene.triangles().iter().enumerate() {
            let material = &scene.materials()[triangle.material as usize];
            if !material.is_emissive() {
                continue;
            }
            let sides = if material.double_sided { 2.0 } else { 1.0 };
            let power =
                f64::from(triangle.area()) * f64::from(material.emissive.element_sum()) * sides;
            if power > 0.0 && power.is_finite() {
                total += power;
                triangles.push(index as u32);
                cdf.push(total);
            }
        }
        Emitters {
            triangles,
            cdf,
            total,
        }
    }

    /// One independent light sample's irradiance at `hit` (normals `normals`).
    fn sample(&self, scene: &Scene, hit: &Hit, normals: (Vec3, Vec3), rng: &mut Rng) -> Vec3 {
        let (geometric_normal, shading_normal) = normals;
        let u = f64::from(rng.next_f32()) * self.total;
        let slot = self
            .cdf
            .partition_point(|&c| c <= u)
            .min(self.cdf.len() - 1);
        let below = if slot == 0 { 0.0 } else { self.cdf[slot - 1] };
        let index = self.triangles[slot];
        if index == hit.triangle {
            return Vec3::ZERO;
        }
        let triangle = &scene.triangles()[index as usize];
        let material = &scene.materials()[triangle.material as usize];
        let (a, b) = (rng.next_f32().sqrt(), rng.next_f32());
        let point = triangle.point(Vec2::new(a * (1.0 - b), a * b));
        let to_light = point - hit.position;
        let distance_squared = to_light.length_squared();
        let towards = to_light / distance_squared.sqrt();
        let cosine = shading_normal.dot(towards);
        let mut light_cosine = -triangle.geometric_normal().dot(towards);
        if material.double_sided {
            light_cosine = light_cosine.abs();
        }
        if cosine <= 0.0 || geometric_normal.dot(towards) <= 0.0 || light_cosine <= 0.0 {
            return Vec3::ZERO;
        }
        // The shadow ray from the offset origin to the point, stopping short of it by 1e-4 of
        // the distance and 16 ulps over the light's cosine (its own plane's rounding).
        let origin = Ray::from_surface(hit.position, geometric_normal, to_light).origin;
        let distance = (point - origin).length();
        let ray = Ray::new(origin, point - origin);
        let scale = point.abs().max_element().max(origin.abs().max_element());
        let margin = 1e-4 * distance + scale * 16.0 * f32::EPSILON / light_cosine.clamp(1e-3, 1.0);
        if scene.occluded(&ray, distance - margin) {
            return Vec3::ZERO;
        }
        let pdf_area = ((self.cdf[slot] - below) / self.total) as f32 / triangle.area();
        material.emissive * (cosine * light_cosine / (distance_squared * pdf_area))
    }
}

/// Visible surface points: `(hit, direction towards the viewer)`.
fn surface_points(scene: &Scene, shader: &Shader<'_>, count: usize) -> Vec<(Hit, Vec3)> {
    let bounds = scene.bounds();
    let size = bounds.max - bounds.min;
    let mut rng = Rng::for_key(3, &[]);
    let mut points = Vec::with_capacity(count);
    while points.len() < count {
        let at = Vec3::new(
            0.3 + 0.4 * rng.next_f32(),
            0.2 + 0.6 * rng.next_f32(),
            0.3 + 0.4 * rng.next_f32(),
        );
        let origin = bounds.min + size * at;
        let z = 2.0 * rng.next_f32() - 1.0;
        let phi = std::f32::consts::TAU * rng.next_f32();
        let r = (1.0 - z * z).max(0.0).sqrt();
        let direction = Vec3::new(r * phi.cos(), z, r * phi.sin());
        if let Some(hit) = scene.closest_hit(&Ray::new(origin, direction), f32::INFINITY)
            && shader.visible_normals(&hit, -direction).is_some()
        {
            points.push((hit, -direction));
        }
    }
    points
}

/// The radiance (channel mean) each point reflects of the light sources' direct light, by
/// `N` independent light samples (`stratified = false`) or by `direct_irradiance`.
fn estimates(
    shader: &Shader<'_>,
    emitters: &Emitters,
    points: &[(Hit, Vec3)],
    samples: u32,
    stratified: bool,
    seed: u64,
) -> Vec<f64> {
    points
        .iter()
        .enumerate()
        .map(|(i, (hit, towards_viewer))| {
            let mut rng = Rng::for_key(seed, &[i as u64]);
            let radiance = if stratified {
                shader.radiance_with_reflected(hit, *towards_viewer, Vec3::ZERO, samples, &mut rng)
            } else {
                let scene = shader.scene();
                let normals = shader
                    .visible_normals(hit, *towards_viewer)
                    .expect("visible points");
                let irradiance = (0..samples)
                    .map(|_| emitters.sample(scene, hit, normals, &mut rng))
                    .sum::<Vec3>()
                    / samples as f32;
                let albedo = scene.materials()[hit.material as usize].base_color;
                shader.emission(hit, *towards_viewer)
                    + albedo * irradiance * std::f32::consts::FRAC_1_PI
            };
            f64::from(radiance.element_sum()) / 3.0
        })
        .collect()
}

fn mean_squared_difference(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(a, b)| (a - b).powi(2)).sum::<f64>() / a.len() as f64
}

fn main() {
    let mut scenes = Vec::new();
    let mut samples = 16u32;
    for argument in std::env::args().skip(1) {
        match argument.parse() {
            Ok(n) => samples = n,
            Err(_) => scenes.push(argument),
        }
    }
    if scenes.is_empty() {
        scenes.push("builtin:cornell".to_owned());
        let gltf = probe_testdata::scene_path(probe_testdata::CORNELL_BOX);
        if gltf.exists() {
            scenes.push(gltf.display().to_string());
        }
    }
    for spec in scenes {
        let scene = match Scene::open(&spec) {
            Ok(scene) => scene,
            Err(error) => {
                eprintln!("{spec}: {error}");
                std::process::exit(1);
            }
        };
        let shader = Shader::new(&scene, Environment::BLACK, 0).expect("a black environment");
        let points = surface_points(&scene, &shader, 1_500);
        let emitters = Emitters::new(&scene);
        let truth = estimates(&shader, &emitters, &points, 4_096, true, 99);
        let independent_truth = estimates(&shader, &emitters, &points, 4_096, false, 98);
        println!(
            "{spec}: {} points, {samples} samples; truth's noise {:.2e} (means {:.5} / {:.5})",
            points.len(),
            mean_squared_difference(&truth, &independent_truth),
            truth.iter().sum::<f64>() / truth.len() as f64,
            independent_truth.iter().sum::<f64>() / truth.len() as f64,
        );
        let mut errors = [0.0f64; 2];
        for (k, stratified) in [false, true].into_iter().enumerate() {
            let start = Instant::now();
            let (mut total, mut worst) = (0.0f64, 0.0f64);
            let seeds = 6;
            for seed in 0..seeds {
                let values = estimates(&shader, &emitters, &points, samples, stratified, seed);
                for (value, truth) in values.iter().zip(&truth) {
                    let squared = (value - truth).powi(2);
                    total += squared;
                    worst = worst.max(squared);
                }
            }
            let mse = total / (seeds as usize * points.len()) as f64;
            errors[k] = mse;
            let name = if stratified {
                "stratified + MIS"
            } else {
                "independent"
            };
            println!(
                "  {name:>16}: MSE {mse:.3e}, worst point {worst:.3e}, {:.1} µs per point",
                start.elapsed().as_secs_f64() * 1e6 / (seeds as usize * points.len()) as f64
            );
        }
        println!("  ratio {:.1}×", errors[0] / errors[1]);
    }
}
