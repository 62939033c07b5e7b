//! The shipped missions and the front door's contracts: the paper's results through the
//! real `vbap` binary, determinism, `vbap check` and `vbap formation --json`.

use tests::*;

fn mission_file(name: &str) -> std::path::PathBuf {
    workspace().join("deploy/missions").join(name)
}

#[test]
fn shipped_missions_converge_within_the_theorems() {
    // (mission, Theorem 4.1 must hold: V ≤ V_U with ideal links)
    for (file, theorem_4_1) in [
        ("paper.toml", true),
        ("glider.toml", true),
        ("quadratic3d.toml", true),
        ("glider_surfacing.toml", false),
        ("glider_iridium.toml", false),
        ("glider_acoustic.toml", false),
    ] {
        let tmp = TempDir::new("ship");
        run_ok(vbap().arg("check").arg(mission_file(file)));
        run_ok(
            vbap()
                .arg("sim")
                .arg(mission_file(file))
                .arg("--out")
                .arg(tmp.join("sim"))
                .arg("--quiet"),
        );
        let s = summary(&tmp.join("sim"));
        assert_eq!(s["converged"], true, "{file}: {s}");
        assert_eq!(
            s["in_set_m"], true,
            "{file}: the final body lies in the set M of Theorem 5.1: {s}"
        );
        if theorem_4_1 {
            assert!(
                s["max_V_over_VU"].as_f64().unwrap() <= 1.0,
                "{file}: Theorem 4.1: {s}"
            );
        }
        for f in [
            "plot.svg",
            "vehicles.csv",
            "body.csv",
            "events.jsonl",
            "mission.toml",
        ] {
            assert!(tmp.join("sim").join(f).exists(), "{file}: {f} written");
        }
    }
}

#[test]
fn same_mission_and_seed_give_identical_files() {
    let tmp = TempDir::new("det");
    let file = mission_file("glider_surfacing.toml");
    for out in ["a", "b"] {
        run_ok(
            vbap()
                .arg("sim")
                .arg(&file)
                .arg("--duration")
                .arg("40000")
                .arg("--out")
                .arg(tmp.join(out))
                .arg("--quiet"),
        );
    }
    assert_same_tracks(&tmp.join("a"), &tmp.join("b"));
    for f in ["mission.toml", "planner_inputs.csv", "plot.svg"] {
        assert_eq!(
            read(&tmp.join("a").join(f)),
            read(&tmp.join("b").join(f)),
            "{f}"
        );
    }
    let (mut a, mut b) = (summary(&tmp.join("a")), summary(&tmp.join("b")));
    a["wall_time_s"] = 0.into();
    b["wall_time_s"] = 0.into();
    assert_eq!(a, b);
    // Another seed gives another run.
    run_ok(
        vbap()
            .arg("sim")
            .arg(&file)
            .arg("--duration")
            .arg("40000")
            .arg("--seed")
            .arg("2")
            .arg("--out")
            .arg(tmp.join("c"))
            .arg("--quiet"),
    );
    assert_ne!(
        read(&tmp.join("a/vehicles.csv")),
        read(&tmp.join("c/vehicles.csv"))
    );
}

#[test]
fn formation_json_reproduces_table_i() {
    let table = [
        (3, 1.910),
        (4, 1.432),
        (5, 1.146),
        (6, 0.955),
        (7, 0.818),
        (8, 0.716),
    ];
    for (n, g) in table {
        let out = run_ok(vbap().args(["formation", "--n", &n.to_string(), "--dim", "2", "--json"]));
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let got = v["g"].as_f64().unwrap();
        assert!((got - g).abs() < 5e-4, "N = {n}: g = {got}, Table I {g}");
        assert_eq!(v["positions"].as_array().unwrap().len(), n);
        assert!(v["radius"].as_f64().unwrap() > 0.0);
        assert_eq!(v["second_moments"].as_array().unwrap().len(), 2);
    }
    let bad = vbap()
        .args(["formation", "--n", "2", "--dim", "2"])
        .output()
        .unwrap();
    assert_eq!(bad.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&bad.stderr).contains("--n"));
}

#[test]
fn check_names_the_key_and_exits_2() {
    let tmp = TempDir::new("check");
    let file = write_mission(
        &tmp,
        "bad.toml",
        "[mission]\nname = \"bad\"\ndt = 0.0\n[field]\ncenter = [1.0, 1.0]\namplitude = 1.0\nwidth = 1.0\n",
    );
    let out = vbap().arg("check").arg(&file).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("mission.dt") && err.contains("bad.toml"),
        "{err}"
    );
    let file = write_mission(&tmp, "unknown.toml", "[vehicles]\ncolor = 3\n");
    let out = vbap().arg("check").arg(&file).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("color"));
}

#[test]
fn with_fewer_vehicles_than_a_gradient_needs_the_body_holds_and_says_so() {
    let tmp = TempDir::new("hold");
    let text = r#"
[mission]
name = "hold"
duration = 6.0
dt = 0.05
[field]
center = [20.0, 10.0]
amplitude = 10.0
width = 15.0
noise_std = 0.1
[vehicles]
count = 3
damping = 5.0
[formation]
alpha = 60.0
[body]
v_u = 10.0
[[faults]]
kind = "kill"
vehicle = 1
at = 2.0
"#;
    let file = write_mission(&tmp, "hold.toml", text);
    vbap_quiet("sim", &file, &tmp.join("sim"));
    let events = read(&tmp.join("sim/events.jsonl"));
    assert!(events.contains("\"holding\""), "{events}");
    let s = summary(&tmp.join("sim"));
    assert!(s["holding_ticks"].as_u64().unwrap() >= 70, "{s}");
    // From the loss on, the body neither moves nor changes speed.
    let body = columns::Table::read(&tmp.join("sim/body.csv"));
    let after: Vec<columns::Row<'_>> = body.rows().filter(|r| r.num("t") >= 2.05).collect();
    assert!(
        after
            .iter()
            .all(|r| r.num("sdot") == 0.0 && r.num("n_vehicles") == 2.0),
        "sdot 0 and two vehicles after the loss"
    );
    assert!(
        after
            .windows(2)
            .all(|w| w[0].num("rx") == w[1].num("rx") && w[0].num("ry") == w[1].num("ry")),
        "r stays put"
    );
}
