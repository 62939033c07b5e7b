//! End-to-end tests of fault detection and recovery at any pace: real processes, real
//! SIGKILLs. Detection latencies and wall times are printed (run with `--nocapture`), never
//! asserted: processes are slow under load.

use std::collections::BTreeSet;
use std::path::Path;
use std::time::Duration;

use tests::mission::GaussianHill;
use tests::*;

fn mission(name: &str, n: usize, duration: f64, dt: f64, pace: &str, extra: &str) -> String {
    // Stiff on purpose (fast settling), so the formation may not shrink below 0.6: the
    // step stays stable (omega dt < 2 at min_scale).
    GaussianHill::stiff(name, "min_scale = 0.6\n")
        .seed(5)
        .count(n)
        .duration(duration)
        .dt(dt)
        .pace(pace)
        .then(extra)
        .toml()
}

fn events(dir: &Path) -> Vec<serde_json::Value> {
    read(&dir.join("events.jsonl"))
        .lines()
        .map(|l| serde_json::from_str(l).expect("event is JSON"))
        .collect()
}

fn kinds(dir: &Path, kind: &str) -> usize {
    std::fs::read_to_string(dir.join("events.jsonl"))
        .map(|t| t.matches(&format!("\"kind\":\"{kind}\"")).count())
        .unwrap_or(0)
}

/// SIGKILLs the processes whose command lines mention the needles, at once (one kill(1)).
fn sigkill_all(needles: &[String]) {
    signal_all("-9", needles);
}

/// Sends `signal` to the processes whose command lines mention the needles (one kill(1)).
fn signal_all(signal: &str, needles: &[String]) {
    let pids: Vec<String> = needles
        .iter()
        .map(|n| {
            processes_mentioning(n)
                .first()
                .unwrap_or_else(|| panic!("no process {n}"))
                .to_string()
        })
        .collect();
    assert!(std::process::Command::new("kill")
        .arg(signal)
        .args(&pids)
        .status()
        .unwrap()
        .success());
}

fn agent(out: &Path, id: u32) -> String {
    format!("{} --id {id} --", out.join("mission.toml").display())
}

fn role(out: &Path, process: &str) -> String {
    format!("{process} --mission {}", out.join("mission.toml").display())
}

/// Kills one agent, then two at once; every kill must be found, with its latency.
/// `stop_first`: the two are stopped (SIGSTOP) before they are killed, so they die at the
/// same moment of the mission even when kill(1) is preempted between its two kill(2) calls
/// (a lockstep tick is well below a millisecond). Returns the lost events.
fn kill_one_then_two(out: &Path, stop_first: bool) -> Vec<serde_json::Value> {
    sigkill_all(&[agent(out, 1)]);
    wait_until(
        || kinds(out, "lost") >= 1,
        Duration::from_secs(60),
        "the first kill to be detected",
    );
    let two = [agent(out, 2), agent(out, 4)];
    if stop_first {
        signal_all("-STOP", &two);
    }
    sigkill_all(&two);
    wait_until(
        || kinds(out, "lost") >= 3,
        Duration::from_secs(60),
        "both kills at once to be detected",
    );
    events(out)
        .into_iter()
        .filter(|e| e["kind"] == "lost")
        .collect()
}

fn print_detections(what: &str, lost: &[serde_json::Value], s: &serde_json::Value) {
    for e in lost {
        eprintln!(
            "{what}: vehicle {} lost at tick {} by {} after {} ms",
            e["vehicle"], e["k"], e["detail"]["by"], e["detail"]["detection_ms"]
        );
    }
    eprintln!(
        "{what}: detection_latency_ms {}, late_ticks {}, wall {} s",
        s["detection_latency_ms"], s["late_ticks"], s["wall_time_s"]
    );
}

/// Before: at pace 10 or 60 a tick's wall period (5 ms or less here) was shorter than the
/// wait after which liveness was scanned, and no kill was ever found. Now the supervisor
/// reports the death and the coordinator checks liveness on a wall clock of its own.
#[test]
fn agent_kills_are_detected_at_pace_10_and_60() {
    for (pace, duration) in [("10.0", 120.0), ("60.0", 720.0)] {
        let tmp = TempDir::new("paced_kill");
        let name = unique_name("pacedkill");
        let file = write_mission(&tmp, "m.toml", &mission(&name, 6, duration, 0.05, pace, ""));
        let out = tmp.join("run");
        let mut run = spawn_run(&file, &out);
        wait_for_ticks(&out, 40);
        let lost = kill_one_then_two(&out, false);
        assert!(run.wait().success(), "pace {pace}: the mission completes");
        let s = summary(&out);
        print_detections(&format!("pace {pace}"), &lost, &s);
        assert_eq!(s["vehicles_lost"], 3, "pace {pace}: {s}");
        assert_eq!(
            s["ticks"].as_u64().unwrap() as f64,
            (duration / 0.05_f64).round(),
            "pace {pace}: every tick ran"
        );
        let ids: BTreeSet<u64> = lost
            .iter()
            .map(|e| e["vehicle"].as_u64().unwrap())
            .collect();
        assert_eq!(ids, BTreeSet::from([1, 2, 4]), "pace {pace}: {lost:?}");
        for e in &lost {
            assert_eq!(e["detail"]["cause"], "process died", "{e}");
            // The supervisor reaped it; a node-list scan may get there first.
            let by = e["detail"]["by"].as_str().unwrap();
            assert!(by == "supervisor" || by == "scan", "{e}");
            assert!(e["detail"]["detection_ms"].as_f64().unwrap() >= 0.0, "{e}");
        }
        let latencies = s["detection_latency_ms"].as_array().unwrap();
        assert_eq!(latencies.len(), 3, "a latency per kill: {s}");
        assert_nothing_left(&name, &tmp);
    }
}

/// Lockstep with a restart policy: a killed agent is found dead before its restarted
/// process asks to join (or by that request, read while the tick waits), never after the
/// 10 s lockstep timeout; two agents killed at once are found within one tick of each
/// other (the tick cannot pass a vehicle that is missing and not yet found dead).
#[test]
fn lockstep_kills_with_restarts_never_wait_for_the_timeout() {
    let tmp = TempDir::new("ls_kill");
    let name = unique_name("lskill");
    let extra = "[restart]\nvehicles = \"on-failure\"\nbackoff = 0.05\n";
    let file = write_mission(
        &tmp,
        "m.toml",
        &mission(&name, 6, 1500.0, 0.05, "\"lockstep\"", extra),
    );
    let out = tmp.join("run");
    let mut run = spawn_run(&file, &out);
    wait_for_ticks(&out, 500);
    let lost = kill_one_then_two(&out, true);
    wait_until(
        || kinds(&out, "rejoin") >= 3,
        Duration::from_secs(60),
        "the restarted agents to rejoin",
    );
    assert!(run.wait().success(), "the mission completes");
    let s = summary(&out);
    print_detections("lockstep", &lost, &s);
    assert_eq!(s["vehicles_lost"], 3, "{s}");
    assert_eq!(s["vehicles_rejoined"], 3, "{s}");
    for e in &lost {
        let by = e["detail"]["by"].as_str().unwrap();
        assert!(["supervisor", "scan", "join"].contains(&by), "{e}");
    }
    let (a, b) = (
        lost[1]["k"].as_u64().unwrap(),
        lost[2]["k"].as_u64().unwrap(),
    );
    assert!(
        a.abs_diff(b) <= 1,
        "kills at once found at ticks {a} and {b}"
    );
    let log = read(&out.join("logs/coordinator.jsonl"));
    assert!(!log.contains("lockstep timeout"), "a tick waited 10 s");
    assert_nothing_left(&name, &tmp);
}

/// The coordinator's gaps between two answers of the field server, ms (its message
/// records): the largest is the outage a field-server kill caused.
fn largest_field_gap_ms(dir: &Path) -> f64 {
    let mut t: Vec<u64> = msg_records(dir, "coordinator")
        .into_iter()
        .filter(|r| r.hop == "field_reply" && r.event == MsgEvent::Recv)
        .filter_map(|r| r.recv_ns)
        .collect();
    t.sort_unstable();
    t.windows(2)
        .map(|w| (w[1] - w[0]) as f64 / 1e6)
        .fold(0.0, f64::max)
}

/// A SIGKILLed field server is restarted and gets the pending request again: the
/// coordinator is not restarted, and in lockstep the run still equals the simulator.
#[test]
fn a_field_server_kill_costs_no_coordinator_restart() {
    let tmp = TempDir::new("fs_kill");
    let name = unique_name("fskill");
    let extra = "[restart]\nfield_server = \"on-failure\"\nbackoff = 0.1\n";
    let file = write_mission(
        &tmp,
        "m.toml",
        &mission(&name, 4, 600.0, 0.05, "\"lockstep\"", extra),
    );
    vbap_quiet("sim", &file, &tmp.join("sim"));
    let out = tmp.join("run");
    let mut run = spawn_run(&file, &out);
    wait_for_ticks(&out, 1500);
    sigkill_all(&[role(&out, "field_server")]);
    assert!(run.wait().success(), "the mission completes");
    assert_same_tracks(&tmp.join("sim"), &out);
    let log = read(&out.join("logs/coordinator.jsonl"));
    assert_eq!(
        log.matches("\"coordinator up\"").count(),
        1,
        "the coordinator was not restarted"
    );
    assert!(!log.contains("resumed from the checkpoint"));
    let fs_log = read(&out.join("logs/field_server.jsonl"));
    assert_eq!(
        fs_log.matches("\"field server up\"").count(),
        2,
        "the field server was restarted once"
    );
    eprintln!(
        "field-server kill: largest gap between two readings {:.1} ms, wall {} s",
        largest_field_gap_ms(&out),
        summary(&out)["wall_time_s"]
    );
    assert_nothing_left(&name, &tmp);
}

/// Every planner input row `(vehicle, report tick)` of fresh reports: each state is used
/// once (a stale state is never used again as if new).
fn fresh_reports(dir: &Path) -> Vec<(u32, u64)> {
    columns::Table::read(&dir.join("planner_inputs.csv"))
        .rows()
        .filter(|r| r.get("role") != "member")
        .map(|r| (r.parse("id"), r.parse("tick")))
        .collect()
}

/// A coordinator SIGKILLed in a paced run resumes on the mission's wall clock (the ticks
/// it missed are caught up, counted late), loses no vehicle, and never uses a state twice.
#[test]
fn a_coordinator_kill_at_pace_10_keeps_the_mission_clock() {
    let tmp = TempDir::new("coord_pace");
    let name = unique_name("coordpace");
    let extra = "[restart]\ncoordinator = \"on-failure\"\nbackoff = 0.1\n";
    let file = write_mission(
        &tmp,
        "m.toml",
        &mission(&name, 4, 60.0, 0.05, "10.0", extra),
    );
    // An unkilled run of the same mission, for the wall time.
    vbap_quiet("run", &file, &tmp.join("clean"));
    let out = tmp.join("run");
    let mut run = spawn_run(&file, &out);
    wait_for_ticks(&out, 300);
    sigkill_all(&[role(&out, "coordinator")]);
    assert!(run.wait().success(), "the mission completes");
    let log = read(&out.join("logs/coordinator.jsonl"));
    assert!(log.contains("resumed from the checkpoint"));
    let (s, clean) = (summary(&out), summary(&tmp.join("clean")));
    eprintln!(
        "coordinator kill at pace 10: wall {} s (unkilled {} s), late_ticks {} (unkilled {})",
        s["wall_time_s"], clean["wall_time_s"], s["late_ticks"], clean["late_ticks"]
    );
    assert_eq!(s["ticks"], 1200, "every tick ran: {s}");
    assert_eq!(s["vehicles_lost"], 0, "{s}");
    assert!(
        s["late_ticks"].as_u64().unwrap() > 0,
        "the ticks missed during the outage count as late: {s}"
    );
    let fresh = fresh_reports(&out);
    let unique: BTreeSet<(u32, u64)> = fresh.iter().copied().collect();
    assert_eq!(unique.len(), fresh.len(), "a state was used twice");
    assert_nothing_left(&name, &tmp);
}

/// Policy `always`: the processes that end normally at the mission's end are not
/// started again.
#[test]
fn policy_always_restarts_nothing_at_mission_end() {
    let tmp = TempDir::new("always");
    let name = unique_name("always");
    let extra = "[restart]\nvehicles = \"always\"\nfield_server = \"always\"\n";
    let file = write_mission(
        &tmp,
        "m.toml",
        &mission(&name, 3, 20.0, 0.05, "\"lockstep\"", extra),
    );
    vbap_quiet("run", &file, &tmp.join("run"));
    let logs = tmp.join("run/logs");
    for process in ["vehicle_agent_0", "vehicle_agent_1", "vehicle_agent_2"] {
        let log = read(&logs.join(format!("{process}.jsonl")));
        assert_eq!(
            log.matches("\"agent up\"").count(),
            1,
            "{process} restarted"
        );
    }
    let log = read(&logs.join("field_server.jsonl"));
    assert_eq!(
        log.matches("\"field server up\"").count(),
        1,
        "field server restarted"
    );
    assert_nothing_left(&name, &tmp);
}

/// Starts `bin` with `args` and waits for its `ready` line.
fn start_ready(bin: &str, args: &[&str]) -> ChildGuard {
    use std::io::BufRead;
    let mut child = std::process::Command::new(bin_dir().join(bin))
        .args(args)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap_or_else(|e| panic!("starting {bin}: {e}"));
    let mut line = String::new();
    std::io::BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    assert_eq!(line.trim(), "ready", "{bin} {args:?}");
    ChildGuard(Some(child))
}

/// Without a supervisor to report deaths, the coordinator finds a killed agent by itself
/// (a scan of the node list when the vehicle falls silent), at pace 10 too.
#[test]
fn a_coordinator_started_alone_finds_dead_agents_by_itself() {
    let tmp = TempDir::new("alone");
    let name = unique_name("alone");
    let file = write_mission(&tmp, "m.toml", &mission(&name, 3, 60.0, 0.05, "10.0", ""));
    let file = file.to_string_lossy().to_string();
    let out = tmp.join("run");
    let log = |p: &str| {
        tmp.join(&format!("{p}.jsonl"))
            .to_string_lossy()
            .to_string()
    };
    let run_dir = out.to_string_lossy().to_string();
    let _field = start_ready("field_server", &["--mission", &file, "--log", &log("fs")]);
    let mut coordinator = start_ready(
        "coordinator",
        &[
            "--mission",
            &file,
            "--run-dir",
            &run_dir,
            "--log",
            &log("co"),
        ],
    );
    let mut agents: Vec<ChildGuard> = (0..3)
        .map(|id| {
            let id = id.to_string();
            start_ready(
                "vehicle_agent",
                &[
                    "--mission",
                    &file,
                    "--id",
                    &id,
                    "--log",
                    &log(&format!("a{id}")),
                ],
            )
        })
        .collect();
    wait_for_ticks(&out, 40);
    agents[1].signal("KILL");
    agents[1].wait();
    assert!(coordinator.wait().success(), "the coordinator completes");
    let lost: Vec<serde_json::Value> = events(&out)
        .into_iter()
        .filter(|e| e["kind"] == "lost")
        .collect();
    eprintln!("alone: {lost:?}");
    assert_eq!(lost.len(), 1, "{lost:?}");
    assert_eq!(lost[0]["vehicle"], 1);
    assert_eq!(lost[0]["detail"]["by"], "scan");
    assert!(lost[0]["detail"]["detection_ms"].as_f64().unwrap() >= 0.0);
    let s = summary(&out);
    assert_eq!(s["ticks"], 1200, "{s}");
    assert_eq!(s["vehicles_lost"], 1, "{s}");
    for mut a in agents.into_iter().filter(|a| a.0.is_some()) {
        assert!(a.wait().success(), "the other agents end with the mission");
    }
    // With no supervisor, nobody cleans the domain at the end (the supervisor does: its
    // dead nodes, then the domain's remaining files); the test does it as the supervisor
    // would, then nothing of the mission is left.
    let domain = vbap_ipc::topics::Domain::new(&name).expect("the mission's domain");
    domain.cleanup_dead_nodes();
    domain.remove_files();
    assert!(
        leftover_files(&name).is_empty(),
        "{:?}",
        leftover_files(&name)
    );
}

/// A stopped agent (SIGSTOP) is silent, not dead: it is waited for (its ticks are late)
/// for 10 s, then lost as `silent` (no detection latency: nothing died), and readmitted as
/// soon as it speaks again (SIGCONT). The run is then interrupted (Ctrl-C): it stops
/// cleanly.
#[test]
fn a_stopped_agent_is_lost_as_silent_after_the_limit_and_readmitted_when_continued() {
    let tmp = TempDir::new("silent");
    let name = unique_name("silent");
    let file = write_mission(&tmp, "m.toml", &mission(&name, 3, 3000.0, 0.05, "10.0", ""));
    let out = tmp.join("run");
    let mut run = spawn_run(&file, &out);
    wait_for_ticks(&out, 40);
    signal_all("-STOP", &[agent(&out, 1)]);
    wait_until(
        || kinds(&out, "lost") >= 1,
        Duration::from_secs(120),
        "the stopped agent to be lost as silent",
    );
    signal_all("-CONT", &[agent(&out, 1)]);
    wait_until(
        || kinds(&out, "rejoin") >= 1,
        Duration::from_secs(60),
        "the continued agent to be readmitted",
    );
    run.signal("INT");
    let status = run.wait();
    assert_eq!(status.code(), Some(130), "an interrupted run: {status:?}");
    let ev = events(&out);
    let lost: Vec<_> = ev.iter().filter(|e| e["kind"] == "lost").collect();
    eprintln!("silent: {lost:?}");
    assert_eq!(lost.len(), 1, "{lost:?}");
    assert_eq!(lost[0]["vehicle"], 1);
    assert_eq!(lost[0]["detail"]["cause"], "silent");
    assert_eq!(lost[0]["detail"]["by"], "silence");
    assert!(lost[0]["detail"]["silent_ms"].as_f64().unwrap() >= 10_000.0);
    assert!(lost[0]["detail"]["detection_ms"].is_null());
    let rejoin: Vec<_> = ev.iter().filter(|e| e["kind"] == "rejoin").collect();
    assert_eq!(rejoin[0]["vehicle"], 1);
    assert!(rejoin[0]["k"].as_u64() > lost[0]["k"].as_u64());
    assert_nothing_left(&name, &tmp);
}
