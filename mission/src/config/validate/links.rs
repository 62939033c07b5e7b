//! `[links]` (delay, loss, surfacing, bursts) and `[restart]`.

use super::super::toml_text::num;
use super::super::{LinksSection, RestartSection};
use super::{Check, Checked};

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
    c.finite("links.loss", l.loss)?;
    c.ensure(
        (0.0..1.0).contains(&l.loss),
        "links.loss",
        num(l.loss),
        "must be in [0, 1)",
    )?;
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
    Ok(())
}

/// Checks `[restart]`.
pub(super) fn restart(c: &Check, r: &RestartSection) -> Checked {
    c.positive("restart.backoff", r.backoff)?;
    c.positive("restart.max_backoff", r.max_backoff)?;
    c.positive("restart.window", r.window)?;
    Ok(())
}
