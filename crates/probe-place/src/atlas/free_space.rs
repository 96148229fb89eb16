//! Where a probe may stand: inside the placement bounds, not inside solid geometry, not
//! touching a surface.

use crate::grid::{INSIDE_BACKFACE_SHARE, INSIDE_TEST_RAYS, fibonacci_directions};
use crate::voxel::{VoxelGrid, VoxelState};
use glam::Vec3;
use probe_scene::{Aabb, Ray, Scene};

/// Decides where probes may stand. The optimisers only move probes to points for which
/// [`FreeSpace::is_free`] holds, and [`PlacementReport`](crate::atlas::PlacementReport) counts the
/// probes for which [`FreeSpace::inside_geometry`] holds.
///
/// [`BackfaceVote`] (a ray vote) and [`VoxelFreeSpace`] (the SDF generator's voxels) implement
/// it.
pub trait FreeSpace: Sync {
    /// The box probes must stay in.
    fn bounds(&self) -> Aabb;

    /// Whether a probe at `point` would be inside solid geometry.
    fn inside_geometry(&self, point: Vec3) -> bool;

    /// Whether a probe may stand at `point`: inside [`FreeSpace::bounds`] and not inside
    /// geometry. Implementations may add conditions (such as a clearance from surfaces).
    fn is_free(&self, point: Vec3) -> bool {
        point.is_finite() && self.bounds().contains(point) && !self.inside_geometry(point)
    }
}

/// The free-space test of this crate's placements: DDGI's classification, as
/// [`inside_geometry`](crate::candidates::inside_geometry) decides it — of
/// [`INSIDE_TEST_RAYS`](crate::candidates::INSIDE_TEST_RAYS) rays in fixed spherical Fibonacci directions,
/// more than `backface_fraction` (default [`INSIDE_BACKFACE_SHARE`]) first hit the back face of
/// a single-sided triangle (seen from inside a closed solid, every face is a back face) — plus
/// the bounds and a clearance.
///
/// Double-sided materials have no back face, so a point next to or between double-sided
/// surfaces (an open, zero-thickness mesh such as a two-sided plane) is never inside. Rays
/// that escape the scene vote "outside". [`FreeSpace::is_free`] additionally requires the
/// point to lie in the bounds, no ray to hit a surface closer than `min_clearance` and, if
/// `max_escaping_fraction` is set, not too many rays to escape. One pass of rays answers all.
#[derive(Clone, Debug)]
pub struct BackfaceVote<'a> {
    scene: &'a Scene,
    directions: Vec<Vec3>,
    /// The box probes must stay in (the scene's bounds by default).
    pub bounds: Aabb,
    /// The share of rays that must hit back faces for the point to count as inside
    /// geometry; default [`INSIDE_BACKFACE_SHARE`], with which
    /// [`FreeSpace::inside_geometry`] agrees with [`inside_geometry`](crate::candidates::inside_geometry).
    pub backface_fraction: f32,
    /// The smallest distance to a surface, along any of the rays, at which a probe may stand;
    /// default 0.25 % of the scene's bounding-box diagonal.
    pub min_clearance: f32,
    /// With `Some(share)`, a point from which more than `share` of the rays leave the scene
    /// without a hit is "outdoors" and not free. `None` (the default) keeps seed 000's "bounding
    /// box minus the geometry". For an interior open to the sky, such as Sponza's atrium,
    /// `Some(0.4)` keeps the building's inside and drops the space above its roofs and beside
    /// its outer walls (where half of all directions are open sky), so that placements and
    /// coverage are about the inside.
    pub max_escaping_fraction: Option<f32>,
}

impl<'a> BackfaceVote<'a> {
    /// The vote over `scene` with the defaults: the scene's bounds, a back-face share of
    /// [`INSIDE_BACKFACE_SHARE`] and a clearance of 0.25 % of the bounds' diagonal.
    pub fn new(scene: &'a Scene) -> BackfaceVote<'a> {
        let bounds = scene.bounds();
        BackfaceVote {
            scene,
            directions: fibonacci_directions(INSIDE_TEST_RAYS),
            bounds,
            backface_fraction: INSIDE_BACKFACE_SHARE,
            min_clearance: 0.0025 * bounds.size().length(),
            max_escaping_fraction: None,
        }
    }

    /// The same vote restricted to another box.
    pub fn with_bounds(self, bounds: Aabb) -> BackfaceVote<'a> {
        BackfaceVote { bounds, ..self }
    }

    /// Casts the rays: (back-face hits, rays without a hit, nearest hit distance).
    fn vote(&self, point: Vec3) -> (usize, usize, f32) {
        let mut backfaces = 0;
        let mut escaping = 0;
        let mut nearest = f32::INFINITY;
        let materials = self.scene.materials();
        for direction in &self.directions {
            let ray = Ray::new(point, *direction);
            match self.scene.closest_hit(&ray, f32::INFINITY) {
                Some(hit) => {
                    nearest = nearest.min(hit.t);
                    if !hit.front_face && !materials[hit.material as usize].double_sided {
                        backfaces += 1;
                    }
                }
                None => escaping += 1,
            }
        }
        (backfaces, escaping, nearest)
    }

    fn inside_from_vote(&self, backfaces: usize) -> bool {
        backfaces as f32 > self.backface_fraction * self.directions.len() as f32
    }
}

impl FreeSpace for BackfaceVote<'_> {
    fn bounds(&self) -> Aabb {
        self.bounds
    }

    fn inside_geometry(&self, point: Vec3) -> bool {
        !point.is_finite() || self.inside_from_vote(self.vote(point).0)
    }

    fn is_free(&self, point: Vec3) -> bool {
        if !point.is_finite() || !self.bounds.contains(point) {
            return false;
        }
        let (backfaces, escaping, nearest) = self.vote(point);
        let outdoors = self
            .max_escaping_fraction
            .is_some_and(|share| escaping as f32 > share * self.directions.len() as f32);
        !self.inside_from_vote(backfaces) && nearest >= self.min_clearance && !outdoors
    }
}

/// The free space of a [`VoxelGrid`] (the SDF generator's voxelization: what a flood fill
/// reaches from outside the bounds, plus sealed rooms), limited to a box (usually the scene's
/// bounds): a point is free when its voxel is [`VoxelState::Free`], and inside geometry when
/// its voxel is [`VoxelState::Inside`]. Voxels that a triangle touches are neither, so probes
/// keep about a voxel of clearance.
#[derive(Clone, Copy, Debug)]
pub struct VoxelFreeSpace<'v> {
    voxels: &'v VoxelGrid,
    bounds: Aabb,
}

impl<'v> VoxelFreeSpace<'v> {
    /// The free space of `voxels` within `bounds`.
    pub fn new(voxels: &'v VoxelGrid, bounds: Aabb) -> VoxelFreeSpace<'v> {
        VoxelFreeSpace { voxels, bounds }
    }
}

impl FreeSpace for VoxelFreeSpace<'_> {
    fn bounds(&self) -> Aabb {
        self.bounds
    }

    fn inside_geometry(&self, point: Vec3) -> bool {
        self.voxels.state_at(point) == VoxelState::Inside
    }

    fn is_free(&self, point: Vec3) -> bool {
        point.is_finite() && self.bounds.contains(point) && self.voxels.is_free(point)
    }
}

/// Both tests at once: a point is free when both call it free (the first is asked first, so
/// put the cheaper one first) and inside geometry when either says so; the bounds are the
/// intersection. Pair [`BackfaceVote`] with [`VoxelFreeSpace`] for scenes with closed
/// double-sided solids (the vote has no back faces to count there; the voxels see the
/// enclosed pocket) or with solids made of touching boxes (coplanar faces can fool the voxels'
/// vote of a sealed pocket; the per-point ray vote is not fooled).
impl<A: FreeSpace, B: FreeSpace> FreeSpace for (A, B) {
    fn bounds(&self) -> Aabb {
        let (a, b) = (self.0.bounds(), self.1.bounds());
        Aabb::new(a.min.max(b.min), a.max.min(b.max))
    }

    fn inside_geometry(&self, point: Vec3) -> bool {
        self.0.inside_geometry(point) || self.1.inside_geometry(point)
    }

    fn is_free(&self, point: Vec3) -> bool {
        self.0.is_free(point) && self.1.is_free(point)
    }
}

/// The centres of a regular grid of cells of edge `spacing` over `free.bounds()` that are
/// free ([`FreeSpace::is_free`]), x fastest then y then z. Per axis the grid has
/// `max(1, round(extent / spacing))` cells and is centred in the bounds. Used as the default
/// reference points of an [`Atlas`](crate::atlas::Atlas) and as a dense candidate pool for
/// [`minimal_cover`](crate::minimal::minimal_cover). The classification runs in parallel.
///
/// Returns an empty list for a non-positive or non-finite `spacing` or empty bounds.
pub fn free_space_grid(free: &dyn FreeSpace, spacing: f32) -> Vec<Vec3> {
    use crate::par::*;
    let bounds = free.bounds();
    if !(spacing.is_finite() && spacing > 0.0) || bounds.is_empty() {
        return Vec::new();
    }
    let size = bounds.size();
    let dims = (size / spacing).round().max(Vec3::ONE);
    if dims.x * dims.y * dims.z > 1.0e8 {
        return Vec::new();
    }
    let cell = size / dims;
    let (nx, ny, nz) = (dims.x as u32, dims.y as u32, dims.z as u32);
    let points: Vec<Vec3> = (0..nz)
        .flat_map(|z| (0..ny).flat_map(move |y| (0..nx).map(move |x| (x, y, z))))
        .map(|(x, y, z)| bounds.min + (Vec3::new(x as f32, y as f32, z as f32) + 0.5) * cell)
        .collect();
    let free_flags: Vec<bool> = points
        .par_iter()
        .with_min_len(16)
        .map(|p| free.is_free(*p))
        .collect();
    points
        .into_iter()
        .zip(free_flags)
        .filter_map(|(p, ok)| ok.then_some(p))
        .collect()
}
