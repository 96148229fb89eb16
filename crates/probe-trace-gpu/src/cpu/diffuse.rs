//! Diffuse shading from irradiance probes (seed 001 §4.3.6–4.3.7), step for step as
//! `gpu/diffuse.wgsl` does it.

use glam::{UVec3, Vec2, Vec3};
use probe_index::TetRecord;

use crate::packed::{
    DiffuseParams, HULL_FACE, HULL_WORDS, INTERPOLATE_GRID, MAX_HULL_FAN, PackedIrradiance,
    SURFEL_VEC4S, TET_WORDS, padded_index, unpack_surfel,
};
use crate::ray::{DiffuseResult, ShadingPoint};

/// The least trilinear weight along each axis of a grid cage (DDGI's 0.001; `gpu/diffuse.wgsl`
/// holds the same).
pub(crate) const GRID_WEIGHT_FLOOR: f32 = 0.001;

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

/// One packed hull triangle (`HULL_WORDS` words at `params.hull + h · HULL_WORDS`).
struct HullTriangle {
    corners: [Vec3; 3],
    probes: [u32; 3],
    /// Outward unit normal and offset: `normal · x > offset` beyond the triangle.
    normal: Vec3,
    offset: f32,
    /// The hull triangles across the edges opposite corners 0, 1, 2.
    adjacent: [u32; 3],
}

fn hull_triangle(ir: &PackedIrradiance, params: &DiffuseParams, h: u32) -> HullTriangle {
    let at = params.hull as usize + h as usize * HULL_WORDS;
    let word = |k: usize| f32::from_bits(ir.words[at + k]);
    let vec = |k: usize| Vec3::new(word(k), word(k + 1), word(k + 2));
    HullTriangle {
        corners: [vec(0), vec(4), vec(8)],
        probes: [ir.words[at + 3], ir.words[at + 7], ir.words[at + 11]],
        normal: vec(12),
        offset: word(15),
        adjacent: [ir.words[at + 16], ir.words[at + 17], ir.words[at + 18]],
    }
}

impl HullTriangle {
    /// `closest_on_triangle` of `x` on this triangle.
    fn closest(&self, x: Vec3) -> (Vec3, bool) {
        closest_on_triangle(x, self.corners[0], self.corners[1], self.corners[2])
    }

    /// Whether `x` lies strictly beyond the triangle's plane.
    fn beyond(&self, x: Vec3) -> bool {
        self.normal.dot(x) - self.offset > 0.0
    }

    /// Squared distance from `x` to the point with barycentric coordinates `l`.
    fn distance2(&self, x: Vec3, l: Vec3) -> f32 {
        let [a, b, c] = self.corners;
        let e = x - a - (b - a) * l.y - (c - a) * l.z;
        e.dot(e)
    }
}

/// Outside the hull: the probes and weights of the nearest point on the hull (a continuous
/// projection), by a descent over the hull's triangles from `start` (the hull triangle the walk
/// left by), or `None` when the descent needed more than `params.max_hull_steps` moves (or met
/// an inconsistent hull): then `hull_weights` scans.
///
/// Only triangles `x` lies beyond are entered; on them every local minimum of the distance is
/// the global one (the hull is convex), so the descent stops at the nearest point. Each move is
/// decided by `closest_on_triangle`'s region tests, which are first order in `x` (dot products
/// with the edges), never by comparing squared distances of candidates that are nearly the
/// same point: those differ by the square of their separation, so f32 rounding of the
/// distances (relative 1e-7) cannot tell apart points up to `√1e-7 · d` apart, and picked a
/// corner where the true nearest point lay 7e-5 along an edge (the jump of
/// `known_discontinuity_outside_the_hull` once the visibility weighting amplified it):
/// - inside a triangle (x's projection onto its plane): that is the nearest point;
/// - on an edge: the nearest point unless the triangle across that edge is beyond `x` and its
///   own nearest point is off the shared edge (then move there);
/// - on a corner: the nearest point unless some triangle around that corner is beyond `x` and
///   its own nearest point is not the corner (then move to the nearest of those).
///
/// In exact arithmetic each move strictly shortens the distance, so it cannot cycle.
fn hull_descent(
    ir: &PackedIrradiance,
    params: &DiffuseParams,
    x: Vec3,
    start: u32,
) -> Option<([u32; 3], Vec3)> {
    let mut h = start;
    let mut f = hull_triangle(ir, params, h);
    let (mut l, mut inside) = f.closest(x);
    for _ in 0..params.max_hull_steps {
        if inside {
            return Some((f.probes, l));
        }
        let zeros = (0..3).filter(|&k| l[k] == 0.0).count();
        if zeros == 0 {
            // Not inside, yet on no edge or corner (closest_on_triangle never answers so).
            return None;
        }
        // The triangle to move to, its nearest point and whether that is inside it.
        let mut next: Option<(u32, HullTriangle, Vec3, bool)> = None;
        if zeros == 1 {
            // On the edge opposite corner k.
            let k = (0..3).find(|&k| l[k] == 0.0).unwrap_or(0);
            let g = f.adjacent[k];
            let t = hull_triangle(ir, params, g);
            if t.beyond(x) {
                let (lg, ig) = t.closest(x);
                // The corner of g off the shared edge.
                let far = (0..3).find(|&j| !f.probes.contains(&t.probes[j]))?;
                if lg[far] > 0.0 {
                    next = Some((g, t, lg, ig));
                }
            }
        } else {
            // On corner m: turn around it (across the edge opposite the next corner, the
            // same way round in every triangle: they are all counter-clockwise from outside).
            let m = (0..3).find(|&k| l[k] != 0.0).unwrap_or(0);
            let v = f.probes[m];
            let mut best = f32::INFINITY;
            let mut g = f.adjacent[(m + 1) % 3];
            let mut turns = 0u32;
            while g != h {
                turns += 1;
                if turns > MAX_HULL_FAN {
                    return None;
                }
                let t = hull_triangle(ir, params, g);
                let slot = t.probes.iter().position(|&p| p == v)?;
                let around = t.adjacent[(slot + 1) % 3];
                if t.beyond(x) {
                    let (lg, ig) = t.closest(x);
                    if lg[(slot + 1) % 3] > 0.0 || lg[(slot + 2) % 3] > 0.0 {
                        let d = t.distance2(x, lg);
                        if next.is_none() || d < best {
                            best = d;
                            next = Some((g, t, lg, ig));
                        }
                    }
                }
                g = around;
            }
        }
        let Some((g, t, lg, ig)) = next else {
            return Some((f.probes, l));
        };
        (h, f, l, inside) = (g, t, lg, ig);
    }
    None
}

/// Outside the hull, the exhaustive fallback of `hull_descent`: the probes and weights of the
/// nearest point on the hull among the hull triangles `x` lies beyond. A triangle holding `x`'s
/// projection onto its plane holds the nearest point (the hull lies behind that plane) and ends
/// the search; otherwise the nearest edge or corner point wins by squared distance (f32
/// rounding makes that ranking uncertain between points up to about `√1e-7 · d` apart, which
/// the descent's first-order tests avoid).
fn hull_weights(
    ir: &PackedIrradiance,
    params: &DiffuseParams,
    x: Vec3,
) -> Option<([u32; 3], Vec3)> {
    let mut best = f32::INFINITY;
    let mut found = None;
    for h in 0..params.hull_count {
        let t = hull_triangle(ir, params, h);
        // Beyond the face's plane, and the plane (a lower bound) not clearly farther than the
        // best yet (the margin keeps a near tie for the projection test below).
        let above = t.normal.dot(x) - t.offset;
        if above <= 0.0 || above * above > best * 1.001 {
            continue;
        }
        let (l, inside) = t.closest(x);
        let d = t.distance2(x, l);
        if inside || d < best {
            best = d;
            found = Some((t.probes, l));
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
            // DDGI's floor per axis: every probe of the cage keeps a little weight, so a
            // point whose nearest probes are inside geometry or hidden from it is lit by the
            // others (outside the lattice the clamped weights are otherwise exactly zero).
            let pick = |bit: u32, v: f32| {
                let along = if bit == 1 { v } else { 1.0 - v };
                along.max(GRID_WEIGHT_FLOOR)
            };
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
            if next & HULL_FACE != 0 {
                // Beyond a hull face's plane: outside the (convex) hull. The nearest point on
                // the hull, by the descent from that face (by the scan where it gives up).
                let h = next & !HULL_FACE;
                let nearest = if h < params.hull_count {
                    hull_descent(ir, params, x, h)
                } else {
                    None
                };
                if let Some((hull_probes, l)) = nearest.or_else(|| hull_weights(ir, params, x)) {
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

/// `probe_octa::surfel_irradiance` of `probe`'s packed surfels at `x` (the sum
/// `gpu/diffuse.wgsl` computes in the same order).
fn surfel_irradiance(
    ir: &PackedIrradiance,
    params: &DiffuseParams,
    probe: u32,
    x: Vec3,
    n: Vec3,
) -> Vec3 {
    let count = params.surfels_per_probe as usize * SURFEL_VEC4S;
    let first = probe as usize * count;
    let packed = &ir.surfels[first..first + count];
    probe_octa::surfel_irradiance(packed.chunks_exact(SURFEL_VEC4S).map(unpack_surfel), x, n)
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
        // A probe inside geometry (flagged in `w`) is left out.
        if interpolation <= 0.0 || ir.positions[probe as usize][3] != 0.0 {
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
        let mut e = Vec3::from(sample_bilinear(
            irradiance,
            params.irradiance_resolution,
            probe,
            n,
        ));
        if params.parallax != 0 {
            // The surfels' irradiance at the probe is stored as the map of probe
            // `probe_count + probe`.
            let at_probe = Vec3::from(sample_bilinear(
                irradiance,
                params.irradiance_resolution,
                params.probe_count + probe,
                n,
            ));
            e *= probe_octa::parallax_gain(surfel_irradiance(ir, params, probe, x, n), at_probe);
        }
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
    use proptest::prelude::*;

    use probe_testdata::Lcg;

    /// A probe set of kind `kind % 3`: a regular grid (cospherical, with coplanar hull
    /// triangles), a jittered grid, or uniform random points; 2 to 5 probes a side.
    fn probe_set(rng: &mut Lcg, kind: u32) -> Vec<Vec3> {
        let side = |rng: &mut Lcg| 2 + (rng.uniform() * 4.0) as u32;
        let (nx, ny, nz) = (side(rng), side(rng), side(rng));
        let spacing = Vec3::new(
            0.3 + rng.uniform() * 1.5,
            0.3 + rng.uniform() * 1.5,
            0.3 + rng.uniform() * 1.5,
        );
        let origin = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 10.0 - 5.0;
        let count = nx * ny * nz;
        (0..count)
            .map(|i| {
                let cell = Vec3::new(
                    (i % nx) as f32,
                    ((i / nx) % ny) as f32,
                    (i / (nx * ny)) as f32,
                );
                let r = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform());
                origin
                    + spacing
                        * match kind % 3 {
                            0 => cell,
                            1 => cell + (r - 0.5) * 0.8,
                            _ => r * Vec3::new(nx as f32, ny as f32, nz as f32),
                        }
            })
            .collect()
    }

    /// The packed irradiance (constant maps: only the geometry matters here) and the diffuse
    /// parameters of a probe set.
    fn packed(
        positions: &[Vec3],
        tets: &probe_index::Tetrahedralization,
    ) -> (PackedIrradiance, DiffuseParams) {
        let irradiance = vec![Vec3::ONE; positions.len() * 9];
        let moments = vec![Vec2::ONE; positions.len() * 9];
        let field = crate::input::IrradianceField {
            positions,
            irradiance_resolution: 1,
            irradiance: &irradiance,
            moments_resolution: 1,
            moments: &moments,
            surfels: &[],
            inside_geometry: &[],
        };
        let ir =
            PackedIrradiance::new(&field, &crate::input::Interpolation::Delaunay(tets)).unwrap();
        let params =
            crate::packed::diffuse_params(&ir, &crate::ray::DiffuseOptions::default()).unwrap();
        (ir, params)
    }

    /// The point with barycentric coordinates `l` on the triangle of `probes`.
    fn point(ir: &PackedIrradiance, probes: &[u32], l: &[f32]) -> Vec3 {
        probes
            .iter()
            .zip(l)
            .map(|(&p, &w)| Vec3::from_slice(&ir.positions[p as usize][..3]) * w)
            .sum()
    }

    /// The descent over the hull finds the same nearest point as the exhaustive scan (and as
    /// `probe_index`'s f64 search), from every hull triangle a point outside lies beyond, on
    /// random probe sets; and the whole blend (walk, then descent) agrees with the f64 search.
    fn descent_matches_scan(seed: u64, kind: u32) -> Result<(), TestCaseError> {
        let mut rng = Lcg(seed);
        let positions = probe_set(&mut rng, kind);
        let Ok(tets) = probe_index::Tetrahedralization::build(&positions) else {
            return Err(TestCaseError::reject("no volume"));
        };
        if tets.tetrahedra().is_empty() {
            return Err(TestCaseError::reject("no volume"));
        }
        let (ir, params) = packed(&positions, &tets);
        let lo = positions.iter().fold(Vec3::INFINITY, |m, &p| m.min(p));
        let hi = positions.iter().fold(Vec3::NEG_INFINITY, |m, &p| m.max(p));
        let size = (hi - lo).max_element();
        let mut outside = 0;
        for _ in 0..64 {
            // Around the probes' box, out to its size beyond each side.
            let r = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform());
            let x = lo - (hi - lo) + r * (hi - lo) * 3.0;
            let reference = tets.locate(x).unwrap();
            if reference.outside_distance <= 1e-3 * size {
                continue;
            }
            outside += 1;
            let d = reference.outside_distance;
            let exact = point(&ir, &reference.probes, &reference.weights);
            let (scan_probes, scan_l) = hull_weights(&ir, &params, x).unwrap();
            let scan = point(&ir, &scan_probes, &scan_l.to_array());
            // The scan ranks squared distances: its point may be off by about √ε·d.
            prop_assert!(
                (scan - exact).length() <= 2e-3 * d + 1e-5 * size,
                "scan {scan} vs f64 {exact} at {x}"
            );
            for h in 0..params.hull_count {
                if !hull_triangle(&ir, &params, h).beyond(x) {
                    continue;
                }
                let Some((probes, l)) = hull_descent(&ir, &params, x, h) else {
                    return Err(TestCaseError::fail(format!(
                        "the descent from hull triangle {h} gave up at {x}"
                    )));
                };
                let found = point(&ir, &probes, &l.to_array());
                prop_assert!(
                    ((found - x).length() - (scan - x).length()).abs() <= 1e-5 * (d + size),
                    "distance {} (descent from {h}) vs {} (scan) at {x}",
                    (found - x).length(),
                    (scan - x).length()
                );
                prop_assert!(
                    (found - scan).length() <= 2e-3 * d + 1e-5 * size,
                    "descent from {h} {found} vs scan {scan} at {x}"
                );
                // First-order tests only: as close to the f64 answer as rounding allows.
                prop_assert!(
                    (found - exact).length() <= 1e-5 * (d + size),
                    "descent from {h} {found} vs f64 {exact} at {x}"
                );
            }
            // The whole blend: the walk, then the descent from the face it left by.
            let (probes, w) = weights(&ir, &params, x);
            let blended = point(&ir, &probes, &w);
            prop_assert!(
                (blended - exact).length() <= 1e-5 * (d + size),
                "blend {blended} vs f64 {exact} at {x}"
            );
        }
        prop_assert!(outside > 0);
        Ok(())
    }

    proptest! {
        // A fixed seed: the same cases on every run.
        #![proptest_config(ProptestConfig {
            cases: 96,
            rng_seed: proptest::test_runner::RngSeed::Fixed(3),
            failure_persistence: None,
            ..ProptestConfig::default()
        })]

        #[test]
        fn hull_descent_finds_the_scans_nearest_point(seed in any::<u64>(), kind in 0u32..3) {
            descent_matches_scan(seed, kind)?;
        }
    }

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
