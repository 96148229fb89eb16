//! 3-D Delaunay tetrahedralization of probe positions, barycentric point location and
//! interpolation (seed 002 §3.2.1).

mod build;
mod order;

use std::collections::HashMap;
use std::ops::{Add, Mul};

use bytemuck::{Pod, Zeroable};
use glam::{DVec3, Vec3};

use crate::error::{DelaunayError, QueryError, ValidationError};
use crate::par::*;
use crate::predicates::{P3, in_sphere, orient};
use build::{INF, StartFailure, ghost_face_order};

/// Neighbour value meaning "no tetrahedron here: this face is on the convex hull".
pub const NO_NEIGHBOUR: u32 = u32::MAX;

/// Seed of the insertion order (BRIO rounds and walk face order). The tetrahedralization itself
/// does not depend on it (ties are broken by symbolic perturbation, not by order); only the
/// numbering of tetrahedra does.
const INSERTION_SEED: u64 = 0x0DE1_A0A7;

/// One tetrahedron, laid out for upload (80 bytes, 16-byte aligned members). WGSL mirror:
///
/// ```wgsl
/// struct TetRecord {
///     vertices: vec4<u32>,            // probe indices
///     neighbours: vec4<u32>,          // neighbours[i] is across the face opposite vertices[i];
///                                     // 0xFFFFFFFF on the convex hull
///     barycentric: array<vec4<f32>, 3>, // λi = dot(barycentric[i], vec4(p, 1)), i < 3;
///                                       // λ3 = 1 − λ0 − λ1 − λ2
/// }
/// ```
///
/// The three rows are Cupisz's precomputed 3×3 matrix (seed 002 §4.2, "precalculated 3-by-3
/// matrix") with the translation folded into the fourth column.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct TetRecord {
    /// The four probe indices (input indices of the probes), positively oriented.
    pub vertices: [u32; 4],
    /// Adjacent tetrahedra; `neighbours[i]` shares the face opposite `vertices[i]`.
    pub neighbours: [u32; 4],
    /// Rows of the world-to-barycentric transform.
    pub barycentric: [[f32; 4]; 3],
}

impl TetRecord {
    /// Barycentric coordinates of `p` with respect to this tetrahedron (they sum to one).
    #[inline]
    pub fn barycentric_of(&self, p: Vec3) -> [f32; 4] {
        let r = &self.barycentric;
        let l0 = r[0][0] * p.x + r[0][1] * p.y + r[0][2] * p.z + r[0][3];
        let l1 = r[1][0] * p.x + r[1][1] * p.y + r[1][2] * p.z + r[1][3];
        let l2 = r[2][0] * p.x + r[2][1] * p.y + r[2][2] * p.z + r[2][3];
        [l0, l1, l2, 1.0 - l0 - l1 - l2]
    }
}

/// A triangle of the convex hull (32 bytes). `vertices` are ordered so that they appear
/// counter-clockwise seen from outside.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Pod, Zeroable)]
pub struct HullFace {
    /// The three probe indices.
    pub vertices: [u32; 3],
    /// The tetrahedron inside this face.
    pub tetrahedron: u32,
    /// The three hull faces sharing an edge with this one.
    pub adjacent: [u32; 3],
    /// Which face of `tetrahedron` this is (the slot of the vertex opposite it).
    pub face: u32,
}

/// Where a point lies in the tetrahedralization, with its interpolation weights.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Location {
    /// The tetrahedron containing the point (or, outside the hull, the one under the nearest
    /// hull face). Pass it as the start of the next nearby query.
    pub tetrahedron: u32,
    /// The probes to blend: the tetrahedron's vertices.
    pub probes: [u32; 4],
    /// Non-negative weights summing to one, in the order of `probes`. Inside the hull these are
    /// the barycentric coordinates; outside they are those of the nearest point on the hull
    /// (the weight of the vertex off the nearest face is zero).
    pub weights: [f32; 4],
    /// Distance from the point to the hull: zero inside.
    pub outside_distance: f32,
    /// Tetrahedra visited by the walk (a cost figure).
    pub steps: u32,
}

/// Delaunay tetrahedralization of a probe set, with adjacency, convex-hull faces and the
/// per-tetrahedron barycentric transforms used by the walk.
///
/// Built by Bowyer–Watson insertion with an infinite vertex (ghost tetrahedra on the hull, as
/// in CGAL) on exact predicates, in BRIO/Hilbert order. Ties (cospherical points, as on every
/// regular grid) are broken by symbolic perturbation, so the result is a valid Delaunay
/// tetrahedralization of the convex hull for any input, and the same for any insertion order.
/// Duplicate points are merged: tetrahedra refer to the first input index of each position.
#[derive(Clone, Debug)]
pub struct Tetrahedralization {
    points: Vec<Vec3>,
    representative: Vec<u32>,
    distinct: usize,
    records: Vec<TetRecord>,
    hull: Vec<HullFace>,
    hull_of_open_face: HashMap<u64, u32>,
    vertex_tet: Vec<u32>,
}

impl Tetrahedralization {
    /// Tetrahedralizes `points`.
    ///
    /// # Errors
    /// [`DelaunayError`] for non-finite points, fewer than four distinct points, or points that
    /// are all collinear or all coplanar.
    pub fn build(points: &[Vec3]) -> Result<Self, DelaunayError> {
        // Neighbour links pack a tetrahedron id and a face into 32 bits (ids below 2^30), and
        // a tetrahedralization has about 6.7 tetrahedra per point.
        let limit = 100_000_000;
        if points.len() > limit {
            return Err(DelaunayError::TooManyPoints {
                given: points.len(),
                limit,
            });
        }
        if let Some((index, &position)) = points.iter().enumerate().find(|(_, p)| !p.is_finite()) {
            return Err(DelaunayError::NonFinitePoint { index, position });
        }
        // Merge duplicates exactly (−0 and +0 are the same position).
        let key = |p: Vec3| (p + Vec3::ZERO).to_array().map(f32::to_bits);
        let mut first_of: HashMap<[u32; 3], u32, BuildMixHasher> =
            HashMap::with_capacity_and_hasher(points.len(), BuildMixHasher);
        let mut representative = Vec::with_capacity(points.len());
        let mut compact_to_input: Vec<u32> = Vec::with_capacity(points.len());
        for (i, &p) in points.iter().enumerate() {
            let c = *first_of.entry(key(p)).or_insert_with(|| {
                compact_to_input.push(i as u32);
                (compact_to_input.len() - 1) as u32
            });
            representative.push(compact_to_input[c as usize]);
        }
        drop(first_of);
        let distinct = compact_to_input.len();
        let pts: Vec<P3> = compact_to_input
            .iter()
            .map(|&i| points[i as usize].as_dvec3().to_array())
            .collect();
        // Renumber the points in insertion order, so that points close in space are close in
        // memory while the tetrahedralization is built.
        let order = order::insertion_order(&pts, INSERTION_SEED);
        let pts: Vec<P3> = order.iter().map(|&i| pts[i as usize]).collect();
        let compact_to_input: Vec<u32> = order
            .iter()
            .map(|&i| compact_to_input[i as usize])
            .collect();
        let sequence: Vec<u32> = (0..pts.len() as u32).collect();
        let raw = build::triangulate(&pts, &sequence, INSERTION_SEED).map_err(|e| match e {
            StartFailure::TooFew => DelaunayError::TooFewPoints {
                distinct,
                given: points.len(),
            },
            StartFailure::Collinear => DelaunayError::AllCollinear { distinct },
            StartFailure::Coplanar => DelaunayError::AllCoplanar { distinct },
        })?;
        Ok(Self::finish(
            points.to_vec(),
            representative,
            distinct,
            &compact_to_input,
            raw,
        ))
    }

    fn finish(
        points: Vec<Vec3>,
        representative: Vec<u32>,
        distinct: usize,
        compact_to_input: &[u32],
        raw: build::RawTriangulation,
    ) -> Self {
        let slots = raw.len();
        // New ids: finite tetrahedra in slot order, ghosts become hull faces.
        let mut new_id = vec![u32::MAX; slots];
        let mut finite = Vec::with_capacity(slots);
        let mut ghosts = Vec::new();
        for (t, id) in new_id.iter_mut().enumerate() {
            if !raw.is_alive(t) {
                continue;
            }
            if raw.vertices(t).contains(&INF) {
                *id = ghosts.len() as u32;
                ghosts.push(t);
            } else {
                *id = finite.len() as u32;
                finite.push(t);
            }
        }
        let to_input = |v: u32| compact_to_input[v as usize];
        let records: Vec<TetRecord> = finite
            .par_iter()
            .map(|&t| {
                let v = raw.vertices(t);
                let nbs = raw.neighbours(t);
                let mut neighbours = [NO_NEIGHBOUR; 4];
                for (nb, &encoded) in neighbours.iter_mut().zip(&nbs) {
                    let n = (encoded >> 2) as usize;
                    if !raw.vertices(n).contains(&INF) {
                        *nb = new_id[n];
                    }
                }
                let vertices = [
                    to_input(v[0]),
                    to_input(v[1]),
                    to_input(v[2]),
                    to_input(v[3]),
                ];
                TetRecord {
                    vertices,
                    neighbours,
                    barycentric: barycentric_rows([
                        points[vertices[0] as usize],
                        points[vertices[1] as usize],
                        points[vertices[2] as usize],
                        points[vertices[3] as usize],
                    ]),
                }
            })
            .collect();
        let hull: Vec<HullFace> = ghosts
            .iter()
            .map(|&g| {
                let v = raw.vertices(g);
                let nbs = raw.neighbours(g);
                let k = v.iter().position(|&x| x == INF).unwrap_or(0);
                let order = ghost_face_order(k);
                let inner = nbs[k];
                let mut adjacent = [0u32; 3];
                for (slot, &pos) in order.iter().enumerate() {
                    adjacent[slot] = new_id[(nbs[pos] >> 2) as usize];
                }
                HullFace {
                    vertices: order.map(|pos| to_input(v[pos])),
                    tetrahedron: new_id[(inner >> 2) as usize],
                    adjacent,
                    face: inner & 3,
                }
            })
            .collect();
        drop(raw);
        let mut vertex_tet = vec![NO_NEIGHBOUR; points.len()];
        for (t, r) in records.iter().enumerate() {
            for &v in &r.vertices {
                vertex_tet[v as usize] = t as u32;
            }
        }
        for i in 0..points.len() {
            vertex_tet[i] = vertex_tet[representative[i] as usize];
        }
        let hull_of_open_face = hull
            .iter()
            .enumerate()
            .map(|(h, f)| {
                (
                    (u64::from(f.tetrahedron) << 2) | u64::from(f.face),
                    h as u32,
                )
            })
            .collect();
        Self {
            points,
            representative,
            distinct,
            records,
            hull,
            hull_of_open_face,
            vertex_tet,
        }
    }

    /// The input points, as given (duplicates included).
    pub fn points(&self) -> &[Vec3] {
        &self.points
    }

    /// The vertex standing for input point `index`: the first input index with the same
    /// position (itself unless it is a duplicate).
    ///
    /// # Panics
    /// If `index` is not below the number of input points.
    pub fn vertex_of(&self, index: usize) -> u32 {
        self.representative[index]
    }

    /// For every input point, the vertex standing for it (see [`Self::vertex_of`]).
    pub fn vertex_map(&self) -> &[u32] {
        &self.representative
    }

    /// Number of distinct positions (vertices).
    pub fn vertex_count(&self) -> usize {
        self.distinct
    }

    /// Number of input points merged into an earlier identical one.
    pub fn duplicate_count(&self) -> usize {
        self.points.len() - self.distinct
    }

    /// The tetrahedra, ready for upload.
    pub fn tetrahedra(&self) -> &[TetRecord] {
        &self.records
    }

    /// The convex hull's triangles.
    pub fn hull_faces(&self) -> &[HullFace] {
        &self.hull
    }

    /// A tetrahedron incident to input point `index` (a good walk start near it).
    ///
    /// # Panics
    /// If `index` is not below the number of input points.
    pub fn tetrahedron_of_vertex(&self, index: usize) -> u32 {
        self.vertex_tet[index]
    }

    /// Bytes held by the tetrahedra and hull records (what a GPU upload needs).
    pub fn memory_bytes(&self) -> usize {
        self.records.len() * size_of::<TetRecord>() + self.hull.len() * size_of::<HullFace>()
    }

    /// Every Delaunay edge once, as `[lower, higher]` vertex indices, sorted.
    pub fn edges(&self) -> Vec<[u32; 2]> {
        let mut edges: Vec<[u32; 2]> = self
            .records
            .iter()
            .flat_map(|r| {
                let v = r.vertices;
                [
                    [v[0], v[1]],
                    [v[0], v[2]],
                    [v[0], v[3]],
                    [v[1], v[2]],
                    [v[1], v[3]],
                    [v[2], v[3]],
                ]
            })
            .map(|[a, b]| if a < b { [a, b] } else { [b, a] })
            .collect();
        edges.par_sort_unstable();
        edges.dedup();
        edges
    }

    /// The Delaunay neighbours of every input point, in compressed rows: the neighbours of point
    /// `i` are `ids[offsets[i]..offsets[i + 1]]`, sorted. Duplicates get their vertex's row.
    pub fn vertex_neighbours(&self) -> (Vec<u32>, Vec<u32>) {
        let n = self.points.len();
        let edges = self.edges();
        let mut degree = vec![0u32; n];
        for &[a, b] in &edges {
            degree[a as usize] += 1;
            degree[b as usize] += 1;
        }
        // Duplicates share their representative's neighbours.
        let row_of = |i: usize| self.representative[i] as usize;
        let mut offsets = Vec::with_capacity(n + 1);
        offsets.push(0u32);
        for i in 0..n {
            let d = degree[row_of(i)];
            offsets.push(offsets[i] + d);
        }
        let mut fill: Vec<u32> = offsets[..n].to_vec();
        let mut ids = vec![0u32; offsets[n] as usize];
        for &[a, b] in &edges {
            ids[fill[a as usize] as usize] = b;
            fill[a as usize] += 1;
            ids[fill[b as usize] as usize] = a;
            fill[b as usize] += 1;
        }
        for i in 0..n {
            let r = row_of(i);
            if r != i {
                let (src, dst) = (offsets[r] as usize, offsets[i] as usize);
                let len = degree[r] as usize;
                ids.copy_within(src..src + len, dst);
            }
        }
        for i in 0..n {
            ids[offsets[i] as usize..offsets[i + 1] as usize].sort_unstable();
        }
        (offsets, ids)
    }

    /// Locates `p` without a cached start: jump-and-walk (Mücke, Saias & Zhu 1996) — the walk
    /// starts from the nearest of about `tetrahedra^⅓` evenly spread tetrahedra. See
    /// [`Self::locate_from`].
    ///
    /// # Errors
    /// [`QueryError::NonFinitePosition`] if `p` has a NaN or infinite coordinate.
    pub fn locate(&self, p: Vec3) -> Result<Location, QueryError> {
        if !p.is_finite() {
            return Err(QueryError::NonFinitePosition { position: p });
        }
        let n = self.records.len();
        let samples = ((n as f64).cbrt().ceil() as usize).max(1);
        let stride = (n / samples).max(1);
        let mut best = (f32::INFINITY, 0u32);
        for t in (0..n).step_by(stride) {
            let v = self.records[t].vertices[0];
            let d = (self.points[v as usize] - p).length_squared();
            if d < best.0 {
                best = (d, t as u32);
            }
        }
        self.locate_from(p, best.1)
    }

    /// Locates `p` by a barycentric walk from tetrahedron `start` (seed 002 §3.2.1: pass the
    /// previous result's tetrahedron for coherent queries). The walk steps across the face with
    /// the most negative barycentric coordinate, never back into a tetrahedron it has visited,
    /// so it ends even on faces, edges and vertices. Points outside the hull get the nearest
    /// hull face and weights clamped onto it. The f32 rows only steer: the walk stops where the
    /// exact orientation test puts `p` inside, and a walk with nowhere left to go (possible on
    /// nearly flat sets) finishes by an exact scan of the tetrahedra.
    ///
    /// # Errors
    /// [`QueryError::NonFinitePosition`] if `p` has a NaN or infinite coordinate.
    pub fn locate_from(&self, p: Vec3, start: u32) -> Result<Location, QueryError> {
        if !p.is_finite() {
            return Err(QueryError::NonFinitePosition { position: p });
        }
        let mut t = if (start as usize) < self.records.len() {
            start
        } else {
            0
        };
        let mut visited = Visited::new(t);
        loop {
            let record = &self.records[t as usize];
            let l = self.local_barycentric(record, p);
            let mut faces = [0usize, 1, 2, 3];
            faces.sort_unstable_by(|&a, &b| l[a].total_cmp(&l[b]));
            let mut next = None;
            for &i in &faces {
                if l[i] >= 0.0 {
                    break;
                }
                let n = record.neighbours[i];
                if n == NO_NEIGHBOUR {
                    // The rows steer; only the exact test says `p` has left the hull (a hull
                    // sliver's rows can put an inside point beyond its open face).
                    if self.is_beyond(record, p, i) {
                        return Ok(self.outside(p, t, i, visited.len() as u32));
                    }
                    continue;
                }
                if !visited.contains(n) {
                    next = Some((i, n));
                    break;
                }
            }
            // The f32 rows can misjudge a sliver (a tetrahedron much thinner than it is
            // long): where the exact orientation puts `p` beyond a face the rows accepted, walk
            // on through it, or hand over to the hull search if it is a hull face. Clamping
            // the negative coordinate instead would blend a point far along the sliver.
            // If that neighbour was visited already, the remembering walk is stuck (it can be
            // on nearly flat sets): scan for the tetrahedron that holds `p` instead.
            let next = match next {
                Some((_, n)) => Some(n),
                None => match self.face_beyond(record, p) {
                    None => None,
                    Some(face) if record.neighbours[face] == NO_NEIGHBOUR => {
                        return Ok(self.outside(p, t, face, visited.len() as u32));
                    }
                    Some(face) if !visited.contains(record.neighbours[face]) => {
                        Some(record.neighbours[face])
                    }
                    Some(_) => return Ok(self.locate_by_scan(p, visited.len() as u32)),
                },
            };
            match next {
                Some(n) => {
                    visited.insert(n);
                    t = n;
                }
                None => {
                    return Ok(Location {
                        tetrahedron: t,
                        probes: record.vertices,
                        weights: clamp_weights(self.exact_barycentric(record, p)),
                        outside_distance: 0.0,
                        steps: visited.len() as u32,
                    });
                }
            }
        }
    }

    /// Point location by exact tests over every tetrahedron, for a walk that got stuck: the
    /// first tetrahedron holding `p`, or outside the hull the hull search from a hull face `p`
    /// lies beyond.
    fn locate_by_scan(&self, p: Vec3, steps: u32) -> Location {
        for (t, record) in self.records.iter().enumerate() {
            if self.face_beyond(record, p).is_none() {
                return Location {
                    tetrahedron: t as u32,
                    probes: record.vertices,
                    weights: clamp_weights(self.exact_barycentric(record, p)),
                    outside_distance: 0.0,
                    steps: steps + t as u32 + 1,
                };
            }
        }
        let q = p.as_dvec3().to_array();
        let beyond = self.hull.iter().find(|face| {
            let [a, b, c] = face
                .vertices
                .map(|v| self.points[v as usize].as_dvec3().to_array());
            orient(&a, &b, &c, &q) > 0
        });
        match beyond {
            Some(face) => self.outside(p, face.tetrahedron, face.face as usize, steps),
            // Unreachable for a valid tetrahedralization; answer as the first tetrahedron.
            None => {
                let record = &self.records[0];
                Location {
                    tetrahedron: 0,
                    probes: record.vertices,
                    weights: clamp_weights(self.exact_barycentric(record, p)),
                    outside_distance: 0.0,
                    steps,
                }
            }
        }
    }

    /// The face of `record` that `p` lies strictly beyond by the exact orientation test (the
    /// one with the most negative f64 coordinate when there are several), if any.
    fn face_beyond(&self, record: &TetRecord, p: Vec3) -> Option<usize> {
        let corners = record
            .vertices
            .map(|v| self.points[v as usize].as_dvec3().to_array());
        let q = p.as_dvec3().to_array();
        let coordinates = self.exact_barycentric(record, p);
        (0..4)
            .filter(|&i| beyond(corners, q, i))
            .min_by(|&a, &b| coordinates[a].total_cmp(&coordinates[b]))
    }

    /// Whether `p` lies strictly beyond face `face` of `record` by the exact orientation test.
    fn is_beyond(&self, record: &TetRecord, p: Vec3, face: usize) -> bool {
        let corners = record
            .vertices
            .map(|v| self.points[v as usize].as_dvec3().to_array());
        beyond(corners, p.as_dvec3().to_array(), face)
    }

    /// Barycentric coordinates of `p` from the stored rows applied to `p` minus the
    /// tetrahedron's last vertex: as cheap as [`TetRecord::barycentric_of`], without its loss
    /// of digits when the tetrahedron is tiny and far from the origin.
    #[inline]
    fn local_barycentric(&self, record: &TetRecord, p: Vec3) -> [f32; 4] {
        let q = p - self.points[record.vertices[3] as usize];
        let r = &record.barycentric;
        let l0 = r[0][0] * q.x + r[0][1] * q.y + r[0][2] * q.z;
        let l1 = r[1][0] * q.x + r[1][1] * q.y + r[1][2] * q.z;
        let l2 = r[2][0] * q.x + r[2][1] * q.y + r[2][2] * q.z;
        [l0, l1, l2, 1.0 - l0 - l1 - l2]
    }

    /// Barycentric coordinates of `p` in `record`'s tetrahedron computed in f64 relative to its
    /// last vertex. The stored rows fold the translation into an f32 column, which loses
    /// digits for tetrahedra much smaller than their distance from the origin (probes 1e-4 m
    /// apart at 0.3 m gave weights off by 1e-3); the walk may use them, the answer may not.
    fn exact_barycentric(&self, record: &TetRecord, p: Vec3) -> [f32; 4] {
        let [a, b, c, d] = record.vertices.map(|v| self.points[v as usize].as_dvec3());
        let m = glam::DMat3::from_cols(a - d, b - d, c - d);
        if m.determinant() == 0.0 {
            return record.barycentric_of(p);
        }
        let l = m.inverse() * (p.as_dvec3() - d);
        [l.x, l.y, l.z, 1.0 - l.x - l.y - l.z].map(|x| x as f32)
    }

    /// Nearest hull face to an outside point, found among the hull faces `p` sees (they form a
    /// connected patch that holds the nearest point), starting from the face the walk left by.
    fn outside(&self, p: Vec3, t: u32, face: usize, steps: u32) -> Location {
        let record = &self.records[t as usize];
        let start = self
            .hull_of_open_face
            .get(&((u64::from(t) << 2) | face as u64))
            .map(|&h| h as usize);
        let Some(start) = start else {
            // Cannot happen (every open face has a hull record); answer with the clamped walk.
            return Location {
                tetrahedron: t,
                probes: record.vertices,
                weights: clamp_weights(record.barycentric_of(p)),
                outside_distance: 0.0,
                steps,
            };
        };
        let pd = p.as_dvec3().to_array();
        let mut best = (f64::INFINITY, start, [1.0f64 / 3.0; 3]);
        let mut seen: std::collections::HashSet<u32> =
            std::collections::HashSet::from([start as u32]);
        let mut queue = vec![start as u32];
        while let Some(h) = queue.pop() {
            let face = &self.hull[h as usize];
            let [a, b, c] = face.vertices.map(|v| self.points[v as usize].as_dvec3());
            let (d2, w) = closest_on_triangle(p.as_dvec3(), a, b, c);
            if d2 < best.0 {
                best = (d2, h as usize, w);
            }
            for &n in &face.adjacent {
                if !seen.insert(n) {
                    continue;
                }
                let nf = &self.hull[n as usize];
                let [x, y, z] = nf
                    .vertices
                    .map(|v| self.points[v as usize].as_dvec3().to_array());
                if orient(&x, &y, &z, &pd) >= 0 {
                    queue.push(n);
                }
            }
        }
        let (d2, h, w) = best;
        let face = &self.hull[h];
        let record = &self.records[face.tetrahedron as usize];
        let mut weights = [0.0f32; 4];
        for (k, &v) in face.vertices.iter().enumerate() {
            if let Some(slot) = record.vertices.iter().position(|&x| x == v) {
                weights[slot] = w[k] as f32;
            }
        }
        Location {
            tetrahedron: face.tetrahedron,
            probes: record.vertices,
            weights,
            outside_distance: d2.sqrt() as f32,
            steps: steps + seen.len() as u32,
        }
    }

    /// Blends per-probe `values` (one per input probe, duplicates included) with the weights of
    /// `location`. Works for any `Copy` value with `+` and `* f32`: colours, `Vec3`
    /// irradiance, SH coefficient structs.
    ///
    /// # Errors
    /// [`QueryError::ValueCountMismatch`] if `values` does not have one entry per input point.
    pub fn interpolate<T>(&self, location: &Location, values: &[T]) -> Result<T, QueryError>
    where
        T: Copy + Add<Output = T> + Mul<f32, Output = T>,
    {
        if values.len() != self.points.len() {
            return Err(QueryError::ValueCountMismatch {
                expected: self.points.len(),
                got: values.len(),
            });
        }
        let [a, b, c, d] = location.probes.map(|v| values[v as usize]);
        let [wa, wb, wc, wd] = location.weights;
        Ok(a * wa + b * wb + c * wc + d * wd)
    }

    /// Blends per-probe blocks of `stride` floats (e.g. 27 floats of RGB SH9 per probe, stored
    /// flat) into `out`.
    ///
    /// # Errors
    /// [`QueryError::ValueCountMismatch`] if `values.len() != stride × probes`,
    /// [`QueryError::OutputLengthMismatch`] if `out.len() != stride`.
    pub fn interpolate_strided(
        &self,
        location: &Location,
        values: &[f32],
        stride: usize,
        out: &mut [f32],
    ) -> Result<(), QueryError> {
        if stride == 0 || values.len() != stride * self.points.len() {
            return Err(QueryError::ValueCountMismatch {
                expected: self.points.len(),
                got: values.len().checked_div(stride).unwrap_or(0),
            });
        }
        if out.len() != stride {
            return Err(QueryError::OutputLengthMismatch {
                stride,
                got: out.len(),
            });
        }
        out.fill(0.0);
        for (&v, &w) in location.probes.iter().zip(&location.weights) {
            let block = &values[v as usize * stride..(v as usize + 1) * stride];
            for (o, &x) in out.iter_mut().zip(block) {
                *o += x * w;
            }
        }
        Ok(())
    }

    /// Checks the structure with exact predicates: every tetrahedron positively oriented,
    /// adjacency mutual and face-sharing, every interior face locally Delaunay (which makes the
    /// whole tetrahedralization Delaunay), hull faces one per open face and convex, and every
    /// distinct point a vertex. Linear time.
    ///
    /// # Errors
    /// The first [`ValidationError`] found.
    pub fn validate(&self) -> Result<(), ValidationError> {
        let pt = |v: u32| self.points[v as usize].as_dvec3().to_array();
        let mut open_faces = 0usize;
        for (t, r) in self.records.iter().enumerate() {
            let [a, b, c, d] = r.vertices.map(pt);
            if orient(&a, &b, &c, &d) <= 0 {
                return Err(ValidationError::NotPositive { tetrahedron: t });
            }
            for i in 0..4 {
                let n = r.neighbours[i];
                if n == NO_NEIGHBOUR {
                    open_faces += 1;
                    continue;
                }
                let nr = self
                    .records
                    .get(n as usize)
                    .ok_or(ValidationError::BrokenAdjacency {
                        tetrahedron: t,
                        face: i,
                    })?;
                let back = nr.neighbours.iter().position(|&x| x == t as u32);
                let shares = back.is_some_and(|j| {
                    let mut f1 = face_of(&r.vertices, i);
                    let mut f2 = face_of(&nr.vertices, j);
                    f1.sort_unstable();
                    f2.sort_unstable();
                    f1 == f2
                });
                if !shares {
                    return Err(ValidationError::BrokenAdjacency {
                        tetrahedron: t,
                        face: i,
                    });
                }
                let j = back.unwrap_or(0);
                let e = pt(nr.vertices[j]);
                if in_sphere(&a, &b, &c, &d, &e) > 0 {
                    return Err(ValidationError::NotDelaunay {
                        tetrahedron: t,
                        face: i,
                    });
                }
            }
        }
        if open_faces != self.hull.len() {
            return Err(ValidationError::BadHull {
                hull_face: self.hull.len().min(open_faces),
            });
        }
        for (h, face) in self.hull.iter().enumerate() {
            let r = self.records.get(face.tetrahedron as usize);
            let ok = r.is_some_and(|r| {
                let mut f1 = face_of(&r.vertices, face.face as usize);
                let mut f2 = face.vertices;
                f1.sort_unstable();
                f2.sort_unstable();
                r.neighbours[face.face as usize] == NO_NEIGHBOUR && f1 == f2
            });
            if !ok {
                return Err(ValidationError::BadHull { hull_face: h });
            }
            let [a, b, c] = face.vertices.map(pt);
            // Outward: the tetrahedron's opposite vertex is strictly inside.
            let inner = self.records[face.tetrahedron as usize].vertices[face.face as usize];
            if orient(&a, &b, &c, &pt(inner)) >= 0 {
                return Err(ValidationError::BadHull { hull_face: h });
            }
            // Convex: no adjacent face's far vertex is beyond this face.
            for &n in &face.adjacent {
                let Some(other) = self.hull.get(n as usize) else {
                    return Err(ValidationError::BadHull { hull_face: h });
                };
                for &v in &other.vertices {
                    if !face.vertices.contains(&v) && orient(&a, &b, &c, &pt(v)) > 0 {
                        return Err(ValidationError::BadHull { hull_face: h });
                    }
                }
            }
        }
        let mut present = vec![false; self.points.len()];
        for r in &self.records {
            for &v in &r.vertices {
                present[v as usize] = true;
            }
        }
        for (i, &rep) in self.representative.iter().enumerate() {
            if !present[rep as usize] {
                return Err(ValidationError::MissingVertex { point: i });
            }
        }
        Ok(())
    }
}

/// A fast non-cryptographic hasher for the duplicate map (keys are coordinate bits, not
/// attacker-controlled in any way that matters here).
#[derive(Clone, Copy, Default)]
struct BuildMixHasher;

#[derive(Default)]
struct MixHasher(u64);

impl std::hash::BuildHasher for BuildMixHasher {
    type Hasher = MixHasher;
    fn build_hasher(&self) -> MixHasher {
        MixHasher(0)
    }
}

impl std::hash::Hasher for MixHasher {
    fn finish(&self) -> u64 {
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.write_u32(u32::from(b));
        }
    }
    fn write_u32(&mut self, x: u32) {
        self.0 = (self.0.rotate_left(21) ^ u64::from(x)).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    }
    fn write_usize(&mut self, x: usize) {
        self.0 = (self.0.rotate_left(21) ^ x as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    }
}

/// The tetrahedra a walk has visited: a short list, becoming a hash set for long walks.
struct Visited {
    list: Vec<u32>,
    set: Option<std::collections::HashSet<u32>>,
}

impl Visited {
    const LIST_LIMIT: usize = 24;

    fn new(first: u32) -> Self {
        let mut list = Vec::with_capacity(Self::LIST_LIMIT);
        list.push(first);
        Self { list, set: None }
    }

    fn contains(&self, t: u32) -> bool {
        match &self.set {
            Some(set) => set.contains(&t),
            None => self.list.contains(&t),
        }
    }

    fn insert(&mut self, t: u32) {
        match &mut self.set {
            Some(set) => {
                set.insert(t);
            }
            None if self.list.len() < Self::LIST_LIMIT => self.list.push(t),
            None => {
                let mut set: std::collections::HashSet<u32> = self.list.drain(..).collect();
                set.insert(t);
                self.set = Some(set);
            }
        }
    }

    fn len(&self) -> usize {
        match &self.set {
            Some(set) => set.len(),
            None => self.list.len(),
        }
    }
}

fn face_of(v: &[u32; 4], i: usize) -> [u32; 3] {
    let mut f = [0u32; 3];
    let mut n = 0;
    for (k, &x) in v.iter().enumerate() {
        if k != i {
            f[n] = x;
            n += 1;
        }
    }
    f
}

/// Barycentric rows for a tetrahedron (computed in f64, stored in f32).
fn barycentric_rows(v: [Vec3; 4]) -> [[f32; 4]; 3] {
    let [a, b, c, d] = v.map(Vec3::as_dvec3);
    let m = glam::DMat3::from_cols(a - d, b - d, c - d);
    let inv = m.inverse();
    let mut rows = [[0.0f32; 4]; 3];
    for (k, row) in rows.iter_mut().enumerate() {
        let r = inv.row(k);
        *row = [r.x as f32, r.y as f32, r.z as f32, (-r.dot(d)) as f32];
    }
    rows
}

/// Clamps rounding-level negatives to zero and renormalizes.
fn clamp_weights(l: [f32; 4]) -> [f32; 4] {
    let c = l.map(|x| x.max(0.0));
    let s: f32 = c.iter().sum();
    if s > 0.0 { c.map(|x| x / s) } else { [0.25; 4] }
}

/// Whether `q` lies strictly beyond the face opposite corner `face` of the tetrahedron
/// `corners` (exact: replacing that corner by `q` turns the orientation negative).
fn beyond(corners: [[f64; 3]; 4], q: [f64; 3], face: usize) -> bool {
    let mut w = corners;
    w[face] = q;
    orient(&w[0], &w[1], &w[2], &w[3]) < 0
}

/// Squared distance from `p` to triangle `abc` and the barycentric weights of the closest point
/// (Ericson, Real-Time Collision Detection §5.1.5).
fn closest_on_triangle(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> (f64, [f64; 3]) {
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = ab.dot(ap);
    let d2 = ac.dot(ap);
    let w = if d1 <= 0.0 && d2 <= 0.0 {
        [1.0, 0.0, 0.0]
    } else {
        let bp = p - b;
        let d3 = ab.dot(bp);
        let d4 = ac.dot(bp);
        if d3 >= 0.0 && d4 <= d3 {
            [0.0, 1.0, 0.0]
        } else {
            let vc = d1 * d4 - d3 * d2;
            if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
                let v = d1 / (d1 - d3);
                [1.0 - v, v, 0.0]
            } else {
                let cp = p - c;
                let d5 = ab.dot(cp);
                let d6 = ac.dot(cp);
                if d6 >= 0.0 && d5 <= d6 {
                    [0.0, 0.0, 1.0]
                } else {
                    let vb = d5 * d2 - d1 * d6;
                    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
                        let w = d2 / (d2 - d6);
                        [1.0 - w, 0.0, w]
                    } else {
                        let va = d3 * d6 - d5 * d4;
                        if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
                            let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
                            [0.0, 1.0 - w, w]
                        } else {
                            let denom = 1.0 / (va + vb + vc);
                            let v = vb * denom;
                            let w = vc * denom;
                            [1.0 - v - w, v, w]
                        }
                    }
                }
            }
        }
    };
    let q = a * w[0] + b * w[1] + c * w[2];
    ((p - q).length_squared(), w)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closest_point_regions() {
        let a = DVec3::ZERO;
        let b = DVec3::X;
        let c = DVec3::Y;
        let (d, w) = closest_on_triangle(DVec3::new(0.2, 0.2, 1.0), a, b, c);
        assert!((d - 1.0).abs() < 1e-12);
        assert!((w[1] - 0.2).abs() < 1e-12 && (w[2] - 0.2).abs() < 1e-12);
        let (d, w) = closest_on_triangle(DVec3::new(-1.0, -1.0, 0.0), a, b, c);
        assert!((d - 2.0).abs() < 1e-12);
        assert_eq!(w, [1.0, 0.0, 0.0]);
        let (_, w) = closest_on_triangle(DVec3::new(1.0, 1.0, 0.0), a, b, c);
        assert!((w[1] - 0.5).abs() < 1e-12 && (w[2] - 0.5).abs() < 1e-12);
    }
}
