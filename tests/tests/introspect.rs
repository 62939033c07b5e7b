//! End-to-end test of the introspection tools on a paced `vbap run`: `vbap services` lists
//! the vehicles' state services with nonzero rates, `vbap echo` decodes a state of the right
//! vehicle, and the run directory holds the mission's iceoryx2 config.

use std::time::Duration;

use serde_json::Value;
use tests::*;

#[test]
fn services_and_echo_see_a_paced_mission() {
    let tmp = TempDir::new("introspect");
    let name = unique_name("intro");
    // Real time (pace 1) at dt = 0.05 s: 20 states a second per vehicle, for up to 60 s.
    let text = format!(
        "[mission]\nname = \"{name}\"\nduration = 60.0\ndt = 0.05\npace = 1.0\n\
         [field]\ncenter = [4.0, 2.0]\namplitude = 10.0\nwidth = 6.0\n[vehicles]\ncount = 3\n"
    );
    let file = write_mission(&tmp, "m.toml", &text);
    let out = tmp.join("run");
    let mut run = spawn_run(&file, &out);
    wait_for_ticks(&out, 5);

    let listing = run_ok(vbap().arg("services").arg(&file).arg("--json"));
    let l: Value = serde_json::from_slice(&listing.stdout).expect("services JSON");
    assert_eq!(l["prefix"], format!("vbap_{name}."));
    let nodes: Vec<&str> = l["nodes"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|n| n["alive"] == true)
        .map(|n| n["name"].as_str().unwrap())
        .collect();
    for node in [
        "coordinator",
        "field_server",
        "vehicle_agent_0",
        "vehicle_agent_2",
    ] {
        assert!(nodes.contains(&node), "{node} in {nodes:?}");
    }
    let services = l["services"].as_array().unwrap();
    for id in 0..3 {
        let state = format!("{name}/vehicle/{id}/state");
        let s = services
            .iter()
            .find(|s| s["name"] == state.as_str())
            .unwrap_or_else(|| panic!("{state} in {services:?}"));
        assert_eq!(s["pattern"], "publish_subscribe");
        let rate = s["rate_hz"].as_f64().unwrap();
        assert!(rate > 0.0, "{state}: rate {rate}");
    }
    assert!(services
        .iter()
        .any(|s| s["name"] == format!("{name}/field/sample").as_str()
            && s["pattern"] == "request_response"));

    let echo = run_ok(
        vbap()
            .arg("echo")
            .arg(&file)
            .args(["vehicle/1/state", "--count", "3"]),
    );
    let lines: Vec<Value> = String::from_utf8_lossy(&echo.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).expect("a JSON line"))
        .collect();
    assert_eq!(lines.len(), 3);
    for state in &lines {
        assert_eq!(state["type"], "VehicleState");
        assert_eq!(state["header"]["sender"], 1, "{state}");
        assert_eq!(state["position"].as_array().unwrap().len(), 3);
    }
    assert!(lines[2]["header"]["tick"].as_u64() > lines[0]["header"]["tick"].as_u64());

    // Not a service vbap can decode: invalid input.
    let bad = vbap()
        .arg("echo")
        .arg(&file)
        .arg("vehicle/1/wake")
        .output()
        .unwrap();
    assert_eq!(bad.status.code(), Some(2));

    // The run directory's iceoryx2 config names the mission's prefix.
    let config = read(&out.join("iox2.toml"));
    assert!(
        config.contains(&format!("prefix = \"vbap_{name}.\"")),
        "{config}"
    );

    run.signal("INT");
    let status = run.wait();
    assert_eq!(status.code(), Some(130), "an interrupted run");
    wait_until(
        || leftover_files(&name).is_empty(),
        Duration::from_secs(10),
        "the mission's files to go",
    );
    assert_nothing_left(&name, &tmp);

    // Nothing running: services says so, exit 1, and creates nothing.
    let idle = vbap().arg("services").arg(&file).output().unwrap();
    assert_eq!(idle.status.code(), Some(1));
    assert!(leftover_files(&name).is_empty());
}
