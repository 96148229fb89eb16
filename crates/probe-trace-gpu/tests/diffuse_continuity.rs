//! Property test: the diffuse blend (CPU twin) is continuous in the shading position, with and
//! without Chebyshev visibility, across the faces of the Delaunay tetrahedra and across the
//! planes of those faces extended outside the convex hull (where a blend that clamps the
//! barycentric coordinates of whichever hull tetrahedron its walk ends in jumps).
//!
//! Two points `2ε` apart on either side of such a plane get irradiance `Δ(ε)` apart. For a
//! continuous blend `Δ` shrinks with `ε` (by about the ratio of the `ε`s where the blend is
//! differentiable; at least 16× is asked for a 1024× smaller `ε`, which leaves room for the
//! steep but continuous transitions the visibility floor makes); at a jump it stays the size
//! of the jump however small `ε` is. Probe sets with slivers are skipped: there the f32
//! barycentric coordinates themselves are off by more than the pairs' difference.

use glam::{Vec2, Vec3};
use probe_index::Tetrahedralization;
use probe_testdata::Lcg;
use probe_trace_gpu::{
    CpuTracer, DiffuseOptions, Interpolation, IrradianceField, ShadingPoint, Tracer,
};
use proptest::prelude::*;

const IRRADIANCE_RESOLUTION: u32 = 6;
const MOMENTS_RESOLUTION: u32 = 6;
/// Half the distance between the two points of a wide pair, in metres (probes span 2 m).
const WIDE: f32 = 2e-3;
/// The same for a narrow pair: 1024× less (about 8 f32 steps at these coordinates).
const NARROW: f32 = WIDE / 1024.0;

/// What f32 rounding may change of the blend, relative to the irradiance spread. Outside the
/// hull, near a hull edge or corner, the nearest point is chosen by comparing squared
/// distances that differ by the square of how far apart the candidates are, so rounding of
/// `d²` moves the weights by up to about `√ε_f32 · d / edge` (≈ 2.4e-4 · 2.5 m / 1 m here).
/// The jumps this test exists for are hundreds of times larger (0.11 for the clamped walk).
const ROUNDING: f32 = 1e-3;

/// The thinnest tetrahedron (smallest vertex-to-face height) a probe set may have, in metres.
const MIN_HEIGHT: f32 = 0.01;

/// The smallest height of any tetrahedron of `tets`.
fn smallest_height(tets: &Tetrahedralization) -> f32 {
    let points = tets.points();
    let mut smallest = f32::INFINITY;
    for record in tets.tetrahedra() {
        let p = record.vertices.map(|v| points[v as usize]);
        let volume = (p[1] - p[0]).cross(p[2] - p[0]).dot(p[3] - p[0]).abs();
        for face in 0..4 {
            let [a, b, c] = [(face + 1) % 4, (face + 2) % 4, (face + 3) % 4].map(|k| p[k]);
            let area = (b - a).cross(c - a).length();
            smallest = smallest.min(volume / area);
        }
    }
    smallest
}

/// The property for one probe set (`seed`) and options; an error names the first pair whose
/// difference does not shrink with the distance between its points.
fn blend_is_continuous(
    seed: u64,
    visibility: bool,
    backface: bool,
    exponent: f32,
) -> Result<(), TestCaseError> {
    let mut rng = Lcg(seed);
    // A 3×3×3 grid 1 m apart (2 m across), each probe moved at random by up to 0.2 m per
    // axis: random, and not too degenerate.
    let positions: Vec<Vec3> = (0..27)
        .map(|i| {
            let cell = Vec3::new((i % 3) as f32, ((i / 3) % 3) as f32, (i / 9) as f32);
            cell + (Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) - 0.5) * 0.4
        })
        .collect();
    let count = positions.len();
    let Ok(tets) = Tetrahedralization::build(&positions) else {
        return Ok(());
    };
    // Slivers (random points make them) have f32 barycentric coordinates off by the
    // rounding of the position over the sliver's height: skip sets with any.
    if smallest_height(&tets) < MIN_HEIGHT {
        return Err(TestCaseError::reject("a sliver"));
    }
    let irradiance_texels = ((IRRADIANCE_RESOLUTION + 2) * (IRRADIANCE_RESOLUTION + 2)) as usize;
    let moments_texels = ((MOMENTS_RESOLUTION + 2) * (MOMENTS_RESOLUTION + 2)) as usize;
    let colours: Vec<Vec3> = (0..count)
        .map(|_| Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()))
        .collect();
    let irradiance: Vec<Vec3> = colours
        .iter()
        .flat_map(|&c| std::iter::repeat_n(c, irradiance_texels))
        .collect();
    // Every probe sees a surface at a random mean distance with a little spread, so the
    // Chebyshev test really occludes points beyond it.
    let moments: Vec<Vec2> = (0..count)
        .flat_map(|_| {
            let mean = 0.3 + 1.5 * rng.uniform();
            std::iter::repeat_n(Vec2::new(mean, mean * mean + 0.01), moments_texels)
        })
        .collect();
    let field = IrradianceField {
        positions: &positions,
        irradiance_resolution: IRRADIANCE_RESOLUTION,
        irradiance: &irradiance,
        moments_resolution: MOMENTS_RESOLUTION,
        moments: &moments,
        surfels: &[],
        inside_geometry: &[],
    };
    let options = DiffuseOptions {
        visibility,
        backface,
        visibility_exponent: exponent,
        ..DiffuseOptions::default()
    };
    let mut tracer = CpuTracer::new();
    let uploaded = tracer
        .upload_irradiance(&field, &Interpolation::Delaunay(&tets))
        .unwrap();
    // Pairs straddling the plane of a random face of a random tetrahedron, at a point of
    // that plane inside the face or beyond its edges (outside the hull when the face is a
    // hull face, or when the point is far enough out).
    let records = tets.tetrahedra();
    let mut pairs = Vec::new();
    for _ in 0..64 {
        let record = &records[(rng.uniform() * records.len() as f32) as usize % records.len()];
        let face = (rng.uniform() * 4.0) as usize % 4;
        let corners: Vec<Vec3> = (0..4)
            .filter(|&k| k != face)
            .map(|k| positions[record.vertices[k] as usize])
            .collect();
        let (u, v) = (rng.uniform() * 3.0 - 1.0, rng.uniform() * 3.0 - 1.0);
        let on_plane = corners[0] + (corners[1] - corners[0]) * u + (corners[2] - corners[0]) * v;
        let normal = (corners[1] - corners[0])
            .cross(corners[2] - corners[0])
            .normalize();
        let shading_normal = Vec3::new(
            rng.uniform() - 0.5,
            rng.uniform() - 0.5,
            rng.uniform() - 0.5,
        )
        .try_normalize()
        .unwrap_or(Vec3::Y);
        for half in [WIDE, NARROW] {
            pairs.push(ShadingPoint::new(on_plane - normal * half, shading_normal));
            pairs.push(ShadingPoint::new(on_plane + normal * half, shading_normal));
        }
    }
    let out = tracer.shade_diffuse(&uploaded, &pairs, &options).unwrap();
    let spread = colours.iter().fold(0.0f32, |m, c| m.max(c.max_element()));
    for (k, four) in out.results.chunks(4).enumerate() {
        let wide = (four[0].irradiance - four[1].irradiance)
            .abs()
            .max_element();
        let narrow = (four[2].irradiance - four[3].irradiance)
            .abs()
            .max_element();
        prop_assert!(
            narrow <= wide / 16.0 + ROUNDING * spread,
            "pair {} at {:?}: |Δ| {} at ε = {} and {} at ε = {} ({} vs {})",
            k,
            pairs[4 * k + 2].position,
            wide,
            WIDE,
            narrow,
            NARROW,
            four[2].irradiance,
            four[3].irradiance
        );
    }
    Ok(())
}

proptest! {
    // A fixed seed: the same cases on every run (the project's rule), 256 of them.
    #![proptest_config(ProptestConfig {
        cases: 256,
        max_global_rejects: 8192,
        rng_seed: proptest::test_runner::RngSeed::Fixed(14),
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    #[test]
    fn blend_is_continuous_across_faces(
        seed in any::<u64>(),
        visibility in any::<bool>(),
        backface in any::<bool>(),
        exponent in 1.0f32..4.0,
    ) {
        blend_is_continuous(seed, visibility, backface, exponent)?;
    }
}

/// A case a randomly seeded run of the property found (CI, 2026-12-02): a pair outside the
/// hull, 0.5 m below the probes, whose difference stayed 0.042 at ε = 2e-6. The nearest hull
/// point was chosen by ranking f32 squared distances of candidates that are nearly the same
/// point (differences of order `(separation)²`): one point of the pair took a hull corner
/// (probe 11 alone), the other a point 7e-5 along an edge from it (probe 20 weighted 7e-5),
/// and the visibility weighting (probe 11 nearly occluded, at the `min_weight` floor) turned
/// that into 6 % of the blend. The descent over the hull decides by first-order region tests.
#[test]
fn known_discontinuity_outside_the_hull() {
    blend_is_continuous(10896597016308689907, true, false, 2.9141228).unwrap();
}
