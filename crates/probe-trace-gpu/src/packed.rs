//! Probe and selection data checked and flattened into the arrays both tracers read: the GPU
//! uploads them as storage buffers, the CPU twin reads the same numbers.

use bytemuck::{Pod, Zeroable};
use glam::{Vec2, Vec3};
use probe_index::{
    GridParams, NO_NEIGHBOUR, NO_PROBE, ProbeGrid, SVO_LEAF_BIT, SVO_PACKED_BIT, SvoHeader,
};
use probe_octa::OctaLayout;

use crate::error::UploadError;
use crate::input::{FieldOptions, Interpolation, IrradianceField, LightField, ProbeSelection};
use crate::pyramid::TexelRegion;
use crate::surface::{pack_normal, texel_center, texel_surface, unpack_normal};

/// Smallest and largest accepted light-field resolutions.
pub(crate) const MIN_RESOLUTION: u32 = 8;
pub(crate) const MAX_RESOLUTION: u32 = 4096;
/// Most pyramid levels stored (level 0 is the full-resolution map itself).
pub(crate) const MAX_LEVELS: usize = 16;

/// Selector codes shared with the WGSL.
pub(crate) const SELECT_GRID: u32 = 0;
pub(crate) const SELECT_SVO: u32 = 1;
pub(crate) const SELECT_VORONOI: u32 = 2;
/// Interpolation codes shared with the WGSL.
pub(crate) const INTERPOLATE_GRID: u32 = 0;
pub(crate) const INTERPOLATE_DELAUNAY: u32 = 1;

/// Words per uploaded tetrahedron (`probe_index::TetRecord`).
pub(crate) const TET_WORDS: usize = 20;

/// Padded texels of one probe's map.
#[inline]
pub(crate) fn padded_len(resolution: u32) -> usize {
    let side = resolution as usize + 2;
    side * side
}

/// Index of interior texel `(ix, iy)` of probe `probe` in a padded slice of such maps.
#[inline]
pub(crate) fn padded_index(resolution: u32, probe: u32, ix: u32, iy: u32) -> usize {
    let side = resolution as usize + 2;
    probe as usize * side * side + (iy as usize + 1) * side + ix as usize + 1
}

/// The light field in upload form.
#[derive(Clone, Debug)]
pub(crate) struct PackedField {
    pub resolution: u32,
    pub probe_count: u32,
    pub sky_distance: f32,
    pub thickness_scale: f32,
    /// Probe centres (w unused).
    pub positions: Vec<[f32; 4]>,
    /// Per padded texel: radial distance bits (sign bit set on edge texels), packed normal,
    /// near and far bound bits (see [`TexelBounds`]).
    pub geometry: Vec<[u32; 4]>,
    /// Pyramid levels `1..level_count`: per texel `(min near bits, max far bits, packed outward
    /// normal, plane offset bits)` ([`crate::pyramid`]), level `l` of probe `p` at
    /// `level_offsets[l] + p·(N >> l)²`, row-major.
    pub pyramid: Vec<[u32; 4]>,
    /// Start of each level in `pyramid` (level 0 unused).
    pub level_offsets: [u32; MAX_LEVELS],
    /// Levels including level 0: `log2(N) + 1`.
    pub level_count: u32,
    /// Radiance, 3 floats per padded texel: level 0 (the bake's maps), then the prefiltered
    /// glossy levels `1..=glossy_levels` (`probe_octa::glossy_pyramid`), level `k` of probe
    /// `p` at texel `glossy_offsets[k] + p·(N >> k + 2)²`, padded, row-major.
    pub radiance: Vec<f32>,
    /// Prefiltered glossy levels after level 0 (0: none).
    pub glossy_levels: u32,
    /// Start texel of each glossy level in `radiance` (level 0 unused).
    pub glossy_offsets: [u32; MAX_GLOSSY_LEVELS + 1],
    /// `LightField::geometry_bounds`, widened by [`BOUNDS_MARGIN`]: `(min, max)`.
    pub bounds: Option<(Vec3, Vec3)>,
    /// Start texel in `radiance` of the sky map ([`pack_sky_map`]): `N²` interior texels,
    /// row-major, unpadded.
    pub sky_map: u32,
}

/// How far the geometry bounds are widened on every side, relative to their diagonal (plus
/// a millimetre): a surface lying in the box's face is met before the box is left.
pub(crate) const BOUNDS_MARGIN: f32 = 1e-4;

/// Most prefiltered glossy levels a field holds (`FieldOptions::glossy_levels` is clamped).
pub(crate) const MAX_GLOSSY_LEVELS: usize = 7;

/// Glossy levels a field of resolution `n` gets for `requested` (at most `log2(n) − 1`, down
/// to 2×2, and [`MAX_GLOSSY_LEVELS`]).
pub(crate) fn glossy_level_count(n: u32, requested: u32) -> u32 {
    requested
        .min(n.trailing_zeros().saturating_sub(1))
        .min(MAX_GLOSSY_LEVELS as u32)
}

/// The sky map, appended to `radiance` (3 floats per texel; returns its start texel): per
/// interior direction texel of resolution `n`, the mean radiance of that texel over the
/// probes that saw nothing but sky there (sky at the centre, no nearer edge in `geometry`:
/// a texel at a silhouette holds part of the surface's radiance). The sky lies at infinity,
/// so every probe that sees it in a direction sees the same radiance: the map is what a MISS
/// reads where none of the probes it asks sees clear sky along the ray (a ray that left a
/// room through its open side at an angle at which every probe inside sees a wall or an
/// edge; before the map it read that wall). Texels no probe sees as clear sky take the mean
/// of their filled neighbours, ring by ring; zero if no probe sees any.
fn pack_sky_map(
    n: u32,
    probes: usize,
    geometry: &[[u32; 4]],
    source: &[Vec3],
    sky: f32,
    radiance: &mut Vec<f32>,
) -> u32 {
    let start = (radiance.len() / 3) as u32;
    let side = n as usize;
    let mut sum = vec![Vec3::ZERO; side * side];
    let mut filled = vec![false; side * side];
    let mut count = vec![0u32; side * side];
    for probe in 0..probes as u32 {
        for iy in 0..n {
            for ix in 0..n {
                let i = padded_index(n, probe, ix, iy);
                if record_is_clear_sky(geometry[i], sky) {
                    let cell = iy as usize * side + ix as usize;
                    sum[cell] += source[i];
                    count[cell] += 1;
                }
            }
        }
    }
    for cell in 0..side * side {
        if count[cell] > 0 {
            sum[cell] /= count[cell] as f32;
            filled[cell] = true;
        }
    }
    // Grow the filled texels into the empty ones, one ring at a time.
    if filled.iter().any(|&f| f) {
        while filled.iter().any(|&f| !f) {
            let (before, was) = (sum.clone(), filled.clone());
            for y in 0..side {
                for x in 0..side {
                    if was[y * side + x] {
                        continue;
                    }
                    let (mut total, mut k) = (Vec3::ZERO, 0u32);
                    for (dx, dy) in [(-1i64, 0i64), (1, 0), (0, -1), (0, 1)] {
                        let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                        if nx < 0 || ny < 0 || nx >= side as i64 || ny >= side as i64 {
                            continue;
                        }
                        let j = ny as usize * side + nx as usize;
                        if was[j] {
                            total += before[j];
                            k += 1;
                        }
                    }
                    if k > 0 {
                        sum[y * side + x] = total / k as f32;
                        filled[y * side + x] = true;
                    }
                }
            }
        }
    }
    radiance.extend(sum.iter().flat_map(|c| c.to_array()));
    start
}

/// Padded texels of the glossy levels `1..=levels` of one probe of resolution `n`.
pub(crate) fn glossy_texels_per_probe(n: u32, levels: u32) -> usize {
    (1..=levels).map(|k| padded_len(n >> k)).sum()
}

/// The prefiltered glossy levels of every probe, appended to `radiance` (3 floats per padded
/// texel, level-major, probes in order within a level), with each level's start texel.
fn pack_glossy(
    n: u32,
    probes: usize,
    levels: u32,
    source: &[Vec3],
    radiance: &mut Vec<f32>,
) -> [u32; MAX_GLOSSY_LEVELS + 1] {
    let mut offsets = [0u32; MAX_GLOSSY_LEVELS + 1];
    if levels == 0 {
        return offsets;
    }
    let per_probe = padded_len(n);
    let threads = std::thread::available_parallelism()
        .map_or(1, |t| t.get())
        .min(probes);
    let next_probe = std::sync::atomic::AtomicUsize::new(0);
    let mut pyramids: Vec<Vec<probe_octa::OctaMap<Vec3>>> = vec![Vec::new(); probes];
    let (sender, receiver) = std::sync::mpsc::channel();
    std::thread::scope(|scope| {
        for _ in 0..threads {
            let (sender, next_probe) = (sender.clone(), &next_probe);
            scope.spawn(move || {
                loop {
                    let probe = next_probe.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                    if probe >= probes {
                        break;
                    }
                    let texels = source[probe * per_probe..(probe + 1) * per_probe].to_vec();
                    let pyramid = probe_octa::OctaMap::from_padded(n, texels)
                        .ok()
                        .and_then(|map| probe_octa::glossy_pyramid(&map, levels).ok())
                        .unwrap_or_default();
                    if sender.send((probe, pyramid)).is_err() {
                        break;
                    }
                }
            });
        }
        drop(sender);
        for (probe, pyramid) in receiver {
            pyramids[probe] = pyramid;
        }
    });
    for (k, offset) in offsets
        .iter_mut()
        .enumerate()
        .take(levels as usize + 1)
        .skip(1)
    {
        *offset = (radiance.len() / 3) as u32;
        let side = padded_len(n >> k);
        for pyramid in &pyramids {
            match pyramid.get(k - 1) {
                Some(map) => radiance.extend(map.texels().iter().flat_map(|c| c.to_array())),
                // Not reached: the resolution is a checked power of two of at least 8.
                None => radiance.extend(std::iter::repeat_n(0.0, 3 * side)),
            }
        }
    }
    offsets
}

fn check_finite(parameter: &'static str, values: &[Vec3]) -> Result<(), UploadError> {
    match values.iter().position(|v| !v.is_finite()) {
        Some(index) => Err(UploadError::NonFinite { parameter, index }),
        None => Ok(()),
    }
}

fn check_length(
    parameter: &'static str,
    expected: usize,
    actual: usize,
) -> Result<(), UploadError> {
    if expected == actual {
        Ok(())
    } else {
        Err(UploadError::LengthMismatch {
            parameter,
            expected,
            actual,
        })
    }
}

/// Elements addressable by a `u32` index in WGSL.
fn check_addressable(
    buffer: &'static str,
    elements: u64,
    bytes_per_element: u64,
) -> Result<(), UploadError> {
    if elements > u64::from(u32::MAX) {
        Err(UploadError::TooLarge {
            buffer,
            bytes: elements * bytes_per_element,
            limit: u64::from(u32::MAX) * bytes_per_element,
        })
    } else {
        Ok(())
    }
}

/// Offsets of the 8 neighbours of a texel.
const NEIGHBOURS: [(i32, i32); 8] = [
    (-1, -1),
    (0, -1),
    (1, -1),
    (-1, 0),
    (1, 0),
    (-1, 1),
    (0, 1),
    (1, 1),
];

/// Surfaces met at a cosine below this (about 76°) are too oblique for a texel's plane to
/// place hits (seed 000 §4.2.1: a probe seeing a surface at a grazing angle is a poor
/// candidate); the texel is flagged like a farther edge.
pub(crate) const COS_TRUSTED: f32 = 0.25;

/// A crossing in a farther-edge texel is a hit when the texels around it all show it
/// (`cpu::samples_showing`), unless the texel is seen at a cosine below this (about 87°): such a
/// texel's cone runs along the surface and its radiance mixes whatever lies along it (on the
/// Cornell box, the ceiling light seen along the ceiling by a probe 1.4 cm below it, read as
/// the ceiling's corner 0.6 m away). Chosen by measurement against 0, 0.1 and
/// [`COS_TRUSTED`]: BENCHMARKS.md, "Crossings beside an edge".
pub(crate) const COS_AMONG_SAMPLES: f32 = 0.05;

/// A crossing refused beside a farther edge is put to the next probes (`cpu::march::Refusal`) when
/// the texels showing it hold at least this share of its bilinear weight (it lies nearer the
/// surface's samples than the edge); a second probe refusing a crossing at the same place
/// makes it a hit. Chosen by measurement against 0 (every refusal), 0.25, 0.5, 0.6 and 0.9:
/// BENCHMARKS.md, "Two probes that refuse the same crossing".
pub(crate) const AGREEMENT_SHOWN_WEIGHT: f32 = 0.75;

/// The sign bit of an `f32`, used as a flag on values that are never negative.
pub(crate) const SIGN_BIT: u32 = 0x8000_0000;

/// Whether a texel's geometry record ([`TexelBounds`]) saw sky at its centre: a radial
/// distance of at least `sky` (`gpu/trace.wgsl`'s `record_is_sky`).
pub(crate) fn record_is_sky(record: [u32; 4], sky: f32) -> bool {
    f32::from_bits(record[0] & !SIGN_BIT) >= sky
}

/// Whether a texel's geometry record saw nothing but sky: sky at its centre and no nearer
/// edge (no surface beside it, none among the baker's samples inside it). Only such a
/// texel's radiance is the sky's: one at a silhouette holds part of the surface's
/// (`gpu/trace.wgsl`'s `record_is_clear_sky`).
pub(crate) fn record_is_clear_sky(record: [u32; 4], sky: f32) -> bool {
    record_is_sky(record, sky) && record[3] & SIGN_BIT == 0
}

/// A grid's GPU parameters, after checking it holds the uploaded probes.
fn grid_params(grid: &ProbeGrid, probes: usize) -> Result<GridParams, UploadError> {
    if grid.probe_count() != probes {
        return Err(UploadError::ProbeCountMismatch {
            selection: "grid",
            expected: probes,
            actual: grid.probe_count(),
        });
    }
    Ok(grid.gpu_params())
}

/// Per-texel depth bounds and edge flags of one probe, computed at upload.
///
/// A texel's surface is the plane through its stored point with its stored normal
/// ([`crate::surface::texel_surface`]); `near` and `far` bound the depth of that patch
/// (thickness included). The surface is not continuous across a texel when a neighbour (of
/// the 8, across seams through the padding) sees sky where it does not, or when the two
/// surfaces are stacked: the neighbour's point lies farther than the texel's thickness from the
/// texel's plane, on the same side as the texel's point lies from the neighbour's plane (one
/// surface occludes the other; a crease or a curved surface puts each point on the other side
/// of the other's plane).
///
/// A texel with a **farther** neighbour shows an occluding edge: beyond it the cone holds the
/// background, so its plane alone is trusted only to say "in front" — a crossing of the plane
/// is reported as a hit only if every texel around the crossing's direction shows it too (it
/// lies among samples of the surface, not beside the edge); otherwise the ray is handed on.
/// Texels seen more obliquely than [`COS_TRUSTED`] are flagged the same way.
///
/// A sky texel with a surface neighbour (a silhouette against the sky) is always treated as
/// having a **nearer** edge, as below: otherwise a ray meeting the surface's rim inside the
/// sky texel's cone would be passed on to the sky as a miss.
///
/// With `FieldOptions::conservative_edges`, also: a texel with a **nearer** neighbour (a
/// foreground edge may intrude into its cone) gets that neighbour's `near` and leaves
/// undecided any ray that reaches it; farther-edge texels widen `far` to the neighbour's; and
/// all flags spread to the 8 neighbours of flagged texels (an edge can cut the corner of a
/// cone whose neighbours all sample one surface).
///
/// Upload layout per texel: distance bits with the sign bit set for a farther edge, packed
/// normal, `near` bits, `far` bits with the sign bit set for a nearer edge.
pub(crate) struct TexelBounds {
    resolution: u32,
    /// Interior, row-major.
    pub near: Vec<f32>,
    pub far: Vec<f32>,
    /// Padded, as uploaded.
    pub packed: Vec<[u32; 4]>,
}

impl TexelBounds {
    fn new(resolution: u32) -> Self {
        let n2 = (resolution * resolution) as usize;
        Self {
            resolution,
            near: vec![0.0; n2],
            far: vec![0.0; n2],
            packed: vec![[0; 4]; padded_len(resolution)],
        }
    }

    /// Fills the bounds of one probe from its padded distance and normal maps.
    #[allow(clippy::too_many_arguments)]
    fn compute(
        &mut self,
        layout: &OctaLayout,
        centers: &[Vec3],
        distance: &[f32],
        normals: &[Vec3],
        distance_range: Option<&[Vec2]>,
        sky: f32,
        thickness_scale: f32,
        conservative: bool,
    ) {
        let n = self.resolution;
        let n2 = (n * n) as usize;
        let mut surfaces = Vec::with_capacity(n2);
        let mut points = Vec::with_capacity(n2);
        let mut is_sky = Vec::with_capacity(n2);
        let mut packed_normals = Vec::with_capacity(n2);
        for iy in 0..n {
            for ix in 0..n {
                let i = (iy * n + ix) as usize;
                let p = layout.interior_index(ix, iy);
                let d = distance[p];
                let packed = pack_normal(normals[p].normalize_or_zero());
                let s = texel_surface(n, centers[i], d, unpack_normal(packed), thickness_scale);
                is_sky.push(d >= sky);
                points.push(centers[i] * d);
                packed_normals.push(packed);
                if d >= sky {
                    self.near[i] = sky;
                    self.far[i] = sky;
                } else {
                    self.near[i] = s.near;
                    self.far[i] = s.far;
                }
                surfaces.push(s);
            }
        }
        let (base_near, base_far) = (self.near.clone(), self.far.clone());
        let mut flags = vec![(false, false); n2];
        for iy in 0..n {
            for ix in 0..n {
                let i = (iy * n + ix) as usize;
                let d = distance[layout.interior_index(ix, iy)];
                let mut farther_edge = false;
                let mut nearer_edge = false;
                let mut near = base_near[i];
                let mut far = base_far[i];
                for (dx, dy) in NEIGHBOURS {
                    let (px, py) = ((ix as i32 + 1 + dx) as u32, (iy as i32 + 1 + dy) as u32);
                    let [sx, sy] = layout.border_source(px, py).unwrap_or([px, py]);
                    let u = ((sy - 1) * n + (sx - 1)) as usize;
                    let discontinuous = if is_sky[i] || is_sky[u] {
                        is_sky[i] != is_sky[u]
                    } else {
                        // Stacked surfaces: each point lies on the same side of the other's
                        // plane (an occlusion). A crease or a curved surface puts them on
                        // opposite sides; a plane puts them within the thickness.
                        let e = points[u] - points[i];
                        let a = e.dot(surfaces[i].visible_normal);
                        let b = e.dot(surfaces[u].visible_normal);
                        a.abs() > surfaces[i].thickness && a * b > 0.0
                    };
                    if discontinuous {
                        let du = distance[layout.interior_index(sx - 1, sy - 1)];
                        if du >= d {
                            farther_edge = true;
                            if conservative {
                                far = far.max(base_far[u]);
                            }
                        } else if conservative || is_sky[i] {
                            // A sky texel beside a surface (its silhouette against the sky)
                            // always: the surface may reach into its cone, and a ray crossing
                            // it there must not be passed on as a miss.
                            nearer_edge = true;
                            near = near.min(base_near[u]);
                        }
                    }
                }
                if !is_sky[i] && surfaces[i].cos_incidence < COS_TRUSTED {
                    // Seen too obliquely for its plane to place a hit.
                    farther_edge = true;
                }
                if let Some(range) = distance_range {
                    // What the baker saw inside the texel's cone: a nearer sample is geometry
                    // the centre's plane does not model (a thin or partly covering surface,
                    // an edge inside the texel), a farther one shows the plane ends inside it.
                    let [lo, hi] = range[layout.interior_index(ix, iy)].to_array();
                    let margin = if is_sky[i] {
                        0.0
                    } else {
                        surfaces[i].thickness
                    };
                    if lo < near.min(sky) - margin {
                        nearer_edge = true;
                        near = near.min(lo - margin);
                    }
                    if !is_sky[i] && hi > base_far[i] + margin {
                        farther_edge = true;
                    }
                }
                self.near[i] = near;
                self.far[i] = far;
                flags[i] = (farther_edge, nearer_edge);
            }
        }
        // Conservative edges: dilate by one texel.
        let (ring_near, ring_far) = (self.near.clone(), self.far.clone());
        for iy in 0..n {
            for ix in 0..n {
                let i = (iy * n + ix) as usize;
                let (mut farther_edge, mut nearer_edge) = flags[i];
                let (mut near, mut far) = (ring_near[i], ring_far[i]);
                for (dx, dy) in NEIGHBOURS {
                    let (px, py) = ((ix as i32 + 1 + dx) as u32, (iy as i32 + 1 + dy) as u32);
                    let [sx, sy] = layout.border_source(px, py).unwrap_or([px, py]);
                    let u = ((sy - 1) * n + (sx - 1)) as usize;
                    let (f, nr) = if conservative {
                        flags[u]
                    } else {
                        (false, false)
                    };
                    if f && !is_sky[i] {
                        farther_edge = true;
                        far = far.max(ring_far[u]);
                    }
                    if nr {
                        nearer_edge = true;
                        near = near.min(ring_near[u]);
                    }
                }
                self.near[i] = near;
                self.far[i] = far;
                let d = distance[layout.interior_index(ix, iy)];
                let flag = |value: f32, on: bool| value.to_bits() | if on { SIGN_BIT } else { 0 };
                self.packed[layout.interior_index(ix, iy)] = [
                    flag(d, farther_edge),
                    packed_normals[i],
                    near.to_bits(),
                    flag(far, nearer_edge),
                ];
            }
        }
        layout.pad(&mut self.packed).expect("sizes match");
    }
}

impl TexelBounds {
    /// The pass regions of the interior texels (row-major) with their `near` and `far`, for
    /// the pyramid ([`crate::pyramid`]): what [`crate::cpu::march`]'s fine test lets through.
    fn regions(
        &self,
        layout: &OctaLayout,
        centers: &[Vec3],
        sky: f32,
        thickness_scale: f32,
    ) -> Vec<(TexelRegion, f32, f32)> {
        let n = self.resolution;
        let mut out = Vec::with_capacity((n * n) as usize);
        for iy in 0..n {
            for ix in 0..n {
                let i = (iy * n + ix) as usize;
                let texel = self.packed[layout.interior_index(ix, iy)];
                let nearer_edge = texel[3] & SIGN_BIT != 0;
                let distance = f32::from_bits(texel[0] & !SIGN_BIT);
                let (near, far) = (self.near[i], self.far[i]);
                let region = if nearer_edge {
                    TexelRegion::Ball(near)
                } else if distance >= sky {
                    TexelRegion::Sky
                } else {
                    let surface = texel_surface(
                        n,
                        centers[i],
                        distance,
                        unpack_normal(texel[1]),
                        thickness_scale,
                    );
                    TexelRegion::Plane {
                        point: centers[i] * distance,
                        outward: -surface.visible_normal,
                        far,
                    }
                };
                out.push((region, near, far));
            }
        }
        out
    }
}

impl PackedField {
    /// Checks and packs a light field, building its pyramids.
    pub fn new(field: &LightField<'_>, options: &FieldOptions) -> Result<Self, UploadError> {
        let n = field.resolution;
        if !(MIN_RESOLUTION..=MAX_RESOLUTION).contains(&n) || !n.is_power_of_two() {
            return Err(UploadError::Resolution {
                parameter: "resolution",
                value: n,
                min: MIN_RESOLUTION,
                max: MAX_RESOLUTION,
            });
        }
        if !(field.sky_distance.is_finite() && field.sky_distance > 0.0) {
            return Err(UploadError::BadParameter {
                parameter: "sky_distance",
                value: field.sky_distance,
                requirement: "it must be finite and > 0",
            });
        }
        let thickness = options.thickness_scale;
        if !(thickness.is_finite() && thickness >= 0.0) {
            return Err(UploadError::BadParameter {
                parameter: "thickness_scale",
                value: thickness,
                requirement: "it must be finite and >= 0",
            });
        }
        let probes = field.positions.len();
        if probes == 0 {
            return Err(UploadError::NoProbes);
        }
        let bounds = match field.geometry_bounds {
            None => None,
            Some([lo, hi]) => {
                for (parameter, corner) in [("geometry_bounds[0]", lo), ("geometry_bounds[1]", hi)]
                {
                    if !corner.is_finite() {
                        return Err(UploadError::BadParameter {
                            parameter,
                            value: f32::NAN,
                            requirement: "its coordinates must be finite",
                        });
                    }
                }
                if lo.cmpgt(hi).any() {
                    return Err(UploadError::BadParameter {
                        parameter: "geometry_bounds",
                        value: (lo - hi).max_element(),
                        requirement: "its min corner must not exceed its max corner on any axis (the value is the largest excess)",
                    });
                }
                let margin = (hi - lo).length() * BOUNDS_MARGIN + 1e-3;
                Some((lo - margin, hi + margin))
            }
        };
        let per_probe = padded_len(n);
        check_addressable("radiance", probes as u64 * per_probe as u64 * 3, 4)?;
        let texels = probes * per_probe;
        check_length("radial_distance", texels, field.radial_distance.len())?;
        check_length("normals", texels, field.normals.len())?;
        check_length("radiance", texels, field.radiance.len())?;
        if let Some(range) = field.distance_range {
            check_length("distance_range", texels, range.len())?;
            for (index, r) in range.iter().enumerate() {
                if !r.is_finite() {
                    return Err(UploadError::NonFinite {
                        parameter: "distance_range",
                        index,
                    });
                }
                if r.x < 0.0 || r.x > r.y {
                    return Err(UploadError::BadParameter {
                        parameter: "distance_range",
                        value: r.x,
                        requirement: "each texel's range must be 0 <= nearest <= farthest",
                    });
                }
            }
        }
        check_finite("positions", field.positions)?;
        check_finite("normals", field.normals)?;
        check_finite("radiance", field.radiance)?;
        for (index, &d) in field.radial_distance.iter().enumerate() {
            if !d.is_finite() {
                return Err(UploadError::NonFinite {
                    parameter: "radial_distance",
                    index,
                });
            }
            if d < 0.0 {
                return Err(UploadError::NegativeDistance { index, value: d });
            }
        }

        let glossy_levels = glossy_level_count(n, options.glossy_levels);
        check_addressable(
            "radiance",
            (probes as u64 * (per_probe + glossy_texels_per_probe(n, glossy_levels)) as u64
                + u64::from(n) * u64::from(n))
                * 3,
            4,
        )?;
        let mut radiance: Vec<f32> = field.radiance.iter().flat_map(|c| c.to_array()).collect();
        let glossy_offsets = pack_glossy(n, probes, glossy_levels, field.radiance, &mut radiance);
        let sky = field.sky_distance;
        let layout = OctaLayout::new(n).expect("resolution checked");
        let centers: Vec<Vec3> = (0..n * n)
            .map(|i| probe_octa::decode(texel_center(n, i % n, i / n)))
            .collect();
        let mut geometry = vec![[0u32; 4]; texels];
        let level_count = n.trailing_zeros() + 1;
        let mut level_offsets = [0u32; MAX_LEVELS];
        let mut total = 0usize;
        for (level, offset) in level_offsets
            .iter_mut()
            .enumerate()
            .take(level_count as usize)
            .skip(1)
        {
            *offset = total as u32;
            let side = (n >> level) as usize;
            total += probes * side * side;
        }
        let mut pyramid = vec![[0u32; 4]; total];
        let corner_dirs: Vec<Vec3> = (0..(n + 1) * (n + 1))
            .map(|i| {
                let step = 2.0 / n as f32;
                let q = Vec2::new(
                    -1.0 + (i % (n + 1)) as f32 * step,
                    -1.0 + (i / (n + 1)) as f32 * step,
                );
                probe_octa::decode(q)
            })
            .collect();
        // Probes are independent: the threads take them one at a time and send their
        // records back to this thread, which writes them in place.
        let threads = std::thread::available_parallelism()
            .map_or(1, |t| t.get())
            .min(probes);
        let next_probe = std::sync::atomic::AtomicUsize::new(0);
        type ProbeRecords = (usize, Vec<[u32; 4]>, Vec<Vec<[u32; 4]>>);
        let (sender, receiver) = std::sync::mpsc::channel::<ProbeRecords>();
        std::thread::scope(|scope| {
            for _ in 0..threads {
                let sender = sender.clone();
                let (next_probe, layout, centers, corner_dirs) =
                    (&next_probe, &layout, &centers, &corner_dirs);
                scope.spawn(move || {
                    let mut texel_bounds = TexelBounds::new(n);
                    loop {
                        let probe = next_probe.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                        if probe >= probes {
                            break;
                        }
                        let range = probe * per_probe..(probe + 1) * per_probe;
                        texel_bounds.compute(
                            layout,
                            centers,
                            &field.radial_distance[range.clone()],
                            &field.normals[range.clone()],
                            field.distance_range.map(|r| &r[range.clone()]),
                            sky,
                            thickness,
                            options.conservative_edges,
                        );
                        let regions = texel_bounds.regions(layout, centers, sky, thickness);
                        let mut levels = vec![Vec::new(); level_count as usize];
                        crate::pyramid::build(
                            n,
                            level_count,
                            &regions,
                            corner_dirs,
                            |level, records| levels[level as usize] = records.to_vec(),
                        );
                        if sender
                            .send((probe, texel_bounds.packed.clone(), levels))
                            .is_err()
                        {
                            break;
                        }
                    }
                });
            }
            drop(sender);
            for (probe, packed, levels) in receiver {
                geometry[probe * per_probe..(probe + 1) * per_probe].copy_from_slice(&packed);
                for (level, records) in levels.iter().enumerate().skip(1) {
                    let side = (n >> level) as usize;
                    let start = level_offsets[level] as usize + probe * side * side;
                    pyramid[start..start + side * side].copy_from_slice(records);
                }
            }
        });
        let sky_map = pack_sky_map(n, probes, &geometry, field.radiance, sky, &mut radiance);
        Ok(Self {
            resolution: n,
            probe_count: probes as u32,
            sky_distance: sky,
            thickness_scale: thickness,
            positions: field
                .positions
                .iter()
                .map(|p| [p.x, p.y, p.z, 0.0])
                .collect(),
            geometry,
            pyramid,
            level_offsets,
            level_count,
            radiance,
            glossy_levels,
            glossy_offsets,
            bounds,
            sky_map,
        })
    }

    /// Probe centre.
    #[inline]
    pub fn position(&self, probe: u32) -> Vec3 {
        let p = self.positions[probe as usize];
        Vec3::new(p[0], p[1], p[2])
    }
}

/// Selection data in upload form: parameters plus one word array holding whichever of the
/// octree nodes and payloads, k-d tree nodes and neighbour table the selector needs.
#[derive(Clone, Debug)]
pub(crate) struct PackedSelection {
    pub kind: u32,
    pub grid: GridParams,
    pub svo: SvoHeader,
    pub words: Vec<u32>,
    pub svo_nodes: u32,
    pub svo_leaves: u32,
    pub svo_blocks: u32,
    pub kd_nodes: u32,
    pub kd_count: u32,
    pub neighbour_table: u32,
    pub neighbour_resolution: u32,
    /// Start of the nearest-probe table in `words`: per probe, itself and its
    /// [`NEAREST_ROW`]` − 1` nearest other probes, nearest first (rows padded with
    /// `NO_PROBE` when there are fewer probes).
    pub nearest_table: u32,
}

/// Entries per row of the nearest-probe table ([`PackedSelection::nearest_table`]).
pub(crate) const NEAREST_ROW: u32 = 16;

fn check_probe(selection: &'static str, probe: u32, probe_count: usize) -> Result<(), UploadError> {
    if probe != NO_PROBE && probe as usize >= probe_count {
        Err(UploadError::ProbeOutOfRange {
            selection,
            probe,
            probe_count,
        })
    } else {
        Ok(())
    }
}

/// Appends k-d tree nodes (position bits, probe) to `words`; returns their start.
fn push_kd_nodes(
    words: &mut Vec<u32>,
    nodes: &[probe_index::KdNode],
    selection: &'static str,
    probe_count: usize,
) -> Result<u32, UploadError> {
    let start = words.len() as u32;
    for node in nodes {
        check_probe(selection, node.probe, probe_count)?;
        words.extend(node.position.iter().map(|c| c.to_bits()));
        words.push(node.probe);
    }
    Ok(start)
}

impl PackedSelection {
    /// Checks a selection against the probes and packs it, with a k-d tree over `positions`
    /// (the nearest-probe extension of every selection; the Voronoi selection's own tree).
    pub fn new(selection: &ProbeSelection<'_>, positions: &[Vec3]) -> Result<Self, UploadError> {
        let probe_count = positions.len();
        let mut packed = PackedSelection {
            kind: SELECT_GRID,
            grid: GridParams::zeroed(),
            svo: SvoHeader::zeroed(),
            words: Vec::new(),
            svo_nodes: 0,
            svo_leaves: 0,
            svo_blocks: 0,
            kd_nodes: 0,
            kd_count: 0,
            neighbour_table: 0,
            neighbour_resolution: 0,
            nearest_table: 0,
        };
        match selection {
            ProbeSelection::Grid(grid) => {
                packed.kind = SELECT_GRID;
                packed.grid = grid_params(grid, probe_count)?;
            }
            ProbeSelection::SparseVoxelOctree(svo) => {
                packed.kind = SELECT_SVO;
                packed.svo = *svo.header();
                let nodes = svo.nodes();
                let leaves = svo.leaves();
                let blocks = svo.blocks();
                let bits = svo.header().packed_bits;
                let bad_node = |word: u32| -> bool {
                    if word & SVO_LEAF_BIT != 0 {
                        (word & !SVO_LEAF_BIT) as usize >= leaves.len()
                    } else if word & SVO_PACKED_BIT != 0 {
                        // A block of 8 payload indices of `bits` bits each.
                        if bits != 8 && bits != 16 {
                            return true;
                        }
                        let per = (32 / bits) as usize;
                        let first = (word & !SVO_PACKED_BIT) as usize * (8 / per);
                        let Some(block) = blocks.get(first..first + 8 / per) else {
                            return true;
                        };
                        (0..8).any(|c| {
                            let w = block[c / per];
                            let id =
                                (w >> (bits as usize * (c % per))) & ((1u64 << bits) - 1) as u32;
                            id as usize >= leaves.len()
                        })
                    } else {
                        word as usize + 8 > nodes.len()
                    }
                };
                if let Some(&word) = nodes.iter().find(|&&w| bad_node(w)) {
                    return Err(UploadError::ProbeCountMismatch {
                        selection: "sparse voxel octree (a node points past the tree)",
                        expected: nodes.len(),
                        actual: word as usize,
                    });
                }
                for leaf in leaves {
                    for &probe in leaf {
                        check_probe("sparse voxel octree", probe, probe_count)?;
                    }
                }
                check_addressable(
                    "selection",
                    nodes.len() as u64 + 4 * leaves.len() as u64 + blocks.len() as u64,
                    4,
                )?;
                packed.svo_nodes = 0;
                packed.words.extend_from_slice(nodes);
                packed.svo_leaves = packed.words.len() as u32;
                packed.words.extend(leaves.iter().flatten());
                packed.svo_blocks = packed.words.len() as u32;
                packed.words.extend_from_slice(blocks);
            }
            ProbeSelection::Voronoi {
                nearest,
                neighbours,
            } => {
                if neighbours.probe_count() != probe_count {
                    return Err(UploadError::ProbeCountMismatch {
                        selection: "Voronoi neighbour maps",
                        expected: probe_count,
                        actual: neighbours.probe_count(),
                    });
                }
                if nearest.nodes().len() != probe_count {
                    return Err(UploadError::ProbeCountMismatch {
                        selection: "nearest-probe tree",
                        expected: probe_count,
                        actual: nearest.nodes().len(),
                    });
                }
                for &probe in neighbours.table() {
                    check_probe("Voronoi neighbour maps", probe, probe_count)?;
                }
                check_addressable(
                    "selection",
                    4 * nearest.nodes().len() as u64 + neighbours.table().len() as u64,
                    4,
                )?;
                packed.kind = SELECT_VORONOI;
                packed.kd_nodes = push_kd_nodes(
                    &mut packed.words,
                    nearest.nodes(),
                    "nearest-probe tree",
                    probe_count,
                )?;
                packed.kd_count = nearest.nodes().len() as u32;
                packed.neighbour_table = packed.words.len() as u32;
                packed.neighbour_resolution = neighbours.resolution();
                packed.words.extend_from_slice(neighbours.table());
            }
        }
        if packed.kind != SELECT_VORONOI {
            // Every selection gets the nearest-probe tree, for candidates beyond its own.
            let nearest = probe_index::NearestProbe::new(positions);
            check_addressable(
                "selection",
                packed.words.len() as u64 + 4 * nearest.nodes().len() as u64,
                4,
            )?;
            packed.kd_nodes = push_kd_nodes(
                &mut packed.words,
                nearest.nodes(),
                "nearest-probe tree",
                probe_count,
            )?;
            packed.kd_count = nearest.nodes().len() as u32;
        }
        // The nearest-probe table: the candidates beyond the selection's own.
        check_addressable(
            "selection",
            packed.words.len() as u64 + u64::from(NEAREST_ROW) * probe_count as u64,
            4,
        )?;
        packed.nearest_table = packed.words.len() as u32;
        let tree = probe_index::NearestProbe::new(positions);
        let mut row = Vec::with_capacity(NEAREST_ROW as usize);
        for p in positions {
            tree.nearest_k(*p, NEAREST_ROW as usize, &mut row);
            packed.words.extend(row.iter().map(|&(probe, _)| probe));
            packed.words.extend(std::iter::repeat_n(
                NO_PROBE,
                NEAREST_ROW as usize - row.len(),
            ));
        }
        if packed.words.is_empty() {
            packed.words.push(0);
        }
        Ok(packed)
    }
}

/// Irradiance and moment maps plus interpolation data in upload form.
#[derive(Clone, Debug)]
pub(crate) struct PackedIrradiance {
    pub probe_count: u32,
    pub positions: Vec<[f32; 4]>,
    pub irradiance_resolution: u32,
    pub moments_resolution: u32,
    /// 3 floats per padded texel: the irradiance maps, then (with surfels) the surfels'
    /// irradiance at each probe ([`probe_octa::surfel_irradiance_map`]), laid out as if they
    /// were the maps of probes `probe_count ..`.
    pub irradiance: Vec<f32>,
    pub moments: Vec<[f32; 2]>,
    /// [`SURFEL_VEC4S`] vec4 per surfel, `surfels_per_probe` per probe (one zero vec4 when
    /// there are none).
    pub surfels: Vec<[f32; 4]>,
    pub surfels_per_probe: u32,
    pub kind: u32,
    pub grid: GridParams,
    /// Tetrahedra (20 words each; an open face's neighbour slot holds [`HULL_FACE`] and its
    /// hull triangle), then a tetrahedron per probe, then k-d tree nodes, then the convex
    /// hull's triangles ([`HULL_WORDS`] each).
    pub words: Vec<u32>,
    pub tets: u32,
    pub tet_count: u32,
    pub vertex_tets: u32,
    pub kd_nodes: u32,
    pub kd_count: u32,
    pub hull: u32,
    pub hull_count: u32,
}

/// Words per convex-hull triangle in [`PackedIrradiance::words`]: the corners `a, b, c` as
/// `vec4(position, bitcast<f32>(probe))`, then the outward plane `vec4(normal, offset)` with
/// `dot(normal, x) > offset` beyond the face, then the three hull triangles across its edges
/// (`adjacent[k]` shares the edge opposite corner `k`) and a padding word.
pub(crate) const HULL_WORDS: usize = 20;

/// Set in a packed tetrahedron's neighbour slot for an open face (a hull triangle): the low
/// bits are the index of that hull triangle, where the walk starts its search over the hull.
/// (`probe_index`'s records hold `NO_NEIGHBOUR` there.)
pub(crate) const HULL_FACE: u32 = 0x8000_0000;

/// Default cap on the moves of the descent over the hull (`DiffuseParams::max_hull_steps`).
pub(crate) const MAX_HULL_STEPS: u32 = 256;

/// Most hull triangles the descent turns through around one corner before it gives up (and
/// the scan answers). WGSL mirror `MAX_HULL_FAN` in `gpu/diffuse.wgsl`.
pub(crate) const MAX_HULL_FAN: u32 = 64;

/// Largest irradiance or moment map resolution accepted.
const MAX_LOW_RESOLUTION: u32 = 256;

/// vec4s per packed surfel: `(position, area)`, `(normal, sky solid angle)`, `(radiance, 0)`,
/// `(sky direction, 0)`, `(sky radiance, 0)`. WGSL mirror `SURFEL_VEC4S` in `gpu/diffuse.wgsl`.
pub(crate) const SURFEL_VEC4S: usize = 5;

/// A surfel in [`SURFEL_VEC4S`] vec4s, as `gpu/diffuse.wgsl` reads it.
fn pack_surfel(s: &probe_octa::Surfel) -> [[f32; 4]; SURFEL_VEC4S] {
    [
        s.position.extend(s.area).to_array(),
        s.normal.extend(s.sky_solid_angle).to_array(),
        s.radiance.extend(0.0).to_array(),
        s.sky_direction.extend(0.0).to_array(),
        s.sky_radiance.extend(0.0).to_array(),
    ]
}

/// The surfel [`pack_surfel`] packed into `v` (`SURFEL_VEC4S` vec4s).
pub(crate) fn unpack_surfel(v: &[[f32; 4]]) -> probe_octa::Surfel {
    let xyz = |k: usize| Vec3::from_slice(&v[k][..3]);
    probe_octa::Surfel {
        position: xyz(0),
        area: v[0][3],
        normal: xyz(1),
        sky_solid_angle: v[1][3],
        radiance: xyz(2),
        sky_direction: xyz(3),
        sky_radiance: xyz(4),
    }
}

/// Most surfels per probe accepted (a 64×64 surfel map).
const MAX_SURFELS_PER_PROBE: usize = 4096;

impl PackedIrradiance {
    /// Checks and packs irradiance data.
    pub fn new(
        field: &IrradianceField<'_>,
        interpolation: &Interpolation<'_>,
    ) -> Result<Self, UploadError> {
        let probes = field.positions.len();
        if probes == 0 {
            return Err(UploadError::NoProbes);
        }
        for (parameter, value) in [
            ("irradiance_resolution", field.irradiance_resolution),
            ("moments_resolution", field.moments_resolution),
        ] {
            if !(1..=MAX_LOW_RESOLUTION).contains(&value) {
                return Err(UploadError::Resolution {
                    parameter,
                    value,
                    min: 1,
                    max: MAX_LOW_RESOLUTION,
                });
            }
        }
        check_finite("positions", field.positions)?;
        check_length(
            "irradiance",
            probes * padded_len(field.irradiance_resolution),
            field.irradiance.len(),
        )?;
        check_length(
            "moments",
            probes * padded_len(field.moments_resolution),
            field.moments.len(),
        )?;
        check_finite("irradiance", field.irradiance)?;
        if let Some(index) = field.moments.iter().position(|m| !m.is_finite()) {
            return Err(UploadError::NonFinite {
                parameter: "moments",
                index,
            });
        }
        if !field.inside_geometry.is_empty() {
            check_length("inside_geometry", probes, field.inside_geometry.len())?;
        }
        let surfels_per_probe = field.surfels.len() / probes;
        if !field.surfels.is_empty() {
            if surfels_per_probe == 0 || surfels_per_probe * probes != field.surfels.len() {
                return Err(UploadError::LengthMismatch {
                    parameter: "surfels",
                    expected: probes * surfels_per_probe.max(1),
                    actual: field.surfels.len(),
                });
            }
            if surfels_per_probe > MAX_SURFELS_PER_PROBE {
                return Err(UploadError::BadParameter {
                    parameter: "surfels per probe",
                    value: surfels_per_probe as f32,
                    requirement: "at most 4096 per probe (a 64×64 surfel map)",
                });
            }
            // Every number the GPU reads is in the packed form.
            let bad = field
                .surfels
                .iter()
                .position(|s| !pack_surfel(s).as_flattened().iter().all(|v| v.is_finite()));
            if let Some(index) = bad {
                return Err(UploadError::NonFinite {
                    parameter: "surfels",
                    index,
                });
            }
        }
        let mut packed = PackedIrradiance {
            probe_count: probes as u32,
            // w = 1 marks a probe left out of every blend (inside geometry).
            positions: field
                .positions
                .iter()
                .enumerate()
                .map(|(i, p)| {
                    let inside = field.inside_geometry.get(i).copied().unwrap_or(false);
                    [p.x, p.y, p.z, f32::from(u8::from(inside))]
                })
                .collect(),
            irradiance_resolution: field.irradiance_resolution,
            moments_resolution: field.moments_resolution,
            irradiance: field.irradiance.iter().flat_map(|c| c.to_array()).collect(),
            moments: field.moments.iter().map(|m| m.to_array()).collect(),
            surfels: vec![[0.0; 4]],
            surfels_per_probe: 0,
            kind: INTERPOLATE_GRID,
            grid: GridParams::zeroed(),
            words: Vec::new(),
            tets: 0,
            tet_count: 0,
            vertex_tets: 0,
            kd_nodes: 0,
            kd_count: 0,
            hull: 0,
            hull_count: 0,
        };
        if !field.surfels.is_empty() {
            packed.pack_surfels(field, surfels_per_probe)?;
        }
        match interpolation {
            Interpolation::Grid(grid) => {
                packed.grid = grid_params(grid, probes)?;
            }
            Interpolation::Delaunay(tets) => {
                if tets.points().len() != probes {
                    return Err(UploadError::ProbeCountMismatch {
                        selection: "tetrahedralization",
                        expected: probes,
                        actual: tets.points().len(),
                    });
                }
                let records = tets.tetrahedra();
                check_addressable(
                    "interpolation",
                    (records.len() * TET_WORDS + 5 * probes) as u64,
                    4,
                )?;
                packed.kind = INTERPOLATE_DELAUNAY;
                packed.tets = 0;
                packed.tet_count = records.len() as u32;
                for record in records {
                    for &v in &record.vertices {
                        check_probe("tetrahedralization", v, probes)?;
                    }
                    packed
                        .words
                        .extend_from_slice(bytemuck::cast_slice(std::slice::from_ref(record)));
                }
                packed.vertex_tets = packed.words.len() as u32;
                packed
                    .words
                    .extend((0..probes).map(|i| tets.tetrahedron_of_vertex(i)));
                let nearest = probe_index::NearestProbe::new(field.positions);
                packed.kd_nodes = push_kd_nodes(
                    &mut packed.words,
                    nearest.nodes(),
                    "nearest-probe tree",
                    probes,
                )?;
                packed.kd_count = nearest.nodes().len() as u32;
                let hull = tets.hull_faces();
                check_addressable(
                    "interpolation",
                    (packed.words.len() + hull.len() * HULL_WORDS) as u64,
                    4,
                )?;
                packed.hull = packed.words.len() as u32;
                packed.hull_count = hull.len() as u32;
                for (h, face) in hull.iter().enumerate() {
                    let bad = |reason| UploadError::BadHull {
                        hull_face: h,
                        reason,
                    };
                    if face.adjacent.iter().any(|&n| n as usize >= hull.len()) {
                        return Err(bad("a neighbouring hull triangle does not exist"));
                    }
                    if face.tetrahedron as usize >= records.len() || face.face >= 4 {
                        return Err(bad("its tetrahedron or face does not exist"));
                    }
                    // The open face's neighbour slot names this hull triangle (the walk starts
                    // its search over the hull there).
                    let slot = packed.tets as usize
                        + face.tetrahedron as usize * TET_WORDS
                        + 4
                        + face.face as usize;
                    if packed.words[slot] != NO_NEIGHBOUR {
                        return Err(bad("its tetrahedron's face is not open"));
                    }
                    packed.words[slot] = HULL_FACE | h as u32;
                    for &v in &face.vertices {
                        if v as usize >= probes {
                            return Err(UploadError::ProbeOutOfRange {
                                selection: "tetrahedralization",
                                probe: v,
                                probe_count: probes,
                            });
                        }
                    }
                    let corners = face.vertices.map(|v| field.positions[v as usize]);
                    for (&v, c) in face.vertices.iter().zip(&corners) {
                        packed
                            .words
                            .extend([c.x.to_bits(), c.y.to_bits(), c.z.to_bits(), v]);
                    }
                    // Counter-clockwise seen from outside: the normal points out.
                    let normal = (corners[1] - corners[0])
                        .cross(corners[2] - corners[0])
                        .normalize_or_zero();
                    let offset = normal.dot(corners[0]);
                    packed
                        .words
                        .extend([normal.x, normal.y, normal.z, offset].map(f32::to_bits));
                    packed.words.extend(face.adjacent);
                    packed.words.push(0);
                }
                // Every open face must have been given its hull triangle.
                for t in 0..records.len() {
                    let at = packed.tets as usize + t * TET_WORDS + 4;
                    if packed.words[at..at + 4].contains(&NO_NEIGHBOUR) {
                        return Err(UploadError::BadHull {
                            hull_face: t,
                            reason: "an open face of this tetrahedron has no hull triangle",
                        });
                    }
                }
            }
        }
        if packed.words.is_empty() {
            packed.words.push(0);
        }
        Ok(packed)
    }
}

impl PackedIrradiance {
    /// Packs `field`'s surfels (`per_probe` per probe, checked by [`Self::new`]) and appends
    /// each probe's surfel irradiance map (at the irradiance maps' resolution) after the
    /// irradiance maps.
    fn pack_surfels(
        &mut self,
        field: &IrradianceField<'_>,
        per_probe: usize,
    ) -> Result<(), UploadError> {
        self.surfels_per_probe = per_probe as u32;
        self.surfels = field.surfels.iter().flat_map(pack_surfel).collect();
        for (p, position) in field.positions.iter().enumerate() {
            let map = probe_octa::surfel_irradiance_map(
                &field.surfels[p * per_probe..(p + 1) * per_probe],
                *position,
                field.irradiance_resolution,
            )
            .map_err(|_| UploadError::Resolution {
                parameter: "irradiance_resolution",
                value: field.irradiance_resolution,
                min: 1,
                max: MAX_LOW_RESOLUTION,
            })?;
            self.irradiance
                .extend(map.texels().iter().flat_map(|c| c.to_array()));
        }
        check_addressable("irradiance", self.irradiance.len() as u64, 4)?;
        Ok(())
    }
}

/// The trace pass's uniform block (352 bytes). WGSL mirror `TraceParams` in `gpu/common.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub(crate) struct TraceParams {
    pub resolution: u32,
    pub probe_count: u32,
    pub ray_count: u32,
    pub threads_per_row: u32,
    pub method: u32,
    pub top_level: u32,
    pub coarse_level: u32,
    pub max_probes: u32,
    pub selector: u32,
    pub back_face_rejection: u32,
    pub level_count: u32,
    pub max_steps: u32,
    pub sky_distance: f32,
    pub thickness_scale: f32,
    pub nearest_candidates: u32,
    pub nearest_table: u32,
    pub level_offsets: [[u32; 4]; 4],
    pub grid: GridParams,
    pub svo: SvoHeader,
    pub svo_nodes: u32,
    pub svo_leaves: u32,
    pub svo_blocks: u32,
    pub kd_nodes: u32,
    pub kd_count: u32,
    pub neighbour_table: u32,
    pub neighbour_resolution: u32,
    /// Prefiltered glossy levels read (0: mirror rays, level 0 only).
    pub glossy_levels: u32,
    /// `tan` of the rays' cone angle (`probe_octa::ggx_lobe_angle` of their roughness),
    /// the angle capped at [`MAX_CONE_ANGLE`].
    pub glossy_tan: f32,
    /// The rays' cone angle (radians).
    pub glossy_angle: f32,
    /// `probe_octa::texel_angle(N)`: the cone angle level 0 matches.
    pub glossy_base_angle: f32,
    /// Probes a filtered glossy answer blends (`TraceOptions::glossy_blend`; 0: the
    /// answering probe alone).
    pub glossy_blend: u32,
    /// Start texel of each glossy level in the radiance buffer (entry 0 unused).
    pub glossy_offsets: [[u32; 4]; 2],
    /// The geometry bounds' min corner, `w` 1 when there are bounds (0: none).
    pub bounds_min: [f32; 4],
    /// The geometry bounds' max corner.
    pub bounds_max: [f32; 4],
    /// Start texel of the sky map in the radiance buffer ([`PackedField::sky_map`]).
    pub sky_map: u32,
    /// [`GLOSSY_WIDE_TAN`]: a filtered hit whose cone footprint, seen from a blended probe,
    /// is wider than this `tan` is read by that probe if it sees the hit or the ray's origin.
    pub glossy_wide_tan: f32,
    /// `TraceOptions::agreement`: two probes that refuse the same crossing make it a hit.
    pub agreement: u32,
    pub pad2: u32,
}

/// The diffuse pass's uniform block (128 bytes). WGSL mirror `DiffuseParams` in
/// `gpu/diffuse.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub(crate) struct DiffuseParams {
    pub point_count: u32,
    pub threads_per_row: u32,
    pub probe_count: u32,
    pub interpolation: u32,
    pub irradiance_resolution: u32,
    pub moments_resolution: u32,
    pub visibility: u32,
    pub max_walk_steps: u32,
    pub normal_bias: f32,
    pub hull: u32,
    pub hull_count: u32,
    pub visibility_exponent: f32,
    pub grid: GridParams,
    pub tets: u32,
    pub tet_count: u32,
    pub vertex_tets: u32,
    pub kd_nodes: u32,
    pub kd_count: u32,
    pub min_weight: f32,
    pub backface: u32,
    /// Most moves of the descent over the hull before it falls back to the scan of every hull
    /// triangle (0: always scan).
    pub max_hull_steps: u32,
    /// Whether each probe's irradiance is corrected by its surfels
    /// (`DiffuseOptions::parallax`, and surfels uploaded).
    pub parallax: u32,
    pub surfels_per_probe: u32,
    pub pad: [u32; 2],
}

/// Method codes shared with the WGSL.
pub(crate) const METHOD_HIZ: u32 = 0;
pub(crate) const METHOD_TWO_LEVEL: u32 = 1;

/// Most single-probe traces per ray an option may ask for.
pub(crate) const MAX_PROBES_PER_RAY: u32 = 64;

/// Most nearest probes a restart point's candidate list may be extended by
/// (`TraceOptions::nearest_candidates`).
pub(crate) const MAX_NEAREST_CANDIDATES: u32 = 16;

/// Most probes a filtered glossy answer may blend (`TraceOptions::glossy_blend`).
pub(crate) const MAX_GLOSSY_BLEND: u32 = 8;

/// Checks trace options and turns them into the uniform block both tracers read.
pub(crate) fn trace_params(
    field: &PackedField,
    selection: &PackedSelection,
    options: &crate::ray::TraceOptions,
) -> Result<TraceParams, crate::error::TraceError> {
    use crate::error::TraceError;
    use crate::ray::TraceMethod;
    if !(1..=MAX_PROBES_PER_RAY).contains(&options.max_probes) {
        return Err(TraceError::BadOption {
            option: "max_probes",
            value: f64::from(options.max_probes),
            requirement: "it must be from 1 to 64",
        });
    }
    if options.nearest_candidates > MAX_NEAREST_CANDIDATES {
        return Err(TraceError::BadOption {
            option: "nearest_candidates",
            value: f64::from(options.nearest_candidates),
            requirement: "it must be from 0 to 16",
        });
    }
    if options.coarse_downsample == 0 || !options.coarse_downsample.is_power_of_two() {
        return Err(TraceError::BadOption {
            option: "coarse_downsample",
            value: f64::from(options.coarse_downsample),
            requirement: "it must be a power of two (1 disables the coarse level)",
        });
    }
    let roughness = options.glossy_roughness;
    if !(0.0..=1.0).contains(&roughness) {
        return Err(TraceError::BadOption {
            option: "glossy_roughness",
            value: f64::from(roughness),
            requirement: "it must be from 0 (mirror rays) to 1",
        });
    }
    if roughness > 0.0 && field.glossy_levels == 0 {
        return Err(TraceError::BadOption {
            option: "glossy_roughness",
            value: f64::from(roughness),
            requirement: "a cone needs prefiltered levels: upload with FieldOptions::glossy_levels > 0, or trace with 0",
        });
    }
    if options.glossy_blend > MAX_GLOSSY_BLEND {
        return Err(TraceError::BadOption {
            option: "glossy_blend",
            value: f64::from(options.glossy_blend),
            requirement: "it must be from 0 (the answering probe alone) to 8",
        });
    }
    let glossy_angle = probe_octa::ggx_lobe_angle(roughness * roughness);
    let mut glossy_offsets = [[0u32; 4]; 2];
    for (i, &offset) in field.glossy_offsets.iter().enumerate() {
        glossy_offsets[i / 4][i % 4] = offset;
    }
    let top = field.level_count - 1;
    let mut level_offsets = [[0u32; 4]; 4];
    for (i, &offset) in field.level_offsets.iter().enumerate() {
        level_offsets[i / 4][i % 4] = offset;
    }
    let (bounds_min, bounds_max) = match field.bounds {
        Some((lo, hi)) => ([lo.x, lo.y, lo.z, 1.0], [hi.x, hi.y, hi.z, 0.0]),
        None => ([0.0; 4], [0.0; 4]),
    };
    Ok(TraceParams {
        resolution: field.resolution,
        probe_count: field.probe_count,
        ray_count: 0,
        threads_per_row: 0,
        method: match options.method {
            TraceMethod::HiZ => METHOD_HIZ,
            TraceMethod::TwoLevel => METHOD_TWO_LEVEL,
        },
        top_level: options.hiz_top_level.min(top),
        coarse_level: options.coarse_downsample.trailing_zeros().min(top),
        max_probes: options.max_probes,
        selector: selection.kind,
        back_face_rejection: u32::from(options.back_face_rejection),
        level_count: field.level_count,
        // Cells a segment can visit: at most 2N at full resolution, and per full-resolution
        // cell at most two visits per level on the way up and down.
        max_steps: 4 * field.resolution * field.level_count + 64,
        sky_distance: field.sky_distance,
        thickness_scale: field.thickness_scale,
        nearest_candidates: options.nearest_candidates,
        nearest_table: selection.nearest_table,
        level_offsets,
        grid: selection.grid,
        svo: selection.svo,
        svo_nodes: selection.svo_nodes,
        svo_leaves: selection.svo_leaves,
        svo_blocks: selection.svo_blocks,
        kd_nodes: selection.kd_nodes,
        kd_count: selection.kd_count,
        neighbour_table: selection.neighbour_table,
        neighbour_resolution: selection.neighbour_resolution,
        glossy_levels: if roughness > 0.0 {
            field.glossy_levels
        } else {
            0
        },
        // The cone's angle reaches 90° at roughness 1 (`2·atan(1)`), where f32 rounding lands
        // just past π/2 and `tan` is −2.3e7: every hit then read level 0, the sharp read, as
        // if the surface were a mirror. Capped just below 90°, the footprint `t·tan φ` of a
        // hit more than a few millimetres away spans what the probe sees, and the read is
        // the top level, as a lobe that wide asks.
        glossy_tan: glossy_angle.min(MAX_CONE_ANGLE).tan(),
        glossy_angle,
        glossy_base_angle: probe_octa::texel_angle(field.resolution),
        glossy_blend: options.glossy_blend,
        glossy_offsets,
        bounds_min,
        bounds_max,
        sky_map: field.sky_map,
        glossy_wide_tan: GLOSSY_WIDE_TAN,
        agreement: u32::from(options.agreement),
        pad2: 0,
    })
}

/// When a filtered glossy hit's cone footprint counts as wide for a probe of the blend
/// (`TraceOptions::glossy_blend`): `t·tan φ ≥ r·GLOSSY_WIDE_TAN`, the footprint (radius
/// `t·tan φ` at hit distance `t`, cone angle `φ`) seen from the probe `r` away wider than 45°.
/// Such a probe reads the blurred region around the hit whether or not it sees the hit point
/// itself, so it joins the blend if it sees the hit or the ray's origin, at its distance
/// weight alone; a narrow footprint still needs the hit seen, weighted by the cosine it is
/// seen at. Before, at roughness 1 (every material of Sponza and the Cornell box) a hit that
/// none of the shading point's probes saw was read by one probe near the hit alone, whose
/// wide read often looked away into the dark: single black pixels on Sponza's drapes
/// (BENCHMARKS.md, "Wide footprints"). 0.4 to 2 gave the same images there.
pub const GLOSSY_WIDE_TAN: f32 = 1.0;

/// The widest cone (radians, from the axis) a filtered trace reads
/// ([`crate::TraceOptions::glossy_roughness`]): just below 90°, which roughness 1 reaches. At
/// 90° itself f32's `tan` is not a number (−2.3e7), which once sent every roughness-1 hit to
/// the sharp level.
pub const MAX_CONE_ANGLE: f32 = std::f32::consts::FRAC_PI_2 - 1e-3;

/// Checks rays and normalises their directions.
pub(crate) fn prepare_rays(
    rays: &[crate::ray::TraceRay],
) -> Result<Vec<crate::ray::TraceRay>, crate::error::TraceError> {
    use crate::error::TraceError;
    let bad = |index, reason| TraceError::BadInput {
        item: "ray",
        index,
        reason,
    };
    rays.iter()
        .enumerate()
        .map(|(index, ray)| {
            let origin = Vec3::from(ray.origin);
            let direction = Vec3::from(ray.direction);
            if !origin.is_finite() {
                return Err(bad(index, "the origin is not finite"));
            }
            if !direction.is_finite() {
                return Err(bad(index, "the direction is not finite"));
            }
            let unit = direction.normalize_or_zero();
            if unit == Vec3::ZERO {
                return Err(bad(index, "the direction is zero"));
            }
            if !(ray.t_min >= 0.0 && ray.t_min.is_finite() && ray.t_max >= ray.t_min) {
                return Err(bad(
                    index,
                    "the range is not 0 <= t_min <= t_max with t_min finite",
                ));
            }
            Ok(crate::ray::TraceRay {
                direction: unit.to_array(),
                ..*ray
            })
        })
        .collect()
}

/// Checks surface queries (finite, a unit direction, a known surface flag) and normalises
/// their directions.
pub(crate) fn prepare_queries(
    queries: &[crate::ray::SurfaceQuery],
) -> Result<Vec<crate::ray::SurfaceQuery>, crate::error::TraceError> {
    use crate::error::TraceError;
    let bad = |index, reason| TraceError::BadInput {
        item: "surface query",
        index,
        reason,
    };
    queries
        .iter()
        .enumerate()
        .map(|(index, q)| {
            if !Vec3::from(q.position).is_finite() {
                return Err(bad(index, "the position is not finite"));
            }
            let direction = Vec3::from(q.direction);
            if !direction.is_finite() {
                return Err(bad(index, "the direction is not finite"));
            }
            let unit = direction.normalize_or_zero();
            if unit == Vec3::ZERO {
                return Err(bad(index, "the direction is zero"));
            }
            if q.surface > 1 {
                return Err(bad(
                    index,
                    "`surface` must be 1 (a surface point) or 0 (an escaped ray)",
                ));
            }
            Ok(crate::ray::SurfaceQuery {
                direction: unit.to_array(),
                ..*q
            })
        })
        .collect()
}

/// Checks shading points and normalises their normals.
pub(crate) fn prepare_points(
    points: &[crate::ray::ShadingPoint],
) -> Result<Vec<crate::ray::ShadingPoint>, crate::error::TraceError> {
    use crate::error::TraceError;
    points
        .iter()
        .enumerate()
        .map(|(index, point)| {
            let position = Vec3::from(point.position);
            let normal = Vec3::from(point.normal);
            let unit = normal.normalize_or_zero();
            if !position.is_finite() || !normal.is_finite() || unit == Vec3::ZERO {
                return Err(TraceError::BadInput {
                    item: "shading point",
                    index,
                    reason: "the position must be finite and the normal finite and non-zero",
                });
            }
            Ok(crate::ray::ShadingPoint::new(position, unit))
        })
        .collect()
}

/// Checks diffuse options and turns them into the uniform block both shaders read.
pub(crate) fn diffuse_params(
    irradiance: &PackedIrradiance,
    options: &crate::ray::DiffuseOptions,
) -> Result<DiffuseParams, crate::error::TraceError> {
    if !(options.normal_bias.is_finite() && options.normal_bias >= 0.0) {
        return Err(crate::error::TraceError::BadOption {
            option: "normal_bias",
            value: f64::from(options.normal_bias),
            requirement: "it must be finite and >= 0",
        });
    }
    if !(options.visibility_exponent.is_finite()
        && (0.0..=16.0).contains(&options.visibility_exponent))
    {
        return Err(crate::error::TraceError::BadOption {
            option: "visibility_exponent",
            value: f64::from(options.visibility_exponent),
            requirement: "it must be from 0 to 16",
        });
    }
    if !(options.min_weight.is_finite() && options.min_weight > 0.0 && options.min_weight <= 1.0) {
        return Err(crate::error::TraceError::BadOption {
            option: "min_weight",
            value: f64::from(options.min_weight),
            requirement: "it must be above 0 and at most 1",
        });
    }
    Ok(DiffuseParams {
        point_count: 0,
        threads_per_row: 0,
        probe_count: irradiance.probe_count,
        interpolation: irradiance.kind,
        irradiance_resolution: irradiance.irradiance_resolution,
        moments_resolution: irradiance.moments_resolution,
        visibility: u32::from(options.visibility),
        // The walk starts in a tetrahedron of the nearest probe, so it is short; the cap only
        // guards against cycling on degenerate (cospherical) configurations.
        max_walk_steps: 1024,
        normal_bias: options.normal_bias,
        hull: irradiance.hull,
        hull_count: irradiance.hull_count,
        visibility_exponent: options.visibility_exponent,
        grid: irradiance.grid,
        tets: irradiance.tets,
        tet_count: irradiance.tet_count,
        vertex_tets: irradiance.vertex_tets,
        kd_nodes: irradiance.kd_nodes,
        kd_count: irradiance.kd_count,
        min_weight: options.min_weight,
        backface: u32::from(options.backface),
        // A descent crosses the hull at most once; the cap only guards against cycling where
        // f32 rounding breaks the strict decrease (then the scan answers).
        max_hull_steps: MAX_HULL_STEPS,
        parallax: u32::from(options.parallax && irradiance.surfels_per_probe > 0),
        surfels_per_probe: irradiance.surfels_per_probe,
        pad: [0; 2],
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Distance and inward normal of the box room `[lo, hi]` seen from `p` along `d`.
    fn box_room(p: Vec3, d: Vec3, lo: Vec3, hi: Vec3) -> (f32, Vec3) {
        let mut best = (f32::INFINITY, Vec3::ZERO);
        for axis in 0..3 {
            if d[axis] > 0.0 {
                let t = (hi[axis] - p[axis]) / d[axis];
                if t < best.0 {
                    let mut n = Vec3::ZERO;
                    n[axis] = -1.0;
                    best = (t, n);
                }
            } else if d[axis] < 0.0 {
                let t = (lo[axis] - p[axis]) / d[axis];
                if t < best.0 {
                    let mut n = Vec3::ZERO;
                    n[axis] = 1.0;
                    best = (t, n);
                }
            }
        }
        best
    }

    /// Flag counts (farther, nearer) of one probe in a box room.
    fn flags_in_room(p: Vec3, n: u32) -> (usize, usize, usize) {
        flags_in_room_sampled(p, n, false)
    }

    /// [`flags_in_room`], optionally with the distance range of 3×3 rays across each texel.
    fn flags_in_room_sampled(p: Vec3, n: u32, sampled: bool) -> (usize, usize, usize) {
        let (lo, hi) = (Vec3::new(-2.0, 0.0, -2.0), Vec3::new(2.0, 3.0, 2.0));
        let layout = OctaLayout::new(n).unwrap();
        let mut distance = vec![0.0; layout.padded_len()];
        let mut normals = vec![Vec3::ZERO; layout.padded_len()];
        let mut grazing = 0;
        for iy in 0..n {
            for ix in 0..n {
                let d = layout.texel_direction(ix, iy);
                let (t, nn) = box_room(p, d, lo, hi);
                distance[layout.interior_index(ix, iy)] = t;
                normals[layout.interior_index(ix, iy)] = nn;
                if nn.dot(d).abs() < COS_TRUSTED {
                    grazing += 1;
                }
            }
        }
        let mut range = vec![Vec2::ZERO; layout.padded_len()];
        let step = 2.0 / n as f32;
        for iy in 0..n {
            for ix in 0..n {
                let (mut lo_t, mut hi_t) = (f32::INFINITY, 0.0f32);
                for k in 0..9 {
                    let (a, b) = ((k % 3) as f32, (k / 3) as f32);
                    let q = Vec2::new(
                        -1.0 + (ix as f32 + (2.0 * a + 1.0) / 6.0) * step,
                        -1.0 + (iy as f32 + (2.0 * b + 1.0) / 6.0) * step,
                    );
                    let t = box_room(p, probe_octa::decode(q), lo, hi).0;
                    lo_t = lo_t.min(t);
                    hi_t = hi_t.max(t);
                }
                range[layout.interior_index(ix, iy)] = Vec2::new(lo_t, hi_t);
            }
        }
        layout.pad(&mut distance).unwrap();
        layout.pad(&mut normals).unwrap();
        layout.pad(&mut range).unwrap();
        let centers: Vec<Vec3> = (0..n * n)
            .map(|i| probe_octa::decode(texel_center(n, i % n, i / n)))
            .collect();
        let mut bounds = TexelBounds::new(n);
        let range = sampled.then_some(&range[..]);
        bounds.compute(
            &layout, &centers, &distance, &normals, range, 100.0, 1.0, false,
        );
        let farther = bounds
            .packed
            .iter()
            .filter(|t| t[0] & SIGN_BIT != 0)
            .count();
        let nearer = bounds
            .packed
            .iter()
            .filter(|t| t[3] & SIGN_BIT != 0)
            .count();
        (farther, nearer, grazing)
    }

    /// Creases (the room's corners) are continuous: a probe in a box room has no edge
    /// texels beyond those seeing walls obliquely.
    #[test]
    fn room_corners_are_not_edges() {
        for p in [
            Vec3::new(0.0, 1.5, 0.0),
            Vec3::new(-0.3, 1.2, -0.3),
            Vec3::new(1.5, 0.4, -1.2),
        ] {
            let (farther, nearer, grazing) = flags_in_room(p, 64);
            eprintln!("{p}: {farther} farther, {nearer} nearer, {grazing} grazing");
            assert_eq!(nearer, 0, "{p}");
            // The baker's samples across each texel see the same walls: no new edges.
            let sampled = flags_in_room_sampled(p, 64, true);
            eprintln!("{p}: with distance ranges {sampled:?}");
            assert_eq!(sampled, (farther, nearer, grazing), "{p}");
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig {
            rng_seed: proptest::test_runner::RngSeed::Fixed(1),
            ..proptest::prelude::ProptestConfig::default()
        })]
        /// The sky map holds, per direction, the mean of the clear sky texels there (sky at
        /// the centre, no nearer edge); elsewhere a value within the range of those means
        /// (grown from neighbours); zero when no probe sees clear sky anywhere. Texels with
        /// a surface, or sky beside one, never enter it.
        #[test]
        fn sky_map_is_the_mean_of_clear_sky(
            kinds in proptest::collection::vec(0u8..4, 3 * 8 * 8),
            values in proptest::collection::vec(0.0f32..10.0, 3 * 8 * 8),
        ) {
            let (n, probes, sky) = (8u32, 3usize, 100.0f32);
            let side = n as usize;
            let mut geometry = vec![[0u32; 4]; probes * padded_len(n)];
            let mut source = vec![Vec3::ZERO; probes * padded_len(n)];
            // Per texel: 0 a surface, 1 clear sky, 2 sky with a nearer edge, 3 clear sky.
            let (mut sum, mut count) = (vec![0.0f32; side * side], vec![0u32; side * side]);
            for probe in 0..probes {
                for cell in 0..side * side {
                    let k = kinds[probe * side * side + cell];
                    let v = values[probe * side * side + cell];
                    let i = padded_index(n, probe as u32, (cell % side) as u32, (cell / side) as u32);
                    let distance = if k == 0 { 1.0f32 } else { sky };
                    let edge = if k == 2 { SIGN_BIT } else { 0 };
                    geometry[i] = [distance.to_bits(), 0, 0, 2.0f32.to_bits() | edge];
                    source[i] = Vec3::splat(v);
                    if k == 1 || k == 3 {
                        sum[cell] += v;
                        count[cell] += 1;
                    }
                }
            }
            let mut radiance = vec![7.0f32; 6];
            let start = pack_sky_map(n, probes, &geometry, &source, sky, &mut radiance);
            proptest::prop_assert_eq!(start, 2);
            proptest::prop_assert_eq!(radiance.len(), 6 + 3 * side * side);
            let means: Vec<f32> = (0..side * side)
                .filter(|&c| count[c] > 0)
                .map(|c| sum[c] / count[c] as f32)
                .collect();
            let lo = means.iter().copied().fold(f32::INFINITY, f32::min);
            let hi = means.iter().copied().fold(f32::NEG_INFINITY, f32::max);
            for cell in 0..side * side {
                let texel = &radiance[6 + 3 * cell..9 + 3 * cell];
                proptest::prop_assert!(texel[0] == texel[1] && texel[1] == texel[2]);
                if count[cell] > 0 {
                    let mean = sum[cell] / count[cell] as f32;
                    proptest::prop_assert!((texel[0] - mean).abs() <= 1e-5 * (1.0 + mean));
                } else if means.is_empty() {
                    proptest::prop_assert_eq!(texel[0], 0.0);
                } else {
                    proptest::prop_assert!(texel[0] >= lo - 1e-4 && texel[0] <= hi + 1e-4);
                }
            }
        }
    }
}
