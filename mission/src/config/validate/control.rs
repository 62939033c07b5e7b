//! `[control]`.

use super::{Check, Checked};
use crate::config::ControlSection;

/// `[control]`: `neighbour_memory`, when given, is finite and > 0 (s).
pub(super) fn check(c: &Check, control: &ControlSection) -> Checked {
    if let Some(tau) = control.neighbour_memory {
        c.positive("control.neighbour_memory", tau)?;
    }
    Ok(())
}
