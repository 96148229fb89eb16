//! `probe_index`: the structures that tell a renderer which radiance probes to use where.
//!
//! - [`Tetrahedralization`]: 3-D Delaunay tetrahedralization of probe positions (Bowyer–Watson
//!   on exact predicates), barycentric point location by a remembering walk from a cached start
//!   and interpolation of per-probe values (seed 002 §3.2.1); [`insert_edge_probes`] adds probes
//!   where geometry cuts an edge (seed 002 §3.2.2).
//! - [`NearestProbe`] and [`VoronoiNeighbours`]: seed 000 §4.1's Voronoi-based selection — the
//!   nearest probe first, then per-texel Delaunay neighbours baked into octahedral maps.
//! - [`SparseVoxelOctree`]: seed 000 §4.2's octree of the best 4 visible probes per voxel.
//! - [`ProbeGrid`]: regular grids, the 8-probe cage and seed 003 Alg. 6's ordering.
//! - [`ProbeSelector`]: the one interface all three selection schemes implement ("which probes,
//!   in what order, for this ray at this point"), the CPU reference for the GPU tracer, which
//!   uploads the flat `Pod` arrays each structure exposes ([`TetRecord`], [`KdNode`],
//!   [`VoronoiNeighbours::table`], [`SvoHeader`] with its node words and payloads,
//!   [`GridParams`]).
//! - [`ProbeIndex`] builds them all and returns an [`IndexReport`] of counts, bytes and times.
//!
//! The crate needs no scene crate: scene queries go through the [`SceneGeometry`] trait. With
//! the `scene` feature, `probe_scene::Scene` implements it (BVH closest-hit and any-hit;
//! `probe-scene` comes without its glTF loader).
//!
//! Features: `scene` (off by default, as above) and `parallel` (default): octree builds,
//! Voronoi tables, edge casts and the Delaunay bookkeeping spread over rayon's thread pool.
//! Without `parallel` they run on the calling thread and give the same results.
//!
//! # Example
//!
//! ```
//! use glam::Vec3;
//! use probe_index::{ProbeGrid, ProbeQuery, ProbeSelector, Tetrahedralization};
//!
//! // A 3×3×3 grid of probes: maximally degenerate (cospherical cube corners), handled exactly.
//! let grid = ProbeGrid::new(Vec3::ZERO, Vec3::ONE, [3, 3, 3])?;
//! let probes = grid.positions();
//! let tets = Tetrahedralization::build(&probes)?;
//! tets.validate()?;
//!
//! // Interpolate a per-probe value (here a linear field, reproduced exactly).
//! let values: Vec<Vec3> = probes.iter().map(|p| *p * 2.0).collect();
//! let at = tets.locate(Vec3::new(0.5, 1.25, 1.75))?;
//! let v = tets.interpolate(&at, &values)?;
//! assert!((v - Vec3::new(1.0, 2.5, 3.5)).length() < 1e-5);
//!
//! // Which probes to trace a ray with, best first (seed 003 Alg. 6): the first one lies behind
//! // the point, looking along the ray.
//! let query = ProbeQuery { position: Vec3::new(0.5, 0.4, 0.6), direction: Vec3::X, failed_probe: None };
//! let order = grid.select(&query);
//! assert_eq!(order.len(), 8);
//! assert_eq!(grid.probe_position(order.as_slice()[0]), Vec3::new(0.0, 0.0, 1.0));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! # Design choices
//!
//! - **Exactness over epsilons.** Orientation and in-sphere signs come from Shewchuk's adaptive
//!   predicates (`robust`) on the f32 inputs (converted to f64 without rounding). Cospherical
//!   ties — every regular grid — are broken by the symbolic perturbation of Devillers & Teillaud
//!   (as in CGAL), which keeps every cavity star-shaped, makes the result independent of
//!   insertion order and never creates a flat tetrahedron. The hull is exact too: an infinite
//!   vertex with ghost tetrahedra on hull faces (no super-tetrahedron). Coplanar-with-hull
//!   insertions use an exact in-circle test built from an in-sphere test with a lifted point.
//! - **Speed.** Points are inserted in BRIO order with Hilbert-sorted rounds and renumbered so
//!   that neighbours in space are neighbours in memory; points are located by a remembering
//!   stochastic visibility walk from the last inserted tetrahedron; the cavity's new
//!   tetrahedra are glued by an open-addressing edge table. Duplicates are merged before
//!   insertion (every input index maps to the first index at its position).
//! - **Flat layouts.** Every structure is a few `Vec`s of `Pod` records or `u32` words, with the
//!   WGSL mirror in its documentation, so the GPU tracer uploads them as they are.
//! - **Octree memory.** Seed 000 stored one RGBA8 voxel per cell (15–243 MB, Table 5.2). Here a
//!   node is one `u32`; uniform subtrees (8 leaf children with the same best-4) merge into one
//!   leaf; identical payloads are stored once; a node whose children are all leaves stores 8
//!   payload indices of 8 or 16 bits. Merging is lossless. Two defaults bend seed 000's letter
//!   to let far more merge (each can be switched off in [`SvoOptions`]): empty voxels at most
//!   4 finest voxels wide next to geometry rank like the surface below them, and voxels from
//!   which no probe is visible (inside solids) may take their siblings' payload. On the
//!   built-in Cornell box at depth 9 this gives 1.3 MB against 80 MB for the full tree (see
//!   `BENCHMARKS.md`).
//! - **Octahedral directions** for the neighbour maps come from `probe-octa` (BRIEF's
//!   encode/decode, texel centres at `((i + 0.5) / N) · 2 − 1`), so the tracer's texel lookup
//!   and these tables agree by construction.
//! - **Errors, not panics**: non-finite input, too few or coplanar points, bad parameters give a
//!   `thiserror` enum per operation naming the item and saying how to fix it.

mod delaunay;
mod edge_cast;
mod error;
mod geometry;
mod grid;
mod index;
mod nearest;
mod par;
mod predicates;
mod rng;
mod selector;
mod svo;
mod voronoi;

pub use delaunay::{HullFace, Location, NO_NEIGHBOUR, TetRecord, Tetrahedralization};
pub use edge_cast::{EdgeCastOptions, EdgeCastResult, insert_edge_probes};
pub use error::{
    DelaunayError, EdgeCastError, GridError, IndexError, NeighbourError, QueryError, SvoError,
    ValidationError,
};
pub use geometry::{RayHit, SceneGeometry, triangle_overlaps_box};
pub use grid::{Cage, GridParams, ProbeGrid, next_cage_slot};
pub use index::{DelaunaySkipped, IndexOptions, IndexReport, ProbeIndex};
pub use nearest::{KdNode, NearestProbe};
pub use selector::{MAX_CANDIDATES, ProbeCandidates, ProbeQuery, ProbeSelector};
pub use svo::{SVO_LEAF_BIT, SVO_PACKED_BIT, SparseVoxelOctree, SvoHeader, SvoOptions, SvoStats};
pub use voronoi::{NEIGHBOURS_PER_TEXEL, NO_PROBE, VoronoiNeighbours, VoronoiSelector};
