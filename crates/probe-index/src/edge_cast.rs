//! Seed 002 §3.2.2 "raytracing along the edges": wherever scene geometry cuts a Delaunay edge,
//! insert a probe on each side of it, so that interpolation does not leak light through walls.

use std::collections::HashMap;

use glam::{IVec3, Vec3};

use crate::delaunay::Tetrahedralization;
use crate::error::EdgeCastError;
use crate::geometry::SceneGeometry;
use crate::nearest::NearestProbe;
use crate::par::*;

/// The conditions of seed 002 §3.2.2 for inserting a probe where an edge hits geometry.
#[derive(Clone, Debug, PartialEq)]
pub struct EdgeCastOptions {
    /// The hit counts only if `|cos|` between the edge and the surface normal is at least this:
    /// an edge running along a surface (both probes on it) does not cross it (seed 002's "dot
    /// product of the ray direction and the intersected geometry normal").
    pub min_abs_cosine: f32,
    /// The hit must be at least this fraction of the edge's length from both of its ends (the
    /// "dynamic, edge length dependant threshold" of Fig. 14), and no probe, old or new, may be
    /// closer than that to the new one.
    pub min_edge_fraction: f32,
    /// The new probe sits off the surface, on the side the ray came from, by this fraction of the
    /// edge's length along the surface normal (seed 002 §3.1.3 offsets probes off surfaces).
    pub surface_offset_fraction: f32,
}

impl Default for EdgeCastOptions {
    fn default() -> Self {
        Self {
            min_abs_cosine: 0.1,
            min_edge_fraction: 0.15,
            surface_offset_fraction: 0.05,
        }
    }
}

/// The probes after edge casting, and the rebuilt tetrahedralization.
#[derive(Clone, Debug)]
pub struct EdgeCastResult {
    /// All probes: the original ones first (same indices), then the added ones.
    pub probes: Vec<Vec3>,
    /// Number of probes added.
    pub added: usize,
    /// Rays cast (two per Delaunay edge).
    pub rays_cast: usize,
    /// Rays that hit geometry inside the edge.
    pub hits: usize,
    /// Tetrahedralization of `probes`.
    pub tetrahedralization: Tetrahedralization,
}

/// Casts a ray along every Delaunay edge of `tetrahedralization` in both directions and inserts a
/// probe near each qualifying hit (one pass), then rebuilds the tetrahedralization.
///
/// Candidates are accepted in edge order, each only if no probe already present or accepted is
/// within its `min_edge_fraction × edge length`, so the result is deterministic.
///
/// # Errors
/// [`EdgeCastError::BadParameter`] for options out of range; [`EdgeCastError::Delaunay`] if the
/// rebuild fails (it cannot when the input tetrahedralization was valid).
pub fn insert_edge_probes(
    tetrahedralization: &Tetrahedralization,
    geometry: &dyn SceneGeometry,
    options: &EdgeCastOptions,
) -> Result<EdgeCastResult, EdgeCastError> {
    let check = |name: &'static str, value: f32, ok: bool| {
        if ok && value.is_finite() {
            Ok(())
        } else {
            Err(EdgeCastError::BadParameter { name, value })
        }
    };
    check(
        "min_abs_cosine",
        options.min_abs_cosine,
        (0.0..=1.0).contains(&options.min_abs_cosine),
    )?;
    check(
        "min_edge_fraction",
        options.min_edge_fraction,
        (0.0..0.5).contains(&options.min_edge_fraction),
    )?;
    check(
        "surface_offset_fraction",
        options.surface_offset_fraction,
        options.surface_offset_fraction >= 0.0
            && options.surface_offset_fraction <= options.min_edge_fraction,
    )?;
    let points = tetrahedralization.points();
    let edges = tetrahedralization.edges();
    // (position, exclusion radius) per edge and direction, in edge order.
    let candidates: Vec<[Option<(Vec3, f32)>; 2]> = edges
        .par_iter()
        .map(|&[a, b]| {
            let pa = points[a as usize];
            let pb = points[b as usize];
            [
                cast(geometry, pa, pb, options),
                cast(geometry, pb, pa, options),
            ]
        })
        .collect();
    let hits = candidates.iter().flatten().filter(|c| c.is_some()).count();
    let existing = NearestProbe::new(points);
    let mut accepted: Vec<Vec3> = Vec::new();
    let mut grid = AcceptedGrid::new(&candidates);
    for (p, r) in candidates.iter().flatten().flatten().copied() {
        let near_existing = existing.nearest(p).is_some_and(|(_, d2)| d2 < r * r);
        if near_existing || grid.any_within(&accepted, p, r) {
            continue;
        }
        grid.insert(p, accepted.len() as u32);
        accepted.push(p);
    }
    let added = accepted.len();
    let mut probes = points.to_vec();
    probes.extend(accepted);
    let tetrahedralization = Tetrahedralization::build(&probes)?;
    Ok(EdgeCastResult {
        probes,
        added,
        rays_cast: edges.len() * 2,
        hits,
        tetrahedralization,
    })
}

/// The new probe for the ray from `from` to `to`, if the first hit qualifies.
fn cast(
    geometry: &dyn SceneGeometry,
    from: Vec3,
    to: Vec3,
    options: &EdgeCastOptions,
) -> Option<(Vec3, f32)> {
    let d = to - from;
    let len = d.length();
    if len <= 0.0 {
        return None;
    }
    let dir = d / len;
    let hit = geometry.closest_hit(from, dir, len)?;
    let min = options.min_edge_fraction * len;
    if hit.distance < min || len - hit.distance < min {
        return None;
    }
    let cos = hit.normal.dot(dir);
    if cos.abs() < options.min_abs_cosine {
        return None;
    }
    // Normal turned towards the ray's origin.
    let n = if cos < 0.0 { hit.normal } else { -hit.normal };
    let p = from + dir * hit.distance + n * (options.surface_offset_fraction * len);
    p.is_finite().then_some((p, min))
}

/// A hash grid over accepted probes for the exclusion-radius test.
struct AcceptedGrid {
    cell: f32,
    cells: HashMap<IVec3, Vec<u32>>,
}

impl AcceptedGrid {
    fn new(candidates: &[[Option<(Vec3, f32)>; 2]]) -> Self {
        let mut radii: Vec<f32> = candidates
            .iter()
            .flatten()
            .flatten()
            .map(|&(_, r)| r)
            .filter(|&r| r > 0.0)
            .collect();
        radii.sort_by(f32::total_cmp);
        let cell = radii.get(radii.len() / 2).copied().unwrap_or(1.0);
        Self {
            cell,
            cells: HashMap::new(),
        }
    }

    fn key(&self, p: Vec3) -> IVec3 {
        (p / self.cell).floor().as_ivec3()
    }

    fn insert(&mut self, p: Vec3, id: u32) {
        let k = self.key(p);
        self.cells.entry(k).or_default().push(id);
    }

    fn any_within(&self, accepted: &[Vec3], p: Vec3, r: f32) -> bool {
        let reach = (r / self.cell).ceil() as i32;
        let k = self.key(p);
        if reach > 8 {
            return accepted.iter().any(|q| (*q - p).length_squared() < r * r);
        }
        for z in -reach..=reach {
            for y in -reach..=reach {
                for x in -reach..=reach {
                    if let Some(ids) = self.cells.get(&(k + IVec3::new(x, y, z)))
                        && ids
                            .iter()
                            .any(|&i| (accepted[i as usize] - p).length_squared() < r * r)
                    {
                        return true;
                    }
                }
            }
        }
        false
    }
}
