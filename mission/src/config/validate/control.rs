//! `[control]`.

use super::super::ControlSection;
use super::{Check, Checked};

/// `[control]`: `neighbour_memory`, when given, is finite and > 0 (s); `plan_horizon`,
/// when given, is finite and ≥ 0 (s).
pub(super) fn check(c: &Check, control: &ControlSection) -> Checked {
    if let Some(tau) = control.neighbour_memory {
        c.positive("control.neighbour_memory", tau)?;
    }
    if let Some(h) = control.plan_horizon {
        c.non_negative("control.plan_horizon", h)?;
    }
    Ok(())
}
