//! `[links]` (delay, loss, surfacing, bursts) and `[restart]`.

use super::super::toml_text::num;
use super::super::{IridiumSection, LinksSection, RestartSection};
use super::{Check, Checked};
use vbap_wire::compact::Precision;

/// Checks `[links]`.
pub(super) fn links(c: &Check, l: &LinksSection) -> Checked {
    c.non_negative("links.delay", l.delay)?;
    c.non_negative("links.jitter", l.jitter)?;
    c.ensure(
        l.jitter <= l.delay,
        "links.jitter",
        num(l.jitter),
        &format!("must be ≤ links.delay = {}", num(l.delay)),
    )?;
    c.probability_below_one("links.loss", l.loss, "")?;
    c.non_negative("links.position_quantum", l.position_quantum)?;
    c.non_negative("links.surfacing_period", l.surfacing_period)?;
    c.non_negative("links.surfacing_window", l.surfacing_window)?;
    c.ensure(
        l.surfacing_window <= l.surfacing_period,
        "links.surfacing_window",
        num(l.surfacing_window),
        &format!(
            "must be ≤ links.surfacing_period = {}",
            num(l.surfacing_period)
        ),
    )?;
    if l.surfacing_period > 0.0 {
        c.ensure(
            l.surfacing_window > 0.0,
            "links.surfacing_window",
            num(l.surfacing_window),
            "must be > 0 when links.surfacing_period > 0 (else never in contact)",
        )?;
    }

    for (key, value) in [
        ("links.burst_enter", l.burst_enter),
        ("links.burst_exit", l.burst_exit),
        ("links.burst_loss", l.burst_loss),
    ] {
        c.finite(key, value)?;
        c.ensure(
            (0.0..=1.0).contains(&value),
            key,
            num(value),
            "must be in [0, 1]",
        )?;
    }
    if l.burst_enter > 0.0 {
        c.ensure(
            l.burst_exit > 0.0,
            "links.burst_exit",
            num(l.burst_exit),
            "must be > 0 when links.burst_enter > 0 (else the bad state never ends)",
        )?;
        c.ensure(
            l.burst_loss < 1.0,
            "links.burst_loss",
            num(l.burst_loss),
            "must be < 1",
        )?;
    }
    if let Some(iridium) = &l.iridium {
        self::iridium(c, iridium)?;
    }
    Ok(())
}

/// The smallest `links.iridium.up_limit`: one state report must fit in one message.
const REPORT_BYTES: u64 = vbap_wire::compact::StateReport::LEN as u64;

/// Checks `[links.iridium]`.
fn iridium(c: &Check, i: &IridiumSection) -> Checked {
    c.positive("links.iridium.session_interval", i.session_interval)?;
    c.probability_below_one(
        "links.iridium.session_failure",
        i.session_failure,
        " (1: no session ever succeeds)",
    )?;
    c.ensure(
        i.up_limit >= REPORT_BYTES,
        "links.iridium.up_limit",
        i.up_limit,
        &format!("must be ≥ {REPORT_BYTES} bytes (one state report)"),
    )?;
    let least = vbap_wire::compact::command_len(None, 0, None, &[], Precision::Exact) as u64;
    c.ensure(
        i.down_limit >= least,
        "links.iridium.down_limit",
        i.down_limit,
        &format!("must be ≥ {least} bytes (a command telling nothing)"),
    )?;
    c.non_negative("links.iridium.latency_short", i.latency_short)?;
    c.finite("links.iridium.latency_full", i.latency_full)?;
    c.at_least(
        "links.iridium.latency_full",
        i.latency_full,
        "links.iridium.latency_short",
        i.latency_short,
    )
}

/// Checks `[restart]`.
pub(super) fn restart(c: &Check, r: &RestartSection) -> Checked {
    c.positive("restart.backoff", r.backoff)?;
    c.positive("restart.max_backoff", r.max_backoff)?;
    c.positive("restart.window", r.window)?;
    Ok(())
}
