//! Sharded bakes: merged shards save byte for byte as the unsharded bake; missing, duplicate
//! and mismatched shards are refused naming the directory; shard ranges partition the set.

use std::path::{Path, PathBuf};

use glam::Vec3;
use probe_capture::{
    BakeError, BakeLoadError, BakeSettings, MergeError, PartialBake, ProbeBake, Sampling, Shard,
    ShardError, bake, bake_shard, merge_shards, no_progress, probe_set_hash,
};
use probe_scene::Scene;
use probe_scene::memory::MemoryLimit;
use probe_testdata::folder_contents;
use proptest::prelude::*;

/// Adaptive sampling (so the second pass is sharded too), at a resolution that bakes in
/// milliseconds.
fn settings() -> BakeSettings {
    BakeSettings {
        resolution: 8,
        sampling: Sampling::adaptive(2, 8, 1e-4),
        moments_resolution: 4,
        irradiance_resolution: 4,
        pyramid_levels: 3,
        filter_source_resolution: 4,
        seed: 7,
        ..Default::default()
    }
}

fn cornell() -> Scene {
    Scene::builtin("cornell").unwrap()
}

/// Seven probes: three shards of 2, 2 and 3.
fn positions() -> Vec<Vec3> {
    (0..7)
        .map(|i| {
            let t = i as f32 / 6.0;
            Vec3::new(
                0.05 + 0.45 * t,
                0.1 + 0.35 * (1.0 - t),
                0.05 + 0.4 * (t * 3.0).fract(),
            )
        })
        .collect()
}

fn limit() -> MemoryLimit {
    MemoryLimit::machine()
}

/// Bakes shard `k/n` and saves it to `root/shard-k`.
fn save_shard(
    root: &Path,
    scene: &Scene,
    positions: &[Vec3],
    settings: &BakeSettings,
    (k, n): (u32, u32),
) -> PathBuf {
    let shard = Shard::new(k, n).unwrap();
    let part = bake_shard(scene, positions, shard, settings, limit(), &no_progress).unwrap();
    assert_eq!(part.shard(), shard);
    assert_eq!(part.total_probes(), positions.len());
    assert_eq!(part.bake().positions(), &positions[part.probe_range()]);
    let dir = root.join(format!("shard-{k}"));
    part.save(&dir).unwrap();
    dir
}

/// The three shards of the standard set, saved under `root`.
fn three_shards(root: &Path) -> Vec<PathBuf> {
    let scene = cornell();
    (0..3)
        .map(|k| save_shard(root, &scene, &positions(), &settings(), (k, 3)))
        .collect()
}

#[test]
fn merged_shards_save_byte_for_byte_as_the_unsharded_bake() {
    let scene = cornell();
    let positions = positions();
    let settings = settings();
    let root = tempfile::tempdir().unwrap();
    let whole = bake(&scene, &positions, &settings, &no_progress).unwrap();
    let whole_dir = root.path().join("whole");
    whole.save(&whole_dir).unwrap();

    // Shards baked in another order than their indices, merged from a shuffled list.
    let shards = root.path().join("shards");
    let mut dirs: Vec<PathBuf> = [2, 0, 1]
        .into_iter()
        .map(|k| save_shard(&shards, &scene, &positions, &settings, (k, 3)))
        .collect();
    dirs.swap(0, 1);
    let calls = std::sync::Mutex::new(Vec::new());
    let merged = merge_shards(&dirs, Some(&scene), limit(), &|done, total| {
        calls.lock().unwrap().push((done, total));
    })
    .unwrap();
    assert_eq!(calls.into_inner().unwrap(), vec![(1, 3), (2, 3), (3, 3)]);
    assert_eq!(merged, whole);
    let merged_dir = root.path().join("merged");
    merged.save(&merged_dir).unwrap();

    let (a, b) = (
        folder_contents(&whole_dir).unwrap(),
        folder_contents(&merged_dir).unwrap(),
    );
    assert_eq!(
        a.iter().map(|f| &f.0).collect::<Vec<_>>(),
        b.iter().map(|f| &f.0).collect::<Vec<_>>()
    );
    assert!(a.len() >= 7, "{} files", a.len());
    for ((name, x), (_, y)) in a.iter().zip(&b) {
        assert!(
            x == y,
            "{name} differs between the whole and the merged bake"
        );
    }
    // Shard directories hold nothing but their bake (no temporary left beside them).
    let mut names: Vec<String> = std::fs::read_dir(&shards)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, ["shard-0", "shard-1", "shard-2"]);
}

#[test]
fn a_shard_holds_its_probes_as_the_whole_bake_does() {
    let scene = cornell();
    let positions = positions();
    let settings = BakeSettings {
        sampling: Sampling::fixed(2),
        ..settings()
    };
    let whole = bake(&scene, &positions, &settings, &no_progress).unwrap();
    let shard = Shard::new(1, 3).unwrap();
    let part = bake_shard(&scene, &positions, shard, &settings, limit(), &no_progress).unwrap();
    let range = part.probe_range();
    assert_eq!(range, 2..4);
    let len = whole.layout().padded_len();
    assert_eq!(
        part.bake().radiance(),
        &whole.radiance()[range.start * len..range.end * len]
    );
    assert_eq!(part.bake().sampling(), &whole.sampling()[range.clone()]);
    // Baked alone from index 0, the same probes take other samples.
    let alone = bake(&scene, &positions[range], &settings, &no_progress).unwrap();
    assert_ne!(alone.radiance(), part.bake().radiance());
    assert_eq!(alone.distances(), part.bake().distances());
    assert_eq!(part.probe_set_hash(), probe_set_hash(&positions));

    // Saved and loaded back, it is the same partial bake; as a whole bake it is refused.
    let root = tempfile::tempdir().unwrap();
    let dir = root.path().join("shard-1");
    part.save(&dir).unwrap();
    assert_eq!(PartialBake::load(&dir, Some(&scene)).unwrap(), part);
    let refused = ProbeBake::load(&dir, Some(&scene)).unwrap_err();
    assert!(
        matches!(
            refused,
            BakeLoadError::PartialBake {
                index: 1,
                count: 3,
                start: 2,
                end: 4,
                total: 7,
                ..
            }
        ),
        "{refused:?}"
    );
    let message = refused.to_string();
    assert!(
        message.contains("shard-1") && message.contains("bake-merge"),
        "{message}"
    );
    // A re-run replaces the shard whole, leaving nothing else beside it.
    part.save(&dir).unwrap();
    assert_eq!(std::fs::read_dir(root.path()).unwrap().count(), 1);
}

#[test]
fn missing_shards_are_refused() {
    let root = tempfile::tempdir().unwrap();
    let dirs = three_shards(root.path());
    let error = merge_shards(&[&dirs[0]], None, limit(), &no_progress).unwrap_err();
    assert!(
        matches!(&error, MergeError::MissingShards { missing, count: 3, found: 1 } if missing == &[1, 2]),
        "{error:?}"
    );
    let message = error.to_string();
    assert!(
        message.contains("1/3, 2/3") && message.contains("--shard"),
        "{message}"
    );
    let empty: [PathBuf; 0] = [];
    assert!(matches!(
        merge_shards(&empty, None, limit(), &no_progress),
        Err(MergeError::NoShards)
    ));
}

#[test]
fn duplicate_shards_are_refused() {
    let root = tempfile::tempdir().unwrap();
    let dirs = three_shards(root.path());
    let copy = root.path().join("copy-of-1");
    std::fs::create_dir(&copy).unwrap();
    for (name, bytes) in folder_contents(&dirs[1]).unwrap() {
        std::fs::write(copy.join(name), bytes).unwrap();
    }
    let given = [
        dirs[0].clone(),
        dirs[1].clone(),
        copy.clone(),
        dirs[2].clone(),
    ];
    let error = merge_shards(&given, None, limit(), &no_progress).unwrap_err();
    match &error {
        MergeError::DuplicateShard { shard, path, other } => {
            assert_eq!(*shard, Shard::new(1, 3).unwrap());
            assert_eq!((path, other), (&dirs[1], &copy));
        }
        other => panic!("{other:?}"),
    }
    assert!(error.to_string().contains("copy-of-1"), "{error}");
}

#[test]
fn shards_of_another_scene_are_refused() {
    let root = tempfile::tempdir().unwrap();
    let mut dirs = three_shards(root.path());
    let boxes = Scene::builtin("boxes").unwrap();
    let other = root.path().join("other");
    dirs[2] = save_shard(&other, &boxes, &positions(), &settings(), (2, 3));
    let error = merge_shards(&dirs, None, limit(), &no_progress).unwrap_err();
    assert!(
        matches!(&error, MergeError::OtherScene { path, .. } if path == &dirs[2]),
        "{error:?}"
    );
    assert!(error.to_string().contains("boxes"), "{error}");
    // Shards of the right scene, merged for another scene, are refused too.
    let dirs = three_shards(&root.path().join("again"));
    let error = merge_shards(&dirs, Some(&boxes), limit(), &no_progress).unwrap_err();
    assert!(
        matches!(error, MergeError::Load(BakeLoadError::SceneMismatch { .. })),
        "{error:?}"
    );
}

#[test]
fn shards_with_other_settings_are_refused() {
    let root = tempfile::tempdir().unwrap();
    let mut dirs = three_shards(root.path());
    let other = root.path().join("other");
    let seed = BakeSettings {
        seed: 8,
        ..settings()
    };
    dirs[1] = save_shard(&other, &cornell(), &positions(), &seed, (1, 3));
    let error = merge_shards(&dirs, None, limit(), &no_progress).unwrap_err();
    match &error {
        MergeError::OtherSettings {
            path, difference, ..
        } => {
            assert_eq!(path, &dirs[1]);
            assert_eq!(difference, "seed 8 vs 7");
        }
        other => panic!("{other:?}"),
    }
    let spp = BakeSettings {
        sampling: Sampling::fixed(2),
        ..settings()
    };
    dirs[1] = save_shard(
        &root.path().join("spp"),
        &cornell(),
        &positions(),
        &spp,
        (1, 3),
    );
    let error = merge_shards(&dirs, None, limit(), &no_progress).unwrap_err();
    assert!(error.to_string().contains("sampling"), "{error}");
}

#[test]
fn shards_of_another_probe_set_or_split_are_refused() {
    let root = tempfile::tempdir().unwrap();
    let scene = cornell();
    let mut dirs = three_shards(root.path());
    // Same count, one position moved.
    let mut moved = positions();
    moved[0].x += 0.01;
    dirs[2] = save_shard(
        &root.path().join("moved"),
        &scene,
        &moved,
        &settings(),
        (2, 3),
    );
    let error = merge_shards(&dirs, None, limit(), &no_progress).unwrap_err();
    assert!(
        matches!(&error, MergeError::OtherProbeSet { path, total: 7, first_total: 7, .. } if path == &dirs[2]),
        "{error:?}"
    );
    // Another count.
    let mut more = positions();
    more.push(Vec3::new(0.3, 0.3, 0.3));
    dirs[2] = save_shard(
        &root.path().join("more"),
        &scene,
        &more,
        &settings(),
        (2, 3),
    );
    let error = merge_shards(&dirs, None, limit(), &no_progress).unwrap_err();
    assert!(
        matches!(
            &error,
            MergeError::OtherProbeSet {
                total: 8,
                first_total: 7,
                ..
            }
        ),
        "{error:?}"
    );
    // A shard of a split into two.
    dirs[2] = save_shard(
        &root.path().join("halves"),
        &scene,
        &positions(),
        &settings(),
        (1, 2),
    );
    let error = merge_shards(&dirs, None, limit(), &no_progress).unwrap_err();
    assert!(
        matches!(&error, MergeError::OtherShardCount { path, .. } if path == &dirs[2]),
        "{error:?}"
    );
    assert!(error.to_string().contains("1/2"), "{error}");
}

#[test]
fn whole_bakes_and_edited_shards_are_refused() {
    let root = tempfile::tempdir().unwrap();
    let scene = cornell();
    let mut dirs = three_shards(root.path());
    let whole = root.path().join("whole");
    bake(&scene, &positions(), &settings(), &no_progress)
        .unwrap()
        .save(&whole)
        .unwrap();
    let error = merge_shards(
        &[whole.clone(), dirs[1].clone()],
        None,
        limit(),
        &no_progress,
    )
    .unwrap_err();
    assert!(
        matches!(&error, MergeError::Load(BakeLoadError::NotAShard { path }) if path.starts_with(&whole)),
        "{error:?}"
    );
    assert!(matches!(
        PartialBake::load(&whole, None),
        Err(BakeLoadError::NotAShard { .. })
    ));
    // A shard whose range was edited no longer matches its index.
    let manifest = dirs[1].join(probe_capture::MANIFEST_FILE);
    let text = std::fs::read_to_string(&manifest).unwrap();
    std::fs::write(
        &manifest,
        text.replace("\"probe_start\": 2", "\"probe_start\": 1"),
    )
    .unwrap();
    let error = merge_shards(&dirs, None, limit(), &no_progress).unwrap_err();
    assert!(
        matches!(&error, MergeError::Load(BakeLoadError::InvalidManifest { path, .. }) if path == &manifest),
        "{error:?}"
    );
    std::fs::write(&manifest, &text).unwrap();
    // A shard whose positions were edited gives another probe set once joined.
    let moved = text.replacen(
        "\"positions\": [\n    [\n      ",
        "\"positions\": [\n    [\n      1",
        1,
    );
    assert_ne!(moved, text);
    std::fs::write(&manifest, moved).unwrap();
    let error = merge_shards(&dirs, None, limit(), &no_progress).unwrap_err();
    assert!(
        matches!(error, MergeError::PositionsDiffer { .. }),
        "{error:?}"
    );
    std::fs::write(&manifest, &text).unwrap();
    // A limit too small for the merged bake is refused before any map is read.
    let error = merge_shards(&dirs, None, MemoryLimit::bytes(1000), &no_progress).unwrap_err();
    assert!(matches!(error, MergeError::OverMemory(_)), "{error:?}");
    dirs.rotate_left(1);
    assert!(merge_shards(&dirs, None, limit(), &no_progress).is_ok());
}

#[test]
fn shard_specs_and_counts_are_checked() {
    assert_eq!("2/5".parse::<Shard>(), Ok(Shard::new(2, 5).unwrap()));
    assert_eq!(Shard::new(2, 5).unwrap().to_string(), "2/5");
    for bad in ["3/3", "0/0", "1", "a/b", "-1/3", "1/3/4", ""] {
        let error = bad.parse::<Shard>().unwrap_err();
        let ShardError::Invalid { text, .. } = &error else {
            panic!("{error:?}")
        };
        assert_eq!(text, bad);
    }
    let scene = cornell();
    let two = &positions()[..2];
    let shard = Shard::new(0, 3).unwrap();
    assert_eq!(
        bake_shard(&scene, two, shard, &settings(), limit(), &no_progress).unwrap_err(),
        BakeError::TooManyShards {
            shards: 3,
            probes: 2
        }
    );
    let mut bad = positions();
    bad[5] = Vec3::NAN;
    // The index named is the probe's index in the whole set, whichever shard meets it.
    assert!(matches!(
        bake_shard(&scene, &bad, shard, &settings(), limit(), &no_progress),
        Err(BakeError::InvalidPosition { probe: 5, .. })
    ));
    assert_eq!(
        bake_shard(&scene, &[], shard, &settings(), limit(), &no_progress).unwrap_err(),
        BakeError::NoProbes
    );
}

proptest! {
    #![proptest_config(ProptestConfig {
        rng_seed: proptest::test_runner::RngSeed::Fixed(1),
        ..ProptestConfig::default()
    })]
    /// The shards' ranges are contiguous, cover the set, are never empty when there are at
    /// least as many probes as shards, and differ in length by at most one.
    #[test]
    fn shard_ranges_partition_the_probes(probes in 1usize..100_000, count in 1u32..300) {
        prop_assume!(count as usize <= probes);
        let mut next = 0;
        let (mut shortest, mut longest) = (usize::MAX, 0);
        for k in 0..count {
            let range = Shard::new(k, count).unwrap().probe_range(probes);
            prop_assert_eq!(range.start, next);
            prop_assert!(!range.is_empty());
            shortest = shortest.min(range.len());
            longest = longest.max(range.len());
            next = range.end;
        }
        prop_assert_eq!(next, probes);
        prop_assert!(longest - shortest <= 1);
    }
}
