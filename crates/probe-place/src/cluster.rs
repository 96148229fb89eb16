//! Clustering of skeleton or medial points into probe candidates, shared by the SDF and
//! medial-axis generators.

use crate::grid::inside_geometry;
use crate::par::*;
use glam::Vec3;
use probe_scene::Scene;

/// How clusters became probes (for [`SdfCandidates`](crate::candidates::SdfCandidates) and
/// [`MedialCandidates`](crate::candidates::MedialCandidates)).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ClusterStats {
    /// Probes placed at their cluster's mean.
    pub at_mean: usize,
    /// Probes moved from a mean outside free space (or seeing mostly back faces) to a member
    /// of the cluster.
    pub moved: usize,
    /// Clusters dropped because no member near the mean was a valid probe position.
    pub dropped: usize,
}

/// How many of a cluster's members nearest its mean are tried when the mean is invalid.
const SETTLE_TRIES: usize = 16;

/// Splits points (skeleton voxels or medial-ball centres) into clusters, each the points one
/// probe would see, by greedy covering:
///
/// visit the points from the largest clearance (distance to geometry) down; a point not yet
/// covered becomes a seed and covers every uncovered point it sees (`visible(seed, point)`,
/// an unoccluded segment) within its cluster radius, `coverage_factor` times its clearance
/// but at most `max_radius`. Seeds thus sit where the space is widest, a seed in a hall
/// reaches farther than one in a corridor, a convex room is one cluster, and every region
/// hidden from earlier seeds starts a cluster of its own. A point joins the first seed that
/// covers it.
///
/// Returns the members (indices into `points`) of each cluster, in seed order.
/// Deterministic (ties broken by index).
pub(crate) fn cover_clusters(
    points: &[Vec3],
    clearances: &[f32],
    coverage_factor: f32,
    max_radius: f32,
    visible: impl Fn(Vec3, Vec3) -> bool + Sync,
) -> Vec<Vec<usize>> {
    assert_eq!(points.len(), clearances.len(), "one clearance per point");
    const UNCOVERED: u32 = u32::MAX;
    let mut order: Vec<usize> = (0..points.len()).collect();
    order.sort_by(|&a, &b| clearances[b].total_cmp(&clearances[a]).then(a.cmp(&b)));
    let mut owner = vec![UNCOVERED; points.len()];
    let mut clusters: Vec<Vec<usize>> = Vec::new();
    for &seed in &order {
        if owner[seed] != UNCOVERED {
            continue;
        }
        let cluster = clusters.len() as u32;
        let centre = points[seed];
        let radius = (coverage_factor * clearances[seed]).min(max_radius);
        let limit = radius * radius;
        owner[seed] = cluster;
        let mut members: Vec<usize> = (0..points.len())
            .into_par_iter()
            .with_min_len(256)
            .filter(|&j| {
                owner[j] == UNCOVERED
                    && points[j].distance_squared(centre) <= limit
                    && visible(centre, points[j])
            })
            .collect();
        for &j in &members {
            owner[j] = cluster;
        }
        members.push(seed);
        members.sort_unstable();
        clusters.push(members);
    }
    clusters
}

/// The probe position of a cluster: its mean if `fits` it and it is not
/// [`inside_geometry`]; else the nearest of its members (up to [`SETTLE_TRIES`]) that passes
/// both; else `None`. Updates `stats`.
pub(crate) fn settle_in_free_space(
    scene: &Scene,
    members: &[Vec3],
    fits: impl Fn(Vec3) -> bool,
    stats: &mut ClusterStats,
) -> Option<Vec3> {
    let mean = members.iter().copied().sum::<Vec3>() / members.len().max(1) as f32;
    if fits(mean) && !inside_geometry(scene, mean) {
        stats.at_mean += 1;
        return Some(mean);
    }
    let mut by_distance: Vec<Vec3> = members.to_vec();
    by_distance.sort_by(|a, b| {
        a.distance_squared(mean)
            .total_cmp(&b.distance_squared(mean))
    });
    let settled = by_distance
        .into_iter()
        .filter(|&p| fits(p))
        .take(SETTLE_TRIES)
        .find(|&p| !inside_geometry(scene, p));
    match settled {
        Some(_) => stats.moved += 1,
        None => stats.dropped += 1,
    }
    settled
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clusters_follow_visibility_and_radius() {
        // Points along x in [0, 4) and [6, 10); a wall at x = 5 hides one half from the other.
        let points: Vec<Vec3> = (0..80)
            .map(|i| {
                let x = (i % 40) as f32 * 0.1 + if i < 40 { 0.0 } else { 6.0 };
                Vec3::new(x, 0.0, 0.0)
            })
            .collect();
        // Clearance peaks in the middle of each half.
        let clearances: Vec<f32> = points
            .iter()
            .map(|p| 2.0 - (p.x - if p.x < 5.0 { 2.0 } else { 8.0 }).abs())
            .collect();
        let wall = |a: Vec3, b: Vec3| (a.x < 5.0) == (b.x < 5.0);
        let clusters = cover_clusters(&points, &clearances, 100.0, 100.0, wall);
        assert_eq!(clusters.len(), 2);
        assert_eq!(clusters[0], (0..40).collect::<Vec<_>>());
        assert_eq!(clusters[1], (40..80).collect::<Vec<_>>());
        // A 1 m radius splits each 3.9 m half: the seed at the middle covers 2 m, then each
        // remaining end needs its own clusters.
        let small = cover_clusters(&points, &clearances, 100.0, 1.0, wall);
        let total: usize = small.iter().map(Vec::len).sum();
        assert_eq!(total, 80);
        assert!(small.len() >= 6, "{}", small.len());
        for cluster in &small {
            let xs: Vec<f32> = cluster.iter().map(|&i| points[i].x).collect();
            let (lo, hi) = xs
                .iter()
                .fold((f32::MAX, f32::MIN), |(l, h), &x| (l.min(x), h.max(x)));
            assert!(hi - lo <= 2.0 + 1e-5, "{xs:?}");
            assert!(lo >= 5.0 || hi < 5.0, "a cluster crosses the wall: {xs:?}");
        }
        // With a coverage factor of 1, the seed at x = 2 (clearance 2) reaches 2 m: to the
        // ends of its half.
        let adaptive = cover_clusters(&points, &clearances, 1.0, 100.0, wall);
        assert_eq!(adaptive.len(), 2);
        let tight = cover_clusters(&points, &clearances, 0.5, 100.0, wall);
        assert!(tight.len() > 2);
        assert!(cover_clusters(&[], &[], 1.0, 1.0, wall).is_empty());
    }
}
