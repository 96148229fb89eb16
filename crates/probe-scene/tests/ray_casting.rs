//! Ray casting on analytic scenes built with `Scene::from_triangles`.

use glam::{Vec2, Vec3};
use probe_scene::{
    AlphaMode, AlphaTexture, BuildError, Camera, Light, Material, Ray, Scene, TextureWrap, Triangle,
};
use std::sync::Arc;

fn triangle(positions: [Vec3; 3], material: u32) -> Triangle {
    Triangle {
        uvs: [Vec2::ZERO, Vec2::X, Vec2::Y],
        ..Triangle::flat(positions, material)
    }
}

/// A closed unit cube `[0, 1]³` facing outward, 12 triangles.
fn unit_cube(material: u32) -> Vec<Triangle> {
    let c = |x: f32, y: f32, z: f32| Vec3::new(x, y, z);
    let quads = [
        [c(0., 0., 0.), c(0., 0., 1.), c(0., 1., 1.), c(0., 1., 0.)], // −X
        [c(1., 0., 0.), c(1., 1., 0.), c(1., 1., 1.), c(1., 0., 1.)], // +X
        [c(0., 0., 0.), c(1., 0., 0.), c(1., 0., 1.), c(0., 0., 1.)], // −Y
        [c(0., 1., 0.), c(0., 1., 1.), c(1., 1., 1.), c(1., 1., 0.)], // +Y
        [c(0., 0., 0.), c(0., 1., 0.), c(1., 1., 0.), c(1., 0., 0.)], // −Z
        [c(0., 0., 1.), c(1., 0., 1.), c(1., 1., 1.), c(0., 1., 1.)], // +Z
    ];
    quads
        .iter()
        .flat_map(|[a, b, c, d]| {
            [
                triangle([*a, *b, *c], material),
                triangle([*a, *c, *d], material),
            ]
        })
        .collect()
}

fn cube_scene() -> Scene {
    Scene::from_triangles(
        "cube",
        unit_cube(0),
        vec![Material::diffuse("grey", Vec3::splat(0.5))],
        Vec::new(),
        Vec::new(),
    )
    .unwrap()
}

#[test]
fn the_cube_is_outward_facing() {
    let scene = cube_scene();
    let centre = Vec3::splat(0.5);
    for t in scene.triangles() {
        let outward = t.point(Vec2::splat(1.0 / 3.0)) - centre;
        assert!(t.geometric_normal().dot(outward) > 0.0);
    }
    assert_eq!(scene.bounds().min, Vec3::ZERO);
    assert_eq!(scene.bounds().max, Vec3::ONE);
}

#[test]
fn ray_into_a_cube_hits_its_front_face() {
    let scene = cube_scene();
    let ray = Ray::new(Vec3::new(0.25, 0.75, -2.0), Vec3::Z);
    let hit = scene.closest_hit(&ray, f32::INFINITY).unwrap();
    assert!((hit.t - 2.0).abs() < 1e-6);
    assert!((hit.position - Vec3::new(0.25, 0.75, 0.0)).length() < 1e-6);
    assert_eq!(hit.geometric_normal, -Vec3::Z);
    assert_eq!(hit.shading_normal, -Vec3::Z);
    assert!(hit.front_face);
    assert_eq!(hit.material, 0);
    let t = &scene.triangles()[hit.triangle as usize];
    assert!((t.point(hit.barycentrics) - hit.position).length() < 1e-6);
    // From inside, the same face is a back face.
    let inside = Ray::new(Vec3::new(0.25, 0.75, 0.5), -Vec3::Z);
    let back = scene.closest_hit(&inside, f32::INFINITY).unwrap();
    assert!(!back.front_face && (back.t - 0.5).abs() < 1e-6);
    assert_eq!(back.geometric_normal, -Vec3::Z);
    // Oblique ray: distance is along the unit direction.
    let oblique = Ray::new(Vec3::new(-1.0, 0.5, -1.0), Vec3::new(1.0, 0.0, 1.0));
    let hit = scene.closest_hit(&oblique, f32::INFINITY).unwrap();
    assert!((hit.t - 2f32.sqrt()).abs() < 1e-5, "{}", hit.t);
    assert!((hit.position - Vec3::new(0.0, 0.5, 0.0)).length() < 1e-5);
}

#[test]
fn misses_and_t_max() {
    let scene = cube_scene();
    let beside = Ray::new(Vec3::new(1.5, 0.5, -2.0), Vec3::Z);
    assert!(scene.closest_hit(&beside, f32::INFINITY).is_none());
    assert!(!scene.occluded(&beside, f32::INFINITY));
    let away = Ray::new(Vec3::new(0.5, 0.5, -2.0), -Vec3::Z);
    assert!(scene.closest_hit(&away, f32::INFINITY).is_none());
    let toward = Ray::new(Vec3::new(0.5, 0.5, -2.0), Vec3::Z);
    assert!(scene.closest_hit(&toward, 1.999).is_none());
    assert!(scene.closest_hit(&toward, 2.001).is_some());
    assert!(!scene.occluded(&toward, 1.999));
    assert!(scene.occluded(&toward, 2.001));
    // Degenerate inputs hit nothing and do not panic.
    assert!(scene.closest_hit(&toward, 0.0).is_none());
    assert!(scene.closest_hit(&toward, f32::NAN).is_none());
    assert!(scene.closest_hit(&toward, -1.0).is_none());
    let nan = Ray {
        origin: Vec3::NAN,
        direction: Vec3::Z,
    };
    assert!(scene.closest_hit(&nan, f32::INFINITY).is_none());
    assert!(!scene.occluded(&nan, f32::INFINITY));
    let zero = Ray {
        origin: Vec3::new(0.5, 0.5, -2.0),
        direction: Vec3::ZERO,
    };
    assert!(scene.closest_hit(&zero, f32::INFINITY).is_none());
}

/// `closest_hit_between` skips hits below `t_min`: a ray that starts exactly on the cube's
/// face, at 1 km from the origin as near it, finds the opposite face with `t` measured from
/// its own origin, while `closest_hit` from the same point may find the face it starts on.
#[test]
fn hits_between_skip_the_surface_a_ray_starts_on() {
    for offset in [Vec3::ZERO, Vec3::splat(1.0e3)] {
        let triangles = unit_cube(0)
            .into_iter()
            .map(|t| triangle(t.positions.map(|p| p + offset), 0))
            .collect();
        let scene = Scene::from_triangles(
            "cube",
            triangles,
            vec![Material::diffuse("grey", Vec3::splat(0.5))],
            Vec::new(),
            Vec::new(),
        )
        .unwrap();
        // On the −Z face, inside the cube, at 60° from the face's normal.
        let origin = offset + Vec3::new(0.3, 0.4, 0.0);
        let direction = Vec3::new(0.0, 0.5, 0.75f32.sqrt());
        let ray = Ray { origin, direction };
        let ulp = |x: f32| f32::from_bits(x.abs().to_bits() + 1) - x.abs();
        let t_min = 16.0 * ulp(origin.max_element().max(1.0)) / direction.z;
        let hit = scene
            .closest_hit_between(&ray, t_min, f32::INFINITY)
            .expect("the far side of the cube");
        // It leaves through the +Z face at z = 1 (at y = 0.98): t = 1 / cos 30°.
        let exit = 1.0 / direction.z;
        assert!((hit.t - exit).abs() < 1e-3, "{offset}: t {}", hit.t);
        assert!(
            (hit.position.z - offset.z - 1.0).abs() < 1e-3,
            "{offset}: {}",
            hit.position
        );
        assert!(hit.t >= t_min);
        // Limits: nothing when t_max ≤ t_min or beyond the last hit; a negative or NaN t_min
        // counts as 0.
        assert!(scene.closest_hit_between(&ray, 1.3, 1.3).is_none());
        assert!(
            scene
                .closest_hit_between(&ray, 1.21, f32::INFINITY)
                .is_none()
        );
        assert_eq!(
            scene
                .closest_hit_between(&ray, f32::NAN, f32::INFINITY)
                .map(|h| h.t),
            scene.closest_hit(&ray, f32::INFINITY).map(|h| h.t)
        );
        let from_outside = Ray::new(origin - Vec3::Z, Vec3::Z);
        let front = scene
            .closest_hit_between(&from_outside, -1.0, f32::INFINITY)
            .expect("the −Z face");
        assert!((front.t - 1.0).abs() < 1e-3);
    }
}

#[test]
fn occlusion_between_points() {
    let scene = cube_scene();
    let a = Vec3::new(0.5, 0.5, -1.0);
    let b = Vec3::new(0.5, 0.5, 2.0);
    let blocked_back = Ray::new(b, a - b);
    assert!(scene.occluded(&blocked_back, (b - a).length()));
    // Beside the cube, parallel to the blocked segment.
    let (c, d) = (Vec3::new(1.2, 0.5, -1.0), Vec3::new(1.2, 0.5, 2.0));
    let clear = Ray::new(c, d - c);
    assert!(!scene.occluded(&clear, (d - c).length()));
    // Stopping short of the cube.
    let short = Ray::new(a, b - a);
    assert!(!scene.occluded(&short, 0.99));
    // Leaving a surface: from_surface avoids hitting the face the ray starts on.
    let on_face = Vec3::new(0.3, 1.0, 0.6);
    let out = Ray::from_surface(on_face, Vec3::Y, Vec3::new(0.2, 1.0, 0.1));
    assert!(!scene.occluded(&out, f32::INFINITY));
    let into = Ray::from_surface(on_face, Vec3::Y, -Vec3::Y);
    let hit = scene.closest_hit(&into, f32::INFINITY).unwrap();
    assert!((hit.position.y - 0.0).abs() < 1e-5, "{:?}", hit.position);
    assert!(!hit.front_face);
}

#[test]
fn edges_and_vertices_do_not_leak() {
    // Rays through the cube's shared edges and corners, from both sides, always hit.
    let scene = cube_scene();
    for (origin, direction) in [
        (Vec3::new(0.5, 0.5, -1.0), Vec3::Z), // through the −Z face's diagonal
        (Vec3::new(0.5, 0.5, 0.5), -Vec3::Z), // same edge from inside
        (Vec3::new(0.0, 0.0, -1.0), Vec3::Z), // through a corner
        (Vec3::new(1.0, 0.5, -1.0), Vec3::Z), // along the cube's edge line
        (Vec3::new(-1.0, -1.0, -1.0), Vec3::ONE), // straight at a vertex
        (Vec3::new(0.5, -1.0, 0.5), Vec3::Y), // −Y face's diagonal
    ] {
        let ray = Ray::new(origin, direction);
        assert!(
            scene.closest_hit(&ray, f32::INFINITY).is_some(),
            "{origin} along {direction} leaked"
        );
        assert!(scene.occluded(&ray, f32::INFINITY));
    }
}

#[test]
fn barycentrics_and_interpolated_normals() {
    let positions = [
        Vec3::ZERO,
        Vec3::new(4.0, 0.0, 0.0),
        Vec3::new(0.0, 2.0, 0.0),
    ];
    let t = Triangle {
        positions,
        normals: [Vec3::Z, Vec3::new(1.0, 0.0, 1.0).normalize(), Vec3::Y],
        uvs: [Vec2::ZERO, Vec2::X, Vec2::Y],
        material: 0,
    };
    let scene = Scene::from_triangles(
        "one",
        vec![t],
        vec![Material::diffuse("m", Vec3::ONE)],
        Vec::new(),
        Vec::new(),
    )
    .unwrap();
    // Aim at b = (0.25, 0.5): (1 − 0.75)·p0 + 0.25·p1 + 0.5·p2 = (1, 1, 0).
    let ray = Ray::new(Vec3::new(1.0, 1.0, 3.0), -Vec3::Z);
    let hit = scene.closest_hit(&ray, f32::INFINITY).unwrap();
    assert!((hit.barycentrics - Vec2::new(0.25, 0.5)).length() < 1e-6);
    assert!((hit.position - Vec3::new(1.0, 1.0, 0.0)).length() < 1e-6);
    assert_eq!(hit.geometric_normal, Vec3::Z);
    let expected =
        (Vec3::Z * 0.25 + Vec3::new(1.0, 0.0, 1.0).normalize() * 0.25 + Vec3::Y * 0.5).normalize();
    assert!((hit.shading_normal - expected).length() < 1e-6);
    assert!(hit.shading_normal.is_normalized());
    assert!(hit.front_face);
    // Zero vertex normals fall back to the geometric normal.
    let flat = Scene::from_triangles(
        "flat",
        vec![Triangle {
            normals: [Vec3::ZERO; 3],
            ..t
        }],
        vec![Material::diffuse("m", Vec3::ONE)],
        Vec::new(),
        Vec::new(),
    )
    .unwrap();
    assert_eq!(
        flat.closest_hit(&ray, f32::INFINITY)
            .unwrap()
            .shading_normal,
        Vec3::Z
    );
}

/// A 1×1 quad at z = 0 (UV 0..1) with a mask whose left half (u < 0.5) is opaque, in front of
/// an opaque backstop quad at z = −1.
fn masked_scene() -> Scene {
    let mut alpha = Vec::new();
    for _row in 0..4 {
        alpha.extend_from_slice(&[255, 255, 0, 0]);
    }
    let mask = AlphaTexture::new(
        4,
        4,
        alpha,
        TextureWrap::ClampToEdge,
        TextureWrap::ClampToEdge,
    )
    .unwrap();
    let leaf = Material {
        alpha: AlphaMode::Mask {
            cutoff: 0.5,
            texture: Some(Arc::new(mask)),
            constant_alpha: 1.0,
        },
        double_sided: true,
        ..Material::diffuse("leaf", Vec3::new(0.1, 0.6, 0.1))
    };
    let quad = |z: f32, material: u32| {
        let p = |x: f32, y: f32| Vec3::new(x, y, z);
        let uv = |x: f32, y: f32| Vec2::new(x, 1.0 - y);
        [
            Triangle {
                positions: [p(0.0, 0.0), p(1.0, 0.0), p(1.0, 1.0)],
                normals: [Vec3::Z; 3],
                uvs: [uv(0.0, 0.0), uv(1.0, 0.0), uv(1.0, 1.0)],
                material,
            },
            Triangle {
                positions: [p(0.0, 0.0), p(1.0, 1.0), p(0.0, 1.0)],
                normals: [Vec3::Z; 3],
                uvs: [uv(0.0, 0.0), uv(1.0, 1.0), uv(0.0, 1.0)],
                material,
            },
        ]
    };
    let mut triangles = quad(0.0, 0).to_vec();
    triangles.extend(quad(-1.0, 1));
    Scene::from_triangles(
        "masked",
        triangles,
        vec![leaf, Material::diffuse("wall", Vec3::splat(0.8))],
        Vec::new(),
        Vec::new(),
    )
    .unwrap()
}

#[test]
fn alpha_cut_outs_are_respected() {
    let scene = masked_scene();
    for y in [0.1, 0.4, 0.9] {
        let opaque = Ray::new(Vec3::new(0.2, y, 1.0), -Vec3::Z);
        let hit = scene.closest_hit(&opaque, f32::INFINITY).unwrap();
        assert_eq!(hit.material, 0, "opaque half at y = {y}");
        assert!((hit.t - 1.0).abs() < 1e-6);
        assert!(scene.occluded(&opaque, 1.5));
        let cut = Ray::new(Vec3::new(0.8, y, 1.0), -Vec3::Z);
        let hit = scene.closest_hit(&cut, f32::INFINITY).unwrap();
        assert_eq!(
            hit.material, 1,
            "cut-out half at y = {y} must show the wall behind"
        );
        assert!((hit.t - 2.0).abs() < 1e-6);
        assert!(!scene.occluded(&cut, 1.5), "cut-outs do not occlude");
        assert!(scene.occluded(&cut, 2.5));
    }
    // Making the same material opaque brings the hidden half back.
    let mut materials = scene.materials().to_vec();
    materials[0].alpha = AlphaMode::Opaque;
    let opaque = Scene::from_triangles(
        "opaque",
        scene.triangles().to_vec(),
        materials,
        Vec::new(),
        Vec::new(),
    )
    .unwrap();
    let cut = Ray::new(Vec3::new(0.8, 0.5, 1.0), -Vec3::Z);
    assert_eq!(opaque.closest_hit(&cut, f32::INFINITY).unwrap().material, 0);
    assert_ne!(opaque.content_hash(), scene.content_hash());
}

#[test]
fn batch_matches_single_rays() {
    let scene = Scene::builtin("colonnade").unwrap();
    let camera = scene.default_camera();
    let (w, h) = (64, 48);
    let rays: Vec<Ray> = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| camera.ray(x, y, w, h, Vec2::new(0.1, -0.2)))
        .collect();
    let hits = scene.closest_hits(&rays, 30.0);
    assert_eq!(hits.len(), rays.len());
    let mut hit_count = 0;
    for (ray, hit) in rays.iter().zip(&hits) {
        assert_eq!(*hit, scene.closest_hit(ray, 30.0));
        hit_count += usize::from(hit.is_some());
    }
    assert!(hit_count > rays.len() / 2);
}

#[test]
fn empty_scene_hits_nothing() {
    let scene =
        Scene::from_triangles("empty", Vec::new(), Vec::new(), Vec::new(), Vec::new()).unwrap();
    assert!(scene.bounds().is_empty());
    let ray = Ray::new(Vec3::ZERO, Vec3::X);
    assert!(scene.closest_hit(&ray, f32::INFINITY).is_none());
    assert!(!scene.occluded(&ray, f32::INFINITY));
    assert!(scene.default_camera().position.is_finite());
}

#[test]
fn bad_triangle_scenes_are_refused() {
    let materials = || vec![Material::diffuse("m", Vec3::ONE)];
    let mut bad = unit_cube(0);
    bad[5].positions[1].y = f32::NAN;
    assert_eq!(
        Scene::from_triangles("bad", bad, materials(), Vec::new(), Vec::new()).unwrap_err(),
        BuildError::NonFiniteVertex {
            triangle: 5,
            attribute: "position"
        }
    );
    let mut bad = unit_cube(0);
    bad[3].uvs[0].x = f32::INFINITY;
    assert!(matches!(
        Scene::from_triangles("bad", bad, materials(), Vec::new(), Vec::new()),
        Err(BuildError::NonFiniteVertex {
            triangle: 3,
            attribute: "uv"
        })
    ));
    let err = Scene::from_triangles("bad", unit_cube(1), materials(), Vec::new(), Vec::new())
        .unwrap_err();
    assert_eq!(
        err,
        BuildError::MaterialOutOfRange {
            triangle: 0,
            material: 1,
            material_count: 1
        }
    );
    assert!(err.to_string().contains("material 1"));
    let mut glowing = materials();
    glowing[0].roughness = 2.0;
    assert!(matches!(
        Scene::from_triangles("bad", unit_cube(0), glowing, Vec::new(), Vec::new()),
        Err(BuildError::InvalidMaterial { material: 0, .. })
    ));
    let light = Light::Spot {
        name: "spot".into(),
        position: Vec3::ONE,
        direction: Vec3::ZERO,
        color: Vec3::ONE,
        intensity: 10.0,
        inner_cone: 0.1,
        outer_cone: 0.5,
        range: None,
    };
    assert!(matches!(
        Scene::from_triangles("bad", unit_cube(0), materials(), vec![light], Vec::new()),
        Err(BuildError::InvalidLight { light: 0, .. })
    ));
    let mut camera = Camera::look_at(Vec3::ZERO, Vec3::X, Vec3::Y, 1.0);
    camera.up = Vec3::X;
    assert!(matches!(
        Scene::from_triangles("bad", unit_cube(0), materials(), Vec::new(), vec![camera]),
        Err(BuildError::InvalidCamera { camera: 0, .. })
    ));
}

#[test]
fn lights_are_normalised_and_hashed() {
    let sun = |direction: Vec3| Light::Directional {
        name: "sun".into(),
        direction,
        color: Vec3::ONE,
        illuminance: 1000.0,
        range: None,
    };
    let build = |light: Light| {
        Scene::from_triangles(
            "lit",
            unit_cube(0),
            vec![Material::diffuse("m", Vec3::ONE)],
            vec![light],
            Vec::new(),
        )
        .unwrap()
    };
    let a = build(sun(Vec3::new(0.0, -2.0, 0.0)));
    match &a.lights()[0] {
        Light::Directional { direction, .. } => assert_eq!(*direction, -Vec3::Y),
        other => panic!("{other:?}"),
    }
    let b = build(sun(-Vec3::Y));
    assert_eq!(a.content_hash(), b.content_hash());
    let c = build(sun(-Vec3::X));
    assert_ne!(a.content_hash(), c.content_hash());
}

#[test]
fn scene_is_send_and_sync() {
    fn assert_send_sync<T: Send + Sync>() {}
    assert_send_sync::<Scene>();
}
