//! End-to-end tests of `vbap stress` (the real binary, the in-process simulator as flyer):
//! a small campaign's table files exist and agree with its result lines, a rerun resumes to
//! the same table, bad input exits 2; and `ci_slice`, a fixed 40-mission slice under the
//! default law that must pass entirely.

use std::path::Path;

use serde_json::Value;
use tests::*;

/// `vbap stress --missions M --seed S --jobs 2 --out OUT` with `extra` arguments.
fn stress(missions: u64, seed: u64, out: &Path, extra: &[&str]) -> std::process::Output {
    vbap()
        .arg("stress")
        .args(["--missions", &missions.to_string()])
        .args(["--seed", &seed.to_string(), "--jobs", "2", "--quiet"])
        .arg("--out")
        .arg(out)
        .args(extra)
        .output()
        .expect("running vbap stress")
}

fn json(path: &Path) -> Value {
    serde_json::from_str(&read(path)).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

#[test]
fn a_small_campaign_writes_a_consistent_table_and_resumes_to_the_same() {
    let tmp = TempDir::new("stress");
    let out = tmp.join("c");
    let first = stress(6, 11, &out, &["--law", "both"]);
    let code = first.status.code();
    assert!(
        matches!(code, Some(0) | Some(1)),
        "exit {code:?}: {}",
        String::from_utf8_lossy(&first.stderr)
    );
    let printed = String::from_utf8_lossy(&first.stdout).to_string();
    for f in [
        "plan.json",
        "results.jsonl",
        "stress.json",
        "stress.md",
        "grid.nc",
    ] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    // One line per flight: 6 missions × 2 laws.
    let lines: Vec<Value> = read(&out.join("results.jsonl"))
        .lines()
        .map(|l| serde_json::from_str(l).expect("a result line is JSON"))
        .collect();
    assert_eq!(lines.len(), 12);
    let passed = lines.iter().filter(|l| l["pass"] == true).count();
    let table = json(&out.join("stress.json"));
    assert_eq!(table["overall"]["flights"], 12);
    assert_eq!(table["overall"]["passed"], passed);
    assert_eq!(code, Some(if passed == 12 { 0 } else { 1 }));
    // Each law flew every mission; each dimension's bins add up to every flight.
    for law in &table["by_law"].as_array().expect("by_law")[..] {
        assert_eq!(law["flights"], 6);
    }
    for dim in table["dimensions"].as_array().expect("dimensions") {
        let rows = dim[1].as_array().expect("rows");
        let sum: u64 = rows
            .iter()
            .map(|r| r["all"]["flights"].as_u64().unwrap())
            .sum();
        assert_eq!(sum, 12, "{}", dim[0]);
    }
    // A failure keeps its run directory and a mission file that `vbap check` accepts; a
    // pass leaves nothing.
    for l in &lines {
        let name = format!(
            "m{:04}_{}",
            l["mission"].as_u64().unwrap(),
            l["law"].as_str().unwrap()
        );
        let dir = out.join("runs").join(&name);
        if l["pass"] == true {
            assert!(!dir.exists(), "{name} passed but its run directory is kept");
        } else {
            assert!(dir.join("summary.json").is_file(), "{name}: summary kept");
            let file = out.join(l["file"].as_str().expect("a failure's file"));
            let check = vbap().arg("check").arg(&file).output().unwrap();
            assert!(
                check.status.success(),
                "{}",
                String::from_utf8_lossy(&check.stderr)
            );
        }
    }
    assert!(read(&out.join("stress.md")).contains("| overall |"));
    // Again on the same directory: nothing flown, the same table.
    let md = read(&out.join("stress.md"));
    let again = stress(6, 11, &out, &["--law", "both"]);
    assert_eq!(again.status.code(), code);
    assert!(
        String::from_utf8_lossy(&again.stderr).contains("0 flights flown now, 12 resumed"),
        "{}",
        String::from_utf8_lossy(&again.stderr)
    );
    assert_eq!(String::from_utf8_lossy(&again.stdout), printed);
    assert_eq!(read(&out.join("stress.md")), md);
    assert_eq!(json(&out.join("stress.json")), table);
    // Interrupted after 5 flights: the rest is flown, the table is the same.
    let kept: String = read(&out.join("results.jsonl"))
        .lines()
        .take(5)
        .map(|l| format!("{l}\n"))
        .collect();
    std::fs::write(out.join("results.jsonl"), kept).unwrap();
    let resumed = stress(6, 11, &out, &["--law", "both"]);
    assert_eq!(resumed.status.code(), code);
    assert!(String::from_utf8_lossy(&resumed.stderr).contains("7 flights flown now, 5 resumed"));
    assert_eq!(json(&out.join("stress.json")), table);
    // Another plan on it is refused, naming the directory.
    let other = stress(7, 11, &out, &["--law", "both"]);
    assert_eq!(other.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&other.stderr).contains("holds another stress campaign"));
}

#[test]
fn bad_input_exits_2_naming_it() {
    let tmp = TempDir::new("stress-bad");
    for (args, what) in [
        (vec!["--set", "links.lost=0.1"], "lost"),
        (vec!["--set", "links.loss=2"], "links.loss"),
        (vec!["--v-bound", "0"], "--v-bound"),
        (vec!["--law", "fast"], "fast"),
    ] {
        let o = stress(2, 1, &tmp.join("x"), &args);
        assert_eq!(o.status.code(), Some(2), "{args:?}");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains(what), "{args:?}: {err}");
    }
    let space = vbap().args(["stress", "--space"]).output().unwrap();
    assert!(space.status.success());
    assert!(String::from_utf8_lossy(&space.stdout).contains("vehicles N"));
}

/// A fixed slice of the space (seed 29, 40 missions) under the default law, held as a
/// ratchet: every mission passes except those listed in `tests/stress_ci_known.txt`
/// (each with the criteria it fails today). A new failure fails the test (a regression),
/// and so does a listed mission that now passes (take it off the list): the list only
/// shrinks.
#[test]
fn ci_slice() {
    let tmp = TempDir::new("stress-ci");
    let out = tmp.join("ci");
    let o = stress(40, 29, &out, &[]);
    assert!(
        matches!(o.status.code(), Some(0) | Some(1)),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let known: std::collections::BTreeMap<u64, String> =
        read(&workspace().join("tests/stress_ci_known.txt"))
            .lines()
            .filter(|l| !l.trim().is_empty() && !l.starts_with('#'))
            .map(|l| {
                let (m, c) = l.split_once(' ').expect("`MISSION CRITERIA` per line");
                (m.parse().expect("a mission number"), c.trim().to_string())
            })
            .collect();
    let mut failing = std::collections::BTreeMap::new();
    for line in read(&out.join("results.jsonl")).lines() {
        let r: Value = serde_json::from_str(line).expect("a result line");
        if r["pass"] == false {
            let failed: Vec<String> = r["judgement"]["failed"]
                .as_array()
                .expect("failed criteria")
                .iter()
                .map(|c| c.as_str().unwrap_or("?").to_string())
                .collect();
            failing.insert(r["mission"].as_u64().expect("mission"), failed.join(","));
        }
    }
    let printed = String::from_utf8_lossy(&o.stdout);
    for (m, c) in &failing {
        assert_eq!(
            known.get(m),
            Some(c),
            "mission {m} fails {c}, which tests/stress_ci_known.txt does not list: a \
             regression\n{printed}"
        );
    }
    for m in known.keys() {
        assert!(
            failing.contains_key(m),
            "mission {m} now passes: take it off tests/stress_ci_known.txt"
        );
    }
}
