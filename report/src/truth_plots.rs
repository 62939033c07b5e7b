//! Pictures of what the vehicles truly did, from the truth files of a run directory:
//! `formation.csv` (per vehicle and tick: contact state, age of the coordinator's newest
//! information, distance from its slot, nearest neighbour, in formation or not), `truth.csv`
//! (per tick: V of (II.2) from the true states beside the coordinator's own, nearest pair,
//! counts) and the events of `events.jsonl`.
//!
//! - [`CONTACT_SVG`], the contact timeline: one row per vehicle over mission time, coloured by
//!   its contact state (in contact, surfaced, submerged, link down, rejoining, dead), with the
//!   deliveries (ticks at which the coordinator's information about the vehicle was renewed:
//!   its age dropped) as dark ticks along the bottom of the row, the vehicle's own events as
//!   symbols on its row, the fleet's events (redesigns, stalls, ...) as labelled dashed lines
//!   across all rows, two fleet rows on top (formation broken, fleet stalled, from the
//!   events), and below, the age of the coordinator's information per vehicle.
//! - panels of `timeseries_formation.svg`: each vehicle's distance from its slot ÷ design
//!   spacing against the in-formation threshold, and the nearest pair ÷ spacing.
//!
//! Older runs have no truth files: the readers return `None` and the pictures are left out.
//! A truth file that does not follow its schema is reported (a warning) and left out too: a
//! plot never fails a run.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;
use std::fs::File;
use std::io::{BufRead, BufReader};
use std::path::Path;

use crate::plot::style::{self, TimeUnit, CONTACT_STATES};
use anyhow::{bail, Context, Result};
use vbap_mission::config::Mission;
use vbap_mission::rundir::{Event, RunDir};

use crate::report_plots::{
    self, esc, linear_ticks, rich, text_width, Axis, Decimator, Panel, RefLine, Series, FONT,
    MARGIN_LEFT, MAX_POINTS, PLOT_W, WIDTH,
};

/// File name of the contact timeline.
pub const CONTACT_SVG: &str = "contact.svg";
/// File name of the per-vehicle truth (written by the recorder).
pub const FORMATION_CSV: &str = "formation.csv";
/// File name of the per-tick truth (written by the recorder).
pub const TRUTH_CSV: &str = "truth.csv";
/// Columns of `formation.csv` this module reads.
pub const FORMATION_COLUMNS: [&str; 8] = [
    "t",
    "k",
    "id",
    "contact",
    "info_age_s",
    "slot_error",
    "nearest_ratio",
    "in_formation",
];
/// Columns of `truth.csv` this module reads.
pub const TRUTH_COLUMNS: [&str; 9] = [
    "t",
    "k",
    "V_true_over_VU",
    "V_seen_over_VU",
    "min_pair_ratio",
    "max_slot_error",
    "n_alive",
    "n_in_formation",
    "sdot_over_v0",
];
/// Most vehicles drawn one line each in a panel; beyond, the worst only.
pub const MAX_VEHICLE_LINES: usize = 12;
/// An information age above this many ticks is a silence (out of contact).
pub const SILENCE_TICKS: u64 = 10;
/// Most silences (age sawteeth) of one vehicle drawn as its own line in the age panel;
/// beyond, the lines would cover each other: the oldest over the vehicles is drawn instead.
pub const MAX_SAWTEETH: u64 = 24;

const N_STATES: usize = CONTACT_STATES.len();

// ---------------------------------------------------------------------------------------------
// Reading.

/// A CSV file read by column name: the index of each wanted column in the header.
struct CsvColumns {
    index: Vec<usize>,
    width: usize,
}

impl CsvColumns {
    /// The positions of `wanted` in `header`; an error names the file and the first missing
    /// column.
    fn new(path: &Path, header: &str, wanted: &[&str]) -> Result<Self> {
        let names: Vec<&str> = header.trim_end().split(',').collect();
        let index = wanted
            .iter()
            .map(|w| {
                names
                    .iter()
                    .position(|n| n == w)
                    .with_context(|| format!("{}: no column {w:?} in the header", path.display()))
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(Self {
            index,
            width: names.len(),
        })
    }
}

/// A number field: empty = none; anything else must parse.
fn opt_num(path: &Path, line: usize, column: &str, s: &str) -> Result<Option<f64>> {
    if s.is_empty() {
        return Ok(None);
    }
    s.parse::<f64>().map(Some).with_context(|| {
        format!(
            "{} line {line}: column {column}: {s:?} is not a number",
            path.display()
        )
    })
}

fn num(path: &Path, line: usize, column: &str, s: &str) -> Result<f64> {
    opt_num(path, line, column, s)?
        .with_context(|| format!("{} line {line}: column {column} is empty", path.display()))
}

/// Streams the complete rows of a CSV file to `row` as the wanted fields in order (a partial
/// last line of an interrupted run, with fewer fields, is skipped); `row` gets the 1-based
/// line number too.
fn for_each_row(
    path: &Path,
    reader: impl BufRead,
    wanted: &[&str],
    mut row: impl FnMut(usize, &[&str]) -> Result<()>,
) -> Result<()> {
    let mut lines = reader.lines();
    let header = lines
        .next()
        .transpose()
        .with_context(|| format!("reading {}", path.display()))?
        .with_context(|| format!("{}: empty file, no header", path.display()))?;
    let cols = CsvColumns::new(path, &header, wanted)?;
    for (i, line) in lines.enumerate() {
        let line = line.with_context(|| format!("reading {}", path.display()))?;
        let fields: Vec<&str> = line.split(',').collect();
        if fields.len() != cols.width {
            continue;
        }
        let wanted_fields: Vec<&str> = cols.index.iter().map(|&c| fields[c]).collect();
        row(i + 2, &wanted_fields)?;
    }
    Ok(())
}

/// One vehicle's lane of the contact timeline and its series.
#[derive(Clone, Debug)]
pub struct Lane {
    /// Time (s) spent in each state of [`CONTACT_STATES`] within each pixel column.
    pub state_time: Vec<[f64; N_STATES]>,
    /// Columns holding at least one delivery.
    pub delivered: Vec<bool>,
    /// Deliveries counted (ticks at which the coordinator's information was renewed).
    pub deliveries: u64,
    /// Deliveries that ended a silence of more than [`SILENCE_TICKS`] ticks.
    pub silences: u64,
    /// Distance from its slot ÷ design spacing over time (s); NaN while dead.
    pub slot_error: Decimator,
    /// Age of the coordinator's newest information over time (s, s); NaN when none.
    pub info_age: Decimator,
    /// Largest information age (s) and when (s).
    pub max_age: Option<(f64, f64)>,
    /// Largest slot error while alive (÷ spacing).
    pub max_slot_error: Option<f64>,
    /// The states met.
    pub seen: [bool; N_STATES],
    /// (t, age) of the previous row with an age.
    prev_age: Option<(f64, f64)>,
}

impl Lane {
    fn new(cols: usize, bucket: u64) -> Self {
        Self {
            state_time: vec![[0.0; N_STATES]; cols],
            delivered: vec![false; cols],
            deliveries: 0,
            silences: 0,
            slot_error: Decimator::with_bucket(bucket),
            info_age: Decimator::with_bucket(bucket),
            max_age: None,
            max_slot_error: None,
            seen: [false; N_STATES],
            prev_age: None,
        }
    }
}

/// `formation.csv`, summarised for the pictures.
#[derive(Clone, Debug)]
pub struct Formation {
    /// Per vehicle id.
    pub lanes: BTreeMap<u32, Lane>,
    /// Mission time covered by the pixel columns, s.
    pub t_range: (f64, f64),
    /// Rows read.
    pub rows: u64,
    /// The largest age of the coordinator's information over the vehicles, per tick (s, s).
    pub worst_age: Decimator,
    /// Largest slot error of a vehicle counted in formation (÷ spacing).
    pub in_max: Option<f64>,
    /// Smallest slot error of a live vehicle counted out of formation (÷ spacing).
    pub out_min: Option<f64>,
    /// The in-formation threshold on the slot error (÷ spacing), from `summary.json`.
    pub threshold: Option<f64>,
    /// The near-collision threshold on a pair's distance (÷ spacing), from `summary.json`.
    pub near_collision: Option<f64>,
}

impl Formation {
    /// Reads `formation.csv` from `reader` (`path` names it in errors), with `cols` pixel
    /// columns over `t_range` (s), ticks of `dt` s, and series decimated into buckets of
    /// `bucket` rows per vehicle.
    pub fn read(
        path: &Path,
        reader: impl BufRead,
        dt: f64,
        t_range: (f64, f64),
        cols: usize,
        bucket: u64,
    ) -> Result<Self> {
        let cols = cols.max(1);
        let (t0, t1) = t_range;
        let width = ((t1 - t0) / cols as f64).max(f64::MIN_POSITIVE);
        let mut f = Formation {
            lanes: BTreeMap::new(),
            t_range,
            rows: 0,
            worst_age: Decimator::with_bucket(bucket),
            in_max: None,
            out_min: None,
            threshold: None,
            near_collision: None,
        };
        let mut tick: Option<(u64, f64, f64)> = None; // (k, t, worst age)
        for_each_row(path, reader, &FORMATION_COLUMNS, |line, r| {
            let t = num(path, line, "t", r[0])?;
            let k = num(path, line, "k", r[1])? as u64;
            let id = r[2].parse::<u32>().with_context(|| {
                format!(
                    "{} line {line}: column id: {:?} is not an id",
                    path.display(),
                    r[2]
                )
            })?;
            let Some(state) = style::contact_index(r[3]) else {
                bail!(
                    "{} line {line}: column contact: {:?} is none of {}",
                    path.display(),
                    r[3],
                    CONTACT_STATES.map(|s| s.0).join(", ")
                );
            };
            let age = opt_num(path, line, "info_age_s", r[4])?;
            let slot = opt_num(path, line, "slot_error", r[5])?;
            let in_formation = match r[7] {
                "1" => true,
                "0" => false,
                other => bail!(
                    "{} line {line}: column in_formation: {other:?} is neither 0 nor 1",
                    path.display()
                ),
            };
            f.rows += 1;
            if tick.is_some_and(|(tk, _, _)| tk != k) {
                let (_, tt, worst) = tick.take().unwrap_or_default();
                f.worst_age.push(tt, worst);
            }
            let entry = tick.get_or_insert((k, t, f64::NAN));
            if let Some(a) = age {
                entry.2 = if entry.2.is_nan() { a } else { entry.2.max(a) };
            }
            let lane = f.lanes.entry(id).or_insert_with(|| Lane::new(cols, bucket));
            lane.seen[state] = true;
            // The tick covers [t, t + dt): spread it over the columns it touches.
            let (a, b) = (t.max(t0), (t + dt).min(t1));
            if b > a {
                let c0 = (((a - t0) / width).floor() as usize).min(cols - 1);
                let c1 = (((b - t0) / width).ceil() as usize).clamp(c0 + 1, cols);
                for c in c0..c1 {
                    let lo = t0 + c as f64 * width;
                    let overlap = b.min(lo + width) - a.max(lo);
                    if overlap > 0.0 {
                        lane.state_time[c][state] += overlap;
                    }
                }
            }
            // A delivery: the age fell below what it would be with no news since last tick.
            if let Some(age) = age {
                let renewed = match lane.prev_age {
                    None => true,
                    Some((tp, ap)) => age < ap + (t - tp) - 1e-9 * (1.0 + t.abs()),
                };
                if renewed {
                    lane.deliveries += 1;
                    if lane
                        .prev_age
                        .is_some_and(|(_, ap)| ap > SILENCE_TICKS as f64 * dt)
                    {
                        lane.silences += 1;
                    }
                    if t >= t0 && t < t1 {
                        let c = (((t - t0) / width) as usize).min(cols - 1);
                        lane.delivered[c] = true;
                    }
                }
                lane.prev_age = Some((t, age));
                if lane.max_age.is_none_or(|(m, _)| age > m) {
                    lane.max_age = Some((age, t));
                }
            }
            lane.info_age.push(t, age.unwrap_or(f64::NAN));
            lane.slot_error.push(t, slot.unwrap_or(f64::NAN));
            if let Some(e) = slot {
                lane.max_slot_error = Some(lane.max_slot_error.map_or(e, |m| m.max(e)));
                if in_formation {
                    f.in_max = Some(f.in_max.map_or(e, |m| m.max(e)));
                } else if state != style::contact_index("dead").unwrap_or(usize::MAX) {
                    f.out_min = Some(f.out_min.map_or(e, |m| m.min(e)));
                }
            }
            Ok(())
        })?;
        if let Some((_, t, worst)) = tick {
            f.worst_age.push(t, worst);
        }
        Ok(f)
    }
}

/// `truth.csv`, decimated.
#[derive(Clone, Debug, Default)]
pub struct Truth {
    /// V of (II.2) from the true states ÷ V_U over time (s).
    pub v_true: Decimator,
    /// The coordinator's own V ÷ V_U over time (s).
    pub v_seen: Decimator,
    /// Nearest pair of live vehicles ÷ design spacing over time (s).
    pub min_pair: Decimator,
    /// Largest slot error ÷ spacing over time (s).
    pub max_slot: Decimator,
    /// Vehicles alive over time (s).
    pub n_alive: Decimator,
    /// Vehicles in formation over time (s).
    pub n_in_formation: Decimator,
    /// Largest true V ÷ V_U.
    pub max_v_true: f64,
    /// Largest seen V ÷ V_U.
    pub max_v_seen: f64,
    /// Smallest nearest-pair ratio and when (s).
    pub closest: Option<(f64, f64)>,
    /// The near-collision threshold (÷ spacing), from `summary.json`.
    pub near_collision: Option<f64>,
    /// Rows read.
    pub rows: u64,
}

impl Truth {
    /// Reads `truth.csv` from `reader` (`path` names it in errors), decimating in buckets of
    /// `bucket` rows.
    pub fn read(path: &Path, reader: impl BufRead, bucket: u64) -> Result<Self> {
        let mut tr = Truth::default();
        for d in [
            &mut tr.v_true,
            &mut tr.v_seen,
            &mut tr.min_pair,
            &mut tr.max_slot,
            &mut tr.n_alive,
            &mut tr.n_in_formation,
        ] {
            d.bucket = bucket;
        }
        for_each_row(path, reader, &TRUTH_COLUMNS, |line, r| {
            let value = |i: usize| opt_num(path, line, TRUTH_COLUMNS[i], r[i]);
            let t = num(path, line, "t", r[0])?;
            let nan = |v: Option<f64>| v.unwrap_or(f64::NAN);
            let (vt, vs) = (value(2)?, value(3)?);
            tr.v_true.push(t, nan(vt));
            tr.v_seen.push(t, nan(vs));
            tr.max_v_true = tr.max_v_true.max(vt.unwrap_or(0.0));
            tr.max_v_seen = tr.max_v_seen.max(vs.unwrap_or(0.0));
            let pair = value(4)?;
            tr.min_pair.push(t, nan(pair));
            if let Some(p) = pair {
                if tr.closest.is_none_or(|(c, _)| p < c) {
                    tr.closest = Some((p, t));
                }
            }
            tr.max_slot.push(t, nan(value(5)?));
            tr.n_alive.push(t, nan(value(6)?));
            tr.n_in_formation.push(t, nan(value(7)?));
            tr.rows += 1;
            Ok(())
        })?;
        Ok(tr)
    }
}

/// A threshold of the truth metrics as `summary.json` records it in its `formation` object
/// (`in_formation_ratio`: the largest slot error ÷ spacing still in formation;
/// `near_collision_ratio`: a pair closer than this × spacing is a near collision).
pub fn summary_ratio(dir: &RunDir, key: &str) -> Option<f64> {
    let text = std::fs::read_to_string(dir.summary()).ok()?;
    let json: serde_json::Value = serde_json::from_str(&text).ok()?;
    json.get("formation")?.get(key)?.as_f64()
}

/// Decimation bucket for `ticks` rows and about `points` points.
fn bucket(ticks: u64, points: usize) -> u64 {
    ticks.div_ceil((points / 4).max(1) as u64).max(1)
}

/// `formation.csv` of `dir` over `t_range` (s); None when absent (an older run) or not
/// readable (a warning says why).
pub fn read_formation_or_warn(
    dir: &RunDir,
    mission: &Mission,
    t_range: (f64, f64),
) -> Option<Formation> {
    let path = dir.root.join(FORMATION_CSV);
    let file = File::open(&path).ok()?;
    let n = mission.vehicles.count.max(1);
    let points = (MAX_POINTS / n.min(MAX_VEHICLE_LINES)).max(400);
    let read = Formation::read(
        &path,
        BufReader::with_capacity(1 << 16, file),
        mission.mission.dt,
        t_range,
        PLOT_W as usize,
        bucket(mission.ticks(), points),
    );
    match read {
        Ok(mut f) => {
            f.threshold = summary_ratio(dir, "in_formation_ratio");
            f.near_collision = summary_ratio(dir, "near_collision_ratio");
            Some(f)
        }
        Err(e) => {
            tracing::warn!(error = %format!("{e:#}"), "contact and slot-error plots left out");
            None
        }
    }
}

/// `truth.csv` of `dir`; None when absent (an older run) or not readable (a warning says
/// why).
pub fn read_truth_or_warn(dir: &RunDir, mission: &Mission) -> Option<Truth> {
    let near_collision = summary_ratio(dir, "near_collision_ratio");
    let path = dir.root.join(TRUTH_CSV);
    let file = File::open(&path).ok()?;
    match Truth::read(
        &path,
        BufReader::with_capacity(1 << 16, file),
        bucket(mission.ticks(), MAX_POINTS / 2),
    ) {
        Ok(t) => Some(Truth {
            near_collision,
            ..t
        }),
        Err(e) => {
            tracing::warn!(error = %format!("{e:#}"), "true V and nearest-pair plots left out");
            None
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Panels of timeseries_formation.svg.

fn rescaled(pts: &[(f64, f64)], unit: TimeUnit) -> Vec<(f64, f64)> {
    pts.iter().map(|&(t, y)| (unit.of(t), y)).collect()
}

/// Each vehicle's true distance from its slot ÷ design spacing, with the in-formation
/// threshold (the worst vehicle only beyond [`MAX_VEHICLE_LINES`] vehicles).
pub fn slot_error_panel(f: &Formation, truth: Option<&Truth>, x: Axis) -> Panel {
    let unit = x.time.unwrap_or(TimeUnit::S);
    let mut p = Panel::new(
        "Distance of each vehicle from its slot ÷ design spacing (true positions)",
        x,
        Axis {
            label: "slot error ÷ spacing".into(),
            from_zero: true,
            ..Axis::default()
        },
    );
    let worst = f
        .lanes
        .values()
        .filter_map(|l| l.max_slot_error)
        .fold(0.0, f64::max);
    if f.lanes.len() <= MAX_VEHICLE_LINES {
        for (id, lane) in &f.lanes {
            p.series.push(Series::line(
                &format!("vehicle {id}"),
                rescaled(&lane.slot_error.points(), unit),
                style::palette(*id as usize),
            ));
        }
    } else if let Some(tr) = truth {
        p.series.push(Series::line(
            &format!("worst of {} vehicles", f.lanes.len()),
            rescaled(&tr.max_slot.points(), unit),
            style::PALETTE[3],
        ));
    } else {
        p.notes
            .push("too many vehicles to draw one by one, and no truth.csv".into());
    }
    let reference = f.threshold.unwrap_or(1.0);
    // A vehicle flung far away: a log axis keeps the others readable.
    if worst > 10.0 * reference.max(0.1) {
        p.y.log = true;
        p.y.from_zero = false;
        p.y.label = "slot error ÷ spacing (log scale)".into();
    }
    match f.threshold {
        Some(th) => p.hlines.push(RefLine {
            y: th,
            label: format!("in formation: ≤ {}", style::fmt_significant(th, 3, 3)),
            colour: "#d62728",
        }),
        None => p.notes.push(match (f.in_max, f.out_min) {
            (Some(a), Some(b)) => format!(
                "in-formation threshold (formation.in_formation_ratio) not in summary.json: between {} and {} by the in_formation column",
                style::fmt_significant(a, 3, 3),
                style::fmt_significant(b, 3, 3)
            ),
            _ => "in-formation threshold (formation.in_formation_ratio) not in summary.json".into(),
        }),
    }
    p
}

/// The nearest pair of live vehicles ÷ design spacing (1 = as designed, near 0 = a
/// collision).
pub fn nearest_pair_panel(tr: &Truth, x: Axis) -> Panel {
    let unit = x.time.unwrap_or(TimeUnit::S);
    let mut p = Panel::new(
        "Nearest pair of live vehicles: true distance ÷ design spacing",
        x,
        Axis {
            label: "nearest pair ÷ spacing".into(),
            from_zero: true,
            ..Axis::default()
        },
    );
    let label = match tr.closest {
        Some((r, t)) => format!(
            "closest {} at {}",
            style::fmt_significant(r, 2, 3),
            unit.fmt(t)
        ),
        None => "nearest pair".into(),
    };
    p.series.push(Series::line(
        &label,
        rescaled(&tr.min_pair.points(), unit),
        style::PALETTE[6],
    ));
    p.hlines.push(RefLine {
        y: 1.0,
        label: "design spacing".into(),
        colour: "#555555",
    });
    if let Some(r) = tr.near_collision {
        p.hlines.push(RefLine {
            y: r,
            label: format!("near collision: < {}", style::fmt_significant(r, 3, 3)),
            colour: style::event_style("near_collision").map_or("#d62728", |s| s.colour),
        });
    }
    p
}

// ---------------------------------------------------------------------------------------------
// contact.svg

/// Colour of the delivery ticks.
const DELIVERY: &str = "#08306b";
/// Lines of event labels above the rows.
const LABEL_LINES: usize = 3;
/// Height of a legend row of the timeline, px.
const LEGEND_ROW: f64 = 18.0;

/// Intervals [start, end) (s) between an opening and a closing kind of event (an open one
/// ends at `t_end`; one starts at the opening event's `detail.since` when it has one), with
/// the opening event's label.
fn intervals(events: &[Event], open: &str, close: &str, t_end: f64) -> Vec<(f64, f64, String)> {
    let mut out = Vec::new();
    let mut current: Option<(f64, String)> = None;
    for e in events {
        if e.kind == open && current.is_none() {
            // The condition began at `detail.since` (s) when the event was debounced.
            let since = e.detail.get("since").and_then(|v| v.as_f64());
            current = Some((since.unwrap_or(e.t).min(e.t), style::event_label(e)));
        } else if e.kind == close {
            if let Some((t, label)) = current.take() {
                out.push((t, e.t, label));
            }
        }
    }
    if let Some((t, label)) = current {
        out.push((t, t_end, label));
    }
    out
}

/// Renders the contact timeline of a run: `f` from `formation.csv`, `events` from
/// `events.jsonl`, times in `unit`.
pub fn render_contact_svg(
    mission: &Mission,
    f: &Formation,
    events: &[Event],
    unit: TimeUnit,
) -> String {
    let m = &mission.mission;
    let (t0, t1) = f.t_range;
    let x0 = MARGIN_LEFT;
    let x1 = MARGIN_LEFT + PLOT_W;
    let x_of = |t: f64| x0 + (t - t0) / (t1 - t0).max(f64::MIN_POSITIVE) * PLOT_W;
    let n = f.lanes.len().max(1);
    let row_h = (380.0 / n as f64).clamp(8.0, 26.0).floor();
    let label_size = (row_h - 2.0).min(13.0);

    // Events: the fleet's as lines across all rows, a vehicle's as a symbol on its row.
    let fleet_events: Vec<&Event> = events
        .iter()
        .filter(|e| e.vehicle.is_none() && style::event_style(&e.kind).is_some())
        .filter(|e| e.t >= t0 && e.t <= t1)
        .collect();
    let vehicle_events: Vec<(u32, &Event)> = events
        .iter()
        .filter(|e| style::event_style(&e.kind).is_some() && !(e.kind == "join" && e.k == 0))
        .flat_map(|e| {
            let ids: Vec<u32> = match (e.kind.as_str(), e.vehicle) {
                ("near_collision", _) => style::near_collision_pair(e)
                    .map(|(a, b)| vec![a as u32, b as u32])
                    .unwrap_or_default(),
                (_, Some(v)) => vec![v],
                _ => Vec::new(),
            };
            ids.into_iter().map(move |v| (v, e))
        })
        .collect();
    let broken = intervals(events, "formation_broken", "formation_restored", t1);
    let stalled = intervals(events, "stall_began", "stall_ended", t1);

    let head_h = 70.0;
    let strip_top = head_h + 6.0;
    let strip_h = if fleet_events.is_empty() {
        0.0
    } else {
        LABEL_LINES as f64 * 14.0 + 6.0
    };
    let fleet_top = strip_top + strip_h;
    let fleet_h = 18.0;
    let rows_top = fleet_top + 2.0 * (fleet_h + 3.0) + 10.0;
    let rows_bottom = rows_top + n as f64 * row_h;
    let axis_bottom = rows_bottom + 50.0;

    // The age panel below.
    let age_unit = TimeUnit::for_magnitude(
        f.lanes
            .values()
            .filter_map(|l| l.max_age.map(|a| a.0))
            .fold(0.0, f64::max),
    );
    let age_panel = age_panel(mission, f, events, unit, age_unit);
    let height = axis_bottom + 20.0 + report_plots::panel_height(&age_panel) + 10.0;

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
        esc(&format!(
            "{} (seed {}): contact with the coordinator",
            m.name, m.seed
        ))
    );
    let deliveries: u64 = f.lanes.values().map(|l| l.deliveries).sum();
    let _ = writeln!(
        svg,
        r##"<text x="{}" y="56" font-size="14" fill="#444444" text-anchor="middle">{}</text>"##,
        WIDTH / 2.0,
        esc(&format!(
            "{} vehicles over {} · one row per vehicle: colour = contact state, dark ticks = reports delivered ({deliveries} in all)",
            f.lanes.len(),
            unit.fmt(t1 - t0)
        ))
    );

    // Time grid behind everything.
    let (ticks, step) = linear_ticks(unit.of(t0), unit.of(t1), 10, false, Some(unit));
    for v in &ticks {
        let x = x_of(v * unit.seconds);
        let _ = writeln!(
            svg,
            r##"<line x1="{x:.1}" y1="{fleet_top}" x2="{x:.1}" y2="{rows_bottom}" stroke="#e5e5e5"/>"##
        );
        let _ = writeln!(
            svg,
            r#"<text x="{x:.1}" y="{}" font-size="13" text-anchor="middle">{}</text>"#,
            rows_bottom + 18.0,
            style::fmt_tick(*v, step)
        );
    }
    let _ = writeln!(
        svg,
        r#"<text x="{:.1}" y="{}" font-size="14" text-anchor="middle">{}</text>"#,
        (x0 + x1) / 2.0,
        rows_bottom + 42.0,
        esc(&unit.axis_label("mission time t"))
    );

    // Fleet rows: formation broken, fleet stalled.
    for (row, (name, never, spans, kind)) in [
        (
            "broken",
            "formation never broken",
            &broken,
            "formation_broken",
        ),
        ("stalled", "fleet never stalled", &stalled, "stall_began"),
    ]
    .into_iter()
    .enumerate()
    {
        let y = fleet_top + row as f64 * (fleet_h + 3.0);
        let colour = style::event_style(kind).map_or("#555555", |s| s.colour);
        let _ = writeln!(
            svg,
            r##"<rect x="{x0}" y="{y}" width="{PLOT_W}" height="{fleet_h}" fill="#f7f7f7"/>"##
        );
        let _ = writeln!(
            svg,
            r#"<text x="{}" y="{:.1}" font-size="12" text-anchor="end">{name}</text>"#,
            x0 - 8.0,
            y + fleet_h / 2.0 + 4.0
        );
        if spans.is_empty() {
            let _ = writeln!(
                svg,
                r##"<text x="{}" y="{:.1}" font-size="11" fill="#777777" font-style="italic">{never}</text>"##,
                x0 + 4.0,
                y + fleet_h / 2.0 + 4.0
            );
        }
        for (a, b, label) in spans {
            let (xa, xb) = (x_of(a.max(t0)), x_of(b.min(t1)));
            let w = (xb - xa).max(1.5);
            let _ = writeln!(
                svg,
                r#"<rect x="{xa:.1}" y="{y}" width="{w:.1}" height="{fleet_h}" fill="{colour}" fill-opacity="0.75"><title>{}</title></rect>"#,
                esc(&format!("{label}: {} to {}", unit.fmt(*a), unit.fmt(*b)))
            );
            if text_width(label, 11.0) + 6.0 < w {
                let _ = writeln!(
                    svg,
                    r#"<text x="{:.1}" y="{:.1}" font-size="11" fill="white">{}</text>"#,
                    xa + 3.0,
                    y + fleet_h / 2.0 + 4.0,
                    esc(label)
                );
            }
        }
    }

    // Vehicle rows.
    for (row, (id, lane)) in f.lanes.iter().enumerate() {
        let y = rows_top + row as f64 * row_h;
        let h = (row_h - 3.0).max(4.0);
        let _ = writeln!(
            svg,
            r#"<text x="{}" y="{:.1}" font-size="{label_size}" text-anchor="end">vehicle {id}</text>"#,
            x0 - 8.0,
            y + h / 2.0 + label_size * 0.35
        );
        // Runs of pixel columns of one state.
        let state_of = |c: usize| -> Option<usize> {
            let st = &lane.state_time[c];
            if st.iter().all(|v| *v <= 0.0) {
                return None;
            }
            // Rare, telling states show even when they cover part of a column.
            let telling = ["dead", "link_down", "rejoining"]
                .iter()
                .filter_map(|s| style::contact_index(s))
                .filter(|&i| st[i] > 0.0)
                .max_by(|&a, &b| st[a].total_cmp(&st[b]));
            telling.or_else(|| {
                (0..N_STATES)
                    .filter(|&i| st[i] > 0.0)
                    .max_by(|&a, &b| st[a].total_cmp(&st[b]))
            })
        };
        let cols = lane.state_time.len();
        let col_w = PLOT_W / cols as f64;
        let mut c = 0;
        while c < cols {
            let s = state_of(c);
            let start = c;
            while c < cols && state_of(c) == s {
                c += 1;
            }
            if let Some(s) = s {
                let (_, colour, legend) = CONTACT_STATES[s];
                let _ = writeln!(
                    svg,
                    r#"<rect x="{:.1}" y="{y:.1}" width="{:.1}" height="{h}" fill="{colour}"><title>vehicle {id}: {} {} to {}</title></rect>"#,
                    x0 + start as f64 * col_w,
                    (c - start) as f64 * col_w,
                    esc(legend),
                    unit.fmt(t0 + start as f64 * col_w / PLOT_W * (t1 - t0)),
                    unit.fmt(t0 + c as f64 * col_w / PLOT_W * (t1 - t0)),
                );
            }
        }
        // Deliveries: runs of columns with one, along the bottom third of the row.
        let dh = (h * 0.35).max(2.0);
        let mut c = 0;
        while c < cols {
            if !lane.delivered[c] {
                c += 1;
                continue;
            }
            let start = c;
            while c < cols && lane.delivered[c] {
                c += 1;
            }
            let _ = writeln!(
                svg,
                r#"<rect x="{:.1}" y="{:.1}" width="{:.1}" height="{dh:.1}" fill="{DELIVERY}"/>"#,
                x0 + start as f64 * col_w,
                y + h - dh,
                ((c - start) as f64 * col_w).max(1.0),
            );
        }
        // The vehicle's own events.
        for (_, e) in vehicle_events.iter().filter(|(v, _)| v == id) {
            if e.t < t0 || e.t > t1 {
                continue;
            }
            let Some(st) = style::event_style(&e.kind) else {
                continue;
            };
            let r = (h / 2.0).clamp(3.0, 7.0);
            let shape = vehicle_symbol(&e.kind, (x_of(e.t), y + h / 2.0), r, st.colour);
            let _ = writeln!(
                svg,
                "<g><title>{}</title>{shape}</g>",
                esc(&format!("{} at {}", style::event_label(e), unit.fmt(e.t)))
            );
        }
    }
    let _ = writeln!(
        svg,
        r#"<rect x="{x0}" y="{rows_top}" width="{PLOT_W}" height="{:.1}" fill="none" stroke="black"/>"#,
        rows_bottom - rows_top
    );

    // The fleet's events: dashed lines, labels on up to three lines above.
    let mut line_ends: [f64; LABEL_LINES] = [f64::NEG_INFINITY; LABEL_LINES];
    for e in &fleet_events {
        let Some(st) = style::event_style(&e.kind) else {
            continue;
        };
        let x = x_of(e.t);
        let _ = writeln!(
            svg,
            r#"<line x1="{x:.1}" y1="{strip_top}" x2="{x:.1}" y2="{rows_bottom}" stroke="{}" stroke-width="1.2" stroke-dasharray="4 3"><title>{}</title></line>"#,
            st.colour,
            esc(&format!("{} at {}", style::event_label(e), unit.fmt(e.t)))
        );
        let label = style::event_label(e);
        let w = text_width(&label, 11.0);
        if let Some(line) = (0..LABEL_LINES).find(|&l| line_ends[l] < x - 2.0) {
            line_ends[line] = x + 3.0 + w;
            let _ = writeln!(
                svg,
                r#"<text x="{:.1}" y="{:.1}" font-size="11" fill="{}">{}</text>"#,
                x + 3.0,
                strip_top + 11.0 + line as f64 * 14.0,
                st.colour,
                esc(&label)
            );
        }
    }

    // Legend: the states met, deliveries, the kinds of events drawn.
    let lx = x1 + 22.0;
    let mut ly = fleet_top + 6.0;
    // Down to the first legend row of the age panel below.
    let legend_bottom = axis_bottom + 40.0;
    let mut entries: Vec<String> = Vec::new();
    for (i, (_, colour, legend)) in CONTACT_STATES.iter().enumerate() {
        if f.lanes.values().any(|l| l.seen[i]) {
            entries.push(format!(
                r#"<rect x="0" y="-7" width="28" height="14" fill="{colour}"/>{}"#,
                legend_text(legend)
            ));
        }
    }
    entries.push(format!(
        r#"<rect x="0" y="2" width="28" height="5" fill="{DELIVERY}"/>{}"#,
        legend_text("report delivered (age reset)")
    ));
    let mut kinds = BTreeSet::new();
    for (_, e) in &vehicle_events {
        if let Some(st) = style::event_style(&e.kind) {
            if kinds.insert(e.kind.as_str()) {
                entries.push(format!(
                    "{}{}",
                    vehicle_symbol(&e.kind, (14.0, 0.0), 6.0, st.colour),
                    legend_text(st.legend)
                ));
            }
        }
    }
    if !fleet_events.is_empty() {
        entries.push(format!(
            r##"<line x1="14" y1="-8" x2="14" y2="8" stroke="#555555" stroke-width="1.5" stroke-dasharray="4 3"/>{}"##,
            legend_text("fleet event (labelled above)")
        ));
    }
    let max_entries = (((legend_bottom - ly) / LEGEND_ROW) as usize).max(1);
    let total = entries.len();
    for (i, e) in entries.into_iter().enumerate() {
        if i + 1 == max_entries && total > max_entries {
            let _ = writeln!(
                svg,
                r##"<text x="{lx}" y="{:.1}" font-size="13" fill="#555555">… and {} more</text>"##,
                ly + 4.5,
                total - i
            );
            break;
        }
        let _ = writeln!(svg, r#"<g transform="translate({lx},{ly:.1})">{e}</g>"#);
        ly += LEGEND_ROW;
    }

    report_plots::render_panel(&mut svg, &age_panel, 0, axis_bottom + 20.0, false);
    svg.push_str("</svg>\n");
    svg
}

/// The symbol of a vehicle's event on its row, centred at `(cx, cy)` px, half-size `r`:
/// a cross for a loss, a diamond for a near collision, a downward triangle otherwise.
fn vehicle_symbol(kind: &str, (cx, cy): (f64, f64), r: f64, colour: &str) -> String {
    match kind {
        "lost" => format!(
            r#"<path d="M{:.1},{:.1}L{:.1},{:.1}M{:.1},{:.1}L{:.1},{:.1}" stroke="{colour}" stroke-width="2.5"/>"#,
            cx - r,
            cy - r,
            cx + r,
            cy + r,
            cx - r,
            cy + r,
            cx + r,
            cy - r
        ),
        "near_collision" => format!(
            r#"<path d="M{cx:.1},{:.1}L{:.1},{cy:.1}L{cx:.1},{:.1}L{:.1},{cy:.1}Z" fill="{colour}" stroke="white"/>"#,
            cy - r,
            cx + r,
            cy + r,
            cx - r
        ),
        _ => format!(
            r#"<path d="M{:.1},{:.1}L{:.1},{:.1}L{cx:.1},{:.1}Z" fill="{colour}" stroke="white"/>"#,
            cx - r,
            cy - r,
            cx + r,
            cy - r,
            cy + r
        ),
    }
}

fn legend_text(label: &str) -> String {
    format!(
        r#"<text x="36" y="4.5" font-size="13">{}</text>"#,
        rich(label, 13.0)
    )
}

/// The age of the coordinator's newest information per vehicle (the worst only beyond
/// [`MAX_VEHICLE_LINES`] vehicles), in `age_unit`, against the surfacing period.
fn age_panel(
    mission: &Mission,
    f: &Formation,
    events: &[Event],
    unit: TimeUnit,
    age_unit: TimeUnit,
) -> Panel {
    let (t0, t1) = f.t_range;
    let mut p = Panel::new(
        "Age of the coordinator's newest information about each vehicle",
        Axis {
            label: unit.axis_label("mission time t"),
            range: Some((unit.of(t0), unit.of(t1))),
            time: Some(unit),
            ..Axis::default()
        },
        Axis {
            label: age_unit.axis_label("information age"),
            from_zero: true,
            ..Axis::default()
        },
    );
    let in_age = |pts: Vec<(f64, f64)>| -> Vec<(f64, f64)> {
        pts.into_iter()
            .map(|(t, a)| (unit.of(t), age_unit.of(a)))
            .collect()
    };
    let max_label = |id: u32, lane: &Lane| match lane.max_age {
        Some((a, _)) => format!("vehicle {id} (max {})", age_unit.fmt(a)),
        None => format!("vehicle {id} (no report)"),
    };
    // One line per vehicle shows its silences when there are a few; with none (ages
    // jittering with the link delay) or very many, the lines would cover each other.
    let sawteeth = f.lanes.values().map(|l| l.silences).max().unwrap_or(0);
    if f.lanes.len() <= MAX_VEHICLE_LINES && (1..=MAX_SAWTEETH).contains(&sawteeth) {
        for (id, lane) in &f.lanes {
            p.series.push(Series::line(
                &max_label(*id, lane),
                in_age(lane.info_age.points()),
                style::palette(*id as usize),
            ));
        }
    } else {
        p.series.push(Series::line(
            &format!("oldest of {} vehicles", f.lanes.len()),
            in_age(f.worst_age.points()),
            style::PALETTE[3],
        ));
        let per_vehicle: Vec<String> = f
            .lanes
            .iter()
            .take(MAX_VEHICLE_LINES)
            .map(|(id, lane)| max_label(*id, lane))
            .collect();
        p.notes.push(per_vehicle.join(", "));
    }
    let period = mission.links.surfacing_period;
    if period > 0.0 {
        p.hlines.push(RefLine {
            y: age_unit.of(period),
            label: format!("surfacing period {}", style::fmt_duration(period)),
            colour: "#555555",
        });
    }
    p.markers = report_plots::event_markers(events, unit);
    p
}

#[cfg(test)]
mod tests {
    use super::*;

    const FORMATION: &str = "t,k,id,contact,info_age_s,slot_error,nearest_ratio,in_formation
0,0,0,surfaced,,0.1,1,1
0,0,1,submerged,,0.2,1,1
1,1,0,surfaced,0,0.1,1,1
1,1,1,submerged,,0.3,1,1
2,2,0,submerged,1,0.1,1,1
2,2,1,surfaced,0.5,0.6,1,0
3,3,0,submerged,2,0.1,1,1
3,3,1,surfaced,0.5,0.2,1,1
4,4,0,link_down,3,0.4,,1
4,4,1,dead,,,,0
5,5,0,rejoining,0,0.5,,0
5,5,1,dead,,,,0
6,6,0,surf";

    fn read_fixture(text: &str) -> Result<Formation> {
        Formation::read(
            Path::new("formation.csv"),
            text.as_bytes(),
            1.0,
            (0.0, 6.0),
            12,
            1,
        )
    }

    #[test]
    fn formation_reader_follows_the_schema() {
        let f = read_fixture(FORMATION).unwrap();
        assert_eq!(f.rows, 12, "the partial last line is skipped");
        assert_eq!(f.lanes.len(), 2);
        let idx = |s| style::contact_index(s).unwrap();
        let v0 = &f.lanes[&0];
        // Two columns per tick of 1 s: column 0 and 1 hold tick 0, half a second each.
        assert_eq!(v0.state_time[0][idx("surfaced")], 0.5);
        assert_eq!(v0.state_time[4][idx("submerged")], 0.5);
        assert_eq!(v0.state_time[8][idx("link_down")], 0.5);
        assert_eq!(v0.state_time[10][idx("rejoining")], 0.5);
        // Vehicle 0: delivered at t = 1 (first report) and t = 5 (age 3 -> 0); its age grew
        // by 1 s a tick in between: no delivery.
        assert_eq!(v0.deliveries, 2);
        let delivered: Vec<usize> = (0..12).filter(|&c| v0.delivered[c]).collect();
        assert_eq!(delivered, vec![2, 10]);
        assert_eq!(v0.max_age, Some((3.0, 4.0)));
        // Vehicle 1: first report at t = 2 (age 0.5), renewed at t = 3 (still 0.5), then dead.
        let v1 = &f.lanes[&1];
        assert_eq!(v1.deliveries, 2);
        assert!(v1.seen[idx("dead")] && !v1.seen[idx("contact")]);
        assert_eq!(v1.max_slot_error, Some(0.6));
        // The slot error breaks (NaN) while dead.
        let pts = v1.slot_error.points();
        assert_eq!(pts.len(), 6);
        assert!(pts[4].1.is_nan() && pts[5].1.is_nan());
        // In formation up to 0.4 (vehicle 0 at t = 4), out from 0.5 (vehicle 0 at t = 5).
        assert_eq!(f.in_max, Some(0.4));
        assert_eq!(f.out_min, Some(0.5));
        // The worst age per tick, over the vehicles that have one.
        let worst = f.worst_age.points();
        assert_eq!(worst.len(), 6);
        assert!(worst[0].1.is_nan());
        assert_eq!(worst[2], (2.0, 1.0));
        assert_eq!(worst[4], (4.0, 3.0));
    }

    #[test]
    fn formation_reader_names_what_is_wrong() {
        let missing = "t,k,id,contact,info_age_s,slot_error,in_formation\n0,0,0,surfaced,,0.1,1\n";
        let e = format!("{:#}", read_fixture(missing).unwrap_err());
        assert!(
            e.contains("formation.csv") && e.contains("nearest_ratio"),
            "{e}"
        );
        let bad_state = "t,k,id,contact,info_age_s,slot_error,nearest_ratio,in_formation\n0,0,0,asleep,,0.1,1,1\n";
        let e = format!("{:#}", read_fixture(bad_state).unwrap_err());
        assert!(e.contains("line 2") && e.contains("asleep"), "{e}");
        let bad_num =
            "t,k,id,contact,info_age_s,slot_error,nearest_ratio,in_formation\n0,0,0,dead,x,,,0\n";
        let e = format!("{:#}", read_fixture(bad_num).unwrap_err());
        assert!(e.contains("info_age_s"), "{e}");
        // Columns in another order, and one more, read the same.
        let reordered = "k,t,extra,id,in_formation,contact,slot_error,info_age_s,nearest_ratio\n0,0,x,3,1,contact,0.25,0,0.9\n";
        let f = read_fixture(reordered).unwrap();
        assert_eq!(f.lanes[&3].max_slot_error, Some(0.25));
        assert_eq!(f.lanes[&3].deliveries, 1);
    }

    #[test]
    fn truth_reader_follows_the_schema() {
        let text = "t,k,V_true_over_VU,V_seen_over_VU,min_pair_ratio,max_slot_error,n_alive,n_in_formation,sdot_over_v0
0,0,0.5,0.4,0.9,0.1,3,3,0
1,1,68.7,13.8,0.06,2.5,3,2,1
2,2,1.5,1.2,,0.2,1,1,0.5
";
        let tr = Truth::read(Path::new("truth.csv"), text.as_bytes(), 1).unwrap();
        assert_eq!(tr.rows, 3);
        assert_eq!(tr.max_v_true, 68.7);
        assert_eq!(tr.max_v_seen, 13.8);
        assert_eq!(tr.closest, Some((0.06, 1.0)));
        let pair = tr.min_pair.points();
        assert!(pair[2].1.is_nan(), "empty when fewer than 2 alive");
        assert_eq!(tr.n_in_formation.points()[1], (1.0, 2.0));
        let e = format!(
            "{:#}",
            Truth::read(Path::new("truth.csv"), "t,k\n0,0\n".as_bytes(), 1).unwrap_err()
        );
        assert!(
            e.contains("truth.csv") && e.contains("V_true_over_VU"),
            "{e}"
        );
    }

    #[test]
    fn intervals_pair_openings_with_closings() {
        let ev = |t: f64, kind: &str| Event {
            t,
            k: t as u64,
            kind: kind.into(),
            vehicle: None,
            detail: serde_json::json!({"why": "holding"}),
        };
        let events = vec![
            ev(1.0, "stall_began"),
            ev(2.0, "stall_ended"),
            ev(5.0, "stall_began"),
        ];
        let iv = intervals(&events, "stall_began", "stall_ended", 9.0);
        assert_eq!(
            iv,
            vec![
                (1.0, 2.0, "stall (holding)".to_string()),
                (5.0, 9.0, "stall (holding)".to_string())
            ]
        );
        // A debounced event: the condition began at detail.since.
        let broken = Event {
            detail: serde_json::json!({"vehicles": [1, 5], "since": 3.5}),
            ..ev(4.0, "formation_broken")
        };
        let iv = intervals(
            &[broken, ev(6.0, "formation_restored")],
            "formation_broken",
            "formation_restored",
            9.0,
        );
        assert_eq!(iv, vec![(3.5, 6.0, "broken: 1, 5".to_string())]);
    }
}
