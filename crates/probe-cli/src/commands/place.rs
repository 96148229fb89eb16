//! `probes place`: automatic probe placement with its report.

use crate::cli_error::CliError;
use crate::output::Report;
use crate::progress::spinner;
use crate::spec::open_scene;
use probe_eval::EvalError;
use probe_eval::lighting::place_lit;
use probe_eval::top_view::{TopViewOptions, write_top_view};
use probe_eval::views::{ViewSetOptions, scene_cameras, view_set};
use probe_place::pipeline::{Method, Optimizer, PlaceOptions, Placement};
use probe_place::region::Region;
use serde_json::{Value, json};
use std::path::PathBuf;

/// Placement methods on the command line.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum MethodArg {
    /// A regular grid over the scene bounds (`--grid NXxNYxNZ`).
    Grid,
    /// The regular grid with DDGI classification and relocation.
    GridRelocated,
    /// Seed 000's SDF skeleton.
    Sdf,
    /// Seed 000's shrinking-ball medial axis.
    Medial,
    /// Seed 002's spawn and merge (lighting from probe-capture).
    SpawnMerge,
    /// Seed 002's irradiance-gradient ascent (lighting from probe-capture).
    GradientAscent,
    /// The fewest probes from a dense candidate pool reaching `--coverage` within `--budget`.
    Minimal,
}

/// Optimisers on the command line.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum OptimizeArg {
    /// Gibbs sampling with importance-sampled directions (seed 000 Alg. 2).
    Gibbs,
    /// Gradient descent over the 8-probe support cube (seed 000 eq. 3.3).
    Descent,
}

/// Arguments of `probes place`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// A glTF 2.0 file or `builtin:NAME`.
    pub scene: String,
    /// The placement method.
    #[arg(long, value_enum, default_value_t = MethodArg::Sdf)]
    pub method: MethodArg,
    /// Grid dimensions for `grid` and `grid-relocated`, `NXxNYxNZ`.
    #[arg(long, default_value = "4x2x4")]
    pub grid: String,
    /// Optimise the method's probes.
    #[arg(long, value_enum)]
    pub optimize: Option<OptimizeArg>,
    /// Keep at most this many probes (chosen greedily by coverage).
    #[arg(long)]
    pub budget: Option<usize>,
    /// Target share of surface samples seen at a non-grazing angle, in (0, 1].
    #[arg(long, default_value_t = 1.0)]
    pub coverage: f32,
    /// Seed of every random choice.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Optimiser iteration cap.
    #[arg(long, default_value_t = 100)]
    pub iterations: usize,
    /// Surface samples (atlas texels) coverage is measured on.
    #[arg(long, default_value_t = 20_000)]
    pub texels: usize,
    /// A region of interest, `x0,y0,z0:x1,y1,z1` (metres; repeat for a union of boxes):
    /// probes only inside, coverage only of what a point inside can see.
    #[arg(long, value_name = "BOX")]
    pub region: Vec<String>,
    /// Complete the coverage: add the free points (of the region) that see the most unseen
    /// surface until every surface sample is seen (within `--budget`).
    #[arg(long)]
    pub complete: bool,
    /// Judge surfaces by a view set: the scene's cameras and N viewpoints sampled in the
    /// region (or free space); the atlas is what they see, directly and in reflection.
    #[arg(long)]
    pub views: Option<usize>,
    /// Seed of the sampled viewpoints.
    #[arg(long, default_value_t = 0)]
    pub view_seed: u64,
    /// Error-driven set (with `--method minimal` and `--views`): the share of what the views
    /// see, directly and in reflection, that may stay unseen by every probe (the proxy of their
    /// glossy error); sets `--coverage` to 1 − E.
    /// The target holds for each view (so that views the set did not learn from meet it
    /// too); see `--target-mean`. Sample 64 or more views: the set generalises from them.
    #[arg(long, value_name = "E", conflicts_with = "coverage")]
    pub target_error: Option<f32>,
    /// With `--target-error`: hold the target over all views together instead of for each
    /// view (fewer probes; views not in the set may see several times the target unseen).
    #[arg(long, requires = "target_error")]
    pub target_mean: bool,
    /// Where to write the probes (`probes/1` JSON).
    #[arg(long)]
    pub out: PathBuf,
    /// Also draw the probes over a top view of the scene into this PNG.
    #[arg(long)]
    pub top_view: Option<PathBuf>,
    /// Also write the optimiser's per-iteration history (JSON) here.
    #[arg(long)]
    pub history: Option<PathBuf>,
}

/// Parses `NXxNYxNZ`.
pub fn parse_dims(parameter: &'static str, text: &str) -> Result<[u32; 3], CliError> {
    let parts: Vec<Option<u32>> = text.split('x').map(|p| p.parse().ok()).collect();
    match parts.as_slice() {
        [Some(x), Some(y), Some(z)] => Ok([*x, *y, *z]),
        _ => Err(CliError::InvalidArgument {
            parameter,
            value: text.to_owned(),
            reason: "expected NXxNYxNZ, e.g. 4x2x4".into(),
        }),
    }
}

/// The `--region` boxes as a region (`None` without any).
pub fn parse_region(boxes: &[String]) -> Result<Option<Region>, CliError> {
    if boxes.is_empty() {
        return Ok(None);
    }
    Region::parse_boxes(boxes)
        .map(Some)
        .map_err(|error| CliError::InvalidArgument {
            parameter: "--region",
            value: boxes.join(" "),
            reason: error.to_string(),
        })
}

/// Places the probes, writes them (and the pictures asked for) and reports.
pub fn run(args: &Args) -> Result<Box<dyn Report>, CliError> {
    let scene = open_scene(&args.scene)?;
    let method = match args.method {
        MethodArg::Grid => Method::Grid(parse_dims("--grid", &args.grid)?),
        MethodArg::GridRelocated => Method::GridRelocated(parse_dims("--grid", &args.grid)?),
        MethodArg::Sdf => Method::Sdf,
        MethodArg::Medial => Method::Medial,
        MethodArg::SpawnMerge => Method::SpawnMerge,
        MethodArg::GradientAscent => Method::GradientAscent,
        MethodArg::Minimal => Method::Minimal,
    };
    let options = PlaceOptions {
        optimize: args.optimize.map(|o| match o {
            OptimizeArg::Gibbs => Optimizer::Gibbs,
            OptimizeArg::Descent => Optimizer::Descent,
        }),
        budget: args.budget,
        coverage: match args.target_error {
            Some(e) if args.views.is_none() => {
                return Err(CliError::InvalidArgument {
                    parameter: "--target-error",
                    value: e.to_string(),
                    reason: "needs --views N: the error is that of a view set".into(),
                });
            }
            Some(e) if !(0.0..1.0).contains(&e) => {
                return Err(CliError::InvalidArgument {
                    parameter: "--target-error",
                    value: e.to_string(),
                    reason: "a share of the seen points in [0, 1)".into(),
                });
            }
            Some(e) => 1.0 - e,
            None => args.coverage,
        },
        seed: args.seed,
        iterations: args.iterations,
        atlas_texels: args.texels,
        region: parse_region(&args.region)?,
        complete: args.complete,
        each_view: args.target_error.is_some() && !args.target_mean,
        ..PlaceOptions::new(method)
    };
    let options = PlaceOptions {
        viewers: match args.views {
            Some(sampled) => Some(
                view_set(
                    &scene,
                    &ViewSetOptions {
                        cameras: scene_cameras(&scene),
                        sampled,
                        seed: args.view_seed,
                        region: options.region.clone(),
                    },
                )
                .map_err(|e| CliError::Eval(e.into()))?,
            ),
            None => None,
        },
        ..options
    };
    let progress = spinner("placing");
    // Seed 002's methods get their lighting from probe-capture.
    let placed = place_lit(&scene, &options);
    progress.finish_and_clear();
    let placed = placed.map_err(|error| match error {
        EvalError::Place(error) => CliError::Place(error),
        other => CliError::Eval(other),
    })?;
    placed.probes.save(&args.out)?;
    if let Some(png) = &args.top_view {
        let bounds = scene.bounds();
        let view = TopViewOptions {
            // Cut just under the top so that ceilings and roofs do not hide the interior.
            // With a region, at its top: the floors viewers stand on.
            cut_height: Some(
                options
                    .region
                    .as_ref()
                    .map_or(bounds.max.y - 0.05 * bounds.size().y, |r| {
                        r.bounds().max.y.min(bounds.max.y)
                    }),
            ),
            number_probes: placed.probes.len() <= 200,
            caption: Some(format!(
                "{}: {} probes, coverage {:.2} %",
                placed.report.method,
                placed.probes.len(),
                100.0 * placed.report.coverage
            )),
            regions: options
                .region
                .as_ref()
                .map_or_else(Vec::new, |r| r.boxes().to_vec()),
            ..TopViewOptions::default()
        };
        write_top_view(&scene, &placed.probes.positions, &view, png)?;
    }
    if let Some(path) = &args.history {
        let history = placed.history.as_ref().ok_or(CliError::InvalidArgument {
            parameter: "--history",
            value: path.display().to_string(),
            reason: "there is no history without --optimize".into(),
        })?;
        let text = serde_json::to_string_pretty(history).unwrap_or_default();
        probe_eval::write_atomic(path, text.as_bytes())?;
    }
    Ok(Box::new(PlaceSummary {
        region: options.region.is_some(),
        placed,
        out: args.out.clone(),
        top_view: args.top_view.clone(),
    }))
}

struct PlaceSummary {
    placed: Placement,
    region: bool,
    out: PathBuf,
    top_view: Option<PathBuf>,
}

impl Report for PlaceSummary {
    fn json(&self) -> Value {
        let mut value = serde_json::to_value(&self.placed.report).unwrap_or(Value::Null);
        if let Value::Object(map) = &mut value {
            map.insert("command".into(), json!("place"));
            map.insert("out".into(), json!(self.out.display().to_string()));
            map.insert(
                "top_view".into(),
                json!(self.top_view.as_ref().map(|p| p.display().to_string())),
            );
            map.insert("atlas_seconds".into(), json!(self.placed.atlas_seconds));
            map.insert(
                "optimizer_iterations".into(),
                json!(
                    self.placed
                        .history
                        .as_ref()
                        .map(|h| h.len().saturating_sub(1))
                ),
            );
        }
        value
    }

    fn text(&self) -> String {
        let r = &self.placed.report;
        let mut text = format!(
            "method     {}\nprobes     {}\ncoverage   {:.2} % ({} of {} surface samples seen at view cosine > {}; {} unreachable from {})\n\
             best view  mean cosine {:.3}\ninside     {} probes inside geometry, {} outside the bounds\ntime       {:.2} s (+{:.2} s free space and atlas)\nwrote      {}\n",
            r.method,
            r.probe_count,
            100.0 * r.coverage,
            r.covered_texels,
            r.texels,
            r.min_view_cosine,
            r.unreachable_texels,
            if self.region {
                "the region's free space"
            } else {
                "free space"
            },
            r.mean_best_view_cosine,
            r.probes_inside_geometry,
            r.probes_outside_bounds,
            r.seconds,
            self.placed.atlas_seconds,
            self.out.display(),
        );
        if let Some(worst) = r.worst_view_coverage
            && let Some(at) = text.find("best view")
        {
            text.insert_str(at, &format!("worst view {:.2} % seen\n", 100.0 * worst));
        }
        if let Some(png) = &self.top_view {
            text.push_str(&format!("top view   {}\n", png.display()));
        }
        text
    }
}
