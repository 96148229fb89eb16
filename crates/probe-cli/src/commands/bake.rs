//! `probes bake`: render light-field probes (radiance, normals, radial distance and the derived
//! maps) and store them as a bake directory.

use crate::cli_error::CliError;
use crate::output::Report;
use crate::progress::bar;
use crate::spec::{MemoryArgs, SunArgs, open_scene_with_limit, probe_set, warnings_json};
use probe_capture::{
    BakeSettings, BakedRadiance, ProbeBake, Sampling, Shard, bake_shard, bake_with_limit,
};
use probe_eval::pipeline::split_bake_settings;
use serde_json::{Value, json};
use std::ops::Range;
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `probes bake`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// A glTF 2.0 file or `builtin:NAME`.
    pub scene: String,
    /// Probe positions: a `probes/1` JSON file or `grid:NXxNYxNZ`.
    #[arg(long)]
    pub probes: String,
    /// Octahedral resolution per probe (interior texels per side, a power of two, ≤ 1024).
    #[arg(long, default_value_t = 256)]
    pub res: u32,
    /// Fixed sampling: exactly this many radiance samples per texel (no adaptive pass).
    /// Without it the bake samples adaptively (`--min-spp`, `--max-spp`, `--noise`).
    #[arg(long, conflicts_with_all = ["min_spp", "max_spp", "noise"])]
    pub spp: Option<u32>,
    /// Adaptive sampling: the samples every texel takes first.
    #[arg(long, default_value_t = Sampling::default().samples_per_texel)]
    pub min_spp: u32,
    /// Adaptive sampling: the most samples a texel takes.
    #[arg(long, default_value_t = Sampling::default().max_samples_per_texel)]
    pub max_spp: u32,
    /// Adaptive sampling: the mean noise each probe's texels are sampled down to, as a
    /// variance in tone-mapped x/(1+x) units (3.5e-5 is a standard error of about 0.006).
    #[arg(long, default_value_t = Sampling::DEFAULT_NOISE_TARGET)]
    pub noise: f32,
    /// Extra diffuse bounces after direct light (0 = direct light only).
    #[arg(long, default_value_t = 1)]
    pub bounces: u32,
    /// Seed of every random choice.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// What the radiance maps hold: `outgoing` (what every tracer reads) or `indirect` (the
    /// light the surfaces reflect alone, without emission and the light sources' direct
    /// light at the texel's surface), which only `probes render --tracer split` reads. A
    /// split render of an outgoing bake makes this second bake itself, as long as the first
    /// took, on every render; bake it once here instead.
    #[arg(long, value_enum, default_value_t = RadianceArg::Outgoing)]
    pub radiance: RadianceArg,
    /// Edge-preserving smoothing of the radiance maps, 0 (off) to 8. Default: 0 for
    /// `--radiance outgoing`, 2 for `indirect` (what the split's own second bake uses).
    #[arg(long)]
    pub denoise: Option<f32>,
    /// Surfels per side of each probe (a power of two; 0 for none), from which diffuse
    /// shading re-gathers the light at each point (`render --diffuse-options parallax`).
    #[arg(long, default_value_t = BakeSettings::default().surfel_resolution)]
    pub surfels: u32,
    /// The sun.
    #[command(flatten)]
    pub sun: SunArgs,
    /// The bake directory to write (created; an existing bake there is replaced).
    #[arg(long)]
    pub out: PathBuf,
    /// Also write PNG previews (radiance, normal, distance) of this probe into the bake folder.
    #[arg(long)]
    pub preview_probe: Option<usize>,
    /// Bake only shard K/N of the probes (K counts from 0; shard K holds probes K·P/N up to
    /// (K+1)·P/N of the P given) into a partial bake at `--out`. Each probe is baked exactly
    /// as in the whole bake, so `probes bake-merge OUT SHARD_DIR...` joins the N partial
    /// bakes into the bake an unsharded run writes, byte for byte. Every shard must be given
    /// the same scene, probes and options.
    #[arg(long, conflicts_with = "preview_probe")]
    pub shard: Option<Shard>,
    /// The memory limit.
    #[command(flatten)]
    pub memory: MemoryArgs,
}

/// What a bake's radiance maps hold, on the command line.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum RadianceArg {
    /// The radiance leaving each texel's surface towards the probe.
    Outgoing,
    /// The light each texel's surface reflects from its surroundings and the sky alone.
    Indirect,
}

/// Bakes the probes and saves the bake.
pub fn run(args: &Args) -> Result<Box<dyn Report>, CliError> {
    let limit = args.memory.limit();
    let scene = open_scene_with_limit(&args.scene, limit)?;
    let probes = probe_set(&args.probes, &scene)?;
    let settings = BakeSettings {
        resolution: args.res,
        sampling: match args.spp {
            Some(spp) => Sampling::fixed(spp),
            None => Sampling::adaptive(args.min_spp, args.max_spp, args.noise),
        },
        bounces: args.bounces,
        seed: args.seed,
        environment: args.sun.environment(&scene)?,
        surfel_resolution: args.surfels,
        ..BakeSettings::default()
    };
    // The bake the split reads, as its own second bake is made.
    let mut settings = match args.radiance {
        RadianceArg::Outgoing => settings,
        RadianceArg::Indirect => split_bake_settings(settings),
    };
    if let Some(denoise) = args.denoise {
        settings.denoise = denoise;
    }
    let progress = bar(0, "baking");
    let start = Instant::now();
    let on_progress = |done: usize, total: usize| {
        progress.set_length(total as u64);
        progress.set_position(done as u64);
    };
    let (baked, shard) = match args.shard {
        Some(shard) => {
            let part = bake_shard(
                &scene,
                &probes.positions,
                shard,
                &settings,
                limit,
                &on_progress,
            );
            progress.finish_and_clear();
            let part = part?;
            let bake_seconds = start.elapsed().as_secs_f64();
            part.save(&args.out)?;
            let record = ShardSummary {
                shard: part.shard(),
                probe_range: part.probe_range(),
                total_probes: part.total_probes(),
            };
            ((part.into_bake(), bake_seconds), Some(record))
        }
        None => {
            let baked = bake_with_limit(&scene, &probes.positions, &settings, limit, &on_progress);
            progress.finish_and_clear();
            let baked = baked?;
            let bake_seconds = start.elapsed().as_secs_f64();
            baked.save(&args.out)?;
            ((baked, bake_seconds), None)
        }
    };
    let (baked, bake_seconds) = baked;
    let save_seconds = start.elapsed().as_secs_f64() - bake_seconds;
    let previews = match args.preview_probe {
        Some(probe) => Some(baked.write_previews(probe, &args.out)?),
        None => None,
    };
    Ok(Box::new(BakeSummary {
        scene: scene.name().to_owned(),
        scene_warnings: warnings_json(&scene),
        out: args.out.clone(),
        bake_seconds,
        save_seconds,
        previews: previews.map(|p| [p.radiance, p.normal, p.distance]),
        baked,
        shard,
    }))
}

/// Which shard a sharded run baked.
struct ShardSummary {
    shard: Shard,
    probe_range: Range<usize>,
    total_probes: usize,
}

struct BakeSummary {
    scene: String,
    scene_warnings: Value,
    out: PathBuf,
    baked: ProbeBake,
    bake_seconds: f64,
    save_seconds: f64,
    previews: Option<[PathBuf; 3]>,
    shard: Option<ShardSummary>,
}

impl BakeSummary {
    /// Primary rays: one geometry ray per texel plus the radiance samples.
    fn rays(&self) -> u64 {
        let s = self.baked.settings();
        let texels = u64::from(s.resolution) * u64::from(s.resolution);
        let samples: u64 = self.baked.sampling().iter().map(|p| p.samples).sum();
        self.baked.probe_count() as u64 * texels + samples
    }
}

impl Report for BakeSummary {
    fn json(&self) -> Value {
        let s = self.baked.settings();
        let stats: Vec<Value> = self
            .baked
            .stats()
            .iter()
            .map(|p| {
                json!({
                    "back_face_share": p.back_face_share,
                    "miss_share": p.miss_share,
                    "mean_distance": p.mean_distance,
                    "min_distance": p.min_distance,
                })
            })
            .collect();
        json!({
            "command": "bake",
            "scene": self.scene,
            "scene_warnings": self.scene_warnings,
            "out": self.out.display().to_string(),
            "probes": self.baked.probe_count(),
            "resolution": s.resolution,
            "samples_per_texel": s.sampling.samples_per_texel,
            "max_samples_per_texel": s.sampling.max_samples_per_texel,
            "noise_target": s.sampling.noise_target,
            "mean_samples_per_texel": self.baked.mean_samples_per_texel(),
            "noise": self.baked.noise(),
            "bounces": s.bounces,
            "radiance": match s.radiance {
                BakedRadiance::Outgoing => "outgoing",
                BakedRadiance::Indirect => "indirect",
            },
            "denoise": s.denoise,
            "seed": s.seed,
            "primary_rays": self.rays(),
            "bake_seconds": self.bake_seconds,
            "save_seconds": self.save_seconds,
            "probe_stats": stats,
            "previews": self.previews.as_ref().map(|p| p.iter().map(|f| f.display().to_string()).collect::<Vec<_>>()),
            "shard": self.shard.as_ref().map(|s| json!({
                "index": s.shard.index(),
                "count": s.shard.count(),
                "probe_start": s.probe_range.start,
                "probe_end": s.probe_range.end,
                "total_probes": s.total_probes,
            })),
        })
    }

    fn text(&self) -> String {
        let s = self.baked.settings();
        let inside = self
            .baked
            .stats()
            .iter()
            .filter(|p| p.inside_geometry())
            .count();
        let mut text = match &self.shard {
            Some(s) => format!(
                "shard {} of a sharded bake: probes {}..{} of {} (merge the {} shards with `probes bake-merge OUT SHARD_DIR...`)\n",
                s.shard,
                s.probe_range.start,
                s.probe_range.end,
                s.total_probes,
                s.shard.count()
            ),
            None => String::new(),
        };
        text += &format!(
            "baked {} probes of {} at {}² × {:.1} spp ({}), {} bounce(s) in {:.2} s ({:.2} M primary rays/s), saved to {} in {:.2} s\n\
             noise (tone-mapped variance per texel, from the replicates): {}\n\
             probes seeing mostly back faces (share > {}, likely inside geometry): {}\n",
            self.baked.probe_count(),
            self.scene,
            s.resolution,
            self.baked.mean_samples_per_texel(),
            match s.sampling.noise_target {
                Some(target) if s.sampling.max_samples_per_texel > s.sampling.samples_per_texel =>
                    format!(
                        "adaptive {}–{} to {target:.1e}",
                        s.sampling.samples_per_texel, s.sampling.max_samples_per_texel
                    ),
                _ => "fixed".to_owned(),
            },
            s.bounces,
            self.bake_seconds,
            self.rays() as f64 / self.bake_seconds / 1e6,
            self.out.display(),
            self.save_seconds,
            self.baked.noise().map_or(
                "not estimated (1 sample per texel)".to_owned(),
                |v| format!("{v:.2e}")
            ),
            probe_capture::ProbeStats::INSIDE_GEOMETRY_BACK_FACE_SHARE,
            inside,
        );
        if s.radiance == BakedRadiance::Indirect {
            text.push_str(&format!(
                "the radiance maps hold the light the surfaces reflect alone (smoothed at {}): \
                 render them with `probes render BAKE --tracer split`\n",
                s.denoise
            ));
        }
        if let Some(previews) = &self.previews {
            for p in previews {
                text.push_str(&format!("preview: {}\n", p.display()));
            }
        }
        text
    }
}
