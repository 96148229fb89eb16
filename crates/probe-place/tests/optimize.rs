//! Gradient descent and Gibbs sampling over the visibility atlas: the oscillation seed 000
//! reports for descent, Gibbs escaping it, determinism, free space and errors.

use glam::Vec3;
use probe_place::{
    atlas::{Atlas, AtlasParams, BackfaceVote, FreeSpace, RewardWeights, free_space_grid},
    optimize::{DescentParams, GibbsParams, OptimizeError, Optimized, descend, gibbs},
};
use probe_scene::Scene;
use std::sync::OnceLock;

/// The Cornell box with a 3000-texel atlas reachable from a 16³-cell free grid.
fn cornell() -> &'static (Scene, AtlasParams, Vec<Vec3>) {
    static CORNELL: OnceLock<(Scene, AtlasParams, Vec<Vec3>)> = OnceLock::new();
    CORNELL.get_or_init(|| {
        let scene = Scene::builtin("cornell").unwrap();
        let pool = free_space_grid(&BackfaceVote::new(&scene), 0.035);
        let params = AtlasParams::for_texel_count(&scene, 3000);
        (scene, params, pool)
    })
}

fn with_atlas<R>(f: impl FnOnce(&Atlas<'_>, &BackfaceVote<'_>) -> R) -> R {
    let (scene, params, pool) = cornell();
    let atlas = Atlas::build(scene, params, pool).unwrap();
    f(&atlas, &BackfaceVote::new(scene))
}

/// Writes the history as JSON under `target/` so that it can be charted.
fn keep_history(name: &str, result: &Optimized) {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"));
    let _ = std::fs::write(
        dir.join(format!("{name}.json")),
        serde_json::to_string_pretty(result).unwrap(),
    );
}

#[test]
fn descent_oscillates_between_two_positions() {
    with_atlas(|atlas, free| {
        let start = [Vec3::new(0.1, 0.1, 0.1)];
        let params = DescentParams {
            step: 0.04,
            max_iterations: 30,
            weights: RewardWeights::default(),
        };
        let result = descend(atlas, free, &start, &params).unwrap();
        keep_history("descent_single_probe", &result);
        let h = &result.history;
        assert_eq!(h.len(), 31);
        assert!(!result.fully_covered);
        // It climbs at first...
        assert!(h[8].reward > h[0].reward + 0.2);
        // ...then jumps back and forth between two positions for the last 20 iterations:
        // position i equals position i − 2 but not i − 1, and the reward alternates without
        // improving.
        for i in 12..h.len() {
            assert_eq!(h[i].positions, h[i - 2].positions, "iteration {i}");
            assert_ne!(h[i].positions, h[i - 1].positions, "iteration {i}");
            assert_eq!(h[i].reward, h[i - 2].reward);
            assert_eq!(h[i].moves, 1);
        }
        let late_best = h[12..].iter().map(|r| r.reward).fold(0.0, f64::max);
        assert!(late_best <= h[10..12].iter().map(|r| r.reward).fold(0.0, f64::max));
        // Every position visited is in free space.
        for r in h {
            assert!(free.is_free(Vec3::from_array(r.positions[0])));
        }
    });
}

#[test]
fn gibbs_escapes_the_lockstep_oscillation_of_descent() {
    // The constructed case: two probes start at the same point (two candidates that
    // coincide). Descent moves every probe at once to its best support probe, computed
    // against the others' current positions, so the twins pick the same corner every time
    // and oscillate in lockstep, covering no more than one probe would. Gibbs moves one probe
    // at a time, so the second one's marginal gain pulls it away from the first.
    with_atlas(|atlas, free| {
        let start = [Vec3::new(0.278, 0.45, 0.28); 2];
        let step = 0.05;
        let descent = descend(
            atlas,
            free,
            &start,
            &DescentParams {
                step,
                max_iterations: 30,
                weights: RewardWeights::default(),
            },
        )
        .unwrap();
        keep_history("descent_twins", &descent);
        let h = &descent.history;
        for r in h {
            assert_eq!(r.positions[0], r.positions[1], "lockstep");
        }
        for i in 10..h.len() {
            assert_eq!(h[i].positions, h[i - 2].positions);
            assert_ne!(h[i].positions, h[i - 1].positions);
        }
        for seed in 0..4 {
            let result = gibbs(
                atlas,
                free,
                &start,
                &GibbsParams {
                    seed,
                    max_iterations: 30,
                    ..GibbsParams::with_step(step)
                },
            )
            .unwrap();
            keep_history(&format!("gibbs_twins_seed{seed}"), &result);
            assert!(
                result.reward > descent.reward + 0.05 && result.coverage > descent.coverage + 0.05,
                "seed {seed}: gibbs R {} coverage {}, descent R {} coverage {}",
                result.reward,
                result.coverage,
                descent.reward,
                descent.coverage
            );
            let [a, b] = [result.positions()[0], result.positions()[1]];
            assert!(a.distance(b) > 0.1, "{a} {b}");
            assert!(a.is_finite() && free.is_free(a) && free.is_free(b));
        }
    });
}

#[test]
fn gibbs_is_deterministic_per_seed_and_keeps_probes_free() {
    with_atlas(|atlas, free| {
        let start = [
            Vec3::new(0.1, 0.1, 0.1),
            Vec3::new(0.45, 0.4, 0.45),
            Vec3::new(0.2, 0.45, 0.2),
        ];
        let params = GibbsParams {
            max_iterations: 8,
            seed: 11,
            ..GibbsParams::with_step(0.04)
        };
        let a = gibbs(atlas, free, &start, &params).unwrap();
        let b = gibbs(atlas, free, &start, &params).unwrap();
        assert_eq!(a, b);
        let c = gibbs(atlas, free, &start, &GibbsParams { seed: 12, ..params }).unwrap();
        assert_ne!(a.history, c.history);
        assert_eq!(a.history.len(), 9);
        assert_eq!(a.history[0].positions, start.map(|p| p.to_array()).to_vec());
        for record in &a.history {
            // Every probe that moved moved within its support cube, into free space.
            for (p, q) in record.positions.iter().zip(&a.history[0].positions) {
                let p = Vec3::from_array(*p);
                if p != Vec3::from_array(*q) {
                    assert!(free.is_free(p));
                }
            }
            assert!(record.moves + record.rejected <= start.len());
        }
        // The best set is never worse than the start.
        assert!(a.coverage >= a.history[0].coverage);
    });
}

#[test]
fn optimisers_stop_at_full_coverage() {
    // Probes from a minimal full cover are already done: no iteration runs.
    with_atlas(|atlas, free| {
        let (_, _, pool) = cornell();
        let set = probe_place::minimal::minimal_cover(
            atlas,
            free,
            pool,
            &probe_place::minimal::CoverParams::full_coverage(),
        )
        .unwrap();
        assert!(set.reached_target);
        let probes = set.positions();
        let g = gibbs(atlas, free, &probes, &GibbsParams::with_step(0.04)).unwrap();
        assert!(g.fully_covered && g.iterations == 0 && g.history.len() == 1);
        let d = descend(atlas, free, &probes, &DescentParams::with_step(0.04)).unwrap();
        assert!(d.fully_covered && d.iterations == 0);
    });
}

#[test]
fn bad_parameters_are_errors() {
    with_atlas(|atlas, free| {
        let probes = [Vec3::new(0.2, 0.3, 0.2)];
        let gibbs_with = |p: GibbsParams| gibbs(atlas, free, &probes, &p);
        let base = GibbsParams::with_step(0.05);
        let name_of = |e: OptimizeError| match e {
            OptimizeError::InvalidParameter { name, .. } => name,
            other => panic!("{other}"),
        };
        let nan_w1 = RewardWeights {
            view_cosine: f32::NAN,
            ..RewardWeights::default()
        };
        let nan_w2 = RewardWeights {
            distance: f32::NAN,
            ..RewardWeights::default()
        };
        assert_eq!(
            name_of(
                gibbs_with(GibbsParams {
                    weights: nan_w1,
                    ..base
                })
                .unwrap_err()
            ),
            "w1"
        );
        assert_eq!(
            name_of(
                gibbs_with(GibbsParams {
                    weights: nan_w2,
                    ..base
                })
                .unwrap_err()
            ),
            "w2"
        );
        assert_eq!(
            name_of(gibbs_with(GibbsParams { step: 0.0, ..base }).unwrap_err()),
            "step"
        );
        assert_eq!(
            name_of(
                gibbs_with(GibbsParams {
                    max_iterations: 0,
                    ..base
                })
                .unwrap_err()
            ),
            "max_iterations"
        );
        assert_eq!(
            name_of(
                gibbs_with(GibbsParams {
                    acceptance_exponent: f32::INFINITY,
                    ..base
                })
                .unwrap_err()
            ),
            "acceptance_exponent"
        );
        let descent = DescentParams {
            weights: nan_w1,
            ..DescentParams::with_step(0.05)
        };
        assert_eq!(
            name_of(descend(atlas, free, &probes, &descent).unwrap_err()),
            "w1"
        );
        assert!(matches!(
            gibbs(atlas, free, &[], &base),
            Err(OptimizeError::NoProbes)
        ));
        assert!(matches!(
            descend(
                atlas,
                free,
                &[Vec3::ONE, Vec3::NAN],
                &DescentParams::with_step(0.05)
            ),
            Err(OptimizeError::NonFiniteProbe { index: 1, .. })
        ));
    });
}
