//! Minimal probe sets ("model no more than a scene needs"): drop the probes whose removal
//! keeps coverage, and pick as few probes as reach a target coverage or fit a budget.

use crate::atlas::{Atlas, FreeSpace, ProbeView, counts_by_view};
use crate::optimize::{GibbsParams, OptimizeError, Optimized, gibbs};
use crate::par::*;
use glam::Vec3;
use serde::{Deserialize, Serialize};
use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// Why a minimal set could not be computed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MinimalSetError {
    /// The probe budget is zero.
    ///
    /// Fix: pass a budget of at least 1, or `None` for no budget.
    #[error("the probe budget is 0: a set of no probes covers nothing")]
    ZeroBudget,
    /// The target coverage is outside `(0, 1]` or not a number.
    ///
    /// Fix: pass a share in `(0, 1]`, e.g. `1.0` for full coverage or `0.99`.
    #[error("target coverage {value} is outside (0, 1]")]
    CoverageOutOfRange {
        /// The value given.
        value: f32,
    },
    /// No probe or candidate was given, or none of them is in free space.
    ///
    /// Fix: pass candidates in free space, e.g. [`free_space_grid`](crate::atlas::free_space_grid).
    #[error("no usable candidates: {given} given, none of them in free space")]
    NoCandidates {
        /// How many were given.
        given: usize,
    },
    /// A probe or candidate position is not finite.
    ///
    /// Fix: remove or repair the point named by `index`.
    #[error("candidate {index} has a non-finite position {position}")]
    NonFiniteCandidate {
        /// Index into the list given.
        index: usize,
        /// The position given.
        position: Vec3,
    },
    /// The Gibbs refinement's parameters are invalid.
    ///
    /// Fix: see [`OptimizeError`].
    #[error("refinement: {0}")]
    Refinement(#[from] OptimizeError),
}

/// What [`minimal_cover`] aims for.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CoverParams {
    /// The share of texels to cover, in `(0, 1]` (1: full coverage).
    pub target_coverage: f32,
    /// The most probes to use (`None`: as many as the target needs).
    pub budget: Option<usize>,
    /// Gibbs refinement of the chosen set when the greedy choice falls short of the target
    /// (`None`: no refinement). Refinement moves probes and never lowers coverage.
    pub refine: Option<GibbsParams>,
    /// For an atlas of views ([`Atlas::from_view_samples`]): the target holds for the
    /// texels of **each view**, not only for all of them together, so that no view is left
    /// far below it (a viewpoint the set did not learn from then meets it too, within the
    /// spread between views). Ignored for other atlases.
    #[serde(default)]
    pub each_view: bool,
}

impl CoverParams {
    /// Full coverage, no budget, no refinement.
    pub fn full_coverage() -> CoverParams {
        CoverParams {
            target_coverage: 1.0,
            budget: None,
            refine: None,
            each_view: false,
        }
    }
}

/// A set chosen by [`minimal_cover`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MinimalSet {
    /// The probe positions (after pruning and refinement).
    pub positions: Vec<[f32; 3]>,
    /// The candidates chosen, as indices into the list given, in the order chosen (those
    /// pruned afterwards left out). Refinement moves probes away from these candidates.
    pub chosen: Vec<usize>,
    /// Coverage after each greedy pick: `coverage_by_count[i]` is the coverage of the first
    /// `i + 1` picks, the curve of coverage against probe count.
    pub coverage_by_count: Vec<f64>,
    /// How many greedy picks the pruning pass dropped.
    pub pruned: usize,
    /// The coverage of `positions`.
    pub coverage: f64,
    /// Whether `coverage` reaches the target.
    pub reached_target: bool,
    /// The refinement's result, when it ran.
    pub refinement: Option<Optimized>,
}

impl MinimalSet {
    /// The positions as `Vec3`s.
    pub fn positions(&self) -> Vec<Vec3> {
        self.positions
            .iter()
            .map(|p| Vec3::from_array(*p))
            .collect()
    }
}

/// A probe set after [`prune_redundant`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Pruned {
    /// Indices of the probes kept, in input order.
    pub kept: Vec<usize>,
    /// Coverage before pruning.
    pub coverage_before: f64,
    /// Coverage after pruning.
    pub coverage_after: f64,
}

fn check_points(points: &[Vec3]) -> Result<(), MinimalSetError> {
    if let Some(index) = points.iter().position(|p| !p.is_finite()) {
        return Err(MinimalSetError::NonFiniteCandidate {
            index,
            position: points[index],
        });
    }
    Ok(())
}

fn check_target(target: f32) -> Result<(), MinimalSetError> {
    if !(target > 0.0 && target <= 1.0) {
        return Err(MinimalSetError::CoverageOutOfRange { value: target });
    }
    Ok(())
}

/// The number of texels a coverage of `target` needs.
fn needed_texels(target: f32, texels: usize) -> usize {
    ((target as f64 * texels as f64) - 1e-9).ceil().max(0.0) as usize
}

/// Drops every probe whose removal keeps the coverage at least `min(min_coverage,
/// coverage of all probes)`; with `min_coverage = 1` that is "every probe whose removal
/// keeps every covered texel covered".
///
/// Greedy, in a documented order: probes are visited from the one that sees the fewest
/// texels to the one that sees the most (ties: lower index first), and each is dropped if the
/// coverage without it stays at least the floor. With a floor equal to the starting coverage
/// the result is irredundant: every probe kept sees a texel no other kept probe sees. The
/// result is never larger than the input.
pub fn prune_redundant(
    atlas: &Atlas<'_>,
    probes: &[Vec3],
    min_coverage: f32,
) -> Result<Pruned, MinimalSetError> {
    check_target(min_coverage)?;
    check_points(probes)?;
    if probes.is_empty() {
        return Err(MinimalSetError::NoCandidates { given: 0 });
    }
    let views: Vec<Vec<u32>> = probes
        .par_iter()
        .map(|p| texel_ids(atlas.probe_views(*p)))
        .collect();
    let all: Vec<usize> = (0..probes.len()).collect();
    let groups = TexelGroups::pooled(atlas.samples().len(), min_coverage);
    let (kept, before, after) = prune_views(&views, &all, &groups);
    Ok(Pruned {
        kept,
        coverage_before: before,
        coverage_after: after,
    })
}

fn texel_ids(views: Vec<ProbeView>) -> Vec<u32> {
    views.into_iter().map(|v| v.sample).collect()
}

/// Which texels must be covered: each texel's group and how many texels of each group the
/// target needs (one group for a target over all texels, one per view for a target held by
/// every view).
struct TexelGroups {
    of: Vec<u32>,
    needed: Vec<usize>,
}

impl TexelGroups {
    fn pooled(texels: usize, target: f32) -> TexelGroups {
        TexelGroups {
            of: vec![0; texels],
            needed: vec![needed_texels(target, texels)],
        }
    }

    /// One group per view of `atlas` when it has views and `each_view` is asked for.
    fn of(atlas: &Atlas<'_>, target: f32, each_view: bool) -> TexelGroups {
        let labels = atlas.sample_views();
        if !each_view || labels.is_empty() {
            return TexelGroups::pooled(atlas.samples().len(), target);
        }
        TexelGroups::by_view(labels, target)
    }

    /// One group per label of `labels` (texel → view).
    fn by_view(labels: &[u32], target: f32) -> TexelGroups {
        TexelGroups {
            of: labels.to_vec(),
            needed: counts_by_view(labels, |_| false)
                .iter()
                .map(|&[_, total]| needed_texels(target, total))
                .collect(),
        }
    }

    fn texels(&self) -> usize {
        self.of.len()
    }

    /// Per group, how many of its texels `seen` says are seen.
    fn covered(&self, seen: impl Fn(usize) -> bool) -> Vec<usize> {
        let mut covered: Vec<usize> = counts_by_view(&self.of, seen)
            .iter()
            .map(|&[seen, _]| seen)
            .collect();
        // No texels at all: the one pooled group saw none.
        covered.resize(self.needed.len(), 0);
        covered
    }

    fn reached(&self, covered: &[usize]) -> bool {
        covered.iter().zip(&self.needed).all(|(c, n)| c >= n)
    }
}

/// Prunes `members` (indices into `views`, the texels each sees), keeping in every group at
/// least `min(needed, covered by all members)` texels; returns (kept, coverage before, after).
fn prune_views(
    views: &[Vec<u32>],
    members: &[usize],
    groups: &TexelGroups,
) -> (Vec<usize>, f64, f64) {
    let texels = groups.texels();
    let mut count = vec![0u32; texels];
    for &m in members {
        for v in &views[m] {
            count[*v as usize] += 1;
        }
    }
    let mut covered = groups.covered(|t| count[t] > 0);
    let total = |covered: &[usize]| covered.iter().sum::<usize>() as f64 / texels as f64;
    let before = total(&covered);
    let floor: Vec<usize> = covered
        .iter()
        .zip(&groups.needed)
        .map(|(c, n)| *n.min(c))
        .collect();
    let mut order = members.to_vec();
    order.sort_by_key(|&m| (views[m].len(), m));
    let mut dropped = vec![false; views.len()];
    let mut lost = vec![0usize; covered.len()];
    for m in order {
        let mut touched = Vec::new();
        for v in &views[m] {
            if count[*v as usize] == 1 {
                let g = groups.of[*v as usize] as usize;
                if lost[g] == 0 {
                    touched.push(g);
                }
                lost[g] += 1;
            }
        }
        if touched.iter().all(|&g| covered[g] - lost[g] >= floor[g]) {
            for v in &views[m] {
                count[*v as usize] -= 1;
            }
            for &g in &touched {
                covered[g] -= lost[g];
            }
            dropped[m] = true;
        }
        for &g in &touched {
            lost[g] = 0;
        }
    }
    let kept = members.iter().copied().filter(|m| !dropped[*m]).collect();
    (kept, before, total(&covered))
}

/// As few probes as reach `params.target_coverage` (or as much coverage as
/// `params.budget` probes give), chosen from `candidates`:
/// 1. candidates outside free space are skipped;
/// 2. **greedy set cover**: repeatedly take the candidate that sees the most texels not yet
///    seen (ties: lower index), until the target is reached, the budget is spent or no
///    candidate adds anything. Greedy cover is within a factor `ln(texels) + 1` of the
///    fewest probes possible from the same candidates; it is evaluated lazily (a candidate's
///    gain only shrinks as others are chosen). With [`CoverParams::each_view`] on an atlas of
///    views, a texel counts only while its view is short of the target, and the target is
///    reached when every view reaches it;
/// 3. [`prune_redundant`]'s pass over the chosen probes, keeping the coverage reached (capped
///    at the target; held by each view, each view's);
/// 4. if `params.refine` is set and the target (over all texels) is not reached, Gibbs
///    sampling ([`gibbs`]) moves the chosen probes to raise coverage (it keeps the best set
///    met, so coverage does not drop).
///
/// With the atlas's own reference points as candidates (e.g. the same
/// [`free_space_grid`](crate::atlas::free_space_grid)), full coverage is always reachable, since
/// every texel kept in the atlas is seen by one of them.
pub fn minimal_cover(
    atlas: &Atlas<'_>,
    free: &dyn FreeSpace,
    candidates: &[Vec3],
    params: &CoverParams,
) -> Result<MinimalSet, MinimalSetError> {
    check_target(params.target_coverage)?;
    if params.budget == Some(0) {
        return Err(MinimalSetError::ZeroBudget);
    }
    check_points(candidates)?;
    let usable: Vec<usize> = {
        let flags: Vec<bool> = candidates
            .par_iter()
            .with_min_len(8)
            .map(|c| free.is_free(*c))
            .collect();
        (0..candidates.len()).filter(|i| flags[*i]).collect()
    };
    if usable.is_empty() {
        return Err(MinimalSetError::NoCandidates {
            given: candidates.len(),
        });
    }
    let texels = atlas.samples().len();
    // Only the texel indices are kept: dense pools hold tens of millions of views.
    let views: Vec<Vec<u32>> = usable
        .par_iter()
        .map(|&i| texel_ids(atlas.probe_views(candidates[i])))
        .collect();
    let groups = TexelGroups::of(atlas, params.target_coverage, params.each_view);
    let by_view = groups.needed.len() > 1;
    let budget = params.budget.unwrap_or(usize::MAX);

    // Lazy greedy: the heap holds (gain bound, lowest index first). Held by each view, a
    // candidate gains only the texels of views still short of the target, up to what each
    // needs (a truncated coverage: still submodular, so gains only shrink).
    let mut seen = vec![false; texels];
    let mut short: Vec<usize> = groups.needed.clone();
    let mut remaining: usize = short.iter().sum();
    let mut new_by_group = vec![0usize; short.len()];
    let mut gain_of = |u: usize, seen: &[bool], short: &[usize]| -> usize {
        if !by_view {
            return views[u].iter().filter(|v| !seen[**v as usize]).count();
        }
        let mut touched = Vec::new();
        for v in &views[u] {
            if !seen[*v as usize] {
                let g = groups.of[*v as usize] as usize;
                if new_by_group[g] == 0 {
                    touched.push(g);
                }
                new_by_group[g] += 1;
            }
        }
        let gain = touched.iter().map(|&g| new_by_group[g].min(short[g])).sum();
        for g in touched {
            new_by_group[g] = 0;
        }
        gain
    };
    let mut heap: BinaryHeap<(usize, Reverse<usize>)> = views
        .iter()
        .enumerate()
        .map(|(u, v)| (v.len(), Reverse(u)))
        .collect();
    let mut covered = 0usize;
    let mut picks: Vec<usize> = Vec::new();
    let mut coverage_by_count = Vec::new();
    while remaining > 0 && picks.len() < budget {
        let Some((_, Reverse(u))) = heap.pop() else {
            break;
        };
        let gain = gain_of(u, &seen, &short);
        if gain == 0 {
            continue;
        }
        if let Some(&(next_bound, Reverse(next))) = heap.peek()
            && (next_bound, Reverse(next)) > (gain, Reverse(u))
        {
            heap.push((gain, Reverse(u)));
            continue;
        }
        for v in &views[u] {
            let s = &mut seen[*v as usize];
            if !*s {
                *s = true;
                covered += 1;
                let g = groups.of[*v as usize] as usize;
                if short[g] > 0 {
                    short[g] -= 1;
                    remaining -= 1;
                }
            }
        }
        picks.push(u);
        coverage_by_count.push(covered as f64 / texels as f64);
    }
    let (kept, _, _) = prune_views(&views, &picks, &groups);
    let pruned = picks.len() - kept.len();
    let chosen_usable: Vec<usize> = picks.iter().copied().filter(|p| kept.contains(p)).collect();
    let chosen: Vec<usize> = chosen_usable.iter().map(|&u| usable[u]).collect();
    let mut positions: Vec<Vec3> = chosen.iter().map(|&i| candidates[i]).collect();
    let mut seen = vec![false; texels];
    for &u in &chosen_usable {
        for v in &views[u] {
            seen[*v as usize] = true;
        }
    }
    let mut coverage = seen.iter().filter(|s| **s).count() as f64 / texels as f64;
    let mut reached = groups.reached(&groups.covered(|t| seen[t]));
    let mut refinement = None;
    // Gibbs raises coverage over all texels: it serves a target over all of them.
    if let Some(refine) = &params.refine
        && !reached
        && !by_view
        && !positions.is_empty()
    {
        let result = gibbs(atlas, free, &positions, refine)?;
        if result.coverage > coverage {
            positions = result.positions();
            coverage = result.coverage;
            reached = coverage * texels as f64 >= groups.needed[0] as f64 - 1e-9;
        }
        refinement = Some(result);
    }
    Ok(MinimalSet {
        positions: positions.iter().map(|p| p.to_array()).collect(),
        chosen,
        coverage_by_count,
        pruned,
        coverage,
        reached_target: reached,
        refinement,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn view(sample: u32) -> u32 {
        sample
    }

    #[test]
    fn pruning_keeps_coverage_and_drops_the_redundant() {
        // Probe 0 sees {0, 1}, probe 1 sees {1, 2}, probe 2 sees {0, 1, 2, 3}, probe 3 sees {3}.
        let views = vec![
            vec![view(0), view(1)],
            vec![view(1), view(2)],
            vec![view(0), view(1), view(2), view(3)],
            vec![view(3)],
        ];
        let (kept, before, after) =
            prune_views(&views, &[0, 1, 2, 3], &TexelGroups::pooled(4, 1.0));
        assert_eq!((before, after), (1.0, 1.0));
        // Visit order by view count: 3 (1 texel), 0, 1 (2 each), 2: 3, 0 and 1 are redundant
        // while 2 remains; 2 is then the only one left.
        assert_eq!(kept, vec![2]);
        // With a 50 % floor everything but one probe can go.
        let (kept, _, after) = prune_views(&views, &[0, 1, 3], &TexelGroups::pooled(4, 0.5));
        assert!(after >= 0.5 && kept.len() == 1, "{kept:?} {after}");
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig {
            rng_seed: proptest::test_runner::RngSeed::Fixed(1),
            ..proptest::prelude::ProptestConfig::default()
        })]
        /// Pruning by view keeps, in every view, at least what the target needs (or what all
        /// the probes saw, if less), and keeps no probe whose removal would keep that.
        #[test]
        fn pruning_keeps_every_views_floor_and_nothing_redundant(
            labels in proptest::collection::vec(0u32..4, 1..40),
            seen in proptest::collection::vec(proptest::collection::vec(0usize..40, 0..12), 1..10),
            target in 0.05f32..=1.0,
        ) {
            let texels = labels.len();
            let views: Vec<Vec<u32>> = seen
                .iter()
                .map(|s| {
                    let mut v: Vec<u32> = s.iter().map(|&t| (t % texels) as u32).collect();
                    v.sort_unstable();
                    v.dedup();
                    v
                })
                .collect();
            let groups = TexelGroups::by_view(&labels, target);
            let all: Vec<usize> = (0..views.len()).collect();
            let per_view = |members: &[usize]| {
                let mut hit = vec![false; texels];
                for &m in members {
                    for &t in &views[m] {
                        hit[t as usize] = true;
                    }
                }
                groups.covered(|t| hit[t])
            };
            let before = per_view(&all);
            let floor: Vec<usize> = before.iter().zip(&groups.needed).map(|(c, n)| *c.min(n)).collect();
            let (kept, _, _) = prune_views(&views, &all, &groups);
            let after = per_view(&kept);
            for g in 0..floor.len() {
                proptest::prop_assert!(after[g] >= floor[g], "view {g}: {} < {}", after[g], floor[g]);
            }
            for skip in 0..kept.len() {
                let fewer: Vec<usize> = kept.iter().enumerate().filter(|(i, _)| *i != skip).map(|(_, m)| *m).collect();
                let without = per_view(&fewer);
                proptest::prop_assert!(
                    (0..floor.len()).any(|g| without[g] < floor[g]),
                    "probe {} was redundant", kept[skip]
                );
            }
        }
    }

    #[test]
    fn pruning_by_view_keeps_each_views_target() {
        // Texels 0–2 come from view 0, texel 3 from view 1; probe 0 sees {0, 1, 2}, probe 1
        // sees {3}. Over all texels 75 % needs probe 0 alone; for each view, probe 1 too.
        let views = vec![vec![view(0), view(1), view(2)], vec![view(3)]];
        let pooled = TexelGroups::pooled(4, 0.75);
        assert_eq!(prune_views(&views, &[0, 1], &pooled).0, vec![0]);
        let by_view = TexelGroups::by_view(&[0, 0, 0, 1], 0.75);
        let (kept, _, after) = prune_views(&views, &[0, 1], &by_view);
        assert_eq!((kept, after), (vec![0, 1], 1.0));
        assert!(by_view.reached(&by_view.covered(|_| true)));
        assert!(!by_view.reached(&by_view.covered(|t| t < 3)));
    }
}

/// What [`complete_coverage`] added.
#[derive(Clone, Debug, PartialEq)]
pub struct Completion {
    /// The probes: those given first, in their order, then the ones added.
    pub positions: Vec<Vec3>,
    /// How many were added.
    pub added: usize,
    /// Texels still unseen (0 unless the budget stopped the completion: every atlas texel is
    /// seen by some reference point, and the candidates given are usually those points).
    pub uncovered: usize,
}

/// Completes the coverage of `chosen`: adds, one at a time, the candidate that sees the most
/// texels no chosen probe sees (ties: the lowest index), until every texel is seen, no
/// candidate sees a new one, or the set has `budget` probes.
///
/// With the atlas's own reference points as `candidates` (as
/// [`pipeline::place`](crate::pipeline::place) passes them) full coverage is always reached
/// without a budget: the atlas keeps only texels some reference point sees. Only the texels
/// left unseen are tested against the candidates, so completing a nearly full set is cheap.
pub fn complete_coverage(
    atlas: &Atlas<'_>,
    candidates: &[Vec3],
    chosen: Vec<Vec3>,
    budget: Option<usize>,
) -> Completion {
    let seen = atlas.seen_by_any(&chosen);
    let mut unseen: Vec<u32> = seen
        .iter()
        .enumerate()
        .filter_map(|(i, s)| (!*s).then_some(i as u32))
        .collect();
    let mut positions = chosen;
    let given = positions.len();
    let budget = budget.unwrap_or(usize::MAX);
    if unseen.is_empty() || positions.len() >= budget {
        return Completion {
            positions,
            added: 0,
            uncovered: unseen.len(),
        };
    }
    // Which unseen texels each candidate sees (sorted texel ids).
    let mut sees: Vec<Vec<u32>> = candidates
        .par_iter()
        .map(|c| atlas.sees_texels(*c, &unseen))
        .collect();
    let mut used = vec![false; candidates.len()];
    let mut covered = vec![false; atlas.samples().len()];
    while !unseen.is_empty() && positions.len() < budget {
        // Drop what the last pick covered from every list, then take the longest.
        let (best, gain) = sees
            .iter_mut()
            .enumerate()
            .filter(|(i, _)| !used[*i])
            .map(|(i, list)| {
                list.retain(|t| !covered[*t as usize]);
                (i, list.len())
            })
            .fold((usize::MAX, 0), |a, b| if b.1 > a.1 { b } else { a });
        if gain == 0 {
            break;
        }
        used[best] = true;
        for &t in &sees[best] {
            covered[t as usize] = true;
        }
        positions.push(candidates[best]);
        unseen.retain(|t| !covered[*t as usize]);
    }
    Completion {
        added: positions.len() - given,
        uncovered: unseen.len(),
        positions,
    }
}
