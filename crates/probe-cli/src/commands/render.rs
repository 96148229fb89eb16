//! `probes render`: render a camera's one-bounce glossy component by tracing reflection rays
//! through a bake's light-field probes, or its diffuse component from the bake's irradiance
//! probes, on the GPU (the CPU twin when no adapter exists).

use crate::cli_error::CliError;
use crate::output::Report;
use crate::progress::spinner;
use crate::spec::{MemoryArgs, camera, open_scene_with_limit, warnings_json};
use glam::Vec3;
use probe_capture::Image;
use probe_capture::{ProbeBake, TileOrder, accumulate_rays, reflection_rays, render_gbuffer};
use probe_eval::final_render::{
    DiffuseBlend, FinalOptions, ProbeFinal, SpecularMode, render_final,
};
use probe_eval::pipeline::{Device, Selection, Tracer, bake_read_by, build_index, light_field};
use probe_index::ProbeGrid;
use probe_trace_gpu::{
    DiffuseOptions, FieldOptions, Interpolation, ShadingPoint, TraceOptions, TraceRay, TraceSummary,
};

use serde_json::{Value, json};
use std::path::PathBuf;
use std::time::Instant;

/// Tracers on the command line.
#[derive(clap::ValueEnum, Clone, Copy, Debug)]
pub enum TracerArg {
    /// Hi-Z over the min/max pyramid (seed 000 §4.3).
    Hiz,
    /// McGuire 2017's coarse DDA plus fine march.
    TwoLevel,
    /// Geometry from the scene's BVH, radiance from the probes that see each hit.
    Hybrid,
    /// Geometry from the scene's BVH, each hit shaded with exact direct light and the
    /// irradiance probes (DDGI's answer to a ray-traced reflection; no light-field probe read).
    Shaded,
    /// Geometry from the scene's BVH, exact direct light with shadow rays, and the light each
    /// hit reflects from its surroundings read from probes baked to hold only that: the bake
    /// given, when it was baked with `--radiance indirect`; else a second bake at the same
    /// positions, made for this render (as long as the first took). Glossy component only.
    Split,
}

/// Selections on the command line.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum SelectArg {
    /// The regular grid's 8-cage (the bake's probes must be a regular grid).
    Grid,
    /// The sparse voxel octree of best probes.
    Svo,
    /// The nearest probe and its Voronoi-sphere neighbours.
    Voronoi,
}

/// Components on the command line.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum ComponentArg {
    /// One-bounce indirect glossy: reflection rays traced through the light-field probes.
    Glossy1,
    /// Diffuse: albedo/π × irradiance probes blended with Chebyshev visibility (indirect
    /// light: the bake's irradiance leaves the light sources out).
    Diffuse,
    /// The final image: emission and direct light with exact shadows, indirect diffuse from
    /// the irradiance probes, GGX specular (each material's roughness and metallic) through
    /// the light-field probes. Written as EXR and PNG.
    Final,
}

/// How the final image's specular part is traced.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpecularArg {
    /// One ray per pixel read from the prefiltered GGX levels.
    Filtered,
    /// GGX samples per pixel.
    Stochastic,
}

/// Arguments of `probes render`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// A bake directory (`probes bake --out`).
    pub bake: PathBuf,
    /// The scene the bake was made from; by default the source recorded in the bake.
    #[arg(long)]
    pub scene: Option<String>,
    /// A camera of the scene by name, `default`, or a pose `px,py,pz:tx,ty,tz[:yfov_degrees]`.
    #[arg(long, default_value = "default")]
    pub camera: String,
    /// The single-probe tracer.
    #[arg(long, value_enum, default_value_t = TracerArg::Hiz)]
    pub tracer: TracerArg,
    /// How rays choose probes.
    #[arg(long, value_enum, default_value_t = SelectArg::Svo)]
    pub select: SelectArg,
    /// What to render.
    #[arg(long, value_enum, default_value_t = ComponentArg::Glossy1)]
    pub component: ComponentArg,
    /// Image width in pixels.
    #[arg(long, default_value_t = 640)]
    pub width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = 360)]
    pub height: u32,
    /// GGX roughness of the reflection lobe; 0 for mirrors.
    #[arg(long, default_value_t = 0.0)]
    pub roughness: f32,
    /// Reflection rays per pixel (`final`: specular rays per pixel of rough materials).
    #[arg(long, default_value_t = 1)]
    pub rays_per_pixel: u32,
    /// Emitter samples per pixel of the direct light of `final` (shadow rays to area lights).
    #[arg(long, default_value_t = 16)]
    pub emitter_samples: u32,
    /// How `final` traces its specular part: `filtered` (one ray per pixel read from the
    /// probes' prefiltered GGX levels; no noise) or `stochastic` (`--rays-per-pixel` GGX
    /// samples per pixel).
    #[arg(long, value_enum, default_value_t = SpecularArg::Filtered)]
    pub specular: SpecularArg,
    /// With `final`: also write the parts (direct, diffuse, specular) beside `--out`, as
    /// `NAME.direct.exr` and `.png`, and so on.
    #[arg(long)]
    pub split: bool,
    /// Filtered glossy (needs `--roughness` > 0; not with `--tracer hybrid`): one mirror ray
    /// per pixel whose radiance is read from the probes' prefiltered GGX levels at the cone's
    /// footprint, weighted by the lobe's albedo; no noise. `--rays-per-pixel` is ignored.
    #[arg(long)]
    pub filtered: bool,
    /// With `--filtered`, or `final`'s filtered specular: rays per pixel, 1 to 8. The GGX
    /// lobe is cut by azimuth into this many parts, one narrower cone each
    /// (`probe_eval::glossy::sub_lobe_rays`; for `final`, each material's lobe, mirrors
    /// keeping one ray): a speed–accuracy knob between one cone and many stochastic rays
    /// (Sponza at roughness 0.3: 1 → 2.71e-3, 2 → 2.33e-3, 4 → 2.10e-3; 16 stochastic rays
    /// 2.23e-3).
    #[arg(long, default_value_t = 1)]
    pub sectors: u32,
    /// With `--filtered --sectors 2` or `4` (not `final`): each pixel traces one of the lobe's
    /// parts (a checkerboard, or 2×2 tiles) and takes the others from its neighbours that
    /// see the same surface (`probe_eval::glossy::interleaved_sub_lobe_rays`): the sectors'
    /// narrower cones at one ray per pixel.
    #[arg(long)]
    pub interleave: bool,
    /// Probes blended per filtered ray (`--filtered`, and `final`'s filtered specular): the
    /// prefiltered reads of the shading point's nearest probes that see the hit, 0 to 8;
    /// 0 reads the answering probe alone.
    #[arg(long, default_value_t = TraceOptions::default().glossy_blend)]
    pub glossy_blend: u32,
    /// Depth of the sparse voxel octree (for `--select svo`).
    #[arg(long, default_value_t = 7)]
    pub svo_depth: u32,
    /// Seed of the reflection rays.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Diffuse shading options of `diffuse` and of `final`'s diffuse part, as `key=value,...`
    /// (`visibility`, `normal-bias`, `exponent`, `min-weight`, `backface`, `parallax`: `off`
    /// skips re-gathering each probe's light at the point from the bake's surfels; see
    /// `probe_trace_gpu::DiffuseOptions`); unnamed keys keep their defaults.
    #[arg(long, default_value = "")]
    pub diffuse_options: DiffuseOptions,
    /// Fail instead of falling back to the CPU twin when no GPU adapter exists.
    #[arg(long)]
    pub require_gpu: bool,
    /// Trace with the CPU twin of the GPU tracer (same algorithm, same answers).
    #[arg(long, conflicts_with = "require_gpu")]
    pub cpu: bool,
    /// The EXR image to write.
    #[arg(long)]
    pub out: PathBuf,
    /// Also write a tone-mapped PNG (`final` writes one beside `--out` without it).
    #[arg(long)]
    pub png: Option<PathBuf>,
    /// The memory limit.
    #[command(flatten)]
    pub memory: MemoryArgs,
}

/// Bytes per pixel of the G-buffer and the image, and per reflection ray of the rays, the
/// trace results and their radiance.
const BYTES_PER_PIXEL: u64 = 96;
const BYTES_PER_RAY: u64 = 160;

/// Rays or shading points of the untimed first dispatch that compiles a pipeline.
const WARM_UP_ITEMS: usize = 256;

/// Renders and reports.
pub fn run(args: &Args) -> Result<Box<dyn Report>, CliError> {
    if args.split && args.component != ComponentArg::Final {
        return Err(CliError::InvalidArgument {
            parameter: "--split",
            value: String::new(),
            reason: "only `--component final` has parts to split".into(),
        });
    }
    let limit = args.memory.limit();
    let pixels = u64::from(args.width) * u64::from(args.height);
    limit.check(
        format_args!(
            "a {}×{} render with {} ray(s) per pixel",
            args.width, args.height, args.rays_per_pixel
        ),
        pixels.saturating_mul(
            BYTES_PER_PIXEL + BYTES_PER_RAY.saturating_mul(u64::from(args.rays_per_pixel)),
        ),
    )?;
    let loaded_without_check = ProbeBake::load_with_limit(&args.bake, None, limit)?;
    if loaded_without_check.settings().radiance == probe_capture::BakedRadiance::Indirect
        && !(args.component == ComponentArg::Glossy1 && matches!(args.tracer, TracerArg::Split))
    {
        // Only the split's glossy reflections add the light sources to a bake of the reflected
        // light: any other image of it would lack them and pass for a render.
        return Err(CliError::InvalidArgument {
            parameter: "BAKE",
            value: args.bake.display().to_string(),
            reason: "the bake holds only the light its surfaces reflect (probes bake --radiance \
                 indirect), which only `--component glossy1 --tracer split` reads; render a \
                 bake of the outgoing radiance (the default of probes bake) for anything else"
                .into(),
        });
    }
    let scene_spec = match (&args.scene, loaded_without_check.scene_source()) {
        (Some(spec), _) => spec.clone(),
        (None, Some(source)) => source.to_owned(),
        (None, None) => {
            return Err(CliError::InvalidArgument {
                parameter: "--scene",
                value: String::new(),
                reason: "the bake records no scene source; name the scene it was baked from".into(),
            });
        }
    };
    let scene = open_scene_with_limit(&scene_spec, limit)?;
    if args.select == SelectArg::Svo {
        let options = probe_index::SvoOptions {
            max_depth: args.svo_depth,
            ..probe_index::SvoOptions::default()
        };
        limit.check(
            format_args!("an octree of depth {}", args.svo_depth),
            options.memory_estimate(scene.triangles().len()),
        )?;
    }
    drop(loaded_without_check);
    let baked = ProbeBake::load_with_limit(&args.bake, Some(&scene), limit)?;
    let camera = camera(&scene, &args.camera)?;
    let (mut device, fallback) = if args.cpu {
        (Device::cpu(), None)
    } else {
        Device::open(args.require_gpu)?
    };
    let progress = spinner("rendering");
    let start = Instant::now();
    let gbuffer = render_gbuffer(&scene, &camera, args.width, args.height)?;
    let grid = ProbeGrid::detect(baked.positions());
    let mut json = json!({
        "command": "render",
        "scene": scene.name(),
        "bake": args.bake.display().to_string(),
        "camera": camera.name,
        "scene_warnings": warnings_json(&scene),
        "device": device.describe(),
        "cpu_fallback_reason": fallback,
        "width": args.width,
        "height": args.height,
        "probes": baked.probe_count(),
    });
    let mut parts = None;
    let image = if args.component == ComponentArg::Final {
        let rendered = final_component(args, &scene, &baked, &gbuffer, grid, &mut device)?;
        let map = json.as_object_mut().expect("an object");
        let t = rendered.times;
        let summary = rendered.specular;
        for (key, value) in [
            ("component", json!("final")),
            (
                "interpolation",
                json!(if args.select == SelectArg::Grid {
                    "grid"
                } else {
                    "delaunay"
                }),
            ),
            ("shading_points", json!(rendered.shading_points)),
            ("sectors", json!(args.sectors)),
            ("rays", json!(summary.rays)),
            (
                "hit_rate",
                json!(summary.hits as f64 / summary.rays.max(1) as f64),
            ),
            (
                "miss_rate",
                json!(summary.misses as f64 / summary.rays.max(1) as f64),
            ),
            ("unknown_rate", json!(summary.unknown_rate())),
            ("fetches_per_ray", json!(summary.fetches_per_ray)),
            ("probes_per_ray", json!(summary.probes_per_ray)),
            ("direct_ms", json!(t.direct_ms)),
            ("shade_wall_ms", json!(t.diffuse_ms)),
            ("shade_gpu_ms", json!(t.diffuse_gpu_ms)),
            ("trace_wall_ms", json!(t.specular_ms)),
            ("trace_gpu_ms", json!(t.specular_gpu_ms)),
            ("first_dispatch_ms", json!(t.first_dispatch_ms)),
        ] {
            map.insert(key.into(), value);
        }
        let image = rendered.parts.sum();
        parts = Some(rendered.parts);
        image
    } else if args.component == ComponentArg::Glossy1 {
        let reflection = if args.roughness > 0.0 {
            probe_capture::Reflection::Ggx {
                roughness: args.roughness,
            }
        } else {
            probe_capture::Reflection::Mirror
        };
        if args.filtered
            && (args.roughness <= 0.0
                || matches!(
                    args.tracer,
                    TracerArg::Hybrid | TracerArg::Shaded | TracerArg::Split
                ))
        {
            return Err(CliError::InvalidArgument {
                parameter: "--filtered",
                value: format!("roughness {}, tracer {:?}", args.roughness, args.tracer),
                reason: "filtered glossy needs --roughness > 0 and a light-field tracer (hiz or two-level)"
                    .into(),
            });
        }
        if args.interleave && !(args.filtered && matches!(args.sectors, 2 | 4)) {
            return Err(CliError::InvalidArgument {
                parameter: "--interleave",
                value: format!("sectors {}, filtered {}", args.sectors, args.filtered),
                reason: "interleaving shares a filtered lobe's parts between neighbours: add \
                         --filtered and --sectors 2 or 4"
                    .into(),
            });
        }
        if args.sectors != 1 && !args.filtered {
            return Err(CliError::InvalidArgument {
                parameter: "--sectors",
                value: args.sectors.to_string(),
                reason: "sectors cut a filtered lobe: add --filtered (with --roughness > 0)".into(),
            });
        }
        let interleaved = if args.interleave {
            Some(probe_eval::glossy::interleaved_sub_lobe_rays(
                &gbuffer,
                args.roughness,
                args.sectors,
            )?)
        } else {
            None
        };
        let rays = if let Some(interleaved) = &interleaved {
            interleaved.rays().to_vec()
        } else if args.filtered {
            probe_eval::glossy::sub_lobe_rays(&gbuffer, args.roughness, args.sectors)?
        } else {
            reflection_rays(&gbuffer, reflection, args.rays_per_pixel, args.seed)?
        };
        let selection = match args.select {
            SelectArg::Grid => Selection::Grid,
            SelectArg::Svo => Selection::Svo,
            SelectArg::Voronoi => Selection::Voronoi,
        };
        if selection == Selection::Grid && grid.is_none() {
            return Err(CliError::InvalidArgument {
                parameter: "--select",
                value: "grid".into(),
                reason: "the bake's probes are not a regular grid; use svo or voronoi".into(),
            });
        }
        let index_start = Instant::now();
        let index = build_index(&scene, baked.positions(), args.svo_depth, grid, args.seed)?;
        let index_seconds = index_start.elapsed().as_secs_f64();
        let Some(probe_selection) = selection.of(&index) else {
            return Err(CliError::InvalidArgument {
                parameter: "--select",
                value: selection.name().into(),
                reason: match selection {
                    Selection::Voronoi => {
                        "the bake's probes span no volume (fewer than 4, or all on a plane): \
                         there are no Voronoi neighbours; use svo"
                            .into()
                    }
                    _ => "this selection could not be built for the bake".into(),
                },
            });
        };
        let tracer = match args.tracer {
            TracerArg::Hiz => Tracer::HiZ,
            TracerArg::TwoLevel => Tracer::TwoLevel,
            TracerArg::Hybrid => Tracer::Hybrid,
            TracerArg::Shaded => Tracer::Shaded,
            TracerArg::Split => Tracer::Split,
        };
        let shading_start = Instant::now();
        let hit_shading = device.hit_shading_for(tracer, &scene, &baked, &index)?;
        let shading_seconds = shading_start.elapsed().as_secs_f64();
        // Without its reflected-light bake the split is refused by `trace_with`.
        let read = bake_read_by(tracer, &baked, hit_shading.as_ref()).unwrap_or(&baked);
        let field = if args.filtered {
            device.upload_with(
                &light_field(&baked),
                &probe_selection,
                &FieldOptions {
                    glossy_levels: probe_eval::glossy::GLOSSY_LEVELS,
                    ..FieldOptions::default()
                },
            )?
        } else {
            device.upload(&light_field(read), &probe_selection)?
        };
        let cone = TraceOptions {
            glossy_roughness: probe_eval::glossy::sub_lobe_roughness(args.roughness, args.sectors),
            glossy_blend: args.glossy_blend,
            ..tracer.options()
        };
        // Traced in 8×8 pixel tiles (faster on a GPU; the answers do not depend on the order).
        let order = TileOrder::of(&rays, args.width);
        let trace_rays: Vec<TraceRay> = order
            .apply(&rays)
            .iter()
            .map(|r| TraceRay::new(r.origin, r.direction))
            .collect();
        // The first dispatch compiles the pipeline (seconds on lavapipe with a cold shader
        // cache); time it apart and the trace on the second.
        let first_start = Instant::now();
        let warm_up = &trace_rays[..trace_rays.len().min(WARM_UP_ITEMS)];
        if args.filtered {
            device.trace(&field, warm_up, &cone)?;
        } else {
            device.trace_with(&scene, &field, warm_up, tracer, hit_shading.as_ref())?;
        }
        let first_dispatch_ms = first_start.elapsed().as_secs_f64() * 1e3;
        let mut output = if args.filtered {
            device.trace(&field, &trace_rays, &cone)?
        } else {
            device.trace_with(&scene, &field, &trace_rays, tracer, hit_shading.as_ref())?
        };
        output.results = order.restore(output.results);
        let summary = TraceSummary::of(&output.results);
        let radiance: Vec<Vec3> = output.results.iter().map(|r| r.radiance).collect();
        let map = json.as_object_mut().expect("an object");
        map.insert("component".into(), json!("glossy1"));
        map.insert("filtered".into(), json!(args.filtered));
        if args.filtered {
            map.insert("sectors".into(), json!(args.sectors));
            map.insert("interleaved".into(), json!(args.interleave));
        }
        map.insert("tracer".into(), json!(tracer.name()));
        map.insert("select".into(), json!(selection.name()));
        map.insert("rays".into(), json!(summary.rays));
        map.insert(
            "hit_rate".into(),
            json!(summary.hits as f64 / summary.rays.max(1) as f64),
        );
        map.insert(
            "miss_rate".into(),
            json!(summary.misses as f64 / summary.rays.max(1) as f64),
        );
        map.insert("unknown_rate".into(), json!(summary.unknown_rate()));
        map.insert("fetches_per_ray".into(), json!(summary.fetches_per_ray));
        map.insert("probes_per_ray".into(), json!(summary.probes_per_ray));
        map.insert(
            "trace_wall_ms".into(),
            json!(output.timing.wall.as_secs_f64() * 1e3),
        );
        map.insert(
            "trace_gpu_ms".into(),
            json!(output.timing.gpu.map(|d| d.as_secs_f64() * 1e3)),
        );
        map.insert("first_dispatch_ms".into(), json!(first_dispatch_ms));
        map.insert("index_seconds".into(), json!(index_seconds));
        if tracer.uses_bvh() {
            // The BVH tracers' irradiance probes, and the split's second bake when the bake
            // given holds the outgoing radiance.
            map.insert("hit_shading_seconds".into(), json!(shading_seconds));
        }
        if tracer == Tracer::Split {
            let made = hit_shading
                .as_ref()
                .and_then(|s| s.indirect_bake())
                .is_some();
            map.insert(
                "reflected_light".into(),
                json!(if made {
                    "baked for this render"
                } else {
                    "the bake given"
                }),
            );
        }
        if let Some(interleaved) = &interleaved {
            let resolve_start = Instant::now();
            let image = interleaved.resolve(&radiance);
            map.insert(
                "resolve_ms".into(),
                json!(resolve_start.elapsed().as_secs_f64() * 1e3),
            );
            image
        } else {
            accumulate_rays(args.width, args.height, &rays, &radiance)?
        }
    } else {
        let interpolation = match (&grid, args.select) {
            (Some(grid), SelectArg::Grid) => Interpolation::Grid(*grid),
            _ => Interpolation::Delaunay(&index_tetrahedra(&baked)?),
        };
        let irradiance = device.upload_irradiance(&baked, &interpolation)?;
        let mut pixels = Vec::new();
        let mut points = Vec::new();
        for (i, sample) in gbuffer.pixels.iter().enumerate() {
            if let Some(s) = sample {
                pixels.push(i);
                points.push(ShadingPoint::new(s.position, s.shading_normal));
            }
        }
        // As for the trace: the first dispatch compiles the pipeline (2 s on lavapipe with a
        // cold shader cache against 0.15 s of shading for 120,800 points), so it is timed
        // apart and the shading on the second.
        let options = args.diffuse_options;
        let first_start = Instant::now();
        device.shade_diffuse(
            &irradiance,
            &points[..points.len().min(WARM_UP_ITEMS)],
            &options,
        )?;
        let first_dispatch_ms = first_start.elapsed().as_secs_f64() * 1e3;
        let output = device.shade_diffuse(&irradiance, &points, &options)?;
        let mut image = Image::new(args.width, args.height);
        for (&pixel, (result, sample)) in pixels.iter().zip(
            output.results.iter().zip(
                pixels
                    .iter()
                    .map(|&p| gbuffer.pixels[p].as_ref().expect("a hit")),
            ),
        ) {
            let albedo = scene.materials()[sample.material as usize].base_color;
            image.rgb[pixel] = (result.irradiance * albedo / std::f32::consts::PI).to_array();
        }
        let map = json.as_object_mut().expect("an object");
        map.insert("component".into(), json!("diffuse"));
        map.insert(
            "interpolation".into(),
            json!(if matches!(interpolation, Interpolation::Grid(_)) {
                "grid"
            } else {
                "delaunay"
            }),
        );
        map.insert("shading_points".into(), json!(points.len()));
        map.insert("first_dispatch_ms".into(), json!(first_dispatch_ms));
        map.insert(
            "shade_wall_ms".into(),
            json!(output.timing.wall.as_secs_f64() * 1e3),
        );
        map.insert(
            "shade_gpu_ms".into(),
            json!(output.timing.gpu.map(|d| d.as_secs_f64() * 1e3)),
        );
        image
    };
    progress.finish_and_clear();
    image.save_exr(&args.out)?;
    let png = args.png.clone().or_else(|| {
        (args.component == ComponentArg::Final).then(|| args.out.with_extension("png"))
    });
    if let Some(png) = &png {
        image.save_png(png)?;
    }
    let mut written_parts = Vec::new();
    if let Some(parts) = parts.filter(|_| args.split) {
        for (name, part) in [
            ("direct", &parts.direct),
            ("diffuse", &parts.diffuse),
            ("specular", &parts.specular),
        ] {
            let exr = args.out.with_extension(format!("{name}.exr"));
            part.save_exr(&exr)?;
            part.save_png(exr.with_extension("png"))?;
            written_parts.push(exr.display().to_string());
        }
    }
    let map = json.as_object_mut().expect("an object");
    map.insert("seconds".into(), json!(start.elapsed().as_secs_f64()));
    map.insert("out".into(), json!(args.out.display().to_string()));
    map.insert(
        "png".into(),
        json!(png.as_ref().map(|p| p.display().to_string())),
    );
    map.insert("parts".into(), json!(written_parts));
    Ok(Box::new(RenderSummary { json }))
}

/// The final image through the probes (probe-eval's [`render_final`]).
fn final_component(
    args: &Args,
    scene: &probe_scene::Scene,
    baked: &ProbeBake,
    gbuffer: &probe_capture::GBuffer,
    grid: Option<ProbeGrid>,
    device: &mut Device,
) -> Result<ProbeFinal, CliError> {
    let (selection, blend) = match args.select {
        SelectArg::Grid => (Selection::Grid, DiffuseBlend::Grid),
        SelectArg::Svo => (Selection::Svo, DiffuseBlend::Delaunay),
        SelectArg::Voronoi => (Selection::Voronoi, DiffuseBlend::Delaunay),
    };
    if selection == Selection::Grid && grid.is_none() {
        return Err(CliError::InvalidArgument {
            parameter: "--select",
            value: "grid".into(),
            reason: "the bake's probes are not a regular grid; use svo or voronoi".into(),
        });
    }
    if args.sectors != 1 && args.specular == SpecularArg::Stochastic {
        return Err(CliError::InvalidArgument {
            parameter: "--sectors",
            value: args.sectors.to_string(),
            reason: "sectors cut a filtered lobe: use --specular filtered, or \
                     --rays-per-pixel for stochastic specular rays"
                .into(),
        });
    }
    if args.interleave {
        return Err(CliError::InvalidArgument {
            parameter: "--interleave",
            value: "component final".into(),
            reason: "interleaved sub-lobes are for the glossy component (--component glossy1 \
                     --filtered); the final image's specular takes --sectors alone"
                .into(),
        });
    }
    let index = build_index(scene, baked.positions(), args.svo_depth, grid, args.seed)?;
    let options = FinalOptions {
        tracer: match args.tracer {
            TracerArg::Hiz => Tracer::HiZ,
            TracerArg::TwoLevel => Tracer::TwoLevel,
            TracerArg::Hybrid => Tracer::Hybrid,
            TracerArg::Shaded => Tracer::Shaded,
            TracerArg::Split => Tracer::Split,
        },
        selection,
        blend,
        diffuse: args.diffuse_options,
        specular: match args.specular {
            SpecularArg::Filtered => SpecularMode::Filtered,
            SpecularArg::Stochastic => SpecularMode::Stochastic,
        },
        glossy_blend: args.glossy_blend,
        specular_sectors: args.sectors,
        specular_rays_per_pixel: args.rays_per_pixel,
        emitter_samples: args.emitter_samples,
        seed: args.seed,
    };
    Ok(render_final(
        device, scene, baked, &index, gbuffer, &options,
    )?)
}

fn index_tetrahedra(baked: &ProbeBake) -> Result<probe_index::Tetrahedralization, CliError> {
    Ok(probe_index::Tetrahedralization::build(baked.positions())
        .map_err(probe_index::IndexError::from)?)
}

struct RenderSummary {
    json: Value,
}

impl Report for RenderSummary {
    fn json(&self) -> Value {
        self.json.clone()
    }

    fn text(&self) -> String {
        let j = &self.json;
        let number = |key: &str| j.get(key).and_then(Value::as_f64);
        let mut text = format!(
            "rendered {} of {} ({} probes) from camera {} on {}\n",
            j["component"].as_str().unwrap_or("?"),
            j["scene"].as_str().unwrap_or("?"),
            j["probes"],
            j["camera"].as_str().unwrap_or("?"),
            j["device"].as_str().unwrap_or("?"),
        );
        if let Some(reason) = j["cpu_fallback_reason"].as_str() {
            text.push_str(&format!("(no GPU: {reason}; traced with the CPU twin)\n"));
        }
        if let Some(rays) = number("rays") {
            text.push_str(&format!(
                "rays {rays:.0}: hit {:.2} %, miss {:.2} %, unknown {:.2} %; {:.1} texel fetches and {:.2} probes per ray; trace {:.1} ms wall{}\n",
                100.0 * number("hit_rate").unwrap_or(0.0),
                100.0 * number("miss_rate").unwrap_or(0.0),
                100.0 * number("unknown_rate").unwrap_or(0.0),
                number("fetches_per_ray").unwrap_or(0.0),
                number("probes_per_ray").unwrap_or(0.0),
                number("trace_wall_ms").unwrap_or(0.0),
                number("trace_gpu_ms").map_or(String::new(), |ms| format!(", {ms:.2} ms GPU")),
            ));
        }
        if let Some(points) = number("shading_points") {
            text.push_str(&format!(
                "shaded {points:.0} points ({} interpolation with Chebyshev visibility) in {:.1} ms wall{}\n",
                j["interpolation"].as_str().unwrap_or("?"),
                number("shade_wall_ms").unwrap_or(0.0),
                number("shade_gpu_ms").map_or(String::new(), |ms| format!(", {ms:.2} ms GPU")),
            ));
        }
        if let Some(ms) = number("direct_ms") {
            text.push_str(&format!(
                "direct light (exact shadow rays on the CPU) {ms:.1} ms\n"
            ));
        }
        if let Some(seconds) = number("hit_shading_seconds") {
            text.push_str(&format!(
                "hit shading made in {seconds:.2} s{}\n",
                match j["reflected_light"].as_str() {
                    Some("baked for this render") =>
                        " (with the split's bake of the reflected light; bake it once with \
                         `probes bake --radiance indirect` and render that)",
                    _ => "",
                }
            ));
        }
        if let Some(ms) = number("first_dispatch_ms") {
            text.push_str(&format!(
                "first dispatch (compiles the pipeline; not in the time above) {ms:.1} ms\n"
            ));
        }
        text.push_str(&format!("wrote {}\n", j["out"].as_str().unwrap_or("?")));
        text
    }
}
