//! Times a full probe bake on Sponza with the default daylight.
//!
//! ```text
//! /usr/bin/time -v cargo run --release -p probe-capture --example bake_sponza -- \
//!     [PROBES] [RESOLUTION] [SAMPLES] [BOUNCES] [SAVE_DIR]
//! ```
//!
//! Defaults: 64 probes (a 4×4×4 grid over the atrium, as probe-scene's `closest_hit`
//! benchmark; other counts use an `n×n×n`-ish grid over the same box), 256², adaptive
//! sampling with the library's defaults (`SAMPLES` = 0; any other value is a fixed count per
//! texel), 1 bounce. Prints the time of each phase (geometry pass, distance ranges, radiance
//! pass, derived maps, read off the progress callback), the total, the rays cast and, with
//! `SAVE_DIR`, the
//! time to save the bake there (PNG previews of probe 0 go to `SAVE_DIR-previews`). Loading
//! the scene and building its BVH are timed apart.

use std::sync::Mutex;
use std::time::Instant;

use glam::Vec3;
use probe_capture::{BakeSettings, RANGE_SAMPLES, Sampling, bake};
use probe_scene::Scene;

fn grid(count: usize) -> Vec<Vec3> {
    let (min, max) = (Vec3::new(-9.0, 4.5, -3.0), Vec3::new(9.0, 14.0, 3.0));
    let side = (count as f64).cbrt().ceil().max(1.0) as usize;
    let mut positions = Vec::with_capacity(count);
    'fill: for z in 0..side {
        for y in 0..side {
            for x in 0..side {
                if positions.len() == count {
                    break 'fill;
                }
                let f = if side > 1 {
                    Vec3::new(x as f32, y as f32, z as f32) / (side - 1) as f32
                } else {
                    Vec3::splat(0.5)
                };
                positions.push(min + (max - min) * f);
            }
        }
    }
    positions
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let arg = |i: usize, default: u32| -> u32 {
        args.get(i)
            .map_or(default, |a| a.parse().expect("a number"))
    };
    let probes = arg(0, 64) as usize;
    let settings = BakeSettings {
        resolution: arg(1, 256),
        sampling: match arg(2, 0) {
            0 => Sampling::default(),
            fixed => Sampling::fixed(fixed),
        },
        bounces: arg(3, 1),
        ..Default::default()
    };
    let save_dir = args.get(4);

    let start = Instant::now();
    let scene = Scene::load(probe_testdata::scene_path(probe_testdata::SPONZA)).expect("Sponza");
    println!(
        "loaded Sponza ({} triangles) and built its BVH in {:.2} s",
        scene.triangles().len(),
        start.elapsed().as_secs_f64()
    );
    let positions = grid(probes);
    let n = settings.resolution as usize;
    let rows = positions.len() * n;
    let marks = Mutex::new([None::<f64>; 3]);
    let start = Instant::now();
    let progress = |done: usize, _total: usize| {
        let t = start.elapsed().as_secs_f64();
        let mut marks = marks.lock().expect("marks");
        if done >= rows && marks[0].is_none() {
            marks[0] = Some(t);
        }
        if done >= 2 * rows && marks[1].is_none() {
            marks[1] = Some(t);
        }
        if done >= 4 * rows && marks[2].is_none() {
            marks[2] = Some(t);
        }
    };
    let baked = bake(&scene, &positions, &settings, &progress).expect("bake");
    let total = start.elapsed().as_secs_f64();
    let [geometry, ranges, radiance] = marks
        .into_inner()
        .expect("marks")
        .map(|m| m.unwrap_or(total));
    let texels = positions.len() * n * n;
    let samples: u64 = baked.sampling().iter().map(|p| p.samples).sum();
    println!(
        "{} probes × {}² × {:.2} samples/texel ({:?}), {} bounce(s), {} threads",
        positions.len(),
        settings.resolution,
        baked.mean_samples_per_texel(),
        settings.sampling,
        settings.bounces,
        rayon::current_num_threads()
    );
    println!(
        "  geometry pass {geometry:.2} s ({texels} texel-centre rays, {:.2} M rays/s)",
        texels as f64 / geometry / 1e6
    );
    println!(
        "  distance ranges {:.2} s ({} sub-texel rays, {:.2} M rays/s)",
        ranges - geometry,
        texels * (RANGE_SAMPLES * RANGE_SAMPLES) as usize,
        (texels * (RANGE_SAMPLES * RANGE_SAMPLES) as usize) as f64 / (ranges - geometry) / 1e6
    );
    println!(
        "  radiance pass {:.2} s ({} radiance samples, {:.2} M samples/s)",
        radiance - ranges,
        samples,
        samples as f64 / (radiance - ranges) / 1e6
    );
    if let Some(noise) = baked.noise() {
        println!("  noise (tone-mapped variance per texel, from the replicates) {noise:.3e}");
    }
    println!("  derived maps  {:.2} s", total - radiance);
    println!("  total bake    {total:.2} s");
    let stats = baked.stats();
    let mean = |f: fn(&probe_capture::ProbeStats) -> f32| {
        stats.iter().map(f).sum::<f32>() / stats.len() as f32
    };
    println!(
        "  mean miss share {:.3}, mean back-face share {:.3}",
        mean(|s| s.miss_share),
        mean(|s| s.back_face_share)
    );
    if let Some(dir) = save_dir {
        let start = Instant::now();
        baked.save(dir).expect("save");
        println!("  saved to {dir} in {:.2} s", start.elapsed().as_secs_f64());
        let previews = format!("{dir}-previews");
        let paths = baked.write_previews(0, &previews).expect("previews");
        println!("  previews of probe 0: {}", paths.radiance.display());
    }
}
