//! Unit tests of the campaign: slots, plans, the detection limit, run names.

use super::report::apply_detection_limit;
use super::timing::{FIRST_ACTION, MIN_STOP};
use super::*;
use vbap_mission::config::MAX_NAME_LEN;

#[test]
fn slots_from_command_lines() {
    let v = |s: &str| s.split(' ').map(String::from).collect::<Vec<_>>();
    assert_eq!(
        slot_of(&v("/x/vehicle_agent --mission m --id 3 --log l")),
        Some(Slot::Agent(3))
    );
    assert_eq!(
        slot_of(&v("/x/coordinator --mission m")),
        Some(Slot::Coordinator)
    );
    assert_eq!(
        slot_of(&v("field_server --mission m")),
        Some(Slot::FieldServer)
    );
    assert_eq!(slot_of(&v("/x/vbap run m")), None);
    assert_eq!(slot_of(&v("/x/vehicle_agent --mission m")), None);
}

#[test]
fn plans_are_seeded_sorted_and_inside_the_window() {
    let a = plan(7, 3, 5, 2, 4.0, 2.0);
    assert_eq!(a, plan(7, 3, 5, 2, 4.0, 2.0));
    assert_ne!(a, plan(8, 3, 5, 2, 4.0, 2.0));
    assert_eq!(a.iter().filter(|x| x.1).count(), 5);
    assert!(a.windows(2).all(|w| w[0].0 <= w[1].0));
    for (at, kill, pause) in a {
        assert!((FIRST_ACTION..=4.0).contains(&at));
        if kill {
            assert_eq!(pause, 0.0);
        } else {
            assert!((MIN_STOP..=2.0).contains(&pause));
        }
    }
}

#[test]
fn a_detection_limit_fails_slow_judged_kills_only() {
    let kill = |ms: f64, judged: bool| Action {
        action: "kill".into(),
        target: "vehicle_agent 1".into(),
        sent: true,
        judged,
        detected: Some(true),
        detection_ms: Some(ms),
        outcome: "ok".into(),
        ..Action::default()
    };
    let mut r = RunReport {
        actions: vec![kill(200.0, true), kill(900.0, true), kill(900.0, false)],
        ..RunReport::default()
    };
    apply_detection_limit(&mut r, 500.0);
    assert_eq!(r.actions[0].outcome, "ok");
    assert!(r.actions[1].outcome.contains("detected after 900 ms"));
    assert!(r.actions[1].failed() && !r.actions[2].failed());
    assert_eq!(r.failures.len(), 1);
}

#[test]
fn run_names_fit() {
    assert_eq!(run_name("paper", 3), "paper_c003");
    let long = run_name(&"a".repeat(40), 12);
    assert_eq!(long.len(), MAX_NAME_LEN);
    assert!(long.ends_with("_c012"));
}

#[test]
fn run_missions_last_the_window_and_tail_in_wall_time() {
    let text = "[mission]\nname = \"c\"\ndt = 0.1\n[field]\ncenter = [1.0, 2.0]\namplitude = 1.0\nwidth = 2.0\n";
    let base = Mission::from_toml_str(text, "m.toml").unwrap();
    let wall = 4.0 + TAIL;
    let paced = args::run_mission(&base, Pace::Factor(10.0), 4.0, None);
    assert!((paced.mission.duration - 10.0 * wall).abs() < 1e-9);
    // Lockstep: 1.5 × the wall time at the measured rate (1000 ticks/s when not measured).
    let measured = args::run_mission(&base, Pace::Lockstep, 4.0, Some(200.0));
    assert!((measured.mission.duration - 200.0 * wall * 1.5 * 0.1).abs() < 1e-9);
    let unmeasured = args::run_mission(&base, Pace::Lockstep, 4.0, None);
    assert!((unmeasured.mission.duration - 1000.0 * wall * 1.5 * 0.1).abs() < 1e-9);
    // Never shorter than 20 ticks.
    let slow = args::run_mission(&base, Pace::Lockstep, 4.0, Some(1e-6));
    assert!((slow.mission.duration - 20.0 * 0.1).abs() < 1e-9);
}

#[test]
fn compound_plans_are_seeded_and_leave_the_single_actions_unchanged() {
    let a = compound_plan(7, 3, 6, 4.0);
    assert_eq!(a, compound_plan(7, 3, 6, 4.0));
    assert_eq!(a.len(), 6);
    assert!(a.windows(2).all(|w| w[0].0 <= w[1].0));
    assert!(a.iter().all(|(at, _)| (FIRST_ACTION..=4.0).contains(at)));
    assert!(compound_plan(7, 3, 0, 4.0).is_empty());
    // Drawn from a stream of their own: a seed's single actions are what they were.
    assert_eq!(plan(7, 3, 5, 2, 4.0, 2.0), plan(7, 3, 5, 2, 4.0, 2.0));
    let names: std::collections::BTreeSet<&str> = compound_plan(1, 0, 60, 4.0)
        .iter()
        .map(|(_, c)| c.name())
        .collect();
    assert_eq!(names.len(), 3, "every case is drawn: {names:?}");
}

#[test]
fn targets_all_is_every_target_and_a_bad_one_is_named() {
    use super::args::parse_targets;
    let all = vec![Target::Agents, Target::Coordinator, Target::FieldServer];
    assert_eq!(parse_targets("all").unwrap(), all);
    assert_eq!(parse_targets("agents,all").unwrap(), all);
    assert_eq!(
        parse_targets("field_server,agents").unwrap(),
        vec![Target::Agents, Target::FieldServer]
    );
    let e = parse_targets("agents,robots").unwrap_err().to_string();
    assert!(e.contains("--targets") && e.contains("robots"), "{e}");
}
