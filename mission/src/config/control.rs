//! `[control]`: which control law and planner the fleet flies.
//!
//! `law = "paper"` is the method of the paper as written: every vehicle acts on the
//! neighbour positions it was last sent as if they were current, and the body moves by
//! (IV.4) on the coordinator's newest view. `law = "robust"` is built for the links the
//! vehicles really have (docs/ARCHITECTURE.md §6): it equals the paper's law whenever the
//! information is fresh (ideal links), and otherwise commits the body's path ahead of time,
//! fades stale neighbour terms and redesigns without a bump.

use serde::{Deserialize, Serialize};

/// The control law and planner of a mission (`control.law`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LawKind {
    /// The paper's law and planner, unchanged.
    #[default]
    Paper,
    /// Age-aware control over the links the fleet really has (beyond the paper).
    Robust,
}

impl LawKind {
    /// The name of the law as the mission file writes it.
    pub fn as_str(self) -> &'static str {
        match self {
            LawKind::Paper => "paper",
            LawKind::Robust => "robust",
        }
    }
}

/// `[control]`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ControlSection {
    /// `"paper"` | `"robust"`.
    pub law: LawKind,
    /// s, > 0: under `law = "robust"`, how fast a relayed neighbour position is forgotten:
    /// its term of (II.1) is weighed by exp(−age/neighbour_memory) and the vehicle's own slot
    /// takes over (`vbap_math::robust`). Absent: K·d0²/α of the current (scaled)
    /// inter-vehicle potential, the damping time of one neighbour spring, which keeps the
    /// lag of stale neighbours from undoing the damping whatever their age.
    pub neighbour_memory: Option<f64>,
    /// Plan horizon H of the robust law, s, ≥ 0: how far ahead the body's path is
    /// committed (the longest a vehicle may go without a fresh command). Absent: derived
    /// from `[links]` (`crate::horizon::plan_horizon`). Unused by `law = "paper"`.
    pub plan_horizon: Option<f64>,
}
