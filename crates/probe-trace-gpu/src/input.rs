//! What the tracers take: probe maps as plain slices, and the selection structures of
//! `probe-index`.

use glam::{Vec2, Vec3};
use probe_index::{
    NearestProbe, ProbeGrid, SparseVoxelOctree, Tetrahedralization, VoronoiNeighbours,
};

/// The baked probes a ray is traced through: per probe an `N×N` octahedral map of radial
/// distance, surface normal and radiance, each stored padded (`(N+2)²` texels, the layout of
/// [`probe_octa::OctaLayout`]), probes one after another.
///
/// Texel `i` of probe `p` is element `p·(N+2)² + i` of each slice. Borders are not read by the
/// tracer (it reads interior texels only), so they may hold anything finite.
#[derive(Clone, Copy, Debug)]
pub struct LightField<'a> {
    /// Interior texels per side, `N`: a power of two from 8 to 4096.
    pub resolution: u32,
    /// Probe centres, world space.
    pub positions: &'a [Vec3],
    /// Distance from the probe centre to the first surface through each texel centre. Texels
    /// that saw no geometry (sky) hold `sky_distance` or more.
    pub radial_distance: &'a [f32],
    /// The surface's unit normal at that point: its front-face normal, or for double-sided
    /// surfaces the side facing the probe. Back-face rejection (seed 003 §7.2) compares the
    /// ray with it. A zero normal means "unknown" and is read as facing the probe.
    pub normals: &'a [Vec3],
    /// Linear RGB radiance leaving that point towards the probe (for sky texels: the sky).
    pub radiance: &'a [Vec3],
    /// Optional: per texel, the nearest and farthest radial distance the baker found over
    /// rays spread across the texel (`sky_distance` or more for rays that saw no geometry),
    /// laid out as the other maps. A texel whose cone holds geometry nearer or farther than
    /// its centre's surface plane allows (a thin or cut-out surface, an edge inside the texel)
    /// is then treated as an edge: rays meeting it there are handed on instead of being
    /// passed in front of geometry the centre ray missed, or given a hit where the plane ends.
    /// `None`: only the centre rays are known (edges are found between neighbours).
    pub distance_range: Option<&'a [Vec2]>,
    /// Radial distances at or above this mean "no geometry" (finite, > 0). A ray that gets
    /// this far from a probe in front of everything it saw is a MISS.
    pub sky_distance: f32,
    /// Optional: a box holding every surface of the scene, `[min, max]` corners (for a
    /// `probe_scene::Scene`, its `bounds()`; `ProbeBake::scene_bounds` records it). Nothing
    /// lies beyond it, so a ray verified empty up to where it leaves the box is a MISS,
    /// whichever probe verified it: rays that leave through an open roof or window end there
    /// instead of needing a probe that sees them reach its sky. Its radiance is the sky along
    /// the ray, read from a probe whose texel in that direction sees the sky. `None`: a ray is
    /// a MISS only when a probe sees it reach the sky (or its `t_max`).
    pub geometry_bounds: Option<[Vec3; 2]>,
}

/// How the uploaded light field is prepared.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FieldOptions {
    /// Scale of the surface thickness accepted around each texel's surface plane (seed 003
    /// §7.1's dynamic epsilon): a texel at distance `D` whose surface meets its direction at
    /// angle `γ`, with angular radius `β`, has thickness `thickness_scale · D · β / cos γ`.
    /// Larger values accept more hits behind a texel's plane (fewer UNKNOWNs at corners and on
    /// curved surfaces) at the price of thicker-looking objects. Default 1.
    pub thickness_scale: f32,
    /// Leave undecided (hand on) rays near occluding edges in both directions: behind a
    /// foreground edge that may intrude into a background texel's cone, and within one texel of
    /// any edge (flags dilated). An edge can cut the corner of a texel whose neighbours all
    /// sample one surface, and a thin foreground can hide in a background texel; then a ray
    /// passing just beside gets a wrong answer. The conservative policy trades those wrong
    /// answers for rays left UNKNOWN: on the Cornell box at 64² wrong answers fall from 2.3 % to
    /// 0.2 % of rays while UNKNOWN rises from 0.4 % to 18 % (see `BENCHMARKS.md`). Default false.
    pub conservative_edges: bool,
    /// Prefiltered radiance levels for glossy cone tracing ([`crate::TraceOptions::glossy_roughness`]):
    /// level `k` of each probe is its radiance at resolution `N >> k` convolved with a GGX
    /// lobe one level texel wide (`probe_octa::glossy_pyramid`), computed at upload from the
    /// radiance maps and stored after them in the radiance buffer (a third more texels for
    /// all levels). Clamped to `log2(N) − 1` (down to 2×2) and 7. Default 0 (none).
    pub glossy_levels: u32,
}

impl Default for FieldOptions {
    fn default() -> Self {
        Self {
            thickness_scale: 1.0,
            conservative_edges: false,
            glossy_levels: 0,
        }
    }
}

/// Low-resolution maps for diffuse shading (seed 001 §4.3.4–4.3.7, DDGI): per probe an
/// irradiance map and a distance-moments map, padded like [`LightField`]'s maps.
#[derive(Clone, Copy, Debug)]
pub struct IrradianceField<'a> {
    /// Probe centres, world space.
    pub positions: &'a [Vec3],
    /// Interior resolution of the irradiance maps (DDGI: 6), at least 1.
    pub irradiance_resolution: u32,
    /// Irradiance `E(n) = ∫ L(ω) max(0, n·ω) dω` per texel normal `n` (e.g.
    /// [`probe_octa::irradiance_map`]); `probes × (R+2)²` texels.
    pub irradiance: &'a [Vec3],
    /// Interior resolution of the moment maps (DDGI: 14), at least 1.
    pub moments_resolution: u32,
    /// `(E[r], E[r²])` of radial distance per texel direction (e.g.
    /// [`probe_octa::distance_moments`]); `probes × (M+2)²` texels.
    pub moments: &'a [Vec2],
    /// Optional: each probe's surfels ([`probe_octa::surfel_map`] of its maps, the radiance
    /// without emission as for the irradiance), the same number per probe, probe after probe;
    /// empty for none. With them, [`crate::DiffuseOptions::parallax`] corrects each probe's
    /// irradiance for the point's offset from the probe.
    pub surfels: &'a [probe_octa::Surfel],
    /// Optional: probes to leave out of every blend, one flag per probe (empty for none).
    /// DDGI's inactive probes: a probe inside geometry sees the inside of a closed mesh, and
    /// its black irradiance would darken every surface around it; flag probes whose baked
    /// view is mostly back faces (`probe_capture::ProbeStats::inside_geometry`: a back-face
    /// share above 0.25, as `probes bake` warns). Their neighbours blend in their place (BENCHMARKS.md,
    /// "Probes inside geometry").
    pub inside_geometry: &'a [bool],
}

/// Which probes a ray tries, in what order (the `probe-index` structures, uploaded as the flat
/// arrays they expose). Every variant answers for the probes of the uploaded [`LightField`],
/// indexed the same way.
#[derive(Clone, Copy, Debug)]
pub enum ProbeSelection<'a> {
    /// A regular grid: the 8-probe cage around the point, first the probe behind it along the
    /// ray, then `(i + 3) mod 8` (seed 003 Alg. 6). Probe `i` of the light field is the grid's
    /// probe `i`; the light field's own positions may differ slightly from the lattice (probes
    /// moved out of geometry, seed 003 §8.3): selection uses the lattice, tracing the positions.
    Grid(ProbeGrid),
    /// The sparse voxel octree of the best 4 visible probes per voxel, looked up at the ray's
    /// current point (seed 000 Alg. 5).
    SparseVoxelOctree(&'a SparseVoxelOctree),
    /// Nearest probe first, then the failed probe's Voronoi-sphere neighbours towards the point
    /// where it failed (seed 000 Alg. 4).
    Voronoi {
        /// Nearest-probe tree over the light field's positions.
        nearest: &'a NearestProbe,
        /// Neighbour maps baked from the Delaunay tetrahedralization of the same positions.
        neighbours: &'a VoronoiNeighbours,
    },
}

impl ProbeSelection<'_> {
    /// A short name: `"grid"`, `"svo"` or `"voronoi"`.
    pub fn name(&self) -> &'static str {
        match self {
            ProbeSelection::Grid(_) => "grid",
            ProbeSelection::SparseVoxelOctree(_) => "svo",
            ProbeSelection::Voronoi { .. } => "voronoi",
        }
    }
}

/// How diffuse shading blends probes (seed 001 §4.3.6).
#[derive(Clone, Copy, Debug)]
pub enum Interpolation<'a> {
    /// Trilinear weights over the 8-probe cage of a regular grid (outside the grid, the
    /// nearest boundary cage with clamped weights), each axis's factor at least 0.001 (DDGI's
    /// floor: every probe of the cage keeps a little weight, for where the others are left
    /// out or hidden).
    Grid(ProbeGrid),
    /// Barycentric weights of the Delaunay tetrahedron holding the point, found by a walk from
    /// a tetrahedron of the nearest probe (outside the hull: the last tetrahedron reached, its
    /// weights clamped to `>= 0` and renormalised).
    Delaunay(&'a Tetrahedralization),
}
