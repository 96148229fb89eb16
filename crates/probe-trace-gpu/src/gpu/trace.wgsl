// The multi-probe light-field trace: one invocation per ray. Compiled after common.wgsl.
// Step for step the same as src/cpu/mod.rs (the ray loop), src/cpu/march.rs (segments, hi-Z,
// two-level, fine test) and src/cpu/select.rs (probe selection); read those for the commentary.

const HIT: u32 = 0u;
const MISS: u32 = 1u;
const UNKNOWN: u32 = 2u;
const CONTINUE: u32 = 3u;
const METHOD_HIZ: u32 = 0u;
const SELECT_GRID: u32 = 0u;
const SELECT_SVO: u32 = 1u;
const SVO_LEAF_BIT: u32 = 0x80000000u;
const SVO_PACKED_BIT: u32 = 0x40000000u;
const NO_EXIT: f32 = 4.0;
// src/packed.rs COS_AMONG_SAMPLES.
const COS_AMONG_SAMPLES: f32 = 0.05;
// src/packed.rs AGREEMENT_SHOWN_WEIGHT.
const AGREEMENT_SHOWN_WEIGHT: f32 = 0.75;
const SIGN_BIT: u32 = 0x80000000u;
// f32::MAX: "no bound" (src/cpu/mod.rs bounds_exit).
const F32_MAX: f32 = 3.40282347e38;

// probe_index::SvoHeader (48 bytes).
struct SvoHeader {
    origin: vec3<f32>,
    size: f32,
    depth: u32,
    node_count: u32,
    leaf_count: u32,
    block_count: u32,
    packed_bits: u32,
    pad0: u32,
    pad1: u32,
    pad2: u32,
}

// src/packed.rs TraceParams (352 bytes).
struct TraceParams {
    resolution: u32,
    probe_count: u32,
    ray_count: u32,
    threads_per_row: u32,
    method: u32,
    top_level: u32,
    coarse_level: u32,
    max_probes: u32,
    selector: u32,
    back_face_rejection: u32,
    level_count: u32,
    max_steps: u32,
    sky_distance: f32,
    thickness_scale: f32,
    nearest_candidates: u32,
    nearest_table: u32,
    level_offsets: array<vec4<u32>, 4>,
    grid: GridParams,
    svo: SvoHeader,
    svo_nodes: u32,
    svo_leaves: u32,
    svo_blocks: u32,
    kd_nodes: u32,
    kd_count: u32,
    neighbour_table: u32,
    neighbour_resolution: u32,
    glossy_levels: u32,
    glossy_tan: f32,
    glossy_angle: f32,
    glossy_base_angle: f32,
    glossy_blend: u32,
    glossy_offsets: array<vec4<u32>, 2>,
    bounds_min: vec4<f32>,
    bounds_max: vec4<f32>,
    sky_map: u32,
    glossy_wide_tan: f32,
    agreement: u32,
    pad2: u32,
}

// src/ray.rs TraceRay (32 bytes).
struct TraceRay {
    origin: vec3<f32>,
    t_min: f32,
    direction: vec3<f32>,
    t_max: f32,
}

// src/ray.rs RayRecord (64 bytes).
struct RayRecord {
    position: vec3<f32>,
    t: f32,
    normal: vec3<f32>,
    status: u32,
    radiance: vec3<f32>,
    probe: u32,
    probes_tried: u32,
    texel_fetches: u32,
    pad0: u32,
    pad1: u32,
}

@group(0) @binding(0) var<uniform> params: TraceParams;
// The rays (TraceRay, 32 bytes: two words of four each), or the look-up's surface queries in
// the same layout (src/ray.rs SurfaceQuery). Read as raw words so that the query's integer
// fields keep their bits.
@group(0) @binding(1) var<storage, read> ray_words: array<vec4<u32>>;
@group(0) @binding(2) var<storage, read_write> records: array<RayRecord>;
@group(0) @binding(3) var<storage, read> positions: array<vec4<f32>>;
// Per padded texel: radial distance bits (sign: farther edge), packed normal, near bits, far
// bits (sign: nearer edge). See src/packed.rs TexelBounds.
@group(0) @binding(4) var<storage, read> geometry: array<vec4<u32>>;
// Levels 1.. of the pyramids: min near bits, max far bits, packed outward normal of the
// bounding plane, plane offset bits (src/pyramid.rs).
@group(0) @binding(5) var<storage, read> pyramid: array<vec4<u32>>;
// 3 floats per padded texel: level 0, then the prefiltered glossy levels (src/packed.rs).
@group(0) @binding(6) var<storage, read> radiance: array<f32>;
// Octree nodes and payloads, or k-d tree nodes and the neighbour table.
@group(0) @binding(7) var<storage, read> words: array<u32>;

// The probe being traced, the ray relative to it, and the fetch counter of the current ray.
var<private> cur_probe: u32;
var<private> ray_o: vec3<f32>;
var<private> ray_d: vec3<f32>;
var<private> ray_t_min: f32;
var<private> fetches: u32;
// The hi-Z level the previous segment's march ended at.
var<private> carry_level: u32;
// The estimate's relaxed march (src/cpu/march.rs ProbeRay::relaxed), and its far guess
// (ProbeRay::pass_hidden).
var<private> relaxed: bool;
var<private> pass_hidden: bool;
// The relaxed march's hit is a guess where the ray went out of sight
// (src/cpu/march.rs ProbeRay::guessed_hidden).
var<private> guessed_hidden: bool;
// The crossing the strict march refused beside a farther edge where it answered UNKNOWN, if
// put on (src/cpu/march.rs Refusal).
struct Refusal {
    t: f32,
    tolerance: f32,
    cell: vec2<u32>,
    normal: u32,
}
var<private> refused: Refusal;
var<private> has_refused: bool;

// src/cpu/march.rs March.
const MARCH_STRICT: u32 = 0u;
const MARCH_FIRST_CONTACT: u32 = 1u;
const MARCH_PAST_HIDDEN: u32 = 2u;

struct Segment {
    t0: f32,
    t1: f32,
    q0: vec2<f32>,
    q1: vec2<f32>,
    l0: f32,
    l1: f32,
}

struct Outcome {
    code: u32,
    t: f32,
    cell: vec2<u32>,
    normal: u32,
}

fn outcome_continue() -> Outcome {
    return Outcome(CONTINUE, 0.0, vec2<u32>(0u), 0u);
}

fn outcome_unknown(t: f32) -> Outcome {
    return Outcome(UNKNOWN, t, vec2<u32>(0u), 0u);
}

fn padded_index(n: u32, probe: u32, cell: vec2<u32>) -> u32 {
    let side = n + 2u;
    return probe * side * side + (cell.y + 1u) * side + cell.x + 1u;
}

// ---- segments (src/cpu/march.rs split_segments) ----

fn encode_in_octant(p: vec3<f32>, signs: vec3<f32>) -> vec2<f32> {
    let l1 = abs(p.x) + abs(p.y) + abs(p.z);
    let q = vec2<f32>(abs(p.x) * signs.x, abs(p.y) * signs.y) / l1;
    if (signs.z < 0.0) {
        return vec2<f32>((1.0 - abs(q.y)) * sign_not_zero(signs.x), (1.0 - abs(q.x)) * sign_not_zero(signs.y));
    }
    return q;
}

struct Endpoint {
    q: vec2<f32>,
    l: f32,
}

fn endpoint(o: vec3<f32>, d: vec3<f32>, t: f32, vanishing: u32, signs: vec3<f32>, starts_here: bool) -> Endpoint {
    var p = o + d * t;
    if ((vanishing & 1u) != 0u) {
        p.x = 0.0;
    }
    if ((vanishing & 2u) != 0u) {
        p.y = 0.0;
    }
    if ((vanishing & 4u) != 0u) {
        p.z = 0.0;
    }
    let l1 = abs(p.x) + abs(p.y) + abs(p.z);
    if (l1 == 0.0) {
        var limit = -d;
        if (starts_here) {
            limit = d;
        }
        return Endpoint(encode_in_octant(limit, signs), 0.0);
    }
    return Endpoint(encode_in_octant(p, signs), l1);
}

struct Segments {
    s: array<Segment, 4>,
    count: u32,
}

fn split_segments(o: vec3<f32>, d: vec3<f32>, t_min: f32, t_max: f32) -> Segments {
    var cut_t: array<f32, 3>;
    var cut_mask: array<u32, 3>;
    var count = 0u;
    for (var axis = 0u; axis < 3u; axis++) {
        if (d[axis] != 0.0) {
            let t = -o[axis] / d[axis];
            if (t > t_min && t < t_max) {
                cut_t[count] = t;
                cut_mask[count] = 1u << axis;
                count += 1u;
            }
        }
    }
    for (var i = 1u; i < count; i++) {
        var j = i;
        loop {
            if (j == 0u || !(cut_t[j - 1u] > cut_t[j])) {
                break;
            }
            let ta = cut_t[j - 1u];
            cut_t[j - 1u] = cut_t[j];
            cut_t[j] = ta;
            let ma = cut_mask[j - 1u];
            cut_mask[j - 1u] = cut_mask[j];
            cut_mask[j] = ma;
            j -= 1u;
        }
    }
    var bound_t: array<f32, 5>;
    var bound_mask: array<u32, 5>;
    bound_t[0] = t_min;
    bound_mask[0] = 0u;
    var bounds = 1u;
    for (var i = 0u; i < count; i++) {
        if (bounds > 1u && bound_t[bounds - 1u] == cut_t[i]) {
            bound_mask[bounds - 1u] |= cut_mask[i];
        } else {
            bound_t[bounds] = cut_t[i];
            bound_mask[bounds] = cut_mask[i];
            bounds += 1u;
        }
    }
    bound_t[bounds] = t_max;
    bound_mask[bounds] = 0u;
    var out: Segments;
    out.count = bounds;
    for (var i = 0u; i < bounds; i++) {
        let t0 = bound_t[i];
        let t1 = bound_t[i + 1u];
        let mid = o + d * (0.5 * t0 + 0.5 * t1);
        let signs = vec3<f32>(sign_not_zero(mid.x), sign_not_zero(mid.y), sign_not_zero(mid.z));
        let e0 = endpoint(o, d, t0, bound_mask[i], signs, true);
        let e1 = endpoint(o, d, t1, bound_mask[i + 1u], signs, false);
        out.s[i] = Segment(t0, t1, e0.q, e1.q, e0.l, e1.l);
    }
    return out;
}

fn t_of(seg: Segment, sigma: f32) -> f32 {
    if (sigma <= 0.0) {
        return seg.t0;
    }
    if (sigma >= 1.0) {
        return seg.t1;
    }
    let a = sigma * seg.l0;
    let lambda = a / (a + (1.0 - sigma) * seg.l1);
    return seg.t0 + (seg.t1 - seg.t0) * lambda;
}

// ---- cells (src/cpu/march.rs) ----

fn entered_index(c: f32, dc: f32) -> i32 {
    let f = floor(c);
    if (dc < 0.0 && c == f) {
        return i32(f) - 1;
    }
    return i32(f);
}

fn start_cell(c0: vec2<f32>, delta: vec2<f32>, n: u32) -> vec2<u32> {
    let last = i32(n) - 1;
    return vec2<u32>(
        u32(clamp(entered_index(c0.x, delta.x), 0, last)),
        u32(clamp(entered_index(c0.y, delta.y), 0, last)),
    );
}

fn exit_axis(i: u32, c: f32, dc: f32, size: f32) -> f32 {
    if (dc > 0.0) {
        return (f32(i + 1u) * size - c) / dc;
    }
    if (dc < 0.0) {
        return (f32(i) * size - c) / dc;
    }
    return NO_EXIT;
}

fn exit_sigmas(cell: vec2<u32>, level: u32, c0: vec2<f32>, delta: vec2<f32>) -> vec2<f32> {
    let size = f32(1u << level);
    return vec2<f32>(exit_axis(cell.x, c0.x, delta.x, size), exit_axis(cell.y, c0.y, delta.y, size));
}

fn advance_axis(i: u32, level: u32, crossed: bool, c: f32, dc: f32) -> i32 {
    let lo = i32(i << level);
    let hi = i32((i + 1u) << level) - 1;
    if (crossed) {
        if (dc > 0.0) {
            return hi + 1;
        }
        return lo - 1;
    }
    return clamp(entered_index(c, dc), lo, hi);
}

// Moves *cursor to where the line enters the next cell after leaving `cell` of `level` at
// σ = exit; false if it left the map.
fn advance(cursor: ptr<function, vec2<u32>>, cell: vec2<u32>, level: u32, s: vec2<f32>, exit: f32, c0: vec2<f32>, delta: vec2<f32>, n: u32) -> bool {
    let at = c0 + delta * exit;
    let x = advance_axis(cell.x, level, s.x <= exit, at.x, delta.x);
    let y = advance_axis(cell.y, level, s.y <= exit, at.y, delta.y);
    let ni = i32(n);
    if (x < 0 || y < 0 || x >= ni || y >= ni) {
        return false;
    }
    *cursor = vec2<u32>(u32(x), u32(y));
    return true;
}

fn sigma_of(seg: Segment, t: f32) -> f32 {
    if (t <= seg.t0 || seg.t1 <= seg.t0) {
        return 0.0;
    }
    if (t >= seg.t1) {
        return 1.0;
    }
    let lambda = (t - seg.t0) / (seg.t1 - seg.t0);
    return lambda * seg.l1 / ((1.0 - lambda) * seg.l0 + lambda * seg.l1);
}

fn entry_axis(i: u32, c: f32, dc: f32) -> f32 {
    if (dc > 0.0) {
        return (f32(i) * 1.0 - c) / dc;
    }
    if (dc < 0.0) {
        return (f32(i + 1u) * 1.0 - c) / dc;
    }
    return bitcast<f32>(0xff800000u);
}

struct Skip {
    ok: bool,
    to_cell: vec2<u32>,
    entry: f32,
}

// src/cpu/march.rs skip_to.
fn skip_to(seg: Segment, t_pass: f32, cell: vec2<u32>, level: u32, c0: vec2<f32>, delta: vec2<f32>, sigma: f32, exit: f32) -> Skip {
    var out = Skip(false, vec2<u32>(0u), 0.0);
    let s = sigma_of(seg, t_pass) - 1e-3 / length(delta);
    if (s <= sigma) {
        return out;
    }
    let p = c0 + delta * s;
    let size = i32(1u << level);
    let lo = vec2<i32>(cell) * size;
    let to_cell = vec2<u32>(
        u32(clamp(entered_index(p.x, delta.x), lo.x, lo.x + size - 1)),
        u32(clamp(entered_index(p.y, delta.y), lo.y, lo.y + size - 1)),
    );
    let entry = max(entry_axis(to_cell.x, c0.x, delta.x), entry_axis(to_cell.y, c0.y, delta.y));
    if (entry > sigma && entry < exit) {
        out = Skip(true, to_cell, entry);
    }
    return out;
}

// ---- tests ----

fn radius(t: f32) -> f32 {
    return length(ray_o + ray_d * t);
}

fn pyramid_texel(level: u32, cell: vec2<u32>) -> vec4<u32> {
    fetches += 1u;
    let side = params.resolution >> level;
    let index = params.level_offsets[level / 4u][level % 4u] + (cur_probe * side + cell.y) * side + cell.x;
    return pyramid[index];
}

// Whether the ray over [ta, tb] lies in front of a pyramid cell's bounding plane (unit normal
// n, offset c).
fn in_front_of(n: vec3<f32>, c: f32, ta: f32, tb: f32) -> bool {
    let base = dot(n, ray_o);
    let slope = dot(n, ray_d);
    return base + ta * slope < c && base + tb * slope < c;
}

// src/cpu/march.rs pass_prefix.
fn pass_prefix(lo: f32, n: vec3<f32>, c: f32, ta: f32, tb: f32) -> f32 {
    let base = dot(n, ray_o);
    let slope = dot(n, ray_d);
    var t = ta;
    if (base + ta * slope < c) {
        if (slope > 0.0) {
            t = (c - base) / slope;
        } else {
            t = tb;
        }
    }
    if (radius(ta) < lo) {
        let b = dot(ray_o, ray_d);
        let q = dot(ray_o, ray_o) - lo * lo;
        t = max(t, -b + sqrt(max(b * b - q, 0.0)));
    }
    return min(t, tb);
}

// The estimate's fine test (src/cpu/march.rs, `relaxed`): where the strict test hands the
// ray on, a guessed hit at the texel's entry (for the far guess, `pass_hidden`, the march
// passes on behind what the probe saw unless the ray comes back through the stored surface
// inside the texel); edges and back faces do not stop a crossing.
fn fine_test_relaxed(cell: vec2<u32>, ta: f32, tb: f32) -> Outcome {
    let n = params.resolution;
    let texel = geometry[padded_index(n, cur_probe, cell)];
    let distance = bitcast<f32>(texel.x & ~SIGN_BIT);
    if (distance >= params.sky_distance) {
        return outcome_continue();
    }
    let near = bitcast<f32>(texel.z);
    let far = bitcast<f32>(texel.w & ~SIGN_BIT);
    let ra = radius(ta);
    let rb = radius(tb);
    if (max(ra, rb) < near) {
        return outcome_continue();
    }
    if (ra > far && !pass_hidden) {
        guessed_hidden = true;
        return Outcome(HIT, ta, cell, texel.y);
    }
    let normal = unpack_normal(texel.y);
    let center = octa_decode(texel_center(n, cell));
    let surface = texel_surface(n, center, distance, normal, params.thickness_scale);
    let nv = surface.visible_normal;
    let sa = dot(ray_o + ray_d * ta - center * distance, nv);
    let k = dot(ray_d, nv);
    let sb = sa + (tb - ta) * k;
    if (pass_hidden && (ra > far || (sa < -surface.thickness && ra >= near))) {
        if (k > 0.0 && sb >= 0.0) {
            return Outcome(HIT, min(ta - sa / k, tb), cell, texel.y);
        }
        return outcome_continue();
    }
    if (sa < -surface.thickness) {
        if (ra >= near) {
            guessed_hidden = true;
            return Outcome(HIT, ta, cell, texel.y);
        }
        return outcome_continue();
    }
    if (sa >= 0.0 && sb >= 0.0) {
        return outcome_continue();
    }
    if (k >= 0.0 || (sa < 0.0 && ta == ray_t_min)) {
        if (sa < -surface.plane_thickness || (pass_hidden && sa < 0.0)) {
            guessed_hidden = true;
            return Outcome(HIT, ta, cell, texel.y);
        }
        return outcome_continue();
    }
    var t = ta;
    if (sa > 0.0) {
        t = min(ta - sa / k, tb);
    }
    return Outcome(HIT, t, cell, texel.y);
}

fn fine_test(cell: vec2<u32>, ta: f32, tb: f32) -> Outcome {
    fetches += 1u;
    if (relaxed) {
        return fine_test_relaxed(cell, ta, tb);
    }
    let n = params.resolution;
    let texel = geometry[padded_index(n, cur_probe, cell)];
    let farther_edge = (texel.x & SIGN_BIT) != 0u;
    let nearer_edge = (texel.w & SIGN_BIT) != 0u;
    let distance = bitcast<f32>(texel.x & ~SIGN_BIT);
    if (distance >= params.sky_distance && !nearer_edge) {
        return outcome_continue();
    }
    let near = bitcast<f32>(texel.z);
    let far = bitcast<f32>(texel.w & ~SIGN_BIT);
    let ra = radius(ta);
    let rb = radius(tb);
    if (max(ra, rb) < near) {
        return outcome_continue();
    }
    if (ra > far || nearer_edge) {
        return outcome_unknown(ta);
    }
    let normal = unpack_normal(texel.y);
    let center = octa_decode(texel_center(n, cell));
    let surface = texel_surface(n, center, distance, normal, params.thickness_scale);
    let nv = surface.visible_normal;
    let sa = dot(ray_o + ray_d * ta - center * distance, nv);
    let k = dot(ray_d, nv);
    let sb = sa + (tb - ta) * k;
    if (sa < -surface.thickness) {
        if (ra >= near) {
            return outcome_unknown(ta);
        }
        return outcome_continue();
    }
    if (sa >= 0.0 && sb >= 0.0) {
        return outcome_continue();
    }
    // The ray has been behind this plane since it started (its origin lies behind it too):
    // it never crossed it; hand it on (src/cpu/march.rs).
    if (k < 0.0 && sa < 0.0 && ta > ray_t_min && sa - (ta - ray_t_min) * k < 0.0) {
        return outcome_unknown(ta);
    }
    if (k >= 0.0 || (sa < 0.0 && ta == ray_t_min)) {
        // Only a ray that starts within the thickness leaves the surface (src/cpu/march.rs).
        if (sa - (ta - ray_t_min) * k < -surface.plane_thickness) {
            return outcome_unknown(ta);
        }
        return outcome_continue();
    }
    if (params.back_face_rejection != 0u && dot(ray_d, normal) > 0.0) {
        return outcome_unknown(ta);
    }
    var t = ta;
    if (sa > 0.0) {
        t = min(ta - sa / k, tb);
    }
    // A texel with a farther edge: the crossing may lie beside the edge, unless the texels
    // around it all show it and the texel is not seen almost edge-on; refused, it is put to
    // the next probes when most of the texels around it show it (src/cpu/march.rs).
    if (farther_edge) {
        let shown = samples_showing(cur_probe, ray_o + ray_d * t);
        if (surface.cos_incidence < COS_AMONG_SAMPLES || shown.x == 0.0) {
            let crossing = ta - sa / k;
            if (shown.y >= AGREEMENT_SHOWN_WEIGHT && crossing > ray_t_min) {
                refused = Refusal(crossing, surface.plane_thickness, cell, texel.y);
                has_refused = true;
            }
            return outcome_unknown(ta);
        }
    }
    return Outcome(HIT, t, cell, texel.y);
}

// ---- marches ----

fn march_hiz(seg: Segment, c0: vec2<f32>, delta: vec2<f32>, top: u32) -> Outcome {
    let n = params.resolution;
    var level = min(carry_level, top);
    var cursor = start_cell(c0, delta, n);
    var sigma = 0.0;
    var ta = seg.t0;
    for (var step = 0u; step < params.max_steps; step++) {
        let cell = cursor >> vec2<u32>(level);
        let s = exit_sigmas(cell, level, c0, delta);
        let exit = max(min(s.x, s.y), sigma);
        let tb = t_of(seg, min(exit, 1.0));
        if (level > 0u) {
            let record = pyramid_texel(level, cell);
            let lo = bitcast<f32>(record.x);
            let ra = radius(ta);
            let rb = radius(tb);
            let plane_n = unpack_normal(record.z);
            let plane_c = bitcast<f32>(record.w);
            if (max(ra, rb) >= lo && !in_front_of(plane_n, plane_c, ta, tb)) {
                if (ra > bitcast<f32>(record.y) && !relaxed) {
                    return outcome_unknown(ta);
                }
                let t_pass = pass_prefix(lo, plane_n, plane_c, ta, tb);
                if (t_pass > ta) {
                    let skip = skip_to(seg, t_pass, cell, level, c0, delta, sigma, exit);
                    if (skip.ok) {
                        cursor = skip.to_cell;
                        sigma = skip.entry;
                        ta = t_of(seg, sigma);
                        if (level > 2u) {
                            level -= 1u;
                        }
                    }
                }
                level -= 1u;
                continue;
            }
        } else {
            let outcome = fine_test(cursor, ta, tb);
            if (outcome.code != CONTINUE) {
                return outcome;
            }
        }
        if (exit >= 1.0 || !advance(&cursor, cell, level, s, exit, c0, delta, n)) {
            carry_level = level;
            return outcome_continue();
        }
        sigma = exit;
        ta = tb;
        let next = cursor >> vec2<u32>(level);
        if (level < top && any((next >> vec2<u32>(1u)) != (cell >> vec2<u32>(1u)))) {
            level += 1u;
        }
    }
    return outcome_unknown(ta);
}

fn march_two_level(seg: Segment, c0: vec2<f32>, delta: vec2<f32>, coarse: u32) -> Outcome {
    let n = params.resolution;
    var cursor = start_cell(c0, delta, n);
    var sigma = 0.0;
    var ta = seg.t0;
    var steps = 0u;
    loop {
        if (steps >= params.max_steps) {
            break;
        }
        steps += 1u;
        let cell = cursor >> vec2<u32>(coarse);
        let s = exit_sigmas(cell, coarse, c0, delta);
        let exit = max(min(s.x, s.y), sigma);
        let tb = t_of(seg, min(exit, 1.0));
        let lo = bitcast<f32>(pyramid_texel(coarse, cell).x);
        var left_cell = false;
        if (max(radius(ta), radius(tb)) >= lo) {
            loop {
                if (steps >= params.max_steps) {
                    break;
                }
                steps += 1u;
                let fs = exit_sigmas(cursor, 0u, c0, delta);
                let fexit = max(min(fs.x, fs.y), sigma);
                let ftb = t_of(seg, min(fexit, 1.0));
                let outcome = fine_test(cursor, ta, ftb);
                if (outcome.code != CONTINUE) {
                    return outcome;
                }
                if (fexit >= exit || fexit >= 1.0) {
                    break;
                }
                let fine = cursor;
                if (!advance(&cursor, fine, 0u, fs, fexit, c0, delta, n)) {
                    return outcome_continue();
                }
                sigma = fexit;
                ta = ftb;
                if (any((cursor >> vec2<u32>(coarse)) != cell)) {
                    left_cell = true;
                    break;
                }
            }
        }
        if (left_cell) {
            continue;
        }
        if (exit >= 1.0 || !advance(&cursor, cell, coarse, s, exit, c0, delta, n)) {
            return outcome_continue();
        }
        sigma = exit;
        ta = tb;
    }
    return outcome_unknown(ta);
}

fn march_segment(seg: Segment) -> Outcome {
    let n = params.resolution;
    let nf = f32(n);
    let c0 = clamp((seg.q0 + vec2<f32>(1.0)) * (0.5 * nf), vec2<f32>(0.0), vec2<f32>(nf));
    let c1 = clamp((seg.q1 + vec2<f32>(1.0)) * (0.5 * nf), vec2<f32>(0.0), vec2<f32>(nf));
    let delta = c1 - c0;
    if (seg.l0 <= 0.0 || seg.l1 <= 0.0 || dot(delta, delta) < 1e-12) {
        let cell = start_cell((c0 + c1) * 0.5, vec2<f32>(0.0), n);
        return fine_test(cell, seg.t0, seg.t1);
    }
    if (params.method == METHOD_HIZ || params.coarse_level == 0u) {
        var top = 0u;
        if (params.method == METHOD_HIZ) {
            top = params.top_level;
        }
        return march_hiz(seg, c0, delta, top);
    }
    return march_two_level(seg, c0, delta, params.coarse_level);
}

// ---- one probe (src/cpu/mod.rs trace_probe) ----

struct ProbeAnswer {
    code: u32,
    t: f32,
    cell: vec2<u32>,
    normal: u32,
}

fn trace_probe(probe: u32, ray: TraceRay, t_start: f32, march: u32) -> ProbeAnswer {
    cur_probe = probe;
    relaxed = march != MARCH_STRICT;
    pass_hidden = march == MARCH_PAST_HIDDEN;
    guessed_hidden = false;
    has_refused = false;
    ray_o = ray.origin - positions[probe].xyz;
    ray_d = ray.direction;
    ray_t_min = ray.t_min;
    carry_level = 0u;
    let sky = params.sky_distance * 0.999;
    let b = dot(ray_o, ray_d);
    let closest = ray_o - ray_d * b;
    let h2 = dot(closest, closest);
    var answer = ProbeAnswer(MISS, t_start, vec2<u32>(0u), 0u);
    if (length(ray_o) >= sky) {
        return answer;
    }
    let t_sky = -b + sqrt(max(sky * sky - h2, 0.0));
    let t_end = min(ray.t_max, t_sky);
    answer.t = t_end;
    if (t_end <= t_start) {
        answer.t = t_start;
        return answer;
    }
    let segments = split_segments(ray_o, ray_d, t_start, t_end);
    for (var i = 0u; i < segments.count; i++) {
        let outcome = march_segment(segments.s[i]);
        if (outcome.code != CONTINUE) {
            return ProbeAnswer(outcome.code, outcome.t, outcome.cell, outcome.normal);
        }
    }
    return answer;
}

// ---- selection (src/cpu/select.rs) ----

const MAX_CANDIDATES: u32 = 8u;
const NEAREST_ROW: u32 = 16u;

struct Candidates {
    probes: array<u32, 8>,
    len: u32,
}

fn push_candidate(c: ptr<function, Candidates>, probe: u32) {
    if (probe == NO_PROBE || (*c).len >= MAX_CANDIDATES) {
        return;
    }
    for (var i = 0u; i < (*c).len; i++) {
        if ((*c).probes[i] == probe) {
            return;
        }
    }
    (*c).probes[(*c).len] = probe;
    (*c).len += 1u;
}

fn select_grid(position: vec3<f32>, direction: vec3<f32>, failed: u32) -> Candidates {
    let g = params.grid;
    let counts = vec3<u32>(g.count_x, g.count_y, g.count_z);
    let max_corner = vec3<f32>(counts - vec3<u32>(2u));
    let base = vec3<u32>(clamp(floor((position - g.origin) / g.spacing), vec3<f32>(0.0), max_corner));
    var cage: array<u32, 8>;
    var first = 0u;
    var best = bitcast<f32>(0xff800000u);
    var failed_slot = 8u;
    for (var slot = 0u; slot < 8u; slot++) {
        let c = base + vec3<u32>(slot & 1u, (slot >> 1u) & 1u, slot >> 2u);
        let probe = c.x + counts.x * (c.y + counts.y * c.z);
        cage[slot] = probe;
        let d = position - (g.origin + vec3<f32>(c) * g.spacing);
        var score = 1.0;
        if (any(d != vec3<f32>(0.0))) {
            score = dot(direction, normalize(d));
        }
        if (score > best) {
            best = score;
            first = slot;
        }
        if (probe == failed) {
            failed_slot = slot;
        }
    }
    var slot = first;
    if (failed_slot < 8u) {
        slot = (failed_slot + 3u) & 7u;
    }
    var out: Candidates;
    out.len = 0u;
    for (var i = 0u; i < 8u; i++) {
        if (cage[slot] != failed) {
            push_candidate(&out, cage[slot]);
        }
        slot = (slot + 3u) & 7u;
    }
    return out;
}

fn select_svo(position: vec3<f32>, failed: u32) -> Candidates {
    let h = params.svo;
    var size = h.size;
    let p = clamp(position, h.origin, h.origin + vec3<f32>(size));
    var lo = h.origin;
    var index = params.svo_nodes;
    var out: Candidates;
    out.len = 0u;
    var payload = 0xffffffffu;
    for (var i = 0u; i <= 32u; i++) {
        let word = words[index];
        if ((word & SVO_LEAF_BIT) != 0u) {
            payload = word & ~SVO_LEAF_BIT;
            break;
        }
        size *= 0.5;
        let mid = lo + vec3<f32>(size);
        var child = 0u;
        if (p.x >= mid.x) {
            child |= 1u;
            lo.x = mid.x;
        }
        if (p.y >= mid.y) {
            child |= 2u;
            lo.y = mid.y;
        }
        if (p.z >= mid.z) {
            child |= 4u;
            lo.z = mid.z;
        }
        if ((word & SVO_PACKED_BIT) != 0u) {
            let bits = h.packed_bits;
            let per = 32u / bits;
            let block = (word & ~SVO_PACKED_BIT) * (8u / per);
            let w = words[params.svo_blocks + block + child / per];
            payload = (w >> (bits * (child % per))) & ((1u << bits) - 1u);
            break;
        }
        index = params.svo_nodes + word + child;
    }
    if (payload != 0xffffffffu) {
        let leaf = params.svo_leaves + 4u * payload;
        for (var k = 0u; k < 4u; k++) {
            let probe = words[leaf + k];
            if (probe != failed) {
                push_candidate(&out, probe);
            }
        }
    }
    return out;
}

fn select_voronoi(position: vec3<f32>, direction: vec3<f32>, failed: u32) -> Candidates {
    var out: Candidates;
    out.len = 0u;
    var source_probe = failed;
    if (failed == NO_PROBE) {
        let first = nearest_probe(params.kd_nodes, params.kd_count, position);
        if (first == NO_PROBE) {
            return out;
        }
        push_candidate(&out, first);
        source_probe = first;
    }
    let away = position - positions[source_probe].xyz;
    var towards = direction;
    if (dot(away, away) > 0.0) {
        towards = away;
    }
    let n = params.neighbour_resolution;
    let texel = texel_containing(n, towards);
    let at = params.neighbour_table + ((source_probe * n + texel.y) * n + texel.x) * 4u;
    for (var k = 0u; k < 4u; k++) {
        push_candidate(&out, words[at + k]);
    }
    return out;
}

fn list_contains(list: Candidates, probe: u32) -> bool {
    for (var i = 0u; i < list.len; i++) {
        if (list.probes[i] == probe) {
            return true;
        }
    }
    return false;
}

// Candidate i of the list extended by the anchor's row of the nearest-probe table, or NO_PROBE
// for an extension entry to skip (src/cpu/select.rs Selector::candidate).
fn candidate(list: Candidates, anchor: u32, failed: u32, i: u32) -> u32 {
    if (i < list.len) {
        return list.probes[i];
    }
    let probe = words[params.nearest_table + anchor * NEAREST_ROW + (i - list.len)];
    if (probe == failed || list_contains(list, probe)) {
        return NO_PROBE;
    }
    return probe;
}

fn select_probes(position: vec3<f32>, direction: vec3<f32>, failed: u32) -> Candidates {
    if (params.selector == SELECT_GRID) {
        return select_grid(position, direction, failed);
    }
    if (params.selector == SELECT_SVO) {
        return select_svo(position, failed);
    }
    return select_voronoi(position, direction, failed);
}

// ---- the ray (src/cpu/mod.rs trace_ray) ----

fn radiance_at(probe: u32, cell: vec2<u32>) -> vec3<f32> {
    let i = 3u * padded_index(params.resolution, probe, cell);
    return vec3<f32>(radiance[i], radiance[i + 1u], radiance[i + 2u]);
}

// Whether `probe`'s depth map can show point p (src/cpu/mod.rs sees_point): one fetch.
fn sees_point(probe: u32, p: vec3<f32>, strict: bool) -> bool {
    return sees_departure(probe, p, vec3<f32>(0.0), strict);
}

// sees_point for the start of a ray leaving p along direction (zero: none): a texel whose
// surface holds p within its plane's thickness and faces away from the direction shows the
// surface the ray leaves from behind, so it does not see the departure (src/cpu/mod.rs
// sees_departure).
fn sees_departure(probe: u32, p: vec3<f32>, direction: vec3<f32>, strict: bool) -> bool {
    let v = p - positions[probe].xyz;
    let r = length(v);
    if (r == 0.0) {
        return true;
    }
    fetches += 1u;
    let plane = texel_plane(probe, texel_containing(params.resolution, v / r));
    if (plane.sky) {
        return true;
    }
    if (r > bitcast<f32>(plane.record.w & ~SIGN_BIT)) {
        return false;
    }
    let surface = plane.surface;
    var slack = surface.plane_thickness;
    if (strict) {
        slack = 0.0;
    }
    let offset = dot(v - plane.point, surface.visible_normal);
    if (abs(offset) <= surface.plane_thickness && dot(direction, surface.visible_normal) < 0.0) {
        return false;
    }
    return offset >= -slack;
}

// Interior texel (ix, iy), ix, iy in [-1, n], through the map's wrap (src/cpu/mod.rs
// wrap_texel).
fn wrap_texel(ix: i32, iy: i32, n: u32) -> vec2<u32> {
    let last = i32(n) - 1;
    let outside_x = ix < 0 || ix > last;
    let outside_y = iy < 0 || iy > last;
    var x = ix;
    var y = iy;
    if (outside_x && outside_y) {
        x = select(0, last, ix < 0);
        y = select(0, last, iy < 0);
    } else if (outside_x) {
        x = select(last, 0, ix < 0);
        y = last - iy;
    } else if (outside_y) {
        x = last - ix;
        y = select(last, 0, iy < 0);
    }
    return vec2<u32>(u32(x), u32(y));
}

// Whether `texel` of `probe` shows point v (relative to the probe: its surface's plane holds v
// within the plane's thickness; src/cpu/mod.rs texel_shows; one fetch, counted by the caller).
fn texel_shows(probe: u32, texel: vec2<u32>, v: vec3<f32>) -> bool {
    let plane = texel_plane(probe, texel);
    return !plane.sky && plane_holds(plane, v);
}

// The surface one texel of a probe stores, as the point tests read it (src/cpu/mod.rs
// TexelPlane; one fetch, counted by the caller): `sky` for a sky texel, whose other fields
// are then unset.
struct TexelPlane {
    sky: bool,
    record: vec4<u32>,
    distance: f32,
    point: vec3<f32>,
    surface: TexelSurface,
}

fn texel_plane(probe: u32, texel: vec2<u32>) -> TexelPlane {
    var plane: TexelPlane;
    let n = params.resolution;
    plane.record = geometry[padded_index(n, probe, texel)];
    plane.distance = bitcast<f32>(plane.record.x & ~SIGN_BIT);
    plane.sky = plane.distance >= params.sky_distance;
    if (plane.sky) {
        return plane;
    }
    let center = octa_decode(texel_center(n, texel));
    plane.point = center * plane.distance;
    plane.surface = texel_surface(n, center, plane.distance, unpack_normal(plane.record.y), params.thickness_scale);
    return plane;
}

// Whether the plane holds v (relative to the probe) within its thickness (src/cpu/mod.rs
// TexelPlane::holds).
fn plane_holds(plane: TexelPlane, v: vec3<f32>) -> bool {
    return abs(dot(v - plane.point, plane.surface.visible_normal)) <= plane.surface.plane_thickness;
}

// The least cosine between a texel's surface and a point's known normal for the texel to
// show the point (src/cpu/mod.rs SAME_SURFACE_COS).
const SAME_SURFACE_COS: f32 = 0.5;

// Whether the texel's surface faces like a surface with `normal` (towards the probe's side;
// zero: unknown, which any texel does; src/cpu/mod.rs TexelPlane::faces_like).
fn plane_faces_like(plane: TexelPlane, normal: vec3<f32>) -> bool {
    return all(normal == vec3<f32>(0.0)) || dot(plane.surface.visible_normal, normal) >= SAME_SURFACE_COS;
}

// texel_shows for a point of a surface with the known `normal` (zero: unknown; src/cpu/mod.rs
// texel_shows_surface; one fetch, counted by the caller).
fn texel_shows_surface(probe: u32, texel: vec2<u32>, v: vec3<f32>, normal: vec3<f32>) -> bool {
    let plane = texel_plane(probe, texel);
    return !plane.sky && plane_holds(plane, v) && plane_faces_like(plane, normal);
}

// The continuous texel coordinate of direction v (relative to a probe) in the n×n map: the
// four texels around it are floor(f) + (0|1, 0|1).
fn bilinear_coordinate(v: vec3<f32>, n: u32) -> vec2<f32> {
    let o = clamp(octa_encode(v / length(v)), vec2<f32>(-1.0), vec2<f32>(1.0));
    return (o + vec2<f32>(1.0)) * (0.5 * f32(n)) - vec2<f32>(0.5);
}

// Bilinear weight of texel k (0..4: x offset k & 1, y offset k >> 1) at fractional part frac.
fn bilinear_weight(k: u32, frac: vec2<f32>) -> f32 {
    var wx = 1.0 - frac.x;
    if ((k & 1u) == 1u) {
        wx = frac.x;
    }
    var wy = 1.0 - frac.y;
    if ((k >> 1u) == 1u) {
        wy = frac.y;
    }
    return wx * wy;
}

// How the texels around the direction of surface point v (relative to `probe`) show it: x is
// 1 when every texel with a bilinear weight does (it lies among samples of its surface), y
// the bilinear weight of those that do, one fetch each, stopping once y can no longer reach
// AGREEMENT_SHOWN_WEIGHT (src/cpu/mod.rs samples_showing).
fn samples_showing(probe: u32, v: vec3<f32>) -> vec2<f32> {
    let n = params.resolution;
    if (length(v) <= 0.0) {
        return vec2<f32>(0.0);
    }
    let f = bilinear_coordinate(v, n);
    let base = floor(f);
    let frac = f - base;
    var all = 1.0;
    var shown = 0.0;
    var hidden = 0.0;
    for (var k = 0u; k < 4u; k++) {
        let w = bilinear_weight(k, frac);
        if (w <= 0.0) {
            continue;
        }
        let texel = wrap_texel(i32(base.x) + i32(k & 1u), i32(base.y) + i32(k >> 1u), n);
        fetches += 1u;
        if (texel_shows(probe, texel, v)) {
            shown += w;
        } else {
            all = 0.0;
            hidden += w;
            if (hidden > 1.0 - AGREEMENT_SHOWN_WEIGHT) {
                break;
            }
        }
    }
    return vec2<f32>(all, shown);
}

// The depth-aware bilinear radiance of `probe` towards point v (relative to it) or, with
// `sky`, in direction v (src/cpu/mod.rs filtered_radiance and surface_radiance); `cell`
// alone where no texel around shows it; the step-edge read only with `sharp`; with a
// non-zero `normal` (the point's surface, towards the probe's side) only texels whose
// surface faces like it show the point.
fn filtered_radiance(probe: u32, v: vec3<f32>, sky: bool, sharp: bool, normal: vec3<f32>, cell: vec2<u32>) -> vec3<f32> {
    let n = params.resolution;
    if (length(v) > 0.0) {
        let f = bilinear_coordinate(v, n);
        let base = floor(f);
        let frac = f - base;
        var sum = vec3<f32>(0.0);
        var weight = 0.0;
        // Sky reads blend the clear sky texels alone where there are any.
        var clear_sum = vec3<f32>(0.0);
        var clear_weight = 0.0;
        // A surface point's texels, for the step-edge read.
        var shown_weight = array<f32, 4>(0.0, 0.0, 0.0, 0.0);
        var shown_value = array<vec3<f32>, 4>(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
        var count = 0u;
        for (var k = 0u; k < 4u; k++) {
            let w = bilinear_weight(k, frac);
            if (w <= 0.0) {
                continue;
            }
            let texel = wrap_texel(i32(base.x) + i32(k & 1u), i32(base.y) + i32(k >> 1u), n);
            fetches += 1u;
            // One load of the texel's record (src/cpu/mod.rs filtered_radiance).
            var shows = false;
            var clear = false;
            if (sky) {
                let record = geometry[padded_index(n, probe, texel)];
                shows = record_is_sky(record);
                clear = record_is_clear_sky(record);
            } else {
                shows = texel_shows_surface(probe, texel, v, normal);
            }
            if (shows) {
                fetches += 1u;
                let value = radiance_at(probe, texel);
                let read = w * value;
                sum += read;
                weight += w;
                shown_weight[count] = w;
                shown_value[count] = value;
                count += 1u;
                if (clear) {
                    clear_sum += read;
                    clear_weight += w;
                }
            }
        }
        if (clear_weight > 0.0) {
            return clear_sum / clear_weight;
        }
        if (!sky && sharp && count >= 2u) {
            // The step-edge read (src/cpu/mod.rs is_step and step_edge).
            var bright = shown_value[0];
            var dark = shown_value[0];
            for (var i = 1u; i < count; i++) {
                if (channel_mean(shown_value[i]) > channel_mean(bright)) {
                    bright = shown_value[i];
                }
                if (channel_mean(shown_value[i]) < channel_mean(dark)) {
                    dark = shown_value[i];
                }
            }
            let h4 = channel_mean(bright);
            let l4 = channel_mean(dark);
            if (h4 > STEP_EDGE_RATIO * l4 && h4 / (1.0 + h4) - l4 / (1.0 + l4) >= STEP_EDGE_CONTRAST) {
                // The ring of texels around the four that show the point gives the step's
                // two sides where the four are only partly lit.
                for (var r = 0u; r < 16u; r++) {
                    let dx = i32(r & 3u) - 1;
                    let dy = i32(r >> 2u) - 1;
                    if ((dx == 0 || dx == 1) && (dy == 0 || dy == 1)) {
                        continue;
                    }
                    let texel = wrap_texel(i32(base.x) + dx, i32(base.y) + dy, n);
                    fetches += 1u;
                    if (texel_shows_surface(probe, texel, v, normal)) {
                        fetches += 1u;
                        let value = radiance_at(probe, texel);
                        if (channel_mean(value) > channel_mean(bright)) {
                            bright = value;
                        }
                        if (channel_mean(value) < channel_mean(dark)) {
                            dark = value;
                        }
                    }
                }
                let h = channel_mean(bright);
                let l = channel_mean(dark);
                var alpha = 0.0;
                var total = 0.0;
                for (var i = 0u; i < count; i++) {
                    alpha += shown_weight[i] * clamp((channel_mean(shown_value[i]) - l) / (h - l), 0.0, 1.0);
                    total += shown_weight[i];
                }
                if (alpha >= 0.5 * total) {
                    return bright;
                }
                return dark;
            }
        }
        if (weight > 0.0) {
            return sum / weight;
        }
    }
    fetches += 1u;
    return radiance_at(probe, cell);
}

// src/cpu/mod.rs STEP_EDGE_RATIO and STEP_EDGE_CONTRAST.
const STEP_EDGE_RATIO: f32 = 8.0;
const STEP_EDGE_CONTRAST: f32 = 0.25;

fn channel_mean(v: vec3<f32>) -> f32 {
    return (v.x + v.y + v.z) / 3.0;
}

// Bilinear radiance of prefiltered glossy level `level` (>= 1) of `probe` in unit direction d,
// through the level's padding (src/cpu/mod.rs glossy_sample): four fetches.
fn glossy_sample(level: u32, probe: u32, d: vec3<f32>) -> vec3<f32> {
    let n = params.resolution >> level;
    let side = n + 2u;
    let o = clamp(octa_encode(d), vec2<f32>(-1.0), vec2<f32>(1.0));
    let c = vec2<f32>(1.0) + (o + vec2<f32>(1.0)) * (0.5 * f32(n)) - vec2<f32>(0.5);
    let base = clamp(floor(c), vec2<f32>(0.0), vec2<f32>(f32(n)));
    let frac = clamp(c - base, vec2<f32>(0.0), vec2<f32>(1.0));
    let start = params.glossy_offsets[level / 4u][level % 4u] + probe * side * side;
    var sum = vec3<f32>(0.0);
    for (var k = 0u; k < 4u; k++) {
        let a = k & 1u;
        let b = k >> 1u;
        var wx = 1.0 - frac.x;
        if (a == 1u) {
            wx = frac.x;
        }
        var wy = 1.0 - frac.y;
        if (b == 1u) {
            wy = frac.y;
        }
        let i = 3u * (start + (u32(base.y) + b) * side + u32(base.x) + a);
        fetches += 1u;
        sum += (wx * wy) * vec3<f32>(radiance[i], radiance[i + 1u], radiance[i + 2u]);
    }
    return sum;
}

// The radiance a ray's cone gathers where it ends (src/cpu/mod.rs glossy_radiance): level 0's
// depth-aware read, or the prefiltered levels around the one whose texel matches the cone's
// footprint `t·tan φ` seen from the probe at v (for the sky, the angle φ).
fn glossy_radiance(probe: u32, v: vec3<f32>, sky: bool, cell: vec2<u32>, t: f32) -> vec3<f32> {
    let r = length(v);
    if (params.glossy_levels == 0u || r <= 0.0) {
        return filtered_radiance(probe, v, sky, true, vec3<f32>(0.0), cell);
    }
    var angle = params.glossy_angle;
    if (!sky) {
        angle = atan(t * params.glossy_tan / r);
    }
    let lambda = clamp(log2(max(angle, 1e-30) / params.glossy_base_angle), 0.0, f32(params.glossy_levels));
    let lo = u32(floor(lambda));
    let f = lambda - floor(lambda);
    let d = v / r;
    var a: vec3<f32>;
    if (lo == 0u) {
        // A cone's read blends: the step-edge read is for rays without one.
        a = filtered_radiance(probe, v, sky, params.glossy_tan == 0.0, vec3<f32>(0.0), cell);
    } else {
        a = glossy_sample(lo, probe, d);
    }
    if (f > 0.0) {
        return mix(a, glossy_sample(lo + 1u, probe, d), f);
    }
    return a;
}

// Most probes a blend queries: src/packed.rs MAX_GLOSSY_BLEND + 1.
const MAX_BLEND_QUERY: u32 = 9u;
var<private> near_probe: array<u32, 9>;
var<private> near_d2: array<f32, 9>;

// The k probes nearest to p in the k-d tree at words[start..], nearest first (ties to the
// lower probe), into near_probe / near_d2; returns how many (src/cpu/select.rs
// nearest_probes).
fn nearest_probes(start: u32, count: u32, p: vec3<f32>, k_in: u32) -> u32 {
    let k = min(k_in, MAX_BLEND_QUERY);
    var found = 0u;
    var stack_lo: array<u32, 64>;
    var stack_hi: array<u32, 64>;
    var stack_depth: array<u32, 64>;
    var stack_bound: array<f32, 64>;
    stack_lo[0] = 0u;
    stack_hi[0] = count;
    stack_depth[0] = 0u;
    stack_bound[0] = -1.0;
    var top = 1u;
    loop {
        if (top == 0u) {
            break;
        }
        top -= 1u;
        let lo = stack_lo[top];
        let hi = stack_hi[top];
        let depth = stack_depth[top];
        let bound = stack_bound[top];
        if (lo >= hi || (found == k && bound > near_d2[k - 1u])) {
            continue;
        }
        let mid = (lo + hi) / 2u;
        let at = start + 4u * mid;
        let q = vec3<f32>(bitcast<f32>(words[at]), bitcast<f32>(words[at + 1u]), bitcast<f32>(words[at + 2u]));
        let probe = words[at + 3u];
        let d = q - p;
        let d2 = d.x * d.x + d.y * d.y + d.z * d.z;
        var insert = found < k;
        if (!insert) {
            insert = d2 < near_d2[k - 1u] || (d2 == near_d2[k - 1u] && probe < near_probe[k - 1u]);
        }
        if (insert) {
            var i = found;
            if (found >= k) {
                i = k - 1u;
            }
            loop {
                if (i == 0u) {
                    break;
                }
                let a = near_d2[i - 1u];
                if (!(d2 < a || (d2 == a && probe < near_probe[i - 1u]))) {
                    break;
                }
                near_probe[i] = near_probe[i - 1u];
                near_d2[i] = a;
                i -= 1u;
            }
            near_probe[i] = probe;
            near_d2[i] = d2;
            found = min(found + 1u, k);
        }
        let axis = depth % 3u;
        let delta = p[axis] - q[axis];
        var near_lo = mid + 1u;
        var near_hi = hi;
        var far_lo = lo;
        var far_hi = mid;
        if (delta < 0.0) {
            near_lo = lo;
            near_hi = mid;
            far_lo = mid + 1u;
            far_hi = hi;
        }
        if (top + 2u <= 64u) {
            stack_lo[top] = far_lo;
            stack_hi[top] = far_hi;
            stack_depth[top] = depth + 1u;
            stack_bound[top] = delta * delta;
            stack_lo[top + 1u] = near_lo;
            stack_hi[top + 1u] = near_hi;
            stack_depth[top + 1u] = depth + 1u;
            stack_bound[top + 1u] = -1.0;
            top += 2u;
        }
    }
    return found;
}

// A filtered glossy answer or estimate blended over the probes nearest to the ray's origin
// (src/cpu/mod.rs blended_radiance): `own` stands where none sees the hit (or, for a wide
// footprint, params.glossy_wide_tan, the ray's origin).
fn blended_radiance(origin: vec3<f32>, direction: vec3<f32>, hit: bool, end: vec3<f32>, normal: vec3<f32>, t: f32, own: vec3<f32>) -> vec3<f32> {
    if (params.glossy_levels == 0u || params.glossy_blend == 0u || params.kd_count == 0u) {
        return own;
    }
    let k = params.glossy_blend;
    let found = nearest_probes(params.kd_nodes, params.kd_count, origin, k + 1u);
    var radius2 = bitcast<f32>(0x7f800000u);
    let finite = found > k;
    if (finite) {
        radius2 = near_d2[k];
    }
    var sum = vec3<f32>(0.0);
    var total = 0.0;
    for (var i = 0u; i < min(found, k); i++) {
        let probe = near_probe[i];
        var falloff = 1.0;
        if (finite) {
            let u = 1.0 - near_d2[i] / radius2;
            falloff = u * u;
        }
        if (falloff <= 0.0) {
            continue;
        }
        if (hit) {
            let v = end - positions[probe].xyz;
            let r = length(v);
            if (r <= 0.0) {
                continue;
            }
            var w = falloff;
            if (t * params.glossy_tan >= r * params.glossy_wide_tan) {
                if (!sees_point(probe, end, false) && !sees_point(probe, origin, false)) {
                    continue;
                }
            } else {
                let facing = -dot(normal, v / r);
                if (facing <= 0.0 || !sees_point(probe, end, false)) {
                    continue;
                }
                w *= facing;
            }
            let cell = texel_containing(params.resolution, v / r);
            sum += w * glossy_radiance(probe, v, false, cell, t);
            total += w;
        } else {
            fetches += 1u;
            let cell = texel_containing(params.resolution, direction);
            if (!sky_texel(probe, cell)) {
                continue;
            }
            sum += falloff * glossy_radiance(probe, direction, true, cell, t);
            total += falloff;
        }
    }
    if (total > 0.0) {
        return sum / total;
    }
    return own;
}

// src/cpu/mod.rs bounds_exit: where the ray leaves the geometry bounds (F32_MAX: none).
fn bounds_exit(origin: vec3<f32>, direction: vec3<f32>) -> f32 {
    if (params.bounds_min.w == 0.0) {
        return F32_MAX;
    }
    var t = F32_MAX;
    for (var axis = 0u; axis < 3u; axis++) {
        let o = origin[axis];
        let d = direction[axis];
        let lo = params.bounds_min[axis];
        let hi = params.bounds_max[axis];
        if (d > 0.0) {
            t = min(t, (hi - o) / d);
        } else if (d < 0.0) {
            t = min(t, (lo - o) / d);
        } else if (o < lo || o > hi) {
            return 0.0;
        }
    }
    return t;
}

// src/cpu/mod.rs leaves_into_sky: the probe sees the sky towards the exit point.
fn leaves_into_sky(probe: u32, exit: vec3<f32>) -> bool {
    let v = exit - positions[probe].xyz;
    if (all(v == vec3<f32>(0.0))) {
        return false;
    }
    fetches += 1u;
    return sky_texel(probe, texel_containing(params.resolution, normalize(v)));
}

// src/packed.rs record_is_sky: the record saw sky at its centre.
fn record_is_sky(texel: vec4<u32>) -> bool {
    return bitcast<f32>(texel.x & ~SIGN_BIT) >= params.sky_distance;
}

// src/packed.rs record_is_clear_sky: sky at its centre and no nearer edge.
fn record_is_clear_sky(texel: vec4<u32>) -> bool {
    return record_is_sky(texel) && (texel.w & SIGN_BIT) == 0u;
}

// src/cpu/mod.rs sky_texel (one fetch).
fn sky_texel(probe: u32, cell: vec2<u32>) -> bool {
    return record_is_sky(geometry[padded_index(params.resolution, probe, cell)]);
}

// src/cpu/mod.rs sees_sky: clear_sky_texel with clear, else sky_texel (one fetch).
fn sees_sky(probe: u32, cell: vec2<u32>, clear: bool) -> bool {
    if (clear) {
        return clear_sky_texel(probe, cell);
    }
    return sky_texel(probe, cell);
}

// src/cpu/mod.rs clear_sky_texel: sky at the centre and no nearer edge (one fetch); what a
// MISS reads the sky from.
fn clear_sky_texel(probe: u32, cell: vec2<u32>) -> bool {
    return record_is_clear_sky(geometry[padded_index(params.resolution, probe, cell)]);
}

// src/cpu/mod.rs first_seeing_sky: (probe or NO_PROBE, first candidate, examined).
fn first_seeing_sky(x: vec3<f32>, direction: vec3<f32>, cell: vec2<u32>) -> vec3<u32> {
    let list = select_probes(x, direction, NO_PROBE);
    let anchor = nearest_probe(params.kd_nodes, params.kd_count, x);
    return first_sky_candidate(list, anchor, NO_PROBE, cell, true);
}

// src/cpu/mod.rs first_sky_candidate: the first probe of the list, then of anchor's
// nearest-table row (none for NO_PROBE), other than skip, whose texel cell sees the sky:
// (that probe or NO_PROBE, first candidate, examined).
fn first_sky_candidate(list: Candidates, anchor: u32, skip: u32, cell: vec2<u32>, clear: bool) -> vec3<u32> {
    var extension = 0u;
    if (anchor != NO_PROBE) {
        extension = min(params.nearest_candidates, NEAREST_ROW);
    }
    var first = NO_PROBE;
    var examined = 0u;
    for (var i = 0u; i < list.len + extension; i++) {
        let q = candidate(list, anchor, skip, i);
        if (q == NO_PROBE || q == skip) {
            continue;
        }
        if (first == NO_PROBE) {
            first = q;
        }
        examined += 1u;
        if (sees_sky(q, cell, clear)) {
            return vec3<u32>(q, first, examined);
        }
    }
    return vec3<u32>(NO_PROBE, first, examined);
}

// src/cpu/mod.rs sky_probe: the probe a MISS reads the sky from (it, else the first of the
// candidates at the ray's origin and then of its nearest-table row whose texel along the ray
// sees the sky, else NO_PROBE: the sky map).
fn sky_probe(probe: u32, origin_list: Candidates, direction: vec3<f32>, clear: bool) -> u32 {
    let cell = texel_containing(params.resolution, direction);
    fetches += 1u;
    if (sees_sky(probe, cell, clear)) {
        return probe;
    }
    let found = first_sky_candidate(origin_list, probe, probe, cell, clear);
    fetches += found.z;
    return found.x;
}

// src/cpu/mod.rs sky_map_radiance: the sky map's texel along the direction (the mean over the
// probes that see the sky that way), for a MISS none of whose probes does.
fn sky_map_radiance(direction: vec3<f32>) -> vec3<f32> {
    let cell = texel_containing(params.resolution, direction);
    let i = 3u * (params.sky_map + cell.y * params.resolution + cell.x);
    fetches += 1u;
    return vec3<f32>(radiance[i], radiance[i + 1u], radiance[i + 2u]);
}

// An edge texel's weight in the score of the probe that sees a point best (src/cpu/mod.rs
// edge_weight; hit_reader and look_up_point).
fn edge_weight(record: vec4<u32>) -> f32 {
    if (((record.x | record.w) & SIGN_BIT) != 0u) {
        return 0.25;
    }
    return 1.0;
}

// src/cpu/mod.rs hit_reader: of the probe that answered (its texel cell) and its row of the
// nearest-probe table, the probes that see the point from the side the ray came from, the one
// that sees it most squarely for its distance (cosine over distance, an edge texel a quarter):
// (probe, cell.x, cell.y). One fetch per candidate examined.
fn hit_reader(probe: u32, cell: vec2<u32>, hit: vec3<f32>, normal: vec3<f32>, origin: vec3<f32>) -> vec3<u32> {
    var side = normal;
    if (dot(normal, origin - hit) < 0.0) {
        side = -normal;
    }
    let v0 = hit - positions[probe].xyz;
    let r0 = length(v0);
    if (r0 == 0.0 || all(side == vec3<f32>(0.0))) {
        return vec3<u32>(probe, cell);
    }
    fetches += 1u;
    let own = geometry[padded_index(params.resolution, probe, cell)];
    var best = vec3<u32>(probe, cell);
    var best_score = max(-dot(side, v0) / r0, 0.0) / r0 * edge_weight(own);
    // The answering probe's row of the nearest-probe table (a table read; the selection's
    // search at the hit, one more inlined copy of it, made every ray 40 % slower).
    var row: Candidates;
    row.len = 0u;
    for (var i = 0u; i < NEAREST_ROW; i++) {
        let q = candidate(row, probe, NO_PROBE, i);
        if (q == NO_PROBE || q == probe) {
            continue;
        }
        let v = hit - positions[q].xyz;
        let r = length(v);
        if (r == 0.0) {
            continue;
        }
        let facing = -dot(side, v) / r;
        // Even an inner texel could not beat the best: no fetch.
        if (facing <= 0.0 || facing / r <= best_score) {
            continue;
        }
        let texel = texel_containing(params.resolution, v / r);
        fetches += 1u;
        let plane = texel_plane(q, texel);
        if (plane.sky) {
            continue;
        }
        let score = facing / r * edge_weight(plane.record);
        if (plane_holds(plane, v) && score > best_score) {
            best = vec3<u32>(q, texel);
            best_score = score;
        }
    }
    return best;
}

// The radiance where a ray (or a guess of its end) ends: at a HIT the read there of the probe
// that sees it best (hit_reader); at a MISS, or a guess past t_exit (nothing lies beyond the
// bounds), the sky along the ray from a probe whose texel there sees clear sky, else the sky
// map's (src/cpu/mod.rs ray_end_radiance; the blend of cones follows after the ray loop).
fn ray_end_radiance(probe: u32, guess: ProbeAnswer, origin: vec3<f32>, direction: vec3<f32>, origin_list: Candidates, t_exit: f32, answered: bool) -> vec3<f32> {
    let sky = guess.code == MISS || guess.t > t_exit;
    if (guess.code == HIT && !sky) {
        let end = origin + direction * guess.t;
        let reader = hit_reader(probe, guess.cell, end, unpack_normal(guess.normal), origin);
        return glossy_radiance(reader.x, end - positions[reader.x].xyz, false, reader.yz, guess.t);
    }
    var reader = probe;
    if (sky) {
        // An answered MISS reads clear sky, else the sky map; an estimate's guess any sky,
        // else the probe's own read along the ray (src/cpu/mod.rs ray_end_radiance).
        let miss = answered && guess.code == MISS;
        reader = sky_probe(probe, origin_list, direction, miss);
        if (reader == NO_PROBE && miss) {
            return sky_map_radiance(direction);
        }
        if (reader == NO_PROBE) {
            reader = probe;
        }
    }
    let cell = texel_containing(params.resolution, direction);
    return glossy_radiance(reader, direction, true, cell, guess.t);
}

fn trace_ray(ray: TraceRay) -> RayRecord {
    fetches = 0u;
    // Nothing lies beyond the geometry bounds (src/cpu/mod.rs trace_ray).
    let t_exit = bounds_exit(ray.origin, ray.direction);
    // A filtered ray verified past the bounds: a MISS with the estimate's radiance.
    var cone_miss = false;
    var t_miss = 0.0;
    let origin = ray.origin;
    let direction = ray.direction;
    var t = ray.t_min;
    var list: Candidates;
    // The candidates at the ray's origin (src/cpu/mod.rs trace_ray).
    var origin_list: Candidates;
    var failed = NO_PROBE;
    var reselect = true;
    var anchor = NO_PROBE;
    var extension = 0u;
    var extended = false;
    var estimating = false;
    // Estimating with no probe that could start the ray: read along it, no march.
    var unstarted = false;
    var next = 0u;
    var tried = 0u;
    var fallback = NO_PROBE;
    // The last crossing a probe refused and put on (src/cpu/mod.rs trace_ray).
    var refusal_probe = NO_PROBE;
    var refusal_t = 0.0;
    var refusal_tolerance = 0.0;
    var blend = false;
    var blend_hit = false;
    var blend_t = 0.0;
    // A mirror ray's estimate takes its far guess (src/cpu/mod.rs trace_ray).
    var far_pass = false;
    var record: RayRecord;
    record.status = UNKNOWN;
    record.probe = NO_PROBE;
    record.normal = vec3<f32>(0.0);
    record.radiance = vec3<f32>(0.0);
    record.pad0 = 0u;
    record.pad1 = 0u;
    loop {
        let here = origin + direction * t;
        if (reselect) {
            list = select_probes(here, direction, failed);
            if (t == ray.t_min) {
                origin_list = list;
            }
            next = 0u;
            extension = 0u;
            extended = false;
            reselect = false;
        }
        var probe = NO_PROBE;
        if (far_pass) {
            // The far guess of a mirror ray's estimate: the same probe, from the near guess.
            probe = record.probe;
        } else {
            if (tried >= params.max_probes) {
                estimating = true;
            } else if (next >= list.len + extension) {
                if (extended || params.nearest_candidates == 0u) {
                    estimating = true;
                } else {
                    anchor = nearest_probe(params.kd_nodes, params.kd_count, here);
                    if (anchor != NO_PROBE) {
                        extension = min(params.nearest_candidates, NEAREST_ROW);
                    }
                    extended = true;
                    continue;
                }
            }
            if (estimating) {
                for (var i = 0u; i < list.len + extension; i++) {
                    let q = candidate(list, anchor, failed, i);
                    if (q != NO_PROBE && sees_point(q, here, i >= list.len)) {
                        probe = q;
                        break;
                    }
                }
                if (probe == NO_PROBE) {
                    probe = fallback;
                }
                record.t = t;
                record.position = here;
                record.probes_tried = tried;
                if (probe == NO_PROBE) {
                    // No probe could start the ray: the probe nearest its start (`anchor`,
                    // found when the list was extended: one call site of the nearest-probe
                    // search; else the list's first) reads along it (src/cpu/mod.rs trace_ray).
                    probe = anchor;
                    if (probe == NO_PROBE && list.len > 0u) {
                        probe = list.probes[0];
                    }
                    unstarted = true;
                    if (probe == NO_PROBE) {
                        break;
                    }
                }
            } else {
                probe = candidate(list, anchor, failed, next);
                // At the ray's start, a candidate must see the ray leave (not the surface it
                // leaves, from behind).
                var departing = vec3<f32>(0.0);
                if (t == ray.t_min) {
                    departing = direction;
                }
                if (probe == NO_PROBE || !sees_departure(probe, here, departing, next >= list.len)) {
                    next += 1u;
                    continue;
                }
                tried += 1u;
                if (fallback == NO_PROBE) {
                    fallback = probe;
                }
            }
        }
        // One call site of the march (and of the estimate's read below): lavapipe inlines
        // every call, and a second copy of the march slowed every ray.
        var march = MARCH_STRICT;
        var march_ray = ray;
        var t_from = t;
        if (estimating) {
            march = MARCH_FIRST_CONTACT;
        }
        if (far_pass) {
            march = MARCH_PAST_HIDDEN;
            march_ray.t_max = min(ray.t_max, t_exit);
            t_from = record.t;
        }
        var answer: ProbeAnswer;
        if (unstarted) {
            answer = ProbeAnswer(UNKNOWN, t, vec2<u32>(0u), 0u);
            guessed_hidden = false;
        } else {
            answer = trace_probe(probe, march_ray, t_from, march);
        }
        if (estimating) {
            let at = positions[probe].xyz;
            let near_hidden = !far_pass && answer.code == HIT && guessed_hidden;
            if (!far_pass) {
                if (answer.code == HIT) {
                    let hit = origin + direction * answer.t;
                    record.t = answer.t;
                    record.position = hit;
                    record.normal = unpack_normal(answer.normal);
                }
                record.probe = probe;
            }
            if (params.glossy_levels == 0u) {
                // A mirror ray: the near guess's radiance, or where it lost sight of the ray
                // the mean with the far guess's, marched on from there no farther than the
                // scene's bounds (src/cpu/mod.rs trace_ray).
                let read = ray_end_radiance(probe, answer, origin, direction, origin_list, t_exit, false);
                if (far_pass) {
                    record.radiance = 0.5 * (record.radiance + read);
                    break;
                }
                record.radiance = read;
                if (near_hidden) {
                    far_pass = true;
                    continue;
                }
                break;
            }
            if (answer.code == HIT) {
                record.radiance = glossy_radiance(probe, origin + direction * answer.t - at, false, answer.cell, answer.t);
            } else {
                let cell = texel_containing(params.resolution, direction);
                record.radiance = glossy_radiance(probe, direction, true, cell, answer.t);
            }
            // A filtered estimate blends like an answer (src/cpu/mod.rs trace_ray).
            blend_hit = answer.code == HIT;
            blend_t = answer.t;
            blend = true;
            break;
        }
        // Two probes that each refused a crossing beside a farther edge at the same place
        // agree on a surface there: a hit at their mean (src/cpu/mod.rs trace_ray).
        if (answer.code == UNKNOWN && has_refused && params.agreement != 0u) {
            if (refusal_probe != NO_PROBE && refusal_probe != probe && abs(refusal_t - refused.t) < min(refusal_tolerance, refused.tolerance)) {
                answer = ProbeAnswer(HIT, 0.5 * (refusal_t + refused.t), refused.cell, refused.normal);
            } else {
                refusal_probe = probe;
                refusal_t = refused.t;
                refusal_tolerance = refused.tolerance;
            }
        }
        if (answer.code == UNKNOWN && answer.t >= t_exit && leaves_into_sky(probe, origin + direction * t_exit)) {
            if (params.glossy_levels > 0u) {
                cone_miss = true;
                t_miss = answer.t;
                estimating = true;
                continue;
            }
            answer.code = MISS;
        }
        if (answer.code == HIT || answer.code == MISS) {
            let hit = origin + direction * answer.t;
            var normal = vec3<f32>(0.0);
            if (answer.code == HIT) {
                normal = unpack_normal(answer.normal);
            }
            // A HIT is read by the probe that sees it best; a MISS reads the sky along the
            // ray, from a probe whose texel there sees clear sky (else the sky map).
            record.radiance = ray_end_radiance(probe, answer, origin, direction, origin_list, F32_MAX, true);
            record.status = answer.code;
            record.t = answer.t;
            record.position = hit;
            record.normal = normal;
            record.probe = probe;
            record.probes_tried = tried;
            blend_hit = answer.code == HIT;
            blend_t = answer.t;
            blend = true;
            break;
        }
        if (answer.t > t) {
            t = answer.t;
            failed = probe;
            reselect = true;
        } else {
            next += 1u;
        }
    }
    // One call site: the blend's k-nearest search keeps its stack once per invocation.
    if (blend) {
        record.radiance = blended_radiance(origin, direction, blend_hit, origin + direction * blend_t, record.normal, blend_t, record.radiance);
    }
    if (cone_miss) {
        record.status = MISS;
        record.t = t_miss;
        record.position = origin + direction * t_miss;
        record.normal = vec3<f32>(0.0);
    }
    record.texel_fetches = fetches;
    return record;
}

fn load_ray(index: u32) -> TraceRay {
    let a = ray_words[2u * index];
    let b = ray_words[2u * index + 1u];
    return TraceRay(bitcast<vec3<f32>>(a.xyz), bitcast<f32>(a.w), bitcast<vec3<f32>>(b.xyz), bitcast<f32>(b.w));
}

// The two candidates whose texel in a point's direction came nearest to showing it, by the
// relative gap between the texel's distance and the point's, the best first
// (src/cpu/mod.rs NearMisses).
struct NearMisses {
    probes: array<u32, 2>,
    cells: array<vec2<u32>, 2>,
    errors: array<f32, 2>,
}

fn near_misses_insert(kept: NearMisses, probe: u32, cell: vec2<u32>, error: f32) -> NearMisses {
    var near = kept;
    if (error < near.errors[0]) {
        near.probes[1] = near.probes[0];
        near.cells[1] = near.cells[0];
        near.errors[1] = near.errors[0];
        near.probes[0] = probe;
        near.cells[0] = cell;
        near.errors[0] = error;
    } else if (error < near.errors[1]) {
        near.probes[1] = probe;
        near.cells[1] = cell;
        near.errors[1] = error;
    }
    return near;
}

// src/cpu/mod.rs NEAREST_SURFACE_REACH.
const NEAREST_SURFACE_REACH: u32 = 4u;

struct SurfaceTexel {
    found: bool,
    texel: vec2<u32>,
    distance: f32,
}

// The texel of `probe` within NEAREST_SURFACE_REACH of `cell` whose stored point lies nearest
// to the surface point `v` on the point's own surface (src/cpu/mod.rs nearest_surface_texel
// step for step; one fetch per texel).
fn nearest_surface_texel(probe: u32, cell: vec2<u32>, v: vec3<f32>, normal: vec3<f32>) -> SurfaceTexel {
    let n = params.resolution;
    var result = SurfaceTexel(false, vec2<u32>(0u), bitcast<f32>(0x7f800000u));
    let lo = vec2<u32>(max(cell, vec2<u32>(NEAREST_SURFACE_REACH)) - vec2<u32>(NEAREST_SURFACE_REACH));
    let hi = min(cell + vec2<u32>(NEAREST_SURFACE_REACH), vec2<u32>(n - 1u));
    for (var y = lo.y; y <= hi.y; y += 1u) {
        for (var x = lo.x; x <= hi.x; x += 1u) {
            let texel = vec2<u32>(x, y);
            fetches += 1u;
            let plane = texel_plane(probe, texel);
            if (plane.sky) {
                continue;
            }
            let gap = plane.point - v;
            let distance = length(gap);
            if (plane_faces_like(plane, normal)
                && abs(dot(gap, normal)) <= plane.surface.plane_thickness + 0.2 * distance
                && distance < result.distance) {
                result = SurfaceTexel(true, texel, distance);
            }
        }
    }
    return result;
}

// The radiance of one surface point from the probes that see it (src/cpu/mod.rs
// look_up_point): the hybrid tracer's second half. The query is read from the ray binding
// as raw words: position, packed normal, direction, surface flag.
fn look_up_point(index: u32) -> RayRecord {
    fetches = 0u;
    let a = ray_words[2u * index];
    let b = ray_words[2u * index + 1u];
    let x = bitcast<vec3<f32>>(a.xyz);
    let direction = bitcast<vec3<f32>>(b.xyz);
    let surface = b.w;
    var record: RayRecord;
    record.status = UNKNOWN;
    record.probe = NO_PROBE;
    record.position = x;
    record.t = 0.0;
    record.normal = vec3<f32>(0.0);
    record.radiance = vec3<f32>(0.0);
    record.probes_tried = 0u;
    record.texel_fetches = 0u;
    record.pad0 = 0u;
    record.pad1 = 0u;
    let n = params.resolution;
    if (surface == 0u) {
        let cell = texel_containing(n, direction);
        let found = first_seeing_sky(x, direction, cell);
        let sky = found.x;
        let first = found.y;
        let examined = found.z;
        fetches += examined;
        var probe = first;
        if (sky != NO_PROBE) {
            probe = sky;
        }
        if (probe != NO_PROBE) {
            record.status = MISS;
            if (sky != NO_PROBE) {
                record.radiance = filtered_radiance(probe, direction, true, true, vec3<f32>(0.0), cell);
            } else {
                record.radiance = sky_map_radiance(direction);
            }
            record.probe = probe;
            record.probes_tried = examined;
            record.texel_fetches = fetches;
        }
        return record;
    }
    let list = select_probes(x, direction, NO_PROBE);
    let normal = unpack_normal(a.w);
    var best = NO_PROBE;
    var best_cell = vec2<u32>(0u);
    var best_score = 0.0;
    // The best probe whose texel holds the point on a surface facing otherwise (src/cpu/mod.rs
    // look_up_point): the answer only where no texel faces like it.
    var other = NO_PROBE;
    var other_cell = vec2<u32>(0u);
    var other_score = 0.0;
    var near = NearMisses(array<u32, 2>(NO_PROBE, NO_PROBE), array<vec2<u32>, 2>(vec2<u32>(0u), vec2<u32>(0u)), array<f32, 2>(bitcast<f32>(0x7f800000u), bitcast<f32>(0x7f800000u)));
    var next = 0u;
    var examined = 0u;
    var anchor = NO_PROBE;
    var extension = 0u;
    var extended = false;
    loop {
        if (next >= list.len + extension) {
            if (extended || best != NO_PROBE || params.nearest_candidates == 0u) {
                break;
            }
            anchor = nearest_probe(params.kd_nodes, params.kd_count, x);
            if (anchor != NO_PROBE) {
                extension = min(params.nearest_candidates, NEAREST_ROW);
            }
            extended = true;
            continue;
        }
        let probe = candidate(list, anchor, NO_PROBE, next);
        next += 1u;
        if (probe == NO_PROBE) {
            continue;
        }
        let v = x - positions[probe].xyz;
        let r = length(v);
        if (r == 0.0) {
            continue;
        }
        let w = v / r;
        var facing = 1.0;
        if (any(normal != vec3<f32>(0.0))) {
            facing = -dot(normal, w);
        }
        if (facing <= 0.0) {
            continue;
        }
        examined += 1u;
        fetches += 1u;
        let cell = texel_containing(n, w);
        let plane = texel_plane(probe, cell);
        if (plane.sky) {
            continue;
        }
        if (plane_holds(plane, v)) {
            let score = facing / r * edge_weight(plane.record);
            if (plane_faces_like(plane, normal)) {
                if (score > best_score) {
                    best = probe;
                    best_cell = cell;
                    best_score = score;
                }
            } else if (score > other_score) {
                other = probe;
                other_cell = cell;
                other_score = score;
            }
        } else {
            near = near_misses_insert(near, probe, cell, abs(r - plane.distance) / r);
        }
    }
    if (best == NO_PROBE && other == NO_PROBE && near.probes[0] == NO_PROBE) {
        // No candidate faces the point: every probe that does is asked (src/cpu/mod.rs).
        for (var probe = 0u; probe < params.probe_count; probe += 1u) {
            let v = x - positions[probe].xyz;
            let r = length(v);
            if (r == 0.0 || (any(normal != vec3<f32>(0.0)) && dot(normal, v) >= 0.0)) {
                continue;
            }
            fetches += 1u;
            let cell = texel_containing(n, v / r);
            let plane = texel_plane(probe, cell);
            if (!plane.sky) {
                near = near_misses_insert(near, probe, cell, abs(r - plane.distance) / r);
            }
        }
    }
    var probe = near.probes[0];
    var cell = near.cells[0];
    var facing_normal = vec3<f32>(0.0);
    if (best != NO_PROBE) {
        record.status = HIT;
        probe = best;
        cell = best_cell;
        facing_normal = normal;
    } else if (other != NO_PROBE) {
        record.status = HIT;
        probe = other;
        cell = other_cell;
    }
    record.probes_tried = examined;
    if (record.status != HIT && probe != NO_PROBE) {
        // No probe sees the point: the nearest point of its surface that one of the two
        // nearest misses does see (else the first's texel in its direction).
        var nearest = bitcast<f32>(0x7f800000u);
        for (var k = 0u; k < 2u; k += 1u) {
            let candidate = near.probes[k];
            if (candidate == NO_PROBE) {
                continue;
            }
            let found = nearest_surface_texel(candidate, near.cells[k], x - positions[candidate].xyz, normal);
            if (found.found && found.distance < nearest) {
                probe = candidate;
                cell = found.texel;
                nearest = found.distance;
            }
        }
    }
    if (probe != NO_PROBE) {
        if (record.status == HIT) {
            record.radiance = filtered_radiance(probe, x - positions[probe].xyz, false, true, facing_normal, cell);
        } else {
            fetches += 1u;
            record.radiance = radiance_at(probe, cell);
        }
        record.probe = probe;
        record.normal = normal;
    }
    record.texel_fetches = fetches;
    return record;
}

@compute @workgroup_size(64)
fn look_up_main(@builtin(global_invocation_id) id: vec3<u32>) {
    let index = id.y * params.threads_per_row + id.x;
    if (index >= params.ray_count) {
        return;
    }
    records[index] = look_up_point(index);
}

@compute @workgroup_size(64)
fn trace_main(@builtin(global_invocation_id) id: vec3<u32>) {
    let index = id.y * params.threads_per_row + id.x;
    if (index >= params.ray_count) {
        return;
    }
    records[index] = trace_ray(load_ray(index));
}
