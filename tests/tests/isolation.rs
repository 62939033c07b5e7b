//! Isolation and hygiene of runs on one host, with the real binaries: a mission whose name
//! begins another's, two starts of one mission at once, a SIGKILLed supervisor, a SIGKILLed
//! agent's message records, and the records' own switch.

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Duration;

use tests::mission::GaussianHill;
use tests::*;

fn mission(name: &str, duration: f64, pace: &str, extra: &str) -> String {
    GaussianHill::new(name)
        .seed(5)
        .duration(duration)
        .pace(pace)
        .default_objective()
        .then(extra)
        .toml()
}

/// `vbap run FILE --out OUT --quiet`, its errors kept for the test to read.
fn run_cmd(file: &Path, out: &Path) -> Command {
    let mut cmd = run_command(file, out);
    cmd.stderr(Stdio::piped());
    cmd
}

/// Every line of a CSV file is whole: it ends with a line break and has the header's
/// number of cells.
fn assert_whole_rows(path: &Path) {
    let text = read(path);
    assert!(
        text.ends_with('\n'),
        "{} ends mid-row: {:?}",
        path.display(),
        text.lines().last()
    );
    let mut lines = text.lines();
    let cells = lines.next().expect("a header").split(',').count();
    for (i, line) in lines.enumerate() {
        assert_eq!(
            line.split(',').count(),
            cells,
            "{} line {}: {line:?}",
            path.display(),
            i + 2
        );
    }
}

#[test]
fn a_mission_named_like_the_start_of_another_leaves_it_alone() {
    let tmp = TempDir::new("pfx");
    let short = unique_name("pfx");
    let long = format!("{short}_2");
    // The long-named mission runs paced (about 10 s of wall time).
    let long_file = write_mission(&tmp, "long.toml", &mission(&long, 20.0, "2.0", ""));
    let long_out = tmp.join("long");
    let mut long_run = spawn_run(&long_file, &long_out);
    wait_until(
        || line_count(&long_out.join("body.csv")) > 10,
        Duration::from_secs(60),
        "the long-named mission to get going",
    );
    let before = leftover_files(&long);
    assert!(
        before.len() > 10,
        "the running mission has its files: {before:?}"
    );
    // The short-named mission starts, runs and ends (cleaning its domain twice) meanwhile.
    let short_file = write_mission(
        &tmp,
        "short.toml",
        &mission(&short, 2.0, "\"lockstep\"", ""),
    );
    vbap_quiet("run", &short_file, &tmp.join("short"));
    assert!(
        leftover_files(&short).is_empty(),
        "{:?}",
        leftover_files(&short)
    );
    let gone: Vec<_> = before.iter().filter(|p| !p.exists()).collect();
    assert!(
        gone.is_empty(),
        "files of {long} removed by {short}: {gone:?}"
    );
    assert!(
        long_run.0.as_mut().unwrap().try_wait().unwrap().is_none(),
        "the long-named mission is still running"
    );
    let status = long_run.wait();
    assert!(status.success(), "{status}");
    let s = summary(&long_out);
    assert_eq!(s["vehicles_lost"], 0, "{s}");
    assert_eq!(s["ticks"], 400, "{s}");
    assert!(
        leftover_files(&long).is_empty(),
        "{:?}",
        leftover_files(&long)
    );
}

#[test]
fn two_starts_of_one_mission_at_once_one_runs_the_other_exits_2_and_writes_nothing() {
    let tmp = TempDir::new("twice");
    let name = unique_name("twice");
    // Paced, so the winner is still running when the loser is refused.
    let file = write_mission(&tmp, "m.toml", &mission(&name, 20.0, "4.0", ""));
    let (out_a, out_b) = (tmp.join("a"), tmp.join("b"));
    let mut a = ChildGuard(Some(run_cmd(&file, &out_a).spawn().unwrap()));
    let mut b = ChildGuard(Some(run_cmd(&file, &out_b).spawn().unwrap()));
    // The first of the two to end is the refused one; the other is still running then.
    let (mut loser, mut winner, loser_out, winner_out) = loop {
        if a.0.as_mut().unwrap().try_wait().unwrap().is_some() {
            break (a, b, out_a, out_b);
        }
        if b.0.as_mut().unwrap().try_wait().unwrap().is_some() {
            break (b, a, out_b, out_a);
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    assert!(
        winner.0.as_mut().unwrap().try_wait().unwrap().is_none(),
        "the other start is still running when the refused one has exited"
    );
    let output = loser.0.take().unwrap().wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains(&format!("mission \"{name}\" is already running (pid ")),
        "{stderr}"
    );
    assert!(
        !loser_out.exists(),
        "the refused start wrote into its --out: {:?}",
        std::fs::read_dir(&loser_out).map(|d| d.count())
    );
    let status = winner.wait();
    assert!(status.success(), "{status}");
    assert_eq!(summary(&winner_out)["vehicles_lost"], 0);
    assert!(
        leftover_files(&name).is_empty(),
        "{:?}",
        leftover_files(&name)
    );
    // The lock went with the winner: the mission starts again.
    vbap_quiet("run", &file, &tmp.join("again"));
}

#[test]
fn a_sigkilled_supervisor_leaves_no_files_no_processes_and_no_half_rows() {
    let tmp = TempDir::new("supkill");
    let name = unique_name("supkill");
    let file = write_mission(&tmp, "m.toml", &mission(&name, 300.0, "1.0", ""));
    let out = tmp.join("run");
    let mut run = spawn_run(&file, &out);
    wait_for_ticks(&out, 20);
    // One agent dies by SIGKILL first: its resources are left to the others to clean.
    let needle = format!("{} --id 2 --", out.join("mission.toml").display());
    let agent = processes_mentioning(&needle);
    assert_eq!(agent.len(), 1, "{agent:?}");
    assert!(vbap_ipc::process::sigkill(agent[0]));
    wait_until(
        || read(&out.join("events.jsonl")).contains("\"lost\""),
        Duration::from_secs(30),
        "vehicle 2 to be found dead",
    );
    assert!(!leftover_files(&name).is_empty());
    run.signal("KILL");
    let status = run.wait();
    assert_eq!(
        std::os::unix::process::ExitStatusExt::signal(&status),
        Some(9)
    );
    // The children end on their own (SIGTERM from the kernel), the last one cleans.
    let mission_path = out.join("mission.toml").display().to_string();
    wait_until(
        || processes_mentioning(&mission_path).is_empty(),
        Duration::from_secs(30),
        "the orphaned processes to end",
    );
    wait_until(
        || leftover_files(&name).is_empty(),
        Duration::from_secs(10),
        "the domain's files to be removed",
    );
    for f in ["body.csv", "vehicles.csv", "planner_inputs.csv"] {
        assert_whole_rows(&out.join(f));
    }
    for p in [
        "coordinator",
        "field_server",
        "vehicle_agent_0",
        "vehicle_agent_2",
    ] {
        let path = out.join(format!("logs/{p}.msgs.csv"));
        assert!(read(&path).ends_with('\n'), "{}", path.display());
    }
    // The coordinator ended as on Ctrl-C: its summary is written.
    assert!(out.join("summary.json").exists());
    // The killed supervisor's lock went with it: the mission starts again at once.
    let again = run_ok(
        vbap()
            .arg("run")
            .arg(&file)
            .arg("--duration")
            .arg("1")
            .arg("--pace")
            .arg("lockstep")
            .arg("--out")
            .arg(tmp.join("again"))
            .arg("--quiet"),
    );
    assert!(again.status.success());
    assert!(
        leftover_files(&name).is_empty(),
        "{:?}",
        leftover_files(&name)
    );
}

#[test]
fn a_sigkilled_agent_keeps_its_message_records_up_to_its_last_tick() {
    let tmp = TempDir::new("agentrec");
    let name = unique_name("agentrec");
    let extra = "[[faults]]\nkind = \"kill\"\nvehicle = 1\nat = 3.0\n";
    let file = write_mission(&tmp, "m.toml", &mission(&name, 6.0, "\"lockstep\"", extra));
    let out = tmp.join("run");
    vbap_quiet("run", &file, &out);
    // The last state of vehicle 1 the coordinator took off IPC...
    let last_state = msg_records(&out, "coordinator")
        .iter()
        .filter(|r| r.event == MsgEvent::Recv && r.hop == "state" && r.sender == Some(1))
        .filter_map(|r| r.tick)
        .max()
        .expect("states of vehicle 1");
    assert!(
        last_state >= 50,
        "vehicle 1 ran before its kill: {last_state}"
    );
    // ...needed the command of the tick before; the agent recorded it and flushed it at
    // its next wait: at most the records since that wait are lost.
    let agent = msg_records(&out, "vehicle_agent_1");
    let last_command = agent
        .iter()
        .filter(|r| r.event == MsgEvent::Recv && r.hop == "body")
        .filter_map(|r| r.tick)
        .max()
        .expect("the killed agent's records survived");
    assert!(
        last_command + 2 >= last_state,
        "records of vehicle 1 end at command {last_command}, its last state was of tick {last_state}"
    );
    assert!(read(&out.join("logs/vehicle_agent_1.msgs.csv")).ends_with('\n'));
    let s = summary(&out);
    assert_eq!(s["vehicles_lost"], 1, "{s}");
}

#[test]
fn message_records_have_their_own_switch_not_the_log_level() {
    let tmp = TempDir::new("records");
    let name = unique_name("records");
    let file = write_mission(&tmp, "m.toml", &mission(&name, 1.0, "\"lockstep\"", ""));
    // RUST_LOG=info keeps them.
    run_ok(
        vbap()
            .env("RUST_LOG", "info")
            .arg("run")
            .arg(&file)
            .arg("--out")
            .arg(tmp.join("info"))
            .arg("--quiet"),
    );
    let states = msg_records(&tmp.join("info"), "coordinator")
        .iter()
        .filter(|r| r.event == MsgEvent::Recv && r.hop == "state")
        .count();
    assert!(
        states >= 4 * 20,
        "{states} state records with RUST_LOG=info"
    );
    // VBAP_MSG_RECORDS=off turns them off.
    run_ok(
        vbap()
            .env("VBAP_MSG_RECORDS", "off")
            .arg("run")
            .arg(&file)
            .arg("--out")
            .arg(tmp.join("off"))
            .arg("--quiet"),
    );
    assert!(!tmp.join("off/logs/coordinator.msgs.csv").exists());
    assert!(tmp.join("off/summary.json").exists());
    // Anything else is refused before a process starts.
    let bad = vbap()
        .env("VBAP_MSG_RECORDS", "maybe")
        .arg("run")
        .arg(&file)
        .arg("--out")
        .arg(tmp.join("bad"))
        .arg("--quiet")
        .output()
        .unwrap();
    assert_eq!(bad.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&bad.stderr).contains("VBAP_MSG_RECORDS"));
    assert!(!tmp.join("bad").exists());
}

#[test]
fn ctrl_c_while_the_agents_start_stops_every_process_and_leaves_nothing() {
    let tmp = TempDir::new("intstart");
    let name = unique_name("intstart");
    let text = GaussianHill::new(&name)
        .duration(300.0)
        .pace("1.0")
        .count(48)
        .toml();
    let file = write_mission(&tmp, "m.toml", &text);
    let out = tmp.join("run");
    // Its log (info and up) goes to a file, for the message of a timeout.
    let log = tmp.join("vbap-run.stderr");
    let mut run = spawn_run_logged(&file, &out, &log);
    // Agent 0 is launched: the other agents are being launched or awaited (48 of them take
    // a while), which is when an interrupted start used to drop the children it had not
    // yet handed to a watcher, and the supervisor then waited for them for ever.
    let mission_path = out.join("mission.toml").display().to_string();
    wait_until(
        || processes_mentioning(&format!("{mission_path} --id 0 --")).len() == 1,
        Duration::from_secs(60),
        "agent 0 to be launched",
    );
    run.signal("INT");
    let pid = run.pid();
    let child = run.0.as_mut().expect("vbap run");
    wait_until_or(
        || child.try_wait().expect("polling vbap run").is_some(),
        Duration::from_secs(60),
        || {
            format!(
                "vbap run (pid {pid}) did not end within 60 s of SIGINT while its agents start\n\
                 its processes:\n{}\nits log:\n{}",
                process_report(&tmp.path.to_string_lossy()),
                std::fs::read_to_string(&log).unwrap_or_default()
            )
        },
    );
    wait_until(
        || processes_mentioning(&mission_path).is_empty(),
        Duration::from_secs(30),
        "every process of the run to end",
    );
    wait_until(
        || leftover_files(&name).is_empty(),
        Duration::from_secs(10),
        "the domain's files to be removed",
    );
}
