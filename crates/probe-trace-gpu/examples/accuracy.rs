//! Accuracy and speed of the tracers against exact BVH hits of the same rays (BRIEF, "How
//! quality is measured"): mirror reflection rays from a camera's first hits, traced through
//! probes baked by the test support's mini capture (one BVH ray per texel centre, plus 3×3
//! rays across each texel for its distance range; radiance = base colour + emission),
//! compared with the BVH's closest hits. The CPU twin is used (the GPU gives the same answers;
//! see the `gpu_trace` tests), and every time is on the same threads as the BVH's.
//!
//! Prints Markdown table rows: per probe set and selection, the light-field tracer with the
//! distance ranges and 16, 8 or 32 probes per ray, without the nearest-probe extension (the
//! selection's own candidates, 8 probes per ray: the tracer before it), without the distance
//! ranges (probe-eval's default, chosen by this table), the same without
//! `TraceOptions::agreement` (two probes that refuse the same crossing make a hit), and the
//! hybrid (BVH hits, radiance looked up in the probes). Wrong answers are split into hits
//! before the true one, hits behind it (the true surface passed) and others (a miss for a
//! hit, a hit for an escape).
//!
//! ```text
//! cargo run --release -p probe-trace-gpu --example accuracy -- [cornell|sponza|sponza-region|breakfast|godot|all] [PROBES.json]
//! ```
//!
//! With a `probes/1` file (`probes place --out`), that probe set is traced instead of the
//! scene's grids (Voronoi and octree selection). `ACCURACY_RESOLUTION=N` bakes the real
//! scenes' probes, and a file's probes on the Cornell box, at N² instead of 256².
//!
//! On stderr, for each probe set's default row: the **ceiling** (the share of seen hits that
//! some probe that sees them stores in the texel of their direction, which no tracer of
//! these maps passes but by chance; hits within a footprint of the ray's own start apart)
//! and where the tracer's failures on seen hits sit, by
//! answer and by how the answering probe holds the true hit (BENCHMARKS.md, "What the bake
//! holds, and where the tracer loses it").

#[path = "../tests/support/mod.rs"]
mod support;

use std::time::{Duration, Instant};

use glam::{Vec2, Vec3};
use probe_index::{
    NearestProbe, ProbeGrid, SparseVoxelOctree, SvoOptions, Tetrahedralization, VoronoiNeighbours,
};
use probe_octa::OctaLayout;
use probe_scene::{Camera, Ray, Scene};
use probe_trace_gpu::{
    CpuTracer, FieldOptions, ProbeSelection, RayResult, RayStatus, TraceMethod, TraceOptions,
    TraceSummary, Tracer,
};
use rayon::prelude::*;
use support::{
    Bake, accuracy, albedo_shade, footprint, hit_queries, mini_capture, reflection_rays,
    to_trace_rays,
};

fn header() {
    println!(
        "| scene | probes | res | selector | variant | rays | true hits seen by a probe | of those, within 1 footprint | within 2 | wrong answers (early / late / other) | unknown | radiance MSE | fetches/ray hi-Z | fetches/ray two-level | probes/ray | CPU ms hi-Z | two-level | BVH | hi-Z / BVH |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
}

/// Wrong answers split by where the answer lies against the truth: a hit before the true one
/// (invented), after it (the true surface passed), or another mismatch (a miss for a hit, a
/// hit for an escape). `hits`: the rays' true hits, as `rows` traced them once.
fn wrong_split(
    bake: &Bake,
    hits: &[Option<probe_scene::Hit>],
    results: &[RayResult],
) -> (usize, usize, usize) {
    let (mut early, mut late, mut other) = (0, 0, 0);
    for (truth, r) in hits.iter().zip(results) {
        if r.status == RayStatus::Unknown {
            continue;
        }
        match (truth, r.status, r.probe) {
            (Some(h), RayStatus::Hit, Some(p)) if misses_by(bake, r, p, h) > 2.0 => {
                if r.t < h.t {
                    early += 1;
                } else {
                    late += 1;
                }
            }
            (Some(_), RayStatus::Miss, _) | (None, RayStatus::Hit, _) => other += 1,
            _ => {}
        }
    }
    (early, late, other)
}

/// How far the answer `r` (by probe `p`) lies from the true hit `h`, in footprints of `p`.
fn misses_by(bake: &Bake, r: &RayResult, p: u32, h: &probe_scene::Hit) -> f32 {
    let f = footprint(
        bake.resolution,
        bake.positions[p as usize],
        h.position,
        h.geometric_normal,
    );
    (r.position - h.position).length() / f
}

/// What the bake can answer of a ray whose true hit some probe sees (the table's "seen").
#[derive(Clone, Copy, Debug, PartialEq)]
enum Held {
    /// The hit lies within one footprint of the ray's own start for every probe that sees it
    /// (a moulding, a crevice, a step beside where the ray leaves): no tracer of these texels
    /// tells the ray meeting it from the ray leaving its surface.
    AtStart,
    /// A probe that sees the hit stores it: the centre ray of the probe's texel holding the
    /// hit's direction ends within one footprint of the hit.
    Stored,
    /// Every probe that sees it stores something else there (a surface thinner than a
    /// texel, an edge across the texel's centre).
    NotStored,
}

/// [`Held`] per ray of `hits` (the rays' true hits; `None`: no true hit, or none that a probe
/// sees). The share of [`Held::Stored`] among seen hits is the within-one-footprint ceiling
/// of any tracer of these texels (passed only by chance).
fn stored_hits(scene: &Scene, bake: &Bake, hits: &[Option<probe_scene::Hit>]) -> Vec<Option<Held>> {
    hits.par_iter()
        .map(|hit| {
            let hit = hit.as_ref()?;
            let views: Vec<(ProbeView, f32)> = (0..bake.positions.len())
                .map(|k| probe_view(scene, bake, k, hit))
                .collect();
            let nearest_footprint = views
                .iter()
                .filter(|(v, _)| *v != ProbeView::Hidden)
                .map(|&(_, f)| f)
                .reduce(f32::min)?;
            Some(if hit.t <= nearest_footprint {
                Held::AtStart
            } else if views.iter().any(|(v, _)| *v == ProbeView::Stores) {
                Held::Stored
            } else {
                Held::NotStored
            })
        })
        .collect()
}

/// How probe `k` holds a surface point.
#[derive(Clone, Copy, Debug, PartialEq)]
enum ProbeView {
    /// Hidden from the probe, or seen at a grazing angle (cosine 0.1 or less).
    Hidden,
    /// Seen, but the centre ray of the texel holding its direction ends more than one
    /// footprint from it.
    SeesOnly,
    /// Seen, and that centre ray ends within one footprint of it.
    Stores,
}

/// How probe `k` holds `hit`, and its footprint there (infinite where hidden).
fn probe_view(scene: &Scene, bake: &Bake, k: usize, hit: &probe_scene::Hit) -> (ProbeView, f32) {
    let layout = OctaLayout::new(bake.resolution).unwrap();
    let p = bake.positions[k];
    let v = hit.position - p;
    let d = v.length();
    if d <= 1e-4
        || hit.geometric_normal.dot(v / d).abs() <= 0.1
        || scene.occluded(&Ray::new(p, v), d * (1.0 - 1e-4) - 1e-4)
    {
        return (ProbeView::Hidden, f32::INFINITY);
    }
    let [ix, iy] = layout.texel_containing(v / d);
    let stored = bake.distance[k * layout.padded_len() + layout.interior_index(ix, iy)];
    let point = p + layout.texel_direction(ix, iy) * stored;
    let f = footprint(bake.resolution, p, hit.position, hit.geometric_normal);
    if (point - hit.position).length() <= f {
        (ProbeView::Stores, f)
    } else {
        (ProbeView::SeesOnly, f)
    }
}

/// Prints (stderr) the ceiling of [`stored_hits`] and where the tracer's failures on seen
/// hits sit: of the seen hits not answered within one footprint, those the bake stores
/// (the tracer's to find) and those it does not (the resolution's), and the stored ones split
/// by the answer (a hit before the true one, behind it, UNKNOWN, a miss) and by how the
/// answering probe holds the true hit ([`ProbeView`]).
fn failure_classes(
    scene: &Scene,
    bake: &Bake,
    hits: &[Option<probe_scene::Hit>],
    results: &[RayResult],
    stored: &[Option<Held>],
    label: &str,
) {
    let seen = stored.iter().flatten().count();
    let count = |held: Held| stored.iter().flatten().filter(|&&s| s == held).count();
    let (mut unstored, mut at_start) = (0, 0);
    // [early, late, unknown, miss] × [hidden, sees only, stores]
    let mut classes = [[0usize; 3]; 4];
    let mut unstarted = 0;
    for ((hit, r), s) in hits.iter().zip(results).zip(stored) {
        let (Some(s), Some(h)) = (*s, hit) else {
            continue;
        };
        if r.status == RayStatus::Hit && r.probe.is_some_and(|p| misses_by(bake, r, p, h) <= 1.0) {
            continue;
        }
        match s {
            Held::AtStart => {
                at_start += 1;
                continue;
            }
            Held::NotStored => {
                unstored += 1;
                continue;
            }
            Held::Stored => {}
        }
        let answer = match r.status {
            RayStatus::Hit if r.t < h.t => 0,
            RayStatus::Hit => 1,
            RayStatus::Unknown => 2,
            RayStatus::Miss => 3,
        };
        // (Every ray here has a probe: only a field without probes leaves it `None`.)
        let view = match r.probe.map(|p| probe_view(scene, bake, p as usize, h).0) {
            Some(ProbeView::Hidden) | None => 0,
            Some(ProbeView::SeesOnly) => 1,
            Some(ProbeView::Stores) => 2,
        };
        classes[answer][view] += 1;
        unstarted += usize::from(r.status == RayStatus::Unknown && r.probes_tried == 0);
    }
    let pct = |x: usize| 100.0 * x as f64 / seen.max(1) as f64;
    let row = |c: [usize; 3]| {
        format!(
            "{:.2} % (answering probe: hidden {:.2} / sees only {:.2} / stores {:.2})",
            pct(c.iter().sum()),
            pct(c[0]),
            pct(c[1]),
            pct(c[2]),
        )
    };
    eprintln!(
        "  ({label}: ceiling {:.1} % of seen hits stored by a probe that sees them, {:.2} % within a footprint of the ray's start; seen hits not within one footprint: at the start {:.2} %, not stored {:.2} %, stored: hit before the true one {}, behind it {}, UNKNOWN {} ({:.2} % tried no probe), miss {:.2} %)",
        pct(count(Held::Stored)),
        pct(count(Held::AtStart)),
        pct(at_start),
        pct(unstored),
        row(classes[0]),
        row(classes[1]),
        row(classes[2]),
        pct(unstarted),
        pct(classes[3].iter().sum()),
    );
}

/// The row of the tracer's defaults (the one the failure classes are printed for).
const DEFAULT_VARIANT: &str = "16 probes, no distance ranges (probe-eval's default)";

#[allow(clippy::too_many_arguments)]
fn rows(
    scene: &Scene,
    label: &str,
    positions: &[Vec3],
    grid: Option<ProbeGrid>,
    resolution: u32,
    sky: f32,
    rays: &[Ray],
    selectors: &[&str],
) {
    let shade = albedo_shade(scene);
    let t = Instant::now();
    let bake = mini_capture(scene, positions, resolution, sky, &shade);
    let bake_time = t.elapsed();
    let trace_rays = to_trace_rays(rays);
    // The baseline a user weighs the probes against: the exact trace of the same rays.
    let t = Instant::now();
    let hits = scene.closest_hits(rays, f32::INFINITY);
    let bvh = t.elapsed();
    let queries = hit_queries(rays, &hits);
    let stored = stored_hits(scene, &bake, &hits);
    let ms = |d: Duration| d.as_secs_f64() * 1e3;
    let pct = |x: usize, of: usize| 100.0 * x as f64 / of.max(1) as f64;
    for &name in selectors {
        let (tets, neighbours, nearest, svo);
        let selection = match name {
            "grid" => ProbeSelection::Grid(grid.expect("a grid")),
            "svo" => {
                svo = SparseVoxelOctree::build(
                    scene,
                    positions,
                    &SvoOptions {
                        max_depth: 7,
                        ..SvoOptions::default()
                    },
                )
                .unwrap();
                ProbeSelection::SparseVoxelOctree(&svo)
            }
            _ => {
                tets = Tetrahedralization::build(positions).unwrap();
                neighbours = VoronoiNeighbours::bake(&tets, 16).unwrap();
                nearest = NearestProbe::new(positions);
                ProbeSelection::Voronoi {
                    nearest: &nearest,
                    neighbours: &neighbours,
                }
            }
        };
        let mut tracer = CpuTracer::new();
        let t = Instant::now();
        let field = tracer
            .upload(&bake.field(), &selection, &FieldOptions::default())
            .unwrap();
        let upload = t.elapsed();
        let mut without_ranges = bake.field();
        without_ranges.distance_range = None;
        let field_without_ranges = tracer
            .upload(&without_ranges, &selection, &FieldOptions::default())
            .unwrap();
        let own_only = TraceOptions {
            nearest_candidates: 0,
            max_probes: 8,
            ..TraceOptions::default()
        };
        let cap = |max_probes| TraceOptions {
            max_probes,
            ..TraceOptions::default()
        };
        for (variant, field, options) in [
            (
                "16 probes, distance ranges",
                &field,
                TraceOptions::default(),
            ),
            ("8 probes, distance ranges", &field, cap(8)),
            ("32 probes, distance ranges", &field, cap(32)),
            (
                "selection's own, 8 probes, distance ranges",
                &field,
                own_only,
            ),
            (
                DEFAULT_VARIANT,
                &field_without_ranges,
                TraceOptions::default(),
            ),
            (
                "the same without agreement (the default before 2026-12-07)",
                &field_without_ranges,
                TraceOptions {
                    agreement: false,
                    ..TraceOptions::default()
                },
            ),
        ] {
            let hiz = tracer.trace(field, &trace_rays, &options).unwrap();
            let two = tracer
                .trace(
                    field,
                    &trace_rays,
                    &TraceOptions {
                        method: TraceMethod::TwoLevel,
                        ..options
                    },
                )
                .unwrap();
            let a = accuracy(scene, &bake, rays, &hiz.results, &shade);
            let (early, late, other) = wrong_split(&bake, &hits, &hiz.results);
            let s_hiz = TraceSummary::of(&hiz.results);
            let s_two = TraceSummary::of(&two.results);
            println!(
                "| {label} | {} | {resolution}² | {name} | {variant} | {} | {:.1} % | {:.1} % | {:.1} % | {:.2} % ({:.2} / {:.2} / {:.2}) | {:.2} % | {:.5} | {:.1} | {:.1} | {:.2} | {:.1} | {:.1} | {:.1} | {:.2} |",
                positions.len(),
                a.rays,
                pct(a.seen, a.true_hits),
                100.0 * a.seen_rate(),
                pct(a.seen_correct_2, a.seen),
                pct(a.wrong_answers, a.rays),
                pct(early, a.rays),
                pct(late, a.rays),
                pct(other, a.rays),
                pct(a.unknown, a.rays),
                a.radiance_mse,
                s_hiz.fetches_per_ray,
                s_two.fetches_per_ray,
                s_hiz.probes_per_ray,
                ms(hiz.timing.wall),
                ms(two.timing.wall),
                ms(bvh),
                hiz.timing.wall.as_secs_f64() / bvh.as_secs_f64(),
            );
            if variant == DEFAULT_VARIANT {
                failure_classes(
                    scene,
                    &bake,
                    &hits,
                    &hiz.results,
                    &stored,
                    &format!("{label}, {name}, {resolution}²"),
                );
            }
        }
        // The hybrid: exact hits, radiance from the probes that see them.
        let t = Instant::now();
        let hits_again = scene.closest_hits(rays, f32::INFINITY);
        let looked = tracer
            .look_up(&field, &queries, &TraceOptions::default())
            .unwrap();
        let hybrid = t.elapsed();
        assert_eq!(hits_again.len(), hits.len());
        let a = accuracy(scene, &bake, rays, &looked.results, &shade);
        let s = TraceSummary::of(&looked.results);
        println!(
            "| {label} | {} | {resolution}² | {name} | hybrid (BVH + look-up) | {} | {:.1} % | {:.1} % (radiance from a probe that sees the hit) | | 0 | {:.2} % | {:.5} | {:.1} (look-up) | | {:.2} | {:.1} (BVH {:.1} + look-up {:.1}) | | {:.1} | {:.2} |",
            positions.len(),
            a.rays,
            pct(a.seen, a.true_hits),
            pct(s.hits, a.true_hits),
            pct(a.unknown, a.rays),
            a.radiance_mse,
            s.fetches_per_ray,
            s.probes_per_ray,
            ms(hybrid),
            ms(hybrid) - ms(looked.timing.wall),
            ms(looked.timing.wall),
            ms(bvh),
            hybrid.as_secs_f64() / bvh.as_secs_f64(),
        );
        eprintln!(
            "  ({label}, {name}: hybrid radiance MSE {:.5}, of which UNKNOWN look-ups {:.5} ({:.1} %))",
            a.radiance_mse,
            a.unknown_mse,
            100.0 * a.unknown_mse / a.radiance_mse.max(f64::MIN_POSITIVE)
        );
        eprintln!("  ({label}, {name}: mini bake {bake_time:?}, upload {upload:?} on the CPU)");
    }
}

/// The real scenes' probe resolution: 256, or `ACCURACY_RESOLUTION` (to see how the ceiling
/// of `stored_hits` moves with it).
fn real_scene_resolution() -> u32 {
    std::env::var("ACCURACY_RESOLUTION")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(256)
}

/// Mirror reflections of the first hits of a `w×h` image from `camera`.
fn rays_from(scene: &Scene, camera: &Camera, w: u32, h: u32) -> Vec<Ray> {
    let mut primary = Vec::new();
    for y in 0..h {
        for x in 0..w {
            primary.push(camera.ray(x, y, w, h, Vec2::ZERO));
        }
    }
    reflection_rays(scene, &primary)
}

/// A grid of `counts` probes at the centres of the cells of `[lo, hi]` divided `counts` ways.
fn cell_centred(lo: Vec3, hi: Vec3, counts: [u32; 3]) -> ProbeGrid {
    let cells = Vec3::new(counts[0] as f32, counts[1] as f32, counts[2] as f32);
    let spacing = (hi - lo) / cells;
    ProbeGrid::new(lo + spacing * 0.5, spacing, counts).unwrap()
}

fn probe_file(path: Option<&String>) -> Option<Vec<Vec3>> {
    path.map(|p| {
        probe_place::ProbeSet::load(p)
            .unwrap_or_else(|e| panic!("{e}"))
            .positions
    })
}

fn cornell(file: Option<&String>) {
    let scene = Scene::open("builtin:cornell").unwrap();
    let rays = rays_from(&scene, &scene.default_camera(), 128, 96);
    if let Some(positions) = probe_file(file) {
        rows(
            &scene,
            "cornell",
            &positions,
            None,
            real_scene_resolution(),
            50.0,
            &rays,
            &["svo", "voronoi"],
        );
        return;
    }
    for (k, resolutions) in [(3u32, &[128u32, 256][..]), (4, &[256][..])] {
        let grid = ProbeGrid::new(
            Vec3::splat(0.06),
            Vec3::new(0.43, 0.43, 0.44) / (k - 1) as f32,
            [k, k, k],
        )
        .unwrap();
        for &resolution in resolutions {
            rows(
                &scene,
                "cornell",
                &grid.positions(),
                Some(grid),
                resolution,
                50.0,
                &rays,
                &["grid"],
            );
        }
    }
}

fn sponza(region_only: bool, file: Option<&String>) {
    let t = Instant::now();
    let scene = Scene::load(probe_testdata::scene_path(probe_testdata::SPONZA)).unwrap();
    eprintln!("  (Sponza loaded in {:?})", t.elapsed());
    let camera = scene.camera("CameraMain").unwrap().clone();
    let rays = rays_from(&scene, &camera, 160, 90);
    if let Some(positions) = probe_file(file) {
        rows(
            &scene,
            "sponza",
            &positions,
            None,
            real_scene_resolution(),
            1000.0,
            &rays,
            &["svo", "voronoi"],
        );
        return;
    }
    if !region_only {
        // 64 probes (seed 000's Sponza count), 8 × 2 × 4 over the atrium and galleries: the
        // grid of the earlier measurements.
        let grid = ProbeGrid::new(
            Vec3::new(-21.0, 6.0, -6.0),
            Vec3::new(6.0, 8.0, 4.0),
            [8, 2, 4],
        )
        .unwrap();
        rows(
            &scene,
            "sponza",
            &grid.positions(),
            Some(grid),
            real_scene_resolution(),
            1000.0,
            &rays,
            &["grid"],
        );
    }
    // 64 probes at the cell centres of the atrium region of eval.toml (the atrium and both
    // gallery floors): -20,4,-9 to 17.3,15,7.6.
    let grid = cell_centred(
        Vec3::new(-20.0, 4.0, -9.0),
        Vec3::new(17.3, 15.0, 7.6),
        [8, 2, 4],
    );
    rows(
        &scene,
        "sponza, region grid",
        &grid.positions(),
        Some(grid),
        real_scene_resolution(),
        1000.0,
        &rays,
        &["grid", "voronoi"],
    );
}

/// An interior: its first camera, or (a file without cameras) one at the room's centre
/// looking along −z; probes at the cell centres of its bounds.
fn interior(label: &str, path: &str, counts: [u32; 3]) {
    let scene = Scene::load(probe_testdata::scene_path(path)).unwrap();
    let bounds = scene.bounds();
    let camera = match scene.cameras().first() {
        Some(camera) => camera.clone(),
        None => {
            let centre = (bounds.min + bounds.max) * 0.5;
            Camera::look_at(centre, centre - Vec3::Z, Vec3::Y, 70f32.to_radians())
        }
    };
    let rays = rays_from(&scene, &camera, 160, 90);
    let grid = cell_centred(bounds.min, bounds.max, counts);
    let sky = 100.0 * bounds.size().length();
    rows(
        &scene,
        label,
        &grid.positions(),
        Some(grid),
        real_scene_resolution(),
        sky,
        &rays,
        &["grid", "voronoi"],
    );
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let which = args.get(1).map_or("all", |s| s.as_str());
    let file = args.get(2);
    header();
    if which == "cornell" || which == "all" {
        cornell(file);
    }
    if which == "sponza" || which == "all" {
        sponza(false, file);
    }
    if which == "sponza-region" {
        sponza(true, file);
    }
    if which == "breakfast" || which == "all" {
        interior("breakfast room", probe_testdata::BREAKFAST_ROOM, [4, 2, 4]);
    }
    if which == "godot" || which == "all" {
        interior("godot room", probe_testdata::GODOT_ROOM, [4, 2, 4]);
    }
}
