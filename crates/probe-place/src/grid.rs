//! Regular probe grids, the baseline every placement is compared with, and the fair baseline:
//! the same grid with DDGI-style probe classification and relocation.

use crate::candidate_error::{CandidateError, ValidRange, check_count_up_to, check_param};
use crate::par::*;
use crate::probes::ProbeSet;
use crate::provenance::PlacementMethod;
use glam::{UVec3, Vec3};
use probe_scene::{Aabb, Ray, Scene};

/// The most cells a regular grid may have along one axis.
pub const MAX_GRID_DIM: u32 = 1024;

/// The most probes a regular grid may hold (`2^20`, about a million).
pub const MAX_GRID_PROBES: u64 = 1 << 20;

/// The farthest relocation may move a probe, as a fraction of its cell: the offset divided
/// by the cell size, per axis, must have a length below this (DDGI's ellipsoid rule).
pub const MAX_RELOCATION_FRACTION: f32 = 0.45;

/// A regular grid of probes: `dims` cells dividing a box, one probe at each cell centre.
///
/// Probe `i` sits in cell `(x, y, z)` with `i = x + dims.x · (y + dims.y · z)` (x fastest),
/// at `bounds.min + (cell + ½) · bounds.size() / dims`. This is the convention of
/// [`probe_scene::builtin::grid_cell_centers`], which the `boxes` scene is built on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RegularGrid {
    bounds: Aabb,
    dims: [u32; 3],
}

impl RegularGrid {
    /// A grid of `dims` cells over `bounds`.
    ///
    /// Errors: [`CandidateError::InvalidGridDims`] for a zero dimension, one above
    /// [`MAX_GRID_DIM`] or more than [`MAX_GRID_PROBES`] probes; [`CandidateError::InvalidBounds`]
    /// for an empty or non-finite box. A box flat along an axis is allowed: its probes lie in
    /// that plane.
    pub fn new(bounds: Aabb, dims: [u32; 3]) -> Result<RegularGrid, CandidateError> {
        let count: u64 = dims.iter().map(|&d| u64::from(d)).product();
        if dims.iter().any(|&d| d == 0 || d > MAX_GRID_DIM) || count > MAX_GRID_PROBES {
            return Err(CandidateError::InvalidGridDims {
                dims,
                max_dim: MAX_GRID_DIM,
                max_probes: MAX_GRID_PROBES,
            });
        }
        if bounds.is_empty() || !bounds.min.is_finite() || !bounds.max.is_finite() {
            return Err(CandidateError::InvalidBounds {
                min: bounds.min.to_array(),
                max: bounds.max.to_array(),
            });
        }
        Ok(RegularGrid { bounds, dims })
    }

    /// A grid of `dims` cells over the scene's bounds; [`CandidateError::EmptyScene`] for a
    /// scene without triangles.
    pub fn over_scene(scene: &Scene, dims: [u32; 3]) -> Result<RegularGrid, CandidateError> {
        if scene.triangles().is_empty() {
            return Err(CandidateError::EmptyScene {
                scene: scene.name().to_owned(),
            });
        }
        RegularGrid::new(scene.bounds(), dims)
    }

    /// The box the grid divides.
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// The number of cells along x, y and z.
    pub fn dims(&self) -> [u32; 3] {
        self.dims
    }

    /// The number of probes (cells).
    pub fn len(&self) -> usize {
        self.dims.iter().map(|&d| d as usize).product()
    }

    /// Always false: a grid has at least one cell.
    pub fn is_empty(&self) -> bool {
        false
    }

    /// The size of one cell, metres (zero along an axis where the box is flat).
    pub fn cell_size(&self) -> Vec3 {
        self.bounds.size() / UVec3::from(self.dims).as_vec3()
    }

    /// The cell `(x, y, z)` of probe `index` (x fastest). Panics if `index ≥ len()`.
    pub fn cell_of(&self, index: usize) -> [u32; 3] {
        assert!(index < self.len(), "probe index {index} out of range");
        let [nx, ny, _] = self.dims.map(|d| d as usize);
        [
            (index % nx) as u32,
            ((index / nx) % ny) as u32,
            (index / (nx * ny)) as u32,
        ]
    }

    /// The centre of cell `(x, y, z)`.
    pub fn cell_center(&self, cell: [u32; 3]) -> Vec3 {
        self.bounds.min + (UVec3::from(cell).as_vec3() + 0.5) * self.cell_size()
    }

    /// The probe positions (cell centres), x fastest, then y, then z.
    pub fn positions(&self) -> Vec<Vec3> {
        (0..self.len())
            .map(|i| self.cell_center(self.cell_of(i)))
            .collect()
    }

    /// The grid as a [`ProbeSet`] with [`PlacementMethod::Grid`] (`"grid"`, parameters
    /// `dims` and `bounds`).
    pub fn probe_set(&self) -> ProbeSet {
        ProbeSet::new(self.positions()).with_method(PlacementMethod::Grid {
            dims: self.dims,
            bounds: self.bounds,
        })
    }
}

/// Parameters of DDGI-style probe classification and relocation ([`classify_grid`]).
///
/// The rules follow RTXGI's probe relocation and classification passes: each probe casts
/// `ray_count` rays (a fixed spherical-Fibonacci set, so no seed is needed); a ray counts as a
/// *back-face hit* when its first hit is the back of a single-sided triangle.
#[derive(Clone, Debug, PartialEq)]
pub struct ClassifyParams {
    /// Whether to move probes before classifying them (the `grid-relocated` method). Default
    /// `true`; `false` only switches probes off.
    pub relocate: bool,
    /// Rays per probe and per relocation step. Default 64; at most 65,536.
    pub ray_count: usize,
    /// A probe is inside geometry when more than this share of its rays hit back faces.
    /// Default 0.25 (RTXGI's `probeBackfaceThreshold`).
    pub backface_threshold: f32,
    /// The distance a probe should keep from the nearest front face, as a fraction of the
    /// smallest non-zero cell size. Default 0.2.
    pub min_frontface_fraction: f32,
    /// Relocation steps (RTXGI runs one per frame). Default 8; at most 1000.
    pub iterations: usize,
}

impl Default for ClassifyParams {
    fn default() -> Self {
        ClassifyParams {
            relocate: true,
            ray_count: 64,
            backface_threshold: 0.25,
            min_frontface_fraction: 0.2,
            iterations: 8,
        }
    }
}

impl ClassifyParams {
    fn check(&self) -> Result<(), CandidateError> {
        check_count_up_to("ray_count", self.ray_count, 1 << 16)?;
        check_param(
            "backface_threshold",
            self.backface_threshold,
            ValidRange::UnitInterval,
        )?;
        check_param(
            "min_frontface_fraction",
            self.min_frontface_fraction,
            ValidRange::NonNegative,
        )?;
        if self.relocate {
            check_count_up_to("iterations", self.iterations, 1000)?;
        }
        Ok(())
    }
}

/// A regular grid after DDGI-style classification (and relocation): the probes kept, where
/// they moved, and the cells switched off.
#[derive(Clone, Debug, PartialEq)]
pub struct ClassifiedGrid {
    /// The grid classified.
    pub grid: RegularGrid,
    /// The kept probes' positions (relocated if asked).
    pub positions: Vec<Vec3>,
    /// For each kept probe, its cell index in the grid (x fastest).
    pub cells: Vec<usize>,
    /// The cells whose probe was switched off: still inside geometry after relocation.
    pub removed: Vec<usize>,
    /// Whether the probes were relocated.
    pub relocated: bool,
}

impl ClassifiedGrid {
    /// The kept probes as a [`ProbeSet`] with method `"grid-relocated"` (or
    /// `"grid-classified"` without relocation).
    pub fn probe_set(&self) -> ProbeSet {
        ProbeSet::new(self.positions.clone()).with_method(PlacementMethod::ClassifiedGrid {
            dims: self.grid.dims,
            bounds: self.grid.bounds,
            removed: self.removed.len(),
            relocated: self.relocated,
        })
    }
}

/// DDGI-style classification (and relocation) of a regular grid's probes.
///
/// Relocation (when `params.relocate`), `params.iterations` steps per probe, each from the
/// current position `p = centre + offset` with `ray_count` rays:
/// 1. if more than `backface_threshold` of the rays hit back faces, the probe is inside
///    geometry: step along the closest back-face hit's direction by its distance plus half the
///    minimum front-face distance (out through that face);
/// 2. else if the closest front face is nearer than the minimum front-face distance, step
///    towards the farthest front face (a miss counts as infinitely far) by at most the minimum
///    distance, unless that direction also approaches the closest face;
/// 3. else step back towards the cell centre by the slack beyond the minimum distance.
///
/// A step is taken only if the new offset stays within the ellipsoid
/// `|offset / cell_size| < 0.45` ([`MAX_RELOCATION_FRACTION`]): no probe leaves 45 % of its
/// cell. Classification then switches off every probe that is still inside geometry (rule 1
/// at its final position); the rest are kept. Probes are processed in parallel; the result is
/// deterministic.
pub fn classify_grid(
    scene: &Scene,
    grid: &RegularGrid,
    params: &ClassifyParams,
) -> Result<ClassifiedGrid, CandidateError> {
    params.check()?;
    if scene.triangles().is_empty() {
        return Err(CandidateError::EmptyScene {
            scene: scene.name().to_owned(),
        });
    }
    let directions = fibonacci_directions(params.ray_count);
    let cell = grid.cell_size();
    let smallest_cell = cell
        .to_array()
        .into_iter()
        .filter(|&c| c > 0.0)
        .fold(f32::INFINITY, f32::min);
    let min_front = if smallest_cell.is_finite() {
        params.min_frontface_fraction * smallest_cell
    } else {
        0.0
    };
    let backface_limit = params.backface_threshold * directions.len() as f32;
    let outcomes: Vec<(Vec3, bool)> = (0..grid.len())
        .into_par_iter()
        .map(|index| {
            let center = grid.cell_center(grid.cell_of(index));
            let mut offset = Vec3::ZERO;
            if params.relocate {
                for _ in 0..params.iterations {
                    let census = RayCensus::take(scene, center + offset, &directions);
                    let step = relocation_step(&census, offset, min_front, backface_limit);
                    match step {
                        Some(new_offset) if within_cell(new_offset, cell) => offset = new_offset,
                        _ => {}
                    }
                }
            }
            let position = center + offset;
            let census = RayCensus::take(scene, position, &directions);
            (position, census.backfaces as f32 > backface_limit)
        })
        .collect();
    let mut result = ClassifiedGrid {
        grid: *grid,
        positions: Vec::new(),
        cells: Vec::new(),
        removed: Vec::new(),
        relocated: params.relocate,
    };
    for (index, (position, inside)) in outcomes.into_iter().enumerate() {
        if inside {
            result.removed.push(index);
        } else {
            result.positions.push(position);
            result.cells.push(index);
        }
    }
    Ok(result)
}

/// The new offset one relocation step proposes, or `None` to stay.
fn relocation_step(
    census: &RayCensus,
    offset: Vec3,
    min_front: f32,
    backface_limit: f32,
) -> Option<Vec3> {
    if census.backfaces as f32 > backface_limit {
        let (distance, direction) = census.closest_back?;
        return Some(offset + direction * (distance + 0.5 * min_front));
    }
    match census.closest_front {
        Some((distance, direction)) if distance < min_front => {
            let (far_distance, far_direction) = census.farthest_front;
            if direction.dot(far_direction) <= 0.0 {
                Some(offset + far_direction * far_distance.min(min_front))
            } else {
                None
            }
        }
        Some((distance, _)) => {
            // Far enough from every front face: drift back towards the cell centre.
            let back = (distance - min_front).min(offset.length());
            (back > 0.0).then(|| offset - offset.normalize_or_zero() * back)
        }
        None => {
            // Nothing but misses and (few) back faces: drift back to the centre.
            (offset != Vec3::ZERO).then_some(Vec3::ZERO)
        }
    }
}

/// Whether an offset lies inside the 45 % ellipsoid of a cell.
fn within_cell(offset: Vec3, cell: Vec3) -> bool {
    let normalized = Vec3::from_array(std::array::from_fn(|axis| {
        let (o, c) = (offset[axis], cell[axis]);
        if c > 0.0 {
            o / c
        } else if o == 0.0 {
            0.0
        } else {
            f32::INFINITY
        }
    }));
    normalized.is_finite()
        && normalized.length_squared() < MAX_RELOCATION_FRACTION * MAX_RELOCATION_FRACTION
}

/// What a probe's rays hit.
struct RayCensus {
    /// Rays whose first hit is the back face of a single-sided triangle.
    backfaces: u32,
    /// The closest back-face hit: distance and direction.
    closest_back: Option<(f32, Vec3)>,
    /// The closest front-face hit (a double-sided triangle counts as front).
    closest_front: Option<(f32, Vec3)>,
    /// The farthest front-face hit; misses count as infinitely far.
    farthest_front: (f32, Vec3),
}

impl RayCensus {
    fn take(scene: &Scene, origin: Vec3, directions: &[Vec3]) -> RayCensus {
        let mut census = RayCensus {
            backfaces: 0,
            closest_back: None,
            closest_front: None,
            farthest_front: (0.0, directions[0]),
        };
        let closer = |best: Option<(f32, Vec3)>, t: f32| best.is_none_or(|(b, _)| t < b);
        for &direction in directions {
            let ray = Ray::new(origin, direction);
            match scene.closest_hit(&ray, f32::INFINITY) {
                Some(hit)
                    if !hit.front_face
                        && !scene.materials()[hit.material as usize].double_sided =>
                {
                    census.backfaces += 1;
                    if closer(census.closest_back, hit.t) {
                        census.closest_back = Some((hit.t, direction));
                    }
                }
                Some(hit) => {
                    if closer(census.closest_front, hit.t) {
                        census.closest_front = Some((hit.t, direction));
                    }
                    if hit.t > census.farthest_front.0 {
                        census.farthest_front = (hit.t, direction);
                    }
                }
                None => {
                    if census.farthest_front.0 < f32::INFINITY {
                        census.farthest_front = (f32::INFINITY, direction);
                    }
                }
            }
        }
        census
    }
}

/// The number of rays [`inside_geometry`] casts.
pub const INSIDE_TEST_RAYS: usize = 64;

/// The share of back-face hits above which [`inside_geometry`] calls a point inside.
pub const INSIDE_BACKFACE_SHARE: f32 = 0.25;

/// Whether a probe at `point` is inside geometry, by DDGI's classification rule: of
/// [`INSIDE_TEST_RAYS`] rays in fixed spherical-Fibonacci directions, more than
/// [`INSIDE_BACKFACE_SHARE`] (a quarter) first hit the back face of a single-sided triangle.
///
/// This is the test behind "probes inside geometry" in placement reports, and the one
/// [`classify_grid`] switches probes off with. It needs no voxelization and no closed meshes:
/// inside a closed single-sided solid every ray hits a back face; in open space (including
/// the two faces of a zero-thickness double-sided plane) none does. A point that sees mostly
/// the backs of single-sided walls (behind a room's wall, under a floor) counts as inside,
/// which is what a probe there is worth. Hits on double-sided triangles never count, so a
/// point inside a closed *double-sided* solid is not detected here: the voxel classification
/// ([`VoxelGrid::is_free`](crate::candidates::VoxelGrid::is_free)) catches those. Non-finite points count
/// as inside (they are no valid probe positions).
pub fn inside_geometry(scene: &Scene, point: Vec3) -> bool {
    if !point.is_finite() {
        return true;
    }
    let directions = fibonacci_directions(INSIDE_TEST_RAYS);
    let census = RayCensus::take(scene, point, &directions);
    census.backfaces as f32 > INSIDE_BACKFACE_SHARE * directions.len() as f32
}

/// `count` unit directions spread evenly over the sphere (spherical Fibonacci, `+Y` as pole).
pub(crate) fn fibonacci_directions(count: usize) -> Vec<Vec3> {
    let golden_angle = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    (0..count)
        .map(|i| {
            let y = 1.0 - (2 * i + 1) as f32 / count as f32;
            let radius = (1.0 - y * y).max(0.0).sqrt();
            let phi = golden_angle * i as f32;
            Vec3::new(radius * phi.cos(), y, radius * phi.sin())
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fibonacci_directions_are_unit_and_balanced() {
        let directions = fibonacci_directions(64);
        assert_eq!(directions.len(), 64);
        let mean: Vec3 = directions.iter().sum::<Vec3>() / 64.0;
        assert!(mean.length() < 0.02, "{mean}");
        for d in &directions {
            assert!((d.length() - 1.0).abs() < 1e-5);
        }
    }

    #[test]
    fn cell_ellipsoid() {
        let cell = Vec3::new(2.0, 1.0, 0.0);
        assert!(within_cell(Vec3::new(0.89, 0.0, 0.0), cell));
        assert!(!within_cell(Vec3::new(0.91, 0.0, 0.0), cell));
        assert!(!within_cell(Vec3::new(0.7, 0.3, 0.0), cell));
        assert!(!within_cell(Vec3::new(0.0, 0.0, 0.01), cell));
        assert!(within_cell(Vec3::ZERO, cell));
    }
}
