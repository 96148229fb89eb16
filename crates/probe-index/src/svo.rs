//! Sparse voxel octree of the best probes per voxel (seed 000 §4.2).
//!
//! The tree follows the scene: a node is subdivided while triangles overlap it (exact
//! separating-axis test) until the chosen depth, and all 8 children of a subdivided node exist,
//! so empty space has leaves too. Each leaf holds up to 4 probes ranked by seed 000's rules:
//! only probes visible from the leaf (segments from the voxel centre, and for empty space also
//! from seeded random points in the voxel), surfaces ranked by `|n·p̂| / d` (the best over the
//! leaf's first 16 non-degenerate triangles in scene order), empty space by `1 / d`.
//!
//! Memory: after ranking, any node whose 8 children are leaves with the same 4 probes becomes
//! one leaf (repeated bottom-up), and identical leaf payloads are stored once; lookups give
//! exactly the same answer as in the full tree. Two options trade a little of seed 000's letter
//! for far fewer nodes (both documented on [`SvoOptions`]): near-surface empty voxels rank like
//! the surface below them, and voxels no probe sees may merge with their visible siblings.

use std::collections::HashMap;
use std::time::{Duration, Instant};

use bytemuck::{Pod, Zeroable};
use glam::{DVec3, Vec3};

use crate::error::SvoError;
use crate::geometry::{SceneGeometry, triangle_overlaps_box};
use crate::nearest::NearestProbe;
use crate::par::*;
use crate::rng::SplitMix64;
use crate::selector::{ProbeCandidates, ProbeQuery, ProbeSelector};
use crate::voronoi::NO_PROBE;

/// Bit 31 of a node word: set for a leaf (low 31 bits: payload index).
pub const SVO_LEAF_BIT: u32 = 1 << 31;
/// Bit 30 of a node word (bit 31 clear): an internal node whose 8 children are all leaves,
/// stored as a packed block of 8 payload indices of [`SvoHeader::packed_bits`] bits each
/// (low 30 bits: block index).
pub const SVO_PACKED_BIT: u32 = 1 << 30;

/// Most triangle normals considered per surface leaf when ranking.
const MAX_LEAF_NORMALS: usize = 16;

/// How to build a [`SparseVoxelOctree`].
#[derive(Clone, Debug, PartialEq)]
pub struct SvoOptions {
    /// Subdivision depth: the finest voxel is the scene cube's side / 2^depth (1..=15).
    pub max_depth: u32,
    /// Random points per empty-space leaf, besides its centre, from which probe visibility is
    /// tested (seed 000 §4.2.2 "multi-sampling"); a probe is visible if any of them sees it.
    /// Leaves ranked as surfaces are tested from their centre only, as in the seed; a surface
    /// voxel whose centre sees no probe at all (it lies behind its surface) is tested from two
    /// points a quarter voxel off the surface on either side instead.
    pub visibility_samples: u32,
    /// Nearest probes considered per leaf (all of them when there are fewer).
    pub max_candidates: usize,
    /// Seed of the sample points.
    pub seed: u64,
    /// Leaves from which no probe is visible (inside closed objects, behind outer walls) hold no
    /// information a ray can use; when set, they take their siblings' payload if that lets the
    /// siblings merge into one leaf. Lookups elsewhere are unchanged; lookups inside such
    /// voxels may then return the probes of the visible voxels next to them instead of none.
    pub merge_unseen_leaves: bool,
    /// Empty leaves in the `surface_shell_levels` finest levels (so at most
    /// `2^(surface_shell_levels − 1)` finest voxels wide) are ranked like surfaces, with their
    /// parent node's triangle normals (the parent always holds geometry), instead of by distance
    /// alone: the voxels just off a surface then agree with the surface voxels, so uniform
    /// regions merge. 0 keeps seed 000's rule exactly: only voxels that overlap triangles use
    /// normals.
    pub surface_shell_levels: u32,
    /// The cube's bounds; by default the bounding box of the triangles and probes, made cubic.
    pub bounds: Option<(Vec3, Vec3)>,
}

impl Default for SvoOptions {
    fn default() -> Self {
        Self {
            max_depth: 7,
            visibility_samples: 4,
            max_candidates: 64,
            seed: 0,
            surface_shell_levels: 3,
            merge_unseen_leaves: true,
            bounds: None,
        }
    }
}

/// The octree's header for upload (48 bytes). WGSL mirror:
///
/// ```wgsl
/// struct SvoHeader {
///     origin: vec3<f32>,  // min corner of the root cube
///     size: f32,          // side of the root cube
///     depth: u32,         // subdivision depth it was built with
///     node_count: u32,
///     leaf_count: u32,
///     block_count: u32,
///     packed_bits: u32,   // 8 or 16 (bits per payload index in a packed block); 0: none
///     _pad0: u32, _pad1: u32, _pad2: u32,
/// }
/// // nodes: array<u32>. Root is nodes[0]. Child slot inside a node of centre `mid`:
/// //   c = u32(p.x >= mid.x) | u32(p.y >= mid.y) << 1 | u32(p.z >= mid.z) << 2.
/// //   bit 31 set:            a leaf; its payload is leaves[word & 0x7FFFFFFF].
/// //   bit 31 clear, 30 set:  8 leaf children packed in block b = word & 0x3FFFFFFF of
/// //                          `blocks` (array<u32>, 8 · packed_bits / 32 words per block):
/// //                          per = 32 / packed_bits;
/// //                          w = blocks[b * (8 / per) + c / per];
/// //                          payload index = (w >> (packed_bits * (c % per))) & ((1 << packed_bits) − 1).
/// //   both clear:            children are nodes[word + c].
/// // leaves: array<vec4<u32>>, best probe first, 0xFFFFFFFF = none.
/// ```
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct SvoHeader {
    /// Min corner of the root cube.
    pub origin: [f32; 3],
    /// Side of the root cube.
    pub size: f32,
    /// Subdivision depth.
    pub depth: u32,
    /// Number of node words.
    pub node_count: u32,
    /// Number of leaf payloads.
    pub leaf_count: u32,
    /// Number of packed leaf blocks.
    pub block_count: u32,
    /// Bits per payload index in packed blocks: 8 (≤ 256 payloads), 16 (≤ 65,536) or 0 (no
    /// packing).
    pub packed_bits: u32,
    /// Padding to 48 bytes.
    pub pad: [u32; 3],
}

/// Counts and timings of an octree build.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SvoStats {
    /// Side of the finest voxels.
    pub finest_voxel_size: f32,
    /// Nodes of the full tree (before merging uniform subtrees).
    pub full_nodes: usize,
    /// Leaves of the full tree that overlap geometry.
    pub surface_leaves: usize,
    /// Leaves of the full tree in empty space.
    pub empty_leaves: usize,
    /// Leaves that no probe is visible from (payload all [`NO_PROBE`]; e.g. inside solid objects).
    pub leaves_without_probe: usize,
    /// Node words after merging.
    pub nodes: usize,
    /// Packed blocks of 8 leaf children (8 or 16 bytes each, see [`SvoHeader::packed_bits`]).
    pub blocks: usize,
    /// Distinct leaf payloads stored.
    pub payloads: usize,
    /// Bytes of the flat layout (header, nodes, packed blocks, payloads).
    pub bytes: usize,
    /// Bytes the full tree would take in the same layout without merging or sharing payloads
    /// (4 bytes per node plus 16 per leaf).
    pub full_bytes: usize,
    /// Segment visibility queries made.
    pub visibility_queries: u64,
    /// Time to subdivide the scene.
    pub subdivide_time: Duration,
    /// Time to rank probes in the leaves.
    pub rank_time: Duration,
    /// Time to merge and lay out.
    pub layout_time: Duration,
}

/// The octree in its flat, upload-ready form.
#[derive(Clone, Debug)]
pub struct SparseVoxelOctree {
    header: SvoHeader,
    nodes: Vec<u32>,
    blocks: Vec<u32>,
    leaves: Vec<[u32; 4]>,
    stats: SvoStats,
}

/// Children made from a chunk of subdivided nodes: coordinates, triangle counts, triangle ids.
type ChildBlock = (Vec<[u32; 3]>, Vec<u32>, Vec<u32>);

struct Level {
    coords: Vec<[u32; 3]>,
    /// Index of each node's parent in the previous level.
    parent: Vec<u32>,
    tri_start: Vec<u32>,
    tri_len: Vec<u32>,
    refs: Vec<u32>,
}

impl SvoOptions {
    /// A rough upper estimate of the memory [`SparseVoxelOctree::build`] takes for a scene of
    /// `triangles` triangles at this depth, in bytes, for refusing a depth before building:
    /// a surface-adaptive octree subdivides only voxels that hold geometry, about
    /// `(surface area / cube face area) · 4^level` of them per level; this assumes 24 faces'
    /// worth (a scene's surfaces rarely exceed that: a closed room has 6) at 48 bytes a node,
    /// plus one 4-byte triangle reference per triangle and level.
    pub fn memory_estimate(&self, triangles: usize) -> u64 {
        let mut nodes: u64 = 0;
        for level in 0..=self.max_depth.min(31) {
            let full = 8u64.saturating_pow(level);
            let surface = 24u64.saturating_mul(4u64.saturating_pow(level));
            nodes = nodes.saturating_add(full.min(surface));
        }
        nodes.saturating_mul(48).saturating_add(
            (triangles as u64)
                .saturating_mul(u64::from(self.max_depth) + 1)
                .saturating_mul(4),
        )
    }
}

impl SparseVoxelOctree {
    /// Builds the octree for `probes` in `geometry`.
    ///
    /// # Errors
    /// [`SvoError`] for a depth outside 1..=15, no probes, a non-finite probe or triangle, or
    /// `max_candidates == 0`.
    pub fn build(
        geometry: &dyn SceneGeometry,
        probes: &[Vec3],
        options: &SvoOptions,
    ) -> Result<Self, SvoError> {
        if !(1..=15).contains(&options.max_depth) {
            return Err(SvoError::BadDepth {
                depth: options.max_depth,
            });
        }
        if probes.is_empty() {
            return Err(SvoError::NoProbes);
        }
        if options.max_candidates == 0 {
            return Err(SvoError::NoCandidates);
        }
        if let Some((index, &position)) = probes.iter().enumerate().find(|(_, p)| !p.is_finite()) {
            return Err(SvoError::NonFiniteProbe { index, position });
        }
        let tri_count = geometry.triangle_count();
        let triangles: Vec<[Vec3; 3]> = (0..tri_count).map(|i| geometry.triangle(i)).collect();
        if let Some(index) = triangles
            .iter()
            .position(|t| !t.iter().all(|v| v.is_finite()))
        {
            return Err(SvoError::NonFiniteTriangle { index });
        }
        let (origin, size) = cube_bounds(&triangles, probes, options.bounds);
        let depth = options.max_depth;

        // 1. Subdivide where triangles are.
        let t0 = Instant::now();
        let voxel = |level: u32, c: [u32; 3]| -> (Vec3, Vec3) {
            let s = size / (1u64 << level) as f64;
            let lo = origin + DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64) * s;
            (lo.as_vec3(), (lo + DVec3::splat(s)).as_vec3())
        };
        let root_box = voxel(0, [0, 0, 0]);
        let root_refs: Vec<u32> = (0..tri_count as u32)
            .into_par_iter()
            .filter(|&t| triangle_overlaps_box(&triangles[t as usize], root_box.0, root_box.1))
            .collect();
        let mut levels = vec![Level {
            coords: vec![[0, 0, 0]],
            parent: vec![0],
            tri_start: vec![0],
            tri_len: vec![root_refs.len() as u32],
            refs: root_refs,
        }];
        for level in 0..depth {
            let cur = &levels[level as usize];
            let internal: Vec<usize> = (0..cur.coords.len())
                .filter(|&i| cur.tri_len[i] > 0)
                .collect();
            if internal.is_empty() {
                break;
            }
            let chunks: Vec<ChildBlock> = internal
                .par_chunks(64)
                .map(|chunk| {
                    let mut coords = Vec::with_capacity(chunk.len() * 8);
                    let mut lens = Vec::with_capacity(chunk.len() * 8);
                    let mut refs = Vec::new();
                    for &i in chunk {
                        let c = cur.coords[i];
                        let tris = &cur.refs[cur.tri_start[i] as usize
                            ..(cur.tri_start[i] + cur.tri_len[i]) as usize];
                        for child in 0..8u32 {
                            let cc = [
                                c[0] * 2 + (child & 1),
                                c[1] * 2 + ((child >> 1) & 1),
                                c[2] * 2 + (child >> 2),
                            ];
                            let (lo, hi) = voxel(level + 1, cc);
                            let before = refs.len();
                            refs.extend(tris.iter().copied().filter(|&t| {
                                triangle_overlaps_box(&triangles[t as usize], lo, hi)
                            }));
                            coords.push(cc);
                            lens.push((refs.len() - before) as u32);
                        }
                    }
                    (coords, lens, refs)
                })
                .collect();
            let mut next = Level {
                coords: Vec::new(),
                parent: internal.iter().flat_map(|&i| [i as u32; 8]).collect(),
                tri_start: Vec::new(),
                tri_len: Vec::new(),
                refs: Vec::new(),
            };
            for (coords, lens, refs) in chunks {
                let base = next.refs.len() as u32;
                let mut off = 0u32;
                for len in &lens {
                    next.tri_start.push(base + off);
                    off += len;
                }
                next.coords.extend(coords);
                next.tri_len.extend(lens);
                next.refs.extend(refs);
            }
            // Triangle lists are needed later only for the levels whose leaves (or their
            // children) rank by surface normals; drop the others once the next level is built.
            if level >= 1 && level - 1 + options.surface_shell_levels < depth {
                levels[level as usize - 1].refs = Vec::new();
            }
            levels.push(next);
        }
        let subdivide_time = t0.elapsed();

        // Global numbering, level by level.
        let mut level_offset = Vec::with_capacity(levels.len() + 1);
        let mut total = 0usize;
        for l in &levels {
            level_offset.push(total);
            total += l.coords.len();
        }
        let deepest = levels.len() as u32 - 1;
        // Leaves: nodes without triangles, and nodes with triangles at the last level built
        // (which is `depth`, unless no node had triangles deeper).
        struct LeafJob {
            global: usize,
            level: u32,
            coord: [u32; 3],
            /// Whether triangles overlap the leaf (a surface leaf).
            surface: bool,
            /// Where the normals that rank this leaf come from: (level, start, len) of a
            /// triangle list — the leaf's own (surface leaves) or its parent's (near-surface
            /// empty leaves); `None` ranks by distance alone.
            normals_from: Option<(u32, u32, u32)>,
        }
        let mut jobs = Vec::new();
        let mut first_child = vec![u32::MAX; total];
        for (li, l) in levels.iter().enumerate() {
            let mut internal_rank = 0usize;
            for i in 0..l.coords.len() {
                let g = level_offset[li] + i;
                let has = l.tri_len[i] > 0;
                if has && (li as u32) < deepest {
                    first_child[g] = (level_offset[li + 1] + 8 * internal_rank) as u32;
                    internal_rank += 1;
                } else {
                    let near_surface = li > 0 && li as u32 + options.surface_shell_levels > depth;
                    let normals_from = if has {
                        Some((li as u32, l.tri_start[i], l.tri_len[i]))
                    } else if near_surface {
                        // Every non-root node's parent overlaps geometry (only such nodes are
                        // subdivided).
                        let up = &levels[li - 1];
                        let pi = l.parent[i] as usize;
                        Some((li as u32 - 1, up.tri_start[pi], up.tri_len[pi]))
                    } else {
                        None
                    };
                    jobs.push(LeafJob {
                        global: g,
                        level: li as u32,
                        coord: l.coords[i],
                        surface: has,
                        normals_from,
                    });
                }
            }
        }

        // 2. Rank probes in every leaf.
        let t1 = Instant::now();
        let nearest = NearestProbe::new(probes);
        let k = options.max_candidates.min(probes.len());
        let ranked: Vec<([u32; 4], u64)> = jobs
            .par_iter()
            .map_init(Vec::new, |scratch, job| {
                let (lo, hi) = voxel(job.level, job.coord);
                let refs = job.normals_from.map(|(level, start, len)| {
                    &levels[level as usize].refs[start as usize..(start + len) as usize]
                });
                // Planes (unit normal, offset) of the triangles that rank this leaf.
                let planes: Vec<(Vec3, f32)> = match refs {
                    Some(refs) => refs
                        .iter()
                        .filter_map(|&t| {
                            let [a, b, c] = triangles[t as usize];
                            let n = (b - a).cross(c - a);
                            (n.length_squared() > 0.0).then(|| {
                                let n = n.normalize();
                                (n, n.dot(a))
                            })
                        })
                        .take(MAX_LEAF_NORMALS)
                        .collect(),
                    _ => Vec::new(),
                };
                let seed = options.seed
                    ^ (u64::from(job.level) << 58)
                    ^ (u64::from(job.coord[0]) << 38)
                    ^ (u64::from(job.coord[1]) << 19)
                    ^ u64::from(job.coord[2]);
                rank_leaf(
                    geometry,
                    probes,
                    &nearest,
                    k,
                    lo,
                    hi,
                    &planes,
                    job.surface,
                    options.visibility_samples,
                    seed,
                    scratch,
                )
            })
            .collect();
        let rank_time = t1.elapsed();

        // 3. Merge uniform subtrees, share payloads, lay out.
        let t2 = Instant::now();
        let mut payload = vec![[NO_PROBE; 4]; total];
        let mut is_leaf = vec![false; total];
        let mut visibility_queries = 0u64;
        let mut leaves_without_probe = 0usize;
        let mut surface_leaves = 0usize;
        for (job, &(best, queries)) in jobs.iter().zip(&ranked) {
            payload[job.global] = best;
            is_leaf[job.global] = true;
            visibility_queries += queries;
            if best[0] == NO_PROBE {
                leaves_without_probe += 1;
            }
            if job.surface {
                surface_leaves += 1;
            }
        }
        let full_leaves = jobs.len();
        drop(jobs);
        for li in (0..levels.len()).rev() {
            for i in 0..levels[li].coords.len() {
                let g = level_offset[li] + i;
                if is_leaf[g] {
                    continue;
                }
                let f = first_child[g] as usize;
                if !(f..f + 8).all(|c| is_leaf[c]) {
                    continue;
                }
                // The payload all children share; with `merge_unseen_leaves`, children that no
                // probe sees (payload all NO_PROBE) agree with anything.
                let unseen = |c: usize| options.merge_unseen_leaves && payload[c][0] == NO_PROBE;
                let common = (f..f + 8)
                    .find(|&c| !unseen(c))
                    .map_or([NO_PROBE; 4], |c| payload[c]);
                if (f..f + 8).all(|c| unseen(c) || payload[c] == common) {
                    is_leaf[g] = true;
                    payload[g] = common;
                }
            }
        }
        // Index width of packed blocks, from the number of distinct payloads (an upper bound on
        // those still reachable after merging).
        let distinct: std::collections::HashSet<[u32; 4]> = (0..total)
            .filter(|&g| is_leaf[g])
            .map(|g| payload[g])
            .collect();
        let packed_bits: u32 = match distinct.len() {
            0..=256 => 8,
            257..=65_536 => 16,
            _ => 0,
        };
        drop(distinct);
        let mut nodes: Vec<u32> = vec![0];
        let mut blocks: Vec<u32> = Vec::new();
        let mut leaves: Vec<[u32; 4]> = Vec::new();
        let mut payload_id: HashMap<[u32; 4], u32> = HashMap::new();
        let mut id_of = |p: [u32; 4]| {
            *payload_id.entry(p).or_insert_with(|| {
                leaves.push(p);
                (leaves.len() - 1) as u32
            })
        };
        // Breadth-first: (old global id, new slot).
        let mut queue = std::collections::VecDeque::from([(0usize, 0usize)]);
        while let Some((g, slot)) = queue.pop_front() {
            if is_leaf[g] {
                nodes[slot] = SVO_LEAF_BIT | id_of(payload[g]);
                continue;
            }
            let f = first_child[g] as usize;
            if packed_bits > 0 && (f..f + 8).all(|c| is_leaf[c]) {
                let per = (32 / packed_bits) as usize;
                let words = 8 / per;
                let base = blocks.len();
                nodes[slot] = SVO_PACKED_BIT | (base / words) as u32;
                blocks.extend(std::iter::repeat_n(0u32, words));
                for c in 0..8 {
                    let id = id_of(payload[f + c]);
                    blocks[base + c / per] |= id << (packed_bits as usize * (c % per));
                }
                continue;
            }
            let base = nodes.len();
            nodes[slot] = base as u32;
            nodes.extend([0u32; 8]);
            for c in 0..8 {
                queue.push_back((f + c, base + c));
            }
        }
        let layout_time = t2.elapsed();

        let header = SvoHeader {
            origin: origin.as_vec3().to_array(),
            size: size as f32,
            depth,
            node_count: nodes.len() as u32,
            leaf_count: leaves.len() as u32,
            block_count: (blocks.len() * 4)
                .checked_div(packed_bits as usize)
                .unwrap_or(0) as u32,
            packed_bits,
            pad: [0; 3],
        };
        let bytes = size_of::<SvoHeader>() + nodes.len() * 4 + blocks.len() * 4 + leaves.len() * 16;
        let stats = SvoStats {
            finest_voxel_size: (size / (1u64 << depth) as f64) as f32,
            full_nodes: total,
            surface_leaves,
            empty_leaves: full_leaves - surface_leaves,
            leaves_without_probe,
            nodes: nodes.len(),
            blocks: header.block_count as usize,
            payloads: leaves.len(),
            bytes,
            full_bytes: size_of::<SvoHeader>() + total * 4 + full_leaves * 16,
            visibility_queries,
            subdivide_time,
            rank_time,
            layout_time,
        };
        Ok(Self {
            header,
            nodes,
            blocks,
            leaves,
            stats,
        })
    }

    /// The header (root cube and counts).
    pub fn header(&self) -> &SvoHeader {
        &self.header
    }

    /// The node words (layout in [`SvoHeader`]'s documentation).
    pub fn nodes(&self) -> &[u32] {
        &self.nodes
    }

    /// The packed leaf blocks as words (layout in [`SvoHeader`]'s documentation).
    pub fn blocks(&self) -> &[u32] {
        &self.blocks
    }

    /// Payload index of child slot `c` (0..8) of packed block `b`.
    ///
    /// # Panics
    /// If `b` or `c` is out of range.
    pub fn packed_child(&self, b: u32, c: usize) -> u32 {
        let bits = self.header.packed_bits as usize;
        let per = 32 / bits;
        let w = self.blocks[b as usize * (8 / per) + c / per];
        (w >> (bits * (c % per))) & ((1u64 << bits) - 1) as u32
    }

    /// The leaf payloads: up to 4 probes, best first, [`NO_PROBE`] for empty slots.
    pub fn leaves(&self) -> &[[u32; 4]] {
        &self.leaves
    }

    /// Counts, bytes and timings of the build.
    pub fn stats(&self) -> &SvoStats {
        &self.stats
    }

    /// Bytes of the flat layout.
    pub fn memory_bytes(&self) -> usize {
        self.stats.bytes
    }

    /// The best probes for position `p` (clamped into the root cube), in O(depth), and the
    /// depth of the leaf reached. A non-finite `p` is looked up at the cube's min corner
    /// (the [`ProbeSelector`] answers such queries with no candidates instead).
    pub fn lookup(&self, p: Vec3) -> ([u32; 4], u32) {
        let origin = Vec3::from(self.header.origin);
        let mut size = self.header.size;
        let mut lo = origin;
        let p = if p.is_finite() { p } else { origin };
        let p = p.clamp(origin, origin + Vec3::splat(size));
        let mut index = 0usize;
        let mut level = 0u32;
        loop {
            let word = self.nodes[index];
            if word & SVO_LEAF_BIT != 0 {
                return (self.leaves[(word & !SVO_LEAF_BIT) as usize], level);
            }
            size *= 0.5;
            let mid = lo + Vec3::splat(size);
            if word & SVO_PACKED_BIT != 0 {
                let c = usize::from(p.x >= mid.x)
                    | usize::from(p.y >= mid.y) << 1
                    | usize::from(p.z >= mid.z) << 2;
                let id = self.packed_child(word & !SVO_PACKED_BIT, c);
                return (self.leaves[id as usize], level + 1);
            }
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
            index = word as usize + child;
            level += 1;
        }
    }
}

impl ProbeSelector for SparseVoxelOctree {
    /// The leaf's probes at the position, best first, without the failed probe (seed 000
    /// Alg. 5: the leaf's visibility test is what keeps a ray from cycling between probes).
    fn select(&self, query: &ProbeQuery) -> ProbeCandidates {
        let mut out = ProbeCandidates::new();
        if !query.position.is_finite() || !query.direction.is_finite() {
            return out;
        }
        for probe in self.lookup(query.position).0 {
            if probe != NO_PROBE && Some(probe) != query.failed_probe {
                out.push(probe);
            }
        }
        out
    }
}

/// The root cube: the box of the triangles and probes (or the given bounds), made cubic and
/// slightly enlarged so nothing lies on its far faces.
fn cube_bounds(
    triangles: &[[Vec3; 3]],
    probes: &[Vec3],
    bounds: Option<(Vec3, Vec3)>,
) -> (DVec3, f64) {
    let (lo, hi) = match bounds {
        Some((a, b)) if a.is_finite() && b.is_finite() => (a.min(b), a.max(b)),
        _ => {
            let mut lo = Vec3::splat(f32::INFINITY);
            let mut hi = Vec3::splat(f32::NEG_INFINITY);
            for v in triangles.iter().flatten().chain(probes) {
                lo = lo.min(*v);
                hi = hi.max(*v);
            }
            (lo, hi)
        }
    };
    let (lo, hi) = (lo.as_dvec3(), hi.as_dvec3());
    let extent = (hi - lo).max_element();
    let side = if extent > 0.0 { extent * 1.001 } else { 1.0 };
    let centre = (lo + hi) * 0.5;
    (centre - DVec3::splat(side * 0.5), side)
}

/// Ranks the candidate probes for one leaf; returns the best 4 visible ones and the number of
/// visibility queries made.
#[allow(clippy::too_many_arguments)]
fn rank_leaf(
    geometry: &dyn SceneGeometry,
    probes: &[Vec3],
    nearest: &NearestProbe,
    k: usize,
    lo: Vec3,
    hi: Vec3,
    planes: &[(Vec3, f32)],
    surface: bool,
    samples: u32,
    seed: u64,
    scratch: &mut Vec<(u32, f32)>,
) -> ([u32; 4], u64) {
    let centre = (lo + hi) * 0.5;
    nearest.nearest_k(centre, k, scratch);
    let mut scored: Vec<(f32, u32)> = scratch
        .iter()
        .map(|&(probe, d2)| {
            let d = d2.sqrt().max(1e-12);
            let score = if planes.is_empty() {
                1.0 / d
            } else {
                let dir = (probes[probe as usize] - centre) / d;
                planes
                    .iter()
                    .map(|(n, _)| n.dot(dir).abs())
                    .fold(0.0f32, f32::max)
                    / d
            };
            (score, probe)
        })
        .collect();
    scored.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    // Seed 000 §4.2.2: surfaces are tested from the voxel centre, empty space from random
    // points in the voxel as well.
    let mut queries = 0u64;
    let mut pick = |points: &[Vec3]| {
        let mut best = [NO_PROBE; 4];
        let mut found = 0;
        for &(_, probe) in &scored {
            let target = probes[probe as usize];
            let visible = points.iter().any(|&s| {
                queries += 1;
                geometry.segment_visible(s, target)
            });
            if visible {
                best[found] = probe;
                found += 1;
                if found == 4 {
                    break;
                }
            }
        }
        best
    };
    let best = if planes.is_empty() {
        let mut rng = SplitMix64::new(seed);
        let mut points = Vec::with_capacity(samples as usize + 1);
        points.push(centre);
        for _ in 0..samples {
            let u = Vec3::new(rng.unit_f32(), rng.unit_f32(), rng.unit_f32());
            points.push(lo + (hi - lo) * u);
        }
        pick(&points)
    } else {
        let from_centre = pick(&[centre]);
        match planes.first() {
            // A surface voxel whose centre sees no probe lies behind its surface (or inside a
            // solid): test from the centre's projection onto the surface, a quarter voxel off
            // it on either side — deterministic, so neighbouring voxels agree.
            Some(&(n, offset)) if surface && from_centre[0] == NO_PROBE => {
                let on_plane = centre - n * (n.dot(centre) - offset);
                let step = n * ((hi.x - lo.x) * 0.25);
                pick(&[on_plane + step, on_plane - step])
            }
            _ => from_centre,
        }
    };
    (best, queries)
}
