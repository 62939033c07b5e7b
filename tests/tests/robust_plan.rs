//! The robust law's committed body path (`[control] law = "robust"`) on the shipped glider
//! surfacing mission, cut to its first eight hours: the body waits until every glider
//! can have heard its plan, then moves only along the path it committed, so gliders out of
//! contact track their slots and the true formation holds where the paper's law tears it.

use std::path::Path;

use tests::*;

/// Runs `vbap sim` of glider_surfacing.toml cut to 30000 s under `law` into `out`.
fn glider_surfacing(tmp: &TempDir, law: &str, out: &Path) -> serde_json::Value {
    let text = read(&workspace().join("deploy/missions/glider_surfacing.toml"))
        .replace("duration = 259200.0", "duration = 30000.0");
    let text = with_law(&text, law);
    assert!(text.contains("duration = 30000.0"), "the mission was cut");
    let file = write_mission(tmp, &format!("{law}.toml"), &text);
    run_ok(
        vbap()
            .arg("sim")
            .arg(&file)
            .arg("--out")
            .arg(out)
            .arg("--quiet"),
    );
    summary(out)
}

#[test]
fn under_the_robust_law_gliders_out_of_contact_keep_the_formation() {
    let tmp = TempDir::new("robust-plan");
    let (paper_dir, robust_dir) = (tmp.join("paper"), tmp.join("robust"));
    let paper = glider_surfacing(&tmp, "paper", &paper_dir);
    let robust = glider_surfacing(&tmp, "robust", &robust_dir);
    let v = |s: &serde_json::Value| s["formation"]["max_V_true_over_VU"].as_f64().unwrap();
    let pair = |s: &serde_json::Value| s["formation"]["min_pair_ratio"].as_f64().unwrap();
    // The paper's law: the body leaves gliders that cannot know it (true V ≫ V_U).
    assert!(v(&paper) > 10.0, "paper: max V/V_U {}", v(&paper));
    assert!(pair(&paper) < 0.5, "paper: nearest pair {}", pair(&paper));
    // The robust law: V stays far below V_U and no pair comes close.
    assert!(v(&robust) < 0.5, "robust: max V/V_U {}", v(&robust));
    assert!(
        pair(&robust) > 0.5,
        "robust: nearest pair {}",
        pair(&robust)
    );
    // The body rests for the plan horizon (period 7200 s + delay 20 s + jitter 10 s +
    // one tick): the deployment plan every glider knows before its first surfacing.
    let body = columns::Table::read(&robust_dir.join("body.csv"));
    let mut moved_at = None;
    for row in body.rows() {
        let (t, rx, ry) = (row.num("t"), row.num("rx"), row.num("ry"));
        if rx != 0.0 || ry != 0.0 {
            moved_at = Some(t);
            break;
        }
    }
    let moved_at = moved_at.expect("the robust body climbs within 30000 s");
    assert!(
        moved_at >= 7240.0,
        "the body left the deployment point at {moved_at} s, before the plan horizon"
    );
}
