//! Grid cages (seed 003 Alg. 6), nearest probe and Voronoi-sphere neighbours (seed 000 §4.1),
//! and the common selector interface.

mod support;

use glam::Vec3;
use probe_index::{
    GridError, NEIGHBOURS_PER_TEXEL, NO_PROBE, NearestProbe, NeighbourError, ProbeGrid, ProbeQuery,
    ProbeSelector, Tetrahedralization, VoronoiNeighbours, VoronoiSelector, next_cage_slot,
};
use support::Rng;

fn q(position: Vec3, direction: Vec3, failed_probe: Option<u32>) -> ProbeQuery {
    ProbeQuery {
        position,
        direction,
        failed_probe,
    }
}

#[test]
fn grid_cage_surrounds_the_point_or_is_the_nearest_boundary_cage() {
    let grid = ProbeGrid::new(
        Vec3::new(-1.0, 0.0, 2.0),
        Vec3::new(0.5, 1.0, 2.0),
        [4, 3, 5],
    )
    .unwrap();
    let mut rng = Rng(1);
    for _ in 0..1000 {
        let p = Vec3::new(
            rng.range(-2.0, 1.5),
            rng.range(-1.0, 3.0),
            rng.range(0.0, 12.0),
        );
        let cage = grid.cage(p);
        let lo = grid.probe_position(cage.probes[0]);
        let hi = grid.probe_position(cage.probes[7]);
        for (slot, &probe) in cage.probes.iter().enumerate() {
            let offset = Vec3::new(
                (slot & 1) as f32,
                ((slot >> 1) & 1) as f32,
                (slot >> 2) as f32,
            );
            let expected = lo + offset * Vec3::new(0.5, 1.0, 2.0);
            assert!((grid.probe_position(probe) - expected).length() < 1e-5);
        }
        // Inside the grid the point is in the cage's box; outside, its clamp is.
        let grid_lo = Vec3::new(-1.0, 0.0, 2.0);
        let grid_hi = grid_lo + Vec3::new(1.5, 2.0, 8.0);
        let c = p.clamp(grid_lo, grid_hi);
        assert!(c.cmpge(lo - 1e-5).all() && c.cmple(hi + 1e-5).all(), "{p}");
    }
}

#[test]
fn grid_first_probe_maximizes_signed_parallelness_and_next_is_plus_three() {
    let grid = ProbeGrid::new(Vec3::ZERO, Vec3::ONE, [5, 5, 5]).unwrap();
    let mut rng = Rng(2);
    for _ in 0..1000 {
        let p = rng.vec3(0.0, 4.0);
        let dir = rng.vec3(-1.0, 1.0).normalize();
        let cage = grid.cage(p);
        let score = |probe: u32| dir.dot((p - grid.probe_position(probe)).normalize());
        let best = cage
            .probes
            .iter()
            .map(|&x| score(x))
            .fold(f32::MIN, f32::max);
        let order = grid.ordered_probes(p, dir);
        assert_eq!(score(order[0]), best);
        // Signed: the first probe is behind the point (positive dot), never in front.
        assert!(score(order[0]) > 0.0);
        let mut slot = cage.probes.iter().position(|&x| x == order[0]).unwrap();
        for &probe in &order {
            assert_eq!(probe, cage.probes[slot]);
            slot = next_cage_slot(slot);
        }
        let mut sorted = order.to_vec();
        sorted.sort();
        sorted.dedup();
        assert_eq!(sorted.len(), 8);
    }
}

#[test]
fn grid_selector_continues_after_a_failed_probe() {
    let grid = ProbeGrid::new(Vec3::ZERO, Vec3::ONE, [3, 3, 3]).unwrap();
    let p = Vec3::new(0.3, 0.6, 0.2);
    let dir = Vec3::new(0.2, -1.0, 0.1).normalize();
    let first = grid.select(&q(p, dir, None));
    assert_eq!(first.as_slice(), grid.ordered_probes(p, dir));
    let failed = first.as_slice()[0];
    let next = grid.select(&q(p, dir, Some(failed)));
    assert_eq!(next.len(), 7);
    assert_eq!(next.as_slice(), &first.as_slice()[1..]);
    // A failed probe from another cell: the new cage in full Alg. 6 order.
    let far = grid.probe_index([2, 2, 2]);
    let other = grid.select(&q(p, dir, Some(far)));
    assert_eq!(other.as_slice(), first.as_slice());
    assert!(grid.select(&q(Vec3::NAN, dir, None)).is_empty());
}

#[test]
fn grid_errors() {
    assert_eq!(
        ProbeGrid::new(Vec3::ZERO, Vec3::ONE, [2, 1, 2]),
        Err(GridError::TooFewProbes { axis: 1, count: 1 })
    );
    assert!(matches!(
        ProbeGrid::new(Vec3::ZERO, Vec3::new(1.0, 0.0, 1.0), [2, 2, 2]),
        Err(GridError::BadSpacing { axis: 1, .. })
    ));
    assert!(matches!(
        ProbeGrid::new(Vec3::ZERO, Vec3::new(1.0, 1.0, f32::NAN), [2, 2, 2]),
        Err(GridError::BadSpacing { axis: 2, .. })
    ));
    assert!(matches!(
        ProbeGrid::new(Vec3::new(f32::INFINITY, 0.0, 0.0), Vec3::ONE, [2, 2, 2]),
        Err(GridError::NonFiniteOrigin { .. })
    ));
    assert!(matches!(
        ProbeGrid::new(Vec3::ZERO, Vec3::ONE, [100_000, 100_000, 2]),
        Err(GridError::TooLarge { .. })
    ));
}

#[test]
fn neighbour_maps_hold_the_nearest_delaunay_neighbours_by_direction() {
    let mut rng = Rng(4);
    let pts: Vec<Vec3> = (0..120).map(|_| rng.vec3(-3.0, 3.0)).collect();
    let t = Tetrahedralization::build(&pts).unwrap();
    let n = 8;
    let maps = VoronoiNeighbours::bake(&t, n).unwrap();
    assert_eq!(
        maps.table().len(),
        pts.len() * (n * n) as usize * NEIGHBOURS_PER_TEXEL
    );
    assert_eq!(maps.memory_bytes(), maps.table().len() * 4);
    let (offsets, ids) = t.vertex_neighbours();
    for probe in 0..pts.len() {
        let row = &ids[offsets[probe] as usize..offsets[probe + 1] as usize];
        for j in 0..n {
            for i in 0..n {
                let slots = maps.texel(probe as u32, i, j);
                // The texel's direction, decoded independently of the crate.
                let o = glam::Vec2::new(
                    (i as f32 + 0.5) / n as f32 * 2.0 - 1.0,
                    (j as f32 + 0.5) / n as f32 * 2.0 - 1.0,
                );
                let mut v = Vec3::new(o.x, o.y, 1.0 - o.x.abs() - o.y.abs());
                if v.z < 0.0 {
                    let sx = if v.x >= 0.0 { 1.0 } else { -1.0 };
                    let sy = if v.y >= 0.0 { 1.0 } else { -1.0 };
                    let (x, y) = ((1.0 - v.y.abs()) * sx, (1.0 - v.x.abs()) * sy);
                    v.x = x;
                    v.y = y;
                }
                let dir = v.normalize();
                let cos = |q: u32| (pts[q as usize] - pts[probe]).normalize().dot(dir);
                let mut expected: Vec<u32> = row.to_vec();
                expected.sort_by(|&a, &b| cos(b).total_cmp(&cos(a)).then(a.cmp(&b)));
                expected.truncate(4);
                assert_eq!(
                    &slots[..expected.len()],
                    &expected[..],
                    "probe {probe} texel {i},{j}"
                );
                assert!(slots[expected.len()..].iter().all(|&s| s == NO_PROBE));
                // The lookup by direction lands on the same texel.
                assert_eq!(maps.towards(probe as u32, dir * 3.0), slots);
            }
        }
    }
}

#[test]
fn a_lone_tetrahedron_has_three_neighbours_and_a_sentinel() {
    let pts = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z];
    let t = Tetrahedralization::build(&pts).unwrap();
    let maps = VoronoiNeighbours::bake(&t, 4).unwrap();
    for probe in 0..4u32 {
        let s = maps.texel(probe, 1, 2);
        assert_eq!(s[3], NO_PROBE);
        assert!(s[..3].iter().all(|&x| x != NO_PROBE && x != probe));
    }
    assert_eq!(maps.towards(0, Vec3::ZERO), [NO_PROBE; 4]);
    assert_eq!(
        VoronoiNeighbours::bake(&t, 0).unwrap_err(),
        NeighbourError::BadResolution { resolution: 0 }
    );
}

#[test]
fn voronoi_selector_starts_at_the_nearest_probe_then_follows_neighbour_maps() {
    let mut rng = Rng(6);
    let pts: Vec<Vec3> = (0..200).map(|_| rng.vec3(0.0, 10.0)).collect();
    let t = Tetrahedralization::build(&pts).unwrap();
    let maps = VoronoiNeighbours::bake(&t, 16).unwrap();
    let nearest = NearestProbe::new(&pts);
    let selector = VoronoiSelector {
        positions: &pts,
        nearest: &nearest,
        neighbours: &maps,
    };
    for _ in 0..300 {
        let x = rng.vec3(0.0, 10.0);
        let dir = rng.vec3(-1.0, 1.0).normalize();
        let c = selector.select(&q(x, dir, None));
        let brute = (0..pts.len())
            .min_by(|&a, &b| {
                (pts[a] - x)
                    .length_squared()
                    .total_cmp(&(pts[b] - x).length_squared())
            })
            .unwrap() as u32;
        assert_eq!(c.as_slice()[0], brute);
        // After the nearest probe fails at a point further along the ray, its neighbours towards
        // that point come next.
        let z = x + dir * 2.0;
        let next = selector.select(&q(z, dir, Some(brute)));
        let expected: Vec<u32> = maps
            .towards(brute, z - pts[brute as usize])
            .into_iter()
            .filter(|&p| p != NO_PROBE)
            .collect();
        assert_eq!(next.as_slice(), &expected[..]);
        assert!(!next.as_slice().contains(&brute));
    }
    assert!(
        selector
            .select(&q(Vec3::new(f32::NAN, 0.0, 0.0), Vec3::X, None))
            .is_empty()
    );
}

#[test]
fn flat_layouts_have_the_documented_sizes_and_grid_params_reproduce_the_cage() {
    use probe_index::{GridParams, HullFace, KdNode, SvoHeader, TetRecord};
    assert_eq!(size_of::<TetRecord>(), 80);
    assert_eq!(size_of::<HullFace>(), 32);
    assert_eq!(size_of::<KdNode>(), 16);
    assert_eq!(size_of::<SvoHeader>(), 48);
    assert_eq!(size_of::<GridParams>(), 48);
    let grid = ProbeGrid::new(
        Vec3::new(1.0, -2.0, 0.5),
        Vec3::new(0.7, 1.1, 0.3),
        [5, 4, 6],
    )
    .unwrap();
    let g = grid.gpu_params();
    let bytes: &[u8] = bytemuck::bytes_of(&g);
    assert_eq!(bytes.len(), 48);
    let mut rng = Rng(8);
    for _ in 0..500 {
        let p = Vec3::new(
            rng.range(-1.0, 6.0),
            rng.range(-4.0, 4.0),
            rng.range(-1.0, 3.0),
        );
        // What a shader does with GridParams alone.
        let counts = [g.count_x, g.count_y, g.count_z];
        let nps = (p - Vec3::from(g.origin)) / Vec3::from(g.spacing);
        let mut corner = [0u32; 3];
        for k in 0..3 {
            corner[k] = nps[k].floor().clamp(0.0, (counts[k] - 2) as f32) as u32;
        }
        let cage = grid.cage(p);
        assert_eq!(cage.corner, corner);
        for slot in 0..8u32 {
            let c = [
                corner[0] + (slot & 1),
                corner[1] + ((slot >> 1) & 1),
                corner[2] + (slot >> 2),
            ];
            let index = c[0] + g.count_x * (c[1] + g.count_y * c[2]);
            assert_eq!(cage.probes[slot as usize], index);
        }
    }
}
