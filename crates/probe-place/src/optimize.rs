//! Probe position optimisation over the visibility atlas (seed 000 §3.2.2–3.2.4): gradient
//! descent over the 8-probe support cube (eq. 3.3) and Gibbs sampling with importance-sampled
//! directions and acceptance `R_new / R_old` (Alg. 2).

use crate::atlas::{Atlas, AtlasState, FreeSpace, ProbeView, RewardWeights};
use crate::par::*;
use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use serde::{Deserialize, Serialize};

/// Why an optimisation could not run.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum OptimizeError {
    /// No probe was given.
    ///
    /// Fix: pass at least one probe position (candidates from a grid, the SDF skeleton or the
    /// medial axis).
    #[error("no probes to optimise")]
    NoProbes,
    /// A probe position is not finite.
    ///
    /// Fix: remove or repair the probe named by `index`.
    #[error("probe {index} has a non-finite position {position}")]
    NonFiniteProbe {
        /// Index into the probe list.
        index: usize,
        /// The position given.
        position: Vec3,
    },
    /// A parameter is out of its range or not finite (weights must be finite and ≥ 0, not
    /// both 0; the step must be finite and > 0; the iteration cap must be ≥ 1).
    ///
    /// Fix: pass a value in the range named in the message.
    #[error("optimisation parameter `{name}` = {value} is invalid: expected {expected}")]
    InvalidParameter {
        /// The parameter's name (`w1`, `w2`, `weights`, `step`, `max_iterations`,
        /// `acceptance_exponent`).
        name: &'static str,
        /// The value given.
        value: f64,
        /// The valid range.
        expected: &'static str,
    },
}

/// Gradient descent over the support cube (seed 000 §3.2.2).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct DescentParams {
    /// The support cube's half edge `h` in metres: the eight support probes sit at
    /// `p + h·(±1, ±1, ±1)`, so the step `γ` of eq. 3.3 is `h·√3`.
    pub step: f32,
    /// The iteration cap (one iteration moves every probe once).
    pub max_iterations: usize,
    /// The reward's weights.
    pub weights: RewardWeights,
}

impl DescentParams {
    /// Default weights and 100 iterations with the given support-cube half edge.
    pub fn with_step(step: f32) -> DescentParams {
        DescentParams {
            step,
            max_iterations: 100,
            weights: RewardWeights::default(),
        }
    }
}

/// Gibbs sampling with importance-sampled directions (seed 000 §3.2.3–3.2.4, Alg. 2).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct GibbsParams {
    /// The support cube's half edge `h` in metres (support probes at `p + h·(±1, ±1, ±1)`);
    /// new samples fall inside this cube.
    pub step: f32,
    /// The iteration cap (one iteration visits every probe once, as one pass of Alg. 2's
    /// outer loop).
    pub max_iterations: usize,
    /// The reward's weights.
    pub weights: RewardWeights,
    /// Seeds the direction sampling and the acceptance test.
    pub seed: u64,
    /// `β` in the acceptance probability `(R_new / R_old)^β`. Seed 000 uses `β = 1`, the
    /// default; larger values make the sampler greedier (a move that loses 1 % of the reward is
    /// accepted with probability `0.99^β`).
    pub acceptance_exponent: f32,
    /// The eight support probes, which only shape the sampling density, are evaluated on every
    /// `support_stride`-th texel (a different subset for each probe and iteration); the
    /// sampled position is always evaluated on all texels. 1 evaluates the support probes
    /// exactly; the default 4 makes an iteration about 3× cheaper (3 visibility queries' worth
    /// per probe instead of 9).
    pub support_stride: usize,
}

impl GibbsParams {
    /// Default weights, 100 iterations, seed 0, `β = 1` and a support stride of 4 with the given
    /// support-cube half edge.
    pub fn with_step(step: f32) -> GibbsParams {
        GibbsParams {
            step,
            max_iterations: 100,
            weights: RewardWeights::default(),
            seed: 0,
            acceptance_exponent: 1.0,
            support_stride: 4,
        }
    }
}

/// The state after one iteration, for charts.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct IterationRecord {
    /// The iteration (0: the starting positions).
    pub iteration: usize,
    /// `R(P)` after the iteration (mean texel fitness).
    pub reward: f64,
    /// The share of texels seen after the iteration.
    pub coverage: f64,
    /// Moves made in the iteration.
    pub moves: usize,
    /// Proposals rejected (by the acceptance test, or because the new position was not free).
    pub rejected: usize,
    /// The summed length of the moves, in metres.
    pub moved_distance: f32,
    /// Every probe's position after the iteration.
    pub positions: Vec<[f32; 3]>,
}

/// The result of an optimisation.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Optimized {
    /// The best probe set met on the way (most texels covered, then highest reward); equal to
    /// the last one when coverage became full.
    pub positions: Vec<[f32; 3]>,
    /// `R(P)` of `positions`.
    pub reward: f64,
    /// The coverage of `positions`.
    pub coverage: f64,
    /// Whether `positions` covers every texel (the stop criterion).
    pub fully_covered: bool,
    /// The iterations run.
    pub iterations: usize,
    /// One record per iteration, starting with iteration 0 (the input).
    pub history: Vec<IterationRecord>,
}

impl Optimized {
    /// The best positions as `Vec3`s.
    pub fn positions(&self) -> Vec<Vec3> {
        self.positions
            .iter()
            .map(|p| Vec3::from_array(*p))
            .collect()
    }
}

fn check(
    probes: &[Vec3],
    step: f32,
    max_iterations: usize,
    weights: &RewardWeights,
) -> Result<(), OptimizeError> {
    if probes.is_empty() {
        return Err(OptimizeError::NoProbes);
    }
    if let Some(index) = probes.iter().position(|p| !p.is_finite()) {
        return Err(OptimizeError::NonFiniteProbe {
            index,
            position: probes[index],
        });
    }
    if let Err((name, value)) = weights.check() {
        return Err(OptimizeError::InvalidParameter {
            name,
            value: value as f64,
            expected: "finite weights >= 0, not both 0",
        });
    }
    if !(step.is_finite() && step > 0.0) {
        return Err(OptimizeError::InvalidParameter {
            name: "step",
            value: step as f64,
            expected: "a finite half edge > 0 in metres",
        });
    }
    if max_iterations == 0 {
        return Err(OptimizeError::InvalidParameter {
            name: "max_iterations",
            value: 0.0,
            expected: "at least 1",
        });
    }
    Ok(())
}

/// The eight support probes around `p`: corner `s` has `x` from bit 0 of `s`, `y` from bit 1
/// and `z` from bit 2 (bit set: `+h`).
fn support_cube(p: Vec3, h: f32) -> [Vec3; 8] {
    std::array::from_fn(|s| {
        let sign = |bit: usize| if s & (1 << bit) != 0 { h } else { -h };
        p + Vec3::new(sign(0), sign(1), sign(2))
    })
}

/// Keeps the best state met: most covered texels, then highest reward.
struct Best {
    positions: Vec<Vec3>,
    covered: usize,
    reward: f64,
}

impl Best {
    fn new(state: &AtlasState<'_, '_>) -> Best {
        Best {
            positions: state.positions().to_vec(),
            covered: state.covered(),
            reward: state.reward(),
        }
    }

    fn offer(&mut self, state: &AtlasState<'_, '_>) {
        if (state.covered(), state.reward()) > (self.covered, self.reward) {
            *self = Best::new(state);
        }
    }

    fn finish(self, texels: usize, iterations: usize, history: Vec<IterationRecord>) -> Optimized {
        Optimized {
            positions: self.positions.iter().map(|p| p.to_array()).collect(),
            reward: self.reward,
            coverage: self.covered as f64 / texels as f64,
            fully_covered: self.covered == texels,
            iterations,
            history,
        }
    }
}

fn record(
    state: &AtlasState<'_, '_>,
    iteration: usize,
    moves: usize,
    rejected: usize,
    moved_distance: f32,
) -> IterationRecord {
    IterationRecord {
        iteration,
        reward: state.reward(),
        coverage: state.coverage(),
        moves,
        rejected,
        moved_distance,
        positions: state.positions().iter().map(|p| p.to_array()).collect(),
    }
}

/// Gradient descent over the support cube, as seed 000 §3.2.2 describes it: in every
/// iteration each probe evaluates the reward with itself replaced by each of its eight support
/// probes `p + h·(±1, ±1, ±1)` (those in free space), against the current positions of the
/// others, and then **all probes move at once** to their best support probe
/// (`p' = p + γ ∇R`, eq. 3.3, with the fixed step `γ = h√3`).
///
/// A fixed-step descent has no notion of standing still: at a local maximum the best support
/// probe is still one step away, and from there the best one is the way back, so probes end
/// up moving back and forth between two positions — the behaviour seed 000 reports and that
/// [`gibbs`] escapes. Stops when every texel is covered or after `max_iterations`; returns
/// the best set met on the way.
pub fn descend(
    atlas: &Atlas<'_>,
    free: &dyn FreeSpace,
    probes: &[Vec3],
    params: &DescentParams,
) -> Result<Optimized, OptimizeError> {
    check(probes, params.step, params.max_iterations, &params.weights)?;
    let texels = atlas.samples().len();
    let mut state = AtlasState::new(atlas, params.weights, probes);
    let mut best = Best::new(&state);
    let mut history = vec![record(&state, 0, 0, 0, 0.0)];
    let mut iterations = 0;
    while !state.is_fully_covered() && iterations < params.max_iterations {
        iterations += 1;
        // Every probe picks its best support probe against the current positions (Jacobi).
        let choices: Vec<Option<(Vec3, Vec<ProbeView>)>> = (0..probes.len())
            .into_par_iter()
            .map(|k| {
                let corners = support_cube(state.positions()[k], params.step);
                let mut choice: Option<(f64, Vec3, Vec<ProbeView>)> = None;
                for corner in corners {
                    if !free.is_free(corner) {
                        continue;
                    }
                    let views = atlas.probe_views(corner);
                    let reward = state.evaluate_move(k, &views).reward;
                    if choice.as_ref().is_none_or(|(r, _, _)| reward > *r) {
                        choice = Some((reward, corner, views));
                    }
                }
                choice.map(|(_, corner, views)| (corner, views))
            })
            .collect();
        let (mut moves, mut rejected, mut moved) = (0, 0, 0.0f32);
        for (k, choice) in choices.into_iter().enumerate() {
            match choice {
                Some((position, views)) => {
                    moved += position.distance(state.positions()[k]);
                    state.move_probe(k, position, views);
                    moves += 1;
                }
                None => rejected += 1,
            }
        }
        best.offer(&state);
        history.push(record(&state, iterations, moves, rejected, moved));
    }
    Ok(best.finish(texels, iterations, history))
}

/// Gibbs sampling with importance-sampled directions (seed 000 Alg. 2, §3.2.3–3.2.4).
///
/// Each iteration visits every probe `k` in turn:
/// 1. The eight support probes `p_k + h·(±1, ±1, ±1)` are evaluated (on a subset of texels,
///    see [`GibbsParams::support_stride`]). Their fitness is the reward with `p_k` replaced by
///    the support probe, *minus the worst support probe's*: the reward itself barely differs
///    between the eight (one probe among many moves), so using it as the sampling density
///    would make the sampling nearly uniform. Support probes outside free space get fitness 0.
/// 2. A new position is drawn inside the cube as in §3.2.4: along each of the four x edges a
///    point is drawn from the linear density through the fitness of the edge's two ends (by
///    inverting its CDF); between the pairs of those points sharing a z, along y, with the
///    linearly interpolated fitness; and between the remaining two, along z.
/// 3. The position is rejected if it is not free; otherwise it is accepted with probability
///    `min(1, (R_new / R_old)^β)`.
///
/// Stops as soon as every texel is covered, or after `max_iterations`; returns the best set
/// met on the way (most texels covered, then highest reward). The same inputs and seed give
/// the same result.
pub fn gibbs(
    atlas: &Atlas<'_>,
    free: &dyn FreeSpace,
    probes: &[Vec3],
    params: &GibbsParams,
) -> Result<Optimized, OptimizeError> {
    check(probes, params.step, params.max_iterations, &params.weights)?;
    let beta = params.acceptance_exponent;
    if !(beta.is_finite() && beta > 0.0) {
        return Err(OptimizeError::InvalidParameter {
            name: "acceptance_exponent",
            value: beta as f64,
            expected: "a finite exponent > 0",
        });
    }
    let texels = atlas.samples().len();
    let mut rng = Pcg64::seed_from_u64(params.seed);
    let mut state = AtlasState::new(atlas, params.weights, probes);
    let mut best = Best::new(&state);
    let mut history = vec![record(&state, 0, 0, 0, 0.0)];
    let mut iterations = 0;
    'outer: while !state.is_fully_covered() && iterations < params.max_iterations {
        iterations += 1;
        let (mut moves, mut rejected, mut moved) = (0, 0, 0.0f32);
        for k in 0..probes.len() {
            let p = state.positions()[k];
            let corners = support_cube(p, params.step);
            let stride = params.support_stride.max(1);
            let phase = (iterations + k) % stride;
            let deltas: Vec<Option<f64>> = corners
                .par_iter()
                .map(|c| {
                    free.is_free(*c).then(|| {
                        let views = atlas.probe_views_strided(*c, stride, phase);
                        state.subset_delta(k, &views, stride, phase)
                    })
                })
                .collect();
            let worst = deltas
                .iter()
                .flatten()
                .cloned()
                .fold(f64::INFINITY, f64::min);
            let fitness: [f64; 8] = std::array::from_fn(|s| match deltas[s] {
                Some(d) => d - worst,
                None => 0.0,
            });
            let candidate = importance_sample(&corners, &fitness, &mut rng);
            let u: f64 = rng.random();
            if !free.is_free(candidate) {
                rejected += 1;
                continue;
            }
            let candidate_views = atlas.probe_views(candidate);
            let proposal = state.evaluate_move(k, &candidate_views);
            let old = state.reward();
            let acceptance = if old > 0.0 {
                (proposal.reward / old).powf(beta as f64)
            } else {
                1.0
            };
            if u <= acceptance {
                moved += candidate.distance(p);
                moves += 1;
                state.move_probe(k, candidate, candidate_views);
                best.offer(&state);
                if state.is_fully_covered() {
                    history.push(record(&state, iterations, moves, rejected, moved));
                    break 'outer;
                }
            } else {
                rejected += 1;
            }
        }
        history.push(record(&state, iterations, moves, rejected, moved));
    }
    Ok(best.finish(texels, iterations, history))
}

/// Draws a point of the support cube by §3.2.4's axis-by-axis linear importance sampling.
/// `fitness[s]` belongs to `corners[s]` (bit 0 of `s`: x, bit 1: y, bit 2: z).
fn importance_sample(corners: &[Vec3; 8], fitness: &[f64; 8], rng: &mut Pcg64) -> Vec3 {
    // A small floor keeps every density positive (uniform when all fitness is zero).
    let floor = 1e-9 + 1e-3 * fitness.iter().cloned().fold(0.0, f64::max);
    let f: [f64; 8] = std::array::from_fn(|s| fitness[s] + floor);
    // Along x: the four edges (y, z) = (bit 1, bit 2).
    let mut points = [(Vec3::ZERO, 0.0f64); 4];
    for (e, point) in points.iter_mut().enumerate() {
        let (a, b) = (e << 1, (e << 1) | 1);
        let t = sample_linear(f[a], f[b], rng.random());
        *point = (
            corners[a].lerp(corners[b], t as f32),
            f[a] + (f[b] - f[a]) * t,
        );
    }
    // Along y: pairs with the same z (points[z·2 + y]).
    let mut pair = [(Vec3::ZERO, 0.0f64); 2];
    for (z, point) in pair.iter_mut().enumerate() {
        let (a, b) = (points[z * 2], points[z * 2 + 1]);
        let t = sample_linear(a.1, b.1, rng.random());
        *point = (a.0.lerp(b.0, t as f32), a.1 + (b.1 - a.1) * t);
    }
    // Along z: the last segment.
    let t = sample_linear(pair[0].1, pair[1].1, rng.random());
    pair[0].0.lerp(pair[1].0, t as f32)
}

/// Inverts the CDF of the density on `[0, 1]` proportional to `f0 + (f1 − f0)·x` (both ends
/// positive) at `xi ∈ [0, 1)`: solves `(a/2)x² + b·x = xi·(a/2 + b)` with `b = f0`,
/// `a = f1 − f0`, in the cancellation-free form `x = 2c / (b + √(b² + 2ac))`, `c = xi·(a/2 + b)`.
fn sample_linear(f0: f64, f1: f64, xi: f64) -> f64 {
    let (a, b) = (f1 - f0, f0);
    let c = xi * (0.5 * a + b);
    let root = (b * b + 2.0 * a * c).max(0.0).sqrt();
    let denominator = b + root;
    if denominator <= 0.0 {
        return xi;
    }
    (2.0 * c / denominator).clamp(0.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn linear_sampling_follows_the_density() {
        // Density 2x on [0, 1]: CDF x², so the median is √½.
        assert!((sample_linear(0.0, 2.0, 0.5) - 0.5f64.sqrt()).abs() < 1e-12);
        // Uniform.
        assert!((sample_linear(3.0, 3.0, 0.25) - 0.25).abs() < 1e-12);
        // Density 2 − 2x: CDF 2x − x², median 1 − √½.
        assert!((sample_linear(2.0, 0.0, 0.5) - (1.0 - 0.5f64.sqrt())).abs() < 1e-12);
        // Ends.
        assert_eq!(sample_linear(1.0, 5.0, 0.0), 0.0);
        assert!((sample_linear(1.0, 5.0, 1.0) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn importance_sampling_leans_to_the_fit_corner() {
        let corners = support_cube(Vec3::ZERO, 1.0);
        let mut fitness = [0.0; 8];
        fitness[7] = 1.0; // (+1, +1, +1)
        let mut rng = Pcg64::seed_from_u64(1);
        let mut mean = Vec3::ZERO;
        for _ in 0..4000 {
            let p = importance_sample(&corners, &fitness, &mut rng);
            assert!(p.abs().max_element() <= 1.0 + 1e-6);
            mean += p / 4000.0;
        }
        // Every axis leans towards +1. Only one of the four x edges has a fit end, so x leans
        // least; the last axis (z) chooses between the two y-sampled points and leans most.
        assert!(mean.min_element() > 0.1 && mean.z > 0.25, "{mean}");
        // Uniform fitness gives a centred mean.
        let mut mean = Vec3::ZERO;
        for _ in 0..4000 {
            mean += importance_sample(&corners, &[0.5; 8], &mut rng) / 4000.0;
        }
        assert!(mean.abs().max_element() < 0.05, "{mean}");
    }
}
