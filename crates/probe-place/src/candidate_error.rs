//! The error type of the candidate generators (grid, voxels, SDF skeleton, medial axis).

use std::fmt;

/// What went wrong while making candidate probe positions.
///
/// Every variant names the parameter or the scene at fault and says how to fix it.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum CandidateError {
    /// The scene has no triangles, so there is nothing to place probes around.
    ///
    /// Fix: load a scene with geometry; check [`Scene::warnings`](probe_scene::Scene::warnings)
    /// for primitives the loader skipped (points and lines carry no surfaces).
    #[error("scene `{scene}` has no triangles: there is nothing to place probes around")]
    EmptyScene {
        /// The scene's name.
        scene: String,
    },

    /// The voxel size is zero, negative or not a number.
    ///
    /// Fix: pass a positive, finite edge length in metres, typically 1/100 to 1/300 of the
    /// scene's largest extent (see [`VoxelGrid::build`](crate::candidates::VoxelGrid::build)).
    #[error("voxel_size must be a positive, finite length in metres, got {voxel_size}")]
    InvalidVoxelSize {
        /// The value given.
        voxel_size: f32,
    },

    /// The voxel grid over the scene would hold more voxels than
    /// [`MAX_VOXELS`](crate::candidates::MAX_VOXELS).
    ///
    /// Fix: use a larger voxel size (doubling it divides the count by eight).
    #[error(
        "voxel_size {voxel_size} m gives a {dims:?} voxel grid ({count} voxels), more than the \
         limit of {limit}: use a larger voxel size"
    )]
    TooManyVoxels {
        /// The voxel size asked for, in metres.
        voxel_size: f32,
        /// The grid dimensions it would give.
        dims: [u64; 3],
        /// Their product.
        count: u64,
        /// [`MAX_VOXELS`](crate::candidates::MAX_VOXELS).
        limit: u64,
    },

    /// Regular-grid dimensions with a zero, or beyond the caps
    /// ([`MAX_GRID_DIM`](crate::candidates::MAX_GRID_DIM) per axis, [`MAX_GRID_PROBES`](crate::candidates::MAX_GRID_PROBES)
    /// in all).
    ///
    /// Fix: give every axis at least one cell and stay within the caps; a grid that large
    /// is not a placement anyone can bake.
    #[error(
        "grid dimensions {dims:?} are invalid: each must lie in 1..={max_dim} and their product \
         must not exceed {max_probes}"
    )]
    InvalidGridDims {
        /// The dimensions given (x, y, z).
        dims: [u32; 3],
        /// [`MAX_GRID_DIM`](crate::candidates::MAX_GRID_DIM).
        max_dim: u32,
        /// [`MAX_GRID_PROBES`](crate::candidates::MAX_GRID_PROBES).
        max_probes: u64,
    },

    /// A box given for a grid is empty or not finite.
    ///
    /// Fix: pass a box with finite corners and `min ≤ max` on every axis.
    #[error("grid bounds {min:?}..{max:?} must be finite with min ≤ max on every axis")]
    InvalidBounds {
        /// The box's minimum corner.
        min: [f32; 3],
        /// The box's maximum corner.
        max: [f32; 3],
    },

    /// A numeric parameter lies outside its valid range (or is not a number).
    ///
    /// Fix: use a value in the range named in the message; each parameter's documentation
    /// gives its meaning and default.
    #[error("parameter `{parameter}` = {value} is invalid: it must be {expected}")]
    InvalidParameter {
        /// The parameter's name, as the field of its parameter struct.
        parameter: &'static str,
        /// The value given.
        value: f64,
        /// The valid range, in words.
        expected: ValidRange,
    },
}

/// The valid range of a parameter, for [`CandidateError::InvalidParameter`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum ValidRange {
    /// `> 0` and finite.
    Positive,
    /// `≥ 0` and finite.
    NonNegative,
    /// In `[0, 1]`.
    UnitInterval,
    /// At least one (a count).
    AtLeastOne,
    /// A count from 1 to the given maximum.
    CountUpTo(u64),
}

impl fmt::Display for ValidRange {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            ValidRange::Positive => "positive and finite",
            ValidRange::NonNegative => "non-negative and finite",
            ValidRange::UnitInterval => "in [0, 1]",
            ValidRange::AtLeastOne => "at least 1",
            ValidRange::CountUpTo(max) => return write!(f, "a count from 1 to {max}"),
        })
    }
}

/// Checks a float parameter against its range.
pub(crate) fn check_param(
    parameter: &'static str,
    value: f32,
    expected: ValidRange,
) -> Result<(), CandidateError> {
    let ok = match expected {
        ValidRange::Positive => value.is_finite() && value > 0.0,
        ValidRange::NonNegative => value.is_finite() && value >= 0.0,
        ValidRange::UnitInterval => (0.0..=1.0).contains(&value),
        ValidRange::AtLeastOne => value.is_finite() && value >= 1.0,
        ValidRange::CountUpTo(max) => value >= 1.0 && f64::from(value) <= max as f64,
    };
    if ok {
        Ok(())
    } else {
        Err(CandidateError::InvalidParameter {
            parameter,
            value: f64::from(value),
            expected,
        })
    }
}

/// Checks a count parameter (at least one).
pub(crate) fn check_count(parameter: &'static str, value: usize) -> Result<(), CandidateError> {
    if value >= 1 {
        Ok(())
    } else {
        Err(CandidateError::InvalidParameter {
            parameter,
            value: value as f64,
            expected: ValidRange::AtLeastOne,
        })
    }
}

/// Checks a count parameter against `1..=max`.
pub(crate) fn check_count_up_to(
    parameter: &'static str,
    value: usize,
    max: u64,
) -> Result<(), CandidateError> {
    if value >= 1 && value as u64 <= max {
        Ok(())
    } else {
        Err(CandidateError::InvalidParameter {
            parameter,
            value: value as f64,
            expected: ValidRange::CountUpTo(max),
        })
    }
}
