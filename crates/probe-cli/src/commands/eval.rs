//! `probes eval`: the speed-against-accuracy sweep with its report and charts.

use crate::cli_error::CliError;
use crate::output::Report;
use crate::spec::MemoryArgs;
use probe_eval::sweep::{EvalConfig, SceneConfig, SweepReport, run_sweep};
use serde_json::{Value, json};
use std::path::PathBuf;

/// Arguments of `probes eval`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Scenes (glTF paths or `builtin:NAME`), each with its default camera; added to the
    /// configuration's `[[scenes]]`.
    pub scenes: Vec<String>,
    /// A TOML configuration (see `eval.toml` at the repository root).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Where `report.md`, `results.csv`, `results.json` and the charts go.
    #[arg(long)]
    pub out: PathBuf,
    /// Fail instead of using the CPU twin when no GPU adapter exists.
    #[arg(long)]
    pub require_gpu: bool,
    /// The shared scenes folder the failure suite's file cases read (`../shared/scenes` beside
    /// a checkout). Default: the `PROBE_SCENES_DIR` environment variable if set, else the
    /// configuration's `scenes_dir` (relative to the configuration file); with none, those
    /// cases are skipped and the report says so.
    #[arg(long)]
    pub scenes_dir: Option<PathBuf>,
    /// A region of interest for the scenes named on the command line, `x0,y0,z0:x1,y1,z1`
    /// (repeat for a union of boxes); per scene in the configuration as `region = [...]`.
    #[arg(long, value_name = "BOX")]
    pub region: Vec<String>,
    /// Viewpoints sampled in each scene's region (or free space) besides its cameras; every
    /// figure is then the mean over the views, with the worst view beside it. Overrides the
    /// configuration's `views`.
    #[arg(long)]
    pub views: Option<usize>,
    /// Seed of the sampled viewpoints (another seed gives a held-out view set).
    #[arg(long)]
    pub view_seed: Option<u64>,
    /// Bake every placement twice (seeds differ by one) and report each image's bake noise
    /// beside its error (the configuration's `measure_bake_noise`); bakes and traces take
    /// twice as long.
    #[arg(long)]
    pub bake_noise: bool,
    /// The memory limit for the sweep's largest bake and its views.
    #[command(flatten)]
    pub memory: MemoryArgs,
}

/// The sweep's largest single step, checked before it starts: the largest grid's bake at the
/// configured resolution plus every view's rays and images.
fn check_memory(config: &EvalConfig, args: &Args) -> Result<(), CliError> {
    let grid_probes = |grid: &String| -> usize {
        grid.split('x')
            .map(|n| n.trim().parse::<usize>().unwrap_or(0))
            .product()
    };
    let largest = config
        .scenes
        .iter()
        .flat_map(|s| s.grids.iter().map(grid_probes))
        .chain(config.grid_counts.iter().map(|&n| n as usize))
        .max()
        .unwrap_or(0);
    // With the bake noise measured, two bakes of a placement are held at once.
    let bakes = if config.measure_bake_noise { 2 } else { 1 };
    let settings = probe_capture::BakeSettings {
        resolution: config.resolution,
        ..Default::default()
    };
    let views: u64 = config
        .scenes
        .iter()
        .map(|s| (s.cameras.len() + s.views.unwrap_or(config.views)) as u64)
        .max()
        .unwrap_or(0);
    let v = &config.view;
    let per_view =
        u64::from(v.width) * u64::from(v.height) * (96 + 160 * u64::from(v.rays_per_pixel.max(1)));
    args.memory.limit().check(
        format_args!(
            "a sweep whose largest bake ({bakes} at once) has {largest} probes at {}² and {views} view(s) of a scene at {}×{}",
            config.resolution, v.width, v.height
        ),
        probe_capture::bake_memory_estimate(largest, &settings)
            .saturating_mul(bakes)
            .saturating_add(views.saturating_mul(per_view)),
    )?;
    Ok(())
}

/// Runs the sweep, logging each step to stderr.
pub fn run(args: &Args) -> Result<Box<dyn Report>, CliError> {
    let mut config = match &args.config {
        Some(path) => EvalConfig::load(path)?,
        None => EvalConfig::default(),
    };
    config.require_gpu |= args.require_gpu;
    if let Some(dir) = args
        .scenes_dir
        .clone()
        .or_else(|| std::env::var_os("PROBE_SCENES_DIR").map(PathBuf::from))
    {
        config.scenes_dir = Some(dir);
    }
    if let Some(views) = args.views {
        config.views = views;
        for scene in &mut config.scenes {
            scene.views = None;
        }
    }
    if let Some(seed) = args.view_seed {
        config.view_seed = seed;
    }
    config.measure_bake_noise |= args.bake_noise;
    if !args.region.is_empty() && args.scenes.is_empty() {
        return Err(CliError::InvalidArgument {
            parameter: "--region",
            value: args.region.join(" "),
            reason: "applies to the scenes named on the command line; name one, or set `region` per scene in the configuration".into(),
        });
    }
    crate::commands::place::parse_region(&args.region)?;
    config
        .scenes
        .extend(args.scenes.iter().map(|scene| SceneConfig {
            scene: scene.clone(),
            cameras: vec!["default".into()],
            grids: Vec::new(),
            placements: Vec::new(),
            region: args.region.clone(),
            views: None,
        }));
    check_memory(&config, args)?;
    let report = run_sweep(&config, &args.out, &|line| eprintln!("eval: {line}"))?;
    Ok(Box::new(EvalSummary(report, args.out.clone())))
}

struct EvalSummary(SweepReport, PathBuf);

impl Report for EvalSummary {
    fn json(&self) -> Value {
        json!({
            "command": "eval",
            "out": self.1.display().to_string(),
            "device": self.0.device,
            "points": self.0.records.len(),
            "view_sets": self.0.view_sets.len(),
            "headline": self.0.headline,
            "files": self.0.files,
            "seconds": self.0.seconds,
        })
    }

    fn text(&self) -> String {
        let mut text = format!(
            "{} points measured on {} in {:.0} s; report: {}\n",
            self.0.records.len(),
            self.0.device,
            self.0.seconds,
            self.1.join("report.md").display()
        );
        let h = &self.0.headline;
        for (scene, figure) in &h.probes_to_match_best_grid {
            match figure {
                Some(f) => text.push_str(&format!(
                    "{scene}: {} probes ({}) match the best grid {} ({} probes): ratio {:.2}{}\n",
                    f.probes,
                    f.placement,
                    f.grid,
                    f.grid_probes,
                    f.ratio,
                    if f.grids_flat() {
                        format!(
                            " (the grids lie within {:.2}x of each other: the error hardly moves with the count)",
                            f.grid_spread
                        )
                    } else {
                        String::new()
                    }
                )),
                None => text.push_str(&format!(
                    "{scene}: no automatic placement matched the best grid's MSE\n"
                )),
            }
            // With the bakes' noise measured: the same with it taken out.
            if let Some(Some(f)) = h.probes_to_match_best_grid_noise_free.get(scene) {
                text.push_str(&format!(
                    "{scene}: with the noise taken out, {} probes ({}) match the best grid {} ({} probes): ratio {:.2}\n",
                    f.probes, f.placement, f.grid, f.grid_probes, f.ratio
                ));
            }
        }
        if let Some([median, min, max]) = h.hiz_time_ratio {
            text.push_str(&format!(
                "hi-Z / two-level trace time: median {median:.2} ({min:.2}–{max:.2})\n"
            ));
        }
        text
    }
}
