//! Step 1 of a placement: candidate probe positions from the scene's geometry (seed 000 §3.1).
//!
//! - [`RegularGrid`]: the baseline, probes at the cell centres of a division of the scene's
//!   bounds; [`classify_grid`] is DDGI-style classification and relocation.
//! - [`VoxelGrid`] and its [`DistanceField`]: the voxelized scene and the free-space test of
//!   the generators below.
//! - [`sdf_candidates`]: the skeleton of the distance field, clustered into probes.
//! - [`medial_candidates`]: area-weighted [`sample_surfaces`], shrinking balls and clusters of
//!   the medial balls.
//! - [`inside_geometry`]: the "is this probe inside geometry" test placement reports use.
//!
//! Every generator fails with a [`CandidateError`] naming the parameter and its
//! [`ValidRange`].

pub use crate::candidate_error::{CandidateError, ValidRange};
pub use crate::cluster::ClusterStats;
pub use crate::grid::{
    ClassifiedGrid, ClassifyParams, INSIDE_BACKFACE_SHARE, INSIDE_TEST_RAYS, MAX_GRID_DIM,
    MAX_GRID_PROBES, MAX_RELOCATION_FRACTION, RegularGrid, classify_grid, inside_geometry,
};
pub use crate::medial::{
    MAX_SURFACE_SAMPLES, MedialBall, MedialCandidates, MedialParams, SurfacePoint,
    medial_candidates, sample_surfaces,
};
pub use crate::sdf::{SdfCandidates, SdfParams, sdf_candidates};
pub use crate::voxel::{DistanceField, MAX_VOXELS, MAX_VOXELS_PER_AXIS, VoxelGrid, VoxelState};
