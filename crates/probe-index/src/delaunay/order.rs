//! Insertion order: biased randomized insertion order (BRIO, Amenta, Choi & Rote 2003) with each
//! round sorted along a 3-D Hilbert curve, as CGAL's `spatial_sort` does. Consecutive points are
//! close, so the walk that locates each new point is short; the random rounds keep the expected
//! cost optimal on adversarial inputs.

use crate::par::*;
use crate::predicates::P3;
use crate::rng::SplitMix64;

/// Bits per axis of the Hilbert key (63-bit keys).
const HILBERT_BITS: u32 = 21;
/// Each BRIO round holds this fraction of the points still to place (the rest come later).
const ROUND_DENOMINATOR: usize = 8;
/// Rounds smaller than this are not split further.
const MIN_ROUND: usize = 64;

/// The Hilbert index of a point with integer coordinates below `2^bits` (Skilling 2004,
/// "Programming the Hilbert curve").
pub(crate) fn hilbert_index(mut x: [u32; 3], bits: u32) -> u64 {
    let m = 1u32 << (bits - 1);
    // Inverse undo.
    let mut q = m;
    while q > 1 {
        let p = q - 1;
        for i in 0..3 {
            if x[i] & q != 0 {
                x[0] ^= p;
            } else {
                let t = (x[0] ^ x[i]) & p;
                x[0] ^= t;
                x[i] ^= t;
            }
        }
        q >>= 1;
    }
    // Gray encode.
    x[1] ^= x[0];
    x[2] ^= x[1];
    let mut t = 0;
    let mut q = m;
    while q > 1 {
        if x[2] & q != 0 {
            t ^= q - 1;
        }
        q >>= 1;
    }
    for v in &mut x {
        *v ^= t;
    }
    let mut h = 0u64;
    for b in (0..bits).rev() {
        for v in &x {
            h = (h << 1) | u64::from((v >> b) & 1);
        }
    }
    h
}

/// Sorts `indices` (into `points`) along a Hilbert curve over the points' bounding box.
fn hilbert_sort(points: &[P3], indices: &mut [u32]) {
    if indices.len() < 2 {
        return;
    }
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for &i in indices.iter() {
        let p = &points[i as usize];
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let cells = f64::from((1u32 << HILBERT_BITS) - 1);
    let mut scale = [0.0; 3];
    for k in 0..3 {
        let extent = hi[k] - lo[k];
        scale[k] = if extent > 0.0 { cells / extent } else { 0.0 };
    }
    let mut keyed: Vec<(u64, u32)> = indices
        .par_iter()
        .map(|&i| {
            let p = &points[i as usize];
            let mut q = [0u32; 3];
            for k in 0..3 {
                q[k] = ((p[k] - lo[k]) * scale[k]).clamp(0.0, cells) as u32;
            }
            (hilbert_index(q, HILBERT_BITS), i)
        })
        .collect();
    keyed.par_sort_unstable();
    for (slot, (_, i)) in indices.iter_mut().zip(keyed) {
        *slot = i;
    }
}

/// The insertion order of all `points`: BRIO rounds, each Hilbert-sorted. Deterministic in `seed`.
pub(crate) fn insertion_order(points: &[P3], seed: u64) -> Vec<u32> {
    let n = points.len();
    let mut order: Vec<u32> = (0..n as u32).collect();
    let mut rng = SplitMix64::new(seed);
    // Fisher–Yates shuffle.
    for i in (1..n).rev() {
        let j = rng.below(i as u64 + 1) as usize;
        order.swap(i, j);
    }
    // Rounds: the last round is the biggest; earlier rounds are the prefixes.
    let mut end = n;
    while end > 0 {
        let start = if end <= MIN_ROUND {
            0
        } else {
            end / ROUND_DENOMINATOR
        };
        hilbert_sort(points, &mut order[start..end]);
        end = start;
    }
    order
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hilbert_index_is_a_bijection_on_a_small_cube_with_unit_steps() {
        let bits = 3;
        let side = 1u32 << bits;
        let mut by_index = vec![[u32::MAX; 3]; (side * side * side) as usize];
        for x in 0..side {
            for y in 0..side {
                for z in 0..side {
                    let h = hilbert_index([x, y, z], bits) as usize;
                    assert_eq!(by_index[h][0], u32::MAX, "index {h} used twice");
                    by_index[h] = [x, y, z];
                }
            }
        }
        // Consecutive cells along the curve are face neighbours.
        for w in by_index.windows(2) {
            let d: u32 = (0..3).map(|k| w[0][k].abs_diff(w[1][k])).sum();
            assert_eq!(d, 1, "{:?} -> {:?}", w[0], w[1]);
        }
    }

    #[test]
    fn order_is_a_permutation_and_deterministic() {
        let points: Vec<P3> = (0..1000)
            .map(|i| {
                let f = i as f64;
                [(f * 0.37).sin(), (f * 0.91).cos(), (f * 1.3).sin()]
            })
            .collect();
        let a = insertion_order(&points, 5);
        let b = insertion_order(&points, 5);
        assert_eq!(a, b);
        let mut sorted = a.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (0..1000).collect::<Vec<u32>>());
    }
}
