//! The human-readable report of `vbap analyze`: the hop table, the loop table and the
//! lockstep tick breakdown.

use std::fmt::Write as _;

use super::{LoopReport, Report, TickReport};

/// Above this many vehicle agents, the loop table lists only the median and the worst one.
const AGENTS_LISTED: usize = 8;

impl Report {
    /// The human-readable report of `vbap analyze`.
    pub fn to_text(&self) -> String {
        let mut out = String::new();
        let _ = writeln!(out, "pace: {}, {} message records", self.pace, self.records);
        hop_table(&mut out, self);
        loop_table(&mut out, self);
        if let Some(t) = &self.tick {
            tick_table(&mut out, t);
        }
        let _ = writeln!(out, "\nlate ticks: {}", self.late_ticks);
        out
    }
}

/// An injected delay (ms of mission time) in the unit of its size: "250 ms", "45 min".
fn delay(ms: f64) -> String {
    if ms == 0.0 {
        "0".to_string()
    } else {
        crate::plot::style::fmt_duration(ms * 1e-3)
    }
}

/// Per hop: deliveries and drops, transport latency (µs), injected delay.
fn hop_table(out: &mut String, r: &Report) {
    let _ = writeln!(
        out,
        "\n{:<14} {:>9} {:>9} {:>9} │ {:>9} {:>9} {:>9} {:>9} │ {:>9} {:>9} {:>9}",
        "hop",
        "delivered",
        "dropped",
        "overflow",
        "p50 µs",
        "p90 µs",
        "p99 µs",
        "max µs",
        "inj p50",
        "inj p99",
        "inj max"
    );
    for (hop, h) in &r.hops {
        let p = h.transport_us;
        let q = h.injected_ms;
        let _ = writeln!(
            out,
            "{hop:<14} {:>9} {:>9} {:>9} │ {:>9.1} {:>9.1} {:>9.1} {:>9.1} │ {:>9} {:>9} {:>9}",
            h.delivered,
            h.dropped_injected,
            h.dropped_overflow,
            p.p50,
            p.p90,
            p.p99,
            p.max,
            delay(q.p50),
            delay(q.p99),
            delay(q.max)
        );
    }
    let _ = writeln!(
        out,
        "(transport latency = receive − send − injected link delay; dropped = by the link model)"
    );
    let sized: Vec<_> = r
        .hops
        .iter()
        .filter_map(|(hop, h)| Some((hop, h.bytes_mean?, h.bytes_max?, h.bytes_total?)))
        .collect();
    if !sized.is_empty() {
        let _ = writeln!(
            out,
            "\n{:<14} {:>11} {:>11} {:>13}",
            "hop", "mean bytes", "max bytes", "total kB"
        );
        for (hop, mean, max, total) in sized {
            let _ = writeln!(
                out,
                "{hop:<14} {mean:>11.0} {max:>11} {:>13.1}",
                total as f64 / 1e3
            );
        }
        let _ = writeln!(
            out,
            "(sizes in the compact link encoding: what the vehicle's own link would carry)"
        );
    }
}

/// Per process: iterations, nominal period, period and jitter (ms); with many agents, only
/// the median and the worst one (by p99 jitter).
fn loop_table(out: &mut String, r: &Report) {
    let _ = writeln!(
        out,
        "\n{:<28} {:>7} {:>9} │ {:>9} {:>9} {:>9} {:>9} │ {:>9} {:>9} {:>9}",
        "loop",
        "iters",
        "nominal",
        "p50 ms",
        "p90 ms",
        "p99 ms",
        "max ms",
        "jit p50",
        "jit p99",
        "jit max"
    );
    let agents: Vec<(&String, &LoopReport)> = r
        .loops
        .iter()
        .filter(|(k, _)| k.starts_with("vehicle_agent"))
        .collect();
    for (name, l) in &r.loops {
        if !name.starts_with("vehicle_agent") || agents.len() <= AGENTS_LISTED {
            loop_line(out, name, l);
        }
    }
    if agents.len() > AGENTS_LISTED {
        // Many agents: the median one and the worst one (by p99 jitter).
        let mut by_jitter = agents.clone();
        by_jitter.sort_by(|a, b| a.1.jitter_ms.p99.total_cmp(&b.1.jitter_ms.p99));
        let (mname, median) = by_jitter[by_jitter.len() / 2];
        let (wname, worst) = by_jitter[by_jitter.len() - 1];
        loop_line(out, &format!("{mname} (median)"), median);
        loop_line(out, &format!("{wname} (worst)"), worst);
        let _ = writeln!(out, "({} agents; all of them in --json)", agents.len());
    }
}

/// One row of the loop table.
fn loop_line(out: &mut String, name: &str, l: &LoopReport) {
    let p = l.period_ms;
    let j = l.jitter_ms;
    let _ = writeln!(
        out,
        "{name:<28} {:>7} {:>9.3} │ {:>9.3} {:>9.3} {:>9.3} {:>9.3} │ {:>9.3} {:>9.3} {:>9.3}",
        l.iterations, l.nominal_ms, p.p50, p.p90, p.p99, p.max, j.p50, j.p99, j.max
    );
}

/// Where the time of a lockstep tick goes (µs).
fn tick_table(out: &mut String, t: &TickReport) {
    let _ = writeln!(
        out,
        "\n{:<28} {:>9} {:>9} {:>9} {:>9}   ({} lockstep ticks)",
        "tick", "p50 µs", "p90 µs", "p99 µs", "max µs", t.ticks
    );
    for (name, p) in [
        ("period", t.period_us),
        ("waiting for states", t.waiting_for_states_us),
        ("after the last state", t.after_last_state_us),
    ] {
        let _ = writeln!(
            out,
            "{name:<28} {:>9.1} {:>9.1} {:>9.1} {:>9.1}",
            p.p50, p.p90, p.p99, p.max
        );
    }
}
