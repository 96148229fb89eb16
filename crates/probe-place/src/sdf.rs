//! Candidate probes from the skeleton of the scene's distance field (seed 000 §3.1.1, Alg. 1).

use crate::candidate_error::{CandidateError, ValidRange, check_count, check_param};
use crate::cluster::{ClusterStats, cover_clusters, settle_in_free_space};
use crate::probes::{ProbeSet, json_f32};
use crate::provenance::PlacementMethod;
use crate::voxel::{DistanceField, VoxelGrid, VoxelState};
use glam::Vec3;
use probe_scene::{Aabb, Ray, Scene};
use serde_json::{Map, Value};

/// Parameters of [`sdf_candidates`]. [`SdfParams::for_scene`] scales them to a scene.
#[derive(Clone, Debug, PartialEq)]
pub struct SdfParams {
    /// Voxel edge length, metres.
    pub voxel_size: f32,
    /// Alg. 1's threshold: skeleton voxels lie at least this far from geometry, metres.
    pub min_clearance: f32,
    /// Skeleton pieces (26-connected) with fewer voxels are dropped (the seed's "diagonal
    /// elements" of Fig. 3.3a), and so are clusters with fewer voxels.
    pub min_cluster_voxels: usize,
    /// A cluster's radius is this multiple of its seed voxel's clearance (distance to
    /// geometry): a probe stands for the skeleton voxels it sees within that distance. Larger
    /// gives fewer probes.
    pub coverage_factor: f32,
    /// The largest cluster radius, metres (splits wide open spaces).
    pub max_cluster_radius: f32,
}

impl SdfParams {
    /// Parameters scaled to the scene's largest extent `L`: voxels of `L / 160`, a clearance of
    /// `max(L / 40, 2 voxels)`, pieces and clusters of at least 16 voxels, clusters reaching 4
    /// times their seed's clearance, at most `L / 2`. They give 10 probes in the Cornell box
    /// (seed 000 used 7), 8 to 13 in the other built-in scenes and the Godot room, 46 in
    /// Sponza (seed 000: 54 to 87). A scene without triangles gets the parameters of a 1 m
    /// scene.
    pub fn for_scene(scene: &Scene) -> SdfParams {
        let extent = scene.bounds().size().max_element();
        let extent = if extent.is_finite() && extent > 0.0 {
            extent
        } else {
            1.0
        };
        let voxel_size = extent / 160.0;
        SdfParams {
            voxel_size,
            min_clearance: (extent / 40.0).max(2.0 * voxel_size),
            min_cluster_voxels: 16,
            coverage_factor: 4.0,
            max_cluster_radius: extent / 2.0,
        }
    }

    fn check(&self) -> Result<(), CandidateError> {
        if !(self.voxel_size.is_finite() && self.voxel_size > 0.0) {
            return Err(CandidateError::InvalidVoxelSize {
                voxel_size: self.voxel_size,
            });
        }
        check_param("min_clearance", self.min_clearance, ValidRange::NonNegative)?;
        check_count("min_cluster_voxels", self.min_cluster_voxels)?;
        check_param(
            "coverage_factor",
            self.coverage_factor,
            ValidRange::Positive,
        )?;
        check_param(
            "max_cluster_radius",
            self.max_cluster_radius,
            ValidRange::Positive,
        )
    }

    pub(crate) fn to_json(&self) -> Map<String, Value> {
        let mut map = Map::new();
        map.insert("voxel_size".to_owned(), json_f32(self.voxel_size));
        map.insert("min_clearance".to_owned(), json_f32(self.min_clearance));
        map.insert(
            "min_cluster_voxels".to_owned(),
            Value::from(self.min_cluster_voxels),
        );
        map.insert("coverage_factor".to_owned(), json_f32(self.coverage_factor));
        map.insert(
            "max_cluster_radius".to_owned(),
            json_f32(self.max_cluster_radius),
        );
        map
    }
}

/// The result of [`sdf_candidates`]: the probes, the voxel grid and distance field they came
/// from (reusable for free-space queries), and counts of each stage.
#[derive(Clone, Debug)]
pub struct SdfCandidates {
    /// The candidate probes (method `"sdf"`, parameters as given).
    pub probes: ProbeSet,
    /// The classified voxel grid.
    pub voxels: VoxelGrid,
    /// Its distance field.
    pub distances: DistanceField,
    /// Skeleton voxels before small pieces were dropped.
    pub skeleton_voxels: usize,
    /// Skeleton pieces kept.
    pub pieces_kept: usize,
    /// Skeleton pieces dropped (fewer than `min_cluster_voxels` voxels).
    pub pieces_dropped: usize,
    /// Clusters dropped (fewer than `min_cluster_voxels` voxels).
    pub small_clusters: usize,
    /// How the clusters became probes.
    pub clusters: ClusterStats,
}

/// Candidate probe positions from the skeleton of the scene's distance field (seed 000
/// §3.1.1, Alg. 1):
///
/// 1. voxelize the scene and classify free space ([`VoxelGrid::build`]);
/// 2. compute the exact Euclidean distance transform ([`VoxelGrid::distance_field`]);
/// 3. the skeleton: free voxels inside the scene's bounds (probes beyond all geometry see
///    little), at least `min_clearance` from geometry, that are ridge voxels of the distance
///    field: along some axis, at least as far from geometry as both neighbours and farther
///    than one. (Keeping every voxel beyond the threshold would give a thick eroded volume;
///    the ridge makes the thin skeleton of the seed's Fig. 3.3a, diagonal elements included);
/// 4. drop 26-connected skeleton pieces smaller than `min_cluster_voxels`;
/// 5. cluster the kept voxels (all pieces together) by greedy covering: from the voxel
///    farthest from geometry down, each voxel not yet covered seeds a cluster of the uncovered
///    voxels it sees (unoccluded segment) within `coverage_factor` times its clearance (at
///    most `max_cluster_radius`); so a convex room is one cluster, a hall's probes reach
///    farther than a corridor's, and every region hidden from the others gets its own.
///    Clusters smaller than `min_cluster_voxels` are dropped; a probe goes to each cluster's
///    mean;
/// 6. a mean that falls outside free space (or nearer to geometry than half the clearance),
///    or where [`inside_geometry`](crate::candidates::inside_geometry) says a probe would see mostly back
///    faces, moves to the cluster's nearest voxel that passes these tests (the cluster is
///    dropped if none of its 16 nearest does).
///
/// Deterministic: no randomness is involved.
pub fn sdf_candidates(scene: &Scene, params: &SdfParams) -> Result<SdfCandidates, CandidateError> {
    params.check()?;
    let voxels = VoxelGrid::build(scene, params.voxel_size)?;
    let distances = voxels.distance_field();
    let clearance = params.min_clearance / params.voxel_size;
    let skeleton = skeleton_voxels(&voxels, &distances, clearance * clearance, &scene.bounds());
    let skeleton_count = skeleton.iter().filter(|&&s| s).count();
    let pieces = components_26(&skeleton, voxels.dims());
    let (kept, dropped): (Vec<_>, Vec<_>) = pieces
        .into_iter()
        .partition(|piece| piece.len() >= params.min_cluster_voxels);
    let mut positions = Vec::new();
    let mut stats = ClusterStats::default();
    let mut small_clusters = 0;
    let squared = distances.squared_voxel_distances();
    // Pieces only filter noise; the kept voxels are clustered together, so that a probe in one
    // piece stands for the voxels it sees in others.
    let kept_voxels: Vec<u32> = kept.iter().flatten().copied().collect();
    let points: Vec<Vec3> = kept_voxels
        .iter()
        .map(|&i| voxels.center(voxels.cell(i as usize)))
        .collect();
    let clearances: Vec<f32> = kept_voxels
        .iter()
        .map(|&i| (squared[i as usize] as f32).sqrt() * params.voxel_size)
        .collect();
    let clusters = cover_clusters(
        &points,
        &clearances,
        params.coverage_factor,
        params.max_cluster_radius,
        |a, b| sees(scene, a, b),
    );
    let min_clearance = 0.5 * params.min_clearance;
    let fits = |p: Vec3| {
        voxels.state_at(p) == VoxelState::Free
            && distances.distance_at(p).is_none_or(|d| d >= min_clearance)
    };
    for cluster in clusters {
        if cluster.len() < params.min_cluster_voxels {
            small_clusters += 1;
            continue;
        }
        let members: Vec<Vec3> = cluster.iter().map(|&i| points[i]).collect();
        if let Some(p) = settle_in_free_space(scene, &members, fits, &mut stats) {
            positions.push(p);
        }
    }
    Ok(SdfCandidates {
        probes: ProbeSet::new(positions).with_method(PlacementMethod::Sdf {
            params: params.clone(),
            skeleton_voxels: skeleton_count,
        }),
        voxels,
        distances,
        skeleton_voxels: skeleton_count,
        pieces_kept: kept.len(),
        pieces_dropped: dropped.len(),
        small_clusters,
        clusters: stats,
    })
}

/// Whether the segment between two points in free space is unoccluded.
pub(crate) fn sees(scene: &Scene, from: Vec3, to: Vec3) -> bool {
    let offset = to - from;
    let distance = offset.length();
    distance == 0.0 || !scene.occluded(&Ray::new(from, offset), distance)
}

/// Free voxels at least `min_squared` (voxel units²) from geometry that are ridge voxels of the
/// distance field along some axis.
fn skeleton_voxels(
    voxels: &VoxelGrid,
    distances: &DistanceField,
    min_squared: f32,
    bounds: &Aabb,
) -> Vec<bool> {
    let [nx, ny, nz] = voxels.dims().map(|d| d as usize);
    let squared = distances.squared_voxel_distances();
    let states = voxels.states();
    let strides = [1, nx, nx * ny];
    let extents = [nx, ny, nz];
    (0..squared.len())
        .map(|i| {
            let d = squared[i];
            if states[i] != VoxelState::Free || (d as f32) < min_squared {
                return false;
            }
            let coords = [i % nx, (i / nx) % ny, i / (nx * ny)];
            let cell = coords.map(|c| c as u32);
            if !bounds.contains(voxels.center(cell)) {
                return false;
            }
            (0..3).any(|axis| {
                let (stride, c) = (strides[axis], coords[axis]);
                let before = if c > 0 { squared[i - stride] } else { 0 };
                let after = if c + 1 < extents[axis] {
                    squared[i + stride]
                } else {
                    0
                };
                d >= before && d >= after && (d > before || d > after)
            })
        })
        .collect()
}

/// The 26-connected components of the marked voxels, as lists of flat indices.
fn components_26(marked: &[bool], dims: [u32; 3]) -> Vec<Vec<u32>> {
    let [nx, ny, nz] = dims.map(|d| d as i64);
    let mut seen = vec![false; marked.len()];
    let mut components = Vec::new();
    let mut stack = Vec::new();
    for start in 0..marked.len() {
        if !marked[start] || seen[start] {
            continue;
        }
        seen[start] = true;
        stack.push(start as u32);
        let mut component = Vec::new();
        while let Some(index) = stack.pop() {
            component.push(index);
            let i = i64::from(index);
            let (x, y, z) = (i % nx, (i / nx) % ny, i / (nx * ny));
            for dz in -1..=1 {
                for dy in -1..=1 {
                    for dx in -1..=1 {
                        let (a, b, c) = (x + dx, y + dy, z + dz);
                        if a < 0 || b < 0 || c < 0 || a >= nx || b >= ny || c >= nz {
                            continue;
                        }
                        let j = (a + nx * (b + ny * c)) as usize;
                        if marked[j] && !seen[j] {
                            seen[j] = true;
                            stack.push(j as u32);
                        }
                    }
                }
            }
        }
        components.push(component);
    }
    components
}
