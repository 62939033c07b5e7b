//! End-to-end tests of `vbap batch --sweep`: every number of `batch.json` recomputed from
//! `batch.csv` (independently, here), a resumed batch equal to a straight one, and bad
//! sweep input refused naming the key.

#[path = "sweep/recompute.rs"]
mod recompute;

use std::path::Path;

use recompute::{compare, read_rows, recompute};
use serde_json::{json, Value};
use tests::*;

/// A short mission (300 ticks, 3 vehicles) with a `[batch]` table: a criterion and a sweep
/// of the link loss.
fn mission(name: &str) -> String {
    format!(
        r#"
[mission]
name = "{name}"
seed = 5
duration = 15.0
dt = 0.05
goal = "max"
tolerance = 1.0

[field]
kind = "gaussian"
center = [4.0, 2.0]
amplitude = 10.0
width = 6.0
noise_std = 0.1

[vehicles]
count = 3
start_spread = 0.3

[links]
delay = 0.1
loss = 0.0

[batch]
min_convergence_rate = 0.0

[batch.sweep]
"links.loss" = [0.0, 0.4]
"#
    )
}

/// `vbap batch FILE --seeds 3 --sweep control.law=paper,robust --in-process --out OUT`
/// with `extra` arguments.
fn batch(file: &Path, out: &Path, extra: &[&str]) -> std::process::Output {
    vbap()
        .arg("batch")
        .arg(file)
        .args(["--seeds", "3", "--in-process", "--quiet"])
        .args(["--sweep", "control.law=paper,robust", "--out"])
        .arg(out)
        .args(extra)
        .output()
        .expect("spawning vbap batch")
}

#[test]
fn every_number_of_batch_json_is_recomputed_from_batch_csv() {
    let tmp = TempDir::new("sweepcsv");
    let file = write_mission(&tmp, "m.toml", &mission("sweepcsv"));
    let out = tmp.join("b");
    let run = batch(&file, &out, &["--jobs", "2"]);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stderr}");
    let (header, rows) = read_rows(&out.join("batch.csv"));
    assert_eq!(rows.len(), 2 * 2 * 3, "2 x 2 grid x 3 seeds");
    assert_eq!(&header[header.len() - 2..], ["links.loss", "control.law"]);
    let actual: Value = serde_json::from_str(&read(&out.join("batch.json"))).unwrap();
    assert_eq!(
        actual,
        serde_json::from_slice::<Value>(&run.stdout).unwrap()
    );
    // The inputs of the batch, not figures of its runs: checked against the command line.
    assert_eq!(actual["mission"], "sweepcsv");
    assert_eq!(actual["mode"], "in-process");
    assert_eq!(actual["jobs"], 2);
    assert_eq!(actual["criteria"], json!({"min_convergence_rate": 0.0}));
    assert_eq!(actual["passed"], true);
    assert_eq!(actual["failures"], json!([]));
    assert!(actual["batch_wall_time_s"].as_f64().unwrap() > 0.0);
    let inputs = [
        "/mission",
        "/mode",
        "/jobs",
        "/criteria",
        "/passed",
        "/failures",
        "/batch_wall_time_s",
    ];
    let mut compared = 0;
    compare(
        &actual,
        &recompute(&header, &rows),
        "",
        &inputs,
        &mut compared,
    );
    // 4 points x (6 numbers + 2 interval bounds + 3 distributions of 7 + 2 rates) + the
    // whole batch: not a vacuous comparison.
    assert!(compared > 150, "{compared} numbers compared");
    // The sweep really changed the runs: no losses without loss, some with.
    let delivered: Vec<f64> = actual["points"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p["delivery_rate"].as_f64().unwrap())
        .collect();
    assert_eq!(delivered[0], 1.0, "{delivered:?}");
    assert!(delivered[3] < 0.9, "{delivered:?}");
    // The points side by side and a plot per swept key.
    let table = read(&out.join("points.txt"));
    assert!(table.starts_with("links.loss "), "{table}");
    assert!(table.lines().nth(1).unwrap().contains("paper"), "{table}");
    for svg in ["sweep_links_loss.svg", "sweep_control_law.svg"] {
        assert!(read(&out.join(svg)).contains("<svg"), "{svg}");
    }
    assert!(out
        .join("p3_links.loss=0.4_control.law=robust/seed_7/summary.json")
        .is_file());
}

/// A run's files that a resume must leave alone, with their modification times.
fn fingerprint(dir: &Path) -> Vec<(String, Vec<u8>, std::time::SystemTime)> {
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file())
        .map(|p| {
            let meta = std::fs::metadata(&p).unwrap();
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            (name, std::fs::read(&p).unwrap(), meta.modified().unwrap())
        })
        .collect();
    files.sort();
    files
}

/// `text` without the column `col` (CSV without quoted commas in the other cells).
fn without_column(text: &str, col: &str) -> String {
    let (header, _) = text.split_once('\n').unwrap();
    let i = header.split(',').position(|h| h == col).unwrap();
    text.lines()
        .map(|l| {
            let mut cells: Vec<&str> = l.split(',').collect();
            cells.remove(i);
            cells.join(",")
        })
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn an_interrupted_batch_resumes_to_the_straight_result() {
    let tmp = TempDir::new("sweepresume");
    let file = write_mission(&tmp, "m.toml", &mission("sweepresume"));
    let straight = tmp.join("straight");
    let first = batch(&file, &straight, &[]);
    assert!(
        first.status.success(),
        "{}",
        String::from_utf8_lossy(&first.stderr)
    );

    // What a batch killed during its 9th run leaves: 8 runs complete, one begun (files
    // but no summary), one whose summary was cut short, the rest never started; no
    // batch.csv. Made from the straight batch's own files.
    let out = tmp.join("resumed");
    std::fs::create_dir_all(&out).unwrap();
    std::fs::copy(straight.join("plan.json"), out.join("plan.json")).unwrap();
    let points = [
        "p0_links.loss=0.0_control.law=paper",
        "p1_links.loss=0.0_control.law=robust",
        "p2_links.loss=0.4_control.law=paper",
        "p3_links.loss=0.4_control.law=robust",
    ];
    let mut kept = Vec::new();
    for (i, p) in points.iter().enumerate() {
        for seed in 5..8 {
            let rel = format!("{p}/seed_{seed}");
            let run = i * 3 + (seed - 5);
            if run >= 10 {
                continue;
            }
            let to = out.join(&rel);
            std::fs::create_dir_all(&to).unwrap();
            for f in std::fs::read_dir(straight.join(&rel)).unwrap() {
                let f = f.unwrap().path();
                if f.is_file() {
                    std::fs::copy(&f, to.join(f.file_name().unwrap())).unwrap();
                }
            }
            match run {
                8 => std::fs::remove_file(to.join("summary.json")).unwrap(),
                9 => {
                    let s = read(&to.join("summary.json"));
                    std::fs::write(to.join("summary.json"), &s[..s.len() / 2]).unwrap();
                }
                _ => kept.push((rel.clone(), fingerprint(&to))),
            }
        }
    }
    assert_eq!(kept.len(), 8);
    let run = batch(&file, &out, &["--jobs", "2"]);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stderr}");
    assert!(
        stderr.contains("8 run(s) complete already, 4 run now"),
        "{stderr}"
    );
    for (rel, before) in &kept {
        assert_eq!(&fingerprint(&out.join(rel)), before, "{rel} was touched");
    }
    // The runs made now are the straight batch's runs, file for file.
    for rel in [
        "p2_links.loss=0.4_control.law=paper/seed_7",
        "p3_links.loss=0.4_control.law=robust/seed_5",
        "p3_links.loss=0.4_control.law=robust/seed_7",
    ] {
        for f in ["vehicles.csv", "body.csv", "truth.csv", "events.jsonl"] {
            assert_eq!(
                read(&out.join(rel).join(f)),
                read(&straight.join(rel).join(f)),
                "{rel}/{f}"
            );
        }
    }
    // The table equals the straight one but for the wall times of the runs made now.
    let (a, b) = (
        read(&out.join("batch.csv")),
        read(&straight.join("batch.csv")),
    );
    assert_eq!(a.lines().count(), 13);
    assert_eq!(
        without_column(&a, "wall_time_s"),
        without_column(&b, "wall_time_s")
    );
    for (la, lb) in a.lines().zip(b.lines()).take(9) {
        assert_eq!(la, lb, "a skipped run's row is the straight run's row");
    }
    let mut ja: Value = serde_json::from_str(&read(&out.join("batch.json"))).unwrap();
    let mut jb: Value = serde_json::from_str(&read(&straight.join("batch.json"))).unwrap();
    for j in [&mut ja, &mut jb] {
        for k in ["batch_wall_time_s", "wall_time_s", "jobs"] {
            j.as_object_mut().unwrap().remove(k);
        }
    }
    assert_eq!(ja, jb);

    // Another sweep on the same directory is refused, naming what differs.
    let other = vbap()
        .arg("batch")
        .arg(&file)
        .args([
            "--seeds",
            "3",
            "--in-process",
            "--sweep",
            "control.law=paper",
            "--out",
        ])
        .arg(&out)
        .output()
        .unwrap();
    assert_eq!(other.status.code(), Some(2));
    let e = String::from_utf8_lossy(&other.stderr);
    assert!(e.contains("the sweep differs"), "{e}");
}

#[test]
fn bad_sweep_input_exits_2_naming_the_key() {
    let tmp = TempDir::new("sweepbad");
    let file = write_mission(&tmp, "m.toml", &mission("sweepbad"));
    for (sweep, needle) in [
        ("links.lost=0,1", "links.lost"),
        ("links.loss=0.1,abc", "--sweep links.loss=abc"),
        ("links.loss=0.1,2", "--sweep links.loss=2"),
        ("links.loss=", "links.loss: empty list"),
        ("control.law=paper,fast", "--sweep control.law=fast"),
    ] {
        let out = tmp.join("never");
        let run = vbap()
            .arg("batch")
            .arg(&file)
            .args(["--seeds", "2", "--in-process", "--sweep", sweep, "--out"])
            .arg(&out)
            .output()
            .unwrap();
        let e = String::from_utf8_lossy(&run.stderr);
        assert_eq!(run.status.code(), Some(2), "{sweep}: {e}");
        assert!(e.contains(needle), "{sweep}: {e}");
        assert!(!out.exists(), "{sweep}: nothing written");
    }
    let bad = mission("sweepbad").replace("[0.0, 0.4]", "[]");
    let file = write_mission(&tmp, "bad.toml", &bad);
    let run = vbap()
        .arg("batch")
        .arg(&file)
        .args(["--seeds", "2", "--in-process", "--out"])
        .arg(tmp.join("never"))
        .output()
        .unwrap();
    let e = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(2), "{e}");
    assert!(
        e.contains("batch.sweep.links.loss: must be a non-empty list"),
        "{e}"
    );
}
