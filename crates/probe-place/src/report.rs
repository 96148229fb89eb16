//! A serialisable summary of a placement: what was run, how many probes, how well they cover
//! the scene and how long it took.

use crate::atlas::{Atlas, FreeSpace, counts_by_view};
use crate::par::*;
use crate::provenance::PlacementMethod;
use glam::Vec3;
use serde::{Deserialize, Serialize};

/// The coverage rule, as stated in every report.
pub const COVERAGE_RULE: &str = "coverage = share of atlas texels seen by at least one probe \
(unoccluded segment, view cosine above min_view_cosine, within max_distance); texels are \
equal-area samples of front faces (both faces if double-sided, alpha cut-outs excluded), kept \
only if some reference point in free space sees them that way";

/// What a placement produced, measured over a visibility atlas. Serialises to JSON with
/// serde; [`PlacementReport::to_json`] gives the pretty form.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PlacementReport {
    /// The placement method with its parameters; in JSON the two fields `"method"` (a name
    /// such as `"grid"`, `"sdf+gibbs"`, `"spawn-merge"`) and `"parameters"` (an object).
    #[serde(flatten)]
    pub method: PlacementMethod,
    /// The number of probes.
    pub probe_count: usize,
    /// The share of texels seen (see [`COVERAGE_RULE`]).
    pub coverage: f64,
    /// Texels seen.
    pub covered_texels: usize,
    /// Texels in the atlas (those reachable from free space).
    pub texels: usize,
    /// Texels sampled but dropped as unreachable from free space.
    pub unreachable_texels: usize,
    /// The atlas's texel edge in metres.
    pub texel_size: f32,
    /// The view-cosine threshold of "seen".
    pub min_view_cosine: f32,
    /// The mean, over the texels seen, of the best view cosine any probe has of them.
    pub mean_best_view_cosine: f64,
    /// Probes inside geometry ([`FreeSpace::inside_geometry`]); must be 0.
    pub probes_inside_geometry: usize,
    /// Probes outside the free-space test's bounds.
    pub probes_outside_bounds: usize,
    /// For an atlas of views ([`Atlas::from_view_samples`]): the coverage of the view whose
    /// points are least seen (what an error-driven set held by each view keeps at its target).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub worst_view_coverage: Option<f64>,
    /// The placement's wall-clock time in seconds, as measured by the caller.
    pub seconds: f64,
    /// [`COVERAGE_RULE`].
    pub coverage_rule: String,
}

impl PlacementReport {
    /// Measures `probes` over `atlas` (views in parallel) and classifies them with `free`.
    /// `seconds` is the time the placement took, measured by the caller.
    pub fn measure(
        method: PlacementMethod,
        atlas: &Atlas<'_>,
        free: &dyn FreeSpace,
        probes: &[Vec3],
        seconds: f64,
    ) -> PlacementReport {
        let best = atlas.best_view_cosines(probes);
        let seen: Vec<f32> = best.iter().copied().filter(|c| *c > 0.0).collect();
        let bounds = free.bounds();
        let inside = probes
            .par_iter()
            .filter(|p| p.is_finite() && free.inside_geometry(**p))
            .count();
        let outside = probes.iter().filter(|p| !bounds.contains(**p)).count();
        PlacementReport {
            method,
            probe_count: probes.len(),
            coverage: seen.len() as f64 / best.len() as f64,
            covered_texels: seen.len(),
            texels: best.len(),
            unreachable_texels: atlas.unreachable_texels(),
            texel_size: atlas.params().texel_size,
            min_view_cosine: atlas.params().min_view_cosine,
            mean_best_view_cosine: if seen.is_empty() {
                0.0
            } else {
                seen.iter().map(|c| *c as f64).sum::<f64>() / seen.len() as f64
            },
            probes_inside_geometry: inside,
            probes_outside_bounds: outside,
            worst_view_coverage: worst_view_coverage(atlas.sample_views(), &best),
            seconds,
            coverage_rule: COVERAGE_RULE.to_owned(),
        }
    }

    /// Pretty-printed JSON.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).unwrap_or_else(|e| format!("{{\"error\": \"{e}\"}}"))
    }
}

/// The least per-view share of texels seen (`best[t] > 0`), for texels labelled by view;
/// `None` without labels.
fn worst_view_coverage(views: &[u32], best: &[f32]) -> Option<f64> {
    counts_by_view(views, |t| best[t] > 0.0)
        .iter()
        .filter(|[_, total]| *total > 0)
        .map(|&[seen, total]| seen as f64 / total as f64)
        .min_by(f64::total_cmp)
}
