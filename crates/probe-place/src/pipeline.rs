//! Placement end to end, as the `probes place` command and the evaluation run it: a method
//! (regular grid, DDGI-relocated grid, SDF skeleton, medial axis, seed 002's
//! irradiance-driven methods, or the minimal cover), an optional optimiser (Gibbs sampling or
//! descent), an optional budget or coverage target, and the placement report measured on one
//! visibility atlas ([`place`]).
//!
//! The irradiance-driven methods ([`Method::SpawnMerge`], [`Method::GradientAscent`]) need
//! light: [`place`] takes a [`LightingOracle`] for them (probe-eval's `CaptureOracle` wires
//! probe-capture's shading into it; an engine can pass its own lighting).
//!
//! ```
//! use probe_place::pipeline::{Method, Optimizer, PlaceOptions, place};
//! use probe_scene::Scene;
//!
//! let scene = Scene::builtin("cornell")?;
//! let mut options = PlaceOptions::new(Method::Sdf);
//! options.optimize = Some(Optimizer::Gibbs);
//! options.iterations = 3;
//! options.atlas_texels = 2000;
//! let placed = place(&scene, &options, None)?;
//! assert!(!placed.probes.is_empty());
//! assert_eq!(placed.probes.method.name(), "sdf+gibbs");
//! assert_eq!(placed.report.probes_inside_geometry, 0);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use std::time::Instant;

use crate::atlas::FreeSpace;
pub use crate::provenance::PlaceProvenance;
use crate::provenance::PlacementMethod;
use crate::viewers::view_samples_per_view;
use crate::{
    ProbeSet,
    atlas::{Atlas, AtlasParams, BackfaceVote, PlacementReport, VoxelFreeSpace, free_space_grid},
    candidates::{
        ClassifyParams, MedialParams, RegularGrid, SdfParams, VoxelGrid, classify_grid,
        medial_candidates, sdf_candidates,
    },
    irradiance::{
        GradientAscentParams, LightingOracle, SpawnMergeParams, gradient_ascent, spawn_and_merge,
    },
    minimal::{CoverParams, complete_coverage, minimal_cover},
    optimize::{DescentParams, GibbsParams, IterationRecord, descend, gibbs},
    region::{Region, RegionError, RegionFreeSpace},
};
use glam::Vec3;
use probe_scene::{Camera, Scene};

/// Why a placement failed: the stage and its error.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PlaceError {
    /// Candidate generation (grid, SDF, medial axis, voxels) failed.
    #[error("candidates: {0}")]
    Candidates(#[from] crate::candidates::CandidateError),
    /// The visibility atlas could not be built.
    #[error("visibility atlas: {0}")]
    Atlas(#[from] crate::atlas::AtlasError),
    /// The optimiser refused its input.
    #[error("optimisation: {0}")]
    Optimize(#[from] crate::optimize::OptimizeError),
    /// The minimal cover failed.
    #[error("minimal set: {0}")]
    Minimal(#[from] crate::minimal::MinimalSetError),
    /// An irradiance-driven method failed.
    #[error("irradiance placement: {0}")]
    Irradiance(#[from] crate::irradiance::IrradianceError),
    /// The region of interest was refused (outside the scene, no free space inside). Fix: as
    /// the [`RegionError`] says.
    #[error("region: {0}")]
    Region(#[from] RegionError),
    /// An irradiance-driven method was asked for without a lighting oracle. Fix: pass a
    /// [`LightingOracle`] to [`place`] (probe-eval's `CaptureOracle` shades the scene with
    /// probe-capture), or choose a geometric method.
    #[error("{method} needs a lighting oracle: pass one to place(), or choose a geometric method")]
    NoOracle {
        /// The method.
        method: String,
    },
    /// A parameter is out of range. Fix: give a value in the range named.
    #[error("invalid {parameter} {value}: {reason}")]
    Invalid {
        /// The parameter.
        parameter: &'static str,
        /// Its value.
        value: String,
        /// What is accepted.
        reason: &'static str,
    },
    /// The method produced no probe (a scene with no free space, or a region where the
    /// method's probes do not fall). Fix: check the scene has room inside its bounds, use a
    /// grid, or set [`PlaceOptions::complete`] to fill a region from its free points.
    #[error(
        "{method} placed no probe in {scene}: the scene (or the region) has no free space the method can use; `complete` fills a region from its free points"
    )]
    NoProbes {
        /// The method.
        method: String,
        /// The scene.
        scene: String,
    },
}

/// A placement method.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// Probes at the cell centres of an NX×NY×NZ division of the scene bounds.
    Grid([u32; 3]),
    /// The same grid with DDGI-style classification and relocation.
    GridRelocated([u32; 3]),
    /// Seed 000 Alg. 1: the SDF skeleton's clusters.
    Sdf,
    /// Seed 000 §3.1.2: clusters of shrinking-ball medial points.
    Medial,
    /// Seed 002: spawn and merge driven by irradiance.
    SpawnMerge,
    /// Seed 002: irradiance-gradient ascent with step reverts.
    GradientAscent,
    /// The fewest probes from a dense pool (free-space grid, SDF and medial candidates) that
    /// reach the coverage target within the budget.
    Minimal,
}

impl Method {
    /// The method's name in reports (`grid-4x2x4`, `sdf`, ...).
    pub fn name(&self) -> String {
        match self {
            Method::Grid([x, y, z]) => format!("grid-{x}x{y}x{z}"),
            Method::GridRelocated([x, y, z]) => format!("grid-relocated-{x}x{y}x{z}"),
            Method::Sdf => "sdf".into(),
            Method::Medial => "medial".into(),
            Method::SpawnMerge => "spawn-merge".into(),
            Method::GradientAscent => "gradient-ascent".into(),
            Method::Minimal => "minimal".into(),
        }
    }

    /// Whether the method is driven by irradiance and so needs a [`LightingOracle`].
    pub fn needs_lighting(&self) -> bool {
        matches!(self, Method::SpawnMerge | Method::GradientAscent)
    }
}

/// An optimiser run after the method.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Optimizer {
    /// Gibbs sampling with importance-sampled directions (seed 000 Alg. 2).
    Gibbs,
    /// Gradient descent over the support cube (seed 000 eq. 3.3).
    Descent,
}

/// What to place and how.
#[derive(Clone, Debug, PartialEq)]
pub struct PlaceOptions {
    /// The method.
    pub method: Method,
    /// An optimiser to run on the method's probes.
    pub optimize: Option<Optimizer>,
    /// The most probes to keep (chosen greedily by coverage from the method's probes). For
    /// [`Method::Minimal`] the budget is also used up: after the cover, candidates that raise
    /// the texels' best read score most are added until the set has `budget` probes
    /// ([`fill_to_budget`]).
    pub budget: Option<usize>,
    /// The share of atlas texels to cover, in (0, 1]; below 1 the method's probes are reduced
    /// to as few as reach it.
    pub coverage: f32,
    /// Seed of every random choice.
    pub seed: u64,
    /// Optimiser iteration cap.
    pub iterations: usize,
    /// Atlas texels (equal-area surface samples).
    pub atlas_texels: usize,
    /// Spacing of the free-space reference grid (metres); default 1/25 of the longest side.
    pub reference_spacing: Option<f32>,
    /// Optimiser support-cube half edge (metres); default 1/100 of the longest side.
    pub step: Option<f32>,
    /// Where viewers go: probes are placed only inside, and the atlas keeps only the
    /// surfaces a free point inside can see (so coverage counts only those). `None`: the whole
    /// scene. Grids divide the region's bounding box (their probes outside every box of a
    /// union are dropped); the longest side above is the region's.
    pub region: Option<Region>,
    /// After the method, the cut and the optimiser: add reference points (the atlas's free
    /// points) that see the most unseen texels until every texel is seen
    /// ([`complete_coverage`]), within the budget if there is one. Full coverage is then
    /// reached by construction; the report's `unreachable_texels` counts the surfaces no free
    /// point (of the region) sees at a non-grazing angle.
    pub complete: bool,
    /// A view set: when given, the atlas's texels are the points these cameras see directly
    /// and in mirror reflection ([`view_samples`](crate::viewers::view_samples), about `atlas_texels` in all) instead of
    /// equal-area samples, so surfaces weigh by how much the viewers see them, and coverage
    /// is the share of what they see that some probe sees at a non-grazing angle — the cheap
    /// proxy of their glossy error. With [`Method::Minimal`] this gives the error-driven sets:
    /// greedy additions of the candidate that most lowers the proxy, then pruning of every
    /// probe whose removal keeps the target (`coverage` = 1 − target error).
    pub viewers: Option<Vec<Camera>>,
    /// With `viewers` and `coverage` below 1: the target holds for what **each** view sees,
    /// not only for all views together ([`CoverParams::each_view`]). A viewpoint the set did
    /// not learn from then meets it too, within the spread between views; the set needs
    /// more probes.
    pub each_view: bool,
}

impl PlaceOptions {
    /// Defaults for `method`: no optimiser, full coverage, seed 0, 100 iterations, 20,000
    /// atlas texels.
    pub fn new(method: Method) -> PlaceOptions {
        PlaceOptions {
            method,
            optimize: None,
            budget: None,
            coverage: 1.0,
            seed: 0,
            iterations: 100,
            atlas_texels: 20_000,
            reference_spacing: None,
            step: None,
            region: None,
            complete: false,
            viewers: None,
            each_view: false,
        }
    }
}

/// A placement and its report.
#[derive(Clone, Debug)]
pub struct Placement {
    /// The probes, with method and parameters.
    pub probes: ProbeSet,
    /// Coverage, view cosines, probes inside geometry, time.
    pub report: PlacementReport,
    /// The optimiser's per-iteration history, if one ran.
    pub history: Option<Vec<IterationRecord>>,
    /// The grid's dimensions when the probes are a full regular grid (cage indexing applies).
    pub full_grid: Option<[u32; 3]>,
    /// Seconds to build the free-space test and the atlas (not part of the method's time).
    pub atlas_seconds: f64,
}

/// The voxels of the free-space test placement uses with the ray vote (both must agree that
/// a point is free): 1/160 of the scene's longest side. The view proxy
/// ([`crate::viewers::ViewProxy`]) uses the same test, so that it counts the texels the
/// placement's atlas counts.
pub(crate) fn free_space_voxels(scene: &Scene) -> Result<VoxelGrid, PlaceError> {
    Ok(VoxelGrid::build(
        scene,
        scene.bounds().size().max_element() / 160.0,
    )?)
}

/// Adds candidates to `chosen`, each time the one that raises the texels' best
/// [`read_score`](crate::atlas::read_score) the most (reach [`READ_REACH`](crate::atlas::READ_REACH)
/// of the atlas's distance scale), until `budget` probes or no candidate adds anything. Greedy
/// on the marginal gain `Σ_texels max(0, score − best score so far)`.
///
/// The score is what the tracer reads a hit by, not the atlas reward R(P), whose distance term
/// pushes probes away from what they see: on the built-in Cornell box the view-set error of
/// `minimal+views@N` fell from 4.19e-4 / 3.11e-4 / 3.18e-4 to 2.62e-4 / 1.81e-4 / 1.46e-4 at 8 /
/// 27 / 64 probes, below the grids' 3.68e-4 / 2.06e-4 / 1.61e-4 (BENCHMARKS.md, "Budgets spent on
/// probes that read well").
///
/// [`place`] uses it for [`Method::Minimal`] with a budget. Candidates already in `chosen` are
/// not added twice; the result keeps `chosen` first, in its order.
pub fn fill_to_budget(
    atlas: &Atlas<'_>,
    candidates: &[Vec3],
    chosen: Vec<Vec3>,
    budget: usize,
) -> Vec<Vec3> {
    #[cfg(feature = "parallel")]
    use rayon::prelude::*;
    if chosen.len() >= budget {
        return chosen;
    }
    let reach = crate::atlas::READ_REACH * atlas.distance_scale();
    let score = |view: &crate::atlas::ProbeView| crate::atlas::read_score(view, reach);
    // Each texel's best score so far, raised by a new probe's views.
    let raise = |best: &mut [f32], views: &[crate::atlas::ProbeView]| {
        for v in views {
            let slot = &mut best[v.sample as usize];
            *slot = slot.max(score(v));
        }
    };
    let mut best = vec![0.0f32; atlas.samples().len()];
    for views in atlas.views_of_probes(&chosen) {
        raise(&mut best, &views);
    }
    let views = atlas.views_of_probes(candidates);
    let mut used: Vec<bool> = candidates.iter().map(|c| chosen.contains(c)).collect();
    let mut chosen = chosen;
    while chosen.len() < budget {
        let gain = |(i, views): (usize, &Vec<crate::atlas::ProbeView>)| -> (usize, f64) {
            let gain: f64 = views
                .iter()
                .map(|v| f64::from((score(v) - best[v.sample as usize]).max(0.0)))
                .sum();
            (i, gain)
        };
        // The largest gain, the lowest index among equals: the same pick in both builds.
        let better = |a: (usize, f64), b: (usize, f64)| {
            if b.1 > a.1 || (b.1 == a.1 && b.0 < a.0) {
                b
            } else {
                a
            }
        };
        let none = (usize::MAX, 0.0);
        let unused = |(i, _): &(usize, &Vec<crate::atlas::ProbeView>)| !used[*i];
        #[cfg(feature = "parallel")]
        let pick = views
            .par_iter()
            .enumerate()
            .filter(unused)
            .map(gain)
            .reduce(|| none, better);
        #[cfg(not(feature = "parallel"))]
        let pick = views
            .iter()
            .enumerate()
            .filter(unused)
            .map(gain)
            .fold(none, better);
        if pick.0 == usize::MAX || pick.1 <= 0.0 {
            break;
        }
        used[pick.0] = true;
        raise(&mut best, &views[pick.0]);
        chosen.push(candidates[pick.0]);
    }
    chosen
}

fn positive(parameter: &'static str, value: f32) -> Result<f32, PlaceError> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(PlaceError::Invalid {
            parameter,
            value: value.to_string(),
            reason: "must be a finite number > 0",
        })
    }
}

/// Places probes in `scene` as `options` say, and measures the result on a visibility atlas.
/// `lighting` drives the irradiance-driven methods and is not used by the others.
///
/// # Errors
/// [`PlaceError`] naming the stage or the parameter; [`PlaceError::NoOracle`] when the method
/// [needs lighting](Method::needs_lighting) and `lighting` is `None`.
pub fn place(
    scene: &Scene,
    options: &PlaceOptions,
    lighting: Option<&dyn LightingOracle>,
) -> Result<Placement, PlaceError> {
    if !(options.coverage > 0.0 && options.coverage <= 1.0) {
        return Err(PlaceError::Invalid {
            parameter: "coverage",
            value: options.coverage.to_string(),
            reason: "must lie in (0, 1]",
        });
    }
    if options.budget == Some(0) {
        return Err(PlaceError::Invalid {
            parameter: "budget",
            value: "0".into(),
            reason: "must be at least 1 probe",
        });
    }
    if scene.triangles().is_empty() {
        return Err(crate::candidates::CandidateError::EmptyScene {
            scene: scene.name().to_owned(),
        }
        .into());
    }
    let region = match &options.region {
        Some(region) => Some(region.within(scene.bounds())?),
        None => None,
    };
    let scene_longest = scene.bounds().size().max_element();
    let longest = region
        .as_ref()
        .map_or(scene_longest, |r| r.bounds().size().max_element());
    let spacing = positive(
        "reference spacing",
        options.reference_spacing.unwrap_or(longest / 25.0),
    )?;
    let step = positive("step", options.step.unwrap_or(longest / 100.0))?;

    // The free-space test (ray vote and SDF voxels must agree) and the atlas.
    let atlas_start = Instant::now();
    let voxels = free_space_voxels(scene)?;
    let scene_free = (
        BackfaceVote::new(scene),
        VoxelFreeSpace::new(&voxels, scene.bounds()),
    );
    let region_free = RegionFreeSpace::new(&scene_free, region.as_ref());
    let free: &dyn FreeSpace = &region_free;
    let pool = free_space_grid(free, spacing);
    if region.is_some() && pool.is_empty() {
        let size = free.bounds().size() / spacing;
        return Err(RegionError::NoFreeSpace {
            points: (size.round().max(Vec3::ONE)).element_product() as usize,
            spacing,
        }
        .into());
    }
    let inside = |p: &Vec3| region.as_ref().is_none_or(|r| r.contains(*p));
    let grid_over = |dims| match &region {
        Some(r) => RegularGrid::new(r.bounds(), dims),
        None => RegularGrid::over_scene(scene, dims),
    };
    let atlas_params = AtlasParams::for_texel_count(scene, options.atlas_texels);
    let atlas = match &options.viewers {
        Some(cameras) => {
            if cameras.is_empty() {
                return Err(PlaceError::Invalid {
                    parameter: "viewers",
                    value: "[]".into(),
                    reason: "give at least one camera, or None for equal-area texels",
                });
            }
            let per_view = (options.atlas_texels / (2 * cameras.len())).max(16);
            let samples = view_samples_per_view(scene, cameras, per_view);
            Atlas::from_view_samples(scene, &atlas_params, samples, &pool)?
        }
        None => Atlas::build(scene, &atlas_params, &pool)?,
    };
    let atlas_seconds = atlas_start.elapsed().as_secs_f64();

    let start = Instant::now();
    let mut full_grid = None;
    let mut run = PlaceProvenance::new(options.method, options.seed);
    let mut positions: Vec<Vec3> = match options.method {
        Method::Grid(dims) => {
            full_grid = Some(dims);
            grid_over(dims)?.positions()
        }
        Method::GridRelocated(dims) => {
            let classified = classify_grid(scene, &grid_over(dims)?, &ClassifyParams::default())?;
            run.removed = Some(classified.removed.len());
            if classified.removed.is_empty() {
                full_grid = Some(dims);
            }
            classified.positions
        }
        Method::Sdf => {
            sdf_candidates(scene, &SdfParams::for_scene(scene))?
                .probes
                .positions
        }
        Method::Medial => {
            let mut params = MedialParams::for_scene(scene);
            params.seed = options.seed;
            medial_candidates(scene, &params)?.probes.positions
        }
        Method::SpawnMerge | Method::GradientAscent => {
            let oracle = lighting.ok_or_else(|| PlaceError::NoOracle {
                method: options.method.name(),
            })?;
            let spacing = longest / 12.0;
            run.spacing = Some(spacing);
            let placed = if options.method == Method::SpawnMerge {
                spawn_and_merge(
                    scene,
                    oracle,
                    free,
                    &SpawnMergeParams::with_spacing(spacing),
                )?
            } else {
                let mut params = GradientAscentParams::with_spacing(spacing);
                params.seed = options.seed;
                gradient_ascent(scene, oracle, free, &params)?
            };
            run.lit = Some(placed.lit);
            run.unlit = Some(placed.unlit);
            placed.positions()
        }
        Method::Minimal => {
            let mut candidates = pool.clone();
            candidates.extend(
                sdf_candidates(scene, &SdfParams::for_scene(scene))?
                    .probes
                    .positions,
            );
            let mut medial = MedialParams::for_scene(scene);
            medial.seed = options.seed;
            candidates.extend(medial_candidates(scene, &medial)?.probes.positions);
            candidates.retain(inside);
            run.candidates = Some(candidates.len());
            let set = minimal_cover(
                &atlas,
                free,
                &candidates,
                &CoverParams {
                    target_coverage: options.coverage,
                    budget: options.budget,
                    refine: None,
                    each_view: options.each_view,
                },
            )?;
            match options.budget {
                // With a budget the set uses it: the cover first, then the candidates that
                // raise the read score most (closer, squarer views of what is already seen).
                Some(budget) => fill_to_budget(&atlas, &candidates, set.positions(), budget),
                None => set.positions(),
            }
        }
    };
    // Inside the region only (a grid's probes outside a union's boxes, the skeleton's and the
    // medial axis's elsewhere in the scene).
    let before = positions.len();
    positions.retain(inside);
    if positions.len() != before {
        full_grid = None;
    }
    // A budget or a coverage target below 1 keeps as few of the method's probes as reach it.
    if !positions.is_empty()
        && options.method != Method::Minimal
        && (options.budget.is_some_and(|b| b < positions.len()) || options.coverage < 1.0)
    {
        let set = minimal_cover(
            &atlas,
            free,
            &positions,
            &CoverParams {
                target_coverage: options.coverage,
                budget: options.budget,
                refine: None,
                each_view: options.each_view,
            },
        )?;
        positions = set.positions();
        full_grid = None;
    }
    let mut history = None;
    if let Some(optimizer) = options.optimize.filter(|_| !positions.is_empty()) {
        run.optimizer = Some((optimizer, step, options.iterations));
        let result = match optimizer {
            Optimizer::Gibbs => gibbs(
                &atlas,
                free,
                &positions,
                &GibbsParams {
                    max_iterations: options.iterations,
                    seed: options.seed,
                    ..GibbsParams::with_step(step)
                },
            )?,
            Optimizer::Descent => descend(
                &atlas,
                free,
                &positions,
                &DescentParams {
                    max_iterations: options.iterations,
                    ..DescentParams::with_step(step)
                },
            )?,
        };
        positions = result.positions();
        history = Some(result.history);
        full_grid = None;
    }
    if options.complete {
        let completion = complete_coverage(&atlas, &pool, positions, options.budget);
        positions = completion.positions;
        if completion.added > 0 {
            full_grid = None;
        }
        run.completed = Some(completion.added);
    }
    let seconds = start.elapsed().as_secs_f64();
    run.budget = options.budget;
    run.region = region.clone();
    run.viewers = options.viewers.as_ref().map(Vec::len);
    if options.coverage < 1.0 {
        run.coverage_target = Some(options.coverage);
        run.each_view = options.each_view && options.viewers.is_some();
    }
    let method = PlacementMethod::Placed(run);
    if positions.is_empty() {
        return Err(PlaceError::NoProbes {
            method: method.name(),
            scene: scene.name().to_owned(),
        });
    }
    let report = PlacementReport::measure(method.clone(), &atlas, free, &positions, seconds);
    Ok(Placement {
        probes: ProbeSet::new(positions).with_method(method),
        report,
        history,
        full_grid,
        atlas_seconds,
    })
}
