//! Sparse voxel octree: structure follows the geometry, leaves rank visible probes by seed
//! 000's rules, merged layout answers like the full tree, determinism and errors.

mod support;

use glam::Vec3;
use probe_index::{
    NO_PROBE, ProbeQuery, ProbeSelector, SVO_LEAF_BIT, SVO_PACKED_BIT, SparseVoxelOctree, SvoError,
    SvoOptions,
};
use support::{Rng, Soup, box_triangles, expected_payload, full_leaf, normals_in};

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

#[test]
fn leaves_follow_the_geometry_and_rank_visible_probes() {
    let scene = divided_room();
    let probes = probes();
    let depth = 4;
    // Seed 000's rules to the letter: no surface shell, no merging of unseen voxels.
    let options = SvoOptions {
        max_depth: depth,
        visibility_samples: 0,
        surface_shell_levels: 0,
        merge_unseen_leaves: false,
        ..SvoOptions::default()
    };
    let svo = SparseVoxelOctree::build(&scene, &probes, &options).unwrap();
    let mut rng = Rng(9);
    let mut surface_hits = 0;
    for _ in 0..600 {
        let p = rng.vec3(-5.2, 5.2);
        let leaf = full_leaf(&scene, &svo, depth, p);
        let (got, level) = svo.lookup(p);
        assert!(level <= leaf.level);
        let normals = if leaf.surface {
            normals_in(&scene, leaf.lo, leaf.hi)
        } else {
            Vec::new()
        };
        let want = expected_payload(&scene, &probes, leaf.lo, leaf.hi, &normals, leaf.surface);
        assert_eq!(
            got, want,
            "at {p} (leaf {}..{}, surface {})",
            leaf.lo, leaf.hi, leaf.surface
        );
        surface_hits += leaf.surface as usize;
    }
    assert!(
        surface_hits > 50,
        "surface leaves were sampled {surface_hits} times"
    );
}

#[test]
fn default_options_rank_the_surface_shell_and_only_merge_unseen_voxels() {
    let scene = divided_room();
    let probes = probes();
    let depth = 5;
    let options = SvoOptions {
        max_depth: depth,
        visibility_samples: 0,
        ..SvoOptions::default()
    };
    assert_eq!(
        (options.surface_shell_levels, options.merge_unseen_leaves),
        (3, true)
    );
    let svo = SparseVoxelOctree::build(&scene, &probes, &options).unwrap();
    let strict = SparseVoxelOctree::build(
        &scene,
        &probes,
        &SvoOptions {
            surface_shell_levels: 0,
            merge_unseen_leaves: false,
            ..options.clone()
        },
    )
    .unwrap();
    assert!(svo.memory_bytes() < strict.memory_bytes());
    let mut rng = Rng(19);
    let (mut shell_hits, mut unseen_hits) = (0, 0);
    for _ in 0..600 {
        let p = rng.vec3(-5.2, 5.2);
        let leaf = full_leaf(&scene, &svo, depth, p);
        // The 3 finest levels: empty leaves 1, 2 or 4 finest voxels wide.
        let in_shell = !leaf.surface && leaf.level > 0 && leaf.level + 3 > depth;
        let normals = if leaf.surface {
            normals_in(&scene, leaf.lo, leaf.hi)
        } else if in_shell {
            normals_in(&scene, leaf.parent.0, leaf.parent.1)
        } else {
            Vec::new()
        };
        let want = expected_payload(&scene, &probes, leaf.lo, leaf.hi, &normals, leaf.surface);
        let (got, _) = svo.lookup(p);
        if want[0] == NO_PROBE {
            unseen_hits += 1; // any sibling's payload may stand in
        } else {
            assert_eq!(got, want, "at {p}");
        }
        shell_hits += in_shell as usize;
    }
    assert!(
        shell_hits > 20 && unseen_hits > 0,
        "{shell_hits} {unseen_hits}"
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
    assert_eq!(h.packed_bits, 8, "{} payloads", svo.leaves().len());
    assert_eq!(h.block_count as usize * 2, svo.blocks().len());
    assert!(!svo.blocks().is_empty());
    assert_eq!(
        svo.memory_bytes(),
        48 + svo.nodes().len() * 4 + svo.blocks().len() * 4 + svo.leaves().len() * 16
    );
    assert!(s.nodes < s.full_nodes, "{} vs {}", s.nodes, s.full_nodes);
    assert!(s.bytes < s.full_bytes);
    assert!(s.surface_leaves > 0 && s.empty_leaves > 0);
    assert!((s.finest_voxel_size - h.size / 32.0).abs() < 1e-6);
    // Every word points in range: leaves to payloads, packed blocks to blocks of 8 payload
    // ids, internal words to 8 children.
    for &w in svo.nodes() {
        if w & SVO_LEAF_BIT != 0 {
            assert!(((w & !SVO_LEAF_BIT) as usize) < svo.leaves().len());
        } else if w & SVO_PACKED_BIT != 0 {
            let b = w & !SVO_PACKED_BIT;
            assert!(b < h.block_count);
            for c in 0..8 {
                // The shader's formula, written out: 8-bit ids, 4 per word, 2 words per block.
                let word = svo.blocks()[b as usize * 2 + c / 4];
                let id = (word >> (8 * (c % 4))) & 0xFF;
                assert_eq!(id, svo.packed_child(b, c));
                assert!((id as usize) < svo.leaves().len());
            }
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
    assert_eq!(bytes.len(), 48);
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
