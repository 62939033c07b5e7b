//! End-to-end tests of the pictures of a run directory, written by the real `vbap sim`:
//! the contact timeline, formation snapshots at events and readable time labels; and of
//! `vbap analyze` refusing a directory without message records.

use std::path::Path;

use tests::mission::GaussianHill;
use tests::*;

/// Vehicles of the mission below.
const N: usize = 5;

/// A short mission with a surfacing schedule, a link outage and a kill with a restart.
fn mission(name: &str) -> String {
    // Stiff on purpose; stable at its smallest scale (omega dt < 2).
    GaussianHill::stiff(name, "min_scale = 0.6\n")
        .seed(11)
        .count(N)
        .then(
            r#"
[links]
delay = 0.2
loss = 0.05
surfacing_period = 4.0
surfacing_window = 1.0

[restart]
vehicles = "on-failure"

[control]
law = "paper"  # the events these pictures label are those of the paper's law

[[faults]]
kind = "kill"
vehicle = 2
at = 5.0
until = 10.0

[[faults]]
kind = "link_down"
vehicle = 1
at = 3.0
until = 6.0
"#,
        )
        .toml()
}

/// The text of an SVG file that starts with `<svg` and ends with `</svg>`, one of each.
fn svg(dir: &Path, file: &str) -> String {
    let text = read(&dir.join(file));
    assert!(
        text.starts_with("<svg"),
        "{file} starts with {:?}",
        &text[..text.len().min(40)]
    );
    assert!(text.trim_end().ends_with("</svg>"), "{file} is not closed");
    assert_eq!(text.matches("<svg").count(), 1, "{file}");
    assert_eq!(text.matches("</svg>").count(), 1, "{file}");
    text
}

#[test]
fn sim_draws_event_snapshots_contact_timeline_and_readable_times() {
    let tmp = TempDir::new("pictures");
    let name = unique_name("pictures");
    let file = write_mission(&tmp, "m.toml", &mission(&name));
    let out = tmp.join("sim");
    vbap_quiet("sim", &file, &out);

    // plot.svg: the evenly spaced snapshots and those at the loss and the rejoin of
    // vehicle 2, labelled with their time (s for a 20 s mission) and the events.
    let plot = svg(&out, "plot.svg");
    assert!(plot.contains("t = 0 s"), "first snapshot");
    assert!(
        plot.contains("t = 5 s: lost 2, redesign"),
        "snapshot at the loss"
    );
    assert!(
        plot.contains("t = 10 s: rejoin 2, redesign"),
        "snapshot at the rejoin"
    );
    assert!(plot.contains("formation at an event"), "legend");

    // The time series: seconds, the events marked and labelled.
    let formation = svg(&out, "timeseries_formation.svg");
    assert!(formation.contains("mission time t (s)"));
    for label in ["kill 2, lost 2, redesign", "link_down 1", "rejoin 2"] {
        assert!(formation.contains(label), "marker {label:?}");
    }
    svg(&out, "timeseries_estimate.svg");

    // The contact timeline is drawn from formation.csv: one row per vehicle, the states of
    // this mission in the legend.
    assert!(
        out.join("formation.csv").exists(),
        "vbap sim writes formation.csv"
    );
    let contact = svg(&out, "contact.svg");
    for id in 0..N {
        assert_eq!(
            contact.matches(&format!("\nvehicle {id}\n</text>")).count(),
            1,
            "one row label for vehicle {id}"
        );
    }
    for state in [
        "surfaced (can talk)",
        "submerged (cannot talk)",
        "link down (fault)",
        "dead / lost",
        "report delivered",
    ] {
        assert!(
            contact.contains(state),
            "contact.svg legend lacks {state:?}"
        );
    }
    assert!(contact.contains("mission time t (s)"));
    assert!(formation.contains("slot error ÷ spacing"));

    // `vbap analyze` on a simulator's run: no message records, exit 2, says what is missing,
    // writes no empty plot.
    let a = vbap().arg("analyze").arg(&out).output().unwrap();
    let stderr = String::from_utf8_lossy(&a.stderr);
    assert_eq!(a.status.code(), Some(2), "stderr: {stderr}");
    assert!(
        stderr.contains("no message records") && stderr.contains(".msgs.csv"),
        "{stderr}"
    );
    assert!(a.stdout.is_empty(), "no table printed");
    assert!(!out.join("latency.svg").exists() && !out.join("loops.svg").exists());
}

#[test]
fn analyze_names_what_is_missing() {
    let tmp = TempDir::new("analyze_missing");
    // Not a run directory at all.
    let a = vbap()
        .arg("analyze")
        .arg(tmp.join("nothing"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&a.stderr);
    assert_eq!(a.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("not a run directory"), "{stderr}");
    // A run directory whose logs hold tracing lines but no message record.
    let dir = tmp.join("run");
    std::fs::create_dir_all(dir.join("logs")).unwrap();
    std::fs::write(dir.join("mission.toml"), "").unwrap();
    std::fs::write(
        dir.join("logs/coordinator.jsonl"),
        "{\"target\":\"coordinator\",\"fields\":{\"message\":\"started\"}}\n",
    )
    .unwrap();
    let a = vbap()
        .arg("analyze")
        .arg(&dir)
        .arg("--json")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&a.stderr);
    assert_eq!(a.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("no message records"), "{stderr}");
    assert!(
        stderr.contains(&dir.display().to_string()),
        "names the directory: {stderr}"
    );
    assert!(a.stdout.is_empty(), "no JSON printed");
}
