//! Charts written as PNG and SVG: sizes, content, Pareto fronts and log axes.

use probe_eval::chart::{
    ChartError, ChartSpec, Point, Series, SeriesStyle, pareto_front, write_chart,
};
use std::collections::HashSet;
use std::path::Path;

/// Where a test keeps its outputs; `PROBE_CHART_KEEP=dir` keeps them for a look.
fn out_dir() -> (tempfile::TempDir, std::path::PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let path = match std::env::var_os("PROBE_CHART_KEEP") {
        Some(keep) => {
            std::fs::create_dir_all(&keep).unwrap();
            std::path::PathBuf::from(keep)
        }
        None => dir.path().to_path_buf(),
    };
    (dir, path)
}

fn speed_accuracy_spec() -> ChartSpec {
    let mut spec = ChartSpec::new(
        "Speed against accuracy (colonnade)",
        "time per frame (ms)",
        "MSE against the path-traced reference",
    );
    spec.x_log = true;
    spec.y_log = true;
    spec.pareto_front = true;
    spec.series = vec![
        Series::new(
            "regular grid",
            SeriesStyle::LineAndMarkers,
            vec![
                Point::labelled(2.0, 0.08, "8"),
                Point::labelled(4.5, 0.05, "27"),
                Point::labelled(11.0, 0.031, "64"),
                Point::labelled(30.0, 0.024, "125"),
            ],
        ),
        Series::new(
            "Gibbs placement",
            SeriesStyle::LineAndMarkers,
            vec![
                Point::labelled(2.4, 0.04, "8"),
                Point::labelled(5.0, 0.022, "16"),
                Point::labelled(9.0, 0.015, "32"),
                Point::labelled(25.0, 0.016, "64"),
            ],
        ),
    ];
    spec
}

fn distinct_colours(image: &image::RgbImage) -> usize {
    image.pixels().map(|p| p.0).collect::<HashSet<_>>().len()
}

#[test]
fn two_series_with_a_front_write_png_and_svg() {
    let (_guard, dir) = out_dir();
    let (png, svg) = (dir.join("speed.png"), dir.join("speed.svg"));
    let spec = speed_accuracy_spec();
    let summary = write_chart(&spec, &png, &svg).unwrap();
    assert_eq!(summary.points_drawn, 8);
    assert_eq!(summary.points_dropped, 0);
    // Front over both series: grid (2, 0.08), Gibbs (2.4, 0.04), (5, 0.022), (9, 0.015).
    assert_eq!(summary.pareto_members, vec![(0, 0), (1, 0), (1, 1), (1, 2)]);

    let image = image::open(&png).unwrap().to_rgb8();
    assert_eq!(image.dimensions(), (1000, 700));
    // Not blank: white background, grey grid, black text and front, the two series' colours.
    let colours = distinct_colours(&image);
    assert!(colours > 20, "only {colours} distinct colours");
    let has = |rgb: [u8; 3]| image.pixels().any(|p| p.0 == rgb);
    assert!(has([0, 114, 178]), "the first series' blue is missing");
    assert!(has([230, 159, 0]), "the second series' orange is missing");
    // Text was rasterised with the embedded font: anti-aliased grey levels exist.
    let greys = image
        .pixels()
        .filter(|p| p.0[0] == p.0[1] && p.0[1] == p.0[2] && p.0[0] > 30 && p.0[0] < 220)
        .count();
    assert!(greys > 500, "{greys} grey pixels: no text?");

    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(
        text.starts_with("<svg"),
        "not an SVG: {}",
        &text[..40.min(text.len())]
    );
    for needle in [
        "regular grid",
        "Gibbs placement",
        "Pareto front (4 points)",
        "Speed against accuracy (colonnade)",
        "time per frame (ms)",
    ] {
        assert!(text.contains(needle), "the SVG lacks {needle:?}");
    }
    // No temporary files are left beside the outputs.
    let leftovers: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().ends_with(".tmp"))
        .collect();
    assert!(leftovers.is_empty());
}

#[test]
fn chart_size_is_the_requested_one() {
    let (_guard, dir) = out_dir();
    let mut spec = speed_accuracy_spec();
    spec.width = 640;
    spec.height = 480;
    let (png, svg) = (dir.join("small.png"), dir.join("small.svg"));
    write_chart(&spec, &png, &svg).unwrap();
    let image = image::open(&png).unwrap();
    assert_eq!((image.width(), image.height()), (640, 480));
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(text.contains("width=\"640\"") && text.contains("height=\"480\""));
}

#[test]
fn log_axes_drop_zero_negative_and_nan_without_panicking() {
    let (_guard, dir) = out_dir();
    let mut spec = ChartSpec::new("log with bad values", "x", "y");
    spec.x_log = true;
    spec.y_log = true;
    spec.pareto_front = true;
    spec.series = vec![Series::new(
        "run",
        SeriesStyle::LineAndMarkers,
        vec![
            Point::new(0.0, 1.0),
            Point::new(1.0, 0.5),
            Point::new(2.0, 0.0),
            Point::new(-3.0, 0.2),
            Point::new(4.0, f64::NAN),
            Point::new(f64::INFINITY, 0.1),
            Point::new(5.0, 0.25),
            Point::new(10.0, 0.3),
        ],
    )];
    let (png, svg) = (dir.join("log.png"), dir.join("log.svg"));
    let summary = write_chart(&spec, &png, &svg).unwrap();
    assert_eq!(summary.points_drawn, 3);
    assert_eq!(summary.points_dropped, 5);
    assert_eq!(summary.pareto_members, vec![(0, 1), (0, 6)]);
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(text.contains("5 points not shown"));
    assert!(image::open(&png).is_ok());

    // The same values on linear axes keep zeros and negatives; only NaN and ∞ go.
    spec.x_log = false;
    spec.y_log = false;
    let summary = write_chart(&spec, &png, &svg).unwrap();
    assert_eq!((summary.points_drawn, summary.points_dropped), (6, 2));
    // (−3, 0.2) and (2, 0) are the front now.
    assert_eq!(summary.pareto_members, vec![(0, 3), (0, 2)]);
}

#[test]
fn a_single_point_and_a_flat_line_get_a_usable_range() {
    let (_guard, dir) = out_dir();
    let mut spec = ChartSpec::new("one point", "x", "y");
    spec.x_log = true;
    spec.series = vec![Series::new(
        "one",
        SeriesStyle::Markers,
        vec![Point::new(3.0, 7.0)],
    )];
    write_chart(&spec, &dir.join("one.png"), &dir.join("one.svg")).unwrap();
    let mut flat = ChartSpec::new("flat", "iteration", "coverage");
    flat.series = vec![Series::from_values("constant", &[0.5; 20])];
    write_chart(&flat, &dir.join("flat.png"), &dir.join("flat.svg")).unwrap();
}

#[test]
fn line_chart_of_values_per_iteration() {
    let (_guard, dir) = out_dir();
    // Descent oscillates between two states; Gibbs climbs and settles.
    let descent: Vec<f64> = (0..60)
        .map(|i| if i % 2 == 0 { 0.62 } else { 0.58 } + 0.001 * (i as f64).min(10.0))
        .collect();
    let gibbs: Vec<f64> = (0..60)
        .map(|i| 0.9 - 0.35 * (-(i as f64) / 12.0).exp())
        .collect();
    let mut spec = ChartSpec::new(
        "Gibbs sampling escapes descent's oscillation",
        "iteration",
        "coverage",
    );
    spec.series = vec![
        Series::from_values("gradient descent", &descent),
        Series::from_values("Gibbs sampling", &gibbs),
    ];
    let (png, svg) = (dir.join("iterations.png"), dir.join("iterations.svg"));
    let summary = write_chart(&spec, &png, &svg).unwrap();
    assert_eq!(summary.points_drawn, 120);
    assert!(summary.pareto_members.is_empty());
    let image = image::open(&png).unwrap().to_rgb8();
    assert!(distinct_colours(&image) > 20);
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(text.contains("gradient descent") && text.contains("Gibbs sampling"));
    // Lines, not markers: the SVG holds polylines for both series.
    assert!(text.matches("<polyline").count() >= 2);
}

#[test]
fn bad_specs_are_errors() {
    let (_guard, dir) = out_dir();
    let (png, svg) = (dir.join("bad.png"), dir.join("bad.svg"));
    let empty = ChartSpec::new("empty", "x", "y");
    assert!(matches!(
        write_chart(&empty, &png, &svg),
        Err(ChartError::NothingToDraw { dropped: 0 })
    ));
    let mut all_bad = ChartSpec::new("all bad", "x", "y");
    all_bad.y_log = true;
    all_bad.series = vec![Series::from_values("zeros", &[0.0, -1.0, f64::NAN])];
    let error = write_chart(&all_bad, &png, &svg).unwrap_err();
    assert!(
        matches!(error, ChartError::NothingToDraw { dropped: 3 }),
        "{error}"
    );
    let mut huge = speed_accuracy_spec();
    huge.width = 0;
    let error = write_chart(&huge, &png, &svg).unwrap_err();
    assert!(error.to_string().contains("0×700"), "{error}");
    assert!(matches!(
        write_chart(&speed_accuracy_spec(), &png, &png),
        Err(ChartError::SamePath { .. })
    ));
    let missing = dir.join("no/such/folder/chart.png");
    let error = write_chart(&speed_accuracy_spec(), &missing, &svg).unwrap_err();
    assert!(matches!(error, ChartError::Write { .. }), "{error}");
    assert!(error.to_string().contains("chart.png"));
    // Nothing was written by any of the failures.
    assert!(!Path::new(&png).exists() && !Path::new(&svg).exists());
}

#[test]
fn pareto_front_hand_made_cases() {
    // Empty and single point.
    assert_eq!(pareto_front(&[]), Vec::<usize>::new());
    assert_eq!(pareto_front(&[(3.0, 4.0)]), vec![0]);
    // A staircase with dominated points mixed in, given out of order.
    let points = [
        (5.0, 1.0),
        (1.0, 5.0),
        (2.0, 6.0),
        (3.0, 3.0),
        (4.0, 3.5),
        (6.0, 0.5),
    ];
    assert_eq!(pareto_front(&points), vec![1, 3, 0, 5]);
    // Ties in x: only the smaller y. Ties in y: only the smaller x.
    assert_eq!(pareto_front(&[(1.0, 2.0), (1.0, 1.0), (2.0, 1.0)]), vec![1]);
    assert_eq!(
        pareto_front(&[(2.0, 1.0), (1.0, 3.0), (1.0, 3.0)]),
        vec![1, 2, 0]
    );
    // Exact duplicates of a member are all members, in index order; a duplicate of a
    // dominated point is not.
    assert_eq!(
        pareto_front(&[(1.0, 1.0), (1.0, 1.0), (2.0, 2.0), (2.0, 2.0)]),
        vec![0, 1]
    );
    // -0.0 and 0.0 are the same value.
    assert_eq!(pareto_front(&[(0.0, 1.0), (-0.0, 1.0)]), vec![0, 1]);
    // NaN and infinite coordinates take no part and dominate nothing.
    let with_nan = [
        (f64::NAN, 0.0),
        (1.0, 1.0),
        (0.5, f64::NAN),
        (2.0, 0.5),
        (f64::NEG_INFINITY, 0.0),
    ];
    assert_eq!(pareto_front(&with_nan), vec![1, 3]);
    assert_eq!(pareto_front(&[(f64::NAN, f64::NAN)]), Vec::<usize>::new());
    // Every returned point is undominated and every other finite point is dominated.
    let cloud: Vec<(f64, f64)> = (0..200)
        .map(|i| {
            let a = (i * 37 % 101) as f64;
            let b = (i * 53 % 97) as f64;
            (a, b)
        })
        .collect();
    let front = pareto_front(&cloud);
    let dominates =
        |p: (f64, f64), q: (f64, f64)| p.0 <= q.0 && p.1 <= q.1 && (p.0 < q.0 || p.1 < q.1);
    for (i, &q) in cloud.iter().enumerate() {
        let dominated = cloud.iter().any(|&p| dominates(p, q));
        assert_eq!(front.contains(&i), !dominated, "point {i} {q:?}");
    }
    assert!(front.windows(2).all(|w| cloud[w[0]].0 <= cloud[w[1]].0));
}

#[test]
fn same_spec_same_bytes() {
    let (_guard, dir) = out_dir();
    let spec = speed_accuracy_spec();
    let (a_png, a_svg) = (dir.join("det_a.png"), dir.join("det_a.svg"));
    let (b_png, b_svg) = (dir.join("det_b.png"), dir.join("det_b.svg"));
    write_chart(&spec, &a_png, &a_svg).unwrap();
    write_chart(&spec, &b_png, &b_svg).unwrap();
    assert_eq!(
        std::fs::read(&a_png).unwrap(),
        std::fs::read(&b_png).unwrap()
    );
    assert_eq!(
        std::fs::read(&a_svg).unwrap(),
        std::fs::read(&b_svg).unwrap()
    );
}

#[test]
fn many_series_cycle_colours_and_markers() {
    let (_guard, dir) = out_dir();
    let mut spec = ChartSpec::new("nine methods", "probes", "coverage");
    spec.series = (0..9)
        .map(|s| {
            let points = (1..=6)
                .map(|k| Point::new(k as f64 * 8.0, 1.0 - 0.5 / (k as f64 + s as f64 * 0.3)))
                .collect();
            Series::new(format!("method {s}"), SeriesStyle::LineAndMarkers, points)
        })
        .collect();
    let (png, svg) = (dir.join("nine.png"), dir.join("nine.svg"));
    let summary = write_chart(&spec, &png, &svg).unwrap();
    assert_eq!(summary.points_drawn, 54);
    let text = std::fs::read_to_string(&svg).unwrap();
    for s in 0..9 {
        assert!(text.contains(&format!("method {s}")));
    }
}

/// Two noise floors (the reference's and the bakes') are told apart: the first grey with
/// long dashes, the second dark with short ones, each named in the legend.
#[test]
fn two_floors_are_drawn_apart_and_named() {
    let (_guard, dir) = out_dir();
    let (png, svg) = (dir.join("floors.png"), dir.join("floors.svg"));
    let mut spec = speed_accuracy_spec();
    spec.floors = vec![
        probe_eval::chart::Floor {
            name: "reference noise floor (2e-3)".into(),
            y: 0.002,
        },
        probe_eval::chart::Floor {
            name: "bake noise (1e-2)".into(),
            y: 0.01,
        },
    ];
    write_chart(&spec, &png, &svg).unwrap();
    let image = image::open(&png).unwrap().to_rgb8();
    let count = |rgb: [u8; 3]| image.pixels().filter(|p| p.0 == rgb).count();
    // Each floor's dashes run across the plot: hundreds of pixels of its own shade.
    assert!(count([120, 120, 120]) > 300, "{}", count([120, 120, 120]));
    assert!(count([40, 40, 40]) > 300, "{}", count([40, 40, 40]));
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(text.contains("reference noise floor (2e-3)"));
    assert!(text.contains("bake noise (1e-2)"));
}
