//! End-to-end tests of links and faults: real processes, real SIGKILLs.

use std::collections::BTreeMap;
use std::time::Duration;

use tests::mission::GaussianHill;
use tests::*;

fn base(name: &str, n: usize, duration: f64, pace: &str, extra: &str) -> String {
    GaussianHill::stiff(name, "")
        .seed(11)
        .count(n)
        .duration(duration)
        .pace(pace)
        // ω·dt would pass 2 (unstable) only at formation.min_scale = 0.2, far below the
        // scales these short runs reach: run them anyway.
        .mission_keys("allow_unstable = true\n")
        .then(extra)
        .toml()
}

fn events(dir: &std::path::Path) -> Vec<serde_json::Value> {
    read(&dir.join("events.jsonl"))
        .lines()
        .map(|l| serde_json::from_str(l).expect("event is JSON"))
        .collect()
}

fn count(events: &[serde_json::Value], kind: &str) -> usize {
    events.iter().filter(|e| e["kind"] == kind).count()
}

#[test]
fn scheduled_faults_and_impaired_links_in_lockstep_equal_the_simulator() {
    let tmp = TempDir::new("sched");
    let extra = r#"
[links]
delay = 0.2
jitter = 0.1
loss = 0.1
burst_enter = 0.02
surfacing_period = 4.0
surfacing_window = 2.0

[restart]
vehicles = "on-failure"

[[faults]]
kind = "kill"
vehicle = 2
at = 5.0
until = 10.0

[[faults]]
kind = "kill"
vehicle = 4
at = 12.0

[[faults]]
kind = "link_down"
vehicle = 1
at = 3.0
until = 6.0

[[faults]]
kind = "sensor_bias"
vehicle = 0
at = 2.0
until = 4.0
value = 0.5

[[faults]]
kind = "sensor_stuck"
vehicle = 3
at = 7.0
until = 9.0
"#;
    let name = unique_name("sched");
    let file = write_mission(&tmp, "m.toml", &base(&name, 5, 20.0, "\"lockstep\"", extra));
    vbap_quiet("sim", &file, &tmp.join("sim"));
    vbap_quiet("run", &file, &tmp.join("run"));
    assert_same_tracks(&tmp.join("sim"), &tmp.join("run"));
    let s = summary(&tmp.join("run"));
    assert_eq!(s["vehicles_lost"], 2, "{s}");
    assert_eq!(s["vehicles_rejoined"], 1, "{s}");
    assert!(s["messages"]["dropped_injected"].as_u64().unwrap() > 0);
    let ev = events(&tmp.join("run"));
    assert_eq!(count(&ev, "fault"), 5);
    assert!(count(&ev, "link_drop") > 0);
    // The restarted agent was a new process (its pid differs) and rejoined.
    let log = read(&tmp.join("run/logs/vehicle_agent_2.jsonl"));
    assert!(log.contains("admitted back into the formation"));
    assert_nothing_left(&name, &tmp);
}

/// A vehicle restarted 30 s after its kill comes back out of the leaders' reach (the body
/// has moved ~15 lengths on); it is guided home to a free slot while the body waits, over
/// delayed and lossy links (the agents dead-reckon their slots and their neighbours'), and
/// the multi-process run equals the simulator byte for byte.
#[test]
fn a_vehicle_rejoining_from_out_of_reach_in_lockstep_equals_the_simulator() {
    let tmp = TempDir::new("rejoinfar");
    let name = unique_name("rejoinfar");
    let text = rejoin_mission(
        &name,
        130.0,
        "[links]\ndelay = 0.3\njitter = 0.1\nloss = 0.05\n\n[[faults]]\nkind = \"kill\"\nvehicle = 2\nat = 5.0\nuntil = 35.0\n",
    );
    let file = write_mission(&tmp, "m.toml", &text);
    vbap_quiet("sim", &file, &tmp.join("sim"));
    vbap_quiet("run", &file, &tmp.join("run"));
    assert_same_tracks(&tmp.join("sim"), &tmp.join("run"));
    let s = summary(&tmp.join("run"));
    assert_eq!(s["vehicles_rejoined"], 1, "{s}");
    assert_eq!(s["converged"], true, "{s}");
    let log = read(&tmp.join("run/logs/vehicle_agent_2.jsonl"));
    assert!(log.contains("admitted back into the formation"));
    assert_nothing_left(&name, &tmp);
}

fn pid_of(needle: &str) -> Option<u32> {
    processes_mentioning(needle).into_iter().next()
}

/// A real SIGKILL to the one process whose command line holds `needle`.
fn sigkill(needle: &str) {
    let pid = pid_of(needle).unwrap_or_else(|| panic!("no process runs {needle:?}"));
    assert!(std::process::Command::new("kill")
        .args(["-9", &pid.to_string()])
        .status()
        .unwrap()
        .success());
}

/// A real SIGKILL to vehicle `id`'s agent of the run in `out`.
fn sigkill_agent(out: &std::path::Path, id: u32) {
    sigkill(&format!(
        "{} --id {id} --",
        out.join("mission.toml").display()
    ));
}

#[test]
fn a_killed_coordinator_resumes_from_its_checkpoint_and_the_run_equals_the_simulator() {
    let tmp = TempDir::new("coordkill");
    let name = unique_name("coordkill");
    // Surfacing windows: the checkpoint's journals hold reports in flight across the kill.
    let extra =
        "[links]\ndelay = 0.1\nloss = 0.05\nsurfacing_period = 4.0\nsurfacing_window = 1.0\n";
    let file = write_mission(
        &tmp,
        "m.toml",
        &base(&name, 4, 400.0, "\"lockstep\"", extra),
    );
    vbap_quiet("sim", &file, &tmp.join("sim"));
    let out = tmp.join("run");
    let mut run = spawn_run(&file, &out);
    let body = out.join("body.csv");
    wait_until(
        || line_count(&body) > 1500,
        Duration::from_secs(60),
        "the run to get going",
    );
    let needle = format!(
        "coordinator --mission {}",
        out.join("mission.toml").display()
    );
    sigkill(&needle);
    assert!(
        run.wait().success(),
        "the run completes after the coordinator restart"
    );
    let log = read(&out.join("logs/coordinator.jsonl"));
    assert!(
        log.contains("resumed from the checkpoint"),
        "the restarted coordinator resumed"
    );
    assert_same_tracks(&tmp.join("sim"), &out);
    assert!(leftover_files(&name).is_empty());
}

#[test]
fn random_agent_kills_are_survived_and_the_restarted_agents_rejoin() {
    let tmp = TempDir::new("agentkill");
    let name = unique_name("agentkill");
    let extra = "[restart]\nvehicles = \"on-failure\"\nbackoff = 0.1\n";
    let file = write_mission(&tmp, "m.toml", &base(&name, 5, 30.0, "4.0", extra));
    let out = tmp.join("run");
    let mut run = spawn_run(&file, &out);
    let body = out.join("body.csv");
    wait_until(
        || line_count(&body) > 20,
        Duration::from_secs(60),
        "the run to get going",
    );
    // Kill three agents one after another; each must be found dead and come back.
    for (round, victim) in [1u32, 3, 1].into_iter().enumerate() {
        sigkill_agent(&out, victim);
        let ev_path = out.join("events.jsonl");
        wait_until(
            || {
                std::fs::read_to_string(&ev_path)
                    .map(|t| t.matches("\"rejoin\"").count() > round)
                    .unwrap_or(false)
            },
            Duration::from_secs(30),
            "the killed agent to be found dead and rejoin",
        );
    }
    assert!(run.wait().success(), "the mission completes");
    let s = summary(&out);
    assert_eq!(s["ticks"], 600, "every tick ran: {s}");
    assert!(s["vehicles_lost"].as_u64().unwrap() >= 3, "{s}");
    assert!(s["vehicles_rejoined"].as_u64().unwrap() >= 3, "{s}");
    // Every loss redesigns the formation at its tick (a loss found at the tick a rejoined
    // vehicle becomes a member again shares that redesign with it).
    assert!(s["reconfigurations"].as_u64().unwrap() >= 3, "{s}");
    assert!(
        !s["detection_latency_ms"].as_array().unwrap().is_empty(),
        "detection latency measured: {s}"
    );
    let ev = events(&out);
    let lost: Vec<_> = ev
        .iter()
        .filter(|e| e["kind"] == "lost")
        .map(|e| e["detail"]["cause"].clone())
        .collect();
    assert!(
        lost.iter()
            .all(|c| c == "process died" || c == "process restarted"),
        "{lost:?}"
    );
    for e in ev.iter().filter(|e| e["kind"] == "lost") {
        assert!(
            ev.iter().any(|r| r["kind"] == "reconfigured"
                && r["k"] == e["k"]
                && !r["detail"]["vehicles"]
                    .as_array()
                    .unwrap()
                    .contains(&e["vehicle"])),
            "no redesign without the lost vehicle at its tick: {e}"
        );
    }
    assert_nothing_left(&name, &tmp);
}

/// The coordinator's message records of the state hop: (injected delays ms, dropped count,
/// received count).
fn uplink_stats(dir: &std::path::Path) -> (Vec<f64>, usize, usize) {
    let mut delays = Vec::new();
    let mut drops = 0;
    let mut total = 0;
    for r in msg_records(dir, "coordinator") {
        if r.hop != "state" {
            continue;
        }
        match r.event {
            MsgEvent::Held => delays.push(r.injected_ms().expect("a held record's delay")),
            MsgEvent::Drop => drops += 1,
            MsgEvent::Recv => total += 1,
        }
    }
    (delays, drops, total)
}

#[test]
fn measured_delay_and_loss_match_the_configured_link() {
    let tmp = TempDir::new("linkstat");
    let name = unique_name("linkstat");
    let extra = "[links]\ndelay = 2.0\njitter = 0.5\nloss = 0.2\n";
    let file = write_mission(&tmp, "m.toml", &base(&name, 4, 60.0, "\"lockstep\"", extra));
    vbap_quiet("run", &file, &tmp.join("run"));
    let (delays, drops, total) = uplink_stats(&tmp.join("run"));
    assert_eq!(
        total,
        4 * 1200,
        "every state reached the coordinator over shared memory"
    );
    // Loss: binomial, 5 standard errors.
    let rate = drops as f64 / total as f64;
    let se = (0.2 * 0.8 / total as f64).sqrt();
    assert!((rate - 0.2).abs() < 5.0 * se, "loss rate {rate}");
    // Delay: uniform on [1.5, 2.5] s, quantised up to the next tick (dt = 0.05 s) at most.
    assert_eq!(delays.len() + drops, total);
    let min = delays.iter().cloned().fold(f64::INFINITY, f64::min);
    let max = delays.iter().cloned().fold(0.0, f64::max);
    assert!(min >= 1500.0 - 1e-6 && max <= 2500.0 + 1e-6, "{min} {max}");
    let mean = delays.iter().sum::<f64>() / delays.len() as f64;
    let se = 288.7 / (delays.len() as f64).sqrt();
    assert!((mean - 2000.0).abs() < 5.0 * se, "mean delay {mean} ms");
    // The summary counts the same drops: these uplink ones plus the agents' downlink ones.
    let downlink: usize = (0..4)
        .map(|i| {
            msg_records(&tmp.join("run"), &format!("vehicle_agent_{i}"))
                .iter()
                .filter(|r| r.event == MsgEvent::Drop && r.hop == "body")
                .count()
        })
        .sum();
    assert!(downlink > 0, "the downlink drops too");
    let s = summary(&tmp.join("run"));
    assert_eq!(
        s["messages"]["dropped_injected"].as_u64().unwrap() as usize,
        drops + downlink,
        "{s}"
    );
}

#[test]
fn nothing_is_delivered_outside_a_surfacing_window() {
    let tmp = TempDir::new("surf");
    let name = unique_name("surf");
    let (period, window, n) = (4.0, 1.0, 4);
    let extra =
        format!("[links]\ndelay = 0.1\nsurfacing_period = {period}\nsurfacing_window = {window}\n");
    let file = write_mission(
        &tmp,
        "m.toml",
        &base(&name, n, 30.0, "\"lockstep\"", &extra),
    );
    vbap_quiet("run", &file, &tmp.join("run"));
    vbap_quiet("sim", &file, &tmp.join("sim"));
    // Both count the messages of the links alike, reports still under way at the end
    // included.
    let (run, sim) = (summary(&tmp.join("run")), summary(&tmp.join("sim")));
    for count in ["sent", "delivered", "dropped_injected"] {
        assert_eq!(run["messages"][count], sim["messages"][count], "{count}");
    }
    // Every report the planner received fresh was delivered while its vehicle was at the
    // surface: staggered phase i·period/N.
    let inputs = columns::Table::read(&tmp.join("run/planner_inputs.csv"));
    let mut fresh_per_vehicle: BTreeMap<u32, usize> = BTreeMap::new();
    for row in inputs.rows() {
        if row.get("role") == "member" {
            continue;
        }
        let k: u64 = row.parse("k");
        let id: u32 = row.parse("id");
        let t = k as f64 * 0.05;
        let phase = period * id as f64 / n as f64;
        let into = (t - phase).rem_euclid(period);
        assert!(
            into < window + 1e-9,
            "vehicle {id} delivered at t = {t} ({into} s into its period)"
        );
        *fresh_per_vehicle.entry(id).or_default() += 1;
    }
    assert_eq!(
        fresh_per_vehicle.len(),
        n,
        "every vehicle got reports through: {fresh_per_vehicle:?}"
    );
}

/// A process stopped and resumed at once (`kill -STOP`/`-CONT`, a debugger or `strace -p`
/// attaching) sees its wait interrupted: that is no request to stop. In lockstep the others
/// wait for it (an agent stopped for less than the coordinator's 250 ms grace is not
/// lost), and the run still equals the simulator.
#[test]
fn stopped_and_resumed_processes_carry_on() {
    let tmp = TempDir::new("stopcont");
    let name = unique_name("stopcont");
    let file = write_mission(&tmp, "m.toml", &base(&name, 4, 600.0, "\"lockstep\"", ""));
    vbap_quiet("sim", &file, &tmp.join("sim"));
    let out = tmp.join("run");
    let mut run = spawn_run(&file, &out);
    let body = out.join("body.csv");
    wait_until(
        || line_count(&body) > 1000,
        Duration::from_secs(60),
        "the run to get going",
    );
    let mission = out.join("mission.toml").display().to_string();
    for needle in [
        format!("vehicle_agent --mission {mission} --id 1 "),
        format!("coordinator --mission {mission}"),
        format!("field_server --mission {mission}"),
    ] {
        let pid = pid_of(&needle).unwrap_or_else(|| panic!("no process {needle}"));
        // The scenario: the process stays stopped a while (this is not a synchronisation);
        // one shell sends both signals, its builtin `kill`s 50 ms apart.
        let script = format!("kill -STOP {pid}; sleep 0.05; kill -CONT {pid}");
        assert!(std::process::Command::new("sh")
            .args(["-c", &script])
            .status()
            .unwrap()
            .success());
    }
    assert!(run.wait().success(), "the run completes");
    assert_same_tracks(&tmp.join("sim"), &out);
    let s = summary(&out);
    assert_eq!(s["vehicles_lost"], 0, "{s}");
    for process in ["vehicle_agent_1", "coordinator", "field_server"] {
        let log = read(&out.join(format!("logs/{process}.jsonl")));
        assert!(!log.contains("stopped by signal"), "{process}: {log}");
    }
    assert_nothing_left(&name, &tmp);
}

/// An agent killed outside every schedule on an acoustic mission: the others wait for its
/// next frame (lockstep cannot tell a dead sender from a slow one) for 2 s, then give it
/// up, once: its later frames are not awaited (before, each of them cost every agent
/// another 2 s, and a 4-hour mission hours of wall time).
#[test]
fn an_acoustic_sender_killed_outside_the_schedule_is_given_up_once() {
    let tmp = TempDir::new("acokill");
    let name = unique_name("acokill");
    let text = read(&workspace().join("deploy/missions/glider_acoustic.toml"))
        .replace("name = \"glider_acoustic\"", &format!("name = \"{name}\""))
        .replace("duration = 259200.0", "duration = 14400.0");
    assert!(text.contains("duration = 14400.0"));
    let file = write_mission(&tmp, "m.toml", &text);
    let out = tmp.join("run");
    let mut run = spawn_run(&file, &out);
    wait_until(
        || line_count(&out.join("body.csv")) > 200,
        Duration::from_secs(120),
        "the run to get going",
    );
    let victim = 3;
    sigkill_agent(&out, victim);
    assert!(run.wait().success(), "the mission completes");
    let s = summary(&out);
    assert_eq!(s["ticks"], 1440, "every tick ran: {s}");
    let ev = events(&out);
    assert!(
        ev.iter()
            .any(|e| e["kind"] == "lost" && e["vehicle"] == victim),
        "the dead vehicle is lost"
    );
    let mut warned = 0;
    for id in (0..6).filter(|id| *id != victim) {
        let log = read(&out.join(format!("logs/vehicle_agent_{id}.jsonl")));
        let gave_up = log
            .lines()
            .filter(|l| {
                l.contains("acoustic frames never came")
                    && l.contains(&format!("\"sender\":{victim}"))
            })
            .count();
        assert!(
            gave_up <= 1,
            "agent {id} gave vehicle {victim} up {gave_up} times"
        );
        warned += gave_up;
    }
    assert!(
        warned >= 1,
        "the agents waited for the dead sender's frames and gave it up"
    );
    assert_nothing_left(&name, &tmp);
}
