//! `[control]`.

use super::super::ControlSection;
use super::{Check, Checked};

/// `[control]`: `neighbour_memory`, when given, is finite and > 0 (s); `plan_horizon`,
/// when given, is finite and ≥ 0 (s); `curvature_memory` is finite and > 0 (design
/// spacings).
pub(super) fn check(c: &Check, control: &ControlSection) -> Checked {
    if let Some(tau) = control.neighbour_memory {
        c.positive("control.neighbour_memory", tau)?;
    }
    if let Some(h) = control.plan_horizon {
        c.non_negative("control.plan_horizon", h)?;
    }
    c.positive("control.curvature_memory", control.curvature_memory)
}
