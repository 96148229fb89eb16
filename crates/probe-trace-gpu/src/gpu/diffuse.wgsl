// Diffuse shading from irradiance probes: one invocation per shading point. Compiled after
// common.wgsl. Step for step the same as src/cpu/diffuse.rs.

const INTERPOLATE_GRID: u32 = 0u;
const TET_WORDS: u32 = 20u;
// src/packed.rs HULL_WORDS, HULL_FACE, MAX_HULL_FAN.
const HULL_WORDS: u32 = 20u;
const HULL_FACE: u32 = 0x80000000u;
const MAX_HULL_FAN: u32 = 64u;

// src/packed.rs SURFEL_VEC4S.
const SURFEL_VEC4S: u32 = 5u;
// probe-octa's MIN_COVERAGE_SCALE, MAX_COVERAGE_SCALE and MAX_PARALLAX_GAIN.
const MIN_COVERAGE_SCALE: f32 = 0.5;
const MAX_COVERAGE_SCALE: f32 = 4.0;
const MAX_PARALLAX_GAIN: f32 = 16.0;
const FRAC_1_PI: f32 = 0.31830987;
// src/cpu/diffuse.rs GRID_WEIGHT_FLOOR.
const GRID_WEIGHT_FLOOR: f32 = 0.001;
const PI: f32 = 3.1415927;

// src/packed.rs DiffuseParams (128 bytes).
struct DiffuseParams {
    point_count: u32,
    threads_per_row: u32,
    probe_count: u32,
    interpolation: u32,
    irradiance_resolution: u32,
    moments_resolution: u32,
    visibility: u32,
    max_walk_steps: u32,
    normal_bias: f32,
    hull: u32,
    hull_count: u32,
    visibility_exponent: f32,
    grid: GridParams,
    tets: u32,
    tet_count: u32,
    vertex_tets: u32,
    kd_nodes: u32,
    kd_count: u32,
    min_weight: f32,
    backface: u32,
    max_hull_steps: u32,
    parallax: u32,
    surfels_per_probe: u32,
    pad0: u32,
    pad1: u32,
}

// src/ray.rs ShadingPoint (32 bytes).
struct ShadingPoint {
    position: vec3<f32>,
    pad0: f32,
    normal: vec3<f32>,
    pad1: f32,
}

@group(0) @binding(0) var<uniform> params: DiffuseParams;
@group(0) @binding(1) var<storage, read> points: array<ShadingPoint>;
// Irradiance (rgb) and the weight sum per point.
@group(0) @binding(2) var<storage, read_write> results: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> positions: array<vec4<f32>>;
// 3 floats per padded texel.
@group(0) @binding(4) var<storage, read> irradiance: array<f32>;
@group(0) @binding(5) var<storage, read> moments: array<vec2<f32>>;
// Tetrahedra, a tetrahedron per probe, k-d tree nodes, convex-hull triangles.
@group(0) @binding(6) var<storage, read> words: array<u32>;
// Surfels: (position, area), (normal, sky solid angle), (radiance, 0), (sky direction, 0),
// (sky radiance, 0).
@group(0) @binding(7) var<storage, read> surfels: array<vec4<f32>>;

// Bilinear taps of a padded octahedral map (probe_octa::OctaMap::sample): the index of the
// top-left tap and the weights along x and y.
struct Taps {
    i00: u32,
    side: u32,
    tx: f32,
    ty: f32,
}

fn bilinear_taps(n: u32, probe: u32, direction: vec3<f32>) -> Taps {
    let nf = f32(n);
    let o = clamp(octa_encode(direction), vec2<f32>(-1.0), vec2<f32>(1.0));
    let c = vec2<f32>(1.0) + (o + vec2<f32>(1.0)) * (0.5 * nf) - vec2<f32>(0.5);
    let x0 = min(u32(max(floor(c.x), 0.0)), n);
    let y0 = min(u32(max(floor(c.y), 0.0)), n);
    let tx = clamp(c.x - f32(x0), 0.0, 1.0);
    let ty = clamp(c.y - f32(y0), 0.0, 1.0);
    let side = n + 2u;
    return Taps(probe * side * side + y0 * side + x0, side, tx, ty);
}

fn irradiance_texel(i: u32) -> vec3<f32> {
    return vec3<f32>(irradiance[3u * i], irradiance[3u * i + 1u], irradiance[3u * i + 2u]);
}

fn sample_irradiance(probe: u32, direction: vec3<f32>) -> vec3<f32> {
    let k = bilinear_taps(params.irradiance_resolution, probe, direction);
    var v = vec3<f32>(0.0);
    v += irradiance_texel(k.i00) * ((1.0 - k.tx) * (1.0 - k.ty));
    v += irradiance_texel(k.i00 + 1u) * (k.tx * (1.0 - k.ty));
    v += irradiance_texel(k.i00 + k.side) * ((1.0 - k.tx) * k.ty);
    v += irradiance_texel(k.i00 + k.side + 1u) * (k.tx * k.ty);
    return v;
}

fn sample_moments(probe: u32, direction: vec3<f32>) -> vec2<f32> {
    let k = bilinear_taps(params.moments_resolution, probe, direction);
    var v = vec2<f32>(0.0);
    v += moments[k.i00] * ((1.0 - k.tx) * (1.0 - k.ty));
    v += moments[k.i00 + 1u] * (k.tx * (1.0 - k.ty));
    v += moments[k.i00 + k.side] * ((1.0 - k.tx) * k.ty);
    v += moments[k.i00 + k.side + 1u] * (k.tx * k.ty);
    return v;
}

// probe_octa::chebyshev_visibility (distance > mean here means variance + excess² > 0).
fn chebyshev(m: vec2<f32>, distance: f32) -> f32 {
    let mean = m.x;
    if (distance <= mean) {
        return 1.0;
    }
    let variance = abs(mean * mean - m.y);
    let excess = distance - mean;
    return clamp(variance / (variance + excess * excess), 0.0, 1.0);
}

// visibility^exponent, with 0^0 = 1 and 0^k = 0.
fn sharpen(visibility: f32, exponent: f32) -> f32 {
    if (exponent == 0.0) {
        return 1.0;
    }
    if (visibility <= 0.0) {
        return 0.0;
    }
    // Whole exponents (the defaults) by multiplication, the same on the CPU twin.
    if (exponent == floor(exponent) && exponent <= 16.0) {
        var p = visibility;
        for (var i = 1u; i < u32(exponent); i++) {
            p *= visibility;
        }
        return p;
    }
    return pow(visibility, exponent);
}

struct Weights {
    probes: array<u32, 8>,
    w: array<f32, 8>,
}

fn tet_barycentric(t: u32, x: vec3<f32>) -> vec4<f32> {
    let at = params.tets + t * TET_WORDS + 8u;
    var l: array<f32, 3>;
    for (var r = 0u; r < 3u; r++) {
        let b = at + 4u * r;
        l[r] = bitcast<f32>(words[b]) * x.x + bitcast<f32>(words[b + 1u]) * x.y
            + bitcast<f32>(words[b + 2u]) * x.z + bitcast<f32>(words[b + 3u]);
    }
    return vec4<f32>(l[0], l[1], l[2], 1.0 - l[0] - l[1] - l[2]);
}

fn hull_vec4(at: u32) -> vec4<f32> {
    return vec4<f32>(bitcast<f32>(words[at]), bitcast<f32>(words[at + 1u]),
        bitcast<f32>(words[at + 2u]), bitcast<f32>(words[at + 3u]));
}

// Barycentric coordinates of the point of triangle abc nearest to p (Ericson, Real-Time
// Collision Detection §5.1.5), and w = 1 where that point is p's projection onto the
// triangle's plane (inside the triangle), 0 where it is on an edge or a corner.
fn closest_on_triangle(p: vec3<f32>, a: vec3<f32>, b: vec3<f32>, c: vec3<f32>) -> vec4<f32> {
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = dot(ab, ap);
    let d2 = dot(ac, ap);
    if (d1 <= 0.0 && d2 <= 0.0) {
        return vec4<f32>(1.0, 0.0, 0.0, 0.0);
    }
    let bp = p - b;
    let d3 = dot(ab, bp);
    let d4 = dot(ac, bp);
    if (d3 >= 0.0 && d4 <= d3) {
        return vec4<f32>(0.0, 1.0, 0.0, 0.0);
    }
    let vc = d1 * d4 - d3 * d2;
    if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
        let v = d1 / (d1 - d3);
        return vec4<f32>(1.0 - v, v, 0.0, 0.0);
    }
    let cp = p - c;
    let d5 = dot(ab, cp);
    let d6 = dot(ac, cp);
    if (d6 >= 0.0 && d5 <= d6) {
        return vec4<f32>(0.0, 0.0, 1.0, 0.0);
    }
    let vb = d5 * d2 - d1 * d6;
    if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
        let w = d2 / (d2 - d6);
        return vec4<f32>(1.0 - w, 0.0, w, 0.0);
    }
    let va = d3 * d6 - d5 * d4;
    if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return vec4<f32>(0.0, 1.0 - w, w, 0.0);
    }
    let denom = 1.0 / (va + vb + vc);
    let v = vb * denom;
    let w = vc * denom;
    return vec4<f32>(1.0 - v - w, v, w, 1.0);
}

// One packed hull triangle (src/packed.rs HULL_WORDS): corners, their probes, the outward
// plane (dot(normal, x) > offset beyond it), the triangles across the edges opposite corners
// 0, 1, 2.
struct HullTriangle {
    a: vec3<f32>,
    b: vec3<f32>,
    c: vec3<f32>,
    probes: vec3<u32>,
    plane: vec4<f32>,
    adjacent: vec3<u32>,
}

fn hull_triangle(h: u32) -> HullTriangle {
    let at = params.hull + h * HULL_WORDS;
    return HullTriangle(hull_vec4(at).xyz, hull_vec4(at + 4u).xyz, hull_vec4(at + 8u).xyz,
        vec3<u32>(words[at + 3u], words[at + 7u], words[at + 11u]), hull_vec4(at + 12u),
        vec3<u32>(words[at + 16u], words[at + 17u], words[at + 18u]));
}

fn hull_beyond(t: HullTriangle, x: vec3<f32>) -> bool {
    return dot(t.plane.xyz, x) - t.plane.w > 0.0;
}

fn hull_closest(t: HullTriangle, x: vec3<f32>) -> vec4<f32> {
    return closest_on_triangle(x, t.a, t.b, t.c);
}

fn hull_distance2(t: HullTriangle, x: vec3<f32>, l: vec4<f32>) -> f32 {
    let e = x - t.a - (t.b - t.a) * l.y - (t.c - t.a) * l.z;
    return dot(e, e);
}

fn set_hull_weights(out: ptr<function, Weights>, t: HullTriangle, l: vec4<f32>) {
    (*out).probes[0] = t.probes.x;
    (*out).probes[1] = t.probes.y;
    (*out).probes[2] = t.probes.z;
    (*out).w[0] = l.x;
    (*out).w[1] = l.y;
    (*out).w[2] = l.z;
}

// Outside the hull: the weights of the nearest point on the hull (a continuous projection),
// by a descent over the hull triangles from `start` (the one the walk left by); false when it
// needed more than params.max_hull_steps moves or met an inconsistent hull (then the scan
// answers). Moves are decided by closest_on_triangle's first-order region tests, never by
// ranking squared distances of nearly the same point (src/cpu/diffuse.rs hull_descent says
// why): inside a triangle, done; on an edge, move across it if the triangle there is beyond x
// and its nearest point is off the shared edge; on a corner, move to the nearest of the
// triangles around it that are beyond x and whose nearest point is not the corner.
fn hull_descent(x: vec3<f32>, start: u32, out: ptr<function, Weights>) -> bool {
    var h = start;
    var f = hull_triangle(h);
    var l = hull_closest(f, x);
    for (var step = 0u; step < params.max_hull_steps; step++) {
        if (l.w == 1.0) {
            set_hull_weights(out, f, l);
            return true;
        }
        // The first zero coordinate and the first non-zero one, as on the CPU twin.
        var zeros = 0u;
        var k = 3u;
        var m = 3u;
        for (var i = 0u; i < 3u; i++) {
            if (l[i] == 0.0) {
                zeros++;
                if (k == 3u) {
                    k = i;
                }
            } else if (m == 3u) {
                m = i;
            }
        }
        if (zeros == 0u) {
            return false;
        }
        var moved = false;
        var g_next = 0u;
        var t_next: HullTriangle;
        var l_next = vec4<f32>(0.0);
        if (zeros == 1u) {
            // On the edge opposite corner k.
            let g = f.adjacent[k];
            let t = hull_triangle(g);
            if (hull_beyond(t, x)) {
                let lg = hull_closest(t, x);
                var far = 3u;
                for (var j = 0u; j < 3u; j++) {
                    if (far == 3u && all(f.probes != vec3<u32>(t.probes[j]))) {
                        far = j;
                    }
                }
                if (far == 3u) {
                    return false;
                }
                if (lg[far] > 0.0) {
                    moved = true;
                    g_next = g;
                    t_next = t;
                    l_next = lg;
                }
            }
        } else {
            // On corner m: turn around it (across the edge opposite the next corner, the same
            // way round in every triangle: they are all counter-clockwise from outside).
            let v = f.probes[m];
            var best = 0.0;
            var g = f.adjacent[(m + 1u) % 3u];
            var turns = 0u;
            while (g != h) {
                turns++;
                if (turns > MAX_HULL_FAN) {
                    return false;
                }
                let t = hull_triangle(g);
                var slot = 3u;
                for (var j = 0u; j < 3u; j++) {
                    if (slot == 3u && t.probes[j] == v) {
                        slot = j;
                    }
                }
                if (slot == 3u) {
                    return false;
                }
                let around = t.adjacent[(slot + 1u) % 3u];
                if (hull_beyond(t, x)) {
                    let lg = hull_closest(t, x);
                    if (lg[(slot + 1u) % 3u] > 0.0 || lg[(slot + 2u) % 3u] > 0.0) {
                        let d = hull_distance2(t, x, lg);
                        if (!moved || d < best) {
                            best = d;
                            moved = true;
                            g_next = g;
                            t_next = t;
                            l_next = lg;
                        }
                    }
                }
                g = around;
            }
        }
        if (!moved) {
            set_hull_weights(out, f, l);
            return true;
        }
        h = g_next;
        f = t_next;
        l = l_next;
    }
    return false;
}

// Outside the hull, the exhaustive fallback of hull_descent: the weights of the nearest point
// on the hull among the hull triangles x lies beyond. A triangle holding x's projection onto
// its plane holds the nearest point (the hull lies behind that plane) and ends the search;
// otherwise the nearest edge or corner point wins by squared distance. False when x lies
// beyond none (rounding at the hull).
fn hull_weights(x: vec3<f32>, out: ptr<function, Weights>) -> bool {
    var best = 3.4e38;
    var found = false;
    for (var h = 0u; h < params.hull_count; h++) {
        let t = hull_triangle(h);
        // Beyond the face's plane, and the plane (a lower bound) not clearly farther than the
        // best yet (the margin keeps a near tie for the projection test below).
        let above = dot(t.plane.xyz, x) - t.plane.w;
        if (above <= 0.0 || above * above > best * 1.001) {
            continue;
        }
        let l = hull_closest(t, x);
        let d = hull_distance2(t, x, l);
        if (l.w == 1.0 || d < best) {
            best = d;
            found = true;
            set_hull_weights(out, t, l);
            if (l.w == 1.0) {
                break;
            }
        }
    }
    return found;
}

fn interpolation_weights(x: vec3<f32>) -> Weights {
    var out: Weights;
    if (params.interpolation == INTERPOLATE_GRID) {
        let g = params.grid;
        let counts = vec3<u32>(g.count_x, g.count_y, g.count_z);
        let max_corner = vec3<f32>(counts - vec3<u32>(2u));
        let nps = (x - g.origin) / g.spacing;
        let base_f = clamp(floor(nps), vec3<f32>(0.0), max_corner);
        let base = vec3<u32>(base_f);
        let f = clamp(nps - base_f, vec3<f32>(0.0), vec3<f32>(1.0));
        for (var slot = 0u; slot < 8u; slot++) {
            let bits = vec3<u32>(slot & 1u, (slot >> 1u) & 1u, slot >> 2u);
            let c = base + bits;
            out.probes[slot] = c.x + counts.x * (c.y + counts.y * c.z);
            // DDGI's floor per axis (cpu/diffuse.rs, `GRID_WEIGHT_FLOOR`).
            let pick = max(select(vec3<f32>(1.0) - f, f, bits == vec3<u32>(1u)), vec3<f32>(GRID_WEIGHT_FLOOR));
            out.w[slot] = pick.x * pick.y * pick.z;
        }
        return out;
    }
    let nearest = nearest_probe(params.kd_nodes, params.kd_count, x);
    var tet = words[params.vertex_tets + nearest];
    var l = tet_barycentric(tet, x);
    for (var step = 0u; step < params.max_walk_steps; step++) {
        var worst = 0u;
        for (var i = 1u; i < 4u; i++) {
            if (l[i] < l[worst]) {
                worst = i;
            }
        }
        if (l[worst] >= 0.0) {
            break;
        }
        let next = words[params.tets + tet * TET_WORDS + 4u + worst];
        if ((next & HULL_FACE) != 0u) {
            // Beyond a hull face's plane: outside the (convex) hull. The nearest point on the
            // hull, by the descent from that face (by the scan where it gives up).
            for (var i = 0u; i < 8u; i++) {
                out.probes[i] = 0u;
                out.w[i] = 0.0;
            }
            let h = next & ~HULL_FACE;
            if (h < params.hull_count && hull_descent(x, h, &out)) {
                return out;
            }
            if (hull_weights(x, &out)) {
                return out;
            }
            break;
        }
        tet = next;
        l = tet_barycentric(tet, x);
    }
    let c = max(l, vec4<f32>(0.0));
    let sum = c.x + c.y + c.z + c.w;
    for (var i = 0u; i < 4u; i++) {
        out.probes[i] = words[params.tets + tet * TET_WORDS + i];
        if (sum > 0.0) {
            out.w[i] = c[i] / sum;
        } else {
            out.w[i] = 0.25;
        }
    }
    for (var i = 4u; i < 8u; i++) {
        out.probes[i] = 0u;
        out.w[i] = 0.0;
    }
    return out;
}

// probe_octa::surfel_irradiance of a probe's surfels at x (src/cpu/diffuse.rs).
fn surfel_irradiance(probe: u32, x: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let first = probe * params.surfels_per_probe;
    var sum = vec3<f32>(0.0);
    var coverage = 0.0;
    for (var s = 0u; s < params.surfels_per_probe; s++) {
        let at = (first + s) * SURFEL_VEC4S;
        let a = surfels[at];
        let b = surfels[at + 1u];
        let area = a.w;
        if (area > 0.0) {
            let v = a.xyz - x;
            let r2 = dot(v, v);
            if (r2 > 0.0) {
                let w = v / sqrt(r2);
                let cx = dot(n, w);
                let cs = -dot(b.xyz, w);
                if (cx > 0.0 && cs > 0.0) {
                    let c = area * cx * cs / (r2 + area * FRAC_1_PI);
                    sum += surfels[at + 2u].xyz * c;
                    coverage += c;
                }
            }
        }
        let sky = b.w;
        if (sky > 0.0) {
            let c = sky * max(dot(n, surfels[at + 3u].xyz), 0.0);
            sum += surfels[at + 4u].xyz * c;
            coverage += c;
        }
    }
    return sum * clamp(PI / max(coverage, 1e-6), MIN_COVERAGE_SCALE, MAX_COVERAGE_SCALE);
}

// probe_octa::parallax_gain.
fn parallax_gain(at_point: vec3<f32>, at_probe: vec3<f32>) -> vec3<f32> {
    let eps = 0.05 * (at_probe.x + at_probe.y + at_probe.z) / 3.0 + 1e-12;
    return min((at_point + vec3<f32>(eps)) / (at_probe + vec3<f32>(eps)), vec3<f32>(MAX_PARALLAX_GAIN));
}

fn shade(point: ShadingPoint) -> vec4<f32> {
    let x = point.position;
    let n = point.normal;
    let weights = interpolation_weights(x);
    var sum = vec3<f32>(0.0);
    var weight_sum = 0.0;
    for (var i = 0u; i < 8u; i++) {
        let interpolation = weights.w[i];
        let probe = weights.probes[i];
        // A probe inside geometry (flagged in `w`) is left out.
        if (interpolation <= 0.0 || positions[probe].w != 0.0) {
            continue;
        }
        var weight = interpolation;
        let p = positions[probe].xyz;
        if (params.backface != 0u) {
            let to_probe = p - x;
            let length_to_probe = length(to_probe);
            var facing = 0.0;
            if (length_to_probe > 0.0) {
                facing = dot(to_probe / length_to_probe, n);
            }
            let f = (facing + 1.0) * 0.5;
            weight *= f * f + 0.2;
        }
        if (params.visibility != 0u) {
            let v = x + n * params.normal_bias - p;
            let distance = length(v);
            var direction = n;
            if (distance > 0.0) {
                direction = v / distance;
            }
            let visibility = chebyshev(sample_moments(probe, direction), distance);
            weight *= max(sharpen(visibility, params.visibility_exponent), params.min_weight);
        }
        var e = sample_irradiance(probe, n);
        if (params.parallax != 0u) {
            // The surfels' irradiance at the probe is stored as the map of probe
            // probe_count + probe.
            let at_probe = sample_irradiance(params.probe_count + probe, n);
            e *= parallax_gain(surfel_irradiance(probe, x, n), at_probe);
        }
        sum += e * weight;
        weight_sum += weight;
    }
    if (weight_sum > 0.0) {
        return vec4<f32>(sum / weight_sum, weight_sum);
    }
    return vec4<f32>(0.0, 0.0, 0.0, weight_sum);
}

@compute @workgroup_size(64)
fn diffuse_main(@builtin(global_invocation_id) id: vec3<u32>) {
    let index = id.y * params.threads_per_row + id.x;
    if (index >= params.point_count) {
        return;
    }
    results[index] = shade(points[index]);
}
