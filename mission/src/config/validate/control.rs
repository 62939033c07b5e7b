//! `[control]`.

use super::super::ControlSection;
use super::{Check, Checked};

/// Checks `[control]`.
pub(super) fn control(c: &Check, s: &ControlSection) -> Checked {
    if let Some(h) = s.plan_horizon {
        c.non_negative("control.plan_horizon", h)?;
    }
    Ok(())
}
