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
    Paper,
    /// Age-aware control over the links the fleet really has (beyond the paper); the
    /// paper's formation law on ideal links until a redesign (which is bumpless), its
    /// gradient filter carried along the body's move by a known curvature (Lemma 5.4's
    /// random walk lags a moving body; none carried without `formation.hessian_guess`).
    #[default]
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

/// Where the Hessian of (V.6) comes from under `law = "robust"` (`control.curvature`); the
/// paper's law always uses the configured one.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CurvatureSource {
    /// `formation.hessian_guess` (identity when absent), as the paper.
    #[default]
    Configured,
    /// Estimated online from the readings (`vbap_math::curvature`), the configured Hessian
    /// as its prior (beyond the paper).
    Estimated,
}

impl CurvatureSource {
    /// The name as the mission file writes it.
    pub fn as_str(self) -> &'static str {
        match self {
            CurvatureSource::Configured => "configured",
            CurvatureSource::Estimated => "estimated",
        }
    }
}

/// `[control]`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
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
    /// `"configured"` (default) | `"estimated"`: the Hessian the robust law sizes the
    /// formation with (V.7) and corrects the readings by; ignored by the paper's law.
    pub curvature: CurvatureSource,
    /// Memory of the curvature estimate, in design spacings (k·d̄0) of the body's travel,
    /// dimensionless, > 0: the data are forgotten as e^(−travel / (memory · spacing)), so the
    /// estimate averages the field's curvature over about 4 × this many spacings of path
    /// (default 0.25: one spacing; chosen by measurement on lossy_kill.toml, where 1.0 lagged
    /// the true curvature by 25 % at the top).
    pub curvature_memory: f64,
    /// Under `law = "robust"`: damp each vehicle relative to the virtual body, −K(ẋ − ṙ),
    /// rather than relative to the water, −K ẋ (`vbap_math::robust`, "Following the body").
    /// Absent: where the stability envelope holds (links that are not ideal), or where
    /// damping against the water would leave the formation more than
    /// `config::envelope::FOLLOW_TRAIL` spacing behind its body ((T.1),
    /// `Mission::trails_its_body`); elsewhere on ideal links the law is the paper's, bit
    /// for bit. `true`: everywhere (a formation moving with its body then never trails
    /// it); `false`: never. Ignored by `law = "paper"`.
    pub follow_body: Option<bool>,
}

impl Default for ControlSection {
    fn default() -> Self {
        Self {
            law: LawKind::default(),
            neighbour_memory: None,
            plan_horizon: None,
            curvature: CurvatureSource::default(),
            curvature_memory: 0.25,
            follow_body: None,
        }
    }
}
