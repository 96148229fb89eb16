//! `probes eval`: the speed-against-accuracy sweep with its report and charts.

use crate::cli_error::CliError;
use crate::output::Report;
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
                    "{scene}: {} probes ({}) match the best grid {} ({} probes): ratio {:.2}\n",
                    f.probes, f.placement, f.grid, f.grid_probes, f.ratio
                )),
                None => text.push_str(&format!(
                    "{scene}: no automatic placement matched the best grid's MSE\n"
                )),
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
