//! Probe selection on the packed arrays, step for step as `gpu/trace.wgsl` does it. Each
//! selector reproduces the `probe_index::ProbeSelector` of its structure (tests check it).

use glam::{UVec3, Vec3};
use probe_index::{NO_PROBE, SVO_LEAF_BIT};

use crate::packed::{PackedSelection, SELECT_GRID, SELECT_SVO, TraceParams};

/// At most this many candidates (a grid cage).
pub(crate) const MAX_CANDIDATES: usize = 8;

/// Probes to try, best first.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Candidates {
    pub probes: [u32; MAX_CANDIDATES],
    pub len: u32,
}

impl Candidates {
    /// Appends `probe` unless it is [`NO_PROBE`], the list is full or already holds it.
    fn push(&mut self, probe: u32) {
        if probe == NO_PROBE || self.len as usize >= MAX_CANDIDATES {
            return;
        }
        if self.probes[..self.len as usize].contains(&probe) {
            return;
        }
        self.probes[self.len as usize] = probe;
        self.len += 1;
    }

    /// The candidates.
    pub fn as_slice(&self) -> &[u32] {
        &self.probes[..self.len as usize]
    }
}

/// Reads the selection words.
pub(crate) struct Selector<'a> {
    pub params: &'a TraceParams,
    pub selection: &'a PackedSelection,
    pub positions: &'a [[f32; 4]],
}

impl Selector<'_> {
    /// The probes to try at `position` for a ray along `direction`, after `failed` gave up there
    /// (`NO_PROBE` at the ray's start).
    pub fn select(&self, position: Vec3, direction: Vec3, failed: u32) -> Candidates {
        match self.selection.kind {
            SELECT_GRID => self.grid(position, direction, failed),
            SELECT_SVO => self.svo(position, failed),
            _ => self.voronoi(position, direction, failed),
        }
    }

    fn grid(&self, position: Vec3, direction: Vec3, failed: u32) -> Candidates {
        let g = &self.params.grid;
        let origin = Vec3::from(g.origin);
        let spacing = Vec3::from(g.spacing);
        let counts = UVec3::new(g.count_x, g.count_y, g.count_z);
        let max = (counts - UVec3::splat(2)).as_vec3();
        let base = ((position - origin) / spacing)
            .floor()
            .clamp(Vec3::ZERO, max)
            .as_uvec3();
        let mut cage = [0u32; 8];
        let mut first = 0usize;
        let mut best = f32::NEG_INFINITY;
        let mut failed_slot = usize::MAX;
        for (slot, probe) in cage.iter_mut().enumerate() {
            let s = slot as u32;
            let c = base + UVec3::new(s & 1, (s >> 1) & 1, s >> 2);
            *probe = c.x + counts.x * (c.y + counts.y * c.z);
            let d = position - (origin + c.as_vec3() * spacing);
            let score = if d == Vec3::ZERO {
                1.0
            } else {
                direction.dot(d.normalize())
            };
            if score > best {
                best = score;
                first = slot;
            }
            if *probe == failed {
                failed_slot = slot;
            }
        }
        let mut slot = if failed_slot < 8 {
            (failed_slot + 3) & 7
        } else {
            first
        };
        let mut out = Candidates::default();
        for _ in 0..8 {
            if cage[slot] != failed {
                out.push(cage[slot]);
            }
            slot = (slot + 3) & 7;
        }
        out
    }

    fn svo(&self, position: Vec3, failed: u32) -> Candidates {
        let h = &self.params.svo;
        let words = &self.selection.words;
        let origin = Vec3::from(h.origin);
        let mut size = h.size;
        let p = position.clamp(origin, origin + Vec3::splat(size));
        let mut lo = origin;
        let mut index = self.params.svo_nodes as usize;
        let mut out = Candidates::default();
        for _ in 0..=32 {
            let word = words[index];
            if word & SVO_LEAF_BIT != 0 {
                let leaf = self.params.svo_leaves as usize + 4 * (word & !SVO_LEAF_BIT) as usize;
                for &probe in &words[leaf..leaf + 4] {
                    if probe != failed {
                        out.push(probe);
                    }
                }
                return out;
            }
            size *= 0.5;
            let mid = lo + Vec3::splat(size);
            let mut child = 0usize;
            if p.x >= mid.x {
                child |= 1;
                lo.x = mid.x;
            }
            if p.y >= mid.y {
                child |= 2;
                lo.y = mid.y;
            }
            if p.z >= mid.z {
                child |= 4;
                lo.z = mid.z;
            }
            index = self.params.svo_nodes as usize + word as usize + child;
        }
        out
    }

    fn voronoi(&self, position: Vec3, direction: Vec3, failed: u32) -> Candidates {
        let mut out = Candidates::default();
        let from = if failed == NO_PROBE {
            let first = nearest_probe(
                &self.selection.words,
                self.params.kd_nodes,
                self.params.kd_count,
                position,
            );
            if first == NO_PROBE {
                return out;
            }
            out.push(first);
            first
        } else {
            failed
        };
        let p = self.positions[from as usize];
        let away = position - Vec3::new(p[0], p[1], p[2]);
        let towards = if away.length_squared() > 0.0 {
            away
        } else {
            direction
        };
        let n = self.params.neighbour_resolution;
        let [i, j] = probe_octa::OctaLayout::new(n)
            .expect("resolution checked at upload")
            .texel_containing(towards);
        let at = self.params.neighbour_table as usize
            + ((from as usize * n as usize + j as usize) * n as usize + i as usize) * 4;
        for &probe in &self.selection.words[at..at + 4] {
            out.push(probe);
        }
        out
    }
}

/// Nearest probe to `p` in the k-d tree stored at `words[start..]` (`count` nodes of 4 words:
/// position bits, probe), ties to the lower probe; the search of `probe_index::NearestProbe`
/// with an explicit stack.
pub(crate) fn nearest_probe(words: &[u32], start: u32, count: u32, p: Vec3) -> u32 {
    let mut best_probe = NO_PROBE;
    let mut best_d2 = f32::INFINITY;
    // (lo, hi, depth, bound): visit [lo, hi) unless bound > best.
    let mut stack = [(0u32, 0u32, 0u32, 0.0f32); 64];
    stack[0] = (0, count, 0, -1.0);
    let mut top = 1usize;
    while top > 0 {
        top -= 1;
        let (lo, hi, depth, bound) = stack[top];
        if bound > best_d2 || lo >= hi {
            continue;
        }
        let mid = (lo + hi) / 2;
        let at = (start + 4 * mid) as usize;
        let q = Vec3::new(
            f32::from_bits(words[at]),
            f32::from_bits(words[at + 1]),
            f32::from_bits(words[at + 2]),
        );
        let probe = words[at + 3];
        let d = q - p;
        let d2 = d.x * d.x + d.y * d.y + d.z * d.z;
        if d2 < best_d2 || (d2 == best_d2 && probe < best_probe) {
            best_d2 = d2;
            best_probe = probe;
        }
        let axis = (depth % 3) as usize;
        let delta = p[axis] - q[axis];
        let (near, far) = if delta < 0.0 {
            ((lo, mid), (mid + 1, hi))
        } else {
            ((mid + 1, hi), (lo, mid))
        };
        if top + 2 <= stack.len() {
            stack[top] = (far.0, far.1, depth + 1, delta * delta);
            stack[top + 1] = (near.0, near.1, depth + 1, -1.0);
            top += 2;
        }
    }
    best_probe
}
