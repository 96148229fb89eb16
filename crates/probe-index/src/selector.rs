//! One interface for "which probes, in what order, for this ray at this point", implemented by
//! the regular grid ([`crate::ProbeGrid`]), the Voronoi-sphere neighbours
//! ([`crate::VoronoiSelector`]) and the sparse voxel octree ([`crate::SparseVoxelOctree`]).
//!
//! A tracer asks at the ray's start (`failed_probe: None`), tries the candidates in order, and
//! when a probe answers UNKNOWN at some point further along the ray, asks again at that point
//! with `failed_probe: Some(probe)` (seed 000 Alg. 4–5, seed 003 Alg. 5–6).

use glam::Vec3;

/// Most candidates one query returns (a regular grid's full 8-probe cage).
pub const MAX_CANDIDATES: usize = 8;

/// A probe-selection query for one ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProbeQuery {
    /// Current point on the ray (its origin at the start, later where the last probe gave up).
    pub position: Vec3,
    /// Unit direction of the ray.
    pub direction: Vec3,
    /// The probe whose trace just ended UNKNOWN at `position`, or `None` at the ray's start.
    pub failed_probe: Option<u32>,
}

/// Probes to try, best first (at most [`MAX_CANDIDATES`]); never contains the failed probe.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct ProbeCandidates {
    len: u8,
    probes: [u32; MAX_CANDIDATES],
}

impl ProbeCandidates {
    /// No candidates.
    pub const fn new() -> Self {
        Self {
            len: 0,
            probes: [0; MAX_CANDIDATES],
        }
    }

    /// Appends `probe` unless the list is full or already holds it; returns whether it was added.
    pub fn push(&mut self, probe: u32) -> bool {
        if (self.len as usize) < MAX_CANDIDATES && !self.as_slice().contains(&probe) {
            self.probes[self.len as usize] = probe;
            self.len += 1;
            true
        } else {
            false
        }
    }

    /// The candidates, best first.
    pub fn as_slice(&self) -> &[u32] {
        &self.probes[..self.len as usize]
    }

    /// Number of candidates.
    pub fn len(&self) -> usize {
        self.len as usize
    }

    /// Whether there are no candidates (the tracer should fall back, e.g. to the nearest probe
    /// used as an environment map, seed 003 §5.4).
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
}

/// Chooses probes for a ray at a point. Implementations are the CPU reference of the lookups
/// that the GPU tracer reimplements on the flat arrays each structure exposes.
pub trait ProbeSelector {
    /// The probes to try for `query`, best first. A non-finite position or direction yields no
    /// candidates.
    fn select(&self, query: &ProbeQuery) -> ProbeCandidates;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn candidates_are_unique_and_bounded() {
        let mut c = ProbeCandidates::new();
        assert!(c.is_empty());
        assert!(c.push(3));
        assert!(!c.push(3));
        for i in 10..20 {
            c.push(i);
        }
        assert_eq!(c.len(), MAX_CANDIDATES);
        assert_eq!(c.as_slice()[..3], [3, 10, 11]);
    }
}
