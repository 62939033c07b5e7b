//! Renders demonstration plots: /tmp/plot_demo.svg (a Gaussian field, four vehicles
//! spiralling in towards its peak), /tmp/plot_demo_ts.svg (two stacked panel charts with
//! event markers, drawn like a run's time series) and /tmp/plot_demo_crowded.svg (24 vehicles,
//! non-dimensional, a field with a hole).
//!
//! `cargo run --release -p vbap-report --example plot_demo`

use vbap_report::plot::chart::{self, Axis, Figure, Panel, Series};
use vbap_report::plot::style::{self, TimeUnit};
use vbap_report::plot::{write_mission_svg, MissionPlot, Snapshot, Track};
use vbap_wire::rundir::Event;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let (ox, oy) = (120.0, 80.0);
    let field = move |x: f64, y: f64| {
        12.0 + 8.0 * (-((x - ox).powi(2) + (y - oy).powi(2)) / (2.0 * 90.0_f64.powi(2))).exp()
    };
    let n = 3000;
    let dt = 0.2;
    let start = (-150.0, -60.0);
    let centre_at = |s: f64| {
        // The body centre moves from `start` to the optimum along a gentle curve.
        let e = 1.0 - (-4.0 * s).exp();
        (
            start.0 + (ox - start.0) * e,
            start.1 + (oy - start.1) * e + 40.0 * (std::f64::consts::PI * e).sin(),
        )
    };
    let tracks: Vec<Track> = (0..4u32)
        .map(|id| {
            let phase = f64::from(id) * std::f64::consts::FRAC_PI_2;
            let points = (0..n)
                .map(|k| {
                    let s = k as f64 / (n - 1) as f64;
                    let (cx, cy) = centre_at(s);
                    let r = 25.0 + 20.0 * (1.0 - s);
                    let a = phase + 5.0 * s;
                    (cx + r * a.cos(), cy + r * a.sin())
                })
                .collect();
            Track { id, points }
        })
        .collect();
    let body_path = (0..n)
        .map(|k| centre_at(k as f64 / (n - 1) as f64))
        .collect();
    let snapshots = [0, n / 4, n / 2, n - 1]
        .iter()
        .map(|&k| Snapshot {
            t: k as f64 * dt,
            label: if k == n / 2 {
                "lost 2, redesign".into()
            } else {
                String::new()
            },
            positions: tracks.iter().map(|t| t.points[k]).collect(),
            centre: centre_at(k as f64 / (n - 1) as f64),
        })
        .collect();
    let kill_k = 900;
    let rejoin_k = 1300;
    let events = vec![
        (
            tracks[2].points[kill_k].0,
            tracks[2].points[kill_k].1,
            format!("vehicle 2 killed (t = {:.0} s)", kill_k as f64 * dt),
        ),
        (
            tracks[2].points[rejoin_k].0,
            tracks[2].points[rejoin_k].1,
            format!("vehicle 2 rejoined (t = {:.0} s)", rejoin_k as f64 * dt),
        ),
    ];
    let plot = MissionPlot {
        title: "Demo mission: 4 gliders climbing a Gaussian temperature field".into(),
        length_unit: "m".into(),
        field: &field,
        field_label: "T (°C)".into(),
        tracks,
        body_path,
        snapshots,
        optimum: Some((ox, oy)),
        events,
        geographic: None,
        current: None,
    };
    write_mission_svg(&plot, std::path::Path::new("/tmp/plot_demo.svg"))?;

    let fig = timeseries_figure(n, dt, kill_k, rejoin_k);
    chart::write_svg(&fig, std::path::Path::new("/tmp/plot_demo_ts.svg"))?;
    println!("wrote /tmp/plot_demo.svg and /tmp/plot_demo_ts.svg");

    crowded_plot()?;
    println!("wrote /tmp/plot_demo_crowded.svg");
    Ok(())
}

/// A crowded, non-dimensional variant: 24 vehicles and a field undefined on part of the plane.
fn crowded_plot() -> Result<(), Box<dyn std::error::Error>> {
    let holey = |x: f64, y: f64| {
        if x > 1.5 && y < -1.0 {
            f64::NAN
        } else {
            (x * 1.3).sin() * (y * 0.9).cos() + 0.2 * x
        }
    };
    let tracks: Vec<Track> = (0..24u32)
        .map(|id| {
            let a0 = f64::from(id) / 24.0 * std::f64::consts::TAU;
            let points = (0..200)
                .map(|k| {
                    let s = f64::from(k) / 199.0;
                    let r = 3.0 - 2.0 * s;
                    (r * (a0 + s).cos(), r * (a0 + s).sin())
                })
                .collect();
            Track { id, points }
        })
        .collect();
    let crowded = MissionPlot {
        title: "Crowded: 24 vehicles, non-dimensional".into(),
        length_unit: String::new(),
        field: &holey,
        field_label: "f".into(),
        snapshots: vec![Snapshot {
            t: 12.5,
            label: String::new(),
            positions: tracks.iter().map(|t| t.points[100]).collect(),
            centre: (0.0, 0.0),
        }],
        tracks,
        body_path: vec![(0.0, 0.0), (0.1, 0.1)],
        optimum: None,
        events: vec![
            (1.0, 1.0, "kill 3".into()),
            (1.05, 1.0, "kill 4".into()),
            (1.0, 1.05, "kill 5".into()),
        ],
        geographic: None,
        current: None,
    };
    write_mission_svg(&crowded, std::path::Path::new("/tmp/plot_demo_crowded.svg"))?;
    Ok(())
}

/// The demo's time series as a run's are drawn: V/V_U and the speed over mission time in
/// stacked panels, with the vehicle-2 loss and rejoin as event markers.
fn timeseries_figure(n: usize, dt: f64, kill_k: usize, rejoin_k: usize) -> Figure {
    let last_t = (n - 1) as f64 * dt;
    let unit = TimeUnit::for_span(last_t);
    let curve = |f: &dyn Fn(f64) -> f64| -> Vec<(f64, f64)> {
        (0..n)
            .map(|k| k as f64 * dt)
            .map(|t| (unit.of(t), f(t)))
            .collect()
    };
    let time_axis = |label: bool| Axis {
        label: if label {
            unit.axis_label("mission time t")
        } else {
            String::new()
        },
        range: Some((0.0, unit.of(last_t))),
        time: Some(unit),
        ..Axis::default()
    };
    let event = |k: usize, kind: &str| Event {
        t: k as f64 * dt,
        k: k as u64,
        kind: kind.into(),
        vehicle: Some(2),
        detail: serde_json::Value::Null,
    };
    let markers = chart::event_markers(&[event(kill_k, "lost"), event(rejoin_k, "rejoin")], unit);
    let mut v = Panel::new(
        "Lyapunov ratio",
        time_axis(false),
        Axis {
            label: "V/V_{U}".into(),
            from_zero: true,
            ..Axis::default()
        },
    );
    v.series.push(Series::line(
        "V/V_{U}",
        curve(&|t| 0.9 * (-t / 150.0).exp() + 0.05 * (t / 20.0).sin().abs()),
        style::palette(0),
    ));
    let mut speed = Panel::new(
        "Speed of the virtual body",
        time_axis(true),
        Axis {
            label: "speed (m/s)".into(),
            from_zero: true,
            ..Axis::default()
        },
    );
    speed.series.push(Series::line(
        "speed",
        curve(&|t| 0.6 * (-t / 300.0).exp()),
        style::palette(1),
    ));
    let mut fig = Figure {
        title: "Demo: Lyapunov ratio and speed".into(),
        subtitle: format!("4 vehicles, {n} ticks of {}", style::fmt_duration(dt)),
        panels: vec![v, speed],
    };
    for p in &mut fig.panels {
        p.markers = markers.clone();
    }
    fig
}
