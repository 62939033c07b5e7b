//! `latency.svg` and `loops.svg` of a run with message records: transport latency per hop
//! (CDF and tail), the injected link delay, loop periods over the run and their jitter.

use crate::plot::chart::{self, Axis, Figure, Panel, RefLine, Series};
use crate::plot::style::{TimeUnit, PALETTE};
use anyhow::Result;
use vbap_mission::config::Mission;
use vbap_wire::rundir::{Percentiles, RunDir};

use super::{Distributions, Report, LATENCY_SVG, LOOPS_SVG};

/// Points of the empirical CDF of `sorted` (ascending), at most about `max` of them, the
/// tail kept in full: (value, fraction ≤ value).
pub(super) fn cdf_points(sorted: &[f64], max: usize) -> Vec<(f64, f64)> {
    let n = sorted.len();
    if n == 0 {
        return Vec::new();
    }
    let tail = (max / 4).min(n);
    let body = n - tail;
    let stride = body.div_ceil((max - tail).max(1)).max(1);
    let mut out = Vec::with_capacity(max + 2);
    let mut i = 0;
    while i < body {
        out.push((sorted[i], (i + 1) as f64 / n as f64));
        i += stride;
    }
    for (j, v) in sorted.iter().enumerate().skip(body) {
        out.push((*v, (j + 1) as f64 / n as f64));
    }
    out
}

/// Same as [`cdf_points`] for the complementary CDF: (value, fraction > value), the last
/// point (fraction 0) left out (it has no place on a log axis).
pub(super) fn ccdf_points(sorted: &[f64], max: usize) -> Vec<(f64, f64)> {
    cdf_points(sorted, max)
        .into_iter()
        .map(|(v, f)| (v, 1.0 - f))
        .filter(|&(_, f)| f > 0.0)
        .collect()
}

fn hop_colour(i: usize) -> &'static str {
    PALETTE[i % PALETTE.len()]
}

/// Clamps latencies for a log axis: non-positive values (clock granularity, an injected
/// delay larger than the measured one) are shown at 0.1 µs.
fn positive(v: &[f64]) -> Vec<f64> {
    v.iter().map(|&x| x.max(0.1)).collect()
}

/// Writes `latency.svg` and `loops.svg` into `dir` from the analysis of its records.
pub fn write_plots(dir: &RunDir, report: &Report, d: &Distributions) -> Result<()> {
    let pace = if report.pace == "lockstep" || report.pace == "unknown" {
        report.pace.clone()
    } else {
        format!("{} × real time", report.pace)
    };
    let name = Mission::load(&dir.mission())
        .map(|m| format!("{} (seed {})", m.mission.name, m.mission.seed))
        .unwrap_or_else(|_| dir.root.display().to_string());
    chart::write_svg(
        &latency_figure(&name, &pace, report, d),
        &dir.root.join(LATENCY_SVG),
    )?;
    chart::write_svg(
        &loops_figure(&name, &pace, report, d),
        &dir.root.join(LOOPS_SVG),
    )?;
    Ok(())
}

/// `latency.svg`: transport latency per hop (CDF and tail), the injected delay when there is
/// one, the drops as notes.
fn latency_figure(name: &str, pace: &str, report: &Report, d: &Distributions) -> Figure {
    let mut cdf = Panel::new(
        "Transport latency per hop: cumulative distribution",
        Axis {
            label: "transport latency (µs, log scale)".into(),
            log: true,
            ..Axis::default()
        },
        Axis {
            label: "fraction of messages".into(),
            range: Some((0.0, 1.0)),
            ..Axis::default()
        },
    );
    let mut ccdf = Panel::new(
        "Tail: fraction of messages slower than x",
        Axis {
            label: "transport latency (µs, log scale)".into(),
            log: true,
            ..Axis::default()
        },
        Axis {
            label: "fraction slower".into(),
            log: true,
            ..Axis::default()
        },
    );
    for (i, (hop, values)) in d.transport_us.iter().enumerate() {
        let h = &report.hops[hop];
        let v = positive(values);
        let label = format!(
            "{hop}: p50 {} p99 {} µs",
            short(h.transport_us.p50),
            short(h.transport_us.p99)
        );
        cdf.series
            .push(Series::line(&label, cdf_points(&v, 1500), hop_colour(i)));
        ccdf.series.push(Series::line(
            &format!("{hop} (n = {})", h.received),
            ccdf_points(&v, 1500),
            hop_colour(i),
        ));
    }
    let mut panels = vec![cdf, ccdf];
    panels.extend(injected_panel(d));
    let drops: Vec<String> = report
        .hops
        .iter()
        .filter(|(_, h)| h.dropped_injected + h.dropped_overflow > 0)
        .map(|(k, h)| {
            format!(
                "{k}: {} dropped by the link, {} by overflow",
                h.dropped_injected, h.dropped_overflow
            )
        })
        .collect();
    if let Some(first) = panels.first_mut() {
        first.notes.extend(drops);
    }
    let delivered: u64 = report.hops.values().map(|h| h.delivered).sum();
    Figure {
        title: format!("{name}: message latency"),
        subtitle: format!(
            "{delivered} messages delivered · pace {pace} · transport = receive − send − injected delay"
        ),
        panels,
    }
}

/// The injected link delay per hop (CDF) in the unit of its size; `None` when none was
/// injected.
fn injected_panel(d: &Distributions) -> Option<Panel> {
    let injected: Vec<_> = d
        .injected_ms
        .iter()
        .enumerate()
        .filter(|(_, (_, v))| v.iter().any(|&x| x > 0.0))
        .collect();
    if injected.is_empty() {
        return None;
    }
    {
        // In the unit of its size: ms for a LAN, s for acoustic modems, min or h for
        // gliders that hold their reports until they surface.
        let largest_ms = injected
            .iter()
            .flat_map(|(_, (_, v))| v.iter().copied())
            .fold(0.0, f64::max);
        let unit = TimeUnit::for_magnitude(largest_ms * 1e-3);
        let mut p = Panel::new(
            "Injected link delay (link model): cumulative distribution",
            Axis {
                label: unit.axis_label("injected delay, mission time"),
                time: Some(unit),
                ..Axis::default()
            },
            Axis {
                label: "fraction of messages".into(),
                range: Some((0.0, 1.0)),
                ..Axis::default()
            },
        );
        for (i, (hop, v)) in injected {
            let in_unit: Vec<f64> = v.iter().map(|ms| unit.of(ms * 1e-3)).collect();
            p.series
                .push(Series::line(hop, cdf_points(&in_unit, 1500), hop_colour(i)));
        }
        Some(p)
    }
}

/// `loops.svg`: the period over the run as the median and the maximum of each of a few
/// hundred buckets of ticks (per-tick lines of several processes are unreadable), and the
/// jitter distributions.
fn loops_figure(name: &str, pace: &str, report: &Report, d: &Distributions) -> Figure {
    let agents: Vec<&String> = d
        .periods
        .keys()
        .filter(|k| k.starts_with("vehicle_agent"))
        .collect();
    Figure {
        title: format!("{name}: loop timing"),
        subtitle: format!(
            "pace {pace} · coordinator: publish to publish · agents: body command to body command · late ticks: {}",
            report.late_ticks
        ),
        panels: vec![period_panel(report, d, &agents), jitter_panel(d, &agents)],
    }
}

/// The loop period over the run: median and maximum per bucket of ticks, the coordinator's
/// and the agents' pooled.
fn period_panel(report: &Report, d: &Distributions, agents: &[&String]) -> Panel {
    let mut period = Panel::new(
        "Loop period over the run (median and maximum of each bucket of ticks)",
        Axis {
            label: "tick".into(),
            ..Axis::default()
        },
        Axis {
            label: "period (ms, log scale)".into(),
            log: true,
            ..Axis::default()
        },
    );
    let mut groups: Vec<(String, Vec<(u64, f64)>)> = Vec::new();
    if let Some(p) = d.periods.get("coordinator") {
        groups.push(("coordinator".into(), p.clone()));
    }
    if !agents.is_empty() {
        let mut pooled: Vec<(u64, f64)> = agents
            .iter()
            .flat_map(|a| d.periods[*a].iter().copied())
            .collect();
        pooled.sort_by_key(|&(k, _)| k);
        let label = if agents.len() == 1 {
            agents[0].clone()
        } else {
            format!("{} agents", agents.len())
        };
        groups.push((label, pooled));
    }
    for (i, (label, points)) in groups.iter().enumerate() {
        let (median, max) = bucket_stats(points, 200);
        period.series.push(Series::line(
            &format!("{label}: median"),
            median,
            hop_colour(i),
        ));
        period.series.push(Series {
            dashed: true,
            ..Series::line(&format!("{label}: max"), max, hop_colour(i))
        });
    }
    if let Some((lo, hi)) = groups
        .iter()
        .flat_map(|(_, p)| p.iter().map(|&(k, _)| k))
        .fold(None, |acc: Option<(u64, u64)>, k| {
            Some(acc.map_or((k, k), |(a, b)| (a.min(k), b.max(k))))
        })
    {
        period.x.range = Some((lo as f64, hi.max(lo + 1) as f64));
    }
    if let Some(n) = report.loops.values().next().map(|l| l.nominal_ms) {
        if report.pace != "lockstep" {
            period.hlines.push(RefLine {
                y: n,
                label: format!("nominal {} ms", short(n)),
                colour: "#555555",
            });
        }
    }
    period
}

/// The jitter of the loops (CDF): each process when few, else the agents pooled.
fn jitter_panel(d: &Distributions, agents: &[&String]) -> Panel {
    let mut jitter = Panel::new(
        "Loop jitter |period − nominal|: cumulative distribution",
        Axis {
            label: "jitter (ms, log scale)".into(),
            log: true,
            ..Axis::default()
        },
        Axis {
            label: "fraction of ticks".into(),
            range: Some((0.0, 1.0)),
            ..Axis::default()
        },
    );
    // Jitter: each process when few, else the coordinator and the agents pooled.
    let mut jitter_sets: Vec<(String, Vec<f64>)> = Vec::new();
    if let Some(j) = d.jitter_ms.get("coordinator") {
        jitter_sets.push(("coordinator".into(), j.clone()));
    }
    if agents.len() <= 6 {
        for a in agents {
            jitter_sets.push(((*a).clone(), d.jitter_ms[*a].clone()));
        }
    } else {
        let pooled: Vec<f64> = agents
            .iter()
            .flat_map(|a| d.jitter_ms[*a].iter().copied())
            .collect();
        jitter_sets.push((format!("all {} agents", agents.len()), pooled));
    }
    for (i, (label, mut values)) in jitter_sets.into_iter().enumerate() {
        for v in &mut values {
            *v = v.max(1e-4);
        }
        values.sort_by(|a, b| a.total_cmp(b));
        jitter.series.push(Series::line(
            &label,
            cdf_points(&values, 1500),
            hop_colour(i),
        ));
    }
    jitter
        .notes
        .push("jitter below 0.1 µs is drawn at 0.1 µs".into());
    jitter
}

/// Points (x, y) of a plotted series.
type Points = Vec<(f64, f64)>;

/// The median and the maximum of y over buckets of consecutive x (`points` sorted by x),
/// about `buckets` of them, each placed at its middle x.
fn bucket_stats(points: &[(u64, f64)], buckets: usize) -> (Points, Points) {
    let (Some(first), Some(last)) = (points.first(), points.last()) else {
        return (Vec::new(), Vec::new());
    };
    let width = (last.0 - first.0 + 1)
        .div_ceil(buckets.max(1) as u64)
        .max(1);
    let mut median = Vec::new();
    let mut max = Vec::new();
    let mut i = 0;
    let mut values = Vec::new();
    while i < points.len() {
        let b = (points[i].0 - first.0) / width;
        values.clear();
        let mut j = i;
        while j < points.len() && (points[j].0 - first.0) / width == b {
            values.push(points[j].1);
            j += 1;
        }
        let x = (points[i].0 + points[j - 1].0) as f64 / 2.0;
        let p = Percentiles::of(&mut values);
        median.push((x, p.p50));
        max.push((x, p.max));
        i = j;
    }
    (median, max)
}

/// A number with 3 significant digits.
fn short(v: f64) -> String {
    if v == 0.0 {
        return "0".into();
    }
    let digits = (2 - v.abs().log10().floor() as i32).max(0) as usize;
    format!("{v:.digits$}")
}
