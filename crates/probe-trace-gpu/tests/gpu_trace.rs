//! The GPU tracer against its CPU twin, on lavapipe here (any wgpu adapter elsewhere).
//!
//! Without an adapter these tests print a message and pass; with `PROBE_REQUIRE_GPU=1` they
//! fail instead (CI sets it).

mod support;

use glam::Vec3;
use probe_index::{
    NearestProbe, ProbeGrid, SparseVoxelOctree, SvoOptions, Tetrahedralization, VoronoiNeighbours,
};
use probe_scene::Scene;
use probe_trace_gpu::{
    CpuTracer, DiffuseOptions, FieldOptions, GpuContext, GpuTracer, Interpolation, IrradianceField,
    LightField, ProbeSelection, RayResult, RayStatus, ShadingPoint, SurfaceQuery, TraceError,
    TraceMethod, TraceOptions, TraceOutput, TraceRay, TraceSummary, Tracer,
};
use support::{
    LowRes, albedo_shade, camera_rays, gpu_tracer, mini_capture, reflection_rays, to_trace_rays,
};

/// Compares GPU and CPU results: statuses agree for ≥ 99.9 % of rays, and where both hit,
/// positions agree within 1e-4 m for ≥ 99.9 % of those.
fn assert_agree(label: &str, gpu: &[RayResult], cpu: &[RayResult]) {
    assert_eq!(gpu.len(), cpu.len());
    let n = gpu.len();
    let same_status = gpu
        .iter()
        .zip(cpu)
        .filter(|(g, c)| g.status == c.status)
        .count();
    let both_hit: Vec<f32> = gpu
        .iter()
        .zip(cpu)
        .filter(|(g, c)| g.status == RayStatus::Hit && c.status == RayStatus::Hit)
        .map(|(g, c)| (g.position - c.position).length())
        .collect();
    let close = both_hit.iter().filter(|&&e| e <= 1e-4).count();
    let same_fetches = gpu
        .iter()
        .zip(cpu)
        .filter(|(g, c)| g.texel_fetches == c.texel_fetches)
        .count();
    // Radiance too, the UNKNOWN rays' estimates included (the mean of two guesses for
    // mirror rays).
    let radiance_close = |status: Option<RayStatus>| {
        let pairs: Vec<bool> = gpu
            .iter()
            .zip(cpu)
            .filter(|(g, c)| g.status == c.status && status.is_none_or(|s| s == c.status))
            .map(|(g, c)| {
                (g.radiance - c.radiance).abs().max_element() <= 1e-4 * (1.0 + c.radiance.length())
            })
            .collect();
        (pairs.iter().filter(|&&b| b).count(), pairs.len())
    };
    let (radiance_same, compared) = radiance_close(None);
    let (unknown_same, unknown) = radiance_close(Some(RayStatus::Unknown));
    eprintln!(
        "{label}: status {same_status}/{n}, hit positions within 1e-4 m {close}/{}, equal fetch counts {same_fetches}/{n}, radiance within 1e-4 {radiance_same}/{compared} (UNKNOWN estimates {unknown_same}/{unknown})",
        both_hit.len()
    );
    assert!(
        radiance_same as f64 >= 0.999 * compared as f64,
        "{label}: radiance agrees for {radiance_same} of {compared}"
    );
    assert!(
        unknown_same as f64 >= 0.99 * unknown as f64,
        "{label}: UNKNOWN estimates' radiance agrees for {unknown_same} of {unknown}"
    );
    assert!(
        same_status as f64 >= 0.999 * n as f64,
        "{label}: statuses agree for {same_status} of {n}"
    );
    assert!(
        close as f64 >= 0.999 * both_hit.len() as f64,
        "{label}: {close} of {} hit positions within 1e-4 m",
        both_hit.len()
    );
    assert!(
        both_hit.len() as f64 > 0.3 * n as f64,
        "{label}: too few hits to compare"
    );
}

/// Uploads `field` with `selection` to the GPU and the CPU twin, traces `rays` with hi-Z and
/// two-level on each and checks every pair with [`assert_agree`] (labelled `label` and the
/// method); also requires equal fetch counts for ≥ 99.9 % of the rays. Returns the pairs.
fn assert_methods_agree(
    gpu: &mut GpuTracer,
    field: &LightField<'_>,
    selection: &ProbeSelection<'_>,
    rays: &[TraceRay],
    label: &str,
) -> Vec<(TraceOutput, TraceOutput)> {
    let gpu_field = gpu
        .upload(field, selection, &FieldOptions::default())
        .unwrap();
    let mut cpu = CpuTracer::new();
    let cpu_field = cpu
        .upload(field, selection, &FieldOptions::default())
        .unwrap();
    [TraceMethod::HiZ, TraceMethod::TwoLevel]
        .into_iter()
        .map(|method| {
            let options = TraceOptions {
                method,
                ..TraceOptions::default()
            };
            let g = gpu.trace(&gpu_field, rays, &options).unwrap();
            let c = cpu.trace(&cpu_field, rays, &options).unwrap();
            let label = format!("{label} {}", method.name());
            assert_agree(&label, &g.results, &c.results);
            let same_fetches = g
                .results
                .iter()
                .zip(&c.results)
                .filter(|(g, c)| g.texel_fetches == c.texel_fetches)
                .count();
            assert!(
                same_fetches as f64 >= 0.999 * rays.len() as f64,
                "{label}: equal fetch counts for {same_fetches} of {} rays",
                rays.len()
            );
            (g, c)
        })
        .collect()
}

fn cornell_grid() -> ProbeGrid {
    ProbeGrid::new(
        Vec3::new(0.07, 0.07, 0.07),
        Vec3::new(0.205, 0.2, 0.21),
        [3, 3, 3],
    )
    .unwrap()
}

/// Every selector and both methods: the GPU reproduces the CPU twin on Cornell reflection rays.
#[test]
fn gpu_matches_cpu_for_every_selector_and_method() {
    let Some(mut gpu) = gpu_tracer() else { return };
    let scene = Scene::open("builtin:cornell").unwrap();
    let shade = albedo_shade(&scene);
    let grid = cornell_grid();
    let positions = grid.positions();
    let bake = mini_capture(&scene, &positions, 64, 50.0, &shade);
    let tets = Tetrahedralization::build(&positions).unwrap();
    let neighbours = VoronoiNeighbours::bake(&tets, 16).unwrap();
    let nearest = NearestProbe::new(&positions);
    let svo = SparseVoxelOctree::build(
        &scene,
        &positions,
        &SvoOptions {
            max_depth: 6,
            ..SvoOptions::default()
        },
    )
    .unwrap();
    let mut rays = to_trace_rays(&reflection_rays(&scene, &camera_rays(&scene, 48, 36)));
    rays.extend(to_trace_rays(&camera_rays(&scene, 24, 18)));
    for selection in [
        ProbeSelection::Grid(grid),
        ProbeSelection::SparseVoxelOctree(&svo),
        ProbeSelection::Voronoi {
            nearest: &nearest,
            neighbours: &neighbours,
        },
    ] {
        for (g, _) in
            assert_methods_agree(&mut gpu, &bake.field(), &selection, &rays, selection.name())
        {
            eprintln!(
                "  {:?} wall {:?} gpu {:?}",
                TraceSummary::of(&g.results),
                g.timing.wall,
                g.timing.gpu
            );
        }
    }
}

/// Crossings within a texel of a wall's free edge (`support::wall_edge`): the GPU answers them
/// as the CPU twin does, ray by ray, with the same fetches (the `among_samples` test of a
/// texel with a farther edge runs on most of these rays).
#[test]
fn gpu_matches_cpu_at_a_free_edge() {
    let Some(mut gpu) = gpu_tracer() else { return };
    let case = support::wall_edge();
    let mut rays = to_trace_rays(&case.rays);
    // And as many aimed at the wall's middle, so that most rays hit.
    rays.extend(case.rays.iter().map(|ray| {
        let target = ray.origin + ray.direction * (ray.origin.x / -ray.direction.x);
        let middle = Vec3::new(0.0, target.y, target.z - 1.0);
        TraceRay::new(ray.origin, middle - ray.origin)
    }));
    let selection = ProbeSelection::Grid(case.grid);
    assert_methods_agree(&mut gpu, &case.bake.field(), &selection, &rays, "wall edge");
}

/// The GPU ends rays at the scene's bounds as the CPU twin does (the Cornell box's open
/// front), and hands on crossings of a thin sheet from behind likewise.
#[test]
fn gpu_matches_cpu_past_the_bounds_and_through_a_sheet() {
    let Some(mut gpu) = gpu_tracer() else { return };
    for (label, case) in [
        ("cornell bounds", support::cornell_reflections()),
        ("two-sided sheet", support::two_sided_sheet()),
    ] {
        let selection = ProbeSelection::Grid(case.grid);
        let rays = to_trace_rays(&case.rays);
        let pairs = assert_methods_agree(&mut gpu, &case.bake.field(), &selection, &rays, label);
        let misses = pairs[0]
            .0
            .results
            .iter()
            .filter(|r| r.status == RayStatus::Miss)
            .count();
        eprintln!("{label}: {misses} misses of {} rays", rays.len());
    }
}

/// Where two probes refuse the same crossing (`TraceOptions::agreement`), the GPU answers the
/// hit as the CPU twin does, ray by ray; and with agreement off, as the twin does without.
#[test]
fn gpu_matches_cpu_where_probes_agree_on_a_refused_crossing() {
    let Some(mut gpu) = gpu_tracer() else { return };
    let case = support::cornell_agreement();
    let selection = ProbeSelection::Grid(case.grid);
    let rays = to_trace_rays(&case.rays);
    let pairs = assert_methods_agree(&mut gpu, &case.bake.field(), &selection, &rays, "agreement");
    let field = case.bake.field();
    let gpu_field = gpu
        .upload(&field, &selection, &FieldOptions::default())
        .unwrap();
    let mut cpu = CpuTracer::new();
    let cpu_field = cpu
        .upload(&field, &selection, &FieldOptions::default())
        .unwrap();
    let without = TraceOptions {
        agreement: false,
        ..TraceOptions::default()
    };
    let g = gpu.trace(&gpu_field, &rays, &without).unwrap();
    let c = cpu.trace(&cpu_field, &rays, &without).unwrap();
    assert_agree("without agreement", &g.results, &c.results);
    // The case exercises agreement: answers differ from those without it.
    let changed = pairs[0]
        .0
        .results
        .iter()
        .zip(&g.results)
        .filter(|(a, b)| a.status != b.status)
        .count();
    assert!(changed >= 5, "only {changed} rays answered differently");
}

/// Buffers are made once and grow only when needed: calls of varying sizes (including more
/// rays than the first call) keep matching the CPU, and an empty call works.
#[test]
fn repeated_calls_reuse_and_grow_buffers() {
    let Some(mut gpu) = gpu_tracer() else { return };
    let scene = Scene::open("builtin:cornell").unwrap();
    let shade = albedo_shade(&scene);
    let grid = cornell_grid();
    let bake = mini_capture(&scene, &grid.positions(), 32, 50.0, &shade);
    let mut cpu = CpuTracer::new();
    let gpu_field = gpu
        .upload(
            &bake.field(),
            &ProbeSelection::Grid(grid),
            &FieldOptions::default(),
        )
        .unwrap();
    let cpu_field = cpu
        .upload(
            &bake.field(),
            &ProbeSelection::Grid(grid),
            &FieldOptions::default(),
        )
        .unwrap();
    let all = to_trace_rays(&camera_rays(&scene, 40, 30));
    for count in [100, 37, 1200, 5, 1200, 0] {
        let rays = &all[..count];
        let g = gpu
            .trace(&gpu_field, rays, &TraceOptions::default())
            .unwrap();
        let c = cpu
            .trace(&cpu_field, rays, &TraceOptions::default())
            .unwrap();
        assert_eq!(g.results.len(), count);
        if count > 0 {
            let same = g
                .results
                .iter()
                .zip(&c.results)
                .filter(|(a, b)| a.status == b.status)
                .count();
            assert!(same as f64 >= 0.99 * count as f64, "{count}: {same}");
        }
    }
    // Options are checked before anything runs.
    let bad = TraceOptions {
        max_probes: 0,
        ..TraceOptions::default()
    };
    assert!(matches!(
        gpu.trace(&gpu_field, &all[..4], &bad),
        Err(TraceError::BadOption {
            option: "max_probes",
            ..
        })
    ));
    let bad_ray = [TraceRay::new(Vec3::ZERO, Vec3::ZERO)];
    assert!(matches!(
        gpu.trace(&gpu_field, &bad_ray, &TraceOptions::default()),
        Err(TraceError::BadInput { index: 0, .. })
    ));
}

/// Diffuse shading on the GPU equals the CPU twin, grid and Delaunay (inside the hull and
/// projected onto it), with and without visibility and the backface term, at two exponents.
#[test]
fn gpu_diffuse_matches_cpu() {
    let Some(mut gpu) = gpu_tracer() else { return };
    let scene = Scene::open("builtin:leak-gap").unwrap();
    let shade = support::direct_light_shade(&scene);
    let grid = ProbeGrid::new(
        Vec3::new(-3.0, 0.5, -1.5),
        Vec3::new(1.2, 1.0, 1.0),
        [6, 3, 4],
    )
    .unwrap();
    let positions = grid.positions();
    let bake = mini_capture(&scene, &positions, 16, 100.0, &shade);
    let low = LowRes::of(&bake);
    let tets = Tetrahedralization::build(&positions).unwrap();
    // Floor points (outside the probes' hull: the hull projection) and points at every
    // height with turning normals (inside it: the walk).
    let points: Vec<ShadingPoint> = (0..800)
        .map(|i| {
            let x = -3.9 + 7.8 * ((i * 37) % 400) as f32 / 400.0;
            let z = -1.9 + 3.8 * ((i * 91) % 400) as f32 / 400.0;
            if i < 400 {
                ShadingPoint::new(Vec3::new(x, 0.0, z), Vec3::Y)
            } else {
                let y = 2.9 * ((i * 53) % 400) as f32 / 400.0;
                let a = i as f32 * 0.7;
                ShadingPoint::new(Vec3::new(x, y, z), Vec3::new(a.cos(), 0.4, a.sin()))
            }
        })
        .collect();
    let mut cpu = CpuTracer::new();
    compare_diffuse(
        &mut gpu,
        &mut cpu,
        &low,
        &[Interpolation::Grid(grid), Interpolation::Delaunay(&tets)],
        &points,
    );
    // The same probes moved at random by up to 0.3 m per axis (a hull of slanted triangles
    // meeting at odd corners, where the descent over the hull turns around corners and
    // crosses edges), with points all around and far outside the hull.
    let mut s = 99u64;
    let mut next = move || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (s >> 40) as f32 / (1u64 << 24) as f32
    };
    let jittered: Vec<Vec3> = positions
        .iter()
        .map(|&p| p + (Vec3::new(next(), next(), next()) - 0.5) * 0.6)
        .collect();
    let bake = mini_capture(&scene, &jittered, 16, 100.0, &shade);
    let low = LowRes::of(&bake);
    let tets = Tetrahedralization::build(&jittered).unwrap();
    let points: Vec<ShadingPoint> = (0..800)
        .map(|_| {
            let x = Vec3::new(next() * 12.0 - 6.0, next() * 6.0 - 1.5, next() * 6.0 - 3.0);
            let n = Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5);
            ShadingPoint::new(x, n.try_normalize().unwrap_or(Vec3::Y))
        })
        .collect();
    compare_diffuse(
        &mut gpu,
        &mut cpu,
        &low,
        &[Interpolation::Delaunay(&tets)],
        &points,
    );
}

/// The GPU and the CPU twin shade `points` alike (999 in 1000 within 1e-3 relative) for each
/// interpolation and a few option sets, with and without the surfels' near-field correction,
/// and with the first probe flagged as inside geometry (left out of the blend).
fn compare_diffuse(
    gpu: &mut GpuTracer,
    cpu: &mut CpuTracer,
    low: &LowRes,
    interpolations: &[Interpolation<'_>],
    points: &[ShadingPoint],
) {
    let mut first_inside = vec![false; low.positions.len()];
    first_inside[0] = true;
    let flagged = IrradianceField {
        inside_geometry: &first_inside,
        ..low.field()
    };
    for (interpolation, field) in interpolations
        .iter()
        .flat_map(|i| [(i, low.field()), (i, flagged)])
    {
        let gpu_irradiance = gpu.upload_irradiance(&field, interpolation).unwrap();
        let cpu_irradiance = cpu.upload_irradiance(&field, interpolation).unwrap();
        for (visibility, exponent, backface, parallax) in [
            (false, 3.0, false, false),
            (false, 3.0, true, false),
            (true, 3.0, true, false),
            (true, 1.5, false, false),
            (true, 5.0, true, true),
            (false, 3.0, false, true),
        ] {
            let options = DiffuseOptions {
                visibility,
                visibility_exponent: exponent,
                backface,
                parallax,
                ..DiffuseOptions::default()
            };
            let g = gpu
                .shade_diffuse(&gpu_irradiance, points, &options)
                .unwrap();
            let c = cpu
                .shade_diffuse(&cpu_irradiance, points, &options)
                .unwrap();
            let close = g
                .results
                .iter()
                .zip(&c.results)
                .filter(|(a, b)| {
                    (a.irradiance - b.irradiance).length() <= 1e-3 * (1.0 + b.irradiance.length())
                })
                .count();
            assert!(
                close as f64 >= 0.999 * points.len() as f64,
                "visibility {visibility}, exponent {exponent}, backface {backface}, \
                 parallax {parallax}: {close}"
            );
        }
    }
}

/// A missing adapter gives a clear error. Run in a child process with `WGPU_BACKEND=metal`
/// (no Metal backend exists on Linux or Windows, so no adapter can be found).
#[test]
#[cfg(not(target_os = "macos"))]
fn missing_adapter_is_a_clear_error() {
    if std::env::var_os("PROBE_TRACE_CHILD").is_some() {
        return;
    }
    let exe = std::env::current_exe().unwrap();
    let run = |require: bool| {
        let mut command = std::process::Command::new(&exe);
        command
            .args([
                "--exact",
                "child_without_adapter",
                "--ignored",
                "--nocapture",
            ])
            .env("WGPU_BACKEND", "metal")
            .env("PROBE_TRACE_CHILD", "1");
        if require {
            command.env("PROBE_REQUIRE_GPU", "1");
        } else {
            command.env_remove("PROBE_REQUIRE_GPU");
        }
        command.output().unwrap()
    };
    let lenient = run(false);
    let text = String::from_utf8_lossy(&lenient.stdout).to_string()
        + &String::from_utf8_lossy(&lenient.stderr);
    assert!(lenient.status.success(), "{text}");
    assert!(text.contains("no GPU adapter is available"), "{text}");
    assert!(text.contains("skipping GPU test"), "{text}");
    let strict = run(true);
    let text = String::from_utf8_lossy(&strict.stdout).to_string()
        + &String::from_utf8_lossy(&strict.stderr);
    assert!(!strict.status.success(), "{text}");
    assert!(
        text.contains("PROBE_REQUIRE_GPU=1 but no GPU is usable"),
        "{text}"
    );
}

/// Child of `missing_adapter_is_a_clear_error` (ignored when run directly).
#[test]
#[ignore = "run by missing_adapter_is_a_clear_error in a child process"]
fn child_without_adapter() {
    if std::env::var_os("PROBE_TRACE_CHILD").is_none() {
        return;
    }
    let error = GpuContext::new().expect_err("no adapter with WGPU_BACKEND=metal");
    println!("error: {error}");
    assert!(gpu_tracer().is_none());
}

/// The hybrid's look-up of Cornell reflection rays' exact BVH hits through `grid`'s probes
/// (the mini capture at 64²): the truth of each hit (`None` for escaped rays) and the CPU
/// twin's answers, after checking that the GPU gives the same.
fn cornell_look_ups(
    gpu: &mut GpuTracer,
    grid: ProbeGrid,
    camera_size: u32,
) -> (Vec<Option<Vec3>>, Vec<RayResult>) {
    let scene = Scene::open("builtin:cornell").unwrap();
    let shade = albedo_shade(&scene);
    let bake = mini_capture(&scene, &grid.positions(), 64, 50.0, &shade);
    let rays = reflection_rays(
        &scene,
        &camera_rays(&scene, camera_size, camera_size * 3 / 4),
    );
    let mut truth = Vec::new();
    let queries: Vec<SurfaceQuery> = rays
        .iter()
        .map(|ray| match scene.closest_hit(ray, f32::INFINITY) {
            Some(hit) => {
                truth.push(Some(shade(&hit, ray.direction)));
                SurfaceQuery::surface(hit.position, hit.geometric_normal, ray.direction)
            }
            None => {
                truth.push(None);
                SurfaceQuery::escaped(ray.origin, ray.direction)
            }
        })
        .collect();
    let selection = ProbeSelection::Grid(grid);
    let options = TraceOptions::default();
    let mut cpu = CpuTracer::new();
    let cpu_field = cpu
        .upload(&bake.field(), &selection, &FieldOptions::default())
        .unwrap();
    let gpu_field = gpu
        .upload(&bake.field(), &selection, &FieldOptions::default())
        .unwrap();
    let c = cpu.look_up(&cpu_field, &queries, &options).unwrap().results;
    let g = gpu.look_up(&gpu_field, &queries, &options).unwrap().results;
    // Everything equal but the unpacked normal and the blended radiance, which the device
    // may round an ulp differently.
    let same = |a: &RayResult, b: &RayResult| {
        a.normal.abs_diff_eq(b.normal, 1e-5)
            && a.radiance
                .abs_diff_eq(b.radiance, 1e-5 * (1.0 + a.radiance.length()))
            && RayResult {
                normal: Vec3::ZERO,
                radiance: Vec3::ZERO,
                ..*a
            } == RayResult {
                normal: Vec3::ZERO,
                radiance: Vec3::ZERO,
                ..*b
            }
    };
    if let Some(i) = (0..c.len()).find(|&i| !same(&c[i], &g[i])) {
        panic!("query {i}: CPU {:?}, GPU {:?}", c[i], g[i]);
    }
    (truth, c)
}

/// The hybrid tracer's look-up: exact BVH hits of Cornell reflection rays, their radiance from
/// the probes that see them. GPU and CPU give the same answers, and the answers are the true
/// surfaces' (the mini capture's radiance is the albedo, the same from every side).
#[test]
fn look_up_agrees_with_the_cpu_and_the_truth() {
    let Some(mut gpu) = gpu_tracer() else { return };
    let (truth, c) = cornell_look_ups(&mut gpu, cornell_grid(), 48);
    let (mut hits, mut right, mut error) = (0usize, 0usize, 0.0f64);
    for (result, truth) in c.iter().zip(&truth) {
        match truth {
            Some(radiance) => {
                if result.status == RayStatus::Hit {
                    hits += 1;
                    let e = (result.radiance - *radiance).abs().max_element();
                    right += usize::from(e < 1e-4);
                    error += f64::from(e);
                }
            }
            None => assert_eq!(result.status, RayStatus::Miss),
        }
    }
    let surfaces = truth.iter().filter(|t| t.is_some()).count();
    let mean_error = error / hits.max(1) as f64;
    eprintln!(
        "look-up: {hits} of {surfaces} surface points seen, {right} with the true radiance, mean error {mean_error:.4}"
    );
    assert!(
        hits as f64 >= 0.97 * surfaces as f64,
        "{hits} of {surfaces} seen"
    );
    // Only texels of a surface facing like the point's show it: a point in a crease is no
    // longer read from the other wall, whose texels' planes hold it too (900 of 951 right,
    // mean error 0.0091, when they did; 950 and 0.0004 since).
    assert!(
        right as f64 >= 0.99 * hits as f64,
        "{right} of {hits} right"
    );
    assert!(mean_error < 0.002, "mean radiance error {mean_error}");
}

/// Points no probe sees: with a 2×2×2 grid many of the box's points are hidden from every
/// probe, and the look-up's estimate (the nearest point of the point's own surface that one
/// of the two nearest misses sees; every probe asked where no candidate faces the point) is
/// the same on the GPU as on the CPU twin.
#[test]
fn look_ups_of_points_no_probe_sees_agree_with_the_cpu() {
    let Some(mut gpu) = gpu_tracer() else { return };
    let grid = ProbeGrid::new(
        Vec3::new(0.14, 0.14, 0.14),
        Vec3::new(0.28, 0.28, 0.28),
        [2, 2, 2],
    )
    .unwrap();
    let (_, c) = cornell_look_ups(&mut gpu, grid, 128);
    let unseen = c.iter().filter(|r| r.status == RayStatus::Unknown).count();
    eprintln!("{unseen} of {} look-ups no probe sees", c.len());
    assert!(unseen >= 20, "{unseen}");
}
