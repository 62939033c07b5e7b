//! The pass/fail criteria of the mission file's `[batch]` table.

use serde::{Deserialize, Serialize};
use vbap_mission::config::Mission;

use vbap_ipc::process::InvalidInput;

/// The pass/fail criteria of the `[batch]` table, each optional.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Criteria {
    /// Smallest acceptable fraction of converged seeds, in [0, 1].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min_convergence_rate: Option<f64>,
    /// Largest acceptable final distance to the optimum of any completed run (length
    /// unit), ≥ 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_final_distance: Option<f64>,
    /// Largest acceptable time to converge of any converged run, s, ≥ 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_time_to_converge: Option<f64>,
}

/// The criteria keys of the `[batch]` table.
pub const CRITERIA_KEYS: [&str; 3] = [
    "min_convergence_rate",
    "max_final_distance",
    "max_time_to_converge",
];

/// The `[batch]` key of the sweep table (read by [`super::sweep::Sweep::of`]).
pub const SWEEP_KEY: &str = "sweep";

impl Criteria {
    /// The criteria of `mission`'s `[batch]` table (none without one), checked: every key
    /// known, every value a finite number in its range. An error names the mission file and
    /// the key (`batch.<key>`).
    pub fn of(mission: &Mission) -> Result<Criteria, InvalidInput> {
        let origin = &mission.origin;
        let Some(table) = &mission.batch else {
            return Ok(Criteria::default());
        };
        if let Some(key) = table
            .keys()
            .find(|k| !CRITERIA_KEYS.contains(&k.as_str()) && k.as_str() != SWEEP_KEY)
        {
            return Err(InvalidInput(format!(
                "{origin}: batch.{key}: unknown key; known: {}, {SWEEP_KEY}",
                CRITERIA_KEYS.join(", ")
            )));
        }
        let mut table = table.clone();
        table.remove(SWEEP_KEY);
        // toml names the key of a value that is no number ("... in `max_final_distance`").
        let criteria: Criteria =
            toml::Value::Table(table)
                .try_into()
                .map_err(|e: toml::de::Error| {
                    let why = e.to_string().replace('\n', " ");
                    InvalidInput(format!("{origin}: [batch]: {}", why.trim()))
                })?;
        criteria.check(origin)?;
        Ok(criteria)
    }

    /// Every given value finite and in its range.
    fn check(&self, origin: &str) -> Result<(), InvalidInput> {
        for (key, value) in [
            ("min_convergence_rate", self.min_convergence_rate),
            ("max_final_distance", self.max_final_distance),
            ("max_time_to_converge", self.max_time_to_converge),
        ] {
            let Some(v) = value else { continue };
            let why = if !v.is_finite() {
                "must be a finite number"
            } else if key == "min_convergence_rate" && !(0.0..=1.0).contains(&v) {
                "must be between 0 and 1"
            } else if v < 0.0 {
                "must be >= 0"
            } else {
                continue;
            };
            return Err(InvalidInput(format!("{origin}: batch.{key} = {v}: {why}")));
        }
        Ok(())
    }
}
