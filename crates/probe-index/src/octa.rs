//! The octahedral map (BRIEF's formula, as in RTXGI and McGuire 2017), kept private here so
//! the crate stands alone; it must agree with `probe-octa`'s `encode`/`decode` (tested against
//! the same formula), and can be replaced by that crate once it is on `main`.

use glam::{Vec2, Vec3};

#[inline]
fn sign_not_zero(v: Vec2) -> Vec2 {
    Vec2::new(
        if v.x >= 0.0 { 1.0 } else { -1.0 },
        if v.y >= 0.0 { 1.0 } else { -1.0 },
    )
}

/// Unit direction → octahedral coordinates in `[-1, 1]²`.
#[inline]
pub(crate) fn encode(v: Vec3) -> Vec2 {
    let l1 = v.x.abs() + v.y.abs() + v.z.abs();
    let p = Vec2::new(v.x, v.y) / l1;
    if v.z < 0.0 {
        (Vec2::ONE - Vec2::new(p.y.abs(), p.x.abs())) * sign_not_zero(p)
    } else {
        p
    }
}

/// Octahedral coordinates in `[-1, 1]²` → unit direction.
#[inline]
pub(crate) fn decode(o: Vec2) -> Vec3 {
    let mut v = Vec3::new(o.x, o.y, 1.0 - o.x.abs() - o.y.abs());
    if v.z < 0.0 {
        let xy = (Vec2::ONE - Vec2::new(v.y.abs(), v.x.abs())) * sign_not_zero(Vec2::new(v.x, v.y));
        v.x = xy.x;
        v.y = xy.y;
    }
    v.normalize()
}

/// Direction of the centre of texel `(i, j)` of an `n × n` map: `o = ((i, j) + 0.5) / n · 2 − 1`,
/// `i` along x (columns), `j` along y (rows).
#[inline]
pub(crate) fn texel_direction(i: u32, j: u32, n: u32) -> Vec3 {
    let o = (Vec2::new(i as f32, j as f32) + 0.5) / n as f32 * 2.0 - 1.0;
    decode(o)
}

/// The texel `(i, j)` of an `n × n` map that holds direction `v`.
#[inline]
pub(crate) fn texel_of(v: Vec3, n: u32) -> (u32, u32) {
    let o = encode(v);
    let t = ((o + 1.0) * 0.5 * n as f32).floor();
    let max = (n - 1) as f32;
    (t.x.clamp(0.0, max) as u32, t.y.clamp(0.0, max) as u32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn texel_round_trip() {
        for n in [1u32, 4, 16, 33] {
            for j in 0..n {
                for i in 0..n {
                    let d = texel_direction(i, j, n);
                    assert!((d.length() - 1.0).abs() < 1e-5);
                    assert_eq!(texel_of(d, n), (i, j), "n={n}");
                }
            }
        }
        for v in [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z] {
            assert!((decode(encode(v)) - v).length() < 1e-6);
        }
    }
}
