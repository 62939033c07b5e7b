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
        geographic: None,
        current: None,
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
        geographic: None,
        current: None,
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
