//! How the cost of each stage grows with the probe count (issue 16): placement (a regular grid
//! over the region, classified and relocated DDGI-style), indexing (the 3-D Delaunay
//! tetrahedralization and the sparse voxel octree), baking (low resolution, one sample per
//! texel, no bounce) and, through the CPU twin of the tracer, packing the field ("upload") and
//! tracing a fixed set of rays with the octree's selection. Per stage and probe count: wall time
//! and the process's peak resident memory during the stage (`VmHWM`, reset before each stage
//! through `/proc/self/clear_refs`). Per stage: the growth exponent, the least-squares slope of
//! log time against log probes, and the slope of each step.
//!
//! ```text
//! cargo run --release -p probe-eval --example growth -- [SCENE] [COUNTS] [OUT]
//! ```
//!
//! Defaults: Sponza (the shared `Sponza_basecolor.gltf`) with the atrium region of
//! `eval.toml`, counts `64,1024,4096,16384`, `OUT` = `growth.md`. Grids: 64 = 8×2×4,
//! 1,024 = 16×4×16, 4,096 = 32×8×16, 16,384 = 64×8×32 (other counts: the nearest
//! `4k × k × 2k` grid). `builtin:NAME` scenes use their bounds shrunk by 10 % per side.
//! Environment: `GROWTH_RES` (bake and trace resolution, default 32), `GROWTH_RAYS` (default
//! 20,000), `GROWTH_SVO_DEPTH` (default 7). It also prints the device footprint
//! ([`probe_trace_gpu::DeviceFootprint`]) of every count at 128² against WebGPU's default
//! limits (computed, not measured: no GPU here).

use std::fmt::Write as _;
use std::time::Instant;

use glam::Vec3;
use probe_capture::{BakeSettings, Sampling, bake, no_progress};
use probe_eval::pipeline::light_field;
use probe_index::{SparseVoxelOctree, SvoOptions, Tetrahedralization};
use probe_place::candidates::{ClassifyParams, RegularGrid, classify_grid};
use probe_scene::{Aabb, Scene};
use probe_testdata::Lcg;
use probe_trace_gpu::{
    CpuTracer, DeviceFootprint, FieldOptions, ProbeSelection, TraceOptions, TraceRay, Tracer,
};

/// Peak resident memory since the last reset, in bytes (`VmHWM`), or 0 where unreadable.
fn peak_rss() -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1)?.parse::<u64>().ok())
        })
        .map_or(0, |kib| kib * 1024)
}

/// Resets the peak to the current resident memory (Linux ≥ 4.0).
fn reset_peak() {
    let _ = std::fs::write("/proc/self/clear_refs", "5");
}

/// The process's resident memory now, in bytes.
fn rss() -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmRSS:"))
                .and_then(|l| l.split_whitespace().nth(1)?.parse::<u64>().ok())
        })
        .map_or(0, |kib| kib * 1024)
}

/// Runs `work`, returning its value, seconds and the peak resident memory during it.
fn measured<T>(stage: &str, probes: usize, work: impl FnOnce() -> T) -> (T, f64, u64) {
    reset_peak();
    let start = Instant::now();
    let value = work();
    let seconds = start.elapsed().as_secs_f64();
    let peak = peak_rss();
    eprintln!(
        "  {stage:<16} {probes:>6} probes: {seconds:>8.3} s, peak RSS {:>8.1} MiB",
        peak as f64 / 1048576.0
    );
    (value, seconds, peak)
}

fn dims_for(count: usize) -> [u32; 3] {
    match count {
        64 => [8, 2, 4],
        1024 => [16, 4, 16],
        4096 => [32, 8, 16],
        16384 => [64, 8, 32],
        n => {
            let k = ((n as f64 / 8.0).cbrt().round() as u32).max(1);
            [4 * k, k, 2 * k]
        }
    }
}

/// Least-squares slope of `ln y` against `ln x`.
fn slope(points: &[(f64, f64)]) -> Option<f64> {
    let points: Vec<(f64, f64)> = points
        .iter()
        .filter(|(x, y)| *x > 0.0 && *y > 0.0)
        .map(|(x, y)| (x.ln(), y.ln()))
        .collect();
    if points.len() < 2 {
        return None;
    }
    let n = points.len() as f64;
    let mx = points.iter().map(|p| p.0).sum::<f64>() / n;
    let my = points.iter().map(|p| p.1).sum::<f64>() / n;
    let sxy: f64 = points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let sxx: f64 = points.iter().map(|p| (p.0 - mx).powi(2)).sum();
    (sxx > 0.0).then(|| sxy / sxx)
}

struct Measure {
    stage: &'static str,
    probes: usize,
    seconds: f64,
    peak: u64,
}

fn env_or(name: &str, default: u32) -> u32 {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let sponza = probe_testdata::scene_path(probe_testdata::SPONZA);
    let scene_spec = args
        .first()
        .cloned()
        .unwrap_or_else(|| sponza.to_string_lossy().into_owned());
    let counts: Vec<usize> = args
        .get(1)
        .map_or("64,1024,4096,16384", String::as_str)
        .split(',')
        .map(|c| {
            c.trim()
                .parse()
                .expect("COUNTS: comma-separated probe counts")
        })
        .collect();
    let out = args.get(2).cloned().unwrap_or_else(|| "growth.md".into());
    let resolution = env_or("GROWTH_RES", 32);
    let ray_count = env_or("GROWTH_RAYS", 20_000) as usize;
    let svo_depth = env_or("GROWTH_SVO_DEPTH", 7);

    let load_start = Instant::now();
    let scene = Scene::open(&scene_spec)?;
    let region = if scene_spec.ends_with("Sponza_basecolor.gltf") {
        Aabb::new(Vec3::new(-20.0, 4.0, -9.0), Vec3::new(17.3, 15.0, 7.6))
    } else {
        let b = scene.bounds();
        let margin = b.size() * 0.1;
        Aabb::new(b.min + margin, b.max - margin)
    };
    eprintln!(
        "{}: {} triangles, loaded in {:.1} s; region {:?}..{:?}; bake and trace at {resolution}², {ray_count} rays, octree depth {svo_depth}",
        scene.name(),
        scene.triangles().len(),
        load_start.elapsed().as_secs_f64(),
        region.min,
        region.max
    );

    // One ray set for every count: origins spread over the region, directions over the sphere.
    let mut rng = Lcg(16);
    let rays: Vec<TraceRay> = (0..ray_count)
        .map(|_| {
            let t = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform());
            let origin = region.min + region.size() * t;
            let z = 2.0 * rng.uniform() - 1.0;
            let phi = std::f32::consts::TAU * rng.uniform();
            let r = (1.0 - z * z).max(0.0).sqrt();
            TraceRay::new(origin, Vec3::new(r * phi.cos(), z, r * phi.sin()))
        })
        .collect();

    let mut measures: Vec<Measure> = Vec::new();
    let mut record = |stage, probes, seconds, peak| {
        measures.push(Measure {
            stage,
            probes,
            seconds,
            peak,
        })
    };
    let mut notes = Vec::new();
    for &count in &counts {
        let dims = dims_for(count);
        let grid = RegularGrid::new(region, dims)?;
        let before = rss();
        eprintln!(
            "{count} probes ({}×{}×{}), resident before: {:.0} MiB",
            dims[0],
            dims[1],
            dims[2],
            before as f64 / 1048576.0
        );
        let (classified, s, m) = measured("placement", count, || {
            classify_grid(&scene, &grid, &ClassifyParams::default())
        });
        let classified = classified?;
        record("placement", count, s, m);
        let positions = classified.positions;
        let probes = positions.len();
        if probes != count {
            notes.push(format!(
                "{count}: classification removed {} probes (inside geometry); later stages take {probes}",
                count - probes
            ));
        }

        let (tets, s, m) = measured("delaunay", probes, || Tetrahedralization::build(&positions));
        drop(tets?);
        record("index: Delaunay", count, s, m);
        let (svo, s, m) = measured("octree", probes, || {
            SparseVoxelOctree::build(
                &scene,
                &positions,
                &SvoOptions {
                    max_depth: svo_depth,
                    ..SvoOptions::default()
                },
            )
        });
        let svo = svo?;
        record("index: octree", count, s, m);
        notes.push(format!(
            "{count}: octree {} node words, {} payloads, {:.2} MB",
            svo.nodes().len(),
            svo.leaves().len(),
            svo.memory_bytes() as f64 / 1e6
        ));

        let settings = BakeSettings {
            resolution,
            sampling: Sampling::fixed(1),
            bounces: 0,
            ..BakeSettings::default()
        };
        let (baked, s, m) = measured("bake", probes, || {
            bake(&scene, &positions, &settings, &no_progress)
        });
        let baked = baked?;
        record("bake", count, s, m);

        let tracer = CpuTracer::new();
        let selection = ProbeSelection::SparseVoxelOctree(&svo);
        let (field, s, m) = measured("upload (pack)", probes, || {
            tracer.upload(&light_field(&baked), &selection, &FieldOptions::default())
        });
        let field = field?;
        record("upload (CPU twin)", count, s, m);
        drop(baked);
        let mut tracer = tracer;
        let (output, s, m) = measured("trace", probes, || {
            tracer.trace(&field, &rays, &TraceOptions::default())
        });
        let output = output?;
        record("trace (CPU twin)", count, s, m);
        let hits = output
            .results
            .iter()
            .filter(|r| r.status == probe_trace_gpu::RayStatus::Hit)
            .count();
        notes.push(format!(
            "{count}: {hits} of {} rays HIT",
            output.results.len()
        ));
    }

    // The report.
    let stages: Vec<&str> = {
        let mut s: Vec<&str> = Vec::new();
        for m in &measures {
            if !s.contains(&m.stage) {
                s.push(m.stage);
            }
        }
        s
    };
    let mut md = String::new();
    writeln!(
        md,
        "Scene {} ({} triangles), bake and trace at {resolution}², bake 1 sample per texel and no bounce, octree depth {svo_depth}, {ray_count} rays (CPU twin, octree selection, hi-Z).\n",
        scene.name(),
        scene.triangles().len()
    )?;
    write!(md, "| stage |")?;
    for c in &counts {
        write!(md, " {c} probes |")?;
    }
    writeln!(md, " exponent (fit) | exponent per step |")?;
    write!(md, "|---|")?;
    for _ in &counts {
        write!(md, "---|")?;
    }
    writeln!(md, "---|---|")?;
    for stage in &stages {
        let rows: Vec<&Measure> = measures.iter().filter(|m| m.stage == *stage).collect();
        write!(md, "| {stage} |")?;
        for c in &counts {
            match rows.iter().find(|m| m.probes == *c) {
                Some(m) => write!(
                    md,
                    " {:.3} s, {:.0} MiB |",
                    m.seconds,
                    m.peak as f64 / 1048576.0
                )?,
                None => write!(md, " – |")?,
            }
        }
        let points: Vec<(f64, f64)> = rows.iter().map(|m| (m.probes as f64, m.seconds)).collect();
        let fit = slope(&points).map_or("–".to_owned(), |s| format!("{s:.2}"));
        let steps: Vec<String> = points
            .windows(2)
            .map(|w| slope(w).map_or("–".to_owned(), |s| format!("{s:.2}")))
            .collect();
        writeln!(md, " {fit} | {} |", steps.join(", "))?;
    }
    writeln!(md)?;
    writeln!(
        md,
        "Device footprint at 128² (computed by `DeviceFootprint::light_field` with a grid \
         selection; WebGPU's default `max_storage_buffer_binding_size` is 128 MiB):\n"
    )?;
    writeln!(
        md,
        "| probes | geometry | radiance | pyramid | all buffers | largest fits 128 MiB / 2 GiB / 4 GiB |"
    )?;
    writeln!(md, "|---|---|---|---|---|---|")?;
    let gib = |b: u64| b as f64 / (1u64 << 30) as f64;
    for &c in &counts {
        let f = DeviceFootprint::light_field(c, 128, None);
        let largest = f.largest().map_or(0, |b| b.bytes);
        let fits = |limit: u64| if largest <= limit { "yes" } else { "no" };
        writeln!(
            md,
            "| {c} | {:.2} GiB | {:.2} GiB | {:.2} GiB | {:.2} GiB | {} / {} / {} |",
            gib(f.buffer("geometry").map_or(0, |b| b.bytes)),
            gib(f.buffer("radiance").map_or(0, |b| b.bytes)),
            gib(f.buffer("pyramid").map_or(0, |b| b.bytes)),
            gib(f.total_bytes()),
            fits(128 << 20),
            fits(2 << 30),
            fits(4 << 30),
        )?;
    }
    writeln!(md)?;
    for note in &notes {
        writeln!(md, "- {note}")?;
    }
    print!("{md}");
    let temporary = format!("{out}.tmp");
    std::fs::write(&temporary, &md)?;
    std::fs::rename(&temporary, &out)?;
    eprintln!("wrote {out}");
    Ok(())
}
