//! Test support: seeded random points, independent exact checks of a tetrahedralization, and
//! synthetic scene geometry with a brute-force ray caster.

#![allow(dead_code)]

use glam::Vec3;
use probe_index::{
    NO_NEIGHBOUR, NO_PROBE, RayHit, SceneGeometry, SparseVoxelOctree, Tetrahedralization,
    triangle_overlaps_box,
};
use robust::Coord3D;

/// SplitMix64, independent of the crate's own copy.
pub struct Rng(pub u64);

impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    pub fn f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }
    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.f32()
    }
    pub fn vec3(&mut self, lo: f32, hi: f32) -> Vec3 {
        Vec3::new(self.range(lo, hi), self.range(lo, hi), self.range(lo, hi))
    }
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
}

fn c(p: Vec3) -> Coord3D<f64> {
    Coord3D {
        x: p.x as f64,
        y: p.y as f64,
        z: p.z as f64,
    }
}

/// det[b−a, c−a, d−a] sign (right-handed positive), exact.
pub fn orient(a: Vec3, b: Vec3, cc: Vec3, d: Vec3) -> f64 {
    -robust::orient3d(c(a), c(b), c(cc), c(d))
}

/// Positive when `e` is strictly inside the sphere of the right-handed `a, b, cc, d`, exact.
pub fn in_sphere(a: Vec3, b: Vec3, cc: Vec3, d: Vec3, e: Vec3) -> f64 {
    -robust::insphere(c(a), c(b), c(cc), c(d), c(e))
}

/// Signed volume of a tetrahedron in f64.
pub fn volume(a: Vec3, b: Vec3, cc: Vec3, d: Vec3) -> f64 {
    let (a, b, cc, d) = (a.as_dvec3(), b.as_dvec3(), cc.as_dvec3(), d.as_dvec3());
    (b - a).cross(cc - a).dot(d - a) / 6.0
}

/// Independent structural checks: positive orientation, mutual face-sharing adjacency, every
/// hull face accounted for, every distinct point used. Returns the total volume.
pub fn check_structure(t: &Tetrahedralization) -> f64 {
    let pts = t.points();
    let tets = t.tetrahedra();
    let mut total = 0.0;
    let mut open = 0;
    for (i, r) in tets.iter().enumerate() {
        let [a, b, cc, d] = r.vertices.map(|v| pts[v as usize]);
        assert!(
            orient(a, b, cc, d) > 0.0,
            "tet {i} not positive: {:?}",
            r.vertices
        );
        total += volume(a, b, cc, d);
        for f in 0..4 {
            let n = r.neighbours[f];
            if n == NO_NEIGHBOUR {
                open += 1;
                continue;
            }
            let other = &tets[n as usize];
            let back = other
                .neighbours
                .iter()
                .position(|&x| x == i as u32)
                .unwrap_or_else(|| panic!("tet {i} face {f}: neighbour {n} does not link back"));
            let mut f1: Vec<u32> = (0..4).filter(|&k| k != f).map(|k| r.vertices[k]).collect();
            let mut f2: Vec<u32> = (0..4)
                .filter(|&k| k != back)
                .map(|k| other.vertices[k])
                .collect();
            f1.sort();
            f2.sort();
            assert_eq!(f1, f2, "tet {i} face {f}: shared face differs");
        }
    }
    assert_eq!(open, t.hull_faces().len(), "open faces vs hull faces");
    let mut used = vec![false; pts.len()];
    for r in tets {
        for &v in &r.vertices {
            used[v as usize] = true;
        }
    }
    for i in 0..pts.len() {
        assert!(used[t.vertex_of(i) as usize], "point {i} unused");
        assert_eq!(
            pts[t.vertex_of(i) as usize],
            pts[i],
            "vertex_of maps to another position"
        );
    }
    total
}

/// Empty-circumsphere property: no distinct point strictly inside any tetrahedron's sphere.
/// `sample`: check only that many (tet, point) pairs chosen at random, plus, for every
/// tetrahedron, its 64 nearest points by index order of a coarse grid bucket.
pub fn check_empty_spheres(t: &Tetrahedralization, sample: Option<(usize, u64)>) {
    let pts = t.points();
    let tets = t.tetrahedra();
    let verts: Vec<u32> = (0..pts.len())
        .filter(|&i| t.vertex_of(i) as usize == i)
        .map(|i| i as u32)
        .collect();
    let check = |ti: usize, v: u32| {
        let r = &tets[ti];
        if r.vertices.contains(&v) {
            return;
        }
        let [a, b, cc, d] = r.vertices.map(|x| pts[x as usize]);
        let s = in_sphere(a, b, cc, d, pts[v as usize]);
        assert!(
            s <= 0.0,
            "point {v} strictly inside the sphere of tet {ti} {:?}",
            r.vertices
        );
    };
    match sample {
        None => {
            for ti in 0..tets.len() {
                for &v in &verts {
                    check(ti, v);
                }
            }
        }
        Some((count, seed)) => {
            let mut rng = Rng(seed);
            for _ in 0..count {
                check(rng.below(tets.len()), verts[rng.below(verts.len())]);
            }
            // Near pairs matter most: each tetrahedron against the vertices of its neighbours'
            // neighbours.
            for ti in (0..tets.len()).step_by(7) {
                for &n in &tets[ti].neighbours {
                    if n == NO_NEIGHBOUR {
                        continue;
                    }
                    for &m in &tets[n as usize].neighbours {
                        if m == NO_NEIGHBOUR {
                            continue;
                        }
                        for &v in &tets[m as usize].vertices {
                            check(ti, v);
                        }
                    }
                }
            }
        }
    }
}

/// Full check used by most tests.
pub fn check_all(t: &Tetrahedralization, hull_volume: Option<f64>, exhaustive: bool) {
    let total = check_structure(t);
    t.validate().expect("validate");
    check_empty_spheres(
        t,
        if exhaustive {
            None
        } else {
            Some((200_000, 99))
        },
    );
    if let Some(v) = hull_volume {
        assert!(
            (total - v).abs() <= 1e-9 * v.abs().max(1e-30) + 1e-12 * v.abs().max(1.0),
            "volume {total} vs hull {v}"
        );
    }
}

/// Triangles of an axis-aligned box (12, outward).
pub fn box_triangles(lo: Vec3, hi: Vec3) -> Vec<[Vec3; 3]> {
    let p = |i: usize| {
        Vec3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        )
    };
    let quads = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    let mut out = Vec::new();
    for q in quads {
        out.push([p(q[0]), p(q[1]), p(q[2])]);
        out.push([p(q[0]), p(q[2]), p(q[3])]);
    }
    out
}

/// Triangle soup with a brute-force closest-hit ray caster (Möller–Trumbore, double-sided).
pub struct Soup {
    pub triangles: Vec<[Vec3; 3]>,
}

impl Soup {
    pub fn new(triangles: Vec<[Vec3; 3]>) -> Self {
        Self { triangles }
    }
}

impl SceneGeometry for Soup {
    fn triangle_count(&self) -> usize {
        self.triangles.len()
    }
    fn triangle(&self, index: usize) -> [Vec3; 3] {
        self.triangles[index]
    }
    fn closest_hit(&self, origin: Vec3, direction: Vec3, max_distance: f32) -> Option<RayHit> {
        let mut best: Option<RayHit> = None;
        for tri in &self.triangles {
            let e1 = tri[1] - tri[0];
            let e2 = tri[2] - tri[0];
            let pv = direction.cross(e2);
            let det = e1.dot(pv);
            if det.abs() < 1e-12 {
                continue;
            }
            let inv = 1.0 / det;
            let tv = origin - tri[0];
            let u = tv.dot(pv) * inv;
            if !(0.0..=1.0).contains(&u) {
                continue;
            }
            let qv = tv.cross(e1);
            let v = direction.dot(qv) * inv;
            if v < 0.0 || u + v > 1.0 {
                continue;
            }
            let d = e2.dot(qv) * inv;
            if d > 0.0 && d <= max_distance && best.is_none_or(|b| d < b.distance) {
                best = Some(RayHit {
                    distance: d,
                    normal: e1.cross(e2).normalize(),
                });
            }
        }
        best
    }
}

// Independent recomputation of the octree's leaves and payloads.

/// The full-tree leaf holding `p`, found independently (descend while triangles overlap):
/// its box, level, whether it overlaps triangles, and its parent's box.
pub struct FullLeaf {
    pub lo: Vec3,
    pub hi: Vec3,
    pub level: u32,
    pub surface: bool,
    pub parent: (Vec3, Vec3),
}

pub fn full_leaf(
    scene: &dyn SceneGeometry,
    svo: &SparseVoxelOctree,
    depth: u32,
    p: Vec3,
) -> FullLeaf {
    let h = svo.header();
    let mut lo = Vec3::from(h.origin);
    let mut size = h.size;
    let mut parent = (lo, lo + Vec3::splat(size));
    for level in 0..=depth {
        let hi = lo + Vec3::splat(size);
        let overlaps =
            (0..scene.triangle_count()).any(|i| triangle_overlaps_box(&scene.triangle(i), lo, hi));
        if !overlaps || level == depth {
            return FullLeaf {
                lo,
                hi,
                level,
                surface: overlaps,
                parent,
            };
        }
        parent = (lo, hi);
        size *= 0.5;
        let mid = lo + Vec3::splat(size);
        lo = Vec3::select(p.cmpge(mid), mid, lo);
    }
    unreachable!()
}

/// Planes (unit normal, a point) of the triangles overlapping a box, in triangle order.
pub fn normals_in(scene: &dyn SceneGeometry, lo: Vec3, hi: Vec3) -> Vec<(Vec3, Vec3)> {
    (0..scene.triangle_count())
        .map(|i| scene.triangle(i))
        .filter(|t| triangle_overlaps_box(t, lo, hi))
        .filter(|t| (t[1] - t[0]).cross(t[2] - t[0]).length_squared() > 0.0)
        .map(|t| ((t[1] - t[0]).cross(t[2] - t[0]).normalize(), t[0]))
        // The crate ranks by at most 16 normals per leaf, the first in scene order.
        .take(16)
        .collect()
}

/// Seed 000's ranking from the centre only (visibility_samples = 0), computed independently:
/// visible probes by |n·p̂|/d with the given planes, or by 1/d without. A voxel overlapping
/// geometry whose centre sees nothing is tested from its centre's projection on the first
/// plane, a quarter voxel to either side.
pub fn expected_payload(
    scene: &dyn SceneGeometry,
    probes: &[Vec3],
    lo: Vec3,
    hi: Vec3,
    planes: &[(Vec3, Vec3)],
    overlaps: bool,
) -> [u32; 4] {
    let mut out = [NO_PROBE; 4];
    for (k, (_, i)) in expected_ranking(scene, probes, lo, hi, planes, overlaps)
        .iter()
        .take(4)
        .enumerate()
    {
        out[k] = *i;
    }
    out
}

/// Every visible probe with its score, best first: [`expected_payload`] before it keeps 4.
pub fn expected_ranking(
    scene: &dyn SceneGeometry,
    probes: &[Vec3],
    lo: Vec3,
    hi: Vec3,
    planes: &[(Vec3, Vec3)],
    overlaps: bool,
) -> Vec<(f32, u32)> {
    let c = (lo + hi) * 0.5;
    let from_centre = rank(scene, probes, c, &[c], planes);
    if overlaps && from_centre.is_empty() {
        let (n, a) = planes[0];
        let q = c - n * n.dot(c - a);
        let step = n * (hi.x - lo.x) * 0.25;
        return rank(scene, probes, c, &[q + step, q - step], planes);
    }
    from_centre
}

fn rank(
    scene: &dyn SceneGeometry,
    probes: &[Vec3],
    c: Vec3,
    from: &[Vec3],
    planes: &[(Vec3, Vec3)],
) -> Vec<(f32, u32)> {
    let surface = !planes.is_empty();
    let normals: Vec<Vec3> = planes.iter().map(|p| p.0).collect();
    let mut scored: Vec<(f32, u32)> = probes
        .iter()
        .enumerate()
        .filter(|(_, p)| from.iter().any(|&f| scene.segment_visible(f, **p)))
        .map(|(i, p)| {
            let d = (*p - c).length();
            let s = if surface {
                normals
                    .iter()
                    .map(|n| n.dot((*p - c) / d).abs())
                    .fold(0.0, f32::max)
                    / d
            } else {
                1.0 / d
            };
            (s, i as u32)
        })
        .collect();
    scored.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    scored
}
