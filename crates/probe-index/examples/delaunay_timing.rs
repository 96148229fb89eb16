//! Times `Tetrahedralization::build` on points read from a file, for the Qhull comparison in
//! `scripts/qhull_compare.py`.
//!
//! Usage: `cargo run --release -p probe-index --example delaunay_timing -- POINTS.f32 [REPEATS] [--validate] [--locate]`
//! where `POINTS.f32` holds little-endian f32 triples (x, y, z). Without a file it times 100,000
//! seeded uniform points in the unit cube. Prints one line per run and a final
//! `median_seconds=…` line.

use std::time::Instant;

use glam::Vec3;
use probe_index::Tetrahedralization;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let points: Vec<Vec3> = match args.get(1) {
        Some(path) => {
            let bytes = match std::fs::read(path) {
                Ok(b) => b,
                Err(e) => {
                    eprintln!("cannot read {path}: {e}");
                    std::process::exit(2);
                }
            };
            if bytes.len() % 12 != 0 {
                eprintln!(
                    "{path}: length {} is not a multiple of 12 bytes",
                    bytes.len()
                );
                std::process::exit(2);
            }
            bytes
                .chunks_exact(12)
                .map(|c| {
                    let f = |i: usize| f32::from_le_bytes([c[i], c[i + 1], c[i + 2], c[i + 3]]);
                    Vec3::new(f(0), f(4), f(8))
                })
                .collect()
        }
        None => {
            let mut state = 1u64;
            let mut next = move || {
                state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
                let mut z = state;
                z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
                z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
                ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
            };
            (0..100_000)
                .map(|_| Vec3::new(next(), next(), next()))
                .collect()
        }
    };
    let repeats: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(5);
    let mut times = Vec::new();
    for run in 0..repeats {
        let start = Instant::now();
        let t = match Tetrahedralization::build(&points) {
            Ok(t) => t,
            Err(e) => {
                eprintln!("build failed: {e}");
                std::process::exit(1);
            }
        };
        let seconds = start.elapsed().as_secs_f64();
        println!(
            "run={run} points={} tetrahedra={} seconds={seconds:.4}",
            points.len(),
            t.tetrahedra().len()
        );
        times.push(seconds);
    }
    if args.iter().any(|a| a == "--validate") {
        let t = Tetrahedralization::build(&points).expect("built above");
        let volume: f64 = t
            .tetrahedra()
            .iter()
            .map(|r| {
                let [a, b, c, d] = r.vertices.map(|v| points[v as usize].as_dvec3());
                (b - a).cross(c - a).dot(d - a) / 6.0
            })
            .sum();
        println!(
            "validate={:?} hull_faces={} volume={volume:.10}",
            t.validate(),
            t.hull_faces().len()
        );
    }
    if args.iter().any(|a| a == "--locate") {
        // Point location: 1,000,000 queries. Coherent: a random walk of small steps, each walk
        // starting from the previous answer; incoherent: independent uniform points in the
        // points' bounding box, located by jump-and-walk.
        let t = Tetrahedralization::build(&points).expect("built above");
        let (lo, hi) = points.iter().fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), p| (lo.min(*p), hi.max(*p)),
        );
        let mut state = 7u64;
        let mut unit = move || {
            state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = state;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
        };
        let extent = hi - lo;
        let step = extent * 0.002;
        for (name, coherent) in [("coherent", true), ("incoherent", false)] {
            let mut p = (lo + hi) * 0.5;
            let mut start = 0;
            let mut steps = 0u64;
            let queries = 1_000_000;
            let clock = Instant::now();
            for _ in 0..queries {
                p = if coherent {
                    (p + (Vec3::new(unit(), unit(), unit()) * 2.0 - 1.0) * step).clamp(lo, hi)
                } else {
                    lo + Vec3::new(unit(), unit(), unit()) * extent
                };
                let loc = if coherent {
                    t.locate_from(p, start).expect("finite")
                } else {
                    t.locate(p).expect("finite")
                };
                start = loc.tetrahedron;
                steps += u64::from(loc.steps);
            }
            let seconds = clock.elapsed().as_secs_f64();
            println!(
                "locate_{name}: {queries} queries, {:.3} us/query, {:.1} tetrahedra visited/query",
                seconds * 1e6 / queries as f64,
                steps as f64 / queries as f64
            );
        }
    }
    times.sort_by(f64::total_cmp);
    println!("median_seconds={:.4}", times[times.len() / 2]);
}
