//! The sections of a mission file about the goal, the field, the vehicles, the formation,
//! the virtual body and the estimator, with their defaults.

use serde::{Deserialize, Serialize};

use super::motion::VehicleModelKind;
use super::pace::Pace;

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
    /// A gridded variable of a file (`field.file`, NetCDF or NumPy), interpolated.
    Grid,
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
            FieldKind::Grid => "grid",
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
            FieldKind::Grid => &["file"],
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
    /// damping·dt above 2, see [`Mission::stiffness`](super::Mission::stiffness)); false =
    /// such a mission is refused.
    pub allow_unstable: bool,
    /// The date and time of mission time 0, RFC 3339 (`"2026-08-01T00:00:00Z"`); absent =
    /// none (the exported NetCDF file then counts time from 1970-01-01, and says so).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub start: Option<String>,
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
            start: None,
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
    /// Grid: the file (NetCDF classic / 64-bit offset `.nc`, NumPy `.npy` / `.npz`),
    /// relative to the mission file; the resolved mission holds it absolute.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub file: Option<String>,
    /// Grid: the variable; absent = the file's only variable of rank ≥ 2.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub variable: Option<String>,
    /// Grid: the x (easting or longitude) coordinate variable; absent = found from CF
    /// `axis` / `standard_name` / `units`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub x: Option<String>,
    /// Grid: the y (northing or latitude) coordinate variable; absent = found as for x.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub y: Option<String>,
    /// Grid: the vertical coordinate variable (metres; 3-D missions); absent = found as for x.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub z: Option<String>,
    /// Grid: the time coordinate variable (CF `<unit> since <date>`; mission t = 0 at its
    /// first value); absent = found as for x.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub time: Option<String>,
    /// Grid: x/y are longitude/latitude in degrees (projected to metres about `origin`);
    /// absent = from the units (`degrees_east` / `degrees_north`) or, in a `.npz`, the names
    /// lon/lat.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub geographic: Option<bool>,
    /// Grid, geographic: [lon, lat] (degrees) of the mission's (0, 0); absent = the grid
    /// centre.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub origin: Option<Vec<f64>>,
    /// Grid: values above this (field unit) are land, e.g. 0.0 for a bathymetry grid where
    /// land is positive elevation; absent = only missing values are land.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub land_above: Option<f64>,
    /// Grid, `.npy` only (it has no coordinates): [x_first, x_last, y_first, y_last] (and
    /// z_first, z_last in 3-D) of the evenly spaced nodes (length unit, or degrees when
    /// `geographic`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub extent: Option<Vec<f64>>,
    /// The loaded grid (kind = "grid"; not a key): read once when the mission is loaded.
    #[serde(skip)]
    pub grid: crate::grid::GridSlot,
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
            file: None,
            variable: None,
            x: None,
            y: None,
            z: None,
            time: None,
            geographic: None,
            origin: None,
            land_above: None,
            extent: None,
            grid: crate::grid::GridSlot::default(),
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
    /// `"ideal"` (default: the paper's double integrator) | `"glider"` (speed, acceleration
    /// and turn limits, dead reckoning under water; beyond the paper). Written only when
    /// not ideal.
    #[serde(skip_serializing_if = "VehicleModelKind::is_ideal")]
    pub model: VehicleModelKind,
    /// Glider: largest speed through the water, length unit/s, > 0; absent =
    /// [`super::motion::DEFAULT_MAX_SPEED`] (0.3 m/s).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_speed: Option<f64>,
    /// Glider: largest change of the water velocity, length unit/s², > 0; absent =
    /// [`super::motion::DEFAULT_MAX_ACCEL`] (0.01 m/s²).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_accel: Option<f64>,
    /// Glider: largest turn rate, rad/s, > 0; absent =
    /// [`super::motion::DEFAULT_MAX_TURN_RATE`] (0.1 rad/s).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_turn_rate: Option<f64>,
    /// Glider: s between GPS fixes, > 0 (a fix at the first tick of every period);
    /// absent = a fix whenever the glider is at the surface by `[links]` surfacing
    /// schedule (every tick without one: a glider that never dives knows its position).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fix_period: Option<f64>,
    /// Glider: estimate the current from the drift found at each fix and dead-reckon with
    /// it (as real gliders estimate the depth-averaged current); absent = true for the
    /// glider model ([`VehiclesSection::estimates_current`]); false: dead reckoning with
    /// the water velocity alone.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub current_estimate: Option<bool>,
    /// Glider, 3-D: z at the bottom of a sawtooth dive (length unit, ≠ 0; positive on a
    /// depth axis pointing down); absent = no dive profile (z is the law's, as before).
    /// The glider's z then follows the profile (readings along the dive), its GPS fix
    /// is at the top of each dive.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub dive_depth: Option<f64>,
    /// Glider with `dive_depth`: vertical speed through the water, length unit/s, > 0 and
    /// < the largest speed; absent = [`super::motion::DEFAULT_DIVE_RATE`] (0.1 m/s).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub dive_rate: Option<f64>,
}

impl VehiclesSection {
    /// Whether the vehicles estimate the current at each fix: `current_estimate`, by
    /// default true for a glider (as real gliders do) and false for the paper's vehicle
    /// (which always knows where it is).
    pub fn estimates_current(&self) -> bool {
        self.current_estimate.unwrap_or(!self.model.is_ideal())
    }
}

impl Default for VehiclesSection {
    fn default() -> Self {
        VehiclesSection {
            count: 4,
            start: vec![0.0, 0.0],
            start_spread: 0.5,
            damping: 1.0,
            model: VehicleModelKind::Ideal,
            max_speed: None,
            max_accel: None,
            max_turn_rate: None,
            fix_period: None,
            current_estimate: None,
            dive_depth: None,
            dive_rate: None,
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
    /// Beyond the paper: under `control.law = "robust"`, on a field that may move
    /// ([`crate::config::Mission::field_may_move`]), estimate the field's drift from the
    /// planner's own estimates (`vbap_math::drift`) and add it to the body's velocity once
    /// it is significant, so a moving optimum is tracked rather than trailed. Default true.
    pub track_drift: bool,
}

impl Default for BodySection {
    fn default() -> Self {
        BodySection {
            v0: 0.5,
            v_u: 1.0,
            delta: 0.01,
            grad_saturation: 1.0,
            track_drift: true,
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
