//! A mission spread over hosts (`vbap run --hosts --host`, `vbap_bridge`): each host in
//! its own network namespace with a private /dev/shm and /tmp/iceoryx2, joined only by
//! veth links to a switch namespace (10.88.<k>.0/24). Needs root (CI runs as root): when
//! namespaces cannot be made the tests FAIL.

use std::process::Command;
use std::time::Duration;

use tests::netns::*;
use tests::*;

#[test]
fn three_hosts_in_lockstep_equal_the_simulator_and_leave_nothing() {
    let tmp = TempDir::new("hosts");
    let net = Net::new();
    let name = unique_name("hosts");
    let file = write(&tmp, "m.toml", &hosts_mission(&name, 6.0));
    let hosts = write(&tmp, "hosts.toml", &net.hosts_file());
    vbap_quiet("sim", &file, &tmp.join("sim"));
    let pcap = tmp.join("hosts.pcap");
    let capture = net.capture(&pcap, &tmp.join("tcpdump.log"));
    // Any order: the glider hosts first, then the shore they wait for.
    let mut a = start_host(&net, &tmp, &file, &hosts, "glider_a");
    let mut b = start_host(&net, &tmp, &file, &hosts, "glider_b");
    let mut shore = start_host(&net, &tmp, &file, &hosts, "shore");
    wait_hosts_ok(&tmp, &mut shore, &mut a, &mut b);
    let run = tmp.join("shore");
    assert_same_tracks(&tmp.join("sim"), &run);
    let s = summary(&run);
    assert_eq!(s["mode"], "multi-process");
    assert_eq!(s["messages"]["rejected"], 0);
    // Over plain TCP (`insecure = true`) the capture between the hosts reads the
    // mission's name and its frames in clear: what hosts_tls.rs's capture must not.
    drop(capture);
    let captured = std::fs::read(&pcap).unwrap();
    for clear in [name.as_bytes(), b"VBAPW3", b"vbap.VehicleState"] {
        assert!(
            holds(&captured, clear),
            "{:?} in the plain-TCP capture",
            String::from_utf8_lossy(clear)
        );
    }
    // The other hosts' message records, merged (copied as hosts/<host>/logs): the hops
    // that crossed hosts apart from the local ones.
    for h in ["glider_a", "glider_b"] {
        assert!(
            tmp.join(h).join("logs/vbap_bridge.jsonl").exists(),
            "{h} has its logs"
        );
        let to = run.join("hosts").join(h).join("logs");
        std::fs::create_dir_all(&to).unwrap();
        for e in std::fs::read_dir(tmp.join(h).join("logs"))
            .unwrap()
            .flatten()
        {
            std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
        }
    }
    let out = run_ok(vbap().arg("analyze").arg(&run).arg("--json"));
    let r: serde_json::Value = serde_json::from_slice(&out.stdout).expect("analyze --json");
    for hop in ["state@hosts", "body@hosts", "field_request", "field_reply"] {
        let p50 = r["hops"][hop]["transport_us"]["p50"].as_f64();
        assert!(p50.is_some_and(|v| v > 0.0), "hop {hop} in {}", r["hops"]);
    }
    // Every vehicle is on a glider host: no state stayed on the shore.
    assert!(r["hops"]["state"].is_null(), "{}", r["hops"]);
    assert_clean(net, &tmp);
}

/// The last line of host `h`'s bridge log (its counts).
fn bridge_done(tmp: &TempDir, h: &str) -> serde_json::Value {
    let log = read(&tmp.join(h).join("logs/vbap_bridge.jsonl"));
    let done = log
        .lines()
        .rfind(|l| l.contains("bridge done"))
        .unwrap_or_else(|| panic!("{h}'s bridge's last line in {log}"));
    serde_json::from_str(done).unwrap()
}

#[test]
fn frames_lost_with_a_link_are_put_again_and_the_run_still_equals_the_simulator() {
    // Zenoh is reliable only within one link: a link that closes loses what its queues
    // held. Here glider_a's bridge loses its 5th state frame and the shore's its 8th body
    // command, as such a link would: without the bridges putting again what went
    // unanswered, lockstep would wait for them until the silence limit lost the vehicles.
    let tmp = TempDir::new("hostslose");
    let net = Net::new();
    let name = unique_name("hostslose");
    let file = write(&tmp, "m.toml", &hosts_mission(&name, 3.0));
    let hosts = write(&tmp, "hosts.toml", &net.hosts_file());
    vbap_quiet("sim", &file, &tmp.join("sim"));
    let lose = "VBAP_BRIDGE_LOSE";
    let mut shore = start_host_with(&net, &tmp, &file, &hosts, "shore", &[(lose, "body:8")]);
    let mut a = start_host_with(&net, &tmp, &file, &hosts, "glider_a", &[(lose, "states:5")]);
    let mut b = start_host(&net, &tmp, &file, &hosts, "glider_b");
    wait_hosts_ok(&tmp, &mut shore, &mut a, &mut b);
    let run = tmp.join("shore");
    assert_same_tracks(&tmp.join("sim"), &run);
    let s = summary(&run);
    assert_eq!(s["vehicles_lost"], 0, "{s}");
    assert_eq!(s["messages"]["rejected"], 0, "{s}");
    for h in ["shore", "glider_a"] {
        let log = read(&tmp.join(h).join("logs/vbap_bridge.jsonl"));
        assert_eq!(
            log.matches("a frame lost on purpose").count(),
            1,
            "{h}: one frame lost"
        );
        let done = bridge_done(&tmp, h);
        assert!(
            done["fields"]["repeated"].as_u64() >= Some(1),
            "{h} put its frame again: {done}"
        );
    }
    // While the shore waited for glider_a's lost states, glider_b had no new command and
    // put its states again: the shore dropped those copies, never published them twice.
    let shore_done = bridge_done(&tmp, "shore");
    assert!(
        shore_done["fields"]["duplicates"].as_u64() >= Some(1),
        "the shore dropped glider_b's copies: {shore_done}"
    );
    assert_clean(net, &tmp);
}

#[test]
fn a_glider_hosts_bridge_killed_loses_its_vehicles_and_restarted_they_rejoin() {
    let tmp = TempDir::new("hostskill");
    let net = Net::new();
    let name = unique_name("hostskill");
    let text = rejoin_mission(&name, 400.0, "").replace("count = 6", "count = 4");
    let file = write(&tmp, "m.toml", &text);
    let hosts = write(&tmp, "hosts.toml", &net.hosts_file());
    let mut shore = start_host(&net, &tmp, &file, &hosts, "shore");
    let mut a = start_host(&net, &tmp, &file, &hosts, "glider_a");
    let mut b = start_host(&net, &tmp, &file, &hosts, "glider_b");
    let out = tmp.join("shore");
    wait_for_ticks(&out, 50);
    // glider_a's bridge, found by its command line (its host name and our temp dir).
    let needle = format!(
        "--host glider_a --mission {}",
        tmp.join("glider_a").display()
    );
    let bridge = processes_mentioning(&needle);
    assert_eq!(bridge.len(), 1, "glider_a's bridge: {bridge:?}");
    let _ = Command::new("kill")
        .args(["-KILL", &bridge[0].to_string()])
        .status();
    let events = || read(&out.join("events.jsonl"));
    let count = |kind: &str| {
        events()
            .lines()
            .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
            .filter(|e| e["kind"] == kind && e["vehicle"].as_u64().is_some_and(|v| v < 2))
            .count()
    };
    wait_until(
        || count("lost") >= 2,
        Duration::from_secs(60),
        "glider_a's vehicles lost",
    );
    // Its supervisor restarts the bridge (on failure, after the backoff): they rejoin.
    wait_until(
        || count("rejoin") >= 2,
        Duration::from_secs(90),
        "glider_a's vehicles back",
    );
    let ev: Vec<serde_json::Value> = events()
        .lines()
        .filter_map(|l| serde_json::from_str(l).ok())
        .collect();
    let lost: Vec<_> = ev.iter().filter(|e| e["kind"] == "lost").collect();
    assert_eq!(
        lost.len(),
        2,
        "only glider_a's two vehicles are lost: {lost:?}"
    );
    for e in &lost {
        assert_eq!(e["detail"]["cause"], "host unreachable", "{e}");
        assert_eq!(e["detail"]["by"], "bridge", "{e}");
    }
    // The mission runs to its end on every host.
    for (h, child) in [
        ("shore", &mut shore),
        ("glider_a", &mut a),
        ("glider_b", &mut b),
    ] {
        let status = child.wait();
        assert!(status.success(), "host {h}: {status:?}");
    }
    assert_eq!(summary(&out)["mode"], "multi-process");
    assert_clean(net, &tmp);
}
