//! The field server: owns the environment and answers sensor reads.
//!
//! [`World::sample`] is pure: the true field value plus the sensor noise keyed by
//! (seed, vehicle, tick), exactly what the in-process simulator draws. [`Sensors`] adds the
//! mission's sensor faults. [`run`] serves the coordinator's batched reads over iceoryx2
//! request-response.

pub mod cli;
pub mod run;
#[cfg(test)]
mod tests;

use std::sync::Arc;

use vbap_math::Vec3;
use vbap_mission::config::Mission;
use vbap_mission::faults::{FaultPlan, SensorState};
use vbap_mission::field::{measure, ScalarField};

/// The environment of a mission.
#[derive(Clone, Debug)]
pub struct World {
    field: Arc<dyn ScalarField>,
    seed: u64,
    noise_std: f64,
    /// Land of a gridded field: no reading is taken there.
    land: Option<Arc<dyn vbap_mission::land::LandMask>>,
}

impl World {
    /// The world of `mission`: the field of its `[field]` section.
    pub fn new(mission: &Mission) -> Self {
        Self::with_field(mission, Arc::new(mission.field()))
    }

    /// The world of `mission` over `field` instead of the mission's own (a user's field;
    /// the seed and the noise σ_M are still the mission's).
    pub fn with_field(mission: &Mission, field: Arc<dyn ScalarField>) -> Self {
        Self {
            field,
            seed: mission.mission.seed,
            noise_std: mission.field.noise_std,
            land: mission.land(),
        }
    }

    /// The field sampled.
    pub fn field(&self) -> &Arc<dyn ScalarField> {
        &self.field
    }

    /// The reading of vehicle `vehicle`'s sensor at `position`, tick `tick`, time `t` (s):
    /// T(p, t) + N(0, σ_M²), the noise keyed by (seed, vehicle, tick). `None` for a
    /// non-finite position, and on land (a gridded field's land or missing data, or outside
    /// its grid): a reading there is impossible, not zero.
    pub fn sample(&self, vehicle: u32, tick: u64, t: f64, position: &Vec3) -> Option<f64> {
        if !position.iter().all(|v| v.is_finite()) || !t.is_finite() {
            return None;
        }
        if self.land.as_ref().is_some_and(|l| l.is_land(position)) {
            return None;
        }
        let v = measure(
            self.field.as_ref(),
            position,
            t,
            self.seed,
            vehicle,
            tick,
            self.noise_std,
        );
        v.is_finite().then_some(v)
    }
}

/// The sensors of a mission: the field, the noise and the scheduled sensor faults.
pub struct Sensors {
    world: World,
    plan: FaultPlan,
    memory: Vec<SensorState>,
}

impl Sensors {
    /// The sensors of `mission`'s vehicles.
    pub fn new(mission: &Mission) -> Self {
        Self::in_world(mission, World::new(mission))
    }

    /// The sensors of `mission`'s vehicles in `world` (e.g. [`World::with_field`]).
    pub fn in_world(mission: &Mission, world: World) -> Self {
        Self {
            world,
            plan: FaultPlan::new(mission),
            memory: vec![SensorState::default(); mission.vehicles.count],
        }
    }

    /// What vehicle `v`'s sensor reports at tick `k` (time `t`, s) at `position`; None for
    /// an unknown vehicle or a non-finite position.
    pub fn read(&mut self, v: u32, k: u64, t: f64, position: &Vec3) -> Option<f64> {
        let memory = self.memory.get_mut(v as usize)?;
        let raw = self.world.sample(v, k, t, position)?;
        Some(self.plan.sensor(v, t, raw, memory))
    }
}
