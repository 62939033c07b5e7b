//! Recomputing `batch.json` from `batch.csv`, independently of vbap's code: the CSV read
//! by the `csv` crate, the figures computed here (nearest-rank percentiles, Wilson
//! interval), and a leaf-by-leaf comparison.

use std::collections::BTreeMap;
use std::path::Path;

use serde_json::{json, Value};

/// The rows of `batch.csv`, each a map column → cell, in file order.
pub fn read_rows(path: &Path) -> (Vec<String>, Vec<BTreeMap<String, String>>) {
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

pub type Row = BTreeMap<String, String>;

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
pub fn recompute(header: &[String], rows: &[Row]) -> Value {
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
pub fn compare(actual: &Value, expected: &Value, path: &str, inputs: &[&str], n: &mut usize) {
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
