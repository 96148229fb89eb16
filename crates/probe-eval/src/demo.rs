//! `probes demo`: the whole system on the built-in Cornell box, no files needed — place probes
//! (SDF skeleton refined by Gibbs sampling, against seed 000's 2×2×2 grid), bake them, index
//! them, trace the one-bounce glossy component through them with the GPU tracer (both
//! single-probe algorithms), render the path-traced reference, and tabulate probes, bake time,
//! trace time, texel fetches per ray, MSE and PSNR, writing images and the table to a folder.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use probe_capture::Image;
use probe_scene::Scene;
use serde::Serialize;

use probe_index::ProbeGrid;
use probe_place::pipeline::{Method, Optimizer, PlaceOptions};

use crate::lighting::place_lit;
use crate::metrics::TraceMetrics;
use crate::pipeline::{
    Device, EvalView, ProbeMemory, Selection, Tracer, ViewSettings, bake_for_view, build_index,
    trace_view,
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
    /// Radiance samples per texel.
    pub samples_per_texel: u32,
    /// Image side in pixels (the Cornell camera is square).
    pub image_size: u32,
    /// Gibbs iterations.
    pub gibbs_iterations: usize,
}

impl DemoOptions {
    /// The defaults: 128² probes, 4 samples per texel, a 256² image, 30 Gibbs iterations.
    pub fn new(out: impl Into<PathBuf>) -> DemoOptions {
        DemoOptions {
            out: out.into(),
            require_gpu: false,
            resolution: 128,
            samples_per_texel: 4,
            image_size: 256,
            gibbs_iterations: 30,
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
    /// Seconds to build the indexes.
    pub index_seconds: f64,
    /// Bytes of the probe textures as traced.
    pub memory: ProbeMemory,
    /// The trace and its comparison with the reference.
    pub trace: TraceMetrics,
    /// The probes' glossy image (PNG).
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
    /// The rows.
    pub rows: Vec<DemoRow>,
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
            "| placement | probes | coverage | bake (s) | selection | tracer | trace (ms) | fetches/ray | probes/ray | hit agreement | MSE | MSE (tone-mapped) | PSNR (dB) |"
        );
        let _ = writeln!(
            text,
            "|---|---:|---:|---:|---|---|---:|---:|---:|---:|---:|---:|---:|"
        );
        for row in &self.rows {
            let t = &row.trace;
            let _ = writeln!(
                text,
                "| {} | {} | {:.1} % | {:.2} | {} | {} | {:.1} | {:.1} | {:.2} | {:.1} % | {:.3e} | {:.3e} | {:.2} |",
                row.placement,
                row.probes,
                100.0 * row.coverage,
                row.bake_seconds,
                t.selection.name(),
                t.tracer.name(),
                t.trace_ms,
                t.fetches_per_ray,
                t.probes_per_ray,
                100.0 * t.status_agreement,
                t.mse,
                t.mse_tonemapped,
                t.psnr
            );
        }
        let _ = writeln!(
            text,
            "\nReference (path traced against the BVH, same rays): {:.2} s. Trace times are {}.",
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

fn save_png(image: &Image, path: &Path, exposure: f32) -> Result<(), EvalError> {
    image.save_png_with_exposure(path, exposure)?;
    Ok(())
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
        ..ViewSettings::default()
    };
    log("rendering the path-traced reference");
    let view = EvalView::render(&scene, scene.default_camera(), settings, &|_, _| {})?;
    let exposure = 0.6 / view.reference_image.mean().max_element().max(1e-6);
    let mut files = Vec::new();
    let reference_png = out.join("reference_glossy.png");
    save_png(&view.reference_image, &reference_png, exposure)?;
    view.reference_image
        .save_exr(out.join("reference_glossy.exr"))?;
    files.push(reference_png);
    let rays = view.trace_rays();

    let placements = [
        ("sdf+gibbs", {
            let mut o = PlaceOptions::new(Method::Sdf);
            o.optimize = Some(Optimizer::Gibbs);
            o.iterations = options.gibbs_iterations;
            o
        }),
        ("grid 2x2x2", PlaceOptions::new(Method::Grid([2, 2, 2]))),
    ];
    let mut rows = Vec::new();
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
            "baking {} probes at {}²",
            placed.probes.len(),
            options.resolution
        ));
        let (baked, bake_seconds) = bake_for_view(
            &scene,
            &placed.probes.positions,
            options.resolution,
            options.samples_per_texel,
            &view,
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
        let slug: String = name
            .chars()
            .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
            .collect();
        if rows.is_empty() {
            let previews = baked.write_previews(0, out)?;
            files.extend([previews.radiance, previews.normal, previews.distance]);
        }
        for selection in [Selection::Grid, Selection::Svo] {
            for tracer in Tracer::ALL {
                let Some((metrics, image)) =
                    trace_view(&mut device, &baked, &index, &view, &rays, tracer, selection)?
                else {
                    continue;
                };
                log(&format!(
                    "  traced {} / {}: {:.1} ms, {:.1} fetches/ray, MSE {:.3e}",
                    selection.name(),
                    tracer.name(),
                    metrics.trace_ms,
                    metrics.fetches_per_ray,
                    metrics.mse
                ));
                let stem = format!("glossy_{slug}_{}_{}", selection.name(), tracer.name());
                let png = out.join(format!("{stem}.png"));
                save_png(&image, &png, exposure)?;
                let error_png = out.join(format!(
                    "error_{slug}_{}_{}.png",
                    selection.name(),
                    tracer.name()
                ));
                error_image(&image, &view.reference_image)
                    .save_png_with_exposure(&error_png, 1.0)?;
                files.push(png.clone());
                files.push(error_png);
                rows.push(DemoRow {
                    placement: (*name).to_owned(),
                    probes: baked.probe_count(),
                    coverage: placed.report.coverage,
                    place_seconds: placed.report.seconds,
                    bake_seconds,
                    index_seconds: index.seconds,
                    memory,
                    trace: metrics,
                    image: png,
                });
            }
        }
        placed_positions.push(placed.probes.positions.clone());
    }
    let top = out.join("top_view.png");
    let bounds = scene.bounds();
    write_top_view(
        &scene,
        &placed_positions[0],
        &TopViewOptions {
            width: 600,
            cut_height: Some(bounds.max.y - 0.02 * bounds.size().y),
            number_probes: true,
            comparison: placed_positions[1].clone(),
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
        rows,
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
