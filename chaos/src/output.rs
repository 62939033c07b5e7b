//! The campaign on paper: `chaos.csv` (a row per action), the line per finished run, and
//! the table printed on the terminal.

use std::fmt::Display;

use vbap_mission::rundir::Percentiles;

use super::report::{Action, Campaign, RunReport};

/// `v`, or "-" when there is none.
fn or_dash<T: Display>(v: Option<T>) -> String {
    v.map_or("-".into(), |v| v.to_string())
}

/// Header of `chaos.csv`.
pub const CSV_HEADER: &str = "run,pace,policy,seed,action,target,pid,at_s,pause_s,sent,judged,detected,detected_t,detection_ms,restarted_ms,rejoined,rejoin_t,reconfigured,survived,declared_lost,recovered,verdict,outcome";

pub(super) fn csv(c: &Campaign) -> String {
    fn o<T: std::fmt::Display>(v: Option<T>) -> String {
        v.map(|v| v.to_string()).unwrap_or_default()
    }
    fn quote(s: &str) -> String {
        if s.contains([',', '"', '\n']) {
            format!("\"{}\"", s.replace('"', "\"\"").replace('\n', " "))
        } else {
            s.to_string()
        }
    }
    let mut out = String::from(CSV_HEADER);
    out.push('\n');
    for r in &c.runs {
        for a in &r.actions {
            out.push_str(&format!(
                "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n",
                r.index,
                r.pace,
                r.policy,
                r.seed,
                a.action,
                quote(&a.target),
                o(a.pid),
                o(a.at_s),
                o(a.pause_s),
                a.sent,
                a.judged,
                o(a.detected),
                o(a.detected_t),
                o(a.detection_ms),
                o(a.restarted_ms),
                o(a.rejoined),
                o(a.rejoin_t),
                o(a.reconfigured),
                o(a.survived),
                o(a.declared_lost),
                o(a.recovered),
                quote(&r.verdict),
                quote(&a.outcome)
            ));
        }
    }
    out
}

/// The line printed when a run is over.
pub(super) fn describe(r: &RunReport) -> String {
    let sent = r.actions.iter().filter(|a| a.sent).count();
    let bad = r.actions.iter().filter(|a| a.failed()).count();
    format!(
        "run {:03} ({}pace {}, policy {}): exit {}, {:.1} s, ticks {}/{}, {} action(s) sent, {} failed, {} leftover(s){}",
        r.index,
        if r.calibration { "calibration, " } else { "" },
        r.pace,
        r.policy,
        or_dash(r.exit_code),
        r.wall_s,
        or_dash(r.ticks),
        r.expected_ticks,
        sent,
        bad,
        r.leftover_files.len() + r.leftover_processes.len(),
        if r.failures.is_empty() { "" } else { ": FAILED" }
    )
}

/// The table printed on the terminal: one line per action, one per run, totals.
pub fn table(c: &Campaign) -> String {
    let mut s = action_table(c);
    s.push_str(&run_table(c));
    s.push_str(&totals(c));
    s
}

/// A line per action, with its legend.
fn action_table(c: &Campaign) -> String {
    let mut s = format!(
        "{:>3} {:>8} {:>10} {:>4} {:<16} {:>7} {:>6} {:>8} {:>9} {:>9} {:>8} {:>8}  {}\n",
        "run",
        "pace",
        "policy",
        "act",
        "target",
        "at s",
        "det",
        "det t",
        "det ms",
        "restart",
        "rejoin",
        "reconf",
        "outcome"
    );
    for r in &c.runs {
        for a in &r.actions {
            s.push_str(&action_line(r, a));
        }
    }
    s.push_str(
        "(det: kill detected, or stopped process survived; det t: mission time of the `lost` \
         event; det ms: SIGKILL to the coordinator's first command after its verdict, or to \
         the new process of a coordinator or field server; restart: SIGKILL to a new process \
         in the slot; act+: part of a compound fault, see chaos.json `compound`)\n\n",
    );
    s
}

fn action_line(r: &RunReport, a: &Action) -> String {
    fn o(v: Option<f64>, d: usize) -> String {
        v.map_or("-".into(), |v| format!("{v:.d$}"))
    }
    fn b(v: Option<bool>) -> &'static str {
        match v {
            Some(true) => "yes",
            Some(false) => "NO",
            None => "-",
        }
    }
    format!(
        "{:>3} {:>8} {:>10} {:>4} {:<16} {:>7} {:>6} {:>8} {:>9} {:>9} {:>8} {:>8}  {}\n",
        r.index,
        r.pace,
        r.policy,
        if a.compound.is_some() {
            format!("{}+", a.action)
        } else {
            a.action.clone()
        },
        if a.target.is_empty() { "-" } else { &a.target },
        o(a.at_s, 2),
        if a.action == "stop" {
            b(a.survived)
        } else {
            b(a.detected)
        },
        o(a.detected_t, 2),
        o(a.detection_ms, 0),
        o(a.restarted_ms, 0),
        b(a.rejoined),
        b(a.reconfigured),
        a.outcome
    )
}

/// A line per run, with its legend.
fn run_table(c: &Campaign) -> String {
    let mut s = format!(
        "{:>3} {:>8} {:>10} {:>5} {:>9} {:>6} {:>5} {:>8} {:>8} {:>9} {:>6} {:>9}  {}\n",
        "run",
        "pace",
        "policy",
        "exit",
        "ticks",
        "late",
        "lost",
        "rejoined",
        "reconfig",
        "rst a/c/f",
        "left",
        "wall s",
        "verdict"
    );
    for r in &c.runs {
        s.push_str(&run_line(r));
    }
    s.push_str(
        "(late: ticks whose states were not all in at the deadline; rst a/c/f: processes \
         the supervisor started again, agents/coordinator/field server; left: leftover files \
         and processes)\n",
    );
    s
}

fn run_line(r: &RunReport) -> String {
    let restarts = |kind: &str| r.restarts_seen.get(kind).copied().unwrap_or(0);
    format!(
        "{:>3} {:>8} {:>10} {:>5} {:>9} {:>6} {:>5} {:>8} {:>8} {:>9} {:>6} {:>9.1}  {}{}\n",
        r.index,
        r.pace,
        if r.calibration { "(calib.)" } else { &r.policy },
        or_dash(r.exit_code),
        or_dash(r.ticks),
        or_dash(r.late_ticks),
        or_dash(r.vehicles_lost),
        or_dash(r.vehicles_rejoined),
        or_dash(r.reconfigurations),
        format!(
            "{}/{}/{}",
            restarts("agents"),
            restarts("coordinator"),
            restarts("field_server")
        ),
        r.leftover_files.len() + r.leftover_processes.len(),
        r.wall_s,
        r.verdict,
        if r.reasons.is_empty() {
            String::new()
        } else {
            format!(" ({})", r.reasons.join("; "))
        }
    )
}

/// The totals' lines.
fn totals(c: &Campaign) -> String {
    let t = &c.totals;
    let dist = |n: usize, p: &Percentiles| {
        if n == 0 {
            "none".to_string()
        } else {
            format!(
                "n {n}, p50 {:.0}, p90 {:.0}, p99 {:.0}, max {:.0}",
                p.p50, p.p90, p.p99, p.max
            )
        }
    };
    format!(
        "\n{} runs ({} failed); kills: {} sent, {} judged, {} detected, {} undetected, {} recovered; stops: {} sent, {} ok; {} not sent, {} unjudged; {} judged action(s) failed\n\
         agent detection ms: {}; the coordinators' own detection_latency_ms: {}; restart ms (coordinator, field server): {}\ncompound faults: {} action(s) sent, {} failed; late ticks {}; leftovers: {} files, {} processes\n",
        t.runs, t.runs_failed, t.kills_sent, t.kills_judged, t.kills_detected, t.kills_undetected, t.kills_recovered, t.stops_sent, t.stops_ok, t.not_sent, t.unjudged, t.actions_failed,
        dist(t.agent_detection_n, &t.agent_detection_ms),
        dist(t.coordinator_detection_n, &t.coordinator_detection_ms),
        dist(t.restart_n, &t.restart_ms),
        t.compound_sent,
        t.compound_failed,
        t.late_ticks,
        t.leftover_files,
        t.leftover_processes
    )
}
