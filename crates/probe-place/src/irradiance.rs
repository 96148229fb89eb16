//! Seed 002's irradiance-driven placement (Sukys 2014, §3.1): spawn and merge, irradiance-
//! gradient ascent with step reverts, and k-means for unlit probes. The lighting comes from a
//! [`LightingOracle`], so this crate needs no renderer.

use crate::atlas::{FreeSpace, free_space_grid, hash64};
use crate::par::*;
use glam::Vec3;
use probe_scene::{Ray, Scene};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;

/// Where the lighting comes from: a renderer (probe-capture's shading, wired in by
/// probe-eval's `CaptureOracle`), or an analytic model such as [`PointLightOracle`].
pub trait LightingOracle: Sync {
    /// How lit `point` is: the irradiance (linear RGB) on a small surface at `point` facing
    /// the brightest direction, or any other non-negative measure that is zero exactly where
    /// no light arrives. Seed 002 treats probes where it is zero as unlit.
    fn irradiance(&self, point: Vec3) -> Vec3;

    /// The irradiance (linear RGB) on a small surface at `point` with unit normal `normal`:
    /// what an SH irradiance probe at `point` returns for `normal`. Seed 002 samples it in 6 or
    /// 26 directions to compare probes and to find the irradiance gradient.
    ///
    /// The default returns [`LightingOracle::irradiance`] for every direction (isotropic
    /// light): gradient ascent then has no direction to follow. Implement it whenever the
    /// source knows directions.
    fn irradiance_towards(&self, point: Vec3, normal: Vec3) -> Vec3 {
        let _ = normal;
        self.irradiance(point)
    }
}

/// An analytic oracle: one point light of radiant intensity `intensity` (W/sr per channel)
/// with inverse-square falloff, shadowed by the scene's geometry (no indirect light):
/// `E(p, n) = I · max(0, n·l) / r²` where `l` points from `p` to the light, and 0 when a
/// triangle blocks the segment. [`LightingOracle::irradiance`] is `I / r²` (a surface facing
/// the light), 0 in shadow.
#[derive(Clone, Copy, Debug)]
pub struct PointLightOracle<'a> {
    scene: &'a Scene,
    /// The light's position.
    pub position: Vec3,
    /// Radiant intensity per channel.
    pub intensity: Vec3,
}

impl<'a> PointLightOracle<'a> {
    /// A point light at `position` in `scene`.
    pub fn new(scene: &'a Scene, position: Vec3, intensity: Vec3) -> PointLightOracle<'a> {
        PointLightOracle {
            scene,
            position,
            intensity,
        }
    }

    /// (unshadowed irradiance facing the light, unit direction to the light).
    fn facing(&self, point: Vec3) -> (Vec3, Vec3) {
        let offset = self.position - point;
        let distance = offset.length();
        if distance.is_nan() || distance <= 1e-4 {
            return (self.intensity * 1e8, Vec3::ZERO);
        }
        let direction = offset / distance;
        if self
            .scene
            .occluded(&Ray::new(point, direction), distance * (1.0 - 1e-5))
        {
            return (Vec3::ZERO, direction);
        }
        (self.intensity / (distance * distance), direction)
    }
}

impl LightingOracle for PointLightOracle<'_> {
    fn irradiance(&self, point: Vec3) -> Vec3 {
        self.facing(point).0
    }

    fn irradiance_towards(&self, point: Vec3, normal: Vec3) -> Vec3 {
        let (e, l) = self.facing(point);
        if l == Vec3::ZERO {
            return e;
        }
        e * normal.dot(l).max(0.0)
    }
}

/// Why an irradiance-driven placement could not run.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum IrradianceError {
    /// The scene has no triangles, so it has no bounds to fill.
    ///
    /// Fix: load a scene with geometry.
    #[error("the scene `{scene}` is empty: there is no volume to place probes in")]
    EmptyScene {
        /// The scene's name.
        scene: String,
    },
    /// A parameter is out of its range or not finite.
    ///
    /// Fix: pass a value in the range named in the message.
    #[error("parameter `{name}` = {value} is invalid: expected {expected}")]
    InvalidParameter {
        /// The parameter's name.
        name: &'static str,
        /// The value given.
        value: f64,
        /// The valid range.
        expected: &'static str,
    },
    /// The starting grid has no point in free space.
    ///
    /// Fix: use a smaller `spacing`, or check the free-space test's bounds.
    #[error("the starting grid of spacing {spacing} m has no point in free space")]
    NoFreeGridPoint {
        /// The grid spacing.
        spacing: f32,
    },
}

/// The 26 directions seed 002 §3.1.3 samples: the 6 axes, the 12 normalised sums of two
/// non-opposite axes and the 8 normalised sums of three (the 3×3×3 neighbourhood).
pub fn sample_directions() -> [Vec3; 26] {
    let mut out = [Vec3::ZERO; 26];
    let mut n = 0;
    for z in -1..=1 {
        for y in -1..=1 {
            for x in -1..=1 {
                if (x, y, z) != (0, 0, 0) {
                    out[n] = Vec3::new(x as f32, y as f32, z as f32).normalize();
                    n += 1;
                }
            }
        }
    }
    out
}

/// Rec. 709 luminance of linear RGB.
fn luminance(c: Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// The luminance of [`LightingOracle::irradiance_towards`] in the 26 directions.
fn signature(oracle: &dyn LightingOracle, point: Vec3) -> [f32; 26] {
    let dirs = sample_directions();
    std::array::from_fn(|i| luminance(oracle.irradiance_towards(point, dirs[i])).max(0.0))
}

/// Seed 002's contrast of two probes: the largest difference over the 26 directions, relative
/// to the brighter probe's brightest direction: `max_d |a_d − b_d| / max(max a, max b)`
/// (0 when both are dark). Normalising by the brightest value rather than per direction keeps
/// directions that face away from the light (near-zero on both sides) from counting as
/// "different".
pub fn contrast(a: &[f32; 26], b: &[f32; 26]) -> f32 {
    let scale = a.iter().chain(b.iter()).cloned().fold(0.0f32, f32::max);
    if scale.is_nan() || scale <= 0.0 {
        return 0.0;
    }
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0f32, f32::max)
        / scale
}

/// Spawn and merge (seed 002 §3.1.1).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SpawnMergeParams {
    /// The starting grid's spacing in metres (over the free-space test's bounds; points not in
    /// free space are left out).
    pub spacing: f32,
    /// Two probes closer than this are compared ("fairly close"); default `1.05 × spacing`
    /// (grid neighbours along the axes).
    pub neighbour_distance: f32,
    /// Contrast (see [`contrast`]) above which two neighbours differ and a probe is spawned
    /// between them, and at or below which they are merged; default 0.25.
    pub contrast_threshold: f32,
    /// No probe is spawned closer than this to another; default `spacing / 4`.
    pub min_spacing: f32,
    /// Iteration cap; default 6.
    pub max_iterations: usize,
    /// Probe cap: spawning stops here; default 20,000.
    pub max_probes: usize,
}

impl SpawnMergeParams {
    /// The defaults for a starting grid of `spacing`.
    pub fn with_spacing(spacing: f32) -> SpawnMergeParams {
        SpawnMergeParams {
            spacing,
            neighbour_distance: 1.05 * spacing,
            contrast_threshold: 0.25,
            min_spacing: 0.25 * spacing,
            max_iterations: 6,
            max_probes: 20_000,
        }
    }
}

/// Counts of one spawn-and-merge iteration.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct SpawnMergeStep {
    /// Probes spawned.
    pub spawned: usize,
    /// Merges (each replaces two probes by one).
    pub merged: usize,
    /// Probes after the iteration.
    pub probes: usize,
}

/// The result of an irradiance-driven placement.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct IrradiancePlacement {
    /// The probe positions.
    pub positions: Vec<[f32; 3]>,
    /// How many of them are lit probes (they come first).
    pub lit: usize,
    /// How many are k-means centres of unlit probes (they come last).
    pub unlit: usize,
    /// The iterations run.
    pub iterations: usize,
    /// Spawn and merge: one entry per iteration. Empty for gradient ascent.
    pub spawn_merge_steps: Vec<SpawnMergeStep>,
    /// Gradient ascent: per iteration, (probes moved, steps reverted). Empty for spawn and
    /// merge.
    pub ascent_steps: Vec<(usize, usize)>,
}

impl IrradiancePlacement {
    /// The positions as `Vec3`s.
    pub fn positions(&self) -> Vec<Vec3> {
        self.positions
            .iter()
            .map(|p| Vec3::from_array(*p))
            .collect()
    }
}

fn invalid(name: &'static str, value: f64, expected: &'static str) -> IrradianceError {
    IrradianceError::InvalidParameter {
        name,
        value,
        expected,
    }
}

fn positive(name: &'static str, value: f32) -> Result<(), IrradianceError> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(invalid(name, value as f64, "a finite value > 0"))
    }
}

fn starting_grid(
    scene: &Scene,
    free: &dyn FreeSpace,
    spacing: f32,
) -> Result<Vec<Vec3>, IrradianceError> {
    if scene.triangles().is_empty() {
        return Err(IrradianceError::EmptyScene {
            scene: scene.name().to_owned(),
        });
    }
    let size = free.bounds().size();
    if (size / spacing).max(Vec3::ONE).element_product() > 4.0e6 {
        return Err(invalid(
            "spacing",
            spacing as f64,
            "a spacing giving at most 4 million grid points",
        ));
    }
    let grid = free_space_grid(free, spacing);
    if grid.is_empty() {
        return Err(IrradianceError::NoFreeGridPoint { spacing });
    }
    Ok(grid)
}

/// Neighbour pairs `(i, j)`, `i < j`: `j` is among the `k` nearest points to `i` closer than
/// `radius`, or `i` among those of `j`. Sorted, without duplicates; a uniform hash grid of
/// cell `radius` finds them. Ties in distance go to the lower index.
fn neighbour_pairs(points: &[Vec3], radius: f32, k: usize) -> Vec<(usize, usize)> {
    let cell = |p: Vec3| (p / radius).floor().as_ivec3();
    let mut grid: HashMap<glam::IVec3, Vec<usize>> = HashMap::new();
    for (i, p) in points.iter().enumerate() {
        grid.entry(cell(*p)).or_default().push(i);
    }
    let r2 = radius * radius;
    let mut pairs: Vec<(usize, usize)> = points
        .par_iter()
        .enumerate()
        .flat_map_iter(|(i, p)| {
            let c = cell(*p);
            let mut near: Vec<(f32, usize)> = Vec::new();
            for dz in -1..=1 {
                for dy in -1..=1 {
                    for dx in -1..=1 {
                        if let Some(list) = grid.get(&(c + glam::IVec3::new(dx, dy, dz))) {
                            for &j in list {
                                let d2 = points[j].distance_squared(*p);
                                if j != i && d2 < r2 {
                                    near.push((d2, j));
                                }
                            }
                        }
                    }
                }
            }
            near.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            near.truncate(k);
            near.into_iter().map(move |(_, j)| (i.min(j), i.max(j)))
        })
        .collect();
    pairs.sort_unstable();
    pairs.dedup();
    pairs
}

/// How many nearest neighbours (within `neighbour_distance`) each probe is compared with.
const NEIGHBOURS: usize = 6;

/// Spawn and merge (seed 002 §3.1.1): start from a grid of free points; in each iteration
/// compare each probe with its 6 nearest neighbours closer than `neighbour_distance` by their
/// [`contrast`] over the 26 sampled directions (comparing every close pair instead makes the
/// work quadratic as spawns densify, the blow-up seed 002 reports). Pairs that differ (contrast above the threshold) get a new probe at
/// their midpoint — if it is free and at least `min_spacing` from every probe; pairs that are
/// similar are replaced by one probe at their midpoint — if it is free, and each probe merges
/// at most once per iteration. Pairs are handled in index order, so the result is
/// deterministic. Stops when an iteration changes nothing, after `max_iterations`, or when
/// `max_probes` is reached (no more spawns).
///
/// Where the lighting is flat, merges thin the grid out; where it changes, spawns refine it
/// (and, as seed 002 notes, cluster around lights).
pub fn spawn_and_merge(
    scene: &Scene,
    oracle: &dyn LightingOracle,
    free: &dyn FreeSpace,
    params: &SpawnMergeParams,
) -> Result<IrradiancePlacement, IrradianceError> {
    positive("spacing", params.spacing)?;
    positive("neighbour_distance", params.neighbour_distance)?;
    positive("min_spacing", params.min_spacing)?;
    if !(params.contrast_threshold >= 0.0 && params.contrast_threshold.is_finite()) {
        return Err(invalid(
            "contrast_threshold",
            params.contrast_threshold as f64,
            "a finite contrast >= 0",
        ));
    }
    if params.max_probes == 0 {
        return Err(invalid("max_probes", 0.0, "at least 1"));
    }
    let mut points = starting_grid(scene, free, params.spacing)?;
    let mut signatures: Vec<[f32; 26]> = points.par_iter().map(|p| signature(oracle, *p)).collect();
    let mut steps = Vec::new();
    let mut iterations = 0;
    while iterations < params.max_iterations {
        iterations += 1;
        let pairs = neighbour_pairs(&points, params.neighbour_distance, NEIGHBOURS);
        let min_d2 = params.min_spacing * params.min_spacing;
        let mut merged_away = vec![false; points.len()];
        let mut replacements: Vec<Vec3> = Vec::new();
        let mut spawn_candidates = Vec::new();
        for &(i, j) in &pairs {
            let mid = 0.5 * (points[i] + points[j]);
            if contrast(&signatures[i], &signatures[j]) > params.contrast_threshold {
                if points[i].distance_squared(points[j]) >= 4.0 * min_d2 {
                    spawn_candidates.push(mid);
                }
            } else if !merged_away[i] && !merged_away[j] && free.is_free(mid) {
                merged_away[i] = true;
                merged_away[j] = true;
                replacements.push(mid);
            }
        }
        let survivors = points.len() - replacements.len();
        let mut index = SpatialSet::new(params.min_spacing);
        for (k, p) in points.iter().enumerate() {
            if !merged_away[k] {
                index.insert(*p, 0);
            }
        }
        for m in &replacements {
            index.insert(*m, 0);
        }
        let mut spawns: Vec<Vec3> = Vec::new();
        for mid in spawn_candidates {
            if survivors + spawns.len() >= params.max_probes {
                break;
            }
            if index.find_within(mid, params.min_spacing).is_none() && free.is_free(mid) {
                index.insert(mid, 0);
                spawns.push(mid);
            }
        }
        if replacements.is_empty() && spawns.is_empty() {
            break;
        }
        steps.push(SpawnMergeStep {
            spawned: spawns.len(),
            merged: replacements.len(),
            probes: survivors + spawns.len(),
        });
        let mut next_points = Vec::with_capacity(survivors + spawns.len());
        let mut next_signatures = Vec::with_capacity(survivors + spawns.len());
        for k in 0..points.len() {
            if !merged_away[k] {
                next_points.push(points[k]);
                next_signatures.push(signatures[k]);
            }
        }
        let fresh: Vec<Vec3> = replacements.into_iter().chain(spawns).collect();
        let fresh_signatures: Vec<[f32; 26]> =
            fresh.par_iter().map(|p| signature(oracle, *p)).collect();
        next_points.extend(fresh);
        next_signatures.extend(fresh_signatures);
        points = next_points;
        signatures = next_signatures;
    }
    Ok(IrradiancePlacement {
        lit: points.len(),
        unlit: 0,
        positions: points.iter().map(|p| p.to_array()).collect(),
        iterations,
        spawn_merge_steps: steps,
        ascent_steps: Vec::new(),
    })
}

/// A set of points with "which is within r" queries (uniform hash grid of cell `r`).
struct SpatialSet {
    cell: f32,
    grid: HashMap<glam::IVec3, Vec<(Vec3, usize)>>,
}

impl SpatialSet {
    fn new(cell: f32) -> SpatialSet {
        SpatialSet {
            cell,
            grid: HashMap::new(),
        }
    }

    fn key(&self, p: Vec3) -> glam::IVec3 {
        (p / self.cell).floor().as_ivec3()
    }

    fn insert(&mut self, p: Vec3, id: usize) {
        let key = self.key(p);
        self.grid.entry(key).or_default().push((p, id));
    }

    /// The lowest id among the points closer than `r` (`r` at most the cell size).
    fn find_within(&self, p: Vec3, r: f32) -> Option<usize> {
        let c = self.key(p);
        let mut found: Option<usize> = None;
        for dz in -1..=1 {
            for dy in -1..=1 {
                for dx in -1..=1 {
                    if let Some(list) = self.grid.get(&(c + glam::IVec3::new(dx, dy, dz))) {
                        for (q, id) in list {
                            if q.distance_squared(p) < r * r {
                                found = Some(found.map_or(*id, |f| f.min(*id)));
                            }
                        }
                    }
                }
            }
        }
        found
    }
}

/// Irradiance-gradient ascent (seed 002 §3.1.2–3.1.3).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct GradientAscentParams {
    /// The starting grid's spacing in metres.
    pub spacing: f32,
    /// The first step length; default `spacing / 2`.
    pub step: f32,
    /// A probe stops once its step falls below this; default `spacing / 16`.
    pub min_step: f32,
    /// Iteration cap; default 40.
    pub max_iterations: usize,
    /// Probes whose [`LightingOracle::irradiance`] luminance is at or below this are unlit;
    /// default 0.
    pub unlit_threshold: f32,
    /// Lit probes that end closer than this are merged into one; default `spacing / 4`.
    pub merge_distance: f32,
    /// How many probes stand for the unlit ones (k-means centres); default 4. With 0 the unlit
    /// probes are dropped.
    pub unlit_clusters: usize,
    /// Seeds the k-means initialisation.
    pub seed: u64,
}

impl GradientAscentParams {
    /// The defaults for a starting grid of `spacing`.
    pub fn with_spacing(spacing: f32) -> GradientAscentParams {
        GradientAscentParams {
            spacing,
            step: 0.5 * spacing,
            min_step: spacing / 16.0,
            max_iterations: 40,
            unlit_threshold: 0.0,
            merge_distance: 0.25 * spacing,
            unlit_clusters: 4,
            seed: 0,
        }
    }
}

/// Seed 002's irradiance gradient at `point`: the sum of the 26 sample directions weighted by
/// the luminance of the irradiance in each (Chajdas et al.'s "sum of directions times
/// luminance"), divided by 26. It points towards where the light comes from.
pub fn irradiance_gradient(oracle: &dyn LightingOracle, point: Vec3) -> Vec3 {
    let dirs = sample_directions();
    let s = signature(oracle, point);
    dirs.iter()
        .zip(s)
        .fold(Vec3::ZERO, |acc, (d, l)| acc + *d * l)
        / 26.0
}

/// Irradiance-gradient ascent with step reverts (seed 002 §3.1.2), then k-means for the unlit
/// probes (§3.1.3):
/// 1. Start from a grid of free points; those whose irradiance luminance is at most
///    `unlit_threshold` are unlit and set aside.
/// 2. Each lit probe climbs [`irradiance_gradient`]: `p ← p + step · g/|g|`. A step is
///    **reverted** (the probe returns to where it was and its step halves) when the new
///    position is dark — seed 002's second-order rule against ascending behind geometry —
///    or is not free. The step also halves when the gradient turns by more than 90°
///    (the probe overshot). A probe stops when its step falls below `min_step` or its gradient
///    vanishes; all stop after `max_iterations`.
/// 3. Lit probes that end within `merge_distance` of each other are merged (greedily in index
///    order) into their mean, or into the first of them if the mean is not free.
/// 4. The unlit probes are clustered by k-means (k-means++ seeding from `seed`, Lloyd
///    iterations) into `unlit_clusters` centres; a centre not in free space is replaced by the
///    nearest unlit probe of its cluster.
pub fn gradient_ascent(
    scene: &Scene,
    oracle: &dyn LightingOracle,
    free: &dyn FreeSpace,
    params: &GradientAscentParams,
) -> Result<IrradiancePlacement, IrradianceError> {
    positive("spacing", params.spacing)?;
    positive("step", params.step)?;
    positive("min_step", params.min_step)?;
    positive("merge_distance", params.merge_distance)?;
    if !(params.unlit_threshold >= 0.0 && params.unlit_threshold.is_finite()) {
        return Err(invalid(
            "unlit_threshold",
            params.unlit_threshold as f64,
            "a finite luminance >= 0",
        ));
    }
    let grid = starting_grid(scene, free, params.spacing)?;
    let lit_flags: Vec<bool> = grid
        .par_iter()
        .map(|p| luminance(oracle.irradiance(*p)) > params.unlit_threshold)
        .collect();
    let mut lit: Vec<Vec3> = Vec::new();
    let mut unlit: Vec<Vec3> = Vec::new();
    for (p, is_lit) in grid.iter().zip(lit_flags) {
        if is_lit { &mut lit } else { &mut unlit }.push(*p);
    }

    #[derive(Clone, Copy)]
    struct Climber {
        position: Vec3,
        step: f32,
        previous: Vec3,
        done: bool,
    }
    let mut climbers: Vec<Climber> = lit
        .iter()
        .map(|p| Climber {
            position: *p,
            step: params.step,
            previous: Vec3::ZERO,
            done: false,
        })
        .collect();
    let mut ascent_steps = Vec::new();
    let mut iterations = 0;
    while iterations < params.max_iterations && climbers.iter().any(|c| !c.done) {
        iterations += 1;
        let outcomes: Vec<(Climber, bool, bool)> = climbers
            .par_iter()
            .map(|c| {
                let mut c = *c;
                if c.done {
                    return (c, false, false);
                }
                let g = irradiance_gradient(oracle, c.position);
                let length = g.length();
                if length <= 0.0 || !length.is_finite() {
                    c.done = true;
                    return (c, false, false);
                }
                let direction = g / length;
                if c.previous.dot(direction) < 0.0 {
                    c.step *= 0.5;
                }
                c.previous = direction;
                let target = c.position + direction * c.step;
                let lit_there = luminance(oracle.irradiance(target)) > params.unlit_threshold;
                let (moved, reverted) = if lit_there && free.is_free(target) {
                    c.position = target;
                    (true, false)
                } else {
                    c.step *= 0.5;
                    (false, true)
                };
                if c.step < params.min_step {
                    c.done = true;
                }
                (c, moved, reverted)
            })
            .collect();
        let moved = outcomes.iter().filter(|o| o.1).count();
        let reverted = outcomes.iter().filter(|o| o.2).count();
        climbers = outcomes.into_iter().map(|o| o.0).collect();
        ascent_steps.push((moved, reverted));
    }

    // Merge lit probes that converged together.
    let mut merged: Vec<Vec3> = Vec::new();
    let mut members: Vec<Vec<Vec3>> = Vec::new();
    let mut index = SpatialSet::new(params.merge_distance);
    for c in &climbers {
        let p = c.position;
        match index.find_within(p, params.merge_distance) {
            Some(k) => members[k].push(p),
            None => {
                index.insert(p, merged.len());
                merged.push(p);
                members.push(vec![p]);
            }
        }
    }
    let lit_positions: Vec<Vec3> = merged
        .iter()
        .zip(&members)
        .map(|(first, group)| {
            let mean = group.iter().copied().sum::<Vec3>() / group.len() as f32;
            if group.len() > 1 && free.is_free(mean) {
                mean
            } else {
                *first
            }
        })
        .collect();

    let unlit_positions = if params.unlit_clusters > 0 && !unlit.is_empty() {
        k_means(&unlit, params.unlit_clusters, params.seed, free)
    } else {
        Vec::new()
    };
    let mut positions: Vec<[f32; 3]> = lit_positions.iter().map(|p| p.to_array()).collect();
    positions.extend(unlit_positions.iter().map(|p| p.to_array()));
    Ok(IrradiancePlacement {
        positions,
        lit: lit_positions.len(),
        unlit: unlit_positions.len(),
        iterations,
        spawn_merge_steps: Vec::new(),
        ascent_steps,
    })
}

/// k-means of `points` into `min(k, points.len())` centres: k-means++ seeding from `seed`, then
/// Lloyd iterations until no assignment changes (at most 100). A centre that is not free is
/// replaced by the member of its cluster nearest to it. Deterministic for a given seed.
pub fn k_means(points: &[Vec3], k: usize, seed: u64, free: &dyn FreeSpace) -> Vec<Vec3> {
    let k = k.min(points.len());
    if k == 0 {
        return Vec::new();
    }
    let mut rng = Pcg64::seed_from_u64(hash64(seed ^ 0x6b6d_6561_6e73));
    let mut centres = vec![points[rng.random_range(0..points.len())]];
    let mut nearest: Vec<f32> = points
        .iter()
        .map(|p| p.distance_squared(centres[0]))
        .collect();
    while centres.len() < k {
        let total: f64 = nearest.iter().map(|d| *d as f64).sum();
        let next = if total > 0.0 {
            let mut target = rng.random::<f64>() * total;
            let mut chosen = points.len() - 1;
            for (i, d) in nearest.iter().enumerate() {
                target -= *d as f64;
                if target < 0.0 {
                    chosen = i;
                    break;
                }
            }
            chosen
        } else {
            centres.len()
        };
        centres.push(points[next]);
        for (d, p) in nearest.iter_mut().zip(points) {
            *d = d.min(p.distance_squared(points[next]));
        }
    }
    let assign = |centres: &[Vec3]| -> Vec<usize> {
        points
            .iter()
            .map(|p| {
                (0..centres.len())
                    .min_by(|a, b| {
                        p.distance_squared(centres[*a])
                            .total_cmp(&p.distance_squared(centres[*b]))
                    })
                    .unwrap_or(0)
            })
            .collect()
    };
    let mut labels = assign(&centres);
    for _ in 0..100 {
        let mut sums = vec![Vec3::ZERO; k];
        let mut counts = vec![0usize; k];
        for (p, l) in points.iter().zip(&labels) {
            sums[*l] += *p;
            counts[*l] += 1;
        }
        for c in 0..k {
            if counts[c] > 0 {
                centres[c] = sums[c] / counts[c] as f32;
            }
        }
        let next = assign(&centres);
        if next == labels {
            break;
        }
        labels = next;
    }
    (0..k)
        .map(|c| {
            if free.is_free(centres[c]) {
                return centres[c];
            }
            points
                .iter()
                .zip(&labels)
                .filter(|(_, l)| **l == c)
                .map(|(p, _)| *p)
                .min_by(|a, b| {
                    a.distance_squared(centres[c])
                        .total_cmp(&b.distance_squared(centres[c]))
                })
                .unwrap_or(centres[c])
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn twenty_six_unit_directions_summing_to_zero() {
        let d = sample_directions();
        assert!(d.iter().all(|v| (v.length() - 1.0).abs() < 1e-6));
        assert!(d.iter().copied().sum::<Vec3>().length() < 1e-5);
    }

    #[test]
    fn contrast_is_relative_to_the_brightest() {
        let mut a = [0.0f32; 26];
        let mut b = [0.0f32; 26];
        assert_eq!(contrast(&a, &b), 0.0);
        a[0] = 10.0;
        b[0] = 8.0;
        a[1] = 0.01;
        assert!((contrast(&a, &b) - 0.2).abs() < 1e-6);
        b[0] = 10.0;
        assert!(contrast(&a, &b) < 0.01);
    }

    #[test]
    fn close_pairs_match_brute_force() {
        let points: Vec<Vec3> = (0..200)
            .map(|i| {
                let h = hash64(i);
                Vec3::new(
                    (h & 0xff) as f32 / 25.0,
                    ((h >> 8) & 0xff) as f32 / 25.0,
                    ((h >> 16) & 0xff) as f32 / 25.0,
                )
            })
            .collect();
        let mut brute = Vec::new();
        for i in 0..points.len() {
            for j in i + 1..points.len() {
                if points[i].distance(points[j]) < 1.3 {
                    brute.push((i, j));
                }
            }
        }
        assert_eq!(neighbour_pairs(&points, 1.3, usize::MAX), brute);
        // With k = 1 every point pairs with its nearest neighbour only.
        for (i, j) in neighbour_pairs(&points, 1.3, 1) {
            assert!(brute.contains(&(i, j)));
        }
    }
}
