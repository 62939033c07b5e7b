//! The stability envelope (docs/ENVELOPE.md): the shipped `lossy_kill` mission holds its
//! formation when one key moves (half or a third of its sensor noise, or twice its link
//! delay) under the default law, judged by the truth; `vbap check` shows the envelope and
//! refuses a formation the robust law cannot hold; a scale held by the envelope is an
//! event and a summary line.

use tests::*;

fn lossy_kill() -> std::path::PathBuf {
    workspace().join("deploy/missions/lossy_kill.toml")
}

/// `vbap sim` of lossy_kill with `sets`, into `out`: its summary.
fn sim(sets: &[&str], out: &std::path::Path) -> serde_json::Value {
    let mut cmd = vbap();
    cmd.arg("sim").arg(lossy_kill()).arg("--out").arg(out);
    for s in sets {
        cmd.args(["--set", s]);
    }
    run_ok(&mut cmd);
    summary(out)
}

#[test]
fn lossy_kill_holds_its_formation_when_one_key_moves() {
    let tmp = TempDir::new("envelope-rows");
    let rows: [&[&str]; 4] = [
        &[],
        &["field.noise_std=0.05"],
        &["field.noise_std=0.03"],
        &["links.delay=1.0"],
    ];
    for (i, sets) in rows.iter().enumerate() {
        let s = sim(sets, &tmp.join(&format!("row{i}")));
        let f = &s["formation"];
        let v = f["max_V_true_over_VU"].as_f64().unwrap();
        assert_eq!(s["converged"], true, "{sets:?}: {s:#}");
        assert_eq!(
            f["out_of_formation_at_end"].as_array().map(|a| a.len()),
            Some(0),
            "{sets:?}: {s:#}"
        );
        assert_eq!(f["near_collision_ticks"], 0, "{sets:?}");
        // The envelope's promise: true V within 2 V_U (they were 1e4–2e5 V_U before the
        // slot frame stopped turning with stale positions).
        assert!(v <= 2.0, "{sets:?}: true max V/V_U {v}");
    }
}

#[test]
fn check_prints_the_envelope_and_refuses_a_formation_the_links_cannot_hold() {
    let out = run_ok(vbap().arg("check").arg(lossy_kill()));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("envelope (robust law, neighbours 0.7 to 2.8 s old): smallest scale k ="),
        "{text}"
    );
    // The paper's law is shown, never refused: it is the baseline.
    let out = run_ok(
        vbap()
            .arg("check")
            .arg(lossy_kill())
            .args(["--set", "control.law=paper"]),
    );
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("(set by the links"), "{text}");
    // Under the robust law, a glider body faster than the gliders is refused, naming the key.
    let out = vbap()
        .arg("check")
        .arg(workspace().join("deploy/missions/glider_current.toml"))
        .args(["--set", "body.v0=0.5"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("body.v0 = 0.5") && err.contains("cannot follow the body"),
        "{err}"
    );
}

#[test]
fn a_scale_held_by_the_envelope_is_an_event_and_a_summary_line() {
    let tmp = TempDir::new("envelope-held");
    // 16 vehicles on lossy_kill's radius: the time step holds the scale at k ≈ 0.34, above
    // min_scale = 0.2, and low noise makes the adaptation want smaller.
    let s = sim(
        &["vehicles.count=16", "field.noise_std=0.03"],
        &tmp.join("run"),
    );
    let held = s["scale_held_ticks"].as_u64().unwrap();
    assert!(held > 0, "{s:#}");
    let reasons = s["reasons"].to_string();
    assert!(
        reasons.contains("the scale was held at k = 0.3"),
        "{reasons}"
    );
    let events = read(&tmp.join("run/events.jsonl"));
    assert!(events.contains("\"kind\":\"scale_held\""), "{events}");
    assert!(s["final_scale"].as_f64().unwrap() >= 0.3, "{s:#}");
    assert_eq!(s["converged"], true, "{s:#}");
}
