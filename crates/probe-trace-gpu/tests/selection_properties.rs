//! Property test: the CPU twin selects the probes `probe-index`'s selectors select.
//!
//! The light field is all sky (every texel at the sky distance), so the first probe the twin
//! tries answers every ray as a MISS, and the answering probe is the first candidate of the
//! twin's selection at the ray's start. Over random probe sets, scenes, points and directions
//! that probe must be the first of the reference `ProbeSelector`'s list (grid cage, Voronoi
//! nearest probe, octree leaf), and a ray where the reference selects nothing must have no
//! probe. The unit tests in `src/cpu/select.rs` compare whole candidate lists on fixed sets.

use glam::Vec3;
use probe_index::{
    NearestProbe, ProbeGrid, ProbeQuery, ProbeSelector, SparseVoxelOctree, SvoOptions,
    Tetrahedralization, VoronoiNeighbours, VoronoiSelector,
};
use probe_trace_gpu::{
    CpuTracer, FieldOptions, LightField, ProbeSelection, RayStatus, TraceOptions, TraceRay, Tracer,
};
use proptest::prelude::*;

const RESOLUTION: u32 = 8;
const SKY: f32 = 1.0e4;

/// Radiance that names its probe: probe `p` stores `(p, 1, 0)` everywhere.
fn tag(probe: u32) -> Vec3 {
    Vec3::new(probe as f32, 1.0, 0.0)
}

/// Traces `rays` through all-sky probes at `positions` with `selection`; each result's probe
/// and radiance must be the reference's first candidate at the ray's origin.
fn check(
    positions: &[Vec3],
    selection: &ProbeSelection<'_>,
    reference: &dyn ProbeSelector,
    rays: &[(Vec3, Vec3)],
) -> Result<(), TestCaseError> {
    let texels = ((RESOLUTION + 2) * (RESOLUTION + 2)) as usize;
    let radiance: Vec<Vec3> = (0..positions.len() as u32)
        .flat_map(|p| std::iter::repeat_n(tag(p), texels))
        .collect();
    let distances = vec![SKY; positions.len() * texels];
    let normals = vec![Vec3::ZERO; positions.len() * texels];
    let field = LightField {
        resolution: RESOLUTION,
        positions,
        radial_distance: &distances,
        normals: &normals,
        radiance: &radiance,
        distance_range: None,
        sky_distance: SKY,
        geometry_bounds: None,
    };
    let mut tracer = CpuTracer::new();
    let uploaded = tracer
        .upload(&field, selection, &FieldOptions::default())
        .unwrap();
    let trace_rays: Vec<TraceRay> = rays.iter().map(|&(o, d)| TraceRay::new(o, d)).collect();
    // The selection's own candidates alone (no nearest-probe extension) ...
    let own = TraceOptions {
        nearest_candidates: 0,
        ..TraceOptions::default()
    };
    let results = tracer.trace(&uploaded, &trace_rays, &own).unwrap().results;
    // ... and with the extension, which answers where the selection has no candidate with
    // the probe nearest to the ray's start.
    let extended = tracer
        .trace(&uploaded, &trace_rays, &TraceOptions::default())
        .unwrap()
        .results;
    let nearest = NearestProbe::new(positions);
    for ((&(origin, direction), result), with_nearest) in rays.iter().zip(&results).zip(&extended) {
        let expected = reference.select(&ProbeQuery {
            position: origin,
            direction: direction.normalize(),
            failed_probe: None,
        });
        match expected.as_slice().first() {
            Some(&first) => {
                prop_assert_eq!(
                    result.probe,
                    Some(first),
                    "{}: ray from {} along {} (reference {:?})",
                    selection.name(),
                    origin,
                    direction,
                    expected.as_slice()
                );
                prop_assert_eq!(result.status, RayStatus::Miss);
                prop_assert_eq!(result.probes_tried, 1);
                prop_assert!(
                    result
                        .radiance
                        .abs_diff_eq(tag(first), 1e-5 * tag(first).length())
                );
            }
            None => {
                prop_assert_eq!(result.probe, None, "{}: from {}", selection.name(), origin);
                prop_assert_eq!(result.status, RayStatus::Unknown);
                prop_assert_eq!(result.probes_tried, 0);
                let closest = nearest.nearest(origin).map(|(p, _)| p);
                prop_assert_eq!(with_nearest.probe, closest, "nearest to {}", origin);
                prop_assert_eq!(with_nearest.status, RayStatus::Miss);
            }
        }
        if !expected.as_slice().is_empty() {
            // The extension only adds candidates after the selection's own.
            prop_assert_eq!(with_nearest, result);
        }
    }
    Ok(())
}

/// Random rays: origins in `[lo, hi]` widened by half a unit (outside the probes' box too),
/// a tenth of them exactly at a probe; directions anywhere but zero.
fn rays(positions: &[Vec3], raw: &[([f32; 3], [f32; 3])], lo: Vec3, hi: Vec3) -> Vec<(Vec3, Vec3)> {
    let (lo, hi) = (lo - Vec3::splat(0.5), hi + Vec3::splat(0.5));
    raw.iter()
        .enumerate()
        .map(|(i, (o, d))| {
            let origin = if i % 10 == 0 {
                positions[i % positions.len()]
            } else {
                lo + (hi - lo) * Vec3::from(*o)
            };
            let d = Vec3::from(*d);
            (origin, if d.length() > 1e-3 { d } else { Vec3::X })
        })
        .collect()
}

fn ray_samples() -> impl Strategy<Value = Vec<([f32; 3], [f32; 3])>> {
    prop::collection::vec(
        (
            prop::array::uniform3(0.0f32..1.0),
            prop::array::uniform3(-1.0f32..1.0),
        ),
        64,
    )
}

#[path = "support/boxes.rs"]
mod boxes;
use boxes::Boxes;

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 48,
        rng_seed: proptest::test_runner::RngSeed::Fixed(1),
        ..ProptestConfig::default()
    })]

    /// Regular grids of any shape and spacing: the twin's cage order starts where
    /// `ProbeGrid::select` does.
    #[test]
    fn grid_selection_matches_probe_index(
        origin in prop::array::uniform3(-5.0f32..5.0),
        spacing in prop::array::uniform3(0.1f32..2.0),
        counts in prop::array::uniform3(2u32..6),
        raw in ray_samples(),
    ) {
        let grid = ProbeGrid::new(Vec3::from(origin), Vec3::from(spacing), counts).unwrap();
        let positions = grid.positions();
        let hi = grid.probe_position(grid.probe_count() as u32 - 1);
        let rays = rays(&positions, &raw, Vec3::from(origin), hi);
        check(&positions, &ProbeSelection::Grid(grid), &grid, &rays)?;
    }

    /// Random probe sets: the twin's k-d tree finds `NearestProbe`'s nearest probe.
    #[test]
    fn voronoi_selection_matches_probe_index(
        points in prop::collection::vec(prop::array::uniform3(0.0f32..1.0), 4..40),
        extent in prop::array::uniform3(0.5f32..5.0),
        raw in ray_samples(),
    ) {
        let extent = Vec3::from(extent);
        let positions: Vec<Vec3> = points.iter().map(|p| Vec3::from(*p) * extent).collect();
        let tets = Tetrahedralization::build(&positions);
        prop_assume!(tets.is_ok());
        let neighbours = VoronoiNeighbours::bake(&tets.unwrap(), 8).unwrap();
        let nearest = NearestProbe::new(&positions);
        let reference = VoronoiSelector {
            positions: &positions,
            nearest: &nearest,
            neighbours: &neighbours,
        };
        let selection = ProbeSelection::Voronoi {
            nearest: &nearest,
            neighbours: &neighbours,
        };
        let rays = rays(&positions, &raw, Vec3::ZERO, extent);
        check(&positions, &selection, &reference, &rays)?;
    }

    /// Random boxes and probes: the twin's walk of the packed octree reaches the leaf
    /// `SparseVoxelOctree::lookup` reaches, including leaves that see no probe.
    #[test]
    fn octree_selection_matches_probe_index(
        boxes in prop::collection::vec(
            (prop::array::uniform3(0.0f32..3.0), prop::array::uniform3(0.2f32..1.5)),
            1..4,
        ),
        points in prop::collection::vec(prop::array::uniform3(0.0f32..4.0), 1..12),
        depth in 2u32..=5,
        merge_unseen_leaves in any::<bool>(),
        raw in ray_samples(),
    ) {
        let boxes: Vec<(Vec3, Vec3)> = boxes
            .iter()
            .map(|(lo, size)| (Vec3::from(*lo), Vec3::from(*lo) + Vec3::from(*size)))
            .collect();
        let geometry = Boxes::new(&boxes);
        let positions: Vec<Vec3> = points.into_iter().map(Vec3::from).collect();
        let svo = SparseVoxelOctree::build(
            &geometry,
            &positions,
            &SvoOptions {
                max_depth: depth,
                merge_unseen_leaves,
                ..SvoOptions::default()
            },
        )
        .unwrap();
        let rays = rays(&positions, &raw, Vec3::ZERO, Vec3::splat(4.5));
        check(&positions, &ProbeSelection::SparseVoxelOctree(&svo), &svo, &rays)?;
    }
}
