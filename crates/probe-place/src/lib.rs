//! `probe_place`: automatic placement of radiance probes in a 3-D scene.
//!
//! Engines place light-field probes by hand or in wasteful regular grids. This crate makes
//! probe positions from the scene's geometry ([`probe_scene::Scene`]) and returns them as a
//! [`ProbeSet`], saved as `probes/1` JSON.
//!
//! # Modules
//!
//! The steps of a placement, as seed 000 takes them, one module each:
//!
//! - [`candidates`]: where probes could go: regular grids with DDGI classification and
//!   relocation, voxels and the SDF skeleton, the medial axis, the inside-geometry test.
//! - [`atlas`]: how well probes see the scene: the visibility atlas, free space, the reward
//!   and the [`PlacementReport`](atlas::PlacementReport).
//! - [`optimize`]: moving probes to see more: descent and Gibbs sampling.
//! - [`minimal`]: keeping only the probes a scene needs: pruning and the minimal cover.
//! - [`irradiance`]: seed 002's lighting-driven methods and the [`LightingOracle`](irradiance::LightingOracle)
//!   they take.
//! - [`pipeline`]: all of it end to end ([`pipeline::place`], budgets and fills).
//!
//! At the root: [`ProbeSet`], the output and its `probes/1` file, and [`PlacementMethod`],
//! how a set was made (the method with its parameters, typed).
//!
//! # Geometry you bring
//!
//! Everything here reads a [`probe_scene::Scene`]: its bounds, triangles, the materials'
//! `double_sided` flag and alpha cut-outs, `closest_hit`, `occluded` and its name. An engine
//! builds one from its own triangles with [`Scene::from_triangles`](probe_scene::Scene::from_triangles);
//! this crate takes `probe-scene` without its glTF loader, so
//! `cargo tree -p probe-place --no-default-features -e normal` lists no gltf or image.
//!
//! ```
//! use glam::{Vec2, Vec3};
//! use probe_place::ProbeSet;
//! use probe_place::candidates::inside_geometry;
//! use probe_scene::{Material, Scene, Triangle};
//!
//! // An engine's room: a 4 m × 4 m floor facing up and a ceiling 3 m above it facing down.
//! let triangle = |positions: [Vec3; 3], normal: Vec3| Triangle {
//!     positions,
//!     normals: [normal; 3],
//!     uvs: [Vec2::ZERO; 3],
//!     material: 0,
//! };
//! let [a, b, c, d] = [[0.0, 0.0], [0.0, 4.0], [4.0, 4.0], [4.0, 0.0]]
//!     .map(|[x, z]| Vec3::new(x, 0.0, z));
//! let up = Vec3::new(0.0, 3.0, 0.0);
//! let triangles = vec![
//!     triangle([a, b, c], Vec3::Y),
//!     triangle([a, c, d], Vec3::Y),
//!     triangle([a + up, c + up, b + up], -Vec3::Y),
//!     triangle([a + up, d + up, c + up], -Vec3::Y),
//! ];
//! let materials = vec![Material::diffuse("plaster", Vec3::splat(0.7))];
//! let scene = Scene::from_triangles("my-room", triangles, materials, Vec::new(), Vec::new())?;
//!
//! let grid = ProbeSet::from_spec("grid:2x1x2", &scene)?;
//! assert_eq!(grid.len(), 4);
//! assert!(grid.positions.iter().all(|&p| p.y == 1.5 && !inside_geometry(&scene, p)));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! # Candidates
//!
//! - [`RegularGrid`](candidates::RegularGrid): the baseline, probes at the cell centres of a division of the scene's
//!   bounds (`grid:4x2x4` in [`ProbeSet::from_spec`]); [`classify_grid`](candidates::classify_grid) is the fair
//!   baseline, DDGI-style classification (probes inside geometry switched off) and relocation
//!   (probes moved at most 45 % of a cell towards free space).
//! - [`VoxelGrid`](candidates::VoxelGrid): the scene voxelized, each voxel free, surface or inside a solid, with an
//!   exact Euclidean [`DistanceField`](candidates::DistanceField); the free-space test of every generator below.
//! - [`sdf_candidates`](candidates::sdf_candidates): seed 000 §3.1.1, Alg. 1: the skeleton of the distance field,
//!   clustered into probes.
//! - [`medial_candidates`](candidates::medial_candidates): seed 000 §3.1.2: area-weighted [`sample_surfaces`](candidates::sample_surfaces), masbcpp's
//!   shrinking balls, and clusters of the medial balls.
//! - [`inside_geometry`](candidates::inside_geometry): the "is this probe inside geometry" test placement reports use.
//!
//! ```
//! use probe_place::ProbeSet;
//! use probe_place::candidates::{ClassifyParams, RegularGrid, classify_grid, inside_geometry};
//! use probe_place::candidates::{SdfParams, sdf_candidates};
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
//!   flood reaches) stay free and closed solids are inside. See [`VoxelGrid`](candidates::VoxelGrid) for the rules
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
//!   free space, or failing [`inside_geometry`](candidates::inside_geometry), moves to the nearest member that passes.
//! - **Deterministic**: the SDF skeleton uses no randomness; the medial axis draws its
//!   surface samples from a seeded PCG; the same input gives the same [`ProbeSet`] bytes.
//!
//! # Visibility atlas, optimisation, minimal sets and irradiance-driven placement
//!
//! How well a probe set sees the scene ([`Atlas`](atlas::Atlas), [`PlacementReport`](atlas::PlacementReport)), moving probes to see
//! more ([`descend`](optimize::descend), [`gibbs`](optimize::gibbs)), keeping only the probes a scene needs ([`prune_redundant`](minimal::prune_redundant),
//! [`minimal_cover`](minimal::minimal_cover)), and seed 002's lighting-driven placement ([`spawn_and_merge`](irradiance::spawn_and_merge),
//! [`gradient_ascent`](irradiance::gradient_ascent)).
//!
//! ```
//! use probe_place::atlas::{Atlas, AtlasParams, BackfaceVote, PlacementReport, free_space_grid};
//! use probe_place::minimal::{CoverParams, minimal_cover};
//! use probe_place::optimize::{GibbsParams, gibbs};
//! use probe_place::PlacementMethod;
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
//! let method = PlacementMethod::Recorded {
//!     name: "minimal-cover".into(),
//!     parameters: serde_json::Map::new(),
//! };
//! let report = PlacementReport::measure(method, &atlas, &free, &set.positions(), 0.0);
//! assert_eq!(report.probes_inside_geometry, 0);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! **The atlas** ([`Atlas`](atlas::Atlas), seed 000 §3.2.1). Instead of unwrapping the scene into a texture,
//! the surfaces are cut into equal-area point samples ("texels"): a triangle of area `A` gets
//! `⌊A / texel_size² + u⌋` of them (`u` seeded per triangle), so every texel stands for the same
//! area and coverage is a share of texels. A probe sees a texel when the segment between them
//! is unoccluded (one BVH shadow ray, [`probe_scene::Scene::occluded`]), the view cosine
//! exceeds a threshold (default 0.2, [`DEFAULT_MIN_VIEW_COSINE`](atlas::DEFAULT_MIN_VIEW_COSINE): views within 78.5° of the
//! normal; more grazing views give stretched, leaky probe texels) and the distance is within an
//! optional limit.
//!
//! **Which surfaces count** (the coverage rule, also in every [`PlacementReport`](atlas::PlacementReport)). Front faces
//! of single-sided triangles and both faces of double-sided ones; alpha cut-outs are not
//! surface. Of those, [`Atlas::build`](atlas::Atlas::build) keeps only the texels that at least one *reference
//! point* in free space sees (by default a dense [`free_space_grid`](atlas::free_space_grid)). This drops faces inside
//! closed solids, the outer sides of a room's walls, the undersides of floors and gaps narrower
//! than the reference spacing, none of which a probe in free space can see well. "Full
//! coverage" means every kept texel is seen; a dense enough reference grid always reaches it, so
//! it is a target placements can meet, and its spacing is the resolution at which "visible from
//! free space" is judged.
//!
//! **Free space** ([`FreeSpace`](atlas::FreeSpace)). [`BackfaceVote`](atlas::BackfaceVote) is [`inside_geometry`](candidates::inside_geometry)'s ray vote (more
//! than a quarter of 64 rays hit the back of a single-sided triangle) plus the bounds and a
//! small clearance from surfaces; open and double-sided meshes (a two-sided plane) have no
//! inside. [`VoxelFreeSpace`](atlas::VoxelFreeSpace) uses the SDF generator's [`VoxelGrid`](candidates::VoxelGrid) instead. Either decides
//! where optimisers may move probes, which reference points an atlas uses and what a report
//! counts as "inside geometry".
//!
//! **The reward** (eq. 3.1–3.2, [`RewardWeights`](atlas::RewardWeights), [`AtlasState`](atlas::AtlasState)). A probe's score for a
//! texel it sees is `w1 · cos + w2 · min(d / scale, 1)`. By default a texel's fitness is its
//! *best* probe's score ([`TexelAggregation::BestProbe`](atlas::TexelAggregation::BestProbe)): eq. 3.2 as written sums over probes,
//! which rewards seeing the same large wall twice as much as covering a hidden corner; the sum
//! is available as [`TexelAggregation::SumOverProbes`](atlas::TexelAggregation::SumOverProbes). `R` is reported as the mean texel
//! fitness. [`AtlasState`](atlas::AtlasState) keeps, per texel, which probes see it and its best and second-best
//! score, so "what if probe `k` moved there" costs one visibility query plus a merge of two
//! sorted view lists.
//!
//! **Optimisation** ([`descend`](optimize::descend), [`gibbs`](optimize::gibbs)). Descent is seed 000 §3.2.2 as described: every
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
//! **Minimal sets** ([`prune_redundant`](minimal::prune_redundant), [`minimal_cover`](minimal::minimal_cover)). Pruning drops, weakest probe
//! first, every probe whose removal keeps coverage; the result is irredundant. The minimal
//! cover is lazy greedy set cover over a candidate pool (within `ln(texels) + 1` of optimal),
//! pruned, optionally refined by Gibbs when a budget stops it short of the target. With the
//! atlas's own reference grid as the pool, full coverage is always reached.
//!
//! **Seed 002** ([`spawn_and_merge`](irradiance::spawn_and_merge), [`gradient_ascent`](irradiance::gradient_ascent), [`k_means`](irradiance::k_means)), driven by a
//! [`LightingOracle`](irradiance::LightingOracle) (irradiance at a point and towards a direction) so that this crate does
//! not depend on a renderer; [`PointLightOracle`](irradiance::PointLightOracle) is an analytic one. Probes are compared by the
//! luminance of the irradiance in the 26 directions of seed 002 §3.1.3, relative to the
//! brighter probe's brightest direction ([`contrast`](irradiance::contrast)). Spawn and merge compares each probe
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
//! [`pipeline::fill_to_budget`] spends a budget left over after a cover on the probes that
//! read best ([`atlas::read_score`]).
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

pub mod atlas;
mod candidate_error;
pub mod candidates;
mod cluster;
mod grid;
pub mod irradiance;
mod medial;
pub mod minimal;
pub mod optimize;
mod par;
pub mod pipeline;
mod probes;
mod provenance;
pub mod region;
mod report;
mod sdf;
pub mod viewers;
mod voxel;

pub use probes::{PROBE_SET_FORMAT, ProbeSet, ProbeSetError};
pub use provenance::PlacementMethod;
