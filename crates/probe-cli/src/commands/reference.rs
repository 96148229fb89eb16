//! `probes reference`: the path-traced reference image (direct light, one-bounce glossy,
//! indirect diffuse, the final image, or full global illumination).

use crate::cli_error::CliError;
use crate::output::Report;
use crate::progress::bar;
use crate::spec::{SunArgs, camera, open_scene, reflection};
use probe_capture::{Component, RenderSettings};
use probe_eval::convergence::{NoiseTarget, render_converged};
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
    /// Indirect diffuse light (base colour × indirect irradiance / π, light sources left to
    /// direct light): the truth of `probes render --component diffuse`.
    Diffuse,
    /// The final image (direct light with exact shadows, indirect diffuse, GGX specular with
    /// each material's metallic-roughness): the truth of `probes render --component final`.
    Final,
}

/// `--bounces` of `glossy1` when not given: the bake's default, so that the reference
/// shades secondary hits as a default bake does.
const DEFAULT_GLOSSY_BOUNCES: u32 = 1;

/// `--bounces` of `full` when not given: deep enough that truncation is invisible (the
/// light a cut after `n` bounces loses is a share `aⁿ⁺¹` of the total for albedo `a`: for
/// 0.8, 3 % after 15 bounces, under 1e-6 after 64), while Russian roulette after
/// [`probe_capture::RUSSIAN_ROULETTE_BOUNCES`] bounces keeps the long paths cheap.
const DEFAULT_FULL_BOUNCES: u32 = 64;

/// The component's name as the command line spells it.
fn component_name(component: ComponentArg) -> &'static str {
    match component {
        ComponentArg::Direct => "direct",
        ComponentArg::Glossy1 => "glossy1",
        ComponentArg::Full => "full",
        ComponentArg::Diffuse => "diffuse",
        ComponentArg::Final => "final",
    }
}

/// Arguments of `probes reference`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// A glTF 2.0 file or `builtin:NAME`.
    pub scene: String,
    /// A camera of the scene by name, `default`, or a pose `px,py,pz:tx,ty,tz[:yfov_degrees]`.
    #[arg(long, default_value = "default")]
    pub camera: String,
    /// Samples per pixel, rendered as two independent halves of half as many (which give the
    /// noise estimate reported); with `--noise`, the first round's.
    #[arg(long, default_value_t = 16)]
    pub spp: u32,
    /// Render progressively until the noise estimate (tone-mapped x/(1+x) MSE between the two
    /// half-sample images, over 4: the variance of the full-sample mean) is at most this, e.g.
    /// `1e-5`, doubling the samples each round from `--spp`, up to `--max-spp`.
    #[arg(long)]
    pub noise: Option<f64>,
    /// The sample cap of `--noise`.
    #[arg(long, default_value_t = 4096)]
    pub max_spp: u32,
    /// Which component to render.
    #[arg(long, value_enum, default_value_t = ComponentArg::Glossy1)]
    pub component: ComponentArg,
    /// Image width in pixels.
    #[arg(long, default_value_t = 640)]
    pub width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = 360)]
    pub height: u32,
    /// Reflection lobe of the glossy component: `mirror` or `ggx:ROUGHNESS` [default:
    /// mirror]. Refused for the other components (`final` takes each material's roughness).
    #[arg(long)]
    pub reflection: Option<String>,
    /// Extra diffuse bounces after direct light (0 = direct light only), as in `probes bake`:
    /// of the radiance the glossy, diffuse and final images' secondary rays pick up
    /// (`glossy1`, `diffuse`, `final`: default 1 like the bake), or of the paths from the
    /// primary hit (`full`, default 64). Refused for `direct`.
    #[arg(long)]
    pub bounces: Option<u32>,
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
    settings.samples_per_pixel = args.spp.div_ceil(2);
    settings.seed = args.seed;
    settings.environment = args.sun.environment(&scene)?;
    let refuse = |parameter: &'static str, value: String| CliError::InvalidArgument {
        parameter,
        value,
        reason: format!(
            "`--component {}` does not use it (only `glossy1` takes `--reflection`; `glossy1` \
             `diffuse`, `final` and `full` take `--bounces`); drop it or pick another component",
            component_name(args.component)
        ),
    };
    match args.component {
        ComponentArg::Direct => {
            if let Some(bounces) = args.bounces {
                return Err(refuse("--bounces", bounces.to_string()));
            }
        }
        ComponentArg::Glossy1 => {
            settings.bounces = args.bounces.unwrap_or(DEFAULT_GLOSSY_BOUNCES);
            settings.reflection = reflection(args.reflection.as_deref().unwrap_or("mirror"))?;
        }
        ComponentArg::Full => settings.bounces = args.bounces.unwrap_or(DEFAULT_FULL_BOUNCES),
        ComponentArg::Diffuse | ComponentArg::Final => {
            settings.bounces = args.bounces.unwrap_or(DEFAULT_GLOSSY_BOUNCES);
        }
    }
    if let (
        ComponentArg::Direct | ComponentArg::Full | ComponentArg::Diffuse | ComponentArg::Final,
        Some(text),
    ) = (args.component, &args.reflection)
    {
        return Err(refuse("--reflection", text.clone()));
    }
    settings.component = match args.component {
        ComponentArg::Direct => Component::Direct,
        ComponentArg::Glossy1 => Component::Glossy1,
        ComponentArg::Full => Component::Full,
        ComponentArg::Diffuse => Component::Diffuse,
        ComponentArg::Final => Component::Final,
    };
    let bounces = match args.component {
        ComponentArg::Direct => 0,
        _ => settings.bounces,
    };
    let progress = bar(0, "rendering");
    let start = Instant::now();
    let on_progress = |done: usize, total: usize| {
        progress.set_length(total as u64);
        progress.set_position(done as u64);
    };
    let target = match args.noise {
        Some(noise) => NoiseTarget::Noise {
            noise,
            max_samples: args.max_spp,
        },
        None => NoiseTarget::Samples(args.spp),
    };
    let rendered = render_converged(&scene, &camera, &settings, target, &on_progress);
    progress.finish_and_clear();
    let (image, noise) = rendered?;
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
            "component": component_name(args.component),
            "bounces": bounces,
            "width": args.width,
            "height": args.height,
            "samples_per_pixel": noise.samples,
            "passes": noise.passes,
            "noise": noise.noise,
            "noise_target": noise.target,
            "converged": noise.converged,
            "seed": args.seed,
            "seconds": seconds,
            "mean_radiance": [mean.x, mean.y, mean.z],
            "out": args.out.display().to_string(),
            "png": args.png.as_ref().map(|p| p.display().to_string()),
        }),
        text: format!(
            "rendered {} ({} bounces) of {} from camera {} at {}×{}, {} spp in {:.2} s, noise {:.2e}{}; mean radiance [{:.4} {:.4} {:.4}]; wrote {}\n",
            component_name(args.component),
            bounces,
            scene.name(),
            camera.name,
            args.width,
            args.height,
            noise.samples,
            seconds,
            noise.noise,
            match noise.target {
                Some(t) if noise.converged => format!(" (target {t:.2e}: met)"),
                Some(t) => format!(
                    " (target {t:.2e}: not met within --max-spp {})",
                    args.max_spp
                ),
                None => String::new(),
            },
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spec::SunArgs;
    use probe_capture::Image;

    pub(super) fn args(
        component: ComponentArg,
        bounces: Option<u32>,
        reflection: Option<&str>,
        out: PathBuf,
    ) -> Args {
        Args {
            scene: "builtin:cornell".into(),
            camera: "default".into(),
            // Enough samples that one or two extra bounces visibly outweigh the noise.
            spp: 16,
            noise: None,
            max_spp: 64,
            component,
            width: 16,
            height: 16,
            reflection: reflection.map(str::to_owned),
            bounces,
            seed: 0,
            sun: SunArgs {
                sun_direction: None,
                sun_illuminance: None,
            },
            out,
            png: None,
        }
    }

    /// Every option either acts or is refused: `--bounces` changes `full`, `full` with no
    /// bounces is `direct`, and options a component cannot use are refused by name.
    #[test]
    fn bounces_act_and_unused_options_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let out = |name: &str| dir.path().join(name);
        for (component, bounces, reflection, parameter) in [
            (ComponentArg::Direct, Some(2), None, "--bounces"),
            (ComponentArg::Direct, None, Some("mirror"), "--reflection"),
            (ComponentArg::Full, Some(3), Some("ggx:0.3"), "--reflection"),
        ] {
            match run(&args(component, bounces, reflection, out("refused.exr"))) {
                Err(CliError::InvalidArgument { parameter: p, .. }) => assert_eq!(p, parameter),
                Err(other) => panic!("{component:?}: {other}"),
                Ok(_) => panic!("{component:?} with {parameter} was accepted"),
            }
        }
        assert!(!out("refused.exr").exists());
        let image = |component, bounces, name: &str| {
            run(&args(component, bounces, None, out(name))).unwrap();
            Image::load_exr(out(name)).unwrap()
        };
        let direct = image(ComponentArg::Direct, None, "direct.exr");
        let full_0 = image(ComponentArg::Full, Some(0), "full0.exr");
        let full_2 = image(ComponentArg::Full, Some(2), "full2.exr");
        let full = image(ComponentArg::Full, None, "full.exr");
        assert_eq!(direct, full_0);
        assert!(full_2.mean().x > direct.mean().x);
        assert_ne!(full_2, full);
        let glossy_0 = image(ComponentArg::Glossy1, Some(0), "glossy0.exr");
        let glossy_1 = image(ComponentArg::Glossy1, None, "glossy1.exr");
        assert!(glossy_1.mean().x > glossy_0.mean().x);
    }
}

#[cfg(test)]
mod noise_tests {
    use super::*;

    fn args(noise: Option<f64>, out: PathBuf) -> Args {
        Args {
            spp: 2,
            noise,
            max_spp: 16,
            width: 8,
            height: 8,
            ..tests::args(ComponentArg::Direct, None, None, out)
        }
    }

    /// `--noise` acts: a loose target stops after the first round, an unreachable one runs to
    /// `--max-spp` and says so; both record the samples used and the noise reached.
    #[test]
    fn noise_target_refines_until_met_or_capped() {
        let dir = tempfile::tempdir().unwrap();
        let loose = run(&args(Some(1.0), dir.path().join("loose.exr")))
            .unwrap()
            .json();
        assert_eq!(loose["samples_per_pixel"], 2);
        assert_eq!(loose["converged"], true);
        let tight = run(&args(Some(1e-30), dir.path().join("tight.exr")))
            .unwrap()
            .json();
        assert_eq!(tight["samples_per_pixel"], 16);
        assert_eq!(tight["converged"], false);
        assert!(tight["noise"].as_f64().unwrap() < loose["noise"].as_f64().unwrap());
        assert!(matches!(
            run(&args(Some(-1.0), dir.path().join("bad.exr"))),
            Err(CliError::Eval(_))
        ));
    }
}
