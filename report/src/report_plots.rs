//! Time-series plots of a run directory, and the small SVG chart writer they (and
//! `vbap analyze`'s plots) are drawn with.
//!
//! [`write_run_plots`] reads `body.csv`, `events.jsonl` and the resolved `mission.toml`
//! (and, when the run has them, the truth files `formation.csv` and `truth.csv`, through
//! [`crate::truth_plots`]) and writes two figures, each a stack of panels on one time axis
//! in s, min, h or days by the run's length, with the events of `events.jsonl` (vehicle
//! lost, rejoined, formation reconfigured or broken, faults, holding, stalls, near
//! collisions, converged) drawn as coloured dashed vertical lines, and the contact timeline:
//! - `timeseries_formation.svg`: V/V_U (Theorem 4.1; true and as the coordinator sees it
//!   when `truth.csv` is there), the body speed ṡ against v₀, the formation scale k, each
//!   vehicle's distance from its slot and the nearest pair ÷ spacing (truth files only),
//!   the vehicles in the formation (members, alive, truly in formation);
//! - `timeseries_estimate.svg`: the gradient-estimate error ‖∇T_est − ∇T‖ against the true
//!   ‖∇T‖, the trace of the Kalman covariance P, the distance of the body centre to the
//!   optimum against the tolerance (log axes);
//! - `contact.svg` ([`crate::truth_plots::render_contact_svg`]), from `formation.csv` only.
//!
//! Long runs are decimated while streaming (minimum and maximum of each of ~1500 buckets,
//! so spikes survive), so the files stay small whatever the number of ticks.
//!
//! The chart writer ([`Figure`], [`Panel`], [`Axis`], [`Series`]) writes plain SVG 1.1 by
//! hand: linear or logarithmic axes with 1-2-5 ticks (time axes at steps of the clock),
//! clipped polylines, horizontal
//! reference lines, event markers and a legend column. Its output is deterministic (same
//! input, same bytes) and renders the same in browsers and `rsvg-convert`.

use std::collections::BTreeSet;
use std::fmt::Write as _;
use std::fs::File;
use std::io::{BufRead, BufReader};
use std::path::Path;

pub use crate::plot::style::PALETTE;
use crate::plot::style::{self, TimeUnit};
use anyhow::{Context, Result};
use vbap_math::Vec3;
use vbap_mission::config::Mission;
use vbap_mission::rundir::{Event, RunDir};

use crate::truth_plots::{self, Formation, Truth};

/// File name of the formation time series.
pub const FORMATION_SVG: &str = "timeseries_formation.svg";
/// File name of the estimator time series.
pub const ESTIMATE_SVG: &str = "timeseries_estimate.svg";
/// Points kept per series of a time-series plot (as min/max pairs of half as many buckets).
pub const MAX_POINTS: usize = 3000;

// ---------------------------------------------------------------------------------------------
// The run plots.

/// Writes the time-series plots of `dir` (from body.csv, events.jsonl and mission.toml);
/// nothing when body.csv has no rows.
pub fn write_run_plots(dir: &RunDir) -> Result<()> {
    let mission = Mission::load(&dir.mission())?;
    let data = RunSeries::read(dir, &mission)?;
    if data.rows == 0 {
        // A run stopped before its first tick: nothing to plot.
        return Ok(());
    }
    let events = crate::plot::read_events(&dir.events())
        .with_context(|| format!("reading {}", dir.events().display()))?;
    let unit = TimeUnit::for_span(data.last_t);
    // The files of the truth metrics (absent in older runs: their panels are left out).
    let t_range = (data.first_t, data.last_t + mission.mission.dt);
    let formation_data = truth_plots::read_formation_or_warn(dir, &mission, t_range);
    let truth = truth_plots::read_truth_or_warn(dir, &mission);
    let (formation, estimate) = run_figures(
        &mission,
        &data,
        &events,
        formation_data.as_ref(),
        truth.as_ref(),
    );
    write_svg(&formation, &dir.root.join(FORMATION_SVG))?;
    write_svg(&estimate, &dir.root.join(ESTIMATE_SVG))?;
    let contact = dir.root.join(truth_plots::CONTACT_SVG);
    match formation_data {
        Some(f) => {
            let svg = truth_plots::render_contact_svg(&mission, &f, &events, unit);
            std::fs::write(&contact, svg)
                .with_context(|| format!("writing {}", contact.display()))?;
        }
        // An older run: no contact states recorded; no stale picture of another run either.
        None => {
            let _ = std::fs::remove_file(&contact);
        }
    }
    Ok(())
}

/// The series of a run, decimated, in mission time (s).
#[derive(Default)]
struct RunSeries {
    v_over_vu: Decimator,
    sdot: Decimator,
    scale: Decimator,
    vehicles: Decimator,
    grad_error: Decimator,
    grad_true: Decimator,
    p_trace: Decimator,
    distance: Vec<(f64, f64)>,
    rows: u64,
    first_t: f64,
    last_t: f64,
    max_v_over_vu: f64,
    has_truth: bool,
}

impl RunSeries {
    fn read(dir: &RunDir, mission: &Mission) -> Result<Self> {
        let path = dir.body();
        let file = File::open(&path).with_context(|| format!("opening {}", path.display()))?;
        let mut lines = BufReader::with_capacity(1 << 16, file).lines();
        let header = lines
            .next()
            .transpose()
            .with_context(|| format!("reading {}", path.display()))?
            .unwrap_or_default();
        let names: Vec<&str> = header.split(',').collect();
        let col = |name: &str| names.iter().position(|n| *n == name);
        let need = |name: &str| {
            col(name).with_context(|| format!("{}: no column {name:?}", path.display()))
        };
        let (c_t, c_sdot, c_scale, c_v, c_n) = (
            need("t")?,
            need("sdot")?,
            need("scale")?,
            need("V")?,
            need("n_vehicles")?,
        );
        let c_r = [need("rx")?, need("ry")?, need("rz")?];
        let c_g = [need("grad_x")?, need("grad_y")?, need("grad_z")?];
        let c_p = col("p_trace");
        let c_tg = match (col("true_grad_x"), col("true_grad_y"), col("true_grad_z")) {
            (Some(x), Some(y), Some(z)) => Some([x, y, z]),
            _ => None,
        };
        let ticks = mission.ticks().max(1);
        let bucket = ticks.div_ceil((MAX_POINTS / 2) as u64).max(1);
        let mut s = RunSeries {
            has_truth: c_tg.is_some(),
            ..Default::default()
        };
        for d in [
            &mut s.v_over_vu,
            &mut s.sdot,
            &mut s.scale,
            &mut s.vehicles,
            &mut s.grad_error,
            &mut s.grad_true,
            &mut s.p_trace,
        ] {
            d.bucket = bucket;
        }
        let distance_every = ticks.div_ceil(MAX_POINTS as u64).max(1);
        let field = mission.field();
        let goal = mission.mission.goal;
        let v_u = mission.body.v_u;
        let mut cols: Vec<f64> = Vec::with_capacity(names.len());
        for (i, line) in lines.enumerate() {
            let line = line.with_context(|| format!("reading {}", path.display()))?;
            cols.clear();
            for c in line.split(',') {
                cols.push(c.parse::<f64>().unwrap_or(f64::NAN));
            }
            if cols.len() != names.len() {
                // A partial last line of an interrupted run.
                continue;
            }
            let t = cols[c_t];
            let v3 = |c: [usize; 3]| Vec3::new(cols[c[0]], cols[c[1]], cols[c[2]]);
            let r = v3(c_r);
            let grad = v3(c_g);
            s.v_over_vu.push(t, cols[c_v] / v_u);
            s.max_v_over_vu = s.max_v_over_vu.max(cols[c_v] / v_u);
            s.sdot.push(t, cols[c_sdot]);
            s.scale.push(t, cols[c_scale]);
            s.vehicles.push(t, cols[c_n]);
            if let Some(c) = c_p {
                s.p_trace.push(t, cols[c]);
            }
            if let Some(c) = c_tg {
                let truth = v3(c);
                s.grad_error.push(t, (grad - truth).norm());
                s.grad_true.push(t, truth.norm());
            }
            if (i as u64).is_multiple_of(distance_every) {
                if let Some(o) = field.optimum(t, goal) {
                    s.distance.push((t, (r - o).norm()));
                }
            }
            if s.rows == 0 {
                s.first_t = t;
            }
            s.rows += 1;
            s.last_t = t;
        }
        Ok(s)
    }
}

/// Event markers: the kinds [`style::event_style`] draws (per-message kinds like
/// `link_drop` are too many to draw, periodic ones like `surfaced` are in `contact.svg`),
/// with the short labels of [`style::event_label`] ("kill 2", "lost 2", "redesign").
pub(crate) fn event_markers(events: &[Event], unit: TimeUnit) -> Vec<Marker> {
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

/// Splits `"T (°C)"` into the field's unit `"°C"`; `""` when there is none.
fn field_unit(label: &str) -> String {
    match (label.rfind('('), label.rfind(')')) {
        (Some(a), Some(b)) if b > a + 1 => label[a + 1..b].trim().to_string(),
        _ => String::new(),
    }
}

fn with_unit(what: &str, unit: &str) -> String {
    if unit.is_empty() {
        what.to_string()
    } else {
        format!("{what} ({unit})")
    }
}

fn run_figures(
    mission: &Mission,
    s: &RunSeries,
    events: &[Event],
    formation_data: Option<&Formation>,
    truth: Option<&Truth>,
) -> (Figure, Figure) {
    let m = &mission.mission;
    let unit = TimeUnit::for_span(s.last_t);
    let tscale = unit.seconds;
    let rescale = |pts: &[(f64, f64)]| -> Vec<(f64, f64)> {
        pts.iter().map(|&(t, y)| (t / tscale, y)).collect()
    };
    let markers = event_markers(events, unit);
    let len = m.length_unit.as_str();
    let funit = field_unit(&m.field_label);
    let grad_unit = match (funit.is_empty(), len.is_empty()) {
        (true, true) => String::new(),
        (false, false) => format!("{funit}/{len}"),
        (false, true) => format!("{funit}/L"),
        (true, false) => format!("F/{len}"),
    };
    let speed_unit = if len.is_empty() {
        String::new()
    } else {
        format!("{len}/s")
    };
    // Tick k covers [k dt, (k + 1) dt): the axis ends where the last tick does.
    let t_range = Some((s.first_t / tscale, (s.last_t + m.dt) / tscale));
    let time_axis = |label: bool| Axis {
        label: if label {
            unit.axis_label("mission time t")
        } else {
            String::new()
        },
        range: t_range,
        time: Some(unit),
        ..Axis::default()
    };
    let converged = events
        .iter()
        .find(|e| e.kind == "converged")
        .map(|e| format!("converged at t = {}", unit.fmt(e.t)))
        .unwrap_or_else(|| "not converged".into());
    let max_v = match truth {
        Some(tr) => format!(
            "max V/V_{{U}} true {}, seen {}",
            style::fmt_significant(tr.max_v_true, 3, 3),
            style::fmt_significant(tr.max_v_seen, 3, 3)
        ),
        None => format!("max V/V_{{U}} = {:.3}", s.max_v_over_vu),
    };
    let subtitle = format!(
        "{} vehicles, {} ticks of {} over {} · {max_v} · {converged}",
        mission.vehicles.count,
        s.rows,
        style::fmt_duration(m.dt),
        unit.fmt(s.last_t + m.dt - s.first_t),
    );
    let title = |what: &str| format!("{} (seed {}): {what}", m.name, m.seed);

    // --- formation and speed
    let mut v_panel = Panel::new(
        "Lyapunov function of the formation (Theorem 4.1 keeps V ≤ V_{U})",
        time_axis(false),
        Axis {
            label: "V / V_{U}".into(),
            from_zero: true,
            ..Axis::default()
        },
    );
    let max_v_shown = match truth {
        Some(tr) => {
            v_panel.title =
                "Lyapunov function V of (II.2), true and as the coordinator sees it (Theorem 4.1 keeps V ≤ V_{U})"
                    .into();
            v_panel.series.push(Series::line(
                "true (vehicles' true states)",
                rescale(&tr.v_true.points()),
                PALETTE[0],
            ));
            v_panel.series.push(Series {
                dashed: true,
                ..Series::line(
                    "seen (coordinator's view)",
                    rescale(&tr.v_seen.points()),
                    PALETTE[1],
                )
            });
            tr.max_v_true.max(tr.max_v_seen)
        }
        None => {
            v_panel.series.push(Series::line(
                "V / V_{U}",
                rescale(&s.v_over_vu.points()),
                PALETTE[0],
            ));
            s.max_v_over_vu
        }
    };
    // Far above the bound (a broken formation): a log axis keeps the bound readable.
    if max_v_shown > 20.0 {
        v_panel.y.log = true;
        v_panel.y.from_zero = false;
    }
    if max_v_shown >= 0.25 {
        v_panel.hlines.push(RefLine {
            y: 1.0,
            label: "bound V = V_{U}".into(),
            colour: "#d62728",
        });
    } else {
        v_panel.notes.push(format!(
            "the bound V = V_{{U}} is off scale (max V/V_{{U}} = {:.3})",
            max_v_shown
        ));
    }
    let mut sdot_panel = Panel::new(
        "Speed of the virtual body along its path, ṡ (IV.4)",
        time_axis(false),
        Axis {
            label: with_unit("body speed ṡ", &speed_unit),
            from_zero: true,
            ..Axis::default()
        },
    );
    sdot_panel
        .series
        .push(Series::line("ṡ", rescale(&s.sdot.points()), PALETTE[1]));
    sdot_panel.hlines.push(RefLine {
        y: mission.body.v0,
        label: format!("nominal v_{{0}} = {}", mission.body.v0),
        colour: "#555555",
    });
    let mut k_panel = Panel::new(
        "Formation scale k (resolution adaptation dk/ds)",
        time_axis(false),
        Axis {
            label: "k".into(),
            ..Axis::default()
        },
    );
    k_panel.series.push(Series::line(
        "scale k",
        rescale(&s.scale.points()),
        PALETTE[2],
    ));
    let mut n_panel = Panel::new(
        "Vehicles in the formation",
        time_axis(true),
        Axis {
            label: "vehicles".into(),
            from_zero: true,
            integer: true,
            ..Axis::default()
        },
    );
    n_panel.series.push(Series {
        step: true,
        ..Series::line(
            if truth.is_some() {
                "members (coordinator's design)"
            } else {
                "vehicles in the formation"
            },
            rescale(&s.vehicles.points()),
            PALETTE[4],
        )
    });
    if let Some(tr) = truth {
        n_panel.title = "Vehicles: members of the design, alive, truly in formation".into();
        n_panel.series.push(Series {
            step: true,
            dashed: true,
            ..Series::line("alive", rescale(&tr.n_alive.points()), "#555555")
        });
        n_panel.series.push(Series {
            step: true,
            ..Series::line(
                "in formation (true slot error)",
                rescale(&tr.n_in_formation.points()),
                PALETTE[2],
            )
        });
    }
    let mut panels = vec![v_panel, sdot_panel, k_panel];
    if let Some(f) = formation_data {
        panels.push(truth_plots::slot_error_panel(f, truth, time_axis(false)));
    }
    if let Some(tr) = truth {
        panels.push(truth_plots::nearest_pair_panel(tr, time_axis(false)));
    }
    panels.push(n_panel);
    let mut formation = Figure {
        title: title("formation and speed"),
        subtitle: subtitle.clone(),
        panels,
    };

    // --- estimate
    let mut g_panel = Panel::new(
        "Gradient estimate error at the body centre (Lemma 5.4 filter)",
        time_axis(false),
        Axis {
            label: with_unit("gradient", &grad_unit),
            log: true,
            ..Axis::default()
        },
    );
    if s.has_truth {
        g_panel.series.push(Series::line(
            "‖∇T_{est} − ∇T‖",
            rescale(&s.grad_error.points()),
            PALETTE[0],
        ));
        g_panel.series.push(Series {
            dashed: true,
            ..Series::line("true ‖∇T‖", rescale(&s.grad_true.points()), "#555555")
        });
    } else {
        g_panel
            .notes
            .push("body.csv has no true gradient columns".into());
    }
    let mut p_panel = Panel::new(
        "Trace of the Kalman covariance P",
        time_axis(false),
        Axis {
            label: "tr P".into(),
            log: true,
            ..Axis::default()
        },
    );
    p_panel.series.push(Series::line(
        "tr P",
        rescale(&s.p_trace.points()),
        PALETTE[3],
    ));
    let mut d_panel = Panel::new(
        "Distance of the virtual body centre to the optimum",
        time_axis(true),
        Axis {
            label: with_unit("distance", len),
            log: true,
            ..Axis::default()
        },
    );
    if s.distance.is_empty() {
        d_panel
            .notes
            .push("the field has no optimum to measure against".into());
    }
    d_panel
        .series
        .push(Series::line("‖r − r*‖", rescale(&s.distance), PALETTE[2]));
    d_panel.hlines.push(RefLine {
        y: m.tolerance,
        label: format!("tolerance {}", m.tolerance),
        colour: "#17becf",
    });
    let mut estimate = Figure {
        title: title("gradient estimate"),
        subtitle,
        panels: [
            Some(g_panel),
            Some(p_panel),
            drops_panel(events, s, m.dt, unit),
            Some(d_panel),
        ]
        .into_iter()
        .flatten()
        .collect(),
    };
    for fig in [&mut formation, &mut estimate] {
        for p in &mut fig.panels {
            p.markers = markers.clone();
        }
    }
    (formation, estimate)
}

/// Messages the link model dropped (`link_drop` events), as a rate per bucket of time;
/// `None` when there were none.
fn drops_panel(events: &[Event], s: &RunSeries, dt: f64, unit: TimeUnit) -> Option<Panel> {
    let tscale = unit.seconds;
    let drops: Vec<f64> = events
        .iter()
        .filter(|e| e.kind == "link_drop")
        .map(|e| e.t)
        .collect();
    if drops.is_empty() {
        return None;
    }
    let span = (s.last_t - s.first_t).max(f64::MIN_POSITIVE);
    let buckets = 60usize;
    let width = span / buckets as f64;
    let mut counts = vec![0u64; buckets];
    for t in &drops {
        let b = (((t - s.first_t) / width) as usize).min(buckets - 1);
        counts[b] += 1;
    }
    let points: Vec<(f64, f64)> = counts
        .iter()
        .enumerate()
        .map(|(i, c)| ((s.first_t + i as f64 * width) / tscale, *c as f64 / width))
        .chain(std::iter::once((
            s.last_t / tscale,
            counts[buckets - 1] as f64 / width,
        )))
        .collect();
    let mut p = Panel::new(
        "Messages dropped by the link model (link_drop events)",
        Axis {
            range: Some((s.first_t / tscale, (s.last_t + dt) / tscale)),
            time: Some(unit),
            ..Axis::default()
        },
        Axis {
            label: "drops per s".into(),
            from_zero: true,
            ..Axis::default()
        },
    );
    p.series.push(Series {
        step: true,
        ..Series::line(
            &format!("{} drops, rate per {}", drops.len(), unit.fmt(width)),
            points,
            PALETTE[5],
        )
    });
    Some(p)
}

// ---------------------------------------------------------------------------------------------
// Decimation.

/// Streaming decimation: keeps the first, minimum, maximum and last point of each bucket of
/// `bucket` consecutive samples (in time order), so peaks survive.
#[derive(Clone, Debug, Default)]
pub struct Decimator {
    /// Samples per bucket (0 or 1: keep everything).
    pub bucket: u64,
    out: Vec<(f64, f64)>,
    cur: Vec<(f64, f64)>,
}

impl Decimator {
    /// A decimator keeping about `points` points of `total` samples.
    pub fn new(total: u64, points: usize) -> Self {
        Self {
            bucket: total.div_ceil((points / 4).max(1) as u64).max(1),
            ..Self::default()
        }
    }
    /// A decimator with buckets of `bucket` samples.
    pub fn with_bucket(bucket: u64) -> Self {
        Self {
            bucket,
            ..Self::default()
        }
    }
    /// Adds a sample (non-finite samples are kept: they break the line).
    pub fn push(&mut self, x: f64, y: f64) {
        self.cur.push((x, y));
        if self.cur.len() as u64 >= self.bucket.max(1) {
            self.flush();
        }
    }
    fn flush(&mut self) {
        if self.cur.is_empty() {
            return;
        }
        if self.cur.len() <= 4 {
            self.out.append(&mut self.cur);
            return;
        }
        let first = 0;
        let last = self.cur.len() - 1;
        // Extremes among the finite values; the first gap (non-finite value) is kept too,
        // so a line broken inside the bucket stays broken.
        let finite = |i: &usize| self.cur[*i].1.is_finite();
        let mut lo = (0..self.cur.len()).find(finite).unwrap_or(first);
        let mut hi = lo;
        for (i, p) in self.cur.iter().enumerate() {
            if p.1 < self.cur[lo].1 {
                lo = i;
            }
            if p.1 > self.cur[hi].1 {
                hi = i;
            }
        }
        let gap = (0..self.cur.len()).find(|i| !finite(i)).unwrap_or(first);
        let mut keep: Vec<usize> = vec![first, lo, hi, gap, last];
        keep.sort_unstable();
        keep.dedup();
        for i in keep {
            self.out.push(self.cur[i]);
        }
        self.cur.clear();
    }
    /// The points kept so far (and the pending bucket).
    pub fn points(&self) -> Vec<(f64, f64)> {
        let mut out = self.out.clone();
        out.extend_from_slice(&self.cur);
        out
    }
}

// ---------------------------------------------------------------------------------------------
// The SVG chart writer.

pub(crate) const WIDTH: f64 = 1200.0;
pub(crate) const MARGIN_LEFT: f64 = 100.0;
const LEGEND_W: f64 = 280.0;
pub(crate) const PLOT_W: f64 = WIDTH - MARGIN_LEFT - LEGEND_W - 25.0;
const PANEL_TITLE_H: f64 = 30.0;
const PLOT_H: f64 = 200.0;
pub(crate) const FONT: &str = "DejaVu Sans, Verdana, Arial, sans-serif";

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
    /// Stroke colour.
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
    /// Colour.
    pub colour: &'static str,
}

/// A vertical event line.
#[derive(Clone, Debug)]
pub struct Marker {
    /// Where, x units.
    pub x: f64,
    /// Label next to the line (first panel only).
    pub label: String,
    /// Colour.
    pub colour: &'static str,
    /// Legend entry of this kind of marker.
    pub legend: String,
}

/// Writes `fig` to `path` as SVG.
pub fn write_svg(fig: &Figure, path: &Path) -> Result<()> {
    std::fs::write(path, render_svg(fig)).with_context(|| format!("writing {}", path.display()))
}

/// Escapes text for SVG.
pub(crate) fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// Text with `_{sub}` / `^{sup}` turned into shifted, smaller tspans.
pub(crate) fn rich(s: &str, size: f64) -> String {
    let mut out = String::new();
    let mut rest = s;
    let shift = (size * 0.3).round();
    let small = (size * 0.72).round();
    while let Some(i) = rest.find(['_', '^']) {
        let (before, after) = rest.split_at(i);
        if !after[1..].starts_with('{') {
            out.push_str(&esc(&rest[..i + 1]));
            rest = &rest[i + 1..];
            continue;
        }
        let Some(close) = after.find('}') else { break };
        out.push_str(&esc(before));
        let inner = &after[2..close];
        let dy = if after.starts_with('_') {
            shift
        } else {
            -shift - 1.0
        };
        let _ = write!(
            out,
            r#"<tspan dy="{dy}" font-size="{small}">{}</tspan><tspan dy="{}">{}</tspan>"#,
            esc(inner),
            -dy,
            "\u{200B}"
        );
        rest = &after[close + 1..];
    }
    out.push_str(&esc(rest));
    out
}

/// Approximate rendered width of `s` at font size `size`, px.
pub(crate) fn text_width(s: &str, size: f64) -> f64 {
    let plain: String = s.replace("_{", "").replace("^{", "").replace('}', "");
    plain.chars().count() as f64 * size * 0.58
}

/// "Nice" linear ticks covering [lo, hi], about `target` of them (on a time axis, at steps
/// of the clock).
pub(crate) fn linear_ticks(
    lo: f64,
    hi: f64,
    target: usize,
    integer: bool,
    time: Option<TimeUnit>,
) -> (Vec<f64>, f64) {
    let span = (hi - lo).max(f64::MIN_POSITIVE);
    let mut step = match time {
        Some(unit) => unit.tick_step(span, target),
        None => style::nice_step(span / target.max(1) as f64),
    };
    if integer {
        step = step.max(1.0).round();
    }
    let mut ticks = Vec::new();
    let mut v = (lo / step).ceil() * step;
    while v <= hi + step * 1e-9 {
        ticks.push(if v.abs() < step * 1e-9 { 0.0 } else { v });
        v += step;
    }
    (ticks, step)
}

/// Log ticks: (value, label shown) for [lo, hi] (both > 0).
fn log_ticks(lo: f64, hi: f64) -> Vec<(f64, bool)> {
    let (a, b) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
    let decades = b - a;
    let every = (decades / 7 + 1).max(1);
    let mut out = Vec::new();
    for e in a..=b {
        for m in [1.0, 2.0, 5.0] {
            let v = m * 10f64.powi(e);
            if v < lo * (1.0 - 1e-9) || v > hi * (1.0 + 1e-9) {
                continue;
            }
            if m == 1.0 {
                out.push((v, (e - a) % every == 0));
            } else if decades <= 2 {
                out.push((v, true));
            } else if decades <= 5 {
                out.push((v, false));
            }
        }
    }
    out
}

fn fmt_log(v: f64) -> String {
    let e = v.log10().round() as i32;
    let m = v / 10f64.powi(e.min(v.log10().floor() as i32));
    if (-3..=4).contains(&e) || (m - 1.0).abs() > 1e-6 {
        let d = if v >= 1.0 {
            0
        } else {
            (-v.log10()).ceil() as usize
        };
        return format!("{v:.d$}");
    }
    format!("10^{{{e}}}")
}

/// Maps data to pixels on one axis.
#[derive(Clone, Copy, Debug)]
struct Scale {
    lo: f64,
    hi: f64,
    log: bool,
    p0: f64,
    p1: f64,
}

impl Scale {
    fn px(&self, v: f64) -> Option<f64> {
        if !v.is_finite() || (self.log && v <= 0.0) {
            return None;
        }
        let f = if self.log {
            (v.log10() - self.lo.log10()) / (self.hi.log10() - self.lo.log10())
        } else {
            (v - self.lo) / (self.hi - self.lo)
        };
        Some(self.p0 + f * (self.p1 - self.p0))
    }
}

/// The data range of an axis.
fn axis_range(axis: &Axis, values: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    if let Some(r) = axis.range {
        return Some(r);
    }
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for v in values {
        if v.is_finite() && (!axis.log || v > 0.0) {
            lo = lo.min(v);
            hi = hi.max(v);
        }
    }
    if lo > hi {
        return None;
    }
    if axis.log {
        if hi / lo < 1.5 {
            return Some((lo / 1.5, hi * 1.5));
        }
        let pad = (hi / lo).powf(0.04);
        return Some((lo / pad, hi * pad));
    }
    if axis.from_zero && lo >= 0.0 {
        lo = 0.0;
    }
    if hi - lo < 1e-12 * hi.abs().max(1.0) {
        let d = if hi == 0.0 { 1.0 } else { hi.abs() * 0.1 };
        return Some((lo - d, hi + d));
    }
    let pad = 0.05 * (hi - lo);
    let lo = if axis.from_zero && lo == 0.0 {
        0.0
    } else {
        lo - pad
    };
    let mut hi = hi + pad;
    if axis.integer {
        hi = hi.ceil();
    }
    Some((lo, hi))
}

/// Renders `fig` to an SVG document.
pub fn render_svg(fig: &Figure) -> String {
    let head_h = if fig.subtitle.is_empty() { 48.0 } else { 70.0 };
    let panel_h = panel_height;
    let height = head_h + fig.panels.iter().map(panel_h).sum::<f64>() + 10.0;
    let mut svg = String::new();
    let _ = writeln!(
        svg,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{WIDTH}" height="{height}" viewBox="0 0 {WIDTH} {height}" font-family="{FONT}">"#
    );
    let _ = writeln!(
        svg,
        r#"<rect x="0" y="0" width="{WIDTH}" height="{height}" fill="white"/>"#
    );
    let _ = writeln!(
        svg,
        r#"<text x="{}" y="32" font-size="21" font-weight="bold" text-anchor="middle">{}</text>"#,
        WIDTH / 2.0,
        rich(&fig.title, 21.0)
    );
    if !fig.subtitle.is_empty() {
        let _ = writeln!(
            svg,
            r##"<text x="{}" y="56" font-size="14" fill="#444444" text-anchor="middle">{}</text>"##,
            WIDTH / 2.0,
            rich(&fig.subtitle, 14.0)
        );
    }
    let mut top = head_h;
    for (i, p) in fig.panels.iter().enumerate() {
        render_panel(&mut svg, p, i, top, i == 0);
        top += panel_h(p);
    }
    svg.push_str("</svg>\n");
    svg
}

/// Height of a panel in the figure, px.
pub(crate) fn panel_height(p: &Panel) -> f64 {
    PANEL_TITLE_H + PLOT_H + 28.0 + if p.x.label.is_empty() { 0.0 } else { 24.0 } + 12.0
}

/// Draws panel `p` (the `index`-th of its figure) with its top at `top` px; event labels
/// only when `label_markers`.
pub(crate) fn render_panel(
    svg: &mut String,
    p: &Panel,
    index: usize,
    top: f64,
    label_markers: bool,
) {
    let x0 = MARGIN_LEFT;
    let x1 = MARGIN_LEFT + PLOT_W;
    let y0 = top + PANEL_TITLE_H;
    let y1 = y0 + PLOT_H;
    let _ = writeln!(
        svg,
        r#"<text x="{x0}" y="{}" font-size="15" font-weight="bold">{}</text>"#,
        top + 20.0,
        rich(&p.title, 15.0)
    );
    let xs = p.series.iter().flat_map(|s| s.points.iter().map(|q| q.0));
    let ys = p
        .series
        .iter()
        .flat_map(|s| s.points.iter().map(|q| q.1))
        .chain(p.hlines.iter().map(|h| h.y));
    let (Some(xr), Some(yr)) = (axis_range(&p.x, xs), axis_range(&p.y, ys)) else {
        let _ = writeln!(
            svg,
            r##"<rect x="{x0}" y="{y0}" width="{PLOT_W}" height="{PLOT_H}" fill="#fafafa" stroke="black"/><text x="{}" y="{}" font-size="14" fill="#777777" text-anchor="middle">no data</text>"##,
            (x0 + x1) / 2.0,
            (y0 + y1) / 2.0
        );
        return;
    };
    let xs = Scale {
        lo: xr.0,
        hi: xr.1,
        log: p.x.log,
        p0: x0,
        p1: x1,
    };
    let ys = Scale {
        lo: yr.0,
        hi: yr.1,
        log: p.y.log,
        p0: y1,
        p1: y0,
    };
    let clip = format!("clip{index}_{}", top as i64);
    let _ = writeln!(
        svg,
        r#"<defs><clipPath id="{clip}"><rect x="{x0}" y="{y0}" width="{PLOT_W}" height="{PLOT_H}"/></clipPath></defs>"#
    );
    // Grid and tick labels.
    let grid = |svg: &mut String, horizontal: bool, v: f64, label: Option<String>, major: bool| {
        let colour = if major { "#dddddd" } else { "#eeeeee" };
        if horizontal {
            let Some(y) = ys.px(v) else { return };
            let _ = writeln!(
                svg,
                r#"<line x1="{x0}" y1="{y:.1}" x2="{x1}" y2="{y:.1}" stroke="{colour}"/>"#
            );
            if let Some(l) = label {
                let _ = writeln!(
                    svg,
                    r#"<text x="{}" y="{:.1}" font-size="13" text-anchor="end">{}</text>"#,
                    x0 - 7.0,
                    y + 4.5,
                    rich(&l, 13.0)
                );
            }
        } else {
            let Some(x) = xs.px(v) else { return };
            let _ = writeln!(
                svg,
                r#"<line x1="{x:.1}" y1="{y0}" x2="{x:.1}" y2="{y1}" stroke="{colour}"/>"#
            );
            if let Some(l) = label {
                let _ = writeln!(
                    svg,
                    r#"<text x="{x:.1}" y="{}" font-size="13" text-anchor="middle">{}</text>"#,
                    y1 + 18.0,
                    rich(&l, 13.0)
                );
            }
        }
    };
    for (horizontal, axis, scale) in [(false, &p.x, &xs), (true, &p.y, &ys)] {
        if axis.log && scale.hi / scale.lo < 10.0 {
            // Less than a decade: nice linear values, placed on the log scale.
            let (ticks, step) = linear_ticks(scale.lo, scale.hi, 5, axis.integer, None);
            for v in ticks.into_iter().filter(|v| *v > 0.0) {
                grid(svg, horizontal, v, Some(style::fmt_tick(v, step)), true);
            }
        } else if axis.log {
            for (v, labelled) in log_ticks(scale.lo, scale.hi) {
                grid(svg, horizontal, v, labelled.then(|| fmt_log(v)), labelled);
            }
        } else {
            let target = if horizontal { 5 } else { 10 };
            let (ticks, step) = linear_ticks(scale.lo, scale.hi, target, axis.integer, axis.time);
            for v in ticks {
                grid(svg, horizontal, v, Some(style::fmt_tick(v, step)), true);
            }
        }
    }
    // Event markers; labels of events closer than 15 px are joined into one.
    let mut labels: Vec<(f64, &'static str, Vec<&str>)> = Vec::new();
    for m in &p.markers {
        let Some(x) = xs.px(m.x) else { continue };
        if x < x0 - 0.5 || x > x1 + 0.5 {
            continue;
        }
        let _ = writeln!(
            svg,
            r#"<line x1="{x:.1}" y1="{y0}" x2="{x:.1}" y2="{y1}" stroke="{}" stroke-width="1.5" stroke-dasharray="5 3"/>"#,
            m.colour
        );
        if !label_markers || m.label.is_empty() {
            continue;
        }
        match labels.last_mut() {
            Some((lx, _, texts)) if x - *lx < 15.0 => {
                if !texts.contains(&m.label.as_str()) {
                    texts.push(&m.label);
                }
            }
            _ => labels.push((x, m.colour, vec![&m.label])),
        }
    }
    for (x, colour, texts) in labels {
        let mut text = texts.join(", ");
        // Keep the label inside the plot's height.
        let room = ((PLOT_H - 8.0) / (11.0 * 0.58)) as usize;
        if text.chars().count() > room {
            text = text
                .chars()
                .take(room.saturating_sub(1))
                .collect::<String>()
                + "…";
        }
        let w = text_width(&text, 11.0) + 6.0;
        let _ = writeln!(
            svg,
            r#"<g transform="translate({:.1},{:.1}) rotate(-90)"><rect x="{:.1}" y="-10" width="{w:.1}" height="13" fill="white" fill-opacity="0.85"/><text x="0" y="0" font-size="11" fill="{colour}" text-anchor="end">{}</text></g>"#,
            x + 3.0,
            y0 + 4.0,
            -w + 3.0,
            esc(&text)
        );
    }
    // Reference lines.
    for h in &p.hlines {
        if let Some(y) = ys.px(h.y) {
            if y >= y0 - 0.5 && y <= y1 + 0.5 {
                let _ = writeln!(
                    svg,
                    r#"<line x1="{x0}" y1="{y:.1}" x2="{x1}" y2="{y:.1}" stroke="{}" stroke-width="1.5" stroke-dasharray="8 4"/>"#,
                    h.colour
                );
            }
        }
    }
    // Data.
    for s in &p.series {
        let dash = if s.dashed {
            r#" stroke-dasharray="7 4""#
        } else {
            ""
        };
        for run in pixel_runs(s, &xs, &ys) {
            if run.len() == 1 {
                let _ = writeln!(
                    svg,
                    r#"<circle cx="{:.1}" cy="{:.1}" r="2.5" fill="{}" clip-path="url(#{clip})"/>"#,
                    run[0].0, run[0].1, s.colour
                );
                continue;
            }
            let mut pts = String::with_capacity(run.len() * 12);
            for (x, y) in run {
                let _ = write!(pts, "{x:.1},{y:.1} ");
            }
            let _ = writeln!(
                svg,
                r#"<polyline points="{}" fill="none" stroke="{}" stroke-width="1.8" stroke-linejoin="round"{dash} clip-path="url(#{clip})"/>"#,
                pts.trim_end(),
                s.colour
            );
        }
    }
    // Frame and axis labels.
    let _ = writeln!(
        svg,
        r#"<rect x="{x0}" y="{y0}" width="{PLOT_W}" height="{PLOT_H}" fill="none" stroke="black"/>"#
    );
    if !p.y.label.is_empty() {
        let _ = writeln!(
            svg,
            r#"<text transform="translate({},{:.1}) rotate(-90)" font-size="14" text-anchor="middle">{}</text>"#,
            x0 - 68.0,
            (y0 + y1) / 2.0,
            rich(&p.y.label, 14.0)
        );
    }
    if !p.x.label.is_empty() {
        let _ = writeln!(
            svg,
            r#"<text x="{:.1}" y="{}" font-size="14" text-anchor="middle">{}</text>"#,
            (x0 + x1) / 2.0,
            y1 + 42.0,
            rich(&p.x.label, 14.0)
        );
    }
    // Legend.
    let lx = x1 + 22.0;
    let mut ly = y0 + 12.0;
    let max_entries = ((PLOT_H - 10.0) / 20.0) as usize;
    let mut entries: Vec<String> = Vec::new();
    for s in &p.series {
        let dash = if s.dashed {
            r#" stroke-dasharray="7 4""#
        } else {
            ""
        };
        entries.push(format!(
            r#"<line x1="0" y1="0" x2="28" y2="0" stroke="{}" stroke-width="2.5"{dash}/>{}"#,
            s.colour,
            legend_text(&s.label)
        ));
    }
    for h in &p.hlines {
        entries.push(format!(
            r#"<line x1="0" y1="0" x2="28" y2="0" stroke="{}" stroke-width="1.5" stroke-dasharray="8 4"/>{}"#,
            h.colour,
            legend_text(&h.label)
        ));
    }
    let mut kinds = BTreeSet::new();
    for m in p.markers.iter().filter(|_| label_markers) {
        if kinds.insert((m.legend.clone(), m.colour)) {
            entries.push(format!(
                r#"<line x1="14" y1="-8" x2="14" y2="8" stroke="{}" stroke-width="1.5" stroke-dasharray="5 3"/>{}"#,
                m.colour,
                legend_text(&m.legend)
            ));
        }
    }
    let total = entries.len();
    for (i, e) in entries.into_iter().enumerate() {
        if i + 1 == max_entries && total > max_entries {
            let _ = writeln!(
                svg,
                r##"<text x="{lx}" y="{:.1}" font-size="13" fill="#555555">… and {} more</text>"##,
                ly + 4.5,
                total - i
            );
            ly += 20.0;
            break;
        }
        let _ = writeln!(svg, r#"<g transform="translate({lx},{ly:.1})">{e}</g>"#);
        ly += 20.0;
    }
    for line in p.notes.iter().flat_map(|n| wrap(n, 40)) {
        let _ = writeln!(
            svg,
            r##"<text x="{lx}" y="{:.1}" font-size="12" fill="#555555" font-style="italic">{}</text>"##,
            ly + 4.0,
            rich(&line, 12.0)
        );
        ly += 16.0;
    }
}

/// Splits `text` into lines of at most `width` characters at spaces.
fn wrap(text: &str, width: usize) -> Vec<String> {
    let mut lines = Vec::new();
    let mut cur = String::new();
    for word in text.split(' ') {
        if !cur.is_empty() && cur.chars().count() + 1 + word.chars().count() > width {
            lines.push(std::mem::take(&mut cur));
        }
        if !cur.is_empty() {
            cur.push(' ');
        }
        cur.push_str(word);
    }
    if !cur.is_empty() {
        lines.push(cur);
    }
    lines
}

fn legend_text(label: &str) -> String {
    let label = if label.chars().count() > 34 {
        let mut s: String = label.chars().take(33).collect();
        s.push('…');
        s
    } else {
        label.to_string()
    };
    format!(
        r#"<text x="36" y="4.5" font-size="13">{}</text>"#,
        rich(&label, 13.0)
    )
}

/// The pixel polylines of a series: runs of drawable points (a non-finite value, or a
/// non-positive one on a log axis, ends a run).
fn pixel_runs(s: &Series, xs: &Scale, ys: &Scale) -> Vec<Vec<(f64, f64)>> {
    let mut runs: Vec<Vec<(f64, f64)>> = Vec::new();
    let mut cur: Vec<(f64, f64)> = Vec::new();
    let mut prev_y: Option<f64> = None;
    for &(x, y) in &s.points {
        match (xs.px(x), ys.px(y)) {
            (Some(px), Some(py)) => {
                if s.step {
                    if let Some(py0) = prev_y {
                        cur.push((px, py0));
                    }
                }
                // Skip points closer than 0.3 px to the previous one on both axes.
                if let Some(&(lx, ly)) = cur.last() {
                    if (px - lx).abs() < 0.3 && (py - ly).abs() < 0.3 {
                        continue;
                    }
                }
                cur.push((px, py));
                prev_y = Some(py);
            }
            _ => {
                if !cur.is_empty() {
                    runs.push(std::mem::take(&mut cur));
                }
                prev_y = None;
            }
        }
    }
    if !cur.is_empty() {
        runs.push(cur);
    }
    runs
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimator_keeps_peaks_and_ends() {
        let mut d = Decimator {
            bucket: 100,
            ..Decimator::default()
        };
        for i in 0..1000 {
            let y = if i == 537 {
                50.0
            } else {
                (i as f64 * 0.01).sin()
            };
            d.push(i as f64, y);
        }
        let pts = d.points();
        assert!(pts.len() <= 40, "{} points", pts.len());
        assert!(pts.contains(&(537.0, 50.0)));
        assert_eq!(pts.first().unwrap().0, 0.0);
        assert_eq!(pts.last().unwrap().0, 999.0);
        assert!(pts.windows(2).all(|w| w[0].0 < w[1].0));
    }

    #[test]
    fn ticks_are_nice() {
        let (t, step) = linear_ticks(0.0, 1.04, 5, false, None);
        assert_eq!(step, 0.25);
        assert_eq!(t, vec![0.0, 0.25, 0.5, 0.75, 1.0]);
        assert_eq!(style::fmt_tick(0.25, step), "0.25");
        let (t, _) = linear_ticks(0.0, 4.4, 5, true, None);
        assert_eq!(t, vec![0.0, 1.0, 2.0, 3.0, 4.0]);
        // A 36 h mission: a tick every 6 h.
        let (t, step) = linear_ticks(0.0, 36.0, 10, false, Some(TimeUnit::H));
        assert_eq!(step, 6.0);
        assert_eq!(t, vec![0.0, 6.0, 12.0, 18.0, 24.0, 30.0, 36.0]);
        let lt: Vec<f64> = log_ticks(0.003, 20.0)
            .into_iter()
            .filter(|(_, l)| *l)
            .map(|(v, _)| v)
            .collect();
        assert_eq!(lt, vec![0.01, 0.1, 1.0, 10.0]);
        assert_eq!(fmt_log(1e-6), "10^{-6}");
        assert_eq!(fmt_log(0.01), "0.01");
        assert_eq!(fmt_log(1000.0), "1000");
    }

    #[test]
    fn rich_text_shifts_and_escapes() {
        let s = rich("V_{U} < 1 & x^{2}", 10.0);
        assert!(
            s.contains(r#"<tspan dy="3" font-size="7">U</tspan>"#),
            "{s}"
        );
        assert!(s.contains("&lt; 1 &amp; x"), "{s}");
        assert_eq!(rich("a_b", 10.0), "a_b");
    }

    #[test]
    fn svg_is_deterministic_and_breaks_lines_on_log_axis() {
        let mut panel = Panel::new(
            "t",
            Axis::default(),
            Axis {
                log: true,
                ..Axis::default()
            },
        );
        panel.series.push(Series::line(
            "s",
            vec![(0.0, 1.0), (1.0, 10.0), (2.0, 0.0), (3.0, 5.0), (4.0, 2.0)],
            PALETTE[0],
        ));
        let fig = Figure {
            title: "x".into(),
            subtitle: String::new(),
            panels: vec![panel],
        };
        let a = render_svg(&fig);
        assert_eq!(a, render_svg(&fig));
        assert_eq!(a.matches("<polyline").count(), 2, "{a}");
    }

    /// A synthetic run directory: a long run (so decimation matters) with events.
    fn synthetic_run(root: &Path, ticks: u64) -> RunDir {
        let dir = RunDir::create(root).unwrap();
        let text = "[mission]\nname = \"synthetic\"\nduration = 100.0\ndt = 0.05\ngoal = \"min\"\n\n[field]\nkind = \"quadratic\"\ncenter = [20.0, 10.0]\nhessian = [[1.0, 0.0], [0.0, 1.0]]\n";
        let mut mission = Mission::from_toml_str(text, "synthetic").unwrap();
        mission.mission.duration = ticks as f64 * mission.mission.dt;
        std::fs::write(dir.mission(), mission.to_toml_string()).unwrap();
        let mut body = String::from(vbap_mission::rundir::BODY_HEADER);
        body.push('\n');
        for k in 0..ticks {
            let t = k as f64 * 0.05;
            let f = k as f64 / ticks as f64;
            let n = if (0.2..0.35).contains(&f) { 3 } else { 4 };
            let spike = if k == ticks / 2 { 5.0 } else { 0.0 };
            body.push_str(&format!(
                "{t},{k},{},{},{},{},0,{},-1,-0.5,0,{},{n},{},-1.1,-0.4,0\n",
                0.5 * t,
                0.5,
                20.0 * f,
                10.0 * f,
                1.0 + 0.1 * (t * 0.3).sin(),
                0.3 + 0.1 * (t * 2.0).sin() + spike,
                1.0 / (1.0 + t)
            ));
        }
        std::fs::write(dir.body(), body).unwrap();
        let t = |f: f64| f * ticks as f64 * 0.05;
        let events = [
            format!(
                r#"{{"t":{},"k":1,"kind":"fault","vehicle":2,"detail":{{"fault":"kill"}}}}"#,
                t(0.2)
            ),
            format!(r#"{{"t":{},"k":2,"kind":"lost","vehicle":2}}"#, t(0.201)),
            format!(
                r#"{{"t":{},"k":2,"kind":"reconfigured","detail":{{"vehicles":[0,1,3]}}}}"#,
                t(0.201)
            ),
            format!(r#"{{"t":{},"k":3,"kind":"rejoin","vehicle":2}}"#, t(0.35)),
            format!(r#"{{"t":{},"k":4,"kind":"link_drop","vehicle":1}}"#, t(0.6)),
            format!(r#"{{"t":{},"k":5,"kind":"converged"}}"#, t(0.8)),
        ];
        std::fs::write(dir.events(), events.join("\n") + "\n").unwrap();
        dir
    }

    #[test]
    fn run_plots_mark_events_and_stay_small() {
        let root = std::env::temp_dir().join(format!("vbap-plots-unit-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let dir = synthetic_run(&root, 200_000);
        write_run_plots(&dir).unwrap();
        let formation = std::fs::read_to_string(root.join(FORMATION_SVG)).unwrap();
        let estimate = std::fs::read_to_string(root.join(ESTIMATE_SVG)).unwrap();
        for svg in [&formation, &estimate] {
            assert!(
                svg.contains(">kill 2, lost 2, redesign<"),
                "coincident events share one label"
            );
            assert!(svg.contains(">rejoin 2<"));
            assert!(
                !svg.contains(">link_drop"),
                "per-message events are not drawn as markers"
            );
            assert!(svg.len() < 600_000, "decimated: {} bytes", svg.len());
        }
        // Link drops are counted in their own panel.
        assert!(estimate.contains("Messages dropped by the link model"));
        assert!(estimate.contains(">1 drops, rate per"));
        // The spike of V (5.3 V_U, one tick of 200 000) survives decimation: the V axis
        // is labelled up to 4.
        assert!(formation.contains("V / V<tspan"));
        let v_panel = formation.split("Speed of the virtual body").next().unwrap();
        assert!(v_panel.contains(r#"text-anchor="end">4</text>"#));
        assert!(
            formation.contains(">bound V = V<tspan"),
            "bound drawn when V is near it"
        );
        if std::env::var_os("VBAP_KEEP_TEST_PLOTS").is_some() {
            eprintln!("kept {}", root.display());
        } else {
            let _ = std::fs::remove_dir_all(&root);
        }
    }

    /// Writes `formation.csv` and `truth.csv` for `ticks` ticks of 0.05 s and 3 vehicles:
    /// each surfaces for a quarter of every 10 s (staggered), vehicle 2 is dead from 40 % to
    /// 60 % of the run then rejoining for a tick, vehicle 1's link is down from 10 % to 20 %.
    fn synthetic_truth(dir: &RunDir, ticks: u64) {
        let mut f =
            String::from("t,k,id,contact,info_age_s,slot_error,nearest_ratio,in_formation\n");
        let mut tr = String::from("t,k,V_true_over_VU,V_seen_over_VU,min_pair_ratio,max_slot_error,n_alive,n_in_formation,sdot_over_v0\n");
        let mut age = [None::<f64>; 3];
        for k in 0..ticks {
            let t = k as f64 * 0.05;
            let frac = k as f64 / ticks as f64;
            let mut alive = 0;
            for (id, a) in age.iter_mut().enumerate() {
                let surfaced = ((t / 10.0 + id as f64 / 3.0) % 1.0) < 0.25;
                let state = if id == 2 && (0.4..0.6).contains(&frac) {
                    "dead"
                } else if id == 2 && frac >= 0.6 && *a == Some(-1.0) {
                    "rejoining"
                } else if id == 1 && (0.1..0.2).contains(&frac) {
                    "link_down"
                } else if surfaced {
                    "surfaced"
                } else {
                    "submerged"
                };
                if state == "dead" {
                    *a = Some(-1.0);
                    f.push_str(&format!("{t},{k},{id},dead,,,,0\n"));
                    continue;
                }
                alive += 1;
                *a = match (*a, state) {
                    (_, "surfaced" | "rejoining") => Some(0.2),
                    (Some(x), _) if x >= 0.0 => Some(x + 0.05),
                    _ => None,
                };
                let age_s = a.map(|x| x.to_string()).unwrap_or_default();
                f.push_str(&format!("{t},{k},{id},{state},{age_s},0.1,0.9,1\n"));
            }
            tr.push_str(&format!(
                "{t},{k},{},{},0.9,0.1,{alive},{alive},1\n",
                2.0 * frac,
                frac
            ));
        }
        std::fs::write(dir.root.join(crate::truth_plots::FORMATION_CSV), f).unwrap();
        std::fs::write(dir.root.join(crate::truth_plots::TRUTH_CSV), tr).unwrap();
        let s = r#"{"formation": {"in_formation_ratio": 0.5, "near_collision_ratio": 0.1}}"#;
        std::fs::write(dir.summary(), s).unwrap();
    }

    #[test]
    fn run_plots_draw_the_truth_when_present_and_leave_it_out_when_absent() {
        let root = std::env::temp_dir().join(format!("vbap-plots-truth-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let dir = synthetic_run(&root, 4000);
        // An older run: no truth files, no contact.svg, no error.
        write_run_plots(&dir).unwrap();
        assert!(!root.join(crate::truth_plots::CONTACT_SVG).exists());
        let old = std::fs::read_to_string(root.join(FORMATION_SVG)).unwrap();
        assert!(!old.contains("slot error"));

        synthetic_truth(&dir, 4000);
        write_run_plots(&dir).unwrap();
        let contact = std::fs::read_to_string(root.join(crate::truth_plots::CONTACT_SVG)).unwrap();
        assert!(contact.starts_with("<svg") && contact.trim_end().ends_with("</svg>"));
        assert_eq!(contact.matches("<svg").count(), 1);
        assert_eq!(contact.matches("</svg>").count(), 1);
        for id in 0..3 {
            assert_eq!(
                contact.matches(&format!(">vehicle {id}</text>")).count(),
                1,
                "one row label for vehicle {id}"
            );
        }
        for state in [
            "surfaced (can talk)",
            "submerged (cannot talk)",
            "link down (fault)",
            "dead / lost",
            "rejoining",
        ] {
            assert!(contact.contains(state), "legend: {state}");
        }
        assert!(contact.contains("report delivered"));
        // 200 s: seconds; the rejoin, the kill and the redesign of the synthetic events.
        assert!(contact.contains("mission time t (s)"));
        assert!(
            contact.contains("kill 2 at 40 s"),
            "vehicle event on its row"
        );
        assert!(contact.contains(">redesign<"), "fleet event labelled");
        assert!(contact.contains("fleet never stalled"));
        assert!(contact.contains("surfacing period") || contact.contains("information age"));
        let formation = std::fs::read_to_string(root.join(FORMATION_SVG)).unwrap();
        for s in [
            "true (vehicles",
            "seen (coordinator",
            "slot error ÷ spacing",
            "in formation: ≤ 0.5",
            "Nearest pair",
            "near collision: &lt; 0.1",
            "in formation (true slot error)",
        ] {
            assert!(
                formation.contains(s),
                "timeseries_formation.svg lacks {s:?}"
            );
        }
        // Malformed truth is left out with a warning, never an error.
        std::fs::write(root.join(crate::truth_plots::FORMATION_CSV), "t,k\n0,0\n").unwrap();
        std::fs::write(root.join(crate::truth_plots::TRUTH_CSV), "t\n0\n").unwrap();
        write_run_plots(&dir).unwrap();
        assert!(!root.join(crate::truth_plots::CONTACT_SVG).exists());
        if std::env::var_os("VBAP_KEEP_TEST_PLOTS").is_some() {
            eprintln!("kept {}", root.display());
        } else {
            let _ = std::fs::remove_dir_all(&root);
        }
    }

    #[test]
    fn field_units() {
        assert_eq!(field_unit("T (°C)"), "°C");
        assert_eq!(field_unit("T"), "");
    }
}
