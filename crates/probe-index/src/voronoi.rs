//! Voronoi-based selection (seed 000 §4.1): the first probe is the nearest one (the Voronoi
//! cell the point is in); when a trace in probe P gives up at a point Z, the next probes are
//! P's Delaunay neighbours whose directions from P lie nearest to `Z − P` — the Voronoi sphere
//! of P's projected neighbours, baked per texel of an octahedral map (§4.1.2, Fig. 4.5–4.6).

use glam::Vec3;
use probe_octa::OctaLayout;

use crate::delaunay::Tetrahedralization;
use crate::error::NeighbourError;
use crate::nearest::NearestProbe;
use crate::par::*;
use crate::selector::{ProbeCandidates, ProbeQuery, ProbeSelector};

/// Sentinel for an empty neighbour slot (a probe with fewer than 4 Delaunay neighbours).
pub const NO_PROBE: u32 = u32::MAX;

/// Neighbour slots per texel (seed 000 bakes 4, one per RGBA channel).
pub const NEIGHBOURS_PER_TEXEL: usize = 4;

/// Per-probe octahedral textures of the nearest Delaunay neighbours by direction.
///
/// Layout of [`Self::table`] (texture-ready, one `u32` per slot):
/// `table[((probe · N + j) · N + i) · 4 + k]` is the `k`-th best neighbour of `probe` for the
/// texel in column `i` (octahedral x) and row `j` (octahedral y) of an `N × N` map, whose centre
/// direction is the octahedral decode of `((i, j) + 0.5) / N · 2 − 1`. Slots are ordered by
/// decreasing cosine between the texel's direction and the direction to the neighbour;
/// unused slots hold [`NO_PROBE`]. As an `N × (N · probes)` RGBA32Uint texture, probe `p`'s map
/// is rows `p·N .. p·N + N`. Duplicate probes get their vertex's map. Texel directions are
/// `probe_octa`'s ([`OctaLayout::texel_direction`]; no padding border here).
#[derive(Clone, Debug)]
pub struct VoronoiNeighbours {
    layout: OctaLayout,
    resolution: u32,
    probe_count: usize,
    table: Vec<u32>,
}

impl VoronoiNeighbours {
    /// Bakes `resolution × resolution` maps for every probe of `tetrahedralization`.
    ///
    /// # Errors
    /// [`NeighbourError::BadResolution`] unless `1 ≤ resolution ≤ 4096`.
    pub fn bake(
        tetrahedralization: &Tetrahedralization,
        resolution: u32,
    ) -> Result<Self, NeighbourError> {
        if !(1..=4096).contains(&resolution) {
            return Err(NeighbourError::BadResolution { resolution });
        }
        let layout = OctaLayout::new(resolution)
            .map_err(|_| NeighbourError::BadResolution { resolution })?;
        let points = tetrahedralization.points();
        let (offsets, ids) = tetrahedralization.vertex_neighbours();
        let n = resolution as usize;
        let texels = n * n;
        let directions: Vec<Vec3> = (0..texels)
            .map(|t| layout.texel_direction((t % n) as u32, (t / n) as u32))
            .collect();
        let mut table = vec![NO_PROBE; points.len() * texels * NEIGHBOURS_PER_TEXEL];
        table
            .par_chunks_mut(texels * NEIGHBOURS_PER_TEXEL)
            .enumerate()
            .for_each(|(probe, maps)| {
                let row = &ids[offsets[probe] as usize..offsets[probe + 1] as usize];
                let here = points[probe];
                let dirs: Vec<(u32, Vec3)> = row
                    .iter()
                    .map(|&q| (q, (points[q as usize] - here).normalize_or_zero()))
                    .collect();
                for (texel, dir) in directions.iter().enumerate() {
                    let best = best_four(&dirs, *dir);
                    maps[texel * NEIGHBOURS_PER_TEXEL..(texel + 1) * NEIGHBOURS_PER_TEXEL]
                        .copy_from_slice(&best);
                }
            });
        Ok(Self {
            layout,
            resolution,
            probe_count: points.len(),
            table,
        })
    }

    /// Texels per side of each map.
    pub fn resolution(&self) -> u32 {
        self.resolution
    }

    /// Number of probes (maps).
    pub fn probe_count(&self) -> usize {
        self.probe_count
    }

    /// The flat table (layout in the type's documentation).
    pub fn table(&self) -> &[u32] {
        &self.table
    }

    /// Bytes held.
    pub fn memory_bytes(&self) -> usize {
        self.table.len() * size_of::<u32>()
    }

    /// The 4 neighbour slots of `probe` at texel `(i, j)`.
    ///
    /// # Panics
    /// If `probe`, `i` or `j` is out of range.
    pub fn texel(&self, probe: u32, i: u32, j: u32) -> [u32; NEIGHBOURS_PER_TEXEL] {
        let n = self.resolution as usize;
        let at = ((probe as usize * n + j as usize) * n + i as usize) * NEIGHBOURS_PER_TEXEL;
        let mut out = [NO_PROBE; NEIGHBOURS_PER_TEXEL];
        out.copy_from_slice(&self.table[at..at + NEIGHBOURS_PER_TEXEL]);
        out
    }

    /// The 4 neighbour slots of `probe` for the texel holding `direction` (seed 000 Alg. 4
    /// `NeighborProbeLookUp`). A zero or non-finite direction gives all [`NO_PROBE`].
    ///
    /// # Panics
    /// If `probe` is out of range.
    pub fn towards(&self, probe: u32, direction: Vec3) -> [u32; NEIGHBOURS_PER_TEXEL] {
        if !direction.is_finite() || direction == Vec3::ZERO {
            return [NO_PROBE; NEIGHBOURS_PER_TEXEL];
        }
        let [i, j] = self.layout.texel_containing(direction);
        self.texel(probe, i, j)
    }
}

/// The up-to-4 neighbours with the largest cosine to `dir`; ties to the lower index.
fn best_four(dirs: &[(u32, Vec3)], dir: Vec3) -> [u32; NEIGHBOURS_PER_TEXEL] {
    let mut best: [(f32, u32); NEIGHBOURS_PER_TEXEL] =
        [(f32::NEG_INFINITY, NO_PROBE); NEIGHBOURS_PER_TEXEL];
    for &(q, d) in dirs {
        let c = d.dot(dir);
        let better = |a: (f32, u32), b: (f32, u32)| a.0 > b.0 || (a.0 == b.0 && a.1 < b.1);
        if better((c, q), best[NEIGHBOURS_PER_TEXEL - 1]) {
            let mut k = NEIGHBOURS_PER_TEXEL - 1;
            while k > 0 && better((c, q), best[k - 1]) {
                best[k] = best[k - 1];
                k -= 1;
            }
            best[k] = (c, q);
        }
    }
    best.map(|(_, q)| q)
}

/// Seed 000's Voronoi-based selection as a [`ProbeSelector`]: nearest probe first, then the
/// Voronoi-sphere neighbours of the probe that failed, towards the point where it failed.
#[derive(Clone, Copy, Debug)]
pub struct VoronoiSelector<'a> {
    /// Probe positions (input order).
    pub positions: &'a [Vec3],
    /// Nearest-probe index over those positions.
    pub nearest: &'a NearestProbe,
    /// Baked neighbour maps.
    pub neighbours: &'a VoronoiNeighbours,
}

impl VoronoiSelector<'_> {
    fn push_neighbours(&self, out: &mut ProbeCandidates, probe: u32, position: Vec3, dir: Vec3) {
        if probe as usize >= self.neighbours.probe_count() {
            return;
        }
        let away = position - self.positions[probe as usize];
        let towards = if away.length_squared() > 0.0 {
            away
        } else {
            dir
        };
        for q in self.neighbours.towards(probe, towards) {
            if q != NO_PROBE {
                out.push(q);
            }
        }
    }
}

impl ProbeSelector for VoronoiSelector<'_> {
    /// At the ray's start: the nearest probe, then its neighbours towards the position (or along
    /// the ray if the position is the probe's own). After probe `p` failed at the position: `p`'s
    /// neighbours in the texel of `position − p` (seed 000 Alg. 4).
    fn select(&self, query: &ProbeQuery) -> ProbeCandidates {
        let mut out = ProbeCandidates::new();
        if !query.position.is_finite() || !query.direction.is_finite() {
            return out;
        }
        match query.failed_probe {
            Some(p) => {
                self.push_neighbours(&mut out, p, query.position, query.direction);
            }
            None => {
                if let Some((first, _)) = self.nearest.nearest(query.position) {
                    out.push(first);
                    self.push_neighbours(&mut out, first, query.position, query.direction);
                }
            }
        }
        out
    }
}
