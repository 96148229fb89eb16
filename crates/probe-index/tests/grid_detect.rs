//! `ProbeGrid::detect`: which probe sets are a regular grid (cage selection applies) and which
//! are not.

use glam::Vec3;
use probe_index::ProbeGrid;

fn grid(counts: [u32; 3]) -> ProbeGrid {
    ProbeGrid::new(
        Vec3::new(-2.5, 0.125, 7.0),
        Vec3::new(0.5, 1.25, 0.75),
        counts,
    )
    .unwrap()
}

#[test]
fn a_grid_is_detected_with_its_origin_spacing_and_counts() {
    for counts in [[2, 2, 2], [4, 2, 4], [3, 5, 2], [7, 3, 6]] {
        let expected = grid(counts);
        assert_eq!(
            ProbeGrid::detect(&expected.positions()),
            Some(expected),
            "{counts:?}"
        );
    }
}

#[test]
fn uneven_spacing_is_not_a_grid() {
    // Three x values, as a 3×2×2 grid has, but the third is not one spacing on.
    let mut positions = Vec::new();
    for z in [0.0, 1.0] {
        for y in [0.0, 1.0] {
            for x in [0.0, 1.0, 3.0] {
                positions.push(Vec3::new(x, y, z));
            }
        }
    }
    assert_eq!(ProbeGrid::detect(&positions), None);
    positions.iter_mut().for_each(|p| {
        if p.x == 3.0 {
            p.x = 2.0;
        }
    });
    assert!(ProbeGrid::detect(&positions).is_some());
}

#[test]
fn a_moved_probe_is_not_a_grid() {
    let mut positions = grid([3, 2, 4]).positions();
    positions[7].y += 0.3;
    assert_eq!(ProbeGrid::detect(&positions), None);
}

#[test]
fn a_missing_or_extra_probe_is_not_a_grid() {
    let positions = grid([3, 3, 3]).positions();
    assert_eq!(ProbeGrid::detect(&positions[..26]), None);
    let mut extra = positions.clone();
    extra.push(positions[0]);
    assert_eq!(ProbeGrid::detect(&extra), None);
}

#[test]
fn another_order_is_not_this_grid() {
    // z fastest instead of x fastest: the same points, but cage indices would be wrong.
    let g = grid([2, 3, 4]);
    let mut positions = Vec::new();
    for x in 0..2 {
        for y in 0..3 {
            for z in 0..4 {
                positions.push(g.positions()[x + 2 * (y + 3 * z)]);
            }
        }
    }
    assert_eq!(ProbeGrid::detect(&positions), None);
}

#[test]
fn flat_empty_single_and_nan_sets_are_not_grids() {
    assert_eq!(ProbeGrid::detect(&[]), None);
    assert_eq!(ProbeGrid::detect(&[Vec3::ZERO]), None);
    // 2×2×1: one layer spans no volume.
    let flat: Vec<Vec3> = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)]
        .map(|(x, z)| Vec3::new(x, 0.0, z))
        .to_vec();
    assert_eq!(ProbeGrid::detect(&flat), None);
    let mut nan = grid([2, 2, 2]).positions();
    nan[3] = Vec3::NAN;
    assert_eq!(ProbeGrid::detect(&nan), None);
}
