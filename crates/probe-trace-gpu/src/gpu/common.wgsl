// Shared by trace.wgsl and diffuse.wgsl, which are each compiled as common.wgsl followed by
// the file. Mirrors src/surface.rs, the octahedral mapping of probe-octa, and the k-d tree
// search of src/cpu/select.rs. The including shader declares
// `var<storage, read> words: array<u32>` (its selection or interpolation words).

const NO_PROBE: u32 = 0xffffffffu;
// Bound on a texel's angular radius: K_BETA * l1^1.5 / N (src/surface.rs).
const K_BETA: f32 = 2.4;
const COS_MIN: f32 = 0.1;

// probe_index::GridParams (48 bytes).
struct GridParams {
    origin: vec3<f32>,
    count_x: u32,
    spacing: vec3<f32>,
    count_y: u32,
    count_z: u32,
    pad0: u32,
    pad1: u32,
    pad2: u32,
}

fn sign_not_zero(v: f32) -> f32 {
    return select(-1.0, 1.0, v >= 0.0);
}

// probe_octa::decode (for finite input).
fn octa_decode(o_in: vec2<f32>) -> vec3<f32> {
    let o = clamp(o_in, vec2<f32>(-1.0), vec2<f32>(1.0));
    let z = 1.0 - abs(o.x) - abs(o.y);
    var xy = o;
    if (z < 0.0) {
        xy = (vec2<f32>(1.0) - abs(o.yx)) * vec2<f32>(sign_not_zero(o.x), sign_not_zero(o.y));
    }
    return normalize(vec3<f32>(xy, z));
}

// probe_octa::encode (for finite, non-zero input).
fn octa_encode(d: vec3<f32>) -> vec2<f32> {
    let l1 = abs(d.x) + abs(d.y) + abs(d.z);
    let p = d.xy / l1;
    if (d.z < 0.0) {
        return (vec2<f32>(1.0) - abs(p.yx)) * vec2<f32>(sign_not_zero(p.x), sign_not_zero(p.y));
    }
    return p;
}

// probe_octa::OctaLayout::texel_containing: the interior texel holding a direction.
fn texel_containing(n: u32, d: vec3<f32>) -> vec2<u32> {
    let o = clamp(octa_encode(d), vec2<f32>(-1.0), vec2<f32>(1.0));
    let f = (o + vec2<f32>(1.0)) * (0.5 * f32(n));
    let last = n - 1u;
    return vec2<u32>(min(u32(max(f.x, 0.0)), last), min(u32(max(f.y, 0.0)), last));
}

// Octahedral coordinates of the centre of interior texel `cell` of an n×n map.
fn texel_center(n: u32, cell: vec2<u32>) -> vec2<f32> {
    let nf = f32(n);
    return vec2<f32>(
        (2.0 * f32(cell.x) + 1.0) / nf - 1.0,
        (2.0 * f32(cell.y) + 1.0) / nf - 1.0,
    );
}

// src/surface.rs unpack_normal: UNKNOWN_NORMAL (x = i16::MIN) is "unknown" (the zero vector).
const UNKNOWN_NORMAL: u32 = 0x00008000u;

fn unpack_normal(packed: u32) -> vec3<f32> {
    if (packed == UNKNOWN_NORMAL) {
        return vec3<f32>(0.0);
    }
    return octa_decode(unpack2x16snorm(packed));
}

// src/surface.rs TexelSurface.
struct TexelSurface {
    near: f32,
    far: f32,
    thickness: f32,
    plane_thickness: f32,
    visible_normal: vec3<f32>,
    // |n·d| of the stored normal and the texel direction (1 for an unknown normal).
    cos_incidence: f32,
}

// src/surface.rs texel_surface.
fn texel_surface(n: u32, center: vec3<f32>, distance: f32, normal: vec3<f32>, thickness_scale: f32) -> TexelSurface {
    let l1 = abs(center.x) + abs(center.y) + abs(center.z);
    let beta = K_BETA * l1 * sqrt(l1) / f32(n);
    let sin_b = sin(beta);
    let cos_b = cos(beta);
    var nn = normal;
    var c = dot(normal, center);
    if (all(normal == vec3<f32>(0.0))) {
        nn = -center;
        c = -1.0;
    }
    var visible = nn;
    if (c > 0.0) {
        visible = -nn;
    }
    let cos_g = min(max(abs(c), max(COS_MIN, 2.0 * sin_b)), 1.0);
    let sin_g = sqrt(max(1.0 - cos_g * cos_g, 0.0));
    let far_extent = distance * (cos_g / (cos_g * cos_b - sin_g * sin_b) - 1.0);
    let near_extent = distance * (1.0 - cos_g / (cos_g * cos_b + sin_g * sin_b));
    let thickness = thickness_scale * distance * beta / cos_g;
    return TexelSurface(distance - near_extent - thickness, distance + far_extent + thickness, thickness, thickness * cos_g, visible, abs(c));
}

// Nearest probe to p in the k-d tree at words[start..] (count nodes of 4 words: position bits,
// probe); ties to the lower probe. src/cpu/select.rs nearest_probe.
fn nearest_probe(start: u32, count: u32, p: vec3<f32>) -> u32 {
    var best_probe = NO_PROBE;
    var best_d2 = bitcast<f32>(0x7f800000u);
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
        if (bound > best_d2 || lo >= hi) {
            continue;
        }
        let mid = (lo + hi) / 2u;
        let at = start + 4u * mid;
        let q = vec3<f32>(bitcast<f32>(words[at]), bitcast<f32>(words[at + 1u]), bitcast<f32>(words[at + 2u]));
        let probe = words[at + 3u];
        let d = q - p;
        let d2 = d.x * d.x + d.y * d.y + d.z * d.z;
        if (d2 < best_d2 || (d2 == best_d2 && probe < best_probe)) {
            best_d2 = d2;
            best_probe = probe;
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
    return best_probe;
}
