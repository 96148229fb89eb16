//! The single-probe trace, step for step as `gpu/trace.wgsl` does it: split the ray into its
//! ≤ 4 octahedral segments, walk each segment's cells (hi-Z or two-level), decide each
//! full-resolution cell with the fine test.

use glam::{UVec2, Vec2, Vec3};

use super::profile::{FetchKind, FetchLog};
use crate::packed::{
    AGREEMENT_SHOWN_WEIGHT, COS_AMONG_SAMPLES, METHOD_HIZ, PackedField, SIGN_BIT, TraceParams,
    padded_index,
};
use crate::surface::{texel_center, texel_plane, unpack_normal};

/// Outcome codes shared with the WGSL.
pub(crate) const HIT: u32 = 0;
pub(crate) const MISS: u32 = 1;
pub(crate) const UNKNOWN: u32 = 2;
pub(crate) const CONTINUE: u32 = 3;

/// σ beyond any segment (segments run over σ ∈ [0, 1]).
const NO_EXIT: f32 = 4.0;

/// One straight piece of the ray in the probe's octahedral map.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct Segment {
    pub t0: f32,
    pub t1: f32,
    pub q0: Vec2,
    pub q1: Vec2,
    /// L1 norms of the ray points (relative to the probe) at `t0` and `t1`: the homogeneous
    /// weights that map a point along the 2-D segment back to `t`.
    pub l0: f32,
    pub l1: f32,
}

/// What a march concluded.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Outcome {
    /// HIT, UNKNOWN or CONTINUE (MISS is decided by the caller).
    pub code: u32,
    /// Hit `t`, or where visibility was lost.
    pub t: f32,
    /// The full-resolution texel of the hit.
    pub cell: UVec2,
    /// Its packed normal.
    pub normal: u32,
}

impl Outcome {
    const CONTINUE: Outcome = Outcome {
        code: CONTINUE,
        t: 0.0,
        cell: UVec2::ZERO,
        normal: 0,
    };

    fn unknown(t: f32) -> Outcome {
        Outcome {
            code: UNKNOWN,
            t,
            ..Outcome::CONTINUE
        }
    }

    /// The relaxed march's guess: a hit at `t` in `cell`.
    fn guess(t: f32, cell: UVec2, normal: u32) -> Outcome {
        Outcome {
            code: HIT,
            t,
            cell,
            normal,
        }
    }
}

/// A crossing the strict march refused beside a farther edge (the cause of its UNKNOWN), put
/// to the probes after it: one that refuses a crossing at the same place makes it a hit
/// (`trace_ray`). Recorded when the texels showing the crossing hold at least
/// [`crate::packed::AGREEMENT_SHOWN_WEIGHT`] of its bilinear weight, and only for a crossing
/// after the ray's start.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Refusal {
    /// Where the ray crosses the texel's plane.
    pub t: f32,
    /// The plane's thickness along its normal: how near another probe's crossing must lie.
    pub tolerance: f32,
    /// The texel.
    pub cell: UVec2,
    /// Its packed normal.
    pub normal: u32,
}

/// The probe-local view of one ray; `L` records where fetches go (`()` records nothing).
pub(crate) struct ProbeRay<'a, L: FetchLog = ()> {
    pub field: &'a PackedField,
    pub params: &'a TraceParams,
    pub probe: u32,
    /// Ray origin relative to the probe centre.
    pub origin: Vec3,
    /// Unit direction.
    pub direction: Vec3,
    /// The ray's own `t_min`: a ray cannot hit a plane it starts behind.
    pub t_min: f32,
    /// Texel fetches so far.
    pub fetches: u32,
    /// The fetch recorder.
    pub log: L,
    /// Where the march is, in full-resolution texels along this probe's path (for the log).
    pub path_position: f32,
    /// The hi-Z level the previous segment's march ended at (the next starts there).
    pub carry_level: u32,
    /// The estimate's march (an UNKNOWN ray's fallback): the first place where the ray may
    /// meet what the probe saw is taken as a hit — entering behind a texel's surface, or
    /// crossing its plane at an edge or from behind — instead of handing the ray on.
    pub relaxed: bool,
    /// With `relaxed`, the estimate's far guess ([`March::PastHidden`]): where the ray goes
    /// behind what the probe saw, the march passes on instead of guessing a hit there; and
    /// as it starts where the near guess lost sight of the ray, a crossing from behind within
    /// the thickness is the ray coming back through a surface, not leaving its start.
    pub pass_hidden: bool,
    /// The relaxed march's hit is a guess where the ray went out of sight (not a crossing).
    pub guessed_hidden: bool,
    /// The crossing the strict march refused where it answered UNKNOWN, if it is put on.
    pub refused: Option<Refusal>,
    /// The last radius computed and its ray parameter: a march step's far end is the next
    /// step's near end, so each radius is asked for twice in a row ([`Self::radius`]).
    pub last_radius: (f32, f32),
}

/// How one probe's march ends a ray it cannot decide.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum March {
    /// Hands it on: UNKNOWN where the ray goes out of the probe's sight.
    Strict,
    /// The estimate's near guess: a hit where the ray may first meet what the probe saw
    /// (goes behind a stored surface, or crosses one at an edge or from behind).
    FirstContact,
    /// The estimate's far guess, marched on from a near guess that lost sight of the ray:
    /// stretches the probe does not see are passed, so the guess is where the ray next
    /// crosses a stored surface (or comes back through one), or the end of the march (a MISS).
    PastHidden,
}

/// `signNotZero` with the `+` side for 0 and −0 (as `probe_octa::sign_not_zero`).
#[inline]
fn sign_not_zero(v: f32) -> f32 {
    if v >= 0.0 { 1.0 } else { -1.0 }
}

/// Octahedral coordinates of `p` as seen inside the octant with `signs`, so that points on a
/// plane get the value of the side they belong to (`probe_octa::split_ray`'s convention).
#[inline]
fn encode_in_octant(p: Vec3, signs: Vec3) -> Vec2 {
    let l1 = p.x.abs() + p.y.abs() + p.z.abs();
    let q = Vec2::new(p.x.abs() * signs.x, p.y.abs() * signs.y) / l1;
    if signs.z < 0.0 {
        Vec2::new(
            (1.0 - q.y.abs()) * sign_not_zero(signs.x),
            (1.0 - q.x.abs()) * sign_not_zero(signs.y),
        )
    } else {
        q
    }
}

/// Endpoint of a piece: octahedral point and L1 weight of the ray at `t`, as the limit from
/// inside the piece (`vanishing`: axes whose plane the ray crosses exactly at `t`).
#[inline]
fn endpoint(
    o: Vec3,
    d: Vec3,
    t: f32,
    vanishing: u32,
    signs: Vec3,
    starts_here: bool,
) -> (Vec2, f32) {
    let mut p = o + d * t;
    if vanishing & 1 != 0 {
        p.x = 0.0;
    }
    if vanishing & 2 != 0 {
        p.y = 0.0;
    }
    if vanishing & 4 != 0 {
        p.z = 0.0;
    }
    let l1 = p.x.abs() + p.y.abs() + p.z.abs();
    if l1 == 0.0 {
        // Through the probe centre: the limit direction of travel.
        let limit = if starts_here { d } else { -d };
        return (encode_in_octant(limit, signs), 0.0);
    }
    (encode_in_octant(p, signs), l1)
}

/// Splits `o + t·d`, `t ∈ [t_min, t_max]` (finite, ordered), at the probe's planes x, y, z = 0
/// into at most four pieces (the algorithm of `probe_octa::split_ray`).
pub(crate) fn split_segments(
    o: Vec3,
    d: Vec3,
    t_min: f32,
    t_max: f32,
    out: &mut [Segment; 4],
) -> usize {
    let mut cut_t = [0.0f32; 3];
    let mut cut_mask = [0u32; 3];
    let mut count = 0usize;
    for axis in 0..3 {
        if d[axis] != 0.0 {
            let t = -o[axis] / d[axis];
            if t > t_min && t < t_max {
                cut_t[count] = t;
                cut_mask[count] = 1 << axis;
                count += 1;
            }
        }
    }
    // Insertion sort by t.
    for i in 1..count {
        let mut j = i;
        while j > 0 && cut_t[j - 1] > cut_t[j] {
            cut_t.swap(j - 1, j);
            cut_mask.swap(j - 1, j);
            j -= 1;
        }
    }
    // Bounds t_min, merged cuts, t_max.
    let mut bound_t = [t_min; 5];
    let mut bound_mask = [0u32; 5];
    let mut bounds = 1usize;
    for i in 0..count {
        if bounds > 1 && bound_t[bounds - 1] == cut_t[i] {
            bound_mask[bounds - 1] |= cut_mask[i];
        } else {
            bound_t[bounds] = cut_t[i];
            bound_mask[bounds] = cut_mask[i];
            bounds += 1;
        }
    }
    bound_t[bounds] = t_max;
    bound_mask[bounds] = 0;
    let pieces = bounds;
    for i in 0..pieces {
        let (t0, t1) = (bound_t[i], bound_t[i + 1]);
        let mid = o + d * (0.5 * t0 + 0.5 * t1);
        let signs = Vec3::new(
            sign_not_zero(mid.x),
            sign_not_zero(mid.y),
            sign_not_zero(mid.z),
        );
        let (q0, l0) = endpoint(o, d, t0, bound_mask[i], signs, true);
        let (q1, l1) = endpoint(o, d, t1, bound_mask[i + 1], signs, false);
        out[i] = Segment {
            t0,
            t1,
            q0,
            q1,
            l0,
            l1,
        };
    }
    pieces
}

/// Ray parameter at `sigma` along a segment's 2-D line (perspective-correct: the octahedral
/// map is projective inside an octant, with the L1 norm as homogeneous weight).
#[inline]
fn t_of(seg: &Segment, sigma: f32) -> f32 {
    if sigma <= 0.0 {
        return seg.t0;
    }
    if sigma >= 1.0 {
        return seg.t1;
    }
    let a = sigma * seg.l0;
    let lambda = a / (a + (1.0 - sigma) * seg.l1);
    seg.t0 + (seg.t1 - seg.t0) * lambda
}

/// A pyramid cell's bounding plane: points with `normal · p < offset` (relative to the probe)
/// pass ([`crate::pyramid`]).
struct Plane {
    normal: Vec3,
    offset: f32,
}

impl Plane {
    #[inline]
    fn unpack(packed_normal: u32, offset: u32) -> Plane {
        Plane {
            normal: unpack_normal(packed_normal),
            offset: f32::from_bits(offset),
        }
    }
}

/// Where the march may go on from inside `cell` of `level` (entered at σ = `sigma`, left at
/// `exit`) when the ray stays in the cell's pass region up to ray parameter `t_pass`: the
/// full-resolution texel holding σ(`t_pass`) less a thousandth of a texel, and the σ where the
/// line enters it — or `None` if that is no further on. The texels skipped lie wholly before
/// `t_pass`, so their fine tests would all have passed; the texel returned is then tested over
/// the same interval the full march would give it.
#[allow(clippy::too_many_arguments)]
#[inline]
fn skip_to(
    seg: &Segment,
    t_pass: f32,
    cell: UVec2,
    level: u32,
    c0: Vec2,
    delta: Vec2,
    sigma: f32,
    exit: f32,
) -> Option<(UVec2, f32)> {
    let s = sigma_of(seg, t_pass) - 1e-3 / delta.length();
    if s <= sigma {
        return None;
    }
    let p = c0 + delta * s;
    let size = 1i32 << level;
    let (lo_x, lo_y) = (cell.x as i32 * size, cell.y as i32 * size);
    let target = UVec2::new(
        entered_index(p.x, delta.x).clamp(lo_x, lo_x + size - 1) as u32,
        entered_index(p.y, delta.y).clamp(lo_y, lo_y + size - 1) as u32,
    );
    let entry = entry_sigma(target, c0, delta);
    (entry > sigma && entry < exit).then_some((target, entry))
}

/// Inverse of [`t_of`]: σ along a segment's 2-D line of ray parameter `t`.
#[inline]
fn sigma_of(seg: &Segment, t: f32) -> f32 {
    if t <= seg.t0 || seg.t1 <= seg.t0 {
        return 0.0;
    }
    if t >= seg.t1 {
        return 1.0;
    }
    let lambda = (t - seg.t0) / (seg.t1 - seg.t0);
    lambda * seg.l1 / ((1.0 - lambda) * seg.l0 + lambda * seg.l1)
}

/// σ where the line enters full-resolution `cell` (the later of its x and y entries): the
/// same float expression as the exit of the cell before it in [`exit_sigmas`].
#[inline]
fn entry_sigma(cell: UVec2, c0: Vec2, delta: Vec2) -> f32 {
    let axis = |i: u32, c: f32, dc: f32| -> f32 {
        if dc > 0.0 {
            (i as f32 * 1.0 - c) / dc
        } else if dc < 0.0 {
            ((i + 1) as f32 * 1.0 - c) / dc
        } else {
            f32::NEG_INFINITY
        }
    };
    axis(cell.x, c0.x, delta.x).max(axis(cell.y, c0.y, delta.y))
}

/// The full-resolution cell where the line starts: the one containing `c0`, or on a cell
/// boundary the one the line enters.
#[inline]
fn start_cell(c0: Vec2, delta: Vec2, resolution: u32) -> UVec2 {
    let last = resolution as i32 - 1;
    UVec2::new(
        (entered_index(c0.x, delta.x)).clamp(0, last) as u32,
        (entered_index(c0.y, delta.y)).clamp(0, last) as u32,
    )
}

/// Index of the unit interval holding `c`, or on an integer the one a line moving along `dc`
/// enters.
#[inline]
fn entered_index(c: f32, dc: f32) -> i32 {
    let f = floor_small(c);
    if dc < 0.0 && c == f {
        f as i32 - 1
    } else {
        f as i32
    }
}

/// `c.floor()` for the map coordinates the march takes (|c| below 2²⁴, where every float is
/// exact as an `i32`), without the library call `f32::floor` makes on CPUs below SSE4.1 (1.6 %
/// of the CPU twin's time went to it). NaN gives 0, as `c.floor() as i32` does.
#[inline]
fn floor_small(c: f32) -> f32 {
    let truncated = c as i32 as f32;
    if truncated > c {
        truncated - 1.0
    } else {
        truncated
    }
}

/// σ where the line leaves `cell` of `level` through its x and its y boundary.
#[inline]
fn exit_sigmas(cell: UVec2, level: u32, c0: Vec2, delta: Vec2) -> (f32, f32) {
    let size = (1u32 << level) as f32;
    let axis = |i: u32, c: f32, dc: f32| -> f32 {
        if dc > 0.0 {
            ((i + 1) as f32 * size - c) / dc
        } else if dc < 0.0 {
            (i as f32 * size - c) / dc
        } else {
            NO_EXIT
        }
    };
    (axis(cell.x, c0.x, delta.x), axis(cell.y, c0.y, delta.y))
}

/// One axis of [`advance`]: the new full-resolution index.
#[inline]
fn advance_axis(i: u32, level: u32, crossed: bool, c: f32, dc: f32) -> i32 {
    let lo = (i << level) as i32;
    let hi = ((i + 1) << level) as i32 - 1;
    if crossed {
        if dc > 0.0 { hi + 1 } else { lo - 1 }
    } else {
        entered_index(c, dc).clamp(lo, hi)
    }
}

/// Moves the full-resolution `cursor` to where the line enters the next cell after leaving
/// `cell` of `level` at σ = `exit` (through x if `sx <= exit`, y if `sy <= exit`). Along a
/// crossed axis the new index is exact (the first column or row of the next cell); along the
/// other it comes from the line's position, kept inside `cell`. `false` if the line left the
/// map. (Eight plain arguments, as the WGSL twin takes them.)
#[allow(clippy::too_many_arguments)]
#[inline]
fn advance(
    cursor: &mut UVec2,
    cell: UVec2,
    level: u32,
    (sx, sy): (f32, f32),
    exit: f32,
    c0: Vec2,
    delta: Vec2,
    resolution: u32,
) -> bool {
    let at = c0 + delta * exit;
    let x = advance_axis(cell.x, level, sx <= exit, at.x, delta.x);
    let y = advance_axis(cell.y, level, sy <= exit, at.y, delta.y);
    let n = resolution as i32;
    if x < 0 || y < 0 || x >= n || y >= n {
        return false;
    }
    *cursor = UVec2::new(x as u32, y as u32);
    true
}

impl<L: FetchLog> ProbeRay<'_, L> {
    /// Radial distance of the ray point at `t` (the same value whether computed or taken from
    /// the last call's).
    #[inline]
    fn radius(&mut self, t: f32) -> f32 {
        if t == self.last_radius.0 {
            return self.last_radius.1;
        }
        let r = (self.origin + self.direction * t).length();
        self.last_radius = (t, r);
        r
    }

    /// The record of pyramid level `level ≥ 1` at `cell` (one fetch): min near and max far bits,
    /// packed bounding-plane normal, plane offset bits ([`crate::pyramid`]).
    #[inline]
    fn pyramid(&mut self, level: u32, cell: UVec2) -> [u32; 4] {
        self.fetches += 1;
        let side = self.field.resolution >> level;
        let index = self.field.level_offsets[level as usize] as usize
            + (self.probe as usize * side as usize + cell.y as usize) * side as usize
            + cell.x as usize;
        self.field.pyramid[index]
    }

    /// Whether the ray over `[ta, tb]` lies in front of a pyramid cell's bounding plane.
    #[inline]
    fn in_front_of(&self, plane: &Plane, ta: f32, tb: f32) -> bool {
        let base = plane.normal.dot(self.origin);
        let slope = plane.normal.dot(self.direction);
        base + ta * slope < plane.offset && base + tb * slope < plane.offset
    }

    /// The end of the part of `[ta, tb]` from `ta` on that lies in a pyramid cell's pass
    /// region (nearer than its minimum `lo`, or in front of its plane); `ta` if `ta` itself is
    /// outside it.
    fn pass_prefix(&mut self, lo: f32, plane: &Plane, ta: f32, tb: f32) -> f32 {
        let base = plane.normal.dot(self.origin);
        let slope = plane.normal.dot(self.direction);
        let mut t = ta;
        if base + ta * slope < plane.offset {
            t = if slope > 0.0 {
                (plane.offset - base) / slope
            } else {
                tb
            };
        }
        if self.radius(ta) < lo {
            // Where the radius grows back to `lo`: the larger root of |o + t·d| = lo.
            let b = self.origin.dot(self.direction);
            let q = self.origin.dot(self.origin) - lo * lo;
            t = t.max(-b + (b * b - q).max(0.0).sqrt());
        }
        t.min(tb)
    }

    /// The fine test of full-resolution `cell` over `[ta, tb]` (one fetch).
    ///
    /// In order: a ray wholly nearer than the texel's `near` bound passes in front; a ray
    /// entering farther than `far` is hidden (UNKNOWN); past `near`, a texel with a nearer
    /// edge cannot place the ray (UNKNOWN); otherwise the texel's plane decides: entering
    /// behind it by more than the thickness is hidden, staying in front passes, moving out of
    /// the thickness layer passes (a ray leaving the surface it starts on) if it lies within
    /// the thickness measured along the normal (deeper it is hidden), and crossing into it is
    /// a hit (unless the ray starts behind it: at its first texel a ray leaving a neighbouring
    /// face passes, later it is handed on, UNKNOWN), unless the surface faces away from the ray
    /// (back-face rejection, UNKNOWN) or the texel has a farther edge and the crossing does
    /// not lie among samples of its surface (`samples_showing`: it may lie beside the edge) or
    /// the texel is seen more obliquely than [`COS_AMONG_SAMPLES`] (UNKNOWN).
    /// See [`crate::packed::TexelBounds`].
    pub(crate) fn fine_test(&mut self, cell: UVec2, ta: f32, tb: f32) -> Outcome {
        let (outcome, kind) = self.fine_test_kind(cell, ta, tb);
        self.log.fetch(kind, 0, self.path_position);
        if self.relaxed && outcome.code == HIT && kind == FetchKind::FineUnknown {
            self.guessed_hidden = true;
        }
        outcome
    }

    /// [`Self::fine_test`] and which of its rules decided.
    fn fine_test_kind(&mut self, cell: UVec2, ta: f32, tb: f32) -> (Outcome, FetchKind) {
        self.fetches += 1;
        let n = self.field.resolution;
        let texel = self.field.geometry[padded_index(n, self.probe, cell.x, cell.y)];
        let farther_edge = texel[0] & SIGN_BIT != 0;
        let nearer_edge = texel[3] & SIGN_BIT != 0 && !self.relaxed;
        let distance = f32::from_bits(texel[0] & !SIGN_BIT);
        if distance >= self.params.sky_distance && !nearer_edge {
            return (Outcome::CONTINUE, FetchKind::FineNear);
        }
        let near = f32::from_bits(texel[2]);
        let far = f32::from_bits(texel[3] & !SIGN_BIT);
        let ra = self.radius(ta);
        let rb = self.radius(tb);
        if ra.max(rb) < near {
            return (Outcome::CONTINUE, FetchKind::FineNear);
        }
        // Where the strict test hands the ray on, the relaxed one guesses a hit.
        let hidden = if self.relaxed {
            Outcome::guess(ta, cell, texel[1])
        } else {
            Outcome::unknown(ta)
        };
        if (ra > far || nearer_edge) && !self.pass_hidden {
            return (hidden, FetchKind::FineUnknown);
        }
        let normal = unpack_normal(texel[1]);
        let center = probe_octa::decode(texel_center(n, cell.x, cell.y));
        let surface = texel_plane(n, center, distance, normal, self.params.thickness_scale);
        let nv = surface.visible_normal;
        let sa = (self.origin + self.direction * ta - center * distance).dot(nv);
        let k = self.direction.dot(nv);
        let sb = sa + (tb - ta) * k;
        if self.pass_hidden && (ra > far || (sa < -surface.thickness && ra >= near)) {
            // The far guess: behind what the probe saw the ray passes on, unless it comes
            // back through the stored surface inside the texel (from behind: it meets it).
            return if k > 0.0 && sb >= 0.0 {
                (
                    Outcome::guess((ta - sa / k).min(tb), cell, texel[1]),
                    FetchKind::FineHit,
                )
            } else {
                (Outcome::CONTINUE, FetchKind::FinePlane)
            };
        }
        if sa < -surface.thickness {
            // Behind the plane by more than the thickness where the ray enters the texel:
            // hidden, unless the entry lies nearer than the whole patch (the plane is only
            // trusted inside the texel's depth range).
            return if ra >= near {
                (hidden, FetchKind::FineUnknown)
            } else {
                (Outcome::CONTINUE, FetchKind::FinePlane)
            };
        }
        if sa >= 0.0 && sb >= 0.0 {
            return (Outcome::CONTINUE, FetchKind::FinePlane);
        }
        if !self.relaxed
            && k < 0.0
            && sa < 0.0
            && ta > self.t_min
            && sa - (ta - self.t_min) * k < 0.0
        {
            // Within the thickness behind the plane, moving deeper, and the ray's origin lies
            // behind it too: the ray has been behind this plane since it started (on a
            // neighbouring face at a convex edge, or under the surface the probe saw) and never
            // crossed it, so it cannot hit it; nor does the probe see where it is. Hand it on
            // (answered as a hit here, it was a hit a few centimetres after the ray left its
            // surface: BENCHMARKS.md, "Two probes that refuse the same crossing; rays that start
            // behind a plane").
            return (Outcome::unknown(ta), FetchKind::FineUnknown);
        }
        if k >= 0.0 || (sa < 0.0 && ta == self.t_min) {
            // Within the thickness behind the plane and moving out of it: the ray leaves the
            // surface it starts on. Or the ray starts behind this plane (on a neighbouring
            // face at a convex edge): it cannot hit the plane from behind. Either only if the
            // ray starts within the thickness along the normal: deeper, the ray is behind the
            // surface (on the far side of a wall), not on it, or (the strict test) comes from
            // behind a thin surface through it (its back face, which this probe does not see).
            let from = if self.relaxed {
                sa
            } else {
                sa - (ta - self.t_min) * k
            };
            if from < -surface.plane_thickness || (self.pass_hidden && sa < 0.0) {
                // (The far guess: not a ray leaving its start, but one coming back through
                // the surface from behind.)
                return (hidden, FetchKind::FineUnknown);
            }
            return (Outcome::CONTINUE, FetchKind::FineLeaving);
        }
        if !self.relaxed && self.params.back_face_rejection != 0 && self.direction.dot(normal) > 0.0
        {
            return (Outcome::unknown(ta), FetchKind::FineUnknown);
        }
        let t = if sa <= 0.0 { ta } else { (ta - sa / k).min(tb) };
        // A texel with a farther edge: the crossing may lie beside the edge, unless the texels
        // around it all show it (it lies among samples of the surface) and the texel is not
        // seen almost edge-on (its radiance then mixes whatever lies along the surface).
        // Refused, it is put to the next probes when most of the texels around it show it.
        if !self.relaxed && farther_edge {
            let point = self.origin + self.direction * t;
            let (among, shown) =
                super::samples_showing(self.field, self.probe, point, &mut self.fetches);
            if surface.cos_incidence < COS_AMONG_SAMPLES || !among {
                let crossing = ta - sa / k;
                if shown >= AGREEMENT_SHOWN_WEIGHT && crossing > self.t_min {
                    self.refused = Some(Refusal {
                        t: crossing,
                        tolerance: surface.plane_thickness,
                        cell,
                        normal: texel[1],
                    });
                }
                return (Outcome::unknown(ta), FetchKind::FineUnknown);
            }
        }
        (
            Outcome {
                code: HIT,
                t,
                cell,
                normal: texel[1],
            },
            FetchKind::FineHit,
        )
    }

    /// Marches one segment; HIT, UNKNOWN, or CONTINUE when the probe saw the ray pass in front
    /// of everything over the whole segment.
    pub(crate) fn march_segment(&mut self, seg: &Segment) -> Outcome {
        let n = self.field.resolution;
        let nf = n as f32;
        let c0 = ((seg.q0 + Vec2::ONE) * (0.5 * nf)).clamp(Vec2::ZERO, Vec2::splat(nf));
        let c1 = ((seg.q1 + Vec2::ONE) * (0.5 * nf)).clamp(Vec2::ZERO, Vec2::splat(nf));
        let delta = c1 - c0;
        let start = self.path_position;
        let outcome = if seg.l0 <= 0.0 || seg.l1 <= 0.0 || delta.dot(delta) < 1e-12 {
            // A single octahedral point (a ray through or from the probe centre).
            let cell = start_cell((c0 + c1) * 0.5, Vec2::ZERO, n);
            self.fine_test(cell, seg.t0, seg.t1)
        } else if self.params.method == METHOD_HIZ || self.params.coarse_level == 0 {
            let top = if self.params.method == METHOD_HIZ {
                self.params.top_level
            } else {
                0
            };
            self.march_hiz(seg, c0, delta, top)
        } else {
            self.march_two_level(seg, c0, delta, self.params.coarse_level)
        };
        if L::ENABLED && outcome.code == CONTINUE {
            self.path_position = start + delta.length();
        }
        outcome
    }

    /// Records where the march is (σ along a segment starting at `start` texels).
    #[inline]
    fn at(&mut self, start: f32, sigma: f32, delta: Vec2) {
        if L::ENABLED {
            self.path_position = start + sigma * delta.length();
        }
    }

    /// Hi-Z: up a level on entering a new parent cell after a cell is passed, down where the
    /// cell's bounds may hold the ray, skipping straight to where the ray leaves the cell's
    /// pass region on the way down.
    fn march_hiz(&mut self, seg: &Segment, c0: Vec2, delta: Vec2, top: u32) -> Outcome {
        let n = self.field.resolution;
        let start = self.path_position;
        // Start at the level the previous segment of this probe's trace ended at (0 for the
        // first): the ray crosses an octant boundary in free flight.
        let mut level = self.carry_level.min(top);
        let mut cursor = start_cell(c0, delta, n);
        let mut sigma = 0.0f32;
        let mut ta = seg.t0;
        for _ in 0..self.params.max_steps {
            let cell = cursor >> level;
            let (sx, sy) = exit_sigmas(cell, level, c0, delta);
            let exit = sx.min(sy).max(sigma);
            let tb = t_of(seg, exit.min(1.0));
            self.at(start, sigma, delta);
            if level > 0 {
                let [lo, hi, packed_normal, offset] = self.pyramid(level, cell);
                let (lo, hi) = (f32::from_bits(lo), f32::from_bits(hi));
                let ra = self.radius(ta);
                let rb = self.radius(tb);
                let plane = Plane::unpack(packed_normal, offset);
                if ra.max(rb) >= lo && !self.in_front_of(&plane, ta, tb) {
                    if ra > hi && !self.relaxed {
                        self.log
                            .fetch(FetchKind::PyramidUnknown, level, self.path_position);
                        return Outcome::unknown(ta);
                    }
                    self.log
                        .fetch(FetchKind::PyramidDescend, level, self.path_position);
                    // Every texel the ray crosses before it leaves the cell's pass region
                    // would pass its fine test: go on from the texel where it leaves.
                    let t_pass = self.pass_prefix(lo, &plane, ta, tb);
                    if t_pass > ta {
                        let skip = skip_to(seg, t_pass, cell, level, c0, delta, sigma, exit);
                        if let Some((target, entry)) = skip {
                            cursor = target;
                            sigma = entry;
                            ta = t_of(seg, sigma);
                            // The ray is about to reach a surface: go down faster.
                            if level > 2 {
                                level -= 1;
                            }
                        }
                    }
                    level -= 1;
                    continue;
                }
                self.log
                    .fetch(FetchKind::PyramidPass, level, self.path_position);
            } else {
                let outcome = self.fine_test(cursor, ta, tb);
                if outcome.code != CONTINUE {
                    return outcome;
                }
            }
            if exit >= 1.0 || !advance(&mut cursor, cell, level, (sx, sy), exit, c0, delta, n) {
                self.carry_level = level;
                return Outcome::CONTINUE;
            }
            sigma = exit;
            ta = tb;
            // Up a level when the cell entered starts a new parent cell along the line.
            let next = cursor >> level;
            if level < top && next >> 1 != cell >> 1 {
                level += 1;
            }
        }
        Outcome::unknown(ta)
    }

    /// Two-level (McGuire 2017): coarse DDA on the minimum level, fine march inside the coarse
    /// cells the ray may reach a surface in.
    fn march_two_level(&mut self, seg: &Segment, c0: Vec2, delta: Vec2, coarse: u32) -> Outcome {
        let n = self.field.resolution;
        let start = self.path_position;
        let mut cursor = start_cell(c0, delta, n);
        let mut sigma = 0.0f32;
        let mut ta = seg.t0;
        let mut steps = 0u32;
        'coarse: while steps < self.params.max_steps {
            steps += 1;
            let cell = cursor >> coarse;
            let (sx, sy) = exit_sigmas(cell, coarse, c0, delta);
            let exit = sx.min(sy).max(sigma);
            let tb = t_of(seg, exit.min(1.0));
            self.at(start, sigma, delta);
            let lo = f32::from_bits(self.pyramid(coarse, cell)[0]);
            if self.radius(ta).max(self.radius(tb)) >= lo {
                self.log
                    .fetch(FetchKind::PyramidDescend, coarse, self.path_position);
                // Fine march from the cursor to the coarse cell's exit.
                while steps < self.params.max_steps {
                    steps += 1;
                    let (fx, fy) = exit_sigmas(cursor, 0, c0, delta);
                    let fexit = fx.min(fy).max(sigma);
                    let ftb = t_of(seg, fexit.min(1.0));
                    self.at(start, sigma, delta);
                    let outcome = self.fine_test(cursor, ta, ftb);
                    if outcome.code != CONTINUE {
                        return outcome;
                    }
                    if fexit >= exit || fexit >= 1.0 {
                        break;
                    }
                    let fine = cursor;
                    if !advance(&mut cursor, fine, 0, (fx, fy), fexit, c0, delta, n) {
                        return Outcome::CONTINUE;
                    }
                    sigma = fexit;
                    ta = ftb;
                    if cursor >> coarse != cell {
                        continue 'coarse;
                    }
                }
            } else {
                self.log
                    .fetch(FetchKind::PyramidPass, coarse, self.path_position);
            }
            if exit >= 1.0 || !advance(&mut cursor, cell, coarse, (sx, sy), exit, c0, delta, n) {
                return Outcome::CONTINUE;
            }
            sigma = exit;
            ta = tb;
        }
        Outcome::unknown(ta)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The split agrees with `probe_octa::split_ray` (same pieces, same octahedral endpoints).
    #[test]
    fn split_matches_probe_octa() {
        let mut state = 12345u64;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 40) as f32 / (1u64 << 24) as f32) * 2.0 - 1.0
        };
        let mut out = [Segment::default(); 4];
        for _ in 0..2000 {
            let o = Vec3::new(next(), next(), next()) * 3.0;
            let d = Vec3::new(next(), next(), next()).normalize();
            let t1 = 0.5 + 5.0 * next().abs();
            let count = split_segments(o, d, 0.0, t1, &mut out);
            let reference = probe_octa::split_ray(Vec3::ZERO, o, d, 0.0, t1).unwrap();
            assert_eq!(count, reference.len());
            for (a, b) in out[..count].iter().zip(reference.iter()) {
                assert_eq!(a.t0, b.t_start);
                assert_eq!(a.t1, b.t_end);
                assert!(
                    a.q0.abs_diff_eq(b.octa_start, 1e-6),
                    "{} {}",
                    a.q0,
                    b.octa_start
                );
                assert!(
                    a.q1.abs_diff_eq(b.octa_end, 1e-6),
                    "{} {}",
                    a.q1,
                    b.octa_end
                );
            }
        }
    }

    /// `floor_small` is `floor` wherever the march uses it.
    #[test]
    fn floor_small_is_floor() {
        let mut state = 99u64;
        for i in 0..200_000u32 {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let x = ((state >> 40) as f32 / (1u64 << 24) as f32 - 0.5) * 2.0 * 4096.0;
            let integral = (i as f32 - 100_000.0) * 0.5;
            for c in [
                x,
                integral,
                -x.abs() / 1e6,
                0.0,
                -0.0,
                1.0 - f32::EPSILON / 2.0,
            ] {
                assert!(floor_small(c) == c.floor(), "{c}");
            }
        }
    }

    /// Points along a segment's 2-D line map back to the ray points that encode there.
    #[test]
    fn t_of_inverts_the_projection() {
        let o = Vec3::new(0.7, -0.3, 1.2);
        let d = Vec3::new(-0.2, 0.9, -0.4).normalize();
        let mut out = [Segment::default(); 4];
        let count = split_segments(o, d, 0.0, 6.0, &mut out);
        for seg in &out[..count] {
            for k in 0..=10 {
                let sigma = k as f32 / 10.0;
                let t = t_of(seg, sigma);
                let q = seg.q0 + (seg.q1 - seg.q0) * sigma;
                let p = o + d * t;
                // Compare directions: on the map's outer edge two points are one direction.
                let chord = (probe_octa::decode(q) - p.normalize()).length();
                assert!(chord < 1e-5 || p.length() < 1e-3, "σ={sigma}: {chord}");
            }
        }
    }
}
