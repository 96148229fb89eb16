//! `probes demo`: the whole system on the built-in Cornell box, no files needed — place probes
//! (SDF skeleton refined by Gibbs sampling; the error-driven set for the demo's own camera at
//! the grid's count, issue 12's "where viewers go"; seed 000's 2×2×2 grid), bake them, index
//! them, trace the one-bounce glossy component through them with the GPU tracer (both
//! single-probe algorithms, and the hybrid: the BVH's hits, the probes' radiance), render the
//! path-traced reference, and tabulate probes, bake time, trace time, texel fetches per ray,
//! MSE, PSNR and FLIP, writing images and the table to a folder.
//!
//! Every MSE carries its noise floors. The reference is rendered after tracing until its
//! noise (two half-sample images, [`crate::convergence`]) is at most 5 % of the smallest
//! traced error, or a sample cap. Each placement is baked twice, with seeds `s` and `s + 1`:
//! half the tone-mapped MSE between the two traced images is the bake's noise (the variance
//! of one bake's image), reported beside the MSE of the first bake.
//!
//! Per configuration the demo writes the glossy image, an error map, an error-class image
//! (one colour per [`PixelClass`]: see the table's legend) and the FLIP error map (magma:
//! black = no visible difference, yellow-white = the most).

use std::fmt::Write as _;

use image::ImageEncoder as _;
use std::path::{Path, PathBuf};

use probe_capture::{Image, Sampling};
use probe_scene::Scene;
use serde::Serialize;

use probe_index::ProbeGrid;
use probe_place::pipeline::{Method, Optimizer, PlaceOptions};

use crate::convergence::ReferenceNoise;
use crate::final_render::{
    DiffuseBlend, FinalComparison, FinalOptions, PartErrors, SpecularMode, reference_final,
    render_and_compare, specular_name,
};
use crate::lighting::place_lit;
use crate::metrics::{Footprints, PixelClass, TraceMetrics, flip, flip_map_rgb8, tonemapped_mse};
use crate::pipeline::{
    Device, EvalView, ProbeMemory, Selection, TracedView, Tracer, ViewSettings, bake_for_view,
    bake_for_view_seeded, build_index, compare_trace, trace_only,
};
use crate::top_view::{TopViewOptions, write_top_view};
use crate::{EvalError, write_atomic};

/// What the demo runs.
#[derive(Clone, Debug, PartialEq)]
pub struct DemoOptions {
    /// Where the images and the table go.
    pub out: PathBuf,
    /// Fail instead of using the CPU twin when no GPU adapter exists.
    pub require_gpu: bool,
    /// Probe resolution (interior texels per side).
    pub resolution: u32,
    /// How many radiance samples the bakes take per texel.
    pub sampling: Sampling,
    /// Image side in pixels (the Cornell camera is square).
    pub image_size: u32,
    /// Gibbs iterations.
    pub gibbs_iterations: usize,
    /// The reference is refined until its noise is at most this share of the smallest traced
    /// tone-mapped MSE.
    pub reference_noise_fraction: f64,
    /// The most shading samples per reference hit.
    pub reference_max_samples: u32,
    /// A region of interest every placement stays in (`None`: the whole box).
    pub region: Option<probe_place::region::Region>,
    /// Samples per pixel of each part of the path-traced final image.
    pub final_reference_samples: u32,
    /// The bakes' radiance smoothing ([`probe_capture::BakeSettings::denoise`]; 0: off).
    pub bake_denoise: f32,
}

impl DemoOptions {
    /// The defaults: 128² probes, bakes sampled adaptively (8 to 512 samples per texel) to a
    /// quarter of [`Sampling::DEFAULT_NOISE_TARGET`], a 256² image, 30 Gibbs iterations, a
    /// reference refined to 5 % of the smallest error with at most 2048 samples per hit.
    ///
    /// At the default target the bakes' own noise in the glossy images was 9–38 % of their
    /// error (BENCHMARKS.md, "The demo: converged bakes and a set placed for its camera"); at
    /// a quarter it is 2–11 %, for 3–3.5× the bake time (a few seconds here).
    pub fn new(out: impl Into<PathBuf>) -> DemoOptions {
        DemoOptions {
            out: out.into(),
            require_gpu: false,
            resolution: 128,
            sampling: Sampling::adaptive(8, 512, Sampling::DEFAULT_NOISE_TARGET / 4.0),
            image_size: 256,
            gibbs_iterations: 30,
            reference_noise_fraction: 0.05,
            reference_max_samples: 2048,
            region: None,
            final_reference_samples: 512,
            bake_denoise: 0.0,
        }
    }
}

/// One row of the demo's table.
#[derive(Clone, Debug, Serialize)]
pub struct DemoRow {
    /// The placement.
    pub placement: String,
    /// Its probe count.
    pub probes: usize,
    /// Its coverage of the scene's surfaces (visibility atlas).
    pub coverage: f64,
    /// Seconds to place.
    pub place_seconds: f64,
    /// Seconds to bake.
    pub bake_seconds: f64,
    /// Mean radiance samples per texel the bake took.
    pub samples_per_texel: f64,
    /// The bake's own noise estimate (its manifest's mean texel noise, tone-mapped variance),
    /// beside the two-seed measurement in [`TraceMetrics::bake_noise`].
    pub bake_noise_estimate: Option<f64>,
    /// Seconds to build the indexes.
    pub index_seconds: f64,
    /// Bytes of the probe textures as traced.
    pub memory: ProbeMemory,
    /// The trace and its comparison with the reference.
    pub trace: TraceMetrics,
    /// The probes' glossy image (PNG).
    pub image: PathBuf,
    /// The error-class image (PNG).
    pub classes_image: PathBuf,
    /// The FLIP error map (PNG).
    pub flip_image: PathBuf,
}

/// One row of the final image's table: a placement's probes against the path-traced final
/// image.
#[derive(Clone, Debug, Serialize)]
pub struct FinalRow {
    /// The placement.
    pub placement: String,
    /// Its probe count.
    pub probes: usize,
    /// How the diffuse part blends the irradiance probes.
    pub blend: String,
    /// How the specular part was traced (`filtered` or `stochastic`, one ray per pixel).
    pub specular: String,
    /// Errors, noise floors, FLIP and times.
    pub comparison: FinalComparison,
    /// The final image (PNG).
    pub image: PathBuf,
}

/// The demo's result.
#[derive(Clone, Debug, Serialize)]
pub struct DemoReport {
    /// What traced the rays.
    pub device: String,
    /// Why the CPU twin was used, if it was.
    pub cpu_fallback_reason: Option<String>,
    /// Rays traced per configuration.
    pub rays: usize,
    /// Seconds to render the reference.
    pub reference_seconds: f64,
    /// The reference's samples per hit and its noise.
    pub reference: ReferenceNoise,
    /// The rows.
    pub rows: Vec<DemoRow>,
    /// The final image through each placement's probes against the path-traced one.
    pub finals: Vec<FinalRow>,
    /// Samples per pixel of each part of the final image's reference, and its seconds.
    pub final_reference: (u32, f64),
    /// The files written.
    pub files: Vec<PathBuf>,
}

impl DemoReport {
    /// The table as Markdown.
    pub fn markdown(&self) -> String {
        let mut text = String::new();
        let _ = writeln!(
            text,
            "Built-in Cornell box, one-bounce glossy (mirror) component, {} rays, traced on {}.\n",
            self.rays, self.device
        );
        let _ = writeln!(
            text,
            "| placement | probes | coverage | bake (s) | samples/texel | selection | tracer | trace (ms) | fetches/ray | probes/ray | hit agreement | MSE | MSE (tone-mapped) | reference noise | bake noise | bake noise (its estimate) | PSNR (dB) | FLIP |"
        );
        let _ = writeln!(
            text,
            "|---|---:|---:|---:|---:|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
        );
        for row in &self.rows {
            let t = &row.trace;
            let _ = writeln!(
                text,
                "| {} | {} | {:.1} % | {:.2} | {:.1} | {} | {} | {:.1} | {:.1} | {:.2} | {:.1} % | {:.3e} | {:.3e} | {:.1e} | {} | {} | {:.2} | {:.4} |",
                row.placement,
                row.probes,
                100.0 * row.coverage,
                row.bake_seconds,
                row.samples_per_texel,
                t.selection.name(),
                t.tracer.name(),
                t.trace_ms,
                t.fetches_per_ray,
                t.probes_per_ray,
                100.0 * t.status_agreement,
                t.mse,
                t.mse_tonemapped,
                t.reference_noise,
                t.bake_noise
                    .map_or("not measured".to_owned(), |n| format!("{n:.1e}")),
                row.bake_noise_estimate
                    .map_or("none".to_owned(), |n| format!("{n:.1e}")),
                t.psnr,
                t.flip
            );
        }
        let _ = writeln!(
            text,
            "\nNoise floors are tone-mapped variances, in the units of the tone-mapped MSE: an \
             image equal to the truth would still score about reference noise + bake noise. \
             Reference: {} shading samples per hit in {} passes, noise {:.2e}{}. Bake noise: \
             half the tone-mapped MSE between the images of two bakes with different seeds; \
             its estimate: the bake's own figure (its manifest's mean texel noise).",
            self.reference.samples,
            self.reference.passes,
            self.reference.noise,
            match self.reference.target {
                Some(target) if self.reference.converged =>
                    format!(" (target {target:.2e}, 5 % of the smallest error: met)"),
                Some(target) => format!(
                    " (target {target:.2e}, 5 % of the smallest error: not met within the sample cap)"
                ),
                None => String::new(),
            }
        );
        let _ = writeln!(
            text,
            "\nPixel classes (share of pixels / share of the tone-mapped MSE):\n"
        );
        let mut header = "| placement | selection | tracer |".to_owned();
        let mut rule = "|---|---|---|".to_owned();
        for class in PixelClass::ALL {
            let _ = write!(header, " {} |", class.name());
            rule.push_str("---:|");
        }
        let _ = writeln!(text, "{header}\n{rule}");
        for row in &self.rows {
            let t = &row.trace;
            let _ = write!(
                text,
                "| {} | {} | {} |",
                row.placement,
                t.selection.name(),
                t.tracer.name()
            );
            for share in &t.classes {
                let _ = write!(
                    text,
                    " {:.1} % / {:.1} % |",
                    100.0 * share.pixels,
                    100.0 * share.mse
                );
            }
            let _ = writeln!(text);
        }
        let _ = writeln!(text, "\n{}", class_legend());
        if !self.finals.is_empty() {
            let _ = writeln!(
                text,
                "\nThe final image (direct light with exact shadows + indirect diffuse from the \
                 irradiance probes + GGX specular through the light field; `probes render \
                 --component final`) against the path-traced final image ({} samples per pixel \
                 of each part, {:.1} s). Tone-mapped MSE per part, each with its noise floors \
                 (reference / bake / render: the reference's variance, half the MSE between \
                 two bakes with different seeds, half the MSE between two renders of one bake \
                 with different seeds).\n",
                self.final_reference.0, self.final_reference.1
            );
            let _ = writeln!(
                text,
                "| placement | probes | diffuse blend | specular rays | final MSE | direct | diffuse | specular | FLIP | direct (ms) | diffuse (ms) | specular (ms) |"
            );
            let _ = writeln!(
                text,
                "|---|---:|---|---|---:|---:|---:|---:|---:|---:|---:|---:|"
            );
            for row in &self.finals {
                let c = &row.comparison;
                let cell = |mse: f64, part: fn(&PartErrors) -> f64| {
                    format!(
                        "{mse:.2e} ({:.0e} / {} / {})",
                        part(&c.reference_noise),
                        c.bake_noise
                            .as_ref()
                            .map_or("–".to_owned(), |n| format!("{:.0e}", part(n))),
                        c.render_noise
                            .as_ref()
                            .map_or("–".to_owned(), |n| format!("{:.0e}", part(n))),
                    )
                };
                let t = &c.times;
                let _ = writeln!(
                    text,
                    "| {} | {} | {} | {} | {} | {} | {} | {} | {:.4} | {:.1} | {:.1} | {:.1} |",
                    row.placement,
                    row.probes,
                    row.blend,
                    row.specular,
                    cell(c.mse.image, |p| p.image),
                    cell(c.mse.direct, |p| p.direct),
                    cell(c.mse.diffuse, |p| p.diffuse),
                    cell(c.mse.specular, |p| p.specular),
                    c.flip,
                    t.direct_ms,
                    t.diffuse_gpu_ms.unwrap_or(t.diffuse_ms),
                    t.specular_gpu_ms.unwrap_or(t.specular_ms),
                );
            }
        }
        let _ = writeln!(
            text,
            "\nReference (path traced against the BVH, same rays): {:.2} s. Trace times are {}; the hybrid's, the shaded hits' and the split's are wall time: the BVH's closest hits on the CPU with the look-up, the shadow rays or both.",
            self.reference_seconds,
            if self.device.starts_with("gpu") {
                "GPU timestamps on the device above"
            } else {
                "wall-clock on the CPU twin"
            }
        );
        text
    }
}

/// The legend of the error-class images: each class's colour and meaning.
pub fn class_legend() -> String {
    let mut text = "Error-class images (`classes_*.png`): ".to_owned();
    let parts: Vec<String> = PixelClass::ALL
        .iter()
        .map(|c| format!("{} = {}", c.colour_name(), c.name()))
        .collect();
    text.push_str(&parts.join(", "));
    text.push_str(
        ". A correct hit lies within one probe texel footprint of the true hit with radiance \
         within 0.05 (tone-mapped) of the reference; a radiance-only error is on the right \
         surface with radiance off by more. FLIP maps (`flip_*.png`): magma, black = no visible \
         difference.",
    );
    text
}

fn save_png(image: &Image, path: &Path, exposure: f32) -> Result<(), EvalError> {
    image.save_png_with_exposure(path, exposure)?;
    Ok(())
}

/// Writes 8-bit RGB as a PNG, atomically.
fn write_png(path: &Path, width: u32, height: u32, rgb: &[u8]) -> Result<(), EvalError> {
    let mut bytes = Vec::new();
    image::codecs::png::PngEncoder::new(&mut bytes)
        .write_image(rgb, width, height, image::ExtendedColorType::Rgb8)
        .map_err(|e| EvalError::Write {
            path: path.to_owned(),
            source: std::io::Error::other(e),
        })?;
    write_atomic(path, &bytes)
}

/// A false-colour picture of the per-pixel error (RGB mean of |probe − reference|, scaled so
/// that the reference's mean luminance is full scale).
fn error_image(image: &Image, reference: &Image) -> Image {
    let mean = reference.mean().dot(glam::Vec3::splat(1.0 / 3.0)).max(1e-6);
    let mut out = Image::new(image.width, image.height);
    for ((o, a), b) in out.rgb.iter_mut().zip(&image.rgb).zip(&reference.rgb) {
        let e = (0..3).map(|c| (a[c] - b[c]).abs()).sum::<f32>() / 3.0 / mean;
        let e = e.clamp(0.0, 1.0);
        // Black → red → yellow → white.
        *o = [
            (3.0 * e).min(1.0),
            (3.0 * e - 1.0).clamp(0.0, 1.0),
            (3.0 * e - 2.0).clamp(0.0, 1.0),
        ];
    }
    out
}

/// Runs the demo. `log` receives one line per stage.
///
/// # Errors
/// [`EvalError`] from any stage.
pub fn run_demo(options: &DemoOptions, log: &dyn Fn(&str)) -> Result<DemoReport, EvalError> {
    let out = &options.out;
    std::fs::create_dir_all(out).map_err(|source| EvalError::Write {
        path: out.clone(),
        source,
    })?;
    let scene = Scene::builtin("cornell")?;
    let (mut device, fallback) = Device::open(options.require_gpu)?;
    if let Some(reason) = &fallback {
        log(&format!(
            "no GPU adapter ({reason}); tracing with the CPU twin"
        ));
    }
    log(&format!("tracer device: {}", device.describe()));

    let settings = ViewSettings {
        width: options.image_size,
        height: options.image_size,
        shading_samples: 16,
        bake_denoise: options.bake_denoise,
        ..ViewSettings::default()
    };
    log("rendering the path-traced reference (first two passes)");
    let mut view = EvalView::render(&scene, scene.default_camera(), settings, &|_, _| {})?;
    let mut files = Vec::new();
    let rays = view.trace_rays();

    let placements = [
        ("sdf+gibbs", {
            let mut o = PlaceOptions::new(Method::Sdf);
            o.optimize = Some(Optimizer::Gibbs);
            o.iterations = options.gibbs_iterations;
            o.region = options.region.clone();
            o
        }),
        // Issue 12's error-driven set where viewers go: the demo's camera is the view set
        // (what it sees directly and in mirror reflection), at the grid's count.
        (
            "minimal+views@8",
            PlaceOptions {
                region: options.region.clone(),
                viewers: Some(vec![view.camera.clone()]),
                budget: Some(8),
                ..PlaceOptions::new(Method::Minimal)
            },
        ),
        (
            "grid 2x2x2",
            PlaceOptions {
                region: options.region.clone(),
                ..PlaceOptions::new(Method::Grid([2, 2, 2]))
            },
        ),
    ];
    // Trace everything first; the reference is refined against the traced errors after.
    struct Pending {
        placement: usize,
        traced: TracedView,
        bake_noise: f64,
    }
    struct Placed {
        name: &'static str,
        coverage: f64,
        place_seconds: f64,
        bake_seconds: f64,
        index_seconds: f64,
        memory: ProbeMemory,
        baked: probe_capture::ProbeBake,
        second: probe_capture::ProbeBake,
        index: crate::pipeline::BuiltIndex,
    }
    let mut placed_sets: Vec<Placed> = Vec::new();
    let mut pending = Vec::new();
    let mut placed_positions = Vec::new();
    for (name, place_options) in &placements {
        log(&format!("placing: {name}"));
        let placed = place_lit(&scene, place_options)?;
        log(&format!(
            "  {} probes, coverage {:.1} %, {} inside geometry",
            placed.probes.len(),
            100.0 * placed.report.coverage,
            placed.report.probes_inside_geometry
        ));
        log(&format!(
            "baking {} probes at {}² (twice, seeds {} and {}, for the bake's noise)",
            placed.probes.len(),
            options.resolution,
            view.settings.seed,
            view.settings.seed + 1
        ));
        let (baked, bake_seconds) = bake_for_view(
            &scene,
            &placed.probes.positions,
            options.resolution,
            options.sampling,
            &view,
            &|_, _| {},
        )?;
        let (second, _) = bake_for_view_seeded(
            &scene,
            &placed.probes.positions,
            options.resolution,
            options.sampling,
            &view,
            view.settings.seed + 1,
            &|_, _| {},
        )?;
        let memory = ProbeMemory::of(&baked, Tracer::HiZ.options().hiz_top_level);
        log("indexing (octree, Voronoi neighbours)");
        let index = build_index(
            &scene,
            baked.positions(),
            7,
            ProbeGrid::detect(baked.positions()),
            0,
        )?;
        if placed_sets.is_empty() {
            let previews = baked.write_previews(0, out)?;
            files.extend([previews.radiance, previews.normal, previews.distance]);
        }
        // The BVH tracers' shading of hits the light field does not answer, for each bake,
        // with the bake of the light the surfaces reflect that the split reads.
        let shading = device.hit_shading_for(Tracer::Split, &scene, &baked, &index)?;
        let second_shading = device.hit_shading_for(Tracer::Split, &scene, &second, &index)?;
        for selection in [Selection::Grid, Selection::Svo] {
            // The light-field tracers, the hybrid (the BVH's hits, the probes' radiance): what a
            // renderer that can trace rays would do with the same probes, and the BVH's hits
            // shaded as DDGI would (direct light, irradiance probes; no selection, so once), and
            // the split (direct light with shadow rays, the probes' reflected light).
            for tracer in Tracer::WITH_BVH {
                if tracer == Tracer::Shaded && selection != Selection::Svo {
                    continue;
                }
                let Some(traced) = trace_only(
                    &mut device,
                    &scene,
                    &baked,
                    &index,
                    &view,
                    &rays,
                    tracer,
                    selection,
                    shading.as_ref(),
                )?
                else {
                    continue;
                };
                let Some(twin) = trace_only(
                    &mut device,
                    &scene,
                    &second,
                    &index,
                    &view,
                    &rays,
                    tracer,
                    selection,
                    second_shading.as_ref(),
                )?
                else {
                    continue;
                };
                log(&format!(
                    "  traced {} / {}: {:.1} ms, {:.1} fetches/ray",
                    selection.name(),
                    tracer.name(),
                    traced.gpu_ms.unwrap_or(traced.wall_ms),
                    traced.results.iter().map(|r| r.texel_fetches).sum::<u32>() as f64
                        / traced.results.len().max(1) as f64,
                ));
                pending.push(Pending {
                    placement: placed_sets.len(),
                    bake_noise: tonemapped_mse(&traced.image, &twin.image) / 2.0,
                    traced,
                });
            }
        }
        placed_positions.push(placed.probes.positions.clone());
        placed_sets.push(Placed {
            name,
            coverage: placed.report.coverage,
            place_seconds: placed.report.seconds,
            bake_seconds,
            index_seconds: index.seconds,
            memory,
            baked,
            second,
            index,
        });
    }
    log("refining the reference to 5 % of the smallest error");
    let images: Vec<&Image> = pending.iter().map(|p| &p.traced.image).collect();
    let reference = view.refine(
        &scene,
        &images,
        options.reference_noise_fraction,
        options.reference_max_samples,
        &|_, _| {},
    )?;
    log(&format!(
        "  reference: {} samples per hit, noise {:.2e} (target {})",
        reference.samples,
        reference.noise,
        reference
            .target
            .map_or("none".to_owned(), |t| format!("{t:.2e}"))
    ));
    let exposure = 0.6 / view.reference_image.mean().max_element().max(1e-6);
    let reference_png = out.join("reference_glossy.png");
    save_png(&view.reference_image, &reference_png, exposure)?;
    view.reference_image
        .save_exr(out.join("reference_glossy.exr"))?;
    files.push(reference_png);
    let mut rows = Vec::new();
    for entry in &pending {
        let set = &placed_sets[entry.placement];
        let (metrics, classes) = compare_trace(
            Footprints::of(&set.baked),
            &view,
            &entry.traced,
            Some(entry.bake_noise),
        )?;
        let image = &entry.traced.image;
        let slug: String = set
            .name
            .chars()
            .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
            .collect();
        let suffix = format!(
            "{slug}_{}_{}",
            metrics.selection.name(),
            metrics.tracer.name()
        );
        log(&format!(
            "  {suffix}: MSE {:.3e} (tone-mapped {:.3e}; noise: reference {:.1e}, bake {:.1e}), FLIP {:.4}",
            metrics.mse,
            metrics.mse_tonemapped,
            metrics.reference_noise,
            entry.bake_noise,
            metrics.flip
        ));
        let png = out.join(format!("glossy_{suffix}.png"));
        save_png(image, &png, exposure)?;
        let error_png = out.join(format!("error_{suffix}.png"));
        error_image(image, &view.reference_image).save_png_with_exposure(&error_png, 1.0)?;
        let classes_png = out.join(format!("classes_{suffix}.png"));
        classes.image().save_png_with_exposure(&classes_png, 1.0)?;
        let flip_png = out.join(format!("flip_{suffix}.png"));
        let (flip_values, _) = flip(image, &view.reference_image)?;
        write_png(
            &flip_png,
            image.width,
            image.height,
            &flip_map_rgb8(image.width, image.height, &flip_values),
        )?;
        files.extend([
            png.clone(),
            error_png,
            classes_png.clone(),
            flip_png.clone(),
        ]);
        rows.push(DemoRow {
            placement: set.name.to_owned(),
            probes: set.baked.probe_count(),
            coverage: set.coverage,
            place_seconds: set.place_seconds,
            bake_seconds: set.bake_seconds,
            samples_per_texel: set.baked.mean_samples_per_texel(),
            bake_noise_estimate: set.baked.noise(),
            index_seconds: set.index_seconds,
            memory: set.memory,
            trace: metrics,
            image: png,
            classes_image: classes_png,
            flip_image: flip_png,
        });
    }
    let (finals, final_reference, final_files) = final_images(
        &mut device,
        &scene,
        &placed_sets
            .iter()
            .map(|p| (p.name, &p.baked, &p.second, &p.index))
            .collect::<Vec<_>>(),
        options,
        log,
    )?;
    files.extend(final_files);
    let top = out.join("top_view.png");
    let bounds = scene.bounds();
    write_top_view(
        &scene,
        &placed_positions[0],
        &TopViewOptions {
            width: 600,
            cut_height: Some(bounds.max.y - 0.02 * bounds.size().y),
            number_probes: true,
            comparison: placed_positions[placed_positions.len() - 1].clone(),
            probes_name: "sdf+gibbs".into(),
            comparison_name: "grid 2x2x2".into(),
            ..TopViewOptions::default()
        },
        &top,
    )?;
    files.push(top);
    let report = DemoReport {
        device: device.describe(),
        cpu_fallback_reason: fallback,
        rays: rays.len(),
        reference_seconds: view.seconds,
        reference: view.reference_noise,
        rows,
        finals,
        final_reference,
        files,
    };
    let table = out.join("table.md");
    write_atomic(&table, report.markdown().as_bytes())?;
    let json = out.join("results.json");
    write_atomic(
        &json,
        serde_json::to_string_pretty(&report)
            .unwrap_or_default()
            .as_bytes(),
    )?;
    let mut report = report;
    report.files.push(table);
    report.files.push(json);
    Ok(report)
}

/// The final images' rows, the reference's samples and seconds, and the files written.
type FinalSection = (Vec<FinalRow>, (u32, f64), Vec<PathBuf>);

/// A placement's name, its bake, its second bake (another seed) and its index.
type FinalSet<'a> = (
    &'a str,
    &'a probe_capture::ProbeBake,
    &'a probe_capture::ProbeBake,
    &'a crate::pipeline::BuiltIndex,
);

/// The demo's final images: each placement's probes (and a second bake, and a second render
/// seed, for the noise floors) against the path-traced final image, with the images, the
/// parts and error maps written.
fn final_images(
    device: &mut Device,
    scene: &Scene,
    sets: &[FinalSet<'_>],
    options: &DemoOptions,
    log: &dyn Fn(&str),
) -> Result<FinalSection, EvalError> {
    let out = &options.out;
    let size = options.image_size;
    let gbuffer = probe_capture::render_gbuffer(scene, &scene.default_camera(), size, size)?;
    log(&format!(
        "path tracing the final image ({} samples per pixel of each part)",
        options.final_reference_samples
    ));
    let reference = reference_final(
        scene,
        sets[0].1,
        &gbuffer,
        options.final_reference_samples,
        0,
        &|_, _| {},
    )?;
    let truth = reference.parts.sum();
    let exposure = 0.6 / truth.mean().max_element().max(1e-6);
    let mut files = Vec::new();
    let reference_png = out.join("final_reference.png");
    save_png(&truth, &reference_png, exposure)?;
    truth.save_exr(out.join("final_reference.exr"))?;
    files.push(reference_png);
    for (part, image) in [
        ("direct", &reference.parts.direct),
        ("diffuse", &reference.parts.diffuse),
        ("specular", &reference.parts.specular),
    ] {
        let png = out.join(format!("final_reference_{part}.png"));
        save_png(image, &png, exposure)?;
        files.push(png);
    }
    let mut rows = Vec::new();
    let runs = sets
        .iter()
        .flat_map(|set| [SpecularMode::Filtered, SpecularMode::Stochastic].map(|mode| (set, mode)));
    for ((name, baked, second, index), specular) in runs {
        log(&format!(
            "final image through the probes: {name}, {} specular",
            specular_name(specular)
        ));
        let final_options = FinalOptions {
            blend: if index.grid.is_some() {
                DiffuseBlend::Grid
            } else {
                DiffuseBlend::Delaunay
            },
            specular,
            ..FinalOptions::default()
        };
        let (first, comparison) = render_and_compare(
            device,
            scene,
            baked,
            Some(second),
            index,
            &gbuffer,
            &final_options,
            &reference,
        )?;
        let mut slug: String = name
            .chars()
            .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
            .collect();
        if specular == SpecularMode::Stochastic {
            slug.push_str("_stochastic");
        }
        let image = first.parts.sum();
        let png = out.join(format!("final_{slug}.png"));
        save_png(&image, &png, exposure)?;
        let error_png = out.join(format!("final_error_{slug}.png"));
        error_image(&image, &truth).save_png_with_exposure(&error_png, 1.0)?;
        files.extend([png.clone(), error_png]);
        for (part, part_image) in [
            ("direct", &first.parts.direct),
            ("diffuse", &first.parts.diffuse),
            ("specular", &first.parts.specular),
        ] {
            let part_png = out.join(format!("final_{slug}_{part}.png"));
            save_png(part_image, &part_png, exposure)?;
            files.push(part_png);
        }
        log(&format!(
            "  final {name}: MSE {:.3e} (noise: reference {:.1e}, bake {:.1e}, render {:.1e}), FLIP {:.4}",
            comparison.mse.image,
            comparison.reference_noise.image,
            comparison.bake_noise.map_or(f64::NAN, |n| n.image),
            comparison.render_noise.map_or(f64::NAN, |n| n.image),
            comparison.flip
        ));
        rows.push(FinalRow {
            placement: (*name).to_owned(),
            specular: specular_name(specular).to_owned(),
            probes: baked.probe_count(),
            blend: if index.grid.is_some() {
                "grid"
            } else {
                "delaunay"
            }
            .to_owned(),
            comparison,
            image: png,
        });
    }
    Ok((rows, (reference.samples, reference.seconds), files))
}
