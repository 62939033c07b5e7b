//! The motion of the vehicles beyond the paper's double integrator: the vehicle model of
//! `[vehicles]` (`model`, `max_speed`, `max_accel`, `max_turn_rate`, `fix_period`), the
//! `[current]` that carries them and the `[land]` they keep out of. Every key here is
//! absent from a resolved mission that does not use it, so the run files of a mission
//! without them stay what they were.

use serde::{Deserialize, Serialize};

/// `vehicles.model`: how the control u_i moves a vehicle.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum VehicleModelKind {
    /// The paper's double integrator ẍ_i = u_i (II.1), no limit; position always known.
    #[default]
    Ideal,
    /// A glider: u_i applied to the velocity through the water and saturated (speed,
    /// acceleration, turn rate); under water it dead-reckons (`vbap_math::vehicle`).
    Glider,
}

impl VehicleModelKind {
    /// True for the paper's vehicle (the default).
    pub fn is_ideal(&self) -> bool {
        *self == VehicleModelKind::Ideal
    }
    /// The name as the mission file writes it.
    pub fn as_str(self) -> &'static str {
        match self {
            VehicleModelKind::Ideal => "ideal",
            VehicleModelKind::Glider => "glider",
        }
    }
}

/// Default `vehicles.dive_rate` of a diving glider, m/s (real gliders: 0.1–0.2 m/s).
pub const DEFAULT_DIVE_RATE: f64 = 0.1;

/// Default `vehicles.max_speed` of a glider, m/s (real gliders: 0.2–0.4 m/s through water).
pub const DEFAULT_MAX_SPEED: f64 = 0.3;
/// Default `vehicles.max_accel` of a glider, m/s²: from rest to 0.3 m/s in 30 s.
pub const DEFAULT_MAX_ACCEL: f64 = 0.01;
/// Default `vehicles.max_turn_rate` of a glider, rad/s (≈ 5.7°/s: a 3 m turn radius at
/// 0.3 m/s).
pub const DEFAULT_MAX_TURN_RATE: f64 = 0.1;

/// `current.kind`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CurrentKind {
    /// Still water.
    #[default]
    None,
    /// The same `velocity` everywhere.
    Uniform,
    /// A Gaussian vortex about `center`: speed `strength`·(r/width)·exp(½ − r²/(2 width²)),
    /// largest (= `strength`) at r = `width`; counter-clockwise for `strength` > 0. Plus
    /// `velocity` when given.
    Eddy,
    /// A shear: `velocity` + `strength`·((y − center_y)/width) along x, a current that
    /// grows across y.
    Shear,
    /// Gridded u, v from a file (`current.file`, `current.u`, `current.v`), read by the
    /// the slot is kept for it).
    Grid,
}

impl CurrentKind {
    /// The name as the mission file writes it.
    pub fn as_str(self) -> &'static str {
        match self {
            CurrentKind::None => "none",
            CurrentKind::Uniform => "uniform",
            CurrentKind::Eddy => "eddy",
            CurrentKind::Shear => "shear",
            CurrentKind::Grid => "grid",
        }
    }
}

/// `[current]`: the water's velocity, which advects every vehicle.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CurrentSection {
    /// `"none"` (default) | `"uniform"` | `"eddy"` | `"shear"` | `"grid"`.
    pub kind: CurrentKind,
    /// Length unit/s, `dim` components: the uniform current, or the background of an eddy
    /// or a shear (empty = none).
    pub velocity: Vec<f64>,
    /// Centre of the eddy / reference line of the shear, length unit, `dim` components.
    pub center: Vec<f64>,
    /// Length unit, > 0 (eddy, shear): radius of the strongest eddy current / the distance
    /// over which the shear adds `strength`.
    pub width: f64,
    /// Length unit/s (eddy, shear).
    pub strength: f64,
    /// s, ≥ 0: when > 0 the whole current is multiplied by cos(2π t / period) (a tide);
    /// 0 = steady.
    pub period: f64,
    /// Grid: the file of the current (NetCDF or NumPy, as `field.file`), relative to the
    /// mission file; its axes are found and projected as the field's (`field.geographic`,
    /// `field.origin`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub file: Option<String>,
    /// Grid: the variable of the eastward / x velocity (length unit/s; default `"u"`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub u: Option<String>,
    /// Grid: the variable of the northward / y velocity (length unit/s; default `"v"`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub v: Option<String>,
    /// The loaded u and v grids (kind = "grid"; not a key): read once with the mission.
    #[serde(skip)]
    pub grid: crate::grid::CurrentGridSlot,
}

impl CurrentSection {
    /// True for still water (the default: the section is not written then).
    pub fn is_none(&self) -> bool {
        self.kind == CurrentKind::None
    }
}

/// `land.kind`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LandKind {
    /// No land.
    #[default]
    None,
    /// A straight coast: land where (x − point)·normal < 0 (`normal` points to the sea).
    Coast,
    /// A round island of `radius` about `center`.
    Island,
}

impl LandKind {
    /// The name as the mission file writes it.
    pub fn as_str(self) -> &'static str {
        match self {
            LandKind::None => "none",
            LandKind::Coast => "coast",
            LandKind::Island => "island",
        }
    }
}

/// `[land]`: analytic land no vehicle and no body centre enters (beyond the paper).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LandSection {
    /// `"none"` (default) | `"coast"` | `"island"`.
    pub kind: LandKind,
    /// Coast: a point of the coastline, length unit, `dim` components.
    pub point: Vec<f64>,
    /// Coast: the normal pointing to the sea, `dim` components (any length > 0).
    pub normal: Vec<f64>,
    /// Island: its centre, length unit, `dim` components.
    pub center: Vec<f64>,
    /// Island: its radius, length unit, > 0.
    pub radius: f64,
    /// Length unit, > 0: a vehicle closer than this to land is pushed away
    /// (`vbap_math::vehicle::land::repulsion`); absent = formation.radius / 2.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub avoid_distance: Option<f64>,
    /// Length unit/s², ≥ 0: the push at the coast itself; absent = 2·formation.alpha /
    /// formation.radius (twice the strongest pull of a leader at the design spacing, about).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub avoid_gain: Option<f64>,
}

impl LandSection {
    /// True without land (the default: the section is not written then).
    pub fn is_none(&self) -> bool {
        self.kind == LandKind::None
    }
}

impl super::Mission {
    /// True when the vehicles move beyond the paper's ideal vehicle: a glider model, a
    /// current or land. Such a run writes the motion columns of `vehicles.csv`.
    pub fn moves_beyond_ideal(&self) -> bool {
        !self.vehicles.model.is_ideal()
            || !self.current.is_none()
            || !self.land.is_none()
            || self.land().is_some()
    }
}
