//! How well an error-driven probe set (issue 12, `--method minimal --views N --target-error E`)
//! meets its target on views it did not learn from. For each training set size and atlas
//! size, and for several seed pairs, it places the error-driven set on a training view set
//! (the scene's cameras and `N` viewpoints sampled with one seed) and measures the proxy —
//! the share of what views see, directly and in mirror reflection, that no probe sees at a
//! non-grazing angle ([`ViewProxy`]) — on the training views and on a held-out view set (the
//! scene's cameras and 4 viewpoints sampled with another seed, the eval's judging set), each
//! proxy from a 20,000-point atlas so that its own sampling noise stays small.
//!
//! ```text
//! cargo run --release -p probe-eval --example held_out -- [SCENE] [REGION] [CAMERAS] [TARGET] [TRAINING] [ATLAS] [SEEDS]
//! ```
//!
//! `RULES` (an eighth argument, default `mean,each`): the target over all training views
//! together, or for each view ([`PlaceOptions::each_view`]); the worst held-out view's proxy
//! (2,500 points each) is printed beside.
//!
//! Defaults: Sponza (the shared `Sponza_basecolor.gltf`) with `eval.toml`'s atrium region and
//! its four cameras, target 0.05, training sizes `8,16,32`, atlas sizes `5000,20000`, seeds
//! `1,2,3` (the held-out set of seed `s` is sampled with `s`, the training set with
//! [`training_seed`]`(s)`, as `probes eval` does). `REGION` `-` for none, `CAMERAS`
//! comma-separated (`-` for the scene's own).

use std::time::Instant;

use probe_eval::sweep::training_seed;
use probe_eval::views::{ViewSetOptions, scene_cameras, view_set};
use probe_place::pipeline::{Method, PlaceOptions, place};
use probe_place::region::Region;
use probe_place::viewers::ViewProxy;
use probe_scene::Scene;

fn list(text: &str) -> Vec<usize> {
    text.split(',')
        .filter_map(|n| n.trim().parse().ok())
        .collect()
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let arg = |i: usize, default: &str| args.get(i).cloned().unwrap_or_else(|| default.to_owned());
    let scene_path = arg(0, "../shared/scenes/sponza/Sponza_basecolor.gltf");
    let region_text = arg(1, "-20,4,-9:17.3,15,7.6");
    let cameras_text = arg(2, "CameraMain,CameraAlternate,CameraBalcony,CameraAlcove");
    let target: f32 = arg(3, "0.05").parse()?;
    let training_sizes = list(&arg(4, "8,16,32"));
    let atlas_sizes = list(&arg(5, "5000,20000"));
    let seeds = list(&arg(6, "1,2,3"));
    // `mean`: the target over all training views together; `each`: for each view.
    let rules: Vec<String> = arg(7, "mean,each").split(',').map(str::to_owned).collect();

    let scene = Scene::open(&scene_path)?;
    let region = match region_text.as_str() {
        "-" => None,
        text => Some(Region::parse_boxes(text.split(';'))?),
    };
    let cameras: Vec<String> = match cameras_text.as_str() {
        "-" => scene_cameras(&scene),
        text => text.split(',').map(str::to_owned).collect(),
    };
    let views = |sampled: usize, seed: u64| {
        view_set(
            &scene,
            &ViewSetOptions {
                cameras: cameras.clone(),
                sampled,
                seed,
                region: region.clone(),
            },
        )
    };
    println!(
        "| rule | training views | atlas | seed | probes | training proxy | held-out proxy | held out / target | worst held-out view | seconds |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for &seed in &seeds {
        let seed = seed as u64;
        let held_out = views(4, seed)?;
        let held_out_proxy = ViewProxy::new(&scene, region.as_ref(), &held_out, 20_000)?;
        let per_view: Vec<ViewProxy<'_>> = held_out
            .iter()
            .map(|c| ViewProxy::new(&scene, region.as_ref(), std::slice::from_ref(c), 2_500))
            .collect::<Result<_, _>>()?;
        for &sampled in &training_sizes {
            let training = views(sampled, training_seed(seed))?;
            let training_proxy = ViewProxy::new(&scene, region.as_ref(), &training, 20_000)?;
            for &texels in &atlas_sizes {
                for rule in &rules {
                    let options = PlaceOptions {
                        atlas_texels: texels,
                        seed: 1,
                        region: region.clone(),
                        viewers: Some(training.clone()),
                        coverage: 1.0 - target,
                        each_view: rule == "each",
                        ..PlaceOptions::new(Method::Minimal)
                    };
                    let start = Instant::now();
                    let placed = place(&scene, &options, None)?;
                    let seconds = start.elapsed().as_secs_f64();
                    let probes = &placed.probes.positions;
                    let held = held_out_proxy.error(probes);
                    let worst = per_view
                        .iter()
                        .map(|p| p.error(probes))
                        .fold(0.0f64, f64::max);
                    println!(
                        "| {rule} | {} | {texels} | {seed} | {} | {:.3} | {held:.3} | {:.2} | {worst:.3} | {seconds:.1} |",
                        training.len(),
                        probes.len(),
                        training_proxy.error(probes),
                        held / f64::from(target),
                    );
                }
            }
        }
    }
    Ok(())
}
