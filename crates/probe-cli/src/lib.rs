//! Pictures for the `probes` command: charts of speed against accuracy, and top views of
//! scenes with their probes.
//!
//! - [`chart`] draws [`chart::ChartSpec`]s (series of points, log or linear axes, an optional
//!   Pareto front over all points, point labels) into a PNG and an SVG with plotters, and
//!   computes Pareto fronts ([`chart::pareto_front`]).
//! - [`top_view`] renders a scene seen from above by casting rays straight down (optionally
//!   from a cut height, so that roofs do not hide the interior), draws probes over it coloured
//!   by height, and writes a PNG.
//!
//! Both draw text with an embedded font (DejaVu Sans, `assets/`), so pictures look the same
//! on a machine without fonts and no system font library is linked. Every file is written to
//! a temporary file beside its target and renamed over it.
//!
//! ```
//! use probe_cli::chart::{ChartSpec, Point, Series, SeriesStyle, write_chart};
//!
//! let mut spec = ChartSpec::new("Speed against accuracy", "time (ms)", "MSE");
//! spec.x_log = true;
//! spec.y_log = true;
//! spec.pareto_front = true;
//! spec.series = vec![
//!     Series::new("grid", SeriesStyle::LineAndMarkers, vec![
//!         Point::labelled(2.0, 0.08, "8"),
//!         Point::labelled(11.0, 0.031, "64"),
//!     ]),
//!     Series::new("placed", SeriesStyle::LineAndMarkers, vec![
//!         Point::labelled(2.4, 0.04, "8"),
//!         Point::labelled(9.0, 0.015, "32"),
//!         Point::new(0.0, 0.01), // not drawable on a log axis: dropped and counted
//!     ]),
//! ];
//! let dir = tempfile::tempdir()?;
//! let (png, svg) = (dir.path().join("speed.png"), dir.path().join("speed.svg"));
//! let summary = write_chart(&spec, &png, &svg)?;
//! assert_eq!((summary.points_drawn, summary.points_dropped), (4, 1));
//! // The front: grid (2, 0.08), placed (2.4, 0.04) and placed (9, 0.015).
//! assert_eq!(summary.pareto_members, vec![(0, 0), (1, 0), (1, 1)]);
//! assert!(std::fs::read_to_string(&svg)?.contains("placed"));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod chart;
pub mod eval;
pub mod placement;
pub mod top_view;
