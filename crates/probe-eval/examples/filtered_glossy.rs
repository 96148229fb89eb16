//! Filtered glossy (issue 14, item 2): one cone ray per pixel through the probes' prefiltered
//! radiance pyramid against many stochastic GGX rays through the same probes and against the
//! path-traced truth, at several roughnesses: tone-mapped MSE, FLIP and trace time.
//!
//! ```text
//! cargo run --release -p probe-eval --example filtered_glossy -- \
//!     [SCENE] [PROBES] [RESOLUTION] [WIDTH]x[HEIGHT] [CAMERA] [OUT] [NAME] [ROUGHNESS ...]
//! ```
//!
//! Defaults: `builtin:cornell grid:3x3x3 64 256x256 default docs/glossy cornell 0.1 0.3 0.6`.
//! The environment may set `GLOSSY_BLEND` (the filtered rays' `TraceOptions::glossy_blend`,
//! default: the tracer's), `STOCHASTIC_SEED` (the 16 stochastic rays' seed, default 1),
//! `CONE_MAX_PROBES` and `CONE_NEAREST` (the cone rays' `TraceOptions::max_probes` and
//! `nearest_candidates`, default: the tracer's), `STOCHASTIC_MAX_PROBES` (the 16 stochastic
//! rays' `max_probes`, default: the tracer's),
//! `FILTERED_SPLIT=K` (a further row: the lobe cut into `K` sectors, one narrower cone each,
//! `probe_eval::glossy::sub_lobe_rays`), `FILTERED_INTERLEAVE=K` (a further row: the lobe
//! cut into `K` = 2 or 4 parts, each pixel tracing one and taking the others from its
//! neighbours, `probe_eval::glossy::interleaved_sub_lobe_rays`; its time is the trace's plus
//! the resolve's on the CPU; with it the picture gains a fifth column) and `BAKE_NOISE=1` (a second bake of the same probes
//! with the next seed: every probe image is traced through both bakes, and each row gains the
//! second bake's MSE and the bake's noise, half the tone-mapped MSE between the two images).
//! One bake (the library's default adaptive sampling, the view's lighting, seed 7), uploaded
//! once with 6 prefiltered glossy levels to the GPU (lavapipe here) or, without an adapter, the
//! CPU twin; the regular grid's cage selects probes, hi-Z traces. Per roughness:
//!
//! - **reference**: the path-traced glossy component of 64 GGX rays per pixel
//!   (`EvalView::render`, 2 shading samples per hit); its noise floor is the tone-mapped MSE
//!   between its even and odd rays' images over 4 (lobe and shading noise of the 64-ray mean);
//! - **probes, 64 rpp**: the same 64 rays per pixel traced through the probes (what the
//!   stochastic estimate converges to);
//! - **stochastic 16 rpp**: 16 GGX rays per pixel (another seed) through the probes;
//! - **filtered 1 rpp**: one ray per pixel along the GGX lobe's mean, traced with
//!   `glossy_roughness` and weighted with the lobe's mean weight
//!   (`probe_eval::glossy::filtered_reflection_rays`).
//!
//! Trace times of the filtered and stochastic images are the median of 3 calls after a warm-up
//! call (GPU timestamps when the device has them, else wall time); the 64-rpp trace runs once.
//! The blended filtered image's error is then split by what each pixel's centre ray answered
//! against the BVH's closest hit (`probe_eval::metrics::classify_pixels`: correct hit, right
//! surface with wrong radiance, wrong hit, UNKNOWN, ...), against the reference and against the
//! probes' 64-ray image, and each image's error is split by the angle the camera sees the
//! surface at (bins of `n·v`). Each trace prints its `TraceSummary` (UNKNOWN share, probes
//! and texel fetches per ray). Prints a Markdown table and writes `OUT/NAME.png`: per roughness
//! a row filtered 1 rpp by one probe | filtered 1 rpp blended | stochastic 16 rpp | reference, at
//! the reference's exposure.

use std::path::PathBuf;
use std::time::Instant;

use glam::Vec3;
use probe_capture::{
    EvaluationRay, Image, ReferenceSample, Reflection, Sampling, TileOrder, accumulate_rays,
    find_camera, reflection_rays, render_gbuffer,
};
use probe_eval::glossy::{
    InterleavedSubLobes, filtered_reflection_rays, interleaved_sub_lobe_rays, sub_lobe_rays,
    sub_lobe_roughness,
};
use probe_eval::metrics::{Footprints, classify_pixels, flip, tonemapped_mse};
use probe_eval::pipeline::{
    Device, EvalView, Selection, ViewSettings, bake_for_view_seeded, build_index, light_field,
};
use probe_index::ProbeGrid;
use probe_place::ProbeSet;
use probe_scene::{Ray, Scene};
use probe_trace_gpu::{AnyField, FieldOptions, RayResult, TraceOptions, TraceRay, TraceSummary};

const REFERENCE_RPP: u32 = 64;
const STOCHASTIC_RPP: u32 = 16;
const GLOSSY_LEVELS: u32 = 6;

/// Milliseconds of the median of `repeats` traces (after a warm-up call), and the last
/// trace's image.
fn timed_image(
    device: &mut Device,
    field: &AnyField,
    rays: &[EvaluationRay],
    options: &TraceOptions,
    size: (u32, u32),
    repeats: usize,
) -> Result<(Image, f64, Vec<RayResult>), Box<dyn std::error::Error>> {
    // Traced in 8×8 pixel tiles, as the renderers do.
    let order = TileOrder::of(rays, size.0);
    let trace_rays: Vec<TraceRay> = order
        .apply(rays)
        .iter()
        .map(|r| TraceRay::new(r.origin, r.direction))
        .collect();
    device.trace(field, &trace_rays[..trace_rays.len().min(4096)], options)?;
    let mut times = Vec::new();
    let mut last = None;
    for _ in 0..repeats {
        let output = device.trace(field, &trace_rays, options)?;
        let t = output.timing.gpu.unwrap_or(output.timing.wall);
        times.push(t.as_secs_f64() * 1e3);
        last = Some(order.restore(output.results));
    }
    times.sort_by(f64::total_cmp);
    let results = last.unwrap_or_default();
    let median = times[times.len() / 2];
    let summary = TraceSummary::of(&results);
    println!(
        "  (trace of {} rays: {:.1} % UNKNOWN, {:.2} probes and {:.1} texel fetches per ray, {median:.1} ms)",
        summary.rays,
        100.0 * summary.unknown_rate(),
        summary.probes_per_ray,
        summary.fetches_per_ray,
    );
    let radiance: Vec<Vec3> = results.iter().map(|r| r.radiance).collect();
    Ok((
        accumulate_rays(size.0, size.1, rays, &radiance)?,
        median,
        results,
    ))
}

/// With a second bake (`BAKE_NOISE`): the image of the same rays traced through it (resolved
/// by `interleaved` where the rays are interleaved sub-lobes), printed as a row under `label`
/// with its MSE against the reference and the bake's noise (half the tone-mapped MSE between
/// the two bakes' images, the variance of one).
#[allow(
    clippy::too_many_arguments,
    reason = "one image's rays and options, and the images it is compared with"
)]
fn second_bake_row(
    device: &mut Device,
    fields: &[AnyField],
    rays: &[EvaluationRay],
    options: &TraceOptions,
    size: (u32, u32),
    first: &Image,
    reference: &Image,
    label: &str,
    roughness: f32,
    interleaved: Option<&InterleavedSubLobes>,
) -> Result<(), Box<dyn std::error::Error>> {
    let Some(second) = fields.get(1) else {
        return Ok(());
    };
    let (mut image, _, results) = timed_image(device, second, rays, options, size, 1)?;
    if let Some(lobes) = interleaved {
        let radiance: Vec<Vec3> = results.iter().map(|r| r.radiance).collect();
        image = lobes.resolve(&radiance);
    }
    println!(
        "| {roughness} | {label}, second bake | | {:.3e} | | bake noise {:.2e} | | |",
        tonemapped_mse(&image, reference),
        tonemapped_mse(first, &image) / 2.0,
    );
    Ok(())
}

/// Bins of `n·v` (shading normal against the direction to the camera), grazing first.
const VIEW_BINS: [f32; 7] = [0.0, 0.1, 0.2, 0.35, 0.5, 0.7, 1.0];

/// Each [`VIEW_BINS`] bin's share of the image's pixels and its pixels' part of the
/// tone-mapped MSE of `image` against `reference` (the parts sum to the image's MSE; pixels
/// without a front-facing surface count in no bin).
fn error_by_view_angle(
    gbuffer: &probe_capture::GBuffer,
    image: &Image,
    reference: &Image,
) -> Vec<(f64, f64)> {
    let map = |v: f32| {
        let v = f64::from(v.max(0.0));
        v / (1.0 + v)
    };
    let n = image.rgb.len().max(1) as f64;
    let mut bins = vec![(0.0f64, 0.0f64); VIEW_BINS.len() - 1];
    for (i, pixel) in gbuffer.pixels.iter().enumerate() {
        let Some(s) = pixel.filter(|s| !s.back_face) else {
            continue;
        };
        let cos = s.shading_normal.dot(s.towards_camera).clamp(0.0, 1.0);
        let bin = VIEW_BINS[1..]
            .iter()
            .position(|&edge| cos < edge)
            .unwrap_or(VIEW_BINS.len() - 2);
        let (a, b) = (image.rgb[i], reference.rgb[i]);
        let error: f64 = (0..3).map(|k| (map(a[k]) - map(b[k])).powi(2)).sum();
        bins[bin].0 += 1.0 / n;
        bins[bin].1 += error / (3.0 * n);
    }
    bins
}

/// The image of every other ray of each pixel (`parity` 0 or 1), weights doubled.
fn half_image(
    view: &EvalView,
    parity: usize,
    size: (u32, u32),
) -> Result<Image, Box<dyn std::error::Error>> {
    let mut rays = Vec::new();
    let mut radiance = Vec::new();
    let mut k = 0usize;
    let mut pixel = u32::MAX;
    for (ray, sample) in view.rays.iter().zip(&view.reference) {
        if ray.pixel != pixel {
            (pixel, k) = (ray.pixel, 0);
        }
        if k % 2 == parity {
            rays.push(EvaluationRay {
                weight: 2.0 * ray.weight,
                ..*ray
            });
            radiance.push(sample.radiance);
        }
        k += 1;
    }
    Ok(accumulate_rays(size.0, size.1, &rays, &radiance)?)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let arg = |i: usize, default: &str| args.get(i).cloned().unwrap_or_else(|| default.into());
    let scene_spec = arg(0, "builtin:cornell");
    let probes_spec = arg(1, "grid:3x3x3");
    let resolution: u32 = arg(2, "64").parse()?;
    let size = arg(3, "256x256");
    let (width, height) = size.split_once('x').ok_or("size: WIDTHxHEIGHT")?;
    let size: (u32, u32) = (width.parse()?, height.parse()?);
    let camera_name = arg(4, "default");
    let out = PathBuf::from(arg(5, "docs/glossy"));
    let name = arg(6, "cornell");
    let roughnesses: Vec<f32> = if args.len() > 7 {
        args[7..]
            .iter()
            .map(|r| r.parse())
            .collect::<Result<_, _>>()?
    } else {
        vec![0.1, 0.3, 0.6]
    };
    std::fs::create_dir_all(&out)?;
    let number = |name: &str, default: u64| -> Result<u64, Box<dyn std::error::Error>> {
        match std::env::var(name) {
            Ok(value) => Ok(value
                .parse()
                .map_err(|e| format!("{name}={value}: {e} (give a whole number)"))?),
            Err(_) => Ok(default),
        }
    };
    // A whole number that must also fit a u32.
    let count = |name: &str, default: u32| -> Result<u32, Box<dyn std::error::Error>> {
        Ok(u32::try_from(number(name, u64::from(default))?)?)
    };
    let defaults = TraceOptions::default();
    let glossy_blend = count("GLOSSY_BLEND", defaults.glossy_blend)?;
    let stochastic_seed = number("STOCHASTIC_SEED", 1)?;
    let sectors = count("FILTERED_SPLIT", 1)?;
    let interleave = count("FILTERED_INTERLEAVE", 1)?;
    let bake_noise = number("BAKE_NOISE", 0)? != 0;
    let cone_max_probes = count("CONE_MAX_PROBES", defaults.max_probes)?;
    let stochastic_max_probes = count("STOCHASTIC_MAX_PROBES", defaults.max_probes)?;
    let cone_nearest = count("CONE_NEAREST", defaults.nearest_candidates)?;

    let scene = Scene::open(&scene_spec)?;
    let probes = ProbeSet::from_spec(&probes_spec, &scene)?;
    let grid = ProbeGrid::detect(&probes.positions).ok_or("the probes must form a regular grid")?;
    let camera = if camera_name == "default" {
        scene.default_camera()
    } else {
        find_camera(&scene, &camera_name)?
    };
    let settings = |roughness: f32| ViewSettings {
        width: size.0,
        height: size.1,
        rays_per_pixel: REFERENCE_RPP,
        roughness,
        shading_samples: 2,
        ..ViewSettings::default()
    };
    let (mut device, fallback) = Device::open(false)?;
    if let Some(why) = fallback {
        println!("no GPU ({why}): the CPU twin traces");
    }
    let gbuffer = render_gbuffer(&scene, &camera, size.0, size.1)?;

    // One field per bake: the first, and with `BAKE_NOISE` a second of the next seed.
    let mut fields: Vec<AnyField> = Vec::new();
    let mut baked = None;
    let mut panels: Vec<Vec<Image>> = Vec::new();
    println!(
        "{scene_spec}: {} probes at {resolution}², {}×{} from {camera_name}, {}",
        probes.positions.len(),
        size.0,
        size.1,
        device.describe()
    );
    println!(
        "| roughness | image | rays | MSE vs reference | FLIP vs reference | MSE vs probes 64 rpp | trace ms | rays ms (CPU) |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    for &roughness in &roughnesses {
        let start = Instant::now();
        let view = EvalView::render(&scene, camera.clone(), settings(roughness), &|_, _| {})?;
        let reference_seconds = start.elapsed().as_secs_f64();
        if baked.is_none() {
            let index = build_index(&scene, &probes.positions, 7, Some(grid), 0)?;
            let selection = Selection::Grid.of(&index).ok_or("grid selection")?;
            let seeds = if bake_noise { 2 } else { 1 };
            for k in 0..seeds {
                let start = Instant::now();
                let (bake, _) = bake_for_view_seeded(
                    &scene,
                    &probes.positions,
                    resolution,
                    Sampling::default(),
                    &view,
                    view.settings.seed + k,
                    &|_, _| {},
                )?;
                let bake_seconds = start.elapsed().as_secs_f64();
                let start = Instant::now();
                fields.push(device.upload_with(
                    &light_field(&bake),
                    &selection,
                    &FieldOptions {
                        glossy_levels: GLOSSY_LEVELS,
                        ..FieldOptions::default()
                    },
                )?);
                println!(
                    "bake (seed {}) {bake_seconds:.1} s; upload with {GLOSSY_LEVELS} glossy levels {:.2} s",
                    view.settings.seed + k,
                    start.elapsed().as_secs_f64()
                );
                if k == 0 {
                    baked = Some(bake);
                }
            }
        }
        let field = fields.first().ok_or("uploaded")?;
        let reference = &view.reference_image;
        let floor =
            tonemapped_mse(&half_image(&view, 0, size)?, &half_image(&view, 1, size)?) / 4.0;
        println!(
            "reference {reference_seconds:.1} s, noise floor (even/odd rays) {floor:.2e}, shading noise {:.2e}",
            view.reference_noise.noise
        );

        let plain = TraceOptions::default();
        let stochastic_options = TraceOptions {
            max_probes: stochastic_max_probes,
            ..plain
        };
        let (converged, converged_ms, _) =
            timed_image(&mut device, field, &view.rays, &plain, size, 1)?;
        let start = Instant::now();
        let stochastic_rays = reflection_rays(
            &gbuffer,
            Reflection::Ggx { roughness },
            STOCHASTIC_RPP,
            stochastic_seed,
        )?;
        let stochastic_rays_ms = start.elapsed().as_secs_f64() * 1e3;
        let (stochastic, stochastic_ms, _) = timed_image(
            &mut device,
            field,
            &stochastic_rays,
            &stochastic_options,
            size,
            3,
        )?;
        let start = Instant::now();
        let filtered_rays = filtered_reflection_rays(&gbuffer, roughness)?;
        let filtered_rays_ms = start.elapsed().as_secs_f64() * 1e3;
        let cone = TraceOptions {
            glossy_roughness: roughness,
            glossy_blend,
            max_probes: cone_max_probes,
            nearest_candidates: cone_nearest,
            ..TraceOptions::default()
        };
        let (filtered, filtered_ms, filtered_results) =
            timed_image(&mut device, field, &filtered_rays, &cone, size, 3)?;
        // The same cone rays read by the answering probe alone (no blend), as before.
        let single = TraceOptions {
            glossy_blend: 0,
            ..cone
        };
        let (unblended, unblended_ms, _) =
            timed_image(&mut device, field, &filtered_rays, &single, size, 3)?;
        for (label, image, rays, options, ms, rays_ms) in [
            (
                "filtered 1 rpp, one probe",
                &unblended,
                &filtered_rays,
                &single,
                unblended_ms,
                Some(filtered_rays_ms),
            ),
            (
                "filtered 1 rpp",
                &filtered,
                &filtered_rays,
                &cone,
                filtered_ms,
                Some(filtered_rays_ms),
            ),
            (
                "stochastic 16 rpp",
                &stochastic,
                &stochastic_rays,
                &stochastic_options,
                stochastic_ms,
                Some(stochastic_rays_ms),
            ),
            (
                "probes 64 rpp",
                &converged,
                &view.rays,
                &plain,
                converged_ms,
                None,
            ),
        ] {
            let (_, mean_flip) = flip(image, reference)?;
            println!(
                "| {roughness} | {label} | {} | {:.3e} | {mean_flip:.4} | {:.3e} | {ms:.1} | {} |",
                rays.len(),
                tonemapped_mse(image, reference),
                tonemapped_mse(image, &converged),
                rays_ms.map_or("–".to_owned(), |m| format!("{m:.1}")),
            );
            second_bake_row(
                &mut device,
                &fields,
                rays,
                options,
                size,
                image,
                reference,
                label,
                roughness,
                None,
            )?;
        }
        println!(
            "| {roughness} | filtered / stochastic time | | | | | {:.3} | |",
            filtered_ms / stochastic_ms
        );
        println!(
            "| {roughness} | filtered one probe / stochastic time | | | | | {:.3} | |",
            unblended_ms / stochastic_ms
        );
        // Optional: the lobe cut into K sectors, one narrower cone each (`FILTERED_SPLIT=K`).
        let mut by_angle = vec![
            ("filtered 1 rpp".to_owned(), filtered.clone()),
            ("stochastic 16 rpp".to_owned(), stochastic.clone()),
            ("probes 64 rpp".to_owned(), converged.clone()),
        ];
        if sectors > 1 {
            let rays = sub_lobe_rays(&gbuffer, roughness, sectors)?;
            let cone = TraceOptions {
                glossy_roughness: sub_lobe_roughness(roughness, sectors),
                ..cone
            };
            let (image, ms, _) = timed_image(&mut device, field, &rays, &cone, size, 3)?;
            let (_, mean_flip) = flip(&image, reference)?;
            println!(
                "| {roughness} | filtered {sectors} rpp (sub-lobes) | {} | {:.3e} | {mean_flip:.4} | {:.3e} | {ms:.1} | – |",
                rays.len(),
                tonemapped_mse(&image, reference),
                tonemapped_mse(&image, &converged),
            );
            second_bake_row(
                &mut device,
                &fields,
                &rays,
                &cone,
                size,
                &image,
                reference,
                "sub-lobes",
                roughness,
                None,
            )?;
            println!(
                "| {roughness} | filtered {sectors} rpp / stochastic time | | | | | {:.3} | |",
                ms / stochastic_ms
            );
            by_angle.insert(1, (format!("filtered {sectors} rpp"), image));
        }
        let mut interleaved = None;
        // Optional: interleaved sub-lobes, one part per pixel shared with its neighbours
        // (`FILTERED_INTERLEAVE=K`, K = 2 or 4).
        if interleave > 1 {
            let lobes = interleaved_sub_lobe_rays(&gbuffer, roughness, interleave)?;
            let cone = TraceOptions {
                glossy_roughness: sub_lobe_roughness(roughness, interleave),
                ..cone
            };
            // The traced parts alone (each ray weighted by its share), then resolved.
            let (_, ms, results) = timed_image(&mut device, field, lobes.rays(), &cone, size, 3)?;
            let radiance: Vec<Vec3> = results.iter().map(|r| r.radiance).collect();
            let start = Instant::now();
            let image = lobes.resolve(&radiance);
            let resolve_ms = start.elapsed().as_secs_f64() * 1e3;
            let (_, mean_flip) = flip(&image, reference)?;
            println!(
                "| {roughness} | filtered, {interleave} interleaved sub-lobes (1 rpp) | {} | {:.3e} | {mean_flip:.4} | {:.3e} | {ms:.1} | resolve {resolve_ms:.1} |",
                lobes.rays().len(),
                tonemapped_mse(&image, reference),
                tonemapped_mse(&image, &converged),
            );
            second_bake_row(
                &mut device,
                &fields,
                lobes.rays(),
                &cone,
                size,
                &image,
                reference,
                "interleaved",
                roughness,
                Some(&lobes),
            )?;
            println!(
                "| {roughness} | interleaved (trace + resolve) / stochastic time | | | | | {:.3} | |",
                (ms + resolve_ms) / stochastic_ms
            );
            by_angle.insert(1, (format!("interleaved {interleave}"), image.clone()));
            interleaved = Some(image);
        }
        // Where each image's error sits by the angle the camera sees the surface at.
        let columns: Vec<Vec<(f64, f64)>> = by_angle
            .iter()
            .map(|(_, image)| error_by_view_angle(&gbuffer, image, reference))
            .collect();
        println!(
            "| {roughness} | n·v bin | pixels | {} |",
            by_angle
                .iter()
                .map(|(label, _)| format!("MSE part, {label}"))
                .collect::<Vec<_>>()
                .join(" | ")
        );
        for (bin, edges) in VIEW_BINS.windows(2).enumerate() {
            println!(
                "| {roughness} | {:.2}–{:.2} | {:.1} % | {} |",
                edges[0],
                edges[1],
                100.0 * columns[0][bin].0,
                columns
                    .iter()
                    .map(|column| format!("{:.2e}", column[bin].1))
                    .collect::<Vec<_>>()
                    .join(" | ")
            );
        }
        // Where the blended filtered image's error sits: its pixels by what the centre ray's
        // answer was against the BVH's (the accuracy classes), with each class's share of the
        // MSE against the reference and against the probes' converged 64-ray image.
        let casts: Vec<Ray> = filtered_rays
            .iter()
            .map(|r| Ray::new(r.origin, r.direction))
            .collect();
        let truth: Vec<ReferenceSample> = scene
            .closest_hits(&casts, f32::INFINITY)
            .into_iter()
            .map(|hit| ReferenceSample {
                hit,
                radiance: Vec3::ZERO,
            })
            .collect();
        let bake = baked.as_ref().ok_or("baked")?;
        let classes = classify_pixels(
            Footprints::of(bake),
            &filtered_rays,
            &truth,
            &filtered_results,
            &filtered,
            reference,
        );
        let total_reference = tonemapped_mse(&filtered, reference);
        let total_converged = tonemapped_mse(&filtered, &converged);
        println!(
            "| {roughness} | filtered 1 rpp by class | pixels | MSE vs reference (share) | | MSE vs probes 64 rpp (share) | | |"
        );
        for (against_reference, against_converged) in classes
            .shares(&filtered, reference)
            .iter()
            .zip(classes.shares(&filtered, &converged))
        {
            if against_reference.pixels == 0.0 {
                continue;
            }
            println!(
                "| {roughness} | {} | {:.1} % | {:.2e} ({:.0} %) | | {:.2e} ({:.0} %) | | |",
                against_reference.class.name(),
                100.0 * against_reference.pixels,
                total_reference * against_reference.mse,
                100.0 * against_reference.mse,
                total_converged * against_converged.mse,
                100.0 * against_converged.mse,
            );
        }
        let mut row = vec![unblended, filtered];
        row.extend(interleaved);
        row.extend([stochastic, reference.clone()]);
        panels.push(row);
    }

    // The picture: a row per roughness, filtered | [interleaved |] stochastic | reference,
    // 4-pixel gaps.
    let gap = 4u32;
    let (w, h) = size;
    let rows = panels.len() as u32;
    let columns = panels.first().map_or(0, Vec::len) as u32;
    let mut picture = Image::new(
        columns * w + (columns - 1) * gap,
        rows * h + (rows - 1) * gap,
    );
    let exposure = panels
        .last()
        .and_then(|row| row.last())
        .map_or(1.0, Image::auto_exposure);
    for (row, images) in panels.iter().enumerate() {
        for (column, image) in images.iter().enumerate() {
            for y in 0..h {
                for x in 0..w {
                    let px = column as u32 * (w + gap) + x;
                    let py = row as u32 * (h + gap) + y;
                    picture.rgb[(py * picture.width + px) as usize] =
                        image.rgb[(y * w + x) as usize];
                }
            }
        }
    }
    let path = out.join(format!("{name}.png"));
    picture.save_png_with_exposure(&path, exposure)?;
    println!(
        "wrote {} (rows: roughness {roughnesses:?}; columns: filtered 1 rpp one probe | filtered 1 rpp blended | [interleaved sub-lobes |] stochastic 16 rpp | reference)",
        path.display()
    );
    Ok(())
}
