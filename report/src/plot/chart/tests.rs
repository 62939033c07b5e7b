use super::panel::{clip_run, pixel_runs};
use super::ticks::{fmt_log, linear_ticks, log_ticks, Scale};
use super::*;
use crate::plot::style::PALETTE;

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
fn a_log_axis_breaks_the_line_at_non_positive_values() {
    let s = Series::line(
        "s",
        vec![(0.0, 1.0), (1.0, 10.0), (2.0, 0.0), (3.0, 5.0), (4.0, 2.0)],
        PALETTE[0],
    );
    let xs = Scale {
        lo: 0.0,
        hi: 4.0,
        log: false,
        p0: 0.0,
        p1: 400.0,
    };
    let ys = Scale {
        lo: 0.5,
        hi: 20.0,
        log: true,
        p0: 200.0,
        p1: 0.0,
    };
    let runs = pixel_runs(&s, &xs, &ys);
    assert_eq!(runs.len(), 2, "{runs:?}");
    assert_eq!(runs[0].len(), 2);
    assert_eq!(runs[1].len(), 2);
}

#[test]
fn clipping_keeps_the_inside_and_cuts_at_the_edges() {
    let rect = (0.0, 0.0, 10.0, 10.0);
    // In, out through the right edge, back in: two pieces, cut at x = 10.
    let run = [(2.0, 5.0), (8.0, 5.0), (14.0, 5.0), (8.0, 6.0), (4.0, 6.0)];
    let pieces = clip_run(&run, rect);
    assert_eq!(pieces.len(), 2, "{pieces:?}");
    assert_eq!(pieces[0], vec![(2.0, 5.0), (8.0, 5.0), (10.0, 5.0)]);
    assert!((pieces[1][0].0 - 10.0).abs() < 1e-12, "{pieces:?}");
    assert_eq!(*pieces[1].last().unwrap(), (4.0, 6.0));
    // Entirely outside: nothing.
    assert!(clip_run(&[(20.0, 1.0), (30.0, 2.0)], rect).is_empty());
}

#[test]
fn figures_are_deterministic_and_show_titles_series_and_legends() {
    let mut panel = Panel::new(
        "Panel title",
        Axis {
            label: "time (s)".into(),
            ..Axis::default()
        },
        Axis {
            label: "V/V_{U}".into(),
            log: true,
            ..Axis::default()
        },
    );
    panel.series.push(Series::line(
        "series one",
        (0..50).map(|i| (i as f64, 1.0 + i as f64)).collect(),
        PALETTE[0],
    ));
    panel.hlines.push(RefLine {
        y: 10.0,
        label: "bound".into(),
        colour: "#555555",
    });
    panel.markers.push(Marker {
        x: 20.0,
        label: "lost 2".into(),
        colour: "#d62728",
        legend: "vehicle lost".into(),
    });
    let fig = Figure {
        title: "Figure title".into(),
        subtitle: "context".into(),
        panels: vec![panel, Panel::new("Empty", Axis::default(), Axis::default())],
    };
    let a = render_svg(&fig).unwrap();
    assert_eq!(a, render_svg(&fig).unwrap());
    for text in [
        "Figure title",
        "context",
        "Panel title",
        "series one",
        "bound",
        "lost 2",
        "vehicle lost",
        "V/V_U",
        "time (s)",
        "no data",
    ] {
        assert!(a.contains(text), "{text} missing");
    }
}

/// The cases the viewer's `view/assets/ticks.js` is tested on too (`ticks_cases.json`): the
/// same ranges give the same ticks and labels in the report and in the browser.
#[test]
fn ticks_match_the_cases_shared_with_the_viewer() {
    let cases: serde_json::Value =
        serde_json::from_str(include_str!("ticks_cases.json")).expect("ticks_cases.json");
    let cases = cases["cases"].as_array().expect("cases");
    assert!(cases.len() >= 10);
    for c in cases {
        let (lo, hi) = (c["lo"].as_f64().unwrap(), c["hi"].as_f64().unwrap());
        let target = c["target"].as_u64().unwrap() as usize;
        let (ticks, step, unit) = if c["time"].as_bool().unwrap() {
            let unit = TimeUnit::for_span(hi - lo);
            let (t, step) = linear_ticks(unit.of(lo), unit.of(hi), target, false, Some(unit));
            (t, step, unit.symbol)
        } else {
            let (t, step) = linear_ticks(lo, hi, target, false, None);
            (t, step, "")
        };
        let labels: Vec<String> = ticks.iter().map(|v| style::fmt_tick(*v, step)).collect();
        let want: Vec<&str> = c["labels"]
            .as_array()
            .unwrap()
            .iter()
            .map(|l| l.as_str().unwrap())
            .collect();
        assert_eq!(labels, want, "case {c}");
        assert_eq!(unit, c["unit"].as_str().unwrap_or(""), "case {c}");
        let mut distinct = labels.clone();
        distinct.dedup();
        assert_eq!(distinct.len(), labels.len(), "two ticks read the same: {c}");
    }
}

/// A time axis without its label (a panel above the last) carries its unit on its last tick.
#[test]
fn an_unlabelled_time_axis_says_its_unit() {
    let scale = Scale {
        lo: 0.0,
        hi: 11.11,
        log: false,
        p0: 0.0,
        p1: 100.0,
    };
    let axis = Axis {
        time: Some(TimeUnit::H),
        ..Axis::default()
    };
    let labels: Vec<String> = scale
        .ticks(&axis, 6)
        .into_iter()
        .filter_map(|(_, l, _)| l)
        .collect();
    assert_eq!(labels, ["0", "2", "4", "6", "8", "10 h"]);
    let labelled = Axis {
        label: "mission time t (h)".into(),
        ..axis
    };
    assert_eq!(
        scale.ticks(&labelled, 6).last().unwrap().1.as_deref(),
        Some("10")
    );
}
