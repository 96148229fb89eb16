//! Sparse voxel octree: structure follows the geometry, leaves rank visible probes by seed
//! 000's rules, merged layout answers like the full tree, determinism and errors.

mod support;

use glam::Vec3;
use probe_index::{
    NO_PROBE, ProbeQuery, ProbeSelector, SVO_LEAF_BIT, SceneGeometry, SparseVoxelOctree, SvoError,
    SvoOptions, triangle_overlaps_box,
};
use support::{Rng, Soup, box_triangles};

/// A 10 m room split by a wall at x = 0 with no opening, plus a pillar in the right half.
fn divided_room() -> Soup {
    let mut tris = box_triangles(Vec3::splat(-5.0), Vec3::splat(5.0));
    let a = Vec3::new(0.0, -5.0, -5.0);
    let b = Vec3::new(0.0, 5.0, -5.0);
    let c = Vec3::new(0.0, 5.0, 5.0);
    let d = Vec3::new(0.0, -5.0, 5.0);
    tris.push([a, b, c]);
    tris.push([a, c, d]);
    tris.extend(box_triangles(
        Vec3::new(2.0, -5.0, 1.0),
        Vec3::new(3.0, 5.0, 2.0),
    ));
    Soup::new(tris)
}

fn probes() -> Vec<Vec3> {
    vec![
        Vec3::new(-2.5, 0.0, 0.0),
        Vec3::new(-2.5, 3.0, -3.0),
        Vec3::new(2.5, 0.0, -2.5),
        Vec3::new(3.5, 2.0, 3.5),
        Vec3::new(1.0, -3.0, 3.0),
    ]
}

/// The full-tree leaf holding `p`, found independently: descend while triangles overlap.
fn full_leaf(scene: &Soup, svo: &SparseVoxelOctree, depth: u32, p: Vec3) -> (Vec3, Vec3, bool) {
    let h = svo.header();
    let mut lo = Vec3::from(h.origin);
    let mut size = h.size;
    for level in 0..=depth {
        let hi = lo + Vec3::splat(size);
        let overlaps = scene
            .triangles
            .iter()
            .any(|t| triangle_overlaps_box(t, lo, hi));
        if !overlaps {
            return (lo, hi, false);
        }
        if level == depth {
            return (lo, hi, true);
        }
        size *= 0.5;
        let mid = lo + Vec3::splat(size);
        lo = Vec3::select(p.cmpge(mid), mid, lo);
    }
    unreachable!()
}

/// Seed 000's ranking from the centre only (visibility_samples = 0), computed independently.
fn expected_payload(scene: &Soup, probes: &[Vec3], lo: Vec3, hi: Vec3, surface: bool) -> [u32; 4] {
    let c = (lo + hi) * 0.5;
    let normals: Vec<Vec3> = if surface {
        scene
            .triangles
            .iter()
            .filter(|t| triangle_overlaps_box(t, lo, hi))
            .map(|t| (t[1] - t[0]).cross(t[2] - t[0]).normalize())
            .collect()
    } else {
        Vec::new()
    };
    let mut scored: Vec<(f32, u32)> = probes
        .iter()
        .enumerate()
        .filter(|(_, p)| scene.segment_visible(c, **p))
        .map(|(i, p)| {
            let d = (*p - c).length();
            let s = if surface {
                normals
                    .iter()
                    .map(|n| n.dot((*p - c) / d).abs())
                    .fold(0.0, f32::max)
                    / d
            } else {
                1.0 / d
            };
            (s, i as u32)
        })
        .collect();
    scored.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    let mut out = [NO_PROBE; 4];
    for (k, (_, i)) in scored.iter().take(4).enumerate() {
        out[k] = *i;
    }
    out
}

#[test]
fn leaves_follow_the_geometry_and_rank_visible_probes() {
    let scene = divided_room();
    let probes = probes();
    let depth = 4;
    let options = SvoOptions {
        max_depth: depth,
        visibility_samples: 0,
        ..SvoOptions::default()
    };
    let svo = SparseVoxelOctree::build(&scene, &probes, &options).unwrap();
    let mut rng = Rng(9);
    let mut surface_hits = 0;
    for _ in 0..600 {
        let p = rng.vec3(-5.2, 5.2);
        let (lo, hi, surface) = full_leaf(&scene, &svo, depth, p);
        let (got, level) = svo.lookup(p);
        assert!(level <= depth);
        let want = expected_payload(&scene, &probes, lo, hi, surface);
        assert_eq!(got, want, "at {p} (leaf {lo}..{hi}, surface {surface})");
        surface_hits += surface as usize;
    }
    assert!(
        surface_hits > 50,
        "surface leaves were sampled {surface_hits} times"
    );
}

#[test]
fn the_dividing_wall_separates_the_probe_sets() {
    let scene = divided_room();
    let probes = probes();
    let svo = SparseVoxelOctree::build(
        &scene,
        &probes,
        &SvoOptions {
            max_depth: 5,
            visibility_samples: 3,
            seed: 4,
            ..SvoOptions::default()
        },
    )
    .unwrap();
    let mut rng = Rng(10);
    for _ in 0..500 {
        let mut p = rng.vec3(-4.8, 4.8);
        if p.x.abs() < 0.4 {
            p.x += 0.8 * p.x.signum();
        }
        let (leaf, _) = svo.lookup(p);
        for probe in leaf.into_iter().filter(|&x| x != NO_PROBE) {
            // Voxels of 10.01/32 m never reach across the wall by more than one voxel.
            let side = probes[probe as usize].x.signum();
            assert_eq!(side, p.x.signum(), "probe {probe} chosen at {p}");
        }
    }
    // A point in the left half with both left probes visible gets exactly those two.
    let (leaf, _) = svo.lookup(Vec3::new(-2.0, 1.0, -1.0));
    assert_eq!(leaf[2..], [NO_PROBE, NO_PROBE]);
    let mut left: Vec<u32> = leaf[..2].to_vec();
    left.sort();
    assert_eq!(left, vec![0, 1]);
}

#[test]
fn flat_layout_is_consistent_and_smaller_than_the_full_tree() {
    let scene = divided_room();
    let probes = probes();
    let svo = SparseVoxelOctree::build(
        &scene,
        &probes,
        &SvoOptions {
            max_depth: 5,
            ..SvoOptions::default()
        },
    )
    .unwrap();
    let s = svo.stats();
    let h = svo.header();
    assert_eq!(h.node_count as usize, svo.nodes().len());
    assert_eq!(h.leaf_count as usize, svo.leaves().len());
    assert_eq!(
        svo.memory_bytes(),
        32 + svo.nodes().len() * 4 + svo.leaves().len() * 16
    );
    assert!(s.nodes < s.full_nodes, "{} vs {}", s.nodes, s.full_nodes);
    assert!(s.bytes < s.full_bytes);
    assert!(s.surface_leaves > 0 && s.empty_leaves > 0);
    assert!((s.finest_voxel_size - h.size / 32.0).abs() < 1e-6);
    // Every internal word points to 8 in-range children; every leaf word to a payload.
    for &w in svo.nodes() {
        if w & SVO_LEAF_BIT != 0 {
            assert!(((w & !SVO_LEAF_BIT) as usize) < svo.leaves().len());
        } else {
            assert!(w as usize + 8 <= svo.nodes().len() && w > 0);
        }
    }
    // Payloads are unique.
    let mut p = svo.leaves().to_vec();
    p.sort();
    p.dedup();
    assert_eq!(p.len(), svo.leaves().len());
    // bytemuck views for upload.
    let bytes: &[u8] = bytemuck::cast_slice(std::slice::from_ref(svo.header()));
    assert_eq!(bytes.len(), 32);
}

#[test]
fn deterministic_for_a_seed() {
    let scene = divided_room();
    let probes = probes();
    let opts = SvoOptions {
        max_depth: 4,
        visibility_samples: 6,
        seed: 77,
        ..SvoOptions::default()
    };
    let a = SparseVoxelOctree::build(&scene, &probes, &opts).unwrap();
    let b = SparseVoxelOctree::build(&scene, &probes, &opts).unwrap();
    assert_eq!(a.nodes(), b.nodes());
    assert_eq!(a.leaves(), b.leaves());
}

#[test]
fn empty_scene_is_one_leaf_sorted_by_distance() {
    let scene = Soup::new(Vec::new());
    let probes = probes();
    let svo = SparseVoxelOctree::build(&scene, &probes, &SvoOptions::default()).unwrap();
    assert_eq!(svo.nodes().len(), 1);
    let (leaf, level) = svo.lookup(Vec3::ZERO);
    assert_eq!(level, 0);
    let h = svo.header();
    let c = Vec3::from(h.origin) + Vec3::splat(h.size * 0.5);
    let mut order: Vec<u32> = (0..probes.len() as u32).collect();
    order.sort_by(|&a, &b| {
        (probes[a as usize] - c)
            .length()
            .total_cmp(&(probes[b as usize] - c).length())
    });
    assert_eq!(leaf.to_vec(), order[..4].to_vec());
}

#[test]
fn selector_skips_the_failed_probe() {
    let scene = divided_room();
    let probes = probes();
    let svo = SparseVoxelOctree::build(
        &scene,
        &probes,
        &SvoOptions {
            max_depth: 4,
            ..SvoOptions::default()
        },
    )
    .unwrap();
    let p = Vec3::new(-2.0, 1.0, -1.0);
    let q = |failed| ProbeQuery {
        position: p,
        direction: Vec3::X,
        failed_probe: failed,
    };
    let all = svo.select(&q(None));
    assert!(!all.is_empty());
    let first = all.as_slice()[0];
    let rest = svo.select(&q(Some(first)));
    assert_eq!(rest.as_slice(), &all.as_slice()[1..]);
    assert!(
        svo.select(&ProbeQuery {
            position: Vec3::NAN,
            direction: Vec3::X,
            failed_probe: None
        })
        .is_empty()
    );
}

#[test]
fn errors_name_the_problem() {
    let scene = divided_room();
    let probes = probes();
    let build = |p: &[Vec3], o: SvoOptions| SparseVoxelOctree::build(&scene, p, &o).unwrap_err();
    assert_eq!(
        build(
            &probes,
            SvoOptions {
                max_depth: 0,
                ..SvoOptions::default()
            }
        ),
        SvoError::BadDepth { depth: 0 }
    );
    assert_eq!(
        build(
            &probes,
            SvoOptions {
                max_depth: 16,
                ..SvoOptions::default()
            }
        ),
        SvoError::BadDepth { depth: 16 }
    );
    assert_eq!(build(&[], SvoOptions::default()), SvoError::NoProbes);
    assert_eq!(
        build(
            &probes,
            SvoOptions {
                max_candidates: 0,
                ..SvoOptions::default()
            }
        ),
        SvoError::NoCandidates
    );
    let mut bad = probes.clone();
    bad[3] = Vec3::new(0.0, f32::NAN, 0.0);
    assert!(matches!(
        build(&bad, SvoOptions::default()),
        SvoError::NonFiniteProbe { index: 3, .. }
    ));
    let mut tris = box_triangles(Vec3::ZERO, Vec3::ONE);
    tris[5][1].z = f32::INFINITY;
    let e =
        SparseVoxelOctree::build(&Soup::new(tris), &probes, &SvoOptions::default()).unwrap_err();
    assert_eq!(e, SvoError::NonFiniteTriangle { index: 5 });
}
