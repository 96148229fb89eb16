//! The final image through probes against the path-traced final image, on any scene:
//! per probe set, two bakes (seeds 0 and 1, for the bake's noise), the final image through the
//! first (and through it again with another render seed, for the render's own noise), the
//! path-traced reference in two halves (for its noise), the tone-mapped MSE of the image and
//! of each part with all three noise floors, FLIP, and each part's time.
//!
//! ```text
//! cargo run --release -p probe-eval --example final_image -- SCENE CAMERA OUT \
//!     [--res N] [--size WxH] [--spp N] [--sectors K] LABEL=PROBES.json...
//! ```
//!
//! `SCENE` is a glTF file or `builtin:NAME`; `PROBES.json` is what `probes place --out`
//! writes. Each set is rendered with filtered specular rays blended over the default 6 probes
//! (`filtered-blend-6`), filtered rays read from the answering probe alone
//! (`filtered-one-probe`) and stochastic specular rays (`stochastic`; one per pixel); with
//! `--sectors K` (2 to 8) also filtered rays over the default blend with each glossy lobe cut
//! into K narrower cones (`filtered-blend-6-sectors-K`, `FinalOptions::specular_sectors`). Writes
//! to `OUT/`: `reference.png`, and per set and mode `LABEL_MODE.png` (probes | reference |
//! error map, at the reference's exposure) and `LABEL_MODE_parts.png` (direct, diffuse,
//! specular through the probes, then the reference's), and prints a Markdown table. The bakes are kept
//! in `OUT/bakes/` and reused by later runs with the same probes and resolution (`bake (s)`
//! is then NaN), so a change to the renderer is measured on the same bakes.

use probe_capture::FinalParts;
use probe_capture::{BakeSettings, Image, ProbeBake, bake, no_progress, render_gbuffer};
use probe_eval::final_render::{
    DiffuseBlend, FinalOptions, FinalReference, PartErrors, SpecularMode, reference_final,
    render_and_compare, specular_name,
};
use probe_eval::pipeline::{Device, build_index};
use probe_index::ProbeGrid;
use probe_place::ProbeSet;
use probe_scene::Scene;
use std::path::PathBuf;
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let mut take = |flag: &str| -> Option<String> {
        let at = args.iter().position(|a| a == flag)?;
        let value = args.get(at + 1).cloned();
        args.drain(at..(at + 2).min(args.len()));
        value
    };
    let resolution: u32 = take("--res").map_or(Ok(128), |v| v.parse())?;
    let spp: u32 = take("--spp").map_or(Ok(256), |v| v.parse())?;
    let sectors: u32 = take("--sectors").map_or(Ok(1), |v| v.parse())?;
    let (width, height) = match take("--size") {
        Some(size) => {
            let (w, h) = size.split_once('x').ok_or("--size WxH")?;
            (w.parse()?, h.parse()?)
        }
        None => (320u32, 180u32),
    };
    let [scene_spec, camera_name, out, sets @ ..] = &args[..] else {
        return Err(
            "usage: final_image SCENE CAMERA OUT [--res N] [--size WxH] [--spp N] [--sectors K] \
                    LABEL=PROBES.json..."
                .into(),
        );
    };
    let out = PathBuf::from(out);
    std::fs::create_dir_all(&out)?;
    let scene = match scene_spec.strip_prefix("builtin:") {
        Some(name) => Scene::builtin(name)?,
        None => Scene::load(scene_spec)?,
    };
    let camera = if camera_name == "default" {
        scene.default_camera()
    } else {
        scene
            .camera(camera_name)
            .cloned()
            .ok_or_else(|| format!("no camera {camera_name}"))?
    };
    let gbuffer = render_gbuffer(&scene, &camera, width, height)?;
    let (mut device, _) = Device::open(false)?;
    eprintln!("device: {}", device.describe());

    let mut rows = Vec::new();
    let mut reference = None;
    for spec in sets {
        let (label, path) = spec.split_once('=').ok_or("give LABEL=PROBES.json")?;
        let probes = ProbeSet::load(path)?;
        let positions = &probes.positions;
        let settings = |seed| BakeSettings {
            resolution,
            seed,
            ..BakeSettings::default()
        };
        // Bakes are kept in OUT/bakes/ and reused by later runs (delete them to re-bake).
        let cached = |seed: u64| -> Result<(ProbeBake, f64), Box<dyn std::error::Error>> {
            let dir = out.join("bakes").join(format!("{label}.seed{seed}"));
            if dir.exists() {
                let baked = ProbeBake::load(&dir, Some(&scene))?;
                if baked.positions() == positions.as_slice()
                    && baked.settings().resolution == resolution
                    && baked.settings().surfel_resolution == settings(seed).surfel_resolution
                {
                    return Ok((baked, f64::NAN));
                }
            }
            let start = Instant::now();
            let baked = bake(&scene, positions, &settings(seed), &no_progress)?;
            let seconds = start.elapsed().as_secs_f64();
            baked.save(&dir)?;
            Ok((baked, seconds))
        };
        let (baked, bake_seconds) = cached(0)?;
        let (second, _) = cached(1)?;
        eprintln!(
            "{label}: {} probes baked at {resolution}² in {bake_seconds:.1} s",
            positions.len()
        );
        let grid = ProbeGrid::detect(baked.positions());
        let index = build_index(&scene, baked.positions(), 7, grid, 0)?;
        if reference.is_none() {
            eprintln!("path tracing the final image at {width}×{height}, {spp} spp per part");
            let r = cached_reference(&out, spp, || {
                reference_final(&scene, &baked, &gbuffer, spp, 0, &no_progress)
            })?;
            eprintln!("  {:.1} s, noise {:.2e}", r.seconds, r.noise.image);
            let truth = r.parts.sum();
            truth.save_png_with_exposure(out.join("reference.png"), truth.auto_exposure())?;
            reference = Some(r);
        }
        let reference = reference.as_ref().expect("rendered above");
        // Filtered specular blended over the default 6 probes (and again with the diffuse
        // part's near-field correction off), read from the answering probe alone, and
        // stochastic: one run, so the ratios between them share the load.
        let blended = FinalOptions::default().glossy_blend;
        let mut modes = vec![
            (SpecularMode::Filtered, blended, true, 1),
            (SpecularMode::Filtered, blended, false, 1),
            (SpecularMode::Filtered, 0, true, 1),
            (SpecularMode::Stochastic, blended, true, 1),
        ];
        if sectors > 1 {
            modes.insert(1, (SpecularMode::Filtered, blended, true, sectors));
        }
        for (specular, glossy_blend, parallax, specular_sectors) in modes {
            let mut mode = match (specular, glossy_blend) {
                (SpecularMode::Filtered, 0) => "filtered-one-probe".to_owned(),
                (SpecularMode::Filtered, k) => format!("filtered-blend-{k}"),
                (SpecularMode::Stochastic, _) => specular_name(specular).to_owned(),
            };
            if specular_sectors > 1 {
                mode.push_str(&format!("-sectors-{specular_sectors}"));
            }
            if !parallax {
                mode.push_str("+no-parallax");
            }
            let defaults = FinalOptions::default();
            let options = FinalOptions {
                blend: if grid.is_some() {
                    DiffuseBlend::Grid
                } else {
                    DiffuseBlend::Delaunay
                },
                specular,
                glossy_blend,
                specular_sectors,
                diffuse: probe_trace_gpu::DiffuseOptions {
                    parallax,
                    ..defaults.diffuse
                },
                ..defaults
            };
            let (first, c) = render_and_compare(
                &mut device,
                &scene,
                &baked,
                Some(&second),
                &index,
                &gbuffer,
                &options,
                reference,
            )?;
            let truth = reference.parts.sum();
            let exposure = truth.auto_exposure();
            let image = first.parts.sum();
            strip(
                &[&image, &truth, &error_map(&image, &truth)],
                &[exposure, exposure, 1.0],
            )
            .save_png_with_exposure(out.join(format!("{label}_{mode}.png")), 1.0)?;
            strip(
                &[
                    &first.parts.direct,
                    &first.parts.diffuse,
                    &first.parts.specular,
                    &reference.parts.direct,
                    &reference.parts.diffuse,
                    &reference.parts.specular,
                ],
                &[exposure; 6],
            )
            .save_png_with_exposure(out.join(format!("{label}_{mode}_parts.png")), 1.0)?;
            let cell = |part: fn(&PartErrors) -> f64| {
                format!(
                    "{:.2e} ({:.0e} / {:.0e} / {:.0e})",
                    part(&c.mse),
                    part(&c.reference_noise),
                    c.bake_noise.as_ref().map_or(f64::NAN, part),
                    c.render_noise.as_ref().map_or(f64::NAN, part),
                )
            };
            let t = c.times;
            rows.push(format!(
            "| {label} | {} | {} | {mode} | {} | {} | {} | {} | {:.4} | {:.1} | {:.1} | {:.1} | {:.1} |",
            positions.len(),
            if grid.is_some() { "grid" } else { "delaunay" },
            cell(|p| p.image),
            cell(|p| p.direct),
            cell(|p| p.diffuse),
            cell(|p| p.specular),
            c.flip,
            t.direct_ms,
            t.diffuse_gpu_ms.unwrap_or(t.diffuse_ms),
            t.specular_gpu_ms.unwrap_or(t.specular_ms),
            bake_seconds,
        ));
        }
    }
    let reference = reference.ok_or("give at least one probe set")?;
    println!(
        "{} from {}, {width}×{height}; reference {} spp per part in {:.1} s; device {}. \
         Tone-mapped MSE (noise floors: reference / bake / render).\n",
        scene.name(),
        camera.name,
        reference.samples,
        reference.seconds,
        device.describe()
    );
    println!(
        "| probes | count | diffuse blend | specular rays | final | direct | diffuse | specular | FLIP | direct (ms) | diffuse (ms) | specular (ms) | bake (s) |"
    );
    println!("|---|---:|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for row in rows {
        println!("{row}");
    }
    Ok(())
}

/// The reference kept in `OUT/reference/` (its parts as EXR, its noise and samples as JSON)
/// by an earlier run with the same samples, or `render`'s, then kept.
fn cached_reference(
    out: &std::path::Path,
    spp: u32,
    render: impl FnOnce() -> Result<FinalReference, probe_eval::EvalError>,
) -> Result<FinalReference, Box<dyn std::error::Error>> {
    let dir = out.join("reference");
    let meta = dir.join("reference.json");
    if let Ok(text) = std::fs::read_to_string(&meta) {
        let v: serde_json::Value = serde_json::from_str(&text)?;
        if v["samples"].as_u64() == Some(u64::from(spp)) {
            let noise = |k: &str| v["noise"][k].as_f64().unwrap_or(f64::NAN);
            return Ok(FinalReference {
                parts: FinalParts {
                    direct: Image::load_exr(dir.join("direct.exr"))?,
                    diffuse: Image::load_exr(dir.join("diffuse.exr"))?,
                    specular: Image::load_exr(dir.join("specular.exr"))?,
                },
                noise: PartErrors {
                    image: noise("image"),
                    direct: noise("direct"),
                    diffuse: noise("diffuse"),
                    specular: noise("specular"),
                },
                samples: spp,
                seconds: v["seconds"].as_f64().unwrap_or(f64::NAN),
            });
        }
    }
    let r = render()?;
    std::fs::create_dir_all(&dir)?;
    r.parts.direct.save_exr(dir.join("direct.exr"))?;
    r.parts.diffuse.save_exr(dir.join("diffuse.exr"))?;
    r.parts.specular.save_exr(dir.join("specular.exr"))?;
    let json = serde_json::json!({ "samples": spp, "seconds": r.seconds, "noise": r.noise });
    std::fs::write(&meta, serde_json::to_string_pretty(&json)?)?;
    Ok(r)
}

/// Images side by side, each pre-scaled by its exposure (the strip is saved at exposure 1).
fn strip(images: &[&Image], exposures: &[f32]) -> Image {
    let (w, h) = (images[0].width, images[0].height);
    let mut out = Image::new(w * images.len() as u32, h);
    for (i, (image, exposure)) in images.iter().zip(exposures).enumerate() {
        for y in 0..h as usize {
            for x in 0..w as usize {
                let v = image.rgb[y * w as usize + x];
                out.rgb[y * out.width as usize + i * w as usize + x] =
                    [v[0] * exposure, v[1] * exposure, v[2] * exposure];
            }
        }
    }
    out
}

/// |probes − reference| per pixel over the reference's mean luminance, clamped to 1, as
/// black → red → yellow → white (the demo's error maps).
fn error_map(image: &Image, reference: &Image) -> Image {
    let mean = (reference.mean().element_sum() / 3.0).max(1e-6);
    let mut out = Image::new(image.width, image.height);
    for ((o, a), b) in out.rgb.iter_mut().zip(&image.rgb).zip(&reference.rgb) {
        let e = ((0..3).map(|c| (a[c] - b[c]).abs()).sum::<f32>() / 3.0 / mean).clamp(0.0, 1.0);
        *o = [
            (3.0 * e).min(1.0),
            (3.0 * e - 1.0).clamp(0.0, 1.0),
            (3.0 * e - 2.0).clamp(0.0, 1.0),
        ];
    }
    out
}
