//! End-to-end test of the extension points: the example crate (`examples/`, a user's own
//! field and control law, no vbap crate edited) run through the in-process simulator
//! (`my_vbap sim`) and through the multi-process system (`my_vbap run`, the executable
//! started again in every role). Checks: both write the same run directory byte for byte;
//! the run is judged by the user's field; every vehicle flies the user's law (its
//! acceleration never exceeds the thrust limit, which the paper's law does), so the tracks
//! differ from those of the paper's law over the same field; `plot.svg` is drawn over the
//! user's field (its optimum star at the user's optimum), alike by both.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

use tests::*;

/// The thrust limit of the example's law (`vbap_examples::my_plugins`), length unit/s².
const U_MAX: f64 = 4.0;

/// Builds the example crate's binaries (release, once per test process); returns the
/// directory holding `my_vbap` and `my_field_only`.
fn example_bins() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = bin_dir().to_path_buf(); // builds vbap and the shipped roles too
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
        let status = Command::new(cargo)
            .current_dir(workspace())
            .args(["build", "--release", "--quiet", "-p", "vbap-examples"])
            .status()
            .expect("running cargo build");
        assert!(status.success(), "building the example failed");
        dir
    })
}

/// The paper's mission (Table I) under the name `name`, `duration` s long.
fn paper_mission(dir: &TempDir, name: &str, duration: f64) -> PathBuf {
    let text = tests::mission::shipped_renamed("paper", name)
        .replace("duration = 100.0", &format!("duration = {duration}"));
    write_mission(dir, "mission.toml", &text)
}

/// `bin sim|run mission --out out --quiet`, which must succeed.
fn run_example(bin: &str, command: &str, mission: &Path, out: &Path) {
    run_ok(
        Command::new(example_bins().join(bin))
            .arg(command)
            .arg(mission)
            .arg("--out")
            .arg(out)
            .arg("--quiet"),
    );
}

/// The largest acceleration ‖Δv‖/dt of any vehicle between two consecutive ticks of
/// `vehicles.csv` (semi-implicit Euler: exactly ‖u‖).
fn max_acceleration(run: &Path, dt: f64) -> f64 {
    let text = read(&run.join("vehicles.csv"));
    let mut last: std::collections::BTreeMap<u64, [f64; 3]> = Default::default();
    let mut max: f64 = 0.0;
    for line in text.lines().skip(1) {
        let cols: Vec<f64> = line
            .split(',')
            .map(|c| c.parse().expect("a number"))
            .collect();
        let (id, v) = (cols[2] as u64, [cols[6], cols[7], cols[8]]);
        if let Some(prev) = last.insert(id, v) {
            let dv =
                ((v[0] - prev[0]).powi(2) + (v[1] - prev[1]).powi(2) + (v[2] - prev[2]).powi(2))
                    .sqrt();
            max = max.max(dv / dt);
        }
    }
    max
}

/// Attribute `name` of an SVG element's opening tag `tag` (what follows the element's name).
fn attr<'a>(tag: &'a str, name: &str) -> Option<&'a str> {
    let start = tag.find(&format!(" {name}=\""))? + name.len() + 3;
    tag[start..].split('"').next()
}

/// Where the optimum star of a `plot.svg` stands, in the plot's length unit: the centre of
/// the first star drawn (the plot's; the legend's comes after), mapped back through the
/// axis tick labels (font size 14: the x axis's centred under it, the y axis's right
/// aligned left of it). Pixels are whole: about 1/30 of a length unit at this plot's scale.
fn optimum_on_plot(svg: &str) -> (f64, f64) {
    let (mut x_ticks, mut y_ticks) = (Vec::new(), Vec::new());
    for part in svg.split("<text").skip(1) {
        let (tag, rest) = part.split_once('>').expect("a text tag");
        let Ok(value) = rest.split("</text>").next().unwrap().trim().parse::<f64>() else {
            continue;
        };
        if attr(tag, "font-size") != Some("14") {
            continue;
        }
        let px = |a: &str| -> f64 { attr(tag, a).unwrap().parse().unwrap() };
        match attr(tag, "text-anchor") {
            Some("middle") => x_ticks.push((px("x"), value)),
            Some("end") => y_ticks.push((px("y"), value)),
            _ => {}
        }
    }
    assert!(
        x_ticks.len() >= 2 && y_ticks.len() >= 2,
        "axis ticks in plot.svg"
    );
    let map = |ticks: &[(f64, f64)], p: f64| {
        let ((p0, v0), (p1, v1)) = (ticks[0], ticks[ticks.len() - 1]);
        v0 + (p - p0) * (v1 - v0) / (p1 - p0)
    };
    let star = svg
        .split("<polygon")
        .skip(1)
        .map(|p| p.split_once("/>").expect("a polygon").0)
        .find(|tag| attr(tag, "fill") == Some("#E41A1C"))
        .expect("the optimum star in plot.svg");
    let vertices: Vec<(f64, f64)> = attr(star, "points")
        .unwrap()
        .split_whitespace()
        .map(|xy| {
            let (x, y) = xy.split_once(',').unwrap();
            (x.parse().unwrap(), y.parse().unwrap())
        })
        .collect();
    assert_eq!(vertices.len(), 10, "a five-pointed star");
    let n = vertices.len() as f64;
    let cx = vertices.iter().map(|v| v.0).sum::<f64>() / n;
    let cy = vertices.iter().map(|v| v.1).sum::<f64>() / n;
    (map(&x_ticks, cx), map(&y_ticks, cy))
}

#[test]
fn a_users_field_and_law_run_alike_in_process_and_as_processes() {
    let tmp = TempDir::new("examples");
    let name = unique_name("ex");
    let mission = paper_mission(&tmp, &name, 30.0);
    let (sim, run) = (tmp.join("sim"), tmp.join("run"));
    run_example("my_vbap", "sim", &mission, &sim);
    run_example("my_vbap", "run", &mission, &run);

    // (a) == (b), byte for byte.
    assert_same_tracks(&sim, &run);
    assert_eq!(
        read(&sim.join("planner_inputs.csv")),
        read(&run.join("planner_inputs.csv"))
    );
    let (s_sim, s_run) = (summary(&sim), summary(&run));
    for key in ["verdict", "optimum", "final_body_position", "max_V_over_VU"] {
        assert_eq!(s_sim[key], s_run[key], "summary.json {key}");
    }
    assert!(
        leftover_files(&name).is_empty(),
        "iceoryx2 files left behind"
    );

    // Judged by the user's field: its bottom (18, 12), not the mission's quadratic (20, 10).
    assert_eq!(s_sim["optimum"], serde_json::json!([18.0, 12.0, 0.0]));
    // The body's true gradient in body.csv is the user's: at the start (0, 0) the log
    // bowl's ∇T = A d / (w² (1 + q)), q = ½‖d‖²/w², with d = (−18, −12), w = 4, A = 10.
    let body = read(&sim.join("body.csv"));
    let first: Vec<&str> = body
        .lines()
        .nth(1)
        .expect("a first row")
        .split(',')
        .collect();
    let q = 0.5 * (18.0f64 * 18.0 + 12.0 * 12.0) / 16.0;
    let expected = 10.0 * -18.0 / (16.0 * (1.0 + q));
    let true_grad_x: f64 = first[14].parse().unwrap();
    assert!(
        (true_grad_x - expected).abs() <= 1e-12 * expected.abs(),
        "true_grad_x {true_grad_x}, the log bowl's {expected}"
    );

    // plot.svg is drawn over the user's field, by both: its optimum star stands at the log
    // bowl's bottom (18, 12), not at the mission's quadratic's centre (20, 10).
    let plot = read(&sim.join("plot.svg"));
    assert_eq!(plot, read(&run.join("plot.svg")), "plot.svg of sim and run");
    let (ox, oy) = optimum_on_plot(&plot);
    assert!(
        (ox - 18.0).abs() < 0.15 && (oy - 12.0).abs() < 0.15,
        "the plot's optimum at ({ox}, {oy}), the user's field's at (18, 12)"
    );

    // Flown by the user's law: never more than U_MAX, in both runs; the paper's law over
    // the same field asks for more, and its tracks differ.
    let dt = 0.05;
    for dir in [&sim, &run] {
        let a = max_acceleration(dir, dt);
        assert!(
            a <= U_MAX * (1.0 + 1e-9),
            "{}: ‖u‖ up to {a}",
            dir.display()
        );
    }
    let paper = tmp.join("paper_law");
    run_example("my_field_only", "sim", &mission, &paper);
    let a = max_acceleration(&paper, dt);
    assert!(a > 1.5 * U_MAX, "the paper's law peaks at {a}");
    assert_ne!(
        read(&paper.join("vehicles.csv")),
        read(&sim.join("vehicles.csv")),
        "the user's law changed nothing"
    );
    assert_eq!(summary(&paper)["optimum"], s_sim["optimum"], "same field");
}

#[test]
fn a_custom_vbap_refuses_what_it_cannot_plug_into() {
    // replay, batch, chaos and bench run the shipped parts: a custom binary says so, exit 2.
    let out = Command::new(example_bins().join("my_vbap"))
        .args(["replay", "/nonexistent"])
        .output()
        .expect("spawning my_vbap");
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("use `vbap`"));
}
