//! Criterion benchmarks: encode/decode throughput, bilinear sampling, ray splitting and
//! min/max pyramid building at 256² and 1024².
//!
//! Run: `cargo bench -p probe-octa`

use std::hint::black_box;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use glam::{Vec2, Vec3};
use probe_octa::{
    CubeMap, FineRead, MinMaxPyramid, OctaMap, decode, decode_snorm16, default_sharpness,
    distance_moments, encode, encode_snorm16, irradiance_map, split_ray,
};

/// Deterministic, well-spread directions (golden-ratio points decoded from the square).
fn directions(count: usize) -> Vec<Vec3> {
    (0..count)
        .map(|i| {
            let p = Vec2::new(
                (i as f32 * 0.618_034).fract() * 2.0 - 1.0,
                (i as f32 * 0.754_877_7).fract() * 2.0 - 1.0,
            );
            decode(p) * (1.0 + (i % 7) as f32)
        })
        .collect()
}

fn encoding(c: &mut Criterion) {
    let dirs = directions(4096);
    let octas: Vec<Vec2> = dirs.iter().map(|&d| encode(d)).collect();
    let codes: Vec<[i16; 2]> = dirs.iter().map(|&d| encode_snorm16(d)).collect();
    let mut group = c.benchmark_group("octahedral");
    group.throughput(Throughput::Elements(dirs.len() as u64));
    group.bench_function("encode", |b| {
        b.iter(|| {
            let mut acc = Vec2::ZERO;
            for &d in black_box(&dirs) {
                acc += encode(d);
            }
            acc
        })
    });
    group.bench_function("decode", |b| {
        b.iter(|| {
            let mut acc = Vec3::ZERO;
            for &p in black_box(&octas) {
                acc += decode(p);
            }
            acc
        })
    });
    group.bench_function("encode_snorm16", |b| {
        b.iter(|| {
            let mut acc = 0i32;
            for &d in black_box(&dirs) {
                let [x, y] = encode_snorm16(d);
                acc = acc.wrapping_add(i32::from(x) ^ i32::from(y));
            }
            acc
        })
    });
    group.bench_function("decode_snorm16", |b| {
        b.iter(|| {
            let mut acc = Vec3::ZERO;
            for &q in black_box(&codes) {
                acc += decode_snorm16(q);
            }
            acc
        })
    });
    group.finish();
}

fn sampling(c: &mut Criterion) {
    let dirs = directions(4096);
    let map = OctaMap::from_fn(256, |d| 1.0 + d.x * d.y).unwrap();
    let mut group = c.benchmark_group("map_256");
    group.throughput(Throughput::Elements(dirs.len() as u64));
    group.bench_function("sample_bilinear", |b| {
        b.iter(|| {
            let mut acc = 0.0f32;
            for &d in black_box(&dirs) {
                acc += map.sample(d);
            }
            acc
        })
    });
    group.bench_function("split_ray", |b| {
        b.iter(|| {
            let mut pieces = 0usize;
            for (i, &d) in black_box(&dirs).iter().enumerate() {
                let origin = dirs[(i * 7 + 3) % dirs.len()];
                pieces += split_ray(Vec3::ZERO, origin, d, 0.0, 10.0).map_or(0, |s| s.len());
            }
            pieces
        })
    });
    group.finish();
}

fn pyramids(c: &mut Criterion) {
    let mut group = c.benchmark_group("min_max_pyramid");
    group.sample_size(20);
    for n in [256u32, 1024] {
        let map = OctaMap::from_fn(n, |d| 2.0 + d.x * d.y - 0.5 * d.z).unwrap();
        group.throughput(Throughput::Elements(u64::from(n) * u64::from(n)));
        for (name, read) in [
            ("nearest", FineRead::Nearest),
            ("bilinear", FineRead::Bilinear),
        ] {
            group.bench_with_input(BenchmarkId::new(name, n), &map, |b, map| {
                b.iter(|| MinMaxPyramid::build(black_box(map), read, u32::MAX).unwrap())
            });
        }
    }
    group.finish();
}

fn filters(c: &mut Criterion) {
    let mut group = c.benchmark_group("filters");
    group.sample_size(10);
    let distance = OctaMap::from_fn(256, |d| 2.0 + d.x * d.y - 0.5 * d.z).unwrap();
    group.bench_function("distance_moments_256_to_14_p50", |b| {
        b.iter(|| distance_moments(black_box(&distance), 14, 50.0).unwrap())
    });
    let radiance = OctaMap::from_fn(128, |d| Vec3::new(d.x.max(0.0), 0.5, d.z * d.z)).unwrap();
    group.bench_function("irradiance_128_to_6", |b| {
        b.iter(|| irradiance_map(black_box(&radiance), 6).unwrap())
    });
    let cube = CubeMap::from_fn(256, |d| Vec3::new(d.x.max(0.0), 0.5, d.z * d.z)).unwrap();
    group.bench_function("cube_256_to_octa_128", |b| {
        b.iter(|| {
            black_box(&cube)
                .to_octahedral(128, default_sharpness(128))
                .unwrap()
        })
    });
    group.finish();
}

criterion_group!(benches, encoding, sampling, pyramids, filters);
criterion_main!(benches);
