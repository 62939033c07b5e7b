//! Faults of the shore across hosts (network namespaces, root: see `tests::netns`): the
//! shore host lost to the network (gliders hold, resume when it returns), the shore's
//! bridge killed alone (the remote vehicles rejoin through the restarted one), a glider
//! host off the network when the final command is published (it gets it when it returns;
//! never returning, the shore ends after `final_wait` naming it), and a placement that
//! cannot work (exit 2, the key named).

use std::path::PathBuf;
use std::process::Command;
use std::time::{Duration, Instant};

use tests::netns::*;
use tests::*;

/// The six vehicles of `rejoin_mission`: 0, 1 on glider_a, 2, 3 on glider_b, 4, 5 on the
/// shore beside the coordinator (it has vehicles of its own while the others are away).
const SHORE_VEHICLES: &str = "vehicles = [4, 5]";

/// The events of kind `kind` in the shore's events.jsonl, of the glider hosts' vehicles.
fn events(out: &std::path::Path, kind: &str) -> Vec<serde_json::Value> {
    read(&out.join("events.jsonl"))
        .lines()
        .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
        .filter(|e| e["kind"] == kind && e["vehicle"].as_u64().is_some_and(|v| v < 4))
        .collect()
}

/// Ticks of vehicle `v` in vehicles.csv (the coordinator's record of its states).
fn ticks_of(out: &std::path::Path, v: u64) -> Vec<u64> {
    let mut r = csv::Reader::from_path(out.join("vehicles.csv")).expect("vehicles.csv");
    let h = r.headers().unwrap().clone();
    let col = |name: &str| h.iter().position(|c| c == name).expect(name);
    let (tick, id) = (col("k"), col("id"));
    r.records()
        .flatten()
        .filter(|rec| rec[id].parse::<u64>().ok() == Some(v))
        .filter_map(|rec| rec[tick].parse().ok())
        .collect()
}

fn wait_all(children: Vec<(&str, &mut ChildGuard)>) {
    for (h, child) in children {
        let status = child.wait();
        assert!(status.success(), "host {h}: {status:?}");
    }
}

/// The three hosts of a paced (2× real time) rejoin mission of `duration` s, 40 ticks in.
///
/// Fields drop in this order: the hosts' processes first, then the directory (which kills
/// every process still mentioning it: a bridge or agent left inside a namespace), then the
/// network, with nothing of the test still running in it.
struct Paced {
    shore: ChildGuard,
    a: ChildGuard,
    b: ChildGuard,
    /// The shore's run directory.
    out: PathBuf,
    tmp: TempDir,
    net: Net,
}

impl Paced {
    fn start(tag: &str, duration: f64) -> Self {
        Self::start_with(tag, duration, "")
    }

    /// [`Paced::start`] with `top` put before the hosts file's tables (e.g. `final_wait`).
    fn start_with(tag: &str, duration: f64, top: &str) -> Self {
        let tmp = TempDir::new(tag);
        let net = Net::new();
        let text = rejoin_mission(&unique_name(tag), duration, "")
            .replace("tolerance = 1.0", "tolerance = 1.0\npace = 2.0");
        let file = write(&tmp, "m.toml", &text);
        let hosts_text = format!("{top}{}", net.hosts_file_with(SHORE_VEHICLES));
        let hosts = write(&tmp, "hosts.toml", &hosts_text);
        let shore = start_host(&net, &tmp, &file, &hosts, "shore");
        let a = start_host(&net, &tmp, &file, &hosts, "glider_a");
        let b = start_host(&net, &tmp, &file, &hosts, "glider_b");
        let out = tmp.join("shore");
        wait_for_ticks(&out, 40);
        Self {
            shore,
            a,
            b,
            out,
            net,
            tmp,
        }
    }

    /// Waits at most `timeout` for the three hosts' `vbap run`, each to succeed; past it,
    /// fails naming the hosts still running (the test's directory, dropped, kills every
    /// process of the run: nothing is left behind).
    fn wait_hosts_within(&mut self, timeout: Duration) {
        let start = Instant::now();
        let mut hosts = [
            ("shore", &mut self.shore),
            ("glider_a", &mut self.a),
            ("glider_b", &mut self.b),
        ];
        let mut status: [Option<std::process::ExitStatus>; 3] = [None; 3];
        while status.iter().any(Option::is_none) {
            for (i, (_, child)) in hosts.iter_mut().enumerate() {
                if status[i].is_none() {
                    let c = child.0.as_mut().expect("a running host");
                    status[i] = c.try_wait().expect("waiting for a host");
                }
            }
            if start.elapsed() > timeout && status.iter().any(Option::is_none) {
                let running: Vec<&str> = hosts
                    .iter()
                    .zip(&status)
                    .filter(|(_, s)| s.is_none())
                    .map(|((h, _), _)| *h)
                    .collect();
                // The test's directory kills every process of the run as it drops.
                panic!("hosts {running:?} still running {timeout:?} after the wait began");
            }
            std::thread::park_timeout(Duration::from_millis(100));
        }
        for ((h, child), s) in hosts.iter_mut().zip(status) {
            child.0 = None;
            let s = s.expect("ended");
            assert!(s.success(), "host {h}: {s:?}");
        }
    }

    /// Waits for the three hosts' `vbap run`, each to succeed.
    fn wait_hosts(&mut self) {
        wait_all(vec![
            ("shore", &mut self.shore),
            ("glider_a", &mut self.a),
            ("glider_b", &mut self.b),
        ]);
    }
}

#[test]
fn the_shore_lost_to_the_network_makes_gliders_hold_and_they_resume_when_it_returns() {
    // Paced: a glider hears nothing and holds station, as when the coordinator dies.
    let mut p = Paced::start("hostslost", 40.0);
    p.net.link("shore", false);
    let cut = Instant::now();
    // The glider hosts' vehicles are lost on the shore (its links' lease, 1 s) ...
    wait_until(
        || events(&p.out, "lost").len() >= 4,
        Duration::from_secs(30),
        "the glider hosts' vehicles lost on the shore",
    );
    // ... and hold station on their hosts (their own logs).
    let holding = |h: &str, v: u32| {
        read(&p.tmp.join(h).join(format!("logs/vehicle_agent_{v}.jsonl")))
            .contains("coordinator silent: holding station")
    };
    wait_until(
        || holding("glider_a", 0) && holding("glider_b", 3),
        Duration::from_secs(30),
        "the gliders holding station",
    );
    // Away for at least 4 s (past the lease on both sides), then back.
    while cut.elapsed() < Duration::from_secs(4) {
        std::thread::park_timeout(Duration::from_millis(100));
    }
    p.net.link("shore", true);
    wait_until(
        || events(&p.out, "rejoin").len() >= 4,
        Duration::from_secs(60),
        "the glider hosts' vehicles rejoined",
    );
    p.wait_hosts();
    // Found by the bridge's liveliness ("host unreachable") or, when the coordinator's own
    // scan sees the vehicle's proxy node go first, as "process gone": either is this loss.
    for e in events(&p.out, "lost") {
        let cause = e["detail"]["cause"].as_str().unwrap_or_default();
        assert!(["host unreachable", "process gone"].contains(&cause), "{e}");
    }
    // The truth of the run: every vehicle's states reach the coordinator again after the
    // outage, up to the mission's end (vehicles.csv), and the shore's own never stopped.
    let last = ticks_of(&p.out, 4).into_iter().max().unwrap();
    for v in 0..6 {
        let ticks = ticks_of(&p.out, v);
        assert!(
            ticks.iter().any(|&t| t + 20 >= last),
            "vehicle {v} recorded near the end (last tick {last}): {:?}",
            ticks.last()
        );
    }
    let s = summary(&p.out);
    assert_eq!(s["mode"], "multi-process");
    assert!(s["vehicles_lost"].as_u64().unwrap() >= 4, "{s}");
    assert_clean(p.net, &p.tmp);
}

#[test]
fn the_shores_bridge_restarted_alone_lets_the_remote_vehicles_rejoin() {
    // Paced, so the mission outlasts the bridge's restart (in lockstep the shore's own two
    // vehicles ran it to its end first).
    let mut p = Paced::start("hostsbridge", 60.0);
    let needle = format!("--host shore --mission {}", p.out.display());
    let bridge = processes_mentioning(&needle);
    assert_eq!(bridge.len(), 1, "the shore's bridge: {bridge:?}");
    let _ = Command::new("kill")
        .args(["-KILL", &bridge[0].to_string()])
        .status();
    // Its proxy nodes die with it: the coordinator loses the remote vehicles ...
    wait_until(
        || events(&p.out, "lost").len() >= 4,
        Duration::from_secs(60),
        "the remote vehicles lost",
    );
    // ... and the shore's supervisor restarts the bridge: they rejoin through it.
    wait_until(
        || events(&p.out, "rejoin").len() >= 4,
        Duration::from_secs(90),
        "the remote vehicles back",
    );
    p.wait_hosts();
    let log = read(&p.out.join("logs/vbap_bridge.jsonl"));
    assert!(log.contains("a restarted bridge"), "{log}");
    assert_eq!(summary(&p.out)["mode"], "multi-process");
    assert_clean(p.net, &p.tmp);
}

/// Waits for the last ticks of `p`'s mission (160 ticks: past 150 rows of body.csv), then
/// takes glider_a's link down, so the final command is published while it is away.
fn glider_a_off_before_the_end(p: &Paced) {
    let body = p.out.join("body.csv");
    wait_until(
        || line_count(&body) > 150,
        Duration::from_secs(60),
        "the mission's last ticks",
    );
    p.net.link("glider_a", false);
}

/// The lines of JSON-lines log `path` (none while it does not exist).
fn log_lines(path: &std::path::Path) -> Vec<String> {
    std::fs::read_to_string(path)
        .unwrap_or_default()
        .lines()
        .map(str::to_string)
        .collect()
}

#[test]
fn a_glider_host_off_the_network_at_the_final_command_gets_it_when_it_returns() {
    // Paced, 160 ticks at 2× real time (8 s); glider_a's link goes down 10 ticks (0.5 s)
    // before the end, so the final command is published while it is away.
    let mut p = Paced::start("hostsfinal", 16.0);
    glider_a_off_before_the_end(&p);
    let shore_bridge = p.out.join("logs/vbap_bridge.jsonl");
    let a_bridge = p.tmp.join("glider_a").join("logs/vbap_bridge.jsonl");
    wait_until(
        || {
            log_lines(&shore_bridge)
                .iter()
                .any(|l| l.contains("the mission's final command is forwarded"))
        },
        Duration::from_secs(60),
        "the shore's bridge forwarding the final command",
    );
    // Away until glider_a's own link to the shore is given up (its lease, 1 s): a final
    // command queued on the old connection is lost with it.
    wait_until(
        || {
            log_lines(&a_bridge)
                .iter()
                .any(|l| l.contains("host gone") && l.contains("\"host\":\"shore\""))
        },
        Duration::from_secs(30),
        "glider_a losing the shore",
    );
    p.net.link("glider_a", true);
    // Every host ends by itself: glider_a's agents on the final command, not by a bound.
    p.wait_hosts_within(Duration::from_secs(60));
    for v in [0, 1] {
        let log = read(
            &p.tmp
                .join(&format!("glider_a/logs/vehicle_agent_{v}.jsonl")),
        );
        assert!(log.contains("mission finished"), "vehicle {v}: {log}");
    }
    let log = read(&shore_bridge);
    for h in ["glider_a", "glider_b"] {
        assert!(
            log.lines()
                .any(|l| l.contains("final command acknowledged") && l.contains(h)),
            "{h} acknowledged the final command: {log}"
        );
    }
    assert!(
        log.contains("every glider host has the final command"),
        "{log}"
    );
    assert_eq!(summary(&p.out)["mode"], "multi-process");
    assert_clean(p.net, &p.tmp);
}

/// Waits at most `timeout` for `child` to end; its status, None when it still runs.
fn exit_within(child: &mut ChildGuard, timeout: Duration) -> Option<std::process::ExitStatus> {
    let start = Instant::now();
    let c = child.0.as_mut().expect("a running host");
    loop {
        if let Some(s) = c.try_wait().expect("waiting for a host") {
            child.0 = None;
            return Some(s);
        }
        if start.elapsed() > timeout {
            return None;
        }
        std::thread::park_timeout(Duration::from_millis(100));
    }
}

/// A process that keeps one CPU busy until its guard drops.
fn busy_loop() -> ChildGuard {
    ChildGuard(Some(
        Command::new("sh")
            .args(["-c", "while :; do :; done"])
            .spawn()
            .expect("starting a busy loop"),
    ))
}

#[test]
fn the_shore_ends_after_final_wait_naming_a_glider_host_that_never_returned() {
    // final_wait 10 s; glider_a's link goes down 10 ticks before the end and stays down.
    // glider_b's acknowledgement must come within final_wait although the shore's Zenoh
    // gives up the dead link meanwhile (docs/design/hosts.md, "A dead link never blocks a
    // healthy one").
    let mut p = Paced::start_with("hostsfinalwait", 16.0, "final_wait = 10.0\n");
    // Both CPUs kept busy by other processes while the link is cut (issue 32: on a busy
    // machine the shore's Zenoh once closed the healthy glider_b's link too).
    let busy: Vec<ChildGuard> = (0..2).map(|_| busy_loop()).collect();
    glider_a_off_before_the_end(&p);
    let shore = exit_within(&mut p.shore, Duration::from_secs(60))
        .expect("the shore still running 60 s after glider_a's link went down");
    drop(busy);
    assert!(shore.success(), "shore: {shore:?}");
    // A dead link never blocks a healthy one: glider_b's vehicles were never lost.
    let lost_b: Vec<_> = events(&p.out, "lost")
        .into_iter()
        .filter(|e| e["vehicle"].as_u64().is_some_and(|v| v >= 2))
        .collect();
    assert!(lost_b.is_empty(), "glider_b's vehicles lost: {lost_b:?}");
    let log = read(&p.out.join("logs/vbap_bridge.jsonl"));
    let never: Vec<&str> = log
        .lines()
        .filter(|l| l.contains("final command not acknowledged"))
        .collect();
    assert_eq!(never.len(), 1, "{log}");
    assert!(
        never[0].contains("glider_a") && !never[0].contains("glider_b"),
        "{}",
        never[0]
    );
    // glider_b's acknowledgement came (it is not named above) and its link held.
    assert!(
        log.lines()
            .any(|l| l.contains("final command acknowledged") && l.contains("glider_b")),
        "{log}"
    );
    // glider_b had it and ended; glider_a never will by itself (its agents hold station):
    // its supervisor is stopped as a user would (SIGTERM), and nothing is left behind.
    assert!(exit_within(&mut p.b, Duration::from_secs(30)).is_some_and(|s| s.success()));
    let a_run = processes_mentioning(&format!("--host glider_a --out {}", p.tmp.path.display()))
        .into_iter()
        .filter(|pid| {
            std::fs::read_to_string(format!("/proc/{pid}/comm")).is_ok_and(|c| c.trim() == "vbap")
        })
        .collect::<Vec<u32>>();
    assert_eq!(a_run.len(), 1, "glider_a's vbap run: {a_run:?}");
    let _ = Command::new("kill")
        .args(["-TERM", &a_run[0].to_string()])
        .status();
    assert!(
        exit_within(&mut p.a, Duration::from_secs(30)).is_some(),
        "glider_a's run ends on SIGTERM"
    );
    assert_clean(p.net, &p.tmp);
}

#[test]
fn a_placement_that_cannot_work_exits_2_naming_the_key() {
    let tmp = TempDir::new("hostsbad");
    let name = unique_name("hostsbad");
    let file = write(&tmp, "m.toml", &hosts_mission(&name, 1.0));
    let bad = [
        (
            "[hosts.shore]\nendpoint = \"tcp/10.1.0.1:7447\"\nprocesses = [\"coordinator\"]\n\
             [hosts.g]\nendpoint = \"tcp/10.1.0.2:7447\"\nprocesses = [\"field_server\"]\nvehicles = [0, 1, 2, 3]\n",
            "hosts: the \"field_server\" must run on the coordinator's host",
        ),
        (
            "[hosts.shore]\nendpoint = \"tcp/0.0.0.0:7447\"\nprocesses = [\"coordinator\", \"field_server\"]\n\
             [hosts.g]\nendpoint = \"tcp/10.1.0.2:7447\"\nvehicles = [0, 1, 2, 3]\n",
            "hosts.shore.endpoint",
        ),
        (
            "[hosts.shore]\nendpoint = \"tcp/10.1.0.1:7447\"\nprocesses = [\"coordinator\", \"field_server\"]\n\
             [hosts.g]\nendpoint = \"tcp/10.1.0.2:7447\"\nvehicles = [0, 1, 2]\n",
            "vehicle 3 is on no host",
        ),
    ];
    for (i, (text, want)) in bad.iter().enumerate() {
        let hosts = write(&tmp, &format!("h{i}.toml"), text);
        let err = refused_hosts_file(&file, &hosts, &tmp.join(&format!("run{i}")), want);
        assert!(err.contains(&format!("h{i}.toml")), "the file named: {err}");
    }
    assert_nothing_left(&name, &tmp);
}
