//! Measures the angular error of octahedral encoding: the f32 round trip and the 2×8-bit and
//! 2×16-bit snorm forms, over uniformly random directions (seeded).
//!
//! Run: `cargo run --release -p probe-octa --example quantisation_error [count] [seed]`

use glam::{DVec3, Vec3};
use probe_octa::{decode, decode_snorm8, decode_snorm16, encode, encode_snorm8, encode_snorm16};

/// SplitMix64: a tiny seeded generator, so the example needs no dependency.
struct SplitMix64(u64);

impl SplitMix64 {
    fn next_f64(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }

    /// A uniformly random unit direction (Archimedes: z uniform in [-1, 1]).
    fn direction(&mut self) -> Vec3 {
        let z = 2.0 * self.next_f64() - 1.0;
        let phi = 2.0 * std::f64::consts::PI * self.next_f64();
        let r = (1.0 - z * z).max(0.0).sqrt();
        DVec3::new(r * phi.cos(), r * phi.sin(), z).as_vec3()
    }
}

/// Angle between two directions in degrees, computed in f64 with atan2 for accuracy.
fn angle_degrees(a: Vec3, b: Vec3) -> f64 {
    let (a, b) = (a.as_dvec3().normalize(), b.as_dvec3().normalize());
    a.cross(b).length().atan2(a.dot(b)).to_degrees()
}

fn main() {
    let mut args = std::env::args().skip(1);
    let count: usize = args
        .next()
        .and_then(|a| a.parse().ok())
        .unwrap_or(10_000_000);
    let seed: u64 = args.next().and_then(|a| a.parse().ok()).unwrap_or(2024);
    let mut rng = SplitMix64(seed);
    let mut stats = [(0.0f64, 0.0f64); 3];
    for _ in 0..count {
        let d = rng.direction();
        let errors = [
            angle_degrees(decode(encode(d)), d),
            angle_degrees(decode_snorm8(encode_snorm8(d)), d),
            angle_degrees(decode_snorm16(encode_snorm16(d)), d),
        ];
        for (s, e) in stats.iter_mut().zip(errors) {
            s.0 += e;
            s.1 = s.1.max(e);
        }
    }
    println!("{count} random directions, seed {seed}");
    for (name, (sum, max)) in [
        "f32 round trip",
        "2x8-bit snorm (16 bits)",
        "2x16-bit snorm (32 bits)",
    ]
    .iter()
    .zip(stats)
    {
        let mean = sum / count as f64;
        println!(
            "{name:26} mean {mean:.6} deg  max {max:.6} deg  (mean {:.2e} rad, max {:.2e} rad)",
            mean.to_radians(),
            max.to_radians()
        );
    }
}
