//! `[[faults]]`: each fault's vehicle, times and value against the rest of the mission.

use super::super::toml_text::num;
use super::super::{FaultKind, Mission, RestartPolicy};
use super::{Check, Checked};

/// Checks every `[[faults]]` entry against `[mission]`, `[vehicles]` and `[restart]`.
pub(super) fn check(c: &Check, mission: &Mission) -> Checked {
    let (m, v) = (&mission.mission, &mission.vehicles);
    for (i, fault) in mission.faults.iter().enumerate() {
        let k = format!("faults[{i}]");
        c.ensure(
            (fault.vehicle as usize) < v.count,
            &format!("{k}.vehicle"),
            fault.vehicle,
            &format!("must be < vehicles.count = {}", v.count),
        )?;
        c.finite(&format!("{k}.at"), fault.at)?;
        c.ensure(
            (0.0..=m.duration).contains(&fault.at),
            &format!("{k}.at"),
            num(fault.at),
            &format!("must be within [0, mission.duration = {}]", num(m.duration)),
        )?;
        if let Some(until) = fault.until {
            c.finite(&format!("{k}.until"), until)?;
            c.ensure(
                until > fault.at && until <= m.duration,
                &format!("{k}.until"),
                num(until),
                &format!(
                    "must be within ({} = at, mission.duration = {}]",
                    num(fault.at),
                    num(m.duration)
                ),
            )?;
        }
        if fault.kind == FaultKind::Kill && fault.until.is_some() {
            c.ensure(
                mission.restart.vehicles != RestartPolicy::Never,
                &format!("{k}.until"),
                num(fault.until.unwrap_or_default()),
                "a kill with a restart time needs restart.vehicles = \"on-failure\" or \"always\"",
            )?;
        }
        match (fault.kind, fault.value) {
            (FaultKind::SensorBias, None) => {
                return Err(c.fail(
                    &format!("{k}.value"),
                    "(missing)",
                    "kind = \"sensor_bias\" needs the bias value",
                ))
            }
            (FaultKind::Kill | FaultKind::LinkDown, Some(x)) => {
                return Err(c.fail(
                    &format!("{k}.value"),
                    num(x),
                    format!(
                        "not used by kind = {:?}; only by \"sensor_stuck\" and \"sensor_bias\"",
                        fault.kind.as_str()
                    ),
                ))
            }
            (_, Some(x)) => c.finite(&format!("{k}.value"), x)?,
            (_, None) => {}
        }
    }
    Ok(())
}
