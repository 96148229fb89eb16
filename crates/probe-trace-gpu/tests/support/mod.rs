//! Test support: bakes (probe-capture's real baker, and a "mini capture" with analytic-style
//! maps: one BVH ray per texel centre, radiance = a closure), probe placements (probe-place),
//! ray sets, BVH references and accuracy figures.
#![allow(dead_code)]

use glam::{Vec2, Vec3};
use probe_octa::{OctaLayout, OctaMap};
use probe_scene::{Hit, Ray, Scene};
use probe_trace_gpu::{
    CpuField, CpuTracer, FieldOptions, GpuContext, GpuTracer, IrradianceField, LightField,
    ProbeSelection, RayResult, RayStatus, SurfaceQuery, TraceRay, Tracer,
};
use rayon::prelude::*;

/// Radiance of misses (the sky) in the mini capture and the references.
pub const SKY: Vec3 = Vec3::new(0.3, 0.5, 0.9);

/// Probes baked by the mini capture, in the tracer's input layout.
pub struct Bake {
    pub resolution: u32,
    pub positions: Vec<Vec3>,
    pub distance: Vec<f32>,
    pub normals: Vec<Vec3>,
    pub radiance: Vec<Vec3>,
    /// Per texel the nearest and farthest distance over 3×3 rays spread across it (empty:
    /// not measured).
    pub distance_range: Vec<Vec2>,
    pub sky_distance: f32,
    /// The scene's bounds (`LightField::geometry_bounds`; `None` for [`Bake::flat`]).
    pub bounds: Option<[Vec3; 2]>,
}

impl Bake {
    /// `resolution`² maps at `positions` in which every texel sees a surface 1 m away facing
    /// +Y, in white, sky at 100 m: for tests of uploads and their errors, where only the sizes
    /// and values of the maps matter.
    pub fn flat(resolution: u32, positions: Vec<Vec3>) -> Bake {
        let len = (resolution as usize + 2).pow(2) * positions.len();
        Bake {
            resolution,
            positions,
            distance: vec![1.0; len],
            normals: vec![Vec3::Y; len],
            radiance: vec![Vec3::ONE; len],
            distance_range: Vec::new(),
            sky_distance: 100.0,
            bounds: None,
        }
    }

    pub fn field(&self) -> LightField<'_> {
        LightField {
            resolution: self.resolution,
            positions: &self.positions,
            radial_distance: &self.distance,
            normals: &self.normals,
            radiance: &self.radiance,
            distance_range: (!self.distance_range.is_empty()).then_some(&self.distance_range[..]),
            sky_distance: self.sky_distance,
            geometry_bounds: self.bounds,
        }
    }

    /// The padded maps of one probe.
    pub fn distance_map(&self, probe: usize) -> OctaMap<f32> {
        self.probe_map(&self.distance, probe)
    }

    pub fn normal_map(&self, probe: usize) -> OctaMap<Vec3> {
        self.probe_map(&self.normals, probe)
    }

    pub fn radiance_map(&self, probe: usize) -> OctaMap<Vec3> {
        self.probe_map(&self.radiance, probe)
    }

    fn probe_map<T: probe_octa::Texel>(&self, texels: &[T], probe: usize) -> OctaMap<T> {
        let len = OctaLayout::new(self.resolution).unwrap().padded_len();
        OctaMap::from_padded(
            self.resolution,
            texels[probe * len..(probe + 1) * len].to_vec(),
        )
        .unwrap()
    }
}

/// The surface normal a probe stores for a hit seen along `direction`: the front face, or for
/// double-sided materials the side facing the probe.
pub fn stored_normal(scene: &Scene, hit: &Hit, direction: Vec3) -> Vec3 {
    let n = hit.geometric_normal;
    if scene.materials()[hit.material as usize].double_sided && n.dot(direction) > 0.0 {
        -n
    } else {
        n
    }
}

/// Bakes `N×N` probes at `positions`: one BVH ray per texel centre. Misses store
/// `sky_distance` and [`SKY`].
pub fn mini_capture(
    scene: &Scene,
    positions: &[Vec3],
    resolution: u32,
    sky_distance: f32,
    shade: &(dyn Fn(&Hit, Vec3) -> Vec3 + Sync),
) -> Bake {
    let layout = OctaLayout::new(resolution).unwrap();
    let len = layout.padded_len();
    let step = 2.0 / resolution as f32;
    /// One probe's padded maps: distance, normals, radiance, distance range.
    type Maps = (Vec<f32>, Vec<Vec3>, Vec<Vec3>, Vec<Vec2>);
    let per_probe: Vec<Maps> = positions
        .par_iter()
        .map(|&p| {
            let mut distance = vec![sky_distance; len];
            let mut normals = vec![Vec3::ZERO; len];
            let mut radiance = vec![SKY; len];
            let mut range = vec![Vec2::splat(sky_distance); len];
            for iy in 0..resolution {
                for ix in 0..resolution {
                    let d = layout.texel_direction(ix, iy);
                    let i = layout.interior_index(ix, iy);
                    if let Some(hit) = scene.closest_hit(&Ray::new(p, d), f32::INFINITY) {
                        distance[i] = hit.t.min(sky_distance);
                        normals[i] = stored_normal(scene, &hit, d);
                        radiance[i] = shade(&hit, d);
                    }
                    let (mut lo, mut hi) = (distance[i], distance[i]);
                    for k in 0..9 {
                        let (a, b) = ((k % 3) as f32, (k / 3) as f32);
                        let q = Vec2::new(
                            -1.0 + (ix as f32 + (2.0 * a + 1.0) / 6.0) * step,
                            -1.0 + (iy as f32 + (2.0 * b + 1.0) / 6.0) * step,
                        );
                        let dir = probe_octa::decode(q);
                        let t = scene
                            .closest_hit(&Ray::new(p, dir), f32::INFINITY)
                            .map_or(sky_distance, |h| h.t.min(sky_distance));
                        lo = lo.min(t);
                        hi = hi.max(t);
                    }
                    range[i] = Vec2::new(lo, hi);
                }
            }
            layout.pad(&mut distance).unwrap();
            layout.pad(&mut normals).unwrap();
            layout.pad(&mut radiance).unwrap();
            layout.pad(&mut range).unwrap();
            (distance, normals, radiance, range)
        })
        .collect();
    let mut bake = Bake {
        resolution,
        positions: positions.to_vec(),
        distance: Vec::with_capacity(len * positions.len()),
        normals: Vec::with_capacity(len * positions.len()),
        radiance: Vec::with_capacity(len * positions.len()),
        distance_range: Vec::with_capacity(len * positions.len()),
        sky_distance,
        bounds: Some([scene.bounds().min, scene.bounds().max]),
    };
    for (d, n, r, range) in per_probe {
        bake.distance.extend(d);
        bake.normals.extend(n);
        bake.radiance.extend(r);
        bake.distance_range.extend(range);
    }
    bake
}

/// Sky distance used with probe-capture bakes: its misses store `MISS_DISTANCE` (1e9 m), and
/// anything at or beyond this counts as sky.
pub fn capture_sky_distance(scene: &Scene) -> f32 {
    100.0 * scene.bounds().size().length().max(1.0)
}

/// The probe-capture settings of the bakes here: `resolution`², one radiance sample per
/// texel, direct light only (the tracer's figures are about where rays end; the references
/// shade with the same [`capture_shader`]).
pub fn capture_settings(resolution: u32) -> probe_capture::BakeSettings {
    probe_capture::BakeSettings {
        resolution,
        sampling: probe_capture::Sampling::fixed(1),
        bounces: 0,
        pyramid_levels: 1,
        ..probe_capture::BakeSettings::default()
    }
}

/// The shader of [`capture_settings`] bakes (direct light, the scene's default environment).
pub fn capture_shader(scene: &Scene) -> probe_capture::Shader<'_> {
    probe_capture::Shader::new(scene, probe_capture::Environment::for_scene(scene), 0)
        .expect("the default environment is valid")
}

/// Bakes `positions` with probe-capture ([`capture_settings`]) into the tracer's input
/// layout. With `PROBE_BAKE_CACHE=DIR` set, bakes are saved under `DIR` (keyed by scene,
/// positions and resolution) and loaded back on later runs.
pub fn capture_bake(scene: &Scene, positions: &[Vec3], resolution: u32) -> Bake {
    use std::hash::{Hash, Hasher};
    let settings = capture_settings(resolution);
    let cache = std::env::var_os("PROBE_BAKE_CACHE").map(|dir| {
        let mut h = std::collections::hash_map::DefaultHasher::new();
        scene.content_hash().hash(&mut h);
        resolution.hash(&mut h);
        for p in positions {
            p.to_array().map(f32::to_bits).hash(&mut h);
        }
        std::path::PathBuf::from(dir).join(format!(
            "{}-{resolution}-{:016x}",
            scene.name(),
            h.finish()
        ))
    });
    let loaded = cache
        .as_ref()
        .and_then(|dir| probe_capture::ProbeBake::load(dir, Some(scene)).ok())
        .filter(|b| b.positions() == positions && b.settings() == &settings);
    let baked = match loaded {
        Some(b) => b,
        None => {
            let b = probe_capture::bake(scene, positions, &settings, &probe_capture::no_progress)
                .expect("valid bake settings");
            if let Some(dir) = &cache {
                let _ = b.save(dir);
            }
            b
        }
    };
    Bake {
        resolution,
        positions: positions.to_vec(),
        distance: baked.distances().to_vec(),
        normals: baked.normals().to_vec(),
        radiance: baked.radiance().to_vec(),
        distance_range: Vec::new(),
        sky_distance: capture_sky_distance(scene),
        bounds: Some([scene.bounds().min, scene.bounds().max]),
    }
}

/// Probe-place's candidates for `scene`: `"sdf"` (skeleton of the distance field) or
/// `"medial"` (shrinking-ball medial axis), with the crate's default parameters.
pub fn placement(scene: &Scene, method: &str) -> Vec<Vec3> {
    match method {
        "sdf" => {
            probe_place::candidates::sdf_candidates(
                scene,
                &probe_place::candidates::SdfParams::for_scene(scene),
            )
            .expect("SDF candidates")
            .probes
            .positions
        }
        "medial" => {
            probe_place::candidates::medial_candidates(
                scene,
                &probe_place::candidates::MedialParams::for_scene(scene),
            )
            .expect("medial candidates")
            .probes
            .positions
        }
        other => panic!("unknown placement {other}"),
    }
}

/// Mirror reflection rays (about the shading normal) of a `width × height` G-buffer from
/// `camera`, as probe-capture's evaluation makes them.
pub fn evaluation_rays(
    scene: &Scene,
    camera: &probe_scene::Camera,
    width: u32,
    height: u32,
) -> Vec<Ray> {
    let gbuffer = probe_capture::render_gbuffer(scene, camera, width, height).expect("size");
    probe_capture::reflection_rays(&gbuffer, probe_capture::Reflection::Mirror, 1, 0)
        .expect("one ray per pixel")
        .iter()
        .map(|r| r.ray())
        .collect()
}

/// Base colour plus emission: tells surfaces apart, so radiance errors mean wrong surfaces.
pub fn albedo_shade(scene: &Scene) -> impl Fn(&Hit, Vec3) -> Vec3 + Sync + '_ {
    move |hit: &Hit, _| {
        let m = &scene.materials()[hit.material as usize];
        m.base_color + m.emissive
    }
}

/// Emission plus one bounce of direct light from the scene's emissive triangles (a fixed
/// 3×3 stratified set of points per emitter triangle), for irradiance tests.
pub fn direct_light_shade(scene: &Scene) -> impl Fn(&Hit, Vec3) -> Vec3 + Sync + '_ {
    let mut emitters = Vec::new();
    for t in scene.triangles() {
        let m = &scene.materials()[t.material as usize];
        if m.emissive != Vec3::ZERO {
            let n = t.geometric_normal();
            let area = t.area();
            for i in 0..3 {
                for j in 0..3 {
                    let (mut u, mut v) = ((i as f32 + 0.5) / 3.0, (j as f32 + 0.5) / 3.0);
                    if u + v > 1.0 {
                        (u, v) = (1.0 - u, 1.0 - v);
                    }
                    emitters.push((t.point(Vec2::new(u, v)), n, m.emissive, area / 9.0));
                }
            }
        }
    }
    move |hit: &Hit, direction: Vec3| {
        let m = &scene.materials()[hit.material as usize];
        let mut n = hit.geometric_normal;
        if n.dot(direction) > 0.0 {
            n = -n;
        }
        let mut e = Vec3::ZERO;
        for &(q, nq, le, area) in &emitters {
            let v = q - hit.position;
            let d2 = v.length_squared();
            let w = v / d2.sqrt();
            let cos_p = n.dot(w);
            let cos_q = nq.dot(-w).abs();
            if cos_p <= 0.0 || d2 <= 1e-8 {
                continue;
            }
            let ray = Ray::from_surface(hit.position, n, w);
            if !scene.occluded(&ray, d2.sqrt() * (1.0 - 1e-3)) {
                e += le * (cos_p * cos_q * area / d2);
            }
        }
        m.emissive + m.base_color * e / std::f32::consts::PI
    }
}

/// Irradiance and distance-moment maps of a bake (DDGI sizes: 6² and 14²), and its surfels
/// (8² per probe).
pub struct LowRes {
    pub positions: Vec<Vec3>,
    pub irradiance: Vec<Vec3>,
    pub moments: Vec<Vec2>,
    pub surfels: Vec<probe_octa::Surfel>,
}

impl LowRes {
    pub fn of(bake: &Bake) -> LowRes {
        let parts: Vec<(Vec<Vec3>, Vec<Vec2>, Vec<probe_octa::Surfel>)> = (0..bake.positions.len())
            .into_par_iter()
            .map(|p| {
                let radiance = bake.radiance_map(p);
                let distance = bake.distance_map(p);
                let e = probe_octa::irradiance_map(&radiance, 6).unwrap();
                let m =
                    probe_octa::distance_moments(&distance, 14, probe_octa::default_sharpness(14))
                        .unwrap();
                let surfels = probe_octa::surfel_map(
                    bake.positions[p],
                    &distance,
                    &bake.normal_map(p),
                    &radiance,
                    bake.sky_distance,
                    8.min(bake.resolution),
                )
                .unwrap();
                (e.texels().to_vec(), m.texels().to_vec(), surfels)
            })
            .collect();
        let mut out = LowRes {
            positions: bake.positions.clone(),
            irradiance: Vec::new(),
            moments: Vec::new(),
            surfels: Vec::new(),
        };
        for (e, m, s) in parts {
            out.irradiance.extend(e);
            out.moments.extend(m);
            out.surfels.extend(s);
        }
        out
    }

    pub fn field(&self) -> IrradianceField<'_> {
        IrradianceField {
            positions: &self.positions,
            irradiance_resolution: 6,
            irradiance: &self.irradiance,
            moments_resolution: 14,
            moments: &self.moments,
            surfels: &self.surfels,
            inside_geometry: &[],
        }
    }
}

/// Camera rays of a `width × height` image from the scene's default camera.
pub fn camera_rays(scene: &Scene, width: u32, height: u32) -> Vec<Ray> {
    let camera = scene.default_camera();
    let mut rays = Vec::with_capacity((width * height) as usize);
    for y in 0..height {
        for x in 0..width {
            rays.push(camera.ray(x, y, width, height, Vec2::ZERO));
        }
    }
    rays
}

/// Mirror reflection rays from the first hits of `primary` (rays that hit nothing are dropped),
/// with origins moved off the surface.
pub fn reflection_rays(scene: &Scene, primary: &[Ray]) -> Vec<Ray> {
    primary
        .par_iter()
        .filter_map(|ray| {
            let hit = scene.closest_hit(ray, f32::INFINITY)?;
            let mut n = hit.geometric_normal;
            if n.dot(ray.direction) > 0.0 {
                n = -n;
            }
            let r = ray.direction - 2.0 * ray.direction.dot(n) * n;
            Some(Ray::from_surface(hit.position, n, r))
        })
        .collect()
}

/// The CPU twin with `bake` uploaded (default options), its probes chosen by `grid`'s cage.
pub fn cpu_grid_field(bake: &Bake, grid: probe_index::ProbeGrid) -> (CpuTracer, CpuField) {
    let tracer = CpuTracer::new();
    let field = tracer
        .upload(
            &bake.field(),
            &ProbeSelection::Grid(grid),
            &FieldOptions::default(),
        )
        .expect("a valid bake and grid");
    (tracer, field)
}

/// The hybrid tracer's queries for `rays` and their BVH hits: each hit's point and geometric
/// normal, or an escape along the ray.
#[allow(dead_code, reason = "not every test and example looks points up")]
pub fn hit_queries(rays: &[Ray], hits: &[Option<Hit>]) -> Vec<SurfaceQuery> {
    rays.iter()
        .zip(hits)
        .map(|(ray, hit)| match hit {
            Some(hit) => SurfaceQuery::surface(hit.position, hit.geometric_normal, ray.direction),
            None => SurfaceQuery::escaped(ray.origin, ray.direction),
        })
        .collect()
}

pub fn to_trace_rays(rays: &[Ray]) -> Vec<TraceRay> {
    rays.iter()
        .map(|r| TraceRay::new(r.origin, r.direction))
        .collect()
}

/// Accuracy of traced results against exact BVH hits of the same rays (BRIEF, "How quality is
/// measured").
#[derive(Debug, Default, Clone)]
pub struct Accuracy {
    pub rays: usize,
    /// Rays with a true hit.
    pub true_hits: usize,
    /// Of those, hits some probe sees (unoccluded, at more than 0.1 cosine).
    pub seen: usize,
    /// Of those, answered Hit within one texel footprint of the true hit / within two.
    pub seen_correct: usize,
    pub seen_correct_2: usize,
    /// Rays with a true hit answered Hit within one footprint / within two.
    pub hits_correct: usize,
    pub hits_correct_2: usize,
    /// Rays that escape the scene, and those answered Miss.
    pub escapes: usize,
    pub escapes_correct: usize,
    pub hits: usize,
    pub misses: usize,
    pub unknown: usize,
    /// Answered Hit or Miss but wrong (not within two footprints, or the wrong status).
    pub wrong_answers: usize,
    /// Mean squared radiance error per channel over all rays.
    pub radiance_mse: f64,
    /// The part of `radiance_mse` from rays answered UNKNOWN (their squared errors over all
    /// rays).
    pub unknown_mse: f64,
}

impl Accuracy {
    /// The goal's figure: share of rays whose true hit some probe sees answered within one
    /// texel footprint.
    pub fn seen_rate(&self) -> f64 {
        self.seen_correct as f64 / self.seen.max(1) as f64
    }

    /// Share of all rays answered right (hit within one footprint, or miss for escapes).
    pub fn correct_rate(&self) -> f64 {
        (self.hits_correct + self.escapes_correct) as f64 / self.rays.max(1) as f64
    }
}

/// The angular diagonal of the interior texel holding `direction` (exact, from its corners).
pub fn texel_diagonal(resolution: u32, direction: Vec3) -> f32 {
    let layout = OctaLayout::new(resolution).unwrap();
    let [ix, iy] = layout.texel_containing(direction);
    let s = 2.0 / resolution as f32;
    let (u, v) = (-1.0 + ix as f32 * s, -1.0 + iy as f32 * s);
    let corner = |a: f32, b: f32| probe_octa::decode(Vec2::new(a, b));
    let d1 = corner(u, v).angle_between(corner(u + s, v + s));
    let d2 = corner(u + s, v).angle_between(corner(u, v + s));
    d1.max(d2)
}

/// One texel footprint of probe `p` at surface point `y` with normal `n`: the texel's angular
/// diagonal times the distance, over the cosine of incidence (at least 0.2).
pub fn footprint(resolution: u32, p: Vec3, y: Vec3, n: Vec3) -> f32 {
    let v = y - p;
    let d = v.length();
    let dir = v / d;
    d * texel_diagonal(resolution, dir) / n.dot(dir).abs().max(0.2)
}

/// Compares results with the BVH truth.
pub fn accuracy(
    scene: &Scene,
    bake: &Bake,
    rays: &[Ray],
    results: &[RayResult],
    shade: &(dyn Fn(&Hit, Vec3) -> Vec3 + Sync),
) -> Accuracy {
    // (true hit, seen, correct, correct within 2, wrong answer, squared error)
    let per_ray: Vec<(bool, bool, bool, bool, bool, f64)> = rays
        .par_iter()
        .zip(results.par_iter())
        .map(|(ray, result)| {
            let truth = scene.closest_hit(ray, f32::INFINITY);
            let (reference, hit, seen, correct, correct_2) = match &truth {
                Some(hit) => {
                    let seen = bake.positions.iter().any(|&p| {
                        let v = hit.position - p;
                        let d = v.length();
                        d > 1e-4
                            && hit.geometric_normal.dot(v / d).abs() > 0.1
                            && !scene.occluded(&Ray::new(p, v), d * (1.0 - 1e-4) - 1e-4)
                    });
                    let (correct, correct_2) = match (result.status, result.probe) {
                        (RayStatus::Hit, Some(p)) => {
                            let f = footprint(
                                bake.resolution,
                                bake.positions[p as usize],
                                hit.position,
                                hit.geometric_normal,
                            );
                            let e = (result.position - hit.position).length();
                            (e <= f, e <= 2.0 * f)
                        }
                        _ => (false, false),
                    };
                    (shade(hit, ray.direction), true, seen, correct, correct_2)
                }
                None => {
                    let ok = result.status == RayStatus::Miss;
                    (SKY, false, false, ok, ok)
                }
            };
            let wrong = result.status != RayStatus::Unknown && !correct_2;
            let e = result.radiance - reference;
            let se = f64::from(e.length_squared()) / 3.0;
            (hit, seen, correct, correct_2, wrong, se)
        })
        .collect();
    let mut a = Accuracy {
        rays: rays.len(),
        ..Accuracy::default()
    };
    let (mut se, mut unknown_se) = (0.0, 0.0);
    for ((hit, seen, correct, correct_2, wrong, e), result) in per_ray.into_iter().zip(results) {
        if hit {
            a.true_hits += 1;
            a.seen += usize::from(seen);
            a.seen_correct += usize::from(seen && correct);
            a.seen_correct_2 += usize::from(seen && correct_2);
            a.hits_correct += usize::from(correct);
            a.hits_correct_2 += usize::from(correct_2);
        } else {
            a.escapes += 1;
            a.escapes_correct += usize::from(correct);
        }
        a.wrong_answers += usize::from(wrong);
        se += e;
        match result.status {
            RayStatus::Hit => a.hits += 1,
            RayStatus::Miss => a.misses += 1,
            RayStatus::Unknown => {
                a.unknown += 1;
                unknown_se += e;
            }
        }
    }
    a.radiance_mse = se / rays.len().max(1) as f64;
    a.unknown_mse = unknown_se / rays.len().max(1) as f64;
    a
}

/// A GPU tracer, or `None` (with a message) when no adapter exists; under
/// `PROBE_REQUIRE_GPU=1` a missing adapter fails the test instead.
pub fn gpu_tracer() -> Option<GpuTracer> {
    match GpuContext::new() {
        Ok(context) => {
            Some(GpuTracer::new(&context).expect("the device builds the tracer's pipelines"))
        }
        Err(error) => {
            if std::env::var("PROBE_REQUIRE_GPU").as_deref() == Ok("1") {
                panic!("PROBE_REQUIRE_GPU=1 but no GPU is usable: {error}");
            }
            eprintln!("skipping GPU test: {error} (set PROBE_REQUIRE_GPU=1 to fail instead)");
            None
        }
    }
}

/// A 2 m square wall in the plane x = 0 facing +x, ending at z = 2 with nothing beyond (its
/// free edge against the sky), eight grid probes 0.8–1.2 m in front of it baked at 64² (texels
/// about 7 cm on the wall), and 2,000 rays aimed at the plane at (0, y, 2 − δ) obliquely
/// towards the edge, δ uniform in ±10 cm (`offsets`): δ > 0 meets the wall, δ < 0 passes
/// beside its edge into the sky.
pub struct WallEdge {
    pub scene: Scene,
    pub grid: probe_index::ProbeGrid,
    pub bake: Bake,
    pub rays: Vec<Ray>,
    pub offsets: Vec<f32>,
}

/// The [`WallEdge`] case.
pub fn wall_edge() -> WallEdge {
    let corner = |y: f32, z: f32| Vec3::new(0.0, y, z);
    let triangle = |positions: [Vec3; 3]| probe_scene::Triangle {
        positions,
        normals: [Vec3::X; 3],
        uvs: [Vec2::ZERO; 3],
        material: 0,
    };
    let triangles = vec![
        triangle([corner(0.0, 0.0), corner(2.0, 0.0), corner(2.0, 2.0)]),
        triangle([corner(0.0, 0.0), corner(2.0, 2.0), corner(0.0, 2.0)]),
    ];
    let materials = vec![probe_scene::Material::diffuse(
        "wall",
        Vec3::new(0.8, 0.3, 0.2),
    )];
    let scene = Scene::from_triangles("edge", triangles, materials, Vec::new(), Vec::new())
        .expect("a valid wall");
    let grid = probe_index::ProbeGrid::new(Vec3::splat(0.8), Vec3::splat(0.4), [2, 2, 2])
        .expect("a valid grid");
    let bake = mini_capture(&scene, &grid.positions(), 64, 50.0, &albedo_shade(&scene));
    let mut lcg = probe_testdata::Lcg(5);
    let (mut rays, mut offsets) = (Vec::new(), Vec::new());
    for _ in 0..2000 {
        let delta = 0.2 * lcg.uniform() - 0.1;
        let target = Vec3::new(0.0, 0.5 + lcg.uniform(), 2.0 - delta);
        let origin = target + Vec3::new(0.5 + 0.3 * lcg.uniform(), 0.0, -0.4);
        rays.push(Ray::new(origin, target - origin));
        offsets.push(delta);
    }
    WallEdge {
        scene,
        grid,
        bake,
        rays,
        offsets,
    }
}

/// A scene, probes baked by the [`mini_capture`] on a grid, and rays to trace through them.
pub struct GridCase {
    pub scene: Scene,
    pub grid: probe_index::ProbeGrid,
    pub bake: Bake,
    pub rays: Vec<Ray>,
}

/// The built-in Cornell box's reflection rays from its default view (`width`×`height`)
/// through a 3×3×3 grid of probes from `first` at `spacing`, baked at `resolution`².
fn cornell_case(first: Vec3, spacing: Vec3, resolution: u32, width: u32, height: u32) -> GridCase {
    let scene = Scene::open("builtin:cornell").expect("a built-in scene");
    let grid = probe_index::ProbeGrid::new(first, spacing, [3, 3, 3]).expect("a valid grid");
    let bake = mini_capture(
        &scene,
        &grid.positions(),
        resolution,
        50.0,
        &albedo_shade(&scene),
    );
    let rays = reflection_rays(&scene, &camera_rays(&scene, width, height));
    GridCase {
        scene,
        grid,
        bake,
        rays,
    }
}

/// The built-in Cornell box's reflection rays from its default view (96×72) through 27
/// probes at 32², with the scene's bounds: many rays leave through the open front.
pub fn cornell_reflections() -> GridCase {
    cornell_case(Vec3::splat(0.07), Vec3::new(0.205, 0.2, 0.21), 32, 96, 72)
}

/// The built-in Cornell box's reflection rays from its default view (128×96) through the
/// accuracy example's 27 probes at 128²: about 30 of its rays end UNKNOWN where two probes
/// refuse the same crossing beside their edges (`TraceOptions::agreement`).
pub fn cornell_agreement() -> GridCase {
    cornell_case(
        Vec3::splat(0.06),
        Vec3::new(0.215, 0.215, 0.22),
        128,
        128,
        96,
    )
}

/// The shared `TwoSidedPlane.glb` (a double-sided sheet 2 m across at y = 0) between 2×2×2
/// probes at ±0.5 m, 32², and 4,000 rays from above and below towards it (as the failure
/// suite's `two-sided-plane`): every ray meets the sheet.
pub fn two_sided_sheet() -> GridCase {
    let scene = Scene::load(probe_testdata::scene_path(probe_testdata::TWO_SIDED_PLANE))
        .expect("the shared scenes");
    let grid =
        probe_index::ProbeGrid::new(Vec3::splat(-0.5), Vec3::ONE, [2, 2, 2]).expect("a valid grid");
    let bake = mini_capture(&scene, &grid.positions(), 32, 100.0, &albedo_shade(&scene));
    let mut lcg = probe_testdata::Lcg(11);
    let rays = (0..4000)
        .map(|i| {
            let side = if i % 2 == 0 { 1.0 } else { -1.0 };
            let origin = Vec3::new(
                1.8 * lcg.uniform() - 0.9,
                side * (0.1 + 0.8 * lcg.uniform()),
                1.8 * lcg.uniform() - 0.9,
            );
            let target = Vec3::new(1.9 * lcg.uniform() - 0.95, 0.0, 1.9 * lcg.uniform() - 0.95);
            Ray::new(origin, target - origin)
        })
        .collect();
    GridCase {
        scene,
        grid,
        bake,
        rays,
    }
}
