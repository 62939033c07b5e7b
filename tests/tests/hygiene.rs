//! Input hygiene: a rogue process publishes malformed, foreign and replayed messages into a
//! running mission; receivers reject and count them, and nothing reaches the estimate.

use std::time::Duration;

use tests::*;
use vbap_ipc::msg::agent_to_coordinator::VehicleState;
use vbap_ipc::msg::coordinator_to_agent::BodyCommand;
use vbap_ipc::msg::Header;
use vbap_ipc::topics::{Domain, Limits};

fn log_count(path: &std::path::Path, what: &str) -> usize {
    std::fs::read_to_string(path)
        .map(|t| t.matches(what).count())
        .unwrap_or(0)
}

#[test]
fn rogue_messages_are_rejected_counted_and_never_reach_the_estimate() {
    let tmp = TempDir::new("rogue");
    let name = unique_name("rogue");
    let text = format!(
        r#"
[mission]
name = "{name}"
duration = 10000.0
dt = 0.05
pace = 1.0
[field]
center = [20.0, 10.0]
amplitude = 10.0
width = 15.0
noise_std = 0.1
[vehicles]
count = 4
damping = 5.0
[formation]
alpha = 60.0
[body]
v_u = 10.0
"#
    );
    let file = write_mission(&tmp, "m.toml", &text);
    let out = tmp.join("run");
    let mut run = spawn_run(&file, &out);
    wait_until(
        || {
            std::fs::read_to_string(out.join("body.csv"))
                .map(|t| t.lines().count() > 5)
                .unwrap_or(false)
        },
        Duration::from_secs(60),
        "the run to get going",
    );
    {
        let domain = Domain::new(&name).unwrap();
        let limits = Limits::for_fleet(4);
        let node = domain.node("rogue").unwrap();
        // Into the agents: a foreign sender, a non-finite body, a replayed sequence number.
        let body_pub = domain
            .body_service(&node, &limits)
            .unwrap()
            .publisher_builder()
            .create()
            .unwrap();
        let mut wakes = Vec::new();
        for id in 0..4 {
            wakes.push(
                domain
                    .vehicle_wake(&node, id, &limits)
                    .unwrap()
                    .notifier_builder()
                    .create()
                    .unwrap(),
            );
        }
        let mut fake = BodyCommand::empty();
        fake.header = Header {
            sender: 7,
            flags: 0,
            tick: 1,
            t: 0.05,
            seq: 1_000_000,
            sent_ns: 0,
        };
        body_pub.send_copy(fake).unwrap();
        fake.header.sender = Header::COORDINATOR;
        fake.r = [f64::NAN, 0.0, 0.0];
        body_pub.send_copy(fake).unwrap();
        fake.r = [0.0; 3];
        fake.header.seq = 1;
        body_pub.send_copy(fake).unwrap();
        for w in &wakes {
            w.notify().unwrap();
        }
        // Into the coordinator: take over a dead vehicle's service and send garbage.
        let needle = format!("{} --id 3 --", out.join("mission.toml").display());
        let pid = processes_mentioning(&needle)[0];
        assert!(std::process::Command::new("kill")
            .args(["-9", &pid.to_string()])
            .status()
            .unwrap()
            .success());
        wait_until(
            || read(&out.join("events.jsonl")).contains("\"lost\""),
            Duration::from_secs(30),
            "vehicle 3 to be found dead",
        );
        let state_service = domain.state_service(&node, 3, &limits).unwrap();
        let mut state_pub = None;
        wait_until(
            || {
                state_pub = state_service.publisher_builder().create().ok();
                state_pub.is_some()
            },
            Duration::from_secs(10),
            "the dead vehicle's service to be free",
        );
        let state_pub = state_pub.unwrap();
        let wake = domain
            .coordinator_wake(&node, &limits)
            .unwrap()
            .notifier_builder()
            .create()
            .unwrap();
        let good = VehicleState {
            header: Header {
                sender: 3,
                flags: 0,
                tick: 1,
                t: 0.05,
                seq: 10,
                sent_ns: 0,
            },
            pid: 1,
            incarnation: 0,
            position: [0.0; 3],
            velocity: [0.0; 3],
            commands_read: 0,
            believed: [0.0; 3],
            water_velocity: [0.0; 3],
            current: [0.0; 3],
        };
        let mut nan = good;
        nan.velocity[1] = f64::NAN;
        let mut foreign = good;
        foreign.header.sender = 2;
        foreign.header.seq = 11;
        let mut future = good;
        future.header.tick = u64::MAX / 2;
        future.header.seq = 12;
        for s in [nan, foreign, future] {
            state_pub.send_copy(s).unwrap();
            wake.notify().unwrap();
        }
        wait_until(
            || log_count(&out.join("logs/coordinator.jsonl"), "rejected a state") >= 3,
            Duration::from_secs(30),
            "the coordinator to reject the rogue states",
        );
        wait_until(
            || {
                (0..3).all(|i| {
                    log_count(
                        &out.join(format!("logs/vehicle_agent_{i}.jsonl")),
                        "rejected a body command",
                    ) >= 3
                })
            },
            Duration::from_secs(30),
            "the agents to reject the rogue commands",
        );
    }
    run.signal("INT");
    run.wait();
    let s = summary(&out);
    assert!(s["messages"]["rejected"].as_u64().unwrap() >= 3, "{s}");
    assert!(s["agent_rejected"].as_u64().unwrap() >= 9, "{s}");
    // Nothing non-finite reached the estimate or the body.
    for line in read(&out.join("body.csv")).lines().skip(1) {
        assert!(
            line.split(',')
                .all(|v| v.parse::<f64>().is_ok_and(f64::is_finite)),
            "non-finite body row: {line}"
        );
    }
    assert!(
        leftover_files(&name).is_empty(),
        "{:?}",
        leftover_files(&name)
    );
}
