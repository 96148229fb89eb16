//! Candidate probes from the medial axis of the scene's free space (seed 000 §3.1.2): area-
//! weighted surface samples, the shrinking-ball algorithm (Ma et al. 2012, as in masbcpp)
//! with its denoising, and clustering of the medial balls.

use crate::candidate_error::{
    CandidateError, ValidRange, check_count, check_count_up_to, check_param,
};
use crate::cluster::{ClusterStats, cover_clusters, settle_in_free_space};
use crate::par::*;
use crate::probes::{ProbeSet, json_f32};
use crate::provenance::PlacementMethod;
use crate::sdf::sees;
use crate::voxel::{VoxelGrid, VoxelState};
use glam::{Vec2, Vec3};
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use probe_scene::Scene;
use rand::{Rng, SeedableRng};
use serde_json::{Map, Value};
use std::num::NonZeroUsize;

/// The most surface samples [`medial_candidates`] takes (`2^24`, about 16.8 million).
pub const MAX_SURFACE_SAMPLES: u64 = 1 << 24;

/// A point on a scene surface, drawn with probability proportional to area.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfacePoint {
    /// The position, world space.
    pub position: Vec3,
    /// The triangle's unit geometric normal (front side, from its winding).
    pub normal: Vec3,
    /// The triangle, an index into [`Scene::triangles`].
    pub triangle: u32,
}

/// `count` points on the scene's triangles, area-weighted and stratified: the `i`-th sample
/// takes the triangle where the cumulative area passes `(i + ξ) / count` of the total (one
/// uniform `ξ` per sample), then a uniform point in it. Zero-area triangles are never drawn.
/// The same scene, count and seed give the same samples. Empty for a scene without area.
pub fn sample_surfaces(scene: &Scene, count: usize, seed: u64) -> Vec<SurfacePoint> {
    let triangles = scene.triangles();
    let mut cumulative = Vec::with_capacity(triangles.len());
    let mut total = 0f64;
    for t in triangles {
        total += f64::from(t.area());
        cumulative.push(total);
    }
    if total.is_nan() || total <= 0.0 || count == 0 {
        return Vec::new();
    }
    let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
    (0..count)
        .map(|i| {
            let target = (i as f64 + rng.random::<f64>()) / count as f64 * total;
            // The first triangle whose cumulative area exceeds the target (never a zero-area one).
            let index = cumulative
                .partition_point(|&c| c <= target)
                .min(triangles.len() - 1);
            let triangle = &triangles[index];
            let (u, v): (f32, f32) = (rng.random(), rng.random());
            let root = u.sqrt();
            let barycentrics = Vec2::new(root * (1.0 - v), root * v);
            SurfacePoint {
                position: triangle.point(barycentrics),
                normal: triangle.geometric_normal(),
                triangle: index as u32,
            }
        })
        .collect()
}

/// A medial ball: its centre is a point of the medial axis, its radius the distance from there
/// to the nearest surface samples.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MedialBall {
    /// The centre, world space.
    pub center: Vec3,
    /// The radius, metres.
    pub radius: f32,
    /// The surface sample the ball touches (index into the samples).
    pub sample: u32,
}

/// Parameters of [`medial_candidates`]. [`MedialParams::for_scene`] scales them to a scene;
/// the shrinking-ball constants are masbcpp's.
#[derive(Clone, Debug, PartialEq)]
pub struct MedialParams {
    /// Area-weighted surface samples. Default 100,000; at most [`MAX_SURFACE_SAMPLES`].
    pub sample_count: usize,
    /// Seed of the surface sampling.
    pub seed: u64,
    /// The radius balls start from, metres (masbcpp's `initial_radius`). Default: the
    /// diagonal of the scene's bounds. A ball that would grow past it touches nothing on its
    /// side (open space) and is dropped.
    pub initial_radius: f32,
    /// Stop shrinking when the radius changes by less than this, as a fraction of
    /// `initial_radius`. Default 1e-5 (masbcpp's `delta_convergance` for unit-scale data).
    pub convergence: f32,
    /// Shrinking steps at most (masbcpp's `iteration_limit`). Default 30; at most 1000.
    pub iteration_limit: usize,
    /// Denoising, degrees (masbcpp's `denoise_preserve`): after the first step, stop at the
    /// previous ball when the angle at the new centre between the sample and its nearest
    /// neighbour falls below this and the radius exceeds their distance. Default 20°; 0 turns
    /// it off.
    pub denoise_preserve_degrees: f32,
    /// Denoising, degrees (masbcpp's `denoise_planar`): drop the ball when that angle is below
    /// this at the first step (the samples around are planar). Default 32°; 0 turns it off.
    pub denoise_planar_degrees: f32,
    /// Voxel size of the free-space grid that keeps only balls centred in free space, metres.
    pub voxel_size: f32,
    /// Balls smaller than this are dropped (crevices are no place for a probe), metres.
    pub min_radius: f32,
    /// A cluster's radius is this multiple of its seed ball's radius: a probe stands for the
    /// medial balls whose centres it sees within that distance. Larger gives fewer probes.
    pub coverage_factor: f32,
    /// The largest cluster radius, metres (splits wide open spaces).
    pub max_cluster_radius: f32,
    /// Clusters with fewer balls are noise and dropped.
    pub min_cluster_balls: usize,
}

impl MedialParams {
    /// Parameters scaled to the scene's largest extent `L` and diagonal `D`: 100,000 samples
    /// (seed 0), initial radius `D`, masbcpp's convergence (1e-5), iteration limit (30) and
    /// denoising angles (20°, 32°), voxels of `L / 160`, balls of radius at least `L / 60`,
    /// clusters reaching 4 times their seed ball's radius, at most `L / 2`, with at least 8
    /// balls.
    pub fn for_scene(scene: &Scene) -> MedialParams {
        let size = scene.bounds().size();
        let extent = size.max_element();
        let (extent, diagonal) = if extent.is_finite() && extent > 0.0 {
            (extent, size.length())
        } else {
            (1.0, 1.0)
        };
        MedialParams {
            sample_count: 100_000,
            seed: 0,
            initial_radius: diagonal,
            convergence: 1e-5,
            iteration_limit: 30,
            denoise_preserve_degrees: 20.0,
            denoise_planar_degrees: 32.0,
            voxel_size: extent / 160.0,
            min_radius: extent / 60.0,
            coverage_factor: 4.0,
            max_cluster_radius: extent / 2.0,
            min_cluster_balls: 8,
        }
    }

    fn check(&self) -> Result<(), CandidateError> {
        if !(self.voxel_size.is_finite() && self.voxel_size > 0.0) {
            return Err(CandidateError::InvalidVoxelSize {
                voxel_size: self.voxel_size,
            });
        }
        check_count_up_to("sample_count", self.sample_count, MAX_SURFACE_SAMPLES)?;
        check_param("initial_radius", self.initial_radius, ValidRange::Positive)?;
        check_param("convergence", self.convergence, ValidRange::Positive)?;
        check_count_up_to("iteration_limit", self.iteration_limit, 1000)?;
        check_param(
            "denoise_preserve_degrees",
            self.denoise_preserve_degrees,
            ValidRange::NonNegative,
        )?;
        check_param(
            "denoise_planar_degrees",
            self.denoise_planar_degrees,
            ValidRange::NonNegative,
        )?;
        check_param("min_radius", self.min_radius, ValidRange::NonNegative)?;
        check_param(
            "coverage_factor",
            self.coverage_factor,
            ValidRange::Positive,
        )?;
        check_param(
            "max_cluster_radius",
            self.max_cluster_radius,
            ValidRange::Positive,
        )?;
        check_count("min_cluster_balls", self.min_cluster_balls)
    }

    pub(crate) fn to_json(&self) -> Map<String, Value> {
        let mut map = Map::new();
        let mut put = |key: &str, value: Value| {
            map.insert(key.to_owned(), value);
        };
        put("sample_count", Value::from(self.sample_count));
        put("seed", Value::from(self.seed));
        put("initial_radius", json_f32(self.initial_radius));
        put("convergence", json_f32(self.convergence));
        put("iteration_limit", Value::from(self.iteration_limit));
        put(
            "denoise_preserve_degrees",
            json_f32(self.denoise_preserve_degrees),
        );
        put(
            "denoise_planar_degrees",
            json_f32(self.denoise_planar_degrees),
        );
        put("voxel_size", json_f32(self.voxel_size));
        put("min_radius", json_f32(self.min_radius));
        put("coverage_factor", json_f32(self.coverage_factor));
        put("max_cluster_radius", json_f32(self.max_cluster_radius));
        put("min_cluster_balls", Value::from(self.min_cluster_balls));
        map
    }
}

/// The result of [`medial_candidates`].
#[derive(Clone, Debug)]
pub struct MedialCandidates {
    /// The candidate probes (method `"medial"`).
    pub probes: ProbeSet,
    /// The medial balls kept (centred in free space, radius at least `min_radius`).
    pub balls: Vec<MedialBall>,
    /// The free-space voxel grid the balls were checked against.
    pub voxels: VoxelGrid,
    /// Balls shrunk (one per sample and open side).
    pub balls_shrunk: usize,
    /// Balls dropped as open (reaching `initial_radius`), planar or noise by the denoising.
    pub balls_open: usize,
    /// Clusters dropped for having fewer than `min_cluster_balls` balls.
    pub small_clusters: usize,
    /// How the clusters became probes.
    pub clusters: ClusterStats,
}

/// Candidate probe positions from the medial axis of free space (seed 000 §3.1.2):
///
/// 1. `sample_count` area-weighted surface samples ([`sample_surfaces`]) with their normals;
/// 2. for each sample, a ball on each side that can face free space (the front of a
///    single-sided triangle, both sides of a double-sided one) is shrunk from
///    `initial_radius` (masbcpp's `sb_point`: centre `c = p + n·r`, nearest other sample `q`
///    of `c` from a kiddo k-d tree, `r = |p − q|² / (2 n·(q − p))`, until the radius changes by
///    less than `convergence · initial_radius` or after `iteration_limit` steps, with the
///    preserve and planar denoising). Balls that stay open are dropped;
/// 3. balls centred outside free space ([`VoxelGrid`]) or outside the scene's bounds, or
///    smaller than `min_radius`, are dropped;
/// 4. the balls are clustered by their centres and radii: from the largest ball down, each
///    ball not yet covered seeds a cluster of the uncovered balls whose centres it sees
///    (unoccluded segment) within `coverage_factor` times its radius (at most
///    `max_cluster_radius`), so probes start where space is widest, their reach follows the
///    size of the space, and every hidden region gets its own; clusters with fewer than
///    `min_cluster_balls` are dropped; each cluster gives a probe at its mean centre, moved
///    to the nearest member centre when the mean lies outside free space or
///    [`inside_geometry`](crate::candidates::inside_geometry) (dropped if none of 16 fits).
///
/// Deterministic for a given seed.
pub fn medial_candidates(
    scene: &Scene,
    params: &MedialParams,
) -> Result<MedialCandidates, CandidateError> {
    params.check()?;
    let voxels = VoxelGrid::build(scene, params.voxel_size)?;
    let samples = sample_surfaces(scene, params.sample_count, params.seed);
    if samples.len() < 2 {
        return Err(CandidateError::EmptyScene {
            scene: scene.name().to_owned(),
        });
    }
    let points: Vec<[f32; 3]> = samples.iter().map(|s| s.position.to_array()).collect();
    let tree: ImmutableKdTree<f32, 3> =
        ImmutableKdTree::new_from_slice(&points).map_err(|_| CandidateError::InvalidParameter {
            parameter: "sample_count",
            value: params.sample_count as f64,
            expected: ValidRange::AtLeastOne,
        })?;
    let shrink = BallShrinker {
        tree: &tree,
        points: &points,
        initial_radius: params.initial_radius,
        convergence: params.convergence * params.initial_radius,
        iteration_limit: params.iteration_limit,
        preserve_angle: params.denoise_preserve_degrees.to_radians(),
        planar_angle: params.denoise_planar_degrees.to_radians(),
        coincident: 1e-6 * params.initial_radius,
    };
    let materials = scene.materials();
    let triangles = scene.triangles();
    let shrink = &shrink;
    let shrunk: Vec<(usize, Option<MedialBall>)> = samples
        .par_iter()
        .enumerate()
        .with_min_len(64)
        .flat_map_iter(|(index, sample)| {
            let double_sided =
                materials[triangles[sample.triangle as usize].material as usize].double_sided;
            let sides: &[f32] = if double_sided { &[1.0, -1.0] } else { &[1.0] };
            sides.iter().map(move |&side| {
                let ball = shrink.ball(index, sample.position, sample.normal * side);
                (index, ball)
            })
        })
        .collect();
    let balls_shrunk = shrunk.len();
    let bounds = scene.bounds();
    let mut balls_open = 0;
    let mut balls = Vec::new();
    for (_, ball) in shrunk {
        match ball {
            None => balls_open += 1,
            Some(ball) => {
                if ball.radius >= params.min_radius
                    && bounds.contains(ball.center)
                    && voxels.state_at(ball.center) == VoxelState::Free
                {
                    balls.push(ball);
                }
            }
        }
    }
    let centers: Vec<Vec3> = balls.iter().map(|b| b.center).collect();
    let radii: Vec<f32> = balls.iter().map(|b| b.radius).collect();
    let clusters = cover_clusters(
        &centers,
        &radii,
        params.coverage_factor,
        params.max_cluster_radius,
        |a, b| sees(scene, a, b),
    );
    let mut stats = ClusterStats::default();
    let mut small_clusters = 0;
    let mut positions = Vec::new();
    for cluster in clusters {
        if cluster.len() < params.min_cluster_balls {
            small_clusters += 1;
            continue;
        }
        let members: Vec<Vec3> = cluster.iter().map(|&i| balls[i].center).collect();
        let fits = |p: Vec3| voxels.state_at(p) == VoxelState::Free;
        if let Some(p) = settle_in_free_space(scene, &members, fits, &mut stats) {
            positions.push(p);
        }
    }
    Ok(MedialCandidates {
        probes: ProbeSet::new(positions).with_method(PlacementMethod::Medial {
            params: params.clone(),
            medial_balls: balls.len(),
        }),
        balls,
        voxels,
        balls_shrunk,
        balls_open,
        small_clusters,
        clusters: stats,
    })
}

/// The shrinking-ball iteration over a fixed sample set.
struct BallShrinker<'a> {
    tree: &'a ImmutableKdTree<f32, 3>,
    points: &'a [[f32; 3]],
    initial_radius: f32,
    /// Absolute convergence threshold on the radius, metres.
    convergence: f32,
    iteration_limit: usize,
    /// The preserve denoising angle, radians.
    preserve_angle: f32,
    /// The planar denoising angle, radians.
    planar_angle: f32,
    /// Samples closer than this to `p` count as `p` itself (duplicates).
    coincident: f32,
}

impl BallShrinker<'_> {
    /// The nearest sample to `c` other than `p` (and its duplicates): index and position.
    fn nearest_other(&self, c: Vec3, p_index: usize, p: Vec3) -> Option<Vec3> {
        let found = self
            .tree
            .query(&c.to_array())
            .nearest_n::<SquaredEuclidean<f32>>(NonZeroUsize::new(4).expect("4 > 0"))
            .execute();
        found.iter().find_map(|item| {
            let index = item.item as usize;
            let q = Vec3::from(self.points[index]);
            (index != p_index && q.distance(p) > self.coincident).then_some(q)
        })
    }

    /// Shrinks the ball touching sample `p_index` at `p` on the side `n` points to (masbcpp's
    /// `sb_point` with `nan_for_initr`): `None` when the ball stays open.
    fn ball(&self, p_index: usize, p: Vec3, n: Vec3) -> Option<MedialBall> {
        let r0 = self.initial_radius;
        let mut r_previous = 0f32;
        let mut c = p + n * r0;
        let mut j = 0usize;
        let mut radius;
        loop {
            let q = self.nearest_other(c, p_index, p)?;
            // The ball through p (tangent to the plane of n) that also passes through q.
            let pq = q - p;
            radius = pq.length_squared() / (2.0 * n.dot(pq));
            if radius.is_nan() || radius <= 0.0 {
                // q lies behind p's plane (or on it): restart from the initial ball.
                radius = r0;
            } else if radius > r0 {
                // Nothing nearer than the initial ball on this side: open space.
                return None;
            }
            let c_next = p + n * radius;
            if self.preserve_angle > 0.0 || self.planar_angle > 0.0 {
                let separation = angle_between(p - c_next, q - c_next);
                if self.preserve_angle > 0.0
                    && separation < self.preserve_angle
                    && j > 0
                    && radius > pq.length()
                {
                    // Noise: keep the previous ball.
                    radius = r_previous;
                    break;
                }
                if self.planar_angle > 0.0 && separation < self.planar_angle && j == 0 {
                    // The sample's neighbourhood is planar: no finite ball on this side.
                    return None;
                }
            }
            if (r_previous - radius).abs() < self.convergence || j >= self.iteration_limit {
                c = c_next;
                break;
            }
            r_previous = radius;
            c = c_next;
            j += 1;
        }
        (radius < r0 && radius > 0.0).then_some(MedialBall {
            center: c,
            radius,
            sample: p_index as u32,
        })
    }
}

/// The angle between two vectors, radians, in `[0, π]`.
fn angle_between(a: Vec3, b: Vec3) -> f32 {
    let cos = a.dot(b) / (a.length() * b.length());
    if cos.is_nan() {
        0.0
    } else {
        cos.clamp(-1.0, 1.0).acos()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shrinking_ball_between_two_planes_finds_the_mid_plane() {
        // Two parallel planes 2 m apart, sampled on a grid: the medial ball of a sample on the
        // lower plane (normal up) has radius 1 and centre on y = 1.
        let mut points = Vec::new();
        for i in -20..=20 {
            for k in -20..=20 {
                let (x, z) = (i as f32 * 0.1, k as f32 * 0.1);
                points.push([x, 0.0, z]);
                points.push([x + 0.05, 2.0, z + 0.05]);
            }
        }
        let tree = ImmutableKdTree::new_from_slice(&points).unwrap();
        let shrinker = BallShrinker {
            tree: &tree,
            points: &points,
            initial_radius: 100.0,
            convergence: 1e-5 * 100.0,
            iteration_limit: 30,
            preserve_angle: 20f32.to_radians(),
            planar_angle: 32f32.to_radians(),
            coincident: 1e-4,
        };
        let index = points.iter().position(|p| *p == [0.0, 0.0, 0.0]).unwrap();
        let ball = shrinker
            .ball(index, Vec3::ZERO, Vec3::Y)
            .expect("a finite ball");
        assert!((ball.radius - 1.0).abs() < 0.01, "{ball:?}");
        assert!((ball.center - Vec3::Y).length() < 0.01, "{ball:?}");
        // Downwards nothing lies below the plane: open.
        assert_eq!(shrinker.ball(index, Vec3::ZERO, -Vec3::Y), None);
    }

    #[test]
    fn angles() {
        assert!((angle_between(Vec3::X, Vec3::Y) - std::f32::consts::FRAC_PI_2).abs() < 1e-6);
        assert_eq!(angle_between(Vec3::ZERO, Vec3::Y), 0.0);
    }
}
