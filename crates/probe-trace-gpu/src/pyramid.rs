//! The hi-Z pyramid of one probe: per cell of levels 1…, the minimum `near` and maximum `far`
//! of its texels (the min/max pyramid of seed 000 §4.3) and a **bounding plane**: a plane such
//! that every ray point inside the cell's cone of directions and in front of the plane (on the
//! probe's side) would pass the fine test of whichever texel it lies in.
//!
//! Why a plane: the minimum radial distance of a cell seen at a grazing angle (a floor, a wall
//! along the view) is far nearer than most of the cell, so a ray flying just above such a
//! surface fails the min test at every level and walks texel by texel — near its own origin
//! (reflection rays leave a surface the probe sees) and near its hit. A plane bound is exact for
//! flat surfaces at any angle and for coarse cells of them, so those rays climb.
//!
//! Construction, bottom-up. A texel's *pass region* (points the fine test lets through, see
//! [`crate::cpu::march`]) contains the convex set "in front of its plane and within `far`" (or
//! "nearer than `near`" for a texel with a nearer edge; everything for sky). A cell's plane `P`
//! is valid when, within the cone of every child (texel, or sub-cell with its own plane or its
//! minimum-distance ball), `P`'s front region lies inside the child's convex region. A texel or
//! cell of the octahedral map is a convex polyhedral cone of directions, or two such cones split
//! along the cell's diagonal (the map's `z = 0` fold), whose vertices are the cell's four
//! corners; and `P`'s front part inside such a cone is the convex hull of its points on the
//! corner rays. So checking the corner rays suffices: `P` is chosen (normal among the children's
//! normals and their mean, by tightness), then its offset is the largest with every child's
//! corner points behind or on it, less a relative margin for rounding.

use glam::Vec3;

use crate::surface::{PYRAMID_MARGIN, pack_normal, unpack_normal};

/// A cell's plane is used only if its normal makes at least this cosine with every corner
/// direction of the cell (farther from parallel, so its distances along the cone stay finite).
const MIN_PLANE_COSINE: f32 = 0.02;

/// Offset stored for a cell with no valid plane: no point is in front of it.
pub(crate) const NO_PLANE: f32 = -f32::MAX;
/// Offset stored for a cell of sky only: every point is in front of it.
pub(crate) const ALL_PASS: f32 = f32::MAX;

/// One texel's pass region as seen by the pyramid.
#[derive(Clone, Copy, Debug)]
pub(crate) enum TexelRegion {
    /// Sky: the fine test passes everything.
    Sky,
    /// Nearer than this radius (a texel with a nearer edge).
    Ball(f32),
    /// In front of the plane through `point` with outward normal `outward` (pointing away from
    /// the probe), and within `far`.
    Plane {
        /// The texel's surface point (relative to the probe).
        point: Vec3,
        /// Unit normal pointing away from the probe's side.
        outward: Vec3,
        /// The texel's far bound.
        far: f32,
    },
}

/// A built cell: `[min near, max far, packed outward normal, offset]` as stored.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Cell {
    min: f32,
    max: f32,
    normal: Vec3,
    packed_normal: u32,
    offset: f32,
}

impl Cell {
    fn record(&self) -> [u32; 4] {
        [
            (self.min - self.min.abs() * PYRAMID_MARGIN).to_bits(),
            (self.max + self.max.abs() * PYRAMID_MARGIN).to_bits(),
            self.packed_normal,
            self.offset.to_bits(),
        ]
    }

    /// The cell's region along direction `u` as a radius (`None`: unconstrained).
    fn radius_along(&self, u: Vec3) -> Option<f32> {
        if self.offset == ALL_PASS {
            return None;
        }
        if self.offset != NO_PLANE {
            let cos = self.normal.dot(u);
            if cos > 0.0 {
                return Some(self.offset / cos);
            }
        }
        // The minimum-distance ball is a pass region too.
        Some(self.min)
    }
}

/// Picks the plane for a cell whose children constrain it at `points` (corner rays `u` with
/// radii), among `candidates` (unit outward normals), with the cell's own corner directions
/// `corners`. Returns the unpacked normal, its packed bits and the offset.
fn best_plane(
    points: &[(Vec3, f32)],
    candidates: &[Vec3],
    corners: &[Vec3; 4],
) -> (Vec3, u32, f32) {
    if points.is_empty() {
        return (Vec3::Z, pack_normal(Vec3::Z), ALL_PASS);
    }
    let mut best: Option<(f32, Vec3, u32, f32)> = None;
    for &candidate in candidates {
        let packed = pack_normal(candidate);
        let n = unpack_normal(packed);
        if n == Vec3::ZERO || corners.iter().any(|&u| n.dot(u) < MIN_PLANE_COSINE) {
            continue;
        }
        let offset = points
            .iter()
            .map(|&(u, r)| r * n.dot(u))
            .fold(f32::INFINITY, f32::min);
        // Also skips NaN.
        if offset.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            continue;
        }
        // Tightness: how close the plane comes to each constraint, on average (1: touching).
        let score: f32 = points
            .iter()
            .map(|&(u, r)| (offset / (n.dot(u).max(1e-6) * r)).min(1.0))
            .sum();
        if best.is_none_or(|b| score > b.0) {
            best = Some((score, n, packed, offset));
        }
    }
    match best {
        Some((_, n, packed, offset)) => (n, packed, offset - offset.abs() * PYRAMID_MARGIN),
        None => (Vec3::Z, pack_normal(Vec3::Z), NO_PLANE),
    }
}

/// Builds levels `1..level_count` of one probe's pyramid. `texels` are the interior texels
/// row-major with their `near`/`far` bounds, `corner_dirs` the `(N+1)²` unit corner directions
/// of the texel grid, row-major. `out[level]` receives `(N >> level)²` records, row-major.
pub(crate) fn build(
    resolution: u32,
    level_count: u32,
    texels: &[(TexelRegion, f32, f32)],
    corner_dirs: &[Vec3],
    mut out: impl FnMut(u32, &[[u32; 4]]),
) {
    let n = resolution as usize;
    let corner = |i: usize, j: usize| corner_dirs[j * (n + 1) + i];
    let mut cells: Vec<Cell> = Vec::new();
    let mut records: Vec<[u32; 4]> = Vec::new();
    let mut points: Vec<(Vec3, f32)> = Vec::with_capacity(16);
    let mut candidates: Vec<Vec3> = Vec::with_capacity(5);
    for level in 1..level_count {
        let side = n >> level;
        let size = 1usize << level;
        let mut next = Vec::with_capacity(side * side);
        for cy in 0..side {
            for cx in 0..side {
                points.clear();
                candidates.clear();
                let mut min = f32::INFINITY;
                let mut max = f32::NEG_INFINITY;
                let mut sum = Vec3::ZERO;
                for k in 0..4 {
                    let (x, y) = (2 * cx + (k & 1), 2 * cy + (k >> 1));
                    let half = size / 2;
                    let child_corners = [
                        corner(x * half, y * half),
                        corner((x + 1) * half, y * half),
                        corner(x * half, (y + 1) * half),
                        corner((x + 1) * half, (y + 1) * half),
                    ];
                    if level == 1 {
                        let (region, near, far) = texels[y * n + x];
                        min = min.min(near);
                        max = max.max(far);
                        match region {
                            TexelRegion::Sky => {}
                            TexelRegion::Ball(radius) => {
                                points.extend(child_corners.iter().map(|&u| (u, radius)));
                            }
                            TexelRegion::Plane {
                                point,
                                outward,
                                far,
                            } => {
                                let reach = outward.dot(point);
                                for &u in &child_corners {
                                    let cos = outward.dot(u);
                                    let r = if cos > 0.0 && reach > 0.0 {
                                        (reach / cos).min(far)
                                    } else {
                                        far
                                    };
                                    points.push((u, r));
                                }
                                candidates.push(outward);
                                sum += outward;
                            }
                        }
                    } else {
                        let child = cells[y * (side * 2) + x];
                        min = min.min(child.min);
                        max = max.max(child.max);
                        for &u in &child_corners {
                            if let Some(r) = child.radius_along(u) {
                                points.push((u, r));
                            }
                        }
                        if child.offset != ALL_PASS && child.offset != NO_PLANE {
                            candidates.push(child.normal);
                            sum += child.normal;
                        }
                    }
                }
                if sum != Vec3::ZERO {
                    candidates.push(sum.normalize());
                }
                let corners = [
                    corner(cx * size, cy * size),
                    corner((cx + 1) * size, cy * size),
                    corner(cx * size, (cy + 1) * size),
                    corner((cx + 1) * size, (cy + 1) * size),
                ];
                let (normal, packed_normal, offset) = best_plane(&points, &candidates, &corners);
                next.push(Cell {
                    min,
                    max,
                    normal,
                    packed_normal,
                    offset,
                });
            }
        }
        records.clear();
        records.extend(next.iter().map(Cell::record));
        out(level, &records);
        cells = next;
    }
}
