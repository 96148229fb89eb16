//! The global visibility atlas of a probe set (seed 000 Fig. 3.8), with incremental updates
//! when one probe moves.

use super::{Atlas, ProbeView, RewardWeights, TexelAggregation};
use glam::Vec3;

/// The reward and coverage a probe set would have (see [`AtlasState::evaluate_move`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Evaluation {
    /// `R(P)` of eq. 3.1, divided by the number of texels: the mean texel fitness.
    pub reward: f64,
    /// How many texels at least one probe sees.
    pub covered: usize,
}

/// The global visibility atlas of a probe set: for every texel, which probes see it and how
/// well, the texel fitness `π` of eq. 3.2, the reward `R(P)` (eq. 3.1, as the mean over texels)
/// and the coverage.
///
/// Moving one probe costs one [`Atlas::probe_views`] and work proportional to the texels the
/// probe saw and sees: [`AtlasState::evaluate_move`] answers "what if probe `k` were there"
/// without changing anything, and [`AtlasState::move_probe`] commits it.
#[derive(Clone, Debug)]
pub struct AtlasState<'s, 'a> {
    atlas: &'s Atlas<'a>,
    weights: RewardWeights,
    positions: Vec<Vec3>,
    /// Per probe, its views in texel order.
    views: Vec<Vec<ProbeView>>,
    /// Per texel, the probes that see it with their scores.
    seen_by: Vec<Vec<(u32, f32)>>,
    /// Per texel, `π`.
    value: Vec<f32>,
    /// Per texel, the probe with the highest score (`u32::MAX` if none).
    best_probe: Vec<u32>,
    /// Per texel, the highest score among the probes other than `best_probe` (0 if none).
    second: Vec<f32>,
    covered: usize,
    reward_sum: f64,
}

impl<'s, 'a> AtlasState<'s, 'a> {
    /// The global atlas of `positions` (views computed here, one probe after another, each in
    /// parallel). `weights` are used as given: check them with [`RewardWeights::check`].
    pub fn new(atlas: &'s Atlas<'a>, weights: RewardWeights, positions: &[Vec3]) -> Self {
        let views = atlas.views_of_probes(positions);
        AtlasState::from_views(atlas, weights, positions.to_vec(), views)
    }

    /// The global atlas of probes whose views are already known (`views[k]` is
    /// `atlas.probe_views(positions[k])`).
    pub fn from_views(
        atlas: &'s Atlas<'a>,
        weights: RewardWeights,
        positions: Vec<Vec3>,
        views: Vec<Vec<ProbeView>>,
    ) -> Self {
        let n = atlas.samples().len();
        let mut state = AtlasState {
            atlas,
            weights,
            positions,
            views,
            seen_by: vec![Vec::new(); n],
            value: vec![0.0; n],
            best_probe: vec![u32::MAX; n],
            second: vec![0.0; n],
            covered: 0,
            reward_sum: 0.0,
        };
        let scale = atlas.distance_scale();
        for (k, views) in state.views.iter().enumerate() {
            for view in views {
                let score = weights.score(view, scale);
                state.seen_by[view.sample as usize].push((k as u32, score));
            }
        }
        for t in 0..n {
            state.refresh_texel(t);
        }
        state.covered = state.seen_by.iter().filter(|s| !s.is_empty()).count();
        state.reward_sum = state.value.iter().map(|v| *v as f64).sum();
        state
    }

    /// The atlas.
    pub fn atlas(&self) -> &'s Atlas<'a> {
        self.atlas
    }

    /// The weights.
    pub fn weights(&self) -> &RewardWeights {
        &self.weights
    }

    /// The probe positions.
    pub fn positions(&self) -> &[Vec3] {
        &self.positions
    }

    /// The views of probe `k`, in texel order.
    pub fn views(&self, k: usize) -> &[ProbeView] {
        &self.views[k]
    }

    /// `R(P)`: the mean texel fitness (eq. 3.1 divided by the texel count).
    pub fn reward(&self) -> f64 {
        self.reward_sum / self.value.len() as f64
    }

    /// How many texels at least one probe sees.
    pub fn covered(&self) -> usize {
        self.covered
    }

    /// The share of texels at least one probe sees.
    pub fn coverage(&self) -> f64 {
        self.covered as f64 / self.value.len() as f64
    }

    /// Whether every texel is seen.
    pub fn is_fully_covered(&self) -> bool {
        self.covered == self.value.len()
    }

    /// How many probes see texel `t`.
    pub fn observers(&self, t: usize) -> usize {
        self.seen_by[t].len()
    }

    /// The reward and coverage the set would have if probe `k` saw `new_views` (views in
    /// texel order, as [`Atlas::probe_views`] returns them) instead of its own. Pass an empty
    /// slice for the set without probe `k`. Nothing changes.
    pub fn evaluate_move(&self, k: usize, new_views: &[ProbeView]) -> Evaluation {
        let scale = self.atlas.distance_scale();
        let old_views = &self.views[k];
        let mut delta = 0.0f64;
        let mut covered = self.covered as isize;
        let (mut i, mut j) = (0, 0);
        while i < old_views.len() || j < new_views.len() {
            let old_t = old_views.get(i).map_or(u32::MAX, |v| v.sample);
            let new_t = new_views.get(j).map_or(u32::MAX, |v| v.sample);
            let t = old_t.min(new_t) as usize;
            let old_score = if old_t as usize == t {
                i += 1;
                Some(self.weights.score(&old_views[i - 1], scale))
            } else {
                None
            };
            let new_score = if new_t as usize == t {
                j += 1;
                Some(self.weights.score(&new_views[j - 1], scale))
            } else {
                None
            };
            let without = self.value_without(t, k, old_score);
            let after = match new_score {
                Some(s) => combine(self.weights.aggregation, without, s),
                None => without,
            };
            delta += after as f64 - self.value[t] as f64;
            let others = self.seen_by[t].len() - usize::from(old_score.is_some());
            let was = !self.seen_by[t].is_empty();
            let is = others > 0 || new_score.is_some();
            covered += is as isize - was as isize;
        }
        Evaluation {
            reward: (self.reward_sum + delta) / self.value.len() as f64,
            covered: covered as usize,
        }
    }

    /// The change of the summed texel fitness over the texels whose index is `phase` modulo
    /// `stride`, if probe `k` saw `new_views` (which must hold only such texels, in order)
    /// there instead of its own views. An estimate of [`AtlasState::evaluate_move`]'s change
    /// from a subset of texels.
    pub(crate) fn subset_delta(
        &self,
        k: usize,
        new_views: &[ProbeView],
        stride: usize,
        phase: usize,
    ) -> f64 {
        let scale = self.atlas.distance_scale();
        let in_subset = |v: &&ProbeView| v.sample as usize % stride == phase;
        let mut old = self.views[k].iter().filter(in_subset).peekable();
        let mut new = new_views.iter().peekable();
        let mut delta = 0.0f64;
        loop {
            let old_t = old.peek().map_or(u32::MAX, |v| v.sample);
            let new_t = new.peek().map_or(u32::MAX, |v| v.sample);
            if old_t == u32::MAX && new_t == u32::MAX {
                break;
            }
            let t = old_t.min(new_t) as usize;
            let old_score = if old_t as usize == t {
                old.next().map(|v| self.weights.score(v, scale))
            } else {
                None
            };
            let new_score = if new_t as usize == t {
                new.next().map(|v| self.weights.score(v, scale))
            } else {
                None
            };
            let without = self.value_without(t, k, old_score);
            let after = match new_score {
                Some(s) => combine(self.weights.aggregation, without, s),
                None => without,
            };
            delta += after as f64 - self.value[t] as f64;
        }
        delta
    }

    /// Moves probe `k` to `position`, whose views are `new_views` (in texel order, from
    /// [`Atlas::probe_views`]), and updates every texel it saw or sees.
    pub fn move_probe(&mut self, k: usize, position: Vec3, new_views: Vec<ProbeView>) {
        let scale = self.atlas.distance_scale();
        let old_views = std::mem::replace(&mut self.views[k], new_views);
        for view in &old_views {
            let list = &mut self.seen_by[view.sample as usize];
            if let Some(at) = list.iter().position(|(p, _)| *p == k as u32) {
                list.swap_remove(at);
            }
        }
        for view in &self.views[k] {
            self.seen_by[view.sample as usize].push((k as u32, self.weights.score(view, scale)));
        }
        let touched: Vec<u32> = old_views
            .iter()
            .chain(self.views[k].iter())
            .map(|v| v.sample)
            .collect();
        for t in touched {
            self.refresh_texel(t as usize);
        }
        self.positions[k] = position;
        self.covered = self.seen_by.iter().filter(|s| !s.is_empty()).count();
        // Summed afresh rather than updated, so that no rounding drift builds up.
        self.reward_sum = self.value.iter().map(|v| *v as f64).sum();
    }

    /// `π` of texel `t` without probe `k`, whose score there is `k_score` (if it sees `t`).
    #[inline]
    fn value_without(&self, t: usize, k: usize, k_score: Option<f32>) -> f32 {
        match (self.weights.aggregation, k_score) {
            (_, None) => self.value[t],
            (TexelAggregation::BestProbe, Some(_)) => {
                if self.best_probe[t] == k as u32 {
                    self.second[t]
                } else {
                    self.value[t]
                }
            }
            (TexelAggregation::SumOverProbes, Some(s)) => (self.value[t] - s).max(0.0),
        }
    }

    fn refresh_texel(&mut self, t: usize) {
        let list = &mut self.seen_by[t];
        // Keep the list in probe order so that ties and sums do not depend on move history.
        list.sort_unstable_by_key(|(p, _)| *p);
        let (mut best, mut best_probe, mut second, mut sum) = (0.0f32, u32::MAX, 0.0f32, 0.0f32);
        for &(p, s) in list.iter() {
            sum += s;
            if best_probe == u32::MAX || s > best {
                second = best;
                best = s;
                best_probe = p;
            } else if s > second {
                second = s;
            }
        }
        self.best_probe[t] = best_probe;
        self.second[t] = second;
        self.value[t] = match self.weights.aggregation {
            TexelAggregation::BestProbe => best,
            TexelAggregation::SumOverProbes => sum,
        };
    }
}

#[inline]
fn combine(aggregation: TexelAggregation, a: f32, b: f32) -> f32 {
    match aggregation {
        TexelAggregation::BestProbe => a.max(b),
        TexelAggregation::SumOverProbes => a + b,
    }
}
