//! Errors, one enum per operation (as wgpu does); each variant says how to fix it (as parry does).

use glam::Vec3;
use thiserror::Error;

/// Why a Delaunay tetrahedralization could not be built.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum DelaunayError {
    /// An input point has a NaN or infinite coordinate.
    ///
    /// Fix: remove or repair the point at `index` before indexing (probe placement should never
    /// produce one; check the scene's bounds and the placement parameters).
    #[error("probe position {index} is not finite: {position}")]
    NonFinitePoint {
        /// Index of the offending point in the input slice.
        index: usize,
        /// Its value.
        position: Vec3,
    },
    /// Fewer than four distinct points were given, so no tetrahedron exists.
    ///
    /// Fix: supply at least four probes that are not all in one plane (duplicates count once).
    #[error(
        "a tetrahedralization needs at least 4 distinct points; got {distinct} (of {given} given)"
    )]
    TooFewPoints {
        /// Number of distinct positions.
        distinct: usize,
        /// Number of input points, duplicates included.
        given: usize,
    },
    /// All distinct points lie on one line.
    ///
    /// Fix: add probes off that line (a probe set must span a volume to be tetrahedralized).
    #[error("all {distinct} distinct points are collinear; add points off the line")]
    AllCollinear {
        /// Number of distinct positions.
        distinct: usize,
    },
    /// All distinct points lie in one plane (e.g. probes placed at one height only).
    ///
    /// Fix: add at least one probe off that plane, for instance a second layer above the first.
    #[error("all {distinct} distinct points are coplanar; add at least one point off the plane")]
    AllCoplanar {
        /// Number of distinct positions.
        distinct: usize,
    },
    /// More points than the 32-bit tetrahedron links can address (100 million).
    ///
    /// Fix: split the scene into regions of fewer probes each.
    #[error("{given} points exceed the limit of {limit}")]
    TooManyPoints {
        /// Number of input points.
        given: usize,
        /// The largest supported count.
        limit: usize,
    },
}

/// Why a point query (location, interpolation, selection) was refused.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum QueryError {
    /// The query position has a NaN or infinite coordinate.
    ///
    /// Fix: check the ray or object position that produced it.
    #[error("query position is not finite: {position}")]
    NonFinitePosition {
        /// The position given.
        position: Vec3,
    },
    /// The per-probe value array does not have one entry per input probe.
    ///
    /// Fix: pass exactly one value (or one `stride`-long block) per probe given to the build,
    /// duplicates included.
    #[error("expected values for {expected} probes, got {got}")]
    ValueCountMismatch {
        /// Number of probes given to the build.
        expected: usize,
        /// Number of values (or blocks) supplied.
        got: usize,
    },
    /// The output slice of a strided interpolation is not `stride` long.
    ///
    /// Fix: pass an output slice with exactly `stride` elements.
    #[error("output holds {got} values, stride is {stride}")]
    OutputLengthMismatch {
        /// The stride (values per probe).
        stride: usize,
        /// Length of the output slice.
        got: usize,
    },
}

/// What [`crate::Tetrahedralization::validate`] found wrong (should never happen; a bug report
/// with the input points is welcome).
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum ValidationError {
    /// A tetrahedron is flat or inverted.
    ///
    /// Fix: none on the caller's side; report the input.
    #[error("tetrahedron {tetrahedron} is not positively oriented")]
    NotPositive {
        /// The tetrahedron's index.
        tetrahedron: usize,
    },
    /// Neighbour links are not symmetric or do not share a face.
    ///
    /// Fix: none on the caller's side; report the input.
    #[error("tetrahedron {tetrahedron} face {face}: neighbour link is not mutual")]
    BrokenAdjacency {
        /// The tetrahedron's index.
        tetrahedron: usize,
        /// The face (opposite this vertex slot).
        face: usize,
    },
    /// A neighbour's opposite vertex lies strictly inside a tetrahedron's circumsphere.
    ///
    /// Fix: none on the caller's side; report the input.
    #[error("tetrahedron {tetrahedron} face {face}: not locally Delaunay")]
    NotDelaunay {
        /// The tetrahedron's index.
        tetrahedron: usize,
        /// The face whose neighbour violates the empty-sphere property.
        face: usize,
    },
    /// The hull faces are inconsistent (not one per open face, or not convex).
    ///
    /// Fix: none on the caller's side; report the input.
    #[error("hull face {hull_face} is inconsistent")]
    BadHull {
        /// The hull face's index.
        hull_face: usize,
    },
    /// A distinct input point is not a vertex of any tetrahedron.
    ///
    /// Fix: none on the caller's side; report the input.
    #[error("point {point} is missing from the tetrahedralization")]
    MissingVertex {
        /// Input index of the point.
        point: usize,
    },
}

/// Why a regular probe grid was refused.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum GridError {
    /// An axis has fewer than two probes, so no 8-probe cage exists.
    ///
    /// Fix: give every axis at least 2 probes.
    #[error("grid axis {axis} has {count} probes; every axis needs at least 2")]
    TooFewProbes {
        /// Axis (0 = x, 1 = y, 2 = z).
        axis: usize,
        /// The count given.
        count: u32,
    },
    /// A spacing is zero, negative or not finite.
    ///
    /// Fix: pass positive, finite spacings.
    #[error("grid spacing on axis {axis} is {value}; it must be positive and finite")]
    BadSpacing {
        /// Axis (0 = x, 1 = y, 2 = z).
        axis: usize,
        /// The spacing given.
        value: f32,
    },
    /// The origin has a NaN or infinite coordinate.
    ///
    /// Fix: pass a finite origin.
    #[error("grid origin {origin} is not finite")]
    NonFiniteOrigin {
        /// The origin given.
        origin: Vec3,
    },
    /// The grid holds more probes than 32-bit indices can address.
    ///
    /// Fix: use a coarser grid.
    #[error("grid of {count} probes exceeds the 32-bit index range")]
    TooLarge {
        /// The product of the three counts.
        count: u64,
    },
}

/// Why Voronoi-sphere neighbour textures could not be baked.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum NeighbourError {
    /// The octahedral resolution is zero or too large.
    ///
    /// Fix: use a resolution between 1 and 4096 texels per side (seed 000 bakes into the probe
    /// texture's own resolution; 16–64 is plenty for 4 neighbours).
    #[error("octahedral resolution {resolution} is outside 1..=4096")]
    BadResolution {
        /// The resolution given.
        resolution: u32,
    },
}

/// Why a sparse voxel octree could not be built.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum SvoError {
    /// The requested depth is outside the supported range.
    ///
    /// Fix: use a depth between 1 and 15 (the finest voxel is the scene cube's size / 2^depth).
    #[error("octree depth {depth} is outside 1..=15")]
    BadDepth {
        /// The depth given.
        depth: u32,
    },
    /// No probes were given.
    ///
    /// Fix: place probes first; every leaf must name at least one probe.
    #[error("no probes to bake into the octree")]
    NoProbes,
    /// A probe position has a NaN or infinite coordinate.
    ///
    /// Fix: remove or repair the probe at `index`.
    #[error("probe {index} is not finite: {position}")]
    NonFiniteProbe {
        /// Index of the probe.
        index: usize,
        /// Its position.
        position: Vec3,
    },
    /// A scene triangle has a NaN or infinite vertex.
    ///
    /// Fix: repair the scene (the loader should have refused it).
    #[error("scene triangle {index} has a non-finite vertex")]
    NonFiniteTriangle {
        /// Index of the triangle in the geometry.
        index: usize,
    },
    /// The candidate count per leaf is zero.
    ///
    /// Fix: consider at least 1 candidate probe per leaf (64 is the default).
    #[error("max_candidates must be at least 1")]
    NoCandidates,
}

/// Why the edge ray casts of seed 002 §3.2.2 could not run.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum EdgeCastError {
    /// A fraction parameter is outside its range.
    ///
    /// Fix: `min_edge_fraction` must be in [0, 0.5) and `surface_offset_fraction` in
    /// [0, `min_edge_fraction`]; `min_abs_cosine` in [0, 1].
    #[error("edge-cast parameter {name} = {value} is out of range")]
    BadParameter {
        /// The parameter's name.
        name: &'static str,
        /// The value given.
        value: f32,
    },
    /// Rebuilding the tetrahedralization with the added probes failed.
    ///
    /// Fix: see the inner error.
    #[error("rebuilding the tetrahedralization failed: {0}")]
    Delaunay(#[from] DelaunayError),
}

/// Why [`crate::ProbeIndex::build`] failed; names the stage.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum IndexError {
    /// The tetrahedralization failed.
    ///
    /// Fix: see the inner error.
    #[error("Delaunay tetrahedralization: {0}")]
    Delaunay(#[from] DelaunayError),
    /// The edge ray casts failed.
    ///
    /// Fix: see the inner error.
    #[error("edge ray casts: {0}")]
    EdgeCast(#[from] EdgeCastError),
    /// The neighbour textures failed.
    ///
    /// Fix: see the inner error.
    #[error("Voronoi-sphere neighbours: {0}")]
    Neighbours(#[from] NeighbourError),
    /// The sparse voxel octree failed.
    ///
    /// Fix: see the inner error.
    #[error("sparse voxel octree: {0}")]
    Svo(#[from] SvoError),
}
