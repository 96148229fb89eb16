//! Delaunay tetrahedralization: validity on degenerate and uneven inputs, point location and
//! interpolation.

mod support;

use glam::Vec3;
use probe_index::{DelaunayError, QueryError, Tetrahedralization};
use support::{Rng, check_all, check_structure};

fn grid(nx: usize, ny: usize, nz: usize, spacing: Vec3, origin: Vec3) -> Vec<Vec3> {
    let mut pts = Vec::new();
    for z in 0..nz {
        for y in 0..ny {
            for x in 0..nx {
                pts.push(origin + Vec3::new(x as f32, y as f32, z as f32) * spacing);
            }
        }
    }
    pts
}

#[test]
fn single_tetrahedron() {
    let pts = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z];
    let t = Tetrahedralization::build(&pts).unwrap();
    assert_eq!(t.tetrahedra().len(), 1);
    assert_eq!(t.hull_faces().len(), 4);
    check_all(&t, Some(1.0 / 6.0), true);
}

#[test]
fn cube_corners_are_cospherical_and_handled_exactly() {
    let pts = grid(2, 2, 2, Vec3::ONE, Vec3::ZERO);
    let t = Tetrahedralization::build(&pts).unwrap();
    // Any triangulation of a cube without interior points has 5 or 6 tetrahedra.
    let n = t.tetrahedra().len();
    assert!(n == 5 || n == 6, "{n} tetrahedra");
    assert_eq!(t.hull_faces().len(), 12);
    check_all(&t, Some(1.0), true);
}

#[test]
fn regular_grids_from_2_to_10_per_side() {
    for n in 2..=10 {
        let spacing = Vec3::new(0.5, 1.25, 2.0);
        let pts = grid(n, n, n, spacing, Vec3::new(-3.0, 1.0, 7.5));
        let t = Tetrahedralization::build(&pts).unwrap_or_else(|e| panic!("{n}³ grid: {e}"));
        let side = (n - 1) as f64;
        let volume = side * 0.5 * side * 1.25 * side * 2.0;
        // Exhaustive empty-sphere check up to 6³ (≈1000 tets × 216 points), sampled beyond.
        check_all(&t, Some(volume), n <= 6);
        assert_eq!(t.vertex_count(), n * n * n);
        // Every hull face lies on one of the 6 box planes, and the box's 6 faces of (n−1)² squares
        // take 2 triangles each.
        assert_eq!(
            t.hull_faces().len(),
            12 * (n - 1) * (n - 1),
            "{n}³ grid hull"
        );
    }
}

#[test]
fn anisotropic_grid_with_mixed_counts() {
    let pts = grid(7, 2, 5, Vec3::new(1.0, 3.0, 0.25), Vec3::ZERO);
    let t = Tetrahedralization::build(&pts).unwrap();
    check_all(&t, Some(6.0 * 3.0 * 1.0), true);
}

#[test]
fn same_result_whatever_the_input_order() {
    // Symbolic perturbation makes the tetrahedralization unique, even on a grid.
    let pts = grid(4, 4, 4, Vec3::ONE, Vec3::ZERO);
    let canonical = |t: &Tetrahedralization, pts: &[Vec3]| {
        let mut tets: Vec<[[i32; 3]; 4]> = t
            .tetrahedra()
            .iter()
            .map(|r| {
                let mut v = r
                    .vertices
                    .map(|i| pts[i as usize].to_array().map(|x| x as i32));
                v.sort();
                v
            })
            .collect();
        tets.sort();
        tets
    };
    let a = Tetrahedralization::build(&pts).unwrap();
    let mut shuffled = pts.clone();
    let mut rng = Rng(3);
    for i in (1..shuffled.len()).rev() {
        let j = rng.below(i + 1);
        shuffled.swap(i, j);
    }
    let b = Tetrahedralization::build(&shuffled).unwrap();
    assert_eq!(canonical(&a, &pts), canonical(&b, &shuffled));
}

#[test]
fn random_points_exhaustive_small_sets() {
    let mut rng = Rng(11);
    for n in [5usize, 8, 20, 60, 150] {
        for _ in 0..4 {
            let pts: Vec<Vec3> = (0..n).map(|_| rng.vec3(-1.0, 1.0)).collect();
            let t = Tetrahedralization::build(&pts).unwrap();
            check_all(&t, Some(brute_force_hull_volume(&pts)), true);
        }
    }
}

#[test]
fn random_points_sampled_large_set() {
    let mut rng = Rng(12);
    // Corners pin the hull to the unit cube, so its volume is known.
    let mut pts = grid(2, 2, 2, Vec3::ONE, Vec3::ZERO);
    pts.extend((0..20_000).map(|_| rng.vec3(0.0, 1.0)));
    let t = Tetrahedralization::build(&pts).unwrap();
    check_all(&t, Some(1.0), false);
    assert_eq!(t.vertex_count(), pts.len());
}

#[test]
fn points_on_a_sphere() {
    let mut rng = Rng(13);
    let mut pts = Vec::new();
    while pts.len() < 200 {
        let v = rng.vec3(-1.0, 1.0);
        let l = v.length();
        if l > 0.1 && l <= 1.0 {
            pts.push(v / l * 3.0);
        }
    }
    let t = Tetrahedralization::build(&pts).unwrap();
    check_all(&t, Some(brute_force_hull_volume(&pts)), true);
    // All points are on the hull.
    let mut on_hull = vec![false; pts.len()];
    for f in t.hull_faces() {
        for &v in &f.vertices {
            on_hull[v as usize] = true;
        }
    }
    assert!(on_hull.iter().all(|&b| b));
}

#[test]
fn points_on_a_sphere_with_exact_cospherical_lattice() {
    // Integer points with x²+y²+z² = 25 (lots of exactly cospherical 5-tuples) plus the centre.
    let mut pts = vec![Vec3::ZERO];
    for x in -5i32..=5 {
        for y in -5i32..=5 {
            for z in -5i32..=5 {
                if x * x + y * y + z * z == 25 {
                    pts.push(Vec3::new(x as f32, y as f32, z as f32));
                }
            }
        }
    }
    let t = Tetrahedralization::build(&pts).unwrap();
    check_all(&t, Some(brute_force_hull_volume(&pts)), true);
}

#[test]
fn random_subsets_of_an_integer_lattice_with_duplicates() {
    // Thousands of exactly cospherical and coplanar configurations, and repeated points.
    let mut rng = Rng(31);
    for round in 0..3 {
        let n = [200, 800, 3000][round];
        let mut pts: Vec<Vec3> = (0..n)
            .map(|_| {
                Vec3::new(
                    rng.below(12) as f32,
                    rng.below(12) as f32,
                    rng.below(12) as f32,
                )
            })
            .collect();
        // Pin the corners so the hull is the lattice's box.
        pts.extend(grid(2, 2, 2, Vec3::splat(11.0), Vec3::ZERO));
        let t = Tetrahedralization::build(&pts).unwrap();
        assert!(t.duplicate_count() > 0 || n < 1000);
        check_all(&t, Some(11.0f64.powi(3)), round == 0);
    }
}

#[test]
fn points_on_the_faces_of_a_cube() {
    // Every hull face is a plane holding many points: the coplanar-hull (ghost circle) test.
    let mut rng = Rng(32);
    let mut pts = grid(2, 2, 2, Vec3::splat(4.0), Vec3::ZERO);
    for _ in 0..600 {
        let mut p = Vec3::new(
            rng.below(9) as f32,
            rng.below(9) as f32,
            rng.below(9) as f32,
        ) * 0.5;
        let axis = rng.below(3);
        p[axis] = if rng.below(2) == 0 { 0.0 } else { 4.0 };
        pts.push(p);
    }
    let t = Tetrahedralization::build(&pts).unwrap();
    check_all(&t, Some(64.0), false);
    for f in t.hull_faces() {
        // Each hull triangle lies in one face plane of the cube.
        let v = f.vertices.map(|i| pts[i as usize]);
        let on_plane =
            (0..3).any(|k| v.iter().all(|p| p[k] == v[0][k]) && (v[0][k] == 0.0 || v[0][k] == 4.0));
        assert!(on_plane, "{v:?}");
    }
}

#[test]
fn duplicates_are_merged_and_reported() {
    let mut pts = grid(3, 3, 3, Vec3::ONE, Vec3::ZERO);
    let n = pts.len();
    pts.push(pts[4]);
    pts.push(pts[0]);
    pts.push(pts[4]);
    pts.push(Vec3::new(-0.0, 0.0, -0.0)); // same as pts[0] (+0)
    let t = Tetrahedralization::build(&pts).unwrap();
    assert_eq!(t.duplicate_count(), 4);
    assert_eq!(t.vertex_count(), n);
    assert_eq!(t.vertex_of(n), 4);
    assert_eq!(t.vertex_of(n + 1), 0);
    assert_eq!(t.vertex_of(n + 2), 4);
    assert_eq!(t.vertex_of(n + 3), 0);
    assert_eq!(t.vertex_of(5), 5);
    for r in t.tetrahedra() {
        assert!(r.vertices.iter().all(|&v| (v as usize) < n));
    }
    check_all(&t, Some(8.0), true);
}

#[test]
fn near_coplanar_slivers() {
    // A flat square grid with a few points a hair above and below it.
    let mut pts = grid(6, 6, 1, Vec3::ONE, Vec3::ZERO);
    let mut rng = Rng(14);
    for _ in 0..30 {
        let mut p = rng.vec3(0.0, 5.0);
        p.z = if rng.below(2) == 0 { 1e-6 } else { -1e-6 } * (1.0 + rng.f32());
        pts.push(p);
    }
    pts.push(Vec3::new(2.5, 2.5, 1e-7));
    pts.push(Vec3::new(2.5, 2.5, -1e-7));
    let t = Tetrahedralization::build(&pts).unwrap();
    check_all(&t, Some(brute_force_hull_volume(&pts)), true);
}

#[test]
fn mixed_spacing_1e6_and_1e3() {
    // A 1e3-spaced lattice with a cluster of 1e-6-spaced points near a vertex.
    let mut pts = grid(4, 4, 4, Vec3::splat(1000.0), Vec3::ZERO);
    let c = Vec3::new(1000.0, 1000.0, 1000.0);
    for z in 0..3 {
        for y in 0..3 {
            for x in 0..3 {
                // Near 1000 an f32 step is 6e-5, so the cluster sits near the origin instead.
                pts.push(Vec3::new(x as f32, y as f32, z as f32) * 1e-6 + Vec3::splat(1e-3));
            }
        }
    }
    pts.push(c + Vec3::new(0.5, 0.25, 0.125));
    let t = Tetrahedralization::build(&pts).unwrap();
    check_all(&t, Some(3000.0f64.powi(3)), true);
    // Location works at both scales.
    let tiny = Vec3::splat(1e-3) + Vec3::splat(0.5e-6);
    let loc = t.locate(tiny).unwrap();
    assert_eq!(loc.outside_distance, 0.0);
    let p = reconstruct(&t, &loc);
    assert!((p - tiny).length() < 1e-8, "{p} vs {tiny}");
}

#[test]
fn degenerate_inputs_give_clear_errors() {
    assert!(matches!(
        Tetrahedralization::build(&[]),
        Err(DelaunayError::TooFewPoints {
            distinct: 0,
            given: 0
        })
    ));
    assert!(matches!(
        Tetrahedralization::build(&[Vec3::ZERO, Vec3::X, Vec3::Y]),
        Err(DelaunayError::TooFewPoints { distinct: 3, .. })
    ));
    assert!(matches!(
        Tetrahedralization::build(&[Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::X, Vec3::ZERO]),
        Err(DelaunayError::TooFewPoints {
            distinct: 3,
            given: 5
        })
    ));
    let line: Vec<Vec3> = (0..10).map(|i| Vec3::splat(i as f32)).collect();
    assert!(matches!(
        Tetrahedralization::build(&line),
        Err(DelaunayError::AllCollinear { distinct: 10 })
    ));
    let plane = grid(5, 5, 1, Vec3::ONE, Vec3::ZERO);
    assert!(matches!(
        Tetrahedralization::build(&plane),
        Err(DelaunayError::AllCoplanar { distinct: 25 })
    ));
    // A tilted plane (coplanar in exact arithmetic: x + y + z = 0 on integers).
    let tilted: Vec<Vec3> = (0..30)
        .map(|i| {
            let (a, b) = ((i % 6) as f32, (i / 6) as f32);
            Vec3::new(a, b, -a - b)
        })
        .collect();
    assert!(matches!(
        Tetrahedralization::build(&tilted),
        Err(DelaunayError::AllCoplanar { .. })
    ));
    let mut nan = grid(2, 2, 2, Vec3::ONE, Vec3::ZERO);
    nan[5].y = f32::NAN;
    assert!(matches!(
        Tetrahedralization::build(&nan),
        Err(DelaunayError::NonFinitePoint { index: 5, .. })
    ));
    let mut inf = grid(2, 2, 2, Vec3::ONE, Vec3::ZERO);
    inf[2].z = f32::INFINITY;
    let e = Tetrahedralization::build(&inf).unwrap_err();
    assert!(e.to_string().contains("probe position 2"), "{e}");
}

fn reconstruct(t: &Tetrahedralization, loc: &probe_index::Location) -> Vec3 {
    let mut p = glam::DVec3::ZERO;
    for (&v, &w) in loc.probes.iter().zip(&loc.weights) {
        p += t.points()[v as usize].as_dvec3() * w as f64;
    }
    p.as_vec3()
}

#[test]
fn walk_locates_points_and_weights_reconstruct_them() {
    let mut rng = Rng(21);
    let pts: Vec<Vec3> = (0..3000).map(|_| rng.vec3(-10.0, 10.0)).collect();
    let t = Tetrahedralization::build(&pts).unwrap();
    let mut start = 0;
    for _ in 0..2000 {
        let q = rng.vec3(-6.0, 6.0);
        let loc = t.locate_from(q, start).unwrap();
        start = loc.tetrahedron;
        if loc.outside_distance > 0.0 {
            continue;
        }
        assert!(loc.weights.iter().all(|&w| w >= 0.0));
        assert!((loc.weights.iter().sum::<f32>() - 1.0).abs() < 1e-5);
        assert!((reconstruct(&t, &loc) - q).length() < 1e-4);
        // The tetrahedron really contains q (exact orientation test, with slack for f32 weights).
        let r = &t.tetrahedra()[loc.tetrahedron as usize];
        let v = r.vertices.map(|i| pts[i as usize]);
        for f in 0..4 {
            let mut w = v;
            w[f] = q;
            let s = support::orient(w[0], w[1], w[2], w[3]);
            let full = support::orient(v[0], v[1], v[2], v[3]);
            assert!(s >= -1e-6 * full, "q outside tet face {f}");
        }
    }
}

#[test]
fn walk_ends_on_vertices_edges_and_faces_of_a_grid() {
    // Points exactly on grid vertices, edges and faces (the degenerate cases that loop a naive
    // walk); the visited list must stop it.
    let pts = grid(5, 5, 5, Vec3::ONE, Vec3::ZERO);
    let t = Tetrahedralization::build(&pts).unwrap();
    let mut start = 0;
    for z in 0..9 {
        for y in 0..9 {
            for x in 0..9 {
                let q = Vec3::new(x as f32, y as f32, z as f32) * 0.5;
                let loc = t.locate_from(q, start).unwrap();
                start = loc.tetrahedron;
                assert_eq!(loc.outside_distance, 0.0, "{q}");
                assert!((reconstruct(&t, &loc) - q).length() < 1e-5, "{q}");
                assert!(loc.steps as usize <= t.tetrahedra().len());
            }
        }
    }
}

#[test]
fn outside_points_get_nearest_hull_face_and_clamped_weights() {
    let pts = grid(4, 4, 4, Vec3::ONE, Vec3::ZERO); // the cube [0,3]³
    let t = Tetrahedralization::build(&pts).unwrap();
    let mut rng = Rng(5);
    for _ in 0..500 {
        let q = rng.vec3(-4.0, 7.0);
        let loc = t.locate(q).unwrap();
        let nearest = q.clamp(Vec3::ZERO, Vec3::splat(3.0));
        let expected = (q - nearest).length();
        assert!(
            (loc.outside_distance - expected).abs() < 1e-4,
            "{q}: {} vs {expected}",
            loc.outside_distance
        );
        assert!(loc.weights.iter().all(|&w| (0.0..=1.0).contains(&w)));
        assert!((loc.weights.iter().sum::<f32>() - 1.0).abs() < 1e-5);
        assert!((reconstruct(&t, &loc) - nearest).length() < 1e-4, "{q}");
    }
}

#[test]
fn interpolation_is_exact_for_linear_fields() {
    let mut rng = Rng(8);
    let pts: Vec<Vec3> = (0..500).map(|_| rng.vec3(0.0, 4.0)).collect();
    let t = Tetrahedralization::build(&pts).unwrap();
    let field = |p: Vec3| Vec3::new(2.0 * p.x - p.y + 0.5, p.z * 3.0, 1.0 - p.x);
    let values: Vec<Vec3> = pts.iter().map(|&p| field(p)).collect();
    let sh: Vec<f32> = pts
        .iter()
        .flat_map(|&p| (0..9).map(move |k| k as f32 * p.x + p.y))
        .collect();
    for _ in 0..300 {
        let q = rng.vec3(1.0, 3.0);
        let loc = t.locate(q).unwrap();
        if loc.outside_distance > 0.0 {
            continue;
        }
        let v = t.interpolate(&loc, &values).unwrap();
        assert!((v - field(q)).length() < 1e-3, "{v} vs {}", field(q));
        let mut out = [0.0f32; 9];
        t.interpolate_strided(&loc, &sh, 9, &mut out).unwrap();
        for (k, o) in out.iter().enumerate() {
            assert!((o - (k as f32 * q.x + q.y)).abs() < 1e-3);
        }
    }
    let loc = t.locate(Vec3::splat(2.0)).unwrap();
    assert!(matches!(
        t.interpolate(&loc, &values[..10]),
        Err(QueryError::ValueCountMismatch {
            expected: 500,
            got: 10
        })
    ));
    assert!(matches!(
        t.locate(Vec3::new(f32::NAN, 0.0, 0.0)),
        Err(QueryError::NonFinitePosition { .. })
    ));
}

#[test]
fn neighbour_lists_match_edges() {
    let pts = grid(3, 3, 3, Vec3::ONE, Vec3::ZERO);
    let mut with_dup = pts.clone();
    with_dup.push(pts[13]);
    let t = Tetrahedralization::build(&with_dup).unwrap();
    let (offsets, ids) = t.vertex_neighbours();
    let edges = t.edges();
    let deg: usize = (0..pts.len())
        .map(|i| (offsets[i + 1] - offsets[i]) as usize)
        .sum();
    assert_eq!(deg, edges.len() * 2);
    for &[a, b] in &edges {
        let row = |v: u32| &ids[offsets[v as usize] as usize..offsets[v as usize + 1] as usize];
        assert!(row(a).contains(&b) && row(b).contains(&a));
    }
    // The centre of a 3³ grid is a vertex of every tetrahedron around it: 26 neighbours at most.
    let dup = pts.len();
    assert_eq!(
        &ids[offsets[dup] as usize..offsets[dup + 1] as usize],
        &ids[offsets[13] as usize..offsets[14] as usize]
    );
    let _ = check_structure(&t);
}

/// Hull volume from brute force: every triple whose plane has all points on one side is a hull
/// facet (general position assumed: the random and sphere sets), and the hull volume is the sum
/// of the pyramids from the centroid. For sets with coplanar hull facets (the cospherical
/// lattice, the flat grid with slivers) facets are fan-triangulated per plane instead.
fn brute_force_hull_volume(pts: &[Vec3]) -> f64 {
    let p: Vec<glam::DVec3> = pts.iter().map(|v| v.as_dvec3()).collect();
    let n = p.len();
    let centroid = p.iter().copied().sum::<glam::DVec3>() / n as f64;
    // Group hull planes: key = the plane's point set; compute the polygon area × height / 3.
    let mut planes: Vec<Vec<usize>> = Vec::new();
    for i in 0..n {
        for j in i + 1..n {
            for k in j + 1..n {
                let (a, b, c) = (pts[i], pts[j], pts[k]);
                if (b - a).cross(c - a) == Vec3::ZERO
                    && support::orient(a, b, c, a + Vec3::X) == 0.0
                    && support::orient(a, b, c, a + Vec3::Y) == 0.0
                    && support::orient(a, b, c, a + Vec3::Z) == 0.0
                {
                    continue;
                }
                let mut pos = false;
                let mut neg = false;
                let mut on = Vec::new();
                for (m, &q) in pts.iter().enumerate() {
                    let s = support::orient(a, b, c, q);
                    if s > 0.0 {
                        pos = true;
                    } else if s < 0.0 {
                        neg = true;
                    } else {
                        on.push(m);
                    }
                    if pos && neg {
                        break;
                    }
                }
                if pos && neg || (!pos && !neg) {
                    continue;
                }
                if !planes.contains(&on) {
                    planes.push(on);
                }
            }
        }
    }
    let mut volume = 0.0;
    for on in planes {
        // Order the coplanar points around their centroid and fan them.
        let c = on.iter().map(|&m| p[m]).sum::<glam::DVec3>() / on.len() as f64;
        let a0 = p[on[0]] - c;
        let normal = (p[on[1]] - p[on[0]]).cross(p[on[2]] - p[on[0]]);
        let normal = if normal.length() > 0.0 {
            normal
        } else {
            // Find any non-collinear triple on the plane.
            let mut best = normal;
            for x in 1..on.len() {
                for y in x + 1..on.len() {
                    let cand = (p[on[x]] - p[on[0]]).cross(p[on[y]] - p[on[0]]);
                    if cand.length() > best.length() {
                        best = cand;
                    }
                }
            }
            best
        };
        let u = a0.normalize_or(normal.any_orthonormal_vector());
        let v = normal.normalize().cross(u);
        // The facet polygon is the 2-D convex hull of the coplanar points (monotone chain).
        let mut flat: Vec<(f64, f64, glam::DVec3)> = on
            .iter()
            .map(|&m| {
                let d = p[m] - c;
                (d.dot(u), d.dot(v), p[m])
            })
            .collect();
        flat.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.total_cmp(&y.1)));
        let cross = |o: &(f64, f64, glam::DVec3),
                     a: &(f64, f64, glam::DVec3),
                     b: &(f64, f64, glam::DVec3)| {
            (a.0 - o.0) * (b.1 - o.1) - (a.1 - o.1) * (b.0 - o.0)
        };
        let mut ring: Vec<(f64, f64, glam::DVec3)> = Vec::new();
        for pass in 0..2 {
            let start = ring.len();
            let iter: Vec<_> = if pass == 0 {
                flat.clone()
            } else {
                flat.iter().rev().cloned().collect()
            };
            for q in iter {
                while ring.len() >= start + 2
                    && cross(&ring[ring.len() - 2], &ring[ring.len() - 1], &q) <= 0.0
                {
                    ring.pop();
                }
                ring.push(q);
            }
            ring.pop();
        }
        for w in 0..ring.len() {
            let a = ring[w].2;
            let b = ring[(w + 1) % ring.len()].2;
            volume += ((a - centroid).cross(b - centroid).dot(c - centroid)).abs() / 6.0;
        }
    }
    volume
}
