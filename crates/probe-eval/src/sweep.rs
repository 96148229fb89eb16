//! `probes eval`: the sweep of seed 000 §5, extended. For each scene and camera: placements
//! (regular grids of several sizes, the classified and relocated grid, SDF skeleton and medial
//! axis with and without Gibbs, the minimal set, and minimal sets at each grid's probe count)
//! × tracers (two-level, hi-Z) × selections (grid cage, octree, Voronoi). Every point records
//! probe count, bake time, memory, trace time, fetches per ray, MSE and PSNR of the glossy
//! component against the path-traced reference. The report holds tables in the form of seed
//! 000's Tables 5.1 and 5.2, the headline figures, and charts of error against time (Pareto
//! front marked), probe count and memory.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use glam::Vec3;
use probe_capture::{Image, ProbeBake, Sampling};
use probe_place::{
    atlas::{Atlas, AtlasParams, BackfaceVote, RewardWeights, free_space_grid},
    optimize::{DescentParams, GibbsParams, descend, gibbs},
};
use probe_scene::{Camera, Scene};
use serde::{Deserialize, Serialize};

use probe_index::ProbeGrid;
use probe_place::pipeline::{Method, Optimizer, PlaceError, PlaceOptions};

use crate::chart::{ChartSpec, Point, Series, SeriesStyle, write_chart};
use crate::failures::{FailureOptions, FailureReport, SharedScenes, run_failure_suite};
use crate::lighting::place_lit;
use crate::metrics::{Footprints, TraceMetrics, tonemapped_mse};
use crate::pipeline::{
    BuiltIndex, Device, EvalView, HitShading, ProbeMemory, Selection, Tracer, ViewSettings,
    bake_for_view_seeded, bake_reflected_for_view, build_index, compare_trace, trace_only,
};
use crate::views::{ViewSetOptions, view_set};
use crate::{EvalError, write_atomic};
use probe_place::region::Region;
use probe_place::viewers::ViewProxy;
use probe_trace_gpu::TraceRay;

/// The sweep's configuration (`--config eval.toml`); every field has a default.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct EvalConfig {
    /// Evaluation rays and reference.
    pub view: ViewSettings,
    /// Probe resolution (interior texels per side, a power of two).
    pub resolution: u32,
    /// Radiance samples every texel takes (the first pass of adaptive sampling).
    pub samples_per_texel: u32,
    /// The most radiance samples a texel takes; equal to `samples_per_texel` for fixed
    /// sampling.
    pub max_samples_per_texel: u32,
    /// The noise each texel is sampled down to (tone-mapped variance,
    /// [`Sampling::noise_target`]).
    pub noise_target: f32,
    /// Depth of the sparse voxel octree.
    pub svo_depth: u32,
    /// Gibbs iterations for `+gibbs` placements.
    pub gibbs_iterations: usize,
    /// Atlas texels for placement and coverage.
    pub atlas_texels: usize,
    /// Tracers: `two-level`, `hiz`.
    pub tracers: Vec<String>,
    /// Selections: `grid`, `svo`, `voronoi`.
    pub selections: Vec<String>,
    /// Approximate probe counts of the regular grids made for every scene without its own
    /// `grids` (dimensions follow the scene's aspect).
    pub grid_counts: Vec<u32>,
    /// Placements for every scene without its own `placements`: `sdf`, `sdf+gibbs`, `medial`,
    /// `medial+gibbs`, `minimal`, `minimal@N`, `minimal@grids` (one minimal set per grid at
    /// its count), `grid-relocated@N` (the relocated grid of about N probes),
    /// `grid-relocated:NXxNYxNZ`. Suffixes: `+complete` completes the coverage, `+views`
    /// learns from the training view set ([`EvalConfig::training_views`]), and `~E` (after
    /// `+views`) makes an error-driven set whose target E — the share of what the views see
    /// left unseen — holds for each training view (`~E/mean`: over all of them together), as
    /// in `minimal+views~0.05`.
    pub placements: Vec<String>,
    /// Fail instead of using the CPU twin when no GPU adapter exists.
    pub require_gpu: bool,
    /// Run the failure suite too and add its section to the report.
    pub failure_suite: bool,
    /// The shared scenes directory the failure suite's file cases read, laid out as
    /// [`SharedScenes::in_dir`] expects (`scenes_dir` in TOML; `shared_scenes` is accepted
    /// too). [`EvalConfig::load`] takes a relative path as relative to the configuration
    /// file's directory. `None`, or a directory that does not exist: those cases are skipped
    /// and the report says so.
    #[serde(alias = "shared_scenes")]
    pub scenes_dir: Option<PathBuf>,
    /// The scenes.
    pub scenes: Vec<SceneConfig>,
    /// After tracing, each camera's reference is refined until its noise is at most this share
    /// of the smallest tone-mapped MSE traced against it ([`EvalView::refine`]).
    pub reference_noise_fraction: f64,
    /// The most shading samples per reference hit while refining.
    pub reference_max_samples: u32,
    /// Viewpoints sampled in each scene's region (or free space) besides its cameras
    /// ([`crate::views::view_set`]); a scene's own `views` overrides it. With more than one
    /// view, every figure of the scene is the mean over its views, with the worst view beside it.
    pub views: usize,
    /// Seed of the sampled viewpoints (another seed gives a held-out view set).
    pub view_seed: u64,
    /// Sampled viewpoints (at least; besides the cameras) of the view set `+views`
    /// placements learn from (seed [`training_seed`]): cheap (no render, no bake), and an
    /// error-driven set generalises to views it did not learn from only with many.
    pub training_views: usize,
    /// `+views` placements learn from the evaluation views themselves instead of the training
    /// view set: issue 12's protocol (a set placed for where viewers go, judged there; its
    /// `~E` targets then checked on a second view set of another seed), against the default's
    /// stricter one (placed from views the evaluation never renders). The report says which.
    pub learn_from_evaluation_views: bool,
    /// Bake every placement a second time with another seed (the view's seed + 1), trace
    /// each view through both and report each image's bake noise: half the tone-mapped MSE
    /// between the two images, the variance one bake's image carries
    /// ([`TraceMetrics::bake_noise`]), with the second bake's own MSE
    /// ([`TraceMetrics::second_bake_mse_tonemapped`]); the headline is then given again on
    /// [`noise_free_error`]. Every other figure is the first bake's, as without it; the bakes
    /// and traces take twice as long.
    pub measure_bake_noise: bool,
}

/// One scene of the sweep.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SceneConfig {
    /// A glTF path or `builtin:NAME`.
    pub scene: String,
    /// Cameras by name (`default` for the scene's default).
    #[serde(default = "default_cameras")]
    pub cameras: Vec<String>,
    /// Grid dimensions `NXxNYxNZ`; default from `grid_counts`.
    #[serde(default)]
    pub grids: Vec<String>,
    /// Placements; default the configuration's `placements`. A `+complete` suffix
    /// (`sdf+gibbs+complete`) completes the coverage ([`PlaceOptions::complete`]).
    #[serde(default)]
    pub placements: Vec<String>,
    /// Where viewers go: boxes `x0,y0,z0:x1,y1,z1` (a union). Probes of every placement are
    /// placed inside, grids divide the region's bounding box, coverage counts what the region
    /// sees, and sampled views stand inside. Empty: the whole scene.
    #[serde(default)]
    pub region: Vec<String>,
    /// Sampled viewpoints for this scene (default: the configuration's `views`).
    #[serde(default)]
    pub views: Option<usize>,
}

impl SceneConfig {
    /// The scene's region, if it has one.
    ///
    /// # Errors
    /// [`EvalError::Config`] naming the scene and the box.
    pub fn region(&self) -> Result<Option<Region>, EvalError> {
        if self.region.is_empty() {
            return Ok(None);
        }
        Region::parse_boxes(&self.region)
            .map(Some)
            .map_err(|e| EvalError::Config {
                path: None,
                reason: format!("scene {}: {e}", self.scene),
            })
    }
}

fn default_cameras() -> Vec<String> {
    vec!["default".into()]
}

impl Default for EvalConfig {
    fn default() -> Self {
        Self {
            view: ViewSettings::default(),
            resolution: 128,
            samples_per_texel: Sampling::default().samples_per_texel,
            max_samples_per_texel: Sampling::default().max_samples_per_texel,
            noise_target: Sampling::DEFAULT_NOISE_TARGET,
            svo_depth: 7,
            gibbs_iterations: 30,
            atlas_texels: 10_000,
            tracers: vec!["two-level".into(), "hiz".into()],
            selections: vec!["grid".into(), "svo".into(), "voronoi".into()],
            grid_counts: vec![8, 27, 64, 125],
            placements: [
                "grid-relocated@64",
                "sdf",
                "sdf+gibbs",
                "medial",
                "medial+gibbs",
                "minimal",
                "minimal@grids",
            ]
            .map(String::from)
            .to_vec(),
            require_gpu: false,
            failure_suite: true,
            scenes_dir: None,
            scenes: Vec::new(),
            reference_noise_fraction: 0.05,
            reference_max_samples: 1024,
            views: 0,
            view_seed: 1,
            training_views: 64,
            learn_from_evaluation_views: false,
            measure_bake_noise: false,
        }
    }
}

impl EvalConfig {
    /// The bakes' sampling: adaptive from `samples_per_texel` to `max_samples_per_texel`
    /// towards `noise_target`, or fixed when the two counts are equal.
    pub fn sampling(&self) -> Sampling {
        if self.max_samples_per_texel > self.samples_per_texel {
            Sampling::adaptive(
                self.samples_per_texel,
                self.max_samples_per_texel,
                self.noise_target,
            )
        } else {
            Sampling::fixed(self.samples_per_texel)
        }
    }

    /// Reads a TOML configuration. Relative paths in it (`scenes_dir`, and scene files other
    /// than `builtin:NAME`) are taken relative to the file's directory, so a configuration
    /// means the same from any working directory.
    ///
    /// # Errors
    /// [`EvalError::Config`] naming the file.
    pub fn load(path: &Path) -> Result<EvalConfig, EvalError> {
        let text = std::fs::read_to_string(path).map_err(|e| EvalError::Config {
            path: Some(path.to_owned()),
            reason: e.to_string(),
        })?;
        let mut config: EvalConfig = toml::from_str(&text).map_err(|e| EvalError::Config {
            path: Some(path.to_owned()),
            reason: e.to_string().replace('\n', " "),
        })?;
        let base = path.parent().unwrap_or(Path::new(""));
        config.resolve_paths(base);
        Ok(config)
    }

    /// Makes relative paths (`scenes_dir`, scene files other than `builtin:NAME`) relative to
    /// `base` instead of the working directory. [`EvalConfig::load`] does this with the
    /// configuration file's directory.
    pub fn resolve_paths(&mut self, base: &Path) {
        if let Some(dir) = &mut self.scenes_dir {
            *dir = base.join(&*dir);
        }
        for scene in &mut self.scenes {
            if !scene.scene.starts_with("builtin:") && Path::new(&scene.scene).is_relative() {
                scene.scene = base.join(&scene.scene).to_string_lossy().into_owned();
            }
        }
    }

    fn invalid(&self, reason: String) -> EvalError {
        EvalError::Config { path: None, reason }
    }

    fn tracers(&self) -> Result<Vec<Tracer>, EvalError> {
        self.tracers
            .iter()
            .map(|t| match t.as_str() {
                "two-level" => Ok(Tracer::TwoLevel),
                "hiz" => Ok(Tracer::HiZ),
                "hybrid" => Ok(Tracer::Hybrid),
                "shaded" => Ok(Tracer::Shaded),
                "split" => Ok(Tracer::Split),
                other => Err(self.invalid(format!(
                    "unknown tracer {other:?} (expected two-level, hiz, hybrid, shaded or split)"
                ))),
            })
            .collect()
    }

    fn selections(&self) -> Result<Vec<Selection>, EvalError> {
        self.selections
            .iter()
            .map(|s| match s.as_str() {
                "grid" => Ok(Selection::Grid),
                "svo" => Ok(Selection::Svo),
                "voronoi" => Ok(Selection::Voronoi),
                other => Err(self.invalid(format!(
                    "unknown selection {other:?} (expected grid, svo or voronoi)"
                ))),
            })
            .collect()
    }
}

/// Grid dimensions of about `count` probes over `bounds`, following its aspect (each axis ≥ 2:
/// a single layer has no 8-probe cage and no tetrahedralization).
pub fn grid_dims_for_count(size: Vec3, count: u32) -> [u32; 3] {
    let size = size.max(Vec3::splat(1e-6));
    let volume = size.x * size.y * size.z;
    let k = (count as f32 / volume).cbrt();
    let mut best = [2u32; 3];
    let mut best_error = f32::INFINITY;
    // Search around the ideal per-axis counts for the product nearest the target.
    let ideal = size * k;
    for dx in -1..=1 {
        for dy in -1..=1 {
            for dz in -1..=1 {
                let dims = [
                    (ideal.x.round() as i32 + dx).max(2) as u32,
                    (ideal.y.round() as i32 + dy).max(2) as u32,
                    (ideal.z.round() as i32 + dz).max(2) as u32,
                ];
                let product = (dims[0] * dims[1] * dims[2]) as f32;
                let aspect_error: f32 = (0..3)
                    .map(|i| (dims[i] as f32 / ideal[i].max(0.5)).ln().abs())
                    .sum();
                let error = (product / count as f32).ln().abs() * 3.0 + aspect_error;
                if error < best_error {
                    best_error = error;
                    best = dims;
                }
            }
        }
    }
    best
}

fn parse_dims(text: &str) -> Option<[u32; 3]> {
    let parts: Vec<u32> = text.split('x').filter_map(|p| p.parse().ok()).collect();
    (parts.len() == 3 && parts.iter().all(|&d| d > 0)).then(|| [parts[0], parts[1], parts[2]])
}

/// Whether a sweep with `tracers` bakes each placement's reflected light alone
/// ([`bake_reflected_for_view`]): with the split the only tracer, nothing reads a bake of the
/// outgoing radiance.
fn bakes_reflected_light_only(tracers: &[Tracer]) -> bool {
    tracers == [Tracer::Split]
}

/// The shading of BVH hits the light field does not answer that `tracers` read, for `baked`
/// (with the bake of the light the surfaces reflect when the split is asked for); `None`
/// when no tracer traces the BVH.
fn hit_shading_for_tracers<'s>(
    device: &mut Device,
    tracers: &[Tracer],
    scene: &'s Scene,
    baked: &ProbeBake,
    index: &BuiltIndex,
) -> Result<Option<HitShading<'s>>, EvalError> {
    if tracers.contains(&Tracer::Split) {
        device.hit_shading_for(Tracer::Split, scene, baked, index)
    } else if tracers.iter().any(|t| t.uses_bvh()) {
        device.hit_shading(scene, baked, index)
    } else {
        Ok(None)
    }
}

/// A bake-noise cell of the report: the noise, or "not measured".
fn noise_cell(noise: Option<f64>) -> String {
    noise.map_or("not measured".to_owned(), |n| format!("{n:.1e}"))
}

/// A ratio cell of the report that may be unmeasured.
fn ratio_cell(ratio: Option<f64>) -> String {
    ratio.map_or("not measured".to_owned(), |r| format!("{r:.2}"))
}

/// An MSE cell of the report that may be unmeasured (the second bake's).
fn mse_cell(mse: Option<f64>) -> String {
    mse.map_or("not measured".to_owned(), |m| format!("{m:.3e}"))
}

/// The seed of the view set `+views` placements learn from, for evaluation views seeded
/// `seed`: never equal to it.
pub fn training_seed(seed: u64) -> u64 {
    seed ^ 0x7a11_5eed
}

/// A trace waiting for its view's refined reference.
struct Pending {
    record: SweepRecord<()>,
    traced: crate::pipeline::TracedView,
    /// The same trace through the second bake ([`EvalConfig::measure_bake_noise`]).
    twin: Option<Image>,
    resolution: u32,
    positions: Vec<Vec3>,
}

/// Per scene with more than one view, one record per placement, selection and tracer: the
/// means over the views of every metric (each view weighs alike; rays are summed, times are
/// per view), with the worst view's tone-mapped MSE beside them. Scenes judged from one view
/// give none.
pub fn mean_over_views(records: &[SweepRecord]) -> Vec<SweepRecord> {
    let mut groups: BTreeMap<(&str, &str, &str, &str), Vec<&SweepRecord>> = BTreeMap::new();
    let mut order = Vec::new();
    for r in records {
        let key = (
            r.scene.as_str(),
            r.placement.as_str(),
            r.trace.selection.name(),
            r.trace.tracer.name(),
        );
        let group = groups.entry(key).or_default();
        if group.is_empty() {
            order.push(key);
        }
        group.push(r);
    }
    let mut out = Vec::new();
    for key in order {
        let group = &groups[&key];
        if group.len() < 2 {
            continue;
        }
        let n = group.len() as f64;
        let mean =
            |f: &dyn Fn(&TraceMetrics) -> f64| group.iter().map(|r| f(&r.trace)).sum::<f64>() / n;
        // The mean of a figure measured only sometimes: `None` unless every view has it.
        let mean_measured = |f: &dyn Fn(&TraceMetrics) -> Option<f64>| {
            group
                .iter()
                .map(|r| f(&r.trace))
                .sum::<Option<f64>>()
                .map(|sum| sum / n)
        };
        let first = group[0];
        let worst = group
            .iter()
            .max_by(|a, b| a.trace.mse_tonemapped.total_cmp(&b.trace.mse_tonemapped))
            .map(|r| (r.camera.clone(), r.trace.mse_tonemapped));
        let mut classes = first.trace.classes.clone();
        for (k, class) in classes.iter_mut().enumerate() {
            let share = |f: &dyn Fn(&crate::metrics::ClassShare) -> f64| {
                group
                    .iter()
                    .filter_map(|r| r.trace.classes.get(k).map(f))
                    .sum::<f64>()
                    / n
            };
            class.pixels = share(&|c| c.pixels);
            class.mse = share(&|c| c.mse);
        }
        let trace = TraceMetrics {
            tracer: first.trace.tracer,
            selection: first.trace.selection,
            rays: group.iter().map(|r| r.trace.rays).sum(),
            trace_ms: mean(&|t| t.trace_ms),
            wall_ms: mean(&|t| t.wall_ms),
            gpu_timestamps: group.iter().all(|r| r.trace.gpu_timestamps),
            fetches_per_ray: mean(&|t| t.fetches_per_ray),
            probes_per_ray: mean(&|t| t.probes_per_ray),
            hit_rate: mean(&|t| t.hit_rate),
            unknown_rate: mean(&|t| t.unknown_rate),
            status_agreement: mean(&|t| t.status_agreement),
            within_footprint: mean(&|t| t.within_footprint),
            mean_position_error: mean(&|t| t.mean_position_error),
            ray_mse: mean(&|t| t.ray_mse),
            mse: mean(&|t| t.mse),
            mse_tonemapped: mean(&|t| t.mse_tonemapped),
            relative_mse: mean(&|t| t.relative_mse),
            psnr: mean(&|t| t.psnr),
            flip: mean(&|t| t.flip),
            reference_noise: mean(&|t| t.reference_noise),
            bake_noise: mean_measured(&|t| t.bake_noise),
            second_bake_mse_tonemapped: mean_measured(&|t| t.second_bake_mse_tonemapped),
            classes,
        };
        out.push(SweepRecord {
            camera: format!("{} views", group.len()),
            views: group.len(),
            worst_view: worst,
            trace,
            ..first.clone()
        });
    }
    out
}

/// The records a scene is judged by: its view set's means where it has one, else its
/// camera's records.
fn judged(records: &[SweepRecord], view_sets: &[SweepRecord]) -> Vec<SweepRecord> {
    records
        .iter()
        .filter(|r| !view_sets.iter().any(|v| v.scene == r.scene))
        .chain(view_sets)
        .cloned()
        .collect()
}

/// One placement of the sweep, resolved.
#[derive(Clone, Debug, PartialEq)]
struct PlacementSpec {
    name: String,
    family: &'static str,
    options: PlaceOptions,
    target_error: Option<f32>,
}

fn placement_specs(
    config: &EvalConfig,
    scene: &Scene,
    scene_config: &SceneConfig,
    region: Option<&Region>,
    viewers: &[Camera],
) -> Result<Vec<PlacementSpec>, EvalError> {
    let size = region.map_or(scene.bounds(), Region::bounds).size();
    let grids: Vec<[u32; 3]> = if scene_config.grids.is_empty() {
        let mut dims: Vec<[u32; 3]> = config
            .grid_counts
            .iter()
            .map(|&n| grid_dims_for_count(size, n))
            .collect();
        dims.dedup();
        dims
    } else {
        scene_config
            .grids
            .iter()
            .map(|g| {
                parse_dims(g).ok_or_else(|| {
                    config.invalid(format!(
                        "grid {g:?} of {} is not NXxNYxNZ",
                        scene_config.scene
                    ))
                })
            })
            .collect::<Result<_, _>>()?
    };
    let with = |method: Method, optimize: Option<Optimizer>, budget: Option<usize>| PlaceOptions {
        optimize,
        budget,
        iterations: config.gibbs_iterations,
        atlas_texels: config.atlas_texels,
        seed: config.view.seed,
        region: region.cloned(),
        ..PlaceOptions::new(method)
    };
    let mut specs: Vec<PlacementSpec> = grids
        .iter()
        .map(|&dims| PlacementSpec {
            name: Method::Grid(dims).name(),
            family: "grid",
            options: with(Method::Grid(dims), None, None),
            target_error: None,
        })
        .collect();
    let placements = if scene_config.placements.is_empty() {
        &config.placements
    } else {
        &scene_config.placements
    };
    for text in placements {
        let complete = text.contains("+complete");
        let views = text.contains("+views");
        let text = text.replace("+complete", "").replace("+views", "");
        // `~E`: an error-driven target (the share of the views' points left unseen).
        // It holds for each view; `~E/mean`: over all views together.
        let (text, target_error, target_mean) = match text.split_once('~') {
            Some((base, e)) => {
                let (e, mean) = match e.strip_suffix("/mean") {
                    Some(e) => (e, true),
                    None => (e, false),
                };
                match e.parse::<f32>() {
                    Ok(e) if (0.0..1.0).contains(&e) => (base.to_owned(), Some(e), mean),
                    _ => {
                        return Err(config.invalid(format!(
                            "placement target {e:?}: give a share of the views' points in [0, 1), e.g. minimal+views~0.05 (each view) or minimal+views~0.05/mean (all views together)"
                        )));
                    }
                }
            }
            None => (text, None, false),
        };
        let text = text.as_str();
        let mut push = |family: &'static str, mut options: PlaceOptions| {
            let mut name = options.method.name();
            match options.optimize {
                Some(Optimizer::Gibbs) => name.push_str("+gibbs"),
                Some(Optimizer::Descent) => name.push_str("+descent"),
                None => {}
            }
            let mut family = family;
            if views {
                options.viewers = Some(viewers.to_vec());
                name.push_str("+views");
                family = "views";
            }
            if complete {
                options.complete = true;
                name.push_str("+complete");
                if !views {
                    family = "complete";
                }
            }
            if let Some(b) = options.budget {
                name.push_str(&format!("@{b}"));
            }
            if let Some(e) = target_error {
                options.coverage = 1.0 - e;
                options.each_view = !target_mean;
                name.push_str(&format!("~{e}"));
                if target_mean {
                    name.push_str("/mean");
                }
            }
            specs.push(PlacementSpec {
                name,
                family,
                options,
                target_error,
            });
        };
        match text {
            "sdf" => push("sdf", with(Method::Sdf, None, None)),
            "sdf+gibbs" => push("sdf+gibbs", with(Method::Sdf, Some(Optimizer::Gibbs), None)),
            "sdf+descent" => push(
                "sdf+descent",
                with(Method::Sdf, Some(Optimizer::Descent), None),
            ),
            "medial" => push("medial", with(Method::Medial, None, None)),
            "medial+gibbs" => push(
                "medial+gibbs",
                with(Method::Medial, Some(Optimizer::Gibbs), None),
            ),
            "minimal" => push("minimal", with(Method::Minimal, None, None)),
            "minimal@grids" => {
                for &dims in &grids {
                    let n = (dims[0] * dims[1] * dims[2]) as usize;
                    push("minimal@N", with(Method::Minimal, None, Some(n)));
                }
            }
            "spawn-merge" => push("spawn-merge", with(Method::SpawnMerge, None, None)),
            "gradient-ascent" => push("gradient-ascent", with(Method::GradientAscent, None, None)),
            other => {
                if let Some(n) = other.strip_prefix("minimal@").and_then(|n| n.parse().ok()) {
                    push("minimal@N", with(Method::Minimal, None, Some(n)));
                } else if let Some(n) = other
                    .strip_prefix("grid-relocated@")
                    .and_then(|n| n.parse().ok())
                {
                    let dims = grid_dims_for_count(size, n);
                    push(
                        "grid-relocated",
                        with(Method::GridRelocated(dims), None, None),
                    );
                } else if let Some(dims) =
                    other.strip_prefix("grid-relocated:").and_then(parse_dims)
                {
                    push(
                        "grid-relocated",
                        with(Method::GridRelocated(dims), None, None),
                    );
                } else {
                    return Err(config.invalid(format!(
                        "unknown placement {other:?} (expected sdf, sdf+gibbs, sdf+descent, medial, \
                         medial+gibbs, minimal, minimal@N, minimal@grids, spawn-merge, \
                         gradient-ascent, grid-relocated@N or grid-relocated:NXxNYxNZ, each \
                         optionally with +views and +complete)"
                    )));
                }
            }
        }
    }
    // The same minimal set may come twice (e.g. minimal@N with N above the full set's size).
    let mut seen = std::collections::HashSet::new();
    specs.retain(|s| seen.insert(s.name.clone()));
    Ok(specs)
}

/// One measured point of the sweep (`T`: its trace's metrics; `()` while the trace waits for
/// the refined reference).
#[derive(Clone, Debug, Serialize)]
pub struct SweepRecord<T = TraceMetrics> {
    /// The scene's name.
    pub scene: String,
    /// The camera.
    pub camera: String,
    /// The placement's name (method, optimiser, budget).
    pub placement: String,
    /// The placement's family for charts (`grid`, `grid-relocated`, `sdf`, ...).
    pub family: String,
    /// Probes.
    pub probes: usize,
    /// Share of the atlas's surface samples seen at a non-grazing angle.
    pub coverage: f64,
    /// Probes inside geometry.
    pub probes_inside_geometry: usize,
    /// Seconds to place.
    pub place_seconds: f64,
    /// Seconds to bake.
    pub bake_seconds: f64,
    /// Mean radiance samples per texel the bake took.
    pub samples_per_texel: f64,
    /// The bake's own noise figure: the mean over its texels of each texel's tone-mapped
    /// variance ([`probe_capture::ProbeBake::noise`]). Not the image's bake noise: an image
    /// inherits the noise of the texels it reads.
    pub bake_texel_noise: Option<f64>,
    /// Seconds to index.
    pub index_seconds: f64,
    /// Distance probes and hi-Z pyramid, MB.
    pub distance_mb: f64,
    /// Radiance, irradiance and moments, MB.
    pub other_mb: f64,
    /// The selection structure, MB.
    pub selection_mb: f64,
    /// The sum, MB.
    pub total_mb: f64,
    /// Views the figures are over: 1 for one camera's record, N for a view set's mean.
    pub views: usize,
    /// A view set's worst view (highest tone-mapped MSE) and its MSE; `None` for one view.
    pub worst_view: Option<(String, f64)>,
    /// The cheap proxy of the glossy error over the scene's evaluation views
    /// ([`probe_place::viewers::ViewProxy`]): the share of what they see, directly and in
    /// reflection, that no probe sees well. `None` for a scene judged from one view.
    pub view_proxy_error: Option<f64>,
    /// For an error-driven set (`minimal+views~E`): the target E.
    pub target_error: Option<f64>,
    /// For a `+views` placement: the proxy on the view set it learnt from (1 − its coverage).
    pub training_proxy_error: Option<f64>,
    /// The trace (for a view set: means over its views, [`mean_over_views`]).
    #[serde(flatten)]
    pub trace: T,
}

impl SweepRecord<()> {
    /// The record with its trace's metrics.
    fn with_trace(self, trace: TraceMetrics) -> SweepRecord {
        SweepRecord {
            scene: self.scene,
            camera: self.camera,
            placement: self.placement,
            family: self.family,
            probes: self.probes,
            coverage: self.coverage,
            probes_inside_geometry: self.probes_inside_geometry,
            place_seconds: self.place_seconds,
            bake_seconds: self.bake_seconds,
            samples_per_texel: self.samples_per_texel,
            bake_texel_noise: self.bake_texel_noise,
            index_seconds: self.index_seconds,
            distance_mb: self.distance_mb,
            other_mb: self.other_mb,
            selection_mb: self.selection_mb,
            total_mb: self.total_mb,
            views: self.views,
            worst_view: self.worst_view,
            view_proxy_error: self.view_proxy_error,
            target_error: self.target_error,
            training_proxy_error: self.training_proxy_error,
            trace,
        }
    }
}

/// The sweep's results.
#[derive(Clone, Debug, Serialize)]
pub struct SweepReport {
    /// The configuration used.
    pub config: EvalConfig,
    /// What traced the rays.
    pub device: String,
    /// Every measured point (one per camera or view).
    pub records: Vec<SweepRecord>,
    /// Per scene with more than one view: each placement, selection and tracer's means over
    /// the views ([`mean_over_views`]). The headline and the charts judge these scenes by them.
    pub view_sets: Vec<SweepRecord>,
    /// Reference render seconds per scene and camera.
    pub reference_seconds: BTreeMap<String, f64>,
    /// The headline figures.
    pub headline: Headline,
    /// Files written.
    pub files: Vec<PathBuf>,
    /// Seconds for the whole sweep.
    pub seconds: f64,
    /// The failure suite's cases, when the configuration asks for them.
    pub failures: Option<FailureReport>,
    /// Placements that could not be measured, with the reason.
    pub skipped: Vec<String>,
}

/// The headline figures, computed from the records.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Headline {
    /// Per scene: fewest probes of an automatic placement that match the best grid's MSE,
    /// divided by that grid's probe count (goal ≤ 0.4).
    pub probes_to_match_best_grid: BTreeMap<String, Option<MatchFigure>>,
    /// Per scene whose bake noise was measured ([`EvalConfig::measure_bake_noise`]): the
    /// same, judged by [`noise_free_error`] (the best grid the one with the least; `grid_mse`
    /// and `mse` hold the errors with the noise taken out).
    pub probes_to_match_best_grid_noise_free: BTreeMap<String, Option<MatchFigure>>,
    /// Per scene and grid: MSE of the minimal set of the grid's probe count divided by the
    /// grid's MSE (goal ≤ 0.25).
    pub mse_at_equal_count: BTreeMap<String, Vec<EqualCountFigure>>,
    /// hi-Z trace time divided by two-level's, over every placement and selection measured
    /// (goal ≤ 0.5): median, min, max.
    pub hiz_time_ratio: Option<[f64; 3]>,
    /// hi-Z texel fetches per ray divided by two-level's (goal ≤ 0.4): median, min, max.
    pub hiz_fetch_ratio: Option<[f64; 3]>,
    /// Per scene with a view set: Spearman's rank correlation between the view proxy and the
    /// measured mean tone-mapped MSE over its placements (best selection and tracer of each),
    /// with the number of placements ranked.
    pub proxy_rank_correlation: BTreeMap<String, (f64, usize)>,
    /// Error-driven sets: the target, the proxy on the views the set learnt from and on the
    /// held-out evaluation views.
    pub target_errors: Vec<TargetFigure>,
}

/// How an error-driven set met its target.
#[derive(Clone, Debug, Serialize)]
pub struct TargetFigure {
    /// The scene.
    pub scene: String,
    /// The placement (`minimal+views~E`).
    pub placement: String,
    /// Its probes.
    pub probes: usize,
    /// The target E.
    pub target: f64,
    /// The proxy on the view set it learnt from.
    pub training: f64,
    /// The proxy on the held-out evaluation views.
    pub held_out: f64,
    /// held_out / target (goal ≤ 1.5).
    pub ratio: f64,
    /// The measured mean tone-mapped MSE over the evaluation views.
    pub mse: f64,
}

/// Spearman's rank correlation of two equally long samples (average ranks for ties); `None`
/// for fewer than 3 pairs or a constant sample.
pub fn spearman(a: &[f64], b: &[f64]) -> Option<f64> {
    let n = a.len().min(b.len());
    if n < 3 {
        return None;
    }
    let ranks = |v: &[f64]| -> Vec<f64> {
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_by(|&i, &j| v[i].total_cmp(&v[j]));
        let mut r = vec![0.0; n];
        let mut i = 0;
        while i < n {
            let mut j = i;
            while j + 1 < n && v[order[j + 1]] == v[order[i]] {
                j += 1;
            }
            let rank = 0.5 * (i + j) as f64;
            for k in i..=j {
                r[order[k]] = rank;
            }
            i = j + 1;
        }
        r
    };
    let (ra, rb) = (ranks(&a[..n]), ranks(&b[..n]));
    let mean = (n as f64 - 1.0) / 2.0;
    let (mut cov, mut va, mut vb) = (0.0, 0.0, 0.0);
    for k in 0..n {
        let (x, y) = (ra[k] - mean, rb[k] - mean);
        cov += x * y;
        va += x * x;
        vb += y * y;
    }
    (va > 0.0 && vb > 0.0).then(|| cov / (va * vb).sqrt())
}

/// "Probes needed to match the best grid's MSE" for one scene.
#[derive(Clone, Debug, Serialize)]
pub struct MatchFigure {
    /// The best grid.
    pub grid: String,
    /// Its probes.
    pub grid_probes: usize,
    /// Its MSE.
    pub grid_mse: f64,
    /// The automatic placement with the fewest probes at or below that MSE.
    pub placement: String,
    /// Its probes.
    pub probes: usize,
    /// Its MSE.
    pub mse: f64,
    /// probes / grid_probes.
    pub ratio: f64,
    /// The scene's worst grid's error over its best grid's (by the same error; at least 1).
    /// Near 1 (below [`FLAT_GRID_SPREAD`]) the scene's error hardly moves with the probe
    /// count, so matching the best grid with few probes says little about placement.
    pub grid_spread: f64,
    /// The grid's image bake noise ([`EvalConfig::measure_bake_noise`]; `None` unmeasured).
    pub grid_bake_noise: Option<f64>,
    /// The placement's image bake noise.
    pub bake_noise: Option<f64>,
}

impl MatchFigure {
    /// Whether the scene's grids lie within [`FLAT_GRID_SPREAD`] of each other: its error
    /// hardly moves with the probe count, and the report says so beside the ratio.
    pub fn grids_flat(&self) -> bool {
        self.grid_spread < FLAT_GRID_SPREAD
    }
}

/// [`MatchFigure::grid_spread`] below which the report says the grids' error hardly moves
/// with the probe count (the leak rooms: 1.02–1.10 over 8 to 63 probes).
pub const FLAT_GRID_SPREAD: f64 = 1.25;

/// "MSE at equal probe count" for one grid.
#[derive(Clone, Debug, Serialize)]
pub struct EqualCountFigure {
    /// The grid.
    pub grid: String,
    /// Probes.
    pub probes: usize,
    /// The grid's MSE.
    pub grid_mse: f64,
    /// The automatic placement compared.
    pub placement: String,
    /// Its probes (at most the grid's).
    pub placement_probes: usize,
    /// Its MSE.
    pub mse: f64,
    /// mse / grid_mse.
    pub ratio: f64,
    /// The grid's image bake noise ([`EvalConfig::measure_bake_noise`]; `None` unmeasured).
    pub grid_bake_noise: Option<f64>,
    /// The placement's image bake noise.
    pub bake_noise: Option<f64>,
    /// The ratio through both second bakes (another seed), when measured.
    pub second_bake_ratio: Option<f64>,
    /// The ratio of the two [`noise_free_error`]s, when the bake noise was measured.
    pub noise_free_ratio: Option<f64>,
}

/// A record's error with the noise taken out, when its bake noise was measured
/// ([`EvalConfig::measure_bake_noise`]): the mean of its two bakes' tone-mapped MSEs less the
/// image's bake noise and the reference's noise. Each bake's MSE is, in expectation, the
/// squared bias of the image its probes converge to plus the variance its bake and the
/// reference add, and those two variances are what the bake noise and the reference noise
/// estimate; so this estimates what a converged bake would score against a converged
/// reference (at least 0). Placements whose bakes are noisier by different amounts are then
/// compared on what their probes can show, not on their Monte Carlo noise.
pub fn noise_free_error(record: &SweepRecord) -> Option<f64> {
    let t = &record.trace;
    let (noise, second) = (t.bake_noise?, t.second_bake_mse_tonemapped?);
    Some((0.5 * (t.mse_tonemapped + second) - noise - t.reference_noise).max(0.0))
}

fn median_min_max(mut values: Vec<f64>) -> Option<[f64; 3]> {
    values.retain(|v| v.is_finite());
    if values.is_empty() {
        return None;
    }
    values.sort_by(f64::total_cmp);
    let n = values.len();
    let median = if n % 2 == 1 {
        values[n / 2]
    } else {
        0.5 * (values[n / 2 - 1] + values[n / 2])
    };
    Some([median, values[0], values[n - 1]])
}

/// The best (lowest-MSE) hi-Z record of each placement of a scene and camera.
fn best_per_placement<'r>(records: &'r [SweepRecord], scene: &str) -> Vec<&'r SweepRecord> {
    let mut best: BTreeMap<(&str, &str), &SweepRecord> = BTreeMap::new();
    for r in records.iter().filter(|r| r.scene == scene) {
        let key = (r.camera.as_str(), r.placement.as_str());
        if best
            .get(&key)
            .is_none_or(|b| r.trace.mse_tonemapped < b.trace.mse_tonemapped)
        {
            best.insert(key, r);
        }
    }
    best.into_values().collect()
}

fn headline(records: &[SweepRecord]) -> Headline {
    let mut h = Headline::default();
    let scenes: Vec<String> = {
        let mut s: Vec<String> = records.iter().map(|r| r.scene.clone()).collect();
        s.dedup();
        s
    };
    for scene in &scenes {
        let best = best_per_placement(records, scene);
        let grids: Vec<&&SweepRecord> = best.iter().filter(|r| r.family == "grid").collect();
        let autos: Vec<&&SweepRecord> = best
            .iter()
            .filter(|r| r.family != "grid" && r.family != "grid-relocated")
            .collect();
        // A view with no error at all (every pixel black in both images) ranks nothing.
        let grids: Vec<&&SweepRecord> = grids
            .into_iter()
            .filter(|g| g.trace.mse_tonemapped > 0.0)
            .collect();
        let best_grid = grids
            .iter()
            .min_by(|a, b| a.trace.mse_tonemapped.total_cmp(&b.trace.mse_tonemapped));
        // The automatic placement with the fewest probes whose `error` is at most the best
        // grid's (the grid with the least `error`).
        let fewest_matching = |error: &dyn Fn(&SweepRecord) -> f64| {
            let g = grids.iter().min_by(|a, b| error(a).total_cmp(&error(b)))?;
            autos
                .iter()
                .filter(|a| error(a) <= error(g))
                .min_by_key(|a| a.probes)
                .map(|a| MatchFigure {
                    grid: g.placement.clone(),
                    grid_probes: g.probes,
                    grid_mse: error(g),
                    placement: a.placement.clone(),
                    probes: a.probes,
                    mse: error(a),
                    ratio: a.probes as f64 / g.probes as f64,
                    grid_spread: grids.iter().map(|g| error(g)).fold(0.0, f64::max) / error(g),
                    grid_bake_noise: g.trace.bake_noise,
                    bake_noise: a.trace.bake_noise,
                })
        };
        h.probes_to_match_best_grid.insert(
            scene.clone(),
            best_grid.and_then(|_| fewest_matching(&|r| r.trace.mse_tonemapped)),
        );
        if grids
            .iter()
            .chain(&autos)
            .all(|r| noise_free_error(r).is_some())
            && !grids.is_empty()
        {
            h.probes_to_match_best_grid_noise_free.insert(
                scene.clone(),
                fewest_matching(&|r| noise_free_error(r).unwrap_or(f64::INFINITY)),
            );
        }
        let mut equal = Vec::new();
        for g in &grids {
            // The best automatic placement with at most the grid's probes, preferring the
            // minimal set made for this count.
            let candidate = autos
                .iter()
                .filter(|a| a.probes <= g.probes && a.probes * 10 >= g.probes * 8)
                .min_by(|a, b| a.trace.mse_tonemapped.total_cmp(&b.trace.mse_tonemapped));
            if let Some(a) = candidate {
                equal.push(EqualCountFigure {
                    grid: g.placement.clone(),
                    probes: g.probes,
                    grid_mse: g.trace.mse_tonemapped,
                    placement: a.placement.clone(),
                    placement_probes: a.probes,
                    mse: a.trace.mse_tonemapped,
                    ratio: a.trace.mse_tonemapped / g.trace.mse_tonemapped,
                    grid_bake_noise: g.trace.bake_noise,
                    bake_noise: a.trace.bake_noise,
                    second_bake_ratio: a
                        .trace
                        .second_bake_mse_tonemapped
                        .zip(g.trace.second_bake_mse_tonemapped)
                        .map(|(a, g)| a / g),
                    noise_free_ratio: noise_free_error(a)
                        .zip(noise_free_error(g))
                        .map(|(a, g)| a / g),
                });
            }
        }
        h.mse_at_equal_count.insert(scene.clone(), equal);
        let ranked: Vec<(f64, f64)> = best
            .iter()
            .filter_map(|r| r.view_proxy_error.map(|p| (p, r.trace.mse_tonemapped)))
            .collect();
        let (proxy, mse): (Vec<f64>, Vec<f64>) = ranked.iter().copied().unzip();
        if let Some(rho) = spearman(&proxy, &mse) {
            h.proxy_rank_correlation
                .insert(scene.clone(), (rho, ranked.len()));
        }
        for r in &best {
            if let (Some(target), Some(training), Some(held_out)) =
                (r.target_error, r.training_proxy_error, r.view_proxy_error)
            {
                h.target_errors.push(TargetFigure {
                    scene: scene.clone(),
                    placement: r.placement.clone(),
                    probes: r.probes,
                    target,
                    training,
                    held_out,
                    ratio: held_out / target.max(f64::MIN_POSITIVE),
                    mse: r.trace.mse_tonemapped,
                });
            }
        }
    }
    let mut time_ratios = Vec::new();
    let mut fetch_ratios = Vec::new();
    for r in records.iter().filter(|r| r.trace.tracer == Tracer::HiZ) {
        if let Some(two) = records.iter().find(|o| {
            o.trace.tracer == Tracer::TwoLevel
                && o.scene == r.scene
                && o.camera == r.camera
                && o.placement == r.placement
                && o.trace.selection == r.trace.selection
        }) {
            time_ratios.push(r.trace.trace_ms / two.trace.trace_ms);
            fetch_ratios.push(r.trace.fetches_per_ray / two.trace.fetches_per_ray);
        }
    }
    h.hiz_time_ratio = median_min_max(time_ratios);
    h.hiz_fetch_ratio = median_min_max(fetch_ratios);
    h
}

/// Runs the sweep and writes `report.md`, `results.csv`, `results.json` and the charts into
/// `out`. `log` receives one line per step.
///
/// # Errors
/// [`EvalError`] from any stage (a scene that fails to load stops the sweep: fix the list).
pub fn run_sweep(
    config: &EvalConfig,
    out: &Path,
    log: &dyn Fn(&str),
) -> Result<SweepReport, EvalError> {
    if config.scenes.is_empty() {
        return Err(
            config.invalid("no scenes: name them on the command line or in [[scenes]]".into())
        );
    }
    let tracers = config.tracers()?;
    let selections = config.selections()?;
    std::fs::create_dir_all(out).map_err(|source| EvalError::Write {
        path: out.to_owned(),
        source,
    })?;
    let start = Instant::now();
    let (mut device, fallback) = Device::open(config.require_gpu)?;
    if let Some(reason) = &fallback {
        log(&format!(
            "no GPU adapter ({reason}); tracing with the CPU twin"
        ));
    }
    log(&format!("tracer device: {}", device.describe()));
    let mut records = Vec::new();
    let mut skipped = Vec::new();
    let mut reference_seconds = BTreeMap::new();
    let mut files = Vec::new();
    for scene_config in &config.scenes {
        let scene = Scene::open(&scene_config.scene)?;
        let region = scene_config.region()?;
        let sampled = scene_config.views.unwrap_or(config.views);
        let cameras = view_set(
            &scene,
            &ViewSetOptions {
                cameras: scene_config.cameras.clone(),
                sampled,
                seed: config.view_seed,
                region: region.clone(),
            },
        )?;
        // `+views` placements learn from a view set of their own (another seed), so that the
        // views they are judged from are held out; or, when asked, from those views.
        let training = if config.learn_from_evaluation_views {
            cameras.clone()
        } else {
            view_set(
                &scene,
                &ViewSetOptions {
                    cameras: scene_config.cameras.clone(),
                    sampled: sampled.max(config.training_views),
                    seed: training_seed(config.view_seed),
                    region: region.clone(),
                },
            )?
        };
        let specs = placement_specs(config, &scene, scene_config, region.as_ref(), &training)?;
        let mut views = Vec::with_capacity(cameras.len());
        for camera in cameras {
            log(&format!("{} / {}: reference", scene.name(), camera.name));
            views.push(EvalView::render(&scene, camera, config.view, &|_, _| {})?);
        }
        let rays: Vec<Vec<TraceRay>> = views.iter().map(EvalView::trace_rays).collect();
        // The proxy over the evaluation views, to see how well it predicts their error.
        let proxy = if views.len() > 1 {
            let cameras: Vec<Camera> = views.iter().map(|v| v.camera.clone()).collect();
            Some(ViewProxy::new(
                &scene,
                region.as_ref(),
                &cameras,
                config.atlas_texels.max(4 * cameras.len()),
            )?)
        } else {
            None
        };
        // Traced first; compared once each view's reference is refined against its traces.
        let mut pending: Vec<Vec<Pending>> = views.iter().map(|_| Vec::new()).collect();
        for spec in &specs {
            log(&format!("{}: {}", scene.name(), spec.name));
            let placed = place_lit(&scene, &spec.options)?;
            // One bake serves every view: the views share the scene's environment and seed.
            // With the split alone, only the bake of the reflected light is read: it is
            // baked directly (the same bytes as the split's second bake), and its time is the
            // placement's bake time.
            let bake_view = if bakes_reflected_light_only(&tracers) {
                bake_reflected_for_view
            } else {
                bake_for_view_seeded
            };
            let bake_seeded = |seed| {
                bake_view(
                    &scene,
                    &placed.probes.positions,
                    config.resolution,
                    config.sampling(),
                    &views[0],
                    seed,
                    &|_, _| {},
                )
            };
            let (baked, bake_seconds) = bake_seeded(views[0].settings.seed)?;
            let grid = placed
                .full_grid
                .and_then(|_| ProbeGrid::detect(baked.positions()));
            let index = match build_index(
                &scene,
                baked.positions(),
                config.svo_depth,
                grid,
                config.view.seed,
            ) {
                Ok(index) => index,
                // A placement the index refuses (fewer than 4 probes, all coplanar) is
                // reported, not fatal to the sweep.
                Err(error) => {
                    let line = format!("{} / {}: not indexed: {error}", scene.name(), spec.name);
                    log(&line);
                    skipped.push(line);
                    continue;
                }
            };
            let memory = ProbeMemory::of(&baked, Tracer::HiZ.options().hiz_top_level);
            let view_proxy_error = proxy.as_ref().map(|p| p.error(baked.positions()));
            // The BVH tracers' shading of hits the light field does not answer (with the
            // bake of the light the surfaces reflect when the split is asked for).
            let shading = hit_shading_for_tracers(&mut device, &tracers, &scene, &baked, &index)?;
            // A second, independent bake of the same probes (same index: it depends on the
            // positions alone) for each image's bake noise.
            let twin = if config.measure_bake_noise {
                let (second, _) = bake_seeded(views[0].settings.seed + 1)?;
                let shading =
                    hit_shading_for_tracers(&mut device, &tracers, &scene, &second, &index)?;
                Some((second, shading))
            } else {
                None
            };
            for (v, view) in views.iter().enumerate() {
                for &selection in &selections {
                    for &tracer in &tracers {
                        // This view, tracer and selection through a bake.
                        let mut trace_bake =
                            |bake: &ProbeBake, shading: Option<&HitShading<'_>>| {
                                trace_only(
                                    &mut device,
                                    &scene,
                                    bake,
                                    &index,
                                    view,
                                    &rays[v],
                                    tracer,
                                    selection,
                                    shading,
                                )
                            };
                        let Some(traced) = trace_bake(&baked, shading.as_ref())? else {
                            continue;
                        };
                        let twin = match &twin {
                            Some((second, shading)) => {
                                trace_bake(second, shading.as_ref())?.map(|t| t.image)
                            }
                            None => None,
                        };
                        let mb = |bytes: u64| bytes as f64 / 1e6;
                        let selection_mb = mb(selection.bytes(&index));
                        let record = SweepRecord {
                            scene: scene.name().to_owned(),
                            camera: view.camera.name.clone(),
                            placement: spec.name.clone(),
                            family: spec.family.to_owned(),
                            probes: baked.probe_count(),
                            coverage: placed.report.coverage,
                            probes_inside_geometry: placed.report.probes_inside_geometry,
                            place_seconds: placed.report.seconds,
                            bake_seconds,
                            samples_per_texel: baked.mean_samples_per_texel(),
                            bake_texel_noise: baked.noise(),
                            index_seconds: index.seconds,
                            distance_mb: mb(memory.distance_bytes),
                            other_mb: mb(memory.other_bytes),
                            selection_mb,
                            total_mb: mb(memory.distance_bytes + memory.other_bytes) + selection_mb,
                            views: 1,
                            worst_view: None,
                            view_proxy_error,
                            target_error: spec.target_error.map(f64::from),
                            training_proxy_error: spec
                                .options
                                .viewers
                                .is_some()
                                .then_some(1.0 - placed.report.coverage),
                            trace: (),
                        };
                        pending[v].push(Pending {
                            record,
                            traced,
                            twin,
                            resolution: baked.resolution(),
                            positions: baked.positions().to_vec(),
                        });
                    }
                }
            }
        }
        for (view, pending) in views.iter_mut().zip(pending) {
            let images: Vec<&Image> = pending.iter().map(|p| &p.traced.image).collect();
            let noise = view.refine(
                &scene,
                &images,
                config.reference_noise_fraction,
                config.reference_max_samples,
                &|_, _| {},
            )?;
            log(&format!(
                "{} / {}: reference {} samples per hit, noise {:.2e}",
                scene.name(),
                view.camera.name,
                noise.samples,
                noise.noise
            ));
            for p in pending {
                let footprints = Footprints {
                    resolution: p.resolution,
                    positions: &p.positions,
                };
                // The bake's own estimate is a mean over its texels; an image inherits the
                // noise of the texels it reads, 1.1× that mean on the Cornell box but 4–5× on
                // Sponza (BENCHMARKS.md, "Bakes that converge"), so it is reported apart
                // (`bake_texel_noise`), and the image's bake noise is measured from a second
                // bake where asked (`measure_bake_noise`).
                let bake_noise = p
                    .twin
                    .as_ref()
                    .map(|twin| tonemapped_mse(&p.traced.image, twin) / 2.0);
                let (mut trace, _) = compare_trace(footprints, view, &p.traced, bake_noise)?;
                trace.second_bake_mse_tonemapped = p
                    .twin
                    .as_ref()
                    .map(|twin| tonemapped_mse(twin, &view.reference_image));
                records.push(p.record.with_trace(trace));
            }
            reference_seconds.insert(
                format!("{}/{}", scene.name(), view.camera.name),
                view.seconds,
            );
        }
    }
    let failures = if config.failure_suite {
        log("failure suite");
        let mut options = FailureOptions::new(config.require_gpu);
        if let Some(dir) = config.scenes_dir.as_ref().filter(|dir| dir.is_dir()) {
            options.shared_scenes = Some(SharedScenes::in_dir(dir));
        }
        Some(run_failure_suite(&options)?)
    } else {
        None
    };
    let view_sets = mean_over_views(&records);
    // A scene with a view set is judged (headline and charts) by its means over the views.
    let judged = judged(&records, &view_sets);
    let headline = headline(&judged);
    let mut report = SweepReport {
        config: config.clone(),
        device: device.describe(),
        records,
        view_sets,
        reference_seconds,
        headline,
        files: Vec::new(),
        seconds: 0.0,
        failures,
        skipped,
    };
    // The data first: a chart that fails must not lose the sweep.
    let csv = out.join("results.csv");
    let all: Vec<SweepRecord> = report
        .records
        .iter()
        .chain(&report.view_sets)
        .cloned()
        .collect();
    write_atomic(&csv, to_csv(&all).as_bytes())?;
    files.push(csv);
    let (charts, notes) = write_charts(&judged, out)?;
    files.extend(charts);
    report.skipped.extend(notes);
    files.push(write_optimiser_chart(out)?.0);
    report.seconds = start.elapsed().as_secs_f64();
    let json = out.join("results.json");
    report.files = files.clone();
    write_atomic(
        &json,
        serde_json::to_string_pretty(&report)
            .unwrap_or_default()
            .as_bytes(),
    )?;
    files.push(json);
    let markdown = out.join("report.md");
    report.files = files.clone();
    report.files.push(markdown.clone());
    write_atomic(&markdown, report_markdown(&report).as_bytes())?;
    Ok(report)
}

fn to_csv(records: &[SweepRecord]) -> String {
    let opt = |v: Option<f64>| v.map_or(String::new(), |v| format!("{v:.6}"));
    let mut text = String::from(
        "scene,camera,placement,family,probes,coverage,probes_inside_geometry,place_seconds,bake_seconds,index_seconds,distance_mb,other_mb,selection_mb,total_mb,tracer,selection,rays,trace_ms,wall_ms,gpu_timestamps,fetches_per_ray,probes_per_ray,hit_rate,unknown_rate,status_agreement,within_footprint,mean_position_error,ray_mse,mse,relative_mse,psnr,mse_tonemapped,reference_noise,bake_noise,second_bake_mse_tonemapped,flip,samples_per_texel,bake_texel_noise,views,worst_view,worst_view_mse_tonemapped,view_proxy_error,target_error,training_proxy_error\n",
    );
    for r in records {
        let t = &r.trace;
        let _ = writeln!(
            text,
            "{},{},{},{},{},{:.6},{},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{},{},{},{:.4},{:.4},{},{:.3},{:.4},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6e},{:.6e},{:.6e},{:.4},{:.6e},{:.6e},{},{},{:.6},{:.3},{},{},{},{},{},{},{}",
            r.scene,
            r.camera,
            r.placement,
            r.family,
            r.probes,
            r.coverage,
            r.probes_inside_geometry,
            r.place_seconds,
            r.bake_seconds,
            r.index_seconds,
            r.distance_mb,
            r.other_mb,
            r.selection_mb,
            r.total_mb,
            t.tracer.name(),
            t.selection.name(),
            t.rays,
            t.trace_ms,
            t.wall_ms,
            t.gpu_timestamps,
            t.fetches_per_ray,
            t.probes_per_ray,
            t.hit_rate,
            t.unknown_rate,
            t.status_agreement,
            t.within_footprint,
            t.mean_position_error,
            t.ray_mse,
            t.mse,
            t.relative_mse,
            t.psnr,
            t.mse_tonemapped,
            t.reference_noise,
            // Measured only with `measure_bake_noise` (else an empty cell, never a made-up
            // figure), as the second bake's MSE. The bake's own texel figure follows, apart.
            t.bake_noise.map_or(String::new(), |n| format!("{n:.6e}")),
            t.second_bake_mse_tonemapped
                .map_or(String::new(), |n| format!("{n:.6e}")),
            t.flip,
            r.samples_per_texel,
            r.bake_texel_noise
                .map_or(String::new(), |n| format!("{n:.6e}")),
            r.views,
            r.worst_view.as_ref().map_or("", |w| w.0.as_str()),
            r.worst_view
                .as_ref()
                .map_or(String::new(), |w| format!("{:.6e}", w.1)),
            opt(r.view_proxy_error),
            opt(r.target_error),
            opt(r.training_proxy_error),
        );
    }
    text
}

fn slug(text: &str) -> String {
    text.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() {
                c.to_ascii_lowercase()
            } else {
                '_'
            }
        })
        .collect()
}

/// The chart families, in legend order.
const FAMILIES: [&str; 11] = [
    "grid",
    "grid-relocated",
    "sdf",
    "sdf+gibbs",
    "sdf+descent",
    "medial",
    "medial+gibbs",
    "minimal",
    "minimal@N",
    "complete",
    "views",
];

/// Writes the charts of every scene; returns the files and a note for each chart left out
/// because none of its points can be drawn (every error 0 on the logarithmic axis: a view of
/// unlit surfaces only, as `leak-closed`'s dark room).
fn write_charts(
    judged: &[SweepRecord],
    out: &Path,
) -> Result<(Vec<PathBuf>, Vec<String>), EvalError> {
    let mut files = Vec::new();
    let mut notes = Vec::new();
    let mut scenes: Vec<&str> = judged.iter().map(|r| r.scene.as_str()).collect();
    scenes.dedup();
    for scene in scenes {
        let records: Vec<&SweepRecord> = judged.iter().filter(|r| r.scene == scene).collect();
        let best = best_per_placement(judged, scene);
        let over = records
            .first()
            .filter(|r| r.views > 1)
            .map_or(String::new(), |r| format!(", {} views", r.views));
        let family_series =
            |points: &dyn Fn(&SweepRecord) -> Option<Point>, all: bool| -> Vec<Series> {
                FAMILIES
                    .iter()
                    .filter_map(|family| {
                        let source: Vec<&SweepRecord> = if all {
                            records
                                .iter()
                                .copied()
                                .filter(|r| r.family == *family)
                                .collect()
                        } else {
                            best.iter()
                                .copied()
                                .filter(|r| r.family == *family)
                                .collect()
                        };
                        let mut pts: Vec<Point> = source.iter().filter_map(|r| points(r)).collect();
                        pts.sort_by(|a, b| a.x.total_cmp(&b.x));
                        (!pts.is_empty()).then(|| {
                            Series::new(
                                *family,
                                if all || *family == "sdf" || *family == "medial" {
                                    SeriesStyle::Markers
                                } else {
                                    SeriesStyle::LineAndMarkers
                                },
                                pts,
                            )
                        })
                    })
                    .collect()
            };
        let charts = [
            (
                "error_vs_time",
                format!(
                    "{scene}: glossy error against trace time (every tracer and selection{over})"
                ),
                "trace time (ms)",
                family_series(
                    &|r| Some(Point::new(r.trace.trace_ms, r.trace.mse_tonemapped)),
                    true,
                ),
                true,
            ),
            (
                "error_vs_probes",
                format!("{scene}: error against probes (best selection{over})"),
                "probes",
                family_series(
                    &|r| {
                        Some(Point::labelled(
                            r.probes as f64,
                            r.trace.mse_tonemapped,
                            r.placement.clone(),
                        ))
                    },
                    false,
                ),
                false,
            ),
            (
                "error_vs_memory",
                format!("{scene}: glossy error against memory (probe textures + selection{over})"),
                "memory (MB)",
                family_series(
                    &|r| Some(Point::new(r.total_mb, r.trace.mse_tonemapped)),
                    false,
                ),
                true,
            ),
        ];
        for (stem, title, x_label, series, pareto) in charts {
            if series.is_empty() {
                continue;
            }
            let mut spec = ChartSpec::new(
                title,
                x_label,
                "MSE of the glossy component (tone-mapped x/(1+x))",
            );
            spec.x_log = true;
            spec.y_log = true;
            spec.pareto_front = pareto;
            spec.series = series;
            // The noise floor beside the errors: the noisiest reference of the scene's
            // cameras.
            let floor = records
                .iter()
                .map(|r| r.trace.reference_noise)
                .fold(0.0, f64::max);
            if floor > 0.0 {
                spec.floors.push(crate::chart::Floor {
                    name: format!("reference noise floor ({floor:.1e})"),
                    y: floor,
                });
            }
            // And the images' bake noise where it was measured (`measure_bake_noise`): the
            // median over the chart's records, below which errors are as much the bakes'
            // noise as the placements'.
            let bake_noises: Vec<f64> = records.iter().filter_map(|r| r.trace.bake_noise).collect();
            if let Some([median, _, _]) = median_min_max(bake_noises).filter(|m| m[0] > 0.0) {
                spec.floors.push(crate::chart::Floor {
                    name: format!("bake noise, median over the placements ({median:.1e})"),
                    y: median,
                });
            }
            let png = out.join(format!("{stem}_{}.png", slug(scene)));
            let svg = out.join(format!("{stem}_{}.svg", slug(scene)));
            match write_chart(&spec, &png, &svg) {
                Ok(_) => {
                    files.push(png);
                    files.push(svg);
                }
                Err(crate::chart::ChartError::NothingToDraw { dropped }) => notes.push(format!(
                    "{scene}: chart {stem} not drawn: none of its {dropped} points is positive \
                     (every error is 0: the view sees no lit surface)"
                )),
                Err(error) => return Err(error.into()),
            }
        }
    }
    Ok((files, notes))
}

/// The chart of issue 4: on the built-in Cornell box, one probe under plain descent over the
/// support cube settles into seed 000's back-and-forth oscillation while Gibbs sampling from
/// the same start keeps improving. Returns the PNG and SVG paths.
///
/// # Errors
/// [`EvalError`] from the atlas, the optimisers or the chart.
pub fn write_optimiser_chart(out: &Path) -> Result<(PathBuf, PathBuf), EvalError> {
    let scene = Scene::builtin("cornell")?;
    let free = BackfaceVote::new(&scene);
    let pool = free_space_grid(&free, 0.035);
    let atlas = Atlas::build(&scene, &AtlasParams::for_texel_count(&scene, 3000), &pool)
        .map_err(PlaceError::from)?;
    let start = [Vec3::new(0.1, 0.1, 0.1)];
    let iterations = 30;
    let descent = descend(
        &atlas,
        &free,
        &start,
        &DescentParams {
            step: 0.04,
            max_iterations: iterations,
            weights: RewardWeights::default(),
        },
    )
    .map_err(PlaceError::from)?;
    let mut series = vec![Series::from_values(
        "descent (moves to the best support probe)",
        &descent.history.iter().map(|r| r.reward).collect::<Vec<_>>(),
    )];
    for seed in 0..3 {
        let result = gibbs(
            &atlas,
            &free,
            &start,
            &GibbsParams {
                seed,
                max_iterations: iterations,
                ..GibbsParams::with_step(0.04)
            },
        )
        .map_err(PlaceError::from)?;
        // The best reward met so far: Gibbs keeps the best set it visits.
        let mut best = f64::MIN;
        let values: Vec<f64> = result
            .history
            .iter()
            .map(|r| {
                best = best.max(r.reward);
                best
            })
            .collect();
        series.push(Series::from_values(
            format!("Gibbs, seed {seed} (best so far)"),
            &values,
        ));
    }
    let mut spec = ChartSpec::new(
        "One probe in the Cornell box: descent oscillates, Gibbs escapes",
        "iteration",
        "reward R(P) (mean texel fitness, eq. 3.1-3.2)",
    );
    spec.series = series;
    let png = out.join("gibbs_vs_descent.png");
    let svg = out.join("gibbs_vs_descent.svg");
    write_chart(&spec, &png, &svg)?;
    Ok((png, svg))
}

fn report_markdown(report: &SweepReport) -> String {
    let mut text = String::new();
    let c = &report.config;
    let _ = writeln!(text, "# Evaluation report\n");
    let _ = writeln!(
        text,
        "Glossy (one-bounce, {}) component at {}×{} ({} reflection ray(s) per pixel), probes at {}² with {} samples per texel and {} bounce(s), octree depth {}; traced on {}. Generated by `probes eval` in {:.0} s.\n",
        if c.view.roughness > 0.0 {
            format!("GGX roughness {}", c.view.roughness)
        } else {
            "mirror".to_owned()
        },
        c.view.width,
        c.view.height,
        c.view.rays_per_pixel,
        c.resolution,
        if c.max_samples_per_texel > c.samples_per_texel {
            format!(
                "{}–{} (adaptive, to a tone-mapped noise of {:.1e} per texel)",
                c.samples_per_texel, c.max_samples_per_texel, c.noise_target
            )
        } else {
            c.samples_per_texel.to_string()
        },
        c.view.bounces,
        c.svo_depth,
        report.device,
        report.seconds
    );
    if c.placements.iter().any(|p| p.contains("+views"))
        || c.scenes
            .iter()
            .any(|s| s.placements.iter().any(|p| p.contains("+views")))
    {
        let _ = writeln!(
            text,
            "{}\n",
            if c.learn_from_evaluation_views {
                "`+views` placements learn from the evaluation views themselves (`learn_from_evaluation_views`): placed for where the viewers are and judged there."
            } else {
                "`+views` placements learn from a training view set the evaluation never renders (another seed; at least `training_views` sampled viewpoints besides the cameras): every `+views` figure is on held-out views."
            }
        );
    }
    let h = &report.headline;
    let _ = writeln!(text, "## Headline figures\n");
    let _ = writeln!(
        text,
        "| scene | best grid | its MSE (tone-mapped) | fewest automatic probes matching it | ratio (goal ≤ 0.4) | grids' worst / best MSE |"
    );
    let _ = writeln!(text, "|---|---|---:|---|---:|---:|");
    let mut flat = false;
    for (scene, figure) in &h.probes_to_match_best_grid {
        match figure {
            Some(f) => {
                let mark = if f.grids_flat() {
                    flat = true;
                    " (flat)"
                } else {
                    ""
                };
                let _ = writeln!(
                    text,
                    "| {scene} | {} ({} probes) | {:.3e} | {} ({} probes, MSE {:.3e}) | {:.2} | {:.2}{mark} |",
                    f.grid,
                    f.grid_probes,
                    f.grid_mse,
                    f.placement,
                    f.probes,
                    f.mse,
                    f.ratio,
                    f.grid_spread
                );
            }
            None => {
                let _ = writeln!(
                    text,
                    "| {scene} | — | — | no automatic placement reached the best grid's MSE | — | |"
                );
            }
        }
    }
    if !h.probes_to_match_best_grid_noise_free.is_empty() {
        let _ = writeln!(
            text,
            "\nWith the noise taken out (`measure_bake_noise`: each error is the mean of the placement's two bakes' MSEs, seeds s and s + 1, less the image's bake noise — half the tone-mapped MSE between the two images — and the reference's noise: what converged bakes would score against a converged reference):\n\n| scene | best grid | its error | its bake noise | fewest automatic probes matching it | their error | their bake noise | ratio (goal ≤ 0.4) |\n|---|---|---:|---:|---|---:|---:|---:|"
        );
        for (scene, figure) in &h.probes_to_match_best_grid_noise_free {
            match figure {
                Some(f) => {
                    let _ = writeln!(
                        text,
                        "| {scene} | {} ({} probes) | {:.3e} | {} | {} ({} probes) | {:.3e} | {} | {:.2}{} |",
                        f.grid,
                        f.grid_probes,
                        f.grid_mse,
                        noise_cell(f.grid_bake_noise),
                        f.placement,
                        f.probes,
                        f.mse,
                        noise_cell(f.bake_noise),
                        f.ratio,
                        if f.grids_flat() {
                            flat = true;
                            " (flat)"
                        } else {
                            ""
                        }
                    );
                }
                None => {
                    let _ = writeln!(
                        text,
                        "| {scene} | — | — | — | no automatic placement reached the best grid's error | — | — | — |"
                    );
                }
            }
        }
    }
    if flat {
        let _ = writeln!(
            text,
            "\n(flat): the scene's grids lie within {FLAT_GRID_SPREAD}× of each other, so its error hardly moves with the probe count and matching the best grid with few probes says little about placement."
        );
    }
    let _ = writeln!(
        text,
        "\n| scene | grid | probes | grid MSE (tone-mapped) | automatic placement (≤ same count) | its MSE | ratio (goal ≤ 0.25) | bake noise (grid / placement) | ratio, second bakes | ratio, noise taken out |"
    );
    let _ = writeln!(text, "|---|---|---:|---:|---|---:|---:|---|---:|---:|");
    for (scene, figures) in &h.mse_at_equal_count {
        for f in figures {
            let _ = writeln!(
                text,
                "| {scene} | {} | {} | {:.3e} | {} ({} probes) | {:.3e} | {:.2} | {} / {} | {} | {} |",
                f.grid,
                f.probes,
                f.grid_mse,
                f.placement,
                f.placement_probes,
                f.mse,
                f.ratio,
                noise_cell(f.grid_bake_noise),
                noise_cell(f.bake_noise),
                ratio_cell(f.second_bake_ratio),
                ratio_cell(f.noise_free_ratio)
            );
        }
    }
    if !h.proxy_rank_correlation.is_empty() {
        let _ = writeln!(
            text,
            "\nHow well the view proxy (share of what the evaluation views see, directly and in reflection, that no probe sees at a non-grazing angle) ranks the placements by their measured mean error:\n\n| scene | placements | Spearman ρ (proxy, MSE) |\n|---|---:|---:|"
        );
        for (scene, (rho, n)) in &h.proxy_rank_correlation {
            let _ = writeln!(text, "| {scene} | {n} | {rho:.2} |");
        }
    }
    if !h.target_errors.is_empty() {
        let _ = writeln!(
            text,
            "\nError-driven sets (`~E`: the proxy's target) on the views they learnt from and on the held-out evaluation views:\n\n| scene | placement | probes | target | training proxy | held-out proxy | held-out / target (goal ≤ 1.5) | mean MSE |\n|---|---|---:|---:|---:|---:|---:|---:|"
        );
        for f in &h.target_errors {
            let _ = writeln!(
                text,
                "| {} | {} | {} | {:.3} | {:.3} | {:.3} | {:.2} | {:.3e} |",
                f.scene, f.placement, f.probes, f.target, f.training, f.held_out, f.ratio, f.mse
            );
        }
    }
    if let Some([median, min, max]) = h.hiz_time_ratio {
        let _ = writeln!(
            text,
            "\nhi-Z trace time / two-level trace time (same rays, probes and selection): median {median:.2}, range {min:.2}–{max:.2} (goal ≤ 0.5)."
        );
    }
    if let Some([median, min, max]) = h.hiz_fetch_ratio {
        let _ = writeln!(
            text,
            "hi-Z texel fetches per ray / two-level's: median {median:.2}, range {min:.2}–{max:.2} (goal ≤ 0.4)."
        );
    }
    if !report.view_sets.is_empty() {
        let _ = writeln!(
            text,
            "\n## View sets\n\nScenes judged from several views: the headline and the charts use the mean over the views; the worst view is beside it.\n"
        );
        let _ = writeln!(
            text,
            "| scene | placement | probes | selection | trace algorithm | views | mean MSE (tone-mapped) | worst view | its MSE | mean reference noise | mean bake noise | mean MSE, second bake | mean FLIP | mean UNKNOWN |"
        );
        let _ = writeln!(
            text,
            "|---|---|---:|---|---|---:|---:|---|---:|---:|---:|---:|---:|---:|"
        );
        for r in &report.view_sets {
            let (worst, worst_mse) = r
                .worst_view
                .clone()
                .unwrap_or_else(|| ("—".to_owned(), f64::NAN));
            let _ = writeln!(
                text,
                "| {} | {} | {} | {} | {} | {} | {:.3e} | {} | {:.3e} | {:.1e} | {} | {} | {:.4} | {:.1} % |",
                r.scene,
                r.placement,
                r.probes,
                r.trace.selection.name(),
                r.trace.tracer.name(),
                r.views,
                r.trace.mse_tonemapped,
                worst,
                worst_mse,
                r.trace.reference_noise,
                noise_cell(r.trace.bake_noise),
                mse_cell(r.trace.second_bake_mse_tonemapped),
                r.trace.flip,
                100.0 * r.trace.unknown_rate
            );
        }
    }
    // Seed 000 Table 5.1: time per placement and tracer.
    let _ = writeln!(
        text,
        "\n## Trace time by placement (the form of seed 000's Table 5.1)\n"
    );
    let _ = writeln!(
        text,
        "| scene | camera | probes | placement | selection | trace algorithm | time (ms) | fetches/ray | probes/ray | MSE | MSE (tone-mapped) | reference noise | bake noise | FLIP | status agreement |"
    );
    let _ = writeln!(
        text,
        "|---|---|---:|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
    );
    for r in &report.records {
        let _ = writeln!(
            text,
            "| {} | {} | {} | {} | {} | {} | {:.2} | {:.1} | {:.2} | {:.3e} | {:.3e} | {:.1e} | {} | {:.4} | {:.1} % |",
            r.scene,
            r.camera,
            r.probes,
            r.placement,
            r.trace.selection.name(),
            r.trace.tracer.name(),
            r.trace.trace_ms,
            r.trace.fetches_per_ray,
            r.trace.probes_per_ray,
            r.trace.mse,
            r.trace.mse_tonemapped,
            r.trace.reference_noise,
            noise_cell(r.trace.bake_noise),
            r.trace.flip,
            100.0 * r.trace.status_agreement
        );
    }
    // Seed 000 Table 5.2: memory per placement.
    let _ = writeln!(text, "\n## Memory (the form of seed 000's Table 5.2, MB)\n");
    let _ = writeln!(
        text,
        "| scene | placement | probes | distance probes + hi-Z | other textures | SVO | Voronoi (tree + neighbours) | total with SVO |"
    );
    let _ = writeln!(text, "|---|---|---:|---:|---:|---:|---:|---:|");
    let mut seen = std::collections::HashSet::new();
    for r in &report.records {
        if !seen.insert((r.scene.clone(), r.placement.clone())) {
            continue;
        }
        let selection_mb = |s: Selection| {
            report
                .records
                .iter()
                .find(|o| {
                    o.scene == r.scene && o.placement == r.placement && o.trace.selection == s
                })
                .map(|o| o.selection_mb)
        };
        let svo = selection_mb(Selection::Svo);
        let voronoi = selection_mb(Selection::Voronoi);
        let fmt = |v: Option<f64>| v.map_or("—".to_owned(), |v| format!("{v:.2}"));
        let _ = writeln!(
            text,
            "| {} | {} | {} | {:.2} | {:.2} | {} | {} | {:.2} |",
            r.scene,
            r.placement,
            r.probes,
            r.distance_mb,
            r.other_mb,
            fmt(svo),
            fmt(voronoi),
            r.distance_mb + r.other_mb + svo.unwrap_or(0.0)
        );
    }
    let _ = writeln!(text, "\n## Placements\n");
    if report
        .config
        .tracers()
        .is_ok_and(|t| bakes_reflected_light_only(&t))
    {
        let _ = writeln!(
            text,
            "With the split the only tracer, each placement's bake is the bake of the light the surfaces reflect that the split reads (`BakedRadiance::Indirect`), made directly; its time is the bake time below.\n"
        );
    }
    let _ = writeln!(
        text,
        "| scene | placement | probes | coverage | inside geometry | place (s) | bake (s) | index (s) |"
    );
    let _ = writeln!(text, "|---|---|---:|---:|---:|---:|---:|---:|");
    let mut seen = std::collections::HashSet::new();
    for r in &report.records {
        if seen.insert((r.scene.clone(), r.placement.clone())) {
            let _ = writeln!(
                text,
                "| {} | {} | {} | {:.2} % | {} | {:.2} | {:.2} | {:.2} |",
                r.scene,
                r.placement,
                r.probes,
                100.0 * r.coverage,
                r.probes_inside_geometry,
                r.place_seconds,
                r.bake_seconds,
                r.index_seconds
            );
        }
    }
    let _ = writeln!(text, "\n## Charts\n");
    for file in &report.files {
        if file.extension().is_some_and(|e| e == "png") {
            let name = file
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
            let _ = writeln!(text, "![{name}]({name})");
        }
    }
    let _ = writeln!(
        text,
        "\nEvery point is in `results.csv` and `results.json`. Trace times are {}.",
        if report.device.starts_with("gpu") {
            "GPU timestamps (or wall-clock of the call where timestamps are missing) on the device above"
        } else {
            "wall-clock on the CPU twin"
        }
    );
    if !report.skipped.is_empty() {
        let _ = writeln!(text, "\nNot measured:\n");
        for line in &report.skipped {
            let _ = writeln!(text, "- {line}");
        }
    }
    if let Some(failures) = &report.failures {
        let _ = writeln!(text, "\n{}", failures.markdown());
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::{Selection, Tracer};

    /// A judged record of `scene` with only what the headline reads.
    fn record(placement: &str, family: &str, probes: usize, mse: f64) -> SweepRecord {
        SweepRecord {
            scene: "s".into(),
            camera: "mean".into(),
            placement: placement.into(),
            family: family.into(),
            probes,
            coverage: 1.0,
            probes_inside_geometry: 0,
            place_seconds: 0.0,
            bake_seconds: 0.0,
            samples_per_texel: 1.0,
            bake_texel_noise: None,
            index_seconds: 0.0,
            distance_mb: 0.0,
            other_mb: 0.0,
            selection_mb: 0.0,
            total_mb: 0.0,
            views: 1,
            worst_view: None,
            view_proxy_error: None,
            target_error: None,
            training_proxy_error: None,
            trace: TraceMetrics {
                tracer: Tracer::HiZ,
                selection: Selection::Voronoi,
                rays: 1,
                trace_ms: 1.0,
                wall_ms: 1.0,
                gpu_timestamps: false,
                fetches_per_ray: 1.0,
                probes_per_ray: 1.0,
                hit_rate: 1.0,
                unknown_rate: 0.0,
                status_agreement: 1.0,
                within_footprint: 1.0,
                mean_position_error: 0.0,
                ray_mse: mse,
                mse,
                mse_tonemapped: mse,
                relative_mse: mse,
                psnr: 0.0,
                flip: 0.0,
                reference_noise: 0.0,
                bake_noise: None,
                second_bake_mse_tonemapped: None,
                classes: Vec::new(),
            },
        }
    }

    /// The match figure carries the grids' spread (worst over best grid MSE): under
    /// [`FLAT_GRID_SPREAD`] for a scene whose grids lie close together (where few automatic
    /// probes match the best grid because the count hardly matters; the report marks it), over
    /// it for a steep one.
    #[test]
    fn the_match_figure_carries_the_grids_spread() {
        let steep = [
            record("grid-2x2x2", "grid", 8, 4.0e-3),
            record("grid-4x4x4", "grid", 64, 1.0e-3),
            record("minimal@8", "minimal", 8, 0.9e-3),
        ];
        let flat = [
            record("grid-2x2x2", "grid", 8, 1.1e-3),
            record("grid-4x4x4", "grid", 64, 1.0e-3),
            record("minimal@8", "minimal", 8, 0.9e-3),
        ];
        let steep_figure = headline(&steep).probes_to_match_best_grid["s"]
            .clone()
            .unwrap();
        assert_eq!(steep_figure.probes, 8);
        assert!((steep_figure.grid_spread - 4.0).abs() < 1e-9);
        let flat_figure = headline(&flat).probes_to_match_best_grid["s"]
            .clone()
            .unwrap();
        assert!((flat_figure.grid_spread - 1.1).abs() < 1e-9);
        assert!(flat_figure.grids_flat());
        assert!(!steep_figure.grids_flat());
    }

    /// The report says which views `+views` placements learnt from, and says nothing of it
    /// when there are none.
    #[test]
    fn the_report_names_what_views_placements_learn_from() {
        let report = |placements: &[&str], learn: bool| {
            report_markdown(&SweepReport {
                config: EvalConfig {
                    placements: placements.iter().map(|p| p.to_string()).collect(),
                    learn_from_evaluation_views: learn,
                    ..EvalConfig::default()
                },
                device: "test".into(),
                records: Vec::new(),
                view_sets: Vec::new(),
                reference_seconds: BTreeMap::new(),
                headline: Headline::default(),
                files: Vec::new(),
                seconds: 0.0,
                failures: None,
                skipped: Vec::new(),
            })
        };
        let held_out = report(&["minimal+views@grids"], false);
        let learnt = report(&["minimal+views@grids"], true);
        let none = report(&["sdf+gibbs"], true);
        assert!(held_out.contains("held-out views"), "{held_out}");
        assert!(learnt.contains("learn from the evaluation views themselves"));
        assert!(!learnt.contains("held-out views"));
        assert!(!none.contains("`+views` placements"));
    }
}
