//! The field server: owns the environment and answers sensor reads.
//!
//! [`World::sample`] is pure: the true field value plus the sensor noise keyed by
//! (seed, vehicle, tick), exactly what the in-process simulator draws. [`Sensors`] adds the
//! mission's sensor faults. [`run`] serves the coordinator's batched reads over iceoryx2
//! request-response.

pub mod run;

use vbap_math::Vec3;
use vbap_mission::config::Mission;
use vbap_mission::faults::{FaultPlan, SensorState};
use vbap_mission::field::{measure, Field};

/// The environment of a mission.
#[derive(Clone, Debug)]
pub struct World {
    field: Field,
    seed: u64,
    noise_std: f64,
}

impl World {
    /// The world of `mission`.
    pub fn new(mission: &Mission) -> Self {
        Self {
            field: mission.field(),
            seed: mission.mission.seed,
            noise_std: mission.field.noise_std,
        }
    }

    /// The reading of vehicle `vehicle`'s sensor at `position`, tick `tick`, time `t` (s):
    /// T(p, t) + N(0, σ_M²), the noise keyed by (seed, vehicle, tick). `None` for a
    /// non-finite position.
    pub fn sample(&self, vehicle: u32, tick: u64, t: f64, position: &Vec3) -> Option<f64> {
        if !position.iter().all(|v| v.is_finite()) || !t.is_finite() {
            return None;
        }
        let v = measure(
            &self.field,
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
        Self {
            world: World::new(mission),
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
