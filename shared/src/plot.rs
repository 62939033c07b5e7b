//! The mission plot (`plot.svg` in the run directory) and simple time-series plots.
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

use crate::rundir::Event;
use style::{nice_step, TimeUnit};

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

/// Time-series canvas size in pixels (width, height).
pub const TIMESERIES_SIZE: (u32, u32) = (1100, 560);

// ---------------------------------------------------------------------------------------------
// Layout and style constants.

const FONT: &str = "sans-serif";
const TITLE_H: u32 = 50;
const MISSION_CHART_W: u32 = 900;
const TS_CHART_W: u32 = 860;
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

/// Viridis sampled at t = 0, 0.1, ..., 1 (linearly interpolated between).
const VIRIDIS: [(u8, u8, u8); 11] = [
    (0x44, 0x01, 0x54),
    (0x48, 0x24, 0x75),
    (0x41, 0x44, 0x87),
    (0x35, 0x5f, 0x8d),
    (0x2a, 0x78, 0x8e),
    (0x21, 0x91, 0x8c),
    (0x22, 0xa8, 0x84),
    (0x44, 0xbf, 0x70),
    (0x7a, 0xd1, 0x51),
    (0xbd, 0xdf, 0x26),
    (0xfd, 0xe7, 0x25),
];

// ---------------------------------------------------------------------------------------------
// Public entry points.

/// Renders the mission plot and writes it to `path` (normally `<run dir>/plot.svg`).
pub fn write_mission_svg(plot: &MissionPlot<'_>, path: &Path) -> Result<(), PlotError> {
    let svg = render_mission_svg(plot)?;
    write_file(path, &svg)
}

/// Renders the mission plot to an SVG document (a `String` starting with `<svg`).
pub fn render_mission_svg(plot: &MissionPlot<'_>) -> Result<String, PlotError> {
    validate_mission(plot)?;
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, MISSION_SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(draw_err)?;
        let (title_area, body) = root.split_vertically(TITLE_H);
        draw_title(&title_area, &plot.title)?;
        let (chart_area, side) = body.split_horizontally(MISSION_CHART_W);

        let (span_x, span_y) = mission_plot_span_px(&chart_area)?;
        let bounds = choose_bounds(plot, span_x / span_y)?;
        let mut chart = mission_chart(&chart_area, bounds)?;
        let px = (bounds.width() / span_x, bounds.height() / span_y);

        // Field: filled bands, then contour lines at the band edges.
        let aspect = span_x / span_y;
        let fine = sample_field(plot.field, bounds, aspect, 2 * FIELD_GRID);
        let fine_levels = fine.levels();
        let fine_rects = field_rects(&fine, fine_levels.as_ref());
        let (grid, levels, rects) = if fine_rects.len() <= FIELD_RECT_BUDGET {
            (fine, fine_levels, fine_rects)
        } else {
            let g = sample_field(plot.field, bounds, aspect, FIELD_GRID);
            let l = g.levels();
            let r = field_rects(&g, l.as_ref());
            (g, l, r)
        };
        draw_field(&mut chart, &grid, levels.as_ref(), rects, px)?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_labels(9)
            .y_labels(9)
            .x_desc(axis_desc("x", &plot.length_unit))
            .y_desc(axis_desc("y", &plot.length_unit))
            .x_label_formatter(&|v| fmt_tick(*v, bounds.width()))
            .y_label_formatter(&|v| fmt_tick(*v, bounds.height()))
            .label_style(font(14.0))
            .axis_desc_style(font(17.0))
            .draw()
            .map_err(draw_err)?;

        // Formation snapshots (under the tracks), labelled in one time unit.
        let time_unit =
            TimeUnit::for_span(plot.snapshots.iter().map(|s| s.t.abs()).fold(0.0, f64::max));
        let mut placer = LabelPlacer::new(chart.plotting_area().get_pixel_range());
        for snap in &plot.snapshots {
            draw_snapshot(&mut chart, snap)?;
        }

        // Body path, then tracks on top.
        let body = simplify_path(&plot.body_path, px, SIMPLIFY_PX);
        if body.len() >= 2 {
            chart
                .draw_series(DashedLineSeries::new(body, 14, 7, BLACK.stroke_width(3)))
                .map_err(draw_err)?;
        }
        for track in &plot.tracks {
            draw_track(&mut chart, track, px)?;
        }

        // Markers and labels, in backend pixels on the root area.
        let to_px = |p: (f64, f64)| chart.backend_coord(&p);
        if let Some(opt) = plot.optimum {
            let c = to_px(opt);
            root.draw(&star(c, 12.0, 5.0, RED_STAR.filled()))
                .map_err(draw_err)?;
            root.draw(&star_outline(c, 12.0, 5.0, BLACK.stroke_width(2)))
                .map_err(draw_err)?;
            placer.block((c.0 - 12, c.1 - 12, c.0 + 12, c.1 + 12));
        }
        for (x, y, _) in &plot.events {
            let c = to_px((*x, *y));
            draw_cross(&root, c, 6)?;
            placer.block((c.0 - 7, c.1 - 7, c.0 + 7, c.1 + 7));
        }
        for snap in &plot.snapshots {
            // Above or below the formation's core: a vehicle flung far away does not
            // carry the label off with it.
            let core = formation_core(snap);
            let ys = core.iter().map(|&p| to_px(p).1);
            let (top, bottom) = (ys.clone().min(), ys.max());
            let mut text = format!("t = {}", time_unit.fmt(snap.t));
            if !snap.label.is_empty() {
                text = format!("{text}: {}", snap.label);
            }
            let (x, y) = to_px(snap.centre);
            placer.place_label(
                &root,
                &text,
                (x, top.unwrap_or(y) - 6),
                13.0,
                LabelSide::AboveOrBelow(bottom.unwrap_or(y) + 6),
            )?;
        }
        for (x, y, label) in &plot.events {
            if !label.is_empty() {
                let c = to_px((*x, *y));
                placer.place_label(&root, label, c, 13.0, LabelSide::Around)?;
            }
        }
        // Frame of the plotting area on top of everything.
        let (xr, yr) = chart.plotting_area().get_pixel_range();
        root.draw(&Rectangle::new(
            [(xr.start, yr.start), (xr.end - 1, yr.end - 1)],
            BLACK.stroke_width(1),
        ))
        .map_err(draw_err)?;

        draw_mission_side(&side, plot, levels.as_ref(), grid.has_no_data())?;
        root.present().map_err(draw_err)?;
    }
    Ok(svg)
}

/// Renders a time-series plot and writes it to `path`.
///
/// `series`: (legend label, points (x, y)) drawn as lines in palette order; `markers`: vertical
/// dashed lines at x with a short label (events). Markers outside the data's x range are not
/// drawn.
pub fn write_timeseries_svg(
    path: &Path,
    title: &str,
    x_label: &str,
    series: &[(String, Vec<(f64, f64)>)],
    y_label: &str,
    markers: &[(f64, String)],
) -> Result<(), PlotError> {
    let svg = render_timeseries_svg(title, x_label, series, y_label, markers)?;
    write_file(path, &svg)
}

/// Renders a time-series plot to an SVG document (see [`write_timeseries_svg`]).
pub fn render_timeseries_svg(
    title: &str,
    x_label: &str,
    series: &[(String, Vec<(f64, f64)>)],
    y_label: &str,
    markers: &[(f64, String)],
) -> Result<String, PlotError> {
    let mut x_range: Option<(f64, f64)> = None;
    let mut y_range: Option<(f64, f64)> = None;
    for (name, pts) in series {
        for (i, &(x, y)) in pts.iter().enumerate() {
            if !x.is_finite() || !y.is_finite() {
                return Err(PlotError::NonFinite {
                    what: format!("series '{name}'"),
                    index: i,
                });
            }
            x_range = Some(extend(x_range, x));
            y_range = Some(extend(y_range, y));
        }
    }
    for (i, (x, _)) in markers.iter().enumerate() {
        if !x.is_finite() {
            return Err(PlotError::NonFinite {
                what: "markers".into(),
                index: i,
            });
        }
    }
    let (Some((x0, x1)), Some((y0, y1))) = (x_range, y_range) else {
        return Err(PlotError::Empty("every series is empty".into()));
    };
    let (x0, x1) = widen_if_flat(x0, x1);
    let (y0, y1) = widen_if_flat(y0, y1);
    let pad = 0.05 * (y1 - y0);
    let (y0, y1) = (y0 - pad, y1 + pad);

    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, TIMESERIES_SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(draw_err)?;
        let (title_area, body) = root.split_vertically(TITLE_H - 5);
        draw_title(&title_area, title)?;
        let (chart_area, side) = body.split_horizontally(TS_CHART_W);
        let mut chart = ChartBuilder::on(&chart_area)
            .margin_left(10)
            .margin_right(15)
            .margin_top(10)
            .margin_bottom(10)
            .x_label_area_size(50)
            .y_label_area_size(80)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(draw_err)?;
        chart
            .configure_mesh()
            .light_line_style(RGBColor(0xee, 0xee, 0xee))
            .bold_line_style(RGBColor(0xdd, 0xdd, 0xdd))
            .x_labels(10)
            .y_labels(8)
            .x_desc(x_label)
            .y_desc(y_label)
            .x_label_formatter(&|v| fmt_tick(*v, x1 - x0))
            .y_label_formatter(&|v| fmt_tick(*v, y1 - y0))
            .label_style(font(14.0))
            .axis_desc_style(font(17.0))
            .draw()
            .map_err(draw_err)?;

        let (xr, yr) = chart.plotting_area().get_pixel_range();
        let px = (
            (x1 - x0) / f64::from((xr.end - xr.start - 1).max(1)),
            (y1 - y0) / f64::from((yr.end - yr.start - 1).max(1)),
        );
        let marker_style = RGBColor(0x55, 0x55, 0x55).mix(0.8).stroke_width(1);
        for (x, _) in markers {
            if *x >= x0 && *x <= x1 {
                chart
                    .draw_series(DashedLineSeries::new(
                        vec![(*x, y0), (*x, y1)],
                        6,
                        4,
                        marker_style,
                    ))
                    .map_err(draw_err)?;
            }
        }
        for (k, (_, pts)) in series.iter().enumerate() {
            let colour = PALETTE[k % PALETTE.len()];
            let pts = simplify_path(pts, px, SIMPLIFY_PX);
            if pts.len() == 1 {
                chart
                    .draw_series(std::iter::once(Circle::new(pts[0], 3, colour.filled())))
                    .map_err(draw_err)?;
            } else {
                chart
                    .draw_series(LineSeries::new(pts, colour.stroke_width(2)))
                    .map_err(draw_err)?;
            }
        }
        let mut placer = LabelPlacer::new((xr.clone(), yr.clone()));
        for (x, label) in markers {
            if *x >= x0 && *x <= x1 && !label.is_empty() {
                let c = chart.backend_coord(&(*x, y1));
                placer.place_label(&root, label, (c.0, c.1 + 4), 13.0, LabelSide::Below)?;
            }
        }
        root.draw(&Rectangle::new(
            [(xr.start, yr.start), (xr.end - 1, yr.end - 1)],
            BLACK.stroke_width(1),
        ))
        .map_err(draw_err)?;

        // Legend in the side panel.
        let mut entries: Vec<(LegendSymbol, String)> = series
            .iter()
            .enumerate()
            .map(|(k, (name, _))| (LegendSymbol::Line(PALETTE[k % PALETTE.len()]), name.clone()))
            .collect();
        if markers.iter().any(|(x, _)| *x >= x0 && *x <= x1) {
            entries.push((
                LegendSymbol::DashedLine(RGBColor(0x55, 0x55, 0x55)),
                "event".into(),
            ));
        }
        let (_, side_h) = side.dim_in_pixel();
        draw_legend(&side, &entries, 20, side_h as i32 - 20)?;
        root.present().map_err(draw_err)?;
    }
    Ok(svg)
}

/// Most formation snapshots `plot.svg` draws at events (besides the evenly spaced ones).
pub const MAX_EVENT_SNAPSHOTS: usize = 6;

/// The events of `events.jsonl` at `path`, in file order (no file: none; lines that are not
/// an event, such as a partial last line of an interrupted run, are skipped).
pub fn read_events(path: &Path) -> std::io::Result<Vec<Event>> {
    use std::io::BufRead;
    let file = match std::fs::File::open(path) {
        Ok(f) => f,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(e),
    };
    let mut out = Vec::new();
    for line in std::io::BufReader::new(file).lines() {
        if let Ok(e) = serde_json::from_str::<Event>(&line?) {
            out.push(e);
        }
    }
    Ok(out)
}

/// The ticks at which the mission plot draws a formation snapshot for an event, each with its
/// label, in tick order: events of the kinds of [`style::SNAPSHOT_EVENTS`] (a vehicle lost,
/// the formation broken, a stall, a near collision, a rejoin, a redesign). Events less than
/// `min_gap` ticks after the first of a group share its snapshot ("lost 2, redesign"). Of
/// more than `max` groups, the first group of each kind is kept first (in the order of
/// [`style::SNAPSHOT_EVENTS`]), then the others by that order and time.
pub fn event_snapshots(events: &[Event], max: usize, min_gap: u64) -> Vec<(u64, String)> {
    let priority = |kind: &str| style::SNAPSHOT_EVENTS.iter().position(|k| *k == kind);
    let mut wanted: Vec<(u64, usize, String)> = events
        .iter()
        .filter_map(|e| priority(&e.kind).map(|p| (e.k, p, style::event_label(e))))
        .collect();
    wanted.sort_by_key(|w| w.0);
    // Groups: (first tick, best priority, kinds seen, labels).
    let mut groups: Vec<(u64, usize, Vec<usize>, Vec<String>)> = Vec::new();
    for (k, p, label) in wanted {
        match groups.last_mut() {
            Some(g) if k < g.0 + min_gap.max(1) => {
                g.1 = g.1.min(p);
                g.2.push(p);
                if !g.3.contains(&label) {
                    g.3.push(label);
                }
            }
            _ => groups.push((k, p, vec![p], vec![label])),
        }
    }
    let mut chosen: Vec<usize> = Vec::new();
    if groups.len() <= max {
        chosen = (0..groups.len()).collect();
    } else {
        for p in 0..style::SNAPSHOT_EVENTS.len() {
            if chosen.len() >= max {
                break;
            }
            if let Some(i) = groups.iter().position(|g| g.2.contains(&p)) {
                if !chosen.contains(&i) {
                    chosen.push(i);
                }
            }
        }
        let mut rest: Vec<usize> = (0..groups.len()).filter(|i| !chosen.contains(i)).collect();
        rest.sort_by_key(|&i| (groups[i].1, groups[i].0));
        chosen.extend(rest.into_iter().take(max.saturating_sub(chosen.len())));
        chosen.sort_unstable();
    }
    chosen
        .into_iter()
        .map(|i| {
            let labels = &groups[i].3;
            let mut label = labels.join(", ");
            if label.chars().count() > 48 {
                label = label.chars().take(47).collect::<String>() + "…";
            }
            (groups[i].0, label)
        })
        .collect()
}

/// Bounds covering every track, the body path, the snapshots, the optimum and the events, with
/// a margin of [`BOUNDS_MARGIN`] × the larger extent, widened in one direction so that
/// width / height = `aspect` (the plotting area's pixel aspect ratio: equal scales on x and y).
pub fn choose_bounds(plot: &MissionPlot<'_>, aspect: f64) -> Result<Bounds, PlotError> {
    let points = plot
        .tracks
        .iter()
        .flat_map(|t| t.points.iter().copied())
        .chain(plot.body_path.iter().copied())
        .chain(
            plot.snapshots
                .iter()
                .flat_map(|s| s.positions.iter().copied().chain(std::iter::once(s.centre))),
        )
        .chain(plot.optimum)
        .chain(plot.events.iter().map(|(x, y, _)| (*x, *y)));
    bounds_around(points, BOUNDS_MARGIN, aspect)
}

/// The smallest rectangle holding `points`, grown by `margin_frac` × its larger extent on every
/// side and then widened about its centre to width / height = `aspect`. A single point (zero
/// extent) gets a half-width of max(1, 0.1 |coordinate|) in the length unit.
pub fn bounds_around(
    points: impl IntoIterator<Item = (f64, f64)>,
    margin_frac: f64,
    aspect: f64,
) -> Result<Bounds, PlotError> {
    if !(aspect.is_finite() && aspect > 0.0) {
        return Err(PlotError::InvalidParameter(format!(
            "aspect ratio must be finite and > 0, got {aspect}"
        )));
    }
    if !(margin_frac.is_finite() && margin_frac >= 0.0) {
        return Err(PlotError::InvalidParameter(format!(
            "margin must be finite and >= 0, got {margin_frac}"
        )));
    }
    let mut xr: Option<(f64, f64)> = None;
    let mut yr: Option<(f64, f64)> = None;
    for (i, (x, y)) in points.into_iter().enumerate() {
        if !x.is_finite() || !y.is_finite() {
            return Err(PlotError::NonFinite {
                what: "plotted points".into(),
                index: i,
            });
        }
        xr = Some(extend(xr, x));
        yr = Some(extend(yr, y));
    }
    let (Some((x0, x1)), Some((y0, y1))) = (xr, yr) else {
        return Err(PlotError::Empty(
            "no track, body path, snapshot, optimum or event".into(),
        ));
    };
    let (w, h) = (x1 - x0, y1 - y0);
    let (mut hw, mut hh) = if w == 0.0 && h == 0.0 {
        let d = 1.0_f64.max(0.1 * x0.abs().max(y0.abs()));
        (d, d)
    } else {
        let m = margin_frac * w.max(h);
        (0.5 * w + m, 0.5 * h + m)
    };
    // One side can still be zero (collinear points, no margin): the aspect fix gives it size.
    let tiny = 1e-9 * hw.max(hh);
    hw = hw.max(tiny);
    hh = hh.max(tiny);
    let (cx, cy) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
    if hw / hh < aspect {
        hw = hh * aspect;
    } else {
        hh = hw / aspect;
    }
    Ok(Bounds {
        x_min: cx - hw,
        x_max: cx + hw,
        y_min: cy - hh,
        y_max: cy + hh,
    })
}

// ---------------------------------------------------------------------------------------------
// Mission-plot pieces.

const RED_STAR: RGBColor = RGBColor(0xe4, 0x1a, 0x1c);

fn validate_mission(plot: &MissionPlot<'_>) -> Result<(), PlotError> {
    let check = |what: String, pts: &mut dyn Iterator<Item = (f64, f64)>| {
        for (i, (x, y)) in pts.enumerate() {
            if !x.is_finite() || !y.is_finite() {
                return Err(PlotError::NonFinite { what, index: i });
            }
        }
        Ok(())
    };
    for t in &plot.tracks {
        check(
            format!("track of vehicle {}", t.id),
            &mut t.points.iter().copied(),
        )?;
    }
    check("body path".into(), &mut plot.body_path.iter().copied())?;
    for (k, s) in plot.snapshots.iter().enumerate() {
        if !s.t.is_finite() {
            return Err(PlotError::NonFinite {
                what: "snapshot times".into(),
                index: k,
            });
        }
        check(
            format!("snapshot {k}"),
            &mut s.positions.iter().copied().chain(std::iter::once(s.centre)),
        )?;
    }
    check("optimum".into(), &mut plot.optimum.into_iter())?;
    check(
        "events".into(),
        &mut plot.events.iter().map(|(x, y, _)| (*x, *y)),
    )?;
    Ok(())
}

type Chart<'a, 'b> = ChartContext<'a, SVGBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

fn axis_desc(axis: &str, unit: &str) -> String {
    if unit.is_empty() {
        axis.to_string()
    } else {
        format!("{axis} ({unit})")
    }
}

fn mission_chart<'a, 'b>(
    area: &'a DrawingArea<SVGBackend<'b>, Shift>,
    b: Bounds,
) -> Result<Chart<'a, 'b>, PlotError> {
    let chart = ChartBuilder::on(area)
        .margin_left(10)
        .margin_right(20)
        .margin_top(10)
        .margin_bottom(10)
        .x_label_area_size(55)
        .y_label_area_size(80)
        .build_cartesian_2d(b.x_min..b.x_max, b.y_min..b.y_max)
        .map_err(draw_err)?;
    Ok(chart)
}

/// The plotting area's span in pixels (x, y) between the first and the last pixel, which is
/// what the data range maps onto.
fn mission_plot_span_px(
    area: &DrawingArea<SVGBackend<'_>, Shift>,
) -> Result<(f64, f64), PlotError> {
    let unit_box = Bounds {
        x_min: 0.0,
        x_max: 1.0,
        y_min: 0.0,
        y_max: 1.0,
    };
    let chart = mission_chart(area, unit_box)?;
    let a = chart.backend_coord(&(0.0, 1.0));
    let b = chart.backend_coord(&(1.0, 0.0));
    Ok((f64::from(b.0 - a.0), f64::from(b.1 - a.1)))
}

/// Field samples at the centres of an nx × ny grid of equal cells covering the bounds.
struct Grid {
    bounds: Bounds,
    nx: usize,
    ny: usize,
    /// Row-major, `v[j * nx + i]` at (x_c(i), y_c(j)).
    v: Vec<f64>,
}

impl Grid {
    fn dx(&self) -> f64 {
        self.bounds.width() / self.nx as f64
    }
    fn dy(&self) -> f64 {
        self.bounds.height() / self.ny as f64
    }
    fn xc(&self, i: usize) -> f64 {
        self.bounds.x_min + (i as f64 + 0.5) * self.dx()
    }
    fn yc(&self, j: usize) -> f64 {
        self.bounds.y_min + (j as f64 + 0.5) * self.dy()
    }
    fn at(&self, i: usize, j: usize) -> f64 {
        self.v[j * self.nx + i]
    }
    fn has_no_data(&self) -> bool {
        self.v.iter().any(|v| !v.is_finite())
    }
    fn levels(&self) -> Option<Levels> {
        let mut r: Option<(f64, f64)> = None;
        for &v in self.v.iter().filter(|v| v.is_finite()) {
            r = Some(extend(r, v));
        }
        r.map(|(lo, hi)| nice_levels(lo, hi, FIELD_BANDS))
    }
}

/// Samples `field` on `cells` cells along the longer side of `bounds` (`aspect` = on-screen
/// width / height).
fn sample_field(
    field: &dyn Fn(f64, f64) -> f64,
    bounds: Bounds,
    aspect: f64,
    cells: usize,
) -> Grid {
    let (nx, ny) = if aspect >= 1.0 {
        (cells, ((cells as f64 / aspect).round() as usize).max(2))
    } else {
        (((cells as f64 * aspect).round() as usize).max(2), cells)
    };
    let mut g = Grid {
        bounds,
        nx,
        ny,
        v: Vec::with_capacity(nx * ny),
    };
    for j in 0..ny {
        for i in 0..nx {
            let v = field(g.xc(i), g.yc(j));
            g.v.push(v);
        }
    }
    g
}

/// Colour bands of the field: `n` bands of width `step` from `base`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Levels {
    base: f64,
    step: f64,
    n: usize,
}

impl Levels {
    fn band(&self, v: f64) -> usize {
        let k = ((v - self.base) / self.step).floor();
        if k < 0.0 {
            0
        } else {
            (k as usize).min(self.n - 1)
        }
    }
    fn edge(&self, k: usize) -> f64 {
        self.base + k as f64 * self.step
    }
    fn colour(&self, k: usize) -> RGBColor {
        washed(viridis((k as f64 + 0.5) / self.n as f64), FIELD_WASH)
    }
}

/// Band edges at multiples of a "nice" step (1, 2, 2.5 or 5 × 10^k) giving at most about
/// `target` bands over [lo, hi].
fn nice_levels(lo: f64, hi: f64, target: usize) -> Levels {
    let span = hi - lo;
    if span <= 0.0 || !span.is_finite() {
        let step = if lo == 0.0 {
            1.0
        } else {
            nice_step(0.1 * lo.abs())
        };
        return Levels {
            base: (lo / step).floor() * step,
            step,
            n: 1,
        };
    }
    let step = nice_step(span / target.max(1) as f64);
    let base = (lo / step).floor() * step;
    let n = (((hi - base) / step).ceil() as usize).max(1);
    // `hi` exactly on an edge would fall in a band of its own.
    let n = if base + n as f64 * step < hi {
        n + 1
    } else {
        n
    };
    Levels { base, step, n }
}

/// A filled field rectangle: two opposite corners (length unit) and its colour.
type FieldRect = ((f64, f64), (f64, f64), RGBColor);

/// The grid's cells coloured by band, horizontal runs of one colour merged into one rectangle.
fn field_rects(g: &Grid, levels: Option<&Levels>) -> Vec<FieldRect> {
    let (dx, dy) = (g.dx(), g.dy());
    let x_edge = |i: usize| g.bounds.x_min + i as f64 * dx;
    let y_edge = |j: usize| g.bounds.y_min + j as f64 * dy;
    let mut rects = Vec::new();
    for j in 0..g.ny {
        let colour_of = |i: usize| {
            let v = g.at(i, j);
            match levels {
                Some(l) if v.is_finite() => l.colour(l.band(v)),
                _ => NO_DATA,
            }
        };
        let mut start = 0;
        let mut current = colour_of(0);
        for i in 1..=g.nx {
            let c = if i < g.nx { Some(colour_of(i)) } else { None };
            if c != Some(current) {
                rects.push((
                    (x_edge(start), y_edge(j + 1)),
                    (x_edge(i), y_edge(j)),
                    current,
                ));
                if let Some(c) = c {
                    start = i;
                    current = c;
                }
            }
        }
    }
    rects
}

fn draw_field(
    chart: &mut Chart<'_, '_>,
    g: &Grid,
    levels: Option<&Levels>,
    rects: Vec<FieldRect>,
    px: (f64, f64),
) -> Result<(), PlotError> {
    chart
        .draw_series(
            rects
                .into_iter()
                .map(|(a, b, c)| Rectangle::new([a, b], c.filled())),
        )
        .map_err(draw_err)?;
    let Some(l) = levels else { return Ok(()) };
    let mut lines = Vec::new();
    let mut n_points = 0;
    for k in 1..l.n {
        for line in contour_lines(g, l.edge(k)) {
            let line = simplify_path(&line, px, SIMPLIFY_PX);
            n_points += line.len();
            if n_points > CONTOUR_POINT_BUDGET {
                // A field this rough (noise) is better read from the bands alone.
                return Ok(());
            }
            lines.push(line);
        }
    }
    let style = BLACK.mix(0.35).stroke_width(1);
    chart
        .draw_series(lines.into_iter().map(|line| PathElement::new(line, style)))
        .map_err(draw_err)?;
    Ok(())
}

/// Contour lines of the grid at `level` by marching squares over the sample points (cells with
/// a non-finite corner are skipped), joined into polylines; a closed loop repeats its first
/// point at the end.
fn contour_lines(g: &Grid, level: f64) -> Vec<Vec<(f64, f64)>> {
    let (nx, ny) = (g.nx, g.ny);
    if nx < 2 || ny < 2 {
        return Vec::new();
    }
    let n_h = (nx - 1) * ny;
    let h_edge = |i: usize, j: usize| j * (nx - 1) + i;
    let v_edge = |i: usize, j: usize| n_h + j * nx + i;
    let n_edges = n_h + nx * (ny - 1);
    let interp = |(i0, j0): (usize, usize), (i1, j1): (usize, usize)| {
        let (a, b) = (g.at(i0, j0), g.at(i1, j1));
        let t = ((level - a) / (b - a)).clamp(0.0, 1.0);
        let (x0, y0, x1, y1) = (g.xc(i0), g.yc(j0), g.xc(i1), g.yc(j1));
        (x0 + t * (x1 - x0), y0 + t * (y1 - y0))
    };

    let mut point_of_edge: Vec<Option<(f64, f64)>> = vec![None; n_edges];
    let mut segments: Vec<(usize, usize)> = Vec::new();
    for j in 0..ny - 1 {
        for i in 0..nx - 1 {
            let c = [
                g.at(i, j),
                g.at(i + 1, j),
                g.at(i + 1, j + 1),
                g.at(i, j + 1),
            ];
            if c.iter().any(|v| !v.is_finite()) {
                continue;
            }
            let case = c
                .iter()
                .enumerate()
                .fold(0usize, |acc, (k, &v)| acc | (usize::from(v >= level) << k));
            if case == 0 || case == 15 {
                continue;
            }
            // Edges: 0 bottom, 1 right, 2 top, 3 left.
            let ids = [
                h_edge(i, j),
                v_edge(i + 1, j),
                h_edge(i, j + 1),
                v_edge(i, j),
            ];
            let ends = [
                ((i, j), (i + 1, j)),
                ((i + 1, j), (i + 1, j + 1)),
                ((i, j + 1), (i + 1, j + 1)),
                ((i, j), (i, j + 1)),
            ];
            let centre_high = 0.25 * c.iter().sum::<f64>() >= level;
            let pairs: &[(usize, usize)] = match case {
                1 | 14 => &[(3, 0)],
                2 | 13 => &[(0, 1)],
                3 | 12 => &[(3, 1)],
                4 | 11 => &[(1, 2)],
                6 | 9 => &[(0, 2)],
                7 | 8 => &[(2, 3)],
                5 if centre_high => &[(0, 1), (2, 3)],
                5 => &[(3, 0), (1, 2)],
                10 if centre_high => &[(3, 0), (1, 2)],
                10 => &[(0, 1), (2, 3)],
                _ => &[],
            };
            for &(a, b) in pairs {
                for e in [a, b] {
                    if point_of_edge[ids[e]].is_none() {
                        point_of_edge[ids[e]] = Some(interp(ends[e].0, ends[e].1));
                    }
                }
                segments.push((ids[a], ids[b]));
            }
        }
    }

    // Each edge touches at most two segments (the two cells beside it).
    let mut at_edge: Vec<[usize; 2]> = vec![[usize::MAX; 2]; n_edges];
    for (s, &(a, b)) in segments.iter().enumerate() {
        for e in [a, b] {
            let slot = &mut at_edge[e];
            if slot[0] == usize::MAX {
                slot[0] = s;
            } else {
                slot[1] = s;
            }
        }
    }
    let mut used = vec![false; segments.len()];
    let mut lines = Vec::new();
    for s0 in 0..segments.len() {
        if used[s0] {
            continue;
        }
        used[s0] = true;
        let (a0, b0) = segments[s0];
        let walk = |from: usize, used: &mut Vec<bool>| {
            let mut chain = Vec::new();
            let mut edge = from;
            loop {
                let next = at_edge[edge]
                    .iter()
                    .copied()
                    .find(|&s| s != usize::MAX && !used[s]);
                let Some(s) = next else { break };
                used[s] = true;
                let (a, b) = segments[s];
                edge = if a == edge { b } else { a };
                chain.push(edge);
            }
            chain
        };
        let forward = walk(b0, &mut used);
        let backward = walk(a0, &mut used);
        let edges: Vec<usize> = backward
            .into_iter()
            .rev()
            .chain([a0, b0])
            .chain(forward)
            .collect();
        lines.push(
            edges
                .into_iter()
                .filter_map(|e| point_of_edge[e])
                .collect::<Vec<_>>(),
        );
    }
    lines
}

fn draw_track(chart: &mut Chart<'_, '_>, track: &Track, px: (f64, f64)) -> Result<(), PlotError> {
    let colour = track_colour(track.id);
    let pts = simplify_path(&track.points, px, SIMPLIFY_PX);
    if pts.len() >= 2 {
        chart
            .draw_series(std::iter::once(PathElement::new(
                pts.clone(),
                WHITE.mix(0.7).stroke_width(4),
            )))
            .map_err(draw_err)?;
        chart
            .draw_series(std::iter::once(PathElement::new(
                pts.clone(),
                colour.stroke_width(2),
            )))
            .map_err(draw_err)?;
    }
    if let (Some(&first), Some(&last)) = (pts.first(), pts.last()) {
        chart
            .draw_series([
                Circle::new(first, 4, colour.stroke_width(2)),
                Circle::new(last, 6, WHITE.filled()),
                Circle::new(last, 5, colour.filled()),
            ])
            .map_err(draw_err)?;
    }
    Ok(())
}

fn track_colour(id: u32) -> RGBColor {
    PALETTE[id as usize % PALETTE.len()]
}

const SNAPSHOT: RGBColor = RGBColor(0x22, 0x22, 0x22);
/// Colour of the snapshots taken at events.
const EVENT_SNAPSHOT: RGBColor = RGBColor(0xb2, 0x18, 0x2b);

fn draw_snapshot(chart: &mut Chart<'_, '_>, snap: &Snapshot) -> Result<(), PlotError> {
    let colour = if snap.label.is_empty() {
        SNAPSHOT
    } else {
        EVENT_SNAPSHOT
    };
    let mut ring = angular_order(snap.centre, &snap.positions);
    if ring.len() >= 3 {
        chart
            .draw_series(std::iter::once(Polygon::new(
                ring.clone(),
                WHITE.mix(0.25).filled(),
            )))
            .map_err(draw_err)?;
    }
    if ring.len() >= 2 {
        if ring.len() >= 3 {
            ring.push(ring[0]);
        }
        chart
            .draw_series(std::iter::once(PathElement::new(
                ring.clone(),
                colour.mix(0.85).stroke_width(2),
            )))
            .map_err(draw_err)?;
    }
    chart
        .draw_series(
            snap.positions
                .iter()
                .map(|&p| Circle::new(p, 3, colour.filled())),
        )
        .map_err(draw_err)?;
    chart
        .draw_series(std::iter::once(
            EmptyElement::at(snap.centre)
                + PathElement::new(vec![(-5, 0), (5, 0)], colour.stroke_width(2))
                + PathElement::new(vec![(0, -5), (0, 5)], colour.stroke_width(2)),
        ))
        .map_err(draw_err)?;
    Ok(())
}

/// The centre and the vehicles of a snapshot not more than 3 × the median distance from it
/// (the vehicles flung far away left out).
fn formation_core(snap: &Snapshot) -> Vec<(f64, f64)> {
    let d = |p: &(f64, f64)| (p.0 - snap.centre.0).hypot(p.1 - snap.centre.1);
    let mut dist: Vec<f64> = snap.positions.iter().map(d).collect();
    dist.sort_by(|a, b| a.total_cmp(b));
    let median = dist.get(dist.len() / 2).copied().unwrap_or(0.0);
    snap.positions
        .iter()
        .copied()
        .filter(|p| d(p) <= 3.0 * median)
        .chain(std::iter::once(snap.centre))
        .collect()
}

/// The points sorted by their angle about `centre` (atan2, from −π), ties by distance.
fn angular_order(centre: (f64, f64), points: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut keyed: Vec<(f64, f64, (f64, f64))> = points
        .iter()
        .map(|&(x, y)| {
            let (dx, dy) = (x - centre.0, y - centre.1);
            (dy.atan2(dx), dx.hypot(dy), (x, y))
        })
        .collect();
    keyed.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    keyed.into_iter().map(|k| k.2).collect()
}

/// A five-pointed star (filled polygon) centred at `c` in backend pixels.
fn star(c: (i32, i32), r_out: f64, r_in: f64, style: ShapeStyle) -> Polygon<(i32, i32)> {
    Polygon::new(star_points(c, r_out, r_in), style)
}

fn star_outline(
    c: (i32, i32),
    r_out: f64,
    r_in: f64,
    style: ShapeStyle,
) -> PathElement<(i32, i32)> {
    let mut p = star_points(c, r_out, r_in);
    p.push(p[0]);
    PathElement::new(p, style)
}

fn star_points(c: (i32, i32), r_out: f64, r_in: f64) -> Vec<(i32, i32)> {
    (0..10)
        .map(|k| {
            let r = if k % 2 == 0 { r_out } else { r_in };
            let a = std::f64::consts::FRAC_PI_2 + k as f64 * std::f64::consts::PI / 5.0;
            (
                c.0 + (r * a.cos()).round() as i32,
                c.1 - (r * a.sin()).round() as i32,
            )
        })
        .collect()
}

fn draw_cross(
    area: &DrawingArea<SVGBackend<'_>, Shift>,
    c: (i32, i32),
    r: i32,
) -> Result<(), PlotError> {
    for (style, w) in [(WHITE, 5), (BLACK, 2)] {
        area.draw(&PathElement::new(
            vec![(c.0 - r, c.1 - r), (c.0 + r, c.1 + r)],
            style.stroke_width(w),
        ))
        .map_err(draw_err)?;
        area.draw(&PathElement::new(
            vec![(c.0 - r, c.1 + r), (c.0 + r, c.1 - r)],
            style.stroke_width(w),
        ))
        .map_err(draw_err)?;
    }
    Ok(())
}

/// The side panel of the mission plot: colour bar on top, legend below.
fn draw_mission_side(
    side: &DrawingArea<SVGBackend<'_>, Shift>,
    plot: &MissionPlot<'_>,
    levels: Option<&Levels>,
    has_no_data: bool,
) -> Result<(), PlotError> {
    let (_, h) = side.dim_in_pixel();
    let h = h as i32;
    let left = 20;
    let mut y = 25;
    side.draw(&Text::new(
        plot.field_label.clone(),
        (left, y),
        font(16.0).pos(Pos::new(HPos::Left, VPos::Center)),
    ))
    .map_err(draw_err)?;
    y += 22;
    let bar_h = 340;
    let bar_w = 26;
    match levels {
        Some(l) => {
            let band_h = f64::from(bar_h) / l.n as f64;
            let y_of = |k: usize| y + bar_h - (k as f64 * band_h).round() as i32;
            for k in 0..l.n {
                side.draw(&Rectangle::new(
                    [(left, y_of(k + 1)), (left + bar_w, y_of(k))],
                    l.colour(k).filled(),
                ))
                .map_err(draw_err)?;
            }
            side.draw(&Rectangle::new(
                [(left, y), (left + bar_w, y + bar_h)],
                BLACK.stroke_width(1),
            ))
            .map_err(draw_err)?;
            // Label every edge when there is room, else every other one.
            let every = if band_h >= 20.0 { 1 } else { 2 };
            for k in (0..=l.n).filter(|k| k % every == 0 || *k == l.n) {
                if k == l.n && k % every != 0 {
                    continue;
                }
                let yk = y_of(k);
                side.draw(&PathElement::new(
                    vec![(left + bar_w, yk), (left + bar_w + 5, yk)],
                    BLACK.stroke_width(1),
                ))
                .map_err(draw_err)?;
                side.draw(&Text::new(
                    fmt_level(l.edge(k), l.step),
                    (left + bar_w + 9, yk),
                    font(13.0).pos(Pos::new(HPos::Left, VPos::Center)),
                ))
                .map_err(draw_err)?;
            }
        }
        None => {
            side.draw(&Text::new(
                "(no finite field values)",
                (left, y + 10),
                font(13.0).pos(Pos::new(HPos::Left, VPos::Center)),
            ))
            .map_err(draw_err)?;
        }
    }
    y += bar_h + 20;
    if has_no_data {
        side.draw(&Rectangle::new(
            [(left, y - 7), (left + bar_w, y + 7)],
            NO_DATA.filled(),
        ))
        .map_err(draw_err)?;
        side.draw(&Text::new(
            "no data",
            (left + bar_w + 9, y),
            font(13.0).pos(Pos::new(HPos::Left, VPos::Center)),
        ))
        .map_err(draw_err)?;
        y += 24;
    }
    y += 16;

    let mut entries: Vec<(LegendSymbol, String)> = plot
        .tracks
        .iter()
        .map(|t| {
            (
                LegendSymbol::Track(track_colour(t.id)),
                format!("vehicle {}", t.id),
            )
        })
        .collect();
    if !plot.tracks.is_empty() {
        entries.push((LegendSymbol::StartEnd, "start / end".into()));
    }
    if plot.body_path.len() >= 2 {
        entries.push((LegendSymbol::DashedLine(BLACK), "virtual body".into()));
    }
    if plot.snapshots.iter().any(|s| s.label.is_empty()) {
        entries.push((LegendSymbol::Formation(SNAPSHOT), "formation".into()));
    }
    if plot.snapshots.iter().any(|s| !s.label.is_empty()) {
        entries.push((
            LegendSymbol::Formation(EVENT_SNAPSHOT),
            "formation at an event".into(),
        ));
    }
    if plot.optimum.is_some() {
        entries.push((LegendSymbol::Star, "optimum".into()));
    }
    if !plot.events.is_empty() {
        entries.push((LegendSymbol::Cross, "event".into()));
    }
    draw_legend(side, &entries, y, h - 10)
}

#[derive(Debug, Clone, Copy)]
enum LegendSymbol {
    Line(RGBColor),
    Track(RGBColor),
    DashedLine(RGBColor),
    StartEnd,
    Formation(RGBColor),
    Star,
    Cross,
}

/// Legend rows from `top` to `bottom` (panel pixels): one column, or two when the rows do not
/// fit; entries that still do not fit are summarised as "+N more".
fn draw_legend(
    area: &DrawingArea<SVGBackend<'_>, Shift>,
    entries: &[(LegendSymbol, String)],
    top: i32,
    bottom: i32,
) -> Result<(), PlotError> {
    const ROW: i32 = 24;
    let (w, _) = area.dim_in_pixel();
    let rows = ((bottom - top) / ROW).max(1) as usize;
    let cols = if entries.len() > rows { 2 } else { 1 };
    let col_w = (w as i32 - 20) / cols as i32;
    let capacity = rows * cols;
    let shown = if entries.len() > capacity {
        capacity - 1
    } else {
        entries.len()
    };
    for (k, (symbol, label)) in entries.iter().take(shown).enumerate() {
        let (col, row) = (k / rows, k % rows);
        let x = 20 + col as i32 * col_w;
        let y = top + row as i32 * ROW + ROW / 2;
        draw_symbol(area, *symbol, (x, y))?;
        area.draw(&Text::new(
            label.clone(),
            (x + 46, y),
            font(15.0).pos(Pos::new(HPos::Left, VPos::Center)),
        ))
        .map_err(draw_err)?;
    }
    if shown < entries.len() {
        let k = shown;
        let (col, row) = (k / rows, k % rows);
        area.draw(&Text::new(
            format!("+{} more", entries.len() - shown),
            (
                20 + col as i32 * col_w + 46,
                top + row as i32 * ROW + ROW / 2,
            ),
            font(15.0).pos(Pos::new(HPos::Left, VPos::Center)),
        ))
        .map_err(draw_err)?;
    }
    Ok(())
}

fn draw_symbol(
    area: &DrawingArea<SVGBackend<'_>, Shift>,
    symbol: LegendSymbol,
    (x, y): (i32, i32),
) -> Result<(), PlotError> {
    let seg = vec![(x, y), (x + 34, y)];
    match symbol {
        LegendSymbol::Line(c) => area
            .draw(&PathElement::new(seg, c.stroke_width(2)))
            .map_err(draw_err),
        LegendSymbol::Track(c) => {
            area.draw(&PathElement::new(seg, c.stroke_width(2)))
                .map_err(draw_err)?;
            area.draw(&Circle::new((x + 34, y), 5, c.filled()))
                .map_err(draw_err)
        }
        LegendSymbol::DashedLine(c) => {
            let w = if c == BLACK { 3 } else { 1 };
            for k in 0..3 {
                let x0 = x + k * 13;
                area.draw(&PathElement::new(
                    vec![(x0, y), ((x0 + 8).min(x + 34), y)],
                    c.stroke_width(w),
                ))
                .map_err(draw_err)?;
            }
            Ok(())
        }
        LegendSymbol::StartEnd => {
            let grey = RGBColor(0x55, 0x55, 0x55);
            area.draw(&Circle::new((x + 6, y), 4, grey.stroke_width(2)))
                .map_err(draw_err)?;
            area.draw(&Circle::new((x + 27, y), 5, grey.filled()))
                .map_err(draw_err)
        }
        LegendSymbol::Formation(colour) => {
            let pts = vec![
                (x + 4, y + 7),
                (x + 17, y - 8),
                (x + 30, y + 7),
                (x + 4, y + 7),
            ];
            area.draw(&PathElement::new(pts.clone(), colour.stroke_width(2)))
                .map_err(draw_err)?;
            for p in &pts[..3] {
                area.draw(&Circle::new(*p, 3, colour.filled()))
                    .map_err(draw_err)?;
            }
            Ok(())
        }
        LegendSymbol::Star => {
            area.draw(&star((x + 17, y), 10.0, 4.0, RED_STAR.filled()))
                .map_err(draw_err)?;
            area.draw(&star_outline((x + 17, y), 10.0, 4.0, BLACK.stroke_width(2)))
                .map_err(draw_err)
        }
        LegendSymbol::Cross => draw_cross(area, (x + 17, y), 6),
    }
}

// ---------------------------------------------------------------------------------------------
// Labels that avoid each other.

#[derive(Debug, Clone, Copy, PartialEq)]
enum LabelSide {
    /// Centred above the anchor or below this y (px), moving away when taken, then around
    /// the anchor.
    AboveOrBelow(i32),
    /// Right of the anchor's vertical line, moving down when taken.
    Below,
    /// Any of the four diagonal positions, then further out.
    Around,
}

/// Greedy placement of text labels (boxes in backend pixels) inside a region.
struct LabelPlacer {
    region: (i32, i32, i32, i32),
    taken: Vec<(i32, i32, i32, i32)>,
}

impl LabelPlacer {
    fn new((xr, yr): (std::ops::Range<i32>, std::ops::Range<i32>)) -> Self {
        Self {
            region: (xr.start, yr.start, xr.end, yr.end),
            taken: Vec::new(),
        }
    }

    fn block(&mut self, b: (i32, i32, i32, i32)) {
        self.taken.push(b);
    }

    fn overlap(&self, b: (i32, i32, i32, i32)) -> i64 {
        let r = self.region;
        let outside = i64::from(b.0 < r.0 || b.1 < r.1 || b.2 > r.2 || b.3 > r.3) * 1_000_000;
        outside
            + self
                .taken
                .iter()
                .map(|t| {
                    let w = (b.2.min(t.2) - b.0.max(t.0)).max(0);
                    let h = (b.3.min(t.3) - b.1.max(t.1)).max(0);
                    i64::from(w) * i64::from(h)
                })
                .sum::<i64>()
    }

    /// Draws `text` (font size `size` px) on a white box near `anchor`, at the first free spot.
    fn place_label(
        &mut self,
        area: &DrawingArea<SVGBackend<'_>, Shift>,
        text: &str,
        anchor: (i32, i32),
        size: f64,
        side: LabelSide,
    ) -> Result<(), PlotError> {
        let w = (text.chars().count() as f64 * 0.56 * size).ceil() as i32 + 8;
        let h = (size * 1.4).ceil() as i32;
        let (ax, ay) = anchor;
        let mut candidates: Vec<(i32, i32)> = Vec::new(); // top-left corners
        for step in 0..8 {
            match side {
                LabelSide::AboveOrBelow(below) => candidates.extend([
                    (ax - w / 2, ay - h - step * (h + 2)),
                    (ax - w / 2, below + step * (h + 2)),
                ]),
                LabelSide::Below => candidates.push((ax + 3, ay + step * (h + 2))),
                LabelSide::Around => {
                    let d = 8 + step * (h + 2);
                    candidates.extend([
                        (ax + 8, ay - d - h + 4),
                        (ax + 8, ay + d - 4),
                        (ax - 8 - w, ay - d - h + 4),
                        (ax - 8 - w, ay + d - 4),
                    ]);
                }
            }
        }
        // Slid sideways into the region where it is too wide for where it was.
        let (left, right) = (self.region.0, self.region.2 - w);
        for c in &mut candidates {
            if right >= left {
                c.0 = c.0.clamp(left, right);
            }
        }
        let mut best = candidates[0];
        let mut best_cost = i64::MAX;
        for &(x, y) in &candidates {
            let cost = self.overlap((x, y, x + w, y + h));
            if cost < best_cost {
                best_cost = cost;
                best = (x, y);
            }
            if cost == 0 {
                break;
            }
        }
        let (x, y) = best;
        self.taken.push((x, y, x + w, y + h));
        area.draw(&Rectangle::new(
            [(x, y), (x + w, y + h)],
            WHITE.mix(0.8).filled(),
        ))
        .map_err(draw_err)?;
        area.draw(&Text::new(
            text.to_string(),
            (x + 4, y + h / 2),
            font(size).pos(Pos::new(HPos::Left, VPos::Center)),
        ))
        .map_err(draw_err)
    }
}

// ---------------------------------------------------------------------------------------------
// Small helpers.

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

fn draw_err<E: std::error::Error + Send + Sync>(e: DrawingAreaErrorKind<E>) -> PlotError {
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

fn widen_if_flat(lo: f64, hi: f64) -> (f64, f64) {
    if hi > lo {
        (lo, hi)
    } else {
        let d = 1.0_f64.max(0.1 * lo.abs());
        (lo - d, hi + d)
    }
}

/// Viridis colormap at t ∈ [0, 1] (clamped).
fn viridis(t: f64) -> RGBColor {
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let s = t * (VIRIDIS.len() - 1) as f64;
    let k = (s.floor() as usize).min(VIRIDIS.len() - 2);
    let f = s - k as f64;
    let (a, b) = (VIRIDIS[k], VIRIDIS[k + 1]);
    let lerp = |p: u8, q: u8| (f64::from(p) + f * (f64::from(q) - f64::from(p))).round() as u8;
    RGBColor(lerp(a.0, b.0), lerp(a.1, b.1), lerp(a.2, b.2))
}

/// `c` mixed with white: `amount` = 0 keeps it, 1 gives white.
fn washed(c: RGBColor, amount: f64) -> RGBColor {
    let m = |v: u8| (f64::from(v) + amount * (255.0 - f64::from(v))).round() as u8;
    RGBColor(m(c.0), m(c.1), m(c.2))
}

/// A band edge written with as many decimals as the step needs (scientific when very large or
/// very small).
fn fmt_level(v: f64, step: f64) -> String {
    let mag = v.abs().max(step.abs());
    if mag >= 1e6 || step.abs() < 1e-4 {
        return format!("{v:.3e}");
    }
    let mut decimals = 0;
    while decimals < 6 {
        let scaled = step * 10f64.powi(decimals);
        if (scaled - scaled.round()).abs() < 1e-6 * scaled.abs().max(1.0) {
            break;
        }
        decimals += 1;
    }
    let s = format!("{v:.*}", decimals as usize);
    if s.trim_start_matches('-')
        .chars()
        .all(|c| c == '0' || c == '.')
    {
        s.trim_start_matches('-').to_string()
    } else {
        s
    }
}

/// An axis tick value on an axis of extent `span`: enough decimals for ticks about span / 10
/// apart, trailing zeros dropped ("200", "0.25", never "-0").
fn fmt_tick(v: f64, span: f64) -> String {
    let decimals = if span > 0.0 && span.is_finite() {
        (2.0 - span.log10().floor()).clamp(0.0, 9.0) as usize
    } else {
        3
    };
    let mut s = format!("{v:.decimals$}");
    if s.contains('.') {
        s = s.trim_end_matches('0').trim_end_matches('.').to_string();
    }
    if s == "-0" {
        s = "0".into();
    }
    s
}

/// Douglas–Peucker simplification of a polyline, with the tolerance `tol_px` in pixels where a
/// pixel is `px.0` × `px.1` length units; endpoints are kept. Consecutive duplicates go first.
fn simplify_path(points: &[(f64, f64)], px: (f64, f64), tol_px: f64) -> Vec<(f64, f64)> {
    let mut pts: Vec<(f64, f64)> = Vec::with_capacity(points.len());
    for &p in points {
        if pts.last() != Some(&p) {
            pts.push(p);
        }
    }
    if pts.len() <= 2 || !(px.0 > 0.0 && px.1 > 0.0) {
        return pts;
    }
    let scaled: Vec<(f64, f64)> = pts.iter().map(|&(x, y)| (x / px.0, y / px.1)).collect();
    let mut keep = vec![false; pts.len()];
    keep[0] = true;
    keep[pts.len() - 1] = true;
    let mut stack = vec![(0usize, pts.len() - 1)];
    while let Some((a, b)) = stack.pop() {
        if b <= a + 1 {
            continue;
        }
        let (pa, pb) = (scaled[a], scaled[b]);
        let (dx, dy) = (pb.0 - pa.0, pb.1 - pa.1);
        let len = dx.hypot(dy);
        let mut worst = (0.0, a);
        for (k, p) in scaled.iter().enumerate().take(b).skip(a + 1) {
            let d = if len > 0.0 {
                ((p.0 - pa.0) * dy - (p.1 - pa.1) * dx).abs() / len
            } else {
                (p.0 - pa.0).hypot(p.1 - pa.1)
            };
            if d > worst.0 {
                worst = (d, k);
            }
        }
        if worst.0 > tol_px {
            keep[worst.1] = true;
            stack.push((a, worst.1));
            stack.push((worst.1, b));
        }
    }
    pts.into_iter()
        .zip(keep)
        .filter_map(|(p, k)| k.then_some(p))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    /// A fresh directory under the system temp dir, removed on drop.
    struct TempDir(PathBuf);
    impl TempDir {
        fn new(tag: &str) -> Self {
            let p = std::env::temp_dir().join(format!(
                "vbap-plot-{tag}-{}-{:?}",
                std::process::id(),
                std::thread::current().id()
            ));
            let _ = std::fs::remove_dir_all(&p);
            std::fs::create_dir_all(&p).unwrap();
            TempDir(p)
        }
    }
    impl Drop for TempDir {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }

    fn gaussian(x: f64, y: f64) -> f64 {
        20.0 + 5.0 * (-((x - 30.0).powi(2) + (y - 20.0).powi(2)) / (2.0 * 40.0f64.powi(2))).exp()
    }

    fn spiral(id: u32, n: usize) -> Track {
        let phase = f64::from(id) * std::f64::consts::FRAC_PI_2;
        let points = (0..n)
            .map(|k| {
                let s = k as f64 / (n - 1) as f64;
                let r = 80.0 * (1.0 - s) + 5.0;
                let a = phase + 6.0 * s;
                (30.0 + r * a.cos() - 60.0 * (1.0 - s), 20.0 + r * a.sin())
            })
            .collect();
        Track { id, points }
    }

    fn example(field: &dyn Fn(f64, f64) -> f64, n: usize) -> MissionPlot<'_> {
        let tracks: Vec<Track> = (0..4).map(|id| spiral(id, n)).collect();
        let body_path = (0..n)
            .map(|k| {
                let s = k as f64 / (n - 1) as f64;
                (30.0 - 60.0 * (1.0 - s), 20.0)
            })
            .collect();
        let snapshots = [0, n / 2, n - 1]
            .iter()
            .map(|&k| Snapshot {
                t: k as f64 * 0.5,
                label: if k == n / 2 {
                    "lost 2, redesign".into()
                } else {
                    String::new()
                },
                positions: tracks.iter().map(|t| t.points[k]).collect(),
                centre: (30.0 - 60.0 * (1.0 - k as f64 / (n - 1) as f64), 20.0),
            })
            .collect();
        MissionPlot {
            title: "Test mission & plot".into(),
            length_unit: "m".into(),
            field,
            field_label: "T (°C)".into(),
            tracks,
            body_path,
            snapshots,
            optimum: Some((30.0, 20.0)),
            events: vec![(0.0, 10.0, "vehicle 2 killed".into())],
        }
    }

    #[test]
    fn mission_svg_is_written_with_title_legend_and_bounded_size() {
        let dir = TempDir::new("mission");
        let path = dir.0.join("plot.svg");
        let plot = example(&gaussian, 400);
        write_mission_svg(&plot, &path).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let text = String::from_utf8(bytes.clone()).unwrap();
        assert!(text.starts_with("<svg"), "{}", &text[..40]);
        assert!(text.trim_end().ends_with("</svg>"));
        assert!(text.contains("Test mission &amp; plot"));
        for label in [
            "vehicle 0",
            "vehicle 1",
            "vehicle 2",
            "vehicle 3",
            "virtual body",
            "formation",
            "optimum",
            "T (°C)",
            "x (m)",
            "y (m)",
            "vehicle 2 killed",
            "t = 0 s",
            "formation at an event",
            ": lost 2, redesign",
        ] {
            assert!(text.contains(label), "missing {label}");
        }
        assert!(bytes.len() < 2_000_000, "{} bytes", bytes.len());
    }

    #[test]
    fn mission_svg_is_deterministic() {
        let plot = example(&gaussian, 200);
        let a = render_mission_svg(&plot).unwrap();
        let b = render_mission_svg(&plot).unwrap();
        assert_eq!(a, b);
    }

    /// Worst case for the merged cells: a field that changes band almost every cell, plus
    /// long tracks (simplified before drawing).
    #[test]
    fn mission_svg_stays_small_for_a_busy_field_and_long_tracks() {
        let busy = |x: f64, y: f64| (x * 0.3).sin() * (y * 0.3).cos() + 0.01 * x;
        let plot = example(&busy, 20_000);
        let svg = render_mission_svg(&plot).unwrap();
        assert!(svg.len() < 2_000_000, "{} bytes", svg.len());
    }

    /// Worst case of all: a field that is pure noise at the cell scale.
    #[test]
    fn mission_svg_stays_small_for_a_noise_field() {
        let noise = |x: f64, y: f64| ((x * 12.9898 + y * 78.233).sin() * 43_758.545_3).fract();
        let plot = example(&noise, 100);
        let svg = render_mission_svg(&plot).unwrap();
        assert!(svg.len() < 2_000_000, "{} bytes", svg.len());
    }

    #[test]
    fn crowded_legend_is_summarised() {
        let mut plot = example(&gaussian, 20);
        plot.tracks = (0..60)
            .map(|id| Track {
                id,
                points: vec![(f64::from(id), 0.0), (f64::from(id), 10.0)],
            })
            .collect();
        let svg = render_mission_svg(&plot).unwrap();
        assert!(svg.contains("vehicle 0\n") && svg.contains("vehicle 30\n"));
        assert!(!svg.contains("vehicle 59\n"));
        assert!(svg.contains(" more\n"));
    }

    #[test]
    fn non_dimensional_axes_have_no_unit() {
        let mut plot = example(&gaussian, 50);
        plot.length_unit = String::new();
        let svg = render_mission_svg(&plot).unwrap();
        assert!(
            svg.contains(">\nx\n<") || svg.contains(">\nx\n</text>"),
            "x label"
        );
        assert!(!svg.contains("x (m)"));
        assert!(svg.contains("t = 0 s"));
    }

    #[test]
    fn non_finite_geometry_is_an_error_and_field_nan_is_not() {
        let mut plot = example(&gaussian, 50);
        plot.tracks[1].points[7].0 = f64::NAN;
        match render_mission_svg(&plot) {
            Err(PlotError::NonFinite { what, index }) => {
                assert_eq!(what, "track of vehicle 1");
                assert_eq!(index, 7);
            }
            other => panic!("expected NonFinite, got {:?}", other.map(|s| s.len())),
        }
        let holey = |x: f64, y: f64| if x > 0.0 { f64::NAN } else { gaussian(x, y) };
        let plot = example(&holey, 50);
        let svg = render_mission_svg(&plot).unwrap();
        assert!(svg.contains("no data"));
    }

    #[test]
    fn empty_plot_is_an_error() {
        let plot = MissionPlot {
            title: "empty".into(),
            length_unit: "m".into(),
            field: &gaussian,
            field_label: "T".into(),
            tracks: vec![],
            body_path: vec![],
            snapshots: vec![],
            optimum: None,
            events: vec![],
        };
        assert!(matches!(
            render_mission_svg(&plot),
            Err(PlotError::Empty(_))
        ));
    }

    #[test]
    fn bounds_cover_points_with_margin_and_requested_aspect() {
        let pts = [(0.0, 0.0), (10.0, 2.0), (4.0, -3.0)];
        for aspect in [0.5, 1.0, 1.7] {
            let b = bounds_around(pts, 0.1, aspect).unwrap();
            assert_relative_eq!(b.width() / b.height(), aspect, max_relative = 1e-12);
            for p in pts {
                assert!(b.contains(p));
                // At least the margin (0.1 × larger extent 10) on every side.
                assert!(p.0 - b.x_min >= 1.0 - 1e-12 && b.x_max - p.0 >= 1.0 - 1e-12);
                assert!(p.1 - b.y_min >= 1.0 - 1e-12 && b.y_max - p.1 >= 1.0 - 1e-12);
            }
        }
        // Tight in the binding direction: width = 10 + 2 margins when aspect is small.
        let b = bounds_around(pts, 0.1, 0.5).unwrap();
        assert_relative_eq!(b.width(), 12.0, max_relative = 1e-12);
        let flat = bounds_around([(0.0, 0.0), (4.0, 0.0)], 0.0, 2.0).unwrap();
        assert_relative_eq!(flat.width(), 4.0);
        assert_relative_eq!(flat.height(), 2.0);
        let single = bounds_around([(5.0, 5.0)], 0.1, 1.0).unwrap();
        assert!(single.width() > 0.0 && single.contains((5.0, 5.0)));
        assert!(matches!(
            bounds_around(std::iter::empty(), 0.1, 1.0),
            Err(PlotError::Empty(_))
        ));
        assert!(matches!(
            bounds_around(pts, 0.1, 0.0),
            Err(PlotError::InvalidParameter(_))
        ));
    }

    #[test]
    fn choose_bounds_covers_everything_in_the_plot() {
        let plot = example(&gaussian, 100);
        let b = choose_bounds(&plot, 1.3).unwrap();
        assert_relative_eq!(b.width() / b.height(), 1.3, max_relative = 1e-12);
        for t in &plot.tracks {
            assert!(t.points.iter().all(|&p| b.contains(p)));
        }
        assert!(plot.body_path.iter().all(|&p| b.contains(p)));
        assert!(b.contains(plot.optimum.unwrap()));
        assert!(b.contains((plot.events[0].0, plot.events[0].1)));
    }

    /// Equal aspect: one length unit is the same number of pixels on both axes.
    #[test]
    fn mission_chart_has_equal_scales() {
        let plot = example(&gaussian, 100);
        let mut svg = String::new();
        let root = SVGBackend::with_string(&mut svg, MISSION_SIZE).into_drawing_area();
        let (_, body) = root.split_vertically(TITLE_H);
        let (chart_area, _) = body.split_horizontally(MISSION_CHART_W);
        let (sx, sy) = mission_plot_span_px(&chart_area).unwrap();
        let b = choose_bounds(&plot, sx / sy).unwrap();
        let chart = mission_chart(&chart_area, b).unwrap();
        let p0 = chart.backend_coord(&(b.x_min, b.y_min));
        let p1 = chart.backend_coord(&(b.x_max, b.y_max));
        let scale_x = f64::from(p1.0 - p0.0) / b.width();
        let scale_y = f64::from(p0.1 - p1.1) / b.height();
        assert_relative_eq!(scale_x, scale_y, max_relative = 0.005);
    }

    #[test]
    fn contour_of_a_plane_is_one_straight_line() {
        let b = Bounds {
            x_min: 0.0,
            x_max: 10.0,
            y_min: 0.0,
            y_max: 5.0,
        };
        let g = sample_field(&|x, _| x, b, 2.0, FIELD_GRID);
        let lines = contour_lines(&g, 3.3);
        assert_eq!(lines.len(), 1);
        let line = &lines[0];
        assert_eq!(line.len(), g.ny);
        for &(x, _) in line {
            assert_relative_eq!(x, 3.3, epsilon = 1e-9);
        }
        let ys: Vec<f64> = line.iter().map(|p| p.1).collect();
        assert_relative_eq!(ys.iter().cloned().fold(f64::INFINITY, f64::min), g.yc(0));
        assert_relative_eq!(
            ys.iter().cloned().fold(f64::NEG_INFINITY, f64::max),
            g.yc(g.ny - 1)
        );
    }

    #[test]
    fn contour_of_a_bowl_is_a_closed_circle() {
        let b = Bounds {
            x_min: -2.0,
            x_max: 2.0,
            y_min: -2.0,
            y_max: 2.0,
        };
        let g = sample_field(&|x, y| x * x + y * y, b, 1.0, FIELD_GRID);
        let lines = contour_lines(&g, 1.0);
        assert_eq!(lines.len(), 1);
        let ring = &lines[0];
        assert!(ring.len() > 50);
        assert_eq!(ring.first(), ring.last(), "closed");
        // Linear interpolation of r² on cells of side h errs by at most about h²/4.
        let h = g.dx();
        for &(x, y) in ring {
            assert!((x.hypot(y) - 1.0).abs() < 0.5 * h * h, "r = {}", x.hypot(y));
        }
    }

    #[test]
    fn nice_levels_cover_the_range_with_a_nice_step() {
        for (lo, hi) in [(0.13, 0.87), (-3.0, 17.0), (20.0, 25.0), (1000.0, 1000.5)] {
            let l = nice_levels(lo, hi, 12);
            assert!(l.base <= lo && l.edge(l.n) >= hi, "{lo}..{hi}: {l:?}");
            assert!(l.n <= 13 && l.n >= 4, "{lo}..{hi}: {l:?}");
            let m = l.step / 10f64.powf(l.step.log10().floor());
            assert!(
                [1.0, 2.0, 2.5, 5.0, 10.0]
                    .iter()
                    .any(|n| (m - n).abs() < 1e-9),
                "step {}",
                l.step
            );
            assert_eq!(l.band(lo), 0);
            assert_eq!(l.band(hi), l.n - 1);
        }
        let flat = nice_levels(4.0, 4.0, 12);
        assert_eq!(flat.n, 1);
        assert_eq!(flat.band(4.0), 0);
    }

    #[test]
    fn level_labels_are_short_and_exact() {
        assert_eq!(fmt_level(0.25, 0.25), "0.25");
        assert_eq!(fmt_level(20.5, 0.5), "20.5");
        assert_eq!(fmt_level(-0.0, 0.1), "0.0");
        assert_eq!(fmt_level(1e-12, 0.2), "0.0");
        assert_eq!(fmt_level(40.0, 5.0), "40");
    }

    #[test]
    fn viridis_ends_and_wash() {
        assert_eq!(viridis(0.0), RGBColor(0x44, 0x01, 0x54));
        assert_eq!(viridis(1.0), RGBColor(0xfd, 0xe7, 0x25));
        assert_eq!(viridis(0.5), RGBColor(0x21, 0x91, 0x8c));
        assert_eq!(washed(RGBColor(0, 0, 0), 1.0), WHITE);
        assert_eq!(washed(RGBColor(10, 20, 30), 0.0), RGBColor(10, 20, 30));
    }

    #[test]
    fn angular_order_goes_round_the_centre() {
        let c = (1.0, 1.0);
        let pts = [(2.0, 1.0), (0.0, 1.0), (1.0, 2.0), (1.0, 0.0)];
        let ordered = angular_order(c, &pts);
        // Angles from atan2: −π/2, 0, π/2, π.
        assert_eq!(
            ordered,
            vec![(1.0, 0.0), (2.0, 1.0), (1.0, 2.0), (0.0, 1.0)]
        );
    }

    #[test]
    fn simplify_keeps_corners_and_drops_collinear_points() {
        let line: Vec<(f64, f64)> = (0..1000).map(|k| (k as f64, 2.0 * k as f64)).collect();
        assert_eq!(
            simplify_path(&line, (1.0, 1.0), 0.4),
            vec![(0.0, 0.0), (999.0, 1998.0)]
        );
        let corner = vec![
            (0.0, 0.0),
            (1.0, 0.0),
            (2.0, 0.0),
            (2.0, 1.0),
            (2.0, 2.0),
            (2.0, 2.0),
        ];
        assert_eq!(
            simplify_path(&corner, (0.01, 0.01), 0.4),
            vec![(0.0, 0.0), (2.0, 0.0), (2.0, 2.0)]
        );
    }

    #[test]
    fn timeseries_svg_is_written_with_labels() {
        let dir = TempDir::new("ts");
        let path = dir.0.join("v.svg");
        let series = vec![
            (
                "V / V_U".to_string(),
                (0..500)
                    .map(|k| (k as f64 * 0.2, (-(k as f64) * 0.01).exp()))
                    .collect(),
            ),
            (
                "speed (m/s)".to_string(),
                (0..500).map(|k| (k as f64 * 0.2, 0.5)).collect(),
            ),
        ];
        let markers = vec![(30.0, "kill 2".to_string()), (60.0, "rejoin 2".to_string())];
        write_timeseries_svg(
            &path,
            "Lyapunov <check>",
            "t (s)",
            &series,
            "value",
            &markers,
        )
        .unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(text.starts_with("<svg"));
        for s in [
            "Lyapunov &lt;check&gt;",
            "V / V_U",
            "speed (m/s)",
            "kill 2",
            "rejoin 2",
            "t (s)",
            "value",
        ] {
            assert!(text.contains(s), "missing {s}");
        }
        assert!(text.len() < 500_000, "{} bytes", text.len());
        let again =
            render_timeseries_svg("Lyapunov <check>", "t (s)", &series, "value", &markers).unwrap();
        assert_eq!(text, again);
    }

    #[test]
    fn timeseries_rejects_empty_and_non_finite() {
        let empty: Vec<(String, Vec<(f64, f64)>)> = vec![("a".into(), vec![])];
        assert!(matches!(
            render_timeseries_svg("t", "x", &empty, "y", &[]),
            Err(PlotError::Empty(_))
        ));
        let nan = vec![("a".to_string(), vec![(0.0, 1.0), (1.0, f64::INFINITY)])];
        assert!(matches!(
            render_timeseries_svg("t", "x", &nan, "y", &[]),
            Err(PlotError::NonFinite { index: 1, .. })
        ));
        // A single flat point still plots.
        let one = vec![("a".to_string(), vec![(2.0, 3.0)])];
        assert!(render_timeseries_svg("t", "x", &one, "y", &[]).is_ok());
    }

    fn event(k: u64, kind: &str, vehicle: Option<u32>, detail: serde_json::Value) -> Event {
        Event {
            t: k as f64 * 10.0,
            k,
            kind: kind.into(),
            vehicle,
            detail,
        }
    }

    #[test]
    fn event_snapshots_group_coincident_events_and_keep_the_telling_ones() {
        use serde_json::json;
        let events = vec![
            event(0, "join", Some(0), json!(null)),
            event(100, "fault", Some(2), json!({"fault": "kill"})),
            event(100, "lost", Some(2), json!({"cause": "scheduled kill"})),
            event(101, "reconfigured", None, json!({"vehicles": [0, 1, 3]})),
            event(150, "link_drop", Some(1), json!(null)),
            event(400, "rejoin", Some(2), json!(null)),
            event(401, "reconfigured", None, json!({"vehicles": [0, 1, 2, 3]})),
        ];
        let snaps = event_snapshots(&events, MAX_EVENT_SNAPSHOTS, 5);
        assert_eq!(
            snaps,
            vec![
                (100, "lost 2, redesign".to_string()),
                (400, "rejoin 2, redesign".to_string())
            ]
        );
        // Too many: the first of each kind, then by kind and time, shown in time order.
        let mut many: Vec<Event> = (0..20)
            .map(|i| event(1000 + 100 * i, "reconfigured", None, json!(null)))
            .collect();
        many.push(event(5000, "stall_began", None, json!({"why": "holding"})));
        many.push(event(3000, "near_collision", None, json!({"pair": [1, 4]})));
        many.push(event(4000, "lost", Some(3), json!(null)));
        let snaps = event_snapshots(&many, 4, 5);
        assert_eq!(snaps.len(), 4);
        let labels: Vec<&str> = snaps.iter().map(|s| s.1.as_str()).collect();
        assert_eq!(
            labels,
            vec![
                "redesign",
                "near collision 1–4",
                "lost 3",
                "stall (holding)"
            ]
        );
        assert!(snaps.windows(2).all(|w| w[0].0 < w[1].0));
        assert!(event_snapshots(&[], 6, 5).is_empty());
    }

    #[test]
    fn long_missions_label_snapshots_in_hours() {
        let mut plot = example(&gaussian, 50);
        for (i, s) in plot.snapshots.iter_mut().enumerate() {
            s.t = i as f64 * 64_800.0; // 0, 18 h, 36 h
        }
        let svg = render_mission_svg(&plot).unwrap();
        assert!(svg.contains("t = 0 h"), "first snapshot");
        assert!(svg.contains("t = 18 h: lost 2, redesign"), "event snapshot");
        assert!(svg.contains("t = 36 h"), "last snapshot");
        assert!(!svg.contains("129600"));
    }

    #[test]
    fn read_events_skips_partial_lines_and_missing_files() {
        let dir = TempDir::new("events");
        let path = dir.0.join("events.jsonl");
        assert!(read_events(&path).unwrap().is_empty());
        std::fs::write(
            &path,
            "{\"t\":1,\"k\":10,\"kind\":\"lost\",\"vehicle\":2}\n{\"t\":2,\"k\":2",
        )
        .unwrap();
        let ev = read_events(&path).unwrap();
        assert_eq!(ev.len(), 1);
        assert_eq!(ev[0].kind, "lost");
        assert_eq!(ev[0].vehicle, Some(2));
    }
}
