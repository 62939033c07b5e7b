//! The sweep plots: for every swept key, `sweep_<key>.svg` with a panel per figure (success
//! rate, median time to converge, largest true V/V_U, formation intact, messages delivered)
//! against that key's values, one line per combination of the other keys' values.

use std::path::{Path, PathBuf};

use vbap_report::plot::chart::{self, Axis, Figure, Panel, Series};
use vbap_report::plot::style::palette;

use super::points::PointAggregate;
use super::sweep::SweptKey;

/// A figure of a grid point: panel title, axis label, value (none: not known there).
type Figure1 = (
    &'static str,
    &'static str,
    fn(&PointAggregate) -> Option<f64>,
);

const FIGURES: [Figure1; 5] = [
    ("Success rate", "converged / runs", |p| Some(p.success_rate)),
    ("Time to converge (median)", "s", |p| {
        (p.time_to_converge_s.n > 0).then_some(p.time_to_converge_s.p50)
    }),
    ("Largest true V / V_U", "V / V_{U}", |p| {
        (p.max_v_over_vu.n > 0).then_some(p.max_v_over_vu.max)
    }),
    ("Formation intact at the end", "share of runs", |p| {
        p.formation_intact_rate
    }),
    ("Messages delivered (median per run)", "messages", |p| {
        (p.messages_delivered.n > 0).then_some(p.messages_delivered.p50)
    }),
];

/// Writes a plot per swept key into `out`; returns their paths.
pub fn write(
    out: &Path,
    mission: &str,
    keys: &[SweptKey],
    points: &[PointAggregate],
) -> anyhow::Result<Vec<PathBuf>> {
    let mut written = Vec::new();
    for k in keys {
        let fig = figure(mission, k, keys, points);
        let safe: String = k
            .key
            .chars()
            .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
            .collect();
        let path = out.join(format!("sweep_{safe}.svg"));
        chart::write_svg(&fig, &path)?;
        written.push(path);
    }
    Ok(written)
}

/// The figure of key `k`: x is the value when every value of `k` is a number, its index
/// in the list otherwise (named in a note).
fn figure(mission: &str, k: &SweptKey, keys: &[SweptKey], points: &[PointAggregate]) -> Figure {
    let numbers: Option<Vec<f64>> = k.values.iter().map(|v| v.parse().ok()).collect();
    let x_of = |label: &str| -> f64 {
        let i = k.values.iter().position(|v| v == label).unwrap_or(0);
        numbers.as_ref().map_or(i as f64, |n| n[i])
    };
    // The lines: the distinct values of the other keys, in grid order.
    let others = |p: &PointAggregate| -> String {
        keys.iter()
            .filter(|o| o.key != k.key)
            .map(|o| format!("{}={}", o.key, p.values[&o.key]))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let mut lines: Vec<String> = Vec::new();
    for p in points {
        let l = others(p);
        if !lines.contains(&l) {
            lines.push(l);
        }
    }
    let mut notes = Vec::new();
    if numbers.is_none() {
        let named: Vec<String> = k
            .values
            .iter()
            .enumerate()
            .map(|(i, v)| format!("{i} = {v}"))
            .collect();
        notes.push(format!("x: {}", named.join(", ")));
    }
    let panels = FIGURES
        .iter()
        .map(|(title, unit, value)| {
            let x = Axis {
                label: k.key.clone(),
                integer: numbers.is_none(),
                // A categorical key: its values at 0, 1, …, with a margin on both sides.
                range: numbers
                    .is_none()
                    .then(|| (-0.25, k.values.len() as f64 - 0.75)),
                ..Axis::default()
            };
            let y = Axis {
                label: unit.to_string(),
                from_zero: true,
                ..Axis::default()
            };
            let mut panel = Panel::new(title, x, y);
            panel.notes = notes.clone();
            for (i, line) in lines.iter().enumerate() {
                let mut pts: Vec<(f64, f64)> = points
                    .iter()
                    .filter(|p| &others(p) == line)
                    .map(|p| (x_of(&p.values[&k.key]), value(p).unwrap_or(f64::NAN)))
                    .collect();
                pts.sort_by(|a, b| a.0.total_cmp(&b.0));
                let label = if line.is_empty() { "all" } else { line };
                panel.series.push(Series::line(label, pts, palette(i)));
            }
            panel
        })
        .collect();
    Figure {
        title: format!("{mission}: figures against {}", k.key),
        subtitle: format!(
            "one line per value of the other swept keys; {} grid points",
            points.len()
        ),
        panels,
    }
}
