//! Cube map → octahedral resampling with seed 001's sharpness weight, against analytic
//! functions of direction.

use glam::Vec3;
use probe_octa::{CubeFace, CubeMap, OctaMap, default_sharpness};

/// A smooth function with structure in every axis and a second-order part (so blur shows).
fn smooth(d: Vec3) -> f32 {
    0.5 + 0.3 * d.x + 0.6 * d.y - 0.45 * d.z + 0.8 * d.x * d.z + 0.5 * (d.y * d.y - d.z * d.z)
}

/// Largest error at octahedral texel centres.
fn worst_error(map: &OctaMap<f32>, f: impl Fn(Vec3) -> f32) -> f32 {
    let layout = map.layout();
    let n = layout.resolution();
    let mut worst = 0.0f32;
    for iy in 0..n {
        for ix in 0..n {
            let d = layout.texel_direction(ix, iy);
            worst = worst.max((map.get(ix, iy).unwrap() - f(d)).abs());
        }
    }
    worst
}

#[test]
fn constant_cube_gives_the_constant() {
    let cube = CubeMap::from_fn(32, |_| Vec3::new(0.25, 1.5, 4.0)).unwrap();
    for sharpness in [0.0, 1.0, 50.0, default_sharpness(16), 1e6] {
        let octa = cube.to_octahedral(16, sharpness).unwrap();
        for t in octa.texels() {
            assert!(
                t.abs_diff_eq(Vec3::new(0.25, 1.5, 4.0), 1e-5),
                "{sharpness}: {t}"
            );
        }
    }
}

#[test]
fn smooth_function_is_reproduced_and_sharpness_matters() {
    let cube = CubeMap::from_fn(128, smooth).unwrap();
    let n = 32;
    let sharp = cube.to_octahedral(n, default_sharpness(n)).unwrap();
    let sharp_error = worst_error(&sharp, smooth);
    // The lobe (σ ≈ 0.055 rad) blurs the second-order part only slightly.
    assert!(sharp_error < 0.01, "default sharpness: {sharp_error}");

    // Error falls as the weight sharpens; plain averaging over the hemisphere washes out.
    let mut previous = f32::INFINITY;
    for sharpness in [0.0, 4.0, 40.0, default_sharpness(n)] {
        let octa = cube.to_octahedral(n, sharpness).unwrap();
        let error = worst_error(&octa, smooth);
        assert!(
            error < previous,
            "sharpness {sharpness}: {error} >= {previous}"
        );
        if sharpness == 0.0 {
            assert!(error > 0.3, "hemisphere average should wash out: {error}");
        }
        previous = error;
    }

    // Bilinear samples of the octahedral map in arbitrary directions follow the function too.
    for i in 0..500 {
        let d = probe_octa::decode(glam::Vec2::new(
            (i as f32 * 0.618_034).fract() * 2.0 - 1.0,
            (i as f32 * 0.754_877_7).fract() * 2.0 - 1.0,
        ));
        assert!((sharp.sample(d) - smooth(d)).abs() < 0.08, "{d}");
    }
}

/// A lobe far narrower than the cube texels holds no cube texel centre; the documented
/// fallback is the cube texel containing the direction.
#[test]
fn too_sharp_a_lobe_falls_back_to_the_nearest_cube_texel() {
    let cube = CubeMap::from_fn(8, smooth).unwrap();
    let octa = cube.to_octahedral(8, 1e9).unwrap();
    let layout = octa.layout();
    for iy in 0..8 {
        for ix in 0..8 {
            let d = layout.texel_direction(ix, iy);
            assert_eq!(octa.get(ix, iy).unwrap(), cube.sample_nearest(d));
        }
    }
}

/// Resampling respects the documented face convention: a map that is 1 on one face and 0
/// elsewhere lands on the octahedral texels of that face's directions.
#[test]
fn each_face_lands_where_its_directions_are() {
    for face in CubeFace::ALL {
        let m = 16;
        let texels: Vec<f32> = (0..6 * m * m)
            .map(|i| {
                if i / (m * m) == face.index() {
                    1.0
                } else {
                    0.0
                }
            })
            .collect();
        let cube = CubeMap::from_texels(m as u32, texels).unwrap();
        let octa = cube.to_octahedral(32, default_sharpness(32)).unwrap();
        let layout = octa.layout();
        for iy in 0..32 {
            for ix in 0..32 {
                let d = layout.texel_direction(ix, iy);
                let (owner, _, _) = cube.texel_containing(d);
                let a = d.abs();
                // Well inside a face (away from its edges), the value is the face indicator.
                let sorted = {
                    let mut v = a.to_array();
                    v.sort_by(f32::total_cmp);
                    v
                };
                if sorted[2] - sorted[1] > 0.2 {
                    let expected = if owner == face { 1.0 } else { 0.0 };
                    let got = octa.get(ix, iy).unwrap();
                    assert!((got - expected).abs() < 1e-2, "{face:?} at {d}: {got}");
                }
            }
        }
    }
}
