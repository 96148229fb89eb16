//! `probes demo`: the README's main job on the built-in Cornell box.

use crate::cli_error::CliError;
use crate::output::Report;
use probe_eval::demo::{DemoOptions, DemoReport, run_demo};
use serde_json::Value;
use std::path::PathBuf;

/// Arguments of `probes demo`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Where the images, the table (`table.md`) and `results.json` go.
    #[arg(long, default_value = "demo-out")]
    pub out: PathBuf,
    /// Fail instead of using the CPU twin when no GPU adapter exists.
    #[arg(long)]
    pub require_gpu: bool,
    /// Probe resolution (interior texels per side, a power of two).
    #[arg(long, default_value_t = 128)]
    pub res: u32,
    /// Image side in pixels.
    #[arg(long, default_value_t = 256)]
    pub size: u32,
    /// A region of interest every placement stays in, `x0,y0,z0:x1,y1,z1` (repeat for a
    /// union of boxes).
    #[arg(long, value_name = "BOX")]
    pub region: Vec<String>,
    /// Edge-preserving smoothing of the bakes' radiance, as strong as K (0: off; 0 to 8):
    /// differences a texel's noise explains are averaged with its neighbours on the same
    /// surface, edges are kept.
    #[arg(long, value_name = "K", default_value_t = 0.0)]
    pub denoise: f32,
}

/// Runs the demo, logging each stage to stderr.
pub fn run(args: &Args) -> Result<Box<dyn Report>, CliError> {
    let options = DemoOptions {
        require_gpu: args.require_gpu,
        resolution: args.res,
        image_size: args.size,
        region: crate::commands::place::parse_region(&args.region)?,
        bake_denoise: args.denoise,
        ..DemoOptions::new(&args.out)
    };
    let report = run_demo(&options, &|line| eprintln!("demo: {line}"))?;
    Ok(Box::new(DemoSummary(report)))
}

struct DemoSummary(DemoReport);

impl Report for DemoSummary {
    fn json(&self) -> Value {
        serde_json::to_value(&self.0).unwrap_or(Value::Null)
    }

    fn text(&self) -> String {
        let mut text = self.0.markdown();
        text.push_str("\nwrote:\n");
        for file in &self.0.files {
            text.push_str(&format!("  {}\n", file.display()));
        }
        text
    }
}
