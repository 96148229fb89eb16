//! Placement as the `probes place` command and the evaluation run it: a method (regular grid,
//! DDGI-relocated grid, SDF skeleton, medial axis, seed 002's irradiance-driven methods, or the
//! minimal cover), an optional optimiser (Gibbs sampling or descent), an optional budget or
//! coverage target, and the placement report measured on one visibility atlas.
//!
//! probe-place knows nothing of probe-capture: [`CaptureOracle`] wires probe-capture's shading
//! into probe-place's [`LightingOracle`] here, for the irradiance-driven methods.

use std::time::Instant;

use glam::Vec3;
use probe_capture::{Environment, Rng, Shader};
use probe_place::{
    Atlas, AtlasParams, BackfaceVote, ClassifyParams, CoverParams, DescentParams, GibbsParams,
    GradientAscentParams, IterationRecord, LightingOracle, MedialParams, PlacementReport, ProbeSet,
    RegularGrid, SdfParams, SpawnMergeParams, VoxelFreeSpace, VoxelGrid, classify_grid, descend,
    free_space_grid, gibbs, gradient_ascent, medial_candidates, minimal_cover, sdf_candidates,
    spawn_and_merge,
};
use probe_scene::{Ray, Scene};
use serde_json::json;

/// Why a placement failed: the stage and its error.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PlaceError {
    /// Candidate generation (grid, SDF, medial axis, voxels) failed.
    #[error("candidates: {0}")]
    Candidates(#[from] probe_place::CandidateError),
    /// The visibility atlas could not be built.
    #[error("visibility atlas: {0}")]
    Atlas(#[from] probe_place::AtlasError),
    /// The optimiser refused its input.
    #[error("optimisation: {0}")]
    Optimize(#[from] probe_place::OptimizeError),
    /// The minimal cover failed.
    #[error("minimal set: {0}")]
    Minimal(#[from] probe_place::MinimalSetError),
    /// An irradiance-driven method failed.
    #[error("irradiance placement: {0}")]
    Irradiance(#[from] probe_place::IrradianceError),
    /// The lighting could not be set up for the oracle.
    #[error("lighting oracle: {0}")]
    Shader(#[from] probe_capture::ShaderError),
    /// A parameter is out of range.
    #[error("invalid {parameter} {value}: {reason}")]
    Invalid {
        /// The parameter.
        parameter: &'static str,
        /// Its value.
        value: String,
        /// What is accepted.
        reason: &'static str,
    },
    /// The method produced no probe (a scene with no free space).
    #[error("{method} placed no probe in {scene}: the scene has no free space the method can use")]
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
    /// the atlas reward most are added until the set has `budget` probes.
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

/// The lighting oracle of seed 002's methods, from probe-capture's shading: irradiance on a
/// small surface by Monte-Carlo integration of the shaded radiance arriving over the
/// hemisphere (cosine-weighted, `samples` rays, seeded by the point).
pub struct CaptureOracle<'s> {
    shader: Shader<'s>,
    samples: u32,
    seed: u64,
}

impl<'s> CaptureOracle<'s> {
    /// An oracle over `scene` lit by its default environment (direct light plus `bounces`).
    ///
    /// # Errors
    /// [`PlaceError::Shader`] if the lighting is refused.
    pub fn new(
        scene: &'s Scene,
        bounces: u32,
        samples: u32,
        seed: u64,
    ) -> Result<Self, PlaceError> {
        Ok(Self {
            shader: Shader::new(scene, Environment::for_scene(scene), bounces)?,
            samples: samples.max(1),
            seed,
        })
    }
}

impl LightingOracle for CaptureOracle<'_> {
    fn irradiance(&self, point: Vec3) -> Vec3 {
        [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z]
            .into_iter()
            .map(|n| self.irradiance_towards(point, n))
            .fold(Vec3::ZERO, |best, e| {
                if e.dot(Vec3::ONE) > best.dot(Vec3::ONE) {
                    e
                } else {
                    best
                }
            })
    }

    fn irradiance_towards(&self, point: Vec3, normal: Vec3) -> Vec3 {
        let Some(normal) = normal.try_normalize() else {
            return Vec3::ZERO;
        };
        let key = [
            u64::from(point.x.to_bits()),
            u64::from(point.y.to_bits()),
            u64::from(point.z.to_bits()),
            u64::from(normal.x.to_bits()) ^ (u64::from(normal.y.to_bits()) << 32),
            u64::from(normal.z.to_bits()),
        ];
        let mut rng = Rng::for_key(self.seed, &key);
        let (tangent, bitangent) = normal.any_orthonormal_pair();
        let mut sum = Vec3::ZERO;
        for _ in 0..self.samples {
            // Cosine-weighted direction: the estimator of E = ∫ L cos dω is π · mean(L).
            let u = rng.next_vec2();
            let r = u.x.sqrt();
            let phi = std::f32::consts::TAU * u.y;
            let direction = tangent * (r * phi.cos())
                + bitangent * (r * phi.sin())
                + normal * (1.0 - u.x).max(0.0).sqrt();
            let (_, radiance) = self.shader.trace(&Ray::new(point, direction), &mut rng);
            sum += radiance;
        }
        sum * (std::f32::consts::PI / self.samples as f32)
    }
}

/// Adds candidates to `chosen`, each time the one that raises the atlas reward R(P) (best-probe
/// aggregation, default weights) the most, until `budget` probes or no candidate adds anything.
/// Greedy on the marginal gain `Σ_texels max(0, score − best score so far)`.
fn fill_to_budget(
    atlas: &Atlas<'_>,
    candidates: &[Vec3],
    chosen: Vec<Vec3>,
    budget: usize,
) -> Vec<Vec3> {
    use rayon::prelude::*;
    if chosen.len() >= budget {
        return chosen;
    }
    let weights = probe_place::RewardWeights::default();
    let scale = atlas.distance_scale();
    let mut best = vec![0.0f32; atlas.samples().len()];
    for views in atlas.views_of_probes(&chosen) {
        for v in views {
            let score = weights.score(&v, scale);
            let slot = &mut best[v.sample as usize];
            *slot = slot.max(score);
        }
    }
    let views = atlas.views_of_probes(candidates);
    let mut used: Vec<bool> = candidates.iter().map(|c| chosen.contains(c)).collect();
    let mut chosen = chosen;
    while chosen.len() < budget {
        let pick = views
            .par_iter()
            .enumerate()
            .filter(|(i, _)| !used[*i])
            .map(|(i, views)| {
                let gain: f64 = views
                    .iter()
                    .map(|v| {
                        f64::from((weights.score(v, scale) - best[v.sample as usize]).max(0.0))
                    })
                    .sum();
                (i, gain)
            })
            .reduce(
                || (usize::MAX, 0.0),
                |a, b| {
                    if b.1 > a.1 || (b.1 == a.1 && b.0 < a.0) {
                        b
                    } else {
                        a
                    }
                },
            );
        if pick.0 == usize::MAX || pick.1 <= 0.0 {
            break;
        }
        used[pick.0] = true;
        for v in &views[pick.0] {
            let score = weights.score(v, scale);
            let slot = &mut best[v.sample as usize];
            *slot = slot.max(score);
        }
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
///
/// # Errors
/// [`PlaceError`] naming the stage or the parameter.
pub fn place(scene: &Scene, options: &PlaceOptions) -> Result<Placement, PlaceError> {
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
        return Err(probe_place::CandidateError::EmptyScene {
            scene: scene.name().to_owned(),
        }
        .into());
    }
    let longest = scene.bounds().size().max_element();
    let spacing = positive(
        "reference spacing",
        options.reference_spacing.unwrap_or(longest / 25.0),
    )?;
    let step = positive("step", options.step.unwrap_or(longest / 100.0))?;

    // The free-space test (ray vote and SDF voxels must agree) and the atlas.
    let atlas_start = Instant::now();
    let voxels = VoxelGrid::build(scene, longest / 160.0)?;
    let free = (
        BackfaceVote::new(scene),
        VoxelFreeSpace::new(&voxels, scene.bounds()),
    );
    let pool = free_space_grid(&free, spacing);
    let atlas = Atlas::build(
        scene,
        &AtlasParams::for_texel_count(scene, options.atlas_texels),
        &pool,
    )?;
    let atlas_seconds = atlas_start.elapsed().as_secs_f64();

    let start = Instant::now();
    let mut full_grid = None;
    let mut parameters = serde_json::Map::new();
    let mut positions: Vec<Vec3> = match options.method {
        Method::Grid(dims) => {
            full_grid = Some(dims);
            parameters.insert("dims".into(), json!(dims));
            RegularGrid::over_scene(scene, dims)?.positions()
        }
        Method::GridRelocated(dims) => {
            parameters.insert("dims".into(), json!(dims));
            let classified = classify_grid(
                scene,
                &RegularGrid::over_scene(scene, dims)?,
                &ClassifyParams::default(),
            )?;
            parameters.insert("removed".into(), json!(classified.removed.len()));
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
            let oracle = CaptureOracle::new(scene, 1, 64, options.seed)?;
            let spacing = longest / 12.0;
            parameters.insert("spacing".into(), json!(spacing));
            let placed = if options.method == Method::SpawnMerge {
                spawn_and_merge(
                    scene,
                    &oracle,
                    &free,
                    &SpawnMergeParams::with_spacing(spacing),
                )?
            } else {
                let mut params = GradientAscentParams::with_spacing(spacing);
                params.seed = options.seed;
                gradient_ascent(scene, &oracle, &free, &params)?
            };
            parameters.insert("lit".into(), json!(placed.lit));
            parameters.insert("unlit".into(), json!(placed.unlit));
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
            parameters.insert("candidates".into(), json!(candidates.len()));
            let set = minimal_cover(
                &atlas,
                &free,
                &candidates,
                &CoverParams {
                    target_coverage: options.coverage,
                    budget: options.budget,
                    refine: None,
                },
            )?;
            match options.budget {
                // With a budget the set uses it: the cover first, then the candidates that
                // raise the reward most (better views of what is already seen).
                Some(budget) => fill_to_budget(&atlas, &candidates, set.positions(), budget),
                None => set.positions(),
            }
        }
    };
    // A budget or a coverage target below 1 keeps as few of the method's probes as reach it.
    if options.method != Method::Minimal
        && (options.budget.is_some_and(|b| b < positions.len()) || options.coverage < 1.0)
    {
        let set = minimal_cover(
            &atlas,
            &free,
            &positions,
            &CoverParams {
                target_coverage: options.coverage,
                budget: options.budget,
                refine: None,
            },
        )?;
        positions = set.positions();
        full_grid = None;
    }
    let mut history = None;
    if let Some(optimizer) = options.optimize {
        parameters.insert("step".into(), json!(step));
        parameters.insert("iterations".into(), json!(options.iterations));
        let result = match optimizer {
            Optimizer::Gibbs => gibbs(
                &atlas,
                &free,
                &positions,
                &GibbsParams {
                    max_iterations: options.iterations,
                    seed: options.seed,
                    ..GibbsParams::with_step(step)
                },
            )?,
            Optimizer::Descent => descend(
                &atlas,
                &free,
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
    let seconds = start.elapsed().as_secs_f64();
    let mut name = options.method.name();
    match options.optimize {
        Some(Optimizer::Gibbs) => name.push_str("+gibbs"),
        Some(Optimizer::Descent) => name.push_str("+descent"),
        None => {}
    }
    if let Some(budget) = options.budget {
        name.push_str(&format!("@{budget}"));
        parameters.insert("budget".into(), json!(budget));
    }
    if options.coverage < 1.0 {
        parameters.insert("coverage_target".into(), json!(options.coverage));
    }
    parameters.insert("seed".into(), json!(options.seed));
    if positions.is_empty() {
        return Err(PlaceError::NoProbes {
            method: name,
            scene: scene.name().to_owned(),
        });
    }
    let report = PlacementReport::measure(
        &name,
        serde_json::Value::Object(parameters.clone()),
        &atlas,
        &free,
        &positions,
        seconds,
    );
    Ok(Placement {
        probes: ProbeSet::new(positions).with_method(name, parameters),
        report,
        history,
        full_grid,
        atlas_seconds,
    })
}
