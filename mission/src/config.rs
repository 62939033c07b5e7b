//! The mission file (TOML), parsed and validated (docs/ARCHITECTURE.md §9).
//!
//! A mission file must give `[mission] name` and the `[field]` keys that shape its kind of
//! field (see [`FieldKind::required_keys`]): they have no meaningful default, so an empty or
//! comment-only file is no mission. Every other key has a default, so a missing section
//! takes its defaults; an unknown key is refused, naming it. A `[batch]` table (the criteria
//! of `vbap batch`) is accepted and ignored here. A file larger than [`MAX_FILE_BYTES`] is
//! refused without being read. [`Mission::from_toml_str`] parses, [`Mission::validate`]
//! checks every number and every cross-key constraint, and every [`ConfigError`] names the file,
//! the dotted key (`field.width`, `faults[1].at`) and the reason, e.g.
//! `missions/x.toml: field.width = -1: must be > 0`.
//!
//! Units: the mission's length unit (metres for gliders, non-dimensional for the paper's
//! examples), seconds of mission time, and the field's unit (°C, say).

use crate::field::Field;
use serde::{Deserialize, Serialize};
use std::fmt;
use std::path::Path;
use std::str::FromStr;
use vbap_math::{Mat3, Vec3};

/// Most vehicles a mission may have (iceoryx2 resources and O(N²) potentials stay bounded).
pub const MAX_VEHICLES: usize = 256;
/// Most ticks (duration / dt) a mission may have.
pub const MAX_TICKS: f64 = 10_000_000.0;
/// Longest mission name (it prefixes every service name and the run directory).
pub const MAX_NAME_LEN: usize = 32;
/// Most bumps of a `gaussian_sum` field.
pub const MAX_BUMPS: usize = 64;
/// Largest mission file read, bytes (1 MiB): a longer file (or `/dev/zero`) is refused after
/// reading at most one byte more.
pub const MAX_FILE_BYTES: u64 = 1 << 20;
/// ω·dt and damping·dt above this make the semi-implicit Euler integration of (II.1)
/// unstable: refused unless `mission.allow_unstable = true`.
pub const UNSTABLE_STEP: f64 = 2.0;

/// Something wrong with a mission: the file, the key and why.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// The mission file is larger than [`MAX_FILE_BYTES`].
    #[error("{origin}: the mission file is larger than {limit} bytes: not a mission file (the limit keeps a wrong path, e.g. /dev/zero, from being read until memory runs out)")]
    TooLarge {
        /// The file.
        origin: String,
        /// The limit, bytes.
        limit: u64,
    },
    /// The mission file could not be read.
    #[error("{origin}: cannot read the mission file: {source}")]
    Read {
        /// The file.
        origin: String,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// The text is not valid TOML.
    #[error("{origin}: line {line}, column {column}: invalid TOML: {message}")]
    Syntax {
        /// The file.
        origin: String,
        /// 1-based line of the error.
        line: usize,
        /// 1-based column of the error.
        column: usize,
        /// toml's description.
        message: String,
    },
    /// A key is unknown, missing or of the wrong type.
    #[error("{origin}: {key}: {message} (line {line}, column {column})")]
    Schema {
        /// The file.
        origin: String,
        /// Dotted path of the key at fault (`field.width`, `faults[0].at`).
        key: String,
        /// 1-based line of the error.
        line: usize,
        /// 1-based column of the error.
        column: usize,
        /// toml's and serde's description.
        message: String,
    },
    /// A value is out of range or inconsistent with another key.
    #[error("{origin}: {key} = {value}: {reason}")]
    Invalid {
        /// The file.
        origin: String,
        /// Dotted path of the key at fault.
        key: String,
        /// The offending value, as written in TOML.
        value: String,
        /// Why it is refused.
        reason: String,
    },
}

impl ConfigError {
    /// The file (or other origin) the error is about.
    pub fn origin(&self) -> &str {
        match self {
            ConfigError::Read { origin, .. }
            | ConfigError::TooLarge { origin, .. }
            | ConfigError::Syntax { origin, .. }
            | ConfigError::Schema { origin, .. }
            | ConfigError::Invalid { origin, .. } => origin,
        }
    }

    /// The dotted key at fault, if the error is about one key.
    pub fn key(&self) -> Option<&str> {
        match self {
            ConfigError::Schema { key, .. } | ConfigError::Invalid { key, .. } => Some(key),
            ConfigError::Read { .. }
            | ConfigError::TooLarge { .. }
            | ConfigError::Syntax { .. } => None,
        }
    }
}

/// How mission time is paced against wall time (docs/ARCHITECTURE.md §3).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum Pace {
    /// As fast as possible, each tick released when every live participant has reported.
    #[default]
    Lockstep,
    /// Real time scaled by this factor (> 0): 1.0 = real time, 60.0 = a minute per second.
    Factor(f64),
}

impl fmt::Display for Pace {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Pace::Lockstep => f.write_str("lockstep"),
            Pace::Factor(x) => write!(f, "{x}"),
        }
    }
}

impl FromStr for Pace {
    type Err = String;

    /// `lockstep` or a real-time factor (a finite number > 0), as on the command line.
    fn from_str(s: &str) -> Result<Pace, String> {
        let s = s.trim();
        if s == "lockstep" {
            return Ok(Pace::Lockstep);
        }
        match s.parse::<f64>() {
            Ok(x) if x.is_finite() && x > 0.0 => Ok(Pace::Factor(x)),
            _ => Err(format!(
                "pace {s:?}: must be \"lockstep\" or a real-time factor > 0 (1.0 = real time)"
            )),
        }
    }
}

impl Serialize for Pace {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            Pace::Lockstep => s.serialize_str("lockstep"),
            Pace::Factor(x) => s.serialize_f64(*x),
        }
    }
}

impl<'de> Deserialize<'de> for Pace {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Pace, D::Error> {
        struct PaceVisitor;
        impl serde::de::Visitor<'_> for PaceVisitor {
            type Value = Pace;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("\"lockstep\" or a real-time factor > 0")
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<Pace, E> {
                if v == "lockstep" {
                    Ok(Pace::Lockstep)
                } else {
                    Err(E::invalid_value(serde::de::Unexpected::Str(v), &self))
                }
            }
            // Range checks belong to `validate`, which names the key.
            fn visit_f64<E: serde::de::Error>(self, v: f64) -> Result<Pace, E> {
                Ok(Pace::Factor(v))
            }
            fn visit_i64<E: serde::de::Error>(self, v: i64) -> Result<Pace, E> {
                Ok(Pace::Factor(v as f64))
            }
            fn visit_u64<E: serde::de::Error>(self, v: u64) -> Result<Pace, E> {
                Ok(Pace::Factor(v as f64))
            }
        }
        d.deserialize_any(PaceVisitor)
    }
}

/// Climb to a maximum or descend to a minimum of the field (Section V).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Goal {
    /// Climb: dr/ds = +∇T_est.
    #[default]
    Max,
    /// Descend: dr/ds = −∇T_est.
    Min,
}

impl Goal {
    /// +1 for `Max`, −1 for `Min`: dr/ds = sign · ∇T_est.
    pub fn sign(self) -> f64 {
        match self {
            Goal::Max => 1.0,
            Goal::Min => -1.0,
        }
    }
}

/// The kind of environment (`field.kind`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FieldKind {
    /// T = offset + ½ (x − center)ᵀ hessian (x − center).
    Quadratic,
    /// T = background + amplitude · exp(−‖x − center‖² / (2 width²)).
    #[default]
    Gaussian,
    /// T = background + Σ over `[[field.bumps]]`.
    GaussianSum,
    /// A Gaussian (center, amplitude, width) over background, drifting at `velocity`.
    Eddy,
    /// T = background + amplitude · tanh((normal·x − offset − speed·t) / width), plus at most
    /// one `[[field.bumps]]`.
    Front,
}

impl FieldKind {
    /// The name used in mission files.
    pub fn as_str(self) -> &'static str {
        match self {
            FieldKind::Quadratic => "quadratic",
            FieldKind::Gaussian => "gaussian",
            FieldKind::GaussianSum => "gaussian_sum",
            FieldKind::Eddy => "eddy",
            FieldKind::Front => "front",
        }
    }

    /// The `[field]` keys a mission file must give for this kind: the ones that shape the
    /// field and have no meaningful default (a Gaussian's height, place and width; a
    /// quadratic's centre and Hessian; an eddy's drift; a front's normal, step and
    /// thickness; a sum's bumps).
    pub fn required_keys(self) -> &'static [&'static str] {
        match self {
            FieldKind::Quadratic => &["center", "hessian"],
            FieldKind::Gaussian => &["center", "amplitude", "width"],
            FieldKind::GaussianSum => &["bumps"],
            FieldKind::Eddy => &["center", "amplitude", "width", "velocity"],
            FieldKind::Front => &["normal", "amplitude", "width"],
        }
    }
}

/// One Gaussian bump of a `gaussian_sum` or `front` field (`[[field.bumps]]`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BumpConfig {
    /// Centre (length unit), `dim` components.
    pub center: Vec<f64>,
    /// Peak height (field unit); negative for a trough; ≠ 0.
    pub amplitude: f64,
    /// Standard deviation (length unit), > 0.
    pub width: f64,
}

/// `[mission]`: identity, time and goal.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MissionSection {
    /// [A-Za-z0-9_]+, at most 32 characters; names the IPC domain and the run directory.
    pub name: String,
    /// Every random draw derives from it (at most 2⁶³ − 1, a TOML integer).
    pub seed: u64,
    /// Mission time simulated (s), ≥ dt.
    pub duration: f64,
    /// Control and integration step (s), > 0.
    pub dt: f64,
    /// `"lockstep"` or a real-time factor > 0.
    pub pace: Pace,
    /// `"max"` or `"min"`.
    pub goal: Goal,
    /// 2 or 3.
    pub dim: usize,
    /// "Converged" = virtual body centre within this distance of the optimum (length unit).
    pub tolerance: f64,
    /// Name of the length unit for plots and reports (`"m"`); empty = non-dimensional.
    /// At most 32 characters, no control characters.
    pub length_unit: String,
    /// Label of the field for plots and reports (`"T (°C)"`). At most 32 characters, no
    /// control characters.
    pub field_label: String,
    /// Run even when the time step makes the integration of (II.1) unstable (ω·dt or
    /// damping·dt above 2, see [`Mission::stiffness`]); false = such a mission is refused.
    pub allow_unstable: bool,
}

impl Default for MissionSection {
    fn default() -> Self {
        MissionSection {
            name: "demo".into(),
            seed: 1,
            duration: 300.0,
            dt: 0.05,
            pace: Pace::Lockstep,
            goal: Goal::Max,
            dim: 2,
            tolerance: 1.0,
            length_unit: String::new(),
            field_label: "T".into(),
            allow_unstable: false,
        }
    }
}

/// `[field]`: the environment (see [`FieldKind`] for which keys each kind uses).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FieldConfig {
    /// The kind of field.
    pub kind: FieldKind,
    /// Location of the extremum (quadratic, gaussian, eddy at t = 0; length unit), `dim`
    /// components.
    pub center: Vec<f64>,
    /// Gaussian or eddy peak height (negative: a trough); front half-step (field unit).
    pub amplitude: f64,
    /// Gaussian or eddy standard deviation; front thickness (length unit), > 0.
    pub width: f64,
    /// Quadratic Hessian H (field unit per length unit²), dim×dim, symmetric.
    pub hessian: Vec<Vec<f64>>,
    /// σ_M: sensor noise standard deviation (field unit), ≥ 0.
    pub noise_std: f64,
    /// Value far from the bumps (gaussian, gaussian_sum, eddy) or mid-front (front).
    pub background: f64,
    /// Quadratic: value at the centre (field unit); front: its position along the normal at
    /// t = 0 (length unit).
    pub offset: f64,
    /// Eddy drift velocity (length unit/s), `dim` components; empty for other kinds.
    pub velocity: Vec<f64>,
    /// Front normal (any length ≠ 0, normalised), `dim` components; empty for other kinds.
    pub normal: Vec<f64>,
    /// Front speed along its normal (length unit/s).
    pub speed: f64,
    /// `[[field.bumps]]`: the bumps of a gaussian_sum (at least one), or the optional bump of
    /// a front (at most one); empty for other kinds.
    pub bumps: Vec<BumpConfig>,
}

impl Default for FieldConfig {
    fn default() -> Self {
        FieldConfig {
            kind: FieldKind::Gaussian,
            center: vec![20.0, 10.0],
            amplitude: 10.0,
            width: 15.0,
            hessian: vec![vec![1.0, 0.0], vec![0.0, 1.0]],
            noise_std: 0.1,
            background: 0.0,
            offset: 0.0,
            velocity: Vec::new(),
            normal: Vec::new(),
            speed: 0.0,
            bumps: Vec::new(),
        }
    }
}

/// `[vehicles]`: the group and its dynamics.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct VehiclesSection {
    /// Number of vehicles N, dim + 1 ≤ N ≤ 256 (Lemma 5.1 needs N ≥ l + 1).
    pub count: usize,
    /// Initial virtual body centre (length unit), `dim` components.
    pub start: Vec<f64>,
    /// Vehicles start at most this far (seeded) from their slots (length unit), ≥ 0.
    pub start_spread: f64,
    /// Damping (1/s): K = damping · I in the control law (II.1), > 0.
    pub damping: f64,
}

impl Default for VehiclesSection {
    fn default() -> Self {
        VehiclesSection {
            count: 4,
            start: vec![0.0, 0.0],
            start_spread: 0.5,
            damping: 1.0,
        }
    }
}

/// `[formation]`: artificial potentials and resolution adaptation.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FormationSection {
    /// Initial vehicle-to-centre distance (length unit), > 0.
    pub radius: f64,
    /// Resolution adaptation dk/ds = −a (k d̄0 − Δ_d) on or off (Section V).
    pub adapt: bool,
    /// a of dk/ds = −a (k d̄0 − Δ_d) (Section V), ≥ 0, > 0 when `adapt`.
    pub adapt_gain: f64,
    /// Potential gain α (length unit²/s²): f(x) = α (1/x − d0/x²) (Sec. II, Fig. 2), > 0.
    pub alpha: f64,
    /// Smallest scale k the adaptation may reach, 0 < min_scale ≤ 1.
    pub min_scale: f64,
    /// Largest scale k the adaptation may reach, ≥ 1.
    pub max_scale: f64,
    /// σ_H of (V.6): uncertainty of the Hessian guess, > 0.
    pub sigma_h: f64,
    /// H of (V.6), the rough Hessian guess (field unit per length unit²), dim×dim, symmetric;
    /// absent = identity.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub hessian_guess: Option<Vec<Vec<f64>>>,
}

impl Default for FormationSection {
    fn default() -> Self {
        FormationSection {
            radius: 1.5,
            adapt: true,
            adapt_gain: 0.5,
            alpha: 1.0,
            min_scale: 0.2,
            max_scale: 5.0,
            sigma_h: 1.0,
            hessian_guess: None,
        }
    }
}

/// `[body]`: the virtual body's speed law (IV.4) and direction (Section V).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BodySection {
    /// v0: nominal virtual body speed (length unit/s), > 0 (Theorem 4.1).
    pub v0: f64,
    /// V_U: the Lyapunov bound of Theorem 4.1 (length unit²/s²), > 0.
    pub v_u: f64,
    /// δ of (IV.4): small positive regulariser, > 0.
    pub delta: f64,
    /// dr/ds = ±∇T_est / max(‖∇T_est‖, grad_saturation) (field unit per length unit), > 0.
    pub grad_saturation: f64,
}

impl Default for BodySection {
    fn default() -> Self {
        BodySection {
            v0: 0.5,
            v_u: 1.0,
            delta: 0.01,
            grad_saturation: 1.0,
        }
    }
}

/// `[estimator]`: least squares + Kalman filter (Lemma 5.1, 5.4) and Theorem 5.1.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct EstimatorSection {
    /// b of Lemma 5.4: random-walk intensity of (∇T, T) per √s, > 0.
    pub kalman_b: f64,
    /// c of Definition 5.1: confidence level of ε_est, 0 < c < 1.
    pub confidence: f64,
    /// δ_M of Theorem 5.1 (field unit per length unit), ≥ 0; absent = 1 % of ε_est
    /// (`vbap_math::convergence::default_delta_m`), since the theorem needs δ_M > 0.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub delta_m: Option<f64>,
    /// σ_M assumed by the estimator (field unit), > 0; absent = estimated online from the
    /// least-squares residuals.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sigma_m: Option<f64>,
    /// Initial Kalman covariance P0 = initial_variance · I, > 0.
    pub initial_variance: f64,
}

impl Default for EstimatorSection {
    fn default() -> Self {
        EstimatorSection {
            kalman_b: 0.05,
            confidence: 0.99,
            delta_m: None,
            sigma_m: None,
            initial_variance: 1.0,
        }
    }
}

/// How the surfacing windows of the vehicles are placed in time.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum SurfacingPhase {
    /// Vehicle i surfaces at phase i·period/N (one or a few at the surface at a time).
    #[default]
    Staggered,
    /// All vehicles surface together.
    Together,
}

/// `[links]`: the vehicle ↔ coordinator link model, both directions (docs/ARCHITECTURE.md §6).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LinksSection {
    /// One-way delay (s), ≥ 0.
    pub delay: f64,
    /// Uniform ± jitter on the delay (s), 0 ≤ jitter ≤ delay.
    pub jitter: f64,
    /// Probability a message is lost, 0 ≤ loss < 1.
    pub loss: f64,
    /// Surfacing period (s); 0 = always in contact.
    pub surfacing_period: f64,
    /// Time at the surface in each period (s), ≤ surfacing_period, > 0 if the period is.
    pub surfacing_window: f64,
    /// Placement of the surfacing windows: "staggered" (vehicle i at phase i·period/N) or
    /// "together".
    pub surfacing_phase: SurfacingPhase,
    /// Bursty loss (Gilbert–Elliott): probability per message of going from the good to
    /// the bad state; 0 = plain Bernoulli loss.
    pub burst_enter: f64,
    /// Gilbert–Elliott: probability per message of leaving the bad state.
    pub burst_exit: f64,
    /// Gilbert–Elliott: loss probability in the bad state (`loss` applies in the good one).
    pub burst_loss: f64,
    /// Apply the model to coordinator → vehicle messages too (false: uplink only).
    pub downlink: bool,
}

impl Default for LinksSection {
    fn default() -> Self {
        Self {
            delay: 0.0,
            jitter: 0.0,
            loss: 0.0,
            surfacing_period: 0.0,
            surfacing_window: 0.0,
            surfacing_phase: SurfacingPhase::Staggered,
            burst_enter: 0.0,
            burst_exit: 0.5,
            burst_loss: 0.5,
            downlink: true,
        }
    }
}

/// A restart policy of the supervisor (`[restart]`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum RestartPolicy {
    /// Never restart.
    Never,
    /// Restart after a failure (non-zero exit or killed by a signal).
    OnFailure,
    /// Restart whenever the process ends before the mission does.
    Always,
}

/// `[restart]`: what the supervisor does when a process of the set dies (docs/ARCHITECTURE.md §7).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RestartSection {
    /// Policy for vehicle agents.
    pub vehicles: RestartPolicy,
    /// Policy for the coordinator (a restarted coordinator resumes from its checkpoint).
    pub coordinator: RestartPolicy,
    /// Policy for the field server.
    pub field_server: RestartPolicy,
    /// Wall time before a restart (s); doubles with each restart inside the window.
    pub backoff: f64,
    /// Largest number of restarts of one process inside `window`; past it, no more.
    pub max_restarts: u32,
    /// Length of the restart-counting window (s, wall time).
    pub window: f64,
}

impl Default for RestartSection {
    fn default() -> Self {
        Self {
            vehicles: RestartPolicy::Never,
            coordinator: RestartPolicy::OnFailure,
            field_server: RestartPolicy::OnFailure,
            backoff: 0.2,
            max_restarts: 5,
            window: 60.0,
        }
    }
}

/// The kind of a scheduled fault (`faults[i].kind`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FaultKind {
    /// SIGKILL the vehicle's process at `at`; restart it at `until` if given.
    Kill,
    /// Cut the vehicle's link both ways from `at` to `until` (or the end).
    LinkDown,
    /// The sensor reads `value` (or its last reading if absent) from `at` to `until`.
    SensorStuck,
    /// The sensor reads T + `value` from `at` to `until`.
    SensorBias,
}

impl FaultKind {
    /// The name used in mission files.
    pub fn as_str(self) -> &'static str {
        match self {
            FaultKind::Kill => "kill",
            FaultKind::LinkDown => "link_down",
            FaultKind::SensorStuck => "sensor_stuck",
            FaultKind::SensorBias => "sensor_bias",
        }
    }
}

/// One scheduled fault (`[[faults]]`, docs/ARCHITECTURE.md §7).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FaultConfig {
    /// What happens.
    pub kind: FaultKind,
    /// Which vehicle (id < vehicles.count).
    pub vehicle: u32,
    /// Mission time it starts (s), in [0, duration].
    pub at: f64,
    /// Mission time it ends (s), in (at, duration]; absent = never (for `kill`: no restart).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub until: Option<f64>,
    /// `sensor_bias`: the bias (field unit, required); `sensor_stuck`: the stuck reading
    /// (optional); not used by other kinds.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub value: Option<f64>,
}

/// A whole mission file. `origin` (the file it came from) is not part of the file and does
/// not take part in equality.
#[derive(Clone, Debug, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields, default)]
pub struct Mission {
    /// `[mission]`.
    pub mission: MissionSection,
    /// `[field]`.
    pub field: FieldConfig,
    /// `[vehicles]`.
    pub vehicles: VehiclesSection,
    /// `[formation]`.
    pub formation: FormationSection,
    /// `[body]`.
    pub body: BodySection,
    /// `[estimator]`.
    pub estimator: EstimatorSection,
    /// `[links]`.
    pub links: LinksSection,
    /// `[restart]`.
    pub restart: RestartSection,
    /// `[[faults]]`, in file order.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub faults: Vec<FaultConfig>,
    /// `[batch]`: the criteria of `vbap batch` (read and checked there and by `vbap check`);
    /// accepted and ignored by every other command, not written to the resolved mission.
    #[serde(skip_serializing)]
    pub batch: Option<toml::Table>,
    /// Where the mission came from (a path, or `<string>`), named in every error.
    #[serde(skip)]
    pub origin: String,
}

impl PartialEq for Mission {
    fn eq(&self, other: &Self) -> bool {
        self.mission == other.mission
            && self.field == other.field
            && self.vehicles == other.vehicles
            && self.formation == other.formation
            && self.body == other.body
            && self.estimator == other.estimator
            && self.links == other.links
            && self.restart == other.restart
            && self.faults == other.faults
    }
}

/// ω·dt and damping·dt of a mission ([`Mission::stiffness`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stiffness {
    /// ω·dt of the stiffest formation mode at the smallest scale.
    pub omega_dt: f64,
    /// vehicles.damping · mission.dt.
    pub damping_dt: f64,
    /// Neighbour spacing at formation.min_scale (length unit).
    pub spacing: f64,
}

impl Stiffness {
    /// Above [`UNSTABLE_STEP`]: the integration diverges.
    pub fn unstable(&self) -> bool {
        self.omega_dt > UNSTABLE_STEP || self.damping_dt > UNSTABLE_STEP
    }
}

/// Command-line overrides of a mission (`--seed`, `--vehicles`, `--duration`, `--pace`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Overrides {
    /// `mission.seed`.
    pub seed: Option<u64>,
    /// `vehicles.count`.
    pub vehicles: Option<usize>,
    /// `mission.duration` (s).
    pub duration: Option<f64>,
    /// `mission.pace`.
    pub pace: Option<Pace>,
}

/// 1-based (line, column) of byte offset `pos` in `text`.
fn line_column(text: &str, pos: usize) -> (usize, usize) {
    let pos = pos.min(text.len());
    let before = text.get(..pos).unwrap_or(text);
    let line = before.matches('\n').count() + 1;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    let column = before[line_start..].chars().count() + 1;
    (line, column)
}

/// Whether a span contains byte offset `pos` (an empty span contains its start).
fn span_has(span: &std::ops::Range<usize>, pos: usize) -> bool {
    span.contains(&pos) || (span.is_empty() && span.start == pos)
}

/// Dotted path (`field.bumps[1].width`) of the innermost key or value at byte offset `pos`.
fn key_path_at(table: &toml::de::DeTable<'_>, pos: usize) -> Option<String> {
    use toml::de::DeValue;
    fn in_value(v: &toml::Spanned<DeValue<'_>>, pos: usize, path: String) -> Option<String> {
        match v.get_ref() {
            DeValue::Table(t) => {
                if let Some(inner) = key_path_at(t, pos) {
                    return Some(format!("{path}.{inner}"));
                }
            }
            DeValue::Array(a) => {
                for (i, e) in a.iter().enumerate() {
                    if let Some(p) = in_value(e, pos, format!("{path}[{i}]")) {
                        return Some(p);
                    }
                }
            }
            _ => {}
        }
        span_has(&v.span(), pos).then_some(path)
    }
    for (k, v) in table.iter() {
        if span_has(&k.span(), pos) {
            return Some(k.get_ref().to_string());
        }
        if let Some(p) = in_value(v, pos, k.get_ref().to_string()) {
            return Some(p);
        }
    }
    None
}

/// Formats a number the way TOML would show it (shortest form, exponent for tiny or huge
/// numbers).
fn num(x: f64) -> String {
    crate::rundir::Num(x).to_string()
}

/// Whether the document `table` has the key at the dotted path `path`.
fn has_key(table: &toml::de::DeTable<'_>, path: &[&str]) -> bool {
    use toml::de::DeValue;
    let Some((first, rest)) = path.split_first() else {
        return true;
    };
    let Some((_, v)) = table.iter().find(|(k, _)| k.get_ref() == first) else {
        return false;
    };
    match (rest.is_empty(), v.get_ref()) {
        (true, _) => true,
        (false, DeValue::Table(t)) => has_key(t, rest),
        _ => false,
    }
}

/// `text` (TOML as the `toml` crate writes it) with every float outside 1e-4 ≤ |x| < 1e16
/// rewritten in the exponent form of [`crate::rundir::Num`] (`1e-300`, not 300 digits):
/// the same number, still a TOML float. Strings and comments are left alone.
fn short_floats(text: &str) -> String {
    let chars: Vec<char> = text.chars().collect();
    let mut out = String::with_capacity(text.len());
    let mut token = String::new();
    let flush = |token: &mut String, out: &mut String| {
        let short = (token.contains('.') || token.contains('e'))
            .then(|| token.parse::<f64>().ok())
            .flatten()
            .map(|x| crate::rundir::Num(x).to_string())
            .filter(|s| s.contains('e') && s.len() < token.len());
        out.push_str(short.as_deref().unwrap_or(token));
        token.clear();
    };
    let mut i = 0;
    while i < chars.len() {
        let ch = chars[i];
        if ch.is_ascii_alphanumeric() || matches!(ch, '.' | '+' | '-' | '_') {
            token.push(ch);
            i += 1;
            continue;
        }
        flush(&mut token, &mut out);
        // A string (single or triple quotes, the basic ones with \ escapes) or a comment is
        // copied as it is.
        let end = match ch {
            '"' | '\'' => {
                let triple = chars.get(i + 1) == Some(&ch) && chars.get(i + 2) == Some(&ch);
                let open = if triple { 3 } else { 1 };
                let mut j = i + open;
                loop {
                    match chars.get(j) {
                        None => break chars.len(),
                        Some('\\') if ch == '"' => j += 2,
                        Some(c)
                            if *c == ch && (!triple || chars[j..].starts_with(&[ch, ch, ch])) =>
                        {
                            break j + open;
                        }
                        _ => j += 1,
                    }
                }
            }
            '#' => chars[i..]
                .iter()
                .position(|c| *c == '\n')
                .map_or(chars.len(), |n| i + n),
            _ => i + 1,
        };
        let end = end.min(chars.len());
        out.extend(&chars[i..end]);
        i = end;
    }
    flush(&mut token, &mut out);
    out
}

/// Reads a mission file, refusing one larger than [`MAX_FILE_BYTES`] after reading at most
/// one byte more (so `/dev/zero` or a wrong multi-gigabyte path fails at once).
pub fn read_mission_file(path: &Path) -> Result<String, ConfigError> {
    use std::io::Read;
    let origin = path.display().to_string();
    let read_err = |source| ConfigError::Read {
        origin: origin.clone(),
        source,
    };
    let file = std::fs::File::open(path).map_err(read_err)?;
    let mut bytes = Vec::new();
    file.take(MAX_FILE_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(read_err)?;
    if bytes.len() as u64 > MAX_FILE_BYTES {
        return Err(ConfigError::TooLarge {
            origin,
            limit: MAX_FILE_BYTES,
        });
    }
    String::from_utf8(bytes).map_err(|e| {
        read_err(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("not UTF-8 text ({e})"),
        ))
    })
}

/// Formats a vector as a TOML array.
fn vec_str(v: &[f64]) -> String {
    let items: Vec<String> = v.iter().map(|x| num(*x)).collect();
    format!("[{}]", items.join(", "))
}

/// Formats a matrix as a TOML array of arrays.
fn mat_str(m: &[Vec<f64>]) -> String {
    let rows: Vec<String> = m.iter().map(|r| vec_str(r)).collect();
    format!("[{}]", rows.join(", "))
}

/// Validation helpers: each names the origin and the key.
struct Check<'a> {
    origin: &'a str,
}

type Checked = Result<(), ConfigError>;

impl Check<'_> {
    fn fail(&self, key: &str, value: impl fmt::Display, reason: impl Into<String>) -> ConfigError {
        ConfigError::Invalid {
            origin: self.origin.to_string(),
            key: key.to_string(),
            value: value.to_string(),
            reason: reason.into(),
        }
    }

    fn ensure(&self, ok: bool, key: &str, value: impl fmt::Display, reason: &str) -> Checked {
        if ok {
            Ok(())
        } else {
            Err(self.fail(key, value, reason))
        }
    }

    fn finite(&self, key: &str, x: f64) -> Checked {
        self.ensure(x.is_finite(), key, num(x), "must be a finite number")
    }

    fn positive(&self, key: &str, x: f64) -> Checked {
        self.finite(key, x)?;
        self.ensure(x > 0.0, key, num(x), "must be > 0")
    }

    fn non_negative(&self, key: &str, x: f64) -> Checked {
        self.finite(key, x)?;
        self.ensure(x >= 0.0, key, num(x), "must be ≥ 0")
    }

    fn all_finite(&self, key: &str, v: &[f64]) -> Checked {
        for (i, x) in v.iter().enumerate() {
            self.finite(&format!("{key}[{i}]"), *x)?;
        }
        Ok(())
    }

    fn vector(&self, key: &str, v: &[f64], dim: usize) -> Checked {
        self.ensure(
            v.len() == dim,
            key,
            vec_str(v),
            &format!("must have {dim} components (mission.dim = {dim})"),
        )?;
        self.all_finite(key, v)
    }

    /// A dim×dim symmetric matrix of finite numbers.
    fn matrix(&self, key: &str, m: &[Vec<f64>], dim: usize) -> Checked {
        let square = m.len() == dim && m.iter().all(|r| r.len() == dim);
        self.ensure(
            square,
            key,
            mat_str(m),
            &format!("must be a {dim}×{dim} matrix (mission.dim = {dim})"),
        )?;
        for (i, row) in m.iter().enumerate() {
            self.all_finite(&format!("{key}[{i}]"), row)?;
        }
        let scale = m.iter().flatten().fold(0.0f64, |s, x| s.max(x.abs()));
        for i in 0..dim {
            for j in 0..i {
                self.ensure(
                    (m[i][j] - m[j][i]).abs() <= 1e-12 * scale,
                    key,
                    mat_str(m),
                    &format!("must be symmetric ([{i}][{j}] ≠ [{j}][{i}])"),
                )?;
            }
        }
        Ok(())
    }

    /// A vector only some field kinds use: required there, empty elsewhere.
    fn kind_vector(&self, key: &str, v: &[f64], dim: usize, used: bool, by: &str) -> Checked {
        if used {
            self.vector(key, v, dim)
        } else {
            self.ensure(
                v.is_empty(),
                key,
                vec_str(v),
                &format!("only used by field.kind = {by}; remove it"),
            )
        }
    }
}

impl Mission {
    /// Reads, parses and validates the mission file at `path`.
    pub fn load(path: &Path) -> Result<Mission, ConfigError> {
        let text = read_mission_file(path)?;
        Mission::from_toml_str(&text, &path.display().to_string())
    }

    /// Parses and validates a mission from TOML `text`; `origin` names it in errors (a path,
    /// or something like `<string>`).
    pub fn from_toml_str(text: &str, origin: &str) -> Result<Mission, ConfigError> {
        // Syntax first, so syntax errors are told apart from schema errors.
        let doc = toml::de::DeTable::parse(text).map_err(|e| {
            let (line, column) = line_column(text, e.span().map_or(0, |s| s.start));
            ConfigError::Syntax {
                origin: origin.to_string(),
                line,
                column,
                message: e.message().to_string(),
            }
        })?;
        let mut mission: Mission = toml::from_str(text).map_err(|e| {
            let pos = e.span().map_or(0, |s| s.start);
            let (line, column) = line_column(text, pos);
            let message = e.message().to_string();
            let mut key = key_path_at(doc.get_ref(), pos).unwrap_or_else(|| "(top level)".into());
            // "missing field `at`" points at the table: name the missing key.
            if let Some(missing) = message
                .strip_prefix("missing field `")
                .and_then(|m| m.strip_suffix('`'))
            {
                key = if key == "(top level)" {
                    missing.to_string()
                } else {
                    format!("{key}.{missing}")
                };
            }
            ConfigError::Schema {
                origin: origin.to_string(),
                key,
                line,
                column,
                message,
            }
        })?;
        mission.origin = origin.to_string();
        mission.require_keys(doc.get_ref())?;
        mission.validate()?;
        Ok(mission)
    }

    /// Refuses a document without `[mission] name` or without the `[field]` keys its kind
    /// needs ([`FieldKind::required_keys`]): those have no meaningful default.
    fn require_keys(&self, doc: &toml::de::DeTable<'_>) -> Result<(), ConfigError> {
        let c = Check {
            origin: &self.origin,
        };
        if !has_key(doc, &["mission", "name"]) {
            return Err(c.fail(
                "mission.name",
                "(missing)",
                format!(
                    "required: a mission file gives at least [mission] name and the [field] keys of \
                     its field.kind (\"gaussian\", the default: {}); an empty or comment-only file is no mission",
                    FieldKind::Gaussian.required_keys().join(", ")
                ),
            ));
        }
        let kind = self.field.kind;
        let given = has_key(doc, &["field", "kind"]);
        for key in kind.required_keys() {
            if !has_key(doc, &["field", key]) {
                return Err(c.fail(
                    &format!("field.{key}"),
                    "(missing)",
                    format!(
                        "required for field.kind = {:?}{} (no meaningful default); it needs {}",
                        kind.as_str(),
                        if given { "" } else { " (the default kind)" },
                        kind.required_keys().join(", ")
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Checks every value and every constraint between values; the first violation is
    /// returned, naming `self.origin`, the dotted key and the reason.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let c = Check {
            origin: &self.origin,
        };
        let m = &self.mission;

        // [mission]
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
        c.ensure(
            m.duration >= m.dt,
            "mission.duration",
            num(m.duration),
            &format!("must be ≥ mission.dt = {}", num(m.dt)),
        )?;
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
        let dim = m.dim;

        // [field]
        let f = &self.field;
        let kind = f.kind;
        let uses_center = matches!(
            kind,
            FieldKind::Quadratic | FieldKind::Gaussian | FieldKind::Eddy
        );
        if uses_center {
            c.vector("field.center", &f.center, dim)?;
        } else {
            c.all_finite("field.center", &f.center)?;
        }
        c.finite("field.amplitude", f.amplitude)?;
        if matches!(kind, FieldKind::Gaussian | FieldKind::Eddy) {
            c.ensure(
                f.amplitude != 0.0,
                "field.amplitude",
                num(f.amplitude),
                "must be ≠ 0 (a flat field has nothing to climb)",
            )?;
        }
        c.positive("field.width", f.width)?;
        if kind == FieldKind::Quadratic {
            c.matrix("field.hessian", &f.hessian, dim)?;
        } else {
            for (i, row) in f.hessian.iter().enumerate() {
                c.all_finite(&format!("field.hessian[{i}]"), row)?;
            }
        }
        c.non_negative("field.noise_std", f.noise_std)?;
        c.finite("field.background", f.background)?;
        c.finite("field.offset", f.offset)?;
        c.kind_vector(
            "field.velocity",
            &f.velocity,
            dim,
            kind == FieldKind::Eddy,
            "\"eddy\"",
        )?;
        c.kind_vector(
            "field.normal",
            &f.normal,
            dim,
            kind == FieldKind::Front,
            "\"front\"",
        )?;
        if kind == FieldKind::Front {
            c.ensure(
                f.normal.iter().any(|x| *x != 0.0),
                "field.normal",
                vec_str(&f.normal),
                "must not be zero",
            )?;
        }
        c.finite("field.speed", f.speed)?;
        let n_bumps = f.bumps.len();
        match kind {
            FieldKind::GaussianSum => c.ensure(
                (1..=MAX_BUMPS).contains(&n_bumps),
                "field.bumps",
                format!("{n_bumps} bumps"),
                "field.kind = \"gaussian_sum\" needs 1 to 64 [[field.bumps]]",
            )?,
            FieldKind::Front => c.ensure(
                n_bumps <= 1,
                "field.bumps",
                format!("{n_bumps} bumps"),
                "field.kind = \"front\" takes at most one [[field.bumps]]",
            )?,
            _ => c.ensure(
                n_bumps == 0,
                "field.bumps",
                format!("{n_bumps} bumps"),
                "only used by field.kind = \"gaussian_sum\" or \"front\"; remove them",
            )?,
        }
        for (i, b) in f.bumps.iter().enumerate() {
            let k = format!("field.bumps[{i}]");
            c.vector(&format!("{k}.center"), &b.center, dim)?;
            c.finite(&format!("{k}.amplitude"), b.amplitude)?;
            c.ensure(
                b.amplitude != 0.0,
                &format!("{k}.amplitude"),
                num(b.amplitude),
                "must be ≠ 0",
            )?;
            c.positive(&format!("{k}.width"), b.width)?;
        }

        // [vehicles]
        let v = &self.vehicles;
        c.ensure(
            v.count > dim && v.count <= MAX_VEHICLES,
            "vehicles.count",
            v.count,
            &format!(
                "must be between mission.dim + 1 = {} (least squares, Lemma 5.1) and {MAX_VEHICLES}",
                dim + 1
            ),
        )?;
        c.vector("vehicles.start", &v.start, dim)?;
        c.non_negative("vehicles.start_spread", v.start_spread)?;
        c.positive("vehicles.damping", v.damping)?;

        // [formation]
        let fo = &self.formation;
        c.positive("formation.radius", fo.radius)?;
        c.non_negative("formation.adapt_gain", fo.adapt_gain)?;
        if fo.adapt {
            c.ensure(
                fo.adapt_gain > 0.0,
                "formation.adapt_gain",
                num(fo.adapt_gain),
                "must be > 0 when formation.adapt = true",
            )?;
        }
        c.positive("formation.alpha", fo.alpha)?;
        c.positive("formation.min_scale", fo.min_scale)?;
        c.ensure(
            fo.min_scale <= 1.0,
            "formation.min_scale",
            num(fo.min_scale),
            "must be ≤ 1 (the formation starts at scale 1)",
        )?;
        c.finite("formation.max_scale", fo.max_scale)?;
        c.ensure(
            fo.max_scale >= 1.0,
            "formation.max_scale",
            num(fo.max_scale),
            "must be ≥ 1 (the formation starts at scale 1)",
        )?;
        c.positive("formation.sigma_h", fo.sigma_h)?;
        if let Some(h) = &fo.hessian_guess {
            c.matrix("formation.hessian_guess", h, dim)?;
            c.ensure(
                h.iter().flatten().any(|x| *x != 0.0),
                "formation.hessian_guess",
                mat_str(h),
                "must not be zero (the optimal formation (V.7) would be infinitely large)",
            )?;
        }

        // [body]
        let b = &self.body;
        c.positive("body.v0", b.v0)?;
        c.positive("body.v_u", b.v_u)?;
        c.positive("body.delta", b.delta)?;
        c.positive("body.grad_saturation", b.grad_saturation)?;

        // [estimator]
        let e = &self.estimator;
        c.positive("estimator.kalman_b", e.kalman_b)?;
        c.finite("estimator.confidence", e.confidence)?;
        c.ensure(
            e.confidence > 0.0 && e.confidence < 1.0,
            "estimator.confidence",
            num(e.confidence),
            "must be strictly between 0 and 1",
        )?;
        if let Some(d) = e.delta_m {
            c.non_negative("estimator.delta_m", d)?;
        }
        if let Some(s) = e.sigma_m {
            c.positive("estimator.sigma_m", s)?;
        }
        c.positive("estimator.initial_variance", e.initial_variance)?;

        // [links]
        let l = &self.links;
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

        // [restart]
        let r = &self.restart;
        c.positive("restart.backoff", r.backoff)?;
        c.positive("restart.window", r.window)?;

        // The time step against the formation's stiffness.
        if let Some(st) = self.stiffness() {
            if !m.allow_unstable && st.unstable() {
                return Err(c.fail(
                    "mission.dt",
                    num(m.dt),
                    format!(
                        "unstable: ω·dt = {:.2}, damping·dt = {:.2}; above {UNSTABLE_STEP} the integration of \
                         (II.1) diverges (neighbour spacing {} at formation.min_scale = {}): lower \
                         mission.dt or formation.alpha, raise formation.radius, or set \
                         mission.allow_unstable = true to run it anyway",
                        st.omega_dt,
                        st.damping_dt,
                        num(st.spacing),
                        num(fo.min_scale)
                    ),
                ));
            }
        }

        // [[faults]]
        for (i, fault) in self.faults.iter().enumerate() {
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
                    self.restart.vehicles != RestartPolicy::Never,
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

    /// How stiff the formation is for the time step: ω·dt and damping·dt. The semi-implicit
    /// Euler integration of (II.1) is stable for ω·dt < 2 and damping·dt < 2, and accurate
    /// only well below. ω² ≈ 2 α/d0² + α/h0² (two neighbours and the central leader at their
    /// equilibrium distances, f'(d0) = α/d0²), at the smallest formation scale. None when the
    /// formation cannot be designed (validation says why).
    pub fn stiffness(&self) -> Option<Stiffness> {
        let design = vbap_math::formation::design_regular(
            self.vehicles.count,
            self.mission.dim,
            self.formation.radius,
            self.formation.alpha,
            self.formation.alpha,
        )
        .ok()?;
        let k = self.formation.min_scale;
        let (d0, h0) = (design.inter.d0 * k, design.leader.d0 * k);
        let alpha = self.formation.alpha;
        let omega = (2.0 * alpha / (d0 * d0) + alpha / (h0 * h0)).sqrt();
        let dt = self.mission.dt;
        Some(Stiffness {
            omega_dt: omega * dt,
            damping_dt: self.vehicles.damping * dt,
            spacing: d0,
        })
    }

    /// A warning when the formation is stiff for the time step (ω·dt or damping·dt above 1:
    /// inaccurate; above 2, allowed by `mission.allow_unstable`: unstable). `None` when
    /// ω·dt ≤ 1 and damping·dt ≤ 1.
    pub fn stiffness_warning(&self) -> Option<String> {
        let st = self.stiffness()?;
        let dt = self.mission.dt;
        let k = self.formation.min_scale;
        (st.omega_dt > 1.0 || st.damping_dt > 1.0).then(|| {
            format!(
                "{}: the formation is stiff for mission.dt = {dt}: ω·dt = {:.2}, damping·dt = {:.2} \
                 (neighbour spacing {:.4} at formation.min_scale = {k}); above 1 the integration is \
                 inaccurate, above 2 unstable{}: lower formation.alpha or mission.dt, or raise \
                 formation.radius",
                self.origin,
                st.omega_dt,
                st.damping_dt,
                st.spacing,
                if st.unstable() {
                    " (run only because mission.allow_unstable = true)"
                } else {
                    ""
                }
            )
        })
    }

    /// The resolved mission as TOML, every default filled in; it parses back to an equal
    /// mission.
    ///
    /// # Panics
    /// If the mission is not valid (a seed above 2⁶³ − 1 cannot be written as TOML).
    pub fn to_toml_string(&self) -> String {
        let body =
            short_floats(&toml::to_string(self).expect("a validated mission serialises to TOML"));
        format!(
            "# Resolved mission (every key, defaults filled in), from {}\n\n{body}",
            if self.origin.is_empty() {
                "<defaults>"
            } else {
                &self.origin
            }
        )
    }

    /// Applies command-line overrides and re-validates; an error names the override.
    pub fn with_overrides(mut self, o: &Overrides) -> Result<Mission, ConfigError> {
        let mut given = Vec::new();
        if let Some(seed) = o.seed {
            self.mission.seed = seed;
            given.push(format!("--seed {seed}"));
        }
        if let Some(n) = o.vehicles {
            self.vehicles.count = n;
            given.push(format!("--vehicles {n}"));
        }
        if let Some(d) = o.duration {
            self.mission.duration = d;
            given.push(format!("--duration {d}"));
        }
        if let Some(p) = o.pace {
            self.mission.pace = p;
            given.push(format!("--pace {p}"));
        }
        match self.validate() {
            Ok(()) => Ok(self),
            Err(ConfigError::Invalid {
                origin,
                key,
                value,
                reason,
            }) => Err(ConfigError::Invalid {
                origin,
                key,
                value,
                reason: format!("{reason} (with overrides {})", given.join(" ")),
            }),
            Err(other) => Err(other),
        }
    }

    /// Number of control ticks, round(duration / dt).
    pub fn ticks(&self) -> u64 {
        (self.mission.duration / self.mission.dt).round() as u64
    }

    /// `vehicles.start` as a position (z = 0 in 2-D).
    pub fn start_vec(&self) -> Vec3 {
        let mut out = Vec3::zeros();
        for (i, x) in self
            .vehicles
            .start
            .iter()
            .take(self.mission.dim.min(3))
            .enumerate()
        {
            out[i] = *x;
        }
        out
    }

    /// H of (V.6): `formation.hessian_guess`, or the identity; only the dim×dim block is
    /// non-zero (in 2-D the z row and column are zero).
    pub fn hessian_guess_mat(&self) -> Mat3 {
        let dim = self.mission.dim.min(3);
        let mut out = Mat3::zeros();
        match &self.formation.hessian_guess {
            Some(h) => {
                for (i, row) in h.iter().take(dim).enumerate() {
                    for (j, x) in row.iter().take(dim).enumerate() {
                        out[(i, j)] = *x;
                    }
                }
            }
            None => {
                for i in 0..dim {
                    out[(i, i)] = 1.0;
                }
            }
        }
        out
    }

    /// The environment this mission describes.
    pub fn field(&self) -> Field {
        Field::from_config(&self.field, self.mission.dim)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Parses `text` exactly as written.
    fn parse_raw(text: &str) -> Result<Mission, ConfigError> {
        Mission::from_toml_str(text, "missions/x.toml")
    }

    /// `text` with the keys every mission must give added where it lacks them (`[mission]
    /// name = "demo"`, the `[field]` keys of a gaussian, quadratic, eddy or front, at their
    /// struct defaults), so a fragment tests the one key it is about. Text that is not TOML
    /// (or whose `mission`/`field` is no table) is left as it is.
    fn complete(text: &str) -> String {
        use toml::Value;
        let Ok(mut doc) = toml::from_str::<toml::Table>(text) else {
            return text.to_string();
        };
        let mut changed = false;
        let d = FieldConfig::default();
        let floats = |v: &[f64]| Value::Array(v.iter().map(|x| Value::Float(*x)).collect());
        for (section, keys) in [("mission", vec!["name"]), ("field", vec![])] {
            let table = doc
                .entry(section)
                .or_insert_with(|| Value::Table(toml::Table::new()));
            let Value::Table(t) = table else { continue };
            let mut keys: Vec<&str> = keys;
            if section == "field" {
                keys = match t.get("kind").and_then(Value::as_str).unwrap_or("gaussian") {
                    "quadratic" => vec!["center", "hessian"],
                    "gaussian" | "eddy" | "front" => vec!["center", "amplitude", "width"],
                    _ => vec![],
                };
            }
            for key in keys {
                if t.contains_key(key) {
                    continue;
                }
                let value = match key {
                    "name" => Value::String("demo".into()),
                    "center" => floats(&d.center),
                    "amplitude" => Value::Float(d.amplitude),
                    "width" => Value::Float(d.width),
                    _ => Value::Array(d.hessian.iter().map(|r| floats(r)).collect()),
                };
                t.insert(key.to_string(), value);
                changed = true;
            }
        }
        if changed {
            toml::to_string(&doc).expect("a TOML table serialises")
        } else {
            text.to_string()
        }
    }

    /// Parses `text` [`complete`]d with the keys every mission must give.
    fn parse(text: &str) -> Result<Mission, ConfigError> {
        parse_raw(&complete(text))
    }

    /// The smallest valid mission: the required keys, at the struct defaults.
    const MINIMAL: &str =
        "[mission]\nname = \"demo\"\n[field]\ncenter = [20.0, 10.0]\namplitude = 10.0\nwidth = 15.0\n";

    #[test]
    fn empty_and_comment_only_files_are_no_mission() {
        for text in ["", "# a comment\n\n   # another\n", "[mission]\nseed = 3\n"] {
            let err = parse_raw(text).expect_err(text);
            assert_eq!(err.key(), Some("mission.name"), "{err}");
            let msg = err.to_string();
            assert!(
                msg.starts_with("missions/x.toml: mission.name = (missing): required"),
                "{msg}"
            );
            assert!(msg.contains("center, amplitude, width"), "{msg}");
        }
    }

    #[test]
    fn field_keys_without_a_meaningful_default_are_required() {
        let name = "[mission]\nname = \"a\"\n";
        for (field, key, kind) in [
            ("", "field.center", "\"gaussian\" (the default kind)"),
            (
                "[field]\ncenter = [1.0, 2.0]\nwidth = 3.0\n",
                "field.amplitude",
                "\"gaussian\"",
            ),
            (
                "[field]\ncenter = [1.0, 2.0]\namplitude = 3.0\n",
                "field.width",
                "\"gaussian\"",
            ),
            (
                "[field]\nkind = \"quadratic\"\ncenter = [1.0, 2.0]\n",
                "field.hessian",
                "\"quadratic\"",
            ),
            (
                "[field]\nkind = \"eddy\"\ncenter = [1.0, 2.0]\namplitude = 1.0\nwidth = 2.0\n",
                "field.velocity",
                "\"eddy\"",
            ),
            (
                "[field]\nkind = \"front\"\nnormal = [1.0, 0.0]\nwidth = 2.0\n",
                "field.amplitude",
                "\"front\"",
            ),
            (
                "[field]\nkind = \"gaussian_sum\"\n",
                "field.bumps",
                "\"gaussian_sum\"",
            ),
        ] {
            let text = format!("{name}{field}");
            let err = parse_raw(&text).expect_err(&text);
            assert_eq!(err.key(), Some(key), "{text:?}: {err}");
            let msg = err.to_string();
            assert!(
                msg.contains("(missing): required for field.kind = "),
                "{msg}"
            );
            assert!(msg.contains(kind), "{msg}");
        }
        // Given, they are enough.
        let q = parse_raw("[mission]\nname = \"a\"\ngoal = \"min\"\n[field]\nkind = \"quadratic\"\ncenter = [1.0, 2.0]\nhessian = [[1.0, 0.0], [0.0, 1.0]]\n").unwrap();
        assert_eq!(q.field.kind, FieldKind::Quadratic);
    }

    #[test]
    fn a_batch_table_is_accepted_and_not_resolved() {
        let text =
            format!("{MINIMAL}[batch]\nmin_convergence_rate = 0.9\nmax_final_distance = 1_000.0\n");
        let m = parse_raw(&text).unwrap();
        assert_eq!(m, parse_raw(MINIMAL).unwrap());
        assert!(!m.to_toml_string().contains("batch"));
    }

    #[test]
    fn an_unstable_time_step_is_refused_unless_allowed() {
        // Defaults: ω ≈ 4.7 rad/s at the smallest scale; dt = 1 s gives ω·dt ≈ 4.7.
        let err = parse("[mission]\ndt = 1.0").unwrap_err();
        assert_eq!(err.key(), Some("mission.dt"), "{err}");
        let msg = err.to_string();
        assert!(msg.contains("unstable: ω·dt = 4.7"), "{msg}");
        assert!(msg.contains("mission.allow_unstable = true"), "{msg}");
        // damping·dt above 2 alone.
        let err = parse("[mission]\ndt = 0.05\n[vehicles]\ndamping = 50.0").unwrap_err();
        assert_eq!(err.key(), Some("mission.dt"), "{err}");
        assert!(err.to_string().contains("damping·dt = 2.50"), "{err}");
        let m = parse("[mission]\ndt = 1.0\nallow_unstable = true").unwrap();
        let w = m.stiffness_warning().expect("still warned");
        assert!(w.contains("allow_unstable"), "{w}");
        // Stiff but stable (1 < ω·dt ≤ 2): a warning only.
        let m = parse("[mission]\ndt = 0.3").unwrap();
        let st = m.stiffness().unwrap();
        assert!(st.omega_dt > 1.0 && st.omega_dt <= 2.0, "{st:?}");
        assert!(m.stiffness_warning().is_some());
        // An override that makes the step unstable is refused, naming the key.
        let err = parse(MINIMAL)
            .unwrap()
            .with_overrides(&Overrides {
                vehicles: Some(64),
                ..Overrides::default()
            })
            .unwrap_err();
        assert_eq!(err.key(), Some("mission.dt"), "{err}");
    }

    #[test]
    fn a_huge_or_endless_file_is_refused_without_reading_it_all() {
        let err = Mission::load(Path::new("/dev/zero")).unwrap_err();
        assert!(matches!(err, ConfigError::TooLarge { .. }), "{err}");
        assert!(
            err.to_string()
                .starts_with("/dev/zero: the mission file is larger than 1048576 bytes"),
            "{err}"
        );
        let dir = std::env::temp_dir().join(format!("vbap-config-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let big = dir.join("big.toml");
        let mut text = String::from(MINIMAL);
        while text.len() as u64 <= MAX_FILE_BYTES {
            text.push_str("# padding padding padding padding padding padding padding padding\n");
        }
        std::fs::write(&big, &text).unwrap();
        assert!(matches!(
            Mission::load(&big).unwrap_err(),
            ConfigError::TooLarge { .. }
        ));
        // Just under the limit is read.
        text.truncate(MAX_FILE_BYTES as usize - 1);
        let cut = text.rfind('\n').unwrap() + 1;
        text.truncate(cut);
        std::fs::write(&big, &text).unwrap();
        assert!(Mission::load(&big).is_ok());
        // Not text.
        std::fs::write(&big, [0xff, 0xfe, 0x00]).unwrap();
        let err = Mission::load(&big).unwrap_err();
        assert!(err.to_string().contains("not UTF-8"), "{err}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn the_glider_fault_examples_validate_when_uncommented() {
        for name in ["glider.toml", "glider_surfacing.toml"] {
            let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../deploy/missions/");
            let text = std::fs::read_to_string(format!("{dir}{name}")).unwrap();
            let uncommented = uncomment_example(&text);
            assert_ne!(uncommented, text, "{name} has a commented example");
            let m = Mission::from_toml_str(&uncommented, name)
                .unwrap_or_else(|e| panic!("{e}\n{uncommented}"));
            assert_eq!(m.faults.len(), 1, "{name}");
            assert_eq!(m.faults[0].kind, FaultKind::Kill);
            assert_eq!(m.faults[0].until, Some(43200.0));
            assert_eq!(m.restart.vehicles, RestartPolicy::OnFailure);
        }
    }

    /// Uncomments the trailing example of a mission file: from its first line `# [` on,
    /// every line `# x` becomes `x` (`## x` stays a comment).
    pub(super) fn uncomment_example(text: &str) -> String {
        let mut on = false;
        let mut out = String::new();
        for line in text.lines() {
            on |= line.starts_with("# [");
            match line.strip_prefix("# ") {
                Some(code) if on => out.push_str(code),
                _ => out.push_str(line),
            }
            out.push('\n');
        }
        out
    }

    #[test]
    fn a_minimal_file_gives_every_default() {
        let m = parse_raw(MINIMAL).expect("defaults are valid");
        let s = &m.mission;
        assert_eq!(s.name, "demo");
        assert_eq!(s.seed, 1);
        assert_eq!(s.duration, 300.0);
        assert_eq!(s.dt, 0.05);
        assert_eq!(s.pace, Pace::Lockstep);
        assert_eq!(s.goal, Goal::Max);
        assert_eq!(s.dim, 2);
        assert_eq!(s.tolerance, 1.0);
        assert_eq!(s.length_unit, "");
        assert_eq!(s.field_label, "T");
        let f = &m.field;
        assert_eq!(f.kind, FieldKind::Gaussian);
        assert_eq!(f.center, vec![20.0, 10.0]);
        assert_eq!(f.amplitude, 10.0);
        assert_eq!(f.width, 15.0);
        assert_eq!(f.hessian, vec![vec![1.0, 0.0], vec![0.0, 1.0]]);
        assert_eq!(f.noise_std, 0.1);
        assert_eq!(f.background, 0.0);
        assert_eq!(f.offset, 0.0);
        assert!(f.velocity.is_empty() && f.normal.is_empty() && f.bumps.is_empty());
        assert_eq!(f.speed, 0.0);
        let v = &m.vehicles;
        assert_eq!(v.count, 4);
        assert_eq!(v.start, vec![0.0, 0.0]);
        assert_eq!(v.start_spread, 0.5);
        assert_eq!(v.damping, 1.0);
        let fo = &m.formation;
        assert_eq!(fo.radius, 1.5);
        assert!(fo.adapt);
        assert_eq!(fo.adapt_gain, 0.5);
        assert_eq!(fo.alpha, 1.0);
        assert_eq!(fo.min_scale, 0.2);
        assert_eq!(fo.max_scale, 5.0);
        assert_eq!(fo.sigma_h, 1.0);
        assert_eq!(fo.hessian_guess, None);
        let b = &m.body;
        assert_eq!(
            (b.v0, b.v_u, b.delta, b.grad_saturation),
            (0.5, 1.0, 0.01, 1.0)
        );
        let e = &m.estimator;
        assert_eq!(e.kalman_b, 0.05);
        assert_eq!(e.confidence, 0.99);
        assert_eq!(e.delta_m, None);
        assert_eq!(e.sigma_m, None);
        assert_eq!(e.initial_variance, 1.0);
        let l = &m.links;
        assert_eq!(
            (
                l.delay,
                l.jitter,
                l.loss,
                l.surfacing_period,
                l.surfacing_window
            ),
            (0.0, 0.0, 0.0, 0.0, 0.0)
        );
        assert!(m.faults.is_empty());
        assert!(!s.allow_unstable);
        assert_eq!(m, Mission::default());
        assert_eq!(m.ticks(), 6000);
        assert_eq!(m.start_vec(), Vec3::zeros());
        assert_eq!(
            m.hessian_guess_mat(),
            Mat3::from_diagonal(&Vec3::new(1.0, 1.0, 0.0))
        );
        assert_eq!(m.origin, "missions/x.toml");
    }

    #[test]
    fn a_missing_section_takes_its_defaults_and_others_keep_theirs() {
        let m = parse("[body]\nv0 = 0.25\n").unwrap();
        assert_eq!(m.body.v0, 0.25);
        assert_eq!(m.body.v_u, 1.0);
        assert_eq!(m.mission, MissionSection::default());
    }

    #[test]
    fn pace_accepts_lockstep_floats_and_integers() {
        assert_eq!(
            parse("[mission]\npace = \"lockstep\"")
                .unwrap()
                .mission
                .pace,
            Pace::Lockstep
        );
        assert_eq!(
            parse("[mission]\npace = 60").unwrap().mission.pace,
            Pace::Factor(60.0)
        );
        assert_eq!(
            parse("[mission]\npace = 0.5").unwrap().mission.pace,
            Pace::Factor(0.5)
        );
        let e = parse("[mission]\npace = \"fast\"").unwrap_err();
        assert_eq!(e.key(), Some("mission.pace"), "{e}");
        assert!(e.to_string().contains("lockstep"), "{e}");
        assert_eq!("lockstep".parse::<Pace>(), Ok(Pace::Lockstep));
        assert_eq!("2.5".parse::<Pace>(), Ok(Pace::Factor(2.5)));
        assert!("0".parse::<Pace>().is_err());
        assert!("-1".parse::<Pace>().is_err());
        assert!("inf".parse::<Pace>().is_err());
        assert!("NaN".parse::<Pace>().is_err());
        assert_eq!(Pace::Factor(60.0).to_string(), "60");
    }

    /// (TOML text, key that must be named). Each is valid except for that one key.
    const BAD: &[(&str, &str)] = &[
        ("[mission]\nname = \"a-b\"", "mission.name"),
        ("[mission]\nname = \"\"", "mission.name"),
        ("[mission]\nname = \"abcdefghijabcdefghijabcdefghij123\"", "mission.name"),
        ("[mission]\nseed = -1", "mission.seed"),
        ("[mission]\ndt = 0", "mission.dt"),
        ("[mission]\ndt = -0.1", "mission.dt"),
        ("[mission]\ndt = nan", "mission.dt"),
        ("[mission]\nduration = inf", "mission.duration"),
        ("[mission]\nduration = 0.01\ndt = 0.05", "mission.duration"),
        ("[mission]\nduration = 1e6\ndt = 0.05", "mission.duration"),
        ("[mission]\npace = 0", "mission.pace"),
        ("[mission]\npace = -2.0", "mission.pace"),
        ("[mission]\npace = nan", "mission.pace"),
        ("[mission]\ngoal = \"up\"", "mission.goal"),
        ("[mission]\ndim = 4", "mission.dim"),
        ("[mission]\ndim = 1", "mission.dim"),
        ("[mission]\ntolerance = 0", "mission.tolerance"),
        ("[mission]\nlength_unit = \"a\\nb\"", "mission.length_unit"),
        ("[mission]\nfield_label = \"abcdefghijabcdefghijabcdefghij123\"", "mission.field_label"),
        ("[mission]\ndim = 3", "field.center"),
        ("[field]\nkind = \"plane\"", "field.kind"),
        ("[field]\nwidth = -1", "field.width"),
        ("[field]\nwidth = 0", "field.width"),
        ("[field]\namplitude = 0", "field.amplitude"),
        ("[field]\namplitude = inf", "field.amplitude"),
        ("[field]\ncenter = [1.0]", "field.center"),
        ("[field]\ncenter = [1.0, nan]", "field.center[1]"),
        ("[field]\ncenter = [1.0, \"a\"]", "field.center[1]"),
        ("[field]\nnoise_std = -0.1", "field.noise_std"),
        ("[field]\nbackground = nan", "field.background"),
        ("[field]\nkind = \"quadratic\"\nhessian = [[1.0, 2.0], [0.0, 1.0]]", "field.hessian"),
        ("[field]\nkind = \"quadratic\"\nhessian = [[1.0, 0.0]]", "field.hessian"),
        ("[field]\nkind = \"quadratic\"\nhessian = [[1.0, 0.0], [0.0, inf]]", "field.hessian[1][1]"),
        ("[field]\nvelocity = [1.0, 0.0]", "field.velocity"),
        ("[field]\nkind = \"eddy\"", "field.velocity"),
        ("[field]\nkind = \"eddy\"\nvelocity = [1.0, 0.0, 0.0]", "field.velocity"),
        ("[field]\nkind = \"front\"", "field.normal"),
        ("[field]\nkind = \"front\"\nnormal = [0.0, 0.0]", "field.normal"),
        ("[field]\nnormal = [1.0, 0.0]", "field.normal"),
        ("[field]\nkind = \"front\"\nnormal = [1.0, 0.0]\nspeed = inf", "field.speed"),
        ("[field]\nkind = \"gaussian_sum\"", "field.bumps"),
        (
            "[field]\n[[field.bumps]]\ncenter = [0.0, 0.0]\namplitude = 1.0\nwidth = 1.0",
            "field.bumps",
        ),
        (
            "[field]\nkind = \"gaussian_sum\"\n[[field.bumps]]\ncenter = [0.0, 0.0]\namplitude = 1.0\nwidth = 1.0\n[[field.bumps]]\ncenter = [0.0, 0.0]\namplitude = 1.0\nwidth = -1.0",
            "field.bumps[1].width",
        ),
        (
            "[field]\nkind = \"gaussian_sum\"\n[[field.bumps]]\ncenter = [0.0]\namplitude = 1.0\nwidth = 1.0",
            "field.bumps[0].center",
        ),
        (
            "[field]\nkind = \"gaussian_sum\"\n[[field.bumps]]\ncenter = [0.0, 0.0]\namplitude = 0.0\nwidth = 1.0",
            "field.bumps[0].amplitude",
        ),
        (
            "[field]\nkind = \"gaussian_sum\"\n[[field.bumps]]\ncenter = [0.0, 0.0]\nwidth = 1.0",
            "field.bumps[0].amplitude",
        ),
        (
            "[field]\nkind = \"front\"\nnormal = [1.0, 0.0]\n[[field.bumps]]\ncenter = [0.0, 0.0]\namplitude = 1.0\nwidth = 1.0\n[[field.bumps]]\ncenter = [0.0, 0.0]\namplitude = 1.0\nwidth = 1.0",
            "field.bumps",
        ),
        ("[vehicles]\ncount = 2", "vehicles.count"),
        ("[vehicles]\ncount = 257", "vehicles.count"),
        ("[vehicles]\ncount = -1", "vehicles.count"),
        ("[mission]\ndim = 3\n[field]\ncenter = [1.0, 2.0, 3.0]\n[vehicles]\nstart = [0.0, 0.0, 0.0]\ncount = 3", "vehicles.count"),
        ("[vehicles]\nstart = [0.0, 0.0, 0.0]", "vehicles.start"),
        ("[vehicles]\nstart_spread = -1", "vehicles.start_spread"),
        ("[vehicles]\ndamping = 0", "vehicles.damping"),
        ("[formation]\nradius = 0", "formation.radius"),
        ("[formation]\nadapt = \"yes\"", "formation.adapt"),
        ("[formation]\nadapt_gain = 0", "formation.adapt_gain"),
        ("[formation]\nadapt_gain = -1\nadapt = false", "formation.adapt_gain"),
        ("[formation]\nalpha = -1", "formation.alpha"),
        ("[formation]\nmin_scale = 0", "formation.min_scale"),
        ("[formation]\nmin_scale = 1.5", "formation.min_scale"),
        ("[formation]\nmax_scale = 0.5", "formation.max_scale"),
        ("[formation]\nsigma_h = 0", "formation.sigma_h"),
        ("[formation]\nhessian_guess = [[1.0, 0.1], [0.0, 1.0]]", "formation.hessian_guess"),
        ("[formation]\nhessian_guess = [[1.0, 0.0, 0.0]]", "formation.hessian_guess"),
        ("[formation]\nhessian_guess = [[0.0, 0.0], [0.0, 0.0]]", "formation.hessian_guess"),
        ("[body]\nv0 = 0", "body.v0"),
        ("[body]\nv_u = -1", "body.v_u"),
        ("[body]\ndelta = 0", "body.delta"),
        ("[body]\ngrad_saturation = 0", "body.grad_saturation"),
        ("[estimator]\nkalman_b = 0", "estimator.kalman_b"),
        ("[estimator]\nconfidence = 1.0", "estimator.confidence"),
        ("[estimator]\nconfidence = 0.0", "estimator.confidence"),
        ("[estimator]\ndelta_m = -0.1", "estimator.delta_m"),
        ("[estimator]\nsigma_m = 0.0", "estimator.sigma_m"),
        ("[estimator]\ninitial_variance = 0", "estimator.initial_variance"),
        ("[links]\ndelay = -1", "links.delay"),
        ("[links]\ndelay = 1\njitter = 2", "links.jitter"),
        ("[links]\nloss = 1.0", "links.loss"),
        ("[links]\nloss = -0.1", "links.loss"),
        ("[links]\nsurfacing_period = -1", "links.surfacing_period"),
        ("[links]\nsurfacing_period = 10\nsurfacing_window = 20", "links.surfacing_window"),
        ("[links]\nsurfacing_period = 10", "links.surfacing_window"),
        ("[links]\nburst_enter = 1.5", "links.burst_enter"),
        ("[links]\nburst_enter = 0.1\nburst_exit = 0.0", "links.burst_exit"),
        ("[restart]\nbackoff = 0", "restart.backoff"),
        ("[restart]\nvehicles = \"sometimes\"", "restart.vehicles"),
        ("[[faults]]\nkind = \"kill\"\nvehicle = 1\nat = 10.0\nuntil = 20.0", "faults[0].until"),
        ("[[faults]]\nkind = \"kill\"\nvehicle = 4\nat = 1.0", "faults[0].vehicle"),
        ("[[faults]]\nkind = \"kill\"\nvehicle = 1\nat = -1.0", "faults[0].at"),
        ("[[faults]]\nkind = \"kill\"\nvehicle = 1\nat = 301.0", "faults[0].at"),
        ("[[faults]]\nkind = \"link_down\"\nvehicle = 1\nat = 10.0\nuntil = 5.0", "faults[0].until"),
        ("[[faults]]\nkind = \"link_down\"\nvehicle = 1\nat = 10.0\nuntil = 400.0", "faults[0].until"),
        ("[[faults]]\nkind = \"sensor_bias\"\nvehicle = 1\nat = 10.0", "faults[0].value"),
        ("[[faults]]\nkind = \"kill\"\nvehicle = 1\nat = 10.0\nvalue = 2.0", "faults[0].value"),
        ("[[faults]]\nkind = \"sensor_stuck\"\nvehicle = 1\nat = 10.0\nvalue = nan", "faults[0].value"),
        ("[[faults]]\nkind = \"explode\"\nvehicle = 1\nat = 10.0", "faults[0].kind"),
        ("[[faults]]\nkind = \"kill\"\nvehicle = 1", "faults[0].at"),
        (
            "[[faults]]\nkind = \"kill\"\nvehicle = 1\nat = 1.0\n[[faults]]\nkind = \"kill\"\nat = 2.0",
            "faults[1].vehicle",
        ),
        ("[mission]\nname = 3", "mission.name"),
        ("mission = 3", "mission"),
        ("[mission]\ndt = 1.0", "mission.dt"),
        ("[mission]\nallow_unstable = 1", "mission.allow_unstable"),
        ("[vehicles]\ndamping = 45.0", "mission.dt"),
        ("[field]\nwidth = -1e-300", "field.width"),
        ("[batch]\nmin_convergence_rate = 0.5\n[mission]\nname = \"a.b\"", "mission.name"),
    ];

    #[test]
    fn every_bad_input_is_refused_naming_its_key() {
        for (text, key) in BAD {
            let err = parse(text).expect_err(text);
            assert_eq!(err.key(), Some(*key), "{text:?} gave: {err}");
            let msg = err.to_string();
            assert!(msg.starts_with("missions/x.toml: "), "{msg}");
            assert!(msg.contains(key), "{msg}");
        }
    }

    #[test]
    fn invalid_message_has_the_documented_form() {
        let err = parse("[field]\nwidth = -1").unwrap_err();
        assert_eq!(
            err.to_string(),
            "missions/x.toml: field.width = -1: must be > 0"
        );
    }

    #[test]
    fn unknown_keys_are_refused_by_name_and_line() {
        let err = parse_raw("[mission]\nname = \"a\"\n[field]\nwidht = 3.0\n").unwrap_err();
        assert_eq!(err.key(), Some("field.widht"), "{err}");
        let msg = err.to_string();
        assert!(msg.contains("unknown field `widht`"), "{msg}");
        assert!(msg.contains("line 4, column 1"), "{msg}");
        let err = parse_raw("speed = 3.0\n").unwrap_err();
        assert_eq!(err.key(), Some("speed"), "{err}");
        let err = parse_raw("[fields]\nkind = \"gaussian\"\n").unwrap_err();
        assert_eq!(err.key(), Some("fields"), "{err}");
        let err = parse_raw("[[faults]]\nkind = \"kill\"\nvehicle = 1\nat = 1.0\nwhen = 2.0\n")
            .unwrap_err();
        assert_eq!(err.key(), Some("faults[0].when"), "{err}");
        let err = parse_raw(
            "[field]\nkind = \"gaussian_sum\"\n[[field.bumps]]\ncenter = [0.0, 0.0]\namplitude = 1.0\nwidth = 1.0\nsigma = 2\n",
        )
        .unwrap_err();
        assert_eq!(err.key(), Some("field.bumps[0].sigma"), "{err}");
    }

    #[test]
    fn syntax_errors_keep_line_and_column() {
        let err = parse_raw("[mission]\nname = 'x\n").unwrap_err();
        match &err {
            ConfigError::Syntax { line, column, .. } => assert_eq!((*line, *column), (2, 10)),
            other => panic!("not a syntax error: {other}"),
        }
        assert!(err
            .to_string()
            .starts_with("missions/x.toml: line 2, column 10: invalid TOML"));
        let err = parse_raw("[mission]\nseed = 1\n[mission]\n").unwrap_err();
        assert!(matches!(err, ConfigError::Syntax { line: 3, .. }), "{err}");
    }

    #[test]
    fn missing_file_names_it() {
        let err = Mission::load(Path::new("/nonexistent/m.toml")).unwrap_err();
        assert!(matches!(err, ConfigError::Read { .. }));
        assert!(
            err.to_string()
                .starts_with("/nonexistent/m.toml: cannot read"),
            "{err}"
        );
    }

    const FULL: &str = r#"
[mission]
name = "full_3d"
seed = 9223372036854775807
duration = 100.0
dt = 0.1
pace = 2.5
goal = "min"
dim = 3
tolerance = 0.3
length_unit = "km"
field_label = "S (psu)"

[field]
kind = "front"
center = [1.0, 2.0, 3.0]
amplitude = -1.5
width = 0.30000000000000004
normal = [0.0, 1.0, 1.0]
speed = 0.01
offset = -2.0
background = 12.0
noise_std = 0.0

[[field.bumps]]
center = [1.0, 1.0, 1.0]
amplitude = -2.0
width = 1e-3

[vehicles]
count = 6
start = [0.1, 0.2, 0.3]

[formation]
adapt = false
adapt_gain = 0.0
hessian_guess = [[2.0, 0.5, 0.0], [0.5, 1.0, 0.0], [0.0, 0.0, 1.0]]

[estimator]
sigma_m = 0.2

[links]
delay = 1.0
jitter = 0.5
loss = 0.1
surfacing_period = 60.0
surfacing_window = 6.0
surfacing_phase = "together"
burst_enter = 0.01

[restart]
vehicles = "on-failure"
backoff = 0.5

[[faults]]
kind = "kill"
vehicle = 2
at = 20.0
until = 40.0

[[faults]]
kind = "sensor_stuck"
vehicle = 5
at = 0.0

[[faults]]
kind = "sensor_bias"
vehicle = 0
at = 100.0
value = -0.5
"#;

    #[test]
    fn resolved_floats_are_short_and_exact() {
        let text = "[mission]\nname = \"tiny\"\nfield_label = \"T 0.0000000000000000000001 '#\\\" x\"\n\
                    [field]\ncenter = [1e300, -1e-300]\namplitude = 2.5e-7\nwidth = 9000.0\n\
                    [formation]\nadapt_gain = 1e-300\nhessian_guess = [[2.5e-8, 0.0], [0.0, 1e-320]]\n";
        let m = parse_raw(text).unwrap();
        let resolved = m.to_toml_string();
        for line in resolved.lines() {
            assert!(line.len() < 120, "{line}");
        }
        assert!(resolved.contains("adapt_gain = 1e-300"), "{resolved}");
        assert!(resolved.contains("amplitude = 2.5e-7"), "{resolved}");
        assert!(resolved.contains("width = 9000.0"), "{resolved}");
        assert!(resolved.contains("center = [1e300, -1e-300]"), "{resolved}");
        assert!(
            resolved.contains("T 0.0000000000000000000001 '#"),
            "strings untouched: {resolved}"
        );
        let back = parse_raw(&resolved).unwrap_or_else(|e| panic!("{e}\n{resolved}"));
        assert_eq!(back, m);
        assert_eq!(
            back.mission.field_label,
            "T 0.0000000000000000000001 '#\" x"
        );
        assert_eq!(
            back.formation.hessian_guess.unwrap()[1][1].to_bits(),
            1e-320f64.to_bits()
        );
    }

    #[test]
    fn resolved_mission_round_trips() {
        for m in [Mission::default(), parse(FULL).unwrap()] {
            let text = m.to_toml_string();
            let back = Mission::from_toml_str(&text, "resolved.toml")
                .unwrap_or_else(|e| panic!("{e}\n{text}"));
            assert_eq!(back, m, "{text}");
            // Every section is written out in full.
            for section in [
                "[mission]",
                "[field]",
                "[vehicles]",
                "[formation]",
                "[body]",
                "[estimator]",
                "[links]",
            ] {
                assert!(text.contains(section), "{section} missing in\n{text}");
            }
            assert!(text.contains("grad_saturation = "), "{text}");
        }
        let full = parse(FULL).unwrap();
        assert_eq!(full.faults.len(), 3);
        assert_eq!(full.faults[0].until, Some(40.0));
        assert_eq!(full.start_vec(), Vec3::new(0.1, 0.2, 0.3));
        assert_eq!(full.hessian_guess_mat()[(0, 1)], 0.5);
        assert_eq!(full.hessian_guess_mat()[(2, 2)], 1.0);
        assert_eq!(full.ticks(), 1000);
        assert_eq!(full.mission.pace, Pace::Factor(2.5));
        assert!(matches!(full.field(), Field::MovingFront { dim: 3, .. }));
    }

    #[test]
    fn overrides_apply_and_revalidate() {
        let m = parse(FULL).unwrap();
        let o = Overrides {
            seed: Some(5),
            vehicles: Some(8),
            duration: Some(200.0),
            pace: Some(Pace::Lockstep),
        };
        let m2 = m.clone().with_overrides(&o).unwrap();
        assert_eq!(m2.mission.seed, 5);
        assert_eq!(m2.vehicles.count, 8);
        assert_eq!(m2.mission.duration, 200.0);
        assert_eq!(m2.mission.pace, Pace::Lockstep);
        assert_eq!(m2.ticks(), 2000);
        assert_eq!(m.clone().with_overrides(&Overrides::default()).unwrap(), m);
        // Fewer vehicles than a fault refers to.
        let err = m
            .clone()
            .with_overrides(&Overrides {
                vehicles: Some(5),
                ..Overrides::default()
            })
            .unwrap_err();
        assert_eq!(err.key(), Some("faults[1].vehicle"), "{err}");
        assert!(err.to_string().contains("--vehicles 5"), "{err}");
        // Too few for 3-D least squares.
        let err = m
            .clone()
            .with_overrides(&Overrides {
                vehicles: Some(3),
                ..Overrides::default()
            })
            .unwrap_err();
        assert_eq!(err.key(), Some("vehicles.count"), "{err}");
        // A shorter mission than a fault time; a seed TOML cannot hold; a bad pace.
        for (o, key) in [
            (
                Overrides {
                    duration: Some(50.0),
                    ..Overrides::default()
                },
                "faults[2].at",
            ),
            (
                Overrides {
                    seed: Some(u64::MAX),
                    ..Overrides::default()
                },
                "mission.seed",
            ),
            (
                Overrides {
                    pace: Some(Pace::Factor(0.0)),
                    ..Overrides::default()
                },
                "mission.pace",
            ),
        ] {
            let err = m.clone().with_overrides(&o).unwrap_err();
            assert_eq!(err.key(), Some(key), "{err}");
        }
    }

    #[test]
    fn mission_field_is_built_from_the_config() {
        let m = parse("[mission]\ngoal = \"max\"\n[field]\ncenter = [3.0, 4.0]\n").unwrap();
        assert_eq!(
            m.field().optimum(0.0, Goal::Max),
            Some(Vec3::new(3.0, 4.0, 0.0))
        );
    }

    #[test]
    fn shipped_missions_parse_and_validate() {
        let dir = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../deploy/missions"));
        let mut files: Vec<_> = std::fs::read_dir(dir)
            .expect("deploy/missions exists")
            .map(|e| e.expect("dir entry").path())
            .filter(|p| p.extension().is_some_and(|e| e == "toml"))
            .collect();
        files.sort();
        assert!(files.len() >= 3, "{files:?}");
        for path in &files {
            let m = Mission::load(path).unwrap_or_else(|e| panic!("{e}"));
            let back = Mission::from_toml_str(&m.to_toml_string(), "resolved")
                .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            assert_eq!(back, m, "{}", path.display());
            let field = m.field();
            assert!(
                field.optimum(0.0, m.mission.goal).is_some(),
                "{}: the field has no optimum for the goal",
                path.display()
            );
            assert!(
                m.ticks() <= 50_000,
                "{}: {} ticks",
                path.display(),
                m.ticks()
            );
        }
    }
}

#[cfg(test)]
mod stiffness_tests {
    use super::*;

    #[test]
    fn shipped_missions_are_not_stiff_and_a_crowded_formation_is() {
        let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../deploy/missions");
        for name in [
            "paper.toml",
            "glider.toml",
            "glider_surfacing.toml",
            "quadratic3d.toml",
        ] {
            let m = Mission::load(&std::path::Path::new(dir).join(name)).unwrap();
            assert_eq!(m.stiffness_warning(), None, "{name}");
        }
        let m = Mission::load(&std::path::Path::new(dir).join("paper.toml")).unwrap();
        let crowded = Overrides {
            vehicles: Some(32),
            ..Overrides::default()
        };
        // 32 vehicles on the paper's radius: unstable, refused naming the time step...
        let err = m.clone().with_overrides(&crowded).unwrap_err();
        assert_eq!(err.key(), Some("mission.dt"), "{err}");
        assert!(err.to_string().contains("--vehicles 32"), "{err}");
        // ...unless allowed, and then still warned about.
        let mut allowed = m.clone();
        allowed.mission.allow_unstable = true;
        let w = allowed
            .with_overrides(&crowded)
            .unwrap()
            .stiffness_warning()
            .expect("32 vehicles on the paper's radius are stiff");
        assert!(
            w.contains("formation.alpha")
                && w.contains("mission.dt")
                && w.contains("allow_unstable"),
            "{w}"
        );
        // Between the two limits: valid, with a warning.
        let stiff = (5..32)
            .map(|n| {
                let mut c = m.clone();
                c.vehicles.count = n;
                c
            })
            .find(|c| {
                c.stiffness()
                    .is_some_and(|s| s.omega_dt > 1.0 && !s.unstable())
            })
            .expect("a fleet size between the limits");
        assert_eq!(stiff.validate().map_err(|e| e.to_string()), Ok(()));
        assert!(stiff.stiffness_warning().is_some());
    }
}
