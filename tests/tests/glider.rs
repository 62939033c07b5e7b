//! Issue 14, the motion side, through the real `vbap`: land keeps the vehicles and the body
//! centre out; the glider keys are validated (exit 2 naming the key); the shipped glider
//! mission keeps every glider within its speed through the water.

use tests::columns::Table;
use tests::mission::GaussianHill;
use tests::*;

fn coast_mission(extra: &str) -> String {
    GaussianHill::new(&unique_name("coast"))
        .then(extra)
        .then("[land]\nkind = \"coast\"\npoint = [3.0, 0.0]\nnormal = [-1.0, 0.0]\n")
        .toml()
}

#[test]
fn a_coast_between_start_and_optimum_stops_the_body_and_the_vehicles() {
    let tmp = TempDir::new("coast");
    let file = write_mission(&tmp, "m.toml", &coast_mission(""));
    vbap_quiet("sim", &file, &tmp.join("sim"));
    let body = Table::read(&tmp.join("sim").join("body.csv"));
    let vehicles = Table::read(&tmp.join("sim").join("vehicles.csv"));
    let rx = body.rows().map(|r| r.num("rx")).fold(f64::MIN, f64::max);
    let x = vehicles.rows().map(|r| r.num("x")).fold(f64::MIN, f64::max);
    // The optimum (6, 3) is on land (x > 3): the body goes as far as the coast, no farther.
    assert!(rx <= 3.0, "the body centre went ashore (x = {rx})");
    assert!(
        rx > 2.9,
        "the body centre never reached the coast (x = {rx})"
    );
    assert!(x <= 3.0, "a vehicle went ashore (x = {x})");
    let last = body.row(body.len() - 1);
    assert!(
        last.num("ry") > 1.0,
        "the body did not slide along the coast"
    );
    assert!(
        vehicles.header().iter().any(|c| c == "bx"),
        "the motion columns are written with land"
    );
}

#[test]
fn glider_keys_are_validated_naming_the_key() {
    let tmp = TempDir::new("glkeys");
    for (extra, needle) in [
        ("max_speed = 0.5\n", "vehicles.max_speed"),
        (
            "model = \"glider\"\nmax_speed = -1.0\n",
            "vehicles.max_speed",
        ),
        ("model = \"boat\"\n", "model"),
    ] {
        let file = write_mission(&tmp, "bad.toml", &coast_mission(extra));
        let out = vbap().arg("check").arg(&file).output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{extra}: {stderr}");
        assert!(stderr.contains(needle), "{extra}: {stderr}");
    }
    let bad_current = coast_mission("").replace("[land]", "[current]\nkind = \"grid\"\n\n[land]");
    let file = write_mission(&tmp, "grid.toml", &bad_current);
    let out = vbap().arg("check").arg(&file).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("current.kind"));
}

/// Under the robust law a body flown by gliders never turns faster than half their
/// `max_turn_rate` nor speeds up faster than min(max_accel/4, v0·Ω/π) (docs/guide/
/// vehicles.md): the shipped diving gliders (Ω = 3 rad/s, max_accel 4 L/s², v0 0.5 L/s,
/// ideal links, so each tick's body velocity is its decision) from the body's track. Its
/// planner would turn as fast as the gradient estimate and start at v0 at once.
#[test]
fn the_body_never_turns_or_speeds_up_faster_than_its_gliders_follow() {
    let tmp = TempDir::new("bodylim");
    let text = read(&workspace().join("deploy/missions/dive3d.toml")).replacen(
        "name = \"dive3d\"",
        &format!("name = \"{}\"", unique_name("bodylim")),
        1,
    );
    let file = write_mission(&tmp, "m.toml", &text);
    vbap_quiet("sim", &file, &tmp.join("sim"));
    let body = Table::read(&tmp.join("sim").join("body.csv"));
    let dt = 0.05;
    let r: Vec<(f64, f64)> = body.rows().map(|b| (b.num("rx"), b.num("ry"))).collect();
    let v: Vec<(f64, f64)> = r
        .windows(2)
        .map(|w| ((w[1].0 - w[0].0) / dt, (w[1].1 - w[0].1) / dt))
        .collect();
    let (accel, omega) = ((0.5 * 3.0 / std::f64::consts::PI).min(1.0), 1.5);
    let (mut fastest_turn, mut top_speed) = (0.0f64, 0.0f64);
    for w in v.windows(2) {
        let (a, b) = (w[0], w[1]);
        let (sa, sb) = (a.0.hypot(a.1), b.0.hypot(b.1));
        top_speed = top_speed.max(sb);
        assert!(
            sb - sa <= accel * dt * (1.0 + 1e-6) + 1e-9,
            "the body sped up {} L/s in a tick",
            sb - sa
        );
        if sa > 1e-6 && sb > 1e-6 {
            let turn = (a.0 * b.1 - a.1 * b.0).atan2(a.0 * b.0 + a.1 * b.1).abs() / dt;
            fastest_turn = fastest_turn.max(turn);
            assert!(
                turn <= omega * (1.0 + 1e-6),
                "the body turned at {turn} rad/s"
            );
        }
    }
    // The limits were reached, so they are what held the body.
    assert!(
        fastest_turn > 0.9 * omega,
        "fastest turn {fastest_turn} rad/s"
    );
    assert!(
        top_speed > 0.4,
        "the body never flew (top speed {top_speed} L/s)"
    );
}
