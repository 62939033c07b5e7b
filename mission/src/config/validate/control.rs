//! `[control]`.

use super::{Check, Checked};
use crate::config::ControlSection;

/// `control.curvature_memory` > 0 and finite.
pub(super) fn control(c: &Check, s: &ControlSection) -> Checked {
    c.positive("control.curvature_memory", s.curvature_memory)
}
