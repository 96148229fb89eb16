//! Everything at once: the structures a renderer needs for a probe set, and a report of their
//! counts, sizes and build times for the CLI to print.

use std::fmt;
use std::time::{Duration, Instant};

use glam::Vec3;

use crate::delaunay::Tetrahedralization;
use crate::edge_cast::{EdgeCastOptions, insert_edge_probes};
use crate::error::{DelaunayError, IndexError};
use crate::geometry::SceneGeometry;
use crate::nearest::NearestProbe;
use crate::svo::{SparseVoxelOctree, SvoOptions, SvoStats};
use crate::voronoi::{VoronoiNeighbours, VoronoiSelector};

/// What [`ProbeIndex::build`] builds.
#[derive(Clone, Debug, PartialEq)]
pub struct IndexOptions {
    /// Seed 002's edge ray casts (adds probes where geometry cuts Delaunay edges); `None` skips.
    pub edge_casts: Option<EdgeCastOptions>,
    /// Texels per side of the Voronoi-sphere neighbour maps.
    pub neighbour_resolution: u32,
    /// The sparse voxel octree; `None` skips it.
    pub svo: Option<SvoOptions>,
}

impl Default for IndexOptions {
    fn default() -> Self {
        Self {
            edge_casts: None,
            neighbour_resolution: 16,
            svo: Some(SvoOptions::default()),
        }
    }
}

/// The indexing structures of one probe set.
#[derive(Clone, Debug)]
pub struct ProbeIndex {
    /// Probe positions: the ones given, then any added by edge casts.
    pub probes: Vec<Vec3>,
    /// Delaunay tetrahedralization of `probes`; `None` when they span no volume (fewer than 4
    /// distinct positions, or all on one plane or line: one probe per room is a placement a
    /// scene may need). Then there are no Voronoi neighbours or edge casts either, and the
    /// nearest-probe tree and the octree serve alone.
    pub tetrahedralization: Option<Tetrahedralization>,
    /// Nearest-probe k-d tree over `probes`.
    pub nearest: NearestProbe,
    /// Voronoi-sphere neighbour maps (with the tetrahedralization).
    pub neighbours: Option<VoronoiNeighbours>,
    /// The sparse voxel octree, if asked for.
    pub svo: Option<SparseVoxelOctree>,
}

/// Counts, bytes and build times of a [`ProbeIndex`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct IndexReport {
    /// Probes given.
    pub probes_given: usize,
    /// Probes added by edge casts.
    pub probes_added: usize,
    /// Rays cast along edges (0 if skipped).
    pub edge_rays: usize,
    /// Duplicate positions merged by the tetrahedralization.
    pub duplicates: usize,
    /// Tetrahedra.
    pub tetrahedra: usize,
    /// Convex-hull triangles.
    pub hull_faces: usize,
    /// Bytes of the tetrahedra and hull records.
    pub tetrahedra_bytes: usize,
    /// Bytes of the nearest-probe tree.
    pub nearest_bytes: usize,
    /// Bytes of the neighbour maps.
    pub neighbour_bytes: usize,
    /// Octree statistics (bytes in `bytes`), if built.
    pub svo: Option<SvoStats>,
    /// Why there is no tetrahedralization (the probes span no volume), if there is none.
    pub delaunay_skipped: Option<DelaunaySkipped>,
    /// Time of the first tetrahedralization.
    pub delaunay_time: Duration,
    /// Time of the edge casts, rebuild included.
    pub edge_cast_time: Duration,
    /// Time to build the nearest-probe tree.
    pub nearest_time: Duration,
    /// Time to bake the neighbour maps.
    pub neighbour_time: Duration,
    /// Time to build the octree.
    pub svo_time: Duration,
}

/// Why [`ProbeIndex::build`] made no tetrahedralization: the probes span no volume, so the
/// octree serves alone and there are no Voronoi neighbours. Displays as the message of the
/// matching [`DelaunayError`] (e.g. `all 9 distinct points are coplanar; …`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum DelaunaySkipped {
    /// Fewer than four distinct positions ([`DelaunayError::TooFewPoints`]).
    TooFewPoints {
        /// Number of distinct positions.
        distinct: usize,
        /// Number of probes given, duplicates included.
        given: usize,
    },
    /// All distinct positions lie on one line ([`DelaunayError::AllCollinear`]).
    AllCollinear {
        /// Number of distinct positions.
        distinct: usize,
    },
    /// All distinct positions lie in one plane ([`DelaunayError::AllCoplanar`]).
    AllCoplanar {
        /// Number of distinct positions.
        distinct: usize,
    },
}

impl From<DelaunaySkipped> for DelaunayError {
    fn from(skipped: DelaunaySkipped) -> DelaunayError {
        match skipped {
            DelaunaySkipped::TooFewPoints { distinct, given } => {
                DelaunayError::TooFewPoints { distinct, given }
            }
            DelaunaySkipped::AllCollinear { distinct } => DelaunayError::AllCollinear { distinct },
            DelaunaySkipped::AllCoplanar { distinct } => DelaunayError::AllCoplanar { distinct },
        }
    }
}

impl fmt::Display for DelaunaySkipped {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        DelaunayError::from(*self).fmt(f)
    }
}

impl ProbeIndex {
    /// Builds every structure for `probes` in `geometry`.
    ///
    /// # Errors
    /// [`IndexError`] naming the stage that failed.
    pub fn build(
        probes: &[Vec3],
        geometry: &dyn SceneGeometry,
        options: &IndexOptions,
    ) -> Result<(Self, IndexReport), IndexError> {
        let mut report = IndexReport {
            probes_given: probes.len(),
            ..IndexReport::default()
        };
        let t = Instant::now();
        let mut tetrahedralization = match Tetrahedralization::build(probes) {
            Ok(tetrahedralization) => Some(tetrahedralization),
            Err(DelaunayError::TooFewPoints { distinct, given }) if !probes.is_empty() => {
                report.delaunay_skipped = Some(DelaunaySkipped::TooFewPoints { distinct, given });
                None
            }
            Err(DelaunayError::AllCollinear { distinct }) if !probes.is_empty() => {
                report.delaunay_skipped = Some(DelaunaySkipped::AllCollinear { distinct });
                None
            }
            Err(DelaunayError::AllCoplanar { distinct }) if !probes.is_empty() => {
                report.delaunay_skipped = Some(DelaunaySkipped::AllCoplanar { distinct });
                None
            }
            Err(error) => return Err(error.into()),
        };
        report.delaunay_time = t.elapsed();
        let mut all = probes.to_vec();
        if let (Some(edge), Some(tets)) = (&options.edge_casts, &tetrahedralization) {
            let t = Instant::now();
            let result = insert_edge_probes(tets, geometry, edge)?;
            report.edge_cast_time = t.elapsed();
            report.probes_added = result.added;
            report.edge_rays = result.rays_cast;
            all = result.probes;
            tetrahedralization = Some(result.tetrahedralization);
        }
        if let Some(tets) = &tetrahedralization {
            report.duplicates = tets.duplicate_count();
            report.tetrahedra = tets.tetrahedra().len();
            report.hull_faces = tets.hull_faces().len();
            report.tetrahedra_bytes = tets.memory_bytes();
        }
        let t = Instant::now();
        let nearest = NearestProbe::new(&all);
        report.nearest_time = t.elapsed();
        report.nearest_bytes = nearest.memory_bytes();
        let t = Instant::now();
        let neighbours = match &tetrahedralization {
            Some(tets) => Some(VoronoiNeighbours::bake(tets, options.neighbour_resolution)?),
            None => None,
        };
        report.neighbour_time = t.elapsed();
        report.neighbour_bytes = neighbours
            .as_ref()
            .map_or(0, VoronoiNeighbours::memory_bytes);
        let svo = match &options.svo {
            Some(svo_options) => {
                let t = Instant::now();
                let svo = SparseVoxelOctree::build(geometry, &all, svo_options)?;
                report.svo_time = t.elapsed();
                report.svo = Some(svo.stats().clone());
                Some(svo)
            }
            None => None,
        };
        Ok((
            Self {
                probes: all,
                tetrahedralization,
                nearest,
                neighbours,
                svo,
            },
            report,
        ))
    }

    /// Seed 000's Voronoi-based selector over this index (`None` without a tetrahedralization).
    pub fn voronoi_selector(&self) -> Option<VoronoiSelector<'_>> {
        Some(VoronoiSelector {
            positions: &self.probes,
            nearest: &self.nearest,
            neighbours: self.neighbours.as_ref()?,
        })
    }
}

fn mib(bytes: usize) -> f64 {
    bytes as f64 / (1024.0 * 1024.0)
}

impl fmt::Display for IndexReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "probes: {} given, {} added by {} edge rays, {} duplicates merged",
            self.probes_given, self.probes_added, self.edge_rays, self.duplicates
        )?;
        match &self.delaunay_skipped {
            Some(why) => writeln!(
                f,
                "delaunay: none ({why}); no Voronoi neighbours, the octree serves alone"
            )?,
            None => writeln!(
                f,
                "delaunay: {} tetrahedra, {} hull faces, {:.3} MiB, {:.3} s (+{:.3} s edge casts)",
                self.tetrahedra,
                self.hull_faces,
                mib(self.tetrahedra_bytes),
                self.delaunay_time.as_secs_f64(),
                self.edge_cast_time.as_secs_f64()
            )?,
        }
        writeln!(
            f,
            "nearest-probe tree: {:.3} MiB, {:.3} s",
            mib(self.nearest_bytes),
            self.nearest_time.as_secs_f64()
        )?;
        writeln!(
            f,
            "voronoi neighbours: {:.3} MiB, {:.3} s",
            mib(self.neighbour_bytes),
            self.neighbour_time.as_secs_f64()
        )?;
        match &self.svo {
            Some(s) => writeln!(
                f,
                "svo: finest voxel {:.4}, {} surface + {} empty leaves ({} without a visible probe), \
                 {} node words + {} packed blocks + {} payloads after merging, {:.3} MiB \
                 (full tree {:.3} MiB), {:.3} s",
                s.finest_voxel_size,
                s.surface_leaves,
                s.empty_leaves,
                s.leaves_without_probe,
                s.nodes,
                s.blocks,
                s.payloads,
                mib(s.bytes),
                mib(s.full_bytes),
                self.svo_time.as_secs_f64()
            ),
            None => writeln!(f, "svo: not built"),
        }
    }
}
