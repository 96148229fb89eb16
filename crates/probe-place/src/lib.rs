//! `probe_place`: automatic placement of radiance probes in a 3-D scene.
//!
//! Engines place light-field probes by hand or in wasteful regular grids. This crate makes
//! probe positions from the scene's geometry ([`probe_scene::Scene`]) and returns them as a
//! [`ProbeSet`], saved as `probes/1` JSON.
//!
//! # Candidates
//!
//! - [`RegularGrid`]: the baseline, probes at the cell centres of a division of the scene's
//!   bounds (`grid:4x2x4` in [`ProbeSet::from_spec`]); [`classify_grid`] is the fair
//!   baseline, DDGI-style classification (probes inside geometry switched off) and relocation
//!   (probes moved at most 45 % of a cell towards free space).
//! - [`VoxelGrid`]: the scene voxelized, each voxel free, surface or inside a solid, with an
//!   exact Euclidean [`DistanceField`]; the free-space test of every generator below.
//! - [`sdf_candidates`]: seed 000 §3.1.1, Alg. 1: the skeleton of the distance field,
//!   clustered into probes.
//! - [`medial_candidates`]: seed 000 §3.1.2: area-weighted [`sample_surfaces`], masbcpp's
//!   shrinking balls, and clusters of the medial balls.
//! - [`inside_geometry`]: the "is this probe inside geometry" test placement reports use.
//!
//! ```
//! use probe_place::{ClassifyParams, ProbeSet, RegularGrid, classify_grid, inside_geometry};
//! use probe_place::{SdfParams, sdf_candidates};
//! use probe_scene::Scene;
//!
//! // `boxes` hides a closed box at every cell centre of a 4×2×4 grid (seed 003, Fig. 8.2).
//! let scene = Scene::open("builtin:boxes")?;
//! let grid = ProbeSet::from_spec("grid:4x2x4", &scene)?;
//! assert_eq!(grid.len(), 32);
//! assert!(grid.positions.iter().all(|&p| inside_geometry(&scene, p)));
//!
//! // DDGI relocation moves every probe out of its box, within 45 % of its cell.
//! let relocated = classify_grid(
//!     &scene,
//!     &RegularGrid::over_scene(&scene, [4, 2, 4])?,
//!     &ClassifyParams::default(),
//! )?;
//! assert_eq!(relocated.positions.len(), 32);
//! assert!(relocated.positions.iter().all(|&p| !inside_geometry(&scene, p)));
//!
//! // The SDF skeleton places far fewer probes, all in free space.
//! let params = SdfParams { voxel_size: 0.1, ..SdfParams::for_scene(&scene) };
//! let sdf = sdf_candidates(&scene, &params)?;
//! assert!(sdf.probes.len() < 32);
//! assert!(sdf.probes.positions.iter().all(|&p| sdf.voxels.is_free(p)));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! ## Design choices (candidates)
//!
//! - **Free space is what a flood fill reaches from outside the bounds** (seed 000's
//!   "bounding box minus the geometry"), so open, double-sided and non-manifold meshes work;
//!   sealed pockets are then decided by a front/back-face vote, so closed rooms (whose air no
//!   flood reaches) stay free and closed solids are inside. See [`VoxelGrid`] for the rules
//!   and why not a winding number or ray parity.
//! - **The skeleton is the ridge of the exact distance field** (voxels at least as far from
//!   geometry as both neighbours along some axis), beyond a clearance threshold: a thin
//!   skeleton as in seed 000's Fig. 3.3a rather than a thick eroded volume.
//! - **Clusters are what one probe sees.** Both generators cluster by greedy covering from
//!   the widest point down: a seed stands for the skeleton voxels (or medial balls) it sees
//!   within a multiple of its clearance. A convex room is one probe, every hidden region gets
//!   its own, and density follows the size of the space (a hall's probe reaches farther than
//!   a corridor's). Seed 000 clustered by "normals and curvature similarities" without
//!   details; visibility is what coverage needs.
//! - **Probes stay inside the scene's bounds and out of geometry**: a cluster mean outside
//!   free space, or failing [`inside_geometry`], moves to the nearest member that passes.
//! - **Deterministic**: the SDF skeleton uses no randomness; the medial axis draws its
//!   surface samples from a seeded PCG; the same input gives the same [`ProbeSet`] bytes.

mod candidate_error;
mod cluster;
mod grid;
mod medial;
mod probes;
mod sdf;
mod voxel;

pub use candidate_error::{CandidateError, ValidRange};
pub use cluster::ClusterStats;
pub use grid::{
    ClassifiedGrid, ClassifyParams, INSIDE_BACKFACE_SHARE, INSIDE_TEST_RAYS, MAX_GRID_DIM,
    MAX_GRID_PROBES, MAX_RELOCATION_FRACTION, RegularGrid, classify_grid, inside_geometry,
};
pub use medial::{
    MAX_SURFACE_SAMPLES, MedialBall, MedialCandidates, MedialParams, SurfacePoint,
    medial_candidates, sample_surfaces,
};
pub use probes::{PROBE_SET_FORMAT, ProbeSet, ProbeSetError};
pub use sdf::{SdfCandidates, SdfParams, sdf_candidates};
pub use voxel::{DistanceField, MAX_VOXELS, MAX_VOXELS_PER_AXIS, VoxelGrid, VoxelState};
