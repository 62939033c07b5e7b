//! Unit tests of the analysis: records of both formats read into the same figures.

use std::path::Path;

use vbap_wire::rundir::{RunDir, Summary};

use super::plots::{self, ccdf_points, cdf_points};
use super::*;

#[test]
fn utc_timestamps_parse() {
    assert_eq!(parse_utc("1970-01-01T00:00:00Z"), Some(0.0));
    let t = parse_utc("2026-12-01T17:24:09.458255Z").unwrap();
    // 2026-12-01 is day 20788 since the epoch.
    assert!((t - (20_788.0 * 86_400.0 + 17.0 * 3600.0 + 24.0 * 60.0 + 9.458255)).abs() < 1e-6);
    assert_eq!(parse_utc("2000-03-01T00:00:01.5Z"), Some(951_868_801.5));
    assert_eq!(parse_utc("2024-02-29T23:59:59Z"), Some(1_709_251_199.0));
    assert_eq!(parse_utc("2024-02-29 23:59:59"), None);
    assert_eq!(parse_utc("not a time"), None);
    assert_eq!(parse_utc("2026-13-01T00:00:00Z"), None);
}

/// The state hop of the records both test logs hold: 3 received, 1 lost by the link, 1
/// held 50 ms, 1 delivered at once; plus the overflow drop of the agent's log.
fn assert_state_hop(r: &Report) {
    let state = &r.hops["state"];
    assert_eq!(
        (
            state.received,
            state.delivered,
            state.dropped_injected,
            state.dropped_overflow
        ),
        (3, 2, 1, 1)
    );
    assert_eq!((state.injected_ms.p50, state.injected_ms.max), (0.0, 50.0));
    assert_eq!(state.transport_us.max, 7.0);
}

fn write_logs(dir: &Path) {
    std::fs::create_dir_all(dir.join("logs")).unwrap();
    let t0: u64 = 1_795_437_897_283_832_923;
    let mut agent = String::new();
    agent.push_str("{\"timestamp\":\"x\",\"level\":\"INFO\",\"fields\":{\"message\":\"agent up\"},\"target\":\"vehicle_agent::run\"}\n");
    for k in 0..5u64 {
        let sent = t0 + k * 1_000_000;
        let recv = sent + 20_000 + 5_000_000 * u64::from(k == 3);
        let inj = if k == 3 { ",\"injected_ms\":5.0" } else { "" };
        agent.push_str(&format!(
            "{{\"timestamp\":\"x\",\"level\":\"DEBUG\",\"fields\":{{\"message\":\"recv\",\"hop\":\"body\",\"sender\":4294967294,\"receiver\":0,\"tick\":{k},\"seq\":{},\"sent_ns\":{sent},\"recv_ns\":{recv}{inj}}},\"target\":\"vbap::msg\"}}\n",
            k + 1
        ));
    }
    agent.push_str("{\"timestamp\":\"x\",\"level\":\"DEBUG\",\"fields\":{\"message\":\"drop\",\"hop\":\"body\",\"reason\":\"injected\",\"tick\":6},\"target\":\"vbap::msg\"}\n");
    agent.push_str("{\"timestamp\":\"x\",\"level\":\"DEBUG\",\"fields\":{\"message\":\"drop\",\"hop\":\"state\",\"reason\":\"overflow\",\"tick\":6},\"target\":\"vbap::msg\"}\n");
    agent.push_str("not json vbap::msg\n");
    std::fs::write(dir.join("logs/vehicle_agent_0.jsonl"), agent).unwrap();
    // The coordinator's format: receptions on arrival, then the link model's verdict.
    let mut coord = String::new();
    for k in 0..3u64 {
        coord.push_str(&format!(
            "{{\"fields\":{{\"message\":\"recv\",\"hop\":\"state\",\"sender\":0,\"tick\":{k},\"seq\":{k},\"sent_ns\":{},\"recv_ns\":{}}},\"target\":\"vbap::msg\"}}\n",
            t0 + k,
            t0 + k + 7_000
        ));
    }
    coord.push_str("{\"fields\":{\"message\":\"held\",\"hop\":\"state_link\",\"sender\":0,\"tick\":0,\"injected_ms\":50.0},\"target\":\"vbap::msg\"}\n");
    coord.push_str("{\"fields\":{\"message\":\"drop\",\"hop\":\"state\",\"sender\":0,\"tick\":1,\"reason\":\"loss\"},\"target\":\"vbap::msg\"}\n");
    std::fs::write(dir.join("logs/coordinator.jsonl"), coord).unwrap();
}

#[test]
fn latency_drops_and_loops_from_logs() {
    let root = std::env::temp_dir().join(format!("vbap-analyze-unit-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    write_logs(&root);
    let dir = RunDir { root: root.clone() };
    let (r, d) = compute(&dir).unwrap();
    let body = &r.hops["body"];
    assert_eq!(body.delivered, 5);
    assert_eq!(body.dropped_injected, 1);
    assert_state_hop(&r);
    assert!(!r.hops.contains_key("state_link"));
    // 20 µs each, exactly (integer subtraction), the injected 5 ms taken out.
    assert!(d.transport_us["body"]
        .iter()
        .all(|&v| (v - 20.0).abs() < 1e-9));
    assert_eq!(body.injected_ms.max, 5.0);
    assert_eq!(r.unparsed, 1);
    // Publications every 1 ms; receptions too, except around the delayed one.
    let c = &r.loops["coordinator"];
    assert_eq!(c.period_ms.p50, 1.0);
    assert_eq!(c.jitter_ms.max, 0.0);
    let a = &r.loops["vehicle_agent_0"];
    assert_eq!(a.iterations, 5);
    // Receptions at 0, 1, 2, 4 and 8 ms (+ 20 µs): the delayed tick 3 came last.
    assert_eq!(a.period_ms.max, 4.0);
    let mut s = Summary::default();
    r.fill_summary(&mut s);
    assert_eq!(s.messages.dropped_injected, 2);
    assert_eq!(s.messages.dropped_overflow, 1);
    assert_eq!(s.latency_us["body"].p50, 20.0);
    let (r, d) = compute(&dir).unwrap();
    plots::write_plots(&dir, &r, &d).unwrap();
    assert!(root.join(LATENCY_SVG).is_file());
    assert!(root.join(LOOPS_SVG).is_file());
    let _ = std::fs::remove_dir_all(&root);
}

#[test]
fn latency_drops_and_loops_from_csv_records() {
    use vbap_wire::msglog::MsgLog;
    let root = std::env::temp_dir().join(format!("vbap-analyze-csv-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    std::fs::create_dir_all(root.join("logs")).unwrap();
    let dir = RunDir { root: root.clone() };
    // The tracing logs now carry lifecycle lines only.
    std::fs::write(
        dir.log("vehicle_agent_0"),
        "{\"timestamp\":\"x\",\"level\":\"INFO\",\"fields\":{\"message\":\"agent up\"},\"target\":\"vehicle_agent::run\"}\n",
    )
    .unwrap();
    let t0: u64 = 1_795_437_897_283_832_923;
    const COORD: u32 = u32::MAX - 1;
    {
        // Receptions on arrival over IPC, then the link model's verdicts.
        let mut agent = MsgLog::open(&dir.msg_log("vehicle_agent_0")).unwrap();
        for k in 0..6u64 {
            let sent = t0 + k * 1_000_000;
            agent.recv("body", COORD, 0, k, k + 1, sent, sent + 20_000);
        }
        agent.held("body", COORD, 0, 3, 0.005);
        agent.drop("body", COORD, 0, 5, "loss");
        agent.drop("state", 0, COORD, 6, "overflow");
        let mut coord = MsgLog::open(&dir.msg_log("coordinator")).unwrap();
        for k in 0..3u64 {
            coord.recv("state", 0, COORD, k, k, t0 + k, t0 + k + 7_000);
        }
        coord.held("state", 0, COORD, 0, 0.05);
        coord.drop("state", 0, COORD, 1, "loss");
    }
    let mut csv = std::fs::read_to_string(dir.msg_log("vehicle_agent_0")).unwrap();
    csv.push_str("recv,body,1,2\n");
    std::fs::write(dir.msg_log("vehicle_agent_0"), csv).unwrap();

    let (r, d) = compute(&dir).unwrap();
    assert_eq!((r.records, r.unparsed), (14, 1));
    let body = &r.hops["body"];
    assert_eq!(
        (body.received, body.delivered, body.dropped_injected),
        (6, 5, 1)
    );
    assert_eq!((body.injected_ms.p50, body.injected_ms.max), (0.0, 5.0));
    assert!(d.transport_us["body"]
        .iter()
        .all(|&v| (v - 20.0).abs() < 1e-9));
    // The same figures as from the JSON records of `write_logs`.
    assert_state_hop(&r);
    assert_eq!(r.loops["coordinator"].period_ms.p50, 1.0);
    let a = &r.loops["vehicle_agent_0"];
    assert_eq!((a.iterations, a.period_ms.max), (6, 1.0));
    let mut s = Summary::default();
    r.fill_summary(&mut s);
    assert_eq!(s.messages.dropped_injected, 2);
    assert_eq!(s.messages.dropped_overflow, 1);
    assert_eq!(s.latency_us["body"].p50, 20.0);
    let _ = std::fs::remove_dir_all(&root);
}

#[test]
fn a_process_may_have_records_in_both_formats() {
    let root = std::env::temp_dir().join(format!("vbap-analyze-mixed-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    std::fs::create_dir_all(root.join("logs")).unwrap();
    let dir = RunDir { root: root.clone() };
    let t0: u64 = 1_795_437_897_283_832_923;
    let mut json = String::new();
    for k in 0..3u64 {
        let sent = t0 + k * 1_000_000;
        json.push_str(&format!(
            "{{\"fields\":{{\"message\":\"recv\",\"hop\":\"body\",\"sender\":4294967294,\"receiver\":0,\"tick\":{k},\"seq\":{k},\"sent_ns\":{sent},\"recv_ns\":{}}},\"target\":\"vbap::msg\"}}\n",
            sent + 10_000
        ));
    }
    std::fs::write(dir.log("vehicle_agent_0"), json).unwrap();
    let mut log = vbap_wire::msglog::MsgLog::open(&dir.msg_log("vehicle_agent_0")).unwrap();
    for k in 3..6u64 {
        let sent = t0 + k * 1_000_000;
        log.recv("body", u32::MAX - 1, 0, k, k, sent, sent + 10_000);
    }
    drop(log);
    let (r, _) = compute(&dir).unwrap();
    assert_eq!(r.hops["body"].received, 6);
    let a = &r.loops["vehicle_agent_0"];
    assert_eq!((a.iterations, a.period_ms.max), (6, 1.0));
    assert_eq!(r.loops["coordinator"].iterations, 6);
    let _ = std::fs::remove_dir_all(&root);
}

#[test]
fn cdf_keeps_the_tail() {
    let v: Vec<f64> = (1..=10_000).map(f64::from).collect();
    let c = cdf_points(&v, 400);
    assert!(c.len() <= 420, "{}", c.len());
    assert_eq!(c.last(), Some(&(10_000.0, 1.0)));
    assert_eq!(c[0], (1.0, 1e-4));
    assert!(c.windows(2).all(|w| w[0].0 <= w[1].0 && w[0].1 < w[1].1));
    let cc = ccdf_points(&v, 400);
    let (v, f) = *cc.last().unwrap();
    assert_eq!(v, 9_999.0);
    assert!((f - 1e-4).abs() < 1e-12);
}

#[test]
fn the_text_lists_the_median_and_worst_of_many_agents() {
    let mut r = Report {
        pace: "lockstep".into(),
        records: 42,
        late_ticks: 3,
        ..Report::default()
    };
    r.loops.insert("coordinator".into(), LoopReport::default());
    // Agents 0..10 with p99 jitter 10, 9, ..., 1 ms: the worst is agent 0, the median
    // (the 6th smallest, 6 ms) agent 4.
    for id in 0..10u32 {
        let mut l = LoopReport::default();
        l.jitter_ms.p99 = f64::from(10 - id);
        r.loops.insert(format!("vehicle_agent_{id}"), l);
    }
    let text = r.to_text();
    assert!(
        text.starts_with("pace: lockstep, 42 message records\n"),
        "{text}"
    );
    assert!(text.contains("\ncoordinator "), "{text}");
    assert!(text.contains("\nvehicle_agent_4 (median) "), "{text}");
    assert!(text.contains("\nvehicle_agent_0 (worst) "), "{text}");
    assert_eq!(text.matches("vehicle_agent_").count(), 2, "{text}");
    assert!(
        text.contains("(10 agents; all of them in --json)"),
        "{text}"
    );
    assert!(
        !text.contains("lockstep ticks"),
        "no tick table without ticks: {text}"
    );
    assert!(text.ends_with("\nlate ticks: 3\n"), "{text}");

    // Few agents: every one listed; the tick breakdown when there is one.
    r.loops
        .retain(|k, _| k != "vehicle_agent_9" && k != "vehicle_agent_8");
    r.loops
        .retain(|k, _| !k.ends_with('7') && !k.ends_with('6'));
    r.tick = Some(TickReport {
        ticks: 12,
        ..TickReport::default()
    });
    let text = r.to_text();
    assert_eq!(text.matches("vehicle_agent_").count(), 6, "{text}");
    assert!(!text.contains("(median)"), "{text}");
    assert!(text.contains("(12 lockstep ticks)"), "{text}");
    assert!(text.contains("\nwaiting for states "), "{text}");
}

/// A command whose fate the agent drew but never read (its process was killed first) was
/// still sent to it: counted received, and delivered or dropped by its fate.
#[test]
fn commands_fated_but_never_read_are_counted_as_sent() {
    use vbap_wire::msglog::MsgLog;
    let root = std::env::temp_dir().join(format!("vbap-analyze-unread-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    std::fs::create_dir_all(root.join("logs")).unwrap();
    let dir = RunDir { root: root.clone() };
    let t0: u64 = 1_795_437_897_283_832_923;
    const COORD: u32 = u32::MAX - 1;
    {
        let mut agent = MsgLog::open(&dir.msg_log("vehicle_agent_0")).unwrap();
        // Fates drawn for commands 0..5 (delayed 3 s; 4 superseded), 0..3 read.
        for k in 0..5u64 {
            if k == 4 {
                agent.drop("body", COORD, 0, k, "superseded");
            } else {
                agent.held("body", COORD, 0, k, 3.0);
            }
        }
        for k in 0..3u64 {
            let sent = t0 + k * 1_000_000;
            agent.recv("body", COORD, 0, k, k + 1, sent, sent + 20_000);
        }
    }
    let (r, _) = compute(&dir).unwrap();
    let body = &r.hops["body"];
    assert_eq!(
        (body.received, body.delivered, body.superseded),
        (5, 4, 1),
        "commands 3 and 4 were sent though never read"
    );
    let _ = std::fs::remove_dir_all(&root);
}
