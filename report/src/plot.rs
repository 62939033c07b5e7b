//! The mission plot (`plot.svg` in the run directory) and the stacked panel charts.
//!
//! SVG only (plotters' SVG backend, no font files: text is written as SVG `<text>` and the
//! viewer renders it). Output is deterministic: the same input gives the same bytes (no clock,
//! no hash-map order, no threads).
//!
//! The mission plot shows, on equal-aspect axes:
//! - the field at the final time as filled colour bands (perceptual *viridis* colormap, washed
//!   towards white so the tracks stand out) with thin contour lines at the band edges and a
//!   colour bar;
//! - each vehicle's track (start: hollow circle, end: filled dot), colour by vehicle id;
//! - the virtual body's centre path (thick, dashed, black);
//! - formation snapshots: closed polygons through the vehicles in angular order about the
//!   centre, labelled with their time (in s, min, h or days by the mission's length); the
//!   snapshots taken at events (a vehicle lost, the formation broken, ...) are drawn in red
//!   and labelled with the event too;
//! - the optimum (star) and events (crosses with short labels).
//!
//! Every picture of a run is drawn with plotters: [`style`] holds what they all share
//! (palette, event colours and labels, tick steps, time units), [`canvas`] the pixel
//! primitives and [`chart`] the stacked panel charts of the time series, the contact
//! timeline's age panel and the analysis plots; [`decimate`] keeps long series small.

pub mod canvas;
pub mod chart;
pub mod decimate;
pub mod style;

use std::path::{Path, PathBuf};

use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use style::{nice_step, TimeUnit};
use vbap_wire::rundir::Event;

mod bounds;
mod contour;
mod events;
mod field;
mod labels;
mod mission;
mod side;

pub use bounds::{bounds_around, choose_bounds};
pub use events::{event_snapshots, read_events, MAX_EVENT_SNAPSHOTS};
pub use mission::{render_mission_svg, write_mission_svg};
use {contour::contour_lines, field::*, labels::*, mission::*, side::*};

/// One vehicle's planar track: positions (x, y) in the mission's length unit, in time order.
#[derive(Debug, Clone, PartialEq)]
pub struct Track {
    /// Vehicle id; also picks the track's colour (`id` modulo the palette), so a vehicle keeps
    /// its colour across plots.
    pub id: u32,
    /// Positions (x, y), length unit of the plot, oldest first.
    pub points: Vec<(f64, f64)>,
}

/// The formation at one instant, drawn as a closed polygon.
#[derive(Debug, Clone, PartialEq)]
pub struct Snapshot {
    /// Mission time of the snapshot, s.
    pub t: f64,
    /// The events this snapshot was taken at ("lost 2, redesign"); empty for the evenly
    /// spaced ones. An event snapshot is drawn in red with this label after its time.
    pub label: String,
    /// Vehicle positions (x, y); any order (they are joined in angular order about `centre`).
    pub positions: Vec<(f64, f64)>,
    /// Virtual-body centre r (x, y) at `t`.
    pub centre: (f64, f64),
}

/// Everything drawn in the mission plot. Lengths are all in `length_unit`.
pub struct MissionPlot<'a> {
    /// Title at the top of the figure.
    pub title: String,
    /// Length unit for the axis labels: "m", "km" or "" (non-dimensional).
    pub length_unit: String,
    /// Field value at (x, y) at the final time, drawn as filled contours. Non-finite values
    /// are drawn as grey cells and ignored for the colour scale.
    pub field: &'a dyn Fn(f64, f64) -> f64,
    /// Colour-bar label of the field, e.g. "T (°C)".
    pub field_label: String,
    /// Vehicle tracks, drawn in this order; legend "vehicle {id}".
    pub tracks: Vec<Track>,
    /// Virtual-body centre r over time (x, y).
    pub body_path: Vec<(f64, f64)>,
    /// Formation outlines at a few times.
    pub snapshots: Vec<Snapshot>,
    /// Location of the field's optimum, if known (star marker).
    pub optimum: Option<(f64, f64)>,
    /// Markers at (x, y) with a short label (kills, rejoins, ...).
    pub events: Vec<(f64, f64, String)>,
    /// [lon, lat] (degrees) of the local (0, 0) of a geographic grid field: the axes are then
    /// labelled in degrees (positions stay local; x = R cos(lat0) Δlon, y = R Δlat).
    pub geographic: Option<[f64; 2]>,
    /// The current (x, y velocity, length unit/s) at (x, y) at the final time, drawn as
    /// arrows on a coarse lattice over the field (None: still water).
    pub current: Option<&'a dyn Fn(f64, f64) -> (f64, f64)>,
}

/// A rectangle of the plane, in the plot's length unit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bounds {
    /// Left edge.
    pub x_min: f64,
    /// Right edge.
    pub x_max: f64,
    /// Bottom edge.
    pub y_min: f64,
    /// Top edge.
    pub y_max: f64,
}

impl Bounds {
    /// Width x_max − x_min (length unit).
    pub fn width(&self) -> f64 {
        self.x_max - self.x_min
    }
    /// Height y_max − y_min (length unit).
    pub fn height(&self) -> f64 {
        self.y_max - self.y_min
    }
    /// Whether (x, y) lies inside or on the edge.
    pub fn contains(&self, (x, y): (f64, f64)) -> bool {
        x >= self.x_min && x <= self.x_max && y >= self.y_min && y <= self.y_max
    }
}

/// Why a plot could not be made.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// There is no point to set the axes by (no track, body path, optimum, ... or no data).
    #[error("nothing to plot: {0}")]
    Empty(String),
    /// A coordinate or a data value is NaN or infinite.
    #[error("non-finite value in {what} at index {index}")]
    NonFinite {
        /// Which input (e.g. "track 3", "series 'speed'").
        what: String,
        /// Index of the offending point in that input.
        index: usize,
    },
    /// A parameter is out of its domain (e.g. a non-positive aspect ratio).
    #[error("invalid plot parameter: {0}")]
    InvalidParameter(String),
    /// plotters failed while drawing.
    #[error("drawing failed: {0}")]
    Draw(String),
    /// The SVG file could not be written.
    #[error("writing {path}: {source}")]
    Io {
        /// File that could not be written.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
}

/// Number of field cells along the longer side of the mission plot (the shorter side gets
/// proportionally fewer, so cells are square on screen). A grid twice as fine is used instead
/// when its colour bands merge into at most [`FIELD_RECT_BUDGET`] rectangles (smooth fields).
pub const FIELD_GRID: usize = 120;

/// Largest number of merged field rectangles accepted from the fine grid (about 85 bytes of
/// SVG each).
pub const FIELD_RECT_BUDGET: usize = 8_000;

/// Margin added around the plotted geometry by [`choose_bounds`], as a fraction of its larger
/// extent.
pub const BOUNDS_MARGIN: f64 = 0.08;

/// Mission-plot canvas size in pixels (width, height).
pub const MISSION_SIZE: (u32, u32) = (1200, 950);

use canvas::FONT;
const TITLE_H: u32 = 50;
const MISSION_CHART_W: u32 = 900;
/// Fraction of white mixed into the field colours so that the tracks stand out.
const FIELD_WASH: f64 = 0.4;
/// Target number of colour bands in the field.
const FIELD_BANDS: usize = 12;
/// Colour of cells where the field is not finite.
const NO_DATA: RGBColor = RGBColor(0xcc, 0xcc, 0xcc);
/// Tolerance (pixels) of the line simplification applied to long paths.
const SIMPLIFY_PX: f64 = 0.4;
/// Most contour-line points drawn (about 8 bytes of SVG each); a rougher field gets no lines.
const CONTOUR_POINT_BUDGET: usize = 40_000;

/// Qualitative palette for tracks and series: [`style::PALETTE`] as plotters colours.
const PALETTE: [RGBColor; 10] = {
    let mut out = [RGBColor(0, 0, 0); 10];
    let mut i = 0;
    while i < out.len() {
        let (r, g, b) = style::rgb(style::PALETTE[i]);
        out[i] = RGBColor(r, g, b);
        i += 1;
    }
    out
};

/// A text style whose SVG `font-size` is `px` (plotters writes size / 1.24).
fn font(px: f64) -> TextStyle<'static> {
    TextStyle::from((FONT, px * 1.24).into_font()).color(&BLACK)
}

fn draw_title(area: &DrawingArea<SVGBackend<'_>, Shift>, title: &str) -> Result<(), PlotError> {
    let (w, h) = area.dim_in_pixel();
    area.draw(&Text::new(
        title.to_string(),
        (w as i32 / 2, h as i32 / 2 + 4),
        TextStyle::from((FONT, 22.0 * 1.24).into_font().style(FontStyle::Bold))
            .color(&BLACK)
            .pos(Pos::new(HPos::Center, VPos::Center)),
    ))
    .map_err(draw_err)
}

pub(crate) fn draw_err<E: std::error::Error + Send + Sync>(
    e: DrawingAreaErrorKind<E>,
) -> PlotError {
    PlotError::Draw(e.to_string())
}

fn write_file(path: &Path, svg: &str) -> Result<(), PlotError> {
    std::fs::write(path, svg).map_err(|source| PlotError::Io {
        path: path.to_path_buf(),
        source,
    })
}

fn extend(r: Option<(f64, f64)>, v: f64) -> (f64, f64) {
    match r {
        None => (v, v),
        Some((lo, hi)) => (lo.min(v), hi.max(v)),
    }
}

#[cfg(test)]
mod tests;
