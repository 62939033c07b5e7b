//! End-to-end tests of `vbap batch --sweep`: every number of `batch.json` recomputed from
//! `batch.csv` (independently, here), a resumed batch equal to a straight one, and bad
//! sweep input refused naming the key.

use std::collections::BTreeMap;
use std::path::Path;

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

/// The rows of `batch.csv`, each a map column → cell, in file order.
fn read_rows(path: &Path) -> (Vec<String>, Vec<BTreeMap<String, String>>) {
    let mut r = csv::Reader::from_path(path).expect("batch.csv");
    let header: Vec<String> = r.headers().unwrap().iter().map(String::from).collect();
    let rows = r
        .records()
        .map(|rec| {
            let rec = rec.unwrap();
            header
                .iter()
                .cloned()
                .zip(rec.iter().map(String::from))
                .collect()
        })
        .collect();
    (header, rows)
}

type Row = BTreeMap<String, String>;

fn num(r: &Row, col: &str) -> Option<f64> {
    let cell = &r[col];
    (!cell.is_empty()).then(|| cell.parse().unwrap_or_else(|_| panic!("{col} = {cell}")))
}

fn ok(r: &Row) -> bool {
    r["status"] == "ok"
}

/// n, min, mean, nearest-rank p50/p90/p99, max; zeros when empty.
fn dist(values: Vec<f64>) -> Value {
    if values.is_empty() {
        return json!({"n": 0, "min": 0.0, "mean": 0.0, "p50": 0.0, "p90": 0.0, "p99": 0.0, "max": 0.0});
    }
    let n = values.len();
    let mean = values.iter().sum::<f64>() / n as f64;
    let mut s = values;
    s.sort_by(f64::total_cmp);
    let rank = |q: f64| s[((q * n as f64).ceil() as usize).clamp(1, n) - 1];
    json!({"n": n, "min": s[0], "mean": mean, "p50": rank(0.5), "p90": rank(0.9),
           "p99": rank(0.99), "max": s[n - 1]})
}

/// Share of the rows where `test` is known that it holds; null when known nowhere.
fn share(rows: &[&Row], test: impl Fn(&Row) -> Option<bool>) -> Value {
    let known: Vec<bool> = rows.iter().filter_map(|r| test(r)).collect();
    if known.is_empty() {
        return Value::Null;
    }
    json!(known.iter().filter(|b| **b).count() as f64 / known.len() as f64)
}

/// 95 % Wilson score interval of k successes in n.
fn wilson(k: usize, n: usize) -> Value {
    if n == 0 {
        return json!([0.0, 1.0]);
    }
    let z: f64 = 1.959_963_984_540_054;
    let (n, p) = (n as f64, k as f64 / n as f64);
    let c = (p + z * z / (2.0 * n)) / (1.0 + z * z / n);
    let h = z / (1.0 + z * z / n) * (p * (1.0 - p) / n + z * z / (4.0 * n * n)).sqrt();
    json!([(c - h).max(0.0), (c + h).min(1.0)])
}

fn intact(r: &Row) -> Option<bool> {
    Some(num(r, "alive_at_end")? == num(r, "in_formation_at_end")?)
}

/// The whole-batch figures of `rows`.
fn whole(rows: &[Row]) -> Value {
    let all: Vec<&Row> = rows.iter().collect();
    let done: Vec<&Row> = all.iter().copied().filter(|r| ok(r)).collect();
    let conv: Vec<&Row> = done
        .iter()
        .copied()
        .filter(|r| r["converged"] == "true")
        .collect();
    let col = |rs: &[&Row], c: &str| rs.iter().filter_map(|r| num(r, c)).collect::<Vec<_>>();
    let mut verdicts = serde_json::Map::new();
    for r in &all {
        let v = if ok(r) {
            r["verdict"].clone()
        } else {
            "failed".into()
        };
        let n = all
            .iter()
            .filter(|o| {
                if ok(o) {
                    o["verdict"] == v
                } else {
                    v == "failed"
                }
            })
            .count();
        verdicts.insert(v, json!(n as f64 / all.len() as f64));
    }
    json!({
        "runs": all.len(),
        "completed": done.len(),
        "failed_runs": all.len() - done.len(),
        "converged": conv.len(),
        "convergence_rate": conv.len() as f64 / all.len() as f64,
        "time_to_converge_s": dist(col(&conv, "time_to_converge_s")),
        "final_distance_to_optimum": dist(col(&done, "final_distance_to_optimum")),
        "final_grad_norm": dist(col(&done, "final_grad_norm")),
        "max_V_over_VU": dist(col(&done, "max_V_over_VU")),
        "in_set_m_rate": share(&done, |r| (!r["in_set_m"].is_empty()).then(|| r["in_set_m"] == "true")),
        "verdicts": verdicts,
        "formation_kept_rate": share(&done, intact),
        "near_collision_rate": share(&done, |r| num(r, "near_collision_ticks").map(|n| n > 0.0)),
        "stall_rate": share(&done, |r| num(r, "stalled_s").map(|s| s > 0.0)),
        "max_V_seen_over_VU": dist(col(&done, "max_V_seen_over_VU")),
        "min_pair_ratio": dist(col(&done, "min_pair_ratio")),
        "worst_slot_error": dist(col(&done, "worst_slot_error")),
        "wall_time_s": dist(col(&all, "wall_time_s")),
        "first_seed": all.iter().map(|r| num(r, "seed").unwrap() as u64).min().unwrap(),
    })
}

/// The figures of one grid point: its rows.
fn point(index: usize, values: Value, rows: &[&Row]) -> Value {
    let done: Vec<&Row> = rows.iter().copied().filter(|r| ok(r)).collect();
    let conv: Vec<&Row> = done
        .iter()
        .copied()
        .filter(|r| r["converged"] == "true")
        .collect();
    let col = |rs: &[&Row], c: &str| rs.iter().filter_map(|r| num(r, c)).collect::<Vec<_>>();
    let sent: f64 = col(&done, "messages_sent").iter().sum();
    let delivered = col(&done, "messages_delivered");
    json!({
        "index": index,
        "values": values,
        "runs": rows.len(),
        "completed": done.len(),
        "converged": conv.len(),
        "success_rate": conv.len() as f64 / rows.len() as f64,
        "success_ci95": wilson(conv.len(), rows.len()),
        "time_to_converge_s": dist(col(&conv, "time_to_converge_s")),
        "max_V_over_VU": dist(col(&done, "max_V_over_VU")),
        "formation_intact_rate": share(&done, intact),
        "messages_delivered": dist(delivered.clone()),
        "delivery_rate": if sent > 0.0 { json!(delivered.iter().sum::<f64>() / sent) } else { Value::Null },
    })
}

/// `batch.json` as far as `batch.csv` (and the sweep's columns) determine it.
fn recompute(header: &[String], rows: &[Row]) -> Value {
    let keys: Vec<&String> = header
        .iter()
        .skip_while(|h| *h != "messages_delivered")
        .skip(1)
        .collect();
    let mut expected = whole(rows);
    let mut sweep = Vec::new();
    for k in &keys {
        let mut values: Vec<&str> = Vec::new();
        for r in rows {
            if !values.contains(&r[*k].as_str()) {
                values.push(&r[*k]);
            }
        }
        sweep.push(json!({"key": k, "values": values}));
    }
    // Grid points in the order the rows first show them.
    let mut order: Vec<Vec<&str>> = Vec::new();
    for r in rows {
        let at: Vec<&str> = keys.iter().map(|k| r[*k].as_str()).collect();
        if !order.contains(&at) {
            order.push(at);
        }
    }
    let points: Vec<Value> = order
        .iter()
        .enumerate()
        .map(|(i, at)| {
            let mine: Vec<&Row> = rows
                .iter()
                .filter(|r| keys.iter().zip(at).all(|(k, v)| r[*k] == *v))
                .collect();
            let values: serde_json::Map<String, Value> = keys
                .iter()
                .zip(at)
                .map(|(k, v)| (k.to_string(), json!(v)))
                .collect();
            point(i, Value::Object(values), &mine)
        })
        .collect();
    expected["sweep"] = json!(sweep);
    expected["points"] = json!(points);
    expected
}

/// Compares every leaf of `actual` with `expected` (numbers to 1e-12, relative above 1),
/// except the paths in `inputs` (not figures of the table); returns how many numbers were
/// compared. A leaf of either side missing in the other fails.
fn compare(actual: &Value, expected: &Value, path: &str, inputs: &[&str], n: &mut usize) {
    if inputs.contains(&path) {
        return;
    }
    match (actual, expected) {
        (Value::Object(a), Value::Object(e)) => {
            for k in a.keys().chain(e.keys()) {
                let p = format!("{path}/{k}");
                if inputs.contains(&p.as_str()) {
                    continue;
                }
                let (Some(av), Some(ev)) = (a.get(k), e.get(k)) else {
                    panic!(
                        "{p}: in batch.json {} but recomputed {}",
                        a.contains_key(k),
                        e.contains_key(k)
                    );
                };
                compare(av, ev, &p, inputs, n);
            }
        }
        (Value::Array(a), Value::Array(e)) => {
            assert_eq!(a.len(), e.len(), "{path}: lengths");
            for (i, (av, ev)) in a.iter().zip(e).enumerate() {
                compare(av, ev, &format!("{path}/{i}"), inputs, n);
            }
        }
        (Value::Number(a), Value::Number(e)) => {
            let (a, e) = (a.as_f64().unwrap(), e.as_f64().unwrap());
            assert!(
                (a - e).abs() <= 1e-12 * e.abs().max(1.0),
                "{path}: batch.json {a}, recomputed {e}"
            );
            *n += 1;
        }
        (a, e) => assert_eq!(a, e, "{path}"),
    }
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
