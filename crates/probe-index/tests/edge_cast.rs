//! Seed 002 §3.2.2 edge ray casts, and the all-in-one index build with its report.

mod support;

use glam::Vec3;
use probe_index::{
    DelaunaySkipped, EdgeCastError, EdgeCastOptions, IndexOptions, ProbeIndex, SvoOptions,
    Tetrahedralization, insert_edge_probes,
};
use support::{Soup, box_triangles};

/// A wall at x = 0 (a thin slab) spanning far beyond the probes.
fn wall() -> Soup {
    Soup::new(box_triangles(
        Vec3::new(-0.01, -50.0, -50.0),
        Vec3::new(0.01, 50.0, 50.0),
    ))
}

fn two_clusters() -> Vec<Vec3> {
    let mut pts = Vec::new();
    for side in [-1.0f32, 1.0] {
        for y in [0.0f32, 2.0] {
            for z in [0.0f32, 2.0] {
                pts.push(Vec3::new(side * 1.5, y, z));
                pts.push(Vec3::new(side * 3.0, y + 0.5, z + 0.5));
            }
        }
    }
    pts
}

#[test]
fn probes_are_added_on_both_sides_of_a_wall_that_cuts_edges() {
    let pts = two_clusters();
    let t = Tetrahedralization::build(&pts).unwrap();
    let opts = EdgeCastOptions::default();
    let r = insert_edge_probes(&t, &wall(), &opts).unwrap();
    assert!(r.added > 0);
    assert_eq!(r.probes.len(), pts.len() + r.added);
    assert_eq!(&r.probes[..pts.len()], &pts[..]);
    assert_eq!(r.rays_cast, t.edges().len() * 2);
    assert!(r.hits >= r.added);
    let added = &r.probes[pts.len()..];
    // Each added probe is just off the wall (offset ≤ 5 % of an edge of at most ~7 m) and off
    // its surface, on the side of the ray's origin.
    for p in added {
        assert!(p.x.abs() > 0.01 && p.x.abs() < 0.4, "{p}");
    }
    assert!(added.iter().any(|p| p.x < 0.0) && added.iter().any(|p| p.x > 0.0));
    // The exclusion radius keeps added probes apart (15 % of the shortest crossing edge, 3 m).
    for (i, a) in added.iter().enumerate() {
        for b in &added[i + 1..] {
            assert!((*a - *b).length() >= 0.15 * 3.0 - 1e-4, "{a} {b}");
        }
    }
    r.tetrahedralization.validate().unwrap();
    // Edges between the original probes on opposite sides of the wall (where light leaks) are
    // mostly replaced by edges to the new probes. One pass (as in the seed) does not remove
    // them all.
    let crossing = |t: &Tetrahedralization| {
        t.edges()
            .iter()
            .filter(|&&[a, b]| {
                let (a, b) = (a as usize, b as usize);
                a < pts.len() && b < pts.len() && pts[a].x.signum() != pts[b].x.signum()
            })
            .count()
    };
    let before = crossing(&t);
    let after = crossing(&r.tetrahedralization);
    assert!(after * 2 < before, "crossing edges {before} -> {after}");
}

#[test]
fn no_geometry_no_probes() {
    let pts = two_clusters();
    let t = Tetrahedralization::build(&pts).unwrap();
    let r = insert_edge_probes(&t, &Soup::new(Vec::new()), &EdgeCastOptions::default()).unwrap();
    assert_eq!(r.added, 0);
    assert_eq!(r.hits, 0);
}

#[test]
fn grazing_hits_and_hits_near_a_probe_are_rejected() {
    // Two probes 10 m apart along x; a plane almost parallel to the edge (cos 0.05) between them.
    let pts = vec![
        Vec3::new(-5.0, 0.0, 0.0),
        Vec3::new(5.0, 0.0, 0.0),
        Vec3::new(0.0, 6.0, 0.0),
        Vec3::new(0.0, 0.0, 6.0),
    ];
    let t = Tetrahedralization::build(&pts).unwrap();
    let n = Vec3::new(0.05, (1.0f32 - 0.0025).sqrt(), 0.0); // |n·x| = 0.05
    let u = Vec3::Z * 20.0;
    let v = n.cross(Vec3::Z).normalize() * 20.0;
    let grazing = Soup::new(vec![[-u - v, u - v, u + v], [-u - v, u + v, -u + v]]);
    let hit = t.edges().iter().any(|&[a, b]| {
        use probe_index::SceneGeometry;
        let (pa, pb) = (pts[a as usize], pts[b as usize]);
        grazing
            .closest_hit(pa, (pb - pa).normalize(), (pb - pa).length())
            .is_some()
    });
    assert!(
        hit,
        "the plane must cut an edge for this test to mean anything"
    );
    let strict = EdgeCastOptions {
        min_abs_cosine: 0.1,
        ..EdgeCastOptions::default()
    };
    let r = insert_edge_probes(&t, &grazing, &strict).unwrap();
    let along_x = r.probes[4..]
        .iter()
        .filter(|p| p.y.abs() < 1.0 && p.z.abs() < 1.0)
        .count();
    assert_eq!(along_x, 0, "grazing hit on the x edge accepted");
    let loose = EdgeCastOptions {
        min_abs_cosine: 0.01,
        ..EdgeCastOptions::default()
    };
    let r = insert_edge_probes(&t, &grazing, &loose).unwrap();
    assert!(
        r.probes[4..]
            .iter()
            .any(|p| p.y.abs() < 1.0 && p.z.abs() < 1.0)
    );

    // A wall 0.5 m from probe 0 on a 10 m edge (5 %) is too close at the default 15 %.
    let near = Soup::new(box_triangles(
        Vec3::new(-4.51, -0.3, -0.3),
        Vec3::new(-4.49, 0.3, 0.3),
    ));
    let r = insert_edge_probes(&t, &near, &EdgeCastOptions::default()).unwrap();
    assert_eq!(r.added, 0);
}

#[test]
fn bad_parameters_are_refused() {
    let t = Tetrahedralization::build(&two_clusters()).unwrap();
    let run = |o: EdgeCastOptions| insert_edge_probes(&t, &wall(), &o).unwrap_err();
    assert!(matches!(
        run(EdgeCastOptions {
            min_edge_fraction: 0.5,
            ..EdgeCastOptions::default()
        }),
        EdgeCastError::BadParameter {
            name: "min_edge_fraction",
            ..
        }
    ));
    assert!(matches!(
        run(EdgeCastOptions {
            min_abs_cosine: f32::NAN,
            ..EdgeCastOptions::default()
        }),
        EdgeCastError::BadParameter {
            name: "min_abs_cosine",
            ..
        }
    ));
    assert!(matches!(
        run(EdgeCastOptions {
            surface_offset_fraction: 0.2,
            ..EdgeCastOptions::default()
        }),
        EdgeCastError::BadParameter {
            name: "surface_offset_fraction",
            ..
        }
    ));
}

#[test]
fn index_build_reports_every_structure() {
    let pts = two_clusters();
    let options = IndexOptions {
        edge_casts: Some(EdgeCastOptions::default()),
        neighbour_resolution: 8,
        svo: Some(SvoOptions {
            max_depth: 4,
            ..SvoOptions::default()
        }),
    };
    let (index, report) = ProbeIndex::build(&pts, &wall(), &options).unwrap();
    assert_eq!(report.probes_given, pts.len());
    assert_eq!(index.probes.len(), pts.len() + report.probes_added);
    assert!(report.probes_added > 0);
    assert_eq!(
        report.tetrahedra,
        index
            .tetrahedralization
            .as_ref()
            .unwrap()
            .tetrahedra()
            .len()
    );
    assert_eq!(
        report.tetrahedra_bytes,
        index.tetrahedralization.as_ref().unwrap().memory_bytes()
    );
    assert_eq!(report.neighbour_bytes, index.probes.len() * 64 * 4 * 4);
    assert_eq!(report.nearest_bytes, index.probes.len() * 16);
    let svo = report.svo.as_ref().unwrap();
    assert_eq!(svo.bytes, index.svo.as_ref().unwrap().memory_bytes());
    let text = report.to_string();
    for needle in [
        "tetrahedra",
        "edge rays",
        "voronoi neighbours",
        "svo: finest voxel",
    ] {
        assert!(text.contains(needle), "{text}");
    }
    // The Voronoi selector works over the index.
    use probe_index::{ProbeQuery, ProbeSelector};
    let c = index.voronoi_selector().unwrap().select(&ProbeQuery {
        position: Vec3::new(-1.4, 0.1, 0.1),
        direction: Vec3::Y,
        failed_probe: None,
    });
    assert_eq!(c.as_slice()[0], 0);
    // Coplanar probes span no volume: no tetrahedralization, no Voronoi neighbours, the
    // octree alone, and the report says why.
    let flat: Vec<Vec3> = (0..9)
        .map(|i| Vec3::new((i % 3) as f32, (i / 3) as f32, 0.0))
        .collect();
    let (index, report) = ProbeIndex::build(&flat, &wall(), &IndexOptions::default()).unwrap();
    assert!(index.tetrahedralization.is_none() && index.neighbours.is_none());
    assert!(index.voronoi_selector().is_none());
    assert!(index.svo.is_some());
    let skipped = report.delaunay_skipped.unwrap();
    assert_eq!(skipped, DelaunaySkipped::AllCoplanar { distinct: 9 });
    let why = skipped.to_string();
    assert!(
        why.starts_with("all 9 distinct points are coplanar"),
        "{why}"
    );
    assert!(
        report
            .to_string()
            .contains("delaunay: none (all 9 distinct points are coplanar")
    );
    // Non-finite probes and an empty set are still refused, with the stage named.
    let mut bad = flat.clone();
    bad[4].x = f32::NAN;
    let e = ProbeIndex::build(&bad, &wall(), &IndexOptions::default()).unwrap_err();
    assert!(
        e.to_string()
            .starts_with("Delaunay tetrahedralization: probe position 4 is not finite"),
        "{e}"
    );
    assert!(ProbeIndex::build(&[], &wall(), &IndexOptions::default()).is_err());
}
