//! Diffuse shading from irradiance probes (seed 001 §4.3.6–4.3.7) on the CPU twin: exact
//! interpolation of linear fields, and the leak rooms with and without Chebyshev visibility.

mod support;

use glam::{Vec2, Vec3};
use probe_index::{ProbeGrid, Tetrahedralization};
use probe_scene::{Ray, Scene};
use probe_trace_gpu::{
    CpuTracer, DiffuseOptions, Interpolation, IrradianceField, ShadingPoint, TraceError, Tracer,
};
use support::{LowRes, direct_light_shade, mini_capture};

/// An irradiance field at resolution 6 with moments at 14 (the moments constant in these
/// tests, with visibility off), no surfels and no probe flagged.
fn constant_moments_field<'a>(
    positions: &'a [Vec3],
    irradiance: &'a [Vec3],
    moments: &'a [Vec2],
) -> IrradianceField<'a> {
    IrradianceField {
        positions,
        irradiance_resolution: 6,
        irradiance,
        moments_resolution: 14,
        moments,
        surfels: &[],
        inside_geometry: &[],
    }
}

/// Both interpolations reproduce a field that is linear in the probe position (irradiance maps
/// constant per probe), anywhere inside the probe set.
#[test]
fn interpolation_reproduces_linear_fields() {
    let grid = ProbeGrid::new(
        Vec3::new(-1.0, 0.0, 0.5),
        Vec3::new(0.8, 0.6, 1.1),
        [4, 3, 3],
    )
    .unwrap();
    let positions = grid.positions();
    let f = |p: Vec3| {
        Vec3::new(
            1.0 + 0.3 * p.x,
            2.0 - 0.2 * p.y + 0.1 * p.z,
            0.5 + 0.25 * p.z,
        )
    };
    let per_probe = (6 + 2) * (6 + 2);
    let irradiance: Vec<Vec3> = positions
        .iter()
        .flat_map(|&p| std::iter::repeat_n(f(p), per_probe))
        .collect();
    let moments = vec![Vec2::new(1.0, 1.0); positions.len() * 16 * 16];
    let field = constant_moments_field(&positions, &irradiance, &moments);
    let tets = Tetrahedralization::build(&positions).unwrap();
    let mut tracer = CpuTracer::new();
    let mut state = 3u64;
    let mut next = || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1);
        (state >> 40) as f32 / (1u64 << 24) as f32
    };
    let points: Vec<ShadingPoint> = (0..500)
        .map(|_| {
            let x = Vec3::new(-1.0 + 2.4 * next(), 1.2 * next(), 0.5 + 2.2 * next());
            ShadingPoint::new(x, Vec3::new(next() - 0.5, 0.3, next() - 0.5))
        })
        .collect();
    // The backface term reweights probes by direction, which no longer reproduces linear
    // fields: it is off here.
    let options = DiffuseOptions {
        visibility: false,
        backface: false,
        ..DiffuseOptions::default()
    };
    for interpolation in [Interpolation::Grid(grid), Interpolation::Delaunay(&tets)] {
        let irradiance = tracer.upload_irradiance(&field, &interpolation).unwrap();
        let out = tracer
            .shade_diffuse(&irradiance, &points, &options)
            .unwrap();
        // The grid's floor of 0.001 per axis (DDGI's) moves a point within 0.001 of a lattice
        // plane by up to a thousandth of a probe's share; its weights sum to at most 1.001³.
        let (tolerance, weight_tolerance) = match interpolation {
            Interpolation::Grid(_) => (1e-3, 3.1e-3),
            Interpolation::Delaunay(_) => (1e-4, 1e-4),
        };
        for (p, r) in points.iter().zip(&out.results) {
            let expected = f(Vec3::from(p.position));
            assert!(
                (r.irradiance - expected).length() < tolerance * expected.length(),
                "{:?} at {:?}: {} vs {expected}",
                interpolation,
                p.position,
                r.irradiance
            );
            assert!((r.weight - 1.0).abs() < weight_tolerance, "{}", r.weight);
        }
    }
}

/// A probe flagged as inside geometry is left out of the blend, and on a grid every probe of
/// the cage keeps DDGI's floor of weight: a point whose only weighted probe is the flagged one
/// (outside the lattice, beyond it) is lit by the others instead of reading its black map.
/// Unflagged, the same points read black.
#[test]
fn probes_inside_geometry_are_left_out() {
    let grid = ProbeGrid::new(Vec3::ZERO, Vec3::ONE, [2, 2, 2]).unwrap();
    let positions = grid.positions();
    let per_probe = (6 + 2) * (6 + 2);
    // Probe 0 (the corner at the origin) sees only the inside of a box: black.
    let irradiance: Vec<Vec3> = (0..positions.len())
        .flat_map(|i| std::iter::repeat_n(Vec3::splat(if i == 0 { 0.0 } else { 1.0 }), per_probe))
        .collect();
    let moments = vec![Vec2::new(1.0, 1.0); positions.len() * 16 * 16];
    let mut inside = vec![false; positions.len()];
    inside[0] = true;
    let field = IrradianceField {
        inside_geometry: &inside,
        ..constant_moments_field(&positions, &irradiance, &moments)
    };
    let options = DiffuseOptions {
        visibility: false,
        backface: false,
        ..DiffuseOptions::default()
    };
    // Beyond the flagged corner (clamped trilinear weights put everything on probe 0), and
    // inside the cage.
    // 3×3×3 floor-facing points from `start` along each axis, `step` apart.
    let lattice = |start: f32, step: f32| -> Vec<ShadingPoint> {
        let f = |k: u32| start + step * k as f32;
        (0..27)
            .map(|i| ShadingPoint::new(Vec3::new(f(i % 3), f((i / 3) % 3), f(i / 9)), Vec3::Y))
            .collect()
    };
    let (beyond, within) = (lattice(-0.5, 0.2), lattice(0.1, 0.4));
    let mut tracer = CpuTracer::new();
    let shade = |tracer: &mut CpuTracer, field: &IrradianceField<'_>, points: &[ShadingPoint]| {
        let uploaded = tracer
            .upload_irradiance(field, &Interpolation::Grid(grid))
            .unwrap();
        tracer
            .shade_diffuse(&uploaded, points, &options)
            .unwrap()
            .results
    };
    for r in shade(&mut tracer, &field, &beyond)
        .iter()
        .chain(&shade(&mut tracer, &field, &within))
    {
        assert!((r.irradiance - Vec3::ONE).length() < 1e-4, "{r:?}");
    }
    let unflagged = IrradianceField {
        inside_geometry: &[],
        ..field
    };
    let dark = shade(&mut tracer, &unflagged, &beyond);
    assert!(dark.iter().all(|r| r.irradiance.x < 1e-2), "{dark:?}");
    // One flag per probe, or none.
    let short = IrradianceField {
        inside_geometry: &inside[1..],
        ..field
    };
    let error = tracer
        .upload_irradiance(&short, &Interpolation::Grid(grid))
        .unwrap_err();
    assert!(error.to_string().contains("`inside_geometry`"), "{error}");
}

/// Irradiance at `x` with normal `n` by BVH: `π ·` the mean of `shade` over cosine-distributed
/// directions (a stratified 16×16 set).
fn reference_irradiance(
    scene: &Scene,
    shade: &(dyn Fn(&probe_scene::Hit, Vec3) -> Vec3 + Sync),
    x: Vec3,
    n: Vec3,
    sky: Vec3,
) -> Vec3 {
    let t = if n.x.abs() < 0.9 { Vec3::X } else { Vec3::Y };
    let u = n.cross(t).normalize();
    let v = n.cross(u);
    let k = 16;
    let mut sum = Vec3::ZERO;
    for i in 0..k {
        for j in 0..k {
            let (a, b) = ((i as f32 + 0.5) / k as f32, (j as f32 + 0.5) / k as f32);
            let r = a.sqrt();
            let phi = std::f32::consts::TAU * b;
            let d = u * (r * phi.cos()) + v * (r * phi.sin()) + n * (1.0 - a).sqrt();
            match scene.closest_hit(&Ray::from_surface(x, n, d), f32::INFINITY) {
                Some(hit) => sum += shade(&hit, d),
                None => sum += sky,
            }
        }
    }
    sum * (std::f32::consts::PI / (k * k) as f32)
}

/// Dark-room floor points near the dividing wall, and lit-room floor points.
fn floor_points(x0: f32, x1: f32, z0: f32, z1: f32) -> Vec<ShadingPoint> {
    let mut points = Vec::new();
    for i in 0..6 {
        for j in 0..6 {
            let x = x0 + (x1 - x0) * (i as f32 + 0.5) / 6.0;
            let z = z0 + (z1 - z0) * (j as f32 + 0.5) / 6.0;
            points.push(ShadingPoint::new(Vec3::new(x, 0.0, z), Vec3::Y));
        }
    }
    points
}

struct LeakFigures {
    dark_leaky: f32,
    dark_visible: f32,
    dark_reference: f32,
    lit_leaky: f32,
    lit_visible: f32,
    lit_reference: f32,
}

/// Mean irradiance (luminance-like: channel mean) on the dark and lit floors, irradiance-only
/// and visibility-aware, against the BVH reference.
fn leak_figures(scene_name: &str) -> LeakFigures {
    let scene = Scene::open(scene_name).unwrap();
    let shade = direct_light_shade(&scene);
    // 6×3×4 probes over both rooms, none inside the 0.2 m wall at x ∈ [-0.1, 0.1].
    let grid = ProbeGrid::new(
        Vec3::new(-3.0, 0.5, -1.5),
        Vec3::new(1.2, 1.0, 1.0),
        [6, 3, 4],
    )
    .unwrap();
    let bake = mini_capture(&scene, &grid.positions(), 16, 100.0, &shade);
    let low = LowRes::of(&bake);
    let mut tracer = CpuTracer::new();
    let irradiance = tracer
        .upload_irradiance(&low.field(), &Interpolation::Grid(grid))
        .unwrap();
    let dark = floor_points(0.15, 1.2, -1.8, 0.8);
    let lit = floor_points(-1.2, -0.15, -1.8, 0.8);
    let mean = |v: &[Vec3]| v.iter().map(|e| (e.x + e.y + e.z) / 3.0).sum::<f32>() / v.len() as f32;
    let mut shade_with = |points: &[ShadingPoint], visibility: bool| -> Vec<Vec3> {
        let options = DiffuseOptions {
            visibility,
            ..DiffuseOptions::default()
        };
        tracer
            .shade_diffuse(&irradiance, points, &options)
            .unwrap()
            .results
            .iter()
            .map(|r| r.irradiance)
            .collect()
    };
    let reference = |points: &[ShadingPoint]| -> Vec<Vec3> {
        points
            .iter()
            .map(|p| {
                reference_irradiance(
                    &scene,
                    &shade,
                    Vec3::from(p.position),
                    Vec3::from(p.normal),
                    support::SKY,
                )
            })
            .collect()
    };
    LeakFigures {
        dark_leaky: mean(&shade_with(&dark, false)),
        dark_visible: mean(&shade_with(&dark, true)),
        dark_reference: mean(&reference(&dark)),
        lit_leaky: mean(&shade_with(&lit, false)),
        lit_visible: mean(&shade_with(&lit, true)),
        lit_reference: mean(&reference(&lit)),
    }
}

/// `builtin:leak-closed`: trilinear irradiance leaks the lit room's light through the complete
/// wall onto the dark floor; the Chebyshev visibility weight removes it, and keeps the lit
/// floor's light.
#[test]
fn visibility_stops_the_leak_through_a_closed_wall() {
    let f = leak_figures("builtin:leak-closed");
    eprintln!(
        "leak-closed dark floor: irradiance-only {:.4}, visibility {:.4}, reference {:.4}; lit floor: {:.4}, {:.4}, {:.4}",
        f.dark_leaky, f.dark_visible, f.dark_reference, f.lit_leaky, f.lit_visible, f.lit_reference
    );
    assert!(
        f.dark_reference < 1e-6,
        "no light reaches the closed dark room"
    );
    assert!(
        f.dark_leaky > 0.05 * f.lit_reference,
        "the irradiance-only blend leaks"
    );
    assert!(
        f.dark_visible < 0.1 * f.dark_leaky,
        "visibility removes the leak"
    );
    assert!(
        (f.lit_visible - f.lit_reference).abs() < 0.35 * f.lit_reference,
        "lit floor keeps its light"
    );
}

/// `builtin:leak-gap`: light really comes through the gap; the visibility-aware blend is
/// closer to the reference on the dark floor than the irradiance-only one.
#[test]
fn visibility_keeps_light_through_a_gap() {
    let f = leak_figures("builtin:leak-gap");
    eprintln!(
        "leak-gap dark floor: irradiance-only {:.4}, visibility {:.4}, reference {:.4}; lit floor: {:.4}, {:.4}, {:.4}",
        f.dark_leaky, f.dark_visible, f.dark_reference, f.lit_leaky, f.lit_visible, f.lit_reference
    );
    assert!(f.dark_reference > 0.0, "some light comes through the gap");
    assert!(
        (f.dark_visible - f.dark_reference).abs() < (f.dark_leaky - f.dark_reference).abs(),
        "visibility is closer to the reference"
    );
}

#[test]
fn diffuse_errors_name_the_problem() {
    let mut tracer = CpuTracer::new();
    let points = [ShadingPoint::new(Vec3::ZERO, Vec3::Y)];
    let positions = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z];
    let irradiance = vec![Vec3::ONE; 4 * 64];
    let moments = vec![Vec2::ONE; 4 * 256];
    let field = IrradianceField {
        positions: &positions,
        irradiance_resolution: 6,
        irradiance: &irradiance,
        moments_resolution: 14,
        moments: &moments,
        surfels: &[],
        inside_geometry: &[],
    };
    let tets = Tetrahedralization::build(&positions).unwrap();
    let uploaded = tracer
        .upload_irradiance(&field, &Interpolation::Delaunay(&tets))
        .unwrap();
    let bad_point = [ShadingPoint::new(Vec3::ZERO, Vec3::ZERO)];
    assert!(matches!(
        tracer.shade_diffuse(&uploaded, &bad_point, &DiffuseOptions::default()),
        Err(TraceError::BadInput {
            item: "shading point",
            index: 0,
            ..
        })
    ));
    let bad_bias = DiffuseOptions {
        normal_bias: -1.0,
        ..DiffuseOptions::default()
    };
    assert!(matches!(
        tracer.shade_diffuse(&uploaded, &points, &bad_bias),
        Err(TraceError::BadOption {
            option: "normal_bias",
            ..
        })
    ));
    for (options, name) in [
        (
            DiffuseOptions {
                visibility_exponent: f32::NAN,
                ..DiffuseOptions::default()
            },
            "visibility_exponent",
        ),
        (
            DiffuseOptions {
                min_weight: 0.0,
                ..DiffuseOptions::default()
            },
            "min_weight",
        ),
    ] {
        match tracer.shade_diffuse(&uploaded, &points, &options) {
            Err(TraceError::BadOption { option, .. }) => assert_eq!(option, name),
            other => panic!("{name}: {other:?}"),
        }
    }
    let parsed: DiffuseOptions = "normal-bias=0.3, exponent=2,backface=off".parse().unwrap();
    assert_eq!(
        parsed,
        DiffuseOptions {
            normal_bias: 0.3,
            visibility_exponent: 2.0,
            backface: false,
            ..DiffuseOptions::default()
        }
    );
    for (text, needle) in [
        ("exponent", "not key=value"),
        ("sharpness=2", "unknown diffuse option `sharpness`"),
        ("backface=maybe", "`maybe` is not a valid value"),
        ("min-weight=x", "`x` is not a valid value"),
    ] {
        let error = text.parse::<DiffuseOptions>().unwrap_err().to_string();
        assert!(error.contains(needle), "{text}: {error}");
    }
    let short = IrradianceField {
        irradiance: &irradiance[1..],
        ..field
    };
    let error = tracer
        .upload_irradiance(&short, &Interpolation::Delaunay(&tets))
        .unwrap_err();
    assert!(error.to_string().contains("`irradiance`"), "{error}");
    // Surfels: the same number per probe, finite.
    let mut surfels = vec![probe_octa::Surfel::default(); 4 * 3];
    let uneven = IrradianceField {
        surfels: &surfels[1..],
        ..field
    };
    let error = tracer
        .upload_irradiance(&uneven, &Interpolation::Delaunay(&tets))
        .unwrap_err();
    assert!(error.to_string().contains("`surfels`"), "{error}");
    surfels[5].area = f32::NAN;
    let nan = IrradianceField {
        surfels: &surfels,
        inside_geometry: &[],
        ..field
    };
    let error = tracer
        .upload_irradiance(&nan, &Interpolation::Delaunay(&tets))
        .unwrap_err();
    assert!(error.to_string().contains("`surfels[5]`"), "{error}");
}

/// The surfels' near-field correction (`DiffuseOptions::parallax`) on the Cornell box with
/// a 3×3×3 grid: against the BVH's irradiance at the surfaces the camera sees, the squared
/// error falls at least 20 % below the plain blend's (0.70× when written: the walls beside
/// each point, the corners; the sky through the open front), for both interpolations. The
/// radiance is the reflected light alone (no emission), as in a
/// bake's irradiance maps and surfels: the light source is direct light, shaded apart.
#[test]
fn parallax_brings_the_near_field() {
    let scene = Scene::open("builtin:cornell").unwrap();
    let direct = direct_light_shade(&scene);
    let shade = |hit: &probe_scene::Hit, d: Vec3| {
        direct(hit, d) - scene.materials()[hit.material as usize].emissive
    };
    let bounds = scene.bounds();
    let size = bounds.size();
    let grid = ProbeGrid::new(bounds.min + size / 6.0, size / 3.0, [3, 3, 3]).unwrap();
    let positions = grid.positions();
    let bake = mini_capture(&scene, &positions, 32, 100.0, &shade);
    let low = LowRes::of(&bake);
    let tets = Tetrahedralization::build(&positions).unwrap();
    let points: Vec<ShadingPoint> = support::camera_rays(&scene, 24, 24)
        .iter()
        .filter_map(|ray| scene.closest_hit(ray, f32::INFINITY))
        .map(|hit| {
            let n = if hit
                .geometric_normal
                .dot(scene.default_camera().position - hit.position)
                >= 0.0
            {
                hit.geometric_normal
            } else {
                -hit.geometric_normal
            };
            ShadingPoint::new(hit.position, n)
        })
        .collect();
    let truth: Vec<Vec3> = points
        .iter()
        .map(|p| {
            let (x, n) = (Vec3::from(p.position), Vec3::from(p.normal));
            reference_irradiance(&scene, &shade, x, n, support::SKY)
        })
        .collect();
    let mut tracer = CpuTracer::new();
    for interpolation in [Interpolation::Grid(grid), Interpolation::Delaunay(&tets)] {
        let irradiance = tracer
            .upload_irradiance(&low.field(), &interpolation)
            .unwrap();
        let mut error = |parallax: bool| -> f32 {
            let options = DiffuseOptions {
                parallax,
                ..DiffuseOptions::default()
            };
            let out = tracer
                .shade_diffuse(&irradiance, &points, &options)
                .unwrap();
            out.results
                .iter()
                .zip(&truth)
                .map(|(r, t)| (r.irradiance - *t).length_squared())
                .sum::<f32>()
                / points.len() as f32
        };
        let (plain, parallax) = (error(false), error(true));
        eprintln!(
            "{points} points, mean squared error: plain {plain:.4e}, parallax {parallax:.4e}",
            points = points.len()
        );
        assert!(parallax < 0.8 * plain, "plain {plain}, parallax {parallax}");
    }
}
