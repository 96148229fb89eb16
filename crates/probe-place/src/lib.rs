//! Automatic placement of radiance probes: candidate positions, the visibility atlas that
//! measures how well a probe set sees a scene, optimisers that move probes to see more, minimal
//! sets that keep only the probes a scene needs, and seed 002's irradiance-driven methods.
//!
//! ```
//! use probe_place::{
//!     Atlas, AtlasParams, BackfaceVote, CoverParams, GibbsParams, PlacementReport,
//!     free_space_grid, gibbs, minimal_cover,
//! };
//! use probe_scene::Scene;
//! use glam::Vec3;
//!
//! let scene = Scene::builtin("cornell")?;
//! // Where probes may stand, and a dense grid of such points.
//! let free = BackfaceVote::new(&scene);
//! let pool = free_space_grid(&free, 0.05);
//! // Equal-area texels of every surface some point of the pool sees.
//! let atlas = Atlas::build(&scene, &AtlasParams::for_texel_count(&scene, 1000), &pool)?;
//!
//! // As few probes as see every texel.
//! let set = minimal_cover(&atlas, &free, &pool, &CoverParams::full_coverage())?;
//! assert_eq!(set.coverage, 1.0);
//! assert!(set.positions.len() <= 8);
//!
//! // Or: move two hand-placed probes by Gibbs sampling to see more.
//! let start = [Vec3::new(0.1, 0.1, 0.1), Vec3::new(0.12, 0.1, 0.1)];
//! let moved = gibbs(&atlas, &free, &start, &GibbsParams { max_iterations: 5, ..GibbsParams::with_step(0.04) })?;
//! assert!(moved.coverage > atlas.coverage(&start));
//!
//! let report = PlacementReport::measure(
//!     "minimal-cover", serde_json::json!({}), &atlas, &free, &set.positions(), 0.0);
//! assert_eq!(report.probes_inside_geometry, 0);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! # Visibility atlas, optimisation, minimal sets and irradiance-driven placement
//!
//! **The atlas** ([`Atlas`], seed 000 §3.2.1). Instead of unwrapping the scene into a texture,
//! the surfaces are cut into equal-area point samples ("texels"): a triangle of area `A` gets
//! `⌊A / texel_size² + u⌋` of them (`u` seeded per triangle), so every texel stands for the same
//! area and coverage is a share of texels. A probe sees a texel when the segment between them
//! is unoccluded (one BVH shadow ray, [`probe_scene::Scene::occluded`]), the view cosine
//! exceeds a threshold (default 0.2, [`DEFAULT_MIN_VIEW_COSINE`]: views within 78.5° of the
//! normal; more grazing views give stretched, leaky probe texels) and the distance is within an
//! optional limit.
//!
//! **Which surfaces count** (the coverage rule, also in every [`PlacementReport`]). Front faces
//! of single-sided triangles and both faces of double-sided ones; alpha cut-outs are not
//! surface. Of those, [`Atlas::build`] keeps only the texels that at least one *reference
//! point* in free space sees (by default a dense [`free_space_grid`]). This drops faces inside
//! closed solids, the outer sides of a room's walls, the undersides of floors and gaps narrower
//! than the reference spacing, none of which a probe in free space can see well. "Full
//! coverage" means every kept texel is seen; a dense enough reference grid always reaches it, so
//! it is a target placements can meet, and its spacing is the resolution at which "visible from
//! free space" is judged.
//!
//! **Free space** ([`FreeSpace`], [`BackfaceVote`]): a point is inside geometry when more than a
//! quarter of 32 rays from it first hit the back of a single-sided triangle (DDGI's probe
//! classification). Open and double-sided meshes (a two-sided plane) have no inside. Probes
//! must also stay in the bounds and keep a small clearance from surfaces. Any voxel
//! classification (an SDF's free voxels) can implement the trait instead.
//!
//! **The reward** (eq. 3.1–3.2, [`RewardWeights`], [`AtlasState`]). A probe's score for a
//! texel it sees is `w1 · cos + w2 · min(d / scale, 1)`. By default a texel's fitness is its
//! *best* probe's score ([`TexelAggregation::BestProbe`]): eq. 3.2 as written sums over probes,
//! which rewards seeing the same large wall twice as much as covering a hidden corner; the sum
//! is available as [`TexelAggregation::SumOverProbes`]. `R` is reported as the mean texel
//! fitness. [`AtlasState`] keeps, per texel, which probes see it and its best and second-best
//! score, so "what if probe `k` moved there" costs one visibility query plus a merge of two
//! sorted view lists.
//!
//! **Optimisation** ([`descend`], [`gibbs`]). Descent is seed 000 §3.2.2 as described: every
//! probe moves at once to its best support probe `p + h·(±1, ±1, ±1)`. With a fixed step it
//! cannot stand still, so it ends up jumping between two positions (the oscillation seed 000
//! reports; `tests/optimize.rs` shows it, and shows twin probes oscillating in lockstep).
//! Gibbs sampling is Alg. 2 with §3.2.4's axis-by-axis linear importance sampling inside the
//! support cube and acceptance `(R_new / R_old)^β` (`β = 1` as in the seed). One choice of
//! ours: the sampling density is the reward of each support probe *minus the worst one's*, since
//! the raw reward differs by a fraction of a percent between the eight corners and would make
//! the sampling uniform. Both stop at full coverage or an iteration cap, never move a probe
//! out of free space, and return the best set met plus a per-iteration history (reward,
//! coverage, moves, positions) for charts.
//!
//! **Minimal sets** ([`prune_redundant`], [`minimal_cover`]). Pruning drops, weakest probe
//! first, every probe whose removal keeps coverage; the result is irredundant. The minimal
//! cover is lazy greedy set cover over a candidate pool (within `ln(texels) + 1` of optimal),
//! pruned, optionally refined by Gibbs when a budget stops it short of the target. With the
//! atlas's own reference grid as the pool, full coverage is always reached.
//!
//! **Seed 002** ([`spawn_and_merge`], [`gradient_ascent`], [`k_means`]), driven by a
//! [`LightingOracle`] (irradiance at a point and towards a direction) so that this crate does
//! not depend on a renderer; [`PointLightOracle`] is an analytic one. Probes are compared by the
//! luminance of the irradiance in the 26 directions of seed 002 §3.1.3, relative to the
//! brighter probe's brightest direction ([`contrast`]). Spawn and merge compares each probe
//! with its 6 nearest neighbours (all close pairs grow quadratically, as seed 002 found);
//! gradient ascent follows the "sum of directions times luminance" gradient, reverts steps that
//! land in the dark or outside free space (seed 002's second-order rule) and halves the step
//! when it overshoots; unlit probes become `k` k-means centres. Every random choice takes a
//! seed.

#![forbid(unsafe_code)]

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
