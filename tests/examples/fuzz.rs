//! A seeded mutation fuzzer for the readers that take files from users, on the stable
//! toolchain (cargo-fuzz needs nightly).
//!
//! ```text
//! cargo run -p probe-tests --example fuzz -- TARGET SECONDS [SEED] [OUT_DIR]
//! ```
//!
//! Targets:
//! - `gltf`: `Scene::load` on every `.gltf`/`.glb` under the shared scenes (with their `.bin`
//!   and image files beside them), mutating the JSON, the GLB or a side file;
//! - `bake`: `ProbeBake::load` on a small bake of `builtin:cornell` made here (manifest and
//!   the six EXR files mutated);
//! - `probes`: `ProbeSet::from_json` on `probes/1` files made here;
//! - `octa`: `probe_octa::decode` (and the snorm decoders, the padded map's sampling) and
//!   `split_ray` on arbitrary `f32` bit patterns, checking their documented guarantees.
//!
//! Every random choice comes from one seeded generator: the same seed gives the same inputs.
//! Mutations: bit flips, interesting bytes, inserted, deleted and duplicated ranges, splices
//! from other corpus entries, and JSON-aware ones (numbers replaced by boundary values,
//! tokens deleted or duplicated). An input whose outcome (its error message with the digits
//! removed) is new joins the corpus, a crude stand-in for coverage feedback.
//!
//! A panic is caught, its input saved under `OUT_DIR/crashes/` and the run goes on. An input
//! that runs longer than the per-input timeout is saved under `OUT_DIR/hangs/` and the
//! process exits with status 3. Before each execution the input is written to
//! `OUT_DIR/current/` so that an abort (allocation failure under `ulimit -v`, stack
//! overflow) leaves it behind for `scripts/fuzz.sh`, which restarts the run with the next
//! seed. At the end one JSON line gives the executions and findings.

use probe_capture::{BakeSettings, ProbeBake, Sampling, bake};
use probe_octa::{OctaMap, decode, decode_snorm8, decode_snorm16, encode, split_ray};
use probe_place::ProbeSet;
use probe_scene::Scene;
use std::collections::{BTreeMap, HashSet};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// SplitMix64: small, fast, seeded.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn below(&mut self, n: usize) -> usize {
        if n == 0 {
            0
        } else {
            (self.next() % n as u64) as usize
        }
    }
    fn chance(&mut self, p: f64) -> bool {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64 * 1.0 < p
    }
}

/// One fuzz input: a set of named files (the first is the one loaded).
#[derive(Clone)]
struct Case {
    files: Vec<(String, Vec<u8>)>,
}

const INTERESTING_BYTES: &[u8] = &[0, 1, 0x7f, 0x80, 0xff, b'"', b'{', b'}', b'[', b']', b','];
const INTERESTING_NUMBERS: &[&str] = &[
    "0",
    "-1",
    "1",
    "2",
    "3",
    "255",
    "65535",
    "4294967295",
    "4294967296",
    "18446744073709551615",
    "9007199254740993",
    "1e38",
    "1e39",
    "-1e39",
    "1e308",
    "1e309",
    "-0",
    "0.5",
    "NaN",
    "null",
    "5120",
    "5121",
    "5123",
    "5125",
    "5126",
    "34962",
    "34963",
    "1024",
    "2048",
    "1073741824",
];

fn mutate_bytes(rng: &mut Rng, data: &mut Vec<u8>, donors: &[&[u8]]) {
    let len = data.len();
    match rng.below(8) {
        0 if len > 0 => {
            let i = rng.below(len);
            data[i] ^= 1 << rng.below(8);
        }
        1 if len > 0 => {
            let i = rng.below(len);
            data[i] = INTERESTING_BYTES[rng.below(INTERESTING_BYTES.len())];
        }
        2 => {
            let i = rng.below(len + 1);
            let n = 1 + rng.below(8);
            let bytes: Vec<u8> = (0..n).map(|_| rng.next() as u8).collect();
            data.splice(i..i, bytes);
        }
        3 if len > 0 => {
            let i = rng.below(len);
            let span = if rng.chance(0.1) { 4096 } else { 16 };
            let n = (1 + rng.below(span)).min(len - i);
            data.drain(i..i + n);
        }
        4 if len > 0 => {
            let i = rng.below(len);
            let n = (1 + rng.below(64)).min(len - i);
            let copy = data[i..i + n].to_vec();
            let at = rng.below(len + 1);
            data.splice(at..at, copy);
        }
        5 if !donors.is_empty() => {
            let donor = donors[rng.below(donors.len())];
            if !donor.is_empty() {
                let i = rng.below(donor.len());
                let n = (1 + rng.below(256)).min(donor.len() - i);
                let at = rng.below(len + 1);
                let cut = (1 + rng.below(256)).min(len - at);
                data.splice(at..at + cut, donor[i..i + n].iter().copied());
            }
        }
        6 if len >= 4 => {
            // A little-endian u32/f32 word set to a boundary value.
            let i = rng.below(len - 3);
            let words: [u32; 8] = [
                0,
                u32::MAX,
                0x7fc0_0000,
                0x7f80_0000,
                0xff80_0000,
                0x8000_0000,
                0x4000_0000,
                1 << rng.below(32),
            ];
            data[i..i + 4].copy_from_slice(&words[rng.below(words.len())].to_le_bytes());
        }
        7 if len > 0 => {
            // Truncation.
            data.truncate(rng.below(len));
        }
        _ => {}
    }
}

/// Byte ranges of the JSON number tokens (and `true`/`false`/`null`) in `text`.
fn json_tokens(text: &[u8]) -> Vec<(usize, usize)> {
    let mut tokens = Vec::new();
    let mut i = 0;
    let mut in_string = false;
    while i < text.len() {
        let c = text[i];
        if in_string {
            if c == b'\\' {
                i += 1;
            } else if c == b'"' {
                in_string = false;
            }
            i += 1;
            continue;
        }
        if c == b'"' {
            in_string = true;
            i += 1;
            continue;
        }
        if c == b'-' || c.is_ascii_digit() || c.is_ascii_alphabetic() {
            let start = i;
            while i < text.len()
                && (text[i].is_ascii_alphanumeric() || matches!(text[i], b'-' | b'+' | b'.'))
            {
                i += 1;
            }
            tokens.push((start, i));
            continue;
        }
        i += 1;
    }
    tokens
}

fn mutate_json(rng: &mut Rng, data: &mut Vec<u8>) {
    let tokens = json_tokens(data);
    if tokens.is_empty() {
        return;
    }
    let (start, end) = tokens[rng.below(tokens.len())];
    match rng.below(4) {
        0 | 1 => {
            let value = INTERESTING_NUMBERS[rng.below(INTERESTING_NUMBERS.len())];
            data.splice(start..end, value.bytes());
        }
        2 => {
            // Off by a little: the token's integer ± 1..3.
            let text = String::from_utf8_lossy(&data[start..end]).into_owned();
            if let Ok(value) = text.parse::<i64>() {
                let delta = [-3i64, -2, -1, 1, 2, 3][rng.below(6)];
                let replaced = value.saturating_add(delta).to_string();
                data.splice(start..end, replaced.bytes());
            }
        }
        _ => {
            // Copy another token over this one.
            let (s2, e2) = tokens[rng.below(tokens.len())];
            let other = data[s2..e2].to_vec();
            data.splice(start..end, other);
        }
    }
}

fn is_json(name: &str) -> bool {
    name.ends_with(".gltf") || name.ends_with(".json")
}

fn mutate(rng: &mut Rng, case: &Case, corpus: &[Case]) -> Case {
    let mut case = case.clone();
    // The loaded file most of the time; a side file otherwise.
    let which = if case.files.len() > 1 && rng.chance(0.3) {
        1 + rng.below(case.files.len() - 1)
    } else {
        0
    };
    let donors: Vec<&[u8]> = corpus
        .iter()
        .filter_map(|c| c.files.get(which).map(|f| f.1.as_slice()))
        .collect();
    let json = is_json(&case.files[which].0);
    let rounds = 1 + rng.below(4);
    for _ in 0..rounds {
        let data = &mut case.files[which].1;
        if json && rng.chance(0.6) {
            mutate_json(rng, data);
        } else {
            mutate_bytes(rng, data, &donors);
        }
    }
    case
}

/// A fuzz target: sets itself up, then runs one case, returning its outcome as text
/// (`ok` or the error message); panics are what the fuzzer looks for.
trait Target {
    fn seeds(&self) -> Vec<Case>;
    fn run(&self, case: &Case) -> String;
    fn timeout(&self) -> Duration;
}

/// Writes the case's files into `dir`.
fn write_case(dir: &Path, case: &Case) {
    for (name, bytes) in &case.files {
        let path = dir.join(name);
        if let Some(parent) = path.parent() {
            std::fs::create_dir_all(parent).expect("fuzz work directory");
        }
        std::fs::write(&path, bytes).expect("fuzz work directory");
    }
}

struct GltfTarget {
    work: PathBuf,
}

impl GltfTarget {
    /// Side files (buffers and images with relative URIs) of a `.gltf`, by URI.
    fn side_files(text: &[u8]) -> Vec<String> {
        let Ok(json) = serde_json::from_slice::<serde_json::Value>(text) else {
            return Vec::new();
        };
        let mut uris = Vec::new();
        for key in ["buffers", "images"] {
            for item in json
                .get(key)
                .and_then(|v| v.as_array())
                .into_iter()
                .flatten()
            {
                if let Some(uri) = item.get("uri").and_then(|u| u.as_str())
                    && !uri.starts_with("data:")
                {
                    uris.push(uri.to_owned());
                }
            }
        }
        uris
    }
}

fn find_scene_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    let mut entries: Vec<PathBuf> = entries.filter_map(|e| e.ok().map(|e| e.path())).collect();
    entries.sort();
    for path in entries {
        if path.is_dir() {
            find_scene_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "gltf" || e == "glb") {
            out.push(path);
        }
    }
}

impl Target for GltfTarget {
    fn seeds(&self) -> Vec<Case> {
        let mut paths = Vec::new();
        find_scene_files(&probe_testdata::scenes_dir(), &mut paths);
        // The loader's own hand-made test files and earlier fuzz findings, when present.
        let extra = Path::new(env!("CARGO_MANIFEST_DIR")).join("../crates/probe-scene/tests/data");
        find_scene_files(&extra, &mut paths);
        let mut cases = Vec::new();
        for path in paths {
            let bytes = std::fs::read(&path).expect("seed file");
            let extension = path.extension().unwrap().to_string_lossy().into_owned();
            let mut files = vec![(format!("input.{extension}"), bytes.clone())];
            if extension == "gltf" {
                for uri in Self::side_files(&bytes) {
                    let side = path.parent().unwrap().join(&uri);
                    match std::fs::read(&side) {
                        // Large side files (Sponza's and the breakfast room's buffers)
                        // travel unmutated: they are copied once per seed below.
                        Ok(data) => files.push((uri, data)),
                        Err(_) => continue,
                    }
                }
            }
            eprintln!("seed {} ({} files)", path.display(), files.len());
            cases.push(Case { files });
        }
        cases
    }

    fn run(&self, case: &Case) -> String {
        write_case(&self.work, case);
        let outcome = match Scene::load(self.work.join(&case.files[0].0)) {
            Ok(scene) => {
                // Touch what a user of the scene touches.
                let bounds = scene.bounds();
                assert!(
                    scene
                        .triangles()
                        .iter()
                        .all(|t| t.positions.iter().all(|p| p.is_finite())),
                    "a loaded scene holds a non-finite position"
                );
                assert!(bounds.min.is_finite() || scene.triangles().is_empty());
                let _ = scene.content_hash();
                format!("ok {} warnings", scene.warnings().len())
            }
            Err(error) => error.to_string(),
        };
        // Leave the directory as the next case expects it: without this case's files.
        for (name, _) in &case.files {
            let _ = std::fs::remove_file(self.work.join(name));
        }
        outcome
    }

    fn timeout(&self) -> Duration {
        Duration::from_secs(30)
    }
}

struct BakeTarget {
    work: PathBuf,
    scene: Scene,
}

impl Target for BakeTarget {
    fn seeds(&self) -> Vec<Case> {
        let positions = [
            glam::Vec3::new(-0.5, 1.0, 0.0),
            glam::Vec3::new(0.5, 1.2, 0.2),
        ];
        let settings = BakeSettings {
            resolution: 8,
            sampling: Sampling::fixed(2),
            bounces: 1,
            seed: 7,
            pyramid_levels: 4,
            moments_resolution: 4,
            irradiance_resolution: 4,
            filter_source_resolution: 8,
            ..BakeSettings::default()
        };
        let baked = bake(&self.scene, &positions, &settings, &|_, _| {}).expect("seed bake");
        let dir = self.work.join("seed");
        baked.save(&dir).expect("seed bake saved");
        let mut names: Vec<String> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        // The manifest first: it is what `run` mutates most.
        names.sort_by_key(|n| n != "manifest.json");
        let files = names
            .iter()
            .map(|n| (n.clone(), std::fs::read(dir.join(n)).unwrap()))
            .collect();
        vec![Case { files }]
    }

    fn run(&self, case: &Case) -> String {
        let dir = self.work.join("case");
        write_case(&dir, case);
        let with_scene = match ProbeBake::load(&dir, Some(&self.scene)) {
            Ok(bake) => {
                assert_eq!(bake.positions().len(), bake.probe_count());
                "ok".to_owned()
            }
            Err(error) => error.to_string(),
        };
        let without = match ProbeBake::load(&dir, None) {
            Ok(_) => "ok".to_owned(),
            Err(error) => error.to_string(),
        };
        format!("{with_scene} | {without}")
    }

    fn timeout(&self) -> Duration {
        Duration::from_secs(20)
    }
}

struct ProbesTarget;

impl Target for ProbesTarget {
    fn seeds(&self) -> Vec<Case> {
        let scene = Scene::builtin("cornell").expect("builtin scene");
        let mut cases = Vec::new();
        for spec in ["grid:2x2x2", "grid:3x1x2"] {
            let set = ProbeSet::from_spec(spec, &scene).expect("grid");
            cases.push(Case {
                files: vec![("probes.json".into(), set.to_json().unwrap().into_bytes())],
            });
        }
        let plain = ProbeSet::new(vec![glam::Vec3::new(0.25, 1.0, -0.5)]);
        cases.push(Case {
            files: vec![("probes.json".into(), plain.to_json().unwrap().into_bytes())],
        });
        cases
    }

    fn run(&self, case: &Case) -> String {
        let text = String::from_utf8_lossy(&case.files[0].1);
        match ProbeSet::from_json(&text) {
            Ok(set) => {
                // What is read is written back (finite positions) and reads the same.
                let again = set.to_json().expect("a read probe set writes back");
                let back = ProbeSet::from_json(&again).expect("a written probe set reads");
                assert_eq!(back.positions, set.positions, "probes/1 round trip");
                format!("ok {}", set.len())
            }
            Err(error) => error.to_string(),
        }
    }

    fn timeout(&self) -> Duration {
        Duration::from_secs(5)
    }
}

struct OctaTarget {
    map: OctaMap<f32>,
}

fn floats(bytes: &[u8]) -> Vec<f32> {
    bytes
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect()
}

impl Target for OctaTarget {
    fn seeds(&self) -> Vec<Case> {
        let values: &[&[f32]] = &[
            &[
                0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 0.3, -0.7,
            ],
            &[
                1.0, 2.0, 3.0, -1.0, 0.5, 0.5, 0.0, 1.0, 0.0, 0.0, 10.0, 0.9, 0.9,
            ],
            &[
                1e30,
                -1e30,
                0.0,
                -1e30,
                1e30,
                1e-30,
                1.0,
                -1.0,
                1e-38,
                f32::NEG_INFINITY,
                f32::INFINITY,
                1.5,
                -1.5,
            ],
            &[
                0.0,
                0.0,
                0.0,
                1.0,
                1.0,
                1.0,
                -1.0,
                -1.0,
                -1.0,
                0.0,
                f32::MAX,
                -0.0,
                0.0,
            ],
        ];
        values
            .iter()
            .map(|v| Case {
                files: vec![(
                    "floats.bin".into(),
                    v.iter().flat_map(|f| f.to_le_bytes()).collect(),
                )],
            })
            .collect()
    }

    fn run(&self, case: &Case) -> String {
        let f = floats(&case.files[0].1);
        let get = |i: usize| f.get(i).copied().unwrap_or(0.0);
        let unit = |v: glam::Vec3, what: &str| {
            assert!(
                v.is_finite() && (v.length() - 1.0).abs() < 1e-4,
                "{what} is not a unit vector: {v:?}"
            );
        };
        let octa = glam::Vec2::new(get(11), get(12));
        let direction = decode(octa);
        unit(direction, "decode");
        let bits = case.files[0].1.first().copied().unwrap_or(0);
        unit(
            decode_snorm8([bits as i8, get(12).to_bits() as i8]),
            "decode_snorm8",
        );
        unit(
            decode_snorm16([get(11).to_bits() as i16, get(12).to_bits() as i16]),
            "decode_snorm16",
        );
        let any = glam::Vec3::new(get(0), get(1), get(2));
        let e = encode(any);
        assert!(
            e.is_finite() && e.abs().max_element() <= 1.0,
            "encode({any:?}) = {e:?} leaves [-1, 1]²"
        );
        let sampled = self.map.sample_octa(octa);
        assert!(sampled.is_finite(), "sample_octa({octa:?}) = {sampled}");
        let _ = self.map.sample(any);
        let _ = self.map.sample_nearest(any);

        let probe = glam::Vec3::new(get(0), get(1), get(2));
        let origin = glam::Vec3::new(get(3), get(4), get(5));
        let ray = glam::Vec3::new(get(6), get(7), get(8));
        let (t_min, t_max) = (get(9), get(10));
        match split_ray(probe, origin, ray, t_min, t_max) {
            Ok(segments) => {
                assert!(
                    (1..=4).contains(&segments.len()),
                    "{} segments",
                    segments.len()
                );
                assert_eq!(segments[0].t_start, t_min, "first piece starts at t_min");
                assert_eq!(
                    segments[segments.len() - 1].t_end,
                    t_max,
                    "last piece ends at t_max"
                );
                for pair in segments.windows(2) {
                    assert_eq!(pair[0].t_end, pair[1].t_start, "pieces are contiguous");
                }
                for s in segments.iter() {
                    assert!(s.t_end >= s.t_start, "a piece runs backwards: {s:?}");
                    for p in [s.octa_start, s.octa_end] {
                        assert!(
                            p.is_finite() && p.abs().max_element() <= 1.0 + 1e-6,
                            "split_ray({probe:?}, {origin:?}, {ray:?}, {t_min}, {t_max}): \
                             endpoint {p:?} outside the map"
                        );
                    }
                }
                format!("ok {}", segments.len())
            }
            Err(error) => error.to_string(),
        }
    }

    fn timeout(&self) -> Duration {
        Duration::from_secs(5)
    }
}

/// The outcome without digits, so that one kind of error is one signature.
fn signature(outcome: &str) -> String {
    // The error's kind, not its quoted details: the first 60 characters without digits
    // (after the work directory's path, which every gltf and bake error starts with).
    let outcome = outcome
        .rsplit_once("/input.")
        .map_or(outcome, |(_, rest)| rest);
    let mut s: String = outcome
        .chars()
        .filter(|c| !c.is_ascii_digit())
        .take(60)
        .collect();
    s.shrink_to_fit();
    s
}

fn fnv(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}

fn save_case(dir: &Path, case: &Case, note: &str) -> PathBuf {
    let hash = case.files.iter().fold(0u64, |h, f| h ^ fnv(&f.1));
    let folder = dir.join(format!("{hash:016x}"));
    std::fs::create_dir_all(&folder).expect("output folder");
    write_case(&folder, case);
    std::fs::write(folder.join("NOTE.txt"), note).expect("output folder");
    folder
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 3 {
        eprintln!("usage: fuzz TARGET SECONDS [SEED] [OUT_DIR]   (targets: gltf bake probes octa)");
        std::process::exit(2);
    }
    let target_name = args[1].clone();
    let seconds: f64 = args[2].parse().expect("SECONDS");
    let seed: u64 = args.get(3).map_or(1, |s| s.parse().expect("SEED"));
    let out = PathBuf::from(
        args.get(4)
            .cloned()
            .unwrap_or_else(|| format!("target/fuzz/{target_name}")),
    );
    std::fs::create_dir_all(&out).expect("output folder");
    let work = tempfile::tempdir().expect("temporary directory");
    let target: Box<dyn Target> = match target_name.as_str() {
        "gltf" => Box::new(GltfTarget {
            work: work.path().to_owned(),
        }),
        "bake" => Box::new(BakeTarget {
            work: work.path().to_owned(),
            scene: Scene::builtin("cornell").expect("builtin scene"),
        }),
        "probes" => Box::new(ProbesTarget),
        "octa" => Box::new(OctaTarget {
            map: OctaMap::from_fn(8, |d| d.x + 2.0 * d.y - d.z).expect("map"),
        }),
        other => {
            eprintln!("unknown target {other:?}");
            std::process::exit(2);
        }
    };
    let seeds = target.seeds();
    assert!(!seeds.is_empty(), "no seeds for {target_name}");
    let mut rng = Rng(seed ^ 0x5eed_f022);
    let mut corpus = seeds.clone();
    let mut signatures: HashSet<String> = HashSet::new();
    for case in &seeds {
        let outcome = target.run(case);
        eprintln!("seed outcome: {outcome}");
        signatures.insert(signature(&outcome));
    }

    // The watchdog: an input running past the timeout is saved and the process exits.
    let started_ms = Arc::new(AtomicU64::new(u64::MAX));
    let clock = Instant::now();
    let timeout = target.timeout();
    {
        let started_ms = Arc::clone(&started_ms);
        let current = out.join("current");
        let hangs = out.join("hangs");
        std::thread::spawn(move || {
            loop {
                std::thread::sleep(Duration::from_millis(200));
                let start = started_ms.load(Ordering::SeqCst);
                if start != u64::MAX
                    && clock.elapsed().as_millis() as u64 > start + timeout.as_millis() as u64
                {
                    let _ = std::fs::create_dir_all(&hangs);
                    let destination = hangs.join(format!("{start}"));
                    let _ = std::fs::rename(&current, &destination);
                    eprintln!(
                        "HANG: an input ran past {timeout:?}; saved to {}",
                        destination.display()
                    );
                    std::process::exit(3);
                }
            }
        });
    }
    let panic_message = Arc::new(std::sync::Mutex::new(String::new()));
    {
        let panic_message = Arc::clone(&panic_message);
        std::panic::set_hook(Box::new(move |info| {
            let location = info
                .location()
                .map(|l| format!("{}:{}", l.file(), l.line()))
                .unwrap_or_default();
            *panic_message.lock().unwrap() = format!("{info} at {location}");
        }));
    }

    let deadline = Duration::from_secs_f64(seconds);
    let mut executions = 0u64;
    let mut crashes: BTreeMap<String, PathBuf> = BTreeMap::new();
    let mut last_report = Instant::now();
    let current = out.join("current");
    while clock.elapsed() < deadline {
        let parent = &corpus[rng.below(corpus.len())];
        let case = mutate(&mut rng, parent, &corpus);
        let _ = std::fs::remove_dir_all(&current);
        std::fs::create_dir_all(&current).expect("output folder");
        write_case(&current, &case);
        started_ms.store(clock.elapsed().as_millis() as u64, Ordering::SeqCst);
        let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| target.run(&case)));
        started_ms.store(u64::MAX, Ordering::SeqCst);
        executions += 1;
        match result {
            Ok(outcome) => {
                let sig = signature(&outcome);
                if !signatures.contains(&sig) && corpus.len() < 2000 {
                    signatures.insert(sig);
                    corpus.push(case);
                }
            }
            Err(_) => {
                let message = panic_message.lock().unwrap().clone();
                let key = signature(&message);
                if let std::collections::btree_map::Entry::Vacant(slot) = crashes.entry(key) {
                    let saved = save_case(&out.join("crashes"), &case, &message);
                    eprintln!("PANIC: {message}\n  input saved to {}", saved.display());
                    slot.insert(saved);
                }
            }
        }
        if last_report.elapsed() > Duration::from_secs(60) {
            eprintln!(
                "[{target_name}] {:.0} s, {executions} executions, corpus {}, {} distinct panics",
                clock.elapsed().as_secs_f64(),
                corpus.len(),
                crashes.len()
            );
            last_report = Instant::now();
        }
    }
    let _ = std::fs::remove_dir_all(&current);
    println!(
        "{}",
        serde_json::json!({
            "target": target_name,
            "seed": seed,
            "seconds": clock.elapsed().as_secs_f64(),
            "executions": executions,
            "seeds": seeds.len(),
            "corpus": corpus.len(),
            "distinct_outcomes": signatures.len(),
            "distinct_panics": crashes.len(),
            "panics": crashes.keys().collect::<Vec<_>>(),
        })
    );
}
