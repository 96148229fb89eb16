//! Sharded bakes from the command line (issue 16): three `probes bake --shard K/3` processes
//! run at once and `probes bake-merge` joins their partial bakes into the bake an unsharded
//! run writes, byte for byte; bad shard lists are refused in one line.

mod support;

use probe_testdata::folder_contents;
use std::path::{Path, PathBuf};
use std::process::Command;
use support::{probes, stderr};

/// The bake options every run shares: the Cornell box, 3×1×2 probes at 8², adaptive sampling.
const BAKE: [&str; 12] = [
    "bake",
    "builtin:cornell",
    "--probes",
    "grid:3x1x2",
    "--res",
    "8",
    "--min-spp",
    "2",
    "--max-spp",
    "8",
    "--seed",
    "3",
];

fn bake_args<'a>(out: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut args = BAKE.to_vec();
    args.extend_from_slice(&["--out", out]);
    args.extend_from_slice(extra);
    args
}

/// Runs the three shard bakes as concurrent processes into `root/shards/shard-K`.
fn bake_three_shards(root: &Path) -> Vec<PathBuf> {
    let dirs: Vec<PathBuf> = (0..3)
        .map(|k| root.join("shards").join(format!("shard-{k}")))
        .collect();
    let children: Vec<_> = dirs
        .iter()
        .enumerate()
        .map(|(k, dir)| {
            let shard = format!("{k}/3");
            let out = dir.to_str().unwrap().to_owned();
            Command::new(env!("CARGO_BIN_EXE_probes"))
                .args(bake_args(&out, &["--shard", &shard, "--json"]))
                .output()
        })
        .collect();
    for (k, child) in children.into_iter().enumerate() {
        let output = child.expect("the probes binary runs");
        assert!(output.status.success(), "shard {k}: {}", stderr(&output));
        let report: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
        assert_eq!(report["shard"]["index"], k);
        assert_eq!(report["shard"]["total_probes"], 6);
        assert_eq!(report["probes"], 2);
    }
    dirs
}

#[test]
fn three_shard_processes_merge_into_the_unsharded_bake_byte_for_byte() {
    let root = tempfile::tempdir().unwrap();
    let whole = root.path().join("whole");
    let output = probes(&bake_args(whole.to_str().unwrap(), &[]));
    assert!(output.status.success(), "{}", stderr(&output));

    let mut dirs = bake_three_shards(root.path());
    dirs.reverse();
    let merged = root.path().join("merged");
    let mut args = vec!["bake-merge", merged.to_str().unwrap()];
    args.extend(dirs.iter().map(|d| d.to_str().unwrap()));
    args.push("--json");
    let output = probes(&args);
    assert!(output.status.success(), "{}", stderr(&output));
    let report: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
    assert_eq!(report["probes"], 6);
    assert_eq!(report["shards"], 3);

    let (a, b) = (
        folder_contents(&whole).unwrap(),
        folder_contents(&merged).unwrap(),
    );
    assert_eq!(
        a.iter().map(|f| &f.0).collect::<Vec<_>>(),
        b.iter().map(|f| &f.0).collect::<Vec<_>>()
    );
    for ((name, x), (_, y)) in a.iter().zip(&b) {
        assert!(
            x == y,
            "{name} differs between the whole and the merged bake"
        );
    }

    // A partial bake is refused where a whole bake is expected.
    let png = root.path().join("render.exr");
    let output = probes(&[
        "render",
        dirs[0].to_str().unwrap(),
        "--out",
        png.to_str().unwrap(),
    ]);
    assert!(!output.status.success());
    assert!(
        stderr(&output).contains("shard 2/3 of a sharded bake"),
        "{}",
        stderr(&output)
    );
}

#[test]
fn bad_shard_lists_are_refused_in_one_line() {
    let root = tempfile::tempdir().unwrap();
    let dirs = bake_three_shards(root.path());
    let out = root.path().join("merged");
    let refused = |args: &[&str], expect: &str| {
        let output = probes(args);
        assert!(!output.status.success(), "{args:?} succeeded");
        let text = stderr(&output);
        assert_eq!(text.lines().count(), 1, "{text}");
        assert!(text.contains(expect), "{args:?}: {text}");
        assert!(!out.exists(), "{args:?} wrote {}", out.display());
    };
    let d: Vec<&str> = dirs.iter().map(|d| d.to_str().unwrap()).collect();
    let o = out.to_str().unwrap();
    refused(&["bake-merge", o, d[0], d[2]], "1/3 of 3 missing");
    refused(&["bake-merge", o, d[0], d[1], d[2], d[1]], "given twice");
    refused(
        &["bake-merge", d[1], d[0], d[1], d[2]],
        "is the shard directory",
    );
    let other = root.path().join("other-seed");
    // The shared options with the seed (their last value) 4 instead of 3.
    let mut other_seed = bake_args(other.to_str().unwrap(), &["--shard", "1/3"]);
    assert_eq!(other_seed[BAKE.len() - 2..BAKE.len()], ["--seed", "3"]);
    other_seed[BAKE.len() - 1] = "4";
    let output = probes(&other_seed);
    assert!(output.status.success(), "{}", stderr(&output));
    refused(
        &["bake-merge", o, d[0], other.to_str().unwrap(), d[2]],
        "seed 4 vs 3",
    );
    // Bad shard specifications are refused by the parser.
    for bad in ["3/3", "x/3", "1"] {
        let output = probes(&bake_args(o, &["--shard", bad]));
        assert!(!output.status.success());
        assert!(stderr(&output).contains("--shard"), "{}", stderr(&output));
    }
    let output = probes(&bake_args(o, &["--shard", "0/7"]));
    assert!(!output.status.success());
    assert!(
        stderr(&output).contains("7 shards of 6 probes"),
        "{}",
        stderr(&output)
    );
}

/// A shard killed while it bakes leaves nothing at its destination; the re-run completes it.
#[test]
fn a_killed_shard_leaves_no_half_bake_and_reruns() {
    let root = tempfile::tempdir().unwrap();
    let dir = root.path().join("shards").join("shard-1");
    let out = dir.to_str().unwrap();
    let slow = [
        "bake",
        "builtin:cornell",
        "--probes",
        "grid:3x1x2",
        "--res",
        "128",
        "--spp",
        "64",
        "--shard",
        "1/3",
        "--out",
        out,
    ];
    let mut child = Command::new(env!("CARGO_BIN_EXE_probes"))
        .args(slow)
        .spawn()
        .expect("the probes binary runs");
    std::thread::sleep(std::time::Duration::from_millis(300));
    let _ = child.kill();
    let status = child.wait().unwrap();
    // Killed mid-bake (or, on a fast machine, after its rename): the destination is absent or
    // a whole partial bake, never a directory being written.
    if dir.exists() {
        probe_capture::PartialBake::load(&dir, None).expect("a whole shard");
    } else {
        assert!(!status.success(), "the shard succeeded but wrote nothing");
    }
    let output = probes(
        &slow[..6]
            .iter()
            .chain(&["--spp", "1", "--shard", "1/3", "--out", out])
            .copied()
            .collect::<Vec<_>>(),
    );
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(dir.join("manifest.json").is_file());
}
