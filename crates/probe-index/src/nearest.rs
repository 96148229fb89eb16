//! Nearest probe (the Voronoi cell a point falls in, seed 000 §4.1.1) by a balanced k-d tree
//! stored implicitly in one flat array.

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

/// One k-d tree node (16 bytes). WGSL mirror: `struct KdNode { position: vec3<f32>, probe: u32 }`.
///
/// The tree over the index range `[lo, hi)` has its root at `mid = (lo + hi) / 2`, the left
/// subtree on `[lo, mid)` and the right one on `[mid + 1, hi)`; the split axis is the depth
/// mod 3 (x, y, z). Left positions are ≤ the root's on that axis, right ones ≥.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct KdNode {
    /// The probe's position.
    pub position: [f32; 3],
    /// The probe's index.
    pub probe: u32,
}

/// Exact nearest-probe queries over a fixed probe set.
#[derive(Clone, Debug)]
pub struct NearestProbe {
    nodes: Vec<KdNode>,
}

impl NearestProbe {
    /// Builds the tree over `positions` (probe `i` at `positions[i]`); non-finite positions are
    /// left out.
    pub fn new(positions: &[Vec3]) -> Self {
        let mut nodes: Vec<KdNode> = positions
            .iter()
            .enumerate()
            .filter(|(_, p)| p.is_finite())
            .map(|(i, p)| KdNode {
                position: p.to_array(),
                probe: i as u32,
            })
            .collect();
        build(&mut nodes, 0);
        Self { nodes }
    }

    /// The flat tree, for upload.
    pub fn nodes(&self) -> &[KdNode] {
        &self.nodes
    }

    /// Bytes held.
    pub fn memory_bytes(&self) -> usize {
        self.nodes.len() * size_of::<KdNode>()
    }

    /// The probe nearest to `p` and its squared distance; ties go to the lower probe index
    /// (so a duplicate position answers with its first index). `None` without probes or for a
    /// non-finite `p`.
    pub fn nearest(&self, p: Vec3) -> Option<(u32, f32)> {
        if self.nodes.is_empty() || !p.is_finite() {
            return None;
        }
        let mut best = (u32::MAX, f32::INFINITY);
        self.search(p.to_array(), 0, self.nodes.len(), 0, &mut best);
        Some(best)
    }

    fn search(&self, p: [f32; 3], lo: usize, hi: usize, depth: usize, best: &mut (u32, f32)) {
        if lo >= hi {
            return;
        }
        let mid = (lo + hi) / 2;
        let node = &self.nodes[mid];
        let d2 = dist2(node.position, p);
        if d2 < best.1 || (d2 == best.1 && node.probe < best.0) {
            *best = (node.probe, d2);
        }
        let axis = depth % 3;
        let delta = p[axis] - node.position[axis];
        let (near, far) = if delta < 0.0 {
            ((lo, mid), (mid + 1, hi))
        } else {
            ((mid + 1, hi), (lo, mid))
        };
        self.search(p, near.0, near.1, depth + 1, best);
        if delta * delta <= best.1 {
            self.search(p, far.0, far.1, depth + 1, best);
        }
    }

    /// The `k` probes nearest to `p`, nearest first, as `(probe, squared distance)`, into `out`
    /// (cleared first). Ties go to the lower index.
    pub fn nearest_k(&self, p: Vec3, k: usize, out: &mut Vec<(u32, f32)>) {
        out.clear();
        if k == 0 || !p.is_finite() {
            return;
        }
        self.search_k(p.to_array(), 0, self.nodes.len(), 0, k, out);
    }

    fn search_k(
        &self,
        p: [f32; 3],
        lo: usize,
        hi: usize,
        depth: usize,
        k: usize,
        out: &mut Vec<(u32, f32)>,
    ) {
        if lo >= hi {
            return;
        }
        let mid = (lo + hi) / 2;
        let node = &self.nodes[mid];
        let d2 = dist2(node.position, p);
        let worse = |a: &(u32, f32), b: &(u32, f32)| a.1 > b.1 || (a.1 == b.1 && a.0 > b.0);
        let cand = (node.probe, d2);
        if out.len() < k || worse(&out[out.len() - 1], &cand) {
            let at = out.partition_point(|e| !worse(e, &cand));
            out.insert(at, cand);
            out.truncate(k);
        }
        let axis = depth % 3;
        let delta = p[axis] - node.position[axis];
        let (near, far) = if delta < 0.0 {
            ((lo, mid), (mid + 1, hi))
        } else {
            ((mid + 1, hi), (lo, mid))
        };
        self.search_k(p, near.0, near.1, depth + 1, k, out);
        if out.len() < k || delta * delta <= out[out.len() - 1].1 {
            self.search_k(p, far.0, far.1, depth + 1, k, out);
        }
    }
}

#[inline]
fn dist2(a: [f32; 3], b: [f32; 3]) -> f32 {
    let d = [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
}

fn build(nodes: &mut [KdNode], depth: usize) {
    if nodes.len() <= 1 {
        return;
    }
    let axis = depth % 3;
    let mid = nodes.len() / 2;
    nodes.select_nth_unstable_by(mid, |a, b| {
        a.position[axis]
            .total_cmp(&b.position[axis])
            .then(a.probe.cmp(&b.probe))
    });
    let (left, rest) = nodes.split_at_mut(mid);
    build(left, depth + 1);
    build(&mut rest[1..], depth + 1);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::SplitMix64;

    #[test]
    fn matches_brute_force() {
        let mut rng = SplitMix64::new(3);
        let mut v = || rng.unit_f32() * 10.0 - 5.0;
        let pts: Vec<Vec3> = (0..500).map(|_| Vec3::new(v(), v(), v())).collect();
        let mut with_dup = pts.clone();
        with_dup.push(pts[17]);
        let tree = NearestProbe::new(&with_dup);
        let mut out = Vec::new();
        for _ in 0..300 {
            let q = Vec3::new(v(), v(), v()) * 1.3;
            let brute = with_dup
                .iter()
                .enumerate()
                .map(|(i, p)| (i as u32, (*p - q).length_squared()))
                .min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)))
                .unwrap();
            let got = tree.nearest(q).unwrap();
            assert_eq!(got.0, brute.0);
            tree.nearest_k(q, 7, &mut out);
            let mut all: Vec<(u32, f32)> = with_dup
                .iter()
                .enumerate()
                .map(|(i, p)| (i as u32, dist2(p.to_array(), q.to_array())))
                .collect();
            all.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
            assert_eq!(out, all[..7].to_vec());
        }
        assert_eq!(tree.nearest(pts[17]).unwrap().0, 17);
        assert!(tree.nearest(Vec3::NAN).is_none());
    }
}
