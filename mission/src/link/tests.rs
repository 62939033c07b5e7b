//! Tests of `link.rs`.

use super::*;
use crate::config::Mission;

fn mission(links: &str) -> Mission {
    Mission::from_toml_str(
        &format!("[mission]\nname = \"t\"\n[field]\ncenter = [20.0, 10.0]\namplitude = 10.0\nwidth = 15.0\n[vehicles]\ncount = 4\n[links]\n{links}"),
        "<test>",
    )
    .unwrap()
}

#[test]
fn contact_states_follow_the_schedule() {
    let m = LinkModel::new(&mission(
        "surfacing_period = 100.0\nsurfacing_window = 10.0\nsurfacing_phase = \"staggered\"",
    ));
    // Vehicle 1 of 4 surfaces at 25 s of every 100 s.
    assert_eq!(m.contact(1, 24.9), Contact::Submerged);
    assert_eq!(m.contact(1, 25.0), Contact::Surfaced);
    assert_eq!(m.contact(1, 134.0), Contact::Surfaced);
    assert_eq!(m.contact(1, 135.0), Contact::Submerged);
    let down = Mission::from_toml_str(
        "[mission]\nname = \"t\"\n[field]\ncenter = [20.0, 10.0]\namplitude = 10.0\nwidth = 15.0\n[vehicles]\ncount = 4\n[[faults]]\nkind = \"link_down\"\nvehicle = 2\nat = 5.0\nuntil = 8.0",
        "<test>",
    )
    .unwrap();
    let m = LinkModel::new(&down);
    assert_eq!(m.contact(2, 4.9), Contact::Contact);
    assert_eq!(m.contact(2, 5.0), Contact::LinkDown);
    assert_eq!(m.contact(2, 8.0), Contact::Contact);
    assert_eq!(m.contact(1, 6.0), Contact::Contact);
    assert!(!Contact::LinkDown.can_talk() && Contact::Surfaced.can_talk());
}

#[test]
fn ideal_links_deliver_at_once() {
    let m = LinkModel::new(&mission(""));
    assert!(m.is_ideal());
    let mut s = LinkState::default();
    assert_eq!(
        m.fate(&mut s, 1, Direction::Uplink, 5, 2.5),
        Fate::Deliver {
            at: 2.5,
            injected: 0.0
        }
    );
}

#[test]
fn delay_and_jitter_are_within_bounds_and_centred() {
    let m = LinkModel::new(&mission("delay = 2.0\njitter = 0.5"));
    let mut s = LinkState::default();
    let mut sum = 0.0;
    let n = 20_000;
    for k in 0..n {
        match m.fate(&mut s, 0, Direction::Uplink, k, k as f64) {
            Fate::Deliver { injected, .. } => {
                assert!((1.5..=2.5).contains(&injected), "{injected}");
                sum += injected;
            }
            Fate::Drop(_) => panic!("no loss configured"),
        }
    }
    // Uniform on [1.5, 2.5]: mean 2, standard error 0.29/sqrt(n).
    assert!((sum / n as f64 - 2.0).abs() < 5.0 * 0.2887 / (n as f64).sqrt());
}

#[test]
fn bernoulli_loss_rate_matches() {
    let m = LinkModel::new(&mission("loss = 0.2"));
    let mut s = LinkState::default();
    let n = 50_000u64;
    let lost = (0..n)
        .filter(|&k| matches!(m.fate(&mut s, 2, Direction::Uplink, k, 0.0), Fate::Drop(_)))
        .count();
    let rate = lost as f64 / n as f64;
    let se = (0.2 * 0.8 / n as f64).sqrt();
    assert!((rate - 0.2).abs() < 5.0 * se, "{rate}");
}

#[test]
fn gilbert_elliott_loss_is_bursty_with_the_stationary_rate() {
    // Stationary probability of bad: enter / (enter + exit) = 0.05 / 0.25 = 0.2;
    // loss = 0.2·0.9 + 0.8·0.01 = 0.188.
    let m = LinkModel::new(&mission(
        "loss = 0.01\nburst_enter = 0.05\nburst_exit = 0.2\nburst_loss = 0.9",
    ));
    let mut s = LinkState::default();
    let n = 200_000u64;
    let drops: Vec<bool> = (0..n)
        .map(|k| {
            matches!(
                m.fate(&mut s, 1, Direction::Downlink, k, 0.0),
                Fate::Drop(_)
            )
        })
        .collect();
    let rate = drops.iter().filter(|d| **d).count() as f64 / n as f64;
    assert!((rate - 0.188).abs() < 0.01, "{rate}");
    // Bursty: a loss is much more likely right after a loss than on average.
    let after_loss = drops.windows(2).filter(|w| w[0]).count() as f64;
    let loss_loss = drops.windows(2).filter(|w| w[0] && w[1]).count() as f64;
    assert!(
        loss_loss / after_loss > 2.0 * rate,
        "{}",
        loss_loss / after_loss
    );
}

#[test]
fn nothing_is_delivered_outside_a_surfacing_window() {
    let m = LinkModel::new(&mission(
        "delay = 5.0\njitter = 4.0\nsurfacing_period = 7200.0\nsurfacing_window = 600.0",
    ));
    let mut s = LinkState::default();
    for vehicle in 0..4u32 {
        for k in 0..2000u64 {
            let sent = k as f64 * 17.0;
            if let Fate::Deliver { at, .. } = m.fate(&mut s, vehicle, Direction::Uplink, k, sent) {
                assert!(
                    m.at_surface(vehicle, at),
                    "vehicle {vehicle} message at {at}"
                );
                assert!(at >= sent + 1.0 - 1e-9);
            }
        }
    }
    // Staggered phases: vehicle i surfaces at i·period/N.
    assert!(m.at_surface(1, 1800.0) && !m.at_surface(0, 1800.0));
    assert_eq!(m.next_surface(0, 700.0), 7200.0);
}

#[test]
fn link_down_drops_inside_its_interval_only() {
    let text = "[mission]\nname = \"t\"\n[field]\ncenter = [20.0, 10.0]\namplitude = 10.0\nwidth = 15.0\n[vehicles]\ncount = 4\n[[faults]]\nkind = \"link_down\"\nvehicle = 1\nat = 10.0\nuntil = 20.0\n";
    let m = LinkModel::new(&Mission::from_toml_str(text, "<test>").unwrap());
    let mut s = LinkState::default();
    assert_eq!(
        m.fate(&mut s, 1, Direction::Uplink, 1, 15.0),
        Fate::Drop(DropReason::LinkDown)
    );
    assert!(matches!(
        m.fate(&mut s, 1, Direction::Uplink, 2, 20.0),
        Fate::Deliver { .. }
    ));
    assert!(matches!(
        m.fate(&mut s, 2, Direction::Uplink, 3, 15.0),
        Fate::Deliver { .. }
    ));
}

#[test]
fn fates_do_not_depend_on_the_order_links_are_asked() {
    let m = LinkModel::new(&mission(
        "loss = 0.3\njitter = 0.5\ndelay = 1.0\nburst_enter = 0.1",
    ));
    let run = |order: &[u32]| {
        let mut states = [LinkState::default(); 4];
        let mut out = Vec::new();
        for k in 0..200u64 {
            for &v in order {
                out.push((
                    v,
                    k,
                    m.fate(&mut states[v as usize], v, Direction::Uplink, k, k as f64),
                ));
            }
        }
        out.sort_by_key(|a| (a.0, a.1));
        out
    };
    assert_eq!(run(&[0, 1, 2, 3]), run(&[3, 1, 0, 2]));
}

/// A glider mission with Iridium sessions: 4 vehicles, dt = 10 s, surfacing 900 s of
/// every 7200 s, a session a minute, `extra` appended to `[links.iridium]`.
fn iridium(extra: &str) -> LinkModel {
    LinkModel::new(&iridium_mission(extra))
}

fn iridium_mission(extra: &str) -> Mission {
    iridium_mission_with("", extra)
}

/// [`iridium_mission`] with `links` appended to `[links]`.
fn iridium_mission_with(links: &str, extra: &str) -> Mission {
    let interval = if extra.contains("session_interval") {
        ""
    } else {
        "session_interval = 60.0\n"
    };
    let text = format!(
        "[mission]\nname = \"t\"\ndt = 10.0\nallow_unstable = true\nduration = 86400.0\n[field]\ncenter = [20.0, 10.0]\namplitude = 10.0\nwidth = 15.0\n[vehicles]\ncount = 4\n[links]\nsurfacing_period = 7200.0\nsurfacing_window = 900.0\n{links}[links.iridium]\n{interval}{extra}"
    );
    Mission::from_toml_str(&text, "<test>").unwrap()
}

#[test]
fn sessions_open_at_the_surface_only_and_fail_at_their_rate() {
    let m = iridium("session_failure = 0.25");
    let mut failed = 0;
    let mut all = 0;
    for v in 0..4 {
        let sessions = m.sessions(v, 0.0, 30.0 * 86_400.0);
        for w in sessions.windows(2) {
            assert!(w[1].at > w[0].at);
        }
        for s in &sessions {
            assert!(m.at_surface(v, s.at), "vehicle {v} session at {}", s.at);
            // Every interval from the window's start: 15 sessions a window.
            let into = (s.at - m.phase_of(v)).rem_euclid(7200.0);
            assert!((into / 60.0 - (into / 60.0).round()).abs() < 1e-9, "{into}");
        }
        assert!(sessions.len() >= 15 * 359, "{}", sessions.len());
        failed += sessions.iter().filter(|s| !s.ok).count();
        all += sessions.len();
    }
    let rate = failed as f64 / all as f64;
    let se = (0.25 * 0.75 / all as f64).sqrt();
    assert!((rate - 0.25).abs() < 5.0 * se, "{rate}");
}

#[test]
fn a_session_carries_the_newest_command_and_every_report_since_the_last() {
    let m = iridium("session_failure = 0.3");
    let dt = 10.0;
    let (mut down, mut up) = (LinkState::default(), LinkState::default());
    let v = 2;
    let mut carried = Vec::new();
    for k in 0..8640u64 {
        let sent = k as f64 * dt;
        let fate = m.fate(&mut down, v, Direction::Downlink, k, sent);
        assert_eq!(
            matches!(fate, Fate::Deliver { .. }),
            m.carries_command(v, k),
            "command {k}"
        );
        if let Fate::Deliver { at, .. } = fate {
            let (_, opens) = m.next_open_session(v, sent).unwrap();
            // Newest at the shore: the next command comes after the session opened.
            assert!(sent <= opens && sent + dt > opens, "{k}: {sent} {opens}");
            assert!((at - opens - 5.0).abs() < 1e-9, "a no-byte transfer: {at}");
            let sized = m.carry(fate, v, Direction::Downlink, k, sent, 945);
            let Fate::Deliver { at: later, .. } = sized else {
                panic!("{sized:?}")
            };
            assert!(
                (later - opens - 12.5).abs() < 1e-9,
                "half full: 12.5 s: {later}"
            );
            carried.push(opens);
        }
        // Every report crosses (no loss), in the first successful session after it.
        let report = m.fate(&mut up, v, Direction::Uplink, k, sent);
        let report = m.carry(report, v, Direction::Uplink, k, sent, 68);
        let Fate::Deliver { at, .. } = report else {
            panic!("report {k}: {report:?}")
        };
        let (_, opens) = m.next_open_session(v, sent).unwrap();
        assert!(
            at >= opens + 5.0 && m.at_surface(v, opens),
            "{k}: {at} {opens}"
        );
    }
    // One command per successful session, each a different session.
    let mut sessions: Vec<f64> = m
        .sessions(v, 0.0, 86_400.0)
        .iter()
        .filter(|s| s.ok)
        .map(|s| s.at)
        .collect();
    sessions.retain(|&s| s <= 8639.0 * dt);
    assert_eq!(carried, sessions);
}

#[test]
fn reports_of_a_long_dive_go_up_packed_into_several_messages() {
    // 7200 s between surfacings at dt = 10 s: ~630 reports of 68 bytes wait, 28 to a
    // 1960-byte message (1904 bytes): 23 messages, the last report after 22 full ones.
    let m = iridium("");
    let v = 0;
    let mut state = LinkState::default();
    let mut last = (0u64, 0.0);
    let mut first_of_session = None;
    for k in 0..=720u64 {
        let sent = k as f64 * 10.0;
        let fate = m.fate(&mut state, v, Direction::Uplink, k, sent);
        let fate = m.carry(fate, v, Direction::Uplink, k, sent, 68);
        if let Fate::Deliver { at, .. } = fate {
            let (_, opens) = m.next_open_session(v, sent).unwrap();
            if (opens - 7200.0).abs() < 1e-9 {
                first_of_session.get_or_insert((k, at - opens));
                last = (k, at - opens);
            }
        }
    }
    let (k0, t0) = first_of_session.unwrap();
    let time = |bytes: u64| 5.0 + 15.0 * bytes as f64 / 1960.0;
    assert!(
        (t0 - time(28 * 68)).abs() < 1e-9,
        "a full first message: {t0}"
    );
    let count = last.0 - k0 + 1;
    let messages = count.div_ceil(28);
    assert!(messages > 20, "{count} reports");
    let in_last = count - 28 * (messages - 1);
    let expected = (messages - 1) as f64 * time(28 * 68) + time(in_last * 68);
    assert!((last.1 - expected).abs() < 1e-9, "{} vs {expected}", last.1);
}

#[test]
fn a_command_over_the_limit_is_split_or_refused_never_cut() {
    let split = iridium("");
    let refuse = iridium("oversize = \"refuse\"");
    let fate = Fate::Deliver {
        at: 100.0,
        injected: 10.0,
    };
    // 4000 bytes = 1890 + 1890 + 220: two full messages and a short one.
    let Fate::Deliver { at, .. } = split.carry(fate, 1, Direction::Downlink, 3, 30.0, 4000) else {
        panic!()
    };
    let expected = 100.0 - 5.0 + 2.0 * 20.0 + 5.0 + 15.0 * 220.0 / 1890.0;
    assert!((at - expected).abs() < 1e-9, "{at} vs {expected}");
    assert_eq!(split.down_messages(4000), 3);
    assert_eq!(split.down_messages(1890), 1);
    assert_eq!(
        refuse.carry(fate, 1, Direction::Downlink, 3, 30.0, 1891),
        Fate::Drop(DropReason::Oversize)
    );
    assert_eq!(
        refuse.carry(fate, 1, Direction::Downlink, 3, 30.0, 1890),
        Fate::Deliver {
            at: 115.0,
            injected: 25.0
        }
    );
    // Without Iridium, size changes nothing.
    let plain = LinkModel::new(&mission("delay = 1.0"));
    assert_eq!(
        plain.carry(fate, 1, Direction::Downlink, 3, 30.0, 1 << 20),
        fate
    );
}

#[test]
fn the_plan_horizon_covers_every_gap_between_commands_carried() {
    for (links, extra) in [
        ("", "session_failure = 0.3"),
        ("", "session_failure = 0.0"),
        ("", "session_interval = 300.0\nsession_failure = 0.5"),
        // Bursts: sessions 6 ticks apart, the chain's memory 0.55⁶ between them.
        (
            "loss = 0.02\nburst_enter = 0.05\nburst_exit = 0.4\nburst_loss = 0.7\n",
            "session_failure = 0.2",
        ),
        // Bursts that outlast sessions (memory 0.98⁶).
        (
            "loss = 0.02\nburst_enter = 0.005\nburst_exit = 0.015\nburst_loss = 0.9\n",
            "session_failure = 0.1",
        ),
    ] {
        let mission = iridium_mission_with(links, extra);
        let m = LinkModel::new(&mission);
        let horizon = crate::horizon::plan_horizon(&mission.links, 10.0);
        for v in 0..4 {
            let mut state = LinkState::default();
            let mut heard = Vec::new();
            for k in 0..30 * 8640u64 {
                let sent = k as f64 * 10.0;
                let fate = m.fate(&mut state, v, Direction::Downlink, k, sent);
                if let Fate::Deliver { at, .. } =
                    m.carry(fate, v, Direction::Downlink, k, sent, 1890)
                {
                    heard.push((sent, at));
                }
            }
            // A command heard at `at` is flown on until the next is heard.
            for w in heard.windows(2) {
                assert!(w[1].1 - w[0].0 <= horizon, "{extra}: {w:?} > {horizon}");
            }
        }
    }
}

#[test]
fn delay_queue_releases_in_delivery_order() {
    let mut q = DelayQueue::default();
    q.push(3.0, "c");
    q.push(1.0, "a");
    q.push(3.0, "d");
    q.push(2.0, "b");
    assert!(q.pop_due(0.5).is_empty());
    assert_eq!(q.pop_due(2.0), vec!["a", "b"]);
    assert_eq!(q.pop_due(10.0), vec!["c", "d"]);
    assert!(q.is_empty());
}
