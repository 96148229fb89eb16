//! Probe selection on the packed arrays, step for step as `gpu/trace.wgsl` does it. Each
//! selector reproduces the `probe_index::ProbeSelector` of its structure (tests check it).

use glam::{UVec3, Vec3};
use probe_index::{NO_PROBE, SVO_LEAF_BIT, SVO_PACKED_BIT};

use crate::packed::{NEAREST_ROW, PackedSelection, SELECT_GRID, SELECT_SVO, TraceParams};

/// At most this many candidates of the selection's own (a grid cage).
pub(crate) const MAX_CANDIDATES: usize = 8;

/// Probes to try, best first.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Candidates {
    pub probes: [u32; MAX_CANDIDATES],
    pub len: u32,
}

impl Candidates {
    /// Whether the list holds `probe`.
    pub(crate) fn contains(&self, probe: u32) -> bool {
        self.probes[..self.len as usize].contains(&probe)
    }

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
    #[cfg(test)]
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

    /// The probe nearest to `position` (ties to the lower index), whose row of the
    /// nearest-probe table extends the candidates when the selection's own have all failed.
    pub fn anchor(&self, position: Vec3) -> u32 {
        nearest_probe(
            &self.selection.words,
            self.params.kd_nodes,
            self.params.kd_count,
            position,
        )
    }

    /// Candidate `i` of `list` extended by the first `extension` entries of `anchor`'s row of
    /// the nearest-probe table, or [`NO_PROBE`] where the extension holds `failed`, a probe
    /// of the list or padding (such entries are skipped).
    pub fn candidate(&self, list: &Candidates, anchor: u32, failed: u32, i: u32) -> u32 {
        if i < list.len {
            return list.probes[i as usize];
        }
        let at = self.params.nearest_table + anchor * NEAREST_ROW + (i - list.len);
        let probe = self.selection.words[at as usize];
        if probe == failed || list.contains(probe) {
            NO_PROBE
        } else {
            probe
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
        let mut payload = u32::MAX;
        for _ in 0..=32 {
            let word = words[index];
            if word & SVO_LEAF_BIT != 0 {
                payload = word & !SVO_LEAF_BIT;
                break;
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
            if word & SVO_PACKED_BIT != 0 {
                // Eight leaf children as `packed_bits`-bit payload indices.
                let bits = h.packed_bits as usize;
                let per = 32 / bits;
                let block = (word & !SVO_PACKED_BIT) as usize * (8 / per);
                let w = words[self.params.svo_blocks as usize + block + child / per];
                payload = (w >> (bits * (child % per))) & ((1u64 << bits) - 1) as u32;
                break;
            }
            index = self.params.svo_nodes as usize + word as usize + child;
        }
        if payload != u32::MAX {
            let leaf = self.params.svo_leaves as usize + 4 * payload as usize;
            for &probe in &words[leaf..leaf + 4] {
                if probe != failed {
                    out.push(probe);
                }
            }
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
/// position bits, probe), ties to the lower probe: [`nearest_probes`] with `k = 1`, the search
/// of `probe_index::NearestProbe` with an explicit stack.
pub(crate) fn nearest_probe(words: &[u32], start: u32, count: u32, p: Vec3) -> u32 {
    let mut out = [(NO_PROBE, 0.0f32); MAX_BLEND_QUERY];
    match nearest_probes(words, start, count, p, 1, &mut out) {
        0 => NO_PROBE,
        _ => out[0].0,
    }
}

/// Most probes a filtered glossy ray blends (`TraceOptions::glossy_blend`), plus one for the
/// blend's radius.
pub(crate) const MAX_BLEND_QUERY: usize = crate::packed::MAX_GLOSSY_BLEND as usize + 1;

/// The `k` (at most [`MAX_BLEND_QUERY`]) probes nearest to `p` in the k-d tree at
/// `words[start..]`, nearest first (ties to the lower probe), as (probe, squared distance);
/// returns how many were found (fewer than `k` only when the tree has fewer probes). The
/// search of [`nearest_probe`] pruned by the `k`-th best distance; `gpu/trace.wgsl`'s
/// `nearest_probes` step for step.
pub(crate) fn nearest_probes(
    words: &[u32],
    start: u32,
    count: u32,
    p: Vec3,
    k: usize,
    out: &mut [(u32, f32); MAX_BLEND_QUERY],
) -> usize {
    let k = k.min(MAX_BLEND_QUERY);
    let mut found = 0usize;
    let mut stack = [(0u32, 0u32, 0u32, 0.0f32); 64];
    stack[0] = (0, count, 0, -1.0);
    let mut top = 1usize;
    while top > 0 {
        top -= 1;
        let (lo, hi, depth, bound) = stack[top];
        if lo >= hi || (found == k && bound > out[k - 1].1) {
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
        // Insert (probe, d2) into the sorted list if it beats the k-th.
        let better = |a: (u32, f32)| d2 < a.1 || (d2 == a.1 && probe < a.0);
        if found < k || better(out[k - 1]) {
            let mut i = if found < k { found } else { k - 1 };
            while i > 0 && better(out[i - 1]) {
                out[i] = out[i - 1];
                i -= 1;
            }
            out[i] = (probe, d2);
            found = (found + 1).min(k);
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
    found
}

/// The selection tests' box scene, shared with `tests/selection_properties.rs`.
#[cfg(test)]
#[path = "../../tests/support/boxes.rs"]
mod test_boxes;

#[cfg(test)]
mod tests {
    use super::*;
    use bytemuck::Zeroable;
    use probe_index::{
        NearestProbe, ProbeGrid, ProbeQuery, ProbeSelector, SparseVoxelOctree, SvoOptions,
        Tetrahedralization, VoronoiNeighbours, VoronoiSelector,
    };

    use crate::input::ProbeSelection;

    /// The k nearest probes from the packed k-d tree are the brute-force k nearest (squared
    /// distances in order, ties to the lower probe), for every k the blend may ask for.
    #[test]
    fn nearest_probes_match_brute_force() {
        let mut rng = Lcg(5);
        for set in 0..20 {
            // Some sets on a regular grid (many equal distances), some random.
            let positions: Vec<Vec3> = (0..(3 + set * 3))
                .map(|i| {
                    if set % 2 == 0 {
                        Vec3::new((i % 3) as f32, ((i / 3) % 3) as f32, (i / 9) as f32)
                    } else {
                        Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 4.0
                    }
                })
                .collect();
            let tree = NearestProbe::new(&positions);
            let words: Vec<u32> = tree
                .nodes()
                .iter()
                .flat_map(|n| {
                    n.position
                        .iter()
                        .map(|c| c.to_bits())
                        .chain(std::iter::once(n.probe))
                })
                .collect();
            for _ in 0..50 {
                let p = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 5.0 - 0.5;
                let mut brute: Vec<(u32, f32)> = positions
                    .iter()
                    .enumerate()
                    .map(|(i, q)| {
                        let d = *q - p;
                        (i as u32, d.x * d.x + d.y * d.y + d.z * d.z)
                    })
                    .collect();
                brute.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
                for k in 1..=MAX_BLEND_QUERY {
                    let mut out = [(NO_PROBE, 0.0f32); MAX_BLEND_QUERY];
                    let found = nearest_probes(&words, 0, positions.len() as u32, p, k, &mut out);
                    assert_eq!(found, k.min(positions.len()));
                    assert_eq!(&out[..found], &brute[..found], "k {k} at {p:?}");
                }
            }
        }
    }

    use probe_testdata::Lcg;

    /// Points and directions drawn from the tests' deterministic numbers.
    trait Draw {
        fn point(&mut self, lo: Vec3, hi: Vec3) -> Vec3;
        fn direction(&mut self) -> Vec3;
    }

    impl Draw for Lcg {
        fn point(&mut self, lo: Vec3, hi: Vec3) -> Vec3 {
            lo + (hi - lo) * Vec3::new(self.uniform(), self.uniform(), self.uniform())
        }

        fn direction(&mut self) -> Vec3 {
            (self.point(Vec3::NEG_ONE, Vec3::ONE) + Vec3::splat(1e-3)).normalize()
        }
    }

    fn params_of(selection: &PackedSelection) -> TraceParams {
        TraceParams {
            selector: selection.kind,
            grid: selection.grid,
            svo: selection.svo,
            svo_nodes: selection.svo_nodes,
            svo_leaves: selection.svo_leaves,
            svo_blocks: selection.svo_blocks,
            kd_nodes: selection.kd_nodes,
            kd_count: selection.kd_count,
            neighbour_table: selection.neighbour_table,
            neighbour_resolution: selection.neighbour_resolution,
            ..TraceParams::zeroed()
        }
    }

    /// Checks the packed selector against the reference on random queries, at the start of a
    /// ray and after a failure (of a probe in the list, and of one elsewhere).
    fn check(
        reference: &dyn ProbeSelector,
        selection: &ProbeSelection<'_>,
        positions: &[Vec3],
        lo: Vec3,
        hi: Vec3,
    ) {
        let packed = PackedSelection::new(selection, positions).unwrap();
        let params = params_of(&packed);
        let padded: Vec<[f32; 4]> = positions.iter().map(|p| [p.x, p.y, p.z, 0.0]).collect();
        let ours = Selector {
            params: &params,
            selection: &packed,
            positions: &padded,
        };
        let mut rng = Lcg(11);
        let (lo, hi) = (lo - Vec3::splat(0.5), hi + Vec3::splat(0.5));
        for i in 0..3000 {
            let position = if i % 10 == 0 {
                // Exactly at a probe.
                positions[i % positions.len()]
            } else {
                rng.point(lo, hi)
            };
            let direction = rng.direction();
            let start = reference.select(&ProbeQuery {
                position,
                direction,
                failed_probe: None,
            });
            let got = ours.select(position, direction, NO_PROBE);
            assert_eq!(
                got.as_slice(),
                start.as_slice(),
                "at {position} along {direction}"
            );
            let failed = match start.as_slice().first() {
                Some(&p) if i % 2 == 0 => p,
                _ => (rng.uniform() * positions.len() as f32) as u32 % positions.len() as u32,
            };
            let after = reference.select(&ProbeQuery {
                position,
                direction,
                failed_probe: Some(failed),
            });
            let got = ours.select(position, direction, failed);
            assert_eq!(
                got.as_slice(),
                after.as_slice(),
                "after {failed} failed at {position}"
            );
        }
    }

    #[test]
    fn grid_selection_matches_probe_index() {
        let grid = ProbeGrid::new(
            Vec3::new(-1.0, 0.2, 0.5),
            Vec3::new(0.7, 1.1, 0.45),
            [4, 3, 5],
        )
        .unwrap();
        let positions = grid.positions();
        let hi = grid.probe_position(grid.probe_count() as u32 - 1);
        check(
            &grid,
            &ProbeSelection::Grid(grid),
            &positions,
            Vec3::new(-1.0, 0.2, 0.5),
            hi,
        );
    }

    #[test]
    fn voronoi_selection_matches_probe_index() {
        let mut rng = Lcg(5);
        let positions: Vec<Vec3> = (0..60)
            .map(|_| rng.point(Vec3::ZERO, Vec3::new(4.0, 2.0, 3.0)))
            .collect();
        let tets = Tetrahedralization::build(&positions).unwrap();
        let neighbours = VoronoiNeighbours::bake(&tets, 8).unwrap();
        let nearest = NearestProbe::new(&positions);
        let reference = VoronoiSelector {
            positions: &positions,
            nearest: &nearest,
            neighbours: &neighbours,
        };
        let selection = ProbeSelection::Voronoi {
            nearest: &nearest,
            neighbours: &neighbours,
        };
        check(
            &reference,
            &selection,
            &positions,
            Vec3::ZERO,
            Vec3::new(4.0, 2.0, 3.0),
        );
    }

    use super::test_boxes::Boxes;

    /// Every selection packs the nearest-probe table: row `p` is probe `p` and its nearest
    /// others, as `NearestProbe::nearest_k` orders them (ties included: a grid has many
    /// equidistant probes), padded with `NO_PROBE` past the probe count.
    #[test]
    fn nearest_table_rows_are_the_nearest_probes() {
        let mut rng = Lcg(23);
        let grid = ProbeGrid::new(Vec3::ZERO, Vec3::splat(0.5), [4, 3, 5]).unwrap();
        let random: Vec<Vec3> = (0..70)
            .map(|_| rng.point(Vec3::ZERO, Vec3::new(3.0, 2.0, 4.0)))
            .collect();
        let small = ProbeGrid::new(Vec3::ZERO, Vec3::ONE, [2, 2, 2]).unwrap();
        for (positions, selection) in [
            (grid.positions(), ProbeSelection::Grid(grid)),
            (random[..8].to_vec(), ProbeSelection::Grid(small)),
        ] {
            let packed = PackedSelection::new(&selection, &positions).unwrap();
            let reference = NearestProbe::new(&positions);
            let mut expected = Vec::new();
            for (p, &position) in positions.iter().enumerate() {
                reference.nearest_k(position, NEAREST_ROW as usize, &mut expected);
                let at = (packed.nearest_table + p as u32 * NEAREST_ROW) as usize;
                let row = &packed.words[at..at + NEAREST_ROW as usize];
                assert_eq!(row[0], p as u32, "probe {p} heads its own row");
                for (j, &probe) in row.iter().enumerate() {
                    let want = expected.get(j).map_or(NO_PROBE, |e| e.0);
                    assert_eq!(probe, want, "row {p}, entry {j}");
                }
            }
        }
    }

    #[test]
    fn octree_selection_matches_probe_index() {
        let geometry = Boxes::new(&[
            (Vec3::ZERO, Vec3::new(4.0, 0.1, 4.0)),
            (Vec3::new(1.5, 0.0, 1.5), Vec3::new(2.5, 2.0, 2.5)),
        ]);
        let grid = ProbeGrid::new(
            Vec3::new(0.5, 0.5, 0.5),
            Vec3::new(1.5, 1.0, 1.5),
            [3, 2, 3],
        )
        .unwrap();
        let positions = grid.positions();
        let svo = SparseVoxelOctree::build(
            &geometry,
            &positions,
            &SvoOptions {
                max_depth: 4,
                ..SvoOptions::default()
            },
        )
        .unwrap();
        check(
            &svo,
            &ProbeSelection::SparseVoxelOctree(&svo),
            &positions,
            Vec3::ZERO,
            Vec3::new(4.0, 2.0, 4.0),
        );
    }
}
