//! End-to-end tests of the multi-process system: they start the real binaries.

use std::time::Duration;

use tests::columns::Table;
use tests::mission::GaussianHill;
use tests::*;

fn mission_2d(name: &str, n: usize, duration: f64, pace: &str) -> String {
    GaussianHill::new(name)
        .count(n)
        .duration(duration)
        .pace(pace)
        .toml()
}

fn mission_3d(name: &str, duration: f64) -> String {
    format!(
        r#"
[mission]
name = "{name}"
seed = 3
duration = {duration}
dt = 0.05
goal = "min"
dim = 3

[field]
kind = "quadratic"
center = [3.0, -2.0, 1.0]
hessian = [[1.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 1.0]]
noise_std = 0.05

[vehicles]
count = 4
start = [0.0, 0.0, 0.0]
"#
    )
}

/// A glider mission (issue 14): speed-limited gliders carried by a current they do not
/// know, dead-reckoning between surfacings, along a coast.
fn mission_glider(name: &str) -> String {
    format!(
        r#"{}
model = "glider"
max_speed = 0.9
max_accel = 4.0
max_turn_rate = 3.0

[links]
surfacing_period = 2.0
surfacing_window = 0.5
surfacing_phase = "staggered"

[current]
kind = "eddy"
velocity = [0.3, -0.1]
center = [3.0, 2.0]
width = 3.0
strength = 0.3

[land]
kind = "coast"
point = [0.0, -1.5]
normal = [0.0, 1.0]
"#,
        mission_2d(name, 5, 8.0, "\"lockstep\"")
    )
}

/// The largest speed through the water in `vehicles.csv` of `dir` (columns wx, wy, wz),
/// and the smallest true y.
fn water_speeds(dir: &std::path::Path) -> (f64, f64) {
    let t = Table::read(&dir.join("vehicles.csv"));
    let mut fastest = 0.0f64;
    let mut lowest = f64::INFINITY;
    for r in t.rows() {
        let w = (r.num("wx").powi(2) + r.num("wy").powi(2) + r.num("wz").powi(2)).sqrt();
        fastest = fastest.max(w);
        lowest = lowest.min(r.num("y"));
    }
    (fastest, lowest)
}

#[test]
fn lockstep_equals_in_process_gliders_in_a_current() {
    let tmp = assert_run_equals_sim(&mission_glider(&unique_name("eqgl")));
    for run in ["sim", "run"] {
        let (fastest, lowest) = water_speeds(&tmp.join(run));
        // 1e-12: the CSV holds each component exactly; the norm is recomputed here.
        assert!(
            fastest <= 0.9 * (1.0 + 1e-12),
            "{run}: a glider went {fastest} through the water (max_speed 0.9)"
        );
        assert!(
            fastest > 0.75,
            "{run}: the gliders never went fast ({fastest})"
        );
        assert!(lowest >= -1.5, "{run}: a glider went ashore (y = {lowest})");
        assert!(
            lowest < -1.3,
            "{run}: no glider came near the coast ({lowest})"
        );
    }
    // Dead reckoning in a current: the believed positions drift from the truth.
    let t = Table::read(&tmp.join("sim").join("vehicles.csv"));
    let drift = t
        .rows()
        .map(|r| ((r.num("x") - r.num("bx")).powi(2) + (r.num("y") - r.num("by")).powi(2)).sqrt())
        .fold(0.0f64, f64::max);
    assert!(drift > 0.05, "beliefs never drifted ({drift})");
}

/// A 3-D glider mission whose gliders fly a sawtooth dive (`vehicles.dive_depth`): the
/// shipped quadratic3d.toml, shortened, with gliders diving to z = −3 at 0.5 L/s (at the
/// surface every 12 s) in a uniform current they do not know and do not estimate (with
/// the estimate, started from the surface drift, a uniform current leaves no error to see).
fn mission_diving(name: &str) -> String {
    let base = std::fs::read_to_string(workspace().join("deploy/missions/quadratic3d.toml"))
        .expect("quadratic3d.toml");
    let text = base
        .replacen("name = \"quadratic3d\"", &format!("name = \"{name}\""), 1)
        .replacen("duration = 150.0", "duration = 30.0", 1)
        .replacen(
            "damping = 5.0",
            "damping = 5.0\nmodel = \"glider\"\nmax_speed = 2.0\nmax_accel = 4.0\n\
             max_turn_rate = 3.0\ndive_depth = -3.0\ndive_rate = 0.5\ncurrent_estimate = false",
            1,
        );
    format!("{text}\n[current]\nkind = \"uniform\"\nvelocity = [0.2, 0.1, 0.0]\n")
}

#[test]
fn lockstep_equals_in_process_diving_gliders() {
    let tmp = assert_run_equals_sim(&mission_diving(&unique_name("eqdv")));
    let t = Table::read(&tmp.join("sim").join("vehicles.csv"));
    let (mut deepest, mut fastest, mut drift) = (0.0f64, 0.0f64, 0.0f64);
    let mut surfaced = 0;
    for r in t.rows() {
        let z = r.num("z");
        assert!((-3.0 - 1e-9..=1e-9).contains(&z), "z = {z} off the dive");
        assert_eq!(z, r.num("bz"), "the depth is known");
        deepest = deepest.min(z);
        let w = (r.num("wx").powi(2) + r.num("wy").powi(2) + r.num("wz").powi(2)).sqrt();
        fastest = fastest.max(w);
        let off = (r.num("x") - r.num("bx")).hypot(r.num("y") - r.num("by"));
        if r.num("k") > 0.0 && z.abs() < 1e-9 {
            surfaced += 1;
            assert_eq!(off, 0.0, "a glider at the surface has its fix");
        }
        drift = drift.max(off);
    }
    assert!(deepest < -2.9, "the gliders never dived ({deepest})");
    assert!(
        surfaced >= 8,
        "{surfaced} ticks at the surface (4 gliders, t = 12 and 24 s)"
    );
    assert!(
        drift > 0.1,
        "under water the beliefs never drifted ({drift})"
    );
    assert!(
        fastest <= 2.0 * (1.0 + 1e-12),
        "{fastest} through the water (max 2.0)"
    );
}

/// The shipped dive3d.toml (gliders diving in a 3-D bowl, a current they estimate): the
/// formation is horizontal, the run equals the simulator byte for byte, and it converges
/// (the body within tolerance of the point above the optimum, every glider in its slot)
/// while every glider follows the dive.
#[test]
fn lockstep_equals_in_process_dive3d_and_converges() {
    let base = std::fs::read_to_string(workspace().join("deploy/missions/dive3d.toml"))
        .expect("dive3d.toml");
    let name = unique_name("eqd3");
    let text = base.replacen("name = \"dive3d\"", &format!("name = \"{name}\""), 1);
    let tmp = assert_run_equals_sim(&text);
    let s = summary(&tmp.join("run"));
    assert_eq!(s["verdict"], "converged", "{}", s["reasons"]);
    let t = Table::read(&tmp.join("run").join("vehicles.csv"));
    let deepest = t.rows().map(|r| r.num("z")).fold(0.0f64, f64::min);
    assert!(deepest < -2.9, "the gliders never dived ({deepest})");
    let body = Table::read(&tmp.join("run").join("body.csv"));
    assert!(
        body.rows().all(|r| r.num("rz") == 0.0),
        "the body stays in the plane"
    );
}

/// `vbap sim` and `vbap run` of the same mission write byte-identical tracks; returns the
/// directory holding both runs (`sim/`, `run/`).
fn assert_run_equals_sim(text: &str) -> TempDir {
    let tmp = TempDir::new("eq");
    let file = write_mission(&tmp, "m.toml", text);
    vbap_quiet("sim", &file, &tmp.join("sim"));
    let out = run_ok(
        vbap()
            .arg("run")
            .arg(&file)
            .arg("--out")
            .arg(tmp.join("run"))
            .arg("--quiet")
            .arg("--json"),
    );
    let printed: serde_json::Value =
        serde_json::from_slice(&out.stdout).expect("vbap run --json prints the summary as JSON");
    assert_eq!(printed["mode"], "multi-process");
    assert_same_tracks(&tmp.join("sim"), &tmp.join("run"));
    let s = summary(&tmp.join("run"));
    assert_eq!(s["messages"]["rejected"], 0);
    assert!(s["messages"]["delivered"].as_u64().unwrap() > 0);
    for hop in ["state", "body", "field_request", "field_reply"] {
        assert!(
            s["latency_us"][hop]["p50"].as_f64().unwrap() > 0.0,
            "latency of hop {hop} recorded"
        );
    }
    let name: toml::Value = toml::from_str(text).unwrap();
    let name = name["mission"]["name"].as_str().unwrap().to_string();
    assert!(
        leftover_files(&name).is_empty(),
        "shared memory left behind: {:?}",
        leftover_files(&name)
    );
    assert!(
        processes_mentioning(&tmp.path.to_string_lossy()).is_empty(),
        "processes left behind"
    );
    tmp
}

#[test]
fn lockstep_equals_in_process_n4_2d() {
    assert_run_equals_sim(&mission_2d(&unique_name("eq4"), 4, 10.0, "\"lockstep\""));
}

#[test]
fn lockstep_equals_in_process_n7_2d() {
    assert_run_equals_sim(&mission_2d(&unique_name("eq7"), 7, 8.0, "\"lockstep\""));
}

#[test]
fn lockstep_equals_in_process_3d() {
    assert_run_equals_sim(&mission_3d(&unique_name("eq3d"), 8.0));
}

/// Positions told at a resolution of 0.002 (`links.position_quantum`): `vbap run` still
/// equals `vbap sim` byte for byte, the vehicles fly on the rounded values (the tracks
/// differ from the exact run's), and the sizes each agent recorded for the commands it was
/// told are those the coordinator counted in the summary.
#[test]
fn lockstep_equals_in_process_with_quantised_commands_whose_sizes_agree() {
    let name = unique_name("eqq");
    let exact = mission_2d(&name, 7, 6.0, "\"lockstep\"");
    let text = format!("{exact}\n[links]\nposition_quantum = 0.002\n");
    let tmp = assert_run_equals_sim(&text);
    let run = tmp.join("run");
    let exact_dir = TempDir::new("eqq_exact");
    let file = write_mission(&exact_dir, "m.toml", &exact);
    vbap_quiet("sim", &file, &exact_dir.join("sim"));
    assert_ne!(
        read(&run.join("vehicles.csv")),
        read(&exact_dir.join("sim").join("vehicles.csv")),
        "the rounded positions change the flight"
    );
    let s = summary(&run);
    let counted = &s["link_bytes"];
    let mut recorded: Vec<u64> = Vec::new();
    for id in 0..7 {
        let records = msg_records(&run, &format!("vehicle_agent_{id}"));
        recorded.extend(
            records
                .iter()
                .filter(|r| r.hop == "body")
                .filter_map(|r| r.bytes),
        );
    }
    assert!(
        !recorded.is_empty(),
        "the agents record the sizes of their commands"
    );
    assert_eq!(
        recorded.iter().max().copied(),
        counted["command_max_b"].as_u64(),
        "the largest command: recorded by the agents, counted by the coordinator"
    );
    let mean = recorded.iter().sum::<u64>() as f64 / recorded.len() as f64;
    let counted_mean = counted["command_mean_b"].as_f64().unwrap();
    assert!(
        (mean - counted_mean).abs() <= 0.01 * counted_mean,
        "mean command: {mean} B recorded, {counted_mean} B counted"
    );
    // Quantised: 12 bytes a vector; 7 vehicles in a ring of which each hears a few.
    assert!(counted_mean < 600.0, "{counted_mean} B");
    assert_eq!(counted["report_b"].as_u64(), Some(68));
    let states = msg_records(&run, "coordinator");
    assert!(states
        .iter()
        .filter(|r| r.hop == "state")
        .all(|r| r.bytes == Some(68)));
}

/// The shipped Iridium mission (`glider_iridium.toml`, cut to 4 h: two surfacings each), once as shipped and
/// once with a down limit below its commands' size and `oversize = "refuse"`: `vbap run`
/// equals `vbap sim` byte for byte; commands cross only in sessions (the shore keeps the
/// newest: the others are dropped as `superseded`, never delivered), and a command over
/// the limit is refused and counted, never cut.
#[test]
fn lockstep_equals_in_process_over_iridium_sessions() {
    let shipped = read(&workspace().join("deploy/missions/glider_iridium.toml"));
    for (tag, extra) in [
        ("as shipped", ""),
        ("refusing", "refuse"),
        ("kill and restart", "kill"),
    ] {
        let name = unique_name("eqiri");
        let mut text = shipped
            .replace("name = \"glider_iridium\"", &format!("name = \"{name}\""))
            .replace("duration = 259200.0", "duration = 14400.0");
        if extra == "refuse" {
            text = text
                .replace("down_limit = 1890", "down_limit = 900")
                .replace("oversize = \"split\"", "oversize = \"refuse\"");
        }
        if extra == "kill" {
            // Glider 2 dies with reports queued under water and commands unread, and
            // comes back an hour later asking to join.
            text += "\n[restart]\nvehicles = \"on-failure\"\n\n[[faults]]\nkind = \"kill\"\n\
                     vehicle = 2\nat = 3600.0\nuntil = 7200.0\n";
        }
        let tmp = assert_run_equals_sim(&text);
        let run = tmp.join("run");
        let s = summary(&run);
        assert_eq!(
            s["messages"],
            summary(&tmp.join("sim"))["messages"],
            "{tag}: the run's message counts are the simulator's"
        );
        let bytes = &s["link_bytes"];
        let iridium = &bytes["iridium"];
        assert!(iridium["sessions"].as_u64().unwrap() > 0, "{tag}: {bytes}");
        let mut reasons: std::collections::BTreeMap<String, usize> = Default::default();
        let mut delivered_sizes = Vec::new();
        for id in 0..6 {
            for r in msg_records(&run, &format!("vehicle_agent_{id}")) {
                if r.hop != "body" {
                    continue;
                }
                if let Some(reason) = &r.reason {
                    *reasons.entry(reason.clone()).or_default() += 1;
                }
                delivered_sizes.extend(r.bytes);
            }
        }
        assert!(
            reasons.get("superseded").copied().unwrap_or(0) > 0,
            "{tag}: {reasons:?}"
        );
        if extra == "refuse" {
            let over = iridium["commands_over_limit"].as_u64().unwrap();
            assert!(over > 0, "{tag}: {bytes}");
            assert!(
                reasons.get("oversize").copied().unwrap_or(0) > 0,
                "{tag}: {reasons:?}"
            );
        } else {
            assert_eq!(iridium["commands_over_limit"], 0, "{bytes}");
            assert!(bytes["command_max_b"].as_u64().unwrap() <= 1890, "{bytes}");
            assert!(
                delivered_sizes.iter().all(|&b| b <= 1890),
                "{delivered_sizes:?}"
            );
        }
    }
}

/// `glider_acoustic` (Iridium at the surface, acoustic modems under water), 4 hours, as
/// shipped (TDMA) and with frames sent at random offsets and a glider killed and restarted:
/// `vbap run` equals `vbap sim` byte for byte, the receptions of every agent (by verdict,
/// from their message records) those of the simulator; frames collide and modems are deaf
/// only without TDMA.
#[test]
fn lockstep_equals_in_process_over_acoustic_modems() {
    let shipped = read(&workspace().join("deploy/missions/glider_acoustic.toml"));
    for (tag, random) in [("TDMA", false), ("random, kill and restart", true)] {
        let name = unique_name("eqaco");
        let mut text = shipped
            .replace("name = \"glider_acoustic\"", &format!("name = \"{name}\""))
            .replace("duration = 259200.0", "duration = 14400.0");
        if random {
            text = text.replace("schedule = \"tdma\"", "schedule = \"random\"")
                + "\n[restart]\nvehicles = \"on-failure\"\n\n[[faults]]\nkind = \"kill\"\n\
                   vehicle = 2\nat = 3600.0\nuntil = 7200.0\n";
        }
        let tmp = assert_run_equals_sim(&text);
        let (sim, run) = (summary(&tmp.join("sim")), summary(&tmp.join("run")));
        assert_eq!(sim["acoustic"], run["acoustic"], "{tag}");
        let a = &run["acoustic"];
        assert_eq!(a["frame_b"], 30, "{tag}: {a}");
        assert!(a["heard"].as_u64().unwrap() > 1000, "{tag}: {a}");
        let (collided, deaf) = (
            a["collision"].as_u64().unwrap(),
            a["deaf"].as_u64().unwrap(),
        );
        if random {
            assert!(collided > 0 && deaf > 0, "{tag}: {a}");
        } else {
            assert_eq!(
                (collided, deaf),
                (0, 0),
                "{tag}: TDMA slots never overlap: {a}"
            );
        }
        let mut verdicts = 0;
        for id in 0..6 {
            verdicts += msg_records(&tmp.join("run"), &format!("vehicle_agent_{id}"))
                .iter()
                .filter(|r| r.hop == "acoustic")
                .count();
        }
        let decided: u64 = ["heard", "range", "deaf", "collision", "undecoded", "noise"]
            .iter()
            .map(|k| a[*k].as_u64().unwrap())
            .sum();
        assert_eq!(verdicts as u64, decided, "{tag}: one record per verdict");
    }
}

#[test]
fn lockstep_equals_in_process_grid_field() {
    // The 2-D mission's Gaussian sampled onto a NetCDF grid: every process reads the file.
    let data = TempDir::new("grid");
    let file = data.join("g.nc");
    tests::grid::write_gaussian_grid(&file, 0.25);
    let text = mission_2d(&unique_name("eqgrid"), 4, 8.0, "\"lockstep\"").replace(
        "kind = \"gaussian\"\ncenter = [6.0, 3.0]\namplitude = 10.0\nwidth = 6.0\n",
        &format!("kind = \"grid\"\nfile = {:?}\n", file.display().to_string()),
    );
    assert!(text.contains("kind = \"grid\""));
    assert_run_equals_sim(&text);
}

#[test]
fn two_missions_at_once_do_not_interfere() {
    let tmp = TempDir::new("two");
    let a = write_mission(
        &tmp,
        "a.toml",
        &mission_2d(&unique_name("twoa"), 4, 6.0, "\"lockstep\""),
    );
    let b_text = GaussianHill::new(&unique_name("twob"))
        .count(5)
        .duration(6.0)
        .pace("\"lockstep\"")
        .seed(8)
        .toml();
    let b = write_mission(&tmp, "b.toml", &b_text);
    let mut runs: Vec<ChildGuard> = [(&a, "run_a"), (&b, "run_b")]
        .iter()
        .map(|(file, out)| spawn_run(file, &tmp.join(out)))
        .collect();
    for r in runs.iter_mut() {
        assert!(r.wait().success());
    }
    vbap_quiet("sim", &a, &tmp.join("sim_a"));
    vbap_quiet("sim", &b, &tmp.join("sim_b"));
    assert_same_tracks(&tmp.join("run_a"), &tmp.join("sim_a"));
    assert_same_tracks(&tmp.join("run_b"), &tmp.join("sim_b"));
}

#[test]
fn real_time_pace_runs_at_wall_speed_and_scaled() {
    let tmp = TempDir::new("rt");
    // pace 1.0: 2 s of mission take at least ~2 s of wall time.
    let file = write_mission(
        &tmp,
        "rt.toml",
        &mission_2d(&unique_name("rt1"), 4, 2.0, "1.0"),
    );
    vbap_quiet("run", &file, &tmp.join("rt1"));
    let s = summary(&tmp.join("rt1"));
    assert_eq!(s["ticks"], 40);
    assert!(
        s["wall_time_s"].as_f64().unwrap() >= 1.9,
        "pace 1.0 ran faster than real time: {s}"
    );
    assert!(s["late_ticks"].as_u64().is_some());
    // pace 60: a minute of mission in about a second (lower bound only).
    let file = write_mission(
        &tmp,
        "rt60.toml",
        &mission_2d(&unique_name("rt60"), 4, 60.0, "60.0"),
    );
    vbap_quiet("run", &file, &tmp.join("rt60"));
    let s = summary(&tmp.join("rt60"));
    assert_eq!(s["ticks"], 1200);
    assert!(
        s["wall_time_s"].as_f64().unwrap() >= 0.95,
        "pace 60 ran faster than 60x: {s}"
    );
}

fn stop_with(sig: &str) {
    let tmp = TempDir::new("sig");
    let name = unique_name("sig");
    let file = write_mission(&tmp, "long.toml", &mission_2d(&name, 4, 100000.0, "1.0"));
    let out = tmp.join("run");
    let mut run = spawn_run(&file, &out);
    let body = out.join("body.csv");
    wait_until(
        || {
            std::fs::read_to_string(&body)
                .map(|t| t.lines().count() > 3)
                .unwrap_or(false)
        },
        Duration::from_secs(60),
        "the run to make progress",
    );
    let children = processes_mentioning(&out.to_string_lossy());
    assert!(
        children.len() >= 6,
        "field server, coordinator and 4 agents run: {children:?}"
    );
    run.signal(sig);
    let status = run.wait();
    assert!(
        !status.success(),
        "an interrupted run does not report success"
    );
    assert!(
        processes_mentioning(&out.to_string_lossy()).is_empty(),
        "processes left after {sig}"
    );
    assert!(
        leftover_files(&name).is_empty(),
        "shared memory left after {sig}: {:?}",
        leftover_files(&name)
    );
    // What was written is kept.
    assert!(read(&body).lines().count() > 3);
    assert!(
        out.join("summary.json").exists(),
        "the coordinator wrote a summary on the way out"
    );
    let s = summary(&out);
    assert_eq!(s["verdict"], "interrupted", "{:?}", s["reasons"]);
    assert_eq!(s["converged"], false);
}

#[test]
fn sigint_stops_everything_cleanly() {
    stop_with("INT");
}

#[test]
fn sigterm_stops_everything_cleanly() {
    stop_with("TERM");
}

#[test]
fn bad_mission_is_refused_before_any_process_starts() {
    let tmp = TempDir::new("bad");
    let name = unique_name("bad");
    let text = mission_2d(&name, 4, 5.0, "\"lockstep\"").replace("width = 6.0", "width = -6.0");
    let file = write_mission(&tmp, "bad.toml", &text);
    let out = vbap()
        .arg("run")
        .arg(&file)
        .arg("--out")
        .arg(tmp.join("run"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("field.width"),
        "the error names the key: {err}"
    );
    assert!(
        !tmp.join("run").join("logs").exists(),
        "no process was started"
    );
    assert!(leftover_files(&name).is_empty());
    let out = vbap().arg("check").arg(&file).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
}
