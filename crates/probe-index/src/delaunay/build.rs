//! Incremental Bowyer–Watson construction with an infinite vertex (ghost tetrahedra on every
//! hull face, as in CGAL), exact predicates and symbolic perturbation.

use crate::predicates::{self, P3, ghost_conflict, orient, sphere_conflict};
use crate::rng::SplitMix64;

/// The infinite vertex.
pub(crate) const INF: u32 = u32::MAX;
/// Marks a freed tetrahedron slot (stored in its first vertex).
const DEAD: u32 = u32::MAX - 1;

/// The raw result: compact vertex ids (`0..points.len()`), live tetrahedra including ghosts.
pub(crate) struct RawTriangulation {
    slots: Vec<Slot>,
}

impl RawTriangulation {
    /// Number of slots (live or freed).
    pub(crate) fn len(&self) -> usize {
        self.slots.len()
    }
    /// Whether slot `t` holds a tetrahedron.
    pub(crate) fn is_alive(&self, t: usize) -> bool {
        self.slots[t].v[0] != DEAD
    }
    /// Vertices of slot `t`; ghosts contain [`INF`].
    pub(crate) fn vertices(&self, t: usize) -> [u32; 4] {
        self.slots[t].v
    }
    /// Neighbours of slot `t`: across face `i` (opposite vertex `i`), encoded `tet << 2 | face`.
    pub(crate) fn neighbours(&self, t: usize) -> [u32; 4] {
        self.slots[t].n
    }
}

/// Why construction could not start.
#[derive(Debug, PartialEq, Eq)]
pub(crate) enum StartFailure {
    TooFew,
    Collinear,
    Coplanar,
}

/// One tetrahedron slot during construction: vertices, neighbours and the cavity mark together,
/// so a visit touches one cache line.
#[derive(Clone, Copy)]
struct Slot {
    v: [u32; 4],
    n: [u32; 4],
    mark: u32,
}

struct Builder<'a> {
    pts: &'a [P3],
    tets: Vec<Slot>,
    free: Vec<u32>,
    stamp: u32,
    cavity: Vec<u32>,
    stack: Vec<u32>,
    boundary: Vec<([u32; 4], u8, u32)>,
    edges: EdgeTable,
    rng: SplitMix64,
    last: u32,
}

/// Open-addressing table matching the new tetrahedra's faces around the cavity's boundary edges.
struct EdgeTable {
    keys: Vec<u64>,
    values: Vec<u32>,
    used: Vec<usize>,
    mask: usize,
}

const EMPTY_KEY: u64 = u64::MAX;

impl EdgeTable {
    fn new() -> Self {
        let size = 256;
        Self {
            keys: vec![EMPTY_KEY; size],
            values: vec![0; size],
            used: Vec::new(),
            mask: size - 1,
        }
    }

    /// Makes room for `entries` keys (keeps the load factor under one quarter).
    fn reserve(&mut self, entries: usize) {
        let wanted = (entries * 4).next_power_of_two().max(256);
        if wanted > self.keys.len() {
            self.keys = vec![EMPTY_KEY; wanted];
            self.values = vec![0; wanted];
            self.used.clear();
            self.mask = wanted - 1;
        }
    }

    /// Inserts `key → value`, or removes and returns the value already stored under `key`.
    #[inline]
    fn pair(&mut self, key: u64, value: u32) -> Option<u32> {
        let mut slot = (key.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 40) as usize & self.mask;
        loop {
            let k = self.keys[slot];
            if k == EMPTY_KEY {
                self.keys[slot] = key;
                self.values[slot] = value;
                self.used.push(slot);
                return None;
            }
            if k == key {
                // Tombstone: a key pairs exactly twice, so the slot is never searched for again
                // in this cavity; it is cleared with the others below.
                self.keys[slot] = EMPTY_KEY - 1;
                return Some(self.values[slot]);
            }
            slot = (slot + 1) & self.mask;
        }
    }

    fn clear(&mut self) {
        for &slot in &self.used {
            self.keys[slot] = EMPTY_KEY;
        }
        self.used.clear();
    }
}

/// `OTHER_TWO[i][j]`: the two slots of a tetrahedron other than `i` and `j` (`i ≠ j`).
const OTHER_TWO: [[[usize; 2]; 4]; 4] = {
    let mut table = [[[0usize; 2]; 4]; 4];
    let mut i = 0;
    while i < 4 {
        let mut j = 0;
        while j < 4 {
            let mut n = 0;
            let mut k = 0;
            while k < 4 {
                if k != i && k != j && n < 2 {
                    table[i][j][n] = k;
                    n += 1;
                }
                k += 1;
            }
            j += 1;
        }
        i += 1;
    }
    table
};

#[inline]
fn edge_key(a: u32, b: u32) -> u64 {
    let (lo, hi) = if a < b { (a, b) } else { (b, a) };
    (u64::from(lo) << 32) | u64::from(hi)
}

/// For a ghost with the infinite vertex at position `k`, the positions of its finite face in the
/// order that makes `orient(face…, x)` equal the orientation with the infinite vertex replaced by x.
#[inline]
pub(crate) fn ghost_face_order(k: usize) -> [usize; 3] {
    if k % 2 == 1 {
        [(k + 1) & 3, (k + 2) & 3, (k + 3) & 3]
    } else {
        [(k + 2) & 3, (k + 1) & 3, (k + 3) & 3]
    }
}

/// Builds the Delaunay tetrahedralization of distinct `pts`, inserted in `order`.
pub(crate) fn triangulate(
    pts: &[P3],
    order: &[u32],
    seed: u64,
) -> Result<RawTriangulation, StartFailure> {
    let (first, rest) = initial_tetrahedron(pts, order)?;
    let mut b = Builder {
        pts,
        tets: Vec::with_capacity(pts.len() * 7 + 16),
        free: Vec::new(),
        stamp: 0,
        cavity: Vec::new(),
        stack: Vec::new(),
        boundary: Vec::new(),
        edges: EdgeTable::new(),
        rng: SplitMix64::new(seed ^ 0x005E_ED0F_DE1A),
        last: 0,
    };
    b.start(first);
    for &v in &rest {
        b.insert(v);
    }
    Ok(RawTriangulation { slots: b.tets })
}

/// Picks four affinely independent points (in insertion order) and returns them, positively
/// oriented, with the remaining order.
fn initial_tetrahedron(pts: &[P3], order: &[u32]) -> Result<([u32; 4], Vec<u32>), StartFailure> {
    if order.len() < 4 {
        return Err(StartFailure::TooFew);
    }
    let a = order[0];
    let b = order[1];
    let pa = &pts[a as usize];
    let pb = &pts[b as usize];
    let c_pos = order[2..]
        .iter()
        .position(|&c| !predicates::collinear(pa, pb, &pts[c as usize]))
        .ok_or(StartFailure::Collinear)?
        + 2;
    let c = order[c_pos];
    let pc = &pts[c as usize];
    let d_pos = order[2..]
        .iter()
        .position(|&d| orient(pa, pb, pc, &pts[d as usize]) != 0)
        .ok_or(StartFailure::Coplanar)?
        + 2;
    let d = order[d_pos];
    let rest: Vec<u32> = order
        .iter()
        .enumerate()
        .filter(|&(i, _)| i >= 2 && i != c_pos && i != d_pos)
        .map(|(_, &v)| v)
        .collect();
    let tet = if orient(pa, pb, pc, &pts[d as usize]) > 0 {
        [a, b, c, d]
    } else {
        [b, a, c, d]
    };
    Ok((tet, rest))
}

impl Builder<'_> {
    #[inline]
    fn p(&self, v: u32) -> &P3 {
        &self.pts[v as usize]
    }

    fn alloc(&mut self, v: [u32; 4]) -> u32 {
        if let Some(t) = self.free.pop() {
            let slot = &mut self.tets[t as usize];
            slot.v = v;
            slot.mark = 0;
            t
        } else {
            self.tets.push(Slot {
                v,
                n: [0; 4],
                mark: 0,
            });
            (self.tets.len() - 1) as u32
        }
    }

    /// The first finite tetrahedron and its four ghosts.
    fn start(&mut self, t0: [u32; 4]) {
        let mut all = vec![t0];
        for i in 0..4 {
            let mut g = t0;
            g[i] = INF;
            // Flip so that replacing INF by a point beyond face i is positive.
            let (j, k) = match i {
                0 => (1, 2),
                1 => (0, 2),
                _ => (0, 1),
            };
            g.swap(j, k);
            all.push(g);
        }
        let ids: Vec<u32> = all.iter().map(|&v| self.alloc(v)).collect();
        for (x, &tx) in ids.iter().enumerate() {
            for i in 0..4 {
                let fx = face_set(&all[x], i);
                for (y, &ty) in ids.iter().enumerate() {
                    if x == y {
                        continue;
                    }
                    for j in 0..4 {
                        if face_set(&all[y], j) == fx {
                            self.tets[tx as usize].n[i] = (ty << 2) | j as u32;
                        }
                    }
                }
            }
        }
        self.last = ids[0];
    }

    #[inline]
    fn is_ghost(&self, t: u32) -> bool {
        self.tets[t as usize].v.contains(&INF)
    }

    /// Orientation of tetrahedron `t` (finite) with its vertex `i` replaced by point `p`.
    #[inline]
    fn orient_replaced(&self, t: u32, i: usize, p: &P3) -> i32 {
        let v = self.tets[t as usize].v;
        let q = |k: usize| if k == i { p } else { self.p(v[k]) };
        orient(q(0), q(1), q(2), q(3))
    }

    /// A tetrahedron in conflict with `p`: a finite one whose closure holds `p`, or a ghost
    /// whose hull face `p` is strictly beyond. Remembering stochastic visibility walk.
    fn locate(&mut self, p: &P3) -> u32 {
        let mut t = self.last;
        let mut prev = u32::MAX;
        let limit = self.tets.len() * 4 + 64;
        let mut steps = 0usize;
        'walk: loop {
            steps += 1;
            if steps > limit {
                // A Delaunay triangulation admits no cycle in a visibility walk; this bound
                // only guards against an internal error turning into an endless loop.
                return self.locate_by_scan(p);
            }
            let r = (self.rng.next_u64() >> 62) as usize;
            for k in 0..4 {
                let i = (r + k) & 3;
                let next = self.tets[t as usize].n[i] >> 2;
                if next == prev {
                    continue;
                }
                if self.orient_replaced(t, i, p) < 0 {
                    prev = t;
                    t = next;
                    if self.is_ghost(t) {
                        return t;
                    }
                    continue 'walk;
                }
            }
            return t;
        }
    }

    fn locate_by_scan(&self, p: &P3) -> u32 {
        for t in 0..self.tets.len() as u32 {
            if self.tets[t as usize].v[0] == DEAD {
                continue;
            }
            if self.conflicts(t, p) {
                return t;
            }
        }
        self.last
    }

    #[inline]
    fn conflicts(&self, t: u32, p: &P3) -> bool {
        let v = self.tets[t as usize].v;
        if let Some(k) = v.iter().position(|&x| x == INF) {
            let [i0, i1, i2] = ghost_face_order(k);
            ghost_conflict(self.p(v[i0]), self.p(v[i1]), self.p(v[i2]), p) > 0
        } else {
            sphere_conflict(self.p(v[0]), self.p(v[1]), self.p(v[2]), self.p(v[3]), p) > 0
        }
    }

    fn insert(&mut self, pv: u32) {
        let p = self.pts[pv as usize];
        let start = self.locate(&p);
        self.stamp = self.stamp.wrapping_add(1);
        if self.stamp >= u32::MAX / 2 {
            self.tets.iter_mut().for_each(|s| s.mark = 0);
            self.stamp = 1;
        }
        let inside = self.stamp * 2;
        let outside = inside + 1;
        self.cavity.clear();
        self.boundary.clear();
        self.stack.clear();
        self.tets[start as usize].mark = inside;
        self.cavity.push(start);
        self.stack.push(start);
        while let Some(c) = self.stack.pop() {
            for i in 0..4 {
                let nb = self.tets[c as usize].n[i];
                let nt = nb >> 2;
                let m = self.tets[nt as usize].mark;
                if m == inside {
                    continue;
                }
                if m != outside && self.conflicts(nt, &p) {
                    self.tets[nt as usize].mark = inside;
                    self.cavity.push(nt);
                    self.stack.push(nt);
                    continue;
                }
                self.tets[nt as usize].mark = outside;
                let mut w = self.tets[c as usize].v;
                w[i] = pv;
                self.boundary.push((w, i as u8, nb));
            }
        }
        // Free the cavity, then build the star of p on its boundary.
        for &c in &self.cavity {
            self.tets[c as usize].v[0] = DEAD;
        }
        self.free.extend(self.cavity.iter().rev());
        self.edges.reserve(self.boundary.len() * 3 / 2 + 8);
        let boundary = std::mem::take(&mut self.boundary);
        let mut last_finite = u32::MAX;
        for &(w, i, outer) in &boundary {
            let t = self.alloc(w);
            let i = i as usize;
            self.tets[t as usize].n[i] = outer;
            self.tets[(outer >> 2) as usize].n[(outer & 3) as usize] = (t << 2) | i as u32;
            for (j, &[k1, k2]) in OTHER_TWO[i].iter().enumerate() {
                if j == i {
                    continue;
                }
                // The face opposite w[j] holds p and the edge of the two other vertices.
                let me = (t << 2) | j as u32;
                if let Some(other) = self.edges.pair(edge_key(w[k1], w[k2]), me) {
                    self.tets[t as usize].n[j] = other;
                    self.tets[(other >> 2) as usize].n[(other & 3) as usize] = me;
                }
            }
            if !w.contains(&INF) {
                debug_assert!(
                    orient(self.p(w[0]), self.p(w[1]), self.p(w[2]), self.p(w[3])) > 0,
                    "flat or inverted tetrahedron created"
                );
                last_finite = t;
            }
        }
        self.edges.clear();
        self.boundary = boundary;
        if last_finite != u32::MAX {
            self.last = last_finite;
        }
    }
}

fn face_set(v: &[u32; 4], i: usize) -> [u32; 3] {
    let mut f = [0u32; 3];
    let mut n = 0;
    for (k, &x) in v.iter().enumerate() {
        if k != i {
            f[n] = x;
            n += 1;
        }
    }
    f.sort_unstable();
    f
}
