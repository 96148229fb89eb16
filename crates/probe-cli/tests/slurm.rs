//! The Slurm recipe of issue 16 for real: `scripts/slurm/submit-bake.sh` submits three shards
//! as an array job and the merge as a job depending on it (`afterok`), on whatever Slurm
//! answers here (a single node on localhost: `scripts/slurm/local-cluster.sh start`). The
//! merged bake must equal the unsharded bake byte for byte.
//!
//! Optional: without `sbatch` or a `slurmctld` answering `scontrol ping`, the test prints why
//! and passes without running.

use probe_testdata::folder_contents;
use std::path::PathBuf;
use std::process::Command;
use std::time::{Duration, Instant};

/// Why Slurm cannot run jobs here, or `None` when it can.
fn slurm_absent() -> Option<String> {
    match Command::new("sbatch").arg("--version").output() {
        Ok(output) if output.status.success() => {}
        _ => return Some("`sbatch` is not installed (apt-get install -y slurm-wlm)".into()),
    }
    match Command::new("scontrol").arg("ping").output() {
        Ok(output)
            if output.status.success()
                && String::from_utf8_lossy(&output.stdout).contains("UP") => {}
        _ => {
            return Some(
                "no slurmctld answers `scontrol ping` (start one: scripts/slurm/local-cluster.sh start)"
                    .into(),
            );
        }
    }
    let nodes = Command::new("sinfo")
        .args(["-h", "-o", "%t"])
        .output()
        .map(|o| String::from_utf8_lossy(&o.stdout).into_owned())
        .unwrap_or_default();
    if !nodes
        .split_whitespace()
        .any(|state| matches!(state, "idle" | "mix" | "alloc" | "comp"))
    {
        return Some(format!("no Slurm node is up (sinfo states: {nodes:?})"));
    }
    None
}

const OPTIONS: [&str; 11] = [
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

#[test]
fn slurm_array_job_bakes_the_shards_and_a_dependent_job_merges_them() {
    if let Some(reason) = slurm_absent() {
        eprintln!("skipping the Slurm test: {reason}");
        return;
    }
    let shared = tempfile::tempdir().unwrap();
    let whole = shared.path().join("whole");
    let mut bake = vec!["bake"];
    bake.extend(OPTIONS);
    let output = Command::new(env!("CARGO_BIN_EXE_probes"))
        .args(&bake)
        .args(["--out", whole.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );

    let script: PathBuf = [
        env!("CARGO_MANIFEST_DIR"),
        "..",
        "..",
        "scripts",
        "slurm",
        "submit-bake.sh",
    ]
    .iter()
    .collect();
    let mut child = Command::new("bash")
        .arg(&script)
        .args(["-n", "3", "-d"])
        .arg(shared.path().join("run"))
        .args(["-b", env!("CARGO_BIN_EXE_probes"), "-w", "--"])
        .args(OPTIONS)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let deadline = Instant::now() + Duration::from_secs(600);
    while child.try_wait().unwrap().is_none() {
        assert!(
            Instant::now() < deadline,
            "the Slurm jobs did not end within 10 minutes (see squeue)"
        );
        std::thread::sleep(Duration::from_millis(200));
    }
    let output = child.wait_with_output().unwrap();
    let run = shared.path().join("run");
    let log = |name: &str| std::fs::read_to_string(run.join("logs").join(name)).unwrap_or_default();
    assert!(
        output.status.success(),
        "submit-bake.sh failed:\n{}{}\nshard 0: {}\nmerge: {}",
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr),
        log("shard-0.out"),
        log("merge.out")
    );
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        stdout.contains("array job") && stdout.contains("ended with status 0"),
        "{stdout}"
    );
    for k in 0..3 {
        assert!(
            log(&format!("shard-{k}.out")).contains(&format!("shard {k}/3")),
            "shard {k}'s log: {}",
            log(&format!("shard-{k}.out"))
        );
    }
    assert!(
        log("merge.out").contains("merged 3 shards"),
        "{}",
        log("merge.out")
    );

    let (a, b) = (
        folder_contents(&whole).unwrap(),
        folder_contents(&run.join("bake")).unwrap(),
    );
    assert_eq!(
        a.iter().map(|f| &f.0).collect::<Vec<_>>(),
        b.iter().map(|f| &f.0).collect::<Vec<_>>()
    );
    for ((name, x), (_, y)) in a.iter().zip(&b) {
        assert!(
            x == y,
            "{name} differs between the unsharded and the Slurm bake"
        );
    }
    eprintln!("Slurm: {}", stdout.trim().replace('\n', "; "));
}
