//! Regular probe grids: the 8-probe cage around a point and seed 003's Alg. 6 ordering (first
//! probe by signed parallelness, then `(i + 3) mod 8`).

use bytemuck::{Pod, Zeroable};
use glam::{IVec3, Vec3};

use crate::error::GridError;
use crate::selector::{ProbeCandidates, ProbeQuery, ProbeSelector};

/// A regular grid of probes: probe `(x, y, z)` sits at `origin + (x, y, z) * spacing` and has
/// index `x + counts.x * (y + counts.y * z)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProbeGrid {
    origin: Vec3,
    spacing: Vec3,
    counts: [u32; 3],
}

/// The grid parameters for upload (48 bytes). WGSL mirror:
///
/// ```wgsl
/// struct GridParams {
///     origin: vec3<f32>,  // probe (0,0,0)
///     count_x: u32,
///     spacing: vec3<f32>,
///     count_y: u32,
///     count_z: u32,
///     _pad0: u32, _pad1: u32, _pad2: u32,
/// }
/// ```
///
/// With these a shader computes the cage corner `clamp(floor((p − origin) / spacing), 0, count − 2)`
/// and cage slot `i` (bits `zyx`) as the probe at corner `+ (i & 1, (i >> 1) & 1, i >> 2)`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct GridParams {
    /// Position of probe (0, 0, 0).
    pub origin: [f32; 3],
    /// Probes along x.
    pub count_x: u32,
    /// Distance between neighbouring probes along each axis.
    pub spacing: [f32; 3],
    /// Probes along y.
    pub count_y: u32,
    /// Probes along z.
    pub count_z: u32,
    /// Padding to a 16-byte multiple.
    pub pad: [u32; 3],
}

/// The 8 probes of the grid cell around a point: slot `i` is the corner with offset
/// `(i & 1, (i >> 1) & 1, i >> 2)` (seed 003 Fig. 5.6: the label's bits are z, y, x).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Cage {
    /// Grid coordinates of corner 0.
    pub corner: [u32; 3],
    /// Probe indices by slot.
    pub probes: [u32; 8],
}

/// Seed 003 Alg. 6 `nextProbe`: the cage slot to try after slot `i` — `(i + 3) mod 8`, which
/// visits all eight corners and never steps along a cube edge (every step is a face diagonal
/// or the body diagonal, Fig. 5.6). The thesis also calls it the maximum of the summed xor of
/// successive labels; that is not so (see this module's tests), but the order is Alg. 6's.
pub const fn next_cage_slot(i: usize) -> usize {
    (i + 3) & 7
}

impl ProbeGrid {
    /// A grid of `counts` probes per axis.
    ///
    /// # Errors
    /// [`GridError`] if an axis has fewer than 2 probes, a spacing is not positive and finite,
    /// the origin is not finite, or the grid has 2^32 probes or more.
    pub fn new(origin: Vec3, spacing: Vec3, counts: [u32; 3]) -> Result<Self, GridError> {
        if !origin.is_finite() {
            return Err(GridError::NonFiniteOrigin { origin });
        }
        for axis in 0..3 {
            if counts[axis] < 2 {
                return Err(GridError::TooFewProbes {
                    axis,
                    count: counts[axis],
                });
            }
            let s = spacing[axis];
            if !(s.is_finite() && s > 0.0) {
                return Err(GridError::BadSpacing { axis, value: s });
            }
        }
        let total = counts.iter().map(|&c| u64::from(c)).product::<u64>();
        if total >= u64::from(u32::MAX) {
            return Err(GridError::TooLarge { count: total });
        }
        Ok(Self {
            origin,
            spacing,
            counts,
        })
    }

    /// Total number of probes.
    pub fn probe_count(&self) -> usize {
        self.counts.iter().map(|&c| c as usize).product()
    }

    /// Probes per axis.
    pub fn counts(&self) -> [u32; 3] {
        self.counts
    }

    /// Index of the probe at grid coordinates `cell` (each below its count).
    pub fn probe_index(&self, cell: [u32; 3]) -> u32 {
        cell[0] + self.counts[0] * (cell[1] + self.counts[1] * cell[2])
    }

    /// Position of probe `index`.
    pub fn probe_position(&self, index: u32) -> Vec3 {
        let x = index % self.counts[0];
        let y = (index / self.counts[0]) % self.counts[1];
        let z = index / (self.counts[0] * self.counts[1]);
        self.origin + Vec3::new(x as f32, y as f32, z as f32) * self.spacing
    }
    /// The regular grid `positions` form, if they do: an axis-aligned lattice of at least 2
    /// probes per axis (`nx` distinct x values, `ny` y values, `nz` z values, `nx·ny·nz`
    /// probes), listed x fastest, then y, then z (as probe-place's `RegularGrid` and
    /// `grid:NXxNYxNZ` make them), each within `1e-4` of the spacing of its lattice point.
    /// `None` for anything else (uneven spacing, another order, a missing, extra or moved
    /// probe, a flat set, NaN), so a caller can fall back to a general index.
    ///
    /// ```
    /// use glam::Vec3;
    /// use probe_index::ProbeGrid;
    ///
    /// let grid = ProbeGrid::new(Vec3::new(-1.0, 0.5, 2.0), Vec3::new(0.5, 1.0, 0.25), [3, 2, 4])?;
    /// assert_eq!(ProbeGrid::detect(&grid.positions()), Some(grid));
    /// let mut moved = grid.positions();
    /// moved[5].x += 0.1;
    /// assert_eq!(ProbeGrid::detect(&moved), None);
    /// # Ok::<(), probe_index::GridError>(())
    /// ```
    pub fn detect(positions: &[Vec3]) -> Option<ProbeGrid> {
        let first = *positions.first()?;
        let counts = [0usize, 1, 2].map(|axis| {
            let mut values: Vec<f32> = positions.iter().map(|p| p[axis]).collect();
            values.sort_by(f32::total_cmp);
            values.dedup();
            values.len()
        });
        if counts.iter().product::<usize>() != positions.len() || counts.iter().any(|&c| c < 2) {
            return None;
        }
        let at = |i: usize| positions[i];
        let spacing = Vec3::new(
            at(1).x - first.x,
            at(counts[0]).y - first.y,
            at(counts[0] * counts[1]).z - first.z,
        );
        let grid = ProbeGrid::new(first, spacing, counts.map(|c| c as u32)).ok()?;
        let tolerance = 1e-4 * spacing.max_element();
        grid.positions()
            .iter()
            .zip(positions)
            .all(|(a, b)| a.distance(*b) <= tolerance)
            .then_some(grid)
    }

    /// All probe positions in index order.
    pub fn positions(&self) -> Vec<Vec3> {
        (0..self.probe_count() as u32)
            .map(|i| self.probe_position(i))
            .collect()
    }

    /// The cage around `p` (seed 003 §5.5 `nearestEightProbes`); outside the grid, the boundary
    /// cage nearest to `p`. Non-finite `p` gets the cage at the origin.
    pub fn cage(&self, p: Vec3) -> Cage {
        let nps = (p - self.origin) / self.spacing;
        let max = IVec3::new(
            self.counts[0] as i32 - 2,
            self.counts[1] as i32 - 2,
            self.counts[2] as i32 - 2,
        );
        let base = if nps.is_finite() {
            nps.floor()
                .clamp(Vec3::ZERO, max.as_vec3())
                .as_ivec3()
                .clamp(IVec3::ZERO, max)
        } else {
            IVec3::ZERO
        };
        let corner = [base.x as u32, base.y as u32, base.z as u32];
        let mut probes = [0u32; 8];
        for (i, probe) in probes.iter_mut().enumerate() {
            *probe = self.probe_index([
                corner[0] + (i as u32 & 1),
                corner[1] + ((i as u32 >> 1) & 1),
                corner[2] + (i as u32 >> 2),
            ]);
        }
        Cage { corner, probes }
    }

    /// Seed 003 Alg. 6 `firstProbe` with the signed heuristic of §5.7: the cage slot whose probe
    /// P maximizes `ω · normalize(X − P)` (the probe behind X looking along the ray). A probe
    /// exactly at X scores 1 (it sees everything from X). Ties go to the lowest slot.
    pub fn first_slot(&self, cage: &Cage, position: Vec3, direction: Vec3) -> usize {
        let mut best = 0;
        let mut best_score = f32::NEG_INFINITY;
        for (slot, &probe) in cage.probes.iter().enumerate() {
            let d = position - self.probe_position(probe);
            let score = if d == Vec3::ZERO {
                1.0
            } else {
                direction.dot(d.normalize())
            };
            if score > best_score {
                best_score = score;
                best = slot;
            }
        }
        best
    }

    /// All 8 cage probes in Alg. 6 order: the first by signed parallelness, then `(i + 3) mod 8`.
    pub fn ordered_probes(&self, position: Vec3, direction: Vec3) -> [u32; 8] {
        let cage = self.cage(position);
        let mut slot = self.first_slot(&cage, position, direction);
        let mut out = [0u32; 8];
        for o in &mut out {
            *o = cage.probes[slot];
            slot = next_cage_slot(slot);
        }
        out
    }

    /// The parameters a shader needs (see [`GridParams`]).
    pub fn gpu_params(&self) -> GridParams {
        GridParams {
            origin: self.origin.to_array(),
            count_x: self.counts[0],
            spacing: self.spacing.to_array(),
            count_y: self.counts[1],
            count_z: self.counts[2],
            pad: [0; 3],
        }
    }
}

impl ProbeSelector for ProbeGrid {
    /// At the ray's start: the 8 cage probes in Alg. 6 order. After probe `p` failed: if `p` is in
    /// the cage here, the rest of the cage continuing from `p`'s slot by `(i + 3) mod 8`;
    /// otherwise (the ray left `p`'s cell) the Alg. 6 order of the new cage without `p`.
    fn select(&self, query: &ProbeQuery) -> ProbeCandidates {
        let mut out = ProbeCandidates::new();
        if !query.position.is_finite() || !query.direction.is_finite() {
            return out;
        }
        let cage = self.cage(query.position);
        let failed_slot = query
            .failed_probe
            .and_then(|f| cage.probes.iter().position(|&p| p == f));
        let mut slot = match failed_slot {
            Some(s) => next_cage_slot(s),
            None => self.first_slot(&cage, query.position, query.direction),
        };
        for _ in 0..8 {
            let probe = cage.probes[slot];
            if Some(probe) != query.failed_probe {
                out.push(probe);
            }
            slot = next_cage_slot(slot);
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn next_slot_visits_all_corners_never_along_a_cube_edge() {
        let mut seen = [false; 8];
        let mut s = 0;
        let mut flips = 0;
        for _ in 0..8 {
            seen[s] = true;
            let n = next_cage_slot(s);
            // Every step is a face diagonal (2 bits flip) or the body diagonal (3 bits).
            let bits = (s ^ n).count_ones();
            assert!(bits >= 2, "{s} -> {n}");
            flips += bits;
            s = n;
        }
        assert!(seen.iter().all(|&b| b));
        assert_eq!(s, 0);
        assert_eq!(flips, 18);
        // Seed 003 §5.5 calls this order optimal for the summed xor; a brute force over all
        // cyclic orders says otherwise (best summed xor 50 vs 40, best bit flips 20 vs 18), so
        // the order is kept for what Fig. 5.6 shows: no step along a cube edge.
        let mut best_xor = 0;
        let mut best_flips = 0;
        let mut perm = [1usize, 2, 3, 4, 5, 6, 7];
        permute(&mut perm, 0, &mut |p| {
            let mut cyc = vec![0];
            cyc.extend_from_slice(p);
            let x: usize = (0..8).map(|i| cyc[i] ^ cyc[(i + 1) % 8]).sum();
            let f: u32 = (0..8)
                .map(|i| (cyc[i] ^ cyc[(i + 1) % 8]).count_ones())
                .sum();
            best_xor = best_xor.max(x);
            best_flips = best_flips.max(f);
        });
        assert_eq!((best_xor, best_flips), (50, 20));
    }

    fn permute(a: &mut [usize; 7], k: usize, f: &mut impl FnMut(&[usize])) {
        if k == a.len() {
            f(a);
            return;
        }
        for i in k..a.len() {
            a.swap(k, i);
            permute(a, k + 1, f);
            a.swap(k, i);
        }
    }
}
