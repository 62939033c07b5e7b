//! A user's own parts for the simulator and the process set: [`Plugins`] (a field, a
//! control law). A leaf: it uses no other module of this crate (`vbap_cli::custom` runs
//! them).

use std::sync::Arc;

use vbap_math::law::ControlLaw;
use vbap_mission::config::Mission;
use vbap_mission::field::ScalarField;

/// A user's own parts; `None`: the shipped one (the mission's `[field]`, the mission's
/// `control.law`).
#[derive(Clone, Debug, Default)]
pub struct Plugins {
    /// The field the sensors sample and the run is judged by.
    pub field: Option<Arc<dyn ScalarField>>,
    /// The vehicles' control law.
    pub law: Option<Arc<dyn ControlLaw>>,
}

impl Plugins {
    /// These plugins with the field `field`.
    pub fn with_field(mut self, field: impl ScalarField + 'static) -> Self {
        self.field = Some(Arc::new(field));
        self
    }

    /// These plugins with the control law `law`.
    pub fn with_law(mut self, law: impl ControlLaw + 'static) -> Self {
        self.law = Some(Arc::new(law));
        self
    }

    /// The field of `mission` under these plugins.
    pub fn field_of(&self, mission: &Mission) -> Arc<dyn ScalarField> {
        self.field
            .clone()
            .unwrap_or_else(|| Arc::new(mission.field()))
    }

    /// The control law of `mission` under these plugins: the user's own, or the mission's
    /// (`control.law`: the paper's or the robust law, `vehicle_agent::mission_law`).
    pub fn law_of(&self, mission: &Mission) -> Arc<dyn ControlLaw> {
        self.law
            .clone()
            .unwrap_or_else(|| vehicle_agent::mission_law(mission))
    }
}
