//! Charts written as PNG and SVG: speed against accuracy with a Pareto front, and plain line
//! charts (reward or coverage per iteration).
//!
//! A [`ChartSpec`] holds a title, axis labels, linear or logarithmic axes and any number of
//! [`Series`]; [`write_chart`] draws it with [plotters](https://docs.rs/plotters) into a PNG and
//! an SVG, each written to a temporary file beside its target and renamed over it.
//!
//! - **Series** get distinct colours (the Okabe–Ito colour-blind-safe palette) and markers
//!   (circle, square, triangle, diamond, cross), and a legend entry each. A series is drawn as
//!   markers, as a line through its points in the given order, or both ([`SeriesStyle`]).
//! - **Values a chart cannot show are dropped and counted, never a panic**: a point whose `x` or
//!   `y` is NaN or infinite, or not positive on a logarithmic axis. [`ChartSummary`] says how
//!   many were drawn and dropped, and the chart carries a footnote when any were dropped. Lines
//!   break at dropped points. Only a chart left with no point at all is an error.
//! - **The Pareto front** ([`ChartSpec::pareto_front`]) is computed over the drawn points of all
//!   series together, minimising both `x` and `y` (e.g. time and error): a black staircase
//!   bounds the dominated region (up and right of it) and each member is ringed.
//! - **Text uses an embedded font** (DejaVu Sans, Bitstream Vera licence, in `assets/`),
//!   registered with plotters' `ab_glyph` backend: the PNG does not depend on the fonts a
//!   machine has, and no fontconfig or freetype library is linked. The SVG names the
//!   `sans-serif` family and leaves the glyphs to the viewer.
//! - **Logarithmic axes** have their own tick placement: powers of ten, or 1-2-5 steps within a
//!   decade or two, or plain linear ticks when the range is narrower than that (plotters' own
//!   log axis shows no tick at all on a range without a power of ten).
//!
//! A line chart of values per iteration is [`Series::from_values`] in a spec without a front.

use plotters::coord::Shift;
use plotters::coord::ranged1d::{KeyPointHint, NoDefaultFormatting, Ranged, ValueFormatter};
use plotters::coord::types::RangedCoordf64;
use plotters::element::{Drawable, PointCollection};
use plotters::prelude::*;
use plotters::style::FontStyle;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters_backend::{BackendCoord, DrawingErrorKind};
use std::fs;
use std::io::{self, Write};
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use std::sync::atomic::{AtomicU64, Ordering};

/// One point of a [`Series`], optionally labelled on the chart.
#[derive(Clone, Debug, PartialEq)]
pub struct Point {
    /// Horizontal value.
    pub x: f64,
    /// Vertical value.
    pub y: f64,
    /// Text drawn beside the point (e.g. the probe count of a run), if any.
    pub label: Option<String>,
}

impl Point {
    /// An unlabelled point.
    pub fn new(x: f64, y: f64) -> Point {
        Point { x, y, label: None }
    }

    /// A point with a label drawn beside it.
    pub fn labelled(x: f64, y: f64, label: impl Into<String>) -> Point {
        Point {
            x,
            y,
            label: Some(label.into()),
        }
    }
}

/// How a series is drawn.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SeriesStyle {
    /// A marker at each point (scatter).
    #[default]
    Markers,
    /// A line through the points in their order, no markers.
    Line,
    /// A line through the points in their order, and a marker at each.
    LineAndMarkers,
}

/// A named set of points drawn in one colour and marker, with a legend entry.
#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    /// The name shown in the legend.
    pub name: String,
    /// The points, in the order a line joins them.
    pub points: Vec<Point>,
    /// Markers, a line, or both.
    pub style: SeriesStyle,
}

impl Series {
    /// A series of the given points.
    pub fn new(name: impl Into<String>, style: SeriesStyle, points: Vec<Point>) -> Series {
        Series {
            name: name.into(),
            points,
            style,
        }
    }

    /// A line of `values` against their index (`x = 0, 1, 2, …`): reward or coverage per
    /// iteration of an optimiser, for instance.
    pub fn from_values(name: impl Into<String>, values: &[f64]) -> Series {
        let points = values
            .iter()
            .enumerate()
            .map(|(i, &y)| Point::new(i as f64, y))
            .collect();
        Series::new(name, SeriesStyle::Line, points)
    }
}

/// A horizontal line across a chart ([`ChartSpec::floors`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Floor {
    /// The legend entry.
    pub name: String,
    /// Its height, in the vertical axis' units.
    pub y: f64,
}

/// Everything a chart shows. Build one with [`ChartSpec::new`] and set the public fields.
#[derive(Clone, Debug, PartialEq)]
pub struct ChartSpec {
    /// The title drawn above the plot.
    pub title: String,
    /// The horizontal axis' description (with its unit).
    pub x_label: String,
    /// The vertical axis' description (with its unit).
    pub y_label: String,
    /// Whether the horizontal axis is logarithmic (base 10).
    pub x_log: bool,
    /// Whether the vertical axis is logarithmic (base 10).
    pub y_log: bool,
    /// The series, drawn in order (later ones on top), each with its own colour and marker.
    pub series: Vec<Series>,
    /// Whether to draw the Pareto front (minimising `x` and `y`) over all series' points.
    pub pareto_front: bool,
    /// Horizontal lines across the data (e.g. a noise floor: errors near it cannot be told
    /// apart), each grey and dashed with a legend entry, never part of the Pareto front; the
    /// vertical axis is fitted to include them. A value that cannot be drawn (NaN, or ≤ 0 on
    /// a logarithmic axis) is left out.
    pub floors: Vec<Floor>,
    /// Width of both pictures in pixels (the SVG's user units), within
    /// [`MIN_CHART_SIDE`]`..=`[`MAX_CHART_SIDE`].
    pub width: u32,
    /// Height of both pictures in pixels, within the same range.
    pub height: u32,
}

/// The smallest chart side, in pixels, that leaves room for the axes and the plot.
pub const MIN_CHART_SIDE: u32 = 200;
/// The largest chart side in pixels.
pub const MAX_CHART_SIDE: u32 = 16384;

impl ChartSpec {
    /// A 1000 × 700 chart with linear axes, no series and no Pareto front.
    pub fn new(
        title: impl Into<String>,
        x_label: impl Into<String>,
        y_label: impl Into<String>,
    ) -> ChartSpec {
        ChartSpec {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            x_log: false,
            y_log: false,
            series: Vec::new(),
            pareto_front: false,
            floors: Vec::new(),
            width: 1000,
            height: 700,
        }
    }
}

/// What [`write_chart`] drew.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ChartSummary {
    /// Points drawn, over all series.
    pub points_drawn: usize,
    /// Points left out: a NaN or infinite coordinate, or a value ≤ 0 on a logarithmic axis.
    pub points_dropped: usize,
    /// The Pareto front's members as `(series index, point index)`, in increasing `x`; empty
    /// when the spec asks for no front.
    pub pareto_members: Vec<(usize, usize)>,
}

/// Why a chart could not be written.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ChartError {
    /// [`ChartSpec::width`] or [`ChartSpec::height`] is outside
    /// [`MIN_CHART_SIDE`]`..=`[`MAX_CHART_SIDE`].
    ///
    /// Fix: choose a size within the range (1000 × 700 suits a page).
    #[error(
        "chart size {width}×{height} is out of range: width and height must each be within {MIN_CHART_SIDE}..={MAX_CHART_SIDE} pixels"
    )]
    InvalidSize {
        /// The requested width.
        width: u32,
        /// The requested height.
        height: u32,
    },
    /// No point is left to draw: the spec has no series, the series are empty, or every point
    /// was dropped.
    ///
    /// Fix: pass at least one point with finite coordinates, positive on a logarithmic axis
    /// (or turn the logarithmic axis off if the data has zeros or negatives).
    #[error(
        "the chart has no point to draw ({dropped} dropped for a NaN or infinite value, or a value ≤ 0 on a logarithmic axis)"
    )]
    NothingToDraw {
        /// How many points were dropped.
        dropped: usize,
    },
    /// The PNG and SVG paths are the same file, so one would overwrite the other.
    ///
    /// Fix: give the two outputs different names (e.g. `chart.png` and `chart.svg`).
    #[error("the PNG and SVG outputs are the same path {path}")]
    SamePath {
        /// The path given twice.
        path: PathBuf,
    },
    /// plotters failed to draw (for instance it found no font); the message is plotters'.
    ///
    /// Fix: none on the caller's side beyond reporting it; it points at a bug here.
    #[error("could not draw the {format} chart: {message}")]
    Draw {
        /// `"PNG"` or `"SVG"`.
        format: &'static str,
        /// plotters' description of the failure.
        message: String,
    },
    /// The PNG could not be encoded.
    ///
    /// Fix: none on the caller's side beyond reporting it; the pixels come from plotters.
    #[error("could not encode the PNG chart {path}: {source}")]
    Encode {
        /// The PNG's target path.
        path: PathBuf,
        /// The encoder's error.
        source: image::ImageError,
    },
    /// Writing the file (its temporary file in the same folder, or the rename) failed.
    ///
    /// Fix: make sure the folder exists and is writable, and the disk is not full.
    #[error("could not write the chart {path}: {source}")]
    Write {
        /// The target path.
        path: PathBuf,
        /// The I/O error.
        source: io::Error,
    },
}

/// The indices of the points on the Pareto front that minimises both coordinates, in
/// increasing `x` (ties: increasing `y`, then increasing index).
///
/// A point is on the front when no other point is at least as good in both coordinates and
/// strictly better in one. So of points sharing an `x` only those with the smallest `y` can be
/// members (and likewise for `y`), and exact duplicates of a member are all members. Points
/// with a NaN or infinite coordinate are never members and take no part (they dominate
/// nothing). `-0.0` and `0.0` compare equal. Runs in `O(n log n)`.
///
/// ```
/// use probe_eval::chart::pareto_front;
/// // (time, error): 1 and 3 are dominated by 0 and 2; 4 is NaN.
/// let points = [(1.0, 5.0), (2.0, 6.0), (3.0, 1.0), (4.0, 1.0), (f64::NAN, 0.0)];
/// assert_eq!(pareto_front(&points), vec![0, 2]);
/// ```
pub fn pareto_front(points: &[(f64, f64)]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..points.len())
        .filter(|&i| points[i].0.is_finite() && points[i].1.is_finite())
        .collect();
    // All values are finite here, so `partial_cmp` is a total order (with -0.0 == 0.0).
    let compare = |a: f64, b: f64| a.partial_cmp(&b).unwrap_or(std::cmp::Ordering::Equal);
    order.sort_by(|&a, &b| {
        let (pa, pb) = (points[a], points[b]);
        compare(pa.0, pb.0)
            .then(compare(pa.1, pb.1))
            .then(a.cmp(&b))
    });
    let mut front = Vec::new();
    let mut last: Option<(f64, f64)> = None;
    for i in order {
        let (x, y) = points[i];
        // In this order every earlier point has x' ≤ x. The last member has the smallest y so
        // far (and the smallest x among those): the point is dominated exactly when that y is
        // smaller, or equal with a smaller x.
        let on_front = match last {
            None => true,
            Some((lx, ly)) => y < ly || (y == ly && x == lx),
        };
        if on_front {
            front.push(i);
            last = Some((x, y));
        }
    }
    front
}

/// Draws `spec` into a PNG at `png` and an SVG at `svg`, each written to a temporary file in
/// its folder and renamed over the target (an existing file is replaced whole or not at all).
///
/// Returns how many points were drawn and dropped and the Pareto front's members. Errors:
/// [`ChartError`] (size out of range, nothing to draw, same path twice, a write failure).
pub fn write_chart(spec: &ChartSpec, png: &Path, svg: &Path) -> Result<ChartSummary, ChartError> {
    if png == svg {
        return Err(ChartError::SamePath {
            path: png.to_path_buf(),
        });
    }
    let plan = Plan::new(spec)?;
    let (width, height) = (spec.width, spec.height);

    let mut pixels = vec![0u8; width as usize * height as usize * 3];
    {
        let backend = BitMapBackend::with_buffer(&mut pixels, (width, height));
        plan.draw(backend).map_err(|message| ChartError::Draw {
            format: "PNG",
            message,
        })?;
    }
    let mut svg_text = String::new();
    {
        let backend = SVGBackend::with_string(&mut svg_text, (width, height));
        plan.draw(backend).map_err(|message| ChartError::Draw {
            format: "SVG",
            message,
        })?;
    }

    let png_bytes = encode_png(&pixels, width, height).map_err(|source| ChartError::Encode {
        path: png.to_path_buf(),
        source,
    })?;
    write_atomically(png, &png_bytes).map_err(|source| ChartError::Write {
        path: png.to_path_buf(),
        source,
    })?;
    write_atomically(svg, svg_text.as_bytes()).map_err(|source| ChartError::Write {
        path: svg.to_path_buf(),
        source,
    })?;
    Ok(plan.summary)
}

// ---------------------------------------------------------------------------------------------
// Shared helpers (also used by `top_view`).

/// The embedded font: DejaVu Sans 2.37 (Bitstream Vera licence, `assets/LICENSE-DejaVu.txt`).
static FONT_BYTES: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");

/// The family name the embedded font is registered under; plotters' default family, and the
/// generic family SVG viewers resolve themselves.
pub(crate) const FONT_FAMILY: &str = "sans-serif";

/// Registers the embedded font with plotters (once per process); an error message if the
/// font does not parse, which would be a packaging bug.
pub(crate) fn ensure_font() -> Result<(), String> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| {
        plotters::style::register_font(FONT_FAMILY, FontStyle::Normal, FONT_BYTES).is_ok()
    });
    if ok {
        Ok(())
    } else {
        Err("the embedded font DejaVuSans.ttf could not be parsed".to_owned())
    }
}

/// Encodes tightly packed RGB8 pixels as a PNG in memory.
pub(crate) fn encode_png(pixels: &[u8], width: u32, height: u32) -> image::ImageResult<Vec<u8>> {
    use image::ImageEncoder;
    let mut bytes = Vec::new();
    image::codecs::png::PngEncoder::new(&mut bytes).write_image(
        pixels,
        width,
        height,
        image::ExtendedColorType::Rgb8,
    )?;
    Ok(bytes)
}

/// Writes `bytes` to a new temporary file in `path`'s folder, flushes it to disk and renames
/// it to `path`; the temporary file is removed if anything fails.
pub(crate) fn write_atomically(path: &Path, bytes: &[u8]) -> io::Result<()> {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let file_name = path.file_name().ok_or_else(|| {
        io::Error::new(
            io::ErrorKind::InvalidInput,
            "the path does not end in a file name",
        )
    })?;
    let folder = match path.parent() {
        Some(parent) if !parent.as_os_str().is_empty() => parent,
        _ => Path::new("."),
    };
    let temporary = folder.join(format!(
        ".{}.{}-{}.tmp",
        file_name.to_string_lossy(),
        std::process::id(),
        COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    let result = (|| {
        let mut file = fs::File::create(&temporary)?;
        file.write_all(bytes)?;
        file.sync_all()?;
        drop(file);
        fs::rename(&temporary, path)
    })();
    if result.is_err() {
        let _ = fs::remove_file(&temporary);
    }
    result
}

// ---------------------------------------------------------------------------------------------
// Layout.

/// The Okabe–Ito palette without black (kept for the Pareto front), yellow last.
const PALETTE: [RGBColor; 7] = [
    RGBColor(0, 114, 178),
    RGBColor(230, 159, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(86, 180, 233),
    RGBColor(213, 94, 0),
    RGBColor(240, 228, 66),
];

const FRONT_COLOUR: RGBColor = RGBColor(20, 20, 20);

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Marker {
    Circle,
    Square,
    Triangle,
    Diamond,
    Cross,
}

const MARKERS: [Marker; 5] = [
    Marker::Circle,
    Marker::Square,
    Marker::Triangle,
    Marker::Diamond,
    Marker::Cross,
];

/// A series' glyph: its marker (half-size `size` pixels), a short line through it, or both,
/// centred on `at`. Drawn straight on the backend so that it needs no boxed element.
#[derive(Clone, Debug)]
struct Glyph<C> {
    at: C,
    marker: Option<Marker>,
    size: i32,
    colour: RGBColor,
    /// Half-length and width of a horizontal line through the centre (legend entries of lines).
    line: Option<(i32, u32)>,
}

impl<'a, C: 'a> PointCollection<'a, C> for &'a Glyph<C> {
    type Point = &'a C;
    type IntoIter = std::iter::Once<&'a C>;

    fn point_iter(self) -> Self::IntoIter {
        std::iter::once(&self.at)
    }
}

impl<C, DB: DrawingBackend> Drawable<DB> for Glyph<C> {
    fn draw<I: Iterator<Item = BackendCoord>>(
        &self,
        mut positions: I,
        backend: &mut DB,
        _parent_dim: (u32, u32),
    ) -> Result<(), DrawingErrorKind<DB::ErrorType>> {
        let Some((x, y)) = positions.next() else {
            return Ok(());
        };
        if let Some((half, width)) = self.line {
            let style = self.colour.stroke_width(width);
            backend.draw_line((x - half, y), (x + half, y), &style)?;
        }
        let fill = self.colour.filled();
        let s = self.size;
        let scaled = |factor: f64| (s as f64 * factor).round() as i32;
        match self.marker {
            None => Ok(()),
            Some(Marker::Circle) => backend.draw_circle((x, y), s.max(1) as u32, &fill, true),
            Some(Marker::Square) => {
                let r = scaled(0.85);
                backend.draw_rect((x - r, y - r), (x + r, y + r), &fill, true)
            }
            Some(Marker::Triangle) => {
                let h = scaled(1.15);
                let base = y + scaled(0.86);
                backend.fill_polygon([(x, y - h), (x + h, base), (x - h, base)], &fill)
            }
            Some(Marker::Diamond) => {
                let h = scaled(1.2);
                backend.fill_polygon([(x, y - h), (x + h, y), (x, y + h), (x - h, y)], &fill)
            }
            Some(Marker::Cross) => {
                let edge = self.colour.stroke_width(scaled(0.5).max(2) as u32);
                backend.draw_line((x - s, y - s), (x + s, y + s), &edge)?;
                backend.draw_line((x - s, y + s), (x + s, y - s), &edge)
            }
        }
    }
}

/// A series after dropping what cannot be drawn.
struct PlannedSeries<'a> {
    name: &'a str,
    style: SeriesStyle,
    colour: RGBColor,
    marker: Marker,
    /// Drawn points with their labels.
    points: Vec<(f64, f64, Option<&'a str>)>,
    /// Maximal runs of consecutive drawn points, which lines join.
    runs: Vec<Vec<(f64, f64)>>,
}

/// A validated spec, ready to draw on any backend.
struct Plan<'a> {
    spec: &'a ChartSpec,
    series: Vec<PlannedSeries<'a>>,
    front: Vec<(f64, f64)>,
    floors: Vec<(&'a str, f64)>,
    x_range: (f64, f64),
    x_axis: Axis,
    y_axis: Axis,
    summary: ChartSummary,
}

impl<'a> Plan<'a> {
    fn new(spec: &'a ChartSpec) -> Result<Plan<'a>, ChartError> {
        let side = MIN_CHART_SIDE..=MAX_CHART_SIDE;
        if !side.contains(&spec.width) || !side.contains(&spec.height) {
            return Err(ChartError::InvalidSize {
                width: spec.width,
                height: spec.height,
            });
        }
        let drawable = |x: f64, y: f64| {
            x.is_finite() && y.is_finite() && (!spec.x_log || x > 0.0) && (!spec.y_log || y > 0.0)
        };
        let mut summary = ChartSummary::default();
        let mut series = Vec::with_capacity(spec.series.len());
        // Every drawn point with where it came from, for the Pareto front.
        let mut all: Vec<(f64, f64)> = Vec::new();
        let mut origin: Vec<(usize, usize)> = Vec::new();
        for (s, source) in spec.series.iter().enumerate() {
            let mut points = Vec::new();
            let mut runs: Vec<Vec<(f64, f64)>> = vec![Vec::new()];
            for (p, point) in source.points.iter().enumerate() {
                if drawable(point.x, point.y) {
                    points.push((point.x, point.y, point.label.as_deref()));
                    runs.last_mut()
                        .expect("never empty")
                        .push((point.x, point.y));
                    all.push((point.x, point.y));
                    origin.push((s, p));
                } else {
                    summary.points_dropped += 1;
                    if !runs.last().expect("never empty").is_empty() {
                        runs.push(Vec::new());
                    }
                }
            }
            runs.retain(|run| !run.is_empty());
            summary.points_drawn += points.len();
            series.push(PlannedSeries {
                name: &source.name,
                style: source.style,
                colour: PALETTE[s % PALETTE.len()],
                marker: MARKERS[s % MARKERS.len()],
                points,
                runs,
            });
        }
        if all.is_empty() {
            return Err(ChartError::NothingToDraw {
                dropped: summary.points_dropped,
            });
        }
        let mut front = Vec::new();
        if spec.pareto_front {
            for i in pareto_front(&all) {
                front.push(all[i]);
                summary.pareto_members.push(origin[i]);
            }
        }
        let floors: Vec<(&str, f64)> = spec
            .floors
            .iter()
            .filter(|f| f.y.is_finite() && (!spec.y_log || f.y > 0.0))
            .map(|f| (f.name.as_str(), f.y))
            .collect();
        let x_range = all.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |r, p| {
            (r.0.min(p.0), r.1.max(p.0))
        });
        let x_axis = Axis::fit(all.iter().map(|p| p.0), spec.x_log);
        let y_axis = Axis::fit(
            all.iter().map(|p| p.1).chain(floors.iter().map(|f| f.1)),
            spec.y_log,
        );
        Ok(Plan {
            spec,
            series,
            front,
            floors,
            x_range,
            x_axis,
            y_axis,
            summary,
        })
    }

    /// The corner of the plot the legend hides least data in: the one whose corner box (a
    /// third of the width, a quarter of the height) holds the fewest points and line samples,
    /// upper right first on ties.
    fn legend_corner(&self) -> SeriesLabelPosition {
        let mut samples: Vec<(f64, f64)> = Vec::new();
        for series in &self.series {
            samples.extend(series.points.iter().map(|&(x, y, _)| (x, y)));
            if series.style != SeriesStyle::Markers {
                for run in &series.runs {
                    for pair in run.windows(2) {
                        let (a, b) = (
                            (
                                self.x_axis.fraction(pair[0].0),
                                self.y_axis.fraction(pair[0].1),
                            ),
                            (
                                self.x_axis.fraction(pair[1].0),
                                self.y_axis.fraction(pair[1].1),
                            ),
                        );
                        for k in 1..8 {
                            let t = k as f64 / 8.0;
                            samples.push((a.0 + (b.0 - a.0) * t, a.1 + (b.1 - a.1) * t));
                        }
                    }
                }
            }
        }
        // Points are in data units, line samples already in fractions: bring points over.
        let point_count: usize = self.series.iter().map(|s| s.points.len()).sum();
        for sample in samples.iter_mut().take(point_count) {
            *sample = (
                self.x_axis.fraction(sample.0),
                self.y_axis.fraction(sample.1),
            );
        }
        let corners = [
            (SeriesLabelPosition::UpperRight, true, true),
            (SeriesLabelPosition::UpperLeft, false, true),
            (SeriesLabelPosition::LowerRight, true, false),
            (SeriesLabelPosition::LowerLeft, false, false),
        ];
        let inside = |(fx, fy): (f64, f64), right: bool, upper: bool| {
            let in_x = if right { fx > 0.62 } else { fx < 0.38 };
            let in_y = if upper { fy > 0.7 } else { fy < 0.3 };
            in_x && in_y
        };
        let mut best = (SeriesLabelPosition::UpperRight, usize::MAX);
        for (position, right, upper) in corners {
            let count = samples.iter().filter(|&&p| inside(p, right, upper)).count();
            if count < best.1 {
                best = (position, count);
            }
        }
        best.0
    }

    /// Draws the chart on `backend`; plotters' error as text.
    fn draw<DB: DrawingBackend>(&self, backend: DB) -> Result<(), String> {
        ensure_font()?;
        let root = backend.into_drawing_area();
        self.draw_on(&root).map_err(|e| e.to_string())?;
        root.present().map_err(|e| e.to_string())
    }

    fn draw_on<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
    ) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
        let spec = self.spec;
        // Sizes scale with the chart so that a larger chart is not a smaller-looking one.
        let scale = (spec.width.min(spec.height * 10 / 7) as f64 / 1000.0).max(0.5);
        let px = |v: f64| (v * scale).round().max(1.0);
        let font = |size: f64| (FONT_FAMILY, px(size)).into_font();

        root.fill(&WHITE)?;
        let footnote = (self.summary.points_dropped > 0).then(|| {
            format!(
                "{} point{} not shown (NaN or infinite, or ≤ 0 on a logarithmic axis)",
                self.summary.points_dropped,
                if self.summary.points_dropped == 1 {
                    ""
                } else {
                    "s"
                }
            )
        });
        let footnote_height = if footnote.is_some() {
            px(24.0) as u32
        } else {
            0
        };
        let (plot_area, note_area) =
            root.split_vertically(spec.height.saturating_sub(footnote_height));

        let mut chart = ChartBuilder::on(&plot_area)
            .caption(&spec.title, font(30.0))
            .margin(px(18.0) as u32)
            .x_label_area_size(px(62.0) as u32)
            .y_label_area_size(px(86.0) as u32)
            .build_cartesian_2d(self.x_axis.clone(), self.y_axis.clone())?;

        chart
            .configure_mesh()
            .x_desc(&spec.x_label)
            .y_desc(&spec.y_label)
            .axis_desc_style(font(22.0))
            .label_style(font(17.0))
            .bold_line_style(RGBColor(200, 200, 200).stroke_width(1))
            .light_line_style(RGBColor(236, 236, 236).stroke_width(1))
            .axis_style(RGBColor(60, 60, 60).stroke_width(1))
            .x_labels(10)
            .y_labels(10)
            .x_max_light_lines(if self.x_axis.log { 10 } else { 2 })
            .y_max_light_lines(if self.y_axis.log { 10 } else { 2 })
            .draw()?;

        let marker_size = px(5.0) as i32;
        let line_width = px(2.5) as u32;
        for series in &self.series {
            let colour = series.colour;
            let with_line = series.style != SeriesStyle::Markers;
            let with_markers = series.style != SeriesStyle::Line;
            if with_line {
                for run in &series.runs {
                    chart.draw_series(LineSeries::new(
                        run.iter().copied(),
                        colour.stroke_width(line_width),
                    ))?;
                }
            }
            if with_markers {
                chart.draw_series(series.points.iter().map(|&(x, y, _)| Glyph {
                    at: (x, y),
                    marker: Some(series.marker),
                    size: marker_size,
                    colour,
                    line: None,
                }))?;
            }
            let labels = series
                .points
                .iter()
                .filter_map(|&(x, y, label)| label.map(|text| (x, y, text)));
            let label_font = font(14.0)
                .color(&RGBColor(40, 40, 40))
                .pos(Pos::new(HPos::Left, VPos::Bottom));
            let offset = marker_size + px(2.0) as i32;
            chart.draw_series(labels.map(|(x, y, text)| {
                EmptyElement::at((x, y))
                    + Text::new(text.to_owned(), (offset, -offset), label_font.clone())
            }))?;
            // The legend entry: an empty series carrying the label and the glyph.
            let (marker, half) = (series.marker, px(14.0) as i32);
            chart
                .draw_series(std::iter::empty::<Circle<(f64, f64), i32>>())?
                .label(series.name)
                .legend(move |(lx, ly)| Glyph {
                    at: (lx + half, ly),
                    marker: with_markers.then_some(marker),
                    size: marker_size,
                    colour,
                    line: with_line.then_some((half, line_width)),
                });
        }

        for (i, &(name, y)) in self.floors.iter().enumerate() {
            // Floors told apart by shade and dash: the first grey with long dashes, the
            // next dark with short ones.
            let (shade, segments) = if i % 2 == 0 { (120, 24) } else { (40, 60) };
            let style = RGBColor(shade, shade, shade).stroke_width(px(2.0) as u32);
            let (x0, x1) = self.x_range;
            // Dashed: every other segment drawn (evenly in the axis' own scale).
            let at = |t: f64| {
                if self.x_axis.log {
                    (x0.ln() + (x1.ln() - x0.ln()) * t).exp()
                } else {
                    x0 + (x1 - x0) * t
                }
            };
            let dashes = (0..segments).step_by(2).map(|k| {
                vec![
                    (at(f64::from(k) / f64::from(segments)), y),
                    (at(f64::from(k + 1) / f64::from(segments)), y),
                ]
            });
            let half = px(14.0) as i32;
            // The legend's glyph: two long dashes, or four short ones.
            let long = i % 2 == 0;
            let dash = move |from: i32, to: i32| PathElement::new(vec![(from, 0), (to, 0)], style);
            chart
                .draw_series(dashes.map(|d| PathElement::new(d, style)))?
                .label(name)
                .legend(move |(lx, ly)| {
                    // Four pieces either way (one element type): the long dashes are two
                    // pieces each, end to end.
                    let (q, t) = (half / 4, half / 3);
                    let [a, b, c, d] = if long {
                        [(-half, -2 * t), (-2 * t, -t), (t, 2 * t), (2 * t, half)]
                    } else {
                        [(-half, -3 * q), (-2 * q, -q), (q, 2 * q), (3 * q, half)]
                    };
                    EmptyElement::at((lx + half, ly))
                        + dash(a.0, a.1)
                        + dash(b.0, b.1)
                        + dash(c.0, c.1)
                        + dash(d.0, d.1)
                });
        }

        if !self.front.is_empty() {
            // The staircase bounding the dominated region: right along a member's y to the
            // next member's x, then down to its y.
            let mut steps = Vec::with_capacity(self.front.len() * 2);
            for (i, &(x, y)) in self.front.iter().enumerate() {
                if i > 0 {
                    steps.push((x, self.front[i - 1].1));
                }
                steps.push((x, y));
            }
            let front_style = FRONT_COLOUR.stroke_width(px(2.0) as u32);
            chart.draw_series(LineSeries::new(steps, front_style))?;
            let ring = marker_size + px(4.0) as i32;
            let ring_style = FRONT_COLOUR.stroke_width(px(2.0) as u32);
            let count = self.front.len();
            let half = px(14.0) as i32;
            chart
                .draw_series(
                    self.front
                        .iter()
                        .map(|&(x, y)| Circle::new((x, y), ring, ring_style)),
                )?
                .label(format!(
                    "Pareto front ({count} point{})",
                    if count == 1 { "" } else { "s" }
                ))
                .legend(move |(lx, ly)| {
                    EmptyElement::at((lx + half, ly))
                        + PathElement::new(
                            vec![
                                (-half, half / 2),
                                (0, half / 2),
                                (0, -half / 2),
                                (half, -half / 2),
                            ],
                            front_style,
                        )
                        + Circle::new((0, -half / 2), ring / 2 + 1, ring_style)
                });
        }

        chart
            .configure_series_labels()
            .position(self.legend_corner())
            .margin(px(10.0) as u32)
            .legend_area_size(px(36.0) as u32)
            .label_font(font(17.0))
            .background_style(WHITE.mix(0.85))
            .border_style(RGBColor(150, 150, 150))
            .draw()?;

        if let Some(note) = footnote {
            let style = font(15.0)
                .color(&RGBColor(90, 90, 90))
                .pos(Pos::new(HPos::Left, VPos::Center));
            note_area.draw(&Text::new(
                note,
                (px(18.0) as i32, footnote_height as i32 / 2),
                style,
            ))?;
        }
        Ok(())
    }
}

// ---------------------------------------------------------------------------------------------
// Axes.

/// A linear or base-10 logarithmic axis over `start..end` with its own ticks and labels.
#[derive(Clone, Debug)]
struct Axis {
    log: bool,
    start: f64,
    end: f64,
}

impl Axis {
    /// An axis over `values` (all drawable: finite, and positive if `log`) with a margin.
    fn fit(values: impl Iterator<Item = f64>, log: bool) -> Axis {
        let (mut min, mut max) = (f64::INFINITY, f64::NEG_INFINITY);
        for v in values {
            min = min.min(v);
            max = max.max(v);
        }
        if log {
            let (start, end) = if max > min {
                let pad = (max / min).powf(0.06);
                (min / pad, max * pad)
            } else {
                (min / 2.0, max * 2.0)
            };
            Axis {
                log: true,
                start,
                end,
            }
        } else {
            let span = max - min;
            let pad = if span > 0.0 {
                span * 0.06
            } else {
                (min.abs() * 0.1).max(1.0)
            };
            Axis {
                log: false,
                start: min - pad,
                end: max + pad,
            }
        }
    }

    /// The position of `value` along the axis, 0 at `start` and 1 at `end`.
    fn fraction(&self, value: f64) -> f64 {
        if self.log {
            (value.log10() - self.start.log10()) / (self.end.log10() - self.start.log10())
        } else {
            (value - self.start) / (self.end - self.start)
        }
    }

    /// Tick values for at most `max_points` ticks; `light` asks for minor grid lines too.
    fn ticks(&self, max_points: usize, light: bool) -> Vec<f64> {
        let linear = |max_points: usize| {
            let coord = RangedCoordf64::from(self.start..self.end);
            coord.key_points(max_points)
        };
        if !self.log {
            return linear(max_points);
        }
        let max_points = max_points.max(2);
        let (start, end) = (self.start, self.end);
        let tolerance = 1e-9;
        let within = |v: f64| v >= start * (1.0 - tolerance) && v <= end * (1.0 + tolerance);
        let first = start.log10().floor() as i32;
        let last = end.log10().ceil() as i32;
        let decades = |multipliers: &[f64], step: usize| -> Vec<f64> {
            (first..=last)
                .step_by(step)
                .flat_map(|e| multipliers.iter().map(move |m| m * 10f64.powi(e)))
                .filter(|&v| within(v))
                .collect()
        };
        let fine: Vec<f64> = decades(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0], 1);
        if light && fine.len() <= max_points && fine.len() >= 2 {
            return fine;
        }
        let powers = decades(&[1.0], 1);
        if powers.len() >= 3 {
            if powers.len() <= max_points {
                return powers;
            }
            // Too many decades: every `step`-th power of ten.
            let step = powers.len().div_ceil(max_points);
            return decades(&[1.0], step);
        }
        let one_two_five = decades(&[1.0, 2.0, 5.0], 1);
        if one_two_five.len() >= 3 && one_two_five.len() <= max_points {
            return one_two_five;
        }
        if fine.len() >= 3 && fine.len() <= max_points {
            return fine;
        }
        // Narrower than a few steps of a decade: plain ticks, still placed logarithmically.
        linear(max_points)
    }
}

impl Ranged for Axis {
    type FormatOption = NoDefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        // Values off the axis (and the log of a value ≤ 0, which drawn points never have) are
        // clamped well outside the plot, where plotters clips them.
        let t = self.fraction(*value);
        let t = if t.is_nan() { -1.0 } else { t.clamp(-1.0, 2.0) };
        (limit.0 as f64 + t * (limit.1 - limit.0) as f64).round() as i32
    }

    fn key_points<Hint: KeyPointHint>(&self, hint: Hint) -> Vec<f64> {
        self.ticks(hint.max_num_points(), hint.weight().allow_light_points())
    }

    fn range(&self) -> Range<f64> {
        self.start..self.end
    }
}

impl ValueFormatter<f64> for Axis {
    fn format(value: &f64) -> String {
        format_significant(*value, 3)
    }

    fn format_ext(&self, value: &f64) -> String {
        if self.log {
            return format_significant(*value, 3);
        }
        // Linear ticks: as many decimals as the tick spacing (about a tenth of the span) needs.
        let step = (self.end - self.start).abs() / 10.0;
        if value.abs() >= 1e6 || (value.abs() < 1e-3 && *value != 0.0) {
            return format_significant(*value, 3);
        }
        let decimals = if step > 0.0 {
            (-(step.log10().floor()) as i32 + 1).clamp(0, 8) as usize
        } else {
            3
        };
        trim_decimals(format!("{value:.decimals$}"))
    }
}

/// `value` with `digits` significant digits, in scientific notation when very large or small,
/// without trailing zeros: `0.25`, `1500`, `3e-5`, `1.2e7`.
fn format_significant(value: f64, digits: usize) -> String {
    if value == 0.0 {
        return "0".to_owned();
    }
    let magnitude = value.abs().log10().floor() as i32;
    if !(-3..6).contains(&magnitude) {
        let text = format!("{:.*e}", digits.saturating_sub(1), value);
        return match text.split_once('e') {
            Some((mantissa, exponent)) => {
                format!("{}e{exponent}", trim_decimals(mantissa.to_owned()))
            }
            None => text,
        };
    }
    let decimals = (digits as i32 - 1 - magnitude).max(0) as usize;
    trim_decimals(format!("{value:.decimals$}"))
}

/// Removes trailing zeros after a decimal point, and the point if nothing follows it.
fn trim_decimals(text: String) -> String {
    if !text.contains('.') {
        return text;
    }
    let trimmed = text.trim_end_matches('0').trim_end_matches('.');
    if trimmed == "-0" {
        "0".to_owned()
    } else {
        trimmed.to_owned()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn significant_formatting() {
        assert_eq!(format_significant(0.25, 3), "0.25");
        assert_eq!(format_significant(1500.0, 3), "1500");
        assert_eq!(format_significant(3e-5, 3), "3e-5");
        assert_eq!(format_significant(1.234e7, 3), "1.23e7");
        assert_eq!(format_significant(0.000_300_000_000_000_03, 3), "3e-4");
        assert_eq!(format_significant(-2.0, 3), "-2");
        assert_eq!(format_significant(0.0, 3), "0");
    }

    #[test]
    fn log_ticks_span_decades_or_fall_back() {
        let wide = Axis {
            log: true,
            start: 0.5,
            end: 2000.0,
        };
        assert_eq!(wide.ticks(10, false), vec![1.0, 10.0, 100.0, 1000.0]);
        let many = Axis {
            log: true,
            start: 1e-12,
            end: 1e12,
        };
        let ticks = many.ticks(6, false);
        assert!(ticks.len() <= 6 && ticks.len() >= 3, "{ticks:?}");
        // Within one decade, without a power of ten inside: 1-2-5 or 1..9 steps.
        let narrow = Axis {
            log: true,
            start: 1.5,
            end: 9.5,
        };
        assert_eq!(
            narrow.ticks(10, false),
            vec![2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0]
        );
        // Two decades: 1-2-5 steps.
        let two = Axis {
            log: true,
            start: 1.5,
            end: 60.0,
        };
        assert_eq!(two.ticks(10, false), vec![2.0, 5.0, 10.0, 20.0, 50.0]);
        // Narrower still: linear ticks, all inside the range.
        let tiny = Axis {
            log: true,
            start: 2.1,
            end: 2.9,
        };
        let ticks = tiny.ticks(8, false);
        assert!(ticks.len() >= 2, "{ticks:?}");
        assert!(ticks.iter().all(|&t| (2.1..=2.9).contains(&t)), "{ticks:?}");
    }

    #[test]
    fn axis_maps_log_values_proportionally() {
        let axis = Axis {
            log: true,
            start: 1.0,
            end: 100.0,
        };
        assert_eq!(axis.map(&10.0, (0, 1000)), 500);
        assert_eq!(axis.map(&1.0, (0, 1000)), 0);
        // Not drawable on a log axis: mapped outside, no panic.
        assert!(axis.map(&0.0, (0, 1000)) < 0);
        assert!(axis.map(&f64::NAN, (0, 1000)) < 0);
    }

    #[test]
    fn atomic_write_replaces_and_leaves_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.bin");
        write_atomically(&path, b"first").unwrap();
        write_atomically(&path, b"second").unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"second");
        let names: Vec<_> = fs::read_dir(dir.path()).unwrap().collect();
        assert_eq!(names.len(), 1);
        // A folder that does not exist: an error, and nothing left behind.
        let missing = dir.path().join("no/such/folder/out.bin");
        assert!(write_atomically(&missing, b"x").is_err());
    }
}
