//! How far a bake's sampling converges, and what it costs: for each sampling configuration,
//! two bakes of the same probes with seeds 0 and 1, traced through the regular grid's cage
//! (hi-Z, the CPU twin) from one camera, judged against a reference refined until its noise
//! is at most 5 % of the smallest error.
//!
//! ```text
//! cargo run --release -p probe-eval --example bake_convergence -- \
//!     [SCENE] [PROBES] [RESOLUTION] [WIDTH]x[HEIGHT] [CAMERA] [OUT] [CONFIG ...]
//! ```
//!
//! Defaults: `builtin:cornell grid:3x3x3 128 256x256 default bake-convergence fixed:4
//! adaptive fixed:64`. A configuration is `fixed:N` (N samples per texel) or
//! `adaptive[:MIN:MAX:NOISE]` (the library's defaults without the numbers).
//!
//! Per configuration it prints, and writes to `OUT/convergence.json` and `OUT/convergence.md`:
//! - the bake time of each seed and the mean samples per texel;
//! - the **bake noise**: half the tone-mapped MSE between the two traced images (the variance
//!   of one image's pixels over seeds), and its share of the error;
//! - the **error**: the tone-mapped MSE of the seed-0 image against the reference;
//! - the bake's own noise estimate (the manifest's mean over probes and texels of each
//!   texel's tone-mapped variance, [`probe_capture::ProbeBake::noise`]) beside the same
//!   quantity measured from the two seeds' radiance maps, and their ratio.
//!
//! It also writes each configuration's seed-0 image and the reference as PNGs at one
//! exposure, and `OUT/side_by_side.png`: the configurations left to right, the reference last.

use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::Instant;

use glam::Vec3;
use probe_capture::{Image, ProbeBake, Sampling, find_camera};
use probe_eval::metrics::tonemapped_mse;
use probe_eval::pipeline::{
    Device, EvalView, Selection, Tracer, ViewSettings, bake_for_view_seeded, build_index,
    trace_only,
};
use probe_index::ProbeGrid;
use probe_place::ProbeSet;
use probe_scene::Scene;

fn parse_sampling(text: &str) -> Sampling {
    let parts: Vec<&str> = text.split(':').collect();
    match parts.as_slice() {
        ["fixed", n] => Sampling::fixed(n.parse().expect("fixed:N")),
        ["adaptive"] => Sampling::default(),
        ["adaptive", min, max, noise] => Sampling::adaptive(
            min.parse().expect("MIN"),
            max.parse().expect("MAX"),
            noise.parse().expect("NOISE"),
        ),
        _ => panic!("configuration {text:?}: give fixed:N or adaptive[:MIN:MAX:NOISE]"),
    }
}

/// The mean over probes and texels of the tone-mapped squared difference of two bakes'
/// radiance, halved: the per-texel variance of one bake, measured from two seeds.
fn measured_texel_noise(a: &ProbeBake, b: &ProbeBake) -> f64 {
    let layout = a.layout();
    let n = layout.resolution();
    let len = layout.padded_len();
    let mut sum = 0.0f64;
    let mut count = 0usize;
    for probe in 0..a.probe_count() {
        for iy in 0..n {
            for ix in 0..n {
                let t = probe * len + layout.interior_index(ix, iy);
                let tone = |v: Vec3| v / (Vec3::ONE + v);
                let d = tone(a.radiance()[t]) - tone(b.radiance()[t]);
                sum += f64::from(d.length_squared()) / 3.0;
                count += 1;
            }
        }
    }
    sum / count as f64 / 2.0
}

struct Row {
    name: String,
    seconds: [f64; 2],
    samples_per_texel: f64,
    noise: f64,
    error: f64,
    estimated_texel_noise: Option<f64>,
    measured_texel_noise: f64,
    image: Image,
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let arg = |i: usize, default: &str| args.get(i).cloned().unwrap_or_else(|| default.into());
    let scene_spec = arg(0, "builtin:cornell");
    let probes_spec = arg(1, "grid:3x3x3");
    let resolution: u32 = arg(2, "128").parse()?;
    let size = arg(3, "256x256");
    let (width, height) = size.split_once('x').ok_or("size: WIDTHxHEIGHT")?;
    let (width, height): (u32, u32) = (width.parse()?, height.parse()?);
    let camera_name = arg(4, "default");
    let out = PathBuf::from(arg(5, "bake-convergence"));
    let configs: Vec<String> = if args.len() > 6 {
        args[6..].to_vec()
    } else {
        ["fixed:4", "adaptive", "fixed:64"]
            .map(String::from)
            .to_vec()
    };
    std::fs::create_dir_all(&out)?;

    let scene = Scene::open(&scene_spec)?;
    let probes = ProbeSet::from_spec(&probes_spec, &scene)?;
    let grid = ProbeGrid::detect(&probes.positions).ok_or("the probes must form a regular grid")?;
    let camera = if camera_name == "default" {
        scene.default_camera()
    } else {
        find_camera(&scene, &camera_name)?
    };
    let settings = ViewSettings {
        width,
        height,
        shading_samples: 64,
        ..ViewSettings::default()
    };
    let start = Instant::now();
    let mut view = EvalView::render(&scene, camera, settings, &|_, _| {})?;
    println!(
        "{scene_spec}: {} probes at {resolution}², {width}×{height} from {camera_name}; first reference {:.1} s",
        probes.positions.len(),
        start.elapsed().as_secs_f64()
    );
    let index = build_index(&scene, &probes.positions, 7, Some(grid), 0)?;
    let mut device = Device::cpu();
    let rays = view.trace_rays();

    let mut rows = Vec::new();
    for config in &configs {
        let sampling = parse_sampling(config);
        let mut images = Vec::new();
        let mut bakes = Vec::new();
        let mut seconds = [0.0; 2];
        for (k, seed) in [0u64, 1].into_iter().enumerate() {
            let (baked, s) = bake_for_view_seeded(
                &scene,
                &probes.positions,
                resolution,
                sampling,
                &view,
                seed,
                &|_, _| {},
            )?;
            seconds[k] = s;
            let traced = trace_only(
                &mut device,
                &scene,
                &baked,
                &index,
                &view,
                &rays,
                Tracer::HiZ,
                Selection::Grid,
                None,
            )?
            .ok_or("no grid selection")?;
            images.push(traced.image);
            bakes.push(baked);
        }
        let row = Row {
            name: config.clone(),
            seconds,
            samples_per_texel: bakes[0].mean_samples_per_texel(),
            noise: tonemapped_mse(&images[0], &images[1]) / 2.0,
            error: f64::NAN,
            estimated_texel_noise: bakes[0]
                .noise()
                .zip(bakes[1].noise())
                .map(|(a, b)| (a + b) / 2.0),
            measured_texel_noise: measured_texel_noise(&bakes[0], &bakes[1]),
            image: images.swap_remove(0),
        };
        println!(
            "  {config}: bakes {:.1} s / {:.1} s, {:.2} samples per texel",
            row.seconds[0], row.seconds[1], row.samples_per_texel
        );
        rows.push(row);
    }
    {
        let images: Vec<&Image> = rows.iter().map(|r| &r.image).collect();
        view.refine(&scene, &images, 0.05, 8192, &|_, _| {})?;
    }
    let noise = view.reference_noise;
    for row in &mut rows {
        row.error = tonemapped_mse(&row.image, &view.reference_image);
    }

    let mut md = String::new();
    let _ = writeln!(
        md,
        "{scene_spec}, {} probes (`{probes_spec}`) at {resolution}², {width}×{height} from camera `{camera_name}`, grid cage + hi-Z (CPU twin), {} thread(s). Reference: {} samples per hit, noise {:.2e} ({}).\n",
        probes.positions.len(),
        rayon::current_num_threads(),
        noise.samples,
        noise.noise,
        if noise.converged {
            "≤ 5 % of the smallest error"
        } else {
            "not yet 5 % of the smallest error: the sample cap was reached"
        }
    );
    let _ = writeln!(
        md,
        "| sampling | bake (s), seeds 0 / 1 | samples per texel | error (tone-mapped MSE) | bake noise (two seeds) | noise / error | texel noise: manifest | texel noise: two seeds | manifest / measured |"
    );
    let _ = writeln!(md, "|---|---|---|---|---|---|---|---|---|");
    let mut json_rows = Vec::new();
    for row in &rows {
        let ratio = row
            .estimated_texel_noise
            .map(|e| e / row.measured_texel_noise);
        let _ = writeln!(
            md,
            "| {} | {:.1} / {:.1} | {:.2} | {:.3e} | {:.2e} | {:.0} % | {} | {:.2e} | {} |",
            row.name,
            row.seconds[0],
            row.seconds[1],
            row.samples_per_texel,
            row.error,
            row.noise,
            100.0 * row.noise / row.error,
            row.estimated_texel_noise
                .map_or("—".to_owned(), |v| format!("{v:.2e}")),
            row.measured_texel_noise,
            ratio.map_or("—".to_owned(), |r| format!("{r:.2}")),
        );
        json_rows.push(serde_json::json!({
            "sampling": row.name,
            "bake_seconds": row.seconds,
            "samples_per_texel": row.samples_per_texel,
            "error": row.error,
            "bake_noise": row.noise,
            "estimated_texel_noise": row.estimated_texel_noise,
            "measured_texel_noise": row.measured_texel_noise,
        }));
    }
    print!("{md}");
    std::fs::write(out.join("convergence.md"), &md)?;
    std::fs::write(
        out.join("convergence.json"),
        serde_json::to_string_pretty(&serde_json::json!({
            "scene": scene_spec,
            "probes": probes_spec,
            "resolution": resolution,
            "width": width,
            "height": height,
            "camera": camera_name,
            "reference_samples": noise.samples,
            "reference_noise": noise.noise,
            "rows": json_rows,
        }))?,
    )?;
    let exposure = view.reference_image.auto_exposure();
    let mut strip = Image::new(width * (rows.len() as u32 + 1), height);
    for (k, image) in rows
        .iter()
        .map(|r| &r.image)
        .chain(std::iter::once(&view.reference_image))
        .enumerate()
    {
        for y in 0..height {
            for x in 0..width {
                let source = image.rgb[(y * width + x) as usize];
                strip.rgb[(y * strip.width + k as u32 * width + x) as usize] = source;
            }
        }
    }
    strip.save_png_with_exposure(out.join("side_by_side.png"), exposure)?;
    for row in &rows {
        let name = row.name.replace(':', "_");
        row.image
            .save_png_with_exposure(out.join(format!("glossy_{name}.png")), exposure)?;
    }
    view.reference_image
        .save_png_with_exposure(out.join("reference.png"), exposure)?;
    Ok(())
}
