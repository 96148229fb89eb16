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
//!
//! # Visibility atlas, optimisation, minimal sets and irradiance-driven placement
//!
//! How well a probe set sees the scene ([`Atlas`], [`PlacementReport`]), moving probes to see
//! more ([`descend`], [`gibbs`]), keeping only the probes a scene needs ([`prune_redundant`],
//! [`minimal_cover`]), and seed 002's lighting-driven placement ([`spawn_and_merge`],
//! [`gradient_ascent`]).
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
//! **Free space** ([`FreeSpace`]). [`BackfaceVote`] is [`inside_geometry`]'s ray vote (more
//! than a quarter of 64 rays hit the back of a single-sided triangle) plus the bounds and a
//! small clearance from surfaces; open and double-sided meshes (a two-sided plane) have no
//! inside. [`VoxelFreeSpace`] uses the SDF generator's [`VoxelGrid`] instead. Either decides
//! where optimisers may move probes, which reference points an atlas uses and what a report
//! counts as "inside geometry".
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
//!
//! # End to end
//!
//! [`pipeline::place`] runs one method (grid, relocated grid, SDF, medial axis, seed 002, or
//! the minimal cover), an optional optimiser and an optional budget or coverage target, and
//! measures the result on one visibility atlas, as `probes place` and probe-eval's sweep do;
//! [`pipeline::fill_to_budget`] spends a budget left over after a cover.
//!
//! # Features
//!
//! - `parallel` (default): voxelization, distance fields, atlases, clustering and optimisation
//!   spread over rayon's thread pool. Without it they run on the calling thread and give the
//!   same results.
//!
//! The crate depends on `probe-scene` without its glTF loader: it needs geometry and ray
//! casting only. Load files through `probe-scene` (its default `gltf` feature) in the crate that
//! calls this one.

#![forbid(unsafe_code)]

mod atlas;
mod candidate_error;
mod cluster;
mod grid;
mod irradiance;
mod medial;
mod minimal;
mod optimize;
mod par;
pub mod pipeline;
mod probes;
mod report;
mod sdf;
mod voxel;

pub use atlas::{
    Atlas, AtlasError, AtlasParams, AtlasState, BackfaceVote, DEFAULT_MIN_VIEW_COSINE, Evaluation,
    FreeSpace, MAX_TEXELS, ProbeView, RewardWeights, SurfaceSample, TexelAggregation,
    VoxelFreeSpace, free_space_grid,
};
pub use candidate_error::{CandidateError, ValidRange};
pub use cluster::ClusterStats;
pub use grid::{
    ClassifiedGrid, ClassifyParams, INSIDE_BACKFACE_SHARE, INSIDE_TEST_RAYS, MAX_GRID_DIM,
    MAX_GRID_PROBES, MAX_RELOCATION_FRACTION, RegularGrid, classify_grid, inside_geometry,
};
pub use irradiance::{
    GradientAscentParams, IrradianceError, IrradiancePlacement, LightingOracle, PointLightOracle,
    SpawnMergeParams, SpawnMergeStep, contrast, gradient_ascent, irradiance_gradient, k_means,
    sample_directions, spawn_and_merge,
};
pub use medial::{
    MAX_SURFACE_SAMPLES, MedialBall, MedialCandidates, MedialParams, SurfacePoint,
    medial_candidates, sample_surfaces,
};
pub use minimal::{
    CoverParams, MinimalSet, MinimalSetError, Pruned, minimal_cover, prune_redundant,
};
pub use optimize::{
    DescentParams, GibbsParams, IterationRecord, OptimizeError, Optimized, descend, gibbs,
};
pub use probes::{PROBE_SET_FORMAT, ProbeSet, ProbeSetError};
pub use report::{COVERAGE_RULE, PlacementReport};
pub use sdf::{SdfCandidates, SdfParams, sdf_candidates};
pub use voxel::{DistanceField, MAX_VOXELS, MAX_VOXELS_PER_AXIS, VoxelGrid, VoxelState};
