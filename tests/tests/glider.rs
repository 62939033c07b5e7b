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
