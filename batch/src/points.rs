//! The figures of every grid point (`batch.json` `points`) and the table that puts the grid
//! points side by side.

use std::collections::BTreeMap;

use serde::Serialize;

use super::row::SeedResult;
use super::stats::{rate_of, wilson, Distribution, Z95};
use super::sweep::Point;

/// The figures of one grid point over its seeds.
#[derive(Clone, Debug, Default, Serialize)]
pub struct PointAggregate {
    /// Index in the grid.
    pub index: usize,
    /// The swept keys' values here (key → value as written in `batch.csv`).
    pub values: BTreeMap<String, String>,
    pub runs: usize,
    pub completed: usize,
    pub converged: usize,
    /// Converged runs ÷ runs (a failed run counts as not converged).
    pub success_rate: f64,
    /// 95 % Wilson score interval of the success rate, `[low, high]`.
    pub success_ci95: [f64; 2],
    /// Over the converged runs, s.
    pub time_to_converge_s: Distribution,
    /// The true max V/V_U, over the completed runs.
    #[serde(rename = "max_V_over_VU")]
    pub max_v_over_vu: Distribution,
    /// Share of the completed runs that ended with every live vehicle in formation.
    pub formation_intact_rate: Option<f64>,
    /// Messages delivered per run, over the completed runs.
    pub messages_delivered: Distribution,
    /// Messages delivered ÷ sent, summed over the completed runs.
    pub delivery_rate: Option<f64>,
}

/// The figures of every point of `points` from `rows` (the rows of a point: `r.point ==
/// index`).
pub fn per_point(rows: &[SeedResult], points: &[Point], keys: &[String]) -> Vec<PointAggregate> {
    points
        .iter()
        .map(|p| {
            let mine: Vec<&SeedResult> = rows.iter().filter(|r| r.point == p.index).collect();
            let mut a = of_rows(&mine);
            a.index = p.index;
            a.values = keys.iter().cloned().zip(p.labels()).collect();
            a
        })
        .collect()
}

/// The figures of `rows`.
fn of_rows(rows: &[&SeedResult]) -> PointAggregate {
    let done: Vec<&SeedResult> = rows.iter().copied().filter(|r| r.ok()).collect();
    let converged: Vec<&SeedResult> = done.iter().copied().filter(|r| r.converged).collect();
    let (sent, delivered) = done.iter().fold((0u64, 0u64), |(s, d), r| {
        (
            s + r.messages_sent.unwrap_or(0),
            d + r.messages_delivered.unwrap_or(0),
        )
    });
    PointAggregate {
        runs: rows.len(),
        completed: done.len(),
        converged: converged.len(),
        success_rate: if rows.is_empty() {
            0.0
        } else {
            converged.len() as f64 / rows.len() as f64
        },
        success_ci95: wilson(converged.len(), rows.len(), Z95),
        time_to_converge_s: Distribution::of(
            converged
                .iter()
                .filter_map(|r| r.time_to_converge_s)
                .collect(),
        ),
        max_v_over_vu: Distribution::of(done.iter().filter_map(|r| r.max_v_over_vu).collect()),
        formation_intact_rate: rate_of(&done, SeedResult::formation_intact),
        messages_delivered: Distribution::of(
            done.iter()
                .filter_map(|r| r.messages_delivered.map(|d| d as f64))
                .collect(),
        ),
        delivery_rate: (sent > 0).then(|| delivered as f64 / sent as f64),
        ..PointAggregate::default()
    }
}

/// The grid points side by side: a column per point (its values on the first lines), a row
/// per figure.
pub fn table(points: &[PointAggregate], keys: &[String]) -> String {
    let pct = |v: Option<f64>| v.map_or("-".into(), |v| format!("{:.0}%", 100.0 * v));
    let num = |d: &Distribution, f: fn(&Distribution) -> f64, digits: usize| {
        if d.n == 0 {
            "-".to_string()
        } else {
            format!("{:.*}", digits, f(d))
        }
    };
    let mut rows: Vec<(String, Vec<String>)> = keys
        .iter()
        .map(|k| {
            (
                k.clone(),
                points.iter().map(|p| p.values[k].clone()).collect(),
            )
        })
        .collect();
    let figure = |name: &str, f: &dyn Fn(&PointAggregate) -> String| {
        (name.to_string(), points.iter().map(f).collect::<Vec<_>>())
    };
    rows.push(figure("runs", &|p| p.runs.to_string()));
    rows.push(figure("success", &|p| {
        format!("{}/{} {}", p.converged, p.runs, pct(Some(p.success_rate)))
    }));
    rows.push(figure("  95% CI", &|p| {
        format!(
            "{:.0}-{:.0}%",
            100.0 * p.success_ci95[0],
            100.0 * p.success_ci95[1]
        )
    }));
    rows.push(figure("converge p50 (s)", &|p| {
        num(&p.time_to_converge_s, |d| d.p50, 0)
    }));
    rows.push(figure("converge max (s)", &|p| {
        num(&p.time_to_converge_s, |d| d.max, 0)
    }));
    rows.push(figure("true V/V_U max", &|p| {
        num(&p.max_v_over_vu, |d| d.max, 3)
    }));
    rows.push(figure(
        "formation intact",
        &|p| pct(p.formation_intact_rate),
    ));
    rows.push(figure("delivered p50", &|p| {
        num(&p.messages_delivered, |d| d.p50, 0)
    }));
    rows.push(figure("delivered/sent", &|p| pct(p.delivery_rate)));
    let first = rows.iter().map(|r| r.0.chars().count()).max().unwrap_or(0);
    let widths: Vec<usize> = (0..points.len())
        .map(|i| {
            rows.iter()
                .map(|r| r.1[i].chars().count())
                .max()
                .unwrap_or(0)
        })
        .collect();
    let mut out = String::new();
    for (name, cells) in &rows {
        out.push_str(&format!("{name:<first$}"));
        for (c, w) in cells.iter().zip(&widths) {
            out.push_str(&format!("  {c:>w$}"));
        }
        out.push('\n');
    }
    out
}
