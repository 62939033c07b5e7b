//! The truth panels: slot errors and the nearest pair (in `timeseries_formation.svg`), the
//! age of the coordinator's information (in `contact.svg`).

use crate::plot::chart::{event_markers, Axis, Panel, RefLine, Series};
use crate::plot::style::{self, TimeUnit};
use vbap_mission::config::Mission;
use vbap_wire::rundir::Event;

use super::{Formation, Lane, Truth, MAX_SAWTEETH, MAX_VEHICLE_LINES};

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

/// The age of the coordinator's newest information per vehicle (the worst only beyond
/// [`MAX_VEHICLE_LINES`] vehicles), in `age_unit`, against the surfacing period.
pub(super) fn age_panel(
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
    p.markers = event_markers(events, unit);
    p
}
