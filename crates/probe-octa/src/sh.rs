//! Order-2 (L2, 9-coefficient) real spherical harmonics of RGB maps.

use std::f32::consts::PI;

use glam::Vec3;

use crate::map::OctaMap;

/// Order-2 real spherical-harmonic coefficients of an RGB function on the sphere.
///
/// Basis (Sloan, *Stupid Spherical Harmonics Tricks*), index `l² + l + m`, for a unit
/// direction `(x, y, z)`:
///
/// | index | `(l, m)` | basis function |
/// |---|---|---|
/// | 0 | (0, 0) | `0.282095` |
/// | 1 | (1, −1) | `0.488603 · y` |
/// | 2 | (1, 0) | `0.488603 · z` |
/// | 3 | (1, 1) | `0.488603 · x` |
/// | 4 | (2, −2) | `1.092548 · xy` |
/// | 5 | (2, −1) | `1.092548 · yz` |
/// | 6 | (2, 0) | `0.315392 · (3z² − 1)` |
/// | 7 | (2, 1) | `1.092548 · xz` |
/// | 8 | (2, 2) | `0.546274 · (x² − y²)` |
///
/// The basis is orthonormal over the sphere, so L2 reproduces every polynomial of degree ≤ 2
/// in the direction exactly.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ShL2Rgb {
    /// Coefficient `i` (RGB) of basis function `i` in the table above.
    pub coefficients: [Vec3; 9],
}

impl ShL2Rgb {
    /// The nine basis functions at a direction (normalised first; zero or NaN → `+z`).
    #[inline]
    pub fn basis(direction: Vec3) -> [f32; 9] {
        let d = direction.normalize_or(Vec3::Z);
        let (x, y, z) = (d.x, d.y, d.z);
        [
            0.282_094_8,
            0.488_602_5 * y,
            0.488_602_5 * z,
            0.488_602_5 * x,
            1.092_548_4 * x * y,
            1.092_548_4 * y * z,
            0.315_391_57 * (3.0 * z * z - 1.0),
            1.092_548_4 * x * z,
            0.546_274_2 * (x * x - y * y),
        ]
    }

    /// Projects an RGB octahedral map: `c_i = Σ_texels L(ω) Y_i(ω) Ω`, with each interior
    /// texel's exact solid angle `Ω` (so a constant map projects to exactly `L·√(4π)` in `c_0`).
    pub fn project(map: &OctaMap<Vec3>) -> Self {
        let layout = map.layout();
        let n = layout.resolution();
        let solid_angles = layout.texel_solid_angles();
        let mut sums = [[0.0f64; 3]; 9];
        for iy in 0..n {
            for ix in 0..n {
                let omega = f64::from(solid_angles[(iy * n + ix) as usize]);
                let value = map.texels()[layout.interior_index(ix, iy)];
                let basis = Self::basis(layout.texel_direction(ix, iy));
                for (sum, b) in sums.iter_mut().zip(basis) {
                    let w = f64::from(b) * omega;
                    sum[0] += f64::from(value.x) * w;
                    sum[1] += f64::from(value.y) * w;
                    sum[2] += f64::from(value.z) * w;
                }
            }
        }
        Self {
            coefficients: sums.map(|s| Vec3::new(s[0] as f32, s[1] as f32, s[2] as f32)),
        }
    }

    /// The function the coefficients describe, at a direction.
    #[inline]
    pub fn evaluate(&self, direction: Vec3) -> Vec3 {
        Self::basis(direction)
            .iter()
            .zip(&self.coefficients)
            .fold(Vec3::ZERO, |acc, (&b, &c)| acc + c * b)
    }

    /// Cosine convolution (Ramamoorthi and Hanrahan 2001): if `self` is radiance `L`, the result
    /// evaluates to irradiance `E(n) = ∫ L(ω) max(0, n·ω) dω`. Band `l` is scaled by
    /// `Â_0 = π`, `Â_1 = 2π/3`, `Â_2 = π/4`.
    pub fn irradiance(&self) -> Self {
        let band = [PI, 2.0 * PI / 3.0, PI / 4.0];
        let mut out = *self;
        for (i, c) in out.coefficients.iter_mut().enumerate() {
            let l = match i {
                0 => 0,
                1..=3 => 1,
                _ => 2,
            };
            *c *= band[l];
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn basis_is_orthonormal_under_map_quadrature() {
        let layout = crate::OctaLayout::new(128).unwrap();
        let solid_angles = layout.texel_solid_angles();
        let mut gram = [[0.0f64; 9]; 9];
        for iy in 0..128 {
            for ix in 0..128 {
                let b = ShL2Rgb::basis(layout.texel_direction(ix, iy));
                let omega = f64::from(solid_angles[iy as usize * 128 + ix as usize]);
                for i in 0..9 {
                    for j in 0..9 {
                        gram[i][j] += f64::from(b[i]) * f64::from(b[j]) * omega;
                    }
                }
            }
        }
        for (i, row) in gram.iter().enumerate() {
            for (j, &g) in row.iter().enumerate() {
                let expected = if i == j { 1.0 } else { 0.0 };
                assert!((g - expected).abs() < 2e-4, "({i},{j}): {g}");
            }
        }
    }
}
