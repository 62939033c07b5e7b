//! End-to-end tests of the tools that study runs: `vbap replay` (the regression test of
//! the recorded planner inputs), `vbap analyze`, `vbap batch` and the time-series plots.

use std::path::Path;

use tests::*;

/// Ticks of the missions below (duration / dt).
const TICKS: u64 = 300;

fn mission(name: &str, n: usize, links: &str, extra: &str) -> String {
    format!(
        r#"
[mission]
name = "{name}"
seed = 11
duration = 15.0
dt = 0.05
goal = "max"
dim = 2
tolerance = 1.0
{extra}
[field]
kind = "gaussian"
center = [4.0, 2.0]
amplitude = 10.0
width = 6.0
noise_std = 0.1

[vehicles]
count = {n}
start = [0.0, 0.0]
start_spread = 0.3

[links]
{links}
"#
    )
}

fn sim(file: &Path, out: &Path) {
    vbap_quiet("sim", file, out);
}

fn run(file: &Path, out: &Path, name: &str) {
    vbap_quiet("run", file, out);
    assert!(
        leftover_files(name).is_empty(),
        "shared memory left behind: {:?}",
        leftover_files(name)
    );
}

/// `vbap replay DIR` succeeds and reproduces body.csv byte for byte.
fn assert_replays(dir: &Path) {
    let out = run_ok(vbap().arg("replay").arg(dir));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("body.csv: identical"), "{stdout}");
    assert!(stdout.contains("parsed exactly"), "{stdout}");
    assert_eq!(
        read(&dir.join("replay/body.csv")),
        read(&dir.join("body.csv")),
        "replayed body.csv"
    );
}

#[test]
fn replay_of_an_in_process_run_reproduces_body_csv() {
    let tmp = TempDir::new("replay_sim");
    let file = write_mission(&tmp, "m.toml", &mission("replaysim", 4, "", ""));
    let dir = tmp.join("sim");
    sim(&file, &dir);
    assert_replays(&dir);

    // A changed input gives a changed body.csv: replay exits 1 and names the line.
    let mut inputs = columns::Table::read(&dir.join("planner_inputs.csv"));
    let row = 4 * 100; // a measurement of tick 100 (4 rows per tick)
    assert_eq!(inputs.row(row).parse::<u64>("k"), 100);
    let m = inputs.row(row).num("measurement");
    inputs.set(row, "measurement", &(m + 0.5).to_string());
    std::fs::write(dir.join("planner_inputs.csv"), inputs.to_csv()).unwrap();
    let out = vbap().arg("replay").arg(&dir).output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(1), "{stdout}");
    assert!(
        stdout.contains("body.csv: DIFFERS, first difference at line 102"),
        "{stdout}"
    );

    // Not a run directory: invalid input.
    let out = vbap()
        .arg("replay")
        .arg(tmp.join("nowhere"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("mission.toml"));
}

#[test]
fn replay_of_multi_process_runs_reproduces_body_csv() {
    let tmp = TempDir::new("replay_run");
    // Ideal links: every report is a member's latest and fresh ("both").
    let name = unique_name("replayrun");
    let file = write_mission(&tmp, "m.toml", &mission(&name, 4, "", ""));
    run(&file, &tmp.join("ideal"), &name);
    assert_replays(&tmp.join("ideal"));
    // Delayed, lossy links: members and fresh reports differ, and some ticks have none.
    let name = unique_name("replaylink");
    let links = "delay = 0.1\njitter = 0.05\nloss = 0.2\n";
    let file = write_mission(&tmp, "l.toml", &mission(&name, 4, links, ""));
    run(&file, &tmp.join("links"), &name);
    let inputs = read(&tmp.join("links/planner_inputs.csv"));
    assert!(
        inputs.contains(",member,") && inputs.contains(",fresh,"),
        "the lossy run exercises both roles"
    );
    assert_replays(&tmp.join("links"));
}

#[test]
fn analyze_json_of_a_multi_process_run() {
    let tmp = TempDir::new("analyze");
    let n = 3u64;
    let name = unique_name("analyze");
    let file = write_mission(&tmp, "m.toml", &mission(&name, n as usize, "", ""));
    let dir = tmp.join("run");
    run(&file, &dir, &name);
    let out = run_ok(vbap().arg("analyze").arg(&dir).arg("--json"));
    let r: serde_json::Value =
        serde_json::from_slice(&out.stdout).expect("vbap analyze --json prints JSON");
    for hop in ["state", "body", "field_request", "field_reply"] {
        let h = &r["hops"][hop];
        for p in ["transport_us", "injected_ms"] {
            for q in ["p50", "p90", "p99", "max"] {
                assert!(h[p][q].is_number(), "hops.{hop}.{p}.{q} in {h}");
            }
        }
        let t = &h["transport_us"];
        let (p50, p99, max) = (
            t["p50"].as_f64().unwrap(),
            t["p99"].as_f64().unwrap(),
            t["max"].as_f64().unwrap(),
        );
        assert!(p50 > 0.0 && p50 <= p99 && p99 <= max, "{hop}: {t}");
        assert!(
            p50 < 1e6,
            "{hop}: a median hop of a second is not plausible: {t}"
        );
        assert_eq!(h["injected_ms"]["max"], 0.0, "ideal links inject nothing");
        assert_eq!(h["dropped_injected"], 0);
        assert_eq!(h["dropped_overflow"], 0);
    }
    let delivered = |hop: &str| r["hops"][hop]["delivered"].as_u64().unwrap();
    // One state per vehicle per tick; one body command per vehicle per tick (+ the final
    // "finished" command); one batched sensor read per tick, answered once.
    assert_eq!(delivered("state"), n * TICKS);
    assert!((n * TICKS..=n * (TICKS + 1)).contains(&delivered("body")));
    assert_eq!(delivered("field_request"), TICKS);
    assert_eq!(delivered("field_reply"), delivered("field_request"));
    // Where a lockstep tick's time goes: both parts within the period.
    let tick = &r["tick"];
    assert!(tick["ticks"].as_u64().unwrap() >= TICKS - 2, "{tick}");
    let p50 = |what: &str| tick[what]["p50"].as_f64().unwrap();
    assert!(p50("period_us") > 0.0, "{tick}");
    assert!(p50("waiting_for_states_us") <= p50("period_us"), "{tick}");
    assert!(p50("after_last_state_us") <= p50("period_us"), "{tick}");
    let mut loops: Vec<&String> = r["loops"].as_object().unwrap().keys().collect();
    loops.sort();
    assert_eq!(
        loops,
        [
            "coordinator",
            "vehicle_agent_0",
            "vehicle_agent_1",
            "vehicle_agent_2"
        ]
    );
    for (process, l) in r["loops"].as_object().unwrap() {
        assert!(
            l["period_ms"]["p50"].as_f64().unwrap() > 0.0,
            "{process}: {l}"
        );
        assert!(
            l["jitter_ms"]["max"].as_f64().unwrap() >= 0.0,
            "{process}: {l}"
        );
        assert!(l["iterations"].as_u64().unwrap() >= TICKS, "{process}: {l}");
    }
    assert_eq!(r["late_ticks"], 0, "lockstep runs have no deadlines");
    for plot in ["latency.svg", "loops.svg"] {
        assert!(read(&dir.join(plot)).starts_with("<svg"), "{plot}");
    }
    // The text report names every hop.
    let out = run_ok(vbap().arg("analyze").arg(&dir));
    let text = String::from_utf8_lossy(&out.stdout);
    for hop in ["state", "body", "field_request", "field_reply"] {
        assert!(text.contains(hop), "{text}");
    }
}

#[test]
fn analyze_separates_injected_delay_and_drops() {
    let tmp = TempDir::new("analyze_links");
    let name = unique_name("analyzelinks");
    let links = "delay = 0.2\njitter = 0.0\nloss = 0.25\n";
    let file = write_mission(&tmp, "m.toml", &mission(&name, 4, links, ""));
    let dir = tmp.join("run");
    run(&file, &dir, &name);
    let out = run_ok(vbap().arg("analyze").arg(&dir).arg("--json"));
    let r: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    for hop in ["state", "body"] {
        let h = &r["hops"][hop];
        // A fixed 200 ms of mission time on every delivered message, none of it counted
        // as transport (which stays far below it on one host).
        let inj = &h["injected_ms"];
        assert!(
            (inj["p50"].as_f64().unwrap() - 200.0).abs() < 1e-6,
            "{hop}: {inj}"
        );
        assert!(h["dropped_injected"].as_u64().unwrap() > 0, "{hop}: {h}");
        assert_eq!(
            h["delivered"].as_u64().unwrap() + h["dropped_injected"].as_u64().unwrap(),
            h["received"].as_u64().unwrap(),
            "{hop}: {h}"
        );
    }
    assert_eq!(r["hops"]["field_request"]["dropped_injected"], 0);
}

#[test]
fn batch_in_process_writes_table_and_aggregate_and_judges() {
    let tmp = TempDir::new("batch");
    let file = write_mission(
        &tmp,
        "m.toml",
        &mission(
            "batchok",
            4,
            "",
            "\n[batch]   # criteria\nmin_convergence_rate = 0.0\n",
        ),
    );
    let out_dir = tmp.join("b");
    let out = run_ok(
        vbap()
            .arg("batch")
            .arg(&file)
            .args(["--seeds", "3", "--jobs", "2", "--in-process", "--out"])
            .arg(&out_dir),
    );
    let agg: serde_json::Value = serde_json::from_slice(&out.stdout).expect("aggregate JSON");
    let table = read(&out_dir.join("batch.csv"));
    let rows: Vec<&str> = table.lines().collect();
    assert_eq!(rows.len(), 4, "header + 3 seeds:\n{table}");
    assert!(rows[0].starts_with(
        "seed,converged,time_to_converge_s,final_distance_to_optimum,final_grad_norm,max_V_over_VU,in_set_m,wall_time_s"
    ));
    let batch = columns::Table::parse(&table, "batch.csv");
    for (i, seed) in [11, 12, 13].iter().enumerate() {
        assert!(rows[i + 1].starts_with(&format!("{seed},")), "{table}");
        let row = batch.row(i);
        assert_eq!(row.get("status"), "ok", "{table}");
        // Each row is that seed's own run, its verdict included (quoted when it holds a
        // comma).
        let s = summary(&out_dir.join(format!("seed_{seed}")));
        let verdict = s["verdict"].as_str().unwrap();
        assert!(!verdict.is_empty());
        let cell = if verdict.contains(',') {
            format!(",\"{verdict}\",")
        } else {
            format!(",{verdict},")
        };
        assert!(rows[i + 1].contains(&cell), "{cell} in {table}");
        assert_eq!(s["seed"], *seed);
        let d = row.get("final_distance_to_optimum");
        assert_eq!(d, s["final_distance_to_optimum"].to_string(), "{table}");
        assert_eq!(row.get("verdict"), verdict, "{table}");
    }
    let on_disk: serde_json::Value =
        serde_json::from_str(&read(&out_dir.join("batch.json"))).unwrap();
    assert_eq!(agg, on_disk);
    assert_eq!(agg["runs"], 3);
    assert_eq!(agg["failed_runs"], 0);
    assert_eq!(agg["passed"], true);
    let rate = agg["convergence_rate"].as_f64().unwrap();
    assert!((0.0..=1.0).contains(&rate));
    assert_eq!(
        agg["converged"].as_u64().unwrap() as f64 / 3.0,
        rate,
        "rate = converged / runs"
    );
    let verdicts = agg["verdicts"].as_object().unwrap();
    let share: f64 = verdicts.values().map(|v| v.as_f64().unwrap()).sum();
    assert!(
        (share - 1.0).abs() < 1e-12,
        "verdict rates add up to 1: {verdicts:?}"
    );
    let d = &agg["final_distance_to_optimum"];
    assert_eq!(d["n"], 3);
    assert!(d["p50"].as_f64().unwrap() <= d["max"].as_f64().unwrap());

    // An impossible criterion: every run ending exactly on the optimum.
    let file = write_mission(
        &tmp,
        "strict.toml",
        &mission(
            "batchstrict",
            4,
            "",
            "\n[batch]\nmax_final_distance = 0.0\n",
        ),
    );
    let out = vbap()
        .arg("batch")
        .arg(&file)
        .args(["--seeds", "2", "--in-process", "--out"])
        .arg(tmp.join("strict"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("FAIL: max_final_distance"), "{stderr}");
    assert!(tmp.join("strict/batch.csv").is_file());

    // An unknown criterion is invalid input, named.
    let file = write_mission(
        &tmp,
        "bad.toml",
        &mission("batchbad", 4, "", "\n[batch]\nmin_rate = 1\n"),
    );
    let out = vbap()
        .arg("batch")
        .arg(&file)
        .args(["--seeds", "2", "--in-process", "--out"])
        .arg(tmp.join("bad"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("batch.min_rate"));
}

#[test]
fn time_series_plots_after_a_sim() {
    let tmp = TempDir::new("plots");
    let file = write_mission(&tmp, "m.toml", &mission("plots", 4, "", ""));
    let dir = tmp.join("sim");
    sim(&file, &dir);
    let formation = read(&dir.join("timeseries_formation.svg"));
    let estimate = read(&dir.join("timeseries_estimate.svg"));
    assert!(formation.starts_with("<svg") && formation.trim_end().ends_with("</svg>"));
    assert!(estimate.starts_with("<svg") && estimate.trim_end().ends_with("</svg>"));
    for panel in [
        "Lyapunov function",
        "Speed of the virtual body",
        "Formation scale k",
        "Vehicles: members of the design, alive, truly in formation",
        "mission time t (s)",
    ] {
        assert!(formation.contains(panel), "{panel}");
    }
    for panel in [
        "Gradient estimate error",
        "Trace of the Kalman covariance P",
        "Distance of the virtual body centre to the optimum",
    ] {
        assert!(estimate.contains(panel), "{panel}");
    }
    assert!(formation.contains("<polyline"));
    // The run converged: its event is marked.
    if read(&dir.join("events.jsonl")).contains("\"converged\"") {
        assert!(
            formation.contains("\nconverged\n"),
            "the converged event is labelled"
        );
    }
}
