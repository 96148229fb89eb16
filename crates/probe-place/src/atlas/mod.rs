//! The visibility atlas of seed 000 §3.2.1: the scene's surfaces cut into equal-area samples
//! (the atlas texels), what each probe sees of them, coverage and the reward `R(P)` of
//! eq. 3.1–3.2.

mod free_space;
mod state;

pub use free_space::{BackfaceVote, FreeSpace, VoxelFreeSpace, free_space_grid};
pub use state::{AtlasState, Evaluation};

pub use crate::report::{COVERAGE_RULE, PlacementReport};

use crate::par::*;
use glam::{Vec2, Vec3};
use probe_scene::{Ray, Scene};
use serde::{Deserialize, Serialize};

/// The default threshold on the view cosine: a texel counts as seen by a probe only when
/// `normal · (probe − texel) / |probe − texel| > 0.2`, i.e. at less than 78.5° from the
/// texel's normal. Views at more grazing angles give the stretched, leaking texels that seed 000
/// §3.2.1 ("View Direction") wants to avoid.
pub const DEFAULT_MIN_VIEW_COSINE: f32 = 0.2;

/// The most texels an atlas may hold (before the reachability filter).
pub const MAX_TEXELS: usize = 20_000_000;

/// How an atlas samples the scene's surfaces.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct AtlasParams {
    /// The texel edge in metres: every texel stands for `texel_size²` of surface.
    pub texel_size: f32,
    /// A texel counts as seen by a probe only above this view cosine (see
    /// [`DEFAULT_MIN_VIEW_COSINE`]); in `[0, 1)`.
    pub min_view_cosine: f32,
    /// Texels farther than this from a probe are not seen by it (`None`: no limit).
    pub max_distance: Option<f32>,
    /// Seeds the stochastic rounding of texel counts and the sample patterns.
    pub seed: u64,
}

impl AtlasParams {
    /// Parameters whose texel size gives about `texels` texels over the front faces (both faces
    /// of double-sided triangles) of `scene`, with the default view cosine, no distance limit
    /// and seed 0. An empty scene gives a texel size of zero, which [`Atlas::build`] refuses.
    pub fn for_texel_count(scene: &Scene, texels: usize) -> AtlasParams {
        let area: f64 = scene
            .triangles()
            .iter()
            .map(|t| {
                let sides = if scene.materials()[t.material as usize].double_sided {
                    2.0
                } else {
                    1.0
                };
                sides * t.area() as f64
            })
            .sum();
        AtlasParams {
            texel_size: (area / texels.max(1) as f64).sqrt() as f32,
            min_view_cosine: DEFAULT_MIN_VIEW_COSINE,
            max_distance: None,
            seed: 0,
        }
    }
}

/// Why an atlas could not be built.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum AtlasError {
    /// The scene has no triangles with area.
    ///
    /// Fix: load a scene with geometry; a scene of points and lines only has no surface to see.
    #[error("the scene `{scene}` has no triangles with area: there is no surface to cover")]
    EmptyScene {
        /// The scene's name.
        scene: String,
    },
    /// A parameter is out of its range or not finite.
    ///
    /// Fix: pass a value in the range named in the message (see [`AtlasParams`]).
    #[error("atlas parameter `{name}` = {value} is invalid: expected {expected}")]
    InvalidParameter {
        /// The parameter's name.
        name: &'static str,
        /// The value given.
        value: f64,
        /// The valid range.
        expected: &'static str,
    },
    /// The texel size is so small for this scene that the atlas would exceed [`MAX_TEXELS`].
    ///
    /// Fix: use a larger `texel_size`, or [`AtlasParams::for_texel_count`].
    #[error(
        "texel_size {texel_size} m gives about {texels} texels, more than the limit of {limit}"
    )]
    TooManyTexels {
        /// The texel size given.
        texel_size: f32,
        /// The estimated texel count.
        texels: u64,
        /// [`MAX_TEXELS`].
        limit: usize,
    },
    /// No reference point was given, so no texel can be reachable.
    ///
    /// Fix: pass free points, e.g. [`free_space_grid`] with a spacing that fits the scene, or
    /// use [`Atlas::build_unfiltered`].
    #[error(
        "no reference points: pass free-space points (e.g. free_space_grid) to decide which surfaces can be seen"
    )]
    NoReferencePoints,
    /// No texel is seen from any reference point (or no texel was sampled at all).
    ///
    /// Fix: check that the reference points lie in free space in front of the surfaces (a grid
    /// entirely inside geometry sees nothing), or use a smaller `texel_size`.
    #[error("no texel of the scene `{scene}` is seen from the {reference_points} reference points")]
    NothingVisible {
        /// The scene's name.
        scene: String,
        /// How many reference points were given.
        reference_points: usize,
    },
}

/// One atlas texel: a surface point with the normal of the side it represents.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceSample {
    /// The point on the surface, world space.
    pub position: Vec3,
    /// The unit normal of the side this texel represents (the geometric normal, reversed for
    /// the back side of a double-sided triangle).
    pub normal: Vec3,
    /// Index into [`Scene::triangles`].
    pub triangle: u32,
}

/// What one probe sees of one texel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProbeView {
    /// Index into [`Atlas::samples`].
    pub sample: u32,
    /// `normal · (probe − texel) / |probe − texel|`, above the atlas's minimum view cosine.
    pub view_cosine: f32,
    /// `|probe − texel|` in metres.
    pub distance: f32,
}

/// The share of the atlas's distance scale ([`Atlas::distance_scale`]) within which
/// [`read_score`] does not fall with distance: 0.4, chosen by measurement (BENCHMARKS.md,
/// "Budgets spent on probes that read well").
pub const READ_REACH: f32 = 0.4;

/// How well a probe reads a texel's radiance for the light-field tracer: the view cosine,
/// times `reach / distance` beyond `reach` (metres). The tracer reads a hit from the probe
/// that sees it most squarely for its distance (cosine over distance: a texel's footprint on
/// the surface grows with distance over cosine), so a probe that sees a surface edge-on or
/// from far away gives a blurred read. Within `reach` only the angle counts, so a probe
/// pressed against a surface gains nothing.
///
/// ```
/// use probe_place::atlas::{ProbeView, read_score};
///
/// let view = |distance| ProbeView { sample: 0, view_cosine: 0.5, distance };
/// assert_eq!(read_score(&view(1.0), 2.0), 0.5); // within reach: the cosine
/// assert_eq!(read_score(&view(4.0), 2.0), 0.25); // twice as far: half
/// ```
#[inline]
pub fn read_score(view: &ProbeView, reach: f32) -> f32 {
    if view.distance <= reach {
        view.view_cosine
    } else {
        view.view_cosine * reach / view.distance
    }
}

/// How the per-probe scores of one texel combine into the texel's fitness `π_ij`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum TexelAggregation {
    /// The best probe's score: `π = max_k (w1·Ω_k + w2·d_k)·V_k`. A texel seen by many
    /// probes counts once, so the reward grows with coverage and view quality, not with
    /// redundant views. The default.
    BestProbe,
    /// Eq. 3.2 as written: `π = Σ_k (w1·Ω_k + w2·d_k)·V_k`. Redundant views add up, so moving a
    /// probe to see a large wall that others already see can beat covering a small hidden
    /// corner.
    SumOverProbes,
}

/// The weights of eq. 3.2: a probe's score for a texel it sees is
/// `w1 · view_cosine + w2 · min(distance / distance_scale, 1)`, where `distance_scale` is the
/// atlas's [`Atlas::distance_scale`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct RewardWeights {
    /// `w1`, the weight of the view cosine `Ω` (orientation metric). Default 1.
    pub view_cosine: f32,
    /// `w2`, the weight of the normalised distance `d` (seed 000 §3.2.1 "Distance to
    /// Surface": it pushes probes away from the surfaces they see). Default 0.25.
    pub distance: f32,
    /// How scores combine per texel. Default [`TexelAggregation::BestProbe`].
    pub aggregation: TexelAggregation,
}

impl Default for RewardWeights {
    fn default() -> RewardWeights {
        RewardWeights {
            view_cosine: 1.0,
            distance: 0.25,
            aggregation: TexelAggregation::BestProbe,
        }
    }
}

impl RewardWeights {
    /// `Err((name, value))` for the first weight that is not finite or is negative, or when
    /// both weights are zero (`name` is then `"weights"`).
    pub fn check(&self) -> Result<(), (&'static str, f32)> {
        for (name, value) in [("w1", self.view_cosine), ("w2", self.distance)] {
            if !(value.is_finite() && value >= 0.0) {
                return Err((name, value));
            }
        }
        if self.view_cosine + self.distance <= 0.0 {
            return Err(("weights", 0.0));
        }
        Ok(())
    }

    /// The score of one view: `w1 · cos + w2 · min(distance / scale, 1)`.
    #[inline]
    pub fn score(&self, view: &ProbeView, distance_scale: f32) -> f32 {
        self.view_cosine * view.view_cosine
            + self.distance * (view.distance / distance_scale).min(1.0)
    }
}

/// The visibility atlas: equal-area samples (texels) of the surfaces a probe in free space can
/// see, with what any probe position sees of them.
///
/// # Which surfaces are sampled (the coverage rule)
/// 1. Every triangle with area, on its front face; double-sided materials on both faces.
///    Alpha-mask cut-outs are not surface and get no texels.
/// 2. Texels are spread by area: a triangle of area `A` gets `⌊A / texel_size² + u⌋` texels
///    (`u` uniform in `[0, 1)`, seeded per triangle), so the expected count is exact, every texel
///    stands for `texel_size²` of surface, and coverage is the share of texels seen. Texels lie
///    on a rank-1 lattice (the R2 sequence) folded into the triangle.
/// 3. **Reachability**: [`Atlas::build`] keeps only texels seen, at a view cosine above the
///    threshold and within the distance limit, from at least one of the given reference
///    points (by default a dense grid of free points, [`free_space_grid`]). This drops faces
///    inside closed solids, the outer sides of a room's walls, surfaces under the ground and
///    gaps narrower than the reference spacing — no probe in free space could see them well.
///    "Full coverage" is defined over the texels kept; [`Atlas::unreachable_texels`] says how
///    many were dropped.
///
/// Coverage of a probe set is the share of kept texels that at least one probe sees: an
/// unoccluded segment from texel to probe, a view cosine above the atlas's threshold and a
/// distance within its limit.
#[derive(Clone, Debug)]
pub struct Atlas<'a> {
    scene: &'a Scene,
    params: AtlasParams,
    samples: Vec<SurfaceSample>,
    /// The view each sample came from ([`Atlas::from_view_samples`]); empty otherwise.
    views: Vec<u32>,
    unreachable: usize,
    distance_scale: f32,
}

impl<'a> Atlas<'a> {
    /// Samples the surfaces of `scene` and keeps the texels seen from at least one of
    /// `reference_points` (see the coverage rule above). The reachability test runs in
    /// parallel and stops, for each texel, at the first reference point that sees it.
    pub fn build(
        scene: &'a Scene,
        params: &AtlasParams,
        reference_points: &[Vec3],
    ) -> Result<Atlas<'a>, AtlasError> {
        if reference_points.is_empty() {
            check_params(params)?;
            return Err(AtlasError::NoReferencePoints);
        }
        Atlas::build_unfiltered(scene, params)?.keep_reachable(reference_points)
    }

    /// Drops the texels no reference point sees (counted in [`Atlas::unreachable_texels`]).
    fn keep_reachable(mut self, reference_points: &[Vec3]) -> Result<Atlas<'a>, AtlasError> {
        let seen = self.seen_by_any(reference_points);
        let before = self.samples.len();
        let mut keep = seen.iter();
        self.samples.retain(|_| *keep.next().unwrap_or(&false));
        if !self.views.is_empty() {
            let mut keep = seen.iter();
            self.views.retain(|_| *keep.next().unwrap_or(&false));
        }
        self.unreachable = before - self.samples.len();
        if self.samples.is_empty() {
            return Err(AtlasError::NothingVisible {
                scene: self.scene.name().to_owned(),
                reference_points: reference_points.len(),
            });
        }
        Ok(self)
    }

    /// An atlas whose texels are `samples` given by the caller (for instance the points a
    /// view set sees, directly and in reflection: [`crate::viewers::view_samples`]) instead
    /// of equal-area samples, kept, as in [`Atlas::build`], only where some reference point
    /// sees them. A surface then weighs by how many samples fall on it: by how much viewers
    /// see it, not by its area. `params.texel_size` is only reported.
    ///
    /// # Errors
    /// As [`Atlas::build`]; [`AtlasError::EmptyScene`] for no sample.
    pub fn from_samples(
        scene: &'a Scene,
        params: &AtlasParams,
        samples: Vec<SurfaceSample>,
        reference_points: &[Vec3],
    ) -> Result<Atlas<'a>, AtlasError> {
        Atlas::from_labelled_samples(scene, params, samples, Vec::new(), reference_points)
    }

    /// [`Atlas::from_samples`] with the samples of each view apart (for instance
    /// [`crate::viewers::view_samples_per_view`]): the atlas remembers which view each texel
    /// came from ([`Atlas::sample_views`]), so that a target can hold for every view
    /// ([`crate::minimal::CoverParams::each_view`]), not only for all views together.
    ///
    /// # Errors
    /// As [`Atlas::from_samples`].
    pub fn from_view_samples(
        scene: &'a Scene,
        params: &AtlasParams,
        views: Vec<Vec<SurfaceSample>>,
        reference_points: &[Vec3],
    ) -> Result<Atlas<'a>, AtlasError> {
        let labels: Vec<u32> = views
            .iter()
            .enumerate()
            .flat_map(|(view, samples)| std::iter::repeat_n(view as u32, samples.len()))
            .collect();
        let samples = views.into_iter().flatten().collect();
        Atlas::from_labelled_samples(scene, params, samples, labels, reference_points)
    }

    fn from_labelled_samples(
        scene: &'a Scene,
        params: &AtlasParams,
        samples: Vec<SurfaceSample>,
        views: Vec<u32>,
        reference_points: &[Vec3],
    ) -> Result<Atlas<'a>, AtlasError> {
        check_params(params)?;
        if reference_points.is_empty() {
            return Err(AtlasError::NoReferencePoints);
        }
        if samples.is_empty() {
            return Err(AtlasError::EmptyScene {
                scene: scene.name().to_owned(),
            });
        }
        let distance_scale = distance_scale_of(scene, params);
        Atlas {
            scene,
            params: *params,
            samples,
            views,
            unreachable: 0,
            distance_scale,
        }
        .keep_reachable(reference_points)
    }

    /// The view each texel came from, in texel order, for an atlas made by
    /// [`Atlas::from_view_samples`]; empty for any other.
    pub fn sample_views(&self) -> &[u32] {
        &self.views
    }

    /// Samples the surfaces of `scene` without the reachability filter: every front face
    /// (both faces of double-sided triangles) gets texels, even where no probe could see it.
    pub fn build_unfiltered(
        scene: &'a Scene,
        params: &AtlasParams,
    ) -> Result<Atlas<'a>, AtlasError> {
        check_params(params)?;
        let texel_area = params.texel_size * params.texel_size;
        let materials = scene.materials();
        let sides = |material: u32| {
            if materials[material as usize].double_sided {
                2usize
            } else {
                1
            }
        };
        let estimate: f64 = scene
            .triangles()
            .iter()
            .map(|t| sides(t.material) as f64 * (t.area() / texel_area) as f64 + 1.0)
            .sum();
        if estimate > MAX_TEXELS as f64 {
            return Err(AtlasError::TooManyTexels {
                texel_size: params.texel_size,
                texels: estimate as u64,
                limit: MAX_TEXELS,
            });
        }
        let seed = params.seed;
        let samples: Vec<SurfaceSample> = scene
            .triangles()
            .par_iter()
            .enumerate()
            .with_min_len(256)
            .flat_map_iter(|(index, triangle)| {
                let normal = triangle.geometric_normal();
                let area = triangle.area();
                let material = &materials[triangle.material as usize];
                let side_count = sides(triangle.material);
                let mut out = Vec::new();
                if normal == Vec3::ZERO || area.is_nan() || area <= 0.0 {
                    return out;
                }
                for side in 0..side_count {
                    let key = hash64(seed ^ hash64((index as u64) << 1 | side as u64));
                    let count = (area / texel_area + unit_f32(key)).floor() as usize;
                    let offset = Vec2::new(unit_f32(hash64(key ^ 1)), unit_f32(hash64(key ^ 2)));
                    let side_normal = if side == 0 { normal } else { -normal };
                    for i in 0..count {
                        let b = r2_point(offset, i);
                        if !material.alpha.passes(triangle.uv(b)) {
                            continue;
                        }
                        out.push(SurfaceSample {
                            position: triangle.point(b),
                            normal: side_normal,
                            triangle: index as u32,
                        });
                    }
                }
                out
            })
            .collect();
        if samples.is_empty() {
            return Err(AtlasError::EmptyScene {
                scene: scene.name().to_owned(),
            });
        }
        let distance_scale = distance_scale_of(scene, params);
        Ok(Atlas {
            scene,
            params: *params,
            samples,
            views: Vec::new(),
            unreachable: 0,
            distance_scale,
        })
    }

    /// The scene the atlas samples.
    pub fn scene(&self) -> &'a Scene {
        self.scene
    }

    /// The parameters it was built with.
    pub fn params(&self) -> &AtlasParams {
        &self.params
    }

    /// The texels (kept after the reachability filter).
    pub fn samples(&self) -> &[SurfaceSample] {
        &self.samples
    }

    /// The area each texel stands for, in m² (`texel_size²`).
    pub fn texel_area(&self) -> f32 {
        self.params.texel_size * self.params.texel_size
    }

    /// How many sampled texels the reachability filter dropped (0 for
    /// [`Atlas::build_unfiltered`]).
    pub fn unreachable_texels(&self) -> usize {
        self.unreachable
    }

    /// The distance that normalises the distance metric: the distance limit if there is one,
    /// else the diagonal of the scene's bounds.
    pub fn distance_scale(&self) -> f32 {
        self.distance_scale
    }

    /// What a probe at `probe` sees: one [`ProbeView`] per texel it sees, in texel order.
    /// Casts one occlusion ray per texel that faces the probe within the distance limit;
    /// the texels are split over rayon's thread pool.
    pub fn probe_views(&self, probe: Vec3) -> Vec<ProbeView> {
        const CHUNK: usize = 2048;
        if !probe.is_finite() {
            return Vec::new();
        }
        let chunks: Vec<Vec<ProbeView>> = self
            .samples
            .par_chunks(CHUNK)
            .enumerate()
            .map(|(c, chunk)| {
                let base = c * CHUNK;
                chunk
                    .iter()
                    .enumerate()
                    .filter_map(|(i, s)| self.view_of(s, base + i, probe))
                    .collect()
            })
            .collect();
        chunks.concat()
    }

    /// [`Atlas::probe_views`] restricted to the texels whose index is `phase` modulo
    /// `stride` (a subset for cheap estimates).
    pub(crate) fn probe_views_strided(
        &self,
        probe: Vec3,
        stride: usize,
        phase: usize,
    ) -> Vec<ProbeView> {
        const CHUNK: usize = 512;
        let stride = stride.max(1);
        if stride == 1 {
            return self.probe_views(probe);
        }
        if !probe.is_finite() {
            return Vec::new();
        }
        let count = self.samples.len().saturating_sub(phase).div_ceil(stride);
        let chunks: Vec<Vec<ProbeView>> = (0..count.div_ceil(CHUNK))
            .into_par_iter()
            .map(|c| {
                (c * CHUNK..((c + 1) * CHUNK).min(count))
                    .filter_map(|j| {
                        let i = phase + j * stride;
                        self.view_of(&self.samples[i], i, probe)
                    })
                    .collect()
            })
            .collect();
        chunks.concat()
    }

    /// Which of `texels` (indices into [`Atlas::samples`]) a probe at `probe` sees, in the
    /// order given.
    pub(crate) fn sees_texels(&self, probe: Vec3, texels: &[u32]) -> Vec<u32> {
        texels
            .iter()
            .copied()
            .filter(|&t| {
                self.view_of(&self.samples[t as usize], t as usize, probe)
                    .is_some()
            })
            .collect()
    }

    /// [`Atlas::probe_views`] for many probes at once.
    pub fn views_of_probes(&self, probes: &[Vec3]) -> Vec<Vec<ProbeView>> {
        probes.iter().map(|p| self.probe_views(*p)).collect()
    }

    /// The view of texel `sample` (index `index`) from `probe`, if the probe sees it.
    #[inline]
    fn view_of(&self, sample: &SurfaceSample, index: usize, probe: Vec3) -> Option<ProbeView> {
        let offset = probe - sample.position;
        let distance_squared = offset.length_squared();
        let max_distance = self.params.max_distance.unwrap_or(f32::INFINITY);
        if distance_squared.is_nan()
            || distance_squared <= 1e-12
            || distance_squared > max_distance * max_distance
        {
            return None;
        }
        let distance = distance_squared.sqrt();
        let view_cosine = sample.normal.dot(offset) / distance;
        if view_cosine <= self.params.min_view_cosine {
            return None;
        }
        let ray = Ray::from_surface(sample.position, sample.normal, offset / distance);
        let remaining = (probe - ray.origin).length();
        if self.scene.occluded(&ray, remaining) {
            return None;
        }
        Some(ProbeView {
            sample: index as u32,
            view_cosine,
            distance,
        })
    }

    /// Whether at least one of `probes` sees each texel, and the best view cosine among those
    /// that do (0 where none does), computed in parallel over the probes.
    pub fn best_view_cosines(&self, probes: &[Vec3]) -> Vec<f32> {
        let mut best = vec![0.0f32; self.samples.len()];
        for views in self.views_of_probes(probes) {
            for view in views {
                let b = &mut best[view.sample as usize];
                *b = b.max(view.view_cosine);
            }
        }
        best
    }

    /// Whether each texel is seen by at least one of `probes`. Texel-major and parallel over
    /// texels: each texel stops at the first probe that sees it, which makes this much
    /// cheaper than collecting every probe's views when many probes see the same texels.
    pub fn seen_by_any(&self, probes: &[Vec3]) -> Vec<bool> {
        self.samples
            .par_iter()
            .enumerate()
            .with_min_len(64)
            .map(|(i, s)| probes.iter().any(|p| self.view_of(s, i, *p).is_some()))
            .collect()
    }

    /// The share of texels that at least one of `probes` sees (in `[0, 1]`).
    pub fn coverage(&self, probes: &[Vec3]) -> f64 {
        let seen = self.seen_by_any(probes);
        seen.iter().filter(|s| **s).count() as f64 / seen.len() as f64
    }

    /// For an atlas of views ([`Atlas::from_view_samples`]): per view, the share of its
    /// texels that at least one of `probes` sees (a view whose texels were all unreachable
    /// counts as fully seen). Empty for any other atlas.
    pub fn view_coverages(&self, probes: &[Vec3]) -> Vec<f64> {
        if self.views.is_empty() {
            return Vec::new();
        }
        let seen = self.seen_by_any(probes);
        counts_by_view(&self.views, |t| seen[t])
            .iter()
            .map(|&[seen, total]| {
                if total == 0 {
                    1.0
                } else {
                    seen as f64 / total as f64
                }
            })
            .collect()
    }
}

/// Per label (`0..=max`) of `labels` (texel → view), `[texels seen, texels]`, where
/// `seen(t)` says whether texel `t` is seen.
pub(crate) fn counts_by_view(labels: &[u32], seen: impl Fn(usize) -> bool) -> Vec<[usize; 2]> {
    let count = labels.iter().max().map_or(0, |m| *m as usize + 1);
    let mut counts = vec![[0usize; 2]; count];
    for (t, &l) in labels.iter().enumerate() {
        counts[l as usize][0] += usize::from(seen(t));
        counts[l as usize][1] += 1;
    }
    counts
}

/// The distance limit if there is one, else the diagonal of the scene's bounds.
fn distance_scale_of(scene: &Scene, params: &AtlasParams) -> f32 {
    params
        .max_distance
        .unwrap_or_else(|| scene.bounds().size().length())
        .max(f32::MIN_POSITIVE)
}

fn check_params(params: &AtlasParams) -> Result<(), AtlasError> {
    let invalid = |name, value: f32, expected| AtlasError::InvalidParameter {
        name,
        value: value as f64,
        expected,
    };
    if !(params.texel_size.is_finite() && params.texel_size > 0.0) {
        return Err(invalid(
            "texel_size",
            params.texel_size,
            "a finite size > 0 in metres",
        ));
    }
    if !(params.min_view_cosine >= 0.0 && params.min_view_cosine < 1.0) {
        return Err(invalid(
            "min_view_cosine",
            params.min_view_cosine,
            "a cosine in [0, 1)",
        ));
    }
    if let Some(d) = params.max_distance
        && (d <= 0.0 || d.is_nan())
    {
        return Err(invalid("max_distance", d, "a distance > 0 or None"));
    }
    Ok(())
}

/// SplitMix64's finaliser: a well-mixed 64-bit hash.
#[inline]
pub(crate) fn hash64(mut x: u64) -> u64 {
    x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^ (x >> 31)
}

/// A uniform number in `[0, 1)` from a hash's top 24 bits.
#[inline]
pub(crate) fn unit_f32(h: u64) -> f32 {
    (h >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
}

/// Point `i` of the R2 sequence (Roberts 2018) shifted by `offset`, folded into the triangle
/// `b1 + b2 ≤ 1` (the fold maps the unit square's upper half onto its lower half, uniformly).
fn r2_point(offset: Vec2, i: usize) -> Vec2 {
    const PLASTIC: f64 = 1.324_717_957_244_746;
    const A1: f64 = 1.0 / PLASTIC;
    const A2: f64 = 1.0 / (PLASTIC * PLASTIC);
    let u = (offset.x as f64 + A1 * i as f64).fract() as f32;
    let v = (offset.y as f64 + A2 * i as f64).fract() as f32;
    if u + v > 1.0 {
        Vec2::new(1.0 - u, 1.0 - v)
    } else {
        Vec2::new(u, v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig {
            rng_seed: proptest::test_runner::RngSeed::Fixed(1),
            ..ProptestConfig::default()
        })]
        /// The read score never rises with distance, is the cosine within reach, scales with
        /// the cosine and lies in [0, cosine].
        #[test]
        fn read_score_falls_with_distance(
            cosine in 0.0f32..=1.0,
            near in 0.0f32..100.0,
            extra in 0.0f32..100.0,
            reach in 0.0f32..50.0,
        ) {
            let view = |distance| ProbeView { sample: 0, view_cosine: cosine, distance };
            let (a, b) = (read_score(&view(near), reach), read_score(&view(near + extra), reach));
            prop_assert!(b <= a, "{b} > {a}");
            prop_assert!((0.0..=cosine).contains(&a));
            if near <= reach {
                prop_assert_eq!(a, cosine);
            } else {
                let half = ProbeView { view_cosine: 0.5 * cosine, ..view(near) };
                prop_assert!((read_score(&half, reach) - 0.5 * a).abs() <= 1e-6 * a.max(1.0));
            }
        }
    }

    #[test]
    fn r2_points_stay_in_the_triangle_and_spread() {
        let mut quadrants = [0usize; 4];
        for i in 0..1000 {
            let b = r2_point(Vec2::new(0.3, 0.7), i);
            assert!(b.x >= 0.0 && b.y >= 0.0 && b.x + b.y <= 1.0 + 1e-6, "{b}");
            // Split the triangle into four congruent halves-of-halves.
            let q = match (b.x > 0.5, b.y > 0.5, b.x + b.y > 0.5) {
                (true, _, _) => 0,
                (_, true, _) => 1,
                (_, _, true) => 2,
                _ => 3,
            };
            quadrants[q] += 1;
        }
        for q in quadrants {
            assert!((230..=270).contains(&q), "{quadrants:?}");
        }
    }

    #[test]
    fn weights_reject_nan_negative_and_all_zero() {
        let w = RewardWeights::default();
        assert!(w.check().is_ok());
        let nan = RewardWeights {
            view_cosine: f32::NAN,
            ..w
        };
        assert_eq!(nan.check().unwrap_err().0, "w1");
        let negative = RewardWeights {
            distance: -1.0,
            ..w
        };
        assert_eq!(negative.check().unwrap_err().0, "w2");
        let zero = RewardWeights {
            view_cosine: 0.0,
            distance: 0.0,
            ..w
        };
        assert_eq!(zero.check().unwrap_err().0, "weights");
    }
}
