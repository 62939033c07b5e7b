//! `vbap analyze RUN_DIR`: timing analysis of a run from its message records.
//!
//! Every receiver records each message it receives over IPC (event `recv`) in
//! `logs/<process>.msgs.csv` ([`vbap_wire::msglog`], the format and its units), with the
//! sender's wall-clock send time `sent_ns` and its own receive time `recv_ns` (all
//! processes share one host clock): their difference is the hop's *transport* latency. The
//! link model (docs/ARCHITECTURE.md §7) works in mission time after reception and records its verdicts
//! separately: `held` (with `injected_ns`, the delay it added) and `drop` (with `reason`:
//! `"loss"`, `"burst"`, `"link_down"`, … are counted as *injected* drops, `"overflow"` as
//! queue overflow). A hop's deliveries are then its receptions minus its injected drops,
//! and the deliveries without a `held` record were delivered at once (0 ms).
//!
//! Run directories of earlier versions carry the same records as JSON lines of target
//! `vbap::msg` in `logs/<process>.jsonl` (message `"recv"`, `"held"` with hop `<hop>_link`
//! and `injected_ms`, `"drop"`); they are read too, into the same figures, and a process
//! may have records in both files. JSON reception records that carry `injected_ms`
//! themselves are read as well: then every reception is a delivery and the transport
//! latency is `recv_ns − sent_ns − injected`.
//!
//! Loops: an agent's loop is driven by the body commands it receives, so its period is the
//! time between consecutive body receptions; the coordinator's period is the time between
//! consecutive body publications (their `sent_ns`, read from the agents' records). Jitter
//! is |period − nominal|, the nominal period being dt / pace factor in real-time runs and
//! the median period in lockstep runs (as fast as possible: no nominal period). The field
//! server answers requests and has no loop of its own.
//!
//! Logs of big fleets run to millions of lines: files are streamed and read in parallel;
//! CSV lines are split in place, and of the JSON logs only lines containing the target
//! string are parsed (with a borrowed, typed deserializer, not a generic JSON tree).
//!
//! Lockstep ticks: from the coordinator's publications and the states it received, the
//! time of each tick split into waiting for the agents' states and the coordinator's own
//! work after the last one ([`TickReport`]).
//!
//! The module's parts: [`report`] (the figures), `records` (reading the logs), `compute`
//! (the figures from the records), `text` (the tables of [`Report::to_text`]).
//!
//! [`analyze`] also writes `latency.svg` (per-hop distributions) and `loops.svg` (loop
//! period over the run and jitter distributions) into the run directory.

use std::path::Path;

use anyhow::Result;
use vbap_wire::msglog::MSG_SUFFIX;
use vbap_wire::msglog::MSG_TARGET;
use vbap_wire::rundir::RunDir;

mod compute;
pub mod plots;
mod records;
mod report;
mod text;

pub use compute::compute;
pub use report::{Distributions, HopReport, LoopReport, Report, TickReport};

/// Seconds since the Unix epoch of an RFC 3339 UTC timestamp as the tracing logs write it
/// (`2026-12-01T17:24:09.458255Z`); None when it is not one.
pub fn parse_utc(ts: &str) -> Option<f64> {
    if !ts.ends_with('Z') {
        return None;
    }
    let t = time::OffsetDateTime::parse(ts, &time::format_description::well_known::Rfc3339).ok()?;
    Some(t.unix_timestamp() as f64 + f64::from(t.nanosecond()) * 1e-9)
}

/// File name of the latency plot.
pub const LATENCY_SVG: &str = "latency.svg";
/// File name of the loop plot.
pub const LOOPS_SVG: &str = "loops.svg";

/// `vbap analyze RUN_DIR [--json]`: prints the report and writes the plots; returns the
/// exit code. A directory without message records is invalid input (exit 2): the message
/// says what is missing, and no empty table or plot is written.
pub fn main(run_dir: &Path, json: bool) -> Result<i32> {
    let invalid = |why: String| -> anyhow::Error {
        crate::InvalidRunDir(format!("{}: {why}", run_dir.display())).into()
    };
    let logs = run_dir.join("logs");
    if !logs.is_dir() {
        if !run_dir.join("mission.toml").is_file() {
            return Err(invalid(
                "not a run directory (no mission.toml, no logs/)".into(),
            ));
        }
        return Err(invalid(format!(
            "no message records to analyse: {} does not exist ({NO_RECORDS_HINT})",
            logs.display()
        )));
    }
    let dir = RunDir {
        root: run_dir.to_path_buf(),
    };
    let (report, dists) = compute(&dir)?;
    if report.records == 0 {
        let unparsed = if report.unparsed > 0 {
            format!("; {} record lines could not be parsed", report.unparsed)
        } else {
            String::new()
        };
        return Err(invalid(format!(
            "no message records to analyse: no logs/*{MSG_SUFFIX} with records and no `{MSG_TARGET}` records in logs/*.jsonl{unparsed} ({NO_RECORDS_HINT})"
        )));
    }
    if let Err(e) = plots::write_plots(&dir, &report, &dists) {
        tracing::warn!(error = %format!("{e:#}"), "writing the analysis plots");
    }
    if json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        print!("{}", report.to_text());
        eprintln!(
            "plots: {}, {}",
            dir.root.join(LATENCY_SVG).display(),
            dir.root.join(LOOPS_SVG).display()
        );
    }
    Ok(vbap_wire::exit::EXIT_OK)
}

/// Why a run directory may hold no message records.
const NO_RECORDS_HINT: &str = "`vbap sim` runs in one process and records no messages; \
`vbap run` records them unless RUST_LOG turned them off";

/// Reads the logs of `dir` and computes the report (the plots are drawn by
/// [`crate::draw_run`] or [`plots::write_plots`]).
pub fn analyze(dir: &RunDir) -> Result<Report> {
    Ok(compute(dir)?.0)
}

#[cfg(test)]
mod tests;
