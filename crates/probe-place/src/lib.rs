//! `probe_place`: work in progress; see the workspace README.

mod atlas;
mod irradiance;
mod minimal;
mod optimize;
mod report;

pub use atlas::{
    Atlas, AtlasError, AtlasParams, AtlasState, BACKFACE_VOTE_RAYS, BackfaceVote,
    DEFAULT_MIN_VIEW_COSINE, Evaluation, FreeSpace, MAX_TEXELS, ProbeView, RewardWeights,
    SurfaceSample, TexelAggregation, free_space_grid,
};
pub use irradiance::{
    GradientAscentParams, IrradianceError, IrradiancePlacement, LightingOracle, PointLightOracle,
    SpawnMergeParams, SpawnMergeStep, contrast, gradient_ascent, irradiance_gradient, k_means,
    sample_directions, spawn_and_merge,
};
pub use minimal::{
    CoverParams, MinimalSet, MinimalSetError, Pruned, minimal_cover, prune_redundant,
};
pub use optimize::{
    DescentParams, GibbsParams, IterationRecord, OptimizeError, Optimized, descend, gibbs,
};
pub use report::{COVERAGE_RULE, PlacementReport};
