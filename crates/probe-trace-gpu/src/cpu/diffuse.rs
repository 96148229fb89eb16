//! Diffuse shading from irradiance probes (seed 001 §4.3.6–4.3.7), step for step as
//! `gpu/diffuse.wgsl` does it.

use glam::{UVec3, Vec2, Vec3};
use probe_index::{NO_NEIGHBOUR, TetRecord};

use crate::packed::{
    DiffuseParams, HULL_WORDS, INTERPOLATE_GRID, PackedIrradiance, TET_WORDS, padded_index,
};
use crate::ray::{DiffuseResult, ShadingPoint};

/// Bilinear sample of a padded octahedral map at `direction`, exactly as
/// `probe_octa::OctaMap::sample` computes it (4 fetches).
fn sample_bilinear<const K: usize>(
    texels: &[[f32; K]],
    resolution: u32,
    probe: u32,
    direction: Vec3,
) -> [f32; K] {
    let n = resolution as f32;
    let o = probe_octa::encode(direction).clamp(Vec2::NEG_ONE, Vec2::ONE);
    let c = Vec2::ONE + (o + Vec2::ONE) * (0.5 * n) - Vec2::splat(0.5);
    let x0 = (c.x.floor().max(0.0) as u32).min(resolution);
    let y0 = (c.y.floor().max(0.0) as u32).min(resolution);
    let tx = (c.x - x0 as f32).clamp(0.0, 1.0);
    let ty = (c.y - y0 as f32).clamp(0.0, 1.0);
    // padded (x0, y0) is interior (x0 − 1, y0 − 1); `padded_index` adds the border back.
    let side = resolution as usize + 2;
    let i00 = padded_index(resolution, probe, 0, 0) - side - 1 + y0 as usize * side + x0 as usize;
    let i01 = i00 + side;
    let (t00, t10, t01, t11) = (texels[i00], texels[i00 + 1], texels[i01], texels[i01 + 1]);
    let mut out = [0.0f32; K];
    for k in 0..K {
        let mut v = 0.0f32;
        v += t00[k] * ((1.0 - tx) * (1.0 - ty));
        v += t10[k] * (tx * (1.0 - ty));
        v += t01[k] * ((1.0 - tx) * ty);
        v += t11[k] * (tx * ty);
        out[k] = v;
    }
    out
}

/// Barycentric coordinates of the point of triangle `abc` nearest to `p` (Ericson, Real-Time
/// Collision Detection §5.1.5), and whether that point is `p`'s projection onto the
/// triangle's plane (inside the triangle) rather than on an edge or a corner.
fn closest_on_triangle(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> (Vec3, bool) {
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = ab.dot(ap);
    let d2 = ac.dot(ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return (Vec3::X, false);
    }
    let bp = p - b;
    let d3 = ab.dot(bp);
    let d4 = ac.dot(bp);
    if d3 >= 0.0 && d4 <= d3 {
        return (Vec3::Y, false);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return (Vec3::new(1.0 - v, v, 0.0), false);
    }
    let cp = p - c;
    let d5 = ab.dot(cp);
    let d6 = ac.dot(cp);
    if d6 >= 0.0 && d5 <= d6 {
        return (Vec3::Z, false);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return (Vec3::new(1.0 - w, 0.0, w), false);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (Vec3::new(0.0, 1.0 - w, w), false);
    }
    let denom = 1.0 / (va + vb + vc);
    let v = vb * denom;
    let w = vc * denom;
    (Vec3::new(1.0 - v - w, v, w), true)
}

/// Outside the hull: the probes and weights of the nearest point on the hull (a continuous
/// projection), among the hull triangles `x` lies beyond. A triangle holding `x`'s projection
/// onto its plane holds the nearest point (the hull lies behind that plane) and ends the
/// search; otherwise the nearest edge or corner point wins (ranking distances there, not
/// everywhere, keeps f32 rounding from choosing between nearly coplanar triangles). `start`
/// (probes, weights, squared distance) is the best candidate yet: the nearest point of the
/// face the walk left by, which prunes most triangles by their plane alone.
fn hull_weights(
    ir: &PackedIrradiance,
    params: &DiffuseParams,
    x: Vec3,
    start: ([u32; 3], Vec3, f32),
) -> Option<([u32; 3], Vec3)> {
    let word = |at: usize| f32::from_bits(ir.words[at]);
    let corner = |at: usize| Vec3::new(word(at), word(at + 1), word(at + 2));
    let mut best = start.2;
    let mut found = (best < 3.4e38).then_some((start.0, start.1));
    for h in 0..params.hull_count as usize {
        let at = params.hull as usize + h * HULL_WORDS;
        // Beyond the face's plane, and the plane (a lower bound) not clearly farther than the
        // best yet (the margin keeps a near tie for the projection test below).
        let above = corner(at + 12).dot(x) - word(at + 15);
        if above <= 0.0 || above * above > best * 1.001 {
            continue;
        }
        let (a, b, c) = (corner(at), corner(at + 4), corner(at + 8));
        let (l, inside) = closest_on_triangle(x, a, b, c);
        let e = x - a - (b - a) * l.y - (c - a) * l.z;
        let d = e.dot(e);
        if inside || d < best {
            best = d;
            found = Some(([ir.words[at + 3], ir.words[at + 7], ir.words[at + 11]], l));
            if inside {
                break;
            }
        }
    }
    found
}

/// `visibility^exponent`, with `0^0 = 1` and `0^k = 0`, as `gpu/diffuse.wgsl` computes it.
fn sharpen(visibility: f32, exponent: f32) -> f32 {
    if exponent == 0.0 {
        1.0
    } else if visibility <= 0.0 {
        0.0
    } else if exponent == exponent.floor() && exponent <= 16.0 {
        // Whole exponents (the defaults) by multiplication, as the shader does.
        let mut p = visibility;
        for _ in 1..exponent as u32 {
            p *= visibility;
        }
        p
    } else {
        visibility.powf(exponent)
    }
}

/// Probes and interpolation weights at `x`.
fn weights(ir: &PackedIrradiance, params: &DiffuseParams, x: Vec3) -> ([u32; 8], [f32; 8]) {
    let mut probes = [0u32; 8];
    let mut w = [0.0f32; 8];
    if params.interpolation == INTERPOLATE_GRID {
        let g = &params.grid;
        let origin = Vec3::from(g.origin);
        let spacing = Vec3::from(g.spacing);
        let counts = UVec3::new(g.count_x, g.count_y, g.count_z);
        let max = (counts - UVec3::splat(2)).as_vec3();
        let nps = (x - origin) / spacing;
        let base_f = nps.floor().clamp(Vec3::ZERO, max);
        let base = base_f.as_uvec3();
        let f = (nps - base_f).clamp(Vec3::ZERO, Vec3::ONE);
        for slot in 0..8u32 {
            let bits = UVec3::new(slot & 1, (slot >> 1) & 1, slot >> 2);
            let c = base + bits;
            probes[slot as usize] = c.x + counts.x * (c.y + counts.y * c.z);
            let pick = |bit: u32, v: f32| if bit == 1 { v } else { 1.0 - v };
            w[slot as usize] = pick(bits.x, f.x) * pick(bits.y, f.y) * pick(bits.z, f.z);
        }
    } else {
        let nearest = super::select::nearest_probe(&ir.words, params.kd_nodes, params.kd_count, x);
        let mut tet = ir.words[(params.vertex_tets + nearest) as usize];
        let record = |t: u32| -> TetRecord {
            let at = (params.tets + t * TET_WORDS as u32) as usize;
            bytemuck::cast_slice::<u32, TetRecord>(&ir.words[at..at + TET_WORDS])[0]
        };
        let mut current = record(tet);
        let mut l = current.barycentric_of(x);
        for _ in 0..params.max_walk_steps {
            let mut worst = 0usize;
            for i in 1..4 {
                if l[i] < l[worst] {
                    worst = i;
                }
            }
            if l[worst] >= 0.0 {
                break;
            }
            let next = current.neighbours[worst];
            if next == NO_NEIGHBOUR {
                // Beyond a hull face's plane: outside the (convex) hull. Most often x's
                // projection onto that face lies inside it: then it is the nearest hull point,
                // and the search over the hull is not needed.
                let mut k = 0;
                let mut corners = [Vec3::ZERO; 3];
                for i in 0..4 {
                    if i != worst {
                        probes[k] = current.vertices[i];
                        corners[k] = Vec3::from_slice(&ir.positions[probes[k] as usize][..3]);
                        k += 1;
                    }
                }
                let (l, inside) = closest_on_triangle(x, corners[0], corners[1], corners[2]);
                if inside {
                    w[..3].copy_from_slice(&l.to_array());
                    return (probes, w);
                }
                // Else its nearest edge or corner point starts the search (and prunes it).
                let e = x
                    - corners[0]
                    - (corners[1] - corners[0]) * l.y
                    - (corners[2] - corners[0]) * l.z;
                let start = ([probes[0], probes[1], probes[2]], l, e.dot(e));
                if let Some((hull_probes, l)) = hull_weights(ir, params, x, start) {
                    probes[..3].copy_from_slice(&hull_probes);
                    w[..3].copy_from_slice(&l.to_array());
                    return (probes, w);
                }
                break;
            }
            tet = next;
            current = record(tet);
            l = current.barycentric_of(x);
        }
        let c = l.map(|v| v.max(0.0));
        let sum = c[0] + c[1] + c[2] + c[3];
        for i in 0..4 {
            probes[i] = current.vertices[i];
            w[i] = if sum > 0.0 { c[i] / sum } else { 0.25 };
        }
    }
    (probes, w)
}

/// Shades one point.
pub(super) fn shade(
    ir: &PackedIrradiance,
    params: &DiffuseParams,
    point: &ShadingPoint,
) -> DiffuseResult {
    let x = Vec3::from(point.position);
    let n = Vec3::from(point.normal);
    let (probes, w) = weights(ir, params, x);
    let irradiance: &[[f32; 3]] = bytemuck::cast_slice(&ir.irradiance);
    let mut sum = Vec3::ZERO;
    let mut weight_sum = 0.0f32;
    for (&probe, &interpolation) in probes.iter().zip(&w) {
        if interpolation <= 0.0 {
            continue;
        }
        let mut weight = interpolation;
        let p = Vec3::from_slice(&ir.positions[probe as usize][..3]);
        if params.backface != 0 {
            let to_probe = p - x;
            let length = to_probe.length();
            let facing = if length > 0.0 {
                (to_probe / length).dot(n)
            } else {
                0.0
            };
            let f = (facing + 1.0) * 0.5;
            weight *= f * f + 0.2;
        }
        if params.visibility != 0 {
            let v = x + n * params.normal_bias - p;
            let distance = v.length();
            let direction = if distance > 0.0 { v / distance } else { n };
            let m = sample_bilinear(&ir.moments, params.moments_resolution, probe, direction);
            let visibility = probe_octa::chebyshev_visibility(Vec2::from(m), distance);
            weight *= sharpen(visibility, params.visibility_exponent).max(params.min_weight);
        }
        let e = Vec3::from(sample_bilinear(
            irradiance,
            params.irradiance_resolution,
            probe,
            n,
        ));
        sum += e * weight;
        weight_sum += weight;
    }
    DiffuseResult {
        irradiance: if weight_sum > 0.0 {
            sum / weight_sum
        } else {
            Vec3::ZERO
        },
        weight: weight_sum,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The hand-written bilinear read equals `probe_octa`'s seam-correct sampler.
    #[test]
    fn bilinear_matches_probe_octa() {
        let n = 6;
        let maps: Vec<probe_octa::OctaMap<Vec3>> = (0..3)
            .map(|k| {
                probe_octa::OctaMap::from_fn(n, |d| Vec3::new(d.x + k as f32, d.y * d.z, 1.0 - d.z))
                    .unwrap()
            })
            .collect();
        let texels: Vec<[f32; 3]> = maps
            .iter()
            .flat_map(|m| m.texels().iter().map(|t| t.to_array()))
            .collect();
        let mut s = 7u64;
        for i in 0..500 {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1);
            let d = probe_octa::decode(Vec2::new(
                (s >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0,
                (s >> 16 & 0xFFFFFF) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0,
            ));
            let probe = i % 3;
            let ours = Vec3::from(sample_bilinear(&texels, n, probe, d));
            let theirs = maps[probe as usize].sample(d);
            assert!(ours.abs_diff_eq(theirs, 1e-5), "{ours} vs {theirs}");
        }
    }
}
