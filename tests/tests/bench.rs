//! `vbap bench --quick` end to end: every floor and every system run is measured, the
//! figures come out as positive ratios and the run leaves nothing behind. Nothing here
//! asserts a speed: the bench only reports (a slow machine gives slow figures, not a
//! failure).

use tests::*;

#[test]
fn quick_bench_measures_every_floor_and_run() {
    let tmp = TempDir::new("bench");
    let json = tmp.join("bench.json");
    // The runs' directories go into the test's own directory (removed with it).
    let out = run_ok(
        vbap()
            .args(["bench", "--quick", "--out"])
            .arg(&json)
            .arg("--work-dir")
            .arg(tmp.join("work")),
    );
    let text = String::from_utf8_lossy(&out.stdout);
    for section in [
        "1. state → coordinator hop",
        "2. lockstep ticks per second",
        "3. real-time capacity",
        "4. simulated glider-days",
        "5. start-up and memory",
        "Goals",
        "busy polling",
        "6. lockstep tick against the skeleton floor",
        "run / (+ serial)",
        "7. state hop p50 (N = 4) / warm raw iceoryx2 p50, 5 interleaved repetitions",
        "8. fan-out of one command",
    ] {
        assert!(text.contains(section), "no {section:?} in\n{text}");
    }
    let r: serde_json::Value = serde_json::from_str(&read(&json)).expect("bench.json is JSON");
    for floor in [
        "hop_iceoryx2",
        "hop_udp",
        "hop_iceoryx2_poll",
        "hop_udp_poll",
    ] {
        let p50 = r[floor]["one_way_us"]["p50"].as_f64().unwrap_or(0.0);
        assert!(p50 > 0.0, "{floor}: {}", r[floor]);
        assert!(r[floor]["samples"].as_u64().unwrap() > 0);
    }
    let lockstep = r["lockstep"].as_array().unwrap();
    assert_eq!(lockstep.len(), 3, "N = 4, 16, 64 in --quick");
    for row in lockstep {
        assert!(row["error"].is_null(), "{row}");
        for rate in [
            "run_ticks_per_s",
            "in_process_ticks_per_s",
            "wake_floor_ticks_per_s",
        ] {
            assert!(row[rate].as_f64().unwrap() > 0.0, "{rate}: {row}");
        }
        // What one vehicle is told: its own neighbours, fewer bytes than the fleet's
        // snapshot every vehicle read before (from N = 16 on).
        let told = row["command_mean_b"].as_f64().unwrap();
        let shared = row["shared_snapshot_b"].as_f64().unwrap();
        assert!(told > 0.0 && shared > 0.0, "{row}");
        if row["vehicles"].as_u64().unwrap() >= 16 {
            assert!(told < shared, "{row}");
        }
    }
    assert!(text.contains("what one vehicle is told"), "{text}");
    for side in ["sim", "run"] {
        let g = &r["glider"][side];
        assert!(g["error"].is_null(), "glider {side}: {g}");
        assert!(
            g["days_per_wall_min"].as_f64().unwrap() > 0.0,
            "glider {side}: {g}"
        );
    }
    for row in r["realtime"]["rows"].as_array().unwrap() {
        assert!(row["error"].is_null(), "{row}");
        assert!(row["ticks"].as_u64().unwrap() > 0, "{row}");
    }
    // Issue 17: the skeleton floor beside every lockstep run, 5 hop repetitions, the
    // fan-out through both transports.
    let o = &r["overhead"];
    let skeleton = o["skeleton"].as_array().unwrap();
    assert_eq!(skeleton.len(), 3, "{o}");
    for row in skeleton {
        assert!(row["skeleton_ticks_per_s"].as_f64().unwrap() > 0.0, "{row}");
        assert!(row["ratio"].as_f64().unwrap() > 0.0, "{row}");
        // The critical-path bound adds vbap sim's work, every part of it measured, to
        // the skeleton's tick: fewer ticks per second than the skeleton.
        let parts = row["sim_parts_us"].as_array().unwrap();
        assert_eq!(parts.len(), 3, "{row}");
        assert!(parts.iter().all(|p| p.as_f64().unwrap() > 0.0), "{row}");
        let critical = row["critical_path_ticks_per_s"].as_f64().unwrap();
        assert!(critical > 0.0, "{row}");
        assert!(
            critical < row["skeleton_ticks_per_s"].as_f64().unwrap(),
            "{row}"
        );
        assert!(row["ratio_critical_path"].as_f64().unwrap() > 0.0, "{row}");
    }
    let repeats = o["hop_repeats"].as_array().unwrap();
    assert_eq!(repeats.len(), 5, "{o}");
    for p in repeats {
        assert!(p["floor_p50_us"].as_f64().unwrap() > 0.0, "{p}");
        assert!(p["ratio"].as_f64().unwrap() > 0.0, "{p}");
    }
    for side in ["iceoryx2", "udp"] {
        let f = &o["fanout"][side];
        assert!(f["cpu_us"].as_f64().unwrap() > 0.0, "{side}: {f}");
        assert!(f["last_us"]["p50"].as_f64().unwrap() > 0.0, "{side}: {f}");
        assert!(f["rounds"].as_u64().unwrap() > 0, "{side}: {f}");
    }
    let goals: Vec<String> = r["goals"]
        .as_array()
        .unwrap()
        .iter()
        .map(|g| g["goal"].as_str().unwrap().to_string())
        .collect();
    assert!(goals.len() >= 10, "{goals:?}");
    for name in [
        "lockstep tick / skeleton tick (N = 16)",
        "hop p50 / warm raw iceoryx2 (N = 4, median of 5)",
        "fan-out CPU, UDP / iceoryx2 (N = 256)",
        "proposed: lockstep tick / (+ serial) (N = 16)",
        "proposed: fan-out copy, UDP sends / our write (N = 256)",
        "proposed: hop p50 / skeleton hop p50 (N = 4, median of 5)",
    ] {
        assert!(
            goals.iter().any(|g| g == name),
            "no goal {name:?}: {goals:?}"
        );
    }
    // Every helper and every run was reaped, every shared-memory file removed.
    assert!(processes_mentioning(&tmp.path.to_string_lossy()).is_empty());
    let leftovers: Vec<_> = std::fs::read_dir("/dev/shm")
        .map(|d| {
            d.flatten()
                .map(|e| e.file_name().to_string_lossy().to_string())
                .filter(|n| n.starts_with("vbap_bench"))
                .collect()
        })
        .unwrap_or_default();
    assert!(leftovers.is_empty(), "{leftovers:?}");
}
