//! `vbap bench --hosts --quick` end to end (root: network namespaces): the mission over
//! three hosts, its skeleton over the same hosts and the raw Zenoh floor are all measured,
//! over plain TCP and over mutual TLS, the ratios come out positive, and nothing is left
//! behind. Nothing here asserts a speed: the bench only reports.

use tests::*;

/// The number after `label` on the line that holds it.
fn figure(text: &str, label: &str) -> f64 {
    let line = text
        .lines()
        .find(|l| l.contains(label))
        .unwrap_or_else(|| panic!("no {label:?} in\n{text}"));
    let after = &line[line.find(label).unwrap() + label.len()..];
    after
        .split_whitespace()
        .find_map(|w| w.trim_matches(|c: char| c == ',' || c == '=').parse().ok())
        .unwrap_or_else(|| panic!("no number after {label:?} in {line:?}"))
}

#[test]
fn hosts_bench_measures_the_mission_against_its_skeleton_over_tcp_and_tls() {
    let tmp = TempDir::new("benchhosts");
    let namespaces_before = netns_list();
    let out = run_ok(
        vbap()
            .args(["bench", "--hosts", "--quick", "--work-dir"])
            .arg(tmp.join("work")),
    );
    let text = String::from_utf8_lossy(&out.stdout).to_string();
    println!("{text}");
    let legs: Vec<&str> = text.split("-- ").skip(1).collect();
    assert_eq!(
        legs.len(),
        3,
        "plain TCP, mutual TLS, the cost of TLS:\n{text}"
    );
    for (leg, name) in legs.iter().zip(["plain TCP", "mutual TLS"]) {
        assert!(leg.starts_with(name), "{leg}");
        for label in [
            "round trip p50",
            "state@hosts hop       p50",
            "tick, 3 hosts         p50",
            "skeleton over hosts   state hop p50",
            "tick p50",
            "hop / skeleton's hop",
            "3-host tick / skeleton's tick",
        ] {
            let v = figure(leg, label);
            assert!(v > 0.0 && v.is_finite(), "{name}: {label} = {v}");
        }
    }
    assert!(legs[2].starts_with("the cost of TLS"), "{}", legs[2]);
    assert_eq!(
        netns_list(),
        namespaces_before,
        "network namespaces left behind"
    );
}

/// The network namespaces that exist now, sorted.
fn netns_list() -> Vec<String> {
    let out = std::process::Command::new("ip")
        .args(["netns", "list"])
        .output()
        .expect("ip netns list (iproute2)");
    let mut v: Vec<String> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| l.split_whitespace().next().unwrap_or("").to_string())
        .collect();
    v.sort();
    v
}
