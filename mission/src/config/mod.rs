//! The mission file (TOML), parsed and validated (docs/ARCHITECTURE.md §10).
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
//!
//! Files: [`error`](ConfigError), [`pace`](Pace), the sections and their defaults
//! (`sections.rs`, `failure_sections.rs`), reading and parsing (`parse.rs`), the value
//! checks (`validate/`, one file per group of sections), the time step against the
//! formation's stiffness (`stiffness.rs`) and numbers as TOML writes them (`toml_text.rs`).

mod acoustic;
mod control;
mod envelope;
mod error;
mod failure_sections;
mod motion;
mod pace;
mod parse;
mod sections;
mod sets;
mod stiffness;
pub use envelope::MAX_ENVELOPE_VEHICLES;
mod toml_text;
mod trail;
mod validate;

#[cfg(test)]
mod tests;

pub use acoustic::{AcousticSchedule, AcousticSection};
pub use control::{ControlSection, CurvatureSource, LawKind};
pub use error::ConfigError;
pub use failure_sections::{
    FaultConfig, FaultKind, IridiumSection, LinksSection, Oversize, RestartPolicy, RestartSection,
    SurfacingPhase,
};
pub use motion::DEFAULT_DIVE_RATE;
pub use motion::{
    CurrentKind, CurrentSection, LandKind, LandSection, VehicleModelKind, DEFAULT_MAX_ACCEL,
    DEFAULT_MAX_SPEED, DEFAULT_MAX_TURN_RATE,
};
pub use pace::Pace;
pub use parse::read_mission_file;
pub use sections::{
    BodySection, BumpConfig, EstimatorSection, FieldConfig, FieldKind, FormationSection, Goal,
    MissionSection, VehiclesSection,
};
pub use sets::KeySet;
pub use stiffness::Stiffness;
pub use trail::Trail;
pub use validate::MAX_ACOUSTIC_VEHICLES;

use serde::{Deserialize, Serialize};
use vbap_math::{Mat3, Vec3};

/// Most vehicles a mission may have (iceoryx2 resources and O(N²) potentials stay bounded).
pub const MAX_VEHICLES: usize = 1024;
/// Most ticks (duration / dt) a mission may have.
pub const MAX_TICKS: f64 = 10_000_000.0;
/// Longest mission name (it prefixes every service name and the run directory).
pub const MAX_NAME_LEN: usize = 32;

/// `<name><suffix>`, the name cut so that the whole fits in [`MAX_NAME_LEN`]: the mission
/// name of one run of a study (`_s<seed>` of a batch, `_c<index>` of a chaos campaign).
pub fn suffixed_name(name: &str, suffix: &str) -> String {
    let keep = MAX_NAME_LEN.saturating_sub(suffix.len()).min(name.len());
    format!("{}{suffix}", &name[..keep])
}
/// Most bumps of a `gaussian_sum` field.
pub const MAX_BUMPS: usize = 64;
/// Largest mission file read, bytes (1 MiB): a longer file (or `/dev/zero`) is refused after
/// reading at most one byte more.
pub const MAX_FILE_BYTES: u64 = 1 << 20;
/// ω·dt and damping·dt above this make the semi-implicit Euler integration of (II.1)
/// unstable: refused unless `mission.allow_unstable = true`.
pub const UNSTABLE_STEP: f64 = 2.0;

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
    /// `[control]`.
    pub control: ControlSection,
    /// `[current]` (beyond the paper; not written when none).
    #[serde(skip_serializing_if = "CurrentSection::is_none")]
    pub current: CurrentSection,
    /// `[land]` (beyond the paper; not written when none).
    #[serde(skip_serializing_if = "LandSection::is_none")]
    pub land: LandSection,
    /// `[acoustic]`: acoustic modems between the vehicles (beyond the paper; absent: none).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub acoustic: Option<AcousticSection>,
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
            && self.control == other.control
            && self.current == other.current
            && self.land == other.land
            && self.acoustic == other.acoustic
            && self.faults == other.faults
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

impl Mission {
    /// The resolved mission as TOML, every default filled in; it parses back to an equal
    /// mission.
    ///
    /// # Panics
    /// If the mission is not valid (a seed above 2⁶³ − 1 cannot be written as TOML).
    pub fn to_toml_string(&self) -> String {
        let body = toml_text::short_floats(
            &toml::to_string(self).expect("a validated mission serialises to TOML"),
        );
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

    /// The dimension of the formation, the virtual body and the gradient estimate: the
    /// mission's, except for diving gliders (`vehicles.dive_depth` in 3-D), whose formation
    /// is horizontal (2): z follows the dive profile, which (II.1) cannot move, and the
    /// readings of one tick are all at the dive's depth, so the z column of Lemma 5.1's C
    /// is constant and only the horizontal gradient is observable (beyond the paper, whose
    /// vehicles move freely in z).
    pub fn formation_dim(&self) -> usize {
        if self.diving() {
            2
        } else {
            self.mission.dim
        }
    }

    /// The initial formation design of the mission (before any loss): `design_regular`
    /// of `vehicles.count` in [`Mission::formation_dim`], `formation.radius`, with
    /// `formation.alpha` for both potentials. What the vehicles start in, and what the
    /// validation's stability, envelope and command-size checks judge.
    pub fn formation_design(
        &self,
    ) -> Result<vbap_math::formation::FormationDesign, vbap_math::formation::FormationError> {
        let fo = &self.formation;
        vbap_math::formation::design_regular(
            self.vehicles.count,
            self.formation_dim(),
            fo.radius,
            fo.alpha,
            fo.alpha,
        )
    }

    /// True when the vehicles fly a sawtooth dive (`vehicles.dive_depth`, a 3-D mission): a
    /// horizontal formation over a 3-D field ([`Mission::formation_dim`]).
    pub fn diving(&self) -> bool {
        self.vehicles.dive_depth.is_some() && self.mission.dim == 3
    }

    /// `vehicles.start` as a position (z = 0 in 2-D and for a horizontal formation).
    pub fn start_vec(&self) -> Vec3 {
        let mut out = Vec3::zeros();
        for (i, x) in self
            .vehicles
            .start
            .iter()
            .take(self.formation_dim().min(3))
            .enumerate()
        {
            out[i] = *x;
        }
        out
    }

    /// H of (V.6): `formation.hessian_guess`, or the identity; only the dim×dim block is
    /// non-zero (in 2-D, and for a horizontal formation, the z row and column are zero).
    pub fn hessian_guess_mat(&self) -> Mat3 {
        let dim = self.formation_dim().min(3);
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
}
