//! End-to-end tests of compound faults: a death during another recovery. Real processes,
//! real SIGKILLs and SIGSTOPs; every wait is for an event of the run (a line of its
//! files), never a sleep; no latency is asserted.

use std::path::Path;
use std::time::Duration;

use tests::mission::GaussianHill;
use tests::*;

fn mission(name: &str, n: usize, pace: &str, extra: &str) -> String {
    GaussianHill::stiff(name, "min_scale = 0.6\n")
        .seed(5)
        .count(n)
        .duration(100_000.0)
        .dt(0.05)
        .pace(pace)
        .then(extra)
        .toml()
}

fn events(dir: &Path) -> Vec<serde_json::Value> {
    std::fs::read_to_string(dir.join("events.jsonl"))
        .unwrap_or_default()
        .lines()
        .filter_map(|l| serde_json::from_str(l).ok())
        .collect()
}

/// Events of `kind` about vehicle `v`.
fn of(dir: &Path, kind: &str, v: u64) -> Vec<serde_json::Value> {
    events(dir)
        .into_iter()
        .filter(|e| e["kind"] == kind && e["vehicle"].as_u64() == Some(v))
        .collect()
}

/// Sends `signal` to the first process whose command line mentions `needle`.
fn signal(signal: &str, needle: &str) {
    let pid = *processes_mentioning(needle)
        .first()
        .unwrap_or_else(|| panic!("no process {needle}"));
    assert!(std::process::Command::new("kill")
        .arg(signal)
        .arg(pid.to_string())
        .status()
        .unwrap()
        .success());
}

fn agent(out: &Path, id: u32) -> String {
    format!("{} --id {id} --", out.join("mission.toml").display())
}

fn coordinator(out: &Path) -> String {
    format!(
        "coordinator --mission {}",
        out.join("mission.toml").display()
    )
}

/// Lines of a process's log that contain `text`.
fn log_count(out: &Path, process: &str, text: &str) -> usize {
    std::fs::read_to_string(out.join("logs").join(format!("{process}.jsonl")))
        .map(|t| t.matches(text).count())
        .unwrap_or(0)
}

/// A run of `mission(name, n, pace, extra)` started in a new temporary directory named
/// after `label`, its mission's name unique: (the directory, the name, the run directory,
/// the `vbap run` process).
fn start(
    label: &str,
    n: usize,
    pace: &str,
    extra: &str,
) -> (TempDir, String, std::path::PathBuf, ChildGuard) {
    let tmp = TempDir::new(&format!("cmp_{label}"));
    let name = unique_name(&format!("cmp{label}"));
    let file = write_mission(&tmp, "m.toml", &mission(&name, n, pace, extra));
    let out = tmp.join("run");
    let run = spawn_run(&file, &out);
    (tmp, name, out, run)
}

/// Waits (at most `limit`) for an event of `kind` about vehicle `v`; on failure the panic
/// says `what` never happened and lists the run's events.
fn await_event(out: &Path, kind: &str, v: u64, limit: Duration, what: &str) {
    wait_until_or(
        || !of(out, kind, v).is_empty(),
        limit,
        || format!("{what}; events: {:?}", events(out)),
    );
}

/// Continues stopped agent `v` (SIGCONT) and waits until it is readmitted.
fn continue_and_await_rejoin(out: &Path, v: u32) {
    signal("-CONT", &agent(out, v));
    await_event(
        out,
        "rejoin",
        u64::from(v),
        Duration::from_secs(60),
        "the continued agent was never readmitted",
    );
}

/// Interrupts the run (SIGINT to `vbap run`) and checks it ended as an interrupted run.
fn interrupt(mut run: ChildGuard) {
    run.signal("INT");
    let status = run.wait();
    assert_eq!(status.code(), Some(130), "an interrupted run: {status:?}");
}

/// An agent killed while the coordinator cannot listen (stopped, then killed itself) and
/// restarted by the supervisor before any coordinator could notice: the new coordinator
/// learns of the death from the supervisor's record (or its report) and readmits the new
/// process, whose join request it never heard the first time. Before: the death was
/// found only if another exit was reported later, and the restarted agent, having asked
/// once, was never readmitted.
#[test]
fn an_agent_killed_and_restarted_while_the_coordinator_restarts_is_lost_then_readmitted() {
    let extra = "[restart]\nvehicles = \"on-failure\"\nbackoff = 0.05\n";
    let (tmp, name, out, run) = start("kill", 5, "\"lockstep\"", extra);
    wait_for_ticks(&out, 200);
    // The coordinator hears nothing from here on.
    signal("-STOP", &coordinator(&out));
    signal("-KILL", &agent(&out, 1));
    wait_until(
        || log_count(&out, "vehicle_agent_1", "\"agent up\"") >= 2,
        Duration::from_secs(60),
        "the killed agent to be restarted",
    );
    // Its one join request went to a coordinator that is now killed.
    signal("-KILL", &coordinator(&out));
    await_event(
        &out,
        "rejoin",
        1,
        Duration::from_secs(120),
        "the restarted agent was never readmitted",
    );
    interrupt(run);
    let lost = of(&out, "lost", 1);
    let rejoin = of(&out, "rejoin", 1);
    eprintln!("compound kill: lost {lost:?}, rejoin {rejoin:?}");
    assert_eq!(lost.len(), 1, "one loss: {lost:?}");
    assert_eq!(rejoin.len(), 1, "one rejoin: {rejoin:?}");
    let by = lost[0]["detail"]["by"].as_str().unwrap();
    assert!(
        ["record", "supervisor", "join", "scan"].contains(&by),
        "{by}"
    );
    assert!(rejoin[0]["k"].as_u64() >= lost[0]["k"].as_u64());
    // The new coordinator resumed, and the death it missed is in the record.
    assert!(log_count(&out, "coordinator", "resumed from the checkpoint") >= 1);
    let record: Vec<serde_json::Value> = read(&out.join("supervisor.exits.jsonl"))
        .lines()
        .map(|l| serde_json::from_str(l).expect("a record line is JSON"))
        .collect();
    let has = |event: &str, incarnation: u64| {
        record.iter().any(|r| {
            r["event"] == event
                && r["role"] == 0
                && r["vehicle"] == 1
                && r["incarnation"].as_u64() == Some(incarnation)
        })
    };
    assert!(has("died", 1), "the kill is recorded: {record:?}");
    assert!(has("restarted", 2), "the restart is recorded: {record:?}");
    assert_nothing_left(&name, &tmp);
}

/// A member stopped (SIGSTOP) never reports until continued: whatever restarts of the
/// coordinator do meanwhile, it is lost, as `stopped`, from the supervisor's report or its
/// record. Here an agent is stopped and the coordinator killed at once. Before the
/// supervisor watched stops: lost as `silent` after 10 s of silence; before that, the
/// resumed coordinator had never heard of the stopped agent, took it for one still
/// starting up, and waited for it forever (every lockstep tick 10 s, "waiting for
/// reports").
#[test]
fn a_stopped_member_is_lost_across_a_coordinator_restart() {
    let (tmp, name, out, run) = start("silent", 4, "\"lockstep\"", "");
    wait_for_ticks(&out, 200);
    signal("-STOP", &agent(&out, 2));
    signal("-KILL", &coordinator(&out));
    await_event(
        &out,
        "lost",
        2,
        Duration::from_secs(120),
        "the stopped member was never lost",
    );
    continue_and_await_rejoin(&out, 2);
    interrupt(run);
    let lost = of(&out, "lost", 2);
    eprintln!("stopped across a restart: {lost:?}");
    assert_eq!(lost.len(), 1, "{lost:?}");
    assert_eq!(lost[0]["detail"]["cause"], "stopped");
    assert!(log_count(&out, "coordinator", "resumed from the checkpoint") >= 1);
    assert_nothing_left(&name, &tmp);
}

/// A lockstep tick does not wait for a stopped member: the supervisor sees the stop (it is
/// the agent's parent), records and reports it, and the coordinator loses the member at
/// once (`stopped`, `by = "supervisor"`), so an agent killed during the stop is decided and
/// the mission commands its other vehicles while the first is still stopped; continued, the
/// stopped agent is readmitted. Before: lockstep waited for the stopped member's state up
/// to its 10 s silence limit, and lost it then as `silent`; every other decision waited.
#[test]
fn a_lockstep_tick_does_not_wait_for_a_stopped_member() {
    let (tmp, name, out, run) = start("stopped", 5, "\"lockstep\"", "");
    wait_for_ticks(&out, 200);
    signal("-STOP", &agent(&out, 2));
    await_event(
        &out,
        "lost",
        2,
        Duration::from_secs(60),
        "the stopped member was never lost",
    );
    signal("-KILL", &agent(&out, 3));
    await_event(
        &out,
        "lost",
        3,
        Duration::from_secs(60),
        "the agent killed during the stop was never lost",
    );
    // Still stopped: the mission goes on commanding the others.
    wait_for_more_ticks(&out, 100);
    let rejoined_while_stopped = of(&out, "rejoin", 2).len();
    continue_and_await_rejoin(&out, 2);
    interrupt(run);
    let stopped = of(&out, "lost", 2);
    eprintln!(
        "stopped in lockstep: {stopped:?}; killed: {:?}",
        of(&out, "lost", 3)
    );
    assert_eq!(stopped.len(), 1, "{stopped:?}");
    assert_eq!(stopped[0]["detail"]["cause"], "stopped");
    assert_eq!(stopped[0]["detail"]["by"], "supervisor");
    assert_eq!(rejoined_while_stopped, 0, "readmitted while stopped");
    let record = exit_record(&out);
    for event in ["stopped", "continued"] {
        assert!(
            record
                .iter()
                .any(|r| r["event"] == event && r["vehicle"].as_u64() == Some(2)),
            "no {event} of agent 2 in the supervisor's record: {record:?}"
        );
    }
    assert_nothing_left(&name, &tmp);
}

fn field_server(out: &Path) -> String {
    format!(
        "field_server --mission {}",
        out.join("mission.toml").display()
    )
}

/// Waits (at most 60 s) for the `lost` event of the killed agent of vehicle `v`.
fn await_lost(out: &Path, v: u64) {
    await_event(
        out,
        "lost",
        v,
        Duration::from_secs(60),
        "the killed agent was never lost",
    );
}

/// An agent killed while the field server is stopped, in a paced run: the coordinator that
/// was running goes on ticking without the field server's readings, loses the agent and
/// keeps commanding the others, all while the field server stays stopped. Before: the
/// coordinator waited for the readings of the tick under way, so the death was decided
/// only when the field server answered again, or, stopped for 10 s, when the coordinator
/// gave up, failed and was restarted, its successor waiting for the readings again.
#[test]
fn a_paced_run_loses_an_agent_killed_while_its_field_server_is_stopped() {
    let (tmp, name, out, run) = start("field", 5, "10.0", "");
    wait_for_ticks(&out, 100);
    // The field server answers nothing from here on.
    signal("-STOP", &field_server(&out));
    signal("-KILL", &agent(&out, 1));
    await_lost(&out, 1);
    // Still stopped: the mission goes on ticking and commanding its other vehicles.
    wait_for_more_ticks(&out, 100);
    let lost = of(&out, "lost", 1);
    let blind = log_count(&out, "coordinator", "the paced ticks go on without them");
    let resumed = log_count(&out, "coordinator", "resumed from the checkpoint");
    signal("-CONT", &field_server(&out));
    interrupt(run);
    eprintln!("killed while the field server was stopped: {lost:?}");
    assert_eq!(lost.len(), 1, "{lost:?}");
    let by = lost[0]["detail"]["by"].as_str().unwrap();
    assert!(["supervisor", "scan"].contains(&by), "{by}");
    // Decided by the coordinator that was running, which went on without the readings.
    assert_eq!(resumed, 0, "the coordinator was restarted");
    assert!(blind >= 1, "no tick went on without its readings");
    assert_nothing_left(&name, &tmp);
}

/// An agent killed while the field server is stopped, in lockstep: the tick waits for
/// every reading (its run equals `vbap sim`), but the coordinator decides the death while
/// it waits, from the supervisor's report, without waiting for the field server's answer;
/// continued, the field server answers and the mission goes on. Before: the death was
/// decided only after the readings came in, or, the field server stopped for 10 s, by a
/// restarted coordinator from the record.
#[test]
fn a_lockstep_coordinator_decides_a_death_while_it_waits_for_a_stopped_field_server() {
    let (tmp, name, out, run) = start("lsfield", 5, "\"lockstep\"", "");
    wait_for_ticks(&out, 200);
    signal("-STOP", &field_server(&out));
    signal("-KILL", &agent(&out, 1));
    // The verdict is logged at once; its `lost` event is written with the tick, which
    // waits for the readings.
    wait_until_or(
        || log_count(&out, "coordinator", "vehicle process is dead") >= 1,
        Duration::from_secs(60),
        || "the death was not decided while the field server was stopped".to_string(),
    );
    let resumed = log_count(&out, "coordinator", "resumed from the checkpoint");
    signal("-CONT", &field_server(&out));
    await_lost(&out, 1);
    wait_for_more_ticks(&out, 100);
    interrupt(run);
    let lost = of(&out, "lost", 1);
    eprintln!("killed while the field server was stopped, lockstep: {lost:?}");
    assert_eq!(lost.len(), 1, "{lost:?}");
    assert_eq!(lost[0]["detail"]["by"], "supervisor");
    assert_eq!(resumed, 0, "decided by a restarted coordinator");
    assert_nothing_left(&name, &tmp);
}

/// The supervisor's record of a run: one JSON value a line.
fn exit_record(out: &Path) -> Vec<serde_json::Value> {
    std::fs::read_to_string(out.join("supervisor.exits.jsonl"))
        .unwrap_or_default()
        .lines()
        .filter_map(|l| serde_json::from_str(l).ok())
        .collect()
}

/// The wall time (ns) of the record's `event` about the process of `role` (0 agent, 1
/// coordinator), `vehicle` for an agent, of incarnation `incarnation`.
fn recorded_at(out: &Path, event: &str, role: u64, vehicle: u64, incarnation: u64) -> Option<u64> {
    exit_record(out)
        .iter()
        .find(|r| {
            r["event"] == event
                && r["role"].as_u64() == Some(role)
                && (role != 0 || r["vehicle"].as_u64() == Some(vehicle))
                && r["incarnation"].as_u64() == Some(incarnation)
        })
        .and_then(|r| r["at_ns"].as_u64())
}

/// An agent killed while the coordinator's restart waits out its backoff is started again
/// after its own backoff, not after the coordinator's restart as well: before, the
/// supervisor restarted one process at a time (the coordinator's backoff, its start-up
/// until ready, and only then the agent's backoff: more than two backoffs after the
/// agent's death; 3.98 s for a 2 s backoff). The backoff is 3 s here, so the bound of
/// 1.5 backoffs leaves 1.5 s for the supervisor's timer and the reaping on a busy machine
/// and is still half a backoff short of the old order.
#[test]
fn an_agent_killed_during_a_coordinator_restart_waits_only_its_own_backoff() {
    let backoff_s = 3.0;
    let extra = format!("[restart]\nvehicles = \"on-failure\"\nbackoff = {backoff_s}\n");
    let (tmp, name, out, run) = start("backoff", 5, "\"lockstep\"", &extra);
    wait_for_ticks(&out, 200);
    signal("-KILL", &coordinator(&out));
    // The supervisor has reaped the coordinator: its restart's backoff is under way.
    wait_until(
        || recorded_at(&out, "died", 1, 0, 1).is_some(),
        Duration::from_secs(30),
        "the coordinator's death to be recorded",
    );
    signal("-KILL", &agent(&out, 1));
    wait_until_or(
        || recorded_at(&out, "restarted", 0, 1, 2).is_some(),
        Duration::from_secs(60),
        || format!("the agent was never restarted: {:?}", exit_record(&out)),
    );
    await_event(
        &out,
        "rejoin",
        1,
        Duration::from_secs(120),
        "the restarted agent was never readmitted",
    );
    interrupt(run);
    let died = recorded_at(&out, "died", 0, 1, 1).expect("the agent's death is recorded");
    let restarted = recorded_at(&out, "restarted", 0, 1, 2).unwrap();
    let coordinator_back = recorded_at(&out, "restarted", 1, 0, 2);
    let waited_s = restarted.saturating_sub(died) as f64 / 1e9;
    eprintln!(
        "agent restarted {waited_s:.3} s after its death (backoff {backoff_s} s); record: {:?}",
        exit_record(&out)
    );
    assert!(coordinator_back.is_some(), "the coordinator was restarted");
    assert!(
        waited_s < 1.5 * backoff_s,
        "the agent's restart waited {waited_s:.3} s: behind the coordinator's restart"
    );
    assert_eq!(of(&out, "lost", 1).len(), 1);
    assert_nothing_left(&name, &tmp);
}
