//! `probes bake-merge`: join the partial bakes of `probes bake --shard K/N` into the whole
//! bake, byte for byte what an unsharded `probes bake` writes.

use crate::cli_error::CliError;
use crate::output::Report;
use crate::progress::bar;
use crate::spec::MemoryArgs;
use probe_capture::merge_shards;
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Arguments of `probes bake-merge`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The merged bake directory to write (created; an existing bake there is replaced).
    pub out: PathBuf,
    /// The shard directories written by `probes bake --shard K/N`: all N of them, in any
    /// order (e.g. `shards/shard-*`). Missing, duplicate and mismatched shards (another
    /// scene, other settings, another probe set or shard count) are refused.
    #[arg(required = true)]
    pub shards: Vec<PathBuf>,
    /// The memory limit (the merged bake plus the largest shard must fit).
    #[command(flatten)]
    pub memory: MemoryArgs,
}

/// Whether `a` and `b` name the same existing directory.
fn same_directory(a: &Path, b: &Path) -> bool {
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => false,
    }
}

/// Merges the shards and saves the whole bake.
pub fn run(args: &Args) -> Result<Box<dyn Report>, CliError> {
    if let Some(shard) = args.shards.iter().find(|s| same_directory(s, &args.out)) {
        return Err(CliError::InvalidArgument {
            parameter: "OUT",
            value: args.out.display().to_string(),
            reason: format!(
                "it is the shard directory {}: write the merged bake elsewhere",
                shard.display()
            ),
        });
    }
    let progress = bar(args.shards.len() as u64, "merging shards");
    let start = Instant::now();
    let merged = merge_shards(&args.shards, None, args.memory.limit(), &|done, total| {
        progress.set_length(total as u64);
        progress.set_position(done as u64);
    });
    progress.finish_and_clear();
    let merged = merged?;
    let merge_seconds = start.elapsed().as_secs_f64();
    let save_start = Instant::now();
    merged.save(&args.out)?;
    Ok(Box::new(MergeSummary {
        out: args.out.clone(),
        shards: args.shards.len(),
        scene: merged.scene_name().to_owned(),
        probes: merged.probe_count(),
        resolution: merged.resolution(),
        merge_seconds,
        save_seconds: save_start.elapsed().as_secs_f64(),
    }))
}

struct MergeSummary {
    out: PathBuf,
    shards: usize,
    scene: String,
    probes: usize,
    resolution: u32,
    merge_seconds: f64,
    save_seconds: f64,
}

impl Report for MergeSummary {
    fn json(&self) -> Value {
        json!({
            "command": "bake-merge",
            "out": self.out.display().to_string(),
            "shards": self.shards,
            "scene": self.scene,
            "probes": self.probes,
            "resolution": self.resolution,
            "merge_seconds": self.merge_seconds,
            "save_seconds": self.save_seconds,
        })
    }

    fn text(&self) -> String {
        format!(
            "merged {} shards: {} probes of {} at {}² in {:.2} s, saved to {} in {:.2} s\n",
            self.shards,
            self.probes,
            self.scene,
            self.resolution,
            self.merge_seconds,
            self.out.display(),
            self.save_seconds
        )
    }
}
