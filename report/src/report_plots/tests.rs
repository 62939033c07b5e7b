use std::path::Path;

use vbap_mission::config::Mission;
use vbap_wire::rundir::RunDir;

use super::figures::field_unit;
use super::*;

/// A synthetic run directory: a long run (so decimation matters) with events.
fn synthetic_run(root: &Path, ticks: u64) -> RunDir {
    let dir = RunDir::create(root).unwrap();
    let text = "[mission]\nname = \"synthetic\"\nduration = 100.0\ndt = 0.05\ngoal = \"min\"\n\n[field]\nkind = \"quadratic\"\ncenter = [20.0, 10.0]\nhessian = [[1.0, 0.0], [0.0, 1.0]]\n";
    let mut mission = Mission::from_toml_str(text, "synthetic").unwrap();
    mission.mission.duration = ticks as f64 * mission.mission.dt;
    std::fs::write(dir.mission(), mission.to_toml_string()).unwrap();
    let mut body = String::from(vbap_wire::rundir::BODY_HEADER);
    body.push('\n');
    for k in 0..ticks {
        let t = k as f64 * 0.05;
        let f = k as f64 / ticks as f64;
        let n = if (0.2..0.35).contains(&f) { 3 } else { 4 };
        let spike = if k == ticks / 2 { 5.0 } else { 0.0 };
        body.push_str(&format!(
            "{t},{k},{},{},{},{},0,{},-1,-0.5,0,{},{n},{},-1.1,-0.4,0\n",
            0.5 * t,
            0.5,
            20.0 * f,
            10.0 * f,
            1.0 + 0.1 * (t * 0.3).sin(),
            0.3 + 0.1 * (t * 2.0).sin() + spike,
            1.0 / (1.0 + t)
        ));
    }
    std::fs::write(dir.body(), body).unwrap();
    let t = |f: f64| f * ticks as f64 * 0.05;
    let events = [
        format!(
            r#"{{"t":{},"k":1,"kind":"fault","vehicle":2,"detail":{{"fault":"kill"}}}}"#,
            t(0.2)
        ),
        format!(r#"{{"t":{},"k":2,"kind":"lost","vehicle":2}}"#, t(0.201)),
        format!(
            r#"{{"t":{},"k":2,"kind":"reconfigured","detail":{{"vehicles":[0,1,3]}}}}"#,
            t(0.201)
        ),
        format!(r#"{{"t":{},"k":3,"kind":"rejoin","vehicle":2}}"#, t(0.35)),
        format!(r#"{{"t":{},"k":4,"kind":"link_drop","vehicle":1}}"#, t(0.6)),
        format!(r#"{{"t":{},"k":5,"kind":"converged"}}"#, t(0.8)),
    ];
    std::fs::write(dir.events(), events.join("\n") + "\n").unwrap();
    dir
}

#[test]
fn run_plots_mark_events_and_stay_small() {
    let root = std::env::temp_dir().join(format!("vbap-plots-unit-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    let dir = synthetic_run(&root, 200_000);
    write_run_plots(&dir, &Mission::load(&dir.mission()).unwrap()).unwrap();
    let formation = std::fs::read_to_string(root.join(FORMATION_SVG)).unwrap();
    let estimate = std::fs::read_to_string(root.join(ESTIMATE_SVG)).unwrap();
    for svg in [&formation, &estimate] {
        assert!(
            svg.contains("\nkill 2, lost 2, redesign\n"),
            "coincident events share one label"
        );
        assert!(svg.contains("\nrejoin 2\n"));
        assert!(
            !svg.contains("\nlink_drop"),
            "per-message events are not drawn as markers"
        );
        assert!(svg.len() < 600_000, "decimated: {} bytes", svg.len());
    }
    // Link drops are counted in their own panel.
    assert!(estimate.contains("Messages dropped by the link model"));
    assert!(estimate.contains("\n1 drops, rate per"));
    // The spike of V (5.3 V_U, one tick of 200 000) survives decimation: the V axis
    // is labelled up to 4.
    assert!(formation.contains("V / V_U"));
    let v_panel = formation.split("Speed of the virtual body").next().unwrap();
    assert!(v_panel.contains("text-anchor=\"end\"") && v_panel.contains("\n4\n</text>"));
    assert!(
        formation.contains("\nbound V = V_U\n"),
        "bound drawn when V is near it"
    );
    if std::env::var_os("VBAP_KEEP_TEST_PLOTS").is_some() {
        eprintln!("kept {}", root.display());
    } else {
        let _ = std::fs::remove_dir_all(&root);
    }
}

/// Writes `formation.csv` and `truth.csv` for `ticks` ticks of 0.05 s and 3 vehicles:
/// each surfaces for a quarter of every 10 s (staggered), vehicle 2 is dead from 40 % to
/// 60 % of the run then rejoining for a tick, vehicle 1's link is down from 10 % to 20 %.
fn synthetic_truth(dir: &RunDir, ticks: u64) {
    let mut f = String::from("t,k,id,contact,info_age_s,slot_error,nearest_ratio,in_formation\n");
    let mut tr = String::from("t,k,V_true_over_VU,V_seen_over_VU,min_pair_ratio,max_slot_error,n_alive,n_in_formation,sdot_over_v0\n");
    let mut age = [None::<f64>; 3];
    for k in 0..ticks {
        let t = k as f64 * 0.05;
        let frac = k as f64 / ticks as f64;
        let mut alive = 0;
        for (id, a) in age.iter_mut().enumerate() {
            let surfaced = ((t / 10.0 + id as f64 / 3.0) % 1.0) < 0.25;
            let state = if id == 2 && (0.4..0.6).contains(&frac) {
                "dead"
            } else if id == 2 && frac >= 0.6 && *a == Some(-1.0) {
                "rejoining"
            } else if id == 1 && (0.1..0.2).contains(&frac) {
                "link_down"
            } else if surfaced {
                "surfaced"
            } else {
                "submerged"
            };
            if state == "dead" {
                *a = Some(-1.0);
                f.push_str(&format!("{t},{k},{id},dead,,,,0\n"));
                continue;
            }
            alive += 1;
            *a = match (*a, state) {
                (_, "surfaced" | "rejoining") => Some(0.2),
                (Some(x), _) if x >= 0.0 => Some(x + 0.05),
                _ => None,
            };
            let age_s = a.map(|x| x.to_string()).unwrap_or_default();
            f.push_str(&format!("{t},{k},{id},{state},{age_s},0.1,0.9,1\n"));
        }
        tr.push_str(&format!(
            "{t},{k},{},{},0.9,0.1,{alive},{alive},1\n",
            2.0 * frac,
            frac
        ));
    }
    std::fs::write(dir.root.join(crate::truth_plots::FORMATION_CSV), f).unwrap();
    std::fs::write(dir.root.join(crate::truth_plots::TRUTH_CSV), tr).unwrap();
    let s = r#"{"formation": {"in_formation_ratio": 0.5, "near_collision_ratio": 0.1}}"#;
    std::fs::write(dir.summary(), s).unwrap();
}

#[test]
fn run_plots_draw_the_truth_when_present_and_leave_it_out_when_absent() {
    let root = std::env::temp_dir().join(format!("vbap-plots-truth-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    let dir = synthetic_run(&root, 4000);
    // An older run: no truth files, no contact.svg, no error.
    write_run_plots(&dir, &Mission::load(&dir.mission()).unwrap()).unwrap();
    assert!(!root.join(crate::truth_plots::CONTACT_SVG).exists());
    let old = std::fs::read_to_string(root.join(FORMATION_SVG)).unwrap();
    assert!(!old.contains("slot error"));

    synthetic_truth(&dir, 4000);
    write_run_plots(&dir, &Mission::load(&dir.mission()).unwrap()).unwrap();
    let contact = std::fs::read_to_string(root.join(crate::truth_plots::CONTACT_SVG)).unwrap();
    assert!(contact.starts_with("<svg") && contact.trim_end().ends_with("</svg>"));
    assert_eq!(contact.matches("<svg").count(), 1);
    assert_eq!(contact.matches("</svg>").count(), 1);
    for id in 0..3 {
        assert_eq!(
            contact.matches(&format!("\nvehicle {id}\n</text>")).count(),
            1,
            "one row label for vehicle {id}"
        );
    }
    for state in [
        "surfaced (can talk)",
        "submerged (cannot talk)",
        "link down (fault)",
        "dead / lost",
        "rejoining",
    ] {
        assert!(contact.contains(state), "legend: {state}");
    }
    assert!(contact.contains("report delivered"));
    // 200 s: seconds; the rejoin, the kill and the redesign of the synthetic events.
    assert!(contact.contains("mission time t (s)"));
    assert!(
        contact.contains("\nvehicle lost\n"),
        "the kinds of vehicle events in the legend"
    );
    assert!(contact.contains("\nredesign\n"), "fleet event labelled");
    assert!(contact.contains("fleet never stalled"));
    assert!(contact.contains("surfacing period") || contact.contains("information age"));
    let formation = std::fs::read_to_string(root.join(FORMATION_SVG)).unwrap();
    for s in [
        "true (vehicles",
        "seen (coordinator",
        "slot error ÷ spacing",
        "in formation: ≤ 0.5",
        "Nearest pair",
        "near collision: &lt; 0.1",
        "in formation (true slot error)",
    ] {
        assert!(
            formation.contains(s),
            "timeseries_formation.svg lacks {s:?}"
        );
    }
    // Malformed truth is left out with a warning, never an error.
    std::fs::write(root.join(crate::truth_plots::FORMATION_CSV), "t,k\n0,0\n").unwrap();
    std::fs::write(root.join(crate::truth_plots::TRUTH_CSV), "t\n0\n").unwrap();
    write_run_plots(&dir, &Mission::load(&dir.mission()).unwrap()).unwrap();
    assert!(!root.join(crate::truth_plots::CONTACT_SVG).exists());
    if std::env::var_os("VBAP_KEEP_TEST_PLOTS").is_some() {
        eprintln!("kept {}", root.display());
    } else {
        let _ = std::fs::remove_dir_all(&root);
    }
}

#[test]
fn field_units() {
    assert_eq!(field_unit("T (°C)"), "°C");
    assert_eq!(field_unit("T"), "");
}
