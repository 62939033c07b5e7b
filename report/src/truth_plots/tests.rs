use std::path::Path;

use crate::plot::style;
use anyhow::Result;
use vbap_wire::rundir::Event;

use super::contact::intervals;
use super::*;

const FORMATION: &str = "t,k,id,contact,info_age_s,slot_error,nearest_ratio,in_formation
0,0,0,surfaced,,0.1,1,1
0,0,1,submerged,,0.2,1,1
1,1,0,surfaced,0,0.1,1,1
1,1,1,submerged,,0.3,1,1
2,2,0,submerged,1,0.1,1,1
2,2,1,surfaced,0.5,0.6,1,0
3,3,0,submerged,2,0.1,1,1
3,3,1,surfaced,0.5,0.2,1,1
4,4,0,link_down,3,0.4,,1
4,4,1,dead,,,,0
5,5,0,rejoining,0,0.5,,0
5,5,1,dead,,,,0
6,6,0,surf";

fn read_fixture(text: &str) -> Result<Formation> {
    Formation::read(
        Path::new("formation.csv"),
        text.as_bytes(),
        1.0,
        (0.0, 6.0),
        12,
        1,
    )
}

#[test]
fn formation_reader_follows_the_schema() {
    let f = read_fixture(FORMATION).unwrap();
    assert_eq!(f.rows, 12, "the partial last line is skipped");
    assert_eq!(f.lanes.len(), 2);
    let idx = |s| style::contact_index(s).unwrap();
    let v0 = &f.lanes[&0];
    // Two columns per tick of 1 s: column 0 and 1 hold tick 0, half a second each.
    assert_eq!(v0.state_time[0][idx("surfaced")], 0.5);
    assert_eq!(v0.state_time[4][idx("submerged")], 0.5);
    assert_eq!(v0.state_time[8][idx("link_down")], 0.5);
    assert_eq!(v0.state_time[10][idx("rejoining")], 0.5);
    // Vehicle 0: delivered at t = 1 (first report) and t = 5 (age 3 -> 0); its age grew
    // by 1 s a tick in between: no delivery.
    assert_eq!(v0.deliveries, 2);
    let delivered: Vec<usize> = (0..12).filter(|&c| v0.delivered[c]).collect();
    assert_eq!(delivered, vec![2, 10]);
    assert_eq!(v0.max_age, Some((3.0, 4.0)));
    // Vehicle 1: first report at t = 2 (age 0.5), renewed at t = 3 (still 0.5), then dead.
    let v1 = &f.lanes[&1];
    assert_eq!(v1.deliveries, 2);
    assert!(v1.seen[idx("dead")] && !v1.seen[idx("contact")]);
    assert_eq!(v1.max_slot_error, Some(0.6));
    // The slot error breaks (NaN) while dead.
    let pts = v1.slot_error.points();
    assert_eq!(pts.len(), 6);
    assert!(pts[4].1.is_nan() && pts[5].1.is_nan());
    // In formation up to 0.4 (vehicle 0 at t = 4), out from 0.5 (vehicle 0 at t = 5).
    assert_eq!(f.in_max, Some(0.4));
    assert_eq!(f.out_min, Some(0.5));
    // The worst age per tick, over the vehicles that have one.
    let worst = f.worst_age.points();
    assert_eq!(worst.len(), 6);
    assert!(worst[0].1.is_nan());
    assert_eq!(worst[2], (2.0, 1.0));
    assert_eq!(worst[4], (4.0, 3.0));
}

#[test]
fn formation_reader_names_what_is_wrong() {
    let missing = "t,k,id,contact,info_age_s,slot_error,in_formation\n0,0,0,surfaced,,0.1,1\n";
    let e = format!("{:#}", read_fixture(missing).unwrap_err());
    assert!(
        e.contains("formation.csv") && e.contains("nearest_ratio"),
        "{e}"
    );
    let bad_state =
        "t,k,id,contact,info_age_s,slot_error,nearest_ratio,in_formation\n0,0,0,asleep,,0.1,1,1\n";
    let e = format!("{:#}", read_fixture(bad_state).unwrap_err());
    assert!(e.contains("line 2") && e.contains("asleep"), "{e}");
    let bad_num =
        "t,k,id,contact,info_age_s,slot_error,nearest_ratio,in_formation\n0,0,0,dead,x,,,0\n";
    let e = format!("{:#}", read_fixture(bad_num).unwrap_err());
    assert!(e.contains("info_age_s"), "{e}");
    // Columns in another order, and one more, read the same.
    let reordered = "k,t,extra,id,in_formation,contact,slot_error,info_age_s,nearest_ratio\n0,0,x,3,1,contact,0.25,0,0.9\n";
    let f = read_fixture(reordered).unwrap();
    assert_eq!(f.lanes[&3].max_slot_error, Some(0.25));
    assert_eq!(f.lanes[&3].deliveries, 1);
}

#[test]
fn truth_reader_follows_the_schema() {
    let text = "t,k,V_true_over_VU,V_seen_over_VU,min_pair_ratio,max_slot_error,n_alive,n_in_formation,sdot_over_v0
0,0,0.5,0.4,0.9,0.1,3,3,0
1,1,68.7,13.8,0.06,2.5,3,2,1
2,2,1.5,1.2,,0.2,1,1,0.5
";
    let tr = Truth::read(Path::new("truth.csv"), text.as_bytes(), 1).unwrap();
    assert_eq!(tr.rows, 3);
    assert_eq!(tr.max_v_true, 68.7);
    assert_eq!(tr.max_v_seen, 13.8);
    assert_eq!(tr.closest, Some((0.06, 1.0)));
    let pair = tr.min_pair.points();
    assert!(pair[2].1.is_nan(), "empty when fewer than 2 alive");
    assert_eq!(tr.n_in_formation.points()[1], (1.0, 2.0));
    let e = format!(
        "{:#}",
        Truth::read(Path::new("truth.csv"), "t,k\n0,0\n".as_bytes(), 1).unwrap_err()
    );
    assert!(
        e.contains("truth.csv") && e.contains("V_true_over_VU"),
        "{e}"
    );
}

#[test]
fn intervals_pair_openings_with_closings() {
    let ev = |t: f64, kind: &str| Event {
        t,
        k: t as u64,
        kind: kind.into(),
        vehicle: None,
        detail: serde_json::json!({"why": "holding"}),
    };
    let events = vec![
        ev(1.0, "stall_began"),
        ev(2.0, "stall_ended"),
        ev(5.0, "stall_began"),
    ];
    let iv = intervals(&events, "stall_began", "stall_ended", 9.0);
    assert_eq!(
        iv,
        vec![
            (1.0, 2.0, "stall (holding)".to_string()),
            (5.0, 9.0, "stall (holding)".to_string())
        ]
    );
    // A debounced event: the condition began at detail.since.
    let broken = Event {
        detail: serde_json::json!({"vehicles": [1, 5], "since": 3.5}),
        ..ev(4.0, "formation_broken")
    };
    let iv = intervals(
        &[broken, ev(6.0, "formation_restored")],
        "formation_broken",
        "formation_restored",
        9.0,
    );
    assert_eq!(iv, vec![(3.5, 6.0, "broken: 1, 5".to_string())]);
}
