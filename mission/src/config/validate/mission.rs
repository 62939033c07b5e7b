//! `[mission]`: name, seed, time, pace, dimension, tolerance and labels.

use super::super::toml_text::num;
use super::super::{MissionSection, Pace, MAX_NAME_LEN, MAX_TICKS};
use super::{Check, Checked};

/// Checks `[mission]`.
pub(super) fn check(c: &Check, m: &MissionSection) -> Checked {
    let name_ok = !m.name.is_empty()
        && m.name.len() <= MAX_NAME_LEN
        && m.name
            .chars()
            .all(|ch| ch.is_ascii_alphanumeric() || ch == '_');
    c.ensure(
        name_ok,
        "mission.name",
        format!("{:?}", m.name),
        "must be 1 to 32 letters, digits or _",
    )?;
    c.ensure(
        m.seed <= i64::MAX as u64,
        "mission.seed",
        m.seed,
        "must be ≤ 9223372036854775807 (a TOML integer)",
    )?;
    c.positive("mission.dt", m.dt)?;
    c.positive("mission.duration", m.duration)?;
    c.at_least("mission.duration", m.duration, "mission.dt", m.dt)?;
    c.ensure(
        m.duration / m.dt <= MAX_TICKS,
        "mission.duration",
        num(m.duration),
        &format!(
            "duration / dt = {} ticks: at most 10 million",
            (m.duration / m.dt).round()
        ),
    )?;
    if let Pace::Factor(x) = m.pace {
        c.finite("mission.pace", x)?;
        c.ensure(
            x > 0.0,
            "mission.pace",
            num(x),
            "must be \"lockstep\" or a real-time factor > 0",
        )?;
    }
    c.ensure(
        m.dim == 2 || m.dim == 3,
        "mission.dim",
        m.dim,
        "must be 2 or 3",
    )?;
    c.positive("mission.tolerance", m.tolerance)?;
    for (key, label) in [
        ("mission.length_unit", &m.length_unit),
        ("mission.field_label", &m.field_label),
    ] {
        c.ensure(
            label.chars().count() <= MAX_NAME_LEN && !label.chars().any(char::is_control),
            key,
            format!("{label:?}"),
            "must be at most 32 characters, without control characters",
        )?;
    }
    if let Some(start) = &m.start {
        let parsed =
            time::OffsetDateTime::parse(start, &time::format_description::well_known::Rfc3339);
        c.ensure(
            parsed.is_ok(),
            "mission.start",
            format!("{start:?}"),
            "must be an RFC 3339 date and time, e.g. \"2026-08-01T00:00:00Z\"",
        )?;
    }
    Ok(())
}
