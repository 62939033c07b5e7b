//! Panel charts: a [`Figure`] is a title and [`Panel`]s stacked vertically, each a chart with
//! linear or logarithmic axes (1-2-5 ticks; time axes at steps of the clock), lines (solid,
//! dashed or staircase, clipped to the chart), horizontal reference lines, vertical event
//! markers and a legend column. The run's time series, the contact timeline's age panel and
//! `vbap analyze`'s latency and loop plots are drawn with it, on the [`super::canvas`].
//!
//! Output is deterministic (same input, same bytes).

pub mod legend;
mod panel;
pub mod ticks;

use std::path::Path;

use super::canvas::{self, Anchor, Canvas, TextOpts};
use super::style::{self, TimeUnit};
use super::PlotError;
use vbap_wire::rundir::Event;

pub use panel::{draw_panel, panel_height};

/// Width of every chart figure, px.
pub const WIDTH: f64 = 1200.0;
/// Left edge of the plot area, px.
pub const MARGIN_LEFT: f64 = 100.0;
/// Width of the legend column, px.
pub const LEGEND_W: f64 = 280.0;
/// Width of the plot area, px.
pub const PLOT_W: f64 = WIDTH - MARGIN_LEFT - LEGEND_W - 25.0;
/// Height of a panel's title row, px.
pub const PANEL_TITLE_H: f64 = 30.0;
/// Height of the plot area of a panel, px.
pub const PLOT_H: f64 = 200.0;

/// A figure: a title and panels stacked vertically.
#[derive(Clone, Debug, Default)]
pub struct Figure {
    /// Title at the top.
    pub title: String,
    /// A line of context under the title (may be empty).
    pub subtitle: String,
    /// The panels, top to bottom.
    pub panels: Vec<Panel>,
}

/// One chart of a figure.
#[derive(Clone, Debug, Default)]
pub struct Panel {
    /// Title above the chart.
    pub title: String,
    /// Horizontal axis.
    pub x: Axis,
    /// Vertical axis.
    pub y: Axis,
    /// Data, drawn in order.
    pub series: Vec<Series>,
    /// Horizontal reference lines (bounds, tolerances), with a legend entry each.
    pub hlines: Vec<RefLine>,
    /// Vertical event lines.
    pub markers: Vec<Marker>,
    /// Short remarks printed under the legend.
    pub notes: Vec<String>,
}

impl Panel {
    /// A panel with a title and axes, no data yet.
    pub fn new(title: &str, x: Axis, y: Axis) -> Self {
        Self {
            title: title.to_string(),
            x,
            y,
            ..Self::default()
        }
    }
}

/// An axis. Labels may use `_{sub}` and `^{sup}`.
#[derive(Clone, Debug, Default)]
pub struct Axis {
    /// Axis label with its unit; empty: none.
    pub label: String,
    /// Logarithmic (non-positive values are left out).
    pub log: bool,
    /// Fixed range instead of the data's.
    pub range: Option<(f64, f64)>,
    /// Linear axis starting at 0 when the data are all ≥ 0.
    pub from_zero: bool,
    /// Integer ticks only.
    pub integer: bool,
    /// A time axis in this unit: ticks at steps of the clock (every 6 h, 15 min, ...).
    pub time: Option<TimeUnit>,
}

/// A line of data.
#[derive(Clone, Debug, Default)]
pub struct Series {
    /// Legend label (may use `_{sub}` and `^{sup}`).
    pub label: String,
    /// Points (x, y) in x order; a non-finite value breaks the line.
    pub points: Vec<(f64, f64)>,
    /// Stroke colour, `#rrggbb`.
    pub colour: &'static str,
    /// Dashed stroke.
    pub dashed: bool,
    /// Draw as a staircase (value held until the next point).
    pub step: bool,
}

impl Series {
    /// A solid line.
    pub fn line(label: &str, points: Vec<(f64, f64)>, colour: &'static str) -> Self {
        Self {
            label: label.to_string(),
            points,
            colour,
            ..Self::default()
        }
    }
}

/// A horizontal reference line.
#[derive(Clone, Debug)]
pub struct RefLine {
    /// Its height, y units.
    pub y: f64,
    /// Legend label.
    pub label: String,
    /// Colour, `#rrggbb`.
    pub colour: &'static str,
}

/// A vertical event line.
#[derive(Clone, Debug)]
pub struct Marker {
    /// Where, x units.
    pub x: f64,
    /// Label next to the line (first panel only).
    pub label: String,
    /// Colour, `#rrggbb`.
    pub colour: &'static str,
    /// Legend entry of this kind of marker.
    pub legend: String,
}

/// Event markers: the kinds [`style::event_style`] draws (per-message kinds like
/// `link_drop` are too many to draw, periodic ones like `surfaced` are in `contact.svg`),
/// with the short labels of [`style::event_label`] ("kill 2", "lost 2", "redesign"), at
/// their times in `unit`.
pub fn event_markers(events: &[Event], unit: TimeUnit) -> Vec<Marker> {
    events
        .iter()
        .filter(|e| !(e.kind == "join" && e.k == 0))
        .filter_map(|e| {
            let st = style::event_style(&e.kind)?;
            Some(Marker {
                x: unit.of(e.t),
                label: style::event_label(e),
                colour: st.colour,
                legend: st.legend.to_string(),
            })
        })
        .collect()
}

/// Writes `fig` to `path` as SVG.
pub fn write_svg(fig: &Figure, path: &Path) -> Result<(), PlotError> {
    let svg = render_svg(fig)?;
    std::fs::write(path, svg).map_err(|source| PlotError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// Renders `fig` to an SVG document.
pub fn render_svg(fig: &Figure) -> Result<String, PlotError> {
    let head_h = if fig.subtitle.is_empty() { 48.0 } else { 70.0 };
    let height = head_h + fig.panels.iter().map(panel_height).sum::<f64>() + 10.0;
    canvas::render((WIDTH, height), |c| {
        draw_head(c, &fig.title, &fig.subtitle)?;
        let mut top = head_h;
        for p in &fig.panels {
            draw_panel(c, p, top, std::ptr::eq(p, &fig.panels[0]))?;
            top += panel_height(p);
        }
        Ok(())
    })
}

/// The title (and the subtitle under it, when not empty) of a figure.
pub fn draw_head(c: &Canvas<'_>, title: &str, subtitle: &str) -> Result<(), PlotError> {
    let mid = WIDTH / 2.0;
    c.text(
        (mid, 32.0),
        title,
        TextOpts::new(21.0).bold().anchor(Anchor::Middle),
    )?;
    if !subtitle.is_empty() {
        c.text(
            (mid, 56.0),
            subtitle,
            TextOpts::new(14.0).colour("#444444").anchor(Anchor::Middle),
        )?;
    }
    Ok(())
}

#[cfg(test)]
mod tests;
