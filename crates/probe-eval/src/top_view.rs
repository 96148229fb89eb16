//! A top view of a scene with probes drawn over it, as a PNG.
//!
//! [`write_top_view`] renders an orthographic view from above (looking down `−Y`, `+X` to the
//! right, `−Z` up the picture, as a map with north at `−Z`) of the scene's `X–Z` extent,
//! widened to take in every probe and padded by 2 %. The picture's width is given; the map's
//! height follows from the extent's aspect, and a legend strip is added under it.
//!
//! - **Shading**: one ray straight down per sample (2 × 2 samples per pixel by default) with
//!   [`Scene::closest_hit`], rows spread over rayon. A surface is drawn in its material's base
//!   colour (emitters in their clamped emission) times a height shade (higher is lighter: 60 %
//!   at the bottom of the scene, 100 % at the top of the view) times a soft `N·L` term (light
//!   from the upper left of the picture).
//! - **Sections**: a single-sided surface met from behind is drawn as dark hatching, as cut
//!   walls are in floor plans. With [`TopViewOptions::cut_height`] the rays start at the cut,
//!   so roofs and ceilings above it vanish and walls, pillars and slabs the cut passes through
//!   show as hatched sections. Without a cut a view of a closed room shows its ceiling from
//!   above; the built-in `cornell` box, whose ceiling faces down into the box, shows it as a
//!   section: give a cut to see inside.
//! - **Probes**: filled circles with a dark outline and a white halo, so that they read on any
//!   background, coloured by height on a blue–teal–yellow–orange–red ramp over the scene's
//!   height; higher probes are drawn over lower ones, probes above the cut get a dark centre
//!   dot, and with [`TopViewOptions::number_probes`] each carries its index. A second set
//!   ([`TopViewOptions::comparison`], e.g. the regular grid) is drawn under them as magenta
//!   squares.
//! - **Legend**: the two sets with their counts, the height ramp with its range in metres,
//!   the cut height and a caption, in the embedded font (see [`crate::chart`]).
//!
//! The PNG is written to a temporary file beside the target and renamed over it.

use crate::chart::{FONT_FAMILY, encode_png, ensure_font, write_atomically};
use glam::{Vec2, Vec3};
use image::RgbImage;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use probe_scene::{Ray, Scene};
use rayon::prelude::*;
use std::io;
use std::path::{Path, PathBuf};

/// The largest picture side in pixels.
pub const MAX_TOP_VIEW_SIDE: u32 = 16384;
/// The smallest picture width in pixels.
pub const MIN_TOP_VIEW_WIDTH: u32 = 16;

/// How [`write_top_view`] draws. [`Default`] gives a 1000-pixel-wide view without a cut.
#[derive(Clone, Debug, PartialEq)]
pub struct TopViewOptions {
    /// The picture's width in pixels, within [`MIN_TOP_VIEW_WIDTH`]`..=`[`MAX_TOP_VIEW_SIDE`].
    pub width: u32,
    /// Ignore geometry above this height (metres): rays start here, so roofs and ceilings do
    /// not hide the interior. `None` starts them above the scene.
    pub cut_height: Option<f32>,
    /// Write each probe's index (its position in the slice) beside it.
    pub number_probes: bool,
    /// The probes' radius in pixels; `None` picks one from the width (`width / 150`, at least
    /// 3).
    pub probe_radius: Option<f32>,
    /// A second probe set drawn for comparison (e.g. a regular grid), as magenta squares.
    pub comparison: Vec<Vec3>,
    /// The legend's name for the probes.
    pub probes_name: String,
    /// The legend's name for the comparison set.
    pub comparison_name: String,
    /// A line of text at the end of the legend (scene name, method, settings…).
    pub caption: Option<String>,
    /// Whether to add the legend strip under the map.
    pub legend: bool,
    /// Four rays per pixel (2 × 2) instead of one, for smooth edges.
    pub antialias: bool,
    /// Boxes of a region of interest, outlined in orange under the probes (their `x`–`z`
    /// footprint).
    pub regions: Vec<probe_scene::Aabb>,
}

impl Default for TopViewOptions {
    fn default() -> TopViewOptions {
        TopViewOptions {
            width: 1000,
            cut_height: None,
            number_probes: false,
            probe_radius: None,
            comparison: Vec::new(),
            probes_name: "probes".to_owned(),
            comparison_name: "grid".to_owned(),
            caption: None,
            legend: true,
            antialias: true,
            regions: Vec::new(),
        }
    }
}

/// Where things landed in a top view: the picture's size and the world region it shows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TopViewLayout {
    /// Picture width in pixels.
    pub width: u32,
    /// Height of the map part (the rows showing the scene), in pixels.
    pub map_height: u32,
    /// Picture height in pixels: the map plus the legend strip.
    pub height: u32,
    /// The world `(x, z)` at the map's top-left corner.
    pub region_min: Vec2,
    /// The world `(x, z)` at the map's bottom-right corner.
    pub region_max: Vec2,
}

impl TopViewLayout {
    /// The picture position of a world point (its height ignored), in pixels from the top-left
    /// corner: pixel `(i, j)` covers `[i, i + 1) × [j, j + 1)`.
    pub fn project(&self, point: Vec3) -> Vec2 {
        let size = self.region_max - self.region_min;
        Vec2::new(
            (point.x - self.region_min.x) / size.x * self.width as f32,
            (point.z - self.region_min.y) / size.y * self.map_height as f32,
        )
    }

    /// The world `(x, z)` at a picture position (the inverse of [`TopViewLayout::project`]).
    pub fn unproject(&self, pixel: Vec2) -> Vec2 {
        let size = self.region_max - self.region_min;
        self.region_min
            + Vec2::new(
                pixel.x / self.width as f32 * size.x,
                pixel.y / self.map_height as f32 * size.y,
            )
    }
}

/// Why a top view could not be drawn or written.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum TopViewError {
    /// The width is outside [`MIN_TOP_VIEW_WIDTH`]`..=`[`MAX_TOP_VIEW_SIDE`], or the height it
    /// implies (from the scene's aspect) is above [`MAX_TOP_VIEW_SIDE`].
    ///
    /// Fix: choose a width within the range; for a very long, narrow scene, a smaller width.
    #[error(
        "top view size {width}×{height} is out of range: the width must be within {MIN_TOP_VIEW_WIDTH}..={MAX_TOP_VIEW_SIDE} pixels and the height (from the scene's aspect) at most {MAX_TOP_VIEW_SIDE}"
    )]
    InvalidSize {
        /// The requested width.
        width: u32,
        /// The height it implies.
        height: u32,
    },
    /// The scene has no triangles, so there is nothing to frame.
    ///
    /// Fix: load a scene with geometry.
    #[error("the scene {scene:?} has no geometry to draw a top view of")]
    EmptyScene {
        /// The scene's name.
        scene: String,
    },
    /// The view has no extent along `x` or `z`: every triangle and probe lies on one vertical
    /// line.
    ///
    /// Fix: such a scene has no top view; check the scene's units and orientation (`+Y` up).
    #[error("the scene {scene:?} has no extent along x or z seen from above")]
    DegenerateView {
        /// The scene's name.
        scene: String,
    },
    /// A probe position has a NaN or infinite coordinate.
    ///
    /// Fix: drop or repair that probe before drawing.
    #[error("{set} probe {index} is not finite: {position}")]
    NonFiniteProbe {
        /// Which set: the probes' or the comparison set's name.
        set: String,
        /// Its index in that set.
        index: usize,
        /// The position given.
        position: Vec3,
    },
    /// [`TopViewOptions::cut_height`] is NaN or infinite.
    ///
    /// Fix: pass a finite height in metres, or `None` for no cut.
    #[error("cut height {cut_height} is not finite")]
    InvalidCutHeight {
        /// The value given.
        cut_height: f32,
    },
    /// [`TopViewOptions::probe_radius`] is not a finite number in `0.5..=200` pixels.
    ///
    /// Fix: pass a radius in that range, or `None` for the automatic one.
    #[error("probe radius {radius} px is out of range: it must be within 0.5..=200 pixels")]
    InvalidProbeRadius {
        /// The value given.
        radius: f32,
    },
    /// plotters failed to draw the probes or the legend; the message is plotters'.
    ///
    /// Fix: none on the caller's side beyond reporting it; it points at a bug here.
    #[error("could not draw the top view's overlay: {message}")]
    Draw {
        /// plotters' description of the failure.
        message: String,
    },
    /// The PNG could not be encoded.
    ///
    /// Fix: none on the caller's side beyond reporting it.
    #[error("could not encode the top view {path}: {source}")]
    Encode {
        /// The target path.
        path: PathBuf,
        /// The encoder's error.
        source: image::ImageError,
    },
    /// Writing the file (its temporary file in the same folder, or the rename) failed.
    ///
    /// Fix: make sure the folder exists and is writable, and the disk is not full.
    #[error("could not write the top view {path}: {source}")]
    Write {
        /// The target path.
        path: PathBuf,
        /// The I/O error.
        source: io::Error,
    },
}

/// Renders the top view of `scene` with `probes` over it (see the [module](self) doc) and
/// writes it as a PNG to `png`, through a temporary file renamed over the target.
///
/// Returns the layout, whose [`TopViewLayout::project`] gives each probe's pixel.
pub fn write_top_view(
    scene: &Scene,
    probes: &[Vec3],
    options: &TopViewOptions,
    png: &Path,
) -> Result<TopViewLayout, TopViewError> {
    let (image, layout) = render_top_view(scene, probes, options)?;
    let bytes = encode_png(image.as_raw(), image.width(), image.height()).map_err(|source| {
        TopViewError::Encode {
            path: png.to_path_buf(),
            source,
        }
    })?;
    write_atomically(png, &bytes).map_err(|source| TopViewError::Write {
        path: png.to_path_buf(),
        source,
    })?;
    Ok(layout)
}

/// Renders the top view in memory (what [`write_top_view`] writes), with its layout.
pub fn render_top_view(
    scene: &Scene,
    probes: &[Vec3],
    options: &TopViewOptions,
) -> Result<(RgbImage, TopViewLayout), TopViewError> {
    let view = View::new(scene, probes, options)?;
    let layout = view.layout;
    let mut pixels = vec![255u8; layout.width as usize * layout.height as usize * 3];
    view.shade_map(
        scene,
        &mut pixels[..layout.width as usize * layout.map_height as usize * 3],
    );
    {
        let backend = BitMapBackend::with_buffer(&mut pixels, (layout.width, layout.height));
        let root = backend.into_drawing_area();
        ensure_font().map_err(|message| TopViewError::Draw { message })?;
        view.draw_overlay(&root, probes, options)
            .map_err(|e| TopViewError::Draw {
                message: e.to_string(),
            })?;
        root.present().map_err(|e| TopViewError::Draw {
            message: e.to_string(),
        })?;
    }
    let image = RgbImage::from_raw(layout.width, layout.height, pixels)
        .expect("the buffer holds width × height RGB pixels");
    Ok((image, layout))
}

/// A validated view: layout, heights and probe size.
struct View {
    layout: TopViewLayout,
    /// Where rays start (the cut, or just above the scene).
    top: f32,
    /// The bottom of the scene, for the height shade.
    ground: f32,
    /// The scene's height range, for the probes' colour ramp.
    height_range: (f32, f32),
    cut: Option<f32>,
    probe_radius: f32,
    antialias: bool,
    /// The legend's items, laid out in rows that fit the width.
    legend_rows: Vec<Vec<LegendItem>>,
    /// The legend's font size and row height in pixels.
    legend_font: f64,
    legend_row: u32,
}

/// One entry of the legend strip.
#[derive(Clone, Debug, PartialEq)]
enum LegendItem {
    /// The probes' glyph and a text.
    Probes(String),
    /// The comparison set's glyph and a text.
    Comparison(String),
    /// The height ramp between two texts.
    Ramp(String, String),
    /// Plain text.
    Text(String),
}

/// Linear RGB of the background where rays hit nothing.
const BACKGROUND: Vec3 = Vec3::new(0.80, 0.84, 0.88);
/// The two linear greys of the section hatching.
const SECTION_DARK: f32 = 0.018;
const SECTION_LIGHT: f32 = 0.055;
/// The hatching's period in pixels.
const HATCH_PERIOD: f32 = 7.0;
const OUTLINE: RGBColor = RGBColor(25, 25, 30);
const COMPARISON_COLOUR: RGBColor = RGBColor(220, 40, 200);
const REGION_COLOUR: RGBColor = RGBColor(240, 130, 0);

impl View {
    fn new(scene: &Scene, probes: &[Vec3], options: &TopViewOptions) -> Result<View, TopViewError> {
        if !(MIN_TOP_VIEW_WIDTH..=MAX_TOP_VIEW_SIDE).contains(&options.width) {
            return Err(TopViewError::InvalidSize {
                width: options.width,
                height: 0,
            });
        }
        let sets = [
            (&options.probes_name, probes),
            (&options.comparison_name, options.comparison.as_slice()),
        ];
        for (name, set) in sets {
            if let Some(index) = set.iter().position(|p| !p.is_finite()) {
                return Err(TopViewError::NonFiniteProbe {
                    set: name.clone(),
                    index,
                    position: set[index],
                });
            }
        }
        if let Some(cut_height) = options.cut_height.filter(|c| !c.is_finite()) {
            return Err(TopViewError::InvalidCutHeight { cut_height });
        }
        if let Some(radius) = options
            .probe_radius
            .filter(|r| !(r.is_finite() && (0.5..=200.0).contains(r)))
        {
            return Err(TopViewError::InvalidProbeRadius { radius });
        }
        let bounds = scene.bounds();
        if scene.triangles().is_empty() || bounds.is_empty() {
            return Err(TopViewError::EmptyScene {
                scene: scene.name().to_owned(),
            });
        }
        let mut min = Vec2::new(bounds.min.x, bounds.min.z);
        let mut max = Vec2::new(bounds.max.x, bounds.max.z);
        let corners = options.regions.iter().flat_map(|b| [b.min, b.max]);
        for p in probes
            .iter()
            .chain(&options.comparison)
            .copied()
            .chain(corners)
        {
            min = min.min(Vec2::new(p.x, p.z));
            max = max.max(Vec2::new(p.x, p.z));
        }
        let extent = max - min;
        if !(extent.x > 0.0 && extent.y > 0.0) {
            return Err(TopViewError::DegenerateView {
                scene: scene.name().to_owned(),
            });
        }
        let pad = extent.max_element() * 0.02;
        let (region_min, region_max) = (min - pad, max + pad);
        let size = region_max - region_min;
        let width = options.width;
        let map_height = (width as f64 * size.y as f64 / size.x as f64)
            .round()
            .max(1.0);
        let legend_font = (width as f64 / 70.0).clamp(11.0, 22.0).round();
        let legend_row = (legend_font * 1.9).round() as u32;
        let legend_rows = if options.legend {
            ensure_font().map_err(|message| TopViewError::Draw { message })?;
            let items = legend_items(probes, options, (bounds.min.y, bounds.max.y));
            lay_out_legend(items, width, legend_font)
        } else {
            Vec::new()
        };
        let legend_height = legend_row * legend_rows.len() as u32;
        let height = map_height + legend_height as f64;
        if height > MAX_TOP_VIEW_SIDE as f64 {
            return Err(TopViewError::InvalidSize {
                width,
                height: height.min(u32::MAX as f64) as u32,
            });
        }
        let map_height = map_height as u32;
        let scene_top = bounds.max.y + 1e-3 * (1.0 + bounds.max.y.abs());
        let top = options.cut_height.map_or(scene_top, |c| c.min(scene_top));
        let probe_radius = options
            .probe_radius
            .unwrap_or_else(|| (width as f32 / 150.0).max(3.0));
        Ok(View {
            layout: TopViewLayout {
                width,
                map_height,
                height: height as u32,
                region_min,
                region_max,
            },
            top,
            ground: bounds.min.y,
            height_range: (bounds.min.y, bounds.max.y),
            cut: options.cut_height,
            probe_radius,
            antialias: options.antialias,
            legend_rows,
            legend_font,
            legend_row,
        })
    }

    /// Fills the map rows of `pixels` (RGB8, `width × map_height`) with the shaded scene.
    fn shade_map(&self, scene: &Scene, pixels: &mut [u8]) {
        let width = self.layout.width as usize;
        let offsets: &[Vec2] = if self.antialias {
            &[
                Vec2::new(0.25, 0.25),
                Vec2::new(0.75, 0.25),
                Vec2::new(0.25, 0.75),
                Vec2::new(0.75, 0.75),
            ]
        } else {
            &[Vec2::new(0.5, 0.5)]
        };
        pixels
            .par_chunks_mut(width * 3)
            .enumerate()
            .for_each(|(row, row_pixels)| {
                for column in 0..width {
                    let mut sum = Vec3::ZERO;
                    for offset in offsets {
                        let at = Vec2::new(column as f32, row as f32) + *offset;
                        sum += self.shade_sample(scene, at);
                    }
                    let colour = sum / offsets.len() as f32;
                    let rgb = &mut row_pixels[column * 3..column * 3 + 3];
                    for (channel, value) in rgb.iter_mut().zip(colour.to_array()) {
                        *channel = linear_to_srgb8(value);
                    }
                }
            });
    }

    /// The linear colour seen at picture position `at` (in pixels).
    fn shade_sample(&self, scene: &Scene, at: Vec2) -> Vec3 {
        let world = self.layout.unproject(at);
        let ray = Ray::new(Vec3::new(world.x, self.top, world.y), -Vec3::Y);
        let Some(hit) = scene.closest_hit(&ray, f32::INFINITY) else {
            return BACKGROUND;
        };
        let material = &scene.materials()[hit.material as usize];
        let seen_from_behind = !hit.front_face && !material.double_sided;
        if seen_from_behind || (self.cut.is_some() && inside_solid(scene, ray.origin)) {
            // Under a one-sided surface, or inside a solid the cut passes through: a section.
            let stripe = ((at.x + at.y) / HATCH_PERIOD).floor() as i64 % 2 == 0;
            return Vec3::splat(if stripe { SECTION_DARK } else { SECTION_LIGHT });
        }
        let albedo = (material.base_color + material.emissive.min(Vec3::ONE)).min(Vec3::ONE);
        let span = (self.top - self.ground).max(1e-6);
        let height = ((hit.position.y - self.ground) / span).clamp(0.0, 1.0);
        let height_shade = 0.6 + 0.4 * height;
        let mut normal = hit.shading_normal;
        if normal.dot(ray.direction) > 0.0 {
            normal = -normal;
        }
        let light = Vec3::new(-0.35, 1.0, -0.45).normalize();
        // 1 for a floor facing straight up; darker away from the light, never black.
        let lambert = 0.3 + 0.7 * (normal.dot(light).max(0.0) / light.y);
        (albedo * height_shade * lambert).min(Vec3::ONE)
    }

    /// The ramp colour of a probe at height `y`.
    fn height_colour(&self, y: f32) -> RGBColor {
        let (low, high) = self.height_range;
        let t = if high > low {
            ((y - low) / (high - low)).clamp(0.0, 1.0)
        } else {
            0.5
        };
        ramp(t)
    }

    /// Draws the probes, their numbers and the legend over the shaded map.
    fn draw_overlay<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        probes: &[Vec3],
        options: &TopViewOptions,
    ) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
        let (map, legend) = root.split_vertically(self.layout.map_height);
        let radius = self.probe_radius;
        let pixel = |p: Vec3| {
            let at = self.layout.project(p);
            (at.x.floor() as i32, at.y.floor() as i32)
        };

        // The region's boxes first, under everything: an orange outline with a white halo.
        for b in &options.regions {
            let (x0, y0) = pixel(b.min);
            let (x1, y1) = pixel(b.max);
            for (inset, colour) in [(0, WHITE), (1, REGION_COLOUR), (2, REGION_COLOUR)] {
                map.draw(&Rectangle::new(
                    [(x0 + inset, y0 + inset), (x1 - inset, y1 - inset)],
                    colour.stroke_width(1),
                ))?;
            }
        }

        // The comparison set, under the probes: squares with a halo and an outline.
        let half = (radius * 0.8).round().max(2.0) as i32;
        for &p in &options.comparison {
            let (x, y) = pixel(p);
            map.draw(&Rectangle::new(
                [(x - half - 2, y - half - 2), (x + half + 2, y + half + 2)],
                WHITE.filled(),
            ))?;
            map.draw(&Rectangle::new(
                [(x - half - 1, y - half - 1), (x + half + 1, y + half + 1)],
                OUTLINE.filled(),
            ))?;
            map.draw(&Rectangle::new(
                [(x - half, y - half), (x + half, y + half)],
                COMPARISON_COLOUR.filled(),
            ))?;
        }

        // Probes, lowest first so that higher ones (nearer the viewer) lie on top.
        let mut order: Vec<usize> = (0..probes.len()).collect();
        order.sort_by(|&a, &b| probes[a].y.total_cmp(&probes[b].y).then(a.cmp(&b)));
        let fill_radius = radius.round().max(1.0) as i32;
        let outline_width = (radius / 4.0).round().clamp(1.0, 4.0) as i32;
        for &i in &order {
            let p = probes[i];
            let centre = pixel(p);
            let r = fill_radius;
            map.draw(&Circle::new(centre, r + outline_width + 1, WHITE.filled()))?;
            map.draw(&Circle::new(centre, r + outline_width, OUTLINE.filled()))?;
            map.draw(&Circle::new(centre, r, self.height_colour(p.y).filled()))?;
            if self.cut.is_some_and(|cut| p.y > cut) {
                map.draw(&Circle::new(centre, (r / 3).max(1), OUTLINE.filled()))?;
            }
        }

        if options.number_probes {
            let size = (radius as f64 * 1.6).max(11.0);
            let style = (FONT_FAMILY, size)
                .into_font()
                .color(&OUTLINE)
                .pos(Pos::new(HPos::Left, VPos::Bottom));
            for &i in &order {
                let text = i.to_string();
                let (x, y) = pixel(probes[i]);
                let at = (x + fill_radius, y - fill_radius);
                let (w, h) = map.estimate_text_size(&text, &style)?;
                map.draw(&Rectangle::new(
                    [
                        (at.0 - 1, at.1 - h as i32 - 1),
                        (at.0 + w as i32 + 2, at.1 + 1),
                    ],
                    WHITE.mix(0.8).filled(),
                ))?;
                map.draw(&Text::new(text, at, style.clone()))?;
            }
        }

        if !self.legend_rows.is_empty() {
            self.draw_legend(&legend)?;
        }
        Ok(())
    }

    /// The legend strip: its rows of items, each a glyph or ramp and a text.
    fn draw_legend<DB: DrawingBackend>(
        &self,
        strip: &DrawingArea<DB, Shift>,
    ) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
        strip.fill(&WHITE)?;
        let style = legend_style(self.legend_font);
        let glyph = (self.legend_font * 0.42).round().max(3.0) as i32;
        let row_height = self.legend_row as i32;
        let mid_colour = self.height_colour((self.height_range.0 + self.height_range.1) / 2.0);
        for (r, row) in self.legend_rows.iter().enumerate() {
            let middle = r as i32 * row_height + row_height / 2;
            let mut x = legend_gap(self.legend_font) / 2;
            for item in row {
                let start = x;
                let text_at = |x: i32| (x, middle);
                match item {
                    LegendItem::Probes(text) => {
                        let centre = (x + glyph + 1, middle);
                        strip.draw(&Circle::new(centre, glyph + 1, OUTLINE.filled()))?;
                        strip.draw(&Circle::new(centre, glyph, mid_colour.filled()))?;
                        x += 3 * glyph;
                        strip.draw(&Text::new(text.clone(), text_at(x), style.clone()))?;
                    }
                    LegendItem::Comparison(text) => {
                        strip.draw(&Rectangle::new(
                            [
                                (x, middle - glyph - 1),
                                (x + 2 * glyph + 2, middle + glyph + 1),
                            ],
                            OUTLINE.filled(),
                        ))?;
                        strip.draw(&Rectangle::new(
                            [(x + 1, middle - glyph), (x + 2 * glyph + 1, middle + glyph)],
                            COMPARISON_COLOUR.filled(),
                        ))?;
                        x += 3 * glyph;
                        strip.draw(&Text::new(text.clone(), text_at(x), style.clone()))?;
                    }
                    LegendItem::Ramp(low, high) => {
                        strip.draw(&Text::new(low.clone(), text_at(x), style.clone()))?;
                        x += text_width(low, self.legend_font) + glyph;
                        let bar = ramp_width(self.legend_font);
                        for k in 0..bar {
                            let colour = ramp(k as f32 / (bar - 1).max(1) as f32);
                            strip.draw(&Rectangle::new(
                                [(x + k, middle - glyph), (x + k + 1, middle + glyph)],
                                colour.filled(),
                            ))?;
                        }
                        strip.draw(&Rectangle::new(
                            [(x - 1, middle - glyph - 1), (x + bar, middle + glyph + 1)],
                            OUTLINE.stroke_width(1),
                        ))?;
                        x += bar + glyph;
                        strip.draw(&Text::new(high.clone(), text_at(x), style.clone()))?;
                    }
                    LegendItem::Text(text) => {
                        strip.draw(&Text::new(text.clone(), text_at(x), style.clone()))?;
                    }
                }
                x = start + item_width(item, self.legend_font) + legend_gap(self.legend_font);
            }
        }
        Ok(())
    }
}

/// The legend's entries for these probes and options, in order.
fn legend_items(probes: &[Vec3], options: &TopViewOptions, heights: (f32, f32)) -> Vec<LegendItem> {
    let mut items = vec![LegendItem::Probes(format!(
        "{} ({})",
        options.probes_name,
        probes.len()
    ))];
    if !options.comparison.is_empty() {
        items.push(LegendItem::Comparison(format!(
            "{} ({})",
            options.comparison_name,
            options.comparison.len()
        )));
    }
    items.push(LegendItem::Ramp(
        format!("height {:.1} m", heights.0),
        format!("{:.1} m", heights.1),
    ));
    if let Some(cut) = options.cut_height {
        let above = probes.iter().filter(|p| p.y > cut).count();
        items.push(LegendItem::Text(if above > 0 {
            format!("cut at y = {cut:.2} m ({above} above it, dotted)")
        } else {
            format!("cut at y = {cut:.2} m")
        }));
    }
    if !options.regions.is_empty() {
        items.push(LegendItem::Text(format!(
            "region: {} box{} (orange)",
            options.regions.len(),
            if options.regions.len() == 1 { "" } else { "es" }
        )));
    }
    items.push(LegendItem::Text("x →  z ↓".to_owned()));
    if let Some(caption) = &options.caption {
        items.push(LegendItem::Text(caption.clone()));
    }
    items
}

/// Greedy rows of items that fit in `width` pixels (an item wider than a row gets its own).
fn lay_out_legend(items: Vec<LegendItem>, width: u32, font: f64) -> Vec<Vec<LegendItem>> {
    let gap = legend_gap(font);
    let mut rows: Vec<Vec<LegendItem>> = Vec::new();
    let mut used = gap / 2;
    for item in items {
        let w = item_width(&item, font);
        match rows.last_mut() {
            Some(row) if used + w <= width as i32 => row.push(item),
            _ => {
                rows.push(vec![item]);
                used = gap / 2;
            }
        }
        used += w + gap;
    }
    rows
}

fn legend_style(font: f64) -> TextStyle<'static> {
    (FONT_FAMILY, font)
        .into_font()
        .color(&OUTLINE)
        .pos(Pos::new(HPos::Left, VPos::Center))
}

fn legend_gap(font: f64) -> i32 {
    (font * 1.4).round() as i32
}

fn ramp_width(font: f64) -> i32 {
    (font * 6.0).round() as i32
}

fn text_width(text: &str, font: f64) -> i32 {
    (FONT_FAMILY, font)
        .into_font()
        .box_size(text)
        .map_or(text.chars().count() as f64 * font * 0.6, |(w, _)| w as f64) as i32
}

/// The width of what precedes an item's (last) text: its glyph, or the ramp and its low text.
fn item_lead(item: &LegendItem, font: f64) -> i32 {
    let glyph = (font * 0.42).round().max(3.0) as i32;
    match item {
        LegendItem::Probes(_) | LegendItem::Comparison(_) => 3 * glyph,
        LegendItem::Ramp(low, _) => text_width(low, font) + glyph + ramp_width(font) + glyph,
        LegendItem::Text(_) => 0,
    }
}

/// An item's whole width in pixels.
fn item_width(item: &LegendItem, font: f64) -> i32 {
    let text = match item {
        LegendItem::Probes(text) | LegendItem::Comparison(text) | LegendItem::Text(text) => text,
        LegendItem::Ramp(_, high) => high,
    };
    item_lead(item, font) + text_width(text, font)
}

/// Whether `origin` lies inside a closed single-sided solid: at least three of four oblique
/// rays leaving it first meet a surface from behind. Oblique rays leave a wall or pillar
/// through its side, where axis-aligned ones often leave through a face it shares with the
/// floor or roof and may report that neighbour's front face instead.
fn inside_solid(scene: &Scene, origin: Vec3) -> bool {
    const DIRECTIONS: [Vec3; 4] = [
        Vec3::new(0.45, -1.0, 0.2),
        Vec3::new(-0.2, -1.0, 0.45),
        Vec3::new(-0.45, -1.0, -0.2),
        Vec3::new(0.2, -1.0, -0.45),
    ];
    let (mut behind, mut other) = (0, 0);
    for direction in DIRECTIONS {
        let hit = scene.closest_hit(&Ray::new(origin, direction), f32::INFINITY);
        match hit {
            Some(hit)
                if !hit.front_face && !scene.materials()[hit.material as usize].double_sided =>
            {
                behind += 1
            }
            _ => other += 1,
        }
        if behind >= 3 {
            return true;
        }
        if other >= 2 {
            return false;
        }
    }
    false
}

/// The probes' height ramp: blue, teal, yellow, orange, red for `t` from 0 to 1.
fn ramp(t: f32) -> RGBColor {
    const STOPS: [[f32; 3]; 5] = [
        [49.0, 110.0, 200.0],
        [0.0, 180.0, 165.0],
        [245.0, 215.0, 50.0],
        [245.0, 135.0, 40.0],
        [210.0, 35.0, 40.0],
    ];
    let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
    let scaled = t * (STOPS.len() - 1) as f32;
    let i = (scaled.floor() as usize).min(STOPS.len() - 2);
    let f = scaled - i as f32;
    let mix = |c: usize| (STOPS[i][c] + (STOPS[i + 1][c] - STOPS[i][c]) * f).round() as u8;
    RGBColor(mix(0), mix(1), mix(2))
}

/// A linear value in `[0, 1]` as an 8-bit sRGB value.
fn linear_to_srgb8(value: f32) -> u8 {
    let v = value.clamp(0.0, 1.0);
    let encoded = if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    };
    (encoded * 255.0).round() as u8
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ramp_ends_and_srgb_encoding() {
        assert_eq!(ramp(0.0), RGBColor(49, 110, 200));
        assert_eq!(ramp(1.0), RGBColor(210, 35, 40));
        assert_eq!(ramp(-3.0), ramp(0.0));
        assert_eq!(ramp(f32::NAN), ramp(0.0));
        assert_eq!(linear_to_srgb8(0.0), 0);
        assert_eq!(linear_to_srgb8(1.0), 255);
        assert_eq!(linear_to_srgb8(0.18), 118);
        assert_eq!(linear_to_srgb8(2.0), 255);
        assert_eq!(linear_to_srgb8(-1.0), 0);
    }

    #[test]
    fn project_and_unproject_are_inverse() {
        let layout = TopViewLayout {
            width: 200,
            map_height: 100,
            height: 120,
            region_min: Vec2::new(-10.0, -5.0),
            region_max: Vec2::new(10.0, 5.0),
        };
        let p = Vec3::new(2.5, 7.0, -1.25);
        let pixel = layout.project(p);
        assert_eq!(pixel, Vec2::new(125.0, 37.5));
        assert_eq!(layout.unproject(pixel), Vec2::new(2.5, -1.25));
    }
}
