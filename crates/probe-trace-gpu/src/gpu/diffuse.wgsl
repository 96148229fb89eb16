// Diffuse shading from irradiance probes: one invocation per shading point. Compiled after
// common.wgsl. Step for step the same as src/cpu/diffuse.rs.

const INTERPOLATE_GRID: u32 = 0u;
const NO_NEIGHBOUR: u32 = 0xffffffffu;
const TET_WORDS: u32 = 20u;

// src/packed.rs DiffuseParams (112 bytes).
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
    pad0: u32,
    pad1: u32,
    pad2: u32,
    grid: GridParams,
    tets: u32,
    tet_count: u32,
    vertex_tets: u32,
    kd_nodes: u32,
    kd_count: u32,
    pad3: u32,
    pad4: u32,
    pad5: u32,
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
// Tetrahedra, a tetrahedron per probe, k-d tree nodes.
@group(0) @binding(6) var<storage, read> words: array<u32>;

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
            let pick = select(vec3<f32>(1.0) - f, f, bits == vec3<u32>(1u));
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
        if (next == NO_NEIGHBOUR) {
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

fn shade(point: ShadingPoint) -> vec4<f32> {
    let x = point.position;
    let n = point.normal;
    let weights = interpolation_weights(x);
    var sum = vec3<f32>(0.0);
    var weight_sum = 0.0;
    for (var i = 0u; i < 8u; i++) {
        let interpolation = weights.w[i];
        if (interpolation <= 0.0) {
            continue;
        }
        let probe = weights.probes[i];
        var weight = interpolation;
        if (params.visibility != 0u) {
            let v = x + n * params.normal_bias - positions[probe].xyz;
            let distance = length(v);
            var direction = n;
            if (distance > 0.0) {
                direction = v / distance;
            }
            let visibility = chebyshev(sample_moments(probe, direction), distance);
            weight *= visibility * visibility * visibility;
        }
        sum += sample_irradiance(probe, n) * weight;
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
