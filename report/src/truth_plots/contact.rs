//! `contact.svg`: one row per vehicle over mission time coloured by its contact state, the
//! deliveries along the bottom of each row, the vehicle's own events as symbols, the fleet's
//! events as labelled dashed lines, two fleet rows on top (formation broken, fleet stalled)
//! and the age panel below. Drawn on [`crate::plot::canvas`] (plotters).

use crate::plot::canvas::{self, text_width, Anchor, Canvas, TextOpts};
use crate::plot::chart::legend::{self, Swatch};
use crate::plot::chart::{
    draw_head, draw_panel, panel_height, ticks::linear_ticks, MARGIN_LEFT, PLOT_W,
};
use crate::plot::style::{self, TimeUnit, CONTACT_STATES};
use crate::plot::PlotError;
use vbap_mission::acoustic::AcousticModel;
use vbap_mission::config::Mission;
use vbap_mission::link::{LinkModel, Session};
use vbap_wire::rundir::Event;

use super::{panels::age_panel, Formation, Lane, N_STATES};

/// Colour of the delivery ticks.
const DELIVERY: &str = "#08306b";
/// Colours of the Iridium sessions (`[links.iridium]`): opened, failed.
const SESSION_OK: &str = "#1a9850";
const SESSION_FAILED: &str = "#d73027";
/// Colour of the acoustic frames a vehicle sends (`[acoustic]`).
const ACOUSTIC_FRAME: &str = "#6a3d9a";
/// Lines of event labels above the rows.
const LABEL_LINES: usize = 3;
/// Height of a legend row of the timeline, px.
const LEGEND_ROW: f64 = 18.0;
/// Height of a fleet row, px.
const FLEET_H: f64 = 18.0;

/// Intervals [start, end) (s) between an opening and a closing kind of event (an open one
/// ends at `t_end`; one starts at the opening event's `detail.since` when it has one), with
/// the opening event's label.
pub(super) fn intervals(
    events: &[Event],
    open: &str,
    close: &str,
    t_end: f64,
) -> Vec<(f64, f64, String)> {
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

/// The vertical layout of the timeline and its horizontal time scale.
struct Layout {
    t0: f64,
    t1: f64,
    row_h: f64,
    strip_top: f64,
    fleet_top: f64,
    rows_top: f64,
    rows_bottom: f64,
    axis_bottom: f64,
}

impl Layout {
    fn new(f: &Formation, fleet_events: bool) -> Self {
        let (t0, t1) = f.t_range;
        let n = f.lanes.len().max(1);
        let row_h = (380.0 / n as f64).clamp(8.0, 26.0).floor();
        let strip_top = 70.0 + 6.0;
        let strip_h = if fleet_events {
            LABEL_LINES as f64 * 14.0 + 6.0
        } else {
            0.0
        };
        let fleet_top = strip_top + strip_h;
        let rows_top = fleet_top + 2.0 * (FLEET_H + 3.0) + 10.0;
        let rows_bottom = rows_top + n as f64 * row_h;
        Self {
            t0,
            t1,
            row_h,
            strip_top,
            fleet_top,
            rows_top,
            rows_bottom,
            axis_bottom: rows_bottom + 50.0,
        }
    }
    /// The pixel column of mission time `t` (s).
    fn x(&self, t: f64) -> f64 {
        MARGIN_LEFT + (t - self.t0) / (self.t1 - self.t0).max(f64::MIN_POSITIVE) * PLOT_W
    }
}

/// The events of the run split for the timeline: the fleet's (lines across all rows) and each
/// vehicle's (a symbol on its row; a near collision on both vehicles' rows).
fn split_events<'a>(events: &'a [Event], l: &Layout) -> (Vec<&'a Event>, Vec<(u32, &'a Event)>) {
    let fleet = events
        .iter()
        .filter(|e| e.vehicle.is_none() && style::event_style(&e.kind).is_some())
        .filter(|e| e.t >= l.t0 && e.t <= l.t1)
        .collect();
    let vehicle = events
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
    (fleet, vehicle)
}

/// Renders the contact timeline of a run: `f` from `formation.csv`, `events` from
/// `events.jsonl`, times in `unit`.
pub fn render_contact_svg(
    mission: &Mission,
    f: &Formation,
    events: &[Event],
    unit: TimeUnit,
) -> Result<String, PlotError> {
    let m = &mission.mission;
    let probe = Layout::new(f, false);
    let (fleet_events, vehicle_events) = split_events(events, &probe);
    let l = Layout::new(f, !fleet_events.is_empty());
    let age_unit = TimeUnit::for_magnitude(
        f.lanes
            .values()
            .filter_map(|l| l.max_age.map(|a| a.0))
            .fold(0.0, f64::max),
    );
    let age = age_panel(mission, f, events, unit, age_unit);
    let height = l.axis_bottom + 20.0 + panel_height(&age) + 10.0;
    let deliveries: u64 = f.lanes.values().map(|l| l.deliveries).sum();
    let model = LinkModel::new(mission);
    let sessions: std::collections::BTreeMap<u32, Vec<Session>> = f
        .lanes
        .keys()
        .map(|&id| (id, model.sessions(id, l.t0, l.t1)))
        .collect();
    let (opened, failed) =
        sessions.values().flatten().fold(
            (0, 0),
            |(o, x), s| {
                if s.ok {
                    (o + 1, x)
                } else {
                    (o, x + 1)
                }
            },
        );
    let iridium = model.iridium().is_some();
    let subtitle_sessions = if iridium {
        format!(" · Iridium sessions along the top ({opened} opened, {failed} failed)")
    } else {
        String::new()
    };
    let channel = AcousticModel::new(mission);
    let frames: std::collections::BTreeMap<u32, Vec<f64>> = f
        .lanes
        .keys()
        .map(|&id| {
            let sent = channel.as_ref().map(|c| c.sent_between(id, l.t0, l.t1));
            (id, sent.unwrap_or_default())
        })
        .collect();
    let sent: usize = frames.values().map(Vec::len).sum();
    canvas::render((crate::plot::chart::WIDTH, height), |c| {
        draw_head(
            c,
            &format!("{} (seed {}): contact with the coordinator", m.name, m.seed),
            &format!(
                "{} vehicles over {} · one row per vehicle: colour = contact state, dark ticks = reports delivered ({deliveries} in all){subtitle_sessions}",
                f.lanes.len(),
                unit.fmt(l.t1 - l.t0)
            ),
        )?;
        draw_time_grid(c, &l, unit)?;
        draw_fleet_rows(c, &l, events, unit)?;
        for (row, (id, lane)) in f.lanes.iter().enumerate() {
            let y = l.rows_top + row as f64 * l.row_h;
            draw_lane(c, &l, y, *id, lane)?;
            draw_sessions(c, &l, y, &sessions[id])?;
            draw_frames(c, &l, y, &frames[id])?;
            let own = vehicle_events
                .iter()
                .filter(|(v, _)| v == id)
                .map(|(_, e)| *e);
            draw_vehicle_events(c, &l, y, own)?;
        }
        let rows = (PLOT_W, l.rows_bottom - l.rows_top);
        c.frame((MARGIN_LEFT, l.rows_top), rows, "#000000")?;
        draw_fleet_events(c, &l, &fleet_events)?;
        let links = Links {
            iridium,
            acoustic: channel.as_ref().map(|_| sent),
        };
        draw_legend(c, &l, f, &vehicle_events, !fleet_events.is_empty(), links)?;
        draw_panel(c, &age, l.axis_bottom + 20.0, false)
    })
}

/// The time grid behind the rows, its tick labels and the axis label.
fn draw_time_grid(c: &Canvas<'_>, l: &Layout, unit: TimeUnit) -> Result<(), PlotError> {
    let (ticks, step) = linear_ticks(unit.of(l.t0), unit.of(l.t1), 10, false, Some(unit));
    let mid = TextOpts::new(13.0).anchor(Anchor::Middle);
    for v in &ticks {
        let x = l.x(v * unit.seconds);
        c.line((x, l.fleet_top), (x, l.rows_bottom), "#e5e5e5", 1, None)?;
        c.text((x, l.rows_bottom + 18.0), &style::fmt_tick(*v, step), mid)?;
    }
    let centre = MARGIN_LEFT + PLOT_W / 2.0;
    let label = unit.axis_label("mission time t");
    c.text(
        (centre, l.rows_bottom + 42.0),
        &label,
        mid.colour("#000000"),
    )
}

/// The fleet rows: formation broken, fleet stalled (from the events).
fn draw_fleet_rows(
    c: &Canvas<'_>,
    l: &Layout,
    events: &[Event],
    unit: TimeUnit,
) -> Result<(), PlotError> {
    let broken = intervals(events, "formation_broken", "formation_restored", l.t1);
    let stalled = intervals(events, "stall_began", "stall_ended", l.t1);
    let rows = [
        (
            "broken",
            "formation never broken",
            &broken,
            "formation_broken",
        ),
        ("stalled", "fleet never stalled", &stalled, "stall_began"),
    ];
    for (row, (name, never, spans, kind)) in rows.into_iter().enumerate() {
        let y = l.fleet_top + row as f64 * (FLEET_H + 3.0);
        let colour = style::event_style(kind).map_or("#555555", |s| s.colour);
        let text_y = y + FLEET_H / 2.0 + 4.0;
        c.rect((MARGIN_LEFT, y), (PLOT_W, FLEET_H), "#f7f7f7", 1.0)?;
        let o = TextOpts::new(12.0).anchor(Anchor::End);
        c.text((MARGIN_LEFT - 8.0, text_y), name, o)?;
        if spans.is_empty() {
            let o = TextOpts::new(11.0).colour("#777777").italic();
            c.text((MARGIN_LEFT + 4.0, text_y), never, o)?;
        }
        for (a, b, label) in spans {
            let (xa, xb) = (l.x(a.max(l.t0)), l.x(b.min(l.t1)));
            let w = (xb - xa).max(1.5);
            c.rect((xa, y), (w, FLEET_H), colour, 0.75)?;
            if text_width(label, 11.0) + 6.0 < w {
                let o = TextOpts::new(11.0).colour("#ffffff");
                c.text((xa + 3.0, text_y), label, o)?;
            }
        }
        let _ = unit;
    }
    Ok(())
}

/// The state shown in pixel column `c` of a lane: a rare, telling state (dead, link down,
/// rejoining) even when it covers part of the column, else the longest.
fn state_of(lane: &Lane, c: usize) -> Option<usize> {
    let st = &lane.state_time[c];
    if st.iter().all(|v| *v <= 0.0) {
        return None;
    }
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
}

/// One vehicle's row at `y`: its label, runs of columns of one state, the deliveries.
fn draw_lane(c: &Canvas<'_>, l: &Layout, y: f64, id: u32, lane: &Lane) -> Result<(), PlotError> {
    let h = (l.row_h - 3.0).max(4.0);
    let label_size = (l.row_h - 2.0).min(13.0);
    let o = TextOpts::new(label_size).anchor(Anchor::End);
    c.text(
        (MARGIN_LEFT - 8.0, y + h / 2.0 + label_size * 0.35),
        &format!("vehicle {id}"),
        o,
    )?;
    let cols = lane.state_time.len();
    let col_w = PLOT_W / cols as f64;
    let mut col = 0;
    while col < cols {
        let s = state_of(lane, col);
        let start = col;
        while col < cols && state_of(lane, col) == s {
            col += 1;
        }
        if let Some(s) = s {
            let x = MARGIN_LEFT + start as f64 * col_w;
            c.rect(
                (x, y),
                ((col - start) as f64 * col_w, h),
                CONTACT_STATES[s].1,
                1.0,
            )?;
        }
    }
    // Deliveries: runs of columns with one, along the bottom third of the row.
    let dh = (h * 0.35).max(2.0);
    let mut col = 0;
    while col < cols {
        if !lane.delivered[col] {
            col += 1;
            continue;
        }
        let start = col;
        while col < cols && lane.delivered[col] {
            col += 1;
        }
        let x = MARGIN_LEFT + start as f64 * col_w;
        let w = ((col - start) as f64 * col_w).max(1.0);
        c.rect((x, y + h - dh), (w, dh), DELIVERY, 1.0)?;
    }
    Ok(())
}

/// A vehicle's own events on its row at `y`.
fn draw_vehicle_events<'a>(
    c: &Canvas<'_>,
    l: &Layout,
    y: f64,
    events: impl Iterator<Item = &'a Event>,
) -> Result<(), PlotError> {
    let h = (l.row_h - 3.0).max(4.0);
    for e in events.filter(|e| e.t >= l.t0 && e.t <= l.t1) {
        let Some(st) = style::event_style(&e.kind) else {
            continue;
        };
        let r = (h / 2.0).clamp(3.0, 7.0);
        vehicle_symbol(c, &e.kind, (l.x(e.t), y + h / 2.0), r, st.colour)?;
    }
    Ok(())
}

/// The symbol of a vehicle's event centred at `(cx, cy)` px, half-size `r`: a cross for a
/// loss, a diamond for a near collision, a downward triangle otherwise.
fn vehicle_symbol(
    c: &Canvas<'_>,
    kind: &str,
    (cx, cy): (f64, f64),
    r: f64,
    colour: &'static str,
) -> Result<(), PlotError> {
    match kind {
        "lost" => {
            c.line((cx - r, cy - r), (cx + r, cy + r), colour, 3, None)?;
            c.line((cx - r, cy + r), (cx + r, cy - r), colour, 3, None)
        }
        "near_collision" => {
            let diamond = [(cx, cy - r), (cx + r, cy), (cx, cy + r), (cx - r, cy)];
            c.polygon(&diamond, colour)
        }
        _ => c.polygon(&[(cx - r, cy - r), (cx + r, cy - r), (cx, cy + r)], colour),
    }
}

/// The fleet's events: dashed lines across the rows, labels on up to three lines above.
fn draw_fleet_events(c: &Canvas<'_>, l: &Layout, events: &[&Event]) -> Result<(), PlotError> {
    let mut line_ends: [f64; LABEL_LINES] = [f64::NEG_INFINITY; LABEL_LINES];
    for e in events {
        let Some(st) = style::event_style(&e.kind) else {
            continue;
        };
        let x = l.x(e.t);
        c.line(
            (x, l.strip_top),
            (x, l.rows_bottom),
            st.colour,
            1,
            Some((4, 3)),
        )?;
        let label = style::event_label(e);
        let w = text_width(&label, 11.0);
        if let Some(line) = (0..LABEL_LINES).find(|&i| line_ends[i] < x - 2.0) {
            line_ends[line] = x + 3.0 + w;
            let at = (x + 3.0, l.strip_top + 11.0 + line as f64 * 14.0);
            c.text(at, &label, TextOpts::new(11.0).colour(st.colour))?;
        }
    }
    Ok(())
}

/// A vehicle's Iridium sessions in its row at `y`: a mark along the top at each, green when
/// it opened, red when it failed.
fn draw_sessions(
    c: &Canvas<'_>,
    l: &Layout,
    y: f64,
    sessions: &[Session],
) -> Result<(), PlotError> {
    let h = (l.row_h - 3.0).max(4.0);
    let dh = (h * 0.3).max(2.0);
    for s in sessions {
        let colour = if s.ok { SESSION_OK } else { SESSION_FAILED };
        c.rect((l.x(s.at), y), (1.0, dh), colour, 1.0)?;
    }
    Ok(())
}

/// A vehicle's acoustic frames in its row at `y`: a mark along the bottom at each (one per
/// pixel column: a frame a minute over days would be thousands).
fn draw_frames(c: &Canvas<'_>, l: &Layout, y: f64, frames: &[f64]) -> Result<(), PlotError> {
    let h = (l.row_h - 3.0).max(4.0);
    let dh = (h * 0.3).max(2.0);
    let mut last = f64::NEG_INFINITY;
    for &at in frames {
        let x = l.x(at).floor();
        if x > last {
            c.rect((x, y + h - dh), (1.0, dh), ACOUSTIC_FRAME, 1.0)?;
            last = x;
        }
    }
    Ok(())
}

/// Which links a contact picture draws beyond the contact states.
#[derive(Clone, Copy)]
struct Links {
    /// Iridium sessions.
    iridium: bool,
    /// Acoustic frames, and how many were sent (None: no acoustic channel).
    acoustic: Option<usize>,
}

/// The legend: the states met, deliveries, Iridium's sessions, acoustic frames, the kinds
/// of vehicle events drawn, fleet events.
fn draw_legend(
    c: &Canvas<'_>,
    l: &Layout,
    f: &Formation,
    vehicle_events: &[(u32, &Event)],
    fleet_events: bool,
    links: Links,
) -> Result<(), PlotError> {
    let iridium = links.iridium;
    let x = MARGIN_LEFT + PLOT_W + 22.0;
    let mut y = l.fleet_top + 6.0;
    // Down to the first legend row of the age panel below.
    let legend_bottom = l.axis_bottom + 40.0;
    let mut entries: Vec<(Option<Swatch>, Option<&str>, String)> = Vec::new();
    for (i, (_, colour, text)) in CONTACT_STATES.iter().enumerate() {
        if f.lanes.values().any(|l| l.seen[i]) {
            let sw = Swatch::Box {
                colour,
                height: 14.0,
            };
            entries.push((Some(sw), None, text.to_string()));
        }
    }
    let sw = Swatch::Box {
        colour: DELIVERY,
        height: 5.0,
    };
    entries.push((Some(sw), None, "report delivered (age reset)".into()));
    if iridium {
        for (colour, text) in [
            (SESSION_OK, "Iridium session"),
            (SESSION_FAILED, "Iridium session failed"),
        ] {
            let sw = Swatch::Box {
                colour,
                height: 5.0,
            };
            entries.push((Some(sw), None, text.into()));
        }
    }
    if let Some(sent) = links.acoustic {
        let sw = Swatch::Box {
            colour: ACOUSTIC_FRAME,
            height: 5.0,
        };
        entries.push((Some(sw), None, format!("acoustic frame sent ({sent})")));
    }
    let mut kinds = std::collections::BTreeSet::new();
    for (_, e) in vehicle_events {
        if let Some(st) = style::event_style(&e.kind) {
            if kinds.insert(e.kind.as_str()) {
                entries.push((None, Some(e.kind.as_str()), st.legend.to_string()));
            }
        }
    }
    if fleet_events {
        let sw = Swatch::Marker {
            colour: "#555555",
            dash: (4, 3),
        };
        entries.push((Some(sw), None, "fleet event (labelled above)".into()));
    }
    let max_entries = (((legend_bottom - y) / LEGEND_ROW) as usize).max(1);
    let total = entries.len();
    for (i, (swatch, kind, text)) in entries.into_iter().enumerate() {
        if i + 1 == max_entries && total > max_entries {
            return legend::more(c, (x, y), total - i);
        }
        match (swatch, kind) {
            (Some(sw), _) => legend::entry(c, (x, y), sw, &text)?,
            (None, Some(kind)) => {
                let colour = style::event_style(kind).map_or("#555555", |s| s.colour);
                vehicle_symbol(c, kind, (x + 14.0, y), 6.0, colour)?;
                c.text((x + 36.0, y + 4.5), &text, TextOpts::new(13.0))?;
            }
            (None, None) => {}
        }
        y += LEGEND_ROW;
    }
    Ok(())
}
