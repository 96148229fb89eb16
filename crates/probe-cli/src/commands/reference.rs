//! `probes reference`: the path-traced reference image (direct light, one-bounce glossy, or
//! full global illumination).

use crate::cli_error::CliError;
use crate::output::Report;
use crate::progress::bar;
use crate::spec::{SunArgs, camera, open_scene, reflection};
use probe_capture::{Component, RenderSettings, render};
use serde_json::{Value, json};
use std::path::PathBuf;
use std::time::Instant;

/// Which light the reference renders.
#[derive(clap::ValueEnum, Clone, Copy, Debug)]
pub enum ComponentArg {
    /// Emission and direct light at the primary hit.
    Direct,
    /// The one-bounce indirect glossy component (the seeds' comparison).
    Glossy1,
    /// Path-traced global illumination.
    Full,
}

/// Arguments of `probes reference`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// A glTF 2.0 file or `builtin:NAME`.
    pub scene: String,
    /// A camera of the scene by name, `default`, or a pose `px,py,pz:tx,ty,tz[:yfov_degrees]`.
    #[arg(long, default_value = "default")]
    pub camera: String,
    /// Samples per pixel.
    #[arg(long, default_value_t = 16)]
    pub spp: u32,
    /// Which component to render.
    #[arg(long, value_enum, default_value_t = ComponentArg::Glossy1)]
    pub component: ComponentArg,
    /// Image width in pixels.
    #[arg(long, default_value_t = 640)]
    pub width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = 360)]
    pub height: u32,
    /// Reflection lobe of the glossy component: `mirror` or `ggx:ROUGHNESS`.
    #[arg(long, default_value = "mirror")]
    pub reflection: String,
    /// Diffuse bounces in the radiance the glossy rays pick up (as in the bake).
    #[arg(long, default_value_t = 1)]
    pub bounces: u32,
    /// Seed of every random choice.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// The sun.
    #[command(flatten)]
    pub sun: SunArgs,
    /// The EXR image to write.
    #[arg(long)]
    pub out: PathBuf,
    /// Also write a tone-mapped PNG.
    #[arg(long)]
    pub png: Option<PathBuf>,
}

/// Renders the reference and writes it.
pub fn run(args: &Args) -> Result<Box<dyn Report>, CliError> {
    let scene = open_scene(&args.scene)?;
    let camera = camera(&scene, &args.camera)?;
    let mut settings = RenderSettings::new(args.width, args.height);
    settings.samples_per_pixel = args.spp;
    settings.seed = args.seed;
    settings.bounces = args.bounces;
    settings.reflection = reflection(&args.reflection)?;
    settings.environment = args.sun.environment(&scene)?;
    settings.component = match args.component {
        ComponentArg::Direct => Component::Direct,
        ComponentArg::Glossy1 => Component::Glossy1,
        ComponentArg::Full => Component::Full,
    };
    let progress = bar(0, "rendering");
    let start = Instant::now();
    let on_progress = |done: usize, total: usize| {
        progress.set_length(total as u64);
        progress.set_position(done as u64);
    };
    let image = render(&scene, &camera, &settings, &on_progress);
    progress.finish_and_clear();
    let image = image?;
    let seconds = start.elapsed().as_secs_f64();
    image.save_exr(&args.out)?;
    if let Some(png) = &args.png {
        image.save_png(png)?;
    }
    let mean = image.mean();
    Ok(Box::new(ReferenceSummary {
        json: json!({
            "command": "reference",
            "scene": scene.name(),
            "camera": camera.name,
            "component": format!("{:?}", args.component).to_lowercase(),
            "width": args.width,
            "height": args.height,
            "samples_per_pixel": args.spp,
            "seed": args.seed,
            "seconds": seconds,
            "mean_radiance": [mean.x, mean.y, mean.z],
            "out": args.out.display().to_string(),
            "png": args.png.as_ref().map(|p| p.display().to_string()),
        }),
        text: format!(
            "rendered {:?} of {} from camera {} at {}×{}, {} spp in {:.2} s; mean radiance [{:.4} {:.4} {:.4}]; wrote {}\n",
            args.component,
            scene.name(),
            camera.name,
            args.width,
            args.height,
            args.spp,
            seconds,
            mean.x,
            mean.y,
            mean.z,
            args.out.display()
        ),
    }))
}

struct ReferenceSummary {
    json: Value,
    text: String,
}

impl Report for ReferenceSummary {
    fn json(&self) -> Value {
        self.json.clone()
    }
    fn text(&self) -> String {
        self.text.clone()
    }
}
