//! `probe_eval`: measuring radiance probes against the path-traced truth, by speed and by
//! accuracy.
//!
//! The measured pipeline behind `probes demo`, `probes eval` and the workspace's failure suite,
//! as a library: place probes (probe-place), bake them (probe-capture), index them
//! (probe-index), trace a camera's reflection rays through them (probe-trace-gpu, on the GPU
//! or its CPU twin) and compare every ray and the image with the BVH's path-traced reference
//! (BRIEF, "How quality is measured").
//!
//! - [`pipeline`]: one camera's evaluation rays and reference ([`pipeline::EvalView`]), bakes
//!   lit as the reference is ([`pipeline::bake_for_view`]), the bake as the tracers take it
//!   ([`pipeline::light_field`]), indexes ([`pipeline::build_index`]), the tracer on whatever
//!   device exists ([`pipeline::Device`]) and one trace compared with the reference
//!   ([`pipeline::trace_view`], or [`pipeline::trace_only`] then [`pipeline::compare_trace`]
//!   so that the reference can be refined in between: [`pipeline::EvalView::refine`]).
//! - [`convergence`]: references rendered progressively until their noise, estimated from two
//!   independent half-sample images, is below a target ([`convergence::render_converged`]).
//! - [`metrics`]: what a trace measured: ray status, hit position within a texel's footprint,
//!   radiance, image MSE (raw, tone-mapped, relative), PSNR, FLIP ([`metrics::flip`]), the
//!   noise floors of reference and bake beside them, and a class per pixel
//!   ([`metrics::PixelClass`]) with each class's share of the pixels and of the MSE.
//! - [`lighting`]: probe-capture's shading as probe-place's `LightingOracle`, so that seed
//!   002's irradiance-driven placements run on any scene ([`lighting::place_lit`]).
//! - [`demo`]: the Cornell-box run of `probes demo`.
//! - [`sweep`]: the speed-against-accuracy sweep of `probes eval` (configuration, records,
//!   headline figures, Markdown report, CSV, JSON and charts).
//! - [`failures`]: the failure suite: scenes and inputs where methods break, each case's
//!   figures and checks.
//! - [`chart`] and [`top_view`]: pictures (charts of speed against accuracy with a Pareto
//!   front; scenes seen from above with their probes), drawn with an embedded font so they are
//!   the same on every machine.
//!
//! Every output is written to a temporary file and renamed over its target; every random
//! choice takes a seed, so the same inputs give the same bytes. Where the shared scenes are
//! is always an input ([`sweep::EvalConfig::scenes_dir`],
//! [`failures::FailureOptions::shared_scenes`]), never a path built into the crate.
//!
//! A whole measurement on the built-in Cornell box, small enough to run in a moment:
//!
//! ```
//! use probe_eval::pipeline::{
//!     Device, EvalView, Selection, Tracer, ViewSettings, bake_for_view, build_index, trace_view,
//! };
//! use probe_index::ProbeGrid;
//! use probe_place::pipeline::{Method, PlaceOptions};
//! use probe_scene::Scene;
//!
//! let scene = Scene::builtin("cornell")?;
//! // The reference: 24×24 mirror-reflection rays from the default camera, path traced.
//! let settings = ViewSettings { width: 24, height: 24, shading_samples: 2, ..ViewSettings::default() };
//! let camera = scene.default_camera();
//! let view = EvalView::render(&scene, camera, settings, &probe_capture::no_progress)?;
//!
//! // A 2×2×2 grid, baked at 16² texels and indexed (grid cage, octree, Voronoi).
//! let placed = probe_eval::lighting::place_lit(&scene, &PlaceOptions {
//!     atlas_texels: 1000,
//!     ..PlaceOptions::new(Method::Grid([2, 2, 2]))
//! })?;
//! let sampling = probe_capture::Sampling::fixed(1);
//! let (baked, _) =
//!     bake_for_view(&scene, &placed.probes.positions, 16, sampling, &view, &probe_capture::no_progress)?;
//! let grid = ProbeGrid::detect(baked.positions());
//! assert!(grid.is_some());
//! let index = build_index(&scene, baked.positions(), 4, grid, 1)?;
//!
//! // Trace on the CPU twin (the same algorithm as the GPU tracer) and compare.
//! let mut device = Device::cpu();
//! let (metrics, image) =
//!     trace_view(&mut device, &scene, &baked, &index, &view, &view.trace_rays(), Tracer::HiZ, Selection::Grid)?
//!         .expect("a full grid has a cage selection");
//! assert_eq!(metrics.rays, view.rays.len());
//! assert!(metrics.status_agreement > 0.5);
//! assert!(metrics.mse.is_finite() && metrics.psnr > 0.0);
//! assert_eq!((image.width, image.height), (24, 24));
//! // Beside the MSE: FLIP, the reference's noise floor (from two half-sample passes) and
//! // each pixel class's share of the pixels and of the MSE.
//! assert!(metrics.flip > 0.0 && metrics.flip < 1.0);
//! assert!(metrics.reference_noise > 0.0 && metrics.reference_noise.is_finite());
//! let pixel_shares: f64 = metrics.classes.iter().map(|c| c.pixels).sum();
//! assert!((pixel_shares - 1.0).abs() < 1e-9);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod chart;
pub mod convergence;
pub mod demo;
pub mod failures;
pub mod final_render;
pub mod glossy;
pub mod lighting;
pub mod metrics;
pub mod pipeline;
pub mod sweep;
pub mod top_view;
pub mod views;

use std::path::PathBuf;

/// Everything an evaluation step can fail with; each variant names the stage.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum EvalError {
    /// A scene could not be loaded.
    #[error(transparent)]
    Scene(#[from] probe_scene::LoadError),
    /// Rendering the reference or the evaluation rays failed.
    #[error("reference: {0}")]
    Render(#[from] probe_capture::RenderError),
    /// The shading setup was refused.
    #[error("shading: {0}")]
    Shader(#[from] probe_capture::ShaderError),
    /// Baking failed.
    #[error("baking: {0}")]
    Bake(#[from] probe_capture::BakeError),
    /// Probe previews could not be written.
    #[error("previews: {0}")]
    Preview(#[from] probe_capture::PreviewError),
    /// An image operation failed.
    #[error("image: {0}")]
    Image(#[from] probe_capture::ImageError),
    /// Indexing failed.
    #[error("indexing: {0}")]
    Index(#[from] probe_index::IndexError),
    /// The grid could not be indexed as a cage.
    #[error("grid cage: {0}")]
    Grid(#[from] probe_index::GridError),
    /// No GPU adapter could be used.
    #[error("gpu: {0}")]
    Gpu(#[from] probe_trace_gpu::GpuError),
    /// Uploading probes to the tracer failed.
    #[error("tracer upload: {0}")]
    Upload(#[from] probe_trace_gpu::UploadError),
    /// Tracing failed.
    #[error("trace: {0}")]
    Trace(#[from] probe_trace_gpu::TraceError),
    /// Placement failed.
    #[error("placement: {0}")]
    Place(#[from] probe_place::pipeline::PlaceError),
    /// A chart could not be drawn.
    #[error("chart: {0}")]
    Chart(#[from] chart::ChartError),
    /// A top view could not be drawn.
    #[error("top view: {0}")]
    TopView(#[from] top_view::TopViewError),
    /// The view set could not be made.
    #[error("view set: {0}")]
    Views(#[from] views::ViewSetError),
    /// The configuration is invalid.
    #[error("configuration {}: {reason}", path.as_ref().map_or("(defaults)".to_owned(), |p| p.display().to_string()))]
    Config {
        /// The configuration file, if any.
        path: Option<PathBuf>,
        /// What is wrong.
        reason: String,
    },
    /// A setting asks for what the probes cannot give. Fix: as the reason says.
    #[error("{parameter} = {value}: {reason}")]
    InvalidSetting {
        /// The setting.
        parameter: &'static str,
        /// Its value.
        value: String,
        /// Why it is refused, and what to use instead.
        reason: String,
    },
    /// An output file could not be written.
    #[error("cannot write {}: {source}", path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
}

/// Writes `bytes` to `path` atomically: a temporary file beside it, then a rename.
pub fn write_atomic(path: &std::path::Path, bytes: &[u8]) -> Result<(), EvalError> {
    let error = |source| EvalError::Write {
        path: path.to_owned(),
        source,
    };
    if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent).map_err(error)?;
    }
    let mut temporary = path.as_os_str().to_owned();
    temporary.push(format!(".{}.tmp", std::process::id()));
    let temporary = PathBuf::from(temporary);
    std::fs::write(&temporary, bytes).map_err(error)?;
    std::fs::rename(&temporary, path).map_err(|e| {
        let _ = std::fs::remove_file(&temporary);
        error(e)
    })
}
